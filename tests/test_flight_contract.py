"""One FlightController contract, run against the scripted fake, the simulator's port and the MAVLink adapter on the
SITL (UDP loopback) as ArduCopter (GUIDED), as PX4 (OFFBOARD), and as PX4 on GNSS (``--vehicle px4``: EKF2's flags,
the ground 0.5 m up, the thrust ramp, GNSS-grade wander; its position checks allow for the wander).

Time is the port's own: the fake's clock and the simulated world advance when told; the MAVLink rig flies its SITL in
lock-step (docs/sitl-lockstep.md): the SITL's time moves only as the rig grants it, at most ``TIME_SCALE`` times the
wall, so its figures do not depend on the machine's load (issue 29: free at x2, run 9 of the SITL load loop stopped
short, 0.11 m/s left after 6 s). The assertions are in autopilot seconds for all. A MAVLink rig's failed wait, and a
failed set-up, add both sides of the flight (``sitl_story``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from masonry.adapters.lockstep import LockstepClock
from masonry.blueprint import load_blueprint
from masonry.errors import CommandRejected
from masonry.ports import FlightController, Telemetry
from sitl_story import describe_flight
from test_sitl import LOCKSTEP_WAIT_S
from waiting import step_until, wait_until

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
TIME_SCALE = 8.0  # in lock-step only the SITL's top speed (free at 4, a loaded machine starved the stream)
#: a bound (wall s) on waiting for the SITL's first heartbeat: evidence, not a figure (at 3 s, run 9 at load
#: 20-27 missed it at set-up)
CONNECT_WAIT_S = 30.0


@dataclass
class Rig:
    fc: FlightController
    now_s: Callable[[], float]
    step: Callable[[float], None]  # let dt_s of the port's time pass
    home_m: tuple[float, float, float]
    gnss_m: float = (
        0.0  # the position source's wander (GNSS-grade on the px4-gnss SITL): added to position checks
    )
    story: Callable[[], str] | None = None  # both sides of a SITL flight now (sitl_story), for a failure

    def told(self, what: str) -> str:
        return what if self.story is None else f"{what}\n{self.story()}"

    def run(self, duration_s: float, each: Callable[[], None] | None = None, dt_s: float = 0.05) -> None:
        end = self.now_s() + duration_s
        while self.now_s() < end:
            if each is not None:
                each()
            self.step(dt_s)

    def until(
        self,
        predicate: Callable[[Telemetry], bool],
        timeout_s: float,
        what: str,
        each: Callable[[], None] | None = None,
    ) -> float:
        start = self.now_s()
        while not predicate(self.fc.telemetry()):
            if self.now_s() - start > timeout_s:
                raise AssertionError(
                    self.told(f"{what}: not within {timeout_s} s; last {self.fc.telemetry()}")
                )
            if each is not None:
                each()
            self.step(0.05)
        return self.now_s() - start


@pytest.fixture(params=["fake", "sim", "mavlink", "mavlink-px4", "mavlink-px4-gnss"])
def rig(request) -> Iterator[Rig]:
    bp = load_blueprint(CASE_STUDY)
    spec = bp.uavs("brick")[0]
    if request.param == "fake":
        from masonry.fakes import FakeClock, FakeFlightController

        clock = FakeClock()
        fake = FakeFlightController(clock, position_m=spec.home_m, ground_z_m=spec.home_m[2])
        fake.connect()
        yield Rig(fake, clock.now_s, clock.advance, spec.home_m)
        fake.close()
        return
    if request.param == "sim":
        from masonry.sim import World

        world = World(bp, seed=1)
        uav = world.add_uav(spec)
        uav.fc.connect()
        yield Rig(uav.fc, world.clock.now_s, world.step, spec.home_m)
        uav.fc.close()
        return
    from masonry.adapters.mavlink import FrameTransform, MavlinkFlightController
    from masonry.adapters.sitl import MavlinkSitl, SitlConfig, free_udp_port

    port = free_udp_port()
    autopilot = "px4" if request.param.startswith("mavlink-px4") else "ardupilot"
    config = SitlConfig(heartbeat_hz=4.0, autopilot=autopilot)
    if request.param == "mavlink-px4-gnss":  # issue 20: EKF2's flags, the ground 0.5 m up, thrust ramp, GNSS
        from masonry.adapters.sitl import SITL_PRESETS

        config = SitlConfig(heartbeat_hz=4.0, **SITL_PRESETS["px4"])
    sitl = MavlinkSitl(
        port, home_m=spec.home_m, time_scale=TIME_SCALE, config=config, lockstep_wait_s=LOCKSTEP_WAIT_S
    )
    sitl.start()
    started_wall_s = time.monotonic()
    # the SITL's local frame starts at its home, as a real autopilot's on GPS (masonry fly's default origin)
    fc = MavlinkFlightController(
        f"udpin:127.0.0.1:{port}",
        connect_timeout_s=CONNECT_WAIT_S,
        frame=FrameTransform(spec.home_m),
        ground_m=spec.home_m,  # the ground measured as masonry fly measures it (HardwareConfig.ground_for)
    )
    clock = LockstepClock(fc)  # before connecting: the SITL announces lock-step on the first heartbeat
    try:
        try:
            fc.connect()
            assert fc.autopilot == autopilot  # detected from the HEARTBEAT
            wait_until(lambda: clock.sleep(0.0) or clock.lockstep, 10.0, "the SITL's lock-step announcement")
            # the estimate's convergence, on the SITL's time (the pre-flight's wait_for_estimate(3.0))
            step_until(clock, lambda: fc.telemetry().position_ok, 3.0, "the position estimate")
            fc.measure_ground(spec.home_m)  # as the pre-flight check does
        except Exception as exc:
            exc.add_note(describe_flight(sitl, fc, started_wall_s))  # both sides at the failure (sitl_story)
            raise
        gnss_m = 0.15 if request.param == "mavlink-px4-gnss" else 0.0  # +-15 cm (issue 20)
        yield Rig(
            fc,
            clock.now_s,
            clock.sleep,
            spec.home_m,
            gnss_m,
            story=lambda: describe_flight(sitl, fc, started_wall_s),
        )
        # on the grants' time throughout: the SITL never ran free
        assert sitl.lockstep is not None and sitl.lockstep.free_runs == 0, describe_flight(
            sitl, fc, started_wall_s
        )
    finally:
        fc.close()
        sitl.stop()


def test_starts_landed_disarmed_at_home(rig: Rig) -> None:
    tel = rig.fc.telemetry()
    assert tel.link_ok and tel.position_ok
    assert tel.on_ground and not tel.armed
    assert tel.position_m == pytest.approx(rig.home_m, abs=0.02)
    assert tel.battery_fraction == pytest.approx(1.0, abs=0.01)


def test_takeoff_requires_arming(rig: Rig) -> None:
    with pytest.raises(CommandRejected) as info:
        rig.fc.takeoff(1.0)
    assert "not armed" in info.value.reason


def test_flight_arm_takeoff_move_turn_stop_land(rig: Rig) -> None:
    fc = rig.fc
    fc.arm()
    assert fc.telemetry().armed
    fc.takeoff(1.0)  # metres above the ground it stands on
    rig.until(
        lambda t: not t.on_ground and t.position_m[2] > 0.95 and abs(t.velocity_mps[2]) < 0.1, 8.0, "takeoff"
    )
    assert fc.telemetry().position_m[2] == pytest.approx(1.0, abs=0.08 + rig.gnss_m)

    with pytest.raises(CommandRejected):
        fc.disarm()  # flying
    assert fc.telemetry().armed

    start = fc.telemetry()
    rig.run(
        2.0, each=lambda: fc.send_velocity((0.5, 0.0, 0.0), 0.4)
    )  # east, turning left (counter-clockwise)
    moved = fc.telemetry()
    dx, dy = moved.position_m[0] - start.position_m[0], moved.position_m[1] - start.position_m[1]
    assert 0.6 - rig.gnss_m < dx < 1.1 + rig.gnss_m and abs(dy) < 0.1 + rig.gnss_m
    assert moved.velocity_mps[0] == pytest.approx(0.5, abs=0.1 + rig.gnss_m)  # (EKF2: noisy velocity too)
    turned = math.remainder(moved.attitude_rad[2] - start.attitude_rad[2], math.tau)
    assert 0.4 < turned < 0.85
    assert moved.position_m[2] == pytest.approx(1.0, abs=0.08 + rig.gnss_m)

    # no more setpoints: the autopilot stops the UAV (guided timeout / the adapter's stale-setpoint hold)
    rig.until(lambda t: math.hypot(*t.velocity_mps) < 0.05, 6.0, "stop when setpoints cease")
    assert not fc.telemetry().on_ground

    fc.land()
    rig.until(lambda t: t.on_ground and not t.armed, 8.0, "landing and auto-disarm")
    assert fc.telemetry().position_m[2] == pytest.approx(0.0, abs=0.03 + rig.gnss_m)


def test_velocity_setpoints_are_ignored_on_the_ground(rig: Rig) -> None:
    rig.fc.arm()
    rig.run(1.0, each=lambda: rig.fc.send_velocity((0.5, 0.5, 0.0), 0.0))
    tel = rig.fc.telemetry()
    assert tel.on_ground
    assert tel.position_m == pytest.approx(rig.home_m, abs=0.02)
