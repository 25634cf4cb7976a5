"""JSON schemas of the log's messages: Foxglove's well-known ones (by name and field layout, so Foxglove draws them
with no plugin) and masonry's own (docs/logging.md). Pure: plain dicts, no I/O."""

from __future__ import annotations

from typing import Any

_NUM = {"type": "number"}
_STR = {"type": "string"}
_INT = {"type": "integer"}
_BOOL = {"type": "boolean"}


def _obj(schema_title: str, **properties: Any) -> dict[str, Any]:
    return {"title": schema_title, "type": "object", "properties": properties}


_TIME = _obj("time", sec={"type": "integer", "minimum": 0}, nsec={"type": "integer", "minimum": 0})
_DURATION = _obj("duration", sec=_INT, nsec={"type": "integer", "minimum": 0})
_VEC3 = _obj("foxglove.Vector3", x=_NUM, y=_NUM, z=_NUM)
_POINT3 = _obj("foxglove.Point3", x=_NUM, y=_NUM, z=_NUM)
_QUAT = _obj("foxglove.Quaternion", x=_NUM, y=_NUM, z=_NUM, w=_NUM)
_POSE = _obj("foxglove.Pose", position=_VEC3, orientation=_QUAT)
_COLOR = _obj("foxglove.Color", r=_NUM, g=_NUM, b=_NUM, a=_NUM)
_KV = _obj("foxglove.KeyValuePair", key=_STR, value=_STR)

_CUBE = _obj("foxglove.CubePrimitive", pose=_POSE, size=_VEC3, color=_COLOR)
_LINE = _obj(
    "foxglove.LinePrimitive",
    type={"title": "foxglove.LineType", "enum": [0, 1, 2]},  # 0 LINE_STRIP, 1 LINE_LOOP, 2 LINE_LIST
    pose=_POSE,
    thickness=_NUM,
    scale_invariant=_BOOL,
    points={"type": "array", "items": _POINT3},
    color=_COLOR,
    colors={"type": "array", "items": _COLOR},
    indices={"type": "array", "items": _INT},
)
_TEXT = _obj(
    "foxglove.TextPrimitive",
    pose=_POSE,
    billboard=_BOOL,
    font_size=_NUM,
    scale_invariant=_BOOL,
    color=_COLOR,
    text=_STR,
)
_ENTITY = _obj(
    "foxglove.SceneEntity",
    timestamp=_TIME,
    frame_id=_STR,
    id=_STR,
    lifetime=_DURATION,
    frame_locked=_BOOL,
    metadata={"type": "array", "items": _KV},
    cubes={"type": "array", "items": _CUBE},
    lines={"type": "array", "items": _LINE},
    texts={"type": "array", "items": _TEXT},
)
_DELETION = _obj(
    "foxglove.SceneEntityDeletion",
    timestamp=_TIME,
    type={"title": "foxglove.SceneEntityDeletionType", "enum": [0, 1]},  # 0 MATCHING_ID, 1 ALL
    id=_STR,
)

#: Foxglove's well-known schemas, by the names Foxglove recognises.
FOXGLOVE: dict[str, dict[str, Any]] = {
    "foxglove.PoseInFrame": _obj("foxglove.PoseInFrame", timestamp=_TIME, frame_id=_STR, pose=_POSE),
    "foxglove.FrameTransform": _obj(
        "foxglove.FrameTransform",
        timestamp=_TIME,
        parent_frame_id=_STR,
        child_frame_id=_STR,
        translation=_VEC3,
        rotation=_QUAT,
    ),
    "foxglove.SceneUpdate": _obj(
        "foxglove.SceneUpdate",
        deletions={"type": "array", "items": _DELETION},
        entities={"type": "array", "items": _ENTITY},
    ),
    "foxglove.Log": _obj(
        "foxglove.Log",
        timestamp=_TIME,
        level={
            "title": "foxglove.LogLevel",
            "enum": [0, 1, 2, 3, 4, 5],
        },  # UNKNOWN DEBUG INFO WARNING ERROR FATAL
        message=_STR,
        name=_STR,
        file=_STR,
        line={"type": "integer", "minimum": 0},
    ),
}

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

__all__ = ["FOXGLOVE", "MASONRY"]
