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

from jaxga.maps.preprocess import blocks_to_map

__all__ = ["ObstacleClearance", "cell_clearance", "segment_square_distance",
           "segments_square_distance"]


def segment_square_distance(a: np.ndarray, b: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Exact distances from segment ``a b`` (points ``float[2]``) to the closed unit squares
    centred at ``centres`` (``float[n, 2]``), float64 (:func:`segments_square_distance`
    for one segment)."""
    return segments_square_distance(np.asarray(a, np.float64)[None],
                                    np.asarray(b, np.float64)[None], centres)[0]


def segments_square_distance(a: np.ndarray, b: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """``float64[m, n]``: exact distances from each segment ``a[i] b[i]`` (``float[m, 2]``)
    to each closed unit square centred at ``centres`` (``float[n, 2]``).

    Zero where a square touches the segment. For a square disjoint from it, the least of
    the distances from the segment's two endpoints to the square and from the square's
    four corners to the segment (exact for two disjoint convex polygons)."""
    a, b, c = (np.asarray(v, np.float64) for v in (a, b, centres))
    a, b, c = a[:, None, :], b[:, None, :], c[None, :, :]  # [m, 1, 2], [1, n, 2]
    d = b - a
    lo, hi = c - 0.5, c + 0.5

    def point_box(p: np.ndarray) -> np.ndarray:
        e = np.maximum(np.maximum(lo - p, p - hi), 0.0)
        return np.hypot(e[..., 0], e[..., 1])

    best = np.minimum(point_box(a), point_box(b))
    len2 = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]  # [m, 1]
    positive = len2 > 0
    safe = np.where(positive, len2, 1.0)
    for sx in (-0.5, 0.5):
        for sy in (-0.5, 0.5):
            q = c + np.array([sx, sy]) - a
            t = np.where(positive, np.clip(
                (q[..., 0] * d[..., 0] + q[..., 1] * d[..., 1]) / safe, 0.0, 1.0), 0.0)
            best = np.minimum(best, np.hypot(q[..., 0] - t * d[..., 0],
                                             q[..., 1] - t * d[..., 1]))
    # touching: the segment meets the square (separating-axis test on the square's axes
    # and the segment's normal)
    over = ((np.minimum(a, b) <= hi).all(axis=-1) & (np.maximum(a, b) >= lo).all(axis=-1))
    side = np.abs(d[..., 0] * (c[..., 1] - a[..., 1]) - d[..., 1] * (c[..., 0] - a[..., 0]))
    touch = over & (side <= 0.5 * (np.abs(d[..., 0]) + np.abs(d[..., 1])) + 1e-12)
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


_SEGMENT_BLOCK = 64
"""Segments of a path measured together by :meth:`ObstacleClearance.of_path`."""

_SQUARE_BLOCK = 4096
"""Obstacle squares per block of that measure (its arrays: segments x squares)."""


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
        integers): where :class:`~jaxga.maps.frame.MapFrame` puts them, in the middle of
        a block's part on the map."""
        return blocks_to_map(np.asarray(cells, np.float64) + 0.5, self.coarsen,
                             self.shape) - 0.5

    def _bounds(self, pts: np.ndarray) -> np.ndarray:
        """An upper bound of each point's distance to the obstacles (map cells): its
        nearest cell centre's distance to the nearest obstacle's centre, plus the way to
        that cell centre."""
        h, w = self.shape
        x = np.clip(np.round(pts[:, 0]), 0, w - 1).astype(np.int64)
        y = np.clip(np.round(pts[:, 1]), 0, h - 1).astype(np.int64)
        return self._edt[y, x] + np.hypot(pts[:, 0] - x, pts[:, 1] - y)

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
        bound = self._bounds(pts)
        best = math.inf
        # the segments in blocks: each block is measured against the boundary squares in
        # the union of its segments' boxes (each segment's box holds every square nearer
        # than its reach), so the least distance is each segment's own, exactly
        for i in range(0, len(pts) - 1, _SEGMENT_BLOCK):
            a, b = pts[i:i + _SEGMENT_BLOCK + 1][:-1], pts[i + 1:i + _SEGMENT_BLOCK + 1]
            reach = np.minimum(np.minimum(bound[i:i + len(a)], bound[i + 1:i + 1 + len(a)]),
                               best)
            lo = np.floor(np.minimum(a, b) - reach[:, None] - 1).min(axis=0)
            hi = np.ceil(np.maximum(a, b) + reach[:, None] + 1).max(axis=0)
            x0, y0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
            x1, y1 = min(int(hi[0]), w - 1), min(int(hi[1]), h - 1)
            ys, xs = np.nonzero(self._boundary[y0:y1 + 1, x0:x1 + 1])
            centres = np.stack([xs + x0, ys + y0], axis=1)
            for j in range(0, len(centres), _SQUARE_BLOCK):
                d = segments_square_distance(a, b, centres[j:j + _SQUARE_BLOCK])
                best = min(best, float(d.min()))
        return best

    def of_path_m(self, cells: np.ndarray) -> float | None:
        """:meth:`of_path` in metres; None for a map without a resolution."""
        if self.cell_size is None:
            return None
        return self.of_path(cells) * self.cell_size
