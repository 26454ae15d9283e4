"""The engine end to end on the canonical problems (tests/canonical.py): every reported path
feasible, same seed same run; and the engine's stages on small maps of their own."""

from __future__ import annotations

import numpy as np
import pytest

import jaxga._runtime as runtime
from jaxga.maps import load_map, random_map
from jaxga.operators.guide import with_guide
from jaxga.reference.any_angle import any_angle_shortest_path
from jaxga.reference.optima import clear_np
from tests import canonical

# the engine's generation, islands and migration in depth (each preset's run: test_api)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def tiny_runs():
    # the canonical sga program (tests/canonical.py), shared with test_api and the docs
    grid = load_map(canonical.MAP)
    a = canonical.run("sga", [0, 1, 2], generations=3)
    b = canonical.run("sga", [9, 2, 5], generations=3)
    return grid, a, b


def test_reported_paths_are_feasible_and_never_below_the_optimum(tiny_runs):
    grid, a, _ = tiny_runs
    blocked = grid.blocked_np()
    bound = any_angle_shortest_path(grid).length
    assert a.success.any()
    for i in np.flatnonzero(a.success):
        path = a.path(i)
        assert path[0] == grid.start_xy and path[-1] == grid.goal_xy
        assert all(clear_np(blocked, grid.corner_rule, p, q) for p, q in zip(path, path[1:]))
        assert a.length[i] >= bound - 1e-5
        raw = a.path(i, raw=True)
        assert all(max(abs(p[0] - q[0]), abs(p[1] - q[1])) == 1 for p, q in zip(raw, raw[1:]))
    assert a.history["best"].shape == (3, 3)
    assert np.all(a.history["mean"] <= a.history["best"] * (1 + 1e-6))  # best >= the mean
    assert np.all(a.initial_fitness <= a.history["best"][:, 0])


def test_a_seed_gives_the_same_run_whichever_runs_share_its_batch(tiny_runs):
    """Seed 2 third in a batch with seeds 0 and 1, and second between seeds 9 and 5: the
    same run (a run alone against blocks of one: the device-count test below)."""
    _, a, b = tiny_runs
    assert a.success[2] == b.success[1]
    assert np.array_equal(a.cells[2], b.cells[1])
    for h in ("best", "mean", "std"):
        assert np.array_equal(a.history[h][2], b.history[h][1])


def test_finish_program_equals_its_functions_compiled_with_xla_defaults():
    """The finish program is compiled with other XLA options
    (``runtime.programs.FINISH_COMPILER_OPTIONS``, the older fusion emitters): its post-optimised
    paths and every reported length and metric are bit for bit those of the same
    functions compiled with XLA's defaults, on agacd's greedy shortcut post-optimisation."""
    import jax
    import jax.numpy as jnp

    from jaxga.core import objectives
    from jaxga.operators import postprocess as post

    assert runtime.programs.FINISH_COMPILER_OPTIONS == {"xla_cpu_use_fusion_emitters": False}
    grid = load_map(canonical.MAP)
    r = canonical.run("agacd", 3, generations=3)  # the canonical agacd program
    assert r.success.any()

    @jax.jit
    def reference(c, n):
        opt_c, opt_n = post.shortcut_greedy(grid, c, n)
        both = jax.vmap(lambda c, n: (objectives.path_length(grid, c, n),
                                      objectives.metrics(grid, c, n)))(
            jnp.stack([c, opt_c]), jnp.stack([n, opt_n]))
        return opt_c, opt_n, both

    for i in np.flatnonzero(r.success):
        opt_c, opt_n, (lengths, metrics) = reference(jnp.asarray(r.raw_cells[i]),
                                                     jnp.asarray(r.raw_n_cells[i]))
        assert int(opt_n) == r.n_cells[i]
        assert np.array_equal(np.asarray(opt_c), r.cells[i])
        assert np.asarray(lengths).tolist() == [r.raw_length[i], r.length[i]]
        for k, v in metrics._asdict().items():
            assert np.asarray(v).tolist() == [r.raw_metrics[k][i], r.metrics[k][i]], k


_DEVICE_SCRIPT = """
import json, jax
from jaxga import api
import jaxga._runtime as runtime
from jaxga.maps import random_map
if jax.device_count() > 1:  # and each device computes its runs one block at a time
    runtime.programs.RUN_BLOCK = runtime.programs.INIT_RUN_BLOCK = 1
g = random_map(10, 10, 0.2, 3, corner_rule="free")
r = api.run("sga", g, seeds=21, population__size=8, generations=3, init__max_tries=50)
n = 21 if jax.device_count() == 1 else 24
blocks = runtime.programs.run_blocks
print(json.dumps({"devices": jax.device_count(), "blocks": blocks(n, jax.device_count()),
                  "init_blocks": blocks(n, jax.device_count(), runtime.programs.INIT_RUN_BLOCK),
                  "cells": r.cells.tolist(), "raw": r.raw_cells.tolist(),
                  "fitness": r.fitness.tolist(), "length": r.length.tolist(),
                  **{h: r.history[h].tolist() for h in ("best", "mean", "std")}}))
"""


def test_results_do_not_depend_on_the_device_count():
    """Seeds sharded over 4 forced host devices (21 seeds padded to 24), each device
    computing its runs one at a time (``runtime.programs.map_runs``), == one device, one ``vmap`` of
    21 (initialised in 3 blocks of 7, ``runtime.programs.INIT_RUN_BLOCK``): the same paths and the
    same float bits for every reported value (sums in a fixed order,
    ``jaxga._batching.numerics``)."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = str(Path(__file__).resolve().parents[2])
    out = []
    for n in (1, 4):
        env = dict(os.environ, PYTHONPATH=root,
                   XLA_FLAGS=f"--xla_force_host_platform_device_count={n}")
        proc = subprocess.run([sys.executable, "-c", _DEVICE_SCRIPT], env=env, cwd=root,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        out.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    assert [o["devices"] for o in out] == [1, 4]
    assert [o["blocks"] for o in out] == [1, 6]
    assert [o["init_blocks"] for o in out] == [3, 6]  # one device: 3 blocks of 7 runs
    for field in ("cells", "raw", "fitness", "length", "best", "mean", "std"):
        np.testing.assert_array_equal(out[0][field], out[1][field], err_msg=field)  # NaN == NaN


@pytest.mark.parametrize("rule", ["free", "no_squeeze", "strict"])
def test_population_waypoint_feasibility_equals_the_per_path_check(rule):
    """The engine's three-tier check (single steps by cell lookups, the bounded test
    gathered for spans 2-4, the full test gathered for longer ones) gives exactly
    ``paths.is_feasible`` on random waypoint paths with every kind of segment: repeated
    nodes, straight and diagonal steps (corner rule), short and long hops, blocked and
    off-map cells, and padding."""
    import jax
    import jax.numpy as jnp

    from jaxga.core.paths import is_feasible
    from jaxga.engine import SHORT_SPAN, waypoints_feasible

    grid = random_map(12, 12, 0.25, 5, corner_rule=rule)
    rng = np.random.default_rng(len(rule))
    p, cap, w = 400, 5, 12
    # random walks whose hops are 0-1 cells (most), 2-4 or up to 9 cells along each axis
    size = rng.choice([1, 4, 9], (p, cap - 1), p=[0.6, 0.25, 0.15])
    hop = rng.integers(-size[..., None], size[..., None] + 1, (p, cap - 1, 2))
    xy = np.concatenate([rng.integers(0, w, (p, 1, 2)), hop], axis=1).cumsum(axis=1)
    xy = np.clip(xy, 0, w - 1)
    cells = (xy[..., 1] * w + xy[..., 0]).astype(np.int32)
    off = rng.random((p, cap)) < 0.01
    cells[off] = rng.choice([-1, w * w], int(off.sum()))
    length = rng.integers(1, cap + 1, p).astype(np.int32)
    got = jax.jit(waypoints_feasible)(grid, jnp.asarray(cells), jnp.asarray(length))
    # the per-path check compiled too (op by op it compiled ~90 programs of its own)
    want = jax.jit(jax.vmap(is_feasible, (None, 0, 0)))(grid, jnp.asarray(cells),
                                                         jnp.asarray(length))
    assert np.array_equal(np.asarray(got), np.asarray(want))
    # every tier is exercised, with both outcomes overall
    a, b = cells[:, :-1], cells[:, 1:]
    span = np.maximum(abs(a % w - b % w), abs(a // w - b // w))
    valid = np.arange(cap - 1)[None, :] < length[:, None] - 1
    for lo, hi in [(0, 0), (1, 1), (2, SHORT_SPAN), (SHORT_SPAN + 1, w)]:
        assert np.sum(valid & (span >= lo) & (span <= hi)) > 20, (lo, hi)
    assert 50 < int(np.sum(want)) < p - 50


def test_adaptive_generation_equals_its_straight_line_composition():
    """With adaptive mutation (AGACD) a generation evaluates the crossed population, mutates
    with probabilities from that fitness, and evaluates again; the engine runs the two
    evaluations as the two steps of one loop. Its islands and failure counts equal the
    stages called one after the other, for two generations of two runs."""
    import functools

    import jax
    import jax.numpy as jnp

    from jaxga.config.presets import load_preset
    from jaxga.core.paths import Population
    from jaxga.engine import build
    from jaxga.engine import evolution as E

    grid = random_map(10, 10, 0.2, 3, corner_rule="free")
    algo, params = build(load_preset("agacd", overrides={
        "population.size": 16, "generations": 3, "init.max_tries": 40,
        # wide adaptive ranges: the gates then depend on which fitness the mutation reads
        "crossover.pc_low": 0.9, "crossover.pc_high": 1.0,
        "mutation.pm_low": 0.0, "mutation.pm_high": 1.0}), grid)
    assert algo.get("mutation.adaptive")

    def straight(key, isl, t):
        active = E._active(algo, params)
        fit_fn = E.fitness_function(algo, params)
        t = t + 1  # the papers' iteration (AGACD eq. 27, 29): 1 in the first generation
        k_sel, k_cx, k_mu, k_si = jax.random.split(key, 4)
        idx = E._select(algo, k_sel, isl.fitness, active)
        pop = Population(isl.cells[idx], isl.length[idx])
        pop, f_cx = E._crossover(algo, k_cx, grid, pop, isl.fitness[idx], active, t, params,
                                 fit_fn)
        fitness, _ = E.evaluate(algo, grid, params, pop.cells, pop.length, active)
        pop, f_mu = E._mutation(algo, k_mu, grid, pop, fitness, active, t, params, fit_fn)
        pop, f_si = E._simplify(algo, k_si, grid, pop, params)
        f, feas = E.evaluate(algo, grid, params, pop.cells, pop.length, active)
        return E.IslandState(pop.cells, pop.length, f, feas), jnp.stack([f_cx, f_mu, f_si])

    one = functools.partial(E.island_generation, algo, grid=grid, params=params)
    looped = jax.jit(lambda k, s, t: one(key=k, isl=s, t=t))
    straight = jax.jit(straight)
    init = jax.jit(lambda k: E.init_state(algo, k, with_guide(grid), params)[0])
    for r in range(2):
        state = init(jax.random.PRNGKey(r))
        isl = jax.tree_util.tree_map(lambda x: x[0], state.islands)
        for t in range(2):
            key = jax.random.fold_in(jax.random.PRNGKey(10 + r), t)
            got = looped(key, isl, jnp.int32(t))
            want = straight(key, isl, jnp.int32(t))
            for g, w in zip(jax.tree_util.tree_leaves(got), jax.tree_util.tree_leaves(want)):
                np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
            isl = got[0]
        assert not np.array_equal(np.asarray(isl.cells), np.asarray(state.islands.cells[0]))


@pytest.mark.parametrize("preset", ["agacd", "mpmga"])
def test_the_rate_rules_and_operators_see_the_papers_iteration(monkeypatch, preset):
    """AGACD eq. 27 and 29 and MPMGA eq. 17 take "the current number of iterations" t,
    1 in the first generation; jaxga's generation counter starts at 0. The crossover
    and mutation (their rates and bindings: MPMGA's temperature) see counter + 1."""
    import jax
    import jax.numpy as jnp

    from jaxga.config.presets import load_preset
    from jaxga.engine import build
    from jaxga.engine import evolution as E
    from jaxga.operators.guide import with_guide

    grid = random_map(8, 8, 0.1, 3, corner_rule="free")
    algo, params = build(load_preset(preset, overrides={
        "population.size": 6, "generations": 3, "init.max_tries": 40}), grid)
    seen = []  # the t each stage is given, while the generation is traced
    for name in ("_crossover", "_mutation"):
        real = getattr(E, name)

        def spy(*args, _real=real):
            seen.append(args[6])
            return _real(*args)

        monkeypatch.setattr(E, name, spy)
    @jax.jit  # one program: the stages' t is read while the generation is traced
    def given_t(t):
        guided = with_guide(grid)
        state = E.init_state(algo, jax.random.PRNGKey(0), guided, params)[0]
        isl = jax.tree_util.tree_map(lambda x: x[0], state.islands)
        per, shared = E._island_params(params, algo.islands)  # island 0's parameters
        first = {**shared, **jax.tree_util.tree_map(lambda x: x[0], per)}
        seen.clear()
        E.island_generation(algo, jax.random.PRNGKey(1), guided, isl, t, first)
        return jnp.stack(seen)

    for t in (0, 2):
        np.testing.assert_array_equal(np.asarray(given_t(jnp.int32(t))), [t + 1, t + 1])


def test_history_row_counts_only_active_individuals_of_every_island():
    """Best-so-far, mean and sd (ddof 0) of the fitness over the active slots of all
    islands (``population.active`` below the capacity), against NumPy."""
    import jax
    import jax.numpy as jnp

    from jaxga.config.presets import load_preset
    from jaxga.engine import build
    from jaxga.engine import evolution as E

    grid = random_map(8, 8, 0.1, 1, corner_rule="free")
    algo, params = build(load_preset("sga", overrides={
        "population.size": 8, "islands.count": 3, "islands.topology": "ring",
        "islands.migrants": 1}), grid)

    params = {**params, "population.active": jnp.int32(5)}
    rng = np.random.default_rng(7)
    fitness = rng.random((3, 8)).astype(np.float32)
    # the state from NumPy arrays and the row in one compiled program (op by op, each
    # array and each reduction was a program of its own)
    state = E.GAState(
        islands=E.IslandState(np.zeros((3, 8, algo.capacity), np.int32),
                              np.ones((3, 8), np.int32), fitness, np.ones((3, 8), bool)),
        best_cells=np.zeros((algo.capacity,), np.int32), best_length=np.int32(1),
        best_fitness=np.float32(0.75), generation=np.int32(4), stall=np.int32(0),
        frozen=np.bool_(False), failures=np.zeros(3, np.int32))
    row = jax.jit(E.history_row, static_argnums=0)(algo, state, params)
    active = fitness[:, :5].astype(np.float64)
    assert float(row["best"]) == 0.75
    np.testing.assert_allclose(float(row["mean"]), active.mean(), rtol=1e-6)
    np.testing.assert_allclose(float(row["std"]), active.std(), rtol=1e-5)
    assert not np.isclose(float(row["mean"]), fitness.mean(), rtol=1e-4)


def test_per_island_rates_apply_to_their_own_island():
    """MPMGA's islands differ by their crossover and mutation rates (MPMGA section 3.3): with
    selection and migration off, an island whose rates are 0 keeps its population
    through a generation and an island with rate 1 does not (the rates are dynamic
    parameters: one compiled generation for every setting)."""
    import jax
    import jax.numpy as jnp

    from jaxga.config.presets import load_preset
    from jaxga.engine import build
    from jaxga.engine import evolution as E

    grid = random_map(10, 10, 0.2, 3, corner_rule="free")
    algo, params = build(load_preset("sga", overrides={
        "population.size": 8, "init.max_tries": 40, "islands.count": 3,
        "islands.topology": "none", "islands.migrants": 0, "selection.method": "none",
        "islands.crossover_probabilities": [0.0, 0.0, 0.0],
        "islands.mutation_probabilities": [0.0, 0.0, 0.0]}), grid)
    state, _ = jax.jit(lambda k: E.init_state(algo, k, with_guide(grid), params))(
        jax.random.PRNGKey(0))
    step = jax.jit(lambda k, s, p: E.generation(algo, k, grid, s, p))
    for pc, pm in [((0.0, 1.0, 1.0), (0.0, 0.0, 0.0)), ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)),
                   ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))]:
        rates = {**params, "crossover.probability": jnp.asarray(pc, jnp.float32),
                 "mutation.probability": jnp.asarray(pm, jnp.float32)}
        new = step(jax.random.PRNGKey(1), state, rates)
        for i in range(3):
            same = np.array_equal(np.asarray(new.islands.cells[i]),
                                  np.asarray(state.islands.cells[i]))
            assert same == (pc[i] == 0 and pm[i] == 0), (i, pc, pm)


def test_init_unique_gives_non_repeating_initial_chromosomes():
    """``init.unique`` (IMGA 4.1 (iii), "M nonrepeating chromosomes"): on an open 5 x 5
    map, where median insertion often draws the same path twice, the initial population
    holds no two equal paths with it and does hold some without it."""
    import jax

    from jaxga.config.presets import load_preset
    from jaxga.core.grid import Grid
    from jaxga.engine import build
    from jaxga.engine import evolution as E

    grid = with_guide(Grid.create(np.zeros((5, 5), bool), corner_rule="free"))
    repeats = {}
    for unique in (False, True):
        config = load_preset("imga", overrides={
            "population.size": 16, "init.unique": unique, "init.fallback": "none",
            "init.max_tries": 200})
        algo, params = build(config, grid)
        init = jax.jit(E.init_state, static_argnums=0)
        state, stats = init(algo, jax.random.PRNGKey(0), grid, params)
        cells = np.asarray(state.islands.cells[0])
        length = np.asarray(state.islands.length[0])
        paths = {tuple(c[:n]) for c, n in zip(cells, length)}
        assert int(np.asarray(stats.n_failed).sum()) == 0  # every slot filled by a draw
        repeats[unique] = len(cells) - len(paths)
    assert repeats[True] == 0 and repeats[False] > 0, repeats


@pytest.mark.parametrize("timing", ["before_variation", "after_variation"])
def test_migration_timing_decides_whether_the_migrants_were_varied(timing):
    """``islands.timing``: MPMGA's Fig. 1 migrates before crossover and mutation,
    after. Island A mutates every individual, B and C keep theirs (rates 0, no selection),
    so what sinks from A into B and C is among A's initial worst four (two into each) before
    the variation, and A's mutated individuals after it."""
    import jax

    from jaxga.config.presets import load_preset
    from jaxga.engine import build
    from jaxga.engine import evolution as E

    grid = random_map(10, 10, 0.2, 3, corner_rule="free")
    algo, params = build(load_preset("sga", overrides={
        "population.size": 8, "init.max_tries": 40, "islands.count": 3,
        "islands.topology": "mpmga", "islands.migrants": 2, "islands.timing": timing,
        "selection.method": "none", "islands.crossover_probabilities": [0.0, 0.0, 0.0],
        "islands.mutation_probabilities": [1.0, 0.0, 0.0]}), grid)
    state, _ = jax.jit(lambda k: E.init_state(algo, k, with_guide(grid), params))(
        jax.random.PRNGKey(0))
    new = jax.jit(lambda k, s: E.generation(algo, k, grid, s, params))(
        jax.random.PRNGKey(1), state)

    def rows(isl, i):
        return [tuple(c[:n]) for c, n in zip(np.asarray(isl.cells[i]),
                                             np.asarray(isl.length[i]))]

    old_bc = set(rows(state.islands, 1) + rows(state.islands, 2))
    arrived = {r for i in (1, 2) for r in rows(new.islands, i) if r not in old_bc}
    a_before = rows(state.islands, 0)
    order = np.argsort(np.asarray(state.islands.fitness[0]), kind="stable")
    assert len(arrived) >= 2
    if timing == "before_variation":  # A's four worst (two into B, two into C), unvaried
        assert arrived <= {a_before[j] for j in order[:4]}
    else:
        assert not arrived <= set(a_before)
