"""The SITL's telemetry streams: one message of each, from the simulated state (:class:`MavlinkSitl`'s ``_send_stream``)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.adapters.mavlink import (
    MSG_ATTITUDE,
    MSG_EKF_STATUS_REPORT,
    MSG_ESTIMATOR_STATUS,
    MSG_EXTENDED_SYS_STATE,
    MSG_LOCAL_POSITION_NED,
    MSG_SYS_STATUS,
    MSG_WIND,
    FrameTransform,
)
from masonry.adapters.sitl_config import (
    MAV_LANDED_STATE_IN_AIR,
    MAV_LANDED_STATE_LANDING,
    MAV_LANDED_STATE_ON_GROUND,
    MAV_LANDED_STATE_TAKEOFF,
)

if TYPE_CHECKING:
    from masonry.adapters.sitl import MavlinkSitl

__all__ = ["send_stream"]


def send_stream(self: MavlinkSitl, msg_id: int) -> None:
    """Send one message of stream ``msg_id`` (its state now): the SITL's ``_send_stream``."""
    v = self.vehicle
    mav = self._conn.mav
    boot_ms = round(self.sim_time_s * 1000) & 0xFFFFFFFF
    ekf_ok = self._ekf_ok()
    if msg_id == MSG_LOCAL_POSITION_NED:
        if ekf_ok:
            tel = v.telemetry() if self.lockstep is None else self.lockstep.telemetry()  # (the step's noise)
            x, y, z = self.frame.position_to_ned(tel.position_m)
            vx, vy, vz = self.frame.velocity_to_ned(tel.velocity_mps)
            mav.local_position_ned_send(boot_ms, x, y, z + self.config.ekf_ground_z_m, vx, vy, vz)
    elif msg_id == MSG_ATTITUDE:
        roll, pitch, yaw = self.frame.attitude_to_ned(*v.attitude_rad)
        mav.attitude_send(
            boot_ms, roll, pitch, yaw, 0.0, 0.0, FrameTransform.yaw_rate_to_ned(v.yaw_rate_radps)
        )
    elif msg_id == MSG_SYS_STATUS:
        fraction = v.battery_fraction
        voltage_mv = int((3.5 + 0.7 * fraction) * 4 * 1000)  # a 4S pack between 14.0 and 16.8 V
        mav.sys_status_send(0, 0, 0, 500, voltage_mv, 1500 if v.armed else 50, round(fraction * 100),
                            0, 0, 0, 0, 0, 0)  # fmt: skip
    elif msg_id == MSG_EKF_STATUS_REPORT:
        flags = (1 | 2 | 4 | 8 | 32) if ekf_ok else (1 | 128 | 1024)  # no GPS: no absolute position
        mav.ekf_status_report_send(flags, 0.1, 0.1, 0.1, 0.1, 0.0)
    elif msg_id == MSG_ESTIMATOR_STATUS:
        flags = (1 | 2 | 4 | 8 | 32) if ekf_ok else (1 | 128)  # ESTIMATOR_STATUS_FLAGS
        if (
            ekf_ok and self.config.ekf2_flags
        ):  # (lock-step: the flicker's phase from the flight's first grant)
            epoch_s = self.lockstep.epoch_s if self.lockstep is not None else 0.0
            at_rest = not v.armed or v.on_ground
            flags = 0x3FF if at_rest else (895 if int(self.sim_time_s - epoch_s) % 2 == 0 else 831)
        mav.estimator_status_send(int(self.sim_time_s * 1e6), flags, 0.1, 0.1, 0.1, 0.1, 0.0, 0.0, 0.01, 0.01)
    elif msg_id == MSG_WIND:
        wx, wy = v.wind_estimate_mps  # ENU, where the air goes: it blows from the opposite bearing
        from_deg = math.degrees(math.atan2(-wx, -wy)) % 360.0 if wx or wy else 0.0
        mav.wind_send(from_deg, math.hypot(wx, wy), 0.0)
    elif msg_id == MSG_EXTENDED_SYS_STATE:
        if not v.armed or v.on_ground:
            landed = MAV_LANDED_STATE_ON_GROUND
        elif v.taking_off:
            landed = MAV_LANDED_STATE_TAKEOFF
        elif self.mode == self._land_mode:
            landed = MAV_LANDED_STATE_LANDING
        else:
            landed = MAV_LANDED_STATE_IN_AIR
        mav.extended_sys_state_send(0, landed)
