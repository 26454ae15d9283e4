"""lane_while_loop (jaxga._batching.lanes): the plain while_loop's results under any vmap nesting,
in its two-phase and its narrow form (``min_lanes=1``: compacted at any width) and as
one plain loop below ``min_lanes``."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._batching.lanes import lane_while_loop


def _collatz(loop, x, table, bound):
    """Count Collatz steps of ``x`` (at most ``bound``), summing ``table`` entries on the
    way: lanes take from 0 to over 100 iterations, and the body reads a closed-over
    shared table and a closed-over per-lane bound."""

    def cond(c):
        v, steps, _ = c
        return (v != 1) & (steps < bound)

    def body(c):
        v, steps, acc = c
        v = jnp.where(v % 2 == 0, v // 2, 3 * v + 1)
        return v, steps + 1, acc + table[v % table.shape[0]]

    return loop(cond, body, (x, jnp.int32(0), jnp.float32(0.0)))



@pytest.mark.parametrize("narrow", [False, True])
@pytest.mark.parametrize("shape", [(40,), (5, 9), (3, 4, 6)])
def test_equals_the_while_loop_at_any_vmap_depth(shape, narrow):
    """Same carries, bit for bit, as lax.while_loop under 1-3 nested vmaps, with a shared
    operand (table) and a per-lane one (bound) both closed over."""
    rng = np.random.default_rng(0)
    xs = jnp.asarray(rng.integers(1, 3000, shape), jnp.int32)
    bounds = jnp.asarray(rng.integers(5, 200, shape), jnp.int32)
    table = jnp.asarray(rng.normal(size=37), jnp.float32)

    def run(loop):
        fn = lambda x, b: _collatz(loop, x, table, b)  # noqa: E731
        for _ in shape:
            fn = jax.vmap(fn)
        return jax.jit(fn)(xs, bounds)

    want = run(jax.lax.while_loop)
    got = run(functools.partial(lane_while_loop, narrow=narrow, min_lanes=1))
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and g.shape == shape
        assert np.array_equal(np.asarray(g), np.asarray(w))
    steps = np.asarray(want[1])
    assert steps.min() < 10 and steps.max() > 100  # very uneven lanes


def test_operand_batched_at_one_level_only():
    """An operand varying over the inner vmap level but shared by the outer one."""
    xs = jnp.arange(1, 61, dtype=jnp.int32).reshape(4, 15)
    tables = jnp.asarray(np.random.default_rng(1).normal(size=(15, 11)), jnp.float32)

    def run(loop):
        def inner(x, t):
            return _collatz(loop, x, t, 500)

        return jax.jit(jax.vmap(lambda x: jax.vmap(inner)(x, tables)))(xs)

    for g, w in zip(run(functools.partial(lane_while_loop, min_lanes=1)),
                    run(jax.lax.while_loop)):
        assert np.array_equal(np.asarray(g), np.asarray(w))


@pytest.mark.parametrize("narrow", [False, True])
@pytest.mark.parametrize("finish", ["none_run", "all_at_once", "most_slow"])
def test_every_split_between_the_full_and_the_compact_phase(finish, narrow):
    """No lane runs, all lanes stop together, and more lanes than the compact buffer
    holds run long (the full-width phase then continues)."""
    n = 64
    rounds = {"none_run": np.zeros(n), "all_at_once": np.full(n, 7),
              "most_slow": np.where(np.arange(n) % 3 == 0, 2, 40)}[finish]
    target = jnp.asarray(rounds, jnp.int32)

    def one(loop, t):
        return loop(lambda c: c[0] < t, lambda c: (c[0] + 1, c[1] * 3 + c[0]),
                    (jnp.int32(0), jnp.int32(1)))

    want = jax.vmap(lambda t: one(jax.lax.while_loop, t))(target)
    loop = functools.partial(lane_while_loop, narrow=narrow, min_lanes=1)
    got = jax.jit(jax.vmap(lambda t: one(loop, t)))(target)
    assert np.array_equal(np.asarray(got[0]), rounds)
    for g, w in zip(got, want):
        assert np.array_equal(np.asarray(g), np.asarray(w))


def test_without_vmap_it_is_the_while_loop():
    got = jax.jit(lambda: lane_while_loop(lambda c: c < 10, lambda c: c + 3, jnp.int32(0)))()
    assert int(got) == 12


def test_invalid_shrink_is_rejected():
    with pytest.raises(ValueError, match="shrink"):
        lane_while_loop(lambda c: c < 1, lambda c: c + 1, jnp.int32(0), shrink=1)


def test_unmasked_loop_with_a_body_that_keeps_finished_lanes():
    """masked=False skips the per-lane select: correct for a body that leaves a lane
    whose condition is false as it is (here: a counter that stops at its target)."""
    target = jnp.asarray(np.random.default_rng(2).integers(0, 60, 48), jnp.int32)

    def one(loop, t, **kw):
        def body(c):
            live = c[0] < t
            return c[0] + live.astype(jnp.int32), jnp.where(live, c[1] * 5 + c[0], c[1])

        return loop(lambda c: c[0] < t, body, (jnp.int32(0), jnp.int32(3)), **kw)

    want = jax.vmap(lambda t: one(jax.lax.while_loop, t))(target)
    got = jax.jit(jax.vmap(lambda t: one(lane_while_loop, t, masked=False, min_lanes=1)))(target)
    for g, w in zip(got, want):
        assert np.array_equal(np.asarray(g), np.asarray(w))


@pytest.mark.parametrize("narrow", [False, True])
def test_fewer_lanes_than_min_lanes_run_as_one_plain_loop(narrow):
    """Below ``min_lanes`` the lanes run in one while loop (the two-phase form has two, so
    its body is compiled twice); at or above it they are compacted. Same carries either
    way."""
    target = jnp.asarray(np.random.default_rng(3).integers(0, 50, 40), jnp.int32)

    def one(loop, t):
        return loop(lambda c: c[0] < t, lambda c: (c[0] + 1, c[1] * 7 + c[0]),
                    (jnp.int32(0), jnp.int32(1)))

    want = jax.vmap(lambda t: one(jax.lax.while_loop, t))(target)
    text = {}
    for min_lanes in (41, 40):
        loop = functools.partial(lane_while_loop, narrow=narrow, min_lanes=min_lanes)
        fn = jax.jit(jax.vmap(functools.partial(one, loop)))
        text[min_lanes] = fn.lower(target).as_text()
        for g, w in zip(fn(target), want):
            assert np.array_equal(np.asarray(g), np.asarray(w))
    assert text[41].count("stablehlo.while") == 1
    if narrow:  # one loop either way, but only the compacted one picks lanes
        assert text[40] != text[41]
    else:
        assert text[40].count("stablehlo.while") == 2
