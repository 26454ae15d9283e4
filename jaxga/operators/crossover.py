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

The splice and loop cut that the single-point crossovers share are in
:mod:`jaxga.operators.joins`; Zhu & Pan's column crossover is in
:mod:`jaxga.operators.column_crossover`. Every operator of the family is registered here.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.numerics import ordered_mean
from jaxga.core import prng
from jaxga.core.dtypes import F32, I32
from jaxga.core.errors import ParameterError
from jaxga.core.geometry import clear, linear_trial
from jaxga.core.grid import Grid, move_legal
from jaxga.core.paths import TABLE_MAX_CELLS
from jaxga.core.paths import position_lookup as _position_lookup
from jaxga.operators.column_crossover import column
from jaxga.operators.joins import (
    accept_children,
    join,
    join_reverse,
    kth_true,
    kth_true_rows,
    uniform_index,
)
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

__all__ = [
    "adaptive_crossover_probability",
    "adaptive_pair_probability",
    "common_point",
    "crossover_population",
    "cut_and_check",
    "heterologous",
    "heterologous_pairs",
]

_U32 = jnp.uint32


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
    removed: jaxga's step (decision 057), not IMGA's, whose 4.3.2 shows the swap alone;
    a child with a loop would otherwise revisit cells. No common cell -> no crossover:
    the parents are returned and nothing is counted as failed. A child that would exceed
    the capacity even after loop removal fails and keeps its parent (the other child is
    still accepted).

    Continuous, loop-free parents give continuous, loop-free children. Cost: one cell
    lookup (where parent 1's cells are in parent 2; the second child's loop cut is read
    off it too, :func:`~jaxga.operators.joins.join_reverse`, exact for a loop-free
    parent 2) and a few gathers of length ``L``; no scan, no O(L^2) matrix. The lookups
    (a scatter per parent) are most of the operator's time, so it does one lookup instead
    of two, with the same children (decision 010).
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
    r = uniform_index(prng.bits(key, (), _U32), count)
    ci = kth_true(cand, r)
    cj = pos2[ci]
    k1 = join(c1, ci, pos2, c2, l2, cj)
    k2 = join_reverse(c2, cj, c1, l1, ci, pos2)  # no second lookup (p2's cells in p1)
    do = count > 0
    return accept_children(do, k1.ok, k2.ok, k1, k2, c1, l1, c2, l2)


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
    bits = prng.bits(key, (2,), _U32)
    i = uniform_index(bits[0], l1 - 1)
    j = uniform_index(bits[1], l2 - 1)
    pos2 = _position_lookup(c2, l2, grid.n_cells)(c1)
    pos1 = _position_lookup(c1, l1, grid.n_cells)(c2)
    k1 = join(c1, i + 1, pos2, c2, l2, j + 1)
    k2 = join(c2, j + 1, pos1, c1, l1, i + 1)
    ok1 = seg_ok(grid, k1.left, k1.right)
    ok2 = seg_ok(grid, k2.left, k2.right)
    do = (l1 >= 2) & (l2 >= 2)
    return accept_children(do, ok1, ok2, k1, k2, c1, l1, c2, l2, need1=ok1, need2=ok2)


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
    c1n = jnp.concatenate([c1[1:], c1[-1:]])  # sliced before dividing: decision 048
    x1n, y1n = c1n % w, c1n // w
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
    (:func:`~jaxga.operators.joins.join_reverse`, exact for a loop-free parent 2), as in
    :func:`common_point`.
    """
    c1, c2 = jnp.asarray(c1, I32), jnp.asarray(c2, I32)
    l1, l2 = jnp.asarray(l1, I32), jnp.asarray(l2, I32)
    jtab, valid = heterologous_pairs(grid, c1, l1, c2, l2)
    count = jnp.sum(valid, dtype=I32)
    r = uniform_index(prng.bits(key, (), _U32), count)
    i, o = kth_true_rows(valid, r)
    j = jnp.maximum(jtab[i, o], 0)
    pos2 = _position_lookup(c2, l2, grid.n_cells)(c1)
    k1 = join(c1, i + 1, pos2, c2, l2, j + 1)
    k2 = join_reverse(c2, j + 1, c1, l1, i + 1, pos2)  # one lookup, as common_point
    paths = jnp.stack([c1, c2, k1.cells, k2.cells])
    lens = jnp.stack([l1, l2, k1.length, k2.length])
    f = jax.vmap(lambda c, ln: jnp.asarray(fitness_fn(grid, c, ln), F32))(paths, lens)
    do = count > 0
    return accept_children(do, f[2] > f[0], f[3] > f[1], k1, k2, c1, l1, c2, l2)


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
        k_half, key = prng.split(key)
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
