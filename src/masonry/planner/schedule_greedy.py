"""The offline schedule's greedy list schedule (:mod:`masonry.planner.schedule`): the solver's hint, its horizon,
and the answer of a part where CP-SAT found nothing in time. The same constraints as the model: highest remaining
chain first, each task on the UAV of its role where it starts first."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from masonry.planner.dispatch_values import task_end_m
from masonry.planner.schedule_deadlines import cure_ready, pick
from masonry.planner.schedule_physical import clear_of

if TYPE_CHECKING:
    from masonry.planner.schedule import _Problem


def _earliest(
    p: _Problem, i: int, t0: int, a0: int, placed: Mapping[int, tuple[int, int]], lo: int = 0, hi: int = 0
) -> tuple[int, int]:
    """Earliest (start, site start) of task ``i`` from ``t0`` (and its site part from ``a0``) clear of the
    placed conflicting intervals (``placed``: task -> its kept-apart interval)."""
    off = p.site_offset_max(i) if p.reservation == "site" else 0
    length = p.site[i] if p.reservation == "site" else p.dur[i]
    t = clear_of(
        sorted(placed[j] for j in p.conflicts[i] if j in placed),
        max(t0, a0 - off),
        off - lo,
        length + lo + hi,
    )
    return t, t + off


def greedy(p: _Problem, part: Sequence[int]) -> dict[int, tuple[int, int, int, int]]:
    """A list schedule of ``part`` after what is placed: task -> (uav, start, end, site start), ticks.

    Highest remaining chain first; each task on the UAV of its role where it ends first.
    """
    in_part = set(part)
    dependents: dict[int, list[int]] = {i: [] for i in part}
    missing = dict.fromkeys(part, 0)
    for i in part:
        for v in p.prereqs[i]:
            if v in in_part:
                dependents[v].append(i)
                missing[i] += 1
    chain: dict[int, int] = {}
    for i in sorted(part, key=lambda i: -_depth(p, i, in_part)):
        chain[i] = p.dur[i] + max((chain[d] for d in dependents[i] if d in chain), default=0)
    ready = list(p.ready)
    pos = list(p.pos)
    prev = list(p.last)
    kept = dict(p.kept)
    start, end, site_start = dict(p.start), dict(p.end), dict(p.site_start)
    phys = p.phys
    picks = {j: phys.pick_window(j, p.start[j]) for j in p.start if j in phys.phases} if phys else {}
    energy = list(phys.energy) if phys else []
    if phys is not None:
        phys.hint_swaps = {k: [] for k in range(len(p.uavs))}
    out: dict[int, tuple[int, int, int, int]] = {}
    avail = [i for i in part if missing[i] == 0]
    while avail:
        avail.sort(key=lambda i: (-chain[i], i))
        i = pick(p.deadlines, p.tasks, p.prereqs, avail, start)
        t0, a0 = cure_ready(p.deadlines, i, end), 0
        for v in p.prereqs[i]:
            if p.prefetch(i):
                t0, a0 = max(t0, start[v]), max(a0, end[v])
            else:
                t0 = max(t0, end[v])
        k, s, a, e, swap = _best_uav(p, i, t0, a0, ready, pos, prev, energy, kept, picks)
        if phys is not None:
            if swap:
                phys.hint_swaps[k].append(ready[k] + phys.home_ticks(pos[k], p.uavs[k].home_m))
                pos[k], prev[k], energy[k] = p.uavs[k].home_m, -1, 0
            energy[k] += p.leg(prev[k], pos[k], i) + p.dur[i]
            if i in phys.phases:
                picks[i] = phys.pick_window(i, s)
        start[i], end[i], site_start[i] = s, e, a
        lo, hi = p.around(prev[k], i, -2)  # its climb out counted: the next task is not known yet
        kept[i] = (a - lo, a + p.site[i] + hi) if p.reservation == "site" else (s, e)
        ready[k], pos[k], prev[k] = e, task_end_m(p.tasks[i]), i
        out[i] = (k, s, e, a)
        for d in dependents[i]:
            missing[d] -= 1
            if missing[d] == 0:
                avail.append(d)
    return out


def _best_uav(
    p: _Problem,
    i: int,
    t0: int,
    a0: int,
    ready: Sequence[int],
    pos: Sequence[Sequence[float]],
    prev: Sequence[int],
    energy: Sequence[int],
    kept: Mapping[int, tuple[int, int]],
    picks: Mapping[int, tuple[int, int]],
) -> tuple[int, int, int, int, bool]:
    """The greedy's UAV for task ``i``: (UAV, start, site start, end, swaps first), the earliest start."""
    phys = p.phys
    best: tuple[int, int, int, int, bool] | None = None
    for k, spec in enumerate(p.uavs):
        if spec.role != p.tasks[i].kind:
            continue
        swap = phys is not None and phys.swap_before(p, k, i, pos[k], energy[k], prev[k])
        r_k = ready[k] + phys.home_ticks(pos[k], spec.home_m) + phys.on_pad[k] if swap and phys else ready[k]
        t_k = max(t0, r_k + (p.leg(-1, spec.home_m, i) if swap else p.leg(prev[k], pos[k], i)))
        if phys is not None and i in phys.phases and phys.pallet:
            s, a, e = phys.earliest(p, i, t_k, a0, kept, picks)
        else:
            s, a = _earliest(p, i, t_k, a0, kept, *p.around(-1 if swap else prev[k], i, -2))
            e = s + p.dur[i]
        if best is None or s < best[1]:
            best = (k, s, a, e, swap)
    assert best is not None  # _problem checked every role has a UAV
    return best


def _depth(p: _Problem, i: int, in_part: set[int]) -> int:
    """How many prerequisites deep ``i`` sits within the part (for a dependents-first order)."""
    depth, frontier = 0, [i]
    seen = {i}
    while frontier:
        nxt = [v for j in frontier for v in p.prereqs[j] if v in in_part and v not in seen]
        seen.update(nxt)
        if nxt:
            depth += 1
        frontier = nxt
    return depth


__all__ = ["greedy"]
