"""Initialisers: one start-to-goal path per PRNG key, and a population with bounded redraws.

Every initialiser builds ONE individual from ``(key, grid, capacity)`` and returns
``(cells int32[capacity], length int32, ok bool)`` in jaxga's representation (padding
repeats the last cell; docs, "the pure core"). When ``ok`` is True the path starts at
``grid.start``, ends at ``grid.goal``, is continuous under ``grid.corner_rule``, loop-free
and fits the capacity; when ``ok`` is False the cells are meaningless and must not be used.
:func:`initialise_population` draws a whole population, redrawing failed individuals (vectorised,
bounded) and reporting the success rate.

* :func:`random_walk`: the plain GA (sga; Zhu & Pan 4.1 "random walk"), primitive
  :func:`uniform_walk`;
* :func:`median_insertion`: IMGA (Li, Hu, Liu 2021) section 4.1, via
  :func:`jaxga.operators.repair.connect`;
* :func:`intermittent_connect`: MPMGA (Hao et al. 2020) section 4.2, anchors
  :func:`intermittent_anchors`, via :func:`jaxga.operators.repair.connect`;
* :func:`greedy_random_target`: AGACD (Hao et al. 2021) section 4.3, primitive
  :func:`greedy_walk`;
* :func:`directional`: Zhu & Pan 2024 section 4.1, Algorithm 1, primitive
  :func:`directional_walk` (also the regrowing step of Zhu's range mutation), one-step
  probabilities :func:`directional_probabilities` (their Table 1).

The walk primitives go from any ``source`` cell to any ``target`` cell and accept an
``exclude`` set (cells that count as visited). Initialisers are looked up by name in
the registry (:func:`jaxga.operators.registry.initialiser`), where the end of this
module declares them.

Implementation notes shared by the walks
----------------------------------------
* A walk is a ``while_loop`` over steps that stops when the walk is done (target
  reached or dead end); under ``vmap`` it is a :func:`jaxga._batching.lanes.lane_while_loop`, which
  finishes the last walking lanes in a compacted batch instead of running every lane to
  the longest one: faster than a fixed-length ``lax.scan`` to the step cap, most of all
  for short walks such as the regrowth of Zhu's range mutation (decision 002). The step
  cap is the capacity: a walk that has not reached its target after ``capacity - 1``
  moves fails (for the AGACD walk, which may revisit cells, see ``max_steps``).
* The 8 neighbours of every cell and whether each move is legal under the corner rule
  are tabulated once per grid (``int32[H*W*8]`` and ``bool[H*W*8]``; under ``vmap`` over
  individuals the grid is shared, so the tables are built once per call). A step then
  costs two flat gathers of 8 entries.
* The visited set of a self-avoiding walk is a ``bool[H*W]`` table per individual,
  updated by one scalar scatter per step: cheaper than updating the table by an
  ``O(H*W)`` select or testing membership against the path so far (8 x L compares per
  step, no table) (decision 002). It costs ``H*W`` bytes per individual in the loop
  carry (P = 1000 on a 256 x 256 map: 65 MB), so on maps of more than
  :data:`VISITED_TABLE_CELLS_PER_NODE` cells per node of capacity the walks keep a hash
  set of their own cells instead (decision 008).
* Cost per attempt (decision 002): the random and
  directional walks are the cheapest, greedy_random_target (640 moves) costs more, and
  median_insertion and intermittent_connect cost the most, both dominated by
  :func:`jaxga.operators.repair.connect` (its ``while_loop`` over insertion rounds runs, under
  ``vmap``, until the slowest lane stops, and a connection that cycles stops only at
  ``max_rounds``).
* Random numbers are drawn in bulk before the loop (one float32 or three uint32 words per
  step), not per step.

One module per family: :mod:`~jaxga.operators.init.walks` (random, directional and greedy
walks), :mod:`~jaxga.operators.init.connect` (median insertion, intermittent paths),
:mod:`~jaxga.operators.init.field` (walks down the distance fields),
:mod:`~jaxga.operators.init.population` (a whole population, redraws and the fallback), and
what they share (:mod:`~jaxga.operators.init.common`).
"""

from jaxga.core.fields import Field
from jaxga.operators.init.common import (  # noqa: F401 - the family's public names
    InitFn,
    check_capacity,
    compute_move_tables,
    exclusion_mask,
    fit_to_capacity,
    free_cells,
    move_tables,
    pick_cell,
)
from jaxga.operators.init.connect import (  # noqa: F401 - the family's public names
    intermittent_anchors,
    intermittent_connect,
    median_insertion,
)
from jaxga.operators.init.field import (  # noqa: F401 - the family's public names
    CLEARANCE_WEIGHTS,
    FIELD_SLACK,
    FIELD_TEMPERATURE,
    clearance_walk,
    field_descent,
    field_path,
    field_reconnect,
    field_walk,
)
from jaxga.operators.init.population import (  # noqa: F401 - the family's public names
    FALLBACK_STREAM,
    InitStats,
    initialise_population,
)
from jaxga.operators.init.walks import (  # noqa: F401 - the family's public names
    VISITED_TABLE_CELLS_PER_NODE,
    directional,
    directional_probabilities,
    directional_walk,
    greedy_random_target,
    greedy_walk,
    random_walk,
    uniform_walk,
)
from jaxga.operators.registry import (
    FIELD_REPAIR,
    NEEDS_FRONT_FIELDS,
    NEEDS_GUIDE,
    NEVER_FAILS,
    Operator,
    register,
)

__all__ = [
    "InitFn",
    "InitStats",
    "directional",
    "directional_probabilities",
    "directional_walk",
    "exclusion_mask",
    "greedy_random_target",
    "greedy_walk",
    "initialise_population",
    "field_descent",
    "field_path",
    "field_reconnect",
    "clearance_walk",
    "field_walk",
    "intermittent_anchors",
    "intermittent_connect",
    "median_insertion",
    "random_walk",
    "uniform_walk",
]


FIELD_WALK_PARAMS = {
    "init.slack": Field(float, low=0.0, high=100.0, dynamic=True, default=0.5,
                        doc="field_walk: paths up to (1 + slack) x the optimal length"),
    "init.temperature": Field(float, low=0.0, high=1000.0, dynamic=True, default=1.0,
                              doc="field_walk: preference for short detours, "
                                  "exp(-excess / temperature); 0 = optimal moves only"),
}
"""The field walk's keys, which the clearance walk reads too."""

# the family's operators (jaxga.operators.registry)
register(Operator("init", "random_walk", random_walk,
                  "uniformly random self-avoiding walk from start to goal (Zhu & Pan 4.1; "
                  "the plain GA)"))
register(Operator("init", "median_insertion", median_insertion,
                  "one random free cell between start and goal, S - N_i - G connected by "
                  "median insertion (IMGA 4.1(3))",
                  traits=frozenset({FIELD_REPAIR})))
register(Operator("init", "intermittent_connect", intermittent_connect,
                  "barrier-free intermittent path + connection + deletion (MPMGA 4.2)",
                  traits=frozenset({FIELD_REPAIR})))
register(Operator("init", "greedy_random_target", greedy_random_target,
                  "greedy walk towards the goal or a random target (AGACD 4.3)"))
register(Operator("init", "directional", directional,
                  "walk with directional guidance, eq. 5 weights (Zhu & Pan 4.1, "
                  "Algorithm 1)"))
register(Operator(
    "init", "field_walk", field_walk,
    "random detour down the exact distance fields; cannot fail where a path exists "
    "(jaxga; decision notes)",
    params=FIELD_WALK_PARAMS,
    traits=frozenset({NEVER_FAILS, NEEDS_GUIDE}),
    options=lambda ctx: {"slack": ctx.params["init.slack"],
                         "temperature": ctx.params["init.temperature"]},
))
register(Operator(
    "init", "clearance_walk", clearance_walk,
    "the field walk, or a walk down the widest field or a clearance-weighted field of a "
    "random weight; spreads a front of length against clearance; cannot fail where a path "
    "exists (jaxga; decision 045)",
    params={
        "init.clearance_weights": Field(
            list, dynamic=False, default=CLEARANCE_WEIGHTS,
            doc="clearance_walk: the weights of the clearance-weighted fields, >= 0"),
        **FIELD_WALK_PARAMS,
    },
    traits=frozenset({NEVER_FAILS, NEEDS_GUIDE, NEEDS_FRONT_FIELDS}),
    options=lambda ctx: {"slack": ctx.params["init.slack"],
                         "temperature": ctx.params["init.temperature"]},
))
