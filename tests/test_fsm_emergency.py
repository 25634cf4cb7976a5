"""The emergency state lands the UAV once and never fights a pilot: on the fakes, and on the SITL as PX4.

LAND is commanded once when the emergency begins; it is tried again (once a second) only while it has not gone
through and the autopilot's mode is unchanged. A landing the autopilot already flies (its own failsafe) is left
alone, and so is a mode a pilot selects: ``Telemetry.landing`` tells the machine about landing modes of either
autopilot (ArduPilot LAND, PX4 AUTO.LAND) without string matching in the state machine.
"""

from __future__ import annotations

import itertools
import time

import pytest

from fsm_rig import Rig, glue_on_px4_sitl
from waiting import wait_until


def lands(rig: Rig) -> list[float]:
    """Times of every land() call that reached the fake autopilot (answered or not)."""
    return [t for t, command, _ in rig.fc.commands if command == "land"]


def emergency_in_transport(**rig_options) -> tuple[Rig, dict[str, float]]:
    """A brick UAV whose gripper board dies while it carries the brick (a hardware error: emergency)."""
    rig = Rig("brick", **rig_options)
    began: dict[str, float] = {}

    def fail(r: Rig) -> None:
        if r.uav.state == "transport" and "t" not in began:
            began["t"] = r.clock.now_s()
            r.uav.lost(reason="actuator board not answering")

    rig.on_emergency = fail  # type: ignore[attr-defined]
    return rig, began


def test_land_is_commanded_once() -> None:
    rig, began = emergency_in_transport()
    rig.run(on_tick=rig.on_emergency)  # type: ignore[attr-defined]
    assert rig.states[-2:] == ["emergency", "halted"]
    assert len(lands(rig)) == 1 and lands(rig)[0] == pytest.approx(began["t"], abs=0.06)
    assert rig.fc.telemetry().on_ground and rig.uav.halt_reason == "actuator board not answering"
    assert rig.link.results[0].status == "failed"


def test_a_pilot_taking_over_is_not_fought() -> None:
    rig, began = emergency_in_transport()
    seen: dict[str, float] = {}

    def tick(r: Rig) -> None:
        rig.on_emergency(r)  # type: ignore[attr-defined]
        now = r.clock.now_s()
        if "t" in began and "pilot" not in seen and now >= began["t"] + 0.5:
            seen["pilot"] = now
            r.fc.mode = "LOITER"  # the safety pilot flips the mode switch while the UAV descends
            r.fc.at(now + 20.0, mode="LAND")  # and lands it 20 s later

    rig.run(on_tick=tick)
    pilot_s = seen["pilot"]
    assert len(lands(rig)) == 1  # ours, before the pilot: never again
    # for the 20 s the pilot held it, the UAV stayed in the air in the emergency state, untouched
    emergency_s = next(t for t, s in rig.uav.trace if s == "emergency")
    halted_s = next(t for t, s in rig.uav.trace if s == "halted")
    assert halted_s > pilot_s + 20.0 and emergency_s < pilot_s
    assert [c for t, c, _ in rig.fc.commands if t > pilot_s] in ([], ["disarm"])


def test_no_setpoints_and_no_land_while_the_pilot_flies() -> None:
    rig, began = emergency_in_transport()
    counts: dict[str, int] = {}

    def tick(r: Rig) -> None:
        rig.on_emergency(r)  # type: ignore[attr-defined]
        if "t" in began and r.uav.state == "emergency" and r.fc.mode == "LAND" and "v" not in counts:
            counts["v"] = r.fc.velocity_commands
            r.fc.mode = "LOITER"

    rig.run(max_s=began.get("t", 0.0) + 200.0, on_tick=tick)
    assert rig.uav.state == "emergency" and not rig.fc.telemetry().on_ground  # still the pilot's
    assert rig.fc.velocity_commands == counts["v"] and len(lands(rig)) == 1


def test_an_unanswered_land_is_retried_until_it_goes_through() -> None:
    rig, began = emergency_in_transport()
    rig.fc.land_failures = 2
    rig.run(on_tick=rig.on_emergency)  # type: ignore[attr-defined]
    tries = lands(rig)
    answered = [args for _, c, args in rig.fc.commands if c == "land"]
    assert len(tries) == 3 and answered == [("unanswered",), ("unanswered",), ()]
    assert tries[0] == pytest.approx(began["t"], abs=0.06)
    assert all(b - a == pytest.approx(1.0, abs=0.06) for a, b in itertools.pairwise(tries))
    assert rig.states[-2:] == ["emergency", "halted"] and rig.fc.telemetry().on_ground


def test_an_unanswered_land_is_not_retried_after_a_pilot_switch() -> None:
    rig, began = emergency_in_transport()
    rig.fc.land_failures = 1000

    def tick(r: Rig) -> None:
        rig.on_emergency(r)  # type: ignore[attr-defined]
        if "t" in began and r.clock.now_s() >= began["t"] + 1.5 and r.fc.mode == "GUIDED":
            r.fc.mode = "LOITER"

    rig.run(max_s=120.0, on_tick=tick)
    tries = lands(rig)
    assert len(tries) == 2 and tries[-1] < began["t"] + 1.5
    assert rig.uav.state == "emergency"


def test_a_landing_autopilot_is_left_to_land() -> None:
    rig = Rig("brick")

    def tick(r: Rig) -> None:
        if r.uav.state == "transport" and r.fc.mode == "GUIDED":
            r.fc.mode = "LAND"  # the autopilot's own failsafe (battery) lands it: setpoints are refused

    rig.run(on_tick=tick)
    assert lands(rig) == [] and rig.states[-2:] == ["emergency", "halted"]
    assert "landing" in (rig.uav.halt_reason or "") and rig.fc.telemetry().on_ground


# -- against the SITL as PX4 (AUTO.LAND, OFFBOARD, the pilot's POSCTL) ------------------------------------------


def _px4_emergency(pilot_takes_over: bool) -> tuple[object, object, list[str]]:
    modes: list[str] = []
    with glue_on_px4_sitl() as (sitl, fc, uav, _link):
        clock = fc.clock
        deadline = time.monotonic() + 20.0
        pilot_s: float | None = None
        while time.monotonic() < deadline:
            now = clock.now_s()
            uav.step(now)
            tel = fc.telemetry()
            if not modes or modes[-1] != tel.mode:
                modes.append(tel.mode)
            if uav.state == "cruise":
                uav.lost(reason="sprayer board not answering")
            if uav.state == "emergency" and pilot_takes_over and pilot_s is None and tel.landing:
                sitl.pilot_mode("POSCTL")
                pilot_s = now
            if pilot_s is not None and now > pilot_s + 5.0:
                break  # five autopilot seconds in the pilot's hands
            if uav.state == "halted":
                break
            clock.sleep(0.05)
    return sitl, uav, modes


def test_px4_emergency_lands_once_in_auto_land() -> None:
    sitl, uav, modes = _px4_emergency(pilot_takes_over=False)
    assert uav.state == "halted" and uav.halt_reason == "sprayer board not answering"
    assert sitl.land_requests == 1
    assert "OFFBOARD" in modes and modes[modes.index("OFFBOARD") :].count("AUTO.LAND") == 1
    assert sitl.vehicle.on_ground and not sitl.vehicle.armed


def test_px4_pilot_in_posctl_is_not_fought() -> None:
    sitl, uav, modes = _px4_emergency(pilot_takes_over=True)
    assert sitl.land_requests == 1  # ours; after the pilot's POSCTL, nothing
    assert sitl.mode == "POSCTL" and modes[-1] == "POSCTL"
    assert uav.state == "emergency" and sitl.vehicle.armed and not sitl.vehicle.on_ground


def test_mavlink_telemetry_flags_ardupilot_land_as_landing() -> None:
    from masonry.adapters.mavlink import MavlinkFlightController
    from masonry.adapters.sitl import MavlinkSitl, SitlConfig, free_udp_port

    port = free_udp_port()
    with MavlinkSitl(port, time_scale=10.0, config=SitlConfig(heartbeat_hz=10.0)) as sitl, \
            MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=5.0) as fc:  # fmt: skip
        fc.arm()
        fc.takeoff(1.0)
        wait_until(lambda: fc.telemetry().position_m[2] >= 0.8, 10.0, "the climb to 0.8 m")
        assert fc.telemetry().mode == "GUIDED" and not fc.telemetry().landing
        fc.land()
        wait_until(lambda: fc.telemetry().landing, 10.0, "the landing flag")
        tel = fc.telemetry()
        assert tel.landing and tel.mode == "LAND" and sitl.land_requests == 1
