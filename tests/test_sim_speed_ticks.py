"""The per-tick fast paths of issue 27's second speed-up give what the general paths gave (docs/performance/mission.md).

Covered: the setpoint shaping's inlined ``sqrt_controller`` and its draws three at a time, the site gate's scan
over the visits in progress, the liveness sweep's early exit, the watchdogs' flags per state, and the battery
budget's legs as tuples and the put-back's legs kept between ticks, the camera's marker layout and its
``covered`` answers kept between frames.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fsm_rig import Rig
from masonry.blueprint import Brick, MarkerSpec, UavSpec
from masonry.fsm.config import UavConfig
from masonry.fsm.navigator import Navigator
from masonry.geometry import wrap_angle_rad
from masonry.mission.liveness import Lapse, Liveness, LivenessTracker, Timeouts
from masonry.mission.records import UavLink
from masonry.mission.sites import SiteIntervals, SiteVisit
from masonry.mission.uav_facts import UavFacts
from masonry.motion.pid import PID, AxisGains, PIDGains
from masonry.planner.tasks import BrickTask, Plan
from masonry.sim.bricks import BrickField, SimBrick
from masonry.sim.camera import CameraConfig, LayoutCache, marker_layout, observe_markers
from masonry.sim.shaping import (
    ARDUCOPTER,
    PX4,
    PX4_BELOW_OWN_LOOP,
    Shaper,
    ShapingConfig,
    _Axis,
    _sqrt_controller,
)
from masonry.sim.vehicle import _Gauss

finite = st.floats(-20.0, 20.0, allow_nan=False)


def _reference_axis_step(axis: _Axis, v: float, a: float, target: float, dt: float) -> tuple[float, float]:
    """``_Axis.step`` as it was: through :func:`_sqrt_controller` (returns the new velocity and acceleration)."""
    e = target - v
    if not math.isfinite(axis.gain):
        return target, 0.0
    want = _sqrt_controller(e, axis.gain, axis.jerk, dt)
    want = axis.accel if want > axis.accel else (-axis.accel if want < -axis.accel else want)
    da = want - a
    step = axis.jerk * dt
    a += step if da > step else (-step if da < -step else da)
    return v + a * dt, a


@settings(max_examples=300, deadline=None)
@given(
    jerk=st.one_of(st.just(math.inf), st.floats(0.5, 20.0)),
    accel=st.one_of(st.just(math.inf), st.floats(0.5, 10.0)),
    targets=st.lists(finite, min_size=1, max_size=30),
    dt=st.sampled_from([0.05, 0.01, 0.1]),
)
def test_axis_step_is_the_sqrt_controller_step(jerk, accel, targets, dt):
    axis = _Axis(jerk, accel)
    v = a = 0.0
    for target in targets:
        v, a = _reference_axis_step(axis, v, a, target, dt)
        assert axis.step(target, dt) == v  # the same float, not a close one
        assert axis.a == a and axis.v == v


def test_drift_takes_the_same_draws_in_blocks_as_one_by_one():
    """Three draws at once (``_Gauss.take``) across the 4096-draw refills give the numbers of one call each."""
    for config in (ARDUCOPTER, PX4):  # PX4: the velocity's wander draws too
        fast, slow = Shaper(config), Shaper(config)
        gauss, plain = _Gauss(np.random.default_rng(3)), _Gauss(np.random.default_rng(3))
        one_by_one = plain.__call__  # (a bound method: no ``take``)
        for _ in range(5000):  # 15,000-30,000 draws: several refills, some mid-triple
            fast.drift(0.05, gauss)
            slow.drift(0.05, one_by_one)
            assert fast.gps_error_m == slow.gps_error_m
            assert fast._velocity_wander_mps == slow._velocity_wander_mps


def _task(i: int) -> BrickTask:
    return BrickTask(f"B{i}", i, False, (0.3 * i, 0.0, 0.15), 0.0, (0.3 * i, -3.0, 0.05))


@settings(max_examples=200, deadline=None)
@given(
    conflicts=st.sets(st.tuples(st.integers(0, 7), st.integers(0, 7)).filter(lambda p: p[0] < p[1])),
    on_site=st.dictionaries(st.integers(0, 7), st.sampled_from(["a", "b", "c"]), max_size=4),
    asking=st.sampled_from(["a", "b", "c"]),
    task=st.integers(0, 7),
)
def test_the_site_gate_scans_the_visits_as_it_scanned_the_neighbours(conflicts, on_site, asking, task):
    tasks = tuple(_task(i) for i in range(8))
    plan = Plan(tasks, (), tuple((f"B{a}", f"B{b}") for a, b in sorted(conflicts)))
    s = SiteIntervals(plan, {asking: f"B{task}"}.get, exclusive=True)
    s.on_site = {f"B{t}": SiteVisit(f"B{t}", uav, 0.0) for t, uav in on_site.items()}
    tid = f"B{task}"
    site = tasks[task].position_m
    visits = s.on_site
    blocked = any(n in visits and visits[n].uav != asking for n in s._neighbours[tid])  # as it was
    assert s.may_enter(asking, site) is (not blocked)


def _reference_sweep(tracker: LivenessTracker, now_s: float, has_task) -> list[tuple[str, Lapse]]:
    """``LivenessTracker.sweep`` as it was: every UAV's silence limit asked on every sweep."""
    out = []
    for name, link in tracker.links.items():
        until_s = link.airspace_until_s
        if until_s is not None and (not link.lost or now_s >= until_s):
            if link.lost:
                out.append((name, Lapse.AIRSPACE_EXPIRED))
            link.airspace_until_s = None
        if link.lost or link.last_heard_s is None:
            continue
        quiet_s = now_s - link.last_heard_s
        if quiet_s > tracker.timeouts.silence_limit_s(link.facts.finishing, has_task(name)):
            out.append((name, Lapse.SILENT_TOO_LONG))
        elif quiet_s > tracker.timeouts.heartbeat_s:
            link.liveness = Liveness.SILENT
    return out


@settings(max_examples=300, deadline=None)
@given(
    rejoin_s=st.floats(-3.0, 10.0),
    uavs=st.lists(
        st.tuples(
            st.one_of(st.none(), st.floats(0.0, 30.0)),  # last heard
            st.booleans(),  # finishing
            st.booleans(),  # has a task
            st.sampled_from(list(Liveness)),
        ),
        min_size=1,
        max_size=5,
    ),
)
def test_the_liveness_sweep_skips_only_what_it_would_not_have_changed(rejoin_s, uavs):
    def links():
        out = {}
        for k, (heard, finishing, _, liveness) in enumerate(uavs):
            link = UavLink(UavSpec(f"u{k}", "brick", (0.0, 0.0, 0.0)), last_heard_s=heard, liveness=liveness)
            link.facts = UavFacts(finishing=finishing)
            out[f"u{k}"] = link
        return out

    tasks = {f"u{k}": u[2] for k, u in enumerate(uavs)}
    fast, slow = links(), links()
    timeouts = Timeouts(5.0, rejoin_s)
    got = LivenessTracker(fast, timeouts).sweep(30.0, tasks.__getitem__)
    assert got == _reference_sweep(LivenessTracker(slow, timeouts), 30.0, tasks.__getitem__)
    assert [link.liveness for link in fast.values()] == [link.liveness for link in slow.values()]


@settings(max_examples=200, deadline=None)
@given(a=st.tuples(finite, finite, finite), b=st.tuples(finite, finite, finite))
def test_a_leg_of_tuples_lasts_what_the_same_leg_of_arrays_lasts(a, b):
    nav = Navigator(UavConfig(name="u", role="brick", home_m=(0.0, 0.0, 0.0)))
    assert nav.leg_duration_s(a, b) == nav.leg_duration_s(np.asarray(a), np.asarray(b))


def _putback_need_as_it_was(uav, from_m) -> float:
    """``PutBack._putback_need_s`` as it was: every leg computed on every call."""
    cfg = uav.config
    effector_m, yaw = uav._putback_pose()
    body = uav.effector.body_target(effector_m, yaw)
    over = (float(body[0]), float(body[1]), uav._transit_altitude_m())
    return (
        uav._route_s(from_m, over)
        + cfg.descent_duration_s
        + cfg.release_dwell_s
        + uav._vertical_s(over[2] - float(body[2]))
        + uav._home_s(over)
    )


@settings(max_examples=50, deadline=None)
@given(
    froms=st.lists(st.tuples(finite, finite, st.floats(0.0, 5.0)), min_size=1, max_size=5),
    estimates=st.lists(
        st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(-3.0, 3.0)), min_size=1, max_size=3
    ),
    carry_yaw=st.floats(-3.0, 3.0),
)
def test_the_put_back_legs_kept_between_ticks_are_the_legs_computed_again(froms, estimates, carry_yaw):
    uav = Rig("brick", clearance={}).uav
    uav.task = uav.link.poll_task()
    for x, y, yaw in estimates:  # a new estimate (or carry yaw) is a new put-back: its legs computed again
        uav.attempt.brick_estimate = (np.array([x, y, 0.05]), yaw)
        uav.attempt.carry_yaw_rad = carry_yaw
        for from_m in froms:
            assert uav._putback_need_s(from_m) == _putback_need_as_it_was(uav, from_m)
        carry_yaw = -carry_yaw


def test_lost_is_the_report_saying_lost_or_out_of_service():
    link = UavLink(UavSpec("u", "brick", (0.0, 0.0, 0.0)))
    for liveness in Liveness:
        link.liveness = liveness
        assert link.lost is (link.status != "ok")


def _field_of(n: int) -> BrickField:
    field = BrickField(0.5)
    size = (0.3, 0.15, 0.1)
    for i in range(n):
        x, z = 0.31 * (i % 4), 0.05 + 0.1 * (i // 4)
        field.add(SimBrick(i, Brick(i, (x, 0.0, z), size), (x, 0.0, z), 0.1 * i, "placed"))
    return field


def test_the_kept_layout_is_the_layout_of_the_bricks_as_they_are_now():
    field, markers = _field_of(8), MarkerSpec()
    cache = LayoutCache()
    bricks = list(field.near(0.3, 0.0, 1.0))

    def same(layout, expected):
        return all(np.array_equal(a, b) for a, b in zip(layout, expected, strict=True))

    assert same(cache.layout(bricks, markers, field.version), marker_layout(bricks, markers))
    field.pick(bricks[0].id, "brick-1")  # carried: compared by its pose from now on
    bricks[0].position_m = (0.5, 0.2, 0.6)
    assert same(cache.layout(bricks, markers, field.version), marker_layout(bricks, markers))
    bricks[0].yaw_rad = 0.7  # (moves with its UAV every physics step)
    assert same(cache.layout(bricks, markers, field.version), marker_layout(bricks, markers))
    field.drop(bricks[0].id, 0.0)  # resting again, somewhere else: a new version
    assert same(cache.layout(bricks, markers, field.version), marker_layout(bricks, markers))
    fewer = bricks[1:]
    assert same(cache.layout(fewer, markers, field.version), marker_layout(fewer, markers))


def test_the_kept_layout_with_carried_bricks_after_the_resting_ones_is_their_layout_every_frame():
    # (a world's frames: the resting bricks near the camera, then every carried brick of the fleet, moving)
    field, markers = _field_of(8), MarkerSpec()
    cache = LayoutCache()
    field.pick(7, "brick-2")
    carried = field.bricks[7]
    resting = list(field.near(0.3, 0.0, 1.0))
    assert all(b.state != "carried" for b in resting)

    def same(layout, expected):
        return all(np.array_equal(a, b) for a, b in zip(layout, expected, strict=True))

    for step in range(4):
        carried.position_m = (0.1 * step, 0.3, 0.8 + 0.05 * step)
        carried.yaw_rad = 0.2 * step
        frame = [*resting, carried]
        assert same(cache.layout(frame, markers, field.version), marker_layout(frame, markers))
        assert same(cache.layout(resting, markers, field.version), marker_layout(resting, markers))
    field.drop(7, 0.0)  # resting again: a new version, and the same bricks laid out afresh
    resting = list(field.near(0.3, 0.0, 1.0))
    assert same(cache.layout(resting, markers, field.version), marker_layout(resting, markers))


def test_covered_kept_answers_what_covered_at_answers_as_bricks_come_and_go():
    field = _field_of(12)
    points = [
        (0.31 * (i % 4) + dx, dy, 0.1 * (i // 4)) for i in range(12) for dx in (0.0, 0.1) for dy in (0, 0.05)
    ]
    for step in range(5):
        for p in points:
            assert field.covered_kept(*p) == field.covered_at(*p)
        if step % 2 == 0:
            field.pick(
                8 + step // 2, "brick-1"
            )  # the upper course's bricks leave, uncovering the ones under them
        else:
            field.drop(8 + step // 2, 0.0)


def test_a_frame_over_no_brick_has_an_empty_layout_and_sees_nothing():
    # (a UAV over bare ground: the kept layout of no brick is empty, not an error; the .ci/run rehearsal of the merge)
    markers = MarkerSpec()
    ids, centres, corners = LayoutCache().layout([], markers, 0)
    assert ids.shape == (0,) and centres.shape == (0, 3) and corners.shape == (0, 4, 3)


# -- issue 27's fourth speed-up (branch simspeed34): the same floats as the code each replaced --------------------


def _pid_as_it_was(pid, integral, now, p, t, ff, yaw, target_yaw, measure_dt):  # type: ignore[no-untyped-def]
    """``PID.step_floats``'s axis loop as it was: all four axes, the yaw's thrown away without a yaw target."""
    rate = pid._rate
    yaw_active = target_yaw is not None
    error = (t[0] - p[0], t[1] - p[1], t[2] - p[2], wrap_angle_rad(target_yaw - yaw) if yaw_active else 0.0)
    integrate = measure_dt is not None and measure_dt > 0.0
    out = [0.0, 0.0, 0.0, 0.0]
    for i, (kp, ki, kd, out_lim, int_lim) in enumerate(pid._flat):
        e = error[i]
        base = (*ff, 0.0)[i] + kp * e - kd * rate[i]
        if integrate:
            candidate = min(int_lim, max(-int_lim, integral[i] + ki * e * measure_dt))
            unsat = base + candidate
            if not (abs(unsat) > out_lim and unsat * e > 0.0):
                integral[i] = candidate
        out[i] = min(out_lim, max(-out_lim, base + integral[i]))
    if not yaw_active:
        integral[3] = 0.0
        return out[0], out[1], out[2], 0.0
    return tuple(out)


@settings(max_examples=100, deadline=None)
@given(
    ticks=st.lists(
        st.tuples(
            st.tuples(finite, finite, finite),
            st.tuples(finite, finite, finite),
            st.floats(-3.0, 3.0),
            st.one_of(st.none(), st.floats(-3.0, 3.0)),
        ),
        min_size=1,
        max_size=40,
    )
)
def test_the_pid_without_a_yaw_target_skips_the_yaw_axis_and_steers_as_before(ticks):
    pid = PID(PIDGains(yaw=AxisGains(kp=1.5, ki=0.4, kd=0.1, output_limit=1.0, integral_limit=0.5)))
    integral = [0.0, 0.0, 0.0, 0.0]
    yaw_was_active = False
    for k, (p, t, yaw, target_yaw) in enumerate(ticks):
        now = 0.1 * k
        if target_yaw is not None and not yaw_was_active:
            integral[3] = 0.0
        yaw_was_active = target_yaw is not None
        prev_t = pid._prev_t_s
        got = pid.step_floats(
            now, p, t, velocity_ff_mps=(0.1, -0.2, 0.0), yaw_rad=yaw, target_yaw_rad=target_yaw
        )
        # (the rates are measured before the loop: the reference reads them as step_floats left them)
        want = _pid_as_it_was(
            pid,
            integral,
            now,
            p,
            t,
            (0.1, -0.2, 0.0),
            yaw,
            target_yaw,
            None if prev_t is None else now - prev_t,
        )
        assert got == want
        assert pid._integral == integral


def _drift_as_it_was(shaper: Shaper, dt_s: float, gauss) -> None:  # type: ignore[no-untyped-def]
    """``Shaper.drift`` as it was: its coefficients computed on every step, the axes in loops."""
    cfg = shaper.config
    if cfg.velocity_wander_mps > 0.0:
        a = min(1.0, dt_s / cfg.velocity_wander_tau_s)
        b = cfg.velocity_wander_mps * math.sqrt(a * (2.0 - a))
        w = shaper._velocity_wander_mps
        g = [gauss(), gauss(), gauss()]
        for i in range(3):
            w[i] += -w[i] * a + b * g[i]
    sigma = cfg.gps_noise_m
    if sigma <= 0.0:
        return
    a = dt_s / cfg.gps_noise_tau_s
    b = sigma * math.sqrt(2.0 * a)
    err = shaper.gps_error_m if cfg.gps_noise_smooth_s <= 0.0 else shaper._wander_m
    g = [gauss(), gauss(), gauss()]
    for i in range(3):
        err[i] += -err[i] * a + b * g[i]
    if cfg.gps_noise_smooth_s > 0.0:
        k = min(1.0, dt_s / cfg.gps_noise_smooth_s)
        for i in range(3):
            shaper.gps_error_m[i] += k * (err[i] - shaper.gps_error_m[i])


def test_the_drift_with_its_coefficients_kept_moves_as_it_did_when_the_step_changes_too():
    unsmoothed = ShapingConfig(gps_noise_m=0.05, gps_noise_tau_s=3.0)
    for config in (ARDUCOPTER, PX4, PX4_BELOW_OWN_LOOP, unsmoothed, ShapingConfig()):
        fast, slow = Shaper(config), Shaper(config)
        gauss, plain = _Gauss(np.random.default_rng(5)), _Gauss(np.random.default_rng(5))
        for k in range(3000):
            dt = (0.05, 0.01, 0.2)[(k // 700) % 3]  # (the kept coefficients follow a new step)
            fast.drift(dt, gauss)
            _drift_as_it_was(slow, dt, plain.__call__)
            assert fast.gps_error_m == slow.gps_error_m
            assert fast._velocity_wander_mps == slow._velocity_wander_mps
            assert fast._wander_m == slow._wander_m


def test_the_kept_covered_answers_and_yaws_see_the_tags_asking_again_sees_frame_after_frame():
    # (a world's frames over a wall of three courses: the resting bricks, then a carried one moving; bricks picked
    # and put down between frames, uncovering and covering markers)
    field, markers, config = _field_of(12), MarkerSpec(), CameraConfig()
    R_wc = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])  # (looking straight down)
    cache = LayoutCache()
    field.pick(11, "brick-2")
    carried = field.bricks[11]
    seen = covered_seen = 0
    for step in range(12):
        if step in (3, 7):
            field.pick(9 if step == 3 else 2, "brick-1")  # (a top brick leaves: the one under it shows)
        if step in (5, 9):
            field.drop(9 if step == 5 else 2, 0.0)
        carried.position_m, carried.yaw_rad = (0.1 * step, 0.05, 0.6 + 0.02 * step), 0.15 * step
        c_w = np.array([0.45 + 0.02 * step, 0.0, 1.0])
        resting = list(field.near(float(c_w[0]), 0.0, 1.5))
        frame = [*resting, carried] if step % 4 else resting
        layout = cache.layout(frame, markers, field.version)
        fast = observe_markers(
            R_wc, c_w, frame, markers, config, np.random.default_rng(step), covered=field.covered_kept,
            layout=layout, kept=cache,
        )  # fmt: skip
        slow = observe_markers(
            R_wc, c_w, frame, markers, config, np.random.default_rng(step), covered=field.covered_at
        )
        everything = observe_markers(R_wc, c_w, frame, markers, config, np.random.default_rng(step))
        assert [t.marker_id for t in fast] == [t.marker_id for t in slow]
        for a, b in zip(fast, slow, strict=True):
            assert np.array_equal(a.position_m, b.position_m) and np.array_equal(
                a.R_cam_marker, b.R_cam_marker
            )
        seen += len(fast)
        covered_seen += len(everything) - len(fast)
    assert seen > 0 and covered_seen > 0  # (markers seen, and markers in view left out as covered)
