"""The masked path representation (docs: the pure core) and loop removal (MPMGA deletion).

Each function under test is jitted once below and called with fixed shapes (populations
padded to ``B`` paths), expected values come from NumPy and plain Python.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxga import Grid, ParameterError
from jaxga.core.grid import DIRECTIONS, step_ends
from jaxga.core.paths import (
    Population,
    cells_to_xy,
    from_coords,
    has_endpoints,
    is_continuous,
    is_feasible,
    is_loop_free,
    last_occurrence,
    pad,
    population_map,
    position_lookup,
    remove_loops,
    to_coords,
)
from jaxga.maps import random_map
from jaxga.reference.optima import clear_np

N = 8  # 8 x 8 open map
CAP = 40
B = 6  # paths per population in test_remove_loops_properties (fewer are padded)
OPEN = Grid.create(np.zeros((N, N), bool), corner_rule="strict")

_remove_table = jax.jit(jax.vmap(functools.partial(remove_loops, n_cells=N * N)))
_remove_sort = jax.jit(jax.vmap(remove_loops))
_remove_one = jax.jit(remove_loops, static_argnums=2)
_continuous = jax.jit(population_map(is_continuous))
_loop_free = jax.jit(jax.vmap(is_loop_free))
_loop_free_400 = jax.jit(functools.partial(is_loop_free, n_cells=400))
_cells_to_xy = jax.jit(cells_to_xy, static_argnums=1)
_pad = jax.jit(pad)


def _hand_checks(grid, cells, length):
    """Every check of one path (the loop-free one by sort and by the map's table)."""
    return {
        "continuous": is_continuous(grid, cells, length),
        "endpoints": has_endpoints(grid, cells, length),
        "feasible": is_feasible(grid, cells, length),
        "loop_free": is_loop_free(cells, length),
        "loop_free_table": is_loop_free(cells, length, grid.n_cells),
    }


_checks = jax.jit(_hand_checks)
_loop_free_sort_and_table = jax.jit(jax.vmap(
    lambda c, n: (is_loop_free(c, n), is_loop_free(c, n, 12))))


def _occurrences(cells, length, n_cells, tables):
    """``last_occurrence`` of each row, and its ``position_lookup`` of the cells -2..44.
    ``tables`` (the patched ``TABLE_CELLS_PER_NODE``, static) is not used: it keys the
    compiled program, which depends on it."""
    queries = jnp.arange(-2, 45, dtype=jnp.int32)
    last = jax.vmap(lambda c, n: last_occurrence(c, n, n_cells))(cells, length)
    look = jax.vmap(lambda c, n: position_lookup(c, n, n_cells)(queries))(cells, length)
    return last, look


_occurrences_jit = jax.jit(_occurrences, static_argnums=(2, 3))


def test_mpmga_loop_deletion_example():
    """MPMGA section 4.3: 0, 20, 40, 21, 41, 40, 60 -> 0, 20, 40, 60 (20 x 20 map)."""
    cells, n = from_coords([(p % 20, p // 20) for p in (0, 20, 40, 21, 41, 40, 60)], 20, 10)
    for n_cells in (None, 400):
        out, k = _remove_one(cells, n, n_cells)
        assert int(k) == 4
        assert np.asarray(out).tolist() == [0, 20, 40, 60] + [60] * 6


@st.composite
def walks(draw):
    """Random 8-connected walks on the open map, with revisits (loops) allowed."""
    n = draw(st.integers(1, CAP))
    x, y = draw(st.integers(0, N - 1)), draw(st.integers(0, N - 1))
    cells = [y * N + x]
    for d in draw(st.lists(st.integers(0, 7), min_size=n - 1, max_size=n - 1)):
        dx, dy = (int(v) for v in DIRECTIONS[d])
        # a coordinate that would leave the map steps back instead (each on its own: a
        # diagonal at the edge reflected as a whole could leave the map the other way)
        x = x + dx if 0 <= x + dx < N else x - dx
        y = y + dy if 0 <= y + dy < N else y - dy
        cells.append(y * N + x)
    return cells


@given(st.lists(walks(), min_size=1, max_size=6))
def test_remove_loops_properties(paths):
    """Loop-free, continuous, same endpoints, an ordered subsequence; both variants agree."""
    k = len(paths)
    pop = Population.from_paths(paths + [[0]] * (B - k), CAP)  # padded to B paths
    cells, length = _remove_table(pop.cells, pop.length)
    cells2, length2 = _remove_sort(pop.cells, pop.length)
    assert np.array_equal(cells, cells2) and np.array_equal(length, length2)
    assert np.asarray(_loop_free(cells, length))[:k].all()
    assert np.asarray(_continuous(OPEN, cells, length))[:k].all()
    cells, length = np.asarray(cells)[:k], np.asarray(length)[:k]
    out = Population(cells, length).to_lists()
    for before, after, row in zip(paths, out, np.asarray(cells)):
        assert after[0] == before[0] and after[-1] == before[-1]
        it = iter(before)
        assert all(c in it for c in after)  # ordered subsequence
        assert set(row[len(after):].tolist()) <= {after[-1]}  # padding repeats the last cell
        if len(set(before)) == len(before):
            assert after == before


def test_checks_on_hand_made_paths():
    blocked = np.zeros((4, 4), bool)
    blocked[1, 1] = True
    grid = Grid.create(blocked, corner_rule="strict")  # start (0,0) goal (3,3)
    assert grid.n_cells == 16  # the table form below (n_cells = 16)

    def check(xy, g=grid, length=None):
        cells, n = from_coords(xy, 4, 8)
        return {k: bool(v) for k, v in _checks(g, cells, n if length is None else
                                                np.int32(length)).items()}

    good = [(0, 0), (1, 0), (2, 0), (3, 1), (3, 2), (3, 3)]
    assert check(good)["continuous"] and check(good)["endpoints"]
    # (1,0)->(2,1) passes side cell (1,1): illegal under "strict", legal under "free".
    cut = [(0, 0), (1, 0), (2, 1)]
    assert not check(cut)["continuous"]
    assert check(cut, grid.replace(corner_rule="free"))["continuous"]
    # A gap is not continuous but can be feasible (waypoint path).
    jump = [(0, 0), (3, 0), (3, 3)]
    assert not check(jump)["continuous"]
    assert check(jump)["feasible"] and check(jump)["endpoints"]
    through = [(0, 0), (2, 2), (3, 3)]
    assert not check(through)["feasible"]
    assert not check(cut)["endpoints"]
    # Loops.
    loop = [(0, 0), (1, 0), (0, 0)]
    assert not check(loop)["loop_free"] and check(good)["loop_free"]
    # The table form (n_cells) agrees with the sort, and rejects an off-map node.
    assert not check(loop)["loop_free_table"] and check(good)["loop_free_table"]
    cells, n = from_coords(good, 4, 8)
    off = np.asarray(cells).copy()
    off[1] = -3
    off_checks = _checks(grid, off, n)
    assert bool(off_checks["loop_free"]) and not bool(off_checks["loop_free_table"])
    rng = np.random.default_rng(5)
    keys = rng.integers(0, 12, (200, 8)).astype(np.int32)
    lens = rng.integers(1, 9, 200).astype(np.int32)
    by_sort, by_table = (np.asarray(x) for x in _loop_free_sort_and_table(keys, lens))
    assert np.array_equal(by_sort, by_table)
    assert by_sort.any() and not by_sort.all()
    # Lengths outside [1, L] are never valid.
    assert not check(good, length=0)["continuous"] and not check(good, length=9)["feasible"]


def test_coordinates_round_trip_and_capacity():
    xy = [(0, 0), (1, 1), (2, 1)]
    cells, n = from_coords(xy, 5, 6)
    assert cells.dtype == jnp.int32 and int(n) == 3
    assert np.asarray(cells).tolist() == [0, 6, 7, 7, 7, 7]
    assert to_coords(cells, n, 5) == xy
    # every cell, the padding (the last cell repeated) too
    assert np.asarray(_cells_to_xy(cells, 5)).tolist() == [list(p) for p in xy + [xy[-1]] * 3]
    with pytest.raises(ParameterError, match="capacity"):
        from_coords(xy, 5, 2)
    with pytest.raises(ParameterError, match="off a map"):
        from_coords([(5, 0)], 5, 4)
    padded = _pad(np.array([1, 2, 3, 9, 9], np.int32), np.int32(3))
    assert np.asarray(padded).tolist() == [1, 2, 3, 3, 3]


def test_remove_loops_under_x64():
    """Dtypes stay int32 with JAX_ENABLE_X64 (PERFORMANCE_NOTES: a promoted carry broke a loop)."""
    with jax.enable_x64(True):
        cells = np.array([0, 20, 40, 21, 41, 40, 60, 60], np.int32)
        out, k = _remove_one(cells, 7, 400)
        assert out.dtype == jnp.int32 and k.dtype == jnp.int32
        assert np.asarray(out)[: int(k)].tolist() == [0, 20, 40, 60]


@pytest.mark.parametrize("rule", ["free", "no_squeeze", "strict"])
def test_is_continuous_agrees_with_the_exact_segment_reference(rule):
    """Random walks with jumps and off-map cells on a map with obstacles: continuous iff
    the length is in [1, L], every cell (padding too) is on the map, the first cell is
    free and every valid step is 8-adjacent and clear (jaxga.reference.optima.clear_np)."""
    grid = random_map(7, 6, 0.3, seed=2, corner_rule=rule)
    blocked, w, n = grid.blocked_np(), grid.width, grid.n_cells
    rng = np.random.default_rng(rule.encode()[0])
    cap, batch = 6, 3000
    steps = rng.integers(-1, 2, (batch, cap - 1)) + w * rng.integers(-1, 2, (batch, cap - 1))
    start = rng.integers(0, n, (batch, 1))
    cells = np.concatenate([start, start + np.cumsum(steps, axis=1)], axis=1)
    jumps = rng.random(cells.shape) < 0.03
    cells[jumps] = rng.integers(-2, n + 2, int(jumps.sum()))
    length = rng.integers(0, cap + 2, batch)
    got = np.asarray(_continuous(grid, jnp.asarray(cells, jnp.int32),
                                 jnp.asarray(length, jnp.int32)))

    def expected(c, k):
        if not 1 <= k <= cap or not all(0 <= v < n for v in c):
            return False
        xy = [(int(v) % w, int(v) // w) for v in c[:k]]
        if blocked[xy[0][1], xy[0][0]]:
            return False
        return all(max(abs(a[0] - b[0]), abs(a[1] - b[1])) == 1
                   and clear_np(blocked, rule, a, b) for a, b in zip(xy, xy[1:]))

    want = np.array([expected(c, k) for c, k in zip(cells, length)])
    assert np.array_equal(got, want)
    assert 50 < want.sum() < batch - 50  # both outcomes are exercised


def test_last_occurrence_is_the_same_for_every_table_variant(monkeypatch):
    """The last valid position of each node's cell (padding: itself), computed by a
    stable argsort (no map size, or a map too large to pack a cell and a position into
    32 bits), one sort of packed words (a large map), a small-map table, and on a map
    above CHUNKED_LOOKUP_CELLS by ``scatter.table_lookup`` (batched rows, so its folded
    rule runs too; tables forced on that map)."""
    from jaxga.core import paths
    from jaxga.core.paths import CHUNKED_LOOKUP_CELLS

    rng = np.random.default_rng(3)
    cells = rng.integers(0, 40, (5, 30)).astype(np.int32)  # many repeats
    length = np.array([30, 17, 1, 0, 29], np.int32)
    want = []
    for c, n in zip(cells, length):
        row = [max(j for j in range(n) if c[j] == c[i]) if i < n else i for i in range(30)]
        want.append(row)
    for n_cells, tables in ((None, 16), (64, 16), (2**20, 16), (2**28, 16),
                            (CHUNKED_LOOKUP_CELLS + 1, 10**6)):
        monkeypatch.setattr(paths, "TABLE_CELLS_PER_NODE", tables)
        assert paths._packable(n_cells, 30) == (n_cells not in (None, 2**28))
        got, look = _occurrences_jit(cells, length, n_cells, tables)
        np.testing.assert_array_equal(got, want)
        for row, c, n in zip(np.asarray(look), cells, length):
            where = {int(v): j for j, v in enumerate(c[:n])}  # the last position of each
            assert row.tolist() == [where.get(q, -1) for q in range(-2, 45)]


def test_is_loop_free_refuses_a_node_off_the_map_whatever_the_width():
    """With the map size given, a valid node off the map makes a path not loop-free in
    the table and in the sort variant alike (a short buffer takes the sort)."""
    for width in (3, 30):
        cells = np.array([0, 500, 2] + [2] * (width - 3), np.int32)
        assert not bool(_loop_free_400(cells, np.int32(3)))
        cells[1] = 1
        assert bool(_loop_free_400(cells, np.int32(3)))


def test_step_ends_are_the_coordinates_of_each_steps_two_cells():
    (xa, ya), (xb, yb) = step_ends(jnp.array([0, 21, 41, 3], jnp.int32), 20)
    assert [list(map(int, v)) for v in (xa, ya, xb, yb)] == [
        [0, 1, 1], [0, 1, 2], [1, 1, 3], [1, 2, 0]]


@given(st.integers(1, 64), st.lists(st.integers(-5000, 5000), min_size=40, max_size=40))
def test_step_ends_equal_the_sliced_coordinates_they_replace(width, cells):
    """Decision 048 moved the slice before the division; the values must not move:
    floor division and modulo of any int32 cell, a batch of rows too (one shape, so that
    the examples share their programs)."""
    c = jnp.asarray(np.array([cells, cells[::-1]], np.int32))
    (xa, ya), (xb, yb) = step_ends(c, width)
    x, y = np.asarray(c) % width, np.asarray(c) // width
    for got, want in ((xa, x[..., :-1]), (ya, y[..., :-1]), (xb, x[..., 1:]), (yb, y[..., 1:])):
        np.testing.assert_array_equal(np.asarray(got), want)
