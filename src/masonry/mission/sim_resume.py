"""Where a resumed simulated mission starts: the bricks already in place and the time it resumes at.

:meth:`masonry.mission.simulate.SimulatedMission.from_blueprint` builds the world of a resumed mission from the
journal's state (:class:`masonry.mission.journal_state.JournalState`) and the completions the UAVs kept, unheard
(:func:`masonry.mission.measured.kept_completions`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from masonry.blueprint import Blueprint, UavSpec
from masonry.mission.measured import KeptCompletion, kept_completions, on_wall_of
from masonry.planner.tasks import BrickTask, Plan

if TYPE_CHECKING:
    from masonry.mission.journal_state import JournalState

__all__ = ["kept_of", "resumed_world"]


def kept_of(
    state: JournalState | None, the_plan: Plan, fleet: Sequence[UavSpec]
) -> dict[str, KeptCompletion]:
    """The completions the UAVs kept in the journal file, unheard (of this plan's tasks and this fleet's UAVs)."""
    ids, names = {t.id for t in the_plan.tasks}, {u.name for u in fleet}
    return {u: k for u, k in kept_completions(state).items() if k.task_id in ids and u in names}


def resumed_world(
    blueprint: Blueprint, the_plan: Plan, state: JournalState | None, kept: Mapping[str, KeptCompletion]
) -> tuple[Blueprint, float | None]:
    """The blueprint the resumed world is built from, and the time it resumes at (None: not a resume).

    Bricks the journal says are placed are in place, and so are those a UAV kept the completion of, unheard (it
    says it again first thing: mission control takes it), and those the world held at their places
    (:data:`~masonry.mission.measured.WALL_META_KEY`: a UAV that released its brick and fell before it reported
    done; a real site has no restart that puts a brick back on its pallet); the clock starts no earlier than a kept completion
    (the UAV finished then, so the mission was running)."""
    if state is None:
        return blueprint, None
    placed = {
        task.brick
        for tid in [r.task_id for r in state.done] + [k.task_id for k in kept.values()]
        if isinstance(task := the_plan.task(tid), BrickTask)
    }
    placed |= set(on_wall_of(state.meta))
    bricks = tuple(dataclasses.replace(b, placed=True) if b.id in placed else b for b in blueprint.bricks)
    resumed_from = max([float(state.last_time_s or 0.0), *(k.time_s for k in kept.values())])
    return dataclasses.replace(blueprint, bricks=bricks), resumed_from
