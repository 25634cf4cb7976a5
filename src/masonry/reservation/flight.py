"""Flights planned before they are flown: timed legs, reserved at the lowest layer free when the UAV is there.

A flight is the shape the state machines fly (``masonry.fsm``): climb vertically where the UAV is, fly straight
at a transit layer, come down vertically over the goal. :func:`plan_flight` times each leg from the UAV's speeds
(the rest-to-rest minimum-jerk legs of :func:`masonry.timing.min_jerk_leg_s`), reserves each for its duration
plus a margin, adds the work at the site (and the paper's site rule over it), and ends the plan in an open-ended
stay: at the site, or, after a second flight, at a parking spot or the pad. It picks the earliest start at which
every window is free of the other UAVs' reservations, and among equal starts the lowest layer.

Pure: no I/O, no clock (times are passed in).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from masonry.errors import InvalidArgument
from masonry.reservation.fence import Fence
from masonry.reservation.space import Volume, column, leg, pad, site
from masonry.reservation.table import Purpose, Reservation, Table
from masonry.segments import XY
from masonry.timing import DEFAULT_TIMING, TaskTiming, min_jerk_leg_s

PlaceKind = Literal["pad", "parking", "site", "air"]

#: Seconds added to every window of a plan: a UAV this much behind its plan is still inside it.
DEFAULT_MARGIN_S = 2.0

#: A lateral leg is reserved in pieces this long at most (:attr:`Airspace.piece_m`).
LEG_PIECE_M = 1.0

#: Arrivals (or starts) this close are equal: the lower layer is chosen.
ARRIVAL_TIE_S = 1e-6


@dataclass(frozen=True)
class Place:
    """Where a UAV is or stays: ``xy`` at altitude ``z_m``.

    ``pad`` and ``parking``: landed (``z_m`` 0), it holds only a ``ground`` volume; ``site``: hovering at its
    work altitude over a site, it holds the column under it, ``radius_m`` wide; ``air``: hovering anywhere
    (a start only, e.g. a UAV that stopped), it holds the column from the ground up to where it is.
    """

    xy: XY
    z_m: float = 0.0
    kind: PlaceKind = "pad"
    radius_m: float = 0.0

    def volume(self) -> Volume:
        """What a UAV holds while it is here."""
        if self.kind in ("pad", "parking"):
            return pad(self.xy)
        return column(self.xy, 0.0, self.z_m, self.radius_m)


@dataclass(frozen=True)
class Work:
    """A task's work at its site: ``duration_s`` at altitude ``z_m`` over ``site_xy`` (along to ``to_xy`` for an
    adhesion segment), in a zone ``radius_m`` wide; ``clearance_m`` (r_c) > 0 also reserves the site's r_c
    neighbourhood from the descent to the end of the work (the paper's conflict rule on site intervals)."""

    site_xy: XY
    z_m: float
    duration_s: float
    to_xy: XY | None = None
    radius_m: float = 0.0
    clearance_m: float = 0.0
    task: str = ""
    #: the height of the work point (a brick's drop-off, an adhesion segment), for the site rule's 3-D distance
    site_z_m: float = 0.0

    def zone(self) -> Volume:
        """The column the UAV works in, from the ground to its work altitude."""
        end = self.site_xy if self.to_xy is None else self.to_xy
        return Volume(self.site_xy, end, 0.0, self.z_m, self.radius_m, "air")

    def end_place(self) -> Place:
        """Where the UAV is when the work is done (the segment's end for adhesion), as a site stay."""
        xy = self.site_xy if self.to_xy is None else self.to_xy
        return Place(xy, self.z_m, "site", self.radius_m)


@dataclass(frozen=True)
class Airspace:
    """The layers and speeds flights are planned with.

    Attributes:
        layers_m: transit layer altitudes, lowest first; each must clear every work zone and stay by the vertical
            separation (e.g. ``masonry.mission.altitudes.layer_base_m`` + k * ``LAYER_SPACING_M``, k >= 1).
        cruise_mps, vertical_mps: the peak speeds of lateral and vertical legs (``TaskTiming``'s).
        margin_s: added to every window (how late a UAV may be before its windows are extended).
        horizon_s: a plan starting later than now + this is not granted: the UAV waits where it is and asks again
            (the rolling horizon).
        any_layer: legs may also fly below the start, the work's top or the stay (the UAV climbs or descends to
            the layer where it is, and the work's column covers the rest, as the column airspace grants them);
            False: only layers over all three.
        first_arrival: of the layers, each at its earliest start, the one whose flight arrives first where it
            stays (a higher layer free now loses to a lower one free a little later when the climb takes longer
            than the wait); False: the earliest start (rule 4 of docs/safety.md).
        piece_m: a lateral leg longer than this is reserved as pieces of at most this length, each from the leg's
            start until the UAV is planned past it (its minimum-jerk profile) plus the margin: the air a UAV
            has flown out of is free before its leg ends (0: the whole leg until its end, as before).
        fence: the site's fence (:class:`~masonry.reservation.fence.Fence`; None: none): a flight is planned only
            at layers where every leg of it keeps inside (:func:`fenced_layers`).
    """

    layers_m: tuple[float, ...]
    cruise_mps: float = DEFAULT_TIMING.cruise_speed_mps
    vertical_mps: float = DEFAULT_TIMING.vertical_speed_mps
    margin_s: float = DEFAULT_MARGIN_S
    horizon_s: float = 60.0
    any_layer: bool = False
    first_arrival: bool = False
    piece_m: float = 0.0
    fence: Fence | None = None

    @classmethod
    def from_timing(
        cls,
        layers_m: Sequence[float],
        timing: TaskTiming = DEFAULT_TIMING,
        *,
        margin_s: float = DEFAULT_MARGIN_S,
        horizon_s: float = 60.0,
        any_layer: bool = False,
    ) -> Airspace:
        """The airspace of UAVs that fly ``timing`` (a ``UavConfig.timing()``): its cruise and vertical speeds."""
        return cls(
            tuple(float(z) for z in layers_m),
            timing.cruise_speed_mps,
            timing.vertical_speed_mps,
            margin_s,
            horizon_s,
            any_layer,
        )

    def __post_init__(self) -> None:
        if not self.layers_m or list(self.layers_m) != sorted(self.layers_m):
            raise InvalidArgument(f"`layers_m` must be a non-empty ascending sequence, got {self.layers_m}")
        if not (
            self.cruise_mps > 0
            and self.vertical_mps > 0
            and self.margin_s >= 0
            and self.horizon_s >= 0
            and self.piece_m >= 0
        ):
            raise InvalidArgument("speeds must be > 0, the margin, horizon and piece length >= 0")


@dataclass(frozen=True)
class Request:
    """``uav``, now at ``start``, asks to fly to ``work`` (None: straight to ``stay``) and then stay at ``stay``
    (None: at the work site)."""

    uav: str
    start: Place
    work: Work | None = None
    stay: Place | None = None

    def __post_init__(self) -> None:
        if self.work is None and self.stay is None:
            raise InvalidArgument(f"{self.uav}'s request has neither work nor a place to stay")


@dataclass(frozen=True)
class FlightPlan:
    """A granted (or grantable) flight: its reservations, in time order, the last one open-ended."""

    uav: str
    start_s: float
    layer_m: float
    reservations: tuple[Reservation, ...]

    @property
    def stay(self) -> Reservation:
        """Where it ends (open-ended)."""
        return self.reservations[-1]


# A part of a plan: volume, purpose, task, offset of its start and of its end from the plan's start.
_Part = tuple[Volume, Purpose, str, float, float]


def _hop(
    a: Place, b: Place, layer_m: float, air: Airspace, at_s: float, task: str
) -> tuple[list[_Part], float]:
    """Climb at ``a``, transit at ``layer_m``, descend at ``b``, from offset ``at_s``: the parts and the arrival."""
    parts: list[_Part] = []
    m = air.margin_s
    climb = min_jerk_leg_s(abs(layer_m - a.z_m), air.vertical_mps)
    parts.append((column(a.xy, a.z_m, layer_m, a.radius_m), "climb", task, at_s, at_s + climb + m))
    t = at_s + climb
    dist = math.hypot(b.xy[0] - a.xy[0], b.xy[1] - a.xy[1])
    if dist > 1e-6:
        transit = min_jerk_leg_s(dist, air.cruise_mps)
        n = max(1, math.ceil(dist / air.piece_m - 1e-9)) if air.piece_m > 0.0 else 1
        for i in range(n):  # piece i: from the leg's start until the UAV is past its end (+ the margin)
            p, q = _along(a.xy, b.xy, i / n), _along(a.xy, b.xy, (i + 1) / n)
            past = transit if i == n - 1 else transit * min_jerk_time_fraction((i + 1) / n)
            parts.append((leg(p, q, layer_m), "transit", task, t, t + past + m))
        t += transit
    descend = min_jerk_leg_s(abs(layer_m - b.z_m), air.vertical_mps)
    parts.append((column(b.xy, b.z_m, layer_m, b.radius_m), "descend", task, t, t + descend + m))
    return parts, t + descend


def _along(a: XY, b: XY, f: float) -> XY:
    """The point ``f`` (0..1) of the way from ``a`` to ``b``."""
    return (a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f)


def min_jerk_time_fraction(distance_fraction: float) -> float:
    """The fraction of a rest-to-rest minimum-jerk leg's time at which it has covered ``distance_fraction`` of
    its length (the inverse of ``10 u^3 - 15 u^4 + 6 u^5``, by bisection)."""
    lo, hi = 0.0, 1.0
    f = min(max(distance_fraction, 0.0), 1.0)
    for _ in range(40):
        u = (lo + hi) / 2
        if u**3 * (10 - 15 * u + 6 * u * u) < f:
            lo = u
        else:
            hi = u
    return hi


def _parts(request: Request, layer_m: float, air: Airspace) -> list[_Part]:
    """The plan's parts at ``layer_m``, offsets from its start; the last one open-ended."""
    w = request.work
    if w is None:
        assert request.stay is not None
        parts, t = _hop(request.start, request.stay, layer_m, air, 0.0, "")
        return [*parts, (request.stay.volume(), "stay", "", t, math.inf)]
    here = Place(w.site_xy, w.z_m, "site", w.radius_m)
    parts, t = _hop(request.start, here, layer_m, air, 0.0, w.task)
    descent_s = parts[-1][3]
    done = t + w.duration_s
    if w.clearance_m > 0.0:
        parts.append(
            (
                site(w.site_xy, w.clearance_m, w.to_xy, w.site_z_m),
                "site",
                w.task,
                descent_s,
                done + air.margin_s,
            )
        )
    if request.stay is None:
        parts.append((w.zone(), "stay", w.task, t, math.inf))
        return parts
    parts.append((w.zone(), "work", w.task, t, done + air.margin_s))
    home, end = _hop(w.end_place(), request.stay, layer_m, air, done, w.task)
    return [*parts, *home, (request.stay.volume(), "stay", "", end, math.inf)]


def fenced_layers(request: Request, airspace: Airspace) -> tuple[float, ...]:
    """The layers ``request``'s flight may fly at: at or over its floor (:attr:`Airspace.any_layer`) and, with a
    fence, every flown part of the flight at that layer inside it (:meth:`~masonry.reservation.fence.Fence.admits`)."""
    floor = _floor_m(request, airspace)
    fence = airspace.fence
    return tuple(
        z
        for z in airspace.layers_m
        if z >= floor
        and (fence is None or all(fence.admits(v, p) for v, p, _t, _a, _b in _parts(request, z, airspace)))
    )


def _floor_m(request: Request, airspace: Airspace) -> float:
    """The lowest layer ``request``'s legs may fly at (:attr:`Airspace.any_layer`)."""
    if airspace.any_layer:
        return -math.inf
    w, s = request.work, request.stay
    return max(request.start.z_m, w.z_m if w is not None else 0.0, s.z_m if s is not None else 0.0)


def earliest_start(
    table: Table, uav: str, parts: Sequence[tuple[Volume, float, float]], from_s: float
) -> tuple[float, tuple[Reservation, ...]]:
    """The earliest ``t >= from_s`` at which every part (volume, offset of start, offset of end) of a plan
    starting at ``t`` is free of the other UAVs' reservations (``math.inf``: none, an open-ended reservation is
    in the way for good), and the reservations in its way at ``from_s``.

    A part ``[t + a, t + b)`` meets a reservation ``[c, d)`` that conflicts with it in space exactly when ``t``
    lies in the open interval ``(c - b, d - a)``: the earliest start is the first ``t`` outside all of them.
    """
    blocked: list[tuple[float, float]] = []
    in_way: list[Reservation] = []
    sep = table.separation
    for q in table.reservations:
        if q.uav == uav or q.t1_s <= q.t0_s:
            continue
        for vol, a, b in parts:
            if sep.conflict(vol, q.volume):
                lo, hi = _outside(q.t0_s, q.t1_s, a, b)
                blocked.append((lo, hi))
                if lo < from_s < hi and q not in in_way:
                    in_way.append(q)
    t = from_s
    for lo, hi in sorted(blocked):
        if lo >= t:
            break
        t = max(t, hi)
    return t, tuple(in_way)


def _outside(c_s: float, d_s: float, a_s: float, b_s: float) -> tuple[float, float]:
    """The open interval of starts ``t`` at which a part ``[t + a, t + b)`` meets ``[c, d)``, rounded outwards
    so that the windows later made as ``t + a`` and ``t + b`` (float sums) never meet ``[c, d)`` at a start
    outside it: ``t <= lo`` gives ``t + b <= c`` and ``t >= hi`` gives ``t + a >= d`` exactly (a flight planned
    to start as another UAV's window ends was refused by :meth:`Table.add` for a rounding of 1e-14 s)."""
    lo, hi = c_s - b_s, d_s - a_s
    while lo + b_s > c_s:
        lo = math.nextafter(lo, -math.inf)
    while hi + a_s < d_s:
        hi = math.nextafter(hi, math.inf)
    return lo, hi


def plan_flight(table: Table, request: Request, from_s: float, airspace: Airspace) -> FlightPlan | None:
    """The flight of ``request`` starting at the earliest time ``>= from_s`` it fits, at the lowest layer of the
    earliest start (with :attr:`Airspace.first_arrival`: at each layer at the earliest start there, the one that
    arrives first where it stays, the lowest among equal arrivals); None if no layer ever fits (an open-ended
    reservation of another UAV is in its way).

    Layers below the start, the work or the stay are skipped (unless :attr:`Airspace.any_layer`), and layers where
    a leg leaves the fence (:func:`fenced_layers`). The UAV's own reservations are not in its way (it leaves its
    stay when the flight starts).
    """
    best: tuple[float, float, float] | None = None  # (arrival, start, layer)
    for layer in fenced_layers(request, airspace):
        parts = _parts(request, layer, airspace)
        t, _ = earliest_start(table, request.uav, [(v, a, b) for v, _p, _t, a, b in parts], from_s)
        arrival = t + parts[-1][3] if airspace.first_arrival else t  # (where it stays, from then on)
        if math.isfinite(t) and (best is None or arrival < best[0] - ARRIVAL_TIE_S):
            best = (arrival, t, layer)
    if best is None:
        return None
    _arrival, t, layer = best
    return FlightPlan(request.uav, t, layer, flight_reservations(request, t, layer, airspace))


def flight_reservations(
    request: Request, start_s: float, layer_m: float, airspace: Airspace
) -> tuple[Reservation, ...]:
    """The reservations of ``request``'s flight at ``layer_m`` starting at ``start_s``, whatever else the table
    holds (a flight that cannot wait: a silent UAV's way home)."""
    parts = _parts(request, layer_m, airspace)
    return tuple(Reservation(request.uav, v, start_s + a, start_s + b, p, task) for v, p, task, a, b in parts)


def blockers(
    table: Table, request: Request, from_s: float, airspace: Airspace, *, standing: bool = False
) -> tuple[Reservation, ...]:
    """The other UAVs' reservations in the way of the request's flight at ``from_s`` on its lowest usable layer
    (``standing``: instead, the open-ended ones in its way at any time on any usable layer: no layer fits, and
    whoever waits in the way of a higher one may be what mission control must move, not only the lowest layer's
    blocker; docs/safety.md, "Parking spots break the cycles")."""
    layers = list(fenced_layers(request, airspace)) or [airspace.layers_m[-1]]
    parts = [(v, a, b) for v, _p, _t, a, b in _parts(request, layers[0], airspace)]
    if not standing:
        return earliest_start(table, request.uav, parts, from_s)[1]
    sep = table.separation
    volumes = [v for z in layers for v, _p, _t, _a, _b in _parts(request, z, airspace)]
    return tuple(
        q
        for q in table.reservations
        if q.uav != request.uav and q.open_ended and any(sep.conflict(v, q.volume) for v in volumes)
    )


__all__ = [
    "DEFAULT_MARGIN_S",
    "LEG_PIECE_M",
    "Airspace",
    "FlightPlan",
    "Place",
    "PlaceKind",
    "Request",
    "Work",
    "blockers",
    "earliest_start",
    "fenced_layers",
    "flight_reservations",
    "min_jerk_time_fraction",
    "plan_flight",
]
