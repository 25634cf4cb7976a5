"""The autopilot takes the vehicle (issue 29): a failsafe switches it out of the mode masonry flies in.

PX4 leaves OFFBOARD for AUTO.RTL, AUTO.LAND or AUTO.LOITER when one of its failsafes fires, and ``masonry fly``
then never returned: its setpoints went unheard and the machine waited in its task. The machine now sees the
mode it flies in (the autopilot's at the end of the take-off) change without its asking, for longer than a
heartbeat period, stops flying (no setpoint, no LAND of its own), fails the task with one line naming the UAV and
the mode, and halts. On the scripted fake (simulated time) and on the project's SITL as PX4 over MAVLink.
"""

from __future__ import annotations

import time

from fsm_rig import Rig, glue_on_px4_sitl
from masonry.fsm.watchdogs import MODE_TAKEN_S, autopilot_mode_watch, for_kind

TAKEN = "brick-1: the autopilot took control: mode RTL, not requested (masonry flies in GUIDED)"


def _switch_in_transport(rig: Rig, mode: str, back_after_s: float | None = None) -> dict[str, float]:
    """Script the fake autopilot to switch to ``mode`` once the brick UAV is in transport (and back to GUIDED
    ``back_after_s`` later, if given); the times it did, in ``seen``."""
    seen: dict[str, float] = {}

    def tick(r: Rig) -> None:
        now = r.clock.now_s()
        if r.uav.state == "transport" and "switch" not in seen:
            seen["switch"] = now
            seen["velocity"] = r.fc.velocity_commands
            r.fc.mode = mode
            if back_after_s is not None:
                r.fc.at(now + back_after_s, mode="GUIDED")

    rig.on_tick = tick  # type: ignore[attr-defined]
    return seen


def test_a_failsafes_rtl_fails_the_task_and_halts_without_a_land_of_ours() -> None:
    rig = Rig("brick")
    seen = _switch_in_transport(rig, "RTL")
    rig.run(on_tick=rig.on_tick)  # type: ignore[attr-defined]
    switch_s = seen["switch"]
    assert rig.states[-2:] == ["emergency", "halted"], rig.states
    assert rig.uav.halt_reason == TAKEN
    assert [r.status for r in rig.link.results] == ["failed"] and rig.link.results[0].reason == TAKEN
    # ended as soon as the switch outlasted a heartbeat period: no hang, no LAND, no setpoint after that
    halted_s = next(t for t, s in rig.uav.trace if s == "halted")
    assert switch_s + MODE_TAKEN_S <= halted_s <= switch_s + MODE_TAKEN_S + 0.5  # two control ticks
    assert [c for t, c, _ in rig.fc.commands if t >= switch_s] == []
    assert rig.fc.velocity_commands <= seen["velocity"] + int(MODE_TAKEN_S / 0.05) + 2
    assert rig.uav.finished


def test_a_failsafe_during_the_take_off_is_named_against_masonrys_mode_not_taken_for_it() -> None:
    """The autopilot switches to AUTO.LOITER in the climb (a real PX4 on a loaded CI machine did): once the
    take-off is over that is a take-over, named against the mode masonry armed in (GUIDED here), not its own."""
    rig = Rig("brick")
    switched: dict[str, float] = {}

    def tick(r: Rig) -> None:
        if r.uav.state == "takeoff" and r.fc.armed and "at" not in switched:
            switched["at"] = r.clock.now_s()
            r.fc.at(switched["at"] + 0.5, mode="AUTO.LOITER")

    rig.run(on_tick=tick)
    assert "at" in switched
    assert [r.status for r in rig.link.results] == ["failed"], rig.link.results
    assert rig.uav.halt_reason is not None and rig.uav.halt_reason.endswith(
        "mode AUTO.LOITER, not requested (masonry flies in GUIDED)"
    ), rig.uav.halt_reason


def test_a_mode_heard_for_less_than_a_heartbeat_period_is_no_take_over() -> None:
    rig = Rig("brick")
    seen = _switch_in_transport(rig, "RTL", back_after_s=1.0)  # a stale HEARTBEAT's mode, then ours again
    rig.run(on_tick=rig.on_tick)  # type: ignore[attr-defined]
    assert "switch" in seen
    assert [r.status for r in rig.link.results] == ["done"], rig.link.results
    assert "emergency" not in rig.states and rig.states[-1] == "idle"


def test_the_land_masonry_asks_for_and_its_own_emergency_are_not_take_overs() -> None:
    rig = Rig("brick")
    rig.run()
    assert [r.status for r in rig.link.results] == ["done"] and "land" in rig.states  # LAND asked for: ours
    rig = Rig("brick")
    began: dict[str, float] = {}

    def fail(r: Rig) -> None:
        if r.uav.state == "transport" and "t" not in began:
            began["t"] = r.clock.now_s()
            r.uav.lost(reason="actuator board not answering")

    rig.run(on_tick=fail)
    # the emergency's own LAND (a mode masonry asked for) is flown to the ground, not given up
    assert rig.states[-2:] == ["emergency", "halted"] and rig.fc.telemetry().on_ground
    assert rig.uav.halt_reason == "actuator board not answering"
    assert len([c for _, c, _ in rig.fc.commands if c == "land"]) == 1


def test_the_watchdog_is_declared_for_both_machines() -> None:
    for kind in ("brick", "adhesion"):
        dogs = {d.name: d for d in for_kind(kind)}
        assert dogs["autopilot"].check is autopilot_mode_watch
        assert dogs["autopilot"].guards("emergency") and dogs["autopilot"].guards("home")
        assert not dogs["autopilot"].guards("land") and not dogs["autopilot"].guards("idle")


def test_px4s_failsafe_hold_over_mavlink_ends_the_flight() -> None:
    """The project's SITL as PX4 (real MAVLink, x10 time): its failsafe takes the vehicle to AUTO.LOITER in
    cruise; the machine halts with the mode named, having commanded no LAND."""
    with glue_on_px4_sitl() as (sitl, fc, uav, link):
        clock = fc.clock
        switched = False
        deadline = time.monotonic() + 30.0  # wall seconds: a bound on the loop, not a timed assertion
        while time.monotonic() < deadline and uav.state != "halted":
            uav.step(clock.now_s())
            # a second into the cruise (the take-off's climb done: its LAND-on-close is another matter)
            if uav.state == "cruise" and clock.now_s() > uav.entered_s + 1.0 and not switched:
                sitl.pilot_mode("AUTO.LOITER")  # as PX4's offboard-loss failsafe does
                switched = True
            clock.sleep(0.05)
    assert switched and uav.state == "halted", uav.trace
    assert uav.halt_reason is not None and uav.halt_reason.startswith(
        "glue-1: the autopilot took control: mode AUTO.LOITER, not requested (masonry flies in OFFBOARD)"
    )
    assert sitl.land_requests == 0 and sitl.mode == "AUTO.LOITER"
    assert [r.status for r in link.results] == ["failed"]


def _climb_then(switch_to: str | None) -> int:
    """PX4 (the project's SITL, real MAVLink) climbing in OFFBOARD; the pilot switches to ``switch_to`` mid-climb
    (None: nobody does); the adapter closed there. The LAND requests the autopilot heard."""
    with glue_on_px4_sitl() as (sitl, fc, _uav, _link):
        fc.arm()
        fc.takeoff(1.5)
        deadline = time.monotonic() + 20.0  # wall seconds: a bound on the loop, not a timed assertion
        while time.monotonic() < deadline and fc.telemetry().position_m[2] < 0.4:
            fc.clock.sleep(0.05)
        assert fc.telemetry().position_m[2] >= 0.4, "the climb never started"
        if switch_to is not None:
            sitl.pilot_mode(switch_to)
            while time.monotonic() < deadline and fc.telemetry().mode != switch_to:
                fc.clock.sleep(0.05)
            assert fc.telemetry().mode == switch_to
    return sitl.land_requests


def test_closing_mid_climb_lands_ours_and_leaves_the_pilots_mode_alone() -> None:
    """The CI failure of stop 45: under load the failsafe's switch came while the adapter still counted the climb
    as its own (the take-off target set), and closing it commanded LAND over the pilot's AUTO.LOITER."""
    assert _climb_then(None) == 1  # still climbing in OFFBOARD, ours: closing lands it
    assert _climb_then("AUTO.LOITER") == 0  # the pilot's mode mid-climb is the pilot's
