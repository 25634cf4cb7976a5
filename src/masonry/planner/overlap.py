"""Rotated-rectangle footprints: separating-axis overlap, intersection polygons, adhesion lines; 3-D distances.

Footprints are rectangles in the xy plane given by centre (x, y), half sizes (hx, hy) along the brick's own
axes and a yaw. The vectorised functions take arrays of pairs so the planner never loops over pairs in Python
except for the rare footprints that are neither parallel nor perpendicular.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Point2 = tuple[float, float]

#: |sin(2 * yaw difference)| below this counts as parallel or perpendicular footprints.
AXIS_ALIGNED_EPS = 1e-9


def sat_depth(
    ca: FloatArray, ha: FloatArray, yaw_a: FloatArray, cb: FloatArray, hb: FloatArray, yaw_b: FloatArray
) -> FloatArray:
    """Smallest projected overlap of two rectangles over their four edge normals (the separating axes).

    Positive: the interiors intersect (for convex polygons the edge normals are the only candidate separating
    axes), and the value bounds how deep; zero or negative: the rectangles are disjoint or only touch.
    Arrays: centres (n, 2), half sizes (n, 2), yaws (n,).
    """
    ua = np.stack([np.cos(yaw_a), np.sin(yaw_a)], axis=1)
    va = np.stack([-np.sin(yaw_a), np.cos(yaw_a)], axis=1)
    ub = np.stack([np.cos(yaw_b), np.sin(yaw_b)], axis=1)
    vb = np.stack([-np.sin(yaw_b), np.cos(yaw_b)], axis=1)
    d = cb - ca
    depth = np.full(len(d), np.inf)
    for axis in (ua, va, ub, vb):
        ra = ha[:, 0] * np.abs(np.einsum("ij,ij->i", axis, ua)) + ha[:, 1] * np.abs(
            np.einsum("ij,ij->i", axis, va)
        )
        rb = hb[:, 0] * np.abs(np.einsum("ij,ij->i", axis, ub)) + hb[:, 1] * np.abs(
            np.einsum("ij,ij->i", axis, vb)
        )
        depth = np.minimum(depth, ra + rb - np.abs(np.einsum("ij,ij->i", axis, d)))
    return depth


def rectangle_corners(center: Point2, half: Point2, yaw_rad: float) -> list[Point2]:
    """Corners of a rotated rectangle, counter-clockwise."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return [
        (center[0] + c * dx - s * dy, center[1] + s * dx + c * dy)
        for dx, dy in ((-half[0], -half[1]), (half[0], -half[1]), (half[0], half[1]), (-half[0], half[1]))
    ]


def clip_convex(subject: Sequence[Point2], clip: Sequence[Point2]) -> list[Point2]:
    """Intersection of two convex counter-clockwise polygons (Sutherland-Hodgman); empty list if disjoint."""
    output = list(subject)
    n = len(clip)
    for k in range(n):
        if not output:
            break
        (x1, y1), (x2, y2) = clip[k], clip[(k + 1) % n]
        ex, ey = x2 - x1, y2 - y1
        inp = output
        output = []
        prev = inp[-1]
        sp = ex * (prev[1] - y1) - ey * (prev[0] - x1)  # > 0: left of the edge, inside
        for cur in inp:
            sc = ex * (cur[1] - y1) - ey * (cur[0] - x1)
            if sc >= 0.0:
                if sp < 0.0:
                    t = sp / (sp - sc)
                    output.append((prev[0] + t * (cur[0] - prev[0]), prev[1] + t * (cur[1] - prev[1])))
                output.append(cur)
            elif sp >= 0.0:
                t = sp / (sp - sc)
                output.append((prev[0] + t * (cur[0] - prev[0]), prev[1] + t * (cur[1] - prev[1])))
            prev, sp = cur, sc
    return output


def polygon_area_centroid(poly: Sequence[Point2]) -> tuple[float, Point2]:
    """Area and centroid of a simple counter-clockwise polygon."""
    a = cx = cy = 0.0
    n = len(poly)
    for k in range(n):
        x0, y0 = poly[k]
        x1, y1 = poly[(k + 1) % n]
        cross = x0 * y1 - x1 * y0
        a += cross
        cx += (x0 + x1) * cross
        cy += (y0 + y1) * cross
    a *= 0.5
    if abs(a) < 1e-18:
        xs = [p[0] for p in poly] or [0.0]
        ys = [p[1] for p in poly] or [0.0]
        return 0.0, (sum(xs) / len(xs), sum(ys) / len(ys))
    return a, (cx / (6.0 * a), cy / (6.0 * a))


def principal_axis(poly: Sequence[Point2]) -> tuple[Point2, Point2]:
    """Centroid and unit direction of the major principal axis of a polygon's area (second moments)."""
    _, (cx, cy) = polygon_area_centroid(poly)
    sxx = syy = sxy = 0.0
    n = len(poly)
    for k in range(n):
        x0, y0 = poly[k][0] - cx, poly[k][1] - cy
        x1, y1 = poly[(k + 1) % n][0] - cx, poly[(k + 1) % n][1] - cy
        cross = x0 * y1 - x1 * y0
        sxx += (y0 * y0 + y0 * y1 + y1 * y1) * cross  # integral of y^2
        syy += (x0 * x0 + x0 * x1 + x1 * x1) * cross  # integral of x^2
        sxy += (x0 * y1 + 2 * x0 * y0 + 2 * x1 * y1 + x1 * y0) * cross
    ixx, iyy, ixy = syy / 12.0, sxx / 12.0, sxy / 24.0  # integrals of x^2, y^2, xy
    angle = 0.5 * math.atan2(2.0 * ixy, ixx - iyy)
    return (cx, cy), (math.cos(angle), math.sin(angle))


def chord(poly: Sequence[Point2], origin: Point2, direction: Point2) -> tuple[float, float]:
    """Parameter range [t0, t1] of the line origin + t * direction inside a convex counter-clockwise polygon."""
    t0, t1 = -math.inf, math.inf
    n = len(poly)
    for k in range(n):
        (x1, y1), (x2, y2) = poly[k], poly[(k + 1) % n]
        ex, ey = x2 - x1, y2 - y1
        # inside: cross(e, p - p1) >= 0 ; along the line: f(t) = f0 + t * df
        f0 = ex * (origin[1] - y1) - ey * (origin[0] - x1)
        df = ex * direction[1] - ey * direction[0]
        if abs(df) < 1e-15:
            if f0 < 0.0:
                return 0.0, 0.0
            continue
        t = -f0 / df
        if df > 0.0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
    if not (math.isfinite(t0) and math.isfinite(t1)) or t1 < t0:
        return 0.0, 0.0
    return t0, t1


def segment_distances(p0: FloatArray, p1: FloatArray, q0: FloatArray, q1: FloatArray) -> FloatArray:
    """Closest distance between 3-D segments [p0, p1] and [q0, q1], row by row (points are zero-length segments).

    The clamped closed form of Ericson, *Real-Time Collision Detection*, section 5.1.9, vectorised.
    """
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    c = np.einsum("ij,ij->i", d1, r)
    b = np.einsum("ij,ij->i", d1, d2)
    eps = 1e-18
    a_zero = a <= eps
    e_zero = e <= eps
    safe_a = np.where(a_zero, 1.0, a)
    safe_e = np.where(e_zero, 1.0, e)
    denom = a * e - b * b
    s = np.where(denom > eps * np.maximum(a * e, eps), (b * f - c * e) / np.where(denom > 0, denom, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    t = (b * s + f) / safe_e
    # t outside [0, 1]: clamp it and recompute s.
    t_lo = t < 0.0
    t_hi = t > 1.0
    t = np.clip(t, 0.0, 1.0)
    s = np.where(t_lo, np.clip(-c / safe_a, 0.0, 1.0), s)
    s = np.where(t_hi, np.clip((b - c) / safe_a, 0.0, 1.0), s)
    # Degenerate segments.
    s = np.where(a_zero, 0.0, s)
    t = np.where(a_zero & ~e_zero, np.clip(f / safe_e, 0.0, 1.0), t)
    t = np.where(e_zero, 0.0, t)
    s = np.where(e_zero & ~a_zero, np.clip(-c / safe_a, 0.0, 1.0), s)
    closest = (p0 + d1 * s[:, None]) - (q0 + d2 * t[:, None])
    distance: FloatArray = np.sqrt(np.einsum("ij,ij->i", closest, closest))
    return distance
