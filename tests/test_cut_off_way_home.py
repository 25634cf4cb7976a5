"""A UAV cut off on a lateral leg flies on until it notices the silence (3 s) and climbs home from where it stops:
mission control keeps that reserved (issue 27 §4.3; docs/safety.md, "Guarantees and what is not covered";
``masonry.mission.airspace_ground.silent``)."""

from __future__ import annotations

import math
from pathlib import Path

from masonry.blueprint import load_blueprint
from masonry.mission.airspace import ColumnClearance
from masonry.mission.envelope import ALLOWANCE_M, outside_m
from masonry.mission.simulate import SimulatedMission

ROOT = Path(__file__).resolve().parents[1]


def test_a_uav_cut_off_mid_leg_keeps_the_way_home_from_wherever_it_stops_on_its_leg() -> None:
    c = ColumnClearance(1.5, 1.2, homes={"a": (0.0, -6.0, 0.0)})
    assert c.take_off("a")
    site = (6.0, 0.0, 1.2)
    g = c.request("a", site, 0.0, (0.0, -6.0, 1.2))
    assert g.granted and g.layer_m is not None
    layer = g.layer_m
    heard = (1.0, -5.0, layer)  # on its leg towards the site, last heard
    c.progress("a", heard)
    c.silent("a", heard, 3.0)  # its fallback layer: 3 m
    vols = c.volumes("a")
    # where it was heard: climb and way home, as before
    assert outside_m((1.0, -5.0, 2.5), vols) < 1e-9
    # flown on to its leg's end (over its site) or stopped anywhere on the way there, it climbs there to 3 m ...
    for f in (0.3, 0.7, 1.0):
        stop = (heard[0] + f * (site[0] - heard[0]), heard[1] + f * (site[1] - heard[1]))
        for z in (layer, (layer + 3.0) / 2.0, 3.0):
            assert outside_m((*stop, z), vols) < 1e-9, (f, z)
        # ... and flies home at 3 m from there
        for k in (0.25, 0.5, 0.75):
            p = (stop[0] + k * (0.0 - stop[0]), stop[1] + k * (-6.0 - stop[1]), 3.0)
            assert outside_m(p, vols) < 1e-9, (f, k)
    assert math.isfinite(outside_m((20.0, 20.0, 3.0), vols))  # (not everywhere)
    assert outside_m((20.0, 20.0, 3.0), vols) > 10.0


def test_a_brick_uav_cut_off_before_its_site_climbs_home_inside_what_is_reserved() -> None:
    # main: brick-1 cut off 1.15 m before its site (pyramid, seed 1, 227.4 s, 40 s) flew on to it and climbed there
    # to its fallback layer, 1.23 m from the climb reserved where it was last heard, for 6.3 s
    mission = SimulatedMission.from_blueprint(
        load_blueprint(ROOT / "blueprints" / "pyramid.yaml"), seed=1, vehicle="ideal"
    )
    cut: list[float] = []

    def hook(now_s: float) -> None:
        v = mission.world.uavs["brick-1"].vehicle
        if not cut and now_s > 200.0 and math.hypot(v.velocity_mps[0], v.velocity_mps[1]) > 0.8:
            cut.append(now_s)
            mission.bus.cut("brick-1")
        elif len(cut) == 1 and now_s > cut[0] + 40.0:
            cut.append(now_s)
            mission.bus.restore("brick-1")

    mission.tick_hooks.append(hook)
    r = mission.run()
    assert len(cut) == 2 and r.completed
    e = r.envelope_excursion
    assert e is not None and e.m <= ALLOWANCE_M and e.s == 0.0, e
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0
