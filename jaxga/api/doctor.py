"""``jaxga doctor``: does this machine's JAX backend compute jaxga's results?

Runs on JAX's default backend, against the CPU in the same process
(docs/devices.md, "Exactness"):

- the exact probes of :mod:`jaxga._runtime.device_probe`: random bits, and one round of the
  walks of sga's initialiser and of the field walk for 2048 runs in one call, bit for bit;
- a few whole runs of every preset (``GA.run``): bit for bit on the CPU (in another order
  of the runs in the call); on another backend, where a one-ulp difference of a division,
  a square root or a power may send a run on another trajectory, each run's success must
  equal the CPU's and its path must be clear and as long as it says when the CPU checks
  it (the share of identical runs is reported);
- a short throughput figure: individual-generations per second of sga on the probe map.

The verdict is one line: ``agrees with the CPU`` or ``DISAGREES:`` and the first
failing probe.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import hashlib
import os
import time
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._runtime import device_probe, executables
from jaxga._runtime.device_probe import ProbeRow
from jaxga._runtime.programs import shape_spec
from jaxga.api.ga import GA
from jaxga.config.presets import load_preset, preset_names
from jaxga.core import prng
from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.geometry import segments_clear
from jaxga.core.grid import Grid, as_integer
from jaxga.core.objectives import path_length
from jaxga.core.own_settings import own_settings

__all__ = ["DoctorReport", "doctor", "runs_off_tolerance"]

RUN_SEEDS = 4
"""Seeds of each preset's whole runs (sga's: :data:`THROUGHPUT_SEEDS`)."""

THROUGHPUT_SEEDS = 64
"""Seeds of sga's whole runs, whose second call gives the throughput figure."""

GENERATIONS = 10
"""Generations of the whole runs."""

LENGTH_TOLERANCE = 1e-5
"""Relative difference allowed between a length a backend reports and the CPU's
evaluation of the same path (an ulp of each square root of a path's segments)."""


@dataclasses.dataclass(frozen=True)
class DoctorReport:
    """What :func:`doctor` found: ``agrees`` (every probe passed), the ``verdict`` line,
    one :class:`~jaxga._runtime.device_probe.ProbeRow` per probe, the throughput in
    individual-generations per second, the time taken."""

    device: str
    agrees: bool
    verdict: str
    rows: tuple[ProbeRow, ...]
    throughput: float
    seconds: float

    def table(self) -> str:
        """The probes as an aligned text table, then the throughput."""
        lines = [f"{'probe':<34} {'rule':<6} {'runs':>5} {'differ':>6} {'time':>7}  "
                 f"{'result':<6} detail"]
        for r in self.rows:
            lines.append(f"{r.name:<34} {'exact' if r.exact else 'close':<6} {r.compared:>5} "
                         f"{r.differ:>6} {r.seconds:>6.1f}s  {'ok' if r.agrees else 'FAIL':<6} "
                         f"{r.detail}")
        if not self.throughput:
            return "\n".join(lines)
        lines.append(f"throughput: {self.throughput:,.0f} individual-generations/s "
                     f"(sga, {THROUGHPUT_SEEDS} runs of {GENERATIONS} generations on "
                     f"{device_probe.PROBE_MAP}, one call)")
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """The report as JSON values."""
        return {"device": self.device, "agrees": self.agrees, "verdict": self.verdict,
                "probes": [r.as_dict() for r in self.rows],
                "throughput_individual_generations_per_s": self.throughput,
                "seconds": self.seconds}


def _compiled(ga: GA, seeds: int, device: jax.Device):
    """The program of ``seeds`` runs of ``ga`` in one call for ``device``: read from
    jaxga's program store (no tracing) or compiled and stored there. The map is part of
    the program, so its cells and endpoints are part of the key."""
    keys = jax.device_put(jnp.zeros((seeds, 2), jnp.uint32), device)
    params = jax.device_put(ga.default_params, device)
    the_map = hashlib.blake2b(np.asarray(ga.grid.blocked).tobytes() + repr(
        (int(ga.grid.start), int(ga.grid.goal))).encode(), digest_size=16).hexdigest()
    key = executables.program_key("doctor runs", ga.algorithm, shape_spec(ga.grid),
                                  shape_spec(params), seeds, [device],
                                  settings=(GENERATIONS, the_map))
    program, _ = executables.load_or_compile(
        key, [device], lambda: jax.jit(jax.vmap(ga.run, (0, None))).lower(keys, params))
    return program


def runs_off_tolerance(grid: Grid, here: dict, there: dict) -> np.ndarray:
    """``bool[runs]``: the device's runs ``here`` that break the contract for results
    that may round differently (decision 040; docs/devices.md, "Exactness"), against the
    CPU's runs ``there`` of the same keys: another success, or a successful path that is
    blocked or whose reported length is not its length re-evaluated on the CPU (within
    :data:`LENGTH_TOLERANCE`)."""
    cpu = jax.devices("cpu")[0]
    grid = jax.device_put(grid, cpu)
    cells, n_cells = jax.device_put((np.asarray(here["cells"]), np.asarray(here["n_cells"])),
                                    cpu)
    clear = jax.jit(jax.vmap(lambda c, n: jnp.all(segments_clear(grid, c, n))))(cells, n_cells)
    length = np.asarray(jax.jit(jax.vmap(lambda c, n: path_length(grid, c, n)))(cells, n_cells))
    ok = np.asarray(here["success"]).astype(bool)
    close = np.abs(length - np.asarray(here["length"])) <= LENGTH_TOLERANCE * np.abs(length)
    return (ok != np.asarray(there["success"]).astype(bool)) | (ok & ~(np.asarray(clear) & close))


def _runner(program, ga: GA) -> Callable:
    """``keys -> results`` of a compiled whole-run program, the parameters on the keys'
    device."""
    def call(keys):
        params = jax.device_put(ga.default_params, next(iter(keys.devices())))
        return program(keys, params)
    return call


def _whole_runs(preset: str, ga: GA, programs: tuple, device: jax.Device, seeds: int
                ) -> tuple[ProbeRow, float]:
    """``seeds`` runs of ``preset`` on ``device`` and on the CPU (the runs rolled by
    half): the probe's row and the device's individual-generations per second (its
    second call)."""
    t0 = time.perf_counter()
    here_prog, cpu_prog = programs
    keys = np.asarray(prng.seed_keys(jnp.arange(seeds, dtype=jnp.uint32)))
    here, there = device_probe.rolled_on_cpu(_runner(here_prog, ga), _runner(cpu_prog, ga),
                                             keys, device)
    t1 = time.perf_counter()
    jax.block_until_ready(_runner(here_prog, ga)(jax.device_put(keys, device)))
    speed = seeds * ga.algorithm.population * GENERATIONS / (time.perf_counter() - t1)
    differ = device_probe.differing(jax.tree_util.tree_leaves(here),
                                    jax.tree_util.tree_leaves(there))
    exact = device.platform == "cpu"
    detail = f"identical {seeds - int(differ.sum())}/{seeds}"
    if exact:
        agrees = not differ.any()
    else:  # the device's paths checked on the CPU
        bad = runs_off_tolerance(ga.grid, here, there)
        agrees = not bad.any()
        detail += f"; {int(bad.sum())} with another success, a blocked path or a wrong length"
    row = ProbeRow(f"{preset} runs ({GENERATIONS} generations)", seeds,
                   int(differ.sum()), agrees, time.perf_counter() - t0, exact=exact,
                   detail=detail)
    return row, speed


@own_settings
def doctor(device: jax.Device | None = None, *, presets: Sequence[str] | None = None,
           runs: int | None = None,
           report: Callable[[str], None] = lambda line: None) -> DoctorReport:
    """Check that ``device`` (default: the first of JAX's default backend) computes
    jaxga's results as the CPU does (module docstring).

    Args:
        device: the device to check.
        presets: the presets of the whole runs (default: every built-in preset; none:
            the exact probes alone, as the gate of runs off the CPU runs them).
        runs: runs per call of the exact probes (default
            :data:`~jaxga._runtime.device_probe.RUNS`).
        report: told one line per phase as it finishes (the command line prints them).

    Returns:
        A :class:`DoctorReport`; its ``verdict`` is the one line to show.
    """
    t0 = time.perf_counter()
    try:  # a generator is read once, here
        names = list(preset_names() if presets is None or isinstance(presets, str)
                     else presets)
    except TypeError:
        names = None
    if names is None or isinstance(presets, str) or not all(isinstance(p, str) for p in names):
        raise ParameterError(f"presets must be a list of preset names, got "
                             f"{shown_value(presets)}")
    for name in names:  # an unknown name refused before the probes, not after them
        load_preset(name)
    if device is not None and not isinstance(device, jax.Device):
        raise ParameterError(f"device must be one JAX device (jax.devices()[0], "
                             f"jax.devices('gpu')[1], ...) or None, got {shown_value(device)}")
    if runs is not None:
        given = runs
        try:
            runs = as_integer(runs)
        except TypeError:
            runs = 0
        if runs < 1:
            raise ParameterError(f"runs must be an integer >= 1, got {shown_value(given)}")
    if not callable(report):
        raise ParameterError(f"report must be a function taking one line, got "
                             f"{shown_value(report)}")
    device = jax.devices()[0] if device is None else device
    cpu = jax.devices("cpu")[0]
    rows = []
    for row in device_probe.probe(device, device_probe.RUNS if runs is None else runs):
        rows.append(row)
        report(f"{row.name}: {'ok' if row.agrees else 'FAIL'} ({row.seconds:.1f} s)")
    if not names:
        verdict = device_probe.verdict_line(rows, device)
        return DoctorReport(device_probe.describe(device), all(r.agrees for r in rows),
                            verdict, tuple(rows), 0.0, time.perf_counter() - t0)
    gas = {p: GA(p, device_probe.PROBE_MAP, generations=GENERATIONS) for p in names}
    seeds = {p: THROUGHPUT_SEEDS if p == "sga" else RUN_SEEDS for p in names}
    t1 = time.perf_counter()

    def compile_one(p: str) -> tuple:
        here = _compiled(gas[p], seeds[p], device)
        return here, here if device == cpu else _compiled(gas[p], seeds[p], cpu)

    # Compiled side by side (XLA compiles outside Python's lock): most of a cold doctor.
    with concurrent.futures.ThreadPoolExecutor(max(1, min(len(names), os.cpu_count() or 1))
                                               ) as pool:
        programs = dict(zip(names, pool.map(compile_one, names)))
    report(f"whole runs of {len(names)} presets compiled ({time.perf_counter() - t1:.1f} s)")
    speed = 0.0
    for p in names:
        row, s = _whole_runs(p, gas[p], programs[p], device, seeds[p])
        rows.append(row)
        speed = s if p == "sga" else speed
        report(f"{row.name}: {'ok' if row.agrees else 'FAIL'} ({row.seconds:.1f} s)")
    verdict = device_probe.verdict_line(rows, device)
    return DoctorReport(device_probe.describe(device), all(r.agrees for r in rows), verdict,
                        tuple(rows), speed, time.perf_counter() - t0)
