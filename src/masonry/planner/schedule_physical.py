"""The physical terms of the offline schedule (``masonry schedule --physical``; docs/schedule.md, "The physical model").

The plain model (:mod:`masonry.planner.schedule`) keeps conflicting tasks' site parts apart and flies each UAV's
empty legs between its tasks. What the simulated fleet cannot escape besides, each term switchable on its own:

* ``pallet``: a brick task is its pickup (at a fixed offset from its start: approach, settle, estimate, align),
  the climb and carry (at least their minimum), its site part and the climb out; the pickup part (descent and
  grasp dwell, at the pallet) of two bricks whose pickups are within r_c of each other never overlap, as the site
  parts of conflicting tasks do not (the pallet is as wide as the wall: it is a shared resource too). Under
  ``site`` the task lasts as long as it must (the wait between pickup and site is in it); under ``task`` it
  keeps its minimum duration and the pickup sits at its offset.
* ``battery``: each UAV's flight between two swaps (its tasks' minimum durations and the empty legs between
  them, the legs to and from its pad) stays within its pack's usable flight (``pack_s`` x (1 -
  ``low_fraction``): the state machines abort a task and fly home below ``low_fraction``); a swap is a node of
  the UAV's circuit: the flight home (at cruise speed), the landing, ``swap_s`` on the pad, the take-off and the
  flight back to the next task.

* ``visit`` (under ``site``): each task's site part is the one it holds at run time, at its floor (a brick's
  flight in from r_c, align, placing and climb out; a segment's whole minimum duration:
  :mod:`masonry.planner.schedule_visit`); with ``pallet`` a brick's carry gives up the flight in and the align.
* ``flown``: each task's duration and visit as the machines fly them (the descent from transit layer 0, the
  climbs to it, each leg settled: :mod:`masonry.planner.schedule_flown`); its visit replaces ``visit``'s floor.
  A model of the mission, not a bound (``all`` leaves it out).

The empty legs between consecutive tasks of a UAV are in every model (the circuit of :func:`~masonry.planner.
schedule._machines`). Every term but ``flown`` is counted at its least, so each stays a lower bound of what the machines fly
(the UAV-to-UAV separation in flight is not a term: docs/schedule.md says why).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from masonry.blueprint import DEFAULT_CLEARANCE_M, UavSpec
from masonry.errors import PlanningError
from masonry.planner.bounds import flight_slack_m, min_site_s
from masonry.planner.schedule_visit import visit_site
from masonry.planner.tasks import BrickTask, Plan, Task
from masonry.timing import MIN_LEG_S, TaskTiming, min_jerk_leg_s

if TYPE_CHECKING:  # the types only: ortools is imported by masonry.planner.schedule, inside solve_schedule
    from collections.abc import Callable

    from ortools.sat.python.cp_model import BoolVarT, CpModel, IntervalVar, IntVar

    from masonry.planner.schedule import _Problem

#: The physical terms ``--physical`` may name (``all``: every one but ``flown``, which is named on its own).
PHYSICAL_TERMS: tuple[str, ...] = ("pallet", "battery", "visit", "flown")
#: What ``all`` names (``flown`` is a model of the mission, not a bound: :mod:`~masonry.planner.schedule_flown`).
ALL_TERMS: tuple[str, ...] = ("pallet", "battery", "visit")


@dataclass(frozen=True)
class BatteryModel:
    """A UAV's pack and its swap (SI units). The defaults are the simulator's and the state machines': every
    ``--vehicle`` preset's ``battery_drain_per_s`` 1/1200 (``VehicleConfig``), ``UavConfig.battery_low_fraction``
    and ``battery_swap_s``, the autopilot's landing (``masonry.fsm.battery``: 0.5 m/s and 1 s to the disarm) and
    its 4 s take-off (tests/test_schedule_physical.py checks they agree)."""

    pack_s: float = 1200.0
    low_fraction: float = 0.20
    swap_s: float = 60.0
    land_speed_mps: float = 0.5
    touchdown_s: float = 1.0
    takeoff_s: float = 4.0

    @property
    def usable_s(self) -> float:
        """Seconds of flight from a fresh pack down to ``low_fraction``."""
        return self.pack_s * (1.0 - self.low_fraction)

    def on_pad_s(self, cruise_altitude_m: float, pad_z_m: float) -> float:
        """Landing from the cruise altitude, the swap and the take-off."""
        return (
            max(0.0, cruise_altitude_m - pad_z_m) / self.land_speed_mps
            + self.touchdown_s
            + self.swap_s
            + (self.takeoff_s)
        )


DEFAULT_BATTERY = BatteryModel()


def physical_terms(physical: str | Sequence[str]) -> tuple[str, ...]:
    """``physical`` (a string of names separated by ``,`` or ``+``, ``all``, ``none`` or "", or a sequence of
    names) as terms of :data:`PHYSICAL_TERMS`, in their order (``all``: :data:`ALL_TERMS`).

    Raises:
        PlanningError: an unknown name.
    """
    names = (
        [n.strip() for n in physical.replace("+", ",").split(",")]
        if isinstance(physical, str)
        else list(physical)
    )
    names = [n for n in names if n and n != "none"]
    if "all" in names:
        names = [n for n in names if n != "all"] + list(ALL_TERMS)
    bad = [n for n in names if n not in PHYSICAL_TERMS]
    if bad:
        raise PlanningError(f"physical: unknown term {bad[0]!r} (of {', '.join(PHYSICAL_TERMS)}, all, none)")
    return tuple(t for t in PHYSICAL_TERMS if t in names)


@dataclass(frozen=True)
class BrickPhases:
    """A brick task's minimum duration cut in its parts (ticks): before the pickup, the pickup at the pallet, the
    climb and carry, the site part, the climb out. They sum to the task's minimum duration."""

    pre: int
    pick: int
    carry: int
    site: int
    post: int


@dataclass
class Physics:
    """The physical terms of one schedule problem (ticks), and what the parts solved so far left behind."""

    terms: tuple[str, ...]
    phases: dict[int, BrickPhases]
    #: per task index, the brick tasks whose pickups are within r_c of its own (``pallet``)
    pick_conflicts: list[set[int]]
    usable: int
    on_pad: list[int]  # per UAV, ticks on its pad for a swap
    tick_s: float
    cruise_speed_mps: float
    slack_m: float
    #: per UAV, ticks flown since its last swap (carried from part to part)
    energy: list[int] = field(default_factory=list)
    #: per UAV, the starts of its swaps so far (ticks)
    swaps: list[list[int]] = field(default_factory=list)
    #: the last model's swap nodes per UAV: (presence, start)
    swap_vars: dict[int, list[tuple[IntVar, IntVar]]] = field(default_factory=dict)
    #: the last greedy's swaps per UAV (the model's hint, or the part's answer when CP-SAT found nothing)
    hint_swaps: dict[int, list[int]] = field(default_factory=dict)
    #: per task its site part at run time (``visit``: :mod:`~masonry.planner.schedule_visit`), else None
    visit_ticks: list[int] | None = None

    @property
    def pallet(self) -> bool:
        return "pallet" in self.terms

    @property
    def visit(self) -> bool:
        return "visit" in self.terms or "flown" in self.terms

    @property
    def battery(self) -> bool:
        return "battery" in self.terms

    def home_ticks(self, a: Sequence[float], b: Sequence[float]) -> int:
        """The flight between ``a`` and a pad (or from one) at cruise speed, less the arrive slack."""
        d_m = math.hypot(a[0] - b[0], a[1] - b[1])
        return math.floor(max(0.0, d_m - self.slack_m) / self.cruise_speed_mps / self.tick_s)

    def flexible(self, p: _Problem, i: int) -> bool:
        """Task ``i`` lasts as long as its pickup and site parts make it (``pallet`` under ``site``)."""
        return self.pallet and p.reservation == "site" and i in self.phases

    def pick_window(self, i: int, start: int) -> tuple[int, int]:
        ph = self.phases[i]
        return start + ph.pre, start + ph.pre + ph.pick

    def earliest(
        self,
        p: _Problem,
        i: int,
        t0: int,
        a0: int,
        kept: Mapping[int, tuple[int, int]],
        picks: Mapping[int, tuple[int, int]],
    ) -> tuple[int, int, int]:
        """The greedy's earliest (start, site start, end) of brick task ``i`` from ``t0`` (its site part from
        ``a0``) clear of the placed conflicting site parts (or tasks, ``task``) and pickups."""
        ph = self.phases[i]
        others = sorted(picks[j] for j in self.pick_conflicts[i] if j in picks)
        flex = self.flexible(p, i)
        t = t0
        while True:
            t = clear_of(others, t, ph.pre, ph.pick)
            if flex:
                a = clear_of(
                    sorted(kept[j] for j in p.conflicts[i] if j in kept),
                    max(a0, t + ph.pre + ph.pick + ph.carry),
                    0,
                    ph.site,
                )
                return t, a, a + ph.site + ph.post
            # fixed length: the task's kept interval (``task``) or the site part at its latest, then the pickup
            off = p.dur[i] - p.site[i] if p.reservation == "site" else 0
            length = p.site[i] if p.reservation == "site" else p.dur[i]
            t2 = clear_of(sorted(kept[j] for j in p.conflicts[i] if j in kept), max(t, a0 - off), off, length)
            if t2 == t:
                return t, t + off, t + p.dur[i]
            t = t2

    def swap_before(
        self, p: _Problem, k: int, i: int, pos: Sequence[float], energy: int, prev: int = -1
    ) -> bool:
        """The greedy's rule: UAV ``k`` at ``pos`` swaps before task ``i`` when the task, the leg to it and the
        flight home after it would not fit in what is left of its pack."""
        if not self.battery:
            return False
        need = p.leg(prev, pos, i) + p.dur[i] + self.home_ticks(_end(p.tasks[i]), p.uavs[k].home_m)
        return energy + need > self.usable

    def apply(self, p: _Problem) -> None:
        """``visit`` (under ``site``): each task's site part is its visit, and a brick's pallet phases hold it
        (its carry gives the flight in and the align, its climb out joins it); then :meth:`check`."""
        if self.visit_ticks is not None and p.reservation == "site":
            for i, v in enumerate(self.visit_ticks):
                ph = self.phases.get(i)
                if ph is None:
                    p.site[i] = max(p.site[i], v)
                    continue
                self.phases[i] = with_visit(ph, v)
                p.site[i] = self.phases[i].site
        self.check(p)

    def check(self, p: _Problem) -> None:
        """Every task fits in a fresh pack with the flights from and to its UAVs' pads (else no schedule)."""
        if not self.battery:
            return
        for i, t in enumerate(p.tasks):
            fits = [
                p.leg(-1, u.home_m, i) + p.dur[i] + self.home_ticks(_end(t), u.home_m) <= self.usable
                for u in p.uavs
                if u.role == t.kind
            ]
            if fits and not any(fits):
                raise PlanningError(
                    f"task {t.id} does not fit in a fresh pack ({self.usable * self.tick_s:.0f} s)"
                )

    def carry_over(
        self,
        p: _Problem,
        part: Sequence[int],
        placed: Mapping[int, tuple[int, int, int, int]],
        swaps: Mapping[int, Sequence[int]],
    ) -> None:
        """After a part (before ``p.pos`` moves on): each UAV's swaps so far and its flight since the last
        one, replayed at its least."""
        for k in range(len(p.uavs)):
            new = list(swaps.get(k, ()))
            self.swaps[k].extend(new)
            events = sorted([(s, -1) for s in new] + [(placed[i][1], i) for i in part if placed[i][0] == k])
            pos, prev, energy = p.pos[k], p.last[k], self.energy[k]
            for _, i in events:
                if i < 0:
                    pos, prev, energy = p.uavs[k].home_m, -1, 0
                else:
                    energy += p.leg(prev, pos, i) + p.dur[i]
                    pos, prev = _end(p.tasks[i]), i
            self.energy[k] = energy


def with_visit(ph: BrickPhases, visit: int) -> BrickPhases:
    """A brick's phases with its site part its visit (``visit``, ticks): the carry gives up the flight in and the
    align, the climb out joins it; never into the pickup, never less than the least site part and climb out."""
    v = max(ph.site + ph.post, min(visit, ph.carry + ph.site + ph.post))
    return BrickPhases(ph.pre, ph.pick, ph.carry + ph.site + ph.post - v, v, 0)


def _end(t: Task) -> tuple[float, float, float]:
    if isinstance(t, BrickTask):
        return t.position_m
    return t.end_m


def _start(t: Task) -> tuple[float, float, float]:
    if isinstance(t, BrickTask):
        return t.pickup_m if t.pickup_m is not None else t.position_m
    return t.start_m


def clear_of(others: Sequence[tuple[int, int]], t: int, off: int, length: int) -> int:
    """The earliest ``t`` >= the given one whose window [t + off, t + off + length) overlaps none of ``others``."""
    moved = True
    while moved:
        moved = False
        for s, e in others:
            x = t + off
            if x < e and s < x + length:
                t = e - off
                moved = True
    return t


def brick_phases(
    plan: Plan,
    tasks: Sequence[Task],
    dur: Sequence[int],
    timing: TaskTiming,
    cruise_altitude_m: float,
    tick_s: float,
) -> dict[int, BrickPhases]:
    """Per brick task index, its minimum duration (``dur``, ticks) cut as :func:`~masonry.planner.bounds.
    min_durations_s` counts it (docs/planner.md)."""
    site_s = min_site_s(plan, timing=timing, cruise_altitude_m=cruise_altitude_m)
    out: dict[int, BrickPhases] = {}
    for i, t in enumerate(tasks):
        if not isinstance(t, BrickTask):
            continue
        h = t.size_m[2]
        top_drop = t.position_m[2] + h / 2.0
        transit = max(cruise_altitude_m, timing.carry_altitude_m(top_drop, h))
        drop = transit - (top_drop - timing.effector_offset_m[2])
        pre = math.floor(
            (2 * MIN_LEG_S + timing.settle_time_s + (timing.min_estimates - 1) * timing.control_period_s)
            / tick_s
        )
        pick = math.floor((timing.descent_duration_s + timing.grasp_dwell_s) / tick_s)
        site = math.floor(site_s[t.id] / tick_s)
        post = math.floor(
            min_jerk_leg_s(max(drop - timing.placement_radius_m, 0.0), timing.vertical_speed_mps) / tick_s
        )
        carry = dur[i] - pre - pick - site - post
        if (
            carry < 0
        ):  # the floors of the parts never sum above the floor of the whole; kept safe all the same
            pre, carry = max(0, pre + carry), 0
        out[i] = BrickPhases(pre, pick, carry, site, post)
    return out


def pickup_conflicts(tasks: Sequence[Task], clearance_m: float) -> list[set[int]]:
    """Per task index, the other brick tasks whose pickups are within ``clearance_m`` (r_c) of its own."""
    out: list[set[int]] = [set() for _ in tasks]
    picks = [(i, _start(t)) for i, t in enumerate(tasks) if isinstance(t, BrickTask)]
    for n, (i, a) in enumerate(picks):
        for j, b in picks[n + 1 :]:
            if math.dist(a, b) <= clearance_m + 1e-9:
                out[i].add(j)
                out[j].add(i)
    return out


def make_physics(
    plan: Plan,
    tasks: Sequence[Task],
    fleet: Sequence[UavSpec],
    dur: Sequence[int],
    *,
    terms: tuple[str, ...],
    timing: TaskTiming,
    cruise_altitude_m: float,
    tick_s: float,
    battery: BatteryModel = DEFAULT_BATTERY,
    clearance_m: float = DEFAULT_CLEARANCE_M,
    flown_visit: Sequence[int] | None = None,
) -> Physics:
    """The physical terms of a schedule problem (ticks); ``flown_visit``: per task its visit as flown
    (``flown``: :func:`~masonry.planner.schedule_flown.flown_terms`), which replaces ``visit``'s floor."""
    if not (math.isfinite(battery.pack_s) and battery.pack_s > 0 and 0 <= battery.low_fraction < 1):
        raise PlanningError(f"battery: a pack of {battery.pack_s!r} s down to {battery.low_fraction!r}")
    phases = brick_phases(plan, tasks, dur, timing, cruise_altitude_m, tick_s)
    visit = None if flown_visit is None else list(flown_visit)
    if visit is None and "visit" in terms:
        site = [phases[i].site if i in phases else 0 for i in range(len(tasks))]
        post = [phases[i].post if i in phases else 0 for i in range(len(tasks))]
        visit = visit_site(tasks, dur, site, post, timing, clearance_m, tick_s)
    return Physics(
        terms=terms,
        phases=phases,
        visit_ticks=visit,
        pick_conflicts=pickup_conflicts(tasks, clearance_m) if "pallet" in terms else [set() for _ in tasks],
        usable=math.floor(battery.usable_s / tick_s),
        on_pad=[math.ceil(battery.on_pad_s(cruise_altitude_m, u.home_m[2]) / tick_s - 1e-9) for u in fleet],
        tick_s=tick_s,
        cruise_speed_mps=timing.cruise_speed_mps,
        slack_m=flight_slack_m(timing),
        energy=[0] * len(fleet),
        swaps=[[] for _ in fleet],
    )


def add_pallet(
    p: _Problem,
    phys: Physics,
    part: Sequence[int],
    m: CpModel,
    s_var: Mapping[int, IntVar],
    e_var: Mapping[int, IntVar],
    a_var: Mapping[int, IntVar],
    cliques: Callable[[Sequence[set[int]], Sequence[int]], list[list[int]]],
) -> None:
    """The brick tasks' parts in order, and no overlap of pickups within r_c (earlier parts' pickups fixed)."""
    picks: dict[int, IntervalVar] = {}
    for i in part:
        ph = phys.phases.get(i)
        if ph is None:
            continue
        picks[i] = m.new_fixed_size_interval_var(s_var[i] + ph.pre, ph.pick, f"pick{i}")
        if phys.flexible(p, i):
            m.add(a_var[i] >= s_var[i] + ph.pre + ph.pick + ph.carry)
            m.add(e_var[i] == a_var[i] + ph.site + ph.post)
    for clique in cliques(phys.pick_conflicts, [i for i in part if i in picks]):
        m.add_no_overlap([picks[i] for i in clique])
    fixed: dict[int, IntervalVar] = {}
    for i in picks:
        for c in phys.pick_conflicts[i]:
            if c in p.end and c not in s_var:
                if c not in fixed:
                    lo, _hi = phys.pick_window(c, p.start[c])
                    fixed[c] = m.new_fixed_size_interval_var(lo, phys.phases[c].pick, f"fixedpick{c}")
                m.add_no_overlap([picks[i], fixed[c]])


def add_battery(
    p: _Problem,
    phys: Physics,
    k: int,
    mine: Sequence[int],
    m: CpModel,
    s_var: Mapping[int, IntVar],
    e_var: Mapping[int, IntVar],
    task_arcs: Sequence[tuple[int, int, BoolVarT]],
    node: Mapping[int, int],
    optional: list[IntervalVar],
    hint_swaps: Sequence[int],
    horizon: int,
    hint: Mapping[int, tuple[int, int, int, int]],
) -> list[tuple[int, int, BoolVarT]]:
    """UAV ``k``'s flight since its last swap along its circuit, and its swap nodes; the arcs to add to the
    circuit (``task_arcs``: (from, to, literal), -1 for the depot, as :func:`~masonry.planner.schedule._machines`
    made them)."""
    home = p.uavs[k].home_m
    cap = phys.usable
    energy = {
        i: m.new_int_var(0, max(0, cap - phys.home_ticks(_end(p.tasks[i]), home)), f"en{i}_{k}") for i in mine
    }
    # the greedy's sequence for this UAV, swaps in it (-1 - w: swap w), and its flight since the last swap: a
    # complete hint (without it CP-SAT found no first solution of the 12 m wall's 8 + 4 parts in 60 s)
    seq = sorted(
        [(hint[i][1], i) for i in mine if hint[i][0] == k] + [(w, -1 - n) for n, w in enumerate(hint_swaps)]
    )
    flown, at, prev, work = phys.energy[k], p.pos[k], p.last[k], phys.energy[k]
    for _, i in seq:
        if i < 0:
            flown, at, prev = 0, home, -1
        else:
            flown += p.leg(prev, at, i) + p.dur[i]
            work += p.leg(prev, at, i) + p.dur[i]
            at, prev = _end(p.tasks[i]), i
            m.add_hint(energy[i], flown)
    after = dict(zip([-1 - 10**9] + [i for _, i in seq], [i for _, i in seq] + [None], strict=True))
    for a, b, lit in task_arcs:
        if a < 0:
            m.add(energy[b] >= phys.energy[k] + p.leg(p.last[k], p.pos[k], b) + p.dur[b]).only_enforce_if(lit)
        else:
            m.add(energy[b] >= energy[a] + p.leg(a, _end(p.tasks[a]), b) + p.dur[b]).only_enforce_if(lit)
    # the greedy's swaps, and one more once its flight for this UAV passes half a pack: a node per swap the role's
    # whole work could need made the 12 m wall's 8 + 4 parts too large for CP-SAT to find a first solution; the
    # cap makes the model a restriction (a schedule found is still one the physics allows: docs/schedule.md)
    n_swaps = min(len(mine), len(hint_swaps) + (1 if 2 * work > cap else 0))
    pad = phys.on_pad[k]
    arcs: list[tuple[int, int, BoolVarT]] = []
    nodes: list[tuple[IntVar, IntVar]] = []
    first = len(node) + 1
    for w in range(n_swaps):
        here = m.new_bool_var(f"sw{k}_{w}")
        start = m.new_int_var(0, horizon, f"sws{k}_{w}")
        m.add_hint(here, int(w < len(hint_swaps)))
        if w < len(hint_swaps):
            m.add_hint(start, hint_swaps[w])
        optional.append(m.new_optional_fixed_size_interval_var(start, pad, here, f"swap{k}_{w}"))
        arcs.append((first + w, first + w, here.Not()))
        if nodes:
            m.add_implication(here, nodes[-1][0])
            m.add(start >= nodes[-1][1] + pad).only_enforce_if(here)
        nodes.append((here, start))
        from_depot = m.new_bool_var(f"dsw{k}_{w}")
        m.add_hint(from_depot, int(after[-1 - 10**9] == -1 - w))
        m.add(start >= p.ready[k] + phys.home_ticks(p.pos[k], home)).only_enforce_if(from_depot)
        arcs.append((0, first + w, from_depot))
        for i in mine:
            to_swap = m.new_bool_var(f"tsw{i}_{k}_{w}")
            m.add(start >= e_var[i] + phys.home_ticks(_end(p.tasks[i]), home)).only_enforce_if(to_swap)
            arcs.append((node[i], first + w, to_swap))
            m.add_hint(to_swap, int(after.get(i) == -1 - w))
            back = m.new_bool_var(f"bsw{i}_{k}_{w}")
            m.add_hint(back, int(after.get(-1 - w) == i))
            m.add(s_var[i] >= start + pad + p.leg(-1, home, i)).only_enforce_if(back)
            m.add(energy[i] >= p.leg(-1, home, i) + p.dur[i]).only_enforce_if(back)
            arcs.append((first + w, node[i], back))
    phys.swap_vars[k] = nodes
    return arcs


__all__ = [
    "ALL_TERMS",
    "DEFAULT_BATTERY",
    "PHYSICAL_TERMS",
    "BatteryModel",
    "BrickPhases",
    "Physics",
    "add_battery",
    "add_pallet",
    "brick_phases",
    "make_physics",
    "physical_terms",
    "pickup_conflicts",
    "with_visit",
]
