"""The space-time reservation model (issue 27): who may be where, and when, as one pure table.

- :mod:`~masonry.reservation.space`: volumes (columns, swept legs, pads, the paper's site rule) and the
  separation between them;
- :mod:`~masonry.reservation.table`: :class:`Reservation` and the :class:`Table` that never holds two of
  different UAVs overlapping in space and time;
- :mod:`~masonry.reservation.flight`: :func:`plan_flight`, timed legs at the lowest free layer, earliest start
  first, ending where the UAV may stay;
- :mod:`~masonry.reservation.decide`: :func:`decide`, grant or wait;
- :mod:`~masonry.reservation.probe`: :func:`soonest_done`, how soon a UAV could finish a task's site visits by the
  table, nothing reserved (airspace-aware dispatch);
- :mod:`~masonry.reservation.changes`: running late, silence and loss as reservations;
- :mod:`~masonry.reservation.holds` and :mod:`~masonry.reservation.fence`: the operator's pause and recall and the
  wind limit as holds on take-offs, the site's fence as the space every flown leg keeps inside;
- :mod:`~masonry.reservation.layout`: the layout the deadlock-freedom argument needs.

Mission control runs it under ``--airspace table`` (``masonry.mission.reserved``; docs/safety.md, "The table at run
time") and asks :func:`soonest_done` which brick a UAV could finish soonest (``masonry.mission.table_dispatch``).
Pure: standard library and masonry's pure values only.
"""

from __future__ import annotations

from masonry.reservation.changes import Move, extend, lose, settle, way_home
from masonry.reservation.decide import Decision, Grant, Wait, decide, start_table
from masonry.reservation.fence import Fence, keeps_inside
from masonry.reservation.flight import (
    DEFAULT_MARGIN_S,
    LEG_PIECE_M,
    Airspace,
    FlightPlan,
    Place,
    Request,
    Work,
    earliest_start,
    fenced_layers,
    flight_reservations,
    plan_flight,
)
from masonry.reservation.holds import HOLD_CAUSES, Hold, held_until, with_holds
from masonry.reservation.layout import layout_problems
from masonry.reservation.probe import soonest_done, soonest_order
from masonry.reservation.space import DEFAULT_SEPARATION, Separation, Volume, column, leg, pad, site
from masonry.reservation.table import PURPOSES, Reservation, Table, clash, violations

__all__ = [
    "DEFAULT_MARGIN_S",
    "DEFAULT_SEPARATION",
    "HOLD_CAUSES",
    "LEG_PIECE_M",
    "PURPOSES",
    "Airspace",
    "Decision",
    "Fence",
    "FlightPlan",
    "Grant",
    "Hold",
    "Move",
    "Place",
    "Request",
    "Reservation",
    "Separation",
    "Table",
    "Volume",
    "Wait",
    "Work",
    "clash",
    "column",
    "decide",
    "earliest_start",
    "extend",
    "fenced_layers",
    "flight_reservations",
    "held_until",
    "keeps_inside",
    "layout_problems",
    "leg",
    "lose",
    "pad",
    "plan_flight",
    "settle",
    "site",
    "soonest_done",
    "soonest_order",
    "start_table",
    "violations",
    "way_home",
    "with_holds",
]
