"""The UAV side's record of one task as it flew it (:attr:`masonry.mission.handler.UavHandler.executions`).

From these records, not from mission control's bookkeeping, the simulator measures conflict and dependency
violations; :mod:`masonry.mission.uav_events` and :mod:`masonry.mission.remote` read them too.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class Execution:
    """One task as the UAV flew it: handed to the machine at ``start_s``, reported at ``end_s``.

    ``queued_s``: how long its assignment waited here before the machine took it (the battery reserve's hold).
    """

    task_id: str
    uav: str
    attempt: int
    start_s: float
    end_s: float | None = None
    status: str = "running"
    queued_s: float = 0.0
    reason: str | None = None  # why it failed, as the machine reported it
    #: when the handler abandoned it (mission control silent): from then on the machine only puts the brick back
    #: or flies home, away from the task's site, until it reports the failure
    abandoned_s: float | None = None


__all__ = ["Execution"]
