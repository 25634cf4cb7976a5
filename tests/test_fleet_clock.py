"""Mission time that follows the UAVs' own clocks (masonry.mission.fleet_clock, issue 29), on a held wall clock.

A SITL asked for x5 that a loaded machine runs at x3.5 must slow the mission equally; with no UAV heard, or on
a real vehicle (its autopilot's clock is the wall's), mission time is ``time_scale`` of the wall.
"""

from __future__ import annotations

import pytest

from masonry.blueprint import UavSpec
from masonry.errors import InputError
from masonry.mission.control import MissionControl
from masonry.mission.fleet_clock import HOLD_HEARTBEATS, LEAD_S, MAX_HOLD_WALL_S, FleetClock
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL, Heartbeat, Progress, encode
from masonry.planner.tasks import BrickTask, Plan


class Wall:
    """A wall clock the test moves."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_with_no_uav_heard_mission_time_runs_at_the_time_scale() -> None:
    wall = Wall()
    clock = FleetClock(5.0, start_s=12.0, monotonic=wall)
    assert clock.now_s() == 12.0
    wall.t += 2.0
    assert clock.now_s() == pytest.approx(22.0)


def fly(clock: FleetClock, wall: Wall, rates: dict[str, float], wall_s: float, period_s: float = 1.0) -> None:
    """Each UAV's clock runs at its rate (its seconds per wall second) and beats every ``period_s`` of its own."""
    own = dict.fromkeys(rates, 0.0)
    beat = dict.fromkeys(rates, 0.0)
    step = 0.01
    for _ in range(round(wall_s / step)):
        wall.t += step
        for name, rate in rates.items():
            own[name] += rate * step
            if own[name] >= beat[name]:
                clock.heard(name, own[name])
                beat[name] += period_s
        clock.now_s()


def look(clock: FleetClock, wall: Wall, wall_s: float) -> None:
    """``wall_s`` of wall with nothing heard, mission control reading its clock every tick (50 ms)."""
    for _ in range(round(wall_s / 0.05)):
        wall.t += 0.05
        clock.now_s()


def test_a_sitl_slowed_by_the_load_slows_the_mission_equally() -> None:
    wall = Wall()
    clock = FleetClock(5.0, monotonic=wall)
    fly(clock, wall, {"brick-1": 3.5}, 60.0)  # asked for x5, the machine gives it x3.5 (measured)
    assert clock.now_s() == pytest.approx(3.5 * 60.0, abs=LEAD_S + 0.1)  # not 300 s: the UAV's 210 s


def test_the_slowest_live_uav_sets_the_pace() -> None:
    wall = Wall()
    clock = FleetClock(5.0, monotonic=wall)
    fly(clock, wall, {"brick-1": 5.0, "glue-1": 2.0}, 30.0)
    assert clock.now_s() == pytest.approx(60.0, abs=LEAD_S + 0.1)


def test_a_lock_step_sitl_slower_than_the_wall_holds_the_mission_between_its_heartbeats() -> None:
    """A SITL in lock-step goes as fast as its loaded client: say x0.8 where x4 was asked, a heartbeat every 1.25 s of
    wall, longer than ``hold_wall_s`` (1 s). It holds the clock for three of its own heartbeats at its measured
    rate, so the mission keeps its pace; it used to drop out between heartbeats and be anchored anew ahead of
    itself each time, the mission at the adhesion UAV's x4 (240 s here)."""
    wall = Wall()
    clock = FleetClock(4.0, monotonic=wall)
    fly(clock, wall, {"brick-1": 0.8, "glue-1": 4.0}, 60.0)
    # its lead, and its first interval not known yet (its first silence let the mission on at the glue's x4)
    assert clock.now_s() == pytest.approx(0.8 * 60.0, abs=5.0)
    before = clock.now_s()
    look(clock, wall, HOLD_HEARTBEATS * 1.25 - 0.1)  # silent: still holding, three heartbeats at its rate
    assert clock.now_s() == pytest.approx(before, abs=LEAD_S)
    look(clock, wall, 1.0)  # gone: the clock runs on at the time scale, so its heartbeat timeout fires
    assert clock.now_s() == pytest.approx(before + 4.0 * 0.9, abs=LEAD_S)
    slow = FleetClock(4.0, monotonic=wall)
    fly(slow, wall, {"brick-1": 0.05}, 60.0)  # 20 s of wall a heartbeat: held at most MAX_HOLD_WALL_S
    assert slow.now_s() > 0.05 * 60.0 + 4.0 * (20.0 - MAX_HOLD_WALL_S) - LEAD_S


def test_mission_control_left_unrun_does_not_count_the_uavs_silent() -> None:
    """Mission control's process left unrun for 3 s by a loaded machine: the UAVs' heartbeats of that while wait
    in its queue. Counted as their silence, mission time jumped 12 s at x4 and anchored them anew ahead of their
    clocks; now it goes on with them."""
    wall = Wall()
    clock = FleetClock(4.0, monotonic=wall)
    fly(clock, wall, {"brick-1": 4.0}, 10.0)
    before = clock.now_s()
    wall.t += 3.0  # not run: nothing read
    for own_s in (41.0, 42.0, 43.0):  # its heartbeats of that while (the last at 40.0 s), read at once
        clock.heard("brick-1", own_s)
    assert clock.now_s() == pytest.approx(before + 3.0, abs=LEAD_S)
    silent = FleetClock(4.0, monotonic=wall, unlooked_s=0.5)
    silent.heard("brick-1", 0.0)
    wall.t += 3.0  # unrun too, then looking on: its silence counts from there
    look(silent, wall, 1.5)
    assert silent.now_s() == pytest.approx(LEAD_S + 4.0 * (1.5 - 1.0 + 0.5), abs=0.25)


def test_on_a_real_vehicle_mission_time_is_the_wall_clock() -> None:
    wall = Wall()
    clock = FleetClock(1.0, monotonic=wall)
    fly(clock, wall, {"brick-1": 1.0, "glue-1": 1.0}, 120.0)
    assert clock.now_s() == pytest.approx(120.0, abs=0.05)


def test_a_silent_uav_stops_holding_the_clock_and_is_anchored_anew_when_heard_again() -> None:
    wall = Wall()
    clock = FleetClock(5.0, monotonic=wall)
    clock.heard("brick-1", 40.0)
    look(clock, wall, clock.hold_wall_s)  # still holding: extrapolated no further than its lead
    assert clock.now_s() == pytest.approx(LEAD_S)
    look(
        clock, wall, 4.0
    )  # silent past the hold: the heartbeat timeout must still come, so mission time runs on
    assert clock.now_s() == pytest.approx(LEAD_S + 20.0)
    before = clock.now_s()
    clock.heard("brick-1", 41.0)  # back: its own clock is its own business, mission time goes on from here
    assert clock.now_s() == pytest.approx(before)
    wall.t += 0.1
    clock.heard("brick-1", 41.5)
    assert clock.now_s() == pytest.approx(before + 0.5)


def test_mission_time_never_runs_backwards_and_a_rebooted_autopilot_is_anchored_anew() -> None:
    wall = Wall()
    clock = FleetClock(5.0, monotonic=wall)
    clock.heard("brick-1", 100.0)
    wall.t += 0.2
    clock.heard("brick-1", 101.0)
    t = clock.now_s()
    assert t == pytest.approx(1.0)
    wall.t += 0.2
    clock.heard("brick-1", 3.0)  # its autopilot rebooted: its clock starts again
    rebooted = clock.now_s()
    assert rebooted >= t
    wall.t += 0.2
    clock.heard("brick-1", 4.0)
    assert clock.now_s() == pytest.approx(rebooted + 1.0)


def test_a_bad_time_scale_is_one_clear_error() -> None:
    with pytest.raises(InputError, match="time_scale must be > 0"):
        FleetClock(0.0)


def test_mission_control_hands_each_uav_heartbeat_to_its_clock() -> None:
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    bus = InprocBus()
    fleet = [UavSpec("brick-1", "brick", (0.0, 0.0, 0.0))]
    mc = MissionControl(plan, fleet, bus.endpoint(MISSION_CONTROL))
    heard: list[tuple[str, float]] = []
    mc.heard_clock = lambda uav, t: heard.append((uav, t))
    uav = bus.endpoint("brick-1")
    uav.send(MISSION_CONTROL, encode(Heartbeat("brick-1", 7.5)))
    uav.send(MISSION_CONTROL, encode(Progress("brick-1", "B0", "working", 8.0)))  # only heartbeats pace it
    mc.step(0.0)
    assert heard == [("brick-1", 7.5)]
