"""The terms of the makespan lower bound, and which one wins (the report's ``lower_bound_s`` and ``lower_bound_kind``).

:func:`masonry.planner.bounds.lower_bound_s` takes the larger of the longest dependency chain and each role's
work shared by its UAVs. Neither sees the conflict graph, which is what binds on short walls
(docs/performance/mission.md, "Where the gap to the 1.15 target comes from"): tasks that pairwise conflict
(G^c), or one of which depends on the other (G^d, directly or not), never run at the same time, so the total
minimum duration of any such set bounds the makespan. The heaviest set is a maximum-weight clique of that
*exclusion graph*: exact (``networkx.max_weight_clique``) on plans of up to :data:`EXACT_CLIQUE_MAX_TASKS`
tasks, greedy (any clique is a valid bound) beyond. With ``--reservation site`` conflicting tasks may run at
once and only their site parts are kept apart, so the clique weighs each task by its site part
(:func:`~masonry.planner.bounds.min_site_s`), which stays valid for dependent pairs too (a site part starts
after every prerequisite ended). docs/schedule.md explains the terms.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from masonry.blueprint import ROLES, UavSpec
from masonry.planner.bounds import longest_chain_s, lower_bound_s
from masonry.planner.tasks import Plan

#: The exact clique search runs on plans with at most this many not-done tasks (greedy beyond).
EXACT_CLIQUE_MAX_TASKS = 400
#: Greedy cliques grow from at most this many start tasks (the heaviest ones) on large plans.
GREEDY_STARTS = 2000
#: networkx's clique search wants integer weights: milliseconds, rounded down (so the bound stays valid).
_WEIGHT_SCALE = 1000.0

KINDS: tuple[str, ...] = ("chain", "role", "conflict-clique", "cp-sat")


@dataclass(frozen=True)
class BoundTerms:
    """Each valid lower bound the project proves cheaply, in seconds (``cp_sat_s``: None without a schedule)."""

    chain_s: float
    role_s: float
    clique_s: float
    cp_sat_s: float | None = None

    @property
    def value_s(self) -> float:
        """The best (largest) of the terms."""
        return max(self.chain_s, self.role_s, self.clique_s, self.cp_sat_s or 0.0)

    @property
    def kind(self) -> str:
        """The term that wins: ``chain``, ``role``, ``conflict-clique`` or ``cp-sat`` (first in that order on ties)."""
        values = (self.chain_s, self.role_s, self.clique_s, self.cp_sat_s or 0.0)
        return KINDS[values.index(max(values))]


def _ancestors(todo: Sequence[str], plan: Plan) -> list[set[int]]:
    index = {tid: i for i, tid in enumerate(todo)}
    prereqs: list[list[int]] = [[] for _ in todo]
    for u, v in plan.dependencies:
        if u in index and v in index:
            prereqs[index[u]].append(index[v])
    memo: list[set[int] | None] = [None] * len(todo)
    for root in range(len(todo)):
        stack = [root]
        while stack:
            j = stack[-1]
            if memo[j] is not None:
                stack.pop()
                continue
            pending = [p for p in prereqs[j] if memo[p] is None]
            if pending:
                stack.extend(pending)
                continue
            acc: set[int] = set()
            for p in prereqs[j]:
                acc.add(p)
                acc |= memo[p] or set()
            memo[j] = acc
            stack.pop()
    return [m or set() for m in memo]


def exclusion_graph(plan: Plan, *, dependencies: bool = True) -> tuple[list[str], list[set[int]]]:
    """The not-done tasks and, per task, the tasks it may never run with: G^c, and (``dependencies``) G^d's
    transitive closure both ways."""
    todo = [t.id for t in plan.tasks if not t.done]
    index = {tid: i for i, tid in enumerate(todo)}
    adj: list[set[int]] = [set() for _ in todo]
    for a, b in plan.conflicts:
        ia, ib = index.get(a), index.get(b)
        if ia is not None and ib is not None and ia != ib:
            adj[ia].add(ib)
            adj[ib].add(ia)
    if dependencies:
        for i, anc in enumerate(_ancestors(todo, plan)):
            for j in anc:
                adj[i].add(j)
                adj[j].add(i)
    return todo, adj


def _greedy_clique(adj: Sequence[set[int]], weight: Sequence[float], starts: Sequence[int]) -> float:
    best = 0.0
    for i in starts:
        candidates = sorted(adj[i], key=lambda j: -weight[j])
        chosen = {i}
        total = weight[i]
        for j in candidates:
            if chosen <= adj[j]:
                chosen.add(j)
                total += weight[j]
        best = max(best, total)
    return best


def conflict_clique_s(plan: Plan, weights_s: Mapping[str, float]) -> float:
    """The total weight of a heaviest set of not-done tasks no two of which may ever run together.

    Exact on plans of up to :data:`EXACT_CLIQUE_MAX_TASKS` not-done tasks (conflicts and dependencies); on
    larger ones the conflicts only, greedy from the :data:`GREEDY_STARTS` heaviest tasks (a smaller but still
    valid bound, and cheap on a 20,000-brick wall).
    """
    small = sum(1 for t in plan.tasks if not t.done) <= EXACT_CLIQUE_MAX_TASKS
    todo, adj = exclusion_graph(plan, dependencies=small)
    if not todo:
        return 0.0
    weight = [max(0.0, float(weights_s.get(tid, 0.0))) for tid in todo]
    if small:
        import networkx as nx

        g = nx.Graph()
        for i, w in enumerate(weight):
            g.add_node(i, w=math.floor(w * _WEIGHT_SCALE))
        g.add_edges_from((i, j) for i, ns in enumerate(adj) for j in ns if i < j)
        _nodes, total = nx.max_weight_clique(g, weight="w")
        return float(total) / _WEIGHT_SCALE
    starts = sorted(range(len(todo)), key=lambda i: -weight[i])[:GREEDY_STARTS]
    return _greedy_clique(adj, weight, starts)


def bound_terms(
    plan: Plan,
    fleet: Sequence[UavSpec],
    durations_s: Mapping[str, float],
    *,
    work_s: Mapping[str, float] | None = None,
    clique_weights_s: Mapping[str, float] | None = None,
    cp_sat_s: float | None = None,
) -> BoundTerms:
    """The terms of the report's bound: :func:`~masonry.planner.bounds.lower_bound_s`'s two, the exclusion
    clique (weighed by ``clique_weights_s``, default ``durations_s``) and CP-SAT's proven bound if given.

    Raises:
        PlanningError: as :func:`~masonry.planner.bounds.lower_bound_s`.
    """
    chain = longest_chain_s(plan, durations_s)
    both = lower_bound_s(plan, fleet, durations_s, work_s=work_s)
    # lower_bound_s = max(chain, role): when the chain wins the role term is at most it
    role = both if both > chain else _role_term_s(plan, fleet, work_s or durations_s)
    clique = conflict_clique_s(plan, durations_s if clique_weights_s is None else clique_weights_s)
    return BoundTerms(chain, role, clique, cp_sat_s)


def _role_term_s(plan: Plan, fleet: Sequence[UavSpec], work_s: Mapping[str, float]) -> float:
    count = dict.fromkeys(ROLES, 0)
    for spec in fleet:
        count[spec.role] = count.get(spec.role, 0) + 1
    work = dict.fromkeys(ROLES, 0.0)
    for t in plan.tasks:
        if not t.done:
            work[t.kind] += float(work_s.get(t.id, 0.0))
    return max((work[r] / count[r] for r in ROLES if count[r]), default=0.0)


__all__ = [
    "EXACT_CLIQUE_MAX_TASKS",
    "GREEDY_STARTS",
    "KINDS",
    "BoundTerms",
    "bound_terms",
    "conflict_clique_s",
    "exclusion_graph",
]
