"""The mission log: an MCAP file Foxglove opens with no plugin, and that ``masonry replay`` reads back.

:class:`McapLog` is an :class:`~masonry.mission.events.EventSink`: mission control hands it every event and it
writes the messages of :class:`~masonry.observe.scene.MissionScene` (topics and schemas in docs/logging.md): the
events themselves, each UAV's pose (``foxglove.PoseInFrame`` and ``/tf``), its state and battery, the wall and
the reserved airspace as ``foxglove.SceneUpdate``, a ``foxglove.Log`` line per event, and at the end the mission's
report, losslessly (:mod:`masonry.mission.report_codec`). Foxglove's topics are the Foxglove SDK's own messages
(protobuf, with the schema the SDK ships); masonry's own are JSON with JSON schemas. Log time is mission time
(nanoseconds from mission time 0).

:func:`read_log` reads one back (:class:`RecordedMission`): the blueprint, the events, the report, from masonry's
own JSON topics, which logs written before Foxglove's topics moved to the SDK (JSON there too) share; the
reservation table's changes (``/mission/reservations``) come back as ``reservation`` and ``hold`` events among the others. The SQLite
journal stays the source of truth for ``--resume``; the log is for people and tools.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from masonry.errors import InputError, MasonryError
from masonry.mission.events import MissionEvent
from masonry.mission.report import MissionReport
from masonry.mission.report_codec import report_from_record
from masonry.observe.scene import (
    COLOURS,
    TOPICS,
    WORLD_FRAME,
    Message,
    MissionScene,
    channel_schema,
    encoded,
    ns,
    volume_cube,
)
from masonry.planner.tasks import Plan

#: The MCAP profile (none of the ROS ones: protobuf and JSON messages with their schemas).
PROFILE = ""

#: The topics :func:`read_log` reads: masonry's own (``/mission/reservations``: the reservation table's changes,
#: ``reservation`` and ``hold`` events, only with ``--airspace table``; a log without them reads as before).
_READ = ("/mission/blueprint", "/mission/events", "/mission/reservations", "/mission/report")


class McapLog(MissionScene):
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
        super().__init__(plan, blueprint_yaml, title=title, command=command)
        self.path = Path(path)
        self._file: Any = None
        self._writer: Writer | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}

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
        self.write_opening()
        return self

    def __enter__(self) -> McapLog:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def emit(self, event: MissionEvent) -> None:
        """Write one mission event, and what it changes on the other topics."""
        if self._writer is not None:
            super().emit(event)

    def finish(self, report: MissionReport, extra: Mapping[str, Any] | None = None) -> None:
        """Write the flown paths and the report (what ``masonry replay`` prints and draws)."""
        if self._writer is not None:
            super().finish(report, extra)

    def close(self) -> None:
        """Finish the file (its summary and index); the log is readable once this returns."""
        if self._writer is not None:
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._writer = None
        if self._file is not None:
            self._file.close()
            self._file = None

    def write(self, topic: str, time_s: float, message: Message) -> None:
        """One message into the file: a Foxglove message in the SDK's encoding, a dict as JSON."""
        assert self._writer is not None
        channel = self._channels.get(topic)
        if channel is None:
            name, schema_encoding, data, encoding = channel_schema(topic)
            schema = self._schemas.get(name)
            if schema is None:
                schema = self._schemas[name] = self._writer.register_schema(name, schema_encoding, data)
            channel = self._channels[topic] = self._writer.register_channel(topic, encoding, schema)
        t = ns(time_s)
        self._writer.add_message(channel, t, encoded(message), t, self.messages)


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
            for _schema, channel, message in reader.iter_messages(topics=[*_READ], log_time_order=True):
                data = json.loads(message.data)
                if channel.topic in ("/mission/events", "/mission/reservations"):
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


def iter_channel_messages(path: str | Path) -> Iterator[tuple[str, tuple[str, str, bytes, str], int, bytes]]:
    """Every message of a log in log time order, as ``(topic, (schema name, schema encoding, schema data, message
    encoding), log time ns, data)``: what ``masonry replay --foxglove`` serves, as it was recorded.

    Raises:
        InputError: the file cannot be read or is not MCAP.
    """
    p = Path(path)
    try:
        with open(p, "rb") as f:
            for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
                desc = (
                    (schema.name, schema.encoding, bytes(schema.data), channel.message_encoding)
                    if schema is not None
                    else ("", "", b"", channel.message_encoding)
                )
                yield channel.topic, desc, message.log_time, bytes(message.data)
    except OSError as exc:
        raise InputError(f"{p}: cannot read it: {exc.strerror or exc}") from None
    except Exception as exc:  # the mcap reader raises its own, struct and zstd errors on a bad file
        raise InputError(f"{p}: not a readable MCAP file ({type(exc).__name__}: {exc})") from None


__all__ = [
    "COLOURS",
    "TOPICS",
    "WORLD_FRAME",
    "McapLog",
    "RecordedMission",
    "iter_channel_messages",
    "read_log",
    "volume_cube",
]
