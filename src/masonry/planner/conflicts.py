"""The conflict graph G^c (paper Section III): task pairs closer than r_c that are not dependent.

Candidates come from a uniform grid over task locations (cell = r_c plus the longest adhesion segment), so
no all-pairs scan; distances are exact 3-D point/segment distances. Dependent pairs are then removed with a
reachability test that stays local: every edge of G^d goes strictly downwards (an upper brick's centre is
above the adhesion line on the brick below, which is above that brick's centre), so a dependency path
between two tasks less than r_c apart only visits tasks whose height lies between theirs. Each task keeps a
bitset of its descendants restricted to the tasks in its height window [z - r_c, z), built bottom-up in one
pass; a candidate pair is then one bit lookup.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from masonry.errors import PlanningError
from masonry.planner.overlap import segment_distances
from masonry.planner.spatial import cell_coordinates, neighbour_pairs

#: Pairs at distance <= r_c + this conflict (the paper's dist <= r_c): a pair laid out exactly r_c apart must not be
#: lost to rounding (1.5 m from 0.3 m bricks comes out as 1.5000000000000002 m).
CONFLICT_TOLERANCE_M = 1e-9

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]


def conflict_pairs(
    start: FloatArray,
    end: FloatArray,
    clearance_m: float,
    edges: tuple[IntArray, IntArray],
    chunk_pairs: int = 250_000,
    reach: int = 3,
) -> tuple[IntArray, IntArray]:
    """Pairs (a, b), a < b, of tasks within ``clearance_m`` of each other that are not dependent.

    Args:
        start, end: (n, 3) task locations: equal rows for a point (a brick's drop-off), else a segment
            (an adhesion line).
        clearance_m: r_c; pairs at distance <= r_c (+ CONFLICT_TOLERANCE_M) conflict.
        edges: (u, v) index arrays of G^d restricted to these tasks: u can start only after v; every edge
            must go strictly downwards in z.
        chunk_pairs: bound on candidate pairs handled at once (memory).
        reach: grid cells are (r_c + longest segment) / reach wide and searched ``reach`` cells away.

    Raises:
        PlanningError: an edge does not go downwards (the dependency graph would not be a DAG by height).
    """
    start = np.asarray(start, dtype=float).reshape(-1, 3)
    end = np.asarray(end, dtype=float).reshape(-1, 3)
    n = len(start)
    empty = np.zeros(0, dtype=np.int64)
    if n < 2:
        return empty, empty
    # Work in height order: index k is the k-th lowest task, so an ancestor always has the larger index.
    z_all = (start[:, 2] + end[:, 2]) / 2.0
    order = np.argsort(z_all, kind="stable")
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    r_c = clearance_m + CONFLICT_TOLERANCE_M
    windows = DescendantWindows(z_all[order], r_c, (rank[edges[0]], rank[edges[1]]))
    start = start[order]
    end = end[order]
    mid = (start + end) / 2.0
    half_len = np.sqrt(((end - start) ** 2).sum(axis=1)) / 2.0
    longest = float(half_len.max())
    # A little slack so rounding never puts a pair at exactly r_c + 2 * longest one cell too far apart.
    cell = (r_c + 2.0 * longest) * (1.0 + 1e-9) / reach + 1e-12
    cells = cell_coordinates(mid, cell)
    # Lay the tasks out cell by cell so the gathers below read nearby memory (a cell's tasks are contiguous).
    by_cell = np.lexsort((cells[:, 2], cells[:, 1], cells[:, 0]))
    cells = cells[by_cell]
    mid_c = mid[by_cell]
    start_c, end_c, half_c = start[by_cell], end[by_cell], half_len[by_cell]
    rank_c = by_cell  # the rank (height order) of each cell-ordered task
    # One contiguous array per axis: gathering scalars is several times faster than gathering (n, 3) rows.
    mx, my, mz = (np.ascontiguousarray(mid_c[:, k]) for k in range(3))
    r2 = r_c * r_c
    keys: list[IntArray] = []
    for a, b in neighbour_pairs(cells, chunk_pairs, reach, max_gap=float(reach)):
        d = mx[a] - mx[b]
        d2 = d * d
        d = my[a] - my[b]
        d2 += d * d
        d = mz[a] - mz[b]
        d2 += d * d
        # The midpoints lie on the segments: d_mid <= r_c is a conflict for sure, and d_mid > r_c + both half
        # lengths cannot be one; only the band between needs the exact segment distance.
        sure = d2 <= r2
        if longest > 0.0:
            bound = r_c + half_c[a] + half_c[b] + 1e-9
            band = np.nonzero(~sure & (d2 <= bound * bound))[0]
            if len(band):
                ia, ib = a[band], b[band]
                sure[band] = segment_distances(start_c[ia], end_c[ia], start_c[ib], end_c[ib]) <= r_c
        ra, rb = rank_c[a[sure]], rank_c[b[sure]]
        hi, lo = np.maximum(ra, rb), np.minimum(ra, rb)
        keep = ~windows.reaches(hi, lo)
        # Back to input indices, then one sortable key per pair.
        ga, gb = order[lo[keep]], order[hi[keep]]
        keys.append(np.minimum(ga, gb) * n + np.maximum(ga, gb))
    key = np.sort(np.concatenate(keys)) if keys else empty
    return key // n, key % n


class DescendantWindows:
    """Per task, the bitset of its G^d descendants whose height is within ``window_m`` below it."""

    def __init__(self, z_sorted: FloatArray, window_m: float, edges: tuple[IntArray, IntArray]) -> None:
        """Args: ``z_sorted`` heights in ascending order (index = rank); ``edges`` (u, v) as ranks, u above v."""
        z_sorted = np.asarray(z_sorted, dtype=float)
        n = len(z_sorted)
        u = np.asarray(edges[0], dtype=np.int64)
        v = np.asarray(edges[1], dtype=np.int64)
        if np.any(z_sorted[u] <= z_sorted[v]):
            k = int(np.argmax(z_sorted[u] <= z_sorted[v]))
            raise PlanningError(
                f"dependency edge from a task at z = {z_sorted[u[k]]:.4f} m to one at z = {z_sorted[v[k]]:.4f} m "
                "does not go downwards"
            )
        lo = np.searchsorted(z_sorted, z_sorted - window_m - 1e-9, side="left").astype(np.int64)
        w0 = lo >> 6
        w1 = np.where(np.arange(n) > lo, ((np.arange(n) - 1) >> 6) + 1, w0)
        nwords = w1 - w0
        offset = np.concatenate([[0], np.cumsum(nwords)]).astype(np.int64)
        bits = np.zeros(int(offset[-1]), dtype=np.uint64)
        # Children of each task (by rank), grouped.
        by_parent = np.argsort(u, kind="stable")
        cu, cv = u[by_parent], v[by_parent]
        first = np.searchsorted(cu, np.arange(n + 1))
        cv_list = cv.tolist()
        first_list = first.tolist()
        lo_list, w0_list, w1_list, off_list = lo.tolist(), w0.tolist(), w1.tolist(), offset.tolist()
        for r in range(n):
            k0, k1 = first_list[r], first_list[r + 1]
            if k0 == k1:
                continue
            base, lo_r, w0_r = off_list[r], lo_list[r], w0_list[r]
            row = bits[base : base + (w1_list[r] - w0_r)]
            for k in range(k0, k1):
                c = cv_list[k]
                if c < lo_r:
                    continue  # the child and everything under it are below the window
                row[(c >> 6) - w0_r] |= np.uint64(1 << (c & 63))
                w0_c, w1_c = w0_list[c], w1_list[c]
                if w1_c > w0_r:
                    oc = off_list[c]
                    row[: w1_c - w0_r] |= bits[oc + (w0_r - w0_c) : oc + (w1_c - w0_c)]
        self._lo = lo
        self._w0 = w0
        self._offset = offset
        self._bits = bits

    def reaches(self, src: IntArray, dst: IntArray) -> NDArray[np.bool_]:
        """Whether rank ``dst`` is a descendant of rank ``src`` (exact whenever z(src) - z(dst) <= window)."""
        inside = (dst >= self._lo[src]) & (dst < src)
        if len(self._bits) == 0:
            return np.zeros(len(src), dtype=bool)
        index = np.where(inside, self._offset[src] + (dst >> 6) - self._w0[src], 0)
        words = self._bits[index]
        bit = (words >> (dst & 63).astype(np.uint64)) & np.uint64(1)
        found: NDArray[np.bool_] = inside & (bit == 1)
        return found

    def dependent(self, a: IntArray, b: IntArray) -> NDArray[np.bool_]:
        """Whether either rank of each pair is reachable from the other."""
        return self.reaches(np.maximum(a, b), np.minimum(a, b))
