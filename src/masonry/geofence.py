"""The site's geofence: a polygon in the world frame and an altitude limit, and the geometry around it.

A blueprint may declare its site (``site: {boundary: [[x, y], ...], max_altitude: H}``, docs/blueprint-format.md):
mission control grants no flight that leaves it (:mod:`masonry.mission.airspace`), the UAVs' machines clamp their
setpoints to it and leave a task whose UAV is blown out of it (:mod:`masonry.fsm.fence`), and the MAVLink adapter
uploads it as the autopilot's own fence (:mod:`masonry.adapters.mavlink_fence`). Pure: floats in, floats out.

Distances are horizontal unless a name says otherwise; "inside by d" means at least ``d`` metres from every edge
on the inner side, "outside by d" at least ``d`` metres from the polygon on the outer side.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

XY = tuple[float, float]
Vec3 = tuple[float, float, float]

#: The wall, every pickup and every home lie at least this far inside the boundary (validation): a UAV working
#: there (its body up to half its 0.8 m span off the point) keeps its setpoints ``SETPOINT_MARGIN_M`` inside.
SITE_MARGIN_M = 1.0
#: A UAV's machine keeps its setpoints (reference positions) this far inside the boundary and under the altitude.
SETPOINT_MARGIN_M = 0.5
#: Mission control grants no volume closer than this to the boundary (or to the altitude limit): the setpoint
#: margin, so that a UAV inside its volumes flies setpoints the clamp leaves alone.
AIRSPACE_MARGIN_M = SETPOINT_MARGIN_M
#: ``max_altitude`` is at least this far above the highest transit layer the airspace will use.
ALTITUDE_MARGIN_M = 0.5
#: A UAV seen this far outside (beyond the boundary or above the limit) has breached the fence: its task stops.
BREACH_MARGIN_M = 0.3
#: The most vertices a boundary may have (a site outline, not a survey).
MAX_BOUNDARY_VERTICES = 1000


@dataclass(frozen=True)
class Site:
    """A site's geofence: a simple polygon (either orientation) and the highest altitude a UAV may reach.

    Attributes:
        boundary_m: the polygon's vertices, world frame (x east, y north), metres; not closed (the last vertex
            joins the first).
        max_altitude_m: the altitude limit, metres above the world origin.
    """

    boundary_m: tuple[XY, ...]
    max_altitude_m: float

    def inside_m(self, x: float, y: float) -> float:
        """How far ``(x, y)`` is inside the boundary: its distance to the nearest edge, negative outside."""
        best = math.inf  # the squared distance to the nearest edge
        inside = False
        for ax, ay, by, ex, ey, inv in self._edges():
            # the crossing test uses the stored end point: ``ay + ey`` can round a vertex off the ray's side
            if (ay > y) != (by > y) and x < ax + (y - ay) * ex / ey:
                inside = not inside
            dx, dy = x - ax, y - ay
            t = (dx * ex + dy * ey) * inv
            if t > 1.0:
                t = 1.0
            elif t < 0.0:
                t = 0.0
            dx -= t * ex
            dy -= t * ey
            d2 = dx * dx + dy * dy
            best = min(best, d2)
        d = math.sqrt(best)
        return d if inside else -d

    def _edges(self) -> tuple[tuple[float, float, float, float, float, float], ...]:
        """Each edge's start, end y, direction and inverse squared length (a cache: the control loop asks every tick)."""
        edges = self.__dict__.get("_edge_cache")
        if edges is None:
            pts = self.boundary_m
            n = len(pts)
            out = []
            for i in range(n):
                (ax, ay), (bx, by) = pts[i], pts[(i + 1) % n]
                ex, ey = bx - ax, by - ay
                ll = ex * ex + ey * ey
                out.append((ax, ay, by, ex, ey, 0.0 if ll == 0.0 else 1.0 / ll))
            edges = tuple(out)
            object.__setattr__(self, "_edge_cache", edges)  # a cache, not state (the value stays frozen)
        return edges

    def outside_by_m(self, p_m: Sequence[float]) -> float:
        """How far the point ``p_m`` (x, y, z) is outside the fence: beyond the boundary or above the altitude
        limit, whichever is more (0 or less: inside)."""
        return max(-self.inside_m(float(p_m[0]), float(p_m[1])), float(p_m[2]) - self.max_altitude_m)

    def contains(self, x: float, y: float, margin_m: float = 0.0) -> bool:
        """``(x, y)`` lies at least ``margin_m`` inside the boundary."""
        return self.inside_m(x, y) >= margin_m

    def segment_inside(self, a: XY, b: XY, margin_m: float = 0.0) -> bool:
        """The whole segment ``a -> b`` lies at least ``margin_m`` inside the boundary (no edge crosses it or comes
        within the margin, and it starts inside)."""
        if not self.contains(a[0], a[1], margin_m) or not self.contains(b[0], b[1], margin_m):
            return False
        pts = self.boundary_m
        n = len(pts)
        for i in range(n):
            c, d = pts[i], pts[(i + 1) % n]
            gap = _segment_segment_m(a, b, c, d)
            if gap < margin_m or gap == 0.0:  # (with no margin: an edge it crosses or touches)
                return False
        return True

    def clamp_m(self, p_m: Sequence[float], margin_m: float = SETPOINT_MARGIN_M) -> Vec3:
        """The point nearest ``p_m`` at least ``margin_m`` inside the boundary and below the altitude limit
        (``p_m`` itself when it is).

        Alternating projections onto the edges' inner half-planes: exact for a convex boundary, and within a few
        centimetres of the inner offset curve at a concave corner (the result is always checked to lie inside by
        the margin, else the nearest vertex's inward bisector point is used).
        """
        x, y, z = float(p_m[0]), float(p_m[1]), float(p_m[2])
        z = min(z, self.max_altitude_m - margin_m)
        if self.inside_m(x, y) >= margin_m:
            return (x, y, z)
        for _ in range(8):
            i = self._nearest_edge(x, y)
            x, y = self._push_inside(i, x, y, margin_m)
            if self.inside_m(x, y) >= margin_m - 1e-9:
                return (x, y, z)
        bx, by = self._inner_point(margin_m)
        # on from there toward the point asked for, as far as the margin allows (bisection)
        lo, hi = 0.0, 1.0
        px, py = float(p_m[0]), float(p_m[1])
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            if self.inside_m(bx + mid * (px - bx), by + mid * (py - by)) >= margin_m:
                lo = mid
            else:
                hi = mid
        return (bx + lo * (px - bx), by + lo * (py - by), z)

    def signed_area_m2(self) -> float:
        """The polygon's area, positive when its vertices run counter-clockwise."""
        pts = self.boundary_m
        n = len(pts)
        return 0.5 * sum(pts[i][0] * pts[(i + 1) % n][1] - pts[(i + 1) % n][0] * pts[i][1] for i in range(n))

    def _nearest_edge(self, x: float, y: float) -> int:
        pts = self.boundary_m
        n = len(pts)
        best, best_d = 0, math.inf
        for i in range(n):
            (ax, ay), (bx, by) = pts[i], pts[(i + 1) % n]
            d = _point_segment_m(x, y, ax, ay, bx, by)
            if d < best_d:
                best, best_d = i, d
        return best

    def _push_inside(self, i: int, x: float, y: float, margin_m: float) -> XY:
        """Move ``(x, y)`` onto the inner side of edge ``i``'s line, ``margin_m`` from it (if it is not there)."""
        pts = self.boundary_m
        (ax, ay), (bx, by) = pts[i], pts[(i + 1) % len(pts)]
        ex, ey = bx - ax, by - ay
        length = math.hypot(ex, ey)
        # the inner normal: left of the edge for a counter-clockwise polygon, right for a clockwise one
        s = 1.0 if self.signed_area_m2() > 0.0 else -1.0
        nx, ny = -s * ey / length, s * ex / length
        depth = (x - ax) * nx + (y - ay) * ny
        if depth < margin_m:
            x, y = x + (margin_m - depth) * nx, y + (margin_m - depth) * ny
        # and along the edge within its ends (a point beyond a convex corner is pushed by both edges in turn)
        t = ((x - ax) * ex + (y - ay) * ey) / (length * length)
        if t < 0.0 or t > 1.0:
            t = min(1.0, max(0.0, t))
            x, y = ax + t * ex + margin_m * nx, ay + t * ey + margin_m * ny
        return (x, y)

    def _inner_point(self, margin_m: float) -> XY:
        """A point at least ``margin_m`` inside (the deepest vertex bisector point, or the centroid)."""
        pts = self.boundary_m
        n = len(pts)
        best, best_d = _centroid(pts), -math.inf
        for i in range(n):
            (px, py), (cx, cy), (qx, qy) = pts[i - 1], pts[i], pts[(i + 1) % n]
            ux, uy = _unit(px - cx, py - cy)
            vx, vy = _unit(qx - cx, qy - cy)
            bx, by = _unit(ux + vx, uy + vy)
            for sign in (1.0, -1.0):
                for step in (margin_m * 1.5, margin_m * 3.0, margin_m * 6.0):
                    qx2, qy2 = cx + sign * step * bx, cy + sign * step * by
                    d = self.inside_m(qx2, qy2)
                    if d > best_d:
                        best, best_d = (qx2, qy2), d
        if self.inside_m(*_centroid(pts)) > best_d:
            best = _centroid(pts)
        return best


def simple_polygon_problem(points: Sequence[XY]) -> str | None:
    """Why ``points`` is not a simple polygon (None: it is): fewer than 3 vertices, a repeated vertex, no area, or
    two edges that cross or touch."""
    n = len(points)
    if n < 3:
        return f"has {n} vertices: a polygon needs at least 3"
    for i in range(n):
        a, b = points[i], points[(i + 1) % n]
        if math.hypot(b[0] - a[0], b[1] - a[1]) < 1e-6:
            return f"vertices {i} and {(i + 1) % n} are the same point"
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                continue  # neighbouring edges share a vertex
            a, b = points[i], points[(i + 1) % n]
            c, d = points[j], points[(j + 1) % n]
            if _segment_segment_m(a, b, c, d) < 1e-9:
                return f"edges {i}-{(i + 1) % n} and {j}-{(j + 1) % n} cross: the boundary is not a simple polygon"
    if abs(Site(tuple(points), 0.0).signed_area_m2()) < 1e-9:
        return "has no area (its vertices lie on one line)"
    return None


def _centroid(pts: Sequence[XY]) -> XY:
    return (sum(p[0] for p in pts) / len(pts), sum(p[1] for p in pts) / len(pts))


def _unit(x: float, y: float) -> XY:
    n = math.hypot(x, y)
    return (0.0, 0.0) if n < 1e-12 else (x / n, y / n)


def _point_segment_m(x: float, y: float, ax: float, ay: float, bx: float, by: float) -> float:
    ex, ey = bx - ax, by - ay
    ll = ex * ex + ey * ey
    t = 0.0 if ll == 0.0 else max(0.0, min(1.0, ((x - ax) * ex + (y - ay) * ey) / ll))
    return math.hypot(x - (ax + t * ex), y - (ay + t * ey))


def _segment_segment_m(a: XY, b: XY, c: XY, d: XY) -> float:
    """The shortest distance between segments ``a-b`` and ``c-d`` (0 when they cross)."""

    def orient(p: XY, q: XY, r: XY) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if ((o1 > 0) != (o2 > 0)) and ((o3 > 0) != (o4 > 0)) and o1 != 0 and o2 != 0 and o3 != 0 and o4 != 0:
        return 0.0
    return min(
        _point_segment_m(a[0], a[1], c[0], c[1], d[0], d[1]),
        _point_segment_m(b[0], b[1], c[0], c[1], d[0], d[1]),
        _point_segment_m(c[0], c[1], a[0], a[1], b[0], b[1]),
        _point_segment_m(d[0], d[1], a[0], a[1], b[0], b[1]),
    )


__all__ = [
    "AIRSPACE_MARGIN_M",
    "ALTITUDE_MARGIN_M",
    "BREACH_MARGIN_M",
    "MAX_BOUNDARY_VERTICES",
    "SETPOINT_MARGIN_M",
    "SITE_MARGIN_M",
    "Site",
    "simple_polygon_problem",
]
