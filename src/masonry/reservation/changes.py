"""What running late, silence and loss do to the table: they are reservations too (pure: no I/O, no clock).

- :func:`extend`: a UAV behind its plan by more than the margin has its remaining windows extended; the plans of
  others that then clash and have not started move later, and each move is returned (:class:`Move`), visibly.
- :func:`way_home`: a silent UAV's fallback flight home, reserved from now for the time it takes (it cannot
  wait: the plans of others in its way move instead).
- :func:`lose`: a lost UAV's last volume stays reserved, open-ended, until it is accounted for
  (:meth:`masonry.reservation.table.Table.release`); plans not under way that need that space are withdrawn.

Plans move whole: a UAV whose plan moves waits longer where it stays before it (its pad, a parking spot, its
site), never in the air. A plan under way (its UAV left its stay) never moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from masonry.errors import PlanningError
from masonry.reservation.fence import keeps_inside
from masonry.reservation.flight import (
    Airspace,
    FlightPlan,
    Place,
    Request,
    earliest_start,
    flight_reservations,
)
from masonry.reservation.space import Volume
from masonry.reservation.table import Reservation, Table, clash


@dataclass(frozen=True)
class Move:
    """A reservation moved (or lengthened) to make room: what it was, what it is now (a window that ends as it
    begins: withdrawn, no longer in the table)."""

    before: Reservation
    after: Reservation

    @property
    def uav(self) -> str:
        return self.before.uav

    def describe(self) -> str:
        """One line: whose reservation moved, from when to when."""
        end = "open-ended" if self.after.open_ended else f"{self.after.t1_s:.1f} s"
        return f"{self.before.describe()} -> from {self.after.t0_s:.1f} s to {end}"


def _departure_s(table: Table, r: Reservation) -> float:
    """When ``r``'s UAV leaves the stay before the plan ``r`` belongs to (-inf: it never held one before it)."""
    ends = [q.t1_s for q in table.of(r.uav) if q.purpose == "stay" and not q.open_ended and q.t1_s <= r.t0_s]
    return max(ends, default=-math.inf)


def _clash_pair(table: Table) -> tuple[Reservation, Reservation] | None:
    rs = table.reservations
    for i in range(len(rs)):
        for j in range(i + 1, len(rs)):
            if clash(rs[i], rs[j], table.separation):
                return rs[i], rs[j]
    return None


def _move_plan(table: Table, r: Reservation, departure_s: float) -> tuple[Table, list[Move]]:
    """``r``'s plan (its UAV's reservations from ``departure_s`` on) moved to the earliest start at which it
    clashes with nobody; the stay before it lengthened to the new start."""
    mine = table.of(r.uav)
    waited = [q for q in mine if q.purpose == "stay" and q.t1_s == departure_s]
    plan = [q for q in mine if q.t0_s >= departure_s and q not in waited]
    parts = [(q.volume, q.t0_s - departure_s, q.t1_s - departure_s) for q in plan]
    start_s, _ = earliest_start(table, r.uav, parts, departure_s)
    if math.isinf(start_s):
        raise PlanningError(
            f"no room is ever made for {r.describe()}: an open-ended reservation is in its way"
        )
    delta = start_s - departure_s
    moves = [Move(q, q.shifted(delta)) for q in plan] + [Move(q, q.until(q.t1_s + delta)) for q in waited]
    out = table.without([m.before for m in moves])
    return replace(out, reservations=(*out.reservations, *(m.after for m in moves))), moves


def _hold(table: Table, uav: str, now_s: float) -> tuple[Table, list[Move]]:
    """``uav``'s windows still to come moved to the earliest time they clash with nobody; the windows it is in now
    lengthened to match (it stays where it is: at its site, its pad or a parking spot)."""
    mine = table.of(uav)
    later = [q for q in mine if q.t0_s > now_s]
    t0 = min(q.t0_s for q in later)
    parts = [(q.volume, q.t0_s - t0, q.t1_s - t0) for q in later]
    start_s, _ = earliest_start(table, uav, parts, t0)
    now = [q for q in mine if q.t0_s <= now_s < q.t1_s and not q.open_ended]
    if math.isinf(start_s) or any(q.purpose in ("climb", "transit", "descend", "home") for q in now):
        raise PlanningError(f"{uav} cannot wait where it is at {now_s:.1f} s: a plan under way is in its way")
    delta = start_s - t0
    moves = [Move(q, q.shifted(delta)) for q in later] + [Move(q, q.until(q.t1_s + delta)) for q in now]
    out = table.without([m.before for m in moves])
    return replace(out, reservations=(*out.reservations, *(m.after for m in moves))), moves


def settle(table: Table, now_s: float, first: str) -> tuple[Table, tuple[Move, ...]]:
    """``table`` without clashes: the plans of others that clash with ``first``'s move later (cascading); a plan
    under way (departed by ``now_s``) never moves: if one is in the way of ``first``'s windows still to come,
    ``first`` waits where it is now (a site or a stay, never in the air) and those windows move instead.

    Raises:
        PlanningError: no move makes room (two plans under way clash, or ``first`` would have to wait in the air);
            the message names them.
    """
    moves: list[Move] = []
    for _ in range(8 * len(table.reservations) + 8):
        pair = _clash_pair(table)
        if pair is None:
            return table, tuple(moves)
        movable = [(r, d) for r in pair if r.uav != first and (d := _departure_s(table, r)) > now_s]
        if movable:
            r, departure_s = max(movable, key=lambda rd: rd[1])
            table, moved = _move_plan(table, r, departure_s)
        else:
            # a plan under way is in the way of one of first's windows still to come: first waits where it is
            own = [r for r in pair if r.uav == first and r.t0_s > now_s]
            if not own:
                raise PlanningError(
                    f"{pair[0].describe()} and {pair[1].describe()} clash and neither can move"
                )
            table, moved = _hold(table, first, now_s)
        moves.extend(moved)
    raise PlanningError("moving plans to make room does not settle (a cycle of moves)")


def extend(table: Table, uav: str, now_s: float, late_s: float) -> tuple[Table, tuple[Move, ...]]:
    """``uav`` is ``late_s`` behind its plan at ``now_s``: its window under way ends ``late_s`` later, its later
    windows start ``late_s`` later; the others' plans in the way move (returned, with ``uav``'s own changes)."""
    if not late_s > 0.0:
        return table, ()
    own: list[Move] = []
    for r in table.of(uav):
        if r.t1_s <= now_s or (r.open_ended and r.t0_s <= now_s):
            continue
        after = r.until(r.t1_s + late_s) if r.t0_s <= now_s else r.shifted(late_s)
        own.append(Move(r, after))
    out = table.without([m.before for m in own])
    table = replace(out, reservations=(*out.reservations, *(m.after for m in own)))
    table, moved = settle(table, now_s, uav)
    return table, (*own, *moved)


def way_home(
    table: Table, uav: str, now_s: float, where: Place, home: Place, airspace: Airspace
) -> tuple[Table, FlightPlan, tuple[Move, ...]]:
    """Reserve a silent ``uav``'s flight from ``where`` home from ``now_s`` on (replacing what it held from then):
    at the lowest layer where it clashes with nobody, else the lowest where every plan in its way can move. With
    ``airspace.fence`` only the layers whose way keeps inside it are tried, as :func:`plan_flight` plans; where
    none does (a leg across the boundary, every layer over the ceiling) every layer is: it cannot wait, and flies
    home all the same (:func:`~masonry.reservation.fence.keeps_inside` tells the caller).

    Raises:
        PlanningError: no layer works (plans under way are in its way on every layer).
    """
    left = table.release(uav, now_s)
    request = Request(uav, where, None, home)
    layers = [z for z in airspace.layers_m if z >= max(where.z_m, home.z_m)]
    ways = [
        (
            layer,
            tuple(
                r if r.purpose == "stay" else replace(r, purpose="home")
                for r in flight_reservations(request, now_s, layer, airspace)
            ),
        )
        for layer in layers
    ]
    inside = [(layer, mine) for layer, mine in ways if keeps_inside(airspace.fence, mine)]
    tries: list[tuple[float, tuple[Reservation, ...]]] = []
    for layer, mine in inside or ways:
        if not any(left.clashes(r) for r in mine):
            return left.add(*mine), FlightPlan(uav, now_s, layer, mine), ()
        tries.append((layer, mine))
    problem = f"no layer takes {uav}'s way home at {now_s:.1f} s"
    for layer, mine in tries:
        try:
            settled, moves = settle(replace(left, reservations=(*left.reservations, *mine)), now_s, uav)
        except PlanningError as exc:
            problem = str(exc)
            continue
        return settled, FlightPlan(uav, now_s, layer, mine), moves
    raise PlanningError(problem)


def _withdraw(table: Table, held: Reservation, now_s: float) -> tuple[Table, list[Move]]:
    """The plans of others not under way that clash with ``held`` (open-ended: no move gets past it) withdrawn:
    their UAVs stay, open-ended, where they were to leave from. A withdrawn reservation's move ends as it begins."""
    moves: list[Move] = []
    for q in table.clashes(held):
        departure_s = _departure_s(table, q)
        if q not in table.reservations or not departure_s > now_s:
            continue  # (withdrawn with its plan already, or under way: settle refuses it)
        mine = table.of(q.uav)
        waited = [r for r in mine if r.purpose == "stay" and r.t1_s == departure_s]
        dropped = [r for r in mine if r.t0_s >= departure_s and r not in waited]
        moves += [Move(r, r.until(r.t0_s)) for r in dropped] + [Move(r, r.until(math.inf)) for r in waited]
        out = table.without([*dropped, *waited])
        table = replace(out, reservations=(*out.reservations, *(r.until(math.inf) for r in waited)))
    return table, moves


def lose(table: Table, uav: str, now_s: float, last: Volume) -> tuple[Table, tuple[Move, ...]]:
    """``uav`` is lost at ``now_s``: it holds ``last`` (the volume it was last known in), open-ended, instead of its
    plan. The plans of others not under way that need that space are withdrawn (their UAVs stay where they were
    to leave from, and ask again); other plans in the way of what was withdrawn move.

    Raises:
        PlanningError: a plan under way needs that space (the message names both).
    """
    left = table.release(uav, now_s)
    held = Reservation(uav, last, now_s, math.inf, "lost")
    left, withdrawn = _withdraw(left, held, now_s)
    settled, moved = settle(replace(left, reservations=(*left.reservations, held)), now_s, uav)
    return settled, (*withdrawn, *moved)


__all__ = ["Move", "extend", "lose", "settle", "way_home"]
