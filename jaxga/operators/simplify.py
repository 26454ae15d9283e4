"""The simplification family: per-generation operators that never lengthen a path, run
with ``simplify.probability`` (Zhu & Pan 4.6; Zhang eq. 3-4), declared in the registry
(:mod:`jaxga.operators.registry`).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxga.operators.mutation import cut_corners
from jaxga.operators.postprocess import simplify_adjacent
from jaxga.operators.registry import NEVER_FAILS, SHRINKING, Operator, register, register_none

__all__ = ["simplify_adjacent_step"]


def simplify_adjacent_step(key: jax.Array, grid: Any, cells: jax.Array,
                           length: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """:func:`jaxga.operators.postprocess.simplify_adjacent` (Zhu & Pan 4.6) as a per-generation
    simplification: a path with nothing to simplify is returned unchanged, which is not
    a failure (``failed`` always False)."""
    out, out_len, _ = simplify_adjacent(key, grid, cells, length)
    return out, out_len, jnp.bool_(False)


register(Operator("simplify", "simplify_adjacent", simplify_adjacent_step,
                  "skip to the farthest later node one move away, dropping the detour "
                  "between (Zhu & Pan 4.6)",
                  traits=frozenset({SHRINKING, NEVER_FAILS})))
register(Operator("simplify", "cut_corners", cut_corners,
                  "delete the middle node of every corner whose ends are adjacent: a "
                  "whole-path pass of Zhang's eq. 3-4 rules (not its one-gene mutation)",
                  traits=frozenset({SHRINKING, NEVER_FAILS}),
                  aliases=("corner_cut",)))
register_none("simplify", "no simplification")
