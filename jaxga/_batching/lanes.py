"""A ``while_loop`` whose unfinished lanes are compacted under ``vmap``.

Under ``vmap`` a ``lax.while_loop`` with a per-lane condition runs every lane until the
slowest one stops: the body is computed for the whole batch at every iteration and the
finished lanes' results are discarded by a select. For the median-insertion rounds of
:func:`jaxga.operators.repair.connect` that is most of the work: most connections close in one
round and a few need many, so a block of connections runs as many rounds at full width
as its slowest connection needs (decision 001).

:func:`lane_while_loop` has the semantics of ``lax.while_loop`` for one lane. It carries
a batching rule that folds every ``vmap`` level into one
flat batch of lanes (:func:`jaxga._batching.folding.fold_call`), so that the loop
sees all its lanes at once, however many ``vmap`` levels (mutants, runs, islands) are
stacked. It then runs the rounds at full width only while more than ``1 / shrink`` of
the lanes are unfinished, moves the unfinished ones to the front of a buffer of
``1 / shrink`` of the lanes (:func:`jaxga._batching.scatter.true_first_order`) and finishes them
there. Each lane computes exactly what it computes alone (same body, same carry, same
operands; bit for bit), only the discarded work is skipped.

Below :data:`MIN_COMPACT_LANES` lanes (64: the loops of a run or two, such as one
run's 60 initial walks or its 5-15 connections of a generation) the loop is one plain
``while_loop`` over all lanes. At that width an iteration costs mostly its fixed
overhead whatever the number of lanes, so compaction saves little, and the two-phase
form compiles the body twice (decision 001).

On a GPU or TPU (:func:`jaxga._batching.folding.on_accelerator`) the loop is always one
plain ``while_loop`` over all lanes: there an iteration costs a chain of kernel launches
whatever its width, so the fewest iterations (the slowest lane's count) are fastest, and
compaction only adds iterations and kernels (decision 049).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.folding import fold_call, hoist, on_accelerator
from jaxga._batching.scatter import true_first_order, true_first_positions

__all__ = ["lane_while_loop"]

SHRINK = 8
"""Default ratio of all lanes to the lanes of the compacted buffer."""

MIN_COMPACT_LANES = 64
"""Default lane count below which the loop is one plain loop over all lanes (module
docstring; ``min_lanes`` of :func:`lane_while_loop`): a plain loop is faster over the
lanes of a few runs and slower over a few hundred lanes (decision 001)."""


def lane_while_loop(
    cond_fun: Callable[[Any], jax.Array],
    body_fun: Callable[[Any], Any],
    init_val: Any,
    *,
    shrink: int = SHRINK,
    masked: bool = True,
    narrow: bool = False,
    min_lanes: int = MIN_COMPACT_LANES,
) -> Any:
    """``lax.while_loop(cond_fun, body_fun, init_val)``, with the unfinished lanes
    compacted when it runs under ``vmap`` (module docstring).

    Args:
        cond_fun: ``carry -> bool`` scalar condition of one lane.
        body_fun: ``carry -> carry`` of one lane. Both may close over arrays (a map, a
            lane's random words): they are hoisted into explicit operands, those shared
            by every lane staying one copy.
        init_val: the carry (a pytree of arrays) of one lane.
        shrink: static; the compacted buffer holds ``1 / shrink`` of the lanes (without
            ``vmap``, or with fewer than ``shrink`` lanes, this is a plain
            ``while_loop``).
        masked: static. True: as ``vmap`` of a ``while_loop`` does, every iteration
            keeps the carry of the lanes whose condition is false (a select over the
            whole carry). False skips that select; then ``body_fun`` itself must leave
            such a lane's condition false and change nothing of its carry that the
            caller reads (scratch entries only). Worth it for large carries: a random
            walk's visited table and path buffer on a 50 x 50 map.
        narrow: static. False: the two phases above (full width, then compacted), which
            compile the body twice. True: one loop at the compacted width that advances
            the first unfinished lanes at every iteration, so the body is compiled once
            (a shorter compile). Narrow suits loops whose lanes mostly finish within a
            few iterations (median-insertion rounds); long loops such as walks then
            need many iterations at the narrow width and run slower (decision 001).
        min_lanes: static; with fewer lanes than this (all ``vmap`` levels together) the
            loop runs every lane to the end, as ``vmap`` of a ``while_loop`` does, and
            the body is compiled once. A narrow batch (one run's population) gains
            little from compaction: its iterations cost mostly their fixed overhead
            whatever the width. On an accelerator every loop is plain (module
            docstring).

    Returns:
        The final carry, equal bit for bit to the plain ``while_loop``'s.
    """
    if shrink < 2:
        raise ValueError(f"shrink must be >= 2, got {shrink}")
    carry_leaves, carry_tree = jax.tree_util.tree_flatten(init_val)
    carry_leaves = [jnp.asarray(x) for x in carry_leaves]
    init_val = jax.tree_util.tree_unflatten(carry_tree, carry_leaves)
    # Closed-over values become operands (a folded call cannot batch closed-over values).
    cond_op, cond_consts = hoist(cond_fun, init_val)
    body_op, body_consts = hoist(body_fun, init_val)
    n_cond = len(cond_consts)

    def client(lead, lanes, operands, axes):
        return _run(lambda c, o: cond_op(o[:n_cond], c), lambda c, o: body_op(o[n_cond:], c),
                    carry_tree, lead, lanes, operands, axes, int(shrink),
                    bool(masked), bool(narrow), int(min_lanes))

    out = fold_call(client, carry_leaves, cond_consts + body_consts, carry_leaves)
    return jax.tree_util.tree_unflatten(carry_tree, out)


def _run(cond_fun, body_fun, carry_tree, lead, flat_c, flat_o, axes, shrink, masked, narrow,
         min_lanes):
    """The loop over the lanes ``flat_c`` (the folded ``vmap`` levels ``lead``; a plain
    ``while_loop`` without ``vmap``). ``cond_fun(carry, operands)`` and
    ``body_fun(carry, operands)`` are one lane's."""

    def tree(leaves):
        return jax.tree_util.tree_unflatten(carry_tree, leaves)

    if not lead:
        out = jax.lax.while_loop(lambda c: cond_fun(c, flat_o), lambda c: body_fun(c, flat_o),
                                 tree(flat_c))
        return jax.tree_util.tree_leaves(out)
    n = int(np.prod(lead, dtype=np.int64))

    def one_cond(c1, o1):
        return cond_fun(tree(c1), o1)

    def one_body(c1, o1):
        return jax.tree_util.tree_leaves(body_fun(tree(c1), o1))

    def active(c, o):
        return jax.vmap(one_cond, in_axes=(0, axes))(c, o)

    def step(c, o, act):
        """One iteration of the lanes ``c`` whose condition is ``act``: the carry and
        the lanes' conditions after it (evaluated once per iteration)."""
        new = jax.vmap(one_body, in_axes=(0, axes))(c, o)
        if masked:
            new = [jnp.where(act.reshape((-1,) + (1,) * (a.ndim - 1)), b, a)
                   for b, a in zip(new, c)]
        new = [b.astype(a.dtype) for b, a in zip(new, c)]
        return new, active(new, o)

    def loop(cond, c, o):
        """``while cond(act): c, act = step(c, o, act)``, the flags carried along."""
        _, c = jax.lax.while_loop(lambda s: cond(s[0]), lambda s: step(s[1], o, s[0])[::-1],
                                  (active(c, o), c))
        return c

    m = n // shrink
    if m < 1 or n < min_lanes or on_accelerator():
        flat_c = loop(jnp.any, flat_c, flat_o)
    elif narrow:
        # One loop at width m: each iteration advances the first m unfinished lanes and
        # evaluates the condition of those m lanes only.
        def narrow_body(s):
            act, c = s
            idx = true_first_order(act)[:m]
            sub_o = [x if ax is None else x[idx] for x, ax in zip(flat_o, axes)]
            sub_c, sub_act = step([x[idx] for x in c], sub_o, act[idx])
            c = [x.at[idx].set(sc, unique_indices=True) for x, sc in zip(c, sub_c)]
            return act.at[idx].set(sub_act, unique_indices=True), c

        _, flat_c = jax.lax.while_loop(lambda s: jnp.any(s[0]), narrow_body,
                                       (active(flat_c, flat_o), flat_c))
    else:
        # Full width while more than m lanes are unfinished ...
        flat_c = loop(lambda act: jnp.sum(act, dtype=jnp.int32) > m, flat_c, flat_o)
        # ... then the (at most m) unfinished lanes, moved to the front, in m lanes.
        act = active(flat_c, flat_o)
        idx = true_first_order(act)[:m]
        sub_o = [x if ax is None else x[idx] for x, ax in zip(flat_o, axes)]
        sub_c = loop(jnp.any, [x[idx] for x in flat_c], sub_o)
        # Merged back by a gather and a select (lane i's result is sub_c[pos[i]] when
        # pos[i] < m), not by a scatter: the same bits from the most plainly defined
        # operations (docs/devices.md, "Exactness").
        pos = true_first_positions(act)
        back, moved = jnp.minimum(pos, m - 1), pos < m
        flat_c = [jnp.where(moved.reshape((-1,) + (1,) * (x.ndim - 1)), s[back], x)
                  for x, s in zip(flat_c, sub_c)]
    return flat_c
