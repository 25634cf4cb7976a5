"""Geometry kernels of the planner against brute force: grid pairs, segment distances, overlaps, reachability."""

from __future__ import annotations

import itertools
import math

import networkx as nx
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.planner.conflicts import DescendantWindows, conflict_pairs
from masonry.planner.contacts import BrickArrays, find_contacts
from masonry.planner.overlap import (
    chord,
    clip_convex,
    polygon_area_centroid,
    principal_axis,
    rectangle_corners,
    sat_depth,
    segment_distances,
)
from masonry.planner.spatial import cell_coordinates, neighbour_pairs


@settings(max_examples=40)
@given(st.integers(0, 120), st.integers(1, 3), st.floats(0.2, 2.0), st.integers(0, 2**31 - 1))
def test_neighbour_pairs_equal_brute_force(n: int, reach: int, cell: float, seed: int) -> None:
    points = np.random.default_rng(seed).uniform(-3, 3, (n, 3))
    cells = cell_coordinates(points, cell)
    got: list[tuple[int, int]] = []
    for a, b in neighbour_pairs(cells, chunk_pairs=50, reach=reach):
        got.extend((min(x, y), max(x, y)) for x, y in zip(a.tolist(), b.tolist()))
    want = {
        (i, j) for i, j in itertools.combinations(range(n), 2) if np.abs(cells[i] - cells[j]).max() <= reach
    }
    assert len(got) == len(set(got)) and set(got) == want


def _to_segment(points, a, b) -> np.ndarray:
    """The exact distance of each of ``points`` to the segment ``a``-``b`` (the closest point, clamped)."""
    ab = b - a
    length2 = float(ab @ ab)
    t = np.clip((points - a) @ ab / length2, 0.0, 1.0) if length2 > 0.0 else np.zeros(len(points))
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def _sampled_distance(p0, p1, q0, q1, k: int = 301) -> float:
    """k points along each segment, each one's exact distance to the other segment: the least of them.

    Every value is a distance between a point of one segment and a point of the other, so the result is never
    below the true distance, and above it by at most half a sampling step of the shorter segment.
    """
    t = np.linspace(0.0, 1.0, k)[:, None]
    on_p = p0 + t * (p1 - p0)
    on_q = q0 + t * (q1 - q0)
    return float(min(_to_segment(on_p, q0, q1).min(), _to_segment(on_q, p0, p1).min()))


@settings(max_examples=30)
@given(st.integers(0, 2**31 - 1))
def test_segment_distance_matches_sampling(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p0, p1, q0, q1 = (rng.normal(size=(40, 3)) for _ in range(4))
    p1[:10] = p0[:10]  # points
    q1[5:15] = q0[5:15]
    d = segment_distances(p0, p1, q0, q1)
    for i in range(40):
        sampled = _sampled_distance(p0[i], p1[i], q0[i], q1[i])
        assert d[i] <= sampled + 1e-12
        assert (
            d[i] >= sampled - 0.02 * (np.linalg.norm(p1[i] - p0[i]) + np.linalg.norm(q1[i] - q0[i])) - 1e-12
        )


def test_segment_distance_parallel_and_crossing() -> None:
    p0 = np.array([[0.0, 0, 0], [0.0, 0, 0]])
    p1 = np.array([[1.0, 0, 0], [1.0, 0, 0]])
    q0 = np.array([[0.5, 1, 0], [0.5, -1, 2]])
    q1 = np.array([[2.0, 1, 0], [0.5, 1, 2]])
    assert np.allclose(segment_distances(p0, p1, q0, q1), [1.0, 2.0])


def test_clip_area_principal_axis_and_chord() -> None:
    a = rectangle_corners((0.0, 0.0), (0.5, 0.25), 0.0)
    b = rectangle_corners((0.5, 0.0), (0.5, 0.25), 0.0)
    poly = clip_convex(a, b)
    area, centroid = polygon_area_centroid(poly)
    assert math.isclose(area, 0.25) and np.allclose(centroid, (0.25, 0.0))
    (cx, cy), (dx, _) = principal_axis(poly)
    assert math.isclose(abs(dx), 1.0, abs_tol=1e-9)
    assert np.allclose(chord(poly, (cx, cy), (1.0, 0.0)), (-0.25, 0.25))
    assert clip_convex(a, rectangle_corners((3.0, 0.0), (0.5, 0.25), 0.3)) == []


@settings(max_examples=40)
@given(st.integers(0, 2**31 - 1))
def test_sat_depth_sign_matches_polygon_clipping(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 30
    ca, cb = rng.uniform(-0.4, 0.4, (n, 2)), rng.uniform(-0.4, 0.4, (n, 2))
    ha, hb = rng.uniform(0.05, 0.3, (n, 2)), rng.uniform(0.05, 0.3, (n, 2))
    ya, yb = rng.uniform(-3, 3, n), rng.uniform(-3, 3, n)
    depth = sat_depth(ca, ha, ya, cb, hb, yb)
    for i in range(n):
        poly = clip_convex(
            rectangle_corners(tuple(ca[i]), tuple(ha[i]), ya[i]),
            rectangle_corners(tuple(cb[i]), tuple(hb[i]), yb[i]),
        )
        area = polygon_area_centroid(poly)[0] if len(poly) >= 3 else 0.0
        if depth[i] > 1e-6:
            assert area > 0.0
        if depth[i] < -1e-6:
            assert area == 0.0


def test_contacts_on_a_stack_and_side_by_side() -> None:
    arrays = BrickArrays.of(
        [(0, 0, 0.05), (0.3, 0, 0.05), (0.15, 0, 0.15), (2, 0, 0.05), (2.1, 0, 0.08)],
        [(0.3, 0.15, 0.1)] * 5,
        [0.0] * 5,
    )
    c = find_contacts(arrays)
    assert sorted(zip(c.upper.tolist(), c.lower.tolist())) == [(2, 0), (2, 1)]
    assert c.penetrating.tolist() == [[3, 4]]


@st.composite
def layered_dags(draw: st.DrawFn) -> tuple[np.ndarray, list[tuple[int, int]]]:
    n = draw(st.integers(2, 40))
    z = np.sort(np.array(draw(st.lists(st.floats(0, 3), min_size=n, max_size=n, unique=True))))
    edges = []
    for u in range(n):
        for v in draw(st.lists(st.integers(0, max(u - 1, 0)), max_size=3, unique=True)):
            if v < u:
                edges.append((u, v))
    return z, edges


@settings(max_examples=60)
@given(layered_dags(), st.floats(0.1, 3.5))
def test_descendant_windows_equal_networkx_reachability(
    dag: tuple[np.ndarray, list[tuple[int, int]]], window: float
) -> None:
    z, edges = dag
    g = nx.DiGraph()
    g.add_nodes_from(range(len(z)))
    g.add_edges_from(edges)
    u = np.array([e[0] for e in edges], dtype=np.int64)
    v = np.array([e[1] for e in edges], dtype=np.int64)
    windows = DescendantWindows(z, window, (u, v))
    pairs = [(a, b) for a, b in itertools.permutations(range(len(z)), 2) if 0 <= z[a] - z[b] <= window]
    if not pairs:
        return
    src = np.array([p[0] for p in pairs])
    dst = np.array([p[1] for p in pairs])
    got = windows.reaches(src, dst)
    want = [nx.has_path(g, a, b) for a, b in pairs]
    assert got.tolist() == want


def test_conflict_pairs_on_points_and_segments() -> None:
    start = np.array([[0.0, 0, 0], [1.0, 0, 0], [3.0, 0, 0], [0.0, 0, 1.0]])
    end = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.5, 0, 0], [0.0, 0, 1.0]])
    a, b = conflict_pairs(start, end, 1.5, (np.array([3]), np.array([0])))
    # 0-1 (1.0), 1-2 (segment end 1.5 away), 1-3 (sqrt 2); 0-3 are dependent; 0-2 is 2.5 away.
    assert list(zip(a.tolist(), b.tolist())) == [(0, 1), (1, 2), (1, 3)]
