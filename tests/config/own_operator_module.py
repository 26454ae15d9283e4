"""A user's mutation declared in a module of its own, as jaxga's families declare theirs:
the function, then at the module's end its registration with its own key (imported by
``tests/config/test_own_operators.py``, which removes it again)."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga.core.fields import Field
from jaxga.core.grid import move_legal
from jaxga.operators.postprocess import compact
from jaxga.operators.registry import SHRINKING, Operator, register


def drop_points(key, grid, cells, length, *, count=1):
    """Delete up to ``count`` interior nodes, one at a time, each one whose neighbours are
    one legal move apart (the path stays continuous and never grows)."""

    def drop(i, carry):
        cells, length, dropped = carry
        at = jnp.arange(cells.shape[0])
        prev, nxt = jnp.roll(cells, 1), jnp.roll(cells, -1)
        can = (at > 0) & (at < length - 1) & move_legal(grid, prev, nxt)
        pick = jax.random.categorical(jax.random.fold_in(key, i),
                                      jnp.where(can, 0.0, -jnp.inf))
        new, new_length = compact(cells, (at < length) & (at != pick))
        ok = jnp.any(can)
        return (jnp.where(ok, new, cells), jnp.where(ok, new_length, length),
                dropped | ok)

    cells, length, dropped = jax.lax.fori_loop(0, count, drop,
                                               (cells, length, jnp.bool_(False)))
    return cells, length, ~dropped


register(Operator(
    "mutation", "drop_points", drop_points,
    "delete up to mutation.drops interior nodes whose neighbours are adjacent",
    params={"mutation.drops": Field(int, "nodes drop_points deletes at most", low=1,
                                    high=8)},
    traits=frozenset({SHRINKING}), required=("mutation.drops",),
    options=lambda ctx: {"count": int(ctx.config.get("mutation.drops"))},
))
