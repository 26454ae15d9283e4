"""One run: the key streams that tie a run's initialisation and generations to its key.

A run's key is split by ``fold_in`` into an initialisation stream (``fold_in(key, 0)``)
and an evolution stream (``fold_in(key, 1)``; generation ``t`` uses
``fold_in(evolution key, t)``). Every path to the engine goes through these two
functions: :class:`jaxga.GA` (the pure core) and the compiled programs of
:func:`jaxga.run`, :func:`jaxga.sweep`, :func:`jaxga.compare`, the DOE and
:func:`jaxga.replan` (:mod:`jaxga.api.programs`), so seed ``s`` of a driver is
``GA.run(PRNGKey(s))``.
"""

from __future__ import annotations

import jax

from jaxga.core.grid import Grid
from jaxga.engine.algorithm import Algorithm
from jaxga.engine.evolution import GAState, evolve, init_state

__all__ = ["EVOLVE_STREAM", "INIT_STREAM", "run_evolve", "run_init"]

INIT_STREAM, EVOLVE_STREAM = 0, 1
"""The ``fold_in`` data of a run's initialisation and evolution streams."""


def run_init(algo: Algorithm, key: jax.Array, grid: Grid, params: dict) -> tuple:
    """``(GAState, InitStats)``: the run's initial populations
    (:func:`jaxga.engine.evolution.init_state`) on its initialisation stream."""
    return init_state(algo, jax.random.fold_in(key, INIT_STREAM), grid, params)


def run_evolve(algo: Algorithm, key: jax.Array, grid: Grid, state: GAState, params: dict,
               generations: int | None = None, count: jax.Array | None = None) -> tuple:
    """``(GAState, history)``: the run's generations from ``state``
    (:func:`jaxga.engine.evolution.evolve`, ``generations`` and ``count`` as there) on its
    evolution stream; generation ``t`` is the same whether the run is evolved in one call
    or in chunks."""
    return evolve(algo, jax.random.fold_in(key, EVOLVE_STREAM), grid, state, params,
                  generations, count)
