"""One decision function: given the table and a UAV's request, grant its flight or tell it to wait where it is.

:func:`decide` is pure: the same table, request and time give the same answer, computed, never cached. A grant
carries the new table (the UAV's stay cut at the flight's start, the flight's reservations added); a wait says
until when the flight would not fit and whose reservations are in its way, or which holds keep it on the ground
(the operator, the wind: :mod:`~masonry.reservation.holds`), or that no layer keeps it inside the fence. Either way
the UAV holds only the place it stays at while it waits (its pad, a parking spot, its site), never shared air.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from masonry.errors import PlanningError
from masonry.reservation.flight import (
    Airspace,
    FlightPlan,
    Place,
    Request,
    blockers,
    fenced_layers,
    plan_flight,
)
from masonry.reservation.holds import Hold, held_until
from masonry.reservation.space import DEFAULT_SEPARATION, Separation
from masonry.reservation.table import Reservation, Table
from masonry.segments import XY


@dataclass(frozen=True)
class Grant:
    """The flight is granted: ``table`` holds it; the UAV leaves its stay at ``plan.start_s``."""

    table: Table
    plan: FlightPlan


@dataclass(frozen=True)
class Wait:
    """Not now: the UAV waits where it stays. The flight would fit from ``until_s`` on (``math.inf``: not while
    an open-ended reservation in ``blocked_by`` or a hold in ``held_by`` stands); ``blocked_by``: the reservations
    in its way now; ``held_by``: the holds that keep it on the ground; ``outside_fence``: no layer keeps the flight
    inside the fence (never granted)."""

    uav: str
    until_s: float
    blocked_by: tuple[Reservation, ...]
    held_by: tuple[Hold, ...] = ()
    outside_fence: bool = False

    @property
    def cause(self) -> str:
        """What it waits for: ``fence`` (never), a hold's cause (``operator``, ``wind``), else ``airspace``."""
        if self.outside_fence:
            return "fence"
        return self.held_by[0].cause if self.held_by else "airspace"

    @property
    def blocking_uavs(self) -> tuple[str, ...]:
        """The UAVs whose reservations are in the way, sorted."""
        return tuple(sorted({r.uav for r in self.blocked_by}))

    def describe(self) -> str:
        """One line: who waits, for whom, until when."""
        if self.outside_fence:
            return f"{self.uav}'s flight leaves the fence at every layer: never granted"
        when = "until they leave" if math.isinf(self.until_s) else f"until {self.until_s:.1f} s"
        why = "; ".join([*(h.describe() for h in self.held_by), *(r.describe() for r in self.blocked_by)])
        return f"{self.uav} waits {when}: {why or 'nothing now (the horizon)'}"


Decision = Grant | Wait


def start_table(
    homes: Mapping[str, XY], now_s: float = 0.0, separation: Separation = DEFAULT_SEPARATION
) -> Table:
    """A fleet on its pads: each UAV holds its pad from ``now_s``, open-ended.

    Raises:
        PlanningError: two pads closer than the pad separation (the message names them).
    """
    table = Table(separation=separation)
    return table.add(
        *(Reservation(u, Place(xy).volume(), now_s, math.inf, "stay") for u, xy in homes.items())
    )


def decide(table: Table, request: Request, now_s: float, airspace: Airspace) -> Decision:
    """Grant ``request``'s flight at the earliest time it fits, or tell the UAV to wait.

    Granted when its flight fits at a start no later than ``now_s + airspace.horizon_s``: the UAV's open-ended stay
    then ends at the start, and every reservation of the flight is added (the last one open-ended). A take-off (the
    UAV stays on the ground) starts outside every hold of its UAV (:mod:`~masonry.reservation.holds`); a flight is
    planned only at layers inside the fence (:attr:`Airspace.fence`). Otherwise a :class:`Wait` with the earliest
    start at which it would fit and the reservations in its way now, the holds that kept it on the ground, or
    ``outside_fence``.

    Raises:
        PlanningError: the UAV holds no open-ended stay (every UAV always has a place it may stay:
            :func:`start_table`), or a flight fits but its reservations clash (a bug: never expected).
    """
    uav, stay = request.uav, table.stay_of(request.uav)
    if stay is None:
        raise PlanningError(f"{uav} holds no place to stay in the table (start it with start_table)")
    if airspace.fence is not None and not fenced_layers(request, airspace):
        return Wait(uav, math.inf, (), outside_fence=True)
    from_s = max(now_s, stay.t0_s)
    holds = table.holds if stay.volume.kind == "ground" else ()  # (a take-off; in the air nothing holds it)
    t, held = held_until(holds, uav, from_s)
    while True:
        if math.isinf(t):
            return Wait(uav, math.inf, (), held)
        plan = plan_flight(table, request, t, airspace)
        if plan is None:
            return Wait(uav, math.inf, blockers(table, request, from_s, airspace, standing=True), held)
        t, more = held_until(holds, uav, plan.start_s)  # (it fits only inside a later hold: after that one)
        if t == plan.start_s:
            break
        held = (*held, *(h for h in more if h not in held))
    if plan.start_s > now_s + airspace.horizon_s:
        return Wait(uav, plan.start_s, blockers(table, request, from_s, airspace), held)
    # the stay ends as the flight starts (kept even if it ends as it begins: it marks the departure)
    left = table.ended(stay, plan.start_s)
    return Grant(left.add(*plan.reservations), plan)


__all__ = ["Decision", "Grant", "Wait", "decide", "start_table"]
