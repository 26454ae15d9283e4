"""The geometry of one masked path that every objective and metric shares: its nodes with
the padding and repeated nodes resolved, its segment vectors, and whether each node turns
(:func:`geometry`), in exact int32 arithmetic (the conventions of
:mod:`jaxga.core.objectives`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, step_ends

__all__ = ["MAX_SIDE", "Geometry", "Scalar", "as_f32", "atan2_nonneg", "check_grid",
           "fill_forward", "geometry", "path_nodes"]

MAX_SIDE = 32767
"""Largest map side for which the int32 cross/dot products cannot overflow."""

Scalar = float | jax.Array


def as_f32(v: Scalar) -> jax.Array:
    return jnp.asarray(v, dtype=F32)


def check_grid(grid: Grid) -> tuple[int, int]:
    h, w = grid.blocked.shape
    if max(h, w) > MAX_SIDE:
        raise ParameterError(
            f"objectives support maps up to {MAX_SIDE} cells per side, got {w} x {h}"
        )
    return h, w


def atan2_nonneg(y: jax.Array, x: jax.Array) -> jax.Array:
    """``atan2(y, x)`` for ``y >= 0`` (so the result lies in ``[0, pi]``), float32.

    Branch-free: reduce to ``t = min/max`` in ``[0, 1]``, halve the angle once
    (``atan t = 2 atan(t / (1 + sqrt(1 + t^2)))``, argument at most ``tan(pi/8)``), sum
    the odd Taylor series to degree 17 (truncation error < 1e-8), then undo the octant
    reduction. ``atan2(0, 0)`` is 0.
    """
    y = y.astype(F32)
    x = x.astype(F32)
    ax = jnp.abs(x)
    swap = y > ax
    num = jnp.where(swap, ax, y)
    den = jnp.where(swap, y, ax)
    t = num / jnp.where(den > 0, den, jnp.ones_like(den))
    u = t / (1.0 + jnp.sqrt(1.0 + t * t))
    u2 = u * u
    series = jnp.zeros_like(u2)
    for k in range(17, 1, -2):  # Horner in u^2: 1 - u2/3 + u2^2/5 - ...
        series = u2 * (((-1) ** ((k - 1) // 2)) / k + series)
    a = 2.0 * u * (1.0 + series)
    a = jnp.where(swap, np.float32(math.pi / 2) - a, a)
    return jnp.where(x < 0, np.float32(math.pi) - a, a)


def fill_forward(key: jax.Array, vx: jax.Array, vy: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Carry ``(vx, vy)`` forward from the last position whose ``key`` is not -1.

    ``key[j]`` is ``j`` at positions that hold a value and -1 at holes. The result is
    ``v[m[j]]`` with ``m`` the running maximum of ``key`` (positions before the first
    value keep their own). Computed by pointer doubling: pass ``p`` lets each position
    take the pair ``(key, v)`` from ``2**p`` positions to its left when that key is
    larger, so after ``p`` passes ``key[j]`` is the maximum over the ``2**p`` positions
    ending at ``j``; the loop stops as soon as ``key`` is non-decreasing, which is
    exactly when it equals its running maximum. Paths without repeated interior nodes
    have no holes and run zero passes; otherwise ``ceil(log2(r + 1))`` passes for the
    longest run of ``r`` holes. (Under ``vmap`` every path of the batch runs the
    batch's largest pass count, so the passes double rather than fill one hole each:
    decision 009.)
    """

    n = key.shape[0]

    def holes(state):
        s, k = state[0], state[1]
        # s >= n: every window covers the whole prefix, k is the running maximum (the
        # bound only guarantees termination; it never stops the loop early)
        return jnp.any(k[1:] < k[:-1]) & (s < n)

    def shifted(v, s, fill):
        # v moved s positions to the right, the first s filled: a dynamic slice (s is the
        # same for every path of a batch, so it stays a slice under vmap, not a gather)
        return jax.lax.dynamic_slice(jnp.concatenate([jnp.full((n,), fill, v.dtype), v]),
                                     (n - s,), (n,))

    def shift(state):
        s, k, ax, ay = state
        k_prev = shifted(k, s, -1)
        take = k_prev > k  # a filled -1 never beats a key (keys are >= -1)
        return (
            2 * s,
            jnp.where(take, k_prev, k),
            jnp.where(take, shifted(ax, s, 0), ax),
            jnp.where(take, shifted(ay, s, 0), ay),
        )

    if n < 2:
        return vx, vy
    _, _, vx, vy = jax.lax.while_loop(holes, shift, (jnp.int32(1), key, vx, vy))
    return vx, vy


class Geometry(NamedTuple):
    """Per-path quantities shared by the objectives (internal)."""

    cells: jax.Array  # int32[L], padding normalised to the last valid cell
    x: jax.Array  # int32[L]
    y: jax.Array  # int32[L]
    node: jax.Array  # bool[L]: a valid node that differs from its predecessor
    dx: jax.Array  # int32[L-1]: segment j = node j -> node j+1
    dy: jax.Array
    moving: jax.Array  # bool[L-1]: non-zero segment
    cross: jax.Array  # int32[L-1]: incoming x segment j (0 where no incoming)
    dot: jax.Array  # int32[L-1]
    turning: jax.Array  # bool[L-1]: the path turns where segment j starts
    ends: tuple  # ((x_a, y_a), (x_b, y_b)), int32[L-1] each: segment j's two ends
    #              (jaxga.core.grid.step_ends: from the cells sliced first, decision 048)


def path_nodes(
    grid: Grid, cells: jax.Array, length: jax.Array
) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]:
    """``(cells, x, y, node, n)``: padding normalised, coordinates, real-node mask, length."""
    _, w = check_grid(grid)
    cells = jnp.asarray(cells, dtype=jnp.int32)
    cap = cells.shape[0]
    n = jnp.clip(jnp.asarray(length, dtype=jnp.int32), 1, cap)
    j = jnp.arange(cap, dtype=jnp.int32)
    cells = jnp.where(j < n, cells, cells[n - 1])
    x = cells % jnp.int32(w)
    y = cells // jnp.int32(w)
    first = jnp.concatenate([jnp.ones((1,), bool), cells[1:] != cells[:-1]])
    return cells, x, y, first & (j < n), n


def geometry(grid: Grid, cells: jax.Array, length: jax.Array) -> Geometry:
    cells, x, y, node, n = path_nodes(grid, cells, length)
    j = jnp.arange(cells.shape[0], dtype=jnp.int32)
    ends = (xa, ya), (xb, yb) = step_ends(cells, grid.width)  # not x[1:] - x[:-1]: 048
    dx = xb - xa
    dy = yb - ya
    moving = (dx != 0) | (dy != 0)
    # Direction of the last non-zero segment at or before j. Tail padding (j >= n-1) is
    # marked as "has a value" too: it lies after every real segment, so it never feeds
    # a real turn, and it keeps paths without interior repeats hole-free (zero passes).
    js = j[:-1]
    key = jnp.where(moving | (js >= n - 1), js, jnp.int32(-1))
    px, py = fill_forward(key, dx, dy)
    zero = jnp.zeros((min(1, cells.shape[0] - 1),), jnp.int32)
    in_x = jnp.concatenate([zero, px[:-1]])
    in_y = jnp.concatenate([zero, py[:-1]])
    cross = in_x * dy - in_y * dx
    dot = in_x * dx + in_y * dy
    has_in = (in_x != 0) | (in_y != 0)
    turning = moving & has_in & ((cross != 0) | (dot < 0))
    return Geometry(cells, x, y, node, dx, dy, moving, cross, dot, turning, ends)
