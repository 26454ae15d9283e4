"""What a compiled run may contain on any platform: no float64, no host callbacks, no
CPU-only lowering or compiler option outside the CPU (docs/devices.md, "GPU")."""

from __future__ import annotations

import contextlib
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.experimental import io_callback
from jax.extend.core import Jaxpr

import jaxga
from jaxga._runtime import lowering, parallel, programs
from jaxga.config.presets import preset_names
from tests.jaxprs import sub_jaxprs

MAP = "classic_ga_gapp3_20x20"
WIDE = {"float64", "complex128"}


def _contents(jaxpr: Jaxpr, dtypes: set[str], primitives: set[str]) -> None:
    """Every dtype and primitive of ``jaxpr`` and of the jaxprs inside it (loops,
    conditionals, custom rules, shard_map bodies)."""
    for var in (*jaxpr.constvars, *jaxpr.invars):
        dtypes.add(str(var.aval.dtype))
    for eqn in jaxpr.eqns:
        primitives.add(eqn.primitive.name)
        for var in (*eqn.invars, *eqn.outvars):
            if hasattr(var.aval, "dtype"):
                dtypes.add(str(var.aval.dtype))
        for sub in sub_jaxprs(eqn.params):
            _contents(sub, dtypes, primitives)


def _host_calls(primitives: set[str]) -> set[str]:
    return {p for p in primitives if "callback" in p or p in ("debug_print", "print")}


def test_the_check_sees_float64_and_callbacks_inside_loops():
    """The walk below is not vacuous: a float64 and each kind of host callback hidden in
    a loop body are found (float64 needs ``jax_enable_x64``, which jaxga never sets)."""

    def leaky(x):
        def body(i, c):
            jax.debug.print("{}", c)
            jax.debug.callback(print, c)
            io_callback(print, None, c)
            c = jax.pure_callback(np.sin, jax.ShapeDtypeStruct(c.shape, c.dtype), c)
            return (c.astype(jnp.float64) + 1).astype(c.dtype)

        return jax.lax.fori_loop(0, 3, body, x)

    dtypes, primitives = set(), set()
    with jax.enable_x64(True):
        _contents(jax.make_jaxpr(leaky)(jnp.float32(0)).jaxpr, dtypes, primitives)
    assert "float64" in dtypes
    assert _host_calls(primitives) == {"debug_print", "debug_callback", "io_callback",
                                       "pure_callback"}


@pytest.mark.parametrize("preset", preset_names())
def test_a_whole_run_of_every_preset_is_float32_without_host_callbacks(preset):
    """``GA.run`` (initialisation, every generation, post-optimisation and metrics: the
    functions jaxga's compiled programs are made of) holds no float64 value and no
    host callback (``jax.pure_callback``, ``io_callback``, ``jax.debug.callback`` /
    ``print``): nothing waits for the host or takes the slow double-precision path of
    a GPU, and the run's numbers are float32 everywhere."""
    assert not jax.config.jax_enable_x64
    ga = jaxga.GA(preset, MAP, generations=2)
    dtypes, primitives = set(), set()
    _contents(jax.make_jaxpr(ga.run)(jax.random.PRNGKey(0), ga.default_params).jaxpr,
              dtypes, primitives)
    assert not dtypes & WIDE, sorted(dtypes)
    assert not _host_calls(primitives), sorted(_host_calls(primitives))
    assert {"while", "scan"} & primitives  # a whole run was traced, loops and all


@pytest.mark.skipif(lowering._rules() is None,
                    reason="this JAX does not expose the Threefry lowering rules")
def test_the_unrolled_threefry_changes_only_the_cpu_lowering(monkeypatch):
    """``jax.export`` lowers the same draws for the CPU, CUDA and ROCm (no GPU needed):
    jaxga's switch changes the CPU program only; the GPU programs are JAX's own,
    identical whether it is on or off."""
    key = jax.random.PRNGKey(0)
    text = {}
    monkeypatch.delenv(lowering.ENV_VAR, raising=False)
    for unrolled in (True, False):
        with lowering.jaxga_lowering() if unrolled else contextlib.nullcontext():
            for platform in ("cpu", "cuda", "rocm"):
                fn = jax.jit(lambda k: jax.random.uniform(k, (4,)))  # a fresh jit cache
                text[unrolled, platform] = jax.export.export(fn, platforms=[platform])(
                    key).mlir_module()
    assert text[True, "cpu"] != text[False, "cpu"]
    assert "stablehlo.while" in text[False, "cpu"]
    assert "stablehlo.while" not in text[True, "cpu"]
    for platform in ("cuda", "rocm"):
        assert text[True, platform] == text[False, platform]


def test_a_whole_run_lowers_for_cuda_without_custom_calls():
    """A whole run of the hybrid preset lowers for CUDA (``jax.export``, no GPU
    needed): no CPU-only kernel (no custom call at all) and no float64 in its program."""
    ga = jaxga.GA("hybrid", MAP, generations=2)
    module = jax.export.export(jax.jit(ga.run), platforms=["cuda"])(
        jax.random.PRNGKey(0), ga.default_params).mlir_module()
    assert not re.findall(r"custom_call @(\w+)", module)
    assert not re.search(r"\bf64\b", module)


def test_xla_cpu_options_go_to_the_cpu_finish_program_only():
    """``FINISH_COMPILER_OPTIONS`` are XLA:CPU options: the finish program gets them on
    the CPU and nothing else gets them anywhere (decision 012)."""
    options = programs.FINISH_COMPILER_OPTIONS
    assert all(k.startswith("xla_cpu_") for k in options)
    assert programs.compiler_options("finish", "cpu") == options
    assert programs.compiler_options("finish", "cpu") is not options  # a copy
    for name in ("init", "evolve"):
        assert programs.compiler_options(name, "cpu") is None
    for platform in ("gpu", "cuda", "rocm", "tpu"):
        for name in ("init", "evolve", "finish"):
            assert programs.compiler_options(name, platform) is None


def test_the_runs_go_over_the_default_backends_devices():
    """The runs are split over ``jax.local_devices()`` of the default backend (here the
    CPU's devices; on a GPU machine its GPUs), the devices seeds are sharded over."""
    from jaxga._runtime.seeds import seed_sharding

    devices = parallel.run_devices()
    assert devices == jax.local_devices()
    assert {d.platform for d in devices} == {jax.default_backend()}
    sharding, _ = seed_sharding()
    assert (sharding is None) == (len(devices) == 1)
    if sharding is not None:
        assert list(sharding.mesh.devices.flat) == devices
