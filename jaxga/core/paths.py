"""The masked path representation and the pure functions on one path.

jaxga's representation (docs, "the pure core"). A population is ``cells: int32[P, L]`` plus
``length: int32[P]``; ``L`` is a fixed *capacity*, ``mask = arange(L) < length[:, None]``,
and the padding after ``length`` REPEATS THE LAST CELL, so that segment sums need no
branch (padded segments have zero length). Every function here is written for ONE path
``(cells: int32[L], length: int32)``, is pure and jittable, and is applied to a
population with ``jax.vmap`` (see :func:`population_map`).

A path ``c0 = start, ..., ck = goal`` is *continuous* when consecutive cells are
8-adjacent and every move is legal under the grid's corner rule, *feasible* when every
consecutive segment is clear (line of sight, :func:`jaxga.core.geometry.clear`), and
*loop-free* when no cell occurs twice.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.scatter import position_table, table_lookup
from jaxga.core.errors import ParameterError
from jaxga.core.geometry import segments_clear
from jaxga.core.grid import Grid, blocked_at, diagonal_legal, step_ends

__all__ = [
    "Population",
    "cell_steps",
    "cells_to_xy",
    "from_coords",
    "has_endpoints",
    "is_continuous",
    "is_feasible",
    "is_loop_free",
    "last_occurrence",
    "pad",
    "population_map",
    "remove_loops",
    "to_coords",
]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Population:
    """A population of masked paths: ``cells int32[P, L]``, ``length int32[P]``."""

    cells: jax.Array
    length: jax.Array

    @property
    def size(self) -> int:
        """Number of individuals ``P``."""
        return self.cells.shape[0]

    @property
    def capacity(self) -> int:
        """Capacity ``L`` (the most nodes a path can hold)."""
        return self.cells.shape[1]

    def mask(self) -> jax.Array:
        """``bool[P, L]``: True on the valid nodes of each path."""
        return jnp.arange(self.capacity, dtype=jnp.int32) < self.length[:, None]

    @classmethod
    def from_paths(cls, paths: Sequence[Sequence[int]], capacity: int) -> Population:
        """Host-side: stack lists of cell indices into a padded population."""
        if not paths:
            raise ParameterError("a population needs at least one path")
        rows = [np.asarray(_pad_host(p, capacity)) for p in paths]
        return cls(
            cells=jnp.asarray(np.stack(rows), dtype=jnp.int32),
            length=jnp.asarray([len(p) for p in paths], dtype=jnp.int32),
        )

    def to_lists(self) -> list[list[int]]:
        """Host-side: the valid cells of every path as Python lists."""
        cells = np.asarray(self.cells)
        length = np.asarray(self.length)
        return [cells[i, : length[i]].tolist() for i in range(cells.shape[0])]


def population_map(fn: Callable, *, in_axes=None) -> Callable:
    """Lift a one-path function ``fn(grid, cells, length, ...)`` to a population.

    The grid is shared (``in_axes`` None) and ``cells``/``length`` are mapped; further
    positional arguments are mapped along axis 0 unless ``in_axes`` says otherwise.
    This is the one helper through which every per-path function reaches a population.
    """

    def lifted(grid, cells, length, *args):
        axes = in_axes if in_axes is not None else (None, 0, 0) + (0,) * len(args)
        return jax.vmap(fn, in_axes=axes)(grid, cells, length, *args)

    lifted.__name__ = getattr(fn, "__name__", "lifted") + "_population"
    lifted.__doc__ = f"Population version of ``{lifted.__name__[:-11]}`` (vmapped over paths)."
    return lifted


# ------------------------------------------------------------------ representation
def _pad_host(cells: Sequence[int], capacity: int) -> list[int]:
    cells = [int(c) for c in cells]
    if not cells:
        raise ParameterError("a path needs at least one cell")
    if len(cells) > capacity:
        raise ParameterError(
            f"path of {len(cells)} cells does not fit capacity {capacity}: raise the capacity"
        )
    return cells + [cells[-1]] * (capacity - len(cells))


def pad(cells: jax.Array, length: jax.Array) -> jax.Array:
    """Re-pad a path: every position at or beyond ``length`` repeats ``cells[length-1]``."""
    cells = jnp.asarray(cells, jnp.int32)
    i = jnp.arange(cells.shape[0], dtype=jnp.int32)
    last = cells[jnp.clip(length - 1, 0, cells.shape[0] - 1)]
    return jnp.where(i < length, cells, last)


def from_coords(xy: Sequence[Sequence[int]] | np.ndarray, width: int, capacity: int):
    """Host-side: ``(x, y)`` coordinates -> ``(cells int32[L], length int32)`` (padded).

    Raises :class:`~jaxga.core.errors.ParameterError` when the path does not fit ``capacity``
    or a coordinate is negative or not below ``width``.
    """
    arr = np.asarray(xy, dtype=np.int64).reshape(-1, 2)
    if np.any(arr < 0) or np.any(arr[:, 0] >= width):
        raise ParameterError(f"coordinates off a map of width {width}: {arr.tolist()}")
    cells = _pad_host((arr[:, 1] * width + arr[:, 0]).tolist(), capacity)
    return jnp.asarray(cells, dtype=jnp.int32), jnp.int32(arr.shape[0])


def cells_to_xy(cells: jax.Array, width: int) -> jax.Array:
    """``int32[..., 2]`` coordinates ``(x, y)`` of cell indices (jittable)."""
    cells = jnp.asarray(cells, jnp.int32)
    return jnp.stack([cells % width, cells // width], axis=-1)


def to_coords(cells: jax.Array, length: jax.Array, width: int) -> list[tuple[int, int]]:
    """Host-side: the valid part of a path as a list of ``(x, y)`` tuples."""
    c = np.asarray(cells)[: int(length)]
    return [(int(p) % width, int(p) // width) for p in c]


# ----------------------------------------------------------------------- checks
def _valid_length(cells: jax.Array, length: jax.Array) -> jax.Array:
    return (length >= 1) & (length <= cells.shape[0])


def has_endpoints(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """True when the path starts at ``grid.start`` and its last valid cell is ``grid.goal``."""
    last = cells[jnp.clip(length - 1, 0, cells.shape[0] - 1)]
    return _valid_length(cells, length) & (cells[0] == grid.start) & (last == grid.goal)


def is_continuous(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """True when every valid step is a legal 8-connected move.

    Checks the cells themselves too: a one-cell path is continuous iff that cell is free.
    The endpoints are not compared with the grid's start and goal (:func:`has_endpoints`).
    """
    cells = jnp.asarray(cells, jnp.int32)
    inside, free, span, step_ok = cell_steps(grid, cells)
    i = jnp.arange(cells.shape[0] - 1, dtype=jnp.int32)
    legal = ((span == 1) & step_ok) | (i >= length - 1)
    return _valid_length(cells, length) & jnp.all(inside) & free[0] & jnp.all(legal)


def cell_steps(grid: Grid, cells: jax.Array) -> tuple[jax.Array, ...]:
    """Per-cell and per-step facts of paths ``cells int32[..., L]``.

    Returns ``(inside bool[..., L], free bool[..., L], span int32[..., L-1],
    step_ok bool[..., L-1])``: whether each cell is on the map, whether it is on the map
    and free, the Chebyshev length of each step, and whether both ends of the step are
    free and, for a diagonal, its side cells satisfy the corner rule. A step with
    ``span == 1`` is a legal move exactly when ``step_ok`` (``move_legal``); a span-0
    step (a repeated node) is clear exactly when ``step_ok``. Each cell is looked up
    once; the coordinates of a step's ends come from the cells sliced first
    (:func:`step_ends`), not from sliced coordinates, which an H200 computed wrongly
    (decision 048).
    """
    n = grid.n_cells
    inside = (cells >= 0) & (cells < n)
    cc = jnp.clip(cells, 0, n - 1)
    free = inside & ~grid.blocked.reshape(-1)[cc]
    (xa, ya), (xb, yb) = step_ends(cc, grid.width)
    dx, dy = xb - xa, yb - ya
    span = jnp.maximum(jnp.abs(dx), jnp.abs(dy))
    step_ok = free[..., :-1] & free[..., 1:]
    if grid.corner_rule != "free":
        corner_ok = diagonal_legal(
            blocked_at(grid.blocked, xb, ya), blocked_at(grid.blocked, xa, yb),
            grid.corner_rule,
        )
        step_ok &= (dx == 0) | (dy == 0) | corner_ok
    return inside, free, span, step_ok


def is_feasible(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """True when every valid segment is clear (waypoint paths, AGACD).

    A continuous path is feasible iff it is continuous; a waypoint path may have long
    segments. The endpoints are not compared with the grid's start and goal.
    """
    cells = jnp.asarray(cells, jnp.int32)
    one_free = ~grid.blocked.reshape(-1)[jnp.clip(cells[0], 0, grid.n_cells - 1)]
    on_map = jnp.all((cells >= 0) & (cells < grid.n_cells))
    return (
        _valid_length(cells, length)
        & on_map
        & one_free
        & jnp.all(segments_clear(grid, cells, length))
    )


def is_loop_free(cells: jax.Array, length: jax.Array, n_cells: int | None = None) -> jax.Array:
    """True when no cell occurs twice among the valid nodes.

    Without ``n_cells``: a sort, O(L log L). With ``n_cells`` (the map size, static) at
    most :data:`TABLE_MAX_CELLS`: the last-occurrence table of :func:`last_occurrence`
    (cheaper than the sort on small maps; decision 008); then a valid node outside
    ``[0, n_cells)`` (off the map) also makes the result False.
    """
    cells = jnp.asarray(cells, jnp.int32)
    n = cells.shape[0]
    i = jnp.arange(n, dtype=jnp.int32)
    if _use_table(n_cells, n):
        on_map = (cells >= 0) & (cells < n_cells)
        last = last_occurrence(cells, length, n_cells)
        return jnp.all((i >= length) | (on_map & (last == i)))
    # Padding gets distinct negative keys so that it never collides with a cell.
    key = jnp.where(i < length, cells, -1 - i)
    s = jnp.sort(key)
    loop_free = ~jnp.any(s[1:] == s[:-1])
    if n_cells is not None:  # as the table variant: a valid node off the map is not
        loop_free &= jnp.all((i >= length) | ((cells >= 0) & (cells < n_cells)))
    return loop_free


# ------------------------------------------------------------------ loop removal
TABLE_MAX_CELLS = 16384
"""Maps with at most this many cells use a scatter table for :func:`last_occurrence`
(and :func:`position_lookup`, :func:`is_loop_free`), if they also have at most
:data:`TABLE_CELLS_PER_NODE` cells per node of the path."""

TABLE_CELLS_PER_NODE = 16
"""A table of the map's cells per path is used only while it is at most this many times
the path's capacity: on larger maps (64 x 64 with paths of 160 cells) a sort of the path,
so that the memory and time per path grow with the path, not with the map (decision 008).
Both give the same answers for paths on the map."""


def _use_table(n_cells: int | None, capacity: int) -> bool:
    return n_cells is not None and n_cells <= min(TABLE_MAX_CELLS,
                                                  TABLE_CELLS_PER_NODE * capacity)

CHUNKED_LOOKUP_CELLS = 1024
"""Maps with more cells read their position tables (:func:`position_lookup`,
:func:`last_occurrence`) through :func:`jaxga._batching.scatter.table_lookup`, in cache-sized chunks
(faster at 50 x 50); smaller ones build the table and gather from it (faster at 20 x 20
than through ``table_lookup``, which does not chunk there; decision 007)."""


def last_occurrence(
    cells: jax.Array, length: jax.Array, n_cells: int | None = None
) -> jax.Array:
    """``int32[L]``: for each valid position i, the last valid position holding ``cells[i]``.

    Padding positions map to themselves. With ``n_cells`` (the map size, static) at most
    :data:`TABLE_MAX_CELLS`, one scatter-max into a table of ``n_cells`` entries and one
    gather (cheaper than a sort on small maps: decision 008); otherwise, or without
    ``n_cells``, a sort, O(L log L), with no map-sized table (decision 008:
    map-sized tables become memory-bound on large maps): one sort of packed
    ``(cell, position)`` words where they fit 32 bits (:func:`_sorted_by_cell`), else a
    stable argsort. The variants agree on paths whose valid nodes lie on the map (every
    population's); a node off the map is its own last occurrence in the packed sort.
    """
    cells = jnp.asarray(cells, jnp.int32)
    n = cells.shape[0]
    i = jnp.arange(n, dtype=jnp.int32)
    valid = i < length
    if _use_table(n_cells, n):
        look = position_lookup(cells, length, n_cells)
        return jnp.where(valid, look(jnp.clip(cells, 0, n_cells - 1)), i)
    if _packable(n_cells, n):  # one sort of one array: cell and position in a word
        sk, order = _sorted_by_cell(cells, valid, n_cells)
        sk = jnp.where(sk == n_cells, -1 - i, sk)  # padding: each its own group
    else:
        key = jnp.where(valid, cells, -1 - i)
        order = jnp.argsort(key, stable=True).astype(jnp.int32)
        sk = key[order]
    is_end = jnp.concatenate([sk[1:] != sk[:-1], jnp.array([True])])
    end = jax.lax.cummin(jnp.where(is_end, i, n), reverse=True)
    return jnp.zeros(n, jnp.int32).at[order].set(order[end])


def _packable(n_cells: int | None, n: int) -> bool:
    """Whether ``(cell, position)`` pairs of a path of ``n`` nodes on a map of ``n_cells``
    cells fit one uint32 (cells up to ``n_cells`` inclusive, the padding's key)."""
    return n_cells is not None and (n_cells + 1) << max(n - 1, 1).bit_length() <= 2**32


def _sorted_by_cell(cells: jax.Array, valid: jax.Array,
                    n_cells: int) -> tuple[jax.Array, jax.Array]:
    """``(cell int32[L], position int32[L])`` sorted by cell, then position (padding, and
    a valid node off the map, as cell ``n_cells``, after every real cell): ONE sort of
    ``cell << b | position`` words.
    On XLA's CPU backend that is faster than the stable ``argsort`` (a sort of two
    arrays) of the same pairs (decision 008)."""
    n = cells.shape[0]
    b = max(n - 1, 1).bit_length()
    key = jnp.where(valid & (cells >= 0) & (cells < n_cells), cells, n_cells)
    key = key.astype(jnp.uint32)
    packed = jnp.sort((key << b) | jnp.arange(n, dtype=jnp.uint32))
    return (packed >> b).astype(jnp.int32), (packed & jnp.uint32((1 << b) - 1)).astype(jnp.int32)


def position_lookup(
    cells: jax.Array, length: jax.Array, n_cells: int | None
) -> Callable:
    """``look(q)``: the last valid position of cell ``q`` in the path, or -1 (any shape).

    A scatter table of ``n_cells`` entries on maps up to :data:`TABLE_MAX_CELLS` cells
    and :data:`TABLE_CELLS_PER_NODE` cells per node of the path, a sort and binary search
    otherwise (also without ``n_cells``). Used by the crossovers
    (where one parent's cells are in the other) and :func:`jaxga.operators.repair.splice_loop_free`.
    """
    n = cells.shape[0]
    i = jnp.arange(n, dtype=jnp.int32)
    valid = i < length
    if _use_table(n_cells, n):
        keys = jnp.where(valid, cells, n_cells)
        if n_cells > CHUNKED_LOOKUP_CELLS:
            return lambda q: table_lookup(keys, q, n_cells)
        table = position_table(keys, n_cells)

        def look(q):
            inside = (q >= 0) & (q < n_cells)
            return jnp.where(inside, table[jnp.clip(q, 0, n_cells - 1)], -1)

        return look
    if _packable(n_cells, n):
        sk, order = _sorted_by_cell(cells, valid, n_cells)
    else:
        key = jnp.where(valid, cells, np.iinfo(np.int32).max)
        order = jnp.argsort(key, stable=True).astype(jnp.int32)
        sk = key[order]

    def look(q):
        k = jnp.searchsorted(sk, q, side="right").astype(jnp.int32) - 1
        kc = jnp.clip(k, 0, n - 1)
        found = (k >= 0) & (sk[kc] == q) & (q >= 0)
        if n_cells is not None:
            found &= q < n_cells
        return jnp.where(found, order[kc], -1)

    return look


def remove_loops(
    cells: jax.Array, length: jax.Array, n_cells: int | None = None
) -> tuple[jax.Array, jax.Array]:
    """Cut out everything between two visits of the same cell (MPMGA section 4.3 deletion).

    From position 0, keep a node and jump to just after the LAST occurrence of its cell,
    until the end of the path: ``0, 20, 40, 21, 41, 40, 60 -> 0, 20, 40, 60``. The result
    is loop-free, keeps both endpoints, is no longer than the input, and a continuous
    path stays continuous (the node after a last occurrence was adjacent to it).

    Cost: :func:`last_occurrence` (pass the static map size ``n_cells`` to get its fast
    table variant on small maps), then a ``lax.while_loop`` over the CUTS only (a walk
    moves one position at a time except at a cell that occurs again later, so only those
    "jump sources" need a sequential step; the next one after a position is a reverse
    prefix minimum), each cut shifting the source index of the later output positions
    (``O(L)`` vector work, no scatter), and one gather. A mutation's splice makes one or
    two cuts; the former ``L``-step scan cost the same for every path.

    Returns:
        ``(cells, length)`` re-padded with the last cell.
    """
    cells = jnp.asarray(cells, jnp.int32)
    n = cells.shape[0]
    length = jnp.asarray(length, jnp.int32)
    i = jnp.arange(n, dtype=jnp.int32)
    last = last_occurrence(cells, length, n_cells)
    # next_jump[p]: the first position >= p whose cell occurs again later (n if none).
    src = jnp.where(last > i, i, n)
    next_jump = jax.lax.associative_scan(jnp.minimum, src, reverse=True)
    next_jump = jnp.concatenate([next_jump, jnp.full((1,), n, jnp.int32)])

    def cond(c):
        q, _, _ = c
        return q < n

    def body(c):
        q, skipped, source = c
        qc = jnp.minimum(q, n - 1)
        d = last[qc] - qc  # positions q+1 .. last[q] are cut
        out_q = qc - skipped  # output position of the kept node q
        source = source + jnp.where(i > out_q, d, 0)
        return next_jump[jnp.minimum(last[qc] + 1, n)], skipped + d, source

    _, skipped, source = jax.lax.while_loop(
        cond, body, (next_jump[0], jnp.int32(0), i)
    )
    new_length = jnp.maximum(jnp.minimum(length, n) - skipped, 0)
    out = cells[jnp.clip(source, 0, n - 1)]
    return pad(out, new_length), new_length
