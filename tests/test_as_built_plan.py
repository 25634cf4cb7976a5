"""Work planned on what was built (issue 30): masonry.planner.as_built_plan, the assignment's ``planned`` and the
blueprint's ``plan_on_as_built`` / ``as_built_pullback_m``, and a mission that flies the planned targets."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from masonry.blueprint import BlueprintError, format_blueprint, parse_blueprint
from masonry.blueprint_gen import running_bond, towers
from masonry.blueprint_yaml import safe_load
from masonry.cli import app
from masonry.errors import ProtocolError
from masonry.fsm.wall_align import WallAlign
from masonry.mission.as_built import PlacementWatch
from masonry.mission.messages import Assign, decode, encode
from masonry.mission.records import Attempt
from masonry.mission.simulate import SimulatedMission
from masonry.perception.types import AsBuiltPose
from masonry.placement_check import PlacementCheck
from masonry.planner.as_built_plan import (
    MAX_PLANNED_SHIFT_M,
    AsBuiltPlan,
    AsBuiltPlanning,
    planned_shift_m,
    pulled_back,
    supports_of,
)
from masonry.planner.graphs import plan
from masonry.planner.tasks import AdhesionTask, BrickTask
from masonry.ports import TaskResult

runner = CliRunner()
mm = st.floats(-0.2, 0.2, allow_nan=False)
SEEDED = settings(derandomize=True, max_examples=200, deadline=None)


def _pose(position_m, design_m=None) -> AsBuiltPose:
    dev = 0.0 if design_m is None else math.dist(position_m, design_m)
    return AsBuiltPose(tuple(float(v) for v in position_m), 0.0, dev, 0.9)


@SEEDED
@given(mm, mm, mm, st.floats(0.0, 0.05), st.floats(0.0, 0.05))
def test_the_pull_back_is_bounded_and_keeps_the_direction(dx, dy, dz, pullback_m, cap_m) -> None:
    x, y, z = pulled_back((dx, dy, dz), pullback_m, cap_m)
    n, m = math.hypot(dx, dy), math.hypot(x, y)
    assert m <= cap_m + 1e-12  # never farther from the design than the cap
    assert m <= max(n - pullback_m, 0.0) + 1e-12  # at least pullback_m nearer the design (or on it)
    if n - pullback_m <= cap_m:
        assert math.hypot(dx - x, dy - y) <= pullback_m + 1e-12  # at most pullback_m off its supports
    assert dx * x + dy * y >= 0.0 and abs(dx * y - dy * x) <= 1e-12  # toward the design, along the deviation
    assert abs(z) <= cap_m and (z == dz or abs(z) == cap_m)  # vertically it follows (within the cap)


def test_no_deviation_is_the_design_exactly() -> None:
    assert pulled_back((0.0, 0.0, 0.0), 0.005, 0.02) == (0.0, 0.0, 0.0)
    bp = running_bond(4, 3)
    tasks = plan(bp).tasks
    planner = AsBuiltPlan(tasks)
    on_design = {t.brick: _pose(t.position_m) for t in tasks if isinstance(t, BrickTask)}
    for t in tasks:
        assert planner.planned(t, {}) is None  # nothing known: the design
        assert planner.planned(t, on_design) is None  # all built on their design: the design


@SEEDED
@given(st.lists(st.tuples(mm, mm), min_size=2, max_size=5), st.sampled_from([(0, 1), (1, 2), (2, 3)]))
def test_any_deviations_give_targets_within_the_cap_and_the_bound(offsets, course_pair) -> None:
    bp = running_bond(4, 3)
    tasks = plan(bp).tasks
    bricks = [t for t in tasks if isinstance(t, BrickTask)]
    planner = AsBuiltPlan(tasks, AsBuiltPlanning(pullback_m=0.003, max_shift_m=0.02))
    poses = {
        t.brick: _pose((t.position_m[0] + dx, t.position_m[1] + dy, t.position_m[2]))
        for t, (dx, dy) in zip(bricks, offsets * 4)
    }
    for t in tasks:
        p = planner.planned(t, poses)
        if p is None:
            continue
        shift = planned_shift_m(t, p)
        assert shift is not None and shift <= 0.02 * math.sqrt(2) + 1e-9 <= MAX_PLANNED_SHIFT_M


def test_a_tall_tower_does_not_accumulate_a_bias_smaller_than_the_pull_back() -> None:
    """Each placement lands ``bias`` off its target: planned on the as-built, the deviation from the design stays
    at ``bias`` when it is below the pull-back, and below the cap whatever it is (30 courses)."""
    bp = towers(1, 30)
    tasks = plan(bp).tasks
    bricks = sorted((t for t in tasks if isinstance(t, BrickTask)), key=lambda t: t.position_m[2])
    for bias_m, pullback_m, bound_m in ((0.004, 0.005, 0.004), (0.009, 0.005, 0.02 + 0.009)):
        planner = AsBuiltPlan(tasks, AsBuiltPlanning(pullback_m=pullback_m, max_shift_m=0.02))
        poses: dict[int, AsBuiltPose] = {}
        for t in bricks:
            target = planner.planned(t, poses) or t
            built = (target.position_m[0] + bias_m, target.position_m[1], target.position_m[2])
            poses[t.brick] = _pose(built, t.position_m)
            assert math.dist(built, t.position_m) <= bound_m + 1e-12
        # without the pull-back the tower would lean by bias_m a course: 30 x bias_m at the top
        assert math.dist(poses[bricks[-1].brick].position_m, bricks[-1].position_m) < 30 * bias_m / 2


def test_targets_keep_the_offsets_to_their_supports_and_segments_move_with_their_bricks() -> None:
    bp = running_bond(2, 2)  # course 1: one brick on both of course 0's
    tasks = plan(bp).tasks
    by_brick = {t.brick: t for t in tasks if isinstance(t, BrickTask)}
    assert supports_of(tasks)
    (top,) = [b for b, s in supports_of(tasks).items() if len(s) == 2]
    s0, s1 = supports_of(tasks)[top]
    d0, d1 = (0.012, 0.0, 0.002), (0.008, 0.004, 0.002)
    poses = {
        s: _pose(tuple(a + b for a, b in zip(by_brick[s].position_m, d))) for s, d in ((s0, d0), (s1, d1))
    }
    planner = AsBuiltPlan(tasks, AsBuiltPlanning(pullback_m=0.005, max_shift_m=0.02))
    brick = planner.planned(by_brick[top], poses)
    assert isinstance(brick, BrickTask)
    mean = (0.010, 0.002, 0.002)
    n = math.hypot(mean[0], mean[1])
    want = tuple(d + m * (n - 0.005) / n for d, m in zip(by_brick[top].position_m[:2], mean[:2]))
    assert brick.position_m[:2] == pytest.approx(want, abs=1e-12)
    assert brick.position_m[2] == pytest.approx(by_brick[top].position_m[2] + 0.002, abs=1e-12)
    seg = next(t for t in tasks if isinstance(t, AdhesionTask) and t.below == s0)
    moved = planner.planned(seg, poses)
    assert isinstance(moved, AdhesionTask)
    target = planner.target_deviation_m(top, poses)
    shift = ((d0[0] + target[0]) / 2, (d0[1] + target[1]) / 2, d0[2])
    for a, b in ((moved.start_m, seg.start_m), (moved.end_m, seg.end_m)):
        assert tuple(x - y for x, y in zip(a, b)) == pytest.approx(shift, abs=1e-12)
    # a support the blueprint lists as placed counts as on its design; one not seen is left out
    assert planner.target_deviation_m(top, {s0: poses[s0]}) == pytest.approx(
        pulled_back(d0, 0.005, 0.02), abs=1e-12
    )


def _assign(planned=None) -> Assign:
    task = plan(towers(1, 2)).tasks[1]
    return Assign("mission-control", "brick-1", task, 1, 3.0, "w", planned)


def test_the_assignment_carries_the_planned_task_and_without_it_reads_as_before() -> None:
    a = _assign()
    assert b'"planned"' not in encode(a) and decode(encode(a)) == a and a.flown == a.task
    t = a.task
    moved = dataclasses.replace(t, position_m=(t.position_m[0] + 0.01, t.position_m[1], t.position_m[2]))
    b = _assign(moved)
    back = decode(encode(b))
    assert back == b and back.flown == moved


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"position_m": (0.06, 0.0, 0.0)}, "moves task B1 0.060 m from its design"),
        ({"size_m": (0.3, 0.1, 0.1)}, "must be task B1 with only its target or segment moved"),
        ({"id": "B0"}, "must be task B1 with only its target or segment moved"),
    ],
)
def test_a_planned_task_farther_than_the_bound_or_another_task_is_refused(change, message) -> None:
    t = _assign().task
    if "position_m" in change:
        dx = change["position_m"][0]
        change = {"position_m": (t.position_m[0] + dx, t.position_m[1], t.position_m[2])}
    with pytest.raises(ProtocolError, match=message):
        decode(encode(_assign(dataclasses.replace(t, **change))))


def test_the_blueprint_fields_parse_write_back_and_refuse_bad_values(tmp_path: Path) -> None:
    base = dict(safe_load(format_blueprint(running_bond(1, 2))))
    assert parse_blueprint(base).placement == PlacementCheck()
    assert not PlacementCheck().plan_on_as_built and PlacementCheck().pullback_m == 0.005
    bp = parse_blueprint({**base, "plan_on_as_built": True, "as_built_pullback_m": 0.002})
    assert bp.placement == PlacementCheck(0.02, "continue", True, 0.002)
    assert parse_blueprint(safe_load(format_blueprint(bp))).placement == bp.placement
    assert "plan_on_as_built" not in format_blueprint(running_bond(1, 2))
    for extra, message in (
        ({"plan_on_as_built": "yes"}, "plan_on_as_built: must be true or false, got 'yes'"),
        ({"as_built_pullback_m": 0.5}, "as_built_pullback_m: 0.5 m is outside [0, 0.05] m"),
    ):
        with pytest.raises(BlueprintError, match=message.replace("[", r"\[")):
            parse_blueprint({**base, **extra}, "wall.yaml")
        path = tmp_path / "wall.yaml"
        path.write_text(json.dumps({**base, **extra}))
        res = runner.invoke(app, ["sim", str(path), "--no-progress"])
        assert res.exit_code == 2 and res.output.strip().count("\n") == 0 and "wall.yaml" in res.output


def test_a_mission_flies_the_targets_planned_on_the_as_built_poses() -> None:
    """A 5-brick tower on the arducopter model with ``plan_on_as_built`` (the default pull-back): every task the
    UAVs are handed is the one planned on the poses reported before it, some are off the design, and the report's
    deviations are from the design."""
    bp = towers(1, 5, clearance_m=1.0)
    bp = dataclasses.replace(bp, placement=PlacementCheck(plan_on_as_built=True))
    mission = SimulatedMission.from_blueprint(bp, seed=1, vehicle="arducopter")
    flown: list = []
    for h in mission.handlers.values():

        def tap(poll=h.poll_task):
            t = poll()
            if t is not None:
                flown.append(t)
            return t

        h.poll_task = tap
    report = mission.run()
    assert report.completed
    tasks = plan(bp).tasks
    design = {t.id: t for t in tasks}
    # (planned on the UAVs' looks: the report's height is the course's, the look it replaced ``world_position_m``)
    poses = {
        int(tid[1:]): pose
        if pose.world_position_m is None
        else dataclasses.replace(pose, position_m=pose.world_position_m)
        for tid, pose in report.as_built.items()
    }
    assert len(poses) == 5
    planner = AsBuiltPlan(tasks, AsBuiltPlanning(0.005, 0.02))
    moved = 0
    for t in flown:
        want = planner.planned(design[t.id], poses) or design[t.id]
        assert t == want
        moved += t != design[t.id]
    assert moved >= 2  # (tasks on bricks seen more than the pull-back off their design)
    for tid, pose in report.as_built.items():
        assert pose.deviation_m == pytest.approx(
            math.dist(pose.position_m, design[tid].position_m), abs=1e-12
        )


def test_the_watch_plans_on_the_journal_poses_of_a_resumed_mission_and_measures_from_the_design() -> None:
    """Mission control's side (``PlacementWatch``): the poses of the attempts a resumed mission restored are known
    at its first assignment; a completion's deviation is measured from the design; off, nothing is planned."""
    p = plan(towers(1, 3))
    b0, b1 = p.task("B0"), p.task("B1")
    assert isinstance(b0, BrickTask) and isinstance(b1, BrickTask)
    built = (b0.position_m[0] + 0.01, b0.position_m[1], b0.position_m[2])
    restored = Attempt("B0", "brick-1", 1, 0.0, 5.0, "done", as_built=_pose(built, b0.position_m))
    mc = SimpleNamespace(plan=p, history=[restored], wall_digest="w")
    assert PlacementWatch().assign(mc, "brick-1", b1, 1, 6.0) == Assign(
        "mission-control", "brick-1", b1, 1, 6.0, "w"
    )
    watch = PlacementWatch(PlacementCheck(plan_on_as_built=True, pullback_m=0.0))
    a = watch.assign(mc, "brick-1", b1, 1, 6.0)
    assert a.planned is not None and a.flown.position_m == pytest.approx(
        (b1.position_m[0] + 0.01, b1.position_m[1], b1.position_m[2]), abs=1e-12
    )
    seen = AsBuiltPose(a.flown.position_m, 0.0, 0.0, 0.9)  # (the UAV measured from the target it flew)
    r = watch.against_design(TaskResult("B1", "done", 30.0, as_built=seen))
    assert r.as_built is not None and r.as_built.deviation_m == pytest.approx(0.01, abs=1e-12)


def test_the_wall_alignment_adds_its_offset_to_the_brick_s_own_design_not_to_a_planned_target() -> None:
    """Both measure the supports' deviation: added to a planned target, the wall's offset would count it twice."""
    align = WallAlign()
    align.reset(np.array([1.0, 2.0, 0.30]))  # the drop-off flown (planned 1 cm off the design)
    own = (0.99, 2.0, 0.30)
    assert align._base_m(own).tolist() == list(own)
    assert align._base_m(None).tolist() == [1.0, 2.0, 0.30]  # (reused marker numbers: no design to go by)
    assert align._base_m((1.0, 2.0, 0.30)) is align.design_m  # as designed: exactly as before
