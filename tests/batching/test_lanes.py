"""lane_while_loop (jaxga._batching.lanes): the plain while_loop's results under any vmap nesting,
in its two-phase and its narrow form (``min_lanes=1``: compacted at any width) and as
one plain loop below ``min_lanes``.

Each comparison computes the plain ``lax.while_loop`` and the lane loops in one program,
jitted once below; data (lanes' targets, bounds, tables) are arguments, so that the cases
of one shape share their program.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._batching.lanes import lane_while_loop
from tests.lowering_variants import accelerators_layout

_PLAIN = jax.lax.while_loop
_WIDE = functools.partial(lane_while_loop, narrow=False, min_lanes=1)
_NARROW = functools.partial(lane_while_loop, narrow=True, min_lanes=1)


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


@jax.jit
def _collatz_nested(xs, bounds, table):
    """``(plain, two-phase, narrow)`` carries of ``_collatz`` under one vmap per
    dimension of ``xs``, ``table`` shared by every lane."""

    def run(loop):
        fn = lambda x, b: _collatz(loop, x, table, b)  # noqa: E731
        for _ in range(xs.ndim):
            fn = jax.vmap(fn)
        return fn(xs, bounds)

    return run(_PLAIN), run(_WIDE), run(_NARROW)


@pytest.mark.parametrize("narrow", [False, True])
@pytest.mark.parametrize("shape", [(40,), (5, 9), (3, 4, 6)])
def test_equals_the_while_loop_at_any_vmap_depth(shape, narrow):
    """Same carries, bit for bit, as lax.while_loop under 1-3 nested vmaps, with a shared
    operand (table) and a per-lane one (bound) both closed over."""
    rng = np.random.default_rng(0)
    xs = rng.integers(1, 3000, shape).astype(np.int32)
    bounds = rng.integers(5, 200, shape).astype(np.int32)
    table = rng.normal(size=37).astype(np.float32)
    want, wide, narrowed = _collatz_nested(xs, bounds, table)
    got = narrowed if narrow else wide
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and g.shape == shape
        assert np.array_equal(np.asarray(g), np.asarray(w))
    steps = np.asarray(want[1])
    assert steps.min() < 10 and steps.max() > 100  # very uneven lanes


@jax.jit
def _collatz_inner_tables(xs, tables):
    """``(plain, lane loop)``: ``tables[j]`` shared by the outer vmap, varying over the
    inner one."""

    def run(loop):
        def inner(x, t):
            return _collatz(loop, x, t, 500)

        return jax.vmap(lambda x: jax.vmap(inner)(x, tables))(xs)

    return run(_PLAIN), run(functools.partial(lane_while_loop, min_lanes=1))


def test_operand_batched_at_one_level_only():
    """An operand varying over the inner vmap level but shared by the outer one."""
    xs = np.arange(1, 61, dtype=np.int32).reshape(4, 15)
    tables = np.random.default_rng(1).normal(size=(15, 11)).astype(np.float32)
    want, got = _collatz_inner_tables(xs, tables)
    for g, w in zip(got, want):
        assert np.array_equal(np.asarray(g), np.asarray(w))


def _count_to(loop, t, **kw):
    return loop(lambda c: c[0] < t, lambda c: (c[0] + 1, c[1] * 3 + c[0]),
                (jnp.int32(0), jnp.int32(1)), **kw)


@jax.jit
def _count_lanes(target):
    """``(plain, two-phase, narrow)`` carries of ``_count_to`` over the lanes' targets."""
    return tuple(jax.vmap(functools.partial(_count_to, loop))(target)
                 for loop in (_PLAIN, _WIDE, _NARROW))


@pytest.mark.parametrize("narrow", [False, True])
@pytest.mark.parametrize("finish", ["none_run", "all_at_once", "most_slow"])
def test_every_split_between_the_full_and_the_compact_phase(finish, narrow):
    """No lane runs, all lanes stop together, and more lanes than the compact buffer
    holds run long (the full-width phase then continues)."""
    n = 64
    rounds = {"none_run": np.zeros(n), "all_at_once": np.full(n, 7),
              "most_slow": np.where(np.arange(n) % 3 == 0, 2, 40)}[finish]
    want, wide, narrowed = _count_lanes(np.asarray(rounds, np.int32))
    got = narrowed if narrow else wide
    assert np.array_equal(np.asarray(got[0]), rounds)
    for g, w in zip(got, want):
        assert np.array_equal(np.asarray(g), np.asarray(w))


_COUNT_BY_3 = jax.jit(lambda: lane_while_loop(lambda c: c < 10, lambda c: c + 3, jnp.int32(0)))


def test_without_vmap_it_is_the_while_loop():
    assert int(_COUNT_BY_3()) == 12


def test_invalid_shrink_is_rejected():
    with pytest.raises(ValueError, match="shrink"):
        lane_while_loop(lambda c: c < 1, lambda c: c + 1, jnp.int32(0), shrink=1)


def _keep_finished(loop, t, **kw):
    def body(c):
        live = c[0] < t
        return c[0] + live.astype(jnp.int32), jnp.where(live, c[1] * 5 + c[0], c[1])

    return loop(lambda c: c[0] < t, body, (jnp.int32(0), jnp.int32(3)), **kw)


@jax.jit
def _unmasked(target):
    """``(plain, unmasked lane loop)`` carries of ``_keep_finished``."""
    return (jax.vmap(lambda t: _keep_finished(_PLAIN, t))(target),
            jax.vmap(lambda t: _keep_finished(lane_while_loop, t, masked=False,
                                              min_lanes=1))(target))


def test_unmasked_loop_with_a_body_that_keeps_finished_lanes():
    """masked=False skips the per-lane select: correct for a body that leaves a lane
    whose condition is false as it is (here: a counter that stops at its target)."""
    target = np.random.default_rng(2).integers(0, 60, 48).astype(np.int32)
    want, got = _unmasked(target)
    for g, w in zip(got, want):
        assert np.array_equal(np.asarray(g), np.asarray(w))


def _count_by_7(loop, t):
    return loop(lambda c: c[0] < t, lambda c: (c[0] + 1, c[1] * 7 + c[0]),
                (jnp.int32(0), jnp.int32(1)))


_BY_7_PLAIN = jax.jit(jax.vmap(functools.partial(_count_by_7, _PLAIN)))
_BY_7_LANES = jax.jit(
    lambda target, narrow, min_lanes: jax.vmap(functools.partial(
        _count_by_7, functools.partial(lane_while_loop, narrow=narrow, min_lanes=min_lanes)
    ))(target), static_argnums=(1, 2))
"""``_count_by_7``'s carries over the lanes' targets (``narrow`` and ``min_lanes`` static)."""


@pytest.mark.parametrize("narrow", [False, True])
def test_fewer_lanes_than_min_lanes_run_as_one_plain_loop(narrow):
    """Below ``min_lanes`` the lanes run in one while loop (the two-phase form has two, so
    its body is compiled twice); at or above it they are compacted. Same carries either
    way."""
    target = np.random.default_rng(3).integers(0, 50, 40).astype(np.int32)
    want = _BY_7_PLAIN(target)
    text = {}
    for min_lanes in (41, 40):
        text[min_lanes] = _BY_7_LANES.lower(target, narrow, min_lanes).as_text()
        for g, w in zip(_BY_7_LANES(target, narrow, min_lanes), want):
            assert np.array_equal(np.asarray(g), np.asarray(w))
    assert text[41].count("stablehlo.while") == 1
    if narrow:  # one loop either way, but only the compacted one picks lanes
        assert text[40] != text[41]
    else:
        assert text[40].count("stablehlo.while") == 2


def _collatz_all(xs, bounds, table):
    """``_collatz_nested``'s three carries, for a program of its own (:func:`layout_as`)."""
    return _collatz_nested.__wrapped__(xs, bounds, table)


@pytest.mark.parametrize("narrow", [False, True])
def test_on_an_accelerator_every_lane_loop_is_one_plain_loop(narrow):
    """Laid out for an accelerator (lowered for ``cuda``, or forced on the CPU), the lane
    loop is the plain ``while_loop`` over all lanes whatever its form (on the CPU the
    two-phase form has two loops, the narrow one picks lanes), with its carries."""
    target = np.random.default_rng(3).integers(0, 50, 40).astype(np.int32)

    def lowered(min_lanes, platform):
        lanes = functools.partial(lane_while_loop, narrow=narrow, min_lanes=min_lanes)
        fn = jax.vmap(functools.partial(_count_by_7, lanes))
        return fn, jax.jit(fn).trace(target).lower(lowering_platforms=(platform,)).as_text()

    fn, cuda = lowered(1, "cuda")
    assert lowered(1, "cpu")[1].count("stablehlo.while") == (1 if narrow else 2)
    assert cuda == lowered(10**9, "cpu")[1]  # the plain loop's program, to the letter
    with accelerators_layout() as seen:
        got = jax.jit(lambda t: fn(t))(target)
    assert seen == [True]
    for g, w in zip(got, _BY_7_PLAIN(target)):
        assert np.array_equal(np.asarray(g), np.asarray(w))


def test_the_accelerators_layout_equals_the_while_loop_under_nested_vmaps():
    rng = np.random.default_rng(0)
    xs = rng.integers(1, 3000, (5, 9)).astype(np.int32)
    bounds = rng.integers(5, 200, (5, 9)).astype(np.int32)
    table = rng.normal(size=37).astype(np.float32)
    with accelerators_layout() as seen:
        want, wide, narrowed = jax.jit(_collatz_all)(xs, bounds, table)
    assert seen == [True, True]  # the two lane loops (the plain one has no client)
    for got in (wide, narrowed):
        for g, w in zip(got, want):
            assert np.array_equal(np.asarray(g), np.asarray(w))
