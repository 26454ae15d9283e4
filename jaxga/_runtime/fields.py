"""The host-side fields a configuration's programs read with the grid: the exact distance
fields of the operators that steer by them, and a front's clearance fields (decision 045).
"""

from __future__ import annotations

import math

import numpy as np

from jaxga._runtime.references import maximin_reference
from jaxga.config.schema import Config
from jaxga.core.grid import Grid
from jaxga.engine.checks import uses_front_fields, uses_guide
from jaxga.maps.frame import MapFrame
from jaxga.operators.guide import with_front_fields, with_guide
from jaxga.operators.init import CLEARANCE_WEIGHTS

__all__ = ["front_band", "front_obstacles", "measures_own_obstacles", "program_fields"]


def measures_own_obstacles(frame: MapFrame | None) -> bool:
    """Whether a front's clearance on ``frame`` is measured from the map's own obstacles
    before inflation (a map loaded without coarsening), not from the grid's blocked
    cells (:func:`front_obstacles`)."""
    return frame is not None and frame.obstacles is not None and frame.coarsen == 1


def front_obstacles(frame: MapFrame | None, grid: Grid) -> np.ndarray | None:
    """What a front's clearance is measured from: the map's own obstacles before
    inflation (``frame.obstacles``, what :meth:`jaxga.api.Result.obstacle_clearance`
    and the baseline measure to) where they lie in the grid's cells (a map loaded
    without coarsening: :func:`measures_own_obstacles`), else None: the grid's blocked
    cells."""
    if not measures_own_obstacles(frame) or frame.obstacles.shape != grid.shape:
        return None
    return frame.obstacles


def front_band(grid: Grid, config: Config, obstacles: np.ndarray | None = None) -> float:
    """The band (cells) of a front's clearance-weighted fields and intrusion objective:
    ``survival.band``, or where it is 0 or left out the problem's exact maximin clearance
    (:func:`jaxga.reference.maximin.maximin_path`: the widest any path can keep, so the
    heaviest field's walks approach the widest path); 1 where the goal is unreachable,
    ``H + W`` on a map without obstacles."""
    band = float(config.get("survival.band", 0.0))
    if band > 0:
        return band
    widest = maximin_reference(grid, obstacles)
    if not widest.found or widest.clearance <= 0:
        return 1.0
    return widest.clearance if math.isfinite(widest.clearance) else float(grid.height
                                                                           + grid.width)


def program_fields(grid: Grid, config: Config, obstacles: np.ndarray | None = None) -> Grid:
    """``grid`` with what ``config``'s programs read attached: a front's fields
    (:func:`jaxga.operators.guide.with_front_fields`, ``init.clearance_weights`` and
    :func:`front_band`, the clearance from ``obstacles``: :func:`front_obstacles`), else
    the exact distance fields where an operator steers by them
    (:func:`jaxga.operators.guide.with_guide`), else ``grid`` itself."""
    if uses_front_fields(config):
        weights = tuple(config.get("init.clearance_weights", CLEARANCE_WEIGHTS))
        return with_front_fields(grid, weights, front_band(grid, config, obstacles),
                                 obstacles)
    return with_guide(grid) if uses_guide(config) else grid
