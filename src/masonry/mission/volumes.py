"""Reserved airspace volumes and the geometry that keeps them apart (pure: no I/O, no clock).

A :class:`Volume` is what :class:`masonry.mission.airspace.ColumnClearance` hands a UAV: a horizontal segment
thickened by a slack, between two altitudes. :func:`volumes_conflict` says whether two volumes could bring
their UAVs within the separation; :func:`volumes_clear` answers the same for many pairs at once (mission
control's inner loop: ``benchmarks/bench_airspace.py`` measures what writing it out saves).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from masonry.segments import nearest_on_segment, point_segment_m, segment_segment_m, segments_closer_than

Vec3 = tuple[float, float, float]
XY = tuple[float, float]

#: How far a UAV may be off its reserved path (tracking error, a report a little late): what lies further behind
#: it on its leg is freed (:meth:`ColumnClearance.progress`).
TRACK_M = 0.3

#: A UAV that stopped mid-flight to ask for another site (it turned back) holds this much around where it is.
HOVER_SLACK_M = 0.3

#: The hold points on a UAV's straight line to its site (:func:`hold_points` given ``from_m``), this far apart.
HOLD_LINE_STEP_M = 0.25

#: How far a UAV flying a leg may coast on after it is told to stop (1.9 m/s peak, 2.5 m/s^2 braking, margin).
STOP_M = 1.0

#: A UAV that asks to leave its work zone from this far outside it (an autopilot coasting past the end of a bead,
#: a gust) leaves from the zone's edge (:func:`leave_from`): half of what ``SEPARATION_XY_M`` keeps over the 1 m
#: target, each UAV's share of the tracking error.
LEAVE_SNAP_M = 0.1


@dataclass(frozen=True)
class Volume:
    """A piece of airspace reserved for one UAV: every point within ``slack_m`` (horizontally) of the 2-D
    segment ``a``-``b``, between altitudes ``z0_m`` and ``z1_m``.

    A vertical move is a degenerate segment (``a == b``) over an altitude range, a lateral leg a segment at one
    altitude, a site's work zone a vertical column from the ground with the work's horizontal ``slack_m``.
    """

    a: XY
    b: XY
    z0_m: float
    z1_m: float
    slack_m: float = 0.0
    kind: str = "leg"  # "climb", "leg", "zone", "hover": what it is, for diagnostics and early release


def volumes_conflict(p: Volume, q: Volume, sep_xy_m: float, sep_z_m: float) -> bool:
    """Could a UAV in ``p`` come within the separation of one in ``q``?

    No if their altitude ranges are ``sep_z_m`` apart, or their horizontal footprints ``sep_xy_m`` (plus both
    slacks) apart. Two UAVs in volumes that do not conflict are at least min(sep_xy_m, sep_z_m) apart.
    """
    if p.z0_m - q.z1_m >= sep_z_m or q.z0_m - p.z1_m >= sep_z_m:
        return False
    need = sep_xy_m + p.slack_m + q.slack_m
    return segments_closer_than(p.a, p.b, q.a, q.b, need)


def volumes_clear(vols: Sequence[Volume], others: Sequence[Volume], sep_xy_m: float, sep_z_m: float) -> bool:
    """No volume of ``vols`` conflicts with one of ``others``: ``not any(volumes_conflict(v, q, ...))``.

    The same tests as :func:`volumes_conflict` in the same order, written out over the pairs (mission control
    asks this for every candidate flight, layer and hold point; ``tests/test_volumes.py`` checks the two agree).
    """
    for v in vols:
        vz0, vz1, vs = v.z0_m, v.z1_m, v.slack_m
        (ax, ay), (bx, by) = v.a, v.b
        vx0, vx1 = min(ax, bx), max(ax, bx)
        vy0, vy1 = min(ay, by), max(ay, by)
        for q in others:
            if vz0 - q.z1_m >= sep_z_m or q.z0_m - vz1 >= sep_z_m:
                continue
            need = sep_xy_m + vs + q.slack_m
            (cx, cy), (dx, dy) = q.a, q.b
            if (
                (cx if cx <= dx else dx) - vx1 >= need
                or vx0 - (cx if cx >= dx else dx) >= need
                or (cy if cy <= dy else dy) - vy1 >= need
                or vy0 - (cy if cy >= dy else dy) >= need
            ):
                continue
            if segment_segment_m(v.a, v.b, q.a, q.b) < need:
                return False
    return True


def ahead_of(vols: Sequence[Volume], x: float, y: float, z: float) -> list[Volume] | None:
    """What of a flight's volumes ``vols`` a UAV reported at ``(x, y, z)`` still needs: the rest of the lateral leg
    it is on (from ``TRACK_M`` behind it) and what follows, or the zone it is coming down into.

    None: nothing is behind it (at the start of a leg, or not on the flight: a report sent before it was granted).
    """
    kept: list[Volume] | None = None
    last_leg: Volume | None = None
    for i, v in enumerate(vols):
        if v.kind != "leg":
            continue
        last_leg = v
        (ax, ay), (bx, by) = v.a, v.b
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        if length < 1e-9 or abs(z - v.z0_m) >= 0.2:
            continue
        along = ((x - ax) * dx + (y - ay) * dy) / length
        across = abs((x - ax) * dy - (y - ay) * dx) / length
        if across > TRACK_M or along > length + TRACK_M:
            continue
        cut = along - TRACK_M
        if cut <= 0.0:
            return None  # at the start of this leg: it may still be climbing (or stopped climbing) to it
        # on this leg: everything before it (its climb, earlier legs, a hover) is behind it
        rest = list(vols[i + 1 :])
        if cut < length:
            f = max(0.0, cut) / length
            rest.insert(0, Volume((ax + f * dx, ay + f * dy), v.b, v.z0_m, v.z1_m, 0.0, "leg"))
        kept = rest
        break
    if kept is None:
        # coming down over its site at the end of its last leg (not a hold flight: that ends in a hover); not still
        # climbing at the leg's start a few decimetres from it (a hop to the next segment 0.3 m on: its climb and
        # leg were freed under it, 0.15 m out of its volumes for 1.85 s, issue 27 §4.3)
        zone = vols[-1]
        to_site = math.hypot(x - zone.a[0], y - zone.a[1])
        if (
            last_leg is None
            or zone.kind != "zone"
            or z >= last_leg.z0_m - 0.2
            or to_site >= TRACK_M
            or to_site >= math.hypot(x - last_leg.a[0], y - last_leg.a[1])
            or math.hypot(last_leg.b[0] - zone.a[0], last_leg.b[1] - zone.a[1]) > 1e-6
        ):
            return None
        kept = [zone]
    return kept


def contains(vols: Sequence[Volume], x: float, y: float, z: float, margin_m: float = TRACK_M) -> bool:
    """``(x, y, z)`` lies in one of ``vols``, or within ``margin_m`` of it (tracking error, a late report)."""
    for v in vols:
        if not v.z0_m - margin_m <= z <= v.z1_m + margin_m:
            continue
        if point_segment_m((x, y), v.a, v.b) <= v.slack_m + margin_m:
            return True
    return False


def leave_from(xy: XY, vols: Sequence[Volume]) -> XY:
    """Where a UAV at ``xy`` holding ``vols`` leaves from: the nearest point of its work zone if it holds only
    one and is within ``LEAVE_SNAP_M`` outside it, else ``xy``.

    Anything granted after the zone was granted keeps the separation from the zone, not from the few centimetres
    past it where the UAV came to rest: a climb reserved there could be refused for good by a hover that fits
    beside the zone, whose UAV waits for the zone to be freed (issue 27: ``bench_layouts --large`` seed 3022, an
    adhesion UAV 5 cm past its bead's end 1.15 m from a brick UAV's hold point 1.20 m from the zone).
    """
    if len(vols) != 1 or vols[0].kind != "zone":
        return xy
    v = vols[0]
    px, py = nearest_on_segment(xy, v.a, v.b)
    d = math.hypot(xy[0] - px, xy[1] - py)
    if d <= v.slack_m or d > v.slack_m + LEAVE_SNAP_M:
        return xy
    f = v.slack_m / d
    return (px + f * (xy[0] - px), py + f * (xy[1] - py))


def on_leg(p: Vec3, vols: Sequence[Volume]) -> Vec3:
    """Where a UAV at ``p`` that stopped on a lateral leg it holds asks from: the nearest point of that leg, at its
    altitude, if ``p`` is within ``LEAVE_SNAP_M`` of it horizontally and vertically, else ``p``.

    As :func:`leave_from` for a zone: anything granted while it flew keeps the separation from its leg, not from
    the few centimetres off it where it came to rest, and a climb reserved there could conflict at every layer with
    a hover granted beside the leg (issue 27, ``bench_layouts --large``: seed 3310, an adhesion UAV turned back 3 cm
    off its hold leg, 1.188 m from a hover 1.217 m from the leg; seed 3275, one 2 cm over its leg, 1.08 m under a
    hover 1.1 m over the leg): no hold flight fitted, and the leg it kept blocked the UAV it waited for.
    """
    for v in vols:
        if v.kind != "leg" or abs(p[2] - v.z0_m) > LEAVE_SNAP_M:
            continue
        q = nearest_on_segment((p[0], p[1]), v.a, v.b)
        if math.hypot(p[0] - q[0], p[1] - q[1]) <= LEAVE_SNAP_M:
            return (q[0], q[1], v.z0_m)
    return p


def column(site: Vec3, top_m: float, to: XY | None, slack_m: float) -> Volume:
    """The zone over ``site``: from the ground up to ``top_m``, along to ``to`` (an adhesion segment), ``slack_m``
    wide."""
    xy = (site[0], site[1])
    return Volume(xy, xy if to is None else to, 0.0, top_m, slack_m, "zone")


def flight_volumes(
    start: XY,
    z0_m: float,
    alt_m: float,
    target: Vec3 | None,
    top_m: float,
    hold: XY | None,
    to: XY | None,
    slack_m: float,
) -> list[Volume]:
    """A flight's volumes: the climb at ``start`` from ``z0_m`` to ``alt_m``, the leg there to the target (or the
    hold point), and the target's column up to ``top_m`` (or the hover at the hold point, ``slack_m`` wide)."""
    vols = [Volume(start, start, min(z0_m, alt_m), max(z0_m, alt_m), 0.0, "climb")]
    end = hold if hold is not None else (target[0], target[1]) if target is not None else start
    if math.hypot(end[0] - start[0], end[1] - start[1]) > 1e-6:
        vols.append(Volume(start, end, alt_m, alt_m, 0.0, "leg"))
    if hold is not None:
        vols.append(Volume(end, end, alt_m, alt_m, slack_m, "hover"))  # it may overshoot a little
    elif target is not None:
        vols.append(column(target, max(top_m, alt_m), to, slack_m))
    return vols


def same_site(a: Vec3, b: Vec3) -> bool:
    """The same site (column): the same point horizontally."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) < 1e-3


def stopped_at(xy: XY, z: float, vols: Sequence[Volume]) -> list[Volume]:
    """The volumes of a UAV that stopped at ``xy`` (``z`` high) inside ``vols``: a hover there, and ``STOP_M`` of
    the lateral leg ahead if it stopped on one (it may coast on along it)."""
    here = [Volume(xy, xy, z - HOVER_SLACK_M, z + HOVER_SLACK_M, HOVER_SLACK_M, "hover")]
    for v in vols:
        length = math.hypot(v.b[0] - v.a[0], v.b[1] - v.a[1])
        if (
            v.kind != "leg"
            or length < 1e-9
            or abs(z - v.z0_m) >= 0.2
            or point_segment_m(xy, v.a, v.b) > TRACK_M
        ):
            continue
        ux, uy = (v.b[0] - v.a[0]) / length, (v.b[1] - v.a[1]) / length
        along = (xy[0] - v.a[0]) * ux + (xy[1] - v.a[1]) * uy
        end = min(length, along + STOP_M)
        if end > along:
            here.append(Volume(xy, (v.a[0] + end * ux, v.a[1] + end * uy), v.z0_m, v.z1_m, 0.0, "leg"))
        break
    return here


def hold_points(
    site: Vec3,
    keep_out: Sequence[XY],
    spans: Sequence[tuple[XY, XY]],
    radius_m: float,
    from_m: XY | None = None,
    ring_step_m: float | None = None,
) -> list[Vec3]:
    """Points around ``site`` (rings ``radius_m`` apart, nearest first, at least six when there are) at least
    1.1 ``radius_m`` from every point of ``keep_out`` and every segment of ``spans``; one far point if none is.

    Given ``from_m`` (where the UAV sent there is), the points of a ring come nearest to it first: on the way
    from there to the site, not round the far side of it (issue 27; else by their angle from east); and the
    points on its straight line to the site, ``HOLD_LINE_STEP_M`` apart from ``radius_m`` out to it, are among
    them by their distance from the site (a sprayer at its linger spot 2.5 m from its segment, the ring at
    1.5 m blocked, waited 3 m out, past where it was: issue 27). ``ring_step_m``: rings that far apart instead
    (from ``radius_m`` out to 8 ``radius_m``).
    """
    r = 1.1 * radius_m
    r2 = r * r

    def free(p: XY) -> bool:
        return all((p[0] - k[0]) ** 2 + (p[1] - k[1]) ** 2 >= r2 for k in keep_out) and all(
            point_segment_m(p, a, b) >= r for a, b in spans
        )

    step = max(radius_m, 0.25)
    radii = [ring * step for ring in range(1, 9)]
    if ring_step_m is not None:  # finer rings, from ``radius_m`` out as far
        radii = [step + i * ring_step_m for i in range(int(7 * step / ring_step_m) + 1)]
    out: list[tuple[float, Vec3]] = []
    for rad in radii:
        for a in range(24):
            ang = 2.0 * math.pi * a / 24.0
            c = (site[0] + rad * math.cos(ang), site[1] + rad * math.sin(ang))
            if free(c):
                out.append((rad, (c[0], c[1], site[2])))
        if len(out) >= 6:
            break
    if from_m is not None:
        fx, fy = from_m
        far = math.hypot(fx - site[0], fy - site[1])
        if far > radius_m:  # the points on the UAV's straight line to the site, from ``radius_m`` out to it
            ux, uy = (fx - site[0]) / far, (fy - site[1]) / far
            d = step
            while d < far + 1e-9:
                c = (site[0] + d * ux, site[1] + d * uy)
                if free(c):
                    out.append((d, (c[0], c[1], site[2])))
                d += HOLD_LINE_STEP_M
        out.sort(
            key=lambda x: math.hypot(x[1][0] - fx, x[1][1] - fy)
        )  # (stable: the rings' order wins below)
    return [p for _d, p in sorted(out, key=lambda x: x[0])] or [(site[0] + 8 * step, site[1], site[2])]


__all__ = [
    "HOLD_LINE_STEP_M",
    "HOVER_SLACK_M",
    "LEAVE_SNAP_M",
    "STOP_M",
    "TRACK_M",
    "XY",
    "Vec3",
    "Volume",
    "ahead_of",
    "column",
    "flight_volumes",
    "hold_points",
    "leave_from",
    "on_leg",
    "point_segment_m",
    "same_site",
    "segment_segment_m",
    "stopped_at",
    "volumes_clear",
    "volumes_conflict",
]
