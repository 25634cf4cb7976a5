"""The volumes of the reservation model and when two of them are too close (pure: no I/O, no clock).

A :class:`Volume` is a capsule standing upright: every point within ``radius_m`` (horizontally) of the 2-D
segment ``a``-``b``, between altitudes ``z0_m`` and ``z1_m``. A column over a point (a climb, a descent, a
work zone, a pad) has ``a == b``; a transit leg is a segment at one altitude; an adhesion segment's work zone
runs along it. The same shapes as mission control's airspace (:mod:`masonry.mission.volumes`), with one more
field, ``kind``, that says which separation applies:

- ``air``: an airborne UAV. Two of them keep :data:`masonry.separation.SEPARATION_XY_M` horizontally (plus both
  radii) or :data:`masonry.separation.LAYER_SPACING_M` vertically.
- ``ground``: a UAV landed on its pad or a parking spot. Anything else keeps the pad separation from it
  (:func:`masonry.separation.pad_separation_m`: the span plus a margin), as a landed UAV holds only its pad.
- ``site``: the paper's conflict rule (G^c) as a volume: a task's site (its work point or level adhesion segment,
  at its height), which another task's site may not come within r_c of (the 3-D distance, ``<= r_c`` plus the
  planner's tolerance, as :mod:`masonry.planner.conflicts` counts it). Sites keep apart from sites only; no UAV
  is in them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from masonry.errors import InvalidArgument
from masonry.segments import XY, segment_segment_m, segments_closer_than
from masonry.separation import LAYER_SPACING_M, SEPARATION_XY_M, pad_separation_m

#: Two sites at distance <= r_c + this conflict: :data:`masonry.planner.conflicts.CONFLICT_TOLERANCE_M` (not
#: imported: the planner's package pulls in networkx; a test keeps the two equal).
SITE_TOLERANCE_M = 1e-9

VolumeKind = Literal["air", "ground", "site"]
VOLUME_KINDS: tuple[VolumeKind, ...] = ("air", "ground", "site")


@dataclass(frozen=True)
class Volume:
    """Every point within ``radius_m`` (horizontally) of the segment ``a``-``b``, from ``z0_m`` up to ``z1_m``.

    ``kind`` (``air``, ``ground`` or ``site``) says which separation keeps it from another volume
    (:meth:`Separation.conflict`).
    """

    a: XY
    b: XY
    z0_m: float
    z1_m: float
    radius_m: float = 0.0
    kind: VolumeKind = "air"

    def __post_init__(self) -> None:
        values = (*self.a, *self.b, self.z0_m, self.z1_m, self.radius_m)
        if not all(math.isfinite(v) for v in values):
            raise InvalidArgument(f"a volume's coordinates must be finite numbers, got {self}")
        if self.z1_m < self.z0_m:
            raise InvalidArgument(f"a volume's top z1_m {self.z1_m} is below its bottom z0_m {self.z0_m}")
        if self.radius_m < 0.0:
            raise InvalidArgument(f"a volume's radius_m must be >= 0, got {self.radius_m}")
        if self.kind not in VOLUME_KINDS:
            raise InvalidArgument(
                f"a volume's kind must be one of {', '.join(VOLUME_KINDS)}, got {self.kind!r}"
            )


def column(xy: XY, z0_m: float, z1_m: float, radius_m: float = 0.0, kind: VolumeKind = "air") -> Volume:
    """A vertical column over ``xy`` from ``z0_m`` to ``z1_m`` (a climb, a descent, a work zone)."""
    lo, hi = min(z0_m, z1_m), max(z0_m, z1_m)
    return Volume(xy, xy, lo, hi, radius_m, kind)


def leg(a: XY, b: XY, z_m: float, radius_m: float = 0.0) -> Volume:
    """A lateral leg from ``a`` to ``b`` at altitude ``z_m``, swept ``radius_m`` wide."""
    return Volume(a, b, z_m, z_m, radius_m, "air")


def pad(xy: XY, top_m: float = 0.3) -> Volume:
    """A UAV landed at ``xy`` (its pad or a parking spot on the ground), ``top_m`` high."""
    return Volume(xy, xy, 0.0, top_m, 0.0, "ground")


def site(a: XY, clearance_m: float, b: XY | None = None, z_m: float = 0.0) -> Volume:
    """A task's site (its work point ``a``, or its level adhesion segment ``a``-``b``, at height ``z_m``) under
    the paper's conflict rule: no other task's site within ``clearance_m`` (r_c)."""
    return Volume(a, a if b is None else b, z_m, z_m, clearance_m, "site")


@dataclass(frozen=True)
class Separation:
    """How far apart two UAVs' volumes keep (defaults: :mod:`masonry.separation`'s numbers).

    Attributes:
        xy_m: horizontal separation between two ``air`` volumes (plus both radii).
        z_m: vertical separation: two ``air`` or ``ground`` volumes this far apart in altitude never conflict.
        pad_m: horizontal separation between a ``ground`` volume and any other ``air`` or ``ground`` one.
    """

    xy_m: float = SEPARATION_XY_M
    z_m: float = LAYER_SPACING_M
    pad_m: float = pad_separation_m()

    def conflict(self, p: Volume, q: Volume) -> bool:
        """Could a UAV in ``p`` come within the separation of one in ``q`` (or, for two ``site`` volumes, are the
        sites within r_c of each other)?"""
        if p.kind == "site" or q.kind == "site":
            if p.kind != q.kind:
                return False
            # level segments: the 3-D distance is the horizontal one and the difference in height
            need = max(p.radius_m, q.radius_m) + SITE_TOLERANCE_M
            return math.hypot(segment_segment_m(p.a, p.b, q.a, q.b), p.z0_m - q.z0_m) <= need
        if p.z0_m - q.z1_m >= self.z_m or q.z0_m - p.z1_m >= self.z_m:
            return False
        gap = self.pad_m if "ground" in (p.kind, q.kind) else self.xy_m
        need = gap + p.radius_m + q.radius_m
        return segments_closer_than(p.a, p.b, q.a, q.b, need)


#: The separation of :mod:`masonry.separation` (the default airframe's pads).
DEFAULT_SEPARATION = Separation()

__all__ = [
    "DEFAULT_SEPARATION",
    "SITE_TOLERANCE_M",
    "VOLUME_KINDS",
    "Separation",
    "Volume",
    "VolumeKind",
    "column",
    "leg",
    "pad",
    "site",
]
