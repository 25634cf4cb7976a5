"""Mission control's way out: messages over the transport and events to the sink, counted in :class:`MissionEvents`.

The thin I/O part of mission control (issue 27 §2): :class:`Outbox` encodes and sends, hands
:class:`~masonry.mission.events.MissionEvent` values to the sink (a log, a live view), and keeps the counters the
report and the benchmarks read.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from masonry.mission.events import EventSink, MissionEvent
from masonry.mission.message_types import Message
from masonry.mission.messages import encode
from masonry.mission.transport import Transport

__all__ = ["MissionEvents", "Outbox"]


@dataclass
class MissionEvents:
    """Counters of what crossed the transport (for the report and the benchmark)."""

    received: int = 0
    rejected: int = 0
    sent: int = 0
    progress: int = 0
    errors: list[str] = field(default_factory=list)
    #: results not acted on, by reason: "not-assigned", "wrong-attempt", "too-short"
    ignored: dict[str, int] = field(default_factory=dict)
    #: UAVs declared lost and heard again with no task (back in the mission)
    rejoined: int = 0


class Outbox:
    """Sends over ``transport`` and tells ``sink`` (None: no one), counting into ``events``."""

    def __init__(self, transport: Transport, sink: EventSink | None, events: MissionEvents) -> None:
        self.transport = transport
        self.sink = sink
        self.events = events

    def send(self, to: str, msg: Message) -> None:
        """Send ``msg`` to the endpoint ``to``."""
        self.transport.send(to, encode(msg))
        self.events.sent += 1

    def broadcast(self, msg: Message, to: Iterable[str]) -> None:
        """Send ``msg`` to every endpoint of ``to`` (encoded once)."""
        data = encode(msg)
        for name in to:
            self.transport.send(name, data)
            self.events.sent += 1

    def emit(
        self, now_s: float, kind: str, uav: str | None = None, task_id: str | None = None, **fields: object
    ) -> None:
        """Hand an event to the sink, if any (it only watches)."""
        if self.sink is not None:
            self.sink.emit(MissionEvent(now_s, kind, uav, task_id, dict(fields)))

    def ignored(self, reason: str) -> None:
        """Count a result not acted on, by ``reason``."""
        self.events.ignored[reason] = self.events.ignored.get(reason, 0) + 1
