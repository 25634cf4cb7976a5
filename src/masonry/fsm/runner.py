"""The thin loop around a UAV model: tick it on an injected clock until its single task is over.

``run_single_task`` is the same loop for simulated time (``advance=world.step``: the world moves the clock and
the physics) and for wall time on a UAV (``advance=clock.sleep``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from masonry.fsm.model import UavModel
from masonry.ports import Clock, TaskResult


@dataclass(frozen=True)
class SingleTaskRun:
    """What one UAV did with one task: its result (None if the time ran out), trace and timing."""

    result: TaskResult | None
    trace: tuple[tuple[float, str], ...]
    start_s: float
    end_s: float
    final_state: str

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def run_single_task(
    uav: UavModel,
    clock: Clock,
    *,
    dt_s: float = 0.05,
    advance: Callable[[float], None] | None = None,
    timeout_s: float = 900.0,
) -> SingleTaskRun:
    """Tick ``uav`` every ``dt_s`` until it has reported a result and is back to rest (landed or halted).

    Args:
        uav: a model whose link holds (or will hand out) the task.
        clock: the time source the model is ticked with.
        dt_s: control period, seconds.
        advance: moves time (and the world) by ``dt_s``; default ``clock.sleep``.
        timeout_s: give up after this much (simulated or wall) time; the run then has ``result=None``
            unless one was reported.
    """
    if not dt_s > 0.0:
        raise ValueError(f"dt_s must be > 0, got {dt_s!r}")
    step_time = clock.sleep if advance is None else advance
    start_s = clock.now_s()
    n_results = len(uav.results)
    while True:
        now = clock.now_s()
        uav.step(now)
        reported = len(uav.results) > n_results
        if reported and uav.finished:
            break
        if now - start_s >= timeout_s:
            break
        step_time(dt_s)
    result = uav.results[n_results] if len(uav.results) > n_results else None
    return SingleTaskRun(result, tuple(uav.trace), start_s, clock.now_s(), uav.state)
