"""Smooth-curve post-processing of waypoint paths: a cubic B-spline fitted with optax.

Beyond the papers (docs/replanning.md). IMGA's conclusion (section 6, future research
direction 2) proposes "combining the algorithm with Bezier curve or other curve smoothing
methods". Its Table 4 / Fig. 9 compares IMGA's broken line (length 27.87, 0.70 s, three
tangencies to obstacles) with BCA, a GA over piecewise Bezier control points whose curve
"is not tangent to any obstacle" (length 29.94, 136.5 s). Here the smoothing is a
post-processing step for a post-optimised jaxga path, one compiled call for a whole
padded population:

1. **Curve.** A clamped uniform cubic B-spline with ``M = config.n_ctrl`` control points
   (``T = M - 3`` spans, parameter ``t`` in ``[0, T]``). Chosen over piecewise cubic
   Bezier because it is C2 by construction (curvature is continuous, so "max curvature"
   is meaningful) with no joint constraints to maintain while optimising; each control
   point acts on 4 spans only; a span lies in the convex hull of its 4 control points;
   clamping makes the curve interpolate its first and last control points, so start and
   goal stay fixed just by not optimising ``P[0]`` and ``P[M-1]``. Each span is
   converted once (float64) to a cubic polynomial, so points and derivatives anywhere are
   a few multiply-adds, and the objective's samples are static matrices times ``P``.
2. **Initialisation.** The control points are placed ON the polyline, evenly spaced by
   arc length (:func:`initial_control_points`), so the initial curve is the polyline
   with its corners slightly cut. A straight polyline (turning bound 0) is returned as
   that straight B-spline without optimising: it is already as smooth as it gets.
3. **Objective**, minimised by ``optax.adam`` (cosine-decayed step size, a fixed number
   of steps in ``lax.scan``; deterministic, no randomness)::

       w_length * length
     + w_bend  * (T / S0)^3 * integral |C''(t)|^2 dt
     + w_clear * integral relu(margin - sdf(C(s)))^2 ds
     + w_cap   * integral relu(kappa(s) - cap)^2 ds
     + w_speed * (T / S0)^2 integral relu(min_speed * S0 / T - |C'(t)|)^2 dt

   ``S0`` is the polyline length, so the bending term approximates the bending energy
   ``integral kappa^2 ds`` of a uniformly parametrised curve (and keeps the
   parametrisation even); ``sdf`` is the signed distance field of :func:`distance_field`
   (exact Euclidean distance to the blocked squares at the nodes of a ``1/upsample``
   lattice, bilinear in between, negative inside obstacles so that a curve cutting into
   one is pushed out); ``cap = min(cap_factor * turning_curvature_bound,
   curvature_limit)`` is a soft curvature limit (see below; ``curvature_limit`` can model a
   robot's minimum turning radius, IMGA section 6 direction 3); the last term keeps the
   parametrisation from stalling (a slow stretch of curve can hide a near-cusp of huge
   curvature between quadrature points). Integrals use the midpoint rule on
   ``samples_per_span`` points per span. The length and bending terms are convex in the
   control points; the clearance, cap and stall terms are not.
4. **Verification** (:func:`verify_curve`), independent of the distance field: exact
   distances from dense samples to the blocked squares, a rigorous bound between samples
   from the curve's derivatives, and exact chord-to-square distances minus the curve's
   deviation from the chord where clearance is tight. The curve is *clear* when the
   certified lower bound on its clearance exceeds ``config.tol`` (a certificate, not a
   sampling heuristic; ``tol`` absorbs float32 rounding).
5. **Fallback.** If the curve cannot be certified clear (also when the path has fewer
   than two nodes or the optimisation produced non-finite values), the result is the
   polyline itself with ``used_fallback = True``; its ``clear`` flag is then the exact
   feasibility of the polyline (:func:`jaxga.core.geometry.segments_clear`, corner rule
   included). A path squeezing between two diagonally touching obstacles (legal under
   ``corner_rule="free"``) always falls back: a curve can only pass such a point with
   clearance 0.

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
of 10+ cells that cut deep into the obstacles the path wraps around (e.g. 0.076 on
``routeplanning_zhangzheng_paper_20x20``, where no clear curve comes close). Since every
segment between distinct cell centres is at least 1 long, the bound of a jaxga path is
simply ``2 tan(theta_max / 2)``: 0.83 for a 45 degree turn, 2 for 90 degrees, 4.83 for
135 degrees. A curve whose maximum curvature is below it turns no more sharply than the
polyline's sharpest corner rounded at grid resolution. The optimiser is given
``cap_factor`` (0.9) times the bound as its soft limit; the tests check the outcome.

Units are cells; coordinates are cell centres ``(x, y)`` with row 0 at the bottom
(docs/maps.md). Everything is float32, jittable and vmappable; :class:`SmoothConfig` is static.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.geometry import segments_clear
from jaxga.core.grid import Grid, blocked_at
from jaxga.plot import plot_map

__all__ = [
    "DistanceField",
    "SmoothConfig",
    "SmoothResult",
    "Verification",
    "curve_points",
    "distance_field",
    "initial_control_points",
    "plot_smooth",
    "polyline_points",
    "resample_curve",
    "smooth",
    "smooth_population",
    "turning_curvature_bound",
    "verify_curve",
]

_BIG = 1e6
_FIELD_PAD = 2  # rings of "outside" cells around the map in the distance field


def _norm(v: jax.Array) -> jax.Array:
    """Euclidean norm over the last axis."""
    return jnp.sqrt(jnp.sum(v * v, axis=-1))


# =========================================================================== config
@dataclasses.dataclass(frozen=True)
class SmoothConfig:
    """Static parameters of :func:`smooth` (hashable: pass it as a static argument).

    Attributes:
        n_ctrl: number of B-spline control points ``M`` (>= 4; ``M - 3`` spans), or None
            (the default) for ``H + W`` of the map, clipped to ``[16, 512]``: about one
            control point per cell of a typical path (a path across an ``H x W`` map is
            ``max(H, W)`` to ``H + W`` long). Too few stiffen the curve: more fallbacks
            and tighter clearances (e.g. 40 on a 50 x 50 map, or H + W = 40 for the
            100+ cell paths of a 20 x 20 maze with 1-cell corridors, where about 35 %
            fall back; 160 smooths them all). Set it to ~1.2 x the longest path length
            for winding paths. Cost is linear in it.
        steps: optimisation steps (``optax.adam`` in ``lax.scan``).
        learning_rate: initial Adam step size in cells (cosine-decayed to 0).
        adam_eps: Adam's ``eps``. Large compared with optax's 1e-8 on purpose: Adam
            normalises gradients, so with a tiny ``eps`` float32 noise in a gradient that
            should be 0 (a straight run of collinear control points) becomes a full-size
            step, and rounding differences (vmapped vs single) are amplified.
        w_length: weight of the curve length.
        w_bend: weight of the bending term (approximates ``integral kappa^2 ds``).
        w_clear: weight of the clearance penalty ``integral relu(margin - sdf)^2 ds``.
        margin: clearance (cells) below which the clearance penalty acts.
        w_cap: weight of the curvature-cap penalty ``integral relu(kappa - cap)^2 ds``.
        cap_factor: the cap is ``cap_factor`` times the polyline's
            :func:`turning_curvature_bound` ...
        curvature_limit: ... or this absolute limit (1 / minimum turning radius), if lower.
            Soft, like the cap: where clearance needs a tighter turn the curve exceeds it
            (or falls back); check ``max_curvature``.
        w_speed: weight of the stall penalty on speeds below ``min_speed`` ...
        min_speed: ... times the mean speed ``S0 / T`` (curve parameter per span).
        samples_per_span: objective quadrature points per span.
        verify_per_span: verification samples per span; also the returned ``points``
            (``(M - 3) * verify_per_span + 1`` of them, at least the path capacity ``L``).
        refine_chords: how many of the tightest verification pieces are refined.
        refine_factor: into how many exact sub-chords each of them is cut.
        upsample: distance-field nodes per cell (node spacing ``1 / upsample``).
        tol: the certified clearance lower bound must exceed this (cells).
    """

    n_ctrl: int | None = None
    steps: int = 200
    learning_rate: float = 0.05
    adam_eps: float = 1e-3
    w_length: float = 1.0
    w_bend: float = 1.0
    w_clear: float = 200.0
    margin: float = 0.25
    w_cap: float = 100.0
    cap_factor: float = 0.9
    curvature_limit: float = float("inf")
    w_speed: float = 100.0
    min_speed: float = 0.5
    samples_per_span: int = 6
    verify_per_span: int = 16
    refine_chords: int = 16
    refine_factor: int = 8
    upsample: int = 4
    tol: float = 1e-3

    def __post_init__(self) -> None:
        ints = {
            "n_ctrl": 4, "steps": 0, "samples_per_span": 1, "verify_per_span": 1,
            "refine_chords": 0, "refine_factor": 1, "upsample": 1,
        }
        for name, lo in ints.items():
            v = getattr(self, name)
            if name == "n_ctrl" and v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ParameterError(f"SmoothConfig.{name} must be an integer >= {lo}, got {v!r}")
        for name in ("learning_rate", "adam_eps", "w_length", "w_bend", "w_clear", "margin",
                     "w_cap", "cap_factor", "curvature_limit", "w_speed", "min_speed", "tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0:
                raise ParameterError(f"SmoothConfig.{name} must be a number >= 0, got {v!r}")

    def resolved(self, shape: tuple[int, int]) -> SmoothConfig:
        """This configuration with ``n_ctrl`` fixed for a map of ``shape = (H, W)``."""
        if self.n_ctrl is not None:
            return self
        return dataclasses.replace(self, n_ctrl=int(min(max(shape[0] + shape[1], 16), 512)))

    @property
    def n_spans(self) -> int:
        """``M - 3`` (after :meth:`resolved`)."""
        if self.n_ctrl is None:
            raise ParameterError("SmoothConfig.n_ctrl is None: call .resolved(grid.shape)")
        return self.n_ctrl - 3

    @property
    def n_points(self) -> int:
        """Number of returned samples, ``(M - 3) * verify_per_span + 1`` (after
        :meth:`resolved`)."""
        return self.n_spans * self.verify_per_span + 1


# ==================================================================== result types
class SmoothResult(NamedTuple):
    """The result of :func:`smooth` for one path (fields gain a leading ``[P]`` axis in
    :func:`smooth_population`)."""

    control: jax.Array
    """float32[M, 2]: the optimised control points (kept even when ``used_fallback``)."""
    points: jax.Array
    """float32[N, 2]: the returned path sampled densely: the curve, or (fallback) the
    polyline with every vertex among the samples. ``N = config.n_points``."""
    length: jax.Array
    """float32: length of the returned path (sum of the chords of ``points``)."""
    max_curvature: jax.Array
    """float32: max curvature over the verification samples; for a fallback, the
    polyline's :func:`turning_curvature_bound` (its fillet surrogate)."""
    mean_curvature: jax.Array
    """float32: total absolute turning / length (``integral |kappa| ds / length``); for a
    polyline, the sum of its turning angles / length (exact in the distributional sense)."""
    min_clearance: jax.Array
    """float32: distance from the returned path to the nearest blocked cell or the map's
    outside. Below 1 cell: exact distances of the dense samples and, where clearance is
    tight, of the refined sub-chords (which follow a curve to within ~1e-4), so within
    a few 1e-3 of the truth; 1 and above: from the distance field (bilinear)."""
    used_fallback: jax.Array
    """bool: True when the curve could not be certified clear and the polyline is returned."""
    clear: jax.Array
    """bool: the returned path is clear (curve: certified clearance ``> tol``; polyline:
    exact feasibility under the grid's corner rule)."""
    curvature_bound: jax.Array
    """float32: the polyline's :func:`turning_curvature_bound`."""
    polyline_length: jax.Array
    """float32: the input polyline's length."""
    loss: jax.Array
    """float32: the final value of the objective."""


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


# ================================================================= distance field
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
    ``O(upsample^2 H W (H + W))``, once per grid); :func:`smooth` interpolates them
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


def _field_at(field: DistanceField, p: jax.Array) -> jax.Array:
    """Bilinear interpolation of the signed distance at points ``p[..., 2]``."""
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


# ===================================================================== B-spline
@functools.lru_cache(maxsize=32)
def _span_matrices(n_ctrl: int) -> np.ndarray:
    """``float32[T, 4, 4]``: span s is ``C(s + u) = sum_d u^d (A[s] @ P[s:s+4])[d]``.

    Clamped uniform cubic B-spline, knots ``0,0,0,0,1,...,T-1,T,T,T,T``; the power-basis
    coefficients are fitted exactly (in float64) to Cox-de Boor values at 4 points.
    """
    t_spans = n_ctrl - 3
    knots = np.concatenate([np.zeros(3), np.arange(t_spans + 1), np.full(3, t_spans)]).astype(
        np.float64
    )

    def basis(t: float) -> np.ndarray:
        n = len(knots) - 1
        b = np.array([1.0 if knots[i] <= t < knots[i + 1] else 0.0 for i in range(n)])
        for k in range(1, 4):
            nb = np.zeros(n - k)
            for i in range(n - k):
                left = knots[i + k] - knots[i]
                right = knots[i + k + 1] - knots[i + 1]
                if left > 0:
                    nb[i] += (t - knots[i]) / left * b[i]
                if right > 0:
                    nb[i] += (knots[i + k + 1] - t) / right * b[i + 1]
            b = nb
        return b  # [n_ctrl]

    us = np.array([0.125, 0.375, 0.625, 0.875])
    vander = us[:, None] ** np.arange(4)[None, :]
    out = np.zeros((t_spans, 4, 4))
    for s in range(t_spans):
        vals = np.stack([basis(s + u)[s : s + 4] for u in us])  # [4 pts, 4 ctrl]
        out[s] = np.linalg.solve(vander, vals)
    return out.astype(np.float32)


def _span_coefficients(control: jax.Array) -> jax.Array:
    """``float32[T, 4, 2]`` power-basis coefficients of every span."""
    m = control.shape[0]
    a = jnp.asarray(_span_matrices(m))
    idx = np.arange(m - 3)[:, None] + np.arange(4)[None, :]
    return jnp.einsum("sdc,scx->sdx", a, control[idx])


@functools.lru_cache(maxsize=32)
def _quadrature_matrices(n_ctrl: int, per_span: int) -> np.ndarray:
    """``float32[3, T * per_span, M]``: point, C' and C'' at the span midpoint samples
    ``u = (k + 1/2) / per_span`` as dense matrices acting on the control points (the
    objective is then three small matmuls, with no gather or scatter in its gradient)."""
    a = _span_matrices(n_ctrl).astype(np.float64)  # [T, 4 powers, 4 ctrl]
    t = n_ctrl - 3
    u = (np.arange(per_span) + 0.5) / per_span
    pw = np.stack([
        np.stack([np.ones_like(u), u, u * u, u ** 3], -1),
        np.stack([np.zeros_like(u), np.ones_like(u), 2 * u, 3 * u * u], -1),
        np.stack([np.zeros_like(u), np.zeros_like(u), 2 * np.ones_like(u), 6 * u], -1),
    ])  # [3, q, 4 powers]
    out = np.zeros((3, t * per_span, n_ctrl))
    for s in range(t):
        out[:, s * per_span:(s + 1) * per_span, s:s + 4] = pw @ a[s]
    return out.astype(np.float32)


def _poly(c: jax.Array, u: jax.Array):
    """Point, first and second derivative of cubic spans ``c[..., 4, 2]`` at ``u[...]``."""
    u = u[..., None]
    p = c[..., 0, :] + u * (c[..., 1, :] + u * (c[..., 2, :] + u * c[..., 3, :]))
    d1 = c[..., 1, :] + u * (2 * c[..., 2, :] + 3 * u * c[..., 3, :])
    d2 = 2 * c[..., 2, :] + 6 * u * c[..., 3, :]
    return p, d1, d2


def _eval_grid(coef: jax.Array, per_span: int, midpoints: bool = False):
    """``(p, d1, d2)``, each ``float32[N, 2]``, at ``per_span`` equal steps per span.

    ``midpoints=False``: ``u = k / per_span`` for every span plus the curve's end,
    ``N = T * per_span + 1`` (consecutive samples bound the verification chords).
    ``midpoints=True``: ``u = (k + 1/2) / per_span``, ``N = T * per_span`` (quadrature).
    No gather: every span is evaluated at the same static ``u``.
    """
    k = np.arange(per_span, dtype=np.float32)
    u = jnp.asarray((k + 0.5) / per_span if midpoints else k / per_span)
    p, d1, d2 = _poly(coef[:, None], jnp.broadcast_to(u, (coef.shape[0], per_span)))
    out = [v.reshape(-1, 2) for v in (p, d1, d2)]
    if not midpoints:
        end = _poly(coef[-1], jnp.float32(1.0))
        out = [jnp.concatenate([v, e[None]], axis=0) for v, e in zip(out, end)]
    return tuple(out)


def resample_curve(points: np.ndarray, spacing: float = 1.0) -> np.ndarray:
    """A dense curve ``float[N, 2]`` (cells) as points every ``spacing`` along its arc,
    both ends kept: what a robot's path needs (a pose per cell or so), not the thousands
    of evaluation points the curve was certified at. Each point lies on a chord of the
    dense curve (host NumPy)."""
    pts = np.asarray(points, float)
    if len(pts) < 3 or not spacing > 0:
        return pts
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    n = max(int(np.ceil(arc[-1] / spacing)), 1)
    at = np.linspace(0.0, arc[-1], n + 1)
    return np.stack([np.interp(at, arc, pts[:, 0]), np.interp(at, arc, pts[:, 1])], axis=1)


def curve_points(control: jax.Array, per_span: int = 16) -> jax.Array:
    """``float32[(M - 3) * per_span + 1, 2]``: the clamped cubic B-spline of ``control``
    sampled at ``per_span`` equal parameter steps per span (first point =
    ``control[0]``, last = ``control[-1]``). Jittable; ``per_span`` static."""
    control = jnp.asarray(control, F32)
    p, _, _ = _eval_grid(_span_coefficients(control), per_span)
    return p.at[0].set(control[0]).at[-1].set(control[-1])


def _curvature(d1: jax.Array, d2: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(|kappa|, speed)`` from first and second derivatives."""
    cross = d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]
    speed2 = jnp.sum(d1 * d1, axis=-1)
    speed = jnp.sqrt(speed2)
    kappa = jnp.abs(cross) / jnp.maximum(speed2 * speed, 1e-12)
    return kappa, speed


# ==================================================================== polylines
def _polyline_xy(grid: Grid, cells: jax.Array, length: jax.Array):
    """``(xy float32[L, 2] re-padded with the last valid node, n int32)``."""
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
    seg_len = _norm(seg)
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
    xy, _ = _polyline_xy(grid, cells, length)
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


def _polyline_turning(xy: jax.Array) -> jax.Array:
    """Sum of the turning angles of a (possibly padded) polyline."""
    corner, cross, dot, _, _ = _corners(xy)
    return jnp.sum(jnp.where(corner, jnp.arctan2(cross, dot), 0.0))


def polyline_points(
    grid: Grid, cells: jax.Array, length: jax.Array, n_points: int
) -> jax.Array:
    """``float32[n_points, 2]``: the polyline resampled with every vertex among the samples.

    The fallback's ``points`` in :func:`smooth`, so that a fallback and a curve
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
    xy, n = _polyline_xy(grid, cells, length)
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

    The starting point of :func:`smooth`'s optimisation.

    Evenly spaced by arc length: the uniform-speed parametrisation that the bending term
    prefers anyway. (Not spacing that gives short segments extra control points, e.g. by
    ``segment length + mean segment length``: on a long path it bunches them on
    a short first or last segment, and the slow curve there forms near-cusps with
    curvatures far above the turning bound.)
    """
    xy, n = _polyline_xy(grid, cells, length)
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


# ================================================================== verification
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


def _verify(blocked, coef, per_span, refine_chords, refine_factor, tol):
    """:func:`verify_curve` on span coefficients; also returns the samples and their
    point clearances ``(verification, p, d1, d2, c)``."""
    p, d1, d2 = _eval_grid(coef, per_span)
    dt = 1.0 / per_span
    c = _point_clearance(blocked, p)
    # Curve piece between samples i, i+1: a point at arc distance s from sample i is at
    # least max(c_i - s, c_{i+1} - (A - s)) >= (c_i + c_{i+1} - A) / 2 from every obstacle,
    # A = arc length <= dt min(|C'_i|, |C'_i+1|) + dt^2 max|C''| / 2 (C'' linear on a span).
    m2 = _norm(jnp.maximum(jnp.abs(d2[:-1]), jnp.abs(d2[1:])))
    speed = _norm(d1)
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
        sp, _, s2 = _poly(coef[span][:, None], u)  # [k, R + 1, 2]
        h = dt / refine_factor
        dev = h * h / 8.0 * _norm(jnp.maximum(jnp.abs(s2[:, :-1]), jnp.abs(s2[:, 1:])))
        cc = _chord_clearance(blocked, sp[:, :-1], sp[:, 1:])
        refined = jnp.min(cc - dev, axis=1)
        lb = lb.at[worst].max(jnp.where(jnp.isfinite(refined), refined, -jnp.inf))
        capped = cc >= 1.0 - 0.5 * _norm(sp[:, 1:] - sp[:, :-1])  # nothing within reach
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
    control = jnp.asarray(control, F32)
    ver, *_ = _verify(jnp.asarray(grid.blocked, bool), _span_coefficients(control), per_span,
                      refine_chords, refine_factor, tol)
    return ver


def _polyline_clearance(blocked: jax.Array, pts: jax.Array, refine_chords: int) -> jax.Array:
    """``min(1, clearance)`` of the polyline through ``pts``: sampled, and exact on the
    ``refine_chords`` chords whose sampled lower bound is smallest (always at least one)."""
    c = _point_clearance(blocked, pts)
    chord = _norm(pts[1:] - pts[:-1])
    lb = 0.5 * (c[:-1] + c[1:] - chord)
    _, worst = jax.lax.top_k(-lb, max(1, min(refine_chords, lb.shape[0])))
    cc = _chord_clearance(blocked, pts[worst], pts[worst + 1])
    return jnp.minimum(jnp.min(c), jnp.min(cc))


def _beyond_one(field: DistanceField, pts: jax.Array, clearance: jax.Array) -> jax.Array:
    """Report values of 1 and more (the exact checks stop at 1) from the distance field."""
    far = jnp.maximum(jnp.min(_field_at(field, pts)), 1.0)
    return jnp.where(clearance >= 1.0, far, clearance)


# ================================================================== optimisation
def _objective(free: jax.Array, ends: jax.Array, origin: jax.Array, field: DistanceField,
               s0: jax.Array, cap: jax.Array, config: SmoothConfig) -> jax.Array:
    """Length + bending + clearance, curvature-cap and stall penalties (module docstring).

    ``free`` and ``ends`` are relative to ``origin`` (the start): then a straight run of
    control points along an axis has exactly zero coordinates across it and exactly zero
    gradient, instead of float32 noise that Adam would scale up to full steps.
    """
    control = jnp.concatenate([ends[:1], free, ends[1:]], axis=0)
    t = config.n_spans
    dt = 1.0 / config.samples_per_span
    q = jnp.asarray(_quadrature_matrices(config.n_ctrl, config.samples_per_span))
    p, d1, d2 = q @ control
    p = p + origin
    speed = jnp.sqrt(jnp.sum(d1 * d1, axis=-1) + 1e-12)
    length = jnp.sum(speed) * dt
    bend = (t / s0) ** 3 * jnp.sum(d2 * d2) * dt
    gap = jax.nn.relu(config.margin - _field_at(field, p))
    clear_pen = jnp.sum(gap * gap * speed) * dt
    kappa, _ = _curvature(d1, d2)
    over = jax.nn.relu(kappa - cap)
    cap_pen = jnp.sum(over * over * speed) * dt
    slow = jax.nn.relu(config.min_speed * s0 / t - speed) * (t / s0)
    speed_pen = jnp.sum(slow * slow) * dt
    return (config.w_length * length + config.w_bend * bend + config.w_clear * clear_pen
            + config.w_cap * cap_pen + config.w_speed * speed_pen)


def _split(control: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(free, ends, origin)``: interior and end control points relative to the start."""
    origin = control[0]
    rel = control - origin
    return rel[1:-1], jnp.stack([rel[0], rel[-1]]), origin


def _optimise(control0: jax.Array, field: DistanceField, s0: jax.Array, cap: jax.Array,
              config: SmoothConfig) -> jax.Array:
    """``config.steps`` Adam steps (cosine-decayed) on the interior control points."""
    free0, ends, origin = _split(control0)
    opt = optax.adam(optax.cosine_decay_schedule(config.learning_rate, max(config.steps, 1)),
                     eps=config.adam_eps)
    grad = jax.grad(_objective)

    def step(carry, _):
        free, state = carry
        upd, state = opt.update(grad(free, ends, origin, field, s0, cap, config), state, free)
        return (optax.apply_updates(free, upd), state), None

    (free, _), _ = jax.lax.scan(step, (free0, opt.init(free0)), None, length=config.steps)
    control = jnp.concatenate([ends[:1], free, ends[1:]], axis=0) + origin
    return control.at[0].set(control0[0]).at[-1].set(control0[-1])


def _smooth_one(grid: Grid, cells: jax.Array, length: jax.Array, field: DistanceField,
                config: SmoothConfig) -> SmoothResult:
    cells = jnp.asarray(cells, jnp.int32)
    config = config.resolved(grid.shape)
    if config.n_points < cells.shape[0]:
        raise ParameterError(
            f"SmoothConfig gives {config.n_points} samples, fewer than the path capacity "
            f"{cells.shape[0]}: raise n_ctrl or verify_per_span"
        )
    blocked = jnp.asarray(grid.blocked, bool)
    xy, n = _polyline_xy(grid, cells, length)
    s0 = jnp.sum(_norm(xy[1:] - xy[:-1]))
    bound = turning_curvature_bound(grid, cells, length)
    cap = jnp.minimum(config.cap_factor * bound, config.curvature_limit)

    control0 = initial_control_points(grid, cells, length, config.n_ctrl)
    s0_safe = jnp.maximum(s0, 1e-3)
    control = _optimise(control0, field, s0_safe, cap, config)
    # A straight polyline (bound 0) is already smooth: keep the straight B-spline on it
    # (optimising could only bend it, for clearance margin or from float32 noise).
    control = jnp.where(bound > 0, control, control0)
    loss = _objective(*_split(control), field, s0_safe, cap, config)

    # ---- the curve: verification, samples, length, curvature
    coef = _span_coefficients(control)
    ver, curve, d1, d2, c = _verify(blocked, coef, config.verify_per_span,
                                    config.refine_chords, config.refine_factor, config.tol)
    curve = curve.at[0].set(control[0]).at[-1].set(control[-1])
    kappa, speed = _curvature(d1, d2)
    curve_len = jnp.sum(_norm(curve[1:] - curve[:-1]))
    kmax = jnp.max(kappa)
    # integral |kappa| ds = integral |kappa| |C'| dt, left rule on the dense samples
    turning = jnp.sum((kappa * speed)[:-1]) / config.verify_per_span
    finite = jnp.all(jnp.isfinite(control)) & jnp.isfinite(kmax) & jnp.isfinite(loss)
    curve_ok = ver.clear & finite & (n >= 2)
    curve_clearance = _beyond_one(field, curve, ver.min_clearance)

    # ---- the polyline (the fallback)
    poly = polyline_points(grid, cells, length, config.n_points)
    start_free = ~blocked_at(blocked, xy[0, 0].astype(jnp.int32), xy[0, 1].astype(jnp.int32))
    poly_clear = jnp.all(segments_clear(grid, cells, n)) & start_free
    poly_clearance = _beyond_one(field, poly,
                                 _polyline_clearance(blocked, poly, config.refine_chords))
    poly_mean = _polyline_turning(xy) / jnp.maximum(s0, 1e-12)

    fb = ~curve_ok
    pick = functools.partial(jnp.where, fb)
    return SmoothResult(
        control=control,
        points=pick(poly, curve),
        length=pick(s0, curve_len).astype(F32),
        max_curvature=pick(bound, kmax).astype(F32),
        mean_curvature=pick(poly_mean, turning / jnp.maximum(curve_len, 1e-12)).astype(F32),
        min_clearance=pick(poly_clearance, curve_clearance).astype(F32),
        used_fallback=fb,
        clear=pick(poly_clear, curve_ok),
        curvature_bound=bound,
        polyline_length=s0.astype(F32),
        loss=loss.astype(F32),
    )


@functools.partial(jax.jit, static_argnames=("config",))
def smooth(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    field: DistanceField | None = None,
    config: SmoothConfig = SmoothConfig(),  # noqa: B008 - frozen, hashable
) -> SmoothResult:
    """Smooth one post-optimised waypoint path into a clear cubic B-spline (IMGA section 6).

    IMGA section 6 (future work 2) and its Table 4 BCA comparison: the GA's broken line is
    turned into a curve by optimising the control points with ``optax.adam`` on length +
    bending + a clearance penalty from :func:`distance_field`, then the curve's clearance
    is certified exactly (:func:`verify_curve`); if that fails the polyline is returned
    (``used_fallback``). See the module docstring for every design decision.

    Args:
        grid: the map (``corner_rule`` only matters for the fallback's ``clear`` flag).
        cells: ``int32[L]`` cell indices ``y * W + x`` (padding repeats the last cell).
        length: int32 number of valid nodes; the path should be feasible (clear segments).
        field: ``distance_field(grid, config.upsample)``; computed here when None (pass
            it to reuse it across calls).
        config: static :class:`SmoothConfig`.

    Returns:
        A :class:`SmoothResult`.
    """
    if field is None:
        field = distance_field(grid, config.upsample)
    # A batch of one, so that a path gets the same curve alone as in a population: the
    # unbatched kernels round differently, and 200 Adam steps amplify that to ~1e-3.
    one = _smooth_batch(grid, jnp.asarray(cells, jnp.int32)[None],
                        jnp.asarray(length, jnp.int32)[None], field, config)
    return jax.tree.map(lambda v: v[0], one)


@functools.partial(jax.jit, static_argnames=("config",))
def smooth_population(
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    field: DistanceField | None = None,
    config: SmoothConfig = SmoothConfig(),  # noqa: B008 - frozen, hashable
) -> SmoothResult:
    """:func:`smooth` for a padded population ``cells int32[P, L]``, ``length int32[P]``.

    The distance field is computed once (when not given) and shared; the paths are
    ``jax.vmap``-ed, so every field of the result gains a leading ``[P]`` axis.
    """
    if field is None:
        field = distance_field(grid, config.upsample)
    return _smooth_batch(grid, jnp.asarray(cells, jnp.int32), jnp.asarray(length, jnp.int32),
                         field, config)


def _smooth_batch(grid: Grid, cells: jax.Array, length: jax.Array, field: DistanceField,
                  config: SmoothConfig) -> SmoothResult:
    return jax.vmap(_smooth_one, in_axes=(None, 0, 0, None, None))(
        grid, cells, length, field, config
    )


# ========================================================================= plot
def plot_smooth(
    ax: Any,
    grid: Grid,
    result: SmoothResult,
    polyline: np.ndarray | Sequence[Sequence[int]] | Sequence[int] | None = None,
    *,
    show_control: bool = True,
) -> Any:
    """Draw the map, the polyline, the smoothed curve and its control polygon on ``ax``.

    For figures like IMGA's Fig. 9 (its broken line against BCA's Bezier curve).

    ``result`` is a single-path :class:`SmoothResult` (index a population result first);
    ``polyline`` is ``int[k, 2]`` ``(x, y)`` waypoints, or a 1-D sequence of cell indices,
    or None. Reuses :func:`jaxga.plot.plot_map` for the map and the polyline. The curve is
    labelled with its length, max curvature and min clearance (a fallback says so).
    Returns ``ax``.
    """

    paths = []
    if polyline is not None:
        arr = np.asarray(polyline)
        if arr.ndim == 1:
            arr = np.stack([arr % grid.width, arr // grid.width], axis=-1)
        seg = np.diff(arr.astype(float), axis=0)
        plen = float(np.sum(np.hypot(seg[:, 0], seg[:, 1]))) if len(arr) > 1 else 0.0
        paths.append(([tuple(map(int, p)) for p in arr], f"polyline ({plen:.2f})"))
    plot_map(grid, paths, ax=ax)
    pts = np.asarray(result.points, float)
    fb = bool(result.used_fallback)
    label = (
        f"{'fallback polyline' if fb else 'smooth'} ({float(result.length):.2f}, "
        f"max curvature {float(result.max_curvature):.2f}, "
        f"clearance {float(result.min_clearance):.2f})"
    )
    ax.plot(pts[:, 0], pts[:, 1], "-", lw=2.0, color="tab:red" if fb else "tab:orange",
            label=label)
    if show_control:
        c = np.asarray(result.control, float)
        ax.plot(c[:, 0], c[:, 1], "s--", ms=3, lw=0.6, color="tab:cyan", alpha=0.8,
                label="control points")
    ax.legend(loc="upper left", fontsize=7, framealpha=0.8)
    return ax
