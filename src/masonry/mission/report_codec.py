"""A :class:`~masonry.mission.report.MissionReport` as JSON and back, losslessly (pure: no I/O).

The JSON report (``MissionReport.to_dict``) rounds and leaves out what the Gantt chart and the 3-D plot need (every
attempt, the flown paths). A log keeps :func:`report_to_record` instead, so that ``masonry replay`` runs the same
output code on the same value: the same summary, the same ``--format json`` bytes, the same drawings. Floats go
through JSON as Python writes them (``repr``, which reads back to the same float); the non-finite ones, which
JSON has not, as the strings ``"inf"``, ``"-inf"`` and ``"nan"``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from masonry.errors import InvalidArgument, MissionError
from masonry.mission.envelope import EnvelopeExcursion
from masonry.mission.report import AttemptReport, MissionReport, TaskReport, UavReport
from masonry.mission.spares import SpareReport
from masonry.mission.waits import TaskWait, WaitCause
from masonry.perception.types import AsBuiltPose
from masonry.ports import PhaseTimes

#: Bumped when the record's form changes; a reader refuses another.
REPORT_RECORD_VERSION = 1


def _num_out(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    return v


def _num_in(v: Any) -> Any:
    if isinstance(v, str) and v in ("inf", "-inf", "nan"):
        return float(v)
    return v


def _row_out(value: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in dataclasses.fields(value):
        v = getattr(value, f.name)
        if isinstance(v, PhaseTimes):
            out[f.name] = v.as_dict()
        elif isinstance(v, tuple) and v and all(isinstance(w, TaskWait) for w in v):
            out[f.name] = [wait_record(w) for w in v]  # a task's waits (TaskReport.waits)
        elif isinstance(v, tuple) and all(isinstance(a, AttemptReport) for a in v):
            out[f.name] = [_row_out(a) for a in v]  # a task's attempts (TaskReport.tries)
        else:
            out[f.name] = _num_out(v)
    return out


def _row_in(cls: Any, data: Any) -> Any:
    if not isinstance(data, Mapping):
        raise MissionError(f"a {cls.__name__} record must be an object, got {type(data).__name__}")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = set(data) - names
    if unknown:
        raise MissionError(f"a {cls.__name__} record has unknown fields {sorted(unknown)}")
    kw = {k: _num_in(v) for k, v in data.items()}
    if kw.get("phases") is not None:
        kw["phases"] = PhaseTimes(**kw["phases"])
    if cls is UavReport and "waiting_air_s" not in kw:
        # a record from before the split: the airspace then held UAVs in the air only (their transits start
        # after the take-off), so all of waiting_s was in the air
        kw["waiting_air_s"] = kw.get("waiting_s", 0.0)
    if cls is TaskReport and "waits" in kw:
        kw["waits"] = waits_from_record(kw["waits"])
    if cls is TaskReport and "tries" in kw:
        tries = kw["tries"]
        if not isinstance(tries, list):
            raise MissionError(f"a TaskReport record's tries must be a list, got {type(tries).__name__}")
        kw["tries"] = tuple(_row_in(AttemptReport, a) for a in tries)
    try:
        return cls(**kw)
    except TypeError as exc:
        raise MissionError(f"a {cls.__name__} record is incomplete: {exc}") from None


def wait_record(w: TaskWait) -> dict[str, object]:
    """One wait as a JSON record (the log's report record, the journal: :func:`waits_from_record` reads it)."""
    return {
        "task_id": w.task_id,
        "cause": dataclasses.asdict(w.cause),
        "from_s": _num_out(w.from_s),
        "duration_s": _num_out(w.duration_s),
    }


def waits_from_record(data: object) -> tuple[TaskWait, ...]:
    """The waits :func:`wait_record` wrote (raises MissionError: not such a list)."""
    if not isinstance(data, list):
        raise MissionError(f"a TaskReport record's waits must be a list, got {type(data).__name__}")
    try:
        return tuple(
            TaskWait(
                str(w["task_id"]),
                WaitCause(**w["cause"]),
                float(_num_in(w["from_s"])),
                float(_num_in(w["duration_s"])),
            )
            for w in data
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise MissionError(f"a task's wait record is malformed: {type(exc).__name__} {exc}") from None


def _opt_int(v: Any) -> int | None:
    return None if v is None else int(v)


def report_to_record(report: MissionReport) -> dict[str, Any]:
    """Everything in ``report`` as JSON values (:func:`report_from_record` reads it back equal)."""
    return {
        "version": REPORT_RECORD_VERSION,
        "completed": report.completed,
        "makespan_s": _num_out(report.makespan_s),
        "lower_bound_s": _num_out(report.lower_bound_s),
        "policy": report.policy,
        "seed": report.seed,
        "uavs": [_row_out(u) for u in report.uavs],
        "tasks": [_row_out(t) for t in report.tasks],
        "placement_error_m": {k: _num_out(v) for k, v in report.placement_error_m.items()},
        "min_separation_m": _num_out(report.min_separation_m),
        **_envelope_out(report.envelope_excursion),
        "conflict_violations": report.conflict_violations,
        "dependency_violations": report.dependency_violations,
        "stuck": list(report.stuck),
        "attempts": [_row_out(a) for a in report.attempts],
        "paths_m": {k: np.asarray(v, dtype=float).tolist() for k, v in report.paths_m.items()},
        "sim_time_s": _num_out(report.sim_time_s),
        "wall_time_s": _num_out(report.wall_time_s),
        "cpu_time_s": _num_out(report.cpu_time_s),
        "resumed_from_s": _num_out(report.resumed_from_s),
        "messages": report.messages,
        "stall": None if report.stall is None else dict(report.stall),
        "lower_bound_kind": report.lower_bound_kind,
        "schedule_followed": report.schedule_followed,
        "schedule_assignments": report.schedule_assignments,
        **_adhesive_out(report),
        **({} if report.spares is None else {"spares": report.spares.to_record()}),
        **({"as_built": {k: v.to_dict() for k, v in report.as_built.items()}} if report.as_built else {}),
    }


def _envelope_out(e: EnvelopeExcursion | None) -> dict[str, object]:
    """The envelope excursion, exactly (only when measured: old records unchanged)."""
    if e is None:
        return {}
    return {"envelope_excursion": {k: _num_out(v) for k, v in dataclasses.asdict(e).items()}}


def _envelope_in(data: object) -> EnvelopeExcursion | None:
    if data is None:
        return None
    if not isinstance(data, Mapping):
        raise MissionError(
            f"a report record's envelope_excursion must be an object, got {type(data).__name__}"
        )
    try:
        return EnvelopeExcursion.from_dict({k: _num_in(v) for k, v in data.items()})
    except InvalidArgument as exc:
        raise MissionError(str(exc)) from None


def _adhesive_out(report: MissionReport) -> dict[str, Any]:
    """The adhesive's measurements (issue 31), only when the mission had an adhesive: old records unchanged."""
    if report.open_time_violations is None:
        return {}
    return {
        "glue_age_s": {k: _num_out(v) for k, v in (report.glue_age_s or {}).items()},
        "open_time_violations": report.open_time_violations,
        "cure_time_violations": report.cure_time_violations,
        "open_time_s": _num_out(report.open_time_s),
    }


def report_from_record(data: Any) -> MissionReport:
    """The report :func:`report_to_record` wrote.

    Raises:
        MissionError: not such a record (another version, a field missing or malformed).
    """
    if not isinstance(data, Mapping):
        raise MissionError(f"a report record must be an object, got {type(data).__name__}")
    if data.get("version") != REPORT_RECORD_VERSION:
        raise MissionError(
            f"a report record of version {data.get('version')!r}; this masonry reads {REPORT_RECORD_VERSION}"
        )
    try:
        paths = {str(k): np.asarray(v, dtype=float).reshape(-1, 3) for k, v in dict(data["paths_m"]).items()}
        return MissionReport(
            completed=bool(data["completed"]),
            makespan_s=float(_num_in(data["makespan_s"])),
            lower_bound_s=float(_num_in(data["lower_bound_s"])),
            policy=str(data["policy"]),
            seed=int(data["seed"]),
            uavs=tuple(_row_in(UavReport, u) for u in data["uavs"]),
            tasks=tuple(_row_in(TaskReport, t) for t in data["tasks"]),
            placement_error_m={str(k): float(_num_in(v)) for k, v in dict(data["placement_error_m"]).items()},
            min_separation_m=_num_in(data["min_separation_m"]),
            envelope_excursion=_envelope_in(data.get("envelope_excursion")),  # (absent: not measured, older)
            conflict_violations=int(data["conflict_violations"]),
            dependency_violations=int(data["dependency_violations"]),
            stuck=tuple(str(s) for s in data["stuck"]),
            attempts=tuple(_row_in(AttemptReport, a) for a in data["attempts"]),
            paths_m=paths,
            sim_time_s=float(_num_in(data["sim_time_s"])),
            wall_time_s=float(_num_in(data["wall_time_s"])),
            cpu_time_s=float(_num_in(data.get("cpu_time_s", 0.0))),  # (absent from older records)
            resumed_from_s=_num_in(data["resumed_from_s"]),
            messages=int(data["messages"]),
            stall=None if data["stall"] is None else dict(data["stall"]),
            lower_bound_kind=str(data["lower_bound_kind"]),
            schedule_followed=_opt_int(data["schedule_followed"]),
            schedule_assignments=_opt_int(data["schedule_assignments"]),
            glue_age_s=(
                None
                if data.get("glue_age_s") is None
                else {str(k): float(_num_in(v)) for k, v in dict(data["glue_age_s"]).items()}
            ),
            open_time_violations=_opt_int(data.get("open_time_violations")),
            cure_time_violations=_opt_int(data.get("cure_time_violations")),
            open_time_s=_num_in(data.get("open_time_s")),
            spares=None if data.get("spares") is None else SpareReport.from_record(data["spares"]),
            # (absent from the records of logs written before issue 30)
            as_built={str(k): AsBuiltPose.from_dict(v) for k, v in dict(data.get("as_built") or {}).items()},
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise MissionError(f"a report record is malformed: {type(exc).__name__} {exc}") from None


__all__ = ["REPORT_RECORD_VERSION", "report_from_record", "report_to_record"]
