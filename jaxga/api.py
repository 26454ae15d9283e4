"""``jaxga.run``: many seeded runs of a preset on a map, in one compiled call.

SPEC 10-11. ``run(preset, grid, seeds=N, **overrides) -> Result``: the seeds are a
``jax.vmap`` (sharded over the available devices), the generations a ``lax.scan``;
initialisation, evolution and post-optimisation are three compiled functions so that
their times can be reported separately, as the papers' tables do. Compilation is timed
on its own.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import functools
import math
import os
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga import parallel
from jaxga.config import Config, flatten
from jaxga.engine import (
    Algorithm,
    build,
    check_migration,
    check_overrides_read,
    default_params,
    evolve,
    finish,
    init_state,
    static_config,
    uses_guide,
    uses_waypoints,
)
from jaxga.errors import InitialisationWarning, JaxgaError, ParameterError
from jaxga.grid import Grid, as_integer
from jaxga.guide import with_guide
from jaxga.lowering import check_environment
from jaxga.maptables import with_tables
from jaxga.objectives import Metrics

if TYPE_CHECKING:
    from jaxga.maps import MapInfo

SUMMARY_METRICS = ("length", "raw_length", "angle_sum", "turns", "fitness",
                   "convergence_generation")
GAPS = ("gap", "raw_gap", "fitness_gap")


GAP_TOLERANCE = 1e-6
"""Relative gaps smaller than this are reported as exactly 0: path lengths are summed in
float32 on the device, so an optimal path can come out a few 1e-8 below the optimum."""
FITNESS_GAP_TOLERANCE = 1e-5
"""The same for :attr:`Result.fitness_gap`: the fitness is a float32 sum of lengths and
turn costs and its reciprocal (errors of about 1e-6 relative), the reference float64."""


def _relative_gap(length: np.ndarray, optimum: float, success: np.ndarray) -> np.ndarray:
    length = np.asarray(length, float)
    if optimum == 0.0:  # start == goal: the optimal path has length 0
        gap = np.where(length == 0.0, 0.0, np.inf)
    else:
        gap = length / optimum - 1.0
    gap = np.where(np.abs(gap) < GAP_TOLERANCE, 0.0, gap)
    return np.where(success, gap, np.nan)


@dataclasses.dataclass
class Result:
    """Per-seed results of :func:`run` (NumPy arrays, leading axis = seeds)."""

    preset: str
    map_name: str
    corner_rule: str
    seeds: np.ndarray
    success: np.ndarray
    reason: str
    cells: np.ndarray  # post-optimised best paths, int32[S, L] (padded)
    n_cells: np.ndarray
    raw_cells: np.ndarray
    raw_n_cells: np.ndarray
    length: np.ndarray
    raw_length: np.ndarray
    fitness: np.ndarray
    convergence_generation: np.ndarray
    history: dict[str, np.ndarray]  # best / mean / std, [S, G]
    metrics: dict[str, np.ndarray]
    raw_metrics: dict[str, np.ndarray]
    failures: np.ndarray  # [S, 3]: crossover, mutation, simplification
    init_success_rate: np.ndarray
    init_unfilled: np.ndarray
    optimum: float
    any_angle_optimum: float
    timing: dict[str, float]
    population: int
    generations: int
    width: int
    config: Config | None = None
    point: dict[str, Any] = dataclasses.field(default_factory=dict)
    fitness_optimum: float = math.nan
    """The exact optimum of the preset's fitness over 8-connected paths
    (:func:`jaxga.fitness_reference.fitness_optimum`); NaN where it is not computed
    (AGACD's waypoint fitness, maps over its size limit)."""
    fitness_optimum_length: float = math.nan
    """The length of the path that reaches :attr:`fitness_optimum`: where the fitness
    charges turns it can be longer than :attr:`optimum`."""
    fitness_optimum_loop_free: bool = True
    """False when the optimal walk visits a cell twice: :attr:`fitness_optimum` is then an
    upper bound of what a loop-free path (all that the GAs keep) can reach."""
    fitness_optimum_reason: str = ""
    """Why :attr:`fitness_optimum` is NaN (not computed), "" when it is computed."""
    start: tuple[int, int] | None = None
    """The start cell ``(x, y)``, y from the bottom."""
    goal: tuple[int, int] | None = None
    """The goal cell ``(x, y)``, y from the bottom."""
    population_capacity: int = 0
    """Individuals per island that the compiled program holds (the largest
    ``population.size`` of a sweep, or ``population_capacity=``): the random numbers of a
    run depend on it, so ``run(..., population_capacity=K)`` repeats a sweep point's runs
    bit for bit."""
    init_fallback: np.ndarray | None = None
    """Per seed, how many initial individuals (all islands together) the fallback
    initialiser made (``init.fallback``): the slots the preset's own initialiser left
    empty after ``init.max_tries`` attempts per individual."""
    causes: np.ndarray | None = None
    """Per seed, why it returned no path ("" for a successful seed); :attr:`reason`
    sums them up."""
    path_capacity: int = 0
    """The cells a path can hold (``population.capacity``, or the automatic capacity of
    :func:`jaxga.engine.default_capacity`)."""

    def path(self, i: int, raw: bool = False) -> list[tuple[int, int]]:
        """Seed ``i``'s best path as ``(x, y)`` cells (post-optimised unless ``raw``)."""
        c = self.raw_cells[i] if raw else self.cells[i]
        n = int(self.raw_n_cells[i] if raw else self.n_cells[i])
        return [(int(p) % self.width, int(p) // self.width) for p in c[:n]]

    @property
    def gap(self) -> np.ndarray:
        """Relative gap of each post-optimised length to the any-angle optimum (its lower
        bound); NaN for failed seeds."""
        return _relative_gap(self.length, self.any_angle_optimum, self.success)

    @property
    def raw_gap(self) -> np.ndarray:
        """Relative gap of each raw length to the exact optimum of its kind: the
        8-connected optimum for 8-connected raw paths, the any-angle optimum for the
        waypoint paths of AGACD (whose straight segments may beat the 8-connected
        optimum); NaN for failed seeds."""
        return _relative_gap(self.raw_length, self.raw_optimum, self.success)

    @property
    def raw_optimum(self) -> float:
        """The exact optimum that :attr:`raw_gap` measures against (see there)."""
        return self.any_angle_optimum if self._raw_waypoints() else self.optimum

    def _raw_waypoints(self) -> bool:
        return self.config is not None and uses_waypoints(self.config)

    @property
    def fitness_gap(self) -> np.ndarray:
        """``fitness_optimum / fitness - 1`` per seed: 0 for a run that found the optimum
        of its own fitness (for the ``1 / cost`` fitnesses, the relative excess of its
        cost); NaN for failed seeds and where the optimum is not computed."""
        ok = self.success & np.isfinite(self.fitness_optimum)  # success: fitness > 0
        gap = self.fitness_optimum / np.where(ok, np.asarray(self.fitness, float), 1.0) - 1.0
        gap = np.where(np.abs(gap) < FITNESS_GAP_TOLERANCE, 0.0, gap)
        return np.where(ok, gap, np.nan)

    def _column(self, name: str) -> np.ndarray:
        if name in self.metrics:
            return np.asarray(self.metrics[name], float)
        return np.asarray(getattr(self, name), float)

    def summary_rows(self) -> list[tuple[str, float, float, float, float]]:
        """``(metric, mean, sd, min, max)`` over successful seeds (AGACD Tables 8-9)."""
        ok = self.success
        rows = []
        names = list(SUMMARY_METRICS) + list(GAPS)
        for name in names:
            v = (getattr(self, name) if name in GAPS else self._column(name))[ok]
            if v.size == 0:
                rows.append((name, math.nan, math.nan, math.nan, math.nan))
            else:
                rows.append((name, float(v.mean()), float(v.std(ddof=1)) if v.size > 1
                             else 0.0, float(v.min()), float(v.max())))
        return rows

    def _fitness_optimum_text(self) -> str:
        if not np.isfinite(self.fitness_optimum):
            return (f"; no fitness optimum: {self.fitness_optimum_reason}"
                    if self.fitness_optimum_reason else "")
        bound = ("" if self.fitness_optimum_loop_free
                 else "; an upper bound: the optimal walk revisits a cell")
        return (f", fitness {self.fitness_optimum:.6g} (a path of length "
                f"{self.fitness_optimum_length:.4f}{bound})")

    def _initial_population_text(self) -> str:
        method = self.config.get("init.method") if self.config is not None else "?"
        text = (f"initial population: {method}, {100 * float(np.mean(self.init_success_rate)):.3g}"
                f" % of its attempts succeeded; paths of up to {self.path_capacity} cells")
        made = np.zeros(len(self.seeds), int) if self.init_fallback is None \
            else np.asarray(self.init_fallback)
        if made.any():
            fallback = self.config.get("init.fallback") if self.config is not None else "?"
            lo, hi = int(made[made > 0].min()), int(made.max())
            count = f"{lo}" if lo == hi else f"{lo}-{hi}"
            text += (f"; the fallback {fallback} made {count} of {self.population} initial "
                     f"individuals in {int((made > 0).sum())} of {len(self.seeds)} seeds "
                     f"({int(made.sum())} in all)")
        return text

    def summary(self) -> str:
        """A text table: mean, sd, min and max per metric, success rate, optima, timing."""
        lines = [
            f"preset {self.preset} on {self.map_name} (corner rule {self.corner_rule!r}), "
            f"{len(self.seeds)} seeds, population {self.population}, "
            f"{self.generations} generations",
            f"success {int(self.success.sum())}/{len(self.seeds)}"
            + (f" ({self.reason})" if self.reason else ""),
            f"optimum: 8-connected {self.optimum:.4f}, any-angle {self.any_angle_optimum:.4f}"
            + self._fitness_optimum_text(),
            f"{'metric':24s} {'mean':>10s} {'sd':>10s} {'min':>10s} {'max':>10s}",
        ]
        if not self.success.any():  # nothing to summarise: the reason says why
            lines[-1] = "no metrics: no seed found a path"
        else:
            for name, mean, sd, lo, hi in self.summary_rows():
                lines.append(f"{name:24s} {mean:10.4f} {sd:10.4f} {lo:10.4f} {hi:10.4f}")
        raw_basis = "any-angle" if self._raw_waypoints() else "8-connected"
        lines.append(f"gaps: gap = length / any-angle optimum - 1, raw_gap = raw_length / "
                     f"{raw_basis} optimum - 1, fitness_gap = fitness optimum / fitness - 1")
        lines.append(self._initial_population_text())
        t = self.timing
        lines.append(
            "time (s): compile {compile_s:.2f}, init {init_s:.3f}, evolve {evolve_s:.3f}, "
            "post {post_s:.3f}, total {total_s:.2f}".format(**t)
        )
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` layout of ``jaxga run``."""
        gaps = {k: getattr(self, k) for k in GAPS}
        runs = []
        for i, seed in enumerate(self.seeds):
            ok = bool(self.success[i])
            runs.append({
                "seed": int(seed),
                "success": ok,
                "path": [list(p) for p in self.path(i)] if ok else [],
                "raw_path": [list(p) for p in self.path(i, raw=True)] if ok else [],
                "length": float(self.length[i]) if ok else None,
                "raw_length": float(self.raw_length[i]) if ok else None,
                "fitness": float(self.fitness[i]),
                "convergence_generation": int(self.convergence_generation[i]),
                # the other metrics of the summary table, null for a failed seed
                **{k: json_number(float(self._column(k)[i])) if ok else None
                   for k in ("angle_sum", "turns")},
                **{k: json_number(float(gaps[k][i])) for k in GAPS},
                "history": {k: [float(x) for x in v[i]] for k, v in self.history.items()},
                "init_fallback": (None if self.init_fallback is None
                                  else int(self.init_fallback[i])),
                "cause": "" if self.causes is None else str(self.causes[i]),
            })
        return {
            "preset": self.preset, "map": self.map_name, "corner_rule": self.corner_rule,
            "start": None if self.start is None else list(self.start),
            "goal": None if self.goal is None else list(self.goal),
            "optimum": json_number(self.optimum),  # null when the goal is unreachable
            "any_angle_optimum": json_number(self.any_angle_optimum),
            "raw_optimum": json_number(self.raw_optimum),
            "fitness_optimum": json_number(self.fitness_optimum),
            "fitness_optimum_length": json_number(self.fitness_optimum_length),
            "fitness_optimum_loop_free": (self.fitness_optimum_loop_free
                                          if np.isfinite(self.fitness_optimum) else None),
            "fitness_optimum_reason": self.fitness_optimum_reason,
            "timing": dict(self.timing), "population": self.population,
            "population_capacity": self.population_capacity,
            "path_capacity": self.path_capacity,
            "generations": self.generations,
            # every setting of the run (preset, file, --set and sweep point resolved)
            "config": None if self.config is None else self.config.as_dict(),
            "runs": runs,
        }


def json_number(x: float | None) -> float | None:
    """``x`` as a JSON number, or ``None`` (null) for None, NaN and infinities."""
    return None if x is None or not math.isfinite(x) else float(x)


SEED_LIMIT = 2**32
"""Seeds are 32-bit (``jax.random.PRNGKey`` of a uint32): seeds must lie in
``[0, SEED_LIMIT)``, where no two give the same run."""


def _seed_list(seeds: int | Sequence[int],
               check_count: Callable[[int], None] | None = None) -> np.ndarray:
    """The seeds of a call, checked: a count ``N`` (seeds ``0..N-1``) or explicit seeds.
    ``check_count(n)`` runs once the number of seeds is known, before a count is turned
    into an array (so a count too large for memory is refused before it is allocated)."""
    check_count = check_count or (lambda n: None)
    if isinstance(seeds, (bool, np.bool_)):  # True is not a count of 1
        raise JaxgaError(f"seeds must be a count or a list of integer seeds, got {seeds!r}")
    if isinstance(seeds, (int, np.integer)) or getattr(seeds, "ndim", None) == 0:
        try:  # a 0-d numpy or JAX integer array is a count too
            seeds = as_integer(seeds)
        except TypeError:
            raise JaxgaError(
                f"seeds must be a count or a list of integer seeds, got {seeds!r}") from None
        if seeds < 1:
            raise JaxgaError(f"seeds must be >= 1, got {seeds}")
        if seeds > SEED_LIMIT:
            raise JaxgaError(f"seeds must be at most 2**32 (seeds are 32-bit), got {seeds}")
        check_count(int(seeds))
        return np.arange(int(seeds))
    try:
        arr = seeds if isinstance(seeds, np.ndarray) else np.asarray(list(seeds))
    except TypeError:
        arr = None
    if arr is None or isinstance(seeds, (str, bytes)) or arr.ndim != 1:
        raise JaxgaError(f"seeds must be a count or a list of integer seeds, got {seeds!r}")
    if arr.size == 0:
        raise JaxgaError("seeds must not be empty")
    if arr.dtype.kind == "O":  # Python integers beyond 64 bits, or mixed integer types
        try:
            values = [as_integer(v) for v in arr.tolist()]
        except TypeError:
            raise JaxgaError(f"seeds must be integers, got {list(seeds)!r}") from None
        if min(values) < 0 or max(values) >= SEED_LIMIT:
            raise JaxgaError(f"seeds must be integers in [0, 2**32) (seeds are 32-bit), got "
                             f"{min(values)} .. {max(values)}")
        arr = np.array(values, np.int64)
    if arr.dtype.kind not in "iu":
        raise JaxgaError(f"seeds must be integers, got {list(seeds)!r}")
    if arr.min() < 0 or arr.max() >= SEED_LIMIT:  # (uint64 compares exactly)
        raise JaxgaError(f"seeds must be integers in [0, 2**32) (seeds are 32-bit), got "
                         f"{int(arr.min())} .. {int(arr.max())}")
    values, counts = np.unique(arr, return_counts=True)
    if (counts > 1).any():  # the same run twice: a pseudo-replicate in any statistic
        raise JaxgaError(f"seeds must be distinct: seed {int(values[counts > 1][0])} is "
                         f"given {int(counts[counts > 1][0])} times (a seed always gives "
                         "the same run)")
    check_count(arr.size)
    return arr.astype(np.int64)


def _seed_sharding() -> tuple[jax.sharding.NamedSharding | None, Any]:
    """(runs axis split over all local devices, replicated); (None, None) with one device.

    Local devices only: with several processes each computes its own share of the runs
    (``jaxga.parallel``), so no program spans processes."""
    n = jax.local_device_count()
    if n == 1:
        return None, None
    mesh = jax.make_mesh((n,), ("runs",), axis_types=(jax.sharding.AxisType.Auto,),
                         devices=jax.local_devices())
    P = jax.sharding.PartitionSpec
    return (jax.sharding.NamedSharding(mesh, P("runs")),
            jax.sharding.NamedSharding(mesh, P()))


def _spec(tree: Any) -> Any:
    return jax.tree_util.tree_map(lambda x: jax.ShapeDtypeStruct(jnp.shape(x), x.dtype), tree)


class _Programs:
    """The programs of a batch of runs: init compiled at once, the evolve programs (one per
    chunk size) and finish compiled when first needed, so that a batch whose
    initialisation found no path at all compiles nothing more (:func:`sweep`)."""

    def __init__(self, traced: dict[str, Any], sizes: tuple[int, ...]) -> None:
        self._traced = traced
        self._compiled: dict[str, Any] = {}
        self.sizes = tuple(sorted(set(sizes)))

    def _compile(self, names: Sequence[str], report: Callable[[float], None]) -> None:
        """Compile the ``names`` not compiled yet, one after the other, reporting the
        fraction of all programs (and the tracing) done after each but the last."""
        steps = 1 + len(self._traced)  # the tracing, then each program
        for name in names:
            if name in self._compiled:
                continue
            self._compiled[name] = self._traced[name].lower().compile(
                FINISH_COMPILER_OPTIONS if name == "finish" else None)
            done = 1 + len(self._compiled)
            if done < steps:
                report(done / steps)

    def compile_init(self, report: Callable[[float], None]) -> None:
        self._compile(["init"], report)

    def compile_rest(self, report: Callable[[float], None]) -> None:
        self._compile([*(f"evolve{n}" for n in self.sizes), "finish"], report)

    @property
    def init(self) -> Any:
        return self._compiled["init"]

    @property
    def evolve(self) -> dict[int, Any]:
        """The compiled evolve program of each chunk size (compiled now if need be)."""
        self.compile_rest(lambda frac: None)
        return {n: self._compiled[f"evolve{n}"] for n in self.sizes}

    @property
    def finish(self) -> Any:
        self.compile_rest(lambda frac: None)
        return self._compiled["finish"]


RUN_BLOCK = 64
"""Largest number of runs one device computes together (see :func:`map_runs`).

Blocks of 20-50 runs compute faster than blocks of 125, and one ``vmap`` of 50 runs is
within noise of two blocks of 25 (``benchmarks/run_block.py``; decision 011). 64 keeps
shares up to 64 runs in one ``vmap`` and splits larger ones into blocks of 32-64."""


INIT_RUN_BLOCK = 10
"""Largest number of runs one device initialises together (the init program's blocks).

The random-walk initialisation is a loop of walk rounds whose length is set by the
slowest run of its batch, and batching walks saves little per run, so it takes smaller
blocks than the evolution: blocks of 10 initialise 1000 seeds faster than blocks of 20
or 50 (decision 011). The results are the same: every run is independent of the runs
that share its block."""


def run_blocks(n_runs: int, n_devices: int = 1, block: int | None = None) -> int:
    """How many blocks :func:`map_runs` splits ``n_runs`` runs into (1 = one ``vmap``).

    The smallest count that divides each device's share into blocks of at most
    ``block`` runs; 1 when no divisor gives blocks of at least ``block // 2`` runs (a
    share of 997 runs stays one block rather than 997 blocks of one). ``block``:
    default :data:`RUN_BLOCK`.
    """
    block = RUN_BLOCK if block is None else int(block)
    per_device = n_runs // max(n_devices, 1)
    if per_device <= block or n_runs % max(n_devices, 1):
        return 1
    for n_blocks in range(2, per_device + 1):
        size = per_device // n_blocks
        if per_device % n_blocks == 0 and size <= block:
            return n_blocks if size >= block // 2 else 1
    return 1


def map_runs(fn: Callable, in_axes: tuple, n_runs: int,
             block: int | None = None) -> Callable:
    """``jax.vmap(fn, in_axes)`` over ``n_runs`` runs, computed in blocks.

    ``in_axes``: 0 (per run) or None (shared) for each argument. With
    ``B = run_blocks(n_runs, 1, block) > 1`` this is ``jax.lax.map`` with
    ``batch_size = n_runs / B``: a loop over ``B`` blocks of consecutive runs, each block
    one ``vmap``. Every run is independent and float sums do not depend on the batch
    (:mod:`jaxga.numerics`), so each run's result is the same whichever runs share its
    block. With several devices it is applied to each device's share
    (``jax.shard_map``). Why blocks: a thousand runs in one ``vmap`` work on arrays far
    larger than the caches (1000 x 60 x 160 cells are 38 MB), and every ``while_loop``
    under the ``vmap`` (the gated operators' blocks, repair rounds, initialisation
    rounds) runs as many iterations as the slowest run of its batch: smaller batches
    wait less (:data:`RUN_BLOCK`, decision 011).
    """
    n_blocks = run_blocks(n_runs, 1, block)
    if n_blocks == 1:
        return jax.vmap(fn, in_axes=in_axes)

    def blocked(*args):
        mapped = [i for i, ax in enumerate(in_axes) if ax == 0 and i < len(args)]

        def one_run(per_run):
            full = list(args)
            for i, a in zip(mapped, per_run):
                full[i] = a
            return fn(*full)

        return jax.lax.map(one_run, tuple(args[i] for i in mapped),
                           batch_size=n_runs // n_blocks)

    return blocked


PROGRAM_CACHE_SIZE = 8
"""How many compiled program sets :func:`sweep` keeps (see :func:`clear_compiled`)."""


FINISH_COMPILER_OPTIONS = {"xla_cpu_use_fusion_emitters": False}
"""XLA options of the finish program (post-optimisation, metrics; it runs once per run):
XLA:CPU's older (LLVM IR) fusion emitters compile it faster than the default MLIR
emitters, with the same results (checked in the A/B tables and by
``tests/test_engine.py``), and its run is no slower (decision 012). Always these
options, whatever the number of runs, so a run's results never depend on how many runs
share its call. The init and evolve programs keep XLA's defaults: with the older
emitters they compile faster but run slower on wide batches (decision 012)."""


_COMPILE_PROGRESS: contextvars.ContextVar[Callable[[float], None] | None] = \
    contextvars.ContextVar("jaxga_compile_progress", default=None)
"""Where :func:`_programs` reports how far a compilation has got (a fraction below 1,
after the tracing and after each program but the last): set by :func:`sweep` around the
call, so that the cached function keeps its arguments (a programs' cache hit reports
nothing)."""


@functools.lru_cache(maxsize=PROGRAM_CACHE_SIZE)
def _programs(algo: Algorithm, grid_spec: Any, params_spec: Any, n_runs: int,
              sizes: tuple[int, ...], n_devices: int) -> _Programs:
    """Trace init / evolve (one per chunk size) / finish for ``n_runs`` runs and compile
    init (the others when first needed: :class:`_Programs`).

    Cached per (algorithm, map shape and corner rule, parameter shapes, run count, chunks,
    devices): a second call with another map of the same shape, other seeds or other
    dynamic parameter values (probabilities, weights, temperatures, population size
    below the capacity) reuses the compiled programs (``jaxga.replan`` relies on it).
    The programs are compiled one after the other.
    """
    del n_devices  # part of the cache key only
    params_spec = dict(params_spec)
    sh, rep = _seed_sharding()

    def do_init(k, grid, params):
        state, stats = init_state(algo, jax.random.fold_in(k, 0), grid, params)
        return state, stats.success_rate, stats.n_failed, stats.from_fallback

    def do_evolve(k, grid, params, state, n):
        return evolve(algo, jax.random.fold_in(k, 1), grid, state, params, n)

    def do_finish(grid, params, state, hist, init_best):
        return finish(algo, grid, state, hist, params, init_best)

    # Every per-run input and output has the run axis first: one sharding for all of
    # them, so each device runs its share and the result does not depend on the device
    # count. The map is replicated. With several devices the program is a shard_map: each
    # device runs its own share as a program of its own. Under a jit sharded by XLA
    # instead, every while_loop whose trip count depends on the runs (the operators'
    # gated blocks, connection rounds) had to agree on its condition across devices at
    # every iteration (decision 011).
    n_dev = 1 if sh is None else sh.mesh.size

    def jit(fn, in_axes, block=None):
        if sh is None:
            return jax.jit(map_runs(fn, in_axes, n_runs, block))
        P = jax.sharding.PartitionSpec
        local = map_runs(fn, in_axes, n_runs // n_dev, block)
        # check_vma=False: the loops' carries start as constants that the runs then vary.
        per_device = jax.shard_map(
            local, mesh=sh.mesh, out_specs=P("runs"), check_vma=False,
            in_specs=tuple(P() if a is None else P("runs") for a in in_axes))
        return jax.jit(per_device, out_shardings=sh,
                       in_shardings=tuple(rep if a is None else sh for a in in_axes))

    keys = jax.ShapeDtypeStruct((n_runs, 2), jnp.uint32)
    init_t = jit(do_init, (0, None, 0), INIT_RUN_BLOCK).trace(keys, grid_spec, params_spec)
    state_spec = init_t.out_info[0]
    evolve_t = {n: jit(functools.partial(do_evolve, n=n), (0, None, 0, 0)).trace(
        keys, grid_spec, params_spec, state_spec) for n in sorted(set(sizes))}
    hist_spec = evolve_t[sizes[0]].out_info[1]
    full_hist = jax.tree_util.tree_map(
        lambda h: jax.ShapeDtypeStruct((n_runs, sum(sizes)), h.dtype), hist_spec)
    finish_t = jit(do_finish, (None, 0, 0, 0, 0)).trace(
        grid_spec, params_spec, state_spec, full_hist,
        jax.ShapeDtypeStruct((n_runs,), jnp.float32))
    traced = {"init": init_t, **{f"evolve{n}": t for n, t in evolve_t.items()},
              "finish": finish_t}
    # One after the other: compiling them in threads (one per core) was no faster
    # (decision 011).
    report = _COMPILE_PROGRESS.get() or (lambda frac: None)
    programs = _Programs(traced, sizes)
    report(1 / (1 + len(traced)))
    programs.compile_init(report)
    return programs


def equal_chunks(generations: int, chunks: int) -> tuple[int, ...]:
    """Split ``generations`` into at most ``chunks`` compiled chunks of one size.

    The number of chunks is the largest divisor of ``generations`` not above ``chunks``
    (45 generations in at most 10 chunks: 9 chunks of 5; a prime count above ``chunks``:
    one chunk). Every chunk size is a compiled evolve program of its own, so unequal
    chunks (45 as 5 x 5 + 5 x 4) would compile the evolution twice for a progress bar;
    equal chunks compile it once. Chunking never changes a result (generation ``t`` uses
    the key ``fold_in(key, t)``, :func:`jaxga.engine.evolve`).
    """
    if generations < 1:
        raise ParameterError(f"generations must be at least 1, got {generations}")
    limit = max(1, min(int(chunks), generations))
    n = max(d for d in range(1, limit + 1) if generations % d == 0)
    return (generations // n,) * n


def clear_compiled() -> None:
    """Free every compiled program this process holds (jaxga's and JAX's caches).

    Each compiled XLA:CPU program maps a few thousand small memory regions (one code,
    one constant and one data region per kernel). Linux limits a process to
    ``vm.max_map_count`` regions (65,530 by default) and XLA crashes with a segmentation
    fault, not an error, when that is exhausted: a notebook or a script that compiles
    many different configurations (operators, map sizes, run counts) in one process
    should call this between experiments. :func:`sweep` keeps at most
    :data:`PROGRAM_CACHE_SIZE` program sets itself; JAX's own ``jit`` caches are not
    bounded. The next call compiles again (from the persistent compilation cache, when
    one is configured).
    """
    import gc

    _programs.cache_clear()
    jax.clear_caches()
    gc.collect()


def _stack_params(per_point: Sequence[dict], seeds: int) -> dict:
    """Per-run parameters: every point repeated once per seed (run ``q * S + s``)."""
    return {k: jnp.repeat(jnp.stack([jnp.asarray(p[k]) for p in per_point]), seeds, axis=0)
            for k in per_point[0]}


def _check_call_options(progress, chunks) -> None:
    """The options of :func:`run` and :func:`sweep` that do not reach the configuration."""
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable (stage, fraction), got "
                             f"{progress!r}")
    try:
        chunks = as_integer(chunks)
    except TypeError:
        raise ParameterError(f"chunks must be an integer >= 1, got {chunks!r}") from None
    if chunks < 1:
        raise ParameterError(f"chunks must be an integer >= 1, got {chunks!r}")


def _normalised(key: str, value: Any) -> Any:
    """``value`` as the configuration stores it (a tuple and a list alike, numpy scalars
    as Python ones), to compare two values given for ``key``; an invalid value is
    refused with the key's own message."""
    from jaxga.config import SCHEMA, _freeze

    if key not in SCHEMA:  # refused by name when the preset loads
        return repr(value)
    return _freeze(SCHEMA[key].check(key, value))


def check_one_corner_rule(corner_rule: str | None, config: Config,
                          overridden: Sequence[str]) -> None:
    """Refuse a ``corner_rule=`` (``--corner-rule``) that disagrees with an overridden
    ``map.corner_rule`` (``--set``): two rules for one run."""
    rule = config["map.corner_rule"]
    if "map.corner_rule" in overridden and corner_rule is not None and corner_rule != rule:
        raise ParameterError(f"two corner rules given: {corner_rule!r} (corner_rule, "
                             f"--corner-rule) and {rule!r} (map.corner_rule)")


def _load(preset, grid, corner_rule, variant, sets, overrides, generations, *,
          check_read: bool = True):
    """``(config, grid, map name)`` of a call, checked; ``check_read=False`` leaves
    overrides that nothing reads to the caller (:func:`jaxga.compare.compare`)."""
    from jaxga.maps import MapInfo, load_map_info
    from jaxga.presets import as_sets, check_file_keys_read, load_preset, parse_set

    check_environment()  # a bad $JAXGA_THREEFRY, which `import jaxga` does not refuse
    map_name = "grid"
    if isinstance(grid, MapInfo):  # a loaded map that keeps its name (and its endpoints)
        grid, map_name = grid.grid, grid.name
    sets = as_sets(sets)
    ov: dict[str, Any] = {k.replace("__", "."): v for k, v in overrides.items()}
    if generations is not None:  # a non-integer is left for the configuration to refuse
        with contextlib.suppress(TypeError):
            generations = as_integer(generations)
        ov["generations"] = generations
    given = flatten(ov)
    set_values = [parse_set(text) for text in sets]
    for key, value in set_values:  # one value per key
        if key in given and _normalised(key, given[key]) != _normalised(key, value):
            raise ParameterError(f"{key} is given twice, as {given[key]!r} and {value!r}")
        given[key] = value
    if isinstance(preset, Config):  # as load_preset: the overrides, then the sets
        if variant is not None:
            raise ParameterError(f"variant {variant!r} given with a Config: load the preset "
                                 "with its variant (jaxga.presets.load_preset) instead")
        config = preset.override(ov).override(dict(set_values))
    else:
        config = load_preset(preset, variant=variant, overrides=ov, sets=sets)
    if check_read:  # never silently ignored
        overridden = [*flatten(ov), *(key for key, _ in set_values)]
        check_overrides_read(config, overridden)
        if not isinstance(preset, Config):  # keys a user TOML file sets, in that file
            check_file_keys_read(preset, variant)
        check_one_corner_rule(corner_rule, config, overridden)
        rule = config["map.corner_rule"]
        if "map.corner_rule" in overridden and isinstance(grid, Grid) \
                and corner_rule is None and grid.corner_rule != rule:
            raise ParameterError(
                f"map.corner_rule = {rule!r} has no effect with a Grid (or a loaded "
                f"MapInfo), which keeps its own corner rule ({grid.corner_rule!r}): give "
                "the Grid that rule "
                "(corner_rule=... or Grid.replace; --corner-rule on the command line)")
    if isinstance(grid, Grid):
        grid = grid.validated()  # a grid made with the plain constructor is checked too
        if corner_rule is not None:
            grid = grid.replace(corner_rule=corner_rule)
    else:
        rule = config["map.corner_rule"] if corner_rule is None else corner_rule
        info = load_map_info(grid, corner_rule=rule)
        grid, map_name = info.grid, info.name
    grid.check_endpoints()
    return config, grid, map_name


def _point_configs(config: Config, points: Sequence[Mapping[str, Any]]) -> list[Config]:
    """Validated configurations of the sweep points; only dynamic keys and the
    population size may vary (they do not change the compiled program)."""
    out = []
    base = static_config(config)
    for point in points:
        changes = {k.replace("__", "."): v for k, v in point.items()}
        cfg = config.override(changes)
        check_overrides_read(cfg, flatten(changes))
        if static_config(cfg) != base:
            new = dict(static_config(cfg).items)
            old = dict(base.items)
            changed = sorted(k for k in new.keys() | old.keys() if new.get(k) != old.get(k))
            raise ParameterError(
                f"sweep point {dict(point)} changes {', '.join(changed)}, which the "
                "compiled program depends on: only scalar dynamic keys (a crossover or "
                "mutation rate, a fitness weight, MPMGA's c1 temperature; "
                "jaxga.config.SCHEMA) and population.size can be swept in one compiled "
                "call; run the other values separately")
        # every point's islands must hold its migrants: an inactive individual never
        # migrates (the check at build time only sees the largest size)
        check_migration(cfg, int(cfg["population.size"]))
        out.append(cfg)
    return out


def sweep(
    preset: str | Config,
    grid: Grid | MapInfo | str,
    points: Sequence[Mapping[str, Any]],
    seeds: int | Sequence[int] = 1,
    *,
    generations: int | None = None,
    corner_rule: str | None = None,
    variant: str | None = None,
    sets: Sequence[str] = (),
    progress: Callable[[str, float], None] | None = None,
    chunks: int = 1,
    population_capacity: int | None = None,
    **overrides: Any,
) -> list[Result]:
    """Run every point of a hyper-parameter sweep with every seed, in ONE compiled call.

    ``points`` are mappings of configuration keys (``crossover.probability``, AGACD's
    ``mutation.pm_low``, fitness weights, ``population.size``, ...) applied on top of the
    preset and ``overrides``. Dynamic keys become per-run arrays of a ``jax.vmap``; the
    population size becomes the engine's ``active`` count below a capacity equal to the
    largest size swept. Keys that change the compiled program (operators, generations,
    capacity) are refused with a :class:`ParameterError`. Run ``q * S + s`` is point
    ``q`` with seed ``s``: every point sees the same seeds (common random numbers, as a
    designed experiment wants). Returns one :class:`Result` per point; their ``timing``
    is that of the whole sweep.

    ``population_capacity`` (default: the largest size swept) fixes the population
    capacity. Results depend on it, so a sweep split into several calls (``jaxga.doe``'s
    resumable blocks) passes the largest size of the WHOLE sweep to every call to get the
    same results as one call. It must be at least every point's ``population.size``.
    The runs are split over this process's devices and, after
    :func:`jaxga.parallel.initialize`, over several processes: each computes its share and
    every process returns the whole, identical result (:mod:`jaxga.parallel`; a lost
    process raises :class:`jaxga.parallel.ProcessLostError`).
    """
    from jaxga.fitness_reference import fitness_optimum, fitness_weights

    t_start = time.perf_counter()
    if not isinstance(points, Sequence) or isinstance(points, str) \
            or not all(isinstance(p, Mapping) and all(isinstance(k, str) for k in p)
                       for p in points):
        raise ParameterError(f"points must be a list of mappings key -> value, got "
                             f"{points!r}")
    if not points:
        raise ParameterError("a sweep needs at least one point")
    _check_call_options(progress, chunks)
    config, grid, map_name = _load(preset, grid, corner_rule, variant, sets, overrides,
                                   generations)
    configs = _point_configs(config, points)
    capacity = _population_capacity(configs, population_capacity)
    octile, any_angle = _optima(grid)
    if not octile.found:
        seed_arr = _seed_list(seeds, lambda n: _check_memory(
            n * len(configs), NO_PATH_BYTES_PER_RUN, "for their results"))
        return [_no_path_result(c, map_name, grid, seed_arr, build(c, grid)[0], octile.reason,
                                time.perf_counter() - t_start, capacity) for c in configs]
    if uses_guide(config):  # the exact distance fields the field initialiser steers by
        grid = with_guide(grid)
    grid = with_tables(grid)  # per-map tables, once per run rather than per generation
    # the capacity is the largest size swept, also when it is below the preset's size
    algo, _ = build(config.override({"population.size": capacity}), grid)
    per_point = [default_params(c, algo.islands) for c in configs]
    # The exact optimum of each point's own fitness, once per distinct weight set (points
    # may sweep the weights).
    fit_keys = [(m, tuple(sorted(w.items()))) for m, w in map(fitness_weights, configs)]
    fit_opts = {k: fitness_optimum(grid, k[0], **dict(k[1])) for k in dict.fromkeys(fit_keys)}
    point_opt = [fit_opts[k] for k in fit_keys]
    n_points = len(configs)
    seed_arr = _seed_list(seeds, lambda n: _check_result_memory(n * n_points, algo))
    n_seeds = len(seed_arr)
    n_runs = n_seeds * n_points
    # Runs padded (copies of the last run) to a multiple of processes x local devices;
    # this process computes its contiguous share and allgather_runs joins the shares.
    n_total, share = parallel.run_share(n_runs)
    pad = n_total - n_runs
    run_seeds = np.concatenate([np.tile(seed_arr, n_points),
                                np.repeat(seed_arr[-1:], pad)])[share]
    params = _stack_params(per_point, n_seeds)
    if pad:
        params = {k: jnp.concatenate([v, jnp.repeat(v[-1:], pad, axis=0)])
                  for k, v in params.items()}
    params = {k: v[share] for k, v in params.items()}
    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(run_seeds, jnp.uint32))
    sh, rep = _seed_sharding()
    if sh is not None:
        keys, params = jax.device_put((keys, params), sh)
        grid = jax.device_put(grid, rep)

    def report(stage: str, frac: float) -> None:
        if progress is not None:
            progress(stage, frac)

    sizes = equal_chunks(algo.generations, chunks)
    report("compile", 0.0)
    t0 = time.perf_counter()
    token = _COMPILE_PROGRESS.set(lambda frac: report("compile", frac))
    try:
        progs = _programs(algo, _spec(grid), tuple(sorted(_spec(params).items())),
                          len(run_seeds), sizes, jax.local_device_count())
    finally:
        _COMPILE_PROGRESS.reset(token)
    compile_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    state, init_rate, unfilled, fallback = jax.block_until_ready(
        progs.init(keys, grid, params))
    init_s = time.perf_counter() - t0
    init_best = state.best_fitness
    # Every process's initial best, so that all of them decide alike whether to evolve.
    started, init_rate, unfilled, fallback = parallel.allgather_runs(
        (init_best > 0, init_rate, unfilled, fallback))
    rate = init_rate.reshape(n_total, -1).mean(axis=1)
    unf = unfilled.reshape(n_total, -1).sum(axis=1)
    from_fallback = fallback.reshape(n_total, -1).sum(axis=1)
    _warn_unfilled(unf, rate, algo.population * algo.islands, config)
    common = dict(config=config, configs=configs, points=points, map_name=map_name,
                  grid=grid, seed_arr=seed_arr, algo=algo, octile=octile,
                  any_angle=any_angle, point_opt=point_opt, rate=rate, unfilled=unf,
                  from_fallback=from_fallback)
    if not started.any():  # nothing can succeed: no evolution, no post-optimisation
        report("compile", 1.0)
        timing = {"compile_s": compile_s, "init_s": init_s, "evolve_s": 0.0,
                  "post_s": 0.0, "total_s": time.perf_counter() - t_start}
        return _unstarted_results(timing=timing, **common)

    t0 = time.perf_counter()
    progs.compile_rest(lambda frac: report("compile", frac))
    compile_s += time.perf_counter() - t0
    report("compile", 1.0)

    t0 = time.perf_counter()
    hists = []
    done = 0
    for n in sizes:
        state, h = progs.evolve[n](keys, grid, params, state)
        jax.block_until_ready(state)
        hists.append(h)
        done += n
        report("evolve", done / algo.generations)
    history = {k: jnp.concatenate([h[k] for h in hists], axis=1) for k in hists[0]}
    evolve_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    out = jax.block_until_ready(progs.finish(grid, params, state, history, init_best))
    post_s = time.perf_counter() - t0
    timing = {"compile_s": compile_s, "init_s": init_s, "evolve_s": evolve_s,
              "post_s": post_s, "total_s": time.perf_counter() - t_start}

    host, hist = parallel.allgather_runs((out, history))
    timing["total_s"] = time.perf_counter() - t_start
    n_seeds = len(seed_arr)
    results = []
    for q, cfg in enumerate(configs):
        sl = slice(q * n_seeds, (q + 1) * n_seeds)
        h = jax.tree_util.tree_map(lambda a, sl=sl: a[sl], host)
        success = h["success"] & h["feasible_post"]
        causes = _causes(success, started[sl], rate[sl], from_fallback[sl], config,
                         algo.capacity, len(octile.path))
        results.append(Result(
            preset=config["name"], map_name=map_name, corner_rule=grid.corner_rule,
            seeds=seed_arr, success=success, reason=_failure_reason(causes),
            cells=h["cells"], n_cells=h["length"],
            raw_cells=h["raw_cells"], raw_n_cells=h["raw_length"],
            length=h["path_length"].astype(float),
            raw_length=h["raw_path_length"].astype(float),
            fitness=h["fitness"].astype(float),
            convergence_generation=h["convergence_generation"],
            history={k: v[sl] for k, v in hist.items()},
            metrics=h["metrics"], raw_metrics=h["raw_metrics"], failures=h["failures"],
            init_success_rate=rate[sl], init_unfilled=unf[sl],
            optimum=float(octile.length), any_angle_optimum=float(any_angle.length),
            timing=dict(timing), population=int(cfg["population.size"]) * algo.islands,
            generations=algo.generations, width=grid.width, config=cfg,
            point={k.replace("__", "."): v for k, v in points[q].items()},
            fitness_optimum=point_opt[q].fitness,
            fitness_optimum_length=point_opt[q].length,
            fitness_optimum_loop_free=point_opt[q].loop_free,
            fitness_optimum_reason="" if point_opt[q].found else point_opt[q].reason,
            start=grid.start_xy, goal=grid.goal_xy, population_capacity=algo.population,
            init_fallback=from_fallback[sl], causes=causes, path_capacity=algo.capacity,
        ))
    return results


def _unstarted_results(*, config, configs, points, map_name, grid, seed_arr, algo, octile,
                       any_angle, point_opt, rate, unfilled, from_fallback,
                       timing) -> list[Result]:
    """The results of a sweep whose initialisation gave no run a path: every seed failed,
    each with its cause; nothing evolved (SPEC 10)."""
    n_seeds = len(seed_arr)
    results = []
    for q, cfg in enumerate(configs):
        sl = slice(q * n_seeds, (q + 1) * n_seeds)
        success = np.zeros(n_seeds, bool)
        causes = _causes(success, success, rate[sl], from_fallback[sl], config,
                         algo.capacity, len(octile.path))
        r = _no_path_result(cfg, map_name, grid, seed_arr, algo, _failure_reason(causes),
                            timing["total_s"], algo.population)
        results.append(dataclasses.replace(
            r, preset=config["name"], init_success_rate=rate[sl], init_unfilled=unfilled[sl],
            optimum=float(octile.length), any_angle_optimum=float(any_angle.length),
            timing=dict(timing), point={k.replace("__", "."): v for k, v in points[q].items()},
            fitness_optimum=point_opt[q].fitness, fitness_optimum_length=point_opt[q].length,
            fitness_optimum_loop_free=point_opt[q].loop_free,
            fitness_optimum_reason="" if point_opt[q].found else point_opt[q].reason,
            init_fallback=from_fallback[sl], causes=causes, path_capacity=algo.capacity))
    return results


@functools.lru_cache(maxsize=32)
def _optima_cached(digest: bytes, shape: tuple[int, int], blocked: bytes, start: tuple,
                   goal: tuple, corner_rule: str):
    from jaxga.reference import any_angle_shortest_path_np, shortest_path_np

    del digest  # the cache key; the arguments are the data
    b = np.frombuffer(blocked, dtype=bool).reshape(shape)
    octile = shortest_path_np(b, start, goal, corner_rule)
    if not octile.found:
        return octile, None
    return octile, any_angle_shortest_path_np(b, start, goal, corner_rule)


def _optima(grid: Grid):
    """``(8-connected optimum, any-angle optimum)`` of the grid's problem (jaxga.reference;
    the any-angle one None when the goal is unreachable), cached for the last 32
    problems: comparing presets or repeating runs on one problem computes them once
    (the any-angle optimum of a long problem on a 256 x 256 map takes seconds:
    decision 015)."""
    import hashlib

    b = np.ascontiguousarray(grid.blocked_np())
    raw = b.tobytes()
    key = (b.shape, grid.start_xy, grid.goal_xy, grid.corner_rule)
    digest = hashlib.blake2b(raw + repr(key).encode(), digest_size=16).digest()
    return _optima_cached(digest, b.shape, raw, *key[1:])


def _population_capacity(configs: Sequence[Config], requested: Any) -> int:
    """Individuals per island of the compiled program: ``requested``, checked, or the
    largest ``population.size`` of the points."""
    capacity = max(int(c["population.size"]) for c in configs)
    if requested is None:
        return capacity
    try:  # 9.7 is not truncated
        requested = as_integer(requested)
    except TypeError:
        raise ParameterError(f"population_capacity must be an integer, got "
                             f"{requested!r}") from None
    if requested < capacity:
        raise ParameterError(f"population_capacity {requested} is below the largest "
                             f"population.size ({capacity})")
    return requested


def run(
    preset: str | Config,
    grid: Grid | MapInfo | str,
    seeds: int | Sequence[int] = 1,
    *,
    generations: int | None = None,
    corner_rule: str | None = None,
    variant: str | None = None,
    sets: Sequence[str] = (),
    progress: Callable[[str, float], None] | None = None,
    chunks: int = 1,
    population_capacity: int | None = None,
    **overrides: Any,
) -> Result:
    """Run ``preset`` on ``grid`` once per seed, all seeds in one compiled call.

    Args:
        preset: a preset name (``jaxga presets``), a TOML file, or a :class:`Config`.
        grid: a :class:`Grid`, a map file or a built-in map name, or a
            :class:`jaxga.maps.MapInfo` (``load_map_info(name, start=..., goal=...)``:
            other endpoints, and the results keep the map's name where a Grid is "grid").
            A map given by name is loaded with ``corner_rule`` or else the preset's
            ``map.corner_rule``; a Grid or MapInfo keeps its own unless ``corner_rule`` is
            given.
        seeds: a count ``N`` (seeds ``0..N-1``) or explicit integer seeds in
            ``[0, 2**32)``, each once (a repeated seed would repeat its run exactly: a
            pseudo-replicate; refused). Seed ``s`` always gives the same run, whatever
            other seeds run with it and on however many devices. A call whose results
            would need more than half the machine's memory is refused
            (:class:`ParameterError`).
        generations: overrides the preset's generation count.
        overrides: configuration keys with ``.`` written as ``__`` (e.g.
            ``crossover__probability=0.7``), or ``sets=("crossover.probability=0.7",)``.
        progress: optional callback ``(stage, fraction)``: ``("compile", 0.0)``, the
            compilation's progress (after the tracing and after each compiled program,
            when the programs are not compiled yet), ``("compile", 1.0)``, then
            ``("evolve", f)`` after each chunk of generations. With ``chunks > 1`` the
            generations run in up to that many compiled chunks of one size
            (:func:`equal_chunks`; same result) for a progress bar.
        population_capacity: individuals per island that the compiled program holds
            (default ``population.size``; not the configuration key
            ``population.capacity``, the cells a path can hold); the random numbers of a
            run depend on it. A
            point of a :func:`sweep` or a DOE over population sizes ran with the largest
            size swept as its capacity (``Result.population_capacity``): pass that to
            repeat its runs bit for bit.

    Returns:
        A :class:`Result`. Seeds that found no feasible path have ``success`` False and
        are never reported with a path. An unreachable goal gives all seeds
        ``success = False`` and ``reason`` naming the cause (nothing is run).

    The compiled programs are cached per algorithm, map shape and run count: calling
    again with other seeds of the same count, another map of the same size or other
    dynamic values (``crossover__probability=...``) does not compile again. For many
    hyper-parameter values in one call use :func:`sweep`.
    """
    return sweep(preset, grid, [{}], seeds, generations=generations,
                 corner_rule=corner_rule, variant=variant, sets=sets, progress=progress,
                 chunks=chunks, population_capacity=population_capacity, **overrides)[0]


RUN_OPTIONS = ("generations", "corner_rule", "variant", "sets", "progress", "chunks",
               "population_capacity")
"""Keyword arguments of :func:`run` (besides ``seeds``) that are not configuration keys."""


def check_run(preset: str | Config, grid: Grid | str, **options: Any) -> Config:
    """The configuration :func:`run` would use with these keyword ``options`` (all of
    :func:`run`'s but ``seeds``), checked as :func:`run` checks it before compiling
    (preset, map, endpoints, overrides that nothing reads, key combinations, migrants);
    raises what :func:`run` would raise. Compiles and runs nothing: :func:`jaxga.compare`
    checks every preset with it before the first one runs."""
    overrides = dict(options)
    named = {k: overrides.pop(k) for k in RUN_OPTIONS if k in overrides}
    _check_call_options(named.get("progress"), named.get("chunks", 1))
    config, grid, _ = _load(preset, grid, named.get("corner_rule"), named.get("variant"),
                            named.get("sets", ()), overrides, named.get("generations"))
    (config,) = _point_configs(config, [{}])
    _population_capacity([config], named.get("population_capacity"))
    build(config, grid)  # check_migration and check_combination
    return config


RESULT_MEMORY_FRACTION = 0.5
"""A call is refused when its results alone would need more than this fraction of the
machine's physical memory (they are all held on the host at the end)."""


def _physical_memory() -> int | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # not POSIX
        return None


def _check_result_memory(n_runs: int, algo: Algorithm) -> None:
    """A clear error instead of the operating system killing the process: every run keeps
    three float32 histories of ``generations`` values, two int32 paths of ``capacity``
    cells and a few hundred bytes of metrics, counters and keys, and while it evolves its
    population (``population x islands x capacity`` int32 cells, counted twice: the state
    and its next generation). An estimate, not a bound: blocks of runs need more."""
    per_run = (12 * algo.generations + 8 * algo.capacity + 256
               + 2 * 4 * algo.population * algo.islands * algo.capacity)
    _check_memory(n_runs, per_run, (
        f"for their results and populations ({algo.generations} generations of history, "
        f"paths of {algo.capacity} cells and a population of "
        f"{algo.population * algo.islands} per run)"))


NO_PATH_BYTES_PER_RUN = 256
"""What a run of a no-path result keeps (its seed, NaN metrics and empty paths)."""


def _check_memory(n_runs: int, per_run: int, what: str) -> None:
    """``ParameterError`` when ``n_runs`` runs of ``per_run`` bytes need more than
    :data:`RESULT_MEMORY_FRACTION` of the machine's physical memory."""
    need, total = n_runs * per_run, _physical_memory()
    if total is not None and need > RESULT_MEMORY_FRACTION * total:
        raise ParameterError(
            f"{n_runs} runs would need about {need / 2**30:.1f} GiB {what}, more than half "
            f"of this machine's {total / 2**30:.1f} GiB: run fewer seeds per call")


def _warn_unfilled(unfilled: np.ndarray, init_rate: np.ndarray, capacity: int,
                   config) -> None:
    """Warn (:class:`~jaxga.errors.InitialisationWarning`) when runs whose initialiser made
    some paths still started with copies in empty slots (SPEC 4; ``jaxga.init.initialise``
    fills slots left empty after ``init.max_tries`` attempts per individual with copies).
    Runs whose initialiser made no path are failures with a reason instead."""
    short = (unfilled > 0) & (init_rate > 0)
    if not short.any():
        return
    n = unfilled[short]
    copied = f"{n.min()}" if n.min() == n.max() else f"{n.min()}-{n.max()}"
    warnings.warn(
        f"{int(short.sum())} of {short.size} runs started with {copied} of their {capacity} "
        f"initial individuals copied: the initialiser {config.get('init.method')!r} "
        f"succeeded in {100 * float(init_rate[short].mean()):.2g} % of its "
        f"attempts, and init.max_tries = {config.get('init.max_tries')} did not fill the "
        "population (raise init.max_tries)",
        InitialisationWarning, stacklevel=_caller_stacklevel())


def _caller_stacklevel() -> int:
    """The ``stacklevel`` that makes a warning raised by this function's caller point at
    the first frame outside the jaxga package (the user's line, whichever of ``run``,
    ``sweep``, ``replan`` or the CLI they called)."""
    frame, level = sys._getframe(1), 1
    while frame.f_back is not None and _in_jaxga(frame.f_globals.get("__name__", "")):
        frame, level = frame.f_back, level + 1
    return level


def _in_jaxga(module: str) -> bool:
    return module == "jaxga" or module.startswith("jaxga.")


def _causes(success: np.ndarray, started: np.ndarray, init_rate: np.ndarray,
            from_fallback: np.ndarray, config, capacity: int,
            shortest_cells: int) -> np.ndarray:
    """Per seed, why it returned no path ("" for a successful seed): its initialisation
    gave it no path (the initialiser never succeeded on this map, with or without the
    fallback; or the path capacity is below the shortest path's cell count), or its best
    path did not survive the final feasibility check."""
    out = np.full(len(success), "", dtype=object)
    method, fallback = config.get("init.method"), config.get("init.fallback", "none")
    for i in np.flatnonzero(~np.asarray(success)):
        if started[i]:
            out[i] = "lost its best path in the final feasibility check"
        elif capacity < shortest_cells:
            out[i] = (f"got no initial path: population.capacity = {capacity} is probably "
                      f"too small: the shortest 8-connected path has {shortest_cells} cells "
                      "(raise population.capacity)")
        elif fallback == "none" or method == "field_walk":
            out[i] = (f"got no initial path: the initialiser {method!r} succeeded in none of "
                      "its attempts on this map (raise init.max_tries, choose another "
                      "init.method, or set init.fallback = 'field_walk')")
        else:
            out[i] = (f"got no initial path: the initialiser {method!r} succeeded in none of "
                      f"its attempts and the fallback {fallback!r} made none either")
    return out


def _failure_reason(causes: np.ndarray) -> str:
    """Why some runs returned no path: how many, and each cause with its seed count."""
    causes = np.asarray(causes, dtype=object)
    failed = causes != ""
    if not failed.any():
        return ""
    text = f"no feasible path found by {int(failed.sum())} of {failed.size} seeds"
    kinds, counts = np.unique(causes[failed].astype(str), return_counts=True)
    for cause, k in zip(kinds, counts):
        text += f"; {int(k)} of them {cause}"
    return text


def _no_path_result(config, map_name, grid, seeds, algo, reason, elapsed,
                    population_capacity) -> Result:
    s = len(seeds)
    empty = np.zeros((s, 1), np.int32)
    nan = np.full(s, np.nan)
    return Result(
        preset=config["name"], map_name=map_name, corner_rule=grid.corner_rule, seeds=seeds,
        success=np.zeros(s, bool), reason=reason, cells=empty, n_cells=np.zeros(s, np.int32),
        raw_cells=empty, raw_n_cells=np.zeros(s, np.int32), length=nan, raw_length=nan,
        fitness=np.zeros(s), convergence_generation=np.full(s, -1),
        history={k: np.zeros((s, 0)) for k in ("best", "mean", "std")},
        metrics={k: nan.copy() for k in Metrics._fields},
        raw_metrics={k: nan.copy() for k in Metrics._fields}, failures=np.zeros((s, 3), np.int32),
        init_success_rate=np.zeros(s), init_unfilled=np.zeros(s, np.int32),
        optimum=math.inf, any_angle_optimum=math.inf,
        timing={"compile_s": 0.0, "init_s": 0.0, "evolve_s": 0.0, "post_s": 0.0,
                "total_s": elapsed},
        population=int(config["population.size"]) * algo.islands,
        generations=algo.generations, width=grid.width, config=config,
        fitness_optimum_reason=reason, start=grid.start_xy, goal=grid.goal_xy,
        population_capacity=population_capacity, init_fallback=np.zeros(s, np.int32),
        causes=np.full(s, reason, dtype=object), path_capacity=algo.capacity,
    )


def summarise(results: Mapping[str, Result]) -> str:
    """Several results side by side (one block per preset)."""
    return "\n\n".join(r.summary() for r in results.values())
