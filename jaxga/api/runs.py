"""``jaxga.run``: many seeded runs of a preset on a map, in one compiled call.

``run(preset, grid, seeds=N, **overrides) -> Result``: the seeds are a
``jax.vmap`` (sharded over the available devices), the generations a ``lax.scan``;
initialisation, evolution and post-optimisation are three compiled functions so that
their times can be reported separately, as the papers' tables do. Compilation is timed
on its own.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import re
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import jax
import numpy as np
from jax.errors import JaxRuntimeError

from jaxga._runtime import executables, parallel
from jaxga._runtime.calls import RunCalls, evolve_in_chunks, this_process_runs
from jaxga._runtime.device_probe import check_backend, needs_probe, run_environment
from jaxga._runtime.fields import front_obstacles, program_fields
from jaxga._runtime.memory import (
    NO_PATH_BYTES_PER_RUN,
    check_compiled_memory,
    check_memory,
    check_result_memory,
)
from jaxga._runtime.programs import (
    GENERATION_CHUNK,
    Programs,
    clear_compiled,
    programs_for,
    tables_for,
)
from jaxga._runtime.references import (
    AnyAngleBounds,
    any_angle_references,
    maximin_reference,
    octile_optimum,
)
from jaxga._runtime.seeds import seed_list
from jaxga._runtime.size_classes import auto_size_class, class_capacity, map_cells, pad_to_class
from jaxga._runtime.sweep_plan import InitOutcome, SweepPlan
from jaxga._runtime.timeline import Timeline
from jaxga.api.failures import (
    failure_causes,
    failure_reason,
    no_path_result,
    unstarted_results,
    warn_unfilled,
)
from jaxga.api.problem import Problem, load_problem
from jaxga.api.result import Result
from jaxga.api.result_fronts import Fronts
from jaxga.config.schema import SCHEMA, Config, dotted, flatten
from jaxga.core.errors import DeviceMemoryError, ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import Grid, as_integer
from jaxga.core.own_settings import own_settings
from jaxga.engine import (
    Algorithm,
    build,
    check_migration,
    check_overrides_read,
    convergence_generation,
    default_params,
    static_config,
    uses_guide,
)
from jaxga.engine.evolution import Front
from jaxga.maps import MapInfo
from jaxga.reference.fitness import FitnessOptimum, fitness_optimum, fitness_weights

if TYPE_CHECKING:
    from jaxga.engine.evolution import Front


MIN_ANY_ANGLE_BUDGET = 0.5
"""Seconds the any-angle reference gets at least under ``any_angle_budget="auto"``: on a
small map the exact search takes milliseconds, more than a quick GA's own time, and a
run's reported gaps should not depend on how fast the machine happened to be."""

WAYPOINT_FITNESS = ("this configuration evolves waypoint paths; the exact fitness optimum "
                    "covers 8-connected paths only, so it bounds nothing here")
"""Why a run of waypoint paths (AGACD, Zhang's eq. 5 deletions) has no fitness gap."""


@dataclasses.dataclass(frozen=True)
class CallOptions:
    """How a request of :func:`run` or :func:`sweep` runs, beside what it runs (the
    problem, the points and the seeds): its progress callback, population capacity,
    size class and any-angle budget, as those functions document them."""

    progress: Callable[[str, float], None] | None = None
    population_capacity: int | None = None
    size_class: bool | None = None
    any_angle_budget: float | str | None = "auto"


def check_call_options(progress, chunks, size_class=None, any_angle_budget="auto") -> None:
    """The options of :func:`run` and :func:`sweep` that do not reach the configuration."""
    if size_class is not None and not isinstance(size_class, (bool, np.bool_)):
        raise ParameterError(f"size_class must be True, False or None (automatic), got "
                             f"{size_class!r}")
    if not (any_angle_budget is None or any_angle_budget == "auto" or (
            isinstance(any_angle_budget, (int, float, np.integer, np.floating))
            and not isinstance(any_angle_budget, (bool, np.bool_))
            and math.isfinite(any_angle_budget) and any_angle_budget >= 0)):
        raise ParameterError(f"any_angle_budget must be 'auto', a number of seconds >= 0 or "
                             f"None (no limit), got {shown_value(any_angle_budget)}")
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable (stage, fraction), got "
                             f"{progress!r}")
    try:
        chunks = as_integer(chunks)
    except TypeError:
        raise ParameterError(f"chunks must be an integer >= 1, got {chunks!r}") from None
    if chunks < 1:
        raise ParameterError(f"chunks must be an integer >= 1, got {chunks!r}")


def _point_configs(config: Config, points: Sequence[Mapping[str, Any]]) -> list[Config]:
    """Validated configurations of the sweep points; only dynamic keys and the
    population size may vary (they do not change the compiled program:
    :func:`jaxga.config.schema.sweepable`)."""
    out = []
    base = static_config(config)
    for point in points:
        changes = dotted(point)
        cfg = config.override(changes)
        check_overrides_read(cfg, flatten(changes))
        if static_config(cfg) != base:
            new = dict(static_config(cfg).items)
            old = dict(base.items)
            changed = sorted(k for k in new.keys() | old.keys() if new.get(k) != old.get(k))
            if changed == ["generations"]:  # a run-time value, but one per call
                raise ParameterError(
                    f"sweep point {dict(point)} changes generations: the runs of one sweep "
                    "share its generation count (given to sweep as generations=); run "
                    "another count as another sweep, which reuses the compiled programs")
            compiled = ", ".join(k for k in changed if k != "generations")
            also = " (and generations, one per sweep)" if "generations" in changed else ""
            raise ParameterError(
                f"sweep point {dict(point)} changes {compiled}, which the "
                f"compiled program depends on{also}: only dynamic keys (rates, weights, "
                "temperatures, init.max_tries, init.fallback, termination.stagnation, "
                "islands.interval, the per-island rates, AGACD's Delphi ratios; 'dynamic' "
                "in jaxga presets --show) and population.size can be swept in one compiled "
                "call; run the other values separately")
        # every point's islands must hold its migrants: an inactive individual never
        # migrates (the check at build time only sees the largest size)
        check_migration(cfg, int(cfg["population.size"]))
        out.append(cfg)
    return out


@own_settings
def sweep(
    preset: str | Config | Problem,
    grid: Grid | MapInfo | str | None,
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
    size_class: bool | None = None,
    any_angle_budget: float | str | None = "auto",
    **overrides: Any,
) -> list[Result]:
    """Run every point of a hyper-parameter sweep with every seed, in ONE compiled call.

    ``points`` are mappings of configuration keys (``crossover.probability``, AGACD's
    ``mutation.pm_low``, fitness weights, ``population.size``, ...) applied on top of the
    preset and ``overrides``. Dynamic keys become per-run arrays of a ``jax.vmap``; the
    population size becomes the engine's ``active`` count below a capacity equal to the
    largest size swept. Keys that change the compiled program (operators, capacity) are
    refused with a :class:`ParameterError`, as is a point's generation count (a run-time
    value, but one per sweep: ``generations=``). Run ``q * S + s`` is point
    ``q`` with seed ``s``: every point sees the same seeds (common random numbers, as a
    designed experiment wants). Returns one :class:`Result` per point; their ``timing``
    is that of the whole sweep.

    ``population_capacity`` (default: the largest size swept) fixes the population
    capacity. Results depend on it, so a sweep split into several calls (``jaxga.doe``'s
    resumable blocks) passes the largest size of the WHOLE sweep to every call to get the
    same results as one call. It must be at least every point's ``population.size``.
    ``size_class`` and ``any_angle_budget`` as in :func:`run`.
    The runs are split over this process's devices and, after
    :func:`jaxga._runtime.parallel.initialize`, over several processes: each computes its share and
    every process returns the whole, identical result (:mod:`jaxga._runtime.parallel`; a lost
    process raises :class:`jaxga._runtime.parallel.ProcessLostError`).
    """

    _check_points(points)
    check_call_options(progress, chunks, size_class, any_angle_budget)
    if chunks != 1:
        warnings.warn("chunks is ignored: the generations run in compiled chunks of "
                      f"{GENERATION_CHUNK} and progress is reported after each",
                      DeprecationWarning, stacklevel=2)
    options = CallOptions(progress, population_capacity, size_class, any_angle_budget)
    while True:
        timeline = Timeline()
        try:
            with timeline.phase("load"):
                problem = load_problem(preset, grid, corner_rule, variant, sets, overrides,
                                       generations)
            return _sweep(problem, points, seeds, options, timeline)
        except JaxRuntimeError as err:
            if "RESOURCE_EXHAUSTED" in str(err):
                raise DeviceMemoryError(out_of_memory(err)) from None
            # a stored program that does not run (jaxga._runtime.executables: "NOT_FOUND:
            # Function ... not found", or "INTERNAL: Error dispatching computation:
            # Function ... not found"): forget the stored programs this process read
            # (deleted: never read again) and run again
            if not _MISSING_FUNCTION.search(str(err)) or not executables.forget_read():
                raise
            clear_compiled()


_MISSING_FUNCTION = re.compile(r"NOT_FOUND|Function \S+ not found")


def out_of_memory(err: Exception) -> str:
    """The one line of a :class:`~jaxga.core.errors.DeviceMemoryError`: the device, XLA's
    first line (cut to 200 characters) and what to make smaller. The memory estimate
    (:mod:`jaxga._runtime.memory`) lays calls out to fit before anything runs; XLA's
    allocator can still run out where the estimate is low for a device (a GPU: it is
    not measured there)."""
    devices = jax.local_devices()
    first = (str(err).strip().splitlines() or [""])[0]
    if len(first) > 200:
        first = first[:200] + "..."
    return (f"the {devices[0].platform} device ({devices[0].device_kind}) ran out of memory "
            f"({first}): run fewer seeds (or sweep points) at a time, a smaller "
            "population.size, or a coarser map (--coarsen)")


def _sweep(problem: Problem, points: Sequence[Mapping[str, Any]], seeds: Any,
           options: CallOptions, timeline: Timeline) -> list[Result]:
    """:func:`sweep`'s work as phases over a :class:`~jaxga._runtime.sweep_plan.SweepPlan`
    (each timed by the :class:`~jaxga._runtime.timeline.Timeline`, which has timed the
    problem's loading): the plan (configurations, references, the programs' map and
    parameters), the compiled programs, the initial populations, the evolution, the
    finish, the any-angle references, the results."""
    report = _reporter(options.progress)
    plan = _plan_sweep(problem, points, seeds, options, timeline, report)
    if not plan.octile.found:  # no path: nothing to compile
        return _no_path_results(plan, timeline)
    runs, progs = _compile_init(plan, timeline, report)
    report("init", 0.0)
    groups = runs.groups()
    states, first = _initialise(groups[0], progs, timeline)
    # every process decides alike: it stops here only where no run of any process's
    # first group started and every process computes one group
    started, one_group = parallel.allgather_runs((first[0] > 0, np.array([len(groups) == 1])))
    if one_group.all() and not started.any():
        # nothing can succeed: no evolution, no post-optimisation
        start = _gathered_start(plan, [first])
        report("compile", 1.0)
        return unstarted_results(plan, start, {"compile_s": 0.0, "init_s": 0.0,
                                                "evolve_s": 0.0, "post_s": 0.0,
                                                **timeline.as_dict()})
    # the stage is "compile" again while evolve and finish compile (the progress line
    # said "init" until the evolve program was done): the tracing and init are done
    report("compile", 2 / (1 + len(Programs.NAMES)))
    with timeline.phase("compile"):
        progs.compile_rest(lambda frac: report("compile", frac))
    check_compiled_memory(progs.memory_stats(), len(groups[0].calls), runs.n_local)
    report("compile", 1.0)
    report("evolve", 0.0)
    inits, outs = [first], []
    for g, group in enumerate(groups):
        if g:
            states, part = _initialise(group, progs, timeline)
            inits.append(part)
        outs.append(_evolve_and_finish(plan, group, progs, states, timeline,
                                       _grouped_progress(report, g, len(groups))))
        del states  # the group's device memory goes before the next group's
    start = _gathered_start(plan, inits)
    with timeline.phase("post"):
        host, hist = parallel.allgather_runs(jax.tree_util.tree_map(
            lambda *parts: np.concatenate(parts), *outs))
    bounds = _any_angle_bounds(plan, host, options.any_angle_budget, timeline, report)
    return _point_results(host, hist, plan, start, timeline.as_dict(), bounds)


def _reporter(progress: Callable[[str, float], None] | None) -> Callable[[str, float], None]:
    """``progress`` or, without one, a function that reports nothing."""
    return progress if progress is not None else (lambda stage, frac: None)


def _plan_sweep(problem: Problem, points: Sequence[Mapping[str, Any]], seeds: Any,
                options: CallOptions, timeline: Timeline,
                report: Callable[[str, float], None]) -> SweepPlan:
    """Every point's configuration checked, the exact 8-connected optimum
    (phase ``references``); where a path exists, the programs' map, the algorithm at the
    sweep's capacity, each point's parameters and the exact optimum of its own fitness
    (``references``), and the seeds (memory checked)."""
    config, map_grid, map_name, frame = problem.config, problem.grid, problem.map_name, \
        problem.frame
    for point in points:  # the points' value or the call's? neither silently
        both = [k for k in flatten(dotted(point)) if k in problem.given]
        if both:
            raise ParameterError(
                f"{', '.join(both)} is set by a sweep point and by the call (a keyword "
                "override or --set): the point's value would replace the call's; give it "
                "in the points alone")
    configs = _point_configs(config, points)
    capacity = checked_capacity(configs, options.population_capacity)
    report("references", 0.0)
    with timeline.phase("references"):
        octile = octile_optimum(map_grid, guided=uses_guide(config))
    info = problem.info  # a bare Grid (a Planner's "grid" too) has no source to record
    source = None if info is None or info.format == "grid" else info.source_json()
    problem = dict(config=config, configs=configs, points=points, map_name=map_name,
                   frame=frame, grid=map_grid, capacity=capacity, octile=octile,
                   map_source=source)
    if not octile.found:
        return SweepPlan(**problem, seed_arr=seed_list(seeds, lambda n: check_memory(
            n * len(configs), NO_PATH_BYTES_PER_RUN, "for their results")))
    # the programs run on the map padded to its size class (decision 029), if asked
    size_class = auto_size_class(map_grid) if options.size_class is None \
        else bool(options.size_class)
    with timeline.phase("references"):
        program_grid, build_config = _program_map(config, map_grid, capacity, size_class,
                                                  front_obstacles(frame, map_grid))
        # the capacity is the largest size swept, also when it is below the preset's size
        algo, _ = build(build_config, program_grid)
        per_point = [default_params(c, algo.islands) for c in configs]
        _check_param_shapes(per_point, points)
        point_opt = _fitness_optima(configs, map_grid, algo)
    seed_arr = seed_list(seeds, lambda n: check_result_memory(n * len(configs), algo))
    return SweepPlan(**problem, seed_arr=seed_arr, size_class=size_class, algo=algo,
                      program_grid=program_grid, per_point=per_point, point_opt=point_opt)


def _check_param_shapes(per_point: Sequence[dict], points: Sequence[Mapping[str, Any]]) -> None:
    """Every point's parameters have the first point's keys, shapes and types (one
    compiled program takes them all): a point that gives a parameter another shape (a
    per-island list where the others have one rate) is refused, naming it."""
    def spec(params: dict) -> dict:
        return {k: (tuple(np.shape(v)), str(np.asarray(v).dtype)) for k, v in params.items()}

    first = spec(per_point[0])
    for point, params in zip(points[1:], per_point[1:]):
        other = spec(params)
        bad = sorted(k for k in first.keys() | other.keys() if first.get(k) != other.get(k))
        if bad:
            def said(s: dict, k: str = bad[0]) -> str:
                return f"shape {s[k][0]} ({s[k][1]})" if k in s else "no value"

            raise ParameterError(
                f"sweep point {dict(point)} gives the parameter {bad[0]} {said(other)} "
                f"where the first point gives it {said(first)}: one compiled call takes "
                "one shape; run these points separately")


def _program_map(config: Config, grid: Grid, capacity: int, size_class: bool,
                 obstacles: np.ndarray | None = None) -> tuple[Grid, Config]:
    """The map the programs run on (the exact distance fields attached when an operator
    steers by them, computed on the map and padded with it; padded to its size class
    when asked) and the configuration they are built from (the sweep's capacity; the
    class's path capacity unless the configuration sets one)."""
    build_config = config.override({"population.size": capacity})
    guided = program_fields(grid, config, obstacles)
    if not size_class:
        return guided, build_config
    if not int(config["population.capacity"]):
        build_config = build_config.override({"population.capacity": class_capacity(
            grid, float(config["population.capacity_factor"]))})
    return pad_to_class(guided), build_config


def _fitness_optima(configs: Sequence[Config], grid: Grid, algo: Algorithm) -> list[Any]:
    """The exact optimum of each point's own fitness, once per distinct weight set
    (points may sweep the weights). It covers 8-connected paths: no bound for waypoint
    paths."""
    fit_keys = [(m, tuple(sorted(w.items()))) for m, w in map(fitness_weights, configs)]
    fit_opts = {k: (FitnessOptimum(False, k[0], math.nan, reason=WAYPOINT_FITNESS)
                    if algo.waypoints else fitness_optimum(grid, k[0], **dict(k[1])))
                for k in dict.fromkeys(fit_keys)}
    return [fit_opts[k] for k in fit_keys]


def _no_path_results(plan: SweepPlan, timeline: Timeline) -> list[Result]:
    """One "no path" result per point, naming the cause (nothing ran)."""
    return [no_path_result(c, plan.map_name, plan.grid, plan.seed_arr,
                           build(c, plan.grid)[0], plan.octile.reason, timeline.as_dict(),
                           plan.capacity, plan.frame, plan.map_source)
            for c in plan.configs]


def _compile_init(plan: SweepPlan, timeline: Timeline,
                  report: Callable[[str, float], None]) -> tuple[RunCalls, Programs]:
    """This process's runs as calls of the compiled programs, on the programs' map with
    its per-map tables (attached once per run rather than computed every generation),
    and the program set with its init program compiled (phase ``compile``). Off the CPU,
    the device probe first, when this device kind has no verdict yet (phase
    ``device_probe``; :func:`jaxga._runtime.device_probe.check_backend`)."""
    if needs_probe():
        report("device-probe", 0.0)
        with timeline.phase("device_probe"):
            check_backend()
    report("compile", 0.0)
    with timeline.phase("compile"):
        grid = tables_for(plan.program_grid)
        for padded in (True, False):
            runs = this_process_runs(plan.seed_arr, plan.per_point, grid, plan.algo, padded)
            progs = programs_for(plan.algo, runs.grid, runs.calls[0][1], runs.per_call,
                                 lambda frac: report("compile", frac))
            try:
                check_compiled_memory(progs.memory_stats(), len(runs.groups()[0].calls),
                                      runs.n_local)
                break
            except ParameterError:
                # XLA's account exceeds the estimate: the same runs without their padding,
                # where there is padding to drop
                if not padded or len(runs.calls) * runs.per_call <= runs.n_local:
                    raise
    return runs, progs


def _initialise(runs: RunCalls, progs: Programs, timeline: Timeline) -> tuple[list, tuple]:
    """The initial population of every call of ``runs`` (phase ``init``), and this
    process's best initial fitness, initialisation success rate, unfilled slots and
    field-walk fallbacks of each of its runs."""
    with timeline.phase("init"):
        inits = jax.block_until_ready([progs.init(k, runs.grid, p) for k, p in runs.calls])
    states = [state for state, *_ in inits]
    return states, (runs.joined([state.best_fitness for state in states]),
                    *(runs.joined([i[j] for i in inits]) for j in (1, 2, 3)))


def _gathered_start(plan: SweepPlan, parts: Sequence[tuple]) -> InitOutcome:
    """The initialisation's outputs of this process's groups of calls, gathered over the
    processes; a warning when slots stayed empty."""
    joined = [np.concatenate(column) for column in zip(*parts)]
    initial, init_rate, unfilled, fallback = parallel.allgather_runs(joined)
    n_total = len(initial)
    start = InitOutcome(initial, init_rate.reshape(n_total, -1).mean(axis=1),
                   unfilled.reshape(n_total, -1).sum(axis=1),
                   fallback.reshape(n_total, -1).sum(axis=1))
    max_tries = np.repeat([int(c["init.max_tries"]) for c in plan.configs], len(plan.seed_arr))
    warn_unfilled(start.unfilled, start.rate, plan.algo.population * plan.algo.islands,
                  plan.config, max_tries)
    return start


def _evolve_and_finish(plan: SweepPlan, runs: RunCalls, progs: Programs, states: list,
                       timeline: Timeline, report: Callable[[str, float], None]) -> tuple:
    """The generations (phase ``evolve``) and the finish program (``post``) of the calls
    of ``runs``: this process's outputs and per-generation history of each of its runs
    (NumPy), the paths on the user's map (not its padding)."""
    with timeline.phase("evolve"):
        states, history = evolve_in_chunks(progs, plan.algo.generations, runs, runs.grid,
                                            states, lambda frac: report("evolve", frac))
    report("post", 0.0)
    with timeline.phase("post"):
        outs = jax.block_until_ready([progs.finish(runs.grid, p, st)
                                      for (_, p), st in zip(runs.calls, states)])
        out = jax.tree_util.tree_map(lambda *parts: runs.joined(parts), *outs)
        out = dataclasses.replace(  # the paths on the user's map
            out, cells=map_cells(out.cells, runs.grid.width, plan.grid.width),
            raw_cells=map_cells(out.raw_cells, runs.grid.width, plan.grid.width),
            front=None if out.front is None else dataclasses.replace(
                out.front, cells=map_cells(out.front.cells, runs.grid.width,
                                           plan.grid.width)))
    report("post", 1.0)
    return out, history


def _grouped_progress(report: Callable[[str, float], None], group: int,
                      groups: int) -> Callable[[str, float], None]:
    """``report`` for one of ``groups`` groups of calls computed one after another: the
    evolution's fraction over all of them."""
    if groups == 1:
        return report
    return lambda stage, frac: report(stage, (group + frac) / groups if stage == "evolve"
                                      else frac)


def _any_angle_bounds(plan: SweepPlan, host: dict, budget: float | str | None,
                      timeline: Timeline,
                      report: Callable[[str, float], None]) -> AnyAngleBounds:
    """The any-angle references of the map (phase ``any_angle``), within ``budget``
    seconds; ``"auto"``: as long as the GA's own work took (init, evolve, post), at least
    :data:`MIN_ANY_ANGLE_BUDGET`."""
    if budget == "auto":
        budget = max(sum(timeline.seconds.get(p, 0.0) for p in ("init", "evolve", "post")),
                     MIN_ANY_ANGLE_BUDGET)
    report("any-angle", 0.0)
    with timeline.phase("any_angle"):
        return any_angle_references(plan.grid, plan.octile, budget,
                                    lambda frac: report("any-angle", frac),
                                    _best_path(host, plan.grid.width))


def _best_path(host: dict, width: int) -> np.ndarray | None:
    """The shortest feasible post-optimised path of all runs as ``(x, y)`` cells (it
    bounds the any-angle search), or None when no run found one."""
    ok = np.flatnonzero(np.asarray(host["success"]) & np.asarray(host["feasible_post"]))
    if ok.size == 0:
        return None
    i = ok[np.argmin(np.asarray(host["length"])[ok])]
    cells = np.asarray(host["cells"][i])[:int(host["n_cells"][i])]
    return np.stack([cells % width, cells // width], axis=1)


def _check_points(points: Any) -> None:
    """A sweep's points: a non-empty list of mappings from key strings to values."""
    if not isinstance(points, Sequence) or isinstance(points, str) \
            or not all(isinstance(p, Mapping) and all(isinstance(k, str) for k in p)
                       for p in points):
        raise ParameterError(f"points must be a list of mappings key -> value, got "
                             f"{points!r}")
    if not points:
        raise ParameterError("a sweep needs at least one point")


def _point_results(host: dict, hist: dict, plan: SweepPlan, start: InitOutcome,
                   timing: dict, bounds: AnyAngleBounds) -> list[Result]:
    """One :class:`Result` per point from the gathered outputs of all runs (run
    ``q * S + s`` is point ``q``, seed ``s``)."""
    config, configs, points, grid, algo, octile = (plan.config, plan.configs, plan.points,
                                                   plan.grid, plan.algo, plan.octile)
    rate, unfilled, from_fallback, initial = (start.rate, start.unfilled, start.from_fallback,
                                              start.initial)
    n_seeds = len(plan.seed_arr)
    digest = grid.cells_digest()
    conv = convergence_generation(hist["best"], host["fitness"], initial)
    maximin = math.nan
    if host.front is not None:
        widest = maximin_reference(grid, front_obstacles(plan.frame, grid))
        maximin = widest.clearance if widest.found else math.nan
    results = []
    environment = run_environment()
    for q, cfg in enumerate(configs):
        sl = slice(q * n_seeds, (q + 1) * n_seeds)
        h = jax.tree_util.tree_map(lambda a, sl=sl: a[sl], host)
        success = h["success"] & h["feasible_post"]

        def found(v, success=success):  # a failed seed's numbers are missing, not 0
            v = np.asarray(v, float)
            return np.where(success.reshape((-1,) + (1,) * (v.ndim - 1)), v, np.nan)

        causes = failure_causes(success, start.started[sl], rate[sl], from_fallback[sl],
                                cfg, algo.capacity, len(octile.path))
        results.append(Result(
            preset=config["name"], map_name=plan.map_name, corner_rule=grid.corner_rule,
            seeds=plan.seed_arr, success=success, reason=failure_reason(causes),
            cells=h["cells"], n_cells=h["n_cells"],
            raw_cells=h["raw_cells"], raw_n_cells=h["raw_n_cells"],
            length=found(h["length"]), raw_length=found(h["raw_length"]),
            fitness=found(h["fitness"]),
            convergence_generation=conv[sl],
            generations_run=np.asarray(h["generations_run"]),
            history={k: v[sl] for k, v in hist.items()},
            metrics={k: found(v) for k, v in h["metrics"].items()},
            raw_metrics={k: found(v) for k, v in h["raw_metrics"].items()},
            failures=h["failures"],
            init_success_rate=rate[sl], init_unfilled=unfilled[sl],
            initial_fitness=initial[sl].astype(float),
            optimum=float(octile.length), any_angle_optimum=bounds.optimum,
            lower_bound=bounds.lower_bound, any_angle_note=bounds.note, frame=plan.frame,
            map_digest=digest, environment=environment, map_source=plan.map_source,
            timing=dict(timing), population=int(cfg["population.size"]) * algo.islands,
            generations=algo.generations, width=grid.width, config=cfg,
            point={k.replace("__", "."): v for k, v in points[q].items()},
            fitness_optimum=plan.point_opt[q].fitness,
            fitness_optimum_length=plan.point_opt[q].length,
            fitness_optimum_loop_free=plan.point_opt[q].loop_free,
            fitness_optimum_reason=("" if plan.point_opt[q].found
                                    else plan.point_opt[q].reason),
            front=_fronts(h.front, algo, maximin), maximin_clearance=maximin,
            start=grid.start_xy, goal=grid.goal_xy, population_capacity=algo.population,
            init_fallback=from_fallback[sl], causes=causes, path_capacity=algo.capacity,
            size_class=plan.size_class,
        ))
    return results


def _fronts(front: Front | None, algo: Algorithm, maximin: float) -> Fronts | None:
    """A front's outputs (:class:`jaxga.engine.evolution.Front`) as the result keeps
    them: the clearance positive, in cells, and infinite on a map without obstacles
    (``maximin``, the exact maximin clearance, infinite), where the runs read it capped
    at ``H + W`` (:func:`jaxga.operators.guide.with_front_fields`)."""
    if front is None:
        return None
    names = algo.stages.objectives
    objectives = np.asarray(front.objectives, float).copy()
    reference = np.asarray(front.reference, float).copy()
    for j, n in enumerate(names):
        if n == "clearance":
            objectives[..., j] = math.inf if maximin == math.inf else -objectives[..., j]
            reference[..., j] *= -1
    return Fronts(names=names, mask=np.asarray(front.mask), cells=np.asarray(front.cells),
                  n_cells=np.asarray(front.n_cells), objectives=objectives,
                  initial_hypervolume=np.asarray(front.initial_hypervolume, float),
                  reference=reference)


def checked_capacity(configs: Sequence[Config], requested: Any) -> int:
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
    most = SCHEMA["population.size"].high  # the program is built with this many
    if requested > most:
        raise ParameterError(f"population_capacity {requested} is above the largest "
                             f"population a program holds ({most:,} per island)")
    return requested


@own_settings
def run(
    preset: str | Config | Problem,
    grid: Grid | MapInfo | str | None = None,
    seeds: int | Sequence[int] = 1,
    *,
    generations: int | None = None,
    corner_rule: str | None = None,
    variant: str | None = None,
    sets: Sequence[str] = (),
    progress: Callable[[str, float], None] | None = None,
    chunks: int = 1,
    population_capacity: int | None = None,
    size_class: bool | None = None,
    any_angle_budget: float | str | None = "auto",
    **overrides: Any,
) -> Result:
    """Run ``preset`` on ``grid`` once per seed, all seeds in one compiled call.

    Args:
        preset: a preset name (``jaxga presets``), a TOML file, or a :class:`Config`; or
            a :class:`jaxga.api.problem.Problem` (:func:`jaxga.problem`: a preset on a
            map, already checked), then without ``grid``, ``corner_rule``, ``variant``,
            ``sets`` or overrides (``generations`` may still be given).
        grid: a :class:`Grid`, a map file or a built-in map name, an occupancy grid in
            memory (a ``nav_msgs/OccupancyGrid`` message or a
            :class:`jaxga.maps.OccupancyGrid`), or a :class:`jaxga.maps.MapInfo`
            (``load_map_info(name, start=..., goal=...)``: other endpoints, and the
            results keep the map's name where a Grid is "grid").
            A map given by name is loaded with ``corner_rule``, else a ``map.corner_rule``
            the configuration sets, else the map's own rule
            (:func:`jaxga.maps.default_corner_rule`: free on the papers' classic maps,
            strict elsewhere); a Grid or MapInfo keeps its own unless ``corner_rule`` is
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
        progress: optional callback ``(stage, fraction)``, called as each phase starts
            and as it advances: ``("references", 0.0)``; ``("compile", 0.0)``, the
            compilation's progress (after the tracing and after each compiled program,
            when the programs are not compiled yet), ``("compile", 1.0)``; ``("evolve",
            f)`` after each chunk of :data:`jaxga._runtime.programs.GENERATION_CHUNK`
            generations; ``("post", 0.0)`` and ``("post", 1.0)``; ``("any-angle", f)``
            (the fraction of its budget used).
        chunks: ignored (deprecated): the generations always run in compiled chunks of
            :data:`jaxga._runtime.programs.GENERATION_CHUNK`, whatever their number.
        population_capacity: individuals per island that the compiled program holds
            (default ``population.size``; not the configuration key
            ``population.capacity``, the cells a path can hold); the random numbers of a
            run depend on it. A
            point of a :func:`sweep` or a DOE over population sizes ran with the largest
            size swept as its capacity (``Result.population_capacity``): pass that to
            repeat its runs bit for bit.
        size_class: run on the map padded with blocked cells to its size class
            (:mod:`jaxga._runtime.size_classes`: each side 32, 64, 128, 256, 384, 512, 768,
            1024, 1536 or 2048 cells, and the class's path capacity), so that all maps of a class
            share compiled programs: a 20 x 20 and a 25 x 25 map compile once, and so
            do two 384 x 384 robot maps. None (default): True for maps with a side
            over 64 (users' maps), False for smaller ones, so that the papers' maps keep
            their published shapes. Results are reported on the map itself. Where an
            operator's arrays are sized by the map's shape (IMGA, MPMGA, Zhu's IGA) or
            the capacity differs, they differ seed by seed from the unpadded runs but
            not in what they are: feasible paths on the map, of the same distribution.
        any_angle_budget: seconds the any-angle reference may take after the runs
            (:mod:`jaxga._runtime.references`): ``"auto"`` (default) the runs' own time
            (initialisation, evolution and post-optimisation), so that the references
            never take longer than the GA, but at least :data:`MIN_ANY_ANGLE_BUDGET`
            (a small map's exact search takes milliseconds); None: no limit (the exact
            value whatever it costs); 0: skip the any-angle optimum and its lower bound
            (a plan that needs no gap; the 8-connected optimum, which tells an unreachable
            goal, is always computed). Beyond the budget :attr:`Result.any_angle_optimum` is NaN,
            :attr:`Result.any_angle_note` says so, and the gaps are to the proven
            lower bound, or with 0 to the straight line from start to goal
            (:attr:`Result.gap_basis`): never below zero.

    Returns:
        A :class:`Result`. Seeds that found no feasible path have ``success`` False and
        are never reported with a path. An unreachable goal gives all seeds
        ``success = False`` and ``reason`` naming the cause (nothing is run).

    The compiled programs are cached per algorithm and map shape and serve any number
    of generations and of seeds (runs padded to 4, or 32 per device, more as several
    calls: :mod:`jaxga._runtime.programs`): calling again with other seeds, another number
    of generations, another map of the same size (with ``size_class``, of the same
    size class) or other dynamic values
    (``crossover__probability=...``) does not compile again. For many hyper-parameter
    values in one call use :func:`sweep`.
    """
    return sweep(preset, grid, [{}], seeds, **_run_options(locals()), **overrides)[0]


RUN_OPTIONS = tuple(name for name, p in inspect.signature(run).parameters.items()
                    if p.kind is inspect.Parameter.KEYWORD_ONLY)
"""Keyword arguments of :func:`run` (besides ``seeds``) that are not configuration keys:
read from its signature, the one list of them (:func:`sweep` takes the same)."""


def _run_options(arguments: Mapping[str, Any]) -> dict[str, Any]:
    """The values of :data:`RUN_OPTIONS` among a call's ``arguments`` (its ``locals()``)."""
    return {name: arguments[name] for name in RUN_OPTIONS}


PROBLEM_OPTIONS = ("generations", "corner_rule", "variant", "sets")
"""The keyword arguments of :func:`run` that make its problem (:func:`jaxga.problem`); the
other :data:`RUN_OPTIONS` say how the problem is run."""


def checked_call(preset: str | Config | Problem, grid: Grid | MapInfo | str | None,
                 **options: Any) -> tuple[Problem, dict[str, Any]]:
    """The :class:`Problem` :func:`run` would run with these keyword ``options`` (all of
    :func:`run`'s but ``seeds``, and configuration overrides), checked as :func:`run`
    checks it before compiling (preset, map, endpoints, overrides that nothing reads,
    key combinations, migrants), and the options that say how it is run: ``run(problem,
    seeds=..., **call)`` then runs it without loading anything again. Raises what
    :func:`run` would raise; compiles and runs nothing (:func:`jaxga.compare` checks
    every preset so before the first one runs)."""
    overrides = dict(options)
    named = {k: overrides.pop(k) for k in RUN_OPTIONS if k in overrides}
    check_call_options(named.get("progress"), named.get("chunks", 1),
                        named.get("size_class"), named.get("any_angle_budget", "auto"))
    problem = load_problem(preset, grid, named.get("corner_rule"), named.get("variant"),
                           named.get("sets", ()), overrides, named.get("generations"))
    (config,) = _point_configs(problem.config, [{}])
    checked_capacity([config], named.get("population_capacity"))
    build(config, problem.grid)  # check_migration and check_combination
    return problem, {k: v for k, v in named.items() if k not in PROBLEM_OPTIONS}


@own_settings
def check_run(preset: str | Config, grid: Grid | str, **options: Any) -> Config:
    """The configuration :func:`run` would use with these keyword ``options``
    (:func:`checked_call`'s problem's), checked as :func:`run` checks it before
    compiling; raises what :func:`run` would raise."""
    problem, _ = checked_call(preset, grid, **options)
    (config,) = _point_configs(problem.config, [{}])
    return config
