"""TaskTiming: one value for the machines, the makespan bound and the airspace, and the three agreeing on it.

For random ``UavConfig`` s: (a) no simulated task beats its minimum duration counted from ``config.timing()``
and the lower bound stays below the makespan; (b) the airspace's work altitude of every task is the altitude the
state machines ask mission control for when they fly there.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

from fsm_rig import Rig, adhesion_task, brick_task
from masonry.airframe import DEFAULT_AIRFRAME
from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.fakes import ScriptedClearanceLink
from masonry.fsm import UavConfig
from masonry.fsm.tuning import uav_settings
from masonry.mission.airspace import task_work_altitude_m, work_altitude_m
from masonry.mission.simulate import simulate
from masonry.motion import MinJerk
from masonry.planner import plan
from masonry.planner.bounds import min_durations_s
from masonry.timing import DEFAULT_TIMING, MIN_JERK_PEAK_TO_MEAN_SPEED, MIN_LEG_S, TaskTiming, min_jerk_leg_s

ROOT = Path(__file__).resolve().parents[1]


# -- the value ---------------------------------------------------------------------------------------------------
def test_the_peak_of_a_min_jerk_leg_is_1_875_times_its_mean_speed() -> None:
    d_m, T_s = 3.0, 4.0
    leg = MinJerk(
        np.zeros(3), np.zeros(3), np.zeros(3), np.array([d_m, 0.0, 0.0]), np.zeros(3), np.zeros(3), T_s
    )
    t = np.linspace(0.0, T_s, 4001)
    peak_mps = float(np.max(np.linalg.norm(leg.velocity(t), axis=-1)))
    assert peak_mps / (d_m / T_s) == pytest.approx(MIN_JERK_PEAK_TO_MEAN_SPEED, rel=1e-6)
    # so a leg flown at a peak speed of v lasts 1.875 d / v, and never less than MIN_LEG_S
    assert min_jerk_leg_s(d_m, peak_mps) == pytest.approx(T_s)
    assert min_jerk_leg_s(0.01, 1.0) == MIN_LEG_S
    assert min_jerk_leg_s(-1.0, 1.0, min_s=0.5) == 0.5


def test_the_default_config_has_the_default_timing() -> None:
    cfg = UavConfig("b", "brick", (0.0, 0.0, 0.0))
    assert cfg.timing() == TaskTiming.from_config(cfg) == DEFAULT_TIMING == TaskTiming()
    assert DEFAULT_TIMING.effector_offset_m == DEFAULT_AIRFRAME.effector_offset_m
    assert DEFAULT_TIMING.descent_duration_s == 7.0  # the paper's t_f
    # every field but the airframe's comes from the config field of the same name
    airframe_fields = {"effector_offset_m", "nozzle_offset_m", "spray_height_m"}
    for f in dataclasses.fields(TaskTiming):
        if f.name not in airframe_fields:
            assert getattr(cfg, f.name) == getattr(DEFAULT_TIMING, f.name), f.name


def test_the_timing_follows_its_config() -> None:
    airframe = dataclasses.replace(DEFAULT_AIRFRAME, effector_offset_m=(0.02, 0.0, -0.6), spray_height_m=0.2)
    cfg = UavConfig("b", "brick", (0.0, 0.0, 0.0), descent_duration_s=5.0, clearance_m=0.4, airframe=airframe)
    t = cfg.timing()
    assert t.descent_duration_s == 5.0 and t.clearance_m == 0.4
    assert t.effector_offset_m == (0.02, 0.0, -0.6) and t.spray_height_m == 0.2
    assert t.carry_altitude_m(1.0, 0.1) == pytest.approx(1.0 + 0.6 + 0.1 + 0.4)
    assert t.spray_altitude_m(1.0) == pytest.approx(1.0 + 0.2 + 0.35 + 0.4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.clearance_m = 1.0  # type: ignore[misc]


# -- random configurations ---------------------------------------------------------------------------------------
@st.composite
def uav_configs(draw: st.DrawFn, geometry: bool = True, preset: str = "ideal") -> UavConfig:
    """A ``UavConfig`` with every number the bound and the airspace count drawn within sane ranges, over the
    gains and gates of the control ``preset`` (the one of the vehicle it flies)."""

    def u(lo: float, hi: float) -> float:
        return draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))

    airframe = DEFAULT_AIRFRAME
    if geometry:
        airframe = dataclasses.replace(
            DEFAULT_AIRFRAME,
            effector_offset_m=(u(-0.03, 0.03), u(-0.03, 0.03), u(-0.6, -0.35)),
            nozzle_offset_m=(0.0, 0.0, u(-0.45, -0.25)),
            spray_height_m=u(0.06, 0.15),
        )
    return UavConfig(
        "template",
        "brick",
        (0.0, 0.0, 0.0),
        **uav_settings(preset),
        airframe=airframe,
        control_period_s=draw(st.sampled_from([0.1, 0.2])),
        cruise_speed_mps=u(0.6, 1.4),
        vertical_speed_mps=u(0.25, 0.6),
        arrive_tolerance_m=u(0.05, 0.12),
        clearance_m=u(0.2, 0.5),
        settle_time_s=u(0.2, 1.0),
        min_estimates=draw(st.integers(5, 15)),
        descent_duration_s=u(3.0, 10.0),
        grasp_dwell_s=u(0.2, 1.0),
        release_dwell_s=u(0.2, 1.0),
        stable_time_s=u(0.5, 1.5),
        spray_descent_s=u(2.0, 6.0),
        spray_speed_mps=u(0.1, 0.25),
        close_dwell_s=u(0.1, 0.6),
        chain_descent_s=u(0.3, 1.0),
    )


def _bound_holds(blueprint, config: UavConfig) -> None:
    note(f"config: {config!r}")
    report = simulate(blueprint, seed=0, uav_config=config)
    assert report.completed, [t for t in report.tasks if t.end_s is None]
    minimum = min_durations_s(
        plan(blueprint), timing=config.timing(), cruise_altitude_m=blueprint.cruise_altitude_m
    )
    for t in report.tasks:
        assert t.start_s is not None and t.end_s is not None
        assert t.end_s - t.start_s >= minimum[t.id] - 1e-6, (t.id, t.end_s - t.start_s, minimum[t.id])
    assert 0.0 < report.lower_bound_s <= report.makespan_s


_SLOW = {
    "deadline": None,
    "derandomize": True,
    "suppress_health_check": [HealthCheck.too_slow],
    "database": None,
}


@pytest.mark.slow
@settings(max_examples=24, **_SLOW)
@given(config=uav_configs(preset="arducopter"))  # simulate()'s default vehicle: arducopter
def test_the_bound_stays_below_the_case_study_for_random_configs(config: UavConfig) -> None:
    _bound_holds(load_blueprint(ROOT / "blueprints" / "paper_case_study.yaml"), config)


@pytest.mark.slow
@settings(max_examples=6, **_SLOW)
@given(config=uav_configs(preset="arducopter"))
def test_the_bound_stays_below_a_running_bond_for_random_configs(config: UavConfig) -> None:
    _bound_holds(running_bond(2, 6, brick_uavs=2, adhesion_uavs=1), config)


class _RecordingLink(ScriptedClearanceLink):
    """Grants every transit at once and records what the machine asked for: (site, top, to)."""

    def __init__(self, tasks, clock) -> None:
        super().__init__(tasks, clock, layer_m=None)
        self.requests: list[tuple[tuple[float, float, float], float | None, object]] = []

    def request_clearance(self, site_m, top_m=None, to_m=None):
        self.requests.append((tuple(float(v) for v in site_m), top_m, to_m))
        return super().request_clearance(site_m, top_m, to_m)


@settings(max_examples=20, **_SLOW)
@given(config=uav_configs(), z_m=st.floats(0.05, 2.0), size_z_m=st.floats(0.06, 0.2))
def test_the_airspace_altitudes_are_the_machines(config: UavConfig, z_m: float, size_z_m: float) -> None:
    note(f"config: {config!r}")
    timing = config.timing()
    cruise = config.cruise_altitude_m
    brick = dataclasses.replace(brick_task(position=(0.0, 0.5, z_m)), size_m=(0.30, 0.15, size_z_m))
    top = z_m + size_z_m / 2.0
    segment = adhesion_task(start=(-0.15, 0.5, top), end=(0.15, 0.5, top))
    carry = _machine_requests("brick", config, brick)
    spray = _machine_requests("adhesion", config, segment)
    # the adhesion UAV asks for its segment's column up to where it flies over it
    assert task_work_altitude_m(segment, cruise, timing=timing) == pytest.approx(spray[0], abs=1e-9)
    # the brick UAV asks for the pickup, then for the drop-off at its transit altitude; the brick's work
    # altitude is the higher of carrying it there and spraying on its top later
    drop = carry[-1]
    assert task_work_altitude_m(brick, cruise, timing=timing) == pytest.approx(max(drop, spray[0]), abs=1e-9)
    assert carry[0] >= drop - 1e-9  # the pickup's column reaches the climb out with the brick
    # and the blueprint's work altitude (layer 0) is the highest of them
    bp = dataclasses.replace(running_bond(1, 2, brick_uavs=1, adhesion_uavs=1), cruise_altitude_m=cruise)
    assert work_altitude_m(bp, timing=timing) == pytest.approx(
        max(task_work_altitude_m(t, cruise, timing=timing) for t in plan(bp).tasks), abs=1e-9
    )


def _machine_requests(kind: str, config: UavConfig, task) -> list[float]:
    """The altitudes the machine asked for, up to the end of its task (brick: pickup, drop-off)."""
    rig = Rig(
        kind,
        tasks=[task],
        config={
            f.name: getattr(config, f.name)
            for f in dataclasses.fields(config)
            if f.name not in ("name", "role", "home_m")
        },
    )
    link = _RecordingLink([rig.link.poll_task()], rig.clock)
    rig.link = rig.uav.link = rig.uav.clearance = link
    want = 2 if kind == "brick" else 1
    while rig.clock.now_s() < 300.0 and len(link.requests) < want and not link.results:
        rig.uav.step(rig.clock.now_s())
        rig.clock.advance(0.05)
    sites = []
    for site, top, _to in link.requests:
        if not sites or not math.isclose(sites[-1][0], site[0]) or not math.isclose(sites[-1][1], site[1]):
            sites.append((site[0], site[1], max(site[2], site[2] if top is None else float(top))))
    assert len(sites) >= want, (rig.states, link.requests)
    return [s[2] for s in sites]


def test_mission_control_raises_its_layers_with_the_uavs_timing() -> None:
    """Layer 0 rises over the work done with the altitudes of the UAVs' timing, not the default one."""
    from masonry.mission.airspace import layer_base_m
    from masonry.mission.control import MissionControl
    from masonry.mission.inproc import InprocBus
    from masonry.mission.messages import MISSION_CONTROL

    bp = running_bond(8, 2, placed_courses=2, brick_uavs=1, adhesion_uavs=1)
    p = plan(bp)
    cruise = bp.cruise_altitude_m
    placed = [t for t in p.tasks if t.done]
    for timing in (DEFAULT_TIMING, dataclasses.replace(DEFAULT_TIMING, clearance_m=0.6, spray_height_m=0.2)):
        final = layer_base_m(bp, timing=timing)
        mc = MissionControl(
            p,
            bp.fleet,
            InprocBus().endpoint(MISSION_CONTROL),
            layer_base_m=final,
            layer_floor_m=cruise,
            timing=timing,
        )
        built = max(task_work_altitude_m(t, cruise, timing=timing) for t in placed)
        assert mc.columns.layer_base_m == pytest.approx(max(cruise, built))
        assert mc.columns.layer_base_m < final
    assert layer_base_m(bp, timing=timing) >= layer_base_m(bp) + 0.3 - 1e-9  # the clearance is 0.3 m higher
