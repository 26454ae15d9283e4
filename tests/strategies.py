"""Hypothesis strategies shared by the operator tests: random grids and valid parents.

Shapes are fixed (``SIZE x SIZE`` maps, capacity ``CAP``) so that every jitted operator
compiles once per test module.
"""

from __future__ import annotations

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from jaxga.maps import legal_moves, random_map
from jaxga.testing import random_parents

SIZE = 10
CAP = 64


@st.composite
def grids(draw, corner_rules=("free", "no_squeeze", "strict"), max_density=0.35):
    """A random ``SIZE x SIZE`` map with start (0, 0) and goal (SIZE-1, SIZE-1) connected."""
    seed = draw(st.integers(0, 2**31 - 1))
    density = draw(st.floats(0.0, max_density))
    rule = draw(st.sampled_from(corner_rules))
    return random_map(SIZE, SIZE, density, seed, corner_rule=rule)


@st.composite
def grids_and_parents(draw, n: int = 8, corner_rules=("free", "no_squeeze", "strict")):
    """A random grid (one of ``corner_rules``) and ``n`` valid parents on it."""
    grid = draw(grids(corner_rules=corner_rules))
    seed = draw(st.integers(0, 2**20))
    try:
        return grid, random_parents(grid, n, seed)
    except RuntimeError:  # median insertion rarely closes on this grid: draw another
        reject()


def check_paths(grid, cells, length, ok, source=None, target=None, exclude=(), cap=CAP):
    """Independent NumPy check of every ok path; returns how many were checked."""
    cells, length, ok = np.asarray(cells), np.asarray(length), np.asarray(ok)
    b = grid.blocked_np()
    w = b.shape[1]
    legal = legal_moves(b, grid.corner_rule)
    dirs = {(1, 0): 0, (1, 1): 1, (0, 1): 2, (-1, 1): 3, (-1, 0): 4, (-1, -1): 5, (0, -1): 6,
            (1, -1): 7}
    source = int(grid.start) if source is None else source
    target = int(grid.goal) if target is None else target
    excluded = set(int(c) for c in exclude) - {source, target}
    for i in np.flatnonzero(ok):
        n = int(length[i])
        assert cells.shape[1] == cap and 1 <= n <= cap
        p = cells[i, :n].tolist()
        assert p[0] == source and p[-1] == target, p
        assert len(set(p)) == n, f"loop in {p}"
        assert not excluded & set(p), f"{p} enters an excluded cell"
        assert (cells[i, n:] == p[-1]).all(), "padding must repeat the last cell"
        for a, c in zip(p[:-1], p[1:]):
            d = dirs.get((c % w - a % w, c // w - a // w))
            assert d is not None and legal[d, a // w, a % w], f"illegal move {a}->{c} in {p}"
        if n == 1:
            assert not b[p[0] // w, p[0] % w]
    return int(ok.sum())
