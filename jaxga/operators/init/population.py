"""A whole population from an initialiser: redraws of failed individuals, the field-walk
fallback for the slots left empty (decision 018), unique chromosomes (IMGA 4.1 (iii)), and
what it did (InitStats)."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core import prng
from jaxga.core.dtypes import F32, I32
from jaxga.core.errors import NoPathError, ParameterError
from jaxga.core.grid import Grid
from jaxga.core.paths import (
    Population,
    has_endpoints,
    is_continuous,
    is_loop_free,
)
from jaxga.operators.init.common import InitFn, check_capacity


# ---------------------------------------------------------------------- population
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class InitStats:
    """What :func:`initialise_population` did (all fields are arrays, so it can leave ``jit``).

    Attributes:
        attempts: int32, candidates drawn (every candidate of every round, including
            successes beyond what was needed).
        successes: int32, candidates for which the initialiser reported ``ok`` (and, with
            ``verify``, the path checked valid).
        success_rate: float32, ``successes / attempts``: the per-attempt success rate
            (Zhu & Pan Table 2 reports it as successes per 100 attempts).
        rounds: int32, rounds of redraws used.
        n_failed: int32, individuals still without a valid path after the last round.
        valid: ``bool[size]``, False for those individuals.
        duplicates: int32, successful candidates rejected as duplicates (``unique``).
        from_fallback: int32, slots filled by the ``fallback`` initialiser (counted in
            neither ``attempts`` nor ``successes``, which describe the initialiser itself).
    """

    attempts: jax.Array
    successes: jax.Array
    success_rate: jax.Array
    rounds: jax.Array
    n_failed: jax.Array
    valid: jax.Array
    duplicates: jax.Array
    from_fallback: jax.Array

    def raise_if_failed(self, allow_partial: bool = False) -> InitStats:
        """Host-side: raise :class:`~jaxga.core.errors.NoPathError` unless the population is valid.

        Raises when no individual was built, and (unless ``allow_partial``) when any is
        missing. Returns ``self`` so that calls can be chained.
        """
        n_failed = int(self.n_failed)
        size = int(np.asarray(self.valid).shape[0])
        if n_failed == size:
            raise NoPathError(
                f"no initial path found in {int(self.attempts)} attempts "
                f"(success rate 0): the goal may be unreachable, the capacity too small "
                f"or the initialiser unsuited to this map"
            )
        if n_failed and not allow_partial:
            raise NoPathError(
                f"{n_failed} of {size} individuals could not be initialised in "
                f"{int(self.attempts)} attempts (success rate "
                f"{float(self.success_rate):.4f}): raise max_tries or the capacity"
            )
        return self


def _valid_path(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    return (
        has_endpoints(grid, cells, length)
        & is_continuous(grid, cells, length)
        & is_loop_free(cells, length, grid.n_cells)
    )


_HASH_A = np.uint32(0x9E3779B1)


_HASH_B = np.uint32(0x85EBCA77)


def _path_hash(cells: jax.Array, length: jax.Array) -> jax.Array:
    """Two 32-bit polynomial hashes of a padded path: ``uint32[2]``."""
    c = cells.astype(jnp.uint32)
    i = jnp.arange(cells.shape[-1], dtype=jnp.uint32)
    ha = jnp.sum((c + jnp.uint32(1)) * (_HASH_A * (i + jnp.uint32(1)) | jnp.uint32(1)),
                 dtype=jnp.uint32)
    hb = jnp.sum((c ^ (i * _HASH_B)) * (_HASH_B + (i << 1) | jnp.uint32(1)), dtype=jnp.uint32)
    return jnp.stack([ha ^ length.astype(jnp.uint32), hb + length.astype(jnp.uint32)])


FALLBACK_STREAM = 0xFFFFFFFF
"""``fold_in`` data of the fallback's key: the rounds use ``fold_in(key, r)`` with ``r``
far below it, so the fallback never draws the numbers of a round."""


def initialise_population(
    key: jax.Array,
    grid: Grid,
    init_fn: InitFn,
    size: int,
    capacity: int,
    max_tries: int | jax.Array = 200,
    chunk: int | None = None,
    unique: bool = False,
    verify: bool = True,
    fallback: InitFn | None = None,
    fallback_on: bool | jax.Array = True,
) -> tuple[Population, InitStats]:
    """A population of ``size`` initial paths, failed individuals redrawn.

    Works in rounds (a ``lax.while_loop`` over rounds, each a ``vmap`` of ``init_fn``
    over ``chunk`` fresh keys): the k-th successful candidate of a round fills the k-th
    still-empty slot, in slot order; rounds stop when every slot is filled or after
    ``ceil(size * max_tries / chunk)`` rounds, i.e. a budget of ``max_tries`` attempts per
    individual on average. With a low success rate, a larger ``chunk`` (e.g.
    ``size / expected_rate``) needs fewer rounds.

    Failure is reported, never hidden: slots still empty after the budget are marked
    ``stats.valid = False`` and counted in ``stats.n_failed``; they hold copies of valid
    individuals (cyclically), so that a GA can run on the population, or the one-cell
    path ``[start]`` if no individual succeeded (not a path to the goal). Call
    ``stats.raise_if_failed()`` on the host to turn a failure into
    :class:`~jaxga.core.errors.NoPathError` (this function runs traced, so it cannot raise on
    traced values itself).

    Args:
        key: PRNG key; the same key gives the same population.
        grid: the map.
        init_fn: static; an initialiser ``(key, grid, capacity) -> (cells, length, ok)``
            (by registered name: :func:`jaxga.operators.registry.initialiser`). Bind options
            with ``functools.partial`` and reuse the same object (a new partial each call
            recompiles).
        size: static population size ``P``.
        capacity: static path capacity ``L``.
        max_tries: average attempts per individual (default 200: enough for
            per-attempt success rates down to about 1 %; rounds stop as soon as the
            population is full, so a generous budget costs nothing when not needed).
            May be traced (an ``int32`` scalar, ``init.max_tries`` of the parameters):
            it only bounds the ``while_loop`` of rounds, so one compiled program serves
            every budget; a concrete value must be >= 1.
        chunk: static candidates per round (default ``size``).
        unique: static; reject candidates identical to an accepted individual (IMGA 4.1
            step (iii): "M nonrepeating chromosomes"). Paths are compared by two 32-bit
            hashes (``O(chunk * (size + chunk))`` comparisons per round); a collision
            only causes an unnecessary redraw. Duplicates count as successes in the
            success rate (the initialiser did find a path) and in ``stats.duplicates``.
        verify: static; check every candidate reported ``ok`` (start, goal, continuous,
            loop-free) and count it as failed otherwise. Cheap, and a guarantee even for
            user-supplied initialisers.
        fallback: static; an initialiser that fills exactly the slots still empty after
            the last round, slot ``i`` with the ``i``-th of ``size`` fallback candidates
            drawn from the key ``fold_in(key, FALLBACK_STREAM)`` (e.g.
            :func:`field_walk`, which cannot fail where a path exists). Slots the rounds
            filled are never touched, so when the rounds fill the population the result
            is the same bit for bit as without a fallback (decision 018).
            ``stats.from_fallback`` counts the slots it filled; candidates are verified
            as the rounds' are (and are not checked for ``unique``).
        fallback_on: whether the ``fallback`` fills anything; may be traced (the flag
            ``init.fallback`` of the parameters: the fallback compiled in, switched on
            and off per run). False leaves every slot as the rounds left it: the result
            of the same call without a fallback, bit for bit.

    Returns:
        ``(Population(cells int32[size, capacity], length int32[size]), InitStats)``.

    ``initialise`` is itself jittable and ``vmap``-able over keys (many seeded runs): the
    rounds then continue until every run's population is full (or the budget is spent).
    The rounds are one plain ``while_loop``: a :func:`jaxga._batching.lanes.lane_while_loop` over
    them saves some run time but nests the initialiser's own compacted loops twice more
    into the program and lengthens its compile (decision 003).
    """
    if not callable(init_fn):
        raise ParameterError(
            f"init_fn must be an initialiser function, got {init_fn!r} (by name: "
            "jaxga.operators.registry.initialiser(name))")
    fn = init_fn
    capacity = check_capacity(capacity)
    traced = isinstance(max_tries, jax.Array)
    if size < 1 or (not traced and max_tries < 1):
        raise ParameterError(f"size and max_tries must be >= 1, got {size}, {max_tries}")
    chunk = size if chunk is None else int(chunk)
    if chunk < 1:
        raise ParameterError(f"chunk must be >= 1, got {chunk}")
    if traced:  # ceil(size * max_tries / chunk) in int32 (at most 1e5 * 1e4: no overflow)
        max_rounds = jnp.maximum(1, (size * jnp.asarray(max_tries, I32) + (chunk - 1)) // chunk)
    else:
        max_rounds = max(1, math.ceil(size * max_tries / chunk))

    def candidates(r):
        keys = prng.split(prng.fold_in(key, r), chunk)
        c, ln, ok = jax.vmap(lambda k: fn(k, grid, capacity))(keys)
        c = c.astype(I32)
        ln = ln.astype(I32)
        if verify:
            ok &= jax.vmap(lambda a, b: _valid_path(grid, a, b))(c, ln)
        return c, ln, ok

    cand_ids = jnp.arange(chunk, dtype=I32)

    def body(state):
        cells, length, hashes, filled, r, attempts, successes, dups = state
        c, ln, ok = candidates(r)
        successes = successes + jnp.sum(ok, dtype=I32)
        if unique:
            h = jax.vmap(_path_hash)(c, ln)
            same_old = jnp.all(h[:, None, :] == hashes[None, :, :], axis=-1) & filled[None, :]
            same_new = (jnp.all(h[:, None, :] == h[None, :, :], axis=-1)
                        & ok[None, :] & (cand_ids[None, :] < cand_ids[:, None]))
            dup = ok & (jnp.any(same_old, axis=1) | jnp.any(same_new, axis=1))
            dups = dups + jnp.sum(dup, dtype=I32)
            ok &= ~dup
        rank = jnp.cumsum(ok, dtype=I32) - 1
        n_ok = jnp.sum(ok, dtype=I32)
        by_rank = jnp.zeros((chunk,), I32).at[jnp.where(ok, rank, chunk)].set(
            cand_ids, mode="drop"
        )
        empty_rank = jnp.cumsum(~filled, dtype=I32) - 1
        take = ~filled & (empty_rank < n_ok)
        src = by_rank[jnp.clip(empty_rank, 0, chunk - 1)]
        cells = jnp.where(take[:, None], c[src], cells)
        length = jnp.where(take, ln[src], length)
        if unique:
            hashes = jnp.where(take[:, None], h[src], hashes)
        return (cells, length, hashes, filled | take, r + 1, attempts + chunk, successes, dups)

    def cond(state):
        filled, r = state[3], state[4]
        return (r < max_rounds) & ~jnp.all(filled)

    state0 = (
        jnp.full((size, capacity), grid.start, I32),
        jnp.ones((size,), I32),
        jnp.zeros((size, 2), jnp.uint32),
        jnp.zeros((size,), bool),
        jnp.int32(0),
        jnp.int32(0),
        jnp.int32(0),
        jnp.int32(0),
    )
    cells, length, _, filled, rounds, attempts, successes, dups = jax.lax.while_loop(
        cond, body, state0
    )
    from_fallback = jnp.int32(0)
    if fallback is not None:
        def fill(args):
            cells, length, filled = args
            keys = prng.split(prng.fold_in(key, FALLBACK_STREAM), size)
            c, ln, ok = jax.vmap(lambda k: fallback(k, grid, capacity))(keys)
            c, ln = c.astype(I32), ln.astype(I32)
            if verify:
                ok &= jax.vmap(lambda a, b: _valid_path(grid, a, b))(c, ln)
            take = ~filled & ok & fallback_on
            return (jnp.where(take[:, None], c, cells), jnp.where(take, ln, length),
                    filled | take)

        # Computed whether or not a slot is empty: under vmap (many runs) a lax.cond would
        # be a select computing both branches anyway, and on a large map its batching
        # multiplied the program's memory many times over (decision 018).
        before = jnp.sum(filled, dtype=I32)
        cells, length, filled = fill((cells, length, filled))
        from_fallback = jnp.sum(filled, dtype=I32) - before
    # Fill the empty slots with copies of valid individuals (flagged invalid).
    n_filled = jnp.sum(filled, dtype=I32)
    filled_ids = jnp.argsort(~filled, stable=True).astype(I32)
    empty_rank = jnp.cumsum(~filled, dtype=I32) - 1
    donor = filled_ids[empty_rank % jnp.maximum(n_filled, 1)]
    use_donor = ~filled & (n_filled > 0)
    cells = jnp.where(use_donor[:, None], cells[donor], cells)
    length = jnp.where(use_donor, length[donor], length)
    stats = InitStats(
        attempts=attempts,
        successes=successes,
        success_rate=successes.astype(F32) / jnp.maximum(attempts, 1).astype(F32),
        rounds=rounds,
        n_failed=size - n_filled,
        valid=filled,
        duplicates=dups,
        from_fallback=from_fallback,
    )
    return Population(cells, length), stats
