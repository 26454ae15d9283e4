"""Selection operators: properties under jit + vmap, exact counts, statistics.

Each operator is jitted once below per way it is called (over runs, once, over keys),
and every test of one kind calls it on the same shapes, so that the file compiles
one program per operator and population size.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.stats
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxga.operators import selection as S

P = 13  # odd on purpose
R = 4  # runs per hypothesis example and per batch of test_same_key_... (vmap over runs)

_FNS = {
    "roulette": S.roulette,
    "roulette_elite": S.roulette_elite,
    "layered_thirds": S.layered_thirds,
    "stratified": S.stratified,
    "stratified_value": functools.partial(S.stratified, bands="value"),
    "tournament3": functools.partial(S.tournament, k=3),
    "shuffle": S.shuffle,
}
_RUNS = {name: jax.jit(jax.vmap(fn)) for name, fn in _FNS.items()}


def _default_and_masked(fn):
    """One run of ``fn``: with its default mask (everyone active) and with ``active``."""
    return jax.jit(lambda key, f, active: (fn(key, f), fn(key, f, active)))


_ONE = {name: _default_and_masked(fn) for name, fn in _FNS.items()}
_DRAWS = {name: jax.jit(jax.vmap(fn, in_axes=(0, None, None)))
          for name, fn in {**_FNS, "tournament2": functools.partial(S.tournament, k=2)}.items()}
"""Many draws (one per key) on one population."""


def _rank_order(f, active):
    """Reference: active by decreasing fitness, ties by lower index."""
    idx = [i for i in range(len(f)) if active[i]]
    return sorted(idx, key=lambda i: (-f[i], i))


def _layered_counts(f, active):
    order = _rank_order(f, active)
    m = len(order)
    q = m // 3
    counts = np.zeros(len(f), int)
    for r, i in enumerate(order):
        counts[i] = 2 if r < q else 1 if r < 2 * q else 1 if r < 2 * q + m % 3 else 0
    return counts


_fitness = st.lists(
    st.one_of(
        st.just(0.0),
        st.floats(0.0, 10.0, width=32, allow_subnormal=False),
        st.sampled_from([1.0, 2.0]),
    ),
    min_size=R * P, max_size=R * P,
)
_active = st.lists(st.booleans(), min_size=R * P, max_size=R * P)


@settings(max_examples=80)
@given(_fitness, _active, st.integers(0, 2**31 - 1), st.booleans())
def test_selection_properties(fit, act, seed, all_active):
    f = np.array(fit, np.float32).reshape(R, P)
    a = np.array(act, bool).reshape(R, P)
    if all_active:
        a[:] = True
    a[:, seed % P] = True  # at least one active individual per run
    keys = jax.random.split(jax.random.PRNGKey(seed), R)
    for name, run in _RUNS.items():
        idx = np.asarray(run(keys, jnp.asarray(f), jnp.asarray(a)))
        assert idx.dtype == np.int32 and idx.shape == (R, P)
        assert ((idx >= 0) & (idx < P)).all(), name
        for r in range(R):
            assert a[r, idx[r]].all(), f"{name} selected an inactive individual"
            sel = idx[r][a[r]]  # the entries of the active slots
            fr, ar = f[r], a[r]
            m = int(ar.sum())
            if name in ("roulette", "roulette_elite") and fr[ar].sum() > 0:
                # a zero-fitness individual is never drawn (except the elite replacement)
                zero = fr[idx[r]] == 0
                assert zero.sum() == 0 or (name == "roulette_elite" and fr[ar].max() == 0)
            if name == "roulette_elite":
                best = _rank_order(fr, ar)[0]
                assert best in sel
                plain = np.asarray(_RUNS["roulette"](keys, jnp.asarray(f), jnp.asarray(a)))[r]
                diff = np.flatnonzero(plain != idx[r])
                assert len(diff) <= 1
                if len(diff):  # the replaced slot held the worst active-slot selection
                    slot = diff[0]
                    assert ar[slot] and idx[r, slot] == best
                    assert fr[plain[slot]] == fr[plain[ar]].min()
            if name == "layered_thirds":
                np.testing.assert_array_equal(np.bincount(sel, minlength=P),
                                              _layered_counts(fr, ar))
            if name == "stratified":
                order = _rank_order(fr, ar)
                kept, dropped = order[: m - m // 4], order[m - m // 4 :]
                counts = np.bincount(sel, minlength=P)
                assert (counts[kept] >= 1).all() and (counts[dropped] == 0).all()
                assert counts.sum() == m
            if name == "stratified_value":
                lo, hi = fr[ar].min(), fr[ar].max()
                counts = np.bincount(sel, minlength=P)
                drop = ar & (fr < lo + (hi - lo) / 4)
                assert (counts[drop] == 0).all() and (counts[ar & ~drop] >= 1).all()


def test_same_key_same_result_and_vmap_equals_loop():
    f = np.random.default_rng(0).random((R, P), np.float32)
    keys = np.asarray(jax.random.split(jax.random.PRNGKey(1), R))
    ones = np.ones(P, bool)
    for name in _FNS:
        batched = np.asarray(_RUNS[name](keys, f, np.ones((R, P), bool)))
        for r in range(R):
            default, masked = (np.asarray(x) for x in _ONE[name](keys[r], f[r], ones))
            np.testing.assert_array_equal(default, batched[r], err_msg=name)
            np.testing.assert_array_equal(masked, batched[r], err_msg=name)


def test_no_active_individual_gives_index_zero():
    f = np.arange(P, dtype=np.float32)
    key = np.asarray(jax.random.PRNGKey(0))
    for name in _FNS:
        idx = np.asarray(_ONE[name](key, f, np.zeros(P, bool))[1])
        assert (idx == 0).all(), name


# ------------------------------------------------------------------ statistics
N_KEYS = 4000


@functools.cache
def _draw_keys() -> np.ndarray:
    return np.asarray(jax.random.split(jax.random.PRNGKey(123), N_KEYS))


def _draws(name, f, active=None):
    """``N_KEYS`` draws of the operator ``name`` (of ``_DRAWS``) on one population."""
    f = np.asarray(f, np.float32)
    if active is None:
        active = np.ones(f.shape, bool)
    return np.asarray(_DRAWS[name](_draw_keys(), f, np.asarray(active, bool)))


def test_roulette_frequencies():
    """Expected counts proportional to fitness over the active individuals (Zhu eq. 10)."""
    f = np.array([0, 1, 2, 3, 4, 5, 6, 7], np.float32)
    active = np.array([True] * 7 + [False])
    idx = _draws("roulette", f, active)
    counts = np.bincount(idx.ravel(), minlength=8)
    assert counts[0] == 0 and counts[7] == 0  # zero fitness, inactive
    exp = f[1:7].astype(float) / f[1:7].sum() * counts.sum()
    assert scipy.stats.chisquare(counts[1:7], exp).pvalue > 1e-4
    # the test has power: uniform selection would be rejected
    assert scipy.stats.chisquare(counts[1:7]).pvalue < 1e-10
    # all-zero fitness: uniform over the active
    idx = _draws("roulette", np.zeros(8), active)
    counts = np.bincount(idx.ravel(), minlength=8)
    assert counts[7] == 0 and scipy.stats.chisquare(counts[:7]).pvalue > 1e-4


def test_roulette_elite_keeps_the_best_and_is_roulette_otherwise():
    f = np.array([0.5, 0.1, 3.0, 0.2, 0.1, 0.4], np.float32)
    idx = _draws("roulette_elite", f)
    plain = _draws("roulette", f)
    assert (idx == 2).any(axis=1).all()
    assert ((idx != plain).sum(axis=1) <= 1).all()


@pytest.mark.parametrize("k", [2, 3])
def test_tournament_rank_probabilities(k):
    """P(rank r wins) = ((M - r + 1)^k - (M - r)^k) / M^k with M active, r = 1 best."""
    rng = np.random.default_rng(k)
    f = rng.permutation(10).astype(np.float32) + 1
    active = np.ones(10, bool)
    active[[2, 7]] = False
    m = 8
    idx = _draws(f"tournament{k}", f, active)
    assert active[idx].all()
    order = _rank_order(f, active)
    counts = np.array([(idx == i).sum() for i in order])
    r = np.arange(1, m + 1)
    prob = ((m - r + 1.0) ** k - (m - r) ** k) / m**k
    assert scipy.stats.chisquare(counts, prob * counts.sum()).pvalue > 1e-4
    other = 5 - k  # the other tournament size must be rejected
    prob2 = ((m - r + 1.0) ** other - (m - r) ** other) / m**other
    assert scipy.stats.chisquare(counts, prob2 * counts.sum()).pvalue < 1e-10


@pytest.mark.parametrize("p", [9, 10, 11, 12, 2, 1])
def test_layered_thirds_exact_counts(p):
    """IMGA 4.3.1: top third x2, middle third x1, bottom dropped, p mod 3 best of the
    bottom part added; with ties broken by lower index."""
    f = np.array([5, 1, 9, 9, 0, 3, 7, 2, 8, 4, 6, 2][:p], np.float32)
    idx = _draws("layered_thirds", f)[:50]
    want = _layered_counts(f, np.ones(p, bool))
    for row in idx:
        np.testing.assert_array_equal(np.bincount(row, minlength=p), want)
    if p == 11:  # by hand: order 2,3 | 8,6,10 | 0,9 | 5,7,1,4 -> q = 3, r = 2
        assert want.tolist() == [1, 0, 2, 2, 0, 1, 1, 0, 2, 1, 1]


def test_layered_thirds_is_shuffled():
    """Slot 0 holds individual i with probability copies_i / P (random pairing)."""
    f = np.arange(12, dtype=np.float32)
    idx = _draws("layered_thirds", f)
    want = _layered_counts(f, np.ones(12, bool)) / 12
    counts = np.bincount(idx[:, 0], minlength=12)
    nz = want > 0
    assert (counts[~nz] == 0).all()
    assert scipy.stats.chisquare(counts[nz], want[nz] * N_KEYS).pvalue > 1e-4


def test_shuffle_is_a_random_permutation_of_the_active_individuals():
    """MPMGA's pairing (presets/mpmga.toml): every active individual once on the active
    slots, active individuals on the inactive ones, each active individual equally likely
    in each active slot, so the pairs (2k, 2k + 1) change from draw to draw."""
    f = np.array([3.0, 0.5, 8.0, 1.0, 6.0, 0.7, 2.0, 5.0], np.float32)
    active = np.array([True, True, False, True, True, True, False, True])
    idx = _draws("shuffle", f, active)
    on = np.flatnonzero(active)
    for row in idx:
        assert sorted(row[on].tolist()) == on.tolist()
        assert active[row[~active]].all()
    counts = np.stack([np.bincount(idx[:, s], minlength=8)[on] for s in on])
    assert scipy.stats.chisquare(counts.ravel()).pvalue > 1e-4  # uniform over slots
    mates = {tuple(sorted(row[:2].tolist())) for row in idx}
    assert len(mates) > 10  # slot 0's mate is not fixed


def test_stratified_drops_the_last_quartile_and_refills_by_roulette():
    f = np.array([3.0, 0.5, 8.0, 1.0, 6.0, 0.7, 2.0, 5.0, 4.0, 0.2, 7.0, 9.0], np.float32)
    idx = _draws("stratified", f)
    order = _rank_order(f, np.ones(12, bool))
    kept, dropped = order[:9], order[9:]
    assert sorted(dropped) == [1, 5, 9]  # the three worst
    counts = np.stack([np.bincount(row, minlength=12) for row in idx])
    assert (counts[:, dropped] == 0).all() and (counts[:, kept] >= 1).all()
    refill = (counts[:, kept] - 1).sum(axis=0)  # 3 roulette draws per call
    assert refill.sum() == 3 * N_KEYS
    exp = f[kept].astype(float) / f[kept].sum() * refill.sum()
    assert scipy.stats.chisquare(refill, exp).pvalue > 1e-4
    assert scipy.stats.chisquare(refill).pvalue < 1e-10  # not uniform


def test_stratified_value_bands():
    """Equal-width fitness bands: everything below min + (max - min) / 4 is dropped."""
    f = np.array([0.0, 1.0, 2.0, 2.4, 2.6, 10.0, 9.0, 8.0], np.float32)
    idx = _draws("stratified_value", f)
    counts = np.stack([np.bincount(row, minlength=8) for row in idx])
    assert (counts[:, [0, 1, 2, 3]] == 0).all() and (counts[:, 4:] >= 1).all()
    # equal fitness: nothing dropped, everyone once
    idx = _draws("stratified_value", np.ones(8))
    assert all(sorted(row) == list(range(8)) for row in idx[:20])


def test_dtypes_under_x64():
    """The result's dtype, traced under x64 (``eval_shape``: as computing it would give,
    without compiling one program per operation)."""
    with jax.enable_x64(True):
        for name, fn in _FNS.items():
            out = jax.eval_shape(
                lambda fn=fn: fn(jax.random.PRNGKey(0), jnp.arange(P, dtype=jnp.float32)))
            assert out.dtype == jnp.int32, name
