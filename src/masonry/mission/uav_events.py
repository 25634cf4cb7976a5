"""A UAV's own events, for its log (``masonry fly --mission ... --log FILE.mcap``): what its handler and machine
did, as :class:`~masonry.mission.events.MissionEvent` values for an :class:`~masonry.mission.events.EventSink`.

:class:`UavWatch` is ticked by the handler's loop (``masonry.mission.remote``): every
:data:`~masonry.mission.events.SAMPLE_PERIOD_S` it samples the UAV's state, task, position and battery (from its
autopilot's telemetry), and it reports each task the machine took (``assigned``) and how it ended (``completed``
or ``failed``), from the handler's executions. It only watches.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from masonry.mission.events import SAMPLE_PERIOD_S, EventSink, MissionEvent

__all__ = ["UavWatch"]


class UavWatch:
    """Turns one UAV handler's life into events.

    Args:
        handler: the :class:`~masonry.mission.handler.UavHandler`.
        model: its state machine (``state``).
        telemetry: returns the autopilot's :class:`~masonry.ports.Telemetry`.
        sink: where the events go.
    """

    def __init__(self, handler: Any, model: Any, telemetry: Callable[[], Any], sink: EventSink) -> None:
        self.handler = handler
        self.model = model
        self.telemetry = telemetry
        self.sink = sink
        self._next_s: float | None = None
        self._seen = 0  # executions reported as assigned
        self._open: list[Any] = []  # executions assigned, not yet ended

    def tick(self, now_s: float, *, sample: bool = False) -> None:
        """Report what changed since the last tick, and a sample when one is due (or ``sample``: the last)."""
        name = self.handler.name
        execs = self.handler.executions
        while self._seen < len(execs):
            e = execs[self._seen]
            self._seen += 1
            self._open.append(e)
            self.sink.emit(MissionEvent(e.start_s, "assigned", name, e.task_id, {"attempt": e.attempt}))
        for e in [e for e in self._open if e.end_s is not None]:
            self._open.remove(e)
            kind = "completed" if e.status == "done" else "failed"
            fields: dict[str, Any] = {"attempt": e.attempt}
            if kind == "failed":
                fields["reason"] = e.status
            self.sink.emit(MissionEvent(e.end_s, kind, name, e.task_id, fields))
        if not sample and self._next_s is not None and now_s < self._next_s - 1e-9:
            return
        self._next_s = (
            now_s + SAMPLE_PERIOD_S if self._next_s is None else max(self._next_s + SAMPLE_PERIOD_S, now_s)
        )
        tel = self.telemetry()
        cur = self._open[-1].task_id if self._open else None
        self.sink.emit(
            MissionEvent(
                now_s,
                "uav",
                name,
                cur,
                {
                    "state": str(getattr(self.model, "state", "")),
                    "position_m": [float(v) for v in tel.position_m],
                    "battery": float(tel.battery_fraction),
                    "status": "ok",
                    "volumes": [],
                },
            )
        )
