"""Mission control's results: a task's result acted on, one said again, one heard late, a task its UAV forgot.

Part of :class:`~masonry.mission.control.MissionControl` (issue 27 §2): the verdicts come from the pure
:mod:`masonry.mission.reducer` (docs/security.md's checks), the records go to the
:class:`~masonry.mission.ledger.AttemptLedger`; these functions carry the effects out on the dispatcher, the
spares, the adhesive's gate and the as-built watch.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from masonry.mission.as_built import take_result
from masonry.mission.messages import Heartbeat, Result
from masonry.mission.records import UavLink
from masonry.mission.reducer import dropped_reason, late_completion, placed_before_loss, screen_result
from masonry.mission.swap_stagger import SWAP_EARLY
from masonry.placement_check import is_place_taken
from masonry.planner.tasks import BrickTask
from masonry.ports import RECALL_REASON, TaskResult

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl
    from masonry.mission.records import Attempt

__all__ = [
    "check_holds_task",
    "given_up_reason",
    "heard_again",
    "ignore",
    "late_result",
    "misplaced",
    "note_release",
    "on_heartbeat",
    "placed_by_lost",
    "recall_again",
    "release_waiting",
    "settle_done",
    "take_result_message",
]

log = logging.getLogger("masonry.mission.control")


def take_result_message(mc: MissionControl, msg: Result, now_s: float) -> None:
    """A task's result from a UAV in the mission: acted on (done or failed), or ignored and counted by reason."""
    r = mc.placement.against_design(msg.result)  # (its deviation from the design: issue 30)
    att = mc.ledger.running.get(r.task_id)
    least_s = mc.min_durations_s.get(r.task_id)
    owner = mc.dispatcher.in_progress.get(r.task_id)
    ignored = screen_result(msg, owner, att, least_s, mc.min_fraction, now_s)
    if ignored is not None:
        ignore(mc, ignored.reason, ignored.detail)
        return
    assert att is not None  # (screen_result ignores a result with no running attempt)
    why = mc.placement.misplaced(mc, r) if r.status == "done" else None
    if why is not None:  # (a brick off its course: not placed, and not to be tried again)
        misplaced(mc, att, r, msg.sender, why, now_s)
    elif r.status == "done":
        r = mc.placement.anchored(mc, r)  # (the pose reported: anchored on the wall where it can be)
        log.info("%s done by %s (attempt %d) at %.1f s", r.task_id, msg.sender, att.attempt, now_s)
        fields = {"placement_error_m": r.placement_error_m, "coverage": r.coverage}
        settle_done(mc, att, r, msg.sender, now_s, {**fields, **mc.placement.event_fields(r.as_built)})
        mc.placement.completed(mc, r, msg.sender, now_s)
    else:
        reason = r.reason or "failed"
        mc.ledger.end(att, now_s, "failed", reason)
        take_result(att, r)
        log.info(
            "%s failed on %s (attempt %d, %.1f-%.1f s): %s",
            *(r.task_id, msg.sender, att.attempt, att.start_s, now_s, reason),
        )
        # abandoned for the UAV's battery (it lands for a fresh pack) or recalled by the operator: not an
        # attempt of the task
        count, give_up = mc.spares.failed(r.task_id, reason, now_s)  # (its brick gone: a spare)
        give_up = give_up or is_place_taken(reason)  # (the brick in its place will not move: not again)
        again = mc.dispatcher.fail(r.task_id, count=count, give_up=give_up)
        mc.ledger.journal_failed(now_s, att, reason)
        mc.out.emit(now_s, "failed", msg.sender, r.task_id, attempt=att.attempt, reason=reason)
        if not again:
            release_waiting(mc, r.task_id, now_s)
    mc.wake()


def placed_by_lost(mc: MissionControl, uav: str, last_state: str, now_s: float) -> bool:
    """``uav``, taken out of the mission for its silence, was last heard with its brick on the wall
    (:func:`~masonry.mission.reducer.placed_before_loss`): its task is done, with no result (no as-built look),
    journaled so; not given again. True if it held a task so taken."""
    task_id = mc.dispatcher.task_of(uav)
    att = None if task_id is None else mc.ledger.running.get(task_id)
    if task_id is None or att is None:
        return False
    log.warning(
        "%s done by %s (attempt %d): lost after its release (last heard in %s)",
        task_id,
        uav,
        att.attempt,
        last_state,
    )
    settle_done(mc, att, TaskResult(task_id, "done", now_s - att.start_s), uav, now_s, phases=False)
    return True


def note_release(mc: MissionControl, link: UavLink, task_id: str | None, now_s: float) -> None:
    """``link``'s UAV, on ``task_id`` (the task its heartbeat or progress report names), says its brick is on the
    wall (:func:`~masonry.mission.reducer.placed_before_loss`): journaled once per attempt
    (:meth:`~masonry.mission.ledger.AttemptLedger.journal_released`), so that a mission control resumed before it
    declared the UAV lost does what :func:`placed_by_lost` would (``control_resume``), not give the task again."""
    name = link.spec.name
    if task_id is None or mc.dispatcher.task_of(name) != task_id:
        return
    att = mc.ledger.running.get(task_id)
    if att is None or att.uav != name:
        return
    if placed_before_loss(link.facts, isinstance(mc.tasks[task_id], BrickTask)):
        mc.ledger.journal_released(now_s, att, link.state)


def settle_done(
    mc: MissionControl,
    att: Attempt,
    r: TaskResult,
    uav: str,
    now_s: float,
    fields: dict[str, object] | None = None,
    *,
    phases: bool = True,
) -> None:
    """``att`` done by ``uav`` with ``r``: in the ledger, the dispatcher, the adhesive's clock, the journal (with
    the attempt's phases unless ``phases`` is False) and a ``completed`` event (with ``fields``)."""
    mc.ledger.done(att, r, now_s)
    mc.dispatcher.complete(r.task_id)
    if mc.glue is not None:
        mc.glue.completed(r.task_id, now_s)
    mc.ledger.journal_done(now_s, r, att, phases=phases)
    mc.out.emit(now_s, "completed", uav, r.task_id, attempt=att.attempt, **(fields or {}))


def misplaced(mc: MissionControl, att: Attempt, r: TaskResult, uav: str, why: str, now_s: float) -> None:
    """A brick its UAV placed that the as-built look found off its course height: failed with ``why`` and stuck
    (the brick is glued where it lies), journaled so, the bricks on it left unbuilt (docs/safety.md)."""
    mc.ledger.end(att, now_s, "failed", why)
    take_result(att, r)
    log.warning("%s placed by %s (attempt %d) but %s", r.task_id, uav, att.attempt, why)
    mc.dispatcher.fail(r.task_id, give_up=True)
    mc.ledger.journal_failed(now_s, att, why)
    mc.out.emit(now_s, "failed", uav, r.task_id, attempt=att.attempt, reason=why)
    release_waiting(mc, r.task_id, now_s)


def release_waiting(mc: MissionControl, stuck: str, now_s: float) -> None:
    """Task ``stuck`` was given up: every UAV on a task that depends on it (a brick fetched while the segment
    under it was flown, waiting at its hold point for it) is recalled now, in the same event, its attempt failing
    with :func:`given_up_reason` (it flies home, a brick on its magnet put back as any recall's), instead of
    waiting until ``hold_patience_s`` ends the wait (issue 27: a wait is ended by the model, not a timer)."""
    for task_id, uav in mc.dispatcher.waiting_on(stuck).items():
        why = given_up_reason(stuck, task_id)
        log.warning("%s: %s: recalled", uav, why)
        mc.recall(uav, now_s, why, task_id, mc.ledger.number_of(task_id))


def recall_again(mc: MissionControl, msg: Heartbeat, now_s: float) -> None:
    """A heartbeat naming the task mission control has its UAV on, a task that waits for a given-up one: the recall
    is sent again, with :func:`given_up_reason` (the one :func:`release_waiting` sent, in the live run or at the
    resume, may have been lost: a Zenoh session drops what it sends before it finds its peers). Sent on each such
    heartbeat until the UAV's failure is taken, no timer; the recall names the task and its attempt, and the
    handler ignores one naming an assignment it does not hold, so one said again is harmless (issue 27, branches
    ``recall41``, ``recall42``)."""
    tid = mc.dispatcher.task_of(msg.sender)
    if tid is None or msg.task_id != tid:
        return
    stuck = mc.dispatcher.given_up_under(tid)
    if stuck is not None:
        why = given_up_reason(stuck, tid)
        log.info("%s: %s: recalled again", msg.sender, why)
        mc.recall(msg.sender, now_s, why, tid, mc.ledger.number_of(tid))


def given_up_reason(stuck: str, waiting: str) -> str:
    """Why the attempt of ``waiting``, which depends on the given-up task ``stuck``, ends."""
    return f"{stuck} under {waiting} was given up"


def ignore(mc: MissionControl, reason: str, detail: str) -> None:
    """A result not acted on: counted by ``reason``, logged."""
    mc.out.ignored(reason)
    log.warning("ignoring %s", detail)


def heard_again(mc: MissionControl, msg: Result) -> bool:
    """A completion already taken, said again by its UAV (the handler repeats one when mission control's
    heartbeats paused around it, as a slow link or a busy computer makes them): nothing to do, nothing
    suspicious."""
    r = msg.result
    return r.status == "done" and mc.ledger.completed(r.task_id, msg.sender, msg.attempt)


def late_result(mc: MissionControl, msg: Result, now_s: float) -> bool:
    """A completion of an attempt its UAV was released from (:func:`~masonry.mission.reducer.late_completion`),
    found by the number the result names: done, and the attempt flying the task now, if any, is recalled by its
    own number (on another UAV, or a later assignment to the same one). True if taken."""
    r = msg.result
    att = mc.ledger.find(r.task_id, msg.sender, msg.attempt)
    settled = r.task_id in mc.dispatcher.done or r.task_id in mc.dispatcher.stuck
    if not late_completion(msg, att, settled):
        return False
    assert att is not None  # (late_completion takes none without its attempt)
    other = mc.dispatcher.complete_late(r.task_id)
    r = mc.placement.anchored(mc, r)
    log.warning("%s done by %s (attempt %d), heard late: taken", r.task_id, msg.sender, att.attempt)
    mc.ledger.done(att, r, now_s)
    if other is not None:
        why = f"{RECALL_REASON}: {r.task_id} was done by {msg.sender}"
        number = mc.ledger.number_of(r.task_id)  # (the attempt ``other`` flies)
        again = mc.ledger.running.get(r.task_id)
        if again is not None:
            mc.ledger.end(again, now_s, "failed", why, result=False)
            mc.ledger.journal_failed(now_s, again, why)
        mc.recall(other, now_s, why, r.task_id, number)
    mc.ledger.journal_done(now_s, r, att, phases=False)
    mc.out.emit(now_s, "completed", msg.sender, r.task_id, attempt=att.attempt)
    mc.wake()
    return True


def check_holds_task(mc: MissionControl, msg: Heartbeat, now_s: float) -> None:
    """A UAV's heartbeat says it forgot its task (:func:`~masonry.mission.reducer.dropped_reason`): the task
    goes back to the pool without counting an attempt; done instead if the attempt was kept from before a resume
    and its UAV said its brick was on the wall (journaled: :func:`note_release`)."""
    name = msg.sender
    tid = mc.dispatcher.task_of(name)
    att = None if tid is None else mc.ledger.running.get(tid)
    reason = dropped_reason(msg, att, now_s, mc.heartbeat_timeout_s)
    if tid is None or att is None or reason is None:
        return
    if att.adopted and mc.ledger.released(att):
        # kept from before a resume, its brick on the wall (it said so: ``note_release``), and it forgot the task
        # since (its handler restarted, as a stop of the whole in-process mission restarts it; one that kept its
        # completion says that first): done, as its loss would make it. (In a live run the no-task heartbeat may
        # come before a completion said again after a link drop: that one goes back to the pool as before, and
        # the completion is taken late with its measurements.)
        log.warning("%s done by %s (attempt %d): %s after its release", tid, name, att.attempt, reason)
        settle_done(mc, att, TaskResult(tid, "done", now_s - att.start_s), name, now_s, phases=False)
        mc.wake()
        return
    log.warning("%s: %s: released", name, reason)
    mc.ledger.end(att, now_s, "failed", reason)
    mc.dispatcher.fail(tid, count=False)
    mc.ledger.journal_failed(now_s, att, reason)
    mc.out.emit(now_s, "failed", name, tid, attempt=att.attempt, reason=reason)
    mc.wake()


def on_heartbeat(mc: MissionControl, msg: Heartbeat, link: UavLink, now_s: float) -> None:
    """What a UAV's heartbeat says besides its state: its battery, the wind its autopilot measures and its
    wind limit, and the task it holds; its time stamp to the clock that paces mission time, if any."""
    if mc.heard_clock is not None:
        mc.heard_clock(msg.sender, msg.time_s)
    if msg.battery is not None:
        if msg.battery >= SWAP_EARLY > (link.battery if link.battery is not None else 1.0):
            mc.wake()  # a fresh pack (swap_stagger): it may be dispatched again
        link.battery = msg.battery
    link.swaps_batteries = msg.swaps_batteries
    mc.lingers.heard(msg.sender, now_s, msg.battery, airborne=not msg.on_pad)
    if mc.heard_wind is not None and (msg.wind_mps is not None or msg.max_wind_mps is not None):
        mc.heard_wind.heard(msg.sender, now_s, msg.wind_mps, msg.max_wind_mps)
    check_holds_task(mc, msg, now_s)
    recall_again(mc, msg, now_s)
