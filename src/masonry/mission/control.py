"""Mission control: the paper's Algorithm 1 as a step function over a transport, a dispatcher and a journal.

``MissionControl.step(now_s)`` is one tick: read every incoming message (heartbeats, progress, results),
declare UAVs silent past the heartbeat timeout lost (their task goes back to the pool), hand available tasks
to idle UAVs through the dispatcher, journal every assignment, completion, failure and loss, send the
assignments, and send its own heartbeat. The loop around it is thin (``masonry sim`` steps it in simulated
time, ``masonry mission-control`` in wall time), so the same code runs in both.

Airspace: a UAV setting off for a site asks for the column there (``ClearanceRequest``); mission control grants
columns first come, first served, never two within ``column_radius_m`` of each other, or tells the UAV where to
wait (:class:`~masonry.mission.airspace.ColumnClearance`), and frees a lost UAV's columns (docs/safety.md).

Results (docs/security.md): a completion counts only if it comes from the UAV the task is assigned to, for the
current attempt, and no sooner after the assignment than ``min_fraction`` of the least time the task can take
(``min_durations_s``, :func:`masonry.planner.min_durations_s`). Anything else is ignored and counted by reason
in ``events.ignored``; the task stays assigned. These checks hold with or without a mission key.

Startup: a UAV takes tasks once it has been heard from. Mission control waits until the whole fleet is
online, or ``startup_timeout_s`` after its first step, then removes the UAVs never heard from.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING

from masonry.blueprint import UavSpec
from masonry.errors import JournalError, MissionError, PlanningError, ProtocolError
from masonry.geofence import Site
from masonry.mission.airspace import ON_PAD_Z_M, ColumnClearance, Grant, Phase, task_work_altitude_m
from masonry.mission.as_built import PlacementWatch, take_result
from masonry.mission.control_ports import JournalPort, WindGate
from masonry.mission.events import EventSink, volume_list
from masonry.mission.glue import glue_gate
from masonry.mission.journal_state import journaled_phases as _journaled_phases  # noqa: F401 - its home before
from masonry.mission.ledger import AttemptLedger
from masonry.mission.liveness import Lapse, LivenessTracker, Timeouts, way_home_s
from masonry.mission.messages import (
    MISSION_CONTROL,
    OPERATOR,
    Assign,
    Clearance,
    ClearanceRequest,
    CommandAnswer,
    Heartbeat,
    Message,
    MissionEnd,
    OperatorCommand,
    Progress,
    Recall,
    Result,
    decode,
)
from masonry.mission.operator import Operator
from masonry.mission.outbox import MissionEvents, Outbox
from masonry.mission.records import LANDED_STATE, Attempt, Liveness, UavLink
from masonry.mission.reducer import (
    OUT_OF_SERVICE_STATE,
    Step,
    dropped_reason,
    late_completion,
    loss_reason,
    screen_result,
    steps_of,
    way_home_of,
)
from masonry.mission.reserved import AIRSPACES, TableClearance
from masonry.mission.sites import SITE_META_PREFIX, SiteIntervals, SiteVisit, journaled_visits
from masonry.mission.spares import SpareBook
from masonry.mission.stall import DEFAULT_STALL_TIMEOUT_S, Stall, StallWatch, stall_of
from masonry.mission.transport import Transport
from masonry.mission.wait_causes import WaitWatch
from masonry.mission.wind_limit import HeardWind
from masonry.placement_check import PlacementCheck
from masonry.planner.dispatch import DEFAULT_RESERVATION
from masonry.planner.schedule_policy import make_dispatcher
from masonry.planner.tasks import BrickTask, Plan, Task
from masonry.ports import CARRYING_STATES, RECALL_REASON
from masonry.timing import DEFAULT_TIMING, TaskTiming

if TYPE_CHECKING:
    from masonry.mission.journal_state import JournalState, RunningRecord
    from masonry.planner.schedule_values import OfflineSchedule

__all__ = ["OUT_OF_SERVICE_STATE", "Attempt", "MissionControl", "MissionEvents", "UavLink"]

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]


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
        self.fleet = tuple(fleet)
        self.transport = transport
        self.wall_digest = wall_digest
        self.min_durations_s = dict(min_durations_s or {})
        self.min_fraction = min_fraction
        self.policy = policy
        self.journal = journal
        self.heartbeat_period_s = heartbeat_period_s
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.startup_timeout_s = startup_timeout_s
        self.rejoin_timeout_s = startup_timeout_s if rejoin_timeout_s is None else rejoin_timeout_s
        self.dispatcher = make_dispatcher(
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
            on_visit=self._journal_visit,
            is_done=self.dispatcher.done.__contains__,
        )
        #: the adhesive's open and cure times (None: none; :mod:`masonry.mission.glue`)
        self.glue = glue_gate(plan, self.dispatcher, self.sites, timing or DEFAULT_TIMING)
        self.uavs: dict[str, UavLink] = {u.name: UavLink(u) for u in self.fleet}
        #: each UAV's :class:`~masonry.mission.records.Liveness` and the timeouts that move it
        self.liveness = LivenessTracker(self.uavs, Timeouts(heartbeat_timeout_s, self.rejoin_timeout_s))
        self.events = MissionEvents()
        self.out = Outbox(transport, events_sink, self.events)  #: what mission control sends and tells
        self.spares = SpareBook(plan, journal, self._emit)  #: spares for lost bricks (mission/spares.py)
        self._tasks: dict[str, Task] = {t.id: t for t in plan.tasks}
        self.ledger = AttemptLedger(journal)  #: every attempt, the running ones, their journal lines
        self.started_at_s: float | None = None
        self._first_step_s: float | None = None
        self._last_heartbeat_s: float | None = None
        self._dirty = True
        self.ended_at_s: float | None = None
        self.resumed_at_s: float | None = None
        self.now_s = 0.0
        if airspace not in AIRSPACES:
            raise MissionError(f"airspace must be one of {', '.join(AIRSPACES)}, got {airspace!r}")
        kind = TableClearance if airspace == "table" else ColumnClearance
        self.columns: ColumnClearance | TableClearance = kind(
            column_radius_m,
            layer_base_m,
            layer_spacing_m,
            homes={u.name: u.home_m for u in self.fleet},
            start_base_m=layer_floor_m,
            gate=self.glue or self.sites,
            fence=fence,
        )
        if isinstance(self.columns, TableClearance):
            self.columns.use_timing(timing or DEFAULT_TIMING)  # the legs' windows: the UAVs' own speeds
        self._fence_failed: set[tuple[str, str, int]] = set()  # (UAV, task, attempt) failed for the fence
        self._layer_floor_m, self.timing = layer_floor_m, timing
        #: each UAV's fixed layer for flights without mission control (``transit_layers_m``, as its machine has)
        self.fallback_layers_m = dict(fallback_layers_m or {})
        self._deferred_at: int | None = None  # airspace version when a landed UAV could not take off
        self._watch = StallWatch(stall_timeout_s)
        #: set when the progress watchdog stopped the mission: who waited for whom
        self.stall: Stall | None = None
        self.waits = WaitWatch(plan, reservation)  # why each task waited (the report's ``waits``)
        self._raise_layers(t.id for t in plan.tasks if t.done)

    # -- resume ----------------------------------------------------------------------------------------
    def restore(self, state: JournalState) -> None:
        """Continue from a journal's replayed state: done tasks stay done with their times, attempts carry on.

        Attempts in progress when the previous run stopped stay with their UAVs (:meth:`_adopt`): what each
        UAV says first decides (its completion, said again, is taken; its heartbeat naming the task keeps it
        flying; one naming no task gives it back to the pool, not counted; silence declares it lost). Handing
        them out again at once would fly a task twice whose completion never reached the journal.
        UAVs the journal declared lost stay lost.
        """

        done = {rec.task_id: rec for rec in state.done}
        unknown = sorted((set(done) | {f.task_id for f in state.failures}) - set(self._tasks))
        if unknown:
            raise JournalError(f"journal holds tasks that are not in this plan: {', '.join(unknown)}")
        attempts = self.spares.restore(state.meta, state.attempts, self.dispatcher.max_attempts)  # (spares)
        self.dispatcher.restore(list(done), attempts)
        if self.glue is not None:  # the beads' ages and the cures go on from the journal's completion times
            self.glue.restore((rec.task_id, rec.time_s) for rec in done.values())
        self.ledger.restore(state.failures, done)
        for name in state.lost_uavs:
            link = self.uavs.get(name)
            if link is not None and not link.lost:
                link.liveness = Liveness.LOST  # (lost before this run: not awaited to rejoin)
                self.dispatcher.remove_uav(name)
        for run in state.running:
            self._adopt(run)
        self.ledger.sort()
        self.resumed_at_s = state.last_time_s
        self.sites.restore(journaled_visits(state.meta, set(done), state.last_time_s))
        self.waits.restore(state.meta)
        # what the previous run may have built: done tasks, and every task it ever assigned
        self._raise_layers([*done, *attempts, *state.in_progress])

    def _adopt(self, run: RunningRecord) -> None:
        """A journaled attempt still running at the stop: in progress on its UAV again (unless the UAV is lost,
        another attempt holds it, or the task cannot run now: then it goes back to the pool as before)."""
        link = self.uavs.get(run.uav)
        if link is None or link.lost or run.task_id in self.dispatcher.done:
            return
        try:
            self.dispatcher.adopt(run.task_id, run.uav)
        except PlanningError as exc:
            log.warning("%s: not kept on %s after the resume: %s", run.task_id, run.uav, exc)
            return
        self.ledger.adopt(run.task_id, run.uav, run.attempt, run.start_s)
        log.info("%s kept on %s (attempt %d) from before the resume", run.task_id, run.uav, run.attempt)

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
    def online(self) -> list[str]:
        """The UAVs heard from and still in the mission."""
        return self.liveness.online()

    # -- the tick --------------------------------------------------------------------------------------
    def step(self, now_s: float) -> None:
        """One tick of mission control at mission time ``now_s`` (see the module docstring)."""
        self.now_s = now_s
        if self._first_step_s is None:
            self._first_step_s = now_s
        for raw in self.transport.receive():
            self._handle(raw, now_s)
        self.operator.step(self, now_s)
        self._check_heartbeats(now_s)
        if self.glue is not None and self.glue.step(self, now_s):
            self._dirty = True
        if self.columns.waiting:
            for g in self.columns.grant(now_s):
                self._answer(g, now_s)
                self.waits.answered(g.uav, self.dispatcher.task_of(g.uav), g.site_m, g.granted)
                self._emit_clearance(now_s, g)
                how = "granted" if g.granted else "held"
                log.debug("flight to (%.2f, %.2f) %s to %s", *g.site_m[:2], how, g.uav)
        if self.started_at_s is None:
            self._maybe_start(now_s)
        if self.started_at_s is not None and self.ended_at_s is None:
            if self.wind_limit is not None and self.wind_limit.update(now_s):
                self._on_wind(now_s)
            if (
                self._dirty or (self._deferred_at is not None and self._deferred_at != self.columns.version)
            ) and not self.operator.holds_dispatch():
                self._dispatch(now_s)
            self.waits.observe(self, now_s)
            self._watch_progress(now_s)
            if self.over:
                self.ended_at_s = now_s
                self._broadcast(MissionEnd(MISSION_CONTROL, now_s, self.finished))
                self._emit(now_s, "end", completed=self.finished)
        if self._last_heartbeat_s is None or now_s - self._last_heartbeat_s >= self.heartbeat_period_s:
            self._last_heartbeat_s = now_s
            self._broadcast(
                Heartbeat(MISSION_CONTROL, now_s, state="running" if self.ended_at_s is None else "ended")
            )

    def _maybe_start(self, now_s: float) -> None:
        missing = self.liveness.never_heard()
        assert self._first_step_s is not None
        if missing and now_s - self._first_step_s < self.startup_timeout_s:
            return
        for name in missing:
            log.warning("UAV %s never came online; starting without it", name)
            self._lose(name, now_s)
        self.started_at_s = now_s
        self._dirty = True
        self._emit(now_s, "start", fleet=[n for n, u in self.uavs.items() if not u.lost])

    def _handle(self, raw: bytes, now_s: float) -> None:
        """One message: decoded, screened, then the :func:`~masonry.mission.reducer.steps_of` it asks for."""
        try:
            msg = decode(raw, self.uavs.keys())
        except ProtocolError as exc:
            self.events.rejected += 1
            self.events.errors.append(str(exc))
            log.warning("rejected message: %s", exc)
            return
        self.events.received += 1
        if isinstance(msg, OperatorCommand):
            self._on_command(msg, now_s)
            return
        if msg.sender == MISSION_CONTROL or msg.sender == OPERATOR:
            return
        link = self.uavs[msg.sender]
        if self._screened(link, msg, now_s):
            return
        self.liveness.heard(link, now_s)
        if isinstance(msg, Result):
            link.taking_off = False
            if msg.position_m is not None:
                link.moved_to(msg.position_m)
        for step in steps_of(msg):
            if step is Step.CLEARANCE and isinstance(msg, ClearanceRequest):
                self._on_clearance_request(msg, now_s)
            elif step is Step.RESULT and isinstance(msg, Result):
                self._on_result(msg, now_s)
            elif step is Step.RETIRE:
                self._lose(msg.sender, now_s, status="out of service")
            elif step is Step.HEARTBEAT and isinstance(msg, Heartbeat):
                self._on_heartbeat(msg, link, now_s)
            elif step is Step.PROGRESS:
                self.events.progress += 1
            elif step is Step.REPORT and isinstance(msg, (Heartbeat, Progress)):
                self._report(link, msg.state, msg.position_m)
                if self.sink is not None and self.uav_events:
                    self._emit_uav(now_s, link)

    def _report(self, link: UavLink, state: str, position_m: Vec3 | None) -> None:
        """A UAV's state and position (heartbeat or progress): its flight shrinks behind it; on its pad, done
        flying, it holds only the pad."""
        link.state = state
        if position_m is None:
            return
        link.moved_to(position_m)
        name = link.spec.name
        if position_m[2] - link.spec.home_m[2] > ON_PAD_Z_M:
            link.taking_off = False  # it is in the air: whatever it reports from now on is after its take-off
        self.columns.progress(name, position_m)
        if state == LANDED_STATE and not link.taking_off and self.dispatcher.task_of(name) is None:
            # (one landed with its task, for a fresh battery, takes off again on its own: it keeps its column)
            self.columns.landed(name, position_m)

    def _on_clearance_request(self, msg: ClearanceRequest, now_s: float) -> None:
        """A UAV asks for a flight (or says it left a column, or came down): the airspace answers."""
        if msg.release:
            self.columns.release(msg.sender, msg.site_m)
            if self.sites.released(msg.sender, msg.site_m, now_s):
                self.columns.touch()
            return
        if msg.arrived:
            self.columns.end_transit(msg.sender)
            return
        if msg.position_m is not None:
            self.columns.progress(msg.sender, msg.position_m)
        if self.sites.leaving(msg.sender, msg.site_m, now_s):
            self.columns.touch()  # a site is free: who waits for it may go now
        g = self.columns.request(msg.sender, msg.site_m, now_s, msg.position_m, msg.top_m, msg.to_m)
        self.waits.answered(msg.sender, self.dispatcher.task_of(msg.sender), g.site_m, g.granted)
        self._emit_clearance(now_s, g)
        if g.refused is not None:
            self._fail_outside_fence(msg.sender, g.refused, now_s)
        self._answer(g, now_s)

    def _answer(self, g: Grant, now_s: float) -> None:
        """Send the airspace's answer ``g`` to its UAV."""
        radius_m = self.columns.release_radius_m
        answer = Clearance(MISSION_CONTROL, g.uav, g.site_m, radius_m, now_s, g.granted, g.hold_m, g.layer_m)
        self._send(g.uav, answer)

    def _fail_outside_fence(self, uav: str, reason: str, now_s: float) -> None:
        """``uav``'s flight can only be flown outside the site's fence: its task fails with the reason (once per
        task in hand; the attempt counts, so a task no UAV can reach inside the fence ends stuck, saying why)."""
        task_id = self.dispatcher.task_of(uav)
        if task_id is None:
            return
        key = (uav, task_id, self.dispatcher.attempt_of(task_id))
        if key in self._fence_failed:
            return
        self._fence_failed.add(key)
        self.recall(uav, now_s, reason)

    def _on_result(self, msg: Result, now_s: float) -> None:
        r = msg.result
        att = self.ledger.running.get(r.task_id)
        least_s = self.min_durations_s.get(r.task_id)
        owner = self.dispatcher.in_progress.get(r.task_id)
        ignored = screen_result(msg, owner, att, least_s, self.min_fraction, now_s)
        if ignored is not None:
            self._ignore(ignored.reason, ignored.detail)
            return
        assert att is not None  # (screen_result ignores a result with no running attempt)
        if r.status == "done":
            self.ledger.done(att, r, now_s)
            log.info("%s done by %s (attempt %d) at %.1f s", r.task_id, msg.sender, att.attempt, now_s)
            self.dispatcher.complete(r.task_id)
            if self.glue is not None:
                self.glue.completed(r.task_id, now_s)
            self.ledger.journal_done(now_s, r, msg.sender)
            self._emit(
                now_s,
                "completed",
                msg.sender,
                r.task_id,
                attempt=att.attempt,
                placement_error_m=r.placement_error_m,
                coverage=r.coverage,
                **self.placement.event_fields(r.as_built),
            )
            self.placement.completed(self, r, msg.sender, now_s)
        else:
            reason = r.reason or "failed"
            self.ledger.end(att, now_s, "failed", reason)
            take_result(att, r)
            log.info(
                "%s failed on %s (attempt %d, %.1f-%.1f s): %s",
                *(r.task_id, msg.sender, att.attempt, att.start_s, now_s, reason),
            )
            # abandoned for the UAV's battery (it lands for a fresh pack) or recalled by the operator: not an
            # attempt of the task
            count, give_up = self.spares.failed(r.task_id, reason, now_s)  # (its brick gone: a spare)
            self.dispatcher.fail(r.task_id, count=count, give_up=give_up)
            self.ledger.journal_failed(now_s, r.task_id, msg.sender, reason)
            self._emit(now_s, "failed", msg.sender, r.task_id, attempt=att.attempt, reason=reason)
        self._dirty = True

    def _ignore(self, reason: str, detail: str) -> None:
        self.out.ignored(reason)
        log.warning("ignoring %s", detail)

    def _screened(self, link: UavLink, msg: Message, now_s: float) -> bool:
        """True when ``msg`` needs nothing more: a late completion taken, or anything else from a UAV declared lost
        (it stays lost until a heartbeat says it holds no task: :meth:`_readmit`; its task went to another)."""
        if isinstance(msg, Result) and (self._heard_again(msg) or self._late_result(msg, now_s)):
            return True
        return link.lost and not self._readmit(link, msg, now_s)

    def _heard_again(self, msg: Result) -> bool:
        """A completion already taken, said again by its UAV (the handler repeats one when mission control's
        heartbeats paused around it, as a slow link or a busy computer makes them): nothing to do, nothing
        suspicious."""
        r = msg.result
        return r.status == "done" and self.ledger.completed(r.task_id, msg.sender, msg.attempt)

    def _late_result(self, msg: Result, now_s: float) -> bool:
        """A completion from a UAV its task was released from (:func:`~masonry.mission.reducer.late_completion`):
        done, and a UAV flying it again is recalled. True if taken."""
        r = msg.result
        att = self.ledger.last_of(r.task_id, msg.sender)
        settled = r.task_id in self.dispatcher.done or r.task_id in self.dispatcher.stuck
        if att is None or not late_completion(msg, att, settled, self.dispatcher.in_progress.get(r.task_id)):
            return False
        other = self.dispatcher.complete_late(r.task_id)
        log.warning("%s done by %s (attempt %d), heard late: taken", r.task_id, msg.sender, att.attempt)
        self.ledger.done(att, r, now_s)
        if other is not None:
            why = f"{RECALL_REASON}: {r.task_id} was done by {msg.sender}"
            again = self.ledger.running.get(r.task_id)
            if again is not None:
                self.ledger.end(again, now_s, "failed", why, result=False)
                self.ledger.journal_failed(now_s, r.task_id, other, why)
            self.recall(other, now_s, why)
        self.ledger.journal_done(now_s, r, msg.sender, phases=False)
        self._emit(now_s, "completed", msg.sender, r.task_id, attempt=att.attempt)
        self._dirty = True
        return True

    def _on_heartbeat(self, msg: Heartbeat, link: UavLink, now_s: float) -> None:
        """What a UAV's heartbeat says besides its state: its battery, the wind its autopilot measures and its
        wind limit, and the task it holds."""
        if msg.battery is not None:
            link.battery = msg.battery
        if self.heard_wind is not None and (msg.wind_mps is not None or msg.max_wind_mps is not None):
            self.heard_wind.heard(msg.sender, now_s, msg.wind_mps, msg.max_wind_mps)
        self._check_holds_task(msg, now_s)

    def _check_holds_task(self, msg: Heartbeat, now_s: float) -> None:
        """A UAV's heartbeat says it forgot its task (:func:`~masonry.mission.reducer.dropped_reason`): the task
        goes back to the pool without counting an attempt."""
        name = msg.sender
        tid = self.dispatcher.task_of(name)
        att = None if tid is None else self.ledger.running.get(tid)
        reason = dropped_reason(msg, att, now_s, self.heartbeat_timeout_s)
        if tid is None or att is None or reason is None:
            return
        log.warning("%s: %s: released", name, reason)
        self.ledger.end(att, now_s, "failed", reason)
        self.dispatcher.fail(tid, count=False)
        self.ledger.journal_failed(now_s, tid, name, reason)
        self._emit(now_s, "failed", name, tid, attempt=att.attempt, reason=reason)
        self._dirty = True

    def _readmit(self, link: UavLink, msg: Message, now_s: float) -> bool:
        """A UAV declared lost for its silence is heard again: back in the mission if its heartbeat says it holds
        no task and is in service (a radio that came back after its task was given away, a handler restarted),
        holding its pad, or the column where it hovers, in the airspace (``ColumnClearance.rejoined``);
        anything else it sends stays ignored (a late result of a task that went to another UAV)."""
        if link.liveness is not Liveness.LOST or not isinstance(msg, Heartbeat) or msg.task_id is not None:
            return False
        if msg.state == OUT_OF_SERVICE_STATE or self.ended_at_s is not None:
            return False
        name = link.spec.name
        way_home = way_home_of(msg.state, link.way_via_m, self.fallback_layers_m.get(name))
        if not self.columns.rejoined(name, msg.position_m, way_home):
            return False
        if not self.dispatcher.readmit_uav(name):
            return False
        log.warning("UAV %s heard again (%s, no task): back in the mission", name, msg.state or "-")
        self.liveness.rejoin(link)
        self.events.rejoined += 1
        self._emit_uav(now_s, link)  # its status is "ok" again (a log, a live view)
        self._dirty = True
        return True

    def _check_heartbeats(self, now_s: float) -> None:
        for name, lapse in self.liveness.sweep(now_s, lambda n: self.dispatcher.task_of(n) is not None):
            if lapse is Lapse.AIRSPACE_EXPIRED:
                self.columns.release(name)  # not heard again: it fell, or landed where it was
            else:
                quiet_s = now_s - (self.uavs[name].last_heard_s or now_s)
                log.warning("UAV %s silent for %.1f s: lost", name, quiet_s)
                self._lose(name, now_s)

    def _lose(self, name: str, now_s: float, status: str = "lost") -> None:
        """Take a UAV out of the mission (silent, or out of service); its task goes back to the pool."""
        link = self.uavs[name]
        self.liveness.lose(link, now_s, out_of_service=status != "lost")
        task_id = self.dispatcher.task_of(name)
        task = self.spares.task(self._tasks[task_id]) if task_id is not None else None
        # last heard with its brick on the magnet: it may have taken it down with it, or puts it back first
        carried = task if link.state in CARRYING_STATES and isinstance(task, BrickTask) else None
        if status == "lost" and self.columns.volumes(name):
            # silent: it may be cut off and hovering where it stopped, inside what it was granted (its rule when
            # mission control is silent), and fly home on its own after LAST_RESORT_S: both stay reserved until
            # it is heard again, or for as long as that flight takes
            link.airspace_until_s = now_s + self.rejoin_timeout_s
            # (carrying, it puts the brick back on its pallet first: docs/state-machines.md, "Putting a brick back")
            link.way_via_m = carried.pickup_m if carried is not None else None
            # (last heard on its pad too: it may have been taking off, and hovers over the pad asking to land)
            if link.position_m is not None:
                layer_m = self.fallback_layers_m.get(name)
                way_m = self.columns.silent(name, link.position_m, layer_m, link.way_via_m)
                way_s = way_home_s(way_m, (self.timing or DEFAULT_TIMING).vertical_speed_mps)
                link.airspace_until_s = now_s + max(self.rejoin_timeout_s, way_s)
        else:
            self.columns.release(name)  # retired (on the ground) or fell: its column is free
        if self.sites.left(name, now_s):
            self.columns.touch()
        released = self.dispatcher.remove_uav(name)
        att = None if released is None else self.ledger.running.get(released)
        if released is not None and att is not None:
            brick = carried.brick if status == "lost" and carried is not None else None
            reason = loss_reason(None if status == "lost" else status, link.state, brick)
            self.ledger.end(att, now_s, "failed", reason, result=False)
            if brick is not None:
                self.spares.lost(released, reason, now_s)
            log.info("%s failed on %s (attempt %d): %s", released, name, att.attempt, reason)
        self.ledger.journal_lost(now_s, name)
        self._emit(now_s, "lost", name, released, status=status)
        self._dirty = True

    def _dispatch(self, now_s: float) -> None:
        self._dirty = False
        positions = {n: u.position_m for n, u in self.uavs.items() if u.position_m is not None and not u.lost}
        self._deferred_at = None
        for a in self.dispatcher.assign(positions or None, may_start=self._may_take_off):
            attempt = a.attempt
            self.ledger.begin(a.task_id, a.uav, attempt, now_s)
            self._raise_layers((a.task_id,))
            log.info("%s assigned to %s (attempt %d) at %.1f s", a.task_id, a.uav, attempt, now_s)
            self._emit(now_s, "assigned", a.uav, a.task_id, attempt=attempt)
            task = self.spares.task(
                self._tasks[a.task_id]
            )  # (with its spare, if one stands in for its brick)
            self._send(a.uav, Assign(MISSION_CONTROL, a.uav, task, attempt, now_s, self.wall_digest))

    def _may_take_off(self, name: str) -> bool:
        """A UAV landed on its pad takes a task only with the column over its pad for its take-off (reserved
        here): take-offs from neighbouring pads go one after the other."""
        if not self.operator.may_fly(self, name):
            return False  # recalled, or its role at the operator's fleet limit
        if self.wind_limit is not None and not self.wind_limit.allows(name):
            return False  # above its max_wind_mps: it finishes its task and lands
        if self.columns.phase(name) is Phase.LANDED and not self.columns.take_off(name):
            self._deferred_at = self.columns.version
            return False
        # from now on a report that it is landed may predate the assignment (it lands, then reads it)
        self.uavs[name].taking_off = True
        return True

    def _watch_progress(self, now_s: float) -> None:
        """The watchdog: progress is a task done or failed, a flight or hold flight granted, a UAV's state
        changed or a UAV lost; none for ``stall_timeout_s`` stops the mission with the wait-for graph."""
        if self.operator.paused or self.operator.held or self.operator.aborting:
            return  # waiting for the operator is no stall
        wind = self.wind_limit
        if wind is not None and wind.grounded:
            self._watch.observe(now_s, ("wind", wind.version))
            return  # waiting for the wind to drop is no stall either
        signature = (
            self.operator.version,
            self.ledger.results,
            self.columns.granted_count,
            self.columns.held_back,
            tuple((link.state, link.lost) for link in self.uavs.values()),
        )
        if not self._watch.observe(now_s, signature) or self.finished:
            return
        assert self._watch.since_s is not None and self._watch.timeout_s is not None
        live = [(name, link.state) for name, link in self.uavs.items() if not link.lost]
        self.stall = stall_of(
            now_s, self._watch.since_s, self._watch.timeout_s, live, self.dispatcher, self.columns
        )
        log.warning("%s", self.stall.line())
        self._emit(now_s, "stall", line=self.stall.line())

    def _on_wind(self, now_s: float) -> None:
        """The wind grounded or freed UAVs: say so, and dispatch again."""
        wind = self.wind_limit
        assert wind is not None
        self._dirty = True
        speed = wind.speed_mps if wind.speed_mps is not None else math.nan
        grounded = sorted(wind.grounded)
        if grounded:
            log.warning("wind %.1f m/s: no tasks for %s (above max_wind_mps)", speed, ", ".join(grounded))
        else:
            log.info("wind %.1f m/s: every UAV within its max_wind_mps, dispatching again", speed)
        self._emit(now_s, "wind", speed_mps=None if math.isnan(speed) else float(speed), grounded=grounded)

    def _journal_visit(self, visit: SiteVisit) -> None:
        """A site interval started or ended: journaled (the last visit of each task), for a resumed report."""
        if self.journal is not None:
            self.journal.set_meta(
                f"{SITE_META_PREFIX}{visit.task_id}",
                {"uav": visit.uav, "start_s": visit.start_s, "end_s": visit.end_s},
            )

    def _raise_layers(self, task_ids: Iterable[str]) -> None:
        """These tasks' bricks may be on the wall now: transit layers granted from now on clear them."""
        if self._layer_floor_m is None:
            return
        top = max(
            (
                task_work_altitude_m(self._tasks[tid], self._layer_floor_m, timing=self.timing)
                for tid in task_ids
            ),
            default=None,
        )
        if top is not None:
            self.columns.raise_base(top)

    def _on_command(self, msg: OperatorCommand, now_s: float) -> None:
        """An operator's command over the network: applied now, answered to the operator. ``masonry ctl`` sends
        it again until it hears the answer: a command already answered (its ``id``) is answered again, not
        applied twice."""
        answer = self.operator.answered.get(msg.id) if msg.id else None
        if answer is None:
            command = {"command": msg.command, "uav": msg.uav, "role": msg.role, "limit": msg.limit}
            out = self.operator.apply(self, {k: v for k, v in command.items() if v is not None}, now_s)
            answer = CommandAnswer(MISSION_CONTROL, msg.id, msg.command, out.accepted, out.reason, now_s)
            if msg.id:
                self.operator.answered[msg.id] = answer
        self._send(OPERATOR, answer)

    def wake(self) -> None:
        """Dispatch again at the next step (the operator resumed, or changed a limit)."""
        self._dirty = True

    def recall(self, uav: str, now_s: float, reason: str) -> None:
        """Tell ``uav`` to drop its task, fly home and land (the operator's recall)."""
        self._send(uav, Recall(MISSION_CONTROL, uav, now_s, reason))

    def emit_event(
        self, now_s: float, kind: str, uav: str | None = None, task_id: str | None = None, **fields: object
    ) -> None:
        """Hand an event to the sink, if any (the operator's commands)."""
        self.out.emit(now_s, kind, uav, task_id, **fields)

    def _emit(
        self, now_s: float, kind: str, uav: str | None = None, task_id: str | None = None, **fields: object
    ) -> None:
        self.out.emit(now_s, kind, uav, task_id, **fields)

    def _emit_clearance(self, now_s: float, g: Grant) -> None:
        if self.sink is not None:
            self._emit(
                now_s,
                "clearance",
                g.uav,
                self.dispatcher.task_of(g.uav),
                site_m=list(g.site_m),
                granted=g.granted,
                hold_m=None if g.hold_m is None else list(g.hold_m),
                layer_m=g.layer_m,
                volumes=volume_list(self.columns.volumes(g.uav)),
            )

    def _emit_uav(
        self, now_s: float, link: UavLink, position_m: Vec3 | None = None, battery: float | None = None
    ) -> None:
        """A UAV's state, position, task and airspace as mission control knows them (its position and battery
        as measured elsewhere, if given)."""
        name = link.spec.name
        p = link.position_m if position_m is None else position_m
        self._emit(
            now_s,
            "uav",
            name,
            self.dispatcher.task_of(name),
            state=link.state,
            position_m=None if p is None else list(p),
            battery=link.battery if battery is None else battery,
            status=link.status,
            volumes=volume_list(self.columns.volumes(name)),
        )

    def sample(self, now_s: float, positions_m: Mapping[str, Vec3], batteries: Mapping[str, float]) -> None:
        """Hand the sink a ``uav`` event per live UAV, with its position and battery measured outside mission
        control (the simulator's world); mission control's own view is unchanged."""
        if self.sink is None:
            return
        for name, link in self.uavs.items():
            if name in positions_m and not link.lost:
                self._emit_uav(now_s, link, positions_m[name], batteries.get(name))

    def _send(self, to: str, msg: Message) -> None:
        self.out.send(to, msg)

    def _broadcast(self, msg: Message) -> None:
        self.out.broadcast(msg, [name for name, link in self.uavs.items() if not link.lost])
