"""Post-optimisation and simplification of paths (SPEC 9).

* :func:`shortcut_greedy` - the "deletion point method" / "optimization operator" /
  "delete operation" of MPMGA section 4.7, AGACD section 4.8 and IMGA section 4.5: turn a
  continuous path into a shorter feasible *waypoint* path. Applied to the final best.
* :func:`shortcut_optimal` - jaxga's (beyond the papers): the shortest clear
  sub-sequence of a continuous path's cells (a dynamic programme over the path), never
  longer than :func:`shortcut_greedy`'s result. Applied to the final best.
* :func:`simplify_adjacent` - Zhu & Pan's simplification operator (section 4.6): drop the
  detour between a node and the farthest later node one step away. Applied to every
  individual with probability ``ps`` every generation; the path stays continuous.
* :func:`remove_loops` - MPMGA's deletion operator, re-exported from :mod:`jaxga.core.paths`.

Every function is written for ONE path ``(cells int32[L], length int32)`` (SPEC 2), is
pure and jittable, has a fixed trip count (a ``lax.scan`` of ``L`` steps or pure
gathers, no ``while_loop``) and ``vmap``s over a population. Deterministic functions take
no key and return ``(cells, length)``; :func:`simplify_adjacent` is a per-individual
operator ``(key, grid, cells, length) -> (cells, length, failed)`` for
:func:`jaxga.operators.lift.over_individuals` and :func:`jaxga.operators.mutation.with_probability`.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga.core.errors import ParameterError
from jaxga.core.geometry import clear, linear_trial
from jaxga.core.grid import Grid, move_legal
from jaxga.core.paths import pad, remove_loops

__all__ = [
    "LINE_OF_SIGHT",
    "compact",
    "line_of_sight",
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
    """Keep the nodes where ``keep`` is True, in order, and re-pad (SPEC 2).

    One cumulative sum and one scatter of ``L`` lanes (no per-step work). ``keep`` must
    be False on the padding. Returns ``(cells, length)``.
    """
    cells = jnp.asarray(cells, jnp.int32)
    n = cells.shape[0]
    pos = jnp.cumsum(keep, dtype=jnp.int32) - 1
    length = jnp.sum(keep, dtype=jnp.int32)
    out = jnp.zeros((n,), jnp.int32).at[jnp.where(keep, pos, n)].set(cells, mode="drop")
    return pad(out, length), length


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

    Implementation: one ``lax.scan`` of ``L - 2`` steps; step ``k`` asks whether the
    current anchor sees ``cells[k]`` (one line-of-sight test per step, fixed trip count,
    ``vmap``-friendly), then one compaction.

    Args:
        grid: the map (``clear`` honours its corner rule; ``linear_trial`` has none).
        cells, length: one path (SPEC 2). It should be feasible under ``los``.
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
    cells = jnp.asarray(cells, jnp.int32)
    length = jnp.asarray(length, jnp.int32)
    n_cap = cells.shape[0]
    i = jnp.arange(n_cap, dtype=jnp.int32)
    if n_cap < 3:
        return cells, length

    def step(anchor, k):
        # j + 1 = k, j = k - 1: does the anchor see cells[k]?
        active = k < length
        visible = sees(grid, anchor, cells[k])
        drop = active & visible
        anchor = jnp.where(active & ~visible, cells[k - 1], anchor)
        return anchor, drop

    _, drop = jax.lax.scan(step, cells[0], jnp.arange(2, n_cap, dtype=jnp.int32))
    # drop[k - 2] says whether node k - 1 is dropped (k = 2 .. L-1).
    dropped = jnp.concatenate([jnp.zeros((1,), bool), drop, jnp.zeros((1,), bool)])
    keep = (i < length) & ~dropped
    return compact(cells, keep)


# ----------------------------------------------------------------- shortcut_optimal
def shortcut_optimal(
    grid: Grid, cells: jax.Array, length: jax.Array, *, window: int = SHORTCUT_WINDOW
) -> tuple[jax.Array, jax.Array]:
    """The shortest clear sub-sequence of a continuous path (jaxga, beyond the papers).

    The papers' greedy pass (:func:`shortcut_greedy`) takes the farthest node the anchor
    sees, which can leave the next segment longer than needed. This is the optimum over
    the same choices: a dynamic programme over the path's nodes, ``d[j] = min_i d[i] +
    |c_i c_j|`` over the earlier nodes ``i`` (at most ``window`` positions back) whose
    segment to ``c_j`` is clear (:func:`jaxga.core.geometry.clear`, exact, under the corner
    rule), then the chain of best predecessors from the goal. The greedy result is
    computed too and the shorter of the two returned, so the result is never longer than
    the papers' post-optimisation. The window bounds the cost (``L * window`` line-of-
    sight tests on segments of at most ``window`` cells a side); a straight stretch
    longer than the window is followed through nodes of the path, which on a continuous
    path lie within a cell of the straight line.

    Args:
        grid: the map.
        cells, length: one feasible CONTINUOUS path (consecutive cells adjacent: a
            segment between positions ``i`` and ``j`` then spans at most ``j - i`` cells
            a side).
        window: static, the positions a segment may span.

    Returns:
        ``(cells, length)``: a feasible sub-sequence with the same endpoints, no longer
        than the input and than :func:`shortcut_greedy`'s result.
    """
    cells = jnp.asarray(cells, jnp.int32)
    length = jnp.asarray(length, jnp.int32)
    n_cap = cells.shape[0]
    if n_cap < 3:
        return cells, length
    w = min(int(window), n_cap - 1)
    width = grid.width
    xy = jnp.stack([cells % width, cells // width], axis=-1).astype(jnp.float32)
    back = jnp.arange(1, w + 1, dtype=jnp.int32)
    inf = jnp.float32(jnp.inf)

    def step(dist, j):
        i = j - back
        inside = (i >= 0) & (j < length)
        ic = jnp.maximum(i, 0)
        seen = jax.vmap(lambda a: clear(grid, a, cells[j], max_span=w))(cells[ic])
        d = jnp.where(inside & seen, dist[ic] + jnp.linalg.norm(xy[ic] - xy[j], axis=-1), inf)
        k = jnp.argmin(d)
        return dist.at[j].set(jnp.where(j < length, d[k], inf)), ic[k]

    dist0 = jnp.full((n_cap,), inf).at[0].set(0.0)
    dist, parent = jax.lax.scan(step, dist0, jnp.arange(1, n_cap, dtype=jnp.int32))
    parent = jnp.concatenate([jnp.zeros((1,), jnp.int32), parent])
    # The chain of best predecessors from the goal back to the start (marks kept nodes).
    last = jnp.maximum(length - 1, 0)

    def follow(c):
        node, keep = c
        return parent[node], keep.at[node].set(True)

    _, keep = jax.lax.while_loop(lambda c: c[0] > 0, follow,
                                 (last, jnp.zeros((n_cap,), bool).at[0].set(True)))
    reachable = jnp.isfinite(dist[last])  # always, for a feasible continuous path
    opt_c, opt_n = compact(cells, keep & reachable | ~reachable & (jnp.arange(n_cap) < length))
    gr_c, gr_n = shortcut_greedy(grid, cells, length)

    def total(c, n):
        p = jnp.stack([c % width, c // width], axis=-1).astype(jnp.float32)
        seg = jnp.linalg.norm(p[1:] - p[:-1], axis=-1)
        return jnp.sum(jnp.where(jnp.arange(n_cap - 1) < n - 1, seg, 0.0))

    use_greedy = total(gr_c, gr_n) < total(opt_c, opt_n)
    return jnp.where(use_greedy, gr_c, opt_c), jnp.where(use_greedy, gr_n, opt_n)


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
    bits = jax.random.bits(key, (), jnp.uint32)
    t = (bits % jnp.maximum(length - 1, 1).astype(jnp.uint32)).astype(jnp.int32)
    near = (k >= t + 2) & (k < length) & move_legal(grid, cells[t], cells)
    s = jnp.max(jnp.where(near, k, -1))
    found = s >= 0
    d = jnp.where(found, s - t - 1, 0)
    out = jnp.where(k <= t, cells, cells[jnp.minimum(k + d, n_cap - 1)])
    new_length = length - d
    return pad(out, new_length), new_length, ~found
