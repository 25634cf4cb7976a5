"""Mission events: what mission control saw happen, as values, for a log or a live view (pure: no I/O).

Mission control hands each :class:`MissionEvent` to an injected :class:`EventSink` (``MissionControl(...,
events_sink=...)``): an MCAP log (``masonry.observe.mcap_log``), the live web view, or a list in a test. The sink
only watches: what it does never changes what mission control decides.

Kinds (``MissionEvent.kind``) and their fields:

- ``start``: the mission starts dispatching (``fleet``: names).
- ``assigned``: ``task_id`` to ``uav``, ``attempt``.
- ``completed``: ``task_id`` by ``uav``, ``placement_error_m`` and ``coverage`` as the UAV measured them, and
  ``as_built`` (a brick's pose as its camera saw it, :class:`~masonry.perception.types.AsBuiltPose`'s dict).
- ``placement``: a brick placed farther from its design than the blueprint's ``placement_tolerance_m``:
  ``deviation_m``, ``tolerance_m``, ``action`` (``continue`` or ``hold``) and ``line`` (:mod:`masonry.mission.as_built`).
- ``failed``: ``task_id`` by ``uav``, ``reason``.
- ``clearance``: a flight to ``site_m`` ``granted`` (true) or held (false, ``hold_m`` where to wait).
- ``uav``: a UAV's ``state``, ``position_m``, ``task_id``, ``battery`` (0..1, None: not reported) and the airspace
  ``volumes`` it holds (each ``[ax, ay, bx, by, z0, z1, slack]``), from its heartbeats and progress reports (the
  simulator adds samples of its world at :data:`SAMPLE_PERIOD_S`).
- ``lost``: ``uav`` taken out of the mission, ``status`` (lost or out of service).
- ``stall``: the watchdog stopped the mission, ``line`` says who waits for whom.
- ``end``: the mission is over, ``completed``.
- ``operator``: an operator's command (``command``, ``accepted``, ``reason``).
- ``wind``: the wind limit grounded or freed UAVs: ``speed_mps`` (the reading, None: none fresh) and
  ``grounded`` (the UAVs given no task for it: empty once the wind has dropped).
- ``glue``: with an adhesive's open time, a bead (``task_id``) sprayed, or known from the journal after a resume:
  its ``brick``, ``sprayed_s`` and ``open_until_s`` (when it expires unless the brick is on it;
  :mod:`masonry.mission.glue`).
- ``spare``: a spare stands in for the brick of ``task_id`` (``spare``, ``brick``, ``reason``), or none is left
  and the brick waits for a person (``spare`` None; :mod:`masonry.mission.spares`).
- ``reservation``: with ``--airspace table``, a reservation of ``uav`` (for ``task_id``) ``made``, ``moved`` or
  ``released`` (``change``), its ``id``, ``purpose``, ``t0_s``, ``t1_s`` (None: open-ended), ``volume``, ``space``
  and, moved, the window it ``was`` (:mod:`masonry.mission.table_events`).
- ``hold``: with ``--airspace table``, a hold on the table's take-offs ``made`` or ``released`` (``change``), its
  ``id``, ``cause`` (``operator`` or ``wind``), ``uavs`` (empty: every UAV; ``uav`` the one it holds, None: not
  one), ``t0_s`` and ``t1_s`` (None: until lifted) (:mod:`masonry.mission.table_events`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from masonry.errors import MissionError

#: How often (mission seconds) a simulated mission samples every UAV's pose and battery for its sink.
SAMPLE_PERIOD_S = 0.5

#: Every kind of event (see the module docstring).
KINDS = (
    "start",
    "assigned",
    "completed",
    "failed",
    "clearance",
    "uav",
    "lost",
    "stall",
    "end",
    "operator",
    "wind",
    "glue",
    "spare",
    "placement",
    "reservation",
    "hold",
)


@dataclass(frozen=True)
class MissionEvent:
    """One thing mission control saw happen, at mission time ``time_s``.

    Args:
        time_s: mission time, seconds.
        kind: one of :data:`KINDS`.
        uav: the UAV it concerns (None: the mission).
        task_id: the task it concerns (None: none).
        fields: the rest, JSON values only (see the module docstring per kind).
    """

    time_s: float
    kind: str
    uav: str | None = None
    task_id: str | None = None
    fields: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The event as a JSON object (the ``/mission/events`` message of the log)."""
        return {
            "time_s": self.time_s,
            "kind": self.kind,
            "uav": self.uav,
            "task_id": self.task_id,
            "fields": dict(self.fields),
        }

    @classmethod
    def from_dict(cls, data: Any) -> MissionEvent:
        """The event back from :meth:`to_dict`'s object.

        Raises:
            MissionError: not such an object (a field missing or of the wrong type, an unknown kind).
        """
        if not isinstance(data, Mapping):
            raise MissionError(f"a mission event must be an object, got {type(data).__name__}")
        t, kind = data.get("time_s"), data.get("kind")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise MissionError(f"a mission event needs a finite time_s, got {t!r}")
        if kind not in KINDS:
            raise MissionError(f"unknown mission event kind {kind!r}")
        uav, task_id, fields = data.get("uav"), data.get("task_id"), data.get("fields", {})
        if uav is not None and not isinstance(uav, str):
            raise MissionError(f"a mission event's uav must be a string, got {uav!r}")
        if task_id is not None and not isinstance(task_id, str):
            raise MissionError(f"a mission event's task_id must be a string, got {task_id!r}")
        if not isinstance(fields, Mapping):
            raise MissionError(f"a mission event's fields must be an object, got {fields!r}")
        return cls(float(t), str(kind), uav, task_id, dict(fields))

    def line(self) -> str:
        """One human line (the ``/log`` topic, ``masonry replay --at``)."""
        f = self.fields
        who = f" {self.uav}" if self.uav else ""
        what = f" {self.task_id}" if self.task_id else ""
        extra = ""
        if self.kind == "failed":
            extra = f": {f.get('reason', 'failed')}"
        elif self.kind == "clearance":
            extra = " granted" if f.get("granted") else " held"
        elif self.kind in ("stall", "operator", "placement"):
            extra = f": {f.get('line') or f.get('reason') or f.get('command', '')}"
        elif self.kind == "end":
            extra = ": completed" if f.get("completed") else ": NOT completed"
        elif self.kind == "uav":
            extra = f" {f.get('state', '')}"
        elif self.kind == "wind":
            speed = f.get("speed_mps")
            grounded = f.get("grounded") or []
            extra = f" {speed:.1f} m/s" if isinstance(speed, (int, float)) else ""
            extra += f": no tasks for {', '.join(grounded)}" if grounded else ": every UAV within its limit"
        elif self.kind == "spare":
            spare = f.get("spare")
            extra = f": {f'spare {spare} for' if spare is not None else 'waiting for a person:'} brick {f.get('brick')}"
        elif self.kind == "reservation":
            t1 = f.get("t1_s")
            end = f"{t1:.1f} s" if isinstance(t1, (int, float)) else "open-ended"
            extra = f": {f.get('change')} {f.get('purpose')} from {f.get('t0_s', 0.0):.1f} s to {end}"
        elif self.kind == "hold":
            t1 = f.get("t1_s")
            end = f"{t1:.1f} s" if isinstance(t1, (int, float)) else "until lifted"
            held = ", ".join(f.get("uavs") or []) or "every UAV"
            extra = f": {f.get('change')} {f.get('cause')} on {held} from {f.get('t0_s', 0.0):.1f} s to {end}"
        elif self.kind == "glue":
            until = f.get("open_until_s")
            extra = f" under {f.get('brick')}" + (
                f", open until {until:.1f} s" if isinstance(until, (int, float)) else ""
            )
        return f"{self.time_s:8.1f} s  {self.kind}{who}{what}{extra}"


class EventSink(Protocol):
    """Where mission events go (a log, a live view); it only watches."""

    def emit(self, event: MissionEvent) -> None:
        """Take one event (called in mission-time order, from mission control's loop)."""


class EventList:
    """An :class:`EventSink` that keeps every event in :attr:`events` (tests, notebooks)."""

    def __init__(self) -> None:
        self.events: list[MissionEvent] = []

    def emit(self, event: MissionEvent) -> None:
        self.events.append(event)


class EventFanout:
    """An :class:`EventSink` that hands every event to each of ``sinks`` in turn (a log and a live view)."""

    def __init__(self, *sinks: EventSink) -> None:
        self.sinks = tuple(sinks)

    def emit(self, event: MissionEvent) -> None:
        for s in self.sinks:
            s.emit(event)


def volume_list(volumes: Any) -> list[list[float]]:
    """Airspace volumes (:class:`masonry.mission.volumes.Volume`) as ``[ax, ay, bx, by, z0, z1, slack]`` rows."""
    return [[v.a[0], v.a[1], v.b[0], v.b[1], v.z0_m, v.z1_m, v.slack_m] for v in volumes]


__all__ = [
    "KINDS",
    "SAMPLE_PERIOD_S",
    "EventFanout",
    "EventList",
    "EventSink",
    "MissionEvent",
    "volume_list",
]
