"""Path objectives, reported metrics and the fitness functions of the five papers.

Every function here is written for ONE path ``(grid, cells, length)``:
``cells`` is ``int32[L]`` (cell indices ``p = y * W + x``), ``length`` an int32 scalar
(the number of valid nodes, ``1 <= length <= L``); the capacity ``L`` is static. All
functions are pure and jittable. A population (``cells int32[P, L]``, ``length
int32[P]``) is evaluated with the project's one lifting helper,
:func:`jaxga.core.paths.population_map`, which ``vmap``s over the paths and shares the grid::

    fit = population_map(functools.partial(objectives.imga, a=6.0))(grid, cells, length)
    fit = population_map(objectives.imga)(grid, cells, length, feasible)  # feasible: bool[P]

Parameters are keyword arguments (bind them with ``functools.partial``, which keeps them
unbatched); every numeric parameter may be a traced value, so an engine can ``vmap`` over
weights. Options that change the compiled code (``border_blocked``, ``method``) are
Python values.

Conventions shared by all functions
-----------------------------------
* **Padding.** Nodes at or beyond ``length`` are replaced by the last valid cell before
  anything is computed (``length`` is clipped to ``[1, L]``), so the result depends only
  on ``cells[:length]`` even if the padding does not repeat the last cell (jaxga's paths
  do). Padding segments then have zero length and never create turns.
* **Repeated nodes.** A node equal to its predecessor is skipped: it adds no length, no
  turn and no safety penalty, and the turn at the next real node is measured between
  the last non-zero segment before it and the segment after it (exactly, for runs of
  any length). Non-consecutive revisits (loops) are *not* merged: they are real nodes.
* **Turn angles** are ``atan2(|cross|, dot)`` of the incoming and outgoing segment
  vectors (0 straight on, pi a reversal), never slopes. Cell coordinates are integers,
  so ``cross`` and ``dot`` are computed exactly in int32 and every *classification*
  (turn or not, below/at/above 45, 90, 135 degrees) is exact: no floating-point
  tolerance is needed and none is used; this is equivalent to a tolerance smaller than
  the smallest non-zero turn possible on the map. Only :func:`angle_sum` and
  :func:`turn_angles` need the angle as a number; they use a branch-free float32
  ``atan2`` for ``y >= 0`` (argument reduction to ``[0, tan(pi/8)]`` and a degree-17 odd
  series, absolute error below 1e-6; faster than ``jnp.arctan2`` on CPU: decision 009)
  that is exact for continuous paths and waypoint paths alike.
* **Dtypes.** Indices and counts are int32, real results float32, also under
  ``JAX_ENABLE_X64=1`` (parameters are cast to float32).
* **Map size.** The exact integer arithmetic requires ``max(H, W) <= 32767``; larger maps
  raise :class:`~jaxga.core.errors.ParameterError` at trace time.
* **Off-map cells** are not obstacles unless ``border_blocked=True`` is passed to a
  safety/clearance function (AGACD and IMGA say nothing about the map border; their maps
  are open at the edges).

Fitness combiners return 0 for infeasible individuals (``feasible=False``); a zero
denominator (only possible for a one-node path, start == goal) is floored at
:data:`EPS` so that no fitness is ever ``inf`` or ``nan``. Each combiner builds the
path geometry once and shares it between its terms.

Cost: the length, the turn-based objectives and the safety terms cost microseconds per
path; ``min_clearance`` and ``tangencies`` search a band of cells around each segment,
``O(L (H + W))``, and the whole map, ``O(L H W)``, only for a path that stays more than
:data:`CLEARANCE_RADIUS` cells from every obstacle: they are meant for reports
(decision 009).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.numerics import ordered_sum
from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, proximity_obstacles

__all__ = [
    "AGACD_WEIGHTS",
    "EPS",
    "MAX_SIDE",
    "Metrics",
    "agacd",
    "agacd_safety",
    "angle_sum",
    "delphi_weights",
    "iga_zhang",
    "iga_zhu",
    "imga",
    "imga_energy",
    "imga_safety",
    "metrics",
    "min_clearance",
    "mpmga",
    "mpmga_penalty",
    "path_length",
    "sga",
    "tangencies",
    "turn_angles",
    "turns",
    "zhu_penalty",
]

"""dtype of every real-valued result."""

EPS = 1e-6
"""Floor of a fitness denominator (a one-node path has length 0)."""

MAX_SIDE = 32767
"""Largest map side for which the int32 cross/dot products below cannot overflow."""

_Scalar = float | jax.Array


# ----------------------------------------------------------------------- helpers
def _f32(v: _Scalar) -> jax.Array:
    return jnp.asarray(v, dtype=F32)


def _check_grid(grid: Grid) -> tuple[int, int]:
    h, w = grid.blocked.shape
    if max(h, w) > MAX_SIDE:
        raise ParameterError(
            f"objectives support maps up to {MAX_SIDE} cells per side, got {w} x {h}"
        )
    return h, w


def _atan2_nonneg(y: jax.Array, x: jax.Array) -> jax.Array:
    """``atan2(y, x)`` for ``y >= 0`` (so the result lies in ``[0, pi]``), float32.

    Branch-free: reduce to ``t = min/max`` in ``[0, 1]``, halve the angle once
    (``atan t = 2 atan(t / (1 + sqrt(1 + t^2)))``, argument at most ``tan(pi/8)``), sum
    the odd Taylor series to degree 17 (truncation error < 1e-8), then undo the octant
    reduction. ``atan2(0, 0)`` is 0.
    """
    y = y.astype(F32)
    x = x.astype(F32)
    ax = jnp.abs(x)
    swap = y > ax
    num = jnp.where(swap, ax, y)
    den = jnp.where(swap, y, ax)
    t = num / jnp.where(den > 0, den, jnp.ones_like(den))
    u = t / (1.0 + jnp.sqrt(1.0 + t * t))
    u2 = u * u
    series = jnp.zeros_like(u2)
    for k in range(17, 1, -2):  # Horner in u^2: 1 - u2/3 + u2^2/5 - ...
        series = u2 * (((-1) ** ((k - 1) // 2)) / k + series)
    a = 2.0 * u * (1.0 + series)
    a = jnp.where(swap, np.float32(math.pi / 2) - a, a)
    return jnp.where(x < 0, np.float32(math.pi) - a, a)


def _fill_forward(key: jax.Array, vx: jax.Array, vy: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Carry ``(vx, vy)`` forward from the last position whose ``key`` is not -1.

    ``key[j]`` is ``j`` at positions that hold a value and -1 at holes. The result is
    ``v[m[j]]`` with ``m`` the running maximum of ``key`` (positions before the first
    value keep their own). Computed by pointer doubling: pass ``p`` lets each position
    take the pair ``(key, v)`` from ``2**p`` positions to its left when that key is
    larger, so after ``p`` passes ``key[j]`` is the maximum over the ``2**p`` positions
    ending at ``j``; the loop stops as soon as ``key`` is non-decreasing, which is
    exactly when it equals its running maximum. Paths without repeated interior nodes
    have no holes and run zero passes; otherwise ``ceil(log2(r + 1))`` passes for the
    longest run of ``r`` holes. (Under ``vmap`` every path of the batch runs the
    batch's largest pass count, so one pass per hole was much slower on batches whose
    paths held long runs of repeated nodes: decision 009.)
    """

    n = key.shape[0]

    def holes(state):
        s, k = state[0], state[1]
        # s >= n: every window covers the whole prefix, k is the running maximum (the
        # bound only guarantees termination; it never stops the loop early)
        return jnp.any(k[1:] < k[:-1]) & (s < n)

    def shifted(v, s, fill):
        # v moved s positions to the right, the first s filled: a dynamic slice (s is the
        # same for every path of a batch, so it stays a slice under vmap, not a gather)
        return jax.lax.dynamic_slice(jnp.concatenate([jnp.full((n,), fill, v.dtype), v]),
                                     (n - s,), (n,))

    def shift(state):
        s, k, ax, ay = state
        k_prev = shifted(k, s, -1)
        take = k_prev > k  # a filled -1 never beats a key (keys are >= -1)
        return (
            2 * s,
            jnp.where(take, k_prev, k),
            jnp.where(take, shifted(ax, s, 0), ax),
            jnp.where(take, shifted(ay, s, 0), ay),
        )

    if n < 2:
        return vx, vy
    _, _, vx, vy = jax.lax.while_loop(holes, shift, (jnp.int32(1), key, vx, vy))
    return vx, vy


class _Geometry(NamedTuple):
    """Per-path quantities shared by the objectives (internal)."""

    cells: jax.Array  # int32[L], padding normalised to the last valid cell
    x: jax.Array  # int32[L]
    y: jax.Array  # int32[L]
    node: jax.Array  # bool[L]: a valid node that differs from its predecessor
    dx: jax.Array  # int32[L-1]: segment j = node j -> node j+1
    dy: jax.Array
    moving: jax.Array  # bool[L-1]: non-zero segment
    cross: jax.Array  # int32[L-1]: incoming x segment j (0 where no incoming)
    dot: jax.Array  # int32[L-1]
    turning: jax.Array  # bool[L-1]: the path turns where segment j starts


def _nodes(
    grid: Grid, cells: jax.Array, length: jax.Array
) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]:
    """``(cells, x, y, node, n)``: padding normalised, coordinates, real-node mask, length."""
    _, w = _check_grid(grid)
    cells = jnp.asarray(cells, dtype=jnp.int32)
    cap = cells.shape[0]
    n = jnp.clip(jnp.asarray(length, dtype=jnp.int32), 1, cap)
    j = jnp.arange(cap, dtype=jnp.int32)
    cells = jnp.where(j < n, cells, cells[n - 1])
    x = cells % jnp.int32(w)
    y = cells // jnp.int32(w)
    first = jnp.concatenate([jnp.ones((1,), bool), cells[1:] != cells[:-1]])
    return cells, x, y, first & (j < n), n


def _geometry(grid: Grid, cells: jax.Array, length: jax.Array) -> _Geometry:
    cells, x, y, node, n = _nodes(grid, cells, length)
    j = jnp.arange(cells.shape[0], dtype=jnp.int32)
    dx = x[1:] - x[:-1]
    dy = y[1:] - y[:-1]
    moving = (dx != 0) | (dy != 0)
    # Direction of the last non-zero segment at or before j. Tail padding (j >= n-1) is
    # marked as "has a value" too: it lies after every real segment, so it never feeds
    # a real turn, and it keeps paths without interior repeats hole-free (zero passes).
    js = j[:-1]
    key = jnp.where(moving | (js >= n - 1), js, jnp.int32(-1))
    px, py = _fill_forward(key, dx, dy)
    zero = jnp.zeros((min(1, cells.shape[0] - 1),), jnp.int32)
    in_x = jnp.concatenate([zero, px[:-1]])
    in_y = jnp.concatenate([zero, py[:-1]])
    cross = in_x * dy - in_y * dx
    dot = in_x * dx + in_y * dy
    has_in = (in_x != 0) | (in_y != 0)
    turning = moving & has_in & ((cross != 0) | (dot < 0))
    return _Geometry(cells, x, y, node, dx, dy, moving, cross, dot, turning)


def _masked_fitness(value: jax.Array, feasible: jax.Array | bool | None) -> jax.Array:
    if feasible is None:
        return value
    return jnp.where(jnp.asarray(feasible, dtype=bool), value, jnp.zeros_like(value))


def _inverse(denominator: jax.Array) -> jax.Array:
    return 1.0 / jnp.maximum(denominator, _f32(EPS))


# -------------------------------------------------------------------- objectives
def path_length(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Path length: the sum of Euclidean segment lengths in cell units, float32.

    IMGA eq. 5, AGACD eq. 9, MPMGA eq. 6, Zhu & Pan eq. 7, Zhang eq. 2 (first term):
    ``L = sum_i sqrt((x_{i+1} - x_i)^2 + (y_{i+1} - y_i)^2)``. Works for continuous
    (8-adjacent) and waypoint paths; a one-node path has length 0.
    """
    return _path_length(_geometry(grid, cells, length))


def _path_length(g: _Geometry) -> jax.Array:
    sq = (g.dx * g.dx + g.dy * g.dy).astype(F32)
    return ordered_sum(jnp.sqrt(sq))


def turn_angles(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Turn angle at every node, ``float32[L]`` in ``[0, pi]`` (radians).

    Entry ``i`` is the angle between the direction into node ``i`` and the direction out
    of it, ``atan2(|cross|, dot)`` (AGACD eq. 10-17 and MPMGA eq. 7-12 define
    the same rotation angle ``theta_i = pi - alpha_i`` through slopes and the law of
    cosines): 0 straight on, pi/4 for a 45-degree turn, pi for a reversal. The start,
    the last node, padding and skipped repeated nodes get 0. In a run of repeated
    nodes the turn is reported at the run's last copy.
    """
    return _turn_angles(_geometry(grid, cells, length))


def _turn_angles(g: _Geometry) -> jax.Array:
    a = _atan2_nonneg(jnp.abs(g.cross), g.dot)
    a = jnp.where(g.turning, a, jnp.zeros_like(a))
    return jnp.concatenate([a, jnp.zeros((1,), F32)])


def turns(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Number of turns: nodes with a non-zero turn angle, int32 (Zhang eq. 2: ``m``).

    The test "non-zero" is exact (integer cross and dot products, see the module
    docstring): a node is a turn unless the path goes straight on through it. Also the
    "number of turns" of IMGA Tables 1 and 3.
    """
    return _turns(_geometry(grid, cells, length))


def _turns(g: _Geometry) -> jax.Array:
    return jnp.sum(g.turning, dtype=jnp.int32)


def angle_sum(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """AGACD smoothness: the sum of the turn angles in radians, float32 (AGACD eq. 10-17).

    ``smoothness = sum_{i=2}^{n-1} theta_i`` with ``theta_i = pi - alpha_i`` the rotation
    angle between segments ``p_{i-1} p_i`` and ``p_i p_{i+1}`` (eq. 13-17 compute it from
    slopes and ``acos``; here ``atan2(|cross|, dot)``, which gives the same angle without
    the slope special cases). 0 for a straight path. One difference: eq. 13 sets
    ``theta = 0`` whenever the two slopes are equal, which includes a 180-degree
    reversal; here a reversal is pi. Reversals cannot occur on loop-free
    8-connected paths, only on waypoint paths.
    """
    return _angle_sum(_geometry(grid, cells, length))


def _angle_sum(g: _Geometry) -> jax.Array:
    return ordered_sum(_turn_angles(g), dtype=F32)


def mpmga_penalty(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """MPMGA smoothness penalty, float32 (MPMGA eq. 13-14).

    Per interior node: 0 if the turn is 0, 5 if ``0 < turn < pi/2``, 25 if ``turn =
    pi/2``, 125 if ``turn > pi/2``; summed over the nodes (eq. 14). The comparisons are
    exact: ``turn = pi/2`` iff ``dot = 0``, ``turn > pi/2`` iff ``dot < 0``.
    """
    return _mpmga_penalty(_geometry(grid, cells, length))


def _mpmga_penalty(g: _Geometry) -> jax.Array:
    pen = jnp.where(
        g.dot > 0, np.float32(5.0), jnp.where(g.dot == 0, np.float32(25.0), np.float32(125.0))
    )
    return ordered_sum(jnp.where(g.turning, pen, jnp.zeros_like(pen)), dtype=F32)


def zhu_penalty(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    c1: _Scalar = 1.0,
    c2: _Scalar = 2.0,
    c3: _Scalar = 3.0,
    c4: _Scalar | None = None,
) -> jax.Array:
    """Zhu & Pan smoothness ``fit_2``: a cost per turn by angle bucket, float32 (eq. 8-9).

    Eq. 9 gives ``Gamma = 0`` when consecutive segments are collinear (the angle at the
    node is pi), ``c1`` for a 45-degree turn (node angle 3pi/4), ``c2`` for 90 degrees,
    ``c3`` for 135 degrees; eq. 8 sums over the interior nodes. Other angles (waypoint
    paths) go to the nearest bucket rounding up: ``(0, 45] -> c1``, ``(45, 90] -> c2``,
    ``(90, 135] -> c3``, decided exactly from integer cross/dot products.

    Decision (the paper is silent): a turn sharper than 135 degrees, up to the
    180-degree reversal, costs ``c4``, which defaults to ``c3`` (the bucket scale
    saturates; on an 8-connected loop-free path such turns cannot occur, they only
    arise on waypoint paths). Pass a larger ``c4`` to punish reversals harder.
    """
    return _zhu_penalty(_geometry(grid, cells, length), c1, c2, c3, c4)


def _zhu_penalty(
    g: _Geometry, c1: _Scalar, c2: _Scalar, c3: _Scalar, c4: _Scalar | None
) -> jax.Array:
    c4 = c3 if c4 is None else c4
    abs_cross = jnp.abs(g.cross)
    cost = jnp.where(
        g.dot >= 0,
        jnp.where(abs_cross <= g.dot, _f32(c1), _f32(c2)),
        jnp.where(abs_cross >= -g.dot, _f32(c3), _f32(c4)),
    )
    return ordered_sum(jnp.where(g.turning, cost, jnp.zeros_like(cost)), dtype=F32)


def imga_energy(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """IMGA path energy ``E(N)``, float32 (IMGA eq. 7 and Fig. 3).

    At every node where the path turns, take the new heading (the outgoing segment) in a
    frame centred on the node whose first quadrant points towards the goal, i.e. each
    heading component is multiplied by the sign of the corresponding component of
    ``goal - node`` (jaxga's reading of Fig. 3). Heading in the first quadrant (both
    components >= 0): +1; third quadrant (both <= 0): +10; second or fourth: +3.

    Decisions:

    * Only turns are charged ("if the robot turns at point i"); going straight costs 0,
      and the start node is not charged (eq. 7 sums from ``i = 2``; the start has no
      incoming heading).
    * When ``goal - node`` has a zero component, that sign is 0, so the heading
      component across that axis is neutral: with the goal straight above, a sideways
      or up-sideways heading costs +1 and any downward heading +10 (symmetric in left and
      right, unlike flipping by a sign of +1).
    * The goal is ``grid.goal`` (not the path's last cell).
    """
    return _imga_energy(grid, _geometry(grid, cells, length))


def _imga_energy(grid: Grid, g: _Geometry) -> jax.Array:
    _, w = _check_grid(grid)
    goal = jnp.asarray(grid.goal, dtype=jnp.int32)
    sx = jnp.sign(goal % jnp.int32(w) - g.x[:-1])
    sy = jnp.sign(goal // jnp.int32(w) - g.y[:-1])
    hx = sx * g.dx
    hy = sy * g.dy
    e = jnp.where(
        (hx >= 0) & (hy >= 0),
        np.float32(1.0),
        jnp.where((hx <= 0) & (hy <= 0), np.float32(10.0), np.float32(3.0)),
    )
    return ordered_sum(jnp.where(g.turning, e, jnp.zeros_like(e)), dtype=F32)


def _near_obstacle(blocked: jax.Array, border_blocked: bool) -> jax.Array:
    """``bool[H, W]``: some 8-neighbour of the cell is blocked (per grid, not per path)."""
    h, w = blocked.shape
    b = jnp.pad(blocked, 1, constant_values=border_blocked)
    near = jnp.zeros((h, w), bool)
    for oy in (-1, 0, 1):
        for ox in (-1, 0, 1):
            if ox or oy:
                near = near | b[1 + oy : 1 + oy + h, 1 + ox : 1 + ox + w]
    return near


def imga_safety(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    penalty: _Scalar = 5.0,
    border_blocked: bool = False,
) -> jax.Array:
    """IMGA path safety ``S(N)``: ``penalty`` (5) per node with a blocked 8-neighbour.

    IMGA eq. 6 and the text after it: a node with no obstacle among its eight neighbours
    is safe, otherwise the penalty grows by 5. Decisions: every node counts, start and
    goal included (jaxga's choice; eq. 6's upper limit ``n - 1`` would drop the goal, which only
    shifts every path's value by the same constant); a node revisited later counts
    again, a repeated consecutive node once; cells off the map are free unless
    ``border_blocked`` (static). The neighbour test is a per-grid table, so the per-path
    cost is one gather per node.
    """
    g = _geometry(grid, cells, length)
    return _imga_safety(grid, g, penalty, border_blocked)


def _imga_safety(grid: Grid, g: _Geometry, penalty: _Scalar, border_blocked: bool) -> jax.Array:
    obstacles = proximity_obstacles(grid, border_blocked)
    near = _near_obstacle(obstacles, border_blocked).reshape(-1)[g.cells]
    return _f32(penalty) * jnp.sum(near & g.node, dtype=F32)


_NEIGHBOURS = np.array(
    [(ox, oy) for oy in (-1, 0, 1) for ox in (-1, 0, 1) if ox or oy], dtype=np.int32
)
"""The 8 neighbour offsets ``(dx, dy)``."""


def _count_table(x: jax.Array, y: jax.Array, node: jax.Array, blocked_ext: jax.Array) -> jax.Array:
    """Obstacles in the union of the nodes' 8-neighbourhoods: bool table + dilation."""
    hp, wp = blocked_ext.shape
    idx = (y + 1) * jnp.int32(wp) + (x + 1)
    idx = jnp.where(node, idx, jnp.int32(hp * wp))  # out of range: dropped
    visited = jnp.zeros(hp * wp, bool).at[idx].set(True, mode="drop").reshape(hp, wp)
    vp = jnp.pad(visited, 1)
    near = jnp.zeros((hp, wp), bool)
    for ox, oy in _NEIGHBOURS:
        near = near | vp[1 + oy : 1 + oy + hp, 1 + ox : 1 + ox + wp]
    return jnp.sum(near & blocked_ext, dtype=jnp.int32)


def _count_sort(x: jax.Array, y: jax.Array, node: jax.Array, blocked_ext: jax.Array) -> jax.Array:
    """Same count by sorting the ``8 L`` candidate neighbour indices."""
    hp, wp = blocked_ext.shape
    qx = x[:, None] + 1 + _NEIGHBOURS[None, :, 0]
    qy = y[:, None] + 1 + _NEIGHBOURS[None, :, 1]
    q = (qy * jnp.int32(wp) + qx).reshape(-1)
    hit = blocked_ext.reshape(-1)[q] & jnp.repeat(node, _NEIGHBOURS.shape[0])
    big = jnp.int32(hp * wp)
    keys = jnp.sort(jnp.where(hit, q, big))
    fresh = jnp.concatenate([keys[:1] != big, (keys[1:] != keys[:-1]) & (keys[1:] != big)])
    return jnp.sum(fresh, dtype=jnp.int32)


def _pack_rows(b: jax.Array) -> jax.Array:
    """``bool[R, C] -> uint32[R, ceil(C / 32)]``, column ``c`` at bit ``c % 32``."""
    r, c = b.shape
    nw = -(-c // 32)
    b = jnp.pad(b, ((0, 0), (0, nw * 32 - c))).reshape(r, nw, 32).astype(jnp.uint32)
    return jnp.sum(b << jnp.arange(32, dtype=jnp.uint32), axis=-1, dtype=jnp.uint32)


def _count_bits(
    x: jax.Array, y: jax.Array, node: jax.Array, blocked_ext: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """Same count on bit-packed rows; returns ``(count, exact)``.

    The nodes are added (scatter-add, there is no scatter-or) as single bits into a
    ``uint32[H+2, ceil((W+2)/32)]`` table, 32x smaller than a bool table, which is what
    makes this fast. Adding the same bit twice (a path that revisits a cell) carries
    into other bits; each add raises the total popcount by exactly one unless it
    carries, so ``exact`` = (total popcount == number of adds) detects every collision.
    """
    hp, wp = blocked_ext.shape
    nw = -(-wp // 32)
    xe = x + 1
    word = jnp.where(node, (y + 1) * jnp.int32(nw) + xe // 32, jnp.int32(hp * nw))
    bit = jnp.left_shift(jnp.uint32(1), (xe % 32).astype(jnp.uint32))
    v = jnp.zeros(hp * nw, jnp.uint32).at[word].add(bit, mode="drop")
    exact = jnp.sum(jax.lax.population_count(v), dtype=jnp.int32) == jnp.sum(node, dtype=jnp.int32)
    v = v.reshape(hp, nw)
    zcol = jnp.zeros((hp, 1), jnp.uint32)
    one, top = jnp.uint32(1), jnp.uint32(31)
    left = (v << one) | jnp.concatenate([zcol, v[:, :-1] >> top], axis=1)  # x+1 neighbours
    right = (v >> one) | jnp.concatenate([v[:, 1:] << top, zcol], axis=1)  # x-1 neighbours
    side = left | right
    row = side | v
    zrow = jnp.zeros((1, nw), jnp.uint32)
    near = side | jnp.concatenate([zrow, row[:-1]]) | jnp.concatenate([row[1:], zrow])
    count = jnp.sum(jax.lax.population_count(near & _pack_rows(blocked_ext)), dtype=jnp.int32)
    return count, exact


def agacd_safety(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    base: _Scalar = 1.0,
    penalty: _Scalar = 0.1,
    border_blocked: bool = False,
    method: str = "auto",
) -> jax.Array:
    """AGACD path safety: ``1 + 0.1 * #obstacle cells next to the path``, float32.

    AGACD eq. 18-20: ``safety = 1 + sum_i S_i``, ``S_i = sum_j punishment(w_j)`` over the
    8 neighbours ``w_j`` of node ``i``; a neighbour contributes 0.1 if it is an obstacle
    that has not already been charged for another node, so every obstacle cell in the
    union of the nodes' 8-neighbourhoods is counted exactly once per path.

    Decisions: cells off the map are not obstacles unless ``border_blocked`` (static);
    the union is of 8-neighbourhoods, so a blocked path node (an infeasible path) counts
    only if it neighbours another node.

    ``method`` (static) picks the exact de-duplication, all giving the same number:

    * ``"bits"``: mark the nodes in a bit-packed ``(H+2) x (W+2)`` table, dilate it by
      the 8-neighbourhood with shifts, popcount against the packed obstacle map; cost
      ``O(L + H W / 32)`` per path. A path that revisits a cell is detected and
      recomputed exactly with ``"table"`` (or ``"sort"`` on large maps) inside a
      ``while_loop`` that runs zero times when no path in the batch revisits a cell.
    * ``"table"``: the same on a bool table, ``O(L + H W)``.
    * ``"sort"``: sort the ``8 L`` candidate neighbour indices and count the distinct
      blocked ones, ``O(L log L)``, independent of the map size.
    * ``"auto"`` (default): ``"bits"`` while the packed table has at most ``64 L`` words
      (e.g. up to about 1000 x 500 cells for ``L = 256``), else ``"sort"``.
    """
    g = _geometry(grid, cells, length)
    return _agacd_safety(grid, g, cells, length, base, penalty, border_blocked, method)


def _agacd_safety(
    grid: Grid,
    g: _Geometry,
    cells: jax.Array,
    length: jax.Array,
    base: _Scalar,
    penalty: _Scalar,
    border_blocked: bool,
    method: str,
) -> jax.Array:
    h, w = _check_grid(grid)
    cap = g.cells.shape[0]
    hp, wp = h + 2, w + 2
    small = hp * -(-wp // 32) <= 64 * cap
    if method == "auto":
        method = "bits" if small else "sort"
    if method not in ("bits", "table", "sort"):
        raise ParameterError(
            f"agacd_safety method must be auto, bits, table or sort, got {method!r}"
        )
    blocked_ext = jnp.pad(proximity_obstacles(grid, border_blocked), 1,
                          constant_values=border_blocked)
    if method == "table":
        count = _count_table(g.x, g.y, g.node, blocked_ext)
    elif method == "sort":
        count = _count_sort(g.x, g.y, g.node, blocked_ext)
    else:
        count, exact = _count_bits(g.x, g.y, g.node, blocked_ext)
        fallback = _count_table if hp * wp <= 16 * 8 * cap else _count_sort

        def recount(state: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
            # The nodes are recomputed from the inputs (already in memory) rather than
            # closed over, so the common no-revisit case does not materialise them; and
            # masking them with the carried flag makes the body depend on the loop state,
            # so that XLA cannot hoist the fallback out of the loop (it would then run on
            # every call).
            _, x, y, node, _ = _nodes(grid, cells, length)
            return fallback(x, y, node & ~state[1], blocked_ext), jnp.bool_(True)

        # Runs its body only if this path (under vmap: any path) revisits a cell.
        count, _ = jax.lax.while_loop(lambda s: ~s[1], recount, (count, exact))
    return _f32(base) + _f32(penalty) * count.astype(F32)


# ----------------------------------------------------------------------- metrics
def _box_clearance(
    ax: jax.Array,
    ay: jax.Array,
    bx: jax.Array,
    by: jax.Array,
    cx: jax.Array,
    cy: jax.Array,
    blk: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """Distance from segment ``a b`` (cell centres) to the nearest of the given cell squares.

    ``cx, cy, blk``: the candidate cells' coordinates and whether each is an obstacle
    (the others count as absent). Returns ``(distance float32, touches bool)`` for one
    segment. A cell ``(cx, cy)`` is the closed square ``[cx - 1/2, cx + 1/2] x [cy - 1/2,
    cy + 1/2]``. Touching (closed intersection) is decided exactly with the
    separating-axis test in integers; the distance of a disjoint square is the minimum
    over the two segment endpoints (to the square) and the four square corners (to the
    segment), which is exact for two disjoint convex polygons. Each cell's distance
    depends on the segment and that cell only, so any set of candidates holding the
    nearest cell gives the same value.
    """
    dx, dy = bx - ax, by - ay
    over_x = (jnp.minimum(ax, bx) <= cx) & (cx <= jnp.maximum(ax, bx))
    over_y = (jnp.minimum(ay, by) <= cy) & (cy <= jnp.maximum(ay, by))
    side = jnp.abs(dx * (cy - ay) - dy * (cx - ax))
    # 2 |n . (c - a)| <= |dx| + |dy| without the doubling (it could overflow int32)
    touch = over_x & over_y & (side <= (jnp.abs(dx) + jnp.abs(dy)) // 2) & blk

    fax, fay, fbx, fby = (v.astype(F32) for v in (ax, ay, bx, by))
    fcx, fcy = cx.astype(F32), cy.astype(F32)

    def point_box(px, py):
        ex = jnp.maximum(jnp.abs(px - fcx) - 0.5, 0.0)
        ey = jnp.maximum(jnp.abs(py - fcy) - 0.5, 0.0)
        return ex * ex + ey * ey

    fdx, fdy = fbx - fax, fby - fay
    len2 = fdx * fdx + fdy * fdy
    inv = jnp.where(len2 > 0, 1.0 / jnp.where(len2 > 0, len2, 1.0), 0.0)
    best = jnp.minimum(point_box(fax, fay), point_box(fbx, fby))
    for sx in (-0.5, 0.5):
        for sy in (-0.5, 0.5):
            qx, qy = fcx + sx - fax, fcy + sy - fay
            t = jnp.clip((qx * fdx + qy * fdy) * inv, 0.0, 1.0)
            ex, ey = qx - t * fdx, qy - t * fdy
            best = jnp.minimum(best, ex * ex + ey * ey)
    dist = jnp.where(touch, 0.0, jnp.sqrt(best))
    dist = jnp.where(blk, dist, jnp.inf)
    return jnp.min(dist, initial=jnp.inf), jnp.any(touch)


def _segment_box_clearance(
    ax: jax.Array,
    ay: jax.Array,
    bx: jax.Array,
    by: jax.Array,
    blocked: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """:func:`_box_clearance` against every cell of the map (``O(H W)``)."""
    h, w = blocked.shape
    cy, cx = jnp.divmod(jnp.arange(h * w, dtype=jnp.int32), jnp.int32(w))
    return _box_clearance(ax, ay, bx, by, cx, cy, blocked.reshape(-1))


CLEARANCE_RADIUS = 4
"""Cells within this distance of a segment are searched around it first (a band), so that a
path's clearance costs ``O(L)`` on a map where it passes near obstacles (see
:func:`_clearance`)."""

CLEARANCE_PIECE = 4
"""Major-axis cells per piece of a segment: each piece's share of the band is one fixed,
small array of cells (:func:`_piece_band_clearance`); a step of a continuous path is one
piece, a segment of ``s`` cells ``ceil(s / CLEARANCE_PIECE)``."""

CLEARANCE_CHUNK = 128
"""Pieces per block of :func:`_clearance`'s loop."""


def _piece_band_clearance(
    ax: jax.Array,
    ay: jax.Array,
    bx: jax.Array,
    by: jax.Array,
    piece: jax.Array,
    blocked: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """:func:`_box_clearance` of segment ``a b`` against the cells of piece ``piece`` of the
    band around it.

    The band, along the segment's major axis ``u`` (x when ``|dx| >= |dy|``, so the slope
    is at most 1): the columns ``u0 - R - 1 .. u1 + R + 1`` (``R`` =
    :data:`CLEARANCE_RADIUS`, ``u0 <= u1`` the segment's ends) and in each the rows within
    ``2 R + 3`` of the line at the column clamped to ``[u0, u1]``. A cell whose square is
    within ``R + 1/4`` of the segment lies in the band: its centre is within ``R + 3/4``
    of the nearest point ``p`` on each axis, and the line at the clamped column is within
    ``R + 3/4`` of ``p`` too. So a band distance of at most ``R`` is the segment's exact
    clearance, and a larger one says that it exceeds ``R``. Piece ``k`` holds the columns
    ``u0 + k P - R - 1 .. u0 + (k + 1) P + R + 1`` (``P`` = :data:`CLEARANCE_PIECE`), so
    the pieces ``0 .. ceil((u1 - u0) / P) - 1`` (at least one) cover the band.
    """
    h, w = blocked.shape
    r, size = CLEARANCE_RADIUS, CLEARANCE_PIECE
    k = 2 * r + 3
    x_major = jnp.abs(bx - ax) >= jnp.abs(by - ay)
    au, av = jnp.where(x_major, ax, ay), jnp.where(x_major, ay, ax)
    bu, bv = jnp.where(x_major, bx, by), jnp.where(x_major, by, bx)
    du = bu - au
    u0, u1 = jnp.minimum(au, bu), jnp.maximum(au, bu)
    cols = u0 + piece * size - (r + 1) + jnp.arange(size + 2 * r + 3, dtype=jnp.int32)
    frac = (jnp.clip(cols, u0, u1) - au).astype(F32) / jnp.where(du == 0, 1, du).astype(F32)
    line = jnp.floor(av.astype(F32) + (bv - av).astype(F32) * frac).astype(jnp.int32)
    cu = jnp.broadcast_to(cols[:, None], (cols.shape[0], 2 * k + 1)).reshape(-1)
    cv = (line[:, None] + jnp.arange(-k, k + 1, dtype=jnp.int32)[None, :]).reshape(-1)
    cx, cy = jnp.where(x_major, cu, cv), jnp.where(x_major, cv, cu)
    inside = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    blk = inside & blocked.reshape(-1)[jnp.where(inside, cy * w + cx, 0)]
    return _box_clearance(ax, ay, bx, by, cx, cy, blk)


def _clearance(grid: Grid, g: _Geometry,
               border_blocked: bool = False) -> tuple[jax.Array, jax.Array]:
    """``(min distance float32, touches bool[S])``: the path's clearance to the cells
    :func:`jaxga.core.grid.proximity_obstacles` counts, and whether each segment (a node
    if L = 1) touches one (False for the zero-length segments after the last moving one:
    padding, never counted as tangencies).

    Exact, with the work bounded by the path rather than the map where the path passes
    within :data:`CLEARANCE_RADIUS` of an obstacle: every segment is measured against a
    band of cells around it, in pieces (:func:`_piece_band_clearance`; one per step of a
    continuous path), all the path's pieces in one loop of blocks that stops at the
    last one. A segment whose band distance is at most the radius has its exact
    clearance; the others are farther, so when any segment is that close the minimum is
    exact, and touching cells always lie in the band. Otherwise (a path that stays away
    from every obstacle) each straight run of the path (consecutive segments in one
    direction, one segment to the map) is measured against the whole map, ``O(R H W)``
    for a path of ``R`` runs.
    """
    h, w = _check_grid(grid)
    obstacles = proximity_obstacles(grid, border_blocked)
    if g.cells.shape[0] == 1:
        a = b = (g.x, g.y)
    else:
        a, b = (g.x[:-1], g.y[:-1]), (g.x[1:], g.y[1:])
    segs = (a[0], a[1], b[0], b[1])
    n_seg = a[0].shape[0]
    span = jnp.maximum(jnp.abs(b[0] - a[0]), jnp.abs(b[1] - a[1]))
    # Segments after the last moving one are points at the last node (the padding), no
    # nearer than that segment: they get no piece.
    j = jnp.arange(n_seg, dtype=jnp.int32)
    used = jnp.maximum(jnp.max(jnp.where(span > 0, j + 1, 0)), 1)
    pieces = jnp.where(j < used, jnp.maximum((span + CLEARANCE_PIECE - 1) // CLEARANCE_PIECE, 1),
                       0)
    first = jnp.cumsum(pieces) - pieces  # each segment's first piece
    total = jnp.sum(pieces)
    chunk = CLEARANCE_CHUNK

    def block(state):
        start, near, touch = state
        t = start + jnp.arange(chunk, dtype=jnp.int32)
        seg = jnp.clip(jnp.searchsorted(first, t, side="right") - 1, 0, n_seg - 1)
        sub = tuple(v[seg] for v in segs)
        d, hit = jax.vmap(lambda *s: _piece_band_clearance(*s, obstacles))(*sub, t - first[seg])
        valid = t < total
        return (start + chunk, jnp.minimum(near, jnp.min(jnp.where(valid, d, jnp.inf))),
                touch.at[jnp.where(valid & hit, seg, n_seg)].set(1, mode="drop"))

    _, near, touch = jax.lax.while_loop(
        lambda s: s[0] < total, block,
        # int32 flags, not bool: no bool table updated in a loop (docs/devices.md)
        (jnp.int32(0), jnp.asarray(jnp.inf, F32), jnp.zeros((n_seg,), jnp.int32)))

    def whole_map(state: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        # masking the segments and the map with the carried flag (False in the body) makes
        # all of the body depend on the loop state, so that XLA cannot hoist any of it out
        # of the loop (it would then run on every call)
        done = state[1]
        blocked = obstacles & ~done
        xs, ys = jnp.where(done, 0, g.x), jnp.where(done, 0, g.y)

        def run(r, near):  # one straight run of the path: a segment between two nodes
            a, b = starts[r], jnp.where(r + 1 < n_runs, starts[r + 1], used)
            d, _ = _segment_box_clearance(xs[a], ys[a], xs[b], ys[b], blocked)
            return jnp.minimum(near, d)

        near = jax.lax.fori_loop(0, n_runs, run, jnp.asarray(jnp.inf, F32))
        return near.astype(F32), jnp.bool_(True)

    # The path's straight runs: consecutive moving segments in one direction lie on one
    # line, so they are one segment to the map (an 8-connected path's hundreds of steps
    # are a few dozen runs); zero-length segments inside a run change nothing.
    if g.cells.shape[0] == 1:
        starts, n_runs = jnp.zeros((1,), jnp.int32), jnp.int32(1)
    else:
        first_move = g.moving & (jnp.cumsum(g.moving.astype(jnp.int32)) == 1)
        begins = g.moving & (g.turning | first_move) & (j < used)
        starts = jnp.nonzero(begins, size=n_seg, fill_value=0)[0].astype(jnp.int32)
        n_runs = jnp.maximum(jnp.sum(begins, dtype=jnp.int32), 1)

    # Runs its body only if this path (under vmap: any path) stays beyond the radius.
    near, _ = jax.lax.while_loop(lambda s: ~s[1], whole_map,
                                 (near.astype(F32), near <= CLEARANCE_RADIUS))
    return near, touch != 0


def _min_clearance(grid: Grid, g: _Geometry, border_blocked: bool) -> jax.Array:
    h, w = grid.blocked.shape
    result, _ = _clearance(grid, g, border_blocked)  # padding segments: harmless points
    if border_blocked:
        xf, yf = g.x.astype(F32), g.y.astype(F32)
        edge = jnp.minimum(jnp.minimum(xf, (w - 1) - xf), jnp.minimum(yf, (h - 1) - yf)) + 0.5
        result = jnp.minimum(result, jnp.min(edge))
    return result


def _tangencies(grid: Grid, g: _Geometry) -> jax.Array:
    _, touch = _clearance(grid, g)
    if g.cells.shape[0] == 1:
        return jnp.int32(0)
    return jnp.sum(touch & g.moving, dtype=jnp.int32)


def min_clearance(
    grid: Grid, cells: jax.Array, length: jax.Array, *, border_blocked: bool = False
) -> jax.Array:
    """Smallest Euclidean distance from the path to a blocked cell, float32 (a metric).

    The path is the polyline through the cell centres; a blocked cell is its closed unit
    square. So a path running along a wall has clearance 0.5, a diagonal step past an
    obstacle's corner (or a squeeze between two diagonal obstacles) has clearance 0, and
    a path through an obstacle has 0. ``inf`` when the map has no blocked cell (and
    ``border_blocked`` is False). With ``border_blocked`` (static) the map's outer
    boundary counts as an obstacle too.

    Cost: a band of cells around each segment (:func:`_clearance`), ``O(L * H * W)``
    (every segment against every cell) only when no segment comes within
    :data:`CLEARANCE_RADIUS` of an obstacle: for reports on a few paths, not for fitness.
    """
    return _min_clearance(grid, _geometry(grid, cells, length), border_blocked)


def tangencies(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Number of path segments that touch a blocked cell (clearance 0), int32 (a metric).

    IMGA Table 3 "number of tangency": a segment passing an obstacle's corner or edge
    (or, for an infeasible path, crossing an obstacle) counts once however many cells it
    touches. Zero-length (padding, repeated-node) segments are not counted. Cost: a band
    of cells around each segment (:func:`_clearance`).
    """
    return _tangencies(grid, _geometry(grid, cells, length))


class Metrics(NamedTuple):
    """Reported metrics of one path; fields are scalars, or ``[P]``
    arrays after :func:`jaxga.core.paths.population_map`."""

    length: jax.Array
    """float32, :func:`path_length`."""
    turns: jax.Array
    """int32, :func:`turns`."""
    angle_sum: jax.Array
    """float32 radians, :func:`angle_sum` (AGACD's smoothness)."""
    min_clearance: jax.Array
    """float32, :func:`min_clearance`."""
    tangencies: jax.Array
    """int32, :func:`tangencies`."""


def metrics(grid: Grid, cells: jax.Array, length: jax.Array) -> Metrics:
    """The metrics reported for a result path: length, turns, angle sum,
    minimum clearance and tangencies; the clearance costs what :func:`min_clearance`
    costs."""
    g = _geometry(grid, cells, length)
    near, touch = _clearance(grid, g)
    tang = jnp.int32(0) if g.cells.shape[0] == 1 else jnp.sum(touch & g.moving, dtype=jnp.int32)
    return Metrics(
        length=_path_length(g),
        turns=_turns(g),
        angle_sum=_angle_sum(g),
        min_clearance=near,
        tangencies=tang,
    )


# ---------------------------------------------------------------- Delphi weights
def delphi_weights(ratios: Sequence[float] | jax.Array) -> jax.Array:
    """Delphi weights from importance ratios, ``float32[n]`` summing to 1 (AGACD eq. 21-25).

    ``ratios = (I_1, ..., I_{n-1})`` with ``I_k = w_k / w_{k+1}`` (eq. 21), indicators in
    decreasing order of importance. Then ``w_n = 1 / (1 + sum_{k=1}^{n-1} prod_{i=k}^{n-1}
    I_i)`` (eq. 22-24) and ``w_k = I_k w_{k+1}``. AGACD's ``(1.2, 1.4)`` gives
    ``(0.4118, 0.3431, 0.2451)`` (eq. 25): ``w_3 = 1 / (1 + 1.4 + 1.2 * 1.4)``. Jittable
    (``ratios`` may be traced); concrete ratios must be positive.
    """
    try:
        concrete = np.asarray(ratios, dtype=np.float64)
    except (TypeError, jax.errors.ConcretizationTypeError):  # traced: no host check
        concrete = None
    if concrete is not None and np.any(concrete <= 0):
        raise ParameterError(f"Delphi importance ratios must be positive, got {ratios!r}")
    r = jnp.asarray(ratios, dtype=F32).reshape(-1)
    # suffix products prod_{i=k}^{n-1} I_i for k = 1..n-1, then 1 for w_n itself
    suffix = jnp.cumprod(r[::-1])[::-1]
    rel = jnp.concatenate([suffix, jnp.ones((1,), F32)])
    return rel / ordered_sum(rel)


AGACD_WEIGHTS: tuple[float, float, float] = (1.2 * 1.4 / 4.08, 1.4 / 4.08, 1.0 / 4.08)
"""AGACD's Delphi weights for ``I = (1.2, 1.4)``: (0.4118, 0.3431, 0.2451) (eq. 25)."""


# ------------------------------------------------------------- fitness combiners
def imga(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    a: _Scalar = 6.0,
    b: _Scalar = 1.0,
    c: _Scalar = 3.0,
    border_blocked: bool = False,
) -> jax.Array:
    """IMGA fitness ``F = 1 / (a L + b S + c E)``, float32 (IMGA eq. 4; a, b, c = 6, 1, 3).

    ``L`` :func:`path_length` (eq. 5), ``S`` :func:`imga_safety` (eq. 6), ``E``
    :func:`imga_energy` (eq. 7); weights from IMGA §5.1. 0 when ``feasible`` is False.
    """
    g = _geometry(grid, cells, length)
    den = (
        _f32(a) * _path_length(g)
        + _f32(b) * _imga_safety(grid, g, 5.0, border_blocked)
        + _f32(c) * _imga_energy(grid, g)
    )
    return _masked_fitness(_inverse(den), feasible)


def agacd(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    weights: Sequence[float] | jax.Array = AGACD_WEIGHTS,
    smoothness_floor: _Scalar = 0.1,
    border_blocked: bool = False,
    safety_method: str = "auto",
) -> jax.Array:
    """AGACD fitness ``w1 / length + w2 / smoothness + w3 / safety``, float32.

    AGACD eq. 7-8 with length eq. 9 (:func:`path_length`), smoothness eq. 10-17
    (:func:`angle_sum`, radians) and safety eq. 18-20 (:func:`agacd_safety`, >= 1);
    ``weights`` default to the Delphi weights of eq. 25 (:data:`AGACD_WEIGHTS`, see
    :func:`delphi_weights`). jaxga's choice (the paper does not say): the smoothness is floored at
    ``smoothness_floor`` (default 0.1 rad) so that a straight path (smoothness 0) gets
    the finite ``w2 / 0.1``; any smoothness below the floor is raised to it. 0 when
    ``feasible`` is False.
    """
    w = jnp.asarray(weights, dtype=F32)
    g = _geometry(grid, cells, length)
    smooth = jnp.maximum(_angle_sum(g), _f32(smoothness_floor))
    safety = _agacd_safety(grid, g, cells, length, 1.0, 0.1, border_blocked, safety_method)
    value = w[0] * _inverse(_path_length(g)) + w[1] / smooth + w[2] * _inverse(safety)
    return _masked_fitness(value, feasible)


def mpmga(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    alpha: _Scalar = 0.8,
    beta: _Scalar = 0.2,
    c: _Scalar = 1.0,
    smoothness_floor: _Scalar = 0.1,
) -> jax.Array:
    """MPMGA fitness ``alpha / length + beta * c / smoothness``, float32 (MPMGA eq. 3-5).

    Length eq. 6 (:func:`path_length`), smoothness eq. 13-14 (:func:`mpmga_penalty`);
    defaults alpha 0.8, beta 0.2, c 1 (MPMGA Table 2). The smoothness is floored at
    ``smoothness_floor`` (default 0.1), as for :func:`agacd`: the penalty is 0 exactly
    for a straight path, and at least 5 otherwise. 0 when ``feasible`` is False.
    """
    g = _geometry(grid, cells, length)
    smooth = jnp.maximum(_mpmga_penalty(g), _f32(smoothness_floor))
    value = _f32(alpha) * _inverse(_path_length(g)) + _f32(beta) * _f32(c) / smooth
    return _masked_fitness(value, feasible)


def iga_zhu(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    omega: _Scalar = 0.7,
    c1: _Scalar = 1.0,
    c2: _Scalar = 2.0,
    c3: _Scalar = 3.0,
    c4: _Scalar | None = None,
) -> jax.Array:
    """Zhu & Pan fitness ``1 / (omega * fit_1 + (1 - omega) * fit_2)``, float32 (eq. 6).

    ``fit_1`` the length (eq. 7), ``fit_2`` :func:`zhu_penalty` (eq. 8-9, costs
    ``c1 < c2 < c3`` for 45/90/135-degree turns, ``c4`` beyond 135, default ``c3``).
    ``omega`` 0.7. 0 when ``feasible`` is False.
    """
    omega = _f32(omega)
    g = _geometry(grid, cells, length)
    den = omega * _path_length(g) + (1.0 - omega) * _zhu_penalty(g, c1, c2, c3, c4)
    return _masked_fitness(_inverse(den), feasible)


def iga_zhang(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    a: _Scalar = 2.0,
    v: _Scalar = 1.0,
    v_t: _Scalar = 0.5,
    r: _Scalar = 0.5,
) -> jax.Array:
    """Zhang fitness ``1 / F`` with ``F = length + a m k``, float32 (Zhang eq. 2).

    ``m`` the number of turns (:func:`turns`), ``k = (v - v_t) pi r / (2 v v_t)`` the
    time lost per turn (speed ``v``, turning speed ``v_t``, turning radius ``r``), ``a``
    the penalty coefficient ("generally greater than 1"). Defaults a 2, v 1, v_t 0.5,
    r 0.5 (k = pi/4). 0 when ``feasible`` is False.
    """
    v, v_t = _f32(v), _f32(v_t)
    k = (v - v_t) * np.float32(math.pi) * _f32(r) / (2.0 * v * v_t)
    g = _geometry(grid, cells, length)
    den = _path_length(g) + _f32(a) * _turns(g).astype(F32) * k
    return _masked_fitness(_inverse(den), feasible)


def sga(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
) -> jax.Array:
    """Plain GA fitness ``1 / length``, float32 (the baseline of every paper).

    0 when ``feasible`` is False.
    """
    return _masked_fitness(_inverse(_path_length(_geometry(grid, cells, length))), feasible)
