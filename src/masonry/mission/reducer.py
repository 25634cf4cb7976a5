"""Mission control's decisions as pure functions: what a message or a silence means (``event -> effects``).

Each function takes what mission control knows (values, no ports, no clock of its own) and returns what to do:
the :class:`Step` list a UAV's message asks for, whether a result is acted on or ignored (:class:`Ignored`, the
checks of docs/security.md), whether a completion heard late counts, whether a heartbeat says its UAV forgot its
task, and why an attempt of a UAV taken out of the mission failed. :class:`~masonry.mission.control.MissionControl`
carries the effects out (its dispatcher, airspace, ledger and transport); these functions are tested on their own
(tests/test_mission_reducer.py).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from masonry.mission.journal_state import LOST_REASON
from masonry.mission.message_types import ClearanceRequest, Heartbeat, Message, Progress, Result
from masonry.mission.records import Attempt
from masonry.mission.uav_facts import OUT_OF_SERVICE_STATE, UavFacts
from masonry.mission.volumes import Vec3
from masonry.ports import TASK_DROPPED_REASON

__all__ = [
    "OUT_OF_SERVICE_STATE",
    "PUTBACK_FLIGHT_STATES",
    "Ignored",
    "Step",
    "dropped_reason",
    "late_completion",
    "loss_reason",
    "placed_before_loss",
    "screen_result",
    "steps_of",
    "way_home_of",
]


#: The states of a UAV flying a brick back to its pallet (``masonry.fsm``): its way home goes through the pickup
#: (kept for readers; mission control decides from the facts ``flying_home`` and ``carrying``).
PUTBACK_FLIGHT_STATES = frozenset({"putback_goto", "putback_descend"})


class Step(enum.Enum):
    """One thing mission control does with a UAV's message, in the order :func:`steps_of` lists them."""

    CLEARANCE = "clearance"  # the airspace answers a request, a release or an arrival
    RESULT = "result"  # a task's result: done or failed (after :func:`screen_result`)
    RETIRE = "retire"  # the UAV is out of service: out of the mission
    HEARTBEAT = "heartbeat"  # its battery, its wind, the task it holds
    PROGRESS = "progress"  # counted
    REPORT = "report"  # its state and position: the airspace follows it


def steps_of(msg: Message) -> tuple[Step, ...]:
    """What a message from a UAV in the mission asks of mission control, in order."""
    if isinstance(msg, Result):
        if not msg.out_of_service:
            return (Step.RESULT,)
        # refused or abandoned because it is out of service: not the task's fault (no result counted)
        return (Step.RETIRE,) if msg.result.status == "failed" else (Step.RESULT, Step.RETIRE)
    if isinstance(msg, (Heartbeat, Progress)):
        if msg.out_of_service:
            return (Step.RETIRE,)
        return (Step.HEARTBEAT if isinstance(msg, Heartbeat) else Step.PROGRESS, Step.REPORT)
    # (the other kinds never come from a UAV: nothing to do)
    return (Step.CLEARANCE,) if isinstance(msg, ClearanceRequest) else ()


@dataclass(frozen=True)
class Ignored:
    """A result not acted on: ``reason`` is the key counted in ``MissionEvents.ignored``."""

    reason: str
    detail: str


def screen_result(
    msg: Result,
    owner: str | None,
    att: Attempt | None,
    least_s: float | None,
    min_fraction: float,
    now_s: float,
) -> Ignored | None:
    """Whether ``msg`` may be acted on (None) or is ignored (docs/security.md).

    Args:
        owner: the UAV ``msg``'s task is assigned to now (None: none).
        att: the task's running attempt.
        least_s: the least time the task can take (None: no such check).
        min_fraction: the margin on ``least_s``.
    """
    r = msg.result
    if owner != msg.sender or att is None:
        return Ignored("not-assigned", f"a result for {r.task_id} from {msg.sender}: not its task now")
    if msg.attempt != att.attempt:
        detail = f"a result for {r.task_id} from {msg.sender} for attempt {msg.attempt}: "
        return Ignored("wrong-attempt", f"{detail}the current one is {att.attempt}")
    # (not for an attempt kept from before a resume: the clock resumed at the journal's last record, and how long
    # mission control was down is not known)
    took_s = now_s - att.start_s
    if r.status == "done" and least_s is not None and not att.adopted and took_s < min_fraction * least_s:
        detail = f"{r.task_id} reported done by {msg.sender} {took_s:.2f} s after its assignment: "
        return Ignored("too-short", f"{detail}it takes at least {least_s:.1f} s")
    return None


def late_completion(msg: Result, named: Attempt | None, settled: bool) -> bool:
    """A completion of an attempt released from its UAV when it was declared lost (or its heartbeat stopped naming
    it): it did the task after all, its result delayed by the link. It counts unless the task is done or stuck
    since (``settled``). The attempt is the one the result names (each assignment has its own number), so a
    completion of an earlier flight is told from a later assignment of the task, to another UAV or the same one
    (issue 27, branch ``attempt43``: before, a task given to the same UAV again had the same number).

    Args:
        named: the sender's attempt of the task with the number ``msg`` names (None: it had none).
    """
    r = msg.result
    if r.status != "done" or settled or named is None:
        return False
    if named.attempt != msg.attempt or named.status != "failed":
        return False
    return (named.reason or "").startswith((LOST_REASON, TASK_DROPPED_REASON))


def dropped_reason(
    msg: Heartbeat, att: Attempt | None, now_s: float, heartbeat_timeout_s: float
) -> str | None:
    """Why the task of ``att`` goes back to the pool (not counted), or None: the UAV's heartbeat says it is idle
    and holds no task although its assignment went out longer than the heartbeat timeout ago (its handler was
    restarted before it was declared lost)."""
    if msg.task_id is not None or att is None or not msg.on_pad:
        return None  # (only an idle machine: a UAV that names no task but is busy flying is not a fresh one)
    if att.adopted:
        return f"{TASK_DROPPED_REASON} (its heartbeat holds no task after the resume)"
    if now_s - att.start_s <= heartbeat_timeout_s:
        return None  # the assignment may still be on its way
    return f"{TASK_DROPPED_REASON} (its heartbeat holds no task {now_s - att.start_s:.1f} s after it)"


def way_home_of(
    facts: UavFacts, via_m: Vec3 | None, layer_m: float | None
) -> tuple[float | None, Vec3 | None] | None:
    """The way home a UAV heard again with ``facts`` flies on its own (its fixed layer, and, with a brick on its
    magnet, the pickup it puts it back on), or None: it is not flying home."""
    if facts.flying_home:
        return (layer_m, via_m if facts.carrying else None)
    return None


def loss_reason(out_of_service: str | None, last_state: str, carried_brick: int | None) -> str:
    """Why the attempt of a UAV taken out of the mission failed: lost (silent; with the brick it was last heard
    carrying, a retry that then finds none on the pallet says why), or ``uav <status>``."""
    if out_of_service is not None:
        return f"uav {out_of_service}"
    if carried_brick is None:
        return LOST_REASON
    return f"{LOST_REASON} (last heard in {last_state}, with brick {carried_brick} on its magnet)"


def placed_before_loss(facts: UavFacts, brick_task: bool) -> bool:
    """A brick UAV taken out of the mission for its silence, last heard with ``facts``, had its brick on the wall:
    finishing its task (``FINISHING_STATES``) with no brick on its magnet, that is from the release on (its magnet
    lets go as it enters ``place_release``; the descent before it is ``carrying``). Its task is done: given again,
    its retry looked for the brick at its pickup ("not seen near its pickup"), a spare stood in for it and met the
    brick in its place (``tests/test_spares_sim.py``, brick-2 lost 3.5 s after its release of brick 8). A sprayer's
    facts do not tell the spraying from the climb after it: False."""
    return brick_task and facts.finishing and not facts.carrying
