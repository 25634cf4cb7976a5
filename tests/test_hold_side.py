"""Hold points on the waiting UAV's side of its site (issue 27): of the admissible points of a ring, the one nearest
the UAV first (``masonry.mission.volumes.hold_points``' ``from_m``), so that a UAV sent to wait flies towards its
site, not round the far side of it. The choice is among the same points, each as far from everyone else as before
(docs/safety.md, "Layers, hold flights, order"); and the admissible points on its straight line to the site
among them, by their distance from the site."""

from __future__ import annotations

import itertools
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.mission.airspace import ColumnClearance
from masonry.mission.volumes import hold_points, point_segment_m

R = 1.5
BASE = 1.35


def _working(c: ColumnClearance, uav: str, site: tuple[float, float, float]) -> None:
    assert c.request(uav, site, 0.0, site).granted
    c.end_transit(uav)


def test_a_uav_coming_from_the_south_waits_south_of_its_site_not_east_of_it():
    c = ColumnClearance(R, BASE)
    _working(c, "a", (0.0, 0.0, 1.2))  # a works 0.5 m from b's site: b must wait
    b = c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))  # b comes from the pallet, 3 m south
    assert not b.granted and b.hold_m is not None
    # before: the first admissible point of the ring by its angle from east, (2.0, 0.0): 3.6 m from b, past
    # its site; now the nearest admissible one to b, south-east of the site (1.7 m from a's zone, >= 1.65 m)
    assert b.hold_m[1] < -1.0, b.hold_m
    assert math.dist(b.hold_m[:2], (0.0, -3.0)) < 2.0
    assert math.dist(b.hold_m[:2], (0.0, 0.0)) >= 1.1 * c.wait_radius_m - 1e-9
    assert c.conflicts() == []


def test_with_two_others_in_the_air_the_hold_points_keep_their_old_order():
    c = ColumnClearance(R, BASE)
    _working(c, "a", (0.0, 0.0, 1.2))
    _working(c, "c", (8.0, 8.0, 1.2))  # a third UAV in the air: a hold point on b's side may be in its way
    b = c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))
    assert b.hold_m is not None and b.hold_m[:2] == (2.0, 0.0)  # the first by its angle from east, as before
    assert c.conflicts() == []


def test_without_a_start_the_points_keep_their_old_order():
    site = (0.5, 0.0, 1.2)
    assert hold_points(site, [(0.0, 0.0)], [], R)[0] == (2.0, 0.0, 1.2)


coord = st.floats(-4.0, 4.0, allow_nan=False, allow_infinity=False)
point = st.tuples(coord, coord)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    site=point,
    keep_out=st.lists(point, max_size=5),
    spans=st.lists(st.tuples(point, point), max_size=2),
    start=point,
    radius_m=st.sampled_from([0.8, 1.2, 1.5, 2.0]),
)
def test_the_points_are_the_same_admissible_ones_and_those_on_the_uav_s_line_nearest_the_uav_first_in_each_ring(
    site, keep_out, spans, start, radius_m
):
    s3 = (site[0], site[1], 1.2)
    before = hold_points(s3, keep_out, spans, radius_m)
    after = hold_points(s3, keep_out, spans, radius_m, from_m=start)
    far = math.dist(site, start)
    extra = list(after)
    for p in before:
        if p != (site[0] + 8 * max(radius_m, 0.25), site[1], 1.2) or p in extra:
            extra.remove(p)  # every point of before is there (the far point only if still none is admissible)
    for p in extra:  # the others lie on the UAV's straight line to its site, no farther than the UAV
        assert point_segment_m(p[:2], site, start) < 1e-6, (p, site, start)
        assert radius_m - 1e-9 <= math.dist(p[:2], site) <= far + 1e-9
    ring = [math.hypot(p[0] - site[0], p[1] - site[1]) for p in after]
    assert all(a <= b + 1e-9 for a, b in itertools.pairwise(ring))  # rings nearest the site first, as before
    if after != [(site[0] + 8 * max(radius_m, 0.25), site[1], 1.2)]:  # (none admissible: one far point)
        # every one as far from the others' points and spans as before (1.1 r): the safety of a hold point
        for p in after:
            assert all(math.dist(p[:2], k) >= 1.1 * radius_m - 1e-9 for k in keep_out)
            assert all(point_segment_m(p[:2], a, b) >= 1.1 * radius_m - 1e-9 for a, b in spans)
    for i in range(len(after) - 1):
        if abs(ring[i] - ring[i + 1]) < 1e-9:  # within a ring, nearest the UAV first
            assert math.dist(after[i][:2], start) <= math.dist(after[i + 1][:2], start) + 1e-9


@settings(max_examples=80, deadline=None, derandomize=True)
@given(
    workers=st.lists(point, min_size=1, max_size=3),
    site=point,
    start=point,
)
def test_a_held_uav_waits_clear_of_everyone_and_no_volumes_conflict(workers, site, start):
    c = ColumnClearance(R, BASE)
    names = []
    for i, w in enumerate(workers):
        g = c.request(f"w{i}", (*w, 1.2), 0.0, (*w, 1.2))
        if g.granted:
            c.end_transit(f"w{i}")
            names.append(w)
    g = c.request("x", (*site, 1.2), 1.0, (*start, 1.2))
    assert c.conflicts() == []
    if g.hold_m is not None:
        for w in names:  # 1.1 x the wait radius from every zone: the liveness argument's hold point
            assert math.dist(g.hold_m[:2], w) >= 1.1 * c.wait_radius_m - 1e-9, (g.hold_m, w)
        c.progress("x", (g.hold_m[0], g.hold_m[1], g.layer_m))
        assert c.conflicts() == []
