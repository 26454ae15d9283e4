"""Flat scatters under vmap (jaxga.scatter): the same tables as the plain .at[] scatters."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga.scatter import position_table, set_drop


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


@pytest.mark.parametrize("depth", [0, 1, 2])
@pytest.mark.parametrize("shared_table", [False, True])
def test_set_drop_is_the_plain_set(depth, shared_table):
    """``table.at[idx].set(vals, mode="drop")`` for distinct indices, in and out of range
    and negative, with the table batched or shared across the vmap."""
    rng = np.random.default_rng(depth)
    batch = (4, 3)[:depth]
    n, k = 16, 6
    # distinct after wrapping: -3..-1 stand for n-3..n-1, which are left out
    pool = np.concatenate([np.arange(-3, n - 3), np.arange(n, n + 3)])
    idx = np.stack([rng.permutation(pool)[:k]
                    for _ in range(int(np.prod(batch)))]).reshape(batch + (k,))
    vals = rng.integers(100, 200, batch + (k,))
    table = rng.integers(0, 9, (n,) if shared_table else batch + (n,))

    def ref(t, i, v):
        return t.at[i].set(v, mode="drop")

    axes = (None if shared_table else 0, 0, 0)
    f_ref, f_new = ref, set_drop
    for _ in range(depth):
        f_ref, f_new = jax.vmap(f_ref, in_axes=axes), jax.vmap(f_new, in_axes=axes)
    args = [jnp.asarray(a, jnp.int32) for a in (table, idx, vals)]
    want = np.asarray(f_ref(*args))
    got = np.asarray(jax.jit(f_new)(*args))
    assert np.array_equal(got, want)
    assert (want >= 100).any() and (want < 100).any()
