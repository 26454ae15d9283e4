"""The masked path representation (docs: the pure core) and loop removal (MPMGA deletion)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxga import Grid, ParameterError
from jaxga.core.grid import DIRECTIONS
from jaxga.core.paths import (
    Population,
    cells_to_xy,
    from_coords,
    has_endpoints,
    is_continuous,
    is_feasible,
    is_loop_free,
    pad,
    population_map,
    remove_loops,
    to_coords,
)
from jaxga.maps import random_map
from jaxga.reference.optima import clear_np

N = 8  # 8 x 8 open map
CAP = 40
OPEN = Grid.create(np.zeros((N, N), bool), corner_rule="strict")

_remove_table = jax.jit(jax.vmap(lambda c, n: remove_loops(c, n, N * N)))
_remove_sort = jax.jit(jax.vmap(lambda c, n: remove_loops(c, n)))
_continuous = jax.jit(population_map(is_continuous))
_loop_free = jax.jit(jax.vmap(is_loop_free))


def test_mpmga_loop_deletion_example():
    """MPMGA section 4.3: 0, 20, 40, 21, 41, 40, 60 -> 0, 20, 40, 60 (20 x 20 map)."""
    cells, n = from_coords([(p % 20, p // 20) for p in (0, 20, 40, 21, 41, 40, 60)], 20, 10)
    for n_cells in (None, 400):
        out, k = remove_loops(cells, n, n_cells)
        assert int(k) == 4
        assert np.asarray(out).tolist() == [0, 20, 40, 60] + [60] * 6


@st.composite
def walks(draw):
    """Random 8-connected walks on the open map, with revisits (loops) allowed."""
    n = draw(st.integers(1, CAP))
    x, y = draw(st.integers(0, N - 1)), draw(st.integers(0, N - 1))
    cells = [y * N + x]
    for d in draw(st.lists(st.integers(0, 7), min_size=n - 1, max_size=n - 1)):
        dx, dy = DIRECTIONS[d]
        if 0 <= x + dx < N and 0 <= y + dy < N:
            x, y = x + int(dx), y + int(dy)
        else:
            x, y = x - int(dx), y - int(dy)
        cells.append(y * N + x)
    return cells


@given(st.lists(walks(), min_size=1, max_size=6))
def test_remove_loops_properties(paths):
    """Loop-free, continuous, same endpoints, an ordered subsequence; both variants agree."""
    pop = Population.from_paths(paths, CAP)
    cells, length = _remove_table(pop.cells, pop.length)
    cells2, length2 = _remove_sort(pop.cells, pop.length)
    assert np.array_equal(cells, cells2) and np.array_equal(length, length2)
    assert bool(jnp.all(_loop_free(cells, length)))
    assert bool(jnp.all(_continuous(OPEN, cells, length)))
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
    good, n = from_coords([(0, 0), (1, 0), (2, 0), (3, 1), (3, 2), (3, 3)], 4, 8)
    assert bool(is_continuous(grid, good, n)) and bool(has_endpoints(grid, good, n))
    # (1,0)->(2,1) passes side cell (1,1): illegal under "strict", legal under "free".
    cut, n2 = from_coords([(0, 0), (1, 0), (2, 1)], 4, 8)
    assert not bool(is_continuous(grid, cut, n2))
    assert bool(is_continuous(grid.replace(corner_rule="free"), cut, n2))
    # A gap is not continuous but can be feasible (waypoint path).
    jump, n3 = from_coords([(0, 0), (3, 0), (3, 3)], 4, 8)
    assert not bool(is_continuous(grid, jump, n3))
    assert bool(is_feasible(grid, jump, n3)) and bool(has_endpoints(grid, jump, n3))
    through, n4 = from_coords([(0, 0), (2, 2), (3, 3)], 4, 8)
    assert not bool(is_feasible(grid, through, n4))
    assert not bool(has_endpoints(grid, cut, n2))
    # Loops.
    loop, n5 = from_coords([(0, 0), (1, 0), (0, 0)], 4, 8)
    assert not bool(is_loop_free(loop, n5)) and bool(is_loop_free(good, n))
    # The table form (n_cells) agrees with the sort, and rejects an off-map node.
    assert not bool(is_loop_free(loop, n5, 16)) and bool(is_loop_free(good, n, 16))
    off = good.at[1].set(-3)
    assert bool(is_loop_free(off, n)) and not bool(is_loop_free(off, n, 16))
    rng = np.random.default_rng(5)
    keys = jnp.asarray(rng.integers(0, 12, (200, 8)), jnp.int32)
    lens = jnp.asarray(rng.integers(1, 9, 200), jnp.int32)
    by_sort = jax.vmap(is_loop_free)(keys, lens)
    by_table = jax.vmap(lambda c, ln: is_loop_free(c, ln, 12))(keys, lens)
    assert np.array_equal(np.asarray(by_sort), np.asarray(by_table))
    assert np.asarray(by_sort).any() and not np.asarray(by_sort).all()
    # Lengths outside [1, L] are never valid.
    assert not bool(is_continuous(grid, good, 0)) and not bool(is_feasible(grid, good, 9))


def test_coordinates_round_trip_and_capacity():
    xy = [(0, 0), (1, 1), (2, 1)]
    cells, n = from_coords(xy, 5, 6)
    assert cells.dtype == jnp.int32 and int(n) == 3
    assert np.asarray(cells).tolist() == [0, 6, 7, 7, 7, 7]
    assert to_coords(cells, n, 5) == xy
    assert np.asarray(cells_to_xy(cells[:3], 5)).tolist() == [list(p) for p in xy]
    with pytest.raises(ParameterError, match="capacity"):
        from_coords(xy, 5, 2)
    with pytest.raises(ParameterError, match="off a map"):
        from_coords([(5, 0)], 5, 4)
    assert np.asarray(pad(jnp.array([1, 2, 3, 9, 9], jnp.int32), 3)).tolist() == [1, 2, 3, 3, 3]


def test_remove_loops_under_x64():
    """Dtypes stay int32 with JAX_ENABLE_X64 (PERFORMANCE_NOTES: a promoted carry broke a loop)."""
    with jax.enable_x64(True):
        cells = jnp.array([0, 20, 40, 21, 41, 40, 60, 60], jnp.int32)
        out, k = jax.jit(remove_loops, static_argnums=2)(cells, 7, 400)
        assert out.dtype == jnp.int32 and k.dtype == jnp.int32
        assert np.asarray(out[: int(k)]).tolist() == [0, 20, 40, 60]


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
    from jaxga.core.paths import CHUNKED_LOOKUP_CELLS, last_occurrence

    rng = np.random.default_rng(3)
    cells = jnp.asarray(rng.integers(0, 40, (5, 30)), jnp.int32)  # many repeats
    length = jnp.array([30, 17, 1, 0, 29], jnp.int32)
    want = []
    for c, n in zip(np.asarray(cells), np.asarray(length)):
        row = [max(j for j in range(n) if c[j] == c[i]) if i < n else i for i in range(30)]
        want.append(row)
    for n_cells, tables in ((None, 16), (64, 16), (2**20, 16), (2**28, 16),
                            (CHUNKED_LOOKUP_CELLS + 1, 10**6)):
        monkeypatch.setattr(paths, "TABLE_CELLS_PER_NODE", tables)
        assert paths._packable(n_cells, 30) == (n_cells not in (None, 2**28))
        got = jax.jit(jax.vmap(lambda c, n, m=n_cells: last_occurrence(c, n, m)))(cells, length)
        np.testing.assert_array_equal(got, want)
        look = jax.jit(jax.vmap(lambda c, n, m=n_cells: paths.position_lookup(c, n, m)(
            jnp.arange(-2, 45, dtype=jnp.int32))))(cells, length)
        for row, c, n in zip(np.asarray(look), np.asarray(cells), np.asarray(length)):
            where = {int(v): j for j, v in enumerate(c[:n])}  # the last position of each
            assert row.tolist() == [where.get(q, -1) for q in range(-2, 45)]


def test_is_loop_free_refuses_a_node_off_the_map_whatever_the_width():
    """With the map size given, a valid node off the map makes a path not loop-free in
    the table and in the sort variant alike (a short buffer takes the sort)."""
    from jaxga.core.paths import is_loop_free

    for width in (3, 30):
        cells = jnp.asarray([0, 500, 2] + [2] * (width - 3), jnp.int32)
        assert not bool(is_loop_free(cells, jnp.int32(3), 400))
        assert bool(is_loop_free(cells.at[1].set(1), jnp.int32(3), 400))
