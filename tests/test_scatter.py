"""Flat scatters under vmap (jaxga.scatter): the same tables as the plain .at[] scatter."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga.scatter import position_table


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
    from jaxga.scatter import MAX_FLAT_ENTRIES, _rows_batched, _rows_flat

    assert MAX_FLAT_ENTRIES == 2**31 - 1
    keys = jnp.asarray(np.random.default_rng(5).integers(-13, 12, (4, 6, 9)), jnp.int32)
    want = np.asarray(jax.vmap(jax.vmap(lambda k: position_table(k, 10)))(keys))
    assert np.array_equal(np.asarray(_rows_flat(keys, 10)), want)
    assert np.array_equal(np.asarray(_rows_batched(keys, 10)), want)
