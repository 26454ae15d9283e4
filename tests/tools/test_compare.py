"""Comparisons between presets: the statistics against scipy and hand-computed values,
``compare`` against separate ``run`` calls, the JSON layout and ``jaxga compare``."""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest
import scipy.stats

from jaxga import api
from jaxga.cli import EXIT_BAD_INPUT, EXIT_NO_PATH, main
from jaxga.compare import METRICS, compare, compare_results
from jaxga.core.errors import ParameterError
from jaxga.maps import load_map, save_map
from jaxga.stats import fisher_success, holm, mann_whitney, wilcoxon_paired
from tests import canonical

# the canonical problems (tests/canonical.py): the programs of tests/api/test_api.py
SMALL = dict(generations=canonical.GENERATIONS, init__max_tries=40)
SEEDS = canonical.SEEDS


# ---------------------------------------------------------------- statistics


def test_mann_whitney_fully_separated_samples():
    a, b = [1.0, 2.0, 3.0, 4.0, 5.0], [6.0, 7.0, 8.0, 9.0, 10.0]
    t = mann_whitney(a, b)
    assert t.statistic == 0.0 and t.a12 == 0.0 and t.rank_biserial == -1.0
    # exact two-sided p: 2 / C(10, 5)
    assert t.p_value == pytest.approx(2 / math.comb(10, 5))
    r = mann_whitney(b, a)
    assert r.statistic == 25.0 and r.a12 == 1.0 and r.rank_biserial == 1.0
    assert r.p_value == pytest.approx(t.p_value)


def test_mann_whitney_with_ties_matches_hand_count_and_scipy():
    a, b = [1.0, 2.0, 2.0, 3.0], [2.0, 3.0, 4.0]
    # pairs a > b count 1, ties count 1/2: a=2 ties one 2 (x2), a=3 beats 2 and ties 3
    u = 0 + 0.5 + 0.5 + 1.5
    t = mann_whitney(a, b)
    assert t.statistic == u
    assert t.a12 == pytest.approx(u / 12) and t.rank_biserial == pytest.approx(2 * u / 12 - 1)
    ref = scipy.stats.mannwhitneyu(a, b, alternative="two-sided")
    assert t.p_value == pytest.approx(ref.pvalue) and t.statistic == ref.statistic
    assert (t.n_a, t.n_b) == (4, 3)


def test_mann_whitney_identical_and_constant_samples_have_no_effect():
    x = [3.0, 1.0, 4.0, 1.5, 9.0]
    t = mann_whitney(x, x)
    assert t.a12 == 0.5 and t.rank_biserial == 0.0 and t.p_value == pytest.approx(1.0)
    c = mann_whitney([2.0, 2.0, 2.0], [2.0, 2.0])
    assert (c.a12, c.rank_biserial, c.p_value) == (0.5, 0.0, 1.0)


def test_mann_whitney_drops_failed_seeds_and_survives_empty_samples():
    t = mann_whitney([1.0, np.nan, 2.0], [3.0, 4.0])
    assert (t.n_a, t.n_b) == (2, 2) and t.a12 == 0.0
    e = mann_whitney([np.nan, np.nan], [1.0])
    assert e.n_a == 0 and math.isnan(e.p_value) and math.isnan(e.a12)


def test_wilcoxon_paired_matches_scipy_and_matched_pairs_rank_biserial():
    a = np.array([10.0, 12.0, 9.0, 15.0, 11.0, 14.0, 13.0])
    b = np.array([9.0, 10.0, 9.5, 11.0, 10.0, 13.5, 10.0])
    t = wilcoxon_paired(a, b)
    ref = scipy.stats.wilcoxon(a, b)
    assert t.p_value == pytest.approx(ref.pvalue)
    # differences 1, 2, -0.5, 4, 1, 0.5, 3: ranks of |d| 3.5, 5, 1.5, 7, 3.5, 1.5, 6
    assert t.statistic == pytest.approx(28 - 1.5)
    assert t.rank_biserial == pytest.approx((26.5 - 1.5) / 28)
    assert wilcoxon_paired(b, a).rank_biserial == pytest.approx(-t.rank_biserial)
    # all a larger: r = 1; pairs with a failure are dropped
    s = wilcoxon_paired([2.0, 3.0, np.nan, 5.0], [1.0, 1.0, 1.0, 1.0])
    assert s.rank_biserial == 1.0 and s.n_a == 3
    z = wilcoxon_paired([1.0, 2.0], [1.0, 2.0])
    assert z.p_value == 1.0 and z.rank_biserial == 0.0
    with pytest.raises(ParameterError):
        wilcoxon_paired([1.0, 2.0], [1.0])


def test_holm_on_known_p_values():
    p = [0.01, 0.04, 0.03, 0.005]
    # sorted: 0.005 x 4 = 0.02, 0.01 x 3 = 0.03, 0.03 x 2 = 0.06, 0.04 x 1 -> max 0.06
    np.testing.assert_allclose(holm(p), [0.03, 0.06, 0.06, 0.02])
    np.testing.assert_allclose(holm([0.5, 0.9]), [1.0, 1.0])  # clipped at 1
    out = holm([0.02, np.nan, 0.01])  # NaN stays NaN and does not count in m
    assert math.isnan(out[1]) and out[0] == pytest.approx(0.02) and out[2] == pytest.approx(0.02)
    assert holm([0.2])[0] == 0.2


def test_fisher_success_matches_scipy():
    t = fisher_success(10, 10, 3, 10)
    ref = scipy.stats.fisher_exact([[10, 0], [3, 7]])
    assert t.p_value == pytest.approx(ref.pvalue) and t.statistic == ref.statistic
    assert fisher_success(5, 5, 5, 5).p_value == 1.0


@pytest.mark.parametrize("call, words", [
    # an infinite value was dropped like a failed seed: U = 1, p = 0.4 on n = 2 where
    # scipy, keeping it, gives U = 4, p = 1 on n = 3
    (lambda: mann_whitney([1.0, 2.0, np.inf], [1.5, 2.5, 3.5]), "sample a holds inf at index 2"),
    (lambda: mann_whitney([1.0], [-np.inf]), "sample b holds -inf at index 0"),
    (lambda: wilcoxon_paired([1, 2, np.inf, 4], [2, 1, 3, 3]), "sample a holds inf"),
    (lambda: wilcoxon_paired([1.0, 2.0], [1.0]), "the same length, got 2 and 1"),
    (lambda: mann_whitney(["a", "b"], [1, 2]), "sample a must hold numbers"),
    (lambda: mann_whitney([[1, 2], [3, 4]], [1, 2, 3]), r"one-dimensional .* shape \(2, 2\)"),
    (lambda: holm([0.5, -0.1, 2.0]), r"a p-value must lie in \[0, 1\].* got -0.1"),
    (lambda: holm([np.inf]), r"a p-value must lie in \[0, 1\]"),
    (lambda: fisher_success(11, 10, 5, 10), "11 successes of 10 runs"),
    (lambda: fisher_success(3, 10, -1, 10), "-1 successes of 10 runs"),
    (lambda: fisher_success(2.5, 10, 1, 10), "whole numbers"),
])
def test_the_statistics_refuse_what_they_cannot_test(call, words):
    """Values no test can take are refused in one line (a ParameterError), never dropped
    in silence, never a negative p-value, never scipy's or numpy's own words."""
    with pytest.raises(ParameterError, match=words):
        call()


def test_numpy_counts_and_nan_p_values_still_pass():
    assert fisher_success(np.int64(3), 10, np.int32(5), 10).p_value == pytest.approx(
        scipy.stats.fisher_exact([[3, 7], [5, 5]]).pvalue)
    assert np.isnan(holm([np.nan])).all() and holm([]).shape == (0,)
    t = mann_whitney(np.array([1.0, np.nan, 3.0]), (2.0, 4.0))
    assert (t.n_a, t.n_b) == (2, 2)


# ---------------------------------------------------------------- compare()


@pytest.fixture(scope="module")
def grid():
    return load_map(canonical.MAP)


@pytest.fixture(scope="module")
def comparison(grid):
    return compare(["sga", "imga"], grid, seeds=SEEDS, **SMALL)


@pytest.mark.slow
def test_presets_as_one_comma_separated_string(comparison, grid):
    """``compare("sga,imga", ...)`` as the command line's --presets, not the letters."""
    again = compare("sga, imga", grid, seeds=SEEDS, **SMALL)
    assert list(again.results) == ["sga", "imga"]
    np.testing.assert_array_equal(again.results["imga"].cells,
                                  comparison.results["imga"].cells)


def test_a_common_key_left_out_is_reported(comparison, grid):
    """IMGA's weight ``a`` (at its preset value, so the compiled programs are reused)
    given to sga and imga: sga does not read it, runs without it, and the summary and
    the JSON say so; the results are those of the plain comparison."""
    again = compare(["sga", "imga"], grid, seeds=SEEDS, fitness__a=6.0, **SMALL)
    assert again.left_out == {"sga": ("fitness.a",), "imga": ()}
    assert "sga does not read fitness.a: left out of its runs" in again.summary()
    js = again.to_json()["presets"]
    assert js["sga"]["left_out"] == ["fitness.a"] and js["imga"]["left_out"] == []
    for name in ("sga", "imga"):
        np.testing.assert_array_equal(again.results[name].cells,
                                      comparison.results[name].cells)
    assert comparison.left_out == {"sga": (), "imga": ()}


def test_compare_gives_the_results_of_separate_runs(comparison, grid):
    for name in ("sga", "imga"):
        alone = api.run(name, grid, seeds=SEEDS, **SMALL)
        got = comparison.results[name]
        np.testing.assert_array_equal(got.success, alone.success)
        np.testing.assert_array_equal(got.cells, alone.cells)
        np.testing.assert_allclose(got.length, alone.length)
        np.testing.assert_allclose(got.raw_length, alone.raw_length)
        np.testing.assert_array_equal(got.convergence_generation,
                                      alone.convergence_generation)


def test_compare_tests_are_those_of_the_per_seed_values(comparison):
    c = comparison
    assert c.labels == ["sga", "imga"] and c.test == "mannwhitneyu"
    assert [t.metric for t in c.pairwise] == list(c.metrics)
    assert c.metrics[0] == "length"
    for t in c.pairwise:
        a, b = c.values("sga", t.metric), c.values("imga", t.metric)
        ref = scipy.stats.mannwhitneyu(a[np.isfinite(a)], b[np.isfinite(b)])
        if np.ptp(np.concatenate([a, b])) > 0:
            assert t.result.p_value == pytest.approx(ref.pvalue)
            assert t.result.a12 == pytest.approx(ref.statistic / (t.result.n_a * t.result.n_b))
        assert t.p_holm == pytest.approx(t.result.p_value)  # one pair: Holm = raw p
    rows = {r["label"]: r for r in c.preset_rows()}
    r = c.results["sga"]
    ok = r.success
    assert rows["sga"]["mean"] == pytest.approx(r.length[ok].mean())
    assert rows["sga"]["gap"] == pytest.approx(
        np.mean(r.length[ok] / r.any_angle_optimum - 1), abs=1e-6)  # api.GAP_TOLERANCE
    assert rows["sga"]["raw_gap"] == pytest.approx(
        np.mean(r.raw_length[ok] / r.optimum - 1), abs=1e-6)
    assert rows["sga"]["success_rate"] == ok.mean()
    text = c.summary()
    assert "pairwise tests on length" in text and "imga" in text
    md = c.to_markdown()
    assert "| sga | imga |" in md and "turns: p Holm / A12" in md
    assert md.count("| sga | imga |") == 2  # full table of length + compact table
    assert c.to_markdown(compact=False).count("| sga | imga |") == len(c.metrics)


def test_compare_json_layout(comparison):
    js = json.loads(json.dumps(comparison.to_json(), allow_nan=False))
    assert {"map", "corner_rule", "seeds", "optimum", "any_angle_optimum", "metric",
            "metrics", "test", "alpha", "correction", "presets", "pairwise",
            "success_tests"} <= set(js)
    assert js["seeds"] == list(range(SEEDS)) and js["correction"] == "holm"
    first = next(iter(comparison.results.values()))
    assert js["map_digest"] == first.map_digest != ""  # the cells compared on
    assert js["environment"] == first.environment != {}  # what computed them
    assert set(js["presets"]) == {"sga", "imga"}
    p = js["presets"]["imga"]
    assert {"preset", "population", "generations", "n_seeds", "n_success", "success_rate",
            "summary", "time_per_run_s", "timing", "values"} <= set(p)
    imga = comparison.results["imga"]
    assert (p["path_capacity"], p["size_class"]) == (imga.path_capacity, imga.size_class)
    assert set(p["summary"]["length"]) == {"mean", "sd", "min", "max"}
    assert all(len(v) == SEEDS for v in p["values"].values())
    assert len(js["pairwise"]) == len(js["metrics"])  # one pair per metric
    first = js["pairwise"][0]
    assert {"metric", "a", "b", "test", "statistic", "p_value", "p_holm", "a12",
            "rank_biserial", "n_a", "n_b", "median_a", "median_b"} <= set(first)
    assert len(js["success_tests"]) == 1


def test_failed_seeds_are_excluded_from_tests_and_counted_in_success(comparison):
    sga, imga = comparison.results["sga"], comparison.results["imga"]
    failing = dataclasses.replace(sga, success=np.array([True] + [False] * (SEEDS - 1)))
    third = dataclasses.replace(imga, preset="imga2")
    c = compare_results({"sga": failing, "imga": imga, "imga2": third})
    assert len(c.tests()) == 3  # three pairs
    t = next(t for t in c.tests() if (t.a, t.b) == ("sga", "imga"))
    assert (t.result.n_a, t.result.n_b) == (1, SEEDS)
    raw = [t.result.p_value for t in c.tests()]
    np.testing.assert_allclose([t.p_holm for t in c.tests()], holm(raw))
    s = next(t for t in c.success_tests if (t.a, t.b) == ("sga", "imga"))
    assert s.result.p_value == pytest.approx(
        scipy.stats.fisher_exact([[1, SEEDS - 1], [SEEDS, 0]]).pvalue)
    assert "Fisher" in c.summary()
    row = {r["label"]: r for r in c.preset_rows()}["sga"]
    assert row["n_success"] == 1 and row["mean"] == pytest.approx(sga.length[0])
    # a preset's failure reason (as jaxga.run words it) is printed and in the JSON
    why = "no feasible path found by 4 of 5 seeds; population.capacity = 3 is too small"
    c = compare_results({"sga": dataclasses.replace(failing, reason=why), "imga": imga})
    assert f"sga: {why}" in c.summary().splitlines()
    assert c.to_json()["presets"]["sga"]["reason"] == why
    assert c.to_json()["presets"]["imga"]["reason"] == ""


def test_a_preset_that_found_no_path_reads_0_of_n_without_nan(comparison):
    """Failed seeds are missing values (NaN in the Result): the tables say 0/N and leave
    the cells they cannot fill as '-', never 'nan'."""
    sga, imga = comparison.results["sga"], comparison.results["imga"]
    nan = np.full(SEEDS, np.nan)
    none = dataclasses.replace(sga, success=np.zeros(SEEDS, bool), length=nan,
                               raw_length=nan, fitness=nan, reason="no path")
    c = compare_results({"sga": none, "imga": imga})
    text, md = c.summary(), c.to_markdown()
    assert f"0/{SEEDS}" in text and "nan" not in text.lower() and "nan" not in md.lower()
    row = next(line for line in text.splitlines() if line.lstrip().startswith("sga "))
    assert row.count(" - ") >= 4  # mean, sd, min, max (and the gaps)


def test_a_success_without_a_finite_length_is_refused(comparison):
    """A seed counted a success must have a finite length: an infinite or missing one was
    left out of the tests like a failed seed while the success rate counted it (6/6 with
    a mean over 5)."""
    sga, imga = comparison.results["sga"], comparison.results["imga"]
    for bad in (np.inf, np.nan):
        length = sga.length.astype(float).copy()
        length[1] = bad
        broken = dataclasses.replace(sga, length=length)
        with pytest.raises(ParameterError, match=f"sga: seed {int(sga.seeds[1])} is counted "
                                                 f"a success with a length of {bad:g}"):
            compare_results({"sga": broken, "imga": imga})
    # a failed seed's missing length is what failure means: accepted
    failed = dataclasses.replace(sga, success=np.r_[False, sga.success[1:]],
                                 length=np.r_[np.nan, sga.length[1:]])
    compare_results({"sga": failed, "imga": imga})


def test_tests_that_could_not_be_made_are_not_counted_or_printed_as_nan(comparison):
    """Two presets without a path and one with: the length has one test of three pairs,
    and the header says so (it said Holm was over 3 pairs where it was over 1); the
    success table's odds ratio of 0/N against 0/N is '-', not 'nan'."""
    sga, imga = comparison.results["sga"], comparison.results["imga"]
    nan = np.full(SEEDS, np.nan)
    none = dataclasses.replace(sga, success=np.zeros(SEEDS, bool), length=nan,
                               raw_length=nan, fitness=nan, reason="no path")
    c = compare_results({"a": none, "b": dataclasses.replace(none, preset="b"), "imga": imga})
    made = [t for t in c.tests() if math.isfinite(t.result.p_value)]
    assert len(made) == 0 and len(c.tests()) == 3
    assert "that could be tested (length 0 of 3, raw_length 0 of 3" in c.summary()
    c = compare_results({"a": none, "imga": imga, "imga2": dataclasses.replace(imga)})
    assert "(length 1 of 3, raw_length 1 of 3" in c.summary()
    made = [t for t in c.tests() if math.isfinite(t.result.p_value)]
    assert len(made) == 1 and made[0].p_holm == made[0].result.p_value  # m = 1
    text = compare_results({"a": none, "b": dataclasses.replace(none)}).summary()
    assert "nan" not in text.lower()
    row = next(line for line in text.splitlines() if line.startswith("a ") and "0/" in line
               and line.count("0/") == 2)
    assert " - " in row
    full = compare_results({"sga": sga, "imga": imga}).summary()
    assert "Holm-corrected over the 1 pair of each metric" in full


def _without_fitness_optimum(r):
    """``r`` as a preset whose own fitness optimum is not computed (AGACD's case)."""
    return dataclasses.replace(r, fitness_optimum=math.nan)


def test_the_header_names_the_tested_pairs_of_every_metric(comparison):
    """A preset without a fitness optimum has no fitness_gap test: the header said Holm
    was over "the 3 pairs of each metric" while fitness_gap's one test was corrected over
    1 pair; each metric's count is now given."""
    sga, imga = comparison.results["sga"], comparison.results["imga"]
    c = compare_results({"sga": sga, "none": _without_fitness_optimum(imga),
                         "imga": imga}, metrics=("length", "fitness_gap"))
    made = [t for t in c.tests("fitness_gap") if math.isfinite(t.result.p_value)]
    assert len(made) == 1 and made[0].p_holm == made[0].result.p_value
    assert "(length 3 of 3, fitness_gap 1 of 3;" in c.summary()
    assert "(length 3 of 3, fitness_gap 1 of 3;" in c.to_markdown()


def test_results_of_other_seeds_are_named_per_preset(comparison):
    """compare_results of runs made apart: the header said the first preset's "N seeds"
    and the JSON's seeds were the first preset's; each preset's seeds are now recorded,
    the top-level list only when they share them."""
    sga, imga = comparison.results["sga"], comparison.results["imga"]
    other = dataclasses.replace(imga, seeds=imga.seeds + 100)
    c = compare_results({"sga": sga, "later": other})
    n = len(sga.seeds)
    assert f"presets of different seeds: sga {n}, later {n};" in c.summary()
    doc = json.loads(json.dumps(c.to_json(), allow_nan=False))
    assert doc["seeds"] is None
    assert doc["presets"]["later"]["seeds"] == [int(v) + 100 for v in imga.seeds]
    same = compare_results({"sga": sga, "imga": imga})
    assert f"{n} seeds;" in same.summary()
    assert same.to_json()["seeds"] == [int(v) for v in sga.seeds]


def test_a_paired_tests_medians_are_those_of_the_pairs_it_tested(comparison):
    """Lengths set by hand, a = (nan, nan, 10, 11, 12), b = (1, 2, 30, 31, 32): the
    Wilcoxon row's n was the 3 pairs tested but its medians were over every seed of b
    (30); they are now the tested pairs' (11, 31). Mann-Whitney keeps each sample's own
    (b: 30)."""
    sga = comparison.results["sga"]
    seeds = np.arange(5)
    base = dataclasses.replace(sga, seeds=seeds, success=np.ones(5, bool),
                               length=np.array([1.0, 2.0, 30.0, 31.0, 32.0]))
    a = dataclasses.replace(base, success=np.array([False, False, True, True, True]),
                            length=np.array([np.nan, np.nan, 10.0, 11.0, 12.0]))
    t = compare_results({"a": a, "b": base}, test="wilcoxon", metrics=("length",)).tests()[0]
    assert (t.result.n_a, t.median_a, t.median_b) == (3, 11.0, 31.0)
    mw = compare_results({"a": a, "b": base}, metrics=("length",)).tests()[0]
    assert (mw.median_a, mw.median_b) == (11.0, 30.0)


def test_an_infinite_odds_ratio_is_written_inf_not_null():
    """Fisher's odds ratio of 6/6 against 2/6 is infinite: the JSON wrote null, which
    elsewhere means "no test"."""
    from jaxga.compare import PairTest

    t = PairTest("success", "a", "b", fisher_success(6, 6, 2, 6), 0.06, 1.0, 1 / 3)
    doc = json.loads(json.dumps(t.to_json(), allow_nan=False))
    assert doc["statistic"] == "inf" and float(doc["statistic"]) == math.inf
    assert doc["p_value"] == pytest.approx(scipy.stats.fisher_exact([[6, 0], [2, 4]])[1])


def test_paired_wilcoxon_option(comparison):
    c = compare_results(comparison.results, test="wilcoxon", metrics=["raw_length"])
    assert c.metrics == ("length", "raw_length")
    for t in c.pairwise:
        a, b = c.values("sga", t.metric), c.values("imga", t.metric)
        ok = np.isfinite(a) & np.isfinite(b)
        if np.any(a[ok] != b[ok]):
            assert t.result.p_value == pytest.approx(scipy.stats.wilcoxon(a[ok], b[ok]).pvalue)
    other = dataclasses.replace(comparison.results["imga"],
                                seeds=comparison.results["imga"].seeds + 1)
    with pytest.raises(ParameterError, match="same seeds"):
        compare_results({"sga": comparison.results["sga"], "imga": other}, test="wilcoxon")


def test_compare_variants_of_one_preset_by_label(comparison, grid):
    """A mapping label -> (preset, overrides): one preset with two mutation rates, the
    paired design the Wilcoxon option is for; per-label overrides win over common ones."""
    c = compare({"sga": "sga", "sga pm 0.9": ("sga", {"mutation__probability": 0.9})},
                grid, seeds=SEEDS, test="wilcoxon", **SMALL)
    assert c.labels == ["sga", "sga pm 0.9"] and c.test == "wilcoxon"
    np.testing.assert_allclose(c.results["sga"].length, comparison.results["sga"].length)
    alone = api.run("sga", grid, seeds=SEEDS, mutation__probability=0.9, **SMALL)
    np.testing.assert_array_equal(c.results["sga pm 0.9"].cells, alone.cells)
    assert c.results["sga pm 0.9"].config["mutation.probability"] == 0.9


def test_compare_rejects_bad_requests(comparison, grid):
    with pytest.raises(ParameterError, match="unknown metric"):
        compare(["sga", "imga"], grid, seeds=2, metric="speed")
    with pytest.raises(ParameterError, match="not comparable"):
        compare_results(comparison.results, metric="fitness")
    with pytest.raises(ParameterError, match="unknown test"):
        compare_results(comparison.results, test="t-test")
    with pytest.raises(ParameterError, match="at least two"):
        compare(["sga"], grid, seeds=2)
    with pytest.raises(ParameterError, match="twice"):
        compare(["sga", "sga"], grid, seeds=2)
    with pytest.raises(ParameterError):  # unknown preset, before anything runs
        compare(["sga", "no_such_preset"], grid, seeds=2)
    with pytest.raises(ParameterError, match="presets must be a list of presets"):
        compare(3, grid, seeds=2)
    with pytest.raises(ParameterError, match="a preset to compare is a name"):
        compare([1, 2], grid, seeds=2)
    with pytest.raises(ParameterError, match="a preset to compare is a name"):
        compare({"a": ("sga", 3), "b": "imga"}, grid, seeds=2)
    assert "fitness" not in METRICS


# ---------------------------------------------------------------- jaxga compare


def _cli_args(map_file, *extra):
    return ["compare", "--presets", "sga,imga", "--map", str(map_file), "--seeds", str(SEEDS),
            "--generations", "3", "--set", "init.max_tries=40",
            "--corner-rule", "free", "--quiet", *extra]


def test_cli_compare_end_to_end(tmp_path, grid, comparison, capsys):
    map_file = save_map(grid, tmp_path / "m.ascii")
    out, png = tmp_path / "c.json", tmp_path / "c.png"
    # --start (the map's own) makes the command pass a Grid: the map keeps its name
    start = "{},{}".format(*grid.start_xy)
    assert main(_cli_args(map_file, "--json", str(out), "--plot", str(png),
                          "--start", start)) == 0
    text = capsys.readouterr().out
    assert "pairwise tests on length" in text and f"wrote {out}" in text
    js = json.loads(out.read_text())
    assert set(js["presets"]) == {"sga", "imga"} and js["metric"] == "length"
    assert js["map"] == "m" and "map m (corner rule 'free')" in text
    assert js["start"] == list(grid.start_xy) and js["goal"] == list(grid.goal_xy)
    for name in ("sga", "imga"):  # every setting of each preset's runs
        conf = js["presets"][name]["config"]
        assert conf == comparison.results[name].config.as_dict()
        assert conf["name"] == name and conf["generations"] == 3
        assert (conf["population.size"] == js["presets"][name]["population_capacity"]
                == comparison.results[name].population_capacity)
    assert "raw gap = raw length" in text  # what the gap columns measure
    # the CLI ran the same seeds as compare(): the same lengths
    for name in ("sga", "imga"):
        want = [None if not ok else x for ok, x in
                zip(comparison.results[name].success, comparison.results[name].length)]
        np.testing.assert_allclose(np.array(js["presets"][name]["values"]["length"], float),
                                   np.array(want, float))
    assert png.stat().st_size > 0


@pytest.mark.parametrize("extra, message", [
    (["--metric", "speed"], "unknown metric"),
    (["--metric", "fitness"], "not comparable"),
    (["--test", "anova"], "unknown test"),
])
def test_cli_compare_bad_options(tmp_path, grid, capsys, extra, message):
    map_file = save_map(grid, tmp_path / "m.ascii")
    assert main(_cli_args(map_file, *extra)) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err


def test_cli_compare_unknown_preset(tmp_path, grid, capsys):
    map_file = save_map(grid, tmp_path / "m.ascii")
    args = _cli_args(map_file)
    args[2] = "sga,no_such_preset"
    assert main(args) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "no_such_preset" in err and "\n" not in err


@pytest.mark.parametrize("presets", [",", "", "sga"])
def test_cli_compare_needs_two_presets_even_with_endpoints(tmp_path, grid, capsys, presets):
    map_file = save_map(grid, tmp_path / "m.ascii")
    args = _cli_args(map_file, "--start", "0,0")
    args[2] = presets
    assert main(args) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "at least two" in err and "\n" not in err


@pytest.mark.parametrize("alpha", [5, 0, 1, float("nan"), "x", True, None])
def test_a_significance_level_outside_0_1_is_refused(comparison, alpha):
    """alpha = 5 marked every test significant; NaN none; "x" failed in summary()."""
    with pytest.raises(ParameterError, match="alpha must be a number in"):
        compare_results(comparison.results, alpha=alpha)


def test_a_bad_significance_level_is_refused_before_running(monkeypatch):
    import importlib

    module = importlib.import_module("jaxga.compare")  # jaxga.compare is also the function
    monkeypatch.setattr(module, "run", lambda *a, **k: pytest.fail("a preset ran"))
    with pytest.raises(ParameterError, match="alpha must be a number in"):
        compare(["sga", "imga"], "classic_ga_gapp3_20x20", seeds=1, alpha=5)


def test_presets_under_different_corner_rules_are_refused_before_running(
        monkeypatch, tmp_path, capsys):
    """Their results could not be compared (other maps, in effect): refused before the
    first preset runs, from the API and from the command line, with --start too (which
    used to give every preset the first preset's rule)."""
    import importlib

    module = importlib.import_module("jaxga.compare")
    monkeypatch.setattr(module, "run", lambda *a, **k: pytest.fail("a preset ran"))
    with pytest.raises(ParameterError, match="different corner rules .a: free, b: strict"):
        compare({"a": "sga", "b": ("sga", {"map__corner_rule": "strict"})},
                "classic_ga_gapp3_20x20", seeds=1)
    strict = tmp_path / "strict.toml"
    strict.write_text('base = "sga"\n[map]\ncorner_rule = "strict"\n')
    for extra in ([], ["--start", "0,0"]):
        rc = main(["compare", "--presets", f"sga,{strict}", "--map",
                   "classic_ga_gapp3_20x20", "--seeds", "1", "--quiet", *extra])
        err = capsys.readouterr().err.strip()
        assert rc == EXIT_BAD_INPUT and "different corner rules" in err and "\n" not in err


def test_a_common_key_is_left_out_of_the_presets_that_do_not_read_it(monkeypatch):
    """``jaxga compare --presets sga,agacd --set crossover.probability=0.7``: sga runs
    with it, AGACD (adaptive rates) without, where it would change nothing; a common
    key that no preset reads is refused, and a preset's own override is strict."""
    import importlib

    module = importlib.import_module("jaxga.compare")
    calls = {}

    class Recorded(Exception):
        pass

    real = module.checked_call

    def fake_checked_call(preset, grid, **options):  # each preset's problem, checked once
        checked = real(preset, grid, **options)
        calls[preset] = options
        if len(calls) == 2:
            raise Recorded
        return checked

    monkeypatch.setattr(module, "checked_call", fake_checked_call)
    both = ("crossover.probability=0.7", "generations=4")
    for kw, sga, agacd in (
            ({"crossover__probability": 0.7}, {"crossover__probability": 0.7}, {}),
            ({"sets": list(both)}, {"sets": both}, {"sets": ("generations=4",)})):
        calls.clear()
        with pytest.raises(Recorded):
            compare(["sga", "agacd"], "classic_ga_gapp3_20x20", seeds=1, **kw)
        assert calls == {"sga": sga, "agacd": agacd}
    # a preset's own sets join the common ones and win over them for their keys
    calls.clear()
    with pytest.raises(Recorded):
        compare({"a": ("sga", {"sets": ["crossover.probability=0.5"]}), "b": "imga"},
                "classic_ga_gapp3_20x20", seeds=1, sets=["crossover.probability=0.6",
                                                         "mutation.probability=0.1"])
    assert calls == {"sga": {"sets": ("mutation.probability=0.1",
                                      "crossover.probability=0.5")},
                     "imga": {"sets": ("crossover.probability=0.6",
                                       "mutation.probability=0.1")}}
    # so do its generations, however either is given
    for own, common in (({"sets": ["generations=20"]}, {"generations": 10}),
                        ({"generations": 20}, {"sets": ["generations=10"]})):
        calls.clear()
        with pytest.raises(Recorded):
            compare({"a": ("sga", own), "b": "imga"}, "classic_ga_gapp3_20x20", seeds=1,
                    **common)
        assert calls["sga"] == {k: tuple(v) if k == "sets" else v for k, v in own.items()}
        assert calls["imga"] == {k: tuple(v) if k == "sets" else v for k, v in common.items()}
    with pytest.raises(ParameterError, match="sets must be 'key=value' strings"):
        compare(["sga", "imga"], "classic_ga_gapp3_20x20", seeds=1, sets=3)
    with pytest.raises(ParameterError, match="fitness.omega has no effect in any of the "
                                             "presets compared"):
        compare(["sga", "agacd"], "classic_ga_gapp3_20x20", seeds=1, fitness__omega=0.5)
    calls.clear()
    with pytest.raises(ParameterError, match="crossover.probability has no effect in 'agacd'"):
        compare({"sga": "sga", "agacd": ("agacd", {"crossover__probability": 0.7})},
                "classic_ga_gapp3_20x20", seeds=1)


@pytest.mark.parametrize("presets, message", [
    # the second preset does not read the override (AGACD's rates are adaptive)
    ({"sga": {"crossover__probability": 0.5}, "agacd": {"crossover__probability": 0.5}},
     "crossover.probability has no effect in 'agacd'"),
    # MPMGA's A island takes in 2 k migrants, more than an island of 3
    ({"sga": {}, "mpmga": {"population__size": 3, "islands__migrants": 2}},
     "islands.migrants = 2 needs 4"),
    ({"sga": {}, "mpmga": {"fitness__smoothness_floor": 0.0}}, "smoothness_floor"),
])
def test_any_presets_bad_input_is_refused_before_the_first_runs(monkeypatch, presets,
                                                                 message):
    """Every preset's configuration is checked before the first preset runs, so that a
    refusal never comes after minutes of runs of the presets listed before it."""
    import importlib

    module = importlib.import_module("jaxga.compare")
    monkeypatch.setattr(module, "run", lambda *a, **k: pytest.fail("a preset ran"))
    with pytest.raises(ParameterError, match=re.escape(message)):
        compare({k: (k, v) for k, v in presets.items()}, "classic_ga_gapp3_20x20", seeds=1)


def test_cli_compare_with_no_path_names_the_cause(tmp_path, capsys):
    walled = tmp_path / "walled.txt"
    walled.write_text("S.#.\n..#G\n")
    args = _cli_args(walled)
    assert main(args) == EXIT_NO_PATH
    err = capsys.readouterr().err.strip()
    assert "no preset found a path" in err and "unreachable" in err


def test_each_preset_runs_the_problem_checked_before_any_run(monkeypatch):
    """``compare`` checks every preset's problem before the first run and runs that
    value (:func:`jaxga.problem`), loading nothing again: ``run`` gets a Problem with the
    common options applied, and only the options that say how to run it."""
    import importlib

    import jaxga

    module = importlib.import_module("jaxga.compare")
    seen = []

    class Stop(Exception):
        pass

    def fake_run(problem, grid=None, *, seeds, **call):
        seen.append((problem, grid, seeds, call))
        raise Stop

    monkeypatch.setattr(module, "run", fake_run)
    with pytest.raises(Stop):
        compare(["sga", "imga"], "classic_ga_gapp3_20x20", seeds=3, generations=7,
                mutation__probability=0.3, size_class=False)
    (problem, grid, seeds, call), = seen
    assert isinstance(problem, jaxga.Problem) and grid is None and seeds == 3
    assert problem.config["name"] == "sga" and problem.config["generations"] == 7
    assert problem.config["mutation.probability"] == 0.3
    assert call == {"size_class": False}
