"""The wall's relative looks combined in one weighted least-squares (issue 30): the horizontal centres of the placed
bricks from every offset seen between them, anchored on the surveyed bricks.

Pure: the surveyed bricks' centres (fixed), the sightings (one per as-built look: the placed brick and its offsets
to every neighbour seen in the same frames) and, optionally, a prior per brick (its world-frame look and that
look's variance) in; the centres, their variances and their surveyed roots out (:func:`solve`).

A sighting measures the bricks in view *up to a translation*: the frames place them all with the same telemetry,
whose error is common to them (on GNSS 6 cm that wanders over seconds; it cancels in their differences). So each
sighting has an unknown of its own, its frame's offset ``g``, and measures ``x_b - g = 0`` for its own brick and
``x_n - g = -offset_n`` for each neighbour ``n``, each with the variance of that brick's estimate in the look (half
the relative look's variance per link, :data:`~masonry.planner.wall_anchor.RELATIVE_SIGMA_M` squared, on a brick
seen in every frame; more on a brick seen in fewer). With one neighbour this is the old chain's link (the offset,
with the link's variance); with several, the errors they share (the placed brick's own, in every offset) are
counted once, not once per neighbour. The two horizontal axes are alike and independent: one sparse system
(the normal equations: bricks and sightings as unknowns), two right-hand sides.

Only the bricks connected to a surveyed one through sightings are solved (a component without a survey has no
absolute reference: its bricks keep their world-frame looks, which the caller knows). The root a brick is anchored
to is the lowest surveyed brick of its component (its id; the search this module did before the union-find of
:func:`_roots` gave every brick its component's first seed too, not the nearest one).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

Vec2 = tuple[float, float]

__all__ = ["Sighting", "Solution", "solve"]


@dataclass(frozen=True)
class Sighting:
    """One as-built look: ``brick`` seen with the neighbours ``offsets`` (neighbour id, the brick's centre less
    the neighbour's horizontally (m), the variance (m^2, per axis) of the neighbour's estimate in the look) and
    ``own_variance_m2`` (its own estimate's)."""

    brick: int
    offsets: tuple[tuple[int, Vec2, float], ...]
    own_variance_m2: float


@dataclass(frozen=True)
class Solution:
    """Brick id -> horizontal centre (m), its surveyed root, and (for the bricks asked for) its variance per axis
    (m^2); only the bricks connected to a surveyed one."""

    centre_m: dict[int, Vec2]
    root: dict[int, int]
    variance_m2: dict[int, float]


def _roots(
    fixed: Collection[int], sightings: Sequence[Sighting], unsurveyed: Collection[int] = ()
) -> dict[int, int]:
    """Brick id -> the root of its component of the sightings' graph: its lowest surveyed brick; for the
    components no surveyed brick reaches, their lowest id of ``unsurveyed`` (itself alone: a brick in no
    sighting); the bricks of the other components are left out."""
    # (union-find: one pass over the sightings, not a search from every seed; the roots are the same)
    parent: dict[int, int] = {}

    def find(b: int) -> int:
        while (up := parent[b]) != b:
            parent[b] = parent[up]
            b = up
        return b

    for s in sightings:
        top = parent.setdefault(s.brick, s.brick)
        top = find(top)
        for n, _, _ in s.offsets:
            other = find(parent.setdefault(n, n))
            if other != top:
                parent[other] = top
    label: dict[int, int] = {}  # (a component's union-find representative -> its root)
    root: dict[int, int] = {}
    for seeds in (sorted(fixed), sorted(unsurveyed)):
        for f in seeds:
            if f in parent:
                label.setdefault(find(f), f)
            else:
                root.setdefault(f, f)
    for b in parent:
        r = label.get(find(b))
        if r is not None:
            root[b] = r
    return root


def solve(
    fixed: Mapping[int, Vec2],
    sightings: Sequence[Sighting],
    priors: Mapping[int, tuple[Vec2, float]] | None = None,
    variance_of: Collection[int] = (),
    unsurveyed: bool = False,
) -> Solution:
    """The least-squares centres of the bricks that ``sightings`` connect to a ``fixed`` (surveyed) brick.

    ``priors``: brick id -> (a direct measurement of its centre, its variance per axis), for bricks among those
    solved (the world-frame looks; others are ignored). ``variance_of``: the bricks whose variance to return.
    ``unsurveyed``: also the components with no surveyed brick but a prior (their translation is then the priors'
    weighted mean, their shape the sightings'), rooted on their lowest id with a prior.
    """
    # scipy on call, as everywhere in the pure packages: `masonry --help` and the planner's import stay light
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    sightings = [s for s in sightings if s.offsets]
    root = _roots(fixed, sightings, (priors or {}).keys() if unsurveyed else ())
    free = sorted(b for b in root if b not in fixed)
    if not free:
        return Solution({}, {}, {})
    index = {b: i for i, b in enumerate(free)}
    used = [s for s in sightings if s.brick in root]
    m = len(free)
    n = m + len(used)
    # Every measurement of every sighting, in order: its sighting's row g, its brick, its y and its weight.
    # The normal equations are built from them with numpy in the same order as the plain loop over them would
    # (the same entries, summed in the same order, the same floats; tests/test_wall_solve.py checks it).
    g_rows = [m + k for k, s in enumerate(used) for _ in range(len(s.offsets) + 1)]
    bricks = [b for s in used for b in (s.brick, *(nb for nb, _, _ in s.offsets))]
    y0 = [y for s in used for y in (0.0, *(-o[0] for _, o, _ in s.offsets))]
    y1 = [y for s in used for y in (0.0, *(-o[1] for _, o, _ in s.offsets))]
    var = [v for s in used for v in (s.own_variance_m2, *(v for _, _, v in s.offsets))]
    g = np.array(g_rows, dtype=np.int64)
    p = np.array([index.get(b, -1) for b in bricks], dtype=np.int64)
    on_free = p >= 0  # (a brick not free is fixed: every brick of a used sighting has a root)
    w = 1.0 / np.array(var, dtype=float)
    fx = np.array([fixed.get(b, (0.0, 0.0)) for b in bricks], dtype=float).reshape(-1, 2)
    y = np.stack([np.array(y0, dtype=float), np.array(y1, dtype=float)], axis=1).reshape(-1, 2)
    # per measurement: (g, g, w), then on a free brick (p, p, w), (p, g, -w), (g, p, -w): the measurement
    # x_b - g = y with weight w
    keep = np.stack([np.ones_like(on_free), on_free, on_free, on_free], axis=1)
    rows = np.stack([g, p, p, g], axis=1)[keep]
    cols = np.stack([g, p, g, p], axis=1)[keep]
    vals = np.stack([w, w, -w, -w], axis=1)[keep]
    # the right-hand side: on a fixed brick rhs[g] += w (fx - y); on a free one rhs[p] += w y, rhs[g] -= w y
    wy = w[:, None] * y
    first_at = np.where(on_free, p, g)
    first = np.where(on_free[:, None], wy, w[:, None] * (fx - y))
    at = np.stack([first_at, g], axis=1)[np.stack([np.ones_like(on_free), on_free], axis=1)]
    add = np.stack([first, -wy], axis=1)[np.stack([np.ones_like(on_free), on_free], axis=1)]
    prior = [(index[b], mv, v) for b, (mv, v) in (priors or {}).items() if b in index]
    if prior:
        pi = np.array([i for i, _, _ in prior], dtype=np.int64)
        pv = np.array([v for _, _, v in prior], dtype=float)
        pm = np.array([mv for _, mv, _ in prior], dtype=float).reshape(-1, 2)
        rows = np.concatenate([rows, pi])
        cols = np.concatenate([cols, pi])
        vals = np.concatenate([vals, 1.0 / pv])
        at = np.concatenate([at, pi])
        add = np.concatenate([add, pm / pv[:, None]])
    rhs = np.zeros((n, 2))
    np.add.at(rhs[:, 0], at, add[:, 0])
    np.add.at(rhs[:, 1], at, add[:, 1])
    h = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
    lu = spla.splu(h)
    x = lu.solve(rhs)
    variance: dict[int, float] = {}
    for b in variance_of:
        if b in index:
            e = np.zeros(n)
            e[index[b]] = 1.0
            variance[b] = float(lu.solve(e)[index[b]])
    xs = x.tolist()
    return Solution(
        {b: (xs[i][0], xs[i][1]) for b, i in index.items()},
        {b: root[b] for b in free},
        variance,
    )
