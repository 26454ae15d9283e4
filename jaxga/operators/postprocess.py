"""Post-optimisation and simplification of paths.

* :func:`shortcut_greedy` - the "deletion point method" / "optimization operator" /
  "delete operation" of MPMGA section 4.7, AGACD section 4.8 and IMGA section 4.5: turn a
  continuous path into a shorter feasible *waypoint* path. Applied to the final best.
* :func:`shortcut_optimal` - jaxga's (beyond the papers): the shortest clear
  sub-sequence of a continuous path's cells (a dynamic programme over the path), never
  longer than :func:`shortcut_greedy`'s result, with minimal waypoints
  (:func:`prune_waypoints`). Applied to the final best.
* :func:`simplify_adjacent` - Zhu & Pan's simplification operator (section 4.6): drop the
  detour between a node and the farthest later node one step away. Applied to every
  individual with probability ``ps`` every generation; the path stays continuous.
* :func:`remove_loops` - MPMGA's deletion operator, re-exported from :mod:`jaxga.core.paths`.

Every function is written for ONE path ``(cells int32[L], length int32)`` (docs, "the
pure core"), is pure and jittable and ``vmap``s over a population; the shortcut passes loop over the
path's ``length`` positions, not its capacity ``L`` (under ``vmap``, the longest path's).
Deterministic functions take no key and return ``(cells, length)``;
:func:`simplify_adjacent` is a per-individual operator
``(key, grid, cells, length) -> (cells, length, failed)`` for
:func:`jaxga.operators.lift.over_individuals_gated`.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from jaxga._batching.numerics import ordered_sum
from jaxga.core import prng
from jaxga.core.errors import ParameterError
from jaxga.core.geometry import clear, floor_div, linear_trial
from jaxga.core.grid import Grid, diagonal_legal, move_legal
from jaxga.core.paths import pad, remove_loops
from jaxga.operators.registry import CONTINUOUS_ONLY, Operator, register, register_none

__all__ = [
    "LINE_OF_SIGHT",
    "compact",
    "line_of_sight",
    "prune_waypoints",
    "remove_loops",
    "shortcut_greedy",
    "shortcut_optimal",
    "simplify_adjacent",
]

SHORTCUT_WINDOW = 64
"""Path positions a segment of :func:`shortcut_optimal` may span."""

LINE_OF_SIGHT = ("clear", "linear_trial")
"""Line-of-sight tests a waypoint operator can use: :func:`jaxga.core.geometry.clear` (exact,
honours the corner rule) or AGACD's :func:`jaxga.core.geometry.linear_trial` (eq. 3-6)."""


def line_of_sight(los: str):
    """The segment test named ``los`` (static): ``"clear"`` or ``"linear_trial"``."""
    if los == "clear":
        return clear
    if los == "linear_trial":
        return linear_trial
    raise ParameterError(f"unknown line-of-sight test {los!r}: expected one of {LINE_OF_SIGHT}")


def compact(cells: jax.Array, keep: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Keep the nodes where ``keep`` is True, in order, and re-pad with the last kept cell.

    One cumulative sum and one scatter of ``L`` lanes (no per-step work). ``keep`` must
    be False on the padding. Returns ``(cells, length)``.
    """
    cells = jnp.asarray(cells, jnp.int32)
    n = cells.shape[0]
    pos = jnp.cumsum(keep, dtype=jnp.int32) - 1
    length = jnp.sum(keep, dtype=jnp.int32)
    out = jnp.zeros((n,), jnp.int32).at[jnp.where(keep, pos, n)].set(cells, mode="drop")
    return pad(out, length), length


# ------------------------------------------------------------------ line of sight
def _vertex_codes(blocked: jax.Array) -> jax.Array:
    """``int32[(H + 1) (W + 1)]``: for every grid vertex ``(X, Y)``, four bits saying which
    of the cells around it are blocked: bit 0 ``(X-1, Y-1)``, bit 1 ``(X, Y-1)``, bit 2
    ``(X-1, Y)``, bit 3 ``(X, Y)`` (cells off the map count as blocked). Index ``(y + 1)
    (W + 1) + x + 1`` is the 2 x 2 block whose lower-left cell is ``(x, y)``."""
    b = jnp.pad(jnp.asarray(blocked, bool), 1, constant_values=True).astype(jnp.int32)
    code = b[:-1, :-1] | (b[:-1, 1:] << 1) | (b[1:, :-1] << 2) | (b[1:, 1:] << 3)
    return code.reshape(-1)


def _clear_short(grid: Grid, codes: jax.Array, a: jax.Array, b: jax.Array,
                 span: int) -> jax.Array:
    """:func:`jaxga.core.geometry.clear` (exact line of sight) of one segment ``a -> b``
    spanning at most ``span`` (static) cells a side, from the blocks of :func:`_vertex_codes`.

    The closed form of :func:`jaxga.reference.optima.clear_pairs_np`: with extents
    ``A >= B`` along the major and minor axes, the segment meets the grid line between
    major offsets ``i`` and ``i + 1`` (``i < A``) at minor offset ``B (2i + 1) / (2A)``;
    with ``r, m = divmod(B (2i + 1) + A, 2A)`` it passes a grid vertex iff ``m == 0``.
    The cells it crosses there are ``(i, r - [m == 0])`` and ``(i + 1, r)`` (the two end
    cells among them), and at a vertex the side cells ``(i + 1, r - 1)`` and ``(i, r)``
    must satisfy the corner rule: all four lie in the 2 x 2 block at ``(i, r - 1)``, one
    lookup per crossing. ``A`` lanes instead of :func:`~jaxga.core.geometry.clear`'s
    ``2 * max_span``, each with one gather instead of three. A segment longer than
    ``span`` is reported as not clear, as ``clear(..., max_span=span)`` does.
    """
    h, w = grid.shape
    on_map = (a >= 0) & (a < h * w) & (b >= 0) & (b < h * w)
    a, b = jnp.where(on_map, a, 0), jnp.where(on_map, b, 0)
    ax, ay, bx, by = a % w, a // w, b % w, b // w
    dx, dy = bx - ax, by - ay
    x_major = jnp.abs(dx) >= jnp.abs(dy)
    big = jnp.maximum(jnp.abs(dx), jnp.abs(dy))
    small = jnp.minimum(jnp.abs(dx), jnp.abs(dy))
    sx, sy = jnp.where(dx < 0, -1, 1), jnp.where(dy < 0, -1, 1)
    i = jnp.arange(span, dtype=jnp.int32)
    den = jnp.maximum(2 * big, 1)
    num = small * (2 * i + 1) + big
    r = floor_div(num, den)
    vertex = num == r * den
    # lower-left cell of the block at major offset i, minor offset r - 1
    px = ax + sx * jnp.where(x_major, i, r - 1)
    py = ay + sy * jnp.where(x_major, r - 1, i)
    x0, y0 = px + jnp.minimum(sx, 0), py + jnp.minimum(sy, 0)
    inside = (x0 >= -1) & (x0 < w) & (y0 >= -1) & (y0 < h)
    code = codes[jnp.where(inside, (y0 + 1) * (w + 1) + x0 + 1, 0)]

    def cell(du: int, dv: int) -> jax.Array:
        """Whether the block's cell at major offset ``du``, minor ``dv`` is blocked."""
        xb = jnp.where(x_major, du, dv) * sx - jnp.minimum(sx, 0)
        yb = jnp.where(x_major, dv, du) * sy - jnp.minimum(sy, 0)
        return ((code >> (xb + 2 * yb)) & 1) == 1

    after = cell(1, 1)
    ok = jnp.where(vertex,
                   ~cell(0, 0) & ~after & diagonal_legal(cell(1, 0), cell(0, 1),
                                                         grid.corner_rule),
                   ~cell(0, 1) & ~after)
    crossings_ok = jnp.all(ok | (i >= big))
    a_free = ~grid.blocked.reshape(-1)[a]  # the only cell when a == b
    return on_map & (big <= span) & crossings_ok & a_free


def _exact_sight(grid: Grid,
                 codes: jax.Array | None = None) -> Callable[[jax.Array, jax.Array], jax.Array]:
    """``sees(a, b)``: :func:`jaxga.core.geometry.clear` of any two cells of ``grid``
    (:func:`_clear_short` with a span of the map's side); ``codes``: the blocks of
    :func:`_vertex_codes`, computed here when not given."""
    codes = _vertex_codes(grid.blocked) if codes is None else codes
    span = max(max(grid.shape) - 1, 1)
    return lambda a, b: _clear_short(grid, codes, a, b, span)


def _greedy_pass(sees: Callable[[jax.Array, jax.Array], jax.Array], cells: jax.Array,
                 length: jax.Array) -> tuple[jax.Array, jax.Array]:
    """:func:`shortcut_greedy`'s pass with the line-of-sight test ``sees(a, b)``."""
    cells = jnp.asarray(cells, jnp.int32)
    length = jnp.asarray(length, jnp.int32)
    n_cap = cells.shape[0]
    if n_cap < 3:
        return cells, length

    def step(k, carry):
        # j + 1 = k, j = k - 1: does the anchor see cells[k]? If so node k - 1 goes.
        anchor, dropped = carry
        visible = sees(anchor, cells[k])
        dropped = dropped.at[k - 1].set(visible.astype(jnp.int32))
        return jnp.where(visible, anchor, cells[k - 1]), dropped

    # int32 flags, not bool: no bool table updated in a loop (docs/devices.md, "Exactness")
    _, dropped = jax.lax.fori_loop(2, jnp.clip(length, 2, n_cap), step,
                                   (cells[0], jnp.zeros((n_cap,), jnp.int32)))
    return compact(cells, (jnp.arange(n_cap, dtype=jnp.int32) < length) & (dropped == 0))


# ------------------------------------------------------------------ shortcut_greedy
def shortcut_greedy(
    grid: Grid, cells: jax.Array, length: jax.Array, *, los: str = "clear"
) -> tuple[jax.Array, jax.Array]:
    """Greedy line-of-sight shortcutting of a feasible path (the papers' optimisation).

    MPMGA section 4.7 (steps 1-4): start with ``i = 1, j = i + 1`` and the list
    ``[path(i)]``; while ``j < n``: if the segment ``path(i) -> path(j+1)`` is clear,
    ``j = j + 1``, else ``i = j`` and append ``path(i)``; finally append ``path(n)``.
    So from an anchor node, extend the reach while the anchor sees the next node; when it
    does not, the last visible node becomes the new anchor.

    The three papers describe the same greedy pass:

    * MPMGA section 4.7 gives the steps above ("deletion point method"; the result is a
      "barrier-free discontinuous path"); its collision test is "passes through the
      obstacle grid", not specified further.
    * AGACD section 4.8 (the optimization operator) walks the example A, B, C, D, E: AC
      clear -> drop B; AD blocked -> keep C; CE clear -> drop D; identical to the steps
      above, with AGACD's linear-trial collision check of section 3 (``los=
      "linear_trial"``).
    * IMGA section 4.5 (the delete operation) states the idea only ("if a node can be
      barrier-free connected to its front and rear nodes (nonadjacent path points), the
      intermediate nodes are redundant") with the example S-21-34-66-76-G ->
      S-66-76-G, and applies it to the best path of each run only, because the result is
      no longer continuous. Its worked example is consistent with the greedy pass.

    Implementation: one loop over the path's positions ``2 .. length - 1`` (its trip
    count is the path's length, not the capacity; under ``vmap`` the longest path's);
    step ``k`` asks whether the current anchor sees ``cells[k]`` (one line-of-sight
    test per step), then one compaction.

    Args:
        grid: the map (``clear`` honours its corner rule; ``linear_trial`` has none).
        cells, length: one padded path. It should be feasible under ``los``.
        los: ``"clear"`` (exact line of sight, default) or ``"linear_trial"`` (AGACD).

    Returns:
        ``(cells, length)``: a sub-sequence of the input with the same endpoints. If the
        input is feasible under ``los``, so is the output, and its Euclidean length is
        no longer (triangle inequality: every dropped stretch is replaced by the
        straight segment between its ends). Decision: a segment of the input that is
        itself not clear is kept as it is (the paper's loop would not terminate on
        such a path).
    """
    sees = line_of_sight(los)
    return _greedy_pass(lambda a, b: sees(grid, a, b), cells, length)


def prune_waypoints(grid: Grid, cells: jax.Array,
                    length: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Drop waypoints until none is removable: every interior waypoint's neighbours are
    then NOT in line of sight (:func:`jaxga.core.geometry.clear`).

    A waypoint whose kept predecessor sees its successor adds length (triangle
    inequality) and a turn for nothing; a collinear middle waypoint always qualifies
    (the union of two collinear clear segments through a cell centre is clear), so the
    result has no collinear triple either. Computed as :func:`shortcut_greedy` passes
    over the waypoints, repeated until a pass drops nothing (a pass that drops nothing
    has tested every interior waypoint's two neighbours); each pass loops over the
    waypoints only, so the cost is small on a post-optimised path.

    Returns ``(cells, length)``: a sub-sequence with the same endpoints, feasible if the
    input is, never longer.
    """
    return _prune(_exact_sight(grid), cells, length)


def _prune(sees: Callable[[jax.Array, jax.Array], jax.Array], cells: jax.Array,
           length: jax.Array) -> tuple[jax.Array, jax.Array]:
    """:func:`prune_waypoints` with the line-of-sight test ``sees(a, b)``."""

    def one_pass(carry):
        c, n, _ = carry
        c2, n2 = _greedy_pass(sees, c, n)
        return c2, n2, n2 < n

    cells, length, _ = jax.lax.while_loop(
        lambda carry: carry[2], one_pass,
        (jnp.asarray(cells, jnp.int32), jnp.asarray(length, jnp.int32), jnp.bool_(True)))
    return cells, length


# ----------------------------------------------------------------- shortcut_optimal
OPTIMAL_CHUNK = 64
"""Path positions whose line-of-sight tests :func:`shortcut_optimal` computes in one batch."""


def _path_length(cells: jax.Array, length: jax.Array, width: int) -> jax.Array:
    """Euclidean length (cell units, float32) of the first ``length`` nodes of ``cells``."""
    p = jnp.stack([cells % width, cells // width], axis=-1).astype(jnp.float32)
    seg = jnp.linalg.norm(p[1:] - p[:-1], axis=-1)
    # a fixed order of additions: XLA chooses a reduction's order per backend and batch
    return ordered_sum(jnp.where(jnp.arange(cells.shape[0] - 1) < length - 1, seg, 0.0))


def shortcut_optimal(
    grid: Grid, cells: jax.Array, length: jax.Array, *, window: int = SHORTCUT_WINDOW
) -> tuple[jax.Array, jax.Array]:
    """The shortest clear sub-sequence of a continuous path, as few waypoints as possible
    (jaxga, beyond the papers).

    The papers' greedy pass (:func:`shortcut_greedy`) takes the farthest node the anchor
    sees, which can leave the next segment longer than needed. This is the optimum over
    the same choices: a dynamic programme over the path's nodes, ``d[j] = min_i d[i] +
    |c_i c_j|`` over the earlier nodes ``i`` (at most ``window`` positions back) whose
    segment to ``c_j`` is clear (:func:`jaxga.core.geometry.clear`, exact, under the corner
    rule), then the chain of best predecessors from the goal. The greedy result is
    computed too and the shorter of the two kept, so the result is never longer than
    the papers' post-optimisation. A straight stretch longer than the window is followed
    through nodes of the path, which on a continuous path lie within a cell of the
    straight line; the final :func:`prune_waypoints` then drops every waypoint whose
    neighbours see each other (collinear ones included), so the waypoint path is
    minimal: no waypoint can go without another change.

    Cost: the line-of-sight tests (``window`` per node, :func:`_clear_short`: one lookup
    per grid line crossed, ``window`` lanes) are computed in batches of
    :data:`OPTIMAL_CHUNK` nodes, in a loop that stops at the path's ``length`` rather
    than its capacity; the programme's own steps are a few gathers each; the greedy
    passes loop over the input's nodes once, then over the waypoints. Ties between
    predecessors go to the farthest one.

    Args:
        grid: the map.
        cells, length: one feasible CONTINUOUS path (consecutive cells adjacent: a
            segment between positions ``i`` and ``j`` then spans at most ``j - i`` cells
            a side).
        window: static, the positions a segment may span.

    Returns:
        ``(cells, length)``: a feasible sub-sequence with the same endpoints, no longer
        than the input and than :func:`shortcut_greedy`'s result, with no interior
        waypoint whose two neighbours see each other.
    """
    cells = jnp.asarray(cells, jnp.int32)
    length = jnp.asarray(length, jnp.int32)
    n_cap = cells.shape[0]
    if n_cap < 3:
        return cells, length
    w = min(int(window), n_cap - 1)
    chunk = min(OPTIMAL_CHUNK, n_cap)
    width = grid.width
    inf = jnp.float32(jnp.inf)
    xy = jnp.stack([cells % width, cells // width], axis=-1).astype(jnp.float32)
    back = jnp.arange(w, 0, -1, dtype=jnp.int32)  # farthest first: argmin's tie-break
    codes = _vertex_codes(grid.blocked)
    sees = _exact_sight(grid, codes)

    def block(carry):
        start, dist, parent = carry
        targets = start + jnp.arange(chunk, dtype=jnp.int32)
        dst = jnp.clip(targets, 0, n_cap - 1)
        src = targets[:, None] - back[None, :]
        inside = (src >= 0) & (targets[:, None] < length)
        src = jnp.clip(src, 0, n_cap - 1)
        # does node t - back[k] see node t (positions w apart span at most w cells)
        seen = jax.vmap(jax.vmap(lambda a, t: _clear_short(grid, codes, a, t, w)))(
            cells[src], jnp.broadcast_to(cells[dst][:, None], src.shape))
        ok = seen & inside
        seg = jnp.linalg.norm(xy[src] - xy[dst][:, None], axis=-1)

        def step(k, carry):
            dist, parent = carry
            d = jnp.where(ok[k], dist[src[k]] + seg[k], inf)
            m = jnp.argmin(d)
            return dist.at[targets[k]].set(d[m]), parent.at[targets[k]].set(src[k, m])

        dist, parent = jax.lax.fori_loop(0, chunk, step, (dist, parent))
        return start + chunk, dist, parent

    # positions up to n_cap + chunk, so that the last block writes past the path safely
    dist0 = jnp.full((n_cap + chunk,), inf).at[0].set(0.0)
    parent0 = jnp.zeros((n_cap + chunk,), jnp.int32)
    _, dist, parent = jax.lax.while_loop(lambda c: c[0] < length, block,
                                         (jnp.int32(1), dist0, parent0))
    # The chain of best predecessors from the goal back to the start (marks kept nodes).
    last = jnp.maximum(length - 1, 0)

    def follow(c):
        node, keep = c
        return parent[node], keep.at[node].set(1)

    _, keep = jax.lax.while_loop(lambda c: c[0] > 0, follow,  # int32: no bool table
                                 (last, jnp.zeros((n_cap,), jnp.int32).at[0].set(1)))
    reachable = jnp.isfinite(dist[last])  # always, for a feasible continuous path
    opt_c, opt_n = compact(cells, jnp.where(reachable, keep != 0, jnp.arange(n_cap) < length))

    # One loop of greedy passes (one copy of the pass in the program): pass 0 is the
    # papers' greedy pass over the input (shortcut_greedy's result); the shorter of its
    # result and the programme's is then pruned (prune_waypoints) by passes over its
    # waypoints until one drops nothing.
    def one_pass(carry):
        c, n, first, _ = carry
        c2, n2 = _greedy_pass(sees, c, n)
        greedy = first & (_path_length(c2, n2, width) < _path_length(opt_c, opt_n, width))
        c3 = jnp.where(first & ~greedy, opt_c, c2)
        n3 = jnp.where(first & ~greedy, opt_n, n2)
        return c3, n3, jnp.bool_(False), first | (n2 < n)

    out_c, out_n, _, _ = jax.lax.while_loop(lambda carry: carry[3], one_pass,
                                            (cells, length, jnp.bool_(True), jnp.bool_(True)))
    return out_c, out_n


# ----------------------------------------------------------------- simplify_adjacent
def simplify_adjacent(
    key: jax.Array, grid: Grid, cells: jax.Array, length: jax.Array
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Zhu & Pan's simplification operator (section 4.6) for one individual.

    (i) pick a random node ``p_t`` other than the end point; (ii) set ``s = t + 1`` and
    scan ``p_{t+2} .. p_n``; (iii) whenever the distance between ``p_t`` and the current
    node is below 2, set ``s`` to it; finally delete the nodes strictly between ``p_t``
    and ``p_s``. "The simplification fails if ``s = t + 1``."

    Decisions where the paper is silent:

    * "distance below 2" between distinct cells is Chebyshev distance 1 (Euclidean 1 or
      sqrt 2); jaxga also requires the new step ``p_t -> p_s`` to be a legal move under
      the grid's corner rule, so a continuous path stays continuous (under ``"free"``
      this adds nothing).
    * ``t`` is uniform over ``0 .. n-2`` (the start may be chosen, the goal not), as the
      paper says; so the operator fails whenever ``p_t`` has no later neighbour, which
      on a good path is most of the time.
    * ``failed`` is True exactly when the paper says the simplification fails (no such
      ``s``, including paths of fewer than 3 nodes); the path is then returned
      unchanged. The operator never grows a path, so it cannot overflow.

    Cost: ``L`` legal-move tests and one gather (no loop). Returns
    ``(cells, length, failed)``.
    """
    cells = jnp.asarray(cells, jnp.int32)
    length = jnp.asarray(length, jnp.int32)
    n_cap = cells.shape[0]
    k = jnp.arange(n_cap, dtype=jnp.int32)
    bits = prng.bits(key, (), jnp.uint32)
    t = (bits % jnp.maximum(length - 1, 1).astype(jnp.uint32)).astype(jnp.int32)
    near = (k >= t + 2) & (k < length) & move_legal(grid, cells[t], cells)
    s = jnp.max(jnp.where(near, k, -1))
    found = s >= 0
    d = jnp.where(found, s - t - 1, 0)
    out = jnp.where(k <= t, cells, cells[jnp.minimum(k + d, n_cap - 1)])
    new_length = length - d
    return pad(out, new_length), new_length, ~found


# post (IMGA 4.5, AGACD 4.8, MPMGA 4.7): the final best path
register(Operator("post", "shortcut_greedy", shortcut_greedy,
                  "delete nodes while the shortcut is collision-free (IMGA 4.5, AGACD 4.8, "
                  "MPMGA 4.7)"))
register(Operator("post", "shortcut_optimal", shortcut_optimal,
                  "the shortest any-angle path through the path's nodes (jaxga)",
                  traits=frozenset({CONTINUOUS_ONLY})))
register_none("post", "no post-optimisation (loops removed)")
