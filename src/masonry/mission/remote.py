"""A UAV as a mission participant in its own process: ``masonry fly --mission tcp/HOST:7447``.

Simulated (``--sim``): the UAV's world runs in wall time, ``time_scale`` simulated seconds per wall second, so
that a handler process keeps pace with a mission control on another process or computer. With hardware
(``--fc URL --actuators PORT --camera ...``): the ports opened by :mod:`masonry.adapters.wiring`, on the
autopilot's clock. Either way the state machine is driven by a :class:`~masonry.mission.handler.UavHandler` on
a :class:`~masonry.mission.zenoh_transport.ZenohTransport`.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from masonry.blueprint import Blueprint, UavSpec
from masonry.errors import InputError, LinkLost
from masonry.fsm.config import UavConfig, blueprint_settings
from masonry.mission.airspace import transit_layers_m
from masonry.mission.handler import UavHandler
from masonry.ports import FlightController, UavPorts, WaitsAlive


@dataclass(frozen=True)
class RemoteRun:
    """What a handler process did: its executions, whether the mission ended, its last state, what it refused."""

    executions: tuple[Any, ...]
    mission_ended: bool
    mission_completed: bool | None
    state: str
    sim_time_s: float
    refused: tuple[str, ...] = ()  # assignments refused (not of this UAV's blueprint), one line each
    dropped: dict[str, int] = field(default_factory=dict)  # frames that failed authentication, by reason
    #: the run ended because the autopilot went silent for good (``autopilot_gone_s``): its process died, its
    #: cable is out
    autopilot_lost: bool = False


def paced(clock: Any, step: Callable[[float], None], time_scale: float) -> Callable[[float], None]:
    """``step`` (which moves ``clock``), slowed so that ``clock`` runs ``time_scale`` times as fast as the wall.

    A simulated world paced like this keeps time with processes on other computers (mission control).
    """
    anchor: list[float] = []

    def advance(dt_s: float) -> None:
        if not anchor:
            anchor.extend((time.monotonic(), clock.now_s()))
        step(dt_s)
        lag = anchor[0] + (clock.now_s() - anchor[1]) / time_scale - time.monotonic()
        if lag > 0:
            time.sleep(lag)

    return advance


def _key_hint(transport: Any, handler: UavHandler) -> str:
    """Why mission control may be unheard although it speaks: the two sides' keys differ (docs/security.md)."""
    dropped = getattr(transport, "dropped", None)
    if dropped:
        return (
            f" ({sum(dropped.values())} frames failed authentication: is `key_file` the same file as mission "
            "control's?)"
        )
    if dropped is None and handler.rejected:
        return f" ({handler.rejected} messages unreadable: does mission control use `key_file`?)"
    return ""


def remote_config(
    blueprint: Blueprint, spec: UavSpec, uav_settings: Mapping[str, object] | None = None
) -> UavConfig:
    """The configuration :func:`run_remote_uav` flies UAV ``spec`` with (``masonry fly --mission``): the
    blueprint's and its fleet's fields as the simulator's (:func:`masonry.fsm.config.blueprint_settings`:
    the other UAVs' pads the side look keeps off, issue 27), a fixed transit layer, and ``uav_settings`` (the
    uav.yaml's tuning) over them."""
    # mission control hands out transit layers per flight; this fixed one (by the UAV's index in the blueprint's
    # fleet, the same in every process) is for when mission control is silent (docs/safety.md)
    layer_m = transit_layers_m(blueprint).get(spec.name)
    return UavConfig.from_spec(
        spec,
        **{**blueprint_settings(blueprint, spec), "lateral_altitude_m": layer_m, **dict(uav_settings or {})},
    )


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
    adapters: UavPorts | None = None,
    uav_settings: Mapping[str, object] | None = None,
    max_wind_mps: float | None = None,
    key: bytes | None = None,
    zenoh_config: str | Path | None = None,
    events_sink: Any = None,
    vehicle: str | None = None,
    autopilot_gone_s: float | None = None,
) -> RemoteRun:
    """Fly one UAV for a remote mission control until it ends the mission and the UAV has landed.

    Args:
        blueprint: the wall (the simulated world lays out its bricks).
        spec: this UAV (its name is its endpoint).
        connect: mission control's Zenoh endpoint(s), e.g. ``["tcp/10.0.0.1:7447"]``.
        listen: this process's own listen endpoint(s) (loopback by default).
        mission_name: Zenoh key prefix shared with mission control.
        seed, camera, faults: the simulated world's (without ``adapters``).
        vehicle: the simulated world's autopilot preset (:data:`masonry.sim.vehicle_config.VEHICLE_PRESETS`;
            None: ``DEFAULT_VEHICLE``).
        dt_s: control tick, seconds of the UAV's clock.
        time_scale: simulated seconds per wall second (1.0: real time), for the simulated world built here.
        wait_s: wall seconds to wait for mission control's first message before giving up, and, once landed
            and idle, for mission control to speak again before leaving.
        max_time_s: seconds of the UAV's clock after which it stops regardless.
        heartbeat_period_s, heartbeat_timeout_s: in mission seconds (the UAV's clock).
        turnaround_s: wall seconds to wait, after reporting a result, for mission control's next assignment.
        echo: called with one line per state change (the process's log), or None.
        adapters: the UAV's ports (:class:`masonry.ports.UavPorts`) instead of a simulated world, as
            :func:`masonry.adapters.wiring.open_adapters` gives
            for ``masonry fly --fc URL --actuators PORT --camera ...``. Its ``advance`` moves time on its clock
            (the autopilot's: wall time on hardware, the SITL's scaled time on a bench), so ``time_scale`` does
            not apply; the caller checks the adapters before flight and closes them afterwards.
        uav_settings: :class:`masonry.fsm.UavConfig` fields to override (``masonry fly`` passes the uav.yaml's
            tuning, ``HardwareConfig.uav_settings``: the same as in single-task mode).
        max_wind_mps: this UAV's wind limit (uav.yaml), sent with its heartbeats beside its autopilot's wind
            reading: mission control gives it no task above it (None: not sent).
        key: the mission's 32-byte key (:mod:`masonry.mission.auth`); None: messages are not authenticated.
        zenoh_config: a Zenoh configuration file (TLS, access control), see
            :class:`~masonry.mission.zenoh_transport.ZenohTransport`.
        autopilot_gone_s: a real autopilot's (``masonry fly --fc``): once the UAV is halted out of service (for
            good: a silent autopilot retires it) with its flight controller's link down this long (wall seconds),
            the run ends with
            ``RemoteRun.autopilot_lost`` (issue 29: a PX4 SITL whose process died left `masonry fly --mission`
            waiting for mission control's silence, then exiting with no word of why). None: never (a simulated
            world's link comes back).
        events_sink: gets this UAV's events (:class:`masonry.mission.uav_events.UavWatch`: its tasks, and its
            state, position and battery every ``SAMPLE_PERIOD_S``), for its log; None: none.

    Raises:
        InputError: a bad ``time_scale`` or ``dt_s``.
        LinkLost: mission control was never heard within ``wait_s``.
    """
    from masonry.fingerprint import wall_digest
    from masonry.fsm import build_uav
    from masonry.mission.auth import AuthenticatedTransport, wrap
    from masonry.mission.zenoh_transport import ZenohTransport
    from masonry.planner import plan

    if not (time_scale > 0 and dt_s > 0):
        raise InputError(
            f"`time_scale` and `dt` must be > 0, got {time_scale} and {dt_s}", options=("time_scale", "dt")
        )
    ports = (
        adapters
        if adapters is not None
        else _paced_world(blueprint, spec, seed, camera, faults, time_scale, vehicle)
    )
    fc, gripper, sprayer, cam = ports.fc, ports.gripper, ports.sprayer, ports.camera
    clock: Any = ports.clock
    advance = ports.advance
    tasks = plan(blueprint).tasks
    zenoh = ZenohTransport(
        spec.name, listen=listen, connect=connect, mission=mission_name, config_file=zenoh_config
    )
    transport = wrap(zenoh, key, mission_name)
    zenoh.connect()

    def await_answer() -> None:
        # the machine polls for its next task right after reporting: give mission control a network round
        # trip and one of its ticks to answer, so that the UAV chains tasks instead of flying home
        deadline = time.monotonic() + turnaround_s
        while not handler.pump() and time.monotonic() < deadline:
            time.sleep(0.002)

    handler = UavHandler(
        spec.name,
        transport,
        position=lambda: fc.telemetry().position_m,
        report_battery=lambda: fc.telemetry().battery_fraction,
        wind=lambda: getattr(fc, "wind_speed_mps", None),  # the autopilot's WIND reading (None: none)
        max_wind_mps=max_wind_mps,
        heartbeat_period_s=heartbeat_period_s,
        heartbeat_timeout_s=heartbeat_timeout_s,
        after_result=await_answer,
        tasks=tasks,
        spares=blueprint.spares,
        role=spec.role,
        wall_digest=wall_digest(blueprint),
    )
    config = remote_config(blueprint, spec, uav_settings)
    model = build_uav(config, fc=fc, link=handler, clock=clock, gripper=gripper, camera=cam, sprayer=sprayer)
    handler.attach(model)
    if isinstance(fc, WaitsAlive):  # its waits (arming through refusals) keep the heartbeat going
        fc.keep_alive = lambda: handler.keep_alive(clock.now_s())
    wall0 = time.monotonic()
    t0 = clock.now_s()

    def not_heard() -> LinkLost:
        hint = _key_hint(transport, handler)
        return LinkLost(
            f"{spec.name}: no word from mission control at {', '.join(connect)} within {wait_s:g} s{hint}",
            options=("key_file",) if hint else (),
        )

    try:
        fc.connect()
        watch = None
        if events_sink is not None:
            from masonry.mission.uav_events import UavWatch

            watch = UavWatch(handler, model, fc.telemetry, events_sink)
        lost = _fly_until_done(
            handler,
            model,
            clock,
            advance,
            dt_s=dt_s,
            start=(t0, wall0),
            wait_s=wait_s,
            max_time_s=max_time_s,
            echo=echo,
            not_heard=not_heard,
            watch=watch,
            autopilot_down=None if autopilot_gone_s is None else _link_down(fc, autopilot_gone_s),
        )
        if watch is not None:
            watch.tick(clock.now_s(), sample=True)  # where it ended: landed
    finally:
        if isinstance(fc, WaitsAlive):
            fc.keep_alive = None
        fc.close()
        transport.close()
    dropped = dict(transport.dropped) if isinstance(transport, AuthenticatedTransport) else {}
    return RemoteRun(
        tuple(handler.executions),
        handler.mission_ended,
        handler.mission_completed,
        model.state,
        clock.now_s() - t0,
        tuple(handler.refused),
        dropped,
        lost,
    )


def _paced_world(
    blueprint: Blueprint,
    spec: UavSpec,
    seed: int,
    camera: str,
    faults: Any,
    time_scale: float,
    vehicle: str | None = None,
) -> UavPorts:
    """The ports of ``spec`` in a simulated world of its own, paced at ``time_scale`` (see :func:`paced`)."""
    from masonry.sim import Faults, World
    from masonry.sim.vehicle_config import vehicle_preset

    world = World(
        blueprint,
        seed=seed,
        camera=camera,  # type: ignore[arg-type]
        faults=faults or Faults(),
        vehicle=vehicle_preset(vehicle),
    )
    ports = world.add_uav(spec).ports
    return dataclasses.replace(ports, advance=paced(ports.clock, ports.advance, time_scale))


def _echo_failures(handler: UavHandler, shown: int, now_s: float, echo: Callable[[str], None]) -> int:
    """Echo the reason of every execution that ended failed since the first ``shown``; the new count."""
    done = handler.executions
    while shown < len(done) and done[shown].end_s is not None:
        e = done[shown]
        if e.status != "done":
            echo(f"{now_s:8.2f} s  {e.task_id} (attempt {e.attempt}) failed: {e.reason or 'no reason given'}")
        shown += 1
    return shown


def _fly_until_done(
    handler: UavHandler,
    model: Any,
    clock: Any,
    advance: Callable[[float], None],
    *,
    dt_s: float,
    start: tuple[float, float],
    wait_s: float,
    max_time_s: float,
    echo: Any,
    not_heard: Callable[[], LinkLost],
    watch: Any = None,
    autopilot_down: Callable[[bool], bool] | None = None,
) -> bool:
    """The control loop of :func:`run_remote_uav`: tick the handler until the mission ends for this UAV.

    It ends when the handler is finished, when the UAV has landed and mission control has been silent for
    ``wait_s`` of wall time, or after ``max_time_s`` of the UAV's clock; ``start`` is (clock, wall) time at
    the start. Raises ``not_heard()`` when mission control was never heard within ``wait_s``. With
    ``autopilot_down`` (:func:`_link_down`) it also ends, returning True, once that says the autopilot is gone.
    """
    t0, wall0 = start
    last_state = model.state
    heard_s: float | None = None  # when mission control was last heard (our clock), and the wall time then
    heard_wall = wall0
    refused_shown = 0
    failed_shown = 0  # executions already looked at for a failure to echo
    while True:
        now = clock.now_s()
        handler.step(now)
        if watch is not None:
            watch.tick(now)
        while echo is not None and len(handler.refused) > refused_shown:
            echo(f"{now:8.2f} s  refused an assignment: {handler.refused[refused_shown]}")
            refused_shown += 1
        if echo is not None:
            failed_shown = _echo_failures(handler, failed_shown, now, echo)
        if echo is not None and model.state != last_state:
            last_state = model.state
            echo(f"{now:8.2f} s  {last_state}")
        if handler.mission_control_heard_s != heard_s:
            heard_s, heard_wall = handler.mission_control_heard_s, time.monotonic()
        if handler.finished:
            handler.say_finished(now)
            break
        if autopilot_down is not None and autopilot_down(model.state == "halted"):
            return True
        if heard_s is None:
            if time.monotonic() - wall0 > wait_s:
                raise not_heard()
        elif model.finished and time.monotonic() - heard_wall > wait_s:
            break  # landed, idle, and mission control silent for wait_s of wall time (it may resume)
        if now - t0 >= max_time_s:
            break
        advance(dt_s)
    return False


def _link_down(
    fc: FlightController, gone_s: float, monotonic: Callable[[], float] = time.monotonic
) -> Callable[[bool], bool]:
    """Whether the autopilot is gone, asked once a tick with whether the UAV is halted (out of service for good): its
    link has been down (``fc.telemetry().link_ok`` False) for ``gone_s`` of wall time (``monotonic``) while it was."""
    since: list[float] = []

    def gone(halted: bool) -> bool:
        if not halted or fc.telemetry().link_ok:
            since.clear()
            return False
        if not since:
            since.append(monotonic())
        return monotonic() - since[0] >= gone_s

    return gone
