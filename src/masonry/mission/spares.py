"""Spare bricks in a mission: which spare stands in for which lost brick, and which bricks wait for a person.

Mission control keeps one :class:`SpareBook`. It is inert for a plan without spares (``Plan.spares`` None: no
``spares`` key in the blueprint), so such a mission runs as it always did. With spares (even ``spares: []``):

- A brick task whose attempt ends with its brick gone (:func:`brick_gone`: the UAV was lost with the brick on its
  magnet, or the brick was dropped, or it was not seen near its pickup) is handed out again for the first
  free spare of the brick's size: the same task (same id, same place in the wall, same dependencies) with the
  spare's pickup and id (``BrickTask.spare``: the UAV looks for the spare's markers). That attempt does not
  count against ``max_attempts``: the brick, not the task, failed.
- With no spare of that size left, the task waits for a person (it is stuck at once, with the reason; the rest
  of the wall that does not depend on it is built). A UAV lost with its brick may have put the brick back on
  its pallet (docs/state-machines.md), so that case alone, with no spare left, is tried at its pickup again.
- Every use of a spare and every brick left waiting is journaled (meta ``spare/<spare id>`` and
  ``waiting/<task>``): a resumed mission hands out no spare twice and keeps the replacements it made.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Protocol

from masonry.errors import MissionError
from masonry.planner.tasks import BrickTask
from masonry.ports import UNCOUNTED_REASONS

if TYPE_CHECKING:
    from masonry.planner.tasks import Plan, Task
    from masonry.spares import Spare

log = logging.getLogger(__name__)


class Emit(Protocol):
    """Mission control's ``_emit``: an event for its sink."""

    def __call__(
        self, now_s: float, kind: str, uav: str | None = None, task_id: str | None = None, **fields: object
    ) -> None: ...


class MetaJournal(Protocol):
    """The part of :class:`~masonry.mission.journal.Journal` the book writes to."""

    def set_meta(self, key: str, value: object) -> None: ...


#: Journal meta key prefixes: a spare handed out for a task, a task waiting for a person.
SPARE_META_PREFIX = "spare/"
WAITING_META_PREFIX = "waiting/"
#: Parts of a failure reason that say the brick itself is gone (the UAV machine's and mission control's words;
#: the machine reports no drop in flight yet: an adapter that detects one says "brick dropped").
GONE_PHRASES = ("not seen near its pickup", "on its magnet)", "brick dropped", "dropped its brick")


def brick_gone(reason: str) -> bool:
    """Whether a failed brick attempt's reason says the brick is gone (lost with its UAV, dropped, not found);
    never one that is not the task's (the battery, a recall, a task its UAV dropped: ``UNCOUNTED_REASONS``)."""
    return not reason.startswith(UNCOUNTED_REASONS) and any(phrase in reason for phrase in GONE_PHRASES)


@dataclass(frozen=True)
class SpareUse:
    """Spare ``spare`` stands in for brick ``brick`` (task ``task_id``) since ``time_s``, because of ``reason``."""

    spare: int
    brick: int
    task_id: str
    reason: str
    time_s: float

    def as_dict(self) -> dict[str, object]:
        return {"spare": self.spare, "brick": self.brick, "task": self.task_id, "reason": self.reason}


@dataclass(frozen=True)
class Waiting:
    """Brick ``brick`` (task ``task_id``) waits for a person: its brick is gone and no spare of its size is left."""

    brick: int
    task_id: str
    reason: str
    time_s: float

    def as_dict(self) -> dict[str, object]:
        return {"brick": self.brick, "task": self.task_id, "reason": self.reason}


def as_flown(task: Task, spare_id: int | None, spares: Mapping[int, Spare]) -> Task:
    """``task`` as it is handed out with spare ``spare_id`` standing in for its brick: the spare's pickup and id
    (``task`` itself with none, or with a spare that is unknown or of another size: a check against it fails)."""
    spare = spares.get(spare_id) if spare_id is not None else None
    if spare is None or not isinstance(task, BrickTask) or not spare.fits(task.size_m):
        return task
    return replace(task, pickup_m=spare.pickup_m, spare=spare.id)


@dataclass(frozen=True)
class SpareReport:
    """What a mission's report says of its spares (:meth:`SpareBook.report`)."""

    used: tuple[SpareUse, ...]
    left: tuple[int, ...]
    waiting: tuple[Waiting, ...]

    def to_dict(self) -> dict[str, object]:
        """The JSON report's fields: ``spares_used``, ``spares_left``, ``waiting_for_person``."""
        return {
            "spares_used": [u.as_dict() for u in self.used],
            "spares_left": list(self.left),
            "waiting_for_person": [w.as_dict() for w in self.waiting],
        }

    def to_record(self) -> dict[str, object]:
        """Everything, as JSON values, for a log's report record (:meth:`from_record` reads it back equal)."""
        return {
            "used": [[u.spare, u.brick, u.task_id, u.reason, u.time_s] for u in self.used],
            "left": list(self.left),
            "waiting": [[w.brick, w.task_id, w.reason, w.time_s] for w in self.waiting],
        }

    @classmethod
    def from_record(cls, data: Mapping[str, object]) -> SpareReport:
        """The report :meth:`to_record` wrote (KeyError, MissionError: not such a record)."""
        used = [
            SpareUse(_int(a), _int(b), str(t), str(r), _float(s)) for a, b, t, r, s in _rows(data["used"], 5)
        ]
        waiting = [Waiting(_int(b), str(t), str(r), _float(s)) for b, t, r, s in _rows(data["waiting"], 4)]
        return cls(tuple(used), tuple(_int(k) for k in _items(data["left"])), tuple(waiting))

    def lines(self) -> list[str]:
        """The summary's lines: which spare replaced which brick, and the bricks left for a person."""
        used = [f"spare {u.spare} for brick {u.brick} ({u.reason})" for u in self.used]
        out = [f"spares used: {'; '.join(used) or 'none'}; {len(self.left)} left"]
        return out + [f"waiting for a person: brick {w.brick} ({w.reason})" for w in self.waiting]


class SpareBook:
    """The spares of a mission: free ones, the ones handed out, and the bricks that wait for a person.

    Args:
        plan: the wall's plan (its ``spares``; None makes the book inert).
        journal: where each use and each wait is recorded (``set_meta``), or None.
        emit: ``emit(now_s, kind, uav, task_id, **fields)``: a ``spare`` event for a log or a live view, or None.
    """

    def __init__(self, plan: Plan, journal: MetaJournal | None = None, emit: Emit | None = None) -> None:
        self.active = plan.spares is not None
        self._free: list[Spare] = list(plan.spares or ())
        self._spares = {s.id: s for s in plan.spares or ()}
        self._tasks = {t.id: t for t in plan.tasks if isinstance(t, BrickTask)}
        self.journal = journal
        self._emit = emit
        #: every spare handed out, in order
        self.used: list[SpareUse] = []
        #: task id -> why its brick waits for a person
        self.waiting: dict[str, Waiting] = {}

    def task(self, task: Task) -> Task:
        """The task as it is flown now: with its spare's pickup and id if one stands in for its brick."""
        use = self.spare_of(task.id)
        return task if use is None else as_flown(task, use.spare, self._spares)

    def spare_of(self, task_id: str) -> SpareUse | None:
        """The latest spare handed out for ``task_id``, if any."""
        return next((u for u in reversed(self.used) if u.task_id == task_id), None)

    def failed(self, task_id: str, reason: str, now_s: float) -> tuple[bool, bool]:
        """A brick or adhesion attempt failed with ``reason``: (count it against ``max_attempts``, stuck now).

        Its brick gone, a free spare of its size stands in (not counted); none left: it waits for a person.
        """
        count = not reason.startswith(UNCOUNTED_REASONS)
        if not self.active or task_id not in self._tasks or not brick_gone(reason):
            return count, False
        if self._hand_out(task_id, reason, now_s, failure=True):
            return False, False
        self._wait(task_id, reason, now_s)
        return count, True

    def lost(self, task_id: str | None, reason: str, now_s: float) -> None:
        """A UAV was declared lost holding ``task_id`` (back in the pool): a spare stands in if its brick went
        with it (none left: the task is tried at its pickup again, where the UAV may have put the brick)."""
        if self.active and task_id in self._tasks and brick_gone(reason):
            self._hand_out(task_id, reason, now_s, failure=False)

    def _hand_out(self, task_id: str, reason: str, now_s: float, *, failure: bool) -> bool:
        """A free spare of the brick's size stands in (False: none). ``failure``: for a journaled failure (which
        a resumed mission's journal counts as an attempt: :meth:`restore` takes it back)."""
        brick = self._tasks[task_id]
        spare = next((s for s in self._free if s.fits(brick.size_m)), None)
        if spare is None:
            return False
        self._free.remove(spare)
        use = SpareUse(spare.id, brick.brick, task_id, reason, now_s)
        self.used.append(use)
        log.warning("%s: spare %d stands in for brick %d (%s)", task_id, spare.id, brick.brick, reason)
        if self.journal is not None:
            value = {**use.as_dict(), "time_s": now_s, "failure": failure}
            self.journal.set_meta(f"{SPARE_META_PREFIX}{spare.id}", value)
        if self._emit is not None:
            self._emit(now_s, "spare", None, task_id, spare=spare.id, brick=brick.brick, reason=reason)
        return True

    def _wait(self, task_id: str, reason: str, now_s: float) -> None:
        brick = self._tasks[task_id]
        size = " x ".join(f"{v:g}" for v in brick.size_m)
        why = f"{reason}; no spare of its size ({size} m) left"
        self.waiting[task_id] = Waiting(brick.brick, task_id, why, now_s)
        log.warning("%s: brick %d waits for a person: %s", task_id, brick.brick, why)
        if self.journal is not None:
            self.journal.set_meta(f"{WAITING_META_PREFIX}{task_id}", {"reason": why, "time_s": now_s})
        if self._emit is not None:
            self._emit(now_s, "spare", None, task_id, spare=None, brick=brick.brick, reason=why)

    def restore(
        self, meta: Mapping[str, object], attempts: Mapping[str, int], max_attempts: int
    ) -> dict[str, int]:
        """Take back the uses and waits a journal holds (its meta).

        Returns:
            ``attempts`` (the journal's finished attempts per task) as mission control counts them: an attempt a
            spare replaced does not count, and a brick waiting for a person stays stuck (``max_attempts``).
        """
        out = {k: int(v) for k, v in attempts.items()}
        if not self.active:
            return out
        values = [(k, v) for k, v in meta.items() if isinstance(v, Mapping)]
        for key, value in sorted(values, key=lambda kv: _time_of(kv[1])):
            task_id = str(value.get("task"))
            spare = next((s for s in self._free if f"{SPARE_META_PREFIX}{s.id}" == key), None)
            if spare is None or task_id not in self._tasks:
                continue
            self._free.remove(spare)
            reason = str(value.get("reason"))
            self.used.append(SpareUse(spare.id, self._tasks[task_id].brick, task_id, reason, _time_of(value)))
            if value.get("failure") is True and out.get(task_id, 0) > 0:
                out[task_id] -= 1
        for key, value in values:
            task_id = key.removeprefix(WAITING_META_PREFIX)
            if key.startswith(WAITING_META_PREFIX) and task_id in self._tasks:
                brick = self._tasks[task_id].brick
                self.waiting[task_id] = Waiting(brick, task_id, str(value.get("reason")), _time_of(value))
                out[task_id] = max(out.get(task_id, 0), max_attempts)
        return out

    def report(self) -> SpareReport | None:
        """The report's account of the spares (None for a plan without spares)."""
        if not self.active:
            return None
        return SpareReport(tuple(self.used), tuple(s.id for s in self._free), tuple(self.waiting.values()))


def _items(value: object) -> list[object]:
    if not isinstance(value, list):
        raise MissionError(f"a spare record is malformed: expected a list, got {value!r}"[:200])
    return list(value)


def _rows(value: object, width: int) -> list[list[object]]:
    """A record's table: a list of lists of ``width`` items."""
    rows = [r for r in _items(value) if isinstance(r, list) and len(r) == width]
    if len(rows) != len(_items(value)):
        raise MissionError(
            f"a spare record is malformed: expected rows of {width} items, got {value!r}"[:200]
        )
    return rows


def _int(value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise MissionError(f"a spare record is malformed: expected an integer, got {value!r}")
    return value


def _float(value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MissionError(f"a spare record is malformed: expected a number, got {value!r}")
    return float(value)


def _time_of(value: object) -> float:
    t = value.get("time_s") if isinstance(value, Mapping) else None
    return float(t) if isinstance(t, (int, float)) else 0.0


__all__ = [
    "GONE_PHRASES",
    "SPARE_META_PREFIX",
    "WAITING_META_PREFIX",
    "MetaJournal",
    "SpareBook",
    "SpareReport",
    "SpareUse",
    "Waiting",
    "as_flown",
    "brick_gone",
]
