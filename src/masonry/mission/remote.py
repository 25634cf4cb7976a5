"""A simulated UAV as a mission participant in its own process: ``masonry fly --sim --mission tcp/HOST:7447``.

The UAV's simulated world runs in wall time, ``time_scale`` simulated seconds per wall second, so that a
handler process keeps pace with a mission control on another process or computer. Its state machine is
driven by a :class:`~masonry.mission.handler.UavHandler` on a :class:`~masonry.mission.zenoh_transport.ZenohTransport`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from masonry.blueprint import Blueprint, UavSpec
from masonry.errors import InputError, LinkLost
from masonry.mission.handler import UavHandler


@dataclass(frozen=True)
class RemoteRun:
    """What a handler process did: its executions, whether the mission ended, its last state."""

    executions: tuple[Any, ...]
    mission_ended: bool
    mission_completed: bool | None
    state: str
    sim_time_s: float


def run_remote_uav(
    blueprint: Blueprint,
    spec: UavSpec,
    *,
    connect: Sequence[str],
    listen: Sequence[str] = ("tcp/127.0.0.1:0",),
    mission_name: str = "default",
    seed: int = 0,
    camera: str = "geometric",
    faults: Any = None,
    dt_s: float = 0.05,
    time_scale: float = 1.0,
    wait_s: float = 60.0,
    max_time_s: float = 3600.0,
    heartbeat_period_s: float = 1.0,
    heartbeat_timeout_s: float = 5.0,
    turnaround_s: float = 0.2,
    echo: Any = None,
) -> RemoteRun:
    """Fly one simulated UAV for a remote mission control until it ends the mission and the UAV has landed.

    Args:
        blueprint: the wall (the simulated world lays out its bricks).
        spec: this UAV (its name is its endpoint).
        connect: mission control's Zenoh endpoint(s), e.g. ``["tcp/10.0.0.1:7447"]``.
        listen: this process's own listen endpoint(s) (loopback by default).
        mission_name: Zenoh key prefix shared with mission control.
        time_scale: simulated seconds per wall second (1.0: real time).
        wait_s: wall seconds to wait for mission control's first message before giving up.
        max_time_s: simulated seconds after which the UAV stops regardless.
        heartbeat_period_s, heartbeat_timeout_s: in simulated (mission) seconds.
        turnaround_s: wall seconds to wait, after reporting a result, for mission control's next assignment.
        echo: called with one line per state change (the process's log), or None.

    Raises:
        InputError: a bad ``time_scale`` or ``dt_s``.
        LinkLost: mission control was never heard within ``wait_s``.
    """
    from masonry.fsm import UavConfig, build_uav
    from masonry.mission.zenoh_transport import ZenohTransport
    from masonry.sim import Faults, World

    if not (time_scale > 0 and dt_s > 0):
        raise InputError(f"--time-scale and --dt must be > 0, got {time_scale} and {dt_s}")
    world = World(blueprint, seed=seed, camera=camera, faults=faults or Faults())  # type: ignore[arg-type]
    sim_uav = world.add_uav(spec)
    transport = ZenohTransport(spec.name, listen=listen, connect=connect, mission=mission_name)
    transport.connect()
    fc = sim_uav.fc

    def await_answer() -> None:
        # the machine polls for its next task right after reporting: give mission control a network round
        # trip and one of its ticks to answer, so that the UAV chains tasks instead of flying home
        deadline = time.monotonic() + turnaround_s
        while not handler.pump() and time.monotonic() < deadline:
            time.sleep(0.002)

    handler = UavHandler(spec.name, transport, position=lambda: fc.telemetry().position_m,
                         heartbeat_period_s=heartbeat_period_s, heartbeat_timeout_s=heartbeat_timeout_s,
                         after_result=await_answer)
    config = UavConfig.from_spec(spec, cruise_altitude_m=blueprint.cruise_altitude_m, markers=blueprint.markers)
    model = build_uav(config, fc=fc, link=handler, clock=world.clock, gripper=sim_uav.gripper,
                      camera=sim_uav.camera, sprayer=sim_uav.sprayer)
    handler.attach(model)
    fc.connect()
    wall0 = time.monotonic()
    sim0 = world.clock.now_s()
    last_state = model.state
    try:
        while True:
            now = world.clock.now_s()
            handler.step(now)
            if echo is not None and model.state != last_state:
                last_state = model.state
                echo(f"{now:8.2f} s  {last_state}")
            last_mc = handler.mission_control_heard_s
            if handler.finished:
                break
            if last_mc is None:
                if time.monotonic() - wall0 > wait_s:
                    raise LinkLost(f"{spec.name}: no word from mission control at {', '.join(connect)} "
                                   f"within {wait_s:g} s")
            elif model.finished and (now - last_mc) / time_scale > wait_s:
                break  # landed, idle, and mission control silent for wait_s of wall time (it may resume)
            if now - sim0 >= max_time_s:
                break
            world.step(dt_s)
            lag = wall0 + (world.clock.now_s() - sim0) / time_scale - time.monotonic()
            if lag > 0:
                time.sleep(lag)
    finally:
        fc.close()
        transport.close()
    return RemoteRun(tuple(handler.executions), handler.mission_ended, handler.mission_completed, model.state,
                     world.clock.now_s() - sim0)
