"""Flat scatters under vmap (jaxga._batching.scatter): the same tables as a plain .at[] scatter.

Each function under test is jitted once below (at each vmap depth); expected values come
from NumPy.
"""

from __future__ import annotations

import jax
import numpy as np
import pytest

from jaxga._batching import scatter
from jaxga._batching.scatter import _rows_batched, _rows_flat, position_table, table_lookup


def _nested_tables(depth: int):
    """``position_table(keys, n_cells)`` under ``depth`` vmaps, jitted (n_cells static)."""
    fn = position_table
    for _ in range(depth):
        fn = jax.vmap(fn, in_axes=(0, None))
    return jax.jit(fn, static_argnums=1)


_TABLES = {depth: _nested_tables(depth) for depth in (0, 1, 2)}
_ROWS_FLAT = jax.jit(_rows_flat, static_argnums=1)
_ROWS_BATCHED = jax.jit(_rows_batched, static_argnums=1)


def _table_reference(keys: np.ndarray, n_cells: int) -> np.ndarray:
    """``full(n_cells, -1).at[k].max(arange(L), mode="drop")`` of every row ``k`` of
    ``keys``, in NumPy: a negative key counts from the end, a key still off the table
    is dropped."""
    out = np.full(keys.shape[:-1] + (n_cells,), -1, np.int32)
    for idx in np.ndindex(keys.shape[:-1]):
        for i, k in enumerate(keys[idx]):
            k = int(k) + n_cells if k < 0 else int(k)
            if 0 <= k < n_cells:
                out[idx + (k,)] = max(out[idx + (k,)], i)
    return out


@pytest.mark.parametrize("shape", [(12,), (7, 12), (3, 5, 12)])
def test_position_table_is_the_scatter_max_at_any_vmap_depth(shape):
    """``table.at[keys].max(arange(L), mode="drop")`` per row, with negative (counted from
    the end) and off-table keys."""
    n_cells = 20
    keys = np.random.default_rng(3).integers(-25, 25, shape).astype(np.int32)
    want = _table_reference(keys, n_cells)
    got = np.asarray(_TABLES[len(shape) - 1](keys, n_cells))
    assert got.dtype == np.int32 and got.shape == shape[:-1] + (n_cells,)
    assert np.array_equal(got, want)
    assert (want >= 0).any() and (want == -1).any()  # both outcomes are exercised


def test_the_flat_and_the_batched_rows_give_the_same_tables():
    """position_table computes a batch of rows with one flat scatter, or (beyond
    MAX_FLAT_ENTRIES = 2**31 - 1 entries, where int32 flat indices would overflow) with
    one batched scatter: both equal the per-row scatter."""
    from jaxga._batching.scatter import MAX_FLAT_ENTRIES

    assert MAX_FLAT_ENTRIES == 2**31 - 1
    keys = np.random.default_rng(5).integers(-13, 12, (4, 6, 9)).astype(np.int32)
    want = _table_reference(keys, 10)
    assert np.array_equal(np.asarray(_TABLES[2](keys, 10)), want)
    assert np.array_equal(np.asarray(_ROWS_FLAT(keys, 10)), want)
    assert np.array_equal(np.asarray(_ROWS_BATCHED(keys, 10)), want)


def _lookup_reference(keys: np.ndarray, queries: np.ndarray, n_cells: int) -> np.ndarray:
    """Last position of each query among the row's keys (-1: absent or off the table)."""
    out = np.full(queries.shape, -1, np.int32)
    for idx in np.ndindex(queries.shape[:-1]):
        row = keys[idx]
        for j, q in enumerate(queries[idx]):
            hits = np.flatnonzero(row == q)
            if 0 <= q < n_cells and hits.size:
                out[idx + (j,)] = hits[-1]
    return out


def _lookups(keys, neg, queries, n_cells, mode):
    """``table_lookup`` of the keys of ``test_table_lookup_...``: of one row, under two
    vmaps (of ``keys`` and of ``neg``), and of each row of ``keys[0]`` with the queries
    ``queries[0, 0]`` shared (as a 3 x 3 array); and the position tables of ``neg`` under
    two vmaps. ``mode`` (static) is not used: it keys the compiled program, which depends
    on the constants the test patches."""
    two = jax.vmap(jax.vmap(lambda k, q: table_lookup(k, q, n_cells)))
    shared = queries[0, 0].reshape(3, 3)
    return (table_lookup(keys[1, 2], queries[1, 2], n_cells), two(keys, queries),
            two(neg, queries), jax.vmap(lambda k: table_lookup(k, shared, n_cells))(keys[0]),
            jax.vmap(jax.vmap(lambda k: position_table(k, n_cells)))(neg))


_LOOKUPS = jax.jit(_lookups, static_argnums=(3, 4))


@pytest.mark.parametrize("mode", ["at_once", "chunked", "batched_rows"])
def test_table_lookup_is_the_table_gather_at_any_vmap_depth(monkeypatch, mode):
    """``table_lookup`` returns what building ``position_table`` and gathering from it
    returns, with -1 for queries off the table; built at once, above
    ``LOOKUP_DIRECT_MAX`` entries in chunks of rows (a row count that is not a multiple
    of the chunk included), and with per-row tables where flat indices would overflow."""
    if mode == "chunked":
        monkeypatch.setattr(scatter, "LOOKUP_DIRECT_MAX", 64)
        monkeypatch.setattr(scatter, "LOOKUP_CHUNK_ENTRIES", 3 * 50)
    if mode == "batched_rows":
        monkeypatch.setattr(scatter, "MAX_FLAT_ENTRIES", 10)
    n_cells = 50
    rng = np.random.default_rng(7)
    keys = rng.integers(0, n_cells + 3, (3, 7, 20)).astype(np.int32)  # repeats, off-table
    queries = rng.integers(-2, n_cells + 2, (3, 7, 9)).astype(np.int32)
    want = _lookup_reference(keys, queries, n_cells)
    neg = keys.copy()
    neg[:, :, ::5] = -1
    one, two, two_neg, got, table = (np.asarray(x) for x in
                                     _LOOKUPS(keys, neg, queries, n_cells, mode))
    np.testing.assert_array_equal(two, want)
    np.testing.assert_array_equal(one, want[1, 2])
    # negative keys count from the end, as in position_table (built under the same
    # patched constants)
    np.testing.assert_array_equal(table, _table_reference(neg, n_cells))
    gathered = np.take_along_axis(table, np.clip(queries, 0, n_cells - 1), axis=-1)
    np.testing.assert_array_equal(
        two_neg, np.where((queries >= 0) & (queries < n_cells), gathered, -1))
    # shared queries, per-row keys; 2-D queries
    np.testing.assert_array_equal(
        got.reshape(7, 9), _lookup_reference(keys[0], np.broadcast_to(queries[0, 0], (7, 9)),
                                             n_cells))
