"""The site's fence uploaded to the autopilot over the MAVLink mission protocol (fence type), checked against the
project's SITL on loopback: accepted and read back in the right frame, refused, unsupported, read back wrong, and
held by the autopilot itself."""

from __future__ import annotations

import math

import pytest

from masonry.adapters.mavlink import FrameTransform
from masonry.adapters.mavlink_fence import (
    GeoOrigin,
    fence_vertices_e7,
    global_to_ned,
    ned_to_global,
)
from masonry.adapters.sitl import SitlConfig
from masonry.adapters.sitl_fence import CMAC
from masonry.errors import CommandRejected
from masonry.geofence import Site
from test_sitl import flight, take_off
from waiting import wait_until

#: A site around the UAV's blueprint home at (2, -2.5): the autopilot's local origin (GPS-like).
SITE = Site(((-2.0, -4.0), (4.0, -4.0), (4.0, 2.5), (-2.0, 2.5)), 6.0)
HOME = (2.0, -2.5, 0.0)


def test_flat_earth_round_trip_and_scale() -> None:
    o = GeoOrigin(47.3977, 8.5456)
    lat, lon = ned_to_global(1000.0, -500.0, o)
    assert lat - o.lat_deg == pytest.approx(1000.0 / 111_319.5, rel=1e-4)
    assert global_to_ned(lat, lon, o) == pytest.approx((1000.0, -500.0), abs=1e-6)


def test_vertices_go_world_to_local_to_global() -> None:
    """A vertex 1 m east of the local origin (the home at (2, -2.5) in the world) is 1 m east of the EKF origin."""
    frame = FrameTransform(HOME)
    site = Site(((3.0, -2.5), (2.0, -1.5), (2.0, -2.5)), 5.0)
    (x0, y0), (x1, y1), (x2, y2) = fence_vertices_e7(site, frame, CMAC)
    assert (x2, y2) == (round(CMAC.lat_deg * 1e7), round(CMAC.lon_deg * 1e7))
    assert global_to_ned(x0 / 1e7, y0 / 1e7, CMAC) == pytest.approx((0.0, 1.0), abs=0.01)  # east
    assert global_to_ned(x1 / 1e7, y1 / 1e7, CMAC) == pytest.approx((1.0, 0.0), abs=0.01)  # north


@pytest.mark.parametrize("yaw_rad", [0.0, 0.7, -2.0])
def test_vertices_come_back_to_the_world_through_the_same_frame(yaw_rad: float) -> None:
    """world -> local NED (offset and yaw) -> latitude/longitude -> local NED -> world: the same points (to the
    1e-7 degree rounding of MISSION_ITEM_INT)."""
    frame = FrameTransform((2.0, -2.5, 0.3), yaw_rad)
    origin = GeoOrigin(52.0, -1.3)
    for (x, y), (lat_e7, lon_e7) in zip(SITE.boundary_m, fence_vertices_e7(SITE, frame, origin)):
        north, east = global_to_ned(lat_e7 / 1e7, lon_e7 / 1e7, origin)
        wx, wy, _ = frame.position_to_world((north, east, 0.0))
        assert math.hypot(wx - x, wy - y) < 0.01  # 1e-7 degrees is 1.1 cm of latitude


def test_the_fence_is_uploaded_accepted_read_back_and_held_by_the_autopilot() -> None:
    with flight(home_m=HOME, frame=FrameTransform(HOME)) as (sitl, fc):
        fc.connect()
        fc.wait_for_estimate(timeout_s=2.0)
        up = fc.upload_fence(SITE)
        assert up.supported and up.vertices == 4 and up.origin == CMAC
        assert "4 vertices accepted and read back" in up.detail
        assert sitl.fence.uploads == 1
        assert sitl.fence.params == {"FENCE_ALT_MAX": 6.0, "FENCE_TYPE": 5.0, "FENCE_ENABLE": 1.0}
        held = sitl.fence.site(sitl.frame)  # back in the world frame, through the SITL's own frame
        assert held is not None
        for (x, y), (hx, hy) in zip(SITE.boundary_m, held.boundary_m):
            assert math.hypot(x - hx, y - hy) < 0.02
        assert held.max_altitude_m == pytest.approx(6.0)
        # the autopilot's own fence: flown out through it, the SITL lands the UAV ("Fence Breach")
        take_off(fc, 1.2)
        deadline_s = 6.0
        wait_until(lambda: _push_east(fc) and sitl.fence.breaches > 0, deadline_s, "the fence breach")
        assert "Fence Breach" in sitl.status_log
        wait_until(lambda: fc.telemetry().landing or fc.telemetry().on_ground, 2.0, "LAND")


def _push_east(fc) -> bool:
    fc.send_velocity((1.5, 0.0, 0.0), 0.0)
    return True


@pytest.mark.parametrize(
    "mode,says",
    [
        ("deny", "upload refused: MISSION_ACK DENIED"),
        ("corrupt", "read-back differs: sent 4 vertices, got 4 back (other coordinates)"),
    ],
)
def test_a_refused_or_altered_fence_is_one_line_and_the_preflight_refuses_to_arm(
    mode: str, says: str
) -> None:
    from masonry.adapters.wiring import _check_fence

    with flight(SitlConfig(fence=mode), home_m=HOME, frame=FrameTransform(HOME)) as (_, fc):
        fc.connect()
        with pytest.raises(CommandRejected) as info:
            fc.upload_fence(SITE)
        assert str(info.value) == f"fence rejected: {says}" or says in str(info.value)
        assert "\n" not in str(info.value)
        item = _check_fence(fc, SITE)
        assert not item.ok and item.blocking and says in item.detail


def test_an_autopilot_without_a_fence_is_a_warning_not_a_refusal() -> None:
    from masonry.adapters.wiring import _check_fence

    with flight(SitlConfig(fence="unsupported"), home_m=HOME, frame=FrameTransform(HOME)) as (sitl, fc):
        fc.connect()
        up = fc.upload_fence(SITE)
        assert not up.supported and "MAV_MISSION_UNSUPPORTED" in up.detail
        item = _check_fence(fc, SITE)
        assert not item.ok and not item.blocking
        assert sitl.fence.uploads == 0 and sitl.fence.params == {}


def test_a_site_with_more_vertices_than_the_autopilot_stores_is_refused_before_sending() -> None:
    ring = tuple((20 * math.cos(k * math.tau / 300), 20 * math.sin(k * math.tau / 300)) for k in range(300))
    with flight(home_m=HOME, frame=FrameTransform(HOME)) as (sitl, fc):
        fc.connect()
        with pytest.raises(CommandRejected, match="300 vertices; the autopilot stores at most 255"):
            fc.upload_fence(Site(ring, 6.0))
        assert sitl.fence.uploads == 0


@pytest.mark.slow
def test_the_fence_on_arducopter_sitl(tmp_path) -> None:
    """ArduCopter itself takes the fence: accepted, read back vertex for vertex ("Fence Indexed OK"), FENCE_*
    set; about 10 s of wall time (its EKF must have its GPS origin first)."""
    from ardupilot_sitl import arducopter, sitl_binary
    from masonry.adapters.mavlink import MavlinkFlightController

    sitl_binary()  # skips, with the reason, when the binary is not configured
    with arducopter(tmp_path / "sitl", instance=44, sysid=45) as url:
        fc = MavlinkFlightController(url, frame=FrameTransform(HOME), connect_timeout_s=30.0)
        try:
            fc.connect()
            fc.wait_for_estimate(90.0)
            up = fc.upload_fence(SITE)
            assert up.supported and up.vertices == 4, up
            # its EKF origin is where it started (the --home of tests/ardupilot_sitl.py)
            assert up.origin is not None and up.origin.lat_deg == pytest.approx(-35.363261, abs=1e-6)
            wait_until(lambda: "Fence Indexed OK" in fc.status_texts(), 5.0, "ArduCopter indexing the fence")
        finally:
            fc.close()
