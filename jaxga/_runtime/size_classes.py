"""Map-size classes: maps padded with blocked cells so that maps of one class share programs.

A compiled program is specialised to the map's shape and the path capacity (decision 029).
With ``size_class=True`` (:func:`jaxga.run`, ``--size-class``) a map of up to
:data:`MAX_CLASS_SIDE` cells a side is padded, on its top and right, to its class
(:func:`class_shape`: each side rounded up to one of :data:`CLASS_SIDES`), and its path
capacity is raised to the class's (:func:`class_capacity`), so that a 20 x 20 and a
25 x 25 map run the same programs, and one warm-up of the class (``jaxga warmup
--size-class``) serves every map in it. By default (``size_class=None``) the maps with
a side over :data:`AUTO_MIN_SIDE` are padded (users' robot maps: two 384 x 384 maps run
one program set) and the smaller ones, the papers' maps among them, keep their shape
(decision 030).

The padding keeps every cell's ``(x, y)``: the map is the bottom-left corner of the
padded one. Padding cells are blocked (no path enters them) and marked as off the map
(``Grid.outside``), so that the safety and clearance measures count them as they count
the map's edge (:func:`jaxga.core.grid.proximity_obstacles`). Results are reported on
the map itself: :func:`map_cells` turns the padded cell indices back into the map's.

What the padding changes: a cell index is ``y * W + x`` with the padded width inside the
run, and operators whose draws or work limits depend on the map's shape (IMGA's and
MPMGA's connection queues, MPMGA's anchor rows, Zhu's mutation radius and column
crossover) and the path capacity (a small map's own can be below its class's) size their
arrays by it. Such runs are other runs of the same method: they differ seed by seed from
the unpadded ones, not in feasibility, success or the lengths' distribution
(``benchmarks/size_classes.py``). The other presets' padded runs equal the unpadded ones
seed for seed when the capacity is the same (``tests/api/test_programs.py``; decision 029).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from jaxga.core.dtypes import on_device
from jaxga.core.grid import Grid
from jaxga.engine.algorithm import CAPACITY_FACTOR, capacity_class, default_capacity
from jaxga.operators.guide import padded_guide

CLASS_SIDES: tuple[int, ...] = (32, 64, 128, 256, 384, 512, 768, 1024, 1536, 2048)
"""A padded side is the smallest of these holding the map's side (each side on its own:
a 604 x 307 map is in the 768 x 384 class)."""

MAX_CLASS_SIDE = CLASS_SIDES[-1]
"""The largest class side; every map jaxga plans on (at most
:data:`jaxga.core.grid.MAX_MAP_CELLS` cells, so no side over 2048 unless the other is
under 2048) has a class but a very long and thin one."""

AUTO_MIN_SIDE = 64
"""``size_class=None`` (the default) pads maps with a side over this: users' maps, whose
compilation (tens of seconds) would otherwise dominate a run that takes a second. The
papers' maps (20 x 20, 50 x 50) keep their published shapes, so that their tables
reproduce (decision 030)."""

CAPACITY_PER_SIDE = 5
"""A class's path capacity is this many times its longer side (160 cells for the 32
class: the papers' 20 x 20 maps have 160; 320 for the 64 class: what a random 64 x 64
map's 3 x optimal path needs). A problem needing more gets its own capacity."""


def auto_size_class(grid: Grid) -> bool:
    """Whether ``size_class=None`` pads ``grid``: a side over :data:`AUTO_MIN_SIDE`."""
    return max(grid.height, grid.width) > AUTO_MIN_SIDE


def class_shape(height: int, width: int) -> tuple[int, int] | None:
    """``(H, W)`` of the size class of an ``height x width`` map, or None when a side is
    over :data:`MAX_CLASS_SIDE` (such maps keep their shape)."""
    if max(height, width) > MAX_CLASS_SIDE:
        return None
    return (next(s for s in CLASS_SIDES if s >= height),
            next(s for s in CLASS_SIDES if s >= width))


def class_capacity(grid: Grid, factor: float = CAPACITY_FACTOR) -> int:
    """The path capacity of ``grid``'s problem in its size class: the class's
    (:data:`CAPACITY_PER_SIDE` times its longer side, scaled by ``factor`` /
    :data:`~jaxga.engine.algorithm.CAPACITY_FACTOR`: ``population.capacity_factor``), or
    the problem's own (:func:`jaxga.engine.algorithm.default_capacity`) when that is
    larger."""
    shape = class_shape(grid.height, grid.width)
    own = default_capacity(grid, factor)
    if shape is None:
        return own
    scaled = math.ceil(CAPACITY_PER_SIDE * max(shape) * factor / CAPACITY_FACTOR)
    return max(own, capacity_class(scaled))


def pad_to_class(grid: Grid) -> Grid:
    """``grid`` padded with blocked cells on its top and right to its size class
    (:func:`class_shape`), the padding marked in ``Grid.outside``; the endpoints keep
    their ``(x, y)``. A map already of a class shape gets an all-False ``outside`` (so
    that it runs the class's programs); a map over :data:`MAX_CLASS_SIDE` is returned
    unchanged. Distance fields attached to ``grid`` are padded with infinity (the padding
    is blocked: no cell of it is reachable), the same fields the padded grid's own
    computation gives; its tables are dropped (they belong to its shape)."""
    shape = class_shape(grid.height, grid.width)
    if shape is None:
        return grid
    pad = ((0, shape[0] - grid.height), (0, shape[1] - grid.width))
    blocked = np.pad(grid.blocked_np(), pad, constant_values=True)
    outside = np.pad(np.zeros(grid.shape, bool), pad, constant_values=True)
    (sx, sy), (gx, gy) = grid.start_xy, grid.goal_xy
    guide = None if grid.guide is None else padded_guide(grid.guide, grid.shape, pad)
    return dataclasses.replace(
        grid, blocked=on_device(blocked), outside=on_device(outside),
        start=on_device(sy * shape[1] + sx, np.int32),
        goal=on_device(gy * shape[1] + gx, np.int32),
        guide=guide, tables=None)


def map_cells(cells: np.ndarray, padded_width: int, width: int) -> np.ndarray:
    """Cell indices of a padded map (``y * padded_width + x``) as the map's own
    (``y * width + x``, as :func:`jaxga.core.grid.index_to_xy` then ``xy_to_index``, on
    the host: in NumPy, so that a fresh process compiles nothing for it); the same array
    when the widths agree."""
    cells = np.asarray(cells)
    if padded_width == width:
        return cells
    y, x = np.divmod(cells, cells.dtype.type(padded_width))
    return y * cells.dtype.type(width) + x
