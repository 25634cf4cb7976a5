"""Which brick each grasp really took, against the task its UAV was flying: picks identified and confusions.

The simulated world records every grasp (:attr:`masonry.sim.world.World.picks`: time, UAV, brick); the mission's
attempts say which task each UAV was on at that time. A pick is *identified* when the brick taken is the task's
brick, a *confusion* when it is another one -- on a big wall that reuses marker numbers, the brick with the same
ids elsewhere (issue 30).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from masonry.mission.report import AttemptReport

__all__ = ["PickAudit", "audit_picks"]


@dataclass(frozen=True)
class PickAudit:
    """The grasps of one mission: how many, how many took their task's brick, the ones that took another."""

    picks: int
    identified: int
    confusions: tuple[tuple[str, int, int], ...]  # (UAV, the task's brick, the brick it took)
    sampled: int = 0  # picks of the bricks whose pickup the ``mixed`` camera saw on drawn images
    sampled_identified: int = 0


def audit_picks(
    picks: Iterable[tuple[float, str, int]],
    attempts: Sequence[AttemptReport],
    sample: frozenset[int] = frozenset(),
) -> PickAudit:
    """Match each grasp ``(time, UAV, brick)`` to the brick task its UAV was on then (``attempts``)."""
    spans: dict[str, list[tuple[float, float, int]]] = {}
    for a in attempts:
        if a.kind == "brick" and a.task_id.startswith("B"):
            end = a.end_s if a.end_s is not None else float("inf")
            spans.setdefault(a.uav, []).append((a.start_s, end, int(a.task_id[1:])))
    count = identified = sampled = sampled_ok = 0
    confusions: list[tuple[str, int, int]] = []
    for time_s, uav, brick in picks:
        count += 1
        task = next((b for t0, t1, b in spans.get(uav, ()) if t0 <= time_s <= t1), None)
        ok = task == brick
        identified += ok
        if task is not None and not ok:
            confusions.append((uav, task, brick))
        if brick in sample:
            sampled += 1
            sampled_ok += ok
    return PickAudit(count, identified, tuple(confusions), sampled, sampled_ok)
