"""Per-map lookup tables, computed once per run instead of once per generation.

Several operators read a table of the whole map: the legal moves of every cell (the
walks of the initialisers and of Zhu's range mutation, the field walks), the free
8-neighbours of every cell (median insertion: IMGA's and MPMGA's connections, the
mutations that reconnect), the legal steps of every cell (MPMGA's heterologous
crossover) and the free-cell prefix counts of every row and column (Zhu's column
crossover). Inside the generation loop XLA computes them again every generation (it does
not hoist computations whose outputs outgrow their inputs), a cost that grows with the
map (decision 008). :func:`with_tables` computes them once and attaches them to
the grid (``Grid.tables``); every function that reads such a table takes it from there
when present, so the results are the same bit for bit. :func:`jaxga.run` attaches them
to every run's grid.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from jaxga.core.grid import Grid
from jaxga.operators.column_crossover import compute_free_prefix
from jaxga.operators.crossover import step_masks
from jaxga.operators.init import compute_move_tables
from jaxga.operators.repair import compute_neighbour_masks

__all__ = ["MapTables", "with_tables"]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class MapTables:
    """The tables of one map and corner rule (flat, cell index ``y * W + x``).

    Attributes:
        nbr: ``int32[8 H W]``, neighbour ``d`` of cell ``p`` at ``8 p + d``
            (:func:`jaxga.operators.init.common.move_tables`).
        legal: ``bool[8 H W]``, whether that move is legal.
        masks: ``int32[H W]``, free neighbours and the cell itself as bits
            (:func:`jaxga.operators.repair.neighbour_masks`).
        step_masks: ``int32[H W]``, legal steps as bits
            (:func:`jaxga.operators.crossover.step_masks`).
        free_prefix: free-cell prefix counts of columns and rows
            (:func:`jaxga.operators.column_crossover.compute_free_prefix`).
    """

    nbr: jax.Array
    legal: jax.Array
    masks: jax.Array
    step_masks: jax.Array
    free_prefix: jax.Array


@jax.jit
def compute_tables(grid: Grid) -> MapTables:
    """The :class:`MapTables` of ``grid`` (a grid without guide or tables), one program."""


    nbr, legal = compute_move_tables(grid)
    bare = dataclasses.replace(grid, tables=None, guide=None)
    steps = step_masks(bare, jnp.arange(grid.n_cells, dtype=jnp.int32))
    return MapTables(nbr=nbr, legal=legal, masks=compute_neighbour_masks(grid),
                     step_masks=steps, free_prefix=compute_free_prefix(grid))


def with_tables(grid: Grid) -> Grid:
    """``grid`` with its :class:`MapTables` attached (``grid.tables``), computed once."""
    if grid.tables is not None:
        return grid
    return dataclasses.replace(grid, tables=compute_tables(dataclasses.replace(grid, guide=None)))
