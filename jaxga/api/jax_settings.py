"""JAX's own switches that jaxga cannot compute under, refused in one line.

jaxga's programs are 32-bit (``int32`` cells and counters, ``float32`` fitness: the same
bits on every backend, :mod:`jaxga.core.dtypes`) and compiled ahead and stored
(:mod:`jaxga.api.executables`). JAX's 64-bit mode changes the types of Python numbers and
index arithmetic inside them, and with ``jit`` disabled JAX cannot run a compiled
program at all; a platform JAX cannot start fails deep in JAX. Each is named here, with
the variable that set it, before any work.
"""

from __future__ import annotations

import os

import jax

from jaxga.core.errors import ParameterError

__all__ = ["check_jax_settings", "check_platform"]


def _given(variable: str) -> str:
    value = os.environ.get(variable)
    return f" (${variable}={value})" if value is not None else ""


def check_jax_settings() -> None:
    """Refuse JAX's 64-bit mode and a disabled ``jit`` (set by their environment variables
    or by ``jax.config.update``) in one :class:`ParameterError` line each."""
    if jax.config.jax_enable_x64:
        raise ParameterError(
            f"JAX's 64-bit mode is on{_given('JAX_ENABLE_X64')}: jaxga computes in 32 bits "
            "(int32 cells, float32 fitness); turn it off for jaxga's runs (unset "
            "JAX_ENABLE_X64, or jax.config.update('jax_enable_x64', False))")
    if jax.config.jax_disable_jit:
        raise ParameterError(
            f"jit is disabled{_given('JAX_DISABLE_JIT')}: jaxga's runs are compiled "
            "programs, which JAX cannot run with jit disabled; unset JAX_DISABLE_JIT (or "
            "jax.config.update('jax_disable_jit', False))")


def check_platform() -> None:
    """Start JAX's backend, refusing in one line a platform it cannot start (a
    ``JAX_PLATFORMS`` naming a platform the machine lacks: CUDA without a GPU)."""
    try:
        jax.devices()
    except Exception as e:  # noqa: BLE001 - JAX raises RuntimeError, or fails an assert
        platforms = os.environ.get("JAX_PLATFORMS")
        why = (str(e).strip().splitlines() or [type(e).__name__])[0][:200]
        hint = (f": $JAX_PLATFORMS={platforms!r} names a platform JAX cannot start here; "
                "unset it or name one this machine has (cpu)" if platforms else "")
        raise ParameterError(f"JAX could not start its backend ({why}){hint}") from None
