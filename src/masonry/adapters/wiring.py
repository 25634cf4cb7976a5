"""Open the adapters one UAV flies with, each chosen on its own, and check them before flight.

``masonry fly`` calls :func:`open_adapters` with a :class:`HardwareConfig` (from ``--fc``, ``--actuators``,
``--camera``, ``--calibration`` and ``--config uav.yaml``), then :func:`preflight`, which prints what is connected
and refuses to arm with a clear reason. Any adapter left at ``sim`` comes from the simulated world; when the
flight controller is real, that world follows the position the autopilot reports, so the simulated camera renders
the bricks as seen from there and the simulated magnet grips a brick the real UAV's tool reaches.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from masonry.adapters.lockstep import LockstepClock
from masonry.adapters.preflight import CheckItem, PreflightReport, preflight
from masonry.adapters.preflight import _check_actuators as _check_actuators
from masonry.adapters.preflight import _check_camera as _check_camera
from masonry.adapters.preflight import _check_fence as _check_fence
from masonry.blueprint import quote
from masonry.errors import InputError
from masonry.fsm.tuning_choice import TUNINGS
from masonry.ports import Telemetry, UavPorts

SIM = "sim"
SIM_CAMERA_MODES = ("sim", "geometric", "render")


@dataclass(frozen=True)
class HardwareConfig:
    """Which adapter drives each port, and their settings (the keys of ``uav.yaml``)."""

    fc: str = SIM  # "sim" or a MAVLink connection string (udpin:0.0.0.0:14550, /dev/ttyACM0, tcp:...)
    actuators: str = SIM  # "sim" or the Arduino's serial port
    camera: str = (
        SIM  # "sim" | "geometric" | "render" (simulated) or a device index, video file, GStreamer string
    )
    calibration: str | None = None  # camera calibration (``masonry calibrate``): required for a real camera
    fc_baud: int = 115200
    autopilot: str = "auto"  # auto | ardupilot | px4
    signing_key: str | None = None  # MAVLink 2 signing key file
    heartbeat_timeout_s: float = 1.0
    # the autopilot's local origin in the world (ENU); None: the UAV's blueprint home (an autopilot on GPS starts
    # its local frame where it stands, ArduCopter and PX4 alike), or the world's origin with motion capture
    # forwarded to it (``mocap_port``: it is fed world-frame poses)
    origin_m: tuple[float, float, float] | None = None
    origin_yaw_rad: float = 0.0
    # measure the ground height the autopilot's EKF reports at each arming at home and read it as the home's z
    # (issue 20: PX4 on GNSS and baro put the ground 0.34-0.71 m up); None: when the autopilot positions itself
    # (no ``origin_m``, no ``mocap_port``)
    measure_ground: bool | None = None
    mocap_port: int | None = None  # forward motion-capture poses from this UDP port to the autopilot
    mocap_host: str = "0.0.0.0"
    mocap_body: str | None = None  # rigid-body name (default: the UAV's name)
    actuator_baud: int = 115200
    actuator_boot_wait_s: float = 2.0  # opening the port resets an Uno/Nano: wait for its HELLO this long
    min_battery: float = 0.5  # pre-flight: refuse to arm below this charge fraction
    # pre-flight: wait this long for the autopilot's position estimate (``--estimate-wait``): ArduCopter SITL needs
    # ~40 s from its first connection (DEPENDENCY-NOTES), a cold Pixhawk about as long; 90 s covers both
    estimate_wait_s: float = 90.0
    # the autopilot's velocity loop time constant: the state machines feed a leg's acceleration x this forward
    # (``UavConfig.velocity_lag_s``, docs/state-machines.md); 0 for none; None: the control preset's
    velocity_lag_s: float | None = None
    # the wind above which mission control gives this UAV no task (issue 18; its heartbeats carry it and the
    # autopilot's WIND reading): masonry.mission.wind_limit.DEFAULT_MAX_WIND_MPS for a 4.5 kg hexacopter
    max_wind_mps: float = 8.0
    # the state machines' tuning (masonry.fsm.tuning): a preset (ideal | arducopter), then any UavConfig field
    # (``control``) and the position controller's gains per axis (``pid``) over it
    control_preset: str | None = None  # None: the autopilot's (masonry.fsm.tuning_choice), or --vehicle's
    control: dict[str, Any] = field(default_factory=dict)
    pid: dict[str, Any] = field(default_factory=dict)
    # ``identify``: the first hover identifies the velocity response and the position gains are derived from it
    # (masonry.fsm.first_hover; the preset's when unusable); ``preset``: the preset's. A ``control_preset`` or
    # ``pid`` given wins: no identification then (masonry.fsm.tuning_choice)
    tuning: str = "preset"

    def uav_settings(
        self, default_preset: str = "ideal", *, own_velocity_loop: bool | None = None
    ) -> dict[str, Any]:
        """The :class:`~masonry.fsm.UavConfig` overrides this configuration asks for (both modes of ``fly``);
        ``default_preset`` when it names none (``fly --sim --vehicle arducopter`` flies the arducopter tuning);
        ``own_velocity_loop``: the flight controller flies masonry's velocity loop (a real PX4, issue 29); None: as
        masonry does on the preset's autopilot by default (masonry.fsm.tuning.uav_settings)."""
        from masonry.fsm.tuning import uav_settings

        control = dict(self.control)
        if self.velocity_lag_s is not None:
            control.setdefault("velocity_lag_s", self.velocity_lag_s)
        return uav_settings(
            self.control_preset or default_preset, control, self.pid, own_velocity_loop=own_velocity_loop
        )

    def origin_for(self, home_m: tuple[float, float, float]) -> tuple[float, float, float]:
        """Where the autopilot's local origin is in the world for a UAV whose blueprint home is ``home_m``."""
        if self.origin_m is not None:
            return self.origin_m
        return (
            (0.0, 0.0, 0.0)
            if self.mocap_port is not None
            else (float(home_m[0]), float(home_m[1]), float(home_m[2]))
        )

    def ground_for(self, home_m: tuple[float, float, float]) -> tuple[float, float, float] | None:
        """Where the UAV stands when it arms, for the adapter to measure the EKF's ground height against (None:
        take the frame as ``origin_for`` gives it); the same rule in single-task and mission mode."""
        measure = self.measure_ground
        if measure is None:
            measure = self.origin_m is None and self.mocap_port is None
        return (float(home_m[0]), float(home_m[1]), float(home_m[2])) if measure else None

    @property
    def sim_fc(self) -> bool:
        return self.fc == SIM

    @property
    def sim_actuators(self) -> bool:
        return self.actuators == SIM

    @property
    def sim_camera(self) -> bool:
        return self.camera in SIM_CAMERA_MODES

    @property
    def all_sim(self) -> bool:
        return self.sim_fc and self.sim_actuators and self.sim_camera


#: Keys a ``--config uav.yaml`` may hold besides the HardwareConfig fields (read by ``masonry fly`` itself).
EXTRA_CONFIG_KEYS = ("name", "mission")


def load_uav_config(path: str | Path) -> dict[str, Any]:
    """Read ``uav.yaml``: a mapping of HardwareConfig field names (plus ``name``, ``mission``) to values.

    Raises:
        InputError: unreadable, not a mapping, an unknown key, or a value of the wrong type (named).
    """
    import yaml

    from masonry.blueprint_yaml import FileLimitError, read_text_limited, safe_load

    p = Path(path)
    try:
        data = safe_load(read_text_limited(p))
    except FileLimitError as exc:
        raise InputError(f"{p}: cannot read the UAV configuration: {exc}") from None
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{p}: not a UAV configuration: not UTF-8 text (byte {exc.object[exc.start]:#04x} at "
            f"offset {exc.start})"
        ) from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read the UAV configuration: {exc.strerror or exc}") from exc
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(f"{p}: not valid YAML{where}: {problem[:160]}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise InputError(f"{p}: a UAV configuration is a mapping of settings (fc: ..., actuators: ...)")
    known = {f.name: f for f in fields(HardwareConfig)}
    out: dict[str, Any] = {}
    for key, value in data.items():
        name = str(key).replace("-", "_")
        if name in EXTRA_CONFIG_KEYS:
            if not isinstance(value, str):
                raise InputError(f"{p}: {key} must be a string")
            out[name] = value
            continue
        if name not in known:
            raise InputError(
                f"{p}: unknown setting {quote(key)} (known: {', '.join(sorted([*known, *EXTRA_CONFIG_KEYS]))})"
            )
        out[name] = _coerce(p, name, value, getattr(HardwareConfig, name, None))
    return out


def _coerce(p: Path, name: str, value: Any, default: Any) -> Any:
    if value is None:
        return None
    if name == "origin_m":
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            raise InputError(f"{p}: origin_m must be a list of 3 numbers [x, y, z], got {quote(value)}")
        try:
            return tuple(float(v) for v in value)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{p}: origin_m must hold numbers") from exc
    if name in ("control", "pid"):
        if not isinstance(value, dict):
            raise InputError(f"{p}: {name} must be a mapping (setting: value), got {quote(value)}")
        return {str(k).replace("-", "_"): v for k, v in value.items()}
    if name == "measure_ground":
        if not isinstance(value, bool):
            raise InputError(f"{p}: measure_ground must be true or false, got {quote(value)}")
        return value
    if name in ("fc_baud", "actuator_baud", "mocap_port"):
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{p}: {name} must be an integer, got {quote(value)}")
        return value
    if isinstance(default, float) or name == "velocity_lag_s":  # (its default, None, is the preset's)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"{p}: {name} must be a number, got {quote(value)}")
        return float(value)
    return str(value)  # fc, actuators, camera (an index may be written as a number), paths, names


def hardware_config(cli: dict[str, Any], file_settings: dict[str, Any] | None = None) -> HardwareConfig:
    """Command-line values (None = not given) over ``uav.yaml`` values over the defaults; checked."""
    merged: dict[str, Any] = {}
    for f in fields(HardwareConfig):
        if cli.get(f.name) is not None:
            merged[f.name] = cli[f.name]
        elif file_settings and file_settings.get(f.name) is not None:
            merged[f.name] = file_settings[f.name]
    hw = HardwareConfig(**merged)
    if hw.tuning not in TUNINGS:
        raise InputError(f"tuning must be {' or '.join(TUNINGS)}, not {hw.tuning!r}")
    if hw.autopilot not in ("auto", "ardupilot", "px4"):
        raise InputError(f"autopilot must be auto, ardupilot or px4, not {hw.autopilot!r}")
    if not hw.sim_camera and hw.calibration is None:
        raise InputError(
            f"`camera` {hw.camera} needs `calibration` FILE (the camera calibration from `masonry calibrate`)",
            options=("camera", "calibration"),
        )
    if not 0.0 <= hw.min_battery <= 1.0:
        raise InputError(f"min_battery must be a fraction between 0 and 1, not {hw.min_battery}")
    if not hw.heartbeat_timeout_s > 0.0:
        raise InputError("heartbeat_timeout_s must be > 0")
    if not 0.0 < hw.max_wind_mps <= 30.0:
        raise InputError(f"max_wind_mps must be > 0 and at most 30 m/s, not {hw.max_wind_mps}")
    if not 0.0 < hw.estimate_wait_s <= 600.0:
        raise InputError(f"estimate_wait_s must be > 0 and at most 600 s, not {hw.estimate_wait_s}")
    if hw.velocity_lag_s is not None and not 0.0 <= hw.velocity_lag_s <= 2.0:
        raise InputError(
            f"velocity_lag_s must be between 0 and 2 s (the autopilot's velocity loop time constant), "
            f"not {hw.velocity_lag_s}"
        )
    hw.uav_settings()  # an unknown preset, setting or gain is an input error now, not in flight
    return hw


#: The old name of the record :func:`open_adapters` returns (it is :class:`masonry.ports.UavPorts` now).
OpenAdapters = UavPorts


@dataclass
class _Opening:
    """What :func:`open_adapters` has opened so far: the closers (newest last) and the descriptions."""

    descriptions: dict[str, str] = field(default_factory=dict)
    closers: list[Callable[[], None]] = field(default_factory=list)

    def close(self) -> None:
        """Close what was opened, newest first; never raises (a shutdown path)."""
        while self.closers:
            closer = self.closers.pop()
            try:
                closer()
            except Exception:  # closing must go on whatever one adapter does
                pass


class ZeroedClock:
    """A clock reading zero when made (``masonry fly`` traces start at 0 s on any time base)."""

    def __init__(self, base: Any) -> None:
        self.base = base
        # in whole ms (time_boot_ms's grain): a lock-step flight's times less it are then the same numbers however
        # long the pre-flight took (docs/sitl-lockstep.md), so the fly loop and a simulated world repeat
        self.start_s = round(base.now_s(), 3)

    def now_s(self) -> float:
        return float(self.base.now_s() - self.start_s)

    def sleep(self, duration_s: float) -> None:
        self.base.sleep(duration_s)


def _follow_autopilot(uav: Any, fc: Any) -> None:
    """Make the simulated UAV's body follow the real autopilot's telemetry (its tools and camera go along)."""
    from masonry.sim.vehicle import SimVehicle

    class TelemetryVehicle(SimVehicle):
        """A SimVehicle whose state is the FlightController's telemetry at every step (``SimVehicle.follow``)."""

        follows_telemetry = True  # (masonry.sim.follow_contact: a carried brick stays on the bricks under it)

        def idle(self, dt_s: float) -> None:  # the world's fast path for a parked vehicle: it may take off
            self.step(dt_s)

        def step(self, dt_s: float) -> None:
            tel: Telemetry = fc.telemetry()
            self.follow(
                tel.position_m,
                tel.velocity_mps,
                tel.attitude_rad,
                on_ground=tel.on_ground,
                armed=tel.armed,
                mode=tel.mode,
                battery_fraction=tel.battery_fraction,
                dt_s=dt_s,
            )

    old = uav.vehicle
    uav.vehicle = TelemetryVehicle(old.config, position_m=old.position_m, yaw_rad=old.yaw_rad)


def open_adapters(
    hw: HardwareConfig,
    *,
    blueprint: Any,
    spec: Any,
    seed: int = 0,
    faults: Any = None,
) -> UavPorts:
    """Build and open the adapters of ``spec`` as ``hw`` says (each port on its own); the caller closes them
    (``UavPorts.close``).

    Raises:
        DeviceNotFound / LinkLost / CommandTimeout: a real device cannot be reached (its error names it).
        InputError: a setting is unusable (calibration, signing key file).
    """
    from masonry.sim import Faults, World

    faults = faults if faults is not None else Faults()
    camera_mode = "render" if hw.camera == "render" else "geometric"
    opened = _Opening()
    try:
        fc = None
        link_clock = None
        if not hw.sim_fc:
            fc, paced = _open_mavlink(hw, spec, opened)
            link_clock = ZeroedClock(paced)
        need_world = hw.sim_fc or hw.sim_actuators or hw.sim_camera
        world = None
        uav = None
        if need_world:
            start_s = link_clock.now_s() if link_clock is not None else 0.0
            world = World(blueprint, seed=seed, camera=camera_mode, faults=faults, start_s=start_s)  # type: ignore[arg-type]
            faults.check_uavs([spec.name])
            uav = world.add_uav(spec)
            if fc is not None:
                _follow_autopilot(uav, fc)
        clock: Any
        advance: Callable[[float], None]
        if fc is None:
            assert uav is not None and world is not None
            fc, clock, advance = uav.fc, world.clock, world.step
            opened.descriptions["flight controller"] = "simulated"
        else:
            clock, advance = link_clock, _advance_on(link_clock, world, paced)
        gripper, sprayer = _open_actuators(hw, uav, opened)
        camera = _open_camera(hw, uav, clock, opened, camera_mode, sim_fc=hw.sim_fc)
        return UavPorts(
            fc, gripper, sprayer, camera, clock, advance, world, dict(opened.descriptions), opened.close
        )
    except BaseException:
        opened.close()
        raise


def _advance_on(clock: Any, world: Any, paced: Any = None) -> Callable[[float], None]:
    """``advance`` on the autopilot's clock: wait until the tick is due, then bring the simulated world (if any) level.

    The tick is due ``dt_s`` after the last one woke: off lock-step the machine's own work runs on the autopilot's
    clock too, and a whole ``dt_s`` after it made the 20 Hz loop tick at 8-9 Hz against the real PX4 (issue 29).
    In lock-step (``paced.lockstep`` and not ``paced.gone``) the clock stands while the tick works, and the wait is
    ``dt_s`` exactly, so a lock-step flight repeats. A tick that overran waits nothing and does not catch up.
    """
    woke_s: list[float] = []

    def advance(dt_s: float) -> None:
        in_step = bool(getattr(paced, "lockstep", False)) and not bool(getattr(paced, "gone", False))
        spent_s = clock.now_s() - woke_s[0] if woke_s and not in_step else 0.0
        clock.sleep(max(0.0, dt_s - spent_s))
        woke_s[:] = [clock.now_s()]
        if world is not None:  # keep the simulated world on the autopilot's time
            step = clock.now_s() - world.clock.now_s()
            if step > 1e-6:
                world.step(step)

    return advance


def _open_actuators(hw: HardwareConfig, uav: Any, opened: _Opening) -> tuple[Any, Any]:
    """The gripper and the sprayer: the simulated UAV's, or the actuator Arduino (one board for both)."""
    if hw.sim_actuators:
        assert uav is not None
        opened.descriptions["actuators"] = "simulated"
        return uav.gripper, uav.sprayer
    from masonry.adapters.arduino import ArduinoActuators

    board = ArduinoActuators(hw.actuators, baud=hw.actuator_baud, boot_wait_s=hw.actuator_boot_wait_s)
    board.connect()
    opened.closers.append(board.close)
    opened.descriptions["actuators"] = f"Arduino on {hw.actuators} (protocol v{board.version})"
    return board, board


def _open_camera(
    hw: HardwareConfig, uav: Any, clock: Any, opened: _Opening, camera_mode: str, *, sim_fc: bool
) -> Any:
    """The camera: the simulated UAV's (seen from where the flight controller says it is), or an OpenCV one."""
    if hw.sim_camera:
        assert uav is not None
        where = "the autopilot's reported position" if not sim_fc else "the simulated UAV"
        opened.descriptions["camera"] = f"simulated ({camera_mode}), seen from {where}"
        return uav.camera
    from masonry.adapters.camera import OpenCvCamera

    cam = OpenCvCamera(hw.camera, calibration=hw.calibration, clock=clock)
    cam.connect()
    opened.closers.append(cam.close)
    intr = cam.intrinsics
    opened.descriptions["camera"] = (
        f"OpenCV {cam.kind} {hw.camera} ({intr.width_px}x{intr.height_px}, {hw.calibration})"
    )
    return cam


def _open_mavlink(hw: HardwareConfig, spec: Any, opened: _Opening) -> tuple[Any, LockstepClock]:
    """The connected flight controller and its clock (in lock-step with a SITL that asks for it)."""
    from masonry.adapters.mavlink import FrameTransform, MavlinkFlightController, load_signing_key

    pose_source = None
    if hw.mocap_port is not None:
        from masonry.adapters.pose_source import UdpPoseSource

        pose_source = UdpPoseSource(hw.mocap_port, host=hw.mocap_host, body=hw.mocap_body or spec.name)
        pose_source.start()
        opened.closers.append(pose_source.close)
    fc = MavlinkFlightController(
        hw.fc,
        baud=hw.fc_baud,
        autopilot=hw.autopilot,  # type: ignore[arg-type]
        heartbeat_timeout_s=hw.heartbeat_timeout_s,
        frame=FrameTransform(hw.origin_for(spec.home_m), hw.origin_yaw_rad),
        ground_m=hw.ground_for(spec.home_m),
        signing_key=load_signing_key(hw.signing_key) if hw.signing_key else None,
        pose_source=pose_source,
    )
    paced = LockstepClock(fc)  # before connecting: a SITL announces lock-step on the first heartbeat it hears
    fc.connect()
    opened.closers.append(fc.close)
    who = f"{fc.autopilot} system {fc.target_system}"
    extras = []
    if hw.signing_key:
        extras.append("signed")
    if pose_source is not None:
        extras.append(f"motion capture from udp:{hw.mocap_host}:{pose_source.port}")
    opened.descriptions["flight controller"] = f"MAVLink {hw.fc}: {who}" + (
        f" ({', '.join(extras)})" if extras else ""
    )
    return fc, paced


def describe(hw: HardwareConfig) -> str:
    """One line: which adapter drives each port."""
    return f"fc {hw.fc}, actuators {hw.actuators}, camera {hw.camera}"


__all__ = [
    "CheckItem",
    "HardwareConfig",
    "OpenAdapters",
    "PreflightReport",
    "describe",
    "hardware_config",
    "load_uav_config",
    "open_adapters",
    "preflight",
]
