"""Uniform-grid spatial hashing: candidate pairs of nearby items without examining all pairs.

Items are binned by integer cell coordinates; only items in the same or adjacent cells (the 27-cell
neighbourhood in 3-D) are paired. Everything is vectorised with numpy and produced in bounded chunks so a
100k-item scene never materialises all candidate pairs at once.
"""

from __future__ import annotations

from collections.abc import Iterator
from itertools import product

import numpy as np
from numpy.typing import NDArray

IntArray = NDArray[np.int64]


def _forward_offsets(reach: int) -> tuple[tuple[int, int, int], ...]:
    """Half of the neighbour offsets within ``reach`` cells (the other half gives the same pairs reversed)."""
    steps = range(-reach, reach + 1)
    return tuple((dx, dy, dz) for dx, dy, dz in product(steps, repeat=3) if (dx, dy, dz) > (0, 0, 0))


def cell_coordinates(points: NDArray[np.float64], cell_size: NDArray[np.float64] | float) -> IntArray:
    """Integer cell of each point (n, 3) for a grid of ``cell_size`` (scalar or per axis)."""
    size = np.broadcast_to(np.asarray(cell_size, dtype=float), (3,))
    cells: IntArray = np.floor(np.asarray(points, dtype=float) / size).astype(np.int64)
    return cells


def neighbour_pairs(
    cells: IntArray, chunk_pairs: int = 2_000_000, reach: int = 1, max_gap: float | None = None
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield index arrays ``(a, b)`` of every unordered pair of items at most ``reach`` cells apart, once each.

    Args:
        cells: (n, 3) integer cell coordinates, one row per item.
        chunk_pairs: soft upper bound on the number of pairs yielded per chunk.
        reach: how many cells away (per axis) a neighbour may be; 1 is the 27-cell neighbourhood.
        max_gap: with ``cell_size``, skip cell offsets whose cells are farther apart than this (the corners of
            a large ``reach``): give it as a multiple of cells, i.e. ``max_gap / cell_size``.
    """
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    n = len(cells)
    if n < 2:
        return
    yield from _item_pairs(*_cell_pairs(cells, reach, max_gap), chunk_pairs)


def _cell_pairs(
    cells: IntArray, reach: int, max_gap: float | None
) -> tuple[IntArray, IntArray, IntArray, IntArray, IntArray, NDArray[np.bool_]]:
    """The pairs of occupied cells to pair items from (each cell with itself, then with each forward neighbour).

    Returns:
        ``order`` (the items sorted by cell), then per cell pair the first index into ``order`` and the item
        count of its two cells (``sa, ca, sb, cb``), and whether it is a cell with itself (``same``).
    """
    # Compress each axis to ranks so the combined cell code never overflows, whatever the coordinates.
    uniques = [np.unique(cells[:, k]) for k in range(3)]
    ranks = np.stack([np.searchsorted(uniques[k], cells[:, k]) for k in range(3)], axis=1)
    dims = [len(u) for u in uniques]
    code = (ranks[:, 0] * dims[1] + ranks[:, 1]) * dims[2] + ranks[:, 2]
    order = np.argsort(code, kind="stable")
    sorted_code = code[order]
    ucode, starts, counts = np.unique(sorted_code, return_index=True, return_counts=True)
    # Representative rank triple and raw coordinates of each occupied cell.
    rep = order[starts]
    cell_ranks = ranks[rep]
    cell_raw = cells[rep]

    pair_sa: list[IntArray] = [starts]
    pair_ca: list[IntArray] = [counts]
    pair_sb: list[IntArray] = [starts]
    pair_cb: list[IntArray] = [counts]
    pair_self: list[NDArray[np.bool_]] = [np.ones(len(ucode), dtype=bool)]
    for offset in _forward_offsets(reach):
        if max_gap is not None:
            gap = sum(max(abs(d) - 1, 0) ** 2 for d in offset) ** 0.5  # closest approach, in cells
            if gap > max_gap:
                continue
        valid = np.ones(len(ucode), dtype=bool)
        nranks = np.empty_like(cell_ranks)
        for k in range(3):
            target = cell_raw[:, k] + offset[k]
            r = np.searchsorted(uniques[k], target)
            r_clipped = np.minimum(r, dims[k] - 1)
            valid &= uniques[k][r_clipped] == target
            nranks[:, k] = r_clipped
        ncode = (nranks[:, 0] * dims[1] + nranks[:, 1]) * dims[2] + nranks[:, 2]
        idx = np.minimum(np.searchsorted(ucode, ncode), len(ucode) - 1)
        valid &= ucode[idx] == ncode
        src = np.nonzero(valid)[0]
        dst = idx[valid]
        pair_sa.append(starts[src])
        pair_ca.append(counts[src])
        pair_sb.append(starts[dst])
        pair_cb.append(counts[dst])
        pair_self.append(np.zeros(len(src), dtype=bool))

    return (
        order,
        np.concatenate(pair_sa),
        np.concatenate(pair_ca),
        np.concatenate(pair_sb),
        np.concatenate(pair_cb),
        np.concatenate(pair_self),
    )


def _item_pairs(
    order: IntArray,
    sa: IntArray,
    ca: IntArray,
    sb: IntArray,
    cb: IntArray,
    same: NDArray[np.bool_],
    chunk_pairs: int,
) -> Iterator[tuple[IntArray, IntArray]]:
    """Expand the cell pairs of :func:`_cell_pairs` into item index pairs, about ``chunk_pairs`` per chunk."""
    sizes = ca * cb
    keep = sizes > 0
    sa, ca, sb, cb, same, sizes = sa[keep], ca[keep], sb[keep], cb[keep], same[keep], sizes[keep]
    bounds = np.cumsum(sizes)
    # Within a chunk the arithmetic fits int32 (half the memory traffic of int64) unless a cell pair is huge.
    small = int(sizes.max()) < 2**31 - 1
    it = np.int32 if small else np.int64
    sa, ca, sb, cb = sa.astype(it), ca.astype(it), sb.astype(it), cb.astype(it)
    begin = 0
    while begin < len(sizes):
        base = bounds[begin - 1] if begin else 0
        end = int(np.searchsorted(bounds, base + chunk_pairs, side="right"))
        end = max(end, begin + 1)
        sl = slice(begin, end)
        m = sizes[sl]
        total = int(m.sum())
        which = np.repeat(np.arange(end - begin, dtype=it), m)
        t = np.arange(total, dtype=np.int64 if total >= 2**31 - 1 else it) - np.repeat(
            (np.cumsum(m) - m).astype(it), m
        )
        cbw = cb[sl][which]
        ia = t // cbw
        ib = t % cbw
        keep_pair = ~same[sl][which] | (ia < ib)
        a = order[sa[sl][which][keep_pair] + ia[keep_pair]]
        b = order[sb[sl][which][keep_pair] + ib[keep_pair]]
        yield a, b
        begin = end
