"""The offline schedule of a plan for a fleet, with OR-Tools CP-SAT (``masonry schedule``; docs/schedule.md).

The model, per part of the plan (the whole plan, or one course after another on large walls):

* one interval per task, of its minimum duration (:func:`~masonry.planner.bounds.min_durations_s`, the
  project's single timing model), in ticks of ``tick_s`` rounded down;
* precedences from G^d (``task``: a task starts after its prerequisites end; ``site``: its site part starts
  after they end, and a brick task, which may fetch its brick meanwhile, starts after they start);
* no overlap of conflicting tasks (G^c, covered by cliques): their task intervals (``task``) or their site
  parts (``site``, :func:`~masonry.planner.bounds.min_site_s`, somewhere inside the task);
* each task on exactly one UAV of its role (optional intervals, a NoOverlap per UAV);
* per UAV a circuit through a depot node (its home) and its tasks, whose arcs carry the sequence-dependent
  empty flight from the end of one task (or the home) to the start of the next
  (:func:`~masonry.planner.bounds.empty_flight_s`).

Every term is a lower bound of what the state machines fly, so with ``task`` the model is a relaxation of a
mission: CP-SAT's proven bound is a valid lower bound of every mission's makespan. A greedy list schedule (the
same constraints) gives the solver its hint and is the answer of a part where CP-SAT found nothing in time.

ortools is imported here only, inside :func:`solve_schedule`: the rest of the planner stays importable without
it (:class:`ScheduleUnavailable` says so).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from masonry.blueprint import DEFAULT_CLEARANCE_M, DEFAULT_CRUISE_ALTITUDE_M, ROLES, UavSpec
from masonry.errors import PlanningError
from masonry.planner.bounds import empty_flight_s, min_durations_s, min_site_s
from masonry.planner.dispatch_values import task_end_m, task_start_m
from masonry.planner.schedule_assemble import _assemble
from masonry.planner.schedule_chain import ChainCosts, chain_costs
from masonry.planner.schedule_deadlines import (
    DeadlinesUnmet,
    TickDeadlines,
    add_deadlines,
    check_open_feasible,
    missed_open,
    serial_horizon,
    tick_deadlines,
)
from masonry.planner.schedule_flown import flown_terms
from masonry.planner.schedule_graph import ancestors as _ancestors
from masonry.planner.schedule_graph import clique_cover as _clique_cover
from masonry.planner.schedule_graph import parts as _parts
from masonry.planner.schedule_graph import precedences as _precedences
from masonry.planner.schedule_greedy import greedy as _greedy
from masonry.planner.schedule_physical import (
    DEFAULT_BATTERY,
    BatteryModel,
    Physics,
    add_battery,
    add_pallet,
    make_physics,
    physical_terms,
)
from masonry.planner.schedule_values import OfflineSchedule
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan, Task
from masonry.timing import DEFAULT_TIMING, TaskTiming

if TYPE_CHECKING:
    from ortools.sat.python.cp_model import BoolVarT, CpModel, IntervalVar, IntVar

#: Plans with more not-done tasks than this are solved course by course (``decomposition="auto"``).
FULL_MODEL_MAX_TASKS = 110
#: A part of a decomposition gathers whole courses up to about this many tasks.
PART_TASKS = 60
DEFAULT_TICK_S = 0.01
DEFAULT_TIME_LIMIT_S = 30.0


class ScheduleUnavailable(PlanningError):
    """The offline schedule needs OR-Tools: ``pip install 'masonry[schedule]'``."""


@dataclass
class _Problem:
    """The not-done tasks in ticks, the graphs among them, and where the UAVs are."""

    tasks: list[Task]
    dur: list[int]
    site: list[int]  # ticks of the site part (``site``; 0 for ``task``)
    prereqs: list[list[int]]
    conflicts: list[set[int]]
    uavs: list[UavSpec]
    reservation: str
    timing: TaskTiming
    tick_s: float
    # the schedule so far (ticks): per task, per UAV
    start: dict[int, int] = field(default_factory=dict)
    end: dict[int, int] = field(default_factory=dict)
    site_start: dict[int, int] = field(default_factory=dict)
    uav_of: dict[int, int] = field(default_factory=dict)
    ready: list[int] = field(default_factory=list)
    pos: list[tuple[float, float, float]] = field(default_factory=list)
    last: list[int] = field(default_factory=list)  # per UAV its last task so far (-1: none, or its pad)
    deadlines: TickDeadlines = field(default_factory=TickDeadlines)  # the adhesive's (issue 31)
    phys: Physics | None = None  # the physical terms (``--physical``), None: the plain model
    chain: ChainCosts | None = None  # the chain term (``chaining``), None: every segment at its chained least
    kept: dict[int, tuple[int, int]] = field(default_factory=dict)  # placed tasks' kept-apart windows (ticks)

    def flight(self, from_m: Sequence[float], i: int) -> int:
        return math.floor(
            empty_flight_s(from_m, task_start_m(self.tasks[i]), timing=self.timing) / self.tick_s
        )

    def leg(self, prev: int, from_m: Sequence[float], i: int) -> int:
        """From the end of task ``prev`` (-1: a pad, or nothing known) at ``from_m`` to the start of task ``i``:
        the empty flight and, with the chain term, the climb out and first descent of a segment not chained."""
        return self.flight(from_m, i) + (self.chain.extra(prev, i) if self.chain is not None else 0)

    def spread(self, i: int) -> bool:
        """Task ``i``'s kept window holds its first descent and climb out when not chained (``site``, chain
        term): the runtime's site interval does (docs/schedule.md, "Chaining")."""
        return (
            self.chain is not None and self.reservation == "site" and isinstance(self.tasks[i], AdhesionTask)
        )

    def around(self, prev: int, i: int, nxt: int) -> tuple[int, int]:
        """Ticks task ``i``'s kept window reaches before its site part and after it, after task ``prev`` (-1:
        none) and before ``nxt`` (-1: none, -2: not known yet, its climb out counted)."""
        c = self.chain
        if c is None or not self.spread(i):
            return 0, 0
        lo = 0 if prev >= 0 and (prev, i) in c.follows else c.descend[i]
        hi = 0 if nxt == -1 or (nxt >= 0 and (i, nxt) in c.follows) else c.climb[i]
        return lo, hi

    def windows(self, placed: Mapping[int, tuple[int, int, int, int]]) -> dict[int, tuple[int, int]]:
        """The kept windows of a part's placed tasks (task -> (UAV, start, end, site start)), each UAV's order
        after its last task so far."""
        by: dict[int, list[int]] = {}
        for i, (k, *_rest) in placed.items():
            by.setdefault(k, []).append(i)
        out: dict[int, tuple[int, int]] = {}
        for k, mine in by.items():
            mine.sort(key=lambda i: placed[i][1])
            for n, i in enumerate(mine):
                _k, s, e, a = placed[i]
                prev = mine[n - 1] if n else self.last[k]
                lo, hi = self.around(prev, i, mine[n + 1] if n + 1 < len(mine) else -1)
                out[i] = (a - lo, a + self.site[i] + hi) if self.reservation == "site" else (s, e)
        return out

    def prefetch(self, i: int) -> bool:
        return self.reservation == "site" and isinstance(self.tasks[i], BrickTask)

    def site_offset_max(self, i: int) -> int:
        return self.dur[i] - self.site[i]


def _problem(
    plan: Plan,
    fleet: Sequence[UavSpec],
    timing: TaskTiming,
    cruise_altitude_m: float,
    reservation: str,
    tick_s: float,
) -> _Problem:
    tasks = [t for t in plan.tasks if not t.done]
    index = {t.id: i for i, t in enumerate(tasks)}
    md = min_durations_s(plan, timing=timing, cruise_altitude_m=cruise_altitude_m)
    site = (
        min_site_s(plan, timing=timing, cruise_altitude_m=cruise_altitude_m) if reservation == "site" else {}
    )
    prereqs: list[list[int]] = [[] for _ in tasks]
    for u, v in plan.dependencies:
        if u in index and v in index:
            prereqs[index[u]].append(index[v])
    conflicts: list[set[int]] = [set() for _ in tasks]
    for a, b in plan.conflicts:
        ia, ib = index.get(a), index.get(b)
        if ia is not None and ib is not None and ia != ib:
            conflicts[ia].add(ib)
            conflicts[ib].add(ia)
    for role in ROLES:
        n_tasks = sum(1 for t in tasks if t.kind == role)
        if n_tasks and not any(s.role == role for s in fleet):
            raise PlanningError(
                f"no {role} UAV in the fleet for {n_tasks} {role} task{'' if n_tasks == 1 else 's'}"
            )
    dur = [math.floor(md[t.id] / tick_s) for t in tasks]
    return _Problem(
        tasks=tasks,
        dur=dur,
        site=[min(dur[i], math.floor(site.get(t.id, 0.0) / tick_s)) for i, t in enumerate(tasks)],
        prereqs=prereqs,
        conflicts=conflicts,
        uavs=list(fleet),
        reservation=reservation,
        timing=timing,
        tick_s=tick_s,
        ready=[0] * len(fleet),
        pos=[(float(s.home_m[0]), float(s.home_m[1]), float(s.home_m[2])) for s in fleet],
        last=[-1] * len(fleet),
        deadlines=tick_deadlines(
            plan, tasks, timing=timing, cruise_altitude_m=cruise_altitude_m, tick_s=tick_s
        ),
    )


@dataclass
class _PartResult:
    placed: dict[int, tuple[int, int, int, int]]
    status: str
    bound: int | None
    solve_s: float
    swaps: dict[int, list[int]] = field(default_factory=dict)  # per UAV its swaps' starts (``battery``)


def _solve_part(
    p: _Problem, part: Sequence[int], time_limit_s: float, seed: int, workers: int
) -> _PartResult:
    from ortools.sat.python import cp_model

    t_start = time.perf_counter()
    hint = _greedy(p, part)
    horizon = max(e for _, _, e, _ in hint.values())
    if p.deadlines:  # the greedy may miss an open time: a serial schedule never does
        ends = [task_end_m(t) for t in p.tasks] + [u.home_m for u in p.uavs]
        flights = [max(p.flight(e, i) for e in ends) + (p.chain.most(i) if p.chain else 0) for i in part]
        horizon += serial_horizon([p.dur[i] for i in part], flights, p.deadlines)
    m = cp_model.CpModel()
    site = p.reservation == "site"
    phys = p.phys
    hint_swaps = dict(phys.hint_swaps) if phys else {}
    if phys is not None:
        phys.swap_vars = {}
    s_var, e_var, a_var, keep, size, ext = _task_vars(p, part, m, horizon, hint)
    _precedences(p, part, m, s_var, e_var, a_var)
    if phys is not None and phys.pallet:
        add_pallet(p, phys, part, m, s_var, e_var, a_var, _clique_cover)
    add_deadlines(p.deadlines, part, m, s_var, e_var, a_var, p.end)
    for clique in _clique_cover(p.conflicts, part):
        m.add_no_overlap([keep[i] for i in clique])
    # conflicting tasks of earlier parts are fixed intervals: a task may fill a gap before one of them
    fixed: dict[int, IntervalVar] = {}
    for i in part:
        for c in p.conflicts[i]:
            if c in p.end and c not in s_var:
                if c not in fixed:
                    lo, hi = p.kept[c]
                    fixed[c] = m.new_fixed_size_interval_var(lo, hi - lo, f"fixed{c}")
                m.add_no_overlap([keep[i], fixed[c]])
    lits, into, away = _machines(p, part, m, s_var, e_var, hint, size, hint_swaps, horizon)
    _link_windows(p, part, m, ext, into, away)
    makespan = m.new_int_var(max(p.end.values(), default=0), horizon, "makespan")
    for i in part:
        m.add(makespan >= e_var[i])
    m.minimize(makespan)
    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = max(0.1, float(time_limit_s))
    solver.parameters.random_seed = int(seed)
    solver.parameters.num_workers = int(workers)
    # probing spent 14 of 15 s in presolve on a 69-task wall (and found nothing): the search does better
    solver.parameters.cp_model_probing_level = 0
    code = solver.solve(m)
    solve_s = time.perf_counter() - t_start
    if code not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return _PartResult(hint, "greedy", None, solve_s, hint_swaps)
    placed: dict[int, tuple[int, int, int, int]] = {}
    for i in part:
        k = next(k for k, lit in lits[i].items() if solver.boolean_value(lit))
        s = int(solver.value(s_var[i]))
        a = int(solver.value(a_var[i])) if site else s
        placed[i] = (k, s, int(solver.value(e_var[i])), a)
    swaps = {
        k: [int(solver.value(w)) for here, w in nodes if solver.boolean_value(here)]
        for k, nodes in (phys.swap_vars.items() if phys else ())
    }
    status = "optimal" if code == cp_model.OPTIMAL else "feasible"
    return _PartResult(placed, status, math.floor(solver.best_objective_bound), solve_s, swaps)


def _task_vars(
    p: _Problem, part: Sequence[int], m: CpModel, horizon: int, hint: Mapping[int, tuple[int, int, int, int]]
) -> tuple[
    dict[int, IntVar],
    dict[int, IntVar],
    dict[int, IntVar],
    dict[int, IntervalVar],
    dict[int, IntVar | int],
    dict[int, tuple[IntVar, IntVar]],
]:
    """Per task its start, end, site start (``site``), kept-apart interval and length (its minimum duration,
    or a variable for a task the physical terms let last longer); per segment whose kept window holds its first
    descent and climb out (:meth:`_Problem.spread`) their ticks (0 when chained)."""
    ext: dict[int, tuple[IntVar, IntVar]] = {}
    hinted = p.windows(hint)
    s_var: dict[int, IntVar] = {}
    e_var: dict[int, IntVar] = {}
    a_var: dict[int, IntVar] = {}
    keep: dict[int, IntervalVar] = {}
    size: dict[int, IntVar | int] = {}
    site = p.reservation == "site"
    for i in part:
        s_var[i] = m.new_int_var(0, horizon, f"s{i}")
        e_var[i] = m.new_int_var(0, horizon, f"e{i}")
        flexible = p.phys is not None and p.phys.flexible(p, i)
        size[i] = m.new_int_var(p.dur[i], horizon, f"d{i}") if flexible else p.dur[i]
        m.new_interval_var(s_var[i], size[i], e_var[i], f"t{i}")
        if site:
            a_var[i] = m.new_int_var(0, horizon, f"a{i}")
            m.add(a_var[i] >= s_var[i])
            m.add(a_var[i] + p.site[i] <= e_var[i])
            keep[i] = m.new_fixed_size_interval_var(a_var[i], p.site[i], f"site{i}")
            if p.spread(i) and p.chain is not None:
                din = m.new_int_var(0, p.chain.descend[i], f"din{i}")
                cout = m.new_int_var(0, p.chain.climb[i], f"cout{i}")
                ext[i] = (din, cout)
                lo_v = m.new_int_var(-p.chain.descend[i], horizon, f"vlo{i}")
                hi_v = m.new_int_var(0, horizon + p.chain.climb[i], f"vhi{i}")
                m.add(lo_v == a_var[i] - din)
                m.add(hi_v == a_var[i] + p.site[i] + cout)
                span = m.new_int_var(p.site[i], p.site[i] + p.chain.descend[i] + p.chain.climb[i], f"vs{i}")
                m.add(span == din + p.site[i] + cout)
                keep[i] = m.new_interval_var(lo_v, span, hi_v, f"visit{i}")
                m.add_hint(din, hint[i][3] - hinted[i][0])
                m.add_hint(cout, hinted[i][1] - hint[i][3] - p.site[i])
        else:
            keep[i] = m.new_fixed_size_interval_var(s_var[i], p.dur[i], f"k{i}")
        m.add_hint(s_var[i], hint[i][1])
        if flexible:
            m.add_hint(e_var[i], hint[i][2])
        if site:
            m.add_hint(a_var[i], hint[i][3])
    return s_var, e_var, a_var, keep, size, ext


def _link_windows(
    p: _Problem,
    part: Sequence[int],
    m: CpModel,
    ext: Mapping[int, tuple[IntVar, IntVar]],
    into: Mapping[int, Sequence[BoolVarT]],
    away: Mapping[int, Sequence[BoolVarT]],
) -> None:
    """A segment's first descent is in its kept window unless it follows the one ending at its start (a circuit
    arc of :func:`_machines`, or its UAV's last task so far), its climb out unless the next one does or it is
    its UAV's last."""
    if not ext or p.chain is None:
        return
    for i, (din, cout) in ext.items():
        m.add(din == p.chain.descend[i] * (1 - sum(into.get(i, ()))))
        m.add(cout == p.chain.climb[i] * sum(away.get(i, ())))


def _machines(
    p: _Problem,
    part: Sequence[int],
    m: CpModel,
    s_var: Mapping[int, IntVar],
    e_var: Mapping[int, IntVar],
    hint: Mapping[int, tuple[int, int, int, int]],
    size: Mapping[int, IntVar | int],
    hint_swaps: Mapping[int, Sequence[int]],
    horizon: int,
) -> tuple[dict[int, dict[int, IntVar]], dict[int, list[BoolVarT]], dict[int, list[BoolVarT]]]:
    """Each task on one UAV of its role; per UAV a circuit through its home with the empty flights (and its
    battery swaps, ``battery``: :func:`~masonry.planner.schedule_physical.add_battery`). Returns per task its
    UAVs' literals, and (chain term) the arcs into it that chain it and out of it to a task they do not chain."""
    lits: dict[int, dict[int, IntVar]] = {i: {} for i in part}
    follows = p.chain.follows if p.chain is not None else frozenset()
    into: dict[int, list[BoolVarT]] = {}
    away: dict[int, list[BoolVarT]] = {}
    battery = p.phys is not None and p.phys.battery
    anc = _ancestors(p.prereqs, part)
    for k, spec in enumerate(p.uavs):
        mine = [i for i in part if p.tasks[i].kind == spec.role]
        if not mine:
            continue
        order = sorted((i for i in mine if hint[i][0] == k), key=lambda i: hint[i][1])
        hinted_arcs = set(zip([-1, *order], [*order, -1]))
        swaps_k = hint_swaps.get(k, ())  # a greedy swap between two tasks: no arc between them
        hinted_arcs -= {
            (a, b)
            for a, b in zip([-1, *order], order)
            if any((hint[a][2] if a >= 0 else 0) <= w < hint[b][1] for w in swaps_k)
        }
        node = {i: n + 1 for n, i in enumerate(mine)}
        arcs: list[tuple[int, int, BoolVarT]] = []
        task_arcs: list[tuple[int, int, BoolVarT]] = []  # (from, to, literal), -1: the depot
        optional = []
        for i in mine:
            x = m.new_bool_var(f"x{i}_{k}")
            lits[i][k] = x
            m.add_hint(x, int(hint[i][0] == k))
            optional.append(m.new_optional_interval_var(s_var[i], size[i], e_var[i], x, f"o{i}_{k}"))
            arcs.append((node[i], node[i], x.Not()))
            first = m.new_bool_var(f"f{i}_{k}")
            m.add(s_var[i] >= p.ready[k] + p.leg(p.last[k], p.pos[k], i)).only_enforce_if(first)
            m.add_hint(first, int((-1, i) in hinted_arcs))
            arcs.append((0, node[i], first))
            if (p.last[k], i) in follows:
                into.setdefault(i, []).append(first)
            task_arcs.append((-1, i, first))
            last = m.new_bool_var(f"l{i}_{k}")
            m.add_hint(last, int((i, -1) in hinted_arcs))
            arcs.append((node[i], 0, last))
        empty = m.new_bool_var(f"empty_{k}")
        m.add_hint(empty, int(not order))
        arcs.append((0, 0, empty))
        for i in mine:
            end_i = task_end_m(p.tasks[i])
            for j in mine:
                if i == j or j in anc[i]:
                    continue  # j must end before i starts: never right after it on one UAV
                lit = m.new_bool_var(f"y{i}_{j}_{k}")
                m.add(s_var[j] >= e_var[i] + p.leg(i, end_i, j)).only_enforce_if(lit)
                m.add_hint(lit, int((i, j) in hinted_arcs))
                arcs.append((node[i], node[j], lit))
                task_arcs.append((i, j, lit))
                if (i, j) in follows:
                    into.setdefault(j, []).append(lit)
                else:
                    away.setdefault(i, []).append(lit)
        if battery and p.phys is not None:
            arcs += add_battery(
                p,
                p.phys,
                k,
                mine,
                m,
                s_var,
                e_var,
                task_arcs,
                node,
                optional,
                hint_swaps.get(k, ()),
                horizon,
                hint,
            )
        m.add_circuit(arcs)
        m.add_no_overlap(optional)
    for i in part:
        m.add_exactly_one(lits[i].values())
    return lits, into, away


def _flown(
    p: _Problem,
    plan: Plan,
    terms: tuple[str, ...],
    timing: TaskTiming,
    cruise_altitude_m: float,
    clearance_m: float,
) -> list[int] | None:
    """``flown``: the tasks' durations and chain term as flown (set on ``p``) and their visits (ticks), else None."""
    if "flown" not in terms:
        return None
    p.dur, visit, p.chain = flown_terms(
        p.tasks, plan.tasks, p.dur, p.chain, timing, cruise_altitude_m, clearance_m, p.tick_s
    )
    return visit


def solve_schedule(
    plan: Plan,
    fleet: Sequence[UavSpec],
    *,
    timing: TaskTiming | None = None,
    cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M,
    reservation: str = "task",
    time_limit_s: float = DEFAULT_TIME_LIMIT_S,
    seed: int = 0,
    workers: int = 2,
    decomposition: str = "auto",
    tick_s: float = DEFAULT_TICK_S,
    max_full_tasks: int = FULL_MODEL_MAX_TASKS,
    part_tasks: int = PART_TASKS,
    physical: str | Sequence[str] = (),
    battery: BatteryModel = DEFAULT_BATTERY,
    clearance_m: float = DEFAULT_CLEARANCE_M,
    chaining: bool = True,
) -> OfflineSchedule:
    """The offline schedule of ``plan``'s not-done tasks for ``fleet`` (see the module docstring).

    Args:
        reservation: ``task`` or ``site``, as ``masonry sim`` (what conflicting tasks must keep apart).
        time_limit_s: CP-SAT's time for the whole plan (shared between the parts of a decomposition, by
            their number of tasks).
        seed, workers: CP-SAT's ``random_seed`` and ``num_workers`` (1 worker and a fixed seed: the same
            schedule on every run that ends before the limit).
        decomposition: ``auto`` (the whole model up to ``max_full_tasks`` tasks, else ``course``), ``none``
            or ``course`` (courses in order, each part solved after the earlier ones are fixed).
        max_full_tasks, part_tasks: ``auto`` decomposes plans with more tasks than ``max_full_tasks``; a part
            gathers whole courses up to ``part_tasks`` tasks (a course larger than that is one part).
        tick_s: the model's time unit; durations and flights are rounded down to it (the bound stays valid).
        physical: the physical terms (:mod:`~masonry.planner.schedule_physical`: ``pallet``, ``battery``,
            ``visit``, ``flown``, as names or one string separated by ``,`` or ``+``; ``all``: every one but
            ``flown``); none by default.
        battery, clearance_m: the packs and swaps (``battery``) and the blueprint's r_c (``pallet``).
        chaining: the chain term (:mod:`~masonry.planner.schedule_chain`): a segment not sprayed right after the
            one ending at its start costs its climb out and first descent (default); False: every segment at its
            chained least, the model before issue 27's chain term.

    Returns:
        The schedule; no digest (the caller, who has the blueprint, adds them).

    Raises:
        ScheduleUnavailable: OR-Tools is not installed.
        PlanningError: bad arguments, a role with tasks has no UAV, or a task no fresh pack covers.
    """
    try:
        import ortools.sat.python.cp_model  # noqa: F401
    except ImportError:
        raise ScheduleUnavailable(
            "the offline schedule needs OR-Tools: pip install 'masonry[schedule]' (or 'ortools')"
        ) from None
    if reservation not in ("site", "task"):
        raise PlanningError(f"reservation must be site or task, got {reservation!r}")
    if decomposition not in ("auto", "none", "course"):
        raise PlanningError(f"decomposition must be auto, none or course, got {decomposition!r}")
    if not (math.isfinite(time_limit_s) and time_limit_s > 0):
        raise PlanningError(f"time_limit_s must be > 0, got {time_limit_s!r}")
    if not (math.isfinite(tick_s) and tick_s > 0):
        raise PlanningError(f"tick_s must be > 0, got {tick_s!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise PlanningError(f"workers must be an integer >= 1, got {workers!r}")
    t_ = DEFAULT_TIMING if timing is None else timing
    t0 = time.perf_counter()
    terms = physical_terms(physical)
    p = _problem(plan, fleet, t_, cruise_altitude_m, reservation, tick_s)
    p.chain = chain_costs(p.tasks, t_, cruise_altitude_m, tick_s) if chaining else None
    flown = _flown(p, plan, terms, t_, cruise_altitude_m, clearance_m)
    if terms:
        p.phys = make_physics(
            plan,
            p.tasks,
            fleet,
            p.dur,
            terms=terms,
            timing=t_,
            cruise_altitude_m=cruise_altitude_m,
            tick_s=tick_s,
            battery=battery,
            clearance_m=clearance_m,
            flown_visit=flown,
        )
        p.phys.apply(p)
    check_open_feasible(p.deadlines, p.tasks, p.dur, tick_s, reservation)
    parts = _parts(p, decomposition, max_full_tasks, part_tasks)
    n = max(1, len(p.tasks))
    reports: list[dict[str, Any]] = []
    last = _PartResult({}, "optimal", 0, 0.0)
    for part in parts:
        if not part:
            continue
        budget = time_limit_s * len(part) / n
        last = _solve_part(p, part, budget, seed, workers)
        if last.status == "greedy" and missed_open(p.deadlines, last.placed, p.end, reservation):
            raise DeadlinesUnmet.within(budget, len(part))
        for i, (k, s, e, a) in last.placed.items():
            p.start[i], p.end[i], p.site_start[i], p.uav_of[i] = s, e, a, k
        p.kept.update(p.windows(last.placed))  # before each UAV's last task moves on
        if p.phys is not None:
            p.phys.carry_over(p, part, last.placed, last.swaps)
        for k in range(len(p.uavs)):
            mine = [i for i in part if last.placed[i][0] == k]
            if mine:
                j = max(mine, key=lambda i: p.end[i])
                p.ready[k], p.pos[k], p.last[k] = p.end[j], task_end_m(p.tasks[j]), j
        reports.append({"tasks": len(part), "status": last.status, "solve_time_s": round(last.solve_s, 3)})
    return _assemble(
        plan,
        fleet,
        p,
        parts,
        last,
        reports,
        t_,
        cruise_altitude_m,
        time_limit_s,
        seed,
        time.perf_counter() - t0,
    )


__all__ = [
    "DEFAULT_TICK_S",
    "DEFAULT_TIME_LIMIT_S",
    "FULL_MODEL_MAX_TASKS",
    "PART_TASKS",
    "ScheduleUnavailable",
    "physical_terms",
    "solve_schedule",
]
