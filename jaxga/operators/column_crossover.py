"""Zhu & Pan's non-common-point (column) crossover (section 4.4, Algorithm 2, Fig. 5).

The child crosses the map column by column from the start's to the goal's: one free cell
in each column strictly between them, drawn between the two parents' cells in that column
(:func:`column_ranges`, :func:`column_anchors`), joined by median insertion
(:func:`column_child`); two roulette spins over both parents and the child fill the pair's
two slots (:func:`column`). The pair signature and the conventions are those of
:mod:`jaxga.operators.crossover`, where the operator is registered.

Algorithm 2's loop runs over the columns up to the goal's (``i <= E_y``) and then appends
the goal, while Fig. 5's child has no cell of its own in the goal's column; jaxga follows
the figure: no cell is drawn for the goal's column, and the child joins the last interior
column's cell to the goal.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core import prng
from jaxga.core.dtypes import F32, I32
from jaxga.core.grid import Grid
from jaxga.core.paths import remove_loops
from jaxga.operators.init import field_path
from jaxga.operators.joins import uniform_index
from jaxga.operators.repair import connect, prefix_count

__all__ = [
    "ColumnRanges",
    "column",
    "column_anchors",
    "column_candidate_sets",
    "column_child",
    "column_ranges",
]

_U32 = jnp.uint32
_INT_MAX = np.iinfo(np.int32).max


class ColumnRanges(NamedTuple):
    """Per-column candidate ranges of the non-common-point crossover (Zhu Algorithm 2).

    Column ``k`` (``k = 0 .. A - 1``, ``A = max(H, W)``) is the line at major coordinate
    ``major[k] = start_major + k * sign(goal_major - start_major)``; columns
    ``1 .. n_steps - 1`` lie strictly between the start and the goal (``interior``).
    ``lo``/``hi`` are the min and max minor coordinate of the two parents' cells in that
    column (``lo > hi`` when neither parent visits it) and ``n_free`` the number of free
    cells with minor coordinate in ``[lo, hi]``. ``x_major``: columns are x (True) or
    rows y (False).
    """

    x_major: jax.Array
    n_steps: jax.Array
    major: jax.Array
    lo: jax.Array
    hi: jax.Array
    n_free: jax.Array
    interior: jax.Array


def _free_prefix(grid: Grid) -> jax.Array:
    """Flat table of free-cell prefix counts along columns (x-major) and rows (y-major).

    ``[W, H + 1]`` entries ``colcum[x, v] = #free (x, y < v)`` then ``[H, W + 1]`` entries
    ``rowcum[y, v] = #free (x < v, y)``. Depends on the grid only (computed once per call,
    not per pair, under ``vmap`` over pairs; read from ``grid.tables`` when attached).
    """
    if grid.tables is not None:
        return grid.tables.free_prefix
    return compute_free_prefix(grid)


def compute_free_prefix(grid: Grid) -> jax.Array:
    """:func:`_free_prefix` computed from the map (what :mod:`jaxga.engine.maptables` stores)."""
    free = (~grid.blocked).astype(I32)
    h, w = free.shape
    col = jnp.concatenate([jnp.zeros((w, 1), I32), prefix_count(free.T, axis=1)], axis=1)
    row = jnp.concatenate([jnp.zeros((h, 1), I32), prefix_count(free, axis=1)], axis=1)
    return jnp.concatenate([col.reshape(-1), row.reshape(-1)])


def _prefix_at(table, grid: Grid, x_major, c, v):
    h, w = grid.shape
    idx = jnp.where(x_major, c * (h + 1) + v, w * (h + 1) + c * (w + 1) + v)
    return table[jnp.clip(idx, 0, table.shape[0] - 1)]


def column_ranges(
    grid: Grid, c1: jax.Array, l1: jax.Array, c2: jax.Array, l2: jax.Array
) -> ColumnRanges:
    """The candidate range of every column between start and goal (Zhu Algorithm 2 l. 5).

    Zhu & Pan walk the columns from the start's to the goal's (their maps have the start
    bottom-left and the goal top-right); jaxga generalises this to the major axis of
    ``goal - start``: columns x when ``|dx| >= |dy|`` (ties: x), else rows y, walked from
    the start towards the goal. For each column the min and max minor coordinate over
    the cells of BOTH parents in that column (Zhu: "the max grid number and the min grid
    number in column i (p1 & p2)") bound the candidates. Cost: two scatters of ``2 L``
    into ``max(H, W)`` entries.
    """
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    h, w = grid.shape
    a = max(h, w)
    sx, sy, gx, gy = grid.start % w, grid.start // w, grid.goal % w, grid.goal // w
    dx, dy = gx - sx, gy - sy
    x_major = jnp.abs(dx) >= jnp.abs(dy)
    d = jnp.where(x_major, dx, dy)
    s_major = jnp.where(x_major, sx, sy)
    sign = jnp.where(d >= 0, 1, -1).astype(I32)
    n_steps = jnp.abs(d).astype(I32)
    n = c1.shape[0]
    i = jnp.arange(n, dtype=I32)
    cells = jnp.concatenate([c1, c2])
    valid = jnp.concatenate([i < l1, i < l2])
    maj = jnp.where(x_major, cells % w, cells // w)
    mnr = jnp.where(x_major, cells // w, cells % w)
    slot = jnp.where(valid, maj, a)
    lo_tab = jnp.full((a,), _INT_MAX, I32).at[slot].min(mnr, mode="drop")
    hi_tab = jnp.full((a,), -1, I32).at[slot].max(mnr, mode="drop")
    k = jnp.arange(a, dtype=I32)
    major = s_major + sign * k
    mc = jnp.clip(major, 0, a - 1)
    lo, hi = lo_tab[mc], hi_tab[mc]
    interior = (k >= 1) & (k < n_steps)
    table = _free_prefix(grid)
    has = hi >= lo
    n_free = jnp.where(
        has,
        _prefix_at(table, grid, x_major, mc, jnp.clip(hi + 1, 0, a))
        - _prefix_at(table, grid, x_major, mc, jnp.clip(lo, 0, a)),
        0,
    )
    return ColumnRanges(x_major, n_steps, major, lo, hi, n_free, interior)


def column_candidate_sets(
    grid: Grid, c1: jax.Array, l1: jax.Array, c2: jax.Array, l2: jax.Array
) -> list[list[int]]:
    """Host-side: the candidate cells of every interior column, from start to goal.

    Entry ``k - 1`` lists the free cells of column ``k`` with minor coordinate in
    ``[lo, hi]`` (:func:`column_ranges`), by increasing minor coordinate. Zhu & Pan
    Figure 5 (5 x 5, P1 = 0-5-10-16-17-23-24, P2 = 0-1-2-8-14-19-24): the first column's
    set is ``[1, 6, 11, 16]``.
    """
    cr = column_ranges(grid, c1, l1, c2, l2)
    blocked = grid.blocked_np().reshape(-1)
    w = grid.width
    out = []
    for k in range(1, int(cr.n_steps)):
        c, lo, hi = int(cr.major[k]), int(cr.lo[k]), int(cr.hi[k])
        cells = [v * w + c if bool(cr.x_major) else c * w + v for v in range(lo, hi + 1)]
        out.append([p for p in cells if not blocked[p]])
    return out


def column_anchors(
    key: jax.Array, grid: Grid, c1: jax.Array, l1: jax.Array, c2: jax.Array, l2: jax.Array
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The intermittent child of Zhu's Algorithm 2 (lines 2-9), before connection.

    ``P = [start]``; for every interior column (:func:`column_ranges`) append a cell drawn
    uniformly among the FREE cells of that column between the parents' min and max; append
    the goal. Zhu's Figure 5 draws from the whole range (its set ``(1, 6, 11, 16)``); a
    blocked cell could never be connected, so blocked cells are excluded and a column
    whose range holds no free cell (or that no parent visits - impossible for continuous
    parents) makes the crossover fail. The draw is a binary search on per-column prefix
    counts of free cells (O(log H) per column), not a scan of the column.

    Returns ``(anchors int32[A], n_anchors int32, ok bool)`` with ``A = max(H, W)``;
    ``anchors[:n_anchors]`` are start, one cell per interior column, goal.
    """
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    h, w = grid.shape
    a = max(h, w)
    cr = column_ranges(grid, c1, l1, c2, l2)
    bits = prng.bits(key, (a,), _U32)
    r = uniform_index(bits, cr.n_free)
    table = _free_prefix(grid)
    mc = jnp.clip(cr.major, 0, a - 1)
    lo = jnp.clip(cr.lo, 0, a - 1)
    hi = jnp.clip(cr.hi, 0, a - 1)
    target = _prefix_at(table, grid, cr.x_major, mc, lo) + r + 1
    # Smallest v in [lo, hi] with prefix(v + 1) >= target: the (r+1)-th free cell.
    left, right = lo, jnp.maximum(hi, lo)
    for _ in range(int(np.ceil(np.log2(a + 1))) + 1):
        mid = (left + right) // 2
        go_left = _prefix_at(table, grid, cr.x_major, mc, mid + 1) >= target
        right = jnp.where(go_left, mid, right)
        left = jnp.where(go_left, left, mid + 1)
    pick = jnp.where(cr.x_major, left * w + mc, mc * w + left)
    k = jnp.arange(a, dtype=I32)
    anchors = jnp.where(k == 0, grid.start, jnp.where(k >= cr.n_steps, grid.goal, pick))
    ok = jnp.all(~cr.interior | (cr.n_free > 0))
    return anchors.astype(I32), (cr.n_steps + 1).astype(I32), ok


def column_child(
    key: jax.Array,
    grid: Grid,
    c1: jax.Array,
    l1: jax.Array,
    c2: jax.Array,
    l2: jax.Array,
    max_rounds: int | None = None,
    queue: int | None = None,
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The child of Zhu's non-common-point crossover (Algorithm 2 lines 2-10).

    :func:`column_anchors` (with the first half of ``key``), then "path continuum
    processing" = median insertion (:func:`jaxga.operators.repair.connect`, Zhu eq. 11-12, with the
    second half of ``key``), then loop removal. Returns ``(cells int32[L], length, ok)``;
    ``ok`` False = Zhu's "crossover failure" (a column without candidates, a failed
    connection, or a capacity overflow; a child spanning more columns than ``L`` cells
    is one).

    ``max_rounds`` and ``queue`` (static) bound the median insertion
    (:func:`jaxga.operators.repair.connect`). Under ``vmap`` every pair runs as many rounds as the
    slowest, and a connection that does not close (a median inside a wall keeps being
    replaced by random neighbours: the paper's "crossover failure") runs them all, so
    they set the cost. Defaults: ``max_rounds = 2 * ceil(log2(max(H, W))) + 6`` (twice
    the rounds an obstacle-free gap needs, plus slack) and ``queue = 2 * max(H, W)``
    (every initial gap split once). On a 20 x 20 map (16 rounds) four times the rounds
    close only a few more children at four times the cost (decision 044).

    ``field_repair`` (static; jaxga's extension, ``repair.fallback = "field"``): a
    connection that does not close gives the optimal path through the middle anchor
    down the exact distance fields (:func:`jaxga.operators.init.field_path`) as the child; needs
    ``grid.guide``.
    """
    n = jnp.asarray(c1).shape[0]
    h, w = grid.shape
    a = max(h, w)
    k_anchor, k_conn = prng.split(key)
    anchors, n_anchors, cols_ok = column_anchors(k_anchor, grid, c1, l1, c2, l2)
    if a > n:  # a big map and a small capacity: a child spanning more columns cannot fit
        cols_ok &= n_anchors <= n
        anchors, n_anchors = anchors[:n], jnp.minimum(n_anchors, n)
    if max_rounds is None:
        max_rounds = 2 * int(np.ceil(np.log2(max(a, 2)))) + 6
    if queue is None:
        queue = 2 * a
    cells, length, ok = connect(
        k_conn, grid, anchors, n_anchors, n, max_rounds=max_rounds, queue=min(n, queue)
    )
    cells, length = remove_loops(cells, length, grid.n_cells)
    ok &= cols_ok
    if field_repair:
        f_c, f_n, f_ok = field_path(prng.fold_in(k_conn, 7), grid,
                                    anchors[n_anchors // 2], n, 0.0, 0.0)
        cells, length = jnp.where(ok, cells, f_c), jnp.where(ok, length, f_n)
        ok = ok | (cols_ok & f_ok)
    return cells, length, ok


def column(
    key: jax.Array,
    grid: Grid,
    c1: jax.Array,
    l1: jax.Array,
    c2: jax.Array,
    l2: jax.Array,
    *,
    fitness_fn: Callable,
    distinct: bool = False,
    max_rounds: int | None = None,
    queue: int | None = None,
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]:
    """Zhu & Pan's non-common-point (column) crossover (section 4.4, Algorithm 2, Fig. 5).

    Builds the child of :func:`column_child`; on success, "2 from P1, P2 and P are
    selected to become child chromosomes using RWS": two roulette spins (Zhu eq. 10)
    over ``{P1, P2, child}`` with weights ``fitness_fn`` (clipped at 0; uniform if all
    are 0) fill output slots 1 and 2 in spin order. ``distinct`` (static): False
    (default) spins independently, as roulette-wheel selection does, so the child may
    fill both slots; True draws the second spin from the two members not yet drawn.
    On "crossover failure" both slots keep their parents and ``failed`` is 2.

    ``fitness_fn(grid, cells, length) -> f32`` is static (bind it with
    ``functools.partial``). ``max_rounds``,
    ``queue``, ``field_repair``: see :func:`column_child` (the first two dominate the
    cost).
    """
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    l1, l2 = jnp.asarray(l1, I32), jnp.asarray(l2, I32)
    k_child, k_spin = prng.split(key)
    cc, cl, ok = column_child(
        k_child, grid, c1, l1, c2, l2, max_rounds=max_rounds, queue=queue,
        field_repair=field_repair,
    )
    paths = jnp.stack([c1, c2, cc])
    lens = jnp.stack([l1, l2, cl])
    f = jax.vmap(lambda c, ln: jnp.asarray(fitness_fn(grid, c, ln), F32))(paths, lens)
    wts = jnp.where(jnp.isnan(f), F32(0), jnp.maximum(f, F32(0)))
    u = prng.uniform(k_spin, (2,), F32)
    s1 = _spin(wts, u[0])
    if distinct:
        s2 = _spin(wts.at[s1].set(0.0), u[1], jnp.arange(3) != s1)
    else:
        s2 = _spin(wts, u[1])
    failed = jnp.where(ok, 0, 2).astype(I32)
    return (
        jnp.where(ok, paths[s1], c1), jnp.where(ok, lens[s1], l1),
        jnp.where(ok, paths[s2], c2), jnp.where(ok, lens[s2], l2),
        failed,
    )


def _spin(weights: jax.Array, u: jax.Array, eligible: jax.Array | None = None) -> jax.Array:
    """One roulette spin over a few weights (uniform over ``eligible`` if all are 0)."""
    if eligible is None:
        eligible = jnp.ones(weights.shape, bool)
    w = jnp.where(jnp.sum(weights) > 0, weights, eligible.astype(F32))
    cdf = jnp.cumsum(w)
    idx = jnp.sum(cdf <= u * cdf[-1], dtype=I32)
    last = jnp.max(jnp.where(w > 0, jnp.arange(w.shape[0], dtype=I32), 0))
    return jnp.minimum(idx, last)
