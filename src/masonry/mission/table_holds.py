"""Under ``--airspace table``: the operator's pause and recall and the wind limit as holds on the table, and the
fence's refusal when no layer of the table keeps a flight inside it.

The operator (:mod:`masonry.mission.operator`) and the wind limit (:mod:`masonry.mission.wind_limit`) say who may
not fly; :func:`sync` makes that the table's :class:`~masonry.reservation.Hold` s (a pause or an abort: every UAV,
cause ``operator``; a recall: that UAV; a wind grounding: each UAV above its ``max_wind_mps``, cause ``wind``), from
the moment they are said until they are lifted. ``decide`` then starts no take-off inside them: a landed UAV that
has a task waits on its pad, the hold named in its task's ``waits`` (:func:`held_cause`). Dispatch gives a held
UAV no task, reading the table's holds (:func:`holding`), and a UAV in the air finishes its task and flies home,
as under the columns (docs/safety.md, "The table at run time"). Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.mission.airspace import ColumnClearance
from masonry.mission.airspace_state import FlightRequest, Grant
from masonry.mission.fence import flight_fence_problem
from masonry.reservation import HOLD_CAUSES, Wait, with_holds

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl
    from masonry.mission.reserved import TableClearance

__all__ = ["fence_refusal", "held_cause", "holding", "is_held", "sync", "wanted"]


def wanted(mc: MissionControl) -> set[tuple[str, frozenset[str]]]:
    """The holds ``mc``'s operator and wind limit ask for now: (cause, UAVs; empty: every UAV)."""
    op, wind = mc.operator, mc.wind_limit
    out: set[tuple[str, frozenset[str]]] = {("operator", frozenset())} if op.holds_dispatch() else set()
    out.update(("operator", frozenset({name})) for name in op.held)
    if wind is not None:
        out.update(("wind", frozenset({name})) for name in wind.grounded)
    return out


def sync(mc: MissionControl, now_s: float) -> None:
    """Under the table (with airspace rules): its holds are :func:`wanted`'s from ``now_s`` (a change: waiting
    requests are looked at again). Under the columns nothing."""
    c = mc.columns
    if isinstance(c, ColumnClearance) or c.base_m is None:
        return
    want = wanted(mc)
    if want == {(h.cause, h.uavs) for h in c.table.holds if math.isinf(h.t1_s)}:
        return  # (nothing changed: the table, its clock and its version stay as they are)
    c.tick(now_s)  # (the table's clock: a hold from now covers a take-off asked now)
    c.table = with_holds(c.table, want, c.now_s)
    c.bump()


def holding(mc: MissionControl, uav: str) -> frozenset[str] | None:
    """The causes of the table's holds that bind ``uav`` now (what dispatch reads under the table, with airspace
    rules: :func:`sync` made them this tick from the operator and the wind limit, before dispatch); None under the
    columns or without airspace rules (no holds on the table: dispatch asks the operator and the wind limit)."""
    c = mc.columns
    if isinstance(c, ColumnClearance) or c.base_m is None:
        return None
    return frozenset(h.cause for h in c.table.holds if h.covers(uav, mc.now_s))


def held_cause(decision: Wait) -> tuple[tuple[str, str], ...]:
    """A wait's ``blocked_by`` entry for a hold that keeps its UAV on the ground: ``("-", cause)`` (the task's
    wait is then the hold's cause, :func:`masonry.mission.wait_causes.airspace_cause`); empty: no hold."""
    return tuple(("-", h.cause) for h in decision.held_by[:1])


def is_held(blocked_by: tuple[tuple[str, str], ...] | list[tuple[str, str]]) -> str | None:
    """The hold's cause if ``blocked_by`` (an airspace's answer) says a hold keeps the UAV on the ground."""
    if blocked_by and blocked_by[0][0] == "-" and blocked_by[0][1] in HOLD_CAUSES:
        return blocked_by[0][1]
    return None


def fence_refusal(c: TableClearance, uav: str, w: FlightRequest) -> Grant:
    """No layer of the table keeps ``uav``'s flight inside the fence (``Wait.outside_fence``): refused with the
    reason, as :func:`masonry.mission.reserved_requests.check_fence` refuses (the task then fails, saying why)."""
    start = w.position if w.position is not None else w.site
    reason = None
    if c.fence is not None:
        layers = c.airspace.layers_m
        reason = flight_fence_problem(c.fence, start, w.site, w.top_m, w.to, layers, c.zone_r_m)
    if reason is None:
        x, y, z = w.site
        reason = (
            f"the flight from ({start[0]:.2f}, {start[1]:.2f}) to ({x:.2f}, {y:.2f}, {z:.2f}) leaves the site "
            "fence at every layer of the table"
        )
    c.fence_refusals[uav] = reason
    c.refused += 1
    return Grant(uav, w.site, False, refused=reason)
