"""Walk initialisers: self-avoiding random walks (Zhu & Pan 4.1: uniform and directional,
Algorithm 1), AGACD's greedy walk to random targets (AGACD 4.3), and the walks' visited-cell
hash set."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.lanes import lane_while_loop
from jaxga.core import prng
from jaxga.core.dtypes import F32, I32
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.core.paths import (
    remove_loops,
)
from jaxga.operators.init.common import (
    check_capacity,
    exclusion_mask,
    fit_to_capacity,
    free_cells,
    move_tables,
    pick_cell,
    write_at,
)


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
    capacity = check_capacity(capacity)
    source = jnp.asarray(source, I32)
    target = jnp.asarray(target, I32)
    n = grid.n_cells
    nbr_t, legal_t = move_tables(grid)
    use_table = n <= VISITED_TABLE_CELLS_PER_NODE * capacity
    if use_table:  # the walk's visited set: one int32 per cell of the map
        # int32, not bool: a bool table updated in a batched loop is a pattern that one
        # accelerator backend has mis-executed (docs/devices.md, "Exactness").
        visited = exclusion_mask(grid, exclude).astype(jnp.int32)
        visited = visited.at[jnp.clip(target, 0, n - 1)].set(0)
        visited = visited.at[jnp.clip(source, 0, n - 1)].set(1)
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
    u = prng.uniform(key, (max(steps, 1),), F32)
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
            cand = legal & (visited[nbr] == 0)
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
            # its costly reduce_window. The directional scores keep jnp.cumsum, where
            # the unrolled adds cost more than they save (decision 002).
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
            visited = visited.at[new].set(1)
        else:
            table, kept = _hash_add(visited[0], new)
            visited = (table, visited[1] | ~kept)
        reached = move & (new == target)
        buf = write_at(buf, n_moves + 1, new)  # past n_moves: scratch
        return (t + 1, new, visited, done | dead | reached, ok | reached,
                n_moves + move.astype(I32), buf)

    # A while loop over steps that stops when the walk is done (a dead end or the
    # target): under vmap its unfinished lanes are compacted (jaxga._batching.lanes), so a batch
    # of walks that mostly die or arrive early does not run to the step cap.
    buf0 = jnp.zeros((capacity,), I32).at[0].set(source)
    carry0 = (jnp.int32(0), jnp.clip(source, 0, n - 1), visited, done0, ok0, jnp.int32(0), buf0)
    # Unmasked: a finished walk's step changes only t, done and the scratch entry past
    # n_moves, none of which is read below, so the loop skips the per-step select of the
    # visited table and the buffer (decision 002).
    _, cur, visited, _, ok, n_moves, buf = lane_while_loop(cond, step, carry0, masked=False)
    if not use_table:
        ok &= ~visited[1]  # a full probe window: the walk may have crossed itself
    # Past its last move a walk stays on its final cell.
    cells = jnp.where(jnp.arange(capacity, dtype=I32) <= n_moves, buf, cur)
    length = 1 + n_moves
    return cells, length, ok


VISITED_TABLE_CELLS_PER_NODE = 64
"""A self-avoiding walk keeps its visited set as one int32 per map cell (not bool:
docs/devices.md, "Exactness") while the map has at most this many cells per node of the
walk's capacity (up to 101 x 101 cells, 40 kB per walk, for a capacity of 160; a table
is probed faster than the hash set of 32-64 bytes per node);
on larger maps as a hash set of the walk's own cells (:func:`_hash_add`) and a sorted
list of the excluded ones, so that its memory and time grow with the capacity, not with
the map (decision 008)."""


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
    nbr_t, legal_t = move_tables(grid)
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
    maps (Zhu & Pan Table 2: 3-6 %); :func:`initialise_population` redraws failures.
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
      ``capacity``. The cap matters on maps with traps, where a walk that revisits cells
      needs many more moves than its loop-free path has cells: on
      ``acoga_skolayat_G_20x20`` ``4 * capacity`` completes most of the walks that twice
      the cap (at twice the cost) would, where ``capacity`` moves lose most of them; on
      the other classic 20 x 20 maps it loses almost none (decision 044).

    Returns ``(cells int32[capacity], length int32, ok bool)`` after loop removal.
    """
    capacity = check_capacity(capacity)
    steps = 4 * capacity if max_steps is None else int(max_steps)
    if steps < 0:
        raise ParameterError(f"max_steps must be >= 0, got {max_steps}")
    n, w = grid.n_cells, grid.width
    source = jnp.asarray(source, I32)
    target = jnp.asarray(target, I32)
    nbr_t, legal_t = move_tables(grid)
    free, n_free = free_cells(grid)
    bits = prng.bits(key, (max(steps, 1), 3), jnp.uint32)[:steps]
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
        rand_target = pick_cell(b[0], free, n_free)
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
    return fit_to_capacity(raw, length, ok, capacity)


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
