"""The analysis of a DOE: per-seed responses and point means, the linear prediction fitted by
least squares (AGACD eq. 30), AGACD's contrast coefficients (eq. 31), main effects and the
predicted best coded combination.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from jaxga.core.errors import ParameterError

# ----------------------------------------------------------------------------- analysis

RESPONSE_ALIASES: dict[str, str] = {"angle_sum": "smoothness"}
"""Other names of a response: ``angle_sum`` is what :func:`jaxga.run`'s summary and
``jaxga compare`` call the smoothness (AGACD eq. 10-17)."""


RESPONSES: dict[str, str] = {
    "fitness": "max",
    "success": "max",
    "length": "min",
    "raw_length": "min",
    "convergence_generation": "min",
    "turns": "min",
    "smoothness": "min",
}
"""Responses a DOE can optimise, with their default direction."""


def seed_responses(result: Any) -> dict[str, np.ndarray]:
    """Every response of every seed of a :class:`jaxga.api.Result` (float arrays).

    ``fitness`` of a failed seed is 0 and ``success`` is 0/1; the length-like responses
    are NaN for failed seeds (see :mod:`jaxga.doe`).
    """
    ok = np.asarray(result.success, bool)

    def only_ok(v) -> np.ndarray:
        return np.where(ok, np.asarray(v, float), np.nan)

    metrics = result.metrics or {}
    nan = np.full(ok.shape, np.nan)
    return {
        "fitness": np.where(ok, np.asarray(result.fitness, float), 0.0),
        "success": ok.astype(float),
        "length": only_ok(result.length),
        "raw_length": only_ok(result.raw_length),
        "convergence_generation": only_ok(result.convergence_generation),
        "turns": only_ok(metrics.get("turns", nan)),
        "smoothness": only_ok(metrics.get("angle_sum", nan)),
    }


def point_means(responses: np.ndarray) -> np.ndarray:
    """Mean over the seeds of each point, ignoring NaN (failed seeds of a length-like
    response); NaN for a point without any value."""
    r = np.asarray(responses, float)
    n = np.sum(~np.isnan(r), axis=1)
    s = np.nansum(r, axis=1)
    return np.where(n > 0, s / np.maximum(n, 1), np.nan)


def fit_linear(coded: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares ``[X0, X1, ..., Xk]`` of ``y = X0 + sum_i Xi * F_i`` (AGACD eq. 30)
    over the rows with a finite ``y`` (``numpy.linalg.lstsq``).

    Raises :class:`ParameterError` when the remaining rows do not determine the
    coefficients (fewer rows than coefficients, or a rank-deficient design)."""
    coded = np.asarray(coded, float)
    y = np.asarray(y, float)
    keep = np.isfinite(y)
    X = np.column_stack([np.ones(int(keep.sum())), coded[keep]])
    if X.shape[0] < X.shape[1]:
        raise ParameterError(
            f"only {X.shape[0]} design points have a response, too few to fit "
            f"{X.shape[1]} coefficients")
    coef, _, rank, _ = np.linalg.lstsq(X, y[keep], rcond=None)
    if rank < X.shape[1]:
        raise ParameterError(
            "the design points with a response do not determine the linear fit "
            f"(rank {rank} < {X.shape[1]})")
    return coef


def contrast_coefficients(coded: np.ndarray, y: np.ndarray) -> np.ndarray:
    """AGACD's own estimate (its Table 5, last row): ``X0 = mean(y)``,
    ``Xi = mean(F_i * y)``. Not least squares: see :mod:`jaxga.doe`. The contrasts
    average over every point, so a point without a response (NaN: all its seeds failed)
    is refused rather than turning every coefficient into NaN; :func:`fit_linear` leaves
    such points out."""
    coded = np.asarray(coded, float)
    y = np.asarray(y, float)
    missing = np.flatnonzero(~np.isfinite(y))
    if missing.size:
        raise ParameterError(
            f"design point {int(missing[0])} has no response ({y[missing[0]]:g}): AGACD's "
            "contrasts average over every point; fit_linear leaves such points out")
    return np.concatenate([[y.mean()], (coded * y[:, None]).mean(axis=0)])


def main_effects(coded: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``[k, 3]``: mean of the point means at coded level -1, 0, 1 of each factor
    (points without a mean left out; NaN for a level without points)."""
    coded = np.asarray(coded)
    y = np.asarray(y, float)
    out = np.full((coded.shape[1], 3), np.nan)
    for i in range(coded.shape[1]):
        for j, level in enumerate((-1, 0, 1)):
            v = y[(coded[:, i] == level) & np.isfinite(y)]
            if v.size:
                out[i, j] = v.mean()
    return out


def predicted_best(coef: np.ndarray, direction: str) -> tuple[np.ndarray, float]:
    """The coded combination that maximises (``"max"``) or minimises (``"min"``) the
    fitted linear prediction, and its predicted value (AGACD: eq. 31 is maximal at
    X1 = X2 = X4 = X5 = 1, X3 = -1, predicted 0.28995)."""
    if direction not in ("max", "min"):
        raise ParameterError(f"direction must be 'max' or 'min', got {direction!r}")
    sign = 1.0 if direction == "max" else -1.0
    slopes = np.asarray(coef[1:], float)
    # round-off zeros (an exactly flat factor fits as +-1e-18) count as zero
    zero = np.abs(slopes) <= 1e-10 * max(float(np.abs(coef).max()), 1e-300)
    best = np.where(zero, 0.0, np.sign(slopes) * sign).astype(np.int8)
    return best, float(coef[0] + np.dot(slopes, best))
