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
    alone = canonical.run("sga")
    with user_prng():
        under = canonical.run("sga")
    _same_runs(alone, under)


def _lowered_text(ga: jaxga.GA) -> str:
    keys = jnp.stack([jnp.zeros(2, jnp.uint32), jnp.arange(2, dtype=jnp.uint32)], -1)
    text = jax.jit(jax.vmap(ga.run, (0, None))).lower(keys, ga.default_params).as_text(
        debug_info=False)
    return re.sub(r"loc\(.*?\)", "", text)


def test_the_pure_core_lowers_to_the_same_program_under_the_users_prng_settings():
    """The whole pure-core run of a preset, under the user's own ``jax.jit``: the same
    StableHLO, so the same bits, with every PRNG setting changed."""
    ga = jaxga.GA("sga", canonical.MAP, generations=2)
    default = _lowered_text(ga)
    with user_prng():
        assert _lowered_text(ga) == default


def test_jaxgas_host_work_runs_under_a_refusing_transfer_guard():
    alone = canonical.run("sga")
    with jax.transfer_guard("disallow"):
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
