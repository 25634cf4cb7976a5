"""How closely a UAV's state machine flies its legs and where it stops to ask for a transit (docs/safety.md).

Mission control reserves a UAV's flight from where the request says it is; the separation it guarantees holds
only as far as the UAV stays inside what was reserved. These tests pin the two tracking properties that keep it
there: a leg ends at its end (no overshoot from the autopilot's velocity lag), and a UAV asks for a transit
only once it is at rest where it will start the flight.
"""

from __future__ import annotations

import math

import pytest

from fsm_rig import HOME, Rig

LAYER_M = 2.6


def _rig(config=None, **link_kwargs):
    # the fake autopilot's velocity loop with the simulated vehicle's 0.3 s lag (the default velocity_lag_s)
    rig = Rig(
        "brick",
        fc={"velocity_time_constant_s": 0.3},
        config=config,
        clearance={"layer_m": LAYER_M, **link_kwargs},
    )
    return rig, rig.link


def _climb_overshoot_m(config=None) -> float:
    """How far above the layer the UAV goes on its first climb, before its lateral leg starts."""
    rig, _link = _rig(config)
    highest = 0.0
    left = False
    track = []

    def tick(r):
        nonlocal highest, left
        x, y, z = r.fc.position_m
        track.append(z)
        if math.hypot(x - HOME[0], y - HOME[1]) > 0.3:
            left = True
        if not left:
            highest = max(highest, z)

    rig.run(max_s=60.0, on_tick=tick)
    assert max(track) > LAYER_M - 0.1, "the UAV never climbed to its layer"
    return highest - LAYER_M


def test_a_climb_to_the_layer_ends_at_the_layer():
    assert _climb_overshoot_m() < 0.02


def test_without_the_acceleration_feed_forward_the_climb_overshoots():
    # the velocity loop trails the reference by lag x acceleration; the integral makes it up as an overshoot
    assert _climb_overshoot_m({"velocity_lag_s": 0.0}) > 0.04


@pytest.mark.parametrize("answer_after_s", [0.0, 2.0])
def test_a_uav_asks_for_its_transit_at_rest_where_its_flight_starts(answer_after_s):
    # the takeoff is over 0.1 m short of its altitude, still climbing: the UAV comes to rest at that altitude
    # first, and asks from there
    rig, link = _rig(answer_after_s=answer_after_s)
    at_ask = []
    ask = link.request_clearance

    def spy(site_m, top_m=None, to_m=None):
        if not at_ask:
            tel = rig.fc.telemetry()
            at_ask.append((tel.position_m, tel.velocity_mps))
        return ask(site_m, top_m, to_m)

    link.request_clearance = spy  # the model asks its clearance link, this one
    starts = []
    rig.run(
        max_s=60.0,
        on_tick=lambda r: (
            starts.append(r.fc.position_m) if r.uav.transit.state == "down" and len(starts) < 1 else None
        ),
    )
    ((p, v),) = at_ask
    cruise = rig.config.cruise_altitude_m
    assert abs(p[2] - cruise) < 0.03, p
    assert math.hypot(*v) < rig.config.settle_speed_mps
    assert starts and math.dist(starts[0], p) < 0.03  # the flight starts where it asked from
