"""The operator in the loop: pause, resume, recall, return-all, abort and fleet limits for mission control.

:class:`Operator` is mission control's desk (``MissionControl.operator``). Commands come over the network
(:class:`~masonry.mission.messages.OperatorCommand` from ``masonry ctl``, authenticated like every message of
the mission) or in-process (:meth:`Operator.submit`, thread-safe: the live page's buttons); mission control
applies them at the start of its next step (:meth:`Operator.step`), so they never race its tick. Each is
acknowledged or refused with a reason, journaled (the journal's ``operator`` entry), and handed to the event
sink (``operator`` events, the log).

- **pause**: no new assignments; every UAV finishes the task it is on and flies home (its own rule when it has no
  next task) and waits there. **resume**: dispatching again; recalled UAVs take tasks again.
- **recall UAV**: it drops its task (:class:`~masonry.mission.messages.Recall`; the task is reported failed with
  :data:`~masonry.ports.RECALL_REASON`, which costs it no attempt, and goes back to the pool), flies home
  through the airspace like any other flight (docs/safety.md) and lands; it takes no task until **resume**.
- **return-all**: pause, and recall every UAV.
- **abort**: return-all, then, once every UAV is landed with no task, the mission ends, not completed, and the
  journal says ``aborted``: ``--resume`` carries on from there like after any stop.
- **limit ROLE N**: at most N UAVs of that role fly tasks at once (the foreman's knob); N = -1 lifts it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from masonry.mission.message_types import MISSION_CONTROL, CommandAnswer, OperatorCommand
from masonry.ports import RECALL_REASON

if TYPE_CHECKING:
    from masonry.mission.control_ports import MissionHost

__all__ = ["CommandOutcome", "Operator"]


@dataclass(frozen=True)
class CommandOutcome:
    """The answer to one command: accepted, or refused with ``reason``."""

    accepted: bool
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"accepted": self.accepted, "reason": self.reason}


class Operator:
    """What the operator has asked of one mission control: the pause, the held UAVs, the limits, an abort."""

    def __init__(self) -> None:
        self.paused = False
        self.aborting = False
        self.aborted = False
        #: UAVs recalled: no task until resume
        self.held: set[str] = set()
        #: role -> how many of its UAVs may fly tasks at once
        self.limits: dict[str, int] = {}
        #: every command and its answer, in order (journaled)
        self.history: list[dict[str, Any]] = []
        #: network commands answered, by id (a command sent again is answered again, not applied twice)
        self.answered: dict[str, CommandAnswer] = {}
        self.version = 0  # bumped by every accepted command (the stall watchdog counts it as progress)
        self._lock = threading.Lock()
        self._inbox: list[tuple[Mapping[str, Any], Callable[[CommandOutcome], None] | None]] = []

    # -- in-process commands ---------------------------------------------------------------------------
    def submit(
        self, command: Mapping[str, Any], answer: Callable[[CommandOutcome], None] | None = None
    ) -> None:
        """Queue a command (``{"command": "recall", "uav": "brick-1"}``) for mission control's next step; it
        calls ``answer`` with the outcome then. Thread-safe."""
        with self._lock:
            self._inbox.append((dict(command), answer))

    def ask(self, command: Mapping[str, Any], timeout_s: float = 5.0) -> CommandOutcome:
        """:meth:`submit` and wait (at most ``timeout_s`` wall seconds) for the answer (another thread steps)."""
        done = threading.Event()
        box: list[CommandOutcome] = []

        def answer(outcome: CommandOutcome) -> None:
            box.append(outcome)
            done.set()

        self.submit(command, answer)
        if not done.wait(timeout_s):
            return CommandOutcome(False, "mission control did not answer (is the mission over?)")
        return box[0]

    # -- mission control's side --------------------------------------------------------------------------
    def step(self, mc: MissionHost, now_s: float) -> None:
        """Apply the queued commands; end an abort once every UAV is down with no task."""
        with self._lock:
            inbox, self._inbox = self._inbox, []
        for command, answer in inbox:
            outcome = self.apply(mc, command, now_s)
            if answer is not None:
                answer(outcome)
        if self.aborting and not self.aborted and self._all_down(mc):
            self.aborted = True
            if mc.journal is not None:
                mc.journal.set_meta("aborted", {"time_s": now_s})

    def apply(self, mc: MissionHost, command: Mapping[str, Any], now_s: float) -> CommandOutcome:
        """Apply one command to mission control ``mc`` at ``now_s``; journal it and tell the sink."""
        outcome = self._apply(mc, command, now_s)
        if outcome.accepted:
            self.version += 1
        entry = {
            "time_s": now_s,
            **{k: v for k, v in command.items() if k in ("command", "uav", "role", "limit")},
            **outcome.to_dict(),
        }
        self.history.append(entry)
        if mc.journal is not None:
            mc.journal.set_meta("operator", self.history)
        line = f"{command.get('command')} {command.get('uav') or command.get('role') or ''}".strip()
        mc.emit_event(
            now_s,
            "operator",
            command.get("uav"),
            command=str(command.get("command")),
            accepted=outcome.accepted,
            reason=outcome.reason,
            line=f"{line}: {'accepted' if outcome.accepted else 'refused (' + outcome.reason + ')'}",
        )
        return outcome

    def _apply(self, mc: MissionHost, command: Mapping[str, Any], now_s: float) -> CommandOutcome:
        what = command.get("command")
        if mc.ended_at_s is not None:
            return CommandOutcome(False, "the mission is over")
        if self.aborting and what != "abort":
            return CommandOutcome(False, "the mission is being aborted")
        if what == "pause":
            if self.paused:
                return CommandOutcome(False, "already paused")
            self.paused = True
            return CommandOutcome(True)
        if what == "resume":
            if not self.paused and not self.held:
                return CommandOutcome(False, "not paused")
            self.paused = False
            self.held.clear()
            mc.wake()
            return CommandOutcome(True)
        if what == "recall":
            uav = command.get("uav")
            link = mc.uavs.get(uav) if isinstance(uav, str) else None
            if link is None:
                return CommandOutcome(False, f"no UAV {uav!r} in this mission")
            if link.lost:
                return CommandOutcome(False, f"{uav} is {link.status}")
            self._recall(mc, str(uav), now_s)
            return CommandOutcome(True)
        if what in ("return-all", "abort"):
            if what == "abort" and self.aborting:
                return CommandOutcome(False, "already aborting")
            self.paused = True
            for name, link in mc.uavs.items():
                if not link.lost:
                    self._recall(mc, name, now_s)
            self.aborting = what == "abort"
            return CommandOutcome(True)
        if what == "limit":
            return self._limit(mc, command)
        return CommandOutcome(False, f"unknown command {what!r}")

    def _limit(self, mc: MissionHost, command: Mapping[str, Any]) -> CommandOutcome:
        role, n = command.get("role"), command.get("limit")
        roles = {link.spec.role for link in mc.uavs.values()}
        if role not in roles:
            return CommandOutcome(
                False, f"no {role!r} UAVs in this mission (roles: {', '.join(sorted(roles))})"
            )
        if type(n) is not int or n < -1:
            return CommandOutcome(False, f"the limit must be a whole number >= 0 (or -1: none), got {n!r}")
        if n < 0:
            self.limits.pop(str(role), None)
        else:
            self.limits[str(role)] = n
        mc.wake()
        return CommandOutcome(True)

    def _recall(self, mc: MissionHost, uav: str, now_s: float) -> None:
        self.held.add(uav)
        mc.recall(uav, now_s, RECALL_REASON)

    def answer(self, mc: MissionHost, msg: OperatorCommand, now_s: float) -> CommandAnswer:
        """A command over the network: applied now, answered to the operator. ``masonry ctl`` sends it again
        until it hears the answer: a command already answered (its ``id``) is answered again, not applied twice."""
        answer = self.answered.get(msg.id) if msg.id else None
        if answer is None:
            command = {"command": msg.command, "uav": msg.uav, "role": msg.role, "limit": msg.limit}
            out = self.apply(mc, {k: v for k, v in command.items() if v is not None}, now_s)
            answer = CommandAnswer(MISSION_CONTROL, msg.id, msg.command, out.accepted, out.reason, now_s)
            if msg.id:
                self.answered[msg.id] = answer
        return answer

    def holds_dispatch(self) -> bool:
        """No assignment at all now (paused, or aborting)."""
        return self.paused or self.aborting

    def may_fly(self, mc: MissionHost, uav: str) -> bool:
        """May ``uav`` take a task now (not held, and its role under its limit)?"""
        return uav not in self.held and self.under_limit(mc, uav)

    def under_limit(self, mc: MissionHost, uav: str) -> bool:
        """Is ``uav``'s role under the operator's limit on it (none: True), counting the others of it flying?"""
        link = mc.uavs[uav]
        limit = self.limits.get(link.spec.role)
        if limit is None:
            return True
        flying = sum(
            1
            for name in mc.dispatcher.in_progress.values()
            if name != uav and mc.uavs[name].spec.role == link.spec.role
        )
        return flying < limit

    def _all_down(self, mc: MissionHost) -> bool:
        return not mc.dispatcher.in_progress and all(
            link.lost or (link.facts.on_pad and not link.taking_off) for link in mc.uavs.values()
        )
