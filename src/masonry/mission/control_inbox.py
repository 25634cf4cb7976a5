"""Mission control's way in: one received frame decoded, screened, and routed to the effects it asks for.

The counterpart of :mod:`~masonry.mission.outbox` (issue 27 §2): :func:`handle` decodes a frame (one that
does not decode is counted and logged, never acted on), answers the operator's commands, screens a UAV's message
(:func:`masonry.mission.control_losses.screened`: a late completion, a UAV declared lost), marks its sender
heard, then carries out the :class:`~masonry.mission.reducer.Step` list that the pure
:func:`~masonry.mission.reducer.steps_of` names for it, each by the part that owns it (``control_airspace``,
``control_results``, ``control_losses``). Part of :class:`~masonry.mission.control.MissionControl`.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from masonry.errors import ProtocolError
from masonry.mission import control_airspace, control_losses, control_results
from masonry.mission.messages import (
    MISSION_CONTROL,
    OPERATOR,
    ClearanceRequest,
    Heartbeat,
    OperatorCommand,
    Progress,
    Result,
    decode,
)
from masonry.mission.reducer import Step, steps_of

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl

__all__ = ["handle"]

log = logging.getLogger("masonry.mission.control")


def handle(mc: MissionControl, raw: bytes, now_s: float) -> None:
    """One message: decoded, screened, then the :func:`~masonry.mission.reducer.steps_of` it asks for."""
    try:
        msg = decode(raw, mc.uavs.keys())
    except ProtocolError as exc:
        mc.events.rejected += 1
        mc.events.errors.append(str(exc))
        log.warning("rejected message: %s", exc)
        return
    mc.events.received += 1
    if isinstance(msg, OperatorCommand):
        mc.out.send(OPERATOR, mc.operator.answer(mc, msg, now_s))
        return
    if msg.sender == MISSION_CONTROL or msg.sender == OPERATOR:
        return
    link = mc.uavs[msg.sender]
    if control_losses.screened(mc, link, msg, now_s):
        return
    mc.liveness.heard(link, now_s)
    if isinstance(msg, Result):
        link.taking_off = False
        if msg.position_m is not None:
            link.moved_to(msg.position_m)
    for step in steps_of(msg):
        if step is Step.CLEARANCE and isinstance(msg, ClearanceRequest):
            control_airspace.on_clearance_request(mc, msg, now_s)
        elif step is Step.RESULT and isinstance(msg, Result):
            control_results.take_result_message(mc, msg, now_s)
        elif step is Step.RETIRE:
            control_losses.lose(mc, msg.sender, now_s, status="out of service")
        elif step is Step.HEARTBEAT and isinstance(msg, Heartbeat):
            control_results.on_heartbeat(mc, msg, link, now_s)
        elif step is Step.PROGRESS:
            _progress(mc, msg, now_s)
        elif step is Step.REPORT and isinstance(msg, (Heartbeat, Progress)):
            control_airspace.report(mc, link, msg, msg.position_m)
            control_results.note_release(mc, link, msg.task_id, now_s)  # (its brick on the wall: journaled)
            if mc.sink is not None and mc.uav_events:
                control_airspace.emit_uav(mc, now_s, link)


def _progress(mc: MissionControl, msg: object, now_s: float) -> None:
    """A progress report, counted; the first a UAV sends on its attempt said (INFO): the line a multi-process
    test waits for before it kills a process mid-task (``tests/test_chaos_distributed.py``), not a guess of
    seconds."""
    mc.events.progress += 1
    att = mc.ledger.under_way(msg.task_id, msg.sender) if isinstance(msg, Progress) else None
    if att is not None:
        log.info("%s under way on %s (attempt %d) at %.1f s", att.task_id, att.uav, att.attempt, now_s)
