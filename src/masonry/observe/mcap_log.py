"""The mission log: an MCAP file Foxglove opens with no plugin, and that ``masonry replay`` reads back.

:class:`McapLog` is an :class:`~masonry.mission.events.EventSink`: mission control hands it every event and it
writes them as JSON messages (topics and schemas in docs/logging.md): the events themselves, each UAV's pose
(``foxglove.PoseInFrame`` and ``/tf``), its state and battery, the wall and the reserved airspace as
``foxglove.SceneUpdate``, a ``foxglove.Log`` line per event, and at the end the mission's report, losslessly
(:mod:`masonry.mission.report_codec`). Log time is mission time (nanoseconds from mission time 0).

:func:`read_log` reads one back (:class:`RecordedMission`): the blueprint, the events, the report. The SQLite
journal stays the source of truth for ``--resume``; the log is for people and tools.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from masonry.errors import InputError, MasonryError
from masonry.mission.events import MissionEvent
from masonry.mission.report import MissionReport
from masonry.mission.report_codec import report_from_record, report_to_record
from masonry.observe.schemas import FOXGLOVE, MASONRY
from masonry.planner.tasks import BrickTask, Plan

#: The MCAP profile (none of the ROS ones: plain JSON messages with JSON schemas).
PROFILE = ""
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

#: Topics (docs/logging.md).
TOPICS: dict[str, str] = {
    "/mission/blueprint": "masonry.Blueprint",
    "/mission/events": "masonry.MissionEvent",
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

_LEVELS = {"failed": 3, "lost": 3, "stall": 4, "end": 2}


def _ns(time_s: float) -> int:
    return max(0, round(time_s * 1e9))


def _stamp(time_s: float) -> dict[str, int]:
    ns = _ns(time_s)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _vec(p: Any) -> dict[str, float]:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def _yaw(yaw_rad: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw_rad / 2.0), "w": math.cos(yaw_rad / 2.0)}


def _rgba(c: tuple[float, float, float, float]) -> dict[str, float]:
    return {"r": c[0], "g": c[1], "b": c[2], "a": c[3]}


def _entity(time_s: float, entity_id: str, **primitives: Any) -> dict[str, Any]:
    return {
        "timestamp": _stamp(time_s),
        "frame_id": WORLD_FRAME,
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": [],
        **primitives,
    }


def volume_cube(row: Any, colour: tuple[float, float, float, float] = COLOURS["airspace"]) -> dict[str, Any]:
    """A reserved volume (``[ax, ay, bx, by, z0, z1, slack]``) as a ``foxglove.CubePrimitive``: the box around
    the segment thickened by its slack (the volume itself has round ends; the box holds it)."""
    ax, ay, bx, by, z0, z1, slack = (float(v) for v in row)
    length = math.hypot(bx - ax, by - ay)
    return {
        "pose": {
            "position": _vec(((ax + bx) / 2, (ay + by) / 2, (z0 + z1) / 2)),
            "orientation": _yaw(math.atan2(by - ay, bx - ax)),
        },
        "size": _vec((max(length + 2 * slack, 0.05), max(2 * slack, 0.05), max(z1 - z0, 0.05))),
        "color": _rgba(colour),
    }


class McapLog:
    """Writes a mission's log to ``path``: :meth:`open`, hand it events (:meth:`emit`), :meth:`finish`, :meth:`close`.

    Args:
        path: the ``.mcap`` file (replaced).
        plan: the mission's plan (the wall's entities).
        blueprint_yaml: the blueprint as flown, as YAML (:func:`masonry.blueprint.format_blueprint`), for replay.
        title: the title of the drawings (``--gantt``, ``--plot3d``).
        command: the command line that ran the mission (for people).
    """

    def __init__(
        self, path: str | Path, plan: Plan, blueprint_yaml: str, *, title: str = "", command: str = ""
    ) -> None:
        self.path = Path(path)
        self.plan = plan
        self.blueprint_yaml = blueprint_yaml
        self.title = title
        self.command = command
        self._file: Any = None
        self._writer: Writer | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._last_s = 0.0
        self._tasks = {t.id: t for t in plan.tasks}
        #: tasks done before the log opens (a resumed mission's), drawn done on the wall from the start
        self.done: set[str] = set()
        self._volumes: dict[str, Any] = {}
        self._tf_s: dict[str, float] = {}
        self._states: dict[str, tuple[Any, float]] = {}
        self.messages = 0

    def open(self) -> McapLog:
        """Create the file and write the blueprint and the wall as it starts.

        Raises:
            InputError: the file cannot be created.
            MasonryError: the log is open already.
        """
        if self._writer is not None:
            raise MasonryError(f"the log {self.path} is open already")
        try:
            self._file = open(self.path, "wb")  # noqa: SIM115 - held until close()
        except OSError as exc:
            raise InputError(
                f"`log` {self.path}: cannot write it: {exc.strerror or exc}", options=("log",)
            ) from None
        self._writer = Writer(self._file, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="masonry")
        self._write(
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
        self._write(
            "/wall",
            0.0,
            {
                "deletions": [],
                "entities": [
                    self._task_entity(0.0, t.id, "done" if t.done or t.id in self.done else "todo")
                    for t in self.plan.tasks
                ],
            },
        )
        return self

    def __enter__(self) -> McapLog:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the sink ------------------------------------------------------------------------------------------
    def emit(self, event: MissionEvent) -> None:
        """Write one mission event, and what it changes on the other topics."""
        if self._writer is None:
            return
        t = event.time_s
        self._write("/mission/events", t, event.to_dict())
        f = event.fields
        if event.kind == "uav" and event.uav is not None:
            self._uav(event)
        else:
            self._write(
                "/log",
                t,
                {
                    "timestamp": _stamp(t),
                    "level": _LEVELS.get(event.kind, 2),
                    "message": event.line().strip(),
                    "name": "mission-control",
                    "file": "",
                    "line": 0,
                },
            )
        if event.task_id is not None and event.kind in ("assigned", "completed", "failed", "lost"):
            state = {"assigned": "running", "completed": "done"}.get(event.kind, "todo")
            self._write(
                "/wall", t, {"deletions": [], "entities": [self._task_entity(t, event.task_id, state)]}
            )
        if event.kind in ("clearance", "lost") and event.uav is not None:
            self._airspace(t, event.uav, f.get("volumes", []))

    def _uav(self, event: MissionEvent) -> None:
        t, f, name = event.time_s, event.fields, str(event.uav)
        p = f.get("position_m")
        if p is not None:
            pose = {"position": _vec(p), "orientation": _yaw(0.0)}
            self._write(
                f"/uav/{name}/pose", t, {"timestamp": _stamp(t), "frame_id": WORLD_FRAME, "pose": pose}
            )
            last_tf = self._tf_s.get(name)
            if last_tf is None or t - last_tf >= TF_PERIOD_S:
                self._tf_s[name] = t
                self._write(
                    "/tf",
                    t,
                    {
                        "timestamp": _stamp(t),
                        "parent_frame_id": WORLD_FRAME,
                        "child_frame_id": name,
                        "translation": _vec(p),
                        "rotation": _yaw(0.0),
                    },
                )
        vols = f.get("volumes", [])
        state = (f.get("state", ""), event.task_id, f.get("status", "ok"), len(vols))
        last = self._states.get(name)
        if last is None or last[0] != state or t - last[1] >= STATE_PERIOD_S:
            self._states[name] = (state, t)
            self._write(
                f"/uav/{name}/state",
                t,
                {
                    "timestamp": _stamp(t),
                    "uav": name,
                    "state": state[0],
                    "task_id": event.task_id,
                    "battery": f.get("battery"),
                    "status": state[2],
                    "volumes": state[3],
                },
            )
        self._airspace(t, name, vols)

    def _airspace(self, t: float, uav: str, volumes: Any) -> None:
        if self._volumes.get(uav) == volumes:
            return
        self._volumes[uav] = volumes
        self._write(
            "/airspace",
            t,
            {
                "deletions": [],
                "entities": [_entity(t, f"airspace/{uav}", cubes=[volume_cube(v) for v in volumes])],
            },
        )

    def _task_entity(self, t: float, task_id: str, state: str) -> dict[str, Any]:
        task = self._tasks[task_id]
        if isinstance(task, BrickTask):
            cube = {
                "pose": {"position": _vec(task.position_m), "orientation": _yaw(task.yaw_rad)},
                "size": _vec(task.size_m),
                "color": _rgba(COLOURS[state]),
            }
            return _entity(t, f"task/{task_id}", cubes=[cube])
        colour = COLOURS["adhesion_done"] if state == "done" else COLOURS[state]
        line = {
            "type": 0,
            "pose": {"position": _vec((0, 0, 0)), "orientation": _yaw(0.0)},
            "thickness": 0.03,
            "scale_invariant": False,
            "points": [_vec(task.start_m), _vec(task.end_m)],
            "color": _rgba(colour),
            "colors": [],
            "indices": [],
        }
        return _entity(t, f"task/{task_id}", lines=[line])

    # -- the end -------------------------------------------------------------------------------------------
    def finish(self, report: MissionReport, extra: Mapping[str, Any] | None = None) -> None:
        """Write the flown paths and the report (what ``masonry replay`` prints and draws)."""
        t = max(self._last_s, report.sim_time_s + (report.resumed_from_s or 0.0))
        lines = []
        for name, path in sorted(report.paths_m.items()):
            pts = [_vec(p) for p in path[:: max(1, len(path) // 2000)]]
            lines.append(
                _entity(
                    t,
                    f"path/{name}",
                    lines=[
                        {
                            "type": 0,
                            "pose": {"position": _vec((0, 0, 0)), "orientation": _yaw(0.0)},
                            "thickness": 0.02,
                            "scale_invariant": False,
                            "points": pts,
                            "color": _rgba((0.1, 0.1, 0.1, 0.8)),
                            "colors": [],
                            "indices": [],
                        }
                    ],
                )
            )
        self._write("/paths", t, {"deletions": [], "entities": lines})
        self._write("/mission/report", t, {"report": report_to_record(report), "extra": dict(extra or {})})

    def close(self) -> None:
        """Finish the file (its summary and index); the log is readable once this returns."""
        if self._writer is not None:
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._writer = None
        if self._file is not None:
            self._file.close()
            self._file = None

    def _write(self, topic: str, time_s: float, message: Mapping[str, Any]) -> None:
        assert self._writer is not None
        channel = self._channels.get(topic)
        if channel is None:
            schema_name = TOPICS.get(topic) or TOPICS["/uav/NAME/" + topic.rsplit("/", 1)[-1]]
            schema = self._schemas.get(schema_name)
            if schema is None:
                body = FOXGLOVE.get(schema_name) or MASONRY[schema_name]
                schema = self._writer.register_schema(schema_name, "jsonschema", json.dumps(body).encode())
                self._schemas[schema_name] = schema
            channel = self._writer.register_channel(topic, "json", schema)
            self._channels[topic] = channel
        self._last_s = max(self._last_s, time_s)
        ns = _ns(time_s)
        self._writer.add_message(
            channel, ns, json.dumps(message, allow_nan=False).encode(), ns, self.messages
        )
        self.messages += 1


@dataclass(frozen=True)
class RecordedMission:
    """What a log holds for ``masonry replay``."""

    path: Path
    blueprint_yaml: str
    title: str
    command: str
    events: tuple[MissionEvent, ...]
    report: MissionReport | None  # None: the log ends before the mission did
    extra: Mapping[str, Any] = field(default_factory=dict)
    done: tuple[str, ...] = ()  # tasks done before the log began (a resumed mission)


def read_log(path: str | Path) -> RecordedMission:
    """Read a mission log that :class:`McapLog` wrote.

    Raises:
        InputError: the file cannot be read, is not MCAP, is cut short, or is not a masonry mission log; the
            message names the file and what is wrong.
    """
    p = Path(path)
    blueprint: dict[str, Any] | None = None
    events: list[MissionEvent] = []
    report: MissionReport | None = None
    extra: dict[str, Any] = {}
    try:
        with open(p, "rb") as f:
            reader = make_reader(f)
            for _schema, channel, message in reader.iter_messages(
                topics=["/mission/blueprint", "/mission/events", "/mission/report"], log_time_order=True
            ):
                data = json.loads(message.data)
                if channel.topic == "/mission/events":
                    events.append(MissionEvent.from_dict(data))
                elif channel.topic == "/mission/blueprint":
                    blueprint = data
                else:
                    report = report_from_record(data["report"])
                    extra = dict(data.get("extra") or {})
    except OSError as exc:
        raise InputError(f"{p}: cannot read it: {exc.strerror or exc}") from None
    except (McapError, EOFError) as exc:
        raise InputError(f"{p}: not a readable MCAP file ({exc or type(exc).__name__})") from None
    except (ValueError, KeyError, TypeError, MasonryError) as exc:
        # json.JSONDecodeError is a ValueError; a malformed record raises MissionError (a MasonryError)
        raise InputError(f"{p}: a malformed masonry record: {exc}") from None
    except Exception as exc:  # the mcap reader raises bare struct/zstd errors on a cut or garbled file
        raise InputError(f"{p}: not a readable MCAP file ({type(exc).__name__}: {exc})") from None
    if blueprint is None or not isinstance(blueprint.get("yaml"), str):
        raise InputError(f"{p}: not a masonry mission log (no /mission/blueprint message)")
    return RecordedMission(
        p,
        blueprint["yaml"],
        str(blueprint.get("title") or ""),
        str(blueprint.get("command") or ""),
        tuple(events),
        report,
        extra,
        tuple(str(t) for t in blueprint.get("done") or ()),
    )


__all__ = ["COLOURS", "TOPICS", "McapLog", "RecordedMission", "read_log", "volume_cube"]
