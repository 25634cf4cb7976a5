"""The UAV side of the mission protocol: one handler per UAV owns its state machine and its MissionLink.

``UavHandler`` is the :class:`~masonry.ports.MissionLink` the state machine (``masonry.fsm``) talks to:
``poll_task`` hands over the task mission control assigned, ``report_progress`` and ``report_result`` become
messages. ``step(now_s)`` reads the transport, sends the UAV's heartbeat, and ticks the machine. It keeps
its own trace of what the UAV actually executed (``executions``), from which the simulator measures
conflict and dependency violations independently of mission control's bookkeeping.

With a ``battery`` and a ``swap_battery`` (the simulator's ground crew), the handler keeps a battery reserve:
below ``reserve_fraction`` a queued task is held back, so the machine flies home and lands, and starts once
the pack is swapped (mission control sees the task in progress meanwhile).

Mission control's heartbeat is watched too: ``mission_control_lost`` turns true when it has been silent past
the timeout. The UAV then finishes the task in hand and takes no new one (none can come). A result sent
while mission control is down is lost: a resumed mission control flies that task again (docs/mission.md).
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from masonry.errors import ProtocolError
from masonry.mission.messages import (
    MISSION_CONTROL,
    Assign,
    Heartbeat,
    MissionEnd,
    Progress,
    Result,
    decode,
    encode,
)
from masonry.mission.transport import Transport
from masonry.planner.tasks import Task
from masonry.ports import TaskResult

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]


@dataclass
class Execution:
    """One task as the UAV flew it: handed to the machine at ``start_s``, reported at ``end_s``."""

    task_id: str
    uav: str
    attempt: int
    start_s: float
    end_s: float | None = None
    status: str = "running"


class UavHandler:
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
        after_result: called right after a result is sent; the in-process simulation steps mission control
            there, so that the answer (the next task) is in the inbox when the machine polls for it, as with a
            network round trip shorter than a tick.
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
        reserve_fraction: float = 0.4,
        after_result: Callable[[], None] | None = None,
    ) -> None:
        self._after_result = after_result
        self._battery = battery
        self._swap_battery = swap_battery
        self.reserve_fraction = reserve_fraction
        self.battery_swaps = 0
        self.name = name
        self.transport = transport
        self._position = position
        self.heartbeat_period_s = heartbeat_period_s
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.model: Any = None
        self._queue: deque[tuple[Task, int]] = deque()
        self._current: Execution | None = None
        self._last_sent_hb_s: float | None = None
        self._last_mc_s: float | None = None
        self.mission_ended = False
        self.mission_completed: bool | None = None
        self.executions: list[Execution] = []
        self.rejected = 0
        self.now_s = 0.0

    def attach(self, model: Any) -> None:
        """Give the handler the state machine it drives (built with ``link=self``)."""
        self.model = model

    @property
    def mission_control_lost(self) -> bool:
        """Mission control has been silent past the heartbeat timeout (or never heard)."""
        return self._last_mc_s is None or self.now_s - self._last_mc_s > self.heartbeat_timeout_s

    @property
    def mission_control_heard_s(self) -> float | None:
        """When mission control was last heard from (None: never)."""
        return self._last_mc_s

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
        if self._battery is not None and self._battery() < self.reserve_fraction:
            # Battery reserve: the task waits while the machine, given nothing, flies home and lands; then
            # the ground crew (``swap_battery``, True once done) swaps the pack and the task starts.
            if self._swap_battery is None or not self._swap_battery():
                return None
            self.battery_swaps += 1
        task, attempt = self._queue.popleft()
        self._current = Execution(task.id, self.name, attempt, self.now_s)
        self.executions.append(self._current)
        return task

    def report_progress(self, task_id: str, state: str, time_s: float) -> None:
        self._send(Progress(self.name, task_id, state, time_s, self._where()))

    def report_result(self, result: TaskResult) -> None:
        cur = self._current
        if cur is not None and cur.task_id == result.task_id:
            cur.end_s = self.now_s
            cur.status = result.status
            self._current = None
        state = str(getattr(self.model, "state", "")) if self.model is not None else ""
        self._send(Result(self.name, result, self.now_s, self._where(), state=state))
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
        for raw in self.transport.receive():
            self._handle(raw, now_s)
        if self._last_sent_hb_s is None or now_s - self._last_sent_hb_s >= self.heartbeat_period_s:
            self._last_sent_hb_s = now_s
            cur = self._current
            state = str(getattr(self.model, "state", "")) if self.model is not None else ""
            self._send(Heartbeat(self.name, now_s, state=state, task_id=cur.task_id if cur else None,
                                 position_m=self._where()))
        model = self.model
        if model is not None and (self._queue or self._current is not None or not model.finished):
            model.step(now_s)

    def _handle(self, raw: bytes, now_s: float) -> None:
        try:
            msg = decode(raw)
        except ProtocolError as exc:
            self.rejected += 1
            log.warning("%s rejected a message: %s", self.name, exc)
            return
        if msg.sender != MISSION_CONTROL:
            return
        self._last_mc_s = now_s
        if isinstance(msg, Assign):
            if msg.uav != self.name:
                self.rejected += 1
                log.warning("%s got an assignment addressed to %s", self.name, msg.uav)
                return
            self._queue.append((msg.task, msg.attempt))
            self.mission_ended = False
        elif isinstance(msg, MissionEnd):
            self.mission_ended = True
            self.mission_completed = msg.completed

    def _where(self) -> Vec3 | None:
        if self._position is None:
            return None
        p = self._position()
        return (float(p[0]), float(p[1]), float(p[2]))

    def _send(self, msg: Any) -> None:
        self.transport.send(MISSION_CONTROL, encode(msg))
