"""What a flight against the project's SITL was doing when a test failed: both sides, in a few lines.

A SITL test that fails on a loaded machine once in a hundred runs cannot be traced from "timed out waiting for
the takeoff altitude" alone (issue 29: the SITL loop's run 7). The failure messages of ``test_sitl``'s ``flight``
and ``take_off`` add these lines: the adapter's last telemetry, its take-off state, the acknowledgements it got
and the autopilot's texts; the SITL's simulated time against the wall, the vehicle's true state, the setpoints
it applied and its status log; and, for a wait on the telemetry, the trace of height and climb rate it saw.
"""

from __future__ import annotations

import time
from collections import deque

from masonry.adapters.mavlink import MavlinkFlightController
from masonry.adapters.sitl import MavlinkSitl

#: The trace's spacing (wall s) and length: the last 6 s of a wait.
TRACE_EVERY_S = 0.1
TRACE_SAMPLES = 60


class HeightTrace:
    """The height and climb rate (telemetry, world frame) a wait saw, every :data:`TRACE_EVERY_S` of wall."""

    def __init__(self, fc: MavlinkFlightController) -> None:
        self._fc = fc
        self._started_s = time.monotonic()
        self._last_s = -float("inf")
        self.samples: deque[tuple[float, float, float, float]] = deque(maxlen=TRACE_SAMPLES)
        self.highest: tuple[float, float] | None = None  # (wall s, height m): the highest the wait saw

    def height_and_climb(self) -> tuple[float, float]:
        """The telemetry's height (m) and climb rate (m/s) now, kept in the trace."""
        tel = self._fc.telemetry()
        z, vz = tel.position_m[2], tel.velocity_mps[2]
        wall_s = time.monotonic() - self._started_s
        if self.highest is None or z > self.highest[1]:
            self.highest = (wall_s, z)
        if wall_s - self._last_s >= TRACE_EVERY_S:
            self._last_s = wall_s
            self.samples.append((wall_s, tel.time_s, z, vz))
        return z, vz

    def reached(self, altitude_m: float) -> bool:
        """The take-off's altitude reached: the height above ``altitude_m`` less 0.05 m, still within 0.05 m/s."""
        z, vz = self.height_and_climb()
        return z > altitude_m - 0.05 and abs(vz) < 0.05

    @staticmethod
    def awaited(altitude_m: float) -> str:
        """What :meth:`reached` waits for, for a wait's message."""
        return f"the takeoff altitude (above {altitude_m - 0.05:.2f} m and within 0.05 m/s)"

    def describe(self) -> str:
        if self.highest is None:
            return "telemetry seen: none"
        rows = ", ".join(f"{w:.1f}/{t:.2f}: {z:.3f} {vz:+.3f}" for w, t, z, vz in self.samples)
        top_s, top_m = self.highest
        return (
            f"telemetry seen (wall s / autopilot s: height m, climb m/s), highest {top_m:.3f} m at {top_s:.1f} s "
            f"of wall; the last {len(self.samples)}: {rows}"
        )


def describe_flight(sitl: MavlinkSitl | None, fc: MavlinkFlightController, started_wall_s: float) -> str:
    """Both sides of a flight now, one line each (never raises: it is read while a failure is reported)."""
    lines = []
    try:
        tel = fc.telemetry()
        acks = [(cmd, result) for _, cmd, result in fc._ack_log[-8:]]
        target = "none" if fc._takeoff_target_m is None else f"{fc._takeoff_target_m:.3f}"
        lines.append(
            f"adapter: t {tel.time_s:.2f} s, height {tel.position_m[2]:.3f} m, climb {tel.velocity_mps[2]:+.3f} m/s, "
            f"{'armed' if tel.armed else 'disarmed'} in {tel.mode}, on the ground {tel.on_ground}, link "
            f"{'up' if tel.link_ok else 'down'}; take-off to {target} m, problem {fc.takeoff_problem}; "
            f"{fc.setpoints_sent} setpoints sent; the last acks (command, result) {acks}; "
            f"the autopilot's texts {fc.status_texts()[-6:]}"
        )
    except Exception as exc:  # a description must not hide the failure it describes
        lines.append(f"adapter: not described ({type(exc).__name__}: {exc})")
    if sitl is None:
        return "\n".join(lines)
    try:
        v = sitl.vehicle
        (_, _, z), (_, _, vz) = v.position_m, v.velocity_mps
        wall_s = time.monotonic() - started_wall_s
        lines.append(
            f"SITL: {sitl.sim_time_s:.2f} s simulated in {wall_s:.2f} s of wall (x{sitl.time_scale:g} asked), "
            f"thread {'running' if sitl._thread is not None and sitl._thread.is_alive() else 'stopped'}; "
            f"vehicle at {z:.3f} m, {vz:+.3f} m/s, {'armed' if v.armed else 'disarmed'} in {sitl.mode}, "
            f"taking off {v.taking_off}, on the ground {v.on_ground}; {sitl.setpoints_received} setpoints "
            f"applied, the last {sitl.last_setpoint_mps}; status log {sitl.status_log[-8:]}"
        )
    except Exception as exc:  # a description must not hide the failure it describes
        lines.append(f"SITL: not described ({type(exc).__name__}: {exc})")
    return "\n".join(lines)
