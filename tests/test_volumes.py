"""The volume geometry of the airspace (``masonry.mission.volumes``): the written-out ``volumes_clear`` is
``not any(volumes_conflict(...))`` over the pairs, exactly."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.mission.volumes import (
    Volume,
    point_segment_m,
    segment_segment_m,
    volumes_clear,
    volumes_conflict,
)

coord = st.floats(-6.0, 6.0, allow_nan=False).map(
    lambda v: round(v, 2)
)  # rounded: ties at the boundaries occur
alt = st.floats(0.0, 6.0, allow_nan=False).map(lambda v: round(v, 1))


@st.composite
def volumes(draw):
    a = (draw(coord), draw(coord))
    b = a if draw(st.booleans()) else (draw(coord), draw(coord))
    z0 = draw(alt)
    z1 = z0 if draw(st.booleans()) else z0 + draw(alt)
    slack = draw(st.sampled_from([0.0, 0.0, 0.3, 0.5]))
    kind = draw(st.sampled_from(["climb", "leg", "zone", "hover"]))
    return Volume(a, b, z0, z1, slack, kind)


@settings(max_examples=400, deadline=None, derandomize=True)
@given(
    vols=st.lists(volumes(), max_size=4),
    others=st.lists(volumes(), max_size=8),
    sep_xy=st.sampled_from([0.5, 1.0, 1.2]),
    sep_z=st.sampled_from([1.0, 1.1 - 1e-9]),
)
def test_volumes_clear_is_no_pair_in_conflict(vols, others, sep_xy, sep_z):
    expected = not any(volumes_conflict(v, q, sep_xy, sep_z) for v in vols for q in others)
    assert volumes_clear(vols, others, sep_xy, sep_z) == expected, (vols, others, sep_xy, sep_z)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(p=volumes(), q=volumes())
def test_conflict_is_symmetric(p, q):
    assert volumes_conflict(p, q, 1.2, 1.1) == volumes_conflict(q, p, 1.2, 1.1)


def test_two_volumes_apart_by_exactly_the_separation_do_not_conflict():
    p = Volume((0.0, 0.0), (0.0, 0.0), 0.0, 2.0)
    assert not volumes_conflict(p, Volume((1.2, 0.0), (1.2, 0.0), 0.0, 2.0), 1.2, 1.1)
    assert volumes_conflict(p, Volume((1.19, 0.0), (1.19, 0.0), 0.0, 2.0), 1.2, 1.1)
    assert not volumes_conflict(p, Volume((0.5, 0.0), (0.5, 0.0), 3.1, 4.0), 1.2, 1.1)  # 1.1 m above
    assert volumes_clear([p], [], 1.2, 1.1)


def test_segment_distances():
    assert point_segment_m((0.0, 1.0), (-1.0, 0.0), (1.0, 0.0)) == 1.0
    assert point_segment_m((3.0, 0.0), (-1.0, 0.0), (1.0, 0.0)) == 2.0
    assert segment_segment_m((-1.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (1.0, -1.0)) == 0.0  # crossing
    assert math.isclose(segment_segment_m((0.0, 0.0), (1.0, 0.0), (0.0, 2.0), (1.0, 3.0)), 2.0)
