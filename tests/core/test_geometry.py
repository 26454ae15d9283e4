"""Exact line of sight (the corner rules, decision 027) and AGACD's linear trial (AGACD eq. 3-6)."""

from __future__ import annotations

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxga import Grid
from jaxga.core.geometry import clear, clear_xy, linear_trial, segments_clear
from jaxga.core.grid import CORNER_RULES, move_legal
from tests._exact_geometry import exact_clear, passes_vertex

H, W = 6, 7  # one fixed shape, so each jitted function compiles once per corner rule

_pairs_clear = jax.jit(jax.vmap(clear, in_axes=(None, 0, 0)))
_pairs_legal = jax.jit(jax.vmap(move_legal, in_axes=(None, 0, 0)))
_pairs_clear_span2 = jax.jit(jax.vmap(lambda g, a, b: clear(g, a, b, 2), in_axes=(None, 0, 0)))
_pairs_trial = jax.jit(jax.vmap(linear_trial, in_axes=(None, 0, 0)))

grids = st.lists(st.booleans(), min_size=H * W, max_size=H * W).map(
    lambda bits: np.array(bits, dtype=bool).reshape(H, W)
)
cells = st.integers(0, H * W - 1)
pair_lists = st.lists(st.tuples(cells, cells), min_size=1, max_size=40)
rules = st.sampled_from(CORNER_RULES)


def _xy(p: int) -> tuple[int, int]:
    return p % W, p // W


def _run(fn, grid, pairs):
    arr = np.asarray(pairs, dtype=np.int32).reshape(-1, 2)
    return np.asarray(fn(grid, arr[:, 0], arr[:, 1]))


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
    fwd = _run(_pairs_clear, grid, pairs)
    bwd = _run(_pairs_clear, grid, [(q, p) for p, q in pairs])
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
    blocked = np.zeros((3, 3), bool)
    blocked[1, 0] = blocked[0, 1] = True  # two obstacles touching diagonally at (1, 1)
    a, b = 0, 4  # (0, 0) -> (1, 1) squeezes between them
    assert bool(clear(Grid.create(blocked, corner_rule="free"), a, b))
    assert not bool(clear(Grid.create(blocked, corner_rule="no_squeeze"), a, b))
    assert not bool(clear(Grid.create(blocked, corner_rule="strict"), a, b))
    one = np.zeros((3, 3), bool)
    one[0, 1] = True  # clip a single corner
    assert bool(clear(Grid.create(one, corner_rule="no_squeeze"), 0, 4))
    assert not bool(clear(Grid.create(one, corner_rule="strict"), 0, 4))
    # An exact diagonal through the centre of a blocked cell.
    mid = np.zeros((3, 3), bool)
    mid[1, 1] = True
    assert not bool(clear(Grid.create(mid, corner_rule="free"), 0, 8))
    # A knight move (0,0)->(1,2) crosses (0,1) and (1,1) only.
    knight = np.zeros((3, 3), bool)
    knight[1, 1] = True
    assert not bool(clear_xy(Grid.create(knight), (0, 0), (1, 2)))
    knight[1, 1], knight[0, 1] = False, True
    assert bool(clear_xy(Grid.create(knight), (0, 0), (1, 2)))
    # Endpoints off the map or blocked are never clear; a free cell sees itself.
    g = Grid.create(mid)
    assert not bool(clear_xy(g, (0, 0), (3, 0)))
    assert not bool(clear(g, 4, 4)) and bool(clear(g, 0, 0))


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
    blocked = np.zeros((4, 4), bool)
    blocked[1, 1] = True
    grid = Grid.create(blocked)
    path = jnp.array([0, 3, 15, 15, 15], jnp.int32)
    assert np.asarray(segments_clear(grid, path, 3)).tolist() == [True, True, True, True]
    assert not np.asarray(segments_clear(grid, jnp.array([0, 10, 10], jnp.int32), 2))[0]


def test_linear_trial_hand_cases():
    """AGACD eq. 3-6: probes every 0.1 along the major axis, rounding half down."""
    blocked = np.zeros((5, 5), bool)
    blocked[2, 2] = True
    g = Grid.create(blocked)
    assert not bool(linear_trial(g, 0, 24))  # the diagonal probes (2, 2)
    assert bool(linear_trial(g, 0, 4))
    assert not bool(linear_trial(g, 10, 14))
    # (0,0)->(4,1): y = x/4 exceeds 0.5 for x in (2, 2.5], which rounds to x = 2, so
    # (2,1) is probed; (3,0) never is (x in (2.5, 3.5] gives y in (0.625, 0.875]).
    b2 = np.zeros((5, 5), bool)
    b2[1, 2] = True
    assert not bool(linear_trial(Grid.create(b2), 0, 5 + 4))
    b2[1, 2], b2[0, 3] = False, True
    assert bool(linear_trial(Grid.create(b2), 0, 5 + 4))
    # (0,0)->(3,1) passes the grid vertex (2, 1): the probes jump from (1,0) to (2,1) and
    # never look at the side cell (2,0), which the exact strict check rejects.
    b3 = np.zeros((5, 5), bool)
    b3[0, 2] = True
    assert bool(linear_trial(Grid.create(b3), 0, 5 + 3))
    assert not bool(clear(Grid.create(b3, corner_rule="strict"), 0, 5 + 3))
    assert bool(clear(Grid.create(b3, corner_rule="free"), 0, 5 + 3))
    # It has no corner rule: it squeezes between diagonal obstacles where clear() may not.
    sq = np.zeros((3, 3), bool)
    sq[1, 0] = sq[0, 1] = True
    assert bool(linear_trial(Grid.create(sq, corner_rule="strict"), 0, 4))


@given(grids, pair_lists)
def test_linear_trial_symmetric_where_no_ties(blocked, pairs):
    """The probe walks from the lower end, so swapping the ends gives the same answer."""
    grid = Grid.create(blocked)
    fwd = _run(_pairs_trial, grid, pairs)
    bwd = _run(_pairs_trial, grid, [(q, p) for p, q in pairs])
    assert fwd.tolist() == bwd.tolist()
