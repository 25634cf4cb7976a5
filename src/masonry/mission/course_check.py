"""A placed brick at its course height, or misplaced (issue 30): mission control does not count a brick a course
too high (or too low) as done.

On GNSS (the ``px4`` model) a brick's neighbour can end up a brick's width off (its UAV's position wandered 13 cm);
the next brick released beside it then rests on it with a quarter or more of its footprint, a course too high
(``masonry.sim.settle``), and its UAV, whose altitude is as far off as its position, reports it placed. The
as-built pose in the world frame cannot see it (it carries the same altitude error: 10 cm on the bundled
pyramid's seed 8), but the relative look does (``masonry.fsm.relative_look``): the placed brick's top-face centre
less a neighbour's, seen in the same frames, against the designed offset between them.

:class:`CourseCheck` keeps each measured brick's *course error* (how far its top stands above its designed
height): the relative offset's height less the designed one, plus the neighbour's own course error (a brick seen
beside a neighbour that is itself a course too high is measured against it); a brick with no neighbour seen has
none (0 when it is a reference). A brick whose course error is beyond half its height is *misplaced*: the task
fails with the reason (:data:`MISPLACED`, the brick, the height error, the neighbour), and is not tried again
(the brick is glued where it lies; a retry would find no brick at its pickup). The bricks that stand on it are
never dispatched, so the error does not climb the wall; the rest of the wall is built, and the report says the
mission did not complete and why (docs/safety.md, "A brick off its course").

Pure: task geometry and as-built poses in, a reason or None out.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from masonry.planner.tasks import BrickTask

if TYPE_CHECKING:
    from masonry.perception.types import AsBuiltPose
    from masonry.planner.tasks import Task

__all__ = ["COURSE_TOLERANCE_FRACTION", "MISPLACED", "CourseCheck", "is_misplaced"]

#: A brick whose top stands more than this share of its height off its designed height is off its course (the
#: simulator's bricks are at their course height within millimetres or a whole course off).
COURSE_TOLERANCE_FRACTION = 0.5
#: How a misplaced brick's failure reason begins (the journal's failures keep it stuck after a resume).
MISPLACED = "misplaced:"


def is_misplaced(reason: str) -> bool:
    """Whether a failure ``reason`` is a brick found off its course (not to be tried again)."""
    return reason.startswith(MISPLACED)


class CourseCheck:
    """The course errors of the bricks measured so far, and the verdict on each new one."""

    def __init__(self, tasks: Sequence[Task]) -> None:
        self._design = {t.brick: t for t in tasks if isinstance(t, BrickTask)}
        #: brick id -> its measured course error (m; above its designed height positive)
        self.errors_m: dict[int, float] = {}

    def course_error_m(self, brick: int, pose: AsBuiltPose) -> float | None:
        """How far ``brick``'s top stands above its designed height, from its relative look (None: no neighbour
        seen, or one not in the plan)."""
        task, ref = (
            self._design.get(brick),
            self._design.get(pose.relative_to if pose.relative_to is not None else -1),
        )
        if task is None or ref is None or pose.relative_offset_m is None:
            return None
        designed_m = _top_z_m(task) - _top_z_m(ref)
        return pose.relative_offset_m[2] - designed_m + self.errors_m.get(ref.brick, 0.0)

    def misplaced(self, task_id: str, brick: int, pose: AsBuiltPose | None) -> str | None:
        """The reason ``brick`` (task ``task_id``), just placed, is misplaced; None if it is at its course height
        or was not measured. Its course error is kept either way (a reference for the bricks after it)."""
        if pose is None:
            return None
        error_m = self.course_error_m(brick, pose)
        if error_m is None:
            return None
        self.errors_m[brick] = error_m
        task = self._design[brick]
        if abs(error_m) <= COURSE_TOLERANCE_FRACTION * task.size_m[2]:
            return None
        where = "above" if error_m > 0.0 else "below"
        return (
            f"{MISPLACED} {task_id} rests {abs(error_m) * 100:.1f} cm {where} its course height (measured against "
            f"B{pose.relative_to} after its release; tolerance {COURSE_TOLERANCE_FRACTION * task.size_m[2] * 100:.1f}"
            f" cm): not counted as placed, the bricks on it are not built, it waits for a person"
        )


def _top_z_m(task: BrickTask) -> float:
    return task.position_m[2] + task.size_m[2] / 2.0
