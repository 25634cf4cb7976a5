"""The site's geofence in the airspace: which reserved volumes keep inside it (pure: no I/O, no clock).

:class:`masonry.mission.airspace.ColumnClearance` grants no flight or hold flight with a volume outside the
fence (``AIRSPACE_MARGIN_M`` inside the boundary, with the volume's slack, and under the altitude limit), and
answers a flight that no layer can fly inside it with the reason (:func:`flight_fence_problem`), which mission
control turns into a failed attempt of the task (docs/safety.md, "The site's fence").
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from masonry.geofence import AIRSPACE_MARGIN_M, Site
from masonry.mission.volumes import XY, Vec3, Volume, flight_volumes
from masonry.reservation.fence import heads_in


def volume_in_fence(site: Site, v: Volume, margin_m: float = AIRSPACE_MARGIN_M) -> bool:
    """``v`` lies ``margin_m`` (plus its slack) inside the boundary and ``margin_m`` under the altitude limit.

    A climb (or descent) is where its UAV already is: only its altitude is checked. A leg that starts less than
    the margin inside (a UAV the wind pushed out, back from the edge) may stay as shallow as it started for its
    first metres only: at ``s`` metres along it, at least ``min(margin, start's depth + s)`` inside, so it heads
    in and never runs along the boundary (:func:`masonry.reservation.fence.heads_in`, the table's check too).
    """
    if v.z1_m > site.max_altitude_m - margin_m + 1e-9:
        return False
    if v.kind == "climb":
        return True
    need = margin_m + v.slack_m
    depth = site.inside_m(v.a[0], v.a[1])
    if depth >= need:
        return site.segment_inside(v.a, v.b, need)
    if v.kind != "leg":
        return False
    return heads_in(site, v.a, v.b, depth, need)


def volumes_in_fence(site: Site, vols: Sequence[Volume], margin_m: float = AIRSPACE_MARGIN_M) -> bool:
    """Every volume of ``vols`` inside the fence (:func:`volume_in_fence`)."""
    return all(volume_in_fence(site, v, margin_m) for v in vols)


def flight_fence_problem(
    site: Site,
    start: Vec3,
    target: Vec3,
    top_m: float,
    to: XY | None,
    layers_m: Iterable[float],
    slack_m: float,
    margin_m: float = AIRSPACE_MARGIN_M,
) -> str | None:
    """Why the flight from ``start`` to ``target`` cannot be flown inside the fence at any of ``layers_m`` (None:
    it can at one of them, whatever the other UAVs hold)."""
    layers = list(layers_m)
    for alt in layers:
        vols = flight_volumes((start[0], start[1]), start[2], alt, target, top_m, None, to, slack_m)
        if volumes_in_fence(site, vols, margin_m):
            return None
    x, y, z = target
    lowest = min(layers) if layers else float("nan")
    where = f"({x:.2f}, {y:.2f}, {z:.2f})"
    if lowest > site.max_altitude_m - margin_m:
        return (
            f"the flight to {where} needs a layer at {lowest:.2f} m, above the site fence's "
            f"{site.max_altitude_m:.2f} m less {margin_m:.2f} m"
        )
    return (
        f"the flight from ({start[0]:.2f}, {start[1]:.2f}) to {where} leaves the site fence "
        f"(a straight leg must keep {margin_m:.2f} m inside its boundary)"
    )


__all__ = ["flight_fence_problem", "volume_in_fence", "volumes_in_fence"]
