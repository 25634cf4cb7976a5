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
to is the surveyed brick fewest sightings away (ties: the lowest id).
"""

from __future__ import annotations

from collections import deque
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
    """Brick id -> the surveyed brick fewest sightings away (ties: the lowest id), for every brick reached; then,
    for the bricks no surveyed one reaches, the lowest id of ``unsurveyed`` in their component (itself alone: a
    brick in no sighting)."""
    near: dict[int, set[int]] = {}
    for s in sightings:
        group = {s.brick, *(n for n, _, _ in s.offsets)}
        for b in group:
            near.setdefault(b, set()).update(group - {b})
    root: dict[int, int] = {}
    for seeds in (sorted(fixed), sorted(unsurveyed)):
        for f in seeds:
            if f in root:
                continue
            root[f] = f
            queue: deque[int] = deque([f])
            while queue:
                b = queue.popleft()
                for n in sorted(near.get(b, ())):
                    if n not in root:
                        root[n] = root[b]
                        queue.append(n)
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
    n = len(free) + len(used)
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    rhs = np.zeros((n, 2))

    def add(i: int, j: int, w: float) -> None:
        rows.append(i)
        cols.append(j)
        vals.append(w)

    for k, s in enumerate(used):
        g = len(free) + k
        for b, y, var in (
            (s.brick, (0.0, 0.0), s.own_variance_m2),
            *((nb, (-o[0], -o[1]), v) for nb, o, v in s.offsets),
        ):
            w = 1.0 / var
            add(g, g, w)  # the measurement x_b - g = y, weight w
            if b in fixed:
                fx = fixed[b]
                rhs[g] += (w * (fx[0] - y[0]), w * (fx[1] - y[1]))
            else:
                p = index[b]
                add(p, p, w)
                add(p, g, -w)
                add(g, p, -w)
                rhs[p] += (w * y[0], w * y[1])
                rhs[g] -= (w * y[0], w * y[1])
    for b, (m, var) in (priors or {}).items():
        if b in index:
            p = index[b]
            add(p, p, 1.0 / var)
            rhs[p] += (m[0] / var, m[1] / var)
    h = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
    lu = spla.splu(h)
    x = lu.solve(rhs)
    variance: dict[int, float] = {}
    for b in variance_of:
        if b in index:
            e = np.zeros(n)
            e[index[b]] = 1.0
            variance[b] = float(lu.solve(e)[index[b]])
    return Solution(
        {b: (float(x[i, 0]), float(x[i, 1])) for b, i in index.items()},
        {b: root[b] for b in free},
        variance,
    )
