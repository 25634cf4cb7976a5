"""simulate() as components (issue 28): one frozen SimOptions, a swappable vehicle model and UAV machine."""

from __future__ import annotations

import dataclasses
import json
import typing
from pathlib import Path

import pytest

from benchmark_module import benchmark
from masonry import SimOptions, simulate
from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.errors import InputError, InvalidArgument
from masonry.mission.sim_options import SimFields
from masonry.mission.simulate import SimulatedMission
from masonry.mission.uav_stack import build_machine
from masonry.sim import Faults, SimVehicle, sim_vehicle
from masonry.sim.wind import WindConfig
from test_behaviour_pinned import schedule_digest

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"


def _bench_vehicle_model():
    """benchmarks/bench_vehicle_model.py as a module (the example docs/architecture.md shows)."""
    return benchmark("bench_vehicle_model")


def small():
    return running_bond(1, 3, brick_uavs=1, adhesion_uavs=1)


def test_the_keywords_are_the_fields_of_sim_options():
    assert [f.name for f in dataclasses.fields(SimOptions)] == list(SimFields.__annotations__)
    assert typing.get_type_hints(SimOptions) == typing.get_type_hints(SimFields)


def test_the_default_options_are_masonry_sims_and_frozen():
    options = SimOptions()
    assert (options.policy, options.reservation, options.camera, options.dt_s) == (
        "critical-path",
        "site",
        "geometric",
        0.05,
    )
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.seed = 3  # type: ignore[misc]


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("policy", "random", "`policy` must be one of"),
        ("camera", "lidar", "`camera` must be geometric, render or mixed"),
        ("reservation", "none", "`reservation` must be one of"),
        ("dt_s", 0.0, "dt_s must be > 0"),
        ("resume", True, "`resume` needs `journal_path`"),
        ("table_dispatch", "nearest", "`table_dispatch` must be one of soonest, policy"),
    ],
)
def test_a_bad_option_is_one_line_naming_it(field, value, match):
    with pytest.raises(InputError, match=match) as info:
        SimOptions(**{field: value})
    assert "\n" not in str(info.value)


def test_an_unknown_vehicle_preset_names_the_presets():
    with pytest.raises(InvalidArgument, match="vehicle must be one of ideal, arducopter"):
        SimOptions(vehicle="glider")


def test_options_and_the_old_keywords_fly_the_same_mission():
    bp = small()
    with_options = simulate(bp, SimOptions(seed=2, policy="fifo"))
    with_keywords = simulate(bp, seed=2, policy="fifo")
    # the keywords replace fields of the options given
    mixed = simulate(bp, SimOptions(seed=9, policy="fifo"), seed=2)
    assert with_options.completed
    assert schedule_digest(with_options) == schedule_digest(with_keywords) == schedule_digest(mixed)


def test_an_unknown_keyword_is_refused():
    with pytest.raises(TypeError, match="sed"):
        simulate(small(), sed=2)  # type: ignore[call-arg]


def test_the_default_components_are_the_named_ones():
    bp = small()
    default = SimulatedMission.from_blueprint(bp, SimOptions(seed=3))
    named = SimulatedMission.from_blueprint(
        bp, SimOptions(seed=3), vehicle_model=sim_vehicle, uav_machine=build_machine
    )
    assert all(type(u.vehicle) is SimVehicle for u in default.world.uavs.values())
    assert schedule_digest(default.run()) == schedule_digest(named.run())


def test_the_benchmarks_vehicle_model_flies_a_mission_through_simulate():
    bench = _bench_vehicle_model()
    bp = small()
    mission = SimulatedMission.from_blueprint(bp, SimOptions(seed=1), vehicle_model=bench.sluggish)
    assert all(isinstance(u.vehicle, bench.Sluggish) for u in mission.world.uavs.values())
    report = mission.run()
    baseline = simulate(bp, SimOptions(seed=1))
    assert report.completed and baseline.completed
    assert report.conflict_violations == 0 and report.dependency_violations == 0
    # a velocity loop that reaches 70 % of its setpoints flies the same tasks more slowly
    assert report.makespan_s > baseline.makespan_s + 10.0, (report.makespan_s, baseline.makespan_s)


def test_a_uav_machine_is_a_component():
    built: list[str] = []

    def counting(spec, *args):
        built.append(spec.name)
        return build_machine(spec, *args)

    bp = small()
    report = simulate(bp, SimOptions(seed=1), uav_machine=counting)
    assert report.completed and sorted(built) == sorted(u.name for u in bp.fleet)


def test_max_wind_mps_reaches_simulate():
    """A 9 m/s front holds the mission at the default 8 m/s limit; with ``max_wind_mps=10`` it does not."""
    front = ((0.0, 1.0), (30.0, 1.0), (35.0, 9.0), (200.0, 9.0), (205.0, 1.0))
    faults = Faults(wind=WindConfig(direction_deg=270.0, schedule=front))
    bp = load_blueprint(CASE_STUDY)
    mission = SimulatedMission.from_blueprint(bp, SimOptions(max_wind_mps=10.0), faults=faults)
    assert set(mission.control.wind_limit.limits_mps.values()) == {10.0}
    default = SimulatedMission.from_blueprint(bp, faults=faults)
    assert set(default.control.wind_limit.limits_mps.values()) == {8.0}
    report = simulate(bp, faults=faults, max_wind_mps=10.0, max_time_s=900.0)
    starts = [a["start_s"] for t in json.loads(report.to_json())["tasks"] for a in t["attempts_detail"]]
    assert report.completed and any(34.0 <= s <= 200.5 for s in starts), starts
