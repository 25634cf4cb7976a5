"""The adhesive's deadlines in the offline schedule (issue 31; docs/schedule.md, "Adhesive deadlines").

Pure apart from the CP-SAT model it is handed (:mod:`masonry.planner.schedule` builds it and calls
:func:`add_deadlines`). The plan's edges (:mod:`masonry.planner.deadlines`) become, in ticks:

* ``open`` (A, B, lag): B's site part starts at most lag after A ends. With ``site`` the site part is its own
  variable; with ``task`` it is the end of B's interval less B's minimum site part
  (:func:`~masonry.planner.bounds.min_site_s`): at minimum durations the placing descent ends the task;
* ``cure`` (B, A', lag): A' starts at least lag after B ends.

Lags are rounded down to ticks, like every duration of the model. The greedy list schedule (the hint and the
fallback) waits for cure times and sprays a bead only once every bead under its brick can be sprayed
(:func:`pick`), so its brick follows soon; CP-SAT enforces the open times exactly.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, MutableSequence, Sequence
from dataclasses import dataclass, field
from typing import Any

from masonry.errors import PlanningError
from masonry.planner.bounds import min_site_s
from masonry.planner.tasks import BrickTask, Plan, Task
from masonry.timing import TaskTiming


class DeadlinesUnmet(PlanningError):
    """No schedule meets the open times (a user's value: ``masonry schedule`` exits 2 with the line)."""

    @classmethod
    def within(cls, budget_s: float, tasks: int) -> DeadlinesUnmet:
        """CP-SAT found none in ``budget_s`` for a part of ``tasks`` tasks (the greedy fallback misses them too)."""
        return cls(
            f"CP-SAT found no schedule meeting the open times in {budget_s:.1f} s (a part of {tasks} tasks): "
            "give a longer `time_limit` or a longer open time",
            options=("time_limit",),
        )


@dataclass(frozen=True)
class TickDeadlines:
    """The deadlines among the not-done tasks of a schedule problem, as task indices and ticks."""

    #: (adhesion, brick, max lag)
    opens: tuple[tuple[int, int, int], ...] = ()
    #: (brick, adhesion, min lag)
    cures: tuple[tuple[int, int, int], ...] = ()
    #: per brick task index (with an open edge), its minimum site part in ticks
    brick_site: Mapping[int, int] = field(default_factory=dict)

    @property
    def has_open(self) -> bool:
        return bool(self.opens)

    def __bool__(self) -> bool:
        return bool(self.opens or self.cures)


def tick_deadlines(
    plan: Plan,
    tasks: Sequence[Task],
    *,
    timing: TaskTiming,
    cruise_altitude_m: float,
    tick_s: float,
) -> TickDeadlines:
    """The plan's deadlines among ``tasks`` (the not-done ones, in the problem's order)."""
    if not plan.deadlines:
        return TickDeadlines()
    index = {t.id: i for i, t in enumerate(tasks)}
    site = min_site_s(plan, timing=timing, cruise_altitude_m=cruise_altitude_m)
    opens: list[tuple[int, int, int]] = []
    cures: list[tuple[int, int, int]] = []
    brick_site: dict[int, int] = {}
    for d in plan.deadlines:
        a, b = index.get(d.adhesion), index.get(d.brick)
        if a is None or b is None:
            continue
        lag = math.floor(d.lag_s / tick_s)
        if d.kind == "open":
            opens.append((a, b, lag))
            brick_site[b] = math.floor(site[d.brick] / tick_s)
        else:
            cures.append((b, a, lag))
    return TickDeadlines(tuple(opens), tuple(cures), brick_site)


def add_deadlines(
    deadlines: TickDeadlines,
    part: Sequence[int],
    m: Any,
    s_var: Mapping[int, Any],
    e_var: Mapping[int, Any],
    a_var: Mapping[int, Any],
    fixed_end: Mapping[int, int],
) -> None:
    """The open and cure edges of the tasks of ``part`` (earlier parts' tasks are fixed: ``fixed_end``)."""
    in_part = set(part)
    for a, b, lag in deadlines.opens:
        if b not in in_part:
            continue
        site_start = a_var[b] if b in a_var else e_var[b] - deadlines.brick_site[b]
        if a in in_part:
            m.add(site_start <= e_var[a] + lag)
        elif a in fixed_end:
            m.add(site_start <= fixed_end[a] + lag)
    for b, a, lag in deadlines.cures:
        if a not in in_part:
            continue
        if b in in_part:
            m.add(s_var[a] >= e_var[b] + lag)
        elif b in fixed_end:
            m.add(s_var[a] >= fixed_end[b] + lag)


def check_open_feasible(
    deadlines: TickDeadlines, tasks: Sequence[Task], dur: Sequence[int], tick_s: float, reservation: str
) -> None:
    """With ``task`` a brick starts after the beads under it end, so an open time shorter than the brick's
    way to its site (its minimum duration less its site part) can never be met.

    Raises:
        DeadlinesUnmet: naming the brick and both times.
    """
    if reservation != "task":
        return
    for _, b, lag in deadlines.opens:
        need = dur[b] - deadlines.brick_site[b]
        if lag < need:
            raise DeadlinesUnmet(
                f"open time {lag * tick_s:g} s is shorter than brick task {tasks[b].id} needs from its "
                f"assignment to its site ({need * tick_s:.1f} s at the least): no schedule can meet it"
            )


def missed_open(
    deadlines: TickDeadlines,
    placed: Mapping[int, tuple[int, int, int, int]],
    fixed_end: Mapping[int, int],
    reservation: str,
) -> list[tuple[int, int]]:
    """The open edges a part's schedule (task -> (uav, start, end, site start)) misses: (adhesion, brick)."""
    out: list[tuple[int, int]] = []
    for a, b, lag in deadlines.opens:
        if b not in placed:
            continue
        end_a = placed[a][2] if a in placed else fixed_end.get(a)
        _, _, end_b, site_b = placed[b]
        start = site_b if reservation == "site" else end_b - deadlines.brick_site[b]
        if end_a is not None and start > end_a + lag:
            out.append((a, b))
    return out


def cure_ready(deadlines: TickDeadlines, i: int, end: Mapping[int, int]) -> int:
    """The earliest tick adhesion task ``i`` may start for the cure of the bricks under it (0: none)."""
    return max((end[b] + lag for b, a, lag in deadlines.cures if a == i and b in end), default=0)


def pick(
    deadlines: TickDeadlines,
    tasks: Sequence[Task],
    prereqs: Sequence[Sequence[int]],
    avail: MutableSequence[int],
    scheduled: Mapping[int, Any],
) -> int:
    """The next task of the greedy list schedule from ``avail`` (sorted best first), removed from it.

    Without open deadlines the first. With them, a bead is laid only when every bead under its brick is
    available or laid already (so the brick can follow it), unless nothing else is available.
    """
    if not deadlines.has_open:
        return avail.pop(0)
    above = {a: b for a, b, _ in deadlines.opens}
    ready = set(avail)
    for k, i in enumerate(avail):
        b = above.get(i)
        if isinstance(tasks[i], BrickTask) or b is None:
            return avail.pop(k)
        if all(v in ready or v in scheduled for v in prereqs[b]):
            return avail.pop(k)
    return avail.pop(0)


def serial_horizon(dur: Sequence[int], flights: Sequence[int], deadlines: TickDeadlines) -> int:
    """A horizon that every deadline-respecting schedule fits in: one task after another, each with its
    longest empty flight, each cure waited for in full."""
    return sum(dur) + sum(flights) + sum(lag for _, _, lag in deadlines.cures)


__all__ = [
    "DeadlinesUnmet",
    "TickDeadlines",
    "add_deadlines",
    "check_open_feasible",
    "cure_ready",
    "missed_open",
    "pick",
    "serial_horizon",
    "tick_deadlines",
]
