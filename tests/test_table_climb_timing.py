"""``--airspace table``: the climbs to and descents from a layer timed as the UAVs fly them (issue 27 §4.3, branch
``climb50``). The table times them at ``TaskTiming.vertical_speed_mps`` (0.4 m/s) by default; the UAVs' machines fly
them at ``UavConfig.layer_vertical_speed_mps`` (0.9 m/s): ``TableClearance(layer_climb_mps=...)`` times them at
that speed, and a UAV at the top of its climb, on its transit, is not taken for late in its climb."""

from __future__ import annotations

import pytest

from airspace_rig import table_pair
from masonry.blueprint_gen import running_bond
from masonry.fsm import UavConfig
from masonry.mission.reserved import TableClearance
from masonry.mission.simulate import SimulatedMission
from masonry.timing import MIN_JERK_PEAK_TO_MEAN_SPEED

LAYER_MPS = UavConfig("a", "brick", (0.0, -5.0, 0.0)).layer_vertical_speed_mps


def _machine_leg_s(dz_m: float) -> float:
    """How long the UAV's machine takes for a climb (or descent) of ``dz_m`` to (from) its layer
    (:meth:`masonry.fsm.navigator.Navigator.layer_route`)."""
    return max(0.5, MIN_JERK_PEAK_TO_MEAN_SPEED * abs(dz_m) / LAYER_MPS)


def _flight(air: TableClearance) -> dict[str, list]:
    air.take_off("a")
    assert air.request("a", (6.0, -5.0, 1.2), 0.0, (0.0, -5.0, 1.2)).granted
    out: dict[str, list] = {}
    for r in sorted(air.table.of("a"), key=lambda r: r.t0_s):
        out.setdefault(r.purpose, []).append(r)
    return out


def _timed_at_layer_speed() -> TableClearance:
    homes = {"a": (0.0, -5.0, 0.0), "b": (3.0, -5.0, 0.0)}
    return TableClearance(0.8, 2.0, homes=homes, start_base_m=1.2, layer_climb_mps=LAYER_MPS)


def test_the_default_table_opens_the_transit_after_the_uav_is_on_its_layer():
    """As on main: the UAV is on its layer seconds before its transit's window opens (what the flag changes)."""
    f = _flight(table_pair())
    climb, transit = f["climb"][0], f["transit"][0]
    up_s = _machine_leg_s(transit.volume.z0_m - climb.volume.z0_m)
    assert transit.t0_s - (climb.t0_s + up_s) > 1.0


def test_a_climb_timed_at_the_layer_speed_is_the_machine_s_climb_and_its_transit_opens_when_it_is_up():
    f = _flight(_timed_at_layer_speed())
    climb, transit, descend = f["climb"][0], f["transit"], f["descend"][0]
    layer_m = transit[0].volume.z0_m
    up_s = _machine_leg_s(layer_m - climb.volume.z0_m)
    # the UAV on its layer (its climb flown) is inside its transit's window, and its climb's window covers the climb
    assert min(r.t0_s for r in transit) <= climb.t0_s + up_s + 1e-6
    assert climb.t1_s >= climb.t0_s + up_s
    # the descent: its window opens when the transit is flown, and lasts the machine's descent (+ the margin)
    down_s = _machine_leg_s(layer_m - descend.volume.z0_m)
    assert descend.t1_s - descend.t0_s >= down_s
    assert descend.t1_s - descend.t0_s == pytest.approx(down_s + TableClearance(0.8).margin_s, abs=0.51)


def test_a_uav_at_the_top_of_its_climb_on_its_begun_transit_is_not_taken_for_late():
    """Its climb's window ends within half the margin, but it is on its transit (whose window has begun): not
    extended. Before, the first leg holding its position (the climb's column, up to the layer) was taken for the
    one it flies, and every such UAV's plan was moved by the margin (25 times on the pyramid at seed 1)."""
    air = _timed_at_layer_speed()
    f = _flight(air)
    climb, transit = f["climb"][0], f["transit"][0]
    layer_m = transit.volume.z0_m
    now_s = climb.t1_s - 1.0  # (within half the 3 s margin of the climb's end; the transit begun)
    assert transit.t0_s <= now_s
    air.tick(now_s)
    air.progress("a", (0.0, -5.0, layer_m))  # at the top of its climb: in its climb's column and its transit
    air.grant(now_s)
    assert air.extended == 0
    assert next(r.t0_s for r in air.table.of("a") if r.purpose == "transit") == transit.t0_s


def test_a_table_mission_timed_at_the_layer_speed_keeps_its_uavs_in_their_volumes(monkeypatch):
    """A small running bond, 2 + 1, seed 1: 1.24 m and 5.25 s out of the table's volumes by default (brick-1,
    on its transit before the window opens), 0.11 m and 0.35 s with the climbs timed at the layer speed."""
    monkeypatch.setattr(TableClearance, "__init__", _with_layer_speed(TableClearance.__init__))
    r = SimulatedMission.from_blueprint(
        running_bond(2, 3, brick_uavs=2, adhesion_uavs=1), seed=1, airspace="table"
    ).run()
    assert r.completed and r.envelope_excursion is not None
    assert r.envelope_excursion.m < 0.3 and r.envelope_excursion.s < 1.0
    assert r.conflict_violations == 0 and r.min_separation_m > 1.0


def _with_layer_speed(init):
    def wrapped(self, *args, **kw):
        kw.setdefault("layer_climb_mps", LAYER_MPS)
        init(self, *args, **kw)

    return wrapped
