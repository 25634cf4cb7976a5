"""Decoding the mission protocol: the wire form back to a validated message (:func:`decode`).

The envelope (version, type, sender) is checked first, then the body of each type by one function
(:data:`_BODIES`); a well-formed heartbeat, the bulk of the traffic, takes a direct path. See
:mod:`masonry.mission.messages` for the protocol and its version history.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from typing import Any

from masonry.errors import ProtocolError
from masonry.mission.as_built import as_built_field
from masonry.mission.message_fields import _Fields, _finite_number, _loads, phases_from_dict, task_from_dict
from masonry.mission.message_types import (
    FACT_FIELDS,
    MISSION_CONTROL,
    OPERATOR,
    OPERATOR_COMMANDS,
    PLAN_PROGRESS_FIELDS,
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
)
from masonry.planner.as_built_plan import MAX_PLANNED_SHIFT_M, planned_shift_m
from masonry.planner.tasks import Task
from masonry.ports import PLAN_LEGS, PlanProgress, TaskResult

_new_message = object.__new__


def _heartbeat_fast(data: dict[str, Any], fleet: Collection[str] | None) -> Heartbeat | None:
    """A well-formed heartbeat (the bulk of the traffic) decoded with the checks of :func:`decode` written out.

    None when any check fails: :func:`decode` then runs its general path, which raises the precise error.
    """
    sender = data.get("sender")
    if type(sender) is not str or not sender:
        return None
    if fleet is not None and sender != MISSION_CONTROL and sender not in fleet:
        return None
    time_s: Any = data.get("time_s")
    if not _finite_number(time_s):
        return None
    task_id = data.get("task_id")
    if task_id is not None and (type(task_id) is not str or not task_id):
        return None
    p = data.get("position_m")
    if p is not None:
        if type(p) is not list or len(p) != 3:
            return None
        x, y, z = p
        if not (_finite_number(x) and _finite_number(y) and _finite_number(z)):
            return None
        p = (float(x), float(y), float(z))
    battery: Any = data.get("battery")
    if battery is not None:
        if not _finite_number(battery) or not 0.0 <= battery <= 1.0:
            return None
        battery = float(battery)
    wind = data.get("wind_mps")
    limit = data.get("max_wind_mps")
    if wind is not None or limit is not None:
        return None  # the checked decoder says what is wrong with them, if anything
    carrying = data.get("carrying", False)
    flying_home = data.get("flying_home", False)
    on_pad = data.get("on_pad", False)
    finishing = data.get("finishing", False)
    out_of_service = data.get("out_of_service", False)
    plan = _plan_progress_fast(data.get("plan_progress"))
    if plan is False:
        return None  # (the checked decoder says what is wrong with it)
    swaps = data.get("swaps_batteries", False)
    if not all(type(v) is bool for v in (carrying, flying_home, on_pad, finishing, out_of_service, swaps)):
        return None
    # the same value as Heartbeat(...) without the frozen dataclass's per-field object.__setattr__
    hb: Heartbeat = _new_message(Heartbeat)
    hb.__dict__.update(
        sender=sender,
        time_s=float(time_s),
        state=str(data.get("state") or ""),
        task_id=task_id,
        position_m=p,
        battery=battery,
        wind_mps=None,
        max_wind_mps=None,
        swaps_batteries=swaps,
        carrying=carrying,
        flying_home=flying_home,
        on_pad=on_pad,
        finishing=finishing,
        out_of_service=out_of_service,
        plan_progress=plan,
    )
    return hb


def _plan_progress_fast(raw: object) -> PlanProgress | bool | None:
    """A heartbeat's ``plan_progress`` with :func:`_plan_progress`'s checks written out: the value, None (none), or
    False (any check fails: :func:`decode`'s general path raises the precise error)."""
    if raw is None:
        return None
    if type(raw) is not dict or len(raw) != len(PLAN_PROGRESS_FIELDS):
        return False
    grant, leg, fraction = raw.get("grant"), raw.get("leg"), raw.get("leg_fraction")
    if type(grant) is not int or grant < 1 or type(leg) is not int or not 0 <= leg < len(PLAN_LEGS):
        return False
    if (
        not (type(fraction) is float or type(fraction) is int) or not 0.0 <= fraction <= 1.0
    ):  # (NaN fails too)
        return False
    return PlanProgress(grant, leg, float(fraction))


def decode(raw: bytes | str, fleet: Collection[str] | None = None) -> Message:
    """Parse and validate one wire message.

    Args:
        raw: the JSON bytes as received.
        fleet: the UAV names of the blueprint's fleet; when given, a UAV sender or addressee outside it is
            rejected.

    Raises:
        ProtocolError: malformed JSON, another protocol version, an unknown type, a bad field, or a UAV name
            not in ``fleet``.
    """
    if fleet is not None:
        return _decode(raw, fleet)
    # Decoding is a pure function of the bytes: a message broadcast to every UAV (mission control's heartbeat,
    # the same bytes to each handler) is parsed and validated once, then handed out again (messages are frozen).
    last = _last_decoded[0]
    if last is not None and last[0] == raw:
        return last[1]
    msg = _decode(raw, None)
    _last_decoded[0] = (raw, msg)
    return msg


#: The last message :func:`decode` decoded without a fleet, with its bytes.
_last_decoded: list[tuple[bytes | str, Message] | None] = [None]


def _decode(raw: bytes | str, fleet: Collection[str] | None = None) -> Message:
    """:func:`decode` without its cache of the last broadcast (same arguments, result and errors)."""
    try:
        data = _loads(raw)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ProtocolError(f"message is not valid JSON: {exc}") from exc
    if not isinstance(data, dict):
        raise ProtocolError(f"message must be a JSON object, got {type(data).__name__}")
    version = data.get("v")
    if version != PROTOCOL_VERSION:
        raise ProtocolError(f"message has protocol version {version!r}; this side speaks {PROTOCOL_VERSION}")
    kind = data.get("type")
    if kind == "heartbeat":
        hb = _heartbeat_fast(data, fleet)
        if hb is not None:
            return hb
    f = _Fields(data, str(kind))
    sender = f.str_("sender")
    body = _BODIES.get(kind) if isinstance(kind, str) else None
    if body is None:
        raise ProtocolError(f"unknown message type {kind!r}")
    return body(f, sender, fleet)


def _check_uav(f: _Fields, fleet: Collection[str] | None, name: str, field: str) -> None:
    if fleet is not None and name not in fleet:
        raise ProtocolError(f"{f.what} message: {field} {name!r} is not a UAV of the blueprint's fleet")


def _check_from_mission_control(f: _Fields, sender: str) -> None:
    if sender != MISSION_CONTROL:
        raise ProtocolError(f"{f.what} message: only {MISSION_CONTROL!r} may send it, not {sender!r}")


def _heartbeat(f: _Fields, sender: str, fleet: Collection[str] | None) -> Heartbeat:
    if sender != MISSION_CONTROL:
        _check_uav(f, fleet, sender, "sender")
    return Heartbeat(
        sender,
        f.num("time_s"),
        state=str(f.data.get("state") or ""),
        task_id=f.str_("task_id", optional=True),
        position_m=f.vec("position_m", optional=True),
        battery=_battery(f),
        wind_mps=_speed(f, "wind_mps", 0.0, MAX_REPORTED_WIND_MPS, low_open=False),
        max_wind_mps=_speed(f, "max_wind_mps", 0.0, MAX_WIND_LIMIT_MPS, low_open=True),
        swaps_batteries=_flag(f, "swaps_batteries"),
        **_facts(f),
        plan_progress=_plan_progress(f),
    )


def _flag(f: _Fields, name: str) -> bool:
    """An optional true-or-false field (false when left out)."""
    value = f.data.get(name, False)
    if type(value) is not bool:
        raise f.fail(name, f"must be true or false, got {value!r}")
    return value


def _facts(f: _Fields) -> dict[str, bool]:
    """A heartbeat's or progress report's facts (:data:`FACT_FIELDS`): each true or false, false when left out."""
    out: dict[str, bool] = {}
    for name in FACT_FIELDS:
        out[name] = _flag(f, name)
    return out


def _plan_progress(f: _Fields) -> PlanProgress | None:
    """A heartbeat's or progress report's optional ``plan_progress`` (:data:`PLAN_PROGRESS_FIELDS`): the answer's
    number an integer >= 1, the leg an index of :data:`~masonry.ports.PLAN_LEGS`, the fraction a finite number in
    0..1, nothing else; null or left out: none. Anything else is refused with the reason (the network is hostile:
    a report that moves mission control's table must say what it means)."""
    raw = f.data.get("plan_progress")
    if raw is None:
        return None
    if not isinstance(raw, dict):
        raise f.fail("plan_progress", f"must be an object, got {type(raw).__name__}")
    unknown = sorted(str(k) for k in raw if k not in PLAN_PROGRESS_FIELDS)
    if unknown:
        raise f.fail("plan_progress", f"has unknown field {', '.join(map(repr, unknown))}")
    p = _Fields(raw, f"{f.what} plan_progress")
    grant, leg = p.int_("grant"), p.int_("leg")
    if grant < 1:
        raise p.fail("grant", f"must be >= 1, got {grant}")
    if not 0 <= leg < len(PLAN_LEGS):
        raise p.fail(
            "leg", f"must be an index of {', '.join(PLAN_LEGS)} (0..{len(PLAN_LEGS) - 1}), got {leg}"
        )
    fraction = p.num("leg_fraction")
    if not 0.0 <= fraction <= 1.0:
        raise p.fail("leg_fraction", f"must be in 0..1, got {fraction}")
    return PlanProgress(grant, leg, fraction)


#: A wind reading above this is no reading (a hurricane's sustained wind is 33 m/s), and a limit above
#: ``MAX_WIND_LIMIT_MPS`` no small UAV's (masonry.mission.wind_limit checks the same).
MAX_REPORTED_WIND_MPS = 60.0
MAX_WIND_LIMIT_MPS = 30.0


def _speed(f: _Fields, name: str, low: float, high: float, *, low_open: bool) -> float | None:
    value = f.num(name, optional=True)
    if value is None:
        return None
    if not (low < value <= high if low_open else low <= value <= high):
        raise f.fail(
            name, f"must be {'>' if low_open else '>='} {low:g} and at most {high:g} m/s, got {value}"
        )
    return float(value)


def _battery(f: _Fields) -> float | None:
    battery = f.num("battery", optional=True)
    if battery is not None and not 0.0 <= battery <= 1.0:
        raise f.fail("battery", f"must be in 0..1, got {battery}")
    return None if battery is None else float(battery)


def _assign(f: _Fields, sender: str, fleet: Collection[str] | None) -> Assign:
    _check_from_mission_control(f, sender)
    uav = f.str_("uav")
    _check_uav(f, fleet, uav, "uav")
    attempt = f.int_("attempt")
    if attempt < 1:
        raise f.fail("attempt", f"must be >= 1, got {attempt}")
    wall = f.data.get("wall", "")
    if not isinstance(wall, str):
        raise f.fail("wall", f"must be a string, got {wall!r}")
    task = task_from_dict(f.obj("task"))
    return Assign(sender, uav, task, attempt, f.num("time_s"), wall, _planned(f, task))


def _planned(f: _Fields, task: Task) -> Task | None:
    """An assignment's optional ``planned``: ``task`` moved onto the wall as built, by at most
    :data:`MAX_PLANNED_SHIFT_M` (anything else is refused: it would fly a brick elsewhere than the blueprint says)."""
    if f.data.get("planned") is None:
        return None
    planned = task_from_dict(f.obj("planned"), "assign planned")
    shift_m = planned_shift_m(task, planned)
    if shift_m is None:
        raise f.fail("planned", f"must be task {task.id} with only its target or segment moved")
    if not shift_m <= MAX_PLANNED_SHIFT_M:
        raise f.fail(
            "planned",
            f"moves task {task.id} {shift_m:.3f} m from its design (at most {MAX_PLANNED_SHIFT_M} m)",
        )
    return planned


def _progress(f: _Fields, sender: str, fleet: Collection[str] | None) -> Progress:
    _check_uav(f, fleet, sender, "sender")
    return Progress(
        sender,
        f.str_("task_id"),
        f.str_("state"),
        f.num("time_s"),
        f.vec("position_m", optional=True),
        **_facts(f),
        plan_progress=_plan_progress(f),
    )


def _result(f: _Fields, sender: str, fleet: Collection[str] | None) -> Result:
    _check_uav(f, fleet, sender, "sender")
    r = _Fields(f.obj("result"), "result result")
    status = r.get("status")
    if status not in ("done", "failed"):
        raise r.fail("status", f"must be 'done' or 'failed', got {status!r}")
    result = TaskResult(
        task_id=r.str_("task_id"),
        status=status,
        duration_s=r.num("duration_s"),
        reason=r.str_("reason", optional=True),
        placement_error_m=r.num("placement_error_m", optional=True),
        coverage=r.num("coverage", optional=True),
        phases=None if r.data.get("phases") is None else phases_from_dict(r.data["phases"]),
        as_built=as_built_field(r.data, r.fail),
    )
    attempt = f.int_("attempt")
    if attempt < 0:
        raise f.fail("attempt", f"must be >= 0, got {attempt}")
    return Result(
        sender,
        result,
        f.num("time_s"),
        f.vec("position_m", optional=True),
        state=str(f.data.get("state") or ""),
        attempt=attempt,
        out_of_service=_flag(f, "out_of_service"),
    )


def _mission_end(f: _Fields, sender: str, fleet: Collection[str] | None) -> MissionEnd:
    _check_from_mission_control(f, sender)
    return MissionEnd(sender, f.num("time_s"), f.bool_("completed"))


def _clearance_request(f: _Fields, sender: str, fleet: Collection[str] | None) -> ClearanceRequest:
    _check_uav(f, fleet, sender, "sender")
    return ClearanceRequest(
        sender,
        f.vec("site_m"),
        f.num("time_s"),
        f.vec("position_m", optional=True),
        f.bool_("release"),
        f.bool_("arrived"),
        f.num("top_m", optional=True),
        f.vec("to_m", optional=True),
    )


def _clearance(f: _Fields, sender: str, fleet: Collection[str] | None) -> Clearance:
    _check_from_mission_control(f, sender)
    uav = f.str_("uav")
    _check_uav(f, fleet, uav, "uav")
    radius = f.num("radius_m")
    if radius < 0.0:
        raise f.fail("radius_m", f"must be >= 0, got {radius}")
    return Clearance(
        sender,
        uav,
        f.vec("site_m"),
        radius,
        f.num("time_s"),
        f.bool_("granted"),
        f.vec("hold_m", optional=True),
        f.num("layer_m", optional=True),
        f.bool_("gentle") if "gentle" in f.data else True,
        f.num("open_for_s", optional=True),
        _grant(f),
    )


def _grant(f: _Fields) -> int:
    """A clearance's optional ``grant``: an integer >= 0 (0 or left out: not numbered)."""
    if "grant" not in f.data:
        return 0
    grant = f.int_("grant")
    if grant < 0:
        raise f.fail("grant", f"must be >= 0, got {grant}")
    return grant


def _operator_command(f: _Fields, sender: str, fleet: Collection[str] | None) -> OperatorCommand:
    if sender != OPERATOR:
        raise f.fail("sender", f"only {OPERATOR!r} sends commands, not {sender!r}")
    command = f.str_("command")
    if command not in OPERATOR_COMMANDS:
        raise f.fail("command", f"must be one of {', '.join(OPERATOR_COMMANDS)}, got {command!r}")
    uav = f.str_("uav", optional=True)  # a UAV not of the fleet is refused by mission control, with a reason
    limit = f.data.get("limit")
    if limit is not None and (type(limit) is not int or limit < -1):
        raise f.fail("limit", f"must be an integer >= -1, got {limit!r}")
    return OperatorCommand(
        sender,
        command,
        f.num("time_s"),
        str(f.data.get("id") or ""),
        uav,
        f.str_("role", optional=True),
        limit,
    )


def _command_answer(f: _Fields, sender: str, fleet: Collection[str] | None) -> CommandAnswer:
    _check_from_mission_control(f, sender)
    return CommandAnswer(
        sender,
        str(f.data.get("id") or ""),
        f.str_("command"),
        f.bool_("accepted"),
        str(f.data.get("reason") or ""),
        f.num("time_s"),
    )


def _recall(f: _Fields, sender: str, fleet: Collection[str] | None) -> Recall:
    _check_from_mission_control(f, sender)
    uav = f.str_("uav")
    _check_uav(f, fleet, uav, "uav")
    task_id = f.str_("task_id", optional=True)
    attempt = f.int_("attempt")
    if task_id is None and attempt != 0:
        raise f.fail("attempt", f"must be 0 when no task is named, got {attempt}")
    if task_id is not None and attempt < 1:
        raise f.fail("attempt", f"must be >= 1 for task {task_id}, got {attempt}")
    return Recall(sender, uav, f.num("time_s"), str(f.data.get("reason") or "recalled"), task_id, attempt)


#: How the body of each message type is read, after the envelope (version, type, sender): one function per type.
_BODIES: dict[str, Callable[[_Fields, str, Collection[str] | None], Message]] = {
    "heartbeat": _heartbeat,
    "assign": _assign,
    "progress": _progress,
    "result": _result,
    "mission-end": _mission_end,
    "clearance-request": _clearance_request,
    "clearance": _clearance,
    "operator-command": _operator_command,
    "command-answer": _command_answer,
    "recall": _recall,
}
