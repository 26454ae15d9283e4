"""The pure core as one object: a preset on a map, for the user's own ``jit``, ``vmap`` and
``scan`` (decision 034).

:class:`GA` does the host work once (the preset and its overrides, checked; the map loaded
and its endpoints checked; the exact distance fields of the presets that steer by them;
the per-map move tables). Everything after the constructor is pure and works under
``jax.jit``, ``jax.vmap`` (over keys and over parameters) and ``jax.lax.scan``::

    ga = jaxga.GA("iga_zhu", "classic_ga_gapp3_20x20")
    params = ga.default_params                       # dynamic hyper-parameters (pytree)
    keys = jax.random.split(jax.random.PRNGKey(0), 100)
    state = jax.jit(jax.vmap(ga.init, (0, None)))(keys, params)
    state = jax.vmap(ga.step, (0, 0, None))(keys, state, params)   # one generation
    out = jax.vmap(ga.finish, (0, None))(state, params)           # paths, lengths, metrics

:meth:`GA.run` is what :func:`jaxga.run` computes for one seed (the same keys: a run of
``GA.run(jax.random.PRNGKey(seed), params)`` equals seed ``seed`` of ``jaxga.run``),
written as three pure calls a user can take apart.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax

from jaxga.api.problem import Problem, load_problem
from jaxga.api.programs import warn_platform
from jaxga.config.schema import Config
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.engine import (
    GAState,
    RunOutputs,
    build,
    default_capacity,
    default_params,
    generation,
    uses_guide,
)
from jaxga.engine import finish as finish_run
from jaxga.engine.maptables import with_tables
from jaxga.engine.run import run_evolve, run_init
from jaxga.maps import MapInfo
from jaxga.maps.frame import MapFrame, endpoint_cells
from jaxga.operators.guide import with_guide

__all__ = ["GA"]


class GA:
    """One preset on one map: host work in the constructor, pure functions after it.

    Args:
        preset: a preset name (``jaxga presets``), a TOML file, or a
            :class:`~jaxga.config.schema.Config`; or a :class:`jaxga.api.problem.Problem`
            (:func:`jaxga.problem`: a preset on a map, already checked), then without a
            map or other options.
        problem: a :class:`~jaxga.core.grid.Grid` (with its start and goal), a loaded
            :class:`~jaxga.maps.MapInfo`, a map file or a built-in map name.
        corner_rule: as for :func:`jaxga.run`.
        variant: a preset variant (e.g. ``"50x50"`` for ``agacd``).
        sets: ``"key=value"`` overrides, as ``--set`` on the command line.
        generations: the number of generations of :meth:`evolve` and :meth:`run`.
        **overrides: configuration keys (``crossover__probability=0.7`` or a nested dict),
            checked as :func:`jaxga.run` checks them (a key the preset never reads is
            refused); or a family with a function of your own (``mutation=my_mutation``,
            ``objective=my_objective``; :func:`jaxga.api.problem.own_operators`).

    Attributes:
        config: the checked configuration.
        grid: the map as the pure functions read it (distance fields and move tables
            attached).
        algorithm: the static part of the configuration (:class:`jaxga.engine.Algorithm`).
        default_params: the dynamic hyper-parameters (a dict of arrays: float32 scalars
            for rates, weights and temperatures, int32 scalars for ``init.max_tries``,
            ``termination.stagnation`` and ``islands.interval``, a bool flag for
            ``init.fallback``, ``[islands]`` per-island rates under their rate's name,
            AGACD's ``float32[2]`` Delphi ratios): pass it, or a modified copy, to every
            pure function; ``jax.vmap`` over any of its entries sweeps it.
        map_name: the map's name.
        frame: the map's world frame (:class:`jaxga.maps.frame.MapFrame`: resolution,
            origin, coarsening), None for a bare grid.
    """

    def __init__(self, preset: str | Config | Problem,
                 problem: Grid | MapInfo | str | None = None, *,
                 corner_rule: str | None = None, variant: str | None = None,
                 sets: Any = (), generations: int | None = None, **overrides: Any) -> None:
        config, grid, map_name, frame = load_problem(
            preset, problem, corner_rule, variant, sets, overrides, generations)
        self.map_name: str = map_name
        self.frame: MapFrame | None = frame
        if uses_guide(config):
            grid = with_guide(grid)
        self.config = config
        self.algorithm, _ = build(config, grid)
        self.grid = with_tables(grid)
        self.default_params: dict[str, jax.Array] = default_params(
            config, self.algorithm.islands)
        warn_platform(jax.default_backend())  # where jit puts the user's calls

    def grid_for(self, start: tuple[int, int] | None = None,
                 goal: tuple[int, int] | None = None, *, start_world: Any = None,
                 goal_world: Any = None) -> Grid:
        """This map with other endpoints (cells ``(x, y)``, or metres on a map with a
        resolution), as the pure functions read it: pass it as their ``grid`` argument.
        Its arrays have the shapes of :attr:`grid`'s, so a program compiled with one
        such grid as an argument serves every pair (host work: the endpoints checked,
        the distance fields of the presets that steer by them; the move tables are the
        map's own)::

            plan = jax.jit(jax.vmap(ga.run, (0, None, None)))
            out = plan(keys, ga.default_params, ga.grid_for((3, 4), (60, 20)))

        Raises :class:`~jaxga.core.errors.EndpointError` for an endpoint off the map or
        blocked, and :class:`~jaxga.core.errors.ParameterError` when the pair's paths
        need more cells than :attr:`algorithm`'s capacity (build the GA with a larger
        ``population__capacity``)."""
        ends = endpoint_cells(self.frame, self.grid, start, goal, start_world, goal_world,
                              required=False)
        grid = self.grid.replace(start=ends[0], goal=ends[1])
        grid.check_endpoints()
        need = default_capacity(grid, float(self.config["population.capacity_factor"]))
        if need > self.algorithm.capacity:
            raise ParameterError(
                f"the paths from {ends[0]} to {ends[1]} need a capacity of {need} cells, "
                f"this GA holds {self.algorithm.capacity}: build it with "
                f"population__capacity={need} (or more) to plan any pair")
        if self.grid.guide is not None:
            grid = with_guide(grid)
        return dataclasses.replace(grid, tables=self.grid.tables, outside=self.grid.outside)

    def init(self, key: jax.Array, params: dict, grid: Grid | None = None) -> GAState:
        """The initial population of every island, evaluated (pure; the initialisers of
        the preset: ``init.method`` and its fallback). ``grid``: another pair of
        endpoints on this map (:meth:`grid_for`), default :attr:`grid`'s."""
        state, _ = run_init(self.algorithm, key, self._grid(grid), params)
        return state

    def step(self, key: jax.Array, state: GAState, params: dict,
             grid: Grid | None = None) -> GAState:
        """One generation (selection, crossover, mutation, simplification, evaluation,
        migration; the stagnation rule); pure. ``key``: this generation's key."""
        return generation(self.algorithm, key, self._grid(grid), state, params)

    def _grid(self, grid: Grid | None) -> Grid:
        if grid is not None and not isinstance(grid, Grid):
            raise TypeError(f"the grid argument is a Grid (GA.grid_for), got "
                            f"{type(grid).__name__}: give generations= by keyword")
        return self.grid if grid is None else grid

    def evolve(self, key: jax.Array, state: GAState, params: dict,
               generations: int | None = None, grid: Grid | None = None
               ) -> tuple[GAState, dict]:
        """``generations`` (default: the configuration's) generations as one
        ``lax.scan``; returns the final state and the history (best-so-far fitness, mean
        and sd of the population's fitness, per generation). Generation ``t`` uses
        ``fold_in(fold_in(key, 1), t)``, as :func:`jaxga.run` does."""
        return run_evolve(self.algorithm, key, self._grid(grid), state, params, generations)

    def finish(self, state: GAState, params: dict, history: dict | None = None,
               initial_best: jax.Array | None = None,
               grid: Grid | None = None) -> RunOutputs:
        """The best path post-optimised (the preset's ``post.method``) and the reported
        metrics as arrays (:class:`jaxga.engine.RunOutputs`, also read by name:
        ``out["fitness"]``): ``success``, ``raw_cells`` / ``raw_n_cells`` (the GA's own
        best and its node count), ``cells`` / ``n_cells`` (post-optimised), ``length`` /
        ``raw_length`` (Euclidean, as :class:`jaxga.api.result.Result`), ``fitness``,
        ``metrics``, ...; with ``history``, also the
        convergence generation (0 for a best the initial population already held, given
        its ``initial_best`` fitness)."""
        return finish_run(self.algorithm, self._grid(grid), state, history, params,
                          initial_best)

    def run(self, key: jax.Array, params: dict, grid: Grid | None = None,
            generations: int | None = None) -> RunOutputs:
        """:meth:`init`, :meth:`evolve` and :meth:`finish` of one run: seed ``s`` of
        :func:`jaxga.run` is ``run(jax.random.PRNGKey(s), ga.default_params)``;
        ``grid``: another pair of endpoints on this map (:meth:`grid_for`)."""
        state = self.init(key, params, grid)
        initial_best = state.best_fitness  # a best found at initialisation converges at 0
        state, history = self.evolve(key, state, params, generations, grid)
        return self.finish(state, params, history, initial_best, grid)
