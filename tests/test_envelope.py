"""The world's UAVs against the space-time envelope mission control reserved for them (issue 27 §4.3):
``masonry.mission.envelope`` and the report's ``envelope_excursion``."""

from __future__ import annotations

import json
import math

import pytest

from masonry.blueprint_gen import running_bond
from masonry.errors import InvalidArgument
from masonry.mission.envelope import (
    ALLOWANCE_M,
    EnvelopeExcursion,
    EnvelopeWatch,
    TableWindows,
    outside_m,
    worse,
)
from masonry.mission.report_codec import report_from_record, report_to_record
from masonry.mission.simulate import SimulatedMission
from masonry.mission.volumes import Volume
from masonry.reservation import Reservation, Table, column, leg, site

LEG = Volume((0.0, 0.0), (2.0, 0.0), 1.2, 1.2, 0.0, "leg")
ZONE = Volume((3.0, 0.0), (3.0, 0.0), 0.0, 1.2, 0.15, "zone")


@pytest.mark.parametrize(
    "p,expected_m",
    [
        ((1.0, 0.0, 1.2), 0.0),  # on the leg
        ((1.0, 0.3, 1.2), 0.3),  # beside it
        ((1.0, 0.0, 1.0), 0.2),  # under it
        ((1.0, 0.3, 1.6), 0.5),  # both: the hypotenuse
        ((-0.3, 0.0, 1.2), 0.3),  # before its start
        ((3.1, 0.0, 0.5), 0.0),  # in the zone (within its slack)
        ((3.0, 0.35, 1.2), 0.2),  # beside the zone: past its slack
        ((3.0, 0.0, 1.5), 0.3),  # over the zone
    ],
)
def test_outside_m_is_the_distance_to_the_nearest_volume(p, expected_m):
    assert outside_m(p, [LEG, ZONE]) == pytest.approx(expected_m)


def test_outside_m_of_no_volume_is_infinite():
    assert outside_m((0.0, 0.0, 1.0), []) == math.inf


class Reserved:
    """A fake airspace: each UAV's volumes, or nothing."""

    def __init__(self, volumes):
        self.volumes = volumes

    def reserved_at(self, uav, t_s):
        return self.volumes.get(uav, ())


def test_the_watch_keeps_the_greatest_distance_and_the_longest_stretch_out():
    watch = EnvelopeWatch(Reserved({"a": (LEG,), "b": (LEG,)}))
    watch.observe(0.0, [("a", (1.0, 0.05, 1.2)), ("b", (1.0, 0.0, 1.2))])  # a 5 cm off: within the allowance
    watch.observe(1.0, [("a", (1.0, 0.3, 1.2)), ("b", (1.0, 0.0, 1.2))])  # a 30 cm off: out
    watch.observe(2.0, [("a", (1.0, 0.2, 1.2))])  # b landed
    watch.observe(3.5, [("a", (1.0, 0.0, 1.2)), ("b", (1.0, 0.0, 1.0))])  # a back; b 20 cm under its leg
    e = watch.worst(4.0)
    assert (e.m, e.uav, e.at_s) == (pytest.approx(0.3), "a", 1.0)
    assert (e.s, e.s_uav, e.s_from_s) == (2.5, "a", 1.0)  # from the first look out to the first look back
    watch.observe(7.0, [("b", (1.0, 0.0, 1.0))])
    e = watch.worst(9.0)  # b still out: its stretch counts up to now
    assert (e.s, e.s_uav, e.s_from_s) == (5.5, "b", 3.5)
    assert watch.worst().s == 2.5  # (only the stretches that ended)


def test_a_uav_holding_no_volume_is_out_for_the_seconds_without_a_distance():
    watch = EnvelopeWatch(Reserved({}))
    watch.observe(0.0, [("a", (1.0, 0.0, 1.2))])
    watch.observe(2.0, [])  # landed
    e = watch.worst()
    assert e.m == 0.0 and e.at_s is None and (e.s, e.s_uav) == (2.0, "a")


def test_the_watch_looks_at_most_as_often_as_it_is_told():
    watch = EnvelopeWatch(Reserved({"a": (LEG,)}), every_s=0.1)
    for k in range(10):
        watch.observe(k * 0.05, [("a", (1.0, 0.0, 1.2))])
    assert watch.looks == 5
    with pytest.raises(InvalidArgument):
        EnvelopeWatch(Reserved({}), every_s=-1.0)


def test_worse_keeps_the_worse_of_each_figure_and_the_value_reads_back():
    a = EnvelopeExcursion(0.3, "a", 10.0, 1.0, "a", 9.0)
    b = EnvelopeExcursion(0.1, "b", 20.0, 4.0, "b", 18.0)
    assert worse(a, b) == EnvelopeExcursion(0.3, "a", 10.0, 4.0, "b", 18.0)
    assert worse(None, b) is b and worse(a, None) is a and worse(None, None) is None
    assert EnvelopeExcursion.from_dict(a.to_dict()) == a
    with pytest.raises(InvalidArgument):
        EnvelopeExcursion.from_dict({"s": 1.0})


def test_the_table_reserves_a_volume_only_within_its_window_and_never_a_site():
    climb = Reservation("a", column((0.0, 0.0), 0.0, 2.3), 10.0, 20.0, "climb")
    transit = Reservation("a", leg((0.0, 0.0), (3.0, 0.0), 2.3), 15.0, 30.0, "transit")
    rule = Reservation("a", site((3.0, 0.0), 0.6, z_m=1.2), 0.0, math.inf, "site")
    other = Reservation("b", column((9.0, 0.0), 0.0, 2.3), 0.0, math.inf, "stay")
    windows = TableWindows()
    table = Table((climb, transit, rule, other))
    assert [v.kind for v in windows.at(table, "a", 12.0)] == ["climb"]
    assert [v.kind for v in windows.at(table, "a", 15.0)] == ["climb", "transit"]
    assert [v.kind for v in windows.at(table, "a", 20.0)] == ["transit"]  # (windows are [t0_s, t1_s))
    assert windows.at(table, "a", 30.0) == ()
    # a UAV early on its transit: out of its envelope, though it is on a volume of its own
    assert outside_m((2.0, 0.0, 2.3), windows.at(table, "a", 12.0)) == pytest.approx(2.0)
    assert windows.at(Table((climb,)), "a", 17.0)[0].kind == "climb"  # (a new table is read again)
    assert windows.at(Table((climb,)), "a", 17.0) != windows.at(table, "a", 17.0)


# -- the simulated mission's report ------------------------------------------------------------------------


def _mission(**kw):
    return SimulatedMission.from_blueprint(running_bond(2, 3, brick_uavs=2, adhesion_uavs=1), seed=1, **kw)


def test_the_report_carries_the_worst_excursion_small_on_a_normal_mission():
    r = _mission().run()
    assert r.completed and r.envelope_excursion is not None
    e = r.envelope_excursion
    # tracking error only (the default arducopter vehicle; tests/test_airspace.py's OUTSIDE_M: 0.10 m), never out
    # past the allowance
    assert 0.0 < e.m < 0.10 and e.uav and e.at_s is not None
    assert e.s == 0.0 and e.s_from_s is None
    d = json.loads(r.to_json())
    assert d["envelope_excursion"] == e.to_dict()
    assert list(d["envelope_excursion"]) == ["m", "uav", "at_s", "s", "s_uav", "s_from_s"]
    assert "envelope excursion 0.0" in r.summary()
    assert report_from_record(json.loads(json.dumps(report_to_record(r)))).envelope_excursion == e


def test_a_uav_pushed_out_of_its_volumes_shows_a_large_excursion():
    """A forced offset of the true position (a gust the world gives, mission control does not see): half a metre
    sideways for 1.5 s while brick-1 flies. The report names it, measured by the world."""
    mission = _mission()
    world = mission.world
    step = world.step
    pushed: list[float] = []

    def gust_step(dt_s):
        step(dt_s)
        v = world.uavs["brick-1"].vehicle
        now = world.clock.now_s()
        flying = v.armed and not v.on_ground
        if flying and v.position_m[2] > 1.0 and (not pushed or now - pushed[0] < 1.5):
            pushed.append(now)
            v._y = v._y + 0.5 * 0.05 / 1.5  # drifts 0.5 m over 1.5 s

    world.step = gust_step
    r = mission.run()
    e = r.envelope_excursion
    assert e is not None and pushed
    assert e.uav == "brick-1" and e.m > 0.3, e
    assert e.s_uav == "brick-1" and e.s > 0.5, e
    assert e.s_from_s is not None and pushed[0] <= e.s_from_s <= pushed[-1] + 0.1


def test_no_airspace_rules_no_envelope():
    r = _mission(separation=False).run()
    assert r.envelope_excursion is None and json.loads(r.to_json())["envelope_excursion"] is None
    assert ALLOWANCE_M == 0.1


def test_a_resumed_mission_keeps_the_worst_of_the_run_before_the_stop():
    from masonry.mission.measured import MeasuredJournal

    mission = _mission()
    before = EnvelopeExcursion(0.5, "brick-2", 30.0, 2.0, "brick-2", 29.0)
    measured = MeasuredJournal(None, mission.world, mission.plan, {"envelope_excursion": before.to_dict()})
    assert measured.envelope_excursion() == before  # (no watch yet: the journal's alone)
    measured.envelope = mission.envelope
    mission.envelope.observe(40.0, [("brick-1", (50.0, 0.0, 1.2))])  # far from anything it holds
    mission.envelope.observe(43.0, [])
    e = measured.envelope_excursion()
    assert e is not None and (e.uav, e.at_s, e.s_uav, e.s) == ("brick-1", 40.0, "brick-1", 3.0) and e.m > 40.0
    assert measured.measurements()["envelope_excursion"] == e.to_dict()
