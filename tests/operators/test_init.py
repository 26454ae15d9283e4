"""Initialisers: Zhu & Pan Table 1, step distributions, properties, redraws.

Maps have row y = 0 at the bottom and cells p = y * W + x (0-based), as in the papers.
Every initialiser is run under ``jax.jit`` + ``jax.vmap``; each jitted function is built
once at module level with fixed shapes, and computes every case of its map at once (no
``jax.jit`` in a test body, no eager ``jnp``: inputs are NumPy).
"""

from __future__ import annotations

import contextlib
import functools
import os
import subprocess
import sys
import textwrap
import unittest.mock

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from jaxga import Grid, NoPathError, ParameterError
from jaxga.maps import legal_moves, random_map
from jaxga.operators import init as I
from jaxga.operators import registry
from jaxga.operators.guide import with_front_fields
from jaxga.operators.init import CLEARANCE_WEIGHTS
from jaxga.operators.init import walks as init_walks
from tests.plain_lifts import initialise
from tests.strategies import CAP, SIZE, check_paths, grids

# the initialisers' properties and references in depth (contracts: test_registry)


def fielded(grid):
    """``grid`` with every field an initialiser may read: the exact distance fields and a
    front's (the clearance walk's; a band of one cell)."""
    return with_front_fields(grid, CLEARANCE_WEIGHTS, 1.0)
pytestmark = pytest.mark.slow

NAMES = registry.names("init")
WALKS = ("random_walk", "greedy_random_target", "directional")  # fail = goal not reached


# ------------------------------------------------------------------------ helpers
def table1_grid(rule: str = "free") -> Grid:
    """Zhu & Pan Figure 3: 5 x 5, start 0, target 24, cells 8, 16 and 17 blocked."""
    b = np.zeros((5, 5), bool)
    for c in (8, 16, 17):
        b[c // 5, c % 5] = True
    return Grid.create(b, start=(0, 0), goal=(4, 4), corner_rule=rule)


# ---------------------------------------------------------- Zhu & Pan Table 1
# (current cell, cells already on the path) of Figure 3a, 3b, 3c; target 24.
FIG3 = {
    "3a": (12, (0, 1, 7), {6: 0.0668, 11: 0.0786, 13: 0.2535, 18: 0.6011}),
    "3b": (13, (0, 1, 7), {9: 0.0546, 12: 0.058, 14: 0.1639, 18: 0.2318, 19: 0.4917}),
    "3c": (7, (0, 1, 6, 11), {2: 0.0889, 3: 0.0964, 12: 0.2812, 13: 0.5335}),
}
# Table 1, column "Literature [28]'s Method" (plain 1/d roulette, factors (1, 1)).
FIG3_CGA = {
    "3a": {6: 0.1414, 11: 0.1664, 13: 0.2682, 18: 0.4243},
    "3b": {9: 0.1152, 12: 0.1222, 14: 0.1728, 18: 0.2443, 19: 0.3455},
    "3c": {2: 0.1765, 3: 0.1914, 12: 0.2791, 13: 0.353},
}


FACTORS = {"paper": (3.0, 2.0), "cga": (1.0, 1.0)}


@jax.jit
def _table1(grid):
    """On the Table 1 map: directional_probabilities of Figures 3a-3c under both factor
    pairs, ``{fig: {name: (cells, prob)}}``, and the edge cases of
    :func:`test_directional_probabilities_edge_cases`: one program."""
    figs = {fig: {name: I.directional_probabilities(grid, cur, 24,
                                                    jnp.array(visited, jnp.int32), factors)
                  for name, factors in FACTORS.items()}
            for fig, (cur, visited, _) in FIG3.items()}
    mask = np.zeros(25, bool)
    mask[[0, 1, 7]] = True
    nbr, prob = I.directional_probabilities(grid, 18, 24)
    _, none = I.directional_probabilities(grid, 9, 24, jnp.array([3, 4, 13, 14]))
    edges = {
        "adjacent": (nbr, prob, jnp.sum(prob)),
        "no_candidate": jnp.sum(none),
        "mask": I.directional_probabilities(grid, 12, 24, jnp.asarray(mask))[1],
        "list": I.directional_probabilities(grid, 12, 24, jnp.array([0, 1, 7, -1, -1]))[1],
        "mask2d": I.directional_probabilities(grid, 12, 24, jnp.asarray(mask.reshape(5, 5)))[1],
    }
    return figs, edges


def _probs(fig, factors=(3.0, 2.0)):
    name = next(k for k, v in FACTORS.items() if v == factors)
    nbr, prob = _table1(table1_grid())[0][fig][name]
    return {int(c): float(q) for c, q in zip(np.asarray(nbr), np.asarray(prob)) if q > 0}


@pytest.mark.parametrize("fig", sorted(FIG3))
def test_zhu_table1_probabilities(fig):
    """Zhu & Pan Table 1, "Paper's Method" column, to 1e-4 (the paper prints 4 digits)."""
    got = _probs(fig)
    want = FIG3[fig][2]
    assert sorted(got) == sorted(want), "candidate list (Table 1 'Grid' column)"
    for c, p in want.items():
        assert abs(got[c] - p) <= 1e-4, (fig, c, got[c], p)
    assert abs(sum(got.values()) - 1) < 1e-6


@pytest.mark.parametrize("fig", sorted(FIG3))
def test_zhu_table1_cga_column(fig):
    """factors (1, 1) is the 1/d roulette of literature [28] (Table 1's middle column).

    One printed value is off in the 4th digit: 3a / cell 18 is 0.7071 / 1.6674 = 0.4241,
    printed 0.4243 (that column sums to 1.0003); it is checked to 3e-4, the rest to 1e-4.
    """
    got = _probs(fig, (1.0, 1.0))
    for c, p in FIG3_CGA[fig].items():
        tol = 3e-4 if (fig, c) == ("3a", 18) else 1e-4
        assert abs(got[c] - p) <= tol, (fig, c, got[c], p)


def test_directional_probabilities_edge_cases():
    grid = table1_grid()
    edges = _table1(grid)[1]  # the calls, in _table1
    # Target adjacent and legal: the walk steps onto it with probability 1.
    nbr, prob, total = edges["adjacent"]
    assert dict(zip(np.asarray(nbr).tolist(), np.asarray(prob).tolist()))[24] == 1.0
    assert float(total) == 1.0
    # No candidate: all zero. Cell 9 = (4, 1): neighbours 3, 4, 8 (blocked), 13, 14.
    assert float(edges["no_candidate"]) == 0.0
    # A bool mask and a cell list are the same exclusion.
    a, b, c = edges["mask"], edges["list"], edges["mask2d"]
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    np.testing.assert_array_equal(np.asarray(a), np.asarray(c))
    with pytest.raises(ParameterError):  # raised while tracing: nothing compiled
        jax.eval_shape(I.exclusion_mask, grid, np.zeros(7, bool))


# ------------------------------------------------------- step distributions
N_DRAWS = 20000


TABLE1_WALKS = ("directional", "cga", "uniform")
EXCLUDED = 4
"""The excluded cells of the step tests, padded with -1 to this many (ignored entries)."""


@functools.partial(jax.jit, static_argnames=("kinds",))
def _first_steps(seed, grid, source, target, exclude, kinds=TABLE1_WALKS):
    """The first move of N_DRAWS walks of each kind (capacity 2 = one step), from the
    keys ``split(PRNGKey(seed), N_DRAWS)``: ``{kind: (first cells, lengths)}``."""
    keys = jax.random.split(jax.random.PRNGKey(seed), N_DRAWS)
    walks = {
        "directional": lambda k: I.directional_walk(k, grid, source, target, 2, exclude),
        "cga": lambda k: I.directional_walk(k, grid, source, target, 2, exclude, (1.0, 1.0)),
        "uniform": lambda k: I.uniform_walk(k, grid, source, target, 2, exclude),
        "greedy": lambda k: I.greedy_walk(k, grid, source, target, 2, max_steps=1),
    }
    out = {}
    for kind in kinds:
        cells, length, _ = jax.vmap(walks[kind])(keys)
        out[kind] = cells[:, 1], length
    return out


def _excluded(cells) -> np.ndarray:
    """``cells`` as int32[EXCLUDED], padded with -1."""
    return np.array(list(cells) + [-1] * (EXCLUDED - len(cells)), np.int32)


def _chi2(first, probs: dict[int, float]) -> float:
    first = np.asarray(first)
    assert set(np.unique(first).tolist()) <= set(probs), "a move outside the candidates"
    cells = sorted(probs)
    obs = np.array([(first == c).sum() for c in cells])
    exp = np.array([probs[c] for c in cells])
    return stats.chisquare(obs, exp / exp.sum() * obs.sum()).pvalue


@pytest.mark.parametrize("fig", ["3a", "3c"])
def test_directional_step_frequencies(fig):
    """Empirical choices of the jitted, vmapped walk match Table 1 (chi-square), and a
    wrong rule (the unadjusted 1/d roulette) is rejected by the same test."""
    cur, visited, want = FIG3[fig]
    steps = _first_steps(2024, table1_grid(), cur, 24, _excluded(visited))
    first, length = steps["directional"]
    assert (np.asarray(length) == 2).all()
    exact = _probs(fig)
    assert _chi2(first, exact) > 1e-3
    assert _chi2(first, _probs(fig, (1.0, 1.0))) < 1e-9
    # And the CGA variant follows its own column (the same keys).
    first_cga, _ = steps["cga"]
    assert _chi2(first_cga, _probs(fig, (1.0, 1.0))) > 1e-3
    assert _chi2(first_cga, exact) < 1e-9


def test_uniform_walk_step_is_uniform():
    cur, visited, want = FIG3["3b"]
    first, _ = _first_steps(7, table1_grid(), cur, 24, _excluded(visited))["uniform"]
    uniform = {c: 1.0 for c in want}
    assert _chi2(first, uniform) > 1e-3
    assert _chi2(first, FIG3["3b"][2]) < 1e-9


def _greedy_step_probs(grid: Grid, cur: int, target: int, p_goal: float = 0.5,
                       split_ties: bool = True):
    """AGACD 4.3 by enumeration: target w.p. 1/2, else each free cell w.p. 1/(2 n_free);
    nearest legal neighbour, ties split evenly (``split_ties=False``: a wrong rule that
    always takes the first tied neighbour in direction order)."""
    b = grid.blocked_np()
    h, w = b.shape
    legal = legal_moves(b, grid.corner_rule)
    from jaxga.core.grid import DIRECTIONS

    nbrs = [(cur % w + dx, cur // w + dy) for d, (dx, dy) in enumerate(DIRECTIONS.tolist())
            if legal[d, cur // w, cur % w]]
    free = np.flatnonzero(~b.reshape(-1))
    out: dict[int, float] = {}
    for t, wt in [(target, p_goal)] + [(int(f), (1 - p_goal) / len(free)) for f in free]:
        d2 = [(x - t % w) ** 2 + (y - t // w) ** 2 for x, y in nbrs]
        best = [n for n, d in zip(nbrs, d2) if d == min(d2)]
        for k, (x, y) in enumerate(best):
            share = wt / len(best) if split_ties else wt * (k == 0)
            out[y * w + x] = out.get(y * w + x, 0.0) + share
    return out


@pytest.mark.parametrize("rule", ["free", "strict"])
def test_greedy_step_distribution(rule):
    """AGACD's step: the empirical first moves match the exact enumeration."""
    b = np.zeros((6, 6), bool)
    for x, y in [(3, 3), (1, 3), (3, 1), (4, 2)]:
        b[y, x] = True
    grid = Grid.create(b, start=(0, 0), goal=(5, 5), corner_rule=rule)
    cur = 2 * 6 + 2  # (2, 2)
    first, _ = _first_steps(11, grid, cur, 35, _excluded([]), kinds=("greedy",))["greedy"]
    exact = _greedy_step_probs(grid, cur, 35)
    assert _chi2(first, exact) > 1e-3
    # Wrong rules are rejected by the same test: a deterministic tie-break (the first
    # tied neighbour) and a walk that always heads for the target.
    def floored(probs):  # every candidate kept, impossible ones at a tiny probability
        return {c: max(probs.get(c, 0.0), 1e-12) for c in exact}

    assert _chi2(first, floored(_greedy_step_probs(grid, cur, 35, split_ties=False))) < 1e-9
    assert _chi2(first, floored(_greedy_step_probs(grid, cur, 35, p_goal=1.0))) < 1e-9


# ---------------------------------------------------------- MPMGA anchors
@jax.jit
def _many_anchors(grid):
    """intermittent_anchors for the keys ``split(PRNGKey(0), 4000)``."""
    keys = jax.random.split(jax.random.PRNGKey(0), 4000)
    return jax.vmap(lambda k: I.intermittent_anchors(k, grid))(keys)


@jax.jit
def _anchors(key, grid):
    """intermittent_anchors along rows and along the major axis: ``{axis: (anchors, n)}``."""
    return {axis: I.intermittent_anchors(key, grid, axis) for axis in ("rows", "major")}


def test_intermittent_anchors_one_free_cell_per_row():
    rng = np.random.default_rng(3)
    b = rng.random((12, 9)) < 0.3
    b[0, 0] = b[11, 8] = False
    b[5, :] = True  # a fully blocked row is skipped
    grid = Grid.create(b, corner_rule="free")
    anchors, n = _many_anchors(grid)
    anchors, n = np.asarray(anchors), np.asarray(n)
    assert anchors.shape == (4000, 13) and (n == 2 + 9).all()  # rows 1..10 minus row 5
    rows = anchors[:, : n[0]] // 9
    assert (rows == np.array([0, 1, 2, 3, 4, 6, 7, 8, 9, 10, 11])).all()
    assert (anchors[:, 0] == 0).all() and (anchors[:, n[0] - 1] == 107).all()
    assert not b.reshape(-1)[anchors[:, : n[0]]].any()
    assert (anchors[:, n[0]:] == 107).all()
    # Uniform over the free cells of row 3.
    free3 = np.flatnonzero(~b[3])
    obs = np.array([(anchors[:, 3] % 9 == x).sum() for x in free3])
    assert stats.chisquare(obs).pvalue > 1e-3


def test_intermittent_anchors_orientation_and_same_row():
    b = np.zeros((6, 8), bool)
    # Goal below the start: rows in descending order.
    key = jax.random.PRNGKey(1)
    grid = Grid.create(b, start=(1, 5), goal=(6, 0), corner_rule="free")
    anchors, n = _anchors(key, grid)["rows"]
    rows = np.asarray(anchors)[: int(n)] // 8
    assert rows.tolist() == [5, 4, 3, 2, 1, 0]
    # Same row: falls back to the columns between (x = 2..5), in order.
    grid = Grid.create(b, start=(1, 2), goal=(6, 2), corner_rule="free")
    anchors, n = _anchors(key, grid)["rows"]
    a = np.asarray(anchors)[: int(n)]
    assert (a % 8).tolist() == [1, 2, 3, 4, 5, 6]
    # "major" picks the longer span; "columns" uses columns.
    grid = Grid.create(b, start=(0, 0), goal=(7, 2), corner_rule="free")
    out = _anchors(key, grid)
    a, n = out["major"]
    assert (np.asarray(a)[: int(n)] % 8).tolist() == list(range(8))
    a, n = out["rows"]
    assert (np.asarray(a)[: int(n)] // 8).tolist() == [0, 1, 2]
    with pytest.raises(ParameterError):
        I.intermittent_anchors(jax.random.PRNGKey(1), grid, "diagonal")


# ---------------------------------------------------------- property tests
N_KEYS = 8


@jax.jit
def _all_initialisers_guided(keys, grid):
    return {name: jax.vmap(lambda k, f=f: f(k, grid, CAP))(keys)
            for name, f in ((op.name, op.fn) for op in registry.operators("init"))}


def _all_initialisers(keys, grid):
    """Every initialiser of the registry (field_walk reads the grid's distance fields, the
    clearance walk a front's fields too)."""
    return _all_initialisers_guided(keys, fielded(grid))


@settings(max_examples=15)
@given(grids(), st.integers(0, 2**31 - 1))
def test_initialisers_properties(grid, seed):
    """Every ok individual: start -> goal, continuous under the corner rule, loop-free,
    within capacity, padded. A walk that fails never ends at the goal (failure is
    reported, not hidden)."""
    keys = jax.random.split(jax.random.PRNGKey(seed), N_KEYS)
    out = _all_initialisers(keys, grid)
    for name in NAMES:
        cells, length, ok = (np.asarray(a) for a in out[name])
        assert cells.dtype == np.int32 and length.dtype == np.int32 and ok.dtype == bool
        check_paths(grid, cells, length, ok)
        if name in WALKS:
            last = cells[np.arange(N_KEYS), np.clip(length - 1, 0, CAP - 1)]
            assert not ((last == int(grid.goal)) & ~ok).any(), name


@jax.jit
def _walks_between(keys, grid, src, dst, excl):
    """The walk primitives between two cells; ``excl`` is int32[CAP] (-1 = padding). The
    directional walk gets it as a bool mask, the uniform walks as a cell list."""
    mask = I.exclusion_mask(grid, excl)
    return {
        "directional": jax.vmap(lambda k: I.directional_walk(k, grid, src, dst, CAP, mask))(keys),
        "uniform": jax.vmap(lambda k: I.uniform_walk(k, grid, src, dst, CAP, excl))(keys),
        "uniform_adj": jax.vmap(
            lambda k: I.uniform_walk(k, grid, src, dst, CAP, excl, stop_adjacent=True))(keys),
        "greedy": jax.vmap(lambda k: I.greedy_walk(k, grid, src, dst, CAP))(keys),
    }


@settings(max_examples=15)
@given(grids(), st.integers(0, 2**31 - 1))
def test_walks_between_cells_avoid_exclusion(grid, seed):
    """The walk primitives (used by range mutation) from a random free cell to another,
    with a random set of excluded cells: ok paths are valid and avoid the exclusion."""
    rng = np.random.default_rng(seed)
    free = np.flatnonzero(~grid.blocked_np().reshape(-1))
    src, dst = (int(c) for c in rng.choice(free, 2))
    excl = np.full(CAP, -1, np.int32)
    excl[:12] = rng.choice(SIZE * SIZE, 12)
    excl[:12][rng.random(12) < 0.3] = -1  # padding entries are ignored
    keys = jax.random.split(jax.random.PRNGKey(seed % 1000), N_KEYS)
    out = _walks_between(keys, grid, src, dst, excl)
    for name, (cells, length, ok) in out.items():
        ex = () if name == "greedy" else excl[excl >= 0]
        check_paths(grid, cells, length, ok, source=src, target=dst, exclude=ex)
        if src == dst:
            assert np.asarray(ok).all() and (np.asarray(length) == 1).all()


def test_every_initialiser_and_walk_succeeds_on_an_open_map():
    """The two property tests above check the paths reported ok; on an obstacle-free map
    every initialiser and walk primitive also reports some (one that always failed
    would pass them). The same compiled functions, 5 x 8 keys."""
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), (0, 0), (SIZE - 1, SIZE - 1),
                       corner_rule="free")
    goal = SIZE * SIZE - 1
    checked = dict.fromkeys([*NAMES, "directional", "uniform", "uniform_adj", "greedy"], 0)
    no_exclusion = np.full((CAP,), -1, np.int32)
    for seed in range(5):
        keys = jax.random.split(jax.random.PRNGKey(seed), N_KEYS)
        for name, (cells, length, ok) in _all_initialisers(keys, grid).items():
            checked[name] += check_paths(grid, cells, length, ok)
        for name, (cells, length, ok) in _walks_between(keys, grid, 0, goal,
                                                         no_exclusion).items():
            checked[name] += check_paths(grid, cells, length, ok, source=0, target=goal)
    assert min(checked.values()) > 0, checked


@jax.jit
def _alone_and_batched(keys, grid, src, dst):
    """``{walk: (alone, batched)}``: the uniform and directional walks of capacity 48 for
    every key, one at a time (``lax.map``: a loop, no ``vmap``) and as one ``vmap`` batch."""
    out = {}
    for walk in ("uniform_walk", "directional_walk"):
        def one(k, walk=walk):
            return getattr(I, walk)(k, grid, src, dst, 48)

        out[walk] = jax.lax.map(one, keys), jax.vmap(one)(keys)
    return out


@pytest.mark.parametrize("walk", ["uniform_walk", "directional_walk"])
def test_batched_walks_equal_walks_one_at_a_time(walk):
    """Under vmap the walk's step loop compacts its unfinished lanes (jaxga._batching.lanes): every
    walk of a batch equals the same walk run alone, cells past its length (copies of
    its last cell) included."""
    grid = random_map(12, 12, 0.2, seed=4)
    free = np.flatnonzero(~grid.blocked_np().reshape(-1))
    src, dst = int(free[0]), int(free[-1])
    keys = jax.random.split(jax.random.PRNGKey(7), 64)
    alone, batched = _alone_and_batched(keys, grid, src, dst)[walk]
    cells, length, ok = (np.asarray(v) for v in batched)
    alone_c, alone_l, alone_ok = (np.asarray(v) for v in alone)
    lengths = length
    assert lengths.min() < 8 and lengths.max() > 30  # walks of very different lengths
    for i in range(keys.shape[0]):
        c1, l1, ok1 = alone_c[i], alone_l[i], alone_ok[i]
        assert np.array_equal(c1, cells[i])
        assert int(l1) == lengths[i] and bool(ok1) == bool(ok[i])
        assert (c1[lengths[i]:] == c1[lengths[i] - 1]).all()


def test_range_mutation_style_regrowth_keeps_the_path_simple():
    """Regrow the stretch between nodes i and j of a path with the rest excluded: the
    spliced path is continuous and loop-free."""
    grid = random_map(SIZE, SIZE, 0.2, 5, corner_rule="strict")
    out = _all_initialisers(jax.random.split(jax.random.PRNGKey(3), N_KEYS), grid)
    cells, length, ok = (np.asarray(a) for a in out["directional"])
    k = int(np.argmax(np.where(ok, length, 0)))
    cells, n = cells[k], int(length[k])
    assert ok[k] and n > 6
    i, j = 1, n - 2
    idx = np.arange(CAP)
    exclude = np.where((idx < i) | ((idx > j) & (idx < n)), cells, -1).astype(np.int32)
    keys = jax.random.split(jax.random.PRNGKey(9), N_KEYS)
    out = _walks_between(keys, grid, int(cells[i]), int(cells[j]), exclude)
    seg_c, seg_l, seg_ok = (np.asarray(a) for a in out["directional"])
    assert seg_ok.any()
    p = cells[:n].tolist()
    for c, ln, good in zip(seg_c, seg_l, seg_ok):
        if good:
            new = p[:i] + c[:ln].tolist() + p[j + 1:]
            full = np.asarray(new + [new[-1]] * (CAP - len(new)), np.int32)
            assert check_paths(grid, full[None], np.array([len(new)]), np.array([True])) == 1


# ------------------------------------------------------------- failures
def _walled(rule="free"):
    b = np.zeros((SIZE, SIZE), bool)
    b[4, :] = True  # a full wall: the goal is unreachable
    return Grid.create(b, corner_rule=rule)


def test_unreachable_goal_every_initialiser_fails():
    grid = _walled()
    out = _all_initialisers(jax.random.split(jax.random.PRNGKey(0), N_KEYS), grid)
    for name in NAMES:
        assert not np.asarray(out[name][2]).any(), name


@jax.jit
def _small_capacity(key, grid):
    return [registry.initialiser(name)(key, grid, SIZE - 1)[2] for name in NAMES]


def test_capacity_too_small_fails():
    """An open map needs SIZE cells from corner to corner: capacity SIZE - 1 must fail,
    for every initialiser (a failure, not an error: MPMGA's intermittent path, which has
    one anchor per row, too)."""
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), corner_rule="free")
    assert not np.asarray(_small_capacity(jax.random.PRNGKey(0), fielded(grid))).any()
    with pytest.raises(ParameterError):
        registry.initialiser("nope")


def test_open_map_median_methods_always_succeed():
    """No obstacle: every median is free, so IMGA and MPMGA never fail."""
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), corner_rule="free")
    out = _all_initialisers(jax.random.split(jax.random.PRNGKey(1), N_KEYS), grid)
    for name in ("median_insertion", "intermittent_connect", "directional",
                 "greedy_random_target", "field_walk"):
        assert np.asarray(out[name][2]).all(), name
    for name in NAMES:
        check_paths(grid, *out[name])


# ------------------------------------------------------------- population
P = 24


def test_initialise_reports_total_failure():
    pop, st_ = initialise(jax.random.PRNGKey(0), _walled(), I.directional, P, CAP, max_tries=3)
    assert int(st_.n_failed) == P and not np.asarray(st_.valid).any()
    assert int(st_.successes) == 0 and float(st_.success_rate) == 0.0
    assert int(st_.attempts) == 3 * P
    assert (np.asarray(pop.length) == 1).all()  # [start]: not a path to the goal
    with pytest.raises(NoPathError):
        st_.raise_if_failed(allow_partial=True)


def test_initialise_determinism_and_validity():
    grid = random_map(SIZE, SIZE, 0.25, 17, corner_rule="no_squeeze")
    a, sa = initialise(jax.random.PRNGKey(5), grid, I.directional, P, CAP)
    b, sb = initialise(jax.random.PRNGKey(5), grid, I.directional, P, CAP)
    c, _ = initialise(jax.random.PRNGKey(6), grid, I.directional, P, CAP)
    np.testing.assert_array_equal(np.asarray(a.cells), np.asarray(b.cells))
    np.testing.assert_array_equal(np.asarray(a.length), np.asarray(b.length))
    assert int(sa.attempts) == int(sb.attempts)
    assert not np.array_equal(np.asarray(a.cells), np.asarray(c.cells))
    assert int(sa.n_failed) == 0 and np.asarray(sa.valid).all()
    assert check_paths(grid, a.cells, a.length, sa.valid) == P
    sa.raise_if_failed()
    # Individuals differ from each other (independent keys).
    assert len({tuple(r) for r in np.asarray(a.cells).tolist()}) > P // 2


@jax.jit
def _random_walks_ok(grid):
    """Whether each of 4000 single random_walk attempts (keys ``split(PRNGKey(99), 4000)``)
    succeeds."""
    keys = jax.random.split(jax.random.PRNGKey(99), 4000)
    return jax.vmap(lambda k: I.random_walk(k, grid, CAP))(keys)[2]


def test_initialise_redraws_and_reports_the_success_rate():
    """random_walk fails most single attempts here; the redraw fills the population and
    the reported per-attempt rate agrees with a direct estimate (binomial bounds)."""
    grid = random_map(SIZE, SIZE, 0.3, 23, corner_rule="free")
    ok = _random_walks_ok(grid)
    p = float(np.mean(np.asarray(ok)))
    assert 0.02 < p < 0.6, p  # single attempts often fail on this map
    pop, st_ = initialise(jax.random.PRNGKey(1), grid, I.random_walk, P, CAP, max_tries=200)
    assert int(st_.n_failed) == 0 and int(st_.rounds) > 1
    assert check_paths(grid, pop.cells, pop.length, st_.valid) == P
    att, succ = int(st_.attempts), int(st_.successes)
    assert att == int(st_.rounds) * P and succ >= P
    assert abs(float(st_.success_rate) - succ / att) < 1e-6
    lo, hi = stats.binom.ppf([1e-6, 1 - 1e-6], att, p)
    assert lo <= succ <= hi, (succ, att, p)
    # Budget too small: the shortfall is reported and flagged, never hidden.
    pop, st_ = initialise(jax.random.PRNGKey(1), grid, I.random_walk, P, CAP, max_tries=1)
    nf = int(st_.n_failed)
    valid = np.asarray(st_.valid)
    assert nf == P - valid.sum() and 0 < nf < P
    assert check_paths(grid, pop.cells, pop.length, valid) == P - nf
    # Empty slots hold copies of valid individuals (so a GA can run), flagged invalid.
    assert check_paths(grid, pop.cells, pop.length, np.ones(P, bool)) == P
    st_.raise_if_failed(allow_partial=True)
    with pytest.raises(NoPathError):
        st_.raise_if_failed()


_THREE = np.array([[0, 1, 2, 5, 8], [0, 3, 6, 7, 8], [0, 4, 8, 8, 8]], np.int32)


def _one_of_three(key, grid, capacity):
    """A toy initialiser on the open 3 x 3 map: one of three fixed paths."""
    i = jax.random.randint(key, (), 0, 3)
    cells = jnp.asarray(_THREE)[i]
    cells = jnp.concatenate([cells, jnp.full((capacity - 5,), 8, jnp.int32)])
    return cells, jnp.where(i == 2, 3, 5).astype(jnp.int32), jnp.bool_(True)


def _liar(key, grid, capacity):
    cells, n, ok = I.directional(key, grid, capacity)
    return cells.at[1].set(grid.goal), n, ok  # breaks continuity / loop-freedom


def test_initialise_unique_and_verify():
    """unique=True gives distinct paths (IMGA's "nonrepeating chromosomes"); an
    initialiser that claims ok for a broken path is caught by verify."""
    grid = Grid.create(np.zeros((3, 3), bool), corner_rule="free")
    pop, st_ = initialise(jax.random.PRNGKey(0), grid, _one_of_three, 3, 9, unique=True)
    rows = {tuple(r[:n]) for r, n in zip(np.asarray(pop.cells).tolist(),
                                         np.asarray(pop.length).tolist())}
    assert int(st_.n_failed) == 0 and len(rows) == 3 and int(st_.duplicates) > 0
    assert int(st_.successes) == int(st_.attempts)  # duplicates are not failures
    pop, _ = initialise(jax.random.PRNGKey(0), grid, _one_of_three, 6, 9)
    assert len({tuple(r) for r in np.asarray(pop.cells).tolist()}) <= 3
    _, st_ = initialise(jax.random.PRNGKey(0), grid, _liar, 4, 9, max_tries=2)
    assert int(st_.successes) == 0 and int(st_.n_failed) == 4


def test_x64_mode_keeps_int32():
    """Under JAX_ENABLE_X64=1 every output stays int32 / float32 (jitted, as in use)."""
    code = textwrap.dedent("""
        import sys, jax, numpy as np
        jax.config.update("jax_compilation_cache_dir", sys.argv[1])
        from jaxga.operators import registry
        from jaxga.operators import init as I
        from jaxga.operators.guide import with_guide
        from jaxga.maps import random_map
        g = with_guide(random_map(10, 10, 0.2, 3, corner_rule="free"))
        names = ("directional", "greedy_random_target", "intermittent_connect", "field_walk")
        f = jax.jit(lambda k: [registry.initialiser(n)(k, g, 64) for n in names])
        for name, (c, n, ok) in zip(names, f(jax.random.PRNGKey(0))):
            assert c.dtype == np.int32 and n.dtype == np.int32 and ok.dtype == bool, name
        pop, st = jax.jit(I.initialise_population, static_argnums=(2, 3, 4))(
            jax.random.PRNGKey(0), g, I.directional, 4, 64)
        assert pop.cells.dtype == np.int32 and pop.length.dtype == np.int32
        assert st.success_rate.dtype == np.float32 and st.attempts.dtype == np.int32
        assert int(st.n_failed) == 0
        print("ok")
    """)
    env = dict(os.environ, JAX_ENABLE_X64="1", JAX_PLATFORMS="cpu")
    cache = str(jax.config.jax_compilation_cache_dir or "")
    res = subprocess.run([sys.executable, "-c", code, cache], env=env, capture_output=True,
                         text=True, timeout=300,
                         cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    assert res.returncode == 0 and "ok" in res.stdout, res.stderr[-2000:]


LARGE_CAP = 32


def _large_map_walks(table: bool):
    """The uniform and directional walks of capacity LARGE_CAP for each key, ``{walk:
    (cells, length, ok)}``; with ``table`` traced with the map-sized visited table forced
    (``VISITED_TABLE_CELLS_PER_NODE``, read by :mod:`jaxga.operators.init.walks` when the
    walk is traced, raised while this function is traced)."""

    def run(keys, grid, src, dst, excl):
        force = (unittest.mock.patch.object(init_walks, "VISITED_TABLE_CELLS_PER_NODE", 10**9)
                 if table else contextlib.nullcontext())
        with force:
            return {walk: jax.vmap(lambda k, walk=walk: getattr(I, walk)(
                k, grid, src, dst, LARGE_CAP, excl))(keys)
                for walk in ("uniform_walk", "directional_walk")}

    return jax.jit(run)


_LARGE_MAP_WALKS = {"hashed": _large_map_walks(False), "table": _large_map_walks(True)}


@pytest.mark.parametrize("walk", ["uniform_walk", "directional_walk"])
def test_large_map_walks_keep_a_capacity_sized_visited_set_with_the_same_paths(walk):
    """On a map of more than 64 cells per node of capacity the walks keep their visited
    set as a hash set of their own cells and a sorted list of the excluded ones: the same
    key gives the same walk as with the map-sized table (forced here), exclusions
    included."""
    grid = random_map(48, 48, 0.25, seed=2)
    free = np.flatnonzero(~grid.blocked_np().reshape(-1))
    src = int(free[len(free) // 2])
    near = [c for c in free if max(abs(c % 48 - src % 48), abs(c // 48 - src // 48)) == 6]
    dst = int(near[0])
    cap = LARGE_CAP  # 48 * 48 > 64 * 32: the hash set
    rng = np.random.default_rng(0)
    excl = np.full(cap, -1, np.int32)
    excl[:20] = rng.choice(free, 20).astype(np.int32)
    keys = jax.random.split(jax.random.PRNGKey(11), 64)
    args = (keys, grid, src, dst, excl)
    # the two variants are different programs (the table is really forced)
    traced = {k: str(jax.make_jaxpr(f)(*args)) for k, f in _LARGE_MAP_WALKS.items()}
    assert traced["hashed"] != traced["table"]
    hashed = _LARGE_MAP_WALKS["hashed"](*args)[walk]
    table = _LARGE_MAP_WALKS["table"](*args)[walk]
    for a, b in zip(hashed, table):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert np.asarray(hashed[2]).any()
    check_paths(grid, *hashed, source=src, target=dst, exclude=excl[excl >= 0], cap=cap)


@functools.partial(jax.jit, static_argnames=("caps",))
def _directional_walks(grid, caps):
    """``{cap: (cells, length, ok)}``: start-to-goal directional walks of each capacity of
    ``caps`` for the keys ``split(PRNGKey(0), 1000)``."""
    keys = jax.random.split(jax.random.PRNGKey(0), 1000)
    return {cap: jax.vmap(lambda k, cap=cap: I.directional_walk(
        k, grid, grid.start, grid.goal, cap))(keys) for cap in caps}


def test_the_directional_walk_is_the_papers_uncapped_walk_on_a_20x20_map():
    """Zhu & Pan's Algorithm 1 allows 10,000 steps; jaxga's walk stops at the chromosome's
    capacity (160 cells on a 20 x 20 map). The walk never revisits a cell, so it ends within
    the map's free cells either way: with room for every free cell the walks are the same,
    walk for walk, so the capacity does not lower Table 2's success rate there."""
    from jaxga.maps import load_map

    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    free = int((~grid.blocked_np()).sum())
    out = {cap: tuple(np.asarray(x) for x in v)
           for cap, v in _directional_walks(grid, caps=(160, free)).items()}
    (c1, n1, ok1), (c2, n2, ok2) = out[160], out[free]
    np.testing.assert_array_equal(ok1, ok2)
    np.testing.assert_array_equal(n1[ok1], n2[ok2])
    assert 0.3 < ok1.mean() < 0.7 and n1[ok1].max() < 160
    for a, b, n in zip(c1[ok1], c2[ok2], n1[ok1]):
        np.testing.assert_array_equal(a[:n], b[:n])


def _imga_insertion_sequential(rng, blocked, start, goal, node_cap=2000):
    """An independent transcription of IMGA 4.1 (3)(i)-(ii): a random free middle cell,
    then the median of the first discontinuous pair inserted (a random free 8-neighbour of
    a blocked median; none: discarded), left to right, one node at a time; ``None`` when
    discarded or past ``node_cap`` nodes (the paper's loop is unbounded)."""
    h, w = blocked.shape
    free = [(x, y) for y in range(h) for x in range(w)
            if not blocked[y, x] and (x, y) not in (start, goal)]
    path = [start, free[rng.integers(len(free))], goal]
    i = 0
    while i < len(path) - 1:
        (x0, y0), (x1, y1) = path[i], path[i + 1]
        if max(abs(x1 - x0), abs(y1 - y0)) <= 1:  # eq. 2: continuous
            i += 1
            continue
        mx, my = (x0 + x1) // 2, (y0 + y1) // 2  # eq. 3
        if blocked[my, mx]:
            around = [(mx + dx, my + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)
                      if (dx or dy) and 0 <= mx + dx < w and 0 <= my + dy < h
                      and not blocked[my + dy, mx + dx]]
            if not around:
                return None
            mx, my = around[rng.integers(len(around))]
        path.insert(i + 1, (mx, my))
        if len(path) > node_cap:
            return None
    return path


@jax.jit
def _median_insertion_ok(grid):
    """Whether each of 300 median insertions of capacity 160 (keys ``split(PRNGKey(0),
    300)``) succeeds: one program for both 20 x 20 maps."""
    keys = jax.random.split(jax.random.PRNGKey(0), 300)
    return jax.vmap(lambda k: I.median_insertion(k, grid, 160))(keys)[2]


@pytest.mark.parametrize("name,lo,hi", [("classic_ga_gapp3_20x20", 0.25, 0.45),
                                        ("aco_classic_20x20_v1_lihongxin", 0.0, 0.0)])
def test_median_insertion_succeeds_as_often_as_the_papers_sequential_insertion(name, lo, hi):
    """jaxga's parallel median insertion (64 rounds, capacity 160) against a sequential
    transcription of the paper with a 2000-node cap, 300 draws each: both about a third
    on gapp3, and both never on aco_classic, whose long walls make the paper's insertion
    cycle (a blocked median's neighbour reopens the gap) whatever the cap: imga's
    ``init.fallback`` fills that population, not the insertion's round cap."""
    from jaxga.maps import load_map

    grid = load_map(name, corner_rule="free")
    blocked = grid.blocked_np()
    rng = np.random.default_rng(0)
    seq = np.mean([_imga_insertion_sequential(rng, blocked, grid.start_xy, grid.goal_xy)
                   is not None for _ in range(300)])
    ok = np.asarray(_median_insertion_ok(grid))
    assert lo <= seq <= hi and lo <= ok.mean() <= hi, (seq, ok.mean())
    assert abs(seq - ok.mean()) <= 0.1
