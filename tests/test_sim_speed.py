"""The mission simulation's fast paths give what the general paths give (docs/performance/mission.md).

Covered: the cached JSON encoder (same bytes as ``json.dumps``), the heartbeat decode fast path and the decode
cache (same values, same errors, the fleet check never skipped), the in-process bus, the vehicle's inlined
clamps and telemetry (same numbers as the formulas they replace), the world's contact and grip guards (a landed
vehicle still takes off, a tool still rests on a brick), and the camera's per-pose marker arrays.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import Brick
from masonry.errors import ProtocolError
from masonry.geometry import wrap_angle_rad
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import (
    MISSION_CONTROL,
    Assign,
    Heartbeat,
    MissionEnd,
    Progress,
    Result,
    decode,
    encode,
)
from masonry.planner.tasks import BrickTask
from masonry.ports import TaskResult
from masonry.sim.bricks import SimBrick
from masonry.sim.camera import marker_layout
from masonry.sim.vehicle import GRAVITY_MPS2, SimVehicle, VehicleConfig

FLEET = {"brick-1", "glue-1"}
BRICK = BrickTask("B3", 3, False, (1.0, 2.0, 0.15), 0.5, (4.0, 0.0, 0.05), (0.3, 0.15, 0.1))

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
names = st.sampled_from(["brick-1", "glue-1", MISSION_CONTROL])


def _reference_encode(msg: object) -> bytes:
    body = json.loads(encode(msg))  # type: ignore[arg-type]
    return json.dumps(body, separators=(",", ":"), allow_nan=False).encode()


@given(
    names,
    finite,
    st.text(max_size=8),
    st.one_of(st.none(), st.text(min_size=1, max_size=5)),
    st.one_of(st.none(), st.tuples(finite, finite, finite)),
)
def test_heartbeat_round_trip_and_bytes(sender, t, state, task_id, position):
    msg = Heartbeat(sender, t, state=state, task_id=task_id, position_m=position)
    raw = encode(msg)
    assert raw == _reference_encode(msg)
    for fleet in (None, FLEET):
        out = decode(raw, fleet)
        assert out == msg and type(out) is Heartbeat
        assert vars(out) == vars(Heartbeat(sender, t, state=state, task_id=task_id, position_m=position))


@pytest.mark.parametrize(
    "msg",
    [
        Assign(MISSION_CONTROL, "brick-1", BRICK, 2, 10.0),
        Progress("glue-1", "A0", "spray", 12.25, (0.8, 2.0, 0.45)),
        Result("brick-1", TaskResult("B3", "done", 71.4, placement_error_m=0.012), 80.0, (1.0, 2.0, 1.2)),
        MissionEnd(MISSION_CONTROL, 400.0, True),
    ],
    ids=lambda m: type(m).__name__,
)
def test_encode_gives_the_json_dumps_bytes(msg):
    assert encode(msg) == _reference_encode(msg)
    assert decode(encode(msg)) == msg


def test_encode_still_refuses_non_finite_numbers():
    with pytest.raises(ValueError):
        encode(Heartbeat("brick-1", math.inf))


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("sender", "", "'sender' must be a non-empty string"),
        ("sender", 3, "'sender' must be a non-empty string"),
        ("time_s", True, "'time_s' must be a finite number"),
        ("time_s", None, "'time_s' must be a finite number"),
        ("task_id", "", "'task_id' must be a non-empty string"),
        ("task_id", 7, "'task_id' must be a non-empty string"),
        ("position_m", [1.0, 2.0, True], "'position_m' must be a list of 3"),
        ("position_m", [1.0, 2.0, "x"], "'position_m' must be a list of 3"),
        ("position_m", (1.0, 2.0, 3.0), None),  # a JSON list either way
    ],
)
def test_bad_heartbeat_fields_get_the_general_path_errors(field, value, match):
    d = json.loads(encode(Heartbeat("brick-1", 1.5, state="s", task_id="B3", position_m=(1.0, 2.0, 3.0))))
    d[field] = value
    raw = json.dumps(d)
    if match is None:
        assert decode(raw, FLEET).position_m == (1.0, 2.0, 3.0)
        return
    for fleet in (None, FLEET):
        with pytest.raises(ProtocolError, match=match):
            decode(raw, fleet)


def test_decode_cache_never_skips_the_fleet_check_nor_returns_a_stale_message():
    intruder = encode(Heartbeat("brick-9", 1.0))
    assert decode(intruder).sender == "brick-9"  # no fleet: accepted (and cached)
    with pytest.raises(ProtocolError, match="not a UAV of the blueprint's fleet"):
        decode(intruder, FLEET)
    a, b = encode(Heartbeat(MISSION_CONTROL, 1.0)), encode(Heartbeat(MISSION_CONTROL, 2.0))
    assert decode(a).time_s == 1.0
    assert decode(a).time_s == 1.0
    assert decode(b).time_s == 2.0
    assert decode(a).time_s == 1.0
    with pytest.raises(ProtocolError):
        decode(b"{not json")
    assert decode(b).time_s == 2.0


def test_inproc_bus_delivers_bytes_in_order_and_cuts():
    bus = InprocBus()
    mc, uav = bus.endpoint(MISSION_CONTROL), bus.endpoint("brick-1")
    assert uav.receive() == []
    mc.send("brick-1", b"1")
    mc.send("brick-1", b"2")
    mc.send("nobody", b"3")
    assert uav.receive() == [b"1", b"2"] and uav.receive() == [] and bus.sent == 2
    bus.cut("brick-1")
    mc.send("brick-1", b"4")
    assert uav.receive() == []
    uav.close()
    assert uav.receive() == []


def _reference_step(v: SimVehicle, dt: float) -> tuple[float, ...]:
    """The velocity/yaw update of SimVehicle.step with the builtin clamps (GUIDED, setpoint live, no gusts)."""
    cfg = v.config
    tx, ty, tz, tyaw = v._sp
    sxy = math.sqrt(tx * tx + ty * ty)
    if sxy > cfg.max_speed_xy_mps:
        f = cfg.max_speed_xy_mps / sxy
        tx, ty = tx * f, ty * f
    tz = min(cfg.max_climb_mps, max(-cfg.max_descent_mps, tz))
    k = (1.0 - math.exp(-dt / cfg.velocity_tau_s)) / dt
    ax, ay, az = (tx - v._vx) * k, (ty - v._vy) * k, (tz - v._vz) * k
    axy = math.sqrt(ax * ax + ay * ay)
    if axy > cfg.max_accel_xy_mps2:
        f = cfg.max_accel_xy_mps2 / axy
        ax, ay = ax * f, ay * f
    az = min(cfg.max_accel_z_mps2, max(-cfg.max_accel_z_mps2, az))
    vx, vy, vz = v._vx + ax * dt, v._vy + ay * dt, v._vz + az * dt
    tyaw = min(cfg.max_yaw_rate_radps, max(-cfg.max_yaw_rate_radps, tyaw))
    rate = v._yaw_rate + (tyaw - v._yaw_rate) * (1.0 - math.exp(-dt / cfg.yaw_tau_s))
    yaw = wrap_angle_rad(v._yaw + rate * dt)
    return (v._x + vx * dt, v._y + vy * dt, v._z + vz * dt, vx, vy, vz, rate, yaw, v.battery_fraction)


@settings(max_examples=60)
@given(st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-3, 3)), st.floats(-4, 4))
def test_vehicle_step_matches_the_builtin_clamps(velocity, yaw_rate):
    v = SimVehicle(VehicleConfig(), position_m=(0.0, 0.0, 0.0), rng=np.random.default_rng(0))
    v.arm()
    v.takeoff(3.0)
    for _ in range(200):
        v.step(0.05)
    assert not v.on_ground
    for _ in range(5):
        v.command_velocity(velocity, yaw_rate, v.time_s)
        battery = max(0.0, v.battery_fraction - v.config.battery_drain_per_s * 0.05)
        expected = (*_reference_step(v, 0.05)[:-1], battery)
        v.step(0.05)
        got = (v._x, v._y, v._z, v._vx, v._vy, v._vz, v._yaw_rate, v._yaw, v.battery_fraction)
        assert got == expected


def test_telemetry_is_the_state_plus_seven_noise_draws():
    rng = np.random.default_rng(5)
    v = SimVehicle(VehicleConfig(), position_m=(1.0, 2.0, 0.0), yaw_rad=3.1, rng=rng)
    v.arm()
    v.takeoff(2.0)
    draws = np.random.default_rng(5).standard_normal(4096 * 3).tolist()
    used = 0
    for _ in range(1500):  # past the end of the first 4096-draw block
        v.step(0.05)
        v.command_velocity((0.3, -0.2, 0.0), 0.4, v.time_s)
        tel = v.telemetry()
        assert v.telemetry() is tel  # one sample per instant
        g = draws[used : used + 7]
        used += 7
        cfg = v.config
        roll, pitch, yaw = v.attitude_rad
        assert tel.position_m == (
            v._x + cfg.mocap_noise_m * g[0],
            v._y + cfg.mocap_noise_m * g[1],
            v._z + cfg.mocap_noise_m * g[2],
        )
        assert tel.velocity_mps[2] == v._vz + cfg.velocity_noise_mps * g[5]
        assert tel.attitude_rad == (roll, pitch, wrap_angle_rad(yaw + cfg.yaw_noise_rad * g[6]))
        assert abs(roll) < math.atan2(3.0, GRAVITY_MPS2) and tel.time_s == v.time_s


def test_landed_vehicle_in_a_world_takes_off_and_lands_again(tmp_path):
    from masonry.blueprint_gen import running_bond
    from masonry.sim import World

    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=1)
    world = World(bp, seed=0)
    uavs = world.add_fleet()
    world.run(1.0)
    for u in uavs:
        assert u.vehicle.on_ground and u.vehicle.time_s == pytest.approx(1.0)
    brick = uavs[0]
    brick.fc.arm()
    brick.fc.takeoff(1.5)
    world.run(6.0)
    assert not brick.vehicle.on_ground and brick.position_m[2] > 1.3
    assert uavs[1].vehicle.on_ground and uavs[1].position_m == uavs[1].spec.home_m
    brick.fc.land()
    world.run(10.0)
    assert brick.vehicle.on_ground and not brick.vehicle.armed


def test_marker_arrays_follow_the_brick():
    from masonry.blueprint import MarkerSpec

    markers = MarkerSpec()
    b = SimBrick(0, Brick(0, (0.0, 0.0, 0.05), (0.3, 0.15, 0.1)), (0.0, 0.0, 0.05), 0.0, "pickup")
    ids, centres, corners = marker_layout([b], markers)
    assert ids.tolist() == [0, 1] and centres.shape == (2, 3) and corners.shape == (2, 4, 3)
    first = centres.copy()
    b.position_m = (1.0, 0.5, 0.05)
    _, moved, _ = marker_layout([b], markers)
    assert np.allclose(moved - first, [1.0, 0.5, 0.0])
    b.yaw_rad = math.pi / 2
    _, turned, _ = marker_layout([b], markers)
    half = markers.spacing_m / 2.0
    assert np.allclose(turned[:, :2], [[1.0, 0.5 + half], [1.0, 0.5 - half]])


def _reference_rects_overlap(a, b):
    """The separating axis test as first written (corners from rect_corners, list projections)."""
    from masonry.sim.bricks import rect_corners

    ca, cb = rect_corners(*a), rect_corners(*b)
    for yaw in (a[2], b[2]):
        for ux, uy in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            pa = [ux * px + uy * py for px, py in ca]
            pb = [ux * px + uy * py for px, py in cb]
            if max(pa) <= min(pb) + 1e-9 or max(pb) <= min(pa) + 1e-9:
                return False
    return True


rects = st.tuples(
    st.floats(-1, 1), st.floats(-1, 1), st.floats(-4, 4), st.floats(1e-4, 0.5), st.floats(1e-4, 0.5)
)


@given(rects, rects)
def test_rects_overlap_matches_the_reference(a, b):
    from masonry.sim.bricks import rects_overlap

    assert rects_overlap(a, b) == _reference_rects_overlap(a, b)
    assert rects_overlap(a, a)


@settings(max_examples=40)
@given(
    st.lists(
        st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.integers(0, 3), st.floats(-3.2, 3.2)),
        min_size=1,
        max_size=25,
    ),
    st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-3.2, 3.2)),
    st.floats(0.0, 0.5),
)
def test_support_queries_match_a_plain_scan(placed, probe, below_z):
    from masonry.sim.bricks import BrickField, point_in_rect, rects_overlap

    field = BrickField(0.5)
    size = (0.3, 0.15, 0.1)
    for i, (x, y, course, yaw) in enumerate(placed):
        z = 0.05 + 0.1 * course
        field.add(SimBrick(i, Brick(i, (x, y, z), size), (x, y, z), yaw, "placed"))
    px, py, pyaw = probe
    rect = (px, py, pyaw, 0.15 - 0.025, 0.075 - 0.025)
    expected = 0.0
    for b in field:
        t = b.top_z_m
        if 0.0 < t <= below_z + 0.02 and rects_overlap(rect, b.rect()) and t > expected:
            expected = t
    assert field.support_under(rect, below_z_m=below_z) == expected
    expected_at = 0.0
    for b in field:
        t = b.top_z_m
        if 0.0 < t <= below_z + 0.02 and point_in_rect(px, py, *b.rect()) and t > expected_at:
            expected_at = t
    assert field.support_at(px, py, below_z_m=below_z) == expected_at
    for z in (0.0, 0.1, 0.2, 0.3, below_z):  # (the courses' bottoms, and any height)
        covered = any(abs(b.bottom_z_m - z) <= 1e-3 and point_in_rect(px, py, *b.rect()) for b in field)
        assert field.covered_at(px, py, z) == covered
        wide = any(abs(b.bottom_z_m - z) <= 0.06 and point_in_rect(px, py, *b.rect()) for b in field)
        assert field.covered_at(px, py, z, tol_m=0.06) == wide
    # a brick picked up is out of the index: it supports and covers nothing where it was
    field.pick(0, "brick-1")
    assert all(b.id != 0 for b in field.near(px, py, 2.0))
    x0, y0, _ = field.bricks[0].position_m
    rest = [b for b in field if b.id != 0]
    bottom0 = field.bricks[0].bottom_z_m
    assert field.covered_at(x0, y0, bottom0) == any(
        abs(b.bottom_z_m - bottom0) <= 1e-3 and point_in_rect(x0, y0, *b.rect()) for b in rest
    )


def test_min_separation_is_the_minimum_over_every_physics_step():
    from masonry.blueprint_gen import running_bond
    from masonry.sim import World

    world = World(running_bond(1, 2, brick_uavs=3, adhesion_uavs=2), seed=3)
    uavs = world.add_fleet()
    rng = np.random.default_rng(1)
    for u in uavs:
        u.fc.arm()
        u.fc.takeoff(1.0 + rng.random())
    expected = math.inf
    for k in range(700):
        if k >= 100 and k % 10 == 0:
            for u in uavs:
                u.fc.send_velocity(tuple(rng.uniform(-1.5, 1.5, 3) * (1.0, 1.0, 0.3)), 0.0)
        world.step(0.05)
        flying = [u.vehicle.position_m for u in uavs if u.vehicle.armed and not u.vehicle.on_ground]
        best2 = math.inf
        for i in range(len(flying)):
            for j in range(i + 1, len(flying)):
                (ax, ay, az), (bx, by, bz) = flying[i], flying[j]
                best2 = min(best2, (ax - bx) * (ax - bx) + (ay - by) * (ay - by) + (az - bz) * (az - bz))
        expected = min(expected, math.sqrt(best2))
        assert world.min_separation_m == (None if expected == math.inf else expected)
    assert expected < 3.0  # they did come close: the record moved during the run


@pytest.mark.parametrize(
    "raw",
    [
        b'{"v":2,"type":"heartbeat","sender":"brick-1","time_s":1.0}',
        b'{"v":2,"type":"heartbeat","sender":"brick-1","time_s":1.0}  ',
        b'{"a":1} x',
        b'{"a":',
        b'{"a":"\xff"}',
        b'\xef\xbb\xbf{"a":1}',
        '{"a":1}',
        b"[1, 2]",
    ],
)
def test_loads_is_json_loads(raw):
    from masonry.mission.messages import _loads

    try:
        expected = json.loads(raw)
    except ValueError as exc:
        with pytest.raises(type(exc), match=re.escape(str(exc))):
            _loads(raw)
    else:
        assert _loads(raw) == expected


@given(
    st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-3.2, 3.2)),
    st.tuples(st.floats(-10, 10), st.floats(-10, 10), st.floats(0, 5)),
    st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-0.5, 0.0)),
    st.tuples(st.floats(-10, 10), st.floats(-10, 10), st.floats(0, 5)),
)
def test_tool_distance_is_the_numpy_tool_position_distance(attitude, position, offset, target):
    from masonry.fsm.tool import Tool
    from masonry.ports import Telemetry

    tel = Telemetry(0.0, position, (0.0, 0.0, 0.0), attitude, True, "GUIDED", 1.0, True, True, False)
    target_m = np.array(target)
    tool = Tool(offset)
    expected = float(np.linalg.norm(tool.position(tel) - target_m))
    got = tool.distance_m(tel, target_m)
    assert got == pytest.approx(expected, rel=1e-12, abs=1e-12)
