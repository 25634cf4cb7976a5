"""The UAV model both machines share: the callbacks of :mod:`masonry.fsm.states`, on ports only.

A model owns one ``transitions`` HierarchicalMachine (``queued=True``, no auto transitions) and is ticked by
``step(now_s)``: it reads the flight controller's telemetry, runs the watchdogs declared for the current state
(:mod:`masonry.fsm.watchdogs`: link, battery, hold, fence), then the current leaf state's ``do_<state>`` handler
(which fires triggers when the state's work is done) and, while a motion is in hand, sends its
:class:`~masonry.fsm.navigator.Navigator`'s setpoint (a minimum-jerk reference tracked by the position PID,
paper, Section IV "UAV Control"). A lateral move with a :class:`~masonry.ports.ClearanceLink` runs the airspace
transit protocol beside the task machine (:class:`~masonry.fsm.transit.Transit`). The brick and adhesion UAVs
are :mod:`masonry.fsm.brick` and :mod:`masonry.fsm.adhesion`.

Frames: world ENU, body FLU; tool offsets (effector, nozzle, camera) come from the airframe and rotate with yaw.
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
from transitions.extensions import HierarchicalMachine

from masonry.errors import HardwareError
from masonry.fsm.battery import TAKEOFF_S, DrainMeter, flight_left_s, land_s, route_s
from masonry.fsm.config import UavConfig
from masonry.fsm.fence import FenceWatch
from masonry.fsm.navigator import Navigator
from masonry.fsm.phases import PhaseClock
from masonry.fsm.states import State, Transition, leaf_states
from masonry.fsm.transit import Transit
from masonry.fsm.watchdogs import TRIGGERS, Abort, Failsafe, Watchdog, for_kind
from masonry.planner.tasks import Task
from masonry.ports import (
    BATTERY_LOW_REASON,
    ClearanceAnswer,
    ClearanceLink,
    Clock,
    FlightController,
    MissionLink,
    TaskResult,
    Telemetry,
)

Vec3 = tuple[float, float, float]
log = logging.getLogger(__name__)
#: A UAV waiting in the air for clearance gives its task up once the flight left above the critical battery falls
#: under this many times its way out of the task (plus ``battery_return_wait_s``): the estimate's margin.
RESERVE_FACTOR = 1.25
#: The transit's states in which the UAV waits in the air for clearance (asking, or at a hold point).
_WAITING = frozenset({"ask", "hold"})
#: The takeoff is over this close under its altitude (the autopilot flies it; the machine then takes over) ...
_TAKEOFF_SHORT_M = 0.1
#: ... once climbing slower than this: an autopilot that shapes its climb (ArduCopter's PSC_JERK_Z) and was taken
#: over at 0.48 m/s rose 0.12 m past the layer its pad's column reaches (issue 19)
_TAKEOFF_SETTLE_MPS = 0.2
#: Disarmed on the ground this long after a take-off was asked for: arm and ask again, at most this often.
_TAKEOFF_RETRY_S = 2.0
_TAKEOFF_RETRIES = 2
_TAKEOFF_STUCK_S = 6.0
#: A swinging UAV this far off its point when a gate fails was blown off (a position loop too fast for its
#: autopilot swings about the point, tens of centimetres; gusts in moderate turbulence carried UAVs 1-40 m).
_BLOWN_OFF_M = 1.0


class UavModel:
    """What both UAV types share: the tick, telemetry failsafes, motion, takeoff/home/land and reporting.

    Attributes:
        state: the machine's current state (``pickup_estimate``...).
        trace: ``(t_s, state)`` for every state entered, starting with ``(t0, "idle")``.
        results: every TaskResult reported, in order.
        task: the task in hand, or None.
        halt_reason: why the UAV went out of service (state ``halted``), or None.
        phase_clock: the seconds per phase of the task in hand (:mod:`masonry.fsm.phases`), sent with its result.
    """

    state: str
    # Triggers (bound by the machine; declared here so type checkers see them).
    assign: Callable[..., bool]
    retire: Callable[..., bool]
    airborne: Callable[..., bool]
    arrived: Callable[..., bool]
    reached: Callable[..., bool]
    finish: Callable[..., bool]
    landed: Callable[..., bool]
    abort: Callable[..., bool]
    recover: Callable[..., bool]
    lost: Callable[..., bool]
    giveup: Callable[..., bool]

    KIND = ""
    #: Build the machines with ``ignore_invalid_triggers=False``: a trigger fired from a state without such a
    #: transition raises ``transitions.MachineError`` (the test suite sets it, tests/conftest.py). Off in
    #: flight: the triggers fired there are all declared (docs/state-machines.md), and a UAV must not crash on
    #: one that is not.
    strict_triggers: ClassVar[bool] = False
    _TASK_STATES_SET: ClassVar[frozenset[str]] = frozenset()

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
        self._task_start_s = 0.0
        self._entered_s = self._now_s
        self._takeoff_tries: list[Any] = [self._now_s, 1, 0.0]  # the take-off asked at, tries, climb (m)
        self._swing: list[float] = [
            math.nan,
            0.0,
            0.0,
        ]  # the gate's state entered at, last tick, mean speed^2
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
        self.held_since_s: float | None = None  # the task's transit waiting for clearance (hold patience)
        self._waiting_since_s: float | None = None  # since when it has waited in the air for clearance
        #: seconds the task in hand has waited in the air for clearance so far, and the waiting it was taken with
        self.task_waited_s = 0.0
        self.task_wait_budget_s = 0.0
        #: the battery's drain per airborne second, measured (masonry.fsm.battery)
        self.drain = DrainMeter()
        self._leaf_names = leaf_states(states)
        #: the cross-cutting checks run before each tick's work (masonry.fsm.watchdogs; add one here)
        self.watchdogs: tuple[Watchdog, ...] = for_kind(self.KIND)
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
        if now_s - self._last_step_s < self.config.control_period_s - 1e-9:
            return  # called faster than the control rate
        step_s = now_s - self._last_step_s
        self._last_step_s = now_s
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
            for dog in self.watchdogs:  # masonry.fsm.watchdogs: those guarding the state (as it is then)
                if (tel.link_ok or not dog.needs_link) and dog.guards(self.state, self._TASK_STATES_SET):
                    verdict = dog.check(self._now_s, tel, self)
                    if verdict is not None:
                        self._react(verdict)
            if not tel.link_ok:
                return
            self._do[self.state](tel)
            if self.nav.active:
                velocity_mps, yaw_rate_radps = self.nav.step(self._now_s, tel)
                self.fc.send_velocity(velocity_mps, yaw_rate_radps)
        except HardwareError as exc:
            self._hardware_failure(str(exc))

    def _observe(self, tel: Telemetry, step_s: float) -> None:
        """The timers the watchdogs read (link down, waiting and held for clearance, outside the fence), the drain.

        The hold's runs in task states only (reset there and at a task's start)."""
        fs = self.failsafe
        if not tel.link_ok:
            fs.link_down_since_s = self._now_s if fs.link_down_since_s is None else fs.link_down_since_s
            return
        fs.link_down_since_s = None
        self.drain.update(self._now_s, tel.battery_fraction, not tel.on_ground)
        waiting = self.transit.state in _WAITING
        if not waiting:
            self._waiting_since_s = None
        elif self._waiting_since_s is None:
            self._waiting_since_s = self._now_s
        elif self.task is not None:
            self.task_waited_s += step_s
        if self.state in self._TASK_STATES_SET:
            if not waiting or self.task is None or self.config.hold_patience_s is None:
                self.held_since_s = None
            elif self.held_since_s is None:
                self.held_since_s = self._now_s
        if self.fence_watch is not None and not tel.on_ground:
            self.fence_watch.observe(self._now_s, tel.position_m)

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

    def site_text(self) -> str:
        x, y, z = self.transit.site_m
        return f"({x:.2f}, {y:.2f}, {z:.2f})"

    def battery_short(self, tel: Telemetry) -> str | None:
        """Why the battery cannot carry on with the task (None: it can); the reason starts with
        :data:`BATTERY_LOW_REASON` (mission control does not count such a failure as an attempt).

        Below ``battery_low_fraction``; or, waiting in the air for clearance, once the flight left above
        ``battery_critical_fraction`` falls under :data:`RESERVE_FACTOR` times the way out of the task (home, or
        the put-back of a brick) plus ``battery_return_wait_s`` of waiting on it."""
        cfg = self.config
        if tel.battery_fraction < cfg.battery_low_fraction:
            return f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%})"
        drain = self.drain.drain_per_s
        if self._waiting_since_s is None or drain is None:
            return None
        left_s = flight_left_s(tel.battery_fraction, cfg.battery_critical_fraction, drain)
        exit_s, way = self._exit_s(tel)
        if left_s >= RESERVE_FACTOR * exit_s + cfg.battery_return_wait_s:
            return None
        return (
            f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%}): waited {self._now_s - self._waiting_since_s:.0f} s "
            f"for clearance to {self.site_text()}; {left_s:.0f} s of flight left, {way} needs {exit_s:.0f} s"
        )

    # -- the battery budget (masonry.fsm.battery) ---------------------------------------------------------
    def _layer_m(self, start_m: Vec3, end_m: Vec3) -> float:
        """The altitude of a lateral leg between two points, as the budget counts it: the higher of the two (and
        with mission control, at least the cruise altitude: the lowest layer, the one a flight is given when the
        airspace is free; a higher one comes with a wait, which the waiting budget covers), or without mission
        control the UAV's fixed ``lateral_altitude_m``."""
        cfg = self.config
        if self.clearance is None and cfg.lateral_altitude_m is not None:
            return cfg.lateral_altitude_m
        return max(start_m[2], end_m[2], cfg.cruise_altitude_m if self.clearance is not None else -math.inf)

    def _route_s(self, start_m: Vec3, end_m: Vec3) -> float:
        """What the flight from ``start_m`` to ``end_m`` takes with no wait (:func:`masonry.fsm.battery.route_s`)."""

        def leg_s(a: Vec3, b: Vec3) -> float:
            return self.nav.leg_duration_s(np.asarray(a, dtype=float), np.asarray(b, dtype=float))

        speed = self.config.layer_vertical_speed_mps
        return route_s(leg_s, speed, start_m, end_m, self._layer_m(start_m, end_m))

    def _home_s(self, from_m: Vec3) -> float:
        """The flight home from ``from_m`` and the landing there."""
        cfg = self.config
        over_home = (cfg.home_m[0], cfg.home_m[1], cfg.cruise_altitude_m)
        return self._route_s(from_m, over_home) + land_s(cfg.cruise_altitude_m - cfg.home_m[2])

    def _exit_s(self, tel: Telemetry) -> tuple[float, str]:
        """What giving the task up now takes, with no wait, and what it is (subclasses: a put-back first)."""
        return self._home_s(tel.position_m), "the way home"

    def _task_flight_s(self, task: Task, from_m: Vec3) -> tuple[float, Vec3]:
        """The flight and work of ``task`` from ``from_m`` with no wait, and where it ends (subclasses)."""
        return 0.0, from_m

    def _wait_budget_s(self) -> float:
        """The waiting for clearance a task is taken with: ``battery_wait_budget_s``, at most the hold patience."""
        cfg = self.config
        patience = math.inf if cfg.hold_patience_s is None else cfg.hold_patience_s
        return min(cfg.battery_wait_budget_s, patience)

    def _flight_need_s(self, task: Task) -> float | None:
        """The flight ``task`` takes from where the UAV is, with no wait: the take-off if on the ground, its
        flight and work, the flight home and the landing (None: no telemetry yet)."""
        tel = self._tel
        if tel is None:
            return None
        flight_s, end_m = self._task_flight_s(task, tel.position_m)
        return (TAKEOFF_S if tel.on_ground else 0.0) + flight_s + self._home_s(end_m)

    def task_budget_s(self, task: Task) -> float | None:
        """What ``task`` needs of the battery from where the UAV is, in seconds of flight: its flight with the
        way home (:meth:`_flight_need_s`) and the waiting budget (:meth:`_wait_budget_s`), the latter cut to what
        a full pack leaves beside the flight (None: no telemetry, or no drain measured yet)."""
        flight_s, drain = self._flight_need_s(task), self.drain.drain_per_s
        if flight_s is None or drain is None:
            return None
        full_s = flight_left_s(1.0, self.config.battery_low_fraction, drain)
        return flight_s + max(0.0, min(self._wait_budget_s(), full_s - flight_s))

    def battery_shortfall(self, task: Task) -> str | None:
        """Why the battery does not cover ``task`` now (the mission handler then holds it for a swap), or None:
        it does, the drain is not measured yet, or not even a full pack would (:meth:`_take` refuses the task).

        Covered: the flight left above ``battery_low_fraction`` at the measured drain is at least
        :meth:`task_budget_s`."""
        tel, drain, low = self._tel, self.drain.drain_per_s, self.config.battery_low_fraction
        need_s = self.task_budget_s(task)
        if tel is None or drain is None or need_s is None or self._pack_too_small(task) is not None:
            return None
        left_s = flight_left_s(tel.battery_fraction, low, drain)
        if left_s >= need_s - 1e-6:
            return None
        return (
            f"battery {tel.battery_fraction:.0%}: {left_s:.0f} s of flight above {low:.0%}, "
            f"task {task.id} needs {need_s:.0f} s"
        )

    def _pack_too_small(self, task: Task) -> str | None:
        """Not even a full pack covers ``task``'s flight from here, with no wait at all (a counted failure: the
        mission stops on it, saying why)."""
        drain, low = self.drain.drain_per_s, self.config.battery_low_fraction
        flight_s = self._flight_need_s(task)
        if drain is None or flight_s is None or flight_s <= flight_left_s(1.0, low, drain):
            return None
        return (
            f"a full battery pack gives {flight_left_s(1.0, low, drain):.0f} s of flight above {low:.0%}; "
            f"task {task.id} needs {flight_s:.0f} s from here (its flight and the way home, with no wait)"
        )

    # -- failsafes -----------------------------------------------------------------------------------------
    def _hardware_failure(self, reason: str) -> None:
        state = self.state
        if state == "halted":
            return
        if state == "idle":
            self.halt_reason = reason
            self.retire(reason=reason)
            return
        if state == "emergency":
            if self._now_s - self._entered_s > self.config.link_lost_timeout_s:
                self.giveup(reason=reason)
            return
        self.lost(reason=reason)

    def _reject_tasks(self) -> None:
        task = self.link.poll_task()
        if task is not None:
            self._report(
                TaskResult(
                    task.id, "failed", 0.0, reason=f"{self.config.name} is out of service: {self.halt_reason}"
                )
            )

    def fail_task(self, *args: Any, reason: str = "unrecoverable error", **kwargs: Any) -> None:
        """Report the task in hand (if any) as failed with ``reason``."""
        if self.task is not None:
            self._report(
                TaskResult(
                    self.task.id,
                    "failed",
                    self._now_s - self._task_start_s,
                    reason=reason,
                    phases=self.phase_clock.stop(),
                )
            )
            self.task = None

    def has_next_task(self, *args: Any, **kwargs: Any) -> bool:
        return self._next_task is not None

    def must_halt(self, *args: Any, **kwargs: Any) -> bool:
        return self._halt_after_landing is not None

    # -- bookkeeping ---------------------------------------------------------------------------------------
    def _record_state(self, *args: Any, **kwargs: Any) -> None:
        self._entered_s = self._now_s
        self.trace.append((self._now_s, self.state))
        if self.task is not None:
            self.link.report_progress(self.task.id, self.state, self._now_s)

    def _report(self, result: TaskResult) -> None:
        self.results.append(result)
        self.link.report_result(result)

    def _take(self, task: Task | None) -> Task | None:
        """Vet a task from the link: one of the wrong kind is reported failed at once."""
        if task is None:
            return None
        if task.kind != self.KIND:
            self._report(
                TaskResult(
                    task.id,
                    "failed",
                    0.0,
                    reason=f"{self.config.name} is a {self.KIND} UAV, "
                    f"it cannot fly {task.kind} task {task.id}",
                )
            )
            return None
        problem = self._task_problem(task) or self._pack_too_small(task)
        if problem is not None:
            self._report(TaskResult(task.id, "failed", 0.0, reason=problem))
            return None
        return task

    def _task_problem(self, task: Task) -> str | None:
        return None

    def _start_task(self, task: Task) -> None:
        self.task = task
        self.held_since_s = None
        self._task_start_s = self._now_s
        self.phase_clock.start(self._now_s)
        budget_s, flight_s = self.task_budget_s(task), self._flight_need_s(task)
        self.task_waited_s = 0.0
        self.task_wait_budget_s = (
            self._wait_budget_s() if budget_s is None or flight_s is None else budget_s - flight_s
        )
        self._begin_task(task)

    def _begin_task(self, task: Task) -> None:
        """Reset the per-task counters (subclasses)."""

    def _report_done(self, **fields: Any) -> None:
        """Report the task in hand done (with ``fields``); the UAV has no task any more."""
        assert self.task is not None
        self._report(
            TaskResult(
                self.task.id,
                "done",
                self._now_s - self._task_start_s,
                phases=self.phase_clock.stop(),
                **fields,
            )
        )
        self.task = None

    def _may_take_task(self, tel: Telemetry) -> bool:
        """A task may be started now: the UAV is not to retire and its battery is not low."""
        return (
            self._halt_after_landing is None
            and tel.battery_fraction >= self.config.battery_low_fraction
            and (self.fence_watch is None or self.fence_watch.since_s is None)  # not while outside its fence
        )

    def _complete_task(self, **fields: Any) -> None:
        self._report_done(**fields)
        self._next_task = self._take(self.link.poll_task())
        if self._next_task is not None:
            self._start_task(self._next_task)
        self.finish()
        self._next_task = None

    # -- motion (the navigator's, the transit's) ----------------------------------------------------------
    def _stop(self) -> None:
        self.transit.drop()
        self.nav.stop()

    def _hold(self, tel: Telemetry, target_m: np.ndarray | None = None, yaw_rad: float | None = None) -> None:
        """Hover at ``target_m`` (default: where the UAV is) with the given yaw (default: keep it)."""
        self.nav.hold(self._now_s, tel, target_m, yaw_rad)

    def _fly_to(
        self,
        tel: Telemetry,
        target_m: np.ndarray,
        duration_s: float | None = None,
        yaw_rad: float | None = None,
        from_rest: bool = False,
    ) -> None:
        """One minimum-jerk leg to rest at ``target_m`` (:meth:`Navigator.fly_to`)."""
        self.nav.fly_to(self._now_s, tel, target_m, duration_s, yaw_rad, from_rest)

    def _fly_line(self, tel: Telemetry, start_m: np.ndarray, end_m: np.ndarray, speed_mps: float) -> None:
        """Track ``start -> end`` at constant ``speed_mps`` (reference starts at ``start`` now)."""
        self.nav.fly_line(self._now_s, start_m, end_m, speed_mps)

    def _yaw_error(self, tel: Telemetry) -> float:
        return self.nav.yaw_error_rad(tel)

    def _route(
        self,
        tel: Telemetry,
        target_m: np.ndarray,
        yaw_rad: float | None = None,
        top_m: float | None = None,
        to_m: np.ndarray | None = None,
    ) -> None:
        """Go to ``target_m`` climbing first if it is higher, descending last if it is lower (never diagonal).

        With a clearance link (mission control's airspace, docs/safety.md) a lateral move is a *transit*: the
        UAV first asks for the column over the target, hovering where it is; then climbs (or descends) to the
        layer it is given, flies there, and descends over the target once the column is its (until then it
        waits at its layer at the hold point it is given). Without one, with a fixed
        ``config.lateral_altitude_m``, the lateral leg flies at that altitude. ``top_m``: the highest altitude
        the UAV will reach while working at the target (default: the target's), ``to_m`` where that work ends if
        it moves along a segment (an adhesion UAV spraying): mission control reserves both.
        """
        self.transit.drop()
        if self.clearance is None:
            self.nav.route(self._now_s, tel, target_m, yaw_rad)
            return
        # even a move of a few centimetres (the next adhesion segment starts where the last one ended): the
        # work there is another span of airspace, which mission control must reserve
        target = np.asarray(target_m, dtype=float)
        self.nav.legs_from_rest = False
        self.transit.begin(
            (float(target[0]), float(target[1]), float(target[2])),
            top_m,
            None if to_m is None else (float(to_m[0]), float(to_m[1]), float(to_m[2])),
        )
        # hover until mission control answers, once come to rest smoothly: it asks once settled, and the flight
        # it is granted starts from rest where it says it is
        stop = self.nav.stop_point_m(tel)
        if self.nav.rests_at(tel, stop):
            self._fly_to(tel, stop, 0.1, yaw_rad=yaw_rad, from_rest=True)  # at rest there already
        else:
            self._fly_to(tel, stop, yaw_rad=yaw_rad)

    def _advance(self, tel: Telemetry, tolerance_m: float | None = None) -> bool:
        """Move the route on at the end of a leg (its next leg, the transit's next phase); True once the whole
        motion is over and the UAV within ``tolerance_m`` of its end."""
        if not self.nav.at_end(self._now_s, tel, tolerance_m):
            return False
        if self.nav.legs:
            self.nav.next_leg(self._now_s, tel)
            return False
        if self.transit.active:
            return self._transit_step(tel)
        return True

    def _transit_step(self, tel: Telemetry) -> bool:
        """A transit's motion is over (see :meth:`_route`): ask, go on, or finish; True when it has arrived."""
        assert self.clearance is not None
        transit = self.transit
        if transit.state == "down":
            transit.arrive()
            self.clearance.end_transit(transit.site_m)
            return True
        if self.nav.settling_since_s is None:
            self.nav.settling_since_s = self._now_s
        if not self.nav.settled(self._now_s, tel):
            self.nav.wait(self._now_s)  # let it settle first (a leg timeout does not run meanwhile)
            return False
        answer = self.clearance.request_clearance(transit.site_m, transit.top_m, transit.to_m)
        if answer is None:
            self.nav.wait(self._now_s)  # no answer yet: hover (a leg timeout does not run meanwhile)
            return False
        p = np.asarray(tel.position_m, dtype=float)
        layer = self._transit_layer_m(answer, p)
        if answer.granted:
            self._granted(tel, p, answer.layer_m if answer.layer_m is not None else layer)
        else:
            self._refused(tel, p, answer.hold_m, layer)
        return False

    def _transit_layer_m(self, answer: ClearanceAnswer, p: np.ndarray) -> float:
        """The altitude of the transit's lateral legs: the one it has, else the answer's, else where it is."""
        layer = self.transit.layer_m
        if layer is None:
            layer = answer.layer_m
            if layer is None:  # no layers: the altitude it is at (or the target's, if higher)
                layer = self.config.lateral_altitude_m or max(float(p[2]), float(self.transit.site_m[2]))
        return layer

    def _granted(self, tel: Telemetry, p: np.ndarray, layer: float) -> None:
        """The column is the UAV's: fly there at ``layer`` (from a hold point perhaps another layer) and down."""
        self.transit.layer_m = layer
        self.transit.grant()
        target = np.array(self.transit.site_m)
        if math.hypot(target[0] - p[0], target[1] - p[1]) <= 0.05:
            # already over the site: no lateral leg, no layer
            self.nav.low_route(self._now_s, tel, p, target, self.nav.target_yaw_rad, from_rest=True)
        else:
            self.nav.layer_route(self._now_s, tel, p, target, layer, self.nav.target_yaw_rad)

    def _refused(self, tel: Telemetry, p: np.ndarray, hold: Vec3 | None, layer: float) -> None:
        """Not yet: wait at the hold point given (flying there at ``layer``), or where the UAV is."""
        first = self.transit.state == "ask"
        if hold is not None and (first or math.hypot(hold[0] - p[0], hold[1] - p[1]) > 0.05):
            self.transit.layer_m = layer
            self.transit.wait()
            self.nav.layer_route(
                self._now_s, tel, p, np.array([hold[0], hold[1], layer]), layer, self.nav.target_yaw_rad
            )
        else:
            self.nav.wait(self._now_s)

    # -- common states -------------------------------------------------------------------------------------
    def enter_idle(self, *args: Any, **kwargs: Any) -> None:
        self._stop()

    def do_idle(self, tel: Telemetry) -> None:
        if not tel.on_ground and tel.armed:
            return  # not ours to fly (should not happen)
        if tel.battery_fraction < self.config.battery_low_fraction and not self._battery_service:
            self.halt_reason = f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%})"
            self.retire(reason=self.halt_reason)
            return
        task = self._take(
            self.link.poll_task()
        )  # with a battery service: handed over once the pack is swapped
        if task is not None:
            self._start_task(task)
            self.assign(task=task)

    def enter_takeoff(self, *args: Any, **kwargs: Any) -> None:
        self._stop()
        tel = self._tel
        assert tel is not None
        self.nav.pid.reset()
        if not tel.armed:
            self.fc.arm()
        climb_m = max(0.3, self._transit_altitude_m() - tel.position_m[2])
        self.fc.takeoff(climb_m)
        self._takeoff_tries = [self._now_s, 1, climb_m]  # when and how often it was asked, and the climb
        x, y, z = tel.position_m
        self.nav.target_m = np.array(
            [x, y, z + climb_m]
        )  # where the autopilot takes it (the machine hovers there next)

    def do_takeoff(self, tel: Telemetry) -> None:
        if (
            not tel.on_ground
            and tel.position_m[2] >= self._transit_altitude_m() - _TAKEOFF_SHORT_M
            and abs(tel.velocity_mps[2]) <= _TAKEOFF_SETTLE_MPS
        ):
            self.airborne()
        elif tel.on_ground and self._retry_takeoff(tel):
            pass
        elif self._now_s - self._entered_s > self.config.takeoff_timeout_s:
            # the flight controller's own account, where it keeps one (the MAVLink adapter's PX4 climb monitor)
            why = getattr(self.fc, "takeoff_problem", None)
            self.abort(
                reason=f"takeoff did not reach {self._transit_altitude_m():.2f} m "
                f"within {self.config.takeoff_timeout_s:.0f} s" + (f": {why}" if isinstance(why, str) else "")
            )

    def _swinging(self, tel: Telemetry) -> str | None:
        """The reason to fail a gate (hover, alignment) now: the UAV swings instead of settling (or None).

        The mean squared speed over ``swing_window_s`` (exponentially weighted), from the gate state's entry; past
        ``swing_patience_s`` after the leg's planned end, its root above ``swing_speed_mps`` fails the attempt.
        """
        cfg = self.config
        swing = self._swing
        if swing[0] != self._entered_s:
            swing[0], swing[1], swing[2] = self._entered_s, self._now_s, 0.0
        dt = self._now_s - swing[1]
        swing[1] = self._now_s
        vx, vy, vz = tel.velocity_mps
        swing[2] += min(1.0, dt / cfg.swing_window_s) * (vx * vx + vy * vy + vz * vz - swing[2])
        if self._now_s < self.nav.end_s + cfg.swing_patience_s or swing[2] <= cfg.swing_speed_mps**2:
            return None
        off_m = math.dist(tel.position_m, self.nav.target_m)
        head = (
            f"swinging at {math.sqrt(swing[2]):.2f} m/s rms, {off_m:.2f} m off, "
            f"{self._now_s - self.nav.end_s:.0f} s after the leg's end: "
        )
        if off_m > _BLOWN_OFF_M:
            # a loop too fast for its autopilot swings about the point; this far off, the air moved it (issue 18)
            return head + "blown off by gusts beyond what the autopilot holds against"
        return head + (
            "the position loop is too fast for this autopilot's lag (measure it: masonry fly --identify; "
            "docs/hardware.md), or gusts"
        )

    def _retry_takeoff(self, tel: Telemetry) -> bool:
        """Still on the ground after asking for the take-off: ask again (at most twice), arming first if the
        autopilot disarmed; after ``_TAKEOFF_RETRY_S`` disarmed, ``_TAKEOFF_STUCK_S`` armed (motors spool up
        first: ArduCopter leaves the ground about 3.5 s after arming).

        ArduCopter SITL sometimes armed, acknowledged the take-off and stayed on the ground until its
        DISARM_DELAY (10 s) disarmed it ("Arming motors", "Disarming motors"): the take-off then timed out
        (issue 19).
        """
        asked_s, tries, climb_m = self._takeoff_tries
        waited = self._now_s - asked_s
        if tries > _TAKEOFF_RETRIES or waited < (_TAKEOFF_STUCK_S if tel.armed else _TAKEOFF_RETRY_S):
            return False
        log.warning(
            "%s: still on the ground %.1f s after the take-off (%s): asking again",
            self.config.name,
            waited,
            "armed" if tel.armed else "disarmed",
        )
        if not tel.armed:
            self.fc.arm()
        self.fc.takeoff(climb_m)
        self._takeoff_tries = [self._now_s, tries + 1, climb_m]
        return True

    def _transit_altitude_m(self) -> float:
        return self.config.cruise_altitude_m

    def enter_home(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        home = self.config.home_m
        z = max(self.config.cruise_altitude_m, tel.position_m[2])
        if self.config.lateral_altitude_m is not None or self.clearance is not None:
            z = self.config.cruise_altitude_m  # down from the layer over home (with clearance), then land
        self._route(tel, np.array([home[0], home[1], z]))

    def do_home(self, tel: Telemetry) -> None:
        if tel.on_ground:
            # still on the ground: a task given up before its take-off had lifted it (a recall at once, on
            # the shaped arducopter vehicle): land (disarm) and take off afresh for the next task, since an
            # autopilot ignores velocity setpoints on the ground (it flew "pickup_goto" on its pad for 30 s).
            # Or landed and disarmed by the autopilot's own battery failsafe on the way: landed (it hovered in
            # `home` on the ground for ever, a stalled mission, before)
            self.arrived()
            return
        # A task assigned on the way home turns the UAV back at once (instead of landing, idling and taking
        # off again), unless the UAV is to retire or its battery is low.
        if self._may_take_task(tel):
            task = self._take(self.link.poll_task())
            if task is not None:
                self._start_task(task)
                self.assign(task=task)
                return
        if self._advance(tel):
            self.arrived()

    def enter_land(self, *args: Any, **kwargs: Any) -> None:
        self._stop()
        self.fc.land()

    def do_land(self, tel: Telemetry) -> None:
        if tel.on_ground:
            if tel.armed:
                self.fc.disarm()
            self._on_landed()
            if self._halt_after_landing is not None:
                self.halt_reason = self._halt_after_landing
            self.landed()

    def _on_landed(self) -> None:
        """Actuators to their resting state after touchdown (subclasses)."""

    def enter_failsafe(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self._safe_actuators()
        self._hold(tel)

    def do_failsafe(self, tel: Telemetry) -> None:
        if tel.battery_fraction < self.config.battery_critical_fraction:
            self._halt_after_landing = f"battery critical ({tel.battery_fraction:.0%})"
            self.lost(reason=self._halt_after_landing)
        else:
            self.recover()

    def _safe_actuators(self) -> None:
        """Make the tool safe after a failure (subclasses: close the valve...)."""

    def enter_emergency(self, *args: Any, reason: str = "unrecoverable error", **kwargs: Any) -> None:
        self._stop()
        self.halt_reason = reason
        try:
            self._safe_actuators()
        except HardwareError:
            pass
        tel = self._tel
        # LAND is commanded once. It is tried again only while it has not gone through (rejected, unanswered,
        # link down) and the autopilot is still in the mode it was in here: a pilot who has switched modes
        # (or the autopilot's own failsafe) has the UAV, and masonry never fights a mode change.
        self.failsafe.mode = tel.mode if tel is not None else None
        self.failsafe.land_pending = True
        self.failsafe.land_tried_s = -math.inf
        self._command_land(tel)

    #: Seconds between tries of a LAND command that did not go through (emergency).
    LAND_RETRY_S = 1.0

    def _command_land(self, tel: Telemetry | None) -> None:
        if tel is not None and (tel.landing or tel.on_ground):
            self.failsafe.land_pending = False  # already landing (the autopilot's failsafe) or down
            return
        self.failsafe.land_tried_s = self._now_s
        try:
            self.fc.land()
        except HardwareError:
            return  # tried again later; meanwhile the autopilot's own failsafe lands it
        self.failsafe.land_pending = False

    def do_emergency(self, tel: Telemetry) -> None:
        if tel.on_ground:
            self.landed()
            return
        fs = self.failsafe
        if not fs.land_pending:
            return
        if tel.landing or tel.mode != fs.mode:
            fs.land_pending = False  # landing, or a pilot took over: never re-send LAND
        elif self._now_s - fs.land_tried_s >= self.LAND_RETRY_S:
            self._command_land(tel)

    def enter_halted(self, *args: Any, reason: str | None = None, **kwargs: Any) -> None:
        self._stop()
        if self.halt_reason is None:
            self.halt_reason = reason or self._halt_after_landing or "halted"

    def do_halted(self, tel: Telemetry) -> None:
        self._reject_tasks()


def __getattr__(name: str) -> Any:
    """``masonry.fsm.model.BrickUav`` and ``AdhesionUav``: their old home (now :mod:`masonry.fsm.brick`, ...)."""
    if name == "BrickUav":
        from masonry.fsm.brick import BrickUav

        return BrickUav
    if name == "AdhesionUav":
        from masonry.fsm.adhesion import AdhesionUav

        return AdhesionUav
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
