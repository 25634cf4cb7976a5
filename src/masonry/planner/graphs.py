"""The pure planner of the paper's Section III: tasks, the dependency graph G^d and the conflict graph G^c.

- Brick i rests on brick j when |bottom(i) - top(j)| <= 5 mm and their footprints overlap with positive area
  (:mod:`masonry.planner.contacts`). For each such pair with i not yet placed there is one adhesion task A_m
  on top of j across the overlap, and G^d gets (B_i, A_m) and (A_m, B_j): u can start only after v.
- The adhesion line lies at the height of top(j), along brick j's length axis, spanning the overlap's extent
  on that axis, on the overlap's mid-line across it; when the two bricks' axes differ (neither parallel nor
  equal), along the overlap polygon's major principal axis through its centroid. A header laid square across
  a stretcher has an axis-aligned rectangular overlap, whose principal axis is its longer side.
- Conflicts: tasks still to do whose locations are within r_c, minus dependent pairs
  (:mod:`masonry.planner.conflicts`).
"""

from __future__ import annotations

import gc
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from masonry.blueprint import Blueprint, validate_blueprint
from masonry.planner.contacts import BrickArrays, Contacts, find_contacts
from masonry.planner.deadlines import Deadline, adhesive_deadlines
from masonry.planner.overlap import AXIS_ALIGNED_EPS, chord, clip_convex, principal_axis, rectangle_corners
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan, Task
from masonry.spares import Spare

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def brick_arrays(blueprint: Blueprint) -> BrickArrays:
    """Column arrays (centres, half sizes, yaws) of a blueprint's bricks, in blueprint order."""
    bricks = blueprint.bricks
    return BrickArrays.of(
        [b.position_m for b in bricks], [b.size_m for b in bricks], [b.yaw_rad for b in bricks]
    )


@dataclass(frozen=True)
class PlanGraphs:
    """A plan with G^c still as index arrays: what :func:`plan` computes before making id pairs.

    Millions of conflict pairs cost seconds and hundreds of MB as Python tuples; the CLI writes JSON straight
    from the arrays. ``conflict_indices`` = (a, b): integer arrays of indices into ``tasks``, a < b, sorted.
    """

    tasks: tuple[Task, ...]
    dependencies: tuple[tuple[str, str], ...]
    conflict_indices: tuple[IntArray, IntArray]
    #: the adhesive's open and cure edges (:mod:`masonry.planner.deadlines`)
    deadlines: tuple[Deadline, ...] = ()
    #: the blueprint's spare bricks (None: no ``spares`` key)
    spares: tuple[Spare, ...] | None = None

    @property
    def conflict_count(self) -> int:
        return len(self.conflict_indices[0])

    def to_plan(self) -> Plan:
        """The :class:`Plan` value (conflicts as (id, id) tuples in task order)."""
        ca, cb = self.conflict_indices
        ids = np.array([t.id for t in self.tasks], dtype=object)
        with _gc_paused():  # millions of small tuples: the cyclic collector would rescan them again and again
            pairs = tuple(zip(ids[ca].tolist(), ids[cb].tolist()))
        return Plan(
            tasks=self.tasks,
            dependencies=self.dependencies,
            conflicts=pairs,
            conflict_indices=(ca, cb),
            deadlines=self.deadlines,
            spares=self.spares,
        )


def plan(blueprint: Blueprint, *, check_marker_ids: bool = True) -> Plan:
    """Tasks, G^d and G^c of a blueprint (pure; no I/O).

    Tasks: one BrickTask per brick in blueprint order ("B<id>", placed bricks with done=True), then the
    adhesion tasks "A0", "A1", ... ordered by upper brick, then lower brick, in blueprint order.

    Raises:
        BlueprintError: the blueprint's geometry or fleet is invalid (see :func:`validate_blueprint`).
    """
    return plan_graphs(blueprint, check_marker_ids=check_marker_ids).to_plan()


def plan_graphs(blueprint: Blueprint, *, check_marker_ids: bool = True) -> PlanGraphs:
    """Like :func:`plan`, with the conflict pairs left as index arrays (fast for very large walls)."""
    arrays = brick_arrays(blueprint)
    contacts = find_contacts(arrays)
    validate_blueprint(blueprint, contacts, check_marker_ids=check_marker_ids)
    bricks = blueprint.bricks
    placed = np.array([b.placed for b in bricks], dtype=bool)
    keep = ~placed[contacts.upper]
    upper, lower = contacts.upper[keep], contacts.lower[keep]
    start, end = adhesion_segments(arrays, upper, lower)

    tasks: list[Task] = [
        BrickTask(
            id=f"B{b.id}",
            brick=b.id,
            done=b.placed,
            position_m=b.position_m,
            yaw_rad=b.yaw_rad,
            pickup_m=b.pickup_m,
            size_m=b.size_m,
            marker=b.marker,
        )
        for b in bricks
    ]
    starts, ends = start.tolist(), end.tolist()
    lengths = np.linalg.norm(end - start, axis=1).tolist()
    dependencies: list[tuple[str, str]] = []
    for m, (i, j) in enumerate(zip(upper.tolist(), lower.tolist())):
        aid = f"A{m}"
        tasks.append(
            AdhesionTask(
                id=aid,
                below=bricks[j].id,
                above=bricks[i].id,
                start_m=(starts[m][0], starts[m][1], starts[m][2]),
                end_m=(ends[m][0], ends[m][1], ends[m][2]),
                length_m=lengths[m],
            )
        )
        dependencies.append((f"B{bricks[i].id}", aid))
        dependencies.append((aid, f"B{bricks[j].id}"))

    ca, cb = _conflicts(blueprint, arrays, placed, upper, lower, start, end)
    return PlanGraphs(
        tasks=tuple(tasks),
        dependencies=tuple(dependencies),
        conflict_indices=(ca, cb),
        deadlines=adhesive_deadlines(tasks, blueprint.adhesive),
        spares=blueprint.spares,
    )


@contextmanager
def _gc_paused() -> Iterator[None]:
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _conflicts(
    blueprint: Blueprint,
    arrays: BrickArrays,
    placed: NDArray[np.bool_],
    upper: IntArray,
    lower: IntArray,
    start: FloatArray,
    end: FloatArray,
) -> tuple[IntArray, IntArray]:
    """Conflict pairs as global task indices (bricks first, then adhesion tasks), sorted, a < b."""
    from masonry.planner.conflicts import conflict_pairs

    n_bricks = len(placed)
    todo_bricks = np.nonzero(~placed)[0]
    n_todo_bricks = len(todo_bricks)
    # Local index: unplaced bricks 0..k-1, then adhesion tasks k..k+m-1.
    local_of_brick = np.full(n_bricks, -1, dtype=np.int64)
    local_of_brick[todo_bricks] = np.arange(n_todo_bricks)
    m = len(upper)
    adhesion_local = n_todo_bricks + np.arange(m)
    loc_start = np.concatenate([arrays.center[todo_bricks], start])
    loc_end = np.concatenate([arrays.center[todo_bricks], end])
    # Edges among tasks still to do: B_upper -> A_m always (upper is unplaced), A_m -> B_lower if unplaced.
    lower_local = local_of_brick[lower]
    lower_todo = lower_local >= 0
    eu = np.concatenate([local_of_brick[upper], adhesion_local[lower_todo]])
    ev = np.concatenate([adhesion_local, lower_local[lower_todo]])
    a, b = conflict_pairs(loc_start, loc_end, blueprint.clearance_m, (eu, ev))
    # Local -> global is increasing (bricks, then adhesion tasks, each in order): order and a < b survive.
    global_of_local = np.concatenate([todo_bricks, n_bricks + np.arange(m)])
    return global_of_local[a], global_of_local[b]


def adhesion_segments(arrays: BrickArrays, upper: IntArray, lower: IntArray) -> tuple[FloatArray, FloatArray]:
    """Start and end (m, 3) of the adhesion line on top of each ``lower`` brick under its ``upper`` brick."""
    m = len(upper)
    start = np.zeros((m, 3))
    end = np.zeros((m, 3))
    if m == 0:
        return start, end
    cj = arrays.center[lower, :2]
    ci = arrays.center[upper, :2]
    yj = arrays.yaw[lower]
    yi = arrays.yaw[upper]
    hj = arrays.half[lower, :2]
    hi = arrays.half[upper, :2]
    cos_j, sin_j = np.cos(yj), np.sin(yj)
    d = ci - cj
    # Upper brick's centre in the lower brick's frame.
    rx = cos_j * d[:, 0] + sin_j * d[:, 1]
    ry = -sin_j * d[:, 0] + cos_j * d[:, 1]
    dyaw = yi - yj
    c, s = np.abs(np.cos(dyaw)), np.abs(np.sin(dyaw))
    aligned = np.abs(np.sin(2.0 * dyaw)) < AXIS_ALIGNED_EPS
    parallel = aligned & (s < c)
    ex = c * hi[:, 0] + s * hi[:, 1]
    ey = s * hi[:, 0] + c * hi[:, 1]
    s0 = np.maximum(-hj[:, 0], rx - ex)
    s1 = np.minimum(hj[:, 0], rx + ex)
    t0 = np.maximum(-hj[:, 1], ry - ey)
    t1 = np.minimum(hj[:, 1], ry + ey)
    along_length = parallel | (s1 - s0 >= t1 - t0)
    smid, tmid = (s0 + s1) / 2.0, (t0 + t1) / 2.0
    ls0 = np.where(along_length, s0, smid)
    ls1 = np.where(along_length, s1, smid)
    lt0 = np.where(along_length, tmid, t0)
    lt1 = np.where(along_length, tmid, t1)
    top = arrays.center[lower, 2] + arrays.half[lower, 2]
    for out, ls, lt in ((start, ls0, lt0), (end, ls1, lt1)):
        out[:, 0] = cj[:, 0] + cos_j * ls - sin_j * lt
        out[:, 1] = cj[:, 1] + sin_j * ls + cos_j * lt
        out[:, 2] = top
    for k in np.nonzero(~aligned)[0].tolist():
        poly = clip_convex(
            rectangle_corners(
                (float(ci[k, 0]), float(ci[k, 1])), (float(hi[k, 0]), float(hi[k, 1])), float(yi[k])
            ),
            rectangle_corners(
                (float(cj[k, 0]), float(cj[k, 1])), (float(hj[k, 0]), float(hj[k, 1])), float(yj[k])
            ),
        )
        centroid, direction = principal_axis(poly)
        # A deterministic orientation: the direction's angle in (-pi/2, pi/2].
        angle = math.atan2(direction[1], direction[0])
        if angle <= -math.pi / 2 or angle > math.pi / 2:
            direction = (-direction[0], -direction[1])
        a, b = chord(poly, centroid, direction)
        start[k, :2] = (centroid[0] + a * direction[0], centroid[1] + a * direction[1])
        end[k, :2] = (centroid[0] + b * direction[0], centroid[1] + b * direction[1])
    return start, end


def contacts_of(blueprint: Blueprint) -> Contacts:
    """Resting and interpenetrating brick pairs of a blueprint (indices in blueprint order)."""
    return find_contacts(brick_arrays(blueprint))
