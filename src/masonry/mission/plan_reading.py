"""Mission control's reading of a UAV's ``plan_progress`` under the table (issue 27 §2.2; docs/safety.md, "The
UAV's plan progress").

Every answer that sets a UAV flying is numbered (:func:`grant_number`: one number per plan of the table, the same
number however often it is answered); the UAV reports the number of the flight it flies, the leg and the fraction
of it behind it (:class:`~masonry.ports.PlanProgress`). A report that names the UAV's current plan says which of
its legs under way it flies (:func:`reported_leg`): :class:`~masonry.mission.reserved.TableClearance` reads that
instead of inferring the leg from the reported position (``leg_now``, ``cut_behind``). A report with another
number (a flight before, an answer it has not flown yet), or none, moves nothing: the position rule decides, as
before. Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from masonry.mission.reserved_parts import on_from
from masonry.mission.reserved_requests import TableUav
from masonry.ports import PLAN_LEGS, PlanProgress
from masonry.reservation import Reservation

__all__ = ["grant_number", "matching", "reported_leg"]


def grant_number(u: TableUav) -> int:
    """The number of ``u``'s plan (its first answer numbers it: 1, 2, ... per UAV); 0: it has none, or flies a plan
    it turned back in on to where it may stay (``flown_on``: a hold flight whose legs are not the plan's)."""
    if u.plan is None or u.flown_on:
        return 0
    if u.numbered is not None and u.numbered[1] is u.plan:
        return u.numbered[0]
    u.grants += 1
    u.numbered = (u.grants, u.plan)
    return u.grants


def matching(u: TableUav, pp: PlanProgress | None) -> PlanProgress | None:
    """``pp`` if it is about ``u``'s current plan (the number its answer gave it), else None."""
    if pp is None or u.plan is None or u.numbered is None or u.numbered[1] is not u.plan:
        return None
    return pp if pp.grant == u.numbered[0] else None


def reported_leg(u: TableUav, legs: Sequence[Reservation], now_s: float) -> int | None:
    """The index in ``legs`` (``u``'s legs under way, in plan order) of the leg its last report says it flies, or
    None: no report about its current plan (:func:`matching`), or that leg's window is over (the position rule
    decides). A transit's piece is the one its fraction falls in, of the plan's pieces (those flown out of are no
    longer under way). At the end of that leg, inside the next one whose window has begun, it is in that one
    (:func:`~masonry.mission.reserved_parts.on_from`: at the top of its climb, settling there, it is on its transit:
    not late in its climb, as ``climb50`` found)."""
    pp = matching(u, u.reported)
    if pp is None or u.plan is None:
        return None
    purpose = PLAN_LEGS[pp.leg]  # (a leg of PLAN_LEGS is the table's leg of the same purpose)
    mine = [i for i, r in enumerate(legs) if r.purpose == purpose]
    if not mine:
        return None
    at = mine[0]
    if purpose == "transit":
        pieces = sum(1 for r in u.plan.reservations if r.purpose == "transit")
        k = min(pieces - 1, math.floor(pp.leg_fraction * pieces)) - (pieces - len(mine))
        at = mine[max(0, min(k, len(mine) - 1))]
    return on_from(legs, at, u.position, now_s)
