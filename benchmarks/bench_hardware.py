"""Hardware adapters over loopback: MAVLink setpoint rate and command round trip, actuator round trip over a pty.

Prints its figures (docs/performance/hardware.md). Run: python benchmarks/bench_hardware.py
"""

from __future__ import annotations

import statistics
import time

from masonry.adapters.arduino import ArduinoActuators
from masonry.adapters.arduino_fake import FakeArduino
from masonry.adapters.mavlink import MAV_CMD_SET_MESSAGE_INTERVAL, MavlinkFlightController
from masonry.adapters.sitl import MavlinkSitl, SitlConfig, free_udp_port


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def mavlink() -> None:
    port = free_udp_port()
    sitl = MavlinkSitl(port, time_scale=4.0, config=SitlConfig(heartbeat_hz=4.0))
    sitl.start()
    started = time.monotonic()
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", setpoint_rate_hz=20.0)
    fc.connect()
    print(f"connect (heartbeat, rates, clock anchored): {(time.monotonic() - started) * 1000:.0f} ms")
    try:
        fc.arm()
        fc.takeoff(1.0)
        while fc.telemetry().position_m[2] < 0.95 or abs(fc.telemetry().velocity_mps[2]) > 0.1:
            time.sleep(0.01)
        for rate_hz in (20.0, 50.0):
            fc.setpoint_rate_hz = rate_hz  # read by the sender at its next start: restart it
            fc.close()
            fc.connect()
            fc.send_velocity((0.1, 0.0, 0.0), 0.0)
            before, t0 = sitl.setpoints_received, time.monotonic()
            window = 3.0
            while time.monotonic() - t0 < window:
                fc.send_velocity((0.1, 0.0, 0.0), 0.0)  # a caller refreshing every 0.2 s
                time.sleep(0.2)
            got = (sitl.setpoints_received - before) / (time.monotonic() - t0)
            calls = window / 0.2
            print(
                f"setpoint stream at {rate_hz:.0f} Hz configured: {got:.1f} Hz received by the autopilot "
                f"(of which {calls / window:.0f} Hz sent directly by send_velocity)"
            )
        rtts = []
        for _ in range(200):
            t = time.perf_counter()
            fc.command("rate", MAV_CMD_SET_MESSAGE_INTERVAL, (32, 1e6 / 30.0))
            rtts.append((time.perf_counter() - t) * 1000)
        print(
            f"COMMAND_LONG -> COMMAND_ACK round trip (loopback): median {statistics.median(rtts):.2f} ms, "
            f"p95 {percentile(rtts, 0.95):.2f} ms, max {max(rtts):.2f} ms"
        )
        fc.land()
    finally:
        fc.close()
        sitl.stop()


def actuators() -> None:
    with FakeArduino() as fake, ArduinoActuators(fake.port, boot_wait_s=0.05) as board:
        rtts = []
        for i in range(500):
            t = time.perf_counter()
            if i % 2:
                board.status()
            else:
                board.set_magnet(i % 4 == 0)
            rtts.append((time.perf_counter() - t) * 1000)
        print(
            f"actuator command round trip (pty fake, 115200 baud nominal): median {statistics.median(rtts):.2f} ms, "
            f"p95 {percentile(rtts, 0.95):.2f} ms"
        )


if __name__ == "__main__":
    mavlink()
    actuators()
