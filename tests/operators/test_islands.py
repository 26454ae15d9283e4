"""Migration between islands (MPMGA 4.4): every topology against a plain NumPy
reference written from the module docstring of :mod:`jaxga.operators.islands`."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga.config.presets import load_preset
from jaxga.core.grid import Grid
from jaxga.engine import IslandState, build
from jaxga.operators.islands import migrate

P, L = 8, 5


def _algo(topology: str, islands: int, k: int, interval: int = 1):
    grid = Grid.create(np.zeros((6, 6), bool), (0, 0), (5, 5), corner_rule="free")
    config = load_preset("sga", overrides={
        "population.size": P, "islands.count": islands, "islands.topology": topology,
        "islands.migrants": k, "islands.interval": interval})
    algo, _ = build(config, grid)
    return algo


def _state(islands: int, seed: int, ties: bool = False) -> IslandState:
    """Individual ``(i, j)`` has every cell ``i * P + j``, so a copy shows its source."""
    rng = np.random.default_rng(seed)
    ident = np.arange(islands * P, dtype=np.int32).reshape(islands, P)
    fitness = (rng.integers(0, 3, (islands, P)) if ties
               else rng.permutation(islands * P).reshape(islands, P)).astype(np.float32)
    return IslandState(
        cells=jnp.asarray(np.repeat(ident[..., None], L, axis=2)),
        length=jnp.asarray(rng.integers(1, L + 1, (islands, P)), jnp.int32),
        fitness=jnp.asarray(fitness),
        feasible=jnp.asarray(rng.random((islands, P)) < 0.7),
    )


def _reference(topology: str, k: int, state: IslandState, active: np.ndarray, key):
    """The migration as the docstring states it, one move at a time, in NumPy."""
    old = {f: np.asarray(getattr(state, f)) for f in ("cells", "length", "fitness",
                                                     "feasible")}
    f = old["fitness"]
    n_isl = f.shape[0]
    on = np.flatnonzero(active)

    def best(i):  # active, fitter first, ties by index
        return sorted(on, key=lambda j: (-f[i, j], j))

    def worst(i):
        return sorted(on, key=lambda j: (f[i, j], j))

    moves = []  # (destination island, slots, source islands, slots)
    if topology == "ring":
        for i in range(n_isl):
            d = (i + 1) % n_isl
            moves.append((d, worst(d)[:k], [i] * k, best(i)[:k]))
    elif topology == "star":
        for i in range(1, n_isl):
            moves.append((0, worst(0)[(i - 1) * k: i * k], [i] * k, best(i)[:k]))
            moves.append((i, worst(i)[:k], [0] * k, best(0)[:k]))
    elif topology == "full":
        for i in range(n_isl):
            pool = sorted(((o, j) for o in range(n_isl) if o != i for j in on),
                          key=lambda oj: (-f[oj], oj[0] * P + oj[1]))[:k]
            moves.append((i, worst(i)[:k], [o for o, _ in pool], [j for _, j in pool]))
    elif topology == "mpmga":
        a_worst = worst(0)
        moves += [(0, a_worst[:k], [1] * k, best(1)[:k]),        # B's best rise into A
                  (0, a_worst[k:2 * k], [2] * k, best(2)[:k]),   # C's best rise into A
                  (1, best(1)[:k], [0] * k, a_worst[:k]),        # A's worst sink into B
                  (2, best(2)[:k], [0] * k, a_worst[k:2 * k])]   # ... and into C
        # B and C swap k random active individuals other than those that moved: the
        # draw the docstring specifies (uniform keys, the k smallest).
        u = np.array(jax.random.uniform(key, (2, P)))
        for row, isl in enumerate((1, 2)):
            u[row, best(isl)[:k]] = np.inf
            u[row, ~active] = np.inf
        rb, rc = np.argsort(u, axis=1, kind="stable")[:, :k]
        moves += [(1, list(rb), [2] * k, list(rc)), (2, list(rc), [1] * k, list(rb))]
    new = {name: a.copy() for name, a in old.items()}
    for d, slots, src_isl, src_slots in moves:
        for s, (o, j) in zip(slots, zip(src_isl, src_slots)):
            for name in new:
                new[name][d, s] = old[name][o, j]
    return new


CASES = [("ring", 4, 2), ("ring", 2, 3), ("star", 4, 2), ("full", 3, 3),
         ("mpmga", 3, 2), ("mpmga", 3, 4)]


@pytest.mark.parametrize("ties", [False, True])
@pytest.mark.parametrize("topology,islands,k", CASES)
def test_migration_moves_exactly_what_the_topology_says(topology, islands, k, ties):
    """Every leaf of every island equals the one-move-at-a-time reference, with all
    individuals active and with the last two inactive where the others still hold the
    migrants (inactive ones never move, nor are they replaced); equal fitness values
    rank by index."""
    algo = _algo(topology, islands, k)
    key = jax.random.PRNGKey(7)
    fn = jax.jit(lambda key, s, t, act: migrate(algo, key, s, t, act))
    need = {"star": (islands - 1) * k, "mpmga": 2 * k}.get(topology, k)  # check_migration
    for n_active in (n for n in (P, P - 2) if n >= need):
        state = _state(islands, seed=islands * 10 + k, ties=ties)
        active = np.arange(P) < n_active
        got = fn(key, state, jnp.int32(0), jnp.asarray(active))
        want = _reference(topology, k, state, active, key)
        for name, w in want.items():
            np.testing.assert_array_equal(np.asarray(getattr(got, name)), w, err_msg=name)
        moved = np.asarray(got.cells)[..., 0] != np.asarray(state.cells)[..., 0]
        assert moved.any() and not moved[:, ~active].any()


def test_migration_waits_for_its_interval_and_compiles_to_the_eager_migration():
    """With interval 3 the islands change after generations 2, 5, ... only (t counts
    completed generations from 0); compiled, it moves what it moves eagerly."""
    algo = _algo("mpmga", 3, 2, interval=3)
    state = _state(3, seed=1)
    active = jnp.ones(P, bool)
    key = jax.random.PRNGKey(3)
    fn = jax.jit(lambda t: migrate(algo, key, state, t, active, 3))
    for t in range(6):
        same = np.array_equal(np.asarray(fn(jnp.int32(t)).cells), np.asarray(state.cells))
        assert same == (t % 3 != 2), t
    # the compiled migration is the eager one, move for move
    a, b = fn(jnp.int32(2)), migrate(algo, key, state, jnp.int32(2), active, 3)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_migration_under_vmap_over_runs_equals_each_run_alone():
    """Runs batched by ``vmap`` (as ``jaxga.run`` batches seeds) migrate independently."""
    algo = _algo("star", 3, 2)
    states = [_state(3, seed=s) for s in range(3)]
    batch = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *states)
    keys = jax.random.split(jax.random.PRNGKey(0), 3)
    active = jnp.ones(P, bool)
    got = jax.jit(jax.vmap(lambda k, s: migrate(algo, k, s, jnp.int32(0), active)))(
        keys, batch)
    for r, s in enumerate(states):
        alone = migrate(algo, keys[r], s, jnp.int32(0), active)
        for x, y in zip(jax.tree_util.tree_leaves(got), jax.tree_util.tree_leaves(alone)):
            np.testing.assert_array_equal(np.asarray(x)[r], np.asarray(y))
