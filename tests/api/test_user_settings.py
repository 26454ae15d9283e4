"""jaxga next to a user's own JAX settings (docs/python.md, "Your JAX settings"): JAX's
PRNG settings change no run, in the drivers, the pure core or the command line; a
transfer guard set to refuse leaves jaxga's own host work running and is back for the
user's code after it."""

from __future__ import annotations

import contextlib
import json
import os
import re
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxga
from tests import canonical

USER_PRNG = {"jax_threefry_partitionable": False, "jax_default_prng_impl": "rbg",
             "jax_random_seed_offset": 7, "jax_legacy_prng_key": "error"}
"""Every PRNG setting a user may give a process, at once (tests/core/test_prng.py takes
them one at a time for the draws)."""


@contextlib.contextmanager
def user_prng():
    """The process under :data:`USER_PRNG`; its settings back after."""
    saved = {name: getattr(jax.config, name) for name in USER_PRNG}
    for name, value in USER_PRNG.items():
        jax.config.update(name, value)
    try:
        yield
    finally:
        for name, value in saved.items():
            jax.config.update(name, value)


def _same_runs(a: jaxga.Result, b: jaxga.Result) -> None:
    assert np.array_equal(a.paths.cells, b.paths.cells)
    assert np.array_equal(a.fitness, b.fitness) and np.array_equal(a.length, b.length)
    assert np.array_equal(a.history["best"], b.history["best"])


def test_a_run_is_the_same_under_the_users_prng_settings():
    """The drivers' own part: the seeds' keys (no seed offset) and their host work. The
    programs are the stored ones (the store's key leaves the PRNG settings out, since the
    programs do not depend on them: the pure core's lowering below shows it)."""
    alone = canonical.run("sga")
    with user_prng():
        under = canonical.run("sga")
    _same_runs(alone, under)


def _lowered_text(ga: jaxga.GA) -> str:
    keys = jnp.stack([jnp.zeros(2, jnp.uint32), jnp.arange(2, dtype=jnp.uint32)], -1)
    text = jax.jit(jax.vmap(ga.run, (0, None))).lower(keys, ga.default_params).as_text(
        debug_info=False)
    return re.sub(r"loc\(.*?\)", "", text)


def test_the_pure_core_lowers_to_the_same_program_under_the_users_settings():
    """The whole pure-core run of a preset, under the user's own ``jax.jit``: the same
    StableHLO, so the same bits, with every PRNG setting changed and rank promotion
    refused (jaxga's operators broadcast ranks as NumPy does)."""
    ga = jaxga.GA("sga", canonical.MAP, generations=2)
    default = _lowered_text(ga)
    with user_prng(), jax.numpy_rank_promotion("raise"):
        assert _lowered_text(ga) == default


def test_jaxgas_host_work_runs_under_a_refusing_transfer_guard_and_rank_promotion():
    alone = canonical.run("sga")
    with jax.transfer_guard("disallow"), jax.numpy_rank_promotion("raise"):
        ga = jaxga.GA("sga", canonical.MAP, generations=canonical.GENERATIONS)
        params = ga.params(**{"crossover.probability": 0.5})
        grid = ga.grid_for((0, 0), (19, 19))
        guarded = canonical.run("sga")
        problem = jaxga.problem("sga", canonical.MAP)
        # the user's guard is back for their own code
        with pytest.raises(Exception, match="Disallowed host-to-device transfer"):
            jnp.zeros(3) + 1
    _same_runs(alone, guarded)
    assert float(params["crossover.probability"]) == 0.5
    assert int(grid.start) == 0 and problem.config["population.size"] > 0


@pytest.mark.slow  # starts a process
def test_the_command_line_is_the_same_under_jaxs_variables(tmp_path):
    env = dict(os.environ, JAX_TRANSFER_GUARD="disallow", JAX_THREEFRY_PARTITIONABLE="0",
               JAX_DEFAULT_PRNG_IMPL="rbg", JAX_RANDOM_SEED_OFFSET="7",
               JAX_LEGACY_PRNG_KEY="error")
    out = tmp_path / "runs.json"
    proc = subprocess.run([sys.executable, "-m", "jaxga.cli", "run", "--preset", "sga",
                           "--map", canonical.MAP, "--seeds", "3", "--generations",
                           str(canonical.GENERATIONS), "--quiet", "--json", str(out)],
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    runs = json.loads(out.read_text())["runs"]
    alone = canonical.run("sga")
    assert [r["length"] for r in runs] == pytest.approx(alone.length.tolist(), abs=5e-5)
    assert [r["path"] for r in runs] == [[list(p) for p in alone.path(i)] for i in range(3)]


@pytest.mark.parametrize("key, words", [
    (lambda: jax.random.key(1, impl="rbg"), "a key of the 'rbg' generator"),
    (lambda: jnp.zeros(3, jnp.uint32), "got uint32[3]"),
    (lambda: jnp.zeros(2, jnp.float32), "got float32[2]"),
    (lambda: 5, "got int"),
    (lambda: jnp.zeros((4, 2), jnp.uint32), "got uint32[4, 2]: jax.vmap the function"),
    (lambda: jax.random.split(jax.random.key(0), 3), "got keys of shape (3,): jax.vmap"),
])
def test_a_key_that_is_not_one_threefry_key_is_refused_in_one_line(key, words):
    """A key of another generator ran, and its bits depended on the keys sharing its
    batch (one seed's run changed with the others); a key of a wrong shape failed deep
    in JAX. Both are refused before any work (``jax.eval_shape``: nothing compiles)."""
    ga = _small_ga()
    with pytest.raises(jaxga.ParameterError) as refused:
        jax.eval_shape(ga.init, key(), ga.default_params)
    assert words in str(refused.value) and "\n" not in str(refused.value)
    with pytest.raises(jaxga.ParameterError, match="generations must be an integer >= 0, "
                                                   "got -3"):
        ga.evolve(jax.random.PRNGKey(0), None, ga.default_params, -3)


def test_a_typed_threefry_key_is_taken():
    ga = _small_ga()
    typed = jax.eval_shape(ga.init, jax.random.key(4), ga.default_params)
    raw = jax.eval_shape(ga.init, jax.random.PRNGKey(4), ga.default_params)
    assert jax.tree_util.tree_structure(typed) == jax.tree_util.tree_structure(raw)


_GA: list = []


def _small_ga() -> jaxga.GA:
    if not _GA:
        _GA.append(jaxga.GA("sga", canonical.MAP, generations=2))
    return _GA[0]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
@pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")  # JAX's own, which says the same
def test_a_process_forked_after_jax_started_is_refused_in_one_line():
    """JAX's backend does not survive a fork: a run in the child waited forever. Forked
    before JAX started, the child is not refused."""
    from jaxga._runtime import jax_settings

    ga = _small_ga()  # the backend has started in this process
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: report what the checks say, and leave at once
        try:
            jax_settings.check_jax_settings()  # as every driver and command does
            said = "not refused"
        except jaxga.ParameterError as e:
            said = str(e)
        try:  # a method of the pure core, of a GA built before the fork
            ga.init(jax.random.PRNGKey(0), ga.default_params)
            said += "|not refused"
        except jaxga.ParameterError as e:
            said += "|" + str(e)
        except BaseException as e:  # noqa: BLE001 - anything, reported to the parent
            said = f"{type(e).__name__}: {e}"
        os.write(write, said.encode()[:4000])
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as pipe:
        said = pipe.read()
    os.waitpid(pid, 0)
    checked, method = said.split("|")
    assert checked == method and "\n" not in said
    assert checked.startswith("this process was forked from one that had started JAX")
    assert "'spawn'" in checked


@pytest.mark.parametrize("kwargs, words", [
    ({"device": "cpu"}, "device must be one JAX device"),
    ({"device": [0]}, "device must be one JAX device"),
    ({"runs": 0}, "runs must be an integer >= 1, got 0"),
    ({"runs": True}, "runs must be an integer >= 1, got True"),
    ({"runs": "64"}, "runs must be an integer >= 1, got '64'"),
    ({"report": None}, "report must be a function taking one line, got None"),
])
def test_doctors_arguments_are_checked_before_any_probe(kwargs, words, monkeypatch):
    from jaxga._runtime import device_probe

    monkeypatch.setattr(device_probe, "probe", lambda *a: pytest.fail("probed"))
    with pytest.raises(jaxga.ParameterError, match=re.escape(words)):
        jaxga.doctor(presets=[], **kwargs)


def test_the_smoothing_traces_under_the_users_promotion_settings():
    """``jaxga.smooth.smooth`` mixes ranks and float with integer arithmetic: under
    ``"raise"`` and ``"strict"`` its tracing failed ("subtract on shapes (40, 2) (2,)").
    Traced only (``jax.eval_shape``): the failure was in tracing."""
    from jaxga.smooth import smooth

    r = canonical.run("sga", seeds=1)
    cells = jnp.asarray(r.paths.cells[0])
    n = jnp.asarray(r.paths.n_cells[0])
    grid = jaxga.GA("sga", canonical.MAP).grid
    with jax.numpy_rank_promotion("raise"), jax.numpy_dtype_promotion("strict"):
        out = jax.eval_shape(smooth, grid, cells, n)
    assert out == jax.eval_shape(smooth, grid, cells, n)
