"""Compile once, run many (decision 028): one program set serves every seed count and every
generation count, and the padding changes no run's result."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import pickle
import shutil
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

import jaxga._runtime as runtime
from jaxga import api, engine
from jaxga._runtime import executables, programs
from jaxga.core.errors import CacheWarning, ParameterError
from jaxga.core.paths import is_feasible
from jaxga.engine.maptables import with_tables
from jaxga.engine.run import run_evolve, run_init
from jaxga.maps import load_map
from jaxga.maps.generators import random_map
from jaxga.operators import registry, schedules
from jaxga.operators.guide import with_guide
from tests import canonical

# the program sets' sizes, sharing, store and memory (programs of their own)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]

# The canonical sga problem (tests/canonical.py) with dynamic overrides only: the programs
# of 5-32 seeds are the docs' (README: 16 seeds of sga on this map). The map's path
# capacity, 160, is the 32 x 32 size class's, so that the map padded to its class runs
# with the capacity of the unpadded one (test_maps_of_one_size_class_run_one_program_set).
OPTIONS = dict(init__max_tries=30, crossover__probability=0.85)


@pytest.fixture(scope="module")
def grid():
    return load_map(canonical.MAP)


@pytest.fixture(scope="module")
def reference(grid):
    """Seeds 0-69 over 50 generations as the engine computes them without the API."""
    return unpadded(grid, range(70), 50)


@pytest.fixture()
def compiled(monkeypatch):
    """The names of the programs XLA compiles during a test (init, evolve, finish)."""
    names: list[str] = []
    original = programs.Programs._compile

    def recording(self, wanted, report):
        names.extend(n for n in wanted if n not in self._compiled)
        return original(self, wanted, report)

    monkeypatch.setattr(programs.Programs, "_compile", recording)
    return names


def unpadded(grid, seeds, generations):
    """The runs as the engine computes them without the API: ``vmap``s of exactly these
    seeds, all generations in one ``lax.scan`` (the API's programs before decision 028)."""
    config = api.check_run("sga", grid, generations=generations, **OPTIONS)
    algo, params = engine.build(config, grid)
    g = with_tables(with_guide(grid) if engine.uses_guide(config) else grid)

    keys = jax.vmap(jax.random.PRNGKey)(np.asarray(seeds, np.uint32))
    # per-run parameters, as the API passes them (a constant would let XLA fold them:
    # a mean over a constant count of individuals rounds differently)
    per_run = {k: np.repeat(np.asarray(v)[None], len(keys), axis=0) for k, v in params.items()}
    init = jax.jit(jax.vmap(lambda k, p: run_init(algo, k, g, p)[0]))
    evolve = jax.jit(jax.vmap(lambda k, p, st: run_evolve(algo, k, g, st, p)))
    finish = jax.jit(jax.vmap(lambda p, st, h, b: engine.finish(algo, g, st, h, p, b)))
    state = init(keys, per_run)
    init_best = state.best_fitness
    state, hist = evolve(keys, per_run, state)
    out = finish(per_run, state, hist, init_best)
    return jax.tree_util.tree_map(np.asarray, (out, hist))


def assert_same_runs(result, rows, ref, ref_hist):
    """``result``'s seeds equal the reference's ``rows``, bit for bit."""
    np.testing.assert_array_equal(result.cells, ref["cells"][rows])
    np.testing.assert_array_equal(result.n_cells, ref["n_cells"][rows])
    np.testing.assert_array_equal(result.fitness, np.where(ref["success"][rows],
                                                           ref["fitness"][rows], np.nan))
    np.testing.assert_array_equal(result.convergence_generation,
                                  ref["convergence_generation"][rows])
    np.testing.assert_array_equal(result.failures, ref["failures"][rows])
    for h in ("best", "mean", "std"):
        np.testing.assert_array_equal(result.history[h], ref_hist[h][rows])


def test_10_20_and_30_seeds_and_50_or_300_generations_run_one_program_set(grid, compiled,
                                                                         reference):
    """Runs of 10, 20 and 30 seeds, then of 50 and 300 generations
    and 3 seeds compile init, evolve and finish once; every seed's result equals its
    unpadded run (a 50-generation run and the first 50 generations of a 300-generation
    one included). The programs compiled earlier in this process (the docs' runs of the
    same problem) are dropped first: each program of the set is then compiled or read
    from the store exactly once."""
    api.clear_compiled()
    runs = {n: api.run("sga", grid, seeds=n, generations=50, **OPTIONS) for n in (10, 20, 30)}
    long = api.run("sga", grid, seeds=3, generations=300, **OPTIONS)
    assert sorted(compiled) == ["evolve", "finish", "init"]
    ref, ref_hist = reference
    for n, r in runs.items():
        assert_same_runs(r, slice(0, n), ref, ref_hist)
    assert (runs[30].success.sum() >= 25) and np.isfinite(runs[30].length).any()
    for h in ("best", "mean", "std"):  # generation t draws fold_in(key, t) in any chunk
        np.testing.assert_array_equal(long.history[h][:, :50], ref_hist[h][:3])
    assert long.history["best"].shape == (3, 300)


def test_more_runs_than_the_largest_program_are_several_calls_of_it(grid, compiled,
                                                                   reference):
    """70 seeds on one device are 3 calls of the 32-run program (the last padded), with
    the results of the unpadded runs; 7 generations are one call of the 25-generation
    chunk that runs 7 of them."""
    n_dev = jax.local_device_count()
    assert runtime.programs.run_layout(70, n_dev) == (32, math.ceil(70 / n_dev / 32))
    r = api.run("sga", grid, seeds=70, generations=50, **OPTIONS)
    assert compiled.count("evolve") <= 1  # the 32-run programs (of the test above)
    assert_same_runs(r, slice(0, 70), *reference)
    short = api.run("sga", grid, seeds=70, generations=7, **OPTIONS)
    assert short.history["best"].shape == (70, 7)
    for h in ("best", "mean", "std"):
        np.testing.assert_array_equal(short.history[h], reference[1][h][:, :7])


def test_a_smaller_call_reuses_a_larger_compiled_program(grid, compiled):
    api.run("sga", grid, seeds=12, generations=5, **OPTIONS)  # 32 runs per device
    compiled.clear()
    r = api.run("sga", grid, seeds=[4, 9], generations=5, **OPTIONS)
    assert compiled == [] and r.timing["compile_s"] < 1.0


def test_maps_of_one_size_class_run_one_program_set(grid, compiled, reference):
    """With ``size_class`` a 25 x 25, an 11 x 11 and the canonical 20 x 20 map
    (all of the 32 x 32 class) compile init, evolve and finish once; every path is a
    feasible path on its own map, reported in its own cells; seeds repeat exactly; and
    SGA's draws do not depend on the map's width, so each seed of the padded 20 x 20 map
    equals its unpadded run bit for bit (the map's capacity is the class's)."""
    maps = [random_map(n, n, 0.2, seed, corner_rule="free") for n, seed in ((25, 4), (11, 5))]
    maps.append(grid)
    runs = [api.run("sga", g, seeds=10, generations=50, size_class=True, **OPTIONS)
            for g in maps]
    assert sorted(compiled) == ["evolve", "finish", "init"]
    # every seed's path checked in one compiled program per map (op by op, the check
    # compiled some 60 programs per map shape)
    feasible = jax.jit(jax.vmap(is_feasible, (None, 0, 0)))
    for g, r in zip(maps, runs):
        assert r.success.sum() >= 8
        assert r.width == g.width and r.start == g.start_xy and r.goal == g.goal_xy
        ok = np.asarray(feasible(g, jnp.asarray(r.cells), jnp.asarray(r.n_cells, jnp.int32)))
        for i in np.flatnonzero(r.success):
            assert bool(ok[i])
            assert r.cells[i].max() < g.n_cells and r.length[i] >= r.optimum - 1e-4
    again = api.run("sga", maps[0], seeds=[3, 7], generations=50, size_class=True, **OPTIONS)
    np.testing.assert_array_equal(again.cells, runs[0].cells[[3, 7]])
    assert sorted(compiled) == ["evolve", "finish", "init"]
    assert_same_runs(runs[2], slice(0, 10), *reference)


def test_size_class_must_be_a_bool(grid):
    with pytest.raises(ParameterError, match="size_class must be True, False or None"):
        api.run("sga", grid, seeds=1, size_class="yes", **OPTIONS)


def test_warmup_runs_each_program_size_once_per_preset_and_map(monkeypatch):
    """``warmup`` runs every preset on every map once per program size (4 runs, then 32
    per device: smallest first, as a larger one would be reused), one generation each,
    with the size class asked for; a size is an open map, a name the map itself."""
    from jaxga.api import warmup as warmup_module

    calls = []

    def fake_run(preset, grid, *, seeds, generations, corner_rule, size_class):
        shape = grid.shape if hasattr(grid, "shape") else grid
        if hasattr(grid, "shape"):
            assert not grid.blocked_np().any() and grid.corner_rule == "strict"
        calls.append((preset, shape, seeds, generations, corner_rule, size_class))
        return type("R", (), {"timing": {"compile_s": 0.5}})()

    monkeypatch.setattr(warmup_module, "run", fake_run)
    rows = warmup_module.warmup(["sga", "imga"], [32, "classic_ga_gapp3_20x20"],
                                size_class=True)
    big = programs.RUNS_PER_DEVICE * jax.local_device_count()
    assert calls == [(p, m, n, 1, None, True) for p in ("sga", "imga")
                     for m in ((32, 32), "classic_ga_gapp3_20x20") for n in (4, big)]
    assert [r["map"] for r in rows[:2]] == ["open 32 x 32"] * 2
    assert all(r["compile_s"] == 0.5 for r in rows)
    with pytest.raises(ParameterError, match="integer >= 2"):
        warmup_module.warmup(["sga"], [1])


@pytest.mark.parametrize("n_runs, n_devices, cells, have, want", [
    (1, 1, 0, (), (4, 1)), (4, 1, 0, (), (4, 1)), (5, 1, 0, (), (32, 1)),
    (30, 1, 0, (), (32, 1)), (33, 1, 0, (), (32, 2)), (1000, 1, 0, (), (32, 32)),
    (1000, 2, 0, (), (32, 16)), (4, 2, 0, (), (2, 1)), (3, 3, 0, (), (2, 1)),
    (10, 2, 0, (), (32, 1)), (30, 2, 0, (), (32, 1)), (8, 2, 0, (), (32, 1)),
    (3, 1, 0, (32,), (32, 1)), (3, 1, 0, (4, 32), (4, 1)), (40, 1, 0, (4,), (32, 2)),
    (3, 1, 256 * 256, (), (4, 1)), (1, 1, 100 * 100, (), (1, 1)),
    (17, 1, 100 * 100, (), (32, 1)), (9, 1, 100 * 100, (), (16, 1)),
    (65, 1, 100 * 100, (), (32, 3)), (3, 1, 100 * 100, (8,), (8, 1)),
])
def test_run_layout(n_runs, n_devices, cells, have, want):
    """Runs per device and calls: up to 4 runs one call of 4 over the devices, more runs
    calls of 32 per device (10, 20 and 30 seeds one program on one or two devices), a
    larger program already compiled reused, powers of two on maps over 64 x 64."""
    assert runtime.programs.run_layout(n_runs, n_devices, cells, have, platform="cpu") == want


@pytest.mark.parametrize("n_runs, n_devices, cells, have, want", [
    (1, 1, 0, (), (4, 1)), (5, 1, 0, (), (32, 1)), (33, 1, 0, (), (64, 1)),
    (100, 1, 0, (), (128, 1)), (256, 1, 0, (), (256, 1)), (257, 1, 0, (), (512, 1)),
    (16_000, 1, 0, (), (2048, 8)), (100, 2, 0, (), (64, 1)), (5000, 2, 0, (), (2048, 2)),
    (40, 1, 0, (2048,), (64, 1)), (40, 1, 0, (32,), (64, 1)), (40, 1, 0, (64, 128), (64, 1)),
    (40, 1, 0, (128,), (64, 1)), (100, 1, 0, (256,), (128, 1)), (3, 1, 0, (32, 2048), (32, 1)),
    (3, 1, 0, (2048,), (4, 1)), (20, 1, 0, (32,), (32, 1)),
    (1, 1, 100 * 100, (), (1, 1)), (100, 1, 100 * 100, (), (32, 4)),
    (9, 1, 100 * 100, (256,), (16, 1)),
])
def test_run_layout_on_a_gpu(n_runs, n_devices, cells, have, want):
    """On a GPU the large programs hold a power of two from 32 to 2048 runs per device
    (one call of the smallest that holds the share, else calls of 2048); maps over
    64 x 64 and the small call keep the CPU's rule; a compiled size is reused only up to
    twice the share or the smallest bucket (a re-plan of 3 runs after a sweep of 2048
    compiles its own 4-run program)."""
    assert runtime.programs.run_layout(n_runs, n_devices, cells, have, platform="gpu") == want


def test_platform_layouts():
    """The CPU computes blocks that fit its caches; a GPU evolves and initialises one
    vmap per call."""
    from jaxga._runtime import programs

    cpu = runtime.programs.platform_layout("cpu")
    assert cpu == programs.PlatformLayout((programs.RUNS_PER_DEVICE,), programs.RUN_BLOCK,
                                          programs.INIT_RUN_BLOCK)
    assert runtime.programs.platform_layout() == cpu  # the suite runs on the CPU
    for platform in ("gpu", "tpu"):
        lay = runtime.programs.platform_layout(platform)
        assert lay.buckets == runtime.programs.ACCELERATOR_BUCKETS == tuple(sorted(lay.buckets))
        assert lay.run_block == lay.buckets[-1]
        assert lay.init_run_block == lay.buckets[-1] == programs.ACCELERATOR_INIT_BLOCK
        assert runtime.programs.run_blocks(lay.buckets[-1], 1, lay.run_block) == 1


def test_run_layout_refuses_no_runs():
    with pytest.raises(ParameterError, match="at least one run"):
        runtime.programs.run_layout(0)


@pytest.mark.parametrize("generations", [1, 7, 45, 300])
def test_agacd_schedules_equal_optax_exponential_decay(generations):
    """The schedules take a traced generation count and give the float32 values of
    optax's schedule with a static one, both compiled (the engine's case; eager
    op-by-op evaluation rounds ``pow`` differently)."""
    t = np.arange(0, generations + 2, dtype=np.int32)
    for ours, rate in ((schedules.agacd_crossover_decay, math.exp(-1.0)),
                       (schedules.agacd_mutation_growth, math.e)):
        want = jax.jit(optax.exponential_decay(1.0, transition_steps=generations,
                                               decay_rate=rate))(t)
        traced = jax.jit(lambda g, t, ours=ours: ours(g)(t))(np.int32(generations), t)
        np.testing.assert_array_equal(np.asarray(traced), np.asarray(want))
        static = jax.jit(ours(generations))(t)
        np.testing.assert_array_equal(np.asarray(static), np.asarray(want))
    with pytest.raises(ValueError, match="generations must be >= 1"):
        schedules.agacd_crossover_decay(0)


NEW_PROCESS = """
import json, sys
import numpy as np
from jaxga import api, configure, engine
configure()  # the store and JAX's cache in $JAXGA_CACHE_DIR, as the command line does
if sys.argv[1] == "read":  # tracing would call these
    engine.evolution.generation = engine.evolution.init_state = None
# the canonical sga problem (tests/canonical.py), here compiled in a store of its own
r = api.run("sga", "classic_ga_gapp3_20x20", seeds=3, generations=9, init__max_tries=30,
            crossover__probability=0.85)
print(json.dumps({"cells": np.asarray(r.cells).tolist(),
                  "best": np.asarray(r.history["best"]).tolist(),
                  "compile_s": r.timing["compile_s"]}))
"""


def test_a_new_process_reads_the_stored_programs_without_tracing(tmp_path):
    """The compiled programs are kept whole beside JAX's cache: a new process traces
    nothing (the traced functions are removed), reads every program and gives the same
    results bit for bit."""
    env = dict(os.environ, JAXGA_CACHE_DIR=str(tmp_path))
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    out = []
    for mode in ("compile", "read"):
        proc = subprocess.run([sys.executable, "-c", NEW_PROCESS, mode], env=env,
                              capture_output=True, text=True, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr[-2000:]
        out.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    # init, evolve and finish, and the map tables' program
    assert len(list((tmp_path / executables.SUBDIRECTORY).glob("*.pkl"))) == 4
    assert out[1]["cells"] == out[0]["cells"] and out[1]["best"] == out[0]["best"]
    assert out[1]["compile_s"] < out[0]["compile_s"]


@pytest.mark.slow  # three processes, two of them compiling the canonical sga programs
def test_a_program_in_jaxs_cache_but_not_in_the_store_is_stored(tmp_path):
    """The store lost its programs (a new key for the same program: another jaxga
    version; files deleted) while JAX's own cache kept them: the next process compiles
    them afresh (a program read from JAX's cache does not serialise whole), stores them,
    and the process after it traces nothing."""
    env = dict(os.environ, JAXGA_CACHE_DIR=str(tmp_path),
               JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0")
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    store = tmp_path / executables.SUBDIRECTORY
    out = []
    for mode in ("compile", "compile", "read"):
        if len(out) == 1:
            shutil.rmtree(store)
            assert any(tmp_path.iterdir())  # JAX's cache entries stay
        proc = subprocess.run([sys.executable, "-c", NEW_PROCESS, mode], env=env,
                              capture_output=True, text=True, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr[-2000:]
        out.append(json.loads(proc.stdout.strip().splitlines()[-1]))
        assert len(list(store.glob("*.pkl"))) == 4
    assert out[2]["cells"] == out[1]["cells"] == out[0]["cells"]
    assert out[2]["best"] == out[0]["best"]


def test_a_program_the_store_lost_twice_is_stored_again(monkeypatch):
    """The afresh compile of a program JAX's cache holds (compile_and_store) drew its
    option's value from the program's key: the second time the store lost the program,
    that compile was in JAX's cache too, so it was never stored again (every process
    traced and compiled it). JAX's cache is played here by a set of option values seen."""
    seen, saved = set(), []

    class Lowered:
        def compile(self, options=None):
            value = (options or {}).get(executables.STORE_OPTION)
            if value in seen:  # a cache hit, as JAX's monitoring event reports it
                executables._CACHE_HITS[0] += 1
            seen.add(value)
            return object()

    monkeypatch.setattr(executables, "save", lambda key, program, devices: saved.append(key))
    for _ in range(4):  # the store loses the program before each process
        executables.compile_and_store("0123456789abcdef", Lowered(), None, [])
    assert saved == ["0123456789abcdef"] * 4


def test_a_stored_program_that_is_not_its_keys_is_removed_with_one_warning(
        tmp_path, monkeypatch):
    """Nothing in the store reaches XLA unless it is the program asked for: an unreadable
    file, a program copied under another key, an older version's file, one compiled for
    other devices and a damaged one are each removed with one warning naming the store
    (XLA would abort the process on a program meant for other shapes or devices), and
    the program is compiled again; one another process's bound removes between the
    check and the read is compiled again without a word (it warned that a writable store
    "takes no changes"); a program stored here loads and runs."""
    monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir",
                        property(lambda self: str(tmp_path)), raising=False)
    store = executables.directory()
    assert store == tmp_path / executables.SUBDIRECTORY
    store.mkdir()
    devices = jax.devices()[:1]
    plus = jax.jit(lambda x: x + 1).lower(np.int32(1)).compile()
    pair = jax.jit(lambda x, y: (x * y, x)).lower(np.float32(1), np.float32(2)).compile()
    executables.save("plus", plus, devices)
    executables.save("pair", pair, devices)
    assert int(executables.load("plus", devices)(np.int32(4))) == 5
    entry = pickle.loads((store / "plus.pkl").read_bytes())
    damaged = dict(entry, program=entry["program"][:-9] + b"x" + entry["program"][-8:])
    cases = {
        "not a program": (b"not a program", "cannot be read"),
        "copied": ((store / "pair.pkl").read_bytes(), "holds another program"),
        "older": (pickle.dumps(pickle.loads(entry["program"])), "another version"),
        "devices": (pickle.dumps(dict(entry, devices=[["cuda", "H200", 0]])),
                    "other devices"),
        "damaged": (pickle.dumps(damaged), "damaged"),
    }
    for what, (data, words) in cases.items():
        (store / "plus.pkl").write_bytes(data)
        with pytest.warns(CacheWarning, match=words) as said:
            assert executables.load("plus", devices) is None, what
        assert len(said) == 1 and str(store) in str(said[0].message), what
        assert "\n" not in str(said[0].message)
        assert not (store / "plus.pkl").exists(), what
    assert executables.load("missing", devices) is None
    # a program another process's bound removes between the check and the read: no word
    def vanishing_open(path, *args):
        os.unlink(path)  # another process's bound removes it now
        return open(path, *args)

    (store / "plus.pkl").write_bytes(b"it is here when checked")
    with monkeypatch.context() as gone, warnings.catch_warnings():
        gone.setattr(executables, "open", vanishing_open, raising=False)
        gone.setattr(executables, "_FORGOTTEN", set())  # no earlier warning stands in
        warnings.simplefilter("error")
        assert executables.load("plus", devices) is None
    program, read = executables.load_or_compile("plus", devices, lambda: jax.jit(
        lambda x: x + 1).lower(np.int32(1)))
    assert not read and int(program(np.int32(4))) == 5
    assert int(executables.load("plus", devices)(np.int32(6))) == 7


def test_callers_sharing_the_store_compile_a_program_once(tmp_path, monkeypatch):
    """Two callers that need one program at once (threads here: ``flock`` locks an open
    file, so two opens conflict as two processes do): one compiles it under its key's
    lock, the other waits and then reads what the first stored."""
    monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir",
                        property(lambda self: str(tmp_path)), raising=False)
    lowered = jax.jit(lambda x: x * 3).lower(np.int32(1))
    compiled_by, started = [], threading.Event()

    def compile_and_store(key, low, options, devices):
        started.set()
        time.sleep(0.5)  # the second caller arrives meanwhile
        program = low.compile()
        executables.save(key, program, devices)
        compiled_by.append(threading.current_thread().name)
        return program

    monkeypatch.setattr(executables, "compile_and_store", compile_and_store)
    got = {}

    def need(name):
        program, read = executables.load_or_compile("k3", jax.devices()[:1], lambda: lowered)
        got[name] = (int(program(np.int32(2))), read)

    first = threading.Thread(target=need, args=("a",), name="a")
    first.start()
    assert started.wait(30)
    second = threading.Thread(target=need, args=("b",), name="b")
    second.start()
    first.join(60)
    second.join(60)
    assert compiled_by == ["a"]
    assert got == {"a": (6, False), "b": (6, True)}


def test_programs_with_a_users_operator_are_not_stored(grid):
    """A user's operator can change without anything in the key changing: its programs
    go through JAX's cache alone (keyed on the lowered program)."""
    config = api.check_run("sga", grid, **OPTIONS)
    algo, _ = engine.build(config, grid)
    args = (None, (), 8, jax.devices()[:1])
    assert executables.program_key("init", algo, *args) is not None
    real = registry.operator("mutation", config["mutation.method"])
    registry.register(registry.Operator("mutation", "users_copy", lambda *a: real.fn(*a),
                                        "a user's operator (test)"))
    try:
        user = dataclasses.replace(algo, config=engine.static_config(config.override(
            {"mutation.method": "users_copy"})))
        assert executables.program_key("init", user, *args) is None
    finally:
        registry.unregister("mutation", "users_copy")


def test_a_program_compiled_with_other_jax_compile_options_has_another_key(grid):
    """``jax_disable_most_optimizations`` (and JAX's other compile options) change what
    XLA compiles: a program stored under one setting is never read under another."""
    config = api.check_run("sga", grid, **OPTIONS)
    algo, _ = engine.build(config, grid)
    args = (None, (), 8, jax.devices()[:1])
    plain = executables.program_key("init", algo, *args)
    jax.config.update("jax_disable_most_optimizations", True)
    try:
        other = executables.program_key("init", algo, *args)
    finally:
        jax.config.update("jax_disable_most_optimizations", False)
    assert plain is not None and other is not None and other != plain
    assert executables.program_key("init", algo, *args) == plain


def test_each_process_of_a_multi_process_run_reads_only_its_own_programs(grid, monkeypatch):
    """In a run over several processes the programs of process 0 and process 1 have
    different keys: a program addresses its own process's devices (read by another
    process it returned arrays that process cannot fetch: tests/api/test_distributed.py)."""
    config = api.check_run("sga", grid, **OPTIONS)
    algo, _ = engine.build(config, grid)
    args = ("init", algo, None, (), 8, jax.devices()[:1])
    keys = []
    for index in (0, 1):
        monkeypatch.setattr(jax, "process_count", lambda: 2)
        monkeypatch.setattr(jax, "process_index", lambda index=index: index)
        keys.append(executables.program_key(*args))
    assert None not in keys and keys[0] != keys[1]


def test_a_stored_program_that_fails_to_run_is_forgotten_and_compiled_again(
        grid, monkeypatch):
    """A program read from the store that fails when it runs (an XLA:CPU program read
    from JAX's own cache did: "Function ... not found") is deleted with the others this
    process read, and the call runs again with fresh compilations: a result, not a
    crash."""
    from jax.errors import JaxRuntimeError

    want = api.run("sga", grid, seeds=12, generations=4, **OPTIONS)  # programs compiled above
    api.clear_compiled()
    served, calls = set(), []

    def load_broken_once(key, devices):
        if key is None or key in served:
            return None
        served.add(key)
        executables._READ.add(key)  # as a real read records it

        def broken(*args):  # both forms XLA:CPU gives, the dispatch error first
            calls.append(key)
            raise JaxRuntimeError("NOT_FOUND: Function fusion.1 not found (type id: 1)"
                                  if len(calls) > 1 else "INTERNAL: Error dispatching "
                                  "computation: Function convert_bitcast_fusion not found "
                                  "(type id: 1)")

        return broken

    monkeypatch.setattr(executables, "load", load_broken_once)
    got = api.run("sga", grid, seeds=12, generations=4, **OPTIONS)
    assert served and calls  # the broken programs were served, then forgotten
    np.testing.assert_array_equal(got.cells, want.cells)
    np.testing.assert_array_equal(got.history["best"], want.history["best"])


@pytest.mark.parametrize(("stored", "expected"), [
    ((), [0.25, 0.5, 0.75]),                             # nothing stored: all compiled
    (("init", "evolve", "finish"), [0.25, 0.5, 0.75]),   # all read from the store
    (("init",), [0.25, 0.5, 0.75]),                      # init stored by an interrupted run
])
def test_a_program_sets_compile_progress_only_goes_forward(monkeypatch, stored, expected):
    """A fresh program set reports 1/4 (the tracing's share), 2/4 after init and 3/4
    after evolve, wherever its programs come from; a compiled set reports nothing."""
    from jaxga._runtime import executables
    from jaxga._runtime.programs import Programs

    class Traced:
        def lower(self):
            return "lowered"

    monkeypatch.setattr(executables, "load", lambda key, devices: key if key in stored else None)
    monkeypatch.setattr(executables, "compile_and_store",
                        lambda key, lowered, options, devices: key)
    progs = Programs(lambda: {n: Traced() for n in Programs.NAMES},
                     {n: n for n in Programs.NAMES}, jax.devices()[:1])
    fractions = []
    progs.compile_init(fractions.append)
    progs.compile_rest(fractions.append)
    assert fractions == expected
    assert progs.read == len(stored)
    assert (progs.init, progs.evolve, progs.finish) == Programs.NAMES
    again = []
    progs.compile_init(again.append)
    progs.compile_rest(again.append)
    assert again == []


def test_runs_off_the_cpu_are_warned_about_once(monkeypatch):
    """A GPU's results are not the CPU's bits: said once per process and platform."""
    from jaxga._runtime import programs
    from jaxga.core.errors import PlatformWarning

    monkeypatch.setattr(programs, "_WARNED_PLATFORMS", set())
    with pytest.warns(PlatformWarning, match="the runs compute on the gpu: .*JAX_PLATFORMS=cpu"):
        programs.warn_platform("gpu")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        programs.warn_platform("gpu")  # once
        programs.warn_platform("cpu")  # never


def test_the_pure_core_warns_off_the_cpu(monkeypatch):
    """``jaxga.GA`` says it too, for the backend its users' jit calls will run on."""
    from jaxga.core.errors import PlatformWarning

    monkeypatch.setattr(programs, "_WARNED_PLATFORMS", set())
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    with pytest.warns(PlatformWarning, match="on the gpu"):
        api.GA("sga", "classic_ga_gapp3_20x20", generations=2)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_lock_file_that_is_not_a_regular_file_does_not_block_the_compile(tmp_path,
                                                                            monkeypatch):
    """A FIFO in a lock file's place (a damaged or hostile cache) would block opening it
    for good: the compile goes on without the lock instead."""
    monkeypatch.setattr(executables, "directory", lambda: tmp_path)
    (tmp_path / "locks").mkdir()
    os.mkfifo(tmp_path / "locks" / "k.lock")
    entered = threading.Event()

    def hold():
        with executables._compiling("k"):
            entered.set()

    worker = threading.Thread(target=hold, daemon=True)
    worker.start()
    assert entered.wait(10), "the lock's open blocked on the FIFO"
    worker.join(10)


def test_threads_of_one_process_wait_for_each_other_without_a_word(tmp_path, monkeypatch):
    """Two threads that need the same program: the second waits for the first's compile
    on this process's own lock (a file lock had it wait for "process <its own pid>",
    warned, and failed under warnings as errors), then goes on."""
    monkeypatch.setattr(executables, "directory", lambda: tmp_path)
    monkeypatch.setattr(executables, "LOCK_NOTE_S", 0.0)
    # the holder unknown: a thread waiting on the file lock would warn of "another process"
    monkeypatch.setattr(executables, "_holder", lambda lock: None)
    inside, order = threading.Event(), []

    def first():
        with executables._compiling("k"):
            inside.set()
            time.sleep(1.5)
            order.append("first")

    def second():
        with executables._compiling("k"):
            order.append("second")

    one = threading.Thread(target=first, daemon=True)
    one.start()
    assert inside.wait(10)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        second()
    one.join(10)
    assert order == ["first", "second"]


def test_a_lock_file_goes_when_its_compile_is_done(tmp_path, monkeypatch):
    """The holder removes its lock file: a lock file per program stayed in the store for
    good (one more for each program ever compiled)."""
    monkeypatch.setattr(executables, "directory", lambda: tmp_path)
    with executables._compiling("k"):
        assert (tmp_path / "locks" / "k.lock").is_file()
    assert list((tmp_path / "locks").iterdir()) == []


def _entry(folder: Path, name: str, size: int, age_s: float) -> Path:
    p = folder / f"{name}.pkl"
    p.write_bytes(b"x" * size)
    t = time.time() - age_s
    os.utime(p, (t, t))
    return p


def test_the_store_keeps_within_its_bound(tmp_path, monkeypatch):
    """Saving a program past the bound removes the programs used longest ago, never the
    one just saved; lock files a killed process left (older than an hour, held by no
    one) go with them, a held one stays. The store grew without bound: every jaxga
    version and edited checkout keys its programs anew."""
    import fcntl

    monkeypatch.setenv("JAXGA_STORE_MAX_MB", "1")
    mib = 1 << 20
    oldest = _entry(tmp_path, "oldest", mib // 2, 500)
    old = _entry(tmp_path, "old", mib // 2, 400)
    recent = _entry(tmp_path, "recent", mib // 4, 100)
    kept = _entry(tmp_path, "kept", mib // 2, 900)  # just saved, with an old time
    locks = tmp_path / "locks"
    locks.mkdir()
    left, fresh, held = (locks / f"{n}.lock" for n in ("left", "fresh", "held"))
    for lock in (left, fresh, held):
        lock.write_text("host 1\n")
    for lock in (left, held):
        os.utime(lock, (time.time() - 7200,) * 2)
    with open(held, "rb") as holder:
        fcntl.flock(holder, fcntl.LOCK_EX)
        executables._prune(tmp_path, kept)
    assert sorted(p.name for p in tmp_path.glob("*.pkl")) == ["kept.pkl", "recent.pkl"]
    assert not oldest.exists() and not old.exists() and recent.exists()
    assert sorted(p.name for p in locks.iterdir()) == ["fresh.lock", "held.lock"]
    monkeypatch.delenv("JAXGA_STORE_MAX_MB")
    executables._prune(tmp_path, kept)  # within the default bound: nothing goes
    assert sorted(p.name for p in tmp_path.glob("*.pkl")) == ["kept.pkl", "recent.pkl"]


def test_jaxs_entries_in_the_configured_folder_count_against_the_bound(tmp_path, monkeypatch):
    """Where jaxga turned JAX's cache on in the store's folder, JAX's entries and jaxga's
    programs share the bound, the ones used longest ago going first; JAX's entries in a
    folder jaxga did not configure are left alone, and so is every file there that is not
    named as JAX names its entries (a user's own ``thumbnail-cache``, older than all)."""
    monkeypatch.setenv("JAXGA_STORE_MAX_MB", "1")
    mib = 1 << 20
    store = tmp_path / executables.SUBDIRECTORY
    store.mkdir()
    jax_old = tmp_path / f"jit_f-{'0123' * 16}-cache"
    jax_new = tmp_path / f"jit_g-{'4567' * 16}-cache"
    atime = tmp_path / f"jit_f-{'0123' * 16}-atime"  # JAX's note where its bound is set
    users = [tmp_path / "thumbnail-cache", tmp_path / "jit_h-0123-cache"]
    for path, age in ((jax_old, 600), (jax_new, 50), *((u, 9000) for u in users)):
        path.write_bytes(b"x" * (mib // 4))
        os.utime(path, (time.time() - age,) * 2)
    atime.write_bytes(b"1")
    program = _entry(store, "program", mib // 2, 300)
    kept = _entry(store, "kept", mib // 2, 900)
    monkeypatch.setattr(executables, "jax_cache_folder", lambda: None)
    executables._prune(store, kept)  # JAX's entries are not jaxga's: the store alone
    assert jax_old.exists() and jax_new.exists() and program.exists()
    monkeypatch.setattr(executables, "jax_cache_folder", lambda: str(tmp_path))
    executables._prune(store, kept)
    assert not jax_old.exists() and not atime.exists() and not program.exists()
    assert jax_new.exists() and kept.exists() and all(u.exists() for u in users)


def test_configure_leaves_jaxs_cache_writing_without_filelock(tmp_path):
    """``configure`` turns JAX's cache on and JAX writes its entries there. JAX's own
    bound (``jax_compilation_cache_max_size``) turns its cache off altogether where the
    filelock package is missing, so jaxga leaves it as the user set it."""
    code = (
        "import jax, jaxga\n"
        "before = jax.config.jax_compilation_cache_max_size\n"
        f"jaxga.configure({str(tmp_path)!r})\n"
        "jax.config.update('jax_persistent_cache_min_compile_time_secs', 0)\n"
        "jax.jit(lambda x: x * 3 + 1)(jax.numpy.arange(5)).block_until_ready()\n"
        "assert jax.config.jax_compilation_cache_max_size == before, 'bound changed'\n"
    )
    env = dict(os.environ)
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    env.pop("JAX_COMPILATION_CACHE_MAX_SIZE", None)
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    entries = list(tmp_path.glob("*-cache"))
    assert entries, sorted(p.name for p in tmp_path.iterdir())
    # the store's bound counts JAX's entries by their names: JAX still names them so
    assert all(executables._JAX_ENTRY.fullmatch(p.name) for p in entries), entries


@pytest.mark.parametrize("value", ["0", "-5", "1.5", "lots", "1e3"])
def test_a_store_bound_that_is_not_a_size_is_refused(monkeypatch, value):
    from jaxga.core.errors import JaxgaError

    monkeypatch.setenv("JAXGA_STORE_MAX_MB", value)
    with pytest.raises(JaxgaError, match="JAXGA_STORE_MAX_MB must be a whole number of MiB"):
        executables.store_limit()
    monkeypatch.setenv("JAXGA_STORE_MAX_MB", "")
    assert executables.store_limit() == executables.STORE_MAX_BYTES == 4 << 30


def test_a_program_read_from_the_store_counts_as_used(tmp_path, monkeypatch):
    """Reading a program renews its time, so the bound removes programs used longest
    ago, not those saved longest ago."""
    monkeypatch.setattr(executables, "directory", lambda: tmp_path)
    devices = jax.devices()[:1]
    compiled = jax.jit(lambda x: x + 1).lower(jnp.float32(1)).compile()
    executables.save("used", compiled, devices)
    path = tmp_path / "used.pkl"
    os.utime(path, (1e9, 1e9))
    program = executables.load("used", devices)
    assert program is not None and float(program(jnp.float32(2))) == 3.0
    assert path.stat().st_mtime > time.time() - 60


def test_a_long_sessions_map_table_programs_are_bounded(monkeypatch):
    """A session over maps of many shapes kept every map-table program (and the record
    of every family's compiled sizes) for good: each keeps only its most recent."""
    import collections

    monkeypatch.setattr(programs, "_TABLE_PROGRAMS", collections.OrderedDict())
    monkeypatch.setattr(programs, "PROGRAM_CACHE_SIZE", 1)  # at most 3 table programs
    for side in (5, 6, 7, 8, 6):
        programs.tables_for(random_map(side, side, 0.1, seed=side))
    assert len(programs._TABLE_PROGRAMS) == 3
    cache = collections.OrderedDict()
    for i in range(30):
        programs._keep_recent(cache, i, str(i), 5)
    programs._keep_recent(cache, 26, "again", 5)  # used again: the last to go
    programs._keep_recent(cache, 30, "30", 5)
    assert list(cache) == [27, 28, 29, 26, 30] and cache[26] == "again"


HOLD_LOCK = """
import sys, time
from jaxga._runtime import executables
with executables._compiling(sys.argv[1]):
    print("holding", flush=True)
    time.sleep(600)
"""


@pytest.mark.slow  # starts a process
@pytest.mark.skipif(not Path("/proc/self").exists() or sys.platform != "linux",
                    reason="reads a process's state from Linux's /proc")
def test_a_stopped_compile_is_not_waited_for(tmp_path, monkeypatch):
    """A process holding a program's lock and then stopped (Ctrl-Z, a paused notebook)
    kept every other process waiting for it in silence for 15 minutes: the lock file
    names its holder, and a holder that is stopped is not waited for; one that runs is
    waited for, and named after LOCK_NOTE_S."""
    import signal

    from jaxga.core.errors import CacheWarning

    monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir",
                        property(lambda self: str(tmp_path)), raising=False)
    env = dict(os.environ, JAXGA_CACHE_DIR=str(tmp_path))
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, "somekey"], env=env,
                              stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert holder.stdout.readline().strip() == "holding"
        assert f" {holder.pid}" in (executables.directory() / "locks" / "somekey.lock"
                                    ).read_text()
        monkeypatch.setattr(executables, "LOCK_NOTE_S", 0.5)
        monkeypatch.setattr(executables, "LOCK_WAIT_S", 3.0)
        t0 = time.monotonic()
        with pytest.warns(CacheWarning, match=f"waiting for process {holder.pid} on "):
            with executables._compiling("somekey"):  # a running holder: waited for
                pass
        assert time.monotonic() - t0 >= 3.0
        holder.send_signal(signal.SIGSTOP)
        t0 = time.monotonic()
        with warnings.catch_warnings():
            warnings.simplefilter("error", CacheWarning)
            monkeypatch.setattr(executables, "LOCK_NOTE_S", 30.0)
            monkeypatch.setattr(executables, "LOCK_WAIT_S", 60.0)
            with executables._compiling("somekey"):  # stopped: not waited for
                pass
        assert time.monotonic() - t0 < 5.0
    finally:
        holder.kill()
        holder.wait()
