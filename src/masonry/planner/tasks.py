"""Task and plan values: what the planner produces and the dispatcher, mission control and UAVs consume."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, Union

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
    size_m: tuple[float, float, float] = (0.30, 0.15, 0.10)

    kind: TaskKind = "brick"

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


Task = Union[BrickTask, AdhesionTask]


@dataclass(frozen=True)
class Plan:
    """Both graphs of the paper's Section III.

    ``dependencies`` holds edges (u, v): u can start only after v is complete.
    ``conflicts`` holds unordered pairs (a, b), a < b in task order, of tasks that must not run at once.
    ``tasks`` keeps a stable order: brick tasks in blueprint order interleaved as the planner emits them.
    """

    tasks: tuple[Task, ...]
    dependencies: tuple[tuple[str, str], ...]
    conflicts: tuple[tuple[str, str], ...]
    #: Optional (a, b) integer arrays of task indices, one entry per conflict (a fast path for large plans;
    #: filled by ``plan()``, ignored by equality).
    conflict_indices: Any = field(default=None, compare=False, repr=False)

    def task(self, task_id: str) -> Task:
        for t in self.tasks:
            if t.id == task_id:
                return t
        raise KeyError(task_id)
