"""A lateral leg reserved in pieces (issue 27, ``Airspace.piece_m``, docs/safety.md "The table at run time"):
the air a UAV has flown out of is free before its leg ends, so a UAV waiting over a site next to where another
leaves it may come down as soon as the other is past, not when the other's whole leg ends."""

from __future__ import annotations

import math

import pytest

from masonry.errors import InvalidArgument
from masonry.reservation import (
    LEG_PIECE_M,
    Airspace,
    Grant,
    Place,
    Request,
    Reservation,
    Table,
    Wait,
    column,
    decide,
)
from masonry.reservation.flight import min_jerk_time_fraction
from masonry.timing import min_jerk_leg_s

#: the bundled pyramid's transit layers (the first at its first course's work altitude)
LAYERS_M = (1.2, 2.3, 3.4, 4.5)


def test_the_time_fraction_inverts_the_minimum_jerk_profile() -> None:
    for f in (0.0, 0.1, 0.25, 0.5, 0.9, 1.0):
        u = min_jerk_time_fraction(f)
        assert u**3 * (10 - 15 * u + 6 * u * u) == pytest.approx(f, abs=1e-9)
    assert min_jerk_time_fraction(0.5) == pytest.approx(0.5)


def _leaving(air: Airspace) -> tuple[Table, tuple[Reservation, ...]]:
    """``b`` leaves its site at (0, 0) for its pad 8 m away at the first layer over it; ``a`` hovers at 3.4 m
    over (0.6, 0), next to where ``b`` climbs out."""
    table = Table().add(
        Reservation("b", column((0.0, 0.0), 0.0, 1.2), 0.0, math.inf, "stay"),
        Reservation("a", column((0.6, 0.0), 3.4, 3.4), 0.0, math.inf, "stay"),
    )
    grant = decide(table, Request("b", Place((0.0, 0.0), 1.2, "site"), None, Place((0.0, -8.0))), 0.0, air)
    assert isinstance(grant, Grant)
    return grant.table, grant.plan.reservations


def _down_at(table: Table, air: Airspace) -> float:
    """The earliest time ``a``'s hop down to its site under it fits (asked every 0.1 s)."""
    down = _req()
    for k in range(600):
        if isinstance(decide(table.prune(k / 10), down, k / 10, air), Grant):
            return k / 10
    return math.inf


def test_a_uav_comes_down_as_soon_as_a_leaving_uav_is_past_not_when_its_leg_ends() -> None:
    whole = Airspace(
        LAYERS_M, margin_s=2.0, horizon_s=0.0
    )  # (as mission control: granted only if it fits now)
    pieces = Airspace(LAYERS_M, margin_s=2.0, horizon_s=0.0, piece_m=LEG_PIECE_M)
    table_w, plan_w = _leaving(whole)
    table_p, plan_p = _leaving(pieces)
    legs_w = [r for r in plan_w if r.purpose == "transit"]
    legs_p = [r for r in plan_p if r.purpose == "transit"]
    assert len(legs_w) == 1 and len(legs_p) == 8  # 8 m in pieces of 1 m
    # the same flight: the same layer, the leg's start and its end; each piece held from the leg's start
    assert legs_p[0].t0_s == legs_w[0].t0_s and legs_p[-1].t1_s == legs_w[0].t1_s
    assert all(r.t0_s == legs_w[0].t0_s for r in legs_p)
    assert [r.t1_s for r in legs_p] == sorted(r.t1_s for r in legs_p)
    transit_s = min_jerk_leg_s(8.0, pieces.cruise_mps)
    assert legs_p[0].t1_s == pytest.approx(legs_p[0].t0_s + transit_s * min_jerk_time_fraction(1 / 8) + 2.0)
    # a: with the whole leg it waits for b's whole leg; with pieces only until b is out of its way
    whole_s, pieces_s = _down_at(table_w, whole), _down_at(table_p, pieces)
    assert 10.0 < whole_s < math.inf  # (its hop down reaches b's layer as b's whole leg ends: 12.9 s)
    assert pieces_s < whole_s - 6.0  # (3.3 s: b's climb and its first metre, with the margin)
    assert isinstance(decide(table_p.prune(pieces_s - 0.2), _req(), pieces_s - 0.2, pieces), Wait)


def _req() -> Request:
    return Request("a", Place((0.6, 0.0), 3.4, "site"), None, Place((0.6, 0.0), 1.3, "site"))


def test_the_piece_length_is_checked() -> None:
    with pytest.raises(InvalidArgument, match="piece length"):
        Airspace(LAYERS_M, piece_m=-1.0)
