"""Floating-point sums whose rounding does not depend on the batch they are computed in.

XLA's CPU backend vectorises a reduction such as ``jnp.sum(x, axis=-1)`` differently
depending on the whole array's shape: under ``vmap``, the same row summed in a batch of
1 and in a batch of 64 can differ in the last bit, for many rows, not a rare few
(decision 044; ``tests/batching/test_numerics.py``). jaxga computes runs in
blocks whose size depends on the number of runs and of devices
(``jaxga._runtime.programs.map_runs``), so a path
length, a fitness or a population mean summed that way would depend on how many seeds
were run alongside and on how many devices ran them: a seed would not give the same
result alone and with others, and ranking ties or roulette draws could turn on it.

:func:`ordered_sum` adds in one fixed pairwise order (a balanced tree of element-wise
additions of slices, zero-padded to a power of two). Element-wise IEEE additions are
exact functions of their operands and XLA does not re-associate floating-point
additions, so each row's sum is the same bits whatever the batch around it. The tree
also has the error bound of pairwise summation (``O(log n)`` ulps rather than ``O(n)``).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

__all__ = ["ordered_mean", "ordered_sum"]


def ordered_sum(x: jax.Array, axis: int = -1, dtype=None) -> jax.Array:
    """Sum of ``x`` along ``axis`` in a fixed pairwise order (batch-invariant rounding).

    Same value as ``jnp.sum(x, axis, dtype)`` up to rounding; bit-identical for a row
    whatever the leading (batch) shape. Integer and boolean inputs are summed exactly
    with ``jnp.sum`` (their sums do not depend on the order). ``axis``: one axis.
    """
    x = jnp.asarray(x)
    if dtype is not None:
        x = x.astype(dtype)
    if not jnp.issubdtype(x.dtype, jnp.inexact):
        return jnp.sum(x, axis=axis, dtype=dtype)
    x = jnp.moveaxis(x, axis, -1)
    n = x.shape[-1]
    if n == 0:
        return jnp.zeros(x.shape[:-1], x.dtype)
    size = 1 << (n - 1).bit_length()
    if size != n:
        x = jnp.concatenate([x, jnp.zeros(x.shape[:-1] + (size - n,), x.dtype)], axis=-1)
    while size > 1:
        size //= 2
        x = x[..., :size] + x[..., size:]
    return x[..., 0]


def ordered_mean(x: jax.Array, where: jax.Array | None = None, axis: int = -1) -> jax.Array:
    """Mean of ``x`` (over the entries where ``where`` holds) with :func:`ordered_sum`.

    An empty selection gives 0 (the count is clamped to 1), as the population
    statistics of the engine expect.
    """
    x = jnp.asarray(x)
    if where is None:
        return ordered_sum(x, axis) / x.shape[axis]
    where = jnp.broadcast_to(jnp.asarray(where, bool), x.shape)
    count = jnp.maximum(jnp.sum(where, axis=axis, dtype=jnp.int32), 1)
    return ordered_sum(jnp.where(where, x, jnp.zeros_like(x)), axis) / count.astype(x.dtype)
