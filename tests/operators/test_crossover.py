"""Crossover operators (the papers' sections on crossover): properties, worked examples, statistics.

Every operator is run under ``jax.jit`` through :func:`jaxga.operators.lift.over_pairs` (the
vmap over pairs) and compared with an independent pure-Python reference that enumerates
every possible crossing choice: the operator's output must be the outcome of one of them
(children with loops cut, capacity failures keeping the parent, rejections keeping the
parent), so loop removal, the failure contract and acceptance rules are checked exactly.

Every jitted function is built once, at module level, and each test's computations on one
map are one program: the property tests' SIZE x SIZE maps with 8 paths of capacity CAP
(the worked examples on such maps reuse them), and one program per hand-made map. Inputs
are NumPy and expected values come from NumPy and pure Python references (no eager
``jnp``).
"""

from __future__ import annotations

import functools
import unittest.mock

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.stats
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxga import Grid
from jaxga.core.geometry import clear
from jaxga.core.grid import DIRECTIONS
from jaxga.core.paths import (
    Population,
    has_endpoints,
    is_continuous,
    is_feasible,
    is_loop_free,
    remove_loops,
)
from jaxga.maps.preprocess import legal_moves
from jaxga.operators import column_crossover as XC
from jaxga.operators import crossover as X
from jaxga.operators import joins as J
from jaxga.operators.lift import over_pairs
from jaxga.operators.repair import connect
from tests.strategies import CAP, SIZE, grids_and_parents

# the crossovers' properties and references in depth (contracts: test_registry)
pytestmark = pytest.mark.slow

N_CELLS = SIZE * SIZE


def _len_fitness(grid, cells, length):
    """Fitness 1 / node count: exact float32 comparisons for the Python reference."""
    return 1.0 / jnp.asarray(length, jnp.float32)


_OPS = {
    "common_point": X.common_point,
    "cut_and_check": X.cut_and_check,
    "heterologous": functools.partial(X.heterologous, fitness_fn=_len_fitness),
    "column": functools.partial(X.column, fitness_fn=_len_fitness),
}
_POP_OPS = {name: jax.jit(over_pairs(op)) for name, op in _OPS.items()}


def _checks(grid, cells, length):
    return (
        has_endpoints(grid, cells, length),
        is_continuous(grid, cells, length),
        is_feasible(grid, cells, length),
        is_loop_free(cells, length),
    )


_HPAIRS = jax.jit(X.heterologous_pairs)
_CHECK = jax.jit(jax.vmap(_checks, in_axes=(None, 0, 0)))
_CLEAR_ALL = jax.jit(
    lambda g: jax.vmap(lambda a: jax.vmap(lambda b: clear(g, a, b))(jnp.arange(N_CELLS)))(
        jnp.arange(N_CELLS)
    )
)


# ------------------------------------------------------------ Python reference
def _rl(seq):
    """remove_loops in plain Python (MPMGA deletion operator)."""
    last = {c: k for k, c in enumerate(seq)}
    out, k = [], 0
    while k < len(seq):
        out.append(seq[k])
        k = last[seq[k]] + 1
    return out


def _adjacency(grid):
    """Python set of legal (a, b) steps, from jaxga.maps.preprocess.legal_moves."""
    lm = legal_moves(grid.blocked_np(), grid.corner_rule)
    w = grid.width
    adj = set()
    for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
        for y, x in zip(*np.nonzero(lm[d])):
            adj.add((y * w + x, (y + dy) * w + x + dx))
    return adj


def _common_outcomes(grid, p1, p2, cap):
    out = []
    s, g = int(grid.start), int(grid.goal)
    for i in range(1, len(p1) - 1):
        if p1[i] in (s, g) or p1[i] not in p2[1:-1]:
            continue
        j = p2.index(p1[i])
        out.append(_outcome(_rl(p1[:i] + p2[j:]), _rl(p2[:j] + p1[i:]), p1, p2, cap))
    return out


def _outcome(k1, k2, p1, p2, cap, take1=True, take2=True, need1=True, need2=True):
    f = int(len(k1) > cap and need1) + int(len(k2) > cap and need2)
    o1 = k1 if (take1 and len(k1) <= cap) else p1
    o2 = k2 if (take2 and len(k2) <= cap) else p2
    return o1, o2, f


def _cut_outcomes(grid, p1, p2, cap, clr):
    out = []
    for i in range(len(p1) - 1):
        for j in range(len(p2) - 1):
            k1 = _rl(p1[: i + 1] + p2[j + 1 :])
            k2 = _rl(p2[: j + 1] + p1[i + 1 :])
            ok1 = all(clr[a, b] for a, b in zip(k1, k1[1:]))
            ok2 = all(clr[a, b] for a, b in zip(k2, k2[1:]))
            out.append(_outcome(k1, k2, p1, p2, cap, ok1, ok2, ok1, ok2))
    return out


def _hetero_pairs(p1, p2, adj):
    def near(a, b):
        return a == b or (a, b) in adj

    return {
        (i, j)
        for i in range(len(p1) - 1)
        for j in range(len(p2) - 1)
        if near(p1[i], p2[j + 1]) and near(p1[i + 1], p2[j])
        and (i, j) not in ((0, 0), (len(p1) - 2, len(p2) - 2))
    }


def _hetero_outcomes(p1, p2, cap, adj):
    out = []
    for i, j in sorted(_hetero_pairs(p1, p2, adj)):
        k1 = _rl(p1[: i + 1] + p2[j + 1 :])
        k2 = _rl(p2[: j + 1] + p1[i + 1 :])
        out.append(_outcome(k1, k2, p1, p2, cap, len(k1) < len(p1), len(k2) < len(p2)))
    return out


def _pair_set(jtab, valid):
    """The crossing pairs ``(i, j)`` of a :func:`X.heterologous_pairs` table, as a set."""
    jtab, valid = np.asarray(jtab), np.asarray(valid)
    return {(int(i), int(jtab[i, o])) for i, o in zip(*np.nonzero(valid))}


def _lists(cells, length):
    return [np.asarray(cells)[k, : int(length[k])].tolist() for k in range(len(length))]


def _waypoints(pop: Population, clr, seed):
    """Waypoint parents: drop random non-consecutive interior nodes whose bypass is clear."""
    rng = np.random.default_rng(seed)
    paths = []
    for p in pop.to_lists():
        out, k = [p[0]], 1
        while k < len(p) - 1:
            if rng.random() < 0.6 and clr[out[-1], p[k + 1]]:
                out.append(p[k + 1])  # skip node k
                k += 2
            else:
                out.append(p[k])
                k += 1
        if out[-1] != p[-1]:
            out.append(p[-1])
        paths.append(out)
    return _population(paths, pop.capacity)


def _population(paths, capacity: int = CAP) -> Population:
    """Paths (lists of cells) as a Population of NumPy arrays, padded with the last cell."""
    cells = np.array([list(p) + [p[-1]] * (capacity - len(p)) for p in paths], np.int32)
    return Population(cells, np.array([len(p) for p in paths], np.int32))


def _run(name, grid, pop, seed):
    out, n_failed = _POP_OPS[name](jax.random.PRNGKey(seed), grid, pop)
    return out, int(n_failed)


def _assert_valid(grid, out: Population, waypoint=False):
    ends, cont, feas, loop_free = (np.asarray(v) for v in _CHECK(grid, out.cells, out.length))
    assert ends.all() and loop_free.all() and feas.all()
    assert np.all(np.asarray(out.length) <= out.capacity)
    if not waypoint:
        assert cont.all()
    # padding repeats the last cell
    for row, n in zip(np.asarray(out.cells), np.asarray(out.length)):
        assert (row[n:] == row[n - 1]).all()


def _assert_matches(got, outcomes, p1, p2, n_failed_pair):
    """``got`` = (o1, o2) must be one of the reference outcomes (or the parents if none)."""
    if not outcomes:
        assert got == (p1, p2) and n_failed_pair == 0
        return
    matches = [f for o1, o2, f in outcomes if (o1, o2) == got]
    assert matches, f"output {got} is not a possible outcome"
    return matches


# ----------------------------------------------------------------- properties
@settings(max_examples=30)
@given(grids_and_parents(n=8), st.integers(0, 2**30))
def test_common_point_properties(gp, seed):
    grid, pop = gp
    out, n_failed = _run("common_point", grid, pop, seed)
    _assert_valid(grid, out)
    parents, kids = pop.to_lists(), out.to_lists()
    fails = []
    for k in range(0, 8, 2):
        p1, p2 = parents[k], parents[k + 1]
        got = (kids[k], kids[k + 1])
        m = _assert_matches(got, _common_outcomes(grid, p1, p2, CAP), p1, p2, 0)
        fails.append(0 if m is None else min(m))
    assert n_failed == sum(fails)


@settings(max_examples=30)
@given(grids_and_parents(n=8), st.integers(0, 2**30), st.booleans())
def test_cut_and_check_properties(gp, seed, waypoint):
    """Continuous parents and waypoint parents (random clear bypasses): every segment of
    every output is clear, endpoints kept, loop-free, and the output is a reference
    outcome (junction clear -> child, else parent)."""
    grid, pop = gp
    clr = np.asarray(_CLEAR_ALL(grid))
    if waypoint:
        pop = _waypoints(pop, clr, seed)
        assert np.asarray(_CHECK(grid, pop.cells, pop.length)[2]).all()
    out, n_failed = _run("cut_and_check", grid, pop, seed)
    _assert_valid(grid, out, waypoint=True)
    parents, kids = pop.to_lists(), out.to_lists()
    for k in range(0, 8, 2):
        p1, p2 = parents[k], parents[k + 1]
        _assert_matches((kids[k], kids[k + 1]), _cut_outcomes(grid, p1, p2, CAP, clr), p1, p2, 0)
    assert n_failed == 0  # parents of <= 32 cells cannot overflow CAP = 64 children


@settings(max_examples=30)
@given(grids_and_parents(n=8), st.integers(0, 2**30))
def test_heterologous_properties(gp, seed):
    grid, pop = gp
    adj = _adjacency(grid)
    out, n_failed = _run("heterologous", grid, pop, seed)
    _assert_valid(grid, out)
    parents, kids = pop.to_lists(), out.to_lists()
    cells, length = np.asarray(pop.cells), np.asarray(pop.length)
    for k in range(0, 8, 2):
        p1, p2 = parents[k], parents[k + 1]
        # the pair table equals the O(L^2) brute force
        jtab, valid = _HPAIRS(grid, cells[k], length[k], cells[k + 1], length[k + 1])
        got_pairs = _pair_set(jtab, valid)
        assert got_pairs == _hetero_pairs(p1, p2, adj)
        _assert_matches((kids[k], kids[k + 1]), _hetero_outcomes(p1, p2, CAP, adj), p1, p2, 0)
        # a child only replaces its parent when strictly fitter (here: shorter)
        assert len(kids[k]) <= len(p1) and len(kids[k + 1]) <= len(p2)
    assert n_failed == 0


def _child_keys(key, n_pairs):
    """The key column_child gets for each pair of ``over_pairs(column)(key, ...)`` (the
    documented keys: over_pairs gives one key per pair, column its first half to the
    child)."""
    return jax.vmap(lambda k: jax.random.split(k)[0])(jax.random.split(key, n_pairs))


def _pairs_of(pop):
    """``(c1, l1, c2, l2)``: the pairs (0, 1), (2, 3), ... of a population."""
    return pop.cells[0::2], pop.length[0::2], pop.cells[1::2], pop.length[1::2]


@functools.partial(jax.jit, static_argnames="max_rounds")
def _column_and_children(key, grid, pop, max_rounds=None):
    """``over_pairs(column)`` (fitness 1 / nodes) and each pair's child recomputed by
    column_child with the documented keys: ``(out, n_failed, (cells, length, ok))``."""
    op = functools.partial(X.column, fitness_fn=_len_fitness, max_rounds=max_rounds)
    out, n_failed = over_pairs(op)(key, grid, pop)
    child = functools.partial(XC.column_child, max_rounds=max_rounds)
    kids = jax.vmap(child, in_axes=(0, None, 0, 0, 0, 0))(
        _child_keys(key, pop.size // 2), grid, *_pairs_of(pop))
    return out, n_failed, kids


@jax.jit
def _column_children_checked(key, grid, pop):
    """column_child of each pair with the keys ``split(key, pairs)``, and the checks of
    the children."""
    keys = jax.random.split(key, pop.size // 2)
    c, n, ok = jax.vmap(XC.column_child, in_axes=(0, None, 0, 0, 0, 0))(keys, grid,
                                                                        *_pairs_of(pop))
    return ok, jax.vmap(_checks, in_axes=(None, 0, 0))(grid, c, n)


@settings(max_examples=25)
@given(grids_and_parents(n=8, corner_rules=("free",)), st.integers(0, 2**30))
def test_column_properties(gp, seed):
    """Outputs are valid paths drawn from {P1, P2, child}; a failed pair returns exactly
    its parents; failures are counted two per failed pair. One corner rule (each compiles
    the operator and the child again, about 7 s): the child under every rule is checked
    by ``test_column_child_is_valid_when_ok``."""
    grid, pop = gp
    # each pair's child recomputed with the documented keys (over_pairs: one key per
    # pair; column: its first half for the child), in the operator's program
    out, n_failed, kids_ref = _column_and_children(jax.random.PRNGKey(seed), grid, pop)
    n_failed = int(n_failed)
    _assert_valid(grid, out)
    parents, kids = pop.to_lists(), out.to_lists()
    kc, kl, ok = (np.asarray(v) for v in kids_ref)
    assert n_failed == 2 * int((~ok).sum())
    for k in range(0, 8, 2):
        p1, p2 = parents[k], parents[k + 1]
        o1, o2 = kids[k], kids[k + 1]
        if ok[k // 2]:
            child = kc[k // 2, : kl[k // 2]].tolist()
            assert o1 in (p1, p2, child) and o2 in (p1, p2, child)
        else:
            assert (o1, o2) == (p1, p2)


@settings(max_examples=20)
@given(grids_and_parents(n=8), st.integers(0, 2**30))
def test_column_child_is_valid_when_ok(gp, seed):
    grid, pop = gp
    # keys split(PRNGKey(seed), 4), one per pair
    ok, checks = _column_children_checked(jax.random.PRNGKey(seed), grid, pop)
    ends, cont, _, lf = (np.asarray(v) for v in checks)
    ok = np.asarray(ok)
    assert (ends | ~ok).all() and (cont | ~ok).all() and (lf | ~ok).all()


# ------------------------------------------------------------- exact examples
def _imga_grid():
    return Grid.create(np.zeros((10, 10), bool), corner_rule="free")


def _imga(label):
    """IMGA numbers the cells of its 10 x 10 map 1..100 (S = N_1, G = N_100, section 4.1
    (2)); jaxga's index is number - 1. The crossover example does not depend on it."""
    return {"S": 0, "G": 99}.get(label, None) if isinstance(label, str) else label - 1


def test_imga_crossover_example():
    """IMGA section 4.3.2: S-2-12-67-69-89-G x S-11-22-67-78-80-G at 67 ->
    S-2-12-67-78-80-G and S-11-22-67-69-89-G (67 is the only common cell)."""
    m1 = [_imga(v) for v in ("S", 2, 12, 67, 69, 89, "G")]
    m2 = [_imga(v) for v in ("S", 11, 22, 67, 78, 80, "G")]
    e1 = [_imga(v) for v in ("S", 2, 12, 67, 78, 80, "G")]
    e2 = [_imga(v) for v in ("S", 11, 22, 67, 69, 89, "G")]
    pop = _population([m1, m2] * 4)  # the property tests' program: 8 paths of capacity CAP
    out, n_failed = _POP_OPS["common_point"](jax.random.PRNGKey(3), _imga_grid(), pop)
    assert out.to_lists() == [e1, e2] * 4 and int(n_failed) == 0


def test_common_point_without_common_cell_returns_parents():
    """The pair four times (four keys), through the property tests' program."""
    pop = _population([[0, 1, 2, 99], [0, 10, 20, 99]] * 4)
    out, n_failed = _POP_OPS["common_point"](jax.random.PRNGKey(0), _imga_grid(), pop)
    assert np.array_equal(out.cells, pop.cells) and np.array_equal(out.length, pop.length)
    assert int(n_failed) == 0


def _snake_pair():
    """On an empty 10 x 10 map: p1 (50 cells) snakes through rows 0-3 before reaching
    (5, 5), p2 (42 cells) reaches (5, 5) quickly and snakes through rows 6-9: crossing
    near (5, 5) gives one child far over the capacity CAP (81 cells at (5, 5)) and one
    short child."""
    w = 10
    head1 = [y * w + (x if y % 2 == 0 else 9 - x) for y in range(4) for x in range(10)]
    head1 += [4 * w + x for x in range(5)]
    p1 = head1 + [55, 66, 77, 88, 99]
    tail2 = [6 * w + x for x in range(4, -1, -1)] + [7 * w + x for x in range(10)]
    tail2 += [8 * w + x for x in range(9, -1, -1)] + [9 * w + x for x in range(10)]
    p2 = [0, 1, 12, 23, 34, 45, 55] + tail2
    return p1, p2


@pytest.mark.parametrize("name", ["common_point", "cut_and_check", "heterologous"])
def test_capacity_overflow_keeps_the_parent_and_counts(name):
    """Each of 64 pairs (different keys) gives a reference outcome, where a child over
    the capacity keeps its parent; the failures are counted exactly. The pairs go four
    at a time through the property tests' programs (capacity CAP)."""
    p1, p2 = _snake_pair()
    grid = _imga_grid()
    cap = CAP
    if name == "common_point":
        ref = _common_outcomes(grid, p1, p2, cap)
    elif name == "cut_and_check":
        ref = _cut_outcomes(grid, p1, p2, cap, np.asarray(_CLEAR_ALL(grid)))
    else:
        ref = _hetero_outcomes(p1, p2, cap, _adjacency(grid))
    assert any(f > 0 for *_, f in ref)
    pop = _population([p1, p2] * 4, cap)
    kids, n_failed = [], 0
    for call in range(16):
        out, failed = _POP_OPS[name](jax.random.PRNGKey(call), grid, pop)
        kids, n_failed = kids + out.to_lists(), n_failed + int(failed)
    lo = hi = 0
    for k in range(0, 128, 2):
        m = _assert_matches((kids[k], kids[k + 1]), ref, p1, p2, 0)
        lo, hi = lo + min(m), hi + max(m)
    assert lo <= n_failed <= hi and n_failed > 0


_COLUMN_RANGES = jax.jit(XC.column_ranges)


def _candidate_sets(grid, c1, l1, c2, l2):
    """:func:`XC.column_candidate_sets` (host-side), with its column_ranges run as one
    jitted program instead of op by op."""
    def ranges(*args):
        return XC.ColumnRanges(*(np.asarray(v) for v in _COLUMN_RANGES(*args)))

    with unittest.mock.patch.object(XC, "column_ranges", ranges):
        return XC.column_candidate_sets(grid, c1, l1, c2, l2)


@jax.jit
def _column_draws(key, grid, c1, l1, c2, l2):
    """For the keys ``split(key, 4000)``: column_anchors with column_child's split (the
    first half of each key), column_anchors with the keys themselves, and column_child:
    ``(anchors, anchors from the keys, children)``."""
    keys = jax.random.split(key, 4000)
    k_anchor = jax.vmap(lambda k: jax.random.split(k)[0])(keys)  # column_child's split
    anchors = jax.vmap(XC.column_anchors, in_axes=(0,) + (None,) * 5)
    kids = jax.vmap(XC.column_child, in_axes=(0,) + (None,) * 5)(keys, grid, c1, l1, c2, l2)
    return (anchors(k_anchor, grid, c1, l1, c2, l2), anchors(keys, grid, c1, l1, c2, l2),
            kids)


def test_zhu_figure5_column_candidates():
    """Zhu & Pan section 4.4, Figure 5 (5 x 5 map numbered from the bottom left):
    P1 = (0, 5, 10, 16, 17, 23, 24), P2 = (0, 1, 2, 8, 14, 19, 24); the second column's
    min and max are 1 and 16, so its candidate set is (1, 6, 11, 16). Figure 5's
    obstacles are not given in the text: the map here is obstacle-free."""
    grid = Grid.create(np.zeros((5, 5), bool), corner_rule="free")
    pop = _population([[0, 5, 10, 16, 17, 23, 24], [0, 1, 2, 8, 14, 19, 24]], 16)
    args = (grid, pop.cells[0], pop.length[0], pop.cells[1], pop.length[1])
    sets = _candidate_sets(*args)
    assert sets[0] == [1, 6, 11, 16]
    assert sets == [[1, 6, 11, 16], [2, 7, 12, 17], [8, 13, 18, 23]]
    # The draws are uniform over each set (chi-square at a fixed key), and the paper's
    # draw (6, 17, 18) is connected into the paper's child P(0, 6, 11, 17, 18, 24).
    (anchors, n, ok), _, kids = _column_draws(jax.random.PRNGKey(0), *args)
    anchors = np.asarray(anchors)
    assert np.asarray(ok).all() and (np.asarray(n) == 5).all()
    assert (anchors[:, 0] == 0).all() and (anchors[:, 4] == 24).all()
    for col, cand in enumerate(sets, start=1):
        counts = [int(np.sum(anchors[:, col] == c)) for c in cand]
        assert sum(counts) == len(anchors)
        assert scipy.stats.chisquare(counts).pvalue > 1e-4
    kids = [np.asarray(v) for v in kids]
    hit = np.flatnonzero((anchors[:, 1:4] == [6, 17, 18]).all(axis=1))
    assert len(hit) > 20
    for k in hit:
        assert kids[0][k, : kids[1][k]].tolist() == [0, 6, 11, 17, 18, 24]


def test_column_blocked_cells_are_never_candidates():
    blocked = np.zeros((5, 5), bool)
    blocked[1, 1] = blocked[2, 1] = True  # cells 6 and 11
    grid = Grid.create(blocked, corner_rule="free")
    pop = _population([[0, 5, 10, 16, 17, 23, 24], [0, 1, 2, 8, 14, 19, 24]], 16)
    args = (grid, pop.cells[0], pop.length[0], pop.cells[1], pop.length[1])
    assert _candidate_sets(*args)[0] == [1, 16]
    # the anchors of the keys split(PRNGKey(1), 4000) (the program of the test above)
    anchors = np.asarray(_column_draws(jax.random.PRNGKey(1), *args)[1][0])
    assert set(anchors[:, 1].tolist()) == {1, 16}


def _sharp_fitness(grid, cells, length):
    return (1.0 / jnp.asarray(length, jnp.float32)) ** 6


@jax.jit
def _roulette(key, grid, pop):
    """``over_pairs(column)`` with fitness ``_sharp_fitness``, with independent spins
    (``False``) and distinct ones (``True``), and each pair's child recomputed with the
    documented keys: ``({distinct: (out, n_failed)}, children)``."""
    outs = {d: over_pairs(functools.partial(X.column, fitness_fn=_sharp_fitness,
                                            distinct=d))(key, grid, pop)
            for d in (False, True)}
    kids = jax.vmap(XC.column_child, in_axes=(0, None, 0, 0, 0, 0))(
        _child_keys(key, pop.size // 2), grid, *_pairs_of(pop))
    return outs, kids


@pytest.mark.parametrize("distinct", [False, True])
def test_column_roulette_over_parents_and_child(distinct):
    """On success two spins over {P1, P2, child} with weights = fitness (Zhu eq. 10).

    The child of each pair is recomputed with the documented key split, so the expected
    slot frequencies are known; chi-square at a fixed key, and equal weights rejected."""
    grid = Grid.create(np.zeros((5, 5), bool), corner_rule="free")
    p1, p2 = [0, 5, 10, 16, 17, 23, 24], [0, 1, 2, 8, 14, 19, 24]
    n = 2000
    pop = _population([p1, p2] * n, 16)
    outs, kids_ref = _roulette(jax.random.PRNGKey(5), grid, pop)
    out, n_failed = outs[distinct]
    assert int(n_failed) == 0  # open map: the connection always closes
    kc, kl, ok = (np.asarray(v) for v in kids_ref)
    assert ok.all()
    kids = out.to_lists()
    obs, exp = np.zeros(3), np.zeros(3)
    for k in range(n):
        child = kc[k, : kl[k]].tolist()
        if child in (p1, p2):
            continue
        w = np.array([1 / 7, 1 / 7, 1 / len(child)]) ** 6
        picks = [0 if o == p1 else 1 if o == p2 else 2 for o in (kids[2 * k], kids[2 * k + 1])]
        assert all(o in (p1, p2, child) for o in (kids[2 * k], kids[2 * k + 1]))
        if distinct:
            assert picks[0] != picks[1]
            q = w / w.sum()
            # P(member m among the two) = q_m + sum_{a != m} q_a q_m / (1 - q_a)
            exp += [q[m] + sum(q[a] * q[m] / (1 - q[a]) for a in range(3) if a != m)
                    for m in range(3)]
        else:
            exp += 2 * w / w.sum()
        for p in picks:
            obs[p] += 1
    assert scipy.stats.chisquare(obs, exp * obs.sum() / exp.sum()).pvalue > 1e-4
    uniform = np.full(3, obs.sum() / 3)
    assert scipy.stats.chisquare(obs, uniform).pvalue < 1e-6


def test_column_failure_returns_both_parents():
    """A connection that cannot close within max_rounds (3 here: some pairs close, some
    do not) is Zhu's "crossover failure"."""
    blocked = np.zeros((10, 10), bool)
    blocked[2:9, 4] = True  # a wall the medians fall into
    grid = Grid.create(blocked, corner_rule="free")
    par = [[0, 1, 2, 3, 13, 23, 33, 43, 53, 63, 73, 83, 93, 94, 95, 96, 97, 98, 99],
           [0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 91, 92, 93, 94, 95, 96, 97, 98, 99]]
    pop = _population(par * 32)
    # each pair's child recomputed with the documented keys (over_pairs: one key per
    # pair; column: its first half for the child): a failed pair returns exactly
    # (P1, P2) and counts 2, a successful one only members of {P1, P2, child}
    out, n_failed, kids_ref = _column_and_children(jax.random.PRNGKey(0), grid, pop,
                                                   max_rounds=3)
    kids = out.to_lists()
    kc, kl, ok = (np.asarray(v) for v in kids_ref)
    assert 0 < (~ok).sum() < 32  # both outcomes occur at this key
    assert int(n_failed) == 2 * int((~ok).sum())
    for k in range(32):
        if ok[k]:
            members = (par[0], par[1], kc[k, : kl[k]].tolist())
            assert all(o in members for o in kids[2 * k: 2 * k + 2])
        else:
            assert kids[2 * k: 2 * k + 2] == par, k


@jax.jit
def _hetero_example(grid, c1, l1, c2, l2):
    """common_point's failure count at PRNGKey(0), and heterologous (fitness 1 / nodes) for
    the keys ``split(PRNGKey(0), 600)``."""
    common_failed = X.common_point(jax.random.PRNGKey(0), grid, c1, l1, c2, l2)[4]
    keys = jax.random.split(jax.random.PRNGKey(0), 600)
    op = jax.vmap(functools.partial(X.heterologous, fitness_fn=_len_fitness),
                  in_axes=(0,) + (None,) * 5)
    return common_failed, op(keys, grid, c1, l1, c2, l2)


def test_heterologous_hand_made_pair():
    """5 x 5 empty map; the parents share no interior cell (no homologous crossover).
    By hand, the valid pairs are (0, 1): S~6, 5~1; (3, 3): 17~13, 18~12; (4, 5): 18~G,
    23~19. With fitness 1 / nodes, (0, 1) and (4, 5) give a shorter child 1
    (0-6-12-13-19-24, 0-5-11-17-18-24; accepted) and a longer child 2 (rejected);
    (3, 3) gives two children of the parents' length (rejected: not strictly fitter)."""
    grid = Grid.create(np.zeros((5, 5), bool), corner_rule="strict")
    p1 = [0, 5, 11, 17, 18, 23, 24]
    p2 = [0, 1, 6, 12, 13, 19, 24]
    pop = _population([p1, p2], 16)
    args = (grid, pop.cells[0], pop.length[0], pop.cells[1], pop.length[1])
    jtab, valid = _HPAIRS(*args)
    pairs = _pair_set(jtab, valid)
    assert pairs == {(0, 1), (3, 3), (4, 5)} == _hetero_pairs(p1, p2, _adjacency(grid))
    common_failed, crossed = _hetero_example(*args)
    assert int(common_failed) == 0
    outcomes = [
        ([0, 6, 12, 13, 19, 24], p2),
        (p1, p2),
        ([0, 5, 11, 17, 18, 24], p2),
    ]
    c1, l1, c2, l2, failed = (np.asarray(v) for v in crossed)
    counts = np.zeros(3)
    for k in range(600):
        got = (c1[k, : l1[k]].tolist(), c2[k, : l2[k]].tolist())
        counts[outcomes.index(got)] += 1
    assert not np.asarray(failed).any()
    assert scipy.stats.chisquare(counts).pvalue > 1e-4  # uniform over the valid pairs


def test_heterologous_respects_the_corner_rule():
    """(1, 1) -> (2, 2) squeezes between the blocked (2, 1) and (1, 2): adjacent under
    "free" only; (2, 0) -> (3, 1) passes one blocked side: illegal under "strict"."""
    blocked = np.zeros((5, 5), bool)
    blocked[1, 2] = blocked[2, 1] = True  # cells 7 = (2, 1) and 11 = (1, 2)
    p1 = [0, 5, 6, 2, 3, 4, 9, 14, 19, 24]
    p2 = [0, 1, 2, 3, 8, 12, 17, 22, 23, 24]
    pairs = {}
    pop = _population([p1, p2], 16)
    for rule in ("free", "no_squeeze", "strict"):
        grid = Grid.create(blocked, corner_rule=rule)
        jtab, valid = _HPAIRS(grid, pop.cells[0], pop.length[0], pop.cells[1], pop.length[1])
        got = _pair_set(jtab, valid)
        assert got == _hetero_pairs(p1, p2, _adjacency(grid))
        pairs[rule] = got
    assert (2, 4) in pairs["free"] and (2, 4) not in pairs["no_squeeze"]
    assert pairs["strict"] <= pairs["no_squeeze"] <= pairs["free"]


# --------------------------------------------------- adaptive probability
@jax.jit
def _adaptive_probabilities():
    """The hand-picked calls of the two tests below, in one program: ``(crossover
    probabilities at t = 0 and 50, the converged one), (pair probabilities: with an
    inactive individual, with equal fitness)``."""
    f = jnp.array([1.0, 0.7, 0.4, 0.2], jnp.float32)
    crossover = (X.adaptive_crossover_probability(f, 1.0, 0.4, 0, 100, 0.3, 0.9),
                 X.adaptive_crossover_probability(f, 1.0, 0.4, 50, 100, 0.3, 0.9),
                 X.adaptive_crossover_probability(0.5, 0.5, 0.5, 100, 100, 0.3, 0.9))
    fit = jnp.array([0.1, 0.5, 0.3, 0.2, 1.0, 0.0, 9.0], jnp.float32)
    active = jnp.array([True] * 6 + [False])
    same = jnp.full((10,), 0.1, jnp.float32)
    pairs = (X.adaptive_pair_probability(fit, 10, 40, 0.2, 0.8, active),
             X.adaptive_pair_probability(same, 0, 10, 0.2, 0.8))
    return crossover, pairs


def test_adaptive_probability_exact_values():
    """AGACD eq. 26-27 on hand-picked inputs (the calls: :func:`_adaptive_probabilities`)."""
    at_0, at_50, converged = _adaptive_probabilities()[0]
    pc = np.asarray(at_0)
    np.testing.assert_allclose(pc, [0.0, 0.9 * 0.3 / 0.6, 0.9, 0.9], rtol=1e-6)
    pc = np.asarray(at_50)
    np.testing.assert_allclose(pc, np.array([0.0, 0.45, 0.9, 0.9]) * np.exp(-0.5), rtol=1e-6)
    # converged population: pc_low, decayed
    pc = converged
    np.testing.assert_allclose(float(pc), 0.3 * np.exp(-1.0), rtol=1e-6)
    assert pc.dtype == jnp.float32


def test_adaptive_pair_probability():
    """(The calls: :func:`_adaptive_probabilities`.)"""
    with_inactive, same = _adaptive_probabilities()[1]
    pc = np.asarray(with_inactive)
    f_max, f_avg = 1.0, 2.1 / 6
    f = np.array([0.5, 0.3, 1.0])
    want = np.where(f >= f_avg, 0.8 * (f_max - f) / (f_max - f_avg), 0.8) * np.exp(-0.25)
    np.testing.assert_allclose(pc, want, rtol=1e-5)
    # equal fitness everywhere: float32 mean == max up to an ulp -> pc_low
    np.testing.assert_allclose(np.asarray(same), 0.2, rtol=1e-6)


def _swap(key, grid, c1, l1, c2, l2):
    return c2, l2, c1, l1, jnp.int32(0)


@jax.jit
def _gated_swaps(grid, pop, scalar_pc):
    """crossover_population(_swap): at the per-pair pc of eq. 26-27 for random fitness
    (keys PRNGKey(9) for the fitness, PRNGKey(0) for the gate) and at each scalar of
    ``scalar_pc`` (PRNGKey(1) for the first, PRNGKey(2) for the others): ``(pc, [(out,
    n_failed) at pc, then at each scalar])``."""
    lifted = X.crossover_population(_swap)
    fitness = jax.random.uniform(jax.random.PRNGKey(9), (pop.size,))
    pc = X.adaptive_pair_probability(fitness, 3, 10, 0.2, 0.9)
    outs = [lifted(jax.random.PRNGKey(0), grid, pop, pc)]
    outs += [lifted(jax.random.PRNGKey(1 if k == 0 else 2), grid, pop, scalar_pc[k])
             for k in range(scalar_pc.shape[0])]
    return pc, outs


def test_crossover_rate_matches_pc():
    """The gate crosses pair k with probability pc[k]: empirical counts at a fixed key."""
    n = 4000
    cells = np.broadcast_to(np.arange(n, dtype=np.int32)[:, None], (n, 4)).copy()
    pop = Population(cells, np.full((n,), 4, np.int32))
    grid = _imga_grid()
    # pc from eq. 26-27, then the scalars 0.35, 0.0 and 1.0
    pc, outs = _gated_swaps(grid, pop, np.array([0.35, 0.0, 1.0], np.float32))
    (out, n_failed), (out_35, _), (out_0, _), (out_1, _) = outs
    swapped = np.asarray(out.cells)[0::2, 0] == np.arange(1, n, 2)
    p = np.asarray(pc, np.float64)
    mean, sd = p.sum(), np.sqrt(np.sum(p * (1 - p)))
    assert abs(swapped.sum() - mean) < 4 * sd and int(n_failed) == 0
    # a scalar pc: binomial test; and it must reject a neighbouring rate
    k = int((np.asarray(out_35.cells)[0::2, 0] == np.arange(1, n, 2)).sum())
    assert scipy.stats.binomtest(k, n // 2, 0.35).pvalue > 1e-4
    assert scipy.stats.binomtest(k, n // 2, 0.45).pvalue < 1e-6
    # pc = 0 and 1
    assert np.array_equal(out_0.cells, pop.cells)
    assert np.array_equal(np.asarray(out_1.cells)[0::2], pop.cells[1::2])


def _always_fail(key, grid, c1, l1, c2, l2):
    return c1, l1, c2, l2, jnp.int32(2)


_GATED_FAILURES = jax.jit(X.crossover_population(_always_fail))


def test_gate_reports_failures_only_when_crossing():
    pop = Population(np.zeros((1000, 4), np.int32), np.full((1000,), 4, np.int32))
    _, n_failed = _GATED_FAILURES(jax.random.PRNGKey(0), _imga_grid(), pop, 0.5)
    assert scipy.stats.binomtest(int(n_failed) // 2, 500, 0.5).pvalue > 1e-4


@jax.jit
def _same_key(grid, c1, l1, c2, l2):
    """Each operator of ``_OPS`` at ``keys[5]`` alone (no vmap) and for all of ``keys =
    split(PRNGKey(7), 8)`` in one vmap batch; and for the keys ``split(PRNGKey(3), 64)``
    column_child and its reference (remove_loops(connect(anchors)) with the documented
    key split and the default bounds for a 5 x 5 map: max_rounds 2 * 3 + 6, queue 2 * 5)."""
    args = (grid, c1, l1, c2, l2)
    keys = jax.random.split(jax.random.PRNGKey(7), 8)
    alone = {name: op(keys[5], *args) for name, op in _OPS.items()}
    batch = {name: jax.vmap(op, in_axes=(0,) + (None,) * 5)(keys, *args)
             for name, op in _OPS.items()}

    def ref(key):
        k_anchor, k_conn = jax.random.split(key)
        anchors, n, ok_a = XC.column_anchors(k_anchor, *args)
        c, m, ok = connect(k_conn, grid, anchors, n, 16, max_rounds=12, queue=10)
        c, m = remove_loops(c, m, 25)
        return c, m, ok & ok_a

    keys = jax.random.split(jax.random.PRNGKey(3), 64)
    want = jax.vmap(ref)(keys)
    got = jax.vmap(lambda k: XC.column_child(k, *args))(keys)
    return alone, batch, want, got


def test_same_key_same_result_in_any_batch_and_column_child_is_connect():
    grid = Grid.create(np.zeros((5, 5), bool), corner_rule="strict")
    pop = _population([[0, 5, 10, 16, 17, 23, 24], [0, 1, 2, 8, 14, 19, 24]], 16)
    alone, batch, want, got = _same_key(grid, pop.cells[0], pop.length[0], pop.cells[1],
                                        pop.length[1])
    # a key gives the same children alone and in a batch of other keys, and other keys
    # other children (for some operator: a different common point, cut or column draw)
    alone, batch = jax.tree.map(np.asarray, (alone, batch))
    differs = False
    for name in _OPS:
        assert all(np.array_equal(x, y[5]) for x, y in zip(alone[name], batch[name])), name
        differs |= any(not np.array_equal(y[5], y[j]) for y in batch[name][:4]
                       for j in range(8))
    assert differs
    # column child = remove_loops(connect(anchors)) (the reference in _same_key)
    assert np.asarray(got[2]).any()
    for w_, g_ in zip(want, got):
        assert np.array_equal(w_, g_)


@jax.jit
def _dtypes(grid, c1, l1, c2, l2):
    """Each operator of ``_OPS`` at PRNGKey(0), and adaptive_crossover_probability on
    Python scalars: one program (per x64 mode)."""
    outs = {name: op(jax.random.PRNGKey(0), grid, c1, l1, c2, l2) for name, op in _OPS.items()}
    return outs, X.adaptive_crossover_probability(0.5, 1.0, 0.4, 1, 10, 0.2, 0.9)


@pytest.mark.parametrize("x64", [False, True])
def test_dtypes(x64):
    grid = _imga_grid()
    pop = _population([[0, 11, 22, 99], [0, 1, 22, 99]], 16)
    args = (grid, pop.cells[0], pop.length[0], pop.cells[1], pop.length[1])
    with jax.enable_x64(x64):
        outs, pc = _dtypes(*args)
        for name, out in outs.items():
            assert [o.dtype for o in out] == [jnp.int32] * 5, name
        assert pc.dtype == jnp.float32


@jax.jit
def _large_map(grid, c1, l1, c2, l2, cells, q):
    """On the 130 x 130 map: heterologous_pairs and heterologous (fitness 1 / nodes) at
    PRNGKey(0); and the lookup of ``q`` in the first 4 of ``cells`` for a map of 16
    cells (a table), of more than TABLE_MAX_CELLS (a sort) and of more than
    CHUNKED_LOOKUP_CELLS (table_lookup)."""
    from jaxga.core.paths import CHUNKED_LOOKUP_CELLS, TABLE_MAX_CELLS

    lookups = tuple(X._position_lookup(cells, 4, n)(q)
                    for n in (16, TABLE_MAX_CELLS + 1, CHUNKED_LOOKUP_CELLS + 1))
    hetero = functools.partial(X.heterologous, fitness_fn=_len_fitness)
    return (lookups, X.heterologous_pairs(grid, c1, l1, c2, l2),
            hetero(jax.random.PRNGKey(0), grid, c1, l1, c2, l2))


def test_large_map_code_paths():
    """Maps above TABLE_MAX_CELLS use a sort for cell lookups and move_legal for the step
    masks: same results as the table variants (the hand-made pair, moved onto 130 x 130).
    The calls: :func:`_large_map`."""
    from jaxga.core.paths import TABLE_MAX_CELLS

    w = 130
    assert w * w > TABLE_MAX_CELLS
    grid = Grid.create(np.zeros((w, w), bool), start=(0, 0), goal=(4, 4), corner_rule="strict")

    def move(path):
        return [(p // 5) * w + p % 5 for p in path]

    p1 = move([0, 5, 11, 17, 18, 23, 24])
    p2 = move([0, 1, 6, 12, 13, 19, 24])
    pop = _population([p1, p2], 16)
    args = (grid, pop.cells[0], pop.length[0], pop.cells[1], pop.length[1])
    cells = np.array([5, 9, 2, 7, 7, 7], np.int32)
    q = np.array([[2, 7, 3], [9, 5, -1]], np.int32)
    (small, big, chunked), (jtab, valid), (c1, l1, c2, l2, _) = _large_map(*args, cells, q)
    np.testing.assert_array_equal(small, big)
    np.testing.assert_array_equal(small, chunked)
    np.testing.assert_array_equal(small, [[2, 3, -1], [1, 0, -1]])

    pairs = _pair_set(jtab, valid)
    assert pairs == {(0, 1), (3, 3), (4, 5)}
    assert np.asarray(c1)[: int(l1)].tolist() in (move([0, 6, 12, 13, 19, 24]), p1,
                                                  move([0, 5, 11, 17, 18, 24]))


KTH_LENGTHS = (1, 32, 33, 160, 400)
KTH_DENSITIES = (0.0, 0.03, 0.4, 1.0)
_KTH = jax.jit(lambda masks, r: {n: jax.vmap(J.kth_true)(masks[n], r[n]) for n in masks})


def _kth_cases(n):
    """For each density: 300 random masks of length ``n`` and ranks (seed ``n``)."""
    rng = np.random.default_rng(n)
    cases = []
    for p in KTH_DENSITIES:
        mask = rng.random((300, n)) < p
        r = rng.integers(0, n + 2, 300)
        cases.append((mask, r))
    return cases


@pytest.mark.parametrize("n", KTH_LENGTHS)
def test_kth_true_is_the_rth_true_index_or_zero(n):
    """The two-level search of long masks (rows of 16) gives NumPy's r-th True index,
    and 0 when the mask has r or fewer Trues, as the one-level prefix search does. (One
    program for every length: each test runs all of them, and checks its own.)"""
    cases = {m: _kth_cases(m) for m in KTH_LENGTHS}
    got = _KTH({m: np.concatenate([mask for mask, _ in c]) for m, c in cases.items()},
               {m: np.concatenate([r for _, r in c]).astype(np.int32) for m, c in cases.items()})
    got = np.asarray(got[n]).reshape(len(KTH_DENSITIES), 300)
    for (mask, r), got_p in zip(cases[n], got):
        want = [np.flatnonzero(m)[k] if k < m.sum() else 0 for m, k in zip(mask, r)]
        np.testing.assert_array_equal(got_p, want)


_JOINS = jax.jit(jax.vmap(lambda c1, l1, c2, l2, cut, start: (
    J.join(c2, cut, X._position_lookup(c1, l1, None)(c2), c1, l1, start),
    J.join_reverse(c2, cut, c1, l1, start, X._position_lookup(c2, l2, None)(c1)))))


@settings(max_examples=30)
@given(grids_and_parents(n=8), st.integers(0, 2**30))
def test_second_child_from_one_lookup_equals_the_two_lookup_join(gp, seed):
    """common_point's second child comes from the lookup of parent 1's cells in parent 2
    (``join_reverse``): for loop-free parents it equals ``join`` with the lookup of
    parent 2's cells in parent 1 that it replaces (cells, length, fit and junction), at
    a common cell of the two parents (as common_point calls it) and at any head cut below
    parent 2's length and any tail start."""
    _, pop = gp
    rng = np.random.default_rng(seed)
    c1, l1, c2, l2 = _pairs_of(Population(np.asarray(pop.cells), np.asarray(pop.length)))
    at_common = []
    for a, n1, b, n2 in zip(c1, l1, c2, l2):
        pairs = [(j, i) for i in range(n1) for j in range(n2) if a[i] == b[j]]
        at_common.append(pairs[rng.integers(len(pairs))] if pairs else (0, 0))
    for cut, start in (np.array(at_common).T, (rng.integers(0, l2), rng.integers(0, l1))):
        two, one = _JOINS(c1, l1, c2, l2, np.asarray(cut, np.int32),
                          np.asarray(start, np.int32))
        for a, b in zip(two, one):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_second_child_loop_cut_example():
    """Head 0-7-3-8-9 of parent 2 (cut before its cell 2) + tail 2-3-4-5 of parent 1: the
    head's cell 3 is in the tail, so the child is 0-7 + 3-4-5 (the loop 3-8-9-2-3 cut),
    by both joins. The pair four times at capacity CAP (the shapes of the test above)."""
    pop = _population([[0, 1, 2, 3, 4, 5], [0, 7, 3, 8, 9, 2, 5]] * 4)
    c1, l1, c2, l2 = _pairs_of(pop)
    four = np.full(4, 1, np.int32)
    for joined in _JOINS(c1, l1, c2, l2, 5 * four, 2 * four):
        cells, length, ok, left, right = (np.asarray(v) for v in joined)
        for k in range(4):
            assert list(cells[k, :int(length[k])]) == [0, 7, 3, 4, 5]
            assert bool(ok[k]) and (int(left[k]), int(right[k])) == (7, 3)
