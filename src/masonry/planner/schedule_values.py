"""The offline schedule's values (what ``masonry schedule`` writes and ``--policy schedule`` follows) and its file.

Pure: :meth:`OfflineSchedule.to_dict` and :func:`schedule_from_dict` convert to and from the JSON document
(docs/schedule.md lists its fields); reading the file is the caller's. Importing this module needs no ortools.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from masonry.errors import InputError

SCHEDULE_FORMAT = "masonry-schedule"
SCHEDULE_VERSION = 1
STATUSES: tuple[str, ...] = ("optimal", "feasible")
DECOMPOSITIONS: tuple[str, ...] = ("none", "course")


@dataclass(frozen=True)
class ScheduledTask:
    """One task in a UAV's planned sequence (seconds from the mission's start)."""

    id: str
    start_s: float
    end_s: float
    #: ``site`` reservation: when its UAV is planned at its site (None: ``task``)
    site_start_s: float | None = None
    site_end_s: float | None = None


@dataclass(frozen=True)
class UavSchedule:
    """A UAV's planned tasks, in order."""

    name: str
    role: str
    tasks: tuple[ScheduledTask, ...]
    #: the starts of its battery swaps (the flight home), s (``--physical battery``)
    swaps_s: tuple[float, ...] = ()


@dataclass(frozen=True)
class OfflineSchedule:
    """An offline schedule of a plan for a fleet: per UAV its ordered tasks, the makespan and a proven bound.

    ``bound_s`` is a valid lower bound of every schedule's makespan (and of every mission's, ``task``
    reservation): CP-SAT's proven bound of the whole model, or, with a decomposition, the report's cheap terms
    (``bound_kind`` says which). ``status`` is ``optimal`` when the makespan equals the bound it proved.
    """

    uavs: tuple[UavSchedule, ...]
    makespan_s: float
    bound_s: float
    bound_kind: str
    status: str
    solve_time_s: float
    decomposition: str
    reservation: str
    time_limit_s: float
    seed: int
    tick_s: float
    wall_digest: str = ""
    fleet_digest: str = ""
    #: per part of a decomposition: tasks, status, solve time
    parts: tuple[Mapping[str, Any], ...] = ()
    #: the physical terms of the model (``masonry schedule --physical``; () : the plain model)
    physical: tuple[str, ...] = ()

    @property
    def battery_swaps(self) -> int:
        """The battery swaps of the schedule, all UAVs together (``--physical battery``)."""
        return sum(len(u.swaps_s) for u in self.uavs)

    @property
    def gap(self) -> float:
        """(makespan - bound) / makespan: 0 when proven optimal."""
        return 0.0 if self.makespan_s <= 0 else max(0.0, (self.makespan_s - self.bound_s) / self.makespan_s)

    def order_of(self) -> dict[str, tuple[str, ...]]:
        """UAV name -> the ids of its tasks, in order."""
        return {u.name: tuple(t.id for t in u.tasks) for u in self.uavs}

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": SCHEDULE_FORMAT,
            "version": SCHEDULE_VERSION,
            "wall_digest": self.wall_digest,
            "fleet_digest": self.fleet_digest,
            "reservation": self.reservation,
            "status": self.status,
            "makespan_s": round(self.makespan_s, 3),
            "bound_s": round(self.bound_s, 3),
            "bound_kind": self.bound_kind,
            "gap": round(self.gap, 4),
            "solve_time_s": round(self.solve_time_s, 3),
            "time_limit_s": self.time_limit_s,
            "seed": self.seed,
            "tick_s": self.tick_s,
            "decomposition": self.decomposition,
            "parts": [dict(p) for p in self.parts],
            **({"physical": list(self.physical)} if self.physical else {}),
            "uavs": [
                {
                    "name": u.name,
                    "role": u.role,
                    "tasks": [_task_dict(t) for t in u.tasks],
                    **({"swaps_s": [round(w, 3) for w in u.swaps_s]} if self.physical else {}),
                }
                for u in self.uavs
            ],
        }

    def summary(self) -> str:
        """A few human lines: status, makespan against the bound, the decomposition, per UAV its task count."""
        lines = [
            f"schedule {self.status}: makespan {self.makespan_s:.1f} s, bound {self.bound_s:.1f} s "
            f"({self.bound_kind}), gap {self.gap * 100:.1f} %, solved in {self.solve_time_s:.1f} s "
            f"(limit {self.time_limit_s:g} s), decomposition {self.decomposition}, reservation {self.reservation}"
            + (f", physical {'+'.join(self.physical)} ({self.battery_swaps} swaps)" if self.physical else "")
        ]
        for u in self.uavs:
            last = u.tasks[-1].end_s if u.tasks else 0.0
            lines.append(f"  {u.name:<12} {u.role:<8} {len(u.tasks):4d} tasks, last ends at {last:.1f} s")
        return "\n".join(lines)


def _task_dict(t: ScheduledTask) -> dict[str, Any]:
    out: dict[str, Any] = {"id": t.id, "start_s": round(t.start_s, 3), "end_s": round(t.end_s, 3)}
    if t.site_start_s is not None:
        out["site_start_s"] = round(t.site_start_s, 3)
        out["site_end_s"] = round(t.site_end_s or t.end_s, 3)
    return out


def _field(doc: Mapping[str, Any], key: str, kind: type | tuple[type, ...], where: str) -> Any:
    if key not in doc:
        raise InputError(f"{where}: missing field `{key}`")
    value = doc[key]
    if (isinstance(value, bool) and kind is not bool) or not isinstance(value, kind):
        raise InputError(f"{where}: field `{key}` has the wrong type ({type(value).__name__})")
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(f"{where}: field `{key}` is not finite")
    return value


def _seconds(doc: Mapping[str, Any], key: str, where: str) -> float:
    value = float(_field(doc, key, (int, float), where))
    if value < 0:
        raise InputError(f"{where}: field `{key}` is negative")
    return value


def schedule_from_dict(doc: Any, where: str = "schedule") -> OfflineSchedule:
    """The schedule a JSON document describes, checked field by field.

    Args:
        where: how errors name the document (the CLI passes the file's name).

    Raises:
        InputError: one line naming ``where`` and the field that is missing, of the wrong type or out of range
            (another format or version, a task listed twice).
    """
    if not isinstance(doc, Mapping):
        raise InputError(f"{where}: not a JSON object")
    if doc.get("format") != SCHEDULE_FORMAT:
        raise InputError(f"{where}: field `format` must be {SCHEDULE_FORMAT!r}, got {doc.get('format')!r}")
    if doc.get("version") != SCHEDULE_VERSION:
        raise InputError(f"{where}: field `version` must be {SCHEDULE_VERSION}, got {doc.get('version')!r}")
    status = _field(doc, "status", str, where)
    if status not in STATUSES:
        raise InputError(f"{where}: field `status` must be one of {', '.join(STATUSES)}, got {status!r}")
    decomposition = _field(doc, "decomposition", str, where)
    if decomposition not in DECOMPOSITIONS:
        raise InputError(f"{where}: field `decomposition` must be one of {', '.join(DECOMPOSITIONS)}")
    reservation = _field(doc, "reservation", str, where)
    if reservation not in ("site", "task"):
        raise InputError(f"{where}: field `reservation` must be site or task, got {reservation!r}")
    uavs_doc = _field(doc, "uavs", list, where)
    seen: set[str] = set()
    uavs: list[UavSchedule] = []
    for k, u in enumerate(uavs_doc):
        at = f"{where}: uavs[{k}]"
        if not isinstance(u, Mapping):
            raise InputError(f"{at}: not a JSON object")
        tasks: list[ScheduledTask] = []
        for j, t in enumerate(_field(u, "tasks", list, at)):
            tat = f"{at}.tasks[{j}]"
            if not isinstance(t, Mapping):
                raise InputError(f"{tat}: not a JSON object")
            tid = _field(t, "id", str, tat)
            if tid in seen:
                raise InputError(f"{tat}: field `id` {tid!r} is scheduled twice")
            seen.add(tid)
            start, end = _seconds(t, "start_s", tat), _seconds(t, "end_s", tat)
            if end < start:
                raise InputError(f"{tat}: field `end_s` is before `start_s`")
            site = (
                (_seconds(t, "site_start_s", tat), _seconds(t, "site_end_s", tat))
                if "site_start_s" in t
                else None
            )
            tasks.append(ScheduledTask(tid, start, end, *(site or (None, None))))
        swaps = _field(u, "swaps_s", list, at) if "swaps_s" in u else []
        if not all(isinstance(w, (int, float)) and not isinstance(w, bool) and w >= 0 for w in swaps):
            raise InputError(f"{at}: field `swaps_s` holds a value that is not a time >= 0")
        uavs.append(
            UavSchedule(
                _field(u, "name", str, at),
                _field(u, "role", str, at),
                tuple(tasks),
                tuple(float(w) for w in swaps),
            )
        )
    parts = _field(doc, "parts", list, where) if "parts" in doc else []
    return OfflineSchedule(
        uavs=tuple(uavs),
        makespan_s=_seconds(doc, "makespan_s", where),
        bound_s=_seconds(doc, "bound_s", where),
        bound_kind=_field(doc, "bound_kind", str, where),
        status=status,
        solve_time_s=_seconds(doc, "solve_time_s", where),
        decomposition=decomposition,
        reservation=reservation,
        time_limit_s=_seconds(doc, "time_limit_s", where),
        seed=int(_field(doc, "seed", int, where)),
        tick_s=_seconds(doc, "tick_s", where),
        wall_digest=_field(doc, "wall_digest", str, where),
        fleet_digest=_field(doc, "fleet_digest", str, where),
        parts=tuple(p for p in parts if isinstance(p, Mapping)),
        physical=tuple(str(t) for t in _field(doc, "physical", list, where)) if "physical" in doc else (),
    )


__all__ = [
    "DECOMPOSITIONS",
    "SCHEDULE_FORMAT",
    "SCHEDULE_VERSION",
    "STATUSES",
    "OfflineSchedule",
    "ScheduledTask",
    "UavSchedule",
    "schedule_from_dict",
]
