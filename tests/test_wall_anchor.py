"""The as-built pose anchored on the wall (issue 30): a placed brick's reported position from its chain of relative
looks to a surveyed brick (masonry.planner.wall_anchor), journaled, reported and shown as such."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, seed, settings
from hypothesis import strategies as st

from masonry.blueprint_gen import pyramid, towers
from masonry.mission.events import EventList
from masonry.mission.simulate import SimulatedMission, simulate
from masonry.perception.types import AsBuiltPose
from masonry.planner import wall_anchor
from masonry.planner.graphs import plan
from masonry.planner.tasks import BrickTask
from masonry.planner.wall_anchor import MIN_WORLD_SIGMA_M, RELATIVE_SIGMA_M, WallAnchor
from masonry.planner.wall_deviation import MAX_WALL_DEVIATION_M
from masonry.planner.wall_solve import Wall

# one tower of four: B0 surveyed (placed), B1 on B0, B2 on B1, B3 on B2
TOWER = plan(towers(1, 4, placed_courses=1))
Vec3 = tuple[float, float, float]


def _task(brick: int) -> BrickTask:
    t = TOWER.task(f"B{brick}")
    assert isinstance(t, BrickTask)
    return t


def _look(brick: int, ref: int | None, truth: dict[int, Vec3], world_err: Vec3, rel_err: Vec3) -> AsBuiltPose:
    """Brick ``brick`` (true centre ``truth[brick]``) seen ``world_err`` off in the world frame and, with ``ref``,
    its top-face offset from ``ref`` seen ``rel_err`` off the true one."""
    t = truth[brick]
    world = (t[0] + world_err[0], t[1] + world_err[1], t[2] + world_err[2])
    dev = math.dist(world, _task(brick).position_m)
    if ref is None:
        return AsBuiltPose(world, 0.0, dev, 0.9)
    offset = (
        t[0] - truth[ref][0] + rel_err[0],
        t[1] - truth[ref][1] + rel_err[1],
        t[2] - truth[ref][2] + rel_err[2],
    )
    return AsBuiltPose(world, 0.0, dev, 0.9, ref, offset, 0.0)


def _truth(shifts: list[tuple[float, float]]) -> dict[int, Vec3]:
    """The tower's true centres: B0 on its design, each brick above shifted ``shifts[i]`` horizontally off it."""
    out = {0: _task(0).position_m}
    for b, (dx, dy) in enumerate(shifts, start=1):
        x, y, z = _task(b).position_m
        out[b] = (x + dx, y + dy, z)
    return out


def test_a_hand_made_chain_is_anchored_on_the_surveyed_brick_through_gnss_wander() -> None:
    truth = _truth([(0.012, -0.004), (0.020, 0.003), (0.018, 0.010)])
    gnss = [(0.08, -0.05, 0.06), (-0.07, 0.02, -0.04), (0.03, 0.09, 0.05)]
    anchor = WallAnchor(TOWER.tasks)
    for b, err in zip((1, 2, 3), gnss, strict=True):
        pose = anchor.take(b, _look(b, b - 1, truth, err, (0.0, 0.0, 0.0)))
        assert pose.anchored_to == 0
        assert pose.world_position_m == pytest.approx(_look(b, None, truth, err, (0, 0, 0)).position_m)
        # the chain is exact here and the world look 5-9 cm off: the chain takes (almost) all the weight
        assert math.dist(pose.position_m, truth[b]) < 1e-4
        assert pose.deviation_m == pytest.approx(math.dist(pose.position_m, _task(b).position_m))
        assert anchor.world(b, pose) == _look(b, b - 1, truth, err, (0.0, 0.0, 0.0))
    sigma = anchor.world_sigma_m()
    assert sigma is not None and 0.03 < sigma < 0.1  # (measured from the looks against the chain)


def test_no_chain_to_a_surveyed_brick_keeps_the_world_look() -> None:
    truth = _truth([(0.01, 0.0), (0.01, 0.0), (0.01, 0.0)])
    anchor = WallAnchor(TOWER.tasks)
    alone = _look(1, None, truth, (0.05, 0.0, 0.0), (0, 0, 0))
    assert anchor.take(1, alone) == alone  # seen alone: nothing to chain
    on_unanchored = _look(2, 1, truth, (0.05, 0.0, 0.0), (0, 0, 0))
    pose = anchor.take(2, on_unanchored)  # its neighbour is not anchored: the pair on its looks
    assert pose.anchored_to is None and pose.world_position_m == on_unanchored.position_m
    assert pose.position_m == pytest.approx(on_unanchored.position_m, abs=1e-12)
    far = _look(1, 0, truth, (0.05, 0.0, 0.0), (MAX_WALL_DEVIATION_M + 0.01, 0.0, 0.0))
    assert anchor.take(1, far).anchored_to is None  # a chain off the wall is not trusted
    up = _look(1, 0, truth, (0.05, 0.0, 0.0), (0.0, 0.0, 0.08))
    assert anchor.take(1, up).anchored_to is None  # nor one off its course


def test_a_look_off_its_course_height_keeps_it_and_one_on_its_course_takes_the_course() -> None:
    truth = _truth([(0.01, 0.0)])
    anchor = WallAnchor(TOWER.tasks)
    low = _look(1, None, truth, (0.0, 0.0, -0.004), (0, 0, 0))
    assert anchor.take(1, low).position_m == pytest.approx(truth[1], abs=1e-12)  # GNSS's height: the course's
    off = _look(1, None, truth, (0.0, 0.0, -0.06), (0, 0, 0))
    assert anchor.take(1, off) == off  # over half a brick off its course: as seen (the course check's case)


@seed(30)
@settings(max_examples=40, deadline=None, print_blob=True)
@given(
    gnss=st.lists(st.tuples(st.floats(-0.15, 0.15), st.floats(-0.15, 0.15)), min_size=7, max_size=7),
    rel=st.lists(st.tuples(st.floats(-0.001, 0.001), st.floats(-0.001, 0.001)), min_size=7, max_size=7),
)
def test_a_wall_on_no_survey_is_within_a_few_mm_in_its_own_frame_whatever_the_wander(gnss, rel) -> None:
    """A pyramid of 7 bricks built on the ground (no survey), each look's world position off by up to 15 cm
    (GNSS) and its offsets to its neighbours off by up to 1 mm: in the wall's frame (the mean error taken out)
    every brick is within 5 mm; in the world the wall sits on its looks' mean (within 15 cm)."""
    wall = plan(pyramid(3, yaw_rad=0.4))
    tasks = {t.brick: t for t in wall.tasks if isinstance(t, BrickTask)}
    rng = np.random.default_rng(7)
    truth = {
        b: np.asarray(t.position_m) + np.array([*rng.normal(scale=0.01, size=2), 0.0])
        for b, t in tasks.items()
    }
    anchor = WallAnchor(wall.tasks)
    order = sorted(tasks, key=lambda b: (tasks[b].position_m[2], b))
    for k, b in enumerate(order):
        t = tasks[b]
        world = truth[b] + (*gnss[k], 0.003)
        below = [
            o for o in order[:k] if math.dist(tasks[o].position_m[:2], t.position_m[:2]) <= t.size_m[0] * 1.01
        ]
        offsets = tuple(
            (o, (*(truth[b][:2] - truth[o][:2] + rel[k]), t.position_m[2] - tasks[o].position_m[2]), 10)
            for o in below
        )
        pose = AsBuiltPose(tuple(float(v) for v in world), 0.0, 0.0, 0.9)  # type: ignore[arg-type]
        if offsets:
            pose = replace(
                pose, relative_to=offsets[0][0], relative_offset_m=offsets[0][1], relative_deviation_m=0.0
            )
            pose = replace(pose, relative_offsets=offsets)  # type: ignore[arg-type]
        anchor.take(b, pose)
    poses = anchor.poses()
    errs = {b: np.subtract(p.position_m, truth[b]) for b, p in poses.items()}
    common = np.mean(list(errs.values()), axis=0)
    assert all(float(np.linalg.norm(e - common)) < 0.005 for e in errs.values()), errs
    assert all(abs(e[2]) < 1e-9 for e in errs.values())  # (on its course: the design's height)
    assert float(np.linalg.norm(common)) <= 0.15 * math.sqrt(2)


def test_an_anchored_pose_survives_the_wire_and_the_journal() -> None:
    truth = _truth([(0.01, 0.0)])
    pose = WallAnchor(TOWER.tasks).take(1, _look(1, 0, truth, (0.06, 0.0, 0.0), (0, 0, 0)))
    assert pose.anchored_to == 0 and pose.world_position_m is not None
    assert AsBuiltPose.from_dict(pose.to_dict()) == pose
    assert {"anchored_to", "world_position_m"} <= set(pose.to_dict(4))
    with pytest.raises(ValueError, match="anchor fields"):
        AsBuiltPose.from_dict({**pose.to_dict(), "anchored_to": "B0"})
    with pytest.raises(ValueError, match="world_position_m"):
        AsBuiltPose.from_dict({k: v for k, v in pose.to_dict().items() if k != "world_position_m"})


_ERR = st.floats(-0.002, 0.002)


@seed(30)
@settings(max_examples=60, deadline=None, print_blob=True)
@given(
    shifts=st.lists(st.tuples(st.floats(-0.03, 0.03), st.floats(-0.03, 0.03)), min_size=3, max_size=3),
    rel=st.lists(st.tuples(_ERR, _ERR, _ERR), min_size=3, max_size=3),
    world_sigma_m=st.sampled_from([0.0005, 0.003, 0.06]),
    gnss=st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)), min_size=3, max_size=3),
)
def test_the_anchored_pose_lies_between_chain_and_look_and_is_no_worse_than_both(
    shifts: list[tuple[float, float]],
    rel: list[Vec3],
    world_sigma_m: float,
    gnss: list[Vec3],
) -> None:
    """Over random towers: every anchored position is finite, on its course height, horizontally between the world
    look and the chain, and within the chain's worst case of the truth when the look is GNSS's."""
    truth = _truth(shifts)
    anchor = WallAnchor(TOWER.tasks)
    chained: Vec3 = truth[0]
    for b in (1, 2, 3):
        err = tuple(world_sigma_m * 2.0 * g for g in gnss[b - 1])
        look = _look(b, b - 1, truth, err, rel[b - 1])  # type: ignore[arg-type]
        pose = anchor.take(b, look)
        assert pose.anchored_to == 0 and all(map(math.isfinite, pose.position_m))
        assert pose.position_m[2] == _task(b).position_m[2]
        # the chain from the anchored neighbour: what the pose is weighted between with the look
        prev = anchor.anchors[b - 1].centre_m if b > 1 else chained
        chain = np.add(prev[:2], np.subtract(look.relative_offset_m[:2], 0.0))  # type: ignore[index]
        w = np.asarray(look.position_m[:2])
        p = np.asarray(pose.position_m[:2])
        span = float(np.linalg.norm(w - chain))
        assert np.linalg.norm(p - chain) <= span + 1e-9 and np.linalg.norm(p - w) <= span + 1e-9
        if world_sigma_m >= 0.03:  # GNSS: the chain's error only, 2 mm per axis per link at most
            assert math.dist(pose.position_m, truth[b]) <= b * 0.002 * math.sqrt(2) + 1e-3
    sigma = anchor.world_sigma_m()
    assert sigma is not None and sigma >= MIN_WORLD_SIGMA_M and RELATIVE_SIGMA_M > 0


@pytest.fixture(scope="module")
def px4_on_a_surveyed_course() -> SimulatedMission:
    """A pyramid of three courses flown on the px4 model (GNSS), built on a surveyed course of four."""
    bp = pyramid(4, placed_courses=1, brick_uavs=1, adhesion_uavs=1, clearance_m=1.0)
    events = EventList()
    mission = SimulatedMission.from_blueprint(bp, seed=3, vehicle="px4", events_sink=events)
    mission.report = mission.run()  # type: ignore[attr-defined]
    mission.events = events  # type: ignore[attr-defined]
    return mission


def test_px4s_reported_as_built_positions_are_within_a_few_mm_of_the_truth(px4_on_a_surveyed_course) -> None:
    mission = px4_on_a_surveyed_course
    report = mission.report
    assert report.completed
    errs, world_errs = [], []
    for tid, pose in report.as_built.items():
        truth = mission.world.bricks[int(tid[1:])].position_m
        assert pose.anchored_to is not None and pose.world_position_m is not None  # every brick chains down
        errs.append(math.dist(pose.position_m, truth))
        world_errs.append(math.dist(pose.world_position_m, truth))
    assert len(errs) == 6
    assert max(errs) < 0.006  # (the world-frame looks: GNSS, several cm)
    assert min(world_errs) > 0.01
    # shown as reported: the completed events (the log, the live page) carry the anchored pose known at the
    # completion, the report the wall re-solved with every look (the last brick's: the same; earlier bricks' moved
    # by the later looks)
    done = {
        e.task_id: e for e in mission.events.events if e.kind == "completed" and e.task_id in report.as_built
    }
    assert set(done) == set(report.as_built)
    last = max(done, key=lambda tid: done[tid].time_s)
    assert done[last].fields["as_built"] == report.as_built[last].to_dict(4)
    for tid, e in done.items():
        then = e.fields["as_built"]
        assert (
            then["anchored_to"] is not None
        )  # (its root may change: a later look may tie it nearer another)
        assert math.dist(then["position_m"], report.as_built[tid].position_m) < 0.003
    # the journal keeps the pose known at the completion, with every offset its UAV sent (what a re-solve needs)
    journaled = {a.task_id: a.as_built for a in mission.control.history if a.task_id in report.as_built}
    assert all(p is not None and p.relative_offsets for p in journaled.values())
    again = WallAnchor(mission.control.plan.tasks)
    for a in sorted(mission.control.history, key=lambda a: a.end_s or 0.0):
        if a.status == "done" and a.as_built is not None:
            again.take(int(a.task_id[1:]), a.as_built)
    assert {f"B{b}": p for b, p in again.poses().items()} == report.as_built
    # a brick beyond the tolerance (2 cm) is an event, on the pose known at its completion; one within is none
    # (how many are beyond is the placement's figure, not the estimate's: seed 3 had none before the hand-over
    # change of issue 27 moved the flights, B9 3.3 cm since; bench_as_built.py --vehicles px4 measures it)
    beyond = {e.task_id: e.fields["deviation_m"] for e in mission.events.events if e.kind == "placement"}
    for tid, e in done.items():
        deviation_m = e.fields["as_built"]["deviation_m"]
        assert (tid in beyond) == (deviation_m > 0.02), (tid, deviation_m, beyond)
        assert tid not in beyond or beyond[tid] == pytest.approx(deviation_m, abs=1e-4)
    # the flights' inputs are the UAVs' world looks, as before
    assert mission.control.placement.poses
    for b, raw in mission.control.placement.poses.items():
        assert raw.anchored_to is None and raw.position_m == report.as_built[f"B{b}"].world_position_m


def test_a_resumed_px4_mission_keeps_the_anchored_poses_and_anchors_on_them(tmp_path) -> None:
    """The journal keeps the anchored poses; the mission resumed from it anchors its later bricks on them."""
    bp = pyramid(4, placed_courses=1, brick_uavs=1, adhesion_uavs=1, clearance_m=1.0)
    journal = tmp_path / "j.jsonl"
    first = simulate(bp, seed=3, vehicle="px4", journal_path=journal, max_time_s=240.0)
    assert first.as_built and not first.completed
    resumed = SimulatedMission.from_blueprint(bp, seed=3, vehicle="px4", journal_path=journal, resume=True)
    again = resumed.run()
    assert again.completed
    for tid, pose in first.as_built.items():  # (the same looks, the wall re-solved with the later ones)
        assert again.as_built[tid].world_position_m == pose.world_position_m
        assert again.as_built[tid].anchored_to is not None
    # the journaled looks re-solved with the later ones: every pose within a few mm of the truth, those known before
    # the stop too (a brick's pose at the stop may rest on fewer looks: seed 3's B6 was 14 mm off then, 4 mm after)
    for tid, pose in again.as_built.items():
        assert math.dist(pose.position_m, resumed.world.bricks[int(tid[1:])].position_m) < 0.006, tid
    assert len(again.as_built) > len(first.as_built)
    assert all(p.anchored_to is not None for p in again.as_built.values())


@pytest.fixture(scope="module", params=["arducopter", "px4"])
def on_no_survey(request: pytest.FixtureRequest) -> SimulatedMission:
    """A pyramid of three courses turned 30 degrees built on the ground (no surveyed brick)."""
    bp = pyramid(3, yaw_rad=math.radians(30.0), brick_uavs=1, adhesion_uavs=1, clearance_m=1.0)
    mission = SimulatedMission.from_blueprint(bp, seed=1, vehicle=request.param)
    mission.report = mission.run()  # type: ignore[attr-defined]
    mission.vehicle = request.param  # type: ignore[attr-defined]
    return mission


def test_a_wall_on_no_survey_is_reported_within_5_mm_in_its_frame_and_on_arducopter_in_the_world(
    on_no_survey,
) -> None:
    """Issue 30's 5 mm: every brick's reported pose (tied to the wall by its sightings: none anchored, each with its
    look kept) within 5 mm of the simulator's truth in the wall's frame (the mission's mean error taken out), and on
    the ``arducopter`` model (GPS-like noise of 3 mm) in the world frame too: its looks alone are up to 8-10 mm off."""
    mission = on_no_survey
    report = mission.report
    assert report.completed
    errs = {}
    for tid, pose in report.as_built.items():
        truth = mission.world.bricks[int(tid[1:])].position_m
        assert pose.anchored_to is None and pose.world_position_m is not None
        assert pose.position_m[2] == mission.control.plan.task(tid).position_m[2]  # on its course
        errs[tid] = np.subtract(pose.position_m, truth)
    assert len(errs) == 6
    common = np.mean(list(errs.values()), axis=0)
    in_wall = {tid: float(np.linalg.norm(e - common)) for tid, e in errs.items()}
    assert max(in_wall.values()) < 0.005, in_wall
    if mission.vehicle == "arducopter":
        assert max(float(np.linalg.norm(e)) for e in errs.values()) < 0.005, errs


def test_a_brick_taken_again_drops_its_old_links_from_the_kept_components(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The anchor's union-find (``wall_solve.Groups``) only joins: a brick taken again (its old sighting replaced,
    or gone when the new look ties it to nothing) has the components found again from the sightings kept: the
    same poses as an anchor whose walls find their components from the sightings on every solve."""
    truth = _truth([(0.012, -0.004), (0.020, 0.003), (0.018, 0.010)])
    err = (0.05, -0.03, 0.0)
    looks = [(b, _look(b, b - 1, truth, err, (0.0, 0.0, 0.0))) for b in (1, 2, 3)]
    looks.append((2, _look(2, None, truth, err, (0.0, 0.0, 0.0))))  # (B2 again, tied to nothing)
    looks.append((2, _look(2, 1, truth, err, (0.001, 0.0, 0.0))))  # (and again, tied to B1)
    kept = WallAnchor(TOWER.tasks)
    got = [(kept.take(b, look), dict(kept.anchors)) for b, look in looks]
    # (B3's only way to the survey runs through B2's sighting: off it, B3 is on B2's own wall)
    assert [a[3].root for _, a in got[2:]] == [0, 2, 0]
    monkeypatch.setattr(wall_anchor, "Wall", lambda fixed, sightings, groups: Wall(fixed, sightings))
    plain = WallAnchor(TOWER.tasks)
    assert [(plain.take(b, look), dict(plain.anchors)) for b, look in looks] == got


@seed(37)
@settings(max_examples=30, deadline=None, print_blob=True)
@given(
    gnss=st.lists(st.tuples(st.floats(-0.15, 0.15), st.floats(-0.15, 0.15)), min_size=9, max_size=9),
    again=st.lists(st.integers(0, 6), max_size=2),
    survey=st.booleans(),
)
def test_an_anchor_read_for_its_brick_alone_gives_what_the_whole_dictionary_gives(
    gnss, again, survey
) -> None:
    """A take reads its own brick's anchor of the solve alone (``WallAnchor._anchor_of``: its row, its component's
    shift), the whole dictionary only when asked: the same answers and poses as an anchor whose dictionary is
    built after every take, on a wall with a survey and one without (each component's shift), bricks taken again."""
    wall = plan(pyramid(3, yaw_rad=0.4, placed_courses=1 if survey else 0))
    tasks = {t.brick: t for t in wall.tasks if isinstance(t, BrickTask)}
    order = sorted(tasks, key=lambda b: (tasks[b].position_m[2], b))
    order = [b for b in order if not tasks[b].done]
    lazy, whole = WallAnchor(wall.tasks), WallAnchor(wall.tasks)
    built = []
    for k, b in enumerate(order + [order[i % len(order)] for i in again]):
        t = tasks[b]
        world = (t.position_m[0] + gnss[k][0], t.position_m[1] + gnss[k][1], t.position_m[2])
        below = [
            o
            for o in tasks
            if tasks[o].position_m[2] < t.position_m[2]
            and math.dist(tasks[o].position_m[:2], t.position_m[:2]) <= t.size_m[0] * 1.01
        ]
        offsets = tuple((o, tuple(np.subtract(t.position_m, tasks[o].position_m)), 10) for o in below)
        pose = AsBuiltPose(world, 0.0, 0.0, 0.9)
        if offsets:
            pose = replace(pose, relative_to=offsets[0][0], relative_offset_m=offsets[0][1])
            pose = replace(pose, relative_deviation_m=0.0, relative_offsets=offsets)  # type: ignore[arg-type]
        assert lazy.take(b, pose) == whole.take(b, pose)
        built.append(dict(whole.anchors))  # (the whole dictionary, built after every take)
    assert lazy.poses() == whole.poses()
    assert lazy.anchors == built[-1]
    surveyed = {b for b, t in tasks.items() if t.done}
    assert built[-1] and all(
        (a.root in surveyed) == survey for a in built[-1].values()
    )  # (no survey: shifts)
