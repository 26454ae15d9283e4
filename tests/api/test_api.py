"""Every preset end to end, hyper-parameter sweeps in one compiled call, the compile cache,
and the optax schedules of the adaptive operators."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import warnings

import jax
import numpy as np
import pytest

import jaxga._runtime as runtime
from jaxga import __version__ as jaxga_version
from jaxga import api, engine
from jaxga import problem as make_problem
from jaxga.compare import compare as jaxga_compare
from jaxga.config.presets import preset_names
from jaxga.config.schema import SCHEMA
from jaxga.core.errors import InitialisationWarning, JaxgaError, ParameterError
from jaxga.core.grid import Grid
from jaxga.maps import load_map, random_map
from jaxga.operators import schedules
from jaxga.reference.any_angle import any_angle_shortest_path
from jaxga.reference.fitness import fitness_optimum, fitness_weights, path_fitness_np
from jaxga.reference.optima import clear_np, path_length, shortest_path
from jaxga.replan import replan as jaxga_replan
from tests import canonical

SMALL = dict(generations=canonical.GENERATIONS)
"""The canonical problems (tests/canonical.py): each preset at its own defaults, few
generations; only dynamic keys are overridden below, unless a test needs its own program."""


@pytest.fixture(scope="module")
def grid():
    """The canonical map (the README's 20 x 20 map, free corner rule) as a Grid."""
    return load_map(canonical.MAP)


ZHANG_DEFAULTS = {"a": 2.0, "v": 1.0, "v_t": 0.5, "r": 0.5}


def _zhang_fitness(path: np.ndarray, a: float, v: float, v_t: float, r: float) -> float:
    """Zhang eq. 2 on any polyline: 1 / (length + a m (v - v_t) pi r / (2 v v_t)), m the
    nodes where the heading changes."""
    seg = np.diff(path.astype(float), axis=0)
    cross = seg[:-1, 0] * seg[1:, 1] - seg[:-1, 1] * seg[1:, 0]
    back = (seg[:-1] * seg[1:]).sum(axis=1) < 0
    turns = int(np.sum((np.abs(cross) > 1e-9) | back))
    return 1.0 / (np.hypot(seg[:, 0], seg[:, 1]).sum()
                  + a * turns * (v - v_t) * math.pi * r / (2 * v * v_t))


@pytest.fixture(scope="module", params=sorted(preset_names()))
def preset_run(request, grid):
    name = request.param
    overrides = dict(SMALL)  # the canonical program of the preset (3 seeds: the 4-run one)
    return name, canonical.run(name, 3, **overrides), overrides


def test_every_preset_returns_only_feasible_paths(preset_run, grid):
    name, r, _ = preset_run
    waypoints = engine.uses_waypoints(r.config)  # AGACD; Zhang's eq. 5 deletions
    blocked = grid.blocked_np()
    octile = shortest_path(grid).length
    bound = any_angle_shortest_path(grid).length
    assert r.success.any(), name
    for i in np.flatnonzero(r.success):
        path = r.path(i)
        assert path[0] == grid.start_xy and path[-1] == grid.goal_xy, name
        assert all(clear_np(blocked, grid.corner_rule, p, q) for p, q in zip(path, path[1:]))
        assert r.length[i] >= bound - 1e-4 and r.raw_length[i] >= bound - 1e-4
        raw = r.path(i, raw=True)
        assert raw[0] == grid.start_xy and raw[-1] == grid.goal_xy
        assert all(clear_np(blocked, grid.corner_rule, p, q) for p, q in zip(raw, raw[1:]))
        if not waypoints:  # grid-step presets: the raw path is 8-connected
            assert all(max(abs(p[0] - q[0]), abs(p[1] - q[1])) == 1
                       for p, q in zip(raw, raw[1:])), name
            assert r.raw_length[i] >= octile - 1e-4
    assert r.history["best"].shape == (3, 3)
    # the best so far is at least every generation's population mean (an engine that lost
    # its best individual, or tracked another run's, would break this)
    assert np.all(r.history["mean"] <= r.history["best"] * (1 + 1e-6)), name
    # no run beats the exact optimum of its own fitness (over 8-connected paths: none for
    # waypoint paths)
    if waypoints:
        assert math.isnan(r.fitness_optimum) and np.isnan(r.fitness_gap).all()
    else:
        opt = fitness_optimum(grid, r.config)
        assert opt.found and r.fitness_optimum == opt.fitness
        assert r.fitness_optimum_length >= octile - 1e-9
        assert np.all(r.fitness_gap[r.success] >= 0), (name, r.fitness, opt.fitness)
        assert np.isnan(r.fitness_gap[~r.success]).all()
        assert r.fitness_optimum_reason == ""
    # every raw gap against the optimum of the raw paths' kind: never below it
    assert np.all(r.raw_gap[r.success] >= 0) and np.all(r.gap[r.success] >= 0), name
    assert r.raw_optimum == (bound if waypoints else octile)
    # the JSON layout of `jaxga run --json`: enough to identify and repeat the runs
    js = r.to_json()
    assert js["preset"] == name and len(js["runs"]) == 3
    assert {"compile_s", "init_s", "evolve_s", "post_s", "total_s"} <= set(js["timing"])
    assert js["fitness_optimum"] == (None if waypoints else r.fitness_optimum)
    assert ("waypoint" in js["fitness_optimum_reason"]) == waypoints
    assert js["start"] == list(grid.start_xy) and js["goal"] == list(grid.goal_xy)
    assert js["config"] == r.config.as_dict() and js["config"]["generations"] == 3
    assert js["population_capacity"] == r.config["population.size"]  # per island
    assert js["raw_optimum"] == r.raw_optimum
    assert js["map_digest"] == grid.cells_digest()  # the cells, whatever the map's name
    _check_environment(js["environment"])
    for i, run in enumerate(js["runs"]):
        for key in ("angle_sum", "turns", "gap", "raw_gap", "fitness_gap"):
            want = r._column(key)[i] if key in ("angle_sum", "turns") else getattr(r, key)[i]
            assert run[key] == (float(want) if r.success[i] and np.isfinite(want) else None)
    json.dumps(js, allow_nan=False)


def _check_environment(recorded: dict) -> None:
    """A result's JSON names what computed it: the versions and this process's device."""
    import jaxlib

    assert recorded["jaxga"] == jaxga_version and recorded["jax"] == jax.__version__
    assert recorded["jaxlib"] == jaxlib.__version__ and recorded["numpy"] == np.__version__
    device = jax.devices()[0]
    assert recorded["device"] == f"{device.platform} ({device.device_kind}, jaxlib " \
        f"{jaxlib.__version__})"


def test_every_preset_is_deterministic(preset_run, grid):
    name, r, overrides = preset_run
    # the program set back in the process's table (a worker's other tests may have pushed
    # it out since the fixture ran), then the same seeds in another order: no new set
    api.run(name, grid, seeds=[0, 1, 2], **overrides)
    before = runtime.programs.compiled_programs.cache_info().misses
    again = api.run(name, grid, seeds=[2, 0, 1], **overrides)  # other order, same program
    assert runtime.programs.compiled_programs.cache_info().misses == before
    for i, j in ((0, 2), (1, 0), (2, 1)):
        assert again.success[i] == r.success[j]
        assert np.array_equal(again.cells[i], r.cells[j])
        # bit for bit: float sums run in a fixed order whatever the batch (jaxga._batching.numerics)
        for h in ("best", "mean", "std"):
            assert np.array_equal(again.history[h][i], r.history[h][j])
        assert again.length[i] == r.length[j] and again.fitness[i] == r.fitness[j]


def test_reported_values_agree_with_the_returned_paths(preset_run, grid):
    """Every per-seed number recomputed here from the returned paths and histories:
    lengths as polylines, the grid presets' fitness by the independent NumPy scorer of
    ``jaxga.reference.fitness``, the convergence generation from the best-so-far
    history, and the JSON runs from the padded cell arrays."""
    name, r, _ = preset_run
    blocked = grid.blocked_np()
    js = r.to_json()
    for i in range(len(r.seeds)):
        best = r.history["best"][i]
        run = js["runs"][i]
        assert run["seed"] == r.seeds[i] and run["success"] == bool(r.success[i])
        assert (best[-1] == r.fitness[i] == np.float32(run["fitness"])) if r.success[i] \
            else (np.isnan(r.fitness[i]) and run["fitness"] is None)
        # the initial population's best: where the best-so-far history starts from
        # (a population without a path never makes one: success needs an initial path)
        assert 0 <= r.initial_fitness[i] <= best[0]
        assert r.initial_fitness[i] > 0 or not r.success[i]
        assert run["initial_fitness"] == float(r.initial_fitness[i])
        for h in ("best", "mean", "std"):
            assert np.array_equal(np.float32(run["history"][h]), r.history[h][i])
        if not r.success[i]:
            assert r.convergence_generation[i] == -1 and run["path"] == []
            continue
        post, raw = r.path(i), r.path(i, raw=True)
        assert math.isclose(r.length[i], path_length(np.array(post)), rel_tol=1e-5)
        assert math.isclose(r.raw_length[i], path_length(np.array(raw)), rel_tol=1e-5)
        method, weights = fitness_weights(r.config)
        if not engine.uses_waypoints(r.config):  # grid-step fitnesses: independent scorer
            ref = path_fitness_np(blocked, grid.goal_xy, method, weights, np.array(raw))
            assert math.isclose(ref, float(r.fitness[i]), rel_tol=1e-5), (name, i)
        elif method == "iga_zhang":  # Zhang's eq. 2 on a polyline, from the paper
            ref = _zhang_fitness(np.array(raw), **{**ZHANG_DEFAULTS, **weights})
            assert math.isclose(ref, float(r.fitness[i]), rel_tol=1e-5), (name, i)
        # the first generation whose best-so-far is the final best (0: the initial
        # population held it, so every generation's best-so-far equals it)
        c = int(r.convergence_generation[i])
        assert 0 <= c <= len(best)
        if c == 0:
            assert np.all(best == r.fitness[i])
        else:
            assert best[c - 1] == r.fitness[i]
            assert c == 1 or best[c - 2] < r.fitness[i]
        assert run["convergence_generation"] == c
        # JSON paths: the padded cell rows decoded as (x, y), y counted from the bottom
        w = grid.width
        for key, cells, n, length in (("path", r.cells, r.n_cells, r.length),
                                      ("raw_path", r.raw_cells, r.raw_n_cells, r.raw_length)):
            row = cells[i][: int(n[i])]
            assert run[key] == [[int(c) % w, int(c) // w] for c in row]
            assert run[key.replace("path", "length")] == float(length[i])
        assert run["path"][0] == list(grid.start_xy) and run["path"][-1] == list(grid.goal_xy)


def test_summary_rows_are_the_statistics_of_the_successful_seeds(preset_run):
    name, r, _ = preset_run
    i, j = np.flatnonzero(r.success)[:2]  # two successful seeds; the third marked failed
    failed = dataclasses.replace(r, success=np.isin(np.arange(3), [i, j]))
    rows = {row[0]: row[1:] for row in failed.summary_rows()}
    columns = {"length": r.length, "raw_length": r.raw_length, "fitness": r.fitness,
               "convergence_generation": r.convergence_generation,
               "angle_sum": r.metrics["angle_sum"], "turns": r.metrics["turns"],
               "gap": failed.gap, "raw_gap": failed.raw_gap,
               "fitness_gap": failed.fitness_gap}
    assert set(rows) == set(columns)
    for key, values in columns.items():
        a, b = float(values[i]), float(values[j])
        expected = ((a + b) / 2, abs(a - b) / math.sqrt(2), min(a, b), max(a, b))
        np.testing.assert_allclose(rows[key], expected, rtol=1e-6, atol=1e-12,
                                   equal_nan=True, err_msg=f"{name} {key}")
    assert "success 2/3" in failed.summary()


def test_a_result_is_its_sub_records(preset_run):
    """Every field of a :class:`~jaxga.api.result.Result` is in exactly one of its typed
    sub-records (setup, paths, outcome, references) or is its timing, and each
    sub-record holds the very values read by name."""
    from jaxga.api.result import RESULT_RECORDS

    _, r, _ = preset_run
    fields = [f.name for f in dataclasses.fields(r)]
    grouped = [f.name for rec in RESULT_RECORDS for f in dataclasses.fields(rec)]
    assert sorted(grouped + ["timing"]) == sorted(fields)
    for view in (r.setup, r.paths, r.outcome, r.references):
        for f in dataclasses.fields(view):
            assert getattr(view, f.name) is getattr(r, f.name), f.name
    assert r.paths.cells.shape[0] == len(r.setup.seeds) == r.outcome.success.shape[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.references.optimum = 0.0


def test_stagnation_freezes_a_run_after_k_generations_without_improvement(grid):
    """IMGA 4.4's stopping rule (``termination.stagnation``): with K = 1 a run freezes
    after its first generation without improvement; until then it is the run without
    the rule (same keys), afterwards its state, so its history, stays as it was."""
    free = api.run("sga", grid, seeds=3, **SMALL)  # the program of ``preset_run``
    stop = api.run("sga", grid, seeds=3, **SMALL, termination__stagnation=1)
    n_gen = SMALL["generations"]
    froze = 0
    for i in range(3):
        best = stop.history["best"][i]
        # with K = 1 generations 1..f improved (f = the convergence generation) and
        # generation f + 1 did not: the run froze there (history index f)
        f = int(stop.convergence_generation[i])
        assert np.all(np.diff(best[:f]) > 0)
        for h in ("best", "mean", "std"):
            upto = min(f, n_gen - 1) + 1  # the same runs until the freeze
            np.testing.assert_allclose(stop.history[h][i, :upto], free.history[h][i, :upto],
                                       rtol=1e-6)
            if f < n_gen:
                assert np.all(stop.history[h][i, f:] == stop.history[h][i, f]), (i, h)
        if f == n_gen:  # improved every generation: never frozen
            assert np.array_equal(stop.cells[i], free.cells[i])
        elif not np.array_equal(stop.history["mean"][i], free.history["mean"][i]):
            froze += 1
    assert froze >= 1  # the rule changed at least one of these runs


def test_a_sweep_point_equals_a_run_with_those_values(grid):
    # 3 points x 1 seed and runs of 3 seeds: the same 4-run (canonical) program as ``preset_run``
    # (compiled programs are keyed by the run count; sharing one keeps the suite short).
    points = [{"crossover.probability": 0.2, "mutation.probability": 0.9},
              {"crossover.probability": 0.9, "mutation.probability": 0.1},
              {"crossover.probability": 0.5, "mutation.probability": 0.5}]
    results = api.sweep("sga", grid, points, seeds=1, **SMALL)
    assert [r.config["crossover.probability"] for r in results] == [0.2, 0.9, 0.5]
    for point, res in zip(points, results):
        single = api.run("sga", grid, seeds=[0, 1, 2], **SMALL,
                         crossover__probability=point["crossover.probability"],
                         mutation__probability=point["mutation.probability"])
        assert np.array_equal(single.cells[:1], res.cells)
        assert np.array_equal(single.history["best"][:1], res.history["best"])
        assert np.array_equal(single.history["mean"][:1], res.history["mean"])
    assert not np.array_equal(results[0].history["mean"], results[1].history["mean"])


def test_population_size_sweep_uses_the_active_mask(grid):
    # sizes up to sga's own 60: the sweep's capacity is the canonical program's population
    results = api.sweep("sga", grid, [{"population.size": s} for s in (20, 40, 60)],
                        seeds=1, **SMALL)
    assert [r.population for r in results] == [20, 40, 60]
    for r in results:
        assert r.success.all()
        assert r.history["best"].shape == (1, 3)
    # an inactive slot never counts: 20 active individuals cannot have the history of 60
    assert not np.array_equal(results[0].history["mean"], results[2].history["mean"])
    # a point's runs are repeated bit for bit by run() with the sweep's capacity (the
    # same 4-run program), which every result and its JSON record
    assert {r.population_capacity for r in results} == {60}
    again = api.run("sga", grid, seeds=[0, 1, 2], population_capacity=60,
                    **{**SMALL, "population__size": 20})
    assert again.population_capacity == 60 and again.to_json()["population_capacity"] == 60
    assert np.array_equal(again.cells[:1], results[0].cells)
    assert np.array_equal(again.history["mean"][:1], results[0].history["mean"])
    with pytest.raises(ParameterError, match="population_capacity 3 is below the largest "
                                             "population.size .4."):
        api.check_run("sga", grid, population_capacity=3, **{**SMALL, "population__size": 4})


UNREAD_CASES = [(name, {}) for name in sorted(preset_names())] + [
    ("agacd", {"crossover.adaptive": False, "crossover.probability": 0.7}),
    ("sga", {"simplify.method": "simplify_adjacent", "simplify.probability": 0.2,
             "selection.method": "tournament"}),
    ("mpmga", {"crossover.adaptive": True, "crossover.pc_low": 0.5,
               "crossover.pc_high": 0.9}),
    ("imga", {"crossover.method": "none", "mutation.method": "segment_sa",
              "mutation.temperature_c1": 50.0, "mutation.temperature_w": 0.9}),
]


@pytest.mark.parametrize("preset, changes", UNREAD_CASES,
                         ids=[f"{p}{'+' if c else ''}{'-'.join(c)[:40]}"
                              for p, c in UNREAD_CASES])
def test_unread_dynamic_keys_are_exactly_those_the_program_does_not_use(preset, changes):
    """``unread_keys`` against the traced program (nothing compiles): every dynamic key
    is given a value, a whole run (initialisation, a generation, post-optimisation) is
    traced, and JAX's dead-code elimination says which parameters reach the outputs.
    A key is reported unread exactly when its parameter does not (a per-island rate
    travels under the rate's name, so it stands for ``islands.*_probabilities``)."""
    import jax

    pe = pytest.importorskip("jax._src.interpreters.partial_eval")
    if not hasattr(pe, "dce_jaxpr"):
        pytest.skip("this JAX has no dce_jaxpr")
    from jaxga._runtime.fields import program_fields
    from jaxga.config.presets import load_preset
    from jaxga.config.schema import SCHEMA

    grid = random_map(8, 8, 0.15, 1, corner_rule="free")
    config = load_preset(preset).override({"population.size": 6, "generations": 1,
                                           "islands.migrants": 1, **changes})
    missing = {k: 0.3 for k, f in SCHEMA.items()
               if f.dynamic and f.kind is not list and config.get(k) is None}
    missing.pop("fitness.v_t", None)  # Zhang: must not exceed v
    config = config.override(missing)
    algo, params = engine.build(config, grid)
    key = jax.random.PRNGKey(0)

    guided = program_fields(grid, config)  # the fields jaxga.run attaches

    def whole_run(params):
        state, _ = engine.init_state(algo, key, guided, params)
        state, history = engine.evolve(algo, key, guided, state, params, 1)
        return engine.finish(algo, guided, state, history, params, state.best_fitness), history

    closed = jax.make_jaxpr(whole_run)(params)
    _, used = pe.dce_jaxpr(closed.jaxpr, [True] * len(closed.jaxpr.outvars))
    paths = [jax.tree_util.keystr(p) for p, _ in jax.tree_util.tree_flatten_with_path(params)[0]]
    used_keys = {p[2:-2] for p, u in zip(paths, used, strict=True) if u}
    unread = engine.unread_keys(config)

    def claimed_unread(k: str) -> bool:
        island_key = engine.PER_ISLAND.get(k)
        if island_key and config.get(island_key) is not None:  # the leaf holds those
            return island_key in unread
        return k in unread

    dynamic = [k for k in config.dynamic()
               if k != "population.size" and k not in engine.PER_ISLAND.values()]
    assert dynamic and used_keys
    wrong = {k: "claimed unread" if claimed_unread(k) else "claimed read"
             for k in dynamic if claimed_unread(k) == (k in used_keys)}
    assert not wrong


@pytest.mark.parametrize("preset, overrides, message", [
    ("sga", {"fitness__omega": 0.5}, "fitness.omega has no effect in 'sga': fitness.method"),
    ("agacd", {"crossover__probability": 0.5}, "crossover.adaptive = true"),
    ("agacd", {"mutation__probability": 0.5}, "mutation.adaptive = true"),
    ("mpmga", {"mutation__probability": 0.5}, "islands.mutation_probabilities sets"),
    ("sga", {"islands__migrants": 2}, "islands.count = 1: there is no migration"),
    ("sga", {"selection__tournament_size": 3},
     "selection.method = 'roulette' has no parameter 'tournament_size' (read by "
     "'tournament' only)"),
    ("imga", {"mutation__temperature_w": 0.5}, "no parameter 'temperature_w' (read by "
     "'segment_sa' only)"),
    ("iga_zhu", {"mutation__radius": 3}, "no parameter 'radius' (read by 'point_checked' "
     "only)"),
    ("iga_zhang", {"fitness__importance_ratios": [1.2, 1.4]},
     "fitness.method = 'iga_zhang' has no parameter 'importance_ratios' (read by 'agacd' "
     "only)"),
    ("agacd", {"fitness__window": True}, "waypoint paths"),
    ("sga", {"islands__count": 2, "islands__topology": "ring"},
     "islands.topology has no effect in 'sga': islands.migrants = 0"),
    ("sga", {"islands__count": 2, "islands__migrants": 1},
     "islands.migrants has no effect in 'sga': islands.topology = 'none'"),
])
def test_an_override_that_nothing_reads_is_refused(grid, monkeypatch, preset, overrides,
                                                   message):
    """As keyword overrides, as ``sets`` (the same values as TOML) and as sweep points,
    before anything compiles."""
    monkeypatch.setattr(runtime.programs, "compiled_programs",
                        lambda *a, **k: pytest.fail("compiled"))
    with pytest.raises(ParameterError, match=re.escape(message)):
        api.run(preset, grid, seeds=1, **SMALL, **overrides)
    sets = [f"{k.replace('__', '.')}={json.dumps(v)}" for k, v in overrides.items()]
    with pytest.raises(ParameterError, match=re.escape(message)):
        api.run(preset, grid, seeds=1, sets=sets, **SMALL)
    with pytest.raises(ParameterError, match=re.escape(message)):
        api.sweep(preset, grid, [{k.replace("__", "."): v for k, v in overrides.items()}],
                  seeds=1, **SMALL)


def test_an_unread_key_set_to_its_default_is_accepted():
    """Switching a feature off explicitly is not refused (notebook 04 runs MPMGA as one
    island with ``islands.topology = "none"``); a value that would matter is."""
    from jaxga.config.presets import load_preset

    ov = {"islands.count": 1, "islands.topology": "none", "islands.migrants": 0,
          "islands.crossover_probabilities": [0.5], "islands.mutation_probabilities": [0.5]}
    config = load_preset("mpmga", overrides=ov)
    engine.check_overrides_read(config, ov)
    config = load_preset("mpmga", overrides={**ov, "islands.migrants": 2})
    with pytest.raises(ParameterError, match="islands.migrants has no effect in 'mpmga'"):
        engine.check_overrides_read(config, ov)
    # AGACD's waypoint paths are never evaluated on the narrow window: False says so
    engine.check_overrides_read(load_preset("agacd", overrides={"fitness.window": False}),
                                ["fitness.window"])


def test_overrides_that_are_read_are_accepted_by_every_preset():
    """The refusal never hits a key the preset's stages read: every dynamic key each
    built-in preset (and variant) sets is read, and so is each fitness weight of its
    own objective, a rate of a non-adaptive operator, and migration settings of islands."""
    from jaxga.config.presets import _chain, load_preset
    from jaxga.config.schema import DEFAULTS

    for name in preset_names():
        variants = {v for _, _, vs in _chain(name) for v in vs}
        for variant in (None, *sorted(variants)):
            config = load_preset(name, variant=variant)
            unread = engine.unread_keys(config)
            method = config["fitness.method"]
            for k in engine.FITNESS_PARAMS[method]:
                assert f"fitness.{k}" not in unread
            set_dynamic = [k for k, v in config.items  # set to a value of its own
                           if SCHEMA[k].dynamic and v is not None
                           and (k not in DEFAULTS or v != DEFAULTS[k])]
            assert not [k for k in set_dynamic if k in unread], (name, variant)
            if config["islands.count"] > 1:
                assert "islands.migrants" not in unread and "islands.topology" not in unread


def test_a_config_preset_takes_sets_and_refuses_a_variant(grid, monkeypatch):
    """``sets`` apply to a :class:`Config` as to a preset name (they were silently
    dropped); a variant cannot apply to a Config that is already loaded."""
    from jaxga.config.presets import load_preset

    config = api.check_run(load_preset("agacd"), grid,
                           sets=["crossover.adaptive=false", "crossover.probability=0.8",
                                 "population.size=7"])
    assert not config["crossover.adaptive"] and config["crossover.probability"] == 0.8
    assert config["population.size"] == 7
    assert config == api.check_run("agacd", grid, sets=["crossover.adaptive=false",
                                                        "crossover.probability=0.8",
                                                        "population.size=7"])
    with pytest.raises(ParameterError, match="variant '50x50' given with a Config"):
        api.check_run(load_preset("agacd"), grid, variant="50x50")


def test_a_corner_rule_key_that_would_be_ignored_is_refused(grid):
    """A Grid keeps its own corner rule (``corner_rule=`` changes it): a preset key
    ``map.corner_rule`` that disagrees with it would be ignored, and so would one that
    disagrees with ``corner_rule=``; both are refused. One that agrees is accepted (the
    command line builds the Grid with it when given --start or --goal)."""
    assert grid.corner_rule == "free"
    for bad in ({"map__corner_rule": "strict"}, {"sets": ["map.corner_rule=strict"]}):
        with pytest.raises(ParameterError, match="map.corner_rule = 'strict' has no effect "
                                                 "with a Grid"):
            api.check_run("sga", grid, **bad)
    api.check_run("sga", grid, map__corner_rule="free")
    api.check_run("sga", grid, map__corner_rule="strict", corner_rule="strict")
    with pytest.raises(ParameterError, match="two corner rules given: 'free'"):
        api.check_run("sga", "classic_ga_gapp3_20x20", corner_rule="free",
                      map__corner_rule="strict")
    config = api.check_run("sga", "classic_ga_gapp3_20x20", map__corner_rule="strict")
    assert config["map.corner_rule"] == "strict"  # a map given by name reads it


def test_a_key_given_twice_with_two_values_is_refused(grid):
    """One value per key: ``generations=1`` with ``sets=["generations=3"]`` ran 3
    generations (the set won silently); the same value twice is harmless."""
    with pytest.raises(ParameterError, match="generations is given twice, as 1 and 3"):
        api.check_run("sga", grid, generations=1, sets=["generations=3"])
    with pytest.raises(ParameterError, match="crossover.probability is given twice"):
        api.check_run("sga", grid, crossover__probability=0.5,
                      sets=["crossover.probability=0.7"])
    with pytest.raises(ParameterError, match="mutation.probability is given twice"):
        api.check_run("sga", grid, sets=["mutation.probability=0.1",
                                         "mutation.probability=0.2"])
    api.check_run("sga", grid, generations=3, sets=["generations=3"])
    # the same value in another type is one value
    api.check_run("agacd", grid, fitness__importance_ratios=(1.2, 1.5),
                  sets=["fitness.importance_ratios=[1.2, 1.5]"])
    api.check_run("sga", grid, crossover__probability=np.float32(0.5),
                  sets=["crossover.probability=0.5"])
    import jax.numpy as jnp  # a 0-d JAX array is that value too (it was "not a number")

    api.check_run("sga", grid, crossover__probability=jnp.float32(0.5),
                  mutation__probability=np.array(0.25), sets=["crossover.probability=0.5"])


def test_keys_a_user_file_sets_are_checked_like_overrides(grid, tmp_path):
    """A user TOML file that sets a key its configuration never reads is refused as
    ``--set`` is; a copy of every built-in preset file is accepted with every variant."""
    from jaxga.config.presets import _chain, _preset_file

    user = tmp_path / "mine.toml"
    user.write_text('base = "agacd"\n[crossover]\nprobability = 0.8\n')
    with pytest.raises(ParameterError, match="mine.toml: crossover.probability has no "
                                             "effect in 'mine'"):
        api.check_run(str(user), grid)
    for name in preset_names():
        copy = tmp_path / f"copy_{name}.toml"
        copy.write_text(_preset_file(name).read_text(encoding="utf-8"))
        for variant in (None, *sorted({v for _, _, vs in _chain(name) for v in vs})):
            api.check_run(str(copy), grid, variant=variant)
    # a file's corner rule is a default, as a built-in preset's: another one replaces it
    copy = str(tmp_path / "copy_sga.toml")
    assert api.check_run(copy, "classic_ga_gapp3_20x20", corner_rule="strict")
    strict = load_map("classic_ga_gapp3_20x20", corner_rule="strict")
    assert api.check_run(copy, strict)
    # a file that builds on another is checked against its own configuration, not
    # against what the file below it set (the fixed rate of the sga copy, now adaptive)
    layered = tmp_path / "adaptive.toml"
    layered.write_text('base = "copy_sga.toml"\n[crossover]\nadaptive = true\n'
                       'pc_low = 0.6\npc_high = 0.8\n')
    assert api.check_run(str(layered), grid)["crossover.adaptive"]
    # a file may spell out a default it does not use (tournament_size = 2 under roulette)
    spelled = tmp_path / "spelled.toml"
    spelled.write_text('base = "sga"\n[selection]\ntournament_size = 2\n')
    api.check_run(str(spelled), grid)


def test_list_keys_take_tuples(grid):
    config = api.check_run("agacd", grid, fitness__importance_ratios=(1.2, 1.5))
    assert list(config["fitness.importance_ratios"]) == [1.2, 1.5]
    config = api.check_run("mpmga", grid, islands__crossover_probabilities=(0.5, 0.6, 0.7))
    assert list(config["islands.crossover_probabilities"]) == [0.5, 0.6, 0.7]


def test_a_fixed_rate_that_is_missing_is_named():
    """AGACD with its adaptive crossover switched off has no fixed rate to use: named
    before tracing (it was a KeyError from inside the traced program)."""
    with pytest.raises(ParameterError, match="needs crossover.probability .or "
                                             "islands.crossover_probabilities."):
        api.check_run("agacd", "classic_ga_gapp3_20x20", crossover__adaptive=False)
    with pytest.raises(ParameterError, match="chunks must be an integer"):
        api.check_run("sga", "classic_ga_gapp3_20x20", chunks=0)


def test_sweeping_a_structural_key_is_refused(grid):
    with pytest.raises(ParameterError, match="mutation.method"):
        api.sweep("sga", grid, [{"mutation.method": "one_point"}], seeds=1, **SMALL)
    with pytest.raises(ParameterError, match="crossover.probability"):
        api.sweep("sga", grid, [{"crossover.probability": 1.5}], seeds=1, **SMALL)


def test_a_sweep_point_too_small_for_its_migrants_is_refused(grid):
    """MPMGA's A island takes in 2 k migrants: a swept population.size below that is
    refused before anything compiles (the capacity of the largest point would fit)."""
    with pytest.raises(ParameterError, match="islands.migrants = 2 needs 4 .* has 3"):
        api.sweep("mpmga", grid, [{"population.size": 8}, {"population.size": 3}],
                  seeds=1, islands__migrants=2, **SMALL)


def test_compiled_programs_are_reused_across_maps_seeds_and_values(grid):
    api.run("sga", grid, seeds=[5, 6, 7], **SMALL)
    before = runtime.programs.compiled_programs.cache_info()
    other = random_map(20, 20, 0.25, 11, corner_rule="free")  # the canonical map's shape
    r = api.run("sga", other, seeds=[7, 8, 9], crossover__probability=0.5, **SMALL)
    after = runtime.programs.compiled_programs.cache_info()
    assert after.misses == before.misses and after.hits == before.hits + 1
    assert r.timing["compile_s"] < 1.0


def test_progress_is_reported_after_every_chunk_and_chunks_is_deprecated(grid):
    """Progress: the references, the compilation's steps (when it compiles), the
    initialisation, the evolution as it starts and after every call of the evolve chunk
    (25 generations; 60 = 25 + 25 + 10), the post-optimisation and the any-angle
    reference, so that a user always sees which phase is running; ``chunks`` changes
    nothing but warns."""
    kw = {**SMALL, "generations": 60}
    one = api.run("iga_zhang", grid, seeds=3, **kw)
    seen = []
    with pytest.warns(DeprecationWarning, match="chunks is ignored"):
        again = api.run("iga_zhang", grid, seeds=3, chunks=3,
                        progress=lambda stage, frac: seen.append((stage, frac)), **kw)
    # the stage is "compile" again while evolve and finish compile after init
    assert seen[:11] == [("references", 0.0), ("compile", 0.0), ("init", 0.0),
                         ("compile", 0.5), ("compile", 1.0), ("evolve", 0.0),
                         ("evolve", 25 / 60), ("evolve", 50 / 60), ("evolve", 1.0),
                         ("post", 0.0), ("post", 1.0)]
    assert [stage for stage, _ in seen[11:]] == ["any-angle"] * len(seen[11:])
    assert seen[11] == ("any-angle", 0.0) and seen[-1] == ("any-angle", 1.0)
    for field in ("cells", "length", "fitness", "convergence_generation"):
        np.testing.assert_array_equal(getattr(again, field), getattr(one, field))
    for h in ("best", "mean", "std"):
        np.testing.assert_array_equal(again.history[h], one.history[h])


def test_unreachable_goal_is_a_no_path_result():
    g = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    blocked = np.asarray(g.blocked).copy()
    gx, gy = g.goal_xy
    blocked[gy - 1:gy + 2, gx - 1:gx + 2] = True
    blocked[gy, gx] = False
    walled = g.replace(blocked=blocked)
    r = api.run("sga", walled, seeds=2, **SMALL)
    assert not r.success.any() and "unreachable" in r.reason
    assert r.to_json()["runs"][0]["path"] == []
    # strict JSON: no optimum is null, not Infinity
    doc = r.to_json()
    assert doc["optimum"] is None and doc["any_angle_optimum"] is None
    json.loads(json.dumps(doc, allow_nan=False))
    # the summary of a no-path result gives the reason and no table of NaNs
    text = r.summary()
    assert "success 0/2" in text and "unreachable" in text
    assert "no metrics: no seed found a path" in text and "nan" not in text
    assert {row[0] for row in r.summary_rows()} >= {"angle_sum", "turns", "gap"}
    assert all(math.isnan(v) for row in r.summary_rows() for v in row[1:])


def test_failed_seeds_are_missing_values_not_zeros():
    """A seed that found no path has NaN length, raw length, fitness and metrics, no
    path (None), a null fitness in the JSON and no part in the summary's statistics;
    the seeds that found one are unaffected (the canonical sga program, one attempt per
    initial path and no fallback: the random walk reaches the goal in a few of 60 attempts
    on gapp3, in none for seed 6)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InitialisationWarning)
        r = canonical.run("sga", [6, 7, 8], init__max_tries=1, init__fallback="none")
    ok = r.success
    assert ok.any() and (~ok).any(), ok
    for values in (r.length, r.raw_length, r.fitness, *r.metrics.values()):
        assert np.isnan(values[~ok]).all() and np.isfinite(values[ok]).all()
    assert all(r.path(i) is None and r.path(i, raw=True) is None for i in np.flatnonzero(~ok))
    assert all(r.path(i)[0] == (0, 0) for i in np.flatnonzero(ok))
    assert np.nanmean(r.length) == pytest.approx(r.length[ok].mean())
    doc = r.to_json()
    assert all(run["fitness"] is None and run["length"] is None
               for run, good in zip(doc["runs"], ok) if not good)
    json.dumps(doc, allow_nan=False)
    text = r.summary()
    assert f"success {int(ok.sum())}/3" in text and "nan" not in text


def test_start_equal_to_goal_has_gap_zero_without_warnings(grid):
    """The optimum is 0 when start == goal: the gap is 0, not 0 / 0."""
    same = grid.replace(goal=grid.start_xy)  # the 4-run (canonical) program of ``preset_run``
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = api.run("sga", same, seeds=3, **SMALL)
        rows = {row[0]: row for row in r.summary_rows()}
    assert r.success.all() and r.optimum == 0.0
    assert (r.length == 0).all() and (r.gap == 0).all() and (r.raw_gap == 0).all()
    assert rows["gap"][1:] == (0.0, 0.0, 0.0, 0.0)


def test_failure_reason_counts_the_seeds_and_names_an_initialiser_that_never_succeeded():
    from jaxga.config.presets import load_preset

    cfg = load_preset("mpmga", sets=["init.fallback=none"])
    fits = dict(capacity=80, shortest_cells=12)
    rate, made = np.array([0.2, 0.1, 0.3]), np.zeros(3, int)

    def reason(success, started, rate=rate, config=cfg, **kw):
        causes = api.failures.failure_causes(np.array(success), np.array(started), rate, made,
                                             config, **{**fits, **kw})
        assert (causes == "").tolist() == list(success)
        return api.failures.failure_reason(causes)

    assert reason([True, True, True], [True, True, True]) == ""
    some = reason([True, False, True], [True, True, True])
    assert some == ("no feasible path found by 1 of 3 seeds; 1 of them lost its best path "
                    "in the final feasibility check")
    none = reason([False, False, True], [False, True, True], rate=np.array([0.0, 0.1, 0.3]))
    assert none.startswith("no feasible path found by 2 of 3 seeds; 1 of them got no initial")
    assert "'intermittent_connect'" in none and "init.max_tries" in none
    assert "init.fallback = 'field_walk'" in none and "capacity" not in none
    # the capacity below the shortest path's cells is named instead
    small = reason([False, False, True], [False, False, True], capacity=10)
    assert small.startswith("no feasible path found by 2 of 3 seeds; 2 of them got no initial "
                            "path: population.capacity = 10 is probably too small")
    # with the fallback on, a seed without any path says that the fallback made none
    both = reason([False, True, True], [False, True, True],
                  config=load_preset("mpmga"))
    assert "and the fallback 'field_walk' made none either" in both


@pytest.mark.slow
def test_a_capacity_below_the_shortest_path_is_named_as_the_cause(grid):
    """Paths cannot hold the shortest path's cells: the reason says so, instead of
    sending the user to raise init.max_tries."""
    from jaxga.reference.optima import shortest_path

    cells = len(shortest_path(grid).path)
    r = api.run("sga", grid, seeds=2, population__capacity=cells - 1, **SMALL)
    assert not r.success.any()
    assert f"population.capacity = {cells - 1} is probably too small" in r.reason
    assert f"has {cells} cells" in r.reason and "init.max_tries" not in r.reason


def test_unfilled_initial_populations_are_warned_about_naming_the_budget(grid):
    # one attempt per individual on average: the random walk fills 1-3 of 60 slots here
    # (the canonical sga program: init.max_tries and init.fallback are dynamic)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = api.run("sga", grid, seeds=3, init__max_tries=1, init__fallback="none", **SMALL)
    short = (r.init_unfilled > 0) & (r.init_success_rate > 0)
    assert short.any() and r.success.all() and (r.init_fallback == 0).all()
    warned = [w for w in caught if issubclass(w.category, InitialisationWarning)]
    assert len(warned) == 1
    assert warned[0].filename == __file__  # points at the caller's line, not into jaxga
    text = str(warned[0].message)
    assert text.startswith(f"{int(short.sum())} of 3 runs started with ")
    assert f"of their {r.population} initial individuals copied" in text and r.population == 60
    assert "'random_walk'" in text and "init.max_tries = 1 " in text
    # the copies are valid individuals: every returned path is still feasible
    blocked = grid.blocked_np()
    for i in range(3):
        path = r.path(i)
        assert path[0] == grid.start_xy and path[-1] == grid.goal_xy
        assert all(clear_np(blocked, grid.corner_rule, p, q) for p, q in zip(path, path[1:]))


def test_the_fallback_fills_exactly_the_slots_the_initialiser_left_empty(grid):
    """The same runs with the fallback on (the default): no copies, no warning; the
    fallback made as many individuals as the initialiser left empty, and the result, its
    summary and its JSON say so."""
    with pytest.warns(InitialisationWarning, match="init.max_tries = 1 did not fill"):
        off = api.run("sga", grid, seeds=3, init__max_tries=1, init__fallback="none",
                      **SMALL)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InitialisationWarning)
        on = api.run("sga", grid, seeds=3, init__max_tries=1, **SMALL)
    np.testing.assert_array_equal(on.init_fallback, off.init_unfilled)
    assert (on.init_unfilled == 0).all() and on.init_fallback.sum() > 0
    np.testing.assert_array_equal(on.init_success_rate, off.init_success_rate)
    made = on.init_fallback[on.init_fallback > 0]
    count = str(made.min()) if made.min() == made.max() else f"{made.min()}-{made.max()}"
    assert on.population == 60
    assert (f"the fallback field_walk made {count} of 60 initial individuals in "
            f"{int((on.init_fallback > 0).sum())} of 3 seeds") in on.summary()
    runs = on.to_json()["runs"]
    assert [run["init_fallback"] for run in runs] == on.init_fallback.tolist()
    assert all(run["cause"] == "" for run in runs)


def test_unfilled_warning_only_for_runs_that_made_some_paths():
    from jaxga.config.presets import load_preset

    cfg = load_preset("mpmga")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        api.failures.warn_unfilled(np.array([0, 0]), np.array([0.3, 0.2]), 60, cfg)
        # no path at all is a failed run with a reason (failure_reason), not a warning
        api.failures.warn_unfilled(np.array([60, 0]), np.array([0.0, 0.2]), 60, cfg)
    with pytest.warns(InitialisationWarning, match=r"^2 of 3 runs started with 12-50 of their "
                      r"60 initial individuals copied: the initialiser 'intermittent_connect' "
                      r"succeeded in 1 % of its attempts, and init.max_tries = 20 "):
        api.failures.warn_unfilled(np.array([12, 60, 50]), np.array([0.015, 0.0, 0.005]), 60, cfg)


@pytest.mark.parametrize("t", [0, 1, 7, 50, 100])
def test_schedules_match_the_papers_formulas(t):
    assert math.isclose(float(schedules.agacd_crossover_decay(100)(t)), math.exp(-t / 100),
                        rel_tol=1e-5)
    assert math.isclose(float(schedules.agacd_mutation_growth(100)(t)), math.exp(t / 100),
                        rel_tol=1e-5)
    assert math.isclose(float(schedules.mpmga_temperature(2.0, 0.7)(t)), 2.0 * 0.7 ** t,
                        rel_tol=1e-5)
    with pytest.raises(ValueError):
        schedules.mpmga_temperature(1.0, 1.5)


def test_relative_gap_rounds_float32_noise_to_zero_but_keeps_real_gaps():
    """An optimal path summed in float32 can be 1e-8 below the optimum: its gap is 0, not
    -0.0000; real gaps (positive, or negative for waypoint paths) and failures are kept."""
    from jaxga.api import relative_gap

    gap = relative_gap(np.array([30.970598, 31.5, 29.0, 30.0]), 30.9706,
                       np.array([True, True, True, False]))
    assert gap[0] == 0.0 and not np.signbit(gap[0])
    assert gap[1] == pytest.approx(31.5 / 30.9706 - 1)
    assert gap[2] == pytest.approx(29.0 / 30.9706 - 1) and gap[2] < 0
    assert np.isnan(gap[3])


def test_clear_compiled_releases_the_programs_memory_mappings(grid):
    """Long sessions stay below Linux's vm.max_map_count (a segfault inside XLA)."""
    from tests.conftest import mapped_regions as regions

    if regions() is None:
        pytest.skip("needs /proc (Linux)")
    api.clear_compiled()
    before = regions()
    # the canonical 4-run sga program: after clear_compiled it is loaded again (from the
    # persistent compilation cache when there is one), which maps its kernels again
    api.run("sga", grid, seeds=3, **SMALL)
    compiled = regions()
    assert compiled > before + 300  # a few hundred kernels, ~3 regions each
    api.clear_compiled()
    assert regions() < before + 100


def test_run_blocks_divide_each_device_share_into_blocks_of_at_most_the_block():
    from jaxga._runtime.programs import run_blocks

    assert run_blocks(100, 1, 128) == 1  # fits one block
    assert run_blocks(1000, 1, 128) == 8  # 8 blocks of 125
    assert run_blocks(1000, 2, 128) == 4  # each device: 500 runs = 4 blocks of 125
    assert run_blocks(1024, 2, 128) == 4  # 4 blocks of 128
    assert run_blocks(997, 1, 128) == 1  # prime: no blocks of 64-128 runs
    assert run_blocks(1000, 2, 64) == 10  # 10 blocks of 50 (the default block)
    assert run_blocks(8, 4, 1) == 2
    for n, d in [(1000, 1), (1000, 2), (600, 2), (5000, 4)]:
        b = run_blocks(n, d, 128)
        assert (n // d) % b == 0 and n // d // b <= 128


def test_map_runs_in_blocks_equals_one_vmap():
    """Blocked ``lax.map`` over runs == ``vmap`` over runs, run by run, with pytree
    arguments, shared (None-axis) arguments and a static argument."""
    import jax
    import jax.numpy as jnp

    from jaxga._runtime.programs import map_runs

    def fn(key, shared, state, n):
        x = jax.random.uniform(key, (3,)) * shared["scale"] + state["a"]
        return {"x": x, "s": jnp.sum(state["b"]) * n}, jnp.argmax(x)

    n_runs = 12
    keys = jax.vmap(jax.random.PRNGKey)(jnp.arange(n_runs, dtype=jnp.uint32))
    shared = {"scale": jnp.float32(2.0)}
    state = {"a": jnp.arange(n_runs, dtype=jnp.float32),
             "b": jnp.arange(n_runs * 4, dtype=jnp.int32).reshape(n_runs, 4)}
    axes = (0, None, 0, None)
    ref = jax.vmap(fn, in_axes=axes)(keys, shared, state, 3)
    blocked = map_runs(fn, axes, n_runs, block=4)  # 3 blocks of 4
    got = jax.jit(blocked, static_argnums=(3,))(keys, shared, state, 3)
    for r, g in zip(jax.tree_util.tree_leaves(ref), jax.tree_util.tree_leaves(got)):
        np.testing.assert_array_equal(np.asarray(r), np.asarray(g))
    text = jax.jit(blocked, static_argnums=(3,)).lower(keys, shared, state, 3).as_text()
    assert "stablehlo.while" in text  # really computed block by block


@pytest.mark.parametrize("preset, overrides, words", [
    ("sga", {"mutation__method": "segment_sa"},
     ["mutation.temperature_c1 and mutation.temperature_w"]),
    ("mpmga", {"mutation__temperature_w": 0.0}, ["mutation.temperature_w", "(0, 1]"]),
    ("sga", {"crossover__adaptive": True}, ["crossover.pc_low and crossover.pc_high"]),
    ("agacd", {"fitness__importance_ratios": [1.0]}, ["2 entries", "[1.0]"]),
    ("agacd", {"fitness__importance_ratios": [1.2, 1.4, 2.0]}, ["2 entries"]),
    # islands of 8 (refused before anything compiles: no program of their own)
    ("mpmga", {"islands__migrants": 9, "population__size": 8},
     ["islands.migrants = 9", "needs 18", "has 8"]),
    ("mpmga", {"islands__migrants": 5, "population__size": 8},
     ["needs 10 individuals", "'mpmga' topology"]),
    ("mpmga", {"islands__count": 2}, ["needs islands.count = 3"]),
    ("iga_zhang", {"fitness__v_t": 0.0}, ["fitness.v_t", "> 0"]),
    ("mpmga", {"fitness__alpha": 0.0, "fitness__beta": 0.0}, ["same fitness"]),
    ("mpmga", {"fitness__alpha": 0.0, "fitness__c": 0.0}, ["every path would have fitness 0"]),
    ("imga", {"fitness__a": 0, "fitness__b": 0, "fitness__c": 0}, ["same fitness"]),
    ("iga_zhu", {"fitness__omega": 0, "fitness__c1": 0, "fitness__c2": 0, "fitness__c3": 0},
     ["fitness.omega and fitness.c1", "same fitness"]),
    ("iga_zhang", {"fitness__v_t": 2.0}, ["fitness.v_t = 2.0 is above fitness.v = 1.0"]),
    ("mpmga", {"fitness__smoothness_floor": 0.0}, ["fitness.smoothness_floor must be > 0"]),
    ("sga", {"generations": 2.7}, ["generations must be an integer"]),
    ("sga", {"generations": True}, ["generations must be an integer"]),
])
def test_inconsistent_parameters_are_refused_before_tracing(grid, monkeypatch, preset,
                                                            overrides, words):
    """Combinations of keys that an operator cannot use (each key valid on its own) give
    a ParameterError naming them, not an error from inside the traced program."""
    monkeypatch.setattr(runtime.programs, "compiled_programs",
                        lambda *a, **k: pytest.fail("compiled"))
    with pytest.raises(ParameterError) as err:
        api.run(preset, grid, seeds=1, **{**SMALL, **overrides})
    assert all(w in str(err.value) for w in words), str(err.value)


@pytest.mark.parametrize("call, words", [
    (lambda g: api.run("sga", g, seeds=1, sets=3), "sets must be 'key=value' strings"),
    (lambda g: api.run("sga", g, seeds=1, chunks="a"), "chunks must be an integer >= 1"),
    (lambda g: api.run("sga", g, seeds=1, chunks=0), "chunks must be an integer >= 1"),
    (lambda g: api.run("sga", g, seeds=1, chunks=2.5), "chunks must be an integer >= 1"),
    (lambda g: api.run("sga", g, seeds=1, progress=3), "progress must be a callable"),
    (lambda g: api.sweep("sga", g, 3), "points must be a list of mappings"),
    (lambda g: api.sweep("sga", g, [3]), "points must be a list of mappings"),
    (lambda g: api.sweep("sga", g, "crossover.probability=0.5"), "points must be a list"),
    (lambda g: api.sweep("sga", g, [{3: 3}]), "points must be a list of mappings"),
    (lambda g: api.run("sga", g, seeds=1, sets=b"x=1"), "sets must be 'key=value' strings"),
    (lambda g: jaxga_compare(["sga", "imga"], g, seeds=1, progress=3),
     "progress must be a callable"),
])
def test_wrong_python_types_are_refused_with_a_jaxga_error(grid, monkeypatch, call, words):
    """Options of the wrong type are named (ParameterError), not a TypeError from deep
    inside, and before anything compiles."""
    monkeypatch.setattr(runtime.programs, "compiled_programs",
                        lambda *a, **k: pytest.fail("compiled"))
    with pytest.raises(ParameterError, match=re.escape(words)):
        call(grid)


@pytest.mark.parametrize("seeds, words", [
    ([2**32], "[0, 2**32)"), ([-1, 3], "[0, 2**32)"), (2**32 + 1, "at most 2**32"),
    ([2**63], "[0, 2**32)"), ([2**70, 1], "[0, 2**32)"), ([1.5, 2], "must be integers"),
    ("ab", "a count or a list"),
    (2.0, "a count or a list"), ([[1, 2]], "a count or a list"),
    (True, "a count or a list"), (np.bool_(True), "a count or a list"),
    ([True, False], "must be integers"), (np.float32(2.0), "a count or a list"),
    ([np.int64(1), 2**70], "[0, 2**32)"), ([1, 2**70, 1.5], "must be integers"),
    ([3, 1, 3, 3], "seeds must be distinct: seed 3 is given 3 times"),
    (np.array([7, 7]), "seed 7 is given 2 times"),
    ([np.uint64(2**32 - 1), -1], "[0, 2**32)"),  # NumPy made them float64: "not integers"
    (jax.random.PRNGKey(7), "the shape of a raw PRNG key"),  # was run as seeds 0 and 7
    (jax.random.key_data(jax.random.key(0)), "the shape of a raw PRNG key"),
])
def test_seeds_outside_32_bits_are_refused(grid, seeds, words):
    """Seeds are 32-bit: 2**32 would silently repeat seed 0, -1 seed 2**32 - 1; seeds that
    are not integers are refused, not truncated (1.5 would have run seed 1). A repeated
    seed repeats its run exactly (a pseudo-replicate in every statistic): refused. A raw
    PRNG key is not two seeds."""
    with pytest.raises(JaxgaError, match=re.escape(words)):
        api.run("sga", grid, seeds=seeds, **SMALL)


def _plain_grid_off_the_map():
    return Grid(blocked=np.zeros((2, 2), bool), start=np.int32(99), goal=3).check_endpoints()


@pytest.mark.parametrize("call, error, words", [
    (lambda: api.run("x" * 5000, canonical.MAP, seeds=2), ParameterError,
     "unknown preset 'xxxx"),  # was OSError: File name too long
    (lambda: load_map("a\0b"), JaxgaError, "a file name cannot hold a NUL character"),
    (lambda: api.run("sga", "a\0b", seeds=2), JaxgaError, "cannot hold a NUL character"),
    (lambda: Grid.create(np.zeros((2, 2), dtype=[("a", int)])), JaxgaError,
     "must hold booleans or 0/1 values"),  # was TypeError from np.isin
    (lambda: Grid.create(np.zeros((2, 2), dtype="V4")), JaxgaError,
     "must hold booleans or 0/1 values"),
    (lambda: Grid.create(np.ma.masked_array(np.zeros((2, 2)), [[0, 1], [0, 0]])),
     JaxgaError, "a grid cannot be a masked array"),  # its mask was dropped
    (_plain_grid_off_the_map, JaxgaError, "start cell index 99 is off the 2 x 2 map"),
    (lambda: api.run("sga", canonical.MAP, seeds=2, crossover__probability=0.5,
                     crossover={"probability": 0.9}), ParameterError,
     "crossover.probability is given twice, as 0.5 and 0.9"),  # 0.9 was used silently
    (lambda: api.sweep("sga", canonical.MAP, [{"crossover__probability": 0.5,
                                               "crossover.probability": 0.9}], seeds=2),
     ParameterError, "crossover.probability is given twice, as 0.5 and 0.9"),
    (lambda: api.sweep("sga", canonical.MAP, [{"crossover.probability": 0.5}], seeds=2,
                       crossover__probability=0.9), ParameterError,
     "crossover.probability is set by a sweep point and by the call"),  # 0.9 was dropped
    (lambda: api.sweep(make_problem("sga", canonical.MAP), None, [{"generations": 10}],
                       seeds=2, generations=50), ParameterError,
     "generations is set by a sweep point and by the call"),  # 50 was dropped
    (lambda: Grid.create(np.zeros((5, 5), bool), start=np.array([[1], [2]])), JaxgaError,
     "start must be a pair of integers (x, y), got an array of shape (2, 1) and dtype int64"),
    (lambda: api.run("sga", np.zeros((20, 20)), seeds=2), JaxgaError,
     "got an array of shape (20, 20) and dtype float64; an array becomes a map through "
     "jaxga.Grid.create(blocked)"),  # its repr spanned 40 lines
    (lambda: Grid.create(np.zeros((5, 5), bool), start={3, 1}), JaxgaError,
     "start must be a pair of integers (x, y), got {1, 3}"),  # was read as (1, 3)
    (lambda: Grid.create(np.zeros((5, 5), bool), goal={3: 0, 1: 0}), JaxgaError,
     "goal must be a pair of integers"),  # its keys were the cell
    (lambda: api.run("sga", canonical.MAP, seeds={5, 1}), JaxgaError,
     "seeds must be a count or a list of integer seeds"),  # run i's seed: unknown
    (lambda: api.run("sga", canonical.MAP, seeds={1: 2, 3: 4}), JaxgaError,
     "seeds must be a count or a list"),
    (lambda: jaxga_replan(Grid.create(np.zeros((5, 5), bool)), [(0, 0), (1, 1), (2, 2)],
                          [(1, 1)], position=(0, 0), fallback="no"), ParameterError,
     "fallback must be True or False, got 'no'"),  # "no" was true
    (lambda: jaxga_replan(Grid.create(np.zeros((5, 5), bool)), [(0, 0), (1, 1), (2, 2)],
                          [(1, 1)], position=(0, 0), post=1), ParameterError,
     "post must be True or False, got 1"),
], ids=["long-preset-name", "nul-map", "nul-map-run", "structured", "void", "masked",
        "plain-grid", "two-spellings-run", "two-spellings-sweep", "point-and-override",
        "point-and-problem-generations",
        "array-endpoint", "array-as-map", "set-endpoint", "dict-endpoint",
        "set-seeds", "dict-seeds", "replan-fallback-word", "replan-post-int"])
def test_hostile_python_arguments_are_one_line_errors(call, error, words):
    """Arguments of the Python API that raised OSError, ValueError, TypeError or
    IndexError tracebacks: a JaxgaError of one short line."""
    with pytest.raises(error) as info:
        call()
    text = str(info.value)
    assert words in text and "\n" not in text and len(text) < 300, text


def test_a_numpy_scalar_budget_is_a_number_of_seconds():
    """np.float32(1) was refused where np.float64(1) was taken; a bool is not seconds."""
    from jaxga.api.runs import check_call_options

    for budget in (np.float32(1), np.float64(2.5), np.int64(3), 0, 1.5, None, "auto"):
        check_call_options(None, 1, None, budget)
    for bad in (np.bool_(True), True, np.float32("nan"), -1, "soon"):
        with pytest.raises(ParameterError, match="any_angle_budget must be"):
            check_call_options(None, 1, None, bad)


def test_a_request_whose_runs_cannot_fit_in_memory_is_refused(grid, monkeypatch):
    """A clear error before anything is allocated, instead of the process being killed,
    naming the size and what to change: where the outputs of every run beside one run
    computed at a time exceed the machine, or where not one run fits."""
    monkeypatch.setattr(runtime.memory, "physical_memory", lambda: int(2.25 * 2**30))
    # one run at a time: 1 GiB base, its state 8 x 60 x 160 int32 population cells
    # (307,200 bytes) and its init temporaries 12 x 38,400; every run's outputs 3 x 3
    # float32 history values, 2 int32 paths of 160 cells and 256 bytes (1,572 bytes):
    # (1.125 GiB - 1 GiB - 768,000) / 1,572 = 84,891 runs fit, 10**5 need 1.15 GiB
    with pytest.raises(ParameterError, match=r"100000 runs of a population of 60 on paths "
                       r"of 160 cells, 1 at a time, would need about 1\.15 GiB, more than "
                       r"half of the 2\.25 GiB this process may use: at most 84891 fit: run "
                       r"fewer seeds") as e:
        api.run("sga", grid, seeds=10**5, **SMALL)
    assert "\n" not in str(e.value)
    with pytest.raises(ParameterError, match="not one run fits: a smaller population.size"):
        api.run("sga", grid, seeds=2, population__size=100_000, population__capacity=4096,
                **SMALL)
    assert api.run("sga", grid, seeds=3, **SMALL).success.all()  # small calls still run


def test_runs_that_do_not_fit_together_run_in_groups_with_the_same_results(grid,
                                                                          monkeypatch):
    """Where a request's runs do not fit one call, they run as calls that do, one after
    another (each initialised, evolved and finished before the next): every seed's result
    is the one it has in a call of its own. 8 runs of sga's canonical problem where only
    4 fit at a time: two calls of 4 (the canonical program), against two requests of 4."""
    from jaxga._runtime import calls

    seeds = [11, 12, 13, 14, 15, 16, 17, 18]
    halves = [api.run("sga", grid, seeds=seeds[:4], **SMALL),
              api.run("sga", grid, seeds=seeds[4:], **SMALL)]
    # 4 runs held among 8 need 1 GiB + 4 x 307,200 + 8 x 1,572 + 4 x 460,800 bytes; 5 need
    # 768,000 more
    budget = 2**30 + 4 * 307_200 + 8 * 1_572 + 4 * 460_800 + 300_000
    monkeypatch.setattr(runtime.memory, "physical_memory", lambda: 2 * budget)
    layouts, stages = [], []
    real = calls.fitting_layout
    monkeypatch.setattr(calls, "fitting_layout",
                        lambda *a: layouts.append(real(*a)) or layouts[-1])
    got = api.run("sga", grid, seeds=seeds, progress=lambda s, f: stages.append((s, f)),
                  **SMALL)
    assert layouts == [(4, 2, 1)]  # 4 runs a call, 2 calls, 1 at a time
    evolve = [f for s, f in stages if s == "evolve"]
    assert evolve == sorted(evolve) and evolve[-1] == 1.0 and 0.5 in evolve
    np.testing.assert_array_equal(got.seeds, seeds)
    for name in ("cells", "n_cells", "raw_cells", "length", "fitness", "success",
                 "convergence_generation", "init_success_rate", "init_unfilled",
                 "initial_fitness", "generations_run"):
        np.testing.assert_array_equal(
            getattr(got, name), np.concatenate([getattr(h, name) for h in halves]), name)
    for key, values in got.history.items():
        np.testing.assert_array_equal(
            values, np.concatenate([h.history[key] for h in halves]), key)
    assert got.timing["evolve_s"] > 0 and got.timing["init_s"] > 0


def test_padded_calls_that_would_not_fit_run_without_their_padding(monkeypatch):
    """5 runs are one padded call of 32 on the CPU; where 32 runs of a large population
    would not fit, the 5 run as one call of 5; where 5 do not fit together either, calls
    of as many as fit, one at a time; where not one fits, one line."""
    from types import SimpleNamespace

    from jaxga._runtime.calls import fitting_layout, grouped_layout

    monkeypatch.setattr(runtime.memory, "physical_memory", lambda: 24 * 2**30)  # CI's machine
    big = SimpleNamespace(population=100_000, islands=1, capacity=160, generations=300)
    assert fitting_layout(big, 5, 1, (32, 1)) == (5, 1, 1)
    call_memory = runtime.memory.call_memory
    assert call_memory(big, 5, 5) < 12 * 2**30 < call_memory(big, 32, 32)
    small = SimpleNamespace(population=60, islands=1, capacity=160, generations=300)
    assert fitting_layout(small, 5, 1, (32, 1)) == (32, 1, 1)
    assert fitting_layout(small, 100, 1, (32, 4)) == (32, 4, 4)
    assert fitting_layout(small, 5, 1, (32, 1), padded=False) == (5, 1, 1)
    # 12 GiB - 1 GiB base = 9 runs of 100,000 x 160 cells (8 x 64 MB state, 12 x 64 MB
    # init temporaries each): 40 runs as 5 calls of 8, one at a time
    assert runtime.memory.runs_that_fit(big, 12 * 2**30) == 9
    assert fitting_layout(big, 40, 1, (64, 1)) == (8, 5, 1)
    assert grouped_layout(big, 41, 1) == (9, 5, 1)  # 5 calls of 9, the last with 4 padded
    assert grouped_layout(big, 41, 2) == (4, 6, 1)  # 6 calls of 2 x 4 devices: 8 at most
    assert grouped_layout(big, 3, 1) == (3, 1, 1)
    huge = SimpleNamespace(population=2_000_000, islands=1, capacity=160, generations=300)
    with pytest.raises(ParameterError, match="not one run fits"):
        fitting_layout(huge, 2, 1, (4, 1))


def test_an_empty_corner_rule_is_refused_not_replaced_by_the_presets(grid):
    with pytest.raises(JaxgaError, match="corner"):
        api.run("sga", "classic_ga_gapp3_20x20", seeds=1, corner_rule="", **SMALL)


def test_integer_types_are_accepted_for_seeds_generations_and_endpoints(grid):
    """numpy and JAX integers, arrays of seeds and one-pass iterables keep working."""
    import jax.numpy as jnp

    # three runs each: the module's canonical sga program (``preset_run``), compiled once
    r = api.run("sga", grid.replace(start=iter(grid.start_xy)), seeds=np.arange(3),
                generations=jnp.int32(3))
    assert r.generations == 3 and list(r.seeds) == [0, 1, 2] and r.success.all()
    # a 0-d integer array is a count: the same three runs
    again = api.run("sga", grid, seeds=jnp.int32(3), **SMALL)
    assert list(again.seeds) == [0, 1, 2] and np.array_equal(again.cells, r.cells)
    mixed = api.run("sga", grid, seeds=np.array([0, np.int64(1), np.int32(2)], dtype=object),
                    **SMALL)
    assert list(mixed.seeds) == [0, 1, 2] and np.array_equal(mixed.cells, r.cells)
    # numpy scalars as configuration values (a sweep built with numpy gives them)
    same = api.run("sga", grid, seeds=3, population__size=np.int64(60), generations=3,
                   init__max_tries=np.int32(40), crossover__probability=np.float64(0.5))
    assert same.config["population.size"] == 60 and same.success.all()
    assert type(same.config["population.size"]) is int


def test_sweep_capacity_must_be_an_integer_and_no_path_sweeps_check_memory(grid, monkeypatch):
    with pytest.raises(ParameterError, match="population_capacity must be an integer"):
        api.sweep("sga", grid, [{"population.size": 4}], seeds=1, population_capacity=9.7,
                  **SMALL)
    # an unreachable goal: no runs, but the per-run results are still allocated
    blocked = np.asarray(grid.blocked).copy()
    gx, gy = grid.goal_xy
    blocked[max(gy - 1, 0):gy + 2, max(gx - 1, 0):gx + 2] = True
    blocked[gy, gx] = False
    walled = grid.replace(blocked=blocked)
    monkeypatch.setattr(runtime.memory, "physical_memory", lambda: 2**30)
    with pytest.raises(ParameterError, match="GiB for their results"):  # 256 bytes a run
        api.run("sga", walled, seeds=10**7, **SMALL)
    assert api.run("sga", walled, seeds=10**6, **SMALL).seeds.size == 10**6  # 0.24 GiB
    assert "unreachable" in api.run("sga", walled, seeds=2, **SMALL).reason
    # a no-path result records the capacity asked for, as a run does
    assert api.run("sga", walled, seeds=2, population_capacity=80,
                   **SMALL).population_capacity == 80
    assert [r.population_capacity for r in api.sweep(
        "sga", walled, [{"population.size": 4}, {"population.size": 6}], 1, **SMALL)] == [6, 6]


def test_the_exact_fitness_optimum_refuses_what_a_run_refuses(grid):
    """``jaxga.reference.fitness.fitness_optimum`` (``jaxga optimum --preset``) checks
    the weights as a run does: a zero smoothness floor divided by zero there."""
    from jaxga.config.presets import load_preset

    config = load_preset("mpmga", overrides={"fitness.smoothness_floor": 0.0})
    with pytest.raises(ParameterError, match="smoothness_floor must be > 0"):
        fitness_optimum(grid, config)
    with pytest.raises(ParameterError, match="above fitness.v"):
        fitness_optimum(grid, "iga_zhang", a=2.0, v=1.0, v_t=3.0, r=0.5)
    assert fitness_optimum(grid, "iga_zhang", a=2.0, v=1.0, v_t=1.0, r=0.5).found
    # weights left out are the objective's defaults, not 0: Zhang's v_t 0.5 is above a
    # v of 0.3; Zhu's omega = 0 keeps the default turn penalties c1-c3 (1, 2, 3)
    with pytest.raises(ParameterError, match="fitness.v_t = 0.5 is above fitness.v = 0.3"):
        fitness_optimum(grid, "iga_zhang", v=0.3)
    assert fitness_optimum(grid, "iga_zhu", omega=0.0).found
    # a floor that the method does not use is not checked
    from jaxga.engine import check_combination

    check_combination(load_preset("sga", overrides={"fitness.smoothness_floor": 0.0}))


def test_a_grid_made_with_the_plain_constructor_is_checked(monkeypatch):
    """``Grid(blocked=..., start=..., goal=...)`` skips ``Grid.create``'s checks; ``run``
    applies them (0/1 floats are a valid map, as for ``create``)."""
    import jax.numpy as jnp

    from jaxga import Grid
    from jaxga.core.errors import EndpointError

    monkeypatch.setattr(runtime.programs, "compiled_programs",
                        lambda *a, **k: pytest.fail("compiled"))
    cases = [
        (Grid(blocked=jnp.zeros((5, 5), bool), start=jnp.int32(0), goal=jnp.int32(25)),
         EndpointError, "goal cell index 25 is off the 5 x 5 map"),
        (Grid(blocked=jnp.zeros((5, 5), bool), start=jnp.float32(1.5), goal=jnp.int32(24)),
         JaxgaError, "start must be one integer cell index"),
        (Grid(blocked=jnp.full((5, 5), 0.5), start=jnp.int32(0), goal=jnp.int32(24)),
         JaxgaError, "booleans or 0/1"),
        (Grid(blocked=jnp.zeros(5, bool), start=jnp.int32(0), goal=jnp.int32(4)),
         JaxgaError, "2-D array"),
    ]
    for g, error, words in cases:
        with pytest.raises(error, match=words):
            api.run("sga", g, seeds=1, **SMALL)
    g = Grid(blocked=jnp.zeros((5, 5)), start=jnp.int32(0), goal=jnp.int32(24))
    assert g.validated().blocked.dtype == bool and g.validated().goal_xy == (4, 4)


def test_a_map_info_keeps_the_map_name_with_its_endpoints(grid):
    """``run(preset, load_map_info(name, start=..., goal=...))``: the runs of the Grid it
    holds, under the map's name (a Grid alone is "grid")."""
    from pathlib import Path

    from jaxga.maps import MapInfo

    info = MapInfo(name="ten", path=Path("ten.txt"), format="01", builtin=False, grid=grid)
    named = api.run("sga", info, seeds=3, **SMALL)
    plain = api.run("sga", grid, seeds=3, **SMALL)
    assert named.map_name == "ten" and named.to_json()["map"] == "ten"
    assert plain.map_name == "grid" and "on ten (corner rule 'free')" in named.summary()
    assert np.array_equal(named.cells, plain.cells)


@pytest.mark.slow
def test_the_field_repair_reaches_the_operators_that_repair(grid):
    """``repair.fallback = "field"`` in iga_zhu (column crossover, range mutation): the
    same runs fail fewer crossovers and mutations, every path stays feasible; in sga
    (no such operator) the key is refused as having no effect."""
    kw = dict(generations=6)  # the canonical iga_zhu program; the repair is compiled in
    plain = api.run("iga_zhu", grid, seeds=3, **kw)
    repaired = api.run("iga_zhu", grid, seeds=3, repair__fallback="field", **kw)
    assert repaired.success.all()
    # crossovers: none fails; mutations: only Zhu's one-point ones (no candidate cell)
    assert plain.failures[:, 0].sum() > 0 and repaired.failures[:, 0].sum() == 0
    assert repaired.failures[:, 1].sum() < plain.failures[:, 1].sum()
    with pytest.raises(ParameterError, match="repair.fallback has no effect in 'sga'"):
        api.run("sga", grid, seeds=1, repair__fallback="field", **SMALL)


def test_run_and_sweep_take_one_list_of_options(monkeypatch):
    """``run`` and ``sweep`` take the same keyword options (RUN_OPTIONS, read from
    ``run``'s signature) with the same defaults, and ``run`` passes each on."""
    import inspect

    from jaxga.api import runs

    def keyword_only(fn):
        return {n: p.default for n, p in inspect.signature(fn).parameters.items()
                if p.kind is inspect.Parameter.KEYWORD_ONLY}

    assert tuple(keyword_only(api.run)) == api.RUN_OPTIONS
    assert keyword_only(api.sweep) == keyword_only(api.run)
    assert "generations" in api.RUN_OPTIONS and "seeds" not in api.RUN_OPTIONS
    calls = []
    monkeypatch.setattr(runs, "sweep", lambda *a, **k: calls.append((a, k)) or ["result"])
    given = {name: object() for name in api.RUN_OPTIONS}
    assert api.run("sga", "m", 7, **given, population__size=9) == "result"
    assert calls == [(("sga", "m", [{}], 7), {**given, "population__size": 9})]


def test_xlas_account_of_a_programs_buffers_is_checked_before_it_runs(monkeypatch):
    """The compiled programs' own account (temporaries, every call's output) over half
    the machine: one line naming the program, before anything of it is allocated."""
    from types import SimpleNamespace

    monkeypatch.setattr(runtime.memory, "physical_memory", lambda: 8 * 2**30)

    def program(temp_gib: float):
        return SimpleNamespace(output_size_in_bytes=2**28, argument_size_in_bytes=2**20,
                               temp_size_in_bytes=int(temp_gib * 2**30))

    # 1 GiB base, 4 calls' outputs of 0.25 GiB, one call's temporaries
    runtime.memory.check_compiled_memory({"init": program(1.0), "evolve": program(1.5)}, 4, 20)
    with pytest.raises(ParameterError, match=r"20 runs in 4 call\(s\) would need about "
                       r"5\.0 GiB in their evolve program .* 8\.00 GiB this process") as e:
        runtime.memory.check_compiled_memory({"init": program(1.0), "evolve": program(3.0)},
                                         4, 20)
    assert "\n" not in str(e.value)


def test_a_device_with_less_memory_than_its_host_bounds_the_calls(monkeypatch):
    """Off the CPU the runs live in the device's own memory: a GPU of 4 GiB on a host of
    64 GiB bounds a call by 80 % of the GPU's (the lower bound), and a refusal names it."""
    from types import SimpleNamespace

    monkeypatch.setattr(runtime.memory, "physical_memory", lambda: 64 * 2**30)
    monkeypatch.setattr(runtime.memory, "device_memory", lambda: (4 * 2**30, 1, "Tesla T4"))
    room, words = runtime.memory.budget()
    assert room == int(0.8 * 4 * 2**30)
    assert words == "more than 80% of the 4.00 GiB of a device's own memory (Tesla T4)"
    account = SimpleNamespace(output_size_in_bytes=2**28, argument_size_in_bytes=0,
                              temp_size_in_bytes=2**30)
    runtime.memory.check_compiled_memory({"evolve": account}, 4, 20)  # 3 GiB: fits 3.2
    with pytest.raises(ParameterError, match=r"about 3\.5 GiB in their evolve program .*"
                       r"a device's own memory \(Tesla T4\): run fewer seeds"):
        runtime.memory.check_compiled_memory({"evolve": account}, 6, 30)
    # four such devices hold a call four times as large, but XLA's account of a program
    # sharded over them is one device's: that is checked against one device
    monkeypatch.setattr(runtime.memory, "device_memory", lambda: (4 * 2**30, 4, "Tesla T4"))
    assert runtime.memory.budget()[0] == int(0.8 * 16 * 2**30)
    assert runtime.memory.budget(per_device=True)[0] == int(0.8 * 4 * 2**30)
    with pytest.raises(ParameterError, match="a device's own memory"):
        runtime.memory.check_compiled_memory({"evolve": account}, 6, 30)
    monkeypatch.setattr(runtime.memory, "device_memory", lambda: (256 * 2**30, 1, "H200"))
    assert runtime.memory.budget()[0] == 32 * 2**30  # the host's half is lower here


def test_device_memory_reads_the_default_devices_allocator_limit(monkeypatch):
    """None on the CPU (its runs use the host's memory, physical_memory); elsewhere one
    device's ``bytes_limit`` and how many local devices there are, None where a device
    gives none."""
    from types import SimpleNamespace

    import jax

    assert runtime.memory.device_memory() is None  # the suite runs on the CPU
    gpu = SimpleNamespace(device_kind="FakeGPU",
                          memory_stats=lambda: {"bytes_limit": 12 * 2**30, "bytes_in_use": 5})
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    monkeypatch.setattr(jax, "local_devices", lambda: [gpu, gpu])
    monkeypatch.setattr(jax, "local_device_count", lambda: 2)
    assert runtime.memory.device_memory() == (12 * 2**30, 2, "FakeGPU")
    for stats in (lambda: None, lambda: {}, lambda: {"bytes_limit": 0}, lambda: 1 / 0):
        gpu.memory_stats = stats
        assert runtime.memory.device_memory() is None


def test_a_device_out_of_memory_is_one_line_naming_it(grid, monkeypatch, capsys):
    """XLA's RESOURCE_EXHAUSTED while the runs compute (a GPU whose memory the estimate
    overrated): a DeviceMemoryError of one line naming the device and what to make
    smaller, in Python and on the command line (exit 2), not XLA's many-line traceback."""
    import jax

    from jaxga.api import runs as runs_module
    from jaxga.cli import main
    from jaxga.core.errors import DeviceMemoryError

    def exhausted(*args, **kwargs):
        raise jax.errors.JaxRuntimeError(
            "RESOURCE_EXHAUSTED: Out of memory while trying to allocate 17179869184 bytes."
            "\nBufferAssignment OOM Debugging.\nBufferAssignment stats: ...")

    monkeypatch.setattr(runs_module, "_sweep", exhausted)
    with pytest.raises(DeviceMemoryError) as e:
        api.run("sga", grid, seeds=2, **SMALL)
    text = str(e.value)
    assert text.startswith("the cpu device (cpu) ran out of memory (RESOURCE_EXHAUSTED: "
                           "Out of memory while trying to allocate 17179869184 bytes.)")
    assert "run fewer seeds" in text and "\n" not in text
    assert main(["run", "--preset", "sga", "--map", canonical.MAP, "--seeds", "2",
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxga: error: the cpu device (cpu) ran out of memory")
    assert err.count("\n") == 1


@pytest.mark.slow  # compiles a program of 5 runs
def test_padded_calls_xla_says_would_not_fit_run_without_their_padding(grid, monkeypatch):
    """Where XLA's account of the padded call exceeds the machine, the same runs run as
    one call without padding (a program of their own size): the same results."""
    from jaxga.api import runs as runs_module

    want = api.run("sga", grid, seeds=5, **SMALL)
    real, seen = runs_module.check_compiled_memory, []

    def refuse_padded(stats, calls, n_runs):
        seen.append(n_runs)
        if len(seen) == 1:
            raise ParameterError("the padded call would not fit")
        return real(stats, calls, n_runs)

    monkeypatch.setattr(runs_module, "check_compiled_memory", refuse_padded)
    api.clear_compiled()
    got = api.run("sga", grid, seeds=5, **SMALL)
    assert len(seen) >= 2
    np.testing.assert_array_equal(got.cells, want.cells)
    np.testing.assert_array_equal(got.history["best"], want.history["best"])


def test_a_problem_checked_once_runs_as_its_preset_and_map(grid):
    """``jaxga.problem`` loads and checks a preset on a map once; ``run``, ``sweep`` and
    ``GA`` take it in place of the preset and the map (same results, nothing loaded
    again); anything that would change it is refused in one line."""
    import jaxga

    problem = jaxga.problem("sga", grid, crossover__probability=0.7, **SMALL)
    assert isinstance(problem, jaxga.Problem) and problem.grid.shape == grid.shape
    assert problem.config["crossover.probability"] == 0.7
    want = api.run("sga", grid, seeds=3, crossover__probability=0.7, **SMALL)
    got = api.run(problem, seeds=3)
    np.testing.assert_array_equal(got.cells, want.cells)
    np.testing.assert_array_equal(got.fitness, want.fitness)
    (point,) = api.sweep(problem, None, [{}], seeds=3)
    np.testing.assert_array_equal(point.cells, want.cells)
    ga = jaxga.GA(problem)
    assert ga.config == problem.config and ga.map_name == problem.map_name
    assert api.run(problem, seeds=1, generations=1).generations == 1
    for extra, words in (({"grid": grid}, "grid given with a Problem"),
                         ({"mutation__probability": 0.1}, "mutation__probability given"),
                         ({"sets": ["fitness.method=imga"]}, "sets given")):
        with pytest.raises(ParameterError, match=words) as e:
            api.run(problem, seeds=1, **extra)
        assert "jaxga.problem" in str(e.value)
    with pytest.raises(ParameterError, match="a map is needed"):
        api.run("sga", seeds=1)
