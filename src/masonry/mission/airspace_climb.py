"""A climb freed below the UAV as it climbs, for the UAV coming down where it set off (issue 27: tried, not kept).

A granted flight starts with a vertical climb (or descent) where its UAV set off, reserved from where it was to its
layer until the UAV is ``release_radius_m`` away. The UAV arriving at the site it leaves waits for that climb
(``bench_site_visits.py``: 332 s of 572 s of hand-overs, 12 m wall, 8 + 4, seed 1). A UAV flies its climb vertically
and one way, so what lies more than ``TRACK_M`` behind the altitude it reports is behind it, as on its lateral leg
(:func:`masonry.mission.volumes.ahead_of`), and once it reports itself at its layer (within ``AT_LAYER_M``) the
climb is over: the arriving UAV's column, up to a layer 1.1 m under the leaving UAV's, is reserved from that report,
not on a timer. Every other UAV keeps clear of the whole climb. Pure: no I/O, no clock.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

from masonry.mission.airspace_state import UavAirspace
from masonry.mission.volumes import TRACK_M, Volume

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance

__all__ = ["AT_LAYER_M", "climb_ahead", "others_volumes"]

#: A UAV reported this near its layer's altitude has climbed (or come down) to it: the airspace's ``SNAP_M``.
AT_LAYER_M = 0.05


def climb_ahead(u: UavAirspace, x: float, y: float, z: float, layer_m: float | None) -> list[Volume] | None:
    """``u``'s volumes with the climb (or descent) at their start shrunk to what lies ahead of it, reported at
    ``(x, y, z)`` in it on its way to ``layer_m``: from ``TRACK_M`` behind that altitude to the layer. The climb
    as granted is kept in ``u.climb``: only a UAV coming down near where it set off may use what is freed
    (:func:`others_volumes`).

    None: nothing to free (no climb first, the report is not in the climb's column, the climb's direction is not
    known from ``layer_m``, or the UAV is less than ``TRACK_M`` along it).
    """
    vols = u.volumes
    if not vols or layer_m is None:
        return None
    v = vols[0]
    if v.kind != "climb" or math.hypot(x - v.a[0], y - v.a[1]) > TRACK_M:
        return None
    at_layer = abs(z - layer_m) < AT_LAYER_M  # (hover noise: it is at its layer, its climb is over)
    if abs(v.z1_m - layer_m) < 1e-6:  # climbing up to the layer: below it is behind
        z0 = v.z1_m if at_layer else min(z - TRACK_M, v.z1_m)
        if z0 <= v.z0_m + 1e-9:
            return None
        trimmed = dataclasses.replace(v, z0_m=z0)
    elif abs(v.z0_m - layer_m) < 1e-6:  # coming down to the layer: above it is behind
        z1 = v.z0_m if at_layer else max(z + TRACK_M, v.z0_m)
        if z1 >= v.z1_m - 1e-9:
            return None
        trimmed = dataclasses.replace(v, z1_m=z1)
    else:
        return None
    if not _within(v, u.climb):
        u.climb = v
    return [trimmed, *vols[1:]]


def others_volumes(c: ColumnClearance, uav: str) -> list[Volume]:
    """The volumes every UAV but ``uav`` holds, as ``uav``'s flight must keep clear of them: a climb freed below
    its UAV (:func:`climb_ahead`) counts whole, unless ``uav`` asks for a site within the wait radius of where that
    UAV set off (it comes down where the other climbs away: the hand-over)."""
    me = c.records.get(uav)
    w = None if me is None else me.request
    out: list[Volume] = []
    for other, o in c.records.items():
        if other == uav:
            continue
        vols = o.volumes
        full = o.climb
        if full is not None and vols and vols[0].kind == "climb" and _within(vols[0], full):
            handed = (
                w is not None
                and o.origin is not None
                and math.hypot(w.site[0] - o.origin[0], w.site[1] - o.origin[1]) < c.wait_radius_m
            )
            if not handed:
                out.append(full)
                out.extend(vols[1:])
                continue
        out.extend(vols)
    return out


def _within(v: Volume, full: Volume | None) -> bool:
    """``v`` is a part of the climb ``full`` (the same column, inside its altitudes)."""
    return (
        full is not None
        and v.a == full.a
        and full.z0_m - 1e-9 <= v.z0_m
        and v.z1_m <= full.z1_m + 1e-9
        and (abs(v.z0_m - full.z0_m) < 1e-9 or abs(v.z1_m - full.z1_m) < 1e-9)
    )
