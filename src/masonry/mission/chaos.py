"""A chaos campaign for whole missions: random walls, fleets and faults, mission control stopped and resumed.

:func:`random_chaos` draws one run: a random site (:func:`masonry.blueprint_random.random_layout`), a random mix
of the simulator's faults (grasp failures, detection dropouts, occlusion, gusts), UAVs lost at random times
(never every UAV of a role, unless ``lose_a_role``), mission links that drop for a few seconds, and one to three
abrupt stops of mission control at random simulated times. :func:`fly_chaos` flies it in-process
(:class:`masonry.mission.simulate.SimulatedMission`) with an SQLite journal: at each stop the mission is dropped
where it is, as by ``kill -9`` (the journal holds what was committed, nothing more: no end-of-run record), and
resumed from the journal in a rebuilt world. :func:`check_chaos` judges the whole run from the UAV handlers'
execution traces of every segment, not from mission control's bookkeeping: no task done twice, no conflict or
dependency violation, the separation kept, and the mission complete unless a role lost every UAV, or else
every task left named with why.

``benchmarks/bench_chaos.py`` runs the campaign and prints the table of docs/reliability.md;
``tests/test_chaos.py`` runs a few seeds of it in CI.
"""

from __future__ import annotations

import dataclasses
import math
import random
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from masonry.blueprint import Blueprint, Role
from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.mission.report import MissionReport
from masonry.mission.sim_options import SimOptions
from masonry.mission.simulate import SimulatedMission
from masonry.planner import plan as make_plan
from masonry.planner.tasks import BrickTask, Plan
from masonry.sim.glue import AT_PLACE_M

__all__ = [
    "CHAOS_LIMITS",
    "ChaosOutcome",
    "ChaosRun",
    "LinkDrop",
    "TraceEntry",
    "check_chaos",
    "fly_chaos",
    "random_chaos",
]

#: Small sites: a run costs seconds, and a campaign covers many of them.
CHAOS_LIMITS = LayoutLimits(max_courses=2, max_per_course=4, max_uavs_per_role=3)

#: The separation every whole-mission simulation keeps between two airborne UAVs (docs/safety.md).
SEPARATION_BOUND_M = 1.0


@dataclasses.dataclass(frozen=True)
class LinkDrop:
    """The mission link of ``uav`` (its radio to mission control) is down from ``at_s`` for ``for_s`` seconds."""

    uav: str
    at_s: float
    for_s: float


@dataclasses.dataclass(frozen=True)
class ChaosRun:
    """One run of the campaign: the site, the faults, when mission control stops (it is resumed each time)."""

    seed: int
    blueprint: Blueprint
    faults: Any  # masonry.sim.Faults
    stops_s: tuple[float, ...] = ()
    link_drops: tuple[LinkDrop, ...] = ()
    vehicle: str = "ideal"
    #: ``task`` (the paper's rule): the traces' task intervals are what the conflict check needs (under ``site``
    #: conflicting tasks may overlap; only their site intervals, mission control's record, may not)
    reservation: str = "task"
    #: mission control's airspace (``columns`` or ``table``, :mod:`masonry.mission.reserved`)
    airspace: str = "columns"

    def injected(self) -> dict[str, int]:
        """How many faults of each kind the run injects (the table's "faults injected")."""
        f = self.faults
        out = {
            "grasp": int(f.grasp_failure > 0),
            "dropout": int(f.dropout > 0),
            "occlusion": int(f.occlusion > 0),
            "gusts": int(f.gusts_mps > 0),
            "uav-loss": len(f.uav_loss_at_s),
            "link-drop": len(self.link_drops),
            "mc-kill": len(self.stops_s),
        }
        return {k: v for k, v in out.items() if v}

    def describe(self) -> str:
        """One line: the seed, the site and what is injected."""
        what = ", ".join(f"{k} {v}" for k, v in self.injected().items()) or "no fault"
        return f"seed {self.seed} {self.blueprint.name} ({len(self.blueprint.fleet)} UAVs, {self.vehicle}): {what}"


@dataclasses.dataclass(frozen=True)
class TraceEntry:
    """One task as a UAV flew it (its handler's execution), in one segment of the run between two stops."""

    segment: int
    uav: str
    task_id: str
    start_s: float
    end_s: float  # a task cut by a stop or by its UAV's loss ends then
    #: done, failed, or cut (stopped by a stop or by the UAV's loss); done too for a UAV lost after its release
    #: whose brick the world holds at its place (mission control marks that task done: ``placed_by_lost``), and
    #: for one cut by a stop after its release (the rebuilt world has the brick in place; mission control, told
    #: of the release, counts it done: branch ``resume50``)
    status: str
    #: the end of its work at the site: ``end_s``, or when it was abandoned (recalled, or mission control silent:
    #: the machine then puts the brick back on its pallet or flies home, away from the site)
    site_end_s: float = math.inf

    def __post_init__(self) -> None:
        object.__setattr__(self, "site_end_s", min(self.site_end_s, self.end_s))


@dataclasses.dataclass(frozen=True)
class ChaosOutcome:
    """What a run produced: the final report, every segment's trace, the lowest separation over all segments."""

    run: ChaosRun
    plan: Plan
    report: MissionReport
    trace: tuple[TraceEntry, ...]
    min_separation_m: float | None
    segments: int
    lost_uavs: tuple[str, ...]


def random_chaos(
    seed: int,
    *,
    vehicle: str = "ideal",
    limits: LayoutLimits = CHAOS_LIMITS,
    max_stops: int = 3,
    lose_a_role: bool = False,
    max_drop_s: float = 8.0,
    airspace: str = "columns",
) -> ChaosRun:
    """Draw one run of the campaign from ``seed`` (see the module docstring).

    Args:
        seed: seeds the site, the faults and the world.
        vehicle: the simulated autopilot (``ideal`` or ``arducopter``).
        limits: how large the sites get.
        max_stops: mission control stops one to this many times (0: never).
        lose_a_role: may lose every UAV of a role (then the report must say which tasks cannot be done).
        max_drop_s: a mission link drops for 1 s to this long (8: "a few seconds"; above ``LAST_RESORT_S``, 30, a
            UAV cut off flies home on its own).
        airspace: mission control's airspace (``columns`` or ``table``).
    """
    from masonry.planner import estimate_durations_s
    from masonry.sim import Faults

    rng = random.Random(seed)
    bp = random_layout(rng, limits)
    the_plan = make_plan(bp)
    expected = estimate_durations_s(the_plan, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m)
    roles: tuple[Role, ...] = ("brick", "adhesion")
    per_role = {r: len(bp.uavs(r)) for r in roles}
    # a rough makespan: each role's work over its UAVs (the faults happen while there is work)
    work = {r: sum(expected[t.id] for t in the_plan.tasks if t.kind == r and not t.done) for r in roles}
    span_s = max([60.0] + [work[r] / max(1, per_role[r]) for r in roles])
    spec = []
    if rng.random() < 0.6:
        spec.append(f"grasp={rng.uniform(0.05, 0.3):.2f}")
    if rng.random() < 0.6:
        spec.append(f"dropout={rng.uniform(0.05, 0.4):.2f}")
    if rng.random() < 0.6:
        spec.append(f"occlusion={rng.uniform(0.05, 0.4):.2f}")
    if rng.random() < 0.5:
        spec.append(f"gusts={rng.uniform(0.1, 0.5):.2f}")
    for role, n in per_role.items():
        names = [u.name for u in bp.uavs(role)]
        most = n if lose_a_role else n - 1
        for name in rng.sample(names, rng.randint(0, most)):
            if rng.random() < 0.7:
                spec.append(f"uav-loss={name}@{rng.uniform(5.0, span_s):.1f}")
    drops = tuple(
        LinkDrop(u.name, round(rng.uniform(5.0, span_s), 1), round(rng.uniform(1.0, max(1.0, max_drop_s)), 1))
        for u in bp.fleet
        if rng.random() < 0.3
    )
    n_stops = rng.randint(1, max_stops) if max_stops > 0 else 0
    stops = tuple(sorted(round(rng.uniform(3.0, span_s), 1) for _ in range(n_stops)))
    return ChaosRun(seed, bp, Faults.parse(spec), stops, drops, vehicle, airspace=airspace)


class _Stop(Exception):
    """Raised from a tick hook: mission control (and the whole in-process mission) stops here, as by kill -9."""


def fly_chaos(run: ChaosRun, workdir: str | Path) -> ChaosOutcome:
    """Fly ``run``: each stop drops the mission where it is, the next segment resumes from the journal.

    Args:
        run: what to fly and inject.
        workdir: a directory for the journal (``chaos-SEED.db``; an old one is removed first).
    """
    journal = Path(workdir) / f"chaos-{run.seed}.db"
    for p in (journal, journal.with_name(journal.name + "-wal"), journal.with_name(journal.name + "-shm")):
        p.unlink(missing_ok=True)
    trace: list[TraceEntry] = []
    seps: list[float] = []
    lost: set[str] = set()
    report: MissionReport | None = None
    segment = 0
    stops = list(run.stops_s)
    plan = make_plan(run.blueprint)
    while report is None:
        options = SimOptions(
            seed=run.seed + 7919 * segment,  # a restarted world does not replay the same noise
            journal_path=journal,
            resume=segment > 0,
            vehicle=run.vehicle,
            reservation=run.reservation,
            airspace=run.airspace,
        )
        mission = SimulatedMission.from_blueprint(run.blueprint, options, faults=run.faults)
        stop_s = stops.pop(0) if stops else None
        placed_at_death: dict[str, str] = {}
        mission.tick_hooks.append(_hook(mission, plan, run.link_drops, stop_s, placed_at_death))
        try:
            report = mission.run()
        except _Stop:
            placed_at_death.update(_placed_at_stop(mission, plan))
        now = mission.clock.now_s()
        for name, h in mission.handlers.items():
            for e in h.executions:
                end = e.end_s if e.end_s is not None else mission.dead.get(name, now)
                status = e.status if e.end_s is not None else "cut"
                if status == "cut" and placed_at_death.get(name) == e.task_id:
                    status = "done"  # its UAV died after the release: the world held its brick in place
                gone = e.abandoned_s if e.abandoned_s is not None else math.inf
                trace.append(TraceEntry(segment, name, e.task_id, e.start_s, end, status, gone))
        lost |= {n for n, link in mission.control.uavs.items() if link.lost}
        sep = mission.world.min_separation_m
        if sep is not None:
            seps.append(float(sep))
        segment += 1
    return ChaosOutcome(
        run, plan, report, tuple(trace), min(seps) if seps else None, segment, tuple(sorted(lost))
    )


def _on_the_wall(mission: SimulatedMission, plan: Plan, task_id: str) -> bool:
    """Whether the world holds the brick of brick task ``task_id`` at rest within ``AT_PLACE_M`` of its place."""
    task = next((t for t in plan.tasks if t.id == task_id), None)
    if not isinstance(task, BrickTask):
        return False
    brick = mission.world.field.bricks.get(task.spare if task.spare is not None else task.brick)
    return (
        brick is not None
        and brick.state == "placed"
        and math.dist(brick.position_m[:2], task.position_m[:2]) <= AT_PLACE_M
    )


def _placed_at_stop(mission: SimulatedMission, plan: Plan) -> dict[str, str]:
    """UAV -> the task it flew when mission control stopped, for each live UAV that had released that task's brick
    in this flight, the world holding it at its place: the stop cut the flight, the brick stays on the wall (the
    rebuilt world has it in place: ``masonry.mission.sim_resume``)."""
    out: dict[str, str] = {}
    for name, h in mission.handlers.items():
        running = [e for e in h.executions if e.end_s is None]
        uav = mission.world.uavs[name]
        if name in mission.dead or not running or uav.carried_brick is not None:
            continue
        e = running[-1]
        let_go = any(u == name and t >= e.start_s for t, u, _ in mission.world.releases)
        if let_go and _on_the_wall(mission, plan, e.task_id):
            out[name] = e.task_id
    return out


def _hook(
    mission: SimulatedMission,
    plan: Plan,
    drops: Sequence[LinkDrop],
    stop_s: float | None,
    placed_at_death: dict[str, str],
) -> Any:
    """The tick hook of one segment: link drops (cut, then restored) and the stop; ``placed_at_death`` gets, for
    each UAV as it dies, the task it flew if the world held that task's brick at its place then."""
    cut: set[str] = set()
    seen_dead: set[str] = set()
    carrying: dict[str, bool] = {}  # each live UAV's magnet held a brick at the tick before

    def hook(now_s: float) -> None:
        for name in mission.dead.keys() - seen_dead:
            seen_dead.add(name)
            running = [e.task_id for e in mission.handlers[name].executions if e.end_s is None]
            # released before it died, not a brick that fell with it
            if running and not carrying.get(name, False) and _on_the_wall(mission, plan, running[-1]):
                placed_at_death[name] = running[-1]
        for name, u in mission.world.uavs.items():
            if name not in seen_dead:
                carrying[name] = u.carried_brick is not None
        for d in drops:
            down = d.at_s <= now_s < d.at_s + d.for_s
            if down and d.uav not in cut:
                cut.add(d.uav)
                mission.bus.cut(d.uav)
            elif not down and d.uav in cut:
                cut.discard(d.uav)
                if d.uav not in mission.dead:  # a UAV that failed meanwhile stays silent
                    mission.bus.restore(d.uav)
        if stop_s is not None and now_s >= stop_s:
            raise _Stop(f"mission control stopped at {now_s:.1f} s")

    return hook


def check_chaos(outcome: ChaosOutcome) -> list[str]:
    """What went wrong in a run, one line each (empty: nothing), judged from the traces (module docstring).

    Each line starts with its kind: ``done twice``, ``conflict``, ``dependency``, ``separation``, ``report``
    (the report's done tasks are not the traces'), ``stall`` or ``unexplained`` (a task left undone, not said why).
    """
    problems: list[str] = []
    trace, the_plan, report = outcome.trace, outcome.plan, outcome.report
    done: dict[str, list[TraceEntry]] = {}
    for e in trace:
        if e.status == "done":
            done.setdefault(e.task_id, []).append(e)
    for tid, entries in sorted(done.items()):
        # done again after a completion its UAV could never report is not the system's doing: counted from the
        # first completion mission control could have heard of
        ordered = sorted(entries, key=lambda e: (e.segment, e.end_s))
        first = next((i for i, e in enumerate(ordered) if not _unheard(outcome.run, e)), len(ordered))
        if len(ordered) - first > 1:
            who = ", ".join(f"{e.uav} {e.start_s:.1f}-{e.end_s:.1f} s" for e in entries)
            problems.append(f"done twice: {tid} done {len(entries)} times: {who}")
    conflicts, deps = trace_violations(the_plan, trace)
    problems += [f"conflict: {c}" for c in conflicts] + [f"dependency: {d}" for d in deps]
    if outcome.min_separation_m is not None and outcome.min_separation_m < SEPARATION_BOUND_M - 1e-9:
        problems.append(f"separation: {outcome.min_separation_m:.3f} m < {SEPARATION_BOUND_M} m")
    reported = {t.id for t in report.tasks if t.status == "done"}
    if reported != set(done):
        problems.append(
            f"report: its done tasks differ from the traces': report only {sorted(reported - set(done))}, "
            f"traces only {sorted(set(done) - reported)}"
        )
    if report.stall is not None:
        problems.append(f"stall: {report.stall.get('line')}")
    if not report.completed:
        problems += _unexplained(outcome)
    return problems


def _unheard(run: ChaosRun, e: TraceEntry) -> bool:
    """Whether ``e``'s completion could never reach mission control: its UAV's link was down from before the
    completion until the UAV fell (no link carried it, and the UAV, and what it kept, are gone). Mission control
    rightly has such a task done again (its UAV lost, nothing said it was done): that is not a task done twice by
    the system's fault, so long as one other completion was heard (chaos seed 61, found once a fallen UAV stayed
    down in a rebuilt world)."""
    fell_s = run.faults.uav_loss_at_s.get(e.uav)
    if fell_s is None or fell_s < e.end_s:
        return False
    return any(d.uav == e.uav and d.at_s <= e.end_s and d.at_s + d.for_s > fell_s for d in run.link_drops)


def trace_violations(plan: Plan, trace: Sequence[TraceEntry]) -> tuple[list[str], list[str]]:
    """Conflicting tasks flown at once, and tasks started before a prerequisite was done, in ``trace``."""
    by_task: dict[str, list[TraceEntry]] = {}
    for e in trace:
        by_task.setdefault(e.task_id, []).append(e)
    conflicts = []
    for a, b in plan.conflicts:
        for ea in by_task.get(a, ()):
            for eb in by_task.get(b, ()):
                # segments do not share a world: a stop ends one, its resume rebuilds the next
                same = ea.segment == eb.segment
                if same and max(ea.start_s, eb.start_s) < min(ea.site_end_s, eb.site_end_s) - 1e-9:
                    conflicts.append(
                        f"{a} ({ea.uav} {ea.start_s:.1f}-{ea.site_end_s:.1f} s) and {b} "
                        f"({eb.uav} {eb.start_s:.1f}-{eb.site_end_s:.1f} s)"
                    )
    pre_done = {t.id for t in plan.tasks if t.done}
    # when each task was first done, as (segment, time): a resume's clock restarts from the journal's last
    # record, so a later segment may begin at an earlier time than the one before ended
    completed: dict[str, tuple[int, float]] = {}
    for e in trace:
        if e.status == "done":
            completed[e.task_id] = min(completed.get(e.task_id, (10**9, math.inf)), (e.segment, e.end_s))
    prereqs: dict[str, list[str]] = {}
    for u, v in plan.dependencies:
        prereqs.setdefault(u, []).append(v)
    deps = []
    for e in trace:
        if e.end_s <= e.start_s:
            continue  # refused at once: never in progress
        for v in prereqs.get(e.task_id, ()):
            if v not in pre_done and completed.get(v, (10**9, math.inf)) > (e.segment, e.start_s + 1e-9):
                deps.append(f"{e.task_id} started by {e.uav} at {e.start_s:.1f} s before {v} was done")
    return conflicts, deps


def _unexplained(outcome: ChaosOutcome) -> list[str]:
    """Tasks left undone that the report does not explain (a role without UAVs, or failed attempts with reasons)."""
    report = outcome.report
    fleet_roles = {u.name: u.role for u in outcome.run.blueprint.fleet}
    alive: set[str] = {fleet_roles[u.name] for u in report.uavs if u.status == "ok"}
    kinds = {t.id: t.kind for t in outcome.plan.tasks}
    failed = {a.task_id for a in report.attempts if a.status == "failed" and a.reason}
    stuck = {t.id for t in report.tasks if t.status == "stuck"}
    out = []
    for tid in report.stuck:
        if kinds[tid] not in alive:
            continue  # every UAV of its role is lost or out of service: the report's uavs say so
        if tid in stuck and tid in failed:
            continue  # its attempts ran out, each with the reason its UAV gave
        if tid in stuck and _waits_for_stuck(outcome.plan, tid, stuck | _role_less(outcome, alive)):
            continue  # a prerequisite can never be done
        if tid in stuck and set(fleet_roles.values()) - alive:
            continue  # the mission ended blocked for want of a role (the report's uavs say which): a lost UAV's
            # late result taken after the end may have freed it since
        out.append(f"unexplained: {tid} not done, and not said why (roles with a UAV left: {sorted(alive)})")
    return out


def _role_less(outcome: ChaosOutcome, alive: set[str]) -> set[str]:
    return {t.id for t in outcome.plan.tasks if t.kind not in alive}


def _waits_for_stuck(plan: Plan, task_id: str, blocked: set[str]) -> bool:
    prereqs: dict[str, list[str]] = {}
    for u, v in plan.dependencies:
        prereqs.setdefault(u, []).append(v)
    seen: set[str] = set()
    todo = list(prereqs.get(task_id, ()))
    while todo:
        v = todo.pop()
        if v in blocked:
            return True
        if v not in seen:
            seen.add(v)
            todo.extend(prereqs.get(v, ()))
    return False
