"""A UAV on and off its pad, and out of touch: take-off, landing, falling silent in the air, being heard again.

Part of :class:`~masonry.mission.airspace.ColumnClearance` (its methods of these names call these): a UAV on its
pad holds only the pad; taking off it holds the column over the pad up to the transit altitude; a silent UAV
keeps the way home it flies on its own; one heard again holds where it is. Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.mission import airspace_queries
from masonry.mission.airspace_state import Phase
from masonry.mission.volumes import TRACK_M, Vec3, Volume, point_segment_m, same_site

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance

__all__ = ["ON_PAD_XY_M", "ON_PAD_Z_M", "can_take_off", "landed", "rejoined", "silent", "take_off"]

#: A UAV reported this close to its home (horizontally) and this low is on its pad.
ON_PAD_XY_M = 0.3
ON_PAD_Z_M = 0.3


def can_take_off(c: ColumnClearance, uav: str) -> bool:
    """``uav`` may take off now: it holds more than its pad already, or the column over its pad is free."""
    u = c.records.get(uav)
    if c.base_m is None or u is None or u.phase is not Phase.LANDED:
        return True
    return c.free(uav, [c.home_column(uav)])


def take_off(c: ColumnClearance, uav: str) -> bool:
    """``uav``, landed on its pad, is about to take off: it holds the column over its pad up to the transit
    altitude, if that is free (True), else it stays on its pad (False: ask again once its ``version``
    changed). A UAV that is not landed already holds what it needs (True)."""
    if not c.can_take_off(uav):
        return False
    u = c.records.get(uav)
    if u is not None and u.phase is Phase.LANDED:
        c.set_zone(uav, c.homes[uav], c.home_top_m())
    return True


def landed(c: ColumnClearance, uav: str, position_m: Vec3) -> bool:
    """``uav`` says it is on the ground at ``position_m``, done flying: if that is on its pad, it holds only
    the pad from now on (True). A UAV whose flight home is still reserved (its ``arrived`` was lost) lands
    out of it too, and so does one holding only where it was last seen (a zone, nothing granted)."""
    home = c.homes.get(uav)
    u = c.records.get(uav)
    if c.base_m is None or home is None or u is None or u.phase is Phase.LANDED:
        return False
    x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
    if math.hypot(x - home[0], y - home[1]) > ON_PAD_XY_M or z - home[2] > ON_PAD_Z_M:
        return False
    at_home = u.zone is not None and same_site(u.zone, home)
    flying_home = u.flight is not None and same_site(u.flight.site, home)
    # nothing granted in flight: what it holds is where it was last seen (heard again while it flew home on
    # its own, cut off past LAST_RESORT_S: the column where it was heard); it is on its pad now
    seen_elsewhere = u.flight is None and u.hold is None
    if u.request is not None or not (at_home or flying_home or seen_elsewhere):
        return False
    c.set_pad(uav)
    return True


def rejoined(
    c: ColumnClearance,
    uav: str,
    position_m: Vec3 | None,
    way_home: tuple[float | None, Vec3 | None] | None = None,
) -> bool:
    """``uav``, taken out of the mission (``release`` with no site), is heard again at ``position_m``: on
    its pad it holds the pad again and takes off like the others; in the air (it hovers where it stopped,
    cut off, and asks for its flight home) it holds the column where it is, up to the transit altitude,
    as after a take-off there, and asks from there; with ``way_home`` (it says it is flying home, or putting
    a brick back, maybe on its own) also that way (:func:`silent`). False: it is down away from its pad (not back yet);
    with no position known it is taken back holding nothing."""
    home = c.homes.get(uav)
    if c.base_m is None or home is None or position_m is None:
        return True
    x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
    on_pad = math.hypot(x - home[0], y - home[1]) <= ON_PAD_XY_M
    if z - home[2] <= ON_PAD_Z_M:
        if not on_pad:
            return False
        c.set_pad(uav)  # (a silent UAV landed kept the column over its pad too: :func:`silent`)
        return True
    u = c.record(uav)
    # what it was granted before it fell silent is over (its `arrived` would end the old flight at its site)
    u.flight, u.hold, u.request, u.origin, u.phase = None, None, None, None, Phase.PARKED
    c.set_zone(uav, (x, y, home[2]), max(z, c.home_top_m()))
    if way_home is not None:
        # it is flying home on its own (cut off past LAST_RESORT_S, it asks nobody until it is down): the
        # rest of that way stays its own (``way_home``: its fallback layer and the pickup it calls at first)
        u.volumes = [
            *u.volumes,
            *airspace_queries.way_home(c, uav, (x, y, z), way_home[0], way_home[1])[0],
        ]
    return True


def silent(
    c: ColumnClearance, uav: str, position_m: Vec3, layer_m: float | None, via_m: Vec3 | None = None
) -> float:
    """``uav`` fell silent in the air at ``position_m``: besides what it holds it keeps the way home it flies on
    its own once mission control has been silent for ``LAST_RESORT_S`` (its machine's route without an
    airspace): the climb or descent where it is to ``layer_m`` (its fixed fallback layer; None: the altitude
    it is at), the leg there to above its pad, and its pad's column; with ``via_m`` (a brick's pickup: it
    puts the brick back first) through that site's column. Returns the way's length in metres."""
    u = c.records.get(uav)
    if u is None or uav not in c.homes:
        return 0.0
    way, length_m = airspace_queries.way_home(c, uav, position_m, layer_m, via_m)
    end = leg_end_ahead(u.volumes, position_m)
    if end is not None:
        # it flies on along its leg until it notices the silence (3 s): to the leg's end, where it then climbs
        # (issue 27 §4.3: a brick UAV cut off 1.15 m before its site climbed there, 1.22 m from the climb reserved
        # where it was last heard, for 6.3 s)
        more, more_m = airspace_queries.way_home(c, uav, end, layer_m, via_m)
        way, length_m = (
            [*way, *more, *stops_between(position_m, end, layer_m, via_m or c.homes[uav])],
            max(length_m, more_m),
        )
    u.volumes = [*u.volumes, *way]
    c.touch()
    return length_m


def stops_between(p: Vec3, end: Vec3, layer_m: float | None, to: Vec3) -> list[Volume]:
    """Where a UAV that stops anywhere on its leg from ``p`` to ``end`` climbs and flies on (to ``to``, its first
    stop on the way home): the climb along the leg up to its layer, and the legs from there to ``to`` (within half
    the leg's length of the one from the leg's middle)."""
    alt = p[2] if layer_m is None else float(layer_m)
    lo, hi = min(end[2], alt), max(end[2], alt)
    mid = ((p[0] + end[0]) / 2.0, (p[1] + end[1]) / 2.0)
    half = math.hypot(end[0] - p[0], end[1] - p[1]) / 2.0
    return [
        Volume((p[0], p[1]), (end[0], end[1]), lo, hi, 0.0, "climb"),
        Volume(mid, (to[0], to[1]), alt, alt, half, "leg"),
    ]


def leg_end_ahead(vols: list[Volume], position_m: Vec3) -> Vec3 | None:
    """The end of the lateral leg of ``vols`` a UAV at ``position_m`` is on (within ``TRACK_M`` of it, at its
    altitude), if that end lies ahead of it; else None."""
    x, y, z = position_m
    for v in reversed(vols):
        if v.kind != "leg" or abs(z - v.z0_m) >= 0.2 or point_segment_m((x, y), v.a, v.b) > TRACK_M:
            continue
        if math.hypot(v.b[0] - x, v.b[1] - y) <= TRACK_M:
            return None  # (at its end already: the way home from where it is covers it)
        return (v.b[0], v.b[1], v.z0_m)
    return None
