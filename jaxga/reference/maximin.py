"""The exact widest path: the largest clearance any 8-connected path keeps, and a path that
keeps it (the bottleneck, or maximin, path over the map's distance transform).

The length of a path has an exact optimum (:mod:`jaxga.reference.optima`); so has its
clearance, the widest end of a front of length against clearance:

* a cell's clearance is the Euclidean distance from its centre to the nearest blocked
  cell, each blocked cell the closed unit square around its centre (0 for a blocked
  cell; with ``border_blocked``, the squares just outside the map count as blocked):
  :func:`jaxga.maps.clearance.cell_clearance`;
* a path's clearance is the least clearance of its cells;
* the maximin clearance of a start and goal is the largest clearance of an 8-connected
  path between them under the map's corner rule (the moves of
  :func:`jaxga.maps.preprocess.move_edges`).

The bottleneck is
the largest clearance value at which the start and the goal are in one component of the
moves between cells of at least that clearance (a binary search over the distinct
values, :func:`scipy.sparse.csgraph.connected_components`); the path returned is the
shortest path among those cells. Host code with NumPy and SciPy, independent of the JAX
side, like the other references.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from jaxga.core.grid import Grid
from jaxga.maps.clearance import cell_clearance
from jaxga.maps.preprocess import move_edges
from jaxga.reference.optima import (
    XY,
    as_blocked,
    as_xy,
    check_rule,
    endpoint_problem,
    path_length,
    unreachable_message,
)

__all__ = ["MaximinPath", "maximin_path", "maximin_path_np"]


@dataclasses.dataclass(frozen=True, eq=False)
class MaximinPath:
    """The widest path of a problem (:func:`maximin_path`).

    Attributes:
        found: True when the goal is reachable.
        clearance: the maximin clearance in cells (``nan`` when not found; ``inf`` on a
            map without obstacles).
        path: ``int32[k, 2]`` ``(x, y)`` cells from start to goal, each at least
            :attr:`clearance` from the obstacles, consecutive cells legal moves: the
            shortest such path. Shape ``(0, 2)`` when not found.
        length: its Euclidean length in cells (``inf`` when not found).
        reason: ``""`` when found, else why not.
    """

    found: bool
    clearance: float
    path: np.ndarray
    length: float
    reason: str = ""


def _connected(n: int, src: np.ndarray, dst: np.ndarray, keep: np.ndarray,
               s: int, g: int) -> bool:
    """Whether cells ``s`` and ``g`` are joined by the edges ``keep`` selects."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(int(keep.sum())), (src[keep], dst[keep])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return bool(labels[s] == labels[g])


def maximin_path_np(blocked: np.ndarray, start_xy: XY, goal_xy: XY,
                    corner_rule: str = "strict", border_blocked: bool = False, *,
                    clearance: np.ndarray | None = None) -> MaximinPath:
    """:func:`maximin_path` on a raw ``bool[H, W]`` array (row 0 = bottom): the paths
    avoid ``blocked``; ``clearance`` (``float[H, W]``, cells) is each cell's clearance
    (default: :func:`jaxga.maps.clearance.cell_clearance` of ``blocked``; for instance the
    distances to a map's own obstacles where ``blocked`` is the map inflated by a robot's
    radius)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    b = as_blocked(blocked)
    rule = check_rule(corner_rule)
    start, goal = as_xy(start_xy), as_xy(goal_xy)
    none = np.zeros((0, 2), np.int32)
    problem = endpoint_problem(b, start, goal)
    if problem:
        return MaximinPath(False, math.nan, none, math.inf, problem)
    h, w = b.shape
    n = h * w
    s, g = start[1] * w + start[0], goal[1] * w + goal[0]
    if clearance is None:
        clearance = cell_clearance(b, border_blocked)
    clear = np.asarray(clearance, np.float64).reshape(-1)
    src, dst, cost = move_edges(b, rule)
    edge = np.minimum(clear[src], clear[dst])
    if s == g:
        values = np.array([clear[s]])
    else:
        values = np.unique(edge[edge <= min(clear[s], clear[g])])[::-1]
    if s != g and (values.size == 0 or not _connected(n, src, dst, edge >= values[-1], s, g)):
        return MaximinPath(False, math.nan, none, math.inf,
                           unreachable_message(start, goal, rule))
    lo, hi = 0, values.size - 1  # values[hi] joins them; find the first (largest) that does
    while lo < hi:
        mid = (lo + hi) // 2
        if _connected(n, src, dst, edge >= values[mid], s, g):
            hi = mid
        else:
            lo = mid + 1
    best = float(values[lo])
    keep = edge >= best
    graph = coo_matrix((cost[keep], (src[keep], dst[keep])), shape=(n, n)).tocsr()
    _, pred = dijkstra(graph, indices=s, return_predecessors=True)
    cells = [g]
    while cells[-1] != s:
        cells.append(int(pred[cells[-1]]))
    path = np.array([(c % w, c // w) for c in reversed(cells)], np.int32)
    return MaximinPath(True, best, path, path_length(path))


def maximin_path(grid: Grid, border_blocked: bool = False, *,
                 obstacles: np.ndarray | None = None) -> MaximinPath:
    """The widest path of ``grid`` from its start to its goal under its corner rule: the
    largest clearance (module docstring) an 8-connected path can keep, and the shortest
    path that keeps it. The clearance is to ``obstacles`` (``bool[H, W]`` in the grid's
    cells, e.g. a map's own obstacles before inflation, ``MapFrame.obstacles`` of an
    uncoarsened map), by default the grid's blocked cells. A blocked endpoint or an
    unreachable goal gives ``found=False`` with a ``reason``."""
    field = None if obstacles is None else cell_clearance(obstacles, border_blocked)
    return maximin_path_np(grid.blocked_np(), grid.start_xy, grid.goal_xy, grid.corner_rule,
                           border_blocked, clearance=field)
