"""Under ``--airspace table`` the operator's pause and recall and the wind limit are holds on the table's take-offs,
and the site's fence is the space every flown leg keeps inside (issue 27 §1.4; masonry.mission.table_holds,
masonry.reservation.holds and .fence). What the operator, the wind and the fence do is what they do under the columns
(tests/test_operator.py, tests/test_wind_limit.py, tests/test_geofence.py): these fly the same missions under the
table and look at the table too."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from airspace_rig import table_pair
from masonry.blueprint import load_blueprint
from masonry.geofence import Site
from masonry.mission import table_holds
from masonry.mission.airspace_state import Phase
from masonry.mission.control_dispatch import may_take_off
from masonry.mission.events import EventList
from masonry.mission.reserved import TableClearance
from masonry.mission.simulate import SimulatedMission
from masonry.mission.wait_causes import airspace_cause
from masonry.mission.waits import WaitCause
from masonry.ports import RECALL_REASON
from masonry.reservation import Fence, Hold, Table, column, with_holds
from masonry.reservation.fence import FLOWN
from masonry.sim import Faults
from masonry.sim.wind import WindConfig
from test_geofence import NOTCH, _with_site
from test_operator import CASE_STUDY
from test_wind_limit import GUST_FRONT

#: The case study's site with a ceiling of 4.2 m: the table's third and fourth layers are over it less 0.5 m.
LOW_CEILING = "site: {boundary: [[-2, -4], [6, -4], [6, 3], [-2, 3]], max_altitude: 4.2}\n"

Seen = list[tuple[float, set[tuple[str, frozenset[str]]]]]


def _open_holds(table: Table) -> set[tuple[str, frozenset[str]]]:
    return {(h.cause, h.uavs) for h in table.holds if math.isinf(h.t1_s)}


def _watch_holds(mission: SimulatedMission) -> Seen:
    """The table's open holds at every tick, with the time."""
    seen: Seen = []
    mission.tick_hooks.append(lambda now_s: seen.append((now_s, _open_holds(mission.control.columns.table))))
    return seen


def _fly(commands: dict[float, dict], **kw):
    """The case study under the table, each command submitted once mission time reaches its key (as
    tests/test_operator.py flies it): its report, the answers (time, command, outcome) and the holds seen."""
    mission = SimulatedMission.from_blueprint(load_blueprint(CASE_STUDY), airspace="table", **kw)
    pending = sorted(commands.items())
    answers: list = []

    def operator(now_s: float) -> None:
        while pending and now_s >= pending[0][0]:
            t, c = pending.pop(0)
            mission.control.operator.submit(c, lambda out, t=t, c=c: answers.append((t, c["command"], out)))

    mission.tick_hooks.append(operator)
    seen = _watch_holds(mission)
    return mission.run(), answers, seen


def _holds_between(seen, t0_s: float, t1_s: float) -> list[set[tuple[str, frozenset[str]]]]:
    return [h for t, h in seen if t0_s <= t <= t1_s]


def test_a_take_off_is_refused_while_a_hold_stands_and_the_wait_names_its_cause() -> None:
    air = table_pair()
    air.table = with_holds(air.table, {("wind", frozenset({"a"}))}, 0.0)
    assert not air.can_take_off("a") and not air.take_off("a") and air.phase("a") is Phase.LANDED
    assert air.can_take_off("b")  # a's grounding is a's only
    # a request from its pad (its ground stay) waits for the hold, which is named: the task's wait says ``wind``
    g = air.request("a", (0.0, 0.0, 1.2), 1.0, (0.0, -5.0, 0.0))
    assert not g.granted and g.refused is None and air.blockers("a") == [("-", "wind")]
    assert airspace_cause(air, "a", lambda uav: None, "ground") == WaitCause("wind", uav="a", where="ground")
    air.table = with_holds(air.table, set(), 2.0)  # the wind dropped: lifted
    assert air.table.holds == () and air.can_take_off("a")
    air.touch()
    assert [x.uav for x in air.grant(3.0)] == ["a"]


def test_pause_under_the_table_holds_every_take_off_and_changes_no_outcome() -> None:
    plain, _, _ = _fly({})
    sink = EventList()
    r, answers, seen = _fly({20.0: {"command": "pause"}, 90.0: {"command": "resume"}}, events_sink=sink)
    assert [(c, o.accepted) for _, c, o in answers] == [("pause", True), ("resume", True)]
    assert r.completed and plain.completed
    assert {t.id: t.status for t in r.tasks} == {t.id: t.status for t in plain.tasks}
    assert r.conflict_violations == 0 and r.dependency_violations == 0
    assert [a for a in r.attempts if 20.1 < a.start_s < 90.0] == []  # nothing assigned while paused
    landed = {
        e.uav
        for e in sink.events
        if e.kind == "uav" and 80.0 < e.time_s < 90.0 and e.fields["state"] == "idle"
    }
    assert landed == {"brick-1", "glue-1"}
    # the pause is the table's hold on every take-off from the command to the resume, then lifted
    assert all(h == {("operator", frozenset())} for h in _holds_between(seen, 20.2, 89.9))
    assert all(h == set() for h in _holds_between(seen, 90.2, math.inf))
    waits = [w for t in json.loads(r.to_json())["tasks"] for w in t["waits"]]
    assert any(w["what"] == "operator" for w in waits), waits


def test_recall_under_the_table_holds_that_uav_until_resume() -> None:
    r, answers, seen = _fly({25.0: {"command": "recall", "uav": "brick-1"}, 70.0: {"command": "resume"}})
    assert [o.accepted for _, _, o in answers] == [True, True]
    b0 = [a for a in r.attempts if a.task_id == "B0"]
    assert [a.status for a in b0] == ["failed", "done"]
    assert b0[0].reason in (RECALL_REASON, f"{RECALL_REASON}; brick 0 put back at its pickup")
    assert b0[0].end_s is not None and b0[0].end_s < 70.0 <= b0[1].start_s
    assert r.completed and r.conflict_violations == 0
    assert all(h == {("operator", frozenset({"brick-1"}))} for h in _holds_between(seen, 25.2, 69.9))
    assert all(h == set() for h in _holds_between(seen, 70.2, math.inf))


def test_a_wind_above_the_limit_under_the_table_grounds_the_fleet_on_the_table_and_it_resumes() -> None:
    bp = load_blueprint(CASE_STUDY)
    faults = Faults(wind=WindConfig(direction_deg=270.0, schedule=GUST_FRONT))
    mission = SimulatedMission.from_blueprint(
        bp, seed=0, faults=faults, vehicle="ideal", max_time_s=900.0, airspace="table"
    )
    seen = _watch_holds(mission)
    airborne: list[float] = []
    mission.tick_hooks.append(
        lambda now_s: (
            airborne.append(now_s)
            if 120.0 <= now_s <= 200.0 and any(not u.vehicle.on_ground for u in mission.world.uavs.values())
            else None
        )
    )
    report = mission.run()
    assert report.completed, report
    tasks = json.loads(report.to_json())["tasks"]
    attempts = [a for t in tasks for a in t["attempts_detail"]]
    assert all(t["attempts"] == 1 for t in tasks)
    assert not [a for a in attempts if 34.0 <= a["start_s"] <= 200.5], attempts
    assert any(a["start_s"] > 200.5 for a in attempts)
    assert not airborne, airborne[:3]
    grounded = {("wind", frozenset({u.name})) for u in bp.fleet}
    assert all(h == grounded for h in _holds_between(seen, 34.5, 200.5))
    assert all(h == set() for h in _holds_between(seen, 201.1, math.inf))


def _fly_fenced(tmp_path: Path, site: str):
    """The case study with ``site`` under the table: its report, and every flown reservation the table ever held
    outside the fence."""
    bp = load_blueprint(_with_site(tmp_path, site))
    assert bp.site is not None
    mission = SimulatedMission.from_blueprint(bp, seed=1, vehicle="ideal", airspace="table")
    c, fence, outside = mission.control.columns, Fence(bp.site), []
    watched = c.on_change

    def check(table: Table, now_s: float) -> object:
        flown = [r for r in table.reservations if r.purpose in FLOWN]
        outside.extend(r.describe() for r in flown if not fence.admits(r.volume, r.purpose))
        return watched(table, now_s)

    c.on_change = check
    return mission.run(), outside


def test_a_flight_across_the_fence_is_never_granted_under_the_table_and_its_task_fails_saying_why(
    tmp_path: Path,
) -> None:
    """The case study with a notch between the wall and the pallet (tests/test_geofence.py): the brick tasks fail
    their three attempts saying why, the adhesion tasks are done, and no flown reservation of the table ever left
    the fence."""
    report, outside = _fly_fenced(tmp_path, NOTCH)
    assert not report.completed and report.stall is None
    by_id = {t.id: t for t in report.tasks}
    assert by_id["A0"].status == by_id["A1"].status == "done"
    for tid in ("B0", "B1"):
        t = by_id[tid]
        assert t.status == "stuck" and len(t.tries) == 3
        assert all("leaves the site fence" in a.reason for a in t.tries), [a.reason for a in t.tries]
    assert not outside, outside[:3]


def test_under_a_low_ceiling_the_table_flies_no_spot_above_it(tmp_path: Path) -> None:
    """A ceiling of 4.2 m (the table's top layers over it): the approach spot (at the top layer) and the parking
    spots are not flown to above it; the mission completes inside the fence (before, brick-1 climbed to its approach
    spot 0.5 m from the ceiling and the mission stalled there)."""
    report, outside = _fly_fenced(tmp_path, LOW_CEILING)
    assert report.completed and report.stall is None and report.conflict_violations == 0
    assert not outside, outside[:3]


def test_a_hold_is_a_value_of_the_table() -> None:
    h = Hold("operator", 5.0)
    assert h.covers("x", 5.0) and not h.covers("x", 4.9) and h.until(3.0).t1_s == 5.0


def test_a_silent_uavs_way_home_under_the_table_keeps_under_the_ceiling() -> None:
    """A UAV falls silent with a fallback layer over the ceiling (4.5 m under a 4.2 m one: a blueprint's own layers
    are checked under it, site_checks; a fallback given by hand is not): its way home is reserved where its clamped
    setpoints fly it, 0.5 m under the ceiling, inside the fence (before: at 4.5 m, outside)."""
    site = Site(((-4.0, -8.0), (8.0, -8.0), (8.0, 4.0), (-4.0, 4.0)), 4.2)
    homes = {"a": (0.0, -5.0, 0.0), "b": (3.0, -5.0, 0.0)}
    c = TableClearance(0.8, 2.0, homes=homes, start_base_m=1.2, fence=site)
    assert c.take_off("a") and c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -5.0, 1.2)).granted
    for t in range(1, 5):
        c.grant(float(t))
    length_m = c.silent("a", (0.0, -3.0, 2.0), 4.5)
    home = [r for r in c.table.of("a") if r.purpose == "home"]
    assert home and max(r.volume.z1_m for r in home) == pytest.approx(3.7)
    assert all(Fence(site).admits(r.volume, r.purpose) for r in home), [r.describe() for r in home]
    assert length_m == pytest.approx(2.0 + 1.7 + 1.7)  # (up 1.7 m, 2 m along, down 1.7 m to over its pad)


def test_a_uav_cut_off_under_a_low_ceiling_flies_home_inside_what_the_table_reserved(tmp_path: Path) -> None:
    """The case study under a 4.2 m ceiling, glue-1's link cut for 40 s as it flies (its fallback layer, 3.4 m, is
    under the ceiling: the blueprint's check): it flies home on its own, the mission completes, and no flown
    reservation of the table, its way home among them, ever left the fence."""
    bp = load_blueprint(_with_site(tmp_path, LOW_CEILING))
    assert bp.site is not None
    mission = SimulatedMission.from_blueprint(bp, seed=1, vehicle="ideal", airspace="table")
    c, fence, outside, homes = mission.control.columns, Fence(bp.site), [], []
    watched = c.on_change

    def check(table: Table, now_s: float) -> object:
        flown = [r for r in table.reservations if r.purpose in FLOWN]
        outside.extend(r.describe() for r in flown if not fence.admits(r.volume, r.purpose))
        homes.extend(r for r in flown if r.purpose == "home")
        return watched(table, now_s)

    c.on_change = check
    cut: list[float] = []

    def hook(now_s: float) -> None:
        v = mission.world.uavs["glue-1"].vehicle
        if not cut and now_s > 10.0 and math.hypot(v.velocity_mps[0], v.velocity_mps[1]) > 0.3:
            cut.append(now_s)
            mission.bus.cut("glue-1")
        elif len(cut) == 1 and now_s > cut[0] + 40.0:
            cut.append(now_s)
            mission.bus.restore("glue-1")

    mission.tick_hooks.append(hook)
    report = mission.run()
    assert len(cut) == 2 and homes, "glue-1 was cut off and its way home reserved"
    assert report.completed and report.conflict_violations == 0
    assert not outside, outside[:3]


def test_dispatch_under_the_table_reads_the_tables_holds() -> None:
    """Under the table dispatch asks the table's holds whether a UAV is recalled or grounded (``table_holds.holding``:
    ``sync`` made them this tick from the operator and the wind limit), not the operator and the wind limit
    beside it; under the columns it asks them. A UAV in the air (not landed: no take-off for its hold to refuse) is
    given no task while the table holds it (before, dispatch did not look at the table)."""
    bp = load_blueprint(CASE_STUDY)
    mission = SimulatedMission.from_blueprint(bp, seed=0, airspace="table")
    mc = mission.control
    c = mc.columns
    assert isinstance(c, TableClearance)
    c.set_stay("brick-1", column((3.0, -0.5), 0.0, 2.1), Phase.PARKED)  # (in the air over its pad)
    assert table_holds.holding(mc, "brick-1") == frozenset()
    c.table = with_holds(c.table, {("wind", frozenset({"brick-1"}))}, 0.0)
    assert table_holds.holding(mc, "brick-1") == frozenset({"wind"})
    assert mc.wind_limit is None or mc.wind_limit.allows("brick-1")  # (the wind limit says nothing)
    assert not may_take_off(mc, "brick-1")
    c.table, mc.now_s = with_holds(c.table, {("operator", frozenset({"brick-1"}))}, 1.0), 1.0
    assert table_holds.holding(mc, "brick-1") == frozenset({"operator"}) and not may_take_off(mc, "brick-1")
    c.table, mc.now_s = with_holds(c.table, set(), 2.0), 2.0
    assert may_take_off(mc, "brick-1")
    columns = SimulatedMission.from_blueprint(bp, seed=0).control  # the columns: no table to read
    assert table_holds.holding(columns, "brick-1") is None
