"""The UAV model both machines share: the machine, the tick and the watchdogs (:mod:`masonry.fsm.states`).

A model owns one ``transitions`` HierarchicalMachine (``queued=True``, no auto transitions) and is ticked by
``step(now_s)``: it reads the flight controller's telemetry, runs the watchdogs declared for the current state
(:mod:`masonry.fsm.watchdogs`: link, battery, hold, fence), then the current leaf state's ``do_<state>`` handler
(which fires triggers when the state's work is done) and, while a motion is in hand, sends its
:class:`~masonry.fsm.navigator.Navigator`'s setpoint (a minimum-jerk reference tracked by the position PID,
paper, Section IV "UAV Control"). A lateral move with a :class:`~masonry.ports.ClearanceLink` runs the airspace
transit protocol beside the task machine (:class:`~masonry.fsm.transit.Transit`). The brick and adhesion UAVs
are :mod:`masonry.fsm.brick` and :mod:`masonry.fsm.adhesion`.

The model is built in layers, one responsibility each (:mod:`masonry.fsm.base`): motion and the transit
(:mod:`~masonry.fsm.routing`), the battery budget (:mod:`~masonry.fsm.budget`), the book of tasks
(:mod:`~masonry.fsm.taskbook`), the common states (:mod:`~masonry.fsm.common`); this module adds the machine and
the tick. What the task in hand has come to is one record, :attr:`UavModel.attempt` (:mod:`masonry.fsm.attempt`).

Frames: world ENU, body FLU; tool offsets (effector, nozzle, camera) come from the airframe and rotate with yaw.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any, ClassVar

from transitions.extensions import HierarchicalMachine

from masonry.errors import HardwareError
from masonry.fsm.attempt import Swing
from masonry.fsm.battery import DrainMeter
from masonry.fsm.common import CommonStates
from masonry.fsm.config import UavConfig
from masonry.fsm.fence import FenceWatch
from masonry.fsm.gates import for_kind as gates_for_kind
from masonry.fsm.navigator import Navigator
from masonry.fsm.phases import PhaseClock
from masonry.fsm.states import State, Transition, leaf_states
from masonry.fsm.transit import Transit
from masonry.fsm.watchdogs import TRIGGERS, Abort, Check, Failsafe, Watchdog, for_kind
from masonry.planner.tasks import Task
from masonry.ports import ClearanceLink, Clock, FlightController, MissionLink, TaskResult, Telemetry

#: The transit's states in which the UAV waits in the air for clearance (asking, or at a hold point).
_WAITING = frozenset({"ask", "hold"})


class UavModel(CommonStates):
    """What both UAV types share: the tick, telemetry failsafes, motion, takeoff/home/land and reporting.

    Attributes:
        state: the machine's current state (``pickup_estimate``...).
        trace: ``(t_s, state)`` for every state entered, starting with ``(t0, "idle")``.
        results: every TaskResult reported, in order.
        task: the task in hand, or None.
        attempt: what the UAV has done of the task in hand (:mod:`masonry.fsm.attempt`; the last task's until it
            takes the next).
        halt_reason: why the UAV went out of service (state ``halted``), or None.
        phase_clock: the seconds per phase of the task in hand (:mod:`masonry.fsm.phases`), sent with its result.
    """

    #: Build the machines with ``ignore_invalid_triggers=False``: a trigger fired from a state without such a
    #: transition raises ``transitions.MachineError`` (the test suite sets it, tests/conftest.py). Off in
    #: flight: the triggers fired there are all declared (docs/state-machines.md), and a UAV must not crash on
    #: one that is not.
    strict_triggers: ClassVar[bool] = False

    def __init__(
        self,
        config: UavConfig,
        fc: FlightController,
        link: MissionLink,
        clock: Clock,
        states: list[State],
        transitions: list[Transition],
        *,
        clearance: ClearanceLink | None = None,
    ) -> None:
        self.config = config
        self.fc = fc
        self.link = link
        self.clock = clock
        self.trace: list[tuple[float, str]] = []
        self.results: list[TaskResult] = []
        self.task: Task | None = None
        self.halt_reason: str | None = None
        self._now_s = clock.now_s()
        self._entered_s = self._now_s
        self._swing = Swing()  # the gate state's running mean speed (_gate_failure)
        self._tel: Telemetry | None = None
        self._next_task: Task | None = None
        self._halt_after_landing: str | None = None
        self.failsafe = Failsafe()
        self.nav = Navigator(config)
        self.transit = Transit(ignore_invalid_triggers=not self.strict_triggers)
        self.phase_clock = PhaseClock()
        self.clearance = clearance
        self.fence_watch = None if config.fence is None else FenceWatch(config.fence)
        # A link whose ground crew swaps the battery of a landed UAV before handing it its next task (the
        # mission handler's battery reserve): a low battery sends the UAV home to land, not out of service.
        self._battery_service = clearance is not None and clearance.swaps_batteries is True
        self._last_step_s = -math.inf
        #: The time (s) between this tick and the last (inf before the second): how soon the next one comes
        self.tick_interval_s = math.inf
        self._due_s = -math.inf  # when the next control tick is due (:meth:`step`)
        self._waiting_since_s: float | None = None  # since when it has waited in the air for clearance
        #: the battery's drain per airborne second, measured (masonry.fsm.battery)
        self.drain = DrainMeter()
        #: the first hover's identification (config.identify_first_hover) and what it gave (masonry.fsm.first_hover)
        self.first_hover = None
        self.hover_tuning = None
        self.attempt = self._new_attempt(0.0, 0.0)  # none yet: a fresh one with each task (_start_task)
        self._leaf_names = leaf_states(states)
        #: the cross-cutting checks run before each tick's work (masonry.fsm.watchdogs; add one here)
        self.watchdogs: tuple[Watchdog, ...] = for_kind(self.KIND)
        #: leaf state -> the watchdogs of ``_guarded_dogs`` (as they were asked) guarding it (:meth:`_guarding`)
        self._guarded: dict[str, tuple[tuple[int, Check, bool], ...]] = {}
        self._guarded_dogs = self.watchdogs
        #: the gate states' exit checks, run by their work after its own test (masonry.fsm.gates)
        self.gates = gates_for_kind(self.KIND)
        self.machine = HierarchicalMachine(
            model=self,
            states=copy.deepcopy(states),
            transitions=copy.deepcopy(transitions),
            initial="idle",
            queued=True,
            auto_transitions=False,
            ignore_invalid_triggers=not self.strict_triggers,
            after_state_change="_record_state",
        )
        self._do: dict[str, Callable[[Telemetry], None]] = {
            n: getattr(self, "do_" + n) for n in self._leaf_names
        }
        self.trace.append((self._now_s, self.state))

    # -- public ---------------------------------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        """Nothing to do: landed with no task (``idle`` on the ground), or out of service (``halted``)."""
        if self.state == "halted":
            return True
        return self.state == "idle" and self.task is None and (self._tel is None or self._tel.on_ground)

    def step(self, now_s: float) -> None:
        """One control tick at ``now_s``: telemetry, the state's watchdogs, the state's work, the velocity setpoint.

        Calls closer together than ``config.control_period_s`` return at once, so a simulation may tick the
        world faster than the UAV's control loop runs.
        """
        if now_s < self._due_s - 1e-9:
            return  # called faster than the control rate
        period_s = self._control_period_s()
        # the next tick on the grid of this one's due time, not a period after it came: a loop whose calls come
        # a hair early or late (a real autopilot's clock, masonry fly's 0.05 s sleeps) ticked a 0.1 s period at
        # 0.15 s every other tick, two past each due time out of three (7.8 Hz on the real PX4, issue 29); after a
        # stall of more than a period, a period after it (no burst of ticks to catch up)
        self._due_s = self._due_s + period_s if now_s < self._due_s + period_s else now_s + period_s
        step_s = now_s - self._last_step_s
        self._last_step_s = now_s
        self.tick_interval_s = step_s
        self._now_s = float(now_s)
        if self.task is not None:  # the time since the last tick, in the phase the UAV was in meanwhile
            self.phase_clock.tick_in(self._now_s, self.state, self.transit.state)
        if self.state == "halted":
            self._reject_tasks()
            return
        try:
            tel = self.fc.telemetry()
            self._tel = tel
            self._observe(tel, step_s)
            if self.watchdogs is not self._guarded_dogs:  # another set (a test's): ask each state again
                self._guarded.clear()
                self._guarded_dogs = self.watchdogs
            # masonry.fsm.watchdogs: those guarding the state as it is then (the checks read the model; only a
            # reaction to a verdict moves the machine, and the dogs after it are those of the state it left it in)
            guarding = self._guarded.get(self.state)
            if guarding is None:
                guarding = self._guarding(self.state)
            link_ok = tel.link_ok
            for i, check, needs_link in guarding:
                if link_ok or not needs_link:
                    verdict = check(self._now_s, tel, self)
                    if verdict is not None:
                        self._react(verdict)
                        self._dogs_after(i, tel)
                        break
            if not link_ok:
                return
            self._do[self.state](tel)
            if self.nav.active:
                velocity_mps, yaw_rate_radps = self.nav.step(self._now_s, tel)
                self.fc.send_velocity(velocity_mps, yaw_rate_radps)
        except HardwareError as exc:
            self._hardware_failure(str(exc))

    def _control_period_s(self) -> float:
        """The period (s) after which the next tick is due: ``config.control_period_s`` (a state may ask less)."""
        return self.config.control_period_s

    def _guarding(self, state: str) -> tuple[tuple[int, Check, bool], ...]:
        """The watchdogs guarding leaf ``state``, each with its index in :attr:`watchdogs`, its check and whether
        it needs the link (asked once per state: the tick looks them up)."""
        got = self._guarded[state] = tuple(
            (i, dog.check, dog.needs_link)
            for i, dog in enumerate(self.watchdogs)
            if dog.guards(state, self._TASK_STATES_SET)
        )
        return got

    def _dogs_after(self, reacted: int, tel: Telemetry) -> None:
        """The watchdogs after the one that moved the machine (index ``reacted``), as guard the state it is in now
        (each reaction moves on to the state it leaves the machine in)."""
        for i, dog in enumerate(self.watchdogs):
            if (
                i > reacted
                and dog.guards(self.state, self._TASK_STATES_SET)
                and (tel.link_ok or not dog.needs_link)
            ):
                verdict = dog.check(self._now_s, tel, self)
                if verdict is not None:
                    self._react(verdict)

    def _observe(self, tel: Telemetry, step_s: float) -> None:
        """The timers the watchdogs read (link down, waiting and held for clearance, outside the fence), the drain.

        The hold's runs in task states only (reset there and at a task's start)."""
        fs = self.failsafe
        if not tel.link_ok:
            fs.link_down_since_s = self._now_s if fs.link_down_since_s is None else fs.link_down_since_s
            return
        fs.link_down_since_s = None
        self._watch_mode(tel)
        self.drain.update(self._now_s, tel.battery_fraction, not tel.on_ground)
        waiting = self.transit.state in _WAITING
        if not waiting:
            self._waiting_since_s = None
        elif self._waiting_since_s is None:
            self._waiting_since_s = self._now_s
        elif self.task is not None:
            self.attempt.waited_s += step_s
        if self.state in self._TASK_STATES_SET:
            if not waiting or self.task is None or self.config.hold_patience_s is None:
                self.attempt.held_since_s = None
            elif self.attempt.held_since_s is None:
                self.attempt.held_since_s = self._now_s
        if self.fence_watch is not None and not tel.on_ground:
            self.fence_watch.observe(self._now_s, tel.position_m)

    def _watch_mode(self, tel: Telemetry) -> None:
        """The mode masonry flies in (the autopilot's as it is first heard armed in the take-off: masonry enters it
        before arming; forgotten on the ground, idle) and since when the autopilot reports another one
        (:func:`masonry.fsm.watchdogs.autopilot_mode_watch`). Not the mode at the take-off's end: a failsafe during
        the climb (a real PX4 on a loaded CI machine went to AUTO.LOITER then) would be taken for masonry's."""
        fs = self.failsafe
        if self.state == "idle":
            fs.flight_mode = None
        elif self.state == "takeoff" and tel.armed and fs.flight_mode is None:
            fs.flight_mode = tel.mode
        if fs.flight_mode is None or tel.mode == fs.flight_mode or self.state in ("takeoff", "land"):
            fs.foreign_mode_since_s = None
        elif fs.foreign_mode_since_s is None:
            fs.foreign_mode_since_s = self._now_s

    def _react(self, verdict: Abort) -> None:
        """Act on a watchdog's verdict (:data:`masonry.fsm.watchdogs.Action`)."""
        reason, action = verdict.reason, verdict.action
        if action == "battery_low" and not self._battery_service:
            self._halt_after_landing = reason  # retired after landing (a ground crew would swap the pack)
        if action == "retire":
            self.halt_reason = reason
        getattr(self, TRIGGERS[action])(reason=reason)

    # -- what the watchdogs read (masonry.fsm.watchdogs.Attempt) --------------------------------------------
    @property
    def entered_s(self) -> float:
        """When the current state was entered."""
        return self._entered_s

    @property
    def task_states(self) -> frozenset[str]:
        return self._TASK_STATES_SET

    @property
    def held_since_s(self) -> float | None:
        """Since when the task's transit has waited for clearance (the hold patience; None: not waiting)."""
        return self.attempt.held_since_s


def __getattr__(name: str) -> Any:
    """``masonry.fsm.model.BrickUav`` and ``AdhesionUav``: their old home (now :mod:`masonry.fsm.brick`, ...)."""
    if name == "BrickUav":
        from masonry.fsm.brick import BrickUav

        return BrickUav
    if name == "AdhesionUav":
        from masonry.fsm.adhesion import AdhesionUav

        return AdhesionUav
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
