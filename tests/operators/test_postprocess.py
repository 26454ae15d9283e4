"""Post-optimisation (MPMGA 4.7, AGACD 4.8, IMGA 4.5, and jaxga's own): shortcut_greedy,
shortcut_optimal, prune_waypoints, simplify_adjacent, remove_loops."""

from __future__ import annotations

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from scipy import stats

from jaxga import Grid
from jaxga.core import paths
from jaxga.core.geometry import clear, floor_div, linear_trial
from jaxga.core.grid import CORNER_RULES
from jaxga.core.objectives import path_length
from jaxga.core.paths import (
    Population,
    has_endpoints,
    is_continuous,
    is_feasible,
    is_loop_free,
    population_map,
)
from jaxga.maps.generators import random_map
from jaxga.operators import postprocess as PP
from jaxga.operators.lift import over_individuals
from jaxga.reference.optima import clear_pairs_np, distances_from, shortest_path_np
from tests.strategies import CAP, SIZE, grids_and_parents

# the post-optimisations' properties and references in depth (contracts: test_registry)
pytestmark = pytest.mark.slow

P = 8

# Every jitted function below is built once, here, and called with a few fixed shapes:
# the operator tests' SIZE x SIZE maps with P paths of capacity CAP (hand-made paths are
# tiled to P), the 40 x 40 maps of the long paths, one path of capacity 160 on the open
# and corridor maps; a corner rule compiles each once per shape. The path checks are
# one program of their own (per shape), not a copy in each operator's program.


@jax.jit
def _checks(g, c, n):
    """The path checks of :mod:`jaxga.core.paths` for a population, and its Euclidean
    lengths."""
    return (
        population_map(has_endpoints)(g, c, n),
        population_map(is_continuous)(g, c, n),
        population_map(is_feasible)(g, c, n),
        jax.vmap(is_loop_free)(c, n),
        population_map(path_length)(g, c, n),
    )


def _path(xy, width: int, capacity: int) -> tuple[np.ndarray, np.int32]:
    """``(x, y)`` coordinates -> ``(cells int32[capacity], length)``, padded with the last
    cell (:func:`jaxga.core.paths.from_coords` in NumPy: no device arrays to convert)."""
    xy = np.asarray(xy, np.int64).reshape(-1, 2)
    assert 1 <= len(xy) <= capacity
    cells = (xy[:, 1] * width + xy[:, 0]).astype(np.int32)
    return np.concatenate([cells, np.full(capacity - len(xy), cells[-1], np.int32)]), \
        np.int32(len(xy))


def _assert_padded(c, n) -> None:
    """Every path is padded as :func:`jaxga.core.paths.pad` pads: each position at or
    beyond its length repeats its last cell (NumPy)."""
    c, n = np.asarray(c), np.asarray(n)
    last = c[np.arange(len(n)), np.clip(n - 1, 0, c.shape[1] - 1)]
    np.testing.assert_array_equal(c, np.where(np.arange(c.shape[1]) < n[:, None], c,
                                              last[:, None]))


def _sight_pairs(g, c, f):
    """Line of sight ``f`` between every two nodes of each path: bool[P, L, L]."""
    each = jax.vmap(jax.vmap(f, in_axes=(None, None, 0)), in_axes=(None, 0, None))
    return jax.vmap(lambda p: each(g, p, p))(c)


@jax.jit
def _greedy(g, c, n):
    """``({los: (cells, length)}, {los: sees})``: shortcut_greedy under each line-of-sight
    test, and that test between every two nodes of each input path (bool[P, L, L])."""
    out = {los: jax.vmap(lambda c, n, los=los: PP.shortcut_greedy(g, c, n, los=los))(c, n)
           for los in PP.LINE_OF_SIGHT}
    sees = {"clear": _sight_pairs(g, c, clear), "linear_trial": _sight_pairs(g, c, linear_trial)}
    return out, sees


@jax.jit
def _optimal(g, c, n):
    """shortcut_optimal at the default window (``"default"``) and at a window of 3
    positions (``"narrow"``)."""
    return {
        "default": jax.vmap(lambda c, n: PP.shortcut_optimal(g, c, n))(c, n),
        "narrow": jax.vmap(lambda c, n: PP.shortcut_optimal(g, c, n, window=3))(c, n),
    }


@jax.jit
def _optimal_long(g, c, n):
    """For the long paths: shortcut_optimal at the default window, and the path checks of
    the input, the optimum and the greedy pass (one program: the checks run on no other
    paths of this capacity)."""
    oc, on = jax.vmap(lambda c, n: PP.shortcut_optimal(g, c, n))(c, n)
    gc, gn = jax.vmap(lambda c, n: PP.shortcut_greedy(g, c, n))(c, n)
    report = _checks(g, jnp.concatenate([c, oc, gc]), jnp.concatenate([n, on, gn]))
    src, opt, greedy = (tuple(v[k * len(n): (k + 1) * len(n)] for v in report)
                        for k in range(3))
    return oc, on, opt, src[4], greedy[4]


# one path of capacity 160: on the open maps the optimum and the pruning, on the
# corridor maps the optimum
_optimal_prune_one = jax.jit(jax.vmap(lambda g, c, n: (PP.shortcut_optimal(g, c, n),
                                                       PP.prune_waypoints(g, c, n)),
                                      in_axes=(None, 0, 0)))
_optimal_one = jax.jit(jax.vmap(PP.shortcut_optimal, in_axes=(None, 0, 0)))
_simplify = jax.jit(over_individuals(PP.simplify_adjacent))
# under x64: the two operators' dtypes, jitted as in use
_x64_ops = jax.jit(lambda g, c, n: (PP.shortcut_optimal(g, c, n), PP.shortcut_greedy(g, c, n)))


def _greedy_reference(path, sees):
    """MPMGA section 4.7, steps (1)-(4), literally (0-based; ``sees[a, b]`` for indices)."""
    n = len(path)
    i, j, out = 0, 1, [path[0]]
    while True:
        if j == n - 1:  # step (2)
            out.append(path[j])
            return out
        if sees[i, j + 1]:  # step (3)
            j += 1
        else:
            i = j
            out.append(path[i])
            assert sees[i, j + 1]  # feasible input: the loop makes progress


def _as_lists(c, n):
    c, n = np.asarray(c), np.asarray(n)
    return [c[i, : n[i]].tolist() for i in range(len(n))]


# ------------------------------------------------------------------ shortcut_greedy
@settings(max_examples=25)
@given(grids_and_parents(n=P))
def test_shortcut_greedy_properties_and_reference(gp):
    """Feasible, same endpoints, no longer, a sub-sequence, and MPMGA's steps exactly."""
    grid, parents = gp
    out, sees = _greedy(grid, parents.cells, parents.length)
    c, n = out["clear"]
    ends, _, feas, loop_free, out_len = (np.asarray(v) for v in _checks(grid, c, n))
    in_len = np.asarray(_checks(grid, parents.cells, parents.length)[4])
    assert ends.all() and feas.all() and loop_free.all()
    assert (out_len <= in_len + 1e-4).all()
    assert (np.asarray(n) <= np.asarray(parents.length)).all()
    _assert_padded(c, n)
    sees = np.asarray(sees["clear"])
    for i, (got, src) in enumerate(zip(_as_lists(c, n), _as_lists(parents.cells, parents.length))):
        assert got == [src[k] for k in _greedy_reference(list(range(len(src))), sees[i])]


@settings(max_examples=15)
@given(grids_and_parents(n=P))
def test_shortcut_greedy_linear_trial(gp):
    """los="linear_trial" (AGACD section 3) follows the same steps with AGACD's test."""
    grid, parents = gp
    out, sees = _greedy(grid, parents.cells, parents.length)
    c, n = out["linear_trial"]
    sees = np.asarray(sees["linear_trial"])
    for i, (got, src) in enumerate(zip(_as_lists(c, n), _as_lists(parents.cells, parents.length))):
        # The paper's loop needs every input segment to pass the test; AGACD's linear trial
        # can reject a legal anti-diagonal step, which jaxga then keeps as it is.
        s = sees[i].copy()
        for k in range(len(src) - 1):
            s[k, k + 1] = True
        assert got == [src[k] for k in _greedy_reference(list(range(len(src))), s)]


def _sees_np(grid, path: list[int]) -> np.ndarray:
    """``bool[n, n]``: line of sight between every two nodes of ``path`` by the NumPy
    reference (:func:`jaxga.reference.optima.clear_pairs_np`, independent of jaxga.core)."""
    w = grid.width
    xy = np.array([(c % w, c // w) for c in path], np.int64)
    i, j = np.meshgrid(np.arange(len(path)), np.arange(len(path)), indexing="ij")
    ok = clear_pairs_np(grid.blocked_np(), grid.corner_rule, xy[i.ravel()], xy[j.ravel()])
    return ok.reshape(len(path), len(path))


def _shortest_subsequence(xy, sees, window: int | None = None) -> float:
    """Brute force: the shortest sub-sequence from the first to the last node whose
    consecutive nodes see each other (at most ``window`` positions apart, if given)."""
    n = len(xy)
    best = [0.0] + [math.inf] * (n - 1)
    for j in range(1, n):
        for i in range(0 if window is None else max(j - window, 0), j):
            if sees[i, j]:
                best[j] = min(best[j], best[i] + math.dist(xy[i], xy[j]))
    return best[-1]


def _check_minimal(grid, got: list[int]) -> None:
    """No collinear triple and no waypoint whose neighbours see each other (NumPy
    reference line of sight)."""
    w = grid.width
    xy = np.array([(c % w, c // w) for c in got], np.int64)
    if len(got) < 3:
        return
    d1, d2 = xy[1:-1] - xy[:-2], xy[2:] - xy[1:-1]
    assert (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] != 0).all(), f"collinear in {got}"
    assert not clear_pairs_np(grid.blocked_np(), grid.corner_rule, xy[:-2], xy[2:]).any(), \
        f"removable waypoint in {got}"


def _check_optimal(grid, c, n, src_c, src_n, window: int, report, in_len, greedy_len):
    """shortcut_optimal's output against the NumPy references, path by path: a feasible
    sub-sequence with the input's endpoints, minimal (:func:`_check_minimal`), no longer
    than the greedy pass nor than the previous result (the windowed optimum or the
    greedy result, whichever is shorter), never shorter than the optimum without a
    window, which it equals when the paths fit the window. ``report``: the output's
    :func:`_checks`; ``in_len``, ``greedy_len``: the Euclidean lengths of the input and
    of the greedy pass's output."""
    w = grid.width
    ends, _, feas, loop_free, out_len = (np.asarray(v) for v in report)
    assert ends.all() and feas.all() and loop_free.all()
    in_len, greedy_len = np.asarray(in_len), np.asarray(greedy_len)
    assert (out_len <= greedy_len + 1e-4).all() and (out_len <= in_len + 1e-4).all()
    _assert_padded(c, n)
    for i, (got, src) in enumerate(zip(_as_lists(c, n), _as_lists(src_c, src_n))):
        positions = [src.index(cell) for cell in got]
        assert positions == sorted(positions) and got[0] == src[0] and got[-1] == src[-1]
        _check_minimal(grid, got)
        sees = _sees_np(grid, src)
        xy = [(cell % w, cell // w) for cell in src]
        best = _shortest_subsequence(xy, sees)
        before = min(_shortest_subsequence(xy, sees, window), float(greedy_len[i]))
        assert best - 1e-4 <= out_len[i] <= before + 1e-4
        if len(src) <= window:
            assert math.isclose(out_len[i], best, rel_tol=1e-5)


@settings(max_examples=25)
@given(grids_and_parents(n=P))
def test_shortcut_optimal_is_the_shortest_clear_subsequence(gp):
    """On random maps and paths (shorter than the window): the brute-force optimum over
    all clear sub-sequences (NumPy line of sight), as few waypoints as possible, never
    longer than the greedy pass; with a window of 3 positions still feasible and minimal,
    between the optimum and the shorter of the windowed optimum and the greedy result."""
    grid, parents = gp
    out = _optimal(grid, parents.cells, parents.length)
    in_len = _checks(grid, parents.cells, parents.length)[4]
    greedy_len = _checks(grid, *_greedy(grid, parents.cells, parents.length)[0]["clear"])[4]
    for name, window in (("default", PP.SHORTCUT_WINDOW), ("narrow", 3)):
        c, n = out[name]
        _check_optimal(grid, c, n, parents.cells, parents.length, window, _checks(grid, c, n),
                       in_len, greedy_len)


LONG_SIZE, LONG_CAP = 40, 256


def _long_parents(grid, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` continuous loop-free start-goal paths of up to ``LONG_CAP`` cells: the
    8-connected optimum, then detours through random free cells (each leg the optimum on
    the map with the earlier legs blocked)."""
    rng = np.random.default_rng(seed)
    b, rule = grid.blocked_np(), grid.corner_rule
    free = np.argwhere(np.isfinite(distances_from(grid)))[:, ::-1]
    out = [shortest_path_np(b, grid.start_xy, grid.goal_xy, rule).path]
    while len(out) < n:
        used, legs, here = b.copy(), [np.asarray([grid.start_xy])], grid.start_xy
        for target in [tuple(int(v) for v in free[k])
                       for k in rng.integers(len(free), size=3)] + [grid.goal_xy]:
            used[here[1], here[0]] = False
            leg = shortest_path_np(used, here, target, rule)
            if not leg.found:
                break
            used[leg.path[:, 1], leg.path[:, 0]] = True
            legs.append(leg.path[1:])
            here = target
        else:
            path = np.concatenate(legs)
            if len(path) <= LONG_CAP:
                out.append(path)
    cells, length = zip(*(_path(p, grid.width, LONG_CAP) for p in out))
    return np.stack(cells), np.array(length, np.int32)


@pytest.mark.parametrize("rule", CORNER_RULES)
def test_shortcut_optimal_long_paths_against_numpy(rule):
    """Paths longer than the window (the optimum and detours of up to 256 cells on 40 x 40
    maps): feasible, minimal, between the optimum over all clear sub-sequences and the
    shorter of the windowed optimum and the greedy result (NumPy references)."""
    for seed in range(2):
        grid = random_map(LONG_SIZE, LONG_SIZE, 0.25, seed, corner_rule=rule)
        cells, length = _long_parents(grid, 4, seed)
        assert int(np.max(length)) > PP.SHORTCUT_WINDOW
        c, n, report, in_len, greedy_len = _optimal_long(grid, cells, length)
        _check_optimal(grid, c, n, cells, length, PP.SHORTCUT_WINDOW, report, in_len,
                       greedy_len)


def test_shortcut_optimal_straight_lines_are_one_segment():
    """100 collinear cells (more than the window) along an axis or a diagonal, and a
    staircase, on an open map: the two end points; a collinear waypoint is dropped."""
    grid = Grid.create(np.zeros((100, 100), bool), corner_rule="strict")
    stair = [(k, k // 2) for k in range(100)]  # slope 1/2: straight and diagonal steps
    for xy in ([(x, 7) for x in range(100)], [(k, 99 - k) for k in range(100)], stair):
        assert _big(grid, xy, prune=True)[0] == [xy[0], xy[-1]]
    assert _big(grid, [(0, 0), (2, 0), (5, 0), (5, 3)], prune=True)[1] == [(0, 0), (5, 3)]
    wall = np.zeros((100, 100), bool)
    wall[1:, 3] = True  # x = 3 above row 0: (5, 0) must stay, (2, 0) goes
    grid = Grid.create(wall, corner_rule="strict")
    assert _big(grid, [(0, 0), (2, 0), (5, 0), (5, 3)], prune=True)[1] == [(0, 0), (5, 0),
                                                                          (5, 3)]


def test_shortcut_optimal_l_corridor():
    """A one-cell-wide L-shaped corridor with legs of 80 cells: its ends and its corner
    (cut by a diagonal step unless the corner rule is strict); in a two-cell-wide one, a
    path along the inner walls keeps its corner node, and one along the outer walls
    wraps the inner corner."""
    size = 80
    corridor = np.ones((size, size), bool)
    corridor[0, :] = False  # row y = 0
    corridor[:, size - 1] = False  # column x = 79
    ell = [(x, 0) for x in range(size)] + [(size - 1, y) for y in range(1, size)]
    for rule in CORNER_RULES:
        grid = Grid.create(corridor, corner_rule=rule)
        # the diagonal step (78, 0) -> (79, 1) passes one blocked side cell, (78, 1)
        corner = [(79, 0)] if rule == "strict" else [(78, 0), (79, 1)]
        assert _big(grid, ell) == [(0, 0), *corner, (79, 79)], rule
    wide = corridor.copy()
    wide[1, : size - 1] = False  # row y = 1 too: the inner corner is cell (77, 2)
    wide[2:, size - 2] = False  # column x = 78 too
    grid = Grid.create(wide, corner_rule="strict")
    inner = [(x, 1) for x in range(size - 1)] + [(size - 2, y) for y in range(2, size)]
    assert _big(grid, inner) == [(0, 1), (78, 1), (78, 79)]
    # along the outer walls: around the inner corner (77.5, 1.5) (cell (77, 2)'s); from
    # (73, 0) the segment to (79, 2) would pass exactly through it (strict: not clear)
    got = _big(grid, ell)
    assert got == [(0, 0), (74, 0), (79, 2), (79, 79)]
    sees = _sees_np(grid, [y * size + x for x, y in ell])
    length = sum(math.dist(a, b) for a, b in zip(got[:-1], got[1:]))
    assert math.isclose(length, _shortest_subsequence(ell, sees), rel_tol=1e-6)


def test_shortcut_optimal_short_paths_and_x64():
    """One and two nodes come back unchanged; int32 out under x64."""
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), corner_rule="strict")
    for xy in ([(0, 0)], [(0, 0), (1, 1)]):
        assert _one("optimal", grid, xy) == xy
    cells, n = _path([(0, 0), (1, 0), (2, 0)], SIZE, 2 + 1)
    with jax.enable_x64(True):
        (c, n2), _ = _x64_ops(grid, cells, n)
        assert c.dtype == jnp.int32 and n2.dtype == jnp.int32 and int(n2) == 2


# --------------------------------------------------------------- line-of-sight helpers
_H, _W = 7, 9
_ALL_PAIRS = np.array(list(itertools.product(range(_H * _W), repeat=2))
                      + [(-1, 3), (3, _H * _W), (_H * _W + 5, 2)], np.int32)
_SPANS = (1, 3, 8)


@jax.jit
def _clear_both(g, a, b):
    """``{span: (clear, _clear_short)}`` on every pair ``(a[k], b[k])``: one program per rule."""
    codes = PP._vertex_codes(g.blocked)
    return {s: (jax.vmap(lambda a, b, s=s: clear(g, a, b, max_span=s))(a, b),
                jax.vmap(lambda a, b, s=s: PP._clear_short(g, codes, a, b, s))(a, b))
            for s in _SPANS}


@pytest.mark.parametrize("rule", CORNER_RULES)
def test_clear_short_is_clear_on_every_pair(rule):
    """shortcut_optimal's line of sight (one 2 x 2 block lookup per crossing) equals
    jaxga.core.geometry.clear with the same span bound on every ordered pair of cells
    (and a few off the map) of random 7 x 9 maps."""
    rng = np.random.default_rng(11)
    for density in (0.0, 0.15, 0.3, 0.5):
        grid = Grid.create(rng.random((_H, _W)) < density, corner_rule=rule)
        out = _clear_both(grid, _ALL_PAIRS[:, 0], _ALL_PAIRS[:, 1])
        for span in _SPANS:
            want, got = (np.asarray(v) for v in out[span])
            np.testing.assert_array_equal(got, want)


_floor_div = jax.jit(floor_div)


def test_floor_div_is_exact():
    """The line-of-sight tests' floor division through float32 equals the integer one for
    quotients up to 2**19 in magnitude, remainders 0 and den - 1 included (where a float
    quotient can round to the wrong side of an integer)."""
    rng = np.random.default_rng(2)
    n = 30000
    den = rng.integers(1, 1 << 12, n)
    q = rng.integers(-(1 << 19), 1 << 19, n)
    rem = np.stack([rng.integers(0, den), np.zeros(n, np.int64), den - 1])
    num = (q * den + rem).astype(np.int32)
    for k in range(3):
        got = np.asarray(_floor_div(num[k], den.astype(np.int32)))
        np.testing.assert_array_equal(got, q)


def _one(kind, grid, xy):
    """One hand-made path on a SIZE x SIZE map, tiled to P paths of capacity CAP (the
    shapes of the property tests), through shortcut_greedy (``kind`` a line-of-sight test)
    or shortcut_optimal (``"optimal"``): the result, as coordinates."""
    cells, n = _tiled(xy)
    if kind == "optimal":
        c, n = _optimal(grid, cells, n)["default"]
    else:
        c, n = _greedy(grid, cells, n)[0][kind]
    c, n = np.asarray(c), np.asarray(n)
    assert (c == c[0]).all() and (n == n[0]).all()  # every copy alike
    return paths.to_coords(c[0], n[0], grid.width)


def _big(grid, xy, prune=False):
    """One hand-made path of capacity 160 through shortcut_optimal, or with ``prune``
    through shortcut_optimal and prune_waypoints: the result(s), as coordinates."""
    cells, n = _path(xy, grid.width, 160)
    if not prune:
        return _coords(grid, *_optimal_one(grid, cells[None], n[None]))
    return tuple(_coords(grid, *out) for out in _optimal_prune_one(grid, cells[None], n[None]))


def _coords(grid, c, n):
    """The first path of a population, as coordinates."""
    return paths.to_coords(np.asarray(c)[0], np.asarray(n)[0], grid.width)


def test_shortcut_greedy_l_path():
    """An L-shaped corridor keeps its corner (2 segments); in an open map it is 1."""
    corridor = np.ones((SIZE, SIZE), bool)
    corridor[0, :] = False  # row y = 0
    corridor[:, SIZE - 1] = False  # column x = 9
    ell = [(x, 0) for x in range(SIZE)] + [(SIZE - 1, y) for y in range(1, SIZE)]
    for rule in ("free", "strict"):
        grid = Grid.create(corridor, corner_rule=rule)
        for los in PP.LINE_OF_SIGHT:
            assert _one(los, grid, ell) == [(0, 0), (9, 0), (9, 9)]
        grid = Grid.create(np.zeros((SIZE, SIZE), bool), corner_rule=rule)
        assert _one("clear", grid, ell) == [(0, 0), (9, 9)]


def test_shortcut_greedy_agacd_example():
    """AGACD 4.8: A, B, C, D, E with AC clear, AD blocked, CE clear -> A, C, E."""
    blocked = np.zeros((SIZE, SIZE), bool)
    blocked[1, 1] = True  # (1, 1)
    path = [(0, 0), (1, 0), (2, 0), (2, 1), (2, 2)]  # A .. E
    grid = Grid.create(blocked, start=(0, 0), goal=(2, 2), corner_rule="free")
    for los in PP.LINE_OF_SIGHT:
        assert _one(los, grid, path) == [(0, 0), (2, 0), (2, 2)], los


def test_shortcut_greedy_segment_through_a_blocked_vertex_cell():
    """(0,0) -> (3,1) passes the vertex (2,1) into the blocked cell (2,1): not clear."""
    blocked = np.zeros((SIZE, SIZE), bool)
    blocked[1, 2] = True  # (2, 1)
    path = [(0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (3, 2)]
    grid = Grid.create(blocked, start=(0, 0), goal=(3, 2), corner_rule="strict")
    got = _one("clear", grid, path)
    assert got == [(0, 0), (3, 0), (3, 2)]


def test_shortcut_greedy_short_and_x64():
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), corner_rule="strict")
    for xy in ([(0, 0)], [(0, 0), (1, 1)]):
        assert _one("clear", grid, xy) == xy
    cells, n = _path([(0, 0), (1, 0), (2, 0)], SIZE, 2 + 1)
    with jax.enable_x64(True):
        _, (c, n2) = _x64_ops(grid, cells, n)
        assert c.dtype == jnp.int32 and n2.dtype == jnp.int32 and int(n2) == 2


# ---------------------------------------------------------------- simplify_adjacent
def _simplify_reference(path, t, legal):
    """Zhu & Pan 4.6 for a given t: farthest s >= t + 2 one legal step away, or None."""
    s = t + 1
    for now in range(t + 2, len(path)):
        if legal(path[t], path[now]):
            s = now
    return None if s == t + 1 else path[: t + 1] + path[s:]


def _legal_fn(grid):
    b, w = grid.blocked_np(), grid.width

    def legal(a, c):
        ax, ay, cx, cy = a % w, a // w, c % w, c // w
        if max(abs(ax - cx), abs(ay - cy)) != 1 or b[ay, ax] or b[cy, cx]:
            return False
        if ax == cx or ay == cy:
            return True
        s1, s2 = b[ay, cx], b[cy, ax]
        return {"free": True, "no_squeeze": not (s1 and s2), "strict": not (s1 or s2)}[
            grid.corner_rule
        ]

    return legal


@settings(max_examples=25)
@given(grids_and_parents(n=P))
def test_simplify_adjacent_properties_and_reference(gp):
    grid, parents = gp
    key = jax.random.PRNGKey(int(np.asarray(parents.length).sum()))
    out, n_failed = _simplify(key, grid, parents)
    c, n = out.cells, out.length
    ends, cont, _, loop_free, _ = (np.asarray(v) for v in _checks(grid, c, n))
    assert ends.all() and cont.all() and loop_free.all()
    _assert_padded(c, n)
    legal = _legal_fn(grid)
    unchanged = 0
    for got, src in zip(_as_lists(c, n), _as_lists(parents.cells, parents.length)):
        options = {tuple(r) for t in range(len(src) - 1)
                   if (r := _simplify_reference(src, t, legal)) is not None}
        if got == src:
            unchanged += 1
        else:
            assert tuple(got) in options
    assert int(n_failed) == unchanged  # it never returns an unchanged path as a success


def _tiled(xy):
    """A hand-made path on a SIZE x SIZE map as P copies of capacity CAP (NumPy)."""
    cells, n = _path(xy, SIZE, CAP)
    return np.tile(cells, (P, 1)), np.full(P, n, np.int32)


def test_simplify_adjacent_detour_exact_and_uniform_t():
    """A detour (0,0) (1,0) (2,0) (2,1) (2,2) (1,2) (0,2) (0,3): t = 1, 3, 5 simplify
    (dropping (2,0), (2,2), (0,2)), t = 0, 2, 4, 6 fail; t uniform over 0 .. n-2."""
    xy = [(0, 0), (1, 0), (2, 0), (2, 1), (2, 2), (1, 2), (0, 2), (0, 3)]
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(0, 0), goal=(0, 3),
                       corner_rule="strict")
    cells, n = _tiled(xy)
    counts: dict[tuple, int] = {}
    for s in range(150):
        out, _ = _simplify(jax.random.PRNGKey(s), grid, Population(cells, n))
        c, m = out.cells, out.length
        for got in _as_lists(c, m):
            k = tuple(paths.to_coords(np.asarray(got), len(got), SIZE))
            counts[k] = counts.get(k, 0) + 1
    drop = lambda p: tuple(q for q in xy if q != p)  # noqa: E731
    assert set(counts) == {tuple(xy), drop((2, 0)), drop((2, 2)), drop((0, 2))}
    # 7 choices of t: 4 fail, 3 succeed (one outcome each).
    assert stats.chisquare([counts[tuple(xy)], counts[drop((2, 0))], counts[drop((2, 2))],
                            counts[drop((0, 2))]], f_exp=np.array([4, 1, 1, 1]) / 7 * 150 * P
                           ).pvalue > 1e-3


def test_simplify_adjacent_farthest_neighbour():
    """From t, the FARTHEST later neighbour is used (Zhu 4.6 (iii): s is overwritten)."""
    # (1,1) is adjacent to (2,0) [k=2], (2,1) [k=3] and (2,2) [k=4]: t = 0 -> s = 4.
    xy = [(1, 1), (1, 0), (2, 0), (2, 1), (2, 2), (2, 3)]
    grid = Grid.create(np.zeros((SIZE, SIZE), bool), start=(1, 1), goal=(2, 3),
                       corner_rule="free")
    cells, n = _tiled(xy)
    seen = set()
    for s in range(40):
        out, _ = _simplify(jax.random.PRNGKey(s), grid, Population(cells, n))
        c, m = out.cells, out.length
        seen |= {tuple(p) for p in _as_lists(c, m)}
    w = SIZE
    idx = lambda pts: tuple(y * w + x for x, y in pts)  # noqa: E731
    # t=0 -> s=4; t=1 ((1,0)) -> s=3 ((2,1)); t=2,3,4 fail.
    assert seen == {idx(xy), idx([(1, 1), (2, 2), (2, 3)]), idx([(1, 1), (1, 0), (2, 1), (2, 2),
                                                                 (2, 3)])}


def test_remove_loops_is_reexported():
    assert PP.remove_loops is paths.remove_loops


def test_shortcut_optimal_is_refused_for_waypoint_paths():
    """AGACD's population holds waypoint paths (segments longer than one step), which the
    windowed programme of shortcut_optimal does not cover: a configuration error."""
    import pytest

    from jaxga.config.presets import load_preset
    from jaxga.core.errors import ParameterError
    from jaxga.engine import check_combination

    with pytest.raises(ParameterError, match="shortcut_optimal' needs continuous paths"):
        check_combination(load_preset("agacd", overrides={"post.method": "shortcut_optimal"}))
    check_combination(load_preset("imga", overrides={"post.method": "shortcut_optimal"}))
