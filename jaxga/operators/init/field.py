"""Field walks: paths down the exact distance fields that cannot fail where a path exists
(decision 018), and the field reconnections the repairs use (decision 019)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.lanes import lane_while_loop
from jaxga.core import prng
from jaxga.core.dtypes import F32, I32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import DIRECTIONS, Grid
from jaxga.core.paths import (
    pad,
    position_lookup,
    remove_loops,
)
from jaxga.operators.init.common import check_capacity, fit_to_capacity, move_tables, write_at
from jaxga.operators.repair import splice_loop_free

# ------------------------------------------------------------------ field walks
_STEP_COST = np.where(np.all(DIRECTIONS != 0, axis=1), np.sqrt(2.0), 1.0).astype(np.float32)
"""Length of a step in each of the 8 :data:`jaxga.core.grid.DIRECTIONS`."""


FIELD_SLACK = 0.5
"""Default ``slack`` of :func:`field_walk`: paths up to 1.5 times the optimum."""


FIELD_TEMPERATURE = 1.0
"""Default ``temperature`` of :func:`field_walk` (excess length in cells per factor e)."""


def _require_guide(grid: Grid, what: str):
    if grid.guide is None:
        raise ParameterError(
            f"{what} steers by the problem's distance fields: attach them with "
            "jaxga.operators.guide.with_guide(grid) (jaxga.run does this itself)")
    return grid.guide


def _excess_tolerance(d: jax.Array) -> jax.Array:
    """Float32 rounding of the fields: a step whose excess length is below this counts as
    an optimal step (the true excess of an optimal step is exactly 0)."""
    return jnp.float32(1e-3) + jnp.float32(2e-7) * d


def field_descent(
    key: jax.Array,
    grid: Grid,
    field: jax.Array,
    source: jax.Array,
    capacity: int,
    budget: jax.Array,
    temperature: jax.Array,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """A random walk down an exact distance field, from ``source`` to the field's zero.

    ``field`` is an exact 8-connected distance field (``float32[H * W]``,
    :class:`jaxga.operators.guide.Guide`) to a target cell: the field is 0 there and nowhere else.
    At every step the walk may take a legal move to a neighbour ``n`` of the current cell
    ``c`` when (i) ``field[n] < field[c]`` and (ii) the *excess* of the move,
    ``step(c, n) + field[n] - field[c] >= 0`` (the length the move adds to the shortest
    remaining path), fits what is left of ``budget``. Among those moves it draws one with
    probability proportional to ``exp(-excess / temperature)`` (``temperature`` 0: only
    optimal moves, uniformly).

    Why it cannot fail: from every cell of finite distance some legal move lowers the
    distance by exactly its own length (the next cell of a shortest path), and that move
    has excess 0, so a candidate always exists; the field strictly decreases along the
    walk, so no cell is visited twice (the path is loop-free by construction) and the
    target is reached. Its length is at most ``field[source] + budget`` (plus float32
    rounding, :func:`_excess_tolerance` per step), so it has at most that many moves.

    Args:
        key: PRNG key (one float32 per step, drawn up front).
        grid: the map and its corner rule (the start and goal are not used).
        field: ``float32[H * W]`` distance field of the target.
        source: int32 cell index.
        capacity: static; output length, and at most ``capacity - 1`` moves.
        budget: float32, the excess length the walk may spend (>= 0).
        temperature: float32 >= 0.

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``: ``ok`` is False when the
        source cannot reach the target (infinite field) or the walk needs more than
        ``capacity - 1`` moves.
    """
    field = jnp.asarray(field, F32)
    if field.shape != (grid.n_cells,):
        raise ParameterError(f"field must have shape ({grid.n_cells},), got {field.shape}")
    return _descent(key, grid, field, jnp.int32(0), source, capacity, budget, temperature)


def _descent(key, grid, table, offset, source, capacity, budget, temperature):
    """:func:`field_descent` down the field ``table[offset : offset + H * W]``: several
    fields in one flat table shared by every lane (under ``vmap`` a field that differed
    between lanes would be copied into every lane of the walk's loop)."""
    capacity = check_capacity(capacity)
    n = grid.n_cells
    source = jnp.clip(jnp.asarray(source, I32), 0, n - 1)
    offset = jnp.asarray(offset, I32)

    def field_at(cell):
        return table[offset + cell]

    nbr_t, legal_t = move_tables(grid)
    cost = jnp.asarray(_STEP_COST)
    steps = capacity - 1
    u = prng.uniform(key, (max(steps, 1),), F32)
    lanes = jnp.arange(8, dtype=I32)
    temp = jnp.maximum(jnp.asarray(temperature, F32), jnp.float32(1e-30))
    budget = jnp.maximum(jnp.asarray(budget, F32), 0.0)
    reachable = jnp.isfinite(field_at(source))

    def cond(carry):
        t, cur, _, _, _ = carry
        return (field_at(cur) > 0) & (t < steps) & reachable

    def step(carry):
        t, cur, used, n_moves, buf = carry
        k = cur * 8 + lanes
        nbr, legal = nbr_t[k], legal_t[k]
        here = field_at(cur)
        there = field_at(nbr)
        excess = cost + there - here
        excess = jnp.where(excess <= _excess_tolerance(here), 0.0, excess)
        cand = legal & (there < here) & (used + excess <= budget)
        weight = jnp.where(cand, jnp.exp(-excess / temp), 0.0)
        cs = jnp.cumsum(weight)
        total = cs[-1]
        idx = jnp.sum(cs <= u[t] * total, dtype=I32)
        last = 7 - jnp.argmax(cand[::-1]).astype(I32)
        idx = jnp.minimum(idx, last)
        # Under vmap the loop runs unmasked (below): a finished walk stays where it is.
        move = (here > 0) & (t < steps) & reachable
        new = jnp.where(move, nbr[idx], cur)
        buf = write_at(buf, n_moves + 1, new)  # past n_moves: scratch
        return (t + 1, new, used + jnp.where(move, excess[idx], 0.0),
                n_moves + move.astype(I32), buf)

    buf0 = jnp.zeros((capacity,), I32).at[0].set(source)
    carry0 = (jnp.int32(0), source, jnp.float32(0.0), jnp.int32(0), buf0)
    # Unmasked: a finished walk's step changes only t and the scratch entry past n_moves.
    _, cur, _, n_moves, buf = lane_while_loop(cond, step, carry0, masked=False)
    cells = jnp.where(jnp.arange(capacity, dtype=I32) <= n_moves, buf, cur)
    ok = reachable & (field_at(cur) == 0)
    return cells, 1 + n_moves, ok


def field_path(
    key: jax.Array,
    grid: Grid,
    via: jax.Array,
    capacity: int,
    budget: jax.Array,
    temperature: jax.Array,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """A path ``start -> via -> goal`` down the exact distance fields (``grid.guide``).

    Two :func:`field_descent` walks from ``via``: one down the start's field (reversed, it
    runs from the start to ``via``) and one down the goal's field; their union has its
    loops removed (:func:`jaxga.core.paths.remove_loops`: the two halves may cross). Whatever
    ``budget`` the detour through ``via`` leaves (``budget`` minus
    ``from_start[via] + to_goal[via] - optimum``) is split evenly between the two walks.

    A ``via`` that the start cannot reach (a cell of another region) is replaced by the
    start itself. So it fails only when the goal is unreachable or the path does not fit
    ``capacity``. With ``via`` on a shortest path and ``budget`` 0 it is an optimal
    8-connected path. Used by :func:`field_walk` and to connect a failed median
    insertion through its own middle cell (:func:`median_insertion`).

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``: continuous, loop-free, from
        ``grid.start`` to ``grid.goal`` when ``ok``.
    """
    capacity = check_capacity(capacity)
    guide = _require_guide(grid, "field_path")
    n = grid.n_cells
    via = jnp.clip(jnp.asarray(via, I32), 0, n - 1)
    via = jnp.where(jnp.isfinite(guide.from_start[via]), via, grid.start)
    optimum = guide.to_goal[grid.start]
    detour = guide.from_start[via] + guide.to_goal[via] - optimum
    half = jnp.maximum(jnp.asarray(budget, F32) - detour, 0.0) / 2
    table = jnp.concatenate([guide.from_start, guide.to_goal])
    keys = prng.split(key, 2)
    cells, length, ok = jax.vmap(
        lambda k, off: _descent(k, grid, table, off, via, capacity, half, temperature)
    )(keys, jnp.asarray([0, n], I32))
    # start .. via (the first walk reversed), then via .. goal without its first cell
    j = jnp.arange(2 * capacity, dtype=I32)
    first = cells[0][jnp.clip(length[0] - 1 - j, 0, capacity - 1)]
    second = cells[1][jnp.clip(j - length[0] + 1, 0, capacity - 1)]
    total = length[0] + length[1] - 1
    joined = jnp.where(j < length[0], first, second)
    joined, total = remove_loops(pad(joined, total), total, n)
    return fit_to_capacity(joined, total, ok[0] & ok[1], capacity)


def field_reconnect(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    i: jax.Array,
    j: jax.Array,
    temperature: float | jax.Array = 0.0,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Reconnect a path through the goal's distance field where a repair failed.

    The repair of an operator (median insertion between positions ``i`` and ``j``, a
    regrowth walk) did not close the gap ``cells[i] -> cells[j]``. Instead of failing:
    walk down the goal's field from ``cells[i]`` (:func:`field_descent`, optimal moves
    only, ties broken at random; ``temperature`` > 0 has no effect with no budget) until
    the walk meets the path again at a position ``>= j`` (at the latest at the goal, the
    path's last cell), and splice ``cells[:i + 1] + walk + cells[k:]`` with its loops
    removed (:func:`jaxga.operators.repair.splice_loop_free`). The walk cannot dead-end, so the
    result is a valid path whenever it fits the capacity: the only failure (decision 019).

    Returns ``(cells int32[L], length, ok)``; ``ok`` False = the result exceeds ``L``
    (the cells are then meaningless). Needs ``grid.guide``.
    """

    guide = _require_guide(grid, "field_reconnect")
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    i, j = jnp.asarray(i, I32), jnp.asarray(j, I32)
    walk, walk_len, reached = _descent(key, grid, guide.to_goal, jnp.int32(0), cells[i], cap,
                                       0.0, temperature)
    pos = position_lookup(cells, length, grid.n_cells)(walk)
    t = jnp.arange(cap, dtype=I32)
    meets = (t >= 1) & (t < walk_len) & (pos >= j)
    k = jnp.argmax(meets).astype(I32)  # the goal (the path's last cell) always meets
    seg = jnp.roll(walk, -1)  # walk[1 : k] as a segment
    new, new_len, fits = splice_loop_free(cells, length, i + 1, seg, k - 1, pos[k],
                                          grid.n_cells)
    del reached  # the walk may meet the path before its end: the splice is what counts
    return new, new_len, fits & jnp.any(meets)


def _via_candidates(grid: Grid, budget: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(count int32[H * W + 1], total)``: running count of the cells whose detour
    ``from_start + to_goal - optimum`` is at most ``budget`` (the ellipse of paths no
    longer than the optimum plus the budget); ``count[i]`` counts cells ``< i``."""
    guide = grid.guide
    optimum = guide.to_goal[grid.start]
    through = guide.from_start + guide.to_goal
    ok = jnp.isfinite(through) & (through - optimum <= budget + _excess_tolerance(optimum))
    count = jnp.concatenate([jnp.zeros((1,), I32), jnp.cumsum(ok, dtype=I32)])
    return count, count[-1]


def field_walk(
    key: jax.Array,
    grid: Grid,
    capacity: int,
    slack: float | jax.Array = FIELD_SLACK,
    temperature: float | jax.Array = FIELD_TEMPERATURE,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """jaxga's initialiser that cannot fail: random detours down the exact distance fields.

    Not from the papers ("a path on every map", decision 018). Draw a cell ``N``
    uniformly among the cells through which a path is at most ``(1 + slack)`` times the
    optimum (``from_start[N] + to_goal[N] <= (1 + slack) * optimum``: an ellipse in the
    map's own distances, so it follows corridors and doors, never walls), then build
    ``start -> N -> goal`` with :func:`field_path`, whose two walks spend what is left of
    the budget ``slack * optimum`` on random detours (``temperature``: the walks prefer
    moves that add little length, ``exp(-excess / temperature)``).

    The via cell spreads the population over the routes around obstacles (the homotopy
    classes a GA needs to choose between), the temperature over the ways to follow a
    route. The result is continuous, loop-free and at most ``(1 + slack)`` times the
    optimum long (plus float32 rounding). It succeeds for every reachable goal whose
    optimal path fits ``capacity``: the only failures are an unreachable goal and a
    capacity below the path's cells. Needs ``grid.guide``
    (:func:`jaxga.operators.guide.with_guide`).

    Args:
        slack: the relative excess length allowed (>= 0; traced values allowed).
        temperature: >= 0 (traced values allowed); 0 takes only optimal moves.
    """
    capacity = check_capacity(capacity)
    guide = _require_guide(grid, "field_walk")
    optimum = guide.to_goal[grid.start]
    budget = jnp.maximum(jnp.asarray(slack, F32), 0.0) * jnp.where(
        jnp.isfinite(optimum), optimum, 0.0)
    count, total = _via_candidates(grid, budget)
    k_via, k_path = prng.split(key)
    r = (prng.bits(k_via, (), jnp.uint32)
         % jnp.maximum(total, 1).astype(jnp.uint32)).astype(I32)
    via = jnp.searchsorted(count, r, side="right").astype(I32) - 1
    cells, length, ok = field_path(k_path, grid, via, capacity, budget, temperature)
    return cells, length, ok & (total > 0)


CLEARANCE_WEIGHTS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
"""Default ``init.clearance_weights`` of :func:`clearance_walk`: from paths that leave the
obstacles a little room to paths that keep as far from them as the band allows."""


def clearance_walk(key: jax.Array, grid: Grid, capacity: int,
                   slack: float | jax.Array = FIELD_SLACK,
                   temperature: float | jax.Array = FIELD_TEMPERATURE,
                   ) -> tuple[jax.Array, jax.Array, jax.Array]:
    """jaxga's initialiser of a front of length against clearance (decision 045): one of
    ``K + 2`` walks drawn uniformly, so a population spreads from the shortest paths to
    the widest:

    * :func:`field_walk` (``slack``, ``temperature``): the shortest routes, over every
      way round the obstacles a via cell opens;
    * a walk from the start down the :func:`jaxga.operators.guide.widest_field` (cells of
      at least the band's clearance: a widest path when the band is the maximin
      clearance) or down one of the ``K`` goal's clearance-weighted fields
      (:func:`jaxga.operators.guide.clearance_weighted_field`), all attached to the grid
      by :func:`jaxga.operators.guide.with_front_fields`. Each step draws uniformly
      among the legal moves that lower the field by at least their own length
      (:func:`field_descent`'s rule with no budget for detours).

    It cannot fail where a path exists: on the widest field every move costs its length;
    on a weighted one its length times at least 1, so the next move of a cheapest path
    lowers the field by at least its length; the field decreases strictly, so the walk
    has no loop and ends at the goal. Only an unreachable goal and a capacity below the
    path's cells fail.
    """
    capacity = check_capacity(capacity)
    guide = _require_guide(grid, "clearance_walk")
    if guide.weighted is None:
        raise ParameterError(
            "clearance_walk walks the clearance-weighted fields: attach them with "
            "jaxga.operators.guide.with_front_fields(grid, weights, band) (jaxga.run does "
            "this for a configuration with survival.method)")
    n = grid.n_cells
    fields = guide.weighted.shape[0] // n
    k_field, k_walk = prng.split(key)
    k = prng.randint(k_field, (), 0, fields + 1, dtype=I32)  # 0: the field walk
    walk = field_walk(k_walk, grid, capacity, slack, temperature)
    down = _descent(k_walk, grid, guide.weighted, jnp.maximum(k - 1, 0) * n, grid.start,
                    capacity, jnp.float32(0.0), jnp.float32(0.0))
    return jax.tree_util.tree_map(lambda a, b: jnp.where(k == 0, a, b), walk, down)
