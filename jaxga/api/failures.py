"""Runs that found no path: their causes, the warnings, and explicit no-path results.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import warnings

import numpy as np

from jaxga._runtime.device_probe import run_environment
from jaxga._runtime.sweep_plan import InitOutcome, SweepPlan
from jaxga.api.result import Result
from jaxga.core.errors import InitialisationWarning
from jaxga.core.objectives import Metrics
from jaxga.operators import registry


def unstarted_results(plan: SweepPlan, start: InitOutcome, timing: dict) -> list[Result]:
    """The results of a sweep whose initialisation gave no run a path: every seed failed,
    each with its cause; nothing evolved."""
    algo, point_opt = plan.algo, plan.point_opt
    n_seeds = len(plan.seed_arr)
    results = []
    for q, cfg in enumerate(plan.configs):
        sl = slice(q * n_seeds, (q + 1) * n_seeds)
        success = np.zeros(n_seeds, bool)
        causes = failure_causes(success, success, start.rate[sl], start.from_fallback[sl],
                                cfg, algo.capacity, len(plan.octile.path))
        r = no_path_result(cfg, plan.map_name, plan.grid, plan.seed_arr, algo,
                           failure_reason(causes), timing, algo.population, plan.frame,
                           plan.map_source)
        results.append(dataclasses.replace(
            r, preset=plan.config["name"], init_success_rate=start.rate[sl],
            init_unfilled=start.unfilled[sl], optimum=float(plan.octile.length),
            any_angle_note="not computed: no seed got an initial path",
            timing=dict(timing),
            point={k.replace("__", "."): v for k, v in plan.points[q].items()},
            fitness_optimum=point_opt[q].fitness, fitness_optimum_length=point_opt[q].length,
            fitness_optimum_loop_free=point_opt[q].loop_free,
            fitness_optimum_reason="" if point_opt[q].found else point_opt[q].reason,
            init_fallback=start.from_fallback[sl], causes=causes,
            path_capacity=algo.capacity, initial_fitness=start.initial[sl].astype(float),
            size_class=plan.size_class))
    return results


def warn_unfilled(unfilled: np.ndarray, init_rate: np.ndarray, capacity: int,
                  config, max_tries: np.ndarray | None = None) -> None:
    """Warn (:class:`~jaxga.core.errors.InitialisationWarning`) when runs whose initialiser made
    some paths still started with copies in empty slots
    (``jaxga.operators.init.initialise_population`` fills slots left empty after
    ``init.max_tries`` attempts per individual with copies).
    Runs whose initialiser made no path are failures with a reason instead.
    ``max_tries``: each run's ``init.max_tries`` (a sweep may vary it; default: the
    configuration's)."""
    short = (unfilled > 0) & (init_rate > 0)
    if not short.any():
        return
    n = unfilled[short]
    copied = f"{n.min()}" if n.min() == n.max() else f"{n.min()}-{n.max()}"
    tries = (np.asarray([config.get("init.max_tries")]) if max_tries is None
             else np.asarray(max_tries)[short])
    budget = f"{tries.min()}" if tries.min() == tries.max() else f"{tries.min()}-{tries.max()}"
    warnings.warn(
        f"{int(short.sum())} of {short.size} runs started with {copied} of their {capacity} "
        f"initial individuals copied: the initialiser {config.get('init.method')!r} "
        f"succeeded in {100 * float(init_rate[short].mean()):.2g} % of its "
        f"attempts, and init.max_tries = {budget} did not fill the "
        "population (raise init.max_tries)",
        InitialisationWarning, stacklevel=caller_stacklevel())


def caller_stacklevel() -> int:
    """The ``stacklevel`` that makes a warning raised by this function's caller point at
    the first frame outside the jaxga package (the user's line, whichever of ``run``,
    ``sweep``, ``replan`` or the CLI they called)."""
    frame, level = sys._getframe(1), 1
    while frame.f_back is not None and registry.in_jaxga(frame.f_globals.get("__name__", "")):
        frame, level = frame.f_back, level + 1
    return level


def failure_causes(success: np.ndarray, started: np.ndarray, init_rate: np.ndarray,
                   from_fallback: np.ndarray, config, capacity: int,
                   shortest_cells: int) -> np.ndarray:
    """Per seed, why it returned no path ("" for a successful seed): its initialisation
    gave it no path (the initialiser never succeeded on this map, with or without the
    fallback; or the path capacity is below the shortest path's cell count; or the
    objective gave none of the paths it made a finite fitness > 0, as a user's objective
    may), or its best path did not survive the final feasibility check."""
    out = np.full(len(success), "", dtype=object)
    method, fallback = config.get("init.method"), config.get("init.fallback", "none")
    own = _own_objective(config)
    for i in np.flatnonzero(~np.asarray(success)):
        if started[i]:
            out[i] = "lost its best path in the final feasibility check"
        elif own is not None and (init_rate[i] > 0 or from_fallback[i] > 0):
            out[i] = (f"got no initial path of fitness > 0: its initialisers made paths, "
                      f"but the objective {own!r} gave none of them a finite fitness > 0 "
                      "(an objective gives a feasible path a finite value > 0, an "
                      "infeasible one 0)")
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


def _own_objective(config) -> str | None:
    """The name of the configuration's objective when it is a user's own (registered from
    outside jaxga, whose values jaxga cannot vouch for), else None."""
    name = config.get("fitness.method")
    try:
        fn = registry.operator("fitness", name).fn
    except (KeyError, ValueError, TypeError):
        return None
    return None if registry.is_jaxgas(fn) else str(name)


def failure_reason(causes: np.ndarray) -> str:
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


def no_path_result(config, map_name, grid, seeds, algo, reason, timing,
                   population_capacity, frame=None, map_source=None) -> Result:
    """The result of runs that cannot start: every seed failed with ``reason``."""
    s = len(seeds)
    empty = np.zeros((s, 1), np.int32)
    nan = np.full(s, np.nan)
    return Result(
        preset=config["name"], map_name=map_name, corner_rule=grid.corner_rule, seeds=seeds,
        success=np.zeros(s, bool), reason=reason, cells=empty, n_cells=np.zeros(s, np.int32),
        raw_cells=empty, raw_n_cells=np.zeros(s, np.int32), length=nan, raw_length=nan,
        fitness=np.full(s, np.nan), convergence_generation=np.full(s, -1),
        history={k: np.zeros((s, 0)) for k in ("best", "mean", "std")
                 + ("hypervolume",) * bool(algo.stages.objectives)},  # a run's own keys
        metrics={k: nan.copy() for k in Metrics._fields},
        raw_metrics={k: nan.copy() for k in Metrics._fields}, failures=np.zeros((s, 3), np.int32),
        init_success_rate=np.zeros(s), init_unfilled=np.zeros(s, np.int32),
        optimum=math.inf, any_angle_optimum=math.inf, any_angle_note=reason,
        timing={"compile_s": 0.0, "init_s": 0.0, "evolve_s": 0.0, "post_s": 0.0,
                **timing},
        population=int(config["population.size"]) * algo.islands,
        generations=algo.generations, width=grid.width, config=config,
        fitness_optimum_reason=reason, start=grid.start_xy, goal=grid.goal_xy,
        population_capacity=population_capacity, init_fallback=np.zeros(s, np.int32),
        initial_fitness=np.zeros(s),
        causes=np.full(s, reason, dtype=object), path_capacity=algo.capacity, frame=frame,
        map_digest=grid.cells_digest(), environment=run_environment(),
        map_source=map_source,
    )

