"""No release onto a place another brick took (issue 30, masonry.fsm.place_taken): a brick of the wall seen in
the drop-off's footprint stops the release; the task fails with the reason and is not tried again."""

from __future__ import annotations

import numpy as np
import pytest

from fsm_rig import BRICK_ID, Rig, brick_task
from masonry.fakes import FakeBrick
from masonry.fsm.place_taken import TAKEN_DEPTH_M, is_place_taken, taken_by

DROP = (0.0, 0.5, 0.25)  # a second-course brick (B7) on brick 3; brick 4 is its neighbour in the course
SUPPORT, NEIGHBOUR = 3, 4
WALL = (
    (SUPPORT, (0.0, 0.5, 0.20)),
    (NEIGHBOUR, (0.3, 0.5, 0.30)),
    (BRICK_ID, (DROP[0], DROP[1], DROP[2] + 0.05)),
)
SIZE_M = (0.3, 0.15, 0.1)


def _rig(neighbour_x_m: float) -> Rig:
    rig = Rig(
        tasks=[brick_task(position=DROP)], config={"align_on_wall": True, "wall": WALL, "side_look": False}
    )
    rig.camera.bricks.append(FakeBrick(SUPPORT, (0.0, 0.5, 0.20), 0.0))
    rig.camera.bricks.append(FakeBrick(NEIGHBOUR, (neighbour_x_m, 0.5, 0.30), 0.0))
    return rig.run()


def test_a_neighbour_built_into_the_place_stops_the_release() -> None:
    rig = _rig(0.2)  # built 10 cm toward B7's place: B7 would rest on it, a course too high
    result = rig.link.results[0]
    assert result.status == "failed"
    assert result.reason is not None and is_place_taken(result.reason)
    assert result.reason.startswith("place taken: B4 seen 10.0 cm into the place of B7; not released"), result
    assert not rig.followed("place_descend", "place_release")


def test_a_neighbour_where_the_design_puts_it_does_not() -> None:
    assert _rig(0.3).link.results[0].status == "done"


def test_the_depth_is_along_both_axes_and_a_support_below_is_no_neighbour() -> None:
    wall = dict(WALL)
    target = np.array([0.0, 0.5, 0.30])
    # 10 cm in along the brick, but beside it across (15 cm): no overlap
    assert taken_by(target, 0.0, SIZE_M, {NEIGHBOUR: np.array([0.2, 0.65, 0.3])}, wall, BRICK_ID) is None
    hit = taken_by(target, 0.0, SIZE_M, {NEIGHBOUR: np.array([0.2, 0.52, 0.3])}, wall, BRICK_ID)
    assert hit is not None and hit[0] == NEIGHBOUR and hit[1] == pytest.approx(0.10)
    # its own support right under it is where it goes
    assert taken_by(target, 0.0, SIZE_M, {SUPPORT: np.array([0.0, 0.5, 0.2])}, wall, BRICK_ID) is None
    # just within the threshold: the edge holds it off
    near = np.array([0.3 - TAKEN_DEPTH_M + 0.001, 0.5, 0.3])
    assert taken_by(target, 0.0, SIZE_M, {NEIGHBOUR: near}, wall, BRICK_ID) is None
