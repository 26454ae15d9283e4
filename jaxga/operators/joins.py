"""Joining two parents at a cut: the children of the single-point crossovers.

The splice ``head[:cut] + tail[start:]`` of two paths with the loop it may make cut as
:func:`jaxga.core.paths.remove_loops` cuts it (in O(L), no scan; exact for loop-free
parents: :mod:`jaxga.operators.crossover`, "Loops"), the random choice of the cut
(:func:`uniform_index`, :func:`kth_true`), and the acceptance of the two children of a pair
or the fall-back to their parents (:func:`accept_children`). Used by the crossovers of
:mod:`jaxga.operators.crossover` (common point, cut and check, heterologous).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxga.core.dtypes import I32
from jaxga.operators.repair import concat, prefix_count

__all__ = [
    "Joined",
    "accept_children",
    "join",
    "join_reverse",
    "kth_true",
    "kth_true_rows",
    "uniform_index",
]

_U32 = jnp.uint32


def kth_true(mask: jax.Array, r: jax.Array) -> jax.Array:
    """Index of the ``r``-th (0-based) True of a 1-D mask (0 if there are fewer).

    Masks longer than ``2 * _KTH_ROW`` are searched in rows of ``_KTH_ROW``
    (:func:`kth_true_rows`): a prefix sum over the rows' counts and one within a row
    instead of one over the whole mask: faster on masks of a path's capacity
    (decision 010).
    """
    n = mask.shape[0]
    if n <= 2 * _KTH_ROW:
        return _kth_true_scan(mask, r)
    rows = -(-n // _KTH_ROW)
    padded = jnp.zeros((rows * _KTH_ROW,), bool).at[:n].set(mask)
    row, col = kth_true_rows(padded.reshape(rows, _KTH_ROW), r)
    return jnp.where(r < jnp.sum(mask, dtype=I32), row * _KTH_ROW + col, 0)


_KTH_ROW = 16
"""Row width of :func:`kth_true`'s two-level search."""


def kth_true_rows(mask: jax.Array, r: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(row, col)`` of the ``r``-th True of a 2-D mask in row-major order.

    Two levels (prefix sums over the rows, then within the row) instead of one prefix
    sum over all ``rows * cols`` entries.
    """
    counts = jnp.sum(mask, axis=1, dtype=I32)
    before = prefix_count(counts) - counts  # Trues in the rows above
    row = jnp.clip(jnp.sum(before <= r, dtype=I32) - 1, 0, mask.shape[0] - 1)
    return row, _kth_true_scan(mask[row], r - before[row])


def _kth_true_scan(mask: jax.Array, r: jax.Array) -> jax.Array:
    """:func:`kth_true` by one prefix sum over the whole mask."""
    return jnp.argmax(prefix_count(mask) > r).astype(I32)


def uniform_index(bits: jax.Array, n: jax.Array) -> jax.Array:
    """A uniform index in ``[0, n)`` from random 32-bit words ``bits``: ``bits mod n``
    (bias below ``n / 2**32``; :mod:`jaxga.operators.crossover`, "Randomness"), 0 when
    ``n`` is 0. Elementwise."""
    return (bits % jnp.maximum(n, 1).astype(_U32)).astype(I32)


class Joined(NamedTuple):
    """A child spliced from two parents (:func:`join`, :func:`join_reverse`): its cells and
    length, whether it fits the capacity, and its one new segment (the junction), which
    the collision-checked crossover tests."""

    cells: jax.Array
    length: jax.Array
    ok: jax.Array
    left: jax.Array  # the two cells of the one new segment of the child
    right: jax.Array


def join(
    ca: jax.Array,
    cut: jax.Array,
    pos_in_b: jax.Array,
    cb: jax.Array,
    lb: jax.Array,
    start_b: jax.Array,
) -> Joined:
    """``ca[:cut] + cb[start_b:lb]`` with the loops cut as ``remove_loops`` cuts them.

    ``pos_in_b[k]`` is the (last) position of ``ca[k]`` in ``cb`` or -1. The first head
    position ``k < cut`` whose cell occurs in the tail (``pos_in_b[k] >= start_b``) makes
    the child ``ca[:k] + cb[pos_in_b[k]:]``; with none, the raw splice. Exact for
    loop-free parents (:mod:`jaxga.operators.crossover`, "Loops"). Also returns the child's one new
    segment ``(left, right)`` (the junction) and whether it fits the capacity.
    """
    n = ca.shape[0]
    i = jnp.arange(n, dtype=I32)
    hit = (i < cut) & (pos_in_b >= start_b)
    has = jnp.any(hit)
    a = jnp.where(has, jnp.argmax(hit).astype(I32), cut)
    b = jnp.where(has, pos_in_b[jnp.clip(a, 0, n - 1)], start_b)
    return _splice(ca, a, cb, b, lb)


def _splice(head: jax.Array, cut: jax.Array, tail: jax.Array, start: jax.Array,
            tail_len: jax.Array) -> Joined:
    """``head[:cut] + tail[start:tail_len]`` (the loop cut already chosen) with its
    junction ``(head[cut - 1], tail[start])`` and whether it fits the capacity."""
    n = head.shape[0]
    cells, length, ok = concat([(head, 0, cut), (tail, start, tail_len)], n)
    right = tail[jnp.clip(start, 0, n - 1)]
    left = jnp.where(cut > 0, head[jnp.clip(cut - 1, 0, n - 1)], right)
    return Joined(cells, length, ok, left, right)


def join_reverse(
    cb: jax.Array,
    cut_b: jax.Array,
    ca: jax.Array,
    la: jax.Array,
    start_a: jax.Array,
    pos_a_in_b: jax.Array,
) -> Joined:
    """``cb[:cut_b] + ca[start_a:la]`` with the loops cut, from the lookup ``pos_a_in_b``
    (the last position of each ``ca[k]`` in ``cb``, or -1) that :func:`join` uses for
    the other child: no lookup of ``cb``'s cells in ``ca``.

    :func:`join` looks for the first head position ``k < cut_b`` whose cell occurs in
    the tail ``ca[start_a:la]``. When ``cb`` is loop-free every cell has at most one
    position in it, so that ``k`` is the smallest ``pos_a_in_b[i]`` below ``cut_b`` over
    the tail positions ``i``, and the child continues at the last such ``i``: the
    same child as ``join(cb, cut_b, pos_b_in_a, ca, la, start_a)`` whenever ``cb`` is
    loop-free (evolving populations are) and ``cut_b`` is at most its length.
    With a ``cb`` that has loops the child is still as continuous as the raw splice (a
    cut junction joins ``cb[k - 1]`` to the cell that follows it in ``cb``), but a loop
    through the junction may remain.
    """
    n = cb.shape[0]
    i = jnp.arange(n, dtype=I32)
    tail = (i >= start_a) & (i < la) & (pos_a_in_b >= 0) & (pos_a_in_b < cut_b)
    first = jnp.min(jnp.where(tail, pos_a_in_b, n))
    has = first < n
    b = jnp.where(has, first, cut_b)
    a = jnp.where(has, jnp.max(jnp.where(tail & (pos_a_in_b == first), i, -1)), start_a)
    return _splice(cb, b, ca, a, la)


def _choose(take: jax.Array, new: jax.Array, old: jax.Array) -> jax.Array:
    return jnp.where(take, new, old)


def accept_children(do, take1, take2, k1: Joined, k2: Joined, c1, l1, c2, l2, need1=True,
                    need2=True):
    """``(c1, l1, c2, l2, failed)`` of a pair: child k replaces parent k where
    ``do & take_k & fits_k``, else the parent is kept. An overflow counts as a failure
    where ``do & need_k`` (``need_k`` False: the child was rejected for another reason
    that does not depend on its length, e.g. a blocked junction), so that ``failed``
    counts the slots that fell back to their parent (:mod:`jaxga.operators.crossover`,
    "Failure")."""
    a1 = do & take1 & k1.ok
    a2 = do & take2 & k2.ok
    failed = (do & need1 & ~k1.ok).astype(I32) + (do & need2 & ~k2.ok).astype(I32)
    return (
        _choose(a1, k1.cells, c1), _choose(a1, k1.length, l1),
        _choose(a2, k2.cells, c2), _choose(a2, k2.length, l2),
        failed,
    )
