"""The mission protocol: versioned, validated messages between mission control and UAV handlers.

Every message travels as one JSON object with an envelope ``{"v": 7, "type": ..., "sender": ...}``.
:func:`decode` checks the version, the type, every field's type and, when the fleet is given, that the
sender (and the addressed UAV) belongs to it; anything else raises :class:`~masonry.errors.ProtocolError`.

Messages (``sender`` is a UAV name or :data:`MISSION_CONTROL`):

- :class:`Heartbeat` both ways, every ``heartbeat_period_s``: a silent peer is declared lost.
- :class:`Assign` mission control -> UAV: one task (the whole task value), its attempt number (the assignment's
  own) and the digest of the blueprint's wall (:func:`masonry.fingerprint.wall_digest`), so that a UAV flies only
  its own wall's tasks.
- :class:`Progress` UAV -> mission control: the UAV's state machine entered ``state`` while on ``task_id``.
- :class:`Result` UAV -> mission control: the task is done or failed (a :class:`~masonry.ports.TaskResult`),
  for the attempt it was assigned with.
- :class:`MissionEnd` mission control -> UAV: nothing more will come; go home and land.
- :class:`ClearanceRequest` UAV -> mission control: I set off for ``site_m``; may I leave my transit layer
  there (a site column, :mod:`masonry.mission.airspace`)? With ``release`` true: I left that column; with
  ``arrived`` true: my flight there is down (its layer is free).
- :class:`Clearance` mission control -> UAV: fly your lateral leg at ``layer_m``; the column over ``site_m``
  is yours (``granted``), or wait at your layer over ``hold_m``; ``radius_m``: free a column once that far
  from it.
- :class:`OperatorCommand` operator (:data:`OPERATOR`, ``masonry ctl``) -> mission control: pause, resume,
  abort, recall a UAV, return all, set a role's fleet limit (:mod:`masonry.mission.operator`).
- :class:`CommandAnswer` mission control -> operator: that command accepted, or refused with a reason.
- :class:`Recall` mission control -> UAV: drop attempt ``attempt`` of ``task_id`` (it is reported failed,
  ``reason``), fly home and land; ``task_id`` null: whatever you hold (the operator's).

Version history: 1 the first five messages; 2 the clearance messages (a mixed pair refuses each other's messages
at once instead of half-working); 3 ``wall`` in the assignment, ``attempt`` in the result (docs/security.md: a UAV
checks the task against its blueprint, mission control accepts a result only for the current attempt); within 3,
optional both ways (a peer without one leaves it out, one that does not know it ignores it): a result's
``phases`` and ``as_built``, a brick task's ``marker`` (a big wall's reused number); 4 the operator's messages (a
version-3 UAV would reject a recall and fly on); within 4, a brick task's ``spare``, an assignment's ``planned``
(the task on the wall as built, :mod:`masonry.planner.as_built_plan`: a UAV that does not know it flies the
design; one that does refuses a ``planned`` that is not the task moved by at most
:data:`~masonry.planner.as_built_plan.MAX_PLANNED_SHIFT_M`); 5 a heartbeat's and a progress report's typed facts
``carrying``, ``flying_home``, ``on_pad``, ``finishing`` and ``out_of_service`` (a result's ``out_of_service`` too) (:mod:`masonry.mission.uav_facts`; booleans, false
when left out): mission control decides from them, not from the state name (a version-4 UAV sends none, and
would be taken for one that never carries a brick); within 5, a heartbeat's ``swaps_batteries`` (a ground crew
swaps its pack: mission control may send it home for an early swap, :mod:`masonry.mission.swap_stagger`; one
that does not send it is never sent home early); 6 a recall's ``task_id`` and ``attempt`` (the assignment it
recalls; null and 0: whatever the UAV holds): a UAV ignores one naming an assignment it does not hold, so a recall
said again cannot fail the next task (a version-5 UAV would take it for "whatever you hold"); within 6, mission
control numbers every assignment of a task anew (``attempt`` 1, 2, 3, ... whether what ended the one before
counted against the task or not: :class:`~masonry.mission.ledger.AttemptLedger`): a UAV only echoes the number and
compares recalls with it, so either side of a mixed pair works as before; 7 a clearance's ``grant`` (the number
of the flight it answers) and a heartbeat's and progress report's ``plan_progress`` (how far the UAV is along that
flight, :class:`~masonry.ports.PlanProgress`; null or left out: none), which the table reads in place of the
position rule (:mod:`masonry.mission.plan_reading`): a version-6 UAV would report none, and its mission control's
answers would number nothing.
"""

from __future__ import annotations

import json
from typing import Any

from masonry.mission.message_decode import (
    MAX_REPORTED_WIND_MPS,
    MAX_WIND_LIMIT_MPS,
    decode,
)
from masonry.mission.message_decode import _decode as _decode
from masonry.mission.message_decode import _last_decoded as _last_decoded
from masonry.mission.message_fields import _finite_number as _finite_number
from masonry.mission.message_fields import _loads as _loads
from masonry.mission.message_fields import phases_from_dict, task_from_dict
from masonry.mission.message_types import (
    _TYPE_NAMES,
    MISSION_CONTROL,
    OPERATOR,
    OPERATOR_COMMANDS,
    PROTOCOL_VERSION,
    Assign,
    Clearance,
    ClearanceRequest,
    CommandAnswer,
    Heartbeat,
    Message,
    MissionEnd,
    OperatorCommand,
    Progress,
    Recall,
    Result,
    Vec3,
)
from masonry.planner.tasks import BrickTask, Task

__all__ = [
    "MAX_REPORTED_WIND_MPS",
    "MAX_WIND_LIMIT_MPS",
    "MISSION_CONTROL",
    "OPERATOR",
    "OPERATOR_COMMANDS",
    "PROTOCOL_VERSION",
    "Assign",
    "Clearance",
    "ClearanceRequest",
    "CommandAnswer",
    "Heartbeat",
    "Message",
    "MissionEnd",
    "OperatorCommand",
    "Progress",
    "Recall",
    "Result",
    "Vec3",
    "decode",
    "encode",
    "phases_from_dict",
    "task_from_dict",
    "task_to_dict",
]


def _vec(v: Vec3 | None) -> list[float] | None:
    return None if v is None else [float(x) for x in v]


def task_to_dict(task: Task) -> dict[str, Any]:
    """A task value as plain JSON data (the inverse of :func:`task_from_dict`)."""
    if isinstance(task, BrickTask):
        return {
            "kind": "brick",
            "id": task.id,
            "brick": task.brick,
            "done": task.done,
            "position_m": _vec(task.position_m),
            "yaw_rad": task.yaw_rad,
            "pickup_m": _vec(task.pickup_m),
            "size_m": _vec(task.size_m),
            **({} if task.spare is None else {"spare": task.spare}),
            **({} if task.marker is None else {"marker": task.marker}),
            **(
                {}
                if not task.wall_as_built
                else {"wall_as_built": [[b, _vec(d)] for b, d in task.wall_as_built]}
            ),
        }
    return {
        "kind": "adhesion",
        "id": task.id,
        "below": task.below,
        "above": task.above,
        "start_m": _vec(task.start_m),
        "end_m": _vec(task.end_m),
        "length_m": task.length_m,
        "done": task.done,
    }


def encode(message: Message) -> bytes:
    """Serialise one message to its JSON wire form (UTF-8)."""
    body: dict[str, Any] = {
        "v": PROTOCOL_VERSION,
        "type": _TYPE_NAMES[type(message)],
        "sender": message.sender,
    }
    if isinstance(message, Heartbeat):
        body.update(
            time_s=message.time_s,
            state=message.state,
            task_id=message.task_id,
            position_m=_vec(message.position_m),
        )
        if message.battery is not None:
            body["battery"] = message.battery
        if message.wind_mps is not None:
            body["wind_mps"] = message.wind_mps
        if message.max_wind_mps is not None:
            body["max_wind_mps"] = message.max_wind_mps
        if message.swaps_batteries:
            body["swaps_batteries"] = True
        body.update(_facts(message))
    elif isinstance(message, Assign):
        body.update(
            uav=message.uav,
            task=task_to_dict(message.task),
            attempt=message.attempt,
            time_s=message.time_s,
            wall=message.wall,
        )
        if message.planned is not None:
            body["planned"] = task_to_dict(message.planned)
    elif isinstance(message, Progress):
        body.update(
            task_id=message.task_id,
            state=message.state,
            time_s=message.time_s,
            position_m=_vec(message.position_m),
        )
        body.update(_facts(message))
    elif isinstance(message, Result):
        r = message.result
        body.update(
            time_s=message.time_s,
            position_m=_vec(message.position_m),
            state=message.state,
            attempt=message.attempt,
            out_of_service=message.out_of_service,
            result={
                "task_id": r.task_id,
                "status": r.status,
                "duration_s": r.duration_s,
                "reason": r.reason,
                "placement_error_m": r.placement_error_m,
                "coverage": r.coverage,
                **({} if r.phases is None else {"phases": r.phases.as_dict()}),
                **({} if r.as_built is None else {"as_built": r.as_built.to_dict()}),
            },
        )
    elif isinstance(message, ClearanceRequest):
        body.update(
            site_m=_vec(message.site_m),
            time_s=message.time_s,
            position_m=_vec(message.position_m),
            release=message.release,
            arrived=message.arrived,
            top_m=message.top_m,
            to_m=_vec(message.to_m),
        )
    elif isinstance(message, Clearance):
        body.update(_clearance_body(message))
    elif isinstance(message, MissionEnd):
        body.update(time_s=message.time_s, completed=message.completed)
    else:
        body.update(_operator_body(message))
    return _ENCODER.encode(body).encode()


def _facts(message: Heartbeat | Progress) -> dict[str, object]:
    """A heartbeat's or progress report's facts (:data:`~masonry.mission.message_types.FACT_FIELDS`, and
    ``plan_progress`` when it has one: :data:`~masonry.mission.message_types.PLAN_PROGRESS_FIELDS`)."""
    out: dict[str, object] = {
        "carrying": message.carrying,
        "flying_home": message.flying_home,
        "on_pad": message.on_pad,
        "finishing": message.finishing,
        "out_of_service": message.out_of_service,
    }
    pp = message.plan_progress
    if pp is not None:
        out["plan_progress"] = {"grant": pp.grant, "leg": pp.leg, "leg_fraction": pp.leg_fraction}
    return out


def _clearance_body(message: Clearance) -> dict[str, object]:
    body: dict[str, object] = {
        "uav": message.uav,
        "site_m": _vec(message.site_m),
        "radius_m": message.radius_m,
        "time_s": message.time_s,
        "granted": message.granted,
        "hold_m": _vec(message.hold_m),
        "layer_m": message.layer_m,
    }
    if not message.gentle:  # (only said when not: an older mission control's answer is gentle)
        body["gentle"] = False
    if message.open_for_s is not None:
        body["open_for_s"] = message.open_for_s
    if message.grant:  # (0: not numbered, left out)
        body["grant"] = message.grant
    return body


def _operator_body(message: OperatorCommand | CommandAnswer | Recall) -> dict[str, Any]:
    if isinstance(message, OperatorCommand):
        return {
            "command": message.command,
            "time_s": message.time_s,
            "id": message.id,
            "uav": message.uav,
            "role": message.role,
            "limit": message.limit,
        }
    if isinstance(message, CommandAnswer):
        return {
            "id": message.id,
            "command": message.command,
            "accepted": message.accepted,
            "reason": message.reason,
            "time_s": message.time_s,
        }
    return {
        "uav": message.uav,
        "time_s": message.time_s,
        "reason": message.reason,
        "task_id": message.task_id,
        "attempt": message.attempt,
    }


#: What ``json.dumps(body, separators=(",", ":"), allow_nan=False)`` builds on every call, built once.
_ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False)
