"""A UAV turned back on the lateral leg of a flight to a site, with no hover free ahead along it, under the table.

docs/safety.md, "A UAV turned back flies on to where it may stay": before branch ``turnback52`` such a UAV (its plan's
stay beyond one hold flight: over the site, then down) waited where it stopped, holding its whole plan (its leg,
its descent, extended while it was late) while its new flight waited: a UAV holding volumes while it waited for
another. It now flies its plan on in two hold flights, over the site at its layer, then down into the stay it was
granted, and waits there holding that stay only.
"""

from __future__ import annotations

import dataclasses
import math

from fsm_rig import Rig
from masonry.mission.airspace import Phase
from masonry.mission.reserved import TableClearance

SITE_B = (-3.0, 0.4, 1.2)  # b works under g's way at 1.2 m: g flies at 2.3 m
SITE_E = (-0.2, 1.3, 1.2)  # e works up to 1.3 m, 1.3 m beside g's leg and 1.32 m beside g's site
SITE_G = (0.0, 0.0, 1.2)
NEXT_G = (-3.0, 1.0, 1.2)  # 0.6 m beside b's site: g's flight there waits for b


def _g_on_its_leg() -> TableClearance:
    """b and e at their sites; g, granted its flight to its site at 2.3 m, flown to 0.4 m short of it."""
    homes = {"g": (-6.0, 0.0, 0.0), "b": (-3.0, -6.0, 0.0), "e": (-0.2, 7.0, 0.0)}
    air = TableClearance(0.5, 2.0, homes=homes, start_base_m=1.2, max_layers=2)
    for uav, site, start, top in (
        ("b", SITE_B, (-3.0, -6.0, 1.2), None),
        ("e", SITE_E, (-0.2, 7.0, 1.2), 1.3),
    ):
        air.take_off(uav)
        assert air.request(uav, site, 0.0, start, top).granted
        air.progress(uav, site)
        air.end_transit(uav)
    air.take_off("g")
    g = air.request("g", SITE_G, 1.0, (-6.0, 0.0, 1.2))
    assert g.granted and g.layer_m == 2.3
    for t in range(2, 17):  # it climbs, then flies its leg at 2.3 m, on time
        p = (-6.0, 0.0, min(2.3, 1.2 + (t - 1) * 0.22)) if t <= 6 else (-6.0 + (t - 6.2) * 0.55, 0.0, 2.3)
        air.progress("g", p)
        air.grant(float(t))
    return air


def test_a_uav_turned_back_on_its_leg_to_a_site_with_no_hover_ahead_flies_on_down_into_its_stay_under_the_table():
    air = _g_on_its_leg()
    stopped = (-0.4, 0.0, 2.3)
    air.progress("g", stopped)
    turned = air.request("g", NEXT_G, 17.0, stopped)  # handed a task next to b's site: it waits for b
    assert not turned.granted and air.blockers("g") == [("b", "stay")]
    # no hover fits where it stopped nor over its site at 2.3 m: each is 1.0 m over e's stay, within 1.5 m of it
    # (was: no hold flight, it waited where it stopped holding its leg, its descent and its stay)
    assert turned.hold_m == (0.0, 0.0, 2.3) and turned.layer_m == 2.3  # on along its leg, over its site
    assert air.phase("g") is Phase.TO_HOLD and air.conflicts() == []
    air.progress("g", (0.0, 0.05, 2.3))
    air.grant(20.0)
    down = air.request("g", NEXT_G, 21.0, (0.0, 0.05, 2.3))
    assert down.hold_m == (0.0, 0.0, 1.2) and down.layer_m == 1.2  # then down its own descent into its stay
    assert [v.kind for v in air.volumes("g")] == ["descend", "stay"]
    air.progress("g", (0.0, 0.05, 1.25))
    air.grant(25.0)
    assert air.phase("g") is Phase.AT_HOLD and [v.kind for v in air.volumes("g")] == ["stay"]
    assert air.conflicts() == []
    # it holds its stay only, as a UAV told to wait does; its new flight is planned from there
    again = air.request("g", NEXT_G, 26.0, (0.0, 0.05, 1.25))
    assert not again.granted and air.blockers("g") == [("b", "stay"), ("e", "stay")]
    # b's next flight waits for stays only (g's and e's), which the parking rule reads
    assert not air.request("b", (3.0, 0.4, 1.2), 27.0, SITE_B).granted
    assert air.blockers("b") == [("e", "stay"), ("g", "stay")]


def test_a_uav_told_to_hold_straight_under_where_it_holds_at_that_altitude_flies_down_to_it():
    # the UAV's side of the second hold flight: a hold point at its layer, straight under the UAV holding over it
    # (was: not flown; a UAV answered a hold point less than 5 cm beside it waited where it was)
    over, under = (1.0, -1.0, 2.6), (1.0, -1.0, 1.8)
    rig = Rig("brick", clearance={"layer_m": 2.6, "grant_after_s": 40.0, "hold_m": over})
    link, ask = rig.link, rig.link.request_clearance
    first: list[float] = []

    def answer(site_m, top_m=None, to_m=None):
        a = ask(site_m, top_m, to_m)
        if not first:
            first.append(rig.clock.now_s())
        if a is None or a.granted or rig.clock.now_s() < first[0] + 20.0:
            return a
        return dataclasses.replace(a, hold_m=under, layer_m=under[2])

    link.request_clearance = answer
    track = []
    rig.run(max_s=400.0, on_tick=lambda r: track.append((r.clock.now_s(), *r.fc.position_m)))
    assert [x.status for x in link.results] == ["done"]
    t0 = first[0]
    held = [p for p in track if t0 + 12.0 <= p[0] < t0 + 19.0]
    assert held and all(math.hypot(p[1] - 1.0, p[2] + 1.0) < 0.15 and abs(p[3] - 2.6) < 0.1 for p in held)
    down = [p for p in track if t0 + 32.0 <= p[0] < t0 + 39.0]
    assert down and all(math.hypot(p[1] - 1.0, p[2] + 1.0) < 0.15 and abs(p[3] - 1.8) < 0.1 for p in down)
