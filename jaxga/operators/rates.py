"""Rate rules: how a generation's crossover and mutation probabilities are set.

A :class:`RateRule` turns the population entering a stage into the stage's probabilities:
``rule(params, fitness, active, t, T) -> float32[n]`` with ``n`` the number of pairs
(crossover) or of individuals (mutation). The engine asks :func:`rate_rule` for the rule of
a configuration and calls it like any other operator; it holds no branch of its own for
any paper's rule.

* ``fixed``: ``<stage>.probability`` for every pair or individual (the papers' constant
  rates; a per-island rate arrives through the parameters, MPMGA section 4.4 and Table 2);
* ``agacd``: AGACD's adaptive rates (Hao et al. 2021, section 4.6): the crossover
  probability of a pair from the fitter parent, eq. 26-27
  (:func:`jaxga.operators.crossover.adaptive_pair_probability`), the mutation probability
  of an individual from its fitness after crossover, eq. 28-29
  (:func:`jaxga.operators.mutation.adaptive_mutation_probability`), each with its time
  factor as an optax schedule (:mod:`jaxga.operators.schedules`).

A configuration selects ``agacd`` with ``<stage>.adaptive = true``. A rule that reads the
fitness after crossover (``reads_offspring_fitness``) makes the generation evaluate the
population between crossover and mutation (AGACD's eq. 28 ``f``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping

import jax
import jax.numpy as jnp

from jaxga._batching.numerics import ordered_mean
from jaxga.operators import crossover as cx
from jaxga.operators import mutation as mu
from jaxga.operators import schedules

__all__ = ["RATE_RULES", "STAGES", "RateRule", "rate_rule"]

STAGES = ("crossover", "mutation")
"""The stages whose probability a rate rule sets."""


@dataclasses.dataclass(frozen=True)
class RateRule:
    """One stage's rate rule.

    Attributes:
        name: ``fixed`` or ``agacd``.
        stage: ``crossover`` (one probability per pair ``(2k, 2k+1)``) or ``mutation``
            (one per individual).
        fn: ``fn(params, fitness, active, t, T) -> float32[n]``: ``params`` the dynamic
            parameters, ``fitness`` and ``active`` the population's, ``t`` the generation
            (traced), ``T`` the run's number of generations (traced).
        reads_offspring_fitness: the rule reads the fitness of the population after
            crossover (the generation evaluates it before the mutation).
    """

    name: str
    stage: str
    fn: Callable
    reads_offspring_fitness: bool = False

    def __call__(self, params: Mapping, fitness: jax.Array, active: jax.Array,
                 t: jax.Array, generations: jax.Array | int) -> jax.Array:
        return self.fn(params, fitness, active, t, generations)


def _fixed_crossover(params, fitness, active, t, generations):
    return params["crossover.probability"]


def _fixed_mutation(params, fitness, active, t, generations):
    return jnp.broadcast_to(params["mutation.probability"], fitness.shape)


def _agacd_crossover(params, fitness, active, t, generations):
    """AGACD eq. 26-27; ``f_max`` and ``f_avg`` over the selected pool (the population
    entering crossover)."""
    return cx.adaptive_pair_probability(
        fitness, t, generations, params["crossover.pc_low"], params["crossover.pc_high"],
        active, schedule=schedules.agacd_crossover_decay(generations))


def _agacd_mutation(params, fitness, active, t, generations):
    """AGACD eq. 28-29 on the fitness after crossover."""
    f_max = jnp.max(jnp.where(active, fitness, -jnp.inf))
    f_avg = ordered_mean(fitness, active)
    return mu.adaptive_mutation_probability(
        fitness, f_max, f_avg, t, generations, params["mutation.pm_low"],
        params["mutation.pm_high"], schedule=schedules.agacd_mutation_growth(generations))


RATE_RULES: dict[tuple[str, str], RateRule] = {
    ("crossover", "fixed"): RateRule("fixed", "crossover", _fixed_crossover),
    ("mutation", "fixed"): RateRule("fixed", "mutation", _fixed_mutation),
    ("crossover", "agacd"): RateRule("agacd", "crossover", _agacd_crossover),
    ("mutation", "agacd"): RateRule("agacd", "mutation", _agacd_mutation,
                                    reads_offspring_fitness=True),
}
"""Every rate rule, by ``(stage, name)``."""


def rate_rule(config: Mapping, stage: str) -> RateRule:
    """The rate rule of ``stage`` in ``config`` (anything with ``get``): ``agacd`` where
    ``<stage>.adaptive`` is true, else ``fixed``."""
    return RATE_RULES[(stage, "agacd" if config.get(f"{stage}.adaptive") else "fixed")]
