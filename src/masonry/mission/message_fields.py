"""Typed reading of a decoded JSON message: its fields, a task value, the phases of a result.

Every failure raises :class:`~masonry.errors.ProtocolError` naming the message type and the field; used by
:mod:`masonry.mission.message_decode` and by the journal (:func:`phases_from_dict`).
"""

from __future__ import annotations

import json
import math
from typing import Any

from masonry.errors import ProtocolError
from masonry.planner.tasks import AdhesionTask, BrickTask, Task
from masonry.planner.wall_deviation import MAX_WALL_DEVIATION_M
from masonry.ports import PHASES, PhaseTimes


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
        if (
            not isinstance(v, list)
            or len(v) != 3
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) for x in v)
        ):
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


def _wall_as_built(f: _Fields) -> tuple[tuple[int, tuple[float, float, float]], ...]:
    """A brick task's optional ``wall_as_built``: [[brick id, [dx, dy, dz]], ...], each deviation at most
    :data:`~masonry.planner.wall_deviation.MAX_WALL_DEVIATION_M` long (a UAV aligns its drop-off on them)."""
    raw = f.data.get("wall_as_built")
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise f.fail("wall_as_built", f"must be a list, got {type(raw).__name__}")
    out = []
    for item in raw:
        if not isinstance(item, list) or len(item) != 2:
            raise f.fail("wall_as_built", f"must hold [brick id, [dx, dy, dz]] pairs, got {item!r}")
        d = _Fields({"brick": item[0], "d": item[1]}, f.what)
        brick, dev = d.int_("brick"), d.vec("d")
        if not math.hypot(*dev) <= MAX_WALL_DEVIATION_M:
            raise f.fail("wall_as_built", f"brick {brick}'s deviation is over {MAX_WALL_DEVIATION_M} m")
        out.append((brick, dev))
    return tuple(out)


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
            wall_as_built=_wall_as_built(f),
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


def _finite_number(v: object) -> bool:
    return (type(v) is float or type(v) is int) and math.isfinite(v)
