"""What a mission shows in Foxglove, as Foxglove's own messages: the wall, the airspace, the UAVs, the log lines.

:class:`MissionScene` is an :class:`~masonry.mission.events.EventSink` that turns each mission event into the
messages of the log's topics (docs/logging.md) and hands them to :meth:`MissionScene.write`, which a subclass
implements: the MCAP log (:class:`masonry.observe.mcap_log.McapLog`) and the live Foxglove server
(:class:`masonry.observe.live.FoxgloveLive`) write the same messages. Foxglove's topics carry the SDK's typed
messages (``foxglove.messages``: its protobuf encoding and the schema it ships); masonry's own carry plain dicts
(JSON, their schemas in :mod:`masonry.observe.schemas`).
"""

from __future__ import annotations

import json
import math
import threading
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import foxglove.messages
from foxglove.messages import (
    Color,
    CubePrimitive,
    Duration,
    FrameTransform,
    LinePrimitive,
    LinePrimitiveLineType,
    Log,
    LogLevel,
    Point3,
    Pose,
    PoseInFrame,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    Timestamp,
    Vector3,
)

from masonry.mission.events import MissionEvent
from masonry.mission.report import MissionReport
from masonry.mission.report_codec import report_to_record
from masonry.observe.schemas import MASONRY
from masonry.planner.tasks import BrickTask, Plan

#: The world frame (ENU, metres) every pose and scene entity is in.
WORLD_FRAME = "world"

#: Colours (r, g, b, a) of a task's brick or segment by its state, and of reserved airspace.
COLOURS: dict[str, tuple[float, float, float, float]] = {
    "todo": (0.62, 0.62, 0.62, 0.35),
    "running": (1.0, 0.6, 0.1, 0.9),
    "done": (0.72, 0.27, 0.18, 1.0),
    "stuck": (0.8, 0.0, 0.0, 1.0),
    "adhesion_done": (0.2, 0.45, 0.95, 1.0),
    "airspace": (0.2, 0.7, 1.0, 0.18),
}

#: Topics (docs/logging.md) and their schemas: ``foxglove.*`` are the SDK's, ``masonry.*`` masonry's own.
TOPICS: dict[str, str] = {
    "/mission/blueprint": "masonry.Blueprint",
    "/mission/events": "masonry.MissionEvent",
    "/mission/reservations": "masonry.MissionEvent",
    "/mission/report": "masonry.MissionReport",
    "/log": "foxglove.Log",
    "/wall": "foxglove.SceneUpdate",
    "/airspace": "foxglove.SceneUpdate",
    "/paths": "foxglove.SceneUpdate",
    "/tf": "foxglove.FrameTransform",
    "/uav/NAME/pose": "foxglove.PoseInFrame",
    "/uav/NAME/state": "masonry.UavState",
}

#: ``/tf`` carries each UAV's frame at most this often (its pose topic has every sample), mission seconds.
TF_PERIOD_S = 1.0
#: ``/uav/NAME/state`` is written when the state, task, status or airspace changes, else this often.
STATE_PERIOD_S = 2.0

_LEVELS = {
    "failed": LogLevel.Warning,
    "lost": LogLevel.Warning,
    "spare": LogLevel.Warning,
    "placement": LogLevel.Warning,
    "stall": LogLevel.Error,
}


def schema_name(topic: str) -> str:
    """The schema of ``topic`` (``/uav/brick-1/pose`` -> ``foxglove.PoseInFrame``)."""
    return TOPICS.get(topic) or TOPICS["/uav/NAME/" + topic.rsplit("/", 1)[-1]]


def channel_schema(topic: str) -> tuple[str, str, bytes, str]:
    """``(schema name, schema encoding, schema data, message encoding)`` of ``topic``'s channel: the SDK's own
    schema for Foxglove's messages (protobuf), masonry's JSON schema for its own."""
    name = schema_name(topic)
    if name.startswith("masonry."):
        return name, "jsonschema", json.dumps(MASONRY[name]).encode(), "json"
    sdk = getattr(foxglove.messages, name.split(".", 1)[1]).get_schema()  # a protobuf FileDescriptorSet
    return str(sdk.name), str(sdk.encoding), bytes(sdk.data), "protobuf"


class Encodable(Protocol):
    """A Foxglove SDK message: it encodes itself in its schema's encoding."""

    def encode(self) -> bytes: ...


#: What the log and the live server write: a Foxglove SDK message, or a dict on masonry's own (JSON) topics.
Message = Encodable | dict[str, object]


def encoded(message: Message) -> bytes:
    """A message's bytes: a Foxglove message in the SDK's encoding, a dict as JSON."""
    if isinstance(message, dict):
        return json.dumps(message, allow_nan=False).encode()
    return bytes(message.encode())


def ns(time_s: float) -> int:
    """Mission seconds as log time (nanoseconds, never negative)."""
    return max(0, round(time_s * 1e9))


def _stamp(time_s: float) -> Timestamp:
    t = ns(time_s)
    return Timestamp(t // 1_000_000_000, t % 1_000_000_000)


def _json_stamp(time_s: float) -> dict[str, int]:
    t = ns(time_s)
    return {"sec": t // 1_000_000_000, "nsec": t % 1_000_000_000}


def _vec(p: Sequence[float]) -> Vector3:
    return Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2]))


def _point(p: Sequence[float]) -> Point3:
    return Point3(x=float(p[0]), y=float(p[1]), z=float(p[2]))


def _yaw(yaw_rad: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw_rad / 2.0), w=math.cos(yaw_rad / 2.0))


def _rgba(c: tuple[float, float, float, float]) -> Color:
    return Color(r=c[0], g=c[1], b=c[2], a=c[3])


def _entity(time_s: float, entity_id: str, **primitives: Any) -> SceneEntity:
    return SceneEntity(
        timestamp=_stamp(time_s), frame_id=WORLD_FRAME, id=entity_id, lifetime=Duration(0, 0), **primitives
    )


def volume_cube(
    row: Sequence[float], colour: tuple[float, float, float, float] = COLOURS["airspace"]
) -> CubePrimitive:
    """A reserved volume (``[ax, ay, bx, by, z0, z1, slack]``) as a ``foxglove.CubePrimitive``: the box around
    the segment thickened by its slack (the volume itself has round ends; the box holds it)."""
    ax, ay, bx, by, z0, z1, slack = (float(v) for v in row)
    length = math.hypot(bx - ax, by - ay)
    return CubePrimitive(
        pose=Pose(
            position=_vec(((ax + bx) / 2, (ay + by) / 2, (z0 + z1) / 2)),
            orientation=_yaw(math.atan2(by - ay, bx - ax)),
        ),
        size=_vec((max(length + 2 * slack, 0.05), max(2 * slack, 0.05), max(z1 - z0, 0.05))),
        color=_rgba(colour),
    )


def _line(
    points: list[Point3], thickness_m: float, colour: tuple[float, float, float, float]
) -> LinePrimitive:
    return LinePrimitive(
        type=LinePrimitiveLineType.LineStrip,
        pose=Pose(position=_vec((0, 0, 0)), orientation=_yaw(0.0)),
        thickness=thickness_m,
        points=points,
        color=_rgba(colour),
    )


class MissionScene(ABC):
    """Turns mission events into the log's messages; a subclass writes them (:meth:`write`).

    Args:
        plan: the mission's plan (the wall's entities).
        blueprint_yaml: the blueprint as flown, as YAML, for replay.
        title: the title of the drawings; command: the command line that ran the mission (for people).
    """

    def __init__(self, plan: Plan, blueprint_yaml: str, *, title: str = "", command: str = "") -> None:
        self.plan = plan
        self.blueprint_yaml = blueprint_yaml
        self.title = title
        self.command = command
        self._tasks = {t.id: t for t in plan.tasks}
        #: tasks done before the log opens (a resumed mission's), drawn done on the wall from the start
        self.done: set[str] = set()
        self._volumes: dict[str, object] = {}
        self._tf_s: dict[str, float] = {}
        self._states: dict[str, tuple[tuple[object, ...], float]] = {}
        #: the wall as it stands (task id -> its entity) and each UAV's airspace: a late viewer's first frame
        self.wall: dict[str, SceneEntity] = {}
        self.airspace: dict[str, SceneEntity] = {}
        self.scene_lock = threading.Lock()
        self.last_s = 0.0
        self.messages = 0

    @abstractmethod
    def write(self, topic: str, time_s: float, message: Message) -> None:
        """Write one message: an SDK message on Foxglove's topics, a dict on masonry's."""

    def wants(self, topic: str) -> bool:
        """Whether anyone reads ``topic`` now (the log: always; a live server: a viewer subscribed to it), so the
        frequent messages are not even built for nobody. The wall and the airspace are kept whatever it says."""
        return True

    def _put(self, topic: str, time_s: float, message: Message) -> None:
        self.last_s = max(self.last_s, time_s)
        self.write(topic, time_s, message)
        self.messages += 1

    def write_opening(self) -> None:
        """The blueprint and the wall as the mission starts."""
        self._put(
            "/mission/blueprint",
            0.0,
            {
                "yaml": self.blueprint_yaml,
                "title": self.title,
                "source": "",
                "command": self.command,
                "done": sorted(self.done),
            },
        )
        with self.scene_lock:
            for t in self.plan.tasks:
                self.wall[t.id] = self._task_entity(
                    0.0, t.id, "done" if t.done or t.id in self.done else "todo"
                )
            entities = list(self.wall.values())
        self._put("/wall", 0.0, SceneUpdate(entities=entities))

    def emit(self, event: MissionEvent) -> None:
        """Write one mission event, and what it changes on the other topics."""
        t = event.time_s
        if event.kind in (
            "reservation",
            "hold",
        ):  # the table's changes (--airspace table): a topic of their own
            if self.wants("/mission/reservations"):
                self._put("/mission/reservations", t, event.to_dict())
            return
        if self.wants("/mission/events"):
            self._put("/mission/events", t, event.to_dict())
        if event.kind == "uav" and event.uav is not None:
            self._uav(event)
        elif self.wants("/log"):
            level = _LEVELS.get(event.kind, LogLevel.Info)
            line = Log(timestamp=_stamp(t), level=level, message=event.line().strip(), name="mission-control")
            self._put("/log", t, line)
        if event.task_id is not None and event.kind in ("assigned", "completed", "failed", "lost"):
            state = {"assigned": "running", "completed": "done"}.get(event.kind, "todo")
            entity = self._task_entity(t, event.task_id, state, event)
            with self.scene_lock:
                self.wall[event.task_id] = entity
            self._put("/wall", t, SceneUpdate(entities=[entity]))
        if event.kind in ("clearance", "lost") and event.uav is not None:
            self._airspace(t, event.uav, event.fields.get("volumes", []))

    def _uav(self, event: MissionEvent) -> None:
        t, f, name = event.time_s, event.fields, str(event.uav)
        p = f.get("position_m")
        if p is not None and self.wants(f"/uav/{name}/pose"):
            pose = Pose(position=_vec(p), orientation=_yaw(0.0))
            self._put(
                f"/uav/{name}/pose", t, PoseInFrame(timestamp=_stamp(t), frame_id=WORLD_FRAME, pose=pose)
            )
        if p is not None and self.wants("/tf"):
            last_tf = self._tf_s.get(name)
            if last_tf is None or t - last_tf >= TF_PERIOD_S:
                self._tf_s[name] = t
                tf = FrameTransform(
                    timestamp=_stamp(t),
                    parent_frame_id=WORLD_FRAME,
                    child_frame_id=name,
                    translation=_vec(p),
                    rotation=_yaw(0.0),
                )
                self._put("/tf", t, tf)
        vols = f.get("volumes", [])
        state = (f.get("state", ""), event.task_id, f.get("status", "ok"), len(vols))
        last = self._states.get(name)
        if (last is None or last[0] != state or t - last[1] >= STATE_PERIOD_S) and self.wants(
            f"/uav/{name}/state"
        ):
            self._states[name] = (state, t)
            self._put(
                f"/uav/{name}/state",
                t,
                {
                    "timestamp": _json_stamp(t),
                    "uav": name,
                    "state": state[0],
                    "task_id": event.task_id,
                    "battery": f.get("battery"),
                    "status": state[2],
                    "volumes": state[3],
                },
            )
        self._airspace(t, name, vols)

    def _airspace(self, t: float, uav: str, volumes: Sequence[Sequence[float]]) -> None:
        if self._volumes.get(uav) == volumes:
            return
        self._volumes[uav] = volumes
        entity = _entity(t, f"airspace/{uav}", cubes=[volume_cube(v) for v in volumes])
        with self.scene_lock:
            self.airspace[uav] = entity
        self._put("/airspace", t, SceneUpdate(entities=[entity]))

    def _task_entity(
        self, t: float, task_id: str, state: str, event: MissionEvent | None = None
    ) -> SceneEntity:
        task = self._tasks[task_id]
        if isinstance(task, BrickTask):
            position, yaw, colour = task.position_m, task.yaw_rad, COLOURS[state]
            f = event.fields if event is not None else {}
            seen = f.get("as_built") if state == "done" else None
            if isinstance(
                seen, Mapping
            ):  # where the camera saw it, green on its design to red at the tolerance
                position, yaw = seen["position_m"], float(seen["yaw_rad"])
                frac = min(1.0, float(seen["deviation_m"]) / max(float(f.get("tolerance_m", 0.02)), 1e-9))
                colour = (frac, 1.0 - frac, 0.1, 1.0)
            cube = CubePrimitive(
                pose=Pose(position=_vec(position), orientation=_yaw(yaw)),
                size=_vec(task.size_m),
                color=_rgba(colour),
            )
            return _entity(t, f"task/{task_id}", cubes=[cube])
        colour = COLOURS["adhesion_done"] if state == "done" else COLOURS[state]
        return _entity(
            t, f"task/{task_id}", lines=[_line([_point(task.start_m), _point(task.end_m)], 0.03, colour)]
        )

    def finish(self, report: MissionReport, extra: Mapping[str, Any] | None = None) -> None:
        """Write the flown paths and the report (what ``masonry replay`` prints and draws)."""
        t = max(self.last_s, report.sim_time_s + (report.resumed_from_s or 0.0))
        lines = [
            _entity(
                t,
                f"path/{name}",
                lines=[
                    _line([_point(p) for p in path[:: max(1, len(path) // 2000)]], 0.02, (0.1, 0.1, 0.1, 0.8))
                ],
            )
            for name, path in sorted(report.paths_m.items())
        ]
        self._put("/paths", t, SceneUpdate(entities=lines))
        self._put("/mission/report", t, {"report": report_to_record(report), "extra": dict(extra or {})})


__all__ = [
    "COLOURS",
    "TOPICS",
    "WORLD_FRAME",
    "MissionScene",
    "channel_schema",
    "encoded",
    "ns",
    "schema_name",
    "volume_cube",
]
