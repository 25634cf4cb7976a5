"""The brick-carrier UAV (paper, Section IV): the callbacks of the brick machine (:data:`states.BRICK_STATES`).

Its put-back, carrying altitude and way out of a task are :mod:`masonry.fsm.putback`'s, its re-seat of a brick
placed out of place :mod:`masonry.fsm.reseat`'s; what it has done of the task in hand is its
:class:`~masonry.fsm.attempt.BrickAttempt` (``attempt``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from masonry.fsm.as_built import AsBuiltLook
from masonry.fsm.base import Vec3
from masonry.fsm.brick_sight import sight_brick
from masonry.fsm.camera_align import CameraAlign, track_brick
from masonry.fsm.config import UavConfig
from masonry.fsm.descent_reach import HeightRunOff
from masonry.fsm.dropoff_reach import DropoffReach, dropoff_error_m
from masonry.fsm.noise_gate import MEAN_ALONE_AFTER, HoverNoise, noise_aligned
from masonry.fsm.release_gate import ReleaseGate
from masonry.fsm.reseat import Reseat
from masonry.fsm.side_look import SideLook, heading_flip_rad
from masonry.fsm.states import BRICK_STATES, BRICK_TASK_STATES, BRICK_TRANSITIONS, leaf_states
from masonry.fsm.tool import Tool
from masonry.fsm.wall_align import WallAlign
from masonry.fsm.wind_lean import WindLean, place_gains
from masonry.geometry import wrap_angle_rad
from masonry.marker_reuse import identify_radius_m
from masonry.perception.estimation import EstimatorConfig, PoseWindow
from masonry.planner.tasks import BrickTask, Task
from masonry.ports import Camera, ClearanceLink, Clock, FlightController, Gripper, MissionLink, Telemetry

#: Hovering and aligning over a brick (estimate, align): seconds the battery budget counts for them.
_ALIGN_S = 3.0
#: A brick UAV this far (horizontally) from its estimate hover point has been blown off it: its camera looks
#: elsewhere, and the time there does not count against the estimate's deadline.
_ESTIMATE_OFF_M = 0.25


class BrickUav(Reseat):
    """The brick-carrier UAV (paper, Section IV): pick a brick up near ``pickup_m``, place it on the wall.

    Args:
        config: the UAV (name, home, airframe, tuning).
        fc, gripper, camera, link, clock: its ports.
        clearance: mission control's airspace (None: no airspace, it flies with no separation from others).
    """

    KIND = "brick"
    #: The swing gate counts the horizontal speed: the alignments it guards judge the horizontal position and speed
    #: only, and PX4's hover wanders vertically (issue 29; the vertical speed had made up to a fifth of a failed
    #: gate's mean square on the real PX4 SITL).
    SWING_AXES = 2
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
    stow: Callable[..., bool]

    def __init__(
        self,
        config: UavConfig,
        fc: FlightController,
        gripper: Gripper,
        camera: Camera,
        link: MissionLink,
        clock: Clock,
        *,
        clearance: ClearanceLink | None = None,
    ) -> None:
        self.gripper = gripper
        self.camera = camera
        self._est_config = EstimatorConfig(spacing_m=config.markers.spacing_m, up=(0.0, 0.0, 1.0))
        self.window = PoseWindow(size=config.window_size, sigma_tol_m=config.sigma_tol_m)
        self._T_body_cam = np.asarray(camera.T_body_cam, dtype=float)
        self._sight_m = identify_radius_m(config.markers)  # a reused marker number is another brick beyond it
        # the rod descends on its unlocked ball joint: it hangs plumb however the UAV leans (masonry.fsm.tool)
        self.effector = Tool.at(config.airframe.effector_offset_m, plumb=True)
        self._camera_align = CameraAlign()
        self.as_built = AsBuiltLook(config.window_size, config.sigma_tol_m)
        self._wall = WallAlign()  # (masonry.fsm.wall_align: with align_on_wall only)
        self._side = SideLook()  # (masonry.fsm.side_look: a tower's support, hidden from above)
        self._gate = ReleaseGate()  # (masonry.fsm.release_gate: a release on a fresh sighting of the wall)
        self._flip_of: tuple[tuple[str, float], float] | None = None  # (_place_yaw_rad)
        self._gate_noise = HoverNoise(config.gate_window_s or 1.0)
        self._gate_entered_s = math.nan
        self._dropoff = DropoffReach(config.gate_window_s or 1.0)  # (masonry.fsm.dropoff_reach)
        # (masonry.fsm.descent_reach: EKF2's height run off past the leg's end)
        self._run_off = HeightRunOff()
        self._lean = WindLean()  # (masonry.fsm.wind_lean: the pickup's hovers)
        super().__init__(config, fc, link, clock, BRICK_STATES, BRICK_TRANSITIONS, clearance=clearance)

    _TASK_STATES_SET = frozenset(s for s in leaf_states(BRICK_STATES) if s.split("_")[0] in BRICK_TASK_STATES)

    @property
    def on_wall(self) -> bool:
        """This placement aligns on the wall's markers: ``align_on_wall``, or in a wind (masonry.fsm.wind_lean)."""
        return self.config.align_on_wall or self.attempt.in_wind

    @property
    def climbs(self) -> int:
        """Climbs made to widen the camera's view (this task)."""
        return self.attempt.climbs

    @property
    def grasp_attempts(self) -> int:
        return self.attempt.grasp_attempts

    @property
    def place_attempts(self) -> int:
        return self.attempt.place_attempts

    @property
    def release_attempts(self) -> int:
        return self.attempt.release_attempts

    @property
    def brick_estimate(self) -> tuple[np.ndarray, float] | None:
        """The brick's estimated top-face centre (world, m) and yaw (rad), once estimated."""
        return self.attempt.brick_estimate

    @property
    def estimates_seen(self) -> int:
        return self.attempt.estimates_seen

    def _task_problem(self, task: Task) -> str | None:
        assert isinstance(task, BrickTask)
        if task.pickup_m is None:
            return f"brick task {task.id} has no pickup location"
        return None

    def _task_flight_s(self, task: Task, from_m: Vec3) -> tuple[float, Vec3]:
        """To the pickup, the estimate and the grasp, the carry, the placement and the climb out of it."""
        if not isinstance(task, BrickTask) or task.pickup_m is None:
            return 0.0, from_m
        cfg = self.config
        carry_z = self._carry_altitude_m(task)
        eff_z = self.effector.offset_body_m[2]
        hover = (task.pickup_m[0], task.pickup_m[1], cfg.cruise_altitude_m)
        over_pickup = (hover[0], hover[1], carry_z)
        over_drop = (task.position_m[0], task.position_m[1], carry_z)
        at_brick_z = task.pickup_m[2] + task.size_m[2] / 2.0 - eff_z  # the body over the brick's top
        at_drop_z = task.position_m[2] + task.size_m[2] / 2.0 - eff_z
        pick_s = (
            cfg.settle_time_s
            + cfg.min_estimates * cfg.control_period_s
            + _ALIGN_S
            + cfg.descent_duration_s
            + cfg.grasp_dwell_s
            + self._vertical_s(carry_z - at_brick_z)
        )
        place_s = (
            _ALIGN_S + cfg.descent_duration_s + cfg.release_dwell_s + self._vertical_s(carry_z - at_drop_z)
        )
        flight_s = self._route_s(from_m, hover) + pick_s + self._route_s(over_pickup, over_drop) + place_s
        return flight_s, over_drop

    # -- pickup --------------------------------------------------------------------------------------------
    def enter_pickup_goto(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_magnet(False)
        self.gripper.set_joint_locked(True)
        pickup = self.brick_task.pickup_m
        assert pickup is not None
        self.attempt.hover_z = self.config.cruise_altitude_m
        # it may climb max_climbs steps there to widen the camera's view, and it climbs out with the brick to its
        # transit altitude: both are part of its column
        top = max(
            self.attempt.hover_z + self.config.max_climbs * self.config.climb_step_m,
            self._transit_altitude_m(),
        )
        self._route(tel, np.array([pickup[0], pickup[1], self.attempt.hover_z]), top_m=top)

    def do_pickup_goto(self, tel: Telemetry) -> None:
        if self._advance(tel):
            self.arrived()
        elif self._now_s > self.nav.end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not reach the pickup of {self.brick_task.id}")

    def climb_step(self, *args: object, **kwargs: object) -> None:
        """Before re-entering ``estimate``: one step up to widen the camera's view."""
        self.attempt.climbs += 1
        self.attempt.hover_z += self.config.climb_step_m

    def enter_pickup_estimate(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        p = tel.position_m
        if self.attempt.hover_z == 0.0:
            self.attempt.hover_z = p[2]
        # a climb to widen the view climbs where the estimate hovered, not where a gust has put the UAV (each
        # climb re-anchored there took a brick UAV 20 m off its pickup in moderate turbulence, issue 18)
        if self.attempt.hover_xy is None:
            self.attempt.hover_xy = (p[0], p[1])
        x, y = self.attempt.hover_xy
        target = np.array([x, y, self.attempt.hover_z])
        if abs(self.attempt.hover_z - p[2]) > 0.05:
            self._fly_to(tel, target)
        else:
            self._hold(tel, target)
        self.window.clear()
        self.attempt.estimates_seen = 0
        self.attempt.deadline_s = self._now_s + self.config.settle_time_s + self.config.estimate_timeout_s
        if self.nav.traj is not None:
            self.attempt.deadline_s += self.nav.traj.duration_s

    def do_pickup_estimate(self, tel: Telemetry) -> None:
        cfg = self.config
        off_m = math.dist(tel.position_m[:2], self.nav.target_m[:2])
        if off_m > _ESTIMATE_OFF_M:
            # blown off the hover point by a gust: the camera looks elsewhere, the time does not count against
            # the estimate's deadline (patience, bounded by leg_timeout_s in all)
            self.attempt.off_s += cfg.control_period_s
            self.attempt.deadline_s += cfg.control_period_s
            if self.attempt.off_s > cfg.leg_timeout_s:
                self.abort(
                    reason=f"blown {off_m:.1f} m off the pickup of {self.brick_task.id} "
                    f"for {self.attempt.off_s:.0f} s while estimating brick {self.brick_task.brick}"
                )
                return
        settling = self._now_s < self.nav.end_s + cfg.settle_time_s
        if not settling:
            self._collect(tel)
        conf = self.window.confidence()
        if conf is not None and conf >= cfg.confidence_threshold and self.window.count >= cfg.min_estimates:
            center, yaw = self.window.mean()
            self.attempt.brick_estimate = (np.array(center, dtype=float), float(yaw))
            self.estimated()
        elif self._now_s >= self.attempt.deadline_s:
            if self.attempt.climbs < cfg.max_climbs:
                self.widen()
            elif self.attempt.estimates_seen == 0:
                self.abort(
                    reason=f"brick {self.brick_task.brick} not seen near its pickup "
                    f"after {self.attempt.climbs} climbs"
                )
            else:
                self.abort(
                    reason=f"brick {self.brick_task.brick} pose confidence "
                    f"{conf if conf is not None else 0.0:.2f} stayed below {cfg.confidence_threshold:.2f} "
                    f"after {self.attempt.climbs} climbs"
                )

    def _collect(self, tel: Telemetry) -> None:
        est = self._fresh_estimate(tel)
        if est is not None:
            self.window.add(est[0], est[1])
            self.attempt.estimates_seen += 1

    def _fresh_estimate(self, tel: Telemetry) -> tuple[np.ndarray, float] | None:
        """The brick's top-face centre (world, m) and yaw as the camera sees it now, from ``tel``'s pose."""
        cfg = self.config
        return sight_brick(
            self.camera, self._T_body_cam, tel, self.brick_task, cfg.markers, self._est_config, self._sight_m
        )

    def enter_pickup_align(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None and self.attempt.brick_estimate is not None
        center, yaw = self.attempt.brick_estimate
        above = np.array([center[0], center[1], tel.position_m[2] + self.effector.offset_body_m[2]])
        self._place_gains(self._lean.windy(self.config.wall_in_wind_rad, self.config.wind_held_rad))
        self._fly_to(tel, self.effector.body_target(above, yaw), yaw_rad=yaw)
        self._camera_align.reset(center)

    def do_pickup_align(self, tel: Telemetry) -> None:
        cfg = self.config
        self._lean.follow(tel, cfg.control_period_s)
        if cfg.align_on_camera:
            track_brick(self, self._camera_align, tel)
        if self._aligned(tel):
            self.aligned()
        elif (swinging := self._gate_failure(tel)) is not None:
            self.abort(reason=f"could not align above brick {self.brick_task.brick}: {swinging}")
        elif self._now_s > self.nav.end_s + cfg.leg_timeout_s:
            self.abort(reason=f"could not align above brick {self.brick_task.brick}")

    def _aligned(self, tel: Telemetry) -> bool:
        cfg = self.config
        if self._now_s < self.nav.end_s or self._yaw_error(tel) > cfg.align_yaw_tolerance_rad:
            return False
        p, t, v = tel.position_m, self.nav.target_m, tel.velocity_mps
        tolerance, speed = cfg.align_tolerance_m, cfg.settle_speed_mps
        if self._now_s > self.nav.end_s + cfg.align_patience_s:
            tolerance, speed = max(tolerance, cfg.align_relaxed_tolerance_m), 2.0 * speed
        if cfg.gate_window_s > 0.0:  # the mean over a window, for a noisy position source (noise_gate.py)
            noise = self._gate_noise
            if self._gate_entered_s != self._entered_s:
                self._gate_entered_s = self._entered_s
                noise.reset()
            noise.add(self._now_s, (p[0] - t[0], p[1] - t[1]), (v[0], v[1]))
            # half the leg's timeout on, the mean alone: the margin is the autopilot's own wander (noise_gate.py)
            margin = self._now_s <= self.nav.end_s + MEAN_ALONE_AFTER * cfg.leg_timeout_s
            return noise_aligned(noise, tolerance, speed, margin=margin)
        return math.hypot(p[0] - t[0], p[1] - t[1]) <= tolerance and math.hypot(v[0], v[1]) <= speed

    @property
    def _descent_from_rest(self) -> bool:
        """A descent after an alignment gate starts from rest on a noisy position source (``gate_window_s``, the
        ``px4`` preset; issue 29): the gate passed on the window's mean, at any phase of the hover's wander, and a
        minimum-jerk leg started with that tick's velocity v0 carries it out to about 0.2 v0 T to the side. On the
        real PX4 v1.16 SITL the hover swings 4-5 cm at up to 0.14 m/s: a 7 s descent swung 15-25 cm off its
        drop-off, the UAV came out of it overshooting and crossed the 1.5 cm disc rather than settling in it
        ("drop-off of B1 not reached within 1.5 cm after 3 descents"). The UAV rests at the point by the gate's
        mean, so the leg does too. Elsewhere the leg starts from the UAV's state, as in the paper."""
        return self.config.gate_window_s > 0.0

    def enter_pickup_descend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None and self.attempt.brick_estimate is not None
        center, yaw = self.attempt.brick_estimate
        self.gripper.set_joint_locked(False)
        self.gripper.set_magnet(True)
        grasp = np.array([center[0], center[1], center[2] - self.config.grasp_press_m])
        body = self.effector.body_target(grasp, yaw)
        self._fly_to(tel, body, self.config.descent_duration_s, yaw, self._descent_from_rest)

    def do_pickup_descend(self, tel: Telemetry) -> None:
        self._lean.follow(tel, self.config.control_period_s)
        if self.config.align_on_camera:
            track_brick(self, self._camera_align, tel)
        if self._now_s >= self.nav.end_s:
            self.touched()

    def enter_pickup_grasp(self, *args: object, **kwargs: object) -> None:
        self._run_off.reset()  # keep tracking the descent's end point (pressing on the brick) with the magnet on

    def do_pickup_grasp(self, tel: Telemetry) -> None:
        # Press on the brick with the magnet on for the dwell (the magnet grips on contact; polling lets an
        # actuator board report it), then climb: the verification happens at cruise altitude. A body still above
        # the brick (an autopilot's vertical lag) presses on for up to grasp_patience_s (masonry.fsm.grasp_reach).
        # On a noisy position source the press does not count while EKF2's height has run off (the body reported
        # decimetres above the brick: descent_reach.HeightRunOff; a CI-load flight's first grasp pressed out its
        # patience 0.5 m up, then missed)
        if self._pressed(tel):
            self.attempt.grasp_yaw_rad = tel.attitude_rad[2]
            self.grasped()

    def enter_pickup_ascend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        p = tel.position_m
        self._fly_to(tel, np.array([p[0], p[1], self._transit_altitude_m()]))

    def do_pickup_ascend(self, tel: Telemetry) -> None:
        if self._advance(tel):
            self.ascended()

    def enter_pickup_verify(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self._hold(tel)

    def do_pickup_verify(self, tel: Telemetry) -> None:
        if self.gripper.is_attached():
            assert self.attempt.brick_estimate is not None
            # The flange keeps the brick from turning on the magnet: remember its yaw relative to the body. Its
            # position is not compensated: the conical guide centres the brick under the effector (paper, IV).
            self.attempt.carry_yaw_rad = wrap_angle_rad(
                self.attempt.brick_estimate[1] - self.attempt.grasp_yaw_rad
            )
            self.attached()
            return
        self.attempt.grasp_attempts += 1
        self.gripper.set_magnet(False)
        if self.attempt.grasp_attempts >= self.config.max_grasp_attempts:
            self.abort(
                reason=f"brick {self.brick_task.brick} not attached after {self.attempt.grasp_attempts} grasps"
            )
        else:
            self.attempt.climbs = 0
            self.attempt.hover_z = self.config.cruise_altitude_m
            self.attempt.hover_xy = None
            self.missed()

    # -- transport and place -------------------------------------------------------------------------------
    def _control_period_s(self) -> float:
        """On the side look's last leg's pass, ``last_leg_period_s`` (where set): a tick every 2-3.5 cm of the pass
        across the 1.5 cm disc missed it between two ticks (docs/performance/autopilots.md)."""
        cfg = self.config
        period_s = cfg.last_leg_period_s
        if period_s > 0.0 and self.state == "place_descend" and self._side.final and not self._gate.looking:
            return min(period_s, cfg.control_period_s)
        return cfg.control_period_s

    def _place_yaw_rad(self) -> float:
        heading = self.brick_task.yaw_rad - self.attempt.carry_yaw_rad
        key = (self.brick_task.id, heading)  # (masonry.fsm.side_look.heading_flip_rad: a neighbour in view)
        if self._flip_of is None or self._flip_of[0] != key:
            self._flip_of = (key, heading_flip_rad(self, heading))
        return wrap_angle_rad(heading + self._flip_of[1])

    def _place_effector_target_m(self) -> np.ndarray:
        t = self.brick_task
        return np.array([t.position_m[0], t.position_m[1], t.position_m[2] + t.size_m[2] / 2.0])

    def enter_transport(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        yaw = self._place_yaw_rad()
        eff = self._place_effector_target_m()
        body = self.effector.body_target(eff, yaw)
        alt = self._transit_altitude_m()
        # The alignment hover of a side look (masonry.fsm.side_look) lies up to 0.5 m from the drop-off: the work
        # there spans drop-off to hover, and mission control must reserve it all (``to_m``), as it reserves an
        # adhesion UAV's segment. Planned now, as enter_place_align will plan it (the lean of the pickup's hovers
        # and the placement decide it; nothing changes them on the way).
        self.attempt.in_wind = self._lean.windy(self.config.wall_in_wind_rad, self.config.wind_held_rad)
        side = self._side.plan(self)
        to = np.array([body[0] + side[0], body[1] + side[1], alt]) if side.any() else None
        self._route(tel, np.array([body[0], body[1], alt]), yaw_rad=yaw, to_m=to)

    def do_transport(self, tel: Telemetry) -> None:
        if self._advance(tel):
            self.arrived()
        elif self._now_s > self.nav.end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not reach the drop-off of {self.brick_task.id}")

    def enter_place_align(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        if math.isnan(self.attempt.place_began_s):  # (masonry.fsm.reseat: how long a placement takes)
            self.attempt.place_began_s = self._now_s
        self.attempt.in_wind = self._lean.windy(self.config.wall_in_wind_rad, self.config.wind_held_rad)
        self._place_gains(self.attempt.in_wind)
        yaw = self._place_yaw_rad()
        body = self.effector.body_target(self._place_effector_target_m() + self._side.plan(self), yaw)
        self._fly_to(tel, np.array([body[0], body[1], self._transit_altitude_m()]), yaw_rad=yaw)
        self._wall.reset(self._place_effector_target_m())

    def do_place_align(self, tel: Telemetry) -> None:
        self._wall.track(self, tel)
        if self._aligned(tel):
            self.aligned()
        elif (swinging := self._gate_failure(tel)) is not None:
            self.abort(reason=f"could not align above the drop-off of {self.brick_task.id}: {swinging}")
        elif self._now_s > self.nav.end_s + self.config.leg_timeout_s:
            self.abort(reason=f"could not align above the drop-off of {self.brick_task.id}")

    def enter_place_descend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(False)
        yaw = self._place_yaw_rad()
        self.attempt.place_effector_target_m = self._place_effector_target_m()
        body = self.effector.body_target(
            self._side.descent_target_m(self.attempt.place_effector_target_m), yaw
        )
        self._fly_to(tel, body, self.config.descent_duration_s, yaw, self._descent_from_rest)
        self._wall.apply(self)
        self._gate.reset(self)
        self._dropoff.reset()
        self._run_off.reset()

    def do_place_descend(self, tel: Telemetry) -> None:
        cfg = self.config
        self._wall.track(self, tel)
        self._wall.carry(self)  # (masonry.fsm.wall_trend: the wander's trend since the frames of the target)
        self._gate.track(self)
        if self._gate.step(self, tel):  # looking back up for the wall: no release
            return
        # the wall's offset stale at the end of the displaced descent: look back up before the last leg
        if self._side.leg_due(self) and self._gate.before_leg(self, tel):
            return
        self._side.step(self, self._place_yaw_rad())
        self._side.track(self, tel, self._gate.looking)
        if self._gate.lost(self, tel):  # the last leg's pass missed the drop-off while fresh: look again now
            return
        self._run_off.hold(self.nav, self._now_s, float(tel.position_m[2]), cfg)
        error = dropoff_error_m(self, tel, self._dropoff)
        gate = self._gate
        if error is not None and (gate.closing(self, tel) or gate.wide(self, tel) or gate.low(self, tel)):
            error = None  # (masonry.fsm.release_gate: nearer by the next tick, wide of it, under the supports' tops)
        if error is not None and self._wall.lags(self) and self._wall.taken(self) is None:
            error = None  # (masonry.fsm.wall_align: the drop-off behind the wall in view would rest on a neighbour)
        if error is not None:
            taken = self._wall.taken(self)
            if taken is not None:  # (masonry.fsm.place_taken: another brick lies in its place)
                self.abort(reason=taken)
            elif self._gate.allows(self, tel):
                a = self.attempt
                a.release_error_m = error
                # (masonry.fsm.reseat: how long the placement took, from place_align to the release)
                a.placing_s, a.place_began_s = self._now_s - a.place_began_s, math.nan
                self.reached()
        elif self._now_s > self.nav.end_s + cfg.release_timeout_s and not self._gate.retries(self, tel):
            self.attempt.place_attempts += 1
            if self.attempt.place_attempts >= cfg.max_place_attempts:
                self.abort(
                    reason=f"drop-off of {self.brick_task.id} not reached within "
                    f"{cfg.placement_radius_m * 100:.1f} cm after {self.attempt.place_attempts} descents"
                )
            else:
                self.timeout()

    def enter_place_release(self, *args: object, **kwargs: object) -> None:
        ahead_s = self._gate.ahead_s  # (masonry.fsm.release_gate.ReleaseGate.ahead: timed within the tick)
        if ahead_s > 0.0:
            self.gripper.release_at(self._now_s + ahead_s)  # (False: it cannot time it, and has let go now)
        else:
            self.gripper.set_magnet(False)

    def _place_gains(self, in_wind: bool) -> None:
        """The position gains from this placement on (masonry.fsm.wind_lean.place_gains; only with
        ``wind_xy_kp_per_s``): the wind's from a placement in a wind until one in calm air."""
        cfg = self.config
        if cfg.wind_xy_kp_per_s > 0.0:
            self.nav.pid.set_gains(place_gains(cfg.pid_gains, cfg.wind_xy_kp_per_s, in_wind))

    def do_place_release(self, tel: Telemetry) -> None:
        if self._now_s - self._entered_s >= self.config.release_dwell_s:
            self.released()

    def enter_place_verify(self, *args: object, **kwargs: object) -> None:
        pass

    def do_place_verify(self, tel: Telemetry) -> None:
        if not self.gripper.is_attached():
            self.deposited()
            return
        self.attempt.release_attempts += 1
        if self.attempt.release_attempts >= self.config.max_release_attempts:
            self.abort(
                reason=f"brick {self.brick_task.brick} still attached after {self.attempt.release_attempts} releases"
            )
        else:
            self.stuck()

    def enter_place_ascend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        self.as_built.begin()
        self.attempt.reseat_judged = False
        p = tel.position_m
        self._fly_to(tel, np.array([p[0], p[1], self._transit_altitude_m()]))

    def do_place_ascend(self, tel: Telemetry) -> None:
        t = self.brick_task  # (masonry.fsm.as_built: the placed brick is under the camera as it climbs)
        self.as_built.look(
            self.camera,
            t.marker_ids[0] // 2,
            tel,
            self.config.markers,
            self._T_body_cam,
            self._est_config,
            self.config.wall,
        )
        climbed = self._advance(tel)
        if not self._reseat_now(tel, climbed) and climbed:  # (masonry.fsm.reseat: out of place, lifted again)
            self._complete_task(
                placement_error_m=self.attempt.release_error_m, as_built=self._as_built_pose()
            )
