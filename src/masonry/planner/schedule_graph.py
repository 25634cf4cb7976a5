"""Graph helpers of the offline schedule's model (:mod:`masonry.planner.schedule`): ancestors, a clique cover, the
decomposition's parts, the precedences of G^d."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from masonry.planner.tasks import BrickTask

if TYPE_CHECKING:
    from ortools.sat.python.cp_model import CpModel, IntVar

    from masonry.planner.schedule import _Problem


def ancestors(prereqs: Sequence[Sequence[int]], part: Sequence[int]) -> dict[int, set[int]]:
    """Per task of ``part``, its prerequisites within the part, transitively."""
    in_part = set(part)
    memo: dict[int, set[int]] = {}

    def of(i: int) -> set[int]:
        stack = [i]
        while stack:
            j = stack[-1]
            todo = [v for v in prereqs[j] if v in in_part and v not in memo]
            if todo:
                stack.extend(todo)
                continue
            acc: set[int] = set()
            for v in prereqs[j]:
                if v in in_part:
                    acc.add(v)
                    acc |= memo[v]
            memo[j] = acc
            stack.pop()
        return memo[i]

    return {i: of(i) for i in part}


def clique_cover(conflicts: Sequence[set[int]], part: Sequence[int]) -> list[list[int]]:
    """Cliques of G^c within ``part`` that cover each of its conflict edges (greedy)."""
    in_part = set(part)
    covered: set[tuple[int, int]] = set()
    out: list[list[int]] = []
    for i in part:
        for j in sorted(conflicts[i] & in_part):
            if j < i or (i, j) in covered:
                continue
            clique = [i, j]
            common = conflicts[i] & conflicts[j] & in_part
            for k in sorted(common):
                if all(k in conflicts[m] for m in clique):
                    clique.append(k)
            for a in clique:
                for b in clique:
                    if a < b:
                        covered.add((a, b))
            out.append(clique)
    return out


def parts(p: _Problem, decomposition: str, max_full: int, part_tasks: int) -> list[list[int]]:
    """The whole plan as one part, or (``course``) whole courses in order, gathered up to ``part_tasks``
    (:data:`~masonry.planner.schedule.PART_TASKS`)."""
    n = len(p.tasks)
    if decomposition == "none" or (decomposition == "auto" and n <= max_full):
        return [list(range(n))]

    def level(i: int) -> float:
        t = p.tasks[i]
        if isinstance(t, BrickTask):
            return round(t.position_m[2], 3)
        return round(min(t.start_m[2], t.end_m[2]), 3)  # glue on top of the course below

    levels = sorted({level(i) for i in range(n)})
    rank = {z: k for k, z in enumerate(levels)}
    part = [rank[level(i)] for i in range(n)]
    # a prerequisite is never in a later part than its dependent (glue on top of a course sits higher)
    changed = True
    while changed:
        changed = False
        for i in range(n):
            for v in p.prereqs[i]:
                if part[v] > part[i]:
                    part[i] = part[v]
                    changed = True
    by_level: dict[int, list[int]] = {}
    for i in range(n):
        by_level.setdefault(part[i], []).append(i)
    out: list[list[int]] = []
    for k in sorted(by_level):
        if out and len(out[-1]) + len(by_level[k]) <= part_tasks:
            out[-1].extend(by_level[k])
        else:
            out.append(list(by_level[k]))
    return out


def precedences(
    p: _Problem,
    part: Sequence[int],
    m: CpModel,
    s_var: Mapping[int, IntVar],
    e_var: Mapping[int, IntVar],
    a_var: Mapping[int, IntVar],
) -> None:
    """G^d inside the part, and the prerequisites placed in earlier parts."""
    site = p.reservation == "site"
    for i in part:
        lo_s, lo_a = 0, 0
        for v in p.prereqs[i]:
            if v in s_var:
                if p.prefetch(i):
                    m.add(s_var[i] >= s_var[v])
                    m.add(a_var[i] >= e_var[v])
                elif site:
                    m.add(s_var[i] >= e_var[v])
                    m.add(a_var[i] >= e_var[v])
                else:
                    m.add(s_var[i] >= e_var[v])
            elif v in p.end:
                if p.prefetch(i):
                    lo_s, lo_a = max(lo_s, p.start[v]), max(lo_a, p.end[v])
                else:
                    lo_s = max(lo_s, p.end[v])
                    lo_a = max(lo_a, p.end[v])
        if lo_s:
            m.add(s_var[i] >= lo_s)
        if site and lo_a:
            m.add(a_var[i] >= lo_a)
