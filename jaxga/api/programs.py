"""The compiled programs of a run, cached per shape: init, evolve (per chunk size), finish.

A run's programs are traced once per (algorithm, map shape and corner rule, parameter
shapes, run count, chunk sizes, devices) and kept (:data:`PROGRAM_CACHE_SIZE`); runs are
split into blocks (:func:`run_blocks`) and generations into equal chunks
(:func:`equal_chunks`).
"""

from __future__ import annotations

import contextvars
import functools
import gc
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.api.seeds import seed_sharding
from jaxga.core.errors import ParameterError
from jaxga.engine import (
    Algorithm,
    evolve,
    finish,
    init_state,
)


def shape_spec(tree: Any) -> Any:
    return jax.tree_util.tree_map(lambda x: jax.ShapeDtypeStruct(jnp.shape(x), x.dtype), tree)


class Programs:
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
    (:mod:`jaxga._batching.numerics`), so each run's result is the same whichever runs share its
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


COMPILE_PROGRESS: contextvars.ContextVar[Callable[[float], None] | None] = \
    contextvars.ContextVar("jaxga_compile_progress", default=None)
"""Where :func:`compiled_programs` reports how far a compilation has got (a fraction below 1,
after the tracing and after each program but the last): set by :func:`sweep` around the
call, so that the cached function keeps its arguments (a programs' cache hit reports
nothing)."""


@functools.lru_cache(maxsize=PROGRAM_CACHE_SIZE)
def compiled_programs(algo: Algorithm, grid_spec: Any, params_spec: Any, n_runs: int,
                      sizes: tuple[int, ...], n_devices: int) -> Programs:
    """Trace init / evolve (one per chunk size) / finish for ``n_runs`` runs and compile
    init (the others when first needed: :class:`Programs`).

    Cached per (algorithm, map shape and corner rule, parameter shapes, run count, chunks,
    devices): a second call with another map of the same shape, other seeds or other
    dynamic parameter values (probabilities, weights, temperatures, population size
    below the capacity) reuses the compiled programs (``jaxga.replan`` relies on it).
    The programs are compiled one after the other.
    """
    del n_devices  # part of the cache key only
    params_spec = dict(params_spec)
    sh, rep = seed_sharding()

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
    report = COMPILE_PROGRESS.get() or (lambda frac: None)
    programs = Programs(traced, sizes)
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

    compiled_programs.cache_clear()
    jax.clear_caches()
    gc.collect()


def stack_params(per_point: Sequence[dict], seeds: int) -> dict:
    """Per-run parameters: every point repeated once per seed (run ``q * S + s``)."""
    # built with NumPy and put on the device once per key (a re-plan's small calls were
    # spending a tenth of their time in eager jnp.stack / jnp.repeat dispatches)
    return {k: jnp.asarray(np.repeat(np.stack([np.asarray(p[k]) for p in per_point]), seeds,
                                     axis=0))
            for k in per_point[0]}

