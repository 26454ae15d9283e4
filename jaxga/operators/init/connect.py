"""Connection initialisers: a random free cell per row joined by median insertion (IMGA 4.1)
and MPMGA's intermittent barrier-free path with its connection (MPMGA 4.2)."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga.core import prng
from jaxga.core.dtypes import I32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.core.paths import (
    remove_loops,
)
from jaxga.operators.init.common import check_capacity, fit_to_capacity, free_cells, pick_cell
from jaxga.operators.init.field import field_path
from jaxga.operators.repair import connect


def median_insertion(
    key: jax.Array,
    grid: Grid,
    capacity: int,
    work_capacity: int | None = None,
    max_rounds: int = 64,
    queue: int | None = None,
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """IMGA's heuristic median insertion (Li, Hu, Liu 2021, section 4.1, eq. 2-3).

    Draw a uniformly random free cell ``N`` that is neither the start nor the goal
    (step (3)(i)), then close the gaps of ``S - N - G`` by median insertion
    (:func:`jaxga.operators.repair.connect`: the median of a discontinuous pair, or a random free
    8-neighbour of it when it is blocked; none = "the individual is directly discarded"),
    then remove loops (:func:`jaxga.core.paths.remove_loops`; IMGA does not say what to do
    with loops, but its chromosomes must be feasible and later operators assume simple
    paths). IMGA asks for ``M`` non-repeating chromosomes: pass ``unique=True`` to
    :func:`initialise_population`. A map whose only free cells are the start and the goal uses
    ``N = start`` (so the individual is the median connection of ``S - G``).

    The paper's insertion loop is unbounded; on maps with long walls it can cycle for
    ever (a blocked median replaced by a neighbour that reopens the gap). Here the
    connection fails after ``max_rounds`` rounds of parallel insertion (64: more rounds
    close no more connections, and a sequential transcription of the paper given far
    more nodes closes about as many, cycling on the same walls; decision 044 and the test
    ``test_median_insertion_succeeds_as_often_as_the_papers_sequential_insertion``),
    with more than ``queue`` gaps open at once (default 16 on maps up to 20 cells a side,
    where it never binds for ``S - N - G``, the value the paper reproductions ran with;
    ``max(H, W)`` on larger maps, the most gaps two gaps of that span can open), or when
    the connected path, loops included, outgrows ``work_capacity`` (default
    ``capacity``). After loop removal the path must fit ``capacity``.

    ``field_repair`` (static; jaxga's extension, ``repair.fallback = "field"``): a
    connection that does not close is replaced by the path ``S -> N -> G`` down the
    exact distance fields (:func:`field_path`, optimal moves through the same ``N``), so
    the only failure left is a path that does not fit the capacity. Needs ``grid.guide``.
    """
    capacity = check_capacity(capacity)
    if capacity < 2:
        raise ParameterError("median_insertion needs capacity >= 2 (start and goal)")
    n = grid.n_cells
    idx = jnp.arange(n, dtype=I32)
    free, count = free_cells(grid, (idx != grid.start) & (idx != grid.goal))
    k_mid, k_conn = prng.split(key)
    mid = jnp.where(count > 0, pick_cell(prng.bits(k_mid, (), jnp.uint32), free, count),
                    grid.start)
    anchors = jnp.stack([grid.start, mid, grid.goal]).astype(I32)
    if capacity < 3:
        anchors = jnp.stack([grid.start, grid.goal]).astype(I32)
    work = capacity if work_capacity is None else max(int(work_capacity), capacity)
    if queue is None:
        queue = 16 if max(grid.shape) <= 20 else max(grid.shape)
    cells, length, ok = connect(
        k_conn, grid, anchors, anchors.shape[0], work, max_rounds=max_rounds, queue=queue
    )
    cells, length = remove_loops(cells, length, n)
    cells, length, ok = fit_to_capacity(cells, length, ok, capacity)
    if field_repair:
        return _repaired(k_conn, grid, mid, capacity, (cells, length, ok))
    return cells, length, ok


def _repaired(key, grid, via, capacity, result):
    """``result`` if ok, else the optimal path through ``via`` down the fields."""
    cells, length, ok = result
    f_cells, f_len, f_ok = field_path(prng.fold_in(key, 7), grid, via, capacity,
                                      0.0, 0.0)
    return (jnp.where(ok, cells, f_cells), jnp.where(ok, length, f_len), ok | f_ok)


def intermittent_anchors(
    key: jax.Array, grid: Grid, axis: str = "rows"
) -> tuple[jax.Array, jax.Array]:
    """The barrier-free intermittent path of :func:`intermittent_connect` (MPMGA 4.2).

    ``start``, then one uniformly random free cell of every row strictly between the
    start's and the goal's rows (ordered from the start towards the goal; rows without a
    free cell skipped), then ``goal``. ``axis`` as in :func:`intermittent_connect`.

    Returns:
        ``(anchors int32[max(H, W) + 1], n_anchors int32)``; entries from ``n_anchors``
        on repeat the goal.
    """
    if axis not in ("rows", "columns", "major"):
        raise ParameterError(f"axis must be 'rows', 'columns' or 'major', got {axis!r}")
    h, w = grid.shape
    k_max = max(h, w) + 1  # start + at most max(H, W) - 2 lines + goal
    sx, sy = grid.start % w, grid.start // w
    gx, gy = grid.goal % w, grid.goal // w
    span_r, span_c = jnp.abs(gy - sy), jnp.abs(gx - sx)
    if axis == "rows":
        use_cols = span_r == 0
    elif axis == "columns":
        use_cols = span_c != 0
    else:
        use_cols = span_c > span_r
    # Free cells of every row (x ascending) and of every column (y ascending).
    blocked = grid.blocked
    row_order = jnp.argsort(blocked, axis=1, stable=True).astype(I32)  # [H, W] x's
    row_count = jnp.sum(~blocked, axis=1, dtype=I32)
    col_order = jnp.argsort(blocked, axis=0, stable=True).astype(I32)  # [H, W] y's
    col_count = jnp.sum(~blocked, axis=0, dtype=I32)

    j = jnp.arange(1, k_max - 1, dtype=I32)  # 1 .. k_max - 2
    bits = prng.bits(key, (max(k_max - 2, 1),), jnp.uint32)[: k_max - 2]
    # Rows: y = sy + sign * j for j < span.
    ry = jnp.clip(sy + jnp.sign(gy - sy) * j, 0, h - 1)
    r_cnt = row_count[ry]
    r_rank = (bits % jnp.maximum(r_cnt, 1).astype(jnp.uint32)).astype(I32)
    r_cell = ry * w + row_order[ry, jnp.minimum(r_rank, w - 1)]
    r_use = (j < span_r) & (r_cnt > 0)
    # Columns: x = sx + sign * j for j < span.
    cx = jnp.clip(sx + jnp.sign(gx - sx) * j, 0, w - 1)
    c_cnt = col_count[cx]
    c_rank = (bits % jnp.maximum(c_cnt, 1).astype(jnp.uint32)).astype(I32)
    c_cell = col_order[jnp.minimum(c_rank, h - 1), cx] * w + cx
    c_use = (j < span_c) & (c_cnt > 0)
    mid = jnp.where(use_cols, c_cell, r_cell)
    use = jnp.where(use_cols, c_use, r_use)
    # Compact: start, the used line cells in order, goal.
    pos = jnp.cumsum(use, dtype=I32)  # 1-based slot of each used cell
    n_mid = jnp.sum(use, dtype=I32)
    anchors = jnp.full((k_max,), grid.goal, I32).at[0].set(grid.start)
    anchors = anchors.at[jnp.where(use, pos, k_max)].set(mid, mode="drop")
    return anchors, n_mid + 2


def intermittent_connect(
    key: jax.Array,
    grid: Grid,
    capacity: int,
    axis: str = "rows",
    work_capacity: int | None = None,
    max_rounds: int = 64,
    queue: int | None = None,
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """MPMGA's barrier-free intermittent path, connected and loop-deleted (Hao et al. 2020 4.2).

    MPMGA section 4.2 (after its reference [21]): "a path that selects a series of free
    grids between the starting point and the target point and does not require
    continuity", then the connection operator (median insertion,
    :func:`jaxga.operators.repair.connect`), then the deletion operator (loop removal). The paper
    does not say how the series is chosen; jaxga follows the classic construction that
    paper lineage uses (start at the bottom row, goal at the top): ONE uniformly random
    free cell in every row strictly between the start's row and the goal's row, ordered
    from the start's row towards the goal's row (the start and goal represent their own
    rows). Rows with no free cell are skipped.

    ``axis`` (static): ``"rows"`` (default, the paper's layout) uses rows, and falls back
    to columns when the start and goal share a row (otherwise the intermittent path would
    be just ``S - G`` with no randomness); ``"columns"`` uses columns (falling back to rows
    when they share a column); ``"major"`` uses whichever of the two spans more lines.

    Connection limits (static): the path, loops included, may grow to ``work_capacity``
    (default ``2 * capacity``: one cell per row at random columns zigzags, and the raw
    connection of a 20 x 20 map is often longer than the 160 cells its loop-free result
    needs); ``queue`` bounds the simultaneously open gaps (default ``4 * max(H, W)``,
    capped at ``work_capacity``; at most ``max(H, W)`` gaps are open at first, and a gap
    splits into at most two); ``max_rounds`` (64) bounds the insertion rounds. After loop
    removal the path must fit ``capacity``; an intermittent path of more anchors than
    ``work_capacity`` cells fails. With these defaults it succeeds nearly as often as a
    sequential transcription of the paper with a far larger node cap, and far more often
    than with ``work_capacity = capacity`` (decision 044).

    ``field_repair`` (static; ``repair.fallback = "field"``): a connection that does not
    close is replaced by the optimal path through the middle anchor down the exact
    distance fields (:func:`field_path`); needs ``grid.guide``.
    """
    capacity = check_capacity(capacity)
    h, w = grid.shape
    work = 2 * capacity if work_capacity is None else max(int(work_capacity), capacity)
    if queue is None:
        queue = min(work, 4 * max(h, w))
    anchors, n_anchors = intermittent_anchors(prng.fold_in(key, 1), grid, axis)
    fits = jnp.bool_(True)
    if anchors.shape[0] > work:  # a big map and a small capacity: more lines than cells
        fits = n_anchors <= work
        anchors, n_anchors = anchors[:work], jnp.minimum(n_anchors, work)
    cells, length, ok = connect(
        prng.fold_in(key, 2), grid, anchors, n_anchors, work,
        max_rounds=max_rounds, queue=queue,
    )
    ok &= fits
    cells, length = remove_loops(cells, length, grid.n_cells)
    result = fit_to_capacity(cells, length, ok, capacity)
    if field_repair:
        return _repaired(key, grid, anchors[n_anchors // 2], capacity, result)
    return result
