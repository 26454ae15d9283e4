"""The gated population helpers compute only the applied individuals and give exactly the
result of the plain (compute everything, then select) formulation.

Compiled programs: every program is jitted once at module level with the maps,
populations, probabilities and keys as arguments (not closed over), and each computes
both sides of its comparison (the gated or windowed result and the plain one, a batch
and its run alone), so that a test's parameters share one program. Test data is built
with NumPy or inside those programs, not with eager ``jnp`` calls."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._batching.numerics import ordered_sum
from jaxga._batching.scatter import true_first_order, true_first_positions
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
from jaxga.operators.postprocess import simplify_adjacent
from jaxga.operators.repair import concat
from jaxga.reference.optima import shortest_path
from tests.plain_lifts import either, pair_with_probability, with_probability

# the gated and spliced batching against full width, operator by operator
pytestmark = pytest.mark.slow


@jax.jit
def _diversified(grid, pop):
    """A few rounds of mutation of the optimal path (keys ``PRNGKey(0..2)``)."""
    for i in range(3):
        pop = over_individuals(mu.neighbour_point)(jax.random.PRNGKey(i), grid, pop)[0]
    return pop


@pytest.fixture(scope="module")
def setting():
    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    ref = shortest_path(grid)
    path = [tuple(p) for p in ref.path.tolist()]
    cells, length = from_coords(path, grid.width, 160)
    n = 10
    pop = Population(jnp.asarray(np.tile(np.asarray(cells), (n, 1))),
                     jnp.asarray(np.full((n,), int(length), np.int32)))
    return grid, _diversified(grid, pop)


def _same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))


def _host(tree):
    return jax.tree.map(np.asarray, tree)


# The map, the population, the probability and the key are arguments (not constants
# closed over): one compiled program serves every parameter of a test.
@jax.jit
def _individuals(k, g, p, prob):
    """``(gated, plain)``: the gated mutation and the compute-all-then-select one."""
    gated = over_individuals_gated(mu.neighbour_point)(k, g, p, prob)
    plain = over_individuals(with_probability(mu.neighbour_point))(
        k, g, p, jnp.full((p.size,), prob))
    return gated, plain


@pytest.mark.parametrize("prob", [0.0, 0.35, 1.0])
def test_gated_individuals_equal_compute_all_then_select(setting, prob):
    grid, pop = setting
    key = jax.random.PRNGKey(7)
    gated, plain = _individuals(key, grid, pop, prob)
    assert _same(gated, plain)


@jax.jit
def _alternative_individuals(k, g, p, use_a):
    gated = over_individuals_gated(mu.replace_point, alternative=mu.regrow_segment)
    plain = over_individuals(with_probability(either(mu.replace_point, mu.regrow_segment)))
    return gated(k, g, p, 0.8, use_a), plain(k, g, p, jnp.full((p.size,), 0.8), use_a)


def test_gated_alternative_equals_either(setting):
    grid, pop = setting
    key = jax.random.PRNGKey(3)
    use_a = np.arange(pop.size) % 3 == 0
    a, b = _alternative_individuals(key, grid, pop, use_a)
    assert _same(a, b)


def _either_pair(op_a, op_b):
    def op(key, grid, c1, l1, c2, l2, use_a):
        a = op_a(key, grid, c1, l1, c2, l2)
        b = op_b(key, grid, c1, l1, c2, l2)
        return tuple(jnp.where(use_a, x, y) for x, y in zip(a, b))
    return op


def _swap(key, grid, c1, l1, c2, l2):  # a trivial second operator
    return c2, l2, c1, l1, jnp.int32(0)


@jax.jit
def _alternative_pairs(k, g, p, use_a):
    gated = over_pairs_gated(cx.common_point, alternative=_swap)
    plain = over_pairs(pair_with_probability(_either_pair(cx.common_point, _swap)))
    return (gated(k, g, p, 0.6, use_a),
            plain(k, g, p, jnp.full((p.size // 2,), 0.6), use_a))


def test_gated_pairs_with_alternative_equal_compute_all(setting):
    grid, pop = setting
    key = jax.random.PRNGKey(5)
    use_a = np.arange(pop.size // 2) % 2 == 0
    a, b = _alternative_pairs(key, grid, pop, use_a)
    assert _same(a, b)


# ----------------------------------------------------------------------- gated_map
_X = np.arange(24, dtype=np.int32).reshape(2, 12)
_APPLY = np.array([[True, False] * 6, [False] * 11 + [True]])
_BLOCKS = (1, 4, 5, 12)


def _times_ten(v):
    return (v * 10,)


@jax.jit
def _gated_map_variants(apply, x):
    """``gated_map`` under ``vmap`` with each of :data:`_BLOCKS`, then ``dense=True``."""
    out = [jax.vmap(lambda a, v, b=block: gated_map(_times_ten, a, (v,), (v,), block=b)[0])(
        apply, x) for block in _BLOCKS]
    out.append(jax.vmap(lambda a, v: gated_map(_times_ten, a, (v,), (v,), dense=True)[0])(
        apply, x))
    return out


def test_gated_map_under_vmap_and_block_sizes():
    outs = _gated_map_variants(_APPLY, _X)
    for out in outs[:len(_BLOCKS)]:
        np.testing.assert_array_equal(out, np.where(_APPLY, _X * 10, _X))


_POOL_BLOCKS = (1, 3, 16)
_SHARED = np.arange(7, dtype=np.int32)


def _pooled_call(block):
    def call(ap, xs, ys, s, o):
        def f(u, v):
            return u * 3 + s + o + jnp.asarray(_SHARED)[u % 7], v * 2.0
        return gated_map(f, ap, (xs, ys), (-xs, ys), block=block)
    return call


@jax.jit
def _pooled(apply, x, y, per_call, per_outer):
    """For each of :data:`_POOL_BLOCKS`: ``gated_map`` under two ``vmap`` levels, and the
    same calls split into three levels."""
    a, r, n = x.shape
    out = []
    for block in _POOL_BLOCKS:
        call = _pooled_call(block)
        two = jax.vmap(jax.vmap(call, in_axes=(0, 0, 0, 0, None)))(
            apply, x, y, per_call, per_outer)
        three = jax.vmap(jax.vmap(jax.vmap(call, in_axes=(0, 0, 0, 0, None)),
                                  in_axes=(0, 0, 0, 0, None)))(
            apply.reshape(a, 2, 2, n), x.reshape(a, 2, 2, n), y.reshape(a, 2, 2, n, 2),
            per_call.reshape(a, 2, 2), per_outer)
        out.append((two, three))
    return out


@pytest.fixture(scope="module")
def pooled():
    """The inputs of the pooled ``gated_map`` test and :func:`_pooled`'s results, by block."""
    rng = np.random.default_rng(0)
    a, r, n = 3, 4, 10
    x = rng.integers(0, 100, (a, r, n)).astype(np.int32)
    y = rng.normal(size=(a, r, n, 2)).astype(np.float32)
    apply = rng.random((a, r, n)) < 0.3
    apply[0, 1] = False
    apply[2, 3] = True
    per_call = rng.integers(0, 1000, (a, r)).astype(np.int32)
    per_outer = rng.integers(0, 1000, (a,)).astype(np.int32)
    out = _host(_pooled(apply, x, y, per_call, per_outer))
    return (apply, x, y, per_call, per_outer), dict(zip(_POOL_BLOCKS, out))


@pytest.mark.parametrize("block", _POOL_BLOCKS)
def test_pooled_gated_map_under_nested_vmap_with_closed_over_operands(pooled, block):
    """Under two and three ``vmap`` levels the applied entries of all calls are pooled;
    every entry still sees its own call's closed-over values (one batched at every
    level, one at the outer level only, one shared) and gets exactly ``fn`` of its
    arguments; unapplied entries keep their defaults, whatever the dtypes."""
    (apply, x, y, per_call, per_outer), results = pooled
    a, r, n = x.shape
    out, out3 = results[block]
    want_x = np.where(apply, x * 3 + per_call[..., None] + per_outer[:, None, None]
                      + _SHARED[x % 7], -x)
    want_y = np.where(apply[..., None], y * 2.0, y)
    np.testing.assert_array_equal(out[0], want_x)
    np.testing.assert_array_equal(out[1], want_y)
    # three levels: the same calls split into an extra level
    np.testing.assert_array_equal(out3[0].reshape(a, r, n), want_x)


@jax.jit
def _gated_individuals_of_runs(key, g, p, probs):
    """``(keys, mutation)``: the gated mutation of ``len(probs)`` runs under ``vmap``, run
    ``i`` with key ``split(key)[i]`` and probability ``probs[i]``."""
    keys = jax.random.split(key, probs.shape[0])
    mutate = over_individuals_gated(mu.neighbour_point)
    return keys, jax.vmap(mutate, in_axes=(0, None, None, 0))(keys, g, p, probs)


def test_pooled_mutation_of_many_runs_equals_each_run_alone(setting):
    """The mutation of 6 runs in one ``vmap`` (the applied individuals of all runs pooled,
    the connections' rounds compacted) equals each run's mutation computed alone."""
    grid, pop = setting
    probs = np.array([0.0, 0.2, 0.5, 1.0, 0.35, 0.9], np.float32)
    keys, batched = _host(_gated_individuals_of_runs(jax.random.PRNGKey(2), grid, pop, probs))
    for i in range(6):
        # the program of test_gated_individuals_equal_compute_all_then_select
        alone, _ = _individuals(keys[i], grid, pop, float(probs[i]))
        assert _same(jax.tree.map(lambda v, i=i: v[i], batched), alone)


@jax.jit
def _pairs(k, g, p, prob):
    """``(dense, gated, plain)`` common-point crossovers of the population."""
    dense = cx.crossover_population(cx.common_point, dense=True)(k, g, p, prob)
    gated = cx.crossover_population(cx.common_point)(k, g, p, prob)
    plain = over_pairs(pair_with_probability(cx.common_point))(
        k, g, p, jnp.full((p.size // 2,), prob))
    return dense, gated, plain


@pytest.mark.parametrize("prob", [0.0, 0.8, 1.0])
def test_dense_pairs_equal_gated_pairs_and_compute_all(setting, prob):
    """``dense=True`` (every pair computed, then selected) gives the gated result."""
    grid, pop = setting
    key = jax.random.PRNGKey(11)
    dense, gated, plain = _pairs(key, grid, pop, prob)
    assert _same(dense, gated) and _same(dense, plain)
    if prob == 0.0:
        assert _same(dense[0], pop)


def test_dense_gated_map_under_vmap():
    out = _gated_map_variants(_APPLY, _X)[-1]  # the program of the block sizes' test
    np.testing.assert_array_equal(out, np.where(_APPLY, _X * 10, _X))


_ORDER_SIZES = (1, 2, 61, 9540)


@pytest.fixture(scope="module")
def true_first_orders():
    """For each of :data:`_ORDER_SIZES`: the flags and ``vmap(true_first_order)`` and
    ``vmap(true_first_positions)`` of them, all computed by one program."""
    flags = []
    for n in _ORDER_SIZES:
        rng = np.random.default_rng(n)
        flags.append(rng.random((6, n)) < np.array([0.0, 0.03, 0.5, 0.97, 1.0, 0.3])[:, None])
    got = jax.jit(lambda fs: [(jax.vmap(true_first_order)(f), jax.vmap(true_first_positions)(f))
                              for f in fs])(flags)
    return dict(zip(_ORDER_SIZES, zip(flags, _host(got))))


@pytest.mark.parametrize("n", _ORDER_SIZES)
def test_true_first_order_is_the_stable_argsort(true_first_orders, n):
    """The gate order of gated_map: True entries first, each group in index order,
    exactly ``argsort(~flags, stable=True)``, also under vmap; all-False and all-True rows
    included."""
    flags, (got, _) = true_first_orders[n]
    want = np.argsort(~flags, axis=1, kind="stable")
    assert got.dtype == np.int32 and np.array_equal(got, want)


@pytest.mark.parametrize("n", _ORDER_SIZES)
def test_true_first_positions_are_the_inverse_of_the_order(true_first_orders, n):
    """``positions[order[j]] == j`` for every ``j``: where each entry lands, as the
    compacted loops use it to merge their lanes back by a gather."""
    flags, (order, positions) = true_first_orders[n]
    want = np.argsort(np.argsort(~flags, axis=1, kind="stable"), axis=1, kind="stable")
    assert positions.dtype == np.int32 and np.array_equal(positions, want)
    assert np.array_equal(np.take_along_axis(positions, order, axis=1),
                          np.broadcast_to(np.arange(n), flags.shape))


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


_DEPTHS = (0, 1, 2)


def _runs_shape(depth):
    """The vmap levels' shape of a test at ``depth`` levels."""
    return (3, 2) if depth == 2 else (4,) if depth == 1 else ()


@jax.jit
def _windowed_cases(longest):
    """For each depth of :data:`_DEPTHS`: ``(windowed_map, vmap)`` of rows drawn with key
    ``PRNGKey(longest)``, paths up to ``longest`` cells, a per-run scale."""
    out = []
    for depth in _DEPTHS:
        shape = _runs_shape(depth)
        cells, length = _rows(jax.random.PRNGKey(longest), shape + (9,), longest)
        scale = jnp.linspace(0.5, 2.0, int(np.prod(shape, dtype=int))).reshape(shape)

        def windowed(c, n, s):
            return windowed_map(_segment_sum(s), c, n)

        def plain(c, n, s):
            return jax.vmap(_segment_sum(s))(c, n)

        for _ in range(depth):
            windowed, plain = jax.vmap(windowed), jax.vmap(plain)
        out.append((windowed(cells, length, scale), plain(cells, length, scale)))
    return out


_WINDOWED_LONGEST = (64, 65, 160)


@pytest.fixture(scope="module")
def windowed_results():
    """:func:`_windowed_cases`'s results by ``longest`` (one program for all)."""
    return {longest: _host(_windowed_cases(longest)) for longest in _WINDOWED_LONGEST}


@pytest.mark.parametrize("longest", _WINDOWED_LONGEST)
@pytest.mark.parametrize("depth", _DEPTHS)
def test_windowed_map_is_vmap_bit_for_bit(windowed_results, depth, longest):
    """Narrow (every path fits 64 cells) and full-width batches, under 0-2 vmap levels,
    with a closed-over per-run scale: exactly ``vmap(fn)``'s bits."""
    got, want = windowed_results[longest][depth]
    for g, w in zip(got, want):
        assert g.shape == w.shape and g.dtype == w.dtype
        np.testing.assert_array_equal(g, w)


def _width(c, n):
    return (jnp.int32(c.shape[0]),)


@jax.jit
def _widths(key):
    """The width ``windowed_map`` ran at for 3 runs of 5 paths of at most 64 cells, and
    for the same with one path of 65 cells."""
    run = jax.vmap(lambda c, n: windowed_map(_width, c, n)[0])
    cells, length = _rows(key, (3, 5), 64)
    return run(cells, length), run(cells, length.at[2, 4].set(65))


def test_windowed_map_picks_one_width_for_the_whole_folded_batch():
    """The width is chosen once for all runs: narrow only when the batch's longest path
    fits the window (a row function that reports its width shows which ran)."""
    assert window_width(160) == 64 and window_width(400) == 256 and window_width(2) == 1
    narrow, wide = _widths(jax.random.PRNGKey(0))
    assert np.all(np.asarray(narrow) == 64)
    assert np.all(np.asarray(wide) == 160)


def _assert_narrow_equals_wide(results, length):
    """``results``: for each probability, a population operator's ``(narrow, wide,
    alone)`` results for runs under vmap, with the window on and off, and for run 0
    alone with the window on. Both give the same leaves for every run, and run 0 alone
    gives the same as in the batch; the operator changed some lengths."""
    for got, want, alone in results:
        for g, w, a in zip(jax.tree_util.tree_leaves(got), jax.tree_util.tree_leaves(want),
                           jax.tree_util.tree_leaves(alone)):
            np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
            np.testing.assert_array_equal(np.asarray(a)[0], np.asarray(w)[0])
        assert int(np.sum(np.asarray(got[0].length) != np.asarray(length))) > 0  # it did


def _head_tail(k, c1, l1, c2, l2):
    """A splicing pair operator: children ``c1[:l1 - 1] + c2[:l2]`` and ``c2[:1] +
    c1[r:l1]`` (``r`` random), up to ``l1 + l2 - 1`` cells, and which width it ran at."""
    cap = c1.shape[0]
    r = jax.random.randint(k, (), 1, jnp.maximum(l1, 2))
    a, la, ok_a = concat([(c1, 0, l1 - 1), (c2, 0, l2)], cap)
    b, lb, ok_b = concat([(c2, 0, 1), (c1, r, l1)], cap)
    return a, la, b, lb, (~ok_a).astype(jnp.int32) + (~ok_b), jnp.int32(cap)


@jax.jit
def _spliced_cases(longest):
    """For each depth of :data:`_DEPTHS`: ``(spliced_pairs_map, vmap)`` of
    :func:`_head_tail` on first parents up to ``longest`` cells (one of exactly
    ``longest``) and second parents up to 64."""
    out = []
    for depth in _DEPTHS:
        shape = _runs_shape(depth)
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
        out.append((spliced(keys, c1, l1, c2, l2), plain(keys, c1, l1, c2, l2)))
    return out


_SPLICED_LONGEST = (64, 65)


@pytest.fixture(scope="module")
def spliced_results():
    """:func:`_spliced_cases`'s results by ``longest`` (one program for all)."""
    return {longest: _host(_spliced_cases(longest)) for longest in _SPLICED_LONGEST}


@pytest.mark.parametrize("longest", _SPLICED_LONGEST)
@pytest.mark.parametrize("depth", _DEPTHS)
def test_spliced_pairs_map_is_vmap_bit_for_bit(spliced_results, depth, longest):
    """Parents that fit 64 cells are spliced on 128 (children up to 127 cells, re-padded
    with their last cell), a batch with one longer parent at full width: under 0-2 vmap
    levels exactly ``vmap(fn)``'s children, lengths and failure counts."""
    got, want = spliced_results[longest][depth]
    for g, w in zip(got[:5], want[:5]):
        assert g.shape == w.shape and g.dtype == w.dtype
        np.testing.assert_array_equal(g, w)
    width = got[5]
    assert np.all(width == (128 if longest <= 64 else 160))
    assert int(np.max(got[1])) > 64 and int(np.sum(got[4])) == 0  # long children fit


def _crossover_runs(splicing, keys, grid, cells, length, pc):
    f = cx.crossover_population(cx.common_point, dense=True, splicing=splicing)
    return jax.vmap(lambda k, c, n: f(k, grid, Population(c, n), pc))(keys, cells, length)


@jax.jit
def _spliced_crossover(key, grid, cells, length, pc):
    """The dense common-point crossover of 3 runs under vmap (keys ``split(key, 3)``),
    ``(with splicing, without, run 0 alone with splicing)``."""
    keys = jax.random.split(key, 3)
    return (_crossover_runs(True, keys, grid, cells, length, pc),
            _crossover_runs(False, keys, grid, cells, length, pc),
            _crossover_runs(True, keys[:1], grid, cells[:1], length[:1], pc))


def test_spliced_common_point_crossover_equals_full_width(setting):
    """The engine's common-point crossover with ``splicing=True`` (parents of at most 64
    cells: computed on 128) gives the children, lengths and failure counts of the plain
    dense crossover, for 3 runs under vmap and for one alone, at pc 0.8 and 1."""
    grid, pop = setting
    assert int(np.max(np.asarray(pop.length))) <= 64
    rng = np.random.default_rng(3)
    order = np.stack([rng.permutation(pop.size) for _ in range(3)])
    cells, length = np.asarray(pop.cells)[order], np.asarray(pop.length)[order]
    key = jax.random.PRNGKey(5)

    _assert_narrow_equals_wide(
        [_spliced_crossover(key, grid, cells, length, pc) for pc in (0.8, 1.0)], length)
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
    parent of 80 cells the whole folded batch runs at 160 (run 0 alone, whose parents
    all fit, at 128). Either way the children, lengths and failure counts equal the plain
    dense crossover's. Each run crosses its three pairs and again its first two: 10
    parents per run, the program of the previous test."""
    grid = Grid.create(np.zeros((20, 20), bool), (0, 0), (19, 19), corner_rule="free")
    rows_0_3 = _serpentine(64)  # ends (17, 3), (16, 3)
    after = [(16, 4), (17, 3), (18, 4), (19, 4)] + _serpentine(60, rows_from=5)
    pairs = [(rows_0_3, after), (_serpentine(50), _serpentine(64, by_column=True)),
             (_serpentine(64, by_column=True), _serpentine(37)),
             (_serpentine(longest), _serpentine(61, by_column=True))]
    runs = [pairs[:3], pairs[1:], pairs[2:] + pairs[:1]]
    runs = [run + run[:2] for run in runs]
    paths = [[from_coords(p, 20, 160) for pair in run for p in pair] for run in runs]
    cells = np.array([[c for c, _ in r] for r in paths], np.int32)
    length = np.array([[n for _, n in r] for r in paths], np.int32)

    results = _spliced_crossover(jax.random.PRNGKey(longest), grid, cells, length, 1.0)
    _assert_narrow_equals_wide([results], length)
    assert int(np.asarray(results[0][0].length)[0, 0]) == 125


_PRESETS = ("sga", "imga", "agacd", "mpmga", "iga_zhu", "iga_zhang")


@pytest.fixture(scope="module")
def evaluations(setting):
    """For each of :data:`_PRESETS`: its ``Algorithm`` with ``fitness.window`` on and off,
    and ``evaluate``'s results with each, all computed by one program (a population of
    short paths, one made discontinuous, the last inactive)."""
    from jaxga.config.presets import load_preset
    from jaxga.engine import build, evaluate, uses_waypoints

    grid, pop = setting
    cells = np.array(pop.cells)
    cells[1, 5] = cells[1, 20]  # a jump: infeasible
    active = np.arange(cells.shape[0]) < 9
    algos, params = {}, {}
    for preset in _PRESETS:
        # waypoint presets (agacd; iga_zhang's eq. 5 deletions) have no window: their
        # grid-step variants
        over = ({"crossover.method": "common_point", "mutation.method": "neighbour_point"}
                if uses_waypoints(load_preset(preset)) else {})
        built = [build(load_preset(preset, overrides={**over, "fitness.window": window}),
                       grid) for window in (True, False)]
        algos[preset] = [algo for algo, _ in built]
        params[preset] = [p for _, p in built]

    def run(grid, params, cells, length, active):
        return {preset: [evaluate(algo, grid, p, cells, length, active)
                         for algo, p in zip(algos[preset], params[preset])]
                for preset in _PRESETS}

    return algos, _host(jax.jit(run)(grid, params, cells, pop.length, active))


@pytest.mark.parametrize("preset", _PRESETS)
def test_engine_evaluation_in_the_window_equals_full_width(setting, evaluations, preset):
    """Every fitness function gives the same bits on the 64-cell window as on the full
    160 cells (``fitness.window`` on and off; a population of short paths, some made
    discontinuous)."""
    _, pop = setting
    algos, out = evaluations
    for algo in algos[preset]:
        assert not algo.waypoints and int(np.max(np.asarray(pop.length))) <= 64
    assert algos[preset][0].get("fitness.window") and not algos[preset][1].get("fitness.window")
    narrow, wide = out[preset]
    assert not bool(narrow[1][1]) and bool(narrow[1][0])
    for a, b in zip(narrow, wide):
        np.testing.assert_array_equal(a, b)


_SHRINKING = {"cut_corners": mu.cut_corners, "simplify_adjacent": simplify_adjacent}


def _gated_runs(op, shrinking, keys, grid, cells, length, prob):
    f = over_individuals_gated(op, shrinking=shrinking)
    return jax.vmap(lambda k, c, n: f(k, grid, Population(c, n), prob))(keys, cells, length)


@jax.jit
def _shrinking_cases(key, grid, cells, length, prob):
    """For each operator of :data:`_SHRINKING`, gated over 3 runs under vmap (keys
    ``split(key, 3)``; the paths padded first): ``(shrinking, full width, run 0 alone
    shrinking)``."""
    cells = jax.vmap(jax.vmap(pad))(cells, length)
    keys = jax.random.split(key, 3)
    return {name: (_gated_runs(op, True, keys, grid, cells, length, prob),
                   _gated_runs(op, False, keys, grid, cells, length, prob),
                   _gated_runs(op, True, keys[:1], grid, cells[:1], length[:1], prob))
            for name, op in _SHRINKING.items()}


_SHRINKING_LONGEST = (40, 80, 160)


@pytest.fixture(scope="module")
def shrinking_results(setting):
    """By ``longest``: the lengths of 3 runs of 20 random paths of the map (up to
    ``longest`` cells; run 1's up to 64) and :func:`_shrinking_cases`'s results on them,
    with probabilities 0.35 and 1 (one program for all)."""
    grid, _ = setting
    free = np.flatnonzero(~np.asarray(grid.blocked).reshape(-1))
    out = {}
    for longest in _SHRINKING_LONGEST:
        rng = np.random.default_rng(longest)
        cells = free[rng.integers(0, free.size, (3, 20, 160))].astype(np.int32)
        length = rng.integers(1, longest + 1, (3, 20)).astype(np.int32)
        length[1] = np.minimum(length[1], 64)  # one run always narrow
        key = jax.random.PRNGKey(longest)
        out[longest] = length, [_host(_shrinking_cases(key, grid, cells, length, prob))
                                for prob in (0.35, 1.0)]
    return out


@pytest.mark.parametrize("op", ["cut_corners", "simplify_adjacent"])
@pytest.mark.parametrize("longest", _SHRINKING_LONGEST)
def test_shrinking_gated_operator_on_the_window_equals_full_width(shrinking_results, op,
                                                                   longest):
    """``shrinking=True`` (blocks whose paths fit 64 cells run on them, the others at full
    width) gives exactly the cells, lengths and failure counts of the full-width gated
    operator, alone and under vmap over 3 runs, with probability 0.35 and 1."""
    length, results = shrinking_results[longest]
    _assert_narrow_equals_wide([by_op[op] for by_op in results], length)
