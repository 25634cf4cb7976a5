"""The parameters of the simulated multirotor and its autopilot (:class:`masonry.sim.vehicle.SimVehicle`).

The module docstring of :mod:`masonry.sim.vehicle` says what each one does in the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from masonry.errors import InvalidArgument
from masonry.sim.shaping import ARDUCOPTER, PX4, PX4_BELOW_OWN_LOOP, ShapingConfig

__all__ = ["VEHICLE_PRESETS", "VehicleConfig", "sitl_vehicle_preset", "vehicle_preset"]


@dataclass(frozen=True)
class VehicleConfig:
    """Parameters of the simulated multirotor and its autopilot (SI units in the names)."""

    velocity_tau_s: float = 0.3
    max_speed_xy_mps: float = 2.0
    max_climb_mps: float = 1.0
    max_descent_mps: float = 1.0
    max_accel_xy_mps2: float = 2.5
    max_accel_z_mps2: float = 2.0
    yaw_tau_s: float = 0.15
    max_yaw_rate_radps: float = 1.5
    takeoff_speed_mps: float = 0.6
    land_speed_mps: float = 0.4
    setpoint_timeout_s: float = 0.5
    hold_gain_per_s: float = 1.0  # position hold after the setpoint timeout: v = gain * error
    hold_max_speed_mps: float = 0.5
    link_failsafe_s: float = 5.0  # ArduPilot FS_GCS_TIMEOUT: hover this long after the link goes, then land
    land_detect_s: float = 1.0
    battery_drain_per_s: float = 1.0 / 1200.0  # a full pack lasts 20 minutes airborne
    battery_arm_min_fraction: float = 0.15
    battery_land_fraction: float = 0.05
    # The airframe in wind (masonry.sim.wind; a 4.5 kg hexacopter, docs/simulator.md "Wind"): rotor drag linear
    # in airspeed (``drag_per_s``, per unit mass) plus the body's quadratic drag (0.5 rho Cd A / m: Cd A about
    # 0.12 m^2), a tilt limit (ArduCopter ANGLE_MAX 30 deg) and thrust-to-weight (a tilt beyond acos(1 / T/W)
    # cannot hold altitude); the autopilot's integral action takes the wind's push out over ``wind_reject_tau_s``
    # (ArduCopter PSC_VELXY_P 2, PSC_VELXY_I 1: the PI's zero near 1-2 s) and its wind estimate (the WIND
    # message) follows the wind over ``wind_estimate_tau_s``.
    drag_per_s: float = 0.5
    drag_quad_per_m: float = 0.016
    max_tilt_rad: float = math.radians(30.0)
    thrust_to_weight: float = 2.0
    wind_reject_tau_s: float = 1.0
    # vertically the push is taken out faster: ArduCopter's altitude controller closes an acceleration loop on the
    # IMU (PSC_ACCZ_P 0.5, PSC_ACCZ_I 1.0 at 400 Hz), the horizontal one only through the attitude
    wind_reject_z_tau_s: float = 0.3
    wind_estimate_tau_s: float = 5.0
    mocap_noise_m: float = 0.0015
    velocity_noise_mps: float = 0.005
    yaw_noise_rad: float = 0.002
    #: an autopilot's setpoint shaping, delay and GPS-like noise (masonry.sim.shaping); None: none (``ideal``)
    shaping: ShapingConfig | None = None
    #: a take-off's thrust ramp (PX4's smooth take-off, ``MPC_TKO_RAMP_T``): for this long after leaving the
    #: ground the climb speed it can reach grows from a tenth of ``max_climb_mps`` to all of it (0: none)
    takeoff_ramp_s: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "velocity_tau_s",
            "max_speed_xy_mps",
            "max_climb_mps",
            "max_descent_mps",
            "max_accel_xy_mps2",
            "max_accel_z_mps2",
            "yaw_tau_s",
            "max_yaw_rate_radps",
            "takeoff_speed_mps",
            "land_speed_mps",
            "setpoint_timeout_s",
            "max_tilt_rad",
            "wind_reject_tau_s",
            "wind_reject_z_tau_s",
            "wind_estimate_tau_s",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidArgument(f"VehicleConfig.{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.takeoff_ramp_s) and self.takeoff_ramp_s >= 0):
            raise InvalidArgument(
                f"VehicleConfig.takeoff_ramp_s must be finite and >= 0, got {self.takeoff_ramp_s!r}"
            )
        if not (math.isfinite(self.thrust_to_weight) and self.thrust_to_weight > 1.0):
            raise InvalidArgument(
                f"VehicleConfig.thrust_to_weight must be > 1, got {self.thrust_to_weight!r}"
            )
        if not (math.isfinite(self.drag_quad_per_m) and self.drag_quad_per_m >= 0.0):
            raise InvalidArgument(f"VehicleConfig.drag_quad_per_m must be >= 0, got {self.drag_quad_per_m!r}")

    @property
    def tilt_limit_rad(self) -> float:
        """The steepest tilt that still holds altitude: ANGLE_MAX or the thrust's limit, whichever is lower."""
        return min(self.max_tilt_rad, math.acos(1.0 / self.thrust_to_weight))


#: The simulated autopilot of ``masonry sim``, ``simulate()`` and a simulated ``masonry fly`` unless told otherwise
#: (issue 19): the realistic one, so that missions, tests and benchmarks meet what a real UAV does. ``VehicleConfig()``
#: itself stays the ``ideal`` model (the state machines' unit tests fly it).
DEFAULT_VEHICLE = "arducopter"

#: ``--vehicle`` presets. ``ideal``: the first-order 0.3 s lag with motion-capture noise the project was tuned on.
#: ``arducopter``: ArduCopter's GUIDED shaping and delay (masonry.sim.shaping.ARDUCOPTER) in front of a faster
#: airframe lag, with the SITL's measured hover noise (docs/performance/autopilots.md, "The fit, again").
#: ``px4``: PX4 v1.16 on GNSS as masonry flies it (issue 20; refitted to the real PX4 v1.16 SITL, issue 29):
#: velocity setpoints unshaped behind 0.25 s of dead time and a 0.15 s lag, an airframe whose velocity wanders
#: about the setpoint (4-5 cm/s rms: masonry's own velocity loop closes on a velocity observed from EKF2's
#: position), the smooth take-off's thrust ramp, and the wandering GNSS-grade position (about +-15 cm) its EKF2
#: reports; its telemetry's velocity is smooth (the observed one), its position without white noise to speak of.
VEHICLE_PRESETS: dict[str, VehicleConfig] = {
    "ideal": VehicleConfig(),
    "arducopter": VehicleConfig(
        velocity_tau_s=0.05,
        shaping=ARDUCOPTER,
        mocap_noise_m=0.002,
        velocity_noise_mps=0.015,
    ),
    "px4": VehicleConfig(
        velocity_tau_s=0.15,
        shaping=PX4,
        mocap_noise_m=0.001,
        velocity_noise_mps=0.01,
        takeoff_ramp_s=3.0,
    ),
}


#: The vehicles of ``masonry sitl --vehicle NAME`` where they differ from :data:`VEHICLE_PRESETS`: ``px4`` below
#: masonry's own velocity loop (the adapter flies that loop on the SITL's acceleration setpoints, and the ``px4``
#: preset stands for it too): the model as issue 20 fitted it, a 0.1 s delay and a 0.2 s lag.
SITL_VEHICLES: dict[str, VehicleConfig] = {
    "px4": VehicleConfig(
        velocity_tau_s=0.2,
        shaping=PX4_BELOW_OWN_LOOP,
        mocap_noise_m=0.004,
        velocity_noise_mps=0.05,
        takeoff_ramp_s=3.0,
    ),
}


def sitl_vehicle_preset(name: str | None) -> VehicleConfig:
    """The vehicle of ``masonry sitl --vehicle name``: :data:`SITL_VEHICLES`' or :func:`vehicle_preset`'s."""
    return SITL_VEHICLES.get(vehicle_name(name)) or vehicle_preset(name)


def vehicle_name(name: str | None) -> str:
    """``name``, or :data:`DEFAULT_VEHICLE` for None."""
    return DEFAULT_VEHICLE if name is None else name


def vehicle_preset(name: str | None) -> VehicleConfig:
    """The :data:`VEHICLE_PRESETS` entry ``name`` (None: :data:`DEFAULT_VEHICLE`; InvalidArgument naming the
    presets otherwise)."""
    try:
        return VEHICLE_PRESETS[vehicle_name(name)]
    except KeyError:
        raise InvalidArgument(
            f"vehicle must be one of {', '.join(VEHICLE_PRESETS)}, not {name!r}", options=("vehicle",)
        ) from None
