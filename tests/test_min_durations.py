"""min_durations_s: per-task durations for the makespan lower bound that the state machines can never beat."""

from __future__ import annotations

import dataclasses

import pytest

from masonry.blueprint_gen import running_bond, towers
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
