"""The UAV side of the mission protocol: one handler per UAV owns its state machine and its MissionLink.

``UavHandler`` is the :class:`~masonry.ports.MissionLink` the state machine (``masonry.fsm``) talks to:
``poll_task`` hands over the task mission control assigned, ``report_progress`` and ``report_result`` become
messages. ``step(now_s)`` reads the transport, sends the UAV's heartbeat, and ticks the machine. It keeps
its own trace of what the UAV actually executed (``executions``), from which the simulator measures
conflict and dependency violations independently of mission control's bookkeeping.

With a ``battery`` and a ``swap_battery`` (the simulator's ground crew), the handler keeps a battery reserve
(:class:`~masonry.mission.handler_battery.GroundCrew`, a base class of the handler).

Airspace (docs/safety.md): the columns over the sites, asked for and freed by
:class:`~masonry.mission.handler_columns.ColumnRequests`, a base class of the handler.

Assignments are checked against the UAV's own blueprint (:class:`~masonry.mission.handler_check.AssignmentCheck`,
docs/security.md). Anything else is refused: counted in ``refused``, logged, answered with a failed result naming
the reason (two blueprint files), unless that task is in hand or queued here: then the refused message cannot be
mission control's.

Mission control's heartbeat is watched: silent past the timeout (``mission_control_lost``), a UAV that had heard
it abandons its tasks (failed, ``mission control lost``: no attempt counted) and flies home (mission control
gave them to another UAV, or a resumed one flies them). Heard again with no task, it is taken back.

The handler's parts, each a small module: the attempt record (:mod:`masonry.mission.execution`), what the parts
share (:mod:`masonry.mission.handler_base`), the results and the kept completion
(:mod:`masonry.mission.handler_results`), the site columns (:mod:`masonry.mission.handler_columns`), the battery
reserve and ground crew (:mod:`masonry.mission.handler_battery`), the assignment check
(:mod:`masonry.mission.handler_check`), the recalls (:mod:`masonry.mission.handler_recall`); this module holds the
queue, the heartbeat and the refusals.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

from masonry.errors import ProtocolError
from masonry.mission.execution import Execution
from masonry.mission.handler_base import Vec3
from masonry.mission.handler_battery import TOP_UP_FRACTION, GroundCrew
from masonry.mission.handler_check import AssignmentCheck
from masonry.mission.handler_columns import ColumnRequests
from masonry.mission.handler_recall import Recalls
from masonry.mission.handler_results import ResultKeeper, ResultReports
from masonry.mission.messages import (
    MAX_REPORTED_WIND_MPS,
    MISSION_CONTROL,
    Assign,
    Clearance,
    Heartbeat,
    MissionEnd,
    Progress,
    Recall,
    decode,
)
from masonry.mission.transport import Transport
from masonry.mission.uav_facts import OUT_OF_SERVICE_STATE, facts_of
from masonry.planner.tasks import Task
from masonry.ports import MISSION_CONTROL_LOST_REASON, ClearanceLink, MissionLink
from masonry.spares import Spare

log = logging.getLogger(__name__)


#: Refusals kept in ``UavHandler.refused`` (and logged); later ones are only counted in ``rejected``.
MAX_REFUSALS_KEPT = 1000


class UavHandler(ResultReports, Recalls, ColumnRequests, GroundCrew, MissionLink, ClearanceLink):
    """Bridge between a transport and one UAV's state machine.

    Construct the handler, build the machine with ``link=handler``, then :meth:`attach` it.

    Args:
        name: the UAV's name (its transport endpoint has the same name).
        transport: the UAV's endpoint.
        position: returns the UAV's current position (for heartbeats and results; mission control's
            ``nearest`` policy uses it).
        heartbeat_period_s: how often the handler sends its heartbeat.
        heartbeat_timeout_s: mission control silent for longer counts as lost.
        battery, swap_battery, reserve_fraction: the battery reserve (see the module docstring).
        return_brick: the ground crew's hands: takes brick N off the landed UAV's magnet and lays it back at its
            pickup, True once done (a UAV that flew home with its brick; docs/state-machines.md).
        report_battery: the battery (0..1) the heartbeats report, without a reserve (a remote UAV's autopilot);
            default ``battery``.
        after_result: called right after a result is sent; the in-process simulation steps mission control
            there, so that the answer (the next task) is in the inbox when the machine polls for it, as with a
            network round trip shorter than a tick.
        tasks, spares, role, wall_digest: the UAV's blueprint, to check every assignment against (its plan's
            tasks and spares, its role, :func:`masonry.fingerprint.wall_digest`); None: that check is not made.
        keeper: keeps the completion mission control has not heard yet; a completion it kept from before a
            restart is said first thing, ahead of the first heartbeat, and again when mission control is first
            heard (mission control ignores what it had).
    """

    def __init__(
        self,
        name: str,
        transport: Transport,
        *,
        position: Callable[[], Vec3] | None = None,
        heartbeat_period_s: float = 1.0,
        heartbeat_timeout_s: float = 5.0,
        battery: Callable[[], float] | None = None,
        swap_battery: Callable[[], bool] | None = None,
        return_brick: Callable[[int], bool] | None = None,
        report_battery: Callable[[], float] | None = None,
        wind: Callable[[], float | None] | None = None,
        max_wind_mps: float | None = None,
        reserve_fraction: float = 0.4,
        top_up_fraction: float = TOP_UP_FRACTION,
        after_result: Callable[[], None] | None = None,
        tasks: Iterable[Task] | None = None,
        spares: Iterable[Spare] | None = None,
        role: str | None = None,
        wall_digest: str | None = None,
        keeper: ResultKeeper | None = None,
    ) -> None:
        self._check = AssignmentCheck.of(tasks, spares, role, wall_digest)
        self.refused: list[str] = []
        self._init_battery(
            battery, swap_battery, return_brick, report_battery, reserve_fraction, top_up_fraction
        )
        #: what the heartbeats say of the wind (the autopilot's reading) and of this UAV's limit (uav.yaml)
        self._wind = wind
        self._max_wind_mps = max_wind_mps
        self.name = name
        self.transport = transport
        self._position = position
        self.heartbeat_period_s = heartbeat_period_s
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.model = None
        self._queue: deque[tuple[Task, int, float]] = deque()  # task, attempt, when its assignment came
        self._current: Execution | None = None
        self._init_recalls()
        self._last_sent_hb_s: float | None = None
        self._last_mc_s: float | None = None
        self.mission_ended = False
        self.mission_completed: bool | None = None
        self.executions: list[Execution] = []
        self.rejected = 0
        self.now_s = 0.0
        self._init_columns()
        self._init_results(keeper, after_result)

    def attach(self, model: Any) -> None:
        """Give the handler the state machine it drives (built with ``link=self``)."""
        self.model = model

    @property
    def mission_control_lost(self) -> bool:
        """Mission control has been silent past the heartbeat timeout (or never heard)."""
        return self._last_mc_s is None or self.now_s - self._last_mc_s > self.heartbeat_timeout_s

    def _mission_control_gone(self) -> bool:
        """Mission control was heard, then fell silent long enough that it may declare this UAV lost soon (never
        heard: nothing was assigned).

        Two heartbeat periods before the timeout: mission control may have last heard this UAV up to a period
        before this UAV last heard it, and it must not give the task to another while this UAV is still on it.
        """
        patience_s = max(self.heartbeat_period_s, self.heartbeat_timeout_s - 2.0 * self.heartbeat_period_s)
        return self._last_mc_s is not None and self.now_s - self._last_mc_s > patience_s

    @property
    def mission_control_heard_s(self) -> float | None:
        """When mission control was last heard from (None: never)."""
        return self._last_mc_s

    def _wind_reading(self) -> float | None:
        """The autopilot's wind now (m/s, within what a heartbeat may carry), or None."""
        if self._wind is None:
            return None
        w = self._wind()
        if w is None or not math.isfinite(w):
            return None
        return min(MAX_REPORTED_WIND_MPS, max(0.0, float(w)))

    @property
    def busy(self) -> bool:
        """A task is queued or in hand."""
        return bool(self._queue) or self._current is not None

    @property
    def finished(self) -> bool:
        """The mission is over for this UAV: mission control said so, no task left, the machine has landed."""
        return self.mission_ended and not self.busy and (self.model is None or bool(self.model.finished))

    # -- MissionLink -----------------------------------------------------------------------------------
    def poll_task(self) -> Task | None:
        if self._current is not None:
            return None
        if not self._queue:
            # the answer to a result just sent may already be here (the machine polls right after reporting)
            self.pump()
            if not self._queue:
                return None
        if self._held_for_swap(self._queue[0][0]):
            return None  # the battery reserve holds it (:mod:`masonry.mission.handler_battery`)
        task, attempt, received_s = self._queue.popleft()
        self._ask_afresh()
        self._current = Execution(
            task.id, self.name, attempt, self.now_s, queued_s=max(0.0, self.now_s - received_s)
        )
        self.executions.append(self._current)
        return task

    def report_progress(self, task_id: str, state: str, time_s: float) -> None:
        f = facts_of(
            state
        )  # (the handler knows its machine: mission control reads these, not the state name)
        where = self._where()
        self._send(
            Progress(
                self.name,
                task_id,
                state,
                time_s,
                where,
                carrying=f.carrying,
                flying_home=f.flying_home,
                on_pad=f.on_pad,
                finishing=f.finishing,
                out_of_service=f.out_of_service,
                plan_progress=self._plan_progress(where),
            )
        )

    def pump(self) -> bool:
        """Read what has arrived now (between ticks); True if a task is waiting for the machine."""
        for raw in self.transport.receive():
            self._handle(raw, self.now_s)
        return bool(self._queue)

    def keep_alive(self, now_s: float) -> None:
        """Between ticks, while the machine waits inside a call (an autopilot refusing to arm for a while): read
        what has arrived and send the heartbeat when due, so that mission control does not declare this UAV lost
        (issue 29; the flight controller calls it: :class:`masonry.ports.WaitsAlive`)."""
        self.now_s = max(self.now_s, now_s)
        self._read_and_beat(self.now_s)

    def _read_and_beat(self, now_s: float) -> None:
        """Handle what has arrived, then send the heartbeat when due (the tick's first duties, and the wait's)."""
        for raw in self.transport.receive():
            self._handle(raw, now_s)
        self._heartbeat_when_due(now_s)

    def say_finished(self, now_s: float) -> None:
        """The run ends (:attr:`finished`: on its pad): a heartbeat now, whatever is due, so that mission control,
        which answers until every UAV has landed (``MissionControl.may_leave``), hears it landed at once."""
        self._last_sent_hb_s = None
        self._heartbeat_when_due(now_s)

    def _heartbeat_when_due(self, now_s: float) -> None:
        if self._last_sent_hb_s is not None and now_s - self._last_sent_hb_s < self.heartbeat_period_s:
            return
        self._last_sent_hb_s = now_s
        self._resend_unheard(now_s)
        cur = self._current
        state = self._state()
        f = facts_of(state)
        where = self._where()
        self._send(
            Heartbeat(
                self.name,
                now_s,
                state=state,
                # the task in hand, or the one queued for it (mission control releases a task its UAV's
                # heartbeats say it does not hold: a handler restarted)
                task_id=cur.task_id if cur else (self._queue[0][0].id if self._queue else None),
                position_m=where,
                battery=None
                if self._report_battery is None
                else min(1.0, max(0.0, float(self._report_battery()))),
                wind_mps=self._wind_reading(),
                max_wind_mps=self._max_wind_mps,
                swaps_batteries=self.swaps_batteries,
                carrying=f.carrying,
                flying_home=f.flying_home,
                on_pad=f.on_pad,
                finishing=f.finishing,
                out_of_service=f.out_of_service,
                plan_progress=self._plan_progress(where),
            )
        )

    # -- the tick --------------------------------------------------------------------------------------
    def step(self, now_s: float) -> None:
        """Read messages, send the heartbeat when due, tick the machine (skipped while landed and idle)."""
        self.now_s = now_s
        if self._kept is not None:
            self._say_kept(now_s)
        # _read_and_beat, inline (every tick of every UAV): the heartbeat's call only when one is due
        for raw in self.transport.receive():
            self._handle(raw, now_s)
        last_hb_s = self._last_sent_hb_s
        if last_hb_s is None or now_s - last_hb_s >= self.heartbeat_period_s:
            self._heartbeat_when_due(now_s)
        if (self._column is not None or self._columns_left) and now_s - self._column_checked_s >= 0.2:
            self._check_columns(now_s)  # (its own early return, checked here first)
        busy = bool(self._queue) or self._current is not None  # busy, inline
        if busy and self._mission_control_gone():
            # mission control has declared this UAV lost by now (the same timeout) and given its task to another
            # UAV, or it has crashed and a resumed one flies the task again: carrying on would do it twice
            why = f"{MISSION_CONTROL_LOST_REASON} ({now_s - (self._last_mc_s or now_s):.1f} s silent)"
            if self._recall_held(why):
                log.warning("%s: %s: abandoning its task, flying home", self.name, why)
        if self._recalls:
            self._apply_recalls()
        model = self.model
        if model is not None and (self._queue or self._current is not None or not model.finished):
            model.step(now_s)
        elif model is not None:
            self._top_up_while_idle()  # landed with nothing to do

    def _handle(self, raw: bytes, now_s: float) -> None:
        try:
            msg = decode(raw)
        except ProtocolError as exc:
            self.rejected += 1
            log.warning("%s rejected a message: %s", self.name, exc)
            return
        if msg.sender != MISSION_CONTROL:
            return
        before, self._last_mc_s = self._last_mc_s, now_s
        self._heard_after(before, now_s)
        if isinstance(msg, Assign):
            if msg.uav != self.name:
                self.rejected += 1
                log.warning("%s got an assignment addressed to %s", self.name, msg.uav)
                return
            why = self._check.refusal(msg)
            if why is not None:
                self._refuse(msg, why)
                return
            self._queue.append((msg.flown, msg.attempt, now_s))  # (planned on the wall as built)
            self.mission_ended = False
        elif isinstance(msg, Clearance):
            self._on_clearance(msg)
        elif isinstance(msg, MissionEnd):
            self.mission_ended = True
            self.mission_completed = msg.completed
        elif isinstance(msg, Recall) and msg.uav == self.name:
            self._take_recall(msg)  # applied at the next tick, outside the machine's callbacks

    def _refuse(self, msg: Assign, why: str) -> None:
        self.rejected += 1
        if len(self.refused) < MAX_REFUSALS_KEPT:
            self.refused.append(why)
            log.warning("%s refused an assignment: %s", self.name, why)
        tid = msg.task.id
        if (self._current is not None and self._current.task_id == tid) or any(
            t.id == tid for t, _, _ in self._queue
        ):
            return  # the real assignment of that task is here: a failed result would cancel it
        self._send_failed(msg.task.id, msg.attempt, f"refused: {why}", self._state())


__all__ = ["MAX_REFUSALS_KEPT", "OUT_OF_SERVICE_STATE", "Execution", "ResultKeeper", "UavHandler"]
