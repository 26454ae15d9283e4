"""Selection operators: which individuals become parents.

Every selection works on a whole population and has the signature::

    fn(key, fitness f32[P], active bool[P] | None = None, **static) -> idx int32[P]

``idx`` are the indices of the selected individuals; the engine builds the mating pool
with ``cells[idx]``, ``length[idx]``. The functions are pure, jittable and ``vmap``-able
over runs (``jax.vmap(roulette)(keys, fitness[R, P])``); static options (``k`` of
:func:`tournament`, ``bands`` of :func:`stratified`) are bound with
``functools.partial``.

Conventions shared by every selection (decisions where the papers are silent):

* **Fitness** is "larger is better" and non-negative (infeasible individuals have
  fitness 0). For the fitness-proportional parts, negative values and NaN count as 0;
  for ranking, NaN ranks below every number. Subnormal values (below ``1.2e-38``) are
  flushed to 0 by XLA on CPU, so they count as 0 as well.
* **Active mask.** Population-size sweeps use a fixed capacity ``P`` and an ``active``
  mask (docs/python.md, "Sweeps"). Inactive individuals are never selected: EVERY output
  index, also the one written into an inactive slot, is the index of an active individual
  (so a gather never copies padding). Only the entries of active slots carry the selection's
  distribution; the entries of inactive slots are valid but otherwise meaningless
  (:func:`roulette` and :func:`tournament` fill them with further independent draws,
  the rank-based selections with the best individual). With no active individual at all,
  every index is 0.
* **Order.** Crossover pairs consecutive individuals ``(0, 1), (2, 3), ...``
  (:func:`jaxga.operators.lift.over_pairs`), so the output is in random order: roulette and
  tournament draws are i.i.d.; the rank-based selections (:func:`layered_thirds`,
  :func:`stratified`) build their deterministic multiset and then place it on the active
  slots in a uniformly random order. Ties in fitness are broken by the lower index.
* **Randomness.** All random numbers of one call are drawn in bulk from ``key``; same key,
  same result. Uniform integers in ``[0, n)`` are ``bits mod n`` of 32-bit words (bias
  below ``n / 2**32``, i.e. below ``1e-6`` for populations up to 4000).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga.core import prng
from jaxga.core.dtypes import F32, I32
from jaxga.core.errors import ParameterError
from jaxga.core.fields import Field
from jaxga.operators.registry import Operator, register, register_none

__all__ = [
    "layered_thirds",
    "rank_order",
    "roulette",
    "roulette_elite",
    "shuffle",
    "stratified",
    "tournament",
]



# ----------------------------------------------------------------------- helpers
def _prepare(fitness: jax.Array, active: jax.Array | None) -> tuple[jax.Array, jax.Array]:
    fitness = jnp.asarray(fitness, F32)
    if fitness.ndim != 1:
        raise ParameterError(
            f"selection takes fitness of shape (P,), got {fitness.shape}: vmap over runs"
        )
    if active is None:
        active = jnp.ones(fitness.shape, bool)
    else:
        active = jnp.asarray(active, bool)
    return fitness, active


def _weights(fitness: jax.Array, active: jax.Array) -> jax.Array:
    """Roulette weights: fitness clipped at 0 (NaN -> 0) on active individuals, else 0."""
    w = jnp.where(jnp.isnan(fitness), F32(0), jnp.maximum(fitness, F32(0)))
    return jnp.where(active, w, F32(0))


def _roulette_draw(key: jax.Array, weights: jax.Array, eligible: jax.Array, n: int) -> jax.Array:
    """``n`` i.i.d. indices with probability proportional to ``weights``.

    If every weight is 0, uniform over ``eligible``; if nothing is eligible, all 0.
    Inverse-CDF sampling: one cumulative sum and a binary search per draw (O(P log P)).
    A zero-weight individual is never drawn (``side="right"`` on the cumulative sums).
    Weights whose sum overflows float32 are divided by the largest first (an infinite
    one: the infinite ones alone, evenly); the sum overflowed, and every draw took the
    last eligible individual. Other weights are used as they are, bit for bit.
    """
    total = jnp.sum(weights)
    big = ~jnp.isfinite(total)
    top = jnp.max(weights)
    scaled = jnp.where(jnp.isinf(top), (weights == top).astype(F32), weights / top)
    weights = jnp.where(big, scaled, weights)
    total = jnp.where(big, jnp.sum(weights), total)
    w = jnp.where(total > 0, weights, eligible.astype(F32))
    # associative_scan: jnp.cumsum is an O(P^2) reduce_window on CPU.
    cdf = jax.lax.associative_scan(jnp.add, w)
    u = prng.uniform(key, (n,), F32) * cdf[-1]
    idx = jnp.searchsorted(cdf, u, side="right").astype(I32)
    # u * total can round up to total: fall back on the last index with positive weight.
    last = jnp.max(jnp.where(w > 0, jnp.arange(w.shape[0], dtype=I32), 0))
    return jnp.minimum(idx, last)


def rank_order(fitness: jax.Array, active: jax.Array | None = None) -> jax.Array:
    """``int32[P]``: active individuals by decreasing fitness (ties: lower index first),
    then the inactive ones by index. NaN fitness ranks last among the active."""
    fitness, active = _prepare(fitness, active)
    f = jnp.where(jnp.isnan(fitness), -jnp.inf, fitness)
    iota = jnp.arange(f.shape[0], dtype=I32)
    neg = jnp.where(active, -f, 0)  # inactive: by index only
    _, _, order = jax.lax.sort(((~active).astype(I32), neg, iota), num_keys=2)
    return order


def _place_on_active(key: jax.Array, seq: jax.Array, active: jax.Array) -> jax.Array:
    """Write ``seq[:M]`` (M = number of active slots) onto the active slots in a uniformly
    random order and ``seq[M:]`` onto the inactive slots."""
    p = seq.shape[0]
    bits = prng.bits(key, (p,), jnp.uint32)
    iota = jnp.arange(p, dtype=I32)
    _, _, slots = jax.lax.sort(((~active).astype(I32), bits, iota), num_keys=2)
    return jnp.zeros((p,), I32).at[slots].set(seq, unique_indices=True)


# -------------------------------------------------------------------- selections
def roulette(key: jax.Array, fitness: jax.Array, active: jax.Array | None = None) -> jax.Array:
    """Fitness-proportional (roulette-wheel) selection; Zhu & Pan eq. 10, AGACD section 4.5.

    Each of the ``P`` output slots independently draws individual ``i`` with probability
    ``f_i / sum_j f_j`` over the active individuals (``pb(i)`` of Zhu eq. 10). When every
    active fitness is 0 (e.g. an all-infeasible population) the draw is uniform over the
    active individuals. Cost: one cumulative sum and ``P`` binary searches.
    """
    fitness, active = _prepare(fitness, active)
    return _roulette_draw(key, _weights(fitness, active), active, fitness.shape[0])


def roulette_elite(
    key: jax.Array, fitness: jax.Array, active: jax.Array | None = None
) -> jax.Array:
    """Roulette selection plus elitism: Zhu & Pan section 4.3, AGACD section 4.5.

    Zhu & Pan: "the best individual in the previous generation will replace the worst
    individual in the constructed population"; AGACD combines roulette with elite
    selection so that "the best individual" cannot be lost by the roulette. At the index
    level this is, precisely:

    1. ``idx = roulette(key, fitness, active)`` (the constructed population);
    2. the *previous best* ``b`` is the active individual of the INPUT population (the
       previous generation, whose ``fitness`` is passed in) with the highest fitness,
       the lowest index among ties;
    3. the *current worst* is the active output slot ``s`` whose selected individual
       ``idx[s]`` has the lowest fitness (lowest slot among ties);
    4. ``idx[s] = b``. The replacement is unconditional, as in Zhu & Pan (even when
       ``b`` was already drawn, so the best then occupies at least two slots).

    So the best individual is always in the mating pool. jaxga has no further elitism
    step: the crossover and mutation that follow may change it (under ``iga_zhu``,
    common-point children replace their parents at pc 0.8, and pm is 0.4), so a run's
    best of a generation can be lost within it. This is one reading of Zhu & Pan's
    "the best individual in the previous generation will replace the worst individual
    in the constructed population after each iteration is completed": the constructed
    population is the selected one (decision 057 records the reading). Under AGACD,
    eq. 26 and 28 give the best pc = pm = 0 only while the population has not converged
    (``f_max`` above ``f_avg`` by more than a relative tolerance) and no child of the
    crossover is fitter than it (eq. 28's ``f_max`` is taken after crossover); a
    converged population gives it ``pc = pc_low e^(-t/T)`` and
    ``pm = min(1, pm_high e^(t/T))``, so there too the best of a generation may be lost
    within it. A run's best-so-far never drops: the engine keeps it
    apart from the population.
    """
    fitness, active = _prepare(fitness, active)
    idx = roulette(key, fitness, active)
    f = jnp.where(jnp.isnan(fitness), -jnp.inf, fitness)
    best = jnp.argmax(jnp.where(active, f, -jnp.inf)).astype(I32)
    worst_slot = jnp.argmin(jnp.where(active, f[idx], jnp.inf)).astype(I32)
    return jnp.where(jnp.any(active), idx.at[worst_slot].set(best), idx)


def layered_thirds(
    key: jax.Array, fitness: jax.Array, active: jax.Array | None = None
) -> jax.Array:
    """IMGA's layered selection (IMGA section 4.3.1, Figure 4).

    The ``M`` active individuals are sorted by decreasing fitness (ties: lower index
    first) and cut into three layers of ``q = M // 3``: the top layer is copied twice,
    the middle layer once, the bottom layer is dropped, and the remaining ``r = M mod 3``
    places go to the best ``r`` individuals of the bottom part (IMGA: "mod(M/3)
    individuals with high fitness value should be selected from the third layer"). The
    multiset is deterministic (rank ``k`` gets 2, 1, 1 or 0 copies), ``2q + q + r = M``;
    ``key`` only shuffles it onto the active slots so that crossover pairs are random.
    With ``M < 3`` every active individual is copied once.
    """
    fitness, active = _prepare(fitness, active)
    order = rank_order(fitness, active)
    m = jnp.sum(active, dtype=I32)
    q = m // 3
    k = jnp.arange(fitness.shape[0], dtype=I32)
    rank = jnp.where(k < 2 * q, k // 2, k - q)  # top layer twice, then ranks q, q+1, ...
    rank = jnp.where(k < m, rank, 0)  # inactive slots: the best
    return _place_on_active(key, order[rank], active)


def stratified(
    key: jax.Array,
    fitness: jax.Array,
    active: jax.Array | None = None,
    bands: str = "quartile",
) -> jax.Array:
    """Zhang's stratified selection (paper 002, "Stratified Approach").

    The active individuals are divided into four fitness levels A > B > C > D (Zhang eq.
    1); A, B and C are copied once each to the next generation and level D is dropped;
    the freed places are refilled by roulette (fitness-proportional, :func:`roulette`'s
    rule, uniform if all their fitness is 0) over A, B and C.

    ``bands`` (static) says how the four levels are formed:

    * ``"quartile"`` (the default): by rank. With ``M`` active individuals sorted
      by decreasing fitness (ties: lower index first), rank ``r`` belongs to level
      ``floor(4 r / M)``; the ``M // 4`` worst (ranks ``>= M - M // 4``) form level D.
    * ``"value"``: four equal-width fitness intervals between the active minimum and
      maximum; level D is ``f < f_min + (f_max - f_min) / 4`` (nothing is dropped when
      all fitness values are equal). Zhang's remark that "the number of individuals in
      layer A is less than layer B, and layer B is less than C" only makes sense for
      value bands, so this variant is offered; jaxga keeps quartiles as the default.

    The output is shuffled onto the active slots (see the module docstring).
    """
    fitness, active = _prepare(fitness, active)
    p = fitness.shape[0]
    order = rank_order(fitness, active)
    m = jnp.sum(active, dtype=I32)
    if bands == "quartile":
        n_keep = m - m // 4
    elif bands == "value":
        f = jnp.where(jnp.isnan(fitness), -jnp.inf, fitness)
        f_max = jnp.max(jnp.where(active, f, -jnp.inf))
        f_min = jnp.min(jnp.where(active, f, jnp.inf))
        dropped = active & (f < f_min + (f_max - f_min) / 4)
        n_keep = m - jnp.sum(dropped, dtype=I32)
    else:
        raise ParameterError(f"unknown bands {bands!r}: expected 'quartile' or 'value'")
    k = jnp.arange(p, dtype=I32)
    kept_by_rank = k < n_keep
    kept = jnp.zeros((p,), bool).at[order].set(kept_by_rank, unique_indices=True)
    k_fill, k_place = prng.split(key)
    refill = _roulette_draw(k_fill, _weights(fitness, kept), kept, p)
    seq = jnp.where(k < n_keep, order, jnp.where(k < m, refill, order[0]))
    return _place_on_active(k_place, seq, active)


def shuffle(key: jax.Array, fitness: jax.Array, active: jax.Array | None = None) -> jax.Array:
    """No selection pressure, random mates: every active individual exactly once, in a
    uniformly random order over the active slots (the inactive slots, never evaluated,
    hold active individuals too, as every selection's do).

    MPMGA (Hao et al. 2020) section 4.4 replaces selection by migration and does not say how
    crossover pairs are formed; with the slots left in place, slot 2k would always mate with
    slot 2k + 1. The shuffle gives every generation new random pairs (consecutive slots are
    the crossover's pairs) and changes no individual's number of copies.
    """
    fitness, active = _prepare(fitness, active)
    order = jnp.argsort(~active, stable=True).astype(I32)  # active first, by index
    m = jnp.maximum(jnp.sum(active), 1)
    seq = order[jnp.arange(order.shape[0]) % m]  # inactive slots: active ones again
    return _place_on_active(key, seq, active)


def tournament(
    key: jax.Array, fitness: jax.Array, active: jax.Array | None = None, k: int = 2
) -> jax.Array:
    """Tournament selection of size ``k`` (static; bind it with ``functools.partial``).

    Each output slot draws ``k`` active individuals uniformly WITH replacement and takes
    the fittest (ties: the first drawn). With ``M`` active individuals of distinct
    fitness, the individual of rank ``r`` (1 = best) wins a slot with probability
    ``((M - r + 1)**k - (M - r)**k) / M**k``. ``k = 1`` is uniform random selection.
    """
    if not isinstance(k, int) or k < 1:
        raise ParameterError(f"tournament size k must be a positive int, got {k!r}")
    fitness, active = _prepare(fitness, active)
    p = fitness.shape[0]
    iota = jnp.arange(p, dtype=I32)
    _, active_idx = jax.lax.sort(((~active).astype(I32), iota), num_keys=1)
    m = jnp.maximum(jnp.sum(active, dtype=I32), 1)
    bits = prng.bits(key, (p, k), jnp.uint32)
    cand = active_idx[(bits % m.astype(jnp.uint32)).astype(I32)]
    f = jnp.where(jnp.isnan(fitness), -jnp.inf, fitness)
    win = jnp.argmax(f[cand], axis=1)
    return jnp.take_along_axis(cand, win[:, None], axis=1)[:, 0].astype(I32)


# the family's operators (jaxga.operators.registry)
register(Operator("selection", "roulette", roulette,
                  "fitness-proportionate roulette (AGACD 4.5, MPMGA 5.2)"))
register(Operator("selection", "roulette_elite", roulette_elite,
                  "roulette, the previous best replaces the worst (AGACD 4.5, Zhu & Pan 4.3)"))
register(Operator("selection", "layered_thirds", layered_thirds,
                  "top third twice, middle third once (IMGA 4.3.1)"))
register(Operator("selection", "stratified", stratified,
                  "layers A > B > C > D, D dropped, refill by roulette (Zhang eq. 1)"))
register(Operator(
    "selection", "tournament", tournament, "the best of k uniformly drawn individuals",
    params={"selection.tournament_size": Field(int, "tournament size k", low=1, high=1000,
                                               default=2)},
    options=lambda ctx: {"k": int(ctx.config.get("selection.tournament_size"))},
))
register(Operator("selection", "shuffle", shuffle,
                  "no selection pressure, random pairs: each individual once (MPMGA 4.4)"))
register_none("selection", "no selection: individuals keep their slots (fixed pairs 2k, 2k + 1)")
