"""The mission report: what ``masonry sim --format json`` prints, plus what the Gantt chart and 3-D plot need.

Where the time goes (docs/mission.md): every attempt carries the seconds its UAV spent in each phase
(:class:`~masonry.ports.PhaseTimes`), every task those of the attempt that completed it, every UAV its ``idle_s``
(mission time with no task assigned) and ``waiting_s`` (its attempts' ``waiting`` and ``holding`` phases).
The rows (per UAV, task and attempt) live in :mod:`masonry.mission.report_rows`.

Also the two checks the report carries, computed from a trace of executed intervals independently of the
dispatcher that produced it (:mod:`masonry.mission.trace_checks`), and the makespan lower bound.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from masonry.mission.as_built import as_built_lines
from masonry.mission.envelope import EnvelopeExcursion
from masonry.mission.report_rows import (
    AttemptReport,
    TaskReport,
    UavReport,
    _r,
    idle_s,
    makespan_s,
    phase_totals,
)
from masonry.mission.spares import SpareReport
from masonry.mission.trace_checks import count_site_violations, count_violations
from masonry.mission.waits import waiting_split_s, waits_lines, with_battery_holds
from masonry.perception.types import AsBuiltPose
from masonry.planner.bound_terms import bound_terms
from masonry.planner.tasks import Plan

#: Rows of the attempt trace in the text summary (the JSON report has every attempt).
TIMELINE_ROWS = 40


@dataclass(frozen=True)
class MissionReport:
    """The outcome of a mission; :meth:`to_dict` is the exact JSON of ``masonry sim --format json``."""

    completed: bool
    makespan_s: float
    lower_bound_s: float
    policy: str
    seed: int
    uavs: tuple[UavReport, ...]
    tasks: tuple[TaskReport, ...]
    placement_error_m: Mapping[str, float]
    min_separation_m: float | None
    conflict_violations: int
    dependency_violations: int
    stuck: tuple[str, ...] = ()
    attempts: tuple[AttemptReport, ...] = ()
    paths_m: Mapping[str, Any] = field(default_factory=dict)  # UAV name -> (n, 3) array of flown positions
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    #: the simulation's CPU time (process time, s): what the real-time factor costs on a shared machine
    cpu_time_s: float = 0.0
    resumed_from_s: float | None = None
    messages: int = 0
    #: the progress watchdog stopped the mission: who waited for whom (``masonry.mission.stall.Stall.to_dict``)
    stall: Mapping[str, Any] | None = None
    #: the term of the bound that won (``masonry.planner.bound_terms.KINDS``)
    lower_bound_kind: str = "role"
    #: ``--policy schedule``: assignments that were their UAV's next planned task, of all assignments
    schedule_followed: int | None = None
    schedule_assignments: int | None = None
    #: with an ``adhesive`` (measured by the simulated world, :mod:`masonry.sim.glue`): per brick task the age
    #: of the oldest glue under it when it was placed, and the bricks placed on expired glue / loaded uncured
    glue_age_s: Mapping[str, float] | None = None
    open_time_violations: int | None = None
    cure_time_violations: int | None = None
    #: the adhesive's open time (for the Gantt chart's open windows; not in the JSON)
    open_time_s: float | None = None
    #: with ``spares`` in the blueprint: which spare replaced which brick, the spares left, the bricks that wait
    #: for a person (:class:`masonry.mission.spares.SpareReport`); None: no spares key, none of these fields
    spares: SpareReport | None = None
    #: per brick task, the brick's pose as the UAV's camera saw it after the release (issue 30)
    as_built: Mapping[str, AsBuiltPose] = field(default_factory=dict)
    #: the world's worst excursion of a UAV out of its reserved envelope (:mod:`masonry.mission.envelope`); None:
    #: not measured (no simulated world, or an airspace without rules)
    envelope_excursion: EnvelopeExcursion | None = None

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall second."""
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf

    @property
    def cpu_real_time_factor(self) -> float:
        """Simulated seconds per second of CPU (process time)."""
        return self.sim_time_s / self.cpu_time_s if self.cpu_time_s > 0 else math.inf

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "completed": self.completed,
            "makespan_s": _r(self.makespan_s, 2),
            "lower_bound_s": _r(self.lower_bound_s, 2),
            "lower_bound_kind": self.lower_bound_kind,
            "policy": self.policy,
            "seed": self.seed,
            "uavs": [u.to_dict() for u in self.uavs],
            "tasks": [self._task_dict(t) for t in self.tasks],
            "placement_error_m": {k: _r(v, 4) for k, v in self.placement_error_m.items()},
            "as_built": {k: v.to_dict(4) for k, v in self.as_built.items()},
            "min_separation_m": _r(self.min_separation_m, 3),
            "envelope_excursion": None
            if self.envelope_excursion is None
            else self.envelope_excursion.to_dict(),
            "conflict_violations": self.conflict_violations,
            "dependency_violations": self.dependency_violations,
        }
        if not self.completed:
            out["stuck"] = list(self.stuck)
        if self.stall is not None:
            out["stall"] = dict(self.stall)
        if self.schedule_followed is not None:
            out["schedule"] = {"followed": self.schedule_followed, "assignments": self.schedule_assignments}
        if self.open_time_violations is not None:
            out["open_time_violations"] = self.open_time_violations
            out["cure_time_violations"] = self.cure_time_violations
        if self.spares is not None:
            out.update(self.spares.to_dict())
        return out

    def _task_dict(self, task: TaskReport) -> dict[str, Any]:
        out = task.to_dict()
        if self.glue_age_s is not None and task.kind == "brick":
            out["glue_age_s"] = _r(self.glue_age_s.get(task.id), 2)
        return out

    def to_json(self, indent: int | None = None) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    def timeline(self, most: int = TIMELINE_ROWS) -> list[str]:
        """The attempts in the order they started (the trace of the mission), at most ``most`` rows."""
        rows = sorted(self.attempts, key=lambda a: (a.start_s, a.task_id))
        lines = ["trace (attempts in start order):"]
        for a in rows[:most]:
            end = "..." if a.end_s is None else f"{a.end_s:7.1f} s"
            reason = f" ({a.reason})" if a.status == "failed" and a.reason else ""
            lines.append(f"  {a.start_s:7.1f} s -> {end}  {a.task_id:<6} {a.uav:<12} {a.status}{reason}")
        if len(rows) > most:
            lines.append(f"  ... {len(rows) - most} more (the JSON report and --gantt show them all)")
        return lines

    def stuck_why(self) -> list[str]:
        """Why each task left undone is: its last attempt's failure (a place taken, a brick off its course, the
        attempts used up), else what it waited for last (its prerequisite, the fleet): no mission ends stuck
        without saying why (issue 30)."""
        lines = []
        for t in self.tasks:
            if t.status == "done" or t.id not in self.stuck:
                continue
            last = t.tries[-1] if t.tries else None
            if last is not None and last.status == "failed" and last.reason:
                lines.append(f"  {t.id}: its attempt {len(t.tries)} failed: {last.reason}")
            elif t.waits:
                cause = t.waits[-1].cause
                on = f" {cause.blocking_task}" if cause.blocking_task else ""
                lines.append(f"  {t.id}: waits for {cause.what}{on}")
        return lines

    def summary(self) -> str:
        """A few human lines: outcome, makespan against the bound, fleet, checks."""
        done = sum(1 for t in self.tasks if t.status == "done")
        ratio = self.makespan_s / self.lower_bound_s if self.lower_bound_s > 0 else float("nan")
        lines = [
            (
                f"mission {'completed' if self.completed else 'NOT completed'}: {done}/{len(self.tasks)} task{'' if len(self.tasks) == 1 else 's'}, "
                f"policy {self.policy}, seed {self.seed}"
            ),
            f"makespan {self.makespan_s:.1f} s (lower bound {self.lower_bound_s:.1f} s, "
            f"{self.lower_bound_kind}, ratio {ratio:.2f})",
        ]
        if self.schedule_followed is not None:
            lines.append(
                f"schedule followed by {self.schedule_followed}/{self.schedule_assignments} assignments"
            )
        if self.open_time_violations is not None:
            ages = sorted((self.glue_age_s or {}).values())
            oldest = f", oldest glue under a brick {ages[-1]:.0f} s" if ages else ""
            lines.append(
                f"adhesive: {self.open_time_violations} open-time and {self.cure_time_violations} cure-time "
                f"violations{oldest}"
            )
        if self.resumed_from_s is not None:
            lines.append(f"resumed from the journal at {self.resumed_from_s:.1f} s")
        for u in self.uavs:
            lines.append(
                f"  {u.name:<12} {u.role:<8} busy {u.busy_s:7.1f} s  idle {u.idle_s:7.1f} s  "
                f"waiting {u.waiting_s:7.1f} s (air {u.waiting_air_s:.1f}, ground {u.waiting_ground_s:.1f})  "
                f"flown {u.distance_m:7.1f} m  {u.status}"
                + (f"  lingered {u.lingering_s:.0f} s ({u.lingers}x near the wall)" if u.lingers else "")
            )
        totals = phase_totals(self.attempts)
        if totals.total_s > 0:
            spent = ", ".join(f"{name} {sec:.0f} s" for name, sec in totals.items() if sec >= 0.5)
            lines.append(f"time per phase (every attempt): {spent}")
        lines.extend(waits_lines(w for t in self.tasks for w in t.waits))
        errs = list(self.placement_error_m.values())
        if errs:
            lines.append(
                f"placement error: mean {sum(errs) / len(errs) * 100:.1f} cm, max {max(errs) * 100:.1f} cm"
            )
        lines.extend(as_built_lines(self.as_built))
        sep = "n/a" if self.min_separation_m is None else f"{self.min_separation_m:.2f} m"
        if self.envelope_excursion is not None:
            sep += f", {self.envelope_excursion.line()}"
        lines.append(
            f"min separation {sep}; conflict violations {self.conflict_violations}, "
            f"dependency violations {self.dependency_violations}"
        )
        failures = sum(1 for a in self.attempts if a.status == "failed")
        if failures:
            lines.append(f"failed attempts: {failures}")
        lines.extend(self.timeline())
        lines.extend(self.spares.lines() if self.spares is not None else ())
        if not self.completed:
            lines.append(f"stuck: {', '.join(self.stuck) or '-'}")
            lines.extend(self.stuck_why())
        if self.stall is not None:
            lines.append(str(self.stall.get("line", "stalled")))
        if self.wall_time_s > 0:
            cpu = f", {self.cpu_time_s:.1f} s CPU" if self.cpu_time_s > 0 else ""
            cpu_x = f", x{self.cpu_real_time_factor:.0f} on CPU" if self.cpu_time_s > 0 else ""
            lines.append(
                f"simulated {self.sim_time_s:.1f} s in {self.wall_time_s:.1f} s wall{cpu} "
                f"(x{self.real_time_factor:.0f} real time on the wall clock{cpu_x})"
            )
        return "\n".join(lines)


def _until(link: Any, end_s: float) -> float:
    """The end of a UAV's part in the mission: ``end_s``, or its loss if sooner."""
    lost = getattr(link, "lost_at_s", None)
    return end_s if lost is None else min(end_s, float(lost))


def _by_task(attempts: Iterable[AttemptReport]) -> dict[str, list[AttemptReport]]:
    """Task id -> its attempts in their order (one pass, not one over all of them per task: 2,881 x 3,000 on the
    1,000-brick wall)."""
    out: dict[str, list[AttemptReport]] = {}
    for a in attempts:
        out.setdefault(a.task_id, []).append(a)
    return out


def control_report(
    mc: Any,
    plan: Plan,
    *,
    policy: str,
    seed: int = 0,
    intervals: Sequence[tuple[str, str, float, float | None]] | None = None,
    distances_m: Mapping[str, float] | None = None,
    placement_error_m: Mapping[str, float] | None = None,
    min_separation_m: float | None = None,
    now_s: float | None = None,
    durations_s: Mapping[str, float] | None = None,
    work_s: Mapping[str, float] | None = None,
    busy_s: Mapping[str, float] | None = None,
    clique_weights_s: Mapping[str, float] | None = None,
    cp_sat_bound_s: float | None = None,
    **extra: Any,
) -> MissionReport:
    """Build the report from a :class:`~masonry.mission.control.MissionControl`'s history.

    Without a simulator, the measurements come from what the UAVs reported: intervals from mission
    control's attempts, distances from the positions in heartbeats, placement errors from the results.
    ``masonry sim`` passes the world's own measurements instead.

    Args:
        intervals: (uav, task id, start_s, end_s) executed by the UAVs (default: mission control's attempts).
        distances_m, placement_error_m, min_separation_m: measured values overriding the reported ones.
        busy_s: time on tasks per UAV, overriding the sum of ``intervals`` (a resumed simulation passes the
            journaled time before the crash plus this run's).
        now_s: end of the trace for attempts still running (default: mission control's last step).
        durations_s: expected task durations for the lower bound (``masonry.planner.estimate_durations_s``:
            the same bound for every policy and seed); default: the durations measured in this run.
        work_s: what each task takes out of its UAV's timeline for the bound's role term
            (``masonry.planner.min_cycles_s``, with ``durations_s`` from ``min_durations_s``); default:
            the durations.
        clique_weights_s: what each task weighs in the bound's conflict-clique term
            (``masonry.planner.bound_terms``); default: the durations (``task`` reservation) or nothing
            (``site``: conflicting tasks may overlap, only their site parts, ``min_site_s``, may not).
        cp_sat_bound_s: CP-SAT's proven bound of an offline schedule for this wall, fleet and ``task``
            reservation (a fourth term).
    """
    now = mc.now_s if now_s is None else now_s
    kinds = {t.id: t.kind for t in plan.tasks}
    attempts = tuple(
        AttemptReport(
            a.task_id,
            a.uav,
            a.attempt,
            a.start_s,
            a.end_s,
            a.status,
            kinds[a.task_id],
            a.reason,
            a.phases,
        )
        for a in sorted(mc.history, key=lambda a: (a.start_s, a.task_id))
    )
    done_att = {a.task_id: a for a in attempts if a.status == "done"}
    visits = list(getattr(getattr(mc, "sites", None), "visits", ()))
    site_intervals = [(v.task_id, v.start_s, v.end_s) for v in visits]
    # the last one of each wins; one still open ends now, unless a crash cut it (not known when it would have)
    last_visit = {
        (v.task_id, v.uav): (v.start_s, v.end_s if v.end_s is not None or v.restored else now) for v in visits
    }
    tasks: list[TaskReport] = []
    stuck: list[str] = []
    watch = getattr(mc, "waits", None)
    ended = getattr(mc, "ended_at_s", None)
    waits = {} if watch is None else watch.log.waits(now if ended is None else min(now, ended))
    if watch is not None:  # the handlers' holds for a battery swap, as the UAVs measured them
        holds = [(a.task_id, a.uav, a.start_s, a.phases.queued) for a in attempts if a.phases is not None]
        waits = with_battery_holds(waits, holds)
    of_task = _by_task(attempts)
    for t in plan.tasks:
        if t.done:
            continue
        tries = of_task.get(t.id, [])
        # the attempts counted against its ``max_attempts``, a running one included (not its assignments: a flight
        # failed for its UAV's battery, the operator or a lost link is not one, though it has its own number)
        n = mc.dispatcher.attempts.get(t.id, 0) + (t.id in mc.dispatcher.in_progress)
        a = done_att.get(t.id)
        if a is not None:
            visit = last_visit.get((t.id, a.uav))
            tasks.append(
                TaskReport(
                    t.id,
                    a.uav,
                    a.start_s,
                    a.end_s,
                    "done",
                    n,
                    t.kind,
                    a.phases,
                    None if visit is None else visit[0],
                    None if visit is None else visit[1],
                    tuple(tries),
                    waits.get(t.id, ()),
                )
            )
            continue
        last = tries[-1] if tries else None
        status = (
            "stuck"
            if (t.id in mc.dispatcher.stuck or mc.ended_blocked or mc.ended_at_s is None)
            else "pending"
        )
        stuck.append(t.id)
        tasks.append(
            TaskReport(
                t.id,
                last.uav if last else None,
                None,
                None,
                status,
                n,
                t.kind,
                tries=tuple(tries),
                waits=waits.get(t.id, ()),
            )
        )
    # the mission starts with its first assignment (mission control may have waited for its fleet before)
    start = min((a.start_s for a in attempts), default=0.0)
    makespan = max((a.end_s - start for a in done_att.values() if a.end_s is not None), default=0.0)
    durations = (
        dict(durations_s)
        if durations_s is not None
        else {tid: (a.end_s or a.start_s) - a.start_s for tid, a in done_att.items()}
    )
    # tasks that never completed (a stuck mission) weigh nothing in a bound from measured durations
    todo_ids = [t.id for t in plan.tasks if not t.done]
    site = getattr(mc, "reservation", "task") == "site"
    terms = bound_terms(
        plan,
        mc.fleet,
        {tid: durations.get(tid, 0.0) for tid in todo_ids},
        work_s=None if work_s is None else {tid: work_s.get(tid, 0.0) for tid in todo_ids},
        clique_weights_s=clique_weights_s if clique_weights_s is not None else ({} if site else None),
        cp_sat_s=cp_sat_bound_s,
    )
    bound = terms.value_s
    if intervals is None:
        intervals = [(a.uav, a.task_id, a.start_s, a.end_s) for a in attempts]
    task_intervals = [(tid, s, e) for _, tid, s, e in intervals]
    conflicts, deps = count_violations(plan, task_intervals)
    if getattr(mc, "reservation", "task") == "site":
        # conflicting tasks may run at once: what must never overlap is their work at their sites, and no site
        # interval may start before a prerequisite completed
        conflicts, deps = count_site_violations(plan, site_intervals, task_intervals)
    busy: dict[str, float] = {}
    for uav, _, s, e in intervals:
        busy[uav] = busy.get(uav, 0.0) + ((e if e is not None else now) - s)
    if busy_s is not None:
        busy = dict(busy_s)
    # idle: from the mission's start to its last completion (to now, if it did not complete), or to the UAV's loss
    end = start + makespan if not stuck else max(now, start)
    every_wait = [w for ws in waits.values() for w in ws]
    uavs = []
    lingers = getattr(mc, "lingers", None)  # (mission/linger.py)
    for spec in mc.fleet:
        waiting = phase_totals(a for a in attempts if a.uav == spec.name).clearance_s
        ground, air = waiting_split_s(waiting, every_wait, spec.name)
        uavs.append(
            UavReport(
                spec.name,
                spec.role,
                busy.get(spec.name, 0.0),
                float((distances_m or {}).get(spec.name, mc.uavs[spec.name].distance_m)),
                mc.uavs[spec.name].status,
                idle_s=idle_s(attempts, spec.name, start, _until(mc.uavs[spec.name], end)),
                waiting_s=waiting,
                waiting_ground_s=ground,
                waiting_air_s=air,
                lingering_s=0.0 if lingers is None else lingers.total_s(spec.name, end),
                lingers=0 if lingers is None else lingers.count.get(spec.name, 0),
            )
        )
    if placement_error_m is None:
        placement_error_m = {
            a.task_id: a.placement_error_m
            for a in mc.history
            if a.status == "done" and a.placement_error_m is not None
        }
    ordered = {t.id: placement_error_m[t.id] for t in plan.tasks if t.id in placement_error_m}
    seen = {a.task_id: a.as_built for a in mc.history if a.status == "done" and a.as_built is not None}
    if (
        seen and getattr(mc, "placement", None) is not None
    ):  # (the best estimates, the wall re-solved: issue 30)
        seen.update({k: v for k, v in mc.placement.best(mc).items() if k in seen})
    return MissionReport(
        completed=not stuck,
        makespan_s=makespan,
        lower_bound_s=bound,
        lower_bound_kind=terms.kind,
        policy=policy,
        seed=seed,
        uavs=tuple(uavs),
        tasks=tuple(tasks),
        placement_error_m=ordered,
        as_built={t.id: seen[t.id] for t in plan.tasks if t.id in seen},
        min_separation_m=min_separation_m,
        conflict_violations=conflicts,
        dependency_violations=deps,
        stuck=tuple(stuck),
        attempts=attempts,
        resumed_from_s=mc.resumed_at_s,
        stall=None if getattr(mc, "stall", None) is None else {**mc.stall.to_dict(), "line": mc.stall.line()},
        spares=mc.spares.report() if getattr(mc, "spares", None) is not None else None,
        **extra,
    )


__all__ = [
    "TIMELINE_ROWS",
    "AttemptReport",
    "MissionReport",
    "TaskReport",
    "UavReport",
    "control_report",
    "count_site_violations",
    "count_violations",
    "idle_s",
    "makespan_s",
    "phase_totals",
]
