"""Exact line of sight (the corner rules, decision 027) and AGACD's linear trial (AGACD eq. 3-6).

Every call has the same shapes: one 6 x 7 map (the hand-made cases are drawn on it too),
pairs in batches of ``M`` (padded with a harmless pair, results sliced back), so each
jitted function below compiles once per corner rule.
"""

from __future__ import annotations

import functools
import itertools

import jax
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxga import Grid
from jaxga.core.geometry import clear, clear_xy, linear_trial, segments_clear
from jaxga.core.grid import CORNER_RULES, move_legal
from tests._exact_geometry import exact_clear, passes_vertex

H, W = 6, 7  # one fixed shape, so each jitted function compiles once per corner rule
M = 256  # pairs per call: every batch of pairs is padded to this many
L = 5  # path length of the segments_clear cases

_pairs_clear = jax.jit(jax.vmap(clear, in_axes=(None, 0, 0)))
_pairs_legal = jax.jit(jax.vmap(move_legal, in_axes=(None, 0, 0)))
_pairs_clear_span2 = jax.jit(jax.vmap(functools.partial(clear, max_span=2), in_axes=(None, 0, 0)))
_pairs_trial = jax.jit(jax.vmap(linear_trial, in_axes=(None, 0, 0)))
_pairs_clear_xy = jax.jit(jax.vmap(clear_xy, in_axes=(None, 0, 0)))
_segments_clear = jax.jit(segments_clear)

grids = st.lists(st.booleans(), min_size=H * W, max_size=H * W).map(
    lambda bits: np.array(bits, dtype=bool).reshape(H, W)
)
cells = st.integers(0, H * W - 1)
pair_lists = st.lists(st.tuples(cells, cells), min_size=1, max_size=40)
rules = st.sampled_from(CORNER_RULES)


def _xy(p: int) -> tuple[int, int]:
    return p % W, p // W


def _cell(x: int, y: int) -> int:
    return y * W + x


def _run(fn, grid, pairs):
    """``fn(grid, a, b)`` on every pair (cell indices, or ``(x, y)`` pairs of pairs), in
    batches of ``M`` padded with the pair ``(0, 0)``; NumPy results, one per pair."""
    arr = np.asarray(pairs, dtype=np.int32)
    arr = arr.reshape((-1, 2) + arr.shape[2:] if arr.ndim > 2 else (-1, 2))
    k = len(arr)
    padded = np.zeros((-(-k // M) * M,) + arr.shape[1:], np.int32)
    padded[:k] = arr
    out = [np.asarray(fn(grid, padded[j:j + M, 0], padded[j:j + M, 1]))
           for j in range(0, len(padded), M)]
    return np.concatenate(out)[:k]


def _map(*blocked_xy: tuple[int, int]) -> np.ndarray:
    """The free 6 x 7 map with the cells ``(x, y)`` blocked (a hand-made case in its
    lower left corner: every segment of a case stays inside the case's own box)."""
    blocked = np.zeros((H, W), bool)
    for x, y in blocked_xy:
        blocked[y, x] = True
    return blocked


def _clear(blocked, rule, a, b) -> bool:
    """``clear`` of one pair of ``(x, y)`` cells, through the batched program."""
    grid = Grid.create(blocked, corner_rule=rule)
    return bool(_run(_pairs_clear, grid, [(_cell(*a), _cell(*b))])[0])


def _clear_xy(blocked, rule, a, b) -> bool:
    return bool(_run(_pairs_clear_xy, Grid.create(blocked, corner_rule=rule), [(a, b)])[0])


def _trial(blocked, rule, a, b) -> bool:
    grid = Grid.create(blocked, corner_rule=rule)
    return bool(_run(_pairs_trial, grid, [(_cell(*a), _cell(*b))])[0])


@pytest.mark.parametrize("rule", CORNER_RULES)
def test_clear_matches_exact_reference_on_all_pairs(rule):
    """Every ordered pair of cells on three random 6 x 7 maps agrees with rational arithmetic."""
    rng = np.random.default_rng(7)
    all_pairs = list(itertools.product(range(H * W), repeat=2))
    for density in (0.15, 0.3, 0.45):
        blocked = rng.random((H, W)) < density
        grid = Grid.create(blocked, corner_rule=rule)
        got = _run(_pairs_clear, grid, all_pairs)
        want = [exact_clear(blocked, rule, _xy(p), _xy(q)) for p, q in all_pairs]
        assert got.tolist() == want


@given(grids, pair_lists, rules)
def test_clear_is_symmetric_and_matches_reference(blocked, pairs, rule):
    grid = Grid.create(blocked, corner_rule=rule)
    both = _run(_pairs_clear, grid, pairs + [(q, p) for p, q in pairs])
    fwd, bwd = both[: len(pairs)], both[len(pairs):]
    assert fwd.tolist() == bwd.tolist()
    assert fwd.tolist() == [exact_clear(blocked, rule, _xy(p), _xy(q)) for p, q in pairs]


@given(grids, rules)
def test_clear_equals_move_rule_on_adjacent_pairs(blocked, rule):
    grid = Grid.create(blocked, corner_rule=rule)
    pairs = [
        (y * W + x, (y + dy) * W + x + dx)
        for x, y in itertools.product(range(W), range(H))
        for dx, dy in itertools.product((-1, 0, 1), repeat=2)
        if (dx or dy) and 0 <= x + dx < W and 0 <= y + dy < H
    ]
    assert _run(_pairs_clear, grid, pairs).tolist() == _run(_pairs_legal, grid, pairs).tolist()


@given(grids, pair_lists, rules)
def test_clear_agrees_with_dense_sampling_away_from_vertices(blocked, pairs, rule):
    """On segments through no grid vertex, clear == every densely sampled point is free."""
    pairs = [(p, q) for p, q in pairs if not passes_vertex(_xy(p), _xy(q))]
    if not pairs:
        return
    grid = Grid.create(blocked, corner_rule=rule)
    got = _run(_pairs_clear, grid, pairs)
    t = np.linspace(0.0, 1.0, 4001)
    for (p, q), g in zip(pairs, got):
        (ax, ay), (bx, by) = _xy(p), _xy(q)
        xs = np.floor(ax + 0.5 + (bx - ax) * t).astype(int)
        ys = np.floor(ay + 0.5 + (by - ay) * t).astype(int)
        assert bool(g) == (not blocked[ys, xs].any()), (p, q)


def test_clear_hand_cases():
    # Two obstacles touching diagonally at the vertex (1, 1): (0, 0) -> (1, 1) squeezes
    # between them.
    two = _map((0, 1), (1, 0))
    assert _clear(two, "free", (0, 0), (1, 1))
    assert not _clear(two, "no_squeeze", (0, 0), (1, 1))
    assert not _clear(two, "strict", (0, 0), (1, 1))
    one = _map((1, 0))  # clip a single corner
    assert _clear(one, "no_squeeze", (0, 0), (1, 1))
    assert not _clear(one, "strict", (0, 0), (1, 1))
    # An exact diagonal through the centre of a blocked cell.
    mid = _map((1, 1))
    assert not _clear(mid, "free", (0, 0), (2, 2))
    # A knight move (0,0)->(1,2) crosses (0,1) and (1,1) only.
    assert not _clear_xy(_map((1, 1)), "strict", (0, 0), (1, 2))
    assert _clear_xy(_map((1, 0)), "strict", (0, 0), (1, 2))
    # Endpoints off the map or blocked are never clear; a free cell sees itself.
    for off in ((W, 0), (-1, 0), (0, H), (0, -1)):
        assert not _clear_xy(mid, "strict", (0, 0), off), off
        assert not _clear_xy(mid, "strict", off, (0, 0)), off
    assert not _clear(mid, "strict", (1, 1), (1, 1)) and _clear(mid, "strict", (0, 0), (0, 0))


@given(grids, pair_lists, rules)
def test_max_span_is_exact_within_the_span(blocked, pairs, rule):
    """With max_span, short segments get the exact answer and long ones are not clear."""
    grid = Grid.create(blocked, corner_rule=rule)
    full = _run(_pairs_clear, grid, pairs)
    short = _run(_pairs_clear_span2, grid, pairs)
    for (p, q), f, s in zip(pairs, full, short):
        (ax, ay), (bx, by) = _xy(p), _xy(q)
        assert s == (f and abs(ax - bx) <= 2 and abs(ay - by) <= 2)


def test_segments_clear_masks_padding():
    grid = Grid.create(_map((1, 1)))
    path = np.array([_cell(0, 0), _cell(3, 0), _cell(3, 3), _cell(3, 3), _cell(3, 3)], np.int32)
    assert np.asarray(_segments_clear(grid, path, np.int32(3))).tolist() == [True] * (L - 1)
    # (0, 0) -> (2, 2) passes through the blocked (1, 1); the padding after it is clear
    cut = np.array([_cell(0, 0)] + [_cell(2, 2)] * (L - 1), np.int32)
    got = np.asarray(_segments_clear(grid, cut, np.int32(2))).tolist()
    assert got == [False] + [True] * (L - 2)


def test_linear_trial_hand_cases():
    """AGACD eq. 3-6: probes every 0.1 along the major axis, rounding half down."""
    centre = _map((2, 2))
    assert not _trial(centre, "strict", (0, 0), (4, 4))  # the diagonal probes (2, 2)
    assert _trial(centre, "strict", (0, 0), (4, 0))
    assert not _trial(centre, "strict", (0, 2), (4, 2))
    # (0,0)->(4,1): y = x/4 exceeds 0.5 for x in (2, 2.5], which rounds to x = 2, so
    # (2,1) is probed; (3,0) never is (x in (2.5, 3.5] gives y in (0.625, 0.875]).
    assert not _trial(_map((2, 1)), "strict", (0, 0), (4, 1))
    assert _trial(_map((3, 0)), "strict", (0, 0), (4, 1))
    # (0,0)->(3,1) passes the grid vertex (2, 1): the probes jump from (1,0) to (2,1) and
    # never look at the side cell (2,0), which the exact strict check rejects.
    b3 = _map((2, 0))
    assert _trial(b3, "strict", (0, 0), (3, 1))
    assert not _clear(b3, "strict", (0, 0), (3, 1))
    assert _clear(b3, "free", (0, 0), (3, 1))
    # It has no corner rule: it squeezes between diagonal obstacles where clear() may not.
    assert _trial(_map((0, 1), (1, 0)), "strict", (0, 0), (1, 1))


@given(grids, pair_lists)
def test_linear_trial_symmetric_where_no_ties(blocked, pairs):
    """The probe walks from the lower end, so swapping the ends gives the same answer."""
    grid = Grid.create(blocked)
    both = _run(_pairs_trial, grid, pairs + [(q, p) for p, q in pairs])
    fwd, bwd = both[: len(pairs)], both[len(pairs):]
    assert fwd.tolist() == bwd.tolist()
