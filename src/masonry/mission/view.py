"""The mission as it stands, folded from its events (pure): for the live web view and ``masonry replay --at``.

:class:`MissionView` is an :class:`~masonry.mission.events.EventSink`: hand it the events of a running mission
(it is thread-safe: the mission's loop emits, a web server reads :meth:`MissionView.snapshot`) or those of a log
up to a time (:func:`view_at`). :func:`wall_layout` is the geometry the page draws: every task's brick or
adhesion segment and every UAV's home.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from masonry.blueprint import UavSpec
from masonry.mission.events import MissionEvent
from masonry.mission.table_view import TableView
from masonry.planner.tasks import BrickTask, Plan

#: Task states in the view.
TASK_STATES = ("todo", "running", "done", "stuck")

#: How many of the latest event lines the view keeps (the page's log, ``--at``).
RECENT_LINES = 12


def wall_layout(plan: Plan, fleet: Sequence[UavSpec], name: str = "") -> dict[str, Any]:
    """The geometry of the mission as JSON: bricks (centre, size, yaw), adhesion segments, UAV homes."""
    tasks: list[dict[str, Any]] = []
    for t in plan.tasks:
        if isinstance(t, BrickTask):
            tasks.append(
                {
                    "id": t.id,
                    "kind": "brick",
                    "done": t.done,
                    "position_m": list(t.position_m),
                    "size_m": list(t.size_m),
                    "yaw_rad": t.yaw_rad,
                }
            )
        else:
            tasks.append(
                {
                    "id": t.id,
                    "kind": "adhesion",
                    "done": t.done,
                    "start_m": list(t.start_m),
                    "end_m": list(t.end_m),
                }
            )
    return {
        "name": name,
        "tasks": tasks,
        "uavs": [{"name": u.name, "role": u.role, "home_m": list(u.home_m)} for u in fleet],
    }


@dataclass(frozen=True)
class OpenBead:
    """A bead sprayed and waiting for its brick (a ``glue`` event)."""

    brick: str
    sprayed_s: float
    open_until_s: float  # it expires then unless its brick is on it


class MissionView:
    """The state of a mission after the events it has been given.

    Args:
        task_ids: the mission's tasks (all ``todo`` at first); ``done`` ones already done (a resumed mission).
        done: tasks done before the first event.
    """

    def __init__(self, task_ids: Iterable[str] = (), done: Iterable[str] = ()) -> None:
        self._lock = threading.Lock()
        self.time_s = 0.0
        self.tasks: dict[str, str] = dict.fromkeys(task_ids, "todo")
        for tid in done:
            self.tasks[tid] = "done"
        self.uavs: dict[str, dict[str, Any]] = {}
        self.bars: list[dict[str, Any]] = []  # one per attempt: uav, task_id, attempt, start_s, end_s, status
        self._open: dict[str, int] = {}  # task id -> index in bars of its running attempt
        self.stall: str | None = None
        self.completed: bool | None = None  # None: still running
        self.operator: list[str] = []
        self.recent: deque[str] = deque(maxlen=RECENT_LINES)
        self.events = 0
        #: beads waiting for their brick (with an adhesive's open time; ``glue`` events)
        self.glue: dict[str, OpenBead] = {}
        self._glued = False  # a ``glue`` event was seen (the snapshot has ``glue`` only then)
        #: brick task -> its as-built ``deviation_m`` and the ``tolerance_m`` it is judged by (issue 30)
        self.as_built: dict[str, dict[str, float]] = {}
        self.beyond: dict[str, float] = {}  # brick tasks placed beyond the tolerance -> deviation (m)
        #: the reservation table (``reservation`` events: ``--airspace table``; mission/table_view.py)
        self.table = TableView()

    def emit(self, event: MissionEvent) -> None:
        """Fold one event in."""
        with self._lock:
            if event.kind in ("reservation", "hold"):  # the table's own (not among the latest events' lines)
                self.events += 1
                self.time_s = max(self.time_s, event.time_s)
                self.table.fold(event)
            else:
                self._apply(event)

    def _apply(self, e: MissionEvent) -> None:
        self.events += 1
        self.time_s = max(self.time_s, e.time_s)
        f = e.fields
        if e.kind != "uav":
            self.recent.append(e.line())
        self._fold_glue(e)
        self._fold_as_built(e)
        if e.kind == "uav" and e.uav is not None:
            u = self.uavs.setdefault(e.uav, {"name": e.uav})
            u.update(
                state=f.get("state", ""),
                task_id=e.task_id,
                status=f.get("status", "ok"),
                volumes=f.get("volumes", []),
            )
            if f.get("position_m") is not None:
                u["position_m"] = f["position_m"]
            if f.get("battery") is not None:
                u["battery"] = f["battery"]
        elif e.kind == "assigned" and e.task_id is not None:
            self.tasks[e.task_id] = "running"
            self._open[e.task_id] = len(self.bars)
            self.bars.append(
                {
                    "uav": e.uav,
                    "task_id": e.task_id,
                    "attempt": f.get("attempt", 0),
                    "start_s": e.time_s,
                    "end_s": None,
                    "status": "running",
                }
            )
            self.uavs.setdefault(e.uav or "", {"name": e.uav})["task_id"] = e.task_id
        elif e.kind in ("completed", "failed") and e.task_id is not None:
            self.tasks[e.task_id] = "done" if e.kind == "completed" else "todo"
            self._close(e.task_id, e.time_s, "done" if e.kind == "completed" else "failed")
        elif e.kind == "clearance" and e.uav is not None:
            self.uavs.setdefault(e.uav, {"name": e.uav})["volumes"] = f.get("volumes", [])
        elif e.kind == "lost" and e.uav is not None:
            u = self.uavs.setdefault(e.uav, {"name": e.uav})
            u.update(status=f.get("status", "lost"), volumes=[], task_id=None)
            if e.task_id is not None:
                self.tasks[e.task_id] = "todo"
                self._close(e.task_id, e.time_s, "failed")
        elif e.kind == "stall":
            self.stall = str(f.get("line", "stalled"))
        elif e.kind == "end":
            self.completed = bool(f.get("completed"))
            for tid, state in self.tasks.items():
                if state != "done":
                    self.tasks[tid] = "stuck"
        elif e.kind == "operator":
            self.operator.append(e.line().strip())

    def _fold_as_built(self, e: MissionEvent) -> None:
        """A brick's as-built pose (a ``completed`` event's), a brick placed beyond the tolerance (``placement``)."""
        f = e.fields
        if e.task_id is None:
            return
        pose = f.get("as_built")
        if e.kind == "completed" and isinstance(pose, Mapping):
            self.as_built[e.task_id] = {
                "deviation_m": float(pose.get("deviation_m", 0.0)),
                "tolerance_m": float(f.get("tolerance_m", 0.0)),
            }
        elif e.kind == "placement":
            self.beyond[e.task_id] = float(f.get("deviation_m", 0.0))

    def _fold_glue(self, e: MissionEvent) -> None:
        """A bead sprayed (``glue``), done again or failed (expired: it is told again), a brick placed on glue."""
        if e.kind not in ("completed", "failed", "glue") or e.task_id is None:
            return
        if e.kind == "glue":
            self._glued = True
            self.glue[str(e.task_id)] = OpenBead(
                str(e.fields.get("brick")),
                float(e.fields.get("sprayed_s", e.time_s)),
                float(e.fields.get("open_until_s", math.inf)),
            )
            return
        self.glue.pop(str(e.task_id), None)
        if e.kind == "completed":  # a brick on its glue: the glue no longer ages in the open
            for bead in [b for b, g in self.glue.items() if g.brick == e.task_id]:
                del self.glue[bead]

    def _close(self, task_id: str, time_s: float, status: str) -> None:
        i = self._open.pop(task_id, None)
        if i is not None:
            self.bars[i].update(end_s=time_s, status=status)

    def open_glue(self) -> list[dict[str, object]]:
        """The beads waiting for their brick now: ``bead``, ``brick``, ``age_s``, ``left_s`` (of the open time;
        below 0: expired, it is sprayed again), the first to expire first."""
        order = sorted(self.glue.items(), key=lambda bg: (bg[1].open_until_s, bg[0]))
        return [
            {
                "bead": bead,
                "brick": g.brick,
                "age_s": round(self.time_s - g.sprayed_s, 1),
                "left_s": round(g.open_until_s - self.time_s, 1),
            }
            for bead, g in order
        ]

    def counts(self) -> dict[str, int]:
        """Tasks per state (:data:`TASK_STATES`)."""
        out = dict.fromkeys(TASK_STATES, 0)
        for s in self.tasks.values():
            out[s] = out.get(s, 0) + 1
        return out

    def snapshot(self) -> dict[str, Any]:
        """The whole view as JSON values (what the page draws)."""
        with self._lock:
            glue = {"glue": self.open_glue()} if self._glued else {}
            seen = {"as_built": {k: dict(v) for k, v in self.as_built.items()}} if self.as_built else {}
            table = (
                {"reservations": self.table.rows(), "holds": self.table.hold_rows()}
                if self.table.seen
                else {}
            )
            return {
                **glue,
                **seen,
                **table,
                "time_s": self.time_s,
                "counts": self.counts(),
                "tasks": dict(self.tasks),
                "uavs": [dict(u) for _, u in sorted(self.uavs.items())],
                "bars": [dict(b) for b in self.bars],
                "stall": self.stall,
                "completed": self.completed,
                "operator": list(self.operator),
                "recent": list(self.recent),
            }

    def lines(self) -> list[str]:
        """The view as text (``masonry replay --at``)."""
        with self._lock:
            c = self.counts()
            state = (
                "running" if self.completed is None else ("completed" if self.completed else "NOT completed")
            )
            out = [
                f"at {self.time_s:.1f} s: mission {state}; tasks: "
                + ", ".join(f"{k} {v}" for k, v in c.items())
            ]
            for name, u in sorted(self.uavs.items()):
                p = u.get("position_m")
                where = "?" if p is None else f"({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f})"
                battery = u.get("battery")
                out.append(
                    f"  {name:<12} {u.get('state') or '-':<14} task {u.get('task_id') or '-':<6} at {where}"
                    + ("" if battery is None else f"  battery {battery:.0%}")
                    + f"  volumes {len(u.get('volumes') or [])}  {u.get('status', 'ok')}"
                )
            running = sorted(t for t, s in self.tasks.items() if s == "running")
            if running:
                out.append(f"  running: {', '.join(running)}")
            if self.glue:
                out.append(
                    "  glue waiting for its brick: "
                    + ", ".join(
                        f"{bead} under {g.brick} {self.time_s - g.sprayed_s:.0f} s old, "
                        f"{g.open_until_s - self.time_s:.0f} s left"
                        for bead, g in sorted(self.glue.items(), key=lambda bg: (bg[1].open_until_s, bg[0]))
                    )
                )
            if self.beyond:
                out.append(
                    "  placed beyond the tolerance: "
                    + ", ".join(f"{t} ({d * 100:.1f} cm)" for t, d in self.beyond.items())
                )
            if self.table.seen:
                out.extend(self.table.lines(self.time_s))
            if self.stall:
                out.append(f"  {self.stall}")
            if self.recent:
                out.append("  latest events:")
                out.extend(f"  {line}" for line in self.recent)
            return out


def view_at(
    events: Iterable[MissionEvent], time_s: float, task_ids: Iterable[str] = (), done: Iterable[str] = ()
) -> MissionView:
    """The view after every event of ``events`` at or before ``time_s`` (``done``: tasks done before them)."""
    view = MissionView(task_ids, done)
    for e in events:
        if e.time_s > time_s:
            break
        view.emit(e)
    view.time_s = max(view.time_s, time_s) if view.events else time_s
    return view


__all__ = ["TASK_STATES", "MissionView", "OpenBead", "view_at", "wall_layout"]
