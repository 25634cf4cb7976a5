"""The results a UAV reports, and the completion it keeps until mission control has heard it.

``report_result`` (the machine's :class:`~masonry.ports.MissionLink` call) closes the attempt's
:class:`~masonry.mission.execution.Execution` and sends the result; a completion is kept (``keeper``, across a
restart of the handler) and said again while the link may have been down: with every heartbeat while mission
control is silent since before it was sent, and once more when it is heard again after such a silence
(docs/mission.md, "Heartbeats and time"). A task the handler dropped itself (mission control silent) was
reported failed then: the machine's own report of it is swallowed.

:class:`ResultReports` is a base class of :class:`~masonry.mission.handler.UavHandler`; its log lines are the
handler's (logger ``masonry.mission.handler``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Protocol

from masonry.errors import ProtocolError
from masonry.mission.handler_base import HandlerBase
from masonry.mission.messages import Result, decode, encode
from masonry.mission.uav_facts import OUT_OF_SERVICE_STATE
from masonry.ports import TaskResult

log = logging.getLogger("masonry.mission.handler")


class ResultKeeper(Protocol):
    """Where a UAV keeps its last completion until mission control has heard it, across a restart of its handler
    (a real UAV's companion computer keeps it on its disk; the in-process simulation in its mission's journal
    file, because a stop of ``masonry sim`` stops its UAVs too)."""

    def kept(self, uav: str) -> bytes | None:
        """The completion ``uav`` kept (its wire form), or None."""
        ...

    def keep(self, uav: str, message: bytes | None) -> None:
        """Keep ``message`` for ``uav`` (None: forget it, mission control heard it); durable when it returns."""
        ...


class ResultReports(HandlerBase):
    """The handler's results and its kept completion (see the module)."""

    def _init_results(self, keeper: ResultKeeper | None, after_result: Callable[[], None] | None) -> None:
        self._after_result = after_result
        self._keeper = keeper
        self._unheard: tuple[Result, float] | None = None  # the last completion sent, and when
        self._kept = self._restore_kept()  # a completion from before a restart: said at the first step
        # a task dropped (mission control silent): its machine's report is not sent
        self._swallow: str | None = None

    def _restore_kept(self) -> Result | None:
        raw = self._keeper.kept(self.name) if self._keeper is not None else None
        if raw is None:
            return None
        try:
            msg = decode(raw)
        except ProtocolError as exc:
            log.warning("%s: the kept completion cannot be read (%s): forgotten", self.name, exc)
            return None
        if not isinstance(msg, Result) or msg.sender != self.name or msg.result.status != "done":
            log.warning("%s: the kept message is not a completion of this UAV: forgotten", self.name)
            return None
        return msg

    def _say_kept(self, now_s: float) -> None:
        """The first step after a restart: the completion mission control may never have heard, ahead of the
        heartbeat (which names no task: heard first, it would give the task back to the pool)."""
        kept, self._kept = self._kept, None
        if kept is None:
            return
        log.info("%s: %s done before the restart: reported again", self.name, kept.result.task_id)
        self._send(kept)
        self._unheard = (kept, -math.inf)  # said again when mission control is first heard (_heard_after)

    def _keep(self, sent: Result | None) -> None:
        if self._keeper is not None:
            self._keeper.keep(self.name, None if sent is None else encode(sent))

    def _resend_unheard(self, now_s: float) -> None:
        """While mission control is silent since before the last completion was sent, say the completion again
        with every heartbeat, ahead of it: the link may be down, and the first thing mission control hears
        when it is back is then the completion, before the heartbeat that takes this UAV back (a task declared
        released and given to it again would be flown twice)."""
        if self._unheard is None:
            return
        sent, sent_s = self._unheard
        last = self._last_mc_s
        if last is not None and last <= sent_s and now_s - last > 1.5 * self.heartbeat_period_s:
            self._send(sent)

    def _heard_after(self, before: float | None, now_s: float) -> None:
        """Mission control is heard at ``now_s`` (last before at ``before``): the completion sent last is heard or
        said again."""
        if self._unheard is None:
            return
        sent, sent_s = self._unheard
        self._unheard = None
        self._keep(None)
        if sent_s == -math.inf or (
            before is not None and before <= sent_s and now_s - before > 1.5 * self.heartbeat_period_s
        ):
            # mission control's heartbeats stopped around the completion: the link was down, the result may
            # be lost. Said again: mission control takes it late if the task was released from this UAV
            # and is not done since, and ignores it if it had it (docs/mission.md, "Heartbeats and time")
            log.info("%s: %s done while the link was down: reported again", self.name, sent.result.task_id)
            self._send(sent)

    def report_result(self, result: TaskResult) -> None:
        cur = self._current
        if self._swallow == result.task_id and (cur is None or cur.task_id != result.task_id):
            self._swallow = None  # the failure of a task dropped when mission control fell silent: sent then
            return
        if cur is not None and cur.task_id == result.task_id:
            cur.end_s = self.now_s
            cur.status = result.status
            cur.reason = None if result.status == "done" else (result.reason or "no reason given")
            self._current = None
            if result.phases is not None and cur.queued_s > 0.0:
                # the machine measured from taking the task; the attempt began when its assignment came
                result = replace(
                    result, phases=replace(result.phases, queued=result.phases.queued + cur.queued_s)
                )
        attempt = cur.attempt if cur is not None and cur.task_id == result.task_id else 0
        state = self._state()
        if result.status == "done":
            log.info("%s: %s attempt %d done at %.1f s", self.name, result.task_id, attempt, self.now_s)
        else:
            log.info(
                "%s: %s attempt %d failed at %.1f s in state %s: %s",
                self.name,
                result.task_id,
                attempt,
                self.now_s,
                state or "-",
                result.reason or "no reason given",
            )
        sent = Result(
            self.name,
            result,
            self.now_s,
            self._where(),
            state=state,
            attempt=attempt,
            out_of_service=state == OUT_OF_SERVICE_STATE,  # (the handler knows its machine)
        )
        self._send(sent)
        if result.status == "done":
            self._unheard = (
                sent,
                self.now_s,
            )  # said again if the link turns out to have been down (_heard_after)
            self._keep(sent)
        if self._after_result is not None:
            self._after_result()

    def _drop_current(self, reason: str) -> None:
        """Off the task now, cut off from mission control: the attempt ends here and is reported failed, so the
        heartbeats say this UAV holds no task (mission control takes it back when it hears them) while the machine
        puts the brick back or heads home; the machine's own report of that failure is not sent again."""
        cur = self._current
        assert cur is not None
        cur.end_s, cur.status, cur.reason = self.now_s, "failed", reason
        self._current = None
        self._swallow = cur.task_id
        self._send_failed(cur.task_id, cur.attempt, reason, self._state())


__all__ = ["ResultKeeper", "ResultReports"]
