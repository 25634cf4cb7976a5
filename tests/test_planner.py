"""The planner: G^d, adhesion lines and G^c on hand-made cases and random walls (hypothesis)."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import Blueprint, BlueprintError, Brick, UavSpec, load_blueprint, validate_blueprint
from masonry.blueprint_gen import pyramid, running_bond, towers
from masonry.planner import AdhesionTask, BrickTask, plan
from masonry.planner.overlap import segment_distances

ROOT = Path(__file__).resolve().parents[1]
FLEET = (UavSpec("b", "brick", (0.0, -3.0, 0.0)), UavSpec("g", "adhesion", (2.0, -3.0, 0.0)))


def _bp(bricks: list[Brick], clearance: float = 1.5) -> Blueprint:
    return Blueprint(bricks=tuple(bricks), fleet=FLEET, clearance_m=clearance, source="<test>")


def _brick(
    bid: int,
    x: float,
    y: float,
    z: float,
    *,
    yaw: float = 0.0,
    placed: bool = False,
    size: tuple[float, float, float] = (0.30, 0.15, 0.10),
) -> Brick:
    # every brick its own pickup (two bricks cannot lie at one spot), off the wall
    return Brick(bid, (x, y, z), size, yaw, placed, None if placed else (5.0 + 0.5 * bid, 5.0, size[2] / 2))


def test_paper_case_study() -> None:
    p = plan(load_blueprint(ROOT / "blueprints" / "paper_case_study.yaml"))
    assert p.available() == ["A0", "A1"]
    assert set(p.conflicts) == {("B0", "B1"), ("B0", "A1"), ("B1", "A0"), ("A0", "A1")}
    assert set(p.dependencies) == {("B0", "A0"), ("A0", "B3"), ("B1", "A1"), ("A1", "B5")}
    assert [t.id for t in p.tasks if t.done] == ["B2", "B3", "B4", "B5"]


def test_issue_example_segment() -> None:
    p = plan(_bp([_brick(0, 0, 0, 0.05, placed=True), _brick(1, 0, 0, 0.15)]))
    a = p.task("A0")
    assert isinstance(a, AdhesionTask)
    assert (a.below, a.above) == (0, 1)
    assert a.start_m == pytest.approx((-0.15, 0.0, 0.1)) and a.end_m == pytest.approx((0.15, 0.0, 0.1))
    assert a.length_m == pytest.approx(0.3)
    assert p.dependencies == (("B1", "A0"), ("A0", "B0"))
    b1 = p.task("B1")
    assert isinstance(b1, BrickTask) and b1.size_m == (0.30, 0.15, 0.10) and not b1.done


def test_running_bond_segment_spans_half_brick_on_mid_line() -> None:
    p = plan(_bp([_brick(0, 0, 0, 0.05, placed=True), _brick(1, 0.15, 0.02, 0.15)]))
    a = p.task("A0")
    assert a.start_m == pytest.approx((0.0, 0.01, 0.1)) and a.end_m == pytest.approx((0.15, 0.01, 0.1))


def test_header_across_stretcher_uses_overlap_principal_axis() -> None:
    # A 0.30 x 0.15 brick turned 90 degrees on a stretcher: the overlap is 0.15 (x) by 0.30 clipped to 0.15 (y)
    # ... made longer along y by a wider lower brick so the principal axis is unambiguous.
    lower = _brick(0, 0, 0, 0.05, placed=True, size=(0.30, 0.25, 0.10))
    upper = _brick(1, 0, 0, 0.15, yaw=math.pi / 2)
    a = plan(_bp([lower, upper])).task("A0")
    assert a.start_m == pytest.approx((0.0, -0.125, 0.1)) and a.end_m == pytest.approx((0.0, 0.125, 0.1))


def test_rotated_brick_segment_is_principal_axis_chord() -> None:
    lower = _brick(0, 0, 0, 0.05, placed=True, size=(0.40, 0.40, 0.10))
    upper = _brick(1, 0, 0, 0.15, yaw=math.pi / 6, size=(0.30, 0.10, 0.10))
    a = plan(_bp([lower, upper])).task("A0")
    direction = np.subtract(a.end_m, a.start_m)
    assert math.atan2(direction[1], direction[0]) == pytest.approx(math.pi / 6)
    assert a.length_m == pytest.approx(0.30)


def test_bricks_side_by_side_do_not_interpenetrate() -> None:
    p = plan(_bp([_brick(0, 0, 0, 0.05), _brick(1, 0.30, 0, 0.05)]))
    assert p.dependencies == () and p.conflicts == (("B0", "B1"),)


def test_plan_rejects_an_invalid_blueprint_value() -> None:
    with pytest.raises(BlueprintError, match="brick 1"):
        plan(_bp([_brick(0, 0, 0, 0.05), _brick(1, 3.0, 0, 0.35)]))


def test_longest_chain_and_available_on_a_wall() -> None:
    p = plan(running_bond(3, 4, placed_courses=1))
    chain = p.longest_chain()
    assert len(chain) == 4  # B(course 2) -> A -> B(course 1) -> A
    deps = set(p.dependencies)
    assert all((u, v) in deps for u, v in itertools.pairwise(chain))
    assert all(t.startswith("A") for t in p.available())
    assert p.available(done=p.available()) != p.available()


# ------------------------------------------------------------------------------- random walls (hypothesis)


@st.composite
def walls(draw: st.DrawFn, max_bricks: int = 18) -> Blueprint:
    """Random courses of random-size bricks with random yaws, offsets and gaps; bottom courses pre-placed."""
    height = draw(st.floats(0.05, 0.15))
    courses = draw(st.integers(1, 4))
    placed_courses = draw(st.integers(0, max(courses - 1, 0)))
    clearance = draw(st.floats(0.2, 1.5))
    bricks: list[Brick] = []
    for course in range(courses):
        x = draw(st.floats(-0.15, 0.15))
        for _ in range(draw(st.integers(2, 6))):
            length = draw(st.floats(0.2, 0.4))
            width = draw(st.floats(0.1, 0.2))
            yaw = draw(st.sampled_from([0.0, 0.0, math.pi / 2, math.pi]) | st.floats(-0.6, 0.6))
            y = draw(st.floats(-0.05, 0.05))
            z = course * height + height / 2 + draw(st.sampled_from([0.0, 0.0, 0.003, -0.004]))
            extent = abs(math.cos(yaw)) * length + abs(math.sin(yaw)) * width  # footprint along x
            candidate = Brick(
                len(bricks),
                (x + extent / 2, y, z),
                (length, width, height),
                yaw,
                course < placed_courses,
                None if course < placed_courses else (9.0, 9.0, height / 2),
            )
            try:
                validate_blueprint(_bp([*bricks, candidate], clearance))
            except BlueprintError:
                pass  # floating or interpenetrating: leave it out
            else:
                bricks.append(candidate)
            x += extent + draw(st.sampled_from([0.0, 0.0, 0.02, 0.1, -0.1]))
            if len(bricks) >= max_bricks:
                break
    if not bricks:
        bricks.append(
            Brick(0, (0.0, 0.0, height / 2), (0.3, 0.15, height), 0.0, False, (9.0, 9.0, height / 2))
        )
    return _bp(bricks, clearance)


def _graph(p):
    g = nx.DiGraph()
    g.add_nodes_from(t.id for t in p.tasks)
    g.add_edges_from(p.dependencies)
    return g


def _inside(point: tuple[float, float], brick: Brick, tol: float = 1e-7) -> bool:
    c, s = math.cos(brick.yaw_rad), math.sin(brick.yaw_rad)
    dx, dy = point[0] - brick.position_m[0], point[1] - brick.position_m[1]
    u, v = c * dx + s * dy, -s * dx + c * dy
    return abs(u) <= brick.size_m[0] / 2 + tol and abs(v) <= brick.size_m[1] / 2 + tol


@pytest.mark.slow
@settings(max_examples=60)
@given(walls())
def test_random_walls_graph_invariants(bp: Blueprint) -> None:
    p = plan(bp)
    g = _graph(p)
    assert nx.is_directed_acyclic_graph(g)
    tasks = {t.id: t for t in p.tasks}
    # Every unplaced brick off the ground waits for at least one adhesion task.
    for b in bp.bricks:
        if not b.placed and b.bottom_z_m > 0.005:
            assert any(tasks[v].kind == "adhesion" for v in g.successors(f"B{b.id}")), b
    # No adhesion task joins two pre-placed bricks; every one sits between its two bricks.
    for t in p.tasks:
        if isinstance(t, AdhesionTask):
            assert not bp.brick(t.above).placed
            assert set(g.predecessors(t.id)) == {f"B{t.above}"} and set(g.successors(t.id)) == {f"B{t.below}"}
    # Conflicts: unique, between tasks to do, never dependent.
    pairs = [frozenset(c) for c in p.conflicts]
    assert len(set(pairs)) == len(pairs) and all(len(c) == 2 for c in pairs)
    closure = nx.transitive_closure_dag(g)
    for a, b in p.conflicts:
        assert not tasks[a].done and not tasks[b].done
        assert not closure.has_edge(a, b) and not closure.has_edge(b, a)


@pytest.mark.slow
@settings(max_examples=60)
@given(walls())
def test_random_walls_adhesion_segments_on_lower_top_face_inside_both_footprints(bp: Blueprint) -> None:
    for t in plan(bp).tasks:
        if isinstance(t, AdhesionTask):
            lower, upper = bp.brick(t.below), bp.brick(t.above)
            assert t.start_m[2] == pytest.approx(lower.top_z_m) and t.end_m[2] == pytest.approx(lower.top_z_m)
            assert t.length_m == pytest.approx(math.dist(t.start_m, t.end_m))
            assert t.length_m > 0
            for point in (t.start_m, t.end_m, t.location_m):
                assert _inside(point[:2], lower) and _inside(point[:2], upper), (t, point)
            if abs(math.sin(upper.yaw_rad - lower.yaw_rad)) < 1e-12 and t.length_m > 1e-9:
                # Parallel bricks: along the lower brick's length axis.
                direction = np.subtract(t.end_m, t.start_m)[:2] / t.length_m
                axis = (math.cos(lower.yaw_rad), math.sin(lower.yaw_rad))
                assert abs(direction[0] * axis[1] - direction[1] * axis[0]) < 1e-9


def _oracle(p, clearance: float) -> set[tuple[str, str]]:
    """All pairs of tasks to do within r_c, minus pairs joined by a path in G^d: the brute-force definition."""
    closure = nx.transitive_closure_dag(_graph(p))
    index = {t.id: k for k, t in enumerate(p.tasks)}
    todo = [t for t in p.tasks if not t.done]

    def seg(t):
        return (t.position_m, t.position_m) if isinstance(t, BrickTask) else (t.start_m, t.end_m)

    out = set()
    for x, y in itertools.combinations(todo, 2):
        d = segment_distances(*(np.array([v], dtype=float) for v in (*seg(x), *seg(y))))[0]
        if d <= clearance + 1e-9 and not closure.has_edge(x.id, y.id) and not closure.has_edge(y.id, x.id):
            out.add(tuple(sorted((x.id, y.id), key=index.__getitem__)))
    return out


@pytest.mark.slow
@settings(max_examples=60)
@given(walls())
def test_random_walls_conflicts_equal_brute_force_oracle(bp: Blueprint) -> None:
    p = plan(bp)
    assert set(p.conflicts) == _oracle(p, bp.clearance_m)
    index = {t.id: k for k, t in enumerate(p.tasks)}
    keys = [(index[a], index[b]) for a, b in p.conflicts]
    assert all(a < b for a, b in keys) and keys == sorted(keys)


@pytest.mark.parametrize(
    "bp",
    [
        running_bond(6, 9, placed_courses=2),
        pyramid(7, yaw_rad=0.4),
        towers(5, 5, spacing_m=0.9),
        running_bond(5, 7, clearance_m=0.4),
    ],
    ids=["running-bond", "pyramid-rotated", "towers", "small-clearance"],
)
def test_generated_walls_equal_oracle(bp: Blueprint) -> None:
    p = plan(bp)
    assert set(p.conflicts) == _oracle(p, bp.clearance_m)


def test_json_fast_path_equals_plain_conversion() -> None:
    import json

    from masonry.planner.export import _pairs_json, plan_json, plan_to_dict
    from masonry.planner.graphs import plan_graphs

    bp = running_bond(6, 12, placed_courses=1, yaw_rad=0.2)
    p = plan(bp)
    assert json.loads(plan_json(p)) == plan_to_dict(p)
    assert json.loads(plan_json(plan_graphs(bp))) == plan_to_dict(p)
    chunked = "".join(_pairs_json(p, None, p.conflict_indices, chunk=7))
    assert json.loads(chunked) == [list(c) for c in p.conflicts]
    assert plan_graphs(bp).to_plan() == p
