"""Where a released brick comes to rest (masonry.sim.settle): on the bricks under it that hold it, not balanced on
a neighbour's corner a course too high."""

from __future__ import annotations

import pytest

from masonry.blueprint import Brick
from masonry.sim.bricks import BrickField, SimBrick
from masonry.sim.settle import clip_rect, rect_polygon, rest_z_m, stands_on

SIZE_M = (0.3, 0.15, 0.1)
SHRINK_M = 0.025  # WorldConfig.support_margin_m


def _field(*placed: tuple[int, float, float, float]) -> BrickField:
    field = BrickField()
    for i, x, y, z in placed:
        field.add(SimBrick(i, Brick(i, (x, y, z), SIZE_M), (x, y, z), 0.0, "placed"))
    return field


def _drop(field: BrickField, x: float, y: float, bottom_z_m: float) -> float:
    """Release brick 9 at (x, y) with its bottom at ``bottom_z_m``; the height of its centre once at rest."""
    z = bottom_z_m + SIZE_M[2] / 2.0
    field.add(SimBrick(9, Brick(9, (x, y, z), SIZE_M), (x, y, z), 0.0, "carried"))
    return field.drop(9, SHRINK_M).position_m[2]


def test_a_brick_on_a_corner_of_a_higher_neighbour_tips_off_onto_its_bed() -> None:
    # its bed (two first-course bricks, tops at 0.1 m) and a misplaced second-course neighbour whose corner it
    # overlaps: released 9 cm above its bed, it lands on the bed, not flat on the corner (top at 0.2 m)
    field = _field((0, -0.15, 0.0, 0.05), (1, 0.15, 0.0, 0.05), (4, 0.25, 0.12, 0.15))
    shrunk = (0.0, 0.0, 0.0, SIZE_M[0] / 2.0 - SHRINK_M, SIZE_M[1] / 2.0 - SHRINK_M)
    assert field.support_under(shrunk, below_z_m=0.19) == pytest.approx(0.2)  # the highest surface it touches
    assert _drop(field, 0.0, 0.0, 0.19) == pytest.approx(0.15)


def test_a_brick_across_two_supports_stays_on_them_even_over_a_gap() -> None:
    assert _drop(_field((3, -0.15, 0.0, 0.15), (4, 0.15, 0.0, 0.15)), 0.0, 0.0, 0.2) == pytest.approx(0.25)
    assert _drop(_field((3, -0.17, 0.0, 0.15), (4, 0.17, 0.0, 0.15)), 0.0, 0.0, 0.2) == pytest.approx(0.25)


@pytest.mark.parametrize(("support_x_m", "rest_z_m_"), [(-0.1, 0.15), (-0.16, 0.15), (-0.25, 0.05)])
def test_on_one_support_it_stays_while_its_centre_is_over_it_or_the_glue_holds_it(
    support_x_m: float, rest_z_m_: float
) -> None:
    # the support spans x in [support_x_m - 0.15, support_x_m + 0.15]: at -0.16 the centre hangs 1 cm beyond it,
    # half the brick on it (a running bond's end brick: the adhesive holds it); at -0.25 a tenth: it tips off
    assert _drop(_field((3, support_x_m, 0.0, 0.05)), 0.0, 0.0, 0.1) == pytest.approx(rest_z_m_)


def test_the_ground_holds_everything_and_an_edge_holds_nothing() -> None:
    footprint = (0.0, 0.0, 0.0, 0.15, 0.075)
    assert rest_z_m(footprint, [], 0.0) == 0.0
    # a neighbour that only touches the footprint along an edge
    assert not stands_on(footprint, [(0.3, 0.0, 0.0, 0.15, 0.075)])
    assert stands_on(footprint, [footprint])


def test_clipping_keeps_the_overlap() -> None:
    square = rect_polygon((0.0, 0.0, 0.0, 1.0, 1.0))
    part = clip_rect(square, (1.0, 1.0, 0.0, 1.0, 1.0))
    xs, ys = zip(*part)
    assert (min(xs), max(xs), min(ys), max(ys)) == pytest.approx((0.0, 1.0, 0.0, 1.0))
    assert clip_rect(square, (5.0, 0.0, 0.0, 1.0, 1.0)) == []
