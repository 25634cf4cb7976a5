"""The options of a simulated mission, as one frozen value: :class:`SimOptions`.

``simulate(blueprint, options, ...)`` and :meth:`masonry.mission.simulate.SimulatedMission.from_blueprint` take
one ``SimOptions`` beside their components (the vehicle model, the faults, the UAVs' tuning, the offline
schedule and the observers); ``masonry sim`` builds it from its flags in one place
(:func:`masonry.cli.sim.sim`), so the CLI, the library, the benchmarks and the chaos campaign cannot
drift apart. The old keywords (``simulate(bp, seed=3, policy="fifo")``) are still taken: each is a field of
``SimOptions`` (:class:`SimFields`), replaced in the default value.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

from masonry.errors import InputError
from masonry.mission.reserved import AIRSPACES, DEFAULT_AIRSPACE
from masonry.mission.stall import DEFAULT_STALL_TIMEOUT_S
from masonry.mission.table_dispatch import DEFAULT_TABLE_DISPATCH, TABLE_DISPATCHES
from masonry.planner.dispatch import DEFAULT_RESERVATION, RESERVATIONS
from masonry.planner.dispatch import POLICIES as DISPATCH_POLICIES
from masonry.planner.schedule_policy import SCHEDULE_POLICY
from masonry.sim.vehicle_config import vehicle_preset

__all__ = ["CAMERA_MODES", "SimFields", "SimOptions", "with_fields"]

#: How the simulated camera sees the markers: from the camera model, rendered images and ArUco, or the camera
#: model with rendered images over the pickups of a sample of bricks (``mixed``).
CAMERA_MODES = ("geometric", "render", "mixed")


@dataclass(frozen=True)
class SimOptions:
    """How a simulated mission runs (every field has the default ``masonry sim`` has).

    Attributes:
        brick_uavs, adhesion_uavs: override the fleet's size per role
            (:func:`masonry.mission.fleet.fleet_for`; None: the blueprint's).
        policy: dispatcher priority: ``fifo``, ``critical-path``, ``nearest``, or ``schedule`` (follow the
            offline schedule given beside the options).
        seed: seed of the world (brick offsets, noise, faults).
        camera: ``geometric`` (marker observations from the camera model), ``render`` (images + ArUco) or
            ``mixed`` (images + ArUco over the pickups of 10 sampled bricks).
        journal_path: SQLite journal to write (and, with ``resume``, to continue from).
        resume: continue the mission recorded in ``journal_path``: its done tasks stay done, its clock
            continues, the report covers the whole mission.
        dt_s: physics step of the world, seconds (handlers and mission control step every control period).
        max_time_s: give up at this simulated time (None: generous, from the number of tasks).
        heartbeat_timeout_s: a UAV silent that long is declared lost.
        max_attempts: failed attempts before a task is stuck.
        separation: transit layers and site columns (docs/safety.md); False flies every lateral leg at the
            work altitude with no column clearance (for comparisons).
        rising_layers: with separation, transit layer 0 rises with the wall instead of staying above the
            finished wall from the start (False, for comparisons).
        stall_timeout_s: stop the mission, not completed, when nothing progresses for this long (simulated
            seconds); None or 0: never.
        reservation: ``site`` (conflicting tasks may run at once; their UAVs never work at their sites at once)
            or ``task`` (the paper: conflicting tasks never run at once); docs/safety.md.
        vehicle: the simulated autopilot's preset (:data:`masonry.sim.vehicle_config.VEHICLE_PRESETS`):
            ``ideal`` or ``arducopter``; None: :data:`~masonry.sim.vehicle_config.DEFAULT_VEHICLE`. Its
            control preset is the UAVs' tuning unless a tuning is given.
        max_wind_mps: the wind (mean at 10 m) above which mission control grounds a UAV, m/s: one figure for
            all or per UAV name (None: :data:`masonry.mission.wind_limit.DEFAULT_MAX_WIND_MPS`).
        airspace: ``columns`` (default) or ``table``: flights planned and reserved in a space-time table, no hold
            patience (:mod:`masonry.mission.reserved`, docs/safety.md).
        table_dispatch: under ``airspace="table"``: ``soonest`` (default), a brick UAV given, of the policy's
            top few, the task it can finish soonest by the table, or ``policy``, the policy's pick
            (:mod:`masonry.mission.table_dispatch`, docs/dispatch.md). No effect under the columns.

    Raises:
        InputError: an unknown policy, camera mode, reservation, airspace or table dispatch, a bad ``dt_s``, or ``resume`` without
            ``journal_path`` (one line naming the field).
        InvalidArgument: an unknown vehicle preset (the line names the presets).
    """

    brick_uavs: int | None = None
    adhesion_uavs: int | None = None
    policy: str = "critical-path"
    seed: int = 0
    camera: str = "geometric"
    journal_path: str | Path | None = None
    resume: bool = False
    dt_s: float = 0.05
    max_time_s: float | None = None
    heartbeat_timeout_s: float = 5.0
    max_attempts: int = 3
    separation: bool = True
    rising_layers: bool = True
    stall_timeout_s: float | None = DEFAULT_STALL_TIMEOUT_S
    reservation: str = DEFAULT_RESERVATION
    vehicle: str | None = None
    max_wind_mps: float | Mapping[str, float] | None = None
    airspace: str = DEFAULT_AIRSPACE
    table_dispatch: str = DEFAULT_TABLE_DISPATCH

    def __post_init__(self) -> None:
        if self.reservation not in RESERVATIONS:
            raise InputError(
                f"`reservation` must be one of {', '.join(RESERVATIONS)}, got {self.reservation!r}",
                options=("reservation",),
            )
        if self.policy not in DISPATCH_POLICIES and self.policy != SCHEDULE_POLICY:
            raise InputError(
                f"`policy` must be one of {', '.join(DISPATCH_POLICIES)}, got {self.policy!r}",
                options=("policy",),
            )
        if self.camera not in CAMERA_MODES:
            raise InputError(
                f"`camera` must be geometric, render or mixed, got {self.camera!r}", options=("camera",)
            )
        if not (self.dt_s > 0 and math.isfinite(self.dt_s)):
            raise InputError(f"dt_s must be > 0, got {self.dt_s!r}")
        if self.resume and self.journal_path is None:
            raise InputError("`resume` needs `journal_path`", options=("resume", "journal_path"))
        if self.airspace not in AIRSPACES:
            raise InputError(
                f"`airspace` must be one of {', '.join(AIRSPACES)}, got {self.airspace!r}",
                options=("airspace",),
            )
        if self.table_dispatch not in TABLE_DISPATCHES:
            raise InputError(
                f"`table_dispatch` must be one of {', '.join(TABLE_DISPATCHES)}, got {self.table_dispatch!r}",
                options=("table_dispatch",),
            )
        vehicle_preset(self.vehicle)  # InvalidArgument naming the presets


class SimFields(TypedDict, total=False):
    """The fields of :class:`SimOptions` as keywords (``simulate(bp, seed=3)``); a test keeps the two equal."""

    brick_uavs: int | None
    adhesion_uavs: int | None
    policy: str
    seed: int
    camera: str
    journal_path: str | Path | None
    resume: bool
    dt_s: float
    max_time_s: float | None
    heartbeat_timeout_s: float
    max_attempts: int
    separation: bool
    rising_layers: bool
    stall_timeout_s: float | None
    reservation: str
    vehicle: str | None
    max_wind_mps: float | Mapping[str, float] | None
    airspace: str
    table_dispatch: str


def with_fields(options: SimOptions | None, fields: SimFields) -> SimOptions:
    """``options`` (default: ``SimOptions()``) with ``fields`` replaced: what ``simulate(bp, options, **fields)``
    runs with."""
    base = options if options is not None else SimOptions()
    return dataclasses.replace(base, **fields) if fields else base
