"""benchmarks/bench_brick_budget.py: the brick UAVs' budget adds up to the mission's makespan, term by term."""

from __future__ import annotations

from benchmark_module import benchmark
from masonry.blueprint_gen import running_bond
from masonry.mission.simulate import simulate


def _bench():
    return benchmark("bench_brick_budget")


def test_the_brick_budget_adds_up_to_the_makespan_and_counts_every_brick():
    bench = _bench()
    bp = running_bond(2, 6, placed_courses=1, brick_uavs=2, adhesion_uavs=1)
    report = simulate(bp, seed=1, camera="geometric", reservation="site")
    assert report.completed
    b = bench.budget(report)
    assert b.uavs == 2
    assert b.bricks == sum(1 for t in report.tasks if t.kind == "brick" and t.status == "done")
    parts = b.start_s + b.work_s + b.holds_s + b.swaps_s + b.between_s + b.tail_s
    assert abs(parts - report.makespan_s) < 1.0
    assert b.work_s > 0 and b.start_s > 0
    # the what-if with the run's own holds per brick is the run
    assert abs(b.with_holds_per_brick(b.holds_per_brick_s) - parts) < 1e-6
    holds = bench.brick_holds(report)
    named = sum(v for k, v in holds.items() if "/" in k)
    assert abs(named - (holds["first"] + holds["later"])) < 1e-6
    lines = bench.budget_lines([("2 + 1", 1, b)])
    assert len(lines) == 3 and lines[2].startswith("| 2 + 1 | 1 |")
