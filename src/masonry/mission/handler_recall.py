"""The recalls of a UAV's mission handler: each bound to the assignments it drops, applied at the next tick.

A :class:`~masonry.mission.messages.Recall` names the assignment it recalls (``task_id``, ``attempt``); the
handler takes it only while it holds that assignment (queued, or in hand and not abandoned) and ignores it
otherwise (counted in ``stale_recalls``, logged): a recall said again, or one that crossed the task's result on
the way, cannot fail the assignment that came after it (issue 27, branch ``recall42``). A recall naming no task
(the operator's, return-all and abort) is bound to whatever the UAV holds when it reads it, as is the handler's
own when mission control falls silent (:data:`~masonry.ports.MISSION_CONTROL_LOST_REASON`): an assignment read
after it is not dropped by it.

A recall is applied at the next tick, outside the machine's callbacks: the queued assignments it names are failed
back at once; the task in hand is aborted (the machine reports it failed and flies home) once the machine may
abort it, and never once its work is on the wall (:data:`~masonry.ports.FINISHING_STATES`: it finishes and
reports done). A recall whose assignment has ended meanwhile is dropped.

:class:`Recalls` is a base class of :class:`~masonry.mission.handler.UavHandler`, as
:mod:`masonry.mission.handler_results` and :mod:`masonry.mission.handler_columns` are.
"""

from __future__ import annotations

import logging
from abc import abstractmethod
from collections import deque

from masonry.mission.handler_base import HandlerBase
from masonry.mission.messages import Recall
from masonry.planner.tasks import Task
from masonry.ports import FINISHING_STATES, MISSION_CONTROL_LOST_REASON

log = logging.getLogger("masonry.mission.handler")

__all__ = ["MAX_STALE_RECALLS_KEPT", "Recalls"]

#: Stale recalls kept in ``Recalls.stale`` (and logged); later ones are only counted in ``stale_recalls``.
MAX_STALE_RECALLS_KEPT = 100

#: One assignment as the protocol names it: the task's id and the attempt number it was assigned with.
Held = tuple[str, int]


class Recalls(HandlerBase):
    """The recalls taken and not applied yet, and those ignored (see the module)."""

    #: the assignments not started yet: task, attempt, when its assignment came
    _queue: deque[tuple[Task, int, float]]

    @abstractmethod
    def _drop_current(self, reason: str) -> None:
        """Off the task in hand now, reported failed (:class:`~masonry.mission.handler_results.ResultReports`)."""

    def _init_recalls(self) -> None:
        #: recalls taken, not applied yet: the assignment -> the reason its failure gives
        self._recalls: dict[Held, str] = {}
        #: recalls that named an assignment this UAV does not hold: ignored (counted; the first ones kept)
        self.stale_recalls = 0
        self.stale: list[Recall] = []

    def _held(self) -> list[Held]:
        """The assignments a recall may drop: those queued, and the one in hand unless abandoned already."""
        out = [(task.id, attempt) for task, attempt, _ in self._queue]
        cur = self._current
        if cur is not None and cur.abandoned_s is None:
            out.append((cur.task_id, cur.attempt))
        return out

    def _take_recall(self, msg: Recall) -> None:
        """A recall addressed to this UAV, read now: bound to what it names (or holds), or ignored."""
        held = self._held()
        if msg.task_id is None:
            names = held  # the operator's: whatever it holds now
        elif (msg.task_id, msg.attempt) in held:
            names = [(msg.task_id, msg.attempt)]
        else:
            self.stale_recalls += 1
            if len(self.stale) < MAX_STALE_RECALLS_KEPT:
                self.stale.append(msg)
                log.info(
                    "%s: ignoring the recall of %s attempt %d (%s): it holds %s",
                    self.name,
                    msg.task_id,
                    msg.attempt,
                    msg.reason,
                    ", ".join(f"{t} attempt {a}" for t, a in held) or "nothing",
                )
            return
        for key in names:
            self._recalls.setdefault(key, msg.reason)

    def _recall_held(self, reason: str) -> bool:
        """The handler's own recall of everything it holds (mission control silent); True if it named any."""
        new = [key for key in self._held() if key not in self._recalls]
        for key in new:
            self._recalls[key] = reason
        return bool(new)

    def _apply_recalls(self) -> None:
        """The recalls taken: queued assignments failed back, the task in hand aborted once it may be."""
        state = self._state()
        for entry in [e for e in self._queue if (e[0].id, e[1]) in self._recalls]:
            self._queue.remove(entry)
            task, attempt, _ = entry
            self._send_failed(task.id, attempt, self._recalls.pop((task.id, attempt)), state)
        cur = self._current
        key = None if cur is None else (cur.task_id, cur.attempt)
        for gone in [k for k in self._recalls if k != key]:
            del self._recalls[gone]  # it ended before the machine could be told (done, or failed on its own)
        if cur is None or key not in self._recalls:
            return
        assert key is not None
        reason = self._recalls[key]
        model = self.model
        if cur.abandoned_s is not None:
            del self._recalls[key]  # abandoned by another recall already
        elif state in FINISHING_STATES:
            pass  # the work is on the wall: the machine finishes and reports it done, then the recall is dropped
        elif model is not None and getattr(model, "task", None) is not None and model.may_abort():
            del self._recalls[key]
            cur.abandoned_s = self.now_s
            if reason.startswith(MISSION_CONTROL_LOST_REASON):
                self._drop_current(reason)
            model.abort(reason=reason)  # reported failed through report_result; it flies home and lands
