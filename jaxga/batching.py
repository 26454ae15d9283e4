"""The one small helper that applies per-individual operators to a population.

Every operator of jaxga is written for ONE individual (or one pair) as a pure function of
an explicit PRNG key (SPEC 2). This module lifts such functions to a population with
``jax.vmap``, splitting the key so that individual ``i`` always gets the same sub-key
for the same population key (same key, same result), and it implements the common
failure contract: an operator that fails for an individual (capacity overflow, a
connection that does not close, ...) returns its input unchanged, and the population
helper returns how many individuals failed.

Conventions:

* mutation-like operators: ``op(key, grid, cells, length, *args) -> (cells, length, failed)``
* pair operators (crossover): ``op(key, grid, c1, l1, c2, l2, *args) -> (c1, l1, c2, l2, failed)``
  where ``failed`` is a bool or an int count for the pair.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from jaxga.grid import Grid
from jaxga.paths import Population

__all__ = ["keep_parent_on_failure", "over_individuals", "over_pairs"]


def keep_parent_on_failure(
    failed: jax.Array,
    new_cells: jax.Array,
    new_length: jax.Array,
    cells: jax.Array,
    length: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """Return the parent where ``failed`` (SPEC 2: a failed operator keeps its parent)."""
    return jnp.where(failed, cells, new_cells), jnp.where(failed, length, new_length)


def over_individuals(op: Callable, *, in_axes_extra: tuple = ()) -> Callable:
    """Lift ``op(key, grid, cells, length, *extra)`` to ``(key, grid, pop, *extra)``.

    Returns a function giving ``(Population, n_failed int32)``. ``in_axes_extra`` gives
    the vmap axes of the extra arguments (default: all mapped along axis 0).
    """

    def lifted(key: jax.Array, grid: Grid, pop: Population, *extra):
        keys = jax.random.split(key, pop.size)
        axes = (0, None, 0, 0) + (in_axes_extra or (0,) * len(extra))
        cells, length, failed = jax.vmap(op, in_axes=axes)(
            keys, grid, pop.cells, pop.length, *extra
        )
        return Population(cells, length), jnp.sum(failed, dtype=jnp.int32)

    lifted.__name__ = getattr(op, "__name__", "op") + "_population"
    lifted.__doc__ = f"``{lifted.__name__[:-11]}`` applied to every individual (vmap)."
    return lifted


def over_pairs(op: Callable, *, in_axes_extra: tuple = ()) -> Callable:
    """Lift a pair operator to a population: pairs are (0, 1), (2, 3), ...

    ``op(key, grid, c1, l1, c2, l2, *extra) -> (c1, l1, c2, l2, failed)``. With an odd
    population the last individual passes through unchanged. Returns
    ``(Population, n_failed int32)``. Shuffle the population first (selection does) if
    pairs should be random.
    """

    def lifted(key: jax.Array, grid: Grid, pop: Population, *extra):
        n_pairs = pop.size // 2
        keys = jax.random.split(key, max(n_pairs, 1))[:n_pairs]
        c, ln = pop.cells, pop.length
        axes = (0, None, 0, 0, 0, 0) + (in_axes_extra or (0,) * len(extra))
        c1, l1, c2, l2, failed = jax.vmap(op, in_axes=axes)(
            keys, grid, c[0 : 2 * n_pairs : 2], ln[0 : 2 * n_pairs : 2],
            c[1 : 2 * n_pairs : 2], ln[1 : 2 * n_pairs : 2], *extra,
        )
        cells = jnp.stack([c1, c2], axis=1).reshape(2 * n_pairs, -1)
        length = jnp.stack([l1, l2], axis=1).reshape(-1)
        if pop.size % 2:
            cells = jnp.concatenate([cells, c[-1:]], axis=0)
            length = jnp.concatenate([length, ln[-1:]], axis=0)
        return Population(cells, length), jnp.sum(failed, dtype=jnp.int32)

    lifted.__name__ = getattr(op, "__name__", "op") + "_population"
    lifted.__doc__ = f"``{lifted.__name__[:-11]}`` applied to consecutive pairs (vmap)."
    return lifted
