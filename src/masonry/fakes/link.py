"""MissionLink fakes (:mod:`masonry.fakes`): tasks from a queue, and an airspace that answers after scripted delays."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from masonry.planner.tasks import Task
from masonry.ports import Clock, TaskResult

Vec3 = tuple[float, float, float]


class QueueMissionLink:
    """MissionLink fake: hands out queued tasks one per ``poll_task`` and collects progress and results."""

    def __init__(self, tasks: Sequence[Task] = ()) -> None:
        self._queue: deque[Task] = deque(tasks)
        self.progress: list[tuple[str, str, float]] = []
        self.results: list[TaskResult] = []

    def push(self, task: Task) -> None:
        """Queue one more task."""
        self._queue.append(task)

    @property
    def pending(self) -> int:
        return len(self._queue)

    def poll_task(self) -> Task | None:
        return self._queue.popleft() if self._queue else None

    def report_progress(self, task_id: str, state: str, time_s: float) -> None:
        self.progress.append((task_id, state, time_s))

    def report_result(self, result: TaskResult) -> None:
        self.results.append(result)


@dataclass(frozen=True)
class FakeClearance:
    """A ClearanceAnswer: what mission control's airspace answers (the fields the state machines read)."""

    granted: bool
    layer_m: float | None
    hold_m: Vec3 | None = None
    gentle: bool = True
    open_for_s: float | None = None
    grant: int = 0


class ScriptedClearanceLink(QueueMissionLink):
    """MissionLink and ClearanceLink fake: mission control answers after ``answer_after_s`` (hold at
    ``hold_m``, or where the UAV is) and grants the column at ``grant_after_s``, both counted from the first
    request for a site.

    Attributes:
        asked: the first request time of every site asked for.
        arrived: the sites of every transit ended (``end_transit``), in order.
    """

    def __init__(
        self,
        tasks: Sequence[Task],
        clock: Clock,
        *,
        layer_m: float | None = 2.6,
        answer_after_s: float = 0.0,
        grant_after_s: float = 0.0,
        hold_m: Vec3 | None = None,
        swaps_batteries: bool = False,
        return_brick: Callable[[int], bool] | None = None,
    ) -> None:
        super().__init__(tasks)
        self.clock = clock
        self.layer_m = layer_m
        self.answer_after_s = answer_after_s
        self.grant_after_s = grant_after_s
        self.hold_m = hold_m
        self._swaps_batteries = swaps_batteries
        self._return_brick = return_brick  # the ground crew's hands (None: no ground crew takes bricks back)
        self.returned: list[int] = []  # bricks the ground crew took back to their pickup
        self.asked: dict[Vec3, float] = {}
        self.arrived: list[Vec3] = []

    @property
    def swaps_batteries(self) -> bool:
        return self._swaps_batteries

    def return_brick(self, brick_id: int) -> bool:
        if self._return_brick is None or not self._return_brick(brick_id):
            return False
        self.returned.append(brick_id)
        return True

    def request_clearance(
        self, site_m: Vec3, top_m: float | None = None, to_m: Vec3 | None = None
    ) -> FakeClearance | None:
        site = (float(site_m[0]), float(site_m[1]), float(site_m[2]))
        first = self.asked.setdefault(site, self.clock.now_s())
        waited = self.clock.now_s() - first
        if waited < self.answer_after_s:
            return None
        n = list(self.asked).index(site) + 1  # (answers numbered: a hold flight 2n - 1, the granted one 2n)
        if waited < self.grant_after_s:
            return FakeClearance(False, self.layer_m, self.hold_m, grant=2 * n - 1)
        return FakeClearance(True, self.layer_m, grant=2 * n)

    def end_transit(self, site_m: Vec3) -> None:
        self.arrived.append((float(site_m[0]), float(site_m[1]), float(site_m[2])))
