"""The operator's pause and recall and the wind limit as constraints on the table: holds on take-offs.

A :class:`Hold` is no one's volume: it says that no flight of its UAVs (all of them when it names none) may leave a
ground stay (take off from a pad or a parking spot) within its window. ``decide`` moves such a flight's start past
every hold of its UAV, and a flight that could start only inside an open-ended hold waits, the hold named
(``Wait.held_by``, its ``cause``: ``operator`` or ``wind``). A UAV in the air is never held: it finishes its task and
flies home, where it stays. Mission control keeps the table's holds what the operator and the wind limit say
(:func:`with_holds`, ``masonry.mission.table_holds``). Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

from masonry.errors import InvalidArgument
from masonry.reservation.table import Table

#: What holds a UAV on the ground: the operator (a pause, a recall, an abort) or the wind (its limit).
HOLD_CAUSES = ("operator", "wind")


@dataclass(frozen=True)
class Hold:
    """No flight of ``uavs`` (empty: every UAV) takes off within ``[t0_s, t1_s)`` (``math.inf``: until lifted)."""

    cause: str
    t0_s: float
    t1_s: float = math.inf
    uavs: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        if self.cause not in HOLD_CAUSES:
            raise InvalidArgument(
                f"a hold's cause must be one of {', '.join(HOLD_CAUSES)}, got {self.cause!r}"
            )
        if not (math.isfinite(self.t0_s) and self.t1_s >= self.t0_s):
            raise InvalidArgument(
                f"a hold's window must be finite-started and not end before it starts: {self}"
            )

    def binds(self, uav: str) -> bool:
        """``uav`` is one it holds."""
        return not self.uavs or uav in self.uavs

    def covers(self, uav: str, t_s: float) -> bool:
        """``uav`` may not take off at ``t_s``."""
        return self.binds(uav) and self.t0_s <= t_s < self.t1_s

    def until(self, t1_s: float) -> Hold:
        """The same hold, ending at ``t1_s`` (lifted then)."""
        return replace(self, t1_s=max(self.t0_s, t1_s))

    def describe(self) -> str:
        who = ", ".join(sorted(self.uavs)) or "every UAV"
        end = "until lifted" if math.isinf(self.t1_s) else f"until {self.t1_s:.1f} s"
        return f"{self.cause} holds {who} on the ground from {self.t0_s:.1f} s {end}"


def held_until(holds: Sequence[Hold], uav: str, t_s: float) -> tuple[float, tuple[Hold, ...]]:
    """The earliest time ``>= t_s`` at which no hold of ``holds`` keeps ``uav`` on the ground (``math.inf``: an
    open-ended one), and the holds that pushed it there (empty: it may take off at ``t_s``)."""
    pushed: list[Hold] = []
    t = t_s
    while True:
        covering = [h for h in holds if h.covers(uav, t)]
        if not covering:
            return t, tuple(pushed)
        pushed.extend(h for h in covering if h not in pushed)
        t = max(h.t1_s for h in covering)
        if math.isinf(t):
            return t, tuple(pushed)


def with_holds(table: Table, wanted: Iterable[tuple[str, frozenset[str]]], now_s: float) -> Table:
    """``table`` with its open-ended holds those of ``wanted`` (cause, UAVs) from ``now_s``: a hold no longer wanted
    ends at ``now_s``, a new one starts then; holds that ended by ``now_s`` are dropped. The same table when nothing
    changed."""
    want = set(wanted)
    open_now = {(h.cause, h.uavs) for h in table.holds if math.isinf(h.t1_s)}
    if open_now == want:
        return table
    kept = [h if (h.cause, h.uavs) in want or not math.isinf(h.t1_s) else h.until(now_s) for h in table.holds]
    new = [Hold(cause, now_s, math.inf, uavs) for cause, uavs in sorted(want - open_now, key=_order)]
    return replace(table, holds=tuple(h for h in (*kept, *new) if h.t1_s > now_s))


def _order(key: tuple[str, frozenset[str]]) -> tuple[str, tuple[str, ...]]:
    return key[0], tuple(sorted(key[1]))


__all__ = ["HOLD_CAUSES", "Hold", "held_until", "with_holds"]
