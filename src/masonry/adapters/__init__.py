"""Hardware adapters: the only modules that talk to devices (pymavlink, pyserial, OpenCV capture, UDP).

Heavy libraries are imported when a device is opened, not when this package is imported.

- :class:`~masonry.adapters.mavlink.MavlinkFlightController`: FlightController over MAVLink 2 (ArduPilot, PX4), on
  :class:`~masonry.adapters.mavlink_link.MavlinkLink` (connection, threads, error counters in ``status()``) and
  :mod:`~masonry.adapters.mavlink_protocol` (MAVLink numbers and modes).
- :class:`~masonry.adapters.sitl.MavlinkSitl`: the simulator's UAV behind a MAVLink endpoint (``masonry sitl``).
- :class:`~masonry.adapters.arduino.ArduinoActuators`: Gripper and Sprayer on the actuator Arduino.
- :class:`~masonry.adapters.arduino_fake.FakeArduino`: that Arduino on a pseudo-terminal, for tests and demos.
- :class:`~masonry.adapters.camera.OpenCvCamera`: Camera on OpenCV VideoCapture.
- :class:`~masonry.adapters.pose_source.UdpPoseSource`: motion-capture poses over UDP/JSON.
- :mod:`~masonry.adapters.wiring`: open the adapters of one UAV and run the pre-flight check.
"""

from __future__ import annotations

from masonry.adapters.arduino import ArduinoActuators
from masonry.adapters.arduino_fake import FakeArduino
from masonry.adapters.camera import OpenCvCamera
from masonry.adapters.mavlink import FrameTransform, LinkClock, MavlinkFlightController, load_signing_key
from masonry.adapters.pose_source import MocapPose, PoseSource, UdpPoseSource
from masonry.adapters.sitl import MavlinkSitl, SitlConfig
from masonry.adapters.wiring import HardwareConfig, PreflightReport, open_adapters, preflight

__all__ = [
    "ArduinoActuators",
    "FakeArduino",
    "FrameTransform",
    "HardwareConfig",
    "LinkClock",
    "MavlinkFlightController",
    "MavlinkSitl",
    "MocapPose",
    "OpenCvCamera",
    "PoseSource",
    "PreflightReport",
    "SitlConfig",
    "UdpPoseSource",
    "load_signing_key",
    "open_adapters",
    "preflight",
]
