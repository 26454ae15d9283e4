"""One run: the pure methods of a GA (:class:`PureGA`) and the key streams that tie a run's
initialisation and generations to its key.

A run's key is split by ``fold_in`` into an initialisation stream (``fold_in(key, 0)``)
and an evolution stream (``fold_in(key, 1)``; generation ``t`` uses
``fold_in(evolution key, t)``). :class:`PureGA` is the one door to the engine:
:class:`jaxga.GA` is a :class:`PureGA` built from a preset and a map, and the compiled
programs of :func:`jaxga.run`, :func:`jaxga.sweep`, :func:`jaxga.compare`, the DOE and
:func:`jaxga.replan` (:mod:`jaxga._runtime.programs`) trace the methods of a :class:`PureGA`
of the same algorithm, so seed ``s`` of a driver is ``GA.run(PRNGKey(s))``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import jax
import jax.numpy as jnp

from jaxga.core import prng
from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import Grid, as_integer
from jaxga.core.own_settings import check_jax_settings, own_settings
from jaxga.engine.algorithm import Algorithm
from jaxga.engine.evolution import GAState, RunOutputs, evolve, finish, generation, init_state
from jaxga.operators.init import InitStats

__all__ = ["EVOLVE_STREAM", "INIT_STREAM", "PureGA", "run_evolve", "run_init"]

INIT_STREAM, EVOLVE_STREAM = 0, 1
"""The ``fold_in`` data of a run's initialisation and evolution streams."""


def run_init(algo: Algorithm, key: jax.Array, grid: Grid, params: dict) -> tuple:
    """``(GAState, InitStats)``: the run's initial populations
    (:func:`jaxga.engine.evolution.init_state`) on its initialisation stream."""
    return init_state(algo, prng.fold_in(key, INIT_STREAM), grid, params)


def run_evolve(algo: Algorithm, key: jax.Array, grid: Grid, state: GAState, params: dict,
               generations: int | None = None, count: jax.Array | None = None) -> tuple:
    """``(GAState, history)``: the run's generations from ``state``
    (:func:`jaxga.engine.evolution.evolve`, ``generations`` and ``count`` as there) on its
    evolution stream; generation ``t`` is the same whether the run is evolved in one call
    or in chunks."""
    return evolve(algo, prng.fold_in(key, EVOLVE_STREAM), grid, state, params,
                  generations, count)


class PureGA:
    """A GA's pure functions over a built :class:`~jaxga.engine.Algorithm`: what a run is,
    defined once. :class:`jaxga.GA` adds the host work of its constructor (the preset and
    the map loaded and checked); the batch drivers' compiled programs
    (:mod:`jaxga._runtime.programs`) trace these same methods, vmapped or sharded over runs,
    with the map as an argument.

    Args:
        algorithm: the static algorithm (:func:`jaxga.engine.build`).
        grid: the map the methods use where a call gives none (its move tables attached:
            :func:`jaxga.engine.maptables.with_tables`); None: every call gives one.
    """

    def __init__(self, algorithm: Algorithm, grid: Grid | None = None) -> None:
        self.algorithm = algorithm
        self.grid = grid
        self.param_keys: frozenset[str] | None = None
        """The keys every ``params`` of these methods must have, no more and no fewer
        (:class:`jaxga.GA` sets its ``default_params``' keys); None: not checked."""

    def _params(self, params: Any) -> Any:
        """``params``, refused in one line where it is not a dict of the GA's parameters
        (a key missing, or one the GA does not read: a misspelt key set by hand would be
        ignored). Its values are not checked: they may be traced (:meth:`jaxga.GA.params`
        is the checked way to set them). JAX's 64-bit mode, turned on after the GA was
        built, is refused too: the programs' int32 and float32 carries would change type."""
        check_jax_settings(jit=False)
        if not isinstance(params, Mapping):
            raise ParameterError(f"params must be the dict of the GA's parameters "
                                 f"(GA.default_params, or GA.params(...) to change some), "
                                 f"got {shown_value(params)}")
        if self.param_keys is not None and set(params) != self.param_keys:
            missing = sorted(self.param_keys - set(params))
            unknown = sorted(map(str, set(params) - self.param_keys))
            said = [f"{_some(missing)} missing"] if missing else []
            said += [f"{_some(unknown)} not read by this GA"] if unknown else []
            raise ParameterError(f"params has other keys than the GA's: {'; '.join(said)} "
                                 "(start from GA.default_params; GA.params(...) sets "
                                 "values, checked)")
        return params

    def _grid(self, grid: Grid | None) -> Grid:
        if grid is not None and not isinstance(grid, Grid):
            raise TypeError(f"the grid argument is a Grid (GA.grid_for), got "
                            f"{type(grid).__name__}: give generations= by keyword")
        if grid is None and self.grid is None:
            raise ParameterError("this GA has no map of its own: pass the grid")
        return self.grid if grid is None else grid

    @own_settings
    def init_with_stats(self, key: jax.Array, params: dict,
                        grid: Grid | None = None) -> tuple[GAState, InitStats]:
        """:meth:`init` and what the initialisers did (per island: attempts' success
        rate, slots left empty, slots the fallback filled), as :func:`jaxga.run`
        reports them."""
        return run_init(self.algorithm, prng.checked_key(key), self._grid(grid),
                        self._params(params))

    @own_settings
    def init(self, key: jax.Array, params: dict, grid: Grid | None = None) -> GAState:
        """The initial population of every island, evaluated (pure; the initialisers of
        the preset: ``init.method`` and its fallback). ``grid``: another pair of
        endpoints on this map (:meth:`jaxga.GA.grid_for`), default :attr:`grid`."""
        return self.init_with_stats(key, params, grid)[0]

    @own_settings
    def step(self, key: jax.Array, state: GAState, params: dict,
             grid: Grid | None = None) -> GAState:
        """One generation (selection, crossover, mutation, simplification, evaluation,
        migration; the stagnation rule); pure. ``key``: this generation's key."""
        return generation(self.algorithm, prng.checked_key(key), self._grid(grid), state,
                          self._params(params))

    @own_settings
    def evolve(self, key: jax.Array, state: GAState, params: dict,
               generations: int | None = None, grid: Grid | None = None, *,
               count: jax.Array | None = None) -> tuple[GAState, dict]:
        """``generations`` (default: the configuration's) generations as one
        ``lax.scan``; returns the final state and the history (best-so-far fitness, mean
        and sd of the population's fitness, per generation). Generation ``t`` uses
        ``fold_in(fold_in(key, 1), t)``, as :func:`jaxga.run` does, so a run evolved in
        chunks equals one evolved at once. ``count`` (a traced, unbatched integer): only
        the first ``count`` of the ``generations`` run (one compiled chunk serves every
        generation count: :func:`jaxga.engine.evolve`)."""
        if generations is not None:
            given = generations
            try:
                generations = as_integer(generations)
            except TypeError:
                generations = -1
            if generations < 0:
                raise ParameterError(f"generations must be an integer >= 0, got "
                                     f"{shown_value(given)}")
        return run_evolve(self.algorithm, prng.checked_key(key), self._grid(grid), state,
                          self._params(params), generations, count)

    @own_settings
    def finish(self, state: GAState, params: dict, history: dict | None = None,
               initial_best: jax.Array | None = None,
               grid: Grid | None = None) -> RunOutputs:
        """The best path post-optimised (the preset's ``post.method``) and the reported
        metrics as arrays (:class:`jaxga.engine.RunOutputs`, also read by name:
        ``out["fitness"]``): ``success``, ``raw_cells`` / ``raw_n_cells`` (the GA's own
        best and its node count), ``cells`` / ``n_cells`` (post-optimised), ``length`` /
        ``raw_length`` (Euclidean, as :class:`jaxga.api.result.Result`), ``fitness``,
        ``metrics``, ...; with ``history``, also the convergence generation (0 for a best
        the initial population already held, given its ``initial_best`` fitness).

        A run that found no path (``success`` False) has NaN lengths and floating-point
        metrics (never 0, which a mean would take for a path's), -1 integer metrics
        (turns, tangencies; their dtype is kept) and fitness 0 (``jaxga.run``'s
        ``Result`` shows NaN for all of them); :func:`jaxga.reference.shortest_path`
        says whether a path exists."""
        out = finish(self.algorithm, self._grid(grid), state, history, self._params(params),
                     initial_best)
        return no_path_as_nan(out)

    @own_settings
    def run(self, key: jax.Array, params: dict, grid: Grid | None = None,
            generations: int | None = None) -> RunOutputs:
        """:meth:`init`, :meth:`evolve` and :meth:`finish` of one run: seed ``s`` of
        :func:`jaxga.run` is ``run(jaxga.core.prng.seed_key(s), ga.default_params)``
        (``jax.random.PRNGKey(s)`` under JAX's default PRNG settings);
        ``grid``: another pair of endpoints on this map (:meth:`jaxga.GA.grid_for`)."""
        state = self.init(key, params, grid)
        initial_best = state.best_fitness  # a best found at initialisation converges at 0
        state, history = self.evolve(key, state, params, generations, grid)
        return self.finish(state, params, history, initial_best, grid)


def _some(names: list[str], shown: int = 4) -> str:
    """The first ``shown`` of ``names``, and how many more."""
    more = len(names) - shown
    return ", ".join(names[:shown]) + (f" and {more} more" if more > 0 else "")


def no_path_as_nan(out: RunOutputs) -> RunOutputs:
    """``out`` with a run without a path marked so: ``success`` False, lengths and
    metrics NaN (-1 for the integer metrics), fitness 0 and convergence generation -1.
    A run without a path found none, or its post-optimised path failed the final
    feasibility check (``feasible_post``, as a user's own post step may make), as
    :func:`jaxga.run` counts it."""
    success = out.success & out.feasible_post

    def nan_unless(v: jax.Array) -> jax.Array:
        missing = jnp.nan if jnp.issubdtype(v.dtype, jnp.floating) else -1
        return jnp.where(success, v, missing).astype(v.dtype)

    conv = out.convergence_generation
    return dataclasses.replace(
        out, success=success, fitness=jnp.where(success, out.fitness, 0).astype(out.fitness.dtype),
        length=nan_unless(out.length), raw_length=nan_unless(out.raw_length),
        metrics={k: nan_unless(v) for k, v in out.metrics.items()},
        raw_metrics={k: nan_unless(v) for k, v in out.raw_metrics.items()},
        convergence_generation=None if conv is None else nan_unless(conv))
