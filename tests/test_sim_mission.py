"""Whole missions in simulated time (World + state machines + mission control + in-process transport)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import running_bond, towers
from masonry.errors import InputError, JournalError
from masonry.mission.simulate import fleet_for, simulate
from masonry.ports import PHASES
from masonry.sim import Faults

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"

REPORT_KEYS = [
    "completed",
    "makespan_s",
    "lower_bound_s",
    "lower_bound_kind",
    "policy",
    "seed",
    "uavs",
    "tasks",
    "placement_error_m",
    "as_built",
    "min_separation_m",
    "envelope_excursion",
    "conflict_violations",
    "dependency_violations",
]


@pytest.fixture(scope="module")
def case_study():
    return simulate(load_blueprint(CASE_STUDY), reservation="task")  # the paper's rule (Section VI)


def test_case_study_follows_the_paper(case_study):
    """Section VI: A0 first; then B0 while A1 waits for the clearance; then A1; then B1."""
    r = case_study
    assert r.completed
    order = [t.id for t in sorted(r.tasks, key=lambda t: t.start_s)]
    assert order == ["A0", "B0", "A1", "B1"]
    by_id = {t.id: t for t in r.tasks}
    # B0 starts when A0 completes; A1 (dependency-free from the start) waits until B0 is done
    assert by_id["B0"].start_s == pytest.approx(by_id["A0"].end_s, abs=0.2)
    assert by_id["A1"].start_s >= by_id["B0"].end_s
    assert by_id["B1"].start_s >= by_id["A1"].end_s
    assert [a.task_id for a in r.attempts] == order  # no failed attempt on the happy path
    assert r.conflict_violations == 0 and r.dependency_violations == 0


def test_case_study_report_is_the_exact_json(case_study):
    d = json.loads(case_study.to_json())
    assert list(d) == REPORT_KEYS
    assert d["policy"] == "critical-path" and d["seed"] == 0 and d["completed"] is True
    assert [list(u) for u in d["uavs"]] == [
        [
            "name",
            "role",
            "busy_s",
            "idle_s",
            "waiting_s",
            "waiting_ground_s",
            "waiting_air_s",
            "lingering_s",
            "lingers",
            "distance_m",
            "status",
        ]
    ] * 2
    assert {u["name"]: (u["role"], u["status"]) for u in d["uavs"]} == {
        "brick-1": ("brick", "ok"),
        "glue-1": ("adhesion", "ok"),
    }
    assert all(
        list(t)
        == [
            "id",
            "uav",
            "start_s",
            "end_s",
            "site_start_s",
            "site_end_s",
            "status",
            "attempts",
            "attempts_detail",
            "phases",
            "waits",
        ]
        for t in d["tasks"]
    )
    # each task's site interval lies within its run (a UAV asks to leave once its task is done, or just after)
    assert all(t["start_s"] < t["site_start_s"] < t["site_end_s"] <= t["end_s"] + 5.0 for t in d["tasks"])
    assert all(list(t["phases"]) == list(PHASES) for t in d["tasks"])
    assert {t["id"] for t in d["tasks"]} == {"A0", "A1", "B0", "B1"}
    assert all(t["status"] == "done" and t["attempts"] == 1 for t in d["tasks"])
    assert set(d["placement_error_m"]) == {"B0", "B1"}
    assert all(0.0 <= e < 0.03 for e in d["placement_error_m"].values())
    assert 0 < d["lower_bound_s"] <= d["makespan_s"]
    assert d["makespan_s"] == max(t["end_s"] for t in d["tasks"])
    assert d["min_separation_m"] > 0
    for u in d["uavs"]:
        assert u["busy_s"] > 0 and u["distance_m"] > 0


def test_case_study_is_deterministic(case_study):
    again = simulate(load_blueprint(CASE_STUDY), reservation="task")
    assert again.to_json() == case_study.to_json()


def test_case_study_with_site_intervals_overlaps_what_the_paper_serialises(case_study):
    """``site`` (the default): brick-1 fetches B0 while A0 is sprayed, and A1 is sprayed while B0 is on its way;
    conflicting tasks never work at their sites at once. 87.8 s against the paper's rule's 106.0 s (112.4 s before
    its brick UAV waited near the wall for B1 instead of flying home: masonry.mission.linger; ``site`` unchanged)."""
    r = simulate(load_blueprint(CASE_STUDY))
    assert r.completed and (r.conflict_violations, r.dependency_violations) == (0, 0)
    by_id = {t.id: t for t in r.tasks}
    assert by_id["B0"].start_s < by_id["A0"].end_s  # fetched during A0
    assert by_id["B0"].site_start_s >= by_id["A0"].end_s  # ... and placed after it
    assert by_id["A1"].start_s < by_id["B0"].end_s  # A1 no longer waits for the whole of B0
    order = [t.id for t in sorted(r.tasks, key=lambda t: t.site_start_s)]
    assert order == ["A0", "A1", "B0", "B1"]
    assert r.makespan_s < 0.85 * case_study.makespan_s


@settings(max_examples=6, deadline=None)
@given(
    kind=st.sampled_from(["towers", "bond"]),
    size=st.integers(2, 3),
    nb=st.integers(1, 2),
    na=st.integers(1, 2),
    seed=st.integers(0, 1000),
    policy=st.sampled_from(["fifo", "critical-path", "nearest"]),
    grasp=st.sampled_from([0.0, 0.3]),
    lose_at=st.one_of(st.none(), st.floats(10.0, 80.0)),
)
def test_safety_invariants_over_random_walls_fleets_seeds_and_faults(
    kind, size, nb, na, seed, policy, grasp, lose_at
):
    if kind == "towers":
        bp = towers(2, size, spacing_m=2.0, brick_uavs=nb, adhesion_uavs=na)
    else:
        bp = running_bond(1, size + 1, brick_uavs=nb, adhesion_uavs=na)
    faults = Faults(grasp_failure=grasp, uav_loss_at_s={"brick-1": lose_at} if lose_at is not None else {})
    r = simulate(bp, policy=policy, seed=seed, faults=faults)
    assert r.conflict_violations == 0
    assert r.dependency_violations == 0
    done = Counter(a.task_id for a in r.attempts if a.status == "done")
    assert all(n == 1 for n in done.values()), f"a task completed twice: {done}"
    if r.completed:
        assert set(done) == {t.id for t in r.tasks}
    else:
        assert r.stuck and set(r.stuck) == {t.id for t in r.tasks} - set(done)
        assert "stuck" in r.to_dict()
    if lose_at is not None and r.makespan_s > lose_at + 6.0:
        assert {u.name: u.status for u in r.uavs}["brick-1"] == "lost"


def test_losing_the_only_brick_uav_leaves_the_mission_incomplete():
    bp = towers(1, 3, brick_uavs=1, adhesion_uavs=1)
    r = simulate(bp, faults=Faults.parse(["uav-loss=brick-1@30"]))
    d = r.to_dict()
    assert d["completed"] is False
    assert {u["name"]: u["status"] for u in d["uavs"]}["brick-1"] == "lost"
    assert d["stuck"] and all(t["status"] != "done" for t in d["tasks"] if t["id"].startswith("B"))


def test_fleet_override_adds_uavs_clear_of_each_other():
    bp = load_blueprint(CASE_STUDY)
    fleet = fleet_for(bp, brick_uavs=3, adhesion_uavs=2)
    assert [u.name for u in fleet] == ["brick-1", "brick-2", "brick-3", "glue-1", "glue-2"]
    homes = [u.home_m for u in fleet]
    assert all(
        ((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2) ** 0.5 >= bp.clearance_m
        for i, a in enumerate(homes)
        for b in homes[i + 1 :]
    )
    assert [u.name for u in fleet_for(bp, brick_uavs=0)] == ["glue-1"]


def test_bad_options_are_input_errors(tmp_path):
    bp = load_blueprint(CASE_STUDY)
    with pytest.raises(InputError, match="`policy`"):
        simulate(bp, policy="random")
    with pytest.raises(InputError, match="`camera`"):
        simulate(bp, camera="lidar")
    with pytest.raises(InputError, match="`resume` needs `journal_path`"):
        simulate(bp, resume=True)
    with pytest.raises(JournalError, match="no journal to resume from"):
        simulate(bp, resume=True, journal_path=tmp_path / "none.db")


def test_journal_refuses_to_restart_a_mission_without_resume(tmp_path):
    bp = load_blueprint(CASE_STUDY)
    j = tmp_path / "m.db"
    r = simulate(bp, journal_path=j)
    assert r.completed
    with pytest.raises(JournalError, match="already holds a mission"):
        simulate(bp, journal_path=j)
    # resuming a finished mission does nothing new and reports the same tasks
    again = simulate(bp, journal_path=j, resume=True)
    assert again.completed
    assert [(t.id, t.uav, t.start_s, t.end_s) for t in again.tasks] == [
        (t.id, t.uav, t.start_s, t.end_s) for t in r.tasks
    ]
    assert again.resumed_from_s == pytest.approx(r.makespan_s, abs=0.01)
