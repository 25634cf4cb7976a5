"""UavConfig: everything a UAV's state machine needs to know about itself and its task execution."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, TypedDict

from masonry.airframe import DEFAULT_AIRFRAME, Airframe
from masonry.blueprint import DEFAULT_CRUISE_ALTITUDE_M, Blueprint, MarkerSpec, Role, UavSpec
from masonry.errors import InputError
from masonry.geofence import Site
from masonry.placement_check import wall_tops_m
from masonry.ports import TAKEOFF_TIMEOUT_S
from masonry.separation import pad_site_distance_m, zone_slack_m
from masonry.timing import DEFAULT_TIMING as _T
from masonry.timing import TaskTiming

Vec3 = tuple[float, float, float]

#: What may drive masonry's velocity loop's observer (:attr:`UavConfig.velocity_observer_input`).
VELOCITY_OBSERVER_INPUTS = ("command", "tilt")


@dataclass(frozen=True)
class UavConfig:
    """One UAV: identity, home, airframe, and the tuning of its task sequence (SI units).

    Defaults follow the paper where it gives a value (C_th = 0.75, minimum-jerk descent t_f = 7 s) and are
    otherwise chosen for the paper's indoor arena (a motion-capture volume of a few metres). The fields the
    makespan bound and the airspace count take their defaults from :class:`masonry.timing.TaskTiming`
    (:meth:`timing`).
    """

    name: str
    role: Role
    home_m: Vec3
    cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M
    markers: MarkerSpec = field(default_factory=MarkerSpec)
    airframe: Airframe = DEFAULT_AIRFRAME
    # Flight
    # control loop period: 10 Hz setpoints (ArduPilot guided and PX4 offboard need > 2 Hz)
    control_period_s: float = _T.control_period_s
    # peak speed of a lateral min-jerk leg, which lasts MIN_JERK_PEAK_TO_MEAN_SPEED (1.875) x distance / this
    cruise_speed_mps: float = _T.cruise_speed_mps
    vertical_speed_mps: float = _T.vertical_speed_mps  # peak speed of a climb leg (as cruise_speed_mps)
    # A leg's planned jerk and acceleration stay within these (a minimum-jerk leg of d metres over T seconds
    # starts with a jerk of 60 d / T^3 and peaks at 5.77 d / T^2): an autopilot that shapes setpoints with its
    # own limits (ArduCopter's PSC_JERK_XY 5 m/s^3, WPNAV_ACCEL 2.5 m/s^2) otherwise trails a short fast leg and
    # overshoots its end (issue 19: 0.3 m past a 0.35 m leg flown in the 1 s minimum). inf: no limit.
    leg_jerk_mps3: float = math.inf
    leg_accel_mps2: float = math.inf
    # ... and a lateral leg into the column over the UAV's own pad within this acceleration: the one column
    # mission control reserves with no slack beyond the separation's 0.1 m for tracking error (no work there;
    # masonry.mission.airspace.ColumnClearance.home_column), and a shaped autopilot overshoots a short leg's end
    # (the arducopter vehicle: 0.11-0.12 m past a 1.5 m leg at 1.1 m/s^2, 0.06 m at 0.5). inf: no other limit.
    pad_leg_accel_mps2: float = math.inf
    # ... and every lateral leg into a site or to a hold point within this while mission control's work zones and
    # hold hovers have no more slack than a short leg's overshoot less the 0.1 m each UAV's tracking error has
    # (zone_slack_m below; issue 27, bench_layouts --large seed 3302: two brick UAVs granted sites 1.20 m apart came
    # 0.996 m close, each 0.1 m past its 1.2 m leg's end). The arducopter vehicle overshoots a 0.6-2.2 m leg by
    # 0.059-0.076 m within 0.7 m/s^2 (0.049-0.054 m within 0.5, which cost compact walls twice the time). inf: none.
    zone_leg_accel_mps2: float = math.inf
    # The horizontal slack of mission control's work zones and hold hovers (masonry.separation.zone_slack_m of the
    # blueprint's r_c, by blueprint_settings: none at r_c under 1.2 m); inf: enough for any overshoot.
    zone_slack_m: float = math.inf
    arrive_tolerance_m: float = _T.arrive_tolerance_m  # a leg is over when the body is this close to its end
    # ... and slower than this (issue 19: on ArduCopter a leg was taken as over at 8 cm while still moving at
    # 1 m/s, and the next leg started from a swing); twice this after align_patience_s past the leg's planned end
    arrive_speed_mps: float = 0.3
    align_tolerance_m: float = 0.015  # horizontal alignment of the tool before a descent
    align_yaw_tolerance_rad: float = 0.05
    # In gusts the tool rarely sits within align_tolerance_m at a tick: after hovering align_patience_s past the
    # leg's end, alignment accepts align_relaxed_tolerance_m (inside the 3 cm grasp tolerance) and twice
    # settle_speed_mps.
    align_patience_s: float = 3.0
    align_relaxed_tolerance_m: float = 0.025
    # Issue 20 (GNSS-grade position noise, masonry.fsm.noise_gate): > 0, the alignment gates ask the mean error
    # and velocity over this window (with a margin of their measured spread) instead of one tick's; 0: one tick's
    gate_window_s: float = 0.0
    # The brick UAV re-estimates the brick from its camera every tick while it aligns and descends and follows it
    # (masonry.fsm.camera_align): the absolute position's wander cancels; False: the estimate hover's estimate
    align_on_camera: bool = False
    # Issue 30: while it aligns above the drop-off and descends, the brick UAV moves the drop-off with the bricks
    # of the wall its camera sees (masonry.fsm.wall_align): the absolute position's wander cancels and the brick
    # keeps its designed offsets to them; ``wall``: every brick's id and designed top-face centre (the blueprint's)
    align_on_wall: bool = False
    # Issue 30, in wind: without align_on_wall, the brick UAV aligns on the wall all the same (the side look and
    # the release gate with it) for a placement where its lean in the pickup's hovers, averaged, was over this
    # (rad): a steady wind's (masonry.fsm.wind_lean). 0: never
    wall_in_wind_rad: float = 0.0
    # Issues 29/30: > 0, a placement in a wind (its lean over wall_in_wind_rad) aligns and descends with this
    # horizontal position gain (1/s) over the configured one's, and flies it on (the next pickup's too) until a
    # placement in calm air (masonry.fsm.wind_lean); 0: the configured gains throughout
    wind_xy_kp_per_s: float = 0.0
    # Issues 29/30: > 0, a placement is in a wind only where its lean held in one direction (averaged as a direction
    # over the pickup's hovers) is over this (rad) too: a hover's swing about the vertical is not a wind (the real
    # PX4's, masonry.fsm.wind_lean). 0: the tilt's magnitude alone
    wind_held_rad: float = 0.0
    wall: tuple[tuple[int, tuple[float, ...]], ...] = ()
    # With align_on_wall: a drop-off whose supports the carried brick hides from above (a tower's) is aligned and
    # descended onto displaced, with a support in the camera's view, then a short last leg (masonry.fsm.side_look)
    side_look: bool = True
    # The other UAVs' pads (x, y; build_machine sets them from the fleet) and how far the side look's displaced
    # work keeps from each (build_machine: the blueprint's pad_site_distance_m, what validation keeps between a
    # pad and the wall): the zone the brick UAV asks for spans the drop-off and the side look's hover, and a zone
    # within that of a landed UAV's pad is never granted (masonry.fsm.side_look)
    pads_m: tuple[tuple[float, float], ...] = ()
    pad_keep_off_m: float = 0.0
    # With align_on_wall: the carried brick's offset on the magnet, seen by the camera in the frames the wall
    # alignment reads, is taken off the drop-off's target (masonry.fsm.carried_look)
    carried_look: bool = True
    # With align_on_wall: > 0, the side look's last leg and the legs from a look back up to the drop-off fly the
    # acceleration feed-forward of this velocity lag (s) instead of velocity_lag_s, not in a wind
    # (masonry.fsm.side_look); 0: off
    last_leg_lag_s: float = 0.0
    # With align_on_wall: > 0, the side look's last leg's passes tick at this period (s) where the loop calls that
    # often (masonry fly's 0.05 s; a simulated mission steps the machines at control_period_s): the pass crosses the
    # 1.5 cm disc at 0.2-0.35 m/s, 2-3.5 cm a 0.1 s tick (masonry.fsm.brick.BrickUav._control_period_s). 0: off
    last_leg_period_s: float = 0.0
    # With align_on_wall: a brick that stands on others is released only if a brick of the wall was in the
    # camera's view at most this long (s) before; else it looks again from above (masonry.fsm.release_gate). 0: off
    release_fresh_s: float = 0.45
    # With align_on_wall, inside r_pl on the side look's last leg: one more tick (this long, s) while the
    # effector's velocity brings it nearer by then and the sighting stays within release_fresh_s
    # (masonry.fsm.release_gate.ReleaseGate.closing). 0: off
    release_closest_s: float = 0.0
    # With align_on_wall: inside r_pl but farther than release_hold_m from the drop-off, the release waits a tick
    # (release_closest_s) while the sighting stays within release_fresh_s then (a lone brick, no wall seen and none
    # under it: regardless), up to release_hold_s past the descent's end (masonry.fsm.release_gate.ReleaseGate.closing).
    # 0: off
    release_hold_m: float = 0.0
    release_hold_s: float = 0.0
    # With align_on_wall, on the side look's last leg of a guarded drop-off in calm air: a tick inside r_pl but
    # farther than this (m) from the drop-off is passed over while looks back up are left (the pass is flown again
    # from the look point; masonry.fsm.release_gate.ReleaseGate.wide). 0: off
    release_leg_m: float = 0.0
    # ... for the first this many looks back up of the descent only (0: all of them, up to the last look's pass);
    # later passes are let go within r_pl (masonry.fsm.release_gate.ReleaseGate.wide)
    release_leg_looks: int = 0
    # ... and in a wind (the placement's lean over wall_in_wind_rad), this far (m) instead (0: not in a wind), for
    # the same first release_leg_looks looks (masonry.fsm.release_gate.ReleaseGate.wide). Off in the presets: on the
    # px4 model 0.012 took the bricks over 2 cm in 4 m/s 13 -> 7 over the bond and the towers (seeds 0-19), but the
    # towers' seeds 0-9 0 -> 2 (branch bond41, docs/performance/as-built.md)
    release_leg_wind_m: float = 0.0
    # With align_on_wall, on the side look's last leg of a guarded drop-off in calm air: the release is timed at the
    # effector's predicted nearest pass to the drop-off (its error carried on its velocity) within this long (s)
    # after the tick, through Gripper.release_at (masonry.fsm.release_gate.ReleaseGate.ahead). 0: off (a release at
    # the tick); the px4 preset's 0.1 (not in a wind: there it hurt the rotated bond; docs/performance/as-built.md)
    release_ahead_s: float = 0.0
    # With align_on_wall: while it descends, the drop-off follows the wall's offset's trend fitted over this last
    # stretch of its frames (s), past the frames its mean is of (masonry.fsm.wall_trend). 0: off
    wall_trend_s: float = 1.5
    # With wall_trend_s: > 0, the offset past the frames is predicted by a Kalman filter on the wander's drift
    # (masonry.fsm.wall_drift: the rate diffuses this fast, m/s per square-root second, and relaxes over
    # wall_drift_tau_s), not by the straight line; 0: the straight line
    wall_drift_mps_per_sqrt_s: float = 0.0
    wall_drift_tau_s: float = 2.0
    # With align_on_wall: the bricks in view count at their as-built poses relative to the wall (the task's
    # ``wall_as_built``, from mission control) and the drop-off keeps the brick's designed offsets to its placed
    # neighbours as built, pulled back toward the design by ``wall_pullback_m`` per course and at most
    # ``wall_follow_cap_m`` from it (masonry.fsm.wall_align); False: every brick in view counts at its design
    wall_as_built: bool = True
    wall_pullback_m: float = 0.002
    wall_follow_cap_m: float = 0.02
    settle_speed_mps: float = 0.08  # "hovering" means slower than this
    # A transit is asked for (docs/safety.md) once the UAV hovers within this of where it stopped, and slower than
    # settle_speed_mps: mission control reserves the flight's climb where the request says the UAV is
    ask_settle_tolerance_m: float = 0.03
    # The autopilot's velocity loop lags its setpoint (about a first-order lag of this time constant; the
    # simulated vehicle's ``velocity_tau_s``): a leg's reference acceleration times this is added to its velocity
    # feed-forward, so the UAV does not trail the reference and overshoot its end (0: velocity feed-forward only)
    velocity_lag_s: float = 0.3
    # On the first take-off's hover, identify the velocity response and fly the position gains derived from it
    # (masonry.fsm.first_hover, masonry.fsm.hover_gains; uav.yaml ``tuning: identify``); False: the preset's gains
    identify_first_hover: bool = False
    clearance_m: float = _T.clearance_m  # transit altitude keeps a carried brick this far above the drop-off
    # Transit layer (docs/safety.md): mission control hands out the altitude of each lateral leg; this one is for
    # a link without clearances (or mission control silent): lateral legs longer than ``layer_min_leg_m`` fly at
    # it, climbing to it first and descending from it last. None: no fixed layer.
    lateral_altitude_m: float | None = None
    layer_min_leg_m: float = 0.3
    # Peak speed of the climbs to and descents from the layer, under the vehicle's 1 m/s (the simulated
    # ``max_climb_mps``; ArduCopter climbs at 2.5 m/s by default). A site freed is granted to the UAV waiting
    # beside it once the leaving UAV's climb column is left (issue 27, benchmarks/bench_site_visits.py: 5 s in the
    # median at 8 + 4, up to a 3.3 m climb to the fifth layer): 0.5 -> 0.9 m/s took the 12 m wall at 8 + 4 from
    # 1,241 to 1,116 s (mean of seeds 1-6)
    layer_vertical_speed_mps: float = 0.9
    # A gate (hover, alignment) that sees the UAV swing fails the attempt at once instead of after
    # leg_timeout_s: an rms speed (over swing_window_s) above swing_speed_mps, swing_patience_s after the leg's
    # planned end, is a position loop too fast for the autopilot's lag (issue 19), not something waiting cures
    swing_speed_mps: float = 0.2
    swing_patience_s: float = 8.0
    swing_window_s: float = 2.0
    # Issue 29: > 0, the velocity the gates read (the swing check above, the alignment's and the hover's speed
    # limits) is made consistent with the reported position over this time constant (masonry.fsm.velocity_filter):
    # PX4's EKF2 on GNSS reports a velocity up to 0.5 m/s off what its own position does; 0: the autopilot's
    velocity_from_position_s: float = 0.0
    # the take-off's one time limit (its clock): the machine gives it up past it, and passes what is left of it to
    # the flight controller's takeoff (the MAVLink adapter ends ArduPilot's own climb, or PX4's, a little before)
    takeoff_timeout_s: float = TAKEOFF_TIMEOUT_S
    # A task whose transit waits for clearance longer than this is given up (the attempt counts; None: never):
    # it frees the UAV's hold volume, which another waiting UAV's flight may need (docs/safety.md)
    hold_patience_s: float | None = 240.0
    # The site's geofence (``Blueprint.site``; None: none): setpoints are clamped inside it; a UAV seen outside it
    # (beyond ``masonry.geofence.BREACH_MARGIN_M``) gives its task up, and lands where it is if it is not back
    # inside ``fence_return_s`` later (masonry.fsm.fence)
    fence: Site | None = None
    fence_return_s: float = 20.0
    leg_timeout_s: float = (
        30.0  # a leg (or an alignment) not over this long after its planned end fails the task
    )
    battery_low_fraction: float = 0.20  # below this a task is aborted and the UAV goes home
    battery_critical_fraction: float = 0.10  # below this it lands where it is
    # The battery budget (masonry.fsm.battery): a task is taken (else held for a swap, with a ground crew) only if
    # the flight left above battery_low_fraction covers it, this much waiting for clearance (at most
    # hold_patience_s), the way home and, beside a neighbouring pad, the wait on it (neighbour_pad_m below); waiting
    # in the air, a UAV gives its task up while the flight left above battery_critical_fraction covers its way out
    # of it (home, or putting its brick back) and battery_return_wait_s of waiting for clearance on that way
    battery_wait_budget_s: float = 60.0
    battery_return_wait_s: float = 45.0
    # The nearest other UAV's pad, centre to centre (build_machine sets it from the fleet; None: none known). Within
    # the separation (plus a margin) of it, this UAV's landing waits while that one holds the column over its pad:
    # its landing, its battery swap (battery_swap_s, the ground crew's time) and its take-off; the task budget
    # counts that wait on the way home (and no other: docs/state-machines.md, "Battery budget")
    neighbour_pad_m: float | None = None
    battery_swap_s: float = 60.0
    link_lost_timeout_s: float = 5.0  # in an emergency, give up on a silent flight controller after this
    # Brick pickup (paper, Section IV)
    confidence_threshold: float = 0.75  # C_th
    min_estimates: int = _T.min_estimates  # estimates in the window before its confidence counts
    window_size: int = 30  # N^W
    sigma_tol_m: float = 0.04  # sigma_tol of the confidence metric
    settle_time_s: float = _T.settle_time_s  # hover this long before collecting estimates
    estimate_timeout_s: float = 5.0  # without C >= C_th by then, climb one step
    climb_step_m: float = 0.3
    max_climbs: int = 3  # then the task fails
    descent_duration_s: float = _T.descent_duration_s  # t_f of the minimum-jerk descent
    grasp_press_m: float = _T.grasp_press_m  # aim the effector this far below the brick's top face
    grasp_dwell_s: float = _T.grasp_dwell_s  # hold on the brick with the magnet on before climbing
    # ... then, not attached and the body still over 1.5 cm above the descent's end (ArduCopter's vertical lag),
    # hold on up to this much longer (masonry.fsm.grasp_reach)
    grasp_patience_s: float = 2.0
    max_grasp_attempts: int = 3
    # Brick placement
    placement_radius_m: float = _T.placement_radius_m  # r_pl: release when the effector is this close to it
    # Issue 30, in wind (masonry.fsm.dropoff_reach.swing_margin_m): r_pl shrinks by release_lead_s times the
    # effector's swing (its fastest horizontal speed about the reference over the last second, within 5 cm of the
    # drop-off) over release_still_mps, to no less than release_floor_m, for release_patience_s past the descent's
    # end (then the paper's r_pl again): a gust's swing lets go within 0.8 cm, not at the 1.5 cm disc's edge; calm
    # air keeps the paper's test. release_lead_s 0: off
    release_lead_s: float = 0.2
    release_still_mps: float = 0.04
    release_floor_m: float = 0.008
    release_patience_s: float = 3.5
    release_timeout_s: float = 4.0  # after the descent's t_f; then hover above and try again
    max_place_attempts: int = 3
    release_dwell_s: float = _T.release_dwell_s
    max_release_attempts: int = 3
    # Issue 30: a brick whose as-built look (in place_ascend) puts it farther than reseat_over_m from its designed
    # offsets to the neighbours it touches, seen with it (their mean: what benchmarks/bench_as_built.py measures),
    # is re-seated: the UAV comes down onto it, grips it, climbs and places it again (masonry.fsm.reseat), at most
    # reseat_max times a task, only while the glue under it stays open and nothing stands on it. 0: off (the px4
    # preset: 0.018, where the placement is aligned on the wall, so a re-placement is aimed at the neighbours too)
    reseat_over_m: float = 0.0
    reseat_max: int = 1
    # Adhesion (paper, Section V)
    # The spray descent flown again from where the UAV is when it has not arrived by its timeout, before the attempt
    # fails, as the brick's drop-off is (issue 29: on the real PX4 the spray descent missed 1 in ~16 flights, EKF2's
    # height running off for seconds mid-descent; a failed attempt costs a mission a flight away and back)
    max_spray_descents: int = 2
    spray_speed_mps: float = _T.spray_speed_mps
    spray_descent_s: float = _T.spray_descent_s
    stable_time_s: float = _T.stable_time_s  # hover still this long over the segment start before descending
    spray_tolerance_m: float = 0.015
    # What the tool saw (issue 18, masonry.fsm.bead): the pass moves the nozzle's reference along the segment at
    # spray_speed_mps, at most spray_lead_m ahead of the nozzle (telemetry: position, lever arm, tilt); the body
    # flies the point that puts the nozzle on it at the tilt measured at that tick. The valve is open while the
    # nozzle is within spray_valve_radius_m of the segment and no higher than spray_check_height_m above it; its
    # sprayed track covers the points within spray_check_radius_m. Gaps left (a gust pushed it off): passes back
    # and forth over them until none is left or, at the latest, spray_patience_s after one pass's time: done then
    # if the track covers spray_min_coverage of the segment, else the attempt fails. The UAV reports the coverage
    # it measured.
    spray_check_radius_m: float = 0.02
    spray_check_height_m: float = 0.2
    spray_valve_radius_m: float = 0.03
    spray_lead_m: float = 0.12
    spray_min_coverage: float = 0.9
    spray_patience_s: float = 25.0
    close_dwell_s: float = _T.close_dwell_s
    # Chaining (paper, Section V: "it continues to the next assigned task"): the task is reported done once the
    # valve is closed; the UAV hovers there up to ``chain_wait_s`` for its next task, and a segment starting
    # within ``chain_distance_m`` of the nozzle (the next overlap along the same course) is sprayed without
    # climbing out and coming down again: a short leg there and a ``chain_descent_s`` descent.
    chain_wait_s: float = 0.5
    chain_distance_m: float = 0.05
    chain_descent_s: float = _T.chain_descent_s
    # Control (None: the motion layer's defaults)
    pid_gains: Any = None
    # Issues 29/30, where masonry closes the velocity loop on a MAVLink autopilot (a real PX4): what drives the
    # loop's observer: ``command`` (the acceleration sent) or ``tilt`` (the acceleration the attitude the autopilot
    # reports gives; PX4 realises a command as a tilt 0.17-0.2 s later). masonry fly sets the adapter's from this;
    # the simulated vehicles ignore it (masonry.motion.velocity_loop, docs/performance/autopilots.md)
    velocity_observer_input: str = "command"

    def __post_init__(self) -> None:
        if self.velocity_observer_input not in VELOCITY_OBSERVER_INPUTS:
            choices = " or ".join(VELOCITY_OBSERVER_INPUTS)
            raise InputError(
                f"velocity_observer_input must be {choices}, got {self.velocity_observer_input!r}"
            )

    def timing(self) -> TaskTiming:
        """The durations, speeds and tool geometry of this UAV's tasks, for the bound and the airspace."""
        return TaskTiming.from_config(self)

    @classmethod
    def from_spec(cls, spec: UavSpec, **overrides: Any) -> UavConfig:
        """The configuration of a fleet member of a blueprint (name, role, home), with overrides."""
        return cls(name=spec.name, role=spec.role, home_m=tuple(spec.home_m), **overrides)  # type: ignore[arg-type]


class BlueprintSettings(TypedDict):
    """The :class:`UavConfig` fields a UAV takes from the blueprint and its fleet (:func:`blueprint_settings`)."""

    cruise_altitude_m: float
    markers: MarkerSpec
    wall: tuple[tuple[int, tuple[float, ...]], ...]
    fence: Site | None
    pads_m: tuple[tuple[float, float], ...]
    pad_keep_off_m: float
    neighbour_pad_m: float | None
    zone_slack_m: float


def blueprint_settings(blueprint: Blueprint, spec: UavSpec) -> BlueprintSettings:
    """The :class:`~masonry.fsm.UavConfig` fields UAV ``spec`` takes from the blueprint and its fleet: the cruise
    altitude, the markers, the wall's bricks, the site fence, the other UAVs' pads (``pads_m``, not its own) with
    the side look's keep-off from them (``pad_keep_off_m``: the blueprint's ``pad_site_distance_m``) and the
    nearest one's distance (``neighbour_pad_m``, for the battery budget), and the slack of mission control's work
    zones and hold hovers (``zone_slack_m``: whether a leg into them is flown within ``zone_leg_accel_mps2``).

    The one derivation of them: the simulator's machines (:func:`masonry.mission.uav_stack.build_machine`) and
    ``masonry fly``'s (:func:`masonry.mission.remote.remote_config` in mission mode, and single-task mode) fly the
    same (issue 27).
    """
    others = [u for u in blueprint.fleet if u.name != spec.name]
    return {
        "cruise_altitude_m": blueprint.cruise_altitude_m,
        "markers": blueprint.markers,
        "wall": wall_tops_m(blueprint.bricks),
        "fence": blueprint.site,
        "pads_m": tuple((u.home_m[0], u.home_m[1]) for u in others),
        "pad_keep_off_m": pad_site_distance_m(blueprint.clearance_m),
        "neighbour_pad_m": min((math.dist(spec.home_m[:2], u.home_m[:2]) for u in others), default=None),
        "zone_slack_m": zone_slack_m(blueprint.clearance_m),
    }
