"""A UAV with no task waits near the wall for one due soon instead of flying home (masonry.mission.linger)."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.mission.airspace import ColumnClearance, Phase, Volume
from masonry.mission.airspace_state import FlightRequest, UavAirspace, hold_candidates
from masonry.mission.linger import held_up_by, round_trip_s
from masonry.mission.sim_options import SimOptions
from masonry.mission.simulate import SimulatedMission
from masonry.mission.volumes import point_segment_m

ROOT = Path(__file__).resolve().parents[1]
R, BASE, S = 1.5, 1.35, 1.1
HOMES = {"g": (0.0, -6.0, 0.0), "b": (2.0, -6.0, 0.0)}
#: the pyramid blueprint's adhesion UAV's pad (blueprints/pyramid.yaml)
HOMES_PYRAMID_GLUE = (2.0, -5.975)
#: the sites still to be worked, along the wall at y = 0 (as zero-length spans)
WALL = tuple(((x / 10.0, 0.0), (x / 10.0, 0.0)) for x in range(-12, 13, 3))


def _at_site(c: ColumnClearance, uav: str, site: tuple[float, float, float]) -> None:
    assert c.take_off(uav)
    assert c.request(uav, site, 0.0, (HOMES[uav][0], HOMES[uav][1], BASE)).granted
    c.end_transit(uav)


def test_a_lingering_uav_waits_near_where_it_is_clear_of_the_wall_then_flies_home_once_let_go():
    c = ColumnClearance(R, BASE, S, homes=HOMES)
    _at_site(c, "g", (0.0, 0.0, 1.2))
    c.lingering["g"] = WALL
    g = c.request("g", HOMES["g"], 10.0, (0.0, 0.0, BASE))
    assert not g.granted and g.hold_m is not None and g.layer_m is not None
    spot = (g.hold_m[0], g.hold_m[1])
    # nearer the wall than its home, and clear of every site still to be worked (and of the pads)
    assert math.dist(spot, (0.0, 0.0)) <= math.dist((0.0, 0.0), HOMES["g"][:2]) / 2.0 + 1e-9
    assert min(math.dist(spot, w) for w, _w in WALL) >= 1.1 * c.wait_radius_m - 1e-9
    assert min(math.dist(spot, h[:2]) for h in HOMES.values()) >= 1.1 * c.wait_radius_m - 1e-9
    c.progress("g", (g.hold_m[0], g.hold_m[1], g.layer_m))
    assert c.phase("g") is Phase.AT_HOLD
    assert c.grant(11.0) == []  # held there while it lingers
    assert "g" not in [u for u, _k in c.blockers("b")]
    del c.lingering["g"]
    c.touch()
    (home,) = c.grant(12.0)
    assert home.uav == "g" and home.granted
    assert c.conflicts() == []


def test_a_lingering_uav_with_no_spot_near_it_flies_home_as_it_asked():
    c = ColumnClearance(R, BASE, S, homes=HOMES)
    _at_site(c, "g", (0.0, 0.0, 1.2))
    # every point within reach is a site still to be worked: no hold point near it fits
    c.lingering["g"] = tuple(
        ((x * 0.5, y * 0.5), (x * 0.5, y * 0.5)) for x in range(-40, 41) for y in range(-40, 41)
    )
    g = c.request("g", HOMES["g"], 10.0, (0.0, 0.0, BASE))
    assert "g" not in c.lingering
    assert g.hold_m is None


def test_the_round_trip_counts_both_legs_and_both_vertical_moves():
    near = round_trip_s((0.0, -1.0, 1.35), (0.0, -2.0, 0.0))
    far = round_trip_s((0.0, 0.0, 1.35), (0.0, -6.0, 0.0))
    assert 0.0 < near < far
    assert far == pytest.approx(round_trip_s((6.0, -6.0, 1.35), (0.0, -6.0, 0.0)))


def _pyramid(linger: bool, max_time_s: float):
    options = SimOptions(brick_uavs=1, adhesion_uavs=1, seed=1, max_time_s=max_time_s)
    mission = SimulatedMission.from_blueprint(load_blueprint(ROOT / "blueprints" / "pyramid.yaml"), options)
    mission.control.lingers.enabled = linger
    return mission.run()


def _take_offs(report, uav: str) -> int:
    return sum(1 for a in report.attempts if a.uav == uav and a.phases is not None and a.phases.takeoff > 0.0)


def test_on_the_pyramid_the_adhesion_uav_waits_near_the_wall_instead_of_flying_home_each_time():
    """The bundled pyramid at 1 + 1 (the default configuration: columns airspace, site rule, critical path):
    each bead is released by the brick under it, so the adhesion UAV had no task between beads and flew home,
    landed and took off again, every time on the critical path."""
    before = _pyramid(False, 600.0)
    after = _pyramid(True, 600.0)
    assert _take_offs(before, "glue-1") >= 6
    assert _take_offs(after, "glue-1") <= 2
    glue = {u.name: u for u in after.uavs}["glue-1"]
    assert glue.lingers >= 4 and glue.lingering_s > 0.0
    assert {u.name: u for u in before.uavs}["glue-1"].lingers == 0
    assert len([a for a in after.attempts if a.status == "done"]) > len(
        [a for a in before.attempts if a.status == "done"]
    )
    for report in (before, after):
        assert report.min_separation_m is not None and report.min_separation_m >= 1.0
        assert report.conflict_violations == 0 and report.dependency_violations == 0


def test_a_lingering_uav_does_not_give_way_on_its_hold_flight_out_of_the_site_it_worked(caplog):
    """Issue 27: the give-way was asked on the hold flight too, which climbs out of the site the UAV has just
    worked; the brick UAV waiting for that site always found it in the way, so nearly every wait ended the
    moment it began (the pyramid at 1 + 1: 17 of 20) and the sprayer flew home and back on the critical path.
    It gives way once it hovers at its spot (its flight home would have been in the way just as much)."""
    with caplog.at_level(logging.INFO, logger="masonry.mission.control"):
        report = _pyramid(True, 600.0)
    started: dict[str, list[str]] = {}
    ended_at_once = 0
    for rec in caplog.records:
        msg = rec.getMessage()
        if msg.startswith("glue-1 waits near the wall"):
            started.setdefault("glue-1", []).append(msg.rsplit(" at ", 1)[1])
        elif msg.startswith("glue-1 stops waiting near the wall") and "in another UAV's way" in msg:
            at = msg.split(" at ", 1)[1].split(" (", 1)[0]
            ended_at_once += at in started.get("glue-1", [])
    glue = {u.name: u for u in report.uavs}["glue-1"]
    assert glue.lingers >= 4
    assert ended_at_once == 0
    # it waits there (was 13.6 s over 6 waits in these 600 s; 187.6 s over 10 with the change)
    assert glue.lingering_s >= 10.0 * glue.lingers
    assert report.min_separation_m is not None and report.min_separation_m >= 1.0
    assert report.conflict_violations == 0 and report.dependency_violations == 0


def test_hold_points_keep_clear_of_a_waiting_sprayers_whole_segment_where_it_climbs_out():
    """bench_layouts --compact seed 5: a hold point 1.2 m from the far end of an earlier sprayer's segment (it
    climbs out there) blocked that climb while the one holding waited for the same spot."""
    seg = FlightRequest((0.0, 0.0, 1.2), 1.2, None, 0.0, 1, to=(1.5, 0.0))
    sprayer = UavAirspace(phase=Phase.TO_HOLD, request=seg)
    for p in hold_candidates((1.5, 0.0, 1.2), [sprayer], 1.0):
        assert point_segment_m((p[0], p[1]), (0.0, 0.0), (1.5, 0.0)) >= 1.1 - 1e-9


def test_a_lingering_uav_yields_to_a_uav_whose_every_hold_flight_it_blocks():
    """The give-way covers every UAV with a request, also one whose site's turn has not come (it needs a hold
    point): a lingering hover over all of its hold points is in its way."""
    c = ColumnClearance(R, BASE, S, homes=HOMES)
    _at_site(c, "g", (0.0, 0.0, 1.2))
    c.lingering["g"] = WALL
    g = c.request("g", HOMES["g"], 10.0, (0.0, 0.0, BASE))
    assert g.hold_m is not None and g.layer_m is not None
    c.progress("g", (g.hold_m[0], g.hold_m[1], g.layer_m))
    assert c.phase("g") is Phase.AT_HOLD
    assert not held_up_by(c, "b", "g")  # (b asks for nothing)
    # b hovers right under g's hover and asks for a site far off: every flight it could be given climbs through g
    assert c.take_off("b")
    b = c.records["b"]
    b.volumes = [Volume((g.hold_m[0], g.hold_m[1]), (g.hold_m[0], g.hold_m[1]), 0.5, 0.5, 0.0, "hover")]
    b.phase, b.zone = Phase.ASKING, None
    b.request = FlightRequest((6.0, 6.0, 1.2), 1.2, (g.hold_m[0], g.hold_m[1], 0.5), 11.0, 99)
    assert held_up_by(c, "b", "g")


def test_a_uav_lingers_only_while_its_battery_covers_the_wait_a_task_and_the_way_home():
    """A wait near the wall is flight time: at the drain its heartbeats show, the flight left above 20 % must cover
    the rest of the wait, its role's longest task still to do and the way home, or it flies home (and is swapped)
    as it asked. With no drain measured yet, the 40 % floor alone decides."""
    options = SimOptions(brick_uavs=1, adhesion_uavs=1, seed=1)
    mission = SimulatedMission.from_blueprint(load_blueprint(ROOT / "blueprints" / "pyramid.yaml"), options)
    mc, book = mission.control, mission.control.lingers
    link = mc.uavs["glue-1"]
    near_wall = (link.spec.home_m[0], link.spec.home_m[1] + 3.0, 1.35)
    link.battery = 0.6
    assert book.affords(mc, "glue-1", near_wall, 1000.0, 0.0)  # nothing measured yet
    for i in range(201):  # 20 s in the air at 0.5 %/s
        book.heard("glue-1", i * 0.1, 0.7 - 0.0005 * i, airborne=True)
    assert book.drains["glue-1"].drain_per_s == pytest.approx(0.005)
    # 0.6: 80 s of flight above 20 %; the pyramid's beads and the way home take well under 60 s
    assert book.affords(mc, "glue-1", near_wall, 20.0, 0.0)
    assert not book.affords(mc, "glue-1", near_wall, 80.0, 0.0)
    link.battery = 0.3  # 20 s above 20 %: not even the way home and a bead
    assert not book.affords(mc, "glue-1", near_wall, 0.0, 0.0)


def test_a_lingering_uav_handed_a_task_at_its_spot_is_not_granted_its_flight_home_before_it_asks_again():
    """Issue 27: the wait ended with a task, and the next look at the airspace granted the UAV its flight home
    (its request then) before it asked for its task's site; that flight's volumes, towards its pad, stayed its
    own until its flight to the site was granted. Until it asks again it keeps its spot; then it is answered
    as any UAV asking from where it is."""
    c = ColumnClearance(R, BASE, S, homes=HOMES)
    _at_site(c, "g", (0.0, 0.0, 1.2))
    c.lingering["g"] = WALL
    g = c.request("g", HOMES["g"], 10.0, (0.0, 0.0, BASE))
    assert g.hold_m is not None and g.layer_m is not None
    spot = (g.hold_m[0], g.hold_m[1], g.layer_m)
    c.progress("g", spot)
    assert c.phase("g") is Phase.AT_HOLD
    # the wait ends with a task (LingerBook.end): no flight home, it stays at its spot
    c.handed_task.add("g")
    del c.lingering["g"]
    c.touch()
    assert c.grant(11.0) == []
    assert c.phase("g") is Phase.AT_HOLD and c.request("g", HOMES["g"], 11.5, spot).hold_m == g.hold_m
    # the request above was its next one: from now on it is answered as any other (here: home, free)
    c.touch()
    (home,) = c.grant(12.0)
    assert home.uav == "g" and home.granted
    # handed a task again at a spot: its request for the site is granted from there as it fits
    c2 = ColumnClearance(R, BASE, S, homes=HOMES)
    _at_site(c2, "g", (0.0, 0.0, 1.2))
    c2.lingering["g"] = WALL
    g2 = c2.request("g", HOMES["g"], 10.0, (0.0, 0.0, BASE))
    assert g2.hold_m is not None and g2.layer_m is not None
    c2.progress("g", (g2.hold_m[0], g2.hold_m[1], g2.layer_m))
    c2.handed_task.add("g")
    del c2.lingering["g"]
    c2.touch()
    site = c2.request("g", (0.6, 0.0, 1.2), 11.0, (g2.hold_m[0], g2.hold_m[1], g2.layer_m))
    assert site.granted and "g" not in c2.handed_task
    assert c2.conflicts() == []


def test_on_the_pyramid_a_wait_near_the_wall_ended_by_a_task_is_followed_by_the_flight_to_its_site(caplog):
    """Issue 27: the pyramid at 1 + 1, seed 1: before, every wait that ended with a task (24 of 24 over the
    mission) was followed by the sprayer's flight home being granted, then turned back for its site."""
    with caplog.at_level(logging.DEBUG, logger="masonry.mission.control"):
        report = _pyramid(True, 600.0)
    lines = [r.getMessage() for r in caplog.records if r.name == "masonry.mission.control"]
    home = f"flight to ({HOMES_PYRAMID_GLUE[0]:.2f}, {HOMES_PYRAMID_GLUE[1]:.2f}) granted to glue-1"
    ended, home_next = 0, 0
    for i, msg in enumerate(lines):
        if msg.startswith("glue-1 stops waiting near the wall") and msg.endswith("(task)"):
            ended += 1
            after = [m for m in lines[i + 1 :] if "granted to glue-1" in m][:1]
            home_next += after == [home]
    assert ended >= 4
    assert home_next == 0
    assert report.min_separation_m is not None and report.min_separation_m >= 1.0
    assert report.conflict_violations == 0 and report.dependency_violations == 0


def test_the_longest_task_still_to_do_kept_between_reviews_is_the_one_a_scan_finds():
    """``LingerBook.affords`` keeps its role's longest expected task not done yet while the dispatcher's done tasks
    stay: after each assignment and each completion it is what a scan of the plan finds."""
    mission = SimulatedMission.from_blueprint(
        load_blueprint(ROOT / "blueprints" / "pyramid.yaml"),
        SimOptions(brick_uavs=2, adhesion_uavs=1, seed=1),
    )
    mc, book = mission.control, mission.control.lingers
    book._due_s(
        mc, "brick", 0.0
    )  # (the expected durations, as the first ``affords`` with a drain computes them)
    expected = book._expected_s
    assert expected is not None

    def scanned(role: str) -> float:
        done = mc.dispatcher.done
        tasks = mc.plan.tasks
        return max(
            (expected.get(t.id, 0.0) for t in tasks if t.kind == role and t.id not in done), default=0.0
        )

    answers = set()
    while True:
        for role in ("brick", "adhesion"):
            kept = book._longest_task_s(mc, role)
            assert kept == scanned(role)
            answers.add(kept)
        if len(mc.dispatcher.done) == len(mc.plan.tasks):
            break
        assigned = mc.dispatcher.assign()
        assert assigned
        for role in ("brick", "adhesion"):
            assert book._longest_task_s(mc, role) == scanned(role)
        for a in assigned:
            mc.dispatcher.complete(a.task_id)
            for role in ("brick", "adhesion"):
                assert book._longest_task_s(mc, role) == scanned(role)
    assert 0.0 in answers and len(answers) > 2  # (the answers changed as the tasks were done)
