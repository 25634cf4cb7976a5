"""What mission control records of each attempt and of each UAV (values of :mod:`masonry.mission.control`)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Literal

from masonry.blueprint import UavSpec
from masonry.mission.uav_facts import LANDED_STATE, UavFacts
from masonry.perception.types import AsBuiltPose
from masonry.ports import PhaseTimes, PlanProgress, TaskResult

Vec3 = tuple[float, float, float]
AttemptStatus = Literal["running", "done", "failed"]


@dataclass
class Attempt:
    """One assignment of a task to a UAV, as mission control saw it."""

    task_id: str
    uav: str
    #: the assignment's own number (the protocol's ``attempt``: 1 for the task's first assignment, one more for each
    #: after it, counted against the task or not; :class:`~masonry.mission.ledger.AttemptLedger`)
    attempt: int
    start_s: float
    end_s: float | None = None
    status: AttemptStatus = "running"
    reason: str | None = None
    placement_error_m: float | None = None
    coverage: float | None = None
    phases: PhaseTimes | None = None  # where its time went, as the UAV measured it (None: not reported)
    as_built: AsBuiltPose | None = None  # a brick's pose as the UAV's camera saw it (None: not reported)
    #: in flight when the journal this run resumed from ends (:meth:`MissionControl.restore`)
    adopted: bool = False


class Liveness(enum.Enum):
    """What mission control hears of a UAV (:mod:`masonry.mission.liveness` moves it)."""

    #: not heard yet, or quiet past the heartbeat timeout while it may be finishing its work
    SILENT = "silent"
    HEARD = "heard"
    #: declared lost for its silence (its task went back to the pool); it may rejoin
    LOST = "lost"
    #: declared lost, then heard again with no task: back in the mission
    REJOINED = "rejoined"
    #: it said it is out of service: out of the mission for good
    OUT_OF_SERVICE = "out of service"


#: The report's word for each liveness (``UavLink.status``).
_STATUS = {Liveness.LOST: "lost", Liveness.OUT_OF_SERVICE: "out of service"}


@dataclass
class UavLink:
    """What mission control knows about one UAV."""

    spec: UavSpec
    last_heard_s: float | None = None
    position_m: Vec3 | None = None
    state: str = ""  # its machine's state as last reported (for the log, the report and the live page)
    #: what it last said of itself (:mod:`masonry.mission.uav_facts`): mission control decides from these
    facts: UavFacts = field(default_factory=UavFacts)
    liveness: Liveness = Liveness.SILENT
    lost_at_s: float | None = None
    distance_m: float = 0.0  # summed between successive reported positions
    battery: float | None = None  # as its heartbeats report it (None: they do not)
    swaps_batteries: bool = False  # its heartbeats say a ground crew swaps its pack on its pad
    #: it was given a task and has not been seen in the air since (nor answered): a report that it is landed
    #: may predate the assignment, or it waits on the ground (a battery swap) before it takes off with it
    taking_off: bool = False
    #: declared lost for its silence, its airspace stays reserved until then (it may hover where it stopped)
    airspace_until_s: float | None = None
    #: silent with a brick on its magnet: the pickup it puts it back on, then home
    way_via_m: Vec3 | None = None
    #: the flights mission control answered it so far (under the columns, the last answer's number)
    grants: int = 0
    #: how far it said it is along the flight last answered it (its last heartbeat's or progress report's; None:
    #: none), for the log and the live page (the table reads its own copy: :mod:`masonry.mission.plan_reading`)
    plan_progress: PlanProgress | None = None

    @property
    def lost(self) -> bool:
        """Out of the mission: lost for its silence, or out of service."""
        liveness = self.liveness  # (identity, not the dict: an enum's hash is Python code, asked every tick)
        return liveness is Liveness.LOST or liveness is Liveness.OUT_OF_SERVICE

    @property
    def status(self) -> str:
        """``ok``, ``lost`` (silent past the timeout) or ``out of service`` (it said so): the report's word."""
        return _STATUS.get(self.liveness, "ok")

    def moved_to(self, position_m: Vec3) -> None:
        if self.position_m is not None:
            self.distance_m += math.dist(self.position_m, position_m)
        self.position_m = position_m


def completion_fields(r: TaskResult, *, phases: bool = True) -> dict[str, object]:
    """What the journal keeps of a completion: its placement error, its coverage, (``phases``) its phases and the
    placed brick's as-built pose."""
    fields: dict[str, object] = {}
    if r.placement_error_m is not None:
        fields["placement_error_m"] = r.placement_error_m
    if r.coverage is not None:
        fields["coverage"] = r.coverage
    if phases and r.phases is not None:
        fields["phases"] = r.phases.as_dict()
    if r.as_built is not None:
        fields["as_built"] = r.as_built.to_dict()
    return fields


__all__ = ["LANDED_STATE", "Attempt", "AttemptStatus", "Liveness", "UavLink", "completion_fields"]
