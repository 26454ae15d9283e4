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
4. **Verification** (:func:`jaxga.curve_clearance.verify_curve`), independent of the
   distance field: exact distances from dense samples to the blocked squares, a rigorous
   bound between samples from the curve's derivatives, and exact chord-to-square
   distances minus the curve's deviation from the chord where clearance is tight. The
   curve is *clear* when the certified lower bound on its clearance exceeds
   ``config.tol`` (a certificate, not a sampling heuristic; ``tol`` absorbs float32
   rounding).
5. **Fallback.** If the curve cannot be certified clear (also when the path has fewer
   than two nodes or the optimisation produced non-finite values), the result is the
   polyline itself with ``used_fallback = True``; its ``clear`` flag is then the exact
   feasibility of the polyline (:func:`jaxga.core.geometry.segments_clear`, corner rule
   included). A path squeezing between two diagonally touching obstacles (legal under
   ``corner_rule="free"``) always falls back: a curve can only pass such a point with
   clearance 0.

**Turning curvature bound** (:func:`jaxga.polyline.turning_curvature_bound`): the
polyline's finite stand-in for the curvature of its corners, the curvature of its
cell-scale fillet rounding (why this one: :mod:`jaxga.polyline`). The optimiser is given
``cap_factor`` (0.9) times the bound as its soft limit; the tests check the outcome.

The modules it is built from: :mod:`jaxga.bspline` (the curve), :mod:`jaxga.polyline`
(the path, its bound and the initial control points), :mod:`jaxga.curve_clearance` (the
distance field and the verification).

Units are cells; coordinates are cell centres ``(x, y)`` with row 0 at the bottom
(docs/maps.md). Everything is float32, jittable and vmappable; :class:`SmoothConfig` is static.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from collections.abc import Sequence
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxga.bspline import norm, quadrature_matrices, span_coefficients
from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.geometry import segments_clear
from jaxga.core.grid import Grid, blocked_at
from jaxga.core.own_settings import own_settings
from jaxga.curve_clearance import (
    DistanceField,
    distance_field,
    field_at,
    polyline_clearance,
    verify_spans,
)
from jaxga.plot import plot_map
from jaxga.polyline import (
    initial_control_points,
    polyline_points,
    polyline_turning,
    polyline_xy,
    turning_curvature_bound,
)

__all__ = [
    "RESAMPLE_TOLERANCE",
    "SmoothConfig",
    "SmoothResult",
    "plot_smooth",
    "resample_curve",
    "smooth",
    "smooth_population",
]


# =========================================================================== config
@dataclasses.dataclass(frozen=True)
class SmoothConfig:
    """Static parameters of :func:`smooth` (hashable: pass it as a static argument).

    Attributes:
        n_ctrl: number of B-spline control points ``M`` (>= 4; ``M - 3`` spans), or None
            (the default) for ``H + W`` of the map, clipped to ``[16, 512]``: about one
            control point per cell of a typical path (a path across an ``H x W`` map is
            ``max(H, W)`` to ``H + W`` long). Too few stiffen the curve: more fallbacks
            and tighter clearances (e.g. 40 on a 50 x 50 map, or ``H + W`` for the
            winding paths of a maze, which are much longer than ``H + W`` cells;
            decision 044). Set it to ~1.2 x the longest path length for winding paths.
            Cost is linear in it.
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


# ====================================================================== measures
RESAMPLE_TOLERANCE = 1e-3
"""Cells: the farthest a chord of :func:`resample_curve`'s output may lie from the dense
curve it replaces, so that the written path keeps the certified curve's clearance to
within this."""


def resample_curve(points: np.ndarray, spacing: float = 1.0,
                   tolerance: float = RESAMPLE_TOLERANCE) -> np.ndarray:
    """A dense curve ``float[N, 2]`` (cells) as points at most ``spacing`` apart along its
    arc, both ends kept: what a robot's path needs (a pose per cell or so), not the
    thousands of evaluation points the curve was certified at (host NumPy).

    Each point lies on the dense curve's polyline. Where a chord between two points would
    cut a bend by more than ``tolerance`` cells (a chord of length ``h`` on a bend of
    curvature ``k`` lies up to ``h**2 k / 8`` inside it), the piece is halved along the
    arc until none does, so every chord lies within ``tolerance`` of the dense curve and
    the path keeps the curve's clearance to within that. A segment of 2 points is
    divided evenly."""
    pts = _finite_points(points, "resample_curve: points")
    if not (isinstance(spacing, numbers.Real) and math.isfinite(spacing) and spacing > 0):
        raise ParameterError(f"resample_curve: spacing must be a number > 0 (cells), got "
                             f"{shown_value(spacing)}")
    if not (isinstance(tolerance, numbers.Real) and math.isfinite(tolerance)
            and tolerance > 0):
        raise ParameterError(f"resample_curve: tolerance must be a number > 0 (cells), got "
                             f"{shown_value(tolerance)}")
    if len(pts) < 2:
        return pts
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    at = np.linspace(0.0, arc[-1], max(int(np.ceil(arc[-1] / spacing)), 1) + 1)
    for _ in range(64):  # each round halves the pieces too far from the curve
        wide = _chords_off_curve(pts, arc, at, tolerance)
        if not wide.any():
            break
        at = np.sort(np.concatenate([at, (at[:-1][wide] + at[1:][wide]) / 2]))
    return _on_arc(pts, arc, at)


def _on_arc(pts: np.ndarray, arc: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The points of the polyline ``pts`` (cumulative arc length ``arc``) at arc positions
    ``at``."""
    return np.stack([np.interp(at, arc, pts[:, 0]), np.interp(at, arc, pts[:, 1])], axis=1)


def _chords_off_curve(pts: np.ndarray, arc: np.ndarray, at: np.ndarray,
                      tolerance: float) -> np.ndarray:
    """``bool[len(at) - 1]``: the chords between the points at arc positions ``at`` that
    pass farther than ``tolerance`` from a point of the dense polyline ``pts`` between
    their ends (``arc``: its cumulative arc length)."""
    ends = _on_arc(pts, arc, at)
    inner = (arc > at[0]) & (arc < at[-1])
    piece = np.searchsorted(at, arc[inner], side="right") - 1  # the chord each lies under
    a, b, q = ends[piece], ends[piece + 1], pts[inner]
    ab = b - a
    t = np.clip(np.sum((q - a) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-300),
                0.0, 1.0)
    off = np.hypot(*(a + t[:, None] * ab - q).T)
    worst = np.zeros(len(at) - 1)
    np.maximum.at(worst, piece, off)
    return worst > tolerance


def _finite_points(points: Any, what: str) -> np.ndarray:
    """``points`` as ``float[N, 2]`` of finite values, or a one-line
    :class:`~jaxga.core.errors.ParameterError` naming ``what``."""
    try:
        pts = np.asarray(points, float)
    except (TypeError, ValueError):
        pts = None
    if pts is None or pts.ndim != 2 or pts.shape[1] != 2:
        raise ParameterError(f"{what} must be an array of [x, y] points (shape [N, 2]), got "
                             f"{shown_value(points)}")
    if not np.isfinite(pts).all():
        raise ParameterError(f"{what}: every coordinate must be finite")
    return pts


def _curvature(d1: jax.Array, d2: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(|kappa|, speed)`` from first and second derivatives."""
    cross = d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]
    speed2 = jnp.sum(d1 * d1, axis=-1)
    speed = jnp.sqrt(speed2)
    kappa = jnp.abs(cross) / jnp.maximum(speed2 * speed, 1e-12)
    return kappa, speed


def _beyond_one(field: DistanceField, pts: jax.Array, clearance: jax.Array) -> jax.Array:
    """Report values of 1 and more (the exact checks stop at 1) from the distance field."""
    far = jnp.maximum(jnp.min(field_at(field, pts)), 1.0)
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
    q = jnp.asarray(quadrature_matrices(config.n_ctrl, config.samples_per_span))
    p, d1, d2 = q @ control
    p = p + origin
    speed = jnp.sqrt(jnp.sum(d1 * d1, axis=-1) + 1e-12)
    length = jnp.sum(speed) * dt
    bend = (t / s0) ** 3 * jnp.sum(d2 * d2) * dt
    gap = jax.nn.relu(config.margin - field_at(field, p))
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
    xy, n = polyline_xy(grid, cells, length)
    s0 = jnp.sum(norm(xy[1:] - xy[:-1]))
    bound = turning_curvature_bound(grid, cells, length)
    # cap_factor x bound, where 0 x inf and inf x 0 are 0 (a cap of 0 / a straight path)
    scaled = (jnp.where(bound > 0, config.cap_factor * bound, 0.0) if config.cap_factor > 0
              else jnp.zeros_like(bound))
    cap = jnp.minimum(scaled, config.curvature_limit)

    control0 = initial_control_points(grid, cells, length, config.n_ctrl)
    s0_safe = jnp.maximum(s0, 1e-3)
    control = _optimise(control0, field, s0_safe, cap, config)
    # A straight polyline (bound 0) is already smooth: keep the straight B-spline on it
    # (optimising could only bend it, for clearance margin or from float32 noise).
    control = jnp.where(bound > 0, control, control0)
    loss = _objective(*_split(control), field, s0_safe, cap, config)

    # ---- the curve: verification, samples, length, curvature
    coef = span_coefficients(control)
    ver, curve, d1, d2, c = verify_spans(blocked, coef, config.verify_per_span,
                                    config.refine_chords, config.refine_factor, config.tol)
    curve = curve.at[0].set(control[0]).at[-1].set(control[-1])
    kappa, speed = _curvature(d1, d2)
    curve_len = jnp.sum(norm(curve[1:] - curve[:-1]))
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
                                 polyline_clearance(blocked, poly, config.refine_chords))
    poly_mean = polyline_turning(xy) / jnp.maximum(s0, 1e-12)

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
@own_settings
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
    is certified exactly (:func:`jaxga.curve_clearance.verify_curve`); if that fails the
    polyline is returned (``used_fallback``). See the module docstring for every design
    decision.

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
    cells, length = _checked_path_arrays(cells, length, batched=False)
    if field is None:
        field = distance_field(grid, config.upsample)
    # A batch of one, so that a path gets the same curve alone as in a population: the
    # unbatched kernels round differently, and 200 Adam steps amplify that to ~1e-3.
    one = _smooth_batch(grid, jnp.asarray(cells, jnp.int32)[None],
                        jnp.asarray(length, jnp.int32)[None], field, config)
    return jax.tree.map(lambda v: v[0], one)


@functools.partial(jax.jit, static_argnames=("config",))
@own_settings
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
    cells, length = _checked_path_arrays(cells, length, batched=True)
    if field is None:
        field = distance_field(grid, config.upsample)
    return _smooth_batch(grid, cells, length, field, config)


def _checked_path_arrays(cells: Any, length: Any, *, batched: bool) -> tuple[jax.Array, ...]:
    """``(cells, length)`` as int32 arrays of :func:`smooth`'s (``batched``:
    :func:`smooth_population`'s) shapes, else one :class:`ParameterError` line. Checked
    from their types alone, under ``jax.jit`` too: cell indices given as floats (NaN would
    become a cell) or as ``(x, y)`` pairs are refused, not converted."""
    name = "smooth_population" if batched else "smooth"
    want = "int32[P, L] cell indices y * W + x" if batched else "int32[L] cell indices y * W + x"
    try:
        c, n = jnp.asarray(cells), jnp.asarray(length)
    except (TypeError, ValueError) as e:
        raise ParameterError(f"{name}: cells must be {want} and length their number of "
                             f"nodes, got {shown_value(cells)} ({e})") from None
    rank = 2 if batched else 1
    if c.ndim != rank or c.shape[-1] < 1 or not jnp.issubdtype(c.dtype, jnp.integer):
        hint = ("; a Result's path(i) is (x, y) pairs: pass r.cells[i] and r.n_cells[i]"
                if c.ndim == rank + 1 and c.shape[-1] == 2 else "")
        raise ParameterError(f"{name}: cells must be {want}, got {c.dtype}{list(c.shape)}"
                             f"{hint}")
    if n.ndim != rank - 1 or not jnp.issubdtype(n.dtype, jnp.integer) or (
            batched and n.shape[0] != c.shape[0]):
        raise ParameterError(f"{name}: length must be an integer "
                             f"{'array of one per path' if batched else 'scalar'}, got "
                             f"{n.dtype}{list(n.shape)}")
    c = c.astype(jnp.int32)
    if c.shape[-1] == 1:  # a one-cell path (start = goal): one padding cell, no segment
        c = jnp.concatenate([c, c], axis=-1)
    return c, n.astype(jnp.int32)


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
