"""Mission control's side of the as-built poses (issue 30): journal them, show them, check them.

A brick UAV's completion carries the pose its camera saw of the brick it placed
(:class:`~masonry.perception.types.AsBuiltPose`, ``masonry.fsm.as_built``). Mission control journals it with the
completion (the ``as_built`` field: the report of a resumed mission keeps it), hands it to the event sink with
the ``completed`` event (the log, the live page colour the brick by its deviation) and checks it against the
blueprint's ``placement_tolerance_m`` (:class:`PlacementWatch`): a brick beyond it is a ``placement`` event at
warning level, and with ``on_placement_error: hold`` the mission pauses as the operator's ``pause`` does
(journaled as an operator command) until the operator resumes.

With the blueprint's ``plan_on_as_built`` the watch also plans the work on what was built
(:class:`~masonry.planner.as_built_plan.AsBuiltPlan`, from the poses of the completions taken and journaled):
each assignment (:meth:`PlacementWatch.assign`) carries the task's target or segment moved onto the wall as built
(``planned``), and a completion's deviation is measured from the design again (:meth:`PlacementWatch.against_design`:
the UAV measured it from the target it was given). Off (the default), assignments and completions are as before.

Whatever the blueprint says, a brick assignment carries the deviations of the placed bricks around its drop-off
relative to the wall (``BrickTask.wall_as_built``, :mod:`masonry.planner.wall_deviation`, chained from the
completions' relative poses), which a UAV aligning on the wall's markers builds the brick relative to.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import TYPE_CHECKING

from masonry.mission.course_check import CourseCheck
from masonry.mission.message_types import MISSION_CONTROL, Assign
from masonry.perception.types import AsBuiltPose
from masonry.placement_check import PlacementCheck
from masonry.planner.as_built_plan import AsBuiltPlan, AsBuiltPlanning
from masonry.planner.tasks import BrickTask
from masonry.planner.wall_anchor import WallAnchor
from masonry.planner.wall_deviation import around, wall_deviations

if TYPE_CHECKING:
    from masonry.errors import ProtocolError
    from masonry.mission.control import MissionControl
    from masonry.mission.records import Attempt
    from masonry.planner.tasks import Task
    from masonry.ports import TaskResult

#: How far around a brick's drop-off (horizontally, m) the bricks' as-built deviations go with its assignment: what
#: its camera sees of the wall while it aligns and descends
WALL_AS_BUILT_RADIUS_M = 1.0

__all__ = [
    "WALL_AS_BUILT_RADIUS_M",
    "PlacementWatch",
    "as_built_field",
    "as_built_lines",
    "journaled_as_built",
    "take_result",
]


def as_built_field(
    data: Mapping[str, object], fail: Callable[[str, str], ProtocolError]
) -> AsBuiltPose | None:
    """A result message's optional ``as_built`` (raises ``fail("as_built", problem)`` on a malformed one)."""
    raw = data.get("as_built")
    if raw is None:
        return None
    try:
        return AsBuiltPose.from_dict(raw)
    except ValueError as exc:
        raise fail("as_built", str(exc)) from None


def take_result(att: Attempt, r: TaskResult) -> None:
    """What an attempt keeps of its UAV's result: what the UAV measured."""
    att.placement_error_m, att.coverage, att.phases, att.as_built = (
        r.placement_error_m,
        r.coverage,
        r.phases,
        r.as_built,
    )


def as_built_lines(poses: Mapping[str, AsBuiltPose]) -> list[str]:
    """The text summary's lines: the bricks seen after their release and their deviation from the design, in the
    world frame and relative to the neighbour each was seen with."""
    devs = [p.deviation_m for p in poses.values()]
    if not devs:
        return []
    lines = [
        f"as-built ({len(devs)} brick{'' if len(devs) == 1 else 's'} seen): deviation from the design mean "
        f"{sum(devs) / len(devs) * 100:.1f} cm, max {max(devs) * 100:.1f} cm"
    ]
    rel = [p.relative_deviation_m for p in poses.values() if p.relative_deviation_m is not None]
    if rel:  # (masonry.fsm.relative_look: measured against a neighbour in the same frames)
        lines.append(
            f"as-built relative to a neighbour ({len(rel)} brick{'' if len(rel) == 1 else 's'}): deviation from "
            f"the design mean {sum(rel) / len(rel) * 100:.1f} cm, max {max(rel) * 100:.1f} cm"
        )
    return lines


def journaled_as_built(raw: object) -> AsBuiltPose | None:
    """A journaled completion's ``as_built`` (None: absent, or a journal written before it existed)."""
    if raw is None:
        return None
    try:
        return AsBuiltPose.from_dict(raw)
    except ValueError:
        return None  # (a hand-edited journal: the pose is lost, not the completion)


class PlacementWatch:
    """The blueprint's :class:`~masonry.placement_check.PlacementCheck` applied to each completion.

    Mission control's ``placement`` (``MissionControl(placement=blueprint.placement)``; its defaults without).
    """

    def __init__(self, check: PlacementCheck | None = None) -> None:
        self.check = check if check is not None else PlacementCheck()
        #: task ids found beyond the tolerance, in order
        self.beyond: list[str] = []
        self._plan: AsBuiltPlan | None = None  # (made at the first assignment, with plan_on_as_built)
        self._design: dict[str, BrickTask] = {}
        #: brick id -> its as-built pose, from the completions: the world-frame look its UAV sent (what the flights
        #: are planned on), not the pose reported anchored on the wall
        self.poses: dict[int, AsBuiltPose] = {}
        self._anchor: WallAnchor | None = None  # (made with the design)
        self._tasks: list[Task] | None = None  # (the plan's, at the first assignment)
        self._course: CourseCheck | None = None  # (made at the first completion)

    def misplaced(self, mc: MissionControl, r: TaskResult) -> str | None:
        """The reason a brick task's completion ``r`` is not a placement: its brick measured off its course
        height (:mod:`masonry.mission.course_check`); None otherwise."""
        if self._course is None:
            self._course = CourseCheck(mc.plan.tasks)
        task = mc.tasks.get(r.task_id)
        if not isinstance(task, BrickTask):
            return None
        return self._course.misplaced(r.task_id, task.brick, r.as_built)

    def assign(self, mc: MissionControl, uav: str, task: Task, attempt: int, now_s: float) -> Assign:
        """The assignment of ``task`` to ``uav``: with ``plan_on_as_built``, its geometry planned on the wall as
        built (``planned``, when that is not the design); a brick task's carries the as-built deviations of the
        placed bricks around it relative to the wall (``BrickTask.wall_as_built``, :mod:`masonry.planner.wall_deviation`:
        what its UAV's wall alignment builds it relative to), when any is known."""
        planned = self.planned(mc, task)
        if isinstance(task, BrickTask):
            self._known(mc)
            assert self._tasks is not None
            near = around(
                self._tasks, task.brick, wall_deviations(self._tasks, self.poses), WALL_AS_BUILT_RADIUS_M
            )
            if any(d != (0.0, 0.0, 0.0) for _, d in near):  # (all on their design: as designed, nothing sent)
                planned = replace(planned if isinstance(planned, BrickTask) else task, wall_as_built=near)
        return Assign(MISSION_CONTROL, uav, task, attempt, now_s, mc.wall_digest, planned)

    def _known(self, mc: MissionControl) -> None:
        """The plan's tasks and the poses of the bricks done so far (a resumed mission: the journal's), once."""
        if self._tasks is not None:
            return
        self._tasks = list(mc.plan.tasks)
        self._design = {t.id: t for t in self._tasks if isinstance(t, BrickTask)}
        self._anchor = WallAnchor(self._tasks)
        done = [a for a in mc.history if a.status == "done"]
        # (the anchors of a resumed mission, in the order the completions were taken: a chain's bricks after its root)
        for att in sorted(done, key=lambda a: a.end_s if a.end_s is not None else math.inf):
            design = self._design.get(att.task_id)
            if att.as_built is not None and design is not None:
                self._anchor.take(design.brick, att.as_built)
        for att in mc.history:
            self._take(att.task_id, att.as_built if att.status == "done" else None)

    def planned(self, mc: MissionControl, task: Task) -> Task | None:
        """``task`` planned on the as-built poses known so far (None: planning off, or the design exactly)."""
        if not self.check.plan_on_as_built:
            return None
        if self._plan is None:
            self._known(mc)
            self._plan = AsBuiltPlan(
                mc.plan.tasks, AsBuiltPlanning(self.check.pullback_m, self.check.tolerance_m)
            )
        return self._plan.planned(task, self.poses)

    def _take(self, task_id: str, pose: AsBuiltPose | None) -> None:
        design = self._design.get(task_id)
        if design is not None and pose is not None and self._anchor is not None:
            self.poses[design.brick] = self._anchor.world(design.brick, pose)

    def anchored(self, mc: MissionControl, r: TaskResult) -> TaskResult:
        """``r`` with its as-built pose anchored on the wall (:mod:`masonry.planner.wall_anchor`: from the chain of
        relative looks to a surveyed brick, where there is one), the pose mission control journals and reports."""
        self._known(mc)
        design = self._design.get(r.task_id)
        if design is None or r.as_built is None or self._anchor is None:
            return r
        return replace(r, as_built=self._anchor.take(design.brick, r.as_built))

    def best(self, mc: MissionControl) -> dict[str, AsBuiltPose]:
        """Task id -> its brick's as-built pose re-solved with every look taken so far (an anchored brick's estimate
        improves with the looks of the bricks built after it: :meth:`~masonry.planner.wall_anchor.WallAnchor.poses`),
        for the bricks taken; what the report shows, where the journal and the ``completed`` event keep the pose
        known at the completion."""
        self._known(mc)
        assert self._anchor is not None
        poses = self._anchor.poses()
        return {tid: poses[t.brick] for tid, t in self._design.items() if t.brick in poses}

    def against_design(self, r: TaskResult) -> TaskResult:
        """``r`` with its as-built deviation measured from the brick's design (with ``plan_on_as_built`` the UAV
        measured it from the planned target); as it is otherwise."""
        design = self._design.get(r.task_id) if self.check.plan_on_as_built else None
        if design is None or r.as_built is None:
            return r
        deviation_m = math.dist(r.as_built.position_m, design.position_m)
        return replace(r, as_built=replace(r.as_built, deviation_m=deviation_m))

    def event_fields(self, pose: AsBuiltPose | None) -> dict[str, object]:
        """The ``completed`` event's as-built fields: the pose and the tolerance it is judged by (none without a
        pose: the events of other tasks read as before)."""
        return {} if pose is None else {"as_built": pose.to_dict(4), "tolerance_m": self.check.tolerance_m}

    def completed(self, mc: MissionControl, r: TaskResult, uav: str, now_s: float) -> None:
        """A task done: if its as-built pose is beyond the tolerance, say so (and hold, as the blueprint says)."""
        pose = r.as_built
        if r.status == "done":
            self._take(r.task_id, pose)
        if pose is None or not self.check.beyond(pose.deviation_m):
            return
        self.beyond.append(r.task_id)
        hold = self.check.on_error == "hold"
        mc.emit_event(
            now_s,
            "placement",
            uav,
            r.task_id,
            deviation_m=round(pose.deviation_m, 4),
            tolerance_m=self.check.tolerance_m,
            action=self.check.on_error,
            line=f"{r.task_id} placed {pose.deviation_m * 100:.1f} cm from its design (tolerance "
            f"{self.check.tolerance_m * 100:.1f} cm): {'mission held, resume to go on' if hold else 'going on'}",
        )
        if hold and not mc.operator.paused:
            mc.operator.apply(mc, {"command": "pause"}, now_s)
