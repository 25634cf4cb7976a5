"""benchmarks/bench_speed.py's ``--occupancy`` count: it reads the UAVs at each control tick and changes nothing."""

from __future__ import annotations

from collections import Counter

from benchmark_module import benchmark
from masonry.blueprint_gen import running_bond
from masonry.mission.sim_loop import CONTROL_PERIOD_S
from masonry.mission.simulate import SimulatedMission, simulate
from test_behaviour_pinned import schedule_digest


def _bench_speed():
    return benchmark("bench_speed")


def test_the_occupancy_count_reads_every_live_uav_at_every_tick_and_leaves_the_mission_as_it_was():
    bench = _bench_speed()
    bp = running_bond(1, 3, brick_uavs=1, adhesion_uavs=1)
    mission = SimulatedMission.from_blueprint(bp, seed=2)
    counts: Counter = Counter()
    mission.tick_hooks.append(bench.occupancy_hook(mission, counts))
    report = mission.run()
    plain = simulate(bp, seed=2)
    assert report.completed and plain.completed
    assert schedule_digest(report) == schedule_digest(plain)
    assert report.min_separation_m == plain.min_separation_m
    # one count per UAV per control tick (the last tick, at the loop's end, is counted too)
    ticks = round(report.sim_time_s / CONTROL_PERIOD_S) + 1
    assert sum(counts.values()) == 2 * ticks
    kinds = Counter()
    for (kind, role, _state, _transit), n in counts.items():
        assert role in ("brick", "adhesion")
        kinds[kind] += n
    assert set(kinds) <= {"landed, motors off", "waiting in the air", "flying or working"}
    # both start on their pads, motors off, and both fly their tasks
    assert kinds["landed, motors off"] > 0 and kinds["flying or working"] > 0
    assert counts[("landed, motors off", "brick", "idle", "clear")] > 0
