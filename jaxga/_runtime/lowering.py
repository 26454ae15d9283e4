"""How jaxga's own programs are lowered for XLA: the Threefry hash without a loop on the
CPU, in a scope that leaves the user's programs alone.

Every random number of jaxga comes from ``jax.random`` with the default Threefry-2x32
generator. On the CPU, JAX lowers each Threefry hash as a ``fori_loop`` over its
five key-injection blocks (a ``while`` in the HLO); on every other platform it emits the
same 20 rounds unrolled. A generation of a GA calls the hash about 20 times (key splits,
gates, operator draws), and each rolled call is a loop of its own that XLA compiles into
separate kernels and cannot fuse with its neighbours.

:func:`jaxga_lowering` makes the CPU use JAX's unrolled lowering while jaxga lowers its own
programs (:func:`jaxga._runtime.executables.load_or_compile`, :meth:`jaxga.GA.plan`), and puts
JAX's own rule back afterwards. The hash is the same function, so every random bit, and so
every result of jaxga, is identical (tested bit for bit in ``tests/api/test_lowering.py``);
only the compiled program changes, which XLA compiles faster (decision 013). Importing
jaxga changes no lowering: a user's own ``jax.random`` program lowers to the same text
with or without jaxga (tested).

Only the CPU: the rule is registered for ``platform="cpu"`` alone, so a program lowered
for a GPU (CUDA or ROCm) keeps JAX's own rule there (the unrolled rounds, or JAX's GPU
kernel when ``jax_threefry_gpu_kernel_lowering`` is set); ``tests/engine/test_platform.py``
lowers the same draws for ``cuda`` and ``rocm`` with and without it and finds the same
program (docs/devices.md).

``JAXGA_THREEFRY=rolled`` keeps JAX's own lowering for jaxga's programs too. JAX exposes
the unrolled rule only privately (``jax._src.random.threefry2x32``): if a JAX release
moves it, jaxga's programs keep JAX's rule. While a scope is open (jaxga lowering a
program), another thread's lowering for the CPU also sees the unrolled rule: the same
bits, another program text.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator

from jax.extend.core.primitives import threefry2x32_p
from jax.interpreters import mlir

from jaxga.core.errors import ParameterError

__all__ = ["check_environment", "jaxga_lowering", "threefry_unrolled"]

ENV_VAR = "JAXGA_THREEFRY"
"""``rolled`` keeps JAX's own CPU lowering of Threefry for jaxga's programs too."""

_scope = {"depth": 0, "saved": None}
_lock = threading.RLock()


def _rules():
    """(unrolled, rolled) lowering rules of JAX's Threefry primitive, or None."""
    try:
        from jax._src.random import threefry2x32 as tf

        return tf._threefry2x32_lowering_rule, tf._threefry2x32_cpu_lowering_rule
    except (ImportError, AttributeError):
        return None


def _cpu_rules() -> dict | None:
    """JAX's table of CPU-specific lowering rules, or None where this JAX has none."""
    from jax._src.interpreters import mlir as internal

    return getattr(internal, "_platform_specific_lowerings", {}).get("cpu")


def threefry_unrolled() -> bool:
    """Whether jaxga lowers its own programs with the unrolled Threefry hash on the CPU:
    ``$JAXGA_THREEFRY`` is ``unrolled`` (the default) and this JAX exposes the rules."""
    try:
        unrolled = check_environment() == "unrolled"
    except ParameterError:
        unrolled = False
    return unrolled and _rules() is not None and _cpu_rules() is not None


@contextlib.contextmanager
def jaxga_lowering() -> Iterator[None]:
    """While open, ``jax.random``'s Threefry hash lowers unrolled on the CPU (where
    :func:`threefry_unrolled`); on leaving, JAX's own rule is back. Re-entrant and
    thread-safe (the rule is swapped on the first entry and restored on the last exit).

    Same random bits either way (the hash of Salmon et al. 2011 that ``jax.random``
    implements); the unrolled form compiles faster and fuses with its consumers
    (decision 013).
    Other platforms are never touched (their lowering is JAX's own)."""
    if not threefry_unrolled():
        yield
        return
    with _lock:
        if _scope["depth"] == 0:
            table = _cpu_rules()
            _scope["saved"] = table.get(threefry2x32_p)
            # JAX registers its unrolled rule out of line (one function, called at each
            # site)
            mlir.register_lowering(threefry2x32_p, _rules()[0], platform="cpu", inline=False)
        _scope["depth"] += 1
    try:
        yield
    finally:
        with _lock:
            _scope["depth"] -= 1
            if _scope["depth"] == 0:
                table = _cpu_rules()
                if _scope["saved"] is None:
                    table.pop(threefry2x32_p, None)
                else:
                    table[threefry2x32_p] = _scope["saved"]
                _scope["saved"] = None


def check_environment() -> str:
    """``$JAXGA_THREEFRY`` (``unrolled``, the default, or ``rolled``), lower case;
    :class:`ParameterError` for any other value (refused by :func:`jaxga.run` and the
    other entry points before anything compiles)."""
    given = os.environ.get(ENV_VAR, "")
    value = given.strip().lower() or "unrolled"  # set but empty: as if unset
    if value not in ("unrolled", "rolled"):
        raise ParameterError(f"{ENV_VAR} must be 'unrolled' or 'rolled', got {given!r}")
    return value
