"""min_durations_s: per-task durations for the makespan lower bound that the state machines can never beat."""

from __future__ import annotations

import dataclasses

import pytest

from masonry.blueprint_gen import running_bond, towers
from masonry.fsm import UavConfig
from masonry.mission.simulate import simulate
from masonry.planner import plan
from masonry.planner.bounds import estimate_durations_s, min_durations_s
from masonry.planner.tasks import AdhesionTask


@pytest.mark.parametrize(
    ("blueprint", "seed"),
    [
        (running_bond(2, 8, brick_uavs=2, adhesion_uavs=1), 0),
        (running_bond(2, 8, brick_uavs=2, adhesion_uavs=1), 1),
        (towers(2, 2, spacing_m=2.0, brick_uavs=2, adhesion_uavs=1), 0),
    ],
)
def test_no_simulated_task_is_faster_than_its_minimum(blueprint, seed) -> None:
    report = simulate(blueprint, seed=seed)
    assert report.completed
    minimum = min_durations_s(plan(blueprint), cruise_altitude_m=blueprint.cruise_altitude_m)
    for t in report.tasks:
        assert t.end_s is not None and t.start_s is not None
        assert t.end_s - t.start_s >= minimum[t.id], (t.id, t.end_s - t.start_s, minimum[t.id])
    assert report.lower_bound_s <= report.makespan_s


@pytest.mark.slow
def test_chained_adhesion_tasks_keep_to_their_minimum() -> None:
    """On a longer wall adhesion UAVs chain segments (no climb out, a short descent): those tasks, the shortest
    of all, still never beat their minimum.

    4 courses of 12 with one adhesion UAV chain 10 of their 69 segments on the default (arducopter) vehicle
    (6-11 over seeds 0-2; with two adhesion UAVs 2-7, fewer in a row for each): enough to show it.
    """
    blueprint = running_bond(4, 12, brick_uavs=4, adhesion_uavs=1)
    report = simulate(blueprint, seed=0, reservation="task")  # fewer with ``site``: fewer segments in a row
    assert report.completed
    p = plan(blueprint)
    minimum = min_durations_s(p, cruise_altitude_m=blueprint.cruise_altitude_m)
    kinds = {t.id: t.kind for t in p.tasks}
    durations = {t.id: t.end_s - t.start_s for t in report.tasks}
    cfg = UavConfig("glue-1", "adhesion", (0.0, 0.0, 0.0))
    # an unchained task takes at least a leg, the hover and the whole descent, before spraying anything
    unchained_s = 1.0 + cfg.stable_time_s + cfg.spray_descent_s
    chained = [k for k, d in durations.items() if kinds[k] == "adhesion" and d < unchained_s]
    assert len(chained) >= 5
    for k, d in durations.items():
        assert d >= minimum[k], (k, d, minimum[k])


def test_minimum_grows_with_the_work() -> None:
    bp = running_bond(2, 4, brick_uavs=1, adhesion_uavs=1)
    p = plan(bp)
    base = min_durations_s(p)
    seg = next(t for t in p.tasks if isinstance(t, AdhesionTask))
    longer = dataclasses.replace(seg, length_m=seg.length_m + 0.3)
    p2 = dataclasses.replace(p, tasks=tuple(longer if t.id == seg.id else t for t in p.tasks))
    assert min_durations_s(p2)[seg.id] == pytest.approx(base[seg.id] + 0.3 / 0.15)
    # a higher transit altitude only lengthens the climbs
    assert all(v >= base[k] for k, v in min_durations_s(p, cruise_altitude_m=2.0).items())
    assert set(base) == set(estimate_durations_s(p, bp.fleet)) == {t.id for t in p.tasks if not t.done}


def _cases():
    from masonry.sim import Faults

    small = running_bond(2, 5, brick_uavs=2, adhesion_uavs=1)
    tower = towers(2, 2, spacing_m=2.0, brick_uavs=2, adhesion_uavs=1)
    return [
        pytest.param(small, 0, False, None, id="bond-2x5-seed0-nosep"),
        pytest.param(small, 1, True, None, id="bond-2x5-seed1-sep"),
        pytest.param(small, 2, False, Faults(grasp_failure=0.3), id="bond-2x5-seed2-nosep-grasp0.3"),
        pytest.param(small, 3, True, Faults(grasp_failure=0.3), id="bond-2x5-seed3-sep-grasp0.3"),
        pytest.param(tower, 4, False, Faults(grasp_failure=0.3), id="towers-seed4-nosep-grasp0.3"),
        pytest.param(tower, 5, True, None, id="towers-seed5-sep"),
    ]


@pytest.mark.parametrize(("blueprint", "seed", "separation", "faults"), _cases())
def test_timeline_never_beats_the_cycles(blueprint, seed, separation, faults) -> None:
    """What the bound assumes per UAV: each completed task, with the stretch since that UAV's previous completed
    task (or the mission's start), lasts at least its cycle; each task at least its minimum duration; so the
    makespan is never below the bound (with faults too: failed attempts only add time)."""
    from masonry.planner.bound_terms import bound_terms
    from masonry.planner.bounds import lower_bound_s, min_cycles_s

    # the paper's reservation: its clique term weighs whole tasks (under ``site``, their site parts)
    report = simulate(blueprint, seed=seed, separation=separation, faults=faults, reservation="task")
    assert report.completed
    p = plan(blueprint)
    minimum = min_durations_s(p, cruise_altitude_m=blueprint.cruise_altitude_m)
    cycles = min_cycles_s(p, blueprint.fleet, minimum)
    assert all(cycles[k] >= minimum[k] for k in minimum)
    assert any(cycles[k] > minimum[k] for k in minimum)  # the approach term is not empty on these walls
    start = min(a.start_s for a in report.attempts)
    by_uav: dict[str, list] = {}
    for t in report.tasks:
        assert t.end_s - t.start_s >= minimum[t.id], (t.id, t.end_s - t.start_s, minimum[t.id])
        by_uav.setdefault(t.uav, []).append(t)
    for uav, done in by_uav.items():
        previous = start
        for t in sorted(done, key=lambda t: t.end_s):
            assert t.end_s - previous >= cycles[t.id], (uav, t.id, t.end_s - previous, cycles[t.id])
            previous = t.end_s
    bound = lower_bound_s(p, blueprint.fleet, minimum, work_s=cycles)
    # the report's bound is the best of its terms: these two and the exclusion clique (task reservation)
    terms = bound_terms(p, blueprint.fleet, minimum, work_s=cycles)
    assert report.lower_bound_s == pytest.approx(terms.value_s, abs=1e-6)
    assert report.lower_bound_kind == terms.kind
    assert bound <= terms.value_s <= report.makespan_s
    assert bound >= lower_bound_s(p, blueprint.fleet, minimum)
