"""The simulated adapters: ``masonry.ports`` Protocols implemented on a ``SimUav`` of a ``World``.

Behaviour a state machine sees, as on the real UAV:

- Flight controller: commands go to the autopilot model (``SimVehicle``); refusals raise ``CommandRejected``.
  After a link loss or a UAV failure, commands are ignored and ``telemetry()`` keeps returning the last sample
  received, with ``link_ok`` False. ``connect``/``close`` only mark the port open (nothing to reach).
- Gripper: magnet and ball-joint lock; ``is_attached()`` reports whether a brick really hangs on the magnet.
- Sprayer: the valve; adhesive is deposited by the world while it is open near a surface (adhesion UAVs).
- Camera: every ``read()`` is a new frame at the current simulated time (``None`` once the UAV has failed):
  marker poses (``geometric``) or a rendered image (``render``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from masonry.perception.types import CameraIntrinsics
from masonry.ports import CameraFrame, Telemetry, Vec3

if TYPE_CHECKING:
    from masonry.sim.world import SimUav

__all__ = ["SimCamera", "SimFlightController", "SimGripper", "SimSprayer"]


class SimFlightController:
    """``FlightController`` on the simulated autopilot of one UAV."""

    def __init__(self, uav: SimUav) -> None:
        self._uav = uav
        self.connected = False

    def connect(self) -> None:
        self.connected = True

    def close(self) -> None:
        self.connected = False

    def _listening(self) -> bool:
        return self._uav.link_ok

    def arm(self) -> None:
        if self._listening():
            self._uav.vehicle.arm()

    def disarm(self) -> None:
        if self._listening():
            self._uav.vehicle.disarm()

    def takeoff(self, altitude_m: float, timeout_s: float | None = None) -> None:
        if self._listening():  # (the simulated autopilot's climb has no time limit of its own)
            self._uav.vehicle.takeoff(altitude_m)

    def land(self) -> None:
        if self._listening():
            self._uav.vehicle.land()

    def send_velocity(self, velocity_mps: Vec3, yaw_rate_radps: float) -> None:
        uav = self._uav
        if uav.link_ok:  # _listening(), inline: every control tick
            vehicle = uav.vehicle
            vehicle.command_velocity(velocity_mps, yaw_rate_radps, vehicle._t)

    @property
    def wind_speed_mps(self) -> float | None:
        """The autopilot's horizontal wind estimate's speed (what a WIND message reports); None: link down."""
        if not self._listening():
            return None
        wx, wy = self._uav.vehicle.wind_estimate_mps
        return math.hypot(wx, wy)

    def telemetry(self) -> Telemetry:
        uav = self._uav
        if uav.link_ok:  # SimUav.telemetry's common case, inline: every control tick
            return uav.vehicle.telemetry()
        return uav.telemetry()


class SimGripper:
    """``Gripper``: the electromagnet on its lockable ball joint (the ball joint starts locked, the magnet off)."""

    def __init__(self, uav: SimUav) -> None:
        self._uav = uav

    def set_magnet(self, on: bool) -> None:
        self._uav.set_magnet(bool(on))

    def set_joint_locked(self, locked: bool) -> None:
        self._uav.joint_locked = bool(locked)

    def is_attached(self) -> bool:
        return self._uav.carried_brick is not None

    def release_at(self, at_s: float) -> bool:
        """Let go at ``at_s`` of the world's clock, inside the physics step that holds it: the brick's pose there
        is interpolated between the step's ends (:meth:`masonry.sim.world.World.step`)."""
        uav = self._uav
        if at_s <= uav.world.clock.now_s():
            uav.set_magnet(False)
        else:
            uav.release_due_s = float(at_s)
        return True

    def can_time_release(self) -> bool:
        """Yes: :meth:`release_at` lets go inside the physics step it falls in."""
        return True


class SimSprayer:
    """``Sprayer``: the adhesive valve."""

    def __init__(self, uav: SimUav) -> None:
        self._uav = uav

    def set_valve(self, open_: bool) -> None:
        self._uav.set_valve(bool(open_))

    def is_valve_open(self) -> bool:
        return self._uav.valve_open


class SimCamera:
    """``Camera``: the downward camera on the UAV body."""

    def __init__(self, uav: SimUav) -> None:
        self._uav = uav

    @property
    def intrinsics(self) -> CameraIntrinsics:
        return self._uav.world.camera_config.intrinsics

    @property
    def T_body_cam(self) -> np.ndarray:
        return self._uav.world.airframe.T_body_cam()

    def read(self) -> CameraFrame | None:
        return self._uav.world._camera_frame(self._uav)

    def read_as_built(self) -> CameraFrame | None:
        """A frame of the as-built look (``masonry.fsm.as_built``): the same camera model, its noise drawn from
        a stream of its own, so that looking leaves every other random draw of the simulation as it was."""
        return self._uav.world._camera_frame(self._uav, self._uav.look_rng)
