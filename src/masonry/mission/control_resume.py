"""Mission control resumed from its journal (``--resume``): done tasks stay done, running attempts stay with their UAVs.

Part of :class:`~masonry.mission.control.MissionControl` (issue 27 §2): the
:class:`~masonry.mission.ledger.AttemptLedger` rebuilds the history; these functions put the dispatcher, the
spares, the adhesive's gate, the site intervals, the waits and the UAVs' liveness back where the journal left them.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from masonry.errors import JournalError, PlanningError
from masonry.mission import control_airspace
from masonry.mission.control_results import release_waiting
from masonry.mission.course_check import is_misplaced
from masonry.mission.ledger import ReleaseMark, journaled_releases
from masonry.mission.records import Liveness
from masonry.mission.sites import journaled_visits
from masonry.mission.uav_facts import UavFacts

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl
    from masonry.mission.journal_state import JournalState, RunningRecord

__all__ = ["adopt", "heard_released", "restore"]

log = logging.getLogger("masonry.mission.control")


def restore(mc: MissionControl, state: JournalState) -> None:
    """Continue from a journal's replayed state: done tasks stay done with their times, attempts carry on.

    Attempts in progress when the previous run stopped stay with their UAVs (:func:`adopt`): what each
    UAV says first decides (its completion, said again, is taken; its heartbeat naming the task keeps it
    flying; one naming no task gives it back to the pool, not counted; silence declares it lost). Handing
    them out again at once would fly a task twice whose completion never reached the journal.
    A kept attempt whose UAV the journal says was heard with its brick on the wall (released at its place:
    :func:`heard_released`) is done if the UAV is then declared lost, as the run that heard it would have done
    (:func:`~masonry.mission.control_results.placed_by_lost`): not given again, not skipped.
    UAVs the journal declared lost stay lost. A UAV kept on a task that depends on a task the journal gave up (the
    previous run stopped before its recall's failure reached the journal) is recalled at once with
    :func:`~masonry.mission.control_results.given_up_reason`, as the run that gave it up did.
    """

    done = {rec.task_id: rec for rec in state.done}
    unknown = sorted((set(done) | {f.task_id for f in state.failures}) - set(mc.tasks))
    if unknown:
        raise JournalError(f"journal holds tasks that are not in this plan: {', '.join(unknown)}")
    attempts = mc.spares.restore(state.meta, state.attempts, mc.dispatcher.max_attempts)  # (spares)
    for f in state.failures:  # a brick found off its course stays where it lies: not tried again
        if is_misplaced(f.reason) and f.task_id not in done:
            attempts[f.task_id] = max(attempts.get(f.task_id, 0), mc.dispatcher.max_attempts)
    mc.dispatcher.restore(list(done), attempts)
    if mc.glue is not None:  # the beads' ages and the cures go on from the journal's completion times
        mc.glue.restore((rec.task_id, rec.time_s) for rec in done.values())
    mc.ledger.restore(state.failures, done, state.numbers)
    for name in state.lost_uavs:
        link = mc.uavs.get(name)
        if link is not None and not link.lost:
            link.liveness = Liveness.LOST  # (lost before this run: not awaited to rejoin)
            mc.dispatcher.remove_uav(name)
    releases = journaled_releases(state.meta)
    for run in state.running:
        adopt(mc, run)
        mark = releases.get(run.task_id)
        if mark is not None and (mark.uav, mark.attempt) == (run.uav, run.attempt):
            heard_released(mc, mark)
    for stuck in sorted(mc.dispatcher.stuck):  # a UAV kept on a task that waits for a given-up one: recalled
        release_waiting(mc, stuck, state.last_time_s)
    mc.ledger.sort()
    mc.resumed_at_s = state.last_time_s
    mc.sites.restore(journaled_visits(state.meta, set(done), state.last_time_s))
    mc.waits.restore(state.meta)
    # what the previous run may have built: done tasks, and every task it ever assigned
    control_airspace.raise_layers(mc, [*done, *attempts, *state.in_progress])


def adopt(mc: MissionControl, run: RunningRecord) -> None:
    """A journaled attempt still running at the stop: in progress on its UAV again (unless the UAV is lost,
    another attempt holds it, or the task cannot run now: then it goes back to the pool as before)."""
    link = mc.uavs.get(run.uav)
    if link is None or link.lost or run.task_id in mc.dispatcher.done:
        return
    try:
        mc.dispatcher.adopt(run.task_id, run.uav)
    except PlanningError as exc:
        log.warning("%s: not kept on %s after the resume: %s", run.task_id, run.uav, exc)
        return
    mc.ledger.adopt(run.task_id, run.uav, run.attempt, run.start_s)
    log.info("%s kept on %s (attempt %d) from before the resume", run.task_id, run.uav, run.attempt)


def heard_released(mc: MissionControl, mark: ReleaseMark) -> None:
    """``mark``'s UAV was last heard before the stop with its brick on the wall (the journal's release mark): its
    facts say so again (``finishing``, no brick on its magnet), until it is heard. Declared lost, its task is then
    done (:func:`~masonry.mission.control_losses.lose`); heard, what it says decides, as any UAV's."""
    link = mc.uavs.get(mark.uav)
    att = mc.ledger.running.get(mark.task_id)
    if link is None or att is None or att.uav != mark.uav or att.attempt != mark.attempt:
        return  # (not kept on it: its UAV lost before, or the task done)
    link.facts = UavFacts(finishing=True)
    link.state = mark.state
    mc.ledger.released_before(mark)
    log.info(
        "%s on %s (attempt %d): its brick released at %.1f s",
        mark.task_id,
        mark.uav,
        mark.attempt,
        mark.time_s,
    )
