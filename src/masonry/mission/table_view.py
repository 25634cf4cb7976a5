"""The reservation table folded from its ``reservation`` events (pure): what ``masonry replay --at T`` prints and
the live page draws under its Gantt chart (a per-UAV timeline of reserved windows).

:class:`TableView` keeps every reservation by its ``id``: those held (their window not over, not released) and, for
the timeline, the latest :data:`HISTORY` of those whose window ended or that were released; and the holds on take-offs (``hold``
events: the operator's pause and recall, the wind limit's groundings), every one made. The events come from
:mod:`masonry.mission.table_events` (``--airspace table``); a mission without them has an empty view.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, replace

from masonry.mission.events import MissionEvent

#: Reservations over (ended or released) the view keeps for the page's timeline, the latest.
HISTORY = 2000


@dataclass(frozen=True)
class Held:
    """One reservation as the events tell it: ``t1_s`` is ``math.inf`` while open-ended."""

    id: int
    uav: str
    purpose: str
    task: str
    t0_s: float
    t1_s: float
    volume: tuple[float, ...]  # [ax, ay, bx, by, z0, z1, radius]
    moves: int = 0  # how often its window moved
    released_s: float | None = None  # when it was released (None: it was not)

    def where(self) -> str:
        """Its volume in a few words: a column over a point, or a leg at an altitude."""
        ax, ay, bx, by, z0, z1 = self.volume[:6]
        z = f"at {z0:.2f} m" if abs(z1 - z0) < 1e-9 else f"z {z0:.2f}-{z1:.2f} m"
        if math.hypot(bx - ax, by - ay) < 1e-9:
            return f"column at ({ax:.2f}, {ay:.2f}) {z}"
        return f"along ({ax:.2f}, {ay:.2f})->({bx:.2f}, {by:.2f}) {z}"

    def line(self) -> str:
        """One line of ``masonry replay --at``."""
        end = "open-ended" if math.isinf(self.t1_s) else f"{self.t1_s:8.1f} s"
        moved = f"  moved {self.moves}x" if self.moves else ""
        return (
            f"    {self.uav:<12} {self.purpose:<8} {self.task or '-':<6} {self.t0_s:8.1f} s -> {end:<10}  "
            f"{self.where()}{moved}"
        )

    def row(self) -> dict[str, object]:
        """Its window for the page (``t1_s`` None: open-ended)."""
        return {
            "id": self.id,
            "uav": self.uav,
            "purpose": self.purpose,
            "task": self.task,
            "t0_s": self.t0_s,
            "t1_s": None if math.isinf(self.t1_s) else self.t1_s,
            "released": self.released_s is not None,
        }


@dataclass(frozen=True)
class HeldDown:
    """One hold on take-offs as its events tell it: ``uavs`` empty holds every UAV; ``t1_s`` ``math.inf`` until
    lifted."""

    id: int
    cause: str
    uavs: tuple[str, ...]
    t0_s: float
    t1_s: float
    released_s: float | None = None  # when it was lifted (None: it was not)

    def line(self) -> str:
        """One line of ``masonry replay --at``."""
        end = "until lifted" if math.isinf(self.t1_s) else f"{self.t1_s:8.1f} s"
        who = ", ".join(self.uavs) or "every UAV"
        return f"    {self.cause:<12} holds {who} on the ground {self.t0_s:8.1f} s -> {end}"

    def row(self) -> dict[str, object]:
        """Its window for the page (``uavs`` empty: every UAV; ``t1_s`` None: until lifted)."""
        return {
            "id": self.id,
            "cause": self.cause,
            "uavs": list(self.uavs),
            "t0_s": self.t0_s,
            "t1_s": None if math.isinf(self.t1_s) else self.t1_s,
            "released": self.released_s is not None,
        }


def _float(value: object, default: float) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else default


class TableView:
    """The reservation table after the ``reservation`` events it has been given (:meth:`fold`)."""

    def __init__(self) -> None:
        self.held: dict[int, Held] = {}
        self.over: deque[Held] = deque(maxlen=HISTORY)
        self.seen = False  # a reservation event was folded (the table exists: --airspace table)
        self.holds: dict[int, HeldDown] = {}  # every hold made, by id (few: one per command or wind front)

    def fold(self, e: MissionEvent) -> None:
        """Fold one ``reservation`` or ``hold`` event in (other kinds are not this view's)."""
        if e.kind == "hold":
            self._fold_hold(e)
            return
        if e.kind != "reservation":
            return
        self.seen = True
        f = e.fields
        rid = int(_float(f.get("id"), 0.0))
        t1 = f.get("t1_s")
        now = Held(
            rid,
            str(e.uav or ""),
            str(f.get("purpose", "")),
            str(e.task_id or ""),
            _float(f.get("t0_s"), e.time_s),
            math.inf if t1 is None else _float(t1, math.inf),
            tuple(_float(v, 0.0) for v in f.get("volume") or ()),
        )
        before = self.held.pop(rid, None)
        change = f.get("change")
        if change == "moved" and before is not None:
            self.held[rid] = replace(now, moves=before.moves + 1)
        elif change == "released":
            self.over.append(replace(now, moves=before.moves if before else 0, released_s=e.time_s))
        else:
            self.held[rid] = now
        self._end(e.time_s)

    def _fold_hold(self, e: MissionEvent) -> None:
        self.seen = True
        f = e.fields
        t1 = f.get("t1_s")
        uavs = f.get("uavs")
        hold = HeldDown(
            int(_float(f.get("id"), 0.0)),
            str(f.get("cause", "")),
            tuple(str(u) for u in uavs) if isinstance(uavs, list) else (),
            _float(f.get("t0_s"), e.time_s),
            math.inf if t1 is None else _float(t1, math.inf),
            e.time_s if f.get("change") == "released" else None,
        )
        self.holds[hold.id] = hold

    def holds_at(self, time_s: float) -> list[HeldDown]:
        """The holds standing at ``time_s`` (begun, not over), in the order made."""
        return [h for _i, h in sorted(self.holds.items()) if h.t0_s <= time_s < h.t1_s]

    def _end(self, time_s: float) -> None:
        """Windows over by ``time_s`` leave the table (for the timeline's history)."""
        for rid in [rid for rid, h in self.held.items() if h.t1_s <= time_s]:
            self.over.append(self.held.pop(rid))

    def at(self, time_s: float) -> list[Held]:
        """The reservations held at ``time_s`` (the window not over), by UAV and start."""
        return sorted((h for h in self.held.values() if h.t1_s > time_s), key=lambda h: (h.uav, h.t0_s, h.id))

    def rows(self) -> list[dict[str, object]]:
        """Every reservation kept (over and held), by start: the page's timeline."""
        every: Sequence[Held] = [*self.over, *self.held.values()]
        return [h.row() for h in sorted(every, key=lambda h: (h.t0_s, h.id))]

    def hold_rows(self) -> list[dict[str, object]]:
        """Every hold made, in that order: the page's timeline draws them over the rows of the UAVs they hold."""
        return [h.row() for _i, h in sorted(self.holds.items())]

    def lines(self, time_s: float) -> list[str]:
        """The table at ``time_s`` as text (``masonry replay --at``)."""
        held = self.at(time_s)
        out = [f"  reservation table: {len(held)} held (current and planned windows)"]
        out.extend(h.line() for h in held)
        holds = self.holds_at(time_s)
        if holds:
            out.append(f"  holds on take-offs: {len(holds)}")
            out.extend(h.line() for h in holds)
        return out


__all__ = ["HISTORY", "Held", "HeldDown", "TableView"]
