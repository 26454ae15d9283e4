"""Batch-invariant float sums (jaxga._batching.numerics) and the objectives built on them.

Each function under test is jitted once below; inputs are NumPy arrays and expected values
come from NumPy (``math.fsum``).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._batching.numerics import ordered_mean, ordered_sum
from jaxga.core.objectives import angle_sum, path_length
from jaxga.maps import random_map

_ordered_sum = jax.jit(ordered_sum, static_argnames=("axis", "dtype"))
_ordered_mean = jax.jit(ordered_mean)
_row_sums = jax.jit(jax.vmap(lambda r: ordered_sum(jnp.sqrt(r))))
_OBJECTIVES = {f: jax.jit(jax.vmap(f, in_axes=(None, 0, 0))) for f in (path_length, angle_sum)}


def _in_blocks(fn, x, block):
    """``fn`` over the rows of ``x`` computed ``block`` rows at a time."""
    return np.concatenate([np.asarray(fn(x[i:i + block])) for i in range(0, len(x), block)])


@pytest.mark.parametrize("n", [0, 1, 2, 3, 7, 8, 60, 161])
def test_ordered_sum_is_the_sum(n):
    x = np.random.default_rng(n).random((5, n)).astype(np.float32) * 10
    got = np.asarray(_ordered_sum(x))
    want = np.array([math.fsum(r) for r in x.astype(np.float64)])
    # pairwise summation: error within ceil(log2 n) + 1 rounding steps of the total
    bound = (max(n, 1).bit_length() + 1) * np.finfo(np.float32).eps * np.maximum(want, 1)
    assert got.shape == (5,) and got.dtype == np.float32
    assert np.all(np.abs(got - want) <= bound)


def test_ordered_sum_axis_dtype_and_integers():
    x = np.arange(24, dtype=np.float32).reshape(2, 3, 4)
    assert np.array_equal(_ordered_sum(x, axis=1), np.sum(x, axis=1))
    assert _ordered_sum(np.array([True, True, False]), dtype=jnp.float32).dtype == jnp.float32
    ints = _ordered_sum(np.array([[2**30, 2**30, -(2**30)]], np.int32))
    assert ints.dtype == jnp.int32 and int(np.asarray(ints)[0]) == 2**30


def test_ordered_mean_over_a_mask():
    x = np.array([1.0, 2.0, 6.0, 100.0], np.float32)
    assert float(_ordered_mean(x, np.array([True, True, True, False]))) == 3.0
    assert float(_ordered_mean(x)) == 27.25
    assert float(_ordered_mean(x, np.zeros(4, bool))) == 0.0  # empty: 0, not NaN


def test_a_row_sum_does_not_depend_on_the_batch_around_it():
    """The rows of one array summed in batches of 1, 3, 64 and 256 are the same bits
    (XLA's own reduction differs in the last bit for about half of these rows on the
    2-core CI machine, depending on the batch size)."""
    x = np.random.default_rng(0).random((256, 161)).astype(np.float32) * 3
    full = np.asarray(_row_sums(x))
    for block in (1, 3, 64):
        assert np.array_equal(_in_blocks(_row_sums, x, block), full)


def test_path_objectives_do_not_depend_on_the_batch_around_them():
    """Waypoint paths' length and turn-angle sum, vmapped over 128 paths or one at a
    time: bit-identical (a seed's fitness does not depend on the seeds run with it)."""
    grid = random_map(16, 16, 0.0, 0, corner_rule="free")
    rng = np.random.default_rng(1)
    cells = rng.integers(0, 256, (128, 40)).astype(np.int32)
    length = rng.integers(1, 41, 128).astype(np.int32)
    for objective in (path_length, angle_sum):
        fn = _OBJECTIVES[objective]
        full = np.asarray(fn(grid, cells, length))
        one = np.concatenate([np.asarray(fn(grid, cells[i:i + 1], length[i:i + 1]))
                              for i in range(128)])
        assert np.array_equal(one, full)
