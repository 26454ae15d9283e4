"""Flat scatters under vmap (jaxga._batching.scatter): the same tables as a plain .at[] scatter."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._batching import scatter
from jaxga._batching.scatter import position_table, table_lookup


def _nest(fn, depth):
    for _ in range(depth):
        fn = jax.vmap(fn)
    return fn


@pytest.mark.parametrize("shape", [(12,), (7, 12), (3, 5, 12)])
def test_position_table_is_the_scatter_max_at_any_vmap_depth(shape):
    """``table.at[keys].max(arange(L), mode="drop")`` per row, with negative (counted from
    the end) and off-table keys."""
    n_cells = 20
    keys = jnp.asarray(np.random.default_rng(3).integers(-25, 25, shape), jnp.int32)

    def ref(k):
        i = jnp.arange(k.shape[0], dtype=jnp.int32)
        return jnp.full((n_cells,), -1, jnp.int32).at[k].max(i, mode="drop")

    depth = len(shape) - 1
    want = np.asarray(_nest(ref, depth)(keys))
    got = np.asarray(jax.jit(_nest(lambda k: position_table(k, n_cells), depth))(keys))
    assert got.dtype == np.int32 and got.shape == shape[:-1] + (n_cells,)
    assert np.array_equal(got, want)
    assert (want >= 0).any() and (want == -1).any()  # both outcomes are exercised


def test_the_flat_and_the_batched_rows_give_the_same_tables():
    """position_table computes a batch of rows with one flat scatter, or (beyond
    MAX_FLAT_ENTRIES = 2**31 - 1 entries, where int32 flat indices would overflow) with
    one batched scatter: both equal the per-row scatter."""
    from jaxga._batching.scatter import MAX_FLAT_ENTRIES, _rows_batched, _rows_flat

    assert MAX_FLAT_ENTRIES == 2**31 - 1
    keys = jnp.asarray(np.random.default_rng(5).integers(-13, 12, (4, 6, 9)), jnp.int32)
    want = np.asarray(jax.vmap(jax.vmap(lambda k: position_table(k, 10)))(keys))
    assert np.array_equal(np.asarray(_rows_flat(keys, 10)), want)
    assert np.array_equal(np.asarray(_rows_batched(keys, 10)), want)


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
    one = jax.jit(lambda k, q: table_lookup(k, q, n_cells))
    two = jax.jit(jax.vmap(jax.vmap(lambda k, q: table_lookup(k, q, n_cells))))
    np.testing.assert_array_equal(two(keys, queries), want)
    np.testing.assert_array_equal(one(keys[1, 2], queries[1, 2]), want[1, 2])
    # negative keys count from the end, as in position_table
    neg = keys.copy()
    neg[:, :, ::5] = -1
    table = np.asarray(jax.vmap(jax.vmap(lambda k: position_table(k, n_cells)))(neg))
    gathered = np.take_along_axis(table, np.clip(queries, 0, n_cells - 1), axis=-1)
    np.testing.assert_array_equal(
        two(neg, queries), np.where((queries >= 0) & (queries < n_cells), gathered, -1))
    # shared queries, per-row keys; 2-D queries
    shared = jax.jit(jax.vmap(lambda k: table_lookup(k, queries[0, 0].reshape(3, 3), n_cells)))
    got = shared(keys[0])
    np.testing.assert_array_equal(
        got.reshape(7, 9), _lookup_reference(keys[0], np.broadcast_to(queries[0, 0], (7, 9)),
                                             n_cells))
