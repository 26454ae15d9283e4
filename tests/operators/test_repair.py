"""Median-insertion connection (IMGA 4.1 eq. 2-3, MPMGA 4.2) and path concatenation."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxga import Grid
from jaxga.core.grid import CORNER_RULES
from jaxga.core.paths import has_endpoints, is_continuous, is_loop_free, remove_loops
from jaxga.operators.repair import SPLICE_LOCAL_MAX, concat, connect, prefix_count, splice_loop_free

N = 10
CAP = 64

# One compiled program per (map shape, corner rule, anchors, capacity): the tests below
# call it on hand-made cases (eagerly, every JAX operation compiled on its own, the file
# compiled about 700 small programs).
_connect_one = jax.jit(connect, static_argnums=(3, 4))
_prefix_count = jax.jit(prefix_count, static_argnames="axis")


def test_mpmga_connection_example():
    """MPMGA section 4.2: the intermittent path 0, 60 becomes 0, 20, 40, 60 (20 x 20)."""
    grid = Grid.create(np.zeros((20, 20), bool), corner_rule="free")
    cells, n, ok = _connect_one(jax.random.PRNGKey(0), grid, jnp.array([0, 60], jnp.int32), 2, 8)
    assert bool(ok) and np.asarray(cells[: int(n)]).tolist() == [0, 20, 40, 60]


def test_medians_on_an_open_map_are_deterministic():
    """No obstacle: the result is the recursive floor-median line (IMGA eq. 3)."""
    grid = Grid.create(np.zeros((20, 20), bool), corner_rule="free")
    out = []
    for seed in range(3):
        cells, n, ok = _connect_one(jax.random.PRNGKey(seed), grid,
                                    jnp.array([0, 5 + 20 * 2]), 2, 16)
        assert bool(ok)
        out.append(np.asarray(cells[: int(n)]).tolist())
    # (0,0)->(5,2): median (2,1); (0,0)-(2,1): (1,0); (2,1)-(5,2): (3,1); (3,1)-(5,2): (4,1).
    assert out[0] == out[1] == out[2] == [0, 1, 22, 23, 24, 45]


_connect = jax.jit(jax.vmap(lambda k, g, a, n: connect(k, g, a, n, CAP), in_axes=(0, None, 0, 0)))
_loops = jax.jit(jax.vmap(lambda c, n: remove_loops(c, n, N * N)))


@given(
    st.lists(st.booleans(), min_size=N * N, max_size=N * N),
    st.sampled_from(CORNER_RULES),
    st.lists(st.lists(st.integers(0, N * N - 1), min_size=2, max_size=5), min_size=4, max_size=4),
    st.integers(0, 2**31 - 1),
)
def test_connect_properties(bits, rule, anchor_lists, seed):
    """ok => after loop removal: continuous, loop-free, from first to last anchor, fits."""
    sparse = np.random.default_rng(seed).random((N, N)) < 0.4
    blocked = np.array(bits, bool).reshape(N, N) & sparse
    grid = Grid.create(blocked, corner_rule=rule)
    anchors = np.array([a + [a[-1]] * (5 - len(a)) for a in anchor_lists], np.int32)
    n = np.array([len(a) for a in anchor_lists], np.int32)
    keys = jax.random.split(jax.random.PRNGKey(seed), len(n))
    cells, length, ok = _connect(keys, grid, jnp.asarray(anchors), jnp.asarray(n))
    cells, length = _loops(cells, length)
    free = ~blocked.reshape(-1)
    for i in range(len(n)):
        if not bool(ok[i]):
            continue
        g = grid.replace(start=(anchors[i, 0] % N, anchors[i, 0] // N),
                         goal=(anchors[i, n[i] - 1] % N, anchors[i, n[i] - 1] // N))
        assert bool(has_endpoints(g, cells[i], length[i]))
        assert bool(is_continuous(g, cells[i], length[i]))
        assert bool(is_loop_free(cells[i], length[i]))
        assert free[np.asarray(cells[i])].all()
    # An anchor on an obstacle can never be connected.
    for i in range(len(n)):
        if not free[anchors[i, : n[i]]].all():
            assert not bool(ok[i])


def _strict_reference(blocked: np.ndarray, path: list[int], rule: str, cap: int):
    """The loop-free "free" connection judged under ``rule`` (None: the connection fails)."""
    w = blocked.shape[1]
    out = [path[0]]
    for h, t in zip(path, path[1:]):
        hx, hy, tx, ty = h % w, h // w, t % w, t // w
        if hx != tx and hy != ty:
            a, b = bool(blocked[hy, tx]), bool(blocked[ty, hx])
            if a and b:
                return None
            if rule == "strict" and (a or b):
                out.append(ty * w + hx if a else hy * w + tx)
        out.append(t)
    return out if len(out) <= cap else None


def test_stricter_rules_judge_the_loop_free_connection():
    """Under no_squeeze / strict, connect = the same key's "free" connection without its
    loops, failing only on a squeeze left in the loop-free path (strict: a one-sided
    corner becomes two orthogonal steps). Squeezes on loops no longer fail it."""
    rng = np.random.default_rng(7)
    blocked = rng.random((N, N)) < 0.3
    free_cells = np.flatnonzero(~blocked.reshape(-1))
    anchors = jnp.asarray(rng.choice(free_cells, size=(256, 5)), jnp.int32)  # intermittent
    n = jnp.full((256,), 5, jnp.int32)
    keys = jax.random.split(jax.random.PRNGKey(3), 256)
    grid = Grid.create(blocked, corner_rule="free")

    def in_fours(fn, *arrays):
        """``fn`` on batches of 4 (the programs test_connect_properties compiled)."""
        parts = [fn(*(a[j:j + 4] for a in arrays)) for j in range(0, 256, 4)]
        return [jnp.concatenate(x) for x in zip(*parts)]

    def connect_all(g):
        return in_fours(lambda k, a, m, g=g: _connect(k, g, a, m), keys, anchors, n)

    raw, raw_n, raw_ok = connect_all(grid)
    looped, looped_n = in_fours(_loops, raw, raw_n)
    saved = 0
    for rule in ("no_squeeze", "strict"):
        cells, length, ok = connect_all(grid.replace(corner_rule=rule))
        for i in range(256):
            want = None
            if bool(raw_ok[i]):
                path = np.asarray(looped[i, : int(looped_n[i])]).tolist()
                want = _strict_reference(blocked, path, rule, CAP)
                raw_path = np.asarray(raw[i, : int(raw_n[i])]).tolist()
                # the raw path squeezes between two obstacles (the old check's failure)
                saved += want is not None and _strict_reference(
                    blocked, raw_path, "no_squeeze", 10**9) is None
            assert bool(ok[i]) == (want is not None), (rule, i)
            if want is not None:
                assert np.asarray(cells[i, : int(length[i])]).tolist() == want, (rule, i)
    assert saved > 0  # connections that the raw-path check used to reject


def test_capacity_overflow_fails_instead_of_wrapping():
    grid = Grid.create(np.zeros((20, 20), bool), corner_rule="free")
    _, _, ok = _connect_one(jax.random.PRNGKey(0), grid, jnp.array([0, 399], jnp.int32), 2, 10)
    assert not bool(ok)
    _, n, ok = _connect_one(jax.random.PRNGKey(0), grid, jnp.array([0, 399], jnp.int32), 2, 20)
    assert bool(ok) and int(n) == 20


def test_strict_rule_goes_round_corners():
    """Under "strict" a diagonal step past an obstacle becomes two orthogonal steps."""
    blocked = np.zeros((3, 3), bool)
    blocked[0, 1] = True  # (1, 0)
    grid = Grid.create(blocked, corner_rule="strict")
    cells, n, ok = _connect_one(jax.random.PRNGKey(0), grid, jnp.array([0, 4], jnp.int32), 2, 8)
    assert bool(ok) and np.asarray(cells[: int(n)]).tolist() == [0, 3, 4]
    free = grid.replace(corner_rule="free")
    cells, n, ok = _connect_one(jax.random.PRNGKey(0), free, jnp.array([0, 4], jnp.int32), 2, 8)
    assert bool(ok) and np.asarray(cells[: int(n)]).tolist() == [0, 4]


def test_concat_and_overflow():
    a = jnp.arange(10, dtype=jnp.int32)
    cells, n, ok = concat([(a, 0, 3), (a + 100, 5, 8)], 8)
    assert bool(ok) and int(n) == 6
    assert np.asarray(cells).tolist() == [0, 1, 2, 105, 106, 107, 107, 107]
    _, _, ok = concat([(a, 0, 6), (a, 0, 6)], 8)
    assert not bool(ok)


def _loop_free_reference(path: list[int]) -> list[int]:
    """From the start, keep a node and jump past the LAST visit of its cell."""
    out, p = [], 0
    while p < len(path):
        last = max(k for k, c in enumerate(path) if c == path[p])
        out.append(path[p])
        p = last + 1
    return out


_SPLICE_L, _SPLICE_CELLS = 24, 40


@functools.cache
def _splice_fn(seg_cap: int, table: bool):
    n_cells = _SPLICE_CELLS if table else None
    return jax.jit(jax.vmap(lambda *a: splice_loop_free(*a, n_cells=n_cells)))


@given(st.integers(0, 2**31 - 1), st.sampled_from([(4, True), (16, True), (16, False),
                                                   (SPLICE_LOCAL_MAX + 8, True)]))
def test_splice_loop_free_matches_the_loop_removal_of_the_splice(seed, variant):
    """For loop-free parents, ``splice_loop_free`` is the loop removal of the raw splice
    (NumPy reference), overflow included, with segments that revisit the parent's cells
    and themselves; table and comparison variants, and the long-segment fallback."""
    seg_cap, table = variant
    rng = np.random.default_rng(seed)
    b = 64
    cells = np.stack([rng.permutation(_SPLICE_CELLS)[:_SPLICE_L] for _ in range(b)])
    length = rng.integers(1, _SPLICE_L + 1, b)
    keep_to = np.array([rng.integers(0, n + 1) for n in length])
    resume = np.array([rng.integers(k, n + 1) for k, n in zip(keep_to, length)])
    seg = rng.integers(0, _SPLICE_CELLS, (b, seg_cap))
    from_parent = rng.random((b, seg_cap)) < 0.5
    picks = rng.integers(0, _SPLICE_L, (b, seg_cap))
    seg = np.where(from_parent, cells[np.arange(b)[:, None], picks], seg)
    seg_len = rng.integers(0, seg_cap + 1, b)
    args = [jnp.asarray(a, jnp.int32) for a in (cells, length, keep_to, seg, seg_len, resume)]
    out, out_len, fits = _splice_fn(seg_cap, table)(*args)
    out, out_len, fits = np.asarray(out), np.asarray(out_len), np.asarray(fits)
    for i in range(b):
        raw = (cells[i, : keep_to[i]].tolist() + seg[i, : seg_len[i]].tolist()
               + cells[i, resume[i]: length[i]].tolist())
        want = _loop_free_reference(raw)
        assert bool(fits[i]) == (len(want) <= _SPLICE_L)
        if fits[i]:
            assert out_len[i] == len(want)
            assert out[i, : out_len[i]].tolist() == want
            if want:
                assert (out[i, out_len[i]:] == want[-1]).all()


@pytest.mark.parametrize("n, size", [(8, 8), (32, 18), (36, 18), (64, 40), (70, 30)])
def test_compact_keeps_the_flagged_values_in_order(n, size):
    """The connection's work-queue compaction (one word, two words, prefix count):
    ``vals[flags]`` in order, padded with -1, the first ``size`` kept, and the count."""
    from jaxga.operators.repair import _compact

    rng = np.random.default_rng(n)
    density = np.array([0.0, 0.1, 0.5, 0.9, 1.0])[:, None]
    flags = rng.random((5, n)) < density
    vals = rng.integers(0, 1000, (5, n)).astype(np.int32)
    out, count = jax.jit(jax.vmap(lambda f, v: _compact(f, v, size)))(
        jnp.asarray(flags), jnp.asarray(vals))
    for f, v, o, c in zip(flags, vals, np.asarray(out), np.asarray(count)):
        want = np.full(size, -1)
        kept = v[f][:size]
        want[: len(kept)] = kept
        assert c == f.sum() and np.array_equal(o, want)


@pytest.mark.parametrize("n", [1, 5, 33])
def test_prefix_count_is_the_cumulative_sum_along_any_axis(n):
    x = np.random.default_rng(n).integers(0, 3, size=(3, n, 4))
    for axis in (0, 1, 2):
        got = _prefix_count(jnp.asarray(x), axis=axis)
        assert got.dtype == jnp.int32
        np.testing.assert_array_equal(got, np.cumsum(x, axis=axis))
    np.testing.assert_array_equal(_prefix_count(jnp.asarray(x[0, :, 0] > 0)),
                                  np.cumsum(x[0, :, 0] > 0))
