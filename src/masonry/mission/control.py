"""Mission control: the paper's Algorithm 1 as a step function over a transport, a dispatcher and a journal.

``MissionControl.step(now_s)`` is one tick: read every incoming message (heartbeats, progress, results),
declare UAVs silent past the heartbeat timeout lost (their task goes back to the pool), hand available tasks
to idle UAVs through the dispatcher, journal every assignment, completion, failure and loss, send the
assignments, and send its own heartbeat. The loop around it is thin (``masonry sim`` steps it in simulated
time, ``masonry mission-control`` in wall time), so the same code runs in both.

This class is the thin shell; its parts (issue 27 §2, docs/architecture.md): :mod:`~masonry.mission.reducer`
(pure: what a message asks for, which results count: docs/security.md), :mod:`~masonry.mission.liveness` (one
enum per UAV: heard, silent, lost, rejoined, out of service), :mod:`~masonry.mission.ledger` (the attempts and
their journal lines), :mod:`~masonry.mission.control_inbox` (what is received: decoded, screened, routed to
the effects of its steps), :mod:`~masonry.mission.outbox` (what is sent and told),
:mod:`~masonry.mission.control_ports` (the operator's, the wind limit's and the journal's Protocols), and the
effects: ``control_results``, ``control_losses`` (startup: the UAVs never heard within ``startup_timeout_s``
are removed), ``control_airspace`` (the airspace of docs/safety.md answers the UAVs' ``ClearanceRequest``),
``control_watch`` and ``control_resume``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

from masonry.blueprint import UavSpec
from masonry.errors import MissionError
from masonry.geofence import Site
from masonry.mission import (
    control_airspace,
    control_dispatch,
    control_inbox,
    control_losses,
    control_resume,
    control_watch,
)
from masonry.mission.as_built import PlacementWatch
from masonry.mission.control_airspace import make_airspace
from masonry.mission.control_ports import JournalPort, WindGate
from masonry.mission.dispatch_chain import mission_dispatcher
from masonry.mission.events import EventSink
from masonry.mission.glue import glue_gate
from masonry.mission.heard_separation import HeardSeparation
from masonry.mission.journal_state import journaled_phases as _journaled_phases  # noqa: F401 - its home before
from masonry.mission.ledger import AttemptLedger
from masonry.mission.linger import LingerBook
from masonry.mission.liveness import LivenessTracker, Timeouts
from masonry.mission.messages import MISSION_CONTROL, Heartbeat, Message, MissionEnd, Recall
from masonry.mission.operator import Operator
from masonry.mission.outbox import MissionEvents, Outbox
from masonry.mission.records import Attempt, UavLink
from masonry.mission.reducer import OUT_OF_SERVICE_STATE
from masonry.mission.sites import SiteIntervals
from masonry.mission.spares import SpareBook
from masonry.mission.stall import DEFAULT_STALL_TIMEOUT_S, Stall, StallWatch
from masonry.mission.swap_stagger import SwapStagger
from masonry.mission.table_dispatch import DEFAULT_TABLE_DISPATCH
from masonry.mission.transport import Transport
from masonry.mission.volumes import Vec3
from masonry.mission.wait_causes import WaitWatch
from masonry.mission.wind_limit import HeardWind
from masonry.placement_check import PlacementCheck
from masonry.planner.dispatch import DEFAULT_RESERVATION
from masonry.planner.tasks import Plan, Task
from masonry.timing import DEFAULT_TIMING, TaskTiming

if TYPE_CHECKING:
    from masonry.mission.journal_state import JournalState
    from masonry.planner.schedule_values import OfflineSchedule

__all__ = ["LANDING_GRACE_S", "OUT_OF_SERVICE_STATE", "Attempt", "MissionControl", "MissionEvents", "UavLink"]

log = logging.getLogger(__name__)

#: How long (mission s) the UAVs get, after the mission's end, to fly home and land while mission control still
#: answers them (:meth:`MissionControl.may_leave`; the simulated mission stops then too).
LANDING_GRACE_S = 180.0


class MissionControl:
    """Reactive mission control over a :class:`~masonry.mission.transport.Transport`.

    Args:
        plan: the wall's plan (``masonry.planner.plan``).
        fleet: the UAVs of the mission (names must be unique).
        transport: the endpoint named ``"mission-control"``.
        policy: dispatcher priority, ``fifo``, ``critical-path`` or ``nearest``.
        journal: an open :class:`~masonry.mission.journal.Journal`, or None for no journal.
        max_attempts: attempts per task before it is reported stuck.
        durations_s: expected task durations for the critical-path priority (task id -> s).
        heartbeat_period_s: how often mission control sends its heartbeat.
        heartbeat_timeout_s: a UAV silent for longer is declared lost.
        startup_timeout_s: how long to wait for the whole fleet before starting without the missing UAVs.
        rejoin_timeout_s: how long a mission left without any UAV of a role waits for one declared lost for its
            silence to rejoin, before it ends (default: ``startup_timeout_s``).
        column_radius_m: two site columns (UAVs below their transit layer) are never granted closer than
            this horizontally (the blueprint's clearance r_c is the natural value; 0 grants every request).
        layer_base_m, layer_spacing_m: transit layers handed out per flight, at ``layer_base_m + k *
            layer_spacing_m`` (``masonry.mission.airspace.work_altitude_m`` gives the base); None: no layers.
        layer_floor_m: with it, layer 0 rises with the wall instead: it is at the highest work altitude of the
            tasks done or ever assigned (``masonry.mission.airspace.task_work_altitude_m``), at least this (the
            blueprint's cruise altitude), at most ``layer_base_m``. None: layer 0 stays at ``layer_base_m``.
        wall_digest: :func:`masonry.fingerprint.wall_digest` of the blueprint, sent with every assignment (the
            UAV refuses a task of another wall).
        min_durations_s: the least time each task can take (task id -> s); a completion that arrives sooner
            after its assignment than ``min_fraction`` of it is ignored. None: no such check.
        min_fraction: the margin on ``min_durations_s`` (two processes' clocks and ticks).
        timing: the UAVs' task timing and tool geometry (:class:`masonry.timing.TaskTiming`; default:
            ``UavConfig``'s), for the work altitudes ``layer_floor_m`` rises to.
        stall_timeout_s: when no task ends, no flight is granted and no UAV's state changes for this long, the
            mission stops, not completed, :attr:`stall` saying who waits for whom; None or 0: never.
        reservation: ``task`` (the paper: conflicting tasks never run at once) or ``site`` (their UAVs never
            work at their sites at once: :mod:`masonry.mission.sites`); site intervals are recorded either way.
        schedule: the offline schedule (:class:`masonry.planner.schedule_values.OfflineSchedule`) that
            ``policy="schedule"`` follows (:mod:`masonry.planner.schedule_policy`).
        events_sink: gets every :class:`~masonry.mission.events.MissionEvent` for a log or a live view.
        fence: the site's geofence (``Blueprint.site``; None: none): the airspace grants no flight that leaves it,
            and a task whose flight could only be flown outside it fails with the reason.
        fallback_layers_m: each UAV's fixed layer for flights without mission control (``transit_layers_m``):
            a UAV silent in the air keeps its way home there reserved (default: the altitude it was last at).
        airspace: ``columns`` (:class:`ColumnClearance`) or ``table`` (:class:`masonry.mission.reserved.TableClearance`).
        table_dispatch: under the table, ``soonest`` or ``policy`` (:mod:`masonry.mission.table_dispatch`).
        placement: the blueprint's as-built check (``Blueprint.placement``; None: 2 cm, continue).
    """

    def __init__(
        self,
        plan: Plan,
        fleet: Sequence[UavSpec],
        transport: Transport,
        *,
        policy: str = "critical-path",
        journal: JournalPort | None = None,
        max_attempts: int = 3,
        durations_s: Mapping[str, float] | None = None,
        heartbeat_period_s: float = 1.0,
        heartbeat_timeout_s: float = 5.0,
        startup_timeout_s: float = 30.0,
        rejoin_timeout_s: float | None = None,
        column_radius_m: float = 1.5,
        layer_base_m: float | None = None,
        layer_spacing_m: float = 1.1,
        layer_floor_m: float | None = None,
        wall_digest: str = "",
        min_durations_s: Mapping[str, float] | None = None,
        min_fraction: float = 0.9,
        timing: TaskTiming | None = None,
        stall_timeout_s: float | None = DEFAULT_STALL_TIMEOUT_S,
        reservation: str = DEFAULT_RESERVATION,
        schedule: OfflineSchedule | None = None,
        events_sink: EventSink | None = None,
        fence: Site | None = None,
        wind_limit: WindGate | None = None,
        fallback_layers_m: Mapping[str, float] | None = None,
        airspace: str = "columns",
        table_dispatch: str = DEFAULT_TABLE_DISPATCH,
        placement: PlacementCheck | None = None,
    ) -> None:
        names = [u.name for u in fleet]
        if len(set(names)) != len(names):
            raise MissionError(f"fleet names must be unique, got {names}")
        self.plan = plan
        #: the wind limit (masonry.mission.wind_limit.WindLimit). None given: the one the UAVs' heartbeats
        #: report (their autopilots' wind and their uav.yaml's max_wind_mps; no UAV grounded until they do)
        self.heard_wind: HeardWind | None = None
        if wind_limit is None:
            self.heard_wind = HeardWind()
            wind_limit = self.heard_wind.limit()
        self.wind_limit: WindGate | None = wind_limit
        #: the operator's commands (pause, recall, abort, limits: :mod:`masonry.mission.operator`)
        self.operator = Operator()
        self.placement = PlacementWatch(placement)
        #: hand the sink a ``uav`` event per heartbeat and progress report (a simulator that samples its world
        #: for the sink, :meth:`sample`, turns this off: its samples are the better measure)
        self.uav_events = True
        #: called with each UAV heartbeat's sender and time stamp (the UAV's own clock): ``masonry
        #: mission-control`` paces mission time by them (:class:`~masonry.mission.fleet_clock.FleetClock`)
        self.heard_clock: Callable[[str, float], None] | None = None
        #: the least separation of two airborne UAVs as their reports were heard (a real mission's measure; the
        #: simulator's report has its world's, masonry.mission.heard_separation)
        self.heard_separation = HeardSeparation()
        self.fleet = tuple(fleet)
        self.transport = transport
        self.wall_digest = wall_digest
        self.min_durations_s = dict(min_durations_s or {})
        self.min_fraction = min_fraction
        self.policy = policy
        self.journal = journal
        self.ledger = AttemptLedger(journal)  #: every attempt, the running ones, their journal lines
        self.heartbeat_period_s = heartbeat_period_s
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.startup_timeout_s = startup_timeout_s
        self.rejoin_timeout_s = startup_timeout_s if rejoin_timeout_s is None else rejoin_timeout_s
        self.dispatcher = mission_dispatcher(
            plan,
            self.fleet,
            policy,
            schedule=schedule,
            max_attempts=max_attempts,
            durations_s=durations_s,
            reservation=reservation,
        )
        self.reservation = reservation
        self.sites = SiteIntervals(
            plan,
            self.dispatcher.task_of,
            exclusive=reservation == "site",
            on_visit=self.ledger.journal_visit,
            is_done=self.dispatcher.done.__contains__,
        )
        #: the adhesive's open and cure times (None: none; :mod:`masonry.mission.glue`)
        self.glue = glue_gate(plan, self.dispatcher, self.sites, timing or DEFAULT_TIMING)
        self.uavs: dict[str, UavLink] = {u.name: UavLink(u) for u in self.fleet}
        #: each UAV's :class:`~masonry.mission.records.Liveness` and the timeouts that move it
        self.liveness = LivenessTracker(self.uavs, Timeouts(heartbeat_timeout_s, self.rejoin_timeout_s))
        self.events = MissionEvents()
        self.out = Outbox(transport, events_sink, self.events)  #: what mission control sends and tells
        self.spares = SpareBook(plan, journal, self.out.emit)  #: spares for lost bricks (mission/spares.py)
        self.tasks: dict[str, Task] = {t.id: t for t in plan.tasks}
        self.started_at_s: float | None = None
        self.first_step_s: float | None = None
        self._last_heartbeat_s: float | None = None
        self._dirty = True
        self.ended_at_s: float | None = None
        #: :attr:`blocked` when the mission ended: a lost UAV's late result taken after the end may free work
        #: nobody is left to do, and the report still says the mission ended stuck
        self.ended_blocked = False
        self.resumed_at_s: float | None = None
        self.now_s = 0.0
        homes = {u.name: u.home_m for u in self.fleet}
        layers_m = (layer_base_m, layer_spacing_m, layer_floor_m)
        gate, work = self.glue or self.sites, self.sites.is_work_site
        roles = {u.name: u.role for u in self.fleet}
        self.columns = make_airspace(
            airspace, column_radius_m, layers_m, homes, gate, fence, timing, work, roles
        )
        self.fence_failed: set[tuple[str, str, int]] = set()  # (UAV, task, attempt) failed for the fence
        self.layer_floor_m, self.timing = layer_floor_m, timing
        #: each UAV's fixed layer for flights without mission control (``transit_layers_m``, as its machine has)
        self.fallback_layers_m = dict(fallback_layers_m or {})
        self._deferred_at: int | None = None  # airspace version when a landed UAV could not take off
        self.lingers = LingerBook()  # who waits near the wall for a task due soon (mission/linger.py)
        self.swaps = SwapStagger()  # who is sent home for an early battery swap (mission/swap_stagger.py)
        self.watch = StallWatch(stall_timeout_s)
        #: set when the progress watchdog stopped the mission: who waited for whom
        self.stall: Stall | None = None
        self.waits = WaitWatch(plan, reservation)  # why each task waited (the report's ``waits``)
        control_airspace.raise_layers(self, [t.id for t in plan.tasks if t.done])
        control_dispatch.admit(
            self, column_radius_m, table_dispatch
        )  # who is not sent into a crowd (docs/dispatch.md)

    def restore(self, state: JournalState) -> None:
        """Continue from a journal's replayed state (:func:`masonry.mission.control_resume.restore`)."""
        control_resume.restore(self, state)

    # -- properties ------------------------------------------------------------------------------------
    @property
    def history(self) -> list[Attempt]:
        """Every attempt of the mission, in the order they began (:class:`~masonry.mission.ledger.AttemptLedger`)."""
        return self.ledger.history

    @property
    def sink(self) -> EventSink | None:
        """Who gets every :class:`~masonry.mission.events.MissionEvent` (None: no one)."""
        return self.out.sink

    @sink.setter
    def sink(self, sink: EventSink | None) -> None:
        self.out.sink = sink

    @property
    def finished(self) -> bool:
        """Every task is done."""
        return bool(self.dispatcher.finished)

    @property
    def blocked(self) -> bool:
        """The mission cannot finish (stuck tasks or no UAV left for a role) and nothing is in flight."""
        return bool(self.dispatcher.blocked) and not self.dispatcher.in_progress

    @property
    def over(self) -> bool:
        """Finished, blocked, stalled or aborted: mission control has sent (or will send) MissionEnd.

        Blocked only for want of a UAV of a role whose last one fell silent less than ``rejoin_timeout_s`` ago
        is not over yet: it may come back (a radio out of range, a handler process restarted) and rejoin.
        """
        blocked = self.blocked and not self.liveness.awaiting_rejoin(self.now_s)
        return self.finished or blocked or self.stall is not None or self.operator.aborted

    @property
    def fleet_down(self) -> bool:
        """No UAV may still ask for the airspace: each is on its pad (not taking off), out of the mission (lost,
        out of service), or was never heard."""
        return all(
            link.lost or link.last_heard_s is None or (link.facts.on_pad and not link.taking_off)
            for link in self.uavs.values()
        )

    def may_leave(self, now_s: float, heard_s: float) -> bool:
        """After its end, whether mission control may stop answering (its process exit): ``heard_s`` (mission s)
        past its MissionEnd, so that every handler has heard it, and every UAV down (:attr:`fleet_down`) or
        :data:`LANDING_GRACE_S` past the end.

        Until then it answers the flights home: a UAV whose way home it had not granted before it left hovered
        where its last task ended for ``LAST_RESORT_S`` (30 s), then flew home on its fallback layer (issue 29: a
        `masonry fly --mission` still running long after its mission control ended).
        """
        if self.ended_at_s is None:
            return False
        since_s = now_s - self.ended_at_s
        return since_s >= heard_s and (self.fleet_down or since_s >= LANDING_GRACE_S)

    @property
    def online(self) -> list[str]:
        """The UAVs heard from and still in the mission."""
        return self.liveness.online()

    # -- the tick --------------------------------------------------------------------------------------
    def step(self, now_s: float) -> None:
        """One tick of mission control at mission time ``now_s`` (see the module docstring)."""
        self.now_s = now_s
        if self.first_step_s is None:
            self.first_step_s = now_s
        for raw in self.transport.receive():
            control_inbox.handle(self, raw, now_s)  # decoded, screened, routed (mission/control_inbox.py)
        self.operator.step(self, now_s)
        control_losses.check_heartbeats(self, now_s)
        if self.glue is not None and self.glue.step(self, now_s):
            self._dirty = True
        control_airspace.grant_waiting(self, now_s)
        if self.started_at_s is None:
            control_losses.maybe_start(self, now_s)
        if self.started_at_s is not None and self.ended_at_s is None:
            if self.wind_limit is not None and self.wind_limit.update(now_s):
                control_watch.on_wind(self, now_s)
            if (
                self._dirty or (self._deferred_at is not None and self._deferred_at != self.columns.version)
            ) and not self.operator.holds_dispatch():
                self._dispatch(now_s)
            self.waits.observe(self, now_s)
            control_watch.watch_progress(self, now_s)
            if self.over:
                self.ended_at_s, self.ended_blocked = now_s, self.blocked
                self._broadcast(MissionEnd(MISSION_CONTROL, now_s, self.finished))
                self.out.emit(now_s, "end", completed=self.finished)
        if self._last_heartbeat_s is None or now_s - self._last_heartbeat_s >= self.heartbeat_period_s:
            self._last_heartbeat_s = now_s
            self._broadcast(
                Heartbeat(MISSION_CONTROL, now_s, state="running" if self.ended_at_s is None else "ended")
            )

    def _dispatch(self, now_s: float) -> None:
        self._dirty = False
        positions = {n: u.position_m for n, u in self.uavs.items() if u.position_m is not None and not u.lost}
        self._deferred_at = None
        for a in self.dispatcher.assign(positions or None, may_start=self._may_take_off):
            attempt = self.ledger.begin(a.task_id, a.uav, now_s).attempt  # (the assignment's own number)
            control_airspace.raise_layers(self, (a.task_id,))
            log.info("%s assigned to %s (attempt %d) at %.1f s", a.task_id, a.uav, attempt, now_s)
            self.out.emit(now_s, "assigned", a.uav, a.task_id, attempt=attempt)
            task = self.spares.task(self.tasks[a.task_id])  # (with its spare, if one stands in for its brick)
            self.out.send(
                a.uav, self.placement.assign(self, a.uav, task, attempt, now_s)
            )  # (planned: issue 30)

    def _may_take_off(self, name: str) -> bool:
        """:func:`masonry.mission.control_dispatch.may_take_off` (the dispatcher's ``may_start``)."""
        return control_dispatch.may_take_off(self, name)

    def wake(self) -> None:
        """Dispatch again at the next step (the operator resumed, or changed a limit)."""
        self._dirty = True

    def recall(
        self, uav: str, now_s: float, reason: str, task_id: str | None = None, attempt: int = 0
    ) -> None:
        """Tell ``uav`` to drop attempt ``attempt`` of ``task_id``, fly home and land; ``task_id`` None: whatever
        it holds when it reads the recall (the operator's recall)."""
        self.out.send(uav, Recall(MISSION_CONTROL, uav, now_s, reason, task_id, attempt))

    def emit_event(
        self, now_s: float, kind: str, uav: str | None = None, task_id: str | None = None, **fields: object
    ) -> None:
        """Hand an event to the sink, if any (the operator's commands)."""
        self.out.emit(now_s, kind, uav, task_id, **fields)

    def sample(self, now_s: float, positions_m: Mapping[str, Vec3], batteries: Mapping[str, float]) -> None:
        """Hand the sink a ``uav`` event per live UAV, with its position and battery measured outside mission
        control (the simulator's world); mission control's own view is unchanged."""
        control_airspace.sample(self, now_s, positions_m, batteries)

    def _broadcast(self, msg: Message) -> None:
        self.out.broadcast(msg, [name for name, link in self.uavs.items() if not link.lost])
