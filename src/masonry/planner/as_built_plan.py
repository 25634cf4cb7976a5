"""Work planned on what was built (issue 30): targets and adhesion segments from the as-built poses.

Pure: the plan's tasks (the design) and the as-built poses known so far (brick id -> the pose its UAV's camera saw
after the release, :class:`~masonry.perception.types.AsBuiltPose`) in; a task's geometry out.

**A brick's target.** The brick keeps its designed offsets to the bricks that support it (those it is glued on: the
``below`` of its adhesion tasks), applied to their as-built poses: with one support off the design by ``d``, the
brick's target is its design plus ``d``; with several, plus the mean of their deviations. Supports the blueprint
lists as placed count as on their design; supports placed but not seen count as unknown (left out; none known:
the design). The deviation ``d`` the brick inherits is then **pulled back toward the design by** ``pullback_m``
**per course** (horizontally: its length shortened by ``pullback_m``, not below zero) and **capped at**
``max_shift_m`` (the blueprint's ``placement_tolerance_m``: a target the blueprint would call misplaced is never
planned). Why a fixed step and a cap, not a factor: a brick then sits at most ``pullback_m`` off its designed
offset to what it stands on (the joint the glue is sized for), and the wall's drift from the design shrinks by
``pullback_m`` per course while a placement adds less than that, so errors do not pile up course after course;
the cap bounds it whatever the placements do. Vertically the target follows its supports (a brick cannot be put
into the one below it), within the same cap.

**An adhesion segment** moves with the two bricks it joins: by the mean of the deviation of the brick below (its
as-built pose, known: it is done before its glue) and of the brick above (its target as planned here, it is not
built yet), horizontally; vertically with the brick below (the bead lies on its top). The yaw of both stays the
design's (the as-built yaw is reported; a few milliradians over a brick are sub-millimetre at its ends).

No pose known, or all of them on their design: every task's geometry is the design's, exactly
(:meth:`AsBuiltPlan.planned` returns None, and nothing is sent).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from masonry.perception.types import AsBuiltPose
from masonry.planner.tasks import AdhesionTask, BrickTask, Task

Vec3 = tuple[float, float, float]

#: The farthest a planned target or segment end may be from its design, any way: a UAV refuses an assignment whose
#: planned geometry is farther (the network is not trusted: docs/security.md).
MAX_PLANNED_SHIFT_M = 0.05

_ZERO: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class AsBuiltPlanning:
    """How far a target follows the wall as built: ``pullback_m`` nearer the design per course, at most
    ``max_shift_m`` from it (clipped to :data:`MAX_PLANNED_SHIFT_M`)."""

    pullback_m: float = 0.005
    max_shift_m: float = 0.02

    @property
    def cap_m(self) -> float:
        """The largest shift planned."""
        return min(self.max_shift_m, MAX_PLANNED_SHIFT_M)


def pulled_back(deviation: Vec3, pullback_m: float, cap_m: float) -> Vec3:
    """``deviation`` (m) shortened horizontally by ``pullback_m`` (not below zero) and capped at ``cap_m``, its
    vertical part kept within ``cap_m``; its horizontal direction kept."""
    dx, dy, dz = deviation
    n = math.hypot(dx, dy)
    m = min(max(n - pullback_m, 0.0), cap_m)
    k = 0.0 if n == 0.0 else m / n
    return (dx * k, dy * k, min(max(dz, -cap_m), cap_m))


def supports_of(tasks: Sequence[Task]) -> dict[int, tuple[int, ...]]:
    """Brick id -> the bricks it is glued on (the ``below`` of its adhesion tasks, in plan order)."""
    out: dict[int, list[int]] = {}
    for t in tasks:
        if isinstance(t, AdhesionTask):
            out.setdefault(t.above, []).append(t.below)
    return {k: tuple(v) for k, v in out.items()}


def _sub(a: Sequence[float], b: Sequence[float]) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _add(a: Sequence[float], b: Sequence[float]) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _mean(vs: Sequence[Vec3]) -> Vec3:
    n = float(len(vs))
    return (sum(v[0] for v in vs) / n, sum(v[1] for v in vs) / n, sum(v[2] for v in vs) / n)


class AsBuiltPlan:
    """The geometry of the plan's tasks on the wall as built (see the module docstring).

    Args:
        tasks: the plan's tasks (the design; bricks done in it count as built on their design).
        planning: the pull-back per course and the cap.
    """

    def __init__(self, tasks: Sequence[Task], planning: AsBuiltPlanning | None = None) -> None:
        self.planning = planning if planning is not None else AsBuiltPlanning()
        self._design = {t.brick: t.position_m for t in tasks if isinstance(t, BrickTask)}
        self._preplaced = {t.brick for t in tasks if isinstance(t, BrickTask) and t.done}
        self._supports = supports_of(tasks)

    def deviation_m(self, brick: int, poses: Mapping[int, AsBuiltPose]) -> Vec3 | None:
        """Brick ``brick``'s as-built centre less its designed one (m); zero for a brick the blueprint lists as
        placed; None: not known."""
        pose = poses.get(brick)
        if pose is not None:
            return _sub(pose.position_m, self._design[brick])
        return _ZERO if brick in self._preplaced else None

    def target_deviation_m(self, brick: int, poses: Mapping[int, AsBuiltPose]) -> Vec3:
        """How far from its design brick ``brick``'s target is planned (m): its known supports' mean deviation,
        pulled back and capped."""
        known = [d for s in self._supports.get(brick, ()) if (d := self.deviation_m(s, poses)) is not None]
        if not known:
            return _ZERO
        return pulled_back(_mean(known), self.planning.pullback_m, self.planning.cap_m)

    def segment_shift_m(self, task: AdhesionTask, poses: Mapping[int, AsBuiltPose]) -> Vec3:
        """How far adhesion segment ``task`` is moved from its design (m; see the module docstring)."""
        above = self.target_deviation_m(task.above, poses)
        below = self.deviation_m(task.below, poses)
        if below is None:
            return (above[0], above[1], 0.0)
        mean = _mean([below, above])
        return pulled_back((mean[0], mean[1], below[2]), 0.0, self.planning.cap_m)

    def planned(self, task: Task, poses: Mapping[int, AsBuiltPose]) -> Task | None:
        """``task`` with its target (a brick) or its segment (adhesion) planned on the wall as built; None when that
        is its design exactly (no pose known, or none off its design)."""
        if isinstance(task, BrickTask):
            d = self.target_deviation_m(task.brick, poses)
            return None if d == _ZERO else replace(task, position_m=_add(task.position_m, d))
        s = self.segment_shift_m(task, poses)
        if s == _ZERO:
            return None
        return replace(task, start_m=_add(task.start_m, s), end_m=_add(task.end_m, s))


def planned_shift_m(design: Task, planned: Task) -> float | None:
    """How far ``planned`` moves ``design`` (the largest distance between their targets or segment ends, m); None
    when it is not the same task with only its target or segment moved (another id, kind, size, pickup...)."""
    if isinstance(design, BrickTask) and isinstance(planned, BrickTask):
        same = replace(
            planned, position_m=design.position_m, done=design.done, wall_as_built=design.wall_as_built
        )
        if same != design:
            return None
        return math.dist(planned.position_m, design.position_m)
    if isinstance(design, AdhesionTask) and isinstance(planned, AdhesionTask):
        if replace(planned, start_m=design.start_m, end_m=design.end_m, done=design.done) != design:
            return None
        return max(math.dist(planned.start_m, design.start_m), math.dist(planned.end_m, design.end_m))
    return None


__all__ = [
    "MAX_PLANNED_SHIFT_M",
    "AsBuiltPlan",
    "AsBuiltPlanning",
    "Vec3",
    "planned_shift_m",
    "pulled_back",
    "supports_of",
]
