"""Mutation operators: properties under jit + vmap, exact cases, statistics.

Every jitted function is built once, at module level, and called with fixed shapes:
``SIZE x SIZE`` maps and ``P`` paths of capacity ``CAP`` (hand-made maps are embedded in
such maps, hand-made paths tiled to ``P``), so each operator compiles once per corner
rule. Inputs are built and expected values computed in NumPy (no eager ``jnp``)."""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from scipy import stats

from jaxga import Grid
from jaxga.core import objectives
from jaxga.core.geometry import clear, linear_trial
from jaxga.core.paths import (
    Population,
    has_endpoints,
    is_continuous,
    is_feasible,
    is_loop_free,
    population_map,
)
from jaxga.maps import random_map
from jaxga.operators import mutation as M
from jaxga.operators.lift import over_individuals
from tests.plain_lifts import either, mutation_population, with_probability
from tests.strategies import CAP, SIZE, grids_and_parents, random_parents

# the mutations' properties and references in depth (contracts: test_registry)
pytestmark = pytest.mark.slow

P = 8
T_FIXED = np.float32(0.01)

# name -> (operator, extra args, in_axes of the extras, kind of output path)
OPS = {
    "neighbour_point": (M.neighbour_point, (), (), "continuous"),
    "replace_point": (M.replace_point, (), (), "continuous"),
    "regrow_segment": (M.regrow_segment, (), (), "continuous"),
    "segment_sa": (
        functools.partial(M.segment_sa, fitness_fn=objectives.mpmga),
        (T_FIXED,), (None,), "continuous",
    ),
    "point_checked": (M.point_checked, (), (), "waypoint"),
    "point_checked_lt": (
        functools.partial(M.point_checked, los="linear_trial", radius=3), (), (), "linear_trial",
    ),
    "cut_corners": (M.cut_corners, (), (), "continuous"),
    "cut_corners_knight": (functools.partial(M.cut_corners, knight=True), (), (), "waypoint"),
    "delete_corner": (M.delete_corner, (), (), "waypoint"),
    "with_probability": (
        with_probability(M.replace_point), (np.float32(0.5),), (None,), "continuous",
    ),
}


def _flagged(op):
    """``op`` with its per-individual ``failed`` flag appended to the cells, so that ONE
    jitted call through the population helper gives the flags and the failure count."""

    def wrapped(key, grid, cells, length, *extra):
        c, n, failed = op(key, grid, cells, length, *extra)
        return jnp.concatenate([c, failed.astype(jnp.int32)[None]]), n, failed

    return wrapped


def _lifted(op, in_axes_extra=()):
    """over_individuals(op) returning ``(cells, length, failed, n_failed)`` (not jitted)."""
    lifted = over_individuals(_flagged(op), in_axes_extra=in_axes_extra)

    def run(key, grid, pop, *extra):
        out, n_failed = lifted(key, grid, pop, *extra)
        return out.cells[:, :-1], out.length, out.cells[:, -1].astype(bool), n_failed

    return run


def _runner(op, in_axes_extra=()):
    """jit(over_individuals(op)) returning ``(cells, length, failed, n_failed)``."""
    return jax.jit(_lifted(op, in_axes_extra))


RUN = {name: _runner(op, axes) for name, (op, _, axes, _) in OPS.items()}


@jax.jit
def _checks(g, c, n):
    """The path checks of :mod:`jaxga.core.paths`, and per segment whether it passes AGACD's
    linear trial (segments past a path's end count as passing): one program per rule."""
    lt_ok = jax.vmap(
        lambda c, n: jax.vmap(linear_trial, in_axes=(None, 0, 0))(g, c[:-1], c[1:])
        | (jnp.arange(c.shape[0] - 1) >= n - 1)
    )(c, n)
    return (
        population_map(has_endpoints)(g, c, n),
        population_map(is_continuous)(g, c, n),
        population_map(is_feasible)(g, c, n),
        jax.vmap(is_loop_free)(c, n),
        lt_ok,
    )


def _assert_padded(c, n) -> None:
    """Every path is padded as :func:`jaxga.core.paths.pad` pads: each position at or
    beyond its length repeats its last cell (NumPy)."""
    last = c[np.arange(len(n)), np.clip(n - 1, 0, c.shape[1] - 1)]
    np.testing.assert_array_equal(c, np.where(np.arange(c.shape[1]) < n[:, None], c,
                                              last[:, None]))


def check_outputs(grid, parents: Population, c, n, failed, n_failed, kind):
    """The masked-path contract for one population of results."""
    c, n, failed = np.asarray(c), np.asarray(n), np.asarray(failed)
    pc, pn = np.asarray(parents.cells), np.asarray(parents.length)
    assert int(n_failed) == int(failed.sum())  # the population helper counts failures
    assert c.dtype == np.int32 and n.dtype == np.int32
    # Failures return the input unchanged, bit for bit.
    np.testing.assert_array_equal(c[failed], pc[failed])
    np.testing.assert_array_equal(n[failed], pn[failed])
    # Every output: within capacity, padded, endpoints, loop-free, continuous/feasible.
    assert ((n >= 1) & (n <= c.shape[1])).all()
    _assert_padded(c, n)
    ends, cont, feas, loop_free, bad_out = (np.asarray(v) for v in _checks(grid, c, n))
    assert ends.all() and loop_free.all()
    if kind == "continuous":
        assert cont.all()
    elif kind == "waypoint":
        assert feas.all()
    else:
        # AGACD's linear trial is asymmetric and may reject a legal anti-diagonal step of
        # the parent: every segment failing it must be a segment the parent already had.
        bad_in = np.asarray(_checks(grid, pc, pn)[4])
        for i in range(len(n)):
            old = {(a, b) for a, b, ok in zip(pc[i, :-1], pc[i, 1:], bad_in[i]) if not ok}
            new = {(a, b) for a, b, ok in zip(c[i, :-1], c[i, 1:], bad_out[i]) if not ok}
            assert new <= old


# ------------------------------------------------------------------ properties
def _property(name):
    op, extra, _, kind = OPS[name]

    @settings(max_examples=12)
    @given(grids_and_parents(n=P))
    def test(gp):
        grid, parents = gp
        key = jax.random.PRNGKey(int(np.asarray(parents.cells).sum()) % 1000)
        c, n, failed, n_failed = RUN[name](key, grid, parents, *extra)
        check_outputs(grid, parents, c, n, failed, n_failed, kind)

    test.__name__ = f"test_properties_{name}"
    test.__doc__ = f"{name}: jit + vmap outputs obey the path contract on random grids."
    return test


for _name in OPS:
    globals()[f"test_properties_{_name}"] = _property(_name)


def test_operators_change_something():
    """Guard against vacuous property tests: on a cluttered map every operator mutates."""
    grid = random_map(SIZE, SIZE, 0.2, 11, corner_rule="free")
    parents = random_parents(grid, P, 5)
    for name, (_, extra, _, kind) in OPS.items():
        changed = 0
        for s in range(4):
            c, n, failed, n_failed = RUN[name](jax.random.PRNGKey(s), grid, parents, *extra)
            check_outputs(grid, parents, c, n, failed, n_failed, kind)
            changed += int(np.any(np.asarray(c) != np.asarray(parents.cells), axis=1).sum())
        assert changed > 0, name


# -------------------------------------------------------------- capacity overflow
def _serpentine():
    """A 64-node boustrophedon on an open 10 x 10 map: rows 0-5 and 4 cells of row 6."""
    xy = []
    for y in range(6):
        xs = range(10) if y % 2 == 0 else range(9, -1, -1)
        xy += [(x, y) for x in xs]
    xy += [(x, 6) for x in range(4)]
    return xy


def test_full_capacity_overflow_fails_cleanly_and_is_counted():
    """Paths at exactly the capacity (64): growing mutants fail, are counted, keep the
    parent; shrinking ones (loop removal AFTER the splice) still succeed."""
    xy = _serpentine()
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(0, 0), goal=(3, 6), corner_rule="free")
    pop = _population(grid, [xy])
    assert int(pop.length[0]) == pop.capacity
    for name in ("neighbour_point", "regrow_segment"):
        fails = ok = 0
        for s in range(20):
            c, n, failed, n_failed = RUN[name](jax.random.PRNGKey(s), grid, pop)
            check_outputs(grid, pop, c, n, failed, n_failed, "continuous")
            fails += int(n_failed)
            ok += int((~np.asarray(failed)).sum())
        assert fails > 0 and ok > 0, name


def _short_parents(grid, n, seed):
    """``n`` parents of at most TIGHT nodes, at capacity CAP (NumPy arrays), drawn P at a
    time (the parents' program of the property tests)."""
    cells, length = [], []
    for attempt in range(80):
        pop = random_parents(grid, P, 100 * seed + attempt)
        sel = np.flatnonzero(np.asarray(pop.length) <= TIGHT)
        cells += list(np.asarray(pop.cells)[sel])
        length += list(np.asarray(pop.length)[sel])
        if len(cells) >= n:
            return Population(np.stack(cells[:n]), np.asarray(length[:n], np.int32))
    raise RuntimeError("no short parents")


TIGHT = 15
# The same connection node table (CAP) as the wide run: identical randomness.
_RUN_TIGHT = _runner(functools.partial(M.segment_sa, fitness_fn=objectives.mpmga,
                                       seg_capacity=CAP), OPS["segment_sa"][2])


def test_segment_sa_tight_capacity_equals_wide_where_it_fits():
    """segment_sa's randomness does not depend on the capacity: at a tight capacity it
    must reproduce the wide result where it succeeds, and fail (counted) on overflow."""
    _, extra, _, kind = OPS["segment_sa"]
    overflow_total = 0
    for seed in range(4):
        grid = random_map(SIZE, SIZE, 0.3, 200 + seed, corner_rule="free")
        wide = _short_parents(grid, P, seed)
        tight = Population(wide.cells[:, :TIGHT], wide.length)
        for k in range(3):
            key = jax.random.PRNGKey(10 * seed + k)
            c, n, failed, n_failed = _RUN_TIGHT(key, grid, tight, *extra)
            check_outputs(grid, tight, c, n, failed, n_failed, kind)
            cw, nw, fw, _ = RUN["segment_sa"](key, grid, wide, *extra)
            c, n, failed = np.asarray(c), np.asarray(n), np.asarray(failed)
            cw, nw, fw = np.asarray(cw), np.asarray(nw), np.asarray(fw)
            # Wide mutants that were accepted and do not fit must fail at the tight size.
            overflow = ~fw & (nw > TIGHT)
            assert failed[overflow].all() and failed[fw].all()
            # A tight failure of a wide success: an overflow, or a rejected wide mutant
            # (then the wide output is the parent and the mutant is not visible).
            rejected = np.all(cw[:, :TIGHT] == np.asarray(tight.cells), 1) & (
                nw == np.asarray(tight.length)
            )
            assert (overflow | rejected)[failed & ~fw].all()
            fits = ~failed
            np.testing.assert_array_equal(c[fits], cw[fits][:, :TIGHT])
            np.testing.assert_array_equal(n[fits], nw[fits])
            overflow_total += int(overflow.sum())
    assert overflow_total > 0


# ------------------------------------------------------------------ exact cases
# Hand-made maps are embedded in SIZE x SIZE maps (the rest blocked) and paths are tiled
# to P individuals at capacity CAP, so the operators compiled above are reused.
def _embed(small):
    blocked = np.ones((SIZE, SIZE), bool)
    small = np.asarray(small, bool)
    blocked[: small.shape[0], : small.shape[1]] = small
    return blocked


def _grid(small, start, goal, rule="free"):
    return Grid.create(_embed(small), start=start, goal=goal, corner_rule=rule)


def _population(grid, paths):
    """The paths, given as ``(x, y)`` lists, repeated to P paths of capacity CAP (NumPy)."""
    w = grid.width
    rows = [[y * w + x for x, y in xy] for xy in (paths * P)[:P]]
    cells = np.array([r + [r[-1]] * (CAP - len(r)) for r in rows], np.int32)
    return Population(cells, np.array([len(r) for r in rows], np.int32))


def _xy(grid, cells, n):
    w = grid.width
    return tuple((int(p) % w, int(p) // w) for p in np.asarray(cells)[: int(n)])


def _apply(name, grid, xy, key=0):
    """The operator on one hand-made path (row 0 of a tiled population)."""
    pop = _population(grid, [xy])
    _, extra, _, _ = OPS[name]
    c, n, failed, _ = (np.asarray(v) for v in RUN[name](jax.random.PRNGKey(key), grid, pop,
                                                         *extra))
    return list(_xy(grid, c[0], n[0])), bool(failed[0])


def _outcomes(name, grid, xy, n_calls):
    """Counts of the distinct results over ``n_calls * P`` independent mutations."""
    pop = _population(grid, [xy])
    _, extra, _, kind = OPS[name]
    counts: dict[tuple, int] = {}
    n_failed = 0
    for s in range(n_calls):
        c, n, failed, nf = (np.asarray(v) for v in RUN[name](jax.random.PRNGKey(1000 + s),
                                                             grid, pop, *extra))
        if s < 3:
            check_outputs(grid, pop, c, n, failed, nf, kind)
        n_failed += int(nf)
        for i in range(P):
            k = _xy(grid, c[i], n[i])
            counts[k] = counts.get(k, 0) + 1
    return counts, n_failed


def test_corner_cut_staircase():
    """Zhang eq. 3-4 on a staircase: every corner node goes, sequentially."""
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(0, 0), goal=(3, 3), corner_rule="free")
    stair = [(0, 0), (1, 0), (1, 1), (2, 1), (2, 2), (3, 2), (3, 3)]
    assert _apply("cut_corners", grid, stair) == ([(0, 0), (1, 1), (2, 2), (3, 3)], False)
    # knight=True (eq. 5): after dropping (1, 0), (0,0) -> (2,1) is a clear knight move,
    # so (1, 1) goes too; the pass continues from the last KEPT node (0, 0).
    assert _apply("cut_corners_knight", grid, stair) == ([(0, 0), (2, 1), (3, 3)], False)


def test_delete_corner_mutates_one_random_position_by_eq_3_to_5():
    """Zhang's mutation at ONE random interior position: the node goes when it is a
    corner of eq. 3-4 (its neighbours adjacent) or eq. 5 (a clear knight move), else
    nothing changes and the mutation counts as failed."""
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(0, 0), goal=(3, 3), corner_rule="free")
    # one interior node: the position is forced
    assert _apply("delete_corner", grid, [(0, 0), (1, 0), (1, 1)]) == ([(0, 0), (1, 1)], False)
    assert _apply("delete_corner", grid, [(0, 0), (1, 0), (2, 0)]) == (
        [(0, 0), (1, 0), (2, 0)], True)  # straight: no corner
    assert _apply("delete_corner", grid, [(0, 0), (1, 1), (2, 1)]) == ([(0, 0), (2, 1)], False)
    b = np.zeros((SIZE, SIZE), bool)
    b[0, 1] = True  # (1, 0): the other cell beside the knight move (0,0) -> (2,1)
    walled = Grid.create(b, start=(0, 0), goal=(2, 1), corner_rule="free")
    assert _apply("delete_corner", walled, [(0, 0), (1, 1), (2, 1)]) == (
        [(0, 0), (1, 1), (2, 1)], True)
    # a staircase: exactly one node goes per mutation, and over many draws every interior
    # node goes (each is a corner), about equally often
    stair = [(0, 0), (1, 0), (1, 1), (2, 1), (2, 2), (3, 2), (3, 3)]
    counts, n_failed = _outcomes("delete_corner", grid, stair, 25)
    assert n_failed == 0
    assert all(len(path) == len(stair) - 1 for path in counts)
    gone = {next(c for c in stair if c not in path) for path in counts}
    assert gone == set(stair[1:-1])
    share = np.array(list(counts.values())) / sum(counts.values())
    assert share.min() > 0.5 / 5 and share.max() < 2.0 / 5


def test_corner_cut_respects_corner_rule_and_zhang_side_cells():
    blocked = np.zeros((SIZE, SIZE), bool)
    blocked[1, 0] = True  # (x=0, y=1): a side cell of the diagonal (0,0) -> (1,1)
    path = [(0, 0), (1, 0), (1, 1), (1, 2)]
    for rule, expect in [("free", [(0, 0), (1, 1), (1, 2)]), ("strict", path)]:
        grid = Grid.create(blocked, start=(0, 0), goal=(1, 2), corner_rule=rule)
        assert _apply("cut_corners", grid, path)[0] == expect
    # Zhang eq. 5 on his 10-wide grid: N_{i+1} - N_{i-1} = 12 (0 -> 11 -> 12), deleted only
    # if the other cell beside the mutation point (1 = (1, 0)) is free.
    for other_blocked, expect in [(False, [(0, 0), (2, 1)]), (True, [(0, 0), (1, 1), (2, 1)])]:
        b = np.zeros((SIZE, SIZE), bool)
        b[0, 1] = other_blocked
        grid = Grid.create(b, start=(0, 0), goal=(2, 1), corner_rule="free")
        assert _apply("cut_corners_knight", grid, [(0, 0), (1, 1), (2, 1)])[0] == expect
        assert _apply("cut_corners", grid, [(0, 0), (1, 1), (2, 1)])[0] == [(0, 0), (1, 1), (2, 1)]
    # Differences 10, 1 (orthogonal neighbours) and 11 (diagonal): eq. 3-4, and their
    # mirror images (jaxga applies the rule in all directions).
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(1, 1), goal=(1, 1), corner_rule="free")
    for mid, nxt in [((2, 2), (2, 1)), ((2, 2), (1, 2)), ((2, 1), (2, 2)), ((0, 1), (0, 0)),
                     ((0, 0), (1, 0)), ((1, 2), (0, 2))]:
        g = Grid.create(np.zeros((SIZE, SIZE), bool), start=(1, 1), goal=nxt, corner_rule="free")
        assert _apply("cut_corners", g, [(1, 1), mid, nxt])[0] == [(1, 1), nxt]
    del grid


_KNIGHT_AND_CLEAR = jax.jit(lambda g, a, b: (
    jax.vmap(M._knight_clear, in_axes=(None, 0, 0))(g, a, b),
    jax.vmap(clear, in_axes=(None, 0, 0))(g, a, b)))


def test_knight_clear_equals_exact_line_of_sight():
    """The 4-cell knight test is geometry.clear for every knight move on random maps."""
    rng = np.random.default_rng(0)
    d = [(2, 1), (1, 2), (-2, 1), (-1, 2), (2, -1), (1, -2), (-2, -1), (-1, -2)]
    for rule in ("free", "no_squeeze", "strict"):
        grid = Grid.create(rng.random((6, 6)) < 0.4, corner_rule=rule)
        a = np.array([[x, y] for x in range(6) for y in range(6) for _ in d])
        b = a + np.array(d * 36)
        inside = ((b >= 0) & (b < 6)).all(1)
        a, b = a[inside], b[inside]
        ia = (a[:, 1] * 6 + a[:, 0]).astype(np.int32)
        ib = (b[:, 1] * 6 + b[:, 0]).astype(np.int32)
        got, want = _KNIGHT_AND_CLEAR(grid, ia, ib)
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))


def test_one_point_candidates_and_corner_rule():
    """Zhu 4.5: the only off-path cell adjacent to both neighbours of (1,0) is (1,1)."""
    line = [(0, 0), (1, 0), (2, 0)]
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(0, 0), goal=(2, 0), corner_rule="free")
    counts, n_failed = _outcomes("replace_point", grid, line, 3)
    assert counts == {((0, 0), (1, 1), (2, 0)): 3 * P} and n_failed == 0
    blocked = np.zeros((SIZE, SIZE), bool)
    blocked[1, 0] = True  # (0, 1): makes (0,0) -> (1,1) illegal under "strict"
    grid = Grid.create(blocked, start=(0, 0), goal=(2, 0), corner_rule="strict")
    assert _apply("replace_point", grid, line) == (line, True)
    # No interior node: nothing to mutate.
    grid = Grid.create(blocked, start=(0, 0), goal=(1, 0), corner_rule="strict")
    assert _apply("replace_point", grid, [(0, 0), (1, 0)]) == ([(0, 0), (1, 0)], True)


def test_neighbour_point_exact_outcomes_are_uniform():
    """IMGA 4.3.3 on a 3 x 3 open region: the 6 candidates, their median connections
    (eq. 3) and a uniform choice (chi-square)."""
    grid = _grid(np.zeros((3, 3)), start=(0, 1), goal=(2, 1))
    expected = {
        ((0, 1), (1, 0), (2, 1)), ((0, 1), (0, 0), (1, 0), (2, 1)),
        ((0, 1), (1, 0), (2, 0), (2, 1)), ((0, 1), (1, 2), (2, 1)),
        ((0, 1), (0, 2), (1, 1), (2, 1)), ((0, 1), (1, 1), (2, 2), (2, 1)),
    }
    counts, n_failed = _outcomes("neighbour_point", grid, [(0, 1), (1, 1), (2, 1)], 150)
    assert n_failed == 0 and set(counts) == expected
    assert stats.chisquare(list(counts.values())).pvalue > 1e-3


def test_point_checked_uniform_and_rejects_blocked_segments():
    """AGACD 4.7: uniform over free, off-path cells in the radius; segments must be clear."""
    grid = _grid(np.zeros((3, 3)), start=(0, 1), goal=(2, 1))
    counts, n_failed = _outcomes("point_checked", grid, [(0, 1), (1, 1), (2, 1)], 150)
    assert n_failed == 0 and len(counts) == 6
    assert stats.chisquare(list(counts.values())).pvalue > 1e-3
    # Radius 2 in a 5 x 5 region, a wall at x = 2 except the middle cell: of the 18 free
    # off-path candidates only (1, 2) and (3, 2) see both ends through the gap.
    small = np.zeros((5, 5), bool)
    small[:, 2] = True
    small[2, 2] = False
    grid = _grid(small, start=(0, 2), goal=(4, 2), rule="strict")
    path = ((0, 2), (2, 2), (4, 2))
    counts, n_failed = _outcomes("point_checked", grid, list(path), 120)
    assert set(counts) == {((0, 2), (1, 2), (4, 2)), ((0, 2), (3, 2), (4, 2)), path}
    assert n_failed == counts[path]
    assert stats.binomtest(n_failed, 120 * P, 16 / 18).pvalue > 1e-3


_RADII = (1, 9, 10_000)
_RUN_RADII = jax.jit(lambda key, grid, pop: {
    r: _lifted(functools.partial(M.point_checked, radius=r))(key, grid, pop) for r in _RADII})


def test_point_checked_radius_beyond_the_map_is_the_radius_that_reaches_every_cell():
    """On a 10 x 10 map radius 9 already reaches every cell: radius 10,000 is clamped to
    it (instead of building a (2r + 1)^2 table of 400 million offsets per node).
    The engine calls this operator with ``mutation.radius`` as given, so a preset run
    with radius 10,000 gets the clamp too."""
    grid = random_map(10, 10, 0.2, 3, corner_rule="free")
    parents = random_parents(grid, P, seed=5)
    key = jax.random.PRNGKey(11)
    # the same program: no larger table is built (a larger one would give the same
    # mutants, since cells off the map are never candidates)
    cells, length = np.asarray(parents.cells)[0], np.asarray(parents.length)[0]
    programs = {r: str(jax.make_jaxpr(functools.partial(M.point_checked, radius=r))(
        key, grid, cells, length)) for r in (9, 10_000)}
    assert programs[9] == programs[10_000]
    outs = _RUN_RADII(key, grid, parents)  # radii 1, 9 and 10,000 in one program
    for a, b in zip(outs[9], outs[10_000]):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    check_outputs(grid, parents, *outs[10_000], "waypoint")
    # the clamp does not hide the radius: radius 1 moves a node by at most one cell
    c, n, failed = (np.asarray(v) for v in outs[1][:3])
    pc = np.asarray(parents.cells)
    moved = c != pc
    assert moved.any()
    w = grid.width
    assert (np.maximum(abs(c % w - pc % w), abs(c // w - pc // w))[moved] == 1).all()


def test_range_mutation_regrows_between_kept_parts():
    """Zhu 4.5: only the stretch between the two nodes changes, by a directional walk."""
    grid = _grid(np.zeros((6, SIZE)), start=(0, 0), goal=(9, 0), rule="strict")
    row = [(x, 0) for x in range(SIZE)]
    counts, n_failed = _outcomes("regrow_segment", grid, row, 40)
    changed = [k for k in counts if k != tuple(row)]
    assert changed and n_failed < 40 * P
    for k in changed:
        # A changed path keeps a prefix and a suffix of the row and leaves it in between.
        i = next(t for t in range(len(k)) if k[t] != row[t])
        j = next(t for t in range(1, len(k) + 1) if k[-t] != row[-t])
        assert i >= 1 and j >= 2 and any(y > 0 for _, y in k)


# --------------------------------------------------------------- segment_sa
def _zigzag():
    """(x, 0), (x, 1) alternating: every reconnection of >= 1 deleted node is shorter."""
    return [(x // 2, x % 2) for x in range(2 * SIZE)]


_DELTA = 0.05
_ZIGZAG = _population(Grid.create(np.zeros((SIZE, SIZE), bool), corner_rule="free"), [_zigzag()])


def _worse(g, c, n):
    """Fitness 1 on the zigzag, ``1 - _DELTA`` on any other path."""
    zc, zn = _ZIGZAG.cells[0], _ZIGZAG.length[0]
    return jnp.where(jnp.all(c == zc) & (n == zn), 1.0, 1.0 - _DELTA)


_RUN_WORSE = _runner(functools.partial(M.segment_sa, fitness_fn=_worse), (None,))


def test_segment_sa_acceptance_rate_matches_eq_16():
    """MPMGA eq. 15-16 at fixed T: a worse mutant is accepted w.p. 1 / (1 + e^{(f_old -
    f_new)/T}). The fitness gives every changed path exactly f_old - delta, and on the
    zigzag every mutant is changed (median reconnection is strictly shorter)."""
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(0, 0), goal=(9, 1), corner_rule="free")
    pop = _population(grid, [_zigzag()])
    pn = int(pop.length[0])
    delta = _DELTA
    for temp in (0.05, 0.02):
        accepted = trials = 0
        for s in range(250):
            c, n, failed, nf = _RUN_WORSE(jax.random.PRNGKey(s), grid, pop, np.float32(temp))
            assert int(nf) == 0
            accepted += int((np.asarray(n) != pn).sum())
            trials += P
        p = 1.0 / (1.0 + math.exp(delta / temp))
        assert stats.binomtest(accepted, trials, p).pvalue > 1e-3, (temp, accepted, p)
        # The wrong sign (accept w.p. 1 / (1 + e^{-a})) fails this test.
        assert stats.binomtest(accepted, trials, 1 - p).pvalue < 1e-6


_FITNESS = jax.jit(population_map(objectives.mpmga))


def test_segment_sa_zero_temperature_only_improves():
    grid = random_map(SIZE, SIZE, 0.1, 4, corner_rule="free")
    parents = random_parents(grid, P, 1)
    f0 = np.asarray(_FITNESS(grid, parents.cells, parents.length))
    changed = 0
    for s in range(10):
        c, n, failed, _ = RUN["segment_sa"](jax.random.PRNGKey(s), grid, parents, np.float32(0))
        f1 = np.asarray(_FITNESS(grid, c, n))
        assert (f1 >= f0).all()
        changed += int(np.any(np.asarray(c) != np.asarray(parents.cells), axis=1).sum())
    assert changed > 0


# ------------------------------------------------------------------ probabilities
_AMP = jax.jit(M.adaptive_mutation_probability)


def test_adaptive_mutation_probability_exact():
    """AGACD eq. 28-29 (with jaxga's min(1, .)) on hand-picked inputs."""
    amp = _AMP
    lo, hi = 0.15, 0.3
    f = np.array([1.0, 0.75, 0.5, 0.2], np.float32)  # f_max 1, f_avg 0.5
    for t, T in [(0, 100), (50, 100), (100, 100)]:
        got = np.asarray(amp(f, 1.0, 0.5, t, T, lo, hi))
        g = math.exp(t / T)
        want = [0.0, lo * 0.25 / 0.5 * g, lo * g, min(1.0, hi * g)]
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
        assert got.dtype == np.float32
    # Converged population: pm_high (not pc_low as for crossover), clamped at 1.
    np.testing.assert_allclose(np.asarray(amp(0.4, 0.4, 0.4, 10, 100, lo, hi)), hi * math.exp(0.1),
                               rtol=1e-6)
    assert float(amp(0.4, 0.4, 0.4, 100, 100, 0.3, 0.6)) == 1.0
    # A float32 mean of identical fitnesses off by an ulp still counts as converged.
    f = np.float32(0.1)
    below = np.nextafter(f, np.float32(0))
    np.testing.assert_allclose(np.asarray(amp(f, f, below, 0, 10, lo, hi)), hi, rtol=1e-6)
    np.testing.assert_allclose(np.asarray(amp(below, f, f, 0, 10, lo, hi)), hi, rtol=1e-6)


def _marker(key, grid, cells, length):
    """An operator that always 'fails': its failure count is the number of applications."""
    return cells, length, jnp.ones((), bool)


@jax.jit
def _rates(grid, pop, fitness, p_scalar, p_gated):
    """The rate tests' four applications of :func:`_marker` in one program: per
    individual with ``pm`` from eq. 28-29 (one key each, vmapped), through
    over_individuals at the scalar ``p_scalar``, and through the gated population helper
    at the scalar ``p_gated`` and at ``pm``."""
    pm = M.adaptive_mutation_probability(fitness, fitness.max(), fitness.mean(), 20, 100)
    keys = jax.random.split(jax.random.PRNGKey(3), pop.size)
    op = jax.vmap(with_probability(_marker), in_axes=(0, None, 0, 0, 0))
    _, _, applied = op(keys, grid, pop.cells, pop.length, pm)
    _, failed_scalar = over_individuals(with_probability(_marker), in_axes_extra=(None,))(
        jax.random.PRNGKey(4), grid, pop, p_scalar)
    lifted = mutation_population(_marker)
    _, failed_gated = lifted(jax.random.PRNGKey(5), grid, pop, p_gated)
    _, failed_gated_pm = lifted(jax.random.PRNGKey(6), grid, pop, pm)
    return pm, applied, failed_scalar, failed_gated, failed_gated_pm


def test_with_probability_empirical_rate():
    """Per-individual pm from eq. 28-29: the applied fraction per group is binomial."""
    grid = Grid.create(np.zeros((4, 4), bool), corner_rule="free")
    n = 6000
    fitness = np.where(np.arange(n) % 3 == 0, 1.0, np.where(np.arange(n) % 3 == 1, 0.8, 0.1))
    fitness = fitness.astype(np.float32)
    pop = Population(np.zeros((n, 4), np.int32), np.ones((n,), np.int32))
    pm, applied, failed_scalar, failed_gated, failed_gated_pm = (
        np.asarray(v) for v in _rates(grid, pop, fitness, np.float32(0.2), np.float32(0.3)))
    for g in range(3):
        sel = np.arange(n) % 3 == g
        p = float(pm[sel][0])
        k = int(applied[sel].sum())
        if p == 0.0:
            assert k == 0
        else:
            assert stats.binomtest(k, int(sel.sum()), p).pvalue > 1e-3, (g, k, p)
    assert stats.binomtest(int(failed_scalar), n, 0.2).pvalue > 1e-3
    # The population helper: a scalar pm and a per-individual pm.
    assert stats.binomtest(int(failed_gated), n, 0.3).pvalue > 1e-3
    assert stats.binomtest(int(failed_gated_pm), n, float(pm.mean())).pvalue > 1e-3


@jax.jit
def _split_and_either(grid, cells, length, use_a):
    """split_half of 101 positions, of 10 positions for 400 keys, and
    either(replace_point, _marker) with each flag of ``use_a``: one program."""
    mask = M.split_half(jax.random.PRNGKey(0), 101)
    keys = jax.random.split(jax.random.PRNGKey(1), 400)
    masks = jax.vmap(M.split_half, in_axes=(0, None))(keys, 10)
    op = either(M.replace_point, _marker)
    return mask, masks, [op(jax.random.PRNGKey(0), grid, cells, length, u) for u in use_a]


def test_either_and_split_half():
    grid = Grid.create(np.zeros((4, 4), bool), start=(0, 0), goal=(2, 0), corner_rule="free")
    cells = np.asarray([0, 1, 2, 2, 2, 2, 2, 2], np.int32)
    mask, masks, ((c, n, f), (c2, n2, f2)) = _split_and_either(
        grid, cells, np.int32(3), np.array([True, False]))
    assert np.asarray(mask).sum() == 50
    masks = np.asarray(masks)
    assert stats.chisquare(masks.sum(0)).pvalue > 1e-3  # every position equally likely
    assert np.asarray(c)[:3].tolist() == [0, 5, 2] and not bool(f)
    assert np.asarray(c2)[:3].tolist() == [0, 1, 2] and bool(f2)


_X64_NAMES = ("replace_point", "cut_corners_knight", "point_checked", "segment_sa")


@jax.jit
def _x64_ops(grid, cells, length, extras):
    """The operators of :data:`_X64_NAMES` on one path (their extra arguments given), and
    adaptive_mutation_probability on Python scalars: one program, run under x64."""
    outs = [OPS[name][0](jax.random.PRNGKey(0), grid, cells, length, *extra)
            for name, extra in zip(_X64_NAMES, extras)]
    return outs, M.adaptive_mutation_probability(0.5, 1.0, 0.5, 3, 10)


def test_x64_mode_keeps_dtypes():
    """Under JAX_ENABLE_X64 the operators still return int32 cells/lengths."""
    grid = random_map(SIZE, SIZE, 0.2, 1, corner_rule="strict")
    parents = random_parents(grid, P, 0)
    cells, length = np.asarray(parents.cells)[0], np.asarray(parents.length)[0]
    with jax.enable_x64(True):
        outs, pm = _x64_ops(grid, cells, length, [OPS[name][1] for name in _X64_NAMES])
        for name, (c, n, f) in zip(_X64_NAMES, outs):
            assert c.dtype == jnp.int32 and n.dtype == jnp.int32 and f.dtype == jnp.bool_, name
        assert pm.dtype == jnp.float32
