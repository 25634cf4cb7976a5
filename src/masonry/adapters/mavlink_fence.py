"""The site's geofence uploaded to the autopilot as its own fence (MAVLink mission protocol, fence type).

The autopilot then holds the fence even when masonry does not (a crashed computer, a pilot's mode): ArduPilot's
fence (and PX4's geofence) takes a polygon as ``MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION`` items in
``mission_type`` ``MAV_MISSION_TYPE_FENCE``, with global coordinates, and the altitude limit as parameters.

Upload (ground station -> autopilot): MISSION_COUNT, then one MISSION_ITEM_INT per MISSION_REQUEST_INT (or
MISSION_REQUEST) the autopilot sends, until its MISSION_ACK (``MAV_MISSION_ACCEPTED`` or the reason). Read-back:
MISSION_REQUEST_LIST, MISSION_COUNT back, one MISSION_REQUEST_INT per item, our MISSION_ACK; every vertex must
come back as sent. Parameters: PARAM_SET, answered by PARAM_VALUE (ArduPilot ``FENCE_ALT_MAX``, ``FENCE_TYPE``,
``FENCE_ENABLE``; PX4 ``GF_MAX_VER_DIST``).

Frames: the site is in the world frame (ENU); the autopilot's local frame is the world shifted to its origin
(:class:`~masonry.adapters.mavlink.FrameTransform`, the UAV's blueprint home by default: ``adapters.wiring``), and
its local origin is its EKF origin, whose latitude and longitude it gives in GPS_GLOBAL_ORIGIN. A vertex goes
world -> local NED (the transform) -> latitude/longitude (flat earth about the origin: 2 mm of error at 1 km).
"""

from __future__ import annotations

import math
import queue
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from masonry.errors import CommandRejected, CommandTimeout
from masonry.geofence import Site

MAV_MISSION_TYPE_FENCE = 1
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
MAV_CMD_REQUEST_MESSAGE = 512
MSG_GPS_GLOBAL_ORIGIN = 49
MAV_FRAME_GLOBAL = 0
MAV_PARAM_TYPE_REAL32 = 9
MAV_MISSION_ACCEPTED = 0
MAV_MISSION_UNSUPPORTED = 3
MAV_MISSION_RESULTS = {
    0: "ACCEPTED",
    1: "ERROR",
    2: "UNSUPPORTED_FRAME",
    3: "UNSUPPORTED",
    4: "NO_SPACE",
    5: "INVALID",
    6: "INVALID_PARAM1",
    7: "INVALID_PARAM2",
    8: "INVALID_PARAM3",
    9: "INVALID_PARAM4",
    10: "INVALID_PARAM5_X",
    11: "INVALID_PARAM6_Y",
    12: "INVALID_PARAM7",
    13: "INVALID_SEQUENCE",
    14: "DENIED",
    15: "OPERATION_CANCELLED",
}
#: WGS-84 equatorial radius: the flat-earth conversion about the EKF origin.
EARTH_RADIUS_M = 6378137.0
#: ArduPilot stores at most this many polygon vertices (``param1`` is a byte).
MAX_VERTICES = 255
#: ArduPilot's FENCE_TYPE bits: maximum altitude (1) and polygon (4).
ARDUPILOT_FENCE_TYPE = 1 | 4
#: The longest wait (s of wall) for a message before the time-out is looked at again on the injected clock.
POLL_S = 0.1
_MISSION_KINDS = (
    "MISSION_REQUEST_INT",
    "MISSION_REQUEST",
    "MISSION_ACK",
    "MISSION_COUNT",
    "MISSION_ITEM_INT",
)


@dataclass(frozen=True)
class GeoOrigin:
    """The autopilot's EKF origin (its local frame's origin) on the earth, degrees."""

    lat_deg: float
    lon_deg: float


def ned_to_global(north_m: float, east_m: float, origin: GeoOrigin) -> tuple[float, float]:
    """A local NED point's latitude and longitude (degrees), flat earth about ``origin``."""
    lat = origin.lat_deg + math.degrees(north_m / EARTH_RADIUS_M)
    lon = origin.lon_deg + math.degrees(east_m / (EARTH_RADIUS_M * math.cos(math.radians(origin.lat_deg))))
    return lat, lon


def global_to_ned(lat_deg: float, lon_deg: float, origin: GeoOrigin) -> tuple[float, float]:
    """The local north and east (metres) of a latitude and longitude, flat earth about ``origin``."""
    north = math.radians(lat_deg - origin.lat_deg) * EARTH_RADIUS_M
    east = math.radians(lon_deg - origin.lon_deg) * EARTH_RADIUS_M * math.cos(math.radians(origin.lat_deg))
    return north, east


def fence_vertices_e7(site: Site, frame: Any, origin: GeoOrigin) -> list[tuple[int, int]]:
    """The site's vertices as MISSION_ITEM_INT ``x``, ``y`` (latitude and longitude, degrees x 1e7)."""
    out = []
    for x, y in site.boundary_m:
        north, east, _ = frame.position_to_ned((x, y, 0.0))
        lat, lon = ned_to_global(north, east, origin)
        out.append((round(lat * 1e7), round(lon * 1e7)))
    return out


def fence_parameters(site: Site, frame: Any, autopilot: str | None) -> dict[str, float]:
    """The autopilot's parameters for the altitude limit (metres above its local origin, which is home)."""
    above_home_m = site.max_altitude_m - float(frame.offset_m[2])
    if autopilot == "px4":
        return {"GF_MAX_VER_DIST": above_home_m}
    return {"FENCE_ALT_MAX": above_home_m, "FENCE_TYPE": float(ARDUPILOT_FENCE_TYPE), "FENCE_ENABLE": 1.0}


@dataclass(frozen=True)
class FenceUpload:
    """What the upload did: ``accepted`` (sent, acknowledged, read back), or not ``supported`` (the autopilot said
    MAV_MISSION_UNSUPPORTED: masonry's own fence still holds, the autopilot's does not)."""

    supported: bool
    vertices: int
    max_altitude_m: float
    origin: GeoOrigin | None
    detail: str


def upload_fence(
    fc: Any,
    site: Site,
    *,
    timeout_s: float = 1.5,
    retries: int = 2,
    monotonic: Callable[[], float] = time.monotonic,
) -> FenceUpload:
    """Upload ``site`` as the autopilot's fence and check it was accepted (MISSION_ACK, a read-back, the
    parameters echoed); ``fc`` is a connected :class:`~masonry.adapters.mavlink.MavlinkFlightController`.

    ``monotonic`` is the clock (s) each step's ``timeout_s`` is measured on: the link's, as its commands' time-outs
    (``MavlinkFlightController.upload_fence`` passes it; a test injects one it moves); the waits themselves are
    polls of at most :data:`POLL_S` of wall time.

    Raises:
        CommandRejected: the autopilot refused it (the MISSION_ACK result), gave back other vertices, kept
            other parameter values, has no EKF origin, or the site has more vertices than it stores.
        CommandTimeout: the autopilot did not answer a step of the protocol after ``retries`` resends.
    """
    n = len(site.boundary_m)
    if n > MAX_VERTICES:
        raise CommandRejected(
            "fence", f"the site has {n} vertices; the autopilot stores at most {MAX_VERTICES}"
        )
    run = _Protocol(fc, timeout_s, retries, monotonic)
    origin = run.origin()
    items = fence_vertices_e7(site, fc.frame, origin)
    result = run.upload(items)
    if result == MAV_MISSION_UNSUPPORTED:
        return FenceUpload(
            False, n, site.max_altitude_m, origin, "the autopilot has no fence (MAV_MISSION_UNSUPPORTED)"
        )
    if result != MAV_MISSION_ACCEPTED:
        raise CommandRejected(
            "fence", f"upload refused: MISSION_ACK {MAV_MISSION_RESULTS.get(result, result)}"
        )
    back = run.download()
    if back != items:
        raise CommandRejected("fence", f"read-back differs: sent {len(items)} vertices, got {len(back)} back "
                              f"({'other coordinates' if len(back) == len(items) else 'another count'})")  # fmt: skip
    params = fence_parameters(site, fc.frame, fc.autopilot)
    for name, value in params.items():
        run.set_param(name, value)
    alt = params.get("FENCE_ALT_MAX", params.get("GF_MAX_VER_DIST", math.nan))
    return FenceUpload(
        True,
        n,
        site.max_altitude_m,
        origin,
        f"{n} vertices accepted and read back, altitude limit {alt:.1f} m above home "
        f"(EKF origin {origin.lat_deg:.7f}, {origin.lon_deg:.7f})",
    )


class _Protocol:
    """One run of the mission protocol (fence type) and the parameter protocol over ``fc``'s link."""

    def __init__(self, fc: Any, timeout_s: float, retries: int, monotonic: Callable[[], float]) -> None:
        self.fc = fc
        self.timeout_s = timeout_s
        self.retries = retries
        self._monotonic = monotonic
        self.ts, self.tc = fc.target_system, fc.target_component

    def _send(self, build: Callable[[Any], None]) -> None:
        self.fc.send_message(build)

    def _await(self, q: queue.Queue[Any], accept: Callable[[Any], bool], what: str) -> Any:
        """The next message ``accept`` takes, within the timeout on the injected clock (None: none)."""
        deadline = self._monotonic() + self.timeout_s
        while (left := deadline - self._monotonic()) > 0.0:
            try:
                msg = q.get(timeout=min(left, POLL_S))
            except queue.Empty:
                continue
            if accept(msg):
                return msg
        return None

    def _exchange(self, kinds: Sequence[str], send: Callable[[Any], None], accept: Callable[[Any], bool], what: str) -> Any:  # fmt: skip
        q = self.fc.listen(kinds)
        try:
            for _ in range(self.retries + 1):
                self._send(send)
                msg = self._await(q, accept, what)
                if msg is not None:
                    return msg
        finally:
            self.fc.unlisten(q)
        raise CommandTimeout(
            f"fence: no {what} from the autopilot after {self.retries + 1} tries of {self.timeout_s:.1f} s"
        )

    def origin(self) -> GeoOrigin:
        """The EKF origin (GPS_GLOBAL_ORIGIN, asked for with MAV_CMD_REQUEST_MESSAGE)."""
        try:
            msg = self._exchange(
                ("GPS_GLOBAL_ORIGIN",),
                lambda mav: mav.command_long_send(
                    self.ts, self.tc, MAV_CMD_REQUEST_MESSAGE, 0, MSG_GPS_GLOBAL_ORIGIN, 0, 0, 0, 0, 0, 0
                ),
                lambda m: True,
                "GPS_GLOBAL_ORIGIN",
            )
        except CommandTimeout:
            raise CommandRejected(
                "fence", "the autopilot has no EKF origin (no GPS_GLOBAL_ORIGIN): the fence's latitudes and "
                "longitudes cannot be known (set the origin, or a GPS fix, first)"
            ) from None  # fmt: skip
        return GeoOrigin(msg.latitude / 1e7, msg.longitude / 1e7)

    def upload(self, items: list[tuple[int, int]]) -> int:
        """Send the vertices; the autopilot's MISSION_ACK result."""
        n = len(items)
        q = self.fc.listen(_MISSION_KINDS)
        try:
            answered = False
            for _ in range(self.retries + 1):
                self._send(lambda mav: mav.mission_count_send(self.ts, self.tc, n, MAV_MISSION_TYPE_FENCE))
                while True:
                    msg = self._await(q, _fence_typed, "MISSION_REQUEST_INT")
                    if msg is None:
                        break
                    answered = True
                    if msg.get_type() == "MISSION_ACK":
                        return int(msg.type)
                    if msg.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST") and 0 <= msg.seq < n:
                        self._send_item(msg.seq, n, items[msg.seq])
                if answered:
                    break
        finally:
            self.fc.unlisten(q)
        raise CommandTimeout(
            f"fence: the autopilot {'stopped answering during' if answered else 'did not answer'} the upload "
            f"(MISSION_COUNT of {n} vertices, {self.retries + 1} tries of {self.timeout_s:.1f} s)"
        )

    def _send_item(self, seq: int, n: int, item: tuple[int, int]) -> None:
        self._send(
            lambda mav: mav.mission_item_int_send(
                self.ts, self.tc, seq, MAV_FRAME_GLOBAL, MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                0, 1, float(n), 0.0, 0.0, 0.0, item[0], item[1], 0.0, MAV_MISSION_TYPE_FENCE,
            )
        )  # fmt: skip

    def download(self) -> list[tuple[int, int]]:
        """Read the autopilot's fence back: its inclusion-polygon vertices, in order."""
        count = self._exchange(
            ("MISSION_COUNT",),
            lambda mav: mav.mission_request_list_send(self.ts, self.tc, MAV_MISSION_TYPE_FENCE),
            _fence_typed,
            "MISSION_COUNT (read-back)",
        )
        out: list[tuple[int, int]] = []
        for seq in range(int(count.count)):
            item = self._exchange(
                ("MISSION_ITEM_INT",),
                self._request_item(seq),
                _item_of(seq),
                f"MISSION_ITEM_INT {seq} (read-back)",
            )
            if int(item.command) == MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION:
                out.append((int(item.x), int(item.y)))
        self._send(
            lambda mav: mav.mission_ack_send(self.ts, self.tc, MAV_MISSION_ACCEPTED, MAV_MISSION_TYPE_FENCE)
        )
        return out

    def _request_item(self, seq: int) -> Callable[[Any], None]:
        return lambda mav: mav.mission_request_int_send(self.ts, self.tc, seq, MAV_MISSION_TYPE_FENCE)

    def set_param(self, name: str, value: float) -> None:
        """PARAM_SET, checked on the PARAM_VALUE echo."""
        msg = self._exchange(
            ("PARAM_VALUE",),
            lambda mav: mav.param_set_send(
                self.ts, self.tc, name.encode("ascii"), value, MAV_PARAM_TYPE_REAL32
            ),
            lambda m: _param_name(m) == name,
            f"PARAM_VALUE {name}",
        )
        if not math.isclose(float(msg.param_value), value, rel_tol=1e-5, abs_tol=1e-3):
            raise CommandRejected(
                "fence", f"{name} is {float(msg.param_value):g}, not {value:g}, after PARAM_SET"
            )


def _item_of(seq: int) -> Callable[[Any], bool]:
    return lambda m: _fence_typed(m) and int(m.seq) == seq


def _fence_typed(msg: Any) -> bool:
    return int(getattr(msg, "mission_type", 0)) == MAV_MISSION_TYPE_FENCE


def _param_name(msg: Any) -> str:
    raw = msg.param_id
    text = raw.decode("ascii", errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.rstrip("\x00")


__all__ = [
    "EARTH_RADIUS_M",
    "FenceUpload",
    "GeoOrigin",
    "fence_parameters",
    "fence_vertices_e7",
    "global_to_ned",
    "ned_to_global",
    "upload_fence",
]
