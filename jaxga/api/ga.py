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

from jaxga._runtime.fields import front_obstacles, program_fields
from jaxga._runtime.programs import warn_platform
from jaxga.api.problem import Problem, checked_endpoints, load_problem
from jaxga.config.schema import SCHEMA, Config, dotted, flatten, sweepable
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.core.own_settings import own_settings
from jaxga.engine import build, default_capacity, default_params
from jaxga.engine.algorithm import static_config
from jaxga.engine.checks import check_overrides_read
from jaxga.engine.maptables import with_tables
from jaxga.engine.run import PureGA
from jaxga.maps import MapInfo
from jaxga.maps.frame import MapFrame, endpoint_cells

__all__ = ["GA"]


class GA(PureGA):
    """One preset on one map: host work in the constructor, pure functions after it (those
    of :class:`jaxga.engine.run.PureGA`, which the batch drivers trace too:
    :meth:`~jaxga.engine.run.PureGA.init`, ``step``, ``evolve``, ``finish``, ``run``).

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

    @own_settings
    def __init__(self, preset: str | Config | Problem,
                 problem: Grid | MapInfo | str | None = None, *,
                 corner_rule: str | None = None, variant: str | None = None,
                 sets: Any = (), generations: int | None = None, **overrides: Any) -> None:
        self._problem = load_problem(preset, problem, corner_rule, variant, sets, overrides,
                                     generations)
        config, grid, map_name, frame, info, _ = self._problem
        self.map_name: str = map_name
        self.frame: MapFrame | None = frame
        self._layers = None if info is None else info.layers
        grid = program_fields(grid, config, front_obstacles(frame, grid))
        self.config = config
        algorithm, _ = build(config, grid)
        super().__init__(algorithm, with_tables(grid))
        self.default_params: dict[str, jax.Array] = default_params(
            config, self.algorithm.islands)
        self.param_keys = frozenset(self.default_params)
        warn_platform(jax.default_backend())  # where jit puts the user's calls

    def __reduce__(self) -> tuple:
        """A GA is sent (pickled, to another process) as its problem and built again there:
        its host work and tables are not sent, and its :attr:`default_params` are the
        problem's (values reassigned by hand are not sent). An operator of your own is
        sent by name and must be registered in the receiving process too
        (:func:`jaxga.register_operator`)."""
        return (type(self), (self._problem,))

    def __repr__(self) -> str:
        return (f"GA({self.config['name']!r} on {self.map_name!r}, "
                f"{self.grid.width} x {self.grid.height} cells)")

    @own_settings
    def params(self, **values: Any) -> dict[str, jax.Array]:
        """:attr:`default_params` with dynamic keys set (``crossover__probability=0.5``,
        ``"mutation.probability"`` as a dict key, nested mappings), each checked as
        :func:`jaxga.run` checks it: its range (a NaN rate, a negative probability), its
        combination with the other keys, a population size within the GA's; refused in
        one line, as is a key the compiled program depends on (build another GA) and
        ``generations``. A value changed in :attr:`default_params` by hand is not checked
        (inside ``jit`` it cannot be): this is the checked way.

        ``params["generations"]`` is the run length ``T`` the rate schedules read (AGACD
        eq. 27, 29), not a loop count: :meth:`evolve` and :meth:`run` step the GA's own
        ``generations`` (``jaxga.GA(..., generations=N)``), and ``T`` equals it here."""
        changes = dotted(values)
        keys = list(flatten(changes))
        if "generations" in keys:
            raise ParameterError(
                "generations is not a parameter of the pure core's calls: evolve and run "
                "step the GA's own count; build jaxga.GA(..., generations=N) (its "
                "default_params' generations, the schedules' T, follow it)")
        config = self.config.override(changes)
        check_overrides_read(config, keys)
        held = [k for k in keys if k == "population.size" or SCHEMA[k].dynamic]
        if static_config(config) != static_config(self.config) or len(held) < len(keys):
            changed = sorted(k for k in keys if k not in held or not sweepable(k))
            raise ParameterError(
                f"{', '.join(changed) or 'these values'} "
                f"{'is' if len(changed) == 1 else 'are'} not a parameter of the pure core's "
                "calls (the compiled program depends on it, or nothing does once the GA is "
                "built): build another jaxga.GA with it")
        size = int(config["population.size"])
        if size > self.algorithm.population:
            raise ParameterError(
                f"population.size {size} is more than the GA's {self.algorithm.population} "
                "individuals: build the GA with the largest size, then set smaller ones here")
        return default_params(config, self.algorithm.islands)

    @own_settings
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
        grid = checked_endpoints(self.grid.replace(start=ends[0], goal=ends[1]), self.frame,
                                 self._layers)
        need = default_capacity(grid, float(self.config["population.capacity_factor"]))
        if need > self.algorithm.capacity:
            raise ParameterError(
                f"the paths from {ends[0]} to {ends[1]} need a capacity of {need} cells, "
                f"this GA holds {self.algorithm.capacity}: build it with "
                f"population__capacity={need} (or more) to plan any pair")
        grid = program_fields(grid, self.config, front_obstacles(self.frame, grid))
        return dataclasses.replace(grid, tables=self.grid.tables, outside=self.grid.outside)
