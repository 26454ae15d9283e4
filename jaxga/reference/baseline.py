"""The deterministic baseline a front of length against clearance is judged by: the two
ends an exact planner gives without any search over the trade-off.

* **shortest**: the any-angle optimum (:func:`jaxga.reference.any_angle.any_angle_shortest_path`),
  which is the shortest path with the best possible shortcut;
* **widest**: the exact widest path (:func:`jaxga.reference.maximin.maximin_path`),
  shortcut greedily (from each vertex to the farthest later one in sight) without
  letting any segment come closer to the obstacles than the widest path itself does.

Each point is measured the same way as a front's paths are reported: Euclidean length
through the cell centres, the exact clearance of the polyline from the obstacle squares
(:class:`jaxga.maps.clearance.ObstacleClearance`), the total and the largest turn. Host
code (NumPy), independent of the JAX side.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from jaxga.core.grid import Grid
from jaxga.maps.clearance import ObstacleClearance
from jaxga.reference.any_angle import any_angle_shortest_path
from jaxga.reference.maximin import maximin_path
from jaxga.reference.optima import clear_np, path_length

__all__ = ["BaselinePoint", "baseline", "measure", "turning", "widest_shortcut"]


@dataclasses.dataclass(frozen=True, eq=False)
class BaselinePoint:
    """One deterministic plan and its objectives (cells and radians).

    Attributes:
        name: ``"shortest"`` or ``"widest"``.
        path: ``int32[k, 2]`` ``(x, y)`` cells from start to goal, each segment clear.
        length: Euclidean length in cells.
        clearance: the polyline's exact clearance from the obstacle squares, in cells.
        turning: the sum of its turn angles, radians.
        max_turn: its largest turn, radians.
    """

    name: str
    path: np.ndarray
    length: float
    clearance: float
    turning: float
    max_turn: float


def turning(path: np.ndarray) -> tuple[float, float]:
    """``(total, largest)`` turn of an ``int[k, 2]`` path in radians: the angle between
    each segment and the next, ``atan2(|cross|, dot)`` (0 straight on)."""
    p = np.asarray(path, np.float64)
    seg = np.diff(p, axis=0)
    seg = seg[np.any(seg != 0, axis=1)]
    if len(seg) < 2:
        return 0.0, 0.0
    a, b = seg[:-1], seg[1:]
    angles = np.arctan2(np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]),
                        np.sum(a * b, axis=1))
    return float(angles.sum()), float(angles.max())


def measure(name: str, path: np.ndarray, clearance: ObstacleClearance) -> BaselinePoint:
    """The :class:`BaselinePoint` of ``path`` (its objectives measured)."""
    total, largest = turning(path)
    return BaselinePoint(name, np.asarray(path, np.int32), path_length(path),
                         clearance.of_path(path), total, largest)


def widest_shortcut(blocked: np.ndarray, corner_rule: str, path: np.ndarray,
                    clearance: ObstacleClearance) -> np.ndarray:
    """``path`` shortcut greedily: from each kept vertex, the farthest later vertex whose
    segment is clear (:func:`jaxga.reference.optima.clear_np`) and keeps at least the
    whole path's clearance, so the result is no longer and no narrower."""
    path = np.asarray(path, np.int32)
    keep = clearance.of_path(path)
    out, i = [path[0]], 0
    while i < len(path) - 1:
        j = len(path) - 1
        while j > i + 1 and not (
                clear_np(blocked, corner_rule, path[i], path[j])
                and clearance.of_path(path[[i, j]]) >= keep):
            j -= 1
        out.append(path[j])
        i = j
    return np.array(out, np.int32)


def baseline(grid: Grid, obstacles: np.ndarray | None = None) -> list[BaselinePoint]:
    """The shortest and the widest ends (module docstring) of ``grid``'s problem, each
    measured; an empty list where the goal is unreachable or an endpoint blocked. The
    clearances are to ``obstacles`` (``bool[H, W]`` in the grid's cells: a map's own
    obstacles before inflation), by default the grid's blocked cells."""
    blocked = grid.blocked_np()
    clearance = ObstacleClearance(blocked if obstacles is None else obstacles)
    shortest = any_angle_shortest_path(grid)
    widest = maximin_path(grid, obstacles=obstacles)
    if not (shortest.found and widest.found):
        return []
    short_cut = widest_shortcut(blocked, grid.corner_rule, widest.path, clearance)
    return [measure("shortest", shortest.path, clearance),
            measure("widest", short_cut, clearance)]
