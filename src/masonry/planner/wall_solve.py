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
from functools import cached_property

import numpy as np

Vec2 = tuple[float, float]

__all__ = ["Groups", "Looks", "Sighting", "Solution", "Wall", "solve"]


@dataclass(frozen=True)
class Sighting:
    """One as-built look: ``brick`` seen with the neighbours ``offsets`` (neighbour id, the brick's centre less
    the neighbour's horizontally (m), the variance (m^2, per axis) of the neighbour's estimate in the look) and
    ``own_variance_m2`` (its own estimate's)."""

    brick: int
    offsets: tuple[tuple[int, Vec2, float], ...]
    own_variance_m2: float

    @cached_property
    def measurements(self) -> np.ndarray:
        """Its measurements ``x_b - g = y`` as rows (b, y_x, y_y, the variance), its own brick's first (y = 0), then
        each neighbour's (y = minus its offset): built once, read by every solve after it (an id is an exact
        float)."""
        rows = [(self.brick, 0.0, 0.0, self.own_variance_m2)]
        rows.extend((nb, -o[0], -o[1], v) for nb, o, v in self.offsets)
        return np.array(rows, dtype=float).reshape(-1, 4)


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
    nodes, has, root = _components(fixed, _Table(sightings), unsurveyed)
    return dict(zip(nodes[has].tolist(), root[has].tolist(), strict=True))


class _Table:
    """Every measurement of ``sightings`` in order (:attr:`Sighting.measurements`), with its sighting's index."""

    def __init__(self, sightings: Sequence[Sighting]) -> None:
        blocks = [s.measurements for s in sightings]
        self.rows = np.concatenate(blocks) if blocks else np.zeros((0, 4))
        counts = np.array([len(b) for b in blocks], dtype=np.int64)
        self.owner = np.repeat(np.arange(len(blocks), dtype=np.int64), counts)  # (each row's sighting)
        self.first = np.cumsum(counts) - counts  # (each sighting's own row)
        self.ids = self.rows[:, 0].astype(np.int64)


class Groups:
    """The connected components of sightings' graph (a brick and each neighbour it saw), kept as sightings come:
    each brick's component label in a dictionary, a join relabelling the smaller component's bricks (integers
    only). The wall anchor keeps one beside its sightings and hands it to each :class:`Wall` of them, whose solves
    then find their roots (:func:`_components`) without building the whole graph again: the same components, so
    the same roots."""

    def __init__(self, sightings: Sequence[Sighting] = ()) -> None:
        self.label: dict[int, int] = {}  # (a brick -> its component's label; absent: a brick alone, itself)
        self._members: dict[int, list[int]] = {}  # (a label -> its component's bricks)
        for s in sightings:
            self.add(s)

    def add(self, sighting: Sighting) -> None:
        """Join ``sighting``'s brick and its neighbours' components (a sighting with no offset joins nothing)."""
        for nb, _, _ in sighting.offsets:
            self._join(sighting.brick, nb)

    def _join(self, a: int, b: int) -> None:
        label, members = self.label, self._members
        la, lb = label.get(a, a), label.get(b, b)
        if la == lb:
            return
        ma = members.pop(la, None) or [la]
        mb = members.pop(lb, None) or [lb]
        if len(ma) < len(mb):
            la, ma, mb = lb, mb, ma
        for x in mb:
            label[x] = la
        label[la] = la
        ma.extend(mb)
        members[la] = ma


def _components(
    fixed: Collection[int], table: _Table, unsurveyed: Collection[int], groups: Groups | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bricks (sorted ids: those of the sightings and the seeds), whether each has a root, and its root
    (:func:`_roots`): the connected components of the sightings' graph, rooted on their lowest seed of the first
    kind they hold (surveyed, else ``unsurveyed``). ``groups``: those components kept as the table's sightings
    came (:class:`Groups`), else found from the table."""
    fixed_ids = np.array(sorted(fixed), dtype=np.int64)
    if isinstance(unsurveyed, np.ndarray):
        loose_ids = unsurveyed  # (:attr:`Looks.seeds`: sorted already)
    else:
        loose_ids = np.array(sorted(unsurveyed), dtype=np.int64)
    nodes = np.unique(np.concatenate([table.ids, fixed_ids, loose_ids]))
    if not len(nodes):
        return nodes, np.zeros(0, dtype=bool), nodes
    if groups is not None:
        return _kept_components(nodes, fixed_ids, loose_ids, groups)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pos = np.searchsorted(nodes, table.ids)
    edges = coo_matrix(
        (np.ones(len(pos)), (pos[table.first][table.owner], pos)), shape=(len(nodes), len(nodes))
    )
    n, label = connected_components(edges, directed=False)
    top = np.iinfo(np.int64).max
    root = np.full(n, top, dtype=np.int64)
    has = np.zeros(n, dtype=bool)
    for seeds in (fixed_ids, loose_ids):
        at = label[np.searchsorted(nodes, seeds)]
        fresh = ~has[at]  # (components a seed of the first kind roots keep it)
        best = np.full(n, top, dtype=np.int64)
        np.minimum.at(best, at[fresh], seeds[fresh])
        root = np.where(has, root, best)
        has |= best != top
    return nodes, has[label], root[label]


def _kept_components(
    nodes: np.ndarray, fixed_ids: np.ndarray, loose_ids: np.ndarray, groups: Groups
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_components` of ``nodes`` from the components ``groups`` kept: each component's root its lowest
    surveyed brick, else its lowest of ``loose_ids`` (both ascending)."""
    of = groups.label.get
    best: dict[int, int] = {}  # (a component -> its root: the first seed seen of it, surveyed ones first)
    for b in fixed_ids.tolist():
        best.setdefault(of(b, b), b)
    for b in loose_ids.tolist():
        best.setdefault(of(b, b), b)
    top = np.iinfo(np.int64).max
    root_of = best.get
    root = np.array([root_of(of(b, b), top) for b in nodes.tolist()], dtype=np.int64)
    return nodes, root != top, root


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
    return Wall(fixed, sightings).solve(priors, variance_of, unsurveyed)


@dataclass(frozen=True, eq=False)
class Looks:
    """The world looks as priors of one variance (:meth:`Wall.rows_on`): the bricks' ids (n,) in the order they
    were taken, their horizontal centres (n, 2) and the ids sorted (the seeds of the components with no survey);
    the same solution as the mapping ``{b: ((x, y), variance)}`` in that order, without building it (the wall
    anchor's two solves a take, 1,000 looks on a 1,000-brick wall). Compared by identity: the solves of one wall
    on one ``Looks`` share their layout."""

    ids: np.ndarray
    xy_m: np.ndarray
    seeds: np.ndarray


@dataclass(frozen=True)
class _Layout:
    """The normal equations of one set of roots before the priors (:meth:`Wall.solve`): the free bricks, their
    roots and index, the unknowns, and the matrix's and the right-hand side's entries in the order they are added."""

    free: list[int]
    free_ids: np.ndarray
    roots: list[int]
    index: dict[int, int]
    n: int
    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    at: np.ndarray
    add: np.ndarray


class Wall:
    """The surveyed bricks and the sightings of one moment, solved for one or more sets of priors (:func:`solve`).

    The measurements' table is built once and the equations' layout once per set of seeds (the priors' bricks
    when ``unsurveyed``), so the wall anchor's three solves of one look share them: the same floats as one
    :func:`solve` per call (the same entries, added in the same order).
    """

    def __init__(
        self, fixed: Mapping[int, Vec2], sightings: Sequence[Sighting], groups: Groups | None = None
    ) -> None:
        self.fixed = fixed
        self.table = _Table([s for s in sightings if s.offsets])
        self.groups = groups  # (the components of these sightings, kept by the caller: :class:`Groups`)
        self._layouts: dict[frozenset[int] | Looks | None, _Layout | None] = {}

    def solve(
        self,
        priors: Mapping[int, tuple[Vec2, float]] | None = None,
        variance_of: Collection[int] = (),
        unsurveyed: bool = False,
        only: Collection[int] | None = None,
    ) -> Solution:
        """:func:`solve` on this wall's surveyed bricks and sightings; ``only``: the solution's centres and roots of
        those bricks alone (the wall anchor's first solve reads one brick's), None: of every brick solved."""
        solved = self._solve(priors, variance_of, unsurveyed)
        if solved is None:
            return Solution({}, {}, {})
        lay, x, variance = solved
        index = lay.index
        free = lay.free
        if only is not None:
            rows_of = [(b, index[b]) for b in only if b in index]
            return Solution(
                {b: tuple(x[i].tolist()) for b, i in rows_of}, {b: lay.roots[i] for b, i in rows_of}, variance
            )
        xs = map(tuple, x[: len(free)].tolist())  # (the free bricks' rows; the sightings' offsets' follow)
        return Solution(dict(zip(free, xs, strict=True)), dict(zip(free, lay.roots, strict=True)), variance)

    def rows(
        self, priors: Mapping[int, tuple[Vec2, float]] | None = None, unsurveyed: bool = False
    ) -> tuple[list[int], list[int], list[list[float]]]:
        """:meth:`solve`'s bricks, their roots and their centres ``[x, y]`` as three lists in its order (the same
        floats, without its dictionaries: the wall anchor reads every brick's once)."""
        solved = self._solve(priors, (), unsurveyed)
        if solved is None:
            return [], [], []
        lay, x, _ = solved
        return lay.free, lay.roots, x[: len(lay.free)].tolist()

    def rows_on(self, looks: Looks, variance_m2: float) -> tuple[list[int], list[int], list[list[float]]]:
        """:meth:`rows` with the priors ``{b: ((x, y), variance_m2)}`` of ``looks`` in its order, ``unsurveyed``:
        the same floats, the priors' rows found by a search of the free bricks, not a dictionary per look."""
        solved = self._solve(None, (), True, (looks, variance_m2))
        if solved is None:
            return [], [], []
        lay, x, _ = solved
        return lay.free, lay.roots, x[: len(lay.free)].tolist()

    def _solve(
        self,
        priors: Mapping[int, tuple[Vec2, float]] | None,
        variance_of: Collection[int],
        unsurveyed: bool,
        looks: tuple[Looks, float] | None = None,
    ) -> tuple[_Layout, np.ndarray, dict[int, float]] | None:
        """The layout, the solution (every unknown's row) and the variances asked for; None: no free brick."""
        # scipy on call, as everywhere in the pure packages: `masonry --help` and the planner's import stay light
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla

        key: frozenset[int] | Looks | None
        if looks is not None:
            key = looks[0]
            seeds: Collection[int] = looks[0].seeds
        else:
            key = frozenset((priors or {}).keys()) if unsurveyed else None
            seeds = key or ()
        if key in self._layouts:
            lay = self._layouts[key]
        else:
            lay = self._layouts[key] = self._layout(seeds)
        if lay is None:
            return None
        index, n = lay.index, lay.n
        rows, cols, vals, at, add = lay.rows, lay.cols, lay.vals, lay.at, lay.add
        if looks is not None:
            pi, pv, pm = _priors_on(lay.free_ids, *looks)
        else:
            prior = [(index[b], mv, v) for b, (mv, v) in (priors or {}).items() if b in index]
            pi = np.array([i for i, _, _ in prior], dtype=np.int64)
            pv = np.array([v for _, _, v in prior], dtype=float)
            pm = np.array([mv for _, mv, _ in prior], dtype=float).reshape(-1, 2)
        if len(pi):
            rows = np.concatenate([rows, pi])
            cols = np.concatenate([cols, pi])
            vals = np.concatenate([vals, 1.0 / pv])
            at = np.concatenate([at, pi])
            add = np.concatenate([add, pm / pv[:, None]])
        # each unknown's entries summed from 0.0 in the order they come (as np.add.at into zeros adds them)
        rhs = np.empty((n, 2))
        rhs[:, 0] = np.bincount(at, weights=add[:, 0], minlength=n)
        rhs[:, 1] = np.bincount(at, weights=add[:, 1], minlength=n)
        h = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
        lu = spla.splu(h)
        x = lu.solve(rhs)
        variance: dict[int, float] = {}
        for b in variance_of:
            if b in index:
                e = np.zeros(n)
                e[index[b]] = 1.0
                variance[b] = float(lu.solve(e)[index[b]])
        return lay, x, variance

    def _layout(self, unsurveyed: Collection[int]) -> _Layout | None:
        """The equations before the priors, the components rooted on ``unsurveyed`` after the surveyed bricks
        (None: no free brick)."""
        fixed, table = self.fixed, self.table
        nodes, has, node_root = _components(fixed, table, unsurveyed, self.groups)
        fixed_ids = np.array(sorted(fixed), dtype=np.int64)
        free_at = has & ~np.isin(nodes, fixed_ids)
        free_ids = nodes[free_at]
        if not len(free_ids):
            return None
        free = free_ids.tolist()
        index = {b: i for i, b in enumerate(free)}
        # the sightings of a rooted brick, in order, and their measurements: the k-th such sighting's unknown is row
        # m + k; every brick of such a sighting is rooted (its component is), so free or surveyed
        m = len(free)
        used = has[np.searchsorted(nodes, table.ids[table.first])]
        n = m + int(used.sum())
        kept = used[table.owner]
        g = m + (np.cumsum(used) - 1)[table.owner][kept]
        ids = table.ids[kept]
        y = table.rows[kept, 1:3]
        w = 1.0 / table.rows[kept, 3]
        near = np.minimum(np.searchsorted(free_ids, ids), m - 1)
        on_free = free_ids[near] == ids
        p = np.where(on_free, near, -1)
        fx = np.zeros((len(ids), 2))
        if len(fixed_ids):
            xy = np.array([fixed[b] for b in fixed_ids.tolist()], dtype=float).reshape(-1, 2)
            fx = xy[np.minimum(np.searchsorted(fixed_ids, ids), len(fixed_ids) - 1)]
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
        return _Layout(free, free_ids, node_root[free_at].tolist(), index, n, rows, cols, vals, at, add)


def _priors_on(
    free_ids: np.ndarray, looks: Looks, variance_m2: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The priors' unknowns, variances and centres (:meth:`Wall._solve`'s ``pi``, ``pv``, ``pm``) of the looks
    on free bricks (``free_ids`` ascending), in the looks' order."""
    ids = looks.ids
    if not len(free_ids) or not len(ids):
        return np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros((0, 2))
    at = np.minimum(np.searchsorted(free_ids, ids), len(free_ids) - 1)
    hit = free_ids[at] == ids
    pi = at[hit]
    return pi, np.full(len(pi), float(variance_m2)), looks.xy_m[hit]
