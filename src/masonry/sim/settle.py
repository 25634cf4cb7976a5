"""Where a released brick comes to rest: on the highest bricks under it that can hold it, else lower down.

A brick lies flat on the bricks under its footprint only if its centre of mass is over the region it rests on (the
convex hull of its overlaps with them) or the adhesive holds it (it rests on a good share of its footprint, as a
running bond's end bricks overhanging by half do). Resting on a sliver of a neighbour's corner, it tips off and falls to the
next level down: a brick released beside a misplaced neighbour does not end up a course too high, balanced on a
corner (docs/simulator.md, "Release"; a GNSS-placed wall in tests/test_wall_align.py met it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = ["HELD_FRACTION", "LEVEL_TOL_M", "Rect", "clip_rect", "rect_polygon", "rest_z_m", "stands_on"]

#: (x, y, yaw, hx, hy): a footprint's centre, yaw and half sides (masonry.sim.bricks.SimBrick.rect).
Rect = tuple[float, float, float, float, float]
Point = tuple[float, float]

#: Supports whose tops are this close in height form one level a brick rests on together.
LEVEL_TOL_M = 0.01
#: The adhesive holds a brick that rests on at least this share of its footprint even with its centre beyond its
#: supports (a running bond's end bricks overhang by half); on less, a sliver of a corner, it tips off.
HELD_FRACTION = 0.25


def rect_polygon(rect: Rect) -> list[Point]:
    """A footprint's corners, counter-clockwise."""
    x, y, yaw, hx, hy = rect
    c, s = math.cos(yaw), math.sin(yaw)
    return [
        (x + c * dx - s * dy, y + s * dx + c * dy) for dx, dy in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
    ]


def _cross(o: Point, a: Point, b: Point) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def clip_rect(polygon: Sequence[Point], rect: Rect) -> list[Point]:
    """The part of a convex ``polygon`` inside the footprint ``rect`` (Sutherland-Hodgman); [] if they do not meet."""
    out = list(polygon)
    corners = rect_polygon(rect)
    for i in range(4):
        a, b = corners[i], corners[(i + 1) % 4]
        pts, out = out, []
        for j, p in enumerate(pts):
            q = pts[(j + 1) % len(pts)]
            p_in, q_in = _cross(a, b, p) >= 0.0, _cross(a, b, q) >= 0.0
            if p_in:
                out.append(p)
            if p_in != q_in:
                dp, dq = _cross(a, b, p), _cross(a, b, q)
                t = dp / (dp - dq)
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
        if not out:
            return []
    return out


def _hull(points: list[Point]) -> list[Point]:
    """Convex hull, counter-clockwise (Andrew's monotone chain)."""
    pts = sorted(set(points))
    if len(pts) < 3:
        return pts
    lower: list[Point] = []
    for p in pts:
        while len(lower) >= 2 and _cross(lower[-2], lower[-1], p) <= 0.0:
            lower.pop()
        lower.append(p)
    upper: list[Point] = []
    for p in reversed(pts):
        while len(upper) >= 2 and _cross(upper[-2], upper[-1], p) <= 0.0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def _area_m2(polygon: Sequence[Point]) -> float:
    return 0.5 * abs(
        sum(_cross((0.0, 0.0), a, polygon[(i + 1) % len(polygon)]) for i, a in enumerate(polygon))
    )


def stands_on(footprint: Rect, supports: Sequence[Rect], tol_m: float = 1e-6) -> bool:
    """Whether a brick with ``footprint`` lying on ``supports`` (one level) stays there: its centre is within
    ``tol_m`` of the convex hull of its overlaps with them, or they cover :data:`HELD_FRACTION` of it."""
    own = rect_polygon(footprint)
    parts = [part for r in supports if (part := clip_rect(own, r))]
    if sum(_area_m2(part) for part in parts) >= HELD_FRACTION * 4.0 * footprint[3] * footprint[4]:
        return True
    hull = _hull([p for part in parts for p in part])
    if len(hull) < 3:
        return False  # an edge or a point of contact holds nothing
    c = (footprint[0], footprint[1])
    for i, a in enumerate(hull):
        b = hull[(i + 1) % len(hull)]
        if _cross(a, b, c) < -tol_m * math.dist(a, b):
            return False
    return True


def rest_z_m(footprint: Rect, supports: Sequence[tuple[float, Rect]], ground_z_m: float) -> float:
    """The height a released brick's bottom comes to rest at, given the ``(top_z_m, footprint)`` of the bricks its
    footprint overlaps below it: the highest level of them it stands on (:func:`stands_on`), else the ground."""
    left = sorted(supports, key=lambda s: s[0], reverse=True)
    while left:
        top = left[0][0]
        level = [r for t, r in left if t >= top - LEVEL_TOL_M]
        if stands_on(footprint, level):
            return top
        left = [(t, r) for t, r in left if t < top - LEVEL_TOL_M]
    return ground_z_m
