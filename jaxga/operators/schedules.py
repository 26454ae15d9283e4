"""Time schedules of the adaptive operators, as optax schedules (``step -> value``).

* AGACD (Hao et al. 2021) eq. 27: the crossover probability decays as ``exp(-t / T)``.
* AGACD eq. 29: the mutation probability grows as ``exp(t / T)``.
* MPMGA (Hao et al. 2020) eq. 17: the annealing temperature of the segment mutation is
  ``T_t = c1 * w ** t``, with ``c1`` and ``w`` traced.

``t`` is the generation counter (a traced int32 inside the engine's ``lax.scan``) and
``T`` the number of generations (traced: a run-time value). They compute what
``optax.exponential_decay`` schedules compute (``init * rate ** (t / steps)``), so
users can swap in any other optax schedule (``optax.cosine_decay_schedule``,
``optax.join_schedules``, ...) through the same keyword of
:func:`jaxga.operators.crossover.adaptive_crossover_probability`,
:func:`jaxga.operators.mutation.adaptive_mutation_probability` and
:func:`jaxga.operators.mutation.segment_sa`'s caller in :mod:`jaxga.engine`.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import optax

__all__ = ["agacd_crossover_decay", "agacd_mutation_growth", "mpmga_temperature"]


def agacd_crossover_decay(generations: int | jax.Array) -> optax.Schedule:
    """``t -> exp(-t / T)`` (AGACD eq. 27, the time factor of ``pc``); ``T`` may be traced."""
    return _exponential(generations, math.exp(-1.0))


def agacd_mutation_growth(generations: int | jax.Array) -> optax.Schedule:
    """``t -> exp(t / T)`` (AGACD eq. 29, the time factor of ``pm``); ``T`` may be traced."""
    return _exponential(generations, math.e)


def _exponential(generations: int | jax.Array, rate: float) -> optax.Schedule:
    """``optax.exponential_decay(1.0, transition_steps=T, decay_rate=rate)`` with a ``T``
    that may be traced (the number of generations is a run-time value, so that one
    compiled program serves every count; optax inspects ``transition_steps`` in Python).
    The same operations as optax's schedule, so the same float32 values
    (``tests/operators/test_mutation.py`` checks them against optax for a static ``T``)."""
    if not isinstance(generations, jax.Array):
        _check(generations)

    def schedule(count):
        return jnp.where(count <= 0, 1.0, 1.0 * jnp.power(rate, count / generations))

    return schedule


def mpmga_temperature(c1: float | jax.Array, w: float | jax.Array) -> optax.Schedule:
    """``t -> c1 * w ** t`` (MPMGA eq. 17, simulated-annealing temperature).

    ``c1`` and ``w`` may be traced (swept parameters: one compiled program serves every
    decay rate); a concrete ``w`` must lie in (0, 1]. The operations of
    ``optax.exponential_decay(c1, transition_steps=1, decay_rate=w)``, so the same
    float32 values as optax's schedule, which inspects its rate in Python and so cannot
    take a traced one.
    """
    try:
        concrete = float(w)
    except (TypeError, jax.errors.ConcretizationTypeError):  # traced: checked on the host
        concrete = None
    if concrete is not None and not 0.0 < concrete <= 1.0:
        raise ValueError(f"temperature decay rate w must be in (0, 1], got {w}")

    def schedule(count):
        decreased = count - 0  # optax: count - transition_begin, then / transition_steps
        return jnp.where(decreased <= 0, c1, c1 * jnp.power(w, decreased / 1))

    return schedule


def _check(generations: int) -> None:
    if int(generations) < 1:
        raise ValueError(f"generations must be >= 1, got {generations}")
