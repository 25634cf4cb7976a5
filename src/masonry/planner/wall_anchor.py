"""The as-built pose anchored on the wall (issue 30): a placed brick's position from the relative looks of the wall,
combined in one least-squares on its surveyed bricks.

Pure: the plan's tasks (the design, and which bricks are surveyed: the blueprint's ``placed``, ``BrickTask.done``)
in, the as-built poses in completion order one by one (:meth:`WallAnchor.take`), the pose mission control reports out;
after each, every brick's best estimate so far (:meth:`WallAnchor.poses`: a later look improves an earlier brick's).

A brick's world-frame look (``AsBuiltPose.position_m`` as its UAV sent it) carries the position source's error: on
GNSS (``px4``) 6 cm per axis that wanders over seconds, 83-94 mm on average over a wall; on motion capture 1-5 mm.
Its offsets from the neighbours seen in the same frames (``relative_offsets``, or only ``relative_to`` and
``relative_offset_m`` from a UAV that sends the one, :mod:`masonry.fsm.relative_look`) do not carry it: 0.85 mm per
horizontal axis. Every look is a *sighting* of its brick and its neighbours up to a common translation; all the
sightings so far, with the surveyed bricks fixed on their design, are solved together in one weighted least-squares
(:mod:`masonry.planner.wall_solve`): a brick seen with bricks of several courses is tied to the survey by its
shortest paths at once, not by a chain through the neighbour seen most. Each brick's estimate in a look has the
variance ``RELATIVE_SIGMA_M**2 / 2`` (the link's, shared by its two ends) times the look's most frames over its own
(a neighbour seen in fewer frames weighs less).

The world looks enter the same least-squares, each as a direct measurement of its brick with the world look's
variance. That variance is not known to mission control (the UAV does not say what its position source is), so it
is measured: the mean over the anchored bricks of the mission so far (this one included, each at its completion) of
the squared horizontal difference between the look and the relative looks' solution without any world look, less
that solution's own variance, never under :data:`MIN_WORLD_SIGMA_M` squared. On GNSS the relative looks take the
whole weight, on motion capture the two share it.

Vertically an anchored brick lies on its course (the sightings reach it from a surveyed course through bricks that
the course check, :mod:`masonry.mission.course_check`, found at their course height): its height is the design's.
The relative look's vertical is its noisiest axis (2.2 mm per link), the world look's on GNSS 6 cm.

A wall with no surveyed brick (docs/estimation.md, "The wall's frame") is solved the same way with nothing fixed:
its sightings give its shape, its world looks (each a direct measurement of its brick) its translation, their
mean; the world look's variance is measured on it too (each look against that solution, over the looks less one
per wall). Such a pose has ``world_position_m`` but no ``anchored_to``: it is exact in the wall's frame (to the
sightings), and in the world as good as the mean of the wall's looks. A brick tied to no other (a tower's, seen
alone) keeps its world-frame look horizontally; every brick whose look is within half a brick of its course's
height is put at that height (the course check's criterion: a brick a course off is failed, not taken). An offset
over :data:`~masonry.planner.wall_deviation.MAX_WALL_DEVIATION_M` from its designed one horizontally, or over half
a brick vertically, is left out (not a brick of this wall's course beside or under it), and a solution that puts a
brick over that distance from its design is not trusted either (no brick of a wall is built that far off its
neighbours; on no survey: that far off relative to the rest of its wall): the brick keeps its world look.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from masonry.perception.types import AsBuiltPose
from masonry.planner.tasks import BrickTask, Task
from masonry.planner.wall_deviation import MAX_WALL_DEVIATION_M
from masonry.planner.wall_solve import Groups, Looks, Sighting, Wall

Vec3 = tuple[float, float, float]

#: The relative look's error per horizontal axis (m): measured, ``benchmarks/bench_as_built.py`` (0.85 mm).
RELATIVE_SIGMA_M = 0.001
#: The least the world look's error per horizontal axis is taken to be (m): a look is never trusted as a survey.
MIN_WORLD_SIGMA_M = 0.0003
#: The world look's error taken before any is measured (m): a wall's translation from its looks' plain mean.
LOOSE_SIGMA_M = 1.0

__all__ = ["MIN_WORLD_SIGMA_M", "RELATIVE_SIGMA_M", "Anchor", "WallAnchor"]


@dataclass(frozen=True)
class Anchor:
    """A brick's anchored centre (world, m) and the surveyed brick it is anchored to (its root)."""

    centre_m: Vec3
    root: int


class WallAnchor:
    """The as-built poses of a mission anchored on its surveyed bricks, taken in completion order.

    Args:
        tasks: the plan's.
        every_neighbour: each look's offsets to every neighbour seen (False: only to the neighbour seen most, the
            single chain of links; for comparison).
    """

    def __init__(self, tasks: Sequence[Task], every_neighbour: bool = True) -> None:
        self._design = {t.brick: t for t in tasks if isinstance(t, BrickTask)}
        self._fixed = {b: (t.position_m[0], t.position_m[1]) for b, t in self._design.items() if t.done}
        self.every_neighbour = every_neighbour
        self._anchors: dict[int, Anchor] | None = {}  # (:attr:`anchors`, None: not read from the solve yet)
        self._solved: tuple[list[int], list[int], list[list[float]]] = ([], [], [])  # (the last solve's rows)
        self._looks: dict[int, AsBuiltPose] = {}  # (brick id -> its world-frame look, in completion order)
        self._looks_xy: dict[int, tuple[float, float]] = {}  # (the same, horizontally)
        # (the same again as arrays in that order, every solve's priors: :class:`Looks`; a brick taken again
        # keeps its row)
        self._look_row: dict[int, int] = {}
        self._look_ids = np.zeros(64, dtype=np.int64)
        self._look_xy = np.zeros((64, 2))
        self._sightings: dict[int, Sighting] = {}
        self._groups = Groups()  # (the sightings' components, joined as they come: every solve's roots)
        self._residuals_m2: list[float] = []
        self._free: tuple[float, int] = (0.0, 0)  # (the unsurveyed walls' look residuals: m^2 summed, dof)

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
        total, dof = self._free
        n = len(self._residuals_m2) + dof
        if n == 0:
            return None
        return math.sqrt(max((sum(self._residuals_m2) + total) / n, MIN_WORLD_SIGMA_M**2))

    def _sighting(self, brick: int, pose: AsBuiltPose) -> Sighting | None:
        """Brick ``brick``'s look as a sighting of it and its neighbours on the wall (None: no neighbour kept)."""
        own = self._design.get(brick)
        if own is None or own.done or pose.relative_to is None or pose.relative_offset_m is None:
            return None
        raw = pose.relative_offsets if self.every_neighbour and pose.relative_offsets else ()
        if not raw:
            raw = ((pose.relative_to, pose.relative_offset_m, 1),)
        most = max(n for _, _, n in raw)
        half = RELATIVE_SIGMA_M**2 / 2.0
        top = own.position_m[2] + own.size_m[2] / 2.0
        offsets = []
        for nb, o, frames in raw:
            other = self._design.get(nb)
            if other is None or nb == brick:
                continue
            designed = (
                own.position_m[0] - other.position_m[0],
                own.position_m[1] - other.position_m[1],
                top - other.position_m[2] - other.size_m[2] / 2.0,
            )
            if (
                abs(o[2] - designed[2]) > own.size_m[2] / 2.0
                or math.hypot(o[0] - designed[0], o[1] - designed[1]) > MAX_WALL_DEVIATION_M
            ):
                continue  # (not a brick of this wall's course beside or under it: not trusted)
            offsets.append((nb, (o[0], o[1]), half * most / frames))
        return Sighting(brick, tuple(offsets), half) if offsets else None

    def take(self, brick: int, pose: AsBuiltPose) -> AsBuiltPose:
        """Brick ``brick``'s reported pose (see the module docstring): anchored when its look ties it to a
        surveyed brick, on the wall's own sightings and the world looks otherwise; the wall re-solved with it
        (:meth:`poses`)."""
        look = self.world(brick, pose)
        self._looks[brick] = look
        self._looks_xy[brick] = xy = (look.position_m[0], look.position_m[1])
        row = self._look_row.setdefault(brick, len(self._look_row))
        if row == len(self._look_ids):
            self._look_ids = np.concatenate([self._look_ids, np.zeros(row, dtype=np.int64)])
            self._look_xy = np.concatenate([self._look_xy, np.zeros((row, 2))])
        self._look_ids[row] = brick
        self._look_xy[row] = xy
        sighting = self._sighting(brick, look)
        again = brick in self._sightings  # (a brick taken again: its old sighting's links go)
        if sighting is None:
            self._sightings.pop(brick, None)
        else:
            self._sightings[brick] = sighting
        if again:
            self._groups = Groups(list(self._sightings.values()))
        elif sighting is not None:
            self._groups.add(sighting)
        # (its three solves share its tables)
        wall = Wall(self._fixed, list(self._sightings.values()), self._groups)
        relative = wall.solve(variance_of=(brick,), only=(brick,))
        c = relative.centre_m.get(brick)
        if c is not None:
            w = look.position_m
            self._residuals_m2.append(
                ((w[0] - c[0]) ** 2 + (w[1] - c[1]) ** 2) / 2.0 - relative.variance_m2[brick]
            )
        n = len(self._look_row)
        ids = self._look_ids[:n]
        priors = Looks(ids, self._look_xy[:n], np.sort(ids))
        self._free = self._unsurveyed_residuals(wall, priors)
        sigma_w = self.world_sigma_m()
        var_w = LOOSE_SIGMA_M**2 if sigma_w is None else sigma_w**2
        self._solved = wall.rows_on(priors, var_w)
        self._anchors = None  # (read from the solve when asked: the take's brick alone, :meth:`_anchor_of`)
        out = self.pose(brick)
        assert out is not None
        return out

    @property
    def anchors(self) -> dict[int, Anchor]:
        """Brick id -> its anchored centre in the last solve (every brick tied to a surveyed one, within its
        design's reach)."""
        return self._all_anchors()

    def _all_anchors(self) -> dict[int, Anchor]:
        if self._anchors is None:
            free, roots, xs = self._solved
            shift = self._wall_shift(free, roots, xs)
            size = Counter(roots)
            self._anchors = {}
            for b, root, x in zip(free, roots, xs, strict=True):
                anchor = self._anchored(b, root, x, size[root], shift.get(root))
                if anchor is not None:
                    self._anchors[b] = anchor
        return self._anchors

    def _anchor_of(self, brick: int) -> Anchor | None:
        """``anchors.get(brick)``, of that brick's row of the last solve alone (its free bricks ascend) while the
        whole dictionary is not built: the same floats (its wall's shift the same sums in the same order)."""
        if self._anchors is not None:
            return self._anchors.get(brick)
        free, roots, xs = self._solved
        i = bisect_left(free, brick)
        if i == len(free) or free[i] != brick:
            return None
        root = roots[i]
        shift = None
        if root not in self._fixed:
            mine = [j for j, r in enumerate(roots) if r == root]
            if len(mine) > 1:
                sums = self._wall_shift([free[j] for j in mine], [root] * len(mine), [xs[j] for j in mine])
                shift = sums[root]
            return self._anchored(brick, root, xs[i], len(mine), shift)
        return self._anchored(brick, root, xs[i], 0, None)

    def _anchored(
        self, b: int, root: int, xy: list[float], size: int, shift: tuple[float, float] | None
    ) -> Anchor | None:
        """Brick ``b``'s anchor from its row of the solve (``size``, ``shift``: its component's bricks and their
        mean offset from their design, read when its root is on no survey), None: not anchored."""
        x, y = xy
        design = self._design[b].position_m
        centre = (x, y, design[2])
        if root in self._fixed:
            ok = math.dist(centre, design) <= MAX_WALL_DEVIATION_M
        elif size == 1 or shift is None:
            return None  # (seen alone, tied to no brick: its look, :meth:`pose`)
        else:
            # (relative to the rest of its wall: a wall built on no survey sits where its looks put it)
            dx, dy = shift
            ok = math.hypot(x - design[0] - dx, y - design[1] - dy) <= MAX_WALL_DEVIATION_M
        return Anchor(centre, root) if ok else None

    def _unsurveyed_residuals(self, wall: Wall, priors: Looks) -> tuple[float, int]:
        """The world looks' squared horizontal residuals per axis (m^2, summed) against the shape of their wall's
        sightings with no survey (the translation the looks' mean), and the degrees of freedom they hold (per
        component, its looks less one)."""
        looks = self._looks_xy
        free, roots, xs = wall.rows_on(priors, LOOSE_SIGMA_M**2)
        total = 0.0
        members: dict[int, int] = {}  # (component root -> its looks)
        fixed = self._fixed
        for b, root, (x, y) in zip(free, roots, xs, strict=True):
            if b in looks and b not in fixed and root not in fixed:
                w = looks[b]
                total += ((w[0] - x) ** 2 + (w[1] - y) ** 2) / 2.0
                members[root] = members.get(root, 0) + 1
        return total, sum(n - 1 for n in members.values())

    def _wall_shift(
        self, free: list[int], roots: list[int], xs: list[list[float]]
    ) -> dict[int, tuple[float, float]]:
        """Per component (of the solution ``free``, ``roots``, ``xs``: :meth:`Wall.rows`), its bricks' mean
        horizontal offset from their design (m): read for those rooted on no surveyed brick."""
        sums: dict[int, list[float]] = {}
        for b, root, (x, y) in zip(free, roots, xs, strict=True):
            design = self._design[b].position_m
            acc = sums.setdefault(root, [0.0, 0.0, 0.0])
            acc[0] += x - design[0]
            acc[1] += y - design[1]
            acc[2] += 1.0
        return {r: (a[0] / a[2], a[1] / a[2]) for r, a in sums.items()}

    def pose(self, brick: int) -> AsBuiltPose | None:
        """Brick ``brick``'s best estimate after the looks taken so far (None: not taken)."""
        look = self._looks.get(brick)
        anchor = self._anchor_of(brick)
        if look is None:
            return None
        design = self._design.get(brick)
        if anchor is None:
            if design is None or abs(look.position_m[2] - design.position_m[2]) > design.size_m[2] / 2.0:
                return look  # (off its course, or no design: the look as it came)
            x, y, z = look.position_m
            if z == design.position_m[2]:
                return look
            centre = (x, y, design.position_m[2])
            root = None
        else:
            centre = anchor.centre_m
            root = anchor.root if anchor.root in self._fixed else None
        return replace(
            look,
            position_m=centre,
            deviation_m=math.dist(centre, self._design[brick].position_m),
            anchored_to=root,
            world_position_m=look.position_m,
        )

    def poses(self) -> dict[int, AsBuiltPose]:
        """Every brick taken -> its best estimate so far (:meth:`pose`), in completion order."""
        self._all_anchors()  # (every brick's built once: not one search per brick)
        return {b: p for b in self._looks if (p := self.pose(b)) is not None}
