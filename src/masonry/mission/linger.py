"""Waiting near the wall for the next task instead of flying home: decided with the model's time.

A UAV whose task is done and that was given no next one asks to fly home, land, and take off again once a task
comes. On a wall where each role's tasks are released one by one by the other role's (a brick by the bead under
it, a bead by the brick under it: G^d), that round trip lies on the critical path every time (the pyramid at
1 + 1: about 20 round trips of 25-35 s). Mission control knows what is in progress, what it releases and how long
it takes (:func:`masonry.planner.estimate_durations_s`), so it can tell whether a task of the UAV's role is due
sooner than the UAV could fly home and back (:func:`round_trip_s`):

- **Linger** (:meth:`LingerBook.consider`, on the UAV's request to fly home with no task): when fewer UAVs of its
  role wait near the wall than tasks of that role are due within its round trip, its flight home is held back and
  it waits at a hold point near where it is, clear of every site and adhesion segment still to be worked, of the
  pads and of what the others hold (:mod:`masonry.mission.linger_airspace`). It is an ordinary hold point: the
  UAV flies its hold flight and hovers there; a task handed to it turns it back from there (docs/safety.md).
- **Until** (:meth:`LingerBook.review`, every tick): it got a task; or the model no longer expects one (a
  failure, a task due later than a round trip); or the expected release passed by more than one round trip
  (the model was wrong: waiting longer costs more than the trip it saves, the rule of the ski-rental problem); or,
  once it hovers at its spot (not on its hold flight out of the site it worked), another UAV's flight, hold
  flight or take-off fits only without its volumes (:func:`held_up_by`), whatever that UAV waits for (the
  airspace, its site's turn): it yields, and its flight home is granted once it fits;
  or its battery is under :data:`MIN_BATTERY` (the handler would hold its next task back for a swap anyway) or
  does not cover the rest of the wait, the task and the way home at the drain its heartbeats show
  (:meth:`LingerBook.affords`: a wait in the air is flight time, and a UAV that cannot afford it goes home);
  or the wind grounds it, the operator pauses, recalls or limits it, or it is lost; or the mission is over.

Only the ``columns`` airspace lingers (the table airspace's plans end on the pad). Pure bookkeeping over mission
control's state: no I/O, no clock.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from masonry.battery_drain import DrainMeter, flight_left_s
from masonry.mission.airspace import ColumnClearance
from masonry.mission.airspace_requests import hold_side, queued_near
from masonry.mission.airspace_state import Phase, UavAirspace, hold_candidates
from masonry.mission.fence import volumes_in_fence
from masonry.mission.swap_stagger import swap_due
from masonry.mission.volumes import XY, Vec3, Volume, volumes_clear
from masonry.planner.bounds import estimate_durations_s
from masonry.planner.tasks import AdhesionTask
from masonry.timing import DEFAULT_TIMING, TaskTiming, min_jerk_leg_s

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl

__all__ = [
    "LOW_BATTERY",
    "MIN_BATTERY",
    "LingerBook",
    "Lingering",
    "due_s",
    "held_up_by",
    "round_trip_s",
    "wanted_flights",
]

log = logging.getLogger("masonry.mission.control")

#: A UAV reporting less charge than this does not wait in the air: it is the mission handler's default reserve
#: (``UavHandler(reserve_fraction=0.4)``), under which its next task is held back until it has landed for a swap.
MIN_BATTERY = 0.4
#: The charge a UAV's budget keeps in reserve (``UavConfig.battery_low_fraction``'s default): a wait near the wall
#: is taken only while the flight left above it covers the wait, the task and the way home.
LOW_BATTERY = 0.2
#: The autopilot's touch-down and disarm, and its take-off's spool-up (s): ``masonry.fsm.battery``'s figures.
_TOUCHDOWN_S = 1.0
_SPOOL_UP_S = 1.5


def round_trip_s(position_m: Vec3, home_m: Vec3, timing: TaskTiming = DEFAULT_TIMING) -> float:
    """The time a UAV hovering at ``position_m`` takes to fly home, land, take off and fly back (s): two
    minimum-jerk lateral legs at the cruise speed and two vertical ones at the climb speed."""
    lateral_s = min_jerk_leg_s(
        math.hypot(position_m[0] - home_m[0], position_m[1] - home_m[1]), timing.cruise_speed_mps
    )
    vertical_s = min_jerk_leg_s(max(0.0, position_m[2] - home_m[2]), timing.vertical_speed_mps)
    return 2.0 * (lateral_s + vertical_s) + _TOUCHDOWN_S + _SPOOL_UP_S


def due_s(
    mc: MissionControl,
    role: str,
    prerequisites: Mapping[str, list[str]],
    expected_s: Mapping[str, float],
    now_s: float,
) -> list[float]:
    """When each task of ``role`` not yet started is expected to be released (mission time, sorted): now for one
    whose prerequisites are done, else the latest expected end of its prerequisites in progress (their start plus
    their expected duration). Tasks with a prerequisite not yet started are not due soon and are left out."""
    d = mc.dispatcher
    done, running = d.done, d.in_progress
    out: list[float] = []
    for task in mc.plan.tasks:
        tid = task.id
        if task.kind != role or tid in done or tid in running or tid in d.stuck:
            continue
        at_s = now_s
        for p in prerequisites.get(tid, ()):
            if p in done:
                continue
            attempt = mc.ledger.running.get(p)
            if p not in running or attempt is None:
                break
            at_s = max(at_s, attempt.start_s + expected_s.get(p, 0.0))
        else:
            out.append(at_s)
    return sorted(out)


def _volumes_but(c: ColumnClearance, uav: str, lingerer: str) -> list[Volume]:
    return [q for n, u in c.records.items() if n not in (uav, lingerer) for q in u.volumes]


def wanted_flights(c: ColumnClearance, uav: str, u: UavAirspace) -> list[list[Volume]]:
    """The flights ``uav`` waits to be given, each at every layer: to its site (from its hold point, or from
    where it asked) unless its site's turn has not come (the site gate, an earlier request near it), and, still
    asking with no hold point, to each hold point it could be sent to (:func:`hold_candidates`)."""
    w = u.request
    if w is None:
        return []
    if u.hold is not None and u.phase in (Phase.AT_HOLD, Phase.TO_HOLD):
        start: Vec3 = (u.hold.point_m[0], u.hold.point_m[1], u.hold.layer_m)
    else:
        start = w.position if w.position is not None else w.site
    turn = (c.gate is None or c.gate.may_enter(uav, w.site)) and not queued_near(c, w)
    out: list[list[Volume]] = []
    if turn:
        home = c.is_home(uav, w.site)
        out = [
            c.flight_volumes_at(start, w.site, w.top_m, k, None, w.to, home=home) for k in range(c.max_layers)
        ]
    if u.phase is Phase.ASKING:
        others = [o for n, o in c.records.items() if n != uav]
        pads = [(h[0], h[1]) for n, h in c.homes.items() if n != uav]
        waited = () if c.gate is None else c.gate.waited_on(uav)
        side = hold_side(c, uav, start)  # (so the points its hold flight would try)
        for hold in hold_candidates(w.site, others, c.wait_radius_m, pads, waited, from_m=side)[:6]:
            out.extend(
                c.flight_volumes_at(start, None, w.top_m, k, (hold[0], hold[1])) for k in range(c.max_layers)
            )
    return out


def held_up_by(c: ColumnClearance, uav: str, lingerer: str) -> bool:
    """No flight ``uav`` waits for (:func:`wanted_flights`) fits now, but one would without ``lingerer``'s
    volumes: ``lingerer`` is in its way, whatever ``uav`` waits for."""
    u = c.records.get(uav)
    if u is None:
        return False
    flights = wanted_flights(c, uav, u)
    if not flights or any(c.fits(uav, vols) for vols in flights):
        return False
    rest = _volumes_but(c, uav, lingerer)
    return any(
        (c.fence is None or volumes_in_fence(c.fence, vols))
        and volumes_clear(vols, rest, c.sep_xy_m, c.spacing_m - 1e-9)
        for vols in flights
    )


@dataclass
class Lingering:
    """One UAV waiting near the wall: since when, and the latest time the model expects its task by."""

    since_s: float
    until_s: float
    events: int  # the dispatcher's event count when ``until_s`` was worked out
    seen: tuple[int, Phase] = (-1, Phase.PARKED)  # the airspace's version and its phase when last looked at


class LingerBook:
    """Which UAVs wait near the wall for their next task, and for how long they did (see the module docstring).

    Args:
        enabled: False: every UAV with no task flies home (as before this).
    """

    def __init__(self, *, enabled: bool = True) -> None:
        self.enabled = enabled
        self.active: dict[str, Lingering] = {}
        self.lingered_s: dict[str, float] = {}  # each UAV's seconds waiting near the wall, over the mission
        self.count: dict[str, int] = {}  # how often each UAV did
        self._expected_s: dict[str, float] | None = None
        self.drains: dict[str, DrainMeter] = {}  # each UAV's drain per airborne second, from its heartbeats
        self._prerequisites: dict[str, list[str]] | None = None
        #: role -> (what it was computed at, the longest expected task of the role still to do): the dispatcher's
        #: done set changes only with its events (an addition also with its size), the plan not at all
        self._longest_s: dict[str, tuple[tuple[object, ...], float]] = {}

    def total_s(self, uav: str, now_s: float) -> float:
        """``uav``'s seconds waiting near the wall so far (one still waiting counts to ``now_s``)."""
        ongoing = self.active.get(uav)
        return self.lingered_s.get(uav, 0.0) + (0.0 if ongoing is None else max(0.0, now_s - ongoing.since_s))

    def heard(self, uav: str, now_s: float, battery: float | None, airborne: bool) -> None:
        """A heartbeat of ``uav`` with its ``battery`` (0..1): its drain per airborne second is measured."""
        if battery is not None:
            self.drains.setdefault(uav, DrainMeter()).update(now_s, battery, airborne)

    def affords(self, mc: MissionControl, uav: str, position_m: Vec3, until_s: float, now_s: float) -> bool:
        """The flight left above :data:`LOW_BATTERY` at ``uav``'s measured drain covers a wait until ``until_s``,
        the longest task of its role still to do and the way home (True while no drain is measured: the
        :data:`MIN_BATTERY` floor alone)."""
        link = mc.uavs[uav]
        meter = self.drains.get(uav)
        drain = None if meter is None else meter.drain_per_s
        if drain is None or link.battery is None:
            return True
        if self._expected_s is None:
            self._due_s(mc, link.spec.role, now_s)
        assert self._expected_s is not None
        task_s = self._longest_task_s(mc, link.spec.role)
        home_s = 0.5 * round_trip_s(position_m, link.spec.home_m, mc.timing or DEFAULT_TIMING)
        need_s = max(0.0, until_s - now_s) + task_s + home_s
        return flight_left_s(link.battery, LOW_BATTERY, drain) >= need_s

    def _longest_task_s(self, mc: MissionControl, role: str) -> float:
        """The longest expected task of ``role`` not done yet (s), kept while the plan and the done tasks stay
        (a lingering UAV asks on every review)."""
        dispatcher = mc.dispatcher
        done = dispatcher.done
        key = (dispatcher, mc.plan, dispatcher.events, len(done))
        kept = self._longest_s.get(role)
        if kept is not None and kept[0] == key:
            return kept[1]
        expected = self._expected_s
        assert expected is not None
        task_s = max(
            (expected.get(t.id, 0.0) for t in mc.plan.tasks if t.kind == role and t.id not in done),
            default=0.0,
        )
        self._longest_s[role] = (key, task_s)
        return task_s

    def _due_s(self, mc: MissionControl, role: str, now_s: float) -> list[float]:
        if self._expected_s is None or self._prerequisites is None:
            self._expected_s = estimate_durations_s(mc.plan, mc.fleet, timing=mc.timing or DEFAULT_TIMING)
            self._prerequisites = mc.plan.prerequisites()
        return due_s(mc, role, self._prerequisites, self._expected_s, now_s)

    def _until_s(self, mc: MissionControl, uav: str, position_m: Vec3, now_s: float) -> float | None:
        """The latest expected release among the tasks this UAV would wait for, or None: not worth waiting."""
        link = mc.uavs[uav]
        role, home = link.spec.role, link.spec.home_m
        trip_s = round_trip_s(position_m, home, mc.timing or DEFAULT_TIMING)
        soon = [t for t in self._due_s(mc, role, now_s) if t - now_s <= trip_s]
        others = sum(1 for n in self.active if n != uav and mc.uavs[n].spec.role == role)
        if len(soon) <= others:
            return None
        return soon[others] + trip_s  # (its own task's release, plus one round trip of patience)

    def _may_wait(self, mc: MissionControl, uav: str) -> str | None:
        """Why ``uav`` may not wait in the air now (None: it may)."""
        link = mc.uavs[uav]
        if mc.over or mc.ended_at_s is not None:
            return "the mission is over"
        if link.lost:
            return "lost"
        if mc.operator.holds_dispatch() or not mc.operator.may_fly(mc, uav):
            return "held by the operator"
        if mc.wind_limit is not None and not mc.wind_limit.allows(uav):
            return "grounded by the wind"
        if link.battery is None or link.battery < MIN_BATTERY or swap_due(mc, uav):
            return "battery"
        return None

    def consider(
        self, mc: MissionControl, uav: str, site_m: Vec3, position_m: Vec3 | None, now_s: float
    ) -> None:
        """``uav`` asks to fly to ``site_m`` from ``position_m``: if that is home, with no task, and a task of its
        role is due sooner than it could fly home and back, it waits near here instead."""
        c = mc.columns
        if (
            not self.enabled
            or not isinstance(c, ColumnClearance)
            or c.base_m is None
            or position_m is None
            or uav in self.active
            or not c.is_home(uav, site_m)
            or c.phase(uav) is not Phase.PARKED
            or mc.dispatcher.task_of(uav) is not None
            or self._may_wait(mc, uav) is not None
        ):
            return
        until_s = self._until_s(mc, uav, position_m, now_s)
        if until_s is None or not self.affords(mc, uav, position_m, until_s, now_s):
            return
        c.lingering[uav] = self._work_to_do(mc)
        c.touch()
        self.active[uav] = Lingering(now_s, until_s, mc.dispatcher.events)
        self.count[uav] = self.count.get(uav, 0) + 1
        log.info(
            "%s waits near the wall for its next task (expected by %.1f s) at %.1f s", uav, until_s, now_s
        )

    @staticmethod
    def _work_to_do(mc: MissionControl) -> tuple[tuple[XY, XY], ...]:
        """The sites (as zero-length spans) and adhesion segments of the tasks not done, and the pickups."""
        done = mc.dispatcher.done
        out: list[tuple[XY, XY]] = []
        for t in mc.plan.tasks:
            if t.id in done:
                continue
            if isinstance(t, AdhesionTask):
                out.append(((t.start_m[0], t.start_m[1]), (t.end_m[0], t.end_m[1])))
            else:
                here = (t.position_m[0], t.position_m[1])
                out.append((here, here))
                if t.pickup_m is not None:
                    out.append(((t.pickup_m[0], t.pickup_m[1]), (t.pickup_m[0], t.pickup_m[1])))
        return tuple(out)

    def review(self, mc: MissionControl, now_s: float) -> None:
        """End the waits that are over (see the module docstring); each one ended may fly home."""
        if not self.active:
            return
        c = mc.columns
        assert isinstance(c, ColumnClearance)
        for uav, w in list(self.active.items()):
            why = self._ends(mc, c, uav, w, now_s)
            if why is not None:
                self.end(mc, uav, now_s, why)

    def _ends(
        self, mc: MissionControl, c: ColumnClearance, uav: str, w: Lingering, now_s: float
    ) -> str | None:
        if mc.dispatcher.task_of(uav) is not None:
            return "task"
        if uav not in c.lingering:
            return "no spot near the wall"
        why = self._may_wait(mc, uav)
        if why is not None:
            return why
        pos = mc.uavs[uav].position_m
        if pos is not None and not self.affords(mc, uav, pos, w.until_s, now_s):
            return "battery (the wait, a task and the way home)"
        if now_s > w.until_s:
            return "no task within a round trip"
        if w.events != mc.dispatcher.events:
            pos = mc.uavs[uav].position_m
            until_s = None if pos is None else self._until_s(mc, uav, pos, now_s)
            if until_s is None:
                return "no task due soon"
            w.events = mc.dispatcher.events  # (its end stays: a wait is never longer than first expected)
        seen, w.seen = w.seen, (c.version, c.phase(uav))
        # only once it hovers at its spot: on its hold flight it is still climbing out of the site it just
        # worked, in the way of the UAV waiting for that site, which its flight home would be as well (issue 27:
        # 17 of the pyramid's 20 waits at 1 + 1 ended so at once, each a round trip home on the critical path)
        if w.seen != seen and w.seen[1] is Phase.AT_HOLD and self._in_the_way(mc, c, uav):
            return "in another UAV's way"
        return None

    @staticmethod
    def _in_the_way(mc: MissionControl, c: ColumnClearance, uav: str) -> bool:
        """Another UAV's flight, hold flight or take-off fits only without ``uav``'s volumes: it waits for
        ``uav``. (Every UAV with a request counts, also one its site gate holds back: that one needs a hold
        flight, and a lingering hover in the way of every hold point kept it hovering at its site, where it
        blocked others' climbs out: ``bench_layouts --compact`` seed 5.)"""
        for other, o in c.records.items():
            if other == uav:
                continue
            if o.request is not None:
                if held_up_by(c, other, uav):
                    return True
            elif o.phase is Phase.LANDED and mc._deferred_at is not None:
                # (a landed UAV waits for the column over its pad only when its take-off was refused)
                pad = [c.home_column(other)]
                if not c.free(other, pad) and volumes_clear(
                    pad, _volumes_but(c, other, uav), c.sep_xy_m, c.spacing_m - 1e-9
                ):
                    return True
        return False

    def end(self, mc: MissionControl, uav: str, now_s: float, why: str) -> None:
        """``uav`` no longer waits near the wall (``why``): its flight home is granted once it fits."""
        w = self.active.pop(uav, None)
        if w is None:
            return
        self.lingered_s[uav] = self.lingered_s.get(uav, 0.0) + max(0.0, now_s - w.since_s)
        c = mc.columns
        if isinstance(c, ColumnClearance) and why == "task" and c.phase(uav) is Phase.AT_HOLD:
            c.handed_task.add(uav)  # (it asks for its site next: no flight home meanwhile)
        if isinstance(c, ColumnClearance) and c.lingering.pop(uav, None) is not None:
            c.touch()  # its flight home is granted once it fits
        log.info("%s stops waiting near the wall at %.1f s (%s)", uav, now_s, why)
