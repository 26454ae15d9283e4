"""Scatters that stay ONE flat scatter under ``vmap``.

Every operator of jaxga is written for one individual and lifted with ``vmap`` over
individuals, islands and seeds (docs, "the pure core"). ``vmap`` turns a scatter into a batched
scatter, and XLA's CPU backend then builds an index vector per batch dimension for
every update (a ``[updates, batch dims + 1]`` concatenation) before a serial update
loop: for the crossovers' position tables that index construction cost more than the
scatter itself. :func:`position_table` carries a
:func:`jax.custom_batching.custom_vmap` rule that folds every ``vmap`` level into one
more leading dimension, and computes all rows with a single 1-D scatter into a flat
table of ``rows * n`` entries, offsetting each row's indices by ``row * n``.

Results are bit-for-bit those of the plain ``.at[]`` scatter (integer maxima are
order-independent). Indices follow ``.at[]``: negative ones count from the end, others
outside the table are dropped. Only the map-sized position tables use this: small
scatters such as the connection's node table stay batched scatters, which are cheaper
there (decision 007).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.custom_batching import custom_vmap

from jaxga._batching.folding import fold_call

__all__ = ["position_table", "table_lookup", "true_first_order", "true_first_positions"]

MAX_FLAT_ENTRIES = int(np.iinfo(np.int32).max)
"""Flat tables must stay below this many entries (int32 indices); larger batches of rows
fall back to one batched scatter."""


def _flat_indices(idx: jax.Array, n: int) -> tuple[jax.Array, int]:
    """Row-offset flat indices of ``idx[..., k]`` into ``rows * n`` entries; the
    out-of-table ones point past the end (dropped)."""
    lead = idx.shape[:-1]
    rows = int(np.prod(lead, dtype=np.int64))
    k = idx.reshape(rows, idx.shape[-1])
    k = jnp.where(k < 0, k + n, k)  # NumPy-style negative indices, as .at[] does
    inside = (k >= 0) & (k < n)
    base = (jnp.arange(rows, dtype=jnp.int32) * n)[:, None]
    return jnp.where(inside, k + base, rows * n).reshape(-1), rows


def position_table(keys: jax.Array, n_cells: int) -> jax.Array:
    """``int32[n_cells]``: ``table[c]`` = the last position ``i`` with ``keys[i] == c``, or -1.

    ``keys`` is ``int32[L]``. Equal to ``full(n_cells, -1).at[keys].max(arange(L),
    mode="drop")``. Used by :func:`jaxga.core.paths.position_lookup` and
    :func:`jaxga.core.paths.last_occurrence` (the crossovers' "where is this cell in the other
    parent" and loop removal): faster than the batched scatter on 20 x 20 and 50 x 50
    maps (decision 007).
    """
    return _position_table_fn(int(n_cells))(jnp.asarray(keys, jnp.int32))


def _rows_flat(keys: jax.Array, n_cells: int) -> jax.Array:
    """``int32[..., L] -> int32[..., n_cells]``: every row's table from one flat scatter."""
    flat, r = _flat_indices(keys, n_cells)
    pos = jnp.broadcast_to(jnp.arange(keys.shape[-1], dtype=jnp.int32), keys.shape)
    table = jnp.full((r * n_cells,), -1, jnp.int32)
    table = table.at[flat].max(pos.reshape(-1), mode="drop")
    return table.reshape(keys.shape[:-1] + (n_cells,))


def _rows_batched(keys: jax.Array, n_cells: int) -> jax.Array:
    """The same tables from one batched scatter (no flat index can overflow)."""

    def one_row(k: jax.Array) -> jax.Array:
        i = jnp.arange(k.shape[-1], dtype=jnp.int32)
        return jnp.full((n_cells,), -1, jnp.int32).at[k].max(i, mode="drop")

    r = int(np.prod(keys.shape[:-1], dtype=np.int64))
    tables = jax.vmap(one_row)(keys.reshape(r, keys.shape[-1]))
    return tables.reshape(keys.shape[:-1] + (n_cells,))


@functools.cache
def _position_table_fn(n_cells: int) -> Callable:
    """The ``custom_vmap`` function of :func:`position_table` for one table size."""

    def rows(keys: jax.Array) -> jax.Array:  # int32[..., L] -> int32[..., n_cells]
        r = int(np.prod(keys.shape[:-1], dtype=np.int64))
        if r * n_cells >= MAX_FLAT_ENTRIES:  # flat int32 indices would overflow
            return _rows_batched(keys, n_cells)
        return _rows_flat(keys, n_cells)

    @custom_vmap
    def table(keys: jax.Array) -> jax.Array:
        return rows(keys)

    @table.def_vmap
    def _batched(axis_size, in_batched, keys):
        # the batch axis is axis 0: one more leading dimension of the same flat scatter
        return table(keys), True

    return table


LOOKUP_DIRECT_MAX = 1 << 22
"""Up to this many table entries (16 MiB of int32) :func:`table_lookup` builds all rows'
tables at once; more are built and read in chunks of :data:`LOOKUP_CHUNK_ENTRIES`."""

LOOKUP_CHUNK_ENTRIES = 1 << 16
"""Table entries (256 KiB of int32) per chunk of a large :func:`table_lookup`."""


def table_lookup(keys: jax.Array, queries: jax.Array, n_cells: int) -> jax.Array:
    """``position_table(keys, n_cells)[queries]``, with -1 for queries outside
    ``[0, n_cells)``; ``queries`` of any shape.

    The same values as building the table and gathering from it (one flat scatter and
    one flat gather for all rows of every ``vmap`` level, folded by
    :func:`jaxga._batching.folding.fold_call`). When all rows' tables would
    exceed :data:`LOOKUP_DIRECT_MAX` entries they are built and read in chunks of
    :data:`LOOKUP_CHUNK_ENTRIES` (a ``lax.map`` over chunks of rows), so that each
    chunk's tables stay in the cache between the scatter and the gather (built all at
    once, a generation's tables outgrow the caches: decision 007).
    :func:`jaxga.core.paths.position_lookup` uses it on
    maps of more than :data:`jaxga.core.paths.CHUNKED_LOOKUP_CELLS` cells.
    """
    queries = jnp.asarray(queries, jnp.int32)

    def client(lead, lanes, operands, axes):
        k, q = lanes if lead else (x[None] for x in lanes)
        out = _lookup_chunked(k, q, int(n_cells))
        return [out if lead else out[0]]

    flat_queries = queries.reshape(-1)
    (flat,) = fold_call(client, [jnp.asarray(keys, jnp.int32), flat_queries], [], [flat_queries])
    return flat.reshape(queries.shape)


def _lookup_rows(keys: jax.Array, queries: jax.Array, n_cells: int) -> jax.Array:
    """``int32[R, L], int32[R, Q] -> int32[R, Q]``: each row's lookups in its own table."""
    inside = (queries >= 0) & (queries < n_cells)
    q = jnp.clip(queries, 0, n_cells - 1)
    if keys.shape[0] * n_cells >= MAX_FLAT_ENTRIES:  # flat int32 indices would overflow
        val = jax.vmap(lambda t, qq: t[qq])(_rows_batched(keys, n_cells), q)
    else:
        # one flat 1-D gather (a batched gather builds an index vector per lookup)
        rows = jnp.arange(keys.shape[0], dtype=jnp.int32)[:, None] * n_cells
        val = _rows_flat(keys, n_cells).reshape(-1)[rows + q]
    return jnp.where(inside, val, -1)


def _lookup_chunked(keys: jax.Array, queries: jax.Array, n_cells: int) -> jax.Array:
    """:func:`_lookup_rows`, in chunks of rows above :data:`LOOKUP_DIRECT_MAX` entries."""
    r = keys.shape[0]
    per_chunk = max(1, LOOKUP_CHUNK_ENTRIES // n_cells)
    if r * n_cells <= LOOKUP_DIRECT_MAX or r <= per_chunk:
        return _lookup_rows(keys, queries, n_cells)
    n_chunks = -(-r // per_chunk)
    pad = n_chunks * per_chunk - r
    k = jnp.concatenate([keys, jnp.full((pad, keys.shape[1]), n_cells, jnp.int32)])
    q = jnp.concatenate([queries, jnp.full((pad, queries.shape[1]), -1, jnp.int32)])
    return jax.lax.map(
        lambda kq: _lookup_rows(kq[0], kq[1], n_cells),
        (k.reshape(n_chunks, per_chunk, -1), q.reshape(n_chunks, per_chunk, -1)),
    ).reshape(n_chunks * per_chunk, -1)[:r]


def true_first_order(flags: jax.Array) -> jax.Array:
    """``int32[n]``: the indices of the True entries of ``flags`` in order, then those of
    the False entries in order; equal to ``jnp.argsort(~flags, stable=True)``.

    A prefix count and one scatter of a permutation instead of a comparison sort, which
    XLA's CPU backend runs much more slowly (decision 004).
    """
    pos = true_first_positions(flags)
    n = pos.shape[0]
    return jnp.zeros((n,), jnp.int32).at[pos].set(jnp.arange(n, dtype=jnp.int32),
                                                  unique_indices=True)


def true_first_positions(flags: jax.Array) -> jax.Array:
    """``int32[n]``: the position of each entry in :func:`true_first_order` (its inverse
    permutation), from a prefix count alone: no scatter, no sort."""
    flags = jnp.asarray(flags, bool)
    i = jnp.arange(flags.shape[0], dtype=jnp.int32)
    trues = jax.lax.associative_scan(jnp.add, flags.astype(jnp.int32))  # inclusive
    return jnp.where(flags, trues - 1, trues[-1] + i - trues)
