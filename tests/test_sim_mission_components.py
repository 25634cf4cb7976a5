"""``SimulatedMission``: a simulated mission from its components (rotorpy's shape); ``simulate()`` wraps it."""

from __future__ import annotations

import dataclasses
import importlib

import pytest

from masonry.blueprint_gen import running_bond
from masonry.errors import InputError
from masonry.fingerprint import wall_digest
from masonry.mission.control import MissionControl
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL
from masonry.mission.simulate import SimulatedMission, simulate
from masonry.planner import plan
from masonry.sim import World
from test_behaviour_pinned import schedule_digest


def small():
    return running_bond(2, 3, brick_uavs=2, adhesion_uavs=1)


def test_simulate_is_from_blueprint_then_run():
    bp = small()
    mission = SimulatedMission.from_blueprint(bp, seed=4, policy="fifo")
    assert set(mission.handlers) == {u.name for u in bp.fleet}
    assert mission.clock is mission.world.clock
    assert schedule_digest(mission.run()) == schedule_digest(simulate(bp, seed=4, policy="fifo"))


class CountingFc:
    """A flight controller that counts the setpoints sent through it (and passes everything on)."""

    def __init__(self, fc):
        self.fc = fc
        self.setpoints = 0

    def send_velocity(self, velocity_mps, yaw_rate_radps):
        self.setpoints += 1
        self.fc.send_velocity(velocity_mps, yaw_rate_radps)

    def __getattr__(self, name):
        return getattr(self.fc, name)


def test_components_are_injected_mission_control_world_and_one_uav_ports_each():
    bp = small()
    the_plan = plan(bp)
    world = World(bp, seed=1)
    world.add_fleet()
    bus = InprocBus()
    mc = MissionControl(
        the_plan, bp.fleet, bus.endpoint(MISSION_CONTROL), startup_timeout_s=1.0, wall_digest=wall_digest(bp)
    )  # the handlers refuse tasks of another wall
    name = bp.fleet[0].name
    counting = CountingFc(world.uavs[name].fc)
    ports = {name: dataclasses.replace(world.uavs[name].ports, fc=counting)}
    mission = SimulatedMission(bp, the_plan, world=world, control=mc, bus=bus, ports=ports, seed=1)
    assert mission.control is mc and mission.world is world and mission.ports[name].fc is counting
    report = mission.run()
    assert report.completed and report.conflict_violations == 0 and report.dependency_violations == 0
    assert counting.setpoints > 100  # the machine of that UAV flew through the injected port


def test_a_mission_runs_once():
    mission = SimulatedMission.from_blueprint(running_bond(1, 2, brick_uavs=1, adhesion_uavs=1))
    assert mission.run().completed
    with pytest.raises(InputError, match="run already"):
        mission.run()


def test_every_uav_of_the_fleet_must_be_in_the_world():
    bp = small()
    world = World(bp, seed=0)
    world.add_uav(bp.fleet[0])
    bus = InprocBus()
    mc = MissionControl(plan(bp), bp.fleet, bus.endpoint(MISSION_CONTROL))
    with pytest.raises(InputError, match="no UAV named"):
        SimulatedMission(bp, plan(bp), world=world, control=mc, bus=bus)


def test_the_journal_is_closed_when_the_run_ends_or_the_mission_is_closed(tmp_path):
    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=1)
    mission = SimulatedMission.from_blueprint(bp, journal_path=tmp_path / "a.db")
    journal = mission.measured.journal
    assert journal._conn is not None
    mission.run()
    assert journal._conn is None
    with SimulatedMission.from_blueprint(bp, journal_path=tmp_path / "b.db") as unused:
        journal = unused.measured.journal
    assert journal._conn is None


def test_a_failed_build_closes_the_journal(tmp_path, monkeypatch):
    from masonry.mission import journal as journal_module

    simulate_module = importlib.import_module("masonry.mission.simulate")

    opened = []
    real_open = journal_module.open_mission_journal

    def spy_open(*args, **kwargs):
        out = real_open(*args, **kwargs)
        opened.append(out[0])
        return out

    def broken(*args, **kwargs):
        raise InputError("no mission control today")

    monkeypatch.setattr(simulate_module, "open_mission_journal", spy_open)
    monkeypatch.setattr(simulate_module, "MissionControl", broken)
    with pytest.raises(InputError, match="no mission control today"):
        SimulatedMission.from_blueprint(
            running_bond(1, 2, brick_uavs=1, adhesion_uavs=1), journal_path=tmp_path / "c.db"
        )
    assert len(opened) == 1 and opened[0]._conn is None


def test_journaled_errors_prefer_the_world_measurement_over_the_uav_estimate():
    from types import SimpleNamespace

    from masonry.mission.measured import journaled_errors_m

    state = SimpleNamespace(
        done=[
            SimpleNamespace(
                task_id="B0", fields={"measured": {"placement_error_m": 0.004}, "placement_error_m": 0.01}
            ),
            SimpleNamespace(
                task_id="B1", fields={"placement_error_m": 0.02}
            ),  # a journal without measurements
            SimpleNamespace(task_id="A0", fields={"coverage": 0.9}),
        ]
    )
    assert journaled_errors_m(state) == {"B0": 0.004, "B1": 0.02}
    assert journaled_errors_m(None) == {}


def test_mission_control_without_the_walls_digest_is_refused_at_once():
    """Built by hand without ``wall_digest``, every UAV would refuse every task: say so instead of hanging."""
    bp = small()
    p = plan(bp)
    world = World(bp)
    world.add_fleet(bp.fleet)
    bus = InprocBus()
    mc = MissionControl(p, bp.fleet, bus.endpoint(MISSION_CONTROL))
    with pytest.raises(InputError, match="built for another wall"):
        SimulatedMission(bp, p, world=world, control=mc, bus=bus)
