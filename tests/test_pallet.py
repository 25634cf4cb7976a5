"""Generated pallets: unique pickups, compact, clear of the wall; along a long wall each brick faces its place."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint_gen import PALLET_MIN_COLUMNS, running_bond, towers


@settings(max_examples=25, deadline=None)
@given(
    courses=st.integers(1, 6),
    per_course=st.integers(1, 40),
    placed=st.integers(0, 2),
    yaw=st.floats(-3.0, 3.0),
    uavs=st.integers(1, 5),
)
def test_pickups_unique_compact_and_clear(
    courses: int, per_course: int, placed: int, yaw: float, uavs: int
) -> None:
    bp = running_bond(
        courses, per_course, placed_courses=min(placed, courses - 1), yaw_rad=yaw, brick_uavs=uavs
    )
    todo = [b for b in bp.bricks if not b.placed]
    picks = [b.pickup_m for b in todo]
    assert all(p is not None for p in picks)
    keys = {(round(p[0], 6), round(p[1], 6)) for p in picks}  # type: ignore[index]
    assert len(keys) == len(todo), "two bricks share a pickup"
    for b in todo:
        assert min(math.dist(b.pickup_m[:2], w.position_m[:2]) for w in bp.bricks) > bp.clearance_m  # type: ignore[index]
    # compact: the pallet's slots (0.5 m x 0.45 m) fill its bounding rectangle at least half
    c, s = math.cos(-yaw), math.sin(-yaw)
    uv = [(c * p[0] - s * p[1], s * p[0] + c * p[1]) for p in picks]  # type: ignore[index]
    cols = round((max(u for u, _ in uv) - min(u for u, _ in uv)) / 0.5) + 1
    rows = round((max(v for _, v in uv) - min(v for _, v in uv)) / 0.45) + 1
    assert len(todo) >= 0.5 * cols * rows, (cols, rows, len(todo))
    # UAV homes beyond the pallet, r_c apart
    home_v = [s * u.home_m[0] + c * u.home_m[1] for u in bp.fleet]
    assert max(home_v) < min(v for _, v in uv) - bp.clearance_m


def test_long_wall_bricks_face_their_places() -> None:
    def carries(bp):
        return [math.dist(b.pickup_m[:2], b.position_m[:2]) for b in bp.bricks if not b.placed]  # type: ignore[index]

    aligned = carries(running_bond(6, 30))  # 9 m: a pallet as wide as the wall
    rows = carries(
        running_bond(6, 30, pallet_columns=20)
    )  # the same bricks on a 20-column pallet, row by row
    assert sum(aligned) / len(aligned) < 0.9 * sum(rows) / len(rows)  # 4.7 m against 5.5 m
    bp = running_bond(6, 30)
    todo = [b for b in bp.bricks if not b.placed]
    front = max(b.pickup_m[1] for b in todo)  # type: ignore[index]
    # every other brick of the first course (it is fetched first) in the front row, the others 3 rows behind
    first = [b for b in todo if b.position_m[2] < 0.1]
    assert all(b.pickup_m[1] == front for b in first[::2])  # type: ignore[index]
    assert all(abs(b.pickup_m[1] - (front - 3 * 0.45)) < 1e-9 for b in first[1::2])  # type: ignore[index]


def test_long_wall_picks_up_bricks_side_by_side_apart_with_short_carries() -> None:
    # the 12 m wall (bench_fleet's): under `site` the second of two bricks side by side is fetched while the first
    # is laid; picked up side by side (the old pallet: 0.5 m apart for 37 of 78 pairs, 1.2 m or more for 18),
    # their UAVs met at the pallet (docs/performance/fleet.md)
    bp = running_bond(3, 40, placed_courses=1)
    todo = [b for b in bp.bricks if not b.placed]
    pairs = [(a, b) for a, b in itertools.pairwise(todo) if a.position_m[2] == b.position_m[2]]
    apart = [a for a, b in pairs if math.dist(a.pickup_m[:2], b.pickup_m[:2]) >= 1.2]  # type: ignore[index]
    assert len(apart) >= 0.4 * len(pairs), (len(apart), len(pairs))  # 39 of 78
    carries = [math.dist(b.pickup_m[:2], b.position_m[:2]) for b in todo]  # type: ignore[index]
    assert (
        sum(carries) / len(carries) <= 3.3 and max(carries) <= 4.0
    )  # 3.25 / 3.93 m (the old: 3.32 / 4.49 m)


@pytest.mark.parametrize("per_course", [2, PALLET_MIN_COLUMNS])
def test_short_wall_keeps_the_row_by_row_pallet(per_course: int) -> None:
    bp = towers(2, 3, spacing_m=1.0) if per_course == 2 else running_bond(2, per_course)
    todo = [b for b in bp.bricks if not b.placed]
    xs = [b.pickup_m[0] for b in todo]  # type: ignore[index]
    if per_course == 2:  # 6 bricks, one row of 6 slots, in brick order
        assert xs == sorted(xs) and len(set(xs)) == 6
    else:  # 3 m wall: 10 columns, row by row
        assert [round(x, 6) for x in xs[:10]] == sorted(round(x, 6) for x in xs[:10])
