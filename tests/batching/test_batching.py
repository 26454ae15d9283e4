"""The gated population helpers compute only the applied individuals and give exactly the
result of the plain (compute everything, then select) formulation."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._batching.numerics import ordered_sum
from jaxga._batching.scatter import true_first_order
from jaxga.core.grid import Grid
from jaxga.core.paths import Population, from_coords, pad
from jaxga.maps import load_map
from jaxga.operators import crossover as cx
from jaxga.operators import mutation as mu
from jaxga.operators.lift import (
    gated_map,
    over_individuals,
    over_individuals_gated,
    over_pairs,
    over_pairs_gated,
    spliced_pairs_map,
    window_width,
    windowed_map,
)
from jaxga.operators.repair import concat
from jaxga.reference.optima import shortest_path
from tests.plain_lifts import either, pair_with_probability, with_probability


@pytest.fixture(scope="module")
def setting():
    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    ref = shortest_path(grid)
    path = [tuple(p) for p in ref.path.tolist()]
    cells, length = from_coords(path, grid.width, 160)
    n = 10
    pop = Population(jnp.tile(jnp.asarray(cells), (n, 1)), jnp.full((n,), length, jnp.int32))
    # diversify: a few rounds of mutation of the optimal path
    mutate = jax.jit(lambda k, p: over_individuals(mu.neighbour_point)(k, grid, p)[0])
    for i in range(3):
        pop = mutate(jax.random.PRNGKey(i), pop)
    return grid, pop


def _same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))


# The map, the population and the probability are arguments (not constants closed over):
# one compiled program serves every parameter of a test.
_GATED_INDIVIDUALS = jax.jit(
    lambda k, g, p, prob: over_individuals_gated(mu.neighbour_point)(k, g, p, prob))
_PLAIN_INDIVIDUALS = jax.jit(
    lambda k, g, p, prob: over_individuals(with_probability(mu.neighbour_point))(
        k, g, p, jnp.full((p.size,), prob)))


@pytest.mark.parametrize("prob", [0.0, 0.35, 1.0])
def test_gated_individuals_equal_compute_all_then_select(setting, prob):
    grid, pop = setting
    key = jax.random.PRNGKey(7)
    assert _same(_GATED_INDIVIDUALS(key, grid, pop, prob),
                 _PLAIN_INDIVIDUALS(key, grid, pop, prob))


def test_gated_alternative_equals_either(setting):
    grid, pop = setting
    key = jax.random.PRNGKey(3)
    use_a = jnp.arange(pop.size) % 3 == 0
    gated = over_individuals_gated(mu.replace_point, alternative=mu.regrow_segment)
    plain = over_individuals(with_probability(either(mu.replace_point, mu.regrow_segment)))
    a = jax.jit(lambda k: gated(k, grid, pop, 0.8, use_a))(key)
    b = jax.jit(lambda k: plain(k, grid, pop, jnp.full((pop.size,), 0.8), use_a))(key)
    assert _same(a, b)


def _either_pair(op_a, op_b):
    def op(key, grid, c1, l1, c2, l2, use_a):
        a = op_a(key, grid, c1, l1, c2, l2)
        b = op_b(key, grid, c1, l1, c2, l2)
        return tuple(jnp.where(use_a, x, y) for x, y in zip(a, b))
    return op


def test_gated_pairs_with_alternative_equal_compute_all(setting):
    grid, pop = setting
    key = jax.random.PRNGKey(5)
    use_a = jnp.arange(pop.size // 2) % 2 == 0

    def swap(key, grid, c1, l1, c2, l2):  # a trivial second operator
        return c2, l2, c1, l1, jnp.int32(0)

    gated = over_pairs_gated(cx.common_point, alternative=swap)
    plain = over_pairs(pair_with_probability(_either_pair(cx.common_point, swap)))
    a = jax.jit(lambda k: gated(k, grid, pop, 0.6, use_a))(key)
    b = jax.jit(lambda k: plain(k, grid, pop, jnp.full((pop.size // 2,), 0.6), use_a))(key)
    assert _same(a, b)


def test_gated_map_under_vmap_and_block_sizes():
    x = jnp.arange(24, dtype=jnp.int32).reshape(2, 12)
    apply = jnp.array([[True, False] * 6, [False] * 11 + [True]])

    def f(v):
        return (v * 10,)

    for block in (1, 4, 5, 12):
        out = jax.vmap(lambda a, v, b=block: gated_map(f, a, (v,), (v,), block=b)[0])(apply, x)
        np.testing.assert_array_equal(out, np.where(apply, np.asarray(x) * 10, x))


@pytest.mark.parametrize("block", [1, 3, 16])
def test_pooled_gated_map_under_nested_vmap_with_closed_over_operands(block):
    """Under two and three ``vmap`` levels the applied entries of all calls are pooled;
    every entry still sees its own call's closed-over values (one batched at every
    level, one at the outer level only, one shared) and gets exactly ``fn`` of its
    arguments; unapplied entries keep their defaults, whatever the dtypes."""
    rng = np.random.default_rng(0)
    a, r, n = 3, 4, 10
    x = jnp.asarray(rng.integers(0, 100, (a, r, n)), jnp.int32)
    y = jnp.asarray(rng.normal(size=(a, r, n, 2)), jnp.float32)
    apply = jnp.asarray(rng.random((a, r, n)) < 0.3).at[0, 1].set(False).at[2, 3].set(True)
    per_call = jnp.asarray(rng.integers(0, 1000, (a, r)), jnp.int32)
    per_outer = jnp.asarray(rng.integers(0, 1000, (a,)), jnp.int32)
    shared = jnp.arange(7, dtype=jnp.int32)

    def call(ap, xs, ys, s, o):
        def f(u, v):
            return u * 3 + s + o + shared[u % 7], v * 2.0
        return gated_map(f, ap, (xs, ys), (-xs, ys), block=block)

    out = jax.jit(jax.vmap(jax.vmap(call, in_axes=(0, 0, 0, 0, None))))(
        apply, x, y, per_call, per_outer)
    want_x = np.where(apply, x * 3 + per_call[..., None] + per_outer[:, None, None]
                      + np.asarray(shared)[np.asarray(x) % 7], -x)
    want_y = np.where(apply[..., None], y * 2.0, y)
    np.testing.assert_array_equal(out[0], want_x)
    np.testing.assert_array_equal(out[1], want_y)
    # three levels: the same calls split into an extra level
    out3 = jax.jit(jax.vmap(jax.vmap(jax.vmap(call, in_axes=(0, 0, 0, 0, None)),
                                     in_axes=(0, 0, 0, 0, None))))(
        apply.reshape(a, 2, 2, n), x.reshape(a, 2, 2, n), y.reshape(a, 2, 2, n, 2),
        per_call.reshape(a, 2, 2), per_outer)
    np.testing.assert_array_equal(out3[0].reshape(a, r, n), want_x)


def test_pooled_mutation_of_many_runs_equals_each_run_alone(setting):
    """The mutation of 6 runs in one ``vmap`` (the applied individuals of all runs pooled,
    the connections' rounds compacted) equals each run's mutation computed alone."""
    grid, pop = setting
    keys = jax.random.split(jax.random.PRNGKey(2), 6)
    probs = jnp.array([0.0, 0.2, 0.5, 1.0, 0.35, 0.9], jnp.float32)
    batched = jax.vmap(lambda k, p: _GATED_INDIVIDUALS(k, grid, pop, p))(keys, probs)
    for i in range(6):
        alone = _GATED_INDIVIDUALS(keys[i], grid, pop, probs[i])
        assert _same(jax.tree.map(lambda v, i=i: v[i], batched), alone)


_DENSE_PAIRS = jax.jit(
    lambda k, g, p, prob: cx.crossover_population(cx.common_point, dense=True)(k, g, p, prob))
_GATED_PAIRS = jax.jit(
    lambda k, g, p, prob: cx.crossover_population(cx.common_point)(k, g, p, prob))
_PLAIN_PAIRS = jax.jit(
    lambda k, g, p, prob: over_pairs(pair_with_probability(cx.common_point))(
        k, g, p, jnp.full((p.size // 2,), prob)))


@pytest.mark.parametrize("prob", [0.0, 0.8, 1.0])
def test_dense_pairs_equal_gated_pairs_and_compute_all(setting, prob):
    """``dense=True`` (every pair computed, then selected) gives the gated result."""
    grid, pop = setting
    key = jax.random.PRNGKey(11)
    dense = _DENSE_PAIRS(key, grid, pop, prob)
    gated = _GATED_PAIRS(key, grid, pop, prob)
    plain = _PLAIN_PAIRS(key, grid, pop, prob)
    assert _same(dense, gated) and _same(dense, plain)
    if prob == 0.0:
        assert _same(dense[0], pop)


def test_dense_gated_map_under_vmap():
    x = jnp.arange(24, dtype=jnp.int32).reshape(2, 12)
    apply = jnp.array([[True, False] * 6, [False] * 11 + [True]])
    out = jax.vmap(lambda a, v: gated_map(lambda u: (u * 10,), a, (v,), (v,), dense=True)[0])(
        apply, x)
    np.testing.assert_array_equal(out, np.where(apply, np.asarray(x) * 10, x))


@pytest.mark.parametrize("n", [1, 2, 61, 9540])
def test_true_first_order_is_the_stable_argsort(n):
    """The gate order of gated_map: True entries first, each group in index order,
    exactly ``argsort(~flags, stable=True)``, also under vmap; all-False and all-True rows
    included."""
    rng = np.random.default_rng(n)
    flags = rng.random((6, n)) < np.array([0.0, 0.03, 0.5, 0.97, 1.0, 0.3])[:, None]
    got = np.asarray(jax.jit(jax.vmap(true_first_order))(jnp.asarray(flags)))
    want = np.argsort(~flags, axis=1, kind="stable")
    assert got.dtype == np.int32 and np.array_equal(got, want)


# ------------------------------------------------------------------- windowed_map
def _segment_sum(scale):
    """A width-agnostic row function (reads ``length`` cells, ordered float sum)."""

    def fn(c, n):
        x, y = (c % 7).astype(jnp.float32), (c // 7).astype(jnp.float32)
        seg = jnp.sqrt(jnp.diff(x) ** 2 + jnp.diff(y) ** 2 + 0.1) * scale
        seg = jnp.where(jnp.arange(c.shape[0] - 1) < n - 1, seg, 0.0)
        return ordered_sum(seg), jnp.max(jnp.where(jnp.arange(c.shape[0]) < n, c, -1))

    return fn


def _rows(key, shape, longest):
    k1, k2 = jax.random.split(key)
    cells = jax.random.randint(k1, shape + (160,), 0, 49, jnp.int32)
    length = jax.random.randint(k2, shape, 1, longest + 1, jnp.int32)
    return cells, length


@pytest.mark.parametrize("longest", [64, 65, 160])
@pytest.mark.parametrize("depth", [0, 1, 2])
def test_windowed_map_is_vmap_bit_for_bit(depth, longest):
    """Narrow (every path fits 64 cells) and full-width batches, under 0-2 vmap levels,
    with a closed-over per-run scale: exactly ``vmap(fn)``'s bits."""
    shape = ((3, 2) if depth == 2 else (4,) if depth == 1 else ())
    cells, length = _rows(jax.random.PRNGKey(longest), shape + (9,), longest)
    scale = jnp.linspace(0.5, 2.0, int(np.prod(shape, dtype=int))).reshape(shape)

    def windowed(c, n, s):
        return windowed_map(_segment_sum(s), c, n)

    def plain(c, n, s):
        return jax.vmap(_segment_sum(s))(c, n)

    for _ in range(depth):
        windowed, plain = jax.vmap(windowed), jax.vmap(plain)
    got = jax.jit(windowed)(cells, length, scale)
    want = jax.jit(plain)(cells, length, scale)
    for g, w in zip(got, want):
        assert g.shape == w.shape and g.dtype == w.dtype
        np.testing.assert_array_equal(np.asarray(g), np.asarray(w))


def test_windowed_map_picks_one_width_for_the_whole_folded_batch():
    """The width is chosen once for all runs: narrow only when the batch's longest path
    fits the window (a row function that reports its width shows which ran)."""
    assert window_width(160) == 64 and window_width(400) == 256 and window_width(2) == 1

    def width(c, n):
        return (jnp.int32(c.shape[0]),)

    run = jax.jit(jax.vmap(lambda c, n: windowed_map(width, c, n)[0]))
    cells, length = _rows(jax.random.PRNGKey(0), (3, 5), 64)
    assert np.all(np.asarray(run(cells, length)) == 64)
    assert np.all(np.asarray(run(cells, length.at[2, 4].set(65))) == 160)


def _assert_narrow_equals_wide(lift, probs, keys, cells, length):
    """``lift(narrow, prob)``: a jitted population operator vmapped over runs, with the
    window on or off. Both give the same leaves for every run, and run 0 alone gives
    the same as in the batch; the operator changed some lengths."""
    for prob in probs:
        got = lift(True, prob)(keys, cells, length)
        want = lift(False, prob)(keys, cells, length)
        alone = lift(True, prob)(keys[:1], cells[:1], length[:1])
        for g, w, a in zip(jax.tree_util.tree_leaves(got), jax.tree_util.tree_leaves(want),
                           jax.tree_util.tree_leaves(alone)):
            np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
            np.testing.assert_array_equal(np.asarray(a)[0], np.asarray(w)[0])
        assert int(jnp.sum(got[0].length != length)) > 0  # the operator did something


def _head_tail(k, c1, l1, c2, l2):
    """A splicing pair operator: children ``c1[:l1 - 1] + c2[:l2]`` and ``c2[:1] +
    c1[r:l1]`` (``r`` random), up to ``l1 + l2 - 1`` cells, and which width it ran at."""
    cap = c1.shape[0]
    r = jax.random.randint(k, (), 1, jnp.maximum(l1, 2))
    a, la, ok_a = concat([(c1, 0, l1 - 1), (c2, 0, l2)], cap)
    b, lb, ok_b = concat([(c2, 0, 1), (c1, r, l1)], cap)
    return a, la, b, lb, (~ok_a).astype(jnp.int32) + (~ok_b), jnp.int32(cap)


@pytest.mark.parametrize("longest", [64, 65])
@pytest.mark.parametrize("depth", [0, 1, 2])
def test_spliced_pairs_map_is_vmap_bit_for_bit(depth, longest):
    """Parents that fit 64 cells are spliced on 128 (children up to 127 cells, re-padded
    with their last cell), a batch with one longer parent at full width: under 0-2 vmap
    levels exactly ``vmap(fn)``'s children, lengths and failure counts."""
    shape = (3, 2) if depth == 2 else (4,) if depth == 1 else ()
    c1, l1 = _rows(jax.random.PRNGKey(longest), shape + (9,), longest)
    c2, l2 = _rows(jax.random.PRNGKey(longest + 1), shape + (9,), 64)
    l1 = l1.reshape(-1).at[-1].set(longest).reshape(l1.shape)  # one parent of `longest`
    lead = c1.shape[:-1]
    c1 = jax.vmap(pad)(c1.reshape(-1, 160), l1.reshape(-1)).reshape(c1.shape)
    c2 = jax.vmap(pad)(c2.reshape(-1, 160), l2.reshape(-1)).reshape(c2.shape)
    keys = jax.random.split(jax.random.PRNGKey(7), int(np.prod(lead))).reshape(lead + (2,))

    def spliced(*a):
        return spliced_pairs_map(_head_tail, a)

    def plain(*a):
        return jax.vmap(_head_tail)(*a)

    for _ in range(depth):
        spliced, plain = jax.vmap(spliced), jax.vmap(plain)
    got = jax.jit(spliced)(keys, c1, l1, c2, l2)
    want = jax.jit(plain)(keys, c1, l1, c2, l2)
    for g, w in zip(got[:5], want[:5]):
        assert g.shape == w.shape and g.dtype == w.dtype
        np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
    width = np.asarray(got[5])
    assert np.all(width == (128 if longest <= 64 else 160))
    assert int(jnp.max(got[1])) > 64 and int(jnp.sum(got[4])) == 0  # long children fit


def _common_point_lift(grid):
    """``lift(splicing, pc)``: the dense common-point crossover of runs under vmap."""

    def lift(splicing, pc):
        f = cx.crossover_population(cx.common_point, dense=True, splicing=splicing)
        return jax.jit(jax.vmap(lambda k, c, n: f(k, grid, Population(c, n), pc)))

    return lift


def test_spliced_common_point_crossover_equals_full_width(setting):
    """The engine's common-point crossover with ``splicing=True`` (parents of at most 64
    cells: computed on 128) gives the children, lengths and failure counts of the plain
    dense crossover, for 3 runs under vmap and for one alone, at pc 0.8 and 1."""
    grid, pop = setting
    assert int(jnp.max(pop.length)) <= 64
    rng = np.random.default_rng(3)
    order = jnp.asarray(np.stack([rng.permutation(pop.size) for _ in range(3)]))
    cells, length = pop.cells[order], pop.length[order]
    keys = jax.random.split(jax.random.PRNGKey(5), 3)

    _assert_narrow_equals_wide(_common_point_lift(grid), (0.8, 1.0), keys, cells, length)
    with pytest.raises(ValueError, match="splicing"):
        over_pairs_gated(cx.common_point, splicing=True)


def _serpentine(n, by_column=False, rows_from=0):
    """The first ``n`` cells of a boustrophedon over an open 20 x 20 map (rows from row
    ``rows_from`` up, or columns from the left): continuous and loop-free."""
    xy = [(x if y % 2 == 0 else 19 - x, y) for y in range(rows_from, 20) for x in range(20)]
    return [(y, x) for x, y in xy[:n]] if by_column else xy[:n]


@pytest.mark.parametrize("longest", [64, 80])
def test_spliced_common_point_long_children_and_wide_batches(longest):
    """Parents of at most 64 cells whose one common cell is near the end of the first
    and at the start of the second give a child of 125 cells (spliced on 128); with one
    parent of 80 cells the whole folded batch runs at 160. Either way the children,
    lengths and failure counts equal the plain dense crossover's."""
    grid = Grid.create(np.zeros((20, 20), bool), (0, 0), (19, 19), corner_rule="free")
    rows_0_3 = _serpentine(64)  # ends (17, 3), (16, 3)
    after = [(16, 4), (17, 3), (18, 4), (19, 4)] + _serpentine(60, rows_from=5)
    pairs = [(rows_0_3, after), (_serpentine(50), _serpentine(64, by_column=True)),
             (_serpentine(64, by_column=True), _serpentine(37)),
             (_serpentine(longest), _serpentine(61, by_column=True))]
    runs = [pairs[:3], pairs[1:], pairs[2:] + pairs[:1]]
    paths = [[from_coords(p, 20, 160) for pair in run for p in pair] for run in runs]
    cells = jnp.asarray(np.array([[c for c, _ in r] for r in paths]), jnp.int32)
    length = jnp.asarray([[n for _, n in r] for r in paths], jnp.int32)
    keys = jax.random.split(jax.random.PRNGKey(longest), 3)

    lift = _common_point_lift(grid)
    _assert_narrow_equals_wide(lift, (1.0,), keys, cells, length)
    assert int(lift(True, 1.0)(keys, cells, length)[0].length[0, 0]) == 125


@pytest.mark.parametrize("preset", ["sga", "imga", "agacd", "mpmga", "iga_zhu", "iga_zhang"])
def test_engine_evaluation_in_the_window_equals_full_width(setting, preset):
    """Every fitness function gives the same bits on the 64-cell window as on the full
    160 cells (``fitness.window`` on and off; a population of short paths, some made
    discontinuous)."""
    from jaxga.config.presets import load_preset
    from jaxga.engine import build, evaluate, uses_waypoints

    grid, pop = setting
    # waypoint presets (agacd; iga_zhang's eq. 5 deletions) have no window: their
    # grid-step variants
    over = ({"crossover.method": "common_point", "mutation.method": "neighbour_point"}
            if uses_waypoints(load_preset(preset)) else {})
    cells = pop.cells.at[1, 5].set(pop.cells[1, 20])  # a jump: infeasible
    active = jnp.arange(cells.shape[0]) < 9
    out = []
    for window in (True, False):
        algo, params = build(load_preset(preset, overrides={**over, "fitness.window": window}),
                             grid)
        assert not algo.waypoints and int(jnp.max(pop.length)) <= 64
        ev = functools.partial(evaluate, algo, grid, params)
        out.append(jax.jit(ev)(cells, pop.length, active))
    narrow, wide = out
    assert not bool(narrow[1][1]) and bool(narrow[1][0])
    for a, b in zip(narrow, wide):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@pytest.mark.parametrize("op", [mu.cut_corners, "simplify_adjacent"])
@pytest.mark.parametrize("longest", [40, 80, 160])
def test_shrinking_gated_operator_on_the_window_equals_full_width(setting, op, longest):
    """``shrinking=True`` (blocks whose paths fit 64 cells run on them, the others at full
    width) gives exactly the cells, lengths and failure counts of the full-width gated
    operator, alone and under vmap over 3 runs, with probability 0.35 and 1."""
    from jaxga.operators.postprocess import simplify_adjacent

    op = simplify_adjacent if op == "simplify_adjacent" else op
    grid, _ = setting
    free = np.flatnonzero(~np.asarray(grid.blocked).reshape(-1))
    rng = np.random.default_rng(longest)
    cells = jnp.asarray(free[rng.integers(0, free.size, (3, 20, 160))], jnp.int32)
    length = jnp.asarray(rng.integers(1, longest + 1, (3, 20)), jnp.int32)
    length = length.at[1].set(jnp.minimum(length[1], 64))  # one run always narrow
    cells = jax.vmap(jax.vmap(pad))(cells, length)
    keys = jax.random.split(jax.random.PRNGKey(longest), 3)

    def lift(shrinking, prob):
        f = over_individuals_gated(op, shrinking=shrinking)
        return jax.jit(jax.vmap(lambda k, c, n: f(k, grid, Population(c, n), prob)))

    _assert_narrow_equals_wide(lift, (0.35, 1.0), keys, cells, length)
