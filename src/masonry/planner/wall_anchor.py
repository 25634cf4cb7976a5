"""The as-built pose anchored on the wall (issue 30): a placed brick's position from its chain of relative looks.

Pure: the plan's tasks (the design, and which bricks are surveyed: the blueprint's ``placed``, ``BrickTask.done``)
in, the as-built poses in completion order one by one (:meth:`WallAnchor.take`), the pose mission control reports out.

A brick's world-frame look (``AsBuiltPose.position_m`` as its UAV sent it) carries the position source's error: on
GNSS (``px4``) 6 cm per axis that wanders over seconds, 83-94 mm on average over a wall; on motion capture 1-5 mm.
Its offset from the neighbour seen in the same frames (``relative_to``, ``relative_offset_m``,
:mod:`masonry.fsm.relative_look`) does not carry it: 0.85 mm per horizontal axis. When that neighbour is surveyed,
or was itself anchored, the brick's centre is known from the neighbour's: the *chain*. Each brick keeps the variance
of its horizontal position (0 on a surveyed brick, plus :data:`RELATIVE_SIGMA_M` squared per link), and the world
look and the chain are combined weighted by their inverse variances. The world look's variance is not known to
mission control (the UAV does not say what its position source is), so it is measured: the mean over the anchored
bricks of the mission so far (this one included) of the squared horizontal difference between look and chain, less
the chain's own variance, never under :data:`MIN_WORLD_SIGMA_M` squared. On GNSS the chain takes the whole
weight, on motion capture the two share it.

Vertically an anchored brick lies on its course (the chain reaches it from a surveyed course through bricks that
the course check, :mod:`masonry.mission.course_check`, found at their course height): its height is the design's.
The relative look's vertical is its noisiest axis (2.2 mm per link), the world look's on GNSS 6 cm.

A brick whose look has no neighbour, or whose chain does not reach a surveyed brick (the first brick of a wall
built on the ground, a tower's bricks, seen alone), keeps its world-frame look: its pose has no ``anchored_to``.
A chain that puts a brick over :data:`~masonry.planner.wall_deviation.MAX_WALL_DEVIATION_M` from its design is not
trusted either (no brick of a wall is built that far off its neighbours).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from masonry.perception.types import AsBuiltPose
from masonry.planner.tasks import BrickTask, Task
from masonry.planner.wall_deviation import MAX_WALL_DEVIATION_M

Vec3 = tuple[float, float, float]

#: The relative look's error per horizontal axis (m): measured, ``benchmarks/bench_as_built.py`` (0.85 mm).
RELATIVE_SIGMA_M = 0.001
#: The least the world look's error per horizontal axis is taken to be (m): a look is never trusted as a survey.
MIN_WORLD_SIGMA_M = 0.0003

__all__ = ["MIN_WORLD_SIGMA_M", "RELATIVE_SIGMA_M", "Anchor", "WallAnchor"]


@dataclass(frozen=True)
class Anchor:
    """A brick's anchored centre (world, m), its horizontal variance per axis (m^2) and its surveyed root."""

    centre_m: Vec3
    variance_m2: float
    root: int


class WallAnchor:
    """The as-built poses of a mission anchored on its surveyed bricks, taken in completion order."""

    def __init__(self, tasks: Sequence[Task]) -> None:
        self._design = {t.brick: t for t in tasks if isinstance(t, BrickTask)}
        self.anchors: dict[int, Anchor] = {}
        self._residuals_m2: list[float] = []

    def world(self, brick: int, pose: AsBuiltPose) -> AsBuiltPose:
        """``pose`` as its UAV sent it: the world-frame look (an anchored pose's ``world_position_m``)."""
        if pose.world_position_m is None:
            return pose
        design = self._design.get(brick)
        dev = pose.deviation_m if design is None else math.dist(pose.world_position_m, design.position_m)
        return replace(
            pose, position_m=pose.world_position_m, deviation_m=dev, anchored_to=None, world_position_m=None
        )

    def world_sigma_m(self) -> float | None:
        """The world look's error per horizontal axis measured so far (m; None before any anchored brick)."""
        if not self._residuals_m2:
            return None
        return math.sqrt(max(sum(self._residuals_m2) / len(self._residuals_m2), MIN_WORLD_SIGMA_M**2))

    def _chain(self, brick: int, pose: AsBuiltPose) -> Anchor | None:
        """Brick ``brick``'s centre from its neighbour's (surveyed or anchored) and the relative look; None."""
        ref, offset = pose.relative_to, pose.relative_offset_m
        own = self._design.get(brick)
        if ref is None or offset is None or own is None or own.done:
            return None
        other = self._design.get(ref)
        if other is None:
            return None
        if other.done:
            base = Anchor(other.position_m, 0.0, ref)
        elif ref in self.anchors:
            base = self.anchors[ref]
        else:
            return None
        # the offset is top face to top face; the centres lie half a height under each
        dz = (other.size_m[2] - own.size_m[2]) / 2.0
        c = (base.centre_m[0] + offset[0], base.centre_m[1] + offset[1], own.position_m[2])
        if math.dist(c, own.position_m) > MAX_WALL_DEVIATION_M or abs(
            base.centre_m[2] + dz + offset[2] - c[2]
        ) > (own.size_m[2] / 2.0):
            return None  # (not a brick of this wall's course beside or under it: not trusted)
        return Anchor(c, base.variance_m2 + RELATIVE_SIGMA_M**2, base.root)

    def take(self, brick: int, pose: AsBuiltPose) -> AsBuiltPose:
        """Brick ``brick``'s reported pose (see the module docstring): anchored when its chain reaches a surveyed
        brick, its world-frame look otherwise; the brick's anchor is kept for the bricks chained to it."""
        look = self.world(brick, pose)
        chain = self._chain(brick, look)
        if chain is None:
            self.anchors.pop(brick, None)
            return look
        w = look.position_m
        var_c = chain.variance_m2
        self._residuals_m2.append(
            ((w[0] - chain.centre_m[0]) ** 2 + (w[1] - chain.centre_m[1]) ** 2) / 2.0 - var_c
        )
        sigma_w = self.world_sigma_m()
        assert sigma_w is not None
        var_w = sigma_w**2
        k = var_w / (var_w + var_c)  # the chain's weight
        x = k * chain.centre_m[0] + (1.0 - k) * w[0]
        y = k * chain.centre_m[1] + (1.0 - k) * w[1]
        centre = (x, y, chain.centre_m[2])
        self.anchors[brick] = Anchor(centre, var_c * var_w / (var_c + var_w), chain.root)
        design = self._design[brick].position_m
        return replace(
            look,
            position_m=centre,
            deviation_m=math.dist(centre, design),
            anchored_to=chain.root,
            world_position_m=w,
        )
