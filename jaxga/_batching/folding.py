"""Fold every ``vmap`` level of a call into one flat batch of lanes.

Every operator of jaxga is written for one individual (or one run) and lifted with
``vmap`` over individuals, islands and runs (docs, "the pure core"). Some computations are cheaper
when they see all their lanes at once, whatever ``vmap`` levels stacked them: a loop
whose lanes finish at different times (:func:`jaxga._batching.lanes.lane_while_loop`), a gated
map that should compute only the applied entries of ALL runs rather than a per-run
block count that every run then pays (:func:`jaxga.operators.lift.gated_map`).

:func:`fold_call` gives such a computation that view. It binds a primitive of its own,
:data:`fold_p`, whose batching rule, at every ``vmap`` level, adds one leading dimension
to the per-call ("lane") arrays and binds it again; when the program is lowered, the
computation receives the lane arrays with all levels flattened into one leading
dimension, and is traced only then, once. Values the computation closes over are
hoisted into explicit operands first (:func:`hoist`); an operand batched at no level
(the map) stays one copy, one batched at some levels only is broadcast.

A client may shape its computation for the platform it is lowered for
(:func:`on_accelerator`): on the CPU a loop over small blocks of lanes is fastest (the
blocks fit the caches and the work skipped is real time); on a GPU or TPU every
iteration of a loop costs a chain of kernel launches whatever its width, so one wide
block is fastest. Whatever the platform, each lane computes what it computes alone, so
the layout changes no result (docs/devices.md, "Exactness").
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import jax
import jax.extend.core
import jax.numpy as jnp
import numpy as np
from jax.interpreters import batching, mlir

__all__ = ["FlatCall", "fold_call", "hoist", "layout_as", "on_accelerator"]

FlatCall = Callable[[tuple, list, list, list], list]
"""``client(lead, lanes, operands, axes) -> outputs``: ``lead`` is the tuple of folded
``vmap`` sizes (``()`` without ``vmap``); ``lanes`` the lane arrays with those levels
flattened into ONE leading dimension of ``prod(lead)`` (no extra dimension without
``vmap``); ``operands[j]`` either shared (``axes[j] is None``) or with the same
flattened leading dimension (``axes[j] == 0``). The outputs have the lanes' layout."""


_PLATFORMS: contextvars.ContextVar[tuple[str, ...] | None] = contextvars.ContextVar(
    "jaxga_fold_platforms", default=None)
"""The platforms the folded call whose client is being traced is lowered for (None
outside a client)."""

_FORCED: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "jaxga_fold_layout", default=None)

LAYOUT_PLATFORMS = ("cpu", "cuda", "rocm", "tpu")
"""The platforms :func:`layout_as` takes: the CPU, and JAX's names of the accelerators."""


def on_accelerator() -> bool:
    """Whether the client being traced (:func:`fold_call`) lays its lanes out for an
    accelerator: True when the program is lowered for platforms none of which is the
    CPU (a GPU or TPU), or run eagerly where JAX's default backend is not the CPU (an
    eager call does not see ``jax.default_device``: on a GPU machine an eager call on
    the CPU gets the GPU's layout, with the same results); False outside a client and in
    a program lowered for several platforms one of which is the CPU. :func:`layout_as`
    overrides it."""
    forced = _FORCED.get()
    if forced is not None:
        return forced != "cpu"
    platforms = _PLATFORMS.get()
    return bool(platforms) and "cpu" not in platforms


@contextlib.contextmanager
def layout_as(platform: str) -> Iterator[None]:
    """Clients lowered inside this scope lay their lanes out as on ``platform`` (``"cpu"``
    or an accelerator's name, ``"cuda"``), whatever they are lowered for.

    For tests and benchmarks that run the accelerators' layout on the CPU: the results
    must be the same bits. Only programs traced and lowered inside the scope are
    affected, and ``jax.jit`` keeps compiled programs by function and argument shapes,
    not by this scope: use a function object of its own inside it.
    """
    name = str(platform).lower()
    if name not in LAYOUT_PLATFORMS:
        raise ValueError(f"layout_as: unknown platform {platform!r} "
                         f"(one of {', '.join(LAYOUT_PLATFORMS)})")
    with _holding(_FORCED, name):
        yield


@contextlib.contextmanager
def _holding(var: contextvars.ContextVar, value: Any) -> Iterator[None]:
    """``var`` set to ``value`` within the scope, and back to what it was after."""
    token = var.set(value)
    try:
        yield
    finally:
        var.reset(token)


def hoist(fn: Callable, *example: Any) -> tuple[Callable, list]:
    """``(fn_op, consts)`` with ``fn_op(consts, *args) == fn(*args)`` and no closure.

    A folded call cannot batch values its computation closes over (a map, a run's
    parameters), and it is traced when the program is lowered, where no tracer of the
    caller may be closed over; tracing ``fn`` once on ``example`` arguments turns them
    into the explicit operands ``consts``.
    """
    closed, shapes = jax.make_jaxpr(fn, return_shape=True)(*example)
    out_tree = jax.tree_util.tree_structure(shapes)

    def fn_op(consts: Sequence[jax.Array], *args: Any) -> Any:
        f = jax.extend.core.jaxpr_as_fun(jax.extend.core.ClosedJaxpr(closed.jaxpr, consts))
        return jax.tree_util.tree_unflatten(out_tree, f(*jax.tree_util.tree_leaves(args)))

    return fn_op, [jnp.asarray(c) for c in closed.consts]


def fold_call(client: FlatCall, lanes: Sequence[jax.Array], operands: Sequence[jax.Array],
              out_like: Sequence[Any]) -> list:
    """``client``'s outputs for the lane arrays ``lanes`` and the ``operands``, with every
    ``vmap`` level above this call folded into the lanes' leading dimension (module
    docstring; :data:`FlatCall` gives ``client``'s contract).

    ``out_like``: one output per ``client`` output, an array (or anything
    ``jnp.asarray`` takes) or a ``jax.ShapeDtypeStruct`` with the shape, dtype and weak
    type of that output for this call alone (no ``vmap``). Shapes and dtypes are checked
    when ``client`` runs; a mismatch raises ``TypeError``.

    ``client`` runs when the program is lowered (``jax.jit(f).lower()``, or the first
    call), not when ``f`` is traced: configuration contexts active only around tracing
    (dtype promotion, matmul precision) and module constants are read then, and
    ``client`` must not close over the caller's tracers (:func:`hoist`). The call has no
    differentiation rule, declares no effects, and is not supported under ``shard_map``
    with ``check_vma=True`` or with explicitly sharded lanes (an error says so); jaxga
    needs none of these.
    """
    lanes = [jnp.asarray(x) for x in lanes]
    operands = [jnp.asarray(x) for x in operands]
    if not lanes:
        raise ValueError("fold_call needs at least one lane array")
    base = tuple(np.ndim(x) for x in lanes)
    outs = tuple(_out_aval(o) for o in out_like)
    return list(fold_p.bind(*lanes, *operands, client=client, base=base,
                            op_levels=tuple(() for _ in operands), out_avals=outs))


fold_p = jax.extend.core.Primitive("jaxga_fold")
"""The folded call as a primitive. Its batching rule only adds a level (no tracing);
``client`` is traced once, when the program is lowered (or run eagerly), with every
level folded. A :func:`jax.custom_batching.custom_vmap` function instead traces its body
again at every ``vmap`` level and every time a loop's body is re-batched, and throws
all but the last trace away: that was a quarter to a half of the presets' tracing time."""
fold_p.multiple_results = True


def _folded_call(*args: jax.Array, client: FlatCall, base: tuple, op_levels: tuple,
                 out_avals: tuple) -> list:
    """Run ``client`` on the lanes with all their ``vmap`` levels flattened into one.

    ``op_levels[j]`` records, outermost level first, whether operand ``j`` is batched at
    each level folded in; every lane array is batched at all of them (the batching rule
    broadcasts an unbatched one).
    """
    lanes, operands = list(args[:len(base)]), list(args[len(base):])
    k = np.ndim(lanes[0]) - base[0]
    lead = tuple(np.shape(lanes[0])[:k])
    if k == 0:
        out = client((), lanes, operands, [None] * len(operands))
    else:
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
        out = [x.reshape(lead + x.shape[1:]) for x in client(lead, flat_lanes, flat_ops, axes)]
    got = tuple((tuple(np.shape(x)), np.dtype(x.dtype)) for x in out)
    want = tuple((lead + s, np.dtype(d)) for s, d, _ in out_avals)
    if got != want:
        raise TypeError(f"fold_call: the client returned {got}, declared {want}")
    return list(out)


def _out_aval(o: Any) -> tuple:
    """``(shape, canonical dtype, weak type)`` of one declared output."""
    if not isinstance(o, jax.ShapeDtypeStruct):
        o = jnp.asarray(o)
    return (tuple(o.shape), jax.dtypes.canonicalize_dtype(o.dtype),
            bool(getattr(o, "weak_type", False)))


def _abstract_eval(*avals: Any, base: tuple, out_avals: tuple, **_: Any) -> list:
    for a in avals:
        mat = getattr(a, "manual_axis_type", None)
        spec = getattr(getattr(a, "sharding", None), "spec", ())
        if (mat is not None and mat.varying) or any(p is not None for p in spec):
            raise NotImplementedError(
                "jaxga._batching.folding.fold_call does not track sharding types: it is not "
                "supported under shard_map with check_vma=True nor on explicitly sharded arrays "
                f"(an input has type {a.str_short()})")
    lead = tuple(avals[0].shape[:avals[0].ndim - base[0]])
    return [jax.core.ShapedArray(lead + s, d, w) for s, d, w in out_avals]


def _batch_rule(args: Sequence[jax.Array], dims: Sequence[Any], *, client: FlatCall,
                base: tuple, op_levels: tuple, out_avals: tuple) -> tuple[list, list]:
    """One more ``vmap`` level: move its axis to the front of every lane array
    (broadcasting the unbatched ones), record which operands it batches, bind again."""
    size = next(x.shape[d] for x, d in zip(args, dims) if d is not None)
    front = [x if d is None else jnp.moveaxis(x, d, 0)
             for x, d in zip(args, dims)]
    n_lanes = len(base)
    lanes = [x if d is not None else jnp.broadcast_to(x, (size,) + x.shape)
             for x, d in zip(front[:n_lanes], dims[:n_lanes])]
    levels = tuple((d is not None,) + lv
                   for d, lv in zip(dims[n_lanes:], op_levels))
    out = fold_p.bind(*lanes, *front[n_lanes:], client=client, base=base, op_levels=levels,
                      out_avals=out_avals)
    return out, [0] * len(out)


def _eager(*args: jax.Array, **params: Any) -> list:
    """The folded call run eagerly: laid out for JAX's default backend, where it runs."""
    with _holding(_PLATFORMS, (jax.default_backend(),)):
        return _folded_call(*args, **params)


_LOWER = mlir.lower_fun(_folded_call, multiple_results=True)


def _lowering(ctx: Any, *args: Any, **params: Any) -> Any:
    """The folded call lowered with the client traced for the platforms of the program
    (:func:`on_accelerator`)."""
    with _holding(_PLATFORMS, tuple(ctx.platforms or ctx.module_context.platforms)):
        return _LOWER(ctx, *args, **params)


fold_p.def_impl(_eager)
fold_p.def_abstract_eval(_abstract_eval)
batching.primitive_batchers[fold_p] = _batch_rule
mlir.register_lowering(fold_p, _lowering)
