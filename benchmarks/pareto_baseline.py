"""What a front of length against clearance must beat on real robot maps: the exact ends and
the deterministic baseline (decision 045).

On the four public ROS ``map_server`` maps of ``benchmarks/robot_maps.py`` (a 0.2 m robot;
its far-apart endpoints, each moved to the freest cell within a metre: the far ends of a
region lie against its walls, and a path's least clearance could then be no more than
its endpoints' own, the same for every path), for each map:

* **exact ends**: the any-angle optimum (the shortest end's reference) and the exact
  maximin clearance (the widest end's reference: the largest least-clearance of an
  8-connected path, to the map's own obstacles, on the inflated planning grid:
  :func:`jaxga.reference.maximin.maximin_path`);
* **baseline**: the shortest end (the any-angle optimum's path) and the widest end (the
  widest path shortcut without narrowing it: :func:`jaxga.reference.baseline.baseline`),
  each measured as a front's paths will be: length, the polyline's exact clearance to the
  map's own obstacles (before inflation), total turning;
* the seconds each reference takes on the host.

    python benchmarks/pareto_baseline.py [--map NAME] [--no-write]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _results import markdown_table, record
from robot_maps import MAPS, RADIUS, far_endpoints

TITLE = "fronts of length against clearance: exact ends and the deterministic baseline"


OPEN_RADIUS_M = 1.0
"""How far (metres) an endpoint may move towards open space."""


def freest_near(blocked: np.ndarray, clearance: np.ndarray, xy: tuple[int, int],
                radius: float) -> tuple[int, int]:
    """The free cell of greatest clearance within ``radius`` cells of ``xy`` (ties: the
    nearest, then the lowest row and column)."""
    h, w = blocked.shape
    ys, xs = np.mgrid[0:h, 0:w]
    d = np.hypot(xs - xy[0], ys - xy[1])
    ok = (d <= radius) & ~blocked
    order = np.lexsort((xs[ok], ys[ok], d[ok], -clearance[ok]))
    return int(xs[ok][order[0]]), int(ys[ok][order[0]])


def problem(name: str):
    """Map ``name``'s inflated grid with the benchmark's endpoints (module docstring), its
    frame, and the map as loaded with that grid (its layers and name, for a plot)."""
    import dataclasses

    from jaxga.maps import load_map_info
    from jaxga.maps.clearance import cell_clearance

    path, coarsen = MAPS[name]
    start, goal = far_endpoints(path, coarsen)
    info = load_map_info(path, robot_radius=RADIUS, coarsen=coarsen, start_world=start,
                         goal_world=goal)
    grid, frame = info.grid, info.frame
    field = cell_clearance(frame.obstacles)
    reach = OPEN_RADIUS_M / frame.cell_size
    ends = [freest_near(grid.blocked_np(), field, xy, reach)
            for xy in (grid.start_xy, grid.goal_xy)]
    grid = grid.replace(start=ends[0], goal=ends[1])
    return grid, frame, dataclasses.replace(info, grid=grid)


def measure_map(name: str) -> list:
    """One table row for map ``name``."""
    from jaxga.reference.any_angle import any_angle_shortest_path
    from jaxga.reference.baseline import baseline
    from jaxga.reference.maximin import maximin_path

    grid, frame, _ = problem(name)
    if frame.coarsen != 1:
        raise SystemExit(f"{name}: coarsened maps are not measured (clearances in map cells)")
    m = frame.cell_size
    t0 = time.perf_counter()
    optimum = any_angle_shortest_path(grid)
    t1 = time.perf_counter()
    widest = maximin_path(grid, obstacles=frame.obstacles)
    t2 = time.perf_counter()
    shortest_end, widest_end = baseline(grid, obstacles=frame.obstacles)
    t3 = time.perf_counter()
    return [
        name, f"{grid.width} x {grid.height}", f"{grid.start_xy} -> {grid.goal_xy}",
        f"{optimum.length * m:.3f}", f"{widest.clearance * m:.3f}",
        f"{shortest_end.length * m:.3f}", f"{shortest_end.clearance * m:.3f}",
        f"{shortest_end.turning:.2f}",
        f"{widest_end.length * m:.3f} (+{100 * (widest_end.length / optimum.length - 1):.1f} %)",
        f"{widest_end.clearance * m:.3f}", f"{widest_end.turning:.2f}",
        f"{t1 - t0:.2f} / {t2 - t1:.2f} / {t3 - t2:.2f}",
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--map", action="append", choices=sorted(MAPS),
                    help="measure only this map (repeatable); default all four")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows = [measure_map(name) for name in (args.map or list(MAPS))]
    headers = ["map", "cells", "endpoints (cells)", "any-angle optimum m", "maximin clearance m",
               "shortest end m", "its clearance m", "its turning rad", "widest end m",
               "its clearance m", "its turning rad", "s (any-angle / maximin / baseline)"]
    body = (f"A {RADIUS} m robot, the endpoints of `benchmarks/robot_maps.py`; clearances to "
            "the map's own obstacles (before inflation), lengths through the cell centres; "
            "the maximin clearance is exact over 8-connected paths on the inflated grid, the "
            "ends' clearances exact for their polylines. A front's shortest end is to be "
            "within 2 % of the any-angle optimum and its widest end at 95 % of the maximin "
            "clearance or more.\n\n" + markdown_table(headers, rows))
    record(TITLE, body, write=not args.no_write)


if __name__ == "__main__":
    np.set_printoptions(precision=4)
    main()
