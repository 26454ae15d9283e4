"""Does JAX's default backend compute what the CPU computes? The exact probes.

Some of jaxga's results must be the same bits on every correct backend (docs/devices.md,
"Exactness"): random bits, and the walks of the initialisers, which hold no operation
a correct backend may compute differently (integer steps, stable sorts, reviewed
scatters). Each probe computes one of them for many runs as ONE call on a device (the
large batches at which a GPU once computed wrong initial populations) and again on the
CPU with the runs in another order (so that a run's neighbours and position in the call
change), and counts the runs that differ.

:func:`probe` runs the probes; :func:`check_backend` is the gate of every run on a
backend other than the CPU: it probes that backend once per jaxlib version and device
kind, remembers the verdict, and refuses to compute on a backend that failed, unless
the user says otherwise (``JAXGA_TRUST_DEVICE=1``). :func:`jaxga.api.doctor.doctor`
adds whole runs of every preset and a throughput figure.
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import jaxlib
import numpy as np

from jaxga._runtime.lowering import jaxga_lowering
from jaxga.core import prng
from jaxga.core.errors import JaxgaError, PlatformWarning
from jaxga.core.files import atomic_write_text, jaxga_cache_home
from jaxga.core.grid import Grid
from jaxga.core.path_geometry import geometry
from jaxga.core.paths import has_endpoints, is_continuous, is_loop_free
from jaxga.core.version import VERSION
from jaxga.engine.maptables import with_tables
from jaxga.maps import load_map_info
from jaxga.operators.guide import with_guide
from jaxga.operators.init.field import field_walk
from jaxga.operators.init.walks import random_walk

__all__ = ["DeviceDisagrees", "ProbeRow", "check_backend", "differing", "needs_probe", "probe",
           "probe_grid", "rolled_on_cpu", "verdict_line", "verdicts_path"]

PROBE_MAP = "classic_ga_gapp3_20x20"
"""The map of the walk probes: the plain GA's map of the literature, where sga's random
walks both succeed and fail often, so a probe sees both outcomes (decision 040)."""

CAPACITY = 160
"""Path capacity of the walk probes (sga's on :data:`PROBE_MAP`)."""

RUNS = 2048
"""Runs per call of the probes: the largest call a GPU computes (docs/devices.md)."""

WALKS_PER_RUN = 4
"""Walks per run in the walk probes (a round of an initialiser draws one per slot)."""

TRUST_ENV = "JAXGA_TRUST_DEVICE"
"""``1``: compute on a backend even though it failed the probe (said once, as a warning)."""

VERDICTS_ENV = "JAXGA_DEVICE_VERDICTS"
"""Path of the remembered verdicts (default ``~/.cache/jaxga/device_verdicts.json``)."""


class DeviceDisagrees(JaxgaError):
    """JAX's default backend computed a probe differently from the CPU: its results
    would not be jaxga's (``jaxga doctor`` shows which)."""


@dataclasses.dataclass(frozen=True)
class ProbeRow:
    """One probe's outcome: ``compared`` runs, ``differ`` of them not the CPU's bit for bit.

    ``exact``: the probe must agree bit for bit (else its rule is in ``detail``, as the
    doctor's whole runs off the CPU); ``agrees``: it passed; ``detail``: what else was
    measured (success rates, identical runs, ...)."""

    name: str
    compared: int
    differ: int
    agrees: bool
    seconds: float
    exact: bool = True
    detail: str = ""

    def as_dict(self) -> dict:
        """The row as JSON values."""
        return dataclasses.asdict(self)


def probe_grid() -> Grid:
    """:data:`PROBE_MAP` with the tables and distance fields the walks read."""
    return with_tables(with_guide(load_map_info(PROBE_MAP).grid))


def _keys(n: int, salt: int) -> jax.Array:
    return jax.vmap(lambda i: prng.fold_in(prng.seed_key(salt), i))(
        jnp.arange(n, dtype=jnp.uint32))


def rolled_on_cpu(on_device: Callable, on_cpu: Callable, keys: np.ndarray,
                  device: jax.Device) -> tuple[list, list]:
    """``on_device(keys)`` with the keys on ``device``, and ``on_cpu`` of the same keys on
    the CPU with the runs in another order (rolled by half a call, then put back): both
    results as pytrees of host arrays, runs first, in the same order."""
    shift = keys.shape[0] // 2
    here = on_device(jax.device_put(keys, device))
    there = on_cpu(jax.device_put(np.roll(keys, shift, axis=0), jax.devices("cpu")[0]))
    return (jax.tree_util.tree_map(np.asarray, here),
            jax.tree_util.tree_map(lambda x: np.roll(np.asarray(x), -shift, axis=0), there))


def _compare(fn: Callable, keys: np.ndarray, device: jax.Device) -> tuple[list, list]:
    """``fn`` of every key as one call on ``device`` and on the CPU (:func:`rolled_on_cpu`):
    the leaves of both."""
    with jaxga_lowering():  # the programs jaxga itself runs
        here, there = rolled_on_cpu(jax.jit(fn), jax.jit(fn), keys, device)
    return jax.tree_util.tree_leaves(here), jax.tree_util.tree_leaves(there)


def differing(here: list, there: list) -> np.ndarray:
    """Per run (the leading axis): does any leaf differ in any bit?"""
    bad = np.zeros(here[0].shape[0], bool)
    for a, b in zip(here, there):
        a8 = np.ascontiguousarray(a).view(np.uint8).reshape(a.shape[0], -1)
        b8 = np.ascontiguousarray(b).view(np.uint8).reshape(b.shape[0], -1)
        bad |= np.any(a8 != b8, axis=1)
    return bad


def random_bits(device: jax.Device, runs: int = RUNS) -> ProbeRow:
    """``jax.random`` words of ``runs`` keys (split, fold_in, bits, uniform): bit for bit."""
    t0 = time.perf_counter()

    def one(key):
        a, b = prng.split(key)
        return (prng.bits(a, (16,), jnp.uint32),
                prng.uniform(prng.fold_in(b, 7), (8,), jnp.float32))

    here, there = _compare(jax.vmap(one), np.asarray(_keys(runs, 0)), device)
    bad = differing(here, there)
    return ProbeRow("random bits", runs, int(bad.sum()), not bad.any(),
                    time.perf_counter() - t0)


def walks(kind: str, device: jax.Device, runs: int = RUNS,
          per_run: int = WALKS_PER_RUN, grid: Grid | None = None) -> ProbeRow:
    """``per_run`` walks of each of ``runs`` runs, one nested ``vmap``: ``kind`` is
    ``"sga walks"`` (the plain GA's random walks, Zhu & Pan 4.1) or ``"field walks"``
    (jaxga's initialiser that cannot fail). Each walk's cells, node count, success flag,
    the path check of its path and the integer geometry every fitness reads (steps,
    turns, nodes: :func:`jaxga.core.path_geometry.geometry`): bit for bit. An H200 once
    computed the check's step spans wrongly at this batch (decision 048)."""
    t0 = time.perf_counter()
    grid = probe_grid() if grid is None else grid
    walk = {"sga walks": random_walk, "field walks": field_walk}[kind]

    def one(key):
        cells, n, ok = walk(key, grid, CAPACITY)
        valid = (has_endpoints(grid, cells, n) & is_continuous(grid, cells, n)
                 & is_loop_free(cells, n, grid.n_cells))
        g = geometry(grid, cells, n)
        return cells, n, ok, ok & valid, (g.node, g.dx, g.dy, g.cross, g.dot, g.turning)

    keys = np.asarray(jax.vmap(lambda k: prng.split(k, per_run))(_keys(runs, 1)))
    here, there = _compare(jax.vmap(jax.vmap(one)), keys, device)
    bad = differing(here, there)
    rate_here, rate_there = float(here[3].mean()), float(there[3].mean())
    broken = int((here[2] & ~here[3]).sum())  # a walk that says it arrived, on a broken path
    return ProbeRow(f"{kind} ({runs} runs x {per_run})", runs, int(bad.sum()),
                    not bad.any() and broken == 0, time.perf_counter() - t0,
                    detail=f"success {rate_here:.2%} (CPU {rate_there:.2%})"
                    + (f", {broken} broken paths" if broken else ""))


def probe(device: jax.Device | None = None, runs: int = RUNS) -> list[ProbeRow]:
    """The exact probes on ``device`` (default: the first of JAX's default backend)."""
    device = jax.devices()[0] if device is None else device
    grid = probe_grid()
    return [random_bits(device, runs), walks("sga walks", device, runs, grid=grid),
            walks("field walks", device, runs, grid=grid)]


def verdict_line(rows: Sequence[ProbeRow], device: jax.Device) -> str:
    """``"agrees with the CPU"`` or ``"DISAGREES: <first failing probe>"``, naming the device."""
    name = describe(device)
    bad = [r for r in rows if not r.agrees]
    if not bad:
        return f"{name}: agrees with the CPU ({len(rows)} probes)"
    r = bad[0]
    return (f"{name}: DISAGREES: {r.name}: {r.differ} of {r.compared} runs differ from the "
            f"CPU's" + (f" ({r.detail})" if r.detail else ""))


def describe(device: jax.Device) -> str:
    """The device as a verdict names it: platform, kind, jaxlib version."""
    return f"{device.platform} ({device.device_kind}, jaxlib {jaxlib.__version__})"


def run_environment() -> dict[str, Any]:
    """What computes this process's runs, as their JSON records it: the versions of
    jaxga, JAX, jaxlib, NumPy and Python and the default device (:func:`describe`).
    Another backend may round otherwise (decision 040), and a stored program belongs to
    one version: two results are compared knowing both. The number of devices is not
    recorded: a run's result does not depend on it (docs/devices.md)."""
    return {"jaxga": VERSION, "jax": jax.__version__,
            "jaxlib": jaxlib.__version__, "numpy": np.__version__,
            "python": platform.python_version(), "device": describe(jax.devices()[0])}


# ------------------------------------------------------------------------ the gate
def verdicts_path() -> Path | None:
    """Where the verdicts of :func:`check_backend` are remembered (:data:`VERDICTS_ENV`),
    None where that is nowhere (no variable and no known home folder: every process
    probes)."""
    given = os.environ.get(VERDICTS_ENV)
    if given:
        return Path(given)
    return jaxga_cache_home("device_verdicts.json")


def _verdict_key(device: jax.Device) -> str:
    return f"{device.platform}|{device.device_kind}|jaxlib {jaxlib.__version__}"


MAX_VERDICTS_BYTES = 1 << 20
"""The largest verdicts file read: a few lines per device kind and jaxlib version."""


def _remembered() -> dict:
    path = verdicts_path()
    try:  # a regular file only: a FIFO would block the run, /dev/zero never end
        if path is None or not path.is_file() or path.stat().st_size > MAX_VERDICTS_BYTES:
            return {}
        data = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError):
        return {}  # none yet, or unreadable: probe again
    return data if isinstance(data, dict) else {}


def _remember(key: str, line: str, agrees: bool) -> None:
    data = _remembered()
    data[key] = {"agrees": agrees, "verdict": line}
    path = verdicts_path()
    if path is None:  # no home folder: the next process probes again
        return
    try:  # a first run on a fresh machine: ~/.cache/jaxga does not exist yet
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(data, indent=1) + "\n")
    except (OSError, JaxgaError) as err:  # not remembered: the next process probes again
        warnings.warn(f"the device verdict could not be saved ({err})", PlatformWarning,
                      stacklevel=3)


_CHECKED: dict[str, tuple[bool, str]] = {}


def _verdict(key: str) -> tuple[bool, str] | None:
    """This device kind's verdict, from the process or the remembered file; None if it
    has none yet (kept in the process once read)."""
    if key not in _CHECKED:
        seen = _remembered().get(key)
        if not (isinstance(seen, dict) and isinstance(seen.get("agrees"), bool)):
            return None
        _CHECKED[key] = (seen["agrees"], str(seen.get("verdict", "")))
    return _CHECKED[key]


def needs_probe(device: jax.Device | None = None) -> bool:
    """Whether :func:`check_backend` would run the probes now (a device off the CPU that
    has no verdict yet): the runs then show it as a phase of its own."""
    device = jax.devices()[0] if device is None else device
    return device.platform != "cpu" and _verdict(_verdict_key(device)) is None


def check_backend(device: jax.Device | None = None,
                  probes: Callable[[jax.Device], list[ProbeRow]] = probe) -> None:
    """Refuse to compute on a backend that computes jaxga's exact results differently
    from the CPU (:class:`DeviceDisagrees`, one line), unless ``JAXGA_TRUST_DEVICE=1``.

    Nothing to do on the CPU. Elsewhere the probes run once per jaxlib version and
    device kind (seconds: a few small programs); their verdict is remembered in
    :func:`verdicts_path` and in the process. ``probes`` is for tests (a backend made
    to disagree)."""
    device = jax.devices()[0] if device is None else device
    if device.platform == "cpu":
        return
    key = _verdict_key(device)
    if _verdict(key) is None:
        rows = probes(device)
        line = verdict_line(rows, device)
        agrees = all(r.agrees for r in rows)
        _remember(key, line, agrees)
        _CHECKED[key] = (agrees, line)
    agrees, line = _CHECKED[key]
    if agrees:
        return
    if os.environ.get(TRUST_ENV) == "1":
        warnings.warn(f"computing on a backend that failed jaxga's probe ({TRUST_ENV}=1): "
                      f"{line}", PlatformWarning, stacklevel=3)
        return
    raise DeviceDisagrees(f"{line}; refusing to compute there (details: jaxga doctor; "
                          f"JAX_PLATFORMS=cpu uses the CPU, {TRUST_ENV}=1 computes anyway)")
