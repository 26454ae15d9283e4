"""Exact distance fields of a problem: what steers the field initialiser and the repairs.

Beyond the papers ("a path on every map", decisions 018 and 019). The papers' initialisers search
blindly: random walks, medians, greedy steps towards random targets. On a maze, an
office or a 256 x 256 city map they rarely reach the goal, and a population that
starts with no path has nothing to evolve. The exact 8-connected distance from every
cell to the goal (and from the start), under the grid's corner rule, removes the
guesswork: from any reachable cell some legal move lowers the distance to the goal by
exactly its own length, so a walk that only takes moves towards the goal cannot get
stuck (:func:`jaxga.operators.init.field_walk`; decision 018).

The fields are computed once per problem on the host with SciPy's Dijkstra
(:func:`scipy.sparse.csgraph.dijkstra`) over the legal-move graph of
:func:`jaxga.maps.preprocess.move_edges` (step cost 1, diagonal ``sqrt(2)``), and
carried to the device as a :class:`Guide` attached to the :class:`~jaxga.core.grid.Grid`
(:func:`with_guide`), so that every compiled program that receives the grid can read
them. A move graph is symmetric under every corner rule (a move and its reverse pass
the same side cells), so the distance *from* the start is also the distance *to* it.

:func:`problem_facts` gives the host-side numbers a run needs before it compiles: the
optimal length and cell count (for the automatic path capacity) and the size of the
start's connected region (no loop-free path holds more cells).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math

import jax
import numpy as np

from jaxga.core.dtypes import on_device
from jaxga.core.grid import Grid
from jaxga.maps.clearance import cell_clearance
from jaxga.maps.preprocess import move_edges, region_labels

__all__ = ["Guide", "ProblemFacts", "clearance_weighted_field", "distance_fields",
           "field_path", "longest_optimal_path_cells", "padded_guide", "problem_facts",
           "widest_field", "with_front_fields", "with_guide"]

@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Guide:
    """The exact distance fields of one problem (flat, index ``y * W + x``).

    Attributes:
        to_goal: ``float32[H * W]``, the 8-connected distance from each cell to the goal
            under the grid's corner rule; ``inf`` for blocked cells and cells that cannot
            reach the goal.
        from_start: ``float32[H * W]``, the same from the start.
    """

    to_goal: jax.Array
    from_start: jax.Array
    clearance: jax.Array | None = None
    """``float32[H * W]`` or None: each cell's clearance in cells
    (:func:`jaxga.maps.clearance.cell_clearance` of the grid's blocked cells, capped at
    ``H + W``), for the robot objectives of a front (:func:`with_front_fields`)."""
    weighted: jax.Array | None = None
    """``float32[(K + 1) * H * W]`` or None: the clearance walk's fields one after another
    in one flat table: the :func:`widest_field` of the band, then the goal's
    :func:`clearance_weighted_field` for each of ``K`` weights."""
    band: jax.Array | None = None
    """``float32`` or None: the band of the weighted fields and of the intrusion
    objective, in cells."""


@dataclasses.dataclass(frozen=True)
class ProblemFacts:
    """Host-side facts of a start-goal problem (from the exact fields).

    Attributes:
        reachable: whether the goal can be reached from the start.
        optimal_length: the 8-connected optimum (``inf`` when unreachable).
        optimal_cells: cells of an optimal path (every optimal path has as many: its
            length ``a + b sqrt(2)`` fixes the numbers of straight and diagonal steps);
            0 when unreachable.
        reachable_cells: free cells connected to the start (the start included): no
            loop-free path holds more.
    """

    reachable: bool
    optimal_length: float
    optimal_cells: int
    reachable_cells: int


@functools.lru_cache(maxsize=1)
def _move_graph_cached(key: bytes, shape: tuple[int, int], corner_rule: str,
                       blocked_bytes: bytes):
    del key  # the cache key (a digest of the arguments); the arguments are the data
    return _move_graph(np.frombuffer(blocked_bytes, dtype=bool).reshape(shape), corner_rule)


def _map_graph(blocked_bytes: bytes, shape: tuple[int, int], corner_rule: str):
    """The legal-move graph of a map, the last map's kept (a planner's new endpoints on
    its map build none)."""
    key = hashlib.blake2b(blocked_bytes + repr((shape, corner_rule)).encode(),
                          digest_size=16).digest()
    return _move_graph_cached(key, shape, corner_rule, blocked_bytes)


def _move_graph(blocked: np.ndarray, corner_rule: str):
    """The legal-move graph as a SciPy CSR matrix (edge weight = step length)."""
    from scipy.sparse import csr_matrix

    n = blocked.size
    rows, cols, costs = move_edges(blocked, corner_rule)
    return csr_matrix((costs, (rows, cols)), shape=(n, n))


@functools.lru_cache(maxsize=4)
def _fields_cached(key: bytes, shape: tuple[int, int], corner_rule: str, start: int,
                   goal: int, blocked_bytes: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    del key  # the cache key (a digest of the arguments); the arguments are the data
    from scipy.sparse.csgraph import dijkstra

    blocked = np.frombuffer(blocked_bytes, dtype=bool).reshape(shape)
    graph = _map_graph(blocked_bytes, shape, corner_rule)
    dist, pred = dijkstra(graph, directed=True, indices=[goal, start],
                          return_predecessors=True)
    # A blocked endpoint reaches nothing (Dijkstra would still give it distance 0).
    for row, cell in ((0, goal), (1, start)):
        if blocked.reshape(-1)[cell]:
            dist[row] = np.inf
    return dist[0], dist[1], pred[0]


def distance_fields(grid: Grid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(to_goal, from_start, predecessor)``: float64 ``[H * W]`` exact distance fields
    and, for each cell, its next cell on a shortest path to the goal (-9999 where none),
    under ``grid.corner_rule``. Cached per map, endpoints and corner rule (the last 4:
    about 5.5 MB each at 512 x 512)."""
    b = np.ascontiguousarray(grid.blocked_np())
    raw = b.tobytes()
    start, goal = int(grid.start), int(grid.goal)
    digest = hashlib.blake2b(raw + repr((b.shape, grid.corner_rule, start, goal)).encode(),
                             digest_size=16).digest()
    return _fields_cached(digest, b.shape, grid.corner_rule, start, goal, raw)


def with_guide(grid: Grid) -> Grid:
    """``grid`` with its :class:`Guide` attached (``grid.guide``), computed on the host.

    Every function that steers by the fields (:func:`jaxga.operators.init.field_walk`, the
    fallback of :func:`jaxga.operators.init.initialise_population`, the field connection
    of the repairs)
    reads ``grid.guide``. The guide belongs to the grid's map, endpoints and corner rule:
    :meth:`Grid.replace` drops it, so a grid with other endpoints gets its own. (A grid
    changed with ``dataclasses.replace`` keeps a stale guide: its field walks then head
    for the old goal, and :func:`jaxga.operators.init.initialise_population` counts them
    as failures, never as paths.)
    """
    if grid.guide is not None:
        return grid
    to_goal, from_start, _ = distance_fields(grid)
    guide = Guide(to_goal=on_device(to_goal, np.float32),
                  from_start=on_device(from_start, np.float32))
    return dataclasses.replace(grid, guide=guide)


def field_path(grid: Grid) -> np.ndarray | None:
    """An optimal path's cell indices (``y * W + x``) from start to goal, following the
    goal's field (each cell's next cell towards the goal, :func:`distance_fields`); None
    where an endpoint is blocked or the goal unreachable."""
    to_goal, _, towards_goal = distance_fields(grid)
    start, goal = int(grid.start), int(grid.goal)
    if not math.isfinite(to_goal[start]) or not math.isfinite(to_goal[goal]):
        return None
    cells = [start]
    while cells[-1] != goal:
        cells.append(int(towards_goal[cells[-1]]))
    return np.asarray(cells, np.int64)


def problem_facts(grid: Grid) -> ProblemFacts:
    """The optimal length and cell count and the start's region size (see
    :class:`ProblemFacts`), from the exact fields of :func:`distance_fields`."""
    to_goal, from_start, _ = distance_fields(grid)
    region = int(np.sum(np.isfinite(from_start)))
    path = field_path(grid)
    if path is None:
        return ProblemFacts(False, math.inf, 0, region)
    return ProblemFacts(True, float(to_goal[int(grid.start)]), len(path), region)


def longest_optimal_path_cells(grid: Grid) -> int:
    """An upper bound of the cells of an optimal path between any two cells of ``grid``'s
    map that are connected under its corner rule (endpoints ignored): what a planner's
    programs must hold for every start and goal it may be given.

    Within a region, ``d(a, b) <= d(a, c) + d(c, b) <= 2 ecc(c)`` for any cell ``c``
    (``ecc``: the longest distance from ``c`` within its region), and an optimal path
    has at most its length + 1 cells (every step is at least 1 long): so ``2 ecc(c) + 1``
    bounds it, tightest for a central ``c``, here the least of three eccentricities: a
    cell's, the farthest cell from it, and the middle of the path between that cell and
    its own farthest (the double sweep). A path has at most its region's cells too, so
    regions are bounded largest first, each by the lesser of the two, until the next
    region has no more cells than the largest bound so far: a large region enclosed by
    another (a race track's infield, a closed room) is bounded by its own distances, not
    by its cells."""
    from scipy.sparse.csgraph import dijkstra

    blocked = np.ascontiguousarray(grid.blocked_np())
    if blocked.all():
        return 1
    labels = region_labels(blocked, grid.corner_rule).reshape(-1)
    counts = np.bincount(labels)
    ends = np.cumsum(counts)
    order = np.argsort(labels, kind="stable")  # each label's cells together, in its order
    sizes = counts.copy()
    sizes[0] = 0  # label 0: blocked cells, no region
    graph = _map_graph(blocked.tobytes(), blocked.shape, grid.corner_rule)

    def region_bound(label: int) -> int:
        cells = order[ends[label] - sizes[label]:ends[label]]
        region = graph[cells][:, cells]  # its own moves: sweeps cost its cells only

        def sweep(cell: int) -> tuple[float, int, np.ndarray]:
            dist, pred = dijkstra(region, directed=True, indices=cell,
                                  return_predecessors=True)
            dist = np.where(np.isfinite(dist), dist, -1.0)  # (a region is connected)
            far = int(np.argmax(dist))
            return float(dist[far]), far, pred

        ecc_a, b, _ = sweep(0)
        ecc_b, e, pred = sweep(b)
        path = [e]
        while path[-1] != b:
            path.append(int(pred[path[-1]]))
        ecc_c, _, _ = sweep(path[len(path) // 2])
        bound = int(math.floor(2 * min(ecc_a, ecc_b, ecc_c) + 1e-9)) + 1
        return min(bound, int(sizes[label]))

    best = 0
    for label in np.argsort(-sizes, kind="stable"):
        if sizes[label] <= best:  # this region's paths, and every smaller one's, fit
            break
        best = max(best, region_bound(int(label)))
    return best


def clearance_weighted_field(grid: Grid, clearance: np.ndarray, weight: float,
                             band: float) -> np.ndarray:
    """``float64[H * W]``: the cost to the goal of every cell when a move costs its length
    times ``1 + weight * d``, ``d`` the mean over its two cells of how deep they lie in a
    band of ``band`` cells around the obstacles (``max(0, band - c) / band`` for a cell of
    clearance ``c``, ``clearance`` in cells: :func:`jaxga.maps.clearance.cell_clearance`);
    ``inf`` where the goal is out of reach.

    With ``weight`` 0 it is the goal's exact distance field (:func:`distance_fields`).
    A walk down a field of a larger weight trades length for clearance, so fields of
    several weights start a population spread along a front of length against
    clearance (decision 045). The cost stays positive and symmetric (a move and its
    reverse cost the same), so every reachable cell has a move that lowers it."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    if weight < 0 or band <= 0:
        raise ValueError(f"weight must be >= 0 and band > 0, got {weight} and {band}")
    blocked = np.ascontiguousarray(grid.blocked_np())
    depth = np.maximum(band - np.asarray(clearance, np.float64).reshape(-1), 0.0) / band
    rows, cols, steps = move_edges(blocked, grid.corner_rule)
    costs = steps * (1.0 + weight * 0.5 * (depth[rows] + depth[cols]))
    graph = csr_matrix((costs, (rows, cols)), shape=(blocked.size, blocked.size))
    goal = int(grid.goal)
    field = dijkstra(graph, directed=True, indices=goal)
    if blocked.reshape(-1)[goal]:
        field[:] = np.inf
    return field


def widest_field(grid: Grid, clearance: np.ndarray, least: float) -> np.ndarray:
    """``float64[H * W]``: the goal's exact distance field over the cells of clearance at
    least ``least`` (cells; ``clearance`` as for :func:`clearance_weighted_field`): a walk
    down it keeps that clearance all the way, so with ``least`` the maximin clearance
    (:mod:`jaxga.reference.maximin`) it follows a widest path. ``inf`` at every cell
    that cannot reach the goal so; where the start cannot, the goal's exact distance
    field itself (:func:`distance_fields`), so that a walk down it cannot fail."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    blocked = np.ascontiguousarray(grid.blocked_np())
    wide = np.asarray(clearance, np.float64).reshape(-1) >= least
    rows, cols, steps = move_edges(blocked, grid.corner_rule)
    keep = wide[rows] & wide[cols]
    graph = csr_matrix((steps[keep], (rows[keep], cols[keep])),
                       shape=(blocked.size, blocked.size))
    field = dijkstra(graph, directed=True, indices=int(grid.goal))
    if not math.isfinite(field[int(grid.start)]) or not wide[int(grid.goal)]:
        return distance_fields(grid)[0]
    return field


def with_front_fields(grid: Grid, weights: tuple[float, ...], band: float,
                      obstacles: np.ndarray | None = None) -> Grid:
    """``grid`` with its :class:`Guide` (:func:`with_guide`) and the fields a front of
    length against clearance reads (decision 045): each cell's clearance
    (:func:`jaxga.maps.clearance.cell_clearance`, the map's edge not counted as an
    obstacle, capped at ``H + W`` so that a map without obstacles has finite values)
    from ``obstacles`` (``bool[H, W]``: a map's own obstacles before inflation), by
    default from the grid's blocked cells; then in :attr:`Guide.weighted` the
    :func:`widest_field` that keeps ``band`` (cells, > 0) and the goal's
    :func:`clearance_weighted_field` of ``band`` for each of ``weights``. Computed on the
    host once per problem; a grid that has them keeps them."""
    grid = with_guide(grid)
    if grid.guide.weighted is not None:
        return grid
    if band <= 0:
        raise ValueError(f"a front's fields need a band > 0, got {band}")
    source = grid.blocked_np() if obstacles is None else np.asarray(obstacles, bool)
    if source.shape != grid.shape:
        raise ValueError(f"obstacles of shape {source.shape} for a grid of {grid.shape}")
    clearance = np.minimum(cell_clearance(source), grid.height + grid.width)
    fields = [widest_field(grid, clearance, float(band))]
    fields += [clearance_weighted_field(grid, clearance, float(w), float(band))
               for w in weights]
    guide = dataclasses.replace(
        grid.guide, clearance=on_device(clearance.reshape(-1), np.float32),
        weighted=on_device(np.concatenate(fields), np.float32),
        band=on_device(np.float32(band), np.float32))
    return dataclasses.replace(grid, guide=guide)


def padded_guide(guide: Guide, shape: tuple[int, int], pad: tuple) -> Guide:
    """``guide``, of a map of ``shape``, for the map padded by ``pad`` (``np.pad`` widths
    of its rows and columns) with blocked cells: the distance fields padded with
    infinity (no padding cell is reachable), the clearances with 0 (a blocked cell's)."""
    def padded(field, fill):
        if field is None:
            return None
        planes = np.asarray(field).reshape((-1, *shape))
        return on_device(np.pad(planes, ((0, 0), *pad), constant_values=fill).reshape(-1))

    return Guide(to_goal=padded(guide.to_goal, np.inf),
                 from_start=padded(guide.from_start, np.inf),
                 clearance=padded(guide.clearance, 0.0),
                 weighted=padded(guide.weighted, np.inf), band=guide.band)
