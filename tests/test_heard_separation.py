"""The least separation of airborne UAVs from their reports as mission control heard them (issue 29: a mission of
real autopilots had none in its report)."""

from __future__ import annotations

import math

import pytest

from masonry.blueprint import UavSpec
from masonry.mission.control import MissionControl
from masonry.mission.heard_separation import HeardSeparation
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL, Heartbeat, encode
from masonry.planner.tasks import BrickTask, Plan


def test_a_report_is_set_against_the_other_uavs_track_at_its_time() -> None:
    # A flies along x at 1 m/s, heard every second; B hovers 1 m off A's line at x = 2.5, heard between A's reports
    heard = HeardSeparation()
    for k in range(6):
        heard.note("A", float(k), (float(k), 0.0, 2.0), airborne=True)
        heard.note("B", k + 0.5, (2.5, 1.0, 2.0), airborne=True)
    # closest when A passes x = 2.5 at t = 2.5, between two of its reports: 1 m, not the 1.118 m of its reports
    assert heard.min_separation_m == pytest.approx(1.0)


def test_each_uavs_reports_count_not_only_the_later_ones() -> None:
    # B is heard first at each instant, then A: A's reports close in on B's, and they are what comes closest
    heard = HeardSeparation()
    for k in range(4):
        heard.note("B", float(k), (0.0, 3.0, 2.0), airborne=True)
        heard.note("A", float(k), (0.0, 0.5 + k * 0.5, 2.0), airborne=True)  # 2.5 m off, then 2, 1.5, 1
    assert heard.min_separation_m == pytest.approx(1.0)


def test_uavs_on_their_pads_and_tracks_with_gaps_are_not_compared() -> None:
    heard = HeardSeparation(max_gap_s=2.0)
    heard.note("A", 0.0, (0.0, 0.0, 0.1), airborne=False)
    heard.note("B", 0.0, (0.5, 0.0, 0.1), airborne=False)
    assert heard.min_separation_m is None  # two landed neighbours are not airborne ones
    heard.note("A", 1.0, (0.0, 0.0, 2.0), airborne=True)
    heard.note(
        "B", 2.0, (0.0, 0.5, 2.0), airborne=True
    )  # A's track ended at 1.0 s: not where it was at 2.0 s
    assert heard.min_separation_m is None
    heard.note("A", 4.0, (4.0, 0.0, 2.0), airborne=True)  # 3 s since its last report: no track to 2.0 s
    assert heard.min_separation_m is None
    heard.note("A", 5.0, (5.0, 0.0, 2.0), airborne=True)
    heard.note("B", 5.0, (5.0, 3.0, 2.0), airborne=True)
    assert heard.min_separation_m == pytest.approx(3.0)
    heard.note("A", 5.5, (5.0, 0.0, 0.1), airborne=False)  # landed: its track ends there
    heard.note("B", 6.0, (5.0, 0.5, 2.0), airborne=True)
    assert heard.min_separation_m == pytest.approx(3.0)


@pytest.mark.parametrize("gap", [0.0, -1.0, math.inf, math.nan])
def test_a_bad_gap_is_refused(gap: float) -> None:
    with pytest.raises(ValueError, match="max_gap_s"):
        HeardSeparation(max_gap_s=gap)


def test_mission_control_measures_it_from_the_uavs_heartbeats() -> None:
    # two brick UAVs heard each second at mission time t: brick-2 crosses 1.5 m in front of brick-1's hover
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    fleet = (UavSpec("brick-1", "brick", (0.0, -3.0, 0.0)), UavSpec("brick-2", "brick", (3.0, -3.0, 0.0)))
    bus = InprocBus()
    mc = MissionControl(plan, fleet, bus.endpoint(MISSION_CONTROL))
    one, two = bus.endpoint("brick-1"), bus.endpoint("brick-2")
    for t in range(6):
        one.send(MISSION_CONTROL, encode(Heartbeat("brick-1", float(t), position_m=(0.0, 0.0, 2.0))))
        two.send(MISSION_CONTROL, encode(Heartbeat("brick-2", float(t), position_m=(t - 2.5, 1.5, 2.0))))
        mc.step(float(t))
    # heard at the same steps, compared there: 1.58 m at 2 and 3 s (its closest, 1.5 m at 2.5 s, between them)
    assert mc.heard_separation.min_separation_m == pytest.approx(math.hypot(0.5, 1.5))
