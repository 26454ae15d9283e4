"""Plain NumPy/Python SGA: the loop-program baseline that ``benchmarks/speed.py`` compares to.

This is the plain genetic algorithm of ``presets/sga.toml`` (the "basic"/"standard" GA
every paper compares against; numbers from AGACD, Hao et al. 2021, Table 6) written the
way paper code is written: for-loops over generations and individuals, every path a
Python list of cell indices, no vectorisation across individuals. It is meant as an
HONEST baseline: no artificial slowness, no needless copies, the obvious
precomputations a careful programmer would make (a table of the free 8-neighbours of
every cell, as ``jaxga.operators.init._move_tables`` builds too), scalar random numbers from one
``numpy.random.default_rng(seed)`` generator.

The map is a boolean ``blocked[H, W]`` array (row 0 at the bottom), start and goal are
cell indices ``y * W + x``, the corner rule is ``"free"``: a move goes to any free
8-neighbour, diagonal squeezes between two blocked side cells included. Paths have a
capacity ``L`` (default ``4 * (H + W)``, ``jaxga.engine.default_capacity``).

Operators, each mirroring the jaxga function named (same semantics, not the same random
stream):

* initialisation ``random_walk`` (:func:`jaxga.operators.init.random_walk` /
  :func:`jaxga.operators.init.uniform_walk`; Zhu & Pan 2024 section 4.1): a self-avoiding walk from
  the start, stepping to a uniformly random free, not yet visited 8-neighbour, until it
  reaches the goal (success), a dead end or ``L - 1`` moves (failure). Failures are
  redrawn as in :func:`jaxga.operators.init.initialise`: a budget of ``max_tries`` (100) attempts
  per individual on average; slots still empty after it get copies of the paths found
  (cyclically), or the one-cell path ``[start]`` if none was found.
  The walk is self-avoiding, so its paths are loop-free.
* fitness ``sga`` (:func:`jaxga.core.objectives.sga`): ``1 / length``, the Euclidean length of
  the cell polyline; 0 for a path that does not run from start to goal through
  consecutive free cells (:func:`jaxga.engine.evaluate`).
* selection ``roulette`` (:func:`jaxga.operators.selection.roulette`; AGACD 4.5, Zhu & Pan eq.
  10): ``P`` i.i.d. fitness-proportional draws (uniform if every fitness is 0).
* crossover ``common_point`` with probability ``pc`` per pair
  (:func:`jaxga.operators.crossover.common_point`; IMGA, Li, Hu & Liu 2021, 4.3.2; Zhu & Pan 4.4):
  consecutive pairs of the mating pool; a cell common to both parents, interior to both,
  chosen uniformly; tails swapped; loops removed; a child longer than ``L`` keeps its
  parent; no common cell, no crossover.
* mutation ``neighbour_point`` with probability ``pm`` per individual
  (:func:`jaxga.operators.mutation.neighbour_point`; IMGA 4.3.3): a random interior node is
  replaced by a random free 8-neighbour other than its two path neighbours, the gaps
  ``prev -> new -> next`` are closed by median insertion (:func:`jaxga.operators.repair.connect`;
  IMGA 4.1 eq. 2-3: insert the median ``((xa + xb) // 2, (ya + yb) // 2)`` of every
  open gap, or a random free 8-neighbour of it if it is blocked; at most 16 rounds, 16
  nodes and 8 open gaps), loops are removed (:func:`jaxga.core.paths.remove_loops`, MPMGA
  4.3), and the parent is kept on any failure or if the mutant exceeds ``L``.
* best-so-far tracking over the initial population and every generation.

Differences from jaxga, all deliberate and none changing the algorithm: the random
stream (indices are ``int(u * n)`` of scalar uniforms); fitness in float64 (jaxga:
float32); a crossover or mutation that the coin ``pc`` / ``pm`` switches off is not
computed at all (under ``vmap`` jaxga computes it and discards it), and the random
walks stop as soon as the population is full (jaxga works in rounds of ``P`` walks).
Crossover children go through the generic loop removal, which gives what jaxga's O(L)
splice computes for loop-free parents.

Run ``python benchmarks/numpy_sga.py`` for the 20 x 20 benchmark (built-in map
``classic_ga_gapp3_20x20``, 3 seeds, P = 60, 300 generations) and
``python benchmarks/numpy_sga.py --large`` to add one 50 x 50 run
(``random_map(50, 50, 0.1, seed=0)``, start (0, 0), goal (49, 49), P = 80, 500
generations; the random walk succeeds in about 0.05 % of attempts there, so the
population starts from a few distinct paths).
"""

from __future__ import annotations

import math
import sys
import time
from bisect import bisect_right
from itertools import accumulate

import numpy as np

MAX_TRIES = 100  # presets/sga.toml init.max_tries: average walk attempts per individual
SEG_CAPACITY = 16  # jaxga.operators.mutation.neighbour_point: nodes of the connection
MAX_ROUNDS = 16  # ... insertion rounds
QUEUE = 8  # ... gaps open at the same time
SQRT2 = math.sqrt(2.0)
DIRECTIONS = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))


# ----------------------------------------------------------------------------- map
def neighbour_table(blocked: np.ndarray) -> list[list[int]]:
    """``table[c]``: the free 8-neighbours of cell ``c`` (for every cell, blocked or not).

    Under the corner rule "free" these are exactly the legal moves out of a free cell.
    """
    h, w = blocked.shape
    table = []
    for c in range(h * w):
        y, x = divmod(c, w)
        cells = []
        for dx, dy in DIRECTIONS:
            nx, ny = x + dx, y + dy
            if 0 <= nx < w and 0 <= ny < h and not blocked[ny, nx]:
                cells.append(ny * w + nx)
        table.append(cells)
    return table


# ------------------------------------------------------------------------- helpers
def remove_loops(path: list[int]) -> list[int]:
    """Keep a node, jump to just after the LAST occurrence of its cell, repeat."""
    last = {c: i for i, c in enumerate(path)}
    out = []
    i, n = 0, len(path)
    while i < n:
        c = path[i]
        out.append(c)
        i = last[c] + 1
    return out


def path_fitness(path: list[int], free: list[bool], w: int, start: int, goal: int) -> float:
    """``1 / length`` of a start-to-goal path of consecutive free cells, else 0."""
    if path[0] != start or path[-1] != goal or not free[start]:
        return 0.0
    total = 0.0
    ax, ay = start % w, start // w
    for k in range(1, len(path)):
        b = path[k]
        bx, by = b % w, b // w
        dx, dy = abs(bx - ax), abs(by - ay)
        if dx > 1 or dy > 1 or dx + dy == 0 or not free[b]:
            return 0.0
        total += SQRT2 if dx and dy else 1.0
        ax, ay = bx, by
    return 1.0 / total if total > 0 else 0.0


def path_length(path: list[int], w: int) -> float:
    """Euclidean length of the cell polyline."""
    total = 0.0
    for k in range(1, len(path)):
        a, b = path[k - 1], path[k]
        total += math.hypot(b % w - a % w, b // w - a // w)
    return total


# --------------------------------------------------------------------------- init
def random_walk(rng, nbrs, start: int, goal: int, capacity: int) -> list[int] | None:
    """Self-avoiding uniform random walk from start to goal, or None (dead end / cap)."""
    path = [start]
    if start == goal:
        return path
    visited = {start}
    cur = start
    while len(path) < capacity:
        cand = [c for c in nbrs[cur] if c not in visited]
        if not cand:
            return None
        cur = cand[int(rng.random() * len(cand))]
        path.append(cur)
        if cur == goal:
            return path
        visited.add(cur)
    return None


def initialise(rng, nbrs, start, goal, population, capacity):
    """``population`` random-walk paths; ``population * MAX_TRIES`` attempts at most."""
    pop = []
    attempts = 0
    while len(pop) < population and attempts < population * MAX_TRIES:
        attempts += 1
        path = random_walk(rng, nbrs, start, goal, capacity)
        if path is not None:
            pop.append(path)
    found = len(pop)
    if found == 0:  # as jaxga.operators.init.initialise: the one-cell path [start] (fitness 0)
        return [[start] for _ in range(population)]
    for k in range(population - found):  # as jaxga.operators.init.initialise: copies, cyclically
        pop.append(pop[k % found])
    return pop


# ---------------------------------------------------------------------- operators
def roulette(rng, fitness: list[float]) -> list[int]:
    """``len(fitness)`` i.i.d. fitness-proportional draws (uniform if all are 0)."""
    n = len(fitness)
    total = sum(fitness)
    if total <= 0:
        return [int(rng.random() * n) for _ in range(n)]
    cum = list(accumulate(fitness))
    last = max(i for i in range(n) if fitness[i] > 0)
    return [min(bisect_right(cum, rng.random() * total), last) for _ in range(n)]


def common_point(rng, p1, p2, start, goal, capacity):
    """Swap the tails at a random common interior cell; loops removed; parent on overflow."""
    n2 = len(p2)
    pos2 = {c: j for j, c in enumerate(p2)}
    common = []
    for i in range(1, len(p1) - 1):
        c = p1[i]
        j = pos2.get(c, -1)
        if 0 < j < n2 - 1 and c != start and c != goal:
            common.append((i, j))
    if not common:
        return p1, p2
    i, j = common[int(rng.random() * len(common))]
    k1 = remove_loops(p1[:i] + p2[j:])
    k2 = remove_loops(p2[:j] + p1[i:])
    return (k1 if len(k1) <= capacity else p1), (k2 if len(k2) <= capacity else p2)


def connect(rng, nbrs, free, w, anchors):
    """Median insertion between consecutive cells until all are adjacent, or None."""
    seg = list(anchors)
    if not all(free[c] for c in seg):
        return None
    for rnd in range(MAX_ROUNDS + 1):
        out = [seg[0]]
        n_open = 0
        for k in range(1, len(seg)):
            a, b = seg[k - 1], seg[k]
            ax, ay, bx, by = a % w, a // w, b % w, b // w
            if max(abs(ax - bx), abs(ay - by)) > 1:
                n_open += 1
                m = ((ay + by) // 2) * w + (ax + bx) // 2
                if not free[m]:
                    cand = nbrs[m]
                    if not cand:
                        return None
                    m = cand[int(rng.random() * len(cand))]
                out.append(m)
            out.append(b)
        if n_open == 0:
            return seg
        if rnd == MAX_ROUNDS or n_open > QUEUE or len(out) > SEG_CAPACITY:
            return None
        seg = out
    return None


def neighbour_point(rng, nbrs, free, w, path, capacity):
    """Move one interior node to a free neighbour and reconnect; None on failure."""
    n = len(path)
    if n < 3:
        return None
    i = 1 + int(rng.random() * (n - 2))
    prev, node, nxt = path[i - 1], path[i], path[i + 1]
    cand = [c for c in nbrs[node] if c != prev and c != nxt]
    if not cand:
        return None
    new = cand[int(rng.random() * len(cand))]
    seg = connect(rng, nbrs, free, w, (prev, new, nxt))
    if seg is None:
        return None
    child = remove_loops(path[: i - 1] + seg + path[i + 2 :])
    return child if len(child) <= capacity else None


# ---------------------------------------------------------------------------- run
def run_sga(
    blocked: np.ndarray,
    start: int,
    goal: int,
    population: int = 60,
    generations: int = 300,
    pc: float = 0.8,
    pm: float = 0.3,
    seed: int = 0,
    capacity: int | None = None,
) -> dict:
    """One run of the plain SGA.

    Returns ``{"best_length", "best_path", "init_s", "evolve_s"}``: the best-so-far path
    (a list of cell indices) and its Euclidean length, and the wall-clock seconds of the
    initialisation (neighbour table, random walks, first evaluation) and of the
    ``generations`` generations. If the random walks found no path at all (as jaxga,
    the run goes on with one-cell paths), ``best_length`` is ``inf`` and ``best_path``
    is empty.
    """
    blocked = np.asarray(blocked, dtype=bool)
    h, w = blocked.shape
    start, goal = int(start), int(goal)
    if capacity is None:
        capacity = 4 * (h + w)
    rng = np.random.default_rng(seed)

    t0 = time.perf_counter()
    nbrs = neighbour_table(blocked)
    free = (~blocked).reshape(-1).tolist()
    pop = initialise(rng, nbrs, start, goal, population, capacity)
    fit = [path_fitness(p, free, w, start, goal) for p in pop]
    k = max(range(population), key=fit.__getitem__)
    best_f, best_path = fit[k], pop[k]
    t1 = time.perf_counter()

    for _ in range(generations):
        pool = [pop[k] for k in roulette(rng, fit)]
        for k in range(0, population - 1, 2):
            if rng.random() < pc:
                pool[k], pool[k + 1] = common_point(
                    rng, pool[k], pool[k + 1], start, goal, capacity
                )
        for k in range(population):
            if rng.random() < pm:
                child = neighbour_point(rng, nbrs, free, w, pool[k], capacity)
                if child is not None:
                    pool[k] = child
        pop = pool
        fit = [path_fitness(p, free, w, start, goal) for p in pop]
        k = max(range(population), key=fit.__getitem__)
        if fit[k] > best_f:
            best_f, best_path = fit[k], pop[k]
    t2 = time.perf_counter()

    found = best_f > 0
    return {
        "best_length": path_length(best_path, w) if found else math.inf,
        "best_path": list(best_path) if found else [],
        "init_s": t1 - t0,
        "evolve_s": t2 - t1,
    }


def check_path(blocked: np.ndarray, path: list[int], start: int, goal: int) -> None:
    """Assert that ``path`` runs from start to goal through 8-adjacent free cells."""
    h, w = blocked.shape
    assert path[0] == start and path[-1] == goal, (path[0], path[-1])
    for a, b in zip(path[:-1], path[1:]):
        assert max(abs(a % w - b % w), abs(a // w - b // w)) == 1, (a, b)
    for c in path:
        assert not blocked[c // w, c % w], c


def _bench(label, blocked, start, goal, population, generations, seeds):
    for seed in seeds:
        r = run_sga(blocked, start, goal, population, generations, seed=seed)
        if r["best_path"]:
            check_path(blocked, r["best_path"], start, goal)
        total = r["init_s"] + r["evolve_s"]
        rate = population * generations / r["evolve_s"]
        print(
            f"{label} P{population}x{generations} seed {seed}: best length "
            f"{r['best_length']:.4f}  init {r['init_s']:.3f} s  evolve {r['evolve_s']:.3f} s  "
            f"run {total:.3f} s  {rate:,.0f} individual-generations/s"
        )


if __name__ == "__main__":
    from jaxga.maps import load_map, random_map

    g = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    print("classic_ga_gapp3_20x20: 8-connected optimum 30.9706")
    _bench("20x20", np.asarray(g.blocked), int(g.start), int(g.goal), 60, 300, (0, 1, 2))
    if "--large" in sys.argv[1:]:
        g = random_map(50, 50, 0.1, seed=0, corner_rule="free")
        _bench("50x50", np.asarray(g.blocked), int(g.start), int(g.goal), 80, 500, (0,))
