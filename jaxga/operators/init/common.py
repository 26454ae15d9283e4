"""What every initialiser shares: the capacity check, the per-map move tables, the free cells,
the masked chromosome of a drawn path."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core.dtypes import I32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import DIRECTIONS, Grid, in_bounds, move_legal
from jaxga.core.paths import (
    pad,
)

InitFn = Callable[[jax.Array, Grid, int], tuple[jax.Array, jax.Array, jax.Array]]
"""``init_fn(key, grid, capacity) -> (cells int32[capacity], length int32, ok bool)``."""


_DX = np.asarray(DIRECTIONS[:, 0], np.int32)


_DY = np.asarray(DIRECTIONS[:, 1], np.int32)


# ------------------------------------------------------------------------ helpers
def check_capacity(capacity: int) -> int:
    if not isinstance(capacity, (int, np.integer)) or capacity < 1:
        raise ParameterError(f"capacity must be a positive Python int, got {capacity!r}")
    return int(capacity)


def move_tables(grid: Grid) -> tuple[jax.Array, jax.Array]:
    """``(nbr int32[n*8], legal bool[n*8])``: neighbour ``d`` of cell ``p`` is entry ``8p+d``.

    Directions are :data:`jaxga.core.grid.DIRECTIONS`; an off-map neighbour is stored as ``p``
    itself with ``legal`` False. ``legal`` is :func:`jaxga.core.grid.move_legal` (both cells
    free, corner rule for diagonals). Read from ``grid.tables`` when attached
    (:func:`jaxga.engine.maptables.with_tables`).
    """
    if grid.tables is not None:
        return grid.tables.nbr, grid.tables.legal
    return compute_move_tables(grid)


def compute_move_tables(grid: Grid) -> tuple[jax.Array, jax.Array]:
    """:func:`move_tables` computed from the map (what :mod:`jaxga.engine.maptables` stores)."""
    h, w = grid.shape
    p = jnp.arange(grid.n_cells, dtype=I32)[:, None]
    nx, ny = p % w + _DX, p // w + _DY
    inside = in_bounds(nx, ny, h, w)
    nbr = jnp.where(inside, ny * w + nx, p)
    legal = inside & move_legal(grid, p, nbr)
    return nbr.reshape(-1), legal.reshape(-1)


def write_at(buf: jax.Array, i: jax.Array, value: jax.Array) -> jax.Array:
    """``buf.at[i].set(value, mode="drop")`` for a scalar ``i``, as an elementwise select.

    A walk writes one path cell per step; under ``vmap`` the scatter form becomes one
    batched scatter per step, the construct suspected in an accelerator's wrong initial
    populations (docs/devices.md, "Exactness"). The select computes the same bits on
    every backend from elementwise operations alone. Jittable.
    """
    return jnp.where(jnp.arange(buf.shape[0], dtype=I32) == i, value, buf)


def exclusion_mask(grid: Grid, exclude: jax.Array | None) -> jax.Array:
    """``bool[H*W]`` mask of cells a self-avoiding walk must not enter.

    ``exclude`` may be None (nothing excluded), a boolean mask of shape ``(H*W,)`` or
    ``(H, W)`` (True = excluded), or an integer array of cell indices of any shape, in
    which entries outside ``[0, H*W)`` (e.g. ``-1`` padding) are ignored. Jittable.
    """
    n = grid.n_cells
    if exclude is None:
        return jnp.zeros((n,), bool)
    exclude = jnp.asarray(exclude)
    if exclude.dtype == jnp.bool_:
        if exclude.size != n or exclude.ndim not in (1, 2):
            raise ParameterError(
                f"a boolean exclude mask must have shape ({n},) or {grid.shape}, "
                f"got {exclude.shape}"
            )
        return exclude.reshape(-1)
    if not jnp.issubdtype(exclude.dtype, jnp.integer):
        raise ParameterError(f"exclude must be a bool mask or integer cells, got {exclude.dtype}")
    cells = exclude.reshape(-1).astype(I32)
    valid = (cells >= 0) & (cells < n)
    return jnp.zeros((n,), bool).at[jnp.where(valid, cells, n)].set(True, mode="drop")


def free_cells(grid: Grid, allow: jax.Array | None = None) -> tuple[jax.Array, jax.Array]:
    """``(cells int32[n], count)``: the free cells (and ``allow``) first, in index order."""
    ok = ~grid.blocked.reshape(-1)
    if allow is not None:
        ok &= allow
    order = jnp.argsort(~ok, stable=True).astype(I32)
    return order, jnp.sum(ok, dtype=I32)


def pick_cell(bits: jax.Array, table: jax.Array, count: jax.Array) -> jax.Array:
    """``table[bits mod count]``: uniform over ``table[:count]`` (bias <= count / 2**32)."""
    i = (bits % jnp.maximum(count, 1).astype(jnp.uint32)).astype(I32)
    return table[i]


def fit_to_capacity(
    cells: jax.Array, length: jax.Array, ok: jax.Array, capacity: int
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Cut or pad a loop-free path of any buffer size to ``capacity``; fail if too long."""
    if cells.shape[0] >= capacity:
        cells = cells[:capacity]
    else:
        cells = jnp.concatenate([cells, jnp.full((capacity - cells.shape[0],), cells[-1], I32)])
    ok = ok & (length <= capacity)
    length = jnp.minimum(length, capacity)
    return pad(cells, length), length, ok
