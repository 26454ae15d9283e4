"""The clamped uniform cubic B-spline that :mod:`jaxga.smooth` fits to a path.

``M`` control points ``P`` give ``T = M - 3`` spans, parameter ``t`` in ``[0, T]``, knots
``0,0,0,0,1,...,T-1,T,T,T,T`` (clamped: the curve interpolates ``P[0]`` and ``P[M-1]``).
Each span is converted once (float64) to a cubic polynomial in the power basis
(:func:`span_coefficients`), so points and derivatives anywhere are a few multiply-adds
(:func:`eval_spans`, :func:`eval_grid`), and the samples of the smoothing objective are
static matrices times ``P`` (:func:`quadrature_matrices`). Why this curve (C2, local,
convex hull, fixed ends): :mod:`jaxga.smooth`, "Curve". Units are cells; float32,
jittable and vmappable.
"""

from __future__ import annotations

import functools
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core.dtypes import F32
from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value

__all__ = [
    "control_points",
    "curve_points",
    "eval_grid",
    "eval_spans",
    "norm",
    "quadrature_matrices",
    "span_coefficients",
    "steps_per_span",
]


def norm(v: jax.Array) -> jax.Array:
    """Euclidean norm over the last axis: the lengths of chords, segments and derivative
    vectors wherever the smoothing measures a curve or a polyline."""
    return jnp.sqrt(jnp.sum(v * v, axis=-1))


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

    def basis(t: float, s: int) -> np.ndarray:
        """Cox-de Boor's values of the basis functions ``s .. s + 3`` at ``t`` in span
        ``s`` (the only ones not zero there): the recurrence over the indices that feed
        them (degree 0: ``s .. s + 6``), each value computed as over all of them."""
        b = np.array([1.0 if knots[i] <= t < knots[i + 1] else 0.0 for i in range(s, s + 7)])
        for k in range(1, 4):
            nb = np.zeros(len(b) - 1)
            for j in range(len(b) - 1):
                i = s + j
                left = knots[i + k] - knots[i]
                right = knots[i + k + 1] - knots[i + 1]
                if left > 0:
                    nb[j] += (t - knots[i]) / left * b[j]
                if right > 0:
                    nb[j] += (knots[i + k + 1] - t) / right * b[j + 1]
            b = nb
        return b  # [4]: functions s .. s + 3

    us = np.array([0.125, 0.375, 0.625, 0.875])
    vander = us[:, None] ** np.arange(4)[None, :]
    out = np.zeros((t_spans, 4, 4))
    for s in range(t_spans):
        vals = np.stack([basis(s + u, s) for u in us])  # [4 pts, 4 ctrl]
        out[s] = np.linalg.solve(vander, vals)
    return out.astype(np.float32)


def span_coefficients(control: jax.Array) -> jax.Array:
    """``float32[T, 4, 2]`` power-basis coefficients of every span: the curve of ``control``
    in the form that :func:`eval_spans` evaluates with a few multiply-adds."""
    m = control.shape[0]
    a = jnp.asarray(_span_matrices(m))
    idx = np.arange(m - 3)[:, None] + np.arange(4)[None, :]
    return jnp.einsum("sdc,scx->sdx", a, control[idx])


@functools.lru_cache(maxsize=32)
def quadrature_matrices(n_ctrl: int, per_span: int) -> np.ndarray:
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


def eval_spans(c: jax.Array, u: jax.Array):
    """Point, first and second derivative of cubic spans ``c[..., 4, 2]`` at ``u[...]``
    (Horner's scheme on the power basis of :func:`span_coefficients`): what the
    verification and the samples of a curve are computed from."""
    u = u[..., None]
    p = c[..., 0, :] + u * (c[..., 1, :] + u * (c[..., 2, :] + u * c[..., 3, :]))
    d1 = c[..., 1, :] + u * (2 * c[..., 2, :] + 3 * u * c[..., 3, :])
    d2 = 2 * c[..., 2, :] + 6 * u * c[..., 3, :]
    return p, d1, d2


def eval_grid(coef: jax.Array, per_span: int, midpoints: bool = False):
    """``(p, d1, d2)``, each ``float32[N, 2]``, at ``per_span`` equal steps per span.

    ``midpoints=False``: ``u = k / per_span`` for every span plus the curve's end,
    ``N = T * per_span + 1`` (consecutive samples bound the verification chords).
    ``midpoints=True``: ``u = (k + 1/2) / per_span``, ``N = T * per_span`` (quadrature).
    No gather: every span is evaluated at the same static ``u``.
    """
    k = np.arange(per_span, dtype=np.float32)
    u = jnp.asarray((k + 0.5) / per_span if midpoints else k / per_span)
    p, d1, d2 = eval_spans(coef[:, None], jnp.broadcast_to(u, (coef.shape[0], per_span)))
    out = [v.reshape(-1, 2) for v in (p, d1, d2)]
    if not midpoints:
        end = eval_spans(coef[-1], jnp.float32(1.0))
        out = [jnp.concatenate([v, e[None]], axis=0) for v, e in zip(out, end)]
    return tuple(out)


def control_points(control: Any, what: str) -> jax.Array:
    """``control`` as ``float32[M, 2]`` with ``M >= 4`` (a clamped cubic B-spline has
    ``M - 3`` spans), or a one-line :class:`~jaxga.core.errors.ParameterError` naming
    ``what``; checked from the shape alone, so it works under ``jax.jit``."""
    shape = np.shape(control) if hasattr(control, "shape") else None
    if shape is None:
        try:
            shape = np.shape(np.asarray(control, float))
        except (TypeError, ValueError):
            shape = None
    if shape is None or len(shape) != 2 or shape[1] != 2 or shape[0] < 4:
        raise ParameterError(f"{what}: control points must have shape [M, 2] with M >= 4 "
                             f"(a cubic B-spline), got {shown_value(control)}")
    return jnp.asarray(control, F32)


def steps_per_span(value: Any, what: str) -> int:
    """A static count of samples (or sub-chords) per span: an integer >= 1, or a
    one-line :class:`~jaxga.core.errors.ParameterError` naming ``what``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ParameterError(f"{what} must be an integer >= 1, got {shown_value(value)}")
    return int(value)


def curve_points(control: jax.Array, per_span: int = 16) -> jax.Array:
    """``float32[(M - 3) * per_span + 1, 2]``: the clamped cubic B-spline of ``control``
    sampled at ``per_span`` equal parameter steps per span (first point =
    ``control[0]``, last = ``control[-1]``). Jittable; ``per_span`` static."""
    control = control_points(control, "curve_points")
    per_span = steps_per_span(per_span, "curve_points: per_span")
    p, _, _ = eval_grid(span_coefficients(control), per_span)
    return p.at[0].set(control[0]).at[-1].set(control[-1])
