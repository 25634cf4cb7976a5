"""How soon could a UAV finish each of a few tasks, by the table? Asked of the table, nothing reserved (issue 27 §1.6).

A task is its *visits*: the sites its UAV flies to in turn and works at (a brick: its pickup, then its drop-off;
an adhesion segment: the segment). :func:`soonest_done` plans each visit's flight as :func:`~masonry.reservation.
decide` would (:func:`~masonry.reservation.flight.plan_flight`: the earliest start at which every leg, the work
zone and the stay there are free of the other UAVs' reservations, from where the UAV stays, no earlier than its
stay begins), adds the work's duration, and flies on from there to the next visit. The table is a value and is
not changed: the answer is what the table holds *now*, so the first visit's arrival is exactly what ``decide``
would grant on this table, and the later ones are a lower bound of what it will (others may reserve meanwhile).

:func:`soonest_order` ranks a UAV's candidates by that time (ties by their order: the dispatch policy's).
Pure: no I/O, no clock (times are passed in).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from masonry.errors import PlanningError
from masonry.reservation.flight import Airspace, Place, Request, Work, plan_flight
from masonry.reservation.table import Table

__all__ = ["soonest_done", "soonest_order"]


def soonest_done(
    table: Table,
    uav: str,
    start: Place,
    visits: Sequence[Work],
    now_s: float,
    airspace: Airspace,
) -> float:
    """The earliest time ``uav``, staying at ``start``, could have flown to each of ``visits`` in turn and worked
    there (``math.inf``: a flight never fits while an open-ended reservation of another UAV stands in its way).

    The first flight starts no earlier than ``now_s`` and than ``uav``'s stay in ``table`` begins (a UAV still
    flying to it leaves it after it is there), as in :func:`~masonry.reservation.decide`; each later one when the
    work before it is done, from where that work ended. No horizon: a flight that would wait is counted with its
    wait. ``table`` is not changed.

    Raises:
        PlanningError: ``visits`` is empty.
    """
    if not visits:
        raise PlanningError(f"{uav}'s task has no site to visit")
    stay = table.stay_of(uav)
    t = now_s if stay is None else max(now_s, stay.t0_s)
    here = start
    for work in visits:
        plan = plan_flight(table, Request(uav, here, work, None), t, airspace)
        if plan is None:
            return math.inf
        t = plan.stay.t0_s + work.duration_s  # (arrived where it works, then the work)
        here = work.end_place()
    return t


def soonest_order(
    table: Table,
    uav: str,
    start: Place,
    candidates: Sequence[Sequence[Work]],
    now_s: float,
    airspace: Airspace,
) -> tuple[int, tuple[float, ...]]:
    """The index of the candidate (its visits) ``uav`` could finish soonest (:func:`soonest_done`), the first of
    equal ones (``candidates`` come in the dispatch policy's order), and each candidate's time.

    Raises:
        PlanningError: no candidates, or a candidate with no visits.
    """
    if not candidates:
        raise PlanningError(f"{uav} has no candidate task to choose from")
    done = tuple(soonest_done(table, uav, start, visits, now_s, airspace) for visits in candidates)
    best = min(range(len(done)), key=lambda k: (done[k], k))
    return best, done
