"""``jaxga.doe``: designs, AGACD Tables 4-5 and eq. 31, the fit, the sweep, checkpoints, CLI."""

from __future__ import annotations

import itertools
import json
import os
import re
import shutil
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

import jaxga
from jaxga.cli import EXIT_BAD_INPUT, EXIT_NO_PATH, main
from jaxga.config.presets import load_preset
from jaxga.core.errors import NoPathError, ParameterError
from jaxga.doe import (
    AGACD_TABLE3,
    AGACD_TABLE4,
    L9,
    L18,
    L27,
    Factor,
    check_factors,
    contrast_coefficients,
    design_array,
    design_points,
    fit_linear,
    main_effects,
    predicted_best,
    run_doe,
)

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT.parent / "shared" / "papers" / "001_66b815cfd6d0fbaa.txt"

# AGACD Table 4 as printed: run no., real values (population, pc_low, pc_high, pm_low,
# pm_high), coded levels.
PAPER_TABLE4 = [
    (1, (40, 0.55, 0.7, 0.05, 0.25), (-1, -1, -1, -1, 0)),
    (2, (40, 0.6, 0.75, 0.1, 0.3), (-1, 0, 0, 0, 1)),
    (3, (40, 0.65, 0.8, 0.15, 0.2), (-1, 1, 1, 1, -1)),
    (4, (50, 0.55, 0.75, 0.15, 0.3), (0, -1, 0, 1, 1)),
    (5, (50, 0.6, 0.8, 0.05, 0.2), (0, 0, 1, -1, -1)),
    (6, (50, 0.65, 0.7, 0.1, 0.25), (0, 1, -1, 0, 0)),
    (7, (60, 0.55, 0.8, 0.1, 0.2), (1, -1, 1, 0, -1)),
    (8, (60, 0.6, 0.7, 0.15, 0.25), (1, 0, -1, 1, 0)),
    (9, (60, 0.65, 0.75, 0.05, 0.3), (1, 1, 0, -1, 1)),
]
# AGACD Table 5: the five trials of each run of Table 4 (fitness).
PAPER_TABLE5 = np.array([
    [0.1386, 0.2398, 0.2551, 0.2132, 0.2398],
    [0.2398, 0.2398, 0.2336, 0.2286, 0.2169],
    [0.2582, 0.2337, 0.2378, 0.2337, 0.2132],
    [0.2398, 0.2398, 0.2336, 0.2804, 0.4392],
    [0.2398, 0.2398, 0.1364, 0.2398, 0.1364],
    [0.2857, 0.4392, 0.2112, 0.2400, 0.2398],
    [0.2219, 0.2857, 0.1386, 0.2398, 0.2378],
    [0.2398, 0.2378, 0.2398, 0.2114, 0.2398],
    [0.2398, 0.2398, 0.2378, 0.2453, 0.4692],
])
PAPER_TABLE5_AVERAGE = [0.2173, 0.2317, 0.2353, 0.2866, 0.1984, 0.2832, 0.2248, 0.2337,
                        0.2864]
PAPER_EQ31 = [0.24416, 0.00673, 0.00847, -0.00841, 0.00594, 0.01624]

# Textbook Taguchi L9 (levels 1, 2, 3).
TEXTBOOK_L9 = [[1, 1, 1, 1], [1, 2, 2, 2], [1, 3, 3, 3], [2, 1, 2, 3], [2, 2, 3, 1],
               [2, 3, 1, 2], [3, 1, 3, 2], [3, 2, 1, 3], [3, 3, 2, 1]]


# ----------------------------------------------------------------------------- designs

@pytest.mark.parametrize("array, shape", [(L9, (9, 4)), (L18, (18, 7)), (L27, (27, 13))])
def test_orthogonal_arrays_are_orthogonal(array, shape):
    assert array.shape == shape
    n = shape[0]
    for col in array.T:
        assert Counter(col.tolist()) == {-1: n // 3, 0: n // 3, 1: n // 3}
    for i, j in itertools.combinations(range(shape[1]), 2):
        pairs = Counter(zip(array[:, i].tolist(), array[:, j].tolist()))
        assert len(pairs) == 9 and set(pairs.values()) == {n // 9}, (i, j)


def test_l9_is_the_textbook_array_and_designs_take_first_columns():
    # the textbook L9 (Taguchi) has the columns in the same order up to level labels
    # of column 4: compare the partitions of the runs each column induces
    text = np.array(TEXTBOOK_L9) - 2
    for j in range(4):
        ours = {tuple(np.flatnonzero(L9[:, j] == v)) for v in (-1, 0, 1)}
        book = {tuple(np.flatnonzero(text[:, j] == v)) for v in (-1, 0, 1)}
        assert ours == book
    np.testing.assert_array_equal(L9[:, :3], text[:, :3])
    np.testing.assert_array_equal(design_array("L27", 3), L27[:, [0, 1, 4]])  # base A, B, C
    np.testing.assert_array_equal(design_array("L18", 7), L18)


def test_full_factorial_is_every_combination_once():
    full = design_array("full", 3)
    assert full.shape == (27, 3)
    assert set(map(tuple, full.tolist())) == set(itertools.product((-1, 0, 1), repeat=3))
    np.testing.assert_array_equal(full[:, 0], np.repeat([-1, 0, 1], 9))  # first slowest


def test_agacd_table4_equals_the_paper():
    np.testing.assert_array_equal(AGACD_TABLE4, [c for _, _, c in PAPER_TABLE4])
    values = design_points(AGACD_TABLE3, AGACD_TABLE4)
    for (_, real, _), point in zip(PAPER_TABLE4, values):
        assert tuple(point.values()) == pytest.approx(real, abs=1e-12)
    assert isinstance(values[0]["population.size"], int)
    # columns 1-4 are the L9; pm_high is balanced but confounded with pc_high
    np.testing.assert_array_equal(AGACD_TABLE4[:, :4], L9)
    pairs = Counter(zip(AGACD_TABLE4[:, 2].tolist(), AGACD_TABLE4[:, 4].tolist()))
    assert pairs == {(-1, 0): 3, (0, 1): 3, (1, -1): 3}


@pytest.mark.skipif(not PAPER.exists(), reason="the AGACD paper text is not available")
def test_agacd_table4_equals_the_paper_text():
    text = PAPER.read_text(encoding="utf-8")
    block = text[text.index("TABLE 4:"):text.index("TABLE 5:")]
    rows = [line.split("\t") for line in block.splitlines() if re.match(r"^[1-9]\t", line)]
    assert len(rows) == 9
    for row, (no, real, coded) in zip(rows, PAPER_TABLE4):
        assert int(row[0]) == no
        assert tuple(float(v) for v in row[1:6]) == pytest.approx(real)
        assert tuple(int(v) for v in row[6:11]) == coded


def test_agacd_eq31_from_its_table5():
    """AGACD's coefficients (eq. 31) are the contrasts mean(F * y) of its Table 5;
    maximal at (1, 1, -1, 1, 1) with 0.28995."""
    y = PAPER_TABLE5.mean(axis=1)
    np.testing.assert_allclose(y, PAPER_TABLE5_AVERAGE, atol=5e-5)
    coef = contrast_coefficients(AGACD_TABLE4, np.array(PAPER_TABLE5_AVERAGE))
    np.testing.assert_allclose(coef, PAPER_EQ31, atol=5e-6)
    best, predicted = predicted_best(coef, "max")
    np.testing.assert_array_equal(best, [1, 1, -1, 1, 1])
    assert predicted == pytest.approx(0.28995, abs=2e-5)
    # least squares on the same means: a different fit (the design is not orthogonal),
    # same best combination
    ls = fit_linear(AGACD_TABLE4, np.array(PAPER_TABLE5_AVERAGE))
    assert ls[0] == pytest.approx(PAPER_EQ31[0], abs=1e-5)
    np.testing.assert_array_equal(predicted_best(ls, "max")[0], [1, 1, -1, 1, 1])


# ----------------------------------------------------------------------------- analysis

@pytest.mark.parametrize("design, k", [("L9", 4), ("agacd-table4", 5), ("L18", 7),
                                       ("full", 2)])
def test_fit_recovers_exact_coefficients(design, k):
    coded = design_array(design, k)
    true = np.array([0.3, 0.1, -0.2, 0.05, 0.0, 0.07, -0.01, 0.02][:k + 1])
    y = true[0] + coded @ true[1:]
    np.testing.assert_allclose(fit_linear(coded, y), true, atol=1e-12)
    # the reference: normal equations
    X = np.column_stack([np.ones(len(coded)), coded])
    np.testing.assert_allclose(np.linalg.solve(X.T @ X, X.T @ y), true, atol=1e-12)


def test_fit_leaves_out_points_without_a_mean_and_refuses_too_few():
    coded = design_array("full", 2)
    y = 1.0 + 2.0 * coded[:, 0] - 0.5 * coded[:, 1]
    y[[0, 4]] = np.nan
    np.testing.assert_allclose(fit_linear(coded, y), [1.0, 2.0, -0.5], atol=1e-12)
    y[2:] = np.nan
    with pytest.raises(ParameterError, match="too few"):
        fit_linear(coded, y)
    with pytest.raises(ParameterError, match="rank"):  # both remaining rows at x1 = -1
        fit_linear(coded[:3], np.array([1.0, 2.0, 3.0]))


@pytest.mark.parametrize("direction", ["max", "min"])
def test_predicted_best_on_an_additive_response(direction):
    rng = np.random.default_rng(3)
    true = rng.normal(size=5)
    coded = design_array("L27", 4)
    coef = fit_linear(coded, true[0] + coded @ true[1:])
    best, predicted = predicted_best(coef, direction)
    every = design_array("full", 4)
    values = true[0] + every @ true[1:]
    i = int(np.argmax(values) if direction == "max" else np.argmin(values))
    np.testing.assert_array_equal(best, every[i])
    assert predicted == pytest.approx(values[i])


def test_flat_factor_goes_to_the_middle_level():
    coded = design_array("L9", 3)
    y = 0.1 + 0.02 * coded[:, 0] - 0.03 * coded[:, 2]  # factor 2 has no effect
    best, predicted = predicted_best(fit_linear(coded, y), "max")
    np.testing.assert_array_equal(best, [1, 0, -1])
    assert predicted == pytest.approx(0.15)


def test_main_effects_are_level_means():
    coded = design_array("L9", 2)
    y = np.arange(9, dtype=float)
    eff = main_effects(coded, y)
    np.testing.assert_allclose(eff[0], [1.0, 4.0, 7.0])  # rows 0-2, 3-5, 6-8
    np.testing.assert_allclose(eff[1], [3.0, 4.0, 5.0])
    y[0] = np.nan
    assert main_effects(coded, y)[0, 0] == pytest.approx(1.5)


# ----------------------------------------------------------------------------- factors

def test_factor_coded_to_real():
    f = Factor.parse("population.size=40,50,60")
    assert (f.value(-1), f.value(0), f.value(1)) == (40, 50, 60)
    assert isinstance(f.value(0), int)
    g = Factor.parse(" crossover.pc_low = 0.55, 0.6 ,0.65")
    assert g.name == "crossover.pc_low" and g.levels == (0.55, 0.6, 0.65)
    with pytest.raises(ParameterError, match="-1, 0 or 1"):
        f.value(2)


@pytest.mark.parametrize("text, words", [
    ("population.size=40,50", "three levels"),
    ("population.size=40,50,60,70", "three levels"),
    ("crossover.pc_low=0.5,x,0.7", "numbers"),
    ("crossover.pc_low=0.7,0.6,0.5", "increase"),
    ("crossover.pc_low", "NAME=LOW,MID,HIGH"),
])
def test_bad_factor_text(text, words):
    with pytest.raises(ParameterError, match=words):
        Factor.parse(text)


def test_a_factor_on_a_weight_left_at_its_default_is_accepted():
    """A fitness weight that the preset does not write down but its objective reads
    (Zhang's turning radius r at its default) is a valid factor, as in a sweep."""
    from jaxga.config.schema import Config

    mapping = load_preset("iga_zhang").as_dict()
    del mapping["fitness.r"]  # a user file that leaves r at the objective's default
    config = Config.from_mapping(mapping)
    assert config.get("fitness.r") is None
    check_factors(config, [Factor("fitness.r", (0.25, 0.5, 0.75))])


@pytest.mark.parametrize("preset, factor, words", [
    ("agacd", Factor("crossover.pc_lo", (0.1, 0.2, 0.3)), "unknown factor"),
    ("sga", Factor("crossover.pc_low", (0.1, 0.2, 0.3)), "crossover.adaptive = false"),
    ("sga", Factor("fitness.omega", (0.1, 0.2, 0.3)), "has no parameter 'omega'"),
    ("agacd", Factor("generations", (10, 20, 30)), "changes the compiled program"),
    ("agacd", Factor("mutation.radius", (1, 2, 3)), "changes the compiled program"),
    ("agacd", Factor("crossover.pc_low", (0.5, 0.9, 1.2)), "above its maximum"),
    ("agacd", Factor("population.size", (10, 15.5, 20)), "integer"),
    ("mpmga", Factor("crossover.probability", (0.5, 0.6, 0.7)), "islands.crossover"),
    ("mpmga+pc", Factor("crossover.probability", (0.5, 0.6, 0.7)), "islands.crossover"),
])
def test_factor_validation_against_the_preset(preset, factor, words):
    """A factor must be a dynamic key (or the population size) that the preset reads;
    the reason names why it would have no effect."""
    name, _, extra = preset.partition("+")
    config = load_preset(name)
    if extra:  # a user --set that the per-island rates override
        config = config.override({"crossover.probability": 0.5})
    with pytest.raises(ParameterError, match=words):
        check_factors(config, [factor])


def test_a_fitness_response_is_refused_for_factors_of_the_fitness_formula(monkeypatch,
                                                                          tmp_path):
    """IMGA's fitness is 1 / (aL + bS + cE): with fitness.a a factor and the response
    fitness (the default), the predicted best was the smallest a, whatever the search
    found. Refused before anything is built or written (no checkpoint folder); the same
    factor with response length, and another factor with the fitness, run."""
    from jaxga.doe import experiment

    def never(*args, **kwargs):
        raise AssertionError("a design point ran")

    monkeypatch.setattr(experiment, "_run_points", never)
    factor = [Factor("fitness.a", (3.0, 6.0, 9.0))]
    with pytest.raises(ParameterError, match="fitness.a changes the fitness formula") as e:
        run_doe("imga", MAP, factor, "full", seeds=2, generations=3,
                checkpoint=tmp_path / "points")
    assert "\n" not in str(e.value) and "length" in str(e.value)
    assert not (tmp_path / "points").exists()
    with pytest.raises(AssertionError, match="a design point ran"):  # planned, then run
        run_doe("imga", MAP, factor, "full", seeds=2, generations=3, response="length")
    with pytest.raises(AssertionError, match="a design point ran"):
        run_doe("imga", MAP, [Factor("mutation.probability", (0.1, 0.2, 0.3))], "full",
                seeds=2, generations=3)


@pytest.mark.parametrize("level", [10**400, 10**5000, float("inf")],
                         ids=["beyond-a-float", "beyond-pythons-repr", "inf"])
def test_a_level_no_float_holds_is_refused_in_a_short_line(level):
    """An integer level beyond the largest float was an OverflowError traceback; one of
    more than 4,300 digits cannot even be printed: a ParameterError of a short line."""
    with pytest.raises(ParameterError, match="levels must be finite numbers") as info:
        Factor("crossover.probability", (0.1, 0.5, level))
    assert len(str(info.value)) < 200


def test_a_level_nested_thousands_deep_names_its_factor():
    with pytest.raises(ParameterError, match="factor crossover.probability: a value nested "
                       "too deeply"):
        Factor.parse("crossover.probability=0.1,0.5," + "[" * 3000 + "]" * 3000)


def test_design_errors():
    with pytest.raises(ParameterError, match="4 columns, too few for 5 factors"):
        design_array("L9", 5)
    with pytest.raises(ParameterError, match="unknown design"):
        design_array("L8", 2)
    with pytest.raises(ParameterError, match="full factorial of 9"):
        design_array("full", 9)
    with pytest.raises(ParameterError, match="more than once"):
        check_factors(load_preset("agacd"), [AGACD_TABLE3[0], AGACD_TABLE3[0]])


# ----------------------------------------------------------------------------- running
# Every run below: preset agacd on a built-in 20 x 20 map, corner rule free, 10
# generations, population capacity 20, 3 seeds: two compiled program sets in all (27 runs
# for the one-call design, 3 runs for blocks, confirmation and jaxga.run).

MAP = "classic_ga_gapp3_20x20"
SMALL = (Factor("population.size", (10, 15, 20)),) + AGACD_TABLE3[1:]
KW = dict(generations=10, corner_rule="free")
CLI_ARGS = ["doe", "--preset", "agacd", "--map", MAP, "--corner-rule", "free",
            "--generations", "10", "--seeds", "3", "--design", "agacd-table4",
            "--factor", "population.size=10,15,20", "--factor", "crossover.pc_low=0.55,0.6,0.65",
            "--factor", "crossover.pc_high=0.7,0.75,0.8", "--factor",
            "mutation.pm_low=0.05,0.1,0.15", "--factor", "mutation.pm_high=0.2,0.25,0.3"]


@pytest.fixture(scope="session")
def one_call():
    """The whole design in one compiled call (27 runs), then the confirmation (3 runs)."""
    return run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, **KW)


@pytest.fixture(scope="session")
def blocked(tmp_path_factory):
    """The same experiment checkpointed in blocks of one point (3 runs per call), not
    interrupted."""
    ckpt = tmp_path_factory.mktemp("doe") / "ckpt"
    return ckpt, run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, checkpoint=ckpt, **KW)


def _without_timing(d: dict) -> dict:
    return {k: v for k, v in d.items() if k != "timing"}


def _assert_same_runs(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    """Same runs, bit for bit: fitness, success, turns, convergence generation and the
    float32 lengths and smoothness (float sums run in a fixed order whatever the number of
    runs per call: jaxga._batching.numerics)."""
    for key in ("fitness", "success", "turns", "convergence_generation",
                "length", "raw_length", "smoothness"):
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


@pytest.mark.slow
def test_the_confirmation_runs_the_designs_program(one_call, monkeypatch):
    """The design (27 runs) and its confirmation (3 runs) run one
    compiled program set (the confirmation's runs padded to the design's call), and a
    second experiment in the process compiles nothing."""
    import jax

    from jaxga._runtime import programs

    real = programs.compiled_programs
    runs_per_call = []
    monkeypatch.setattr(programs, "compiled_programs",
                        lambda *a: runs_per_call.append(a[3]) or real(*a))
    misses = real.cache_info().misses
    again = run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, **KW)
    assert runs_per_call == [32 * jax.local_device_count()] * 2  # design, confirmation
    assert real.cache_info().misses == misses
    _assert_same_runs(again.confirmation_all, one_call.confirmation_all)


def test_doe_points_equal_separate_runs(one_call):
    from jaxga.doe import seed_responses

    r = one_call
    assert r.responses.shape == (9, 3)
    # every point, with the design's capacity (its largest population.size), which
    # the result records: one compiled program for all nine runs
    assert r.population_capacity == max(v["population.size"] for v in r.values)
    for q, point in enumerate(r.values):
        single = jaxga.run("agacd", MAP, seeds=3, **KW,
                           population_capacity=r.population_capacity,
                           **{k.replace(".", "__"): v for k, v in point.items()})
        _assert_same_runs({k: v[q] for k, v in r.all_responses.items()},
                          seed_responses(single))
    # the response of each point is the mean over its seeds; fitness-like: all seeds
    np.testing.assert_allclose(r.means, r.responses.mean(axis=1))
    assert r.direction == "max" and r.response == "fitness"
    assert r.predicted == pytest.approx(r.coefficients[0] + np.abs(r.coefficients[1:]).sum())


def test_json_layout(one_call):
    d = json.loads(json.dumps(one_call.to_json(), allow_nan=False))
    for key in ("preset", "map", "response", "factors", "points", "coefficients",
                "predicted_best", "confirmation", "timing"):
        assert key in d
    assert d["preset"] == "agacd" and d["map"] == MAP and d["response"] == "fitness"
    # what a re-run needs: the cells, endpoints and path capacity, and what computed it
    grid = jaxga.maps.load_map(MAP)
    assert d["map_digest"] == grid.cells_digest()
    assert (d["start"], d["goal"]) == (list(grid.start_xy), list(grid.goal_xy))
    assert d["path_capacity"] > 0 and d["size_class"] is False
    assert d["environment"]["jaxga"] == jaxga.__version__
    names = [f.name for f in SMALL]
    assert list(d["factors"]) == names and d["factors"]["population.size"] == [10, 15, 20]
    assert len(d["points"]) == 9
    p = d["points"][3]
    assert p["coded"] == dict(zip(names, [0, -1, 0, 1, 1]))
    assert p["values"] == {"population.size": 15, "crossover.pc_low": 0.55,
                           "crossover.pc_high": 0.75, "mutation.pm_low": 0.15,
                           "mutation.pm_high": 0.3}
    assert len(p["responses"]) == 3 and p["mean"] == pytest.approx(np.mean(p["responses"]))
    assert list(d["coefficients"]) == ["X0", *names]
    assert set(d["predicted_best"]) == {"coded", "values", "predicted"}
    assert set(d["predicted_best"]["coded"].values()) <= {-1, 0, 1}
    assert len(d["confirmation"]["responses"]) == 3
    assert isinstance(d["confirmation"]["mean"], float)
    # what identifies the experiment: every setting, the generations, the capacity
    assert d["config"] == one_call.config.as_dict() and d["config"]["name"] == "agacd"
    assert d["generations"] == one_call.config["generations"]
    assert d["population_capacity"] == 20  # the largest population.size of the design
    t = d["timing"]
    assert t["total_s"] >= t["sweep_s"] + t["confirmation_s"] > 0
    assert t["compile_s"] <= t["sweep_s"] + t["confirmation_s"]
    # the report's time line says how its parts add up (compile is inside the others)
    line = one_call.report().splitlines()[-1]
    assert line.startswith(f"time (s): total {t['total_s']:.2f} = design points "
                           f"{t['sweep_s']:.2f} + confirmation {t['confirmation_s']:.2f}")
    assert f"compiling took {t['compile_s']:.2f} of the first two" in line


def test_failed_seeds_fitness_zero_lengths_excluded():
    from jaxga.doe import point_means, seed_responses

    class R:  # the fields of jaxga.api.Result that seed_responses reads
        success = np.array([True, False, True])
        fitness = np.array([0.3, -1.0, 0.2])
        length = np.array([30.0, 99.0, 32.0])
        raw_length = length
        convergence_generation = np.array([4, -1, 6])
        metrics = {"turns": np.array([3, 9, 5]), "angle_sum": np.array([1.0, 9.0, 2.0])}

    s = seed_responses(R)
    np.testing.assert_array_equal(s["fitness"], [0.3, 0.0, 0.2])
    assert point_means(s["fitness"][None])[0] == pytest.approx(0.5 / 3)
    assert point_means(s["length"][None])[0] == pytest.approx(31.0)
    assert point_means(s["convergence_generation"][None])[0] == pytest.approx(5.0)
    assert point_means(s["smoothness"][None])[0] == pytest.approx(1.5)
    assert point_means(s["success"][None])[0] == pytest.approx(2 / 3)
    assert np.isnan(point_means(np.full((1, 3), np.nan))[0])


def test_checkpointed_blocks_equal_one_call_and_resume(one_call, blocked, tmp_path):
    ckpt0, first = blocked
    _assert_same_runs(first.all_responses, one_call.all_responses)
    _assert_same_runs(first.confirmation_all, one_call.confirmation_all)
    # the fitness response, its fit and its confirmation: identical
    assert _without_timing(first.to_json()) == _without_timing(one_call.to_json())
    ckpt = tmp_path / "ckpt"
    shutil.copytree(ckpt0, ckpt)
    files = sorted(ckpt.glob("point-*.json"))
    assert len(files) == 9 and (ckpt / "manifest.json").exists()
    assert len(list(ckpt.glob("confirm_*.json"))) == 1
    for f in files[2:7]:
        f.unlink()
    seen = []
    again = run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, checkpoint=ckpt,
                    progress=lambda done, total: seen.append(done), **KW)
    assert seen[0] == 4 and seen[-1] == 9  # 4 points loaded, 5 run again
    for key, v in first.all_responses.items():  # same blocks: bit for bit
        np.testing.assert_array_equal(again.all_responses[key], v)
    assert _without_timing(again.to_json()) == _without_timing(first.to_json())
    # another configuration is refused before anything runs
    with pytest.raises(ParameterError, match="different configuration.*seeds"):
        run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=2, checkpoint=ckpt, **KW)
    with pytest.raises(ParameterError, match="different configuration.*config"):
        run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, checkpoint=ckpt,
                generations=11, corner_rule="free")
    with pytest.raises(ParameterError, match="different configuration.*factors"):
        run_doe("agacd", MAP, (Factor("population.size", (10, 16, 20)),) + SMALL[1:],
                "agacd-table4", seeds=3, checkpoint=ckpt, **KW)
    # the same factors in another order: the design's columns mean other factors
    with pytest.raises(ParameterError, match="different configuration.*factors"):
        run_doe("agacd", MAP, SMALL[::-1], "agacd-table4", seeds=3, checkpoint=ckpt, **KW)
    with pytest.raises(ParameterError, match="different configuration.*block"):
        run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, checkpoint=ckpt, block=2,
                **KW)
    # points computed on another device: not mixed into this one's fit
    manifest = json.loads((ckpt / "manifest.json").read_text())
    assert manifest["device"].startswith("cpu (cpu, jaxlib ")
    manifest["device"] = "gpu (NVIDIA H200, jaxlib 0.11.2)"
    (ckpt / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ParameterError) as e:
        run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, checkpoint=ckpt, **KW)
    assert "was computed on gpu (NVIDIA H200, jaxlib 0.11.2), this run is on cpu (" \
        in str(e.value)


@pytest.mark.parametrize("damage, where", [
    ("{bad", "point"), ("", "point"), ('{"point": 3}', "point"),
    ('{"responses": {"fitness": [1, 2, 3]}}', "point"),
    ("two_seeds", "point"), ("text_value", "point"), ("{bad", "confirm"),
    ("two_seeds", "confirm"), ("success_2", "point"), ("failed_with_length", "point"),
    ("negative_length", "confirm"), ("half_turn", "point"), ("reason_number", "point"),
    ("late_convergence", "point"),
])
def test_a_damaged_checkpoint_file_is_named_not_a_traceback(blocked, tmp_path, monkeypatch,
                                                            damage, where):
    """A point or confirmation file that is not valid JSON, lacks responses, holds
    another number of seeds or a value no run can return (a success of 2, a failed seed
    with a length, a negative length, half a turn) is refused naming the file, before
    anything runs."""
    ckpt0, _ = blocked
    ckpt = tmp_path / "ckpt"
    shutil.copytree(ckpt0, ckpt)
    target = (ckpt / "point-0004.json" if where == "point"
              else next(ckpt.glob("confirm_*.json")))
    saved = json.loads(target.read_text())
    if damage == "two_seeds":
        saved["responses"] = {k: v[:2] for k, v in saved["responses"].items()}
        damage = json.dumps(saved)
    elif damage == "text_value":
        saved["responses"]["length"][0] = "x"
        damage = json.dumps(saved)
    elif damage != "" and not damage.startswith("{"):  # values no run can return
        r = saved["responses"]
        assert r["success"][0] == 1  # the damage below is impossible for a success
        change = {"success_2": ("success", 2), "negative_length": ("length", -1.0),
                  "half_turn": ("turns", 1.5),
                  "late_convergence": ("convergence_generation", 99)}.get(damage)
        if change:
            r[change[0]][0] = change[1]
        elif damage == "failed_with_length":  # a failed seed with a length
            r["success"][0], r["fitness"][0] = 0, 0.0
        else:
            saved["reason"] = 3
        damage = json.dumps(saved)
    target.write_text(damage)
    monkeypatch.setattr(jaxga.api, "sweep", lambda *a, **k: pytest.fail("a sweep ran"))
    with pytest.raises(ParameterError, match=re.escape(target.name)):
        run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, checkpoint=ckpt, **KW)


def test_a_point_file_round_trips_an_overflowing_fitness_and_the_reason(tmp_path):
    """What a run can return is read back exactly: a fitness that overflowed float32
    (+inf, written "inf"), a failed seed's NaN lengths (null) and the no-path reason; an
    infinite length is not something a run returns."""
    from jaxga.doe import RESPONSES
    from jaxga.doe.checkpoint import Checkpoint, decode

    responses = {k: np.array([2.5, np.nan]) for k in RESPONSES}
    responses.update(fitness=np.array([np.inf, 0.0]), success=np.array([1.0, 0.0]),
                     convergence_generation=np.array([3.0, np.nan]),
                     turns=np.array([2.0, np.nan]))
    ckpt = Checkpoint(tmp_path, {"format": 1})
    ckpt.save_point(0, responses, "no feasible path found by 1 of 2 seeds")
    (saved,) = ckpt.load_points(1, 2)
    assert saved["reason"] == "no feasible path found by 1 of 2 seeds"
    assert saved["fitness"] == ["inf", 0.0]
    back = decode(saved)
    assert set(back) == set(RESPONSES)
    for k in RESPONSES:
        np.testing.assert_array_equal(back[k], responses[k])
    point = tmp_path / "point-0000.json"
    data = json.loads(point.read_text())
    data["responses"]["length"][0] = "inf"
    point.write_text(json.dumps(data))
    with pytest.raises(ParameterError, match="length of seed 0 is 'inf'"):
        ckpt.load_points(1, 2)
    ckpt.save_point(0, responses)  # a point file that says it holds another point
    data = json.loads(point.read_text())
    point.write_text(json.dumps({**data, "point": 7}))
    with pytest.raises(ParameterError, match="holds point 7, not 0"):
        ckpt.load_points(1, 2)
    other = Checkpoint(tmp_path / "other", {"format": 1, "factors": "others"})
    other.save_point(0, responses)  # another experiment's point 0, copied in: its
    point.write_bytes((tmp_path / "other" / point.name).read_bytes())  # values were read
    with pytest.raises(ParameterError, match="was written by another experiment"):
        ckpt.load_points(1, 2)
    if hasattr(os, "mkfifo"):  # a FIFO in a point file's place: refused, not read forever
        point.unlink()
        os.mkfifo(point)
        with pytest.raises(ParameterError, match="not a regular file"):
            ckpt.load_points(1, 2)


def test_a_checkpointed_doe_checks_the_memory_of_one_block(blocked, tmp_path, monkeypatch):
    """Only a block of points is in memory at a time: 3 seeds x 1 point, not x 9."""
    ckpt0, _ = blocked
    ckpt = tmp_path / "ckpt"
    shutil.copytree(ckpt0, ckpt)
    checked = []
    import jaxga.doe.plan as plan_module

    real = plan_module.check_result_memory
    monkeypatch.setattr(plan_module, "check_result_memory",
                        lambda n, algo: checked.append(n) or real(n, algo))
    monkeypatch.setattr(jaxga.api, "sweep", lambda *a, **k: pytest.fail("a sweep ran"))
    run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, checkpoint=ckpt, **KW)
    assert checked == [3]


def test_a_doe_on_an_unreachable_goal_is_no_path_naming_the_cause(tmp_path, capsys):
    walled = tmp_path / "walled.txt"
    walled.write_text("S.#.\n..#G\n")
    with pytest.raises(NoPathError, match="unreachable"):
        run_doe("agacd", str(walled), SMALL, "agacd-table4", seeds=3, **KW)
    args = [a if a != MAP else str(walled) for a in CLI_ARGS]
    assert main(args) == EXIT_NO_PATH
    assert "unreachable" in capsys.readouterr().err


def test_cli_errors_are_one_line(tmp_path, capsys):
    l9 = ["L9" if a == "agacd-table4" else a for a in CLI_ARGS]  # --design given once
    cases = [
        (CLI_ARGS + ["--factor", "generations=10,20,30"], "changes the compiled program"),
        (l9, "4 columns, too few for 5 factors"),
        (CLI_ARGS + ["--factor", "population.size=10,20"], "three levels"),
    ]
    for argv, words in cases:
        assert main(argv) == EXIT_BAD_INPUT
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and words in err and "Traceback" not in err
    assert main(["doe", "--preset", "agacd", "--map", MAP, "--design", "L9"]) == EXIT_BAD_INPUT
    assert "--factor" in capsys.readouterr().err


def test_cli_refuses_checkpoint_of_another_configuration(tmp_path, capsys):
    ckpt = tmp_path / "ckpt"
    ckpt.mkdir()
    (ckpt / "manifest.json").write_text(json.dumps({"format": 1, "seeds": [0, 1]}))
    assert main(CLI_ARGS + ["--checkpoint", str(ckpt)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "different configuration" in err and "\n" not in err


@pytest.mark.parametrize("damage", ["list", "null", "fifo"])
def test_a_manifest_that_is_not_a_json_object_or_not_a_file_is_one_line(tmp_path, capsys,
                                                                        damage):
    """A manifest holding JSON of another kind, or a FIFO in its place (whose read would
    block for good), is refused in one line before anything runs."""
    ckpt = tmp_path / "ckpt"
    ckpt.mkdir()
    manifest = ckpt / "manifest.json"
    if damage == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("needs FIFOs")
        os.mkfifo(manifest)
    else:
        manifest.write_text(damage if damage == "null" else "[1, 2]")
    assert main(CLI_ARGS + ["--checkpoint", str(ckpt)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "manifest" in err and "\n" not in err and "Traceback" not in err


@pytest.mark.slow
def test_killed_checkpointed_doe_resumes_to_the_same_result(blocked, tmp_path):
    """Kill a checkpointed ``jaxga doe`` subprocess midway, rerun
    the same command, and get the JSON of an uninterrupted run of the same command."""
    ckpt, out = tmp_path / "ckpt", tmp_path / "out.json"
    cmd = [sys.executable, "-m", "jaxga.cli", *CLI_ARGS, "--checkpoint", str(ckpt),
           "--json", str(out)]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    for _attempt in range(3):
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 600
        while (proc.poll() is None and time.monotonic() < deadline
               and not any(ckpt.glob("point-*.json"))):
            time.sleep(0.002)
        proc.kill()
        proc.wait()
        n_done = len(list(ckpt.glob("point-*.json")))
        if 1 <= n_done < 9:
            break
        shutil.rmtree(ckpt, ignore_errors=True)  # killed too late (or too early): again
    else:
        pytest.fail("could not kill the sweep between its first and last point")
    assert not out.exists()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    first = re.search(r"design points done: (\d+)/9", done.stderr)
    assert first and int(first.group(1)) == n_done  # resumed, not recomputed
    got = json.loads(out.read_text())
    assert _without_timing(got) == _without_timing(
        json.loads(json.dumps(blocked[1].to_json())))


# ----------------------------------------------------------------------------- plot

def test_plot_main_effects_draws_level_means():
    from jaxga.plot import plot_main_effects

    coded = design_array("L9", 2)
    y = np.arange(9, dtype=float)
    doe_json = {
        "preset": "p", "map": "m", "response": "fitness",
        "factors": {"a": [1, 2, 3], "b": [0.1, 0.2, 0.3]},
        "points": [{"coded": {"a": int(r[0]), "b": int(r[1])}, "mean": float(v)}
                   for r, v in zip(coded, y)],
    }
    ax = plot_main_effects(doe_json)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    np.testing.assert_allclose(lines["a (1, 2, 3)"].get_ydata(), [1.0, 4.0, 7.0])
    np.testing.assert_allclose(lines["b (0.1, 0.2, 0.3)"].get_ydata(), [3.0, 4.0, 5.0])
    np.testing.assert_allclose(lines["mean of the points"].get_ydata(), [4.0, 4.0])
    import matplotlib.pyplot as plt

    plt.close(ax.figure)


@pytest.mark.parametrize("kw, words", [
    ({"factors": {"mutation.probability": (0.1, 0.2, 0.3)}}, "factors must be a list"),
    ({"factors": "x"}, "factors must be a list"),
    ({"factors": [("x", (1, 2, 3))]}, "factors must be a list"),
    ({"block": "1"}, "block must be an integer"),
    ({"block": 1.5}, "block must be an integer"),
    ({"progress": 3}, "progress must be a callable"),
    ({"checkpoint": 3}, "checkpoint must be a directory path"),
])
def test_wrong_python_types_for_a_doe_are_named(monkeypatch, kw, words):
    monkeypatch.setattr(jaxga.api, "sweep", lambda *a, **k: pytest.fail("a sweep ran"))
    args = {"factors": [Factor("mutation.probability", (0.1, 0.2, 0.3))], **kw}
    with pytest.raises(ParameterError, match=words):
        run_doe("sga", MAP, design="full", seeds=1, generations=2, **args)
    with pytest.raises(ParameterError, match="a factor's name is a configuration key"):
        Factor(3, (1, 2, 3))


def test_table_headers_tell_the_factors_apart():
    from jaxga.doe import column_names

    assert column_names(["population.size", "crossover.pc_low"]) == ["size", "pc_low"]
    assert column_names(["crossover.probability", "mutation.probability", "fitness.a"]) == [
        "crossover.probability", "mutation.probability", "a"]


def test_one_set_string_is_one_set(monkeypatch):
    """``sets="mutation.probability=0.5"`` is one override (it was split into letters), in
    the problem every design point's sweep runs (checked once, :func:`jaxga.problem`)."""
    seen = {}

    def fake_sweep(preset, grid, points, seeds, **options):
        seen.update(problem=preset, grid=grid)
        raise KeyboardInterrupt

    monkeypatch.setattr(jaxga.api, "sweep", fake_sweep)
    with pytest.raises(KeyboardInterrupt):
        run_doe("sga", MAP, [Factor("crossover.probability", (0.5, 0.6, 0.7))], "full",
                seeds=1, generations=2, sets="mutation.probability=0.5")
    assert isinstance(seen["problem"], jaxga.Problem) and seen["grid"] is None
    assert seen["problem"].config["mutation.probability"] == 0.5


def test_a_checkpoint_that_is_a_file_is_named(monkeypatch, tmp_path):
    monkeypatch.setattr(jaxga.api, "sweep", lambda *a, **k: pytest.fail("a sweep ran"))
    existing = tmp_path / "m.txt"
    existing.write_text("x")
    with pytest.raises(ParameterError, match="m.txt is a file, not a directory"):
        run_doe("sga", MAP, [Factor("mutation.probability", (0.1, 0.2, 0.3))], "full",
                seeds=1, generations=2, checkpoint=existing)


def test_a_factor_that_is_also_an_override_is_refused(monkeypatch):
    """The factor's levels would silently replace the override."""
    monkeypatch.setattr(jaxga.api, "sweep", lambda *a, **k: pytest.fail("a sweep ran"))
    factor = [Factor("mutation.probability", (0.1, 0.2, 0.3))]
    for kw in ({"mutation__probability": 0.9}, {"sets": ["mutation.probability=0.9"]}):
        with pytest.raises(ParameterError, match="mutation.probability is both a factor "
                                                 "and an override"):
            run_doe("sga", MAP, factor, "full", seeds=1, generations=2, **kw)
        # in a loaded Problem (what `jaxga doe --set` gives): it ran, the --set ignored
        with pytest.raises(ParameterError, match="mutation.probability is both a factor "
                                                 "and an override"):
            run_doe(jaxga.problem("sga", MAP, **kw), None, factor, "full", seeds=1)


def test_every_design_point_is_checked_before_the_first_runs(monkeypatch):
    """A level that is valid alone but not with the preset's other keys (Zhang's
    straight speed below its turning speed 0.5) is refused before any point runs, not
    after the points before it (a checkpoint could not be resumed past it)."""
    monkeypatch.setattr(jaxga.api, "sweep", lambda *a, **k: pytest.fail("a sweep ran"))
    with pytest.raises(ParameterError, match="fitness.v_t = 0.5 is above fitness.v = 0.25"):
        run_doe("iga_zhang", MAP, [Factor("fitness.v", (0.25, 0.5, 1.0))], "full", seeds=1,
                generations=2, population__size=8, response="length")


def test_angle_sum_is_the_smoothness_response(one_call):
    """``response="angle_sum"`` (the name of run's summary and compare) is the smoothness
    response: the same design, the same compiled programs, the smoothness values."""
    r = run_doe("agacd", MAP, SMALL, "agacd-table4", seeds=3, response="angle_sum", **KW)
    assert r.response == "smoothness" and r.direction == "min"
    np.testing.assert_array_equal(r.responses, one_call.all_responses["smoothness"])
