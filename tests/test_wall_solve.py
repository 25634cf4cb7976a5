"""The wall's relative looks in one least-squares (issue 30, masonry.planner.wall_solve): exact without noise,
and on average never worse than the single chain of links through each look's reference neighbour."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, seed, settings
from hypothesis import strategies as st

from masonry.planner.wall_solve import Groups, Looks, Sighting, Wall, _components, _Table, solve

HALF_M2 = 0.001**2 / 2.0  # (a brick's estimate in a look: half the link's variance)


def _graph(draw: st.DrawFn) -> tuple[dict[int, tuple[float, float]], dict[int, np.ndarray], list[list[int]]]:
    """Surveyed bricks (0..), free bricks after them with true centres, and per free brick the bricks its look
    saw: the first its reference (surveyed or seen before it), the others any brick but itself."""
    n_fixed = draw(st.integers(1, 3))
    n_free = draw(st.integers(1, 9))
    coords = st.tuples(st.floats(-2, 2), st.floats(-2, 2))
    fixed = {b: draw(coords) for b in range(n_fixed)}
    truth = {b: np.asarray(p) for b, p in fixed.items()}
    seen: list[list[int]] = []
    for b in range(n_fixed, n_fixed + n_free):
        truth[b] = np.asarray(draw(coords))
        ref = draw(st.integers(0, b - 1))
        others = [
            o for o in draw(st.lists(st.integers(0, n_fixed + n_free - 1), max_size=4)) if o not in (b, ref)
        ]
        seen.append([ref, *dict.fromkeys(others)])
    return fixed, truth, seen


@st.composite
def graphs(
    draw: st.DrawFn,
) -> tuple[dict[int, tuple[float, float]], dict[int, np.ndarray], list[list[int]], list[list[int]]]:
    fixed, truth, seen = _graph(draw)
    frames = [[draw(st.integers(2, 30)) for _ in s] for s in seen]
    return fixed, truth, seen, frames


def _sightings(
    truth: dict[int, np.ndarray],
    seen: list[list[int]],
    frames: list[list[int]],
    n_fixed: int,
    noise: list[np.ndarray],
) -> list[Sighting]:
    """Each free brick's look: its own estimate and each neighbour's up to the look's translation, ``noise[k]``
    holding the errors (own first), drawn by the caller with the variances the sighting declares."""
    out = []
    for k, (nbs, fr) in enumerate(zip(seen, frames, strict=True)):
        b = n_fixed + k
        most = max(fr)
        own = truth[b] + noise[k][0]
        offsets = tuple(
            (n, tuple(float(v) for v in own - (truth[n] + noise[k][i + 1])), HALF_M2 * most / f)
            for i, (n, f) in enumerate(zip(nbs, fr, strict=True))
        )
        out.append(Sighting(b, offsets, HALF_M2))  # type: ignore[arg-type]
    return out


def _chain(fixed: dict[int, tuple[float, float]], sightings: list[Sighting]) -> dict[int, np.ndarray]:
    """The single chain: each brick from its look's reference neighbour (the first offset) and its offset."""
    out = {b: np.asarray(p) for b, p in fixed.items()}
    for s in sightings:
        ref, offset, _ = s.offsets[0]
        out[s.brick] = out[ref] + np.asarray(offset)
    return out


@seed(30)
@settings(max_examples=80, deadline=None, print_blob=True)
@given(g=graphs())
def test_without_noise_the_solve_is_exact_and_anchored_on_a_surveyed_brick(g) -> None:
    fixed, truth, seen, frames = g
    zero = [np.zeros((len(s) + 1, 2)) for s in seen]
    sightings = _sightings(truth, seen, frames, len(fixed), zero)
    sol = solve(fixed, sightings, variance_of=list(truth))
    free = [b for b in truth if b not in fixed]
    assert sorted(sol.centre_m) == free  # (every look chains down to a surveyed brick)
    for b in free:
        assert sol.centre_m[b] == pytest.approx(tuple(truth[b]), abs=1e-9)
        assert sol.root[b] in fixed
        assert 0.0 < sol.variance_m2[b] <= len(truth) * 2 * HALF_M2 * 15 + 1e-12
    # a prior (a world look on the truth) changes nothing; far off with a large variance, next to nothing
    priors = {b: (tuple(truth[b]), 0.05**2) for b in free}
    with_priors = solve(fixed, sightings, priors)  # type: ignore[arg-type]
    for b in free:
        assert with_priors.centre_m[b] == pytest.approx(tuple(truth[b]), abs=1e-9)


@seed(30)
@settings(max_examples=40, deadline=None, print_blob=True)
@given(g=graphs(), noise_seed=st.integers(0, 2**32 - 1))
def test_with_noise_the_solve_is_never_worse_than_the_single_chain_on_average(g, noise_seed: int) -> None:
    """Noise drawn as the sightings declare it (each brick's estimate in a look, per axis): over 200 draws on the
    same graph, the mean squared error of the solve is at most the chain's (the least-squares is the best linear
    unbiased estimate; the chain is one), within the draws' spread; on a brick tied only by its chain, the same."""
    fixed, truth, seen, frames = g
    rng = np.random.default_rng(noise_seed)
    free = [b for b in truth if b not in fixed]
    se_solve, se_chain = 0.0, 0.0
    for _ in range(200):
        noise = []
        for s, fr in zip(seen, frames, strict=True):
            most = max(fr)
            sig = [math.sqrt(HALF_M2)] + [math.sqrt(HALF_M2 * most / f) for f in fr]
            noise.append(rng.normal(size=(len(s) + 1, 2)) * np.asarray(sig)[:, None])
        sightings = _sightings(truth, seen, frames, len(fixed), noise)
        sol = solve(fixed, sightings)
        chain = _chain(fixed, sightings)
        for b in free:
            se_solve += float(np.sum((np.asarray(sol.centre_m[b]) - truth[b]) ** 2))
            se_chain += float(np.sum((chain[b] - truth[b]) ** 2))
    assert se_solve <= se_chain * 1.02 + 1e-12
    if all(
        len(s) == 1 for s in seen
    ):  # (one neighbour per look: the chain is the only path, the same estimate)
        assert se_solve == pytest.approx(se_chain, rel=1e-6)


def test_a_brick_not_tied_to_a_surveyed_one_is_not_solved() -> None:
    fixed = {0: (0.0, 0.0)}
    # brick 1 on the survey; bricks 2 and 3 only see each other
    sightings = [
        Sighting(1, ((0, (0.3, 0.0), HALF_M2),), HALF_M2),
        Sighting(2, ((3, (0.3, 0.0), HALF_M2),), HALF_M2),
        Sighting(4, (), HALF_M2),
    ]
    sol = solve(fixed, sightings, {2: ((5.0, 5.0), 1.0)}, variance_of=[1, 2])
    assert sol.centre_m == {1: (0.3, 0.0)} and sol.root == {1: 0}
    assert sol.variance_m2 == {1: pytest.approx(2 * HALF_M2)}
    assert solve(fixed, []) == solve({}, sightings)


def test_with_unsurveyed_a_component_with_a_prior_is_solved_and_rooted_on_its_lowest_prior() -> None:
    fixed = {0: (0.0, 0.0)}
    sightings = [
        Sighting(1, ((0, (0.3, 0.0), HALF_M2),), HALF_M2),
        Sighting(2, ((3, (0.3, 0.0), HALF_M2),), HALF_M2),
    ]
    # bricks 2 and 3 (no survey) where their priors' mean puts them, with the sighting's shape; 5 alone: its prior
    priors = {2: ((5.3, 5.1), 1.0), 3: ((5.1, 4.9), 1.0), 5: ((7.0, 7.0), 1.0)}
    sol = solve(fixed, sightings, priors, unsurveyed=True)
    assert sol.root == {1: 0, 2: 2, 3: 2, 5: 5}
    assert sol.centre_m[2] == pytest.approx((5.35, 5.0)) and sol.centre_m[3] == pytest.approx((5.05, 5.0))
    assert sol.centre_m[5] == pytest.approx((7.0, 7.0)) and sol.centre_m[1] == pytest.approx((0.3, 0.0))


@seed(30)
@settings(max_examples=60, deadline=None, print_blob=True)
@given(
    g=graphs(),
    shift=st.tuples(st.floats(-0.2, 0.2), st.floats(-0.2, 0.2)),
    noise_seed=st.integers(0, 2**32 - 1),
)
def test_with_no_survey_the_wall_keeps_its_shape_and_sits_on_its_looks_mean(
    g, shift, noise_seed: int
) -> None:
    """No brick surveyed, exact sightings, the world looks off by a common ``shift`` plus their own noise (equal
    variances): every brick of a connected wall is off by the same translation, the mean of its looks' errors
    (the wall's frame is exact; the error in the world is the looks' common part)."""
    _, truth, seen, frames = g
    n_fixed = len(truth) - len(seen)
    # (the graph's surveyed bricks taken as unsurveyed, not fixed: the whole wall stands on its looks)
    sightings = _sightings(truth, seen, frames, n_fixed, [np.zeros((len(s) + 1, 2)) for s in seen])
    rng = np.random.default_rng(noise_seed)
    err = {b: np.asarray(shift) + rng.normal(scale=0.05, size=2) for b in truth}
    priors = {b: (tuple(float(v) for v in truth[b] + e), 0.05**2) for b, e in err.items()}
    sol = solve({}, sightings, priors, unsurveyed=True)  # type: ignore[arg-type]
    assert set(sol.centre_m) == set(truth)
    for root in set(sol.root.values()):
        members = [b for b in sol.root if sol.root[b] == root]
        common = np.mean([err[b] for b in members], axis=0)
        # the sightings (1 mm) weigh (1 mm / 5 cm)^2 = 0.04 % against the looks (5 cm), times the graph's leverage: a
        # brick is pulled off the common translation by a small share of the looks' spread about it (1,500 random
        # walls: 0.18 % at most, 0.2 mm; a fresh clone's run found 0.103 mm, over the 0.1 mm bound this had)
        spread_m = max(float(np.linalg.norm(err[b] - common)) for b in members)
        for b in members:
            assert np.asarray(sol.centre_m[b]) - truth[b] == pytest.approx(common, abs=0.01 * spread_m + 1e-9)


def _search_roots(fixed, sightings, unsurveyed):  # type: ignore[no-untyped-def]
    """The roots by a breadth-first search from each seed in id order, the surveyed ones first."""
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
            queue = [f]
            while queue:
                b = queue.pop(0)
                for n in sorted(near.get(b, ())):
                    if n not in root:
                        root[n] = root[b]
                        queue.append(n)
    return root


def _loop_solve(fixed, sightings, priors=None, variance_of=(), unsurveyed=False):  # type: ignore[no-untyped-def]
    """The normal equations built entry by entry (the solve's plain form, :func:`_search_roots`'s roots): what
    :func:`solve` must return bit for bit."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    sightings = [s for s in sightings if s.offsets]
    root = _search_roots(fixed, sightings, (priors or {}).keys() if unsurveyed else ())
    free = sorted(b for b in root if b not in fixed)
    if not free:
        return {}, {}, {}
    index = {b: i for i, b in enumerate(free)}
    used = [s for s in sightings if s.brick in root]
    n = len(free) + len(used)
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    rhs = np.zeros((n, 2))
    for k, s in enumerate(used):
        g = len(free) + k
        for b, y, var in (
            (s.brick, (0.0, 0.0), s.own_variance_m2),
            *((nb, (-o[0], -o[1]), v) for nb, o, v in s.offsets),
        ):
            w = 1.0 / var
            rows.append(g), cols.append(g), vals.append(w)
            if b in fixed:
                rhs[g] += (w * (fixed[b][0] - y[0]), w * (fixed[b][1] - y[1]))
            else:
                p = index[b]
                for i, j, v in ((p, p, w), (p, g, -w), (g, p, -w)):
                    rows.append(i), cols.append(j), vals.append(v)
                rhs[p] += (w * y[0], w * y[1])
                rhs[g] -= (w * y[0], w * y[1])
    for b, (m, var) in (priors or {}).items():
        if b in index:
            rows.append(index[b]), cols.append(index[b]), vals.append(1.0 / var)
            rhs[index[b]] += (m[0] / var, m[1] / var)
    lu = spla.splu(sp.csc_matrix((vals, (rows, cols)), shape=(n, n)))
    x = lu.solve(rhs)
    variance = {}
    for b in variance_of:
        if b in index:
            e = np.zeros(n)
            e[index[b]] = 1.0
            variance[b] = float(lu.solve(e)[index[b]])
    centre = {b: (float(x[i, 0]), float(x[i, 1])) for b, i in index.items()}
    return centre, {b: root[b] for b in free}, variance


@st.composite
def random_sightings(draw: st.DrawFn) -> tuple:  # type: ignore[type-arg]
    """Any bricks, surveyed or not, any sightings among them (empty ones too), any priors."""
    n = draw(st.integers(1, 14))
    ids = st.integers(0, n - 1)
    coords = st.tuples(st.floats(-3, 3), st.floats(-3, 3))
    var = st.sampled_from([HALF_M2, 2 * HALF_M2, 3.3e-7, 0.01])
    fixed = draw(st.dictionaries(ids, coords, max_size=3))
    sightings = [
        Sighting(b, tuple((o, draw(coords), draw(var)) for o in dict.fromkeys(others) if o != b), draw(var))
        for b, others in draw(st.lists(st.tuples(ids, st.lists(ids, max_size=4)), max_size=16))
    ]
    priors = draw(st.none() | st.dictionaries(ids, st.tuples(coords, var)))
    return fixed, sightings, priors, draw(st.lists(ids, max_size=3)), draw(st.booleans())


@seed(30)
@settings(max_examples=150, deadline=None)
@given(random_sightings())
def test_the_solve_is_bit_for_bit_the_normal_equations_built_entry_by_entry(case) -> None:  # type: ignore[no-untyped-def]
    fixed, sightings, priors, variance_of, unsurveyed = case
    got = solve(fixed, sightings, priors, variance_of, unsurveyed)
    centre, root, variance = _loop_solve(fixed, sightings, priors, variance_of, unsurveyed)
    assert got.centre_m == centre, case
    assert got.root == root, case
    assert got.variance_m2 == variance, case


@seed(34)
@settings(max_examples=100, deadline=None)
@given(random_sightings(), st.lists(st.integers(0, 15), max_size=4))
def test_a_solve_of_some_bricks_only_gives_their_centres_and_roots_of_the_whole_solve(case, only) -> None:  # type: ignore[no-untyped-def]
    fixed, sightings, priors, variance_of, unsurveyed = case
    whole = Wall(fixed, sightings).solve(priors, variance_of, unsurveyed)
    some = Wall(fixed, sightings).solve(priors, variance_of, unsurveyed, only=only)
    assert some.centre_m == {b: whole.centre_m[b] for b in only if b in whole.centre_m}, case
    assert some.root == {b: whole.root[b] for b in only if b in whole.root}, case
    assert some.variance_m2 == whole.variance_m2, case


@seed(35)
@settings(max_examples=100, deadline=None)
@given(random_sightings())
def test_the_rows_are_the_whole_solve_in_its_order_without_its_dictionaries(case) -> None:  # type: ignore[no-untyped-def]
    # (the wall anchor reads every brick's centre of its loose and last solves from these lists)
    fixed, sightings, priors, _, unsurveyed = case
    whole = Wall(fixed, sightings).solve(priors, (), unsurveyed)
    free, roots, xs = Wall(fixed, sightings).rows(priors, unsurveyed)
    assert free == list(whole.centre_m), case
    assert dict(zip(free, roots, strict=True)) == whole.root, case
    assert [tuple(x) for x in xs] == list(whole.centre_m.values()), case
    assert all(len(x) == 2 and all(type(v) is float for v in x) for x in xs), case


@seed(36)
@settings(max_examples=200, deadline=None)
@given(random_sightings(), st.lists(st.integers(0, 15), max_size=5))
def test_the_kept_groups_give_the_components_the_graph_gives(case, loose) -> None:  # type: ignore[no-untyped-def]
    # (the wall anchor keeps a union-find of its sightings as they come: the same bricks, flags and roots, as arrays)
    fixed, sightings, _, _, _ = case
    kept = [s for s in sightings if s.offsets]
    table = _Table(kept)
    groups = Groups()
    for s in sightings:  # (one by one, as the anchor adds them; one with no offset joins nothing)
        groups.add(s)
    for seeds in ((), loose):
        want = _components(fixed, table, seeds)
        got = _components(fixed, table, seeds, groups)
        assert [a.tolist() for a in got] == [a.tolist() for a in want], (case, seeds)
        assert [a.dtype for a in got] == [a.dtype for a in want]


@seed(36)
@settings(max_examples=100, deadline=None)
@given(random_sightings())
def test_a_wall_with_kept_groups_solves_bit_for_bit_as_without(case) -> None:  # type: ignore[no-untyped-def]
    fixed, sightings, priors, variance_of, unsurveyed = case
    plain = Wall(fixed, sightings).solve(priors, variance_of, unsurveyed)
    kept = Wall(fixed, sightings, Groups(sightings)).solve(priors, variance_of, unsurveyed)
    assert kept == plain, case


@seed(37)
@settings(max_examples=150, deadline=None)
@given(random_sightings(), st.floats(1e-8, 1.0))
def test_the_rows_on_looks_are_the_rows_on_their_mapping_bit_for_bit(case, variance) -> None:  # type: ignore[no-untyped-def]
    # (the wall anchor's priors: its looks as arrays in the order taken, one variance, not a mapping per solve)
    fixed, sightings, priors, _, _ = case
    mapping = {b: (m, variance) for b, (m, _) in (priors or {}).items()}
    ids = np.array(list(mapping), dtype=np.int64)
    xy = np.array([m for m, _ in mapping.values()], dtype=float).reshape(-1, 2)
    wall = Wall(fixed, sightings)
    looks = Looks(ids, xy, np.sort(ids))
    want = Wall(fixed, sightings).rows(mapping, unsurveyed=True)
    assert wall.rows_on(looks, variance) == want, case
    assert wall.rows_on(looks, variance / 3.0) == Wall(fixed, sightings).rows(
        {b: (m, variance / 3.0) for b, (m, _) in mapping.items()}, unsurveyed=True
    ), case  # (a second solve on the same looks: the layout kept)
