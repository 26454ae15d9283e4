"""The unrolled CPU lowering of Threefry (jaxga/api/lowering.py): same bits, no loop."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga.api import lowering
from jaxga.core.errors import ParameterError

pytestmark = pytest.mark.skipif(lowering._rules() is None,
                                reason="this JAX does not expose the Threefry lowering rules")


def _random_program():
    """A fresh function (own jit cache) drawing through every jax.random path jaxga uses:
    split, fold_in, bits, uniform, randint, permutation, choice, under vmap."""

    def draw(key):
        k1, k2, k3 = jax.random.split(key, 3)
        k4 = jax.random.fold_in(k1, 7)
        return (
            jax.random.bits(k2, (5,), jnp.uint32),
            jax.random.uniform(k3, (3,)),
            jax.random.randint(k4, (4,), 0, 1000),
            jax.random.permutation(k1, 9),
            jax.random.choice(k2, 20, (3,), replace=False),
            jax.random.key_data(jax.random.wrap_key_data(k4)),
        )

    return jax.jit(jax.vmap(draw))


@pytest.fixture
def restore_lowering():
    before = lowering.threefry_unrolled()
    yield
    lowering.unroll_threefry_on_cpu(before)


def _has_loop(fn, keys) -> bool:
    return "stablehlo.while" in fn.lower(keys).as_text()


def test_unrolled_and_rolled_threefry_give_identical_bits(restore_lowering):
    keys = jax.vmap(jax.random.PRNGKey)(jnp.arange(6, dtype=jnp.uint32))
    out = {}
    for unrolled in (False, True):
        assert lowering.unroll_threefry_on_cpu(unrolled)
        fn = _random_program()
        # The switch really changes the program (else this test would compare a thing
        # with itself): the rolled hash is a while loop, the unrolled one is not.
        assert _has_loop(fn, keys) is (not unrolled)
        out[unrolled] = jax.tree_util.tree_map(np.asarray, fn(keys))
    for a, b in zip(out[False], out[True]):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    # The draws are not degenerate (different keys, different bits).
    assert len({row.tobytes() for row in out[True][0]}) == 6


def test_importing_jaxga_unrolls_threefry_unless_told_not_to(monkeypatch, restore_lowering):
    import os

    if os.environ.get(lowering.ENV_VAR, "unrolled").lower() == "unrolled":
        assert lowering.threefry_unrolled()
    monkeypatch.setenv(lowering.ENV_VAR, "rolled")
    assert lowering.configure_from_environment()
    assert not lowering.threefry_unrolled()
    keys = jax.vmap(jax.random.PRNGKey)(jnp.arange(2, dtype=jnp.uint32))
    assert _has_loop(_random_program(), keys)
    monkeypatch.setenv(lowering.ENV_VAR, " ")  # set but empty: the default
    assert lowering.check_environment() == "unrolled"
    monkeypatch.setenv(lowering.ENV_VAR, "sideways")
    with pytest.raises(ParameterError, match="JAXGA_THREEFRY must be 'unrolled' or 'rolled'"):
        lowering.configure_from_environment()


def test_a_bad_threefry_setting_is_one_line_on_the_command_line_and_refused_by_run(
        monkeypatch):
    """``import jaxga`` does not raise on a bad ``$JAXGA_THREEFRY`` (the console script
    could only show a traceback); the command line says it in one line (exit 2) and
    ``jaxga.run`` refuses it before anything compiles."""
    import os
    import subprocess
    import sys

    import jaxga

    env = {**os.environ, lowering.ENV_VAR: "sideways"}
    proc = subprocess.run([sys.executable, "-m", "jaxga.cli", "presets"], env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("jaxga: error: JAXGA_THREEFRY must be 'unrolled' or "
                                   "'rolled', got 'sideways'")
    assert proc.stdout == ""
    monkeypatch.setenv(lowering.ENV_VAR, "sideways")
    monkeypatch.setattr(jaxga.api.runs, "build", lambda *a, **k: pytest.fail("it went on"))
    with pytest.raises(ParameterError, match="JAXGA_THREEFRY must be"):
        jaxga.run("sga", "classic_ga_gapp3_20x20", seeds=1)
