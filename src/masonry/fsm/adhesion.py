"""The adhesion UAV (paper, Section V): the callbacks of the adhesion machine (:data:`states.ADHESION_STATES`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from masonry.fsm.attempt import AdhesionAttempt
from masonry.fsm.battery import LEG_SETTLE_S
from masonry.fsm.bead import BeadPass, BeadSettings
from masonry.fsm.config import UavConfig
from masonry.fsm.descent_reach import DescentReach, HeightRunOff
from masonry.fsm.hover_still import HoverStill
from masonry.fsm.model import UavModel
from masonry.fsm.noise_gate import MEAN_ALONE_AFTER
from masonry.fsm.states import ADHESION_STATES, ADHESION_TASK_STATES, ADHESION_TRANSITIONS
from masonry.fsm.tool import Tool
from masonry.planner.tasks import AdhesionTask, Task
from masonry.ports import ClearanceLink, Clock, FlightController, MissionLink, Sprayer, Telemetry
from masonry.timing import spray_descent_leg_s

Vec3 = tuple[float, float, float]

#: The smallest lean the nozzle's targets allow for (2 degrees: 1.2 cm at the nozzle's 0.35 m).
_LEAN_MIN_RAD = math.radians(2.0)
#: The time the lean is averaged over (turbulence tilts the UAV by as much again for a second or two).
_LEAN_TAU_S = 3.0


class AdhesionUav(UavModel):
    """The adhesion UAV (paper, Section V): spray a bead of adhesive along a segment.

    Args:
        config: the UAV (name, home, airframe, tuning).
        fc, sprayer, link, clock: its ports.
        clearance: mission control's airspace (None: no airspace, it flies with no separation from others).
    """

    KIND = "adhesion"
    attempt: AdhesionAttempt
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
        *,
        clearance: ClearanceLink | None = None,
    ) -> None:
        self.sprayer = sprayer
        self.nozzle = Tool.at(config.airframe.nozzle_offset_m)
        #: the heading it flies its segments at (set for each task on the way there; the chaining of the next
        #: task's segment is judged at it, so it outlives the attempt)
        self._yaw_rad = 0.0
        self._descent = DescentReach(config.gate_window_s or 1.0)  # (masonry.fsm.descent_reach)
        self._run_off = HeightRunOff()
        self._hover_still = HoverStill(config.gate_window_s or 1.0)  # (masonry.fsm.hover_still)
        self._climbing = False  # in ``ascend``: the climb out has begun (no chaining any more)
        self._climb_to_m = (
            config.cruise_altitude_m
        )  # in ``ascend``: the transit altitude of the task just done
        self._climb_over_m = (
            0.0,
            0.0,
        )  # in ``ascend``: the point it holds at the bead's end, climbed out over
        super().__init__(config, fc, link, clock, ADHESION_STATES, ADHESION_TRANSITIONS, clearance=clearance)

    _TASK_STATES_SET = frozenset(ADHESION_TASK_STATES)

    def _new_attempt(self, start_s: float, wait_budget_s: float) -> AdhesionAttempt:
        return AdhesionAttempt(start_s=start_s, wait_budget_s=wait_budget_s)

    @property
    def _bead(self) -> BeadPass:
        """The attempt's pass of the bead (``attempt.bead``; its old name, read by tests)."""
        return self.attempt.bead

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
        if isinstance(self.task, AdhesionTask):
            return self._spray_transit_m(self.task)
        return self.config.cruise_altitude_m

    def _spray_transit_m(self, t: AdhesionTask) -> float:
        """The transit altitude of adhesion task ``t``: cruise, raised so the nozzle clears the surface."""
        surface = max(t.start_m[2], t.end_m[2])
        return max(
            self.config.cruise_altitude_m,
            surface
            + self.config.airframe.spray_height_m
            - self.nozzle.offset_body_m[2]
            + self.config.clearance_m,
        )

    def _task_flight_s(self, task: Task, from_m: Vec3) -> tuple[float, Vec3]:
        """To the segment's start, the hover, the descent, the segment, the valve's close and the climb out."""
        if not isinstance(task, AdhesionTask):
            return 0.0, from_m
        cfg = self.config
        top = self._spray_transit_m(task)
        start = self._nozzle_body(task.start_m)
        end = self._nozzle_body(task.end_m)
        over_start = (float(start[0]), float(start[1]), top)
        climb_s = self.nav.leg_duration_s(end, np.array([end[0], end[1], top])) + LEG_SETTLE_S
        work_s = (
            cfg.stable_time_s
            + spray_descent_leg_s(top - float(start[2]), cfg.vertical_speed_mps, cfg.spray_descent_s)
            + LEG_SETTLE_S
            + task.length_m / cfg.spray_speed_mps
            + cfg.close_dwell_s
            + climb_s
        )
        return self._route_s(from_m, over_start) + work_s, (float(end[0]), float(end[1]), top)

    def _nozzle_body(
        self, point_m: tuple[float, float, float] | np.ndarray, tel: Telemetry | None = None
    ) -> np.ndarray:
        """The body position that puts the nozzle over ``point_m`` at the spraying height; with ``tel``, leaning
        as the UAV leans now (into a wind: 10 degrees at 4 m/s put a rigid nozzle 6 cm downwind of a level one,
        twice the bead's radius; the lean of a hover is that of the spray leg that follows it)."""
        p = np.array([point_m[0], point_m[1], point_m[2] + self.config.airframe.spray_height_m])
        tilt = None
        if tel is not None:
            roll, pitch = self.attempt.lean_rad
            # below _LEAN_MIN_RAD the shift (under 1.2 cm) is within the spray tolerance: fly level, as in calm
            # air (where a hover's tilt is a fraction of a degree of noise, and the schedules stay as they were)
            if roll * roll + pitch * pitch > _LEAN_MIN_RAD**2:
                tilt = (roll, pitch)
        return self.nozzle.body_target(p, self._yaw_rad, tilt)

    def _safe_actuators(self) -> None:
        self.sprayer.set_valve(False)

    def _on_landed(self) -> None:
        if self.sprayer.is_valve_open():
            self.sprayer.set_valve(False)

    def enter_cruise(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self._yaw_rad = tel.attitude_rad[2]
        start = self._nozzle_body(self.adhesion_task.start_m)
        end = self._nozzle_body(self.adhesion_task.end_m)  # it sprays along to there: part of its zone
        top = self._transit_altitude_m()
        if self._chains(self._resting_at(tel), start):
            # still down at the end of the last segment, which is where this one starts: stay down
            self._route(tel, start, yaw_rad=self._yaw_rad, top_m=top, to_m=end)
            return
        self._route(tel, np.array([start[0], start[1], top]), yaw_rad=self._yaw_rad, to_m=end)

    def _resting_at(self, tel: Telemetry) -> Sequence[float]:
        """Where the UAV comes to rest: the point it holds, if it is near it (an autopilot that shapes its
        setpoints coasts a few centimetres past the end of a bead: 4-6 cm on the ``arducopter`` vehicle, which
        broke chains of 5 cm), else where it is."""
        held = self.nav.target_m
        p = tel.position_m
        if math.dist(p, held) <= 3.0 * self.config.chain_distance_m:
            return (float(held[0]), float(held[1]), float(held[2]))
        return p

    def _chains(self, position_m: Sequence[float], start_body_m: Sequence[float] | np.ndarray) -> bool:
        """The body at ``position_m`` is within ``chain_distance_m`` (horizontally and vertically) of the body
        position that sprays the segment's start: the UAV sprays it without climbing out."""
        d = self.config.chain_distance_m
        return (
            math.hypot(position_m[0] - start_body_m[0], position_m[1] - start_body_m[1]) <= d
            and abs(position_m[2] - start_body_m[2]) <= d
        )

    def do_cruise(self, tel: Telemetry) -> None:
        if self._advance(tel):
            self.arrived()
        elif self._now_s > self.nav.end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not reach the start of {self.adhesion_task.id}")

    def enter_hover(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.attempt.stable_since_s = None
        self._hover_still.reset()
        self.attempt.lean_rad = (tel.attitude_rad[0], tel.attitude_rad[1])
        self._hold(tel, self.nav.target_m.copy(), self._yaw_rad)

    def _follow_lean(self, tel: Telemetry) -> None:
        k = min(1.0, self.config.control_period_s / _LEAN_TAU_S)
        roll, pitch = self.attempt.lean_rad
        self.attempt.lean_rad = (
            roll + (tel.attitude_rad[0] - roll) * k,
            pitch + (tel.attitude_rad[1] - pitch) * k,
        )

    def do_hover(self, tel: Telemetry) -> None:
        cfg = self.config
        self._follow_lean(tel)
        p, t, v = tel.position_m, self.nav.target_m, tel.velocity_mps
        # Patience (issue 19): in turbulence the UAV may never sit within 3 cm and 0.08 m/s for stable_time_s;
        # align_patience_s past the leg's end both limits double (the spray leg then starts from up to 6 cm off
        # its start and catches up along the segment: coverage counts what it covers), and leg_timeout_s still
        # ends the attempt with a reason.
        scale = 2.0 if self._now_s > self.nav.end_s + cfg.align_patience_s else 1.0
        if cfg.gate_window_s > 0.0:
            # a noisy position source (the px4 preset): the window's mean position and velocity, not a run of
            # ticks (masonry.fsm.hover_still); the window is the stable time
            self._hover_still.add(self._now_s, [p[i] - t[i] for i in range(3)], v)
            if self._hover_still.still(
                scale * 2.0 * cfg.align_tolerance_m,
                scale * cfg.settle_speed_mps,
                margin=self._now_s <= self.nav.end_s + MEAN_ALONE_AFTER * cfg.leg_timeout_s,
            ) and (self._yaw_error(tel) <= scale * cfg.align_yaw_tolerance_rad):
                self.stable()
                return
        still = (
            cfg.gate_window_s <= 0.0
            and math.dist(p, t) <= scale * 2.0 * cfg.align_tolerance_m
            and math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2) <= scale * cfg.settle_speed_mps
            and self._yaw_error(tel) <= scale * cfg.align_yaw_tolerance_rad
        )
        attempt = self.attempt
        if not still:
            attempt.stable_since_s = None
        elif attempt.stable_since_s is None:
            attempt.stable_since_s = self._now_s
        elif self._now_s - attempt.stable_since_s >= cfg.stable_time_s:
            self.stable()
            return
        swinging = self._gate_failure(tel)
        if swinging is not None:
            self.abort(reason=f"could not hover still over the start of {self.adhesion_task.id}: {swinging}")
        elif self._now_s > self.nav.end_s + cfg.leg_timeout_s:
            self.abort(reason=f"could not hover still over the start of {self.adhesion_task.id}")

    def enter_descend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        start = self._nozzle_body(self.adhesion_task.start_m, tel)
        # a chained segment: the UAV hovers at the spraying height already
        drop_m = float(tel.position_m[2] - start[2])
        cfg = self.config
        if abs(drop_m) <= cfg.chain_distance_m:
            descent_s = cfg.chain_descent_s
        else:
            descent_s = spray_descent_leg_s(drop_m, cfg.vertical_speed_mps, cfg.spray_descent_s)
        self._descent.reset(descent_s)
        self._run_off.reset()
        # from rest on a noisy position source (the px4 preset), as the brick's descents (BrickUav.
        # _descent_from_rest): the hover's gate passed on its window's mean at any phase of the wander, and a leg
        # started with that tick's velocity strays about 0.2 v0 T to the side (issue 29: 8 cm on the real PX4)
        self._fly_to(tel, start, descent_s, self._yaw_rad, cfg.gate_window_s > 0.0)

    def do_descend(self, tel: Telemetry) -> None:
        cfg = self.config
        self._follow_lean(tel)
        # patience, as in the hover: align_patience_s past the descent's end the tolerance doubles; the attempt
        # ends (with its reason) at release_timeout_s or, if later, twice the patience; on a noisy position source
        # those count from the reported height's return after it ran off (masonry.fsm.descent_reach.HeightRunOff)
        self._run_off.hold(self.nav, self._now_s, float(tel.position_m[2]), cfg)
        late = self._now_s - self.nav.end_s
        tolerance_m = cfg.spray_tolerance_m * (2.0 if late > cfg.align_patience_s else 1.0)
        if cfg.gate_window_s > 0.0:
            # a noisy position source (the px4 preset): the window's mean about the descent's reference, not one
            # tick (masonry.fsm.descent_reach); the tick's speed as before
            ref = self.nav.reference(self._now_s)[0]
            p, target = tel.position_m, self.nav.target_m
            self._descent.add(self._now_s, [p[i] - float(ref[i]) for i in range(3)])
            arrived = self._advance(tel, math.inf) and self._descent.reached(
                [float(ref[i]) - float(target[i]) for i in range(3)], tolerance_m
            )
        else:
            arrived = self._advance(tel, tolerance_m)
        if arrived:
            self.reached()
        elif late > max(cfg.release_timeout_s, 2.0 * cfg.align_patience_s):
            self.attempt.spray_descents += 1
            if self.attempt.spray_descents < cfg.max_spray_descents:
                self.enter_descend()  # once more, a fresh leg from where it is (its window restarts)
                return
            self.abort(
                reason=f"could not reach the spraying height over {self.adhesion_task.id}"
                f" after {self.attempt.spray_descents} descents"
            )

    def enter_spray(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        t = self.adhesion_task
        cfg = self.config
        self.attempt.bead = BeadPass(
            t.start_m,
            t.end_m,
            BeadSettings(
                speed_mps=cfg.spray_speed_mps,
                valve_radius_m=cfg.spray_valve_radius_m,
                check_radius_m=cfg.spray_check_radius_m,
                lead_m=cfg.spray_lead_m,
            ),
        )
        self.attempt.bead_tick_s = self._now_s
        # the spray ends by then, covered or not (bounded: gusts that never let the nozzle cover it end the task,
        # which reports the coverage it measured)
        self.attempt.spray_deadline_s = (
            self._now_s + self.attempt.bead.length_m / cfg.spray_speed_mps + cfg.spray_patience_s
        )
        self._steer_bead(tel)

    def _steer_bead(self, tel: Telemetry) -> bool:
        """One tick of the pass (:mod:`masonry.fsm.bead`): the nozzle (measured: position, lever arm, tilt) marks
        what it covered, the valve follows it on and off the bead, and the body flies the point that puts the
        nozzle on the bead's reference as the UAV leans now (in turbulence the tilt swings by 10-20 degrees within
        seconds: 6-12 cm at the nozzle's 0.35 m, more than the 3 cm bead radius); True when the pass is over."""
        cfg = self.config
        attempt = self.attempt
        dt = self._now_s - attempt.bead_tick_s
        attempt.bead_tick_s = self._now_s
        nozzle = self.nozzle.position(tel)
        above = float(nozzle[2]) - self.adhesion_task.start_m[2]
        step = attempt.bead.step(dt, nozzle, -0.01 <= above <= cfg.spray_check_height_m)
        if step.valve_open != self.sprayer.is_valve_open():
            self.sprayer.set_valve(step.valve_open)
        ref = step.nozzle_ref_m
        body = self.nozzle.body_target(
            (ref[0], ref[1], ref[2] + cfg.airframe.spray_height_m),
            self._yaw_rad,
            (tel.attitude_rad[0], tel.attitude_rad[1]),
        )
        bead = attempt.bead
        remaining_s = abs((bead.length_m if bead.direction > 0 else 0.0) - bead.progress_m)
        self.nav.steer(self._now_s, body, step.velocity_mps, self._now_s + remaining_s / cfg.spray_speed_mps)
        return step.pass_over

    def do_spray(self, tel: Telemetry) -> None:
        cfg = self.config
        over = self._steer_bead(tel)
        bead = self.attempt.bead
        if over and bead.coverage() < 1.0:
            bead.turn()  # a gap left (the nozzle pushed off): back along the segment over it, valve on the bead
            over = False
        if over:
            self.sprayed()
        elif self._now_s > self.attempt.spray_deadline_s:
            # bounded: gusts that never let the nozzle cover the segment end the spray; below spray_min_coverage
            # the attempt fails (mission control tries again: what was sprayed stays)
            if bead.coverage() >= cfg.spray_min_coverage:
                self.sprayed()
            else:
                self.abort(
                    reason=f"sprayed {bead.coverage():.0%} of the bead of {self.adhesion_task.id} in "
                    f"{self._now_s - self._entered_s:.0f} s, {bead.passes} passes: gusts kept the nozzle off it"
                )

    def enter_close(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.sprayer.set_valve(False)
        self._hold(tel, self.nav.target_m.copy(), self._yaw_rad)

    def do_close(self, tel: Telemetry) -> None:
        if self._now_s - self._entered_s >= self.config.close_dwell_s:
            self.closed()

    def enter_ascend(self, *args: object, **kwargs: object) -> None:
        # The segment is sprayed and the valve closed: the task is done, reported now so that mission control
        # can hand over the next one while the UAV is still down here (see ``do_ascend``).
        tel = self._tel
        assert tel is not None
        self._climb_to_m = self._transit_altitude_m()
        self._report_done(
            coverage=self.attempt.bead.coverage()
        )  # its own measure: what the nozzle's track covered
        self._next_task = None
        self._climbing = False
        held = self.nav.target_m.copy()
        self._climb_over_m = (float(held[0]), float(held[1]))
        self._hold(tel, held, self._yaw_rad)

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
            if isinstance(nxt, AdhesionTask) and self._chains(
                self._resting_at(tel), self._nozzle_body(nxt.start_m)
            ):
                self._leave_ascend()
                return
            if nxt is None and self._now_s - self._entered_s < self.config.chain_wait_s:
                return
            self._climbing = True
            # inside the zone it holds (issue 27 §4.3): over the bead's end it holds, not over where it coasted
            # to (0.10-0.13 m past a zone without slack at compact r_c), and up to the zone's top (this segment's
            # transit altitude), not the next task's if that is higher (0.14-0.24 m over the top on the pyramid
            # and the 200-brick bond): the climb on to it is the next flight's, reserved before it is flown
            x, y = self._climb_over_m
            self._fly_to(tel, np.array([x, y, self._climb_to_m]))
            return
        if self._advance(tel):
            self._leave_ascend()

    def _leave_ascend(self) -> None:
        self.finish()  # to the next task's cruise, or home
        self._next_task = None
