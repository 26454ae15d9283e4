"""Crossover operators: one pair of parents -> two children.

Every operator has the pair signature of :func:`jaxga.operators.lift.over_pairs`::

    op(key, grid, c1, l1, c2, l2, *extra) -> (c1, l1, c2, l2, failed)

for ONE pair of paths (``cells int32[L]``, ``length int32``, padded with the last cell;
docs, "the pure core"), is pure and jittable, and reaches a population through
:func:`jaxga.operators.lift.over_pairs` or, with a crossover probability, through
:func:`crossover_population`. Operators that need a fitness take ``fitness_fn``, a
Python callable ``(grid, cells, length) -> f32`` (larger is better, e.g.
``jaxga.core.objectives.mpmga``) that is STATIC: bind it with ``functools.partial(op,
fitness_fn=...)`` before lifting/jitting.

Conventions shared by the operators (decisions where the papers are silent):

* **Children and slots.** Output 1 is the child that starts with parent 1's head (it
  replaces parent 1), output 2 the child that starts with parent 2's head.
* **Failure** means a child that cannot be represented: it would exceed the
  capacity ``L`` (after loop removal - a child that fits once its loops are cut is NOT a
  failure), or, for :func:`column`, the paper's "crossover failure". A failed child is
  replaced by its parent, unchanged. ``failed`` is the int32 NUMBER OF OUTPUT SLOTS
  (0, 1 or 2) that fell back to their parent because of a failure, so that the
  population count of :func:`~jaxga.operators.lift.over_pairs` counts individuals, like
  :func:`~jaxga.operators.lift.over_individuals`. "No crossover point exists", "the junction
  is not clear" and "the child is not fitter" are regular outcomes of the operators, not
  failures: the parent is kept and nothing is counted.
* **Loops.** Splicing two loop-free paths can create a loop (a cell of the head also in
  the tail). Children are cut exactly as :func:`jaxga.core.paths.remove_loops` (MPMGA's
  deletion operator) would cut them, but in O(L) without its scan: for a head ``a[:m]``
  and a tail ``b[s:]``, the first head position ``k`` whose cell occurs in the tail at
  position ``t`` gives the child ``a[:k] + b[t:]``. This equals ``remove_loops`` of the
  raw splice whenever both parents are loop-free (the population invariant);
  loops already inside a parent are left alone.
* **Cell lookups** ("where does this cell occur in the other parent?") use a table of
  ``n_cells`` entries on maps of up to :data:`jaxga.core.paths.TABLE_MAX_CELLS` cells and a
  sort (O(L log L), no map-sized work) on larger maps.
* **Randomness.** Every random choice is uniform and drawn in bulk from the operator's
  key (32-bit words, ``bits mod n``: bias below ``n / 2**32``). Same key, same result.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.numerics import ordered_mean
from jaxga.core.dtypes import F32, I32
from jaxga.core.errors import ParameterError
from jaxga.core.geometry import clear, linear_trial
from jaxga.core.grid import Grid, move_legal
from jaxga.core.paths import TABLE_MAX_CELLS, remove_loops
from jaxga.core.paths import position_lookup as _position_lookup
from jaxga.operators.init import field_path
from jaxga.operators.lift import over_pairs_gated
from jaxga.operators.mutation import split_half
from jaxga.operators.registry import (
    FIELD_REPAIR,
    NEEDS_FITNESS,
    SPLICING,
    WAYPOINTS,
    Binding,
    Operator,
    operator,
    register,
    register_none,
)
from jaxga.operators.repair import concat, connect, prefix_count

__all__ = [
    "ColumnRanges",
    "adaptive_crossover_probability",
    "adaptive_pair_probability",
    "column",
    "column_anchors",
    "column_candidate_sets",
    "column_child",
    "column_ranges",
    "common_point",
    "crossover_population",
    "cut_and_check",
    "heterologous",
    "heterologous_pairs",
]

_U32 = jnp.uint32
_INT_MAX = np.iinfo(np.int32).max


# ------------------------------------------------------------------- helpers
def _kth_true(mask: jax.Array, r: jax.Array) -> jax.Array:
    """Index of the ``r``-th (0-based) True of a 1-D mask (0 if there are fewer).

    Masks longer than ``2 * _KTH_ROW`` are searched in rows of ``_KTH_ROW``
    (:func:`_kth_true_rows`): a prefix sum over the rows' counts and one within a row
    instead of one over the whole mask: faster on masks of a path's capacity
    (decision 010).
    """
    n = mask.shape[0]
    if n <= 2 * _KTH_ROW:
        return _kth_true_scan(mask, r)
    rows = -(-n // _KTH_ROW)
    padded = jnp.zeros((rows * _KTH_ROW,), bool).at[:n].set(mask)
    row, col = _kth_true_rows(padded.reshape(rows, _KTH_ROW), r)
    return jnp.where(r < jnp.sum(mask, dtype=I32), row * _KTH_ROW + col, 0)


_KTH_ROW = 16
"""Row width of :func:`_kth_true`'s two-level search."""


def _kth_true_rows(mask: jax.Array, r: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(row, col)`` of the ``r``-th True of a 2-D mask in row-major order.

    Two levels (prefix sums over the rows, then within the row) instead of one prefix
    sum over all ``rows * cols`` entries.
    """
    counts = jnp.sum(mask, axis=1, dtype=I32)
    before = prefix_count(counts) - counts  # Trues in the rows above
    row = jnp.clip(jnp.sum(before <= r, dtype=I32) - 1, 0, mask.shape[0] - 1)
    return row, _kth_true_scan(mask[row], r - before[row])


def _kth_true_scan(mask: jax.Array, r: jax.Array) -> jax.Array:
    """:func:`_kth_true` by one prefix sum over the whole mask."""
    return jnp.argmax(prefix_count(mask) > r).astype(I32)


def _uniform_index(bits: jax.Array, n: jax.Array) -> jax.Array:
    return (bits % jnp.maximum(n, 1).astype(_U32)).astype(I32)


class _Joined(NamedTuple):
    cells: jax.Array
    length: jax.Array
    ok: jax.Array
    left: jax.Array  # the two cells of the one new segment of the child
    right: jax.Array


def _join(
    ca: jax.Array,
    cut: jax.Array,
    pos_in_b: jax.Array,
    cb: jax.Array,
    lb: jax.Array,
    start_b: jax.Array,
) -> _Joined:
    """``ca[:cut] + cb[start_b:lb]`` with the loops cut as ``remove_loops`` cuts them.

    ``pos_in_b[k]`` is the (last) position of ``ca[k]`` in ``cb`` or -1. The first head
    position ``k < cut`` whose cell occurs in the tail (``pos_in_b[k] >= start_b``) makes
    the child ``ca[:k] + cb[pos_in_b[k]:]``; with none, the raw splice. Exact for
    loop-free parents (see the module docstring). Also returns the child's one new
    segment ``(left, right)`` (the junction) and whether it fits the capacity.
    """
    n = ca.shape[0]
    i = jnp.arange(n, dtype=I32)
    hit = (i < cut) & (pos_in_b >= start_b)
    has = jnp.any(hit)
    a = jnp.where(has, jnp.argmax(hit).astype(I32), cut)
    b = jnp.where(has, pos_in_b[jnp.clip(a, 0, n - 1)], start_b)
    return _splice(ca, a, cb, b, lb)


def _splice(head: jax.Array, cut: jax.Array, tail: jax.Array, start: jax.Array,
            tail_len: jax.Array) -> _Joined:
    """``head[:cut] + tail[start:tail_len]`` (the loop cut already chosen) with its
    junction ``(head[cut - 1], tail[start])`` and whether it fits the capacity."""
    n = head.shape[0]
    cells, length, ok = concat([(head, 0, cut), (tail, start, tail_len)], n)
    right = tail[jnp.clip(start, 0, n - 1)]
    left = jnp.where(cut > 0, head[jnp.clip(cut - 1, 0, n - 1)], right)
    return _Joined(cells, length, ok, left, right)


def _join_reverse(
    cb: jax.Array,
    cut_b: jax.Array,
    ca: jax.Array,
    la: jax.Array,
    start_a: jax.Array,
    pos_a_in_b: jax.Array,
) -> _Joined:
    """``cb[:cut_b] + ca[start_a:la]`` with the loops cut, from the lookup ``pos_a_in_b``
    (the last position of each ``ca[k]`` in ``cb``, or -1) that :func:`_join` uses for
    the other child: no lookup of ``cb``'s cells in ``ca``.

    :func:`_join` looks for the first head position ``k < cut_b`` whose cell occurs in
    the tail ``ca[start_a:la]``. When ``cb`` is loop-free every cell has at most one
    position in it, so that ``k`` is the smallest ``pos_a_in_b[i]`` below ``cut_b`` over
    the tail positions ``i``, and the child continues at the last such ``i``: the
    same child as ``_join(cb, cut_b, pos_b_in_a, ca, la, start_a)`` whenever ``cb`` is
    loop-free (evolving populations are) and ``cut_b`` is at most its length.
    With a ``cb`` that has loops the child is still as continuous as the raw splice (a
    cut junction joins ``cb[k - 1]`` to the cell that follows it in ``cb``), but a loop
    through the junction may remain.
    """
    n = cb.shape[0]
    i = jnp.arange(n, dtype=I32)
    tail = (i >= start_a) & (i < la) & (pos_a_in_b >= 0) & (pos_a_in_b < cut_b)
    first = jnp.min(jnp.where(tail, pos_a_in_b, n))
    has = first < n
    b = jnp.where(has, first, cut_b)
    a = jnp.where(has, jnp.max(jnp.where(tail & (pos_a_in_b == first), i, -1)), start_a)
    return _splice(cb, b, ca, a, la)


def _choose(take: jax.Array, new: jax.Array, old: jax.Array) -> jax.Array:
    return jnp.where(take, new, old)


# --------------------------------------------------------------- common point
def common_point(
    key: jax.Array,
    grid: Grid,
    c1: jax.Array,
    l1: jax.Array,
    c2: jax.Array,
    l2: jax.Array,
) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]:
    """Single-point crossover at a common cell (IMGA 4.3.2, Zhu & Pan 4.4 one-point, SGA).

    A cell present in both parents other than the start and the goal is chosen
    uniformly among all such common cells (IMGA: "randomly select one of the two parent
    individuals with the same sequence number (except the starting point S and the
    target point G)"; Zhu: "removes the start and end points to form a common set, and
    then randomly selects a point"); with ``p1[i] == p2[j]`` the children are
    ``p1[:i] + p2[j:]`` and ``p2[:j] + p1[i:]`` (IMGA's example: S-2-12-67-69-89-G x
    S-11-22-67-78-80-G at 67 -> S-2-12-67-78-80-G, S-11-22-67-69-89-G). Loops are then
    removed (IMGA 4.3.2). No common cell -> no crossover: the parents are returned and
    nothing is counted as failed. A child that would exceed the capacity even after loop
    removal fails and keeps its parent (the other child is still accepted).

    Continuous, loop-free parents give continuous, loop-free children. Cost: one cell
    lookup (where parent 1's cells are in parent 2; the second child's loop cut is read
    off it too, :func:`_join_reverse`, exact for a loop-free parent 2) and a few gathers
    of length ``L``; no scan, no O(L^2) matrix. The lookups (a scatter per parent) are
    most of the operator's time, so it does one lookup instead of two, with the same
    children (decision 010).
    """
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    l1, l2 = jnp.asarray(l1, I32), jnp.asarray(l2, I32)
    n = c1.shape[0]
    pos2 = _position_lookup(c2, l2, grid.n_cells)(c1)  # where p1's cells are in p2
    i = jnp.arange(n, dtype=I32)
    cand = (
        (i >= 1) & (i <= l1 - 2) & (pos2 >= 1) & (pos2 <= l2 - 2)
        & (c1 != grid.start) & (c1 != grid.goal)
    )
    count = jnp.sum(cand, dtype=I32)
    r = _uniform_index(jax.random.bits(key, (), _U32), count)
    ci = _kth_true(cand, r)
    cj = pos2[ci]
    k1 = _join(c1, ci, pos2, c2, l2, cj)
    k2 = _join_reverse(c2, cj, c1, l1, ci, pos2)  # no second lookup (p2's cells in p1)
    do = count > 0
    return _finish(do, k1.ok, k2.ok, k1, k2, c1, l1, c2, l2)


def _finish(do, take1, take2, k1: _Joined, k2: _Joined, c1, l1, c2, l2, need1=True, need2=True):
    """Accept child k where ``do & take_k & fits_k``. An overflow counts as a failure
    where ``do & need_k`` (``need_k`` False: the child was rejected for another reason
    that does not depend on its length, e.g. a blocked junction)."""
    a1 = do & take1 & k1.ok
    a2 = do & take2 & k2.ok
    failed = (do & need1 & ~k1.ok).astype(I32) + (do & need2 & ~k2.ok).astype(I32)
    return (
        _choose(a1, k1.cells, c1), _choose(a1, k1.length, l1),
        _choose(a2, k2.cells, c2), _choose(a2, k2.length, l2),
        failed,
    )


# --------------------------------------------------------------- cut and check
def cut_and_check(
    key: jax.Array,
    grid: Grid,
    c1: jax.Array,
    l1: jax.Array,
    c2: jax.Array,
    l2: jax.Array,
    check: str = "clear",
) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]:
    """AGACD's single-point crossover with collision check (AGACD section 4.6, section 3).

    AGACD joins two parents at random positions and removes infeasible children with its
    collision detection ("both crossover and mutation operations generate infeasible
    path individuals, it is necessary to use a collision detection algorithm to remove
    these"); its individuals are waypoint paths (feasible: every segment clear).
    Here: a cut after node ``i`` of parent 1 and after node ``j`` of parent 2, ``i``
    uniform in ``[0, l1 - 2]`` and ``j`` uniform in ``[0, l2 - 2]`` independently (a cut
    is a gap between two nodes, so both parts are non-empty; a cut at the very start of
    both or the very end of both just swaps the parents). Children
    ``p1[:i+1] + p2[j+1:]`` and ``p2[:j+1] + p1[i+1:]``; loops are removed; each child is
    accepted only if its one new segment (the junction) is clear, otherwise its parent
    is kept (not a failure; a child with a clear junction that overflows the capacity
    is a failure). When a loop cut removes the raw junction, the child is made
    of parent segments only and is accepted. Feasible, loop-free parents give feasible,
    loop-free children.

    ``check`` (static): ``"clear"`` (default, the exact line of sight
    :func:`jaxga.core.geometry.clear` under the grid's corner rule) or ``"linear_trial"``
    (AGACD's own eq. 3-6 probe, :func:`jaxga.core.geometry.linear_trial`; it ignores the
    corner rule, so children may then fail :func:`jaxga.core.paths.is_feasible`).
    """
    if check == "clear":
        seg_ok = clear
    elif check == "linear_trial":
        seg_ok = linear_trial
    else:
        raise ParameterError(f"unknown check {check!r}: expected 'clear' or 'linear_trial'")
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    l1, l2 = jnp.asarray(l1, I32), jnp.asarray(l2, I32)
    bits = jax.random.bits(key, (2,), _U32)
    i = _uniform_index(bits[0], l1 - 1)
    j = _uniform_index(bits[1], l2 - 1)
    pos2 = _position_lookup(c2, l2, grid.n_cells)(c1)
    pos1 = _position_lookup(c1, l1, grid.n_cells)(c2)
    k1 = _join(c1, i + 1, pos2, c2, l2, j + 1)
    k2 = _join(c2, j + 1, pos1, c1, l1, i + 1)
    ok1 = seg_ok(grid, k1.left, k1.right)
    ok2 = seg_ok(grid, k2.left, k2.right)
    do = (l1 >= 2) & (l2 >= 2)
    return _finish(do, ok1, ok2, k1, k2, c1, l1, c2, l2, need1=ok1, need2=ok2)


# --------------------------------------------------------------- heterologous
_OFFSETS9 = np.array([[dx, dy] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], np.int32)


def step_masks(grid: Grid, cells: jax.Array) -> jax.Array:
    """``int32[...]``: bit ``(dy + 1) * 3 + (dx + 1)`` set when the step from the cell by
    ``(dx, dy)`` is legal (:func:`jaxga.core.grid.move_legal`); bit 4 (no step) always set.

    With ``grid.tables`` attached the masks of all cells are read from them; otherwise, on
    maps of up to :data:`~jaxga.core.paths.TABLE_MAX_CELLS` cells the masks of all cells are
    built once per call (under a ``vmap`` over pairs the table is not batched) and
    gathered; on larger maps they are computed for the given cells only.
    """
    n_cells, w, h = grid.n_cells, grid.width, grid.height
    bit = jnp.left_shift(jnp.int32(1), jnp.arange(9, dtype=I32))

    def legal9(c):
        c = c[..., None]
        qx = c % w + _OFFSETS9[:, 0]
        qy = c // w + _OFFSETS9[:, 1]
        inside = (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h)
        legal = inside & move_legal(grid, c, jnp.where(inside, qy * w + qx, 0))
        return legal | (bit == 16)

    if grid.tables is not None:
        return grid.tables.step_masks[jnp.clip(cells, 0, n_cells - 1)]
    if n_cells > TABLE_MAX_CELLS:
        return jnp.sum(jnp.where(legal9(cells), bit, 0), axis=-1, dtype=I32)
    # The bits are packed with a matrix product: XLA fuses an elementwise/reduce table
    # into the gather that reads it (recomputing 9 move_legal per gathered element:
    # decision 010) but never a dot. Exact: integers below 2**9 in float32.
    legal = legal9(jnp.arange(n_cells, dtype=I32)).astype(F32)
    table = jnp.dot(legal, bit.astype(F32), precision=jax.lax.Precision.HIGHEST)
    return table.astype(I32)[jnp.clip(cells, 0, n_cells - 1)]


def heterologous_pairs(
    grid: Grid, c1: jax.Array, l1: jax.Array, c2: jax.Array, l2: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """All crossing points ``(i, j)`` of MPMGA's heterologous crossover, as a table.

    Returns ``(j int32[L, 9], valid bool[L, 9])``: row ``i`` lists the (at most nine)
    ``j`` such that ``(i, j)`` is a valid crossing pair, i.e. ``0 <= i <= l1 - 2``,
    ``0 <= j <= l2 - 2``, ``p1[i]`` equals or is legally adjacent
    (:func:`jaxga.core.grid.move_legal` under the grid's corner rule) to ``p2[j+1]``,
    ``p1[i+1]`` equals or is legally adjacent to ``p2[j]`` (MPMGA section 4.5 conditions
    (1), (2)), and the pair is not one of the two trivial ones ``(0, 0)`` and
    ``(l1 - 2, l2 - 2)`` (their children are the parents swapped: they play the role of
    the start and goal that the homologous crossover excludes).

    Speed: instead of testing all ``L^2`` pairs, condition (1) is inverted: ``p2[j+1]``
    must be one of the nine cells around ``p1[i]``, whose positions in parent 2 come
    from a cell lookup, so the work is ``9 L`` entries of two gathers each; legality
    comes from per-cell 9-bit step masks (:func:`step_masks`), so no division or
    obstacle lookup is done per entry. For a loop-free parent 2 (the population
    invariant) this enumerates every valid pair exactly once; with loops in parent 2 only
    the last visit of a cell is seen.
    """
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    n = c1.shape[0]
    w = grid.width
    x1, y1 = c1 % w, c1 // w
    qx = x1[:, None] + _OFFSETS9[:, 0]
    qy = y1[:, None] + _OFFSETS9[:, 1]
    inside = (qx >= 0) & (qx < w) & (qy >= 0) & (qy < grid.height)
    q = c1[:, None] + (_OFFSETS9[:, 1] * w + _OFFSETS9[:, 0])
    j = _position_lookup(c2, l2, grid.n_cells)(jnp.where(inside, q, -1)) - 1  # p2[j+1] = q
    i = jnp.arange(n, dtype=I32)[:, None]
    in_range = (i <= l1 - 2) & (j >= 0) & (j <= l2 - 2)
    m1 = step_masks(grid, c1)
    o = jnp.arange(9, dtype=I32)
    cond1 = (jnp.right_shift(m1[:, None], o) & 1) == 1
    # Condition (2): the step p1[i+1] -> p2[j]; coordinates of p2 packed in one word.
    m1n = jnp.concatenate([m1[1:], m1[-1:]])
    x1n = jnp.concatenate([x1[1:], x1[-1:]])
    y1n = jnp.concatenate([y1[1:], y1[-1:]])
    xy2 = jnp.left_shift(c2 // w, 16) | (c2 % w)
    b = xy2[jnp.clip(j, 0, n - 1)]
    dx = (b & 0xFFFF) - x1n[:, None]
    dy = jnp.right_shift(b, 16) - y1n[:, None]
    near = (jnp.abs(dx) <= 1) & (jnp.abs(dy) <= 1)
    code = jnp.where(near, (dy + 1) * 3 + (dx + 1), 0)
    cond2 = near & ((jnp.right_shift(m1n[:, None], code) & 1) == 1)
    trivial = ((i == 0) & (j == 0)) | ((i == l1 - 2) & (j == l2 - 2))
    return j, in_range & cond1 & cond2 & ~trivial


def heterologous(
    key: jax.Array,
    grid: Grid,
    c1: jax.Array,
    l1: jax.Array,
    c2: jax.Array,
    l2: jax.Array,
    *,
    fitness_fn: Callable,
) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]:
    """MPMGA's heterologous single-point crossover (MPMGA section 4.5, Figure 9).

    A crossing pair ``(i, j)`` (see :func:`heterologous_pairs`) is chosen uniformly among
    ALL valid pairs (the paper only says such a pair is "found"); the children are
    ``p1[:i+1] + p2[j+1:]`` and ``p2[:j+1] + p1[i+1:]``, continuous by construction,
    then their loops are removed (MPMGA's deletion operator). With MPMGA's "individual
    reception method", each child replaces its parent (child 1 -> slot 1) only if it is
    strictly fitter (``fitness_fn(child) > fitness_fn(parent)``; a tie keeps the parent).
    No valid pair -> no crossover (not a failure). A child that overflows the capacity
    fails (counted) and keeps its parent. The homologous crossover is the special case
    ``p1[i] == p2[j]``.

    ``fitness_fn(grid, cells, length) -> f32`` is static (bind it with
    ``functools.partial``); it is evaluated on the two parents and the two children.
    The second child's loop cut comes from the lookup of parent 1's cells in parent 2
    (:func:`_join_reverse`, exact for a loop-free parent 2), as in
    :func:`common_point`.
    """
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    l1, l2 = jnp.asarray(l1, I32), jnp.asarray(l2, I32)
    jtab, valid = heterologous_pairs(grid, c1, l1, c2, l2)
    count = jnp.sum(valid, dtype=I32)
    r = _uniform_index(jax.random.bits(key, (), _U32), count)
    i, o = _kth_true_rows(valid, r)
    j = jnp.maximum(jtab[i, o], 0)
    pos2 = _position_lookup(c2, l2, grid.n_cells)(c1)
    k1 = _join(c1, i + 1, pos2, c2, l2, j + 1)
    k2 = _join_reverse(c2, j + 1, c1, l1, i + 1, pos2)  # one lookup, as common_point
    paths = jnp.stack([c1, c2, k1.cells, k2.cells])
    lens = jnp.stack([l1, l2, k1.length, k2.length])
    f = jax.vmap(lambda c, ln: jnp.asarray(fitness_fn(grid, c, ln), F32))(paths, lens)
    do = count > 0
    return _finish(do, f[2] > f[0], f[3] > f[1], k1, k2, c1, l1, c2, l2)


# --------------------------------------------------------------------- column
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
    bits = jax.random.bits(key, (a,), _U32)
    r = _uniform_index(bits, cr.n_free)
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
    (every initial gap split once). Measured on the 20 x 20 classic map with median-
    insertion parents: 16 rounds close 30% of the children, 64 rounds 34-38%, at 4x
    the cost.

    ``field_repair`` (static; jaxga's extension, ``repair.fallback = "field"``): a
    connection that does not close gives the optimal path through the middle anchor
    down the exact distance fields (:func:`jaxga.operators.init.field_path`) as the child; needs
    ``grid.guide``.
    """
    n = jnp.asarray(c1).shape[0]
    h, w = grid.shape
    a = max(h, w)
    k_anchor, k_conn = jax.random.split(key)
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
        f_c, f_n, f_ok = field_path(jax.random.fold_in(k_conn, 7), grid,
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
    k_child, k_spin = jax.random.split(key)
    cc, cl, ok = column_child(
        k_child, grid, c1, l1, c2, l2, max_rounds=max_rounds, queue=queue,
        field_repair=field_repair,
    )
    paths = jnp.stack([c1, c2, cc])
    lens = jnp.stack([l1, l2, cl])
    f = jax.vmap(lambda c, ln: jnp.asarray(fitness_fn(grid, c, ln), F32))(paths, lens)
    wts = jnp.where(jnp.isnan(f), F32(0), jnp.maximum(f, F32(0)))
    u = jax.random.uniform(k_spin, (2,), F32)
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


# ------------------------------------------------------ crossover probability
def adaptive_crossover_probability(
    f: jax.Array,
    f_max: jax.Array,
    f_avg: jax.Array,
    t: jax.Array,
    T: jax.Array,
    pc_low: jax.Array,
    pc_high: jax.Array,
    rtol: float = 1e-6,
    schedule: Callable | None = None,
) -> jax.Array:
    """AGACD's adaptive crossover probability (AGACD section 4.6, eq. 26-27), float32.

    ``schedule`` (an optax schedule, e.g. :func:`jaxga.operators.schedules.agacd_crossover_decay`)
    replaces the time factor ``exp(-t / T)`` by ``schedule(t)``; without it the factor is
    computed directly (``T`` may then be traced).

    ``f`` is the larger fitness of the pair, ``f_max`` / ``f_avg`` the maximum / mean
    fitness of the population, ``t`` the current and ``T`` the total number of
    iterations::

        pc_temp = pc_low                                 if f_max == f_avg
                  pc_high * (f_max - f) / (f_max - f_avg) if f >= f_avg
                  pc_high                                 if f <  f_avg
        pc = pc_temp * exp(-t / T)

    jaxga follows eq. 26-27 of the paper as printed. Notes: the formula is
    continuous at ``f = f_avg`` (both branches give ``pc_high``) and gives 0 for a pair
    holding the population's best (``f = f_max``), which is therefore never crossed; the
    probability decays to ``pc_temp / e`` at ``t = T``. Decisions: "``f_max == f_avg``"
    is tested with a relative tolerance ``rtol`` (a float32 mean of equal values can
    differ from them by an ulp); the middle branch is clipped to ``[0, pc_high]`` (it
    can only leave that range if ``f > f_max``). Elementwise; broadcasts.
    """
    f, f_max, f_avg = (jnp.asarray(v, F32) for v in (f, f_max, f_avg))
    t, T = jnp.asarray(t, F32), jnp.asarray(T, F32)
    pc_low, pc_high = jnp.asarray(pc_low, F32), jnp.asarray(pc_high, F32)
    gap = f_max - f_avg
    converged = gap <= F32(rtol) * jnp.abs(f_max)
    safe_gap = jnp.where(converged, F32(1), gap)
    mid = jnp.clip(pc_high * (f_max - f) / safe_gap, 0, pc_high)
    pc_t = jnp.where(converged, pc_low, jnp.where(f >= f_avg, mid, pc_high))
    factor = jnp.exp(-t / T) if schedule is None else jnp.asarray(schedule(t), F32)
    return (pc_t * factor).astype(F32)


def adaptive_pair_probability(
    fitness: jax.Array,
    t: jax.Array,
    T: jax.Array,
    pc_low: jax.Array,
    pc_high: jax.Array,
    active: jax.Array | None = None,
    schedule: Callable | None = None,
) -> jax.Array:
    """``float32[P // 2]``: AGACD eq. 26-27 for the pairs ``(0, 1), (2, 3), ...``.

    ``f`` of pair ``k`` is ``max(fitness[2k], fitness[2k+1])`` (the pairs of
    :func:`jaxga.operators.lift.over_pairs`); ``f_max`` and ``f_avg`` are taken over the
    active individuals (all if ``active`` is None). Pass the result as the per-pair
    ``pc`` of :func:`crossover_population`. ``schedule``: as in
    :func:`adaptive_crossover_probability`.
    """
    fitness = jnp.asarray(fitness, F32)
    if active is None:
        active = jnp.ones(fitness.shape, bool)
    f_max = jnp.max(jnp.where(active, fitness, -jnp.inf))
    f_avg = ordered_mean(fitness, active)
    n_pairs = fitness.shape[0] // 2
    f = jnp.maximum(fitness[0 : 2 * n_pairs : 2], fitness[1 : 2 * n_pairs : 2])
    return adaptive_crossover_probability(f, f_max, f_avg, t, T, pc_low, pc_high,
                                          schedule=schedule)


def crossover_population(
    op: Callable, *, in_axes_extra: tuple = (), dense: bool = False, splicing: bool = False
) -> Callable:
    """Lift a pair operator with a crossover probability to a population.

    Returns ``lifted(key, grid, pop, pc, *extra) -> (Population, n_failed)``: pairs
    ``(0, 1), (2, 3), ...`` (shuffle first - the selections do), pair ``k`` crossed with
    probability ``pc[k]``; ``pc`` is a scalar (SGA, IMGA ``pc = 0.8``) or ``f32[P // 2]``
    per pair (AGACD: :func:`adaptive_pair_probability`). Built on
    :func:`jaxga.operators.lift.over_pairs`; ``in_axes_extra`` gives the vmap axes of ``extra``
    (default: all mapped along axis 0). With an odd population the last individual
    passes through. Only the pairs that are crossed are computed
    (:func:`jaxga.operators.lift.over_pairs_gated`); the result is that of
    every pair crossed and kept with probability ``pc``. ``dense=True`` computes every
    pair and selects
    (same result; cheaper at the papers' high crossover rates). ``splicing=True`` (with
    ``dense``; operators with the registry trait ``splicing`` only) computes the pairs on
    twice the window (:func:`jaxga.operators.lift.spliced_pairs_map`) when every parent fits it.
    """
    return over_pairs_gated(op, in_axes_extra=in_axes_extra, dense=dense, splicing=splicing)


# the family's operators (jaxga.operators.registry)
def _half_common_point_half_column(ctx: Binding) -> Callable:
    """Zhu & Pan 4.4 / 4.7 step 3: half the pairs through the common-point crossover,
    half through the column (non-common point) crossover, drawn per generation."""
    lifted = over_pairs_gated(operator("crossover", "common_point").bind(ctx),
                              alternative=operator("crossover", "column").bind(ctx))

    def run(key, grid, pop, pc):
        k_half, key = jax.random.split(key)
        return lifted(key, grid, pop, pc, split_half(k_half, pop.size // 2))

    return run


register(Operator("crossover", "common_point", common_point,
                  "single point at a cell both parents share (IMGA 4.3.2, Zhu & Pan 4.4)",
                  traits=frozenset({SPLICING})))
register(Operator("crossover", "cut_and_check", cut_and_check,
                  "single point, child kept only if its junction is collision-free "
                  "(AGACD 4.6)", traits=frozenset({WAYPOINTS})))
register(Operator("crossover", "heterologous", heterologous,
                  "single point between different cells, child kept only if fitter "
                  "(MPMGA 4.5)", traits=frozenset({NEEDS_FITNESS})))
register(Operator("crossover", "column", column,
                  "non-common point: join the parents across a column (Zhu & Pan 4.4)",
                  traits=frozenset({NEEDS_FITNESS, FIELD_REPAIR})))
register(Operator("crossover", "common_point_or_column", None,
                  "half the pairs common_point, half column (Zhu & Pan 4.4, 4.7 step 3)",
                  traits=frozenset({NEEDS_FITNESS, FIELD_REPAIR}),
                  population=_half_common_point_half_column, aliases=("zhu_mixed",)))
register_none("crossover", "no crossover")
