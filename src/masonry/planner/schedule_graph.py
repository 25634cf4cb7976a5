"""Graph helpers of the offline schedule's model (:mod:`masonry.planner.schedule`): ancestors, a clique cover."""

from __future__ import annotations

from collections.abc import Sequence


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
