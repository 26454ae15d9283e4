"""The `pareto` preset on real robot maps: fronts of length against clearance and turning,
their exact ends, the hypervolume the generations gain, and the wall time a warm second
process takes (decision 045).

On the four public ROS ``map_server`` maps of ``benchmarks/robot_maps.py`` (a 0.2 m robot,
the endpoints of ``benchmarks/pareto_baseline.py``: the far ends of each map, moved to
the freest cell within a metre), 8 seeds each, every map in a fresh process twice with
one cache of its own (the first compiles; the second is what a user waits for once the
cache is warm). Per map:

* **front**: points per run (the distinct non-dominated paths of its final population),
  and whether every front path is feasible on the inflated grid (8-connected steps
  through free cells under the map's corner rule, from the start to the goal);
* **exact ends**: the shortest end post-optimised against the exact any-angle optimum
  (median and worst gap over runs); the widest end's least clearance against the exact
  maximin clearance (the least share over runs);
* **the generations' worth**: the hypervolume of the last generation over the initial
  population's (median over runs; the reference point fixed at initialisation);
* **against the baseline**: each front path shortcut without narrowing it and
  measured as the baseline's ends are (length, exact clearance from the map's own
  obstacles): how many of a run's points neither end dominates (trade-offs the
  baseline does not offer), and how many baseline ends a front point dominates;
* **wall**: the second process, start to exit (load, fields, references, init, evolve,
  post).

Targets: >= 5 points per run and every path feasible; shortest end <= 2 % over the
any-angle optimum; widest end >= 95 % of the maximin clearance; median hypervolume ratio
>= 1.05; second process <= 10 s per map.

    python benchmarks/pareto_front.py [--map NAME] [--seeds 8] [--no-write]
    python benchmarks/pareto_front.py --figure docs/figures/pareto_small_house.png

``--figure`` draws one run of the first map given (default ``small_house``) with
:func:`jaxga.plot.plot_result` instead: its front's paths, the trade-off against the
exact ends, and the hypervolume over the generations (the docs' figure).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import markdown_table, record
from pareto_baseline import problem
from robot_maps import MAPS, RADIUS

TITLE = "pareto: fronts of length, clearance and turning on ROS maps"
ROOT = Path(__file__).resolve().parents[1]


def feasible(grid, path: list) -> bool:
    """``path`` (``(x, y)`` cells) joins the start to the goal by legal 8-connected moves
    through free cells."""
    from jaxga.reference.optima import clear_np

    blocked = grid.blocked_np()
    p = np.asarray(path)
    if tuple(p[0]) != grid.start_xy or tuple(p[-1]) != grid.goal_xy:
        return False
    steps = np.abs(np.diff(p, axis=0))
    return bool(np.all(steps.max(axis=1) == 1) and all(
        clear_np(blocked, grid.corner_rule, a, b) for a, b in zip(p[:-1], p[1:])))


def one(name: str, seeds: int) -> dict:
    """Run the preset on map ``name`` in this process; its measures as a dict."""
    t0 = time.perf_counter()
    import jaxga

    grid, frame, info = problem(name)  # the map as loaded: its frame, its own obstacles
    result = jaxga.run("pareto", info, seeds=seeds, any_angle_budget=None)
    wall = time.perf_counter() - t0
    points, ok, gaps, ratios = [], True, [], []
    for i in range(seeds):
        front = result.front_points(i)
        ends = result.front_ends(i)
        points.append(len(front))
        ok &= bool(result.success[i]) and all(feasible(grid, p["path"]) for p in front)
        gaps.append(ends["shortest_gap"])
        ratios.append(ends["widest_ratio"])
    fronts = [[p["path"] for p in result.front_points(i)] for i in range(seeds)]
    return {"points": points, "feasible": ok, "gaps": gaps, "ratios": ratios,
            "fronts": fronts,
            "hv_ratio": result.front.gain(result.history).tolist(), "wall": wall,
            "maximin_m": result.maximin_clearance * frame.cell_size,
            "any_angle_m": result.any_angle_optimum * frame.cell_size,
            "cells": f"{grid.width} x {grid.height}"}


def against_baseline(name: str, fronts: list) -> tuple[float, int, int]:
    """The fronts as a robot follows them against the deterministic baseline
    (:func:`jaxga.reference.baseline.baseline`: the any-angle optimum and the widest
    path shortcut), every path measured alike: each front path shortcut without
    narrowing it (:func:`jaxga.reference.baseline.widest_shortcut`), its length and its
    exact clearance from the map's own obstacles (before inflation). Returns the median
    per run of the front's points that neither baseline end dominates, how many of the
    baseline's ends some front point of the same run dominates, and how many ends
    there were."""
    from jaxga.maps.clearance import ObstacleClearance
    from jaxga.reference.baseline import baseline, measure, widest_shortcut

    grid, frame, _ = problem(name)
    ends = baseline(grid, obstacles=frame.obstacles)
    clearance = ObstacleClearance(frame.obstacles)
    blocked = grid.blocked_np()

    def dominates(a, b) -> bool:
        return (a.length <= b.length and a.clearance >= b.clearance
                and (a.length < b.length or a.clearance > b.clearance))

    new, beaten = [], 0
    for paths in fronts:
        points = [measure("front", widest_shortcut(blocked, grid.corner_rule,
                                                   np.asarray(p), clearance), clearance)
                  for p in paths]
        new.append(sum(not any(dominates(e, q) for e in ends) for q in points))
        beaten += sum(any(dominates(q, e) for q in points) for e in ends)
    return statistics.median(new), beaten, len(ends) * len(fronts)


def measure_map(name: str, seeds: int) -> list:
    """One table row: the map run twice in fresh processes sharing one new cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, JAXGA_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        env.pop("JAX_COMPILATION_CACHE_DIR", None)
        runs = []
        for _ in range(2):
            t0 = time.perf_counter()
            out = subprocess.run([sys.executable, __file__, "--one", name, "--seeds",
                                  str(seeds)], env=env, capture_output=True, text=True,
                                 check=True, cwd=Path(__file__).parent)
            m = json.loads(out.stdout.strip().splitlines()[-1])
            m["process"] = time.perf_counter() - t0
            runs.append(m)
    m = runs[1]
    new, beaten, total = against_baseline(name, m["fronts"])
    return [
        name, m["cells"], f"{min(m['points'])} / {statistics.median(m['points']):g}",
        "yes" if m["feasible"] else "NO",
        f"{m['any_angle_m']:.2f}",
        f"{100 * statistics.median(m['gaps']):.2f} / {100 * max(m['gaps']):.2f}",
        f"{m['maximin_m']:.3f}", f"{min(m['ratios']):.3f}",
        f"{statistics.median(m['hv_ratio']):.3f} ({min(m['hv_ratio']):.3f}-"
        f"{max(m['hv_ratio']):.3f})",
        f"{new:g}", f"{beaten} of {total}",
        f"{runs[0]['process']:.1f}", f"{m['process']:.1f}",
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--map", action="append", choices=sorted(MAPS),
                    help="measure only this map (repeatable); default all four")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--one", choices=sorted(MAPS), help=argparse.SUPPRESS)
    ap.add_argument("--figure", metavar="OUT.png", help="draw one run instead")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one(args.one, args.seeds)))
        return
    if args.figure:
        import jaxga
        from jaxga.plot import plot_result

        name = (args.map or ["small_house"])[0]
        grid, frame, info = problem(name)
        result = jaxga.run("pareto", info, seeds=args.seeds, any_angle_budget=None)
        plot_result(result, grid, args.figure, info=info)
        print(f"wrote {args.figure}")
        return
    rows = [measure_map(name, args.seeds) for name in (args.map or list(MAPS))]
    headers = ["map", "cells", "front points min / median", "all feasible",
               "any-angle optimum m", "shortest end gap % median / worst",
               "maximin clearance m", "widest end / maximin (least)",
               "hypervolume last / initial median (range)",
               "front points the baseline does not dominate (median)",
               "baseline ends a front point dominates", "first process s",
               "second process s"]
    body = (f"`pareto` preset, {args.seeds} seeds per map, a {RADIUS} m robot, the endpoints "
            "of `benchmarks/pareto_baseline.py`. Clearances are each path's least cell "
            "clearance from the map's own obstacles (before inflation), the measure of the "
            "exact maximin clearance over the paths of the inflated grid "
            "(`jaxga.reference.maximin`); the shortest end is the post-optimised best "
            "path. Processes are wall times from start to exit, the first compiling into "
            "an empty cache, the second reading it. Targets: >= 5 points, every path "
            "feasible, shortest end <= 2 %, widest end >= 0.95 of the maximin clearance, "
            "median hypervolume ratio >= 1.05, second process <= 10 s. Against the "
            "deterministic baseline (`benchmarks/pareto_baseline.py`: the any-angle "
            "optimum and the widest path shortcut), each front path is shortcut without "
            "narrowing it and measured as the baseline is: length and exact clearance "
            "from the map's own obstacles.\n\n"
            + markdown_table(headers, rows))
    record(TITLE, body, write=not args.no_write)


if __name__ == "__main__":
    main()
