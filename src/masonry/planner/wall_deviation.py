"""The wall as built relative to itself (issue 30): each placed brick's deviation from its design, chained from
the relative as-built poses.

Pure: the plan's tasks (the design) and the as-built poses known so far (brick id ->
:class:`~masonry.perception.types.AsBuiltPose`) in; brick id -> deviation (m) out.

A brick's world-frame as-built pose carries its position source's error (on GNSS, ``px4``: 9-11 cm), but the
offset to the neighbour its UAV saw in the same frames (``relative_to``, ``relative_offset_m``) does not: the
source's error cancels (2 mm mean, ``masonry.fsm.relative_look``). That offset less the designed one is the
brick's deviation less its neighbour's. Chained back to a brick with no such neighbour (the first brick of a
wall, one seen alone; or one not seen at all), which counts as on its design, it gives every brick's deviation
relative to the wall: up to one constant per chain (the root's own deviation, unknown on GNSS), which the UAV's
wall alignment (``masonry.fsm.wall_align``) cancels as it cancels the position source's error: it aligns on the
bricks in view at these deviations and puts the brick at its design plus its neighbours' (pulled back).

A deviation over :data:`MAX_WALL_DEVIATION_M` is left out (unknown): no brick of a wall is built that far off its
neighbours' chain, and a UAV refuses an assignment carrying one (the network is not trusted: docs/security.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from masonry.perception.types import AsBuiltPose
from masonry.planner.tasks import BrickTask, Task

Vec3 = tuple[float, float, float]

#: The largest deviation relative to the wall passed on (m).
MAX_WALL_DEVIATION_M = 0.1

_ZERO: Vec3 = (0.0, 0.0, 0.0)

__all__ = ["MAX_WALL_DEVIATION_M", "around", "wall_deviations"]


def _top(t: BrickTask) -> Vec3:
    x, y, z = t.position_m
    return (x, y, z + t.size_m[2] / 2.0)


def wall_deviations(tasks: Sequence[Task], poses: Mapping[int, AsBuiltPose]) -> dict[int, Vec3]:
    """Brick id -> its deviation from its design relative to the wall (m), for every brick with an as-built pose
    (see the module docstring); a brick whose pose has no neighbour, or whose chain meets a brick without a pose
    or itself again, is chained to that brick at zero."""
    top = {t.brick: _top(t) for t in tasks if isinstance(t, BrickTask)}
    out: dict[int, Vec3] = {}

    def step(b: int) -> tuple[int | None, Vec3]:
        """Brick ``b``'s neighbour in its pose and its deviation less that neighbour's (None: a root)."""
        pose = poses.get(b)
        if pose is None or pose.relative_to is None or pose.relative_offset_m is None:
            return None, _ZERO
        ref = pose.relative_to
        if ref not in top or b not in top:
            return None, _ZERO
        o, tb, tr = pose.relative_offset_m, top[b], top[ref]
        return ref, (o[0] - (tb[0] - tr[0]), o[1] - (tb[1] - tr[1]), o[2] - (tb[2] - tr[2]))

    for brick in poses:
        chain: list[tuple[int, Vec3]] = []
        b: int | None = brick
        while b is not None and b not in out and all(b != c for c, _ in chain):
            ref, d = step(b)
            chain.append((b, d))
            b = ref if ref in poses else None
        base = out.get(b, _ZERO) if b is not None else _ZERO
        for c, d in reversed(chain):
            base = (base[0] + d[0], base[1] + d[1], base[2] + d[2])
            out[c] = base
    return {b: d for b, d in out.items() if math.hypot(*d) <= MAX_WALL_DEVIATION_M}


def around(
    tasks: Sequence[Task], brick: int, deviations: Mapping[int, Vec3], radius_m: float
) -> tuple[tuple[int, Vec3], ...]:
    """The ``deviations`` of the bricks whose designed centres lie within ``radius_m`` horizontally of brick
    ``brick``'s (itself left out), by brick id: what its UAV's camera can see of the wall at its drop-off."""
    design = {t.brick: t.position_m for t in tasks if isinstance(t, BrickTask)}
    own = design.get(brick)
    if own is None:
        return ()
    return tuple(
        (b, d)
        for b, d in sorted(deviations.items())
        if b != brick and b in design and math.hypot(design[b][0] - own[0], design[b][1] - own[1]) <= radius_m
    )
