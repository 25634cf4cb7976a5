"""The site's fence uploaded to the autopilot over the MAVLink mission protocol (fence type), checked against the
project's SITL on loopback: accepted and read back in the right frame, refused, unsupported, read back wrong, and
held by the autopilot itself."""

from __future__ import annotations

import math
import queue
from types import SimpleNamespace
from typing import Any

import pytest

from masonry.adapters.mavlink import FrameTransform
from masonry.adapters.mavlink_fence import (
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_TYPE_FENCE,
    POLL_S,
    GeoOrigin,
    fence_vertices_e7,
    global_to_ned,
    ned_to_global,
    upload_fence,
)
from masonry.adapters.sitl import SitlConfig
from masonry.adapters.sitl_fence import CMAC
from masonry.errors import CommandRejected, CommandTimeout
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


def _msg(kind: str, **fields: Any) -> SimpleNamespace:
    return SimpleNamespace(get_type=lambda: kind, mission_type=MAV_MISSION_TYPE_FENCE, **fields)


class _ScriptedAutopilot:
    """An autopilot on the link's clock (``now``, s): it answers the fence's protocol ``delay_s`` after each
    request, and sends a PARAM_VALUE of another parameter every 0.2 s (ArduPilot's parameter stream); it echoes
    no PARAM_SET when ``mute_params``. A listener's ``get`` moves the clock to the next message, or by its
    ``timeout`` when none comes within it: nothing waits on the wall."""

    def __init__(self, delay_s: float, *, mute_params: bool = False) -> None:
        self.now, self.delay_s, self.mute_params = 0.0, delay_s, mute_params
        self.target_system, self.target_component = 1, 1
        self.frame, self.autopilot = FrameTransform(HOME), "ardupilot"
        self.outbox: list[tuple[float, SimpleNamespace]] = []
        self.sent: list[tuple[float, str]] = []
        self.vertices: list[tuple[int, int]] = []
        self.polls: list[float] = []

    def listen(self, kinds: Any) -> Any:
        outer = self

        class Listener:
            def get(self, timeout: float) -> SimpleNamespace:
                outer.polls.append(timeout)
                chatter = (math.floor(outer.now / 0.2) + 1) * 0.2
                due = [(t, m) for t, m in outer.outbox if m.get_type() in kinds]
                t, msg = min(due, key=lambda d: d[0], default=(math.inf, None))
                if "PARAM_VALUE" in kinds and chatter < t:
                    t, msg = chatter, _msg("PARAM_VALUE", param_id=b"SIM_SPEEDUP", param_value=5.0)
                if t > outer.now + timeout:
                    outer.now += timeout
                    raise queue.Empty
                outer.now = max(outer.now, t)
                outer.outbox = [(u, m) for u, m in outer.outbox if m is not msg]
                return msg

        return Listener()

    def unlisten(self, q: Any) -> None:
        pass

    def send_message(self, build: Any) -> None:
        build(SimpleNamespace(**{name: self._sender(name) for name in _SENDS}))

    def _sender(self, name: str) -> Any:
        def send(*args: Any) -> None:
            self.sent.append((self.now, name))
            answer = self._answer(name, args)
            if answer is not None:
                self.outbox.append((self.now + self.delay_s, answer))

        return send

    def _answer(self, name: str, args: tuple[Any, ...]) -> SimpleNamespace | None:
        if name == "command_long_send":
            return _msg(
                "GPS_GLOBAL_ORIGIN", latitude=round(CMAC.lat_deg * 1e7), longitude=round(CMAC.lon_deg * 1e7)
            )
        if name == "mission_count_send":
            self.vertices = [(0, 0)] * args[2]
            return _msg("MISSION_REQUEST_INT", seq=0)
        if name == "mission_item_int_send":
            seq = args[2]
            self.vertices[seq] = (args[11], args[12])
            if seq + 1 < len(self.vertices):
                return _msg("MISSION_REQUEST_INT", seq=seq + 1)
            return _msg("MISSION_ACK", type=MAV_MISSION_ACCEPTED)
        if name == "mission_request_list_send":
            return _msg("MISSION_COUNT", count=len(self.vertices))
        if name == "mission_request_int_send":
            x, y = self.vertices[args[2]]
            return _msg("MISSION_ITEM_INT", seq=args[2], command=5001, x=x, y=y)
        if name == "param_set_send" and not self.mute_params:
            return _msg("PARAM_VALUE", param_id=args[2], param_value=args[3])
        return None


_SENDS = ("command_long_send", "mission_count_send", "mission_item_int_send", "mission_request_list_send",
          "mission_request_int_send", "mission_ack_send", "param_set_send")  # fmt: skip


def test_the_fence_protocol_times_out_on_the_links_clock() -> None:
    """Issue 29: the fence's waits ran on ``time.monotonic`` while the link's commands run on its injected clock (a
    test could not drive them); each step's time-out is now the link's (``MavlinkFlightController.upload_fence``
    passes it), polled in ``POLL_S`` slices of wall. An autopilot 1 s slow (of 1.5 s) is answered at the first try
    of each of the 14 steps; one that never echoes the PARAM_SET is given up after 3 tries of 1.5 s of the link's
    clock, whatever other parameters it streams meanwhile."""
    slow = _ScriptedAutopilot(1.0)
    up = upload_fence(slow, SITE, timeout_s=1.5, monotonic=lambda: slow.now)
    assert up.supported and up.vertices == 4 and up.origin == CMAC
    kinds = [name for _, name in slow.sent]
    assert kinds.count("command_long_send") == 1 and kinds.count("param_set_send") == 3  # no resend
    assert slow.now == pytest.approx(
        1.0 * 14
    )  # the origin, 4 requests + the ACK, the count + 4 items, 3 echoes
    assert max(slow.polls) <= POLL_S
    mute = _ScriptedAutopilot(0.05, mute_params=True)
    with pytest.raises(
        CommandTimeout, match=r"no PARAM_VALUE FENCE_ALT_MAX from the autopilot after 3 tries of 1\.5 s"
    ):
        upload_fence(mute, SITE, timeout_s=1.5, monotonic=lambda: mute.now)
    param_sets = [t for t, name in mute.sent if name == "param_set_send"]
    assert [t - param_sets[0] for t in param_sets] == pytest.approx([0.0, 1.5, 3.0], abs=POLL_S)


def test_the_flight_controller_uploads_its_fence_on_its_links_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    import masonry.adapters.mavlink_fence as fence
    from masonry.adapters.mavlink import MavlinkFlightController

    def link_clock() -> float:
        return 100.0

    fc = MavlinkFlightController("udpin:127.0.0.1:9", frame=FrameTransform(HOME), monotonic=link_clock)
    fc._conn = object()  # "connected": nothing is sent or read here
    fc._state.last_message_s = fc._state.last_heartbeat_s = 100.0
    given: dict[str, Any] = {}
    monkeypatch.setattr(fence, "upload_fence", lambda fc, site, **kw: given.update(kw) or "uploaded")
    assert fc.upload_fence(SITE) == "uploaded"
    assert given == {"monotonic": link_clock}
