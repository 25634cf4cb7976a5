"""The UAV model's book of tasks: taking one from the mission link, starting it, reporting how it ended.

A task of the wrong kind, one the machine cannot fly, or one a full battery pack cannot carry is reported failed
at once; a task taken gets a fresh attempt record (:mod:`masonry.fsm.attempt`); its end goes out as one
:class:`~masonry.ports.TaskResult` with the seconds per phase (:mod:`masonry.fsm.phases`).
"""

from __future__ import annotations

from typing import Any

from masonry.fsm.attempt import TaskAttempt
from masonry.fsm.budget import BatteryBudget
from masonry.planner.tasks import Task
from masonry.ports import TaskResult, Telemetry


class TaskBook(BatteryBudget):
    """Taking, starting and reporting the model's tasks (see the module's docstring)."""

    def _reject_tasks(self) -> None:
        task = self.link.poll_task()
        if task is not None:
            self._report(
                TaskResult(
                    task.id, "failed", 0.0, reason=f"{self.config.name} is out of service: {self.halt_reason}"
                )
            )

    def fail_task(self, *args: object, reason: str = "unrecoverable error", **kwargs: object) -> None:
        """Report the task in hand (if any) as failed with ``reason``."""
        if self.task is not None:
            self._report(
                TaskResult(
                    self.task.id,
                    "failed",
                    self._now_s - self.attempt.start_s,
                    reason=reason,
                    phases=self.phase_clock.stop(),
                )
            )
            self.task = None

    def has_next_task(self, *args: object, **kwargs: object) -> bool:
        return self._next_task is not None

    def must_halt(self, *args: object, **kwargs: object) -> bool:
        return self._halt_after_landing is not None

    # -- bookkeeping ---------------------------------------------------------------------------------------
    def _record_state(self, *args: object, **kwargs: object) -> None:
        self._entered_s = self._now_s
        self.trace.append((self._now_s, self.state))
        if self.task is not None:
            self.link.report_progress(self.task.id, self.state, self._now_s)

    def _report(self, result: TaskResult) -> None:
        self.results.append(result)
        self.link.report_result(result)

    def _take(self, task: Task | None) -> Task | None:
        """Vet a task from the link: one of the wrong kind is reported failed at once."""
        if task is None:
            return None
        if task.kind != self.KIND:
            self._report(
                TaskResult(
                    task.id,
                    "failed",
                    0.0,
                    reason=f"{self.config.name} is a {self.KIND} UAV, "
                    f"it cannot fly {task.kind} task {task.id}",
                )
            )
            return None
        problem = self._task_problem(task) or self._pack_too_small(task)
        if problem is not None:
            self._report(TaskResult(task.id, "failed", 0.0, reason=problem))
            return None
        return task

    def _task_problem(self, task: Task) -> str | None:
        return None

    def _start_task(self, task: Task) -> None:
        """Take ``task`` in hand: a fresh attempt record, with the waiting for clearance its budget leaves."""
        self.task = task
        self.phase_clock.start(self._now_s)
        budget_s, flight_s = self.task_budget_s(task), self._flight_need_s(task)
        wait_budget_s = self._wait_budget_s()
        if (
            budget_s is not None and flight_s is not None
        ):  # (what the budget leaves of it: the way home's wait last)
            wait_budget_s = min(wait_budget_s, budget_s - flight_s)
        self.attempt = self._new_attempt(self._now_s, wait_budget_s)

    def _new_attempt(self, start_s: float, wait_budget_s: float) -> TaskAttempt:
        """A fresh attempt record for a task taken at ``start_s`` (subclasses: their kind's record)."""
        return TaskAttempt(start_s=start_s, wait_budget_s=wait_budget_s)

    def _report_done(self, **fields: Any) -> None:
        """Report the task in hand done (with ``fields``); the UAV has no task any more."""
        assert self.task is not None
        self._report(
            TaskResult(
                self.task.id,
                "done",
                self._now_s - self.attempt.start_s,
                phases=self.phase_clock.stop(),
                **fields,
            )
        )
        self.task = None

    def _may_take_task(self, tel: Telemetry) -> bool:
        """A task may be started now: the UAV is not to retire and its battery is not low."""
        return (
            self._halt_after_landing is None
            and tel.battery_fraction >= self.config.battery_low_fraction
            and (self.fence_watch is None or self.fence_watch.since_s is None)  # not while outside its fence
        )

    def _complete_task(self, **fields: Any) -> None:
        self._report_done(**fields)
        self._next_task = self._take(self.link.poll_task())
        if self._next_task is not None:
            self._start_task(self._next_task)
        self.finish()
        self._next_task = None
