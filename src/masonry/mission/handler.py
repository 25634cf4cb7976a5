"""The UAV side of the mission protocol: one handler per UAV owns its state machine and its MissionLink.

``UavHandler`` is the :class:`~masonry.ports.MissionLink` the state machine (``masonry.fsm``) talks to:
``poll_task`` hands over the task mission control assigned, ``report_progress`` and ``report_result`` become
messages. ``step(now_s)`` reads the transport, sends the UAV's heartbeat, and ticks the machine. It keeps
its own trace of what the UAV actually executed (``executions``), from which the simulator measures
conflict and dependency violations independently of mission control's bookkeeping.

With a ``battery`` and a ``swap_battery`` (the simulator's ground crew), the handler keeps a battery reserve:
below ``reserve_fraction`` a queued task is held back, so the machine flies home and lands, and starts once
the pack is swapped (mission control sees the task in progress meanwhile). That hold is the ``queued`` phase
the handler adds to the machine's phases in the result (docs/mission.md, "Where the time goes").

Airspace (docs/safety.md): ``request_clearance(site_m)`` is how the state machine asks for the column over a
site before leaving its transit layer; the handler sends a ``ClearanceRequest`` (again every heartbeat period
while unanswered), answers True once mission control's ``Clearance`` has come, and frees the column by itself
once the UAV is ``radius_m`` away from it horizontally or has landed. The answer also gives the altitude of the
lateral leg (a transit layer) and, while the column is taken, a hold point where the machine waits at that
layer; ``end_transit`` tells mission control the flight is down (its layer is free).

Assignments are checked against the UAV's own blueprint (docs/security.md): given its ``tasks``, ``spares``,
``role`` and ``wall_digest``, it takes a task only with the same wall digest, one of the blueprint's tasks (same
id and geometry, or with one of its spares of that size in the brick's place) of the UAV's role. Anything else
is refused: counted in ``refused``, logged, answered with a failed result naming the reason (two blueprint
files), unless that task is in hand or queued here: then the refused message cannot be mission control's.

Mission control's heartbeat is watched: silent past the timeout (``mission_control_lost``), a UAV that had heard
it abandons its tasks (failed, ``mission control lost``: no attempt counted) and flies home (mission control
gave them to another UAV, or a resumed one flies them). Heard again with no task, it is taken back.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any, Protocol

from masonry.errors import ProtocolError
from masonry.mission.messages import (
    MAX_REPORTED_WIND_MPS,
    MISSION_CONTROL,
    Assign,
    Clearance,
    ClearanceRequest,
    Heartbeat,
    MissionEnd,
    Progress,
    Recall,
    Result,
    decode,
    encode,
)
from masonry.mission.spares import as_flown
from masonry.mission.transport import Transport
from masonry.planner.tasks import BrickTask, Task
from masonry.ports import (
    FINISHING_STATES,
    LAST_RESORT_S,
    MISSION_CONTROL_LOST_REASON,
    ClearanceLink,
    MissionLink,
    TaskResult,
)
from masonry.spares import Spare

log = logging.getLogger(__name__)

#: The state a machine reports when it is out of service for the rest of the mission (as in control.py).
OUT_OF_SERVICE_STATE = "halted"

Vec3 = tuple[float, float, float]

#: Refusals kept in ``UavHandler.refused`` (and logged); later ones are only counted in ``rejected``.
MAX_REFUSALS_KEPT = 1000


@dataclass
class Execution:
    """One task as the UAV flew it: handed to the machine at ``start_s``, reported at ``end_s``.

    ``queued_s``: how long its assignment waited here before the machine took it (the battery reserve's hold).
    """

    task_id: str
    uav: str
    attempt: int
    start_s: float
    end_s: float | None = None
    status: str = "running"
    queued_s: float = 0.0
    reason: str | None = None  # why it failed, as the machine reported it
    #: when the handler abandoned it (mission control silent): from then on the machine only puts the brick back
    #: or flies home, away from the task's site, until it reports the failure
    abandoned_s: float | None = None


class ResultKeeper(Protocol):
    """Where a UAV keeps its last completion until mission control has heard it, across a restart of its handler
    (a real UAV's companion computer keeps it on its disk; the in-process simulation in its mission's journal
    file, because a stop of ``masonry sim`` stops its UAVs too)."""

    def kept(self, uav: str) -> bytes | None:
        """The completion ``uav`` kept (its wire form), or None."""
        ...

    def keep(self, uav: str, message: bytes | None) -> None:
        """Keep ``message`` for ``uav`` (None: forget it, mission control heard it); durable when it returns."""
        ...


class UavHandler(MissionLink, ClearanceLink):
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
        report_battery: Callable[[], float] | None = None,
        wind: Callable[[], float | None] | None = None,
        max_wind_mps: float | None = None,
        reserve_fraction: float = 0.4,
        after_result: Callable[[], None] | None = None,
        tasks: Iterable[Task] | None = None,
        spares: Iterable[Spare] | None = None,
        role: str | None = None,
        wall_digest: str | None = None,
        keeper: ResultKeeper | None = None,
    ) -> None:
        self._after_result = after_result
        self._keeper = keeper
        self._tasks = None if tasks is None else {t.id: t for t in tasks}
        self._spares = {sp.id: sp for sp in spares or ()}  # (one may stand in for a brick)
        self._role = role
        self._wall_digest = wall_digest
        self.refused: list[str] = []
        self._battery = battery
        self._swap_battery = swap_battery
        #: what the heartbeats say of the battery (the reserve's, or ``report_battery``'s)
        self._report_battery = report_battery if report_battery is not None else battery
        #: what the heartbeats say of the wind (the autopilot's reading) and of this UAV's limit (uav.yaml)
        self._wind = wind
        self._max_wind_mps = max_wind_mps
        self.reserve_fraction = reserve_fraction
        self.battery_swaps = 0
        self._held_for: str | None = None  # why the battery budget holds the next task (logged once)
        self.name = name
        self.transport = transport
        self._position = position
        self.heartbeat_period_s = heartbeat_period_s
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.model: Any = None
        self._queue: deque[tuple[Task, int, float]] = deque()  # task, attempt, when its assignment came
        self._current: Execution | None = None
        #: the operator recalled this UAV (the reason): its task is dropped at the next tick it can be
        self._recall: str | None = None
        self._last_sent_hb_s: float | None = None
        self._last_mc_s: float | None = None
        self.mission_ended = False
        self.mission_completed: bool | None = None
        self.executions: list[Execution] = []
        self.rejected = 0
        self.now_s = 0.0
        self._column: Vec3 | None = None  # site of the column last asked for (granted or not)
        self._column_granted = False
        # a new attempt asks again even for the column it was granted last (issue 19): it may have flown off
        self._column_stale = False
        self._column_answer: Clearance | None = None
        self._columns_left: list[Vec3] = []  # granted earlier, freed once the UAV is out of them
        self._column_radius_m = 0.0
        self._column_sent_s = -1e18
        self._column_top_m: float | None = None
        self._column_to_m: Vec3 | None = None
        self._column_checked_s = -1e18
        self.clearance_requests = 0
        self._unheard: tuple[Result, float] | None = None  # the last completion sent, and when
        self._kept = self._restore_kept()  # a completion from before a restart: said at the first step
        self._swallow: str | None = (
            None  # a task dropped (mission control silent): its machine's report is not sent
        )

    def _restore_kept(self) -> Result | None:
        raw = self._keeper.kept(self.name) if self._keeper is not None else None
        if raw is None:
            return None
        try:
            msg = decode(raw)
        except ProtocolError as exc:
            log.warning("%s: the kept completion cannot be read (%s): forgotten", self.name, exc)
            return None
        if not isinstance(msg, Result) or msg.sender != self.name or msg.result.status != "done":
            log.warning("%s: the kept message is not a completion of this UAV: forgotten", self.name)
            return None
        return msg

    def _say_kept(self, now_s: float) -> None:
        """The first step after a restart: the completion mission control may never have heard, ahead of the
        heartbeat (which names no task: heard first, it would give the task back to the pool)."""
        kept, self._kept = self._kept, None
        if kept is None:
            return
        log.info("%s: %s done before the restart: reported again", self.name, kept.result.task_id)
        self._send(kept)
        self._unheard = (kept, -math.inf)  # said again when mission control is first heard (_handle)

    def _keep(self, sent: Result | None) -> None:
        if self._keeper is not None:
            self._keeper.keep(self.name, None if sent is None else encode(sent))

    def attach(self, model: Any) -> None:
        """Give the handler the state machine it drives (built with ``link=self``)."""
        self.model = model

    @property
    def mission_control_lost(self) -> bool:
        """Mission control has been silent past the heartbeat timeout (or never heard)."""
        return self._last_mc_s is None or self.now_s - self._last_mc_s > self.heartbeat_timeout_s

    def _resend_unheard(self, now_s: float) -> None:
        """While mission control is silent since before the last completion was sent, say the completion again
        with every heartbeat, ahead of it: the link may be down, and the first thing mission control hears
        when it is back is then the completion, before the heartbeat that takes this UAV back (a task declared
        released and given to it again would be flown twice)."""
        if self._unheard is None:
            return
        sent, sent_s = self._unheard
        last = self._last_mc_s
        if last is not None and last <= sent_s and now_s - last > 1.5 * self.heartbeat_period_s:
            self._send(sent)

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

    @property
    def swaps_batteries(self) -> bool:
        """A ground crew swaps the battery before a task starts (the reserve): a low battery needs no retirement.

        The state machine reads this: with it, a battery run low in the air (e.g. waiting for a site column)
        aborts the task and lands the UAV at home, where the next task it is handed waits for the swap,
        instead of taking the UAV out of service.
        """
        return self._battery is not None and self._swap_battery is not None

    @property
    def out_of_service(self) -> bool:
        """The machine is out of service (state ``halted``): it refuses every task it is handed, at once.

        Such a UAV is handed its queued tasks without the battery reserve's hold, so that the refusal is not
        delayed past the moment mission control (told by the ``halted`` heartbeat) has released the task.
        """
        return self.model is not None and str(getattr(self.model, "state", "")) == OUT_OF_SERVICE_STATE

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
        if self._battery is not None and not self.out_of_service and self._needs_swap(self._queue[0][0]):
            # Battery reserve: the task waits while the machine, given nothing, flies home and lands; then
            # the ground crew (``swap_battery``, True once done) swaps the pack and the task starts.
            if self._swap_battery is None or not self._swap_battery():
                return None
            self.battery_swaps += 1
        task, attempt, received_s = self._queue.popleft()
        self._column_stale = self._column is not None and self._column_granted
        self._current = Execution(
            task.id, self.name, attempt, self.now_s, queued_s=max(0.0, self.now_s - received_s)
        )
        self.executions.append(self._current)
        return task

    def _needs_swap(self, task: Task) -> bool:
        """The battery is under ``reserve_fraction``, or (with a ground crew) does not cover ``task``: the
        machine's battery budget (its ``battery_shortfall``: the task's flight, a budget of waiting for
        clearance and the way home, at the drain it has measured; docs/state-machines.md, "Battery budget")."""
        assert self._battery is not None
        if self._battery() < self.reserve_fraction:
            return True
        shortfall = getattr(self.model, "battery_shortfall", None)
        if self._swap_battery is None or shortfall is None:
            return False
        why = shortfall(task)
        if why is not None and why != self._held_for:
            log.info("%s: %s holds it for a battery swap", self.name, why)
        self._held_for = why
        return why is not None

    def request_clearance(
        self, site_m: Vec3, top_m: float | None = None, to_m: Vec3 | None = None
    ) -> Clearance | None:
        """The UAV sets off for ``site_m``: mission control's answer (layer, column granted or hold point), or None.

        The first call for a site sends the request (again every heartbeat period while unanswered); the answer
        is None until mission control's has come, then the latest one (``granted`` turns true when the column
        is given). Mission control silent (a link down) is asked again every heartbeat period: the UAV hovers
        where it stopped, its task abandoned, until mission control answers. Without mission control (never
        heard, or silent for ``LAST_RESORT_S``) there is nobody to ask: granted, no layer, so the UAV can land.
        """
        site = (float(site_m[0]), float(site_m[1]), float(site_m[2]))
        col = self._column
        same = col is not None and abs(col[0] - site[0]) < 1e-3 and abs(col[1] - site[1]) < 1e-3
        if same and self._column_granted and not self._column_stale:
            return self._column_answer
        if self._last_mc_s is None or self.now_s - self._last_mc_s > LAST_RESORT_S:
            # nobody to ask: never heard (no mission), or silent so long it is not coming back
            return Clearance(MISSION_CONTROL, self.name, site, 0.0, self.now_s, True, None, None)
        if not same:
            if col is not None and self._column_granted:
                self._columns_left.append(col)  # freed once the UAV is out of it
            elif col is not None:
                self._send(ClearanceRequest(self.name, col, self.now_s, release=True))  # no longer wanted
            self._column = site
            self._column_granted = False
            self._column_answer = None
            self._column_sent_s = self.now_s
            self.clearance_requests += 1
            self._column_top_m = top_m
            self._column_to_m = None if to_m is None else (float(to_m[0]), float(to_m[1]), float(to_m[2]))
            self._send(
                ClearanceRequest(
                    self.name, site, self.now_s, self._where(), top_m=top_m, to_m=self._column_to_m
                )
            )
        elif self._column_stale or self.now_s - self._column_sent_s >= (
            0.25
            if self._column_answer is not None and self._column_answer.hold_m is None
            else self.heartbeat_period_s
        ):  # refused for now (another flight in the way): ask again soon
            if self._column_stale:  # a new attempt: a fresh request from where it is now, not the old grant
                self._column_stale = False
                self._column_granted = False
                self._column_answer = None
                self.clearance_requests += 1
                self._column_top_m = top_m
                self._column_to_m = None if to_m is None else (float(to_m[0]), float(to_m[1]), float(to_m[2]))
            self._column_sent_s = self.now_s  # lost on the way? ask again (mission control keeps its place)
            self._send(
                ClearanceRequest(
                    self.name,
                    site,
                    self.now_s,
                    self._where(),
                    top_m=self._column_top_m,
                    to_m=self._column_to_m,
                )
            )
        self.pump()  # in-process, the answer may already be here
        return self._column_answer

    def end_transit(self, site_m: Vec3) -> None:
        """The flight to ``site_m`` has come down there: its layer is free."""
        self._send(
            ClearanceRequest(
                self.name, (float(site_m[0]), float(site_m[1]), float(site_m[2])), self.now_s, arrived=True
            )
        )

    @property
    def columns(self) -> tuple[Vec3, ...]:
        """Sites of the columns this UAV holds."""
        cur = (self._column,) if self._column is not None and self._column_granted else ()
        return tuple(self._columns_left) + cur

    def _check_columns(self, now_s: float) -> None:
        """Free columns the UAV has left (``radius_m`` away horizontally); all of them once it has landed."""
        if now_s - self._column_checked_s < 0.2:
            return
        self._column_checked_s = now_s
        model = self.model
        if model is not None and bool(model.finished):
            for col in [*self._columns_left, *([self._column] if self._column is not None else [])]:
                self._send(ClearanceRequest(self.name, col, now_s, release=True))
            self._columns_left = []
            self._column = None
            self._column_granted = False
            return
        if not self._columns_left or self._position is None:
            return
        p = self._position()
        r2 = self._column_radius_m**2
        keep = []
        for col in self._columns_left:
            if (p[0] - col[0]) ** 2 + (p[1] - col[1]) ** 2 >= r2:
                self._send(ClearanceRequest(self.name, col, now_s, release=True))
            else:
                keep.append(col)
        self._columns_left = keep

    def report_progress(self, task_id: str, state: str, time_s: float) -> None:
        self._send(Progress(self.name, task_id, state, time_s, self._where()))

    def report_result(self, result: TaskResult) -> None:
        cur = self._current
        if self._swallow == result.task_id and (cur is None or cur.task_id != result.task_id):
            self._swallow = None  # the failure of a task dropped when mission control fell silent: sent then
            return
        if cur is not None and cur.task_id == result.task_id:
            cur.end_s = self.now_s
            cur.status = result.status
            cur.reason = None if result.status == "done" else (result.reason or "no reason given")
            self._current = None
            if result.phases is not None and cur.queued_s > 0.0:
                # the machine measured from taking the task; the attempt began when its assignment came
                result = replace(
                    result, phases=replace(result.phases, queued=result.phases.queued + cur.queued_s)
                )
        attempt = cur.attempt if cur is not None and cur.task_id == result.task_id else 0
        state = str(getattr(self.model, "state", "")) if self.model is not None else ""
        if result.status == "done":
            log.info("%s: %s attempt %d done at %.1f s", self.name, result.task_id, attempt, self.now_s)
        else:
            log.info(
                "%s: %s attempt %d failed at %.1f s in state %s: %s",
                self.name,
                result.task_id,
                attempt,
                self.now_s,
                state or "-",
                result.reason or "no reason given",
            )
        sent = Result(self.name, result, self.now_s, self._where(), state=state, attempt=attempt)
        self._send(sent)
        if result.status == "done":
            self._unheard = (sent, self.now_s)  # said again if the link turns out to have been down (_handle)
            self._keep(sent)
        if self._after_result is not None:
            self._after_result()

    def pump(self) -> bool:
        """Read what has arrived now (between ticks); True if a task is waiting for the machine."""
        for raw in self.transport.receive():
            self._handle(raw, self.now_s)
        return bool(self._queue)

    # -- the tick --------------------------------------------------------------------------------------
    def step(self, now_s: float) -> None:
        """Read messages, send the heartbeat when due, tick the machine (skipped while landed and idle)."""
        self.now_s = now_s
        if self._kept is not None:
            self._say_kept(now_s)
        for raw in self.transport.receive():
            self._handle(raw, now_s)
        if self._last_sent_hb_s is None or now_s - self._last_sent_hb_s >= self.heartbeat_period_s:
            self._last_sent_hb_s = now_s
            self._resend_unheard(now_s)
            cur = self._current
            state = str(getattr(self.model, "state", "")) if self.model is not None else ""
            self._send(
                Heartbeat(
                    self.name,
                    now_s,
                    state=state,
                    # the task in hand, or the one queued for it (mission control releases a task its UAV's
                    # heartbeats say it does not hold: a handler restarted)
                    task_id=cur.task_id if cur else (self._queue[0][0].id if self._queue else None),
                    position_m=self._where(),
                    battery=None
                    if self._report_battery is None
                    else min(1.0, max(0.0, float(self._report_battery()))),
                    wind_mps=self._wind_reading(),
                    max_wind_mps=self._max_wind_mps,
                )
            )
        if self._column is not None or self._columns_left:
            self._check_columns(now_s)
        cur = self._current
        if (
            self._recall is None
            and self.busy
            and (cur is None or cur.abandoned_s is None)
            and self._mission_control_gone()
        ):
            # mission control has declared this UAV lost by now (the same timeout) and given its task to another
            # UAV, or it has crashed and a resumed one flies the task again: carrying on would do it twice
            self._recall = (
                f"{MISSION_CONTROL_LOST_REASON} ({now_s - (self._last_mc_s or now_s):.1f} s silent)"
            )
            log.warning("%s: %s: abandoning its task, flying home", self.name, self._recall)
        if self._recall is not None:
            self._apply_recall(self._recall)
        model = self.model
        if model is not None and (self._queue or self._current is not None or not model.finished):
            model.step(now_s)

    def _apply_recall(self, reason: str) -> None:
        """The operator's recall: assignments not started are failed back, the task in hand is aborted (the
        machine reports it failed with ``reason`` and flies home); once nothing is left, done."""
        state = str(getattr(self.model, "state", "")) if self.model is not None else ""
        while self._queue:
            task, attempt, _ = self._queue.popleft()
            self._send(
                Result(
                    self.name,
                    TaskResult(task.id, "failed", 0.0, reason=reason),
                    self.now_s,
                    self._where(),
                    state=state,
                    attempt=attempt,
                )
            )
        model = self.model
        if self._current is None:
            self._recall = None
        elif state in FINISHING_STATES:
            pass  # the work is on the wall: the machine finishes and reports it done, then nothing is left
        elif model is not None and getattr(model, "task", None) is not None and model.may_abort():
            self._current.abandoned_s = self.now_s
            if reason.startswith(MISSION_CONTROL_LOST_REASON):
                self._drop_current(reason)
            model.abort(reason=reason)  # reported failed through report_result; it flies home and lands
            self._recall = None

    def _drop_current(self, reason: str) -> None:
        """Off the task now, cut off from mission control: the attempt ends here and is reported failed, so the
        heartbeats say this UAV holds no task (mission control takes it back when it hears them) while the machine
        puts the brick back or heads home; the machine's own report of that failure is not sent again."""
        cur = self._current
        assert cur is not None
        cur.end_s, cur.status, cur.reason = self.now_s, "failed", reason
        self._current = None
        self._swallow = cur.task_id
        state = str(getattr(self.model, "state", "")) if self.model is not None else ""
        self._send(
            Result(
                self.name,
                TaskResult(cur.task_id, "failed", 0.0, reason=reason),
                self.now_s,
                self._where(),
                state=state,
                attempt=cur.attempt,
            )
        )

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
        if self._unheard is not None:
            sent, sent_s = self._unheard
            self._unheard = None
            self._keep(None)
            if sent_s == -math.inf or (
                before is not None and before <= sent_s and now_s - before > 1.5 * self.heartbeat_period_s
            ):
                # mission control's heartbeats stopped around the completion: the link was down, the result may
                # be lost. Said again: mission control takes it late if the task was released from this UAV
                # and is not done since, and ignores it if it had it (docs/mission.md, "Heartbeats and time")
                log.info(
                    "%s: %s done while the link was down: reported again", self.name, sent.result.task_id
                )
                self._send(sent)
        if isinstance(msg, Assign):
            if msg.uav != self.name:
                self.rejected += 1
                log.warning("%s got an assignment addressed to %s", self.name, msg.uav)
                return
            why = self._refusal(msg)
            if why is not None:
                self._refuse(msg, why)
                return
            self._queue.append((msg.flown, msg.attempt, now_s))  # (planned on the wall as built)
            self.mission_ended = False
        elif isinstance(msg, Clearance):
            col = self._column
            if (
                msg.uav == self.name
                and col is not None
                and abs(col[0] - msg.site_m[0]) < 1e-3
                and abs(col[1] - msg.site_m[1]) < 1e-3
            ):
                self._column_radius_m = msg.radius_m
                if msg.granted or not self._column_granted:
                    self._column_answer = msg
                    self._column_granted = msg.granted
        elif isinstance(msg, MissionEnd):
            self.mission_ended = True
            self.mission_completed = msg.completed
        elif isinstance(msg, Recall) and msg.uav == self.name:
            self._recall = msg.reason  # applied at the next tick, outside the machine's callbacks

    def _refusal(self, msg: Assign) -> str | None:
        """Why this assignment is not one of this UAV's blueprint's tasks for its role (None: it is)."""
        task = msg.task
        if self._wall_digest is not None and msg.wall != self._wall_digest:
            return (
                f"task {task.id} is for the wall {msg.wall or '(none given)'}, this UAV's blueprint is "
                f"{self._wall_digest}"
            )
        if self._role is not None and task.kind != self._role:
            return (
                f"task {task.id} is {task.kind} work, this UAV is {'an' if self._role[:1] == 'a' else 'a'} "
                f"{self._role} UAV"
            )
        if self._tasks is not None:
            mine = self._tasks.get(task.id)
            if mine is None:
                return f"task {task.id} is not a task of this UAV's blueprint"
            if replace(task, done=mine.done) != as_flown(mine, getattr(task, "spare", None), self._spares):
                what = "brick" if isinstance(task, BrickTask) else "segment"
                return f"task {task.id}: its {what} geometry differs from this UAV's blueprint"
        return None

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
        state = str(getattr(self.model, "state", "")) if self.model is not None else ""
        self._send(
            Result(
                self.name,
                TaskResult(msg.task.id, "failed", 0.0, reason=f"refused: {why}"),
                self.now_s,
                self._where(),
                state=state,
                attempt=msg.attempt,
            )
        )

    def _where(self) -> Vec3 | None:
        if self._position is None:
            return None
        p = self._position()
        return (float(p[0]), float(p[1]), float(p[2]))

    def _send(self, msg: Any) -> None:
        self.transport.send(MISSION_CONTROL, encode(msg))
