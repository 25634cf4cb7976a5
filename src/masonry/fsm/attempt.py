"""One attempt at a task, both kinds of UAV: the task, its times, its tries, what it carries, what it measured.

The model owns one record, :attr:`masonry.fsm.model.UavModel.attempt`, and makes a fresh one each time it takes a
task (:meth:`~masonry.fsm.model.UavModel._start_task`); only the model and its states write it. What goes in is a
value: a frozen :class:`Takeoff` (replaced, never edited), floats, tuples. The brick UAV's record adds its
counters and the brick's estimate (:class:`BrickAttempt`), the adhesion UAV's its bead (:class:`AdhesionAttempt`).
The watchdogs read the model, not this record (:class:`masonry.fsm.watchdogs.Attempt`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from masonry.fsm.bead import BeadPass, BeadSettings


@dataclass(frozen=True)
class Takeoff:
    """A take-off asked of the autopilot: when it was last asked, how often, the climb asked for and the altitude it
    ends at (world, m): the ground measured when it was asked (after the arming) plus the climb, the one reference
    the autopilot climbs from and the machine waits on (issue 29)."""

    asked_s: float
    tries: int = 1
    climb_m: float = 0.0
    target_m: float = math.nan


@dataclass(frozen=True)
class Swing:
    """A gate state's running mean of the squared speed (kept by ``UavModel._gate_failure``, read by the swing gate)."""

    entered_s: float = math.nan  # the gate state's entry it belongs to
    tick_s: float = 0.0  # the tick it was last updated at
    mean_sq_mps2: float = 0.0  # exponentially weighted over ``swing_window_s`` (the machine's ``SWING_AXES``)


@dataclass
class TaskAttempt:
    """What both kinds of UAV keep of the task in hand: its times, its waiting and its take-off.

    Attributes:
        start_s: when the UAV took the task.
        waited_s: the seconds it has waited in the air for clearance so far.
        wait_budget_s: the waiting for clearance the task was taken with (the battery budget's).
        held_since_s: since when the task's transit has waited for clearance (the hold patience; None: not waiting).
        takeoff: the take-off asked for it (None: none yet).
    """

    start_s: float = 0.0
    waited_s: float = 0.0
    wait_budget_s: float = 0.0
    held_since_s: float | None = None
    takeoff: Takeoff | None = None


@dataclass
class BrickAttempt(TaskAttempt):
    """A brick UAV's attempt: the counters, the brick's estimate, the heights and yaws it flies."""

    climbs: int = 0
    grasp_attempts: int = 0
    place_attempts: int = 0
    release_attempts: int = 0
    brick_estimate: tuple[np.ndarray, float] | None = None  # top-face centre (world, m), yaw (rad)
    estimates_seen: int = 0
    hover_z: float = 0.0  # the estimate hover's altitude (0: where the UAV is)
    hover_xy: tuple[float, float] | None = None  # where the estimate hovers (None: where the UAV is)
    deadline_s: float = 0.0  # of the estimate
    off_s: float = 0.0  # the estimate's time blown off its hover point (not counted against its deadline)
    carry_yaw_rad: float = 0.0  # the carried brick's yaw relative to the body
    grasp_yaw_rad: float = 0.0  # the body's yaw at the grasp
    place_effector_target_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    release_error_m: float | None = None  # the effector's distance to its target at the release
    #: aligned on the wall for the wind (``UavConfig.wall_in_wind_rad``, masonry.fsm.wind_lean)
    in_wind: bool = False
    putback_reason: str = ""  # why the task was given up while the brick is being put back
    #: re-seats (masonry.fsm.reseat): made, the as-built look judged for one, when the glue under the brick closes
    #: (this UAV's clock; None: no open time said), when the placement began (place_align; nan: none under way)
    #: and how long the last one took to its release (s)
    reseats: int = 0
    reseat_judged: bool = False
    open_until_s: float | None = None
    place_began_s: float = math.nan
    placing_s: float = 0.0
    kept_on_board: str = ""  # flown home with the brick on the magnet: the failure reported once landed


def _no_bead() -> BeadPass:
    return BeadPass((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), BeadSettings(speed_mps=1.0))


@dataclass
class AdhesionAttempt(TaskAttempt):
    """An adhesion UAV's attempt: the hover's stillness, the lean it sprays at, and the bead's pass."""

    stable_since_s: float | None = None  # ``hover``: still since then (None: not still)
    #: the lean (roll, pitch) averaged from the hover on: a steady wind's, not a gust's
    lean_rad: tuple[float, float] = (0.0, 0.0)
    bead: BeadPass = field(default_factory=_no_bead)  # ``spray``'s (what the nozzle covered: its coverage)
    bead_tick_s: float = 0.0
    spray_deadline_s: float = 0.0
    spray_descents: int = 0  # ``descend``: the descents flown in this attempt (UavConfig.max_spray_descents)


__all__ = ["AdhesionAttempt", "BrickAttempt", "Swing", "Takeoff", "TaskAttempt"]
