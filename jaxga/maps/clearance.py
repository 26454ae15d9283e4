"""The clearance a robot has: the distance from a path to the obstacles of the map as
loaded, before any inflation, and the margin beyond the robot's radius.

The GA plans on an inflated grid (``--robot-radius``, ``--inflate``), and
:func:`jaxga.core.objectives.min_clearance` measures a path against the cells it plans
on: a path that hugs the inflated margin has a clearance near 0 there although the wall
is a robot's radius away. A robot user asks how far the path stays from the walls
themselves. :class:`ObstacleClearance` answers that, exactly, on the host:

* the obstacles are the map file's blocked cells (occupied, and unknown where unknown
  cells are planned on as blocked), each the closed square of its map cell, at the map
  file's own resolution (also when the planning grid is coarsened);
* a path is the polyline through its planning cells' centres;
* its clearance is the least Euclidean distance between the polyline and the union of
  the squares (0 for a path touching or crossing one).

One Euclidean distance transform per map (computed once, when the map is loaded) bounds
each segment's clearance from above by its endpoints' distances, and only the obstacle
cells on the boundary of an obstacle (a free 4-neighbour) inside the segment's box
grown by that bound are measured exactly: the cost follows the path and its
surroundings, not the map's free area.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ObstacleClearance", "cell_clearance", "segment_square_distance"]


def segment_square_distance(a: np.ndarray, b: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Exact distances from segment ``a b`` (points ``float[2]``) to the closed unit squares
    centred at ``centres`` (``float[n, 2]``), float64.

    Zero where a square touches the segment. For a square disjoint from it, the least of
    the distances from the segment's two endpoints to the square and from the square's
    four corners to the segment (exact for two disjoint convex polygons)."""
    a, b, c = (np.asarray(v, np.float64) for v in (a, b, centres))
    d = b - a
    lo, hi = c - 0.5, c + 0.5

    def point_box(p: np.ndarray) -> np.ndarray:
        e = np.maximum(np.maximum(lo - p, p - hi), 0.0)
        return np.hypot(e[:, 0], e[:, 1])

    best = np.minimum(point_box(a), point_box(b))
    len2 = float(d @ d)
    for sx in (-0.5, 0.5):
        for sy in (-0.5, 0.5):
            q = c + (sx, sy) - a
            t = np.clip(q @ d / len2, 0.0, 1.0) if len2 > 0 else np.zeros(len(c))
            best = np.minimum(best, np.hypot(q[:, 0] - t * d[0], q[:, 1] - t * d[1]))
    # touching: the segment meets the square (separating-axis test on the square's axes
    # and the segment's normal)
    over = (np.minimum(a, b) <= hi).all(axis=1) & (np.maximum(a, b) >= lo).all(axis=1)
    side = np.abs(d[0] * (c[:, 1] - a[1]) - d[1] * (c[:, 0] - a[0]))
    touch = over & (side <= 0.5 * (abs(d[0]) + abs(d[1])) + 1e-12)
    return np.where(touch, 0.0, best)


def _square_term(d: np.ndarray) -> np.ndarray:
    """One axis's share of the squared distance from a cell centre to a unit square
    ``d`` cells away along that axis."""
    return np.maximum(np.abs(d) - 0.5, 0.0) ** 2


def _row_distances(blocked: np.ndarray) -> np.ndarray:
    """``float64[H, W]``: along each row, the distance in cells from each cell to the
    nearest blocked cell of that row (``inf`` for a row without one)."""
    h, w = blocked.shape
    x = np.broadcast_to(np.arange(w, dtype=np.float64), (h, w))
    left = np.where(blocked, x, -np.inf)
    left = np.maximum.accumulate(left, axis=1)
    right = np.where(blocked, x, np.inf)
    right = np.minimum.accumulate(right[:, ::-1], axis=1)[:, ::-1]
    return np.minimum(x - left, right - x)


def cell_clearance(blocked: np.ndarray, border_blocked: bool = False) -> np.ndarray:
    """``float64[H, W]``: the exact Euclidean distance from each cell's centre to the
    nearest blocked cell's square (``blocked[y, x]``; 0 on a blocked cell, ``inf`` on a
    map without blocked cells), with the squares just outside the map blocked too when
    ``border_blocked``.

    Exact: the squared distance to a unit square is a sum of one term per axis,
    ``max(|dx| - 1/2, 0)**2 + max(|dy| - 1/2, 0)**2``, so one pass along the rows (the
    nearest blocked cell of each row, the term being monotone in ``|dx|``) and one pass
    of row offsets give every cell's minimum; the offsets stop once no further row can
    be nearer. The widest path (:mod:`jaxga.reference.maximin`) and the robot
    objectives (:mod:`jaxga.core.robot_objectives`) read it."""
    b = np.asarray(blocked, dtype=bool)
    if b.ndim != 2:
        raise ValueError(f"blocked must be a 2-D array, got shape {b.shape}")
    if border_blocked:
        b = np.pad(b, 1, constant_values=True)
    h, w = b.shape
    across = _square_term(_row_distances(b))  # each row's share, per source row
    best = across.copy()
    for dy in range(1, h):
        step = _square_term(np.float64(dy))
        if step >= best.max():
            break  # every cell already has a nearer square than any further row offers
        best[dy:] = np.minimum(best[dy:], across[:-dy] + step)
        best[:-dy] = np.minimum(best[:-dy], across[dy:] + step)
    out = np.sqrt(best)
    return out[1:-1, 1:-1] if border_blocked else out


class ObstacleClearance:
    """Exact clearance of paths from the obstacles of one map as loaded.

    Args:
        obstacles: ``bool[H, W]`` in the map file's cells (row 0 at the bottom): the map's
            own obstacles, before inflation.
        coarsen: map cells a side per planning cell (paths are given in planning cells).
        cell_size: metres per map cell, or None for a map without a resolution.
    """

    def __init__(self, obstacles: np.ndarray, coarsen: int = 1,
                 cell_size: float | None = None) -> None:
        from scipy import ndimage  # deferred: scipy's import is paid by the maps measured

        obstacles = np.asarray(obstacles, bool)
        self.coarsen = int(coarsen)
        self.cell_size = cell_size
        self.shape = obstacles.shape
        self.any = bool(obstacles.any())
        # distance from each cell's centre to the nearest obstacle cell's centre (an
        # upper bound of the distance to its square)
        self._edt = (ndimage.distance_transform_edt(~obstacles) if self.any
                     else np.full(obstacles.shape, np.inf))
        free = np.pad(~obstacles, 1, constant_values=False)
        near_free = free[:-2, 1:-1] | free[2:, 1:-1] | free[1:-1, :-2] | free[1:-1, 2:]
        # the union's nearest point to a point outside it lies on an edge no other
        # obstacle square shares: on a square with a free 4-neighbour
        self._boundary = obstacles & near_free

    def map_points(self, cells: np.ndarray) -> np.ndarray:
        """Planning cells' centres ``(x, y)`` in map-cell coordinates (centres at
        integers)."""
        k = self.coarsen
        return (np.asarray(cells, np.float64) + 0.5) * k - 0.5

    def _bound(self, p: np.ndarray) -> float:
        """An upper bound of point ``p``'s distance to the obstacles (map cells)."""
        h, w = self.shape
        x = min(max(int(round(p[0])), 0), w - 1)
        y = min(max(int(round(p[1])), 0), h - 1)
        return float(self._edt[y, x]) + math.hypot(p[0] - x, p[1] - y)

    def of_path(self, cells: np.ndarray) -> float:
        """The path's clearance in map cells: the least distance from the polyline
        through the planning cells ``cells`` (``int[k, 2]``, ``(x, y)``) to the obstacle
        squares; ``inf`` on a map without obstacles."""
        if not self.any:
            return math.inf
        pts = self.map_points(cells).reshape(-1, 2)
        if len(pts) == 1:
            pts = np.concatenate([pts, pts])
        h, w = self.shape
        best = math.inf
        for a, b in zip(pts[:-1], pts[1:]):
            reach = min(self._bound(a), self._bound(b), best)
            x0 = max(int(math.floor(min(a[0], b[0]) - reach - 1)), 0)
            x1 = min(int(math.ceil(max(a[0], b[0]) + reach + 1)), w - 1)
            y0 = max(int(math.floor(min(a[1], b[1]) - reach - 1)), 0)
            y1 = min(int(math.ceil(max(a[1], b[1]) + reach + 1)), h - 1)
            ys, xs = np.nonzero(self._boundary[y0:y1 + 1, x0:x1 + 1])
            if len(xs):
                centres = np.stack([xs + x0, ys + y0], axis=1)
                best = min(best, float(segment_square_distance(a, b, centres).min()))
        return best

    def of_path_m(self, cells: np.ndarray) -> float | None:
        """:meth:`of_path` in metres; None for a map without a resolution."""
        if self.cell_size is None:
            return None
        return self.of_path(cells) * self.cell_size
