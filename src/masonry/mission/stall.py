"""The progress watchdog of mission control: a mission that stops moving says so, and says who waits for whom.

:class:`StallWatch` is told, every tick, a *signature* of everything that counts as progress (tasks done, flights
and hold flights granted, each UAV's reported state, UAVs lost); when it has not changed for ``timeout_s`` the
mission is stalled. :class:`Stall` is what mission control then reports (``stall`` in the JSON report): for every
UAV that has a task or waits for the airspace, what it asked for and which other UAVs' reservations are in the
way (the wait-for graph, from :meth:`masonry.mission.airspace.ColumnClearance.blockers`).

Pure: no I/O, no clock (times are passed in).
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from dataclasses import dataclass
from typing import Any

from masonry.errors import InvalidArgument

Vec3 = tuple[float, float, float]

#: A mission with no progress this long (simulated or wall seconds of mission time) is stalled. The longest
#: step of a healthy mission with nothing else changing is a battery swap or a long transit (tens of seconds).
DEFAULT_STALL_TIMEOUT_S = 300.0


@dataclass(frozen=True)
class Blocker:
    """Another UAV in the way, and what of it: the kind of its reserved volume (``pad``, ``zone``, ``climb``,
    ``leg``, ``hover``) or ``earlier-request`` (it asked first for a site within the wait radius and its turn
    comes first: :func:`masonry.mission.airspace_requests.queued_near`)."""

    uav: str
    holds: str

    def to_dict(self) -> dict[str, str]:
        return {"uav": self.uav, "holds": self.holds}


@dataclass(frozen=True)
class Wait:
    """One UAV at the moment of the stall: its state, its task, its airspace phase, and what blocks it."""

    uav: str
    state: str
    task: str | None
    airspace: str
    asked_for_m: Vec3 | None
    blocked_by: tuple[Blocker, ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "uav": self.uav,
            "state": self.state,
            "task": self.task,
            "airspace": self.airspace,
            "asked_for_m": None
            if self.asked_for_m is None
            else [round(float(v), 3) for v in self.asked_for_m],
            "blocked_by": [b.to_dict() for b in self.blocked_by],
        }

    def text(self) -> str:
        what = f"{self.task} " if self.task else ""
        if self.blocked_by:
            by = ", ".join(f"{b.uav} ({b.holds})" for b in self.blocked_by)
            return f"{self.uav} [{what}{self.state}, {self.airspace}] waits for {by}"
        return f"{self.uav} [{what}{self.state}, {self.airspace}]"


@dataclass(frozen=True)
class Stall:
    """No progress from ``since_s`` to ``at_s`` (at least ``timeout_s``): who waited for whom then."""

    at_s: float
    since_s: float
    timeout_s: float
    waits: tuple[Wait, ...]
    available: tuple[str, ...] = ()  # tasks ready but not assigned

    def to_dict(self) -> dict[str, Any]:
        return {
            "at_s": round(self.at_s, 2),
            "since_s": round(self.since_s, 2),
            "timeout_s": self.timeout_s,
            "waits": [w.to_dict() for w in self.waits],
            "available": list(self.available),
        }

    def line(self) -> str:
        """One line for logs and the summary."""
        waits = "; ".join(w.text() for w in self.waits) or "no UAV has a task"
        return (
            f"stalled: no progress for {self.at_s - self.since_s:.0f} s (since {self.since_s:.1f} s): {waits}"
        )


class StallWatch:
    """Says when the progress signature has not changed for ``timeout_s`` (None or 0: never), counted from the
    later of the last change and the end of the last wait mission control knew the end of.

    A wait with a known end is no stall (issue 27): a lost UAV's rejoin window still open, the airspace a lost
    UAV's way home holds until a known time, an adhesive curing. Mission control passes the latest such end
    still ahead (``known_until_s``); the timeout counts only from when none is left, so a UAV that rejoins 400 s
    after its loss in a 750 s window is waited for, and a mission stuck with nothing on the clock still stops
    ``timeout_s`` after its last progress or its last known wait, whichever came later.
    """

    def __init__(self, timeout_s: float | None = DEFAULT_STALL_TIMEOUT_S) -> None:
        if timeout_s is not None and not (timeout_s >= 0.0 and math.isfinite(timeout_s)):
            raise InvalidArgument(f"stall timeout must be a finite number >= 0 s, got {timeout_s!r}")
        self.timeout_s = None if not timeout_s else float(timeout_s)
        #: the last progress (the signature changed)
        self.since_s: float | None = None
        #: where the count towards ``timeout_s`` starts: the last progress, or the last tick a known wait was open
        self.counting_from_s: float | None = None
        self._last: Hashable = None

    def observe(self, now_s: float, signature: Hashable, known_until_s: float | None = None) -> bool:
        """Record the signature at ``now_s``; True when it has not changed for ``timeout_s`` with no wait of a
        known end open meanwhile (``known_until_s``: the latest end of one, None: none)."""
        if self.since_s is None or signature != self._last:
            self.since_s, self.counting_from_s, self._last = now_s, now_s, signature
            return False
        if known_until_s is not None and known_until_s >= now_s:
            self.counting_from_s = now_s  # waiting for something on the clock: not stalled
            return False
        assert self.counting_from_s is not None
        return self.timeout_s is not None and now_s - self.counting_from_s >= self.timeout_s


def stall_of(
    now_s: float,
    since_s: float,
    timeout_s: float,
    uavs: Sequence[tuple[str, str]],
    dispatcher: Any,
    columns: Any,
) -> Stall:
    """The stall at ``now_s``: for every UAV ``(name, reported state)`` still in the mission, its task (from the
    dispatcher), its airspace phase, what it asked for and who blocks it (from the airspace)."""
    waits = tuple(
        Wait(
            name,
            state,
            dispatcher.task_of(name),
            columns.phase(name).value,
            columns.asked_for(name),
            tuple(Blocker(other, kind) for other, kind in columns.blockers(name)),
        )
        for name, state in uavs
    )
    return Stall(now_s, since_s, timeout_s, waits, tuple(dispatcher.available))


__all__ = ["DEFAULT_STALL_TIMEOUT_S", "Blocker", "Stall", "StallWatch", "Wait", "stall_of"]
