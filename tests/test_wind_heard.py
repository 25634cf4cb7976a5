"""The wind limit in a distributed mission (issue 18): each UAV's heartbeat carries its autopilot's wind reading
(MAVLink WIND) and its uav.yaml's ``max_wind_mps``; mission control grounds the UAVs it is above."""

from __future__ import annotations

import pytest

from masonry.adapters.wiring import hardware_config
from masonry.blueprint_gen import running_bond
from masonry.errors import InputError, ProtocolError
from masonry.mission.control import MissionControl
from masonry.mission.events import EventList, MissionEvent
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL, Heartbeat, decode, encode
from masonry.mission.wind_limit import HEARD_WIND_FRESH_S, HeardWind
from masonry.planner import plan
from test_mavlink import _Conn, _link_on, _Msg


def test_heartbeats_carry_the_wind_and_the_limit_and_refuse_nonsense() -> None:
    hb = Heartbeat("brick-1", 3.0, state="idle", wind_mps=6.5, max_wind_mps=8.0)
    back = decode(encode(hb), ["brick-1"])
    assert back == hb
    plain = Heartbeat("brick-1", 3.0, state="idle")
    assert decode(encode(plain), ["brick-1"]) == plain
    for field, value, words in (
        ("wind_mps", -1.0, "wind_mps"),
        ("wind_mps", 1e9, "wind_mps"),
        ("max_wind_mps", 0.0, "max_wind_mps"),
        ("max_wind_mps", 45.0, "max_wind_mps"),
    ):
        raw = encode(Heartbeat("brick-1", 3.0, state="idle", **{field: value}))
        with pytest.raises(ProtocolError, match=words):
            decode(raw, ["brick-1"])


def test_the_reading_is_the_strongest_fresh_report() -> None:
    heard = HeardWind()
    heard.heard("a", 0.0, 3.0, 8.0)
    heard.heard("b", 1.0, 9.0, 10.0)
    assert heard.reading(2.0) == 9.0 and heard.limits_mps == {"a": 8.0, "b": 10.0}
    assert heard.reading(1.0 + HEARD_WIND_FRESH_S + 0.1) is None
    limit = heard.limit()
    assert limit.update(2.0) and limit.grounded == {"a"}  # 9 m/s: above a's 8, within b's 10


def _mission(wind: dict[str, float]):
    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=1)
    bus = InprocBus()
    mc = MissionControl(
        plan(bp), bp.fleet, bus.endpoint(MISSION_CONTROL), startup_timeout_s=100.0, events_sink=EventList()
    )
    handlers = {
        u.name: UavHandler(
            u.name,
            bus.endpoint(u.name),
            position=lambda u=u: (u.home_m[0], u.home_m[1], 0.0),
            wind=lambda n=u.name: wind[n],
            max_wind_mps=8.0,
        )
        for u in bp.fleet
    }
    return bp, mc, handlers


def test_mission_control_gives_no_task_above_a_uavs_reported_limit_and_resumes_below_it() -> None:
    wind = {"brick-1": 12.0, "glue-1": 12.0}
    _bp, mc, handlers = _mission(wind)
    t = 0.0
    for _ in range(30):  # 3 s: both heard, the mission started, the wind read
        for h in handlers.values():
            h.step(t)
        mc.step(t)
        t += 0.1
    assert mc.wind_limit.grounded == {"brick-1", "glue-1"}
    assert all(h.poll_task() is None for h in handlers.values())
    assert mc.dispatcher.in_progress == {}
    wind.update({"brick-1": 5.0, "glue-1": 5.0})  # below 8 - 0.5: dispatch goes on
    for _ in range(30):
        for h in handlers.values():
            h.step(t)
        mc.step(t)
        t += 0.1
    assert mc.wind_limit.grounded == set()
    assert mc.dispatcher.in_progress, "no task was assigned once the wind had dropped"
    # the log says both, as events (an MCAP log's /log topic shows their lines)
    winds = [e for e in mc.sink.events if e.kind == "wind"]
    assert [(e.fields["speed_mps"], e.fields["grounded"]) for e in winds] == [
        (12.0, ["brick-1", "glue-1"]),
        (5.0, []),
    ]
    assert winds[0].line().endswith("wind 12.0 m/s: no tasks for brick-1, glue-1")
    assert MissionEvent.from_dict(winds[1].to_dict()) == winds[1]


def test_the_autopilots_wind_message_is_read_and_goes_stale() -> None:
    fc = _link_on(_Conn([]))
    assert fc.wind_speed_mps is None
    fc._receive(_Msg("WIND", direction=270.0, speed=6.5, speed_z=0.0), fc._monotonic())
    assert fc.wind_speed_mps == pytest.approx(6.5)
    fc._state.wind_time_s -= fc.WIND_FRESH_S + 1.0  # heard long ago
    assert fc.wind_speed_mps is None


def test_max_wind_mps_in_uav_yaml_is_checked() -> None:
    assert hardware_config({"fc": "sim"}, {"max_wind_mps": 10.0}).max_wind_mps == 10.0
    assert hardware_config({"fc": "sim"}).max_wind_mps == 8.0
    with pytest.raises(InputError, match="max_wind_mps must be > 0 and at most 30 m/s"):
        hardware_config({"fc": "sim"}, {"max_wind_mps": 50.0})


def test_the_project_sitl_reports_its_wind_and_the_adapter_reads_it() -> None:
    """ArduPilot's WIND stream end to end on loopback: a vehicle hovering in a steady 6 m/s wind (from the
    west), its autopilot's estimate sent at 1 Hz, read by the MAVLink adapter."""
    import math
    from dataclasses import replace

    import numpy as np

    from masonry.adapters.mavlink import MavlinkFlightController
    from masonry.adapters.sitl import MavlinkSitl, SitlConfig, free_udp_port
    from masonry.sim.vehicle import SimVehicle
    from masonry.sim.vehicle_config import vehicle_preset
    from masonry.sim.wind import WindConfig, WindField
    from test_sitl import take_off
    from waiting import wait_until

    config = SitlConfig()
    vehicle = SimVehicle(
        replace(
            vehicle_preset("ideal"), setpoint_timeout_s=config.guided_timeout_s, link_failsafe_s=math.inf
        ),
        rng=np.random.default_rng(0),
        wind=WindField(WindConfig(speed_mps=6.0, direction_deg=270.0), np.random.default_rng(1)),
    )
    port = free_udp_port()
    sitl = MavlinkSitl(port, vehicle=vehicle, time_scale=4.0, config=replace(config, heartbeat_hz=4.0))
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=3.0)
    sitl.start()
    try:
        fc.connect()
        take_off(fc)
        wait_until(lambda: (fc.wind_speed_mps or 0.0) > 3.0, 10.0, "a WIND reading of the 6 m/s wind")
        assert (fc.wind_speed_mps or 0.0) < 6.5  # at 1.2 m the power-law profile slows the 10 m wind
    finally:
        fc.close()
        sitl.stop()
