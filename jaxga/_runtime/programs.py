"""The compiled programs of a run, cached per shape: init, evolve (one chunk), finish.

One program set serves many calls (decision 028): the runs go through programs of a few
sizes (runs per device, padded with copies of the last run; more runs are several calls
of the largest size, :func:`run_layout`; the sizes are the platform's,
:func:`platform_layout`), and the generations
through one evolve program of :data:`GENERATION_CHUNK` generations called as often as
needed (the last call runs only the generations left: ``jaxga.engine.evolve``'s
``count``). A program set is traced once per (algorithm without its generation count,
map shape and corner rule, parameter shapes, runs per call, devices) and kept
(:data:`PROGRAM_CACHE_SIZE`); each of its programs is keyed on the part of the
configuration it reads (:func:`program_view`), so a key that only the initialisation
(or the finish) reads compiles that program alone. Every run's result depends only on
its seed and parameters, never on the runs that share its call, so the padding changes
no result.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import gc
import math
import threading
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._runtime import executables
from jaxga._runtime.device_probe import check_backend
from jaxga._runtime.seeds import seed_sharding
from jaxga.config.schema import Config
from jaxga.core.errors import ParameterError, PlatformWarning
from jaxga.engine import (
    Algorithm,
    chosen_operators,
)
from jaxga.engine.maptables import compute_tables
from jaxga.engine.run import PureGA


def shape_spec(tree: Any) -> Any:
    return jax.tree_util.tree_map(lambda x: jax.ShapeDtypeStruct(jnp.shape(x), x.dtype), tree)


PROGRAM_SECTIONS: dict[str, tuple[str, ...]] = {
    "init": ("init.", "fitness.", "repair.", "survival."),
    "finish": ("post.", "repair.", "survival."),
}
"""The configuration sections each program reads (:func:`program_view`): the init
program draws and evaluates the initial populations (its initialisers, the fitness, a
front's objectives, the repairs of median insertion), the finish program post-optimises
the best path (its operator is bound with the repair setting, like every operator; a
front's shapes follow ``survival.``); the
evolve program reads every section but ``init.`` and ``post.``.
``tests/api/test_swept_keys.py`` traces every preset from these views and fails on a read
outside them."""


def program_view(algo: Algorithm, name: str) -> Algorithm:
    """``algo`` as program ``name`` (``"init"``, ``"evolve"``, ``"finish"``) sees it: its
    sizes, and the configuration keys of the sections that program reads
    (:data:`PROGRAM_SECTIONS`). Each program is traced from its view and keyed on it, so a
    key only one program reads (``init.method``, ``post.method``) compiles that program
    alone: the others are shared with the configurations that differ only in it. A
    program traced from its view depends on nothing else (a key outside the view reads
    as absent), so sharing it is exact."""
    if name == "evolve":
        def reads(key: str) -> bool:
            return not key.startswith(("init.", "post."))
    else:
        def reads(key: str) -> bool:
            return key.startswith(PROGRAM_SECTIONS[name])
    # stages=None: resolved again from the view, so a stage of a family outside it is None
    return dataclasses.replace(
        algo, config=Config(tuple((k, v) for k, v in algo.config.items if reads(k))),
        stages=None)


_SHARED_PROGRAMS: collections.OrderedDict[Any, Any] = collections.OrderedDict()
"""The compiled programs of this process by (program, view, shapes, runs, devices,
operator functions), most recently used last, at most ``3 * PROGRAM_CACHE_SIZE``: the
program sets of :func:`compiled_programs` take each program from here first."""


_RECENT_LOCK = threading.Lock()
"""Held by every change of an entry's place in the caches below: threads planning at once
(a robot node's executor) would otherwise drop an entry that another thread is moving."""


def _keep_recent(cache: collections.OrderedDict, key: Any, value: Any, most: int) -> None:
    """Put ``value`` in ``cache`` as its most recently used entry, and drop the entries
    used longest ago past ``most``: no cache of a long session grows without bound."""
    with _RECENT_LOCK:
        cache[key] = value
        cache.move_to_end(key)
        while len(cache) > most:
            cache.popitem(last=False)


def _recent(cache: collections.OrderedDict, key: Any) -> Any:
    """``cache``'s entry for ``key`` (None when it has none), made its most recently used."""
    with _RECENT_LOCK:
        value = cache.get(key)
        if value is not None:
            cache.move_to_end(key)
        return value


def _share(key: Any, program: Any) -> None:
    _keep_recent(_SHARED_PROGRAMS, key, program, 3 * PROGRAM_CACHE_SIZE)


class Programs:
    """The programs of a batch of runs: init compiled at once, evolve and finish compiled
    when first needed, so that a batch whose initialisation found no path at all compiles
    nothing more (:func:`sweep`). Each is taken from another program set of this process
    that shares it (``shared``: its key per program, :func:`program_view`), else read
    from :mod:`jaxga._runtime.executables` when stored there; the functions are traced
    (``trace()``) only when one is neither."""

    NAMES = ("init", "evolve", "finish")

    def __init__(self, trace: Callable[[], dict[str, Any]], keys: dict[str, str | None],
                 devices: Sequence[Any], shared: dict[str, Any] | None = None) -> None:
        self._trace = trace
        self._traced: dict[str, Any] | None = None
        self._keys = keys
        self._devices = devices
        self._shared = shared or {}
        self._compiled: dict[str, Any] = {}
        self._stats: dict[str, Any] = {}
        self.read = 0  # how many programs came from the store

    def _compile(self, names: Sequence[str], report: Callable[[float], None]) -> None:
        """Compile (or read) the ``names`` not compiled yet, one after the other,
        reporting the fraction of the work (the tracing, then each program) done after
        each program but the last."""
        steps = 1 + len(self.NAMES)  # the tracing, then each program
        for name in names:
            shared = self._shared.get(name)
            if name in self._compiled:
                if shared is not None:  # used again: most recently used among the shared
                    _share(shared, self._compiled[name])
                continue
            program = _recent(_SHARED_PROGRAMS, shared) if shared is not None else None
            if program is None:
                program, read = executables.load_or_compile(
                    self._keys[name], self._devices, functools.partial(self._lower, name),
                    compiler_options(name, self._devices[0].platform))
                self.read += read
                if shared is not None:
                    _share(shared, program)
            self._compiled[name] = program
            done = 1 + len(self._compiled)
            if done < steps:
                report(done / steps)

    def _lower(self, name: str) -> Any:
        """The program ``name`` lowered (the functions traced first if they are not)."""
        if self._traced is None:
            self._traced = self._trace()
        return self._traced[name].lower()

    def compile_init(self, report: Callable[[float], None]) -> None:
        """Compile (or read) the init program if it is not yet, reporting the tracing's
        share of the work first (then :meth:`_compile`'s fractions), so a fresh set
        reports 1/4, 2/4 here and 3/4 in :meth:`compile_rest`, wherever its programs
        come from; a compiled one reports nothing."""
        if "init" not in self._compiled:
            report(1 / (1 + len(self.NAMES)))
        self._compile(["init"], report)

    def compile_rest(self, report: Callable[[float], None]) -> None:
        self._compile(["evolve", "finish"], report)

    @property
    def init(self) -> Any:
        return self._compiled["init"]

    def memory_stats(self) -> dict[str, Any]:
        """XLA's account of the buffers of each program compiled (or read) so far
        (``Compiled.memory_analysis()``, None where the backend gives none), by name;
        asked once per program (it takes tens of milliseconds)."""
        for name, program in self._compiled.items():
            if name not in self._stats:
                try:
                    self._stats[name] = program.memory_analysis()
                except Exception:  # noqa: BLE001 - a backend without the analysis
                    self._stats[name] = None
        return dict(self._stats)

    @property
    def evolve(self) -> Any:
        """The compiled evolve program (compiled now if need be): ``(keys, grid, params,
        state, count) -> (state, history)``, :data:`GENERATION_CHUNK` generations of
        which the first ``count`` run."""
        self.compile_rest(lambda frac: None)
        return self._compiled["evolve"]

    @property
    def finish(self) -> Any:
        self.compile_rest(lambda frac: None)
        return self._compiled["finish"]


_TABLE_PROGRAMS: collections.OrderedDict[str, Any] = collections.OrderedDict()
"""The map-table programs of this process by key, most recently used last, at most
``3 * PROGRAM_CACHE_SIZE``."""


def tables_for(grid: Any) -> Any:
    """``grid`` with its map tables (:func:`jaxga.engine.maptables.with_tables`), computed
    by a program kept in the store like the run's own (:mod:`jaxga._runtime.executables`), so
    that a later process on a map of the same shape compiles nothing for them."""
    if grid.tables is not None:
        return grid
    bare = dataclasses.replace(grid, guide=None)
    devices = jax.local_devices()[:1]
    key = executables.program_key("map tables", None, shape_spec(bare), None, 1, devices)
    program = _recent(_TABLE_PROGRAMS, key) if key is not None else None
    if program is None:
        program, _ = executables.load_or_compile(key, devices,
                                                 lambda: compute_tables.lower(bare))
        if key is not None:
            _keep_recent(_TABLE_PROGRAMS, key, program, 3 * PROGRAM_CACHE_SIZE)
    return dataclasses.replace(grid, tables=program(bare))


GENERATION_CHUNK = 25
"""Generations per call of the compiled evolve program: a run of ``G`` generations makes
``ceil(G / 25)`` calls, the last running only the generations left, so every generation
count shares one program, and progress is reported after every call (the last call's
loop runs only its ``count`` steps)."""


SMALL_CALL_RUNS = 4
"""Runs of the small program: a call of up to 4 runs (all devices together) is one
program of 4 runs, so a re-plan's 4 seeds compute no padding (a larger small program
slows every re-plan: decision 028)."""


RUNS_PER_DEVICE = 32
"""Runs per device of the large program: a call of more than :data:`SMALL_CALL_RUNS`
runs is one or more calls of ``32 x devices`` runs (the last padded)."""


RUN_BUCKETS = (SMALL_CALL_RUNS, RUNS_PER_DEVICE)
"""The CPU's two program sizes (:func:`run_layout`; a GPU's: :func:`platform_layout`):
1-4 seeds share one program, and any count
above runs the 32-per-device program as often as needed, on any number of devices (10,
20 and 30 seeds: one program). So two program sets per preset and map serve every seed
count. On maps up to 64 x 64 a run computes in milliseconds, so padding a few runs to a
call of 32 per device costs far less than compiling a program for them; blocks of 20-50
runs per device compute fastest, and many seeds as calls of 32 per device lose little
throughput to that layout (decision 011)."""


LARGE_MAP_BUCKETS = (1, 2, 4, 8, 16, 32)
"""Runs per device on maps of more than :data:`LARGE_MAP_CELLS` cells, where a run's
computation, not the compilation, is most of the waiting: powers of two, so the padding
at most doubles it."""


LARGE_MAP_CELLS = 64 * 64


ACCELERATOR_BUCKETS = (32, 64, 128, 256, 512, 1024, 2048)
"""Runs per device of the large programs on a GPU (any platform but the CPU), on maps up
to :data:`LARGE_MAP_CELLS` cells: the smallest power of two that holds a device's share,
more runs being calls of 2048, each evolved as one ``vmap``. On a GPU a run costs less
the more runs share its call, but not so much less that padding pays: powers of two
bound the padding to twice the runs (decision 037)."""


@dataclasses.dataclass(frozen=True)
class PlatformLayout:
    """How runs are laid out as calls on one platform (:func:`platform_layout`).

    Attributes:
        buckets: runs per device of the large programs, ascending (:func:`run_layout`).
        run_block: the most runs one ``vmap`` evolves and finishes (:func:`map_runs`).
        init_run_block: the most runs one ``vmap`` initialises.
        reuse_factor: a program already compiled for more runs is reused for a call
            (instead of compiling its own size) when it holds at most this many times
            the call's runs per device, or the smallest bucket; None: any size up to the
            largest bucket.
    """

    buckets: tuple[int, ...]
    run_block: int
    init_run_block: int
    reuse_factor: int | None = None


def platform_layout(platform: str | None = None) -> PlatformLayout:
    """The run layout of ``platform`` (default: JAX's default backend, where the programs
    run).

    On the CPU: calls of :data:`RUNS_PER_DEVICE` runs per device, computed in blocks of
    :data:`RUN_BLOCK` and initialised in blocks of :data:`INIT_RUN_BLOCK` (decision 011:
    batches that fit the caches, loops that wait for fewer runs). On a GPU or TPU:
    calls of :data:`ACCELERATOR_BUCKETS` runs per device, each evolved and finished as
    one ``vmap`` (a run costs less the more runs share its call), and initialised as one
    ``vmap`` of up to :data:`ACCELERATOR_INIT_BLOCK` runs (decision 048). On the CPU a
    run's result does not depend on its call or block, so the layout changes no result
    there.
    """
    platform = jax.default_backend() if platform is None else platform
    if platform == "cpu":
        return PlatformLayout((RUNS_PER_DEVICE,), RUN_BLOCK, INIT_RUN_BLOCK)
    return PlatformLayout(ACCELERATOR_BUCKETS, ACCELERATOR_BUCKETS[-1], ACCELERATOR_INIT_BLOCK,
                          reuse_factor=2)


ACCELERATOR_INIT_BLOCK = ACCELERATOR_BUCKETS[-1]
"""The most runs a GPU or TPU initialises in one ``vmap``: a whole call. On an H200 the
initial populations of 2048 runs in one call are the CPU's bit for bit (decision 048), so
decision 037's blocks of 10 there, a workaround while the path check was computed wrongly,
ended: they make a call's initialisation a loop of small blocks one after another."""


_WARNED_PLATFORMS: set[str] = set()


def warn_platform(platform: str) -> None:
    """Warn once per process and platform when the runs compute anywhere but on the CPU
    (:class:`jaxga.core.errors.PlatformWarning`): jaxga's results are the same bits for a
    seed, whatever the seeds, devices and layout around it, only on the CPU."""
    if platform == "cpu" or platform in _WARNED_PLATFORMS:
        return
    _WARNED_PLATFORMS.add(platform)
    warnings.warn(
        f"the runs compute on the {platform}: there a seed's result may differ from the "
        "CPU's and with the number of runs in its call (measured on a GPU, decision 048); "
        "for reproducible results, JAX_PLATFORMS=cpu runs them on the CPU",
        PlatformWarning, stacklevel=3)


def run_layout(n_runs: int, n_devices: int = 1, cells: int = 0,
               compiled: Sequence[int] = (), platform: str | None = None) -> tuple[int, int]:
    """``(runs per device of each call, calls)`` for ``n_runs`` runs on ``n_devices``
    devices of ``platform`` (default: JAX's default backend).

    Up to :data:`SMALL_CALL_RUNS` runs: one call of ``ceil(4 / devices)`` per device;
    more: the smallest of the platform's buckets (:func:`platform_layout`: 32 on the
    CPU; powers of two from 32 to 2048 on a GPU) that holds each device's share, or
    calls of the largest. On maps of more than :data:`LARGE_MAP_CELLS` ``cells``: the smallest of
    :data:`LARGE_MAP_BUCKETS` that holds each device's share, or calls of 32, on every
    platform. ``compiled``: runs per device of the programs this process has already
    compiled for the same algorithm and map; the smallest of them that holds the share
    is taken instead of compiling a new size (a DOE's confirmation run, a replan after a
    larger run: no new compilation, at the cost of the padded runs); on a GPU only one
    of at most twice the share or the smallest bucket (``reuse_factor``), so that a
    re-plan of 4 runs does not compute a call of 2048.
    """
    if n_runs < 1 or n_devices < 1:
        raise ParameterError(f"need at least one run and one device, got {n_runs} runs on "
                             f"{n_devices} devices")
    per_device = math.ceil(n_runs / n_devices)
    layout = platform_layout(platform)
    buckets = layout.buckets if cells <= LARGE_MAP_CELLS else LARGE_MAP_BUCKETS
    largest = buckets[-1]
    if per_device > largest:
        return largest, math.ceil(per_device / largest)
    reuse = largest if layout.reuse_factor is None else min(
        largest, max(buckets[0], layout.reuse_factor * per_device))
    have = [b for b in compiled if per_device <= b <= reuse]
    if have:
        return min(have), 1
    if n_runs <= SMALL_CALL_RUNS and cells <= LARGE_MAP_CELLS:
        return math.ceil(SMALL_CALL_RUNS / n_devices), 1
    return min(b for b in buckets if b >= per_device), 1


RUN_BLOCK = 64
"""Largest number of runs :func:`map_runs` computes in one ``vmap`` on the CPU
(:func:`platform_layout`).

Blocks of 20-50 runs compute faster than blocks of 125, and one ``vmap`` of 50 runs is
within noise of two blocks of 25 (decision 011). The CPU's
programs of :func:`compiled_programs` hold at most ``RUN_BUCKETS[-1]`` runs per device,
so there only their initialisation is split further (:data:`INIT_RUN_BLOCK`)."""


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
    default the platform's (:func:`platform_layout`: :data:`RUN_BLOCK` on the CPU).
    """
    block = platform_layout().run_block if block is None else int(block)
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
"""XLA:CPU options of the finish program (post-optimisation, metrics; it runs once per
run): XLA:CPU's older (LLVM IR) fusion emitters compile it faster than the default MLIR
emitters, with the same results (checked in the A/B tables and by
``tests/engine/test_engine.py``), and its run is no slower (decision 012). Always these
options on the CPU, whatever the number of runs, so a run's results never depend on how
many runs share its call; never on another platform (:func:`compiler_options`). The
init and evolve programs keep XLA's defaults: with the older emitters they compile
faster but run slower on wide batches (decision 012)."""


def compiler_options(name: str, platform: str) -> dict[str, bool] | None:
    """The XLA options program ``name`` (``"init"``, ``"evolve"``, ``"finish"``) is
    compiled with for devices of ``platform`` (``jax.Device.platform``): a copy of
    :data:`FINISH_COMPILER_OPTIONS` for the finish program on ``"cpu"``, None (XLA's
    defaults) otherwise.

    Why only there: they are ``xla_cpu_*`` options, measured on XLA:CPU (decision 012).
    XLA's GPU compiler has no emitter they select, so passing them there would at best be
    ignored; not passing them keeps a GPU compile exactly XLA's default one
    (docs/devices.md)."""
    if name == "finish" and platform == "cpu":
        return dict(FINISH_COMPILER_OPTIONS)
    return None


def program_algorithm(algo: Algorithm) -> Algorithm:
    """``algo`` as the compiled programs see it: without its number of generations (a
    run-time value: the dynamic parameter ``generations`` and the calls of the evolve
    chunk), so that runs of any length share one program set."""
    config = Config(tuple((k, v) for k, v in algo.config.items if k != "generations"))
    return dataclasses.replace(algo, config=config, generations=0)


_COMPILED_BUCKETS: collections.OrderedDict[Any, set[int]] = collections.OrderedDict()
"""Runs per device of the program sets compiled in this process, per (algorithm, map
spec, per-run parameter spec, devices): :func:`run_layout` reuses a larger one rather
than compile a new size. The families used most recently, at most
``8 * PROGRAM_CACHE_SIZE`` (a family forgotten costs at most a program of another size)."""


def compiled_buckets(algo: Algorithm, grid: Any, params: dict) -> set[int]:
    """The bucket sizes (runs per device) this process has compiled for the programs of
    ``algo`` on ``grid`` with these per-run ``params``."""
    return set(_COMPILED_BUCKETS.get(_family(program_algorithm(algo), shape_spec(grid),
                                             params), ()))


def _family(algo: Algorithm, grid_spec: Any, params: dict) -> Any:
    per_run = tuple(sorted((k, (tuple(v.shape[1:]), str(v.dtype))) for k, v in params.items()))
    return algo, grid_spec, per_run, jax.local_device_count()


def programs_for(algo: Algorithm, grid: Any, params: dict, n_runs: int,
                 report: Callable[[float], None] = lambda frac: None) -> Programs:
    """The program set of ``n_runs`` runs per call (a multiple of the local devices) with
    these parameters (arrays with the runs first) (:func:`compiled_programs`), its init
    program compiled (or read) now if this process has not yet: ``report`` is told how
    far that has got (:meth:`Programs.compile_init`; nothing when it is compiled)."""
    algo = program_algorithm(algo)
    check_backend()  # off the CPU: refuse a backend that failed the device probe
    warn_platform(jax.default_backend())
    n_dev = jax.local_device_count()
    grid_spec = shape_spec(grid)
    progs = compiled_programs(algo, grid_spec, tuple(sorted(shape_spec(params).items())),
                              n_runs, n_dev, operator_functions(algo))
    progs.compile_init(report)
    family = _family(algo, grid_spec, params)
    sizes = (_recent(_COMPILED_BUCKETS, family) or set()) | {n_runs // n_dev}
    _keep_recent(_COMPILED_BUCKETS, family, sizes, 8 * PROGRAM_CACHE_SIZE)
    return progs


def operator_functions(algo: Algorithm) -> tuple:
    """The functions of ``algo``'s operators (part of a compiled program's identity)."""
    return tuple((op.family, op.name, op.fn, op.population, op.options)
                 for op in chosen_operators(algo.config).values())


@functools.lru_cache(maxsize=PROGRAM_CACHE_SIZE)
def compiled_programs(algo: Algorithm, grid_spec: Any, params_spec: Any, n_runs: int,
                      n_devices: int, functions: tuple = ()) -> Programs:
    """The program set (init / evolve / finish) of ``n_runs`` runs, each traced and
    compiled, or read from the store, when first needed (:class:`Programs`); each
    program is traced from its own view of ``algo`` (:func:`program_view`) and shared
    with the sets of this process that have the same view.

    Cached per (algorithm, map shape and corner rule, parameter shapes, run count,
    devices, the chosen operators' functions: an operator registered again under its
    name is traced again): a second call with another map of the same shape, other
    seeds, another number of generations (``algo`` comes through :func:`program_algorithm`) or other
    dynamic parameter values (probabilities, weights, temperatures, population size
    below the capacity) reuses the compiled programs (``jaxga.replan`` relies on it).
    The programs are compiled one after the other.
    """
    del n_devices, functions  # parts of the cache key only
    if algo.generations:
        raise ParameterError("compiled_programs takes program_algorithm(algo): the number of "
                             "generations is a run-time value")
    params_spec = dict(params_spec)
    sh, rep = seed_sharding()

    views = {name: program_view(algo, name) for name in Programs.NAMES}
    # each program traces the methods of a GA of its view (the pure core's own methods)
    ga = {name: PureGA(view) for name, view in views.items()}

    def do_init(k, grid, params):
        state, stats = ga["init"].init_with_stats(k, params, grid)
        return state, stats.success_rate, stats.n_failed, stats.from_fallback

    def do_evolve(k, grid, params, state, count):
        return ga["evolve"].evolve(k, state, params, GENERATION_CHUNK, grid, count=count)

    def do_finish(grid, params, state):
        return ga["finish"].finish(state, params, grid=grid)

    # Every per-run input and output has the run axis first: one sharding for all of
    # them, so each device runs its share and the result does not depend on the device
    # count. The map and the evolve chunk's generation count are replicated. With
    # several devices the program is a shard_map: each device runs its own share as a
    # program of its own. Under a jit sharded by XLA instead, every while_loop whose trip
    # count depends on the runs (the operators' gated blocks, connection rounds) had to
    # agree on its condition across devices at every iteration (decision 011).
    n_dev = 1 if sh is None else sh.mesh.size
    # this process's own device: with several processes, jax.devices()[0] is process 0's
    devices = [jax.local_devices()[0]] if sh is None else list(sh.mesh.devices.flat)

    layout = platform_layout(devices[0].platform)

    def jit(fn, in_axes, block):
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

    def trace() -> dict[str, Any]:
        init_t = jit(do_init, (0, None, 0), layout.init_run_block).trace(
            keys, grid_spec, params_spec)
        state_spec = init_t.out_info[0]
        evolve_t = jit(do_evolve, (0, None, 0, 0, None), layout.run_block).trace(
            keys, grid_spec, params_spec, state_spec, jax.ShapeDtypeStruct((), jnp.int32))
        finish_t = jit(do_finish, (None, 0, 0), layout.run_block).trace(
            grid_spec, params_spec, state_spec)
        return {"init": init_t, "evolve": evolve_t, "finish": finish_t}

    settings = (layout.init_run_block, layout.run_block, GENERATION_CHUNK,
                FINISH_COMPILER_OPTIONS)
    stored = {name: executables.program_key(name, views[name], grid_spec, params_spec,
                                            n_runs, devices, settings)
              for name in Programs.NAMES}
    shared = {name: (name, views[name], grid_spec, tuple(sorted(params_spec.items())), n_runs,
                     tuple(devices), operator_functions(views[name]))
              for name in Programs.NAMES}
    # One after the other: threads (one per core) do not shorten the compile
    # (decision 011).
    return Programs(trace, stored, devices, shared)


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
    _SHARED_PROGRAMS.clear()
    _COMPILED_BUCKETS.clear()
    _TABLE_PROGRAMS.clear()
    jax.clear_caches()
    gc.collect()


def stack_params(per_point: Sequence[dict], seeds: int) -> dict[str, np.ndarray]:
    """Per-run parameters (NumPy): every point repeated once per seed (run ``q * S + s``)."""
    # NumPy, put on the devices once per call of the programs (a re-plan's small calls
    # were spending a tenth of their time in eager jnp.stack / jnp.repeat dispatches)
    return {k: np.repeat(np.stack([np.asarray(p[k]) for p in per_point]), seeds, axis=0)
            for k in per_point[0]}
