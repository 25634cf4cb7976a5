"""The UAV machines' watchdogs: the cross-cutting checks, declared as data beside the states they guard.

Each tick, before the current state's ``do_<state>`` work, :meth:`masonry.fsm.model.UavModel.step` runs the
watchdogs that guard that state, in the order declared, each a small pure function
``check(now_s, telemetry, attempt) -> Abort | None``: it reads, and returns what to do, and the model's one
dispatcher acts on it (:meth:`~masonry.fsm.model.UavModel._react`). The timers the checks read (since when the
link is down, since when the transit has waited for clearance, since when the UAV is outside its fence) are the
model's bookkeeping, kept before the checks run. With the flight controller's link down only the watchdogs that
read no telemetry (``needs_link=False``) run, and the tick ends there. ``masonry fsm diagram`` draws the list
(docs/state-machines.md, "Watchdogs").

A new watchdog is one declaration: ``Watchdog("marker_lost", ("pickup_estimate",), check)`` added to a model's
``watchdogs`` (docs/architecture.md, "Where a new thing goes").
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, Protocol

from masonry.fsm.config import UavConfig
from masonry.fsm.fence import FenceWatch
from masonry.fsm.states import ADHESION_TASK_STATES, BRICK_TASK_STATES
from masonry.planner.tasks import Task
from masonry.ports import Telemetry

#: What the machine does on an :class:`Abort`: ``abort`` gives the task up (failsafe, then home; a brick UAV
#: puts its brick back first), ``battery_low`` does so and retires the UAV after landing unless its ground crew
#: swaps batteries, ``land`` lands where it is (``lost``: the emergency), ``retire`` takes a UAV on the ground
#: out of service, ``give_up`` leaves an emergency to the autopilot (``halted``).
Action = Literal["abort", "battery_low", "land", "retire", "give_up"]
#: The machine's trigger per action (masonry.fsm.states).
TRIGGERS: dict[str, str] = {
    "abort": "abort",
    "battery_low": "abort",
    "land": "lost",
    "retire": "retire",
    "give_up": "giveup",
}
#: In a watchdog's ``states``: every state of the machine ...
ANY = "*"
#: ... or the states in which a task is under way (the machine's task states: takeoff, pickup...).
TASK = "task"


@dataclass
class Failsafe:
    """The flight controller's link (the link watch reads it) and the emergency landing (``enter_emergency``)."""

    link_down_since_s: float | None = None  # when the link went down (None: it is up)
    mode: str | None = None  # the autopilot's mode when the emergency began
    land_pending: bool = False  # emergency: LAND still to be commanded
    land_tried_s: float = -math.inf
    flight_mode: str | None = (
        None  # the autopilot's mode masonry flies in (its mode at the end of the take-off)
    )
    foreign_mode_since_s: float | None = (
        None  # since when the autopilot reports another mode (None: it does not)
    )


@dataclass(frozen=True)
class Abort:
    """A watchdog's verdict: why, and what the machine does (:data:`Action`)."""

    reason: str
    action: Action = "abort"


class Attempt(Protocol):
    """What a watchdog may read of the UAV and its attempt at the task in hand (the model; read only)."""

    @property
    def state(self) -> str: ...
    @property
    def task(self) -> Task | None: ...
    @property
    def config(self) -> UavConfig: ...
    @property
    def entered_s(self) -> float: ...
    @property
    def failsafe(self) -> Failsafe: ...
    @property
    def held_since_s(self) -> float | None: ...
    @property
    def fence_watch(self) -> FenceWatch | None: ...
    @property
    def task_states(self) -> frozenset[str]: ...
    def battery_short(self, tel: Telemetry) -> str | None: ...
    def site_text(self) -> str: ...


Check = Callable[[float, Telemetry, Attempt], "Abort | None"]


@dataclass(frozen=True)
class Watchdog:
    """A named check and the states it guards (names: a leaf ``pickup_align``, a parent ``pickup`` for all its
    children, :data:`TASK` or :data:`ANY`); ``needs_link=False``: it runs while the link is down, and alone."""

    name: str
    states: tuple[str, ...]
    check: Check
    needs_link: bool = True

    def guards(self, state: str, task_states: frozenset[str] = frozenset()) -> bool:
        """Does this watchdog run in leaf ``state`` (``task_states``: the machine's, for :data:`TASK`)?"""
        return _guards(self.states, state, task_states)


@functools.lru_cache(maxsize=4096)  # asked for every watchdog on every tick: a few dozen distinct answers
def _guards(names: tuple[str, ...], state: str, task_states: frozenset[str]) -> bool:
    return (
        ANY in names
        or state in names
        or state.split("_")[0] in names
        or (TASK in names and state in task_states)
    )


def link_watch(now_s: float, tel: Telemetry, a: Attempt) -> Abort | None:
    """The flight controller's link is down: land (``lost``) when flying; on the ground out of service after
    ``link_lost_timeout_s``; in an emergency left to the autopilot once down or past that timeout."""
    since_s = a.failsafe.link_down_since_s
    if tel.link_ok or since_s is None:
        return None
    late = now_s - since_s > a.config.link_lost_timeout_s
    reason = "flight controller link lost"
    if a.state == "idle":  # landed with a silent flight controller: tasks go to other UAVs
        return Abort(reason, "retire") if late else None
    if a.state == "emergency":
        return Abort(reason, "give_up") if tel.on_ground or late else None
    return Abort(reason, "land")


#: Task states after the brick has left the magnet on the wall: the work is done, what is left is the climb out
#: (which the way home begins with anyway), so a low battery does not give the task up there. Given up, the placed
#: brick's task went back to the queue and its next attempt looked for the brick at its pickup ("not seen near its
#: pickup after 3 climbs"): the wall stranded behind a brick that was on it.
WORK_DONE_STATES = ("place_verify", "place_ascend", "reseat_descend", "reseat_grasp")


def battery_watch(now_s: float, tel: Telemetry, a: Attempt) -> Abort | None:
    """The battery cannot carry on with the task (the model's budget, masonry.fsm.battery): give it up (not
    once the brick is released on the wall: :data:`WORK_DONE_STATES`)."""
    if a.state in WORK_DONE_STATES:
        return None
    short = a.battery_short(tel)
    return None if short is None else Abort(short, "battery_low")


def hold_watch(now_s: float, tel: Telemetry, a: Attempt) -> Abort | None:
    """The task's transit has waited for clearance (asking, or at a hold point) longer than ``hold_patience_s``:
    give the task up, which frees the UAV's hold volume. UAVs that hold where each other's sites are could
    otherwise wait for each other until their batteries run low (docs/safety.md)."""
    since_s, patience_s = a.held_since_s, a.config.hold_patience_s
    if since_s is None or patience_s is None or now_s - since_s <= patience_s:
        return None
    return Abort(
        f"held {now_s - since_s:.0f} s for clearance to {a.site_text()}, longer than hold_patience_s"
    )


def fence_watch(now_s: float, tel: Telemetry, a: Attempt) -> Abort | None:
    """Outside the site fence beyond its margin: during a task give it up (it hovers inside its clamped setpoint,
    then flies home); still outside ``fence_return_s`` later, land where it is (masonry.fsm.fence)."""
    watch = a.fence_watch
    if watch is None or tel.on_ground or watch.since_s is None:
        return None
    x, y, z = (float(v) for v in tel.position_m)
    where = f"outside by {watch.outside_m:.2f} m at ({x:.2f}, {y:.2f}, {z:.2f})"
    if a.task is not None and a.state in a.task_states:
        return Abort(f"outside the site fence by {watch.outside_m:.2f} m at ({x:.2f}, {y:.2f}, {z:.2f})")
    if watch.out_for_s(now_s) > a.config.fence_return_s:
        return Abort(
            f"could not get back inside the site fence within {a.config.fence_return_s:.0f} s ({where}): "
            "landing where it is",
            "land",
        )
    return None


#: Seconds the autopilot must report a mode other than the one masonry flies in before the autopilot counts as
#: having taken the vehicle: more than one HEARTBEAT period (1 s), so that a heartbeat sent before the mode change
#: and heard after it is no take-over.
MODE_TAKEN_S = 2.0


def autopilot_mode_watch(now_s: float, tel: Telemetry, a: Attempt) -> Abort | None:
    """The autopilot has taken the vehicle (its failsafe switched it out of the mode masonry flies in, to RTL or
    LAND; or a pilot did): stop flying it, without a LAND of masonry's (``land``: the emergency, which commands
    nothing then), and leave it to the autopilot once there (``give_up``: halted, the task failed) unless it is
    landing the vehicle (then halted on the ground)."""
    fs = a.failsafe
    if fs.flight_mode is None:
        return None
    if a.state == "emergency":  # entered over a mode the autopilot chose: nothing left for masonry to do (a
        # landing is watched to the ground, as before: it ends; an RTL, a hold may not for minutes)
        taken = taken_over(fs) and not tel.landing
        return Abort(f"the autopilot has the vehicle (mode {tel.mode})", "give_up") if taken else None
    since_s = fs.foreign_mode_since_s
    if a.state == "takeoff" or since_s is None or now_s - since_s < MODE_TAKEN_S:
        return None
    return Abort(
        f"{a.config.name}: the autopilot took control: mode {tel.mode}, not requested (masonry flies in "
        f"{fs.flight_mode})",
        "land",
    )


def taken_over(fs: Failsafe) -> bool:
    """The emergency began in a mode the autopilot chose (not the one masonry flies in): masonry commands nothing."""
    return fs.flight_mode is not None and fs.mode is not None and fs.mode != fs.flight_mode


def standard(*, putback: bool = False) -> tuple[Watchdog, ...]:
    """Every UAV's watchdogs, in the order they run (``putback``: the brick machine's putback states too)."""
    airborne = (TASK, *(("putback",) if putback else ()), "home", "failsafe")
    return (
        Watchdog("link", (ANY,), link_watch, needs_link=False),
        Watchdog("battery", (TASK,), battery_watch),
        Watchdog("hold", (TASK,), hold_watch),
        Watchdog("fence", airborne, fence_watch),
        Watchdog("autopilot", (*airborne, "emergency"), autopilot_mode_watch),
    )


BRICK_WATCHDOGS: tuple[Watchdog, ...] = standard(putback=True)
ADHESION_WATCHDOGS: tuple[Watchdog, ...] = standard()
#: The declared watchdogs per machine, and its task states (for :data:`TASK`), for the diagrams.
WATCHDOGS: dict[str, tuple[tuple[Watchdog, ...], tuple[str, ...]]] = {
    "brick": (BRICK_WATCHDOGS, tuple(BRICK_TASK_STATES)),
    "adhesion": (ADHESION_WATCHDOGS, tuple(ADHESION_TASK_STATES)),
}


def for_kind(kind: str) -> tuple[Watchdog, ...]:
    """The watchdogs a UAV of ``kind`` (``brick``, ``adhesion``) runs; any other: :func:`standard`."""
    return WATCHDOGS[kind][0] if kind in WATCHDOGS else standard()


def guarded_states(kind: str) -> list[tuple[str, tuple[str, ...]]]:
    """Each watchdog of machine ``kind`` and the (top-level) states it guards, as the diagrams label them."""
    dogs, task_states = WATCHDOGS[kind]
    out: list[tuple[str, tuple[str, ...]]] = []
    for dog in dogs:
        names: list[str] = []
        for s in dog.states:
            names.extend(task_states if s == TASK else ["all but halted"] if s == ANY else [s])
        out.append((dog.name, tuple(names)))
    return out


__all__ = [
    "ADHESION_WATCHDOGS",
    "ANY",
    "BRICK_WATCHDOGS",
    "MODE_TAKEN_S",
    "TASK",
    "TRIGGERS",
    "WATCHDOGS",
    "WORK_DONE_STATES",
    "Abort",
    "Action",
    "Attempt",
    "Check",
    "Failsafe",
    "Watchdog",
    "autopilot_mode_watch",
    "battery_watch",
    "fence_watch",
    "for_kind",
    "guarded_states",
    "hold_watch",
    "link_watch",
    "standard",
    "taken_over",
]
