"""Which bricks rest on which, and which interpenetrate: a uniform grid over brick centres, no all-pairs scan.

Brick i rests on brick j when |bottom(i) - top(j)| <= RESTING_TOLERANCE_M and their footprints overlap with
positive area (separating-axis depth > CONTACT_EPS_M). Two bricks interpenetrate when their volumes overlap by
more than PENETRATION_TOLERANCE_M on every separating axis (z and the four footprint edge normals).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from masonry.planner.overlap import sat_depth
from masonry.planner.spatial import cell_coordinates, neighbour_pairs

#: |bottom(upper) - top(lower)| within this counts as resting (the issue's 5 mm), and the ground tolerance.
RESTING_TOLERANCE_M = 0.005
#: Volumes may overlap this much (e.g. a brick sunk into the one below within the resting tolerance).
PENETRATION_TOLERANCE_M = 0.005
#: Footprints must overlap deeper than this to count as a contact with positive area.
CONTACT_EPS_M = 1e-4


@dataclass(frozen=True)
class BrickArrays:
    """Column arrays of a brick list (index = position in the list)."""

    center: NDArray[np.float64]  # (n, 3)
    half: NDArray[np.float64]  # (n, 3) half sizes along length, width, height
    yaw: NDArray[np.float64]  # (n,)

    @classmethod
    def of(
        cls, positions: Sequence[Sequence[float]], sizes: Sequence[Sequence[float]], yaws: Sequence[float]
    ) -> BrickArrays:
        center = np.asarray(positions, dtype=float).reshape(-1, 3)
        half = np.asarray(sizes, dtype=float).reshape(-1, 3) / 2.0
        return cls(center, half, np.asarray(yaws, dtype=float).reshape(-1))

    @property
    def bottom(self) -> NDArray[np.float64]:
        return self.center[:, 2] - self.half[:, 2]

    @property
    def top(self) -> NDArray[np.float64]:
        return self.center[:, 2] + self.half[:, 2]


@dataclass(frozen=True)
class Contacts:
    """Result of the contact search; index arrays refer to positions in the brick list."""

    upper: NDArray[np.int64]  # brick upper[k] rests on brick lower[k]
    lower: NDArray[np.int64]
    penetrating: NDArray[np.int64]  # (m, 2) pairs whose volumes interpenetrate


def find_contacts(bricks: BrickArrays, chunk_pairs: int = 2_000_000) -> Contacts:
    """Resting pairs and interpenetrating pairs, using a grid sized to the largest brick."""
    n = len(bricks.center)
    empty = np.zeros(0, dtype=np.int64)
    if n < 2:
        return Contacts(empty, empty, np.zeros((0, 2), dtype=np.int64))
    radius = np.hypot(bricks.half[:, 0], bricks.half[:, 1])
    cell = np.array(
        [
            max(2.0 * float(radius.max()), 1e-6),
            max(2.0 * float(radius.max()), 1e-6),
            max(2.0 * float(bricks.half[:, 2].max()) + RESTING_TOLERANCE_M, 1e-6),
        ]
    )
    cells = cell_coordinates(bricks.center, cell)
    uppers: list[NDArray[np.int64]] = []
    lowers: list[NDArray[np.int64]] = []
    pens: list[NDArray[np.int64]] = []
    bottom, top = bricks.bottom, bricks.top
    xy = bricks.center[:, :2]
    hxy = bricks.half[:, :2]
    for a, b in neighbour_pairs(cells, chunk_pairs):
        near = np.hypot(*(xy[a] - xy[b]).T) < radius[a] + radius[b]
        a, b = a[near], b[near]
        if len(a) == 0:
            continue
        z_overlap = np.minimum(top[a], top[b]) - np.maximum(bottom[a], bottom[b])
        a_on_b = np.abs(bottom[a] - top[b]) <= RESTING_TOLERANCE_M
        b_on_a = np.abs(bottom[b] - top[a]) <= RESTING_TOLERANCE_M
        maybe = (z_overlap > PENETRATION_TOLERANCE_M) | a_on_b | b_on_a
        a, b = a[maybe], b[maybe]
        z_overlap, a_on_b, b_on_a = z_overlap[maybe], a_on_b[maybe], b_on_a[maybe]
        depth = sat_depth(xy[a], hxy[a], bricks.yaw[a], xy[b], hxy[b], bricks.yaw[b])
        touching = depth > CONTACT_EPS_M
        pen = (depth > PENETRATION_TOLERANCE_M) & (z_overlap > PENETRATION_TOLERANCE_M)
        pens.append(np.stack([a[pen], b[pen]], axis=1))
        rest_ab = touching & a_on_b & ~pen
        rest_ba = touching & b_on_a & ~pen
        uppers.extend((a[rest_ab], b[rest_ba]))
        lowers.extend((b[rest_ab], a[rest_ba]))
    upper = np.concatenate(uppers) if uppers else empty
    lower = np.concatenate(lowers) if lowers else empty
    order = np.lexsort((lower, upper))
    pen_pairs = np.concatenate(pens) if pens else np.zeros((0, 2), dtype=np.int64)
    if len(pen_pairs):
        pen_pairs = np.sort(pen_pairs, axis=1)
        pen_pairs = pen_pairs[np.lexsort((pen_pairs[:, 1], pen_pairs[:, 0]))]
    return Contacts(upper[order], lower[order], pen_pairs)
