"""The static algorithm and the dynamic parameters of a configuration.

:class:`Algorithm` is what is compiled in (operators, sizes, flags: a hashable ``jit``
argument); the dynamic parameters (probabilities, weights, temperatures, the integer
settings that bound no array, the per-island rates, AGACD's Delphi ratios, the fallback
flag, the active population size) are a pytree, so configurations that differ only in
them share one program. The path capacity is chosen here when the configuration leaves
it at 0.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import jax
import jax.numpy as jnp

from jaxga.config.schema import SCHEMA, Config
from jaxga.core.dtypes import F32, I32, on_device
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.engine.checks import (
    PER_ISLAND,
    check_combination,
    check_migration,
    chosen_operators,
    compiled_fallback,
    uses_waypoints,
)
from jaxga.maps.preprocess import endpoints_connected
from jaxga.operators import registry
from jaxga.operators.fitness import objective_default, objective_keywords
from jaxga.operators.guide import longest_optimal_path_cells, problem_facts
from jaxga.operators.rates import RateRule, rate_rule
from jaxga.operators.registry import NEVER_FAILS, Operator

FITNESS_PARAMS: dict[str, tuple[str, ...]] = {
    op.name: tuple(key.split(".", 1)[1] for key in objective_keywords(op))
    for op in registry.operators("fitness")
}
"""Each fitness combiner's weights: ``fitness.NAME`` keys that are keywords of its
objective in :mod:`jaxga.core.objectives` (from the registry; AGACD's Delphi ratios are
not: the objective takes the weights computed from them, eq. 21-25)."""


FITNESS_DEFAULTS: dict[str, dict[str, float]] = {
    m: {k: objective_default(m, k) for k in names}
    for m, names in FITNESS_PARAMS.items()
}
"""Each combiner's parameters and their defaults, read from :mod:`jaxga.core.objectives` (the
papers' values where they give one; docs/presets.md), so that the two cannot drift apart:
what a parameter the configuration leaves out is."""


@dataclasses.dataclass(frozen=True)
class Stages:
    """The operators and rate rules a configuration chose, resolved from the registry once,
    when its :class:`Algorithm` is made: the values the engine's stages call, in the
    order of a generation (as ``optax.chain`` composes its transformations), instead of
    looking an operator up by name wherever a stage is traced.

    A family the configuration leaves out (a program's view of it holds only the keys
    that program reads: :func:`jaxga._runtime.programs.program_view`) is None, so a stage
    that would call it fails while tracing rather than reading a key it was not keyed
    on."""

    init: Operator | None = None
    """``init.method``."""
    fallback: Operator | None = None
    """The initialiser compiled in as ``init.fallback`` (None where ``init.method``
    cannot fail or none is compiled: :func:`jaxga.engine.checks.compiled_fallback`)."""
    fitness: Operator | None = None
    """``fitness.method``: the objective."""
    selection: Operator | None = None
    crossover: Operator | None = None
    mutation: Operator | None = None
    simplify: Operator | None = None
    """The per-generation simplification (``simplify.method``)."""
    post: Operator | None = None
    """The post-optimisation of the best path (``post.method``)."""
    crossover_rate: RateRule | None = None
    """The crossover probability's rule (fixed, or AGACD eq. 26-27)."""
    mutation_rate: RateRule | None = None
    """The mutation probability's rule (fixed, or AGACD eq. 28-29)."""
    field_repair: bool = False
    """``repair.fallback = "field"``: the repairs fall back to a field walk."""
    survival: str | None = None
    """``survival.method``: ``"nsga2"`` keeps a front of the objectives
    ``survival.objectives`` (decision 045); None (the key left out) is the papers' scalar
    GA, whose offspring replace their parents."""
    objectives: tuple[str, ...] = ()
    """The robot objectives a front minimises (``survival.objectives``), () without one."""


def resolve_stages(config: Config) -> Stages:
    """The :class:`Stages` of ``config`` (a configuration or a program's view of one),
    looked up in the registry (:mod:`jaxga.operators.registry`) by their names."""

    def chosen(family: str) -> Operator | None:
        name = config.get(f"{family}.method")
        return None if name is None else registry.operator(family, name)

    ops = {family: chosen(family) for family in registry.FAMILIES}
    init, compiled = ops["init"], config.get("init.fallback", "none")
    fallback = None
    if init is not None and compiled != "none" and NEVER_FAILS not in init.traits:
        fallback = registry.operator("init", compiled)
    rates = {f"{stage}_rate": rate_rule(config, stage) if ops[stage] is not None else None
             for stage in ("crossover", "mutation")}
    survival = config.get("survival.method")
    return Stages(**ops, fallback=fallback, **rates,
                  field_repair=config.get("repair.fallback") == "field",
                  survival=survival,
                  objectives=front_objectives(config) if survival is not None else ())


FRONT_OBJECTIVES = ("length", "clearance")
"""The objectives of a front when ``survival.objectives`` is left out."""


def front_objectives(config: Config) -> tuple[str, ...]:
    """The robot objectives (:data:`jaxga.core.robot_objectives.ROBOT_OBJECTIVES`) a
    configuration's front minimises: ``survival.objectives``, by default
    :data:`FRONT_OBJECTIVES`."""
    return tuple(config.get("survival.objectives", FRONT_OBJECTIVES))


@dataclasses.dataclass(frozen=True)
class Algorithm:
    """The static part of a GA: which operators, which sizes (a hashable jit argument).

    ``stages`` are its operators resolved once (:func:`resolve_stages`; left out of its
    equality and hash, which its configuration decides: the caches of compiled programs
    add the operators' functions to their keys)."""

    config: Config
    population: int
    capacity: int
    generations: int
    islands: int
    waypoints: bool
    stages: Stages | None = dataclasses.field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.stages is None:
            object.__setattr__(self, "stages", resolve_stages(self.config))

    def get(self, key: str, default: Any = None) -> Any:
        return self.config.get(key, default)


CAPACITY_FACTOR = 3.0
"""The automatic path capacity holds this many times the optimal path's cells (the default
of ``population.capacity_factor``)."""


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


def default_capacity(grid: Grid, factor: float = CAPACITY_FACTOR) -> int:
    """Path capacity used when the configuration says 0 (``population.capacity``).

    ``factor`` (``population.capacity_factor``, :data:`CAPACITY_FACTOR` = 3) times the
    cells of an optimal path, bounded by the free cells
    the start can reach (no loop-free path holds more), rounded up to a size class
    (:func:`capacity_class`), and at least ``min(4 * (H + W), 160)``
    (:data:`SMALL_MAP_CAPACITY`). The 400-cell optimum of a 65 x 65 maze gets 1280 cells,
    a 30-cell optimum on a 256 x 256 map 160. A path that would not fit is a counted
    failure of the operator that made it (never truncated). Computed on the host from
    the exact distance fields (:func:`jaxga.operators.guide.problem_facts`); an unreachable goal
    gets the minimum (decision 020).
    """

    floor = min(4 * (grid.height + grid.width), SMALL_MAP_CAPACITY)
    if not endpoints_connected(grid):  # known from the regions, without the fields
        return floor
    facts = problem_facts(grid)  # reachable: the regions said so
    need = min(math.ceil(factor * facts.optimal_cells), facts.reachable_cells)
    return max(floor, capacity_class(need))


def map_capacity(grid: Grid, factor: float = CAPACITY_FACTOR) -> int:
    """The path capacity that every start and goal on ``grid``'s map fits: as
    :func:`default_capacity`, with the longest optimal path the map can have
    (:func:`jaxga.operators.guide.longest_optimal_path_cells`) in place of this problem's.
    A planner that sizes its programs by it plans any pair of its map without compiling
    again, and holds no more than the map needs."""
    floor = min(4 * (grid.height + grid.width), SMALL_MAP_CAPACITY)
    return max(floor, capacity_class(math.ceil(factor * longest_optimal_path_cells(grid))))


def build(config: Config, grid: Grid) -> tuple[Algorithm, dict]:
    """The static :class:`Algorithm` and the dynamic parameter pytree of a configuration.

    The population capacity is ``population.size`` (a sweep over sizes builds with its
    largest size; the ``active`` parameter then says how many are used).
    """
    cap_p = int(config["population.size"])
    capacity = int(config["population.capacity"]) or default_capacity(
        grid, float(config["population.capacity_factor"]))
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


NON_STRUCTURAL = ("name", "paper", "description", "population.size",
                  "population.capacity_factor")
"""Keys that never enter the compiled program (metadata; the size is ``active``)."""


def static_config(config: Config) -> Config:
    """The part of a configuration that is compiled in: operators, sizes, flags.

    Dynamic values (probabilities, weights, temperatures, the integer settings and lists
    of :data:`jaxga.config.schema.SCHEMA` marked dynamic) and metadata are left out, so
    two configurations that differ only in them share one compiled program. One dynamic
    key leaves a static part: ``init.fallback`` is kept as the initialiser compiled in
    (:func:`jaxga.engine.checks.compiled_fallback`: the same whether the fallback is on
    or ``"none"``, which a traced flag says).
    """
    items = [(k, v) for k, v in config.items
             if not SCHEMA[k].dynamic and k not in NON_STRUCTURAL]
    if config.get("init.method") is not None:
        items.append(("init.fallback", compiled_fallback(config)))
    return Config(tuple(sorted(items)))


def param_value(key: str, value: Any) -> jax.Array:
    """The traced value of dynamic key ``key``: ``float32`` for a number, ``int32`` for an
    integer (``init.max_tries``, ``termination.stagnation``, ``islands.interval``), a
    ``float32`` array for a list (its shape fixed by static keys: ``islands.count``,
    AGACD's objectives), and for ``init.fallback`` a bool flag, True unless ``"none"``."""
    if key == "init.fallback":
        return on_device(value != "none")
    kinds = SCHEMA[key].kind if isinstance(SCHEMA[key].kind, tuple) else (SCHEMA[key].kind,)
    if int in kinds and float not in kinds:
        return on_device(value, I32)
    return on_device(value, F32)


def default_params(config: Config, islands: int = 1) -> dict[str, jax.Array]:
    """Dynamic parameters: one traced value per dynamic key (:func:`param_value`), the
    active population size, the generation count and what the chosen operators derive
    (their ``prepare``: AGACD's Delphi ratios); a per-island rate
    (``islands.crossover_probabilities``, ``islands.mutation_probabilities``) travels as
    its rate's ``[islands]`` array (``crossover.probability``, ``mutation.probability``).

    Checks the configuration's combinations first (:func:`check_combination`); a
    per-island list whose length is not ``islands`` is refused."""
    check_combination(config)
    island_keys = set(PER_ISLAND.values())
    params: dict[str, jax.Array] = {
        k: param_value(k, v) for k, v in config.dynamic().items() if k not in island_keys
    }
    params["population.active"] = jnp.asarray(config["population.size"], I32)
    # dynamic, so that one compiled program serves every generation count (AGACD's
    # schedules read it; the API runs the generations in fixed compiled chunks)
    params["generations"] = jnp.asarray(config["generations"], I32)
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
