"""A UAV that flies on without mission control flies its fixed fallback layer, the one mission control reserves.

Chaos campaign seed 203 (``bench_chaos.py --max-drop 40``, both vehicles): glue-1, flying home, waited at its
hold point on layer 0 (1.2 m) when its radio went for 33 s. Past ``LAST_RESORT_S`` its handler answered itself
"granted, no layer" (nobody to ask), and the machine flew home at the layer its transit already had, the hold
flight's 1.2 m, instead of its fixed ``lateral_altitude_m`` (5.6 m): mission control had reserved its way home at
5.6 m (``ColumnClearance.silent``) and had sent brick-3 to a hold point 0.53 m from the 1.2 m line, which
glue-1 passed at 0.537 m (ideal) and 0.521 m (arducopter).
"""

from __future__ import annotations

import math

import pytest

from fsm_rig import Rig, adhesion_task
from masonry.mission.chaos import check_chaos, fly_chaos, random_chaos

HOLD_M = (2.0, -0.5, 1.2)
FALLBACK_M = 3.4


def test_a_grant_without_a_layer_after_a_hold_flies_the_fixed_fallback_layer() -> None:
    """Held at 1.2 m, then granted with no layer (the handler's answer once mission control has been silent
    for ``LAST_RESORT_S``): the lateral leg from the hold point to the site flies at ``lateral_altitude_m``."""
    rig = Rig(
        "adhesion",
        clearance={"layer_m": 1.2, "hold_m": HOLD_M, "grant_after_s": 15.0},
        config={"lateral_altitude_m": FALLBACK_M},
    )
    site = adhesion_task().start_m
    held: list[float] = []  # altitudes while waiting at the hold point
    lateral: list[float] = []  # altitudes on the way from the hold point to the site, away from both

    def tick(r: Rig) -> None:
        transit, (x, y, z) = r.uav.transit, r.fc.position_m
        if r.link.results:
            return  # (the first transit only)
        if transit.state == "hold":
            r.link.layer_m = None  # from now on the answers carry no layer: nobody to ask
            if math.hypot(x - HOLD_M[0], y - HOLD_M[1]) < 0.05:
                held.append(z)
        elif transit.state == "down":
            from_hold = math.hypot(x - HOLD_M[0], y - HOLD_M[1])
            to_site = math.hypot(x - site[0], y - site[1])
            if from_hold > 0.3 and to_site > 0.3:
                lateral.append(z)

    rig.run(max_s=120.0, on_tick=tick)
    assert [r.status for r in rig.link.results] == ["done"]
    assert held and max(abs(z - 1.2) for z in held) < 0.05, "it waited at the hold flight's layer"
    assert lateral, "no lateral leg seen from the hold point to the site"
    assert min(lateral) > FALLBACK_M - 0.1, (min(lateral), max(lateral))


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
def test_a_uav_cut_off_at_its_hold_point_flies_home_at_the_layer_mission_control_reserved(tmp_path, vehicle):
    """Campaign seed 203 with link drops up to 40 s (the module's docstring): no separation under 1 m now."""
    out = fly_chaos(random_chaos(203, vehicle=vehicle, max_drop_s=40.0), tmp_path)
    assert check_chaos(out) == []
    assert out.min_separation_m is not None and out.min_separation_m >= 1.0
