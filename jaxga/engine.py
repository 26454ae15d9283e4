"""The evolution engine: one generation as a composition of stages, a run as a ``lax.scan``.

SPEC 8, 10. A generation is

    selection -> crossover -> mutation -> (simplification) -> evaluation

each stage a pure function chosen by the configuration (:mod:`jaxga.config`) from the
operator families (:mod:`jaxga.selection`, :mod:`jaxga.crossover`,
:mod:`jaxga.mutation`, :mod:`jaxga.postprocess`). A run is ``init`` followed by a
``lax.scan`` over generations with no host round-trip; IMGA's stagnation rule freezes a
run inside the scan. Many runs are a ``jax.vmap`` over PRNG keys and over the dynamic
parameters (probabilities, weights, temperatures) and the active population size.

Populations always carry an island axis: ``cells int32[I, P, L]``. A single-population
GA is ``I = 1``; the multi-population model (MPMGA) is the same generation ``vmap``-ed
over islands followed by a migration (:mod:`jaxga.islands`).

The population size is a static *capacity* ``P`` plus a dynamic ``active`` count:
individuals at positions ``>= active`` are computed but never selected, counted or
reported, so a sweep over population sizes is one compiled call.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from typing import Any

import jax
import jax.numpy as jnp

from jaxga import crossover as cx
from jaxga import mutation as mu
from jaxga import objectives, registry, schedules
from jaxga.batching import windowed_map
from jaxga.config import SCHEMA, Config
from jaxga.errors import ParameterError
from jaxga.grid import Grid
from jaxga.init import initialise_population
from jaxga.islands import migrates
from jaxga.numerics import ordered_mean
from jaxga.paths import (
    Population,
    cell_steps,
    has_endpoints,
    is_continuous,
    is_feasible,
    remove_loops,
)
from jaxga.registry import FIELD_REPAIR, NEVER_FAILS, WAYPOINTS, Binding

F32 = jnp.float32
I32 = jnp.int32

FITNESS_PARAMS: dict[str, tuple[str, ...]] = {
    op.name: tuple(key.split(".", 1)[1] for key, field in op.params.items() if field.dynamic)
    for op in registry.operators("fitness")
}
"""Each fitness combiner's weights: ``fitness.NAME`` keys that are keywords of its
objective in :mod:`jaxga.objectives` (from the registry; AGACD's Delphi ratios become its
``weights``)."""
FITNESS_DEFAULTS: dict[str, dict[str, float]] = {
    m: {k: registry.objective_default(m, k) for k in names}
    for m, names in FITNESS_PARAMS.items()
}
"""Each combiner's parameters and their defaults, read from :mod:`jaxga.objectives` (the
papers' values, SPEC 3), so that the two cannot drift apart: what a parameter the
configuration leaves out is."""


def chosen_operators(config: Config) -> dict[str, registry.Operator]:
    """The registered operators a configuration uses, by role: ``<family>.method`` for
    every family, and ``init.fallback`` when it names an initialiser. A configuration
    without a family's key (a fitness alone, :mod:`jaxga.fitness_reference`) uses
    none there."""
    out = {f"{family}.method": registry.operator(family, config.get(f"{family}.method"))
           for family in registry.FAMILIES if config.get(f"{family}.method") is not None}
    if config.get("init.fallback", "none") != "none":
        out["init.fallback"] = registry.operator("init", config["init.fallback"])
    return out


FIELD_REPAIR_ROLES = ("init.method", "crossover.method", "mutation.method")
"""The roles whose operator ``repair.fallback`` can change (not the fallback initialiser)."""


def _has_trait(chosen: dict[str, registry.Operator], trait: str,
               roles: Iterable[str] | None = None) -> bool:
    """Whether an operator of ``chosen`` (:func:`chosen_operators`), in one of ``roles``
    (all: None), declares ``trait``."""
    return any(trait in op.traits for role, op in chosen.items()
               if roles is None or role in roles)


def uses_waypoints(config: Config) -> bool:
    """Whether the population holds waypoint paths (an operator with the trait
    :data:`~jaxga.registry.WAYPOINTS`, AGACD's crossover or point mutation: segments
    checked by line of sight) rather than 8-connected cell paths."""
    return _has_trait(chosen_operators(config), WAYPOINTS)


PER_ISLAND: dict[str, str] = {
    "crossover.probability": "islands.crossover_probabilities",
    "mutation.probability": "islands.mutation_probabilities",
}
"""A rate and the key that, when set, gives each island its own (MPMGA A, B, C)."""


@dataclasses.dataclass(frozen=True)
class Algorithm:
    """The static part of a GA: which operators, which sizes (a hashable jit argument)."""

    config: Config
    population: int
    capacity: int
    generations: int
    islands: int
    waypoints: bool

    def get(self, key: str, default: Any = None) -> Any:
        return self.config.get(key, default)


CAPACITY_FACTOR = 3
"""The automatic path capacity holds this many times the optimal path's cells."""

SMALL_MAP_CAPACITY = 160
"""The automatic capacity is at least ``min(4 * (H + W), 160)`` cells: the ``4 * (H + W)``
the papers' 20 x 20 maps have always had (so that their reproductions are unchanged;
their random walks and connections need the room), for maps up to that size."""


def capacity_class(cells: int) -> int:
    """The smallest size class ``2**k * (1, 1.25, 1.5 or 1.75)`` (at least 8) holding
    ``cells``: problems of similar size share compiled programs."""
    cells = max(int(cells), 8)
    k = max(cells.bit_length() - 3, 0)
    step = 1 << k  # a quarter of the power of two below cells
    return -(-cells // step) * step


def default_capacity(grid: Grid) -> int:
    """Path capacity used when the configuration says 0 (``population.capacity``).

    ``CAPACITY_FACTOR`` (3) times the cells of an optimal path, bounded by the free cells
    the start can reach (no loop-free path holds more), rounded up to a size class
    (:func:`capacity_class`), and at least ``min(4 * (H + W), 160)``
    (:data:`SMALL_MAP_CAPACITY`). The 400-cell optimum of a 65 x 65 maze gets 1280 cells,
    a 30-cell optimum on a 256 x 256 map 160. A path that would not fit is a counted
    failure of the operator that made it (never truncated). Computed on the host from
    the exact distance fields (:func:`jaxga.guide.problem_facts`); an unreachable goal
    gets the minimum (decision 020).
    """
    from jaxga.guide import problem_facts

    floor = min(4 * (grid.height + grid.width), SMALL_MAP_CAPACITY)
    facts = problem_facts(grid)
    if not facts.reachable:
        return floor
    need = min(CAPACITY_FACTOR * facts.optimal_cells, facts.reachable_cells)
    return max(floor, capacity_class(need))


def build(config: Config, grid: Grid) -> tuple[Algorithm, dict]:
    """The static :class:`Algorithm` and the dynamic parameter pytree of a configuration.

    The population capacity is ``population.size`` (a sweep over sizes builds with its
    largest size; the ``active`` parameter then says how many are used).
    """
    cap_p = int(config["population.size"])
    capacity = int(config["population.capacity"]) or default_capacity(grid)
    islands = int(config["islands.count"])
    check_migration(config, cap_p)
    algo = Algorithm(
        config=static_config(config),
        population=cap_p,
        capacity=capacity,
        generations=int(config["generations"]),
        islands=islands,
        waypoints=uses_waypoints(config),
    )
    return algo, default_params(config, islands)


NON_STRUCTURAL = ("name", "paper", "description", "population.size")
"""Keys that never enter the compiled program (metadata; the size is ``active``)."""


def static_config(config: Config) -> Config:
    """The part of a configuration that is compiled in: operators, sizes, flags.

    Dynamic values (probabilities, weights, temperatures) and metadata are left out, so
    two configurations that differ only in them share one compiled program.
    """
    return Config(tuple((k, v) for k, v in config.items
                        if not SCHEMA[k].dynamic and k not in NON_STRUCTURAL))


NEEDS: tuple[tuple[str, Any, tuple[str, ...]], ...] = (
    ("crossover.adaptive", True, ("crossover.pc_low", "crossover.pc_high")),
    ("mutation.adaptive", True, ("mutation.pm_low", "mutation.pm_high")),
)
"""``(key, value, keys needed)``: configuration keys read when ``key`` has ``value``
(AGACD eq. 26-29's adaptive rates). An operator's own needed keys are its
``required`` keys in the registry (MPMGA eq. 17's temperature schedule)."""



def unread_keys(config: Config) -> dict[str, str]:
    """The configuration keys that no stage of this configuration reads, with the reason.

    Setting one of them changes nothing (a fitness weight of another objective, a fixed
    rate under AGACD's adaptive rates eq. 26-29, MPMGA's temperature without its
    simulated-annealing mutation, migration settings of a single island, ...), so
    :func:`jaxga.run` refuses them as overrides instead of ignoring them silently. An
    operator's own keys (:func:`jaxga.registry.schema_fields`) are read exactly when an
    operator the configuration uses declares them (:func:`chosen_operators`); the
    families' shared keys follow what :func:`build`, the stages and
    :func:`jaxga.islands.migrate` read.
    """
    out: dict[str, str] = {}
    chosen = chosen_operators(config)
    read = {key for op in chosen.values() for key in op.params}
    for key in registry.schema_fields():
        if key in read:
            continue
        family, name = key.split(".", 1)
        who = registry.readers(key)
        where = " as init.method or init.fallback" if family == "init" else ""
        out[key] = (f"{family}.method = {config[f'{family}.method']!r} has no parameter "
                    f"{name!r} (read by {', '.join(map(repr, who))} only{where})")
    if _has_trait(chosen, WAYPOINTS):
        out["fitness.window"] = "waypoint paths are evaluated without the narrow window"
    if NEVER_FAILS in chosen["init.method"].traits:
        out["init.fallback"] = (f"init.method = {config['init.method']!r} cannot fail where "
                                "a path exists")
    if not _has_trait(chosen, FIELD_REPAIR, FIELD_REPAIR_ROLES):
        out["repair.fallback"] = ("no operator of this configuration repairs by median "
                                  "insertion or a regrowth walk")
    for stage, low, high in (("crossover", "pc_low", "pc_high"),
                             ("mutation", "pm_low", "pm_high")):
        island_key = PER_ISLAND[f"{stage}.probability"]
        if config[f"{stage}.method"] == "none":
            for k in (f"{stage}.probability", f"{stage}.adaptive", f"{stage}.{low}",
                      f"{stage}.{high}", island_key):
                out[k] = f"{stage}.method = 'none'"
        elif config[f"{stage}.adaptive"]:
            for k in (f"{stage}.probability", island_key):
                out[k] = (f"{stage}.adaptive = true: the rate is {stage}.{low} .. "
                          f"{stage}.{high} (AGACD eq. 26-29)")
        else:
            for k in (low, high):
                out[f"{stage}.{k}"] = f"{stage}.adaptive = false"
            if config.get(island_key) is not None:
                out[f"{stage}.probability"] = f"{island_key} sets each island's rate"
    if config["simplify.method"] == "none":
        out["simplify.probability"] = "simplify.method = 'none'"
    if int(config["islands.count"]) == 1:
        for k in ("islands.topology", "islands.interval", "islands.migrants"):
            out[k] = "islands.count = 1: there is no migration"
    elif not migrates(config):
        why = ("islands.topology = 'none'" if config["islands.topology"] == "none"
               else "islands.migrants = 0")
        for k in ("islands.topology", "islands.interval", "islands.migrants"):
            if k not in why:
                out[k] = f"{why}: there is no migration"
    return out


OFF_VALUES: dict[str, Any] = {
    "init.fallback": "none",
    "repair.fallback": "none",
    "islands.topology": "none", "islands.migrants": 0, "islands.interval": 1,
    "simplify.probability": 0.0, "crossover.adaptive": False, "mutation.adaptive": False,
    "fitness.window": False,
}
"""Values of unread keys that say what happens anyway (no migration, no simplification,
fixed rates, no narrow window): accepted as overrides, as in notebook 04's one-island
MPMGA with ``islands.topology = "none"``."""


def check_overrides_read(config: Config, keys: Iterable[str]) -> None:
    """Refuse overridden ``keys`` that ``config`` never reads (:func:`unread_keys`),
    unless set to the value that says what happens anyway (:data:`OFF_VALUES`)."""
    unread = unread_keys(config)
    bad = [k for k in keys
           if k in unread and (k not in OFF_VALUES or config.get(k) != OFF_VALUES[k])]
    if bad:
        name = config.get("name", "the configuration")
        raise ParameterError("; ".join(
            f"{k} has no effect in {name!r}: {unread[k]}" for k in bad))


def check_combination(config: Config) -> None:
    """Checks that involve several configuration keys, before anything is traced.

    Raises :class:`ParameterError` naming the keys: keys an operator needs and the
    configuration does not set (:data:`NEEDS`, the operators' ``required`` keys; a fixed
    crossover or mutation rate, or one per island), a post-optimisation of cell paths on
    waypoint paths, and what each chosen operator's own ``check`` refuses
    (:mod:`jaxga.registry`: MPMGA's decay rate ``w = 0``, eq. 17; Zhang's speeds not
    positive or a turning speed above the straight one, eq. 2; IMGA's, MPMGA's or Zhu's
    fitness weights all 0; a smoothness floor not positive; a Delphi ratio list whose
    length does not match AGACD's three objectives, eq. 21-25). Migrants are checked
    against the island size by :func:`check_migration`.
    """
    chosen = chosen_operators(config)
    needs = [*NEEDS, *((role, op.name, op.required)
                       for role, op in chosen.items() if op.required)]
    for key, value, needed in needs:
        if config.get(key) == value:
            missing = [k for k in needed if config.get(k) is None]
            if missing:
                raise ParameterError(
                    f"{key} = {value!r} needs {' and '.join(missing)}, which this "
                    f"configuration does not set (--set KEY=VALUE)")
    for stage in ("crossover", "mutation"):  # a fixed rate, or one per island
        rate, island_key = f"{stage}.probability", PER_ISLAND[f"{stage}.probability"]
        method = config.get(f"{stage}.method", "none")  # fitness_optimum: fitness only
        if method != "none" and not config.get(f"{stage}.adaptive") \
                and config.get(rate) is None and config.get(island_key) is None:
            raise ParameterError(
                f"{stage}.method = {method!r} with {stage}.adaptive = "
                f"false needs {rate} (or {island_key}), which this configuration does not "
                "set (--set KEY=VALUE)")
    post_op = chosen.get("post.method")
    if post_op is not None and registry.CONTINUOUS_ONLY in post_op.traits \
            and _has_trait(chosen, WAYPOINTS):
        raise ParameterError(
            f"post.method = {post_op.name!r} needs continuous paths (8-connected cells); "
            "this configuration evolves waypoint paths (AGACD's cut_and_check crossover or "
            "point_checked mutation): use post.method = 'shortcut_greedy'")
    for op in chosen.values():
        if op.check is not None:
            op.check(config)


def check_migration(config: Config, population: int) -> None:
    """Migrants must fit the islands of ``population`` individuals (the capacity: a sweep
    over sizes is checked at its largest). Each island receives ``k`` migrants per source
    (ring, full: ``k``; star: the centre ``(I - 1) k``; MPMGA's A-B-C scheme: ``2 k`` into
    A, and B and C swap ``k`` others than the ``k`` that moved), SPEC 8 / MPMGA 4.4."""
    count, topology = int(config["islands.count"]), config["islands.topology"]
    k = int(config["islands.migrants"])
    if not migrates(config):
        return
    if topology == "mpmga" and count != 3:
        raise ParameterError(f"islands.topology = 'mpmga' needs islands.count = 3 (A, B, C), "
                             f"got {count}")
    need = {"star": (count - 1) * k, "mpmga": 2 * k}.get(topology, k)
    if need > population:
        raise ParameterError(
            f"islands.migrants = {k} needs {need} individuals per island under the "
            f"{topology!r} topology; an island has {population} (population.size)")


def default_params(config: Config, islands: int = 1) -> dict[str, jax.Array]:
    """Dynamic parameters (float32 scalars, or ``[islands]`` arrays for per-island rates).

    Checks the configuration's combinations first (:func:`check_combination`)."""
    check_combination(config)
    params: dict[str, jax.Array] = {
        k: jnp.asarray(v, F32) for k, v in config.dynamic().items()
    }
    params["population.active"] = jnp.asarray(config["population.size"], I32)
    for op in chosen_operators(config).values():
        if op.prepare is not None:
            params.update(op.prepare(config))
    for key, island_key in PER_ISLAND.items():
        per_island = config.get(island_key)
        if per_island is not None:
            if len(per_island) != islands:
                raise ParameterError(
                    f"{island_key} has {len(per_island)} entries for {islands} islands "
                    f"(islands.count): give one rate per island")
            params[key] = jnp.asarray(per_island, F32)
    return params


# ----------------------------------------------------------------------------- stages
def fitness_function(algo: Algorithm, params: dict) -> Callable:
    """``f(grid, cells, length, feasible) -> f32`` with the configured combiner and weights."""
    op = registry.operator("fitness", algo.get("fitness.method"))
    return op.bind(Binding(algo, params))


def feasibility(algo: Algorithm, grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Whether a path is a valid answer: from start to goal, continuous (or, for waypoint
    algorithms, every segment clear)."""
    ok = has_endpoints(grid, cells, length)
    if algo.waypoints:
        return ok & is_feasible(grid, cells, length)
    return ok & is_continuous(grid, cells, length)


SHORT_SPAN = 4
"""Segments with ``|dx|, |dy| <= SHORT_SPAN`` get the cheap bounded line-of-sight test."""


def waypoints_feasible(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """``bool[P]``: :func:`jaxga.paths.is_feasible` of a population of waypoint paths.

    Same answer, less work. A segment of span at most 1 (a grid step, or a repeated node)
    is clear exactly when its cells are free and, for a diagonal step, its side cells
    satisfy the corner rule (:func:`jaxga.geometry.clear` on 8-adjacent pairs is
    :func:`jaxga.grid.move_legal`): one lookup per cell, computed for every slot. Only
    the longer segments get a line-of-sight test, gathered across the population by
    :func:`jaxga.batching.gated_map`: the bounded exact test
    (``clear(..., max_span=SHORT_SPAN)``) for spans up to :data:`SHORT_SPAN`, the full
    exact test beyond (crossover junctions, simplified corners). After 30 generations
    of AGACD on a 20 x 20 map, 86 % of the valid segments are single steps and 87 % of
    the ``P x (L - 1)`` slots are padding; testing every slot with the bounded test was
    two thirds of an AGACD generation.
    """
    from jaxga.batching import gated_map
    from jaxga.geometry import clear

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
    :func:`jaxga.batching.windowed_map`: on the first ``window_width(L)`` cells (64 of
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
    """What the stages bind operators with (:class:`jaxga.registry.Binding`): the static
    algorithm, the dynamic parameters, generation ``t``, the fitness function and
    whether ``repair.fallback = "field"``."""
    return Binding(algo, params, generation=t, generations=algo.generations,
                   fitness_fn=fit_fn, field_repair=_field_repair(algo))


def _select(algo: Algorithm, key, fitness, active) -> jax.Array:
    op = registry.operator("selection", algo.get("selection.method"))
    if op.fn is None:
        return jnp.arange(fitness.shape[0], dtype=I32)
    return op.bind(Binding(algo, {}))(key, fitness, active)


def _crossover(algo: Algorithm, key, grid, pop, fitness, active, t, params, fit_fn):
    op = registry.operator("crossover", algo.get("crossover.method"))
    if op.fn is None and op.population is None:
        return pop, jnp.int32(0)
    if algo.get("crossover.adaptive"):
        # AGACD eq. 26-27: f = the fitter of the pair; f_max, f_avg of the population
        # (taken over the selected pool, which is the population entering crossover).
        pc = cx.adaptive_pair_probability(
            fitness, t, algo.generations, params["crossover.pc_low"],
            params["crossover.pc_high"], active,
            schedule=schedules.agacd_crossover_decay(algo.generations),
        )
    else:
        pc = params["crossover.probability"]
    return op.lift(binding(algo, params, t, fit_fn))(key, grid, pop, pc)


def _mutation(algo: Algorithm, key, grid, pop, fitness, active, t, params, fit_fn):
    op = registry.operator("mutation", algo.get("mutation.method"))
    if op.fn is None and op.population is None:
        return pop, jnp.int32(0)
    if algo.get("mutation.adaptive"):
        f_max = jnp.max(jnp.where(active, fitness, -jnp.inf))
        f_avg = ordered_mean(fitness, active)
        pm = mu.adaptive_mutation_probability(
            fitness, f_max, f_avg, t, algo.generations, params["mutation.pm_low"],
            params["mutation.pm_high"],
            schedule=schedules.agacd_mutation_growth(algo.generations),
        )
    else:
        pm = jnp.broadcast_to(params["mutation.probability"], (pop.size,))
    return op.lift(binding(algo, params, t, fit_fn))(key, grid, pop, pm)


def _simplify(algo: Algorithm, key, grid, pop, params):
    op = registry.operator("simplify", algo.get("simplify.method"))
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


def _active(algo: Algorithm, params: dict) -> jax.Array:
    return jnp.arange(algo.population, dtype=I32) < params["population.active"]


def _best_of(state_islands: IslandState) -> tuple:
    f = state_islands.fitness.reshape(-1)
    k = jnp.argmax(f)
    cells = state_islands.cells.reshape(-1, state_islands.cells.shape[-1])[k]
    return cells, state_islands.length.reshape(-1)[k], f[k]


def uses_guide(config: Config) -> bool:
    """Whether a run of ``config`` steers by the problem's exact distance fields (its grid
    needs :func:`jaxga.guide.with_guide`): an operator with the trait
    :data:`~jaxga.registry.NEEDS_GUIDE` (the field initialiser, as ``init.method`` or as
    the fallback of another initialiser), and the field repairs (``repair.fallback``)."""
    return _has_trait(chosen_operators(config), registry.NEEDS_GUIDE) or (
        config["repair.fallback"] != "none" and field_repairs(config))



def field_repairs(config: Config) -> bool:
    """Whether ``repair.fallback = "field"`` changes an operator of ``config`` (one with
    the trait :data:`~jaxga.registry.FIELD_REPAIR`: its ``field_repair`` option;
    decision 019)."""
    return _has_trait(chosen_operators(config), FIELD_REPAIR, FIELD_REPAIR_ROLES)


def _field_repair(algo: Algorithm) -> bool:
    return algo.get("repair.fallback") == "field"


def init_state(algo: Algorithm, key: jax.Array, grid: Grid, params: dict) -> tuple:
    """Initial population of every island (SPEC 4) and its evaluation.

    ``init.method`` draws the population within ``init.max_tries`` attempts per
    individual; ``init.fallback = "field_walk"`` then fills exactly the slots it left
    empty with :func:`jaxga.init.field_walk` (``init.slack``, ``init.temperature``), so a
    run starts with a whole population wherever a path exists (decision 018). Returns
    ``(GAState, InitStats)`` (one entry per island).
    """
    ctx = binding(algo, params)
    method = registry.operator("init", algo.get("init.method"))
    init_fn = method.bind(ctx)
    fallback = None
    if algo.get("init.fallback") != "none" and NEVER_FAILS not in method.traits:
        fallback = registry.operator("init", algo.get("init.fallback")).bind(ctx)
    keys = jax.random.split(key, algo.islands)
    active = _active(algo, params)

    def one(k):
        pop, stats = initialise_population(
            k, grid, init_fn, algo.population, algo.capacity,
            max_tries=int(algo.get("init.max_tries")), fallback=fallback,
        )
        # Once per run: at full width (the window pays off in the generations' loop).
        fitness, feas = evaluate(algo, grid, params, pop.cells, pop.length, active,
                                 window=False)
        return IslandState(pop.cells, pop.length, fitness, feas), stats

    islands, stats = jax.vmap(one)(keys)
    best_c, best_n, best_f = _best_of(islands)
    state = GAState(
        islands=islands, best_cells=best_c, best_length=best_n, best_fitness=best_f,
        generation=jnp.int32(0), stall=jnp.int32(0), frozen=jnp.bool_(False),
        failures=jnp.zeros(3, I32),
    )
    return state, stats


def island_generation(algo: Algorithm, key, grid: Grid, isl: IslandState, t, params: dict):
    """One generation of one island: selection -> crossover -> mutation -> simplify -> eval."""
    active = _active(algo, params)
    fit_fn = fitness_function(algo, params)
    k_sel, k_cx, k_mu, k_si = jax.random.split(key, 4)
    idx = _select(algo, k_sel, isl.fitness, active)
    pop = Population(isl.cells[idx], isl.length[idx])
    fitness = isl.fitness[idx]
    pop, f_cx = _crossover(algo, k_cx, grid, pop, fitness, active, t, params, fit_fn)

    def vary(pop, fitness):
        pop, f_mu = _mutation(algo, k_mu, grid, pop, fitness, active, t, params, fit_fn)
        pop, f_si = _simplify(algo, k_si, grid, pop, params)
        return pop, jnp.stack([f_mu, f_si]).astype(I32)

    if not algo.get("mutation.adaptive"):  # the mutation does not read the fitness
        pop, fails = vary(pop, fitness)
        new_fitness, feas = evaluate(algo, grid, params, pop.cells, pop.length, active)
    else:
        # AGACD eq. 28-29: an individual's mutation probability depends on its fitness
        # after crossover, so the generation evaluates twice. The two evaluations are the
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
    return IslandState(pop.cells, pop.length, new_fitness, feas), jnp.concatenate(
        [jnp.reshape(f_cx, (1,)).astype(I32), fails])


def _island_params(params: dict, islands: int) -> tuple[dict, dict]:
    """Split params into per-island ones (leading axis I) and shared ones."""
    per = {k: v for k, v in params.items() if jnp.ndim(v) == 1 and v.shape[0] == islands
           and k.endswith("probability")}
    shared = {k: v for k, v in params.items() if k not in per}
    return per, shared


def generation(algo: Algorithm, key, grid: Grid, state: GAState, params: dict):
    """One generation of a run (every island, then migration); honours the freeze."""
    from jaxga.islands import migrate

    t = state.generation
    per, shared = _island_params(params, algo.islands)
    keys = jax.random.split(key, algo.islands + 1)

    def one(k, isl, p_isl):
        return island_generation(algo, k, grid, isl, t, {**shared, **p_isl})

    islands, fails = jax.vmap(one)(keys[:-1], state.islands, per)
    islands = migrate(algo, keys[-1], islands, t, _active(algo, params))
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
    )
    k_stop = int(algo.get("termination.stagnation"))
    if k_stop > 0:
        new = dataclasses.replace(new, frozen=new.stall >= k_stop)
    return jax.tree_util.tree_map(lambda old, nw: jnp.where(state.frozen, old, nw), state, new)


def history_row(algo: Algorithm, state: GAState, params: dict) -> dict:
    """Best-so-far, mean and sd of the active fitness (MPMGA Figs. 15-17)."""
    active = jnp.broadcast_to(_active(algo, params), state.islands.fitness.shape)
    f = state.islands.fitness
    # ordered (batch-invariant) sums: a seed's history does not depend on the runs
    # computed alongside it (jaxga.numerics)
    active, f = active.reshape(-1), f.reshape(-1)
    mean = ordered_mean(f, active)
    var = ordered_mean((f - mean) ** 2, active)
    return {"best": state.best_fitness, "mean": mean, "std": jnp.sqrt(var)}


def evolve(algo: Algorithm, key, grid: Grid, state: GAState, params: dict,
           generations: int | None = None):
    """``lax.scan`` over generations; returns ``(final state, history)``.

    Generation ``t`` uses the key ``fold_in(key, t)``, so running ``G`` generations in one
    call or in chunks (for a progress bar) gives the same result. The history holds, per
    generation, the best-so-far fitness and the mean and sd of the active fitness.
    """
    n = algo.generations if generations is None else generations
    ts = state.generation + jnp.arange(n, dtype=I32)

    def body(st, t):
        st = generation(algo, jax.random.fold_in(key, t), grid, st, params)
        return st, history_row(algo, st, params)

    return jax.lax.scan(body, state, ts)


def finish(algo: Algorithm, grid: Grid, state: GAState, history: dict, params: dict,
           initial_best: jax.Array | None = None) -> dict:
    """Post-optimise the best path and compute the reported metrics (SPEC 3, 9, 10).

    ``convergence_generation`` is the first generation whose best-so-far fitness equals
    the final best (AGACD Tables 8, 12): 0 when the initial population already held it
    (pass ``initial_best``), -1 when no feasible path was found.
    """
    raw_c, raw_n = state.best_cells, state.best_length
    success = state.best_fitness > 0
    post_op = registry.operator("post", algo.get("post.method"))
    if post_op.fn is None:
        opt_c, opt_n = remove_loops(raw_c, raw_n, grid.n_cells)
    else:
        opt_c, opt_n = post_op.bind(binding(algo, params))(grid, raw_c, raw_n)
    best = history["best"]
    if initial_best is not None:
        best = jnp.concatenate([jnp.reshape(initial_best, (1,)), best])
        offset = 0
    else:
        offset = 1
    reached = best >= state.best_fitness
    conv = jnp.argmax(reached).astype(I32) + offset
    # Raw and post-optimised paths measured as one batch of two: one copy of the metric
    # code in the compiled program instead of two.
    both_len, both_metrics = jax.vmap(
        lambda c, n: (objectives.path_length(grid, c, n), objectives.metrics(grid, c, n))
    )(jnp.stack([raw_c, opt_c]), jnp.stack([raw_n, opt_n]))
    return {
        "success": success,
        "raw_cells": raw_c, "raw_length": raw_n,
        "cells": opt_c, "length": opt_n,
        "fitness": state.best_fitness,
        "raw_path_length": both_len[0],
        "path_length": both_len[1],
        "raw_metrics": {k: v[0] for k, v in both_metrics._asdict().items()},
        "metrics": {k: v[1] for k, v in both_metrics._asdict().items()},
        "convergence_generation": jnp.where(success, conv, -1),
        "generations_run": state.generation,
        "failures": state.failures,
        "feasible_post": is_feasible(grid, opt_c, opt_n) & has_endpoints(grid, opt_c, opt_n),
    }
