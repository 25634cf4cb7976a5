"""No release onto a place another brick took (issue 30): the brick UAV refuses to let its brick go where the
camera sees a brick of the wall lying in the drop-off's footprint.

On GNSS (the ``px4`` model) a brick can be built a brick's width off (its UAV's position wandered 10-13 cm); the
brick designed beside it, released at its drop-off, then rests on it a course too high
(:mod:`masonry.mission.course_check` finds it after the release, glued where it lies). With the wall's markers
(``align_on_wall``) the camera sees that neighbour while the UAV descends: its estimated top-face centre and the
drop-off are placed in the world by the same telemetry, so their horizontal offset is the true one (the wander
cancels) when both are one view's: the drop-off the view puts the brick at, at its designed offsets to the bricks
in view as built (``WallAlign.taken``), and a view older than ``release_fresh_s`` judges nothing (a neighbour
merely off its design is followed, not a taken place; docs/state-machines.md). A neighbour in the brick's course or above whose centre lies deeper than :data:`TAKEN_DEPTH_M` inside
the drop-off's footprint along both of the brick's axes (footprints of the brick's own size and yaw) takes the
place: the UAV does not release, the task fails with the reason (:data:`PLACE_TAKEN`, the brick, the neighbour,
the depth) and the brick goes back to its pickup; mission control does not try it again (the neighbour will not
move), and the bricks that stand on it wait for a person with it (docs/safety.md, "A brick off its course").
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from masonry.placement_check import PLACE_TAKEN, is_place_taken

__all__ = ["PLACE_TAKEN", "TAKEN_DEPTH_M", "is_place_taken", "taken_by"]

#: A neighbour this deep (m) in the footprint along both axes takes the place; a designed neighbour touches it
#: (0), a GNSS-placed one a few centimetres in is held off by the edge as the simulator's ``support_margin_m``
#: (2.5 cm) says, and from a third of the brick's width in, the brick would rest on it.
TAKEN_DEPTH_M = 0.05
#: A brick seen farther than this from its design is not on the wall (a pallet, a magnet).
_ON_WALL_M = 0.5


def taken_by(
    target_top_m: np.ndarray,
    yaw_rad: float,
    size_m: tuple[float, float, float],
    estimates: Mapping[int, np.ndarray],
    wall: Mapping[int, tuple[float, ...]],
    own: int,
) -> tuple[int, float] | None:
    """The wall brick deepest in the drop-off's footprint and its depth (m), if deeper than :data:`TAKEN_DEPTH_M`.

    Args:
        target_top_m: the drop-off (the placed brick's top-face centre, world).
        yaw_rad: the brick's yaw at the drop-off.
        size_m: the brick's size (its neighbours are taken to have its size and yaw).
        estimates: brick id -> its top-face centre as the camera saw it (world, the same telemetry).
        wall: brick id -> its designed top-face centre; ``own``: the brick being placed.
    """
    own_top = wall.get(own)
    if own_top is None:
        return None
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    best: tuple[int, float] | None = None
    for bid, top in estimates.items():
        design = wall.get(bid)
        if bid == own or design is None or design[2] < own_top[2] - size_m[2] / 2.0:
            continue  # (a support, one course below, is where the brick goes on)
        seen = np.asarray(top, dtype=float)
        if float(np.linalg.norm(seen - np.asarray(design, dtype=float))) > _ON_WALL_M:
            continue
        dx, dy = float(seen[0] - target_top_m[0]), float(seen[1] - target_top_m[1])
        along, across = c * dx + s * dy, -s * dx + c * dy
        depth = min(size_m[0] - abs(along), size_m[1] - abs(across))
        if depth > TAKEN_DEPTH_M and (best is None or depth > best[1]):
            best = (bid, depth)
    return best
