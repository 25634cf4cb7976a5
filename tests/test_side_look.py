"""The side look (issue 30): a drop-off whose supports the carried brick hides is approached from where the camera
sees one, so that on GNSS a tower's brick keeps to the brick it stands on."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from masonry.airframe import camera_mount
from masonry.blueprint_gen import running_bond, towers
from masonry.fsm.config import UavConfig
from masonry.fsm.side_look import LookScene, SideLook, look_offset_m, marker_in_view
from masonry.fsm.tuning import uav_settings
from masonry.geometry import rot_z
from masonry.mission.simulate import SimulatedMission
from masonry.perception.types import DEFAULT_INTRINSICS
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

YAW = math.radians(30.0)
SIZE = (0.30, 0.15, 0.10)
DROP = (1.0, 2.0, 0.3)  # the drop-off's top-face centre: a second-course brick


def _scene(supports: tuple[tuple[float, float, float], ...], others: tuple = ()) -> LookScene:
    return LookScene(
        drop_top_m=DROP,
        body_yaw_rad=YAW,
        brick_yaw_rad=YAW,
        size_m=SIZE,
        supports=supports,
        others=others,
        marker_size_m=0.05,
        marker_spacing_m=0.175,
        intrinsics=DEFAULT_INTRINSICS,
        T_body_cam=camera_mount(),
        effector_body_m=(0.0, 0.0, -0.45),
        align_height_m=0.55,
    )


def _along(d_m: float, across_m: float = 0.0, z_m: float = 0.2) -> tuple[float, float, float]:
    """A point ``d_m`` along the brick's length and ``across_m`` across it from the drop-off, at height ``z_m``."""
    c, s = math.cos(YAW), math.sin(YAW)
    return (DROP[0] + c * d_m - s * across_m, DROP[1] + s * d_m + c * across_m, z_m)


def _support_markers_seen(displacement_m: np.ndarray, height_m: float) -> int:
    """The support's (right under the drop-off) markers the camera sees, whole, past the carried brick."""
    effector = np.array(DROP) + np.array([displacement_m[0], displacement_m[1], height_m])
    R_wb = rot_z(YAW)
    T = camera_mount()
    camera = effector - R_wb @ np.array([0.0, 0.0, -0.45]) + R_wb @ T[:3, 3]
    seen = 0
    for sign in (1.0, -1.0):
        mx, my, mz = _along(sign * 0.0875)
        corners = np.array(
            [
                _rot_corner(mx, my, mz, dx * 0.025, dy * 0.025)
                for dx, dy in ((-1, 1), (1, 1), (1, -1), (-1, -1))
            ]
        )
        seen += marker_in_view(
            corners, camera, R_wb @ T[:3, :3], DEFAULT_INTRINSICS, effector, YAW, (0.15, 0.075)
        )
    return seen


def _rot_corner(x: float, y: float, z: float, dx: float, dy: float) -> tuple[float, float, float]:
    c, s = math.cos(YAW), math.sin(YAW)
    return (x + c * dx - s * dy, y + s * dx + c * dy, z)


def test_a_towers_support_is_hidden_from_above_and_seen_from_the_displaced_descent() -> None:
    found = look_offset_m(_scene((_along(0.0),)))
    assert found is not None
    hover, pre = found
    assert hover[2] == pre[2] == 0.0
    assert 0.08 <= np.linalg.norm(pre) <= np.linalg.norm(hover) <= 0.5
    # from right above the drop-off the carried brick hides both markers, at the release and high up
    for height in (0.0, 0.03, 0.3, 0.55):
        assert _support_markers_seen(np.zeros(3), height) == 0
    # from the pre-release point and the hover, and on the straight descent between them, one is in view
    for f in np.linspace(0.0, 1.0, 5):
        assert _support_markers_seen(pre + f * (hover - pre), 0.03 + f * (0.55 - 0.03)) >= 1


def test_no_support_no_side_look_and_a_marker_at_the_edge_of_the_view_is_not_counted_on() -> None:
    assert look_offset_m(_scene(())) is None
    # a running bond's second course: half on a brick whose far marker sticks out on the camera's side, in view at
    # the release only if the support is where the position says: the side look keeps it in view instead
    found = look_offset_m(_scene((_along(0.15),)))
    assert found is not None
    assert np.linalg.norm(found[1]) <= np.linalg.norm(found[0])


def test_no_side_look_where_bricks_of_its_course_stand_all_round() -> None:
    ring = tuple(
        _along(0.45 * math.cos(a), 0.45 * math.sin(a), 0.3) for a in np.linspace(0, 2 * math.pi, 12)[:-1]
    )
    assert look_offset_m(_scene((_along(0.0),), ring)) is None
    # the bricks that stand on the new one are not built yet: no obstacle
    above = (_along(0.15, 0.0, 0.4), _along(-0.15, 0.0, 0.4))
    assert look_offset_m(_scene((_along(0.0),), above)) is not None


@pytest.mark.slow
def test_on_gnss_a_towers_bricks_keep_to_the_brick_they_stand_on() -> None:
    """The px4 model (GNSS wander +-15 cm), issue 30's towers turned 30 degrees, seed 2: no brick above the first
    course past 2.5 cm of its support's offset (before the side look 14.7-98.9 mm, the camera never saw the
    support of two of them; docs/performance/as-built.md has the benchmark).

    The bound is the towers' worst brick over seeds 0-9 (``bench_as_built.py --vehicles px4 --seeds 10 --walls
    towers``: 23.8 mm before issue 29's release on the windowed height, 20.7 mm with it and the 3 s window): a
    brick's offset from its support is the wall estimate's error, 0.3-0.4 s old, plus the release's, random on
    GNSS; seed 2's worst moved from 10.9 to 20.7 mm with the release's timing. Since issue 30's five looks the
    worst of seeds 0-9 is 30.4 mm; issue 27's held flight home (a timing change: the wander's draw at each
    placement moves) put seed 2's at 26.7 mm, and issue 30's follow cap measured from the bricks in view (a brick
    keeps to its one support) brought it to 19.9 mm with both: the bound stays 2.5 cm. On the px4 model refitted to
    the real PX4 (issue 29) it read 53.5 mm: the last leg arrived 5-8 cm short and overshot past the sighting's
    freshness, and a brick was let go on the offset of a look 2.7 s old; with the px4 preset's lag feed-forward
    (``velocity_lag_s`` 0.5) and the carried brick's offset seen on the magnet (masonry.fsm.carried_look) it holds
    again (docs/performance/as-built.md, the px4 towers' section)."""
    bp = towers(3, 3, spacing_m=1.0, yaw_rad=YAW, clearance_m=1.0, brick_uavs=1, adhesion_uavs=1)
    mission = SimulatedMission.from_blueprint(bp, seed=2, vehicle="px4")
    assert mission.run().completed
    world = mission.world
    errors = []
    for b in bp.bricks:
        if b.position_m[2] < b.size_m[2]:
            continue  # the first course: nothing to keep to (GNSS puts it)
        below = next(
            o
            for o in bp.bricks
            if math.dist(o.position_m[:2], b.position_m[:2]) < 1e-6
            and o.id != b.id
            and abs(b.position_m[2] - o.position_m[2] - b.size_m[2]) < 1e-6
        )
        off = np.subtract(world.bricks[b.id].position_m, b.position_m)
        off_below = np.subtract(world.bricks[below.id].position_m, below.position_m)
        errors.append(float(np.linalg.norm((off - off_below)[:2])))
    assert len(errors) == 6
    assert max(errors) < 0.025, errors


@pytest.mark.slow
def test_a_stale_offset_at_the_end_of_the_displaced_descent_is_looked_at_again_before_the_last_leg() -> None:
    """The px4 model, issue 30's running bond turned 30 degrees, seed 12: B8's supports (B3, B4) were out of view
    for the 7 s of its displaced descent while the vertical wander moved 11 cm; the last leg, flown on that stale
    offset, took the carried brick sideways under its supports' tops into the course below. B8 rested ~10 cm
    low, 100.6 mm off its neighbours; mission control failed the task (misplaced, waits for a person) and the
    mission did not complete. With the look back up before the leg (``ReleaseGate.before_leg``) every brick is on
    its course and the mission completes."""
    bp = running_bond(3, 5, yaw_rad=YAW, clearance_m=1.0, brick_uavs=1, adhesion_uavs=1, name="rotated-bond")
    mission = SimulatedMission.from_blueprint(bp, seed=12, vehicle="px4")
    report = mission.run()
    assert report.completed, report.stuck
    assert all(a.status == "done" for a in report.attempts if a.kind == "brick"), [
        a.reason for a in report.attempts if a.status != "done"
    ]
    for b in bp.bricks:
        truth = mission.world.bricks[b.id]
        assert truth.state == "placed"
        assert abs(truth.position_m[2] - b.position_m[2]) < 0.02, (b.id, truth.position_m)


@pytest.mark.slow
def test_in_4_m_s_wind_the_px4_rotated_bond_completes_with_every_brick_on_its_course() -> None:
    """Issue 30's done-when in wind: the px4 model, the running bond turned 30 degrees, 4 m/s with light
    turbulence, seed 7. Before the look back up before the side look's last leg, B7 and B8 went in under their
    supports' tops (9.7 and 9.8 cm below their course, found by the course check: misplaced, waits for a person)
    and the mission did not complete; the same tree with ``ReleaseGate.before_leg`` switched off still fails so.
    Now each of them looks again before its leg, and every brick rests on its course."""
    bp = running_bond(3, 5, yaw_rad=YAW, clearance_m=1.0, brick_uavs=1, adhesion_uavs=1, name="rotated-bond")
    wind = Faults(wind=WindConfig(speed_mps=4.0, turbulence="light"))
    mission = SimulatedMission.from_blueprint(bp, seed=7, vehicle="px4", faults=wind)
    report = mission.run()
    assert report.completed, report.stuck
    for b in bp.bricks:
        truth = mission.world.bricks[b.id]
        assert truth.state == "placed"
        assert abs(truth.position_m[2] - b.position_m[2]) < 0.02, (b.id, truth.position_m)


def test_it_is_on_with_the_wall_alignment_and_uav_yaml_may_switch_it_off() -> None:
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).side_look is True  # (it acts only with align_on_wall)
    assert uav_settings("px4", {"side_look": False})["side_look"] is False
    assert "side_look" not in uav_settings("arducopter")


def _pass_rig(lag_s: float = 0.5, in_wind: bool = False):
    """A stand-in brick UAV for :class:`SideLook`'s pass bookkeeping: the drop-off at the origin, the pre-release
    point 15 cm along -x (the leg runs along +x), the effector where ``rig.at`` says."""
    rig = SimpleNamespace(at=np.zeros(3))
    uav = SimpleNamespace(
        config=SimpleNamespace(last_leg_lag_s=lag_s),
        attempt=SimpleNamespace(in_wind=in_wind, place_effector_target_m=np.zeros(3)),
        effector=SimpleNamespace(position=lambda tel: rig.at),
    )
    side = SideLook()
    side.offset_m, side.final = np.array([-0.15, 0.0, 0.0]), True
    return side, uav, rig


def _fly_pass(side, uav, rig, xs_m: list[float]) -> float | None:
    """One pass of the last leg: its lag, then the effector at ``xs_m`` along the leg, tick by tick."""
    lag = side.leg_lag_s(uav)
    for x in xs_m:
        rig.at = np.array([x, 0.01, 0.0])
        side.track(uav, None, looking=False)
    return lag


def test_the_last_legs_lag_comes_down_after_passes_past_the_drop_off_and_back_after_short_ones() -> None:
    """Issue 29 on the real PX4: the last leg's passes on the px4 preset's 0.5 s lag ran 4-12 cm past the drop-off;
    each pass more than 3 cm past takes 0.1 s off the next one's lag (down to none), one gone stale more than 3 cm
    short puts 0.1 s back (never over the configured lag), one within 3 cm leaves it."""
    side, uav, rig = _pass_rig()
    overshooting = [-0.15, -0.08, 0.0, 0.06, 0.08]
    lags = [_fly_pass(side, uav, rig, overshooting) for _ in range(7)]
    assert lags == pytest.approx([0.5, 0.4, 0.3, 0.2, 0.1, 0.0, 0.0])
    assert _fly_pass(side, uav, rig, [-0.15, -0.10, -0.06]) == pytest.approx(0.0)  # the one before overshot
    assert _fly_pass(side, uav, rig, [-0.15, -0.01, 0.02]) == pytest.approx(0.1)  # the one before was short
    assert _fly_pass(side, uav, rig, [-0.15, -0.01, 0.02]) == pytest.approx(0.1)  # within 3 cm: kept
    for _ in range(8):  # short passes: back up to the configured lag, not past it
        last = _fly_pass(side, uav, rig, [-0.15, -0.10])
    assert last == pytest.approx(0.5)
    # a look back up (ticks while looking) is no part of the pass
    side.leg_lag_s(uav)
    rig.at = np.array([0.2, 0.0, 0.0])
    side.track(uav, None, looking=True)
    assert _fly_pass(side, uav, rig, []) == pytest.approx(0.5)


def test_a_pass_passed_over_inside_r_pl_in_time_moves_no_lag() -> None:
    """With ``release_leg_m`` (ReleaseGate.wide) a pass that was inside r_pl on a fresh sighting but wider than the
    rule goes on past the drop-off: it arrived in time, so what it ran past after says nothing of the lag (on the
    px4 model the learnt lag ran down on such passes, and the towers in calm air went 3/60 over 2 cm, one brick
    84.8 mm: docs/performance/as-built.md, branch px4rel36); the pass after it learns again."""
    side, uav, rig = _pass_rig()
    assert _fly_pass(side, uav, rig, [-0.15, -0.01, 0.06]) == pytest.approx(0.5)
    side.on_time = True  # (ReleaseGate.wide passed a tick of it over)
    assert _fly_pass(side, uav, rig, [-0.15, 0.0, 0.06]) == pytest.approx(0.5)
    assert _fly_pass(side, uav, rig, []) == pytest.approx(0.4)  # not passed over: 6 cm past, a step down
    side.on_time = True
    side.offset_m, side.final = None, False
    side.plan(SimpleNamespace(on_wall=False, config=SimpleNamespace(side_look=False, wall=())))
    assert not side.on_time  # a new placement starts no pass


def test_a_new_placement_starts_no_pass_and_in_a_wind_the_last_leg_flies_the_uavs_own_lag() -> None:
    """The lag learnt carries over to the next placement (the same vehicle), the pass in hand does not; in a wind
    the last leg has no lag of its own (masonry.fsm.side_look.last_leg_lag_s) and nothing is learnt."""
    side, uav, rig = _pass_rig()
    _fly_pass(side, uav, rig, [0.0, 0.08])
    side.offset_m, side._past_m = None, None  # plan(): a new alignment
    side.offset_m, side.final = np.array([-0.15, 0.0, 0.0]), True
    assert _fly_pass(side, uav, rig, [0.0, 0.08]) == pytest.approx(0.5)
    assert _fly_pass(side, uav, rig, []) == pytest.approx(0.4)
    windy, wuav, wrig = _pass_rig(in_wind=True)
    assert _fly_pass(windy, wuav, wrig, [0.0, 0.08]) is None
    assert _fly_pass(windy, wuav, wrig, []) is None
