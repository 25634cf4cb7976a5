"""The project's SITL (:class:`~masonry.adapters.sitl.MavlinkSitl`): its knobs (:class:`SitlConfig`), the MAVLink
constants it answers with, its default stream rates and :func:`free_udp_port`."""

from __future__ import annotations

from dataclasses import dataclass

from masonry.adapters.mavlink import (
    MSG_ATTITUDE,
    MSG_EKF_STATUS_REPORT,
    MSG_EXTENDED_SYS_STATE,
    MSG_LOCAL_POSITION_NED,
    MSG_SYS_STATUS,
    MSG_WIND,
)

MAV_TYPE_QUADROTOR = 2
MAV_RESULT_ACCEPTED, MAV_RESULT_DENIED, MAV_RESULT_UNSUPPORTED, MAV_RESULT_FAILED = 0, 2, 3, 4
MAV_RESULT_TEMPORARILY_REJECTED = 1
MAV_SEVERITY_CRITICAL, MAV_SEVERITY_WARNING, MAV_SEVERITY_INFO = 2, 4, 6
MAV_STATE_STANDBY, MAV_STATE_ACTIVE = 3, 4
MAV_LANDED_STATE_ON_GROUND, MAV_LANDED_STATE_IN_AIR = 1, 2
MAV_LANDED_STATE_TAKEOFF, MAV_LANDED_STATE_LANDING = 3, 4
DISARM_MAGIC = 21196  # ArduPilot: param2 of a forced disarm
VELOCITY_IGNORED = 8 | 16 | 32  # vx, vy, vz ignored: an acceleration target (masonry's own velocity loop)
VELOCITY_ONLY_IGNORED = 1 | 2 | 4  # x, y, z ignored: the only targets this SITL flies (velocity control)

#: Default stream rates (Hz) before a ground station asks for others (ArduPilot's SRx_ defaults are a few Hz).
DEFAULT_RATES_HZ = {
    MSG_LOCAL_POSITION_NED: 4.0,
    MSG_ATTITUDE: 4.0,
    MSG_SYS_STATUS: 1.0,
    MSG_EKF_STATUS_REPORT: 1.0,
    MSG_EXTENDED_SYS_STATE: 1.0,
    MSG_WIND: 1.0,  # ArduPilot's; a px4 SITL does not send it
}


#: Where :func:`free_udp_port` draws its ports: below the kernel's ephemeral range and above the autopilots' fixed
#: ports (PX4 14540-14600 and 18570-18600, ArduCopter 5760 on and 9002 on, MAVProxy 14550).
FREE_PORTS_FROM = 20000
#: Linux's default ephemeral range (``/proc/sys/net/ipv4/ip_local_port_range``), where that file cannot be read.
EPHEMERAL_PORTS_DEFAULT = (32768, 60999)


def free_udp_port(host: str = "127.0.0.1") -> int:
    """A UDP port on ``host`` that nothing is bound to right now (for tests and ``masonry sitl --port 0``).

    Drawn at random below the kernel's ephemeral ports: a port the kernel hands out (``bind`` to port 0, or any
    socket that sends before it binds: every SITL's, every ``udpout`` link's) can be taken by another socket between
    this check and the caller's own bind, and was (issue 29: the SITL load loop's run 15, "Address already in use").
    A port outside that range is taken only by an explicit bind to its number.
    """
    import secrets
    import socket

    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range", encoding="ascii") as f:
            ephemeral_from = int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        ephemeral_from = EPHEMERAL_PORTS_DEFAULT[0]
    count = ephemeral_from - FREE_PORTS_FROM
    for _ in range(100 if count > 0 else 0):
        port = FREE_PORTS_FROM + secrets.randbelow(count)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            try:
                sock.bind((host, port))
            except OSError:
                continue  # bound already: another draw
            return port
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:  # no room below the ephemeral range
        sock.bind((host, 0))
        return int(sock.getsockname()[1])


@dataclass(frozen=True)
class SitlConfig:
    """Knobs of the simulated autopilot (ArduCopter parameter names in comments)."""

    guided_timeout_s: float = 3.0  # GUID_TIMEOUT
    gcs_failsafe_s: float = 5.0  # FS_GCS_TIMEOUT (FS_GCS_ENABLE = LAND)
    ekf_converge_s: float = 0.5
    position_source: str = (
        "internal"  # "internal" (always available) or "vision" (needs VISION_POSITION_ESTIMATE)
    )
    arm_min_battery: float = 0.2  # BATT_ARM_MAH-like: refuse to arm below this fraction
    prearm_failure: str | None = None  # e.g. "Compass not calibrated": every arm attempt fails with it
    # PX4's first seconds: arming before this much simulated time is answered TEMPORARILY_REJECTED (PX4 v1.16
    # SITL: for 3 s after its first HEARTBEAT, with no STATUSTEXT on the offboard link); 0: ready at once
    arm_ready_s: float = 0.0
    heartbeat_hz: float = 1.0
    autopilot: str = "ardupilot"  # or "px4": PX4 modes, OFFBOARD rules, ESTIMATOR_STATUS
    offboard_loss_s: float = 1.0  # PX4 COM_OF_LOSS_T: OFFBOARD without setpoints this long -> AUTO.LOITER
    # the first this many answers that look at the setpoint stream (PX4's arming in OFFBOARD, an armed switch to
    # OFFBOARD) see it stale, as for a client starved under load (issue 29; tests)
    starved_answers: int = 0
    # PX4 EKF2's ESTIMATOR_STATUS as PX4 v1.16 SITL sends it (issue 20): 0x3FF at rest (constant-position mode
    # with everything else), 895 / 831 in flight (height above ground comes and goes)
    ekf2_flags: bool = False
    # the EKF's NED z where the vehicle stands (PX4 on GNSS and baro: -0.34 to -0.71 m, issue 20); 0: at home
    ekf_ground_z_m: float = 0.0
    vehicle: str = "ideal"  # the simulated vehicle's preset (masonry.sim.vehicle_config.VEHICLE_PRESETS)
    system_id: int = 1
    component_id: int = 1
    fence: str = (
        "accept"  # the fence's answers (masonry.adapters.sitl_fence: accept, unsupported, deny, corrupt)
    )
