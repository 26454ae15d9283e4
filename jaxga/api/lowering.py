"""How jaxga's programs are lowered for XLA: the Threefry hash without a loop on the CPU.

Every random number of jaxga comes from ``jax.random`` with the default Threefry-2x32
generator. On the CPU, JAX lowers each Threefry hash as a ``fori_loop`` over its
five key-injection blocks (a ``while`` in the HLO); on every other platform it emits the
same 20 rounds unrolled. A generation of a GA calls the hash about 20 times (key splits,
gates, operator draws), and each rolled call is a loop of its own that XLA compiles into
separate kernels and cannot fuse with its neighbours.

:func:`unroll_threefry_on_cpu` makes the CPU use JAX's unrolled lowering. The hash is the
same function, so every random bit, and so every result of jaxga, is identical (tested
bit for bit in ``tests/api/test_lowering.py``); only the compiled program changes, which
XLA compiles faster (decision 013).

Only the CPU: the rule is registered for ``platform="cpu"`` alone, so a program lowered
for a GPU (CUDA or ROCm) keeps JAX's own rule there (the unrolled rounds, or JAX's GPU
kernel when ``jax_threefry_gpu_kernel_lowering`` is set), whatever this module does;
``tests/engine/test_platform.py`` lowers the same draws for ``cuda`` and ``rocm`` with
and without it and finds the same program (docs/devices.md).

``import jaxga`` turns it on. It changes how JAX lowers Threefry on the CPU for the whole
process, which only ever changes compile time: set ``JAXGA_THREEFRY=rolled`` in the
environment before importing jaxga, or call ``unroll_threefry_on_cpu(False)``, to keep
JAX's own choice. JAX exposes the unrolled rule only privately
(``jax._src.random.threefry2x32``): if a JAX release moves it, this does nothing and
reports ``False``.
"""

from __future__ import annotations

import os

from jax.extend.core.primitives import threefry2x32_p
from jax.interpreters import mlir

from jaxga.core.errors import ParameterError

__all__ = ["threefry_unrolled", "unroll_threefry_on_cpu"]

ENV_VAR = "JAXGA_THREEFRY"
"""``rolled`` keeps JAX's own CPU lowering of Threefry when jaxga is imported."""

_state = {"unrolled": False}


def _rules():
    """(unrolled, rolled) lowering rules of JAX's Threefry primitive, or None."""
    try:
        from jax._src.random import threefry2x32 as tf

        return tf._threefry2x32_lowering_rule, tf._threefry2x32_cpu_lowering_rule
    except (ImportError, AttributeError):
        return None


def unroll_threefry_on_cpu(enable: bool = True) -> bool:
    """Lower ``jax.random``'s Threefry hash unrolled (``True``) or rolled (JAX's CPU
    default) on the CPU, for programs lowered from now on.

    Same random bits either way (the hash of Salmon et al. 2011 that ``jax.random``
    implements); the unrolled form compiles faster and fuses with its consumers.
    Other platforms are never touched (their lowering is JAX's own). Returns whether
    the requested lowering is in effect (``False`` when this JAX does not expose the
    rules).
    """
    rules = _rules()
    if rules is None:
        return False
    unrolled, rolled = rules
    # JAX registers its unrolled rule out of line (one function, called at each site).
    mlir.register_lowering(threefry2x32_p, unrolled if enable else rolled,
                           platform="cpu", inline=not enable)
    _state["unrolled"] = bool(enable)
    return True


def threefry_unrolled() -> bool:
    """Whether jaxga installed the unrolled CPU lowering of Threefry."""
    return _state["unrolled"]


def check_environment() -> str:
    """``$JAXGA_THREEFRY`` (``unrolled``, the default, or ``rolled``), lower case;
    :class:`ParameterError` for any other value.

    ``import jaxga`` leaves JAX's lowering alone on such a value and does not raise (the
    command line could only show it as a traceback); :func:`jaxga.run` and the other
    entry points call this first and refuse it before anything compiles."""
    given = os.environ.get(ENV_VAR, "")
    value = given.strip().lower() or "unrolled"  # set but empty: as if unset
    if value not in ("unrolled", "rolled"):
        raise ParameterError(f"{ENV_VAR} must be 'unrolled' or 'rolled', got {given!r}")
    return value


def configure_from_environment() -> bool:
    """Apply ``$JAXGA_THREEFRY`` (:func:`check_environment`) at import."""
    return unroll_threefry_on_cpu(check_environment() == "unrolled")
