"""The evolution engine: one generation as a composition of stages, a run as a ``lax.scan``.

A generation is

    selection -> crossover -> mutation -> (simplification) -> evaluation

each stage a pure function chosen by the configuration (:mod:`jaxga.config.schema`) from the
operator families (:mod:`jaxga.operators.selection`, :mod:`jaxga.operators.crossover`,
:mod:`jaxga.operators.mutation`, :mod:`jaxga.operators.postprocess`). A run is ``init``
followed by a ``lax.scan`` over generations with no host round-trip; IMGA's stagnation
rule freezes a run inside the scan. Many runs are a ``jax.vmap`` over PRNG keys and over the dynamic
parameters (probabilities, weights, temperatures) and the active population size.

Populations always carry an island axis: ``cells int32[I, P, L]``. A single-population
GA is ``I = 1``; the multi-population model (MPMGA) is the same generation ``vmap``-ed
over islands followed by a migration (:mod:`jaxga.operators.islands`).

The population size is a static *capacity* ``P`` plus a dynamic ``active`` count:
individuals at positions ``>= active`` are computed but never selected, counted or
reported, so a sweep over population sizes is one compiled call.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.numerics import ordered_mean
from jaxga.core import objectives, prng
from jaxga.core.geometry import clear
from jaxga.core.grid import Grid
from jaxga.core.paths import (
    Population,
    cell_steps,
    has_endpoints,
    is_continuous,
    is_feasible,
    remove_loops,
)
from jaxga.core.robot_objectives import minimised, robot_objectives
from jaxga.engine.algorithm import F32, I32, Algorithm
from jaxga.operators.init import initialise_population
from jaxga.operators.islands import migrate
from jaxga.operators.lift import gated_map, windowed_map
from jaxga.operators.pareto import (
    crowded_order,
    crowded_tournament,
    crowding_distance,
    hypervolume,
    nondominated_rank,
)
from jaxga.operators.registry import Binding


# ----------------------------------------------------------------------------- stages
def fitness_function(algo: Algorithm, params: dict) -> Callable:
    """``f(grid, cells, length, feasible) -> f32`` with the configured combiner and weights."""
    return algo.stages.fitness.bind(Binding(algo, params))


SHORT_SPAN = 4
"""Segments with ``|dx|, |dy| <= SHORT_SPAN`` get the cheap bounded line-of-sight test."""


def waypoints_feasible(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """``bool[P]``: :func:`jaxga.core.paths.is_feasible` of a population of waypoint paths.

    Same answer, less work. A segment of span at most 1 (a grid step, or a repeated node)
    is clear exactly when its cells are free and, for a diagonal step, its side cells
    satisfy the corner rule (:func:`jaxga.core.geometry.clear` on 8-adjacent pairs is
    :func:`jaxga.core.grid.move_legal`): one lookup per cell, computed for every slot. Only
    the longer segments get a line-of-sight test, gathered across the population by
    :func:`jaxga.operators.lift.gated_map`: the bounded exact test
    (``clear(..., max_span=SHORT_SPAN)``) for spans up to :data:`SHORT_SPAN`, the full
    exact test beyond (crossover junctions, simplified corners). Most segments of an
    evolved population are single steps and most slots are padding, so no slot pays for
    a line-of-sight test it does not need (decision 004).
    """

    p, cap = cells.shape
    inside, free, span, step_ok = cell_steps(grid, cells)
    valid = jnp.arange(cap - 1, dtype=I32)[None, :] < (length[:, None] - 1)
    medium = valid & (span > 1) & (span <= SHORT_SPAN)
    long_ = valid & (span > SHORT_SPAN)
    a, b = cells[:, :-1].reshape(-1), cells[:, 1:].reshape(-1)
    ones = (jnp.ones((p * (cap - 1),), bool),)
    (medium_ok,) = gated_map(lambda u, v: (clear(grid, u, v, max_span=SHORT_SPAN),),
                             medium.reshape(-1), (a, b), ones, block=16)
    (long_ok,) = gated_map(lambda u, v: (clear(grid, u, v),), long_.reshape(-1), (a, b),
                           ones, block=16)
    seg_ok = jnp.where(
        long_, long_ok.reshape(p, cap - 1),
        jnp.where(medium, medium_ok.reshape(p, cap - 1), step_ok | ~valid),
    )
    on_map = jnp.all(inside, axis=1)
    sized = (length >= 1) & (length <= cap)
    return sized & on_map & free[:, 0] & jnp.all(seg_ok, axis=1)


def evaluate(algo: Algorithm, grid: Grid, params: dict, cells, length, active, *,
             window: bool | None = None) -> tuple:
    """``(fitness f32[P], feasible bool[P])``; infeasible or inactive -> fitness 0.

    With ``fitness.window`` (default) grid paths are evaluated by
    :func:`jaxga.operators.lift.windowed_map`: on the first ``window_width(L)`` cells (64 of
    160 on a 20 x 20 map) whenever every path of the batch fits, with the same bits as
    on all ``L``: faster where paths stay short, at the price of a second (narrow)
    program to compile; iga_zhu and mpmga switch it off (their populations keep a few
    long paths, and they gained nothing; decision 005). ``window`` (static): ``False``
    evaluates at full width only whatever the configuration says (the initial
    population, evaluated once per run: one program instead of two, the same bits;
    decision 006).
    """
    fit = fitness_function(algo, params)
    if algo.waypoints:
        ends = jax.vmap(lambda c, n: has_endpoints(grid, c, n))(cells, length)
        feas = ends & waypoints_feasible(grid, cells, length)
        f = jax.vmap(lambda c, n, ok: fit(grid, c, n, ok))(cells, length, feas)
    else:
        def one(c, n):
            ok = has_endpoints(grid, c, n) & is_continuous(grid, c, n)
            return fit(grid, c, n, ok), ok

        use_window = algo.get("fitness.window") if window is None else window
        if use_window:
            f, feas = windowed_map(one, cells, length)
        else:
            f, feas = jax.vmap(one)(cells, length)
    return jnp.where(active, f, 0.0).astype(F32), feas & active


def binding(algo: Algorithm, params: dict, t: jax.Array | None = None,
            fit_fn: Callable | None = None) -> Binding:
    """What the stages bind operators with (:class:`jaxga.operators.registry.Binding`): the static
    algorithm, the dynamic parameters, generation ``t``, the fitness function and
    whether ``repair.fallback = "field"``."""
    return Binding(algo, params, generation=t, generations=run_generations(algo, params),
                   fitness_fn=fit_fn, field_repair=algo.stages.field_repair)


def run_generations(algo: Algorithm, params: dict) -> jax.Array | int:
    """The run's number of generations ``T`` (AGACD eq. 27, 29): the dynamic parameter
    ``generations`` (:func:`jaxga.engine.default_params`), so that one compiled program
    serves every generation count; ``algo.generations`` for parameters without it."""
    return params.get("generations", algo.generations)


def _select(algo: Algorithm, key, fitness, active) -> jax.Array:
    op = algo.stages.selection
    if op.fn is None:
        return jnp.arange(fitness.shape[0], dtype=I32)
    return op.bind(Binding(algo, {}))(key, fitness, active)


def _crossover(algo: Algorithm, key, grid, pop, fitness, active, t, params, fit_fn):
    op = algo.stages.crossover
    if op.fn is None and op.population is None:
        return pop, jnp.int32(0)
    pc = algo.stages.crossover_rate(params, fitness, active, t,
                                      run_generations(algo, params))
    return op.lift(binding(algo, params, t, fit_fn))(key, grid, pop, pc)


def _mutation(algo: Algorithm, key, grid, pop, fitness, active, t, params, fit_fn):
    op = algo.stages.mutation
    if op.fn is None and op.population is None:
        return pop, jnp.int32(0)
    pm = algo.stages.mutation_rate(params, fitness, active, t,
                                     run_generations(algo, params))
    return op.lift(binding(algo, params, t, fit_fn))(key, grid, pop, pm)


def _simplify(algo: Algorithm, key, grid, pop, params):
    op = algo.stages.simplify
    if op.fn is None:
        return pop, jnp.int32(0)
    ps = jnp.broadcast_to(params["simplify.probability"], (pop.size,))
    return op.lift(binding(algo, params))(key, grid, pop, ps)


# ------------------------------------------------------------------------------ state
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class IslandState:
    """One population (one island): paths, fitness, feasibility."""

    cells: jax.Array  # int32[P, L]
    length: jax.Array  # int32[P]
    fitness: jax.Array  # float32[P]
    feasible: jax.Array  # bool[P]
    objectives: jax.Array | None = None
    """``float32[P, M]``: the minimised robot objectives of a front (``survival.method``;
    :func:`objective_vectors`); None for a scalar GA."""


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class GAState:
    """The state of one run: islands, the best path so far, counters."""

    islands: IslandState  # leading axis I
    best_cells: jax.Array  # int32[L]
    best_length: jax.Array  # int32
    best_fitness: jax.Array  # float32 (0 while no feasible path was seen)
    generation: jax.Array  # int32
    stall: jax.Array  # int32: generations without improvement
    frozen: jax.Array  # bool: stagnation rule fired
    failures: jax.Array  # int32[3]: crossover, mutation, simplification failures
    reference: jax.Array | None = None
    """``float32[M]``: the reference point of a front's hypervolume
    (:func:`hypervolume_reference`), fixed at initialisation; None for a scalar GA."""
    initial_hypervolume: jax.Array | None = None
    """``float32``: the initial population's hypervolume (the history's rows start after
    the first generation); None for a scalar GA."""


def _active(algo: Algorithm, params: dict) -> jax.Array:
    return jnp.arange(algo.population, dtype=I32) < params["population.active"]


def _best_of(state_islands: IslandState) -> tuple:
    f = state_islands.fitness.reshape(-1)
    k = jnp.argmax(f)
    cells = state_islands.cells.reshape(-1, state_islands.cells.shape[-1])[k]
    return cells, state_islands.length.reshape(-1)[k], f[k]


def init_state(algo: Algorithm, key: jax.Array, grid: Grid, params: dict) -> tuple:
    """Initial population of every island and its evaluation.

    ``init.method`` draws the population within ``init.max_tries`` attempts per
    individual (traced: the bound of a ``while_loop`` of rounds); ``init.fallback =
    "field_walk"`` then fills exactly the slots it left empty with
    :func:`jaxga.operators.init.field_walk` (``init.slack``, ``init.temperature``), so a
    run starts with a whole population wherever a path exists (decision 018). The
    fallback is compiled in whenever ``init.method`` can fail and runs where the traced
    flag ``params["init.fallback"]`` is set (``"none"`` clears it: the slots stay as the
    initialiser left them, the results of a program without the fallback). Returns
    ``(GAState, InitStats)`` (one entry per island).
    """
    ctx = binding(algo, params)
    init_fn = algo.stages.init.bind(ctx)
    fallback, fallback_on = None, True
    if algo.stages.fallback is not None:
        fallback = algo.stages.fallback.bind(ctx)
        fallback_on = params["init.fallback"]
    keys = prng.split(key, algo.islands)
    active = _active(algo, params)
    max_tries = params["init.max_tries"]

    def one(k):
        pop, stats = initialise_population(
            k, grid, init_fn, algo.population, algo.capacity,
            max_tries=max_tries, fallback=fallback, fallback_on=fallback_on,
            unique=bool(algo.get("init.unique", False)),
        )
        # Once per run: at full width (the window pays off in the generations' loop).
        fitness, feas = evaluate(algo, grid, params, pop.cells, pop.length, active,
                                 window=False)
        return IslandState(pop.cells, pop.length, fitness, feas,
                           objective_vectors(algo, grid, pop.cells, pop.length)), stats

    islands, stats = jax.vmap(one)(keys)
    best_c, best_n, best_f = _best_of(islands)
    reference = volume = None
    if islands.objectives is not None:
        m = len(algo.stages.objectives)
        points, valid = islands.objectives.reshape(-1, m), islands.feasible.reshape(-1)
        reference = hypervolume_reference(points, valid)
        volume = hypervolume(points, valid, reference)
    state = GAState(
        islands=islands, best_cells=best_c, best_length=best_n, best_fitness=best_f,
        generation=jnp.int32(0), stall=jnp.int32(0), frozen=jnp.bool_(False),
        failures=jnp.zeros(3, I32), reference=reference, initial_hypervolume=volume,
    )
    return state, stats


def island_generation(algo: Algorithm, key, grid: Grid, isl: IslandState, t, params: dict):
    """One generation of one island: selection -> crossover -> mutation -> simplify -> eval."""
    active = _active(algo, params)
    fit_fn = fitness_function(algo, params)
    k_sel, k_cx, k_mu, k_si = prng.split(key, 4)
    if algo.stages.survival is None:
        idx = _select(algo, k_sel, isl.fitness, active)
    else:  # NSGA-II's mating selection (Deb et al. 2002, III-B) on the parents' front
        rank = nondominated_rank(isl.objectives, isl.feasible)
        idx = crowded_tournament(k_sel, rank, crowding_distance(isl.objectives, rank),
                                 active, algo.population)
    pop = Population(isl.cells[idx], isl.length[idx])
    fitness = isl.fitness[idx]
    # the papers' "current number of iterations" t (AGACD eq. 27 and 29, MPMGA eq. 17)
    # is 1 in the first generation; jaxga's generation counter ``t`` starts at 0
    iteration = t + 1
    pop, f_cx = _crossover(algo, k_cx, grid, pop, fitness, active, iteration, params, fit_fn)

    def vary(pop, fitness):
        pop, f_mu = _mutation(algo, k_mu, grid, pop, fitness, active, iteration, params,
                              fit_fn)
        pop, f_si = _simplify(algo, k_si, grid, pop, params)
        return pop, jnp.stack([f_mu, f_si]).astype(I32)

    if not algo.stages.mutation_rate.reads_offspring_fitness:
        pop, fails = vary(pop, fitness)
        new_fitness, feas = evaluate(algo, grid, params, pop.cells, pop.length, active)
    else:
        # The mutation rate reads the fitness after crossover (AGACD eq. 28-29), so the
        # generation evaluates twice. The two evaluations are the
        # two steps of one loop, mutation and simplification a branch of step 0: the
        # evaluation is compiled once (fewer kernels to compile; decision 006), with the
        # same results.
        def step(i, carry):
            pop, _, _, fails = carry
            fitness, feas = evaluate(algo, grid, params, pop.cells, pop.length, active)
            pop, fails = jax.lax.cond(i == 0, lambda: vary(pop, fitness),
                                      lambda: (pop, fails))
            return pop, fitness, feas, fails

        zero = (jnp.zeros((algo.population,), F32), jnp.zeros((algo.population,), bool),
                jnp.zeros((2,), I32))
        pop, new_fitness, feas, fails = jax.lax.fori_loop(0, 2, step, (pop, *zero))
    offspring = IslandState(pop.cells, pop.length, new_fitness, feas,
                            objective_vectors(algo, grid, pop.cells, pop.length))
    if algo.stages.survival is not None:
        offspring = survive(isl, offspring, active)
    return offspring, jnp.concatenate([jnp.reshape(f_cx, (1,)).astype(I32), fails])


def objective_vectors(algo: Algorithm, grid: Grid, cells: jax.Array,
                      length: jax.Array) -> jax.Array | None:
    """``float32[P, M]``: the robot objectives a front minimises
    (:func:`jaxga.core.robot_objectives.robot_objectives`, in cells, the clearance
    negated, :func:`jaxga.core.robot_objectives.minimised`) of a population, read from
    the grid's clearance field and band (:func:`jaxga.operators.guide.with_front_fields`);
    None without a front (``survival.method``)."""
    names = algo.stages.objectives
    if not names:
        return None
    guide = grid.guide

    def one(c, n):
        return minimised(robot_objectives(grid, c, n, guide.clearance, band=guide.band),
                         names)

    return jax.vmap(one)(cells, length)


def distinct(objectives: jax.Array, valid: jax.Array) -> jax.Array:
    """``bool[P]``: valid individuals whose objective vector no earlier valid individual
    has (the first of each set of equal vectors): copies never take a place on a front."""
    same = jnp.all(objectives[:, None, :] == objectives[None, :, :], axis=-1)
    n = objectives.shape[0]
    earlier = jnp.arange(n)[None, :] < jnp.arange(n)[:, None]
    return valid & ~jnp.any(same & earlier & valid[None, :], axis=1)


def survive(parents: IslandState, offspring: IslandState, active: jax.Array) -> IslandState:
    """NSGA-II's elitist survival (Deb et al. 2002, section III-C) of parents and offspring
    together: whole fronts while they fit, then the least crowded of the next, among
    distinct objective vectors (:func:`distinct`); then copies, then paths that are not
    feasible. The survivors are in crowded order; slots past ``active`` are inactive."""
    both = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b]), parents, offspring)
    n = both.fitness.shape[0]
    unique = distinct(both.objectives, both.feasible)
    rank = nondominated_rank(both.objectives, unique)
    crowding = crowding_distance(both.objectives, rank)
    rank = jnp.where(unique, rank, jnp.where(both.feasible, n, n + 1))
    keep = crowded_order(rank, crowding)[:n // 2]
    kept = jax.tree_util.tree_map(lambda a: a[keep], both)
    return dataclasses.replace(kept, fitness=jnp.where(active, kept.fitness, 0.0),
                               feasible=kept.feasible & active)


HYPERVOLUME_MARGIN = 0.1
"""The reference point of a front's hypervolume lies this share of the initial
population's range beyond its worst value of each objective."""


def hypervolume_reference(objectives: jax.Array, valid: jax.Array) -> jax.Array:
    """``float32[M]``: the reference point of a run's hypervolume, fixed at initialisation
    (decision 045): each objective's worst value over the valid initial individuals,
    moved :data:`HYPERVOLUME_MARGIN` of their range (and a little more, so that a
    population of one value has a volume) further; zeros without a valid individual."""
    valid = valid[:, None]
    worst = jnp.max(jnp.where(valid, objectives, -jnp.inf), axis=0)
    best = jnp.min(jnp.where(valid, objectives, jnp.inf), axis=0)
    ref = worst + HYPERVOLUME_MARGIN * (worst - best) + 1e-3 * (1.0 + jnp.abs(worst))
    return jnp.where(jnp.isfinite(ref), ref, 0.0).astype(F32)


def _island_params(params: dict, islands: int) -> tuple[dict, dict]:
    """Split params into per-island ones (leading axis I) and shared ones."""
    per = {k: v for k, v in params.items() if jnp.ndim(v) == 1 and v.shape[0] == islands
           and k.endswith("probability")}
    shared = {k: v for k, v in params.items() if k not in per}
    return per, shared


def generation(algo: Algorithm, key, grid: Grid, state: GAState, params: dict):
    """One generation of a run: every island's variation and the migration, in the order of
    ``islands.timing`` (jaxga's default: vary, then migrate; MPMGA Fig. 1: migrate, then vary;
    every ``islands.interval`` generations, traced); honours the freeze and applies IMGA
    4.4's stagnation rule (``termination.stagnation``, traced: a run freezes after K
    generations without improvement, never for K = 0)."""

    t = state.generation
    per, shared = _island_params(params, algo.islands)
    keys = prng.split(key, algo.islands + 1)

    def one(k, isl, p_isl):
        return island_generation(algo, k, grid, isl, t, {**shared, **p_isl})

    islands = state.islands
    before = algo.get("islands.timing") == "before_variation"
    interval = params["islands.interval"]
    if before:  # MPMGA section 2 / Fig. 1: evaluate, migrate, then cross and mutate
        islands = migrate(algo, keys[-1], islands, t, _active(algo, params), interval)
    islands, fails = jax.vmap(one)(keys[:-1], islands, per)
    if not before:  # jaxga's default: vary every island, then migrate
        islands = migrate(algo, keys[-1], islands, t, _active(algo, params), interval)
    best_c, best_n, best_f = _best_of(islands)
    better = best_f > state.best_fitness
    new = GAState(
        islands=islands,
        best_cells=jnp.where(better, best_c, state.best_cells),
        best_length=jnp.where(better, best_n, state.best_length),
        best_fitness=jnp.where(better, best_f, state.best_fitness),
        generation=t + 1,
        stall=jnp.where(better, 0, state.stall + 1),
        frozen=state.frozen,
        failures=state.failures + jnp.sum(fails, axis=0),
        reference=state.reference,
        initial_hypervolume=state.initial_hypervolume,
    )
    # IMGA 4.4: stop after K generations without improvement (K traced; 0 = never). A
    # frozen run keeps its old state below, so only an unfrozen one can freeze here.
    k_stop = params["termination.stagnation"]
    new = dataclasses.replace(new, frozen=(k_stop > 0) & (new.stall >= k_stop))
    return jax.tree_util.tree_map(lambda old, nw: jnp.where(state.frozen, old, nw), state, new)


def history_row(algo: Algorithm, state: GAState, params: dict) -> dict:
    """Best-so-far, mean and sd of the active fitness (MPMGA Figs. 15-17)."""
    active = jnp.broadcast_to(_active(algo, params), state.islands.fitness.shape)
    f = state.islands.fitness
    # ordered (batch-invariant) sums: a seed's history does not depend on the runs
    # computed alongside it (jaxga._batching.numerics)
    active, f = active.reshape(-1), f.reshape(-1)
    mean = ordered_mean(f, active)
    var = ordered_mean((f - mean) ** 2, active)
    row = {"best": state.best_fitness, "mean": mean, "std": jnp.sqrt(var)}
    if state.reference is not None:  # a front: the volume it dominates (decision 045)
        isl = state.islands
        row["hypervolume"] = hypervolume(isl.objectives.reshape(-1, state.reference.shape[0]),
                                         isl.feasible.reshape(-1), state.reference)
    return row


def evolve(algo: Algorithm, key, grid: Grid, state: GAState, params: dict,
           generations: int | None = None, count: jax.Array | None = None):
    """``lax.scan`` over generations; returns ``(final state, history)``.

    Generation ``t`` uses the key ``fold_in(key, t)``, so running ``G`` generations in one
    call or in chunks (for a progress bar) gives the same result. The history holds, per
    generation, the best-so-far fitness and the mean and sd of the active fitness.

    ``count`` (optional, a traced integer): only the first ``count`` of the
    ``generations`` steps run (a loop with a run-time trip count); the history rows after
    them are zeros, to be dropped. One compiled chunk of ``generations`` steps then serves
    every generation count (:mod:`jaxga._runtime.programs`); ``count`` must not be batched (a
    ``vmap``'s ``in_axes`` None). That loop also ends once the run is frozen by the
    stagnation rule (under ``vmap``: once every run of the batch is): a frozen run's
    generations change nothing, so its remaining rows are its final row and the result
    is the same as looping on, at the cost of the generations it needs.
    """
    n = algo.generations if generations is None else generations
    ts = state.generation + jnp.arange(n, dtype=I32)

    def step(st, t):
        return generation(algo, prng.fold_in(key, t), grid, st, params)

    if count is None:
        def body(st, t):
            st = step(st, t)
            return st, history_row(algo, st, params)

        return jax.lax.scan(body, state, ts)

    # a loop of ``count`` steps writing the history rows in place (not a scan with a
    # branch per step, which copies the state at every step: decision 028)
    rows = jax.eval_shape(lambda st: history_row(algo, st, params), state)
    history = jax.tree_util.tree_map(lambda r: jnp.zeros((n, *r.shape), r.dtype), rows)

    steps = jnp.minimum(count, n)

    def counted(carry):
        i, st, hist = carry
        st = step(st, ts[i])
        row = history_row(algo, st, params)
        return i + 1, st, jax.tree_util.tree_map(lambda h, r: h.at[i].set(r), hist, row)

    ran, state, history = jax.lax.while_loop(
        lambda c: (c[0] < steps) & ~c[1].frozen, counted, (jnp.int32(0), state, history))
    # rows a frozen run skipped: what each of those generations would have recorded
    last = history_row(algo, state, params)
    skipped = (jnp.arange(n) >= ran) & (jnp.arange(n) < steps)
    history = jax.tree_util.tree_map(
        lambda h, r: jnp.where(skipped.reshape((n,) + (1,) * r.ndim), r, h), history, last)
    return state, history


def convergence_generation(best: jax.Array, final_best: jax.Array,
                           initial_best: jax.Array | None = None) -> jax.Array:
    """The first generation whose best-so-far fitness equals the final best (AGACD
    Tables 8, 12), per run: 0 when the initial population already held it (given
    ``initial_best``), -1 when no feasible path was found (``final_best`` 0).

    ``best``: ``[..., G]`` best-so-far fitness per generation (the history's ``best``);
    ``final_best`` and ``initial_best``: ``[...]``. Works on NumPy arrays as on JAX ones
    (the API computes it on the host from the gathered history, so that the compiled
    programs do not depend on the number of generations).
    """
    xp = jnp if isinstance(best, jax.Array) else np
    final_best = xp.asarray(final_best)
    if initial_best is not None:
        best = xp.concatenate([xp.asarray(initial_best)[..., None], best], axis=-1)
        offset = 0
    else:
        offset = 1
    conv = xp.argmax(best >= final_best[..., None], axis=-1).astype(xp.int32) + offset
    return xp.where(final_best > 0, conv, -1).astype(xp.int32)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Front:
    """The first front of a run's final population (decision 045): every distinct
    non-dominated feasible path, in the population's slots (``mask`` says which)."""

    mask: jax.Array
    """bool[P]: the slot holds a point of the front."""
    cells: jax.Array
    """int32[P, L]: the paths (padded with their last cell)."""
    n_cells: jax.Array
    """int32[P]: their numbers of cells."""
    objectives: jax.Array
    """float32[P, M]: their minimised objectives in cells (``survival.objectives``, the
    clearance negated)."""
    initial_hypervolume: jax.Array
    """float32: the initial population's hypervolume (the history's ``hypervolume``
    holds each generation's, against the same reference point)."""
    reference: jax.Array
    """float32[M]: the reference point of the hypervolumes, in the objectives'
    minimised form (:func:`hypervolume_reference`)."""


def final_front(state: GAState) -> Front:
    """The :class:`Front` of ``state``'s population (one island)."""
    isl = jax.tree_util.tree_map(lambda a: a[0], state.islands)
    unique = distinct(isl.objectives, isl.feasible)
    rank = nondominated_rank(isl.objectives, unique)
    return Front(mask=unique & (rank == 0), cells=isl.cells, n_cells=isl.length,
                 objectives=isl.objectives, initial_hypervolume=state.initial_hypervolume,
                 reference=state.reference)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class RunOutputs:
    """What :func:`finish` reports of one run (arrays with a leading runs axis once
    mapped over runs). Also read as a mapping by field name (``out["fitness"]``,
    ``out.keys()``), as the pure core's users and the drivers read it."""

    success: jax.Array
    """bool: a feasible path was found."""
    raw_cells: jax.Array
    """int32[L]: the best path as evolved (padded with its last cell)."""
    raw_n_cells: jax.Array
    """int32: its number of cells."""
    cells: jax.Array
    """int32[L]: the best path post-optimised (``post.method``); with a front, the
    shortest of a few of its fittest paths post-optimised (decision 045)."""
    n_cells: jax.Array
    """int32: its number of cells."""
    fitness: jax.Array
    """float32: the best fitness (0 without a feasible path)."""
    raw_length: jax.Array
    """float32: the raw path's Euclidean length in cells."""
    length: jax.Array
    """float32: the post-optimised path's length in cells."""
    raw_metrics: dict
    """The raw path's :class:`jaxga.core.objectives.Metrics`, by name."""
    metrics: dict
    """The post-optimised path's metrics, by name."""
    generations_run: jax.Array
    """int32: generations computed (fewer when the stagnation rule stopped the run)."""
    failures: jax.Array
    """int32[3]: failed crossovers, mutations and simplifications."""
    feasible_post: jax.Array
    """bool: the post-optimised path is feasible and joins the endpoints."""
    convergence_generation: jax.Array | None = None
    """int32: :func:`convergence_generation`, None where the history stayed on the host."""
    front: Front | None = None
    """A front's non-dominated paths (``survival.method``), None for a scalar GA."""

    def __getitem__(self, key: str) -> Any:
        if key not in self.keys():
            raise KeyError(key)
        return getattr(self, key)

    def __contains__(self, key: object) -> bool:
        return key in self.keys()

    def keys(self) -> tuple[str, ...]:
        """The fields that hold a value."""
        return tuple(f.name for f in dataclasses.fields(self)
                     if getattr(self, f.name) is not None)

    def items(self) -> list[tuple[str, Any]]:
        """``(field, value)`` of every field that holds a value."""
        return [(k, getattr(self, k)) for k in self.keys()]


POST_POOL = 8
"""How many paths a front's shortest end is chosen from after post-optimisation: the
best path and the final population's fittest others (:func:`_shortest_after_post`)."""


def _shortest_after_post(grid: Grid, state: GAState, post: Callable) -> tuple:
    """``(cells, length)``: of the best path and the final population's
    :data:`POST_POOL` - 1 fittest feasible paths (ties by slot), each post-optimised, the
    shortest. A front's shortest end (decision 045): the path of least raw length need
    not shortcut to the shortest curve, so a few candidates are post-optimised instead of
    one. Never longer than the best path's own post-optimisation."""
    isl = jax.tree_util.tree_map(lambda a: a[0], state.islands)
    p = isl.fitness.shape[0]
    fit = jnp.where(isl.feasible, isl.fitness, -jnp.inf)
    pick = jnp.lexsort((jnp.arange(p), -fit))[:min(POST_POOL - 1, p)]
    cells = jnp.concatenate([state.best_cells[None], isl.cells[pick]])
    length = jnp.concatenate([state.best_length[None], isl.length[pick]])
    ok = jnp.concatenate([(state.best_fitness > 0)[None], isl.feasible[pick]])
    opt_c, opt_n = jax.vmap(lambda c, n: post(grid, c, n))(cells, length)
    opt_len = jax.vmap(lambda c, n: objectives.path_length(grid, c, n))(opt_c, opt_n)
    k = jnp.argmin(jnp.where(ok, opt_len, jnp.inf))
    return opt_c[k], opt_n[k]


def finish(algo: Algorithm, grid: Grid, state: GAState, history: dict | None, params: dict,
           initial_best: jax.Array | None = None) -> RunOutputs:
    """Post-optimise the best path and compute the reported metrics
    (:class:`RunOutputs`).

    ``convergence_generation``: :func:`convergence_generation` of ``history["best"]``
    (None when ``history`` is None: the compiled programs of :mod:`jaxga.api` compute it
    on the host, so that they serve every generation count).
    """
    raw_c, raw_n = state.best_cells, state.best_length
    success = state.best_fitness > 0
    post_op = algo.stages.post
    if post_op.fn is None:
        def post(g, c, n):
            return remove_loops(c, n, g.n_cells)
    else:
        post = post_op.bind(binding(algo, params))
    if state.islands.objectives is None:
        opt_c, opt_n = post(grid, raw_c, raw_n)
    else:
        opt_c, opt_n = _shortest_after_post(grid, state, post)
    # Raw and post-optimised paths measured as one batch of two: one copy of the metric
    # code in the compiled program instead of two.
    both_len, both_metrics = jax.vmap(
        lambda c, n: (objectives.path_length(grid, c, n), objectives.metrics(grid, c, n))
    )(jnp.stack([raw_c, opt_c]), jnp.stack([raw_n, opt_n]))
    return RunOutputs(
        success=success,
        raw_cells=raw_c, raw_n_cells=raw_n,
        cells=opt_c, n_cells=opt_n,
        fitness=state.best_fitness,
        raw_length=both_len[0],
        length=both_len[1],
        raw_metrics={k: v[0] for k, v in both_metrics._asdict().items()},
        metrics={k: v[1] for k, v in both_metrics._asdict().items()},
        generations_run=state.generation,
        failures=state.failures,
        feasible_post=is_feasible(grid, opt_c, opt_n) & has_endpoints(grid, opt_c, opt_n),
        convergence_generation=None if history is None else convergence_generation(
            history["best"], state.best_fitness, initial_best),
        front=None if state.islands.objectives is None else final_front(state),
    )
