"""``jaxga.compare``: several presets on one map with the same seeds, with statistics.

``compare(presets, grid, seeds, **options) -> Comparison`` runs
every preset with :func:`jaxga.api.run` and gives, per preset, the summary table of
:meth:`Result.summary_rows` (AGACD Tables 8-9, Zhu & Pan Table 4), the success rate,
the gap of the raw path to the exact 8-connected optimum (to the any-angle optimum for
the waypoint paths of AGACD and Zhang's eq. 5, :attr:`Result.raw_gap`) and of the
post-optimised path to the any-angle optimum, and the time per run; and, between every
pair of presets, two-sided tests with effect sizes (:mod:`jaxga.stats`) on one or more
metrics, Holm-corrected over the pairs of each metric, plus Fisher's exact test on the
success rates.

Decisions recorded here (the papers leave them open):

* **Which test.** The default is the Mann-Whitney U test of independent samples. Running
  every preset with the same seeds does not make the design paired: different
  algorithms consume their random keys differently, so seed ``i`` of one preset and
  seed ``i`` of another share no random numbers and their results are not correlated
  (the seed is a label, not a shared experimental unit such as a problem instance).
  The Wilcoxon signed-rank test (``test="wilcoxon"``) is offered for designs where
  the pairing is real, e.g. the same preset with other dynamic parameters, whose runs
  with the same seed start from the same initial population (common random numbers,
  as :func:`jaxga.api.sweep` uses); it needs the same seeds in every preset.
* **Failed seeds** (no feasible path) have no length: they are excluded from the tests
  and summaries of every metric (for Wilcoxon the pair is dropped), and counted in the
  success rate, which is compared separately by Fisher's exact test.
* **Metrics.** ``length`` (post-optimised, the default), ``raw_length`` (the GA's own
  8-connected path, before post-optimisation), ``gap``, ``raw_gap``, ``fitness_gap``
  (how far each preset's best fitness is from the exact optimum of its OWN fitness,
  :mod:`jaxga.reference.fitness`; NaN for AGACD), ``turns`` and ``angle_sum`` (of the
  post-optimised path) and ``convergence_generation``. The fitness itself is not
  offered: its definition differs between presets, so fitness values of two presets are
  not comparable. Their gaps to their own optima are on one scale, with a caveat: for
  the ``1 / cost`` fitnesses the gap is the relative excess cost, for MPMGA's
  ``alpha / length + beta c / smoothness`` a ratio of fitness values.
* **Multiple comparisons.** Holm's step-down correction over the k(k-1)/2 pairs of each
  metric separately (each metric answers its own question); Fisher tests likewise.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from jaxga.api import GAPS, RUN_OPTIONS, Result, load_problem, run
from jaxga.api import json_number as _num
from jaxga.api.runs import checked_call
from jaxga.config.presets import as_sets, overridden_keys, parse_set
from jaxga.config.schema import Config
from jaxga.core.equality import MutableValueEquality
from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import Grid
from jaxga.core.own_settings import own_settings
from jaxga.engine import OFF_VALUES, unread_keys
from jaxga.stats import TwoSampleTest, fisher_success, holm, mann_whitney, wilcoxon_paired

__all__ = ["METRICS", "TESTS", "Comparison", "PairTest", "compare", "compare_results",
           "metric_values"]

GAP_NOTE = ("mean gaps over the successful seeds: raw gap = raw length (before "
            "post-optimisation) / exact 8-connected optimum - 1 (any-angle optimum for the "
            "waypoint paths of AGACD and Zhang's eq. 5); gap = post-optimised length / "
            "exact any-angle optimum - 1 (or a lower bound of it where it was not "
            "computed: the JSON's gap_basis); gap own fitness = optimum of the preset's "
            "fitness / fitness - 1")
"""What the gap columns of the per-preset table measure (printed under it)."""

METRICS = ("length", "raw_length", "gap", "raw_gap", "fitness_gap", "turns", "angle_sum",
           "convergence_generation")
TESTS = ("mannwhitneyu", "wilcoxon")
DEFAULT_METRICS = ("length", "raw_length", "turns", "convergence_generation")

PresetSpec = str | Config | tuple[str | Config, Mapping[str, Any]]


def check_alpha(alpha: Any) -> None:
    """The significance level must be a number in (0, 1): ``alpha = 5`` would mark every
    test significant, NaN none."""
    ok = (isinstance(alpha, (int, float, np.floating)) and not isinstance(alpha, bool)
          and 0 < alpha < 1)
    if not ok:
        raise ParameterError(f"alpha must be a number in (0, 1), got {alpha!r}")


def check_metric(metric: str) -> str:
    """``metric`` if it is one of :data:`METRICS`, else a :class:`ParameterError`."""
    if metric not in METRICS:
        extra = (" (fitness is not comparable between presets: each defines its own)"
                 if metric == "fitness" else "")
        raise ParameterError(f"unknown metric {metric!r}{extra}; choose from "
                             f"{', '.join(METRICS)}")
    return metric


def metric_values(result: Result, metric: str) -> np.ndarray:
    """Per-seed values of ``metric`` (float), NaN for failed seeds.

    ``metric`` is one of :data:`METRICS` or ``"fitness"`` (for plots of one preset's
    runs; not for tests between presets).
    """
    if metric != "fitness":
        check_metric(metric)
    if metric in GAPS:
        v = getattr(result, metric)
    elif metric in ("turns", "angle_sum"):
        v = result.metrics.get(metric, np.full(len(result.seeds), np.nan))
    else:
        v = getattr(result, metric)
    return np.where(result.success, np.asarray(v, float), np.nan)


@dataclasses.dataclass(frozen=True)
class PairTest:
    """One pairwise test between presets ``a`` and ``b`` on ``metric``."""

    metric: str
    a: str
    b: str
    result: TwoSampleTest
    p_holm: float
    median_a: float
    median_b: float

    def to_json(self) -> dict[str, Any]:
        """One entry of the ``pairwise`` / ``success_tests`` lists of the JSON layout. An
        infinite odds ratio (one preset never failed, the other did) is written
        ``"inf"``, which JSON has no number for; null is a value that is not a number
        (no test, or an odds ratio of 0 / 0 where both always or never failed)."""
        r = self.result
        return {"metric": self.metric, "a": self.a, "b": self.b, "test": r.test,
                "statistic": "inf" if r.statistic == math.inf else _num(r.statistic),
                "p_value": _num(r.p_value),
                "p_holm": _num(self.p_holm), "a12": _num(r.a12),
                "rank_biserial": _num(r.rank_biserial), "n_a": r.n_a, "n_b": r.n_b,
                "median_a": _num(self.median_a), "median_b": _num(self.median_b)}


def _time_per_run(r: Result) -> float:
    t = r.timing
    return (t["init_s"] + t["evolve_s"] + t["post_s"]) / max(1, len(r.seeds))


def _stats(v: np.ndarray) -> tuple[float, float, float, float]:
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (math.nan,) * 4
    return (float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else math.nan,
            float(v.min()), float(v.max()))


@dataclasses.dataclass(eq=False)
class Comparison(MutableValueEquality):
    """Results of several presets on one map, with pairwise tests (see module doc)."""

    results: dict[str, Result]
    metric: str
    metrics: tuple[str, ...]
    test: str
    alpha: float
    pairwise: list[PairTest]
    success_tests: list[PairTest]
    left_out: dict[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    """Per preset label, the common override keys that :func:`compare` left out of its
    run because the preset never reads them (they would change nothing)."""

    @property
    def labels(self) -> list[str]:
        """The preset labels, in the order given."""
        return list(self.results)

    @property
    def optimum(self) -> float:
        """The exact 8-connected optimum of the map (under its corner rule)."""
        return next(iter(self.results.values())).optimum

    @property
    def any_angle_optimum(self) -> float:
        """The exact any-angle optimum (lower bound of post-optimised lengths)."""
        return next(iter(self.results.values())).any_angle_optimum

    def values(self, label: str, metric: str | None = None) -> np.ndarray:
        """Per-seed values of ``metric`` (default the main one) for ``label``; NaN = failed.
        An unknown label is refused in one line naming the labels."""
        if not isinstance(label, str) or label not in self.results:
            raise ParameterError(f"no preset labelled {shown_value(label)} in this "
                                 f"comparison: its labels are {', '.join(self.results)}")
        return metric_values(self.results[label], metric or self.metric)

    def tests(self, metric: str | None = None) -> list[PairTest]:
        """The pairwise tests on ``metric`` (default the main one); a metric the
        comparison did not test is refused in one line naming those it did (not an empty
        list, which would read as "no pair differs")."""
        m = metric or self.metric
        if not isinstance(m, str) or m not in self.metrics:
            raise ParameterError(f"this comparison tested {', '.join(self.metrics)}, not "
                                 f"{shown_value(m)}: pass metrics=(...) to jaxga.compare "
                                 "to test another")
        return [t for t in self.pairwise if t.metric == m]

    def preset_rows(self) -> list[dict[str, Any]]:
        """Per preset: success, mean / sd / min / max of the main metric, mean gaps, s/run."""
        rows = []
        for label, r in self.results.items():
            mean, sd, lo, hi = _stats(self.values(label))
            rows.append({
                "label": label, "preset": r.preset, "n": int(len(r.seeds)),
                "n_success": int(r.success.sum()),
                "success_rate": float(r.success.mean()),
                "mean": mean, "sd": sd, "min": lo, "max": hi,
                "raw_gap": _stats(metric_values(r, "raw_gap"))[0],
                "gap": _stats(metric_values(r, "gap"))[0],
                "fitness_gap": _stats(metric_values(r, "fitness_gap"))[0],
                "time_per_run_s": _time_per_run(r),
                "population": r.population, "generations": r.generations,
            })
        return rows

    def _preset_table(self) -> tuple[list[str], list[list[str]]]:
        head = ["preset", "pop x gen", "success", f"{self.metric} mean", "sd", "min", "max",
                "raw gap", "gap", "gap own fitness", "s/run"]
        rows = [[r["label"], f"{r['population']} x {r['generations']}",
                 f"{r['n_success']}/{r['n']}", *(_number(r[k]) for k in
                                                  ("mean", "sd", "min", "max")),
                 _percent(r["raw_gap"]), _percent(r["gap"]), _percent(r["fitness_gap"]),
                 f"{r['time_per_run_s']:.3f}"]
                for r in self.preset_rows()]
        return head, rows

    def _test_table(self, metric: str) -> tuple[list[str], list[list[str]]]:
        mw = self.test == "mannwhitneyu"
        head = ["a", "b", "n a", "n b", "median a", "median b",
                "U" if mw else "W+", "p", "p Holm", "A12" if mw else "-", "r rank-biserial",
                f"p Holm < {self.alpha}"]
        rows = []
        for t in self.tests(metric):
            r = t.result
            rows.append([t.a, t.b, str(r.n_a), str(r.n_b), _number(t.median_a),
                         _number(t.median_b), _number(r.statistic, ".1f"), _p(r.p_value),
                         _p(t.p_holm), _number(r.a12, ".3f") if mw else "-",
                         _number(r.rank_biserial, "+.3f"),
                         "yes" if t.p_holm < self.alpha else "no"])
        return head, rows

    def _success_table(self) -> tuple[list[str], list[list[str]]]:
        head = ["a", "b", "success a", "success b", "odds ratio", "p", "p Holm"]
        rows = []
        for t in self.success_tests:
            ka = int(self.results[t.a].success.sum())
            kb = int(self.results[t.b].success.sum())
            rows.append([t.a, t.b, f"{ka}/{t.result.n_a}", f"{kb}/{t.result.n_b}",
                         _number(t.result.statistic, ".3g"), _p(t.result.p_value),
                         _p(t.p_holm)])
        return head, rows

    def shared_seeds(self) -> np.ndarray | None:
        """The seeds every preset ran, or None where their seeds differ
        (:func:`compare_results` of runs made apart)."""
        seeds = [np.asarray(r.seeds) for r in self.results.values()]
        return seeds[0] if all(np.array_equal(s, seeds[0]) for s in seeds) else None

    def _header(self) -> str:
        r = next(iter(self.results.values()))
        test = ("two-sided Mann-Whitney U (independent samples), A12 = P(a > b) + "
                "P(a = b)/2" if self.test == "mannwhitneyu" else
                "two-sided Wilcoxon signed-rank (paired by seed; n and medians over the "
                "pairs where both found a path, pairs of equal values carry no rank)")
        by_metric = {m: self.tests(m) for m in self.metrics}
        counts = {m: (sum(math.isfinite(t.result.p_value) for t in tests), len(tests))
                  for m, tests in by_metric.items()}
        made, total = counts[self.metric]
        pairs = f"{total} pair{'s' if total != 1 else ''}"
        if all(c == counts[self.metric] and c[0] == c[1] for c in counts.values()):
            family = f"Holm-corrected over the {pairs} of each metric"
        else:
            each = ", ".join(f"{m} {k} of {n}" for m, (k, n) in counts.items())
            family = ("Holm-corrected over the pairs of each metric that could be tested "
                      f"({each}; a pair with a preset without a path, or without the "
                      "metric, has no test)")
        shared = self.shared_seeds()
        seeds = (f"{len(shared)} seeds" if shared is not None
                 else "presets of different seeds: " + ", ".join(
                     f"{k} {len(v.seeds)}" for k, v in self.results.items()))
        return (f"map {r.map_name} (corner rule {r.corner_rule!r}), {seeds}; "
                f"optimum: 8-connected {self.optimum:.4f}, {r.any_angle_text()}\ntests: "
                f"{test}; failed seeds excluded; p {family}")

    def summary(self, verbose: bool = False) -> str:
        """Text tables: per preset, then the pairwise tests of every metric.

        ``verbose`` adds each preset's full :meth:`Result.summary`.
        """
        parts = [self._header(), _text_table(*self._preset_table()), GAP_NOTE]
        failed = [f"{label}: {r.reason}" for label, r in self.results.items() if r.reason]
        if failed:  # why a preset's seeds found no path (e.g. a capacity too small)
            parts.append("\n".join(failed))
        if any(self.left_out.values()):
            parts.append("\n".join(f"{label} does not read {', '.join(keys)}: left out of "
                                   "its runs" for label, keys in self.left_out.items()
                                   if keys))
        for m in self.metrics:
            parts.append(f"pairwise tests on {m}:\n" + _text_table(*self._test_table(m)))
        if self.all_succeeded():
            parts.append("every seed of every preset found a path (no success-rate tests)")
        else:
            parts.append("success rates (Fisher's exact test):\n"
                         + _text_table(*self._success_table()))
        if verbose:
            parts += [r.summary() for r in self.results.values()]
        return "\n\n".join(parts)

    def _compact_table(self, metrics: Sequence[str]) -> tuple[list[str], list[list[str]]]:
        mw = self.test == "mannwhitneyu"
        eff = "A12" if mw else "r"
        head = ["a", "b"] + [f"{m}: p Holm / {eff}" for m in metrics]
        by = {(t.metric, t.a, t.b): t for t in self.pairwise}
        rows = []
        for a, b in _pairs(self.labels):
            cells = []
            for m in metrics:
                t = by[(m, a, b)]
                e = t.result.a12 if mw else t.result.rank_biserial
                cells.append(f"{_p(t.p_holm)} / {_number(e, '.2f')}")
            rows.append([a, b] + cells)
        return head, rows

    def to_markdown(self, compact: bool = True) -> str:
        """The tables of :meth:`summary` as GitHub markdown (for RESULTS.md).

        With ``compact`` the main metric has the full table and the other metrics one
        table of Holm-corrected p-values and effect sizes (one row per pair).
        """
        parts = [self._header().replace("\n", "; "), _md_table(*self._preset_table()),
                 GAP_NOTE]
        parts.append(f"Pairwise tests on `{self.metric}`:\n\n"
                     + _md_table(*self._test_table(self.metric)))
        others = [m for m in self.metrics if m != self.metric]
        if compact and others:
            parts.append("Other metrics (p Holm / effect size):\n\n"
                         + _md_table(*self._compact_table(others)))
        else:
            for m in others:
                parts.append(f"Pairwise tests on `{m}`:\n\n" + _md_table(*self._test_table(m)))
        if self.all_succeeded():
            parts.append("Every seed of every preset found a path (no success-rate tests).")
        else:
            parts.append("Success rates (Fisher's exact test):\n\n"
                         + _md_table(*self._success_table()))
        return "\n\n".join(parts)

    def all_succeeded(self) -> bool:
        """True if every seed of every preset found a feasible path."""
        return all(bool(r.success.all()) for r in self.results.values())

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` layout of ``jaxga compare`` (NaN written as null). ``seeds`` is
        the seeds every preset ran (null where they differ); each preset's own are under
        ``presets``."""
        r0 = next(iter(self.results.values()))
        presets = {}
        for row in self.preset_rows():
            r = self.results[row["label"]]
            presets[row["label"]] = {
                "preset": r.preset, "population": r.population,
                "generations": r.generations, "n_seeds": row["n"],
                "fitness_optimum": _num(r.fitness_optimum),
                "n_success": row["n_success"], "success_rate": row["success_rate"],
                "reason": r.reason, "left_out": list(self.left_out.get(row["label"], ())),
                "summary": {name: {"mean": _num(m), "sd": _num(s), "min": _num(lo),
                                   "max": _num(hi)}
                            for name, m, s, lo, hi in r.summary_rows()},
                "seeds": [int(v) for v in r.seeds],
                "time_per_run_s": row["time_per_run_s"], "timing": dict(r.timing),
                "values": {m: [_num(x) for x in metric_values(r, m)] for m in self.metrics},
                "population_capacity": r.population_capacity,
                "path_capacity": r.path_capacity, "size_class": r.size_class,
                "config": None if r.config is None else r.config.as_dict(),
            }
        return {
            "map": r0.map_name, "map_digest": r0.map_digest,
            "environment": dict(getattr(r0, "environment", {})),
            "corner_rule": r0.corner_rule,
            "start": None if r0.start is None else list(r0.start),
            "goal": None if r0.goal is None else list(r0.goal),
            "seeds": (None if (shared := self.shared_seeds()) is None
                      else [int(v) for v in shared]),
            "optimum": _num(self.optimum),
            "any_angle_optimum": _num(self.any_angle_optimum), "metric": self.metric,
            "metrics": list(self.metrics), "test": self.test, "alpha": self.alpha,
            "correction": "holm", "presets": presets,
            "pairwise": [t.to_json() for t in self.pairwise],
            "success_tests": [t.to_json() for t in self.success_tests],
        }


def _percent(v: float) -> str:
    """A share as ``12.34%``; ``-`` where there is none (no seed found a path)."""
    return "-" if math.isnan(v) else f"{100 * v:.2f}%"


def _number(v: float, spec: str = ".4f") -> str:
    """``v`` formatted by ``spec``; ``-`` where there is none (no seed found a path)."""
    return "-" if math.isnan(v) else format(v, spec)


def _p(p: float) -> str:
    if not math.isfinite(p):
        return "-"
    return f"{p:.2e}" if p < 1e-3 else f"{p:.4f}"


def _text_table(head: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h)
              for i, h in enumerate(head)]
    lines = ["  ".join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in
                       enumerate(zip(head, widths, strict=True)))]
    for r in rows:
        lines.append("  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in
                               enumerate(zip(r, widths, strict=True))))
    return "\n".join(lines)


def _md_table(head: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(head) + " |",
           "|" + "|".join("---:" if i else "---" for i in range(len(head))) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def _pairs(labels: Sequence[str]) -> list[tuple[str, str]]:
    return [(a, b) for i, a in enumerate(labels) for b in labels[i + 1:]]


def compare_results(
    results: Mapping[str, Result],
    *,
    metric: str = "length",
    metrics: Sequence[str] | None = None,
    test: str = "mannwhitneyu",
    alpha: float = 0.05,
) -> Comparison:
    """Pairwise statistics of results already computed (one :class:`Result` per label).

    Args:
        results: label -> Result, all on the same map with the same corner rule (the
            optima must agree).
        metric: the main metric (preset table and the first tests).
        metrics: every metric to test (default ``metric`` then ``raw_length``, ``turns``,
            ``convergence_generation``); see :data:`METRICS`.
        test: ``"mannwhitneyu"`` (default, independent samples) or ``"wilcoxon"``
            (paired by seed; needs the same seeds in every result).
        alpha: the family-wise level the tables mark significance at (Holm).
    """
    if len(results) < 2:
        raise ParameterError(f"a comparison needs at least two presets, got {len(results)}")
    check_alpha(alpha)
    check_metric(metric)
    if test not in TESTS:
        raise ParameterError(f"unknown test {test!r}; choose from {', '.join(TESTS)}")
    if metrics is None:
        metrics = (metric,) + tuple(m for m in DEFAULT_METRICS if m != metric)
    metrics = tuple(dict.fromkeys(check_metric(m) for m in metrics))
    if metric not in metrics:
        metrics = (metric,) + metrics
    rs = list(results.values())
    # a map given as a bare Grid is named "grid" whatever it holds: its cells' digest
    # (and its size, endpoints and optimum) tell such maps apart
    keys = {(r.map_name, r.corner_rule, None if np.isnan(r.optimum) else float(r.optimum),
             r.width, r.start, r.goal, r.map_digest) for r in rs}
    if len(keys) > 1:
        raise ParameterError(
            "the results to compare are on different maps, endpoints or corner rules: "
            + "; ".join(f"{k[0]} ({k[1]}, width {k[3]}, start {k[4]}, goal {k[5]}, optimum "
                        f"{k[2]}, cells {k[6] or 'unknown'})" for k in sorted(keys, key=str)))
    if test == "wilcoxon" and any(not np.array_equal(r.seeds, rs[0].seeds) for r in rs):
        raise ParameterError("the Wilcoxon signed-rank test pairs runs by seed: every "
                             "preset must have run the same seeds")
    labels = list(results)
    pairs = _pairs(labels)
    pairwise: list[PairTest] = []
    for m in metrics:
        vals = {k: _checked_values(results[k], k, m) for k in labels}
        raw = [mann_whitney(vals[a], vals[b]) if test == "mannwhitneyu"
               else wilcoxon_paired(vals[a], vals[b]) for a, b in pairs]
        adj = holm([t.p_value for t in raw])
        pairwise += [PairTest(m, a, b, t, float(p), *_medians(vals[a], vals[b], test))
                     for (a, b), t, p in zip(pairs, raw, adj, strict=True)]
    fish = [fisher_success(int(results[a].success.sum()), len(results[a].seeds),
                           int(results[b].success.sum()), len(results[b].seeds))
            for a, b in pairs]
    adj = holm([t.p_value for t in fish])
    success_tests = [PairTest("success", a, b, t, float(p), float(results[a].success.mean()),
                              float(results[b].success.mean()))
                     for (a, b), t, p in zip(pairs, fish, adj, strict=True)]
    return Comparison(results=dict(results), metric=metric, metrics=metrics, test=test,
                      alpha=alpha, pairwise=pairwise, success_tests=success_tests)


def _checked_values(result: Result, label: str, metric: str) -> np.ndarray:
    """:func:`metric_values`, refusing a value no run can have: an infinite one, or a
    length that is not a number for a seed counted a success (the tests would leave it
    out as a failed seed while the success rate counts it)."""
    v = metric_values(result, metric)
    wrong = np.isinf(v)
    if metric in ("length", "raw_length"):
        wrong |= np.isnan(v) & np.asarray(result.success, bool)
    bad = np.flatnonzero(wrong)
    if bad.size:
        i = int(bad[0])
        raise ParameterError(
            f"{label}: seed {int(result.seeds[i])} is counted a success with a {metric} of "
            f"{v[i]:g}; a result to compare has a finite {metric} for every seed that "
            "found a path")
    return v


def _median(v: np.ndarray) -> float:
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else math.nan


def _medians(a: np.ndarray, b: np.ndarray, test: str) -> tuple[float, float]:
    """The medians a test's row shows: of each sample's seeds that found a path, or, for
    the paired test, of the pairs it tested (both seeds found a path)."""
    if test == "wilcoxon":
        both = np.isfinite(a) & np.isfinite(b)
        a, b = a[both], b[both]
    return _median(a), _median(b)


def one_corner_rule(rules: Mapping[str, str]) -> str:
    """The corner rule that every preset (label -> rule) runs under; presets under
    different rules are refused (their results could not be compared)."""
    if len(set(rules.values())) > 1:
        raise ParameterError(
            "the presets would run under different corner rules ("
            + ", ".join(f"{label}: {rule}" for label, rule in rules.items())
            + "): give one with corner_rule=... (--corner-rule)")
    return next(iter(rules.values()))


def _options_per_preset(specs, grid, common: Mapping[str, Any]
                        ) -> tuple[dict[str, dict[str, Any]], dict[str, tuple[str, ...]]]:
    """Each preset's keyword arguments for :func:`jaxga.api.run`, and the common keys
    left out of them: the common options, less the common configuration keys
    (overrides and ``sets``) that this preset never reads
    (:func:`jaxga.engine.unread_keys`; they would change nothing), then its own
    overrides, which are checked strictly by ``run``. A common key that no preset
    reads is refused, and so are presets that would run under different corner rules."""

    sets = as_sets(common.get("sets", ()))
    common_keys = overridden_keys({k: v for k, v in common.items() if k not in RUN_OPTIONS},
                                  sets)
    # generations= is a configuration key given as an option: a preset's own wins
    option_names = [k for k in RUN_OPTIONS if k != "generations"]
    out: dict[str, dict[str, Any]] = {}
    left_out: dict[str, tuple[str, ...]] = {}
    unread_by_all: dict[str, str] | None = None
    rules: dict[str, str] = {}
    for label, (preset, ov) in specs.items():
        own_sets = as_sets(ov.get("sets", ()))
        own = set(overridden_keys({k: v for k, v in ov.items() if k not in option_names},
                                  own_sets))
        # the common keys this preset does not set itself, then its own
        merged = {k: v for k, v in common.items()
                  if k in option_names or k.replace("__", ".") not in own}
        merged.update({k: v for k, v in ov.items() if k != "sets"})
        merged_sets = tuple(t for t in sets if parse_set(t)[0] not in own) + own_sets
        config, loaded, *_ = load_problem(preset, grid, merged.get("corner_rule"),
                                         merged.get("variant"), merged_sets,
                                         {k: v for k, v in merged.items() if k not in RUN_OPTIONS},
                                         merged.get("generations"), check_read=False)
        rules[label] = loaded.corner_rule
        unread = {k: why for k, why in unread_keys(config).items()
                  if k not in own and config.get(k) != OFF_VALUES.get(k, object())}
        options = {k: v for k, v in merged.items()
                   if k in RUN_OPTIONS or k.replace("__", ".") not in unread}
        options.pop("sets", None)
        read_sets = tuple(t for t in merged_sets if parse_set(t)[0] not in unread)
        if read_sets:
            options["sets"] = read_sets
        out[label] = options
        left_out[label] = tuple(k for k in dict.fromkeys(common_keys)
                                if k in unread and k not in own)
        unread_by_all = (dict(unread) if unread_by_all is None
                         else {k: v for k, v in unread_by_all.items() if k in unread})
    one_corner_rule(rules)  # compare_results would refuse them after the runs
    nowhere = [k for k in dict.fromkeys(common_keys) if k in (unread_by_all or {})]
    if nowhere:
        raise ParameterError("; ".join(f"{k} has no effect in any of the presets compared "
                                       f"(e.g. {unread_by_all[k]})" for k in nowhere))
    return out, left_out


def _normalise_presets(presets: Sequence[PresetSpec] | Mapping[str, PresetSpec]
                       ) -> dict[str, tuple[str | Config, dict[str, Any]]]:
    def spec_of(spec: Any) -> tuple[str | Config, dict[str, Any]]:
        preset, ov = spec if isinstance(spec, tuple) and len(spec) == 2 else (spec, {})
        if not isinstance(preset, (str, os.PathLike, Config)) or not isinstance(ov, Mapping):
            raise ParameterError(
                f"a preset to compare is a name, a TOML file, a Config or (preset, "
                f"overrides), got {spec!r}")
        return preset, dict(ov)

    if isinstance(presets, Mapping):
        items = [(str(label), spec_of(spec)) for label, spec in presets.items()]
    elif isinstance(presets, Sequence):
        items = []
        for p in presets:
            base, ov = spec_of(p)
            items.append((str(base["name"]) if isinstance(base, Config) else str(base),
                          (base, ov)))
    else:
        raise ParameterError(f"presets must be a list of presets, a mapping label -> "
                             f"preset or a comma-separated string, got {presets!r}")
    out: dict[str, tuple[str | Config, dict[str, Any]]] = {}
    for label, spec in items:
        if label in out:
            raise ParameterError(f"preset {label!r} given twice; use a mapping "
                                 "{label: (preset, overrides)} to compare variants")
        out[label] = spec
    return out


def split_presets(text: str) -> list[str]:
    """``"sga, imga"`` -> ``["sga", "imga"]``: a comma-separated preset list (``jaxga
    compare --presets``, or :func:`compare` given one string)."""
    return [p.strip() for p in text.split(",") if p.strip()]


def same_references(results: Mapping[str, Result]) -> dict[str, Result]:
    """``results`` measured against one reference: each preset's run computes the any-angle
    optimum within its own budget (:mod:`jaxga._runtime.references`), so where one run got it
    and another only its lower bound, every result gets the exact value, so that their
    gaps compare."""
    exact = [r for r in results.values() if math.isfinite(r.any_angle_optimum)]
    if not exact:
        return dict(results)
    best = exact[0]
    return {k: dataclasses.replace(r, any_angle_optimum=best.any_angle_optimum,
                                   any_angle_note="", lower_bound=best.lower_bound)
            for k, r in results.items()}


@own_settings
def compare(
    presets: Sequence[PresetSpec] | Mapping[str, PresetSpec] | str,
    grid: Grid | str,
    seeds: int | Sequence[int] = 30,
    *,
    metric: str = "length",
    metrics: Sequence[str] | None = None,
    test: str = "mannwhitneyu",
    alpha: float = 0.05,
    progress: Callable[[str], None] | None = None,
    **common_options: Any,
) -> Comparison:
    """Run every preset on ``grid`` with the same ``seeds`` and compare them.

    Args:
        presets: preset names / TOML files / :class:`Config`s (or one comma-separated
            string of names), or a mapping label -> preset or ``(preset, overrides)``
            to compare variants of one preset.
        grid: a :class:`Grid`, map file or built-in map name (as :func:`jaxga.api.run`).
        seeds: a count or explicit seeds, the same for every preset.
        metric: see :func:`compare_results`.
        metrics: see :func:`compare_results`.
        test: see :func:`compare_results`.
        alpha: see :func:`compare_results`.
        progress: optional callback, called with the label before each preset runs.
        common_options: passed to every :func:`jaxga.api.run` call (``generations``,
            ``corner_rule``, ``variant``, ``sets``, ``size_class``, overrides such as
            ``population__size=10``); per-preset overrides win over them. A common
            configuration key that a preset never reads (``crossover.probability`` for
            AGACD, whose rates are adaptive) is left out of that preset's run, where it
            would change nothing; one that no preset reads is refused.

    Returns:
        A :class:`Comparison` (see the module docstring for the decisions on tests,
        failed seeds and corrections). Each preset's :class:`Result` is exactly what
        :func:`jaxga.api.run` returns for it with the common options (less the keys it
        does not read, :attr:`Comparison.left_out`) and its own overrides.
    """
    check_alpha(alpha)
    check_metric(metric)
    for m in metrics or ():
        check_metric(m)
    if test not in TESTS:
        raise ParameterError(f"unknown test {test!r}; choose from {', '.join(TESTS)}")
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable (label), got {progress!r}")
    if isinstance(presets, str):  # "sga,imga", as on the command line
        presets = split_presets(presets)
    specs = _normalise_presets(presets)
    if len(specs) < 2:
        raise ParameterError(f"a comparison needs at least two presets, got {len(specs)}")
    options, left_out = _options_per_preset(specs, grid, common_options)
    # each preset's problem loaded and checked once: bad input fails before anything runs
    calls = {label: checked_call(preset, grid, **options[label])
             for label, (preset, _) in specs.items()}
    results = {}
    for label, (problem, call) in calls.items():
        if progress is not None:
            progress(label)
        results[label] = run(problem, seeds=seeds, **call)
    comparison = compare_results(same_references(results), metric=metric, metrics=metrics,
                                 test=test, alpha=alpha)
    return dataclasses.replace(comparison, left_out=left_out)
