"""Motion-capture poses in, as the paper fed its Vicon positions to the UAVs: a port and a UDP/JSON reference.

The port is anything with ``latest() -> MocapPose | None``. The reference implementation listens for UDP
datagrams, each one JSON object per rigid body::

    {"body": "brick-1", "time_s": 12.345, "position_m": [1.20, 0.50, 0.80],
     "attitude_rad": [0.0, 0.0, 1.571]}                  # roll, pitch, yaw; world ENU, FLU body

``attitude_rad`` may be replaced by ``"quaternion": [w, x, y, z]`` (world-from-body); ``time_s`` defaults to the
arrival time. A bridge from Vicon (DataStream SDK), OptiTrack (NatNet) or a ROS topic is a few lines that send
such datagrams (docs/hardware.md). :class:`~masonry.adapters.mavlink.MavlinkFlightController` forwards the
poses of its body to the autopilot as VISION_POSITION_ESTIMATE.
"""

from __future__ import annotations

import json
import math
import socket
import threading
import time
from dataclasses import dataclass
from typing import Any, Protocol

from typing_extensions import Self

from masonry.errors import DeviceNotFound, InputError, InvalidArgument
from masonry.ports import Vec3


@dataclass(frozen=True)
class MocapPose:
    """One rigid-body pose in the world frame (ENU, metres; roll, pitch, yaw of the FLU body, radians)."""

    body: str
    time_s: float
    position_m: Vec3
    attitude_rad: Vec3


class PoseSource(Protocol):
    """A stream of motion-capture poses for one body."""

    def latest(self) -> MocapPose | None: ...


def quaternion_to_euler(w: float, x: float, y: float, z: float) -> Vec3:
    """Unit quaternion (world-from-body) -> roll, pitch, yaw (ZYX), radians."""
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if n == 0.0:
        raise InvalidArgument("zero quaternion")
    w, x, y, z = w / n, x / n, y / n, z / n
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return (roll, pitch, yaw)


def parse_pose(data: bytes | str, *, received_s: float) -> MocapPose:
    """One datagram -> ``MocapPose`` (raises InputError naming the field)."""
    try:
        obj = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"pose datagram is not JSON: {exc}") from exc
    if not isinstance(obj, dict):
        raise InputError("pose datagram must be a JSON object")

    def vector(name: str, size: int) -> tuple[float, ...]:
        value = obj.get(name)
        if not isinstance(value, list) or len(value) != size:
            raise InputError(f"pose field {name} must be a list of {size} numbers")
        try:
            out = tuple(float(v) for v in value)
        except (TypeError, ValueError) as exc:
            raise InputError(f"pose field {name} must hold numbers") from exc
        if not all(math.isfinite(v) for v in out):
            raise InputError(f"pose field {name} must be finite")
        return out

    body = obj.get("body", "")
    if not isinstance(body, str):
        raise InputError("pose field body must be a string")
    position = vector("position_m", 3)
    attitude: tuple[float, ...]
    if "quaternion" in obj:
        try:
            attitude = quaternion_to_euler(*vector("quaternion", 4))
        except ValueError as exc:
            raise InputError("pose field quaternion must not be zero") from exc
    elif "attitude_rad" in obj:
        attitude = vector("attitude_rad", 3)
    else:
        attitude = (0.0, 0.0, 0.0)
        if "yaw_rad" in obj:
            attitude = (0.0, 0.0, _scalar(obj, "yaw_rad"))
    t = obj.get("time_s", received_s)
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
        raise InputError("pose field time_s must be a number")
    return MocapPose(body, float(t), position, attitude)  # type: ignore[arg-type]


def _scalar(obj: dict[str, Any], name: str) -> float:
    value = obj.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"pose field {name} must be a number")
    return float(value)


class UdpPoseSource:
    """Listens on UDP for JSON poses and keeps the newest one of ``body`` (construct, then ``start``).

    Args:
        port: UDP port to listen on.
        host: address to bind (default loopback; ``0.0.0.0`` to hear a motion-capture PC on the network).
        body: rigid-body name to keep (None: every datagram, for a single-body setup).
        max_age_s: ``latest()`` returns None for a pose older than this (the tracker lost the body).
    """

    def __init__(
        self, port: int, *, host: str = "127.0.0.1", body: str | None = None, max_age_s: float = 0.5
    ):
        self.port = port
        self.host = host
        self.body = body
        self.max_age_s = max_age_s
        self.received = 0
        self.rejected = 0
        self.last_error: str | None = None
        self._latest: tuple[float, MocapPose] | None = None
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((self.host, self.port))
        except OSError as exc:
            sock.close()
            raise DeviceNotFound(f"pose source: cannot listen on udp {self.host}:{self.port}: {exc}") from exc
        sock.settimeout(0.05)
        self._sock = sock
        self.port = sock.getsockname()[1]
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="pose-source", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def _run(self) -> None:
        assert self._sock is not None
        while not self._stop.is_set():
            try:
                data, _addr = self._sock.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            now = time.monotonic()
            try:
                pose = parse_pose(data, received_s=now)
            except InputError as exc:
                self.rejected += 1
                self.last_error = str(exc)
                continue
            if self.body is not None and pose.body != self.body:
                continue
            with self._lock:
                self._latest = (now, pose)
                self.received += 1

    def latest(self) -> MocapPose | None:
        with self._lock:
            if self._latest is None or time.monotonic() - self._latest[0] > self.max_age_s:
                return None
            return self._latest[1]


def send_pose(sock: socket.socket, address: tuple[str, int], pose: MocapPose) -> None:
    """Send ``pose`` as one datagram (for bridges and tests)."""
    payload = {
        "body": pose.body,
        "time_s": pose.time_s,
        "position_m": list(pose.position_m),
        "attitude_rad": list(pose.attitude_rad),
    }
    sock.sendto(json.dumps(payload).encode("utf-8"), address)
