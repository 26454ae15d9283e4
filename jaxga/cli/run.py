"""``jaxga run``: a preset for many seeds, its summary, time line, JSON, path file and plot."""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga import api, export
from jaxga._runtime import parallel
from jaxga._runtime.fields import front_obstacles
from jaxga._runtime.parallel import add_parallel_arguments
from jaxga._runtime.timeline import Timeline, process_age, time_line
from jaxga.api.result_fronts import check_front_point, json_number
from jaxga.cli.options import (
    EXACT_HELP,
    EXIT_NO_PATH,
    SIZE_CLASS_HELP,
    add_preset_arguments,
    not_lead,
    problem_for_run,
    snap_notes,
    write_json,
)
from jaxga.cli.outputs import write_empty_path
from jaxga.core.errors import JaxgaError
from jaxga.core.numerals import ascii_float
from jaxga.engine.algorithm import front_objectives
from jaxga.maps.clearance import ObstacleClearance
from jaxga.plot import (
    plot_result,
)
from jaxga.reference.baseline import widest_shortcut
from jaxga.reference.optima import path_length
from jaxga.smooth import resample_curve, smooth_population


class Progress:
    """Progress of a run on stderr, shown from the first update after the run has taken
    ``delay`` seconds (a quick run shows none): on a terminal a one-line bar redrawn in
    place; on a pipe or a file (a log) one plain line per update, no carriage returns.

    A phase that goes on for more than ``delay`` seconds without an update (a reference
    search, a plot) is shown too, with its seconds so far (:meth:`tick`, called every half
    second by a background thread between :meth:`start` and :meth:`close`)."""

    def __init__(self, stream: Any = None, clock: Callable[[], float] = time.perf_counter,
                 delay: float = 2.0) -> None:
        self.stream = sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", None)
        self.tty = bool(isatty()) if callable(isatty) else False
        self.clock = clock
        self.t0 = clock()
        self.delay = delay
        self.shown = False
        self.stage: str | None = None
        self.stage_start = self.last = self.t0
        self._line = ""
        self._stop: threading.Event | None = None

    def __call__(self, stage: str, frac: float) -> None:
        now = self.clock()
        if stage != self.stage:
            self.stage, self.stage_start = stage, now
        self.last = now
        if not self.shown and now - self.t0 < self.delay:
            return
        self.shown = True
        if not self.tty:
            line = f"progress: {stage} {100 * frac:.0f}%"
            if line != self._line:  # a log says each percentage once
                print(line, file=self.stream, flush=True)
            self._line = line
            return
        bar = "#" * int(30 * frac)
        print(f"\r{stage:8s} [{bar:30s}] {100 * frac:5.1f}%", end="", file=self.stream,
              flush=True)
        if stage == "evolve" and frac >= 1.0:
            print(file=self.stream)

    def tick(self) -> None:
        """Say that the current phase is still running, when it has gone on for more than
        ``delay`` seconds and nothing was shown for ``delay`` seconds; in a log, for half
        the phase's time so far (lines at about 2, 4, 8, 16 s: a few lines, not one
        every 2 s of a long compile)."""
        now = self.clock()
        quiet = self.delay if self.tty else max(self.delay, 0.5 * (now - self.stage_start))
        if self.stage is None or now - self.last < quiet \
                or now - self.stage_start < self.delay:
            return
        self.last = self.clock()
        self.shown = True
        text = f"{self.stage} still running ({now - self.stage_start:.0f} s)"
        if self.tty:
            print(f"\r{text:49s}", end="", file=self.stream, flush=True)
        else:
            self._line = f"progress: {text}"
            print(self._line, file=self.stream, flush=True)

    def start(self) -> Progress:
        """Call :meth:`tick` every half second in a background thread until :meth:`close`."""
        self._stop = threading.Event()

        def beat(stop: threading.Event = self._stop) -> None:
            while not stop.wait(0.5):
                self.tick()

        threading.Thread(target=beat, daemon=True, name="jaxga-progress").start()
        return self

    def close(self) -> None:
        """Stop the background thread (and end a bar's line on a terminal); a second call
        does nothing."""
        if self._stop is not None:
            self._stop.set()
            self._stop = None
        if self.tty and self.shown:
            print(file=self.stream, flush=True)
            self.shown = False


def cmd_run(args: argparse.Namespace) -> int:
    """``jaxga run``: many seeds of a preset on a map; summary table, JSON, path, plot.
    Every phase is timed, from the process's start to the last file written
    (:mod:`jaxga._runtime.timeline`); the time line is printed last."""

    timeline = process_timeline()
    lead = parallel.process_index() == 0
    progress = None if args.quiet or not lead else Progress().start()
    try:
        return run_and_report(args, timeline, progress)
    finally:
        if progress is not None:
            progress.close()


def run_and_report(args: argparse.Namespace, timeline: Timeline,
                    progress: Progress | None) -> int:
    """:func:`cmd_run`'s work, each phase timed on ``timeline`` and shown on ``progress``."""

    def phase(name: str):
        if progress is not None:
            progress(name.replace("_", "-"), 0.0)
        return timeline.phase(name)

    with phase("load"):
        problem = problem_for_run(args)
    info = problem.info
    if args.path_out and (info.frame is None or not info.frame.has_metres):
        raise JaxgaError(f"cannot write --path-out {args.path_out}: the map has no resolution "
                         "and origin (a ROS map_server .yaml has them); --json has the path "
                         "in cells")
    keeps_front = problem.config.get("survival.method") is not None
    if args.front_point is not None and not keeps_front:  # never silently ignored
        raise JaxgaError(f"--front-point chooses a point of a front, and preset "
                         f"{problem.config['name']!r} keeps none (one best path a seed): "
                         "leave it out, or use a preset that keeps a front (pareto)")
    args.front_point = "knee" if args.front_point is None else args.front_point
    choice = front_point_choice(args.front_point)
    if args.path_out and keeps_front:
        check_front_point(front_objectives(problem.config), choice)
    result = api.run(
        problem, seeds=args.seeds, progress=progress,
        population_capacity=args.population_capacity,
        size_class=args.size_class,
        any_angle_budget=0.0 if args.no_reference else None if args.exact_optimum else "auto",
    )
    for key, seconds in result.timing.items():
        if key != "total_s":
            timeline.add(key[:-2], seconds)
    if not_lead(f"{len(result.seeds)} seeds", timeline.elapsed()):
        return 0
    print(result.summary(time=False))
    if result.front is not None:
        print(result.front_text())
    for note in snap_notes(args, info):
        print(note)
    curves = None
    if args.smooth and result.success.any():
        with phase("smooth"):
            curves = smooth_runs(result, info.grid)
        print(smooth_summary(result, curves))
    best = result.best_seed()
    if args.plot:
        with phase("plot"):
            curve = None
            if curves is not None and best is not None and curves[best]:
                curve = np.asarray(curves[best]["points"])
            plot_result(result, info.grid, args.plot, curve=curve, info=info)
        print(f"wrote {args.plot}")
    point = unmet = None
    if args.path_out and best is not None and result.front is not None:
        point = result.front_point(best, choice)
        if point is None:  # a request no path meets: no path, the JSON still written
            unmet = (f"no point of seed {int(result.seeds[best])}'s front keeps a "
                     f"clearance of {args.front_point} m (--front-point)")
    if point is not None:
        with phase("write"):
            line = front_polyline(info.grid, point["path"],
                                  front_obstacles(result.frame, info.grid))
            export.write_path(args.path_out, result.frame.to_world(line.astype(float)),
                              decimals=result.frame.world_decimals)
        evolved = (f"{point['length_m']:.3f} m long as evolved, " if "length_m" in point
                   else "")
        clear = ""
        if "clearance_m" in point and math.isfinite(point["clearance_m"]):
            # the cells' clearance is the front's objective; the written line's own,
            # between the cells, may be less (a diagonal passes nearer a corner)
            clear = f", its cells' clearance {point['clearance_m']:.3f} m"
            own = (None if result.frame.clearance is None
                   else result.frame.clearance.of_path_m(line))
            if own is not None and math.isfinite(own):
                clear += f", the line's own {own:.3f} m"
        print(f"wrote {args.path_out} (seed {int(result.seeds[best])}, front point "
              f"{args.front_point}: {evolved}"
              f"{path_length(line) * result.frame.cell_size:.3f} m shortcut without "
              f"narrowing it{clear}; metres)")
    elif args.path_out and best is not None and unmet is None:
        with phase("write"):
            export.write_path(args.path_out, robot_path(result, best, curves),
                              decimals=result.frame.world_decimals)
        print(f"wrote {args.path_out} (seed {int(result.seeds[best])}, "
              f"{'smooth curve' if use_curve(curves, best) else 'waypoints'}, metres)")
    elif args.path_out:
        write_empty_path(args)
    if args.json:
        with phase("write"):
            doc = result.to_json()
            doc["timing"] = timeline.as_dict()  # every phase but this write
            if curves is not None:
                for run, curve in zip(doc["runs"], curves):
                    run["smooth"] = curve_json(curve, result.frame)
            write_json(args.json, doc)
    print(time_line(timeline.as_dict()))
    if not result.success.any() or unmet is not None:
        print(f"jaxga: no path: {unmet or result.reason}{ends_in_metres(result)}",
              file=sys.stderr)
        return EXIT_NO_PATH
    return 0


def ends_in_metres(result) -> str:
    """`` (start (x, y) m, goal (x, y) m)``, the cell centres a reason naming cells
    stands for, on a map with metres; else ``""``."""
    frame = result.frame
    if frame is None or not frame.has_metres or result.start is None or result.goal is None \
            or "cell (" not in str(result.reason):
        return ""
    (sx, sy), (gx, gy) = frame.to_world(np.array([result.start, result.goal], float))
    m = frame.coordinate_text
    return f" (start ({m(sx)}, {m(sy)}) m, goal ({m(gx)}, {m(gy)}) m)"


def front_polyline(grid, path, obstacles: np.ndarray | None = None) -> np.ndarray:
    """A front point's path (``(x, y)`` cells, 8-connected as evolved) as a robot follows
    it: shortcut greedily through the grid's free cells without coming closer to
    ``obstacles`` (those its clearance is measured from:
    :func:`jaxga._runtime.fields.front_obstacles`; the grid's blocked cells by default)
    than the path itself does (:func:`jaxga.reference.baseline.widest_shortcut`), so it
    is no longer and no narrower."""
    blocked = grid.blocked_np()
    return widest_shortcut(blocked, grid.corner_rule, np.asarray(path),
                           ObstacleClearance(blocked if obstacles is None else obstacles))


FRONT_POINTS = ("knee", "shortest", "widest")
"""The named points of a front ``--front-point`` takes (or a clearance in metres)."""


def front_point_choice(value: str) -> str | float:
    """``--front-point``: a name of :data:`FRONT_POINTS`, or a least clearance in metres
    (a number >= 0)."""
    if value in FRONT_POINTS:
        return value
    try:  # ASCII digits only: '1_0' is not 10 m
        least = ascii_float(value)
    except ValueError:
        least = math.nan
    if not least >= 0 or not math.isfinite(least):
        raise argparse.ArgumentTypeError(
            f"--front-point takes {', '.join(FRONT_POINTS)} or a clearance in metres >= 0, "
            f"got {value!r}")
    return least


def front_point_arg(value: str) -> str:
    """``--front-point`` as given, once :func:`front_point_choice` accepts it."""
    front_point_choice(value)
    return value


def process_timeline() -> Timeline:
    """A timeline that starts at the process's start: its first phase, ``import``, is the
    interpreter's start and the imports (where the system says when the process began)."""
    age = process_age()
    timeline = Timeline()
    if age is not None:
        timeline.start -= age
        timeline.add("import", age)
    return timeline


def use_curve(curves, i: int) -> bool:
    """Whether seed ``i``'s smooth curve is the path to export: smoothed and certified
    clear (a curve that fell back to the polyline is the waypoint path)."""
    return bool(curves is not None and curves[i] and curves[i]["clear"]
                and not curves[i]["used_fallback"])


def robot_path(result, i: int, curves) -> np.ndarray:
    """Seed ``i``'s path in metres for ``--path-out``: its smooth curve when it has a
    certified one, else its post-optimised waypoints."""
    if use_curve(curves, i):  # poses a cell apart or closer, within 0.001 cells of the curve
        return result.frame.to_world(resample_curve(curves[i]["points"]))
    return result.world_path(i)


def curve_json(curve: dict | None, frame) -> dict | None:
    """A smooth curve's JSON, with its points, length and clearance in metres too."""
    if curve is None or frame is None or not frame.has_metres:
        return curve
    obstacles = curve.get("obstacle_clearance")
    return {**curve,
            "points_world": frame.world_list(np.asarray(curve["points"], float)),
            "length_m": curve["length"] * frame.cell_size,
            # as a path's min_clearance_m: to the map's own obstacles, before inflation
            "min_clearance_m": (json_number(obstacles * frame.resolution)
                                if obstacles is not None else None)}


def smooth_runs(result, grid) -> list[dict | None]:
    """``jaxga run --smooth``: every successful seed's post-optimised path smoothed into
    a certified-clear cubic B-spline (:func:`jaxga.smooth.smooth_population`, one
    vectorised call), as JSON-ready dicts (None for a seed without a path): the dense
    ``points`` ``[[x, y], ...]``, ``length``, ``max_curvature``, ``min_clearance`` (planning
    cells, to the grid planned on: inflated by the robot), ``obstacle_clearance`` (map
    cells, to the map's own obstacles before inflation, as a path's
    :meth:`~jaxga.api.result.Result.obstacle_clearance`; None without a loaded map),
    ``clear`` and ``used_fallback`` (the polyline returned where no clear curve was
    found)."""
    ok = np.flatnonzero(result.success)
    paths = [result.path(int(i)) for i in ok]
    cap = max(len(p) for p in paths)
    cells = np.array([[y * grid.width + x for x, y in p] + [p[-1][1] * grid.width + p[-1][0]]
                      * (cap - len(p)) for p in paths], np.int32)
    lengths = np.array([len(p) for p in paths], np.int32)
    res = jax.device_get(smooth_population(grid, jnp.asarray(cells), jnp.asarray(lengths)))
    out: list[dict | None] = [None] * len(result.seeds)
    for k, i in enumerate(ok):
        out[int(i)] = {
            "points": np.asarray(res.points[k], float).round(4).tolist(),
            "length": float(res.length[k]), "max_curvature": float(res.max_curvature[k]),
            "min_clearance": float(res.min_clearance[k]), "clear": bool(res.clear[k]),
            "used_fallback": bool(res.used_fallback[k]),
        }
        f = result.frame
        out[int(i)]["obstacle_clearance"] = (
            None if f is None or f.clearance is None
            else f.clearance.of_path(np.asarray(res.points[k], np.float64)))
    return out


def smooth_summary(result, curves: list[dict | None]) -> str:
    """One line on the smoothed paths."""
    done = [c for c in curves if c is not None]
    curved = [c for c in done if not c["used_fallback"]]
    line = (f"smooth      {len(curved)} of {len(done)} paths smoothed into a certified clear "
            "curve")
    if curved:
        ratio = np.mean([c["length"] for c in curved]) / np.nanmean(
            [result.length[i] for i, c in enumerate(curves) if c and not c["used_fallback"]])
        length = np.mean([c["length"] for c in curved])
        curvature = max(c["max_curvature"] for c in curved)
        clearance = min(c["min_clearance"] for c in curved)
        size = None if result.frame is None else result.frame.cell_size
        if size:  # a map with a resolution: metres, to the map's own obstacles like a path's
            obstacles = [c["obstacle_clearance"] for c in curved
                         if c.get("obstacle_clearance") is not None]
            own = (f"{min(obstacles) * result.frame.resolution:.3f} m from the map's "
                   "obstacles" if obstacles else f"{clearance * size:.3f} m")
            line += (f" (mean length {length * size:.3f} m, {100 * (ratio - 1):+.2f} % against "
                     f"the polylines; max curvature {curvature / size:.3f} 1/m, min clearance "
                     f"{own})")
        else:
            line += (f" (mean length {length:.4f}, {100 * (ratio - 1):+.2f} % against the "
                     f"polylines; max curvature {curvature:.3f}, min clearance "
                     f"{clearance:.3f} cells)")
    if len(curved) < len(done):
        line += f"; {len(done) - len(curved)} kept as polylines (no clear curve found)"
    return line


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``run`` command to ``jaxga``'s parser."""
    p = commands.add_parser("run", help="run a preset on a map for many seeds")
    add_preset_arguments(p)
    p.add_argument("--seeds", type=int, default=10, help="number of seeded runs (default 10)")
    p.add_argument("--population-capacity", type=int, metavar="K",
                   help="individuals per island of the compiled program (default: "
                   "population.size; not the key population.capacity, the cells of a "
                   "path); a run's random numbers depend on it: give a DOE's or sweep's "
                   "population_capacity to repeat one of its points bit for bit")
    p.add_argument("--size-class", action=argparse.BooleanOptionalAction, default=None,
                   help=SIZE_CLASS_HELP)
    refs = p.add_mutually_exclusive_group()
    refs.add_argument("--exact-optimum", action="store_true", help=EXACT_HELP)
    refs.add_argument("--no-reference", action="store_true",
                      help="skip the any-angle optimum and its lower bound (a plan that needs "
                      "no gap; gap is then to the straight line from start to goal, and so "
                      "is raw_gap of waypoint paths)")
    p.add_argument("--json", metavar="OUT", help="write every run as JSON (paths in cells "
                   "and, on a map with a resolution, in metres)")
    p.add_argument("--path-out", metavar="FILE.csv|FILE.yaml",
                   help="write the best seed's path in metres (a map with a resolution): "
                   "x,y rows (.csv) or a nav_msgs/Path in YAML (.yaml), frame 'map', "
                   "yaw along the path; the smooth curve with --smooth")
    p.add_argument("--front-point", default=None, metavar="knee|shortest|widest|METRES",
                   type=front_point_arg,
                   help="with a preset that keeps a front (pareto): which of the best "
                   "seed's front points --path-out writes: the knee (default), an end, or "
                   "the shortest that keeps at least METRES from the obstacles")
    p.add_argument("--plot", metavar="OUT.png", help="plot the map, best paths and "
                   "convergence (a front: its paths, the trade-off and the hypervolume)")
    p.add_argument("--smooth", action="store_true",
                   help="smooth every path found into a certified-clear cubic B-spline "
                   "(jaxga.smooth): a summary line, each run's curve in the JSON, the best "
                   "seed's in the plot")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_run, compiles=True)
