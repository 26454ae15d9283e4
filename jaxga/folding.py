"""Fold every ``vmap`` level of a call into one flat batch of lanes.

Every operator of jaxga is written for one individual (or one run) and lifted with
``vmap`` over individuals, islands and runs (SPEC 2). Some computations are cheaper
when they see all their lanes at once, whatever ``vmap`` levels stacked them: a loop
whose lanes finish at different times (:func:`jaxga.lanes.lane_while_loop`), a gated
map that should compute only the applied entries of ALL runs rather than a per-run
block count that every run then pays (:func:`jaxga.batching.gated_map`).

:func:`fold_call` gives such a computation that view. It carries a
:func:`jax.custom_batching.custom_vmap` rule that, at every ``vmap`` level, adds one
leading dimension to the per-call ("lane") arrays and calls itself again, so that the
innermost call receives the lane arrays with all levels as leading dimensions, flattens
them into one, and hands them to the computation. Values the computation closes over
are hoisted into explicit operands first (:func:`hoist`); an operand batched at no
level (the map) stays one copy, one batched at some levels only is broadcast.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.extend.core
import jax.numpy as jnp
import numpy as np
from jax.custom_batching import custom_vmap

__all__ = ["FlatCall", "fold_call", "hoist"]

FlatCall = Callable[[tuple, list, list, list], list]
"""``client(lead, lanes, operands, axes) -> outputs``: ``lead`` is the tuple of folded
``vmap`` sizes (``()`` without ``vmap``); ``lanes`` the lane arrays with those levels
flattened into ONE leading dimension of ``prod(lead)`` (no extra dimension without
``vmap``); ``operands[j]`` either shared (``axes[j] is None``) or with the same
flattened leading dimension (``axes[j] == 0``). The outputs have the lanes' layout."""


def hoist(fn: Callable, *example: Any) -> tuple[Callable, list]:
    """``(fn_op, consts)`` with ``fn_op(consts, *args) == fn(*args)`` and no closure.

    ``jax.custom_batching.custom_vmap`` cannot batch values a function closes over (a
    map, a run's parameters); tracing ``fn`` once on ``example`` arguments turns them
    into the explicit operands ``consts``.
    """
    closed, shapes = jax.make_jaxpr(fn, return_shape=True)(*example)
    out_tree = jax.tree_util.tree_structure(shapes)

    def fn_op(consts: Sequence[jax.Array], *args: Any) -> Any:
        f = jax.extend.core.jaxpr_as_fun(jax.extend.core.ClosedJaxpr(closed.jaxpr, consts))
        return jax.tree_util.tree_unflatten(out_tree, f(*jax.tree_util.tree_leaves(args)))

    return fn_op, [jnp.asarray(c) for c in closed.consts]


def fold_call(client: FlatCall, lanes: Sequence[jax.Array], operands: Sequence[jax.Array],
              n_out: int) -> list:
    """``client``'s outputs (``n_out`` arrays) for the lane arrays ``lanes`` and the
    ``operands``, with every ``vmap`` level above this call folded into the lanes'
    leading dimension (module docstring; :data:`FlatCall` gives ``client``'s contract).
    """
    lanes = [jnp.asarray(x) for x in lanes]
    operands = [jnp.asarray(x) for x in operands]
    base = tuple(np.ndim(x) for x in lanes)
    fn = _folded(client, base, tuple(() for _ in operands), int(n_out))
    return list(fn(lanes, operands))


def _folded(client: FlatCall, base: tuple, op_levels: tuple, n_out: int) -> Callable:
    """The ``custom_vmap`` function for one stack of ``vmap`` levels.

    ``op_levels[j]`` records, outermost level first, whether operand ``j`` is batched at
    each level already folded in; every lane array is batched at all of them (the rule
    broadcasts an unbatched one).
    """

    def call(lanes, operands):
        k = np.ndim(lanes[0]) - base[0]
        if k == 0:
            return client((), lanes, operands, [None] * len(operands))
        lead = tuple(np.shape(lanes[0])[:k])
        n = int(np.prod(lead, dtype=np.int64))
        flat_lanes = [x.reshape((n,) + x.shape[k:]) for x in lanes]
        flat_ops, axes = [], []
        for x, lv in zip(operands, op_levels):
            if not any(lv):  # shared by every lane: stays one copy
                flat_ops.append(x)
                axes.append(None)
                continue
            if not all(lv):  # batched at some levels only: broadcast to every lane
                rest = x.shape[sum(lv):]
                shape = tuple(d if b else 1 for d, b in zip(lead, lv))
                x = jnp.broadcast_to(x.reshape(shape + rest), lead + rest)
            flat_ops.append(x.reshape((n,) + x.shape[k:]))
            axes.append(0)
        out = client(lead, flat_lanes, flat_ops, axes)
        return [x.reshape(lead + x.shape[1:]) for x in out]

    fn = custom_vmap(call)

    @fn.def_vmap
    def _rule(axis_size, in_batched, lanes, operands):
        lane_b, op_b = in_batched
        lanes = [x if b else jnp.broadcast_to(x, (axis_size,) + x.shape)
                 for x, b in zip(lanes, lane_b)]
        levels = tuple((bool(b),) + lv for b, lv in zip(op_b, op_levels))
        return _folded(client, base, levels, n_out)(lanes, operands), [True] * n_out

    return fn
