"""The fence side of the project's SITL (:class:`~masonry.adapters.sitl.MavlinkSitl`): what ArduCopter does with a
fence a ground station uploads.

- The MAVLink mission protocol for ``mission_type`` MAV_MISSION_TYPE_FENCE, both ways: MISSION_COUNT ->
  MISSION_REQUEST_INT per item -> MISSION_ACK (upload), MISSION_REQUEST_LIST -> MISSION_COUNT -> MISSION_ITEM_INT per
  MISSION_REQUEST_INT (read-back). Only MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION items in a global frame are kept
  (anything else: MAV_MISSION_UNSUPPORTED / UNSUPPORTED_FRAME, as ArduPilot).
- PARAM_SET answered by PARAM_VALUE (FENCE_ENABLE, FENCE_TYPE, FENCE_ALT_MAX, and any other name).
- GPS_GLOBAL_ORIGIN on MAV_CMD_REQUEST_MESSAGE: the EKF origin (its local frame's origin), ArduPilot SITL's
  default home at CMAC unless told otherwise.
- The fence itself: with FENCE_ENABLE, a vehicle in the air outside the polygon or above FENCE_ALT_MAX is
  landed where it is ("Fence Breach", ArduCopter's FENCE_ACTION 2).
- ``mode`` for tests: ``"accept"``; ``"unsupported"`` (no fence: MAV_MISSION_UNSUPPORTED); ``"deny"`` (the upload
  answered MAV_MISSION_DENIED); ``"corrupt"`` (accepted, but read back with the first vertex moved).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from masonry.adapters.mavlink_fence import (
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_UNSUPPORTED,
    MAV_PARAM_TYPE_REAL32,
    MSG_GPS_GLOBAL_ORIGIN,
    GeoOrigin,
    global_to_ned,
)
from masonry.geofence import Site

#: ArduPilot SITL's default home (Canberra Model Aircraft Club), its EKF origin on GPS.
CMAC = GeoOrigin(-35.363262, 149.165237)
MAV_MISSION_UNSUPPORTED_FRAME = 2
MAV_MISSION_DENIED = 14
_GLOBAL_FRAMES = (0, 3, 5, 6, 10, 11)  # GLOBAL, GLOBAL_RELATIVE_ALT, their _INT forms, TERRAIN_ALT(_INT)
_FENCE_MODES = ("accept", "unsupported", "deny", "corrupt")


@dataclass
class SitlFence:
    """The SITL's stored fence, its upload in progress and its parameters."""

    mode: str = "accept"
    origin: GeoOrigin = CMAC
    vertices_e7: list[tuple[int, int]] = field(default_factory=list)
    params: dict[str, float] = field(default_factory=dict)
    uploads: int = 0  # accepted uploads
    breaches: int = 0
    _receiving: list[tuple[int, int] | None] | None = None
    _cached: tuple[Any, Site | None] | None = None

    def __post_init__(self) -> None:
        if self.mode not in _FENCE_MODES:
            raise ValueError(f"fence mode must be one of {', '.join(_FENCE_MODES)}, not {self.mode!r}")

    def handle(self, sitl: Any, msg: Any) -> bool:
        """Answer ``msg`` if it is the fence's (True), else leave it to the SITL (False)."""
        kind = msg.get_type()
        if kind == "COMMAND_LONG":
            if int(msg.command) != MAV_CMD_REQUEST_MESSAGE or int(msg.param1) != MSG_GPS_GLOBAL_ORIGIN:
                return False
            sitl._ack(MAV_CMD_REQUEST_MESSAGE, 0)
            sitl._conn.mav.gps_global_origin_send(
                round(self.origin.lat_deg * 1e7), round(self.origin.lon_deg * 1e7), 0
            )
            return True
        if kind == "PARAM_SET":
            name = _text(msg.param_id)
            self.params[name] = float(msg.param_value)
            sitl._conn.mav.param_value_send(
                name.encode("ascii"), float(msg.param_value), MAV_PARAM_TYPE_REAL32, len(self.params), 0
            )
            return True
        if kind not in ("MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT"):
            return kind == "MISSION_ACK" and int(getattr(msg, "mission_type", 0)) == MAV_MISSION_TYPE_FENCE
        if int(getattr(msg, "mission_type", 0)) != MAV_MISSION_TYPE_FENCE:
            return False
        gcs = (msg.get_srcSystem(), msg.get_srcComponent())
        getattr(self, "_" + kind.lower())(sitl._conn.mav, gcs, msg)
        return True

    def _mission_count(self, mav: Any, gcs: tuple[int, int], msg: Any) -> None:
        if self.mode == "unsupported":
            mav.mission_ack_send(*gcs, MAV_MISSION_UNSUPPORTED, MAV_MISSION_TYPE_FENCE)
            return
        self._receiving = [None] * int(msg.count)
        if not self._receiving:
            self._complete(mav, gcs)
            return
        mav.mission_request_int_send(*gcs, 0, MAV_MISSION_TYPE_FENCE)

    def _mission_item_int(self, mav: Any, gcs: tuple[int, int], msg: Any) -> None:
        items = self._receiving
        seq = int(msg.seq)
        if items is None or not 0 <= seq < len(items):
            return  # not uploading, or an item out of range: ignored (the ground station asks again)
        if int(msg.command) != MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION:
            self._receiving = None
            mav.mission_ack_send(*gcs, MAV_MISSION_UNSUPPORTED, MAV_MISSION_TYPE_FENCE)
            return
        if int(msg.frame) not in _GLOBAL_FRAMES:
            self._receiving = None
            mav.mission_ack_send(*gcs, MAV_MISSION_UNSUPPORTED_FRAME, MAV_MISSION_TYPE_FENCE)
            return
        items[seq] = (int(msg.x), int(msg.y))
        missing = next((i for i, item in enumerate(items) if item is None), None)
        if missing is not None:
            mav.mission_request_int_send(*gcs, missing, MAV_MISSION_TYPE_FENCE)
            return
        self._complete(mav, gcs)

    def _complete(self, mav: Any, gcs: tuple[int, int]) -> None:
        items, self._receiving = self._receiving or [], None
        if self.mode == "deny":
            mav.mission_ack_send(*gcs, MAV_MISSION_DENIED, MAV_MISSION_TYPE_FENCE)
            return
        self.vertices_e7 = [item for item in items if item is not None]
        self.uploads += 1
        mav.mission_ack_send(*gcs, MAV_MISSION_ACCEPTED, MAV_MISSION_TYPE_FENCE)

    def _mission_request_list(self, mav: Any, gcs: tuple[int, int], msg: Any) -> None:
        mav.mission_count_send(*gcs, len(self.vertices_e7), MAV_MISSION_TYPE_FENCE)

    def _mission_request_int(self, mav: Any, gcs: tuple[int, int], msg: Any) -> None:
        seq = int(msg.seq)
        if not 0 <= seq < len(self.vertices_e7):
            return
        x, y = self.vertices_e7[seq]
        if self.mode == "corrupt" and seq == 0:
            x += 10_000  # about 0.1 m north
        mav.mission_item_int_send(
            *gcs, seq, 0, MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 0, 1,
            float(len(self.vertices_e7)), 0.0, 0.0, 0.0, x, y, 0.0, MAV_MISSION_TYPE_FENCE,
        )  # fmt: skip

    def site(self, frame: Any) -> Site | None:
        """The stored fence in the world frame (through the SITL's frame), None without one."""
        key = (tuple(self.vertices_e7), self.params.get("FENCE_ALT_MAX"), frame)
        if self._cached is not None and self._cached[0] == key:
            return self._cached[1]
        self._cached = (key, self._site(frame))
        return self._cached[1]

    def _site(self, frame: Any) -> Site | None:
        if len(self.vertices_e7) < 3:
            return None
        pts = []
        for x, y in self.vertices_e7:
            north, east = global_to_ned(x / 1e7, y / 1e7, self.origin)
            wx, wy, _ = frame.position_to_world((north, east, 0.0))
            pts.append((wx, wy))
        alt = self.params.get("FENCE_ALT_MAX", 100.0) + float(frame.offset_m[2])
        return Site(tuple(pts), alt)

    def breached(self, frame: Any, position_m: tuple[float, float, float]) -> bool:
        """FENCE_ENABLE is on and ``position_m`` (world) is outside the polygon or above the altitude limit."""
        if self.params.get("FENCE_ENABLE", 0.0) < 0.5:
            return False
        site = self.site(frame)
        return site is not None and site.outside_by_m(position_m) > 0.0

    def enforce(self, sitl: Any) -> None:
        """One physics step of the fence: a breach in the air lands the vehicle where it is (once)."""
        v = sitl.vehicle
        if not v.armed or v.on_ground or sitl.mode == sitl._land_mode:
            return
        if self.breached(sitl.frame, v.position_m):
            self.breaches += 1
            sitl._text(2, "Fence Breach")  # MAV_SEVERITY_CRITICAL
            sitl._set_mode(sitl._land_mode)


def _text(raw: Any) -> str:
    text = raw.decode("ascii", errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.rstrip("\x00")


__all__ = ["CMAC", "SitlFence"]
