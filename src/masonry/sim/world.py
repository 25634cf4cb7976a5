"""The simulated world: bricks, adhesive and UAVs on one simulated clock, behind the ``masonry.ports`` seams.

``World(blueprint, seed=...)`` lays the bricks out (pre-placed ones at their blueprint pose, the others at their
approximate pickup plus a random offset and yaw), ``add_uav(spec)`` adds a UAV whose ``.fc``, ``.gripper``,
``.sprayer`` and ``.camera`` are the ports a state machine drives, and ``step(dt_s)`` advances the clock and the
physics. Randomness: one seed per world; the bricks draw from their own stream and every UAV from a stream
derived from the seed and its name, so adding a UAV does not change the others' noise.

Cost per step is independent of the number of bricks: tool contact, attachment, deposits and camera views look
bricks up in a spatial hash.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from masonry.airframe import DEFAULT_AIRFRAME, Airframe
from masonry.blueprint import Blueprint, UavSpec
from masonry.errors import InputError, InvalidArgument
from masonry.geometry import body_to_world_floats
from masonry.planner.tasks import AdhesionTask
from masonry.ports import CameraFrame, Telemetry, UavPorts, Vec3
from masonry.sim.adhesive import AdhesiveDeposit
from masonry.sim.bricks import GROUND_Z_M, BrickField, SimBrick
from masonry.sim.camera import CameraConfig, LayoutCache, R_world_body, observe_markers
from masonry.sim.clock import SimClock
from masonry.sim.faults import Faults
from masonry.sim.follow_contact import carried_support_m
from masonry.sim.glue import GlueWatch
from masonry.sim.ports import SimCamera, SimFlightController, SimGripper, SimSprayer
from masonry.sim.release import release_brick, release_start, release_within
from masonry.sim.render_camera import over_sampled_pickup, render_sample, rendered_frame
from masonry.sim.spares import lay_out_spares
from masonry.sim.vehicle import SimVehicle, VehicleConfig
from masonry.sim.vehicle_model import VehicleModel, sim_vehicle
from masonry.sim.wind import WindField

__all__ = ["CameraMode", "SimUav", "World", "WorldConfig"]

CameraMode = Literal["geometric", "render", "mixed"]

#: A tool (or a carried brick) within this height above the highest brick top is checked for contact.
_CONTACT_TOL_M = 0.06


@dataclass(frozen=True)
class WorldConfig:
    """Physical parameters of the world around the UAVs (metres, radians, seconds)."""

    pickup_offset_m: float = 0.05  # a brick lies uniformly within this radius of its approximate pickup
    pickup_yaw_spread_rad: float = math.pi  # ... with a yaw uniform in +- this (pi: any yaw)
    contact_band_m: float = 0.015  # the effector touches a brick top when within this height of it
    guide_residual: float = 0.2  # the conical guide centres the brick: this fraction of the offset remains
    support_margin_m: float = 0.025  # a falling brick ignores overlaps with neighbours thinner than this
    release_scatter_m: float = 0.002  # a released brick settles this far (std, per axis) from its release
    release_scatter_per_m: float = 0.05  # ... plus this much per metre of fall
    release_yaw_scatter_rad: float = 0.005
    spray_max_height_m: float = 0.25  # adhesive reaches the surface from at most this nozzle height
    bead_radius_m: float = 0.03  # coverage: a point is covered within this distance of a bead
    path_sample_s: float = 0.5  # flown paths are recorded at this period
    cell_m: float = 0.5  # spatial hash cell


@dataclass(eq=False, repr=False)
class SimUav:
    """One UAV in a world: its autopilot model, its tool state and its ports.

    ``ports`` (:class:`masonry.ports.UavPorts`) is what a state machine flies with: ``fc`` (FlightController),
    ``gripper`` (Gripper), ``sprayer`` (Sprayer), ``camera`` (Camera), the world's clock and step. Every UAV has
    all four; the world moves bricks only for ``role == "brick"`` and deposits adhesive only for
    ``role == "adhesion"``. What only a simulation has (the ``vehicle`` whose battery the ground crew swaps,
    ``failed``, the true position) stays here, beside the ports.
    """

    name: str
    spec: UavSpec
    world: World
    vehicle: SimVehicle
    rng: np.random.Generator  # gripper and camera faults, camera noise
    look_rng: np.random.Generator  # the as-built look's frames (its own stream: shifts no later draw)
    magnet_on: bool = False
    joint_locked: bool = True
    valve_open: bool = False
    carried_brick: int | None = None
    release_due_s: float | None = None  # a timed release (Gripper.release_at) not yet due
    failed: bool = False
    link_ok: bool = True
    _carry_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # brick top centre (body x, y) and yaw offset
    _attempt: int | None = None  # brick of the current contact episode
    _attempt_ok: bool = False
    _last_deposit: Vec3 | None = None
    _stale: Telemetry | None = None
    _path: list[tuple[float, float, float, float]] = field(default_factory=list)
    _next_sample_s: float = -math.inf

    def __repr__(self) -> str:
        return (
            f"SimUav(name={self.name!r}, role={self.role!r}, position_m={self.position_m!r}, "
            f"failed={self.failed}, link_ok={self.link_ok}, carried_brick={self.carried_brick})"
        )

    def __post_init__(self) -> None:
        # per-UAV constants of the world's physics step
        self._brick_role = self.spec.role == "brick"
        airframe = self.world.airframe
        self._tool_dz_m = (airframe.effector_offset_m if self._brick_role else airframe.nozzle_offset_m)[2]
        self.fc = SimFlightController(self)
        self.gripper = SimGripper(self)
        self.sprayer = SimSprayer(self)
        self.camera = SimCamera(self)
        self.ports = UavPorts(
            self.fc,
            self.gripper,
            self.sprayer,
            self.camera,
            self.world.clock,
            self.world.step,
            self.world,
            {"flight controller": "simulated", "actuators": "simulated", "camera": "simulated"},
        )

    @property
    def role(self) -> str:
        return self.spec.role

    @property
    def position_m(self) -> Vec3:
        """True position (no measurement noise)."""
        return self.vehicle.position_m

    def tool_point_m(self, offset_m: Vec3) -> Vec3:
        """A point fixed on the body (FLU offset) in the world; tilt is neglected (a few degrees at most)."""
        x, y, z = self.vehicle.position_m
        yaw = self.vehicle.yaw_rad
        c, s = math.cos(yaw), math.sin(yaw)
        return (x + c * offset_m[0] - s * offset_m[1], y + s * offset_m[0] + c * offset_m[1], z + offset_m[2])

    def effector_m(self) -> Vec3:
        """The electromagnet's tip in the world."""
        return self.tool_point_m(self.world.airframe.effector_offset_m)

    def nozzle_m(self) -> Vec3:
        """The spray nozzle's outlet in the world: fixed to the body, it leans with it (10-20 degrees into a
        strong wind: centimetres at the outlet)."""
        x, y, z = self.vehicle.position_m
        rx, ry, rz = body_to_world_floats(self.vehicle.attitude_rad, self.world.airframe.nozzle_offset_m)
        return (x + rx, y + ry, z + rz)

    def telemetry(self) -> Telemetry:
        """What the flight controller port reports (stale, with ``link_ok`` False, after link or UAV loss)."""
        if self.link_ok:
            return self.vehicle.telemetry()
        if self._stale is None:
            self._stale = self.vehicle.telemetry()
        return replace(self._stale, link_ok=False)

    def set_magnet(self, on: bool) -> None:
        self.magnet_on = on
        self.release_due_s = None
        if not on:
            self._attempt = None
            if self.carried_brick is not None:
                self.world._release(self)

    def set_valve(self, open_: bool) -> None:
        self.valve_open = open_ and not self.failed
        if not self.valve_open:
            self._last_deposit = None

    def path_m(self) -> np.ndarray:
        """The recorded path: rows (t_s, x, y, z), one per ``WorldConfig.path_sample_s``."""
        return np.asarray(self._path, dtype=float).reshape(-1, 4)


class World:
    """Bricks, adhesive and UAVs on a simulated clock.

    Args:
        blueprint: the wall; its bricks are laid out in the world (its fleet is not added: see ``add_fleet``).
        seed: one seed for everything random in the world (>= 0).
        camera: ``"geometric"`` (marker poses from the camera model plus noise), ``"render"`` (synthetic images)
            or ``"mixed"`` (images over a sample of the pickups: :mod:`masonry.sim.render_camera`).
        faults: injected faults.
        airframe: tool and camera placement on the UAVs.
        vehicle: multirotor model parameters.
        vehicle_model: builds each UAV's vehicle (default: a ``SimVehicle``; :mod:`masonry.sim.vehicle_model`).
        camera_config: intrinsics, detection limits and noise.
        config: pickup scatter, contact and adhesive parameters.
        start_s: the clock's initial time.
    """

    def __init__(
        self,
        blueprint: Blueprint,
        *,
        seed: int = 0,
        camera: CameraMode = "geometric",
        faults: Faults | None = None,
        airframe: Airframe = DEFAULT_AIRFRAME,
        vehicle: VehicleConfig | None = None,
        camera_config: CameraConfig | None = None,
        config: WorldConfig | None = None,
        start_s: float = 0.0,
        vehicle_model: VehicleModel = sim_vehicle,
    ) -> None:
        if camera not in ("geometric", "render", "mixed"):
            raise InputError(f"camera mode must be 'geometric', 'render' or 'mixed', got {camera!r}")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise InputError(f"seed must be an integer >= 0, got {seed!r}")
        self.blueprint = blueprint
        self.seed = int(seed)
        self.camera_mode: CameraMode = camera
        self.faults = faults if faults is not None else Faults()
        self.airframe = airframe
        self.vehicle_config = vehicle if vehicle is not None else VehicleConfig()
        self.vehicle_model = vehicle_model
        self.camera_config = camera_config if camera_config is not None else CameraConfig()
        self.config = config if config is not None else WorldConfig()
        self.clock = SimClock(start_s)
        self.uavs: dict[str, SimUav] = {}
        self.adhesive = AdhesiveDeposit(bead_radius_m=self.config.bead_radius_m)
        self.glue = GlueWatch(blueprint, self.adhesive)  # glue ages (inert without an ``adhesive``)
        self.field = BrickField(self.config.cell_m)
        self._T_body_cam = airframe.T_body_cam()
        self._min_sep: float | None = None
        #: the UAVs armed in the air after the last step, and where they are (the envelope watch reads it)
        self.airborne: list[tuple[str, Vec3]] = []
        self._layouts = LayoutCache()  # the camera's marker arrays, kept between frames
        self.drawn_pickups = render_sample(blueprint) if camera == "mixed" else frozenset()  # mixed mode
        self.picks: list[tuple[float, str, int]] = []  # (time, UAV, brick) of every grasp
        self.releases: list[tuple[float, str, int]] = []  # (time, UAV, brick) of every release
        self.rendered_frames = 0
        self._lay_out_bricks()

    def __repr__(self) -> str:
        return (
            f"World(t={self.clock.now_s():.2f} s, bricks={len(self.field)}, uavs={list(self.uavs)}, "
            f"seed={self.seed}, camera={self.camera_mode!r})"
        )

    def _lay_out_bricks(self) -> None:
        cfg = self.config
        rng = np.random.default_rng([self.seed, 0])
        bricks = self.blueprint.bricks
        radius = cfg.pickup_offset_m * np.sqrt(rng.random(len(bricks)))
        angle = rng.uniform(-math.pi, math.pi, len(bricks))
        yaw = rng.uniform(-cfg.pickup_yaw_spread_rad, cfg.pickup_yaw_spread_rad, len(bricks))
        for b in sorted(bricks, key=lambda b: b.position_m[2]):
            if b.placed:
                self.field.add(SimBrick(b.id, b, b.position_m, b.yaw_rad, "placed"))
        for i, b in enumerate(bricks):
            if b.placed or b.pickup_m is None:
                continue
            x = b.pickup_m[0] + float(radius[i] * math.cos(angle[i]))
            y = b.pickup_m[1] + float(radius[i] * math.sin(angle[i]))
            brick = SimBrick(b.id, b, (x, y, 0.0), float(yaw[i]), "carried")
            support = self.field.support_under(brick.rect(cfg.support_margin_m))
            brick.position_m = (x, y, support + b.size_m[2] / 2.0)
            brick.state = "pickup"
            self.field.add(brick)
        lay_out_spares(self.field, self.blueprint, self.seed, cfg.pickup_offset_m, cfg.pickup_yaw_spread_rad)

    def add_uav(self, spec: UavSpec, *, yaw_rad: float = 0.0) -> SimUav:
        """Add a UAV landed and disarmed at ``spec.home_m``; its random stream derives from the seed and its name."""
        if spec.name in self.uavs:
            raise InputError(f"a UAV named {spec.name!r} is already in the world")
        # the third stream (the wind's) and the fourth (the as-built look's) leave the ones before them as they were
        vehicle_ss, uav_ss, wind_ss, look_ss = np.random.SeedSequence(
            [self.seed, 1, zlib.crc32(spec.name.encode())]
        ).spawn(4)
        site_wind = self.faults.site_wind()
        wind = (
            None
            if site_wind.calm
            else WindField(site_wind, np.random.default_rng(wind_ss), self.clock.now_s())
        )
        vehicle = self.vehicle_model(
            spec,
            self.vehicle_config,
            position_m=spec.home_m,
            yaw_rad=yaw_rad,
            rng=np.random.default_rng(vehicle_ss),
            wind=wind,
            battery_drain_per_s=self.faults.battery_drain_per_s,
            start_s=self.clock.now_s(),
        )
        rngs = np.random.default_rng(uav_ss), np.random.default_rng(look_ss)
        self.uavs[spec.name] = uav = SimUav(spec.name, spec, self, vehicle, *rngs)
        now = self.clock.now_s()
        timed = (self.faults.uav_loss_at_s.get(spec.name), self.faults.link_loss_at_s.get(spec.name))
        if any(at is not None and at < now for at in timed):
            # failed (or cut off) before this world began (one rebuilt after a stop, at the journal's time): it
            # stays down, silent from the start, not alive again until its first step
            self._timed_faults(uav, now)
        return uav

    def add_fleet(self, fleet: Iterable[UavSpec] | None = None) -> list[SimUav]:
        """Add every UAV of ``fleet`` (default: the blueprint's), after checking the faults name only these."""
        specs = list(self.blueprint.fleet if fleet is None else fleet)
        self.faults.check_uavs([s.name for s in specs] + list(self.uavs))
        return [self.add_uav(s) for s in specs]

    def swap_battery(self, name: str) -> None:
        """Ground crew puts a full pack in the UAV (it must be landed and disarmed: else CommandRejected)."""
        self.uavs[name].vehicle.swap_battery()

    def step(self, dt_s: float) -> None:
        """Advance the clock and the physics of every UAV and brick by ``dt_s`` seconds."""
        if not (dt_s > 0.0 and math.isfinite(dt_s)):
            raise InvalidArgument(f"World.step needs a finite dt_s > 0, got {dt_s!r}")
        now = self.clock.now_s() + dt_s
        faults = self.faults
        timed_faults = bool(faults.uav_loss_at_s) or bool(faults.link_loss_at_s)
        airborne: list[tuple[str, Vec3]] = []
        self.airborne = airborne  # (a new list each step: a caller may keep the last one)
        sample_s = self.config.path_sample_s
        field = self.field
        for uav in self.uavs.values():
            vehicle = uav.vehicle
            if timed_faults and not uav.failed:
                self._timed_faults(uav, now)
            if vehicle.armed or not vehicle.on_ground:
                # release_start's own early exit (no timed release due), checked here first
                start = None if uav.release_due_s is None else release_start(uav, field, now)
                vehicle.step(dt_s)
                if vehicle.failed and not uav.failed:
                    self._fail(uav)  # the vehicle stopped on its own (battery empty in the air)
                # _contact's own early exit, checked here first (most steps: a tool high above every brick)
                if (
                    uav.carried_brick is not None
                    or vehicle._z + uav._tool_dz_m <= field.max_top_z_m + _CONTACT_TOL_M
                ):
                    self._contact(uav)
                if start is not None:
                    release_within(self, uav, start, now - dt_s, now)
                if uav._brick_role:
                    # _grip's own guard, checked here first (the magnet stays on while a brick is carried)
                    if uav.magnet_on and uav.carried_brick is None and not (uav.joint_locked or uav.failed):
                        self._grip(uav)
                elif uav.valve_open:
                    self._spray(uav)
                if vehicle.armed and not vehicle.on_ground:
                    airborne.append((uav.name, (vehicle._x, vehicle._y, vehicle._z)))
            else:
                vehicle.idle(dt_s)  # parked (or fallen): only its clock moves
            if now >= uav._next_sample_s:
                uav._path.append((now, vehicle._x, vehicle._y, vehicle._z))
                uav._next_sample_s = now + sample_s
        if len(airborne) > 1:
            self._record_separation(airborne)
        self.clock.advance(dt_s)

    def _record_separation(self, airborne: list[tuple[str, Vec3]]) -> None:
        """Lower the smallest separation seen so far to the closest pair of ``airborne`` positions (two or more)."""
        best2 = math.inf  # smallest squared distance this step (one square root, not one per pair)
        # A pair whose x distance alone reaches the smallest separation so far cannot lower it: skip it after
        # one product. The margin keeps the square root's rounding out of it: if every pair is skipped, the
        # step's true minimum is above the record and would not have replaced it either.
        record = self._min_sep
        skip2 = math.inf if record is None else record * record * (1.0 + 1e-9)
        for i in range(len(airborne) - 1):
            ax, ay, az = airborne[i][1]
            for _b, (bx, by, bz) in airborne[i + 1 :]:
                dx = ax - bx
                d2 = dx * dx
                if d2 >= skip2:
                    continue
                d2 = d2 + (ay - by) * (ay - by) + (az - bz) * (az - bz)  # the same sum, left to right
                if d2 < best2:  # noqa: PLR1730 (no min() call: hot loop)
                    best2 = d2
        d = math.sqrt(best2)
        if self._min_sep is None or d < self._min_sep:
            self._min_sep = d

    def _timed_faults(self, uav: SimUav, now: float) -> None:
        faults = self.faults
        at = faults.uav_loss_at_s.get(uav.name)
        if at is not None and now >= at:
            self._fail(uav)
        elif uav.link_ok:
            at = faults.link_loss_at_s.get(uav.name)
            if at is not None and now >= at:
                uav._stale = uav.vehicle.telemetry()
                uav.link_ok = False
                uav.vehicle.lose_link()

    def run(self, duration_s: float, dt_s: float = 0.05) -> None:
        """Step for ``duration_s`` seconds (no controllers: for tests and notebooks)."""
        for _ in range(max(0, round(duration_s / dt_s))):
            self.step(dt_s)

    def _fail(self, uav: SimUav) -> None:
        if uav._stale is None or uav.link_ok:
            uav._stale = uav.vehicle.telemetry()
        uav.failed = True
        uav.link_ok = False
        uav.vehicle.fail()
        uav.set_valve(False)
        uav.magnet_on = False
        if uav.carried_brick is not None:
            self._release(uav)

    def _contact(self, uav: SimUav) -> None:
        """Keep the tool from passing through brick tops, and a carried brick through bricks or the ground."""
        vehicle = uav.vehicle
        tol = _CONTACT_TOL_M
        clear_z = self.field.max_top_z_m + tol  # above this nothing can be touched
        if uav.carried_brick is not None:
            brick = self.field.bricks[uav.carried_brick]
            self._carry_pose(uav, brick)
            if brick.bottom_z_m > clear_z:
                return
            support = carried_support_m(self.field, vehicle, brick, self.config.support_margin_m, tol)
            if brick.bottom_z_m < support:
                vehicle.hold_above(vehicle.position_m[2] + support - brick.bottom_z_m)
                self._carry_pose(uav, brick)
            return
        offset = self.airframe.effector_offset_m if uav.role == "brick" else self.airframe.nozzle_offset_m
        if vehicle._z + offset[2] > clear_z:
            return
        tool = uav.tool_point_m(offset)
        support = self.field.support_at(tool[0], tool[1], below_z_m=tool[2], tol_m=tol)
        # Bricks only: on the ground the landing gear, not the rod, takes the vehicle's weight.
        if support > GROUND_Z_M and tool[2] < support:
            vehicle.hold_above(vehicle.position_m[2] + support - tool[2])

    def _carry_pose(self, uav: SimUav, brick: SimBrick) -> None:
        vehicle = uav.vehicle
        yaw = vehicle._yaw
        c, s = math.cos(yaw), math.sin(yaw)
        ox, oy, oz = self.airframe.effector_offset_m  # uav.effector_m(), inline (same cos and sin)
        ex, ey, ez = vehicle._x + c * ox - s * oy, vehicle._y + s * ox + c * oy, vehicle._z + oz
        bx, by, dyaw = uav._carry_offset
        brick.position_m = (ex + c * bx - s * by, ey + s * bx + c * by, ez - brick.size_m[2] / 2.0)
        brick.yaw_rad = math.remainder(yaw + dyaw, 2.0 * math.pi)

    def _grip(self, uav: SimUav) -> None:
        if not uav.magnet_on or uav.joint_locked or uav.carried_brick is not None or uav.failed:
            return
        ex, ey, ez = uav.effector_m()
        tol = self.airframe.grasp_tolerance_m
        band = self.config.contact_band_m
        best: SimBrick | None = None
        best_d2 = tol * tol
        for b in self.field.near(ex, ey, tol):
            tx, ty, tz = b.top_center_m
            d2 = (ex - tx) ** 2 + (ey - ty) ** 2
            if d2 <= best_d2 and abs(ez - tz) <= band:
                best, best_d2 = b, d2
        if best is None:
            uav._attempt = None
            return
        if uav._attempt != best.id:
            uav._attempt = best.id
            uav._attempt_ok = bool(uav.rng.random() >= self.faults.grasp_failure)
        if not uav._attempt_ok:
            return
        yaw = uav.vehicle.yaw_rad
        c, s = math.cos(yaw), math.sin(yaw)
        tx, ty, _ = best.top_center_m
        dx, dy = (tx - ex) * self.config.guide_residual, (ty - ey) * self.config.guide_residual
        uav._carry_offset = (c * dx + s * dy, -s * dx + c * dy, best.yaw_rad - yaw)
        self.field.pick(best.id, uav.name)
        self.picks.append((self.clock.now_s(), uav.name, best.id))
        uav.carried_brick = best.id
        uav._attempt = None
        self._carry_pose(uav, best)

    def _release(self, uav: SimUav) -> None:
        release_brick(self, uav)  # (masonry.sim.release)

    def _spray(self, uav: SimUav) -> None:
        nx, ny, nz = uav.nozzle_m()
        surface = self.field.support_at(nx, ny, below_z_m=nz)
        if not (-0.01 <= nz - surface <= self.config.spray_max_height_m):
            uav._last_deposit = None
            return
        point = (nx, ny, surface)
        prev = uav._last_deposit
        if prev is not None and abs(prev[2] - surface) > 1e-6:
            prev = None  # moved onto another surface: start a new bead
        self.adhesive.add(prev if prev is not None else point, point, self.clock.now_s())
        uav._last_deposit = point
        self.glue.sprayed_at(self.field, point, self.clock.now_s())

    def camera_pose(self, uav: SimUav) -> np.ndarray:
        """4x4 true pose of the UAV's camera in the world (body attitude included)."""
        vehicle = uav.vehicle
        T_wb = np.eye(4)
        T_wb[:3, :3] = R_world_body(*vehicle.attitude_rad)
        T_wb[:3, 3] = vehicle.position_m
        return T_wb @ self._T_body_cam

    def _visible_candidates(self, T_wc: np.ndarray) -> list[SimBrick]:
        cfg = self.camera_config
        cx, cy, cz = T_wc[:3, 3]
        reach = min(cfg.max_range_m(self.blueprint.markers.size_m), max(cz, 0.0) + 0.1)
        radius = reach * cfg.half_diagonal_tan() + 0.3
        found = list(self.field.near(float(cx), float(cy), radius))
        for other in self.uavs.values():
            if other.carried_brick is not None:
                found.append(self.field.bricks[other.carried_brick])
        return found

    def _renders_at(self, T_wc: np.ndarray) -> bool:
        """``mixed`` mode: whether this camera is over a sampled brick still waiting at its pickup."""
        return over_sampled_pickup(self.field, self.drawn_pickups, float(T_wc[0, 3]), float(T_wc[1, 3]))

    def _camera_frame(self, uav: SimUav, rng: np.random.Generator | None = None) -> CameraFrame | None:
        if uav.failed:
            return None
        now = self.clock.now_s()
        T_wc = self.camera_pose(uav)
        bricks = self._visible_candidates(T_wc)
        rng = uav.rng if rng is None else rng
        faults = self.faults
        dropped = faults.dropout > 0.0 and rng.random() < faults.dropout
        hidden: set[int] = set()
        if faults.occlusion > 0.0 and rng.random() < faults.occlusion:
            hidden = {b.blueprint.marker_ids()[int(rng.integers(2))] for b in bricks}
        mode = self.camera_mode
        if mode == "render" or (mode == "mixed" and self._renders_at(T_wc)):
            if dropped:
                hidden = {m for b in bricks for m in b.blueprint.marker_ids()}
            markers, config = self.blueprint.markers, self.camera_config
            self.rendered_frames += 1
            return rendered_frame(now, T_wc, bricks, markers, config, rng, hidden)
        if dropped:
            return CameraFrame(time_s=now, tags=())
        occluder = self.field.bricks[uav.carried_brick] if uav.carried_brick is not None else None
        tags = observe_markers(
            T_wc[:3, :3],
            T_wc[:3, 3],
            bricks,
            self.blueprint.markers,
            self.camera_config,
            rng,
            hidden=hidden,
            occluder=occluder,
            covered=self.field.covered_kept,
            layout=self._layouts.layout(bricks, self.blueprint.markers, self.field.version),
            kept=self._layouts,
        )
        return CameraFrame(time_s=now, tags=tags)

    @property
    def bricks(self) -> Mapping[int, SimBrick]:
        """Every brick in the world by id (true state)."""
        return self.field.bricks

    def placement_error_m(self, brick_id: int) -> float | None:
        """Distance (3-D) from a released brick's resting centre to its blueprint centre.

        0.0 for a pre-placed brick; None while the brick has not been released by a UAV (still at its pickup
        or carried) or if the world has no such brick. (A spare's: ``MeasuredJournal.error_m``.)"""
        brick = self.field.bricks.get(brick_id)
        if brick is None or brick.state == "carried":
            return None
        if brick.blueprint.placed and not brick.released:
            return 0.0
        if not brick.released:
            return None
        return brick.placement_error_m()

    def placement_yaw_error_rad(self, brick_id: int) -> float | None:
        """Absolute yaw difference of a released brick from its blueprint yaw (None as ``placement_error_m``)."""
        if self.placement_error_m(brick_id) is None:
            return None
        brick = self.field.bricks[brick_id]
        return abs(math.remainder(brick.yaw_rad - brick.blueprint.yaw_rad, 2.0 * math.pi))

    def placement_errors(self) -> dict[int, float]:
        """Placement error of every brick released so far, by brick id."""
        return {
            k: b.placement_error_m()
            for k, b in self.field.bricks.items()
            if b.released and b.state == "placed"
        }

    def coverage(self, task: AdhesionTask) -> float:
        """Fraction of the task's segment within ``WorldConfig.bead_radius_m`` of deposited adhesive."""
        return self.adhesive.coverage(task.start_m, task.end_m)

    def distance_flown_m(self, name: str) -> float:
        """Path length flown by the UAV so far (true positions)."""
        return self.uavs[name].vehicle.distance_m

    @property
    def min_separation_m(self) -> float | None:
        """Smallest distance seen between two airborne UAVs so far (None until two have flown at once)."""
        return self._min_sep
