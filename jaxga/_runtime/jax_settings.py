"""JAX's own switches that jaxga cannot compute under, refused in one line.

jaxga's programs are 32-bit (``int32`` cells and counters, ``float32`` fitness: the same
bits on every backend, :mod:`jaxga.core.dtypes`) and compiled ahead and stored
(:mod:`jaxga._runtime.executables`). JAX's 64-bit mode changes the types of Python numbers and
index arithmetic inside them, and with ``jit`` disabled JAX cannot run a compiled
program at all; a platform JAX cannot start fails deep in JAX; a flag XLA does not know
in ``XLA_FLAGS`` ends the process from XLA's C++ when the backend starts, with no Python
error to catch; a process forked after JAX's backend started cannot compute at all. Each
is named here, with the variable that set it, before any work.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import jax
import jaxlib

from jaxga._runtime.parallel import user_device_setting
from jaxga.core.errors import ParameterError
from jaxga.core.files import atomic_write_text, jaxga_cache_home
from jaxga.core.own_settings import check_jax_settings

__all__ = ["check_jax_settings", "check_platform", "check_xla_flags", "xla_flags_verdicts"]

XLA_FLAGS_PROBE_S = 120
"""Seconds the probe of ``XLA_FLAGS`` may take (a fresh process starting JAX's backend)."""


def check_platform() -> None:
    """Start JAX's backend, refusing in one line a platform it cannot start (a
    ``JAX_PLATFORMS`` naming a platform the machine lacks: CUDA without a GPU)."""
    try:
        jax.devices()
    except Exception as e:  # noqa: BLE001 - JAX raises RuntimeError, or fails an assert
        platforms = os.environ.get("JAX_PLATFORMS")
        why = (str(e).strip().splitlines() or [type(e).__name__])[0][:200]
        devices = user_device_setting()
        hint = (f": $JAX_PLATFORMS={platforms!r} names a platform JAX cannot start here; "
                "unset it or name one this machine has (cpu)" if platforms
                else f": check the CPU device count {devices}" if devices else "")
        raise ParameterError(f"JAX could not start its backend ({why}){hint}") from None


def xla_flags_verdicts() -> Path | None:
    """Where the flags XLA accepted are remembered (per jaxlib version and platforms), so
    that only the first command with new ``XLA_FLAGS`` pays for the probe; None without a
    known home folder (every command probes)."""
    return jaxga_cache_home("xla_flags.json")


def check_xla_flags() -> None:
    """Refuse in one :class:`ParameterError` line ``XLA_FLAGS`` that XLA does not accept,
    before this process starts JAX's backend (where XLA would end the process from C++):
    a fresh process starts the backend with the same environment; its verdict is
    remembered (:func:`xla_flags_verdicts`). Nothing without ``XLA_FLAGS``; a probe that
    fails for another reason is left to :func:`check_platform`."""
    flags = os.environ.get("XLA_FLAGS", "").strip()
    if not flags:
        return
    key = f"{flags}|{os.environ.get('JAX_PLATFORMS', '')}|jaxlib {jaxlib.__version__}"
    path = xla_flags_verdicts()
    try:
        known = json.loads(path.read_text()) if path is not None and path.is_file() else {}
    except (OSError, ValueError, RecursionError):  # a damaged file of verdicts: none known
        known = {}
    if isinstance(known, dict) and key in known:
        return
    try:
        probe = subprocess.run([sys.executable, "-c", "import jax; jax.devices()"],
                               capture_output=True, text=True, timeout=XLA_FLAGS_PROBE_S,
                               stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired):
        return
    if probe.returncode != 0:
        said = [line for line in probe.stderr.splitlines() if "XLA_FLAGS" in line]
        if said:
            why = said[-1].split("] ", 1)[-1].strip()[:200]
            raise ParameterError(f"XLA does not accept $XLA_FLAGS={flags!r} ({why}): fix or "
                                 "unset XLA_FLAGS")
        return
    known = known if isinstance(known, dict) else {}
    known[key] = True
    if path is None:
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(known, indent=1) + "\n")
    except OSError:
        pass  # not remembered: the next command probes again
