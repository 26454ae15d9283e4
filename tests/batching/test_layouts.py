"""The accelerators' layout of jaxga's folded computations (decision 049): lowered for a
GPU or TPU, a gated operator computes all the entries of its folded batch in one block
(``jaxga.operators.lift.pool_width``), with the same results as the CPU's small blocks.

Programs are only lowered for ``cuda`` (no GPU is needed); results come from the CPU with
the accelerators' layout forced (``tests.lowering_variants.accelerators_layout``), each
in a function object of its own so that no program compiled before is reused (the
layout's spy says so).
"""

from __future__ import annotations

import jax
import numpy as np
import pytest

from jaxga._batching.folding import layout_as
from jaxga.operators.lift import (
    ACCELERATOR_POOL_BYTES,
    ACCELERATOR_POOL_MAX,
    POOL_MAX,
    POOL_SHRINK,
    gated_map,
    pool_width,
)
from tests.lowering_variants import accelerators_layout

CALLS, ENTRIES = 4, 10


def _gated(block=None):
    """``gated_map`` of one call (``ENTRIES`` entries, a closed-over per-call offset),
    to be vmapped over ``CALLS`` calls."""

    def call(apply, x, offset):
        return gated_map(lambda v: (v * 3 + offset,), apply, (x,), (-x,), block=block)[0]

    return jax.vmap(call)


def _inputs():
    rng = np.random.default_rng(4)
    apply = rng.random((CALLS, ENTRIES)) < 0.4
    x = rng.integers(0, 100, (CALLS, ENTRIES)).astype(np.int32)
    offset = rng.integers(0, 1000, CALLS).astype(np.int32)
    return apply, x, offset


def test_lowered_for_a_gpu_a_gated_map_is_one_block_of_all_its_entries():
    """The program lowered for ``cuda`` is, to the letter, the CPU's program with a
    block of all ``CALLS * ENTRIES`` entries; the CPU's own blocks are narrower."""
    args = _inputs()

    def text(fn, platform):
        return jax.jit(fn).trace(*args).lower(lowering_platforms=(platform,)).as_text()

    cuda = text(_gated(), "cuda")
    assert cuda == text(_gated(block=CALLS * ENTRIES), "cpu")
    assert cuda != text(_gated(), "cpu")


def test_the_accelerators_blocks_give_the_cpus_results():
    apply, x, offset = _inputs()
    want = np.where(apply, x * 3 + offset[:, None], -x)
    with accelerators_layout() as seen:
        wide = jax.jit(lambda *a: _gated()(*a))(apply, x, offset)
    assert seen == [True]  # traced here, laid out for a GPU
    small = jax.jit(lambda *a: _gated()(*a))(apply, x, offset)
    np.testing.assert_array_equal(wide, want)
    np.testing.assert_array_equal(small, want)


@pytest.mark.parametrize("block, calls, per_call", [(15, 1, 60), (15, 100, 60),
                                                    (15, 2048, 60), (15, 4096, 60),
                                                    (64, 1, 10)])
def test_pool_width_on_the_cpu_and_on_an_accelerator(block, calls, per_call):
    cpu = pool_width(block, calls, per_call)
    assert cpu == max(block, min(-(-block * calls // POOL_SHRINK), POOL_MAX))
    with layout_as("cuda"):
        accelerator = pool_width(block, calls, per_call)
    assert accelerator == max(block, min(calls * per_call, ACCELERATOR_POOL_MAX))
    assert accelerator >= cpu
    # every entry in one block whenever they fit the largest
    assert accelerator >= min(calls * per_call, ACCELERATOR_POOL_MAX)


def test_on_an_accelerator_a_block_holds_at_most_its_bytes_of_entries():
    """Entries of long paths make narrower blocks: at most ``ACCELERATOR_POOL_BYTES``
    of them, never fewer than the per-call block; the CPU ignores their size."""
    many, big = 2048 * 60, ACCELERATOR_POOL_BYTES // 1000
    with layout_as("cuda"):
        assert pool_width(15, 2048, 60, entry_bytes=1300) == min(many, ACCELERATOR_POOL_MAX)
        assert pool_width(15, 2048, 60, entry_bytes=big) == 1000
        assert pool_width(15, 2048, 60, entry_bytes=ACCELERATOR_POOL_BYTES * 2) == 15
    assert pool_width(15, 2048, 60, entry_bytes=big) == pool_width(15, 2048, 60)
