"""The unrolled CPU lowering of Threefry (jaxga/_runtime/lowering.py): same bits, no loop."""

from __future__ import annotations

import contextlib

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._runtime import lowering
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


def _has_loop(fn, keys) -> bool:
    return "stablehlo.while" in fn.lower(keys).as_text()


def test_unrolled_and_rolled_threefry_give_identical_bits(monkeypatch):
    """jaxga's scope lowers the hash without a loop (its own programs), JAX's rule outside
    it has the loop; the same bits from both."""
    monkeypatch.delenv(lowering.ENV_VAR, raising=False)
    keys = jax.vmap(jax.random.PRNGKey)(jnp.arange(6, dtype=jnp.uint32))
    out = {}
    for unrolled in (False, True):
        fn = _random_program()
        with lowering.jaxga_lowering() if unrolled else contextlib.nullcontext():
            # The scope really changes the program (else this test would compare a thing
            # with itself): the rolled hash is a while loop, the unrolled one is not.
            assert _has_loop(fn, keys) is (not unrolled)
            out[unrolled] = jax.tree_util.tree_map(np.asarray, fn(keys))
    for a, b in zip(out[False], out[True]):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    # The draws are not degenerate (different keys, different bits).
    assert len({row.tobytes() for row in out[True][0]}) == 6


def test_the_scope_restores_jaxs_rule_nests_and_obeys_the_environment(monkeypatch):
    keys = jax.vmap(jax.random.PRNGKey)(jnp.arange(2, dtype=jnp.uint32))
    monkeypatch.delenv(lowering.ENV_VAR, raising=False)
    assert lowering.threefry_unrolled()
    with lowering.jaxga_lowering():
        with lowering.jaxga_lowering():
            assert not _has_loop(_random_program(), keys)
        assert not _has_loop(_random_program(), keys)  # the inner exit keeps the outer's
    assert _has_loop(_random_program(), keys)
    with pytest.raises(RuntimeError), lowering.jaxga_lowering():
        raise RuntimeError("a failed lowering")
    assert _has_loop(_random_program(), keys)  # restored after an error too
    monkeypatch.setenv(lowering.ENV_VAR, "rolled")
    assert not lowering.threefry_unrolled()
    with lowering.jaxga_lowering():
        assert _has_loop(_random_program(), keys)
    monkeypatch.setenv(lowering.ENV_VAR, " ")  # set but empty: the default
    assert lowering.check_environment() == "unrolled"
    monkeypatch.setenv(lowering.ENV_VAR, "sideways")
    with pytest.raises(ParameterError, match="JAXGA_THREEFRY must be 'unrolled' or 'rolled'"):
        lowering.check_environment()


def test_jaxgas_own_programs_are_lowered_in_its_scope(monkeypatch):
    """Every program jaxga compiles goes through ``executables.load_or_compile``, which
    lowers it in jaxga's scope: no Threefry loop in it, and JAX's rule back afterwards."""
    from jaxga._runtime import executables

    monkeypatch.delenv(lowering.ENV_VAR, raising=False)
    keys = jax.vmap(jax.random.PRNGKey)(jnp.arange(2, dtype=jnp.uint32))
    fn, texts = _random_program(), []

    def lower():
        texts.append(fn.lower(keys).as_text())
        return fn.lower(keys)

    program, read = executables.load_or_compile(None, jax.devices()[:1], lower)
    assert not read and "stablehlo.while" not in texts[0]
    assert _has_loop(_random_program(), keys)
    np.testing.assert_array_equal(program(keys)[0], fn(keys)[0])


USER_PROGRAM = """
import json, sys
import jax, jax.numpy as jnp
def text():
    fn = jax.jit(jax.vmap(lambda k: jax.random.uniform(k, (3,))))
    return fn.lower(jax.vmap(jax.random.PRNGKey)(jnp.arange(2, dtype=jnp.uint32))).as_text()
def settings():
    return {k: repr(v) for k, v in sorted(jax.config.values.items())}
seen = [(text(), settings())]
import jaxga
seen.append((text(), settings()))
ga = jaxga.GA("sga", "classic_ga_gapp3_20x20", generations=2)
seen.append((text(), settings()))
jax.jit(jax.vmap(ga.run, (0, None)))(jax.random.split(jax.random.PRNGKey(0), 2),
                                      ga.default_params)
seen.append((text(), settings()))
print(json.dumps(seen))
"""


@pytest.mark.slow  # a fresh process, a whole GA traced and compiled
def test_importing_jaxga_and_building_a_ga_leave_jax_alone(tmp_path):
    """``import jaxga``, ``jaxga.GA(...)`` and running the GA's pure core change no JAX
    setting and not the lowering of the user's own ``jax.random`` program."""
    import json
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_", "JAXGA_"))}
    env["HOME"] = str(tmp_path)
    proc = subprocess.run([sys.executable, "-c", USER_PROGRAM], env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    seen = json.loads(proc.stdout.splitlines()[-1])
    assert "stablehlo.while" in seen[0][0]  # JAX's own CPU rule, a loop
    for text, settings in seen[1:]:
        assert text == seen[0][0]
        assert settings == seen[0][1], {k for k in settings if settings[k] != seen[0][1].get(k)}


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


def test_the_top_level_namespace_exports_only_the_public_api():
    """``jaxga``'s names are its ``__all__`` (and its own subpackages, which Python
    binds on import): no stray import such as ``contextlib`` or ``lowering``."""
    import types

    import jaxga

    stray = [name for name, value in vars(jaxga).items()
             if not name.startswith("_") and name not in jaxga.__all__
             and not (isinstance(value, types.ModuleType)
                      and value.__name__ == f"jaxga.{name}")]
    assert stray == []
    assert "configure" in jaxga.__all__ and "lowering" not in vars(jaxga)
