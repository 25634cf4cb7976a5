"""JSON schemas of masonry's own messages in the log (docs/logging.md). Pure: plain dicts, no I/O.

Foxglove's messages (scene, poses, frames, log lines) are not here: they are written with the Foxglove SDK's own
types and schemas (:mod:`masonry.observe.scene`)."""

from __future__ import annotations

from typing import Any

_NUM = {"type": "number"}
_STR = {"type": "string"}
_INT = {"type": "integer"}


def _obj(schema_title: str, **properties: Any) -> dict[str, Any]:
    return {"title": schema_title, "type": "object", "properties": properties}


_TIME = _obj("time", sec={"type": "integer", "minimum": 0}, nsec={"type": "integer", "minimum": 0})
_NULLABLE_STR = {"type": ["string", "null"]}

#: masonry's own schemas (docs/logging.md).
MASONRY: dict[str, dict[str, Any]] = {
    "masonry.MissionEvent": {
        **_obj(
            "masonry.MissionEvent",
            time_s=_NUM,
            kind=_STR,
            uav=_NULLABLE_STR,
            task_id=_NULLABLE_STR,
            fields={"type": "object"},
        ),
        "required": ["time_s", "kind", "uav", "task_id", "fields"],
    },
    "masonry.UavState": _obj(
        "masonry.UavState",
        timestamp=_TIME,
        uav=_STR,
        state=_STR,
        task_id=_NULLABLE_STR,
        battery={"type": ["number", "null"]},
        status=_STR,
        volumes=_INT,
    ),
    "masonry.Blueprint": {
        "title": "masonry.Blueprint",
        "type": "object",
        "properties": {
            "yaml": _STR,
            "title": _STR,
            "source": _STR,
            "command": _STR,
            "done": {"type": "array", "items": _STR},
        },
        "required": ["yaml", "title"],
    },
    "masonry.MissionReport": {
        **_obj("masonry.MissionReport", report={"type": "object"}, extra={"type": "object"}),
        "required": ["report"],
    },
}

__all__ = ["MASONRY"]
