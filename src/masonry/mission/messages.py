"""The mission protocol: versioned, validated messages between mission control and UAV handlers.

Every message travels as one JSON object with an envelope ``{"v": 2, "type": ..., "sender": ...}``.
:func:`decode` checks the version, the type, every field's type and, when the fleet is given, that the
sender (and the addressed UAV) belongs to it; anything else raises :class:`~masonry.errors.ProtocolError`.

Messages (``sender`` is a UAV name or :data:`MISSION_CONTROL`):

- :class:`Heartbeat` both ways, every ``heartbeat_period_s``: a silent peer is declared lost.
- :class:`Assign` mission control -> UAV: one task (the whole task value), its attempt number and the digest of
  the blueprint's wall (:func:`masonry.fingerprint.wall_digest`), so that a UAV flies only its own wall's tasks.
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
- :class:`Recall` mission control -> UAV: drop your task (it is reported failed, ``reason``), fly home and land.

Version history: 1 the first five messages; 2 the clearance messages (a mixed pair refuses each other's messages
at once instead of half-working); 3 ``wall`` in the assignment, ``attempt`` in the result (docs/security.md);
within 3, optional both ways: a result's ``phases`` and ``as_built``, a brick task's ``marker`` (a big wall's
reused number); 4 the operator's messages (a version-3 UAV would reject a recall and fly on); within 4, a brick
task's ``spare``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from masonry.errors import ProtocolError
from masonry.mission.as_built import as_built_field
from masonry.planner.tasks import AdhesionTask, BrickTask, Task
from masonry.ports import PHASES, PhaseTimes, TaskResult

PROTOCOL_VERSION = 4
MISSION_CONTROL = "mission-control"
#: The sender name of an operator's commands (``masonry ctl``); mission control answers to it.
OPERATOR = "operator"
#: What an operator may ask (:class:`OperatorCommand`).
OPERATOR_COMMANDS = ("pause", "resume", "abort", "recall", "return-all", "limit")

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Heartbeat:
    """I am alive: sent by every UAV handler and by mission control once per heartbeat period."""

    sender: str
    time_s: float
    state: str = ""
    task_id: str | None = None
    position_m: Vec3 | None = None
    #: the UAV's battery, 0..1 (None: not reported; optional on the wire, for the log and the live page)
    battery: float | None = None
    #: the wind its autopilot reports (MAVLink WIND), m/s, and its ``max_wind_mps`` (uav.yaml): mission control
    #: gives it no task above that (None: not reported)
    wind_mps: float | None = None
    max_wind_mps: float | None = None


@dataclass(frozen=True)
class Assign:
    """Mission control gives ``task`` to ``uav`` (attempt number ``attempt``, from 1) of the wall ``wall``.

    ``wall`` is :func:`masonry.fingerprint.wall_digest` of mission control's blueprint ("" when it has none).
    """

    sender: str
    uav: str
    task: Task
    attempt: int
    time_s: float
    wall: str = ""


@dataclass(frozen=True)
class Progress:
    """A UAV's state machine entered ``state`` while working on ``task_id``."""

    sender: str
    task_id: str
    state: str
    time_s: float
    position_m: Vec3 | None = None


@dataclass(frozen=True)
class Result:
    """A UAV finished (``done``) or abandoned (``failed``) a task."""

    sender: str
    result: TaskResult
    time_s: float
    position_m: Vec3 | None = None
    state: str = ""  # the UAV's state after the result ("halted": out of service)
    attempt: int = 0  # the attempt of the assignment this result answers (0: unknown, never accepted)


@dataclass(frozen=True)
class MissionEnd:
    """Mission control is done with the UAVs (``completed`` false when the mission could not finish)."""

    sender: str
    time_s: float
    completed: bool


@dataclass(frozen=True)
class ClearanceRequest:
    """A UAV asks for the column over ``site_m`` (it will leave its layer there); ``release``: it left it."""

    sender: str
    site_m: Vec3
    time_s: float
    position_m: Vec3 | None = None
    release: bool = False
    arrived: bool = False
    #: the highest altitude the UAV will reach while working at the site (None: the site's own altitude)
    top_m: float | None = None
    #: where the work at the site ends, if it moves along a segment (an adhesion UAV spraying); None: at the site
    to_m: Vec3 | None = None


@dataclass(frozen=True)
class Clearance:
    """Mission control's answer: the column over ``site_m`` is ``uav``'s (``granted``), or hold over ``hold_m``."""

    sender: str
    uav: str
    site_m: Vec3
    radius_m: float
    time_s: float
    granted: bool = True
    hold_m: Vec3 | None = None
    layer_m: float | None = None


@dataclass(frozen=True)
class OperatorCommand:
    """An operator asks mission control to ``command`` (one of :data:`OPERATOR_COMMANDS`).

    ``uav``: the UAV to recall; ``role`` and ``limit``: how many UAVs of that role may fly at once (-1 lifts it);
    ``id``: echoed in the answer."""

    sender: str
    command: str
    time_s: float
    id: str = ""
    uav: str | None = None
    role: str | None = None
    limit: int | None = None


@dataclass(frozen=True)
class CommandAnswer:
    """Mission control's answer to the operator's command ``id``: ``accepted``, or not and ``reason``."""

    sender: str
    id: str
    command: str
    accepted: bool
    reason: str
    time_s: float


@dataclass(frozen=True)
class Recall:
    """Mission control tells ``uav`` to drop its task (reported failed with ``reason``), fly home and land."""

    sender: str
    uav: str
    time_s: float
    reason: str


Message = (
    Heartbeat
    | Assign
    | Progress
    | Result
    | MissionEnd
    | ClearanceRequest
    | Clearance
    | OperatorCommand
    | CommandAnswer
    | Recall
)

_TYPE_NAMES: dict[type, str] = {
    Heartbeat: "heartbeat",
    Assign: "assign",
    Progress: "progress",
    Result: "result",
    MissionEnd: "mission-end",
    ClearanceRequest: "clearance-request",
    Clearance: "clearance",
    OperatorCommand: "operator-command",
    CommandAnswer: "command-answer",
    Recall: "recall",
}


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
    elif isinstance(message, Assign):
        body.update(
            uav=message.uav,
            task=task_to_dict(message.task),
            attempt=message.attempt,
            time_s=message.time_s,
            wall=message.wall,
        )
    elif isinstance(message, Progress):
        body.update(
            task_id=message.task_id,
            state=message.state,
            time_s=message.time_s,
            position_m=_vec(message.position_m),
        )
    elif isinstance(message, Result):
        r = message.result
        body.update(
            time_s=message.time_s,
            position_m=_vec(message.position_m),
            state=message.state,
            attempt=message.attempt,
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
        body.update(
            uav=message.uav,
            site_m=_vec(message.site_m),
            radius_m=message.radius_m,
            time_s=message.time_s,
            granted=message.granted,
            hold_m=_vec(message.hold_m),
            layer_m=message.layer_m,
        )
    elif isinstance(message, MissionEnd):
        body.update(time_s=message.time_s, completed=message.completed)
    else:
        body.update(_operator_body(message))
    return _ENCODER.encode(body).encode()


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
    return {"uav": message.uav, "time_s": message.time_s, "reason": message.reason}


#: What ``json.dumps(body, separators=(",", ":"), allow_nan=False)`` builds on every call, built once.
_ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False)


class _Fields:
    """Typed access to a JSON object's fields; every failure names the message type and the field."""

    def __init__(self, data: dict[str, Any], what: str) -> None:
        self.data = data
        self.what = what

    def fail(self, field: str, problem: str) -> ProtocolError:
        return ProtocolError(f"{self.what} message: field {field!r} {problem}")

    def get(self, field: str) -> Any:
        if field not in self.data:
            raise self.fail(field, "is missing")
        return self.data[field]

    def str_(self, field: str, *, optional: bool = False) -> Any:
        v = self.data.get(field) if optional else self.get(field)
        if v is None and optional:
            return None
        if not isinstance(v, str) or not v:
            raise self.fail(field, f"must be a non-empty string, got {v!r}")
        return v

    def num(self, field: str, *, optional: bool = False) -> Any:
        v = self.data.get(field) if optional else self.get(field)
        if v is None and optional:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise self.fail(field, f"must be a finite number, got {v!r}")
        return float(v)

    def int_(self, field: str) -> int:
        v = self.get(field)
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(field, f"must be an integer, got {v!r}")
        return v

    def bool_(self, field: str) -> bool:
        v = self.get(field)
        if not isinstance(v, bool):
            raise self.fail(field, f"must be true or false, got {v!r}")
        return v

    def vec(self, field: str, *, optional: bool = False) -> Any:
        v = self.data.get(field) if optional else self.get(field)
        if v is None and optional:
            return None
        if not isinstance(v, list) or len(v) != 3 or not all(_finite_number(x) for x in v):
            raise self.fail(field, f"must be a list of 3 finite numbers, got {v!r}")
        return (float(v[0]), float(v[1]), float(v[2]))

    def obj(self, field: str) -> dict[str, Any]:
        v = self.get(field)
        if not isinstance(v, dict):
            raise self.fail(field, f"must be an object, got {type(v).__name__}")
        return v


_PHASE_NAMES = frozenset(PHASES)


def phases_from_dict(data: Any, what: str = "result result") -> PhaseTimes:
    """Rebuild :class:`~masonry.ports.PhaseTimes` from its ``as_dict`` form (raises ProtocolError).

    Every key must be a phase of :data:`~masonry.ports.PHASES` and every value a finite number >= 0; a phase left
    out is 0 s.
    """
    if not isinstance(data, dict):
        raise ProtocolError(f"{what} message: field 'phases' must be an object, got {type(data).__name__}")
    unknown = sorted(str(k) for k in data if k not in _PHASE_NAMES)
    if unknown:
        raise ProtocolError(
            f"{what} message: field 'phases' has unknown phase {', '.join(map(repr, unknown))} "
            f"(known: {', '.join(PHASES)})"
        )
    seconds: dict[str, float] = {}
    for name, v in data.items():
        if not _finite_number(v) or v < 0:
            raise ProtocolError(
                f"{what} message: field 'phases' phase {name!r} must be a finite number >= 0, got {v!r}"
            )
        seconds[name] = float(v)
    return PhaseTimes(**seconds)


def task_from_dict(data: dict[str, Any], what: str = "assign") -> Task:
    """Rebuild a task value from :func:`task_to_dict` data (raises ProtocolError)."""
    f = _Fields(data, f"{what} task")
    kind = f.get("kind")
    if kind == "brick":
        return BrickTask(
            id=f.str_("id"),
            brick=f.int_("brick"),
            done=f.bool_("done"),
            position_m=f.vec("position_m"),
            yaw_rad=f.num("yaw_rad"),
            pickup_m=f.vec("pickup_m", optional=True),
            size_m=f.vec("size_m"),
            spare=None if data.get("spare") is None else f.int_("spare"),
            marker=f.int_("marker") if "marker" in data else None,
        )
    if kind == "adhesion":
        return AdhesionTask(
            id=f.str_("id"),
            below=f.int_("below"),
            above=f.int_("above"),
            start_m=f.vec("start_m"),
            end_m=f.vec("end_m"),
            length_m=f.num("length_m"),
            done=f.bool_("done"),
        )
    raise f.fail("kind", f"must be 'brick' or 'adhesion', got {kind!r}")


_new_message = object.__new__


_JSON = json.JSONDecoder()


def _loads(raw: bytes | str) -> Any:
    """``json.loads(raw)``, with a direct path for the common case: UTF-8 bytes holding one JSON object.

    ``json.loads`` detects the encoding (UTF-8 for bytes starting ``{"``), decodes, then parses and checks that
    nothing follows; anything else (another encoding, trailing whitespace, an error) goes through it as is.
    """
    if type(raw) is bytes and raw[:2] == b'{"':
        try:
            s = raw.decode("utf-8", "surrogatepass")
            data, end = _JSON.raw_decode(s)
        except ValueError:  # UnicodeDecodeError, JSONDecodeError: json.loads raises its own error
            return json.loads(raw)
        if end == len(s):
            return data
    return json.loads(raw)


def _finite_number(v: Any) -> bool:
    return (type(v) is float or type(v) is int) and math.isfinite(v)


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
    wind: Any = data.get("wind_mps")
    limit: Any = data.get("max_wind_mps")
    if wind is not None or limit is not None:
        return None  # the checked decoder says what is wrong with them, if anything
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
    )
    return hb


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
    )


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
    return Assign(sender, uav, task_from_dict(f.obj("task")), attempt, f.num("time_s"), wall)


def _progress(f: _Fields, sender: str, fleet: Collection[str] | None) -> Progress:
    _check_uav(f, fleet, sender, "sender")
    return Progress(
        sender, f.str_("task_id"), f.str_("state"), f.num("time_s"), f.vec("position_m", optional=True)
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
    )


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
    return Recall(sender, uav, f.num("time_s"), str(f.data.get("reason") or "recalled"))


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
