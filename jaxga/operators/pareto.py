"""Multi-objective selection (Deb, Pratap, Agarwal and Meyarivan 2002, NSGA-II): fronts of
non-dominated individuals, crowding distances, the crowded comparison and the elitist
survival built on them; and the hypervolume a front dominates (Zitzler and Thiele 1998),
the measure of its progress over the generations.

Every objective is minimised (a quantity to maximise, such as clearance, enters negated).
``objectives`` are ``float32[P, M]`` (one row per individual) and ``valid`` ``bool[P]``:
an individual that is not valid (no feasible path, an inactive slot) never dominates,
is dominated by every valid one and ranks last. Each function is pure and shape-static
(``P`` and ``M`` fixed), so it works under ``jax.jit`` and ``jax.vmap`` (over runs), and
its result is fully determined by its inputs: ties are broken by the individual's index,
never by the sorting algorithm, and sums are taken in a fixed order
(:func:`jaxga._batching.numerics.ordered_sum`), so a run's values do not depend on the
runs computed beside it.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga._batching.numerics import ordered_sum
from jaxga.core import prng
from jaxga.core.dtypes import F32, I32

__all__ = [
    "crowded_order",
    "crowded_tournament",
    "crowding_distance",
    "domination_matrix",
    "hypervolume",
    "hypervolume_2d",
    "hypervolume_3d",
    "nondominated_rank",
    "survivors",
]


def domination_matrix(objectives: jax.Array, valid: jax.Array) -> jax.Array:
    """``bool[P, P]``: entry ``[i, j]`` is true where individual ``i`` dominates ``j``
    (Deb et al. 2002, section III-A: no worse in every objective and better in at least
    one); a valid individual dominates every invalid one, an invalid one nothing."""
    f = jnp.asarray(objectives, F32)
    no_worse = jnp.all(f[:, None, :] <= f[None, :, :], axis=-1)
    better = jnp.any(f[:, None, :] < f[None, :, :], axis=-1)
    valid = jnp.asarray(valid, bool)
    return valid[:, None] & ((no_worse & better & valid[None, :]) | ~valid[None, :])


def nondominated_rank(objectives: jax.Array, valid: jax.Array) -> jax.Array:
    """``int32[P]``: each individual's front (Deb et al. 2002, fast non-dominated sort,
    section III-A): 0 for the individuals no other dominates, ``r`` for those that only
    individuals of fronts ``< r`` dominate; ``P`` for an invalid individual. Fronts are
    peeled one at a time (a ``while_loop`` of at most ``P`` rounds over the domination
    matrix)."""
    dom = domination_matrix(objectives, valid)
    n = dom.shape[0]

    def peel(state):
        rank, remaining, r = state
        dominated = jnp.any(dom & remaining[:, None], axis=0)
        front = remaining & ~dominated
        return jnp.where(front, r, rank), remaining & ~front, r + 1

    rank, _, _ = jax.lax.while_loop(
        lambda s: jnp.any(s[1]), peel,
        (jnp.full((n,), n, I32), jnp.asarray(valid, bool), jnp.int32(0)))
    return rank


def crowding_distance(objectives: jax.Array, rank: jax.Array) -> jax.Array:
    """``float32[P]``: each individual's crowding distance within its front (Deb et al.
    2002, section III-B): over the objectives, the side of the cuboid its two
    neighbours along that objective span, normalised by the front's range of the
    objective (a range of 0 adds nothing); a front's extreme individuals in any
    objective get infinity. Individuals of one front that tie in an objective are
    ordered by their index. Invalid individuals (rank ``P``) get 0."""
    f = jnp.asarray(objectives, F32)
    rank = jnp.asarray(rank, I32)
    n = f.shape[0]
    idx = jnp.arange(n, dtype=I32)

    def along(col: jax.Array) -> jax.Array:
        order = jnp.lexsort((idx, col, rank))
        r, v = rank[order], col[order]
        edge = r[1:] != r[:-1]
        first = jnp.concatenate([jnp.ones((1,), bool), edge])
        last = jnp.concatenate([edge, jnp.ones((1,), bool)])
        # sorted by front, then value: a front's least and greatest values are its first
        # and last entries (gathers, no scatter whose order could matter)
        lo = v[jnp.searchsorted(r, r, side="left")]
        hi = v[jnp.searchsorted(r, r, side="right") - 1]
        span = hi - lo
        gap = jnp.roll(v, -1) - jnp.roll(v, 1)
        inner = jnp.where(span > 0, gap / jnp.where(span > 0, span, 1.0), 0.0)
        sorted_d = jnp.where(first | last, jnp.inf, inner)
        return sorted_d[jnp.argsort(order)]  # back to the individuals' order (a gather)

    d = ordered_sum(jax.vmap(along, in_axes=1, out_axes=1)(f), axis=1)
    return jnp.where(rank >= n, 0.0, d).astype(F32)


def crowded_order(rank: jax.Array, crowding: jax.Array) -> jax.Array:
    """``int32[P]``: the individuals best first under the crowded comparison (Deb et al.
    2002, section III-B: the lower front first, within a front the larger crowding
    distance first), ties by index."""
    n = rank.shape[0]
    return jnp.lexsort((jnp.arange(n, dtype=I32), -jnp.asarray(crowding, F32),
                        jnp.asarray(rank, I32))).astype(I32)


def survivors(objectives: jax.Array, valid: jax.Array, n: int) -> jax.Array:
    """``int32[n]``: NSGA-II's elitist survival (Deb et al. 2002, section III-C): of the
    parents and offspring together (``objectives``, ``valid``), the ``n`` best under the
    crowded comparison: whole fronts while they fit, then the least crowded individuals
    of the front that does not."""
    rank = nondominated_rank(objectives, valid)
    return crowded_order(rank, crowding_distance(objectives, rank))[:n]


def crowded_tournament(key: jax.Array, rank: jax.Array, crowding: jax.Array,
                       active: jax.Array, n: int) -> jax.Array:
    """``int32[n]``: NSGA-II's mating selection (Deb et al. 2002, section III-B): ``n``
    binary tournaments between individuals drawn uniformly among the ``active`` ones,
    each won by the crowded comparison (lower front, then larger crowding distance, then
    the first drawn)."""
    active = jnp.asarray(active, bool)
    n_active = jnp.maximum(jnp.sum(active.astype(I32)), 1)
    pool = jnp.argsort(~active, stable=True).astype(I32)  # the active individuals first
    draws = prng.randint(key, (n, 2), 0, n_active)
    a, b = pool[draws[:, 0]], pool[draws[:, 1]]
    a_wins = (rank[a] < rank[b]) | ((rank[a] == rank[b]) & (crowding[a] >= crowding[b]))
    return jnp.where(a_wins, a, b)


def hypervolume_2d(points: jax.Array, valid: jax.Array, reference: jax.Array) -> jax.Array:
    """``float32``: the area that the valid ``points`` (``float32[P, 2]``, minimised)
    dominate up to ``reference`` (Zitzler and Thiele 1998): a sweep along the first
    objective under the running minimum of the second. Dominated points and points not
    below the reference add nothing."""
    p = jnp.asarray(points, F32)
    ref = jnp.asarray(reference, F32)
    inside = jnp.asarray(valid, bool) & jnp.all(p < ref, axis=1)
    x = jnp.where(inside, p[:, 0], ref[0])
    y = jnp.where(inside, p[:, 1], ref[1])
    order = jnp.lexsort((y, x))
    xs, ys = x[order], y[order]
    lowest = jax.lax.cummin(ys)
    widths = jnp.concatenate([xs[1:], ref[:1]]) - xs
    return ordered_sum(widths * (ref[1] - lowest))


def hypervolume_3d(points: jax.Array, valid: jax.Array, reference: jax.Array) -> jax.Array:
    """``float32``: the volume that the valid ``points`` (``float32[P, 3]``, minimised)
    dominate up to ``reference``: slices along the third objective, each the area
    (:func:`hypervolume_2d`) of the points at or below it (Zitzler and Thiele 1998)."""
    p = jnp.asarray(points, F32)
    ref = jnp.asarray(reference, F32)
    inside = jnp.asarray(valid, bool) & jnp.all(p < ref, axis=1)
    n = p.shape[0]
    z = jnp.where(inside, p[:, 2], ref[2])
    order = jnp.lexsort((jnp.arange(n), z))
    zs = z[order]
    position = jnp.argsort(order)  # each point's place along the third objective

    def area_at(k):
        return hypervolume_2d(p[:, :2], inside & (position <= k), ref[:2])

    areas = jax.vmap(area_at)(jnp.arange(n))
    heights = jnp.concatenate([zs[1:], ref[2:]]) - zs
    return ordered_sum(heights * areas)


def hypervolume(points: jax.Array, valid: jax.Array, reference: jax.Array) -> jax.Array:
    """``float32``: the hypervolume of the valid ``points`` up to ``reference``, for two
    objectives (:func:`hypervolume_2d`) or three (:func:`hypervolume_3d`)."""
    m = jnp.shape(points)[-1]
    if m == 2:
        return hypervolume_2d(points, valid, reference)
    if m == 3:
        return hypervolume_3d(points, valid, reference)
    raise ValueError(f"hypervolume takes 2 or 3 objectives, got {m}")
