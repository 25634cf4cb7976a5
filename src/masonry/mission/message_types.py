"""The mission protocol's values: one frozen dataclass per message type (:mod:`masonry.mission.messages`).

The wire form, the version history and the checks live in :mod:`masonry.mission.messages` (encoding) and
:mod:`masonry.mission.message_decode` (decoding); this module holds only the values both sides share.
"""

from __future__ import annotations

from dataclasses import dataclass

from masonry.planner.tasks import Task
from masonry.ports import PlanProgress, TaskResult

PROTOCOL_VERSION = 7
MISSION_CONTROL = "mission-control"
#: The sender name of an operator's commands (``masonry ctl``); mission control answers to it.
OPERATOR = "operator"
#: What an operator may ask (:class:`OperatorCommand`).
OPERATOR_COMMANDS = ("pause", "resume", "abort", "recall", "return-all", "limit")

Vec3 = tuple[float, float, float]

#: A heartbeat's and a progress report's typed facts (:mod:`masonry.mission.uav_facts`), booleans on the wire.
FACT_FIELDS = ("carrying", "flying_home", "on_pad", "finishing", "out_of_service")
#: The typed fact ``plan_progress`` (:class:`~masonry.ports.PlanProgress`, null or left out: none) and its fields on
#: the wire: ``{"grant": int >= 1, "leg": index of PLAN_LEGS, "leg_fraction": 0..1}``.
PLAN_PROGRESS_FIELDS = ("grant", "leg", "leg_fraction")


@dataclass(frozen=True)
class Heartbeat:
    """I am alive: sent by every UAV handler and by mission control once per heartbeat period."""

    sender: str
    time_s: float
    state: str = ""
    task_id: str | None = None
    position_m: Vec3 | None = None
    #: the UAV's battery, 0..1 (None: not reported; optional on the wire, for the log and the live page)
    battery: float | None = None
    #: the wind its autopilot reports (MAVLink WIND), m/s, and its ``max_wind_mps`` (uav.yaml): mission control
    #: gives it no task above that (None: not reported)
    wind_mps: float | None = None
    max_wind_mps: float | None = None
    #: a ground crew swaps its pack on its pad (``UavHandler.swaps_batteries``): mission control may send it home
    #: for an early swap (:mod:`masonry.mission.swap_stagger`)
    swaps_batteries: bool = False
    #: its facts (:class:`~masonry.mission.uav_facts.UavFacts`): mission control decides from these, ``state``
    #: is for display
    carrying: bool = False
    flying_home: bool = False
    on_pad: bool = False
    finishing: bool = False
    out_of_service: bool = False
    #: how far it is along the flight mission control last answered it, as it knows it (None: it flies none)
    plan_progress: PlanProgress | None = None


@dataclass(frozen=True)
class Assign:
    """Mission control gives ``task`` to ``uav`` (attempt number ``attempt``, from 1: this assignment's own, one
    more than the task's previous assignment) of the wall ``wall``.

    ``wall`` is :func:`masonry.fingerprint.wall_digest` of mission control's blueprint ("" when it has none).
    ``planned``: the same task with its target or segment moved onto the wall as built
    (:mod:`masonry.planner.as_built_plan`; None: flown as designed).
    """

    sender: str
    uav: str
    task: Task
    attempt: int
    time_s: float
    wall: str = ""
    planned: Task | None = None

    @property
    def flown(self) -> Task:
        """The task as the UAV flies it: ``planned`` if given, else ``task``."""
        return self.task if self.planned is None else self.planned


@dataclass(frozen=True)
class Progress:
    """A UAV's state machine entered ``state`` while working on ``task_id`` (with its facts, as a heartbeat)."""

    sender: str
    task_id: str
    state: str
    time_s: float
    position_m: Vec3 | None = None
    carrying: bool = False
    flying_home: bool = False
    on_pad: bool = False
    finishing: bool = False
    out_of_service: bool = False
    plan_progress: PlanProgress | None = None


@dataclass(frozen=True)
class Result:
    """A UAV finished (``done``) or abandoned (``failed``) a task."""

    sender: str
    result: TaskResult
    time_s: float
    position_m: Vec3 | None = None
    state: str = ""  # the UAV's state after the result (for display)
    attempt: int = 0  # the attempt of the assignment this result answers (0: unknown, never accepted)
    #: the UAV is out of service after it (its fact, as in a heartbeat): mission control retires it
    out_of_service: bool = False


@dataclass(frozen=True)
class MissionEnd:
    """Mission control is done with the UAVs (``completed`` false when the mission could not finish)."""

    sender: str
    time_s: float
    completed: bool


@dataclass(frozen=True)
class ClearanceRequest:
    """A UAV asks for the column over ``site_m`` (it will leave its layer there); ``release``: it left it."""

    sender: str
    site_m: Vec3
    time_s: float
    position_m: Vec3 | None = None
    release: bool = False
    arrived: bool = False
    #: the highest altitude the UAV will reach while working at the site (None: the site's own altitude)
    top_m: float | None = None
    #: where the work at the site ends, if it moves along a segment (an adhesion UAV spraying); None: at the site
    to_m: Vec3 | None = None


@dataclass(frozen=True)
class Clearance:
    """Mission control's answer: the column over ``site_m`` is ``uav``'s (``granted``), or hold over ``hold_m``."""

    sender: str
    uav: str
    site_m: Vec3
    radius_m: float
    time_s: float
    granted: bool = True
    hold_m: Vec3 | None = None
    layer_m: float | None = None
    #: fly the lateral leg to the site or hold point gently where the zones have no slack for its overshoot (False:
    #: nothing of another UAV's is near its end, which mission control widened: docs/safety.md)
    gentle: bool = True
    #: granted at a brick's drop-off with glue under it: the seconds its glue stays open from ``time_s`` (the
    #: bead sprayed longest ago; None: no open time). A re-seat presses the brick again only within it
    open_for_s: float | None = None
    #: the answer's number (>= 1; 0: not numbered): mission control numbers each flight it answers (a grant, a
    #: hold flight), and the UAV's ``plan_progress`` names the one it flies
    grant: int = 0


@dataclass(frozen=True)
class OperatorCommand:
    """An operator asks mission control to ``command`` (one of :data:`OPERATOR_COMMANDS`).

    ``uav``: the UAV to recall; ``role`` and ``limit``: how many UAVs of that role may fly at once (``limit``;
    ``limit`` -1 lifts it); ``id``: echoed in the answer.
    """

    sender: str
    command: str
    time_s: float
    id: str = ""
    uav: str | None = None
    role: str | None = None
    limit: int | None = None


@dataclass(frozen=True)
class CommandAnswer:
    """Mission control's answer to the operator's command ``id``: ``accepted``, or not and ``reason``."""

    sender: str
    id: str
    command: str
    accepted: bool
    reason: str
    time_s: float


@dataclass(frozen=True)
class Recall:
    """Mission control tells ``uav`` to drop attempt ``attempt`` of ``task_id`` (reported failed with ``reason``),
    fly home and land.

    ``task_id`` None (``attempt`` 0): whatever the UAV holds when it reads the recall (the operator's recall, and
    return-all and abort). A recall naming a task the UAV does not hold (done, failed or dropped since; a recall
    said again, or late) is ignored: it cannot fail the assignment that came after it (issue 27, ``recall42``).
    """

    sender: str
    uav: str
    time_s: float
    reason: str
    task_id: str | None = None
    attempt: int = 0


Message = (
    Heartbeat
    | Assign
    | Progress
    | Result
    | MissionEnd
    | ClearanceRequest
    | Clearance
    | OperatorCommand
    | CommandAnswer
    | Recall
)

_TYPE_NAMES: dict[type, str] = {
    Heartbeat: "heartbeat",
    Assign: "assign",
    Progress: "progress",
    Result: "result",
    MissionEnd: "mission-end",
    ClearanceRequest: "clearance-request",
    Clearance: "clearance",
    OperatorCommand: "operator-command",
    CommandAnswer: "command-answer",
    Recall: "recall",
}
