"""Exact optimum of a preset's own fitness over 8-connected paths (SPEC 3, 11).

:mod:`jaxga.reference` gives the length optima. Most papers' GAs do not minimise length
alone: Zhu & Pan (eq. 6-9), Zhang (eq. 2), IMGA (eq. 4-7) and MPMGA (eq. 3-14) add a
cost per turn (and IMGA a cost per node next to an obstacle), so the path a perfect
optimiser of *their* fitness returns can be longer than the shortest path. This module
computes that optimum exactly, so a GA can be judged against the value it actually
maximises (``Result.fitness_gap``).

The search space is the one the grid-step GAs evolve in: paths of 8-adjacent cells from
start to goal, every move legal under the grid's corner rule (SPEC 1). For the four
fitnesses whose denominator is a sum over moves and nodes (``sga``, ``iga_zhu``,
``iga_zhang``, ``imga``), the optimum is a shortest path in the graph of states
``(cell, heading of the move that entered it)``: a move costs its weighted length, the
node it enters, and the turn it makes at the cell it leaves. MPMGA's fitness
``alpha / length + beta * c / smoothness`` is not a sum; its penalties are multiples of
5, so the graph gets one layer per smoothness value ``5 s`` and the optimum is the best
of ``alpha / L*(s) + beta * c / max(5 s, floor)`` over the layers, ``L*(s)`` the shortest
path with smoothness exactly ``5 s``; layers are added until no larger smoothness can
win. Dijkstra is :func:`scipy.sparse.csgraph.dijkstra`.

The optimum is taken over *walks*; if the optimal walk visits a cell twice (a loop that
pays for itself in saved turn costs), it is only a bound for the loop-free paths the GAs
keep, and :attr:`FitnessOptimum.loop_free` says so. AGACD's fitness is not covered: its
individuals are waypoint paths, not 8-connected ones (its length gap is measured against
:func:`jaxga.reference.any_angle_shortest_path`).

The costs are written here from SPEC 3 and the papers' equations, independently of
:mod:`jaxga.objectives`; the tests check that the two agree on every optimum returned.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from jaxga.errors import ParameterError
from jaxga.grid import DIRECTIONS, Grid
from jaxga.maps.preprocess import legal_moves

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
per cell (about 100 MB at this size, more for MPMGA's layers)."""

DEFAULT_WEIGHTS: dict[str, dict[str, float]] = {
    "sga": {},
    "iga_zhu": {"omega": 0.7, "c1": 1.0, "c2": 2.0, "c3": 3.0},
    "iga_zhang": {"a": 2.0, "v": 1.0, "v_t": 0.5, "r": 0.5},
    "imga": {"a": 6.0, "b": 1.0, "c": 3.0},
    "mpmga": {"alpha": 0.8, "beta": 0.2, "c": 1.0, "smoothness_floor": 0.1},
}
"""The papers' weights (SPEC 3), the defaults of :mod:`jaxga.objectives` too."""

_STEP = np.array([math.hypot(dx, dy) for dx, dy in DIRECTIONS.tolist()])
MAX_EDGES = 24_000_000
"""MPMGA's layered graph is not built beyond this many edges (about 300 MB)."""


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
            optimum over loop-free paths; otherwise it is an upper bound of it.
        reason: why nothing was computed (unsupported method, map too large, no path).
    """

    found: bool
    method: str
    fitness: float
    length: float = math.nan
    path: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2), np.int32))
    loop_free: bool = True
    reason: str = ""


def _missing(method: str, reason: str) -> FitnessOptimum:
    return FitnessOptimum(False, method, math.nan, reason=reason)


def fitness_weights(config: Mapping) -> tuple[str, dict[str, float]]:
    """``(method, weights)`` of a configuration's fitness (keys ``fitness.*``).

    Missing keys take the papers' values (:data:`DEFAULT_WEIGHTS`)."""
    method = str(config["fitness.method"])
    weights = dict(DEFAULT_WEIGHTS.get(method, {}))
    for name in weights:
        key = f"fitness.{name}"
        if config.get(key) is not None:
            weights[name] = float(config[key])
    return method, weights


# ------------------------------------------------------------------ per-move costs
def _turn_steps(d_in: int, d_out: int) -> int:
    """The turn between two headings in 45-degree steps, 0 (straight) to 4 (reversal)."""
    k = (d_out - d_in) % 8
    return min(k, 8 - k)


def _near_obstacle(blocked: np.ndarray) -> np.ndarray:
    """``bool[H, W]``: some 8-neighbour is blocked (off the map counts as free; IMGA eq. 6)."""
    h, w = blocked.shape
    pad = np.pad(blocked, 1, constant_values=False)
    near = np.zeros((h, w), bool)
    for oy in (-1, 0, 1):
        for ox in (-1, 0, 1):
            if ox or oy:
                near |= pad[1 + oy : 1 + oy + h, 1 + ox : 1 + ox + w]
    return near


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
        node = b * 5.0 * _near_obstacle(blocked).reshape(-1)
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


def _search(n_cells: int, legal: np.ndarray, w: int, start: int, weight_of, layer_of,
            layers: int):
    """Dijkstra over states ``(layer, heading, cell)`` plus one start state.

    ``weight_of(d_in, d_out, src, dst)`` gives the edge weights of the moves in
    direction ``d_out`` out of a cell entered with heading ``d_in``; ``layer_of(d_in,
    d_out)`` how many layers the move climbs (0 for additive fitnesses). Returns the
    distance and predecessor arrays; state ``i`` is ``((layer * 8 + d) * n_cells + c)``,
    the start state is the last one.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    n_states = layers * 8 * n_cells + 1
    src_state = n_states - 1
    rows, cols, vals = [], [], []
    moves = _moves(legal, w)
    for d_out, src, dst in moves:  # the first move, out of the start
        m = src == start
        rows.append(np.full(int(m.sum()), src_state))
        cols.append(d_out * n_cells + dst[m])
        vals.append(weight_of(None, d_out, src[m], dst[m]))
    for layer in range(layers):
        for d_in in range(8):
            for d_out, src, dst in moves:
                up = layer_of(d_in, d_out)
                if layer + up >= layers:
                    continue
                rows.append((layer * 8 + d_in) * n_cells + src)
                cols.append(((layer + up) * 8 + d_out) * n_cells + dst)
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


def _length(cells: list[int], w: int) -> float:
    p = _as_path(cells, w).astype(float)
    return float(np.sum(np.hypot(*np.diff(p, axis=0).T))) if len(cells) > 1 else 0.0


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
    wts = dict(DEFAULT_WEIGHTS[method])
    wts.update({k: float(v) for k, v in (weights or {}).items() if k in wts})
    b = np.asarray(blocked, dtype=bool)
    h, w = b.shape
    n = h * w
    if max_cells is not None and n > max_cells:
        return _missing(method, f"the map has {n:,} cells, more than the exact fitness "
                                f"reference searches by default ({max_cells:,})")
    (sx, sy), (gx, gy) = (int(v) for v in start_xy), (int(v) for v in goal_xy)
    for name, (x, y) in (("start", (sx, sy)), ("goal", (gx, gy))):
        if not (0 <= x < w and 0 <= y < h) or b[y, x]:
            return _missing(method, f"{name} ({x}, {y}) is blocked or off the map")
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

    dist, pred, src_state = _search(n, legal, w, start, weight_of, lambda di, do: 0, 1)
    ends = np.arange(8) * n + goal
    best = int(ends[np.argmin(dist[ends])])
    if not np.isfinite(dist[best]):
        return _missing(method, f"goal ({gx}, {gy}) unreachable from start ({sx}, {sy}) "
                                f"under corner rule {corner_rule!r}")
    if method == "mpmga":  # the shortest length bounds what higher smoothness can give
        return _mpmga_optimum(b, legal, start, goal, wts, shortest=float(dist[best]))
    cells = _walk(pred, best, src_state, n, start)
    cost = float(dist[best]) + float(node[start])
    return FitnessOptimum(True, method, 1.0 / cost, _length(cells, w), _as_path(cells, w),
                          loop_free=len(set(cells)) == len(cells))


def _mpmga_optimum(b: np.ndarray, legal: np.ndarray, start: int, goal: int,
                   wts: Mapping[str, float], shortest: float) -> FitnessOptimum:
    """MPMGA eq. 3: ``alpha / L + beta c / max(S, floor)``, best over smoothness layers.

    ``shortest`` is the 8-connected optimum: no path of any smoothness is shorter."""
    h, w = b.shape
    n = h * w
    alpha, beta_c, floor = wts["alpha"], wts["beta"] * wts["c"], wts["smoothness_floor"]
    edges_per_layer = 64 * int(legal.sum())

    def weight_of(d_in, d_out, src, dst):
        return _STEP[d_out]

    def layer_of(d_in, d_out):
        return _mpmga_turn(d_in, d_out)

    layers = 8
    while True:
        if layers * edges_per_layer > MAX_EDGES:
            if layers == 8:
                return _missing("mpmga", f"the map is too large for MPMGA's layered search "
                                         f"({layers * edges_per_layer:,} edges for 8 "
                                         f"smoothness layers; the limit is {MAX_EDGES:,})")
            return _missing("mpmga", f"MPMGA's optimum needs more than {layers // 2} "
                                     f"smoothness layers (smoothness {5 * layers // 2}) on "
                                     f"this map; the search stops at {MAX_EDGES:,} edges")
        dist, pred, src_state = _search(n, legal, w, start, weight_of, layer_of, layers)
        ends = dist[: layers * 8 * n].reshape(layers, 8, n)[:, :, goal]  # [layer, heading]
        per_layer = ends.min(axis=1)  # L*(s): the shortest path of smoothness 5 s
        s = np.arange(layers) * 5.0
        with np.errstate(divide="ignore"):
            value = np.where(np.isfinite(per_layer),
                             alpha / per_layer + beta_c / np.maximum(s, floor), -np.inf)
        k = int(np.argmax(value))
        # A smoothness of 5 * layers or more gives at most alpha / shortest + beta c / (5 layers).
        if value[k] >= alpha / shortest + beta_c / (5.0 * layers):
            break
        layers *= 2
    d = int(np.argmin(ends[k]))
    cells = _walk(pred, (k * 8 + d) * n + goal, src_state, n, start)
    return FitnessOptimum(True, "mpmga", float(value[k]), float(per_layer[k]),
                          _as_path(cells, w), loop_free=len(set(cells)) == len(cells))


def path_fitness_np(
    blocked: np.ndarray,
    goal_xy: tuple[int, int],
    method: str,
    weights: Mapping[str, float] | None,
    path_xy: np.ndarray,
) -> float:
    """The fitness of one path of 8-adjacent cells by the costs the search minimises.

    For checking: on every continuous path it equals the GA's fitness
    (:mod:`jaxga.objectives`), which the tests verify path by path.
    """
    if method not in SUPPORTED_METHODS:
        raise ParameterError(f"no exact optimum for fitness {method!r}")
    wts = dict(DEFAULT_WEIGHTS[method])
    wts.update({k: float(v) for k, v in (weights or {}).items() if k in wts})
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
    return 1.0 / cost


def fitness_optimum(grid: Grid, config: Mapping | str, *,
                    max_cells: int | None = MAX_CELLS, **weights: float) -> FitnessOptimum:
    """The exact optimum of a preset's fitness on ``grid`` (SPEC 3, 11).

    ``config`` is a :class:`~jaxga.config.Config` (its ``fitness.*`` keys) or a fitness
    method name with ``weights`` as keywords (``fitness_optimum(grid, "iga_zhu",
    omega=0.5)``). The search covers 8-connected paths under ``grid.corner_rule``, the
    space of the grid-step GAs. See :func:`fitness_optimum_np`.
    """
    if isinstance(config, str):
        method, wts = config, dict(weights)
    else:
        method, wts = fitness_weights(config)
    return fitness_optimum_np(grid.blocked_np(), grid.start_xy, grid.goal_xy,
                              grid.corner_rule, method, wts, max_cells=max_cells)
