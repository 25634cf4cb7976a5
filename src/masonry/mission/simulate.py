"""A whole mission in simulated time: World + one handler and state machine per UAV + MissionControl, in-process.

``simulate(blueprint, ...)`` is what ``masonry sim`` runs. Every control tick (``CONTROL_PERIOD_S``, 0.1 s
of simulated time): each live UAV handler reads its messages and ticks its state machine, mission control
steps, then the world advances in steps of ``dt_s``. Nothing sleeps, so a mission runs as fast as the
machine allows and is deterministic for a given seed.

Safety checks in the report are measured independently of mission control: conflict and dependency
violations from the intervals the UAV handlers actually executed, separation from the world's vehicles.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from masonry.airframe import DEFAULT_AIRFRAME
from masonry.blueprint import Blueprint, UavSpec
from masonry.errors import InputError, MasonryError
from masonry.fingerprint import fleet_digest, wall_digest
from masonry.mission.airspace import layer_base_m, transit_layers_m
from masonry.mission.control import MissionControl
from masonry.mission.events import SAMPLE_PERIOD_S, EventSink
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.journal import open_mission_journal
from masonry.mission.measured import (
    KeptCompletion,
    MeasuredJournal,
    journaled_errors_m,
    kept_completions,
    kept_errors_m,
    simulated_report,
)
from masonry.mission.messages import MISSION_CONTROL
from masonry.mission.report import MissionReport
from masonry.mission.schedule_file import check_schedule, with_schedule_counts
from masonry.mission.stall import DEFAULT_STALL_TIMEOUT_S
from masonry.mission.wind_limit import DEFAULT_MAX_WIND_MPS, WindLimit
from masonry.planner import estimate_durations_s
from masonry.planner import plan as make_plan
from masonry.planner.bounds import min_durations_s
from masonry.planner.dispatch import DEFAULT_RESERVATION, RESERVATIONS
from masonry.planner.dispatch import POLICIES as DISPATCH_POLICIES
from masonry.planner.schedule_policy import SCHEDULE_POLICY
from masonry.planner.tasks import BrickTask, Plan
from masonry.ports import Clock, UavPorts
from masonry.sim.vehicle_config import vehicle_name, vehicle_preset
from masonry.timing import DEFAULT_TIMING, TaskTiming

if TYPE_CHECKING:
    from masonry.fsm.config import UavConfig
    from masonry.planner.schedule_values import OfflineSchedule
    from masonry.sim import World

#: The dispatch policies (the planner's, named here for the callers of ``simulate``).
POLICIES = DISPATCH_POLICIES

#: How long the ground crew takes to swap a landed UAV's battery (the handler keeps a reserve, see UavHandler).
BATTERY_SWAP_S = 60.0
#: How long the UAVs get, after the last task, to fly home and land before the simulation stops.
LANDING_GRACE_S = 180.0

#: The state machines' control period (``UavConfig.control_period_s``, from :data:`masonry.timing.DEFAULT_TIMING`):
#: UAV handlers and mission control step at this period, the world at ``dt_s``.
CONTROL_PERIOD_S = DEFAULT_TIMING.control_period_s

ProgressFn = Callable[[int, int, float], None]


#: Expected durations are rounded to this for the critical-path priority (see :func:`priority_durations_s`).
PRIORITY_QUANTUM_S = 5.0


def priority_durations_s(
    durations_s: Mapping[str, float], quantum_s: float = PRIORITY_QUANTUM_S
) -> dict[str, float]:
    """Expected durations rounded to ``quantum_s`` for the dispatcher's critical-path priority.

    The estimates are a model, good to several seconds; comparing chains that differ by less than that
    would let noise (a home a metre further away) decide, where the tie-break by flight distance is the
    better rule. In the paper's case study this is what makes A0, the adhesion task nearest the adhesion
    UAV, go first.
    """
    return {k: max(quantum_s, round(v / quantum_s) * quantum_s) for k, v in durations_s.items()}


def _position_of(ports: UavPorts) -> Callable[[], tuple[float, float, float]]:
    fc = ports.fc
    return lambda: fc.telemetry().position_m


def _battery_of(sim_uav: Any) -> Callable[[], float]:
    vehicle = sim_uav.vehicle
    return lambda: float(vehicle.battery_fraction)


class _GroundCrew:
    """Swaps a landed, disarmed UAV's battery, taking ``BATTERY_SWAP_S``; True once the fresh pack is in."""

    def __init__(self, vehicle: Any, clock: Any) -> None:
        self.vehicle = vehicle
        self.clock = clock
        self._since_s: float | None = None

    def __call__(self) -> bool:
        v = self.vehicle
        if not (v.on_ground and not v.armed):
            self._since_s = None
            return False
        now = self.clock.now_s()
        if self._since_s is None:
            self._since_s = now
        if now - self._since_s < BATTERY_SWAP_S:
            return False
        try:
            v.swap_battery()
        except MasonryError:
            return False
        self._since_s = None
        return True


def _build_machine(
    spec: UavSpec,
    ports: UavPorts,
    blueprint: Blueprint,
    handler: UavHandler,
    clock: Clock,
    lateral_altitude_m: float | None = None,
    template: UavConfig | None = None,
) -> Any:
    from masonry.fsm import AdhesionUav, BrickUav, UavConfig

    # the template's tuning (default: UavConfig's), with this UAV's identity, home, layer and the blueprint's
    base = template if template is not None else UavConfig(spec.name, spec.role, spec.home_m)
    config = dataclasses.replace(
        base,
        name=spec.name,
        role=spec.role,
        home_m=spec.home_m,
        cruise_altitude_m=blueprint.cruise_altitude_m,
        markers=blueprint.markers,
        wall=tuple((b.id, (*b.position_m[:2], b.position_m[2] + b.size_m[2] / 2)) for b in blueprint.bricks),
        lateral_altitude_m=lateral_altitude_m,
        fence=blueprint.site,
    )
    if spec.role == "brick":
        return BrickUav(config, ports.fc, ports.gripper, ports.camera, handler, clock, clearance=handler)
    return AdhesionUav(config, ports.fc, ports.sprayer, handler, clock, clearance=handler)


def simulate(
    blueprint: Blueprint,
    *,
    brick_uavs: int | None = None,
    adhesion_uavs: int | None = None,
    policy: str = "critical-path",
    seed: int = 0,
    camera: str = "geometric",
    faults: Any = None,
    journal_path: str | Path | None = None,
    resume: bool = False,
    dt_s: float = 0.05,
    max_time_s: float | None = None,
    heartbeat_timeout_s: float = 5.0,
    max_attempts: int = 3,
    progress: ProgressFn | None = None,
    separation: bool = True,
    rising_layers: bool = True,
    warn: Callable[[str], None] | None = None,
    uav_config: UavConfig | None = None,
    stall_timeout_s: float | None = DEFAULT_STALL_TIMEOUT_S,
    reservation: str = DEFAULT_RESERVATION,
    schedule: OfflineSchedule | None = None,
    events_sink: EventSink | None = None,
    vehicle: str | None = None,
) -> MissionReport:
    """Run a whole mission in simulated time and report it: ``SimulatedMission.from_blueprint(...).run()``.

    The arguments, and what it raises, are those of :meth:`SimulatedMission.from_blueprint`.
    """
    return SimulatedMission.from_blueprint(
        blueprint,
        brick_uavs=brick_uavs,
        adhesion_uavs=adhesion_uavs,
        policy=policy,
        seed=seed,
        camera=camera,
        faults=faults,
        journal_path=journal_path,
        resume=resume,
        dt_s=dt_s,
        max_time_s=max_time_s,
        heartbeat_timeout_s=heartbeat_timeout_s,
        max_attempts=max_attempts,
        progress=progress,
        separation=separation,
        rising_layers=rising_layers,
        warn=warn,
        uav_config=uav_config,
        vehicle=vehicle,
        stall_timeout_s=stall_timeout_s,
        reservation=reservation,
        schedule=schedule,
        events_sink=events_sink,
    ).run()


class SimulatedMission:
    """A whole mission in simulated time, from its components: a world, mission control on an in-process bus,
    and one :class:`masonry.ports.UavPorts` per UAV of the fleet, each flown by a UAV handler and its machine.

    :meth:`from_blueprint` builds the components the way ``masonry sim`` does; :meth:`run` flies the mission
    and reports it. Build the parts yourself to look inside (``mission.control``, ``mission.world``) or to swap
    one (another UAV's ports, another mission control), then ``run()``.

    Args:
        blueprint: the wall, with the fleet that flies it.
        plan: its plan (the tasks mission control dispatches).
        world: the simulated world, every UAV of the fleet in it (its vehicle, battery and failures).
        control: mission control, on an endpoint of ``bus``.
        bus: the in-process bus; each UAV handler gets the endpoint of its name.
        ports: UAV name -> the ports its machine flies with (default: the world UAV's own, ``SimUav.ports``).
        clock: the time handlers and mission control read (default: the world's clock, which ``world.step``
            moves on).
        policy, seed: for the report.
        dt_s: physics step of the world, seconds (handlers and mission control step every ``CONTROL_PERIOD_S``).
        max_time_s: give up at this simulated time (default: generous, from the number of tasks).
        heartbeat_timeout_s: a UAV silent that long is declared lost (by its handler's heartbeats).
        progress: called as ``progress(done_tasks, total_tasks, sim_time_s)`` (see :func:`simulate`).
        layers_m: UAV name -> altitude of its lateral legs (:func:`masonry.mission.airspace.transit_layers_m`;
            empty: no transit layers).
        measured: the journal mission control writes to, with the world's measurements (None: a plain one with
            no journal behind it, for the report's measurements).
        resumed_from: the simulated time the mission resumed at (None: a fresh mission).
        journaled_errors_m: placement errors of the bricks done before a resume (from the journal).
        resources: closed when the run ends (the journal, by :meth:`from_blueprint`).
        uav_config: the tuning every UAV's machine flies with (None: ``UavConfig``'s defaults); the report's
            bound counts its timing (``uav_config.timing()``).
    """

    def __init__(
        self,
        blueprint: Blueprint,
        plan: Plan,
        *,
        world: World,
        control: MissionControl,
        bus: InprocBus,
        ports: Mapping[str, UavPorts] | None = None,
        clock: Clock | None = None,
        policy: str = "critical-path",
        seed: int = 0,
        dt_s: float = 0.05,
        max_time_s: float | None = None,
        heartbeat_timeout_s: float = 5.0,
        progress: ProgressFn | None = None,
        layers_m: Mapping[str, float] | None = None,
        measured: MeasuredJournal | None = None,
        resumed_from: float | None = None,
        journaled_errors_m: Mapping[str, float] | None = None,
        resources: contextlib.ExitStack | None = None,
        uav_config: UavConfig | None = None,
    ) -> None:
        if not (dt_s > 0 and math.isfinite(dt_s)):
            raise InputError(f"dt_s must be > 0, got {dt_s!r}")
        self.blueprint = blueprint
        self.plan = plan
        self.fleet = tuple(blueprint.fleet)
        self.world = world
        self.control = control
        self.bus = bus
        self.clock: Clock = clock if clock is not None else world.clock
        self.policy = policy
        self.seed = seed
        self.dt_s = dt_s
        self.progress = progress
        self.resumed_from = resumed_from
        self.journaled_errors_m = dict(journaled_errors_m or {})
        self.uav_config = uav_config
        self.timing: TaskTiming = DEFAULT_TIMING if uav_config is None else uav_config.timing()
        self.measured = measured if measured is not None else MeasuredJournal(None, world, plan, {})
        self._resources = resources if resources is not None else contextlib.ExitStack()
        self._ran = False
        self.started_wall_s = time.perf_counter()
        #: called as ``hook(now_s)`` after every control tick (a live view paces the mission against the wall
        #: clock, an operator pauses it); they may sleep, never change the mission's state
        self.tick_hooks: list[Callable[[float], None]] = []
        total = sum(1 for t in plan.tasks if not t.done)
        self.max_time_s = (
            max_time_s if max_time_s is not None else (resumed_from or 0.0) + 600.0 + 150.0 * total
        )
        missing = [u.name for u in self.fleet if u.name not in world.uavs]
        if missing:
            raise InputError(f"the world has no UAV named {', '.join(missing)}: add the fleet first")
        ports = ports if ports is not None else {}
        layers = layers_m if layers_m is not None else {}
        wall = wall_digest(blueprint)
        if control.wall_digest != wall:
            # the handlers check every assignment against the wall: each would refuse each task, and the
            # mission would never progress
            raise InputError(
                "mission control was built for another wall: pass it "
                "`wall_digest=masonry.fingerprint.wall_digest(blueprint)`"
            )
        self.ports: dict[str, UavPorts] = {}
        self.handlers: dict[str, UavHandler] = {}
        for spec in self.fleet:
            sim_uav = world.uavs[spec.name]
            uav_ports = ports.get(spec.name, sim_uav.ports)
            h = UavHandler(
                spec.name,
                bus.endpoint(spec.name),
                position=_position_of(uav_ports),
                heartbeat_timeout_s=heartbeat_timeout_s,
                battery=_battery_of(sim_uav),
                swap_battery=_GroundCrew(sim_uav.vehicle, self.clock),
                after_result=self._step_control,
                tasks=plan.tasks,
                role=spec.role,
                wall_digest=wall,
                keeper=self.measured if self.measured.journal is not None else None,
            )
            h.attach(
                _build_machine(spec, uav_ports, blueprint, h, self.clock, layers.get(spec.name), uav_config)
            )
            self.ports[spec.name] = uav_ports
            self.handlers[spec.name] = h
        self.measured.handlers = self.handlers
        #: UAV -> the simulated time it failed (it flies, and says, nothing more)
        self.dead: dict[str, float] = {}
        self.measured.dead = self.dead
        #: an offline schedule's proven bound for the report (``from_blueprint`` with a ``task`` schedule)
        self.cp_sat_bound_s: float | None = None

    def _step_control(self) -> None:
        self.control.step(self.clock.now_s())

    @classmethod
    def from_blueprint(
        cls,
        blueprint: Blueprint,
        *,
        brick_uavs: int | None = None,
        adhesion_uavs: int | None = None,
        policy: str = "critical-path",
        seed: int = 0,
        camera: str = "geometric",
        faults: Any = None,
        journal_path: str | Path | None = None,
        resume: bool = False,
        dt_s: float = 0.05,
        max_time_s: float | None = None,
        heartbeat_timeout_s: float = 5.0,
        max_attempts: int = 3,
        progress: ProgressFn | None = None,
        separation: bool = True,
        rising_layers: bool = True,
        warn: Callable[[str], None] | None = None,
        uav_config: UavConfig | None = None,
        stall_timeout_s: float | None = DEFAULT_STALL_TIMEOUT_S,
        reservation: str = DEFAULT_RESERVATION,
        schedule: OfflineSchedule | None = None,
        events_sink: EventSink | None = None,
        vehicle: str | None = None,
        max_wind_mps: float | Mapping[str, float] | None = None,
    ) -> SimulatedMission:
        """The mission ``masonry sim`` flies: the world, mission control and the fleet's machines for ``blueprint``.

        Args:
            blueprint: the wall and its fleet.
            brick_uavs, adhesion_uavs: override the fleet's size per role (see :func:`fleet_for`).
            policy: dispatcher priority: ``fifo``, ``critical-path`` or ``nearest``.
            seed: seed of the world (brick offsets, noise, faults).
            camera: ``geometric`` (marker observations from the camera model) or ``render`` (images + ArUco).
            faults: a :class:`masonry.sim.Faults` (None: no fault).
            journal_path: SQLite journal to write (and, with ``resume``, to continue from); held open until the
                run ends (or :meth:`close`).
            resume: continue the mission recorded in ``journal_path``: its done tasks stay done (their bricks
                are in place in the world), its clock continues, the report covers the whole mission.
            dt_s: physics step of the world, seconds (handlers and mission control step every
                ``CONTROL_PERIOD_S``).
            max_time_s: give up at this simulated time (default: generous, from the number of tasks).
            heartbeat_timeout_s: a UAV silent that long is declared lost.
            max_attempts: failed attempts before a task is stuck.
            progress: called as ``progress(done_tasks, total_tasks, sim_time_s)`` after each completion, and at
                least once per simulated second between them (so a progress display can keep time on a slow task).
            separation: transit layers and site columns (docs/safety.md); False flies every lateral leg at the
                work altitude with no column clearance, as before they existed (for comparisons).
            rising_layers: with separation, transit layer 0 rises with the wall (over the tasks done or assigned
                so far) instead of staying above the finished wall from the start (False, for comparisons).
            warn: called with a warning line (a journal without a fingerprint); default :func:`warnings.warn`.
            uav_config: the tuning of every UAV (default: ``UavConfig``'s defaults); each keeps its own name,
                role, home and transit layer, and the blueprint's cruise altitude and markers. The world's UAVs
                get its airframe; the lower bound, the expected durations and the airspace its timing.
                Default with a ``vehicle`` other than ``ideal``: the control preset of that name
                (:mod:`masonry.fsm.tuning`), the tuning a real UAV on that autopilot flies with.
            vehicle: the simulated autopilot (:data:`masonry.sim.vehicle_config.VEHICLE_PRESETS`): ``ideal``
                (a first-order 0.3 s velocity lag) or ``arducopter`` (ArduCopter's shaping, delay and GPS-like
                noise, fitted to its SITL: docs/performance/autopilots.md); None (default):
                :data:`~masonry.sim.vehicle_config.DEFAULT_VEHICLE`, ``arducopter``.
            stall_timeout_s: stop the mission, not completed, when nothing progresses for this long
                (simulated seconds; :class:`masonry.mission.control.MissionControl`); None or 0: never.
            reservation: ``site`` (default: conflicting tasks may run at once; their UAVs never work at their
                sites at once) or ``task`` (the paper: conflicting tasks never run at once); docs/safety.md.
            schedule: the offline schedule ``policy="schedule"`` follows (``masonry schedule``; computed for
                this wall, fleet and reservation: :func:`masonry.mission.schedule_file.check_schedule`).
            events_sink: gets mission control's events (:mod:`masonry.mission.events`) and, every
                ``SAMPLE_PERIOD_S``, each UAV's pose and battery as the world has them (a log, a live view).

        The journal stores the fingerprint of the wall and the fleet (:func:`masonry.fingerprint.wall_digest`,
        :func:`~masonry.fingerprint.fleet_digest`) and, with every record, what the world measured (the
        true placement error of a brick, the distance each UAV has flown, the minimum separation), so that a
        resumed report says for the work done before the crash what the run that did it would have said.

        Raises:
            InputError: an unknown policy or camera mode, a bad fleet size, or ``resume`` without a journal.
            JournalUnusable: the journal cannot serve this mission (it already holds one and ``resume`` is off,
                it was written for another wall or fleet, it is not a journal, it is read-only).
            JournalError: the journal cannot be written during the mission.
        """
        from masonry.sim import Faults, World

        if reservation not in RESERVATIONS:
            raise InputError(
                f"`reservation` must be one of {', '.join(RESERVATIONS)}, got {reservation!r}",
                options=("reservation",),
            )
        if policy == SCHEDULE_POLICY and schedule is None:
            raise InputError(
                "`policy` schedule needs `schedule` (masonry schedule)", options=("policy", "schedule")
            )
        if policy not in POLICIES and policy != SCHEDULE_POLICY:
            raise InputError(
                f"`policy` must be one of {', '.join(POLICIES)}, got {policy!r}", options=("policy",)
            )
        if camera not in ("geometric", "render"):
            raise InputError(f"`camera` must be geometric or render, got {camera!r}", options=("camera",))
        if not (dt_s > 0 and math.isfinite(dt_s)):
            raise InputError(f"dt_s must be > 0, got {dt_s!r}")
        if resume and journal_path is None:
            raise InputError("`resume` needs `journal_path`", options=("resume", "journal_path"))
        faults = faults if faults is not None else Faults()
        wall0 = time.perf_counter()
        vehicle = vehicle_name(vehicle)
        vehicle_config = vehicle_preset(vehicle)
        if uav_config is None and vehicle != "ideal":
            # the tuning a real UAV on that autopilot flies with (masonry.fsm.tuning's preset of the same name)
            from masonry.fsm import UavConfig
            from masonry.fsm.tuning import uav_settings

            uav_config = UavConfig("template", "brick", (0.0, 0.0, 0.0), **uav_settings(vehicle))
        timing = DEFAULT_TIMING if uav_config is None else uav_config.timing()

        fleet = fleet_for(blueprint, brick_uavs, adhesion_uavs)
        if not fleet:
            raise InputError(
                "the fleet is empty: give `brick_uavs` / `adhesion_uavs` or a fleet in the blueprint",
                options=("brick_uavs", "adhesion_uavs"),
            )
        if fleet != blueprint.fleet:
            blueprint = with_fleet(blueprint, fleet)
        the_plan = make_plan(blueprint)
        if policy == SCHEDULE_POLICY and schedule is not None:
            check_schedule(schedule, blueprint, reservation)

        with contextlib.ExitStack() as resources:
            journal = None
            state = None
            if journal_path is not None:
                journal, state = open_mission_journal(
                    Path(journal_path),
                    resume=resume,
                    wall_digest=wall_digest(blueprint),
                    fleet_digest=fleet_digest(blueprint),
                    fleet_names=[u.name for u in fleet],
                    task_ids=[t.id for t in the_plan.tasks],
                    reservation=reservation,
                    warn=warn,
                )
                resources.callback(journal.close)

            kept = _kept(state, the_plan, fleet)
            world_blueprint, resumed_from = _resumed_world(blueprint, the_plan, state, kept)
            world = World(
                world_blueprint,
                seed=seed,
                camera=camera,  # type: ignore[arg-type]
                faults=faults,
                start_s=resumed_from or 0.0,
                airframe=DEFAULT_AIRFRAME if uav_config is None else uav_config.airframe,
                vehicle=vehicle_config,
            )
            measured = MeasuredJournal(
                journal, world, the_plan, state.measured if state is not None else {}, kept
            )
            expected_s = estimate_durations_s(
                the_plan, fleet, cruise_altitude_m=blueprint.cruise_altitude_m, timing=timing
            )
            bus = InprocBus()
            mc = MissionControl(
                the_plan,
                fleet,
                bus.endpoint(MISSION_CONTROL),
                policy=policy,
                journal=measured if journal is not None else None,
                max_attempts=max_attempts,
                durations_s=priority_durations_s(expected_s),
                heartbeat_timeout_s=heartbeat_timeout_s,
                startup_timeout_s=max(10 * dt_s, 1.0),
                # a radio that drops out for a few seconds: its UAV, the last of its role, may come back
                rejoin_timeout_s=2.0 * heartbeat_timeout_s,
                column_radius_m=blueprint.clearance_m if separation else 0.0,
                layer_base_m=layer_base_m(blueprint, timing=timing) if separation else None,
                layer_floor_m=blueprint.cruise_altitude_m if separation and rising_layers else None,
                wall_digest=wall_digest(blueprint),
                min_durations_s=min_durations_s(
                    the_plan, cruise_altitude_m=blueprint.cruise_altitude_m, timing=timing
                ),
                timing=timing,
                stall_timeout_s=stall_timeout_s,
                reservation=reservation,
                schedule=schedule if policy == SCHEDULE_POLICY else None,
                events_sink=events_sink,
                fence=blueprint.site,
                wind_limit=_wind_limit(faults, fleet, max_wind_mps),
                fallback_layers_m=transit_layers_m(blueprint, fleet, timing=timing) if separation else None,
                placement=blueprint.placement,
            )
            if state is not None:
                mc.restore(state)
            world.add_fleet(fleet)
            mission = cls(
                blueprint,
                the_plan,
                world=world,
                control=mc,
                bus=bus,
                policy=policy,
                seed=seed,
                dt_s=dt_s,
                max_time_s=max_time_s,
                heartbeat_timeout_s=heartbeat_timeout_s,
                progress=progress,
                layers_m=transit_layers_m(blueprint, fleet, timing=timing) if separation else {},
                measured=measured,
                resumed_from=resumed_from,
                journaled_errors_m={**kept_errors_m(kept), **journaled_errors_m(state)},
                resources=resources.pop_all(),
                uav_config=uav_config,
            )
        mission.started_wall_s = wall0
        if schedule is not None and reservation == "task" and timing == DEFAULT_TIMING and state is None:
            # the same timing model (a vehicle's control preset may fly other gains over the same minimum
            # durations), wall and fleet: a valid term
            mission.cp_sat_bound_s = schedule.bound_s
        return mission

    def close(self) -> None:
        """Close what the mission holds (its journal); :meth:`run` does it when it ends."""
        self._resources.close()

    def __enter__(self) -> SimulatedMission:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def run(self) -> MissionReport:
        """Fly the mission to its end (or ``max_time_s``) and report it; closes the journal.

        Raises:
            InputError: the mission was run already (a world flies once).
            JournalError: the journal cannot be written during the mission.
        """
        if self._ran:
            raise InputError("this mission has run already: build another one")
        self._ran = True
        with self._resources:
            self._fly()
            if self.measured.journal is not None:
                # the end of the run, for a later resume of a finished mission (no record follows the landing)
                self.measured.journal.set_meta(
                    "measured", {**self.measured.measurements(), "time_s": self.clock.now_s()}
                )
            report = simulated_report(
                self.blueprint,
                self.plan,
                self.fleet,
                self.control,
                self.handlers,
                self.world,
                self.dead,
                policy=self.policy,
                seed=self.seed,
                sim_time_s=self.clock.now_s() - (self.resumed_from or 0.0),
                wall_time_s=time.perf_counter() - self.started_wall_s,
                resumed_from=self.resumed_from,
                messages=self.bus.sent,
                measured=self.measured,
                journaled_errors_m=self.journaled_errors_m,
                timing=self.timing,
                cp_sat_bound_s=self.cp_sat_bound_s,
            )
            return with_schedule_counts(report, self.control.dispatcher)

    def _fly(self) -> None:
        """The loop: handlers and mission control at the control period, the world's physics at ``dt_s``."""
        mc, world, clock, handlers, dead = self.control, self.world, self.clock, self.handlers, self.dead
        total = sum(1 for t in self.plan.tasks if not t.done)
        # Handlers and mission control tick at the machines' control rate; the world's physics at dt_s in
        # between. A tick of theirs in between would do nothing the next one does not (the machines act every
        # control_period_s, and an answer to a result is handled at once through ``after_result``).
        dt_s = self.dt_s
        substeps = max(1, round(CONTROL_PERIOD_S / dt_s)) if dt_s < CONTROL_PERIOD_S else 1
        pre_done = sum(1 for t in self.plan.tasks if t.done)
        done_seen = len(mc.dispatcher.done) - pre_done
        progress_s = clock.now_s()
        mission_end_s: float | None = None
        next_sample_s = clock.now_s()
        mc.uav_events = False  # the world's samples below tell the sink where each UAV is
        while True:
            now = clock.now_s()
            for name, h in handlers.items():
                if name in dead:
                    continue
                if world.uavs[name].failed:
                    # a failed UAV (``uav-loss``) says nothing more: mission control must notice the silence
                    dead[name] = now
                    self.bus.cut(name)
                    continue
                h.step(now)
            mc.step(now)
            if mc.sink is not None and now >= next_sample_s - 1e-9:
                next_sample_s = max(next_sample_s + SAMPLE_PERIOD_S, now)
                live = [(n, u.vehicle) for n, u in world.uavs.items() if n not in dead]
                mc.sample(now, {n: v.position_m for n, v in live}, {n: v.battery_fraction for n, v in live})
            for hook in self.tick_hooks:
                hook(now)
            if self.progress is not None:
                n_done = len(mc.dispatcher.done) - pre_done
                if n_done != done_seen or now - progress_s >= 1.0:
                    done_seen = n_done
                    progress_s = now
                    self.progress(n_done, total, now)
            if mc.ended_at_s is not None:
                if mission_end_s is None:
                    mission_end_s = now
                landed = all(h.finished for n, h in handlers.items() if n not in dead)
                if landed or now - mission_end_s > LANDING_GRACE_S:
                    break
            if now >= self.max_time_s:
                break
            for _ in range(substeps):
                world.step(dt_s)


__all__ = ["POLICIES", "SimulatedMission", "fleet_for", "simulate"]


def _wind_limit(faults: Any, fleet: Sequence[Any], max_wind_mps: float | Mapping[str, float] | None) -> Any:
    """Mission control's wind limit for the simulated site (None in still air): each UAV's ``max_wind_mps``
    (one figure for all, or per name; default :data:`~masonry.mission.wind_limit.DEFAULT_MAX_WIND_MPS`) against
    the site's mean wind at 10 m."""

    wind = faults.site_wind() if faults is not None else None
    if wind is None or wind.calm:
        return None
    if isinstance(max_wind_mps, Mapping):
        limits = {u.name: float(max_wind_mps.get(u.name, DEFAULT_MAX_WIND_MPS)) for u in fleet}
    else:
        limit = DEFAULT_MAX_WIND_MPS if max_wind_mps is None else float(max_wind_mps)
        limits = {u.name: limit for u in fleet}
    return WindLimit(limits, wind.speed_at)


def _kept(state: Any, the_plan: Plan, fleet: Sequence[UavSpec]) -> dict[str, KeptCompletion]:
    """The completions the UAVs kept in the journal file, unheard (of this plan's tasks and this fleet's UAVs)."""
    ids, names = {t.id for t in the_plan.tasks}, {u.name for u in fleet}
    return {u: k for u, k in kept_completions(state).items() if k.task_id in ids and u in names}


def _resumed_world(
    blueprint: Blueprint, the_plan: Plan, state: Any, kept: Mapping[str, KeptCompletion]
) -> tuple[Blueprint, float | None]:
    """The blueprint the resumed world is built from, and the time it resumes at (None: not a resume).

    Bricks the journal says are placed are in place, and so are those a UAV kept the completion of, unheard (it
    says it again first thing: mission control takes it); the clock starts no earlier than a kept completion
    (the UAV finished then, so the mission was running)."""
    if state is None:
        return blueprint, None
    placed = {
        the_plan.task(tid).brick  # type: ignore[union-attr]
        for tid in [r.task_id for r in state.done] + [k.task_id for k in kept.values()]
        if isinstance(the_plan.task(tid), BrickTask)
    }
    bricks = tuple(dataclasses.replace(b, placed=True) if b.id in placed else b for b in blueprint.bricks)
    resumed_from = max([float(state.last_time_s or 0.0), *(k.time_s for k in kept.values())])
    return dataclasses.replace(blueprint, bricks=bricks), resumed_from
