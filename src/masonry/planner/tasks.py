"""Task and plan values: what the planner produces and the dispatcher, mission control and UAVs consume."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from masonry.blueprint import DEFAULT_BRICK_SIZE_M

if TYPE_CHECKING:
    from masonry.planner.deadlines import Deadline
    from masonry.spares import Spare

TaskKind = Literal["brick", "adhesion"]


@dataclass(frozen=True)
class BrickTask:
    """Pick brick ``brick`` up near ``pickup_m`` and place it at ``position_m`` with ``yaw_rad`` (id "B<brick>")."""

    id: str
    brick: int
    done: bool
    position_m: tuple[float, float, float]
    yaw_rad: float
    pickup_m: tuple[float, float, float] | None
    size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M
    #: the brick's marker number when the blueprint reuses numbers (ArUco ids 2m, 2m+1); None: ``brick``
    marker: int | None = None

    kind: TaskKind = "brick"
    #: the spare picked up in place of brick ``brick`` (its id; ``pickup_m`` is then the spare's), or None
    spare: int | None = None
    #: placed bricks around it as built, relative to the wall (issue 30; ``masonry.planner.wall_deviation``): (brick
    #: id, (dx, dy, dz) of its centre from its design, m), given by mission control with an assignment; (): none
    wall_as_built: tuple[tuple[int, tuple[float, float, float]], ...] = ()

    @property
    def marker_ids(self) -> tuple[int, int]:
        """The ArUco ids the camera looks for on the brick to pick up: 2k and 2k+1 of the spare's id when a spare
        stands in, else of the brick's marker number (its id unless the blueprint reuses numbers)."""
        k = self.spare if self.spare is not None else self.brick if self.marker is None else self.marker
        return (2 * k, 2 * k + 1)

    @property
    def location_m(self) -> tuple[float, float, float]:
        """Where the task is flown for conflict purposes: the drop-off point."""
        return self.position_m


@dataclass(frozen=True)
class AdhesionTask:
    """Spray adhesive from ``start_m`` to ``end_m`` on top of brick ``below`` before ``above`` goes on (id "A<n>")."""

    id: str
    below: int
    above: int
    start_m: tuple[float, float, float]
    end_m: tuple[float, float, float]
    length_m: float

    kind: TaskKind = "adhesion"
    done: bool = False

    @property
    def location_m(self) -> tuple[float, float, float]:
        """Segment midpoint (conflicts use the whole segment)."""
        return tuple((a + b) / 2.0 for a, b in zip(self.start_m, self.end_m))  # type: ignore[return-value]


Task = BrickTask | AdhesionTask


@dataclass(frozen=True)
class Plan:
    """Both graphs of the paper's Section III.

    ``dependencies`` holds edges (u, v): u can start only after v is complete.
    ``conflicts`` holds unordered pairs (a, b), a < b in task order, of tasks that must not run at once.
    ``tasks`` keeps a stable order: brick tasks in blueprint order, then adhesion tasks A0, A1, ...
    """

    tasks: tuple[Task, ...]
    dependencies: tuple[tuple[str, str], ...]
    conflicts: tuple[tuple[str, str], ...]
    #: Optional (a, b) integer arrays of task indices, one entry per conflict (a fast path for large plans;
    #: filled by ``plan()``, ignored by equality).
    conflict_indices: Any = field(default=None, compare=False, repr=False)
    #: The adhesive's open and cure edges (:mod:`masonry.planner.deadlines`; empty without ``adhesive``).
    deadlines: tuple[Deadline, ...] = ()
    #: the blueprint's spare bricks (None: no ``spares`` key; :mod:`masonry.mission.spares`)
    spares: tuple[Spare, ...] | None = None

    def task(self, task_id: str) -> Task:
        """The task with id ``task_id`` (KeyError if there is none)."""
        index = self.__dict__.get("_task_index")
        if index is None:
            index = {t.id: t for t in self.tasks}
            object.__setattr__(self, "_task_index", index)  # a cache, not state
        return index[task_id]  # type: ignore[no-any-return]

    def prerequisites(self) -> dict[str, list[str]]:
        """For every task id, the ids it waits for (its successors in G^d), in edge order."""
        return prerequisites(self.tasks, self.dependencies)

    def available(self, done: Iterable[str] = ()) -> list[str]:
        """Ids of tasks not done whose prerequisites are all done (tasks with ``done=True`` count as done).

        This is the paper's availability rule; conflicts are not considered (they only forbid running two
        tasks at once).
        """
        return available(self.tasks, self.dependencies, done)

    def longest_chain(self) -> list[str]:
        """The longest chain of tasks still to do, each waiting for the next (top first; empty if none)."""
        return longest_chain(self.tasks, self.dependencies)


def prerequisites(tasks: Sequence[Task], dependencies: Sequence[tuple[str, str]]) -> dict[str, list[str]]:
    """For every task id, the ids it waits for (its successors in G^d), in edge order."""
    out: dict[str, list[str]] = {t.id: [] for t in tasks}
    for u, v in dependencies:
        out[u].append(v)
    return out


def available(
    tasks: Sequence[Task], dependencies: Sequence[tuple[str, str]], done: Iterable[str] = ()
) -> list[str]:
    """Ids of tasks not done whose prerequisites are all done (see :meth:`Plan.available`)."""
    finished = {t.id for t in tasks if t.done} | set(done)
    prereq = prerequisites(tasks, dependencies)
    return [t.id for t in tasks if t.id not in finished and all(v in finished for v in prereq[t.id])]


def longest_chain(tasks: Sequence[Task], dependencies: Sequence[tuple[str, str]]) -> list[str]:
    """The longest chain of tasks still to do, each waiting for the next (top first; empty if none)."""
    todo = {t.id for t in tasks if not t.done}
    prereq = prerequisites(tasks, dependencies)
    # Kahn's order from the bottom (tasks with no pending prerequisite) upwards.
    pending = {tid: sum(1 for v in prereq[tid] if v in todo) for tid in todo}
    dependants: dict[str, list[str]] = {tid: [] for tid in todo}
    for u, v in dependencies:
        if u in todo and v in todo:
            dependants[v].append(u)
    best: dict[str, int] = {}
    nxt: dict[str, str | None] = {}
    queue = [tid for tid in todo if pending[tid] == 0]
    order: list[str] = []
    while queue:
        tid = queue.pop()
        order.append(tid)
        for u in dependants[tid]:
            pending[u] -= 1
            if pending[u] == 0:
                queue.append(u)
    for tid in order:
        below = [v for v in prereq[tid] if v in todo]
        if below:
            v = max(below, key=lambda x: best[x])
            best[tid], nxt[tid] = best[v] + 1, v
        else:
            best[tid], nxt[tid] = 1, None
    if not best:
        return []
    rank = {t.id: k for k, t in enumerate(tasks)}
    top = max(best, key=lambda x: (best[x], -rank[x]))
    chain = [top]
    while nxt[chain[-1]] is not None:
        chain.append(nxt[chain[-1]])  # type: ignore[arg-type]
    return chain
