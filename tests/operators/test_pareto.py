"""Multi-objective selection (jaxga.operators.pareto): exact values on a hand-computed
front, agreement with moocore (non-dominated ranks, hypervolume) and with a plain
transcription of Deb et al.'s crowding distance, the invariants of fronts and survival,
and the same results under jit and vmap."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import moocore
import numpy as np
import pytest

from jaxga.operators import pareto

HAND = np.array([[1, 5], [2, 3], [3, 4], [4, 1], [5, 5]], np.float32)
"""Five points (both objectives minimised): fronts {0, 1, 3}, {2}, {4}."""

rank_of = jax.jit(pareto.nondominated_rank)
crowding_of = jax.jit(pareto.crowding_distance)
hv2 = jax.jit(pareto.hypervolume_2d)
hv3 = jax.jit(pareto.hypervolume_3d)


def deb_crowding(f: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """Deb et al. 2002, crowding-distance-assignment, front by front, as the paper writes
    it (ties along an objective by index)."""
    d = np.zeros(len(f))
    for r in set(rank.tolist()) - {len(f)}:
        front = np.flatnonzero(rank == r)
        for m in range(f.shape[1]):
            order = front[np.lexsort((front, f[front, m]))]
            d[order[0]] = d[order[-1]] = math.inf
            span = f[order[-1], m] - f[order[0], m]
            for k in range(1, len(order) - 1):
                if span > 0:
                    d[order[k]] += (f[order[k + 1], m] - f[order[k - 1], m]) / span
    return d


def random_points(seed: int, n: int, m: int) -> np.ndarray:
    """Points on a coarse lattice: many ties and duplicates among them."""
    return np.random.default_rng(seed).integers(0, 6, size=(n, m)).astype(np.float32)


def test_a_hand_computed_front():
    valid = np.ones(5, bool)
    rank = np.asarray(rank_of(HAND, valid))
    assert rank.tolist() == [0, 0, 1, 0, 2]
    d = np.asarray(crowding_of(HAND, rank))
    # front 0 sorted along each objective: (1,5) (2,3) (4,1); (2,3) spans 3/3 and 4/4
    assert d.tolist() == [math.inf, 2.0, math.inf, math.inf, math.inf]
    assert float(hv2(HAND, valid, np.array([6, 6], np.float32))) == 17.0
    # the survivors of 4: front 0 (its two extremes, then the crowded middle), then the
    # single point of front 1
    assert np.asarray(pareto.survivors(HAND, valid, 4)).tolist() == [0, 3, 1, 2]


def test_invalid_individuals_rank_last_and_dominate_nothing():
    valid = np.array([True, False, True, True, False])
    rank = np.asarray(rank_of(HAND, valid))
    assert rank.tolist() == [0, 5, 0, 0, 5]  # (3,4) is no longer dominated by (2,3)
    assert np.asarray(crowding_of(HAND, rank))[[1, 4]].tolist() == [0.0, 0.0]
    dom = np.asarray(pareto.domination_matrix(HAND, valid))
    assert not dom[[1, 4]].any() and dom[:, 1][valid].all()


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("m", [2, 3])
def test_ranks_and_hypervolume_agree_with_moocore(seed, m):
    f = random_points(seed, 40, m)
    valid = np.ones(len(f), bool)
    np.testing.assert_array_equal(np.asarray(rank_of(f, valid)), moocore.pareto_rank(f))
    ref = np.full(m, 6.5, np.float32)
    hv = float((hv2 if m == 2 else hv3)(f, valid, ref))
    assert hv == pytest.approx(moocore.hypervolume(f, ref=ref), rel=1e-6)


@pytest.mark.parametrize("seed", range(4))
def test_hypervolume_ignores_invalid_points_and_points_beyond_the_reference(seed):
    f = random_points(seed, 30, 3) + np.random.default_rng(seed).random((30, 3), np.float32)
    valid = np.random.default_rng(seed + 7).random(30) < 0.7
    ref = np.array([5.0, 5.5, 4.5], np.float32)
    inside = valid & (f < ref).all(axis=1)
    expected = moocore.hypervolume(f[inside], ref=ref) if inside.any() else 0.0
    assert float(hv3(f, valid, ref)) == pytest.approx(expected, rel=1e-5)
    inside2 = valid & (f[:, :2] < ref[:2]).all(axis=1)
    expected2 = moocore.hypervolume(f[inside2, :2], ref=ref[:2]) if inside2.any() else 0.0
    assert float(hv2(f[:, :2], valid, ref[:2])) == pytest.approx(expected2, rel=1e-5)


@pytest.mark.parametrize("seed", range(6))
def test_crowding_is_debs_and_fronts_hold_their_invariants(seed):
    f = random_points(seed, 50, 3)
    valid = np.random.default_rng(seed).random(50) < 0.9
    rank = np.asarray(rank_of(f, valid))
    np.testing.assert_allclose(np.asarray(crowding_of(f, rank)), deb_crowding(f, rank),
                               rtol=1e-6)  # float32 against the float64 transcription
    dom = np.asarray(pareto.domination_matrix(f, valid))
    for j in np.flatnonzero(valid):
        dominators = rank[dom[:, j]]
        # nobody of its own front or a later one dominates it; a front > 0 has a
        # dominator in the front just before
        assert (dominators < rank[j]).all()
        assert rank[j] == 0 or (rank[j] - 1) in dominators


@pytest.mark.parametrize("seed", range(4))
def test_survivors_keep_whole_fronts_then_the_least_crowded(seed):
    f = random_points(seed, 60, 2)
    valid = np.ones(60, bool)
    keep = np.asarray(pareto.survivors(f, valid, 25))
    rank = np.asarray(rank_of(f, valid))
    d = np.asarray(crowding_of(f, rank))
    assert len(set(keep.tolist())) == 25
    left = np.setdiff1d(np.arange(60), keep)
    worst_kept = max(rank[keep])
    assert (rank[left] >= worst_kept).all()
    cut = rank[left] == worst_kept
    if cut.any():  # within the front that did not fit, the kept are the least crowded
        assert d[keep][rank[keep] == worst_kept].min() >= d[left][cut].max()


def test_tournaments_follow_the_crowded_comparison_and_the_key():
    rank = jnp.array([0, 1, 0, 2, 0], jnp.int32)
    crowding = jnp.array([1.0, 9.0, 3.0, 9.0, jnp.inf], jnp.float32)
    active = jnp.array([True, True, True, True, False])
    key = jax.random.PRNGKey(3)
    won = np.asarray(pareto.crowded_tournament(key, rank, crowding, active, 400))
    assert 4 not in won  # inactive, never drawn
    counts = np.bincount(won, minlength=5)
    # individual 2 (front 0, the larger crowding of the active front-0 pair) wins most
    assert counts[2] == counts.max() and counts[3] < counts[0]
    again = pareto.crowded_tournament(key, rank, crowding, active, 400)
    np.testing.assert_array_equal(won, np.asarray(again))


def test_batched_calls_equal_single_calls():
    fs = np.stack([random_points(s, 24, 2) for s in range(5)])
    valid = np.ones((5, 24), bool)
    ref = np.full((5, 2), 6.5, np.float32)
    ranks = jax.jit(jax.vmap(pareto.nondominated_rank))(fs, valid)
    d = jax.jit(jax.vmap(pareto.crowding_distance))(fs, ranks)
    hv = jax.jit(jax.vmap(pareto.hypervolume))(fs, valid, ref)
    for i in range(5):
        np.testing.assert_array_equal(np.asarray(ranks[i]), np.asarray(rank_of(fs[i], valid[i])))
        np.testing.assert_array_equal(np.asarray(d[i]), np.asarray(crowding_of(fs[i], ranks[i])))
        assert float(hv[i]) == float(hv2(fs[i], valid[i], ref[i]))


def test_hypervolume_refuses_other_objective_counts():
    with pytest.raises(ValueError, match="2 or 3 objectives"):
        pareto.hypervolume(np.zeros((3, 4), np.float32), np.ones(3, bool), np.ones(4))
