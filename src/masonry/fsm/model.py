"""The brick and adhesion UAV models: the callbacks of the machines in :mod:`masonry.fsm.states`, on ports only.

A model owns one ``transitions`` HierarchicalMachine (``queued=True``, no auto transitions) and is ticked by
``step(now_s)``: it reads the flight controller's telemetry, checks the failsafes, runs the current leaf state's
``do_<state>`` handler (which fires triggers when the state's work is done) and, while a motion target is active,
turns it into a velocity setpoint: a minimum-jerk reference (``masonry.motion.MinJerk``) tracked by the
position PID with the reference velocity as feed-forward (paper, Section IV "UAV Control").

Frames: world ENU, body FLU; tool offsets (effector, nozzle, camera) come from the airframe and rotate with yaw.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from transitions.extensions import HierarchicalMachine

from masonry.errors import HardwareError
from masonry.fsm.config import UavConfig
from masonry.fsm.states import (
    ADHESION_STATES,
    ADHESION_TASK_STATES,
    ADHESION_TRANSITIONS,
    BRICK_STATES,
    BRICK_TASK_STATES,
    BRICK_TRANSITIONS,
    State,
    Transition,
    leaf_states,
)
from masonry.geometry import R_world_body, rot_z
from masonry.motion import PID, MinJerk
from masonry.perception.types import TagPose
from masonry.planner.tasks import AdhesionTask, BrickTask, Task
from masonry.ports import (
    BATTERY_LOW_REASON,
    Camera,
    Clock,
    FlightController,
    Gripper,
    MissionLink,
    Sprayer,
    TaskResult,
    Telemetry,
)
from masonry.timing import MIN_JERK_PEAK_TO_MEAN_SPEED, MIN_LEG_S

_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False
_ZERO_FF = (0.0, 0.0, 0.0)  # no velocity feed-forward, as plain floats for the PID
#: The takeoff is over this close under its altitude (the autopilot flies it; the machine then takes over).
_TAKEOFF_SHORT_M = 0.1
#: A UAV this close to the end of its leg (or takeoff) when it asks for a transit hovers at that end.
_END_NEAR_M = 0.15


def _wrap(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


class UavModel:
    """What both UAV types share: the tick, telemetry failsafes, motion, takeoff/home/land and reporting.

    Attributes:
        state: the machine's current state (``pickup_estimate``...).
        trace: ``(t_s, state)`` for every state entered, starting with ``(t0, "idle")``.
        results: every TaskResult reported, in order.
        task: the task in hand, or None.
        halt_reason: why the UAV went out of service (state ``halted``), or None.
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
    _TASK_STATES: tuple[str, ...] = ()

    def __init__(
        self,
        config: UavConfig,
        fc: FlightController,
        link: MissionLink,
        clock: Clock,
        states: list[State],
        transitions: list[Transition],
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
        self._tel: Telemetry | None = None
        self._next_task: Task | None = None
        self._halt_after_landing: str | None = None
        self._emergency_mode: str | None = None  # the autopilot's mode when the emergency began
        self._land_pending = False  # emergency: LAND still to be commanded
        self._land_tried_s = -math.inf
        self._link_down_since_s: float | None = None
        self._pid = PID(config.pid_gains)
        self._velocity_lag_s = float(config.velocity_lag_s)
        self._motion = False
        self._legs: list[tuple[np.ndarray, float | None]] = []
        self._traj: MinJerk | None = None
        self._coef: list[list[float]] = []
        self._last_step_s = -math.inf
        self._traj_t0_s = 0.0
        self._traj_end_s = 0.0
        self._target = np.zeros(3)
        self._target_yaw: float | None = None
        self._ref_speed_mps = 0.0
        self._line: tuple[np.ndarray, np.ndarray, float] | None = None  # start, unit direction, length
        # a transit in progress (docs/safety.md): (phase "ask" | "hold" | "down", site, layer altitude)
        self._transit: tuple[str, tuple[float, float, float], float | None] | None = None
        self._gate_at = 0  # != 0: the legs of a layer route start from rest
        self._settling_since_s: float | None = None  # when the current hover began waiting to settle
        self._transit_top_m: float | None = None  # top of the work at the transit's site (see _route)
        self._transit_to_m: tuple[float, float, float] | None = None  # where that work ends (see _route)
        self._request_clearance: Callable[..., Any] | None = getattr(link, "request_clearance", None)
        # A link whose ground crew swaps the battery of a landed UAV before handing it its next task (the
        # mission handler's battery reserve): a low battery sends the UAV home to land, not out of service.
        self._battery_service = getattr(link, "swaps_batteries", False) is True
        self._leaf_names = leaf_states(states)
        self.machine = HierarchicalMachine(
            model=self,
            states=copy.deepcopy(states),
            transitions=copy.deepcopy(transitions),
            initial="idle",
            queued=True,
            auto_transitions=False,
            ignore_invalid_triggers=True,
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
        """One control tick at ``now_s``: telemetry, failsafes, the state's work, the velocity setpoint.

        Calls closer together than ``config.control_period_s`` return at once, so a simulation may tick the
        world faster than the UAV's control loop runs.
        """
        if now_s - self._last_step_s < self.config.control_period_s - 1e-9:
            return  # called faster than the control rate
        self._last_step_s = now_s
        self._now_s = float(now_s)
        if self.state == "halted":
            self._reject_tasks()
            return
        try:
            tel = self.fc.telemetry()
            self._tel = tel
            if not tel.link_ok:
                self._link_down(tel)
                return
            self._link_down_since_s = None
            if (
                self.state in self._TASK_STATES_SET
                and tel.battery_fraction < self.config.battery_low_fraction
            ):
                if not self._battery_service:
                    self._halt_after_landing = f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%})"
                self.abort(reason=f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%})")
            self._do[self.state](tel)
            if self._motion:
                self._track(tel)
        except HardwareError as exc:
            self._hardware_failure(str(exc))

    # -- failsafes -----------------------------------------------------------------------------------------
    def _link_down(self, tel: Telemetry) -> None:
        if self._link_down_since_s is None:
            self._link_down_since_s = self._now_s
        state = self.state
        if state == "idle":
            # Landed with a silent flight controller: out of service, so that tasks go to other UAVs.
            if self._now_s - self._link_down_since_s > self.config.link_lost_timeout_s:
                self.halt_reason = "flight controller link lost"
                self.retire(reason=self.halt_reason)
            return
        if state == "emergency":
            if tel.on_ground or self._now_s - self._link_down_since_s > self.config.link_lost_timeout_s:
                self.giveup(reason="flight controller link lost")
            return
        self.lost(reason="flight controller link lost")

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
            self._report(TaskResult(self.task.id, "failed", self._now_s - self._task_start_s, reason=reason))
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
        problem = self._task_problem(task)
        if problem is not None:
            self._report(TaskResult(task.id, "failed", 0.0, reason=problem))
            return None
        return task

    def _task_problem(self, task: Task) -> str | None:
        return None

    def _start_task(self, task: Task) -> None:
        self.task = task
        self._task_start_s = self._now_s
        self._begin_task(task)

    def _begin_task(self, task: Task) -> None:
        """Reset the per-task counters (subclasses)."""

    def _report_done(self, **fields: Any) -> None:
        """Report the task in hand done (with ``fields``); the UAV has no task any more."""
        assert self.task is not None
        self._report(TaskResult(self.task.id, "done", self._now_s - self._task_start_s, **fields))
        self.task = None

    def _may_take_task(self, tel: Telemetry) -> bool:
        """A task may be started now: the UAV is not to retire and its battery is not low."""
        return self._halt_after_landing is None and tel.battery_fraction >= self.config.battery_low_fraction

    def _complete_task(self, **fields: Any) -> None:
        self._report_done(**fields)
        self._next_task = self._take(self.link.poll_task())
        if self._next_task is not None:
            self._start_task(self._next_task)
        self.finish()
        self._next_task = None

    # -- motion --------------------------------------------------------------------------------------------
    def _stop(self) -> None:
        self._transit = None
        self._motion = False
        self._traj = None
        self._line = None
        self._legs = []

    def _hold(self, tel: Telemetry, target_m: np.ndarray | None = None, yaw_rad: float | None = None) -> None:
        """Hover at ``target_m`` (default: where the UAV is) with the given yaw (default: keep it)."""
        if not self._motion:
            self._pid.reset()
        self._traj = None
        self._line = None
        self._legs = []
        self._traj_end_s = self._now_s
        self._target = np.array(tel.position_m if target_m is None else target_m, dtype=float)
        self._target_yaw = tel.attitude_rad[2] if yaw_rad is None else yaw_rad
        self._motion = True

    def _fly_to(
        self,
        tel: Telemetry,
        target_m: np.ndarray,
        duration_s: float | None = None,
        yaw_rad: float | None = None,
        from_rest: bool = False,
    ) -> None:
        """One minimum-jerk leg from the current state (``from_rest``: from rest where the UAV is) to rest at
        ``target_m``."""
        if not self._motion:
            self._pid.reset()
        self._legs = []
        self._line = None
        self._start_leg(tel, np.asarray(target_m, dtype=float), duration_s, from_rest=from_rest)
        if yaw_rad is not None:
            self._target_yaw = yaw_rad
        elif not self._motion:
            self._target_yaw = tel.attitude_rad[2]
        self._motion = True

    def _route(self, tel: Telemetry, target_m: np.ndarray, yaw_rad: float | None = None,
               top_m: float | None = None, to_m: np.ndarray | None = None) -> None:
        """Go to ``target_m`` climbing first if it is higher, descending last if it is lower (never diagonal).

        With a link that hands out clearances (mission control's airspace, docs/safety.md) a lateral move is a
        *transit*: the UAV first asks for the column over the target, hovering where it is; then climbs (or
        descends) to the layer it is given, flies there, and descends over the target once the column is its
        (until then it waits at its layer at the hold point it is given). Without one, with a fixed
        ``config.lateral_altitude_m``, the lateral leg flies at that altitude. ``top_m``: the highest altitude
        the UAV will reach while working at the target (default: the target's), ``to_m`` where that work ends if
        it moves along a segment (an adhesion UAV spraying): mission control reserves both.
        """
        p = np.asarray(tel.position_m, dtype=float)
        target = np.asarray(target_m, dtype=float)
        self._transit = None
        self._gate_at = 0
        d_xy = math.hypot(target[0] - p[0], target[1] - p[1])
        if self._request_clearance is not None:
            # even a move of a few centimetres (the next adhesion segment starts where the last one ended): the
            # work there is another span of airspace, which mission control must reserve
            self._transit = ("ask", (float(target[0]), float(target[1]), float(target[2])), None)
            self._transit_top_m = top_m
            self._transit_to_m = None if to_m is None else (float(to_m[0]), float(to_m[1]), float(to_m[2]))
            # hover until mission control answers, once come to rest smoothly: it asks once settled
            # (_still_enough_to_ask), and the flight it is granted starts from rest where it says it is
            stop = self._stop_point_m(tel)
            if self._rests_at(tel, stop):
                self._fly_to(tel, stop, 0.1, yaw_rad=yaw_rad, from_rest=True)  # at rest there already
            else:
                self._fly_to(tel, stop, yaw_rad=yaw_rad)
            return
        layer = self.config.lateral_altitude_m
        if layer is not None and d_xy > self.config.layer_min_leg_m:
            self._layer_legs(tel, p, target, layer, yaw_rad)
            return
        legs = self._low_legs(p, target)
        self._fly_to(tel, legs[0], yaw_rad=yaw_rad)
        self._legs = [(leg, None) for leg in legs[1:]]

    def _layer_legs(
        self, tel: Telemetry, p: np.ndarray, target: np.ndarray, layer: float, yaw_rad: float | None
    ) -> None:
        """Climb (or descend) to ``layer`` where the UAV is, fly there above ``target``, descend to it."""
        v_z = self.config.layer_vertical_speed_mps
        legs: list[tuple[np.ndarray, float | None]] = []
        if math.hypot(target[0] - p[0], target[1] - p[1]) > 0.05:
            legs.append((np.array([target[0], target[1], layer]), None))
        if abs(target[2] - layer) > 0.05:
            legs.append((target, max(0.5, MIN_JERK_PEAK_TO_MEAN_SPEED * abs(layer - target[2]) / v_z)))
        self._gate_at = -1  # legs start from rest: a corner is turned where the UAV is, never cut
        if abs(p[2] - layer) > 0.05 or not legs:
            self._fly_to(tel, np.array([p[0], p[1], layer]), max(0.5, MIN_JERK_PEAK_TO_MEAN_SPEED * abs(layer - p[2]) / v_z),
                         yaw_rad=yaw_rad, from_rest=True)
            self._legs = legs
        else:
            self._fly_to(tel, legs[0][0], legs[0][1], yaw_rad=yaw_rad, from_rest=True)
            self._legs = legs[1:]

    @staticmethod
    def _low_legs(p: np.ndarray, target: np.ndarray) -> list[np.ndarray]:
        """Legs from ``p`` to ``target``: climb first if it is higher, descend last if it is lower."""
        if target[2] > p[2] + 0.05:
            legs = [np.array([p[0], p[1], target[2]]), target]
        elif target[2] < p[2] - 0.05:
            legs = [np.array([target[0], target[1], p[2]]), target]
        else:
            legs = [target]
        return [leg for i, leg in enumerate(legs) if i == len(legs) - 1 or np.linalg.norm(leg - p) > 0.05]

    def _transit_step(self, tel: Telemetry) -> bool:
        """A transit's motion is over (see :meth:`_route`): ask, go on, or finish; True when it has arrived."""
        assert self._transit is not None and self._request_clearance is not None
        phase, site, layer = self._transit
        if phase == "down":
            self._transit = None
            end = getattr(self.link, "end_transit", None)
            if end is not None:
                end(site)
            return True
        if not self._still_enough_to_ask(tel):
            self._traj_end_s = self._now_s  # let it settle first (a leg timeout does not run meanwhile)
            return False
        answer = self._request_clearance(site, self._transit_top_m, self._transit_to_m)
        if answer is None:
            self._traj_end_s = self._now_s  # no answer yet: hover (a leg timeout does not run meanwhile)
            return False
        target = np.array(site)
        p = np.asarray(tel.position_m, dtype=float)
        if layer is None:
            layer = answer.layer_m
            if layer is None:  # no layers: the altitude it is at (or the target's, if higher)
                layer = self.config.lateral_altitude_m or max(float(p[2]), float(target[2]))
        if answer.granted:
            # from a hold point the rest of the flight may come with another layer than the hold flight's
            if answer.layer_m is not None:
                layer = answer.layer_m
            self._transit = ("down", site, layer)
            if math.hypot(target[0] - p[0], target[1] - p[1]) <= 0.05:
                legs = self._low_legs(p, target)  # already over the site: no lateral leg, no layer
                self._fly_to(tel, legs[0], yaw_rad=self._target_yaw, from_rest=True)
                self._legs = [(leg, None) for leg in legs[1:]]
            else:
                self._layer_legs(tel, p, target, layer, self._target_yaw)
            return False
        hold = answer.hold_m
        if hold is not None and (phase == "ask" or math.hypot(hold[0] - p[0], hold[1] - p[1]) > 0.05):
            self._transit = ("hold", site, layer)
            self._layer_legs(tel, p, np.array([hold[0], hold[1], layer]), layer, self._target_yaw)
        else:
            self._traj_end_s = self._now_s
        return False

    def _stop_point_m(self, tel: Telemetry) -> np.ndarray:
        """Where the UAV comes to rest when it stops to ask for a transit (its current leg's end or on the way).

        Near the end of its leg or takeoff (within ``_END_NEAR_M``; a takeoff is over 0.1 m short, climbing), at
        that end. Stopped mid-flight (it was flying home and got a task), on along its velocity as far as a
        one-second smooth stop takes it (half a second's flight, a deceleration of at most 1.5 x speed per
        second), never past the leg's end: stopping dead from cruise speed swung it 0.1-0.2 m past the point and
        back, slowly, vertically. Mission control keeps the leg ahead of a UAV for it until it asks (and the
        next metre after: ``STOP_M``).
        """
        p = np.asarray(tel.position_m, dtype=float)
        end = np.asarray(self._target, dtype=float)
        to_end = float(np.linalg.norm(end - p))
        if to_end <= _END_NEAR_M:
            return end
        v = np.asarray(tel.velocity_mps, dtype=float)
        coast = 0.5 * v  # a 1 s quintic from (p, v) to rest at p + v / 2 decelerates monotonically
        length = float(np.linalg.norm(coast))
        if length > to_end:
            coast *= to_end / length
        return p + coast

    def _still_enough_to_ask(self, tel: Telemetry) -> bool:
        """The UAV has come to rest where it hovers, so that the flight it asks for starts where it says it is.

        Mission control reserves the climb of a granted flight (or of a hold flight) where the request says the UAV
        is, and the flight starts from rest there. A UAV that stopped from cruise speed to ask (it was flying home
        and got a task) swings 0.1-0.2 m past its hover point and back: asking then put the climb's volume where
        the swing was, and the UAV left it by up to 0.15 m (slow at the turning point of the swing is not at
        rest). So it asks once within ``ask_settle_tolerance_m`` of its hover point and slower than
        ``settle_speed_mps`` (twice both after ``align_patience_s``, and anyhow after twice that time: gusts may
        never let it settle, and waiting for ever would strand it).
        """
        if self._settling_since_s is None:
            self._settling_since_s = self._now_s
        waited = self._now_s - self._settling_since_s
        cfg = self.config
        if waited >= 2.0 * cfg.align_patience_s:
            return True
        return self._rests_at(tel, self._target, 1.0 if waited < cfg.align_patience_s else 2.0)

    def _rests_at(self, tel: Telemetry, point_m: Sequence[float] | np.ndarray, scale: float = 1.0) -> bool:
        """Within ``scale`` x ``ask_settle_tolerance_m`` of ``point_m`` and slower than ``scale`` x
        ``settle_speed_mps``."""
        vx, vy, vz = tel.velocity_mps
        speed = scale * self.config.settle_speed_mps
        if vx * vx + vy * vy + vz * vz > speed * speed:
            return False
        p, t = tel.position_m, point_m
        tol = scale * self.config.ask_settle_tolerance_m
        return (p[0] - t[0]) ** 2 + (p[1] - t[1]) ** 2 + (p[2] - t[2]) ** 2 <= tol * tol

    def _leg_duration_s(self, start: np.ndarray, target: np.ndarray) -> float:
        d_xy = math.hypot(target[0] - start[0], target[1] - start[1])
        d_z = abs(target[2] - start[2])
        # A rest-to-rest minimum-jerk leg peaks at 1.875 x its average speed.
        return max(
            MIN_LEG_S, MIN_JERK_PEAK_TO_MEAN_SPEED * max(d_xy / self.config.cruise_speed_mps, d_z / self.config.vertical_speed_mps)
        )

    def _start_leg(
        self, tel: Telemetry, target: np.ndarray, duration_s: float | None, from_rest: bool = False
    ) -> None:
        p = np.asarray(tel.position_m, dtype=float)
        # from rest: the reference turns the corner where the UAV is (a layer route never cuts diagonally)
        v = _ZERO3 if from_rest else np.asarray(tel.velocity_mps, dtype=float)
        T = self._leg_duration_s(p, target) if duration_s is None else float(duration_s)
        self._traj = MinJerk(p, v, _ZERO3, target, _ZERO3, _ZERO3, T)
        # Per-axis polynomial coefficients as floats: evaluating them by hand each tick is ~10x cheaper than
        # the vectorised MinJerk methods on one sample.
        self._coef = self._traj.coefficients.T.tolist()
        self._traj_t0_s = self._now_s
        self._traj_end_s = self._now_s + T
        self._target = target
        self._settling_since_s = None

    def _fly_line(self, tel: Telemetry, start_m: np.ndarray, end_m: np.ndarray, speed_mps: float) -> None:
        """Track ``start -> end`` at constant ``speed_mps`` (reference starts at ``start`` now)."""
        d = end_m - start_m
        length = float(np.linalg.norm(d))
        self._legs = []
        self._traj = None
        self._line = (np.array(start_m, dtype=float), d / max(length, 1e-9), length)
        self._ref_speed_mps = speed_mps
        self._traj_t0_s = self._now_s
        self._traj_end_s = self._now_s + length / speed_mps
        self._target = np.array(end_m, dtype=float)
        self._motion = True

    def _leg_done(self, tel: Telemetry, tolerance_m: float | None = None) -> bool:
        """The current motion (all its legs) is over and the UAV is within ``tolerance_m`` of its end."""
        if self._now_s < self._traj_end_s:
            return False
        tol = self.config.arrive_tolerance_m if tolerance_m is None else tolerance_m
        p = tel.position_m
        t = self._target
        if type(t) is np.ndarray:
            t = t.tolist()  # plain floats: the same squares, without a numpy scalar per element
        close = (p[0] - t[0]) ** 2 + (p[1] - t[1]) ** 2 + (p[2] - t[2]) ** 2 <= tol * tol
        if close and self._legs:
            target, duration = self._legs.pop(0)
            self._start_leg(tel, target, duration, from_rest=self._gate_at != 0)
            return False
        if close and self._transit is not None:
            return self._transit_step(tel)
        return close

    def _yaw_error(self, tel: Telemetry) -> float:
        if self._target_yaw is None:
            return 0.0
        return abs(_wrap(self._target_yaw - tel.attitude_rad[2]))

    def _track(self, tel: Telemetry) -> None:
        now = self._now_s
        ref: Any
        ff: Any
        traj = self._traj
        if traj is not None:
            duration = traj.duration_s
            t = now - self._traj_t0_s  # min(max(t, 0.0), duration), written out (every tick of a flight)
            if t < 0.0:  # noqa: PLR1730 (no min/max call: hot loop)
                t = 0.0
            if duration < t:  # noqa: PLR1730
                t = duration
            (a0, a1, a2, a3, a4, a5), (b0, b1, b2, b3, b4, b5), (c0, c1, c2, c3, c4, c5) = self._coef
            ref = (
                ((((a5 * t + a4) * t + a3) * t + a2) * t + a1) * t + a0,
                ((((b5 * t + b4) * t + b3) * t + b2) * t + b1) * t + b0,
                ((((c5 * t + c4) * t + c3) * t + c2) * t + c1) * t + c0,
            )
            if t < duration:
                # velocity, plus the acceleration times the autopilot's velocity lag: a first-order velocity
                # loop then follows the reference's velocity instead of trailing it by lag x acceleration,
                # which the integral would otherwise make up for as an overshoot at the end of the leg
                lag = self._velocity_lag_s
                ff = (
                    (((5.0 * a5 * t + 4.0 * a4) * t + 3.0 * a3) * t + 2.0 * a2) * t + a1
                    + lag * (((20.0 * a5 * t + 12.0 * a4) * t + 6.0 * a3) * t + 2.0 * a2),
                    (((5.0 * b5 * t + 4.0 * b4) * t + 3.0 * b3) * t + 2.0 * b2) * t + b1
                    + lag * (((20.0 * b5 * t + 12.0 * b4) * t + 6.0 * b3) * t + 2.0 * b2),
                    (((5.0 * c5 * t + 4.0 * c4) * t + 3.0 * c3) * t + 2.0 * c2) * t + c1
                    + lag * (((20.0 * c5 * t + 12.0 * c4) * t + 6.0 * c3) * t + 2.0 * c2),
                )
            else:
                ff = _ZERO_FF
        elif self._line is not None:
            start, direction, length = self._line
            s = (now - self._traj_t0_s) * self._ref_speed_mps
            if s < length:
                ref = (start + direction * s).tolist()
                ff = (direction * self._ref_speed_mps).tolist()
            else:
                ref, ff = self._target, _ZERO_FF
        else:
            ref, ff = self._target, _ZERO_FF
        if type(ref) is np.ndarray:
            ref = ref.tolist()  # the PID takes floats: hand it floats, not numpy scalars to convert
        vx, vy, vz, yaw_rate = self._pid.step_floats(
            now,
            tel.position_m,
            ref,
            velocity_ff_mps=ff,
            yaw_rad=tel.attitude_rad[2],
            target_yaw_rad=self._target_yaw,
        )
        self.fc.send_velocity((vx, vy, vz), yaw_rate)

    def _tool_body_target(
        self, tool_target_m: np.ndarray, offset_body_m: tuple[float, float, float], yaw_rad: float
    ) -> np.ndarray:
        """Body position that puts a tool at ``offset_body_m`` (FLU) on ``tool_target_m`` at heading ``yaw_rad``."""
        return np.asarray(tool_target_m, dtype=float) - rot_z(yaw_rad) @ np.asarray(
            offset_body_m, dtype=float
        )

    def _tool_position(self, tel: Telemetry, offset_body_m: tuple[float, float, float]) -> np.ndarray:
        roll, pitch, yaw = tel.attitude_rad
        return np.asarray(tel.position_m, dtype=float) + R_world_body(roll, pitch, yaw) @ np.asarray(
            offset_body_m
        )

    def _tool_distance_m(
        self, tel: Telemetry, offset_body_m: tuple[float, float, float], target_m: np.ndarray
    ) -> float:
        """Distance from the tool at ``offset_body_m`` to ``target_m``: ``|_tool_position - target|`` on floats.

        Every tick of a descent; the same rotation (``R_world_body``) written out, equal to the numpy form to
        rounding (~1e-16 m).
        """
        roll, pitch, yaw = tel.attitude_rad
        cr, sr = math.cos(roll), math.sin(roll)
        cp, sp = math.cos(pitch), math.sin(pitch)
        cy, sy = math.cos(yaw), math.sin(yaw)
        ox, oy, oz = offset_body_m
        px, py, pz = tel.position_m
        tx, ty, tz = target_m.tolist() if type(target_m) is np.ndarray else target_m
        dx = px + (cy * cp * ox + (cy * sp * sr - sy * cr) * oy + (cy * sp * cr + sy * sr) * oz) - tx
        dy = py + (sy * cp * ox + (sy * sp * sr + cy * cr) * oy + (sy * sp * cr - cy * sr) * oz) - ty
        dz = pz + (-sp * ox + cp * sr * oy + cp * cr * oz) - tz
        return math.sqrt(dx * dx + dy * dy + dz * dz)

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
        task = self._take(self.link.poll_task())  # with a battery service: handed over once the pack is swapped
        if task is not None:
            self._start_task(task)
            self.assign(task=task)

    def enter_takeoff(self, *args: Any, **kwargs: Any) -> None:
        self._stop()
        tel = self._tel
        assert tel is not None
        self._pid.reset()
        if not tel.armed:
            self.fc.arm()
        climb_m = max(0.3, self._transit_altitude_m() - tel.position_m[2])
        self.fc.takeoff(climb_m)
        x, y, z = tel.position_m
        self._target = np.array([x, y, z + climb_m])  # where the autopilot takes it (the machine hovers there next)

    def do_takeoff(self, tel: Telemetry) -> None:
        if not tel.on_ground and tel.position_m[2] >= self._transit_altitude_m() - _TAKEOFF_SHORT_M:
            self.airborne()
        elif self._now_s - self._entered_s > self.config.takeoff_timeout_s:
            self.abort(
                reason=f"takeoff did not reach {self._transit_altitude_m():.2f} m "
                f"within {self.config.takeoff_timeout_s:.0f} s"
            )

    def _transit_altitude_m(self) -> float:
        return self.config.cruise_altitude_m

    def enter_home(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        home = self.config.home_m
        z = max(self.config.cruise_altitude_m, tel.position_m[2])
        if self.config.lateral_altitude_m is not None or self._request_clearance is not None:
            z = self.config.cruise_altitude_m  # down from the layer over home (with clearance), then land
        self._route(tel, np.array([home[0], home[1], z]))

    def do_home(self, tel: Telemetry) -> None:
        # A task assigned on the way home turns the UAV back at once (instead of landing, idling and taking
        # off again), unless the UAV is to retire or its battery is low.
        if self._may_take_task(tel):
            task = self._take(self.link.poll_task())
            if task is not None:
                self._start_task(task)
                self.assign(task=task)
                return
        if self._leg_done(tel):
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
        self._emergency_mode = tel.mode if tel is not None else None
        self._land_pending = True
        self._land_tried_s = -math.inf
        self._command_land(tel)

    #: Seconds between tries of a LAND command that did not go through (emergency).
    LAND_RETRY_S = 1.0

    def _command_land(self, tel: Telemetry | None) -> None:
        if tel is not None and (tel.landing or tel.on_ground):
            self._land_pending = False  # already landing (the autopilot's failsafe) or down
            return
        self._land_tried_s = self._now_s
        try:
            self.fc.land()
        except HardwareError:
            return  # tried again later; meanwhile the autopilot's own failsafe lands it
        self._land_pending = False

    def do_emergency(self, tel: Telemetry) -> None:
        if tel.on_ground:
            self.landed()
            return
        if not self._land_pending:
            return
        if tel.landing or tel.mode != self._emergency_mode:
            self._land_pending = False  # landing, or a pilot took over: never re-send LAND
        elif self._now_s - self._land_tried_s >= self.LAND_RETRY_S:
            self._command_land(tel)

    def enter_halted(self, *args: Any, reason: str | None = None, **kwargs: Any) -> None:
        self._stop()
        if self.halt_reason is None:
            self.halt_reason = reason or self._halt_after_landing or "halted"

    def do_halted(self, tel: Telemetry) -> None:
        self._reject_tasks()

    _TASK_STATES_SET: frozenset[str] = frozenset()


class BrickUav(UavModel):
    """The brick-carrier UAV (paper, Section IV): pick a brick up near ``pickup_m``, place it on the wall.

    Args:
        config: the UAV (name, home, airframe, tuning).
        fc, gripper, camera, link, clock: its ports.
    """

    KIND = "brick"
    touched: Callable[..., bool]
    grasped: Callable[..., bool]
    ascended: Callable[..., bool]
    attached: Callable[..., bool]
    missed: Callable[..., bool]
    widen: Callable[..., bool]
    estimated: Callable[..., bool]
    aligned: Callable[..., bool]
    timeout: Callable[..., bool]
    released: Callable[..., bool]
    deposited: Callable[..., bool]
    stuck: Callable[..., bool]

    def __init__(
        self,
        config: UavConfig,
        fc: FlightController,
        gripper: Gripper,
        camera: Camera,
        link: MissionLink,
        clock: Clock,
    ) -> None:
        from masonry.perception.estimation import EstimatorConfig, PoseWindow

        self.gripper = gripper
        self.camera = camera
        self._est_config = EstimatorConfig(spacing_m=config.markers.spacing_m, up=(0.0, 0.0, 1.0))
        self.window = PoseWindow(size=config.window_size, sigma_tol_m=config.sigma_tol_m)
        self._T_body_cam = np.asarray(camera.T_body_cam, dtype=float)
        o = config.airframe.effector_offset_m
        self._eff: tuple[float, float, float] = (float(o[0]), float(o[1]), float(o[2]))
        self._begin_counters()
        super().__init__(config, fc, link, clock, BRICK_STATES, BRICK_TRANSITIONS)

    _TASK_STATES_SET = frozenset(s for s in leaf_states(BRICK_STATES) if s.split("_")[0] in BRICK_TASK_STATES)

    def _begin_counters(self) -> None:
        self.climbs = 0
        self.grasp_attempts = 0
        self.place_attempts = 0
        self.release_attempts = 0
        self.brick_estimate: tuple[np.ndarray, float] | None = None
        self.estimates_seen = 0
        self._hover_z = 0.0
        self._deadline_s = 0.0
        self._carry_yaw_rad = 0.0
        self._grasp_yaw_rad = 0.0
        self._place_effector_target = np.zeros(3)
        self._release_error_m: float | None = None

    def _begin_task(self, task: Task) -> None:
        self._begin_counters()

    def _task_problem(self, task: Task) -> str | None:
        assert isinstance(task, BrickTask)
        if task.pickup_m is None:
            return f"brick task {task.id} has no pickup location"
        return None

    @property
    def brick_task(self) -> BrickTask:
        assert isinstance(self.task, BrickTask)
        return self.task

    def _transit_altitude_m(self) -> float:
        """Cruise altitude, raised so a carried brick clears the drop-off by ``clearance_m``."""
        z = self.config.cruise_altitude_m
        if isinstance(self.task, BrickTask):
            t = self.task
            top_z = t.position_m[2] + t.size_m[2] / 2.0
            z = max(z, top_z - self._eff[2] + t.size_m[2] + self.config.clearance_m)
        return z

    def _safe_actuators(self) -> None:
        self.gripper.set_joint_locked(True)  # keep a carried brick; it is put down after landing

    def _on_landed(self) -> None:
        self.gripper.set_magnet(False)
        self.gripper.set_joint_locked(True)

    # -- pickup --------------------------------------------------------------------------------------------
    def enter_pickup_goto(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_magnet(False)
        self.gripper.set_joint_locked(True)
        pickup = self.brick_task.pickup_m
        assert pickup is not None
        self._hover_z = self.config.cruise_altitude_m
        # it may climb max_climbs steps there to widen the camera's view, and it climbs out with the brick to its
        # transit altitude: both are part of its column
        top = max(self._hover_z + self.config.max_climbs * self.config.climb_step_m, self._transit_altitude_m())
        self._route(tel, np.array([pickup[0], pickup[1], self._hover_z]), top_m=top)

    def do_pickup_goto(self, tel: Telemetry) -> None:
        if self._leg_done(tel):
            self.arrived()
        elif self._now_s > self._traj_end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not reach the pickup of {self.brick_task.id}")

    def climb_step(self, *args: Any, **kwargs: Any) -> None:
        """Before re-entering ``estimate``: one step up to widen the camera's view."""
        self.climbs += 1
        self._hover_z += self.config.climb_step_m

    def enter_pickup_estimate(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        p = tel.position_m
        if self._hover_z == 0.0:
            self._hover_z = p[2]
        target = np.array([p[0], p[1], self._hover_z])
        if abs(self._hover_z - p[2]) > 0.05:
            self._fly_to(tel, target)
        else:
            self._hold(tel, target)
        self.window.clear()
        self.estimates_seen = 0
        self._deadline_s = self._now_s + self.config.settle_time_s + self.config.estimate_timeout_s
        if self._traj is not None:
            self._deadline_s += self._traj.duration_s

    def do_pickup_estimate(self, tel: Telemetry) -> None:
        cfg = self.config
        settling = self._now_s < self._traj_end_s + cfg.settle_time_s
        if not settling:
            self._collect(tel)
        conf = self.window.confidence()
        if conf is not None and conf >= cfg.confidence_threshold and self.window.count >= cfg.min_estimates:
            center, yaw = self.window.mean()
            self.brick_estimate = (np.array(center, dtype=float), float(yaw))
            self.estimated()
        elif self._now_s >= self._deadline_s:
            if self.climbs < cfg.max_climbs:
                self.widen()
            elif self.estimates_seen == 0:
                self.abort(
                    reason=f"brick {self.brick_task.brick} not seen near its pickup "
                    f"after {self.climbs} climbs"
                )
            else:
                self.abort(
                    reason=f"brick {self.brick_task.brick} pose confidence "
                    f"{conf if conf is not None else 0.0:.2f} stayed below {cfg.confidence_threshold:.2f} "
                    f"after {self.climbs} climbs"
                )

    def _collect(self, tel: Telemetry) -> None:
        frame = self.camera.read()
        if frame is None:
            return
        tags = frame.tags
        if tags is None:
            if frame.image is None:
                return
            from masonry.perception.aruco import detect_tags

            tags = tuple(detect_tags(frame.image, self.camera.intrinsics, self.config.markers))
        id1, id2 = 2 * self.brick_task.brick, 2 * self.brick_task.brick + 1
        tag1 = tag2 = None
        for tag in tags:
            if tag.marker_id == id1:
                tag1 = tag
            elif tag.marker_id == id2:
                tag2 = tag
        if tag1 is None and tag2 is None:
            return
        from masonry.perception.estimation import estimate_brick_pose

        roll, pitch, yaw = tel.attitude_rad
        R_wb = R_world_body(roll, pitch, yaw)
        R_wc = R_wb @ self._T_body_cam[:3, :3]
        t_wc = np.asarray(tel.position_m, dtype=float) + R_wb @ self._T_body_cam[:3, 3]

        def to_world(tag: TagPose | None) -> TagPose | None:
            if tag is None:
                return None
            return TagPose(tag.marker_id, R_wc @ np.asarray(tag.position_m) + t_wc, R_wc @ tag.R_cam_marker)

        est = estimate_brick_pose(to_world(tag1), to_world(tag2), self._est_config)
        if est is not None:
            self.window.add(est.center_m, est.yaw_rad)
            self.estimates_seen += 1

    def enter_pickup_align(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None and self.brick_estimate is not None
        center, yaw = self.brick_estimate
        above = np.array([center[0], center[1], tel.position_m[2] + self._eff[2]])
        self._fly_to(tel, self._tool_body_target(above, self._eff, yaw), yaw_rad=yaw)

    def do_pickup_align(self, tel: Telemetry) -> None:
        cfg = self.config
        if self._aligned(tel):
            self.aligned()
        elif self._now_s > self._traj_end_s + cfg.leg_timeout_s:
            self.abort(reason=f"could not align above brick {self.brick_task.brick}")

    def _aligned(self, tel: Telemetry) -> bool:
        cfg = self.config
        if self._now_s < self._traj_end_s or self._yaw_error(tel) > cfg.align_yaw_tolerance_rad:
            return False
        p, t, v = tel.position_m, self._target, tel.velocity_mps
        tolerance, speed = cfg.align_tolerance_m, cfg.settle_speed_mps
        if self._now_s > self._traj_end_s + cfg.align_patience_s:
            tolerance, speed = max(tolerance, cfg.align_relaxed_tolerance_m), 2.0 * speed
        return math.hypot(p[0] - t[0], p[1] - t[1]) <= tolerance and math.hypot(v[0], v[1]) <= speed

    def enter_pickup_descend(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None and self.brick_estimate is not None
        center, yaw = self.brick_estimate
        self.gripper.set_joint_locked(False)
        self.gripper.set_magnet(True)
        grasp = np.array([center[0], center[1], center[2] - self.config.grasp_press_m])
        self._fly_to(tel, self._tool_body_target(grasp, self._eff, yaw), self.config.descent_duration_s, yaw)

    def do_pickup_descend(self, tel: Telemetry) -> None:
        if self._now_s >= self._traj_end_s:
            self.touched()

    def enter_pickup_grasp(self, *args: Any, **kwargs: Any) -> None:
        pass  # keep tracking the descent's end point (pressing on the brick) with the magnet on

    def do_pickup_grasp(self, tel: Telemetry) -> None:
        # Press on the brick with the magnet on for the dwell (the magnet grips on contact; polling lets an
        # actuator board report it), then climb: the verification happens at cruise altitude.
        self.gripper.is_attached()
        if self._now_s - self._entered_s >= self.config.grasp_dwell_s:
            self._grasp_yaw_rad = tel.attitude_rad[2]
            self.grasped()

    def enter_pickup_ascend(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        p = tel.position_m
        self._fly_to(tel, np.array([p[0], p[1], self._transit_altitude_m()]))

    def do_pickup_ascend(self, tel: Telemetry) -> None:
        if self._leg_done(tel):
            self.ascended()

    def enter_pickup_verify(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self._hold(tel)

    def do_pickup_verify(self, tel: Telemetry) -> None:
        if self.gripper.is_attached():
            assert self.brick_estimate is not None
            # The flange keeps the brick from turning on the magnet: remember its yaw relative to the body. Its
            # position is not compensated: the conical guide centres the brick under the effector (paper, IV).
            self._carry_yaw_rad = _wrap(self.brick_estimate[1] - self._grasp_yaw_rad)
            self.attached()
            return
        self.grasp_attempts += 1
        self.gripper.set_magnet(False)
        if self.grasp_attempts >= self.config.max_grasp_attempts:
            self.abort(
                reason=f"brick {self.brick_task.brick} not attached after {self.grasp_attempts} grasps"
            )
        else:
            self.climbs = 0
            self._hover_z = self.config.cruise_altitude_m
            self.missed()

    # -- transport and place -------------------------------------------------------------------------------
    def _place_yaw_rad(self) -> float:
        return _wrap(self.brick_task.yaw_rad - self._carry_yaw_rad)

    def _place_effector_target_m(self) -> np.ndarray:
        t = self.brick_task
        return np.array([t.position_m[0], t.position_m[1], t.position_m[2] + t.size_m[2] / 2.0])

    def enter_transport(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        yaw = self._place_yaw_rad()
        eff = self._place_effector_target_m()
        body = self._tool_body_target(eff, self._eff, yaw)
        self._route(tel, np.array([body[0], body[1], self._transit_altitude_m()]), yaw_rad=yaw)

    def do_transport(self, tel: Telemetry) -> None:
        if self._leg_done(tel):
            self.arrived()
        elif self._now_s > self._traj_end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not reach the drop-off of {self.brick_task.id}")

    def enter_place_align(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        yaw = self._place_yaw_rad()
        body = self._tool_body_target(self._place_effector_target_m(), self._eff, yaw)
        self._fly_to(tel, np.array([body[0], body[1], self._transit_altitude_m()]), yaw_rad=yaw)

    def do_place_align(self, tel: Telemetry) -> None:
        if self._aligned(tel):
            self.aligned()
        elif self._now_s > self._traj_end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not align above the drop-off of {self.brick_task.id}")

    def enter_place_descend(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(False)
        yaw = self._place_yaw_rad()
        self._place_effector_target = self._place_effector_target_m()
        body = self._tool_body_target(self._place_effector_target, self._eff, yaw)
        self._fly_to(tel, body, self.config.descent_duration_s, yaw)

    def do_place_descend(self, tel: Telemetry) -> None:
        cfg = self.config
        error = self._tool_distance_m(tel, self._eff, self._place_effector_target)
        if error <= cfg.placement_radius_m:
            self._release_error_m = error
            self.reached()
        elif self._now_s > self._traj_end_s + cfg.release_timeout_s:
            self.place_attempts += 1
            if self.place_attempts >= cfg.max_place_attempts:
                self.abort(
                    reason=f"drop-off of {self.brick_task.id} not reached within "
                    f"{cfg.placement_radius_m * 100:.1f} cm after {self.place_attempts} descents"
                )
            else:
                self.timeout()

    def enter_place_release(self, *args: Any, **kwargs: Any) -> None:
        self.gripper.set_magnet(False)

    def do_place_release(self, tel: Telemetry) -> None:
        if self._now_s - self._entered_s >= self.config.release_dwell_s:
            self.released()

    def enter_place_verify(self, *args: Any, **kwargs: Any) -> None:
        pass

    def do_place_verify(self, tel: Telemetry) -> None:
        if not self.gripper.is_attached():
            self.deposited()
            return
        self.release_attempts += 1
        if self.release_attempts >= self.config.max_release_attempts:
            self.abort(
                reason=f"brick {self.brick_task.brick} still attached after {self.release_attempts} releases"
            )
        else:
            self.stuck()

    def enter_place_ascend(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        p = tel.position_m
        self._fly_to(tel, np.array([p[0], p[1], self._transit_altitude_m()]))

    def do_place_ascend(self, tel: Telemetry) -> None:
        if self._leg_done(tel):
            self._complete_task(placement_error_m=self._release_error_m)


class AdhesionUav(UavModel):
    """The adhesion UAV (paper, Section V): spray a bead of adhesive along a segment.

    Args:
        config: the UAV (name, home, airframe, tuning).
        fc, sprayer, link, clock: its ports.
    """

    KIND = "adhesion"
    stable: Callable[..., bool]
    sprayed: Callable[..., bool]
    closed: Callable[..., bool]

    def __init__(
        self,
        config: UavConfig,
        fc: FlightController,
        sprayer: Sprayer,
        link: MissionLink,
        clock: Clock,
    ) -> None:
        self.sprayer = sprayer
        n = config.airframe.nozzle_offset_m
        self._nozzle: tuple[float, float, float] = (float(n[0]), float(n[1]), float(n[2]))
        self._stable_since_s: float | None = None
        self._yaw_rad = 0.0
        self._climbing = False  # in ``ascend``: the climb out has begun (no chaining any more)
        self._climb_to_m = config.cruise_altitude_m  # in ``ascend``: the transit altitude of the task just done
        super().__init__(config, fc, link, clock, ADHESION_STATES, ADHESION_TRANSITIONS)

    _TASK_STATES_SET = frozenset(ADHESION_TASK_STATES)

    @property
    def adhesion_task(self) -> AdhesionTask:
        assert isinstance(self.task, AdhesionTask)
        return self.task

    def _task_problem(self, task: Task) -> str | None:
        assert isinstance(task, AdhesionTask)
        if math.dist(task.start_m, task.end_m) < 1e-6:
            return f"adhesion task {task.id} has an empty segment"
        return None

    def _transit_altitude_m(self) -> float:
        z = self.config.cruise_altitude_m
        if isinstance(self.task, AdhesionTask):
            t = self.task
            surface = max(t.start_m[2], t.end_m[2])
            z = max(
                z, surface + self.config.airframe.spray_height_m - self._nozzle[2] + self.config.clearance_m
            )
        return z

    def _nozzle_body(self, point_m: tuple[float, float, float] | np.ndarray) -> np.ndarray:
        p = np.array([point_m[0], point_m[1], point_m[2] + self.config.airframe.spray_height_m])
        return self._tool_body_target(p, self._nozzle, self._yaw_rad)

    def _safe_actuators(self) -> None:
        self.sprayer.set_valve(False)

    def _on_landed(self) -> None:
        if self.sprayer.is_valve_open():
            self.sprayer.set_valve(False)

    def enter_cruise(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self._yaw_rad = tel.attitude_rad[2]
        start = self._nozzle_body(self.adhesion_task.start_m)
        end = self._nozzle_body(self.adhesion_task.end_m)  # it sprays along to there: part of its zone
        top = self._transit_altitude_m()
        if self._chains(tel.position_m, start):
            # still down at the end of the last segment, which is where this one starts: stay down
            self._route(tel, start, yaw_rad=self._yaw_rad, top_m=top, to_m=end)
            return
        self._route(tel, np.array([start[0], start[1], top]), yaw_rad=self._yaw_rad, to_m=end)

    def _chains(self, position_m: Sequence[float], start_body_m: Sequence[float] | np.ndarray) -> bool:
        """The body at ``position_m`` is within ``chain_distance_m`` (horizontally and vertically) of the body
        position that sprays the segment's start: the UAV sprays it without climbing out."""
        d = self.config.chain_distance_m
        return (
            math.hypot(position_m[0] - start_body_m[0], position_m[1] - start_body_m[1]) <= d
            and abs(position_m[2] - start_body_m[2]) <= d
        )

    def do_cruise(self, tel: Telemetry) -> None:
        if self._leg_done(tel):
            self.arrived()
        elif self._now_s > self._traj_end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not reach the start of {self.adhesion_task.id}")

    def enter_hover(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self._stable_since_s = None
        self._hold(tel, self._target.copy(), self._yaw_rad)

    def do_hover(self, tel: Telemetry) -> None:
        cfg = self.config
        p, t, v = tel.position_m, self._target, tel.velocity_mps
        still = (
            math.dist(p, t) <= 2.0 * cfg.align_tolerance_m
            and math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2) <= cfg.settle_speed_mps
            and self._yaw_error(tel) <= cfg.align_yaw_tolerance_rad
        )
        if not still:
            self._stable_since_s = None
        elif self._stable_since_s is None:
            self._stable_since_s = self._now_s
        elif self._now_s - self._stable_since_s >= cfg.stable_time_s:
            self.stable()
            return
        if self._now_s > self._traj_end_s + cfg.leg_timeout_s:
            self.abort(reason=f"could not hover still over the start of {self.adhesion_task.id}")

    def enter_descend(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        start = self._nozzle_body(self.adhesion_task.start_m)
        # a chained segment: the UAV hovers at the spraying height already
        short = abs(tel.position_m[2] - start[2]) <= self.config.chain_distance_m
        self._fly_to(
            tel, start, self.config.chain_descent_s if short else self.config.spray_descent_s, self._yaw_rad
        )

    def do_descend(self, tel: Telemetry) -> None:
        if self._leg_done(tel, self.config.spray_tolerance_m):
            self.reached()
        elif self._now_s > self._traj_end_s + self.config.release_timeout_s:
            self.abort(reason=f"could not reach the spraying height over {self.adhesion_task.id}")

    def enter_spray(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        t = self.adhesion_task
        self.sprayer.set_valve(True)
        self._fly_line(
            tel, self._nozzle_body(t.start_m), self._nozzle_body(t.end_m), self.config.spray_speed_mps
        )

    def do_spray(self, tel: Telemetry) -> None:
        cfg = self.config
        if (
            self._leg_done(tel, cfg.spray_tolerance_m)
            or self._now_s > self._traj_end_s + cfg.release_timeout_s
        ):
            self.sprayed()

    def enter_close(self, *args: Any, **kwargs: Any) -> None:
        tel = self._tel
        assert tel is not None
        self.sprayer.set_valve(False)
        self._hold(tel, self._target.copy(), self._yaw_rad)

    def do_close(self, tel: Telemetry) -> None:
        if self._now_s - self._entered_s >= self.config.close_dwell_s:
            self.closed()

    def enter_ascend(self, *args: Any, **kwargs: Any) -> None:
        # The segment is sprayed and the valve closed: the task is done, reported now so that mission control
        # can hand over the next one while the UAV is still down here (see ``do_ascend``).
        tel = self._tel
        assert tel is not None
        self._climb_to_m = self._transit_altitude_m()
        self._report_done()
        self._next_task = None
        self._climbing = False
        self._hold(tel, self._target.copy(), self._yaw_rad)

    def do_ascend(self, tel: Telemetry) -> None:
        """After a segment: hover up to ``chain_wait_s`` for the next task; one starting where the nozzle is goes
        on from down here (``cruise`` stays low), anything else (or nothing) climbs to the transit altitude first,
        then goes to it (or home)."""
        if self._next_task is None and self._may_take_task(tel):
            task = self._take(self.link.poll_task())
            if task is not None:
                self._next_task = task
                self._start_task(task)
        if not self._climbing:
            nxt = self._next_task
            if isinstance(nxt, AdhesionTask) and self._chains(tel.position_m, self._nozzle_body(nxt.start_m)):
                self._leave_ascend()
                return
            if nxt is None and self._now_s - self._entered_s < self.config.chain_wait_s:
                return
            self._climbing = True
            p = tel.position_m
            top = max(self._climb_to_m, self._transit_altitude_m())  # the next task's, if it is higher
            self._fly_to(tel, np.array([p[0], p[1], top]))
            return
        if self._leg_done(tel):
            self._leave_ascend()

    def _leave_ascend(self) -> None:
        self.finish()  # to the next task's cruise, or home
        self._next_task = None
