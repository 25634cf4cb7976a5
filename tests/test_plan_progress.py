"""The UAV's ``plan_progress`` (issue 27 §2.2, branch ``progress51``): a typed fact in heartbeats and progress
reports, how far the UAV is along the flight mission control answered it (the answer's number, the leg, the
fraction of it behind the UAV). On the wire (protocol version 7), refused with a reason when malformed, reported by
the UAV's machine along its flight, and read by the table in place of the position rule when it names the UAV's
current plan (docs/mission.md, "The UAV's plan progress")."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from airspace_rig import table_pair
from fsm_rig import Rig
from masonry.blueprint_gen import running_bond
from masonry.cli import app
from masonry.errors import ProtocolError
from masonry.fsm.transit import flight_of, progress_on
from masonry.mission import plan_reading
from masonry.mission.messages import (
    MISSION_CONTROL,
    PROTOCOL_VERSION,
    Clearance,
    Heartbeat,
    Progress,
    decode,
    encode,
)
from masonry.mission.reserved import TableClearance
from masonry.mission.reserved_parts import legs_under_way
from masonry.mission.simulate import SimulatedMission
from masonry.observe.mcap_log import read_log
from masonry.ports import PLAN_LEGS, PlanProgress

FLEET = ("brick-1", "glue-1")
CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


# -- on the wire ------------------------------------------------------------------------------------------------
def test_plan_progress_and_the_grant_number_round_trip():
    pp = PlanProgress(3, 1, 0.25)
    for msg in (
        Heartbeat("brick-1", 2.0, "place_transit", "B1", (1.0, 2.0, 3.0), plan_progress=pp),
        Progress("brick-1", "B1", "place_transit", 2.0, (1.0, 2.0, 3.0), carrying=True, plan_progress=pp),
        Heartbeat("brick-1", 2.0),
        Clearance(MISSION_CONTROL, "brick-1", (1.0, 2.0, 0.5), 0.8, 2.0, True, None, 2.4, grant=7),
        Clearance(MISSION_CONTROL, "brick-1", (1.0, 2.0, 0.5), 0.8, 2.0, False),
    ):
        assert decode(encode(msg), FLEET) == msg
        assert decode(encode(msg)) == msg  # (the heartbeat's direct path too)
    body = json.loads(encode(Heartbeat("brick-1", 2.0, plan_progress=pp)))
    assert body["v"] == PROTOCOL_VERSION == 7
    assert body["plan_progress"] == {"grant": 3, "leg": 1, "leg_fraction": 0.25}
    assert "plan_progress" not in json.loads(encode(Heartbeat("brick-1", 2.0)))  # none: left out
    assert pp.leg_name == "transit" and PLAN_LEGS == ("climb", "transit", "descend")


def _heartbeat_with(plan_progress: object, kind: str = "heartbeat") -> bytes:
    body = json.loads(
        encode(
            Progress("brick-1", "B1", "place_transit", 2.0)
            if kind == "progress"
            else Heartbeat("brick-1", 2.0)
        )
    )
    body["plan_progress"] = plan_progress
    return json.dumps(body).encode()


@pytest.mark.parametrize("kind", ["heartbeat", "progress"])
@pytest.mark.parametrize(
    ("value", "reason"),
    [
        ([1, 0, 0.5], "'plan_progress' must be an object, got list"),
        ({"grant": 1, "leg": 0}, "'leg_fraction' is missing"),
        (
            {"grant": 1, "leg": 3, "leg_fraction": 0.5},
            "'leg' must be an index of climb, transit, descend (0..2), got 3",
        ),
        ({"grant": 1, "leg": -1, "leg_fraction": 0.5}, "got -1"),
        ({"grant": 1, "leg": True, "leg_fraction": 0.5}, "'leg' must be an integer, got True"),
        ({"grant": 1, "leg": 1.0, "leg_fraction": 0.5}, "'leg' must be an integer, got 1.0"),
        ({"grant": 0, "leg": 1, "leg_fraction": 0.5}, "'grant' must be >= 1, got 0"),
        ({"grant": "1", "leg": 1, "leg_fraction": 0.5}, "'grant' must be an integer"),
        ({"grant": 1, "leg": 1, "leg_fraction": 1.5}, "'leg_fraction' must be in 0..1, got 1.5"),
        ({"grant": 1, "leg": 1, "leg_fraction": -0.01}, "'leg_fraction' must be in 0..1, got -0.01"),
        ({"grant": 1, "leg": 1, "leg_fraction": math.nan}, "'leg_fraction' must be a finite number"),
        ({"grant": 1, "leg": 1, "leg_fraction": math.inf}, "'leg_fraction' must be a finite number"),
        ({"grant": 1, "leg": 1, "leg_fraction": "0.5"}, "'leg_fraction' must be a finite number"),
        ({"grant": 1, "leg": 1, "leg_fraction": 0.5, "site": [0, 0, 0]}, "has unknown field 'site'"),
    ],
)
def test_a_hostile_plan_progress_is_refused_with_its_reason(kind, value, reason):
    with pytest.raises(ProtocolError) as exc:
        decode(_heartbeat_with(value, kind), FLEET)
    assert reason in str(exc.value)
    assert "plan_progress" in str(exc.value)


def test_a_clearance_s_grant_number_is_checked_and_an_older_peer_refused():
    body = json.loads(encode(Clearance(MISSION_CONTROL, "brick-1", (1.0, 2.0, 0.5), 0.8, 2.0, grant=1)))
    for bad, reason in (
        (-1, "'grant' must be >= 0, got -1"),
        (1.5, "'grant' must be an integer"),
        (True, "'grant' must be an integer"),
    ):
        with pytest.raises(ProtocolError, match=reason):
            decode(json.dumps({**body, "grant": bad}).encode(), FLEET)
    old = json.loads(encode(Heartbeat("brick-1", 2.0, plan_progress=PlanProgress(1, 0, 0.0))))
    with pytest.raises(ProtocolError, match="protocol version 6; this side speaks 7"):
        decode(json.dumps({**old, "v": 6}).encode(), FLEET)


# -- the UAV's side -----------------------------------------------------------------------------------------------
def test_a_flight_s_legs_are_named_from_its_points():
    up = flight_of(4, [(0.0, 0.0, 1.0), (0.0, 0.0, 2.6), (3.0, 4.0, 2.6), (3.0, 4.0, 0.5)])
    assert [leg for leg, _a, _b in up.legs] == [0, 1, 2]
    # from a hold point at a higher layer: down to the new layer is its climb leg (before the transit)
    down_first = flight_of(5, [(0.0, 0.0, 3.0), (0.0, 0.0, 2.6), (3.0, 4.0, 2.6)])
    assert [leg for leg, _a, _b in down_first.legs] == [0, 1]
    assert [leg for leg, _a, _b in flight_of(6, [(0.0, 0.0, 2.0), (0.0, 0.0, 0.5)]).legs] == [2]
    # halfway along its transit, the navigator flying to its end with the descent after it
    assert progress_on(up, (3.0, 4.0, 2.6), 1, (1.5, 2.0, 2.6)) == PlanProgress(4, 1, 0.5)
    assert progress_on(up, (3.0, 4.0, 0.5), 0, (3.0, 4.0, 0.5)) == PlanProgress(4, 2, 1.0)
    # the navigator flies elsewhere (it stopped, turned back): no progress
    assert progress_on(up, (1.0, 1.0, 2.6), 1, (1.0, 1.0, 2.6)) is None


def test_the_uav_reports_its_progress_along_the_flight_it_was_answered():
    """A brick UAV on fakes whose airspace grants every column (the granted answer of the n-th site asked for is
    numbered 2n): along each transit its machine reports that number, its legs in order, fractions in 0..1."""
    seen: list[tuple[float, PlanProgress | None, str]] = []

    def sample(rig: Rig) -> None:
        seen.append((rig.clock.now_s(), rig.uav.plan_progress(rig.fc.position_m), rig.uav.transit.state))

    rig = Rig("brick", clearance={"layer_m": 2.6}).run(on_tick=sample)
    assert rig.link.results[-1].status == "done"
    reports = [pp for _t, pp, _s in seen if pp is not None]
    assert reports, "no plan progress reported"
    assert {pp.grant for pp in reports} <= {2 * n for n in range(1, len(rig.link.asked) + 1)}
    assert {pp.leg for pp in reports} == {0, 1, 2}
    assert all(0.0 <= pp.leg_fraction <= 1.0 for pp in reports)
    for grant in {
        pp.grant for pp in reports
    }:  # along one flight: legs in order, each fraction not going back
        mine = [(pp.leg, pp.leg_fraction) for pp in reports if pp.grant == grant]
        assert [leg for leg, _f in mine] == sorted(leg for leg, _f in mine)
        assert all(
            b >= a - 0.02 for (k, a), (j, b) in itertools.pairwise(mine) if k == j
        )  # (at rest: jitter)
    # none when it flies no transit (clear: before its first request, after it came down)
    assert all(pp is None for _t, pp, state in seen if state == "clear")


def test_a_table_mission_s_uavs_report_their_plans_and_mission_control_reads_them(monkeypatch):
    """A small running bond, 2 + 1, under the table: the reports that reach mission control (decoded from the
    wire) carry plan progress naming the UAVs' current plans, which the table reads."""
    heard: list[tuple[str, PlanProgress | None, bool]] = []
    progress = TableClearance.progress

    def spy(self, uav, position_m, plan_progress=None):
        u = self._uavs.get(uav)
        heard.append(
            (uav, plan_progress, u is not None and plan_reading.matching(u, plan_progress) is not None)
        )
        progress(self, uav, position_m, plan_progress)

    monkeypatch.setattr(TableClearance, "progress", spy)
    mission = SimulatedMission.from_blueprint(
        running_bond(2, 3, brick_uavs=2, adhesion_uavs=1), seed=1, airspace="table"
    )
    r = mission.run()
    assert r.completed
    said = [(uav, pp) for uav, pp, _m in heard if pp is not None]
    assert {uav for uav, _pp in said} == {"brick-1", "glue-1"}  # (brick-2 is given no task at seed 1)
    assert {pp.leg for _u, pp in said} == {0, 1, 2}
    table = mission.control.columns
    assert isinstance(table, TableClearance)
    assert table.plan_read == sum(m for _u, _pp, m in heard) > len(said) // 2


# -- mission control's side ---------------------------------------------------------------------------------------
def _granted_hop() -> tuple[TableClearance, int, float, float]:
    air = table_pair()
    air.take_off("a")
    assert air.request("a", (6.0, -5.0, 1.2), 0.0, (0.0, -5.0, 1.2)).granted
    number = plan_reading.grant_number(air.record("a"))
    transit = sorted((r for r in air.table.of("a") if r.purpose == "transit"), key=lambda r: r.t0_s)
    assert len(transit) == 6  # (a 6 m transit, reserved in 1 m pieces)
    return air, number, transit[0].t0_s + 0.1, transit[0].volume.z0_m


def _pieces(air: TableClearance, now_s: float) -> int:
    return sum(1 for r in legs_under_way(air.table.of("a"), now_s) if r.purpose == "transit")


#: 0.5 m beside its transit (the line y = -5 at its layer, 3.3 m along): in none of its legs by the position rule
#: (``ON_LEG_M`` 0.3 m), as a UAV blown off its track is.
OFF_TRACK = (3.3, -4.5)


def test_the_table_reads_a_report_of_the_current_plan_before_the_position():
    """Off its track (the position rule finds it in no leg: nothing ends), the UAV says it is 55 % along its
    transit: its climb and the three pieces of its transit behind it end now."""
    air, number, now_s, layer_m = _granted_hop()
    assert number == 1 and plan_reading.grant_number(air.record("a")) == 1  # (said again: the same number)
    air.tick(now_s)
    air.progress("a", (*OFF_TRACK, layer_m), PlanProgress(number, 1, 0.55))
    assert air.plan_read == 1
    assert _pieces(air, now_s + 1e-6) == 3
    assert not any(r.purpose == "climb" for r in legs_under_way(air.table.of("a"), now_s + 1e-6))


def test_a_report_never_ends_a_leg_the_uav_is_still_in():
    """At the top of its climb (in its climb's column, and its transit's first piece), a report of 55 % along its
    transit ends nothing: the position rule's leg, the earlier, is kept."""
    air, number, now_s, layer_m = _granted_hop()
    air.tick(now_s)
    air.progress("a", (0.0, -5.0, layer_m), PlanProgress(number, 1, 0.55))
    assert air.plan_read == 1 and _pieces(air, now_s + 1e-6) == 6


def test_a_report_of_another_plan_or_none_moves_nothing_the_position_rule_would_not():
    """The same report under another number (a flight before, or one not flown yet), or no report: the position
    rule decides, as before the fact existed (the table as with the position alone)."""
    for said in ("stale", "none"):
        air, number, now_s, layer_m = _granted_hop()
        alone, _n, _t, _z = _granted_hop()
        for table in (air, alone):
            table.tick(now_s)
        pp = PlanProgress(number + 1, 1, 0.55) if said == "stale" else None
        air.progress("a", (*OFF_TRACK, layer_m), pp)
        alone.progress("a", (*OFF_TRACK, layer_m))
        assert air.plan_read == 0
        assert air.table.of("a") == alone.table.of("a")
        assert _pieces(air, now_s + 1e-6) == 6


def test_the_log_carries_each_uav_s_plan_progress(tmp_path):
    """``masonry sim --log``: the ``uav`` events (the MCAP log, ``masonry replay``) carry the UAV's last reported
    ``plan_progress``, its leg named (null when it flies none)."""
    log = tmp_path / "run.mcap"
    res = CliRunner().invoke(
        app, ["sim", str(CASE_STUDY), "--airspace", "table", "--log", str(log), "--no-progress"]
    )
    assert res.exit_code == 0, res.output
    uav_events = [e for e in read_log(log).events if e.kind == "uav"]
    said = [e.fields["plan_progress"] for e in uav_events if e.fields.get("plan_progress") is not None]
    assert said and len(said) < len(uav_events)
    legs = {p["leg_name"] for p in said}
    assert "transit" in legs and legs <= set(PLAN_LEGS)
    assert all(p["grant"] >= 1 and 0.0 <= p["leg_fraction"] <= 1.0 for p in said)
    assert all(PLAN_LEGS[p["leg"]] == p["leg_name"] for p in said)
