"""A waypoint path as a polyline, for :mod:`jaxga.smooth`: its coordinates and corners,
its turning curvature bound, its resampling and the initial control points on it.

**Turning curvature bound** (:func:`turning_curvature_bound`). A polyline has infinite
curvature at its corners; its finite stand-in is the curvature of its *cell-scale fillet
rounding*. At a corner of turning angle ``theta`` (0 = straight) between segments of
lengths ``a`` and ``b``, take the largest circular arc tangent to both segments whose
tangent points lie at most ``t = min(a, b, 1) / 2`` from the corner: at most half of each
segment (an interior segment is shared by two corners) and within half a cell. Its
radius is ``t / tan(theta / 2)``, so

    kappa = 2 tan(theta / 2) / min(a, b, 1) = 2 |u x v| / ((|u||v| + u.v) min(a, b, 1))

for the segment vectors ``u, v``; the bound is the maximum over the corners (0 for a
straight path, finite for every polyline without a reversal ``theta = pi``). Why this
one: the arc lies in the triangle of the corner and its tangent points, all within
distance 1/2 of the corner's cell centre, so the rounded corner stays inside the
corner's own cell, which is free: the fillet rounding is always realisable without
touching a new obstacle. The uncapped fillet ``2 tan(theta/2) / min(a, b)`` is not: on
any-angle paths, whose segments are long and graze obstacle corners, it asks for radii
of 10+ cells that cut deep into the obstacles the path wraps around: a curvature no
clear curve comes close to (decision 044). Since every
segment between distinct cell centres is at least 1 long, the bound of a jaxga path is
simply ``2 tan(theta_max / 2)``: 0.83 for a 45 degree turn, 2 for 90 degrees, 4.83 for
135 degrees. A curve whose maximum curvature is below it turns no more sharply than the
polyline's sharpest corner rounded at grid resolution. The optimiser of
:mod:`jaxga.smooth` is given ``cap_factor`` (0.9) times the bound as its soft limit; the
tests check the outcome.

Units are cells; coordinates are cell centres ``(x, y)`` with row 0 at the bottom
(docs/maps.md). Float32, jittable and vmappable.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga.bspline import norm
from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid

__all__ = [
    "initial_control_points",
    "polyline_points",
    "polyline_turning",
    "polyline_xy",
    "turning_curvature_bound",
]


def polyline_xy(grid: Grid, cells: jax.Array, length: jax.Array):
    """``(xy float32[L, 2] re-padded with the last valid node, n int32)``: the cell centres
    of a padded path, so that its padding adds only zero-length segments."""
    w = grid.width
    cells = jnp.asarray(cells, jnp.int32)
    n = jnp.clip(jnp.asarray(length, jnp.int32), 1, cells.shape[0])
    i = jnp.arange(cells.shape[0], dtype=jnp.int32)
    cells = jnp.where(i < n, cells, cells[n - 1])
    xy = jnp.stack([cells % w, cells // w], axis=-1).astype(F32)
    return xy, n


def _corners(xy: jax.Array):
    """Per segment ``i`` of a padded polyline: ``(corner, |u x v|, u.v, |u|, |v|)`` of the
    corner between it (``v``) and the previous segment of non-zero length (``u``);
    ``corner`` is False for the first moving segment and for zero-length segments."""
    seg = xy[1:] - xy[:-1]
    seg_len = norm(seg)
    moving = seg_len > 0
    idx = jnp.arange(seg.shape[0], dtype=jnp.int32)
    last = jax.lax.cummax(jnp.where(moving, idx, -1))
    prev = jnp.concatenate([jnp.array([-1], jnp.int32), last[:-1]])
    u = seg[jnp.maximum(prev, 0)]
    cross = jnp.abs(u[:, 0] * seg[:, 1] - u[:, 1] * seg[:, 0])
    dot = jnp.sum(u * seg, axis=-1)
    return moving & (prev >= 0), cross, dot, seg_len[jnp.maximum(prev, 0)], seg_len


def turning_curvature_bound(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """The polyline's turning curvature bound, ``max 2 tan(theta / 2) / min(a, b, 1)``.

    ``theta`` is a corner's turning angle (0 = straight), ``a`` and ``b`` the lengths of
    its two segments: the curvature of the largest circular fillet whose tangent points
    lie within half of each segment and within half a cell of the corner, so that the
    rounded corner stays inside the corner's own (free) cell. The module docstring gives
    the reasoning (and why not the uncapped ``2 tan(theta / 2) / min(a, b)``); for jaxga
    paths (segments >= 1) it is ``2 tan(theta_max / 2)``. 0 for a path without corners;
    ``inf`` only for a reversal (``theta = pi``). Zero-length segments (repeated nodes,
    padding) are skipped. IMGA section 6. float32 scalar; jittable, vmappable.
    """
    xy, _ = polyline_xy(grid, cells, length)
    corner, cross, dot, a, b = _corners(xy)
    # tan(theta / 2) = |u x v| / (|u||v| + u.v) = (|u||v| - u.v) / |u x v|: the first form
    # for theta <= 90 degrees, the second beyond (no cancellation); inf for a reversal.
    ab = a * b
    tan_half = jnp.where(
        dot >= 0,
        cross / jnp.where(ab + dot > 0, ab + dot, 1.0),
        jnp.where(cross > 0, (ab - dot) / jnp.where(cross > 0, cross, 1.0), jnp.inf),
    )
    k = 2.0 * tan_half / jnp.minimum(jnp.minimum(a, b), 1.0)
    return jnp.max(jnp.where(corner, k, 0.0), initial=0.0).astype(F32)


def polyline_turning(xy: jax.Array) -> jax.Array:
    """Sum of the turning angles of a (possibly padded) polyline: its total absolute
    curvature, which :func:`jaxga.smooth.smooth` divides by the length to report a
    fallback's mean curvature."""
    corner, cross, dot, _, _ = _corners(xy)
    return jnp.sum(jnp.where(corner, jnp.arctan2(cross, dot), 0.0))


def polyline_points(
    grid: Grid, cells: jax.Array, length: jax.Array, n_points: int
) -> jax.Array:
    """``float32[n_points, 2]``: the polyline resampled with every vertex among the samples.

    The fallback's ``points`` in :func:`jaxga.smooth.smooth`, so that a fallback and a curve
    have the same shape and draw the same way.

    Vertex ``j`` lands on sample ``k_j = j + round((n_points - n) * s_j / S)`` (``s_j``
    the arc length to it, ``S`` the total), so segments get samples in proportion to their
    length plus one each; consecutive samples are on one segment. Needs
    ``n_points >= L`` (static check).
    """
    cells = jnp.asarray(cells, jnp.int32)
    cap = cells.shape[0]
    if n_points < cap:
        raise ParameterError(f"polyline_points: n_points = {n_points} < capacity {cap}")
    xy, n = polyline_xy(grid, cells, length)
    seg_len = jnp.sqrt(jnp.sum(jnp.square(xy[1:] - xy[:-1]), axis=-1))
    cum = jnp.concatenate([jnp.zeros(1, F32), jnp.cumsum(seg_len)])
    total = cum[-1]
    j = jnp.arange(cap, dtype=jnp.int32)
    extra = (n_points - n).astype(F32)
    frac = jnp.where(total > 0, cum / jnp.where(total > 0, total, 1.0), 0.0)
    kj = j + jnp.round(extra * frac).astype(jnp.int32)
    kj = jnp.where(j < n, kj, n_points - 1 + (j - n + 1))  # padding beyond the end
    k = jnp.arange(n_points, dtype=jnp.int32)
    seg = jnp.clip(jnp.searchsorted(kj, k, side="right").astype(jnp.int32) - 1, 0,
                   jnp.maximum(n - 2, 0))
    k0, k1 = kj[seg], kj[jnp.minimum(seg + 1, cap - 1)]
    f = jnp.clip((k - k0).astype(F32) / jnp.maximum(k1 - k0, 1).astype(F32), 0.0, 1.0)
    p0, p1 = xy[seg], xy[jnp.minimum(seg + 1, cap - 1)]
    pts = (p0 + f[:, None] * (p1 - p0)).at[-1].set(xy[n - 1])
    return jnp.where(n > 1, pts, xy[0])


def initial_control_points(
    grid: Grid, cells: jax.Array, length: jax.Array, n_ctrl: int
) -> jax.Array:
    """``float32[n_ctrl, 2]`` control points on the polyline, first = start, last = goal.

    The starting point of :func:`jaxga.smooth.smooth`'s optimisation.

    Evenly spaced by arc length: the uniform-speed parametrisation that the bending term
    prefers anyway. (Not spacing that gives short segments extra control points, e.g. by
    ``segment length + mean segment length``: on a long path it bunches them on
    a short first or last segment, and the slow curve there forms near-cusps with
    curvatures far above the turning bound.)
    """
    xy, n = polyline_xy(grid, cells, length)
    seg_len = jnp.sqrt(jnp.sum(jnp.square(xy[1:] - xy[:-1]), axis=-1))
    i = jnp.arange(seg_len.shape[0], dtype=jnp.int32)
    valid = i < n - 1
    wgt = jnp.where(valid, seg_len, 0.0)
    cum = jnp.concatenate([jnp.zeros(1, F32), jnp.cumsum(wgt)])
    total = cum[-1]
    target = jnp.linspace(0.0, 1.0, n_ctrl, dtype=F32) * total
    s = jnp.clip(jnp.searchsorted(cum, target, side="right").astype(jnp.int32) - 1, 0,
                 jnp.maximum(n - 2, 0))
    f = jnp.clip((target - cum[s]) / jnp.where(wgt[s] > 0, wgt[s], 1.0), 0.0, 1.0)
    pts = xy[s] + f[:, None] * (xy[s + 1] - xy[s])
    pts = jnp.where(total > 0, pts, xy[0])
    return pts.at[0].set(xy[0]).at[-1].set(xy[n - 1])
