"""Mutation operators of the five papers, for ONE individual.

Every operator has the signature ``op(key, grid, cells, length, *extra) -> (cells,
length, failed)`` and is applied to a population with
:func:`jaxga.operators.lift.over_individuals` (``jax.vmap``; same key, same result)::

    mutate = over_individuals(functools.partial(neighbour_point, queue=16))
    pop, n_failed = mutate(key, grid, pop)

Static options (capacities of the connection, line-of-sight test, ``fitness_fn``) are
keyword arguments bound with :func:`functools.partial`; traced per-call values (the
annealing temperature, a mutation probability) are positional extras, mapped or not
through ``in_axes_extra``.

``failed`` contract (shared by every operator here): ``failed`` is True when the
operator was asked to mutate the individual and could not produce a valid mutant - no
mutation point / candidate cell exists, the connection (median insertion) or the regrowth
walk did not close, a line-of-sight check rejected the mutant, or the result would exceed
the capacity ``L``. The input is then returned unchanged (bit for bit). A mutant that is
produced but *rejected by design* (simulated-annealing acceptance in
:func:`segment_sa`) is not a failure, and the deterministic cleanup :func:`cut_corners`
never fails. AGACD (section 4.7) calls these "invalid mutations"; IMGA section 4.3.3 and
Zhu & Pan section 4.5 call them failures.

Conventions: positions are drawn from one bulk ``jax.random.bits`` call per individual
and reduced modulo the number of choices (bias below ``L / 2**32``); every valid result
starts at ``cells[0]``, ends at ``cells[length-1]``, is loop-free if the input is, and is
re-padded (docs, "the pure core"). Continuous operators keep a continuous path continuous under the
grid's corner rule; waypoint operators keep a feasible path feasible.

Probabilities: :func:`jaxga.operators.lift.over_individuals_gated` applies an operator
with a per-individual probability, computing only the individuals it selects (as
:func:`jaxga.operators.crossover.crossover_population` does for pairs);
:func:`adaptive_mutation_probability` is AGACD's eq. 28-29, and :func:`split_half` with
the gated lift's ``alternative`` implements Zhu & Pan's "half the population through one
operator, half through the other".
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core import prng
from jaxga.core.dtypes import I32
from jaxga.core.errors import ParameterError
from jaxga.core.fields import POS, Field
from jaxga.core.grid import DIRECTIONS, Grid, blocked_at, move_legal
from jaxga.operators import schedules
from jaxga.operators.init import directional_walk, field_reconnect
from jaxga.operators.lift import keep_parent_on_failure, over_individuals_gated
from jaxga.operators.postprocess import compact, line_of_sight
from jaxga.operators.registry import (
    FIELD_REPAIR,
    NEEDS_FITNESS,
    SHRINKING,
    WAYPOINTS,
    Binding,
    Operator,
    operator,
    register,
    register_none,
)
from jaxga.operators.repair import concat, connect, splice_loop_free

__all__ = [
    "adaptive_mutation_probability",
    "cut_corners",
    "delete_corner",
    "neighbour_point",
    "replace_point",
    "point_checked",
    "regrow_segment",
    "segment_sa",
    "split_half",
]

_U32 = jnp.uint32
# NumPy, not jnp: importing jaxga must not start JAX's backend (jaxga._runtime.parallel sets the
# device count first).
_OFF8 = np.asarray(DIRECTIONS, np.int32)


# ------------------------------------------------------------------------ helpers
def _below(bits: jax.Array, n: jax.Array) -> jax.Array:
    """Uniform integer in ``[0, n)`` from 32 random bits (``n >= 1``, int32)."""
    return (bits % jnp.maximum(n, 1).astype(_U32)).astype(I32)


def _uniform01(bits: jax.Array) -> jax.Array:
    """float32 uniform in ``[0, 1)`` from 32 random bits (24-bit resolution)."""
    return (bits >> 8).astype(jnp.float32) * jnp.float32(2.0**-24)


def _pick(bits: jax.Array, mask: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Index of a uniformly random True entry of the 1-D ``mask``, and whether one exists."""
    count = jnp.sum(mask, dtype=I32)
    rank = _below(bits, count)
    hit = mask & (jnp.cumsum(mask, dtype=I32) - 1 == rank)
    return jnp.argmax(hit).astype(I32), count > 0


def _interior(bits: jax.Array, length: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Uniform interior position ``1 .. length-2`` and whether the path has one."""
    return 1 + _below(bits, length - 2), length >= 3


def _segment(b0: jax.Array, b1: jax.Array, length: jax.Array):
    """Uniform pair of positions ``0 <= i < j <= length-1`` with ``j - i >= 2``.

    Two distinct values ``u != v`` uniform in ``0 .. length-2``; ``i = min``,
    ``j = max + 1``: a bijection onto the pairs with at least one node between them, so
    the pair is uniform over those. Returns ``(i, j, ok)``, ``ok`` False for paths of
    fewer than 3 nodes.
    """
    m = length - 1
    u = _below(b0, m)
    v = _below(b1, m - 1)
    v = v + (v >= u).astype(I32)
    return jnp.minimum(u, v), jnp.maximum(u, v) + 1, length >= 3


def _neighbours(grid: Grid, cell: jax.Array, offsets: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Cells ``cell + offsets`` (int32[K]) and whether each is on the map and free."""
    w = grid.width
    x = cell % w + offsets[:, 0]
    y = cell // w + offsets[:, 1]
    free = ~blocked_at(grid.blocked, x, y)  # off the map counts as blocked
    return jnp.where(free, y * w + x, 0).astype(I32), free


def _finish(ok, new_cells, new_length, cells, length):
    failed = ~ok
    out_c, out_l = keep_parent_on_failure(failed, new_cells, new_length, cells, length)
    return out_c, out_l, failed


# ------------------------------------------------------------ IMGA neighbour point
def neighbour_point(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    seg_capacity: int = 16,
    max_rounds: int = 16,
    queue: int = 8,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """IMGA's eight-neighbourhood single-point mutation (IMGA section 4.3.3, Fig. 2).

    Pick a random node ``N_i`` other than S and G; replace it with a random free cell
    ``N_i'`` of its 8-neighbourhood other than its path neighbours ``N_{i-1}``,
    ``N_{i+1}``; connect ``N_{i-1} -> N_i' -> N_{i+1}`` "according to the initial path
    generation method" (median insertion, :func:`jaxga.operators.repair.connect`, which enforces
    the corner rule) and remove the loops this creates (:func:`jaxga.core.paths.remove_loops`).

    Fails (IMGA: "this mutation fails") when the path has no interior node, no free
    candidate exists, the connection does not close, or the result exceeds the capacity.

    Decisions: the candidate is uniform over the free 8-neighbours (IMGA says
    "randomly"); it may be a cell already on the path (loop removal, jaxga's step and
    not the paper's, then shortens the path: decision 057). The capacity is checked
    AFTER loop removal (the splice is built in a work buffer of ``L + seg_capacity``
    cells), so a mutant that only temporarily exceeds ``L`` is not lost. Both gaps are
    at most 2 cells wide, so the connection is run with a small node table
    ``seg_capacity`` (static; a connection that needs more nodes fails), ``max_rounds``
    and ``queue``; overflowing any of them
    is a failure, never a corruption.
    """
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    k_conn, k_bits = prng.split(key)
    bits = prng.bits(k_bits, (2,), _U32)
    i, has_node = _interior(bits[0], length)
    prev, node, nxt = cells[i - 1], cells[i], cells[jnp.minimum(i + 1, cap - 1)]
    cand, free = _neighbours(grid, node, _OFF8)
    j, has_cand = _pick(bits[1], free & (cand != prev) & (cand != nxt))
    anchors = jnp.stack([prev, cand[j], nxt])
    seg, seg_len, closed = connect(k_conn, grid, anchors, 3, seg_capacity, max_rounds, queue)
    new, new_len, ok = splice_loop_free(cells, length, i - 1, seg, seg_len, i + 2, grid.n_cells)
    return _finish(has_node & has_cand & closed & ok, new, new_len, cells, length)


# ---------------------------------------------------------------- Zhu one point
def replace_point(
    key: jax.Array, grid: Grid, cells: jax.Array, length: jax.Array
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Zhu & Pan's one-point mutation (section 4.5, Fig. 6).

    (i) pick a random node ``p_m`` other than the start and target; (ii) delete it and
    find the set ``Y`` of cells that make ``p_{m-1}`` and ``p_{m+1}`` consecutive; (iii)
    put a random cell of ``Y`` in place of ``p_m``. Empty ``Y``: no mutation (jaxga's
    choice; the paper does not say), reported as ``failed``.

    Decisions: "consecutive" means both steps ``p_{m-1} -> y -> p_{m+1}`` are legal
    moves under the grid's corner rule; ``Y`` excludes ``p_m`` itself (a mutation that
    changes nothing is no mutation) and every cell already on the path (Zhu's chromosomes
    "do not allow duplicate grid numbers"), so the path length is unchanged and no loop
    is created; the choice is uniform over ``Y``. Cost: 8 candidates, ``8 L``
    comparisons, no loop.
    """
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    bits = prng.bits(key, (2,), _U32)
    m, has_node = _interior(bits[0], length)
    prev, nxt = cells[m - 1], cells[jnp.minimum(m + 1, cap - 1)]
    cand, free = _neighbours(grid, prev, _OFF8)
    # The padding repeats the goal, which is on the path anyway: compare with all cells.
    on_path = jnp.any(cand[:, None] == cells[None, :], axis=1)
    ok = free & move_legal(grid, prev, cand) & move_legal(grid, cand, nxt) & ~on_path
    j, has_cand = _pick(bits[1], ok)
    new = jnp.where(jnp.arange(cap, dtype=I32) == m, cand[j], cells)
    return _finish(has_node & has_cand, new, length, cells, length)


# ---------------------------------------------------------------- Zhu range
def regrow_segment(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    factors: tuple[float, float] = (3.0, 2.0),
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Zhu & Pan's range mutation (section 4.5, Fig. 7).

    (i) pick two random nodes ``p_i``, ``p_j`` and delete the path between them; (ii)
    "set ``p_i`` as the start point and ``p_j`` as the target point. Determine a new path
    by using the method of population initialization" - the directionally guided walk of
    Algorithm 1, :func:`jaxga.operators.init.directional_walk` (``factors``: its eq. 5
    multipliers); "if a new path is not found, the mutation fails".

    Decisions where the paper is silent: the pair is uniform over ``i < j`` with
    ``j - i >= 2`` (at least one node deleted, as for :func:`segment_sa`); the kept parts
    of the parent (``p_0 .. p_{i-1}`` and ``p_{j+1} .. p_{n-1}``) count as visited for the
    walk, so the regrown stretch never re-enters them and the result is loop-free without
    loop removal (Zhu's chromosomes "do not allow duplicate grid numbers"); the walk's
    step cap is the capacity. ``failed`` when the path has fewer than 3 nodes, the walk
    hits a dead end or its step cap, or the spliced path exceeds the capacity.

    ``field_repair`` (static; jaxga's extension, ``repair.fallback = "field"``): a walk
    that dead-ends is replaced by the walk down the goal's exact distance field from
    ``p_i`` (:func:`jaxga.operators.init.field_reconnect`), which cannot dead-end; needs
    ``grid.guide``.
    """
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    idx = jnp.arange(cap, dtype=I32)
    k_walk, k_bits = prng.split(key)
    bits = prng.bits(k_bits, (2,), _U32)
    i, j, has_seg = _segment(bits[0], bits[1], length)
    exclude = jnp.where((idx < i) | ((idx > j) & (idx < length)), cells, -1)
    seg, seg_len, reached = directional_walk(
        k_walk, grid, cells[i], cells[j], cap, exclude=exclude, factors=factors
    )
    new, new_len, fits = concat([(cells, 0, i), (seg, 0, seg_len), (cells, j + 1, length)], cap)
    ok = has_seg & reached & fits
    if field_repair:
        new, new_len, ok = _field_repaired(k_walk, grid, cells, length, i, j, has_seg,
                                           (new, new_len, ok))
    return _finish(ok, new, new_len, cells, length)


def _field_repaired(key, grid, cells, length, i, j, has_seg, result):
    """``result`` where ok, else the path reconnected down the goal's field from
    position ``i`` (:func:`jaxga.operators.init.field_reconnect`)."""
    new, new_len, ok = result
    f_c, f_n, f_ok = field_reconnect(prng.fold_in(key, 7), grid, cells, length, i, j)
    return (jnp.where(ok, new, f_c), jnp.where(ok, new_len, f_n), ok | (has_seg & f_ok))


# ------------------------------------------------------------------ MPMGA segment
def segment_sa(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    temperature: jax.Array,
    *,
    fitness_fn: Callable[[Grid, jax.Array, jax.Array], jax.Array],
    seg_capacity: int | None = None,
    max_rounds: int = 32,
    queue: int | None = None,
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """MPMGA's single-gene-segment mutation with simulated-annealing acceptance (4.6).

    Delete a random gene segment, repair the gap with the connection operator (median
    insertion, :func:`jaxga.operators.repair.connect`) and remove loops; then accept the mutant
    with MPMGA eq. 15-16::

        a = (fitness(old) - fitness(new)) / T
        p(new) = 1                 if fitness(new) > fitness(old)
                 1 / (1 + e**a)    if fitness(new) <= fitness(old)

    Sign check: for a worse mutant ``a > 0``, so ``p < 1/2``, and ``p -> 0`` as
    ``T -> 0``: worse mutants are accepted with a probability that falls as the
    temperature falls, as MPMGA's text says. An equally fit mutant is accepted with
    probability exactly 1/2 (eq. 16 puts equality in the second case). The temperature
    schedule is eq. 17, ``T = c1 * w**t`` (c1 = 1, w = 0.7 or 0.9): the caller passes
    ``temperature`` as a traced scalar, e.g. from
    ``optax.exponential_decay(c1, 1, w)(t)``; ``T <= 0`` is treated as the limit
    ``T -> 0+`` (worse mutants never accepted, equal ones with 1/2).

    Args:
        temperature: float32 scalar ``T`` (an extra positional argument: with
            :func:`~jaxga.operators.lift.over_individuals` pass ``in_axes_extra=(None,)``).
        fitness_fn: STATIC ``(grid, cells, length) -> f32`` (bind with
            :func:`functools.partial`, e.g. ``partial(objectives.mpmga)``). Evaluated on
            the parent and the mutant.
        seg_capacity: static node-table size of the connection (default ``L``): a
            reconnection that needs more nodes fails.
        max_rounds, queue: static bounds of ``connect`` (rounds of median insertion, gaps
            open at once). ``queue`` defaults to ``max(H, W) // 2 + 8`` (a gap of
            Chebyshev length D has about D / 2 sub-gaps open at its widest round).
            ``max_rounds = 32``: fewer rounds lose reconnections and more close no
            more, while under ``vmap`` every lane pays for the slowest, so the default
            is the smallest bound that lost nothing measurable (decision 044).

    Decisions: the deleted segment is the open stretch between positions ``i < j`` drawn
    uniformly among the pairs with ``j - i >= 2`` (at least one node deleted; the
    endpoints ``p_i``, ``p_j`` stay and are reconnected); MPMGA's Fig. 10 shows a
    segment of interior genes. ``failed`` (parent returned) when the path has fewer than
    3 nodes, the connection does not close (or needs more than ``seg_capacity`` nodes),
    or the result exceeds the capacity ``L`` (checked after loop removal, in a work
    buffer of ``L + seg_capacity`` cells). A rejected mutant is NOT a failure.

    ``field_repair`` (static; jaxga's extension, ``repair.fallback = "field"``): a
    connection that does not close is replaced by the walk down the goal's exact
    distance field from ``p_i`` (:func:`jaxga.operators.init.field_reconnect`); the mutant is then
    accepted or rejected as any other. Needs ``grid.guide``.
    """
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    k_conn, k_bits = prng.split(key)
    bits = prng.bits(k_bits, (3,), _U32)
    i, j, has_seg = _segment(bits[0], bits[1], length)
    seg, seg_len, closed = connect(
        k_conn, grid, jnp.stack([cells[i], cells[j]]), 2, seg_capacity or cap, max_rounds,
        queue or max(grid.shape) // 2 + 8,
    )
    new, new_len, fits = splice_loop_free(cells, length, i, seg, seg_len, j + 1, grid.n_cells)
    ok = has_seg & closed & fits
    if field_repair:
        new, new_len, ok = _field_repaired(k_conn, grid, cells, length, i, j, has_seg,
                                           (new, new_len, ok))
    f_old = jnp.asarray(fitness_fn(grid, cells, length), jnp.float32)
    f_new = jnp.asarray(fitness_fn(grid, new, new_len), jnp.float32)
    t = jnp.maximum(jnp.asarray(temperature, jnp.float32), jnp.finfo(jnp.float32).tiny)
    p = jnp.where(f_new > f_old, jnp.float32(1.0), jax.nn.sigmoid((f_new - f_old) / t))
    accept = _uniform01(bits[2]) < p
    out_c, out_l = keep_parent_on_failure(~(ok & accept), new, new_len, cells, length)
    return out_c, out_l, ~ok


# -------------------------------------------------------------- AGACD point
def point_checked(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    radius: int = 2,
    los: str = "clear",
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """AGACD's single-gene point mutation with collision detection (section 4.7).

    Pick a random node other than the start and goal, move it to a random free cell
    within ``radius`` (Chebyshev), and accept the mutant only if both adjacent segments
    ``prev -> new`` and ``new -> next`` pass the line-of-sight test (AGACD section 4.1:
    infeasible individuals produced by mutation are removed by the collision detection
    of section 3). For feasible *waypoint* paths.

    Decisions where AGACD is silent (it only says "single-gene point mutation"):
    ``radius`` (static, default 2; beyond the map's larger side minus one it changes
    nothing and is clamped) bounds the move; the new cell is uniform over the free
    cells of the ``(2r+1)^2`` square other than the node itself and any cell already on
    the path (so the path stays loop-free and keeps its length); ``los`` (static) is
    ``"clear"`` (exact, honours the corner rule, default) or ``"linear_trial"``
    (AGACD's own check, eq. 3-6). ``failed`` when there is no interior node, no candidate,
    or a segment is not clear (AGACD's "invalid mutation").
    """
    if radius < 1:
        raise ParameterError(f"radius must be >= 1, got {radius}")
    # the map's larger side minus one already reaches every cell: a larger radius gives
    # the same candidate cells (but would build a (2r+1)^2 offset table per node)
    radius = max(1, min(radius, max(grid.blocked.shape) - 1))
    sees = line_of_sight(los)
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    r = np.arange(-radius, radius + 1)
    off = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)
    off = jnp.asarray(off[np.any(off != 0, axis=1)], jnp.int32)
    bits = prng.bits(key, (2,), _U32)
    i, has_node = _interior(bits[0], length)
    prev, node, nxt = cells[i - 1], cells[i], cells[jnp.minimum(i + 1, cap - 1)]
    cand, free = _neighbours(grid, node, off)
    on_path = jnp.any(cand[:, None] == cells[None, :], axis=1)
    j, has_cand = _pick(bits[1], free & ~on_path)
    c = cand[j]
    ok = has_node & has_cand & sees(grid, prev, c) & sees(grid, c, nxt)
    new = jnp.where(jnp.arange(cap, dtype=I32) == i, c, cells)
    return _finish(ok, new, length, cells, length)


# --------------------------------------------------------------- Zhang corner cut
def _knight_clear(grid: Grid, a: jax.Array, b: jax.Array) -> jax.Array:
    """Line of sight for a knight move ``a -> b`` (|dx|, |dy|) = (1, 2) or (2, 1).

    Such a segment meets no grid vertex and crosses exactly four cells: the two ends and
    the two cells between them (for ``dx = 2 sx, dy = sy``: ``(ax+sx, ay)`` and
    ``(ax+sx, ay+sy)``), so it is clear iff those four are free, whatever the corner
    rule; this equals :func:`jaxga.core.geometry.clear`. It is jaxga's reading of Zhang's
    condition "the upper and lower grids of the mutation point are free" (decision 057):
    the cells the knight move's segment crosses, which for ``N_{i+1} - N_{i-1} = 12``
    with ``N_i = N_{i-1} + 1`` are ``N_i`` and the cell above it, not the one below.
    False for any other offset.
    """
    w = grid.width
    ax, ay, bx, by = a % w, a // w, b % w, b // w
    dx, dy = bx - ax, by - ay
    knight = ((jnp.abs(dx) == 2) & (jnp.abs(dy) == 1)) | ((jnp.abs(dx) == 1) & (jnp.abs(dy) == 2))
    # The middle pair: one step along the long axis, then the short-axis offset.
    long_x = jnp.abs(dx) == 2
    mx = ax + jnp.where(long_x, dx // 2, 0)
    my = ay + jnp.where(long_x, 0, dy // 2)
    m2x = jnp.where(long_x, mx, mx + dx)
    m2y = jnp.where(long_x, my + dy, my)
    free = ~blocked_at(grid.blocked, ax, ay) & ~blocked_at(grid.blocked, bx, by)
    free &= ~blocked_at(grid.blocked, mx, my) & ~blocked_at(grid.blocked, m2x, m2y)
    return knight & free


def cut_corners(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    knight: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """A corner-removing pass after Zhang's eq. 3-5: every node of the path, left to right.

    Not Zhang's mutation as such: the paper mutates ONE gene at a random position ("use
    the random number method to determine the individual's mutation position"); this
    pass applies its rules to every node (``hybrid`` and ``pareto`` use it as a
    simplification; ``iga_zhang`` does not, see its preset).

    Zhang examines each node ``N_i`` with its neighbours ``N_{i-1}``, ``N_{i+1}`` on a
    10-wide grid and deletes ``N_i`` when ``N_{i+1} - N_{i-1}`` is 10 or 1 (the
    neighbours are orthogonally adjacent: a 45-degree corner, eq. 3), 11 (diagonally
    adjacent: a 90-degree corner, eq. 4), or 12 or 21 (a knight move apart: a 135-degree
    corner, eq. 5, only "if the upper and lower grids of the mutation point are free").
    The paper lists only the positive differences of its examples; jaxga applies the
    rule in all 8 directions and on any width: delete ``N_i`` when

    * ``N_{i-1} -> N_{i+1}`` is a legal move under the corner rule (eq. 3-4; the path
      stays continuous), or
    * ``knight=True`` (static) and ``N_{i-1} -> N_{i+1}`` is a clear knight move
      (eq. 5; the path becomes a feasible waypoint path, which is what Zhang's fitness of
      segment lengths and turns then scores).

    The pass is sequential: after deleting ``N_i``, node ``N_{i+1}`` is examined with
    the last *kept* node as its predecessor. Implemented as a fixed-length
    ``lax.scan`` over the capacity (scalar work per step) and one compaction. Zhang uses
    mutation probability 1. Deterministic (``key`` unused, kept for the common
    signature); never fails (``failed`` always False). A continuous loop-free input stays
    continuous (``knight=False``) or feasible (``knight=True``), loop-free, and no longer.
    """
    del key
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    idx = jnp.arange(cap, dtype=I32)
    if cap < 3:
        return cells, length, jnp.zeros((), bool)

    def step(prev, k):
        cur, nxt = cells[k], cells[k + 1]
        cut = (k + 1 < length) & move_legal(grid, prev, nxt)
        if knight:
            cut |= (k + 1 < length) & _knight_clear(grid, prev, nxt)
        return jnp.where(cut, prev, cur), cut

    _, cut = jax.lax.scan(step, cells[0], jnp.arange(1, cap - 1, dtype=I32))
    dropped = jnp.concatenate([jnp.zeros((1,), bool), cut, jnp.zeros((1,), bool)])
    out, out_len = compact(cells, (idx < length) & ~dropped)
    return out, out_len, jnp.zeros((), bool)


def delete_corner(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    knight: bool = True,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Zhang's improved mutation at one random mutation position (Zhang, "Research
    Method" and "Improved Mutation Operators", eq. 3-5).

    The paper mutates an individual at one position drawn at random ("use the random
    number method to determine the individual's mutation position, and mutate the gene at
    this position") and deletes that gene ``N_i`` when ``N_{i-1}, N_i, N_{i+1}`` form a
    45 degree corner (``N_{i+1} - N_{i-1}`` = 10 or 1 on its 10-wide grid: the neighbours
    are orthogonally adjacent, eq. 3), a 90 degree corner (11: diagonally adjacent, eq. 4)
    or a 135 degree corner (12 or 21: a knight move apart, eq. 5) "if the upper and lower
    grids of the gene position of the mutation point are free". jaxga draws the position
    uniformly among the interior nodes and applies the rule in all 8 directions and on any
    width: ``N_i`` is deleted when ``N_{i-1} -> N_{i+1}`` is a legal move under the
    corner rule (eq. 3-4: the path stays continuous) or, with ``knight`` (static), a clear
    knight move (eq. 5, :func:`_knight_clear`: the path becomes a feasible waypoint path,
    scored by Zhang's fitness of segment lengths and turns). Not a corner, or a path
    without an interior node: no mutation, reported as ``failed`` (the parent is kept).
    A feasible loop-free input stays feasible, loop-free, and one node shorter.
    """
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    if cap < 3:
        return cells, length, jnp.ones((), bool)
    i, has_node = _interior(prng.bits(key, (), _U32), length)
    prev, nxt = cells[i - 1], cells[jnp.minimum(i + 1, cap - 1)]
    corner = move_legal(grid, prev, nxt)
    if knight:
        corner |= _knight_clear(grid, prev, nxt)
    idx = jnp.arange(cap, dtype=I32)
    shifted = cells[jnp.minimum(idx + 1, cap - 1)]
    new = jnp.where(idx < i, cells, shifted)
    return _finish(has_node & corner, new, length - 1, cells, length)


# ------------------------------------------------------------- probabilities
def adaptive_mutation_probability(
    f: jax.Array,
    f_max: jax.Array,
    f_avg: jax.Array,
    t: jax.Array,
    T: jax.Array,  # noqa: N803 - the paper's name
    pm_low: float | jax.Array = 0.15,
    pm_high: float | jax.Array = 0.3,
    *,
    rtol: float = 1e-6,
    schedule: Callable | None = None,
) -> jax.Array:
    """AGACD's adaptive mutation probability (eq. 28-29), float32, elementwise.

    ``schedule`` (an optax schedule, e.g. :func:`jaxga.operators.schedules.agacd_mutation_growth`)
    replaces the time factor ``exp(t / T)`` by ``schedule(t)``.

    ::

        pm_temp = pm_high                                 if f_max = f_avg
                  pm_low * (f_max - f) / (f_max - f_avg)  if f >= f_avg, f_max != f_avg
                  pm_high                                 if f <  f_avg, f_max != f_avg
        pm      = min(1, pm_temp * exp(t / T))

    ``f`` the individual's fitness, ``f_max``/``f_avg`` the population's maximum and
    mean, ``t`` the current and ``T`` the total number of iterations; AGACD's defaults
    ``pm_low = 0.15``, ``pm_high = 0.3`` (Table 6). Everything broadcasts and may be
    traced (``t`` from the generation counter; ``exp(t/T)`` is an optax schedule too).

    Notes on the paper (jaxga's choices where it is ambiguous or incomplete):

    * eq. 28 as printed reads "f_avg and f_max != f_avg" in its second case; the text
      and eq. 26 make it ``f >= f_avg``.
    * eq. 29 has no ``min(1, .)``; jaxga adds it. With AGACD's 0.15/0.3 the product stays
      below ``0.3 e = 0.82``, so the clamp only matters for larger ``pm_high`` (e.g. the
      0.6 of the 50 x 50 comparison table) or ``t > T``.
    * Unlike crossover (eq. 26: ``pc_low``), a converged population (f_max = f_avg) gets
      the HIGH rate "to try to break the current optimal solution"; the best
      individual of an unconverged population gets ``pm_temp = 0``.
    * Decision: ``f_max = f_avg`` is tested as ``f_max - f_avg <= rtol * |f_max|``: a
      float32 mean of identical fitnesses can differ from them by an ulp, which would
      otherwise give a converged population ``pm = 0`` instead of ``pm_high``.
    """
    f32 = jnp.float32
    f, f_max, f_avg = (jnp.asarray(v, f32) for v in (f, f_max, f_avg))
    t, T = jnp.asarray(t, f32), jnp.asarray(T, f32)  # noqa: N806
    pm_low, pm_high = jnp.asarray(pm_low, f32), jnp.asarray(pm_high, f32)
    gap = f_max - f_avg
    converged = gap <= f32(rtol) * jnp.abs(f_max)
    scaled = pm_low * (f_max - f) / jnp.where(converged, f32(1.0), gap)
    pm_temp = jnp.where(converged, pm_high, jnp.where(f >= f_avg, scaled, pm_high))
    factor = jnp.exp(t / T) if schedule is None else jnp.asarray(schedule(t), f32)
    return jnp.minimum(f32(1.0), pm_temp * factor)


def split_half(key: jax.Array, n: int) -> jax.Array:
    """``bool[n]`` with exactly ``n // 2`` True entries at uniformly random positions."""
    return prng.permutation(key, n) < n // 2


# the family's operators (jaxga.operators.registry)
def _half_replace_point_half_regrow(ctx: Binding) -> Callable:
    """Zhu & Pan 4.5 / 4.7 step 3: half the individuals through the one-point mutation
    (``replace_point``), half through the range mutation (``regrow_segment``)."""
    lifted = over_individuals_gated(operator("mutation", "replace_point").bind(ctx),
                                    alternative=operator("mutation", "regrow_segment").bind(ctx))

    def run(key, grid, pop, pm):
        k_half, key = prng.split(key)
        return lifted(key, grid, pop, pm, split_half(k_half, pop.size))

    return run


def _check_annealing(config: Mapping) -> None:
    if not config["mutation.temperature_w"] > 0:
        raise ParameterError("mutation.temperature_w must be in (0, 1] (MPMGA eq. 17: "
                             f"T = c1 * w**t), got {config['mutation.temperature_w']}")


def _annealing_temperature(ctx: Binding) -> dict:
    """MPMGA eq. 17: ``T = c1 * w**t`` at iteration ``t`` (1 in the first generation;
    ``c1`` and ``w`` traced)."""
    schedule = schedules.mpmga_temperature(ctx.params["mutation.temperature_c1"],
                                           ctx.params["mutation.temperature_w"])
    return {"temperature": schedule(ctx.generation)}


register(Operator("mutation", "neighbour_point", neighbour_point,
                  "move a node to a free 8-neighbour and reconnect (IMGA 4.3.3)"))
register(Operator("mutation", "replace_point", replace_point,
                  "replace a node by another cell adjacent to both its neighbours "
                  "(Zhu & Pan 4.5 one-point mutation)", aliases=("one_point",)))
register(Operator("mutation", "regrow_segment", regrow_segment,
                  "delete the path between two nodes and regrow it by Algorithm 1's walk "
                  "(Zhu & Pan 4.5 range mutation)", traits=frozenset({FIELD_REPAIR}),
                  aliases=("range",)))
register(Operator(
    "mutation", "segment_sa", segment_sa,
    "delete a segment, reconnect, accept by simulated annealing (MPMGA 4.6, eq. 15-17)",
    params={
        "mutation.temperature_c1": Field(**POS, doc="MPMGA annealing T = c1 * w**t: c1"),
        "mutation.temperature_w": Field(float, low=0.0, high=1.0, dynamic=True,
                                        doc="MPMGA annealing T = c1 * w**t: decay rate w "
                                            "in (0, 1]"),
    },
    traits=frozenset({NEEDS_FITNESS, FIELD_REPAIR}), options=_annealing_temperature,
    required=("mutation.temperature_c1", "mutation.temperature_w"), check=_check_annealing,
))
register(Operator(
    "mutation", "point_checked", point_checked,
    "move a node within a radius, kept only if collision-free (AGACD 4.7)",
    params={"mutation.radius": Field(
        int, "AGACD point mutation radius in cells", low=1, high=10_000,
        default=inspect.signature(point_checked).parameters["radius"].default)},
    traits=frozenset({WAYPOINTS}),
    options=lambda ctx: {"radius": int(ctx.config.get("mutation.radius"))},
))
register(Operator("mutation", "replace_point_or_regrow", None,
                  "half replace_point, half regrow_segment (Zhu & Pan 4.5, 4.7 step 3)",
                  traits=frozenset({FIELD_REPAIR}), population=_half_replace_point_half_regrow,
                  aliases=("zhu_mixed",)))
register(Operator("mutation", "delete_corner", delete_corner,
                  "delete the node at one random position when it is a 45, 90 or 135 degree "
                  "corner (Zhang eq. 3-5)", traits=frozenset({SHRINKING, WAYPOINTS})))
register_none("mutation", "no mutation")
