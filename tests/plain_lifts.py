"""Plain reference versions of what jaxga computes gated: an operator applied with a
probability (every individual computed, the result selected), a choice between two
operators, a population lift, and the jitted population initialiser. The tests check that
jaxga's gated lifts (:mod:`jaxga.operators.lift`) give the same bits."""

from __future__ import annotations

import functools
from collections.abc import Callable

import jax
import jax.numpy as jnp

from jaxga.core.dtypes import F32, I32
from jaxga.operators.init import initialise_population
from jaxga.operators.lift import keep_parent_on_failure, over_individuals_gated


def with_probability(op: Callable) -> Callable:
    """Apply a per-individual operator with probability ``prob`` (a mutation or crossover rate).

    Returns ``wrapped(key, grid, cells, length, prob, *extra) -> (cells, length,
    failed)``: with probability ``prob`` (a float32 scalar, traced; per individual when
    mapped) it returns ``op(sub_key, grid, cells, length, *extra)``, otherwise the input
    unchanged with ``failed = False``; so the population helper counts only failures of
    operators that were actually applied. Use with
    :func:`~jaxga.operators.lift.over_individuals`::

        mutate = over_individuals(with_probability(neighbour_point), in_axes_extra=(0,))
        pop, n_failed = mutate(key, grid, pop, pm)      # pm: float32[P] (AGACD eq. 29)
        mutate = over_individuals(with_probability(op), in_axes_extra=(None,))
        pop, n_failed = mutate(key, grid, pop, 0.2)     # one rate for all (IMGA)

    Under ``vmap`` the operator is evaluated for every individual and the result
    selected (XLA has no per-lane branch), so the cost does not fall with ``prob``.
    """

    def wrapped(key, grid, cells, length, prob, *extra):
        k_coin, k_op = jax.random.split(key)
        apply = jax.random.uniform(k_coin, (), jnp.float32) < jnp.asarray(prob, jnp.float32)
        new_c, new_l, failed = op(k_op, grid, cells, length, *extra)
        out_c, out_l = keep_parent_on_failure(~apply, new_c, new_l, cells, length)
        return out_c, out_l, apply & failed

    wrapped.__name__ = "with_probability_" + getattr(op, "__name__", "op")
    return wrapped


def mutation_population(op: Callable, *, in_axes_extra: tuple = ()) -> Callable:
    """Lift a mutation with a mutation probability to a population.

    Returns ``lifted(key, grid, pop, pm, *extra) -> (Population, n_failed)``: individual
    ``i`` is mutated with probability ``pm[i]``; ``pm`` is a scalar (IMGA 0.2) or
    ``float32[P]`` (AGACD, :func:`adaptive_mutation_probability`). ``in_axes_extra`` are
    the vmap axes of ``extra`` (default: all mapped along axis 0). The counterpart of
    :func:`jaxga.operators.crossover.crossover_population`; equal to
    ``over_individuals(with_probability(op))`` but only the mutated individuals are
    computed (:func:`jaxga.operators.lift.over_individuals_gated`). ``n_failed`` counts
    failures of applied mutations only.
    """
    return over_individuals_gated(op, in_axes_extra=in_axes_extra)


def either(op_a: Callable, op_b: Callable) -> Callable:
    """Choose between two operators per individual: ``op_a`` where ``use_a``, else ``op_b``.

    Returns ``wrapped(key, grid, cells, length, use_a, *extra) -> (cells, length,
    failed)``.

    Both operators receive the same key and extras; under ``vmap`` both are evaluated
    (see :func:`with_probability`). With :func:`split_half` this is Zhu & Pan's step 3:
    "randomly selects half of the population to use the one-point mutation and the other
    half to use the range mutation".
    """

    def wrapped(key, grid, cells, length, use_a, *extra):
        ca, la, fa = op_a(key, grid, cells, length, *extra)
        cb, lb, fb = op_b(key, grid, cells, length, *extra)
        return jnp.where(use_a, ca, cb), jnp.where(use_a, la, lb), jnp.where(use_a, fa, fb)

    return wrapped


def pair_with_probability(op: Callable) -> Callable:
    """Gate a pair operator: ``op_p(key, grid, c1, l1, c2, l2, pc, *extra)``.

    With probability ``pc`` (a scalar for this pair) the pair goes through
    ``op(key', grid, c1, l1, c2, l2, *extra)``; otherwise the parents are returned
    unchanged with ``failed = 0``. One uniform per pair decides (``u < pc``), drawn from
    a sub-key independent of the operator's own.
    """

    def op_p(key, grid, c1, l1, c2, l2, pc, *extra):
        k_gate, k_op = jax.random.split(key)
        do = jax.random.uniform(k_gate, (), F32) < jnp.asarray(pc, F32)
        n1, m1, n2, m2, failed = op(k_op, grid, c1, l1, c2, l2, *extra)
        return (
            jnp.where(do, n1, c1), jnp.where(do, m1, l1),
            jnp.where(do, n2, c2), jnp.where(do, m2, l2),
            jnp.where(do, jnp.asarray(failed, I32), 0),
        )

    op_p.__name__ = getattr(op, "__name__", "op") + "_with_probability"
    return op_p


initialise = functools.wraps(initialise_population)(jax.jit(
    initialise_population,
    static_argnames=("init_fn", "size", "capacity", "max_tries", "chunk", "unique", "verify",
                     "fallback"),
))
"""The jitted :func:`initialise_population` (its static arguments: ``init_fn``, ``size``,
``capacity``, ``max_tries``, ``chunk``, ``unique``, ``verify``, ``fallback``). Inside a
traced program, with an ``init_fn`` or ``fallback`` that closes over traced parameters
(the engine's dynamic ``init.slack``), call :func:`initialise_population` itself."""
