"""A UAV's check of an assignment against its own blueprint (docs/security.md).

Given its ``tasks``, ``spares``, ``role`` and ``wall_digest``, a UAV takes a task only with the same wall digest,
one of the blueprint's tasks (same id and geometry, or with one of its spares of that size in the brick's place)
of the UAV's role. The handler (:class:`~masonry.mission.handler.UavHandler`) refuses anything else. Pure: no
I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

from masonry.mission.messages import Assign
from masonry.mission.spares import as_flown
from masonry.planner.tasks import BrickTask, Task
from masonry.spares import Spare

__all__ = ["AssignmentCheck"]


@dataclass(frozen=True)
class AssignmentCheck:
    """The UAV's blueprint, as far as an assignment is checked against it (None: that part is not checked)."""

    tasks: Mapping[str, Task] | None
    spares: Mapping[int, Spare]  # (one may stand in for a brick)
    role: str | None
    wall_digest: str | None

    @classmethod
    def of(
        cls,
        tasks: Iterable[Task] | None,
        spares: Iterable[Spare] | None,
        role: str | None,
        wall_digest: str | None,
    ) -> AssignmentCheck:
        """The check of a UAV given its plan's tasks and spares, its role and its wall's digest."""
        return cls(
            None if tasks is None else {t.id: t for t in tasks},
            {sp.id: sp for sp in spares or ()},
            role,
            wall_digest,
        )

    def refusal(self, msg: Assign) -> str | None:
        """Why this assignment is not one of this UAV's blueprint's tasks for its role (None: it is)."""
        task = msg.task
        if self.wall_digest is not None and msg.wall != self.wall_digest:
            return (
                f"task {task.id} is for the wall {msg.wall or '(none given)'}, this UAV's blueprint is "
                f"{self.wall_digest}"
            )
        if self.role is not None and task.kind != self.role:
            return (
                f"task {task.id} is {task.kind} work, this UAV is {'an' if self.role[:1] == 'a' else 'a'} "
                f"{self.role} UAV"
            )
        if self.tasks is not None:
            mine = self.tasks.get(task.id)
            if mine is None:
                return f"task {task.id} is not a task of this UAV's blueprint"
            if replace(task, done=mine.done) != as_flown(mine, getattr(task, "spare", None), self.spares):
                what = "brick" if isinstance(task, BrickTask) else "segment"
                return f"task {task.id}: its {what} geometry differs from this UAV's blueprint"
        return None
