"""An offline schedule file for ``masonry sim --policy schedule``: read, check it against the mission, digest it.

The schedule (:mod:`masonry.planner.schedule_values`) carries the digests of the wall and the fleet it was
computed for (:mod:`masonry.fingerprint`): a schedule for another wall or fleet, or for the other reservation,
is refused in one line.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from masonry.blueprint import Blueprint
from masonry.errors import InputError
from masonry.fingerprint import fleet_digest, wall_digest
from masonry.mission.report import MissionReport
from masonry.planner.schedule_values import OfflineSchedule, schedule_from_dict


def read_schedule(path: Path) -> OfflineSchedule:
    """The schedule in the JSON file ``path``.

    Raises:
        InputError: the file cannot be read, is not JSON, or a field is missing or bad (one line naming the
            file and the field).
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(
            f"`schedule` {path}: cannot be read ({exc.__class__.__name__})", options=("schedule",)
        ) from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"`schedule` {path}: not JSON (line {exc.lineno})", options=("schedule",)) from None
    try:
        return schedule_from_dict(doc, where=str(path))
    except InputError as exc:
        raise InputError(f"`schedule` {exc}", options=("schedule",)) from None


def stamp_schedule(schedule: OfflineSchedule, blueprint: Blueprint) -> OfflineSchedule:
    """``schedule`` with the digests of ``blueprint``'s wall and fleet (the ones it was computed for)."""
    import dataclasses

    return dataclasses.replace(
        schedule, wall_digest=wall_digest(blueprint), fleet_digest=fleet_digest(blueprint)
    )


def check_schedule(schedule: OfflineSchedule, blueprint: Blueprint, reservation: str) -> None:
    """Refuse a schedule computed for another wall, fleet or reservation than this mission's.

    Raises:
        InputError: one line saying which.
    """
    if schedule.wall_digest != wall_digest(blueprint):
        raise InputError(
            "`schedule` was computed for another wall (its wall digest differs): run masonry schedule on this one",
            options=("schedule",),
        )
    if schedule.fleet_digest != fleet_digest(blueprint):
        raise InputError(
            "`schedule` was computed for another fleet (names, roles or homes differ): give the same "
            "`brick_uavs` / `adhesion_uavs` as to masonry schedule",
            options=("schedule", "brick_uavs", "adhesion_uavs"),
        )
    if schedule.reservation != reservation:
        raise InputError(
            f"`schedule` was computed for `reservation` {schedule.reservation}, the mission has {reservation}",
            options=("schedule", "reservation"),
        )


def with_schedule_counts(report: MissionReport, dispatcher: Any) -> MissionReport:
    """``report`` with how many assignments followed the schedule (a dispatcher of ``--policy schedule``;
    any other dispatcher: the report as it is)."""
    followed = getattr(dispatcher, "followed", None)
    if followed is None:
        return report
    import dataclasses

    return dataclasses.replace(
        report, schedule_followed=int(followed), schedule_assignments=int(followed + dispatcher.fallbacks)
    )


__all__ = ["check_schedule", "read_schedule", "stamp_schedule", "with_schedule_counts"]
