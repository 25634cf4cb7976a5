"""Horizontal distances between points and segments: the geometry that keeps reserved volumes apart.

Mission control's airspace (:mod:`masonry.mission.volumes`) and the space-time reservation model
(:mod:`masonry.reservation`) both measure with these. Pure: no I/O.
"""

from __future__ import annotations

import math

XY = tuple[float, float]


def _along(p: XY, a: XY, b: XY) -> float:
    """Where on the segment ``a``-``b`` (0 at ``a``, 1 at ``b``) the point nearest ``p`` lies."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    n2 = dx * dx + dy * dy
    return 0.0 if n2 == 0.0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / n2))


def point_segment_m(p: XY, a: XY, b: XY) -> float:
    """Horizontal distance from ``p`` to the segment ``a``-``b``."""
    t = _along(p, a, b)
    return math.hypot(p[0] - a[0] - t * (b[0] - a[0]), p[1] - a[1] - t * (b[1] - a[1]))


def nearest_on_segment(p: XY, a: XY, b: XY) -> XY:
    """The point of the segment ``a``-``b`` nearest ``p``."""
    t = _along(p, a, b)
    return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))


def segment_segment_m(a: XY, b: XY, c: XY, d: XY) -> float:
    """Horizontal distance between segments ``a``-``b`` and ``c``-``d``."""

    def orient(p: XY, q: XY, r: XY) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if o1 * o2 < 0.0 and o3 * o4 < 0.0:
        return 0.0  # they cross
    return min(
        point_segment_m(c, a, b), point_segment_m(d, a, b), point_segment_m(a, c, d), point_segment_m(b, c, d)
    )


def segments_closer_than(a: XY, b: XY, c: XY, d: XY, need_m: float) -> bool:
    """Segments ``a``-``b`` and ``c``-``d`` come horizontally closer than ``need_m`` (a cheap reject on their
    bounding boxes before the exact distance: most pairs of a fleet's volumes are far apart)."""
    if (
        min(a[0], b[0]) - max(c[0], d[0]) >= need_m
        or min(c[0], d[0]) - max(a[0], b[0]) >= need_m
        or min(a[1], b[1]) - max(c[1], d[1]) >= need_m
        or min(c[1], d[1]) - max(a[1], b[1]) >= need_m
    ):
        return False
    return segment_segment_m(a, b, c, d) < need_m


__all__ = ["XY", "nearest_on_segment", "point_segment_m", "segment_segment_m", "segments_closer_than"]
