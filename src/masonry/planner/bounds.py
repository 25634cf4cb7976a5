"""Makespan lower bound of a plan for a fleet, and expected task durations to feed it and the dispatcher.

The bound is the larger of

* the longest dependency chain of task durations (no schedule can run a chain faster than its sum), and
* for each role, the total work of that role divided by the number of UAVs of that role (they can at best share
  it perfectly).

Conflicts only make the true optimum larger, so both terms stay valid lower bounds for any dispatcher.

The role term may weigh each task by more than its own duration: ``work_s`` (from :func:`min_cycles_s`) adds
the flight a brick UAV must make to reach the task's pickup, which happens partly *before* the task's assignment
(on the way home from its previous drop-off) and so is not in the task's duration. The chain term never counts
it (in a chain the UAV may already be right above the next pickup). docs/dispatch.md explains the argument.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from masonry.blueprint import DEFAULT_CRUISE_ALTITUDE_M, ROLES, UavSpec
from masonry.errors import PlanningError
from masonry.planner.bounds_timing import _LEGACY_FIELDS as _LEGACY_FIELDS
from masonry.planner.bounds_timing import _check_timing, _timing
from masonry.planner.tasks import BrickTask, Plan
from masonry.timing import (
    DEFAULT_TIMING,
    MIN_JERK_PEAK_TO_MEAN_SPEED,
    MIN_LEG_S,
    TaskTiming,
    spray_descent_leg_s,
)


def _check_durations(plan: Plan, durations_s: Mapping[str, float]) -> dict[str, float]:
    out: dict[str, float] = {}
    for t in plan.tasks:
        if t.done:
            continue
        if t.id not in durations_s:
            raise PlanningError(f"durations_s has no entry for task {t.id}")
        try:
            d = float(durations_s[t.id])
        except (TypeError, ValueError):
            raise PlanningError(f"durations_s[{t.id!r}] is not a number: {durations_s[t.id]!r}") from None
        if not math.isfinite(d) or d < 0.0:
            raise PlanningError(f"durations_s[{t.id!r}] must be finite and >= 0, got {d!r}")
        out[t.id] = d
    return out


def longest_chain_s(plan: Plan, durations_s: Mapping[str, float]) -> float:
    """The longest dependency chain of not-done tasks, weighted by ``durations_s`` (done tasks weigh 0).

    Raises:
        PlanningError: a not-done task has no (or a bad) duration, the graph names an unknown task or has a
            cycle.
    """
    dur = _check_durations(plan, durations_s)
    ids = [t.id for t in plan.tasks]
    index = {tid: i for i, tid in enumerate(ids)}
    n = len(ids)
    prereqs: list[list[int]] = [[] for _ in range(n)]
    n_dependents = [0] * n
    dependents: list[list[int]] = [[] for _ in range(n)]
    for u, v in plan.dependencies:
        if u not in index or v not in index:
            raise PlanningError(f"dependency ({u}, {v}) names an unknown task")
        iu, iv = index[u], index[v]
        prereqs[iu].append(iv)
        dependents[iv].append(iu)
        n_dependents[iv] += 1
    weight = [dur.get(tid, 0.0) for tid in ids]
    # Kahn's algorithm in prerequisite-first order: finish[i] = weight[i] + max(finish of prerequisites).
    missing = [len(prereqs[i]) for i in range(n)]
    order = [i for i in range(n) if missing[i] == 0]
    finish = [0.0] * n
    k = 0
    while k < len(order):
        i = order[k]
        k += 1
        finish[i] = weight[i] + max((finish[p] for p in prereqs[i]), default=0.0)
        for d in dependents[i]:
            missing[d] -= 1
            if missing[d] == 0:
                order.append(d)
    if len(order) != n:
        raise PlanningError(
            f"the dependency graph has a cycle through task {ids[missing.index(max(missing))]}"
        )
    return max(finish, default=0.0)


def lower_bound_s(
    plan: Plan,
    fleet: Sequence[UavSpec],
    durations_s: Mapping[str, float],
    *,
    work_s: Mapping[str, float] | None = None,
) -> float:
    """A makespan lower bound: max(longest dependency chain, each role's total work / its number of UAVs).

    Args:
        plan: the plan; its done tasks (pre-placed bricks) cost nothing.
        fleet: the UAVs at the start of the mission.
        durations_s: the duration of every not-done task (e.g. from :func:`estimate_durations_s`, or the
            durations measured in a run); the chain term adds these.
        work_s: the time each not-done task takes out of its UAV's timeline, for the role term (default:
            ``durations_s``); e.g. :func:`min_cycles_s`, which adds the flight to the pickup that a
            minimum duration cannot count. Only sound with durations that leave that flight out.

    Returns:
        The bound in seconds (0.0 for a plan with nothing to do).

    Raises:
        PlanningError: a duration is missing or bad, the dependency graph is cyclic or names unknown tasks, or
            a role has work but no UAV (no makespan is finite then).
    """
    dur = _check_durations(plan, durations_s)
    per_task = dur if work_s is None else _check_durations(plan, work_s)
    count = dict.fromkeys(ROLES, 0)
    for spec in fleet:
        count[spec.role] = count.get(spec.role, 0) + 1
    work = dict.fromkeys(ROLES, 0.0)
    tasks_of = dict.fromkeys(ROLES, 0)
    for t in plan.tasks:
        if not t.done:
            work[t.kind] += per_task[t.id]
            tasks_of[t.kind] += 1
    per_role = 0.0
    for role in ROLES:
        if tasks_of[role] and not count[role]:
            raise PlanningError(
                f"no {role} UAV in the fleet for {tasks_of[role]} {role} task{'' if tasks_of[role] == 1 else 's'}"
            )
        if count[role]:
            per_role = max(per_role, work[role] / count[role])
    return max(longest_chain_s(plan, dur), per_role)


def estimate_durations_s(
    plan: Plan,
    fleet: Sequence[UavSpec],
    *,
    timing: TaskTiming | None = None,
    cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M,
    brick_handling_s: float = 4.0,
    adhesion_handling_s: float = 1.5,
    include_approach: bool = True,
    **deprecated: Any,
) -> dict[str, float]:
    """Expected duration of every not-done task, from the flight it implies.

    A brick task: the approach to the pickup (from the nearest brick UAV home or, if nearer, from its own
    drop-off, where a UAV coming back from the previous placement is), a minimum-jerk descent of
    ``timing.descent_duration_s``, the climb back to cruise altitude, the carry to the drop-off at
    ``timing.cruise_speed_mps``, a second descent, the climb, and ``brick_handling_s`` of settling, estimation
    and grasp/release dwells. An adhesion task: its first descent (:func:`masonry.timing.spray_descent_leg_s`: its drop at
    ``timing.vertical_speed_mps``, at most ``timing.spray_descent_s``), the segment at
    ``timing.spray_speed_mps``, the climb, and ``adhesion_handling_s``; its approach counts as zero (consecutive
    segments are neighbours). Horizontal legs use the cruise speed, climbs ``timing.vertical_speed_mps`` (as
    mean speeds: an estimate, not a bound). With ``include_approach=False`` no approach is counted (for a
    model that adds the real flight to each task's start, as :func:`dispatch_makespan_s` with
    ``cruise_speed_mps`` does).

    Args:
        timing: the UAVs' task timing (default: ``UavConfig``'s, :data:`masonry.timing.DEFAULT_TIMING`).
        deprecated: the old keywords ``cruise_speed_mps``, ``vertical_speed_mps``, ``descent_s``,
            ``spray_speed_mps``, ``spray_descent_s`` (a DeprecationWarning; they replace those of ``timing``).

    Returns:
        task id -> seconds, for every not-done task.

    Raises:
        PlanningError: a speed or time is not finite and positive (times: >= 0).
    """
    t_ = _timing(
        "estimate_durations_s",
        timing,
        deprecated,
        ("cruise_speed_mps", "vertical_speed_mps", "descent_s", "spray_speed_mps", "spray_descent_s"),
    )
    _check_timing(
        t_,
        ("cruise_speed_mps", "vertical_speed_mps", "spray_speed_mps"),
        ("descent_duration_s", "spray_descent_s"),
    )
    for name, value in (
        ("cruise_altitude_m", cruise_altitude_m),
        ("brick_handling_s", brick_handling_s),
        ("adhesion_handling_s", adhesion_handling_s),
    ):
        if not math.isfinite(value) or value < 0.0:
            raise PlanningError(f"{name} must be finite and >= 0, got {value!r}")
    cruise_speed_mps, vertical_speed_mps = t_.cruise_speed_mps, t_.vertical_speed_mps
    descent_s, spray_descent_s, spray_speed_mps = (
        t_.descent_duration_s,
        t_.spray_descent_s,
        t_.spray_speed_mps,
    )
    brick_homes = [spec.home_m for spec in fleet if spec.role == "brick"]

    def horizontal(a: Sequence[float], b: Sequence[float]) -> float:
        return math.hypot(a[0] - b[0], a[1] - b[1])

    def climb(z_m: float) -> float:
        return max(cruise_altitude_m - z_m, 0.0) / vertical_speed_mps

    out: dict[str, float] = {}
    for t in plan.tasks:
        if t.done:
            continue
        if isinstance(t, BrickTask):
            pickup = t.pickup_m if t.pickup_m is not None else t.position_m
            carry = horizontal(pickup, t.position_m)
            approach = (
                min([carry] + [horizontal(h, pickup) for h in brick_homes]) if include_approach else 0.0
            )
            out[t.id] = (
                (approach + carry) / cruise_speed_mps
                + 2.0 * descent_s
                + climb(pickup[2])
                + climb(t.position_m[2])
                + brick_handling_s
            )
        else:
            surface_m = max(t.start_m[2], t.end_m[2])
            nozzle_body_m = surface_m + t_.spray_height_m - t_.nozzle_offset_m[2]
            drop_m = max(cruise_altitude_m, t_.spray_altitude_m(surface_m)) - nozzle_body_m
            out[t.id] = (
                spray_descent_leg_s(drop_m, vertical_speed_mps, spray_descent_s)
                + t.length_m / spray_speed_mps
                + climb(min(t.start_m[2], t.end_m[2]))
                + adhesion_handling_s
            )
    return out


def _min_jerk_time_to_within(distance_m: float, tolerance_m: float) -> float:
    """Fraction of a rest-to-rest minimum-jerk move after which the reference is within ``tolerance_m`` of its end."""
    if distance_m <= tolerance_m:
        return 0.0
    goal = 1.0 - tolerance_m / distance_m
    lo, hi = 0.0, 1.0
    for _ in range(50):  # s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 is increasing on [0, 1]
        mid = 0.5 * (lo + hi)
        if mid * mid * mid * (10.0 + mid * (-15.0 + 6.0 * mid)) < goal:
            lo = mid
        else:
            hi = mid
    return lo


_MIN_DURATION_KEYWORDS = (
    "cruise_speed_mps",
    "vertical_speed_mps",
    "leg_peak_factor",
    "min_leg_s",
    "control_period_s",
    "clearance_m",
    "settle_time_s",
    "min_estimates",
    "descent_s",
    "grasp_press_m",
    "grasp_dwell_s",
    "placement_radius_m",
    "release_dwell_s",
    "stable_time_s",
    "spray_descent_s",
    "spray_speed_mps",
    "close_dwell_s",
    "chain_descent_s",
    "effector_offset_z_m",
)


def min_durations_s(
    plan: Plan,
    *,
    timing: TaskTiming | None = None,
    cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M,
    **deprecated: Any,
) -> dict[str, float]:
    """The least time the state machines (``masonry.fsm``, flying ``timing``) can take for each task.

    A sound per-task lower bound for :func:`lower_bound_s` (``masonry sim`` reports the bound with these): every
    state of a task is counted at its shortest, with perfect tracking and no wait, from assignment to the
    result. The flight to the task's start counts as one minimum leg (:data:`~masonry.timing.MIN_LEG_S`): a UAV
    may be turned back to a task from anywhere on its way home, even right above it. A lateral or vertical leg
    of the machines is a rest-to-rest minimum-jerk move lasting :func:`~masonry.timing.min_jerk_leg_s` (1.875 x
    distance / peak speed, at least ``MIN_LEG_S``); the placing descent counts until its reference is within
    the release radius. docs/planner.md lists the terms and where their numbers come from.

    Brick task: approach, estimate (settle + ``min_estimates`` frames at the control rate), align, descent
    (``descent_duration_s``), grasp dwell, climb to the transit altitude (:meth:`TaskTiming.carry_altitude_m`),
    the carry to the drop-off, align, descent to the release, release dwell, verify, climb. Adhesion task:
    approach, hover ``stable_time_s``, descent (the shorter of ``spray_descent_s`` and ``chain_descent_s``: a
    segment that starts where the UAV's last one ended is sprayed without climbing out), the segment at
    ``spray_speed_mps``, ``close_dwell_s``; an adhesion UAV reports the task done once the valve is closed, so
    its climb out is not part of the task.

    Args:
        timing: the UAVs' task timing (default: ``UavConfig``'s, :data:`masonry.timing.DEFAULT_TIMING`).
        cruise_altitude_m: the blueprint's cruise altitude (the UAVs' ``UavConfig.cruise_altitude_m``).
        deprecated: the old keywords (``descent_s``, ``cruise_speed_mps``, ..., ``effector_offset_z_m``,
            ``leg_peak_factor``, ``min_leg_s``): a DeprecationWarning; they replace those of ``timing``.

    Returns:
        task id -> seconds, for every not-done task.
    """
    t_ = _timing("min_durations_s", timing, deprecated, _MIN_DURATION_KEYWORDS)
    return _min_durations_s(
        plan,
        t_,
        cruise_altitude_m,
        float(deprecated.get("leg_peak_factor", MIN_JERK_PEAK_TO_MEAN_SPEED)),
        float(deprecated.get("min_leg_s", MIN_LEG_S)),
    )


def _min_durations_s(
    plan: Plan, timing: TaskTiming, cruise_altitude_m: float, leg_peak_factor: float, min_leg_s: float
) -> dict[str, float]:
    eff_z = timing.effector_offset_m[2]

    def lateral(d_m: float) -> float:
        return max(min_leg_s, leg_peak_factor * d_m / timing.cruise_speed_mps)

    def vertical(dz_m: float) -> float:
        return max(min_leg_s, leg_peak_factor * max(dz_m, 0.0) / timing.vertical_speed_mps)

    tick = timing.control_period_s
    out: dict[str, float] = {}
    for t in plan.tasks:
        if t.done:
            continue
        if isinstance(t, BrickTask):
            h = t.size_m[2]
            pickup = t.pickup_m if t.pickup_m is not None else t.position_m
            top_drop = t.position_m[2] + h / 2.0
            transit = max(cruise_altitude_m, timing.carry_altitude_m(top_drop, h))
            # the brick lies on the ground (or higher, as the pickup says): its top at least h up
            top_pick = max(pickup[2] + h / 2.0, h)
            grasp_body_z = top_pick - timing.grasp_press_m - eff_z
            release_body_z = top_drop - eff_z
            drop = transit - release_body_z
            out[t.id] = (
                min_leg_s  # approach
                + timing.settle_time_s
                + (timing.min_estimates - 1) * tick  # estimate
                + min_leg_s  # align
                + timing.descent_duration_s
                + timing.grasp_dwell_s
                + vertical(transit - grasp_body_z)
                + tick  # verify
                + lateral(math.hypot(t.position_m[0] - pickup[0], t.position_m[1] - pickup[1]))
                + min_leg_s  # align above the drop-off
                + timing.descent_duration_s * _min_jerk_time_to_within(drop, timing.placement_radius_m)
                + timing.release_dwell_s
                + tick  # release, verify
                + vertical(drop - timing.placement_radius_m)
            )
        else:
            out[t.id] = (
                min_leg_s  # approach
                + timing.stable_time_s
                + min(timing.spray_descent_s, timing.chain_descent_s)
                + t.length_m / timing.spray_speed_mps
                + timing.close_dwell_s
            )
    return out


def flight_slack_m(timing: TaskTiming) -> float:
    """How far a UAV may be from a point it is said to be at: both ends' arrive tolerance and the effector's
    horizontal offset (for the sound flight times of :func:`min_cycles_s` and :func:`empty_flight_s`)."""
    x, y, _z = timing.effector_offset_m
    return 2.0 * timing.arrive_tolerance_m + math.hypot(x, y)


def empty_flight_s(
    from_m: Sequence[float],
    to_m: Sequence[float],
    *,
    timing: TaskTiming | None = None,
    min_leg_s: float = MIN_LEG_S,
) -> float:
    """The least time between a UAV at ``from_m`` (the end of its last task, or its home) and the start of a task
    at ``to_m`` that is not already in that task's :func:`min_durations_s`.

    The argument of :func:`min_cycles_s` for one known predecessor: the UAV covers the horizontal distance
    (less :func:`flight_slack_m`) no faster than ``timing.cruise_speed_mps``, and the task's minimum duration
    already counts its approach as one ``min_leg_s``. The offline schedule's sequence-dependent empty flights
    (:mod:`masonry.planner.schedule`) are these.
    """
    t_ = DEFAULT_TIMING if timing is None else timing
    d_m = math.hypot(from_m[0] - to_m[0], from_m[1] - to_m[1])
    return max(0.0, max(0.0, d_m - flight_slack_m(t_)) / t_.cruise_speed_mps - min_leg_s)


def min_site_s(
    plan: Plan, *, timing: TaskTiming | None = None, cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M
) -> dict[str, float]:
    """The least part of each task's :func:`min_durations_s` that its UAV spends at the task's site.

    What ``--reservation site`` keeps apart (:mod:`masonry.mission.sites`: from the grant of the flight down to
    the site to the request to leave it). Counted at its shortest and without the ends that may fall outside
    the visit: a brick's placing descent (until the release radius), release dwell and verify; an adhesion
    segment's descent, spray and valve close. Always <= the task's minimum duration (a part of it).
    """
    t_ = DEFAULT_TIMING if timing is None else timing
    eff_z = t_.effector_offset_m[2]
    out: dict[str, float] = {}
    for t in plan.tasks:
        if t.done:
            continue
        if isinstance(t, BrickTask):
            h = t.size_m[2]
            top_drop = t.position_m[2] + h / 2.0
            transit = max(cruise_altitude_m, t_.carry_altitude_m(top_drop, h))
            drop = transit - (top_drop - eff_z)
            out[t.id] = (
                t_.descent_duration_s * _min_jerk_time_to_within(drop, t_.placement_radius_m)
                + t_.release_dwell_s
                + t_.control_period_s
            )
        else:
            out[t.id] = (
                min(t_.spray_descent_s, t_.chain_descent_s)
                + t.length_m / t_.spray_speed_mps
                + t_.close_dwell_s
            )
    return out


def min_cycles_s(
    plan: Plan,
    fleet: Sequence[UavSpec],
    durations_s: Mapping[str, float] | None = None,
    *,
    timing: TaskTiming | None = None,
    cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M,
    min_leg_s: float = MIN_LEG_S,
    **deprecated: Any,
) -> dict[str, float]:
    """The least time each task takes out of its UAV's timeline: its minimum duration plus the unseen approach.

    For :func:`lower_bound_s`'s ``work_s``. Between the end of a brick UAV's previous completed task (it is then
    above that task's drop-off) -- or the start of the mission (it is at its home) -- and its arrival above the
    pickup of its next completed task j, the UAV must cover the horizontal distance from there to the pickup.
    Whatever it flies meanwhile (home and turned back, failed attempts), its reference never moves faster than
    a minimum-jerk leg's peak speed, ``timing.cruise_speed_mps`` (a leg lasts
    :data:`~masonry.timing.MIN_JERK_PEAK_TO_MEAN_SPEED` x distance / speed), and each end may be off by
    ``timing.arrive_tolerance_m`` (and the effector's horizontal offset). So that stretch lasts at least
    (d_j - slack) / cruise speed, where d_j is the distance from the pickup to the nearest possible start: any
    other brick's drop-off or any brick UAV's home. These stretches and the rest of the tasks are disjoint on
    the UAV's timeline. ``durations_s`` (default :func:`min_durations_s` with ``timing``) already counts the
    last approach leg as ``min_leg_s``, so a brick task weighs its duration + max(0, flight - ``min_leg_s``).
    Adhesion tasks weigh their duration (consecutive segments touch: no sound approach term).

    Args:
        timing: the UAVs' task timing (default: ``UavConfig``'s, :data:`masonry.timing.DEFAULT_TIMING`).
        deprecated: the old keywords ``cruise_speed_mps``, ``arrive_tolerance_m``, ``effector_offset_m`` (a
            DeprecationWarning; they replace those of ``timing``).

    Returns:
        task id -> seconds, for every not-done task (>= ``durations_s``).

    Raises:
        PlanningError: a bad speed or tolerance, or a missing or bad duration.
    """
    import numpy as np
    from scipy.spatial import cKDTree

    t_ = _timing(
        "min_cycles_s", timing, deprecated, ("cruise_speed_mps", "arrive_tolerance_m", "effector_offset_m")
    )
    _check_timing(t_, ("cruise_speed_mps",), ("arrive_tolerance_m",))
    cruise_speed_mps = t_.cruise_speed_mps
    if not math.isfinite(min_leg_s) or min_leg_s < 0.0:
        raise PlanningError(f"min_leg_s must be finite and >= 0, got {min_leg_s!r}")
    if durations_s is None:
        durations_s = _min_durations_s(plan, t_, cruise_altitude_m, MIN_JERK_PEAK_TO_MEAN_SPEED, min_leg_s)
    out = dict(_check_durations(plan, durations_s))
    slack = flight_slack_m(t_)
    bricks = [t for t in plan.tasks if isinstance(t, BrickTask)]
    todo = [i for i, t in enumerate(bricks) if not t.done]
    if not todo:
        return out
    homes = np.array([s.home_m[:2] for s in fleet if s.role == "brick"], dtype=float).reshape(-1, 2)
    drops = np.array([t.position_m[:2] for t in bricks], dtype=float)
    picks = np.array(
        [(t.pickup_m if t.pickup_m is not None else t.position_m)[:2] for t in bricks], dtype=float
    )
    # nearest drop-off other than the brick's own (the UAV cannot have completed the task it is about to do)
    k = min(2, len(bricks))
    dist, idx = cKDTree(drops).query(picks[todo], k=k)
    dist = np.asarray(dist, dtype=float).reshape(len(todo), k)
    idx = np.asarray(idx).reshape(len(todo), k)
    own = idx[:, 0] == np.asarray(todo)
    nearest_drop = np.where(own, dist[:, 1] if k > 1 else np.inf, dist[:, 0])
    if len(homes):
        d_home = np.sqrt(((picks[todo][:, None, :] - homes[None, :, :]) ** 2).sum(axis=2)).min(axis=1)
        nearest = np.minimum(nearest_drop, d_home)
    else:
        nearest = nearest_drop
    for row, i in enumerate(todo):
        flight = max(0.0, float(nearest[row]) - slack) / cruise_speed_mps
        out[bricks[i].id] += max(0.0, flight - min_leg_s)
    return out


def dispatch_makespan_s(
    plan: Plan,
    fleet: Sequence[UavSpec],
    durations_s: Mapping[str, float],
    policy: str = "critical-path",
    *,
    cruise_speed_mps: float | None = None,
) -> float:
    """The makespan the reactive dispatcher reaches when every task takes exactly its duration (no faults).

    A discrete-event run of :class:`~masonry.planner.dispatch.Dispatcher` in model time: useful to compare
    policies against :func:`lower_bound_s` without flying anything. With ``cruise_speed_mps`` the flight from
    the UAV's position (its home, then where its last task ended) to the task's start is added at that speed
    (then ``durations_s`` should not include it); without it, moving between tasks is free.

    Raises:
        PlanningError: as :class:`Dispatcher` and :func:`lower_bound_s`; or the run cannot finish (a role with
            work has no UAV).
    """
    import heapq

    from masonry.planner.dispatch import Dispatcher, task_start_m

    dur = _check_durations(plan, durations_s)
    if cruise_speed_mps is not None and (not math.isfinite(cruise_speed_mps) or cruise_speed_mps <= 0.0):
        raise PlanningError(f"cruise_speed_mps must be finite and > 0, got {cruise_speed_mps!r}")
    d = Dispatcher(plan, fleet, policy, durations_s=dur)
    where = {spec.name: tuple(spec.home_m) for spec in fleet}
    now = 0.0
    events: list[tuple[float, int, str]] = []
    seq = 0
    while True:
        for a in d.assign():
            task = d.task(a.task_id)
            travel = 0.0
            if cruise_speed_mps is not None:
                travel = math.dist(where[a.uav], task_start_m(task)) / cruise_speed_mps
            heapq.heappush(events, (now + travel + dur[a.task_id], seq, a.task_id))
            seq += 1
        if not events:
            break
        now, _, tid = heapq.heappop(events)
        uav = d.in_progress[tid]
        d.complete(tid)
        t = d.task(tid)
        where[uav] = t.position_m if isinstance(t, BrickTask) else t.end_m
    if not d.finished:
        raise PlanningError(
            f"the plan cannot finish with this fleet: {len(d.remaining)} task{'' if len(d.remaining) == 1 else 's'} left"
        )
    return now
