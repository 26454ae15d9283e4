"""How far a curve stays from the blocked cells, for :mod:`jaxga.smooth`: the signed
distance field its optimiser reads and the exact certificate of a curve's clearance.

* **Distance field** (:func:`distance_field`): the exact Euclidean distance to the
  blocked squares at the nodes of a ``1/upsample`` lattice, bilinear in between
  (:func:`field_at`), negative inside obstacles so that a curve cutting into one is
  pushed out: continuous, so that the optimiser's clearance penalty has a gradient;
  exact at the nodes only.
* **Verification** (:func:`verify_curve`), independent of the distance field: exact
  distances from dense samples to the blocked squares, a rigorous bound between samples
  from the curve's derivatives, and exact chord-to-square distances minus the curve's
  deviation from the chord where clearance is tight: a certificate, not a sampling
  heuristic. :func:`polyline_clearance` does the same for a polyline.

Blocked cells are closed unit squares centred on their ``(x, y)``; the outside of the map
counts as blocked. Units are cells; float32, jittable.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.bspline import (
    control_points,
    eval_grid,
    eval_spans,
    norm,
    span_coefficients,
    steps_per_span,
)
from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, blocked_at

__all__ = [
    "DistanceField",
    "Verification",
    "distance_field",
    "field_at",
    "polyline_clearance",
    "verify_curve",
    "verify_spans",
]

_BIG = 1e6
_FIELD_PAD = 2  # rings of "outside" cells around the map in the distance field


class DistanceField(NamedTuple):
    """Signed Euclidean distance to the blocked cells, sampled on a fine lattice.

    ``values[j, i]`` is the signed distance at ``(x, y) = (origin + i / upsample,
    origin + j / upsample)``: positive outside obstacles (distance to the nearest blocked
    square or to the outside of the map), negative inside (minus the distance to the
    nearest free square). Exact at the nodes (up to float32).
    """

    values: jax.Array
    """float32[Ny, Nx]."""
    origin: jax.Array
    """float32 scalar: coordinate of node 0 in x and in y (``-0.5 - 1``)."""
    upsample: int
    """nodes per cell (a Python int: static)."""


jax.tree_util.register_pytree_node(
    DistanceField,
    lambda f: ((f.values, f.origin), f.upsample),
    lambda aux, ch: DistanceField(ch[0], ch[1], aux),
)


def _sq_dist_to_set(mask: jax.Array, xs: jax.Array, ys: jax.Array) -> jax.Array:
    """Exact squared distance from lattice nodes to the union of the unit squares of
    ``mask`` (cells centred at integer coordinates, index = coordinate), ``[Ny, Nx]``.

    Separable: ``d^2 = min_c fx(x, cx) + fy(y, cy)`` with ``f(p, c) = max(|p - c| - 1/2, 0)^2``,
    so a min over rows per column first, then a min over columns (each a ``lax.map``).
    """
    h, w = mask.shape
    cy = jnp.arange(h, dtype=F32)
    cx = jnp.arange(w, dtype=F32)
    fy = jnp.square(jnp.maximum(jnp.abs(ys[:, None] - cy[None, :]) - 0.5, 0.0))  # [Ny, H]
    fx = jnp.square(jnp.maximum(jnp.abs(xs[:, None] - cx[None, :]) - 0.5, 0.0))  # [Nx, W]

    def column(col):  # col: bool[H] -> [Ny]
        return jnp.min(jnp.where(col[None, :], fy, _BIG), axis=1)

    g = jax.lax.map(column, mask.T)  # [W, Ny]

    def row(gj):  # gj: [W] -> [Nx]
        return jnp.min(fx + gj[None, :], axis=1)

    return jax.lax.map(row, g.T)  # [Ny, Nx]


def distance_field(grid: Grid, upsample: int = 4) -> DistanceField:
    """The signed Euclidean distance field of ``grid``'s blocked cells.

    Blocked cells are closed unit squares centred on their ``(x, y)``; the outside of the
    map counts as blocked. Nodes are spaced ``1 / upsample`` and cover the map plus one
    cell on every side, so points slightly off the map still get a gradient back. The
    distances are exact at the nodes (a separable min-plus transform, cost
    ``O(upsample^2 H W (H + W))``, once per grid); :func:`jaxga.smooth.smooth` interpolates them
    bilinearly. Jittable (``upsample`` static).
    """
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)) or upsample < 1:
        raise ParameterError(f"upsample must be an integer >= 1, got {upsample!r}")
    h, w = grid.shape
    p = _FIELD_PAD
    blocked = jnp.pad(jnp.asarray(grid.blocked, bool), p, constant_values=True)
    origin = -0.5 - 1.0
    nx, ny = upsample * (w + 2) + 1, upsample * (h + 2) + 1
    # coordinates in the padded frame (cell index = coordinate + p)
    xs = origin + p + jnp.arange(nx, dtype=F32) / upsample
    ys = origin + p + jnp.arange(ny, dtype=F32) / upsample
    d_blocked = jnp.sqrt(_sq_dist_to_set(blocked, xs, ys))
    d_free = jnp.sqrt(_sq_dist_to_set(~blocked, xs, ys))
    return DistanceField(
        values=(d_blocked - d_free).astype(F32), origin=jnp.asarray(origin, F32),
        upsample=int(upsample),
    )


def field_at(field: DistanceField, p: jax.Array) -> jax.Array:
    """Bilinear interpolation of the signed distance at points ``p[..., 2]``: continuous
    in ``p``, so that the smoothing's clearance penalty has a gradient everywhere."""
    ny, nx = field.values.shape
    g = (p - field.origin) * field.upsample
    gx = jnp.clip(g[..., 0], 0.0, nx - 1.001)
    gy = jnp.clip(g[..., 1], 0.0, ny - 1.001)
    i0, j0 = jnp.floor(gx).astype(jnp.int32), jnp.floor(gy).astype(jnp.int32)
    fx, fy = gx - i0, gy - j0
    v = field.values
    v00, v01 = v[j0, i0], v[j0, i0 + 1]
    v10, v11 = v[j0 + 1, i0], v[j0 + 1, i0 + 1]
    return (v00 * (1 - fx) + v01 * fx) * (1 - fy) + (v10 * (1 - fx) + v11 * fx) * fy


_OFFSETS = np.stack(np.meshgrid(np.arange(-1, 2), np.arange(-1, 2)), -1).reshape(-1, 2)


def _window(blocked: jax.Array, p: jax.Array) -> tuple[jax.Array, jax.Array]:
    """The 3 x 3 cells around the cell holding each point ``p[..., 2]``: ``(centres
    float32[..., 9, 2], blocked bool[..., 9])`` (cells off the map count as blocked)."""
    cell = jnp.floor(p + 0.5).astype(jnp.int32)
    cells = cell[..., None, :] + jnp.asarray(_OFFSETS, jnp.int32)
    return cells.astype(F32), blocked_at(blocked, cells[..., 0], cells[..., 1])


def _point_clearance(blocked: jax.Array, p: jax.Array) -> jax.Array:
    """``min(1, distance)`` from points ``p[..., 2]`` to the blocked squares, exact.

    Every square outside the 3 x 3 window around a point's cell is at least 1 away, so
    the local minimum is the exact distance whenever it is below 1.
    """
    c, blk = _window(blocked, p)
    e = jnp.maximum(jnp.abs(p[..., None, :] - c) - 0.5, 0.0)
    d = jnp.sqrt(jnp.sum(e * e, axis=-1))
    return jnp.minimum(jnp.min(jnp.where(blk, d, jnp.inf), axis=-1), 1.0)


def _segment_square_distance(p0: jax.Array, p1: jax.Array, c: jax.Array) -> jax.Array:
    """Exact distance between segments ``p0 p1`` and closed unit squares centred at ``c``.

    Broadcasting over leading axes; 0 when they intersect (bounding boxes overlap and the
    square's corners are not all strictly on one side of the segment's line), else the
    minimum over the segment ends (to the square) and the square's corners (to the
    segment), which is exact for disjoint convex sets.
    """
    d = p1 - p0
    lo, hi = c - 0.5, c + 0.5
    overlap = jnp.all((jnp.minimum(p0, p1) <= hi) & (jnp.maximum(p0, p1) >= lo), axis=-1)
    corners = [c + jnp.asarray([sx, sy], F32) for sx in (-0.5, 0.5) for sy in (-0.5, 0.5)]
    sides = jnp.stack(
        [d[..., 0] * (q[..., 1] - p0[..., 1]) - d[..., 1] * (q[..., 0] - p0[..., 0])
         for q in corners], axis=-1,
    )
    hit = overlap & (jnp.min(sides, axis=-1) <= 0) & (jnp.max(sides, axis=-1) >= 0)

    def point_square(p):
        e = jnp.maximum(jnp.abs(p - c) - 0.5, 0.0)
        return jnp.sum(e * e, axis=-1)

    best = jnp.minimum(point_square(p0), point_square(p1))
    len2 = jnp.sum(d * d, axis=-1)
    inv = jnp.where(len2 > 0, 1.0 / jnp.where(len2 > 0, len2, 1.0), 0.0)
    for q in corners:
        r = q - p0
        t = jnp.clip(jnp.sum(r * d, axis=-1) * inv, 0.0, 1.0)
        e = r - t[..., None] * d
        best = jnp.minimum(best, jnp.sum(e * e, axis=-1))
    return jnp.where(hit, 0.0, jnp.sqrt(best))


def _chord_clearance(blocked: jax.Array, p0: jax.Array, p1: jax.Array) -> jax.Array:
    """``min(distance, 1 - |p1 - p0| / 2)`` from chords ``p0 p1`` to the blocked squares.

    Exact over the 3 x 3 cells around the midpoint's cell; every other square is at least
    ``1 - chord / 2`` from the chord, so the result is exact whenever it is below that.
    """
    mid = 0.5 * (p0 + p1)
    c, blk = _window(blocked, mid)
    dist = _segment_square_distance(p0[..., None, :], p1[..., None, :], c)
    local = jnp.min(jnp.where(blk, dist, jnp.inf), axis=-1)
    chord = jnp.sqrt(jnp.sum(jnp.square(p1 - p0), axis=-1))
    return jnp.minimum(local, 1.0 - 0.5 * chord)


class Verification(NamedTuple):
    """The result of :func:`verify_curve`."""

    clear: jax.Array
    """bool: the certified lower bound on the curve's clearance exceeds ``tol``."""
    lower_bound: jax.Array
    """float32: that lower bound (at most 1: the checks look one cell around the curve)."""
    min_clearance: jax.Array
    """float32: the curve's clearance, ``min(1, .)``: exact distances of the refined
    (tightest) sub-chords, which follow the curve to within ``h^2/8 max|C''|`` (about
    1e-4), and of the samples elsewhere."""


def verify_spans(blocked, coef, per_span, refine_chords, refine_factor, tol):
    """:func:`verify_curve` on span coefficients; also returns the samples and their
    point clearances ``(verification, p, d1, d2, c)``, from which
    :func:`jaxga.smooth.smooth` takes the curve's points, length and curvature without
    evaluating it again."""
    p, d1, d2 = eval_grid(coef, per_span)
    dt = 1.0 / per_span
    c = _point_clearance(blocked, p)
    # Curve piece between samples i, i+1: a point at arc distance s from sample i is at
    # least max(c_i - s, c_{i+1} - (A - s)) >= (c_i + c_{i+1} - A) / 2 from every obstacle,
    # A = arc length <= dt min(|C'_i|, |C'_i+1|) + dt^2 max|C''| / 2 (C'' linear on a span).
    m2 = norm(jnp.maximum(jnp.abs(d2[:-1]), jnp.abs(d2[1:])))
    speed = norm(d1)
    arc = dt * jnp.minimum(speed[:-1], speed[1:]) + 0.5 * dt * dt * m2
    lb = 0.5 * (c[:-1] + c[1:] - arc)
    lb = jnp.where(jnp.isfinite(lb), lb, -jnp.inf)
    exact_min = jnp.min(c)
    k = min(refine_chords, lb.shape[0])
    if k > 0:
        # Where clearance is tight: exact chord distances on refine_factor sub-chords,
        # minus the curve's deviation from a sub-chord, h^2 / 8 max|C''| (h its dt).
        _, worst = jax.lax.top_k(-lb, k)
        span = worst // per_span
        r = np.linspace(0.0, 1.0, refine_factor + 1, dtype=np.float32)
        u = ((worst % per_span).astype(F32)[:, None] + jnp.asarray(r)[None, :]) * dt
        sp, _, s2 = eval_spans(coef[span][:, None], u)  # [k, R + 1, 2]
        h = dt / refine_factor
        dev = h * h / 8.0 * norm(jnp.maximum(jnp.abs(s2[:, :-1]), jnp.abs(s2[:, 1:])))
        cc = _chord_clearance(blocked, sp[:, :-1], sp[:, 1:])
        refined = jnp.min(cc - dev, axis=1)
        lb = lb.at[worst].max(jnp.where(jnp.isfinite(refined), refined, -jnp.inf))
        capped = cc >= 1.0 - 0.5 * norm(sp[:, 1:] - sp[:, :-1])  # nothing within reach
        exact_min = jnp.minimum(exact_min, jnp.min(jnp.where(capped, 1.0, cc)))
    lower = jnp.min(lb)
    ver = Verification(clear=lower > tol, lower_bound=lower.astype(F32),
                       min_clearance=exact_min.astype(F32))
    return ver, p, d1, d2, c


def verify_curve(
    grid: Grid,
    control: jax.Array,
    *,
    per_span: int = 16,
    refine_chords: int = 16,
    refine_factor: int = 8,
    tol: float = 1e-3,
) -> Verification:
    """Certify that the B-spline of ``control`` stays more than ``tol`` from blocked cells.

    Independent of the distance field and exact.
    A point is in a blocked cell when ``floor(x + 1/2), floor(y + 1/2)`` is blocked or off
    the map; distances are to the closed unit squares of those cells. The curve is sampled
    at ``per_span`` parameter steps per span, the exact distance from every sample to the
    nearest blocked square is computed (3 x 3 cell window, exact below 1), and each curve
    piece between two samples gets the lower bound ``(c_i + c_{i+1} - A) / 2``, where
    ``A`` bounds the piece's arc length from the derivatives. Where clearance is tight
    (the ``refine_chords`` smallest bounds) the piece is cut into ``refine_factor``
    sub-chords whose exact distance to the blocked squares, minus the curve's deviation
    from a chord (``h^2 / 8 max |C''|``, exact because ``C''`` is linear on a span), is a
    sharper bound. The curve is clear when the smallest bound exceeds ``tol`` (a
    certificate up to float32 rounding, which ``tol`` absorbs). Static arguments:
    ``per_span``, ``refine_chords``, ``refine_factor``.
    """
    control = control_points(control, "verify_curve")
    per_span = steps_per_span(per_span, "verify_curve: per_span")
    refine_chords = steps_per_span(refine_chords, "verify_curve: refine_chords")
    refine_factor = steps_per_span(refine_factor, "verify_curve: refine_factor")
    ver, *_ = verify_spans(jnp.asarray(grid.blocked, bool), span_coefficients(control), per_span,
                      refine_chords, refine_factor, tol)
    return ver


def polyline_clearance(blocked: jax.Array, pts: jax.Array, refine_chords: int) -> jax.Array:
    """``min(1, clearance)`` of the polyline through ``pts``: sampled, and exact on the
    ``refine_chords`` chords whose sampled lower bound is smallest (always at least one):
    the clearance :func:`jaxga.smooth.smooth` reports for a fallback polyline."""
    c = _point_clearance(blocked, pts)
    chord = norm(pts[1:] - pts[:-1])
    lb = 0.5 * (c[:-1] + c[1:] - chord)
    _, worst = jax.lax.top_k(-lb, max(1, min(refine_chords, lb.shape[0])))
    cc = _chord_clearance(blocked, pts[worst], pts[worst + 1])
    return jnp.minimum(jnp.min(c), jnp.min(cc))
