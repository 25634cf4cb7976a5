"""The progress watchdog (masonry.mission.stall): a mission that stops moving stops, not completed, and says who
waits for whom; one that makes progress is never stopped."""

from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.mission.control import MissionControl
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL, ClearanceRequest, Heartbeat, MissionEnd, decode, encode
from masonry.mission.stall import StallWatch
from masonry.planner.tasks import BrickTask, Plan
from test_mission_control import fleet_of, random_plan, run_mission


def test_the_watch_fires_only_after_the_timeout_without_change():
    w = StallWatch(10.0)
    assert not w.observe(0.0, (0, "a"))
    assert not w.observe(9.9, (0, "a"))
    assert not w.observe(10.5, (1, "a"))  # progress: the clock starts again
    assert not w.observe(20.0, (1, "a"))
    assert w.observe(20.5, (1, "a")) and w.since_s == 10.5
    assert not StallWatch(0).observe(1e9, 1) and not StallWatch(None).observe(1e9, 1)
    with pytest.raises(ValueError, match="stall timeout"):
        StallWatch(-1.0)


def _two_brick_plan() -> Plan:
    return Plan(
        (
            BrickTask("B0", 0, False, (0.0, 0.0, 0.15), 0.0, (0.0, -3.0, 0.05)),
            BrickTask("B1", 1, False, (6.0, 0.0, 0.15), 0.0, (6.0, -3.0, 0.05)),
        ),
        (),
        (),
    )


def test_a_fleet_waiting_for_a_uav_that_hangs_at_its_site_stops_with_the_wait_for_graph():
    fleet = (UavSpec("a", "brick", (0.0, -6.0, 0.0)), UavSpec("b", "brick", (3.0, -6.0, 0.0)))
    bus = InprocBus()
    mc = MissionControl(
        _two_brick_plan(), fleet, bus.endpoint(MISSION_CONTROL), layer_base_m=1.35, stall_timeout_s=60.0
    )
    a, b = bus.endpoint("a"), bus.endpoint("b")
    site = (0.0, -3.0, 0.05)
    ends = []
    t = 0.0
    while mc.ended_at_s is None and t < 400.0:
        for ep, name, state, pos in (
            (a, "a", "pickup_estimate", site),
            (b, "b", "pickup_goto", (3.0, -6.0, 1.35)),
        ):
            ep.send(MISSION_CONTROL, encode(Heartbeat(name, t, state, None, pos)))
            ends += [m for m in map(decode, ep.receive()) if isinstance(m, MissionEnd)]
        if t == 2.0:  # a flies to its pickup and stays there for ever (it hangs, still heartbeating)
            a.send(MISSION_CONTROL, encode(ClearanceRequest("a", site, t, (0.0, -6.0, 1.35))))
        if t == 3.0:
            a.send(MISSION_CONTROL, encode(ClearanceRequest("a", site, t, arrived=True)))
        if (
            t >= 4.0 and t % 1.0 == 0.0
        ):  # b wants a pickup 0.5 m from a's (it asks again and again, as UAVs do)
            b.send(MISSION_CONTROL, encode(ClearanceRequest("b", (0.5, -3.0, 0.05), t, (3.0, -6.0, 1.35))))
        mc.step(t)
        t = round(t + 0.5, 3)
    assert mc.stall is not None and not mc.finished
    assert 60.0 <= mc.stall.at_s - mc.stall.since_s < 61.0
    assert mc.stall.at_s < 80.0  # the last progress was b's hold flight, at 4 s
    waits = {w.uav: w for w in mc.stall.waits}
    assert waits["b"].asked_for_m == (0.5, -3.0, 0.05)
    assert [(x.uav, x.holds) for x in waits["b"].blocked_by] == [("a", "zone")]
    assert waits["a"].blocked_by == () and waits["a"].state == "pickup_estimate"
    d = mc.stall.to_dict()
    assert d["waits"][1]["blocked_by"] == [{"uav": "a", "holds": "zone"}]
    assert "; b [B1 pickup_goto, to-hold] waits for a (zone)" in mc.stall.line(), mc.stall.line()
    t += 0.5
    for ep in (a, b):
        ends += [m for m in map(decode, ep.receive()) if isinstance(m, MissionEnd)]
    assert ends and not ends[0].completed  # the UAVs are told the mission ended, not completed


@settings(max_examples=25, deadline=None)
@given(
    st.integers(1, 25),
    st.integers(1, 3),
    st.integers(1, 3),
    st.integers(0, 10**6),
    st.floats(0.0, 0.3),
)
def test_the_watchdog_never_stops_a_mission_that_makes_progress(n, nb, na, seed, fail_p):
    # every scripted task takes 2-20 s: with a 25 s watchdog, something changes within every window
    plan = random_plan(random.Random(seed), n)
    mc, _handlers, _intervals = run_mission(
        plan, fleet_of(nb, na), seed=seed, fail_p=fail_p, stall_timeout_s=25.0
    )
    assert mc.stall is None
    assert mc.over and mc.ended_at_s is not None
