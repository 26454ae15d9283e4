"""The multi-population migration model (MPMGA section 2 and 4.4).

Islands are stacked on a leading axis ``I`` (``cells int32[I, P, L]``); one generation is
the single-population generation ``vmap``-ed over islands with per-island rates (see
:func:`jaxga.engine.generation`), then :func:`migrate`, a pure function of the stack.

Topologies (every ``interval`` generations, traced; ``k`` migrants, static):

* ``"ring"``: island ``i`` sends copies of its best ``k`` to island ``i + 1`` (mod I),
  where they replace the worst ``k``;
* ``"star"``: island 0 is the hub: every other island sends its best ``k`` to the hub,
  replacing the hub's worst, and receives the hub's best ``k`` in place of its worst;
* ``"full"``: every island receives the best ``k`` of all the OTHER islands together
  (ranked over their union) in place of its worst ``k``;
* ``"mpmga"`` (MPMGA, ``I = 3``: A elite, B high pc, C high pm): the best ``k`` of B and
  the best ``k`` of C rise into A in place of A's worst ``2k``, those worst of A sink into
  B and C in place of the risen ones, and B and C swap ``k`` random individuals.

All sources are taken from the state before the migration (synchronous), so the order
of islands does not matter and the function is deterministic given its key.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga.core import prng

__all__ = ["migrate"]


def _ranked(fitness: jax.Array, active: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Per island: indices best-first and worst-first among the active individuals."""
    best_first = jnp.argsort(jnp.where(active, -fitness, jnp.inf), axis=-1, stable=True)
    worst_first = jnp.argsort(jnp.where(active, fitness, jnp.inf), axis=-1, stable=True)
    return best_first.astype(jnp.int32), worst_first.astype(jnp.int32)


def _replace(islands, dst: int, dst_idx: jax.Array, src: int, src_idx: jax.Array, old):
    """Copy individuals ``old[src, src_idx]`` into ``islands[dst, dst_idx]``."""
    return jax.tree_util.tree_map(
        lambda new, o: new.at[dst, dst_idx].set(o[src, src_idx]), islands, old
    )


def migrates(config) -> bool:
    """Whether a configuration (a :class:`jaxga.config.schema.Config` or an
    :class:`jaxga.engine.Algorithm`) moves individuals between islands at all: more than
    one island, a topology other than ``"none"`` and at least one migrant."""
    return (int(config.get("islands.count", 1)) > 1
            and config.get("islands.topology") != "none"
            and int(config.get("islands.migrants", 0)) > 0)


def migrate(algo, key: jax.Array, islands, t: jax.Array, active: jax.Array,
            interval: int | jax.Array = 1):
    """Apply the configured migration to the island stack (MPMGA 4.4).

    Args:
        algo: the :class:`jaxga.engine.Algorithm` (topology, migrants: static).
        key: PRNG key (MPMGA's random B-C exchange).
        islands: an ``IslandState`` with leading axis ``I``.
        t: the generation just completed (0-based); migration happens when
            ``(t + 1) % interval == 0``.
        active: ``bool[P]`` active individuals (inactive ones never move).
        interval: generations between migrations (``islands.interval``, >= 1); may be
            traced (the parameter ``islands.interval``: a sweep over it is one program).
    """
    n_isl = algo.islands
    topology = algo.get("islands.topology")
    k = int(algo.get("islands.migrants"))
    if not migrates(algo):
        return islands
    p_active_min = algo.population  # k is checked against the capacity at build time
    if k > p_active_min:
        raise ValueError(f"{k} migrants exceed the population of {p_active_min}")
    best, worst = _ranked(islands.fitness, active[None, :])
    old = islands
    new = islands
    if topology == "ring":
        for i in range(n_isl):
            new = _replace(new, (i + 1) % n_isl, worst[(i + 1) % n_isl, :k], i, best[i, :k], old)
    elif topology == "star":
        for i in range(1, n_isl):
            new = _replace(new, 0, worst[0, (i - 1) * k: i * k], i, best[i, :k], old)
            new = _replace(new, i, worst[i, :k], 0, best[0, :k], old)
    elif topology == "full":
        flat_f = jnp.where(active[None, :], old.fitness, -jnp.inf)
        for i in range(n_isl):
            others = jnp.where(jnp.arange(n_isl)[:, None] == i, -jnp.inf, flat_f).reshape(-1)
            top = jnp.argsort(-others, stable=True)[:k]
            src_isl, src_idx = top // algo.population, top % algo.population
            new = jax.tree_util.tree_map(
                lambda nw, o, i=i, si=src_isl, sx=src_idx, w=worst[i, :k]: nw.at[i, w].set(
                    o[si, sx]), new, old)
    elif topology == "mpmga":
        if n_isl != 3:
            raise ValueError("the mpmga topology needs exactly 3 islands (A, B, C)")
        a_worst_b, a_worst_c = worst[0, :k], worst[0, k: 2 * k]
        new = _replace(new, 0, a_worst_b, 1, best[1, :k], old)   # B's best rise into A
        new = _replace(new, 0, a_worst_c, 2, best[2, :k], old)   # C's best rise into A
        new = _replace(new, 1, best[1, :k], 0, a_worst_b, old)   # A's worst sink into B
        new = _replace(new, 2, best[2, :k], 0, a_worst_c, old)   # ... and into C
        # B and C swap k random active individuals (other than the ones that just moved).
        u = prng.uniform(key, (2, algo.population))
        moved = jnp.zeros((2, algo.population), bool).at[0, best[1, :k]].set(True)
        moved = moved.at[1, best[2, :k]].set(True)
        u = jnp.where(active[None, :] & ~moved, u, jnp.inf)
        pick = jnp.argsort(u, axis=-1)[:, :k]
        rb, rc = pick[0], pick[1]
        new = _replace(new, 1, rb, 2, rc, old)
        new = _replace(new, 2, rc, 1, rb, old)
    else:
        raise ValueError(f"unknown migration topology {topology!r}")
    do = (t + 1) % interval == 0
    return jax.tree_util.tree_map(lambda o, nw: jnp.where(do, nw, o), old, new)
