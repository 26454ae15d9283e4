"""Lowerings that a correct backend may choose differently, swapped in for a test.

Every ``set`` scatter applies its updates in reverse order, and every unstable sort
(``is_stable=False``) puts equal keys in reverse order of position. XLA defines neither
order (a stable sort's is defined: equal keys keep their positions), so a program whose
results do not change under these lowerings does not rely on what one backend happens
to do there (docs/devices.md, "Exactness"). They replace the CPU's lowering rules of
JAX's ``scatter`` and ``sort`` primitives (JAX internals: this is test code) only inside
:func:`altered_lowering`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import jax
import jax.numpy as jnp
from jax._src.interpreters import mlir
from jax._src.lax import lax as lax_internal
from jax._src.lax import slicing

_CPU = mlir._platform_specific_lowerings["cpu"]
_INSIDE = [False]


def _reversed_scatter_rule(ctx, operand, indices, updates, *, dimension_numbers, **params):
    """The default scatter lowering with its updates in reverse order: the scatter
    dimensions of ``indices`` and ``updates`` that are not batching dimensions are
    flipped together (an update keeps its index; only their order changes)."""
    dn = dimension_numbers
    idx_aval, upd_aval = ctx.avals_in[1], ctx.avals_in[2]
    index_dims = range(idx_aval.ndim - 1)  # the last one holds the index vector
    update_dims = [d for d in range(upd_aval.ndim) if d not in dn.update_window_dims]
    pairs = [(i, u) for i, u in zip(index_dims, update_dims)
             if i not in dn.scatter_indices_batching_dims]
    if pairs:
        def flip(i, u):
            return (jax.lax.rev(i, [p[0] for p in pairs]),
                    jax.lax.rev(u, [p[1] for p in pairs]))

        sub = ctx.replace(primitive=None, avals_in=ctx.avals_in[1:],
                          avals_out=ctx.avals_in[1:])
        indices, updates = mlir.lower_fun(flip, multiple_results=True)(sub, indices, updates)
    return slicing._scatter_lower(ctx, operand, indices, updates, dimension_numbers=dn,
                                  **params)


def _flipped_ties_sort_rule(ctx, *operands, dimension, is_stable, num_keys):
    """An unstable sort with one more, last key (minus the position along the sorted
    dimension), so that equal keys come out in reverse order of position; a stable sort
    is lowered as it is."""
    if _INSIDE[0] or is_stable:
        return lax_internal._sort_lower(ctx, *operands, dimension=dimension,
                                        is_stable=is_stable, num_keys=num_keys)

    def sort(*ops):
        back = -jax.lax.broadcasted_iota(jnp.int32, ops[0].shape, dimension)
        out = jax.lax.sort((*ops[:num_keys], back, *ops[num_keys:]), dimension=dimension,
                           is_stable=is_stable, num_keys=num_keys + 1)
        return (*out[:num_keys], *out[num_keys + 1:])

    _INSIDE[0] = True
    try:
        return mlir.lower_fun(sort, multiple_results=True)(ctx, *operands)
    finally:
        _INSIDE[0] = False


@contextlib.contextmanager
def altered_lowering(scatters: bool = True, sorts: bool = True) -> Iterator[None]:
    """Within: CPU programs are lowered with reversed ``set`` scatters and/or the ties of
    unstable sorts flipped (jit a new function inside: a program lowered before keeps
    its lowering)."""
    saved = {p: _CPU.get(p) for p in (slicing.scatter_p, lax_internal.sort_p)}
    try:
        if scatters:
            _CPU[slicing.scatter_p] = mlir.LoweringRuleEntry(_reversed_scatter_rule, False)
        if sorts:
            _CPU[lax_internal.sort_p] = mlir.LoweringRuleEntry(_flipped_ties_sort_rule, False)
        yield
    finally:
        for p, entry in saved.items():
            if entry is None:
                _CPU.pop(p, None)
            else:
                _CPU[p] = entry


@contextlib.contextmanager
def accelerators_layout() -> Iterator[list]:
    """Within: programs lowered for the CPU lay their folded loops out as a GPU's
    (``jaxga._batching.folding.layout_as("cuda")``: one block per gated operator, plain
    lane loops; decision 049). Yields the list of what each gated operator and lane loop
    traced inside saw (``on_accelerator()``), so that a test can tell that the layout
    was in force: empty when no client was traced (a program lowered before was
    reused), False where it was not."""
    import jaxga._batching.lanes as lanes
    import jaxga.operators.lift as lift
    from jaxga._batching import folding

    seen: list = []

    def spy() -> bool:
        answer = folding.on_accelerator()
        seen.append(answer)
        return answer

    saved = (lanes.on_accelerator, lift.on_accelerator)
    lanes.on_accelerator = lift.on_accelerator = spy
    try:
        with folding.layout_as("cuda"):
            yield seen
    finally:
        lanes.on_accelerator, lift.on_accelerator = saved
