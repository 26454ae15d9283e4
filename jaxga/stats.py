"""Two-sample tests, effect sizes and multiple-comparison correction for comparisons.

Thin wrappers over :mod:`scipy.stats` (the tests themselves are scipy's): two-sided
Mann-Whitney U with the Vargha-Delaney A12 and rank-biserial effect sizes derived from
its U statistic, the Wilcoxon signed-rank test for paired samples with the matched-pairs
rank-biserial correlation, Fisher's exact test on success counts, and Holm's step-down
correction (scipy 1.17 has only Benjamini-Hochberg / -Yekutieli in
``scipy.stats.false_discovery_control``, so Holm is implemented here).

Conventions (recorded decisions): every test is two-sided; the effect sizes are oriented
"a larger than b" (A12 = P(a > b) + P(a = b) / 2; a rank-biserial correlation of +1
means every a is larger), so for a metric to minimise (path length) A12 < 0.5 favours
``a``. A comparison with an empty sample (every seed of a preset failed) gives NaN
statistics and p-value, never an exception. A sample holds numbers, NaN for a failed
seed; an infinite value, a sample of more than one dimension or of other things than
numbers is refused (:class:`~jaxga.core.errors.ParameterError`): dropped like a failed
seed, it changed n, the statistic and p without a word.

:mod:`scipy.stats` is imported by the functions that use it, not with the module, so
that ``import jaxga`` (which imports this module through :mod:`jaxga.compare`), and with
it every ``jaxga run`` from the command line, does not pay for it (decision 016).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from jaxga.core.errors import ParameterError

Sample = Sequence[float] | np.ndarray

__all__ = ["TwoSampleTest", "fisher_success", "holm", "mann_whitney", "rank_biserial_from_a12",
           "vargha_delaney_a12", "wilcoxon_paired"]


@dataclasses.dataclass(frozen=True)
class TwoSampleTest:
    """The outcome of one two-sample test (``a`` against ``b``)."""

    test: str  # "mannwhitneyu", "wilcoxon" or "fisher"
    statistic: float  # U of a (Mann-Whitney), W+ (Wilcoxon), odds ratio (Fisher)
    p_value: float
    a12: float  # Vargha-Delaney A12 (Mann-Whitney only; NaN otherwise)
    rank_biserial: float  # rank-biserial correlation (matched-pairs for Wilcoxon)
    n_a: int
    n_b: int


def vargha_delaney_a12(u_a: float, n_a: int, n_b: int) -> float:
    """Vargha & Delaney's A12 = U_a / (n_a n_b) = P(a > b) + P(a = b) / 2.

    ``u_a`` is the Mann-Whitney U statistic of sample ``a`` as returned by
    :func:`scipy.stats.mannwhitneyu` (ties count one half). 0.5 = no effect.
    """
    if n_a == 0 or n_b == 0:
        return math.nan
    return float(u_a) / (n_a * n_b)


def rank_biserial_from_a12(a12: float) -> float:
    """Rank-biserial correlation r = 2 A12 - 1 (Kerby 2014), in [-1, 1]; 0 = no effect."""
    return 2.0 * a12 - 1.0


def _numbers(x: Sample, name: str) -> np.ndarray:
    """``x`` as a 1-D float array; other shapes and things that are not numbers refused."""
    try:
        v = np.asarray(x, float)
    except (TypeError, ValueError):
        raise ParameterError(f"sample {name} must hold numbers (NaN for a failed seed), "
                             f"got {type(x).__name__}") from None
    if v.ndim != 1:
        raise ParameterError(f"sample {name} must be one-dimensional (one value each), "
                             f"got shape {v.shape}")
    return v


def _sample(x: Sample, name: str) -> np.ndarray:
    """``x`` as a 1-D float array, NaN kept (a failed seed); an infinite value refused."""
    v = _numbers(x, name)
    bad = np.flatnonzero(np.isinf(v))
    if bad.size:
        raise ParameterError(
            f"sample {name} holds {v[bad[0]]:g} at index {bad[0]}: the tests take finite "
            "values, and NaN for a failed seed (which they leave out)")
    return v


def _clean(x: Sample, name: str) -> np.ndarray:
    v = _sample(x, name)
    return v[~np.isnan(v)]


def mann_whitney(a: Sample, b: Sample) -> TwoSampleTest:
    """Two-sided Mann-Whitney U test of independent samples ``a`` and ``b``.

    NaN entries (failed seeds) are dropped first; an infinite entry is refused. scipy
    chooses the exact distribution for small samples without ties and the normal
    approximation with tie correction otherwise (``method="auto"``). Two samples with one
    common value have p = 1.
    """
    import scipy.stats

    a, b = _clean(a, "a"), _clean(b, "b")
    if a.size == 0 or b.size == 0:
        return TwoSampleTest("mannwhitneyu", math.nan, math.nan, math.nan, math.nan,
                             int(a.size), int(b.size))
    if np.ptp(np.concatenate([a, b])) == 0:  # all equal: no evidence, scipy gives NaN
        return TwoSampleTest("mannwhitneyu", a.size * b.size / 2, 1.0, 0.5, 0.0,
                             int(a.size), int(b.size))
    res = scipy.stats.mannwhitneyu(a, b, alternative="two-sided")
    a12 = vargha_delaney_a12(res.statistic, a.size, b.size)
    return TwoSampleTest("mannwhitneyu", float(res.statistic), float(res.pvalue), a12,
                         rank_biserial_from_a12(a12), int(a.size), int(b.size))


def wilcoxon_paired(a: Sample, b: Sample) -> TwoSampleTest:
    """Two-sided Wilcoxon signed-rank test of paired samples (``a[i]`` with ``b[i]``).

    Pairs where either value is NaN (a failed seed) are dropped (an infinite value is
    refused, as are samples of different lengths); zero differences are
    dropped as well (scipy's default ``zero_method="wilcox"``). The effect size is the
    matched-pairs rank-biserial correlation (W+ - W-) / (W+ + W-) of the ranks of
    ``|a - b|`` (Kerby 2014); ``statistic`` is W+, the rank sum of the pairs with a > b.
    """
    import scipy.stats

    a, b = _sample(a, "a"), _sample(b, "b")
    if a.shape != b.shape:
        raise ParameterError(f"paired samples need the same length, got {a.size} and "
                             f"{b.size}")
    ok = ~np.isnan(a) & ~np.isnan(b)
    d = a[ok] - b[ok]
    n = int(ok.sum())
    nz = d[d != 0]
    if nz.size == 0:
        p = math.nan if n == 0 else 1.0
        r = math.nan if n == 0 else 0.0
        return TwoSampleTest("wilcoxon", 0.0, p, math.nan, r, n, n)
    ranks = scipy.stats.rankdata(np.abs(nz))
    w_plus = float(ranks[nz > 0].sum())
    w_minus = float(ranks[nz < 0].sum())
    res = scipy.stats.wilcoxon(a[ok], b[ok], alternative="two-sided")
    return TwoSampleTest("wilcoxon", w_plus, float(res.pvalue), math.nan,
                         (w_plus - w_minus) / (w_plus + w_minus), n, n)


def fisher_success(k_a: int, n_a: int, k_b: int, n_b: int) -> TwoSampleTest:
    """Fisher's exact test (two-sided) of success rates ``k_a / n_a`` vs ``k_b / n_b``.

    ``statistic`` is scipy's sample odds ratio of the table ``[[k_a, n_a - k_a],
    [k_b, n_b - k_b]]``. Counts that are not whole numbers with ``0 <= k <= n`` are
    refused.
    """
    import scipy.stats

    for k, n, name in ((k_a, n_a, "a"), (k_b, n_b, "b")):
        if not all(isinstance(c, (int, np.integer)) and not isinstance(c, (bool, np.bool_))
                   for c in (k, n)) or not 0 <= k <= n:
            raise ParameterError(f"success counts of {name}: {k!r} successes of {n!r} runs; "
                                 "Fisher's test takes whole numbers 0 <= successes <= runs")
    table = [[int(k_a), int(n_a - k_a)], [int(k_b), int(n_b - k_b)]]
    res = scipy.stats.fisher_exact(table, alternative="two-sided")
    return TwoSampleTest("fisher", float(res.statistic), float(res.pvalue), math.nan,
                         math.nan, int(n_a), int(n_b))


def holm(p_values: Sample) -> np.ndarray:
    """Holm's (1979) step-down adjusted p-values (family-wise error rate).

    With the m p-values sorted ascending, p_(i) becomes max_{j <= i} min(1, (m - j + 1)
    p_(j)); reject where the adjusted value is <= alpha. NaN p-values (tests that could
    not be made) are left NaN and do not count in m; a value outside [0, 1] is refused.
    scipy has no Holm correction
    (``false_discovery_control`` controls the false discovery rate, a different error).
    """
    p = _numbers(p_values, "of p-values")
    if np.any((p < 0) | (p > 1)):
        bad = p[(p < 0) | (p > 1)][0]
        raise ParameterError(f"a p-value must lie in [0, 1] (NaN for a test that could not "
                             f"be made), got {bad:g}")
    out = np.full(p.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(p))
    m = ok.size
    if m == 0:
        return out
    order = ok[np.argsort(p[ok], kind="stable")]
    scaled = np.minimum(1.0, (m - np.arange(m)) * p[order])
    out[order] = np.maximum.accumulate(scaled)
    return out
