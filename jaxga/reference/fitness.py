"""Exact optimum of a preset's own fitness over 8-connected paths.

:mod:`jaxga.reference.optima` gives the length optima. Most papers' GAs do not minimise length
alone: Zhu & Pan (eq. 6-9), Zhang (eq. 2), IMGA (eq. 4-7) and MPMGA (eq. 3-14) add a
cost per turn (and IMGA a cost per node next to an obstacle), so the path a perfect
optimiser of *their* fitness returns can be longer than the shortest path. This module
computes that optimum exactly, so a GA can be judged against the value it actually
maximises (``Result.fitness_gap``).

The search space is the one the grid-step GAs evolve in: paths of 8-adjacent cells from
start to goal, every move legal under the grid's corner rule (decision 027). For the four
fitnesses whose denominator is a sum over moves and nodes (``sga``, ``iga_zhu``,
``iga_zhang``, ``imga``), the optimum is a shortest path in the graph of states
``(cell, heading of the move that entered it)``: a move costs its weighted length, the
node it enters, and the turn it makes at the cell it leaves; Dijkstra is
:func:`scipy.sparse.csgraph.dijkstra`. MPMGA's fitness ``alpha / length + beta * c /
smoothness`` is not a sum; its penalties are multiples of 5, so the states get one layer
per smoothness value ``5 s``, computed one after the other, and the optimum is the best
of ``alpha / L*(s) + beta * c / max(5 s, floor)``, ``L*(s)`` the shortest walk with
smoothness exactly ``5 s``; layers are added until no larger smoothness can win.

The optimum is taken over *walks*; if the optimal walk visits a cell twice (a loop that
pays for itself in saved turn costs), it is only a bound for the loop-free paths the GAs
keep, and :attr:`FitnessOptimum.loop_free` says so. AGACD's fitness is not covered: its
individuals are waypoint paths, not 8-connected ones (its length gap is measured against
:func:`jaxga.reference.any_angle.any_angle_shortest_path`).

The costs are written here from the papers' equations, independently of
:mod:`jaxga.core.objectives`; the tests check that the two agree on every optimum returned.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from jaxga.core import objectives
from jaxga.core.errors import ParameterError
from jaxga.core.grid import DIRECTIONS, Grid
from jaxga.engine import FITNESS_DEFAULTS, check_combination
from jaxga.maps.preprocess import legal_moves
from jaxga.reference.any_angle import obstacle_adjacent_cells
from jaxga.reference.optima import endpoint_problem, path_length, unreachable_message

__all__ = [
    "FitnessOptimum",
    "SUPPORTED_METHODS",
    "MAX_CELLS",
    "fitness_optimum",
    "fitness_optimum_np",
    "path_fitness_np",
    "fitness_weights",
]

SUPPORTED_METHODS = ("sga", "iga_zhu", "iga_zhang", "imga", "mpmga")
"""Fitness methods with an exact 8-connected optimum (``agacd`` is waypoint-based)."""

MAX_CELLS = 128 * 128
"""Maps with more cells are not searched by default: the state graph has up to 64 edges
per cell (about 100 MB at this size; MPMGA's layers have :data:`MAX_LAYER_STATES`)."""

DEFAULT_WEIGHTS: dict[str, dict[str, float]] = {
    m: dict(FITNESS_DEFAULTS[m]) for m in SUPPORTED_METHODS}
"""The weights of each fitness and their defaults (:data:`jaxga.engine.FITNESS_DEFAULTS`,
read from :mod:`jaxga.core.objectives`)."""

MAX_LAYER_STATES = 48_000_000
"""MPMGA's search keeps every layer's states (8 headings x cells, 16 bytes each): it gives
up beyond this many (about 770 MB; 5,800 layers on a 32 x 32 map, 366 on 128 x 128)."""


@dataclasses.dataclass(frozen=True, eq=False)
class FitnessOptimum:
    """The best value of a fitness over 8-connected paths, and a path that reaches it.

    Attributes:
        found: True when the optimum was computed.
        method: the fitness method (``fitness.method`` of a preset).
        fitness: the optimal fitness value (NaN when not found).
        length: the Euclidean length of the optimal path.
        path: ``int32[k, 2]`` ``(x, y)`` cells from start to goal; ``(0, 2)`` if not found.
        loop_free: the optimal walk visits no cell twice, so ``fitness`` is the exact
            optimum over loop-free paths; otherwise it is an upper bound of it (which a
            loop-free path may still reach, on a tie).
        reason: why nothing was computed (unsupported method, map too large, no path).
    """

    found: bool
    method: str
    fitness: float
    length: float = math.nan
    path: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2), np.int32))
    loop_free: bool = True
    reason: str = ""


_STEP = np.array([math.hypot(dx, dy) for dx, dy in DIRECTIONS.tolist()])


def _missing(method: str, reason: str) -> FitnessOptimum:
    return FitnessOptimum(False, method, math.nan, reason=reason)


def _weights(method: str, weights: Mapping[str, float] | None) -> dict[str, float]:
    """The method's weights: ``weights`` over the defaults; unknown names are refused."""
    out = dict(DEFAULT_WEIGHTS[method])
    unknown = sorted(set(weights or {}) - set(out))
    if unknown:
        raise ParameterError(f"fitness {method!r} has no weight {', '.join(unknown)} "
                             f"(its weights: {', '.join(out) or 'none'})")
    out.update({k: float(v) for k, v in (weights or {}).items()})
    return out


def fitness_weights(config: Mapping) -> tuple[str, dict[str, float]]:
    """``(method, weights)`` of a configuration's fitness (keys ``fitness.*``).

    Keys the configuration does not set are left out; :func:`fitness_optimum_np` then
    takes the papers' values (:data:`DEFAULT_WEIGHTS`)."""
    method = str(config["fitness.method"])
    weights = {name: float(config[f"fitness.{name}"]) for name in DEFAULT_WEIGHTS.get(method, {})
               if config.get(f"fitness.{name}") is not None}
    return method, weights


# ------------------------------------------------------------------ per-move costs
def _turn_steps(d_in: int, d_out: int) -> int:
    """The turn between two headings in 45-degree steps, 0 (straight) to 4 (reversal)."""
    k = (d_out - d_in) % 8
    return min(k, 8 - k)


def _additive_costs(method: str, weights: Mapping[str, float], blocked: np.ndarray,
                    goal_xy: tuple[int, int]):
    """``(step[8], node[HW], turn(d_in, d_out) -> float or float[HW])`` of a fitness whose
    denominator is a sum: ``sum step[d] + sum node[cell] + sum turn``."""
    h, w = blocked.shape
    zero_nodes = np.zeros(h * w)
    if method == "sga":  # 1 / length
        return _STEP, zero_nodes, lambda di, do: 0.0
    if method == "iga_zhu":  # Zhu & Pan eq. 6-9: omega L + (1 - omega) sum Gamma
        om = weights["omega"]
        bucket = [0.0, weights["c1"], weights["c2"], weights["c3"], weights["c3"]]
        return om * _STEP, zero_nodes, lambda di, do: (1 - om) * bucket[_turn_steps(di, do)]
    if method == "iga_zhang":  # Zhang eq. 2: L + a m k, k = (v - v_t) pi r / (2 v v_t)
        v, vt = weights["v"], weights["v_t"]
        if v <= 0 or vt <= 0:
            raise ParameterError(f"fitness.v and fitness.v_t must be > 0, got {v}, {vt}")
        per_turn = weights["a"] * (v - vt) * math.pi * weights["r"] / (2 * v * vt)
        return _STEP, zero_nodes, lambda di, do: per_turn if di != do else 0.0
    if method == "imga":  # IMGA eq. 4-7: a L + b S + c E
        a, b, c = weights["a"], weights["b"], weights["c"]
        # IMGA eq. 6: 5 per node with a blocked 8-neighbour (off the map counts as free)
        node = b * 5.0 * obstacle_adjacent_cells(blocked).reshape(-1)
        ys, xs = np.divmod(np.arange(h * w), w)
        sx, sy = np.sign(goal_xy[0] - xs), np.sign(goal_xy[1] - ys)

        def energy(di: int, do: int) -> np.ndarray | float:
            if di == do:
                return 0.0
            dx, dy = DIRECTIONS[do].tolist()
            hx, hy = sx * dx, sy * dy  # the new heading in the goal-facing frame
            e = np.where((hx >= 0) & (hy >= 0), 1.0,
                         np.where((hx <= 0) & (hy <= 0), 10.0, 3.0))
            return c * e

        return a * _STEP, node, energy
    raise ParameterError(f"no additive form for fitness {method!r}")


def _mpmga_turn(d_in: int, d_out: int) -> int:
    """MPMGA eq. 13 in units of 5: 0 straight, 1 below 90 degrees, 5 at 90, 25 beyond."""
    return (0, 1, 5, 25, 25)[_turn_steps(d_in, d_out)]


# ------------------------------------------------------------------------ the graph
def _moves(legal: np.ndarray, w: int) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """Per heading ``d``: the cells a legal move leaves and the cells it enters."""
    out = []
    for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
        src = np.flatnonzero(legal[d].reshape(-1))
        out.append((d, src, src + dy * w + dx))
    return out


def _search(n_cells: int, legal: np.ndarray, w: int, start: int, weight_of):
    """Dijkstra over states ``(heading, cell)`` plus one start state.

    ``weight_of(d_in, d_out, src, dst)`` gives the edge weights of the moves in
    direction ``d_out`` out of a cell entered with heading ``d_in`` (``None`` for the
    start). Returns the distance and predecessor arrays; state ``i`` is
    ``d * n_cells + c``, the start state is the last one.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    n_states = 8 * n_cells + 1
    src_state = n_states - 1
    rows, cols, vals = [], [], []
    moves = _moves(legal, w)
    for d_out, src, dst in moves:  # the first move, out of the start
        m = src == start
        rows.append(np.full(int(m.sum()), src_state))
        cols.append(d_out * n_cells + dst[m])
        vals.append(weight_of(None, d_out, src[m], dst[m]))
    for d_in in range(8):
        for d_out, src, dst in moves:
            rows.append(d_in * n_cells + src)
            cols.append(d_out * n_cells + dst)
            vals.append(weight_of(d_in, d_out, src, dst))
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    v = np.concatenate([np.broadcast_to(np.asarray(x, float), (len(rr),))
                        for x, rr in zip(vals, rows)])
    # csgraph treats an explicit 0 as "no edge" in some paths: weights are > 0 (every
    # move has a positive length), but keep a guard against zero-weight configurations.
    v = np.maximum(v, 1e-300)
    graph = csr_matrix((v, (r, c)), shape=(n_states, n_states))
    dist, pred = dijkstra(graph, directed=True, indices=src_state, return_predecessors=True)
    return dist, pred, src_state


def _walk(pred: np.ndarray, state: int, src_state: int, n_cells: int, start: int) -> list[int]:
    cells = []
    while state != src_state:
        cells.append(int(state % n_cells))
        state = int(pred[state])
    cells.append(start)
    return cells[::-1]


def _as_path(cells: list[int], w: int) -> np.ndarray:
    idx = np.asarray(cells, dtype=np.int64)
    return np.stack([idx % w, idx // w], axis=1).astype(np.int32)


def _found(method: str, fitness: float, cells: list[int], w: int) -> FitnessOptimum:
    path = _as_path(cells, w)
    return FitnessOptimum(True, method, fitness, path_length(path), path,
                          loop_free=len(set(cells)) == len(cells))


def fitness_optimum_np(
    blocked: np.ndarray,
    start_xy: tuple[int, int],
    goal_xy: tuple[int, int],
    corner_rule: str,
    method: str,
    weights: Mapping[str, float] | None = None,
    *,
    max_cells: int | None = MAX_CELLS,
) -> FitnessOptimum:
    """The exact optimum of fitness ``method`` on a raw ``bool[H, W]`` map (row 0 = bottom).

    ``weights`` are the fitness keys without the ``fitness.`` prefix (``omega``, ``c1``,
    ...; missing ones take :data:`DEFAULT_WEIGHTS`). ``max_cells=None`` lifts the size
    limit. Returns ``found=False`` with a ``reason`` for an unsupported method, a map over
    the limit, a blocked endpoint or an unreachable goal.
    """
    if method not in SUPPORTED_METHODS:
        return _missing(method, f"no exact optimum for fitness {method!r} (only "
                                f"{', '.join(SUPPORTED_METHODS)}: AGACD evolves waypoint paths)")
    wts = _weights(method, weights)
    b = np.asarray(blocked, dtype=bool)
    h, w = b.shape
    n = h * w
    if max_cells is not None and n > max_cells:
        return _missing(method, f"the map has {n:,} cells, more than the exact fitness "
                                f"reference searches by default ({max_cells:,})")
    (sx, sy), (gx, gy) = (int(v) for v in start_xy), (int(v) for v in goal_xy)
    problem = endpoint_problem(b, (sx, sy), (gx, gy))
    if problem:
        return _missing(method, problem)
    start, goal = sy * w + sx, gy * w + gx
    if start == goal:
        return _missing(method, "start equals goal: there is no path to optimise")
    legal = legal_moves(b, corner_rule)
    additive = "sga" if method == "mpmga" else method
    step, node, turn = _additive_costs(additive, wts, b, (gx, gy))

    def weight_of(d_in, d_out, src, dst):
        t = 0.0 if d_in is None else turn(d_in, d_out)
        if not np.isscalar(t):
            t = t[src]
        return step[d_out] + node[dst] + t

    dist, pred, src_state = _search(n, legal, w, start, weight_of)
    ends = np.arange(8) * n + goal
    best = int(ends[np.argmin(dist[ends])])
    if not np.isfinite(dist[best]):
        return _missing(method, unreachable_message((sx, sy), (gx, gy), corner_rule))
    if method == "mpmga":  # the shortest length bounds what higher smoothness can give
        return _mpmga_optimum(b, legal, start, goal, wts, shortest=float(dist[best]))
    cells = _walk(pred, best, src_state, n, start)
    cost = max(float(dist[best]) + float(node[start]), objectives.EPS)  # as the GA's fitness
    return _found(method, 1.0 / cost, cells, w)


def _mpmga_optimum(b: np.ndarray, legal: np.ndarray, start: int, goal: int,
                   wts: Mapping[str, float], shortest: float) -> FitnessOptimum:
    """MPMGA eq. 3: ``alpha / L + beta c / max(S, floor)``, best over smoothness layers.

    Layer ``s`` holds, for every state (heading, cell), the shortest walk from the start
    whose smoothness is exactly ``5 s``; it is computed from layers ``s - 1``, ``s - 5``
    and ``s - 25`` (a turn of 45, 90 or more degrees) and then by straight moves within
    the layer, one layer after the other. ``shortest`` is the 8-connected optimum: no
    walk of any smoothness is shorter, so once ``alpha / shortest + beta c / (5 (s + 1))``
    is no better than the best value found, no later layer can win.
    """
    h, w = b.shape
    n = h * w
    alpha, beta_c, floor = wts["alpha"], wts["beta"] * wts["c"], wts["smoothness_floor"]
    moves = _moves(legal, w)
    turns = {inc: [(di, do) for di in range(8) for do in range(8) if _mpmga_turn(di, do) == inc]
             for inc in (1, 5, 25)}
    max_layers = max(1, MAX_LAYER_STATES // (8 * n))
    # A loop-free path turns at most n - 2 times, by at most 25 units each: the layers up
    # to 25 (n - 2) hold every loop-free path, so their best bounds the loop-free optimum.
    all_paths = 25 * max(n - 2, 0) + 1
    dist: list[np.ndarray] = []  # [layer] float64[8, n]
    pred: list[np.ndarray] = []  # [layer] int64[8, n]: (layer * 8 + heading) * n + cell
    best_value, best_state = -np.inf, -1
    for layer in range(min(max_layers, all_paths)):
        cur = np.full((8, n), np.inf)
        came = np.full((8, n), -1, np.int64)
        if layer == 0:  # the first move, out of the start: no turn
            for d, src, dst in moves:
                m = src == start
                cur[d, dst[m]] = _STEP[d]
        for inc, pairs in turns.items():  # a turn climbs inc layers
            if layer < inc:
                continue
            prev = dist[layer - inc]
            for d_in, d_out in pairs:
                _, src, dst = moves[d_out]
                cand = prev[d_in, src] + _STEP[d_out]
                better = cand < cur[d_out, dst]
                cur[d_out, dst[better]] = cand[better]
                came[d_out, dst[better]] = ((layer - inc) * 8 + d_in) * n + src[better]
        for d, src, dst in moves:  # straight on, within the layer, until nothing improves
            while True:
                cand = cur[d, src] + _STEP[d]
                better = cand < cur[d, dst]
                if not better.any():
                    break
                cur[d, dst[better]] = cand[better]
                came[d, dst[better]] = (layer * 8 + d) * n + src[better]
        dist.append(cur)
        pred.append(came)
        d_best = int(np.argmin(cur[:, goal]))
        if np.isfinite(cur[d_best, goal]):
            value = alpha / cur[d_best, goal] + beta_c / max(5.0 * layer, floor)
            if value > best_value:
                best_value, best_state = value, (layer * 8 + d_best) * n + goal
        if best_value >= alpha / shortest + beta_c / (5.0 * (layer + 1)):
            break
    else:
        if max_layers < all_paths:
            return _missing("mpmga", f"MPMGA's optimum needs more than {max_layers} smoothness "
                                     f"layers (smoothness {5 * max_layers}) on this map: "
                                     "not computed")
    cells, state = [], best_state
    while state >= 0:
        layer, rest = divmod(state, 8 * n)
        d, cell = divmod(rest, n)
        cells.append(cell)
        state = int(pred[layer][d, cell])
    cells.append(start)
    cells.reverse()
    return _found("mpmga", float(best_value), cells, w)


def path_fitness_np(
    blocked: np.ndarray,
    goal_xy: tuple[int, int],
    method: str,
    weights: Mapping[str, float] | None,
    path_xy: np.ndarray,
) -> float:
    """The fitness of one path of 8-adjacent cells by the costs the search minimises.

    For checking: on every continuous path it equals the GA's fitness
    (:mod:`jaxga.core.objectives`), which the tests verify path by path.
    """
    if method not in SUPPORTED_METHODS:
        raise ParameterError(f"no exact optimum for fitness {method!r}")
    wts = _weights(method, weights)
    b = np.asarray(blocked, dtype=bool)
    w = b.shape[1]
    p = np.asarray(path_xy, dtype=np.int64).reshape(-1, 2)
    heads = [[tuple(v) for v in DIRECTIONS.tolist()].index((int(dx), int(dy)))
             for dx, dy in np.diff(p, axis=0)]
    cells = (p[:, 1] * w + p[:, 0]).tolist()
    if method == "mpmga":
        smooth = 5.0 * sum(_mpmga_turn(a, c) for a, c in zip(heads[:-1], heads[1:]))
        return wts["alpha"] / float(sum(_STEP[heads])) + wts["beta"] * wts["c"] / max(
            smooth, wts["smoothness_floor"])
    step, node, turn = _additive_costs(method, wts, b, (int(goal_xy[0]), int(goal_xy[1])))
    cost = float(node[cells[0]])
    for k, d in enumerate(heads):
        t = 0.0 if k == 0 else turn(heads[k - 1], d)
        cost += step[d] + node[cells[k + 1]] + (t if np.isscalar(t) else t[cells[k]])
    return 1.0 / max(cost, objectives.EPS)


def fitness_optimum(grid: Grid, config: Mapping | str, *,
                    max_cells: int | None = MAX_CELLS, **weights: float) -> FitnessOptimum:
    """The exact optimum of a preset's fitness on ``grid``.

    ``config`` is a :class:`~jaxga.config.schema.Config` (its ``fitness.*`` keys) or a fitness
    method name with ``weights`` as keywords (``fitness_optimum(grid, "iga_zhu",
    omega=0.5)``). The search covers 8-connected paths under ``grid.corner_rule``, the
    space of the grid-step GAs. See :func:`fitness_optimum_np`.
    """
    if isinstance(config, str):
        method, wts = config, dict(weights)
        check_combination({"fitness.method": method,
                           **{f"fitness.{k}": v for k, v in wts.items()}})
    elif weights:
        raise ParameterError("give the weights in the configuration (fitness.* keys), not "
                             "as keywords beside it")
    else:
        check_combination(config)  # the weights a run would refuse are refused here too
        method, wts = fitness_weights(config)
    return fitness_optimum_np(grid.blocked_np(), grid.start_xy, grid.goal_xy,
                              grid.corner_rule, method, wts, max_cells=max_cells)
