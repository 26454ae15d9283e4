"""Where the planning grid lies: its cells against the map file's cells and the world frame.

A map is planned on as loaded, or coarsened (``--coarsen K``: ``K x K`` cells of the file
merged into one). Three frames describe the same point:

* **planning cells**: the cells of the grid the GA runs on, ``(x, y)`` with ``y = 0`` the
  bottom row (every :class:`~jaxga.api.result.Result` path is in these);
* **map cells**: the map file's own cells, the same as the planning cells unless
  coarsened; a planning cell ``(x, y)`` is the block of map cells ``[xK, xK + K) x [yK,
  yK + K)`` and is named by the map cell holding its centre (:meth:`MapFrame.map_cell`);
* **metres** (a ROS ``map_server`` map, which has a ``resolution`` and an ``origin``): a
  planning cell is ``K x resolution`` metres a side, and the block of planning cell
  ``(0, 0)`` starts at the origin, as the map file's first cell does, so the world
  position of a point ``(x, y)`` in planning cells (centres at integer coordinates) is
  ``origin + R(yaw) ((x + 1/2, y + 1/2) K resolution)`` (REP 103 and ``map_server``'s
  origin: the lower-left corner of the lower-left cell). A last row or column of blocks
  that reaches past the map stands for its part on the map: its positions are drawn on
  that part (:meth:`MapFrame.local_metres`), so that no point of a path lies off the map.

Every length in planning cells times :attr:`MapFrame.cell_size` is metres: a coarsened
map's lengths are not K times too short.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np

from jaxga.core.equality import ValueEquality
from jaxga.core.errors import EndpointError
from jaxga.core.grid import check_xy
from jaxga.maps.clearance import ObstacleClearance
from jaxga.maps.preprocess import block_middle_cells, blocks_to_map, map_to_blocks

__all__ = ["MapFrame", "cells_crossed", "endpoint_cells", "world_decimals"]


def world_decimals(step: float | None) -> int:
    """Decimals that write coordinates ``step`` metres apart to a hundredth of ``step`` or
    finer: 4 for steps of a centimetre and more (a 0.05 m map's cell centres), more for
    finer ones (a 10 um map's points, written to 4 decimals, collapsed onto each other),
    at most 15 (float64's digits)."""
    if step is None or not math.isfinite(step) or step <= 0:
        return 4
    return min(15, max(4, 2 - math.floor(math.log10(step))))


@dataclasses.dataclass(frozen=True, eq=False)
class MapFrame(ValueEquality):
    """How planning cells relate to the map file's cells and to metres.

    Attributes:
        map_shape: ``(H, W)`` of the map file, in its own cells.
        coarsen: ``K``, map cells a side per planning cell (1: not coarsened).
        resolution: metres per MAP cell (a ROS map's ``resolution``), None without one.
        origin: ``(x, y, yaw)`` of a ROS map, metres and radians; None without one.
        obstacles: ``bool[H, W]`` (map cells): the map's own obstacles, before any
            inflation, or None where not known (a frame built by hand); what
            :attr:`clearance` measures to.
        robot_radius: the robot's radius the map was inflated by (metres), or None.
    """

    map_shape: tuple[int, int]
    coarsen: int = 1
    resolution: float | None = None
    origin: tuple[float, float, float] | None = None
    obstacles: np.ndarray | None = dataclasses.field(default=None, compare=False, repr=False)
    robot_radius: float | None = None

    @functools.cached_property
    def clearance(self) -> ObstacleClearance | None:
        """The exact clearance of paths from :attr:`obstacles`
        (:class:`jaxga.maps.clearance.ObstacleClearance`, its distance transform computed
        once per frame, so once per loaded map), or None without obstacles."""
        if self.obstacles is None:
            return None
        return ObstacleClearance(self.obstacles, self.coarsen, self.resolution)

    @property
    def has_metres(self) -> bool:
        """Whether the frame knows metres (a ROS map)."""
        return self.resolution is not None and self.origin is not None

    @property
    def cell_size(self) -> float | None:
        """Metres per PLANNING cell (``coarsen * resolution``), None without a resolution."""
        return None if self.resolution is None else self.coarsen * self.resolution

    def metres(self, length: float | np.ndarray) -> float | np.ndarray | None:
        """A length (or array of lengths) in planning cells, in metres; None without a
        resolution."""
        size = self.cell_size
        if size is None:
            return None
        return np.asarray(length, float) * size if np.ndim(length) else float(length) * size

    @property
    def world_decimals(self) -> int:
        """Decimals that write a point in metres to a hundredth of a planning cell or
        finer (:func:`world_decimals`): 4 on maps of centimetre cells and coarser."""
        return world_decimals(self.cell_size)

    def world_list(self, points: np.ndarray) -> list:
        """:meth:`to_world` as nested lists rounded to :attr:`world_decimals` (the JSON
        outputs' ``path_world`` and endpoints)."""
        return self.to_world(points).round(self.world_decimals).tolist()

    def to_world(self, points: np.ndarray) -> np.ndarray:
        """``float[..., 2]`` world coordinates (metres) of points in planning cells (cell
        centres at integer coordinates). Needs a frame with metres."""
        if not self.has_metres:
            raise ValueError("this map has no resolution and origin: no world frame")
        p = self.local_metres(points)
        c, s = math.cos(self.origin[2]), math.sin(self.origin[2])
        x = self.origin[0] + c * p[..., 0] - s * p[..., 1]
        y = self.origin[1] + s * p[..., 0] + c * p[..., 1]
        return np.stack([x, y], axis=-1)

    def local_metres(self, points: np.ndarray) -> np.ndarray:
        """``float[..., 2]``: points in planning cells (centres at integers) in metres along
        the map's own axes from its origin (before its yaw): ``K`` map cells a planning
        cell, except in a last block that reaches past the map, which stands for its part
        on the map (:func:`jaxga.maps.preprocess.blocks_to_map`)."""
        return blocks_to_map(np.asarray(points, float) + 0.5, self.coarsen, self.map_shape,
                             self.resolution)

    def _local(self, point: tuple[float, float]) -> tuple[float, float]:
        """``point`` (metres) along the map's own axes, from its origin (metres)."""
        c, s = math.cos(self.origin[2]), math.sin(self.origin[2])
        dx, dy = point[0] - self.origin[0], point[1] - self.origin[1]
        return c * dx + s * dy, -s * dx + c * dy

    def cell_coordinates(self, point: tuple[float, float]) -> tuple[float, float]:
        """World point ``point`` (metres) in planning cells, not rounded: planning cell
        ``(x, y)`` covers ``[x, x + 1) x [y, y + 1)`` (its centre at ``x + 0.5``), so
        :meth:`cell_of` is the floor of this (the inverse of :meth:`to_world`, whose
        centres are at ``x + 0.5`` here). A point on a cell's edge counts in the cell above
        it, to within what float64 can tell at the point's distance from 0
        (:meth:`edge_tolerance`: a point written to two decimals on a map whose origin
        lies 4,000 km out falls on the edge's wrong side by 1e-8 of a cell)."""
        return self._cells(self._local(point), self.edge_tolerance(point))

    def _cells(self, local: tuple[float, float], tol: float) -> tuple[float, float]:
        """:meth:`cell_coordinates` of a point already in metres along the map's axes
        (:meth:`_local`), with its :meth:`edge_tolerance`."""
        if self.coarsen == 1:
            return tuple(v / self.cell_size + tol for v in local)
        blocks = map_to_blocks(np.asarray(local, float) / self.resolution, self.coarsen,
                               self.map_shape)
        return tuple(float(v) + tol for v in blocks)

    def edge_tolerance(self, point: tuple[float, float]) -> float:
        """How far (in planning cells) a world point may lie below a cell's edge and still
        count on it: 1e-9 of a cell (edges' coordinates are rounded), and more where the
        point's or the origin's distance from 0 makes float64's rounding of the metres
        larger: 8 units in the last place of the largest coordinate (the rounding of the
        origin, the point and their difference is about 2), at most 2e-4 of a map cell
        (an origin :data:`jaxga.maps.ros.MAX_ORIGIN_CELLS` cells out)."""
        coords = [abs(float(v)) for v in (*point, *(self.origin or (0.0, 0.0))[:2])]
        far = max((v for v in coords if math.isfinite(v)), default=0.0)
        return (1e-9 + 8 * np.finfo(float).eps * far / self.resolution) / self.coarsen

    def coordinate_text(self, value: float) -> str:
        """A coordinate in metres as text: to :attr:`world_decimals` and no further, with
        no trailing zeros (``512347.33``, not ``512347``, as ``:g`` wrote it; ``5``); a
        coordinate of 1e15 m or more (a typing slip) in exponent form."""
        v = float(value)
        if not abs(v) < 1e15:
            return repr(v)
        return np.format_float_positional(v + 0.0, precision=self.world_decimals,
                                          unique=True, trim="-")

    def cell_of(self, point: tuple[float, float], shape: tuple[int, int],
                what: str = "point") -> tuple[int, int]:
        """The planning cell ``(x, y)`` holding world point ``point`` (metres) on a
        planning grid of ``shape = (H, W)``; :class:`~jaxga.core.errors.EndpointError`
        naming ``what`` and the map's extent in metres when it lies off the map."""
        if not self.has_metres:
            raise EndpointError(f"{what} in metres needs a map with a resolution and an "
                                "origin (a ROS map_server .yaml)")
        local = self._local(point)
        tol = self.edge_tolerance(point)
        h, w = shape
        cells = self._cells(local, tol)
        # a point (or origin) so far away that the cell overflows is off the map too
        x, y = (int(math.floor(v)) if math.isfinite(v) else -1 for v in cells)
        # on the map's own extent too: a last block reaching past the map covers its part
        on_map = all(math.isfinite(v) and 0 <= v / self.resolution + tol * self.coarsen < n
                     for v, n in zip(local, self.map_shape[::-1]))
        if not (on_map and 0 <= x < w and 0 <= y < h):
            x0, y0, yaw = self.origin
            wide, high = self.map_shape[1] * self.resolution, self.map_shape[0] * self.resolution
            m = self.coordinate_text
            if not yaw:
                raise EndpointError(
                    f"{what} ({m(point[0])}, {m(point[1])}) m is off the map: it covers x "
                    f"{m(x0)}..{m(x0 + wide)} m, y {m(y0)}..{m(y0 + high)} m")
            # the map's rectangle is turned about its origin: its own axes show why
            raise EndpointError(
                f"{what} ({m(point[0])}, {m(point[1])}) m is off the map: along the map's own "
                f"axes (turned by its yaw, {yaw:g} rad, about its origin ({m(x0)}, {m(y0)}) "
                f"m) the point lies at ({m(local[0])}, {m(local[1])}) m from the origin, and "
                f"the map covers 0..{m(wide)} m by 0..{m(high)} m")
        return x, y

    def map_cell(self, cells: np.ndarray) -> np.ndarray:
        """``int[..., 2]``: for planning cells ``(x, y)``, the map cell holding the
        planning cell's centre (the middle of its block; of its part on the map where a
        last block reaches past it). The identity when not coarsened."""
        c = np.asarray(cells, np.int64)
        if self.coarsen == 1:
            return c
        return block_middle_cells(c, self.coarsen, self.map_shape)

    def planning_cell(self, map_cells: np.ndarray) -> np.ndarray:
        """``int[..., 2]``: the planning cells holding map cells ``(x, y)``."""
        return np.asarray(map_cells, np.int64) // self.coarsen

    def describe(self) -> str:
        """One line for a summary: the cell size and how planning cells relate to the map."""
        parts = []
        if self.coarsen > 1:
            parts.append(f"coarsened {self.coarsen} x {self.coarsen}: a planning cell is "
                         f"{self.coarsen} x {self.coarsen} map cells")
        if self.cell_size is not None:
            parts.append(f"{self.cell_size:g} m per planning cell")
        return "; ".join(parts)

    def to_json(self) -> dict:
        """The frame as JSON: both cell frames and the world frame, so that a file is
        read without its map."""
        return {
            "coarsen": self.coarsen,
            "map_shape": list(self.map_shape),
            "resolution": self.resolution,
            "cell_size": self.cell_size,
            "origin": None if self.origin is None else list(self.origin),
            "frames": {
                "path": "planning cells (x, y), y = 0 the bottom row",
                "map_path": "map file cells (x, y) holding each planning cell's centre",
                "path_world": "metres in the map's world frame" if self.has_metres
                else None,
            },
        }


def cells_crossed(p: tuple[float, float], q: tuple[float, float]) -> list[tuple[int, int]]:
    """The cells ``(x, y)`` the segment from ``p`` to ``q`` (coordinates in cells: cell
    ``(x, y)`` covers ``[x, x + 1) x [y, y + 1)``) passes through, in order, from the cell
    holding ``p`` to the one holding ``q`` (Amanatides & Woo's walk). Consecutive cells
    share a side, except where the segment passes exactly through a grid vertex: there
    the step is diagonal. A robot's recorded path (metres) becomes the planning cells it
    drove through this way, where the chords between the cells of its points would cut
    corners it did not."""
    x, y = math.floor(p[0]), math.floor(p[1])
    end = (math.floor(q[0]), math.floor(q[1]))
    dx, dy = q[0] - p[0], q[1] - p[1]
    step_x, step_y = (1 if dx > 0 else -1), (1 if dy > 0 else -1)
    # the segment's parameter at its next vertical and horizontal grid line
    next_x = ((x + (dx > 0)) - p[0]) / dx if dx else math.inf
    next_y = ((y + (dy > 0)) - p[1]) / dy if dy else math.inf
    delta_x, delta_y = (abs(1 / dx) if dx else math.inf), (abs(1 / dy) if dy else math.inf)
    out = [(x, y)]
    for _ in range(abs(end[0] - x) + abs(end[1] - y)):
        # the segment ends at or before its next grid line: q's cell follows below (a
        # crossing at t = 1 would step past q where it lies on a line, going down or left)
        if (x, y) == end or min(next_x, next_y) >= 1.0 - 1e-12:
            break
        if abs(next_x - next_y) <= 1e-12:  # through a vertex: a diagonal step
            x, y = x + step_x, y + step_y
            next_x, next_y = next_x + delta_x, next_y + delta_y
        elif next_x < next_y:
            x += step_x
            next_x += delta_x
        else:
            y += step_y
            next_y += delta_y
        out.append((x, y))
    if out[-1] != end:  # rounding at the far end: the last cell is q's own
        out.append(end)
    return out


def endpoint_cells(frame: MapFrame | None, grid: Any, start: Any = None, goal: Any = None,
                   start_world: Any = None, goal_world: Any = None, *,
                   required: bool = True) -> tuple[tuple[int, int], tuple[int, int]]:
    """The start and goal cells ``(x, y)`` of ``grid``'s map given each once, in cells or
    in metres (``*_world``, the cell holding the point on a map with a resolution);
    without ``required`` an endpoint given neither way keeps ``grid``'s. A one-line
    :class:`EndpointError` otherwise."""
    ends = []
    for name, cell, world in (("start", start, start_world), ("goal", goal, goal_world)):
        if cell is not None and world is not None or (required and cell is None
                                                      and world is None):
            raise EndpointError(f"give the {name} once: in cells ({name}=) or in metres "
                                f"({name}_world=)")
        if world is not None:
            if frame is None or not frame.has_metres:
                raise EndpointError(f"the {name} in metres needs a map with a resolution "
                                    "and an origin (a ROS map_server .yaml)")
            cell = frame.cell_of(world_point(name, world), grid.blocked.shape,
                                 f"the {name}")
        h, w = grid.blocked.shape
        ends.append(getattr(grid, f"{name}_xy") if cell is None
                    else check_xy(name, cell, w, h))
    return ends[0], ends[1]


def world_point(name: str, point: Any) -> tuple[float, float]:
    """``point`` as two finite floats (metres), or a one-line :class:`EndpointError`:
    strings, bools and NaN are refused, not converted."""
    try:
        if isinstance(point, (str, bytes)):
            raise TypeError
        x, y = tuple(point)
        if any(isinstance(v, (bool, np.bool_, str, bytes)) for v in (x, y)):
            raise TypeError
        x, y = float(x), float(y)
    except (TypeError, ValueError):
        raise EndpointError(f"the {name} in metres must be a pair of numbers (x, y), got "
                            f"{point!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise EndpointError(f"the {name} in metres must be finite, got ({x}, {y})")
    return x, y
