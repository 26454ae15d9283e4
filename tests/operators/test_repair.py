"""Median-insertion connection (IMGA 4.1 eq. 2-3, MPMGA 4.2) and path concatenation.

Each function under test is jitted once below; the hand-made connections share one
20 x 20 map (and one capacity where the capacity is not what is tested), the batched
connections one batch size, and the checks of their results run in the same program.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxga import Grid
from jaxga.core.grid import CORNER_RULES
from jaxga.core.paths import has_endpoints, is_continuous, is_loop_free, remove_loops
from jaxga.operators.repair import (
    SPLICE_LOCAL_MAX,
    _compact,
    concat,
    connect,
    prefix_count,
    splice_loop_free,
)

# the repairs' properties in depth (every operator's contract: tests/config/test_registry.py)
pytestmark = pytest.mark.slow

N = 10
CAP = 64
BATCH = 4  # connections per call of _connect
SIDE = 20  # the hand-made connections' map
HAND_CAP = 20  # and their capacity (test_capacity_overflow_... tests 10 as well)

# One compiled program per (map shape, corner rule, anchors, capacity): the tests below
# call it on hand-made cases (eagerly, every JAX operation compiled on its own, the file
# compiled about 700 small programs).
_connect_one = jax.jit(connect, static_argnums=(3, 4))
_concat = jax.jit(concat, static_argnums=1)
_compact_rows = jax.jit(lambda f, v, size: jax.vmap(lambda a, b: _compact(a, b, size))(f, v),
                        static_argnums=2)
_prefix_counts = jax.jit(lambda x, b: ([prefix_count(x, axis=a) for a in range(x.ndim)],
                                       prefix_count(b)))
"""The prefix count of ``x`` along each of its axes, and of the 1-D ``b``."""


def _open(rule: str = "free", *blocked_xy: tuple[int, int]) -> Grid:
    """The open ``SIDE x SIDE`` map with the cells ``(x, y)`` blocked."""
    blocked = np.zeros((SIDE, SIDE), bool)
    for x, y in blocked_xy:
        blocked[y, x] = True
    return Grid.create(blocked, corner_rule=rule)


def _connect_path(grid, anchors, seed=0, capacity=HAND_CAP):
    """``(ok, the connection's cells)`` of two anchors (cell indices), one connection."""
    cells, n, ok = _connect_one(jax.random.PRNGKey(seed), grid,
                                np.asarray(anchors, np.int32), 2, capacity)
    return bool(ok), np.asarray(cells)[: int(n)].tolist()


def test_mpmga_connection_example():
    """MPMGA section 4.2: the intermittent path 0, 60 becomes 0, 20, 40, 60 (20 x 20)."""
    ok, path = _connect_path(_open(), [0, 60])
    assert ok and path == [0, 20, 40, 60]


def test_medians_on_an_open_map_are_deterministic():
    """No obstacle: the result is the recursive floor-median line (IMGA eq. 3)."""
    out = []
    for seed in range(3):
        ok, path = _connect_path(_open(), [0, 5 + 20 * 2], seed)
        assert ok
        out.append(path)
    # (0,0)->(5,2): median (2,1); (0,0)-(2,1): (1,0); (2,1)-(5,2): (3,1); (3,1)-(5,2): (4,1).
    assert out[0] == out[1] == out[2] == [0, 1, 22, 23, 24, 45]


def _connect_and_check(keys, grid, anchors, n):
    """A batch of connections (``BATCH`` keys, anchors and anchor counts), their loop
    removal, and the checks of the loop-free paths: whether they run from the first to
    the last anchor, are continuous and are loop-free."""
    raw = jax.vmap(lambda k, a, m: connect(k, grid, a, m, CAP))(keys, anchors, n)
    looped = jax.vmap(lambda c, m: remove_loops(c, m, N * N))(*raw[:2])

    def checks(c, m, a, na):
        g = dataclasses.replace(grid, start=a[0], goal=a[na - 1])
        return has_endpoints(g, c, m), is_continuous(g, c, m), is_loop_free(c, m)

    return raw, looped, jax.vmap(checks)(*looped, anchors, n)


_connect = jax.jit(_connect_and_check)


def _np(tree):
    return jax.tree.map(np.asarray, tree)


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
    (_, _, ok), (cells, length), (endpoints, continuous, loop_free) = _np(
        _connect(keys, grid, anchors, n))
    free = ~blocked.reshape(-1)
    for i in range(len(n)):
        if not bool(ok[i]):
            continue
        # the grid's start and goal are the first and the last anchor
        assert bool(endpoints[i])
        assert bool(continuous[i])
        assert bool(loop_free[i])
        assert free[cells[i]].all()
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
    anchors = rng.choice(free_cells, size=(256, 5)).astype(np.int32)  # intermittent
    n = np.full((256,), 5, np.int32)
    keys = np.asarray(jax.random.split(jax.random.PRNGKey(3), 256))
    grid = Grid.create(blocked, corner_rule="free")

    def connect_all(g):
        """The connections and their loop removal, in batches of BATCH (the programs
        test_connect_properties compiled)."""
        parts = [_np(_connect(keys[j:j + BATCH], g, anchors[j:j + BATCH], n[j:j + BATCH])[:2])
                 for j in range(0, 256, BATCH)]
        return jax.tree.map(lambda *x: np.concatenate(x), *parts)

    (raw, raw_n, raw_ok), (looped, looped_n) = connect_all(grid)
    saved = 0
    for rule in ("no_squeeze", "strict"):
        (cells, length, ok), _ = connect_all(grid.replace(corner_rule=rule))
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
    key, grid, anchors = jax.random.PRNGKey(0), _open(), np.array([0, 399], np.int32)
    _, _, ok = _connect_one(key, grid, anchors, 2, 10)
    assert not bool(ok)
    _, n, ok = _connect_one(key, grid, anchors, 2, 20)
    assert bool(ok) and int(n) == 20


def test_strict_rule_goes_round_corners():
    """Under "strict" a diagonal step past an obstacle becomes two orthogonal steps."""
    # (0, 0) -> (1, 1) past the blocked (1, 0): round it through (0, 1)
    assert _connect_path(_open("strict", (1, 0)), [0, SIDE + 1]) == (True, [0, SIDE, SIDE + 1])
    assert _connect_path(_open("free", (1, 0)), [0, SIDE + 1]) == (True, [0, SIDE + 1])


def test_concat_and_overflow():
    a = np.arange(10, dtype=np.int32)
    cells, n, ok = _concat([(a, 0, 3), (a + 100, 5, 8)], 8)
    assert bool(ok) and int(n) == 6
    assert np.asarray(cells).tolist() == [0, 1, 2, 105, 106, 107, 107, 107]
    _, _, ok = _concat([(a, 0, 6), (a, 0, 6)], 8)
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
_SPLICE = {table: jax.jit(jax.vmap(lambda *a, m=_SPLICE_CELLS if table else None:
                                   splice_loop_free(*a, n_cells=m)))
           for table in (True, False)}
"""splice_loop_free with the map's table (True) or by comparisons (False)."""


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
    args = [np.asarray(a, np.int32) for a in (cells, length, keep_to, seg, seg_len, resume)]
    out, out_len, fits = _SPLICE[table](*args)
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
    rng = np.random.default_rng(n)
    density = np.array([0.0, 0.1, 0.5, 0.9, 1.0])[:, None]
    flags = rng.random((5, n)) < density
    vals = rng.integers(0, 1000, (5, n)).astype(np.int32)
    out, count = _compact_rows(flags, vals, size)
    for f, v, o, c in zip(flags, vals, np.asarray(out), np.asarray(count)):
        want = np.full(size, -1)
        kept = v[f][:size]
        want[: len(kept)] = kept
        assert c == f.sum() and np.array_equal(o, want)


@pytest.mark.parametrize("n", [1, 5, 33])
def test_prefix_count_is_the_cumulative_sum_along_any_axis(n):
    x = np.random.default_rng(n).integers(0, 3, size=(3, n, 4))
    along, flags = _prefix_counts(jnp.asarray(x), x[0, :, 0] > 0)
    for axis in (0, 1, 2):
        got = along[axis]
        assert got.dtype == jnp.int32
        np.testing.assert_array_equal(got, np.cumsum(x, axis=axis))
    np.testing.assert_array_equal(flags, np.cumsum(x[0, :, 0] > 0))
