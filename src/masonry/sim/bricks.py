"""Bricks as objects in the simulated world: where each really lies, who carries it, where it landed.

Geometry is 2.5-D: a brick is a box with a yaw; it rests on the ground (z = 0) or on the top of bricks below it.
Lookups go through a uniform spatial hash on the ground plane, so finding the bricks near an effector, a camera
or a falling brick costs the same for a 10-brick wall and a 10,000-brick one.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Literal

from masonry.blueprint import Brick
from masonry.errors import InvalidArgument
from masonry.sim.settle import rest_z_m

__all__ = [
    "GROUND_Z_M",
    "BrickField",
    "SimBrick",
    "SpatialHash",
    "point_in_rect",
    "rect_corners",
    "rects_overlap",
]

GROUND_Z_M = 0.0
#: The height bins (m) :meth:`BrickField.covered_at` files the resting bricks' bottoms in, per ground cell (a cell
#: holds a brick of every course of a wall; a marker is covered only by a brick whose bottom is at its height).
BOTTOM_BIN_M = 0.01
BrickState = Literal["pickup", "carried", "placed"]


class SpatialHash:
    """Keys indexed by the ground-plane cells their bounding boxes touch."""

    def __init__(self, cell_m: float = 0.5) -> None:
        if not cell_m > 0:
            raise InvalidArgument(f"cell_m must be > 0, got {cell_m!r}")
        self.cell_m = float(cell_m)
        self._cells: dict[tuple[int, int], set[int]] = {}
        self._where: dict[int, list[tuple[int, int]]] = {}

    def _range(self, lo: float, hi: float) -> range:
        return range(math.floor(lo / self.cell_m), math.floor(hi / self.cell_m) + 1)

    def insert(self, key: int, xmin: float, ymin: float, xmax: float, ymax: float) -> None:
        self.remove(key)
        cells = [(i, j) for i in self._range(xmin, xmax) for j in self._range(ymin, ymax)]
        for c in cells:
            self._cells.setdefault(c, set()).add(key)
        self._where[key] = cells

    def remove(self, key: int) -> None:
        for c in self._where.pop(key, ()):
            bucket = self._cells[c]
            bucket.discard(key)
            if not bucket:
                del self._cells[c]

    def query(self, xmin: float, ymin: float, xmax: float, ymax: float) -> set[int]:
        """Keys whose cells meet the box (a superset of the keys whose boxes meet it)."""
        found: set[int] = set()
        cells = self._cells
        for i in self._range(xmin, xmax):
            for j in self._range(ymin, ymax):
                bucket = cells.get((i, j))
                if bucket:
                    found |= bucket
        return found

    def query_point(self, x: float, y: float) -> set[int] | None:
        """Keys whose cells hold the point (None if none; the set is the index's own: do not modify it)."""
        c = self.cell_m
        return self._cells.get((math.floor(x / c), math.floor(y / c)))

    def cells_of(self, key: int) -> list[tuple[int, int]]:
        """The cells ``key`` is indexed in (none: not indexed)."""
        return self._where.get(key, [])

    def __contains__(self, key: object) -> bool:
        return key in self._where

    def __len__(self) -> int:
        return len(self._where)


def rect_corners(x: float, y: float, yaw: float, hx: float, hy: float) -> list[tuple[float, float]]:
    """Corners of a rectangle centred at (x, y) with half sizes (hx, hy) along its yawed axes, counter-clockwise."""
    c, s = math.cos(yaw), math.sin(yaw)
    return [
        (x + c * dx - s * dy, y + s * dx + c * dy) for dx, dy in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
    ]


def point_in_rect(px: float, py: float, x: float, y: float, yaw: float, hx: float, hy: float) -> bool:
    """Whether (px, py) lies in the yawed rectangle (closed)."""
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = px - x, py - y
    return abs(c * dx + s * dy) <= hx and abs(-s * dx + c * dy) <= hy


def rects_overlap(
    a: tuple[float, float, float, float, float], b: tuple[float, float, float, float, float]
) -> bool:
    """Whether two yawed rectangles (x, y, yaw, hx, hy) overlap with positive area (separating axis test)."""
    # The arithmetic of ``rect_corners`` and of the projections, written out (a falling or carried brick tests
    # its neighbours every physics step): same corners, same axes, same comparisons.
    ax, ay, ayaw, ahx, ahy = a
    bx, by, byaw, bhx, bhy = b
    ac, as_ = math.cos(ayaw), math.sin(ayaw)
    bc, bs = math.cos(byaw), math.sin(byaw)
    ca = [
        (ax + ac * dx - as_ * dy, ay + as_ * dx + ac * dy)
        for dx, dy in ((-ahx, -ahy), (ahx, -ahy), (ahx, ahy), (-ahx, ahy))
    ]
    cb = [
        (bx + bc * dx - bs * dy, by + bs * dx + bc * dy)
        for dx, dy in ((-bhx, -bhy), (bhx, -bhy), (bhx, bhy), (-bhx, bhy))
    ]
    for ux, uy in ((ac, as_), (-as_, ac), (bc, bs), (-bs, bc)):
        (p0x, p0y), (p1x, p1y), (p2x, p2y), (p3x, p3y) = ca
        a0, a1, a2, a3 = ux * p0x + uy * p0y, ux * p1x + uy * p1y, ux * p2x + uy * p2y, ux * p3x + uy * p3y
        (p0x, p0y), (p1x, p1y), (p2x, p2y), (p3x, p3y) = cb
        b0, b1, b2, b3 = ux * p0x + uy * p0y, ux * p1x + uy * p1y, ux * p2x + uy * p2y, ux * p3x + uy * p3y
        if (
            max(a0, a1, a2, a3) <= min(b0, b1, b2, b3) + 1e-9
            or max(b0, b1, b2, b3) <= min(a0, a1, a2, a3) + 1e-9
        ):
            return False
    return True


@dataclass(eq=False)
class SimBrick:
    """One brick's true state: centre ``position_m``, ``yaw_rad``, and where it is in its life."""

    id: int
    blueprint: Brick
    position_m: tuple[float, float, float]
    yaw_rad: float
    state: BrickState
    carrier: str | None = None
    released: bool = False  # dropped at least once by a UAV: its placement error is measured
    picked_from: tuple[tuple[float, float, float], float] | None = (
        None  # its pose (centre, yaw) when last picked
    )
    marker_cache: tuple[object, object] | None = field(default=None, repr=False)  # camera model's, per pose

    @property
    def size_m(self) -> tuple[float, float, float]:
        return self.blueprint.size_m

    @property
    def top_z_m(self) -> float:
        return self.position_m[2] + self.blueprint.size_m[2] / 2.0

    @property
    def bottom_z_m(self) -> float:
        return self.position_m[2] - self.blueprint.size_m[2] / 2.0

    @property
    def top_center_m(self) -> tuple[float, float, float]:
        return (self.position_m[0], self.position_m[1], self.top_z_m)

    def rect(self, shrink_m: float = 0.0) -> tuple[float, float, float, float, float]:
        """Footprint as (x, y, yaw, hx, hy), optionally shrunk on every side."""
        sx, sy, _ = self.blueprint.size_m
        return (
            self.position_m[0],
            self.position_m[1],
            self.yaw_rad,
            max(sx / 2.0 - shrink_m, 1e-4),
            max(sy / 2.0 - shrink_m, 1e-4),
        )

    def placement_error_m(self) -> float:
        """Distance from the blueprint centre."""
        return math.dist(self.position_m, self.blueprint.position_m)


class BrickField:
    """All bricks of a world; the resting ones (at a pickup site or placed) indexed by a spatial hash.

    A resting brick does not move while it is indexed (it moves when picked, :meth:`pick`, and is indexed again
    where it comes to rest): its footprint is kept with it, computed once (:meth:`covered_at` and
    :meth:`support_at` ask for it every camera frame and physics step).
    """

    def __init__(self, cell_m: float = 0.5) -> None:
        self.bricks: dict[int, SimBrick] = {}
        self._hash = SpatialHash(cell_m)
        self.max_top_z_m = GROUND_Z_M  # highest brick top ever indexed: nothing rests above it
        # (resting brick id -> bottom z, top z, x, y, cos yaw, sin yaw, half sizes: ``rect()``'s arithmetic)
        self._rest: dict[int, tuple[float, float, float, float, float, float, float, float]] = {}
        self._rects: dict[int, tuple[float, float, float, float, float]] = {}  # (resting brick -> rect())
        #: bumped whenever the resting bricks change (one indexed or picked): answers about them kept meanwhile
        #: (the camera's marker layout, ``covered_at``) are still the answers
        self.version = 0
        self._covered: dict[tuple[float, float, float], bool] = {}  # (covered_kept's answers at this version)
        # (ground cell i, j and bottom height bin -> the resting bricks there; brick id -> its keys)
        self._by_bottom: dict[tuple[int, int, int], set[int]] = {}
        self._bottom_keys: dict[int, list[tuple[int, int, int]]] = {}

    def __iter__(self) -> Iterator[SimBrick]:
        return iter(self.bricks.values())

    def __len__(self) -> int:
        return len(self.bricks)

    def add(self, brick: SimBrick) -> None:
        self.bricks[brick.id] = brick
        if brick.state != "carried":
            self._index(brick)

    def _index(self, brick: SimBrick) -> None:
        self.version += 1
        self._covered.clear()
        self.max_top_z_m = max(self.max_top_z_m, brick.top_z_m)
        rect = brick.rect()
        xs, ys = zip(*rect_corners(*rect))
        self._hash.insert(brick.id, min(xs), min(ys), max(xs), max(ys))
        x, y, yaw, hx, hy = rect
        bottom = brick.bottom_z_m
        self._rest[brick.id] = (bottom, brick.top_z_m, x, y, math.cos(yaw), math.sin(yaw), hx, hy)
        self._rects[brick.id] = rect
        self._unfile_bottom(brick.id)
        zb = math.floor(bottom / BOTTOM_BIN_M)
        keys = [(i, j, zb) for i, j in self._hash.cells_of(brick.id)]
        for key in keys:
            self._by_bottom.setdefault(key, set()).add(brick.id)
        self._bottom_keys[brick.id] = keys

    def _unfile_bottom(self, brick_id: int) -> None:
        for key in self._bottom_keys.pop(brick_id, ()):
            bucket = self._by_bottom[key]
            bucket.discard(brick_id)
            if not bucket:
                del self._by_bottom[key]

    def pick(self, brick_id: int, carrier: str) -> SimBrick:
        """Take a resting brick out of the index: it is now carried."""
        brick = self.bricks[brick_id]
        self.version += 1
        self._covered.clear()
        self._hash.remove(brick_id)
        self._rest.pop(brick_id, None)
        self._rects.pop(brick_id, None)
        self._unfile_bottom(brick_id)
        brick.picked_from = (brick.position_m, brick.yaw_rad)
        brick.state = "carried"
        brick.carrier = carrier
        return brick

    def drop(self, brick_id: int, shrink_m: float) -> SimBrick:
        """Let a carried brick fall straight down onto the bricks below its footprint that hold it, and index it."""
        brick = self.bricks[brick_id]
        x, y, _ = brick.position_m
        support = self.rest_under(brick.rect(shrink_m), below_z_m=brick.bottom_z_m)
        brick.position_m = (x, y, support + brick.size_m[2] / 2.0)
        brick.state = "placed"
        brick.carrier = None
        brick.released = True
        self._index(brick)
        return brick

    def return_to_pickup(self, brick_id: int) -> SimBrick:
        """A carried brick taken off its UAV by hand and laid back where it was picked up (the ground crew's)."""
        brick = self.bricks[brick_id]
        assert brick.state == "carried" and brick.picked_from is not None
        brick.position_m, brick.yaw_rad = brick.picked_from
        brick.state = "pickup"
        brick.carrier = None
        self._index(brick)
        return brick

    def near(self, x: float, y: float, radius_m: float) -> Iterable[SimBrick]:
        """Resting bricks whose indexed cells meet the square of half side ``radius_m`` around (x, y)."""
        bricks = self.bricks
        return [bricks[k] for k in self._hash.query(x - radius_m, y - radius_m, x + radius_m, y + radius_m)]

    def support_at(self, x: float, y: float, below_z_m: float = math.inf, tol_m: float = 0.02) -> float:
        """Height of the surface under the point (x, y) at or below ``below_z_m`` (+ ``tol_m``): a brick top or the ground."""
        top = GROUND_Z_M
        limit = below_z_m + tol_m
        rest = self._rest
        for k in self._hash.query_point(x, y) or ():
            _, t, bx, by, c, s, hx, hy = rest[k]
            if top < t <= limit:
                # point_in_rect(x, y, *b.rect()), inline (a tool near the bricks asks every physics step)
                dx, dy = x - bx, y - by
                if abs(c * dx + s * dy) <= hx and abs(-s * dx + c * dy) <= hy:
                    top = t
        return top

    def covered_at(self, x: float, y: float, z: float, tol_m: float = 1e-3) -> bool:
        """Whether a resting brick sits on the surface point (x, y, z) (its bottom at z, its footprint over it)."""
        if not math.isfinite(z):
            return False  # (no bottom is within any tolerance of it)
        rest = self._rest
        # the bricks of the point's cell with their bottoms in the bins that z +- tol_m meets (a margin over the
        # rounding of the bins' edges): the exact test below decides, as on every brick of the cell
        lo = math.floor((z - tol_m - 1e-9) / BOTTOM_BIN_M)
        hi = math.floor((z + tol_m + 1e-9) / BOTTOM_BIN_M)
        if hi - lo > 8:
            candidates: Iterable[int] = self._hash.query_point(x, y) or ()
        else:
            cell = self._hash.cell_m
            i, j = math.floor(x / cell), math.floor(y / cell)
            by_bottom = self._by_bottom
            candidates = [k for zb in range(lo, hi + 1) for k in by_bottom.get((i, j, zb), ())]
        for k in candidates:
            g = rest[k]
            if abs(g[0] - z) <= tol_m:
                # point_in_rect(x, y, *b.rect()), inline (every marker of every camera frame asks)
                _, _, bx, by, c, s, hx, hy = g
                dx, dy = x - bx, y - by
                if abs(c * dx + s * dy) <= hx and abs(-s * dx + c * dy) <= hy:
                    return True
        return False

    def covered_kept(self, x: float, y: float, z: float) -> bool:
        """:meth:`covered_at` (default tolerance), each point's answer kept until the resting bricks change: the
        camera asks it for every marker in view of every frame, the same markers frame after frame."""
        key = (x, y, z)
        hit = self._covered.get(key)
        if hit is None:
            hit = self._covered[key] = self.covered_at(x, y, z)
        return hit

    def support_under(
        self, rect: tuple[float, float, float, float, float], below_z_m: float = math.inf, tol_m: float = 0.02
    ) -> float:
        """Height of the highest surface under a footprint, at or below ``below_z_m`` (+ ``tol_m``)."""
        xs, ys = zip(*rect_corners(*rect))
        limit = below_z_m + tol_m
        rest, rects = self._rest, self._rects
        # The answer is the highest top among the overlapping candidates: test them highest first and stop at
        # the first overlap (a carried brick over a wall asks every physics step; the lower courses under it
        # need no overlap test). The maximum does not depend on the order, so this is the plain scan's answer.
        # Tops and footprints as indexed (``top_z_m``, ``rect()``: a resting brick does not move while indexed).
        tops: list[tuple[float, int]] = []
        for k in self._hash.query(min(xs), min(ys), max(xs), max(ys)):
            t = rest[k][1]
            if GROUND_Z_M < t <= limit:
                tops.append((t, k))
        if len(tops) > 1:
            tops.sort(reverse=True)
        for t, k in tops:
            if rects_overlap(rect, rects[k]):
                return t
        return GROUND_Z_M

    def rest_under(
        self, rect: tuple[float, float, float, float, float], below_z_m: float = math.inf, tol_m: float = 0.02
    ) -> float:
        """Height a brick with footprint ``rect`` released at ``below_z_m`` (+ ``tol_m``) comes to rest at: the
        highest tops under it that hold it (its centre over them; masonry.sim.settle), else lower down."""
        xs, ys = zip(*rect_corners(*rect))
        limit = below_z_m + tol_m
        bricks = self.bricks
        supports = []
        for k in self._hash.query(min(xs), min(ys), max(xs), max(ys)):
            b = bricks[k]
            if GROUND_Z_M < b.top_z_m <= limit and rects_overlap(rect, b.rect()):
                supports.append((b.top_z_m, b.rect()))
        return rest_z_m(rect, supports, GROUND_Z_M)
