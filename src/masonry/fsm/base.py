"""What every part of the UAV model reads and fires, declared once for the type checker.

:class:`~masonry.fsm.model.UavModel` is built in layers, one responsibility each, every layer reading only what is
declared here and what the layers under it define::

    ModelBase                 the declarations (this module)
    └── Routing               motion: the navigator's legs, the route, the transit's asking (masonry.fsm.routing)
        └── BatteryBudget     the battery budget in seconds of flight (masonry.fsm.budget)
            └── TaskBook      taking, starting and reporting tasks (masonry.fsm.taskbook)
                └── CommonStates   idle, takeoff, home, land, failsafe, emergency, halted (masonry.fsm.common)
                    └── UavModel   the machine, the tick, the watchdogs (masonry.fsm.model)

The attributes are set by :meth:`UavModel.__init__`; the triggers are bound by its ``transitions`` machine.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, ClassVar

if TYPE_CHECKING:
    from masonry.fsm.attempt import Swing, TaskAttempt
    from masonry.fsm.battery import DrainMeter
    from masonry.fsm.config import UavConfig
    from masonry.fsm.fence import FenceWatch
    from masonry.fsm.first_hover import FirstHover
    from masonry.fsm.gates import Gate
    from masonry.fsm.hover_gains import HoverTuning
    from masonry.fsm.navigator import Navigator
    from masonry.fsm.phases import PhaseClock
    from masonry.fsm.transit import Transit
    from masonry.fsm.watchdogs import Failsafe
    from masonry.planner.tasks import Task
    from masonry.ports import ClearanceLink, Clock, FlightController, MissionLink, TaskResult, Telemetry

Vec3 = tuple[float, float, float]


class ModelBase:
    """The UAV model's attributes and triggers (see the module's docstring for the layers that use them)."""

    KIND: ClassVar[str] = ""
    _TASK_STATES_SET: ClassVar[frozenset[str]] = frozenset()

    state: str
    config: UavConfig
    fc: FlightController
    link: MissionLink
    clock: Clock
    clearance: ClearanceLink | None
    trace: list[tuple[float, str]]
    results: list[TaskResult]
    task: Task | None
    halt_reason: str | None
    attempt: TaskAttempt
    failsafe: Failsafe
    nav: Navigator
    transit: Transit
    phase_clock: PhaseClock
    fence_watch: FenceWatch | None
    drain: DrainMeter
    gates: tuple[Gate, ...]
    first_hover: FirstHover | None
    hover_tuning: HoverTuning | None
    _now_s: float
    _entered_s: float
    _tel: Telemetry | None
    _swing: Swing
    _next_task: Task | None
    _halt_after_landing: str | None
    _battery_service: bool
    _waiting_since_s: float | None

    # Triggers (bound by the machine; declared here so type checkers see them).
    assign: Callable[..., bool]
    retire: Callable[..., bool]
    airborne: Callable[..., bool]
    arrived: Callable[..., bool]
    reached: Callable[..., bool]
    finish: Callable[..., bool]
    landed: Callable[..., bool]
    abort: Callable[..., bool]
    recover: Callable[..., bool]
    lost: Callable[..., bool]
    giveup: Callable[..., bool]

    def _transit_altitude_m(self) -> float:
        """The altitude of the UAV's lateral moves: the cruise altitude (a task raises it, subclasses)."""
        return self.config.cruise_altitude_m
