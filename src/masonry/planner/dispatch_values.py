"""The values the dispatcher hands out and the places a task sends a UAV to (pure)."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from collections.abc import Set as AbstractSet
from dataclasses import dataclass

from masonry.errors import PlanningError
from masonry.planner.tasks import BrickTask, Task

Vec3 = Sequence[float]

#: A task's state in the dispatcher: waiting for a UAV, flown by one, complete, failed for good.
PENDING, RUNNING, DONE, STUCK = 0, 1, 2, 3


@dataclass(frozen=True)
class Assignment:
    """Task ``task_id`` goes to UAV ``uav``; ``attempt`` counts from 1 (the attempts counted against the task's
    ``max_attempts`` before it + 1; mission control numbers each assignment on its own:
    :class:`~masonry.mission.ledger.AttemptLedger`)."""

    uav: str
    task_id: str
    attempt: int = 1


class SetView(AbstractSet[str]):
    """A live, read-only view of a set of task ids held by the dispatcher (O(1) to obtain)."""

    __slots__ = ("_data",)

    def __init__(self, data: AbstractSet[str]) -> None:
        self._data = data

    def __contains__(self, item: object) -> bool:
        return item in self._data

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __repr__(self) -> str:
        return f"{{{', '.join(sorted(self._data))}}}"


def task_start_m(task: Task) -> tuple[float, float, float]:
    """Where a UAV has to fly to begin ``task``: the pickup (or the drop-off if unknown) or the segment start."""
    if isinstance(task, BrickTask):
        return task.pickup_m if task.pickup_m is not None else task.position_m
    return task.start_m


def task_end_m(task: Task) -> tuple[float, float, float]:
    """Where a UAV is when ``task`` is complete: the drop-off or the segment end."""
    if isinstance(task, BrickTask):
        return task.position_m
    return task.end_m


def vec3(value: Vec3, what: str) -> tuple[float, float, float]:
    try:
        x, y, z = (float(v) for v in value)
    except (TypeError, ValueError) as exc:
        raise PlanningError(f"{what}: expected 3 coordinates in metres, got {value!r}") from exc
    if not all(math.isfinite(c) for c in (x, y, z)):
        raise PlanningError(f"{what}: coordinates must be finite, got {value!r}")
    return (x, y, z)


__all__ = [
    "DONE",
    "PENDING",
    "RUNNING",
    "STUCK",
    "Assignment",
    "SetView",
    "task_end_m",
    "task_start_m",
    "vec3",
]
