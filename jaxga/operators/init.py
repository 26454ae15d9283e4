"""Initialisers: one start-to-goal path per PRNG key, and a population with bounded redraws.

Every initialiser builds ONE individual from ``(key, grid, capacity)`` and returns
``(cells int32[capacity], length int32, ok bool)`` in jaxga's representation (padding
repeats the last cell; docs, "the pure core"). When ``ok`` is True the path starts at
``grid.start``, ends at ``grid.goal``, is continuous under ``grid.corner_rule``, loop-free
and fits the capacity; when ``ok`` is False the cells are meaningless and must not be used.
:func:`initialise` draws a whole population, redrawing failed individuals (vectorised,
bounded) and reporting the success rate.

* :func:`random_walk`: the plain GA (sga; Zhu & Pan 4.1 "random walk"), primitive
  :func:`uniform_walk`;
* :func:`median_insertion`: IMGA (Li, Hu, Liu 2021) section 4.1, via
  :func:`jaxga.operators.repair.connect`;
* :func:`intermittent_connect`: MPMGA (Hao et al. 2020) section 4.2, anchors
  :func:`intermittent_anchors`, via :func:`jaxga.operators.repair.connect`;
* :func:`greedy_random_target`: AGACD (Hao et al. 2021) section 4.3, primitive
  :func:`greedy_walk`;
* :func:`directional`: Zhu & Pan 2024 section 4.1, Algorithm 1, primitive
  :func:`directional_walk` (also the regrowing step of Zhu's range mutation), one-step
  probabilities :func:`directional_probabilities` (their Table 1).

The walk primitives go from any ``source`` cell to any ``target`` cell and accept an
``exclude`` set (cells that count as visited). Initialisers are looked up by name in
the registry (:func:`jaxga.config.registry.initialiser`).

Implementation notes shared by the walks
----------------------------------------
* A walk is a ``while_loop`` over steps that stops when the walk is done (target
  reached or dead end); under ``vmap`` it is a :func:`jaxga._batching.lanes.lane_while_loop`, which
  finishes the last walking lanes in a compacted batch instead of running every lane to
  the longest one: faster than a fixed-length ``lax.scan`` to the step cap, most of all
  for short walks such as the regrowth of Zhu's range mutation (decision 002). The step
  cap is the capacity: a walk that has not reached its target after ``capacity - 1``
  moves fails (for the AGACD walk, which may revisit cells, see ``max_steps``).
* The 8 neighbours of every cell and whether each move is legal under the corner rule
  are tabulated once per grid (``int32[H*W*8]`` and ``bool[H*W*8]``; under ``vmap`` over
  individuals the grid is shared, so the tables are built once per call). A step then
  costs two flat gathers of 8 entries.
* The visited set of a self-avoiding walk is a ``bool[H*W]`` table per individual,
  updated by one scalar scatter per step: cheaper than updating the table by an
  ``O(H*W)`` select or testing membership against the path so far (8 x L compares per
  step, no table) (decision 002). It costs ``H*W`` bytes per individual in the loop
  carry (P = 1000 on a 256 x 256 map: 65 MB), so on maps of more than
  :data:`VISITED_TABLE_CELLS_PER_NODE` cells per node of capacity the walks keep a hash
  set of their own cells instead (decision 008).
* Cost per attempt (decision 002): the random and
  directional walks are the cheapest, greedy_random_target (640 moves) costs more, and
  median_insertion and intermittent_connect cost the most, both dominated by
  :func:`jaxga.operators.repair.connect` (its ``while_loop`` over insertion rounds runs, under
  ``vmap``, until the slowest lane stops, and a connection that cycles stops only at
  ``max_rounds``).
* Random numbers are drawn in bulk before the loop (one float32 or three uint32 words per
  step), not per step.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.lanes import lane_while_loop
from jaxga.core.dtypes import F32, I32
from jaxga.core.errors import NoPathError, ParameterError
from jaxga.core.grid import DIRECTIONS, Grid, in_bounds, move_legal
from jaxga.core.paths import (
    Population,
    has_endpoints,
    is_continuous,
    is_loop_free,
    pad,
    position_lookup,
    remove_loops,
)
from jaxga.operators.repair import connect, splice_loop_free

__all__ = [
    "InitFn",
    "InitStats",
    "directional",
    "directional_probabilities",
    "directional_walk",
    "exclusion_mask",
    "greedy_random_target",
    "greedy_walk",
    "initialise",
    "initialise_population",
    "field_descent",
    "field_path",
    "field_reconnect",
    "field_walk",
    "intermittent_anchors",
    "intermittent_connect",
    "median_insertion",
    "random_walk",
    "uniform_walk",
]

InitFn = Callable[[jax.Array, Grid, int], tuple[jax.Array, jax.Array, jax.Array]]
"""``init_fn(key, grid, capacity) -> (cells int32[capacity], length int32, ok bool)``."""

_DX = np.asarray(DIRECTIONS[:, 0], np.int32)
_DY = np.asarray(DIRECTIONS[:, 1], np.int32)


# ------------------------------------------------------------------------ helpers
def _check_capacity(capacity: int) -> int:
    if not isinstance(capacity, (int, np.integer)) or capacity < 1:
        raise ParameterError(f"capacity must be a positive Python int, got {capacity!r}")
    return int(capacity)


def _move_tables(grid: Grid) -> tuple[jax.Array, jax.Array]:
    """``(nbr int32[n*8], legal bool[n*8])``: neighbour ``d`` of cell ``p`` is entry ``8p+d``.

    Directions are :data:`jaxga.core.grid.DIRECTIONS`; an off-map neighbour is stored as ``p``
    itself with ``legal`` False. ``legal`` is :func:`jaxga.core.grid.move_legal` (both cells
    free, corner rule for diagonals). Read from ``grid.tables`` when attached
    (:func:`jaxga.engine.maptables.with_tables`).
    """
    if grid.tables is not None:
        return grid.tables.nbr, grid.tables.legal
    return compute_move_tables(grid)


def compute_move_tables(grid: Grid) -> tuple[jax.Array, jax.Array]:
    """:func:`_move_tables` computed from the map (what :mod:`jaxga.engine.maptables` stores)."""
    h, w = grid.shape
    p = jnp.arange(grid.n_cells, dtype=I32)[:, None]
    nx, ny = p % w + _DX, p // w + _DY
    inside = in_bounds(nx, ny, h, w)
    nbr = jnp.where(inside, ny * w + nx, p)
    legal = inside & move_legal(grid, p, nbr)
    return nbr.reshape(-1), legal.reshape(-1)


def exclusion_mask(grid: Grid, exclude: jax.Array | None) -> jax.Array:
    """``bool[H*W]`` mask of cells a self-avoiding walk must not enter.

    ``exclude`` may be None (nothing excluded), a boolean mask of shape ``(H*W,)`` or
    ``(H, W)`` (True = excluded), or an integer array of cell indices of any shape, in
    which entries outside ``[0, H*W)`` (e.g. ``-1`` padding) are ignored. Jittable.
    """
    n = grid.n_cells
    if exclude is None:
        return jnp.zeros((n,), bool)
    exclude = jnp.asarray(exclude)
    if exclude.dtype == jnp.bool_:
        if exclude.size != n or exclude.ndim not in (1, 2):
            raise ParameterError(
                f"a boolean exclude mask must have shape ({n},) or {grid.shape}, "
                f"got {exclude.shape}"
            )
        return exclude.reshape(-1)
    if not jnp.issubdtype(exclude.dtype, jnp.integer):
        raise ParameterError(f"exclude must be a bool mask or integer cells, got {exclude.dtype}")
    cells = exclude.reshape(-1).astype(I32)
    valid = (cells >= 0) & (cells < n)
    return jnp.zeros((n,), bool).at[jnp.where(valid, cells, n)].set(True, mode="drop")


def _free_cells(grid: Grid, allow: jax.Array | None = None) -> tuple[jax.Array, jax.Array]:
    """``(cells int32[n], count)``: the free cells (and ``allow``) first, in index order."""
    ok = ~grid.blocked.reshape(-1)
    if allow is not None:
        ok &= allow
    order = jnp.argsort(~ok, stable=True).astype(I32)
    return order, jnp.sum(ok, dtype=I32)


def _pick(bits: jax.Array, table: jax.Array, count: jax.Array) -> jax.Array:
    """``table[bits mod count]``: uniform over ``table[:count]`` (bias <= count / 2**32)."""
    i = (bits % jnp.maximum(count, 1).astype(jnp.uint32)).astype(I32)
    return table[i]


def _fit(
    cells: jax.Array, length: jax.Array, ok: jax.Array, capacity: int
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Cut or pad a loop-free path of any buffer size to ``capacity``; fail if too long."""
    if cells.shape[0] >= capacity:
        cells = cells[:capacity]
    else:
        cells = jnp.concatenate([cells, jnp.full((capacity - cells.shape[0],), cells[-1], I32)])
    ok = ok & (length <= capacity)
    length = jnp.minimum(length, capacity)
    return pad(cells, length), length, ok


# -------------------------------------------------------------- self-avoiding walks
def _directional_scores(
    grid: Grid, current: jax.Array, nbr: jax.Array, target: jax.Array, factors
) -> jax.Array:
    """Zhu & Pan eq. 3-5 for the 8 neighbours ``nbr`` of ``current``: float32[8].

    ``score = 1 / d(nbr, target)`` (eq. 3-4), times ``factors[0]`` (3) when
    ``sgn((xT-xc)(xn-xc)) + sgn((yT-yc)(yn-yc)) = 2`` and ``factors[1]`` (2) when it is 1
    (eq. 5). A neighbour equal to the target gets ``inf`` (never used: the walk stops
    first).
    """
    w = grid.width
    cx, cy = current % w, current // w
    tx, ty = target % w, target // w
    nx, ny = nbr % w, nbr // w
    ddx, ddy = (nx - tx).astype(F32), (ny - ty).astype(F32)
    score = 1.0 / jnp.sqrt(ddx * ddx + ddy * ddy)
    s = jnp.sign((tx - cx) * (nx - cx)) + jnp.sign((ty - cy) * (ny - cy))
    f_two = jnp.asarray(factors[0], F32)
    f_one = jnp.asarray(factors[1], F32)
    return score * jnp.where(s == 2, f_two, jnp.where(s == 1, f_one, jnp.float32(1.0)))


def _self_avoiding_walk(
    key: jax.Array,
    grid: Grid,
    source: jax.Array,
    target: jax.Array,
    capacity: int,
    exclude: jax.Array | None,
    *,
    directional: bool,
    factors=(3.0, 2.0),
    stop_adjacent: bool,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Shared scan of :func:`uniform_walk` and :func:`directional_walk`.

    Each step: candidates = legal moves to cells neither visited nor excluded; if
    ``stop_adjacent`` and the target is a legal neighbour, step onto it and stop;
    otherwise roulette over the candidate scores (all 1 for the uniform walk); no
    candidate = failure; reaching the target = success.
    """
    capacity = _check_capacity(capacity)
    source = jnp.asarray(source, I32)
    target = jnp.asarray(target, I32)
    n = grid.n_cells
    nbr_t, legal_t = _move_tables(grid)
    use_table = n <= VISITED_TABLE_CELLS_PER_NODE * capacity
    if use_table:  # the walk's visited set: one bool per cell of the map
        visited = exclusion_mask(grid, exclude)
        visited = visited.at[jnp.clip(target, 0, n - 1)].set(False)
        visited = visited.at[jnp.clip(source, 0, n - 1)].set(True)
        seen = None
    else:  # a large map: a set of at most `capacity` cells, and the excluded cells
        seen = _excluded_cells(grid, exclude, target)
        visited = (_hash_add(_hash_empty(capacity), jnp.clip(source, 0, n - 1))[0],
                   jnp.bool_(False))
    source_free = ~grid.blocked.reshape(-1)[jnp.clip(source, 0, n - 1)]
    on_map = (source >= 0) & (source < n) & (target >= 0) & (target < n)
    done0 = (source == target) | ~on_map | ~source_free
    ok0 = (source == target) & on_map & source_free
    steps = capacity - 1
    u = jax.random.uniform(key, (max(steps, 1),), F32)
    lanes = jnp.arange(8, dtype=I32)

    def cond(carry):
        t, _, _, done, _, _, _ = carry
        return ~done & (t < steps)

    def step(carry):
        t, cur, visited, done, ok, n_moves, buf = carry
        k = cur * 8 + lanes
        nbr = nbr_t[k]
        legal = legal_t[k]
        if use_table:
            cand = legal & ~visited[nbr]
        else:
            cand = legal & ~_hash_seen(visited[0], nbr) & ~seen(nbr)
        if directional:
            score = jnp.where(cand, _directional_scores(grid, cur, nbr, target, factors), 0.0)
        else:
            score = cand.astype(F32)
        if directional:
            cs = jnp.cumsum(score)
        else:
            # 0/1 scores: seven unrolled adds give jnp.cumsum's (exact) values without
            # its reduce_window, which was the costliest op of an SGA initialisation.
            # Not for the directional scores: there the unrolled adds made iga_zhu's
            # evolution slower (decision 002).
            parts = [score[0]]
            for j in range(1, 8):
                parts.append(parts[-1] + score[j])
            cs = jnp.stack(parts)
        total = cs[-1]
        # Roulette: the first lane whose cumulative score exceeds u * total (a lane with
        # score 0 never does); guard u * total rounding up to total.
        idx = jnp.sum(cs <= u[t] * total, dtype=I32)
        last = 7 - jnp.argmax(cand[::-1]).astype(I32)
        idx = jnp.minimum(idx, last)
        nxt = nbr[idx]
        if stop_adjacent:
            at_target = jnp.any(legal & (nbr == target))
            nxt = jnp.where(at_target, target, nxt)
            dead = ~at_target & ~(total > 0)
        else:
            dead = ~(total > 0)
        # A walk that is done or at the step cap stays where it is: under vmap the
        # loop runs unmasked (below), so this step is applied to finished walks too.
        move = ~done & (t < steps) & ~dead
        new = jnp.where(move, nxt, cur)
        if use_table:
            visited = visited.at[new].set(True)
        else:
            table, kept = _hash_add(visited[0], new)
            visited = (table, visited[1] | ~kept)
        reached = move & (new == target)
        buf = buf.at[n_moves + 1].set(new, mode="drop")  # past n_moves: scratch
        return (t + 1, new, visited, done | dead | reached, ok | reached,
                n_moves + move.astype(I32), buf)

    # A while loop over steps that stops when the walk is done (a dead end or the
    # target): under vmap its unfinished lanes are compacted (jaxga._batching.lanes), so a batch
    # of walks that mostly die or arrive early does not run to the step cap.
    buf0 = jnp.zeros((capacity,), I32).at[0].set(source)
    carry0 = (jnp.int32(0), jnp.clip(source, 0, n - 1), visited, done0, ok0, jnp.int32(0), buf0)
    # Unmasked: a finished walk's step changes only t, done and the scratch entry past
    # n_moves, none of which is read below (with the masked loop, the per-step select of
    # the visited table and the buffer slowed a 50 x 50 initialisation: decision 002).
    _, cur, visited, _, ok, n_moves, buf = lane_while_loop(cond, step, carry0, masked=False)
    if not use_table:
        ok &= ~visited[1]  # a full probe window: the walk may have crossed itself
    # Past its last move a walk stays on its final cell.
    cells = jnp.where(jnp.arange(capacity, dtype=I32) <= n_moves, buf, cur)
    length = 1 + n_moves
    return cells, length, ok


VISITED_TABLE_CELLS_PER_NODE = 64
"""A self-avoiding walk keeps its visited set as one bool per map cell while the map has
at most this many cells per node of the walk's capacity (up to 101 x 101 cells for a
capacity of 160; below that the hash set of 32-64 bytes per node would be larger);
on larger maps as a hash set of the walk's own cells (:func:`_hash_add`) and a sorted
list of the excluded ones, so that its memory and time grow with the capacity, not with
the map (a range mutation on a 256 x 256 map held 64 kB per walk; decision 008)."""

_HASH_PROBES = 16
_HASH_MULT = np.uint32(0x9E3779B1)


def _hash_empty(capacity: int) -> jax.Array:
    """An empty set of at most ``capacity`` cells: ``int32[M]`` slots holding ``cell + 1``
    (0 = empty), ``M`` the power of two >= 8 capacity (a load of at most 1/8)."""
    return jnp.zeros((1 << max(4, (8 * capacity - 1).bit_length()),), I32)


def _hash_probe(table: jax.Array, cells: jax.Array) -> jax.Array:
    """The ``_HASH_PROBES`` slots a cell may occupy (Fibonacci hashing, linear probing)."""
    bits = int(table.shape[0]).bit_length() - 1
    home = (cells.astype(jnp.uint32) * _HASH_MULT) >> jnp.uint32(32 - bits)
    return ((home.astype(I32)[..., None] + jnp.arange(_HASH_PROBES, dtype=I32))
            & (table.shape[0] - 1))


def _hash_seen(table: jax.Array, cells: jax.Array) -> jax.Array:
    """Whether each of ``cells`` is in the set (exact: a cell is always stored within its
    probe window, or its insertion was reported lost)."""
    return jnp.any(table[_hash_probe(table, cells)] == cells[..., None] + 1, axis=-1)


def _hash_add(table: jax.Array, cell: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(table with cell, kept)``: ``kept`` False when its probe window of 16 slots is
    full (at a load of at most 1/8 a negligible event; the walk then reports failure)."""
    slots = _hash_probe(table, cell)
    held = table[slots]
    present = jnp.any(held == cell + 1)
    empty = held == 0
    write = ~present & jnp.any(empty)
    table = table.at[jnp.where(write, slots[jnp.argmax(empty)], table.shape[0])].set(
        cell + 1, mode="drop")
    return table, present | write


def _excluded_cells(grid: Grid, exclude, target) -> Callable[[jax.Array], jax.Array]:
    """``excluded(cells) -> bool``: membership in ``exclude`` (see :func:`exclusion_mask`)
    without a map-sized table for a list of cells (a sorted copy and binary search); the
    target is never excluded."""
    n = grid.n_cells
    target = jnp.asarray(target, I32)
    if exclude is None:
        return lambda cells: jnp.zeros(cells.shape, bool)
    exclude = jnp.asarray(exclude)
    if exclude.dtype == jnp.bool_:
        mask = exclusion_mask(grid, exclude)
        return lambda cells: mask[jnp.clip(cells, 0, n - 1)] & (cells != target)
    listed = jnp.sort(jnp.where((exclude >= 0) & (exclude < n), exclude, n).reshape(-1)
                      .astype(I32))

    def excluded(cells):
        k = jnp.clip(jnp.searchsorted(listed, cells), 0, listed.shape[0] - 1)
        return (listed[k] == cells) & (cells != target)

    return excluded


def uniform_walk(
    key: jax.Array,
    grid: Grid,
    source: jax.Array,
    target: jax.Array,
    capacity: int,
    exclude: jax.Array | None = None,
    stop_adjacent: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Self-avoiding uniform random walk from cell ``source`` to cell ``target``.

    The plain GA's initialisation (``random_walk``; Zhu & Pan section 4.1: "the
    start grid will be added to the path, a random search for walkable grid to join the
    path will be carried out, until the target grid is found"): at every step move to a
    uniformly random neighbour that is free, legally reachable under the corner rule and
    neither visited nor excluded. A dead end (no such neighbour) is a failure; stepping
    onto ``target`` is a success. With ``stop_adjacent=True`` the walk steps onto the
    target as soon as it is a legal neighbour (Zhu & Pan Algorithm 1's stopping rule).

    Args:
        key: PRNG key (one float32 per step is drawn up front).
        grid: the map and its corner rule (``grid.start``/``grid.goal`` are not used).
        source, target: int32 cell indices. ``source == target`` gives the one-cell path.
        capacity: static; at most ``capacity - 1`` moves (the step cap).
        exclude: cells that count as already visited (see :func:`exclusion_mask`):
            a ``bool[H*W]``/``bool[H, W]`` mask or an int array of cells (negative
            entries ignored). ``target`` is never excluded; ``source`` always is.
        stop_adjacent: static; see above.

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``; on success the path runs
        from ``source`` to ``target``, continuous, loop-free and avoiding ``exclude``.
    """
    return _self_avoiding_walk(
        key, grid, source, target, capacity, exclude,
        directional=False, stop_adjacent=stop_adjacent,
    )


def directional_walk(
    key: jax.Array,
    grid: Grid,
    source: jax.Array,
    target: jax.Array,
    capacity: int,
    exclude: jax.Array | None = None,
    factors: tuple[float, float] = (3.0, 2.0),
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Zhu & Pan's directionally guided walk (Algorithm 1) from ``source`` to ``target``.

    Zhu & Pan 2024 section 4.1, Algorithm 1 and eq. 3-5. At every step the candidate list
    ("gridlist") is the neighbours of the current cell that are free, legally reachable
    under the corner rule and not yet on the path (the paper's chromosomes "do not allow
    duplicate grid numbers"; its Table 1 candidate lists exclude visited cells) nor in
    ``exclude``. If the target is a legal neighbour it is appended and the walk succeeds
    (Algorithm 1 lines 7-10); an empty list is a failure (lines 12-15); otherwise the next
    cell is drawn by roulette (RWS) on ``score = 1 / d(candidate, target)`` multiplied by
    ``factors[0]`` = 3 when the move points towards the target in both axes
    (``sgn((xT - xc)(xn - xc)) + sgn((yT - yc)(yn - yc)) = 2``) and by ``factors[1]`` = 2
    when it is 1 (eq. 5). ``factors=(1, 1)`` gives the unadjusted 1/d roulette of Zhu &
    Pan's "literature [28]" (CGA) initialiser.

    The step cap is ``capacity - 1`` moves (the paper's cap is 10,000 iterations, which
    a self-avoiding walk on maps of fewer cells never reaches). A walk that would outgrow
    the chromosome is a counted failure, never truncated; on a 20 x 20 map with the
    automatic capacity (160) the walks are the uncapped walks, walk for walk (the test
    ``test_the_directional_walk_is_the_papers_uncapped_walk_on_a_20x20_map``).

    This is also the regrowing step of Zhu & Pan's range mutation (section 4.5: "set p_i
    as the start point and p_j as the target point. Determine a new path by using the
    method of population initialization"). For that use, pass the rest of the parent as
    ``exclude`` so that the regrown stretch cannot create a loop with it, e.g.
    ``exclude = jnp.where((idx < i) | ((idx > j) & (idx < length)), cells, -1)``.

    Args:
        key: PRNG key (one float32 per step is drawn up front).
        grid: the map and its corner rule (``grid.start``/``grid.goal`` are not used).
        source, target: int32 cell indices (traced values allowed).
        capacity: static; length of the output and step cap.
        exclude: cells that count as visited: None, a ``bool[H*W]`` or ``bool[H, W]``
            mask, or an int array of cell indices where entries outside ``[0, H*W)``
            (``-1`` padding) are ignored (:func:`exclusion_mask`). ``target`` is never
            excluded and ``source`` always is (it is the first node).
        factors: the multipliers of eq. 5 (traced values allowed).

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``. When ``ok`` the path runs from
        ``source`` to ``target`` (both included), is continuous, loop-free and avoids
        ``exclude``; ``source == target`` gives the one-cell path.
    """
    return _self_avoiding_walk(
        key, grid, source, target, capacity, exclude,
        directional=True, factors=factors, stop_adjacent=True,
    )


def directional_probabilities(
    grid: Grid,
    current: jax.Array,
    target: jax.Array,
    visited: jax.Array | None = None,
    factors: tuple[float, float] = (3.0, 2.0),
) -> tuple[jax.Array, jax.Array]:
    """The roulette probabilities of one step of :func:`directional_walk` (Zhu Table 1).

    Args:
        grid: the map.
        current: the current cell index.
        target: the target cell index.
        visited: cells already on the path (a mask or a list of cells, as ``exclude``
            of :func:`directional_walk`); ``current`` counts as visited.
        factors: the multipliers of eq. 5.

    Returns:
        ``(cells int32[8], prob float32[8])``: the 8 neighbours in
        :data:`jaxga.core.grid.DIRECTIONS` order and the probability of stepping to each (0 for
        non-candidates). If the target is a legal neighbour it gets probability 1 (the
        walk stops there); with no candidate all probabilities are 0.
    """
    current = jnp.asarray(current, I32)
    target = jnp.asarray(target, I32)
    nbr_t, legal_t = _move_tables(grid)
    k = current * 8 + jnp.arange(8, dtype=I32)
    nbr, legal = nbr_t[k], legal_t[k]
    vis = exclusion_mask(grid, visited).at[current].set(True)
    cand = legal & ~vis[nbr]
    score = jnp.where(cand, _directional_scores(grid, current, nbr, target, factors), 0.0)
    total = jnp.sum(score)
    prob = jnp.where(total > 0, score / jnp.where(total > 0, total, 1.0), 0.0)
    at_target = legal & (nbr == target)
    prob = jnp.where(jnp.any(at_target), at_target.astype(F32), prob)
    return nbr, prob


# --------------------------------------------------------------- the initialisers
def random_walk(
    key: jax.Array, grid: Grid, capacity: int, stop_adjacent: bool = False
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The plain GA's random-walk initialiser (``random_walk``; Zhu & Pan 4.1).

    :func:`uniform_walk` from ``grid.start`` to ``grid.goal``: a uniformly random free,
    unvisited, legally reachable neighbour at every step; a dead end is a failure; the
    walk stops on the goal (``stop_adjacent=True``: as soon as the goal is a legal
    neighbour). Step cap: ``capacity - 1`` moves. Its success rate is low on cluttered
    maps (Zhu & Pan Table 2: 3-6 %); :func:`initialise` redraws failures.
    """
    return uniform_walk(key, grid, grid.start, grid.goal, capacity, stop_adjacent=stop_adjacent)


def directional(
    key: jax.Array, grid: Grid, capacity: int, factors: tuple[float, float] = (3.0, 2.0)
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Zhu & Pan 2024's initialiser with directional guidance (section 4.1, Algorithm 1).

    :func:`directional_walk` from ``grid.start`` to ``grid.goal``. ``factors=(1, 1)`` is
    the plain 1/d roulette of their comparison method CGA (literature [28]).
    """
    return directional_walk(key, grid, grid.start, grid.goal, capacity, factors=factors)


def median_insertion(
    key: jax.Array,
    grid: Grid,
    capacity: int,
    work_capacity: int | None = None,
    max_rounds: int = 64,
    queue: int | None = None,
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """IMGA's heuristic median insertion (Li, Hu, Liu 2021, section 4.1, eq. 2-3).

    Draw a uniformly random free cell ``N`` that is neither the start nor the goal
    (step (3)(i)), then close the gaps of ``S - N - G`` by median insertion
    (:func:`jaxga.operators.repair.connect`: the median of a discontinuous pair, or a random free
    8-neighbour of it when it is blocked; none = "the individual is directly discarded"),
    then remove loops (:func:`jaxga.core.paths.remove_loops`; IMGA does not say what to do
    with loops, but its chromosomes must be feasible and later operators assume simple
    paths). IMGA asks for ``M`` non-repeating chromosomes: pass ``unique=True`` to
    :func:`initialise`. A map whose only free cells are the start and the goal uses
    ``N = start`` (so the individual is the median connection of ``S - G``).

    The paper's insertion loop is unbounded; on maps with long walls it can cycle for
    ever (a blocked median replaced by a neighbour that reopens the gap). Here the
    connection fails after ``max_rounds`` rounds of parallel insertion (64; on
    ``classic_ga_gapp3_20x20`` the success rate is 32 % with 64 rounds and with 1000,
    and 34-38 % for a sequential transcription of the paper with a 2000-node cap; on
    ``aco_classic_20x20_v1_lihongxin`` 0 % with either, whatever the cap: the test
    ``test_median_insertion_succeeds_as_often_as_the_papers_sequential_insertion``),
    with more than ``queue`` gaps open at once (default 16 on maps up to 20 cells a side,
    where it never binds for ``S - N - G``, the value the paper reproductions ran with;
    ``max(H, W)`` on larger maps, the most gaps two gaps of that span can open), or when
    the connected path, loops included, outgrows ``work_capacity`` (default
    ``capacity``). After loop removal the path must fit ``capacity``.

    ``field_repair`` (static; jaxga's extension, ``repair.fallback = "field"``): a
    connection that does not close is replaced by the path ``S -> N -> G`` down the
    exact distance fields (:func:`field_path`, optimal moves through the same ``N``), so
    the only failure left is a path that does not fit the capacity. Needs ``grid.guide``.
    """
    capacity = _check_capacity(capacity)
    if capacity < 2:
        raise ParameterError("median_insertion needs capacity >= 2 (start and goal)")
    n = grid.n_cells
    idx = jnp.arange(n, dtype=I32)
    free, count = _free_cells(grid, (idx != grid.start) & (idx != grid.goal))
    k_mid, k_conn = jax.random.split(key)
    mid = jnp.where(count > 0, _pick(jax.random.bits(k_mid, (), jnp.uint32), free, count),
                    grid.start)
    anchors = jnp.stack([grid.start, mid, grid.goal]).astype(I32)
    if capacity < 3:
        anchors = jnp.stack([grid.start, grid.goal]).astype(I32)
    work = capacity if work_capacity is None else max(int(work_capacity), capacity)
    if queue is None:
        queue = 16 if max(grid.shape) <= 20 else max(grid.shape)
    cells, length, ok = connect(
        k_conn, grid, anchors, anchors.shape[0], work, max_rounds=max_rounds, queue=queue
    )
    cells, length = remove_loops(cells, length, n)
    cells, length, ok = _fit(cells, length, ok, capacity)
    if field_repair:
        return _repaired(k_conn, grid, mid, capacity, (cells, length, ok))
    return cells, length, ok


def _repaired(key, grid, via, capacity, result):
    """``result`` if ok, else the optimal path through ``via`` down the fields."""
    cells, length, ok = result
    f_cells, f_len, f_ok = field_path(jax.random.fold_in(key, 7), grid, via, capacity,
                                      0.0, 0.0)
    return (jnp.where(ok, cells, f_cells), jnp.where(ok, length, f_len), ok | f_ok)


def intermittent_anchors(
    key: jax.Array, grid: Grid, axis: str = "rows"
) -> tuple[jax.Array, jax.Array]:
    """The barrier-free intermittent path of :func:`intermittent_connect` (MPMGA 4.2).

    ``start``, then one uniformly random free cell of every row strictly between the
    start's and the goal's rows (ordered from the start towards the goal; rows without a
    free cell skipped), then ``goal``. ``axis`` as in :func:`intermittent_connect`.

    Returns:
        ``(anchors int32[max(H, W) + 1], n_anchors int32)``; entries from ``n_anchors``
        on repeat the goal.
    """
    if axis not in ("rows", "columns", "major"):
        raise ParameterError(f"axis must be 'rows', 'columns' or 'major', got {axis!r}")
    h, w = grid.shape
    k_max = max(h, w) + 1  # start + at most max(H, W) - 2 lines + goal
    sx, sy = grid.start % w, grid.start // w
    gx, gy = grid.goal % w, grid.goal // w
    span_r, span_c = jnp.abs(gy - sy), jnp.abs(gx - sx)
    if axis == "rows":
        use_cols = span_r == 0
    elif axis == "columns":
        use_cols = span_c != 0
    else:
        use_cols = span_c > span_r
    # Free cells of every row (x ascending) and of every column (y ascending).
    blocked = grid.blocked
    row_order = jnp.argsort(blocked, axis=1, stable=True).astype(I32)  # [H, W] x's
    row_count = jnp.sum(~blocked, axis=1, dtype=I32)
    col_order = jnp.argsort(blocked, axis=0, stable=True).astype(I32)  # [H, W] y's
    col_count = jnp.sum(~blocked, axis=0, dtype=I32)

    j = jnp.arange(1, k_max - 1, dtype=I32)  # 1 .. k_max - 2
    bits = jax.random.bits(key, (max(k_max - 2, 1),), jnp.uint32)[: k_max - 2]
    # Rows: y = sy + sign * j for j < span.
    ry = jnp.clip(sy + jnp.sign(gy - sy) * j, 0, h - 1)
    r_cnt = row_count[ry]
    r_rank = (bits % jnp.maximum(r_cnt, 1).astype(jnp.uint32)).astype(I32)
    r_cell = ry * w + row_order[ry, jnp.minimum(r_rank, w - 1)]
    r_use = (j < span_r) & (r_cnt > 0)
    # Columns: x = sx + sign * j for j < span.
    cx = jnp.clip(sx + jnp.sign(gx - sx) * j, 0, w - 1)
    c_cnt = col_count[cx]
    c_rank = (bits % jnp.maximum(c_cnt, 1).astype(jnp.uint32)).astype(I32)
    c_cell = col_order[jnp.minimum(c_rank, h - 1), cx] * w + cx
    c_use = (j < span_c) & (c_cnt > 0)
    mid = jnp.where(use_cols, c_cell, r_cell)
    use = jnp.where(use_cols, c_use, r_use)
    # Compact: start, the used line cells in order, goal.
    pos = jnp.cumsum(use, dtype=I32)  # 1-based slot of each used cell
    n_mid = jnp.sum(use, dtype=I32)
    anchors = jnp.full((k_max,), grid.goal, I32).at[0].set(grid.start)
    anchors = anchors.at[jnp.where(use, pos, k_max)].set(mid, mode="drop")
    return anchors, n_mid + 2


def intermittent_connect(
    key: jax.Array,
    grid: Grid,
    capacity: int,
    axis: str = "rows",
    work_capacity: int | None = None,
    max_rounds: int = 64,
    queue: int | None = None,
    field_repair: bool = False,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """MPMGA's barrier-free intermittent path, connected and loop-deleted (Hao et al. 2020 4.2).

    MPMGA section 4.2 (after its reference [21]): "a path that selects a series of free
    grids between the starting point and the target point and does not require
    continuity", then the connection operator (median insertion,
    :func:`jaxga.operators.repair.connect`), then the deletion operator (loop removal). The paper
    does not say how the series is chosen; jaxga follows the classic construction that
    paper lineage uses (start at the bottom row, goal at the top): ONE uniformly random
    free cell in every row strictly between the start's row and the goal's row, ordered
    from the start's row towards the goal's row (the start and goal represent their own
    rows). Rows with no free cell are skipped.

    ``axis`` (static): ``"rows"`` (default, the paper's layout) uses rows, and falls back
    to columns when the start and goal share a row (otherwise the intermittent path would
    be just ``S - G`` with no randomness); ``"columns"`` uses columns (falling back to rows
    when they share a column); ``"major"`` uses whichever of the two spans more lines.

    Connection limits (static): the path, loops included, may grow to ``work_capacity``
    (default ``2 * capacity``: one cell per row at random columns zigzags, and the raw
    connection of a 20 x 20 map is often longer than the 160 cells its loop-free result
    needs); ``queue`` bounds the simultaneously open gaps (default ``4 * max(H, W)``,
    capped at ``work_capacity``; at most ``max(H, W)`` gaps are open at first, and a gap
    splits into at most two); ``max_rounds`` (64) bounds the insertion rounds. After loop
    removal the path must fit ``capacity``; an intermittent path of more anchors than
    ``work_capacity`` cells fails. Measured on ``classic_ga_gapp3_20x20``
    (capacity 160): 16-17 % success, against 19 % for a sequential NumPy transcription of
    the paper with a 2000-node cap and 8.5 % with ``work_capacity = capacity``.

    ``field_repair`` (static; ``repair.fallback = "field"``): a connection that does not
    close is replaced by the optimal path through the middle anchor down the exact
    distance fields (:func:`field_path`); needs ``grid.guide``.
    """
    capacity = _check_capacity(capacity)
    h, w = grid.shape
    work = 2 * capacity if work_capacity is None else max(int(work_capacity), capacity)
    if queue is None:
        queue = min(work, 4 * max(h, w))
    anchors, n_anchors = intermittent_anchors(jax.random.fold_in(key, 1), grid, axis)
    fits = jnp.bool_(True)
    if anchors.shape[0] > work:  # a big map and a small capacity: more lines than cells
        fits = n_anchors <= work
        anchors, n_anchors = anchors[:work], jnp.minimum(n_anchors, work)
    cells, length, ok = connect(
        jax.random.fold_in(key, 2), grid, anchors, n_anchors, work,
        max_rounds=max_rounds, queue=queue,
    )
    ok &= fits
    cells, length = remove_loops(cells, length, grid.n_cells)
    result = _fit(cells, length, ok, capacity)
    if field_repair:
        return _repaired(key, grid, anchors[n_anchors // 2], capacity, result)
    return result


def greedy_walk(
    key: jax.Array,
    grid: Grid,
    source: jax.Array,
    target: jax.Array,
    capacity: int,
    goal_probability: float = 0.5,
    max_steps: int | None = None,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """AGACD's walk ("prior knowledge and random perturbation", Hao et al. 2021 4.3).

    At every step: (1) draw a temporary target, ``target`` with probability
    ``goal_probability`` (0.5) else a uniformly random free cell of the map (any free
    cell, the current one and ``target`` included: "any free grid as the target point");
    (2) the Euclidean distance of each neighbour to it, infinite for an obstacle (and,
    jaxga's extension, for a move the corner rule forbids or a neighbour off the map);
    (3) move to the nearest neighbour; stop when it is ``target``.

    Decisions where AGACD is silent:

    * visited cells are NOT excluded (the paper keeps no visited set; its list may
      revisit cells). Loops are removed after the walk (:func:`jaxga.core.paths.remove_loops`),
      which gives exactly the chronological loop erasure of the walk.
    * ties between equally near neighbours are broken uniformly at random (a fixed
      direction order would bias every path the same way); distances are compared
      exactly as integer squared distances.
    * all neighbours at infinite distance (an isolated cell) is a failure.
    * ``max_steps`` (static, default ``4 * capacity``) caps the moves of the raw walk,
      loops included (the cost is one scan step per move); a walk that has not reached
      ``target`` by then fails, and so does one whose loop-free path exceeds
      ``capacity``. The cap matters on maps with traps: on ``acoga_skolayat_G_20x20``
      (capacity 160) the success rate is 34 % with 159 moves, 80 % with 640 (the
      default) and 96 % with 1280; on the other classic 20 x 20 maps it is >= 99 % with
      640.

    Returns ``(cells int32[capacity], length int32, ok bool)`` after loop removal.
    """
    capacity = _check_capacity(capacity)
    steps = 4 * capacity if max_steps is None else int(max_steps)
    if steps < 0:
        raise ParameterError(f"max_steps must be >= 0, got {max_steps}")
    n, w = grid.n_cells, grid.width
    source = jnp.asarray(source, I32)
    target = jnp.asarray(target, I32)
    nbr_t, legal_t = _move_tables(grid)
    free, n_free = _free_cells(grid)
    bits = jax.random.bits(key, (max(steps, 1), 3), jnp.uint32)[:steps]
    p_goal = float(goal_probability)
    if not 0.0 <= p_goal <= 1.0:
        raise ParameterError(f"goal_probability must be in [0, 1], got {goal_probability}")
    # Per step three words: random target, goal coin (word < p * 2**32), tie rank.
    threshold = None if p_goal >= 1.0 else jnp.uint32(min(round(p_goal * 2**32), 2**32 - 1))
    lanes = jnp.arange(8, dtype=I32)
    big = jnp.int32(2**30)
    on_map = (source >= 0) & (source < n) & (target >= 0) & (target < n)
    src_free = ~grid.blocked.reshape(-1)[jnp.clip(source, 0, n - 1)]
    done0 = (source == target) | ~on_map | ~src_free
    ok0 = (source == target) & on_map & src_free

    def step(carry, b):
        cur, done, ok = carry
        rand_target = _pick(b[0], free, n_free)
        if threshold is None:
            to_goal = jnp.bool_(True)
        else:
            to_goal = b[1] < threshold
        t = jnp.where(to_goal, target, rand_target)
        k = cur * 8 + lanes
        nbr, legal = nbr_t[k], legal_t[k]
        ddx, ddy = nbr % w - t % w, nbr // w - t // w
        d2 = jnp.where(legal, ddx * ddx + ddy * ddy, big)
        best = jnp.min(d2)
        tie = legal & (d2 == best)
        n_tie = jnp.sum(tie, dtype=I32)
        rank = (b[2] % jnp.maximum(n_tie, 1).astype(jnp.uint32)).astype(I32)
        pick = jnp.argmax(tie & (jnp.cumsum(tie, dtype=I32) - 1 == rank))
        dead = n_tie == 0
        move = ~done & ~dead
        new = jnp.where(move, nbr[pick], cur)
        reached = move & (new == target)
        return (new, done | dead | reached, ok | reached), (new, move)

    (_, _, ok), (seq, moved) = jax.lax.scan(step, (jnp.clip(source, 0, n - 1), done0, ok0), bits)
    raw = jnp.concatenate([source[None], seq]).astype(I32)
    raw_len = 1 + jnp.sum(moved, dtype=I32)
    raw, length = remove_loops(raw, raw_len, n)
    return _fit(raw, length, ok, capacity)


def greedy_random_target(
    key: jax.Array,
    grid: Grid,
    capacity: int,
    goal_probability: float = 0.5,
    max_steps: int | None = None,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """AGACD's initialiser (Hao et al. 2021 section 4.3): :func:`greedy_walk` start -> goal.

    A random target per step (the goal with probability 0.5, else a random free cell),
    a greedy step to the nearest legal neighbour, stop at the goal, then loop removal.
    See :func:`greedy_walk` for the decisions where the paper is silent.
    """
    return greedy_walk(
        key, grid, grid.start, grid.goal, capacity,
        goal_probability=goal_probability, max_steps=max_steps,
    )


# ------------------------------------------------------------------ field walks
_STEP_COST = np.where(np.all(DIRECTIONS != 0, axis=1), np.sqrt(2.0), 1.0).astype(np.float32)
"""Length of a step in each of the 8 :data:`jaxga.core.grid.DIRECTIONS`."""

FIELD_SLACK = 0.5
"""Default ``slack`` of :func:`field_walk`: paths up to 1.5 times the optimum."""

FIELD_TEMPERATURE = 1.0
"""Default ``temperature`` of :func:`field_walk` (excess length in cells per factor e)."""


def _require_guide(grid: Grid, what: str):
    if grid.guide is None:
        raise ParameterError(
            f"{what} steers by the problem's distance fields: attach them with "
            "jaxga.operators.guide.with_guide(grid) (jaxga.run does this itself)")
    return grid.guide


def _excess_tolerance(d: jax.Array) -> jax.Array:
    """Float32 rounding of the fields: a step whose excess length is below this counts as
    an optimal step (the true excess of an optimal step is exactly 0)."""
    return jnp.float32(1e-3) + jnp.float32(2e-7) * d


def field_descent(
    key: jax.Array,
    grid: Grid,
    field: jax.Array,
    source: jax.Array,
    capacity: int,
    budget: jax.Array,
    temperature: jax.Array,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """A random walk down an exact distance field, from ``source`` to the field's zero.

    ``field`` is an exact 8-connected distance field (``float32[H * W]``,
    :class:`jaxga.operators.guide.Guide`) to a target cell: the field is 0 there and nowhere else.
    At every step the walk may take a legal move to a neighbour ``n`` of the current cell
    ``c`` when (i) ``field[n] < field[c]`` and (ii) the *excess* of the move,
    ``step(c, n) + field[n] - field[c] >= 0`` (the length the move adds to the shortest
    remaining path), fits what is left of ``budget``. Among those moves it draws one with
    probability proportional to ``exp(-excess / temperature)`` (``temperature`` 0: only
    optimal moves, uniformly).

    Why it cannot fail: from every cell of finite distance some legal move lowers the
    distance by exactly its own length (the next cell of a shortest path), and that move
    has excess 0, so a candidate always exists; the field strictly decreases along the
    walk, so no cell is visited twice (the path is loop-free by construction) and the
    target is reached. Its length is at most ``field[source] + budget`` (plus float32
    rounding, :func:`_excess_tolerance` per step), so it has at most that many moves.

    Args:
        key: PRNG key (one float32 per step, drawn up front).
        grid: the map and its corner rule (the start and goal are not used).
        field: ``float32[H * W]`` distance field of the target.
        source: int32 cell index.
        capacity: static; output length, and at most ``capacity - 1`` moves.
        budget: float32, the excess length the walk may spend (>= 0).
        temperature: float32 >= 0.

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``: ``ok`` is False when the
        source cannot reach the target (infinite field) or the walk needs more than
        ``capacity - 1`` moves.
    """
    field = jnp.asarray(field, F32)
    if field.shape != (grid.n_cells,):
        raise ParameterError(f"field must have shape ({grid.n_cells},), got {field.shape}")
    return _descent(key, grid, field, jnp.int32(0), source, capacity, budget, temperature)


def _descent(key, grid, table, offset, source, capacity, budget, temperature):
    """:func:`field_descent` down the field ``table[offset : offset + H * W]``: several
    fields in one flat table shared by every lane (under ``vmap`` a field that differed
    between lanes would be copied into every lane of the walk's loop)."""
    capacity = _check_capacity(capacity)
    n = grid.n_cells
    source = jnp.clip(jnp.asarray(source, I32), 0, n - 1)
    offset = jnp.asarray(offset, I32)

    def field_at(cell):
        return table[offset + cell]

    nbr_t, legal_t = _move_tables(grid)
    cost = jnp.asarray(_STEP_COST)
    steps = capacity - 1
    u = jax.random.uniform(key, (max(steps, 1),), F32)
    lanes = jnp.arange(8, dtype=I32)
    temp = jnp.maximum(jnp.asarray(temperature, F32), jnp.float32(1e-30))
    budget = jnp.maximum(jnp.asarray(budget, F32), 0.0)
    reachable = jnp.isfinite(field_at(source))

    def cond(carry):
        t, cur, _, _, _ = carry
        return (field_at(cur) > 0) & (t < steps) & reachable

    def step(carry):
        t, cur, used, n_moves, buf = carry
        k = cur * 8 + lanes
        nbr, legal = nbr_t[k], legal_t[k]
        here = field_at(cur)
        there = field_at(nbr)
        excess = cost + there - here
        excess = jnp.where(excess <= _excess_tolerance(here), 0.0, excess)
        cand = legal & (there < here) & (used + excess <= budget)
        weight = jnp.where(cand, jnp.exp(-excess / temp), 0.0)
        cs = jnp.cumsum(weight)
        total = cs[-1]
        idx = jnp.sum(cs <= u[t] * total, dtype=I32)
        last = 7 - jnp.argmax(cand[::-1]).astype(I32)
        idx = jnp.minimum(idx, last)
        # Under vmap the loop runs unmasked (below): a finished walk stays where it is.
        move = (here > 0) & (t < steps) & reachable
        new = jnp.where(move, nbr[idx], cur)
        buf = buf.at[n_moves + 1].set(new, mode="drop")  # past n_moves: scratch
        return (t + 1, new, used + jnp.where(move, excess[idx], 0.0),
                n_moves + move.astype(I32), buf)

    buf0 = jnp.zeros((capacity,), I32).at[0].set(source)
    carry0 = (jnp.int32(0), source, jnp.float32(0.0), jnp.int32(0), buf0)
    # Unmasked: a finished walk's step changes only t and the scratch entry past n_moves.
    _, cur, _, n_moves, buf = lane_while_loop(cond, step, carry0, masked=False)
    cells = jnp.where(jnp.arange(capacity, dtype=I32) <= n_moves, buf, cur)
    ok = reachable & (field_at(cur) == 0)
    return cells, 1 + n_moves, ok


def field_path(
    key: jax.Array,
    grid: Grid,
    via: jax.Array,
    capacity: int,
    budget: jax.Array,
    temperature: jax.Array,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """A path ``start -> via -> goal`` down the exact distance fields (``grid.guide``).

    Two :func:`field_descent` walks from ``via``: one down the start's field (reversed, it
    runs from the start to ``via``) and one down the goal's field; their union has its
    loops removed (:func:`jaxga.core.paths.remove_loops`: the two halves may cross). Whatever
    ``budget`` the detour through ``via`` leaves (``budget`` minus
    ``from_start[via] + to_goal[via] - optimum``) is split evenly between the two walks.

    A ``via`` that the start cannot reach (a cell of another region) is replaced by the
    start itself. So it fails only when the goal is unreachable or the path does not fit
    ``capacity``. With ``via`` on a shortest path and ``budget`` 0 it is an optimal
    8-connected path. Used by :func:`field_walk` and to connect a failed median
    insertion through its own middle cell (:func:`median_insertion`).

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``: continuous, loop-free, from
        ``grid.start`` to ``grid.goal`` when ``ok``.
    """
    capacity = _check_capacity(capacity)
    guide = _require_guide(grid, "field_path")
    n = grid.n_cells
    via = jnp.clip(jnp.asarray(via, I32), 0, n - 1)
    via = jnp.where(jnp.isfinite(guide.from_start[via]), via, grid.start)
    optimum = guide.to_goal[grid.start]
    detour = guide.from_start[via] + guide.to_goal[via] - optimum
    half = jnp.maximum(jnp.asarray(budget, F32) - detour, 0.0) / 2
    table = jnp.concatenate([guide.from_start, guide.to_goal])
    keys = jax.random.split(key, 2)
    cells, length, ok = jax.vmap(
        lambda k, off: _descent(k, grid, table, off, via, capacity, half, temperature)
    )(keys, jnp.asarray([0, n], I32))
    # start .. via (the first walk reversed), then via .. goal without its first cell
    j = jnp.arange(2 * capacity, dtype=I32)
    first = cells[0][jnp.clip(length[0] - 1 - j, 0, capacity - 1)]
    second = cells[1][jnp.clip(j - length[0] + 1, 0, capacity - 1)]
    total = length[0] + length[1] - 1
    joined = jnp.where(j < length[0], first, second)
    joined, total = remove_loops(pad(joined, total), total, n)
    return _fit(joined, total, ok[0] & ok[1], capacity)


def field_reconnect(
    key: jax.Array,
    grid: Grid,
    cells: jax.Array,
    length: jax.Array,
    i: jax.Array,
    j: jax.Array,
    temperature: float | jax.Array = 0.0,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Reconnect a path through the goal's distance field where a repair failed.

    The repair of an operator (median insertion between positions ``i`` and ``j``, a
    regrowth walk) did not close the gap ``cells[i] -> cells[j]``. Instead of failing:
    walk down the goal's field from ``cells[i]`` (:func:`field_descent`, optimal moves
    only, ties broken at random; ``temperature`` > 0 has no effect with no budget) until
    the walk meets the path again at a position ``>= j`` (at the latest at the goal, the
    path's last cell), and splice ``cells[:i + 1] + walk + cells[k:]`` with its loops
    removed (:func:`jaxga.operators.repair.splice_loop_free`). The walk cannot dead-end, so the
    result is a valid path whenever it fits the capacity: the only failure (decision 019).

    Returns ``(cells int32[L], length, ok)``; ``ok`` False = the result exceeds ``L``
    (the cells are then meaningless). Needs ``grid.guide``.
    """

    guide = _require_guide(grid, "field_reconnect")
    cells = jnp.asarray(cells, I32)
    length = jnp.asarray(length, I32)
    cap = cells.shape[0]
    i, j = jnp.asarray(i, I32), jnp.asarray(j, I32)
    walk, walk_len, reached = _descent(key, grid, guide.to_goal, jnp.int32(0), cells[i], cap,
                                       0.0, temperature)
    pos = position_lookup(cells, length, grid.n_cells)(walk)
    t = jnp.arange(cap, dtype=I32)
    meets = (t >= 1) & (t < walk_len) & (pos >= j)
    k = jnp.argmax(meets).astype(I32)  # the goal (the path's last cell) always meets
    seg = jnp.roll(walk, -1)  # walk[1 : k] as a segment
    new, new_len, fits = splice_loop_free(cells, length, i + 1, seg, k - 1, pos[k],
                                          grid.n_cells)
    del reached  # the walk may meet the path before its end: the splice is what counts
    return new, new_len, fits & jnp.any(meets)


def _via_candidates(grid: Grid, budget: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(count int32[H * W + 1], total)``: running count of the cells whose detour
    ``from_start + to_goal - optimum`` is at most ``budget`` (the ellipse of paths no
    longer than the optimum plus the budget); ``count[i]`` counts cells ``< i``."""
    guide = grid.guide
    optimum = guide.to_goal[grid.start]
    through = guide.from_start + guide.to_goal
    ok = jnp.isfinite(through) & (through - optimum <= budget + _excess_tolerance(optimum))
    count = jnp.concatenate([jnp.zeros((1,), I32), jnp.cumsum(ok, dtype=I32)])
    return count, count[-1]


def field_walk(
    key: jax.Array,
    grid: Grid,
    capacity: int,
    slack: float | jax.Array = FIELD_SLACK,
    temperature: float | jax.Array = FIELD_TEMPERATURE,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """jaxga's initialiser that cannot fail: random detours down the exact distance fields.

    Not from the papers ("a path on every map", decision 018). Draw a cell ``N``
    uniformly among the cells through which a path is at most ``(1 + slack)`` times the
    optimum (``from_start[N] + to_goal[N] <= (1 + slack) * optimum``: an ellipse in the
    map's own distances, so it follows corridors and doors, never walls), then build
    ``start -> N -> goal`` with :func:`field_path`, whose two walks spend what is left of
    the budget ``slack * optimum`` on random detours (``temperature``: the walks prefer
    moves that add little length, ``exp(-excess / temperature)``).

    The via cell spreads the population over the routes around obstacles (the homotopy
    classes a GA needs to choose between), the temperature over the ways to follow a
    route. The result is continuous, loop-free and at most ``(1 + slack)`` times the
    optimum long (plus float32 rounding). It succeeds for every reachable goal whose
    optimal path fits ``capacity``: the only failures are an unreachable goal and a
    capacity below the path's cells. Needs ``grid.guide``
    (:func:`jaxga.operators.guide.with_guide`).

    Args:
        slack: the relative excess length allowed (>= 0; traced values allowed).
        temperature: >= 0 (traced values allowed); 0 takes only optimal moves.
    """
    capacity = _check_capacity(capacity)
    guide = _require_guide(grid, "field_walk")
    optimum = guide.to_goal[grid.start]
    budget = jnp.maximum(jnp.asarray(slack, F32), 0.0) * jnp.where(
        jnp.isfinite(optimum), optimum, 0.0)
    count, total = _via_candidates(grid, budget)
    k_via, k_path = jax.random.split(key)
    r = (jax.random.bits(k_via, (), jnp.uint32)
         % jnp.maximum(total, 1).astype(jnp.uint32)).astype(I32)
    via = jnp.searchsorted(count, r, side="right").astype(I32) - 1
    cells, length, ok = field_path(k_path, grid, via, capacity, budget, temperature)
    return cells, length, ok & (total > 0)


# ---------------------------------------------------------------------- population
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class InitStats:
    """What :func:`initialise` did (all fields are arrays, so it can leave ``jit``).

    Attributes:
        attempts: int32, candidates drawn (every candidate of every round, including
            successes beyond what was needed).
        successes: int32, candidates for which the initialiser reported ``ok`` (and, with
            ``verify``, the path checked valid).
        success_rate: float32, ``successes / attempts``: the per-attempt success rate
            (Zhu & Pan Table 2 reports it as successes per 100 attempts).
        rounds: int32, rounds of redraws used.
        n_failed: int32, individuals still without a valid path after the last round.
        valid: ``bool[size]``, False for those individuals.
        duplicates: int32, successful candidates rejected as duplicates (``unique``).
        from_fallback: int32, slots filled by the ``fallback`` initialiser (counted in
            neither ``attempts`` nor ``successes``, which describe the initialiser itself).
    """

    attempts: jax.Array
    successes: jax.Array
    success_rate: jax.Array
    rounds: jax.Array
    n_failed: jax.Array
    valid: jax.Array
    duplicates: jax.Array
    from_fallback: jax.Array

    def raise_if_failed(self, allow_partial: bool = False) -> InitStats:
        """Host-side: raise :class:`~jaxga.core.errors.NoPathError` unless the population is valid.

        Raises when no individual was built, and (unless ``allow_partial``) when any is
        missing. Returns ``self`` so that calls can be chained.
        """
        n_failed = int(self.n_failed)
        size = int(np.asarray(self.valid).shape[0])
        if n_failed == size:
            raise NoPathError(
                f"no initial path found in {int(self.attempts)} attempts "
                f"(success rate 0): the goal may be unreachable, the capacity too small "
                f"or the initialiser unsuited to this map"
            )
        if n_failed and not allow_partial:
            raise NoPathError(
                f"{n_failed} of {size} individuals could not be initialised in "
                f"{int(self.attempts)} attempts (success rate "
                f"{float(self.success_rate):.4f}): raise max_tries or the capacity"
            )
        return self


def _valid_path(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    return (
        has_endpoints(grid, cells, length)
        & is_continuous(grid, cells, length)
        & is_loop_free(cells, length, grid.n_cells)
    )


_HASH_A = np.uint32(0x9E3779B1)
_HASH_B = np.uint32(0x85EBCA77)


def _path_hash(cells: jax.Array, length: jax.Array) -> jax.Array:
    """Two 32-bit polynomial hashes of a padded path: ``uint32[2]``."""
    c = cells.astype(jnp.uint32)
    i = jnp.arange(cells.shape[-1], dtype=jnp.uint32)
    ha = jnp.sum((c + jnp.uint32(1)) * (_HASH_A * (i + jnp.uint32(1)) | jnp.uint32(1)),
                 dtype=jnp.uint32)
    hb = jnp.sum((c ^ (i * _HASH_B)) * (_HASH_B + (i << 1) | jnp.uint32(1)), dtype=jnp.uint32)
    return jnp.stack([ha ^ length.astype(jnp.uint32), hb + length.astype(jnp.uint32)])


FALLBACK_STREAM = 0xFFFFFFFF
"""``fold_in`` data of the fallback's key: the rounds use ``fold_in(key, r)`` with ``r``
far below it, so the fallback never draws the numbers of a round."""


def initialise_population(
    key: jax.Array,
    grid: Grid,
    init_fn: InitFn,
    size: int,
    capacity: int,
    max_tries: int = 200,
    chunk: int | None = None,
    unique: bool = False,
    verify: bool = True,
    fallback: InitFn | None = None,
) -> tuple[Population, InitStats]:
    """A population of ``size`` initial paths, failed individuals redrawn.

    Works in rounds (a ``lax.while_loop`` over rounds, each a ``vmap`` of ``init_fn``
    over ``chunk`` fresh keys): the k-th successful candidate of a round fills the k-th
    still-empty slot, in slot order; rounds stop when every slot is filled or after
    ``ceil(size * max_tries / chunk)`` rounds, i.e. a budget of ``max_tries`` attempts per
    individual on average. With a low success rate, a larger ``chunk`` (e.g.
    ``size / expected_rate``) needs fewer rounds.

    Failure is reported, never hidden: slots still empty after the budget are marked
    ``stats.valid = False`` and counted in ``stats.n_failed``; they hold copies of valid
    individuals (cyclically), so that a GA can run on the population, or the one-cell
    path ``[start]`` if no individual succeeded (not a path to the goal). Call
    ``stats.raise_if_failed()`` on the host to turn a failure into
    :class:`~jaxga.core.errors.NoPathError` (this function runs traced, so it cannot raise on
    traced values itself).

    Args:
        key: PRNG key; the same key gives the same population.
        grid: the map.
        init_fn: static; an initialiser ``(key, grid, capacity) -> (cells, length, ok)``
            (by registered name: :func:`jaxga.config.registry.initialiser`). Bind options
            with ``functools.partial`` and reuse the same object (a new partial each call
            recompiles).
        size: static population size ``P``.
        capacity: static path capacity ``L``.
        max_tries: static average attempts per individual (default 200: enough for
            per-attempt success rates down to about 1 %; rounds stop as soon as the
            population is full, so a generous budget costs nothing when not needed).
        chunk: static candidates per round (default ``size``).
        unique: static; reject candidates identical to an accepted individual (IMGA 4.1
            step (iii): "M nonrepeating chromosomes"). Paths are compared by two 32-bit
            hashes (``O(chunk * (size + chunk))`` comparisons per round); a collision
            only causes an unnecessary redraw. Duplicates count as successes in the
            success rate (the initialiser did find a path) and in ``stats.duplicates``.
        verify: static; check every candidate reported ``ok`` (start, goal, continuous,
            loop-free) and count it as failed otherwise. Cheap, and a guarantee even for
            user-supplied initialisers.
        fallback: static; an initialiser that fills exactly the slots still empty after
            the last round, slot ``i`` with the ``i``-th of ``size`` fallback candidates
            drawn from the key ``fold_in(key, FALLBACK_STREAM)`` (e.g.
            :func:`field_walk`, which cannot fail where a path exists). Slots the rounds
            filled are never touched, so when the rounds fill the population the result
            is the same bit for bit as without a fallback (decision 018).
            ``stats.from_fallback`` counts the slots it filled; candidates are verified
            as the rounds' are (and are not checked for ``unique``).

    Returns:
        ``(Population(cells int32[size, capacity], length int32[size]), InitStats)``.

    ``initialise`` is itself jittable and ``vmap``-able over keys (many seeded runs): the
    rounds then continue until every run's population is full (or the budget is spent).
    The rounds are one plain ``while_loop``: a :func:`jaxga._batching.lanes.lane_while_loop` over
    them saves some run time but nests the initialiser's own compacted loops twice more
    into the program and lengthens its compile (decision 003).
    """
    if not callable(init_fn):
        raise ParameterError(
            f"init_fn must be an initialiser function, got {init_fn!r} (by name: "
            "jaxga.config.registry.initialiser(name))")
    fn = init_fn
    capacity = _check_capacity(capacity)
    if size < 1 or max_tries < 1:
        raise ParameterError(f"size and max_tries must be >= 1, got {size}, {max_tries}")
    chunk = size if chunk is None else int(chunk)
    if chunk < 1:
        raise ParameterError(f"chunk must be >= 1, got {chunk}")
    max_rounds = max(1, math.ceil(size * max_tries / chunk))

    def candidates(r):
        keys = jax.random.split(jax.random.fold_in(key, r), chunk)
        c, ln, ok = jax.vmap(lambda k: fn(k, grid, capacity))(keys)
        c = c.astype(I32)
        ln = ln.astype(I32)
        if verify:
            ok &= jax.vmap(lambda a, b: _valid_path(grid, a, b))(c, ln)
        return c, ln, ok

    cand_ids = jnp.arange(chunk, dtype=I32)

    def body(state):
        cells, length, hashes, filled, r, attempts, successes, dups = state
        c, ln, ok = candidates(r)
        successes = successes + jnp.sum(ok, dtype=I32)
        if unique:
            h = jax.vmap(_path_hash)(c, ln)
            same_old = jnp.all(h[:, None, :] == hashes[None, :, :], axis=-1) & filled[None, :]
            same_new = (jnp.all(h[:, None, :] == h[None, :, :], axis=-1)
                        & ok[None, :] & (cand_ids[None, :] < cand_ids[:, None]))
            dup = ok & (jnp.any(same_old, axis=1) | jnp.any(same_new, axis=1))
            dups = dups + jnp.sum(dup, dtype=I32)
            ok &= ~dup
        rank = jnp.cumsum(ok, dtype=I32) - 1
        n_ok = jnp.sum(ok, dtype=I32)
        by_rank = jnp.zeros((chunk,), I32).at[jnp.where(ok, rank, chunk)].set(
            cand_ids, mode="drop"
        )
        empty_rank = jnp.cumsum(~filled, dtype=I32) - 1
        take = ~filled & (empty_rank < n_ok)
        src = by_rank[jnp.clip(empty_rank, 0, chunk - 1)]
        cells = jnp.where(take[:, None], c[src], cells)
        length = jnp.where(take, ln[src], length)
        if unique:
            hashes = jnp.where(take[:, None], h[src], hashes)
        return (cells, length, hashes, filled | take, r + 1, attempts + chunk, successes, dups)

    def cond(state):
        filled, r = state[3], state[4]
        return (r < max_rounds) & ~jnp.all(filled)

    state0 = (
        jnp.full((size, capacity), grid.start, I32),
        jnp.ones((size,), I32),
        jnp.zeros((size, 2), jnp.uint32),
        jnp.zeros((size,), bool),
        jnp.int32(0),
        jnp.int32(0),
        jnp.int32(0),
        jnp.int32(0),
    )
    cells, length, _, filled, rounds, attempts, successes, dups = jax.lax.while_loop(
        cond, body, state0
    )
    from_fallback = jnp.int32(0)
    if fallback is not None:
        def fill(args):
            cells, length, filled = args
            keys = jax.random.split(jax.random.fold_in(key, FALLBACK_STREAM), size)
            c, ln, ok = jax.vmap(lambda k: fallback(k, grid, capacity))(keys)
            c, ln = c.astype(I32), ln.astype(I32)
            if verify:
                ok &= jax.vmap(lambda a, b: _valid_path(grid, a, b))(c, ln)
            take = ~filled & ok
            return (jnp.where(take[:, None], c, cells), jnp.where(take, ln, length),
                    filled | take)

        # Computed whether or not a slot is empty: under vmap (many runs) a lax.cond would
        # be a select computing both branches anyway, and on a large map its batching
        # multiplied the program's memory many times over (decision 018).
        before = jnp.sum(filled, dtype=I32)
        cells, length, filled = fill((cells, length, filled))
        from_fallback = jnp.sum(filled, dtype=I32) - before
    # Fill the empty slots with copies of valid individuals (flagged invalid).
    n_filled = jnp.sum(filled, dtype=I32)
    filled_ids = jnp.argsort(~filled, stable=True).astype(I32)
    empty_rank = jnp.cumsum(~filled, dtype=I32) - 1
    donor = filled_ids[empty_rank % jnp.maximum(n_filled, 1)]
    use_donor = ~filled & (n_filled > 0)
    cells = jnp.where(use_donor[:, None], cells[donor], cells)
    length = jnp.where(use_donor, length[donor], length)
    stats = InitStats(
        attempts=attempts,
        successes=successes,
        success_rate=successes.astype(F32) / jnp.maximum(attempts, 1).astype(F32),
        rounds=rounds,
        n_failed=size - n_filled,
        valid=filled,
        duplicates=dups,
        from_fallback=from_fallback,
    )
    return Population(cells, length), stats


initialise = functools.wraps(initialise_population)(jax.jit(
    initialise_population,
    static_argnames=("init_fn", "size", "capacity", "max_tries", "chunk", "unique", "verify",
                     "fallback"),
))
"""The jitted :func:`initialise_population` (its static arguments: ``init_fn``, ``size``,
``capacity``, ``max_tries``, ``chunk``, ``unique``, ``verify``, ``fallback``). Inside a
traced program, with an ``init_fn`` or ``fallback`` that closes over traced parameters
(the engine's dynamic ``init.slack``), call :func:`initialise_population` itself."""
