"""CPU cost per simulated second of a whole mission: prints its figures, asserts nothing.

Runs ``masonry.mission.simulate`` on a running bond (geometric camera, no faults) and prints CPU (process) time,
wall time, simulated time, real-time factors and the behaviour figures to compare before/after a speed-up
(makespan, tasks done, min separation, envelope excursion, mean placement error, a digest of the task schedule).

``--occupancy`` also prints what the UAVs do at their control ticks (a tick hook, which only reads): the share of
UAV ticks landed with the motors off, waiting in the air for clearance (the transit's ``ask`` or ``hold``), and
the rest, then the most frequent (role, state, transit) triples: where an idle UAV could be skipped.

Usage: python benchmarks/bench_speed.py [--courses 6] [--per-course 50] [--brick-uavs 4] [--adhesion-uavs 2]
       [--seed 0] [--no-separation] [--profile FILE.prof] [--occupancy]
"""

from __future__ import annotations

import argparse
import hashlib
import statistics
import time
from collections import Counter
from collections.abc import Callable

from masonry.blueprint_gen import running_bond
from masonry.mission.simulate import SimulatedMission

#: A UAV tick's class, role, state and transit phase (:func:`occupancy_hook`).
TickKind = tuple[str, str, str, str]


def occupancy_hook(mission: SimulatedMission, counts: Counter[TickKind]) -> Callable[[float], None]:
    """A tick hook counting each live UAV's tick by what it does then: landed with its motors off, waiting in the
    air for clearance, or anything else (flying, working, climbing), with its role, state and transit phase."""

    def hook(now_s: float) -> None:
        for name, h in mission.handlers.items():
            model = h.model
            if name in mission.dead or model is None:
                continue
            vehicle = mission.world.uavs[name].vehicle
            transit = str(model.transit.state)
            if vehicle.on_ground and not vehicle.armed:
                kind = "landed, motors off"
            elif transit in ("ask", "hold"):
                kind = "waiting in the air"
            else:
                kind = "flying or working"
            counts[(kind, mission.world.uavs[name].role, str(model.state), transit)] += 1

    return hook


def print_occupancy(counts: Counter[TickKind]) -> None:
    total = sum(counts.values())
    kinds: Counter[str] = Counter()
    for (kind, *_), n in counts.items():
        kinds[kind] += n
    print(f"  UAV ticks {total}: " + ", ".join(f"{k} {n / total:.1%}" for k, n in kinds.most_common()))
    for (kind, role, state, transit), n in counts.most_common(12):
        print(f"    {n / total:6.1%}  {role:8s} {state:16s} transit {transit:6s} ({kind})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--courses", type=int, default=6)
    ap.add_argument("--per-course", type=int, default=50)
    ap.add_argument("--brick-uavs", type=int, default=4)
    ap.add_argument("--adhesion-uavs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-separation", action="store_true")
    ap.add_argument("--profile", default=None, help="write a cProfile of the run to this file")
    ap.add_argument("--occupancy", action="store_true", help="count what the UAVs do at their ticks")
    args = ap.parse_args()
    bp = running_bond(
        args.courses, args.per_course, brick_uavs=args.brick_uavs, adhesion_uavs=args.adhesion_uavs
    )
    kwargs = {"camera": "geometric", "seed": args.seed, "separation": not args.no_separation}
    cpu0, wall0 = time.process_time(), time.perf_counter()
    mission = SimulatedMission.from_blueprint(bp, **kwargs)  # (what ``simulate`` runs)
    counts: Counter[TickKind] = Counter()
    if args.occupancy:
        mission.tick_hooks.append(occupancy_hook(mission, counts))
    if args.profile:
        import cProfile

        prof = cProfile.Profile()
        report = prof.runcall(mission.run)
        prof.dump_stats(args.profile)
    else:
        report = mission.run()
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    done = sum(1 for t in report.tasks if t.status == "done")
    errs = list(report.placement_error_m.values())
    sched = ";".join(f"{t.id},{t.uav},{t.start_s:.2f},{t.end_s}" for t in report.tasks)
    print(
        f"wall {args.courses}x{args.per_course}, {args.brick_uavs}+{args.adhesion_uavs} UAVs, seed {args.seed}, "
        f"separation {'off' if args.no_separation else 'on'}"
    )
    print(
        f"  completed {report.completed}, tasks done {done}/{len(report.tasks)}, makespan {report.makespan_s:.1f} s, "
        f"simulated {report.sim_time_s:.1f} s, messages {report.messages}"
    )
    print(
        f"  min_separation_m {report.min_separation_m}, placement error mean "
        f"{statistics.fmean(errs) if errs else float('nan'):.5f} m, "
        f"violations {report.conflict_violations}/{report.dependency_violations}"
    )
    if report.envelope_excursion is not None:
        print(
            f"  {report.envelope_excursion.line()}, positions looked at {mission.envelope.looks if mission.envelope else 0}"
        )
    print(f"  schedule digest {hashlib.sha1(sched.encode()).hexdigest()[:12]}")
    print(
        f"  CPU {cpu:.2f} s, wall {wall:.2f} s, real-time factor x{report.sim_time_s / cpu:.0f} (CPU), "
        f"x{report.sim_time_s / wall:.0f} (wall), {cpu / report.sim_time_s * 1e3:.2f} ms CPU per simulated s"
    )
    if args.occupancy:
        print_occupancy(counts)


if __name__ == "__main__":
    main()
