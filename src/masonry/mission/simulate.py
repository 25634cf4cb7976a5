"""A whole mission in simulated time: World + one handler and state machine per UAV + MissionControl, in-process.

``simulate(blueprint, options, ...)`` is what ``masonry sim`` runs: the options are one frozen
:class:`~masonry.mission.sim_options.SimOptions`, and the components beside them can be swapped: the world's
vehicle model (``vehicle_model``, :mod:`masonry.sim.vehicle_model`), its faults and site wind (``faults``), the
UAVs' tuning (``uav_config``) and state machines (``uav_machine``, :mod:`masonry.mission.uav_stack`), the
offline schedule and the observers. :meth:`SimulatedMission.from_blueprint` is the builder;
:class:`SimulatedMission` takes the built parts (world, mission control, bus, ports, clock) and runs them.

Every control tick (``CONTROL_PERIOD_S``, 0.1 s of simulated time): each live UAV handler reads its messages and
ticks its state machine, mission control steps, then the world advances in steps of ``dt_s``. Nothing sleeps, so
a mission runs as fast as the machine allows and is deterministic for a given seed.

Safety checks in the report are measured independently of mission control: conflict and dependency
violations from the intervals the UAV handlers actually executed, separation from the world's vehicles.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from masonry.airframe import DEFAULT_AIRFRAME
from masonry.blueprint import Blueprint
from masonry.errors import InputError
from masonry.fingerprint import fleet_digest, wall_digest
from masonry.mission.airspace import layer_base_m, transit_layers_m
from masonry.mission.control import LANDING_GRACE_S, MissionControl
from masonry.mission.envelope import EnvelopeWatch
from masonry.mission.events import EventSink
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.journal import open_mission_journal
from masonry.mission.measured import MeasuredJournal, journaled_errors_m, kept_errors_m, simulated_report
from masonry.mission.messages import MISSION_CONTROL
from masonry.mission.report import MissionReport
from masonry.mission.reserved import DEFAULT_AIRSPACE
from masonry.mission.schedule_file import check_schedule, with_schedule_counts
from masonry.mission.sim_loop import CONTROL_PERIOD_S, fly
from masonry.mission.sim_options import SimFields, SimOptions, with_fields
from masonry.mission.sim_resume import kept_of, resumed_world
from masonry.mission.table_events import watch_table
from masonry.mission.uav_stack import (
    BATTERY_SWAP_S,
    GroundCrew,
    UavMachineFactory,
    battery_of,
    build_machine,
    position_of,
    priority_durations_s,
    template_config,
)
from masonry.mission.wind_limit import site_wind_limit
from masonry.planner import estimate_durations_s
from masonry.planner import plan as make_plan
from masonry.planner.bounds import min_durations_s
from masonry.planner.dispatch import POLICIES as DISPATCH_POLICIES
from masonry.planner.schedule_policy import SCHEDULE_POLICY
from masonry.planner.tasks import Plan
from masonry.ports import Clock, UavPorts
from masonry.sim import Faults, World
from masonry.sim.glue import AT_PLACE_M
from masonry.sim.vehicle_config import vehicle_name, vehicle_preset
from masonry.sim.vehicle_model import VehicleModel, sim_vehicle
from masonry.timing import DEFAULT_TIMING, TaskTiming

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from masonry.fsm.config import UavConfig
    from masonry.planner.schedule_values import OfflineSchedule

#: The dispatch policies (the planner's, named here for the callers of ``simulate``).
POLICIES = DISPATCH_POLICIES

ProgressFn = Callable[[int, int, float], None]


def simulate(
    blueprint: Blueprint,
    options: SimOptions | None = None,
    *,
    vehicle_model: VehicleModel = sim_vehicle,
    faults: Faults | None = None,
    uav_config: UavConfig | None = None,
    uav_machine: UavMachineFactory = build_machine,
    schedule: OfflineSchedule | None = None,
    progress: ProgressFn | None = None,
    warn: Callable[[str], None] | None = None,
    events_sink: EventSink | None = None,
    **fields: Unpack[SimFields],
) -> MissionReport:
    """Run a whole mission in simulated time and report it: ``SimulatedMission.from_blueprint(...).run()``.

    ``options`` (default: ``SimOptions()``) say how the mission runs; the old keywords (``seed=3``) replace its
    fields. The components and what it raises are those of :meth:`SimulatedMission.from_blueprint`.
    """
    return SimulatedMission.from_blueprint(
        blueprint,
        with_fields(options, fields),
        vehicle_model=vehicle_model,
        faults=faults,
        uav_config=uav_config,
        uav_machine=uav_machine,
        schedule=schedule,
        progress=progress,
        warn=warn,
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
        uav_machine: builds each UAV's state machine (default: :func:`masonry.mission.uav_stack.build_machine`).
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
        uav_machine: UavMachineFactory = build_machine,
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
        self.started_cpu_s = time.process_time()
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
                position=position_of(uav_ports),
                heartbeat_timeout_s=heartbeat_timeout_s,
                battery=battery_of(sim_uav.vehicle),
                swap_battery=(crew := GroundCrew(sim_uav.vehicle, self.clock, sim_uav)),
                return_brick=crew.return_brick,
                after_result=self._step_control,
                tasks=plan.tasks,
                spares=plan.spares,
                role=spec.role,
                wall_digest=wall,
                keeper=self.measured if self.measured.journal is not None else None,
            )
            h.attach(
                uav_machine(spec, uav_ports, blueprint, h, self.clock, layers.get(spec.name), uav_config)
            )
            self.ports[spec.name] = uav_ports
            self.handlers[spec.name] = h
        self.measured.handlers, self.measured.spares = self.handlers, self.control.spares
        #: UAV -> the simulated time it failed (it flies, and says, nothing more)
        self.dead: dict[str, float] = {}
        self.measured.dead = self.dead
        #: an offline schedule's proven bound for the report (``from_blueprint`` with a ``task`` schedule)
        self.cp_sat_bound_s: float | None = None
        #: the world's UAVs against their reserved envelopes (None: the airspace has no rules, reserves nothing)
        self.envelope = None if control.columns.base_m is None else EnvelopeWatch(control.columns)
        self.measured.envelope = self.envelope

    def _step_control(self) -> None:
        self.control.step(self.clock.now_s())

    @classmethod
    def from_blueprint(
        cls,
        blueprint: Blueprint,
        options: SimOptions | None = None,
        *,
        vehicle_model: VehicleModel = sim_vehicle,
        faults: Faults | None = None,
        uav_config: UavConfig | None = None,
        uav_machine: UavMachineFactory = build_machine,
        schedule: OfflineSchedule | None = None,
        progress: ProgressFn | None = None,
        warn: Callable[[str], None] | None = None,
        events_sink: EventSink | None = None,
        **fields: Unpack[SimFields],
    ) -> SimulatedMission:
        """The mission ``masonry sim`` flies: the world, mission control and the fleet's machines for ``blueprint``.

        Args:
            blueprint: the wall and its fleet.
            options: how the mission runs (:class:`~masonry.mission.sim_options.SimOptions`; default: its
                defaults); the old keywords (``seed=3``, each a field of it) replace its fields. The journal
                (``journal_path``) is held open until the run ends (or :meth:`close`).
            vehicle_model: builds each UAV's vehicle in the world (:mod:`masonry.sim.vehicle_model`; default:
                a ``SimVehicle`` with the ``vehicle`` preset of the options).
            faults: a :class:`masonry.sim.Faults`, with the site's wind (None: no fault, still air).
            uav_config: the tuning of every UAV (default: ``UavConfig``'s defaults); each keeps its own name,
                role, home and transit layer, and the blueprint's cruise altitude and markers. The world's UAVs
                get its airframe; the lower bound, the expected durations and the airspace its timing.
                Default with a ``vehicle`` other than ``ideal``: the control preset of that name
                (:mod:`masonry.fsm.tuning`), the tuning a real UAV on that autopilot flies with.
            uav_machine: builds each UAV's state machine (:mod:`masonry.mission.uav_stack`; default: the brick
                or adhesion machine of :mod:`masonry.fsm`).
            schedule: the offline schedule ``policy="schedule"`` follows (``masonry schedule``; computed for
                this wall, fleet and reservation: :func:`masonry.mission.schedule_file.check_schedule`).
            progress: called as ``progress(done_tasks, total_tasks, sim_time_s)`` after each completion, and at
                least once per simulated second between them (so a progress display can keep time on a slow task).
            warn: called with a warning line (a journal without a fingerprint); default :func:`warnings.warn`.
            events_sink: gets mission control's events (:mod:`masonry.mission.events`) and, every
                ``SAMPLE_PERIOD_S``, each UAV's pose and battery as the world has them (a log, a live view).

        The journal stores the fingerprint of the wall and the fleet (:func:`masonry.fingerprint.wall_digest`,
        :func:`~masonry.fingerprint.fleet_digest`) and, with every record, what the world measured (the
        true placement error of a brick, the distance each UAV has flown, the minimum separation), so that a
        resumed report says for the work done before the crash what the run that did it would have said.

        Raises:
            InputError: a bad option (:class:`~masonry.mission.sim_options.SimOptions`), a bad fleet size, or
                ``policy="schedule"`` without a schedule.
            JournalUnusable: the journal cannot serve this mission (it already holds one and ``resume`` is off,
                it was written for another wall or fleet, it is not a journal, it is read-only).
            JournalError: the journal cannot be written during the mission.
        """
        opts = with_fields(options, fields)
        policy, reservation, separation = opts.policy, opts.reservation, opts.separation
        if policy == SCHEDULE_POLICY and schedule is None:
            raise InputError(
                "`policy` schedule needs `schedule` (masonry schedule)", options=("policy", "schedule")
            )
        faults = faults if faults is not None else Faults()
        wall0, cpu0 = time.perf_counter(), time.process_time()
        vehicle = vehicle_name(opts.vehicle)
        vehicle_config = vehicle_preset(vehicle)
        uav_config = template_config(uav_config, vehicle, opts.airspace)
        timing = DEFAULT_TIMING if uav_config is None else uav_config.timing()

        # the pads up the admission rule's ladder under the columns only (mission.fleet.fleet_for)
        admission = separation and opts.airspace == DEFAULT_AIRSPACE
        fleet = fleet_for(blueprint, opts.brick_uavs, opts.adhesion_uavs, admission=admission)
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
            if opts.journal_path is not None:
                journal, state = open_mission_journal(
                    Path(opts.journal_path),
                    resume=opts.resume,
                    wall_digest=wall_digest(blueprint),
                    fleet_digest=fleet_digest(blueprint),
                    fleet_names=[u.name for u in fleet],
                    task_ids=[t.id for t in the_plan.tasks],
                    reservation=reservation,
                    warn=warn,
                )
                resources.callback(journal.close)

            kept = kept_of(state, the_plan, fleet)
            world_blueprint, resumed_from = resumed_world(blueprint, the_plan, state, kept)
            world = World(
                world_blueprint,
                seed=opts.seed,
                camera=opts.camera,  # type: ignore[arg-type]
                faults=faults,
                start_s=resumed_from or 0.0,
                airframe=DEFAULT_AIRFRAME if uav_config is None else uav_config.airframe,
                vehicle=vehicle_config,
                vehicle_model=vehicle_model,
            )
            measured = MeasuredJournal(
                journal,
                world,
                the_plan,
                state.measured if state is not None else {},
                kept,
                before_meta=state.meta if state is not None else None,
                at_place_m=AT_PLACE_M,
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
                max_attempts=opts.max_attempts,
                durations_s=priority_durations_s(expected_s),
                heartbeat_timeout_s=opts.heartbeat_timeout_s,
                startup_timeout_s=max(10 * opts.dt_s, 1.0),
                # a radio that drops out for a few seconds: its UAV, the last of its role, may come back
                rejoin_timeout_s=2.0 * opts.heartbeat_timeout_s,
                column_radius_m=blueprint.clearance_m if separation else 0.0,
                layer_base_m=layer_base_m(blueprint, timing=timing) if separation else None,
                layer_floor_m=blueprint.cruise_altitude_m if separation and opts.rising_layers else None,
                wall_digest=wall_digest(blueprint),
                min_durations_s=min_durations_s(
                    the_plan, cruise_altitude_m=blueprint.cruise_altitude_m, timing=timing
                ),
                timing=timing,
                stall_timeout_s=opts.stall_timeout_s,
                reservation=reservation,
                schedule=schedule if policy == SCHEDULE_POLICY else None,
                events_sink=events_sink,
                fence=blueprint.site,
                wind_limit=site_wind_limit(faults.site_wind(), fleet, opts.max_wind_mps),
                fallback_layers_m=transit_layers_m(blueprint, fleet, timing=timing) if separation else None,
                airspace=opts.airspace,
                table_dispatch=opts.table_dispatch,
                placement=blueprint.placement,
            )
            if state is not None:
                mc.restore(state)
            if events_sink is not None:  # (--airspace table: the sink sees its reservations too)
                watch_table(mc)
            world.add_fleet(fleet)
            mission = cls(
                blueprint,
                the_plan,
                world=world,
                control=mc,
                bus=bus,
                policy=policy,
                seed=opts.seed,
                dt_s=opts.dt_s,
                max_time_s=opts.max_time_s,
                heartbeat_timeout_s=opts.heartbeat_timeout_s,
                progress=progress,
                layers_m=transit_layers_m(blueprint, fleet, timing=timing) if separation else {},
                measured=measured,
                resumed_from=resumed_from,
                journaled_errors_m={**kept_errors_m(kept), **journaled_errors_m(state)},
                resources=resources.pop_all(),
                uav_config=uav_config,
                uav_machine=uav_machine,
            )
        mission.started_wall_s, mission.started_cpu_s = wall0, cpu0
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
            fly(self)
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
                cpu_time_s=time.process_time() - self.started_cpu_s,
                resumed_from=self.resumed_from,
                messages=self.bus.sent,
                measured=self.measured,
                journaled_errors_m=self.journaled_errors_m,
                timing=self.timing,
                cp_sat_bound_s=self.cp_sat_bound_s,
            )
            return with_schedule_counts(report, self.control.dispatcher)


__all__ = [
    "BATTERY_SWAP_S",
    "CONTROL_PERIOD_S",
    "LANDING_GRACE_S",
    "POLICIES",
    "SimOptions",
    "SimulatedMission",
    "fleet_for",
    "priority_durations_s",
    "simulate",
]
