"""The airspace's state, one record per UAV (:class:`masonry.mission.airspace.ColumnClearance` keeps them), and
its answers (:class:`Grant`). Pure values: no I/O, no clock.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable
from dataclasses import dataclass, field

from masonry.mission.volumes import XY, Vec3, Volume, hold_points


@dataclass(frozen=True)
class Grant:
    """Mission control's answer to a UAV setting off for ``site_m``.

    ``layer_m``: the altitude of its lateral leg (None: no layers, fly as you like, or no flight yet).
    ``granted`` True: fly there (climb where you are to ``layer_m``, fly over the site, come down). False with a
    ``hold_m``: fly (at ``layer_m``) to ``hold_m`` and wait there, the rest comes later. False without: hover
    where you are and ask again. ``refused``: why the flight can never be granted (it leaves the site's fence
    at every layer; mission control fails the UAV's task with it).
    """

    uav: str
    site_m: Vec3
    granted: bool = True
    hold_m: Vec3 | None = None
    layer_m: float | None = None
    refused: str | None = None
    #: fly the lateral leg to the site (or hold point) within the gentle leg's limit: its end is near another UAV's
    #: reservation (False: mission control widened the end by a fast leg's overshoot, ``fast_leg_excess_m``)
    gentle: bool = True


class Phase(enum.Enum):
    """Where a UAV is in the transit protocol (:class:`ColumnClearance`)."""

    LANDED = "landed"  # on its pad at home: it holds only the pad (a take-off needs the column over it)
    PARKED = "parked"  # nothing asked, nothing granted: in the zone at its site (or where it stopped)
    ASKING = "asking"  # asked for a flight, nothing granted yet: it hovers where it is
    TO_HOLD = "to-hold"  # its hold flight is granted: it flies to the hold point near its site
    AT_HOLD = "at-hold"  # it hovers at its hold point until the rest of the flight fits
    FLYING = "flying"  # its flight is granted: over to its site and down


@dataclass(frozen=True)
class FlightRequest:
    """A UAV's request for a flight to ``site``, where it works up to ``top_m`` (and along to ``to``)."""

    site: Vec3
    top_m: float
    position: Vec3 | None  # where it asked from (None: at its site)
    since_s: float
    seq: int  # the order of the requests: first come, first served
    to: XY | None = None  # the work at the site spans from it to here (an adhesion segment)


#: :attr:`HoldFlight.layer` of a hold flight flown at the altitude its UAV asked from, off the layers
#: (:func:`masonry.mission.airspace_requests.off_layer_m`)
OFF_LAYER = -1


@dataclass(frozen=True)
class HoldFlight:
    """The hold flight a waiting UAV was granted: to ``point_m`` at layer ``layer`` (``layer_m`` high)."""

    point_m: Vec3
    layer: int
    layer_m: float  # its altitude then (the layer base may have risen since)
    #: the hold point lies on the straight line from where the hold flight set off to the site, at the layer the
    #: rest of the flight flies: flying straight on over it to the site stays inside the hold flight and the rest
    straight: bool = False


def request_geometry(
    site_m: Vec3, top_m: float | None, position_m: Vec3 | None
) -> tuple[Vec3, float, Vec3 | None]:
    """A flight request's site, the top of its work there (never below the site) and the UAV's position, as floats
    (both airspaces read a request so)."""
    site = (float(site_m[0]), float(site_m[1]), float(site_m[2]))
    top = max(site[2], float(top_m) if top_m is not None else site[2])
    pos = None if position_m is None else (float(position_m[0]), float(position_m[1]), float(position_m[2]))
    return site, top, pos


@dataclass(frozen=True)
class GrantedFlight:
    """A granted flight: to ``site`` at layer ``layer`` (``layer_m`` high), then the zone there up to ``top_m``."""

    site: Vec3
    layer: int
    layer_m: float
    top_m: float
    to: XY | None = None
    gentle: bool = True  # (Grant.gentle: said again with a repeated request)


@dataclass
class UavAirspace:
    """One UAV's share of the airspace: its phase, its volumes and what they are for."""

    phase: Phase = Phase.PARKED
    volumes: list[Volume] = field(default_factory=list)
    zone: Vec3 | None = None  # the site of the zone it works in
    origin: Vec3 | None = None  # the site it set off from (its climb is freed once away)
    request: FlightRequest | None = None  # ASKING, TO_HOLD, AT_HOLD
    hold: HoldFlight | None = None  # TO_HOLD, AT_HOLD
    flight: GrantedFlight | None = None  # FLYING
    seen_version: int = -1  # airspace version at the last evaluation of its request (unchanged: same answer)
    answer: Grant | None = None


def hold_candidates(
    site: Vec3,
    others: Iterable[UavAirspace],
    radius_m: float,
    pads: Iterable[XY] = (),
    waited_on: Iterable[tuple[XY, XY]] = (),
    from_m: Vec3 | None = None,
    ring_step_m: float | None = None,
) -> list[Vec3]:
    """Hold points near ``site`` for a UAV that must wait (:func:`masonry.mission.volumes.hold_points`), kept
    ``1.1 radius_m`` from where ``others`` work, fly to, wait for or wait at, from wherever they climb, hover or
    work, and from their ``pads``: a UAV waiting there must be able to leave vertically, and to come home,
    without passing the hold point (else the two could wait for each other: a UAV holding beside another's pad
    blocked the column that one needed to land, while it waited for that one's zone), and from the work the
    waiting UAV's task waits on (``waited_on``: a brick UAV held over the bead it waits for, whose sprayer had
    not asked yet, blocked that sprayer until hold patience broke the wait). A request along a segment keeps
    hold points from the whole segment: its UAV climbs out at the far end (a hold point 1.2 m from the end of an
    earlier sprayer's segment blocked that sprayer's climb out while it waited for the same spot). Given
    ``from_m`` (where the waiting UAV is), the points of a ring come nearest to it first (:func:`hold_points`)."""
    keep_out, spans = hold_keep_out(others, pads, waited_on)
    return hold_points(
        site, keep_out, spans, radius_m, None if from_m is None else (from_m[0], from_m[1]), ring_step_m
    )


def hold_keep_out(
    others: Iterable[UavAirspace], pads: Iterable[XY] = (), waited_on: Iterable[tuple[XY, XY]] = ()
) -> tuple[list[XY], list[tuple[XY, XY]]]:
    """The points and segments a hold point keeps ``1.1 radius_m`` from (:func:`hold_candidates`)."""
    keep_out: list[XY] = list(pads)
    spans: list[tuple[XY, XY]] = list(waited_on)
    for o in others:
        if o.zone is not None:
            keep_out.extend(v.b for v in o.volumes if v.kind == "zone")
            keep_out.append((o.zone[0], o.zone[1]))
        if o.flight is not None:
            keep_out.append((o.flight.site[0], o.flight.site[1]))
        if o.request is not None:
            keep_out.append((o.request.site[0], o.request.site[1]))
            if o.request.to is not None:  # (it climbs out at the far end of its segment)
                spans.append(((o.request.site[0], o.request.site[1]), o.request.to))
            if o.hold is not None:
                keep_out.append((o.hold.point_m[0], o.hold.point_m[1]))
        # a hold hover is a layer (>= 1.1 m) above any pad, and legs are passed at another layer
        spans.extend((v.a, v.b) for v in o.volumes if v.kind not in ("leg", "pad"))
    return keep_out, spans


__all__ = [
    "OFF_LAYER",
    "FlightRequest",
    "Grant",
    "GrantedFlight",
    "HoldFlight",
    "Phase",
    "UavAirspace",
    "hold_candidates",
    "hold_keep_out",
    "request_geometry",
]
