"""The space-time reservation table: who may be where, and when (pure: no I/O, no clock).

A :class:`Reservation` is a UAV, a :class:`~masonry.reservation.space.Volume` it may occupy, a time window
``[t0_s, t1_s)`` (``t1_s`` is ``math.inf`` where the UAV may stay: its pad, a parking spot, its site) and a
purpose. A :class:`Table` never holds two reservations of different UAVs that overlap in space (the
:class:`~masonry.reservation.space.Separation`) *and* in time: :meth:`Table.add` refuses them. It also holds the
constraints that are no one's volume, :class:`~masonry.reservation.holds.Hold` (no take-off in a window: the
operator's pause or recall, the wind limit). Tables are values: every change returns a new one.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Literal

from masonry.errors import InvalidArgument, PlanningError
from masonry.reservation.space import DEFAULT_SEPARATION, Separation, Volume

if TYPE_CHECKING:
    from masonry.reservation.holds import Hold

#: What a reservation is for. ``stay``: a place the UAV may stay (open-ended); ``climb``, ``transit``,
#: ``descend``: a flight's legs; ``work``: its work zone at a site; ``site``: the paper's conflict rule (its
#: site's r_c neighbourhood for the site interval); ``home``: a silent UAV's fallback flight home; ``lost``: a
#: lost UAV's last volume, kept until it is accounted for.
Purpose = Literal["stay", "climb", "transit", "descend", "work", "site", "home", "lost"]
PURPOSES: tuple[Purpose, ...] = ("stay", "climb", "transit", "descend", "work", "site", "home", "lost")


@dataclass(frozen=True)
class Reservation:
    """``uav`` may occupy ``volume`` from ``t0_s`` until (not including) ``t1_s`` (``math.inf``: open-ended)."""

    uav: str
    volume: Volume
    t0_s: float
    t1_s: float
    purpose: Purpose
    #: the task it serves ("" for none)
    task: str = ""

    def __post_init__(self) -> None:
        if not self.uav:
            raise InvalidArgument("a reservation needs a UAV name")
        if not math.isfinite(self.t0_s) or math.isnan(self.t1_s) or self.t1_s < self.t0_s:
            raise InvalidArgument(
                f"{self.uav}'s {self.purpose} reservation: the window [{self.t0_s}, {self.t1_s}) is not a time "
                "window (t0_s finite, t1_s >= t0_s, math.inf for open-ended)"
            )
        if self.purpose not in PURPOSES:
            raise InvalidArgument(f"{self.uav}'s reservation: unknown purpose {self.purpose!r}")

    @property
    def open_ended(self) -> bool:
        """It has no end: a place the UAV may stay."""
        return math.isinf(self.t1_s)

    def overlaps_in_time(self, other: Reservation) -> bool:
        """Their windows share an instant (windows are half-open: one may start as the other ends, and an empty
        window, a stay that ended as it began, shares none)."""
        return max(self.t0_s, other.t0_s) < min(self.t1_s, other.t1_s)

    def shifted(self, delta_s: float) -> Reservation:
        """The same reservation ``delta_s`` later (an open-ended one stays open-ended)."""
        return replace(self, t0_s=self.t0_s + delta_s, t1_s=self.t1_s + delta_s)

    def until(self, t1_s: float) -> Reservation:
        """The same reservation ending at ``t1_s``."""
        return replace(self, t1_s=t1_s)

    def describe(self) -> str:
        """One line: who, what for, when."""
        end = "open-ended" if self.open_ended else f"{self.t1_s:.1f} s"
        task = f" (task {self.task})" if self.task else ""
        return f"{self.uav}'s {self.purpose}{task} from {self.t0_s:.1f} s to {end}"


def clash(p: Reservation, q: Reservation, separation: Separation = DEFAULT_SEPARATION) -> bool:
    """Two reservations of different UAVs that overlap in time and in space (the separation)."""
    return p.uav != q.uav and p.overlaps_in_time(q) and separation.conflict(p.volume, q.volume)


@dataclass(frozen=True)
class Table:
    """The reservations of a fleet: never two of different UAVs that :func:`clash`; and its holds (no take-off
    in their windows: :mod:`masonry.reservation.holds`)."""

    reservations: tuple[Reservation, ...] = ()
    separation: Separation = DEFAULT_SEPARATION
    holds: tuple[Hold, ...] = ()

    def clashes(self, r: Reservation) -> tuple[Reservation, ...]:
        """The reservations of other UAVs ``r`` would clash with."""
        return tuple(q for q in self.reservations if clash(r, q, self.separation))

    def add(self, *new: Reservation) -> Table:
        """This table with ``new`` added.

        Raises:
            PlanningError: one of ``new`` clashes with a reservation of another UAV (in the table or in ``new``);
                the message names both.
        """
        kept = list(self.reservations)
        for r in new:
            for q in kept:
                if clash(r, q, self.separation):
                    raise PlanningError(f"{r.describe()} clashes with {q.describe()}")
            kept.append(r)
        return replace(self, reservations=tuple(kept))

    def of(self, uav: str) -> tuple[Reservation, ...]:
        """``uav``'s reservations, by start time."""
        return tuple(sorted((r for r in self.reservations if r.uav == uav), key=lambda r: (r.t0_s, r.t1_s)))

    def stay_of(self, uav: str) -> Reservation | None:
        """``uav``'s open-ended reservation (where its plan ends), if it has one."""
        stays = [r for r in self.reservations if r.uav == uav and r.open_ended]
        return max(stays, key=lambda r: r.t0_s) if stays else None

    def at(self, t_s: float) -> tuple[Reservation, ...]:
        """The reservations whose window holds ``t_s``."""
        return tuple(r for r in self.reservations if r.t0_s <= t_s < r.t1_s)

    def uavs(self) -> tuple[str, ...]:
        """The UAVs with a reservation, sorted."""
        return tuple(sorted({r.uav for r in self.reservations}))

    def without(self, drop: Iterable[Reservation]) -> Table:
        """This table without the reservations ``drop`` (compared by value)."""
        gone = list(drop)
        kept = list(self.reservations)
        for r in gone:
            kept.remove(r)
        return replace(self, reservations=tuple(kept))

    def ended(self, r: Reservation, t1_s: float) -> Table:
        """This table with ``r`` ending at ``t1_s``, no later than it did. Not checked: a window cut short clashes
        with nothing the whole one did not, so a clash the table was given unchecked (what a UAV physically holds)
        is kept, never raised here."""
        if t1_s > r.t1_s:
            raise PlanningError(f"{r.describe()} cannot be made to end later, at {t1_s:.1f} s")
        return replace(self, reservations=tuple(r.until(t1_s) if q == r else q for q in self.reservations))

    def release(self, uav: str, from_s: float) -> Table:
        """``uav`` gives up everything from ``from_s`` on: windows that start then or later are dropped, windows
        running past it end there. Nothing of another UAV changes."""
        kept: list[Reservation] = []
        for r in self.reservations:
            if r.uav != uav or r.t1_s <= from_s:
                kept.append(r)
            elif r.t0_s < from_s:
                kept.append(r.until(from_s))
        return replace(self, reservations=tuple(kept))

    def prune(self, now_s: float) -> Table:
        """Without the windows (and holds) that ended by ``now_s`` (they bind nobody any more)."""
        kept = tuple(r for r in self.reservations if r.t1_s > now_s)
        return replace(self, reservations=kept, holds=tuple(h for h in self.holds if h.t1_s > now_s))


def violations(table: Table) -> list[tuple[Reservation, Reservation]]:
    """Every pair of reservations of ``table`` that clash (none for a table built with :meth:`Table.add`)."""
    rs = table.reservations
    return [
        (rs[i], rs[j])
        for i in range(len(rs))
        for j in range(i + 1, len(rs))
        if clash(rs[i], rs[j], table.separation)
    ]


__all__ = ["PURPOSES", "Purpose", "Reservation", "Table", "clash", "violations"]
