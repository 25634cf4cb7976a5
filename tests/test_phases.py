"""Where the time goes: the phase mapping, the UAV's phase clock, the result's ``phases`` on the wire, the report's
``phases`` / ``idle_s`` / ``waiting_s`` and the Gantt chart's phase segments (docs/mission.md)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import load_blueprint
from masonry.errors import ProtocolError
from masonry.fsm.phases import STATE_PHASES, TRANSIT_PHASES, PhaseClock, phase_of
from masonry.fsm.states import ADHESION_STATES, BRICK_STATES, TRANSIT_STATES, leaf_states
from masonry.mission.messages import Result, decode, encode, phases_from_dict
from masonry.mission.report import AttemptReport, idle_s, phase_totals
from masonry.mission.simulate import CONTROL_PERIOD_S, SimulatedMission, simulate
from masonry.ports import PHASES, PhaseTimes, TaskResult
from masonry.viz.gantt import PHASE_COLOURS, _Bars, draw_gantt

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"


# -- the mapping -------------------------------------------------------------------------------------------
def test_every_state_of_both_task_machines_has_a_phase_and_nothing_else_does():
    states = set(leaf_states(BRICK_STATES)) | set(leaf_states(ADHESION_STATES))
    assert set(STATE_PHASES) == states
    assert set(STATE_PHASES.values()) <= set(PHASES)


def test_every_transit_state_is_mapped_and_asking_or_holding_override_the_task_state():
    assert set(TRANSIT_PHASES) == {s["name"] for s in TRANSIT_STATES}
    for state in STATE_PHASES:
        assert phase_of(state, "ask") == "waiting"
        assert phase_of(state, "hold") == "holding"
        assert phase_of(state, "clear") == phase_of(state, "down") == STATE_PHASES[state]


@pytest.mark.parametrize(
    ("state", "phase"),
    [
        ("takeoff", "takeoff"),
        ("pickup_goto", "transit"),
        ("transport", "transit"),
        ("cruise", "transit"),
        ("pickup_estimate", "estimating"),
        ("pickup_descend", "descending"),
        ("place_descend", "descending"),
        ("descend", "descending"),
        ("pickup_grasp", "grasping"),
        ("spray", "spraying"),
        ("place_release", "placing"),
        ("place_ascend", "ascending"),
    ],
)
def test_the_issue_s_phases(state, phase):
    assert phase_of(state, "clear") == phase


def test_an_unknown_state_is_an_error_not_a_phase():
    with pytest.raises(KeyError):
        phase_of("pickup_dance", "clear")
    with pytest.raises(KeyError):
        phase_of("transport", "sideways")


def test_phase_times_fields_are_the_phases_in_order():
    assert tuple(f.name for f in dataclasses.fields(PhaseTimes)) == PHASES
    assert set(PHASE_COLOURS) == set(PHASES)


# -- the clock ---------------------------------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 2.0), st.sampled_from(PHASES)), min_size=0, max_size=40))
def test_the_clock_s_phases_add_up_to_the_time_from_start_to_stop(ticks):
    clock = PhaseClock()
    clock.tick(1.0, "transit")  # no task yet: nothing counted
    clock.start(5.0)
    now = 5.0
    for dt, phase in ticks:
        now += dt
        clock.tick(now, phase)
    times = clock.stop()
    assert times.total_s == pytest.approx(now - 5.0, abs=1e-9)
    for phase in PHASES:
        spent = sum(dt for dt, p in ticks if p == phase)
        assert getattr(times, phase) == pytest.approx(spent, abs=1e-9)
    assert not clock.running
    clock.tick(now + 3.0, "waiting")  # stopped: nothing counted
    assert clock.so_far() == times


def test_the_tabulated_tick_is_phase_of():
    for state in STATE_PHASES:
        for transit in TRANSIT_PHASES:
            by_table, by_name = PhaseClock(), PhaseClock()
            by_table.start(0.0)
            by_name.start(0.0)
            by_table.tick_in(1.5, state, transit)
            by_name.tick(1.5, phase_of(state, transit))
            assert by_table.stop() == by_name.stop() != PhaseTimes()


def test_phase_times_add_and_list_in_order():
    a, b = PhaseTimes(transit=2.0, waiting=1.0), PhaseTimes(waiting=0.5, holding=4.0)
    total = a + b
    assert total.transit == 2.0 and total.waiting == 1.5 and total.holding == 4.0
    assert total.clearance_s == 5.5 and total.total_s == 7.5
    assert [name for name, _ in total.items()] == list(PHASES)
    assert total.as_dict()["holding"] == 4.0


# -- the wire ----------------------------------------------------------------------------------------------
def _result(phases: PhaseTimes | None) -> Result:
    return Result("brick-1", TaskResult("B0", "done", 12.0, phases=phases), 30.0, attempt=1)


def test_the_result_carries_its_phases_both_ways():
    phases = PhaseTimes(takeoff=2.0, transit=5.5, waiting=1.25, placing=0.5)
    msg = decode(encode(_result(phases)), ["brick-1"])
    assert isinstance(msg, Result) and msg.result.phases == phases


def test_a_result_without_phases_is_still_a_result():
    raw = encode(_result(None))
    assert b"phases" not in raw  # a peer that does not know the field never sees it
    msg = decode(raw, ["brick-1"])
    assert isinstance(msg, Result) and msg.result.phases is None


def _with_phases(value: object) -> bytes:
    body = json.loads(encode(_result(PhaseTimes(transit=1.0))))
    body["result"]["phases"] = value
    return json.dumps(body).encode()


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ([1.0, 2.0], "must be an object"),
        ("transit", "must be an object"),
        ({"teleport": 1.0}, "unknown phase 'teleport'"),
        ({"transit": -0.5}, "finite number >= 0"),
        ({"transit": "3"}, "finite number >= 0"),
        ({"transit": True}, "finite number >= 0"),
        ({"transit": None}, "finite number >= 0"),
        ({"transit": [1.0]}, "finite number >= 0"),
        ({"transit": float("nan")}, "finite number >= 0"),
        ({"transit": float("inf")}, "finite number >= 0"),
    ],
)
def test_garbage_phases_are_rejected_on_decode(value, problem):
    with pytest.raises(ProtocolError, match=problem):
        decode(_with_phases(value), ["brick-1"])


def test_phases_left_out_are_zero():
    assert phases_from_dict({"transit": 3}) == PhaseTimes(transit=3.0)
    assert phases_from_dict({}) == PhaseTimes()


# -- a mission ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def case_study():
    # the paper's rule: the brick UAV idles while A0 is sprayed (under ``site`` it
    # fetches B0's brick meanwhile and A1 follows A0 in the air)
    mission = SimulatedMission.from_blueprint(load_blueprint(CASE_STUDY), seed=0, reservation="task")
    report = mission.run()
    return mission, report


def test_every_attempt_s_phases_add_up_to_its_duration_within_a_tick(case_study):
    _, report = case_study
    assert report.completed and report.attempts
    for a in report.attempts:
        assert a.phases is not None and a.end_s is not None
        # the assignment reaches the UAV at its next tick: the only time its clock does not see
        assert abs(a.phases.total_s - (a.end_s - a.start_s)) <= CONTROL_PERIOD_S + 1e-6, a
        assert a.phases.other == 0.0 and a.phases.queued == 0.0


def test_the_machine_s_phases_add_up_to_the_duration_it_reports(case_study):
    mission, _ = case_study
    results = [r for h in mission.handlers.values() for r in h.model.results]
    assert results
    for r in results:
        assert r.phases is not None
        assert r.phases.total_s == pytest.approx(r.duration_s, abs=1e-9)


def test_brick_and_adhesion_attempts_go_through_their_own_phases(case_study):
    _, report = case_study
    took_off: set[str] = set()
    for a in report.attempts:
        assert a.phases is not None
        assert a.phases.transit > 0 and a.phases.descending > 0
        # each UAV's first attempt starts on its pad; a later one may start in the air (the linger, docs/safety.md)
        if a.uav not in took_off:
            assert a.phases.takeoff > 0
            took_off.add(a.uav)
        if a.kind == "brick":
            assert a.phases.estimating > 0 and a.phases.grasping > 0 and a.phases.placing > 0
            assert a.phases.spraying == 0
        else:
            assert a.phases.spraying > 0
            assert a.phases.estimating == a.phases.grasping == a.phases.placing == 0


def test_the_json_report_has_phases_idle_and_waiting(case_study):
    _, report = case_study
    d = json.loads(report.to_json())
    by_id = {a.task_id: a for a in report.attempts if a.status == "done"}
    for t in d["tasks"]:
        assert list(t["phases"]) == list(PHASES)
        assert t["phases"] == {k: round(v, 2) for k, v in by_id[t["id"]].phases.as_dict().items()}
    span = report.makespan_s
    for u in d["uavs"]:
        mine = [a for a in report.attempts if a.uav == u["name"]]
        assert u["waiting_s"] == round(sum(a.phases.waiting + a.phases.holding for a in mine), 2)
        assert u["waiting_s"] > 0  # the case study's flights ask for their columns
        # every second of the mission is idle or in an attempt
        assert u["idle_s"] + sum(a.end_s - a.start_s for a in mine) == pytest.approx(span, abs=0.02)
    assert d["uavs"][0]["idle_s"] > 0  # the brick UAV waits for A0 before B0


def test_a_uav_swapped_before_its_first_task_is_given_it_with_the_fresh_pack():
    """Under the handler's 40 % reserve mission control hears the low charge and gives glue-1 nothing
    (``masonry.mission.swap_stagger``): it is swapped idle on its pad, so A0's attempt starts after the crew's 60 s
    with nothing ``queued`` (a handler's hold, when mission control does not hear the charge, is
    test_mission_control's ``heard=False``), and the phases still add up to the attempt."""
    mission = SimulatedMission.from_blueprint(load_blueprint(CASE_STUDY), seed=0)
    mission.world.uavs["glue-1"].vehicle.battery_fraction = 0.3  # below the handler's 40 % reserve
    report = mission.run()
    assert report.completed
    first = next(a for a in report.attempts if a.uav == "glue-1")
    assert first.phases is not None and first.end_s is not None
    assert first.start_s >= 60.0 - 1e-6 and first.phases.queued == 0.0  # the ground crew's swap came first
    assert abs(first.phases.total_s - (first.end_s - first.start_s)) <= CONTROL_PERIOD_S + 1e-6


def test_a_lost_uav_s_idle_time_ends_at_its_loss():
    attempts = [
        AttemptReport("B0", "brick-1", 1, 0.0, 10.0, "done", "brick", phases=PhaseTimes(transit=10.0)),
        AttemptReport("B1", "brick-1", 1, 30.0, None, "running", "brick"),
    ]
    assert idle_s(attempts, "brick-1", 0.0, 50.0) == pytest.approx(20.0)
    assert idle_s(attempts, "brick-1", 0.0, 20.0) == pytest.approx(10.0)
    assert idle_s(attempts, "glue-1", 0.0, 50.0) == pytest.approx(50.0)
    assert phase_totals(attempts) == PhaseTimes(transit=10.0)


def test_phases_survive_a_resume_from_the_journal(tmp_path):
    journal = tmp_path / "m.db"
    first = simulate(load_blueprint(CASE_STUDY), journal_path=journal)
    again = simulate(load_blueprint(CASE_STUDY), journal_path=journal, resume=True)
    assert [t.phases for t in again.tasks] == [t.phases for t in first.tasks]
    assert all(t.phases is not None for t in again.tasks)


def test_journaled_garbage_phases_are_dropped():
    from masonry.mission.control import _journaled_phases

    assert _journaled_phases({"transit": 1.0}) == PhaseTimes(transit=1.0)
    assert _journaled_phases(None) is None
    assert _journaled_phases({"transit": -1.0}) is None
    assert _journaled_phases("lots") is None


# -- the Gantt chart ---------------------------------------------------------------------------------------
def test_a_bar_is_split_by_phase_in_proportion():
    bars = _Bars()
    bars.add(0, 10.0, 20.0, "brick", PhaseTimes(transit=3.0, waiting=1.0))  # 4 s reported over a 20 s bar
    assert bars.segments == {
        (0, PHASE_COLOURS["transit"]): [(10.0, 15.0)],
        (0, PHASE_COLOURS["waiting"]): [(25.0, 5.0)],
    }
    assert bars.outlines == {0: [(10.0, 20.0)]} and bars.phases == {"transit", "waiting"} and not bars.kinds
    bars.add(1, 0.0, 5.0, "adhesion", None)
    assert bars.segments[(1, "#4f81bd")] == [(0.0, 5.0)] and bars.kinds == {"adhesion"}


def test_the_gantt_chart_draws_the_phases_with_a_legend(case_study, tmp_path):
    _, report = case_study
    out = draw_gantt(report, tmp_path / "g.svg")
    svg = out.read_text()
    drawn = {p for a in report.attempts if a.phases for p, s in a.phases.items() if s > 0}
    assert {"transit", "waiting", "spraying", "placing"} <= drawn
    for phase in drawn:
        assert f">{phase}<" in svg or f"<!-- {phase} -->" in svg, phase
    assert "no phases" not in svg
    # a report whose attempts carry no phases is drawn by task kind, as before
    bare = dataclasses.replace(
        report, attempts=tuple(dataclasses.replace(a, phases=None) for a in report.attempts)
    )
    svg = draw_gantt(bare, tmp_path / "bare.svg").read_text()
    assert "brick (no phases)" in svg and "transit" not in svg
