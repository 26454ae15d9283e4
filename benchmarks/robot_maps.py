"""A plan on a real robot map: the wall time a user waits, phase by phase, and the quality.

On public ROS ``map_server`` maps (``benchmarks/maps/SOURCE.md``: two 384 x 384 maps, a
500 x 500 house and a 604 x 307 depot; more with ``--map``), each with two endpoints far
apart (the ends of a double sweep of the 8-connected distance over the inflated map),
this runs what a robot user runs, each time in a fresh process, from an EMPTY cache::

    jaxga run --preset hybrid --seeds 8 --robot-radius 0.2 --start-world X,Y --goal-world X,Y

* **first run** of each map: the first map compiles everything (cold cache); a later map
  of a size class already compiled (``jaxga._runtime.size_classes``) compiles nothing;
* **warm run**: the same command again (fresh process, warm cache);
* **quality**: success of 8 seeds, median gap of the post-optimised lengths over the
  exact any-angle optimum (computed here without a budget; its time is reported);
* **re-plan** on the first 384 x 384 map: ``jaxga replan --robot-radius 0.2`` with a new
  obstacle on the path given in metres (warm CLI call, fresh process), and the Python
  API's third call in one process; the new path's clearance from the new obstacle.

Wall = process start to exit (``subprocess.run``), every phase included; the phases are
the run's own time line (its JSON). Targets (2-core machine): warm <= 3 s; a second map of
one size class <= 3 s with nothing compiled; empty cache <= 60 s; 8/8 success and a median
gap <= 2 %; replan warm CLI <= 3 s, in-process third call <= 100 ms.

    python benchmarks/robot_maps.py [--map NAME=FILE.yaml[:K]] [--no-write]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import markdown_table, record

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MAPS = {
    "tb3_world": (HERE / "maps" / "tb3_world" / "map.yaml", 1),
    "bookstore": (HERE / "maps" / "bookstore" / "map.yaml", 1),
    "small_house": (HERE / "maps" / "small_house" / "map.yaml", 1),
    "depot": (HERE / "maps" / "depot" / "depot.yaml", 1),
}
RADIUS = 0.2
SEEDS = 8
PHASES = ("import", "load", "references", "compile", "init", "evolve", "post", "any_angle",
          "write")


def far_endpoints(path: Path, coarsen: int) -> tuple[tuple[float, float], tuple[float, float]]:
    """Two free points far apart (metres): a double sweep of the exact 8-connected distance
    in the largest region of the inflated planning grid, from its first free cell."""
    from scipy import ndimage

    from jaxga.maps import load_map_info
    from jaxga.reference.optima import OctileGraph

    info = load_map_info(path, robot_radius=RADIUS, coarsen=coarsen)
    b = info.grid.blocked_np()
    labels, _ = ndimage.label(~b)
    biggest = np.argmax(np.bincount(labels.ravel())[1:]) + 1
    ys, xs = np.nonzero(labels == biggest)
    graph = OctileGraph(b, "strict")
    end = (int(xs[0]), int(ys[0]))
    for _ in range(2):
        d = graph.distances(end)
        d[~np.isfinite(d)] = -1
        y, x = np.unravel_index(np.argmax(d), d.shape)
        start, end = end, (int(x), int(y))
    world = info.frame.to_world(np.array([start, end], float)).round(3)
    return tuple(world[0]), tuple(world[1])


def cli(args: list[str], cache: Path) -> tuple[float, subprocess.CompletedProcess]:
    """``jaxga <args>`` in a fresh process with the cache ``cache``; (wall s, process)."""
    env = dict(os.environ, JAXGA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "jaxga.cli", *args], env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"jaxga {' '.join(args)}: {proc.stderr[-2000:]}")
    return wall, proc


def xy(p: tuple[float, float]) -> str:
    return f"{p[0]:g},{p[1]:g}"


def exact_optimum(path: Path, coarsen: int, start, goal) -> tuple[float, float, float]:
    """(exact any-angle optimum, its Euclidean lower bound, seconds) without a budget."""
    from jaxga._runtime.references import any_angle_references, octile_optimum
    from jaxga.maps import load_map_info

    grid = load_map_info(path, robot_radius=RADIUS, coarsen=coarsen, start_world=start,
                         goal_world=goal).grid
    t0 = time.perf_counter()
    bounds = any_angle_references(grid, octile_optimum(grid), None)
    return bounds.optimum, bounds.lower_bound, time.perf_counter() - t0


def replan_case(name: str, path: Path, run_json: Path, cache: Path, tmp: Path) -> dict:
    """``jaxga replan`` on ``run_json``'s best post-optimised path (the one the robot
    drives): the robot a quarter along the cells it crosses, a new obstacle (a point in
    metres) 30 % along them; the first call (which may compile), a
    warm CLI call and the Python API's calls 1-3 in one process."""
    from jaxga.maps import load_map_info
    from jaxga.reference.optima import line_walk
    from jaxga.replan import replan

    doc = json.loads(run_json.read_text())
    best = min((r for r in doc["runs"] if r["success"]), key=lambda r: r["length"])
    waypoints = [tuple(c) for c in best["path"]]  # what the robot drives (--path-out)
    cells = [waypoints[0]] + [c for a, b in zip(waypoints[:-1], waypoints[1:])
                              for c, _ in line_walk(a, b)]
    frame_info = load_map_info(path, robot_radius=RADIUS)
    frame = frame_info.frame
    robot = cells[len(cells) // 4]
    obstacle = cells[int(len(cells) * 0.3)]
    robot_w, obstacle_w = frame.to_world(np.array([robot, obstacle], float))
    args = ["replan", "--map", str(path), "--robot-radius", str(RADIUS), "--path-json",
            str(run_json), "--position-world", xy(robot_w), "--obstacles-world",
            xy(obstacle_w), "--json", str(tmp / f"{name}-replan.json")]
    first, _ = cli(args, cache)
    warm, _ = cli(args, cache)
    out = json.loads((tmp / f"{name}-replan.json").read_text())
    radius_cells = RADIUS / frame.cell_size
    new = np.asarray(out["path"], float)
    clearance = float(np.min(np.hypot(*(new - np.asarray(obstacle, float)).T)))
    grid = frame_info.grid
    lat = []
    for call in range(3):
        r = replan(grid, waypoints, [tuple(obstacle)], tuple(robot),
                   seeds=list(range(4 * call, 4 * call + 4)), inflate=radius_cells)
        lat.append(r.wall_s)
    return {"first": first, "warm": warm, "api": lat, "success": out["success"],
            "clearance": clearance, "radius": radius_cells, "window": out["segments"][0]
            ["window"] if out["segments"] else None}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--map", action="append", default=[], metavar="NAME=FILE.yaml[:K]",
                    help="another map (coarsened K x K)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    maps = dict(MAPS)
    for spec in args.map:
        name, rest = spec.split("=", 1)
        file, _, k = rest.partition(":")
        maps[name] = (Path(file), int(k or 1))
    rows, phase_rows, classes = [], [], set()
    replan_row = None
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        cache = tmp / "cache"
        for name, (path, k) in maps.items():
            start, goal = far_endpoints(path, k)
            out = tmp / f"{name}.json"
            cmd = ["run", "--preset", "hybrid", "--map", str(path), "--seeds", str(SEEDS),
                   "--robot-radius", str(RADIUS), "--start-world", xy(start),
                   "--goal-world", xy(goal), "--quiet", "--json", str(out)]
            if k > 1:
                cmd += ["--coarsen", str(k)]
            first, _ = cli(cmd, cache)
            first_doc = json.loads(out.read_text())
            warm, proc = cli(cmd, cache)
            doc = json.loads(out.read_text())
            shape = doc["frame"]["map_shape"]
            from jaxga._runtime.size_classes import class_shape

            cells = (-(-shape[0] // k), -(-shape[1] // k))
            cls = class_shape(*cells)
            seen = cls in classes
            classes.add(cls)
            optimum, bound, exact_s = exact_optimum(path, k, start, goal)
            ok = [r for r in doc["runs"] if r["success"]]
            gaps = [100 * (r["length"] / optimum - 1) for r in ok]
            rows.append([
                name, f"{cells[1]} x {cells[0]}", f"{cls[1]} x {cls[0]}" if cls else "-",
                f"({start[0]:g}, {start[1]:g}) -> ({goal[0]:g}, {goal[1]:g})",
                f"{first:.1f}" + (" (class seen)" if seen else " (compiles)"),
                f"{first_doc['timing'].get('compile_s', 0):.2f}", f"{warm:.2f}",
                f"{len(ok)}/{SEEDS}", f"{statistics.median(gaps):.3f}" if gaps else "-",
                f"{100 * (optimum / bound - 1):.3f}" if math.isfinite(bound) else "-",
                f"{exact_s:.1f}", doc["gap_basis"],
            ])
            t = doc["timing"]
            phase_rows.append([name, *(f"{t.get(p + '_s', 0.0):.2f}" for p in PHASES),
                               f"{t['total_s']:.2f}", f"{warm:.2f}"])
            print(rows[-1], phase_rows[-1], flush=True)
            if replan_row is None and cells == (384, 384):
                rp = replan_case(name, path, out, cache, tmp)
                replan_row = [name, f"{rp['first']:.1f}", f"{rp['warm']:.2f}",
                              ", ".join(f"{1000 * s:.0f}" for s in rp["api"]),
                              str(rp["window"]), "yes" if rp["success"] else "no",
                              f"{rp['clearance']:.2f} > {rp['radius']:.1f}"]
                print(replan_row, flush=True)
    body = (
        f"`jaxga run --preset hybrid --seeds {SEEDS} --robot-radius {RADIUS}` with endpoints "
        "far apart (metres), each call a fresh process, from an empty cache; wall = process "
        "start to exit. first run: the first map compiles every program; a map whose size "
        "class was compiled before compiles nothing ('class seen'). compile s (first) = "
        "the first run's compile phase. gap = median over the 8 seeds of the post-"
        "optimised length / exact any-angle optimum - 1 (the exact optimum computed here "
        "without a budget, in 'exact s'); bound slack = exact optimum / Euclidean lower "
        "bound - 1; gap basis = what the run itself reported its gap against within its "
        "default budget. Maps: benchmarks/maps/SOURCE.md.\n\n"
        + markdown_table(["map", "cells", "class", "endpoints (m)", "first run s",
                          "compile s (first)", "warm s", "success", "gap %",
                          "bound slack %", "exact s", "gap basis"], rows)
        + "\n\n**Phases of the warm run** (seconds, the run's JSON time line; wall = measured "
        "outside the process)\n\n"
        + markdown_table(["map", *PHASES, "total", "wall"], phase_rows)
    )
    if replan_row is not None:
        body += ("\n\n**Re-planning** (`jaxga replan --robot-radius 0.2` on the run's "
                 "best post-optimised path: the robot a quarter along it, a new obstacle "
                 "given in metres 30 % along it; the window is chosen automatically). "
                 "first / warm = CLI wall s (fresh processes); API ms = the Python API's "
                 "calls 1-3 in one process (wall of jaxga.replan); clearance = the new "
                 "path's least distance (cells) from the new obstacle's cell against the "
                 "inflation radius.\n\n"
                 + markdown_table(["map", "first s", "warm s", "API ms (calls 1-3)",
                                   "window", "success", "clearance"], [replan_row]))
    record("a plan on a real robot map (benchmarks/robot_maps.py)", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
