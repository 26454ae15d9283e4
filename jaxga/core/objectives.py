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
* **Sums.** Floating-point sums are added in one fixed order (:func:`ordered_sum`,
  re-exported here for objectives of your own): ``jnp.sum`` rounds by the shape of the
  whole batch it runs in, so a path's value would depend on the runs beside it.
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
:data:`jaxga.core.clearance.CLEARANCE_RADIUS` cells from every obstacle: they are meant for reports
(decision 009).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.numerics import ordered_sum  # re-exported: for objectives of your own
from jaxga.core.clearance import (
    clearance_band,
    min_clearance,
    tangencies,
)
from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, proximity_obstacles
from jaxga.core.path_geometry import (
    MAX_SIDE,
    Geometry,
    Scalar,
    as_f32,
    atan2_nonneg,
    check_grid,
    geometry,
    path_nodes,
)

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
    "ordered_sum",
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



# ----------------------------------------------------------------------- helpers
def _masked_fitness(value: jax.Array, feasible: jax.Array | bool | None) -> jax.Array:
    if feasible is None:
        return value
    return jnp.where(jnp.asarray(feasible, dtype=bool), value, jnp.zeros_like(value))


def _inverse(denominator: jax.Array) -> jax.Array:
    return 1.0 / jnp.maximum(denominator, as_f32(EPS))


# -------------------------------------------------------------------- objectives
def path_length(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Path length: the sum of Euclidean segment lengths in cell units, float32.

    IMGA eq. 5, AGACD eq. 9, MPMGA eq. 6, Zhu & Pan eq. 7, Zhang eq. 2 (first term):
    ``L = sum_i sqrt((x_{i+1} - x_i)^2 + (y_{i+1} - y_i)^2)``. Works for continuous
    (8-adjacent) and waypoint paths; a one-node path has length 0.
    """
    return _path_length(geometry(grid, cells, length))


def _path_length(g: Geometry) -> jax.Array:
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
    return _turn_angles(geometry(grid, cells, length))


def _turn_angles(g: Geometry) -> jax.Array:
    a = atan2_nonneg(jnp.abs(g.cross), g.dot)
    a = jnp.where(g.turning, a, jnp.zeros_like(a))
    return jnp.concatenate([a, jnp.zeros((1,), F32)])


def turns(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Number of turns: nodes with a non-zero turn angle, int32 (Zhang eq. 2: ``m``).

    The test "non-zero" is exact (integer cross and dot products, see the module
    docstring): a node is a turn unless the path goes straight on through it. Also the
    "number of turns" of IMGA Tables 1 and 3.
    """
    return _turns(geometry(grid, cells, length))


def _turns(g: Geometry) -> jax.Array:
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
    return _angle_sum(geometry(grid, cells, length))


def _angle_sum(g: Geometry) -> jax.Array:
    return ordered_sum(_turn_angles(g), dtype=F32)


def mpmga_penalty(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """MPMGA smoothness penalty, float32 (MPMGA eq. 13-14).

    Per interior node: 0 if the turn is 0, 5 if ``0 < turn < pi/2``, 25 if ``turn =
    pi/2``, 125 if ``turn > pi/2``; summed over the nodes (eq. 14). The comparisons are
    exact: ``turn = pi/2`` iff ``dot = 0``, ``turn > pi/2`` iff ``dot < 0``. One
    difference: eq. 9 sets ``theta = 0`` whenever the two slopes are equal, which
    includes a 180-degree reversal (penalty 0); here a reversal is a turn of pi (125).
    MPMGA's individuals are continuous loop-free paths, which cannot reverse.
    """
    return _mpmga_penalty(geometry(grid, cells, length))


def _mpmga_penalty(g: Geometry) -> jax.Array:
    pen = jnp.where(
        g.dot > 0, np.float32(5.0), jnp.where(g.dot == 0, np.float32(25.0), np.float32(125.0))
    )
    return ordered_sum(jnp.where(g.turning, pen, jnp.zeros_like(pen)), dtype=F32)


def zhu_penalty(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    *,
    c1: Scalar = 1.0,
    c2: Scalar = 2.0,
    c3: Scalar = 3.0,
    c4: Scalar | None = None,
) -> jax.Array:
    """Zhu & Pan smoothness ``fit_2``: a cost per turn by angle bucket, float32 (eq. 8-9).

    Eq. 9 as printed takes the angle between consecutive headings ``P_i P_{i+1}`` and
    ``P_{i+1} P_{i+2}`` (0 when pi, c1 at 3pi/4, c2 at pi/2, c3 at pi/4): read literally,
    a reversal costs 0 and a 45-degree turn c3. With ``0 < c1 < c2 < c3`` the angles can
    only be the interior angle at the node, and jaxga reads them so (decision 057):
    ``Gamma = 0`` when consecutive segments are collinear (the angle at the node is pi),
    ``c1`` for a 45-degree turn (node angle 3pi/4), ``c2`` for 90 degrees, ``c3`` for 135
    degrees; eq. 8 sums over the interior nodes. Other angles (waypoint
    paths) go to the nearest bucket rounding up: ``(0, 45] -> c1``, ``(45, 90] -> c2``,
    ``(90, 135] -> c3``, decided exactly from integer cross/dot products.

    Decision (the paper is silent): a turn sharper than 135 degrees, up to the
    180-degree reversal, costs ``c4``, which defaults to ``c3`` (the bucket scale
    saturates; on an 8-connected loop-free path such turns cannot occur, they only
    arise on waypoint paths). Pass a larger ``c4`` to punish reversals harder.
    """
    return _zhu_penalty(geometry(grid, cells, length), c1, c2, c3, c4)


def _zhu_penalty(
    g: Geometry, c1: Scalar, c2: Scalar, c3: Scalar, c4: Scalar | None
) -> jax.Array:
    c4 = c3 if c4 is None else c4
    abs_cross = jnp.abs(g.cross)
    cost = jnp.where(
        g.dot >= 0,
        jnp.where(abs_cross <= g.dot, as_f32(c1), as_f32(c2)),
        jnp.where(abs_cross >= -g.dot, as_f32(c3), as_f32(c4)),
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
    * A heading along an axis of that frame lies on the edge of two quadrants, which
      the paper does not assign. It counts in the first quadrant (+1) when its non-zero
      component points towards the goal and in the third (+10) when it points away;
      never in the second or fourth (+3): with the goal up and to the right, a step
      right or up costs +1, a step left or down +10.
    * The goal is ``grid.goal`` (not the path's last cell).
    """
    return _imga_energy(grid, geometry(grid, cells, length))


def _imga_energy(grid: Grid, g: Geometry) -> jax.Array:
    _, w = check_grid(grid)
    goal = jnp.asarray(grid.goal, dtype=jnp.int32)
    (xa, ya), _ = g.ends  # not g.x[:-1] beside g.dx: decision 048
    sx = jnp.sign(goal % jnp.int32(w) - xa)
    sy = jnp.sign(goal // jnp.int32(w) - ya)
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
    penalty: Scalar = 5.0,
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
    g = geometry(grid, cells, length)
    return _imga_safety(grid, g, penalty, border_blocked)


def _imga_safety(grid: Grid, g: Geometry, penalty: Scalar, border_blocked: bool) -> jax.Array:
    obstacles = proximity_obstacles(grid, border_blocked)
    near = _near_obstacle(obstacles, border_blocked).reshape(-1)[g.cells]
    # counted in int32 (exact, as the float sum of 0s and 1s was), added as one float
    return as_f32(penalty) * jnp.sum(near & g.node, dtype=jnp.int32).astype(F32)


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
    base: Scalar = 1.0,
    penalty: Scalar = 0.1,
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
    g = geometry(grid, cells, length)
    return _agacd_safety(grid, g, cells, length, base, penalty, border_blocked, method)


def _agacd_safety(
    grid: Grid,
    g: Geometry,
    cells: jax.Array,
    length: jax.Array,
    base: Scalar,
    penalty: Scalar,
    border_blocked: bool,
    method: str,
) -> jax.Array:
    h, w = check_grid(grid)
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
            _, x, y, node, _ = path_nodes(grid, cells, length)
            return fallback(x, y, node & ~state[1], blocked_ext), jnp.bool_(True)

        # Runs its body only if this path (under vmap: any path) revisits a cell.
        count, _ = jax.lax.while_loop(lambda s: ~s[1], recount, (count, exact))
    return as_f32(base) + as_f32(penalty) * count.astype(F32)


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
    g = geometry(grid, cells, length)
    near, touch = clearance_band(grid, g)
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
    a: Scalar = 6.0,
    b: Scalar = 1.0,
    c: Scalar = 3.0,
    border_blocked: bool = False,
) -> jax.Array:
    """IMGA fitness ``F = 1 / (a L + b S + c E)``, float32 (IMGA eq. 4; a, b, c = 6, 1, 3).

    ``L`` :func:`path_length` (eq. 5), ``S`` :func:`imga_safety` (eq. 6), ``E``
    :func:`imga_energy` (eq. 7); weights from IMGA §5.1. 0 when ``feasible`` is False.
    """
    g = geometry(grid, cells, length)
    den = (
        as_f32(a) * _path_length(g)
        + as_f32(b) * _imga_safety(grid, g, 5.0, border_blocked)
        + as_f32(c) * _imga_energy(grid, g)
    )
    return _masked_fitness(_inverse(den), feasible)


def agacd(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    weights: Sequence[float] | jax.Array = AGACD_WEIGHTS,
    smoothness_floor: Scalar = 0.1,
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
    g = geometry(grid, cells, length)
    smooth = jnp.maximum(_angle_sum(g), as_f32(smoothness_floor))
    safety = _agacd_safety(grid, g, cells, length, 1.0, 0.1, border_blocked, safety_method)
    value = w[0] * _inverse(_path_length(g)) + w[1] / smooth + w[2] * _inverse(safety)
    return _masked_fitness(value, feasible)


def mpmga(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    alpha: Scalar = 0.8,
    beta: Scalar = 0.2,
    c: Scalar = 1.0,
    smoothness_floor: Scalar = 0.1,
) -> jax.Array:
    """MPMGA fitness ``alpha / length + beta * c / smoothness``, float32 (MPMGA eq. 3-5).

    Length eq. 6 (:func:`path_length`), smoothness eq. 13-14 (:func:`mpmga_penalty`);
    defaults alpha 0.8, beta 0.2, c 1 (MPMGA Table 2). The smoothness is floored at
    ``smoothness_floor`` (default 0.1), as for :func:`agacd`: the penalty is 0 exactly
    for a straight path, and at least 5 otherwise. 0 when ``feasible`` is False.
    """
    g = geometry(grid, cells, length)
    smooth = jnp.maximum(_mpmga_penalty(g), as_f32(smoothness_floor))
    value = as_f32(alpha) * _inverse(_path_length(g)) + as_f32(beta) * as_f32(c) / smooth
    return _masked_fitness(value, feasible)


def iga_zhu(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    omega: Scalar = 0.7,
    c1: Scalar = 1.0,
    c2: Scalar = 2.0,
    c3: Scalar = 3.0,
    c4: Scalar | None = None,
) -> jax.Array:
    """Zhu & Pan fitness ``1 / (omega * fit_1 + (1 - omega) * fit_2)``, float32 (eq. 6).

    ``fit_1`` the length (eq. 7), ``fit_2`` :func:`zhu_penalty` (eq. 8-9, costs
    ``c1 < c2 < c3`` for 45/90/135-degree turns, ``c4`` beyond 135, default ``c3``).
    ``omega`` 0.7. 0 when ``feasible`` is False.
    """
    omega = as_f32(omega)
    g = geometry(grid, cells, length)
    den = omega * _path_length(g) + (1.0 - omega) * _zhu_penalty(g, c1, c2, c3, c4)
    return _masked_fitness(_inverse(den), feasible)


def iga_zhang(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    feasible: jax.Array | bool | None = None,
    *,
    a: Scalar = 2.0,
    v: Scalar = 1.0,
    v_t: Scalar = 0.5,
    r: Scalar = 0.5,
) -> jax.Array:
    """Zhang fitness ``1 / F`` with ``F = length + a m k``, float32 (Zhang eq. 2).

    ``m`` the number of turns (:func:`turns`), ``k = (v - v_t) pi r / (2 v v_t)`` the
    time lost per turn (speed ``v``, turning speed ``v_t``, turning radius ``r``), ``a``
    the penalty coefficient ("generally greater than 1"). Defaults a 2, v 1, v_t 0.5,
    r 0.5 (k = pi/4). 0 when ``feasible`` is False.

    The form of ``k`` is reconstructed (decision 057): the paper's extracted text of eq. 2
    ("F = n - li = 1d(pi, pi + 1) + am(v - vt)pi 2rvt") may also be read
    ``(v - v_t) pi / (2 r v_t)`` (k = pi at the defaults). ``a``, ``v``, ``v_t`` and ``r``
    are not in the paper, so only the weight of a turn is at stake.
    """
    v, v_t = as_f32(v), as_f32(v_t)
    k = (v - v_t) * np.float32(math.pi) * as_f32(r) / (2.0 * v * v_t)
    g = geometry(grid, cells, length)
    den = _path_length(g) + as_f32(a) * _turns(g).astype(F32) * k
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
    return _masked_fitness(_inverse(_path_length(geometry(grid, cells, length))), feasible)
