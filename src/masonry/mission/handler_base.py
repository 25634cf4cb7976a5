"""What the parts of a UAV's mission handler share: who the UAV is, how it talks to mission control, where it is.

:class:`~masonry.mission.handler.UavHandler` is built from small parts, each a base class of it: this one, the
results it reports and keeps (:mod:`masonry.mission.handler_results`) and the site columns it asks for
(:mod:`masonry.mission.handler_columns`). The handler sets the attributes declared here in its constructor.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable
from typing import Any

from masonry.mission.execution import Execution
from masonry.mission.messages import MISSION_CONTROL, Message, Result, encode
from masonry.mission.transport import Transport
from masonry.mission.uav_facts import OUT_OF_SERVICE_STATE
from masonry.ports import PlanProgress, TaskResult

Vec3 = tuple[float, float, float]


class HandlerBase:
    """The UAV's name, endpoint, clock reading and machine; the messages it sends (see the module)."""

    name: str
    transport: Transport
    #: the time of the current step (the handler's clock: set by ``step``)
    now_s: float
    #: the UAV's state machine (``masonry.fsm``), attached after it is built with the handler as its link
    model: Any
    heartbeat_period_s: float
    _position: Callable[[], Vec3] | None
    #: when mission control was last heard from (None: never)
    _last_mc_s: float | None
    #: the task the machine has in hand (None: none)
    _current: Execution | None
    #: mission control said the mission is over
    mission_ended: bool

    @abstractmethod
    def pump(self) -> bool:
        """Read what has arrived now (between ticks); True if a task is waiting for the machine."""

    @property
    def out_of_service(self) -> bool:
        """The machine is out of service (state ``halted``): it refuses every task it is handed, at once.

        Such a UAV is handed its queued tasks without the battery reserve's hold, so that the refusal is not
        delayed past the moment mission control (told by the ``halted`` heartbeat) has released the task.
        """
        return self.model is not None and str(getattr(self.model, "state", "")) == OUT_OF_SERVICE_STATE

    def _state(self) -> str:
        """The machine's state now (empty without a machine)."""
        return str(getattr(self.model, "state", "")) if self.model is not None else ""

    def _plan_progress(self, position_m: Vec3 | None) -> PlanProgress | None:
        """How far the UAV is along the flight mission control last answered it (the machine's
        ``plan_progress``, :meth:`masonry.fsm.routing.Routing.plan_progress`; None: none, or no such machine)."""
        read = getattr(self.model, "plan_progress", None) if self.model is not None else None
        if read is None:
            return None
        pp = read(position_m)
        return pp if isinstance(pp, PlanProgress) else None

    def _where(self) -> Vec3 | None:
        if self._position is None:
            return None
        p = self._position()
        return (float(p[0]), float(p[1]), float(p[2]))

    def _send(self, msg: Message) -> None:
        self.transport.send(MISSION_CONTROL, encode(msg))

    def _send_failed(self, task_id: str, attempt: int, reason: str, state: str) -> None:
        """Tell mission control attempt ``attempt`` of ``task_id`` failed (``reason``), the machine in ``state``."""
        self._send(
            Result(
                self.name,
                TaskResult(task_id, "failed", 0.0, reason=reason),
                self.now_s,
                self._where(),
                state=state,
                attempt=attempt,
                out_of_service=state == OUT_OF_SERVICE_STATE,
            )
        )


__all__ = ["HandlerBase", "Vec3"]
