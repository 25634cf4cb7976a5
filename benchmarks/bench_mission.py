"""Mission simulation benchmarks (policies, separation, gusts): prints its figures, asserts nothing.

1. Makespan / lower bound for each dispatch policy on a few walls and fleets, with what the bound leaves out:
   the *clearance bound* (tasks that pairwise conflict, or are ordered by dependencies, can never run at the
   same time: the heaviest such set, found greedily, is serialised whatever the policy).
2. Wind gusts: ``masonry fly --sim`` (one UAV, one task of the paper's case study) over seeds, per gust strength:
   success rate, placement error (brick) or coverage (adhesion), task duration.
3. A 1,000-brick running bond (20 courses x 50 bricks) with 4 brick and 2 adhesion UAVs, geometric camera:
   wall and CPU time of ``masonry.mission.simulate`` and the real-time factor.

Usage: python benchmarks/bench_mission.py [--quick] [--skip-big] [--skip-gusts] [--skip-policies] [--no-separation]
       [--courses C --per-course N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Iterable, Mapping

from masonry.blueprint_gen import running_bond, towers
from masonry.mission.simulate import simulate
from masonry.planner import plan as make_plan
from masonry.planner.bounds import lower_bound_s, min_durations_s
from masonry.planner.tasks import Plan


def clearance_bound_s(plan: Plan, durations_s: Mapping[str, float]) -> float:
    """Total duration of a heavy set of tasks no two of which may ever run together (a valid lower bound).

    Two tasks never overlap when they conflict (G^c) or when one depends on the other, directly or not (G^d's
    transitive closure). Any such set is serialised, so its total duration bounds the makespan. Greedy from
    every task: add its neighbours, longest first, while they are compatible with all already chosen.
    """
    todo = [t.id for t in plan.tasks if not t.done]
    index = {tid: i for i, tid in enumerate(todo)}
    n = len(todo)
    prereqs: list[list[int]] = [[] for _ in range(n)]
    for u, v in plan.dependencies:
        if u in index and v in index:
            prereqs[index[u]].append(index[v])
    adj = _exclusive_bits(_ancestor_bits(prereqs), plan.conflicts, index)
    weight = [float(durations_s[tid]) for tid in todo]
    best = 0.0
    for i in range(n):
        neigh = [j for j in range(n) if adj[i] >> j & 1]
        neigh.sort(key=lambda j: -weight[j])
        chosen = 1 << i
        total = weight[i]
        for j in neigh:
            if chosen & ~adj[j] == 0:
                chosen |= 1 << j
                total += weight[j]
        best = max(best, total)
    return best


def _ancestor_bits(prereqs: list[list[int]]) -> list[int]:
    """Per task, its prerequisites (direct or not) as an int bitset, from the direct ones (depth-first)."""
    n = len(prereqs)
    anc = [0] * n
    done = [False] * n
    for i in range(n):
        stack = [(i, False)]
        while stack:
            j, expanded = stack.pop()
            if done[j]:
                continue
            if expanded:
                bits = 0
                for p in prereqs[j]:
                    bits |= anc[p] | (1 << p)
                anc[j] = bits
                done[j] = True
            else:
                stack.append((j, True))
                stack.extend((p, False) for p in prereqs[j] if not done[p])
    return anc


def _exclusive_bits(
    anc: list[int], conflicts: Iterable[tuple[str, str]], index: Mapping[str, int]
) -> list[int]:
    """Per task, the tasks it may never run with as an int bitset: its conflicts, ancestors and descendants."""
    n = len(anc)
    adj = [0] * n
    for a, b in conflicts:
        if a in index and b in index:
            ia, ib = index[a], index[b]
            adj[ia] |= 1 << ib
            adj[ib] |= 1 << ia
    for i in range(n):
        bits = anc[i]
        adj[i] |= bits
        j = 0
        while bits:
            if bits & 1:
                adj[j] |= 1 << i
            bits >>= 1
            j += 1
    return adj


def _sep(separation: bool) -> dict[str, bool]:
    """``separation=False`` for simulate() when asked (and when this version of simulate has the option)."""
    import inspect

    return (
        {}
        if separation or "separation" not in inspect.signature(simulate).parameters
        else {"separation": False}
    )


def policies(quick: bool, separation: bool) -> None:
    walls = [
        ("paper case study, 1+1", None),
        ("running bond 2x8, 2+1", running_bond(2, 8, brick_uavs=2, adhesion_uavs=1)),
        ("towers 3x3 (2 m apart), 3+2", towers(3, 3, spacing_m=2.0, brick_uavs=3, adhesion_uavs=2)),
    ]
    if not quick:
        walls += [
            ("running bond 3x12, 4+2", running_bond(3, 12, brick_uavs=4, adhesion_uavs=2)),
            ("running bond 2x30, 2+1", running_bond(2, 30, brick_uavs=2, adhesion_uavs=1)),
            ("running bond 4x25, 4+2", running_bond(4, 25, brick_uavs=4, adhesion_uavs=2)),
            ("running_bond_200.yaml, 3+2", "running_bond_200.yaml"),
        ]
    print(
        f"makespan / lower bound per policy (seed 0, separation {'on' if separation else 'off'}); "
        "clearance = serialised-set bound (see the docstring)"
    )
    print(
        f"  {'wall':<30} {'policy':<14} {'makespan':>9} {'bound0':>7} {'bound':>7} {'ratio':>6} {'clearance':>9} "
        f"{'ratio*':>6} {'done':>7} {'wall s':>7} {'cpu s':>6}"
    )
    for label, bp in walls:
        if bp is None or isinstance(bp, str):
            from masonry.blueprint import load_blueprint

            bp = load_blueprint(
                os.path.join(os.path.dirname(__file__), "..", "blueprints", bp or "paper_case_study.yaml")
            )
        p = make_plan(bp)
        minimum = min_durations_s(p, cruise_altitude_m=bp.cruise_altitude_m)
        clear = clearance_bound_s(p, minimum)
        bound0 = lower_bound_s(p, bp.fleet, minimum)  # without the approach flights (min_cycles_s)
        for policy in ("fifo", "critical-path", "nearest"):
            t0, c0 = time.perf_counter(), time.process_time()
            r = simulate(bp, policy=policy, **_sep(separation))
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            both = max(r.lower_bound_s, clear)
            print(
                f"  {label:<30} {policy:<14} {r.makespan_s:9.1f} {bound0:7.1f} {r.lower_bound_s:7.1f} "
                f"{r.makespan_s / max(r.lower_bound_s, 1e-9):6.2f} {clear:9.1f} {r.makespan_s / both:6.2f} "
                f"{sum(t.status == 'done' for t in r.tasks):3d}/{len(r.tasks):<3d} {wall:7.1f} {cpu:6.1f}"
            )
    print(
        "  bound0 = lower_bound_s over min_durations_s only (before min_cycles_s); bound = the report's "
        "lower_bound_s (role term over min_cycles_s); ratio = makespan / bound; ratio* = makespan / max(bound, "
        "clearance); an incomplete run (done < all) has a meaningless makespan"
    )


def gusts(seeds: int) -> None:
    from masonry.blueprint import load_blueprint
    from masonry.fsm import UavConfig, fly_task
    from masonry.sim import Faults, World

    bp = load_blueprint(os.path.join(os.path.dirname(__file__), "..", "blueprints", "paper_case_study.yaml"))
    p = make_plan(bp)
    print(
        f"gusts: one task of the paper's case study, {seeds} seeds each (masonry fly --sim --fault gusts=S)"
    )
    print(
        f"  {'task':<5} {'gusts m/s':>9} {'done':>6} {'error/coverage mean':>20} {'max':>7} {'duration s':>10}  failures"
    )
    for task_id in ("B0", "A0"):
        task = p.task(task_id)
        for g in (0.0, 0.5, 1.0, 1.5, 2.0):
            ok, values, durations, reasons = 0, [], [], {}
            for seed in range(seeds):
                world = World(bp, seed=seed, faults=Faults(gusts_mps=g))
                uav = world.add_uav(next(u for u in bp.fleet if u.role == task.kind))
                cfg = UavConfig.from_spec(
                    uav.spec, cruise_altitude_m=bp.cruise_altitude_m, markers=bp.markers
                )
                run = fly_task(
                    cfg,
                    task,
                    fc=uav.fc,
                    clock=world.clock,
                    gripper=uav.gripper,
                    camera=uav.camera,
                    sprayer=uav.sprayer,
                    advance=world.step,
                )
                res = run.result
                if res is not None and res.status == "done":
                    ok += 1
                    durations.append(res.duration_s)
                    values.append(
                        world.placement_error_m(task.brick)
                        if task.kind == "brick"  # type: ignore[union-attr]
                        else world.coverage(task)
                    )  # type: ignore[arg-type]
                else:
                    why = res.reason if res is not None else "no result"
                    why = why.split(" of ")[0].split(" brick ")[0].split(" over ")[0]
                    reasons[why] = reasons.get(why, 0) + 1
            unit = "mm" if task.kind == "brick" else ""
            scale = 1000.0 if task.kind == "brick" else 1.0
            mean = f"{statistics.mean(values) * scale:.{1 if unit else 2}f} {unit}" if values else "-"
            worst = (
                f"{(max(values) if unit else min(values)) * scale:.{1 if unit else 2}f}" if values else "-"
            )
            dur = f"{statistics.mean(durations):.1f}" if durations else "-"
            print(
                f"  {task_id:<5} {g:9.1f} {ok:3d}/{seeds:<2d} {mean:>20} {worst:>7} {dur:>10}  {reasons or ''}"
            )
    print("  (brick: placement error, max; adhesion: coverage, min)")


def big_wall(courses: int, per_course: int, separation: bool) -> None:
    bp = running_bond(courses, per_course, brick_uavs=4, adhesion_uavs=2)
    t0, c0 = time.perf_counter(), time.process_time()
    r = simulate(bp, camera="geometric", **_sep(separation))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    done = sum(1 for t in r.tasks if t.status == "done")
    print(
        f"running bond {courses}x{per_course} = {len(bp.bricks)} bricks, 4 brick + 2 adhesion UAVs, geometric camera, "
        f"separation {'on' if separation else 'off'}"
    )
    print(f"  tasks done {done}/{len(r.tasks)}, completed {r.completed}")
    print(
        f"  simulated {r.sim_time_s:.0f} s in {wall:.1f} s wall ({cpu:.1f} s CPU; load average before "
        f"{_load_before:.1f}): real-time factor x{r.sim_time_s / wall:.0f} (x{r.sim_time_s / cpu:.0f} per CPU second)"
    )
    print(
        f"  makespan {r.makespan_s:.0f} s, lower bound {r.lower_bound_s:.0f} s, "
        f"ratio {r.makespan_s / max(r.lower_bound_s, 1e-9):.2f}"
    )
    print(
        f"  messages {r.messages}, violations: conflict {r.conflict_violations}, "
        f"dependency {r.dependency_violations}, min separation {r.min_separation_m}"
    )


_load_before = 0.0


def main() -> None:
    global _load_before  # noqa: PLW0603 - the load before the run, printed beside every figure
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer policy walls, fewer gust seeds")
    ap.add_argument("--skip-big", action="store_true", help="skip the 1,000-brick wall")
    ap.add_argument("--skip-gusts", action="store_true")
    ap.add_argument("--skip-policies", action="store_true")
    ap.add_argument(
        "--no-separation",
        action="store_true",
        help="simulate(separation=False): no transit layers or site columns (docs/safety.md)",
    )
    ap.add_argument("--courses", type=int, default=20)
    ap.add_argument("--per-course", type=int, default=50)
    args = ap.parse_args()
    if not args.skip_big:
        _load_before = os.getloadavg()[0]
        big_wall(args.courses, args.per_course, not args.no_separation)
    if not args.skip_policies:
        policies(args.quick, not args.no_separation)
    if not args.skip_gusts:
        gusts(4 if args.quick else 10)


if __name__ == "__main__":
    main()
