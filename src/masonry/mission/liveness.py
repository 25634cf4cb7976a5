"""Who mission control hears: one :class:`Liveness` per UAV and the timeouts that move it (issue 27 §2).

A UAV starts :attr:`Liveness.SILENT` (not heard yet) and is :attr:`Liveness.HEARD` from its first message. Quiet
past ``heartbeat_timeout_s`` it is declared :attr:`Liveness.LOST` (its task goes back to the pool); one last heard
finishing its work (its facts say ``finishing``) with a task first gets ``rejoin_timeout_s`` more, :attr:`Liveness.SILENT`
meanwhile. A lost UAV heard again with no task is :attr:`Liveness.REJOINED` (back in the mission); one that says
it is out of service is :attr:`Liveness.OUT_OF_SERVICE` for the rest of the mission. ``UavLink.lost`` and
``UavLink.status`` (the report's word) are read from this one value.

The tracker decides, mission control acts: :meth:`LivenessTracker.sweep` says which UAVs fell silent for too long
and whose reserved way home ran out, in the order mission control handles them.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from masonry.mission.records import Liveness, UavLink
from masonry.mission.uav_facts import MAY_FINISH_STATES
from masonry.ports import LAST_RESORT_S

__all__ = [
    "MAY_FINISH_STATES",
    "WAY_HOME_MARGIN_S",
    "Lapse",
    "Liveness",
    "LivenessTracker",
    "Timeouts",
    "way_home_s",
]

#: Added to the time a silent UAV's way home takes before mission control frees it (never heard again).
WAY_HOME_MARGIN_S = 30.0


class Lapse(enum.Enum):
    """What :meth:`LivenessTracker.sweep` found for one UAV."""

    #: heard within its timeout no more: declare it lost
    SILENT_TOO_LONG = "silent too long"
    #: its airspace was kept for its way home; the time is up (never heard again): free it
    AIRSPACE_EXPIRED = "airspace expired"


@dataclass(frozen=True)
class Timeouts:
    """How long a UAV may be quiet: ``heartbeat_s`` in general, ``heartbeat_s + rejoin_s`` while it finishes."""

    heartbeat_s: float
    rejoin_s: float

    def silence_limit_s(self, finishing: bool, has_task: bool) -> float:
        """The longest a UAV last heard ``finishing`` its work (its facts) or not may stay quiet before it is
        declared lost."""
        if finishing and has_task:
            # its work is (or was about to be) on the wall, and it finishes it even cut off: its completion may
            # come late, and a conflicting task given out now would work beside it
            return self.heartbeat_s + self.rejoin_s
        return self.heartbeat_s


def way_home_s(way_m: float, vertical_speed_mps: float) -> float:
    """How long a silent UAV's own way home (``way_m`` of flight) may take: its last-resort wait, the flight at
    the vertical speed (the slowest leg), and :data:`WAY_HOME_MARGIN_S`."""
    return LAST_RESORT_S + way_m / vertical_speed_mps + WAY_HOME_MARGIN_S


class LivenessTracker:
    """The :class:`Liveness` of every UAV of a mission, moved by what is heard and by the clock."""

    def __init__(self, links: Mapping[str, UavLink], timeouts: Timeouts) -> None:
        self.links = links
        self.timeouts = timeouts

    def heard(self, link: UavLink, now_s: float) -> None:
        """``link``'s UAV said something that counts (not a lost UAV's ignored chatter)."""
        link.last_heard_s = now_s
        if link.liveness is Liveness.SILENT:
            link.liveness = Liveness.HEARD

    def sweep(self, now_s: float, has_task: Callable[[str], bool]) -> list[tuple[str, Lapse]]:
        """What the clock did to each UAV since the last sweep (in fleet order; a UAV may show twice)."""
        out: list[tuple[str, Lapse]] = []
        heartbeat_s = self.timeouts.heartbeat_s
        finishing_s = self.timeouts.silence_limit_s(True, True)
        for name, link in self.links.items():
            until_s = link.airspace_until_s
            if until_s is not None and (not link.lost or now_s >= until_s):
                if link.lost:  # not heard again: it fell, or landed where it was (heard: the hold just ends)
                    out.append((name, Lapse.AIRSPACE_EXPIRED))
                link.airspace_until_s = None
            if link.lost or link.last_heard_s is None:
                continue
            quiet_s = now_s - link.last_heard_s
            if quiet_s <= heartbeat_s and quiet_s <= finishing_s:
                continue  # within both limits (every UAV but a silent one, every tick): nothing to ask
            if quiet_s > self.timeouts.silence_limit_s(link.facts.finishing, has_task(name)):
                out.append((name, Lapse.SILENT_TOO_LONG))
            elif quiet_s > self.timeouts.heartbeat_s:
                link.liveness = Liveness.SILENT  # in its grace: finishing its work cut off
        return out

    def lose(self, link: UavLink, now_s: float, *, out_of_service: bool = False) -> None:
        """``link``'s UAV is out of the mission: silent too long, or out of service (it said so)."""
        link.liveness = Liveness.OUT_OF_SERVICE if out_of_service else Liveness.LOST
        link.lost_at_s = now_s

    def rejoin(self, link: UavLink) -> None:
        """``link``'s UAV, declared lost for its silence, is back in the mission."""
        link.liveness = Liveness.REJOINED
        link.lost_at_s = None
        link.taking_off = False

    def awaiting_rejoin(self, now_s: float) -> bool:
        """A role has no UAV left, and one of its UAVs was declared lost for silence within ``rejoin_s``."""
        live = {link.spec.role for link in self.links.values() if not link.lost}
        return any(
            link.liveness is Liveness.LOST
            and link.spec.role not in live
            and link.lost_at_s is not None
            and now_s - link.lost_at_s <= self.timeouts.rejoin_s
            for link in self.links.values()
        )

    def known_ends_s(self, now_s: float) -> list[float]:
        """The ends of the waits on this tracker's clock still open at ``now_s`` (the stall watchdog's: a wait
        whose end mission control knows is no stall): a rejoin window :meth:`awaiting_rejoin` waits out, the
        airspace a lost UAV's way home holds (freed then, :attr:`Lapse.AIRSPACE_EXPIRED`), a UAV cut off while
        finishing its work (declared lost by then, :meth:`Timeouts.silence_limit_s`)."""
        rejoin_s, grace_s = self.timeouts.rejoin_s, self.timeouts.silence_limit_s(True, True)
        live: set[str] | None = None
        out: list[float] = []
        for link in self.links.values():
            liveness = link.liveness
            if liveness is Liveness.HEARD or liveness is Liveness.REJOINED:
                continue  # (every UAV but a quiet or lost one, every tick)
            if liveness is Liveness.SILENT:
                if link.last_heard_s is not None:
                    out.append(link.last_heard_s + grace_s)
                continue
            if link.airspace_until_s is not None:
                out.append(link.airspace_until_s)
            lost_at_s = link.lost_at_s
            if liveness is Liveness.LOST and lost_at_s is not None and now_s - lost_at_s <= rejoin_s:
                if live is None:
                    live = {other.spec.role for other in self.links.values() if not other.lost}
                if link.spec.role not in live:  # (awaiting_rejoin's own test)
                    out.append(lost_at_s + rejoin_s)
        return out

    def online(self) -> list[str]:
        """The UAVs heard from and not out of the mission."""
        return [n for n, u in self.links.items() if u.last_heard_s is not None and not u.lost]

    def never_heard(self) -> list[str]:
        """The UAVs not heard from yet and not out of the mission (before the start)."""
        return [n for n, u in self.links.items() if u.last_heard_s is None and not u.lost]
