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
statistics and p-value, never an exception.

:mod:`scipy.stats` is imported by the functions that use it, not with the module, so
that ``import jaxga`` (which imports this module through :mod:`jaxga.compare`), and with
it every ``jaxga run`` from the command line, does not pay for it (decision 016).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

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


def _clean(x: Sample) -> np.ndarray:
    x = np.asarray(x, float).ravel()
    return x[np.isfinite(x)]


def mann_whitney(a: Sample, b: Sample) -> TwoSampleTest:
    """Two-sided Mann-Whitney U test of independent samples ``a`` and ``b``.

    NaN entries (failed seeds) are dropped first. scipy chooses the exact distribution
    for small samples without ties and the normal approximation with tie correction
    otherwise (``method="auto"``). Two samples with one common value have p = 1.
    """
    import scipy.stats

    a, b = _clean(a), _clean(b)
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

    Pairs where either value is NaN (a failed seed) are dropped; zero differences are
    dropped as well (scipy's default ``zero_method="wilcox"``). The effect size is the
    matched-pairs rank-biserial correlation (W+ - W-) / (W+ + W-) of the ranks of
    ``|a - b|`` (Kerby 2014); ``statistic`` is W+, the rank sum of the pairs with a > b.
    """
    import scipy.stats

    a = np.asarray(a, float).ravel()
    b = np.asarray(b, float).ravel()
    if a.shape != b.shape:
        raise ValueError(f"paired samples need the same length, got {a.size} and {b.size}")
    ok = np.isfinite(a) & np.isfinite(b)
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
    [k_b, n_b - k_b]]``.
    """
    import scipy.stats

    table = [[int(k_a), int(n_a - k_a)], [int(k_b), int(n_b - k_b)]]
    res = scipy.stats.fisher_exact(table, alternative="two-sided")
    return TwoSampleTest("fisher", float(res.statistic), float(res.pvalue), math.nan,
                         math.nan, int(n_a), int(n_b))


def holm(p_values: Sample) -> np.ndarray:
    """Holm's (1979) step-down adjusted p-values (family-wise error rate).

    With the m p-values sorted ascending, p_(i) becomes max_{j <= i} min(1, (m - j + 1)
    p_(j)); reject where the adjusted value is <= alpha. NaN p-values (tests that could
    not be made) are left NaN and do not count in m. scipy has no Holm correction
    (``false_discovery_control`` controls the false discovery rate, a different error).
    """
    p = np.asarray(p_values, float)
    out = np.full(p.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(p))
    m = ok.size
    if m == 0:
        return out
    order = ok[np.argsort(p[ok], kind="stable")]
    scaled = np.minimum(1.0, (m - np.arange(m)) * p[order])
    out[order] = np.maximum.accumulate(scaled)
    return out
