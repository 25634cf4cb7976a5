"""benchmarks/bench_site_chain.py: a mission's site visits laid end to end add up to its makespan, and every gap
second is put down to what the next visitor waited for."""

from __future__ import annotations

from benchmark_module import benchmark
from masonry.blueprint_gen import running_bond
from masonry.mission.simulate import simulate
from masonry.planner.schedule_values import OfflineSchedule, ScheduledTask, UavSchedule


def _bench():
    return benchmark("bench_site_chain")


def test_the_site_chain_adds_up_to_the_makespan_and_names_every_gap_second():
    bench = _bench()
    bp = running_bond(2, 6, placed_courses=1, brick_uavs=2, adhesion_uavs=1)
    report = simulate(bp, seed=1, camera="geometric", reservation="site")
    assert report.completed
    c = bench.chain(report)
    visited = [t for t in report.tasks if t.site_start_s is not None]
    assert sum(n for n, _ in c.visits.values()) == len(visited) == len(c.order)
    assert (
        abs(sum(s for _, s in c.visits.values()) - sum(t.site_end_s - t.site_start_s for t in visited)) < 1e-6
    )
    # first visit + the visits' union + the gaps: the span from the first visit's start to the last one's end
    last_end = max(t.site_end_s for t in visited)
    assert abs(c.first_s + c.union_s + c.gaps_s - last_end) < 1e-6
    assert c.union_s <= sum(s for _, s in c.visits.values()) + 1e-6
    assert abs(sum(c.by_transition.values()) - c.gaps_s) < 1e-6
    assert abs(sum(c.by_cause.values()) - c.gaps_s) < 1e-6
    assert c.switches == sum(1 for a, b in zip(c.order, c.order[1:]) if a != b)
    row = bench.chain_row("x", report.makespan_s, c)
    assert row.startswith("| x | ") and row.count("|") == 10


def _schedule(tasks: dict[str, list[ScheduledTask]]) -> OfflineSchedule:
    uavs = tuple(
        UavSchedule(n, "brick" if n.startswith("b") else "adhesion", tuple(ts)) for n, ts in tasks.items()
    )
    return OfflineSchedule(uavs, 14.0, 0.0, "none", "feasible", 0.0, "none", "site", 1.0, 0, 0.1)


def test_a_schedules_site_parts_laid_end_to_end():
    bench = _bench()
    s = _schedule(
        {
            "brick-1": [ScheduledTask("B0", 0.0, 6.0, 1.0, 5.0), ScheduledTask("B2", 6.0, 14.0, 10.0, 12.0)],
            "glue-1": [ScheduledTask("A1", 2.0, 9.0, 3.0, 8.0)],
        }
    )
    c = bench.schedule_chain(s)
    assert c.first_s == 1.0
    assert c.union_s == 9.0  # 1-8 and 10-12
    assert c.gaps_s == 2.0 and dict(c.by_transition) == {"adhesion>brick": 2.0}
    assert c.order == "BAB" and c.switches == 2
    assert c.visits == {"brick": (2, 6.0), "adhesion": (1, 5.0)}
    assert not c.by_cause
