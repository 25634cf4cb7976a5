"""The seams of masonry: every piece of hardware or middleware a UAV handler talks to, as a small Protocol.

World frame ENU (x east, y north, z up), metres, radians, seconds. Adapters (``masonry.adapters``), the
simulator (``masonry.sim``) and the scripted fakes (``masonry.fakes``) implement these; the state machines
(``masonry.fsm``) use nothing else.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np

    from masonry.perception.types import AsBuiltPose, CameraIntrinsics, TagPose
    from masonry.planner.tasks import Task

Vec3 = tuple[float, float, float]

#: How long (s of the flight controller's clock) a take-off may take before the state machine gives it up: the
#: default of ``UavConfig.takeoff_timeout_s``, which the machine passes to :meth:`FlightController.takeoff` (the
#: MAVLink adapter ends the climb it flies or watches a little before it: ``masonry.adapters.takeoff``), and what
#: a flight controller assumes when a caller passes none.
TAKEOFF_TIMEOUT_S = 30.0


@dataclass(frozen=True)
class Telemetry:
    """A flight controller's state at ``time_s``."""

    time_s: float
    position_m: Vec3
    velocity_mps: Vec3
    attitude_rad: Vec3  # roll, pitch, yaw (yaw about +z from +x, ENU)
    armed: bool
    mode: str
    battery_fraction: float  # 1.0 full, 0.0 empty
    link_ok: bool
    position_ok: bool  # the autopilot's position estimate is usable
    on_ground: bool
    # The autopilot is in its landing mode (ArduPilot LAND, PX4 AUTO.LAND; also its failsafe landings): it
    # descends on its own authority. The adapters set it, so the state machines never match mode names.
    landing: bool = False


@dataclass(frozen=True, eq=False)
class CameraFrame:
    """One camera sample: an image (BGR or grey) to run detection on, or marker poses already measured."""

    time_s: float
    image: np.ndarray | None = None
    tags: tuple[TagPose, ...] | None = None


#: A failed task's ``reason`` starts with this when the UAV abandoned it for its battery: the UAV's fault, not
#: the task's, so mission control does not count it as an attempt of the task.
BATTERY_LOW_REASON = "battery low"
#: ... and with this when the operator recalled the UAV (``masonry ctl recall``): not the task's fault either.
RECALL_REASON = "recalled by the operator"
#: ... and with this when the UAV abandoned it because mission control fell silent past the heartbeat timeout
#: (mission control gives the task to another UAV meanwhile, or a resumed one flies it again).
MISSION_CONTROL_LOST_REASON = "mission control lost"
#: ... and with this when mission control released it because its UAV's heartbeats said it held no task (its
#: handler restarted, the assignment forgotten).
TASK_DROPPED_REASON = "uav dropped the task"
#: The machines' states in which a task's work is done or being finished on the wall (the brick released, the
#: segment sprayed): an abort there would report failed a task that is done, so a recall or a lost link lets it
#: finish, and mission control gives a UAV silent in one of them longer before it declares it lost.
FINISHING_STATES = frozenset(
    {
        "place_release",
        "place_verify",
        "place_ascend",
        "reseat_descend",
        "reseat_grasp",
        "reseat_ascend",
        "close",
        "ascend",
    }
)
#: The brick machine's states after the grasp in which the brick is on the magnet (a UAV lost in one of them
#: may have taken its brick down with it: mission control says so in the attempt's reason).
CARRYING_STATES = frozenset(
    {
        "pickup_ascend",
        "pickup_verify",
        "transport",
        "place_align",
        "place_descend",
        "reseat_ascend",
        "putback_goto",
        "putback_descend",
    }
)
#: Mission control silent this long (mission seconds) is not coming back: a UAV hovering for its clearance flies
#: home and lands without one, at its fixed fallback layer (mission control keeps that way home reserved for
#: it: docs/safety.md, "A UAV that falls silent").
LAST_RESORT_S = 30.0
#: The reasons of a failure that costs its task no attempt.
UNCOUNTED_REASONS = (BATTERY_LOW_REASON, RECALL_REASON, MISSION_CONTROL_LOST_REASON, TASK_DROPPED_REASON)


#: The phases a task attempt's time is split into (docs/mission.md, "Where the time goes"), in the order a task
#: goes through them. ``queued``: assigned, not yet started by the machine (the handler holds it for a battery
#: swap); ``waiting``: hovering until mission control grants the flight's site column; ``holding``: sent to a hold
#: point (flying there, waiting there); ``other``: a state that never holds a task for long (``idle``, ``land``,
#: the failsafes), so that the phases always add up to the attempt. :func:`masonry.fsm.phases.phase_of` maps the
#: machines' states to them.
PHASES: tuple[str, ...] = (
    "queued",
    "takeoff",
    "transit",
    "waiting",
    "holding",
    "estimating",
    "aligning",
    "descending",
    "grasping",
    "spraying",
    "placing",
    "ascending",
    "other",
)


@dataclass(frozen=True)
class PhaseTimes:
    """Seconds one task attempt spent in each phase of :data:`PHASES` (each >= 0; they add up to the attempt)."""

    queued: float = 0.0
    takeoff: float = 0.0
    transit: float = 0.0
    waiting: float = 0.0
    holding: float = 0.0
    estimating: float = 0.0
    aligning: float = 0.0
    descending: float = 0.0
    grasping: float = 0.0
    spraying: float = 0.0
    placing: float = 0.0
    ascending: float = 0.0
    other: float = 0.0

    @property
    def total_s(self) -> float:
        """All the phases together: the attempt's duration."""
        return float(sum(getattr(self, name) for name in PHASES))

    @property
    def clearance_s(self) -> float:
        """Seconds spent waiting for the airspace: ``waiting`` plus ``holding``."""
        return self.waiting + self.holding

    def items(self) -> tuple[tuple[str, float], ...]:
        """``(phase, seconds)`` in the order of :data:`PHASES`."""
        return tuple((name, float(getattr(self, name))) for name in PHASES)

    def as_dict(self) -> dict[str, float]:
        """Phase name -> seconds, every phase (the form of the wire, the journal and the JSON report)."""
        return dict(self.items())

    def __add__(self, other: PhaseTimes) -> PhaseTimes:
        return PhaseTimes(*(a + b for (_, a), (_, b) in zip(self.items(), other.items(), strict=True)))


@dataclass(frozen=True)
class TaskResult:
    """What a UAV reports when it finishes or abandons a task.

    ``phases``: where the attempt's time went (the machine's ticks, from taking the task to this result); None
    from a UAV that does not measure it.
    """

    task_id: str
    status: Literal["done", "failed"]
    duration_s: float
    reason: str | None = None
    placement_error_m: float | None = None
    coverage: float | None = None
    phases: PhaseTimes | None = None
    #: a brick's pose as the UAV's camera saw it after the release (None: not seen, or not a brick task)
    as_built: AsBuiltPose | None = None


@runtime_checkable
class Clock(Protocol):
    """Time source: simulated (advances only when told) or wall."""

    def now_s(self) -> float: ...

    def sleep(self, duration_s: float) -> None: ...


@runtime_checkable
class FlightController(Protocol):
    """The autopilot: arming, takeoff/land, velocity + yaw-rate setpoints, telemetry."""

    def connect(self) -> None: ...

    def close(self) -> None: ...

    def arm(self) -> None: ...

    def disarm(self) -> None: ...

    def takeoff(self, altitude_m: float, timeout_s: float | None = None) -> None:
        """Climb ``altitude_m`` above where the UAV stands; ``timeout_s``: how long (s of its clock, from now) the
        caller gives the climb before it gives the take-off up (None: :data:`TAKEOFF_TIMEOUT_S`)."""
        ...

    def land(self) -> None: ...

    def send_velocity(self, velocity_mps: Vec3, yaw_rate_radps: float) -> None: ...

    def telemetry(self) -> Telemetry: ...


@runtime_checkable
class WaitsAlive(Protocol):
    """A flight controller whose calls may wait (arming through an autopilot's refusals, its estimate) and that
    calls ``keep_alive`` while it does, so that the loop around the machine keeps its other duties (the UAV's
    heartbeat to mission control: issue 29's "uav lost")."""

    keep_alive: Callable[[], None] | None


@runtime_checkable
class Gripper(Protocol):
    """Electromagnet on a lockable ball joint."""

    def set_magnet(self, on: bool) -> None: ...

    def set_joint_locked(self, locked: bool) -> None: ...

    def is_attached(self) -> bool: ...

    def release_at(self, at_s: float) -> bool:
        """Let go of the brick at ``at_s`` (s, the UAV's :class:`Clock`): True if it will be let go then; False if
        this gripper cannot time a release, and has then let go at once (as ``set_magnet(False)``). A time already
        past lets go at once. ``set_magnet`` before ``at_s`` cancels it."""
        ...

    def can_time_release(self) -> bool:
        """True if :meth:`release_at` lets go at the time asked (else it lets go at once): the release gate predicts
        a release from a tick outside r_pl only then (:meth:`masonry.fsm.release_gate.ReleaseGate.ahead`)."""
        ...


@runtime_checkable
class Sprayer(Protocol):
    """The adhesive valve."""

    def set_valve(self, open_: bool) -> None: ...

    def is_valve_open(self) -> bool: ...


@runtime_checkable
class Camera(Protocol):
    """Downward camera on the UAV body: intrinsics, mounting, frames."""

    @property
    def intrinsics(self) -> CameraIntrinsics: ...

    @property
    def T_body_cam(self) -> np.ndarray: ...  # 4x4: camera pose in the UAV body frame (FLU body, z up)

    def read(self) -> CameraFrame | None: ...


@runtime_checkable
class MissionLink(Protocol):
    """A UAV handler's line to mission control: tasks in; progress and results out."""

    def poll_task(self) -> Task | None: ...

    def report_progress(self, task_id: str, state: str, time_s: float) -> None: ...

    def report_result(self, result: TaskResult) -> None: ...


#: The legs of a flight mission control answered, as a UAV flies them (:class:`PlanProgress`): up or down to its
#: layer where it is, along the layer, down over the site (a flight to a hold point has no descent).
PLAN_LEGS = ("climb", "transit", "descend")


@dataclass(frozen=True)
class PlanProgress:
    """How far a UAV is along the flight mission control answered it, as the UAV knows it (issue 27 §2.2): its
    ``plan_progress`` fact, in heartbeats and progress reports (docs/safety.md, "The UAV's plan progress").

    Attributes:
        grant: the number of mission control's answer whose flight it flies (``Clearance.grant``, >= 1).
        leg: the leg it flies, an index of :data:`PLAN_LEGS` (0 climb, 1 transit, 2 descend).
        leg_fraction: how much of that leg is behind it, 0..1 (its position along the leg's line, from the leg's
            start to its end; 1: at the end, e.g. hovering at its hold point).
    """

    grant: int
    leg: int
    leg_fraction: float

    @property
    def leg_name(self) -> str:
        return PLAN_LEGS[self.leg]


class ClearanceAnswer(Protocol):
    """Mission control's answer to a transit request (:class:`masonry.mission.messages.Clearance` is one)."""

    @property
    def grant(self) -> int: ...  # the answer's number, which the UAV's plan progress names (0: not numbered)

    @property
    def granted(self) -> bool: ...  # the column over the site is the UAV's: it may come down there

    @property
    def layer_m(self) -> float | None: ...  # the altitude of its lateral leg (None: no layers)

    @property
    def hold_m(self) -> Vec3 | None: ...  # not granted yet: where to wait at the layer (None: where it is)

    @property
    def gentle(
        self,
    ) -> bool: ...  # its lateral leg's end is near another UAV's: fly it gently (docs/safety.md)

    @property
    def open_for_s(
        self,
    ) -> (
        float | None
    ): ...  # granted at a brick's drop-off: how long the glue under it stays open (None: no open time)


@runtime_checkable
class ClearanceLink(Protocol):
    """A UAV handler's line to mission control's airspace (docs/safety.md): transits asked for and ended.

    A machine built without one (``clearance=None``) flies with no separation from other UAVs: a single UAV,
    or a fixed ``UavConfig.lateral_altitude_m`` layer per UAV.
    """

    def request_clearance(
        self, site_m: Vec3, top_m: float | None = None, to_m: Vec3 | None = None
    ) -> ClearanceAnswer | None:
        """Ask (again) for the column over ``site_m``; None while mission control has not answered."""
        ...

    def end_transit(self, site_m: Vec3) -> None:
        """The flight to ``site_m`` has come down there: its layer is free."""
        ...

    @property
    def swaps_batteries(self) -> bool:
        """A ground crew swaps the battery of a landed UAV before its next task (a low battery: land, not retire)."""
        ...

    def return_brick(self, brick_id: int) -> bool:
        """The ground crew takes brick ``brick_id`` off the landed UAV's magnet and lays it back at its pickup;
        True once it is there, False without a ground crew (the brick stays on the UAV's pad for a person)."""
        ...


def _no_tick(dt_s: float) -> None:
    """A time base that moves on by itself (nothing to advance)."""


def _nothing_to_close() -> None:
    """Ports that hold no resource."""


@dataclass(frozen=True)
class UavPorts:
    """The ports one UAV flies with, its clock, how to move time on by one tick, and how to close it all.

    What every producer of a UAV's ports returns (the simulated world's :attr:`masonry.sim.SimUav.ports`,
    :func:`masonry.adapters.wiring.open_adapters`) and every consumer takes (``masonry.simulate``'s mission,
    :func:`masonry.mission.remote.run_remote_uav`, ``masonry fly``).

    Attributes:
        fc, gripper, sprayer, camera: the ports (one board may be both ``gripper`` and ``sprayer``).
        clock: the time base the machine reads.
        advance: moves time on by ``dt_s`` seconds: the simulated world's step, or a sleep on a wall clock.
        world: the simulated world behind any simulated port (for what only it can measure: the true placement
            error, the adhesive coverage), None when every port is real hardware.
        descriptions: port name -> what drives it (for the pre-flight report).
        close: closes what was opened, newest first; never raises (a shutdown path).
    """

    fc: FlightController
    gripper: Gripper
    sprayer: Sprayer
    camera: Camera
    clock: Clock
    advance: Callable[[float], None] = _no_tick
    world: object | None = None
    descriptions: Mapping[str, str] = field(default_factory=dict)
    close: Callable[[], None] = _nothing_to_close
