"""Gates that cannot livelock on a real autopilot (issue 19): a swing fails the attempt at once with its reason;
a take-off the autopilot dropped (disarmed on the ground) is asked for again."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.blueprint import load_blueprint
from masonry.cli import app
from masonry.fsm import UavConfig, fly_task
from masonry.fsm.tuning import uav_settings
from masonry.planner import plan
from masonry.sim import World
from masonry.sim.vehicle_config import vehicle_preset

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def test_a_swinging_hover_fails_fast_with_its_reason(tmp_path):
    # the simulated ArduCopter flown with a position gain far past its stability limit (pi / (2 x lag)). The
    # ideal vehicle's kp 3 /s swings on the SITL (issue 19), but only just on the model: its 0.1 s delay does not
    # reproduce the SITL's limit cycle (docs/performance/autopilots.md, "The fit, again")
    config = tmp_path / "uav.yaml"
    config.write_text("control_preset: ideal\npid: {xy: {kp: 7.0}}\n")
    res = CliRunner().invoke(app, [
        "fly", "--sim", "--vehicle", "arducopter", "--config", str(config), "--uav", "adhesion", "--task", "A0",
        "--blueprint", str(CASE_STUDY), "--format", "json",
    ])  # fmt: skip
    assert res.exit_code == 0, res.output  # (--format json reports a failed task in the JSON)
    out = json.loads(res.stdout)
    assert out["reason"].startswith("could not hover still over the start of A0: swinging at ")
    assert "masonry fly --identify" in out["reason"]
    states = {s["state"]: s["t_s"] for s in out["trace"]}
    # the gate gave up about swing_patience_s after the leg's end, not after leg_timeout_s (30 s)
    assert states["failsafe"] - states["hover"] < 15.0


class _DroppedTakeoff:
    """The flight controller port of a simulated UAV whose autopilot drops the first take-off: it stays on the
    ground armed, or disarms (``disarm``)."""

    def __init__(self, fc, vehicle, disarm):
        self._fc, self._vehicle, self._disarm, self.takeoffs = fc, vehicle, disarm, 0
        self.asked = []  # (the clock when asked, the time-out given)

    def takeoff(self, altitude_m, timeout_s=None):
        self.takeoffs += 1
        self.asked.append((self._fc.telemetry().time_s, timeout_s))
        if self.takeoffs == 1:
            if self._disarm:
                self._vehicle.disarm()
            return
        self._fc.takeoff(altitude_m, timeout_s)

    def __getattr__(self, name):
        return getattr(self._fc, name)


@pytest.mark.parametrize("disarm", [True, False])
def test_a_dropped_take_off_is_asked_for_again(disarm):
    bp = load_blueprint(CASE_STUDY)
    spec = next(u for u in bp.fleet if u.role == "adhesion")
    world = World(bp, seed=0)
    uav = world.add_uav(spec)
    ports = uav.ports
    fc = _DroppedTakeoff(ports.fc, uav.vehicle, disarm)
    task = next(t for t in plan(bp).tasks if t.id == "A0")
    config = UavConfig.from_spec(spec, cruise_altitude_m=bp.cruise_altitude_m, markers=bp.markers)
    run = fly_task(config, task, fc=fc, clock=ports.clock, sprayer=ports.sprayer, advance=ports.advance)
    assert fc.takeoffs == 2
    assert run.result is not None and run.result.status == "done", run.result
    # the take-off's one time-out, the machine's: the flight controller is given what is left of it each time
    (first_s, first), (again_s, again) = fc.asked
    assert first == config.takeoff_timeout_s == 30.0
    assert again == pytest.approx(first - (again_s - first_s), abs=0.05) and again <= first - 2.0


class _SlowArming:
    """The flight controller port of a simulated UAV whose arming takes ``arming_s`` of the autopilot's clock (a real
    autopilot's pre-arm checks, a lock-step SITL's pre-flight), its world moving on meanwhile."""

    def __init__(self, fc, advance, arming_s):
        self._fc, self._advance, self._arming_s, self.takeoffs = fc, advance, arming_s, 0
        self.timeouts = []

    def arm(self):
        self._advance(self._arming_s)
        self._fc.arm()

    def takeoff(self, altitude_m, timeout_s=None):
        self.takeoffs += 1
        self.timeouts.append(timeout_s)
        self._fc.takeoff(altitude_m, timeout_s)

    def __getattr__(self, name):
        return getattr(self._fc, name)


def test_the_wait_before_asking_a_take_off_again_counts_from_the_arming():
    # the shaped arducopter vehicle leaves its pad a few tenths of a second after the take-off; the machine asks
    # again after 6 s on the ground armed. That wait counted from the tick that began the arming, so an arming of
    # 7 s (on the autopilot's clock) made a take-off asked a moment ago look stuck (a lock-step flight against the
    # project's SITL asked again "9.2 s after the take-off" and flew another way: issue 29)
    bp = load_blueprint(CASE_STUDY)
    spec = next(u for u in bp.fleet if u.role == "adhesion")
    world = World(bp, seed=0, vehicle=vehicle_preset("arducopter"))
    uav = world.add_uav(spec)
    ports = uav.ports
    fc = _SlowArming(ports.fc, ports.advance, arming_s=7.0)
    task = next(t for t in plan(bp).tasks if t.id == "A0")
    config = UavConfig.from_spec(spec, cruise_altitude_m=bp.cruise_altitude_m, markers=bp.markers)
    run = fly_task(config, task, fc=fc, clock=ports.clock, sprayer=ports.sprayer, advance=ports.advance)
    assert fc.takeoffs == 1
    assert fc.timeouts == [pytest.approx(30.0 - 7.0, abs=0.05)]  # the arming spent 7 s of the take-off's 30
    assert run.result is not None and run.result.status == "done", run.result


class _GroundMovesOnArming:
    """The flight controller port of a simulated UAV whose arming takes ``arming_s`` of the autopilot's clock and
    whose reported altitude was ``pre_arm_offset_m`` off until then (an estimate that settles as the autopilot arms:
    PX4's EKF2 moved its altitude while arming on the real SITL, issue 29); the autopilot climbs from the ground it
    has once armed, as a real one does."""

    def __init__(self, fc, advance, arming_s, pre_arm_offset_m):
        self._fc, self._advance, self._arming_s, self._offset_m = fc, advance, arming_s, pre_arm_offset_m
        self.armed_once = False

    def arm(self):
        self._advance(self._arming_s)
        self._fc.arm()
        self.armed_once = True

    def telemetry(self):
        tel = self._fc.telemetry()
        if self.armed_once:
            return tel
        x, y, z = tel.position_m
        return dataclasses.replace(tel, position_m=(x, y, z + self._offset_m))

    def __getattr__(self, name):
        return getattr(self._fc, name)


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter", "px4"])
def test_the_take_off_waits_for_the_altitude_it_climbs_to_from_the_ground_measured_once_armed(vehicle):
    # the machine computed the climb from the ground it saw before arming and waited for the transit altitude;
    # the autopilot climbed from the ground it had once armed: 0.3 m apart, the climb ended 0.3 m under what the
    # machine waited for (more than its 0.1 m slack, and than the px4 vehicle's overshoot) and the take-off timed
    # out (issue 29: PX4 "stalled at 0.99 m of 1.09 m", 1.09 m aimed at while 1.10 m was waited for)
    bp = load_blueprint(CASE_STUDY)
    spec = next(u for u in bp.fleet if u.role == "adhesion")
    world = World(bp, seed=0, vehicle=vehicle_preset(vehicle))
    uav = world.add_uav(spec)
    ports = uav.ports
    fc = _GroundMovesOnArming(ports.fc, ports.advance, arming_s=1.0, pre_arm_offset_m=0.3)
    task = next(t for t in plan(bp).tasks if t.id == "A0")
    tuning = uav_settings(vehicle)  # the vehicle's own control preset, as `masonry fly` picks it
    config = UavConfig.from_spec(spec, cruise_altitude_m=bp.cruise_altitude_m, markers=bp.markers, **tuning)
    run = fly_task(config, task, fc=fc, clock=ports.clock, sprayer=ports.sprayer, advance=ports.advance)
    assert run.result is not None and run.result.status == "done", run.result
    states = [state for _, state in run.trace]
    assert "takeoff" in states and "failsafe" not in states, states
