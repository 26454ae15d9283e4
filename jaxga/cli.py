"""The ``jaxga`` command line.

``jaxga optimum`` prints the exact 8-connected and any-angle optima of a map
(decisions 015 and 031); ``jaxga run`` runs a preset for many seeds; ``jaxga doe``
runs a designed experiment (:mod:`jaxga.doe`); ``jaxga compare`` compares presets with
statistical tests (:mod:`jaxga.compare`); ``jaxga replan`` re-plans around new obstacles
(:mod:`jaxga.replan`); ``jaxga presets`` and ``jaxga maps`` list the presets and the
built-in maps. Bad input (a missing or malformed file, a start or goal off the map or
blocked, an unreachable goal, an unknown corner rule) ends with a one-line message on
stderr and a non-zero exit status, never a Python traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import re
import sys
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga import api, export, interrupts
from jaxga.api import check_one_corner_rule, configured_rule, parallel
from jaxga.api.compilation_cache import ENV_VAR as CACHE_ENV_VAR
from jaxga.api.compilation_cache import use_compilation_cache
from jaxga.api.lowering import check_environment
from jaxga.api.parallel import (
    ENV_PROCESS_ID,
    EXIT_PROCESS_LOST,
    ProcessLostError,
    add_parallel_arguments,
    configure_from_args,
    env_int,
)
from jaxga.api.references import any_angle_references, octile_optimum
from jaxga.api.result import json_number
from jaxga.api.timeline import Timeline, process_age, time_line
from jaxga.api.warmup import warmup
from jaxga.compare import TESTS, check_metric, compare, split_presets
from jaxga.config import registry
from jaxga.config.presets import load_preset, parse_set, preset_info, preset_settings
from jaxga.core.errors import EndpointError, JaxgaError, NoPathError, ParameterError
from jaxga.core.files import check_outputs as check_output_files
from jaxga.core.files import remove_temporaries, same_file
from jaxga.core.grid import CORNER_RULES, as_integer, check_corner_rule
from jaxga.doe import AGACD_TABLE3, DESIGNS, RESPONSE_ALIASES, RESPONSES, Factor, run_doe
from jaxga.engine import check_file_keys_read, check_overrides_read
from jaxga.maps import (
    builtin_names,
    builtin_scenario_path,
    load_map,
    load_map_info,
    read_scen,
    scenario_path,
)
from jaxga.maps.inputs import PATH_JSON_CAP, read_input
from jaxga.maps.ros import read_ros_yaml
from jaxga.plot import (
    plot_comparison,
    plot_main_effects,
    plot_replan,
    plot_result,
    save_figure,
)
from jaxga.reference.fitness import fitness_optimum
from jaxga.replan import replan
from jaxga.smooth import smooth_population

EXIT_BAD_INPUT = 2
EXIT_NO_PATH = 3


def _parse_xy(text: str) -> tuple[int, int]:
    try:
        x, y = (int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected X,Y (two integers separated by a comma), got {text!r}"
        ) from None
    return x, y


def _budget(text: str) -> float | None:
    """``--budget``: seconds >= 0 (0: no limit)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") \
            from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"expected a number of seconds >= 0, got {text!r}")
    return value or None


def _parse_point(text: str) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected X,Y (two numbers in metres separated by a comma), got {text!r}"
        ) from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise argparse.ArgumentTypeError(f"expected finite coordinates, got {text!r}")
    return x, y


RULE_DEFAULT = ("the map's own: free on the papers' classic 20 x 20 maps, strict on every "
                "other map (no path touches a blocked cell's corner)")
MAP_HELP = ("a map file (0/1 text, Moving AI .map, ASCII, an image such as PNG or PGM, a "
            "ROS map_server .yaml) or a built-in map name (see `jaxga maps`)")


def _add_source_arguments(p: argparse.ArgumentParser) -> None:
    """How a map file is read and grown: image threshold, ROS unknown cells, inflation.
    The first two default to None, so that one given for a map format it has no effect on
    is refused (:func:`jaxga.maps.load_map_info`) instead of ignored; the loader applies
    the defaults the help names."""
    p.add_argument("--threshold", type=float, metavar="LUMA", default=None,
                   help="images (PNG, PGM, ...): a pixel darker than this luminance (0 black "
                   ".. 1 white) is blocked (default 0.5; refused for other formats)")
    p.add_argument("--unknown", choices=("blocked", "free"), default=None,
                   help="ROS maps: plan through unknown cells (free) or not (blocked, "
                   "default; refused for other formats)")
    grow = p.add_mutually_exclusive_group()
    grow.add_argument("--inflate", type=float, metavar="CELLS",
                      help="grow the obstacles by this many cells (centre to centre)")
    grow.add_argument("--robot-radius", type=float, metavar="METRES",
                      help="ROS maps: grow the obstacles by the robot's radius plus margin, "
                      "in metres (divided by the map's resolution)")


def _add_map_arguments(p: argparse.ArgumentParser, rule_default: str = "strict") -> None:
    p.add_argument("--map", required=True, help=MAP_HELP)
    p.add_argument("--start", type=_parse_xy, metavar="X,Y",
                   help="start cell; x = column, y = row from the bottom (default: the "
                   "file's S or (0, 0))")
    p.add_argument("--goal", type=_parse_xy, metavar="X,Y",
                   help="goal cell (default: the file's G or (W-1, H-1))")
    p.add_argument("--start-world", type=_parse_point, metavar="X,Y",
                   help="ROS maps: the start in metres (world frame), instead of --start")
    p.add_argument("--goal-world", type=_parse_point, metavar="X,Y",
                   help="ROS maps: the goal in metres (world frame), instead of --goal")
    _add_source_arguments(p)
    p.add_argument("--scenario", type=int, metavar="N",
                   help="start and goal of problem N (0 = the first) of a Moving AI "
                   "scenario file: --scen, or else the built-in map's own, or "
                   "X-random-N.scen, X.map.scen or X.scen beside a map file X.map (y is "
                   "converted: the file counts it from the top). Its optimal lengths "
                   "assume no corner cutting: --corner-rule strict to compare")
    p.add_argument("--scen", metavar="FILE", help="the .scen file of --scenario")
    p.add_argument("--scenario-map-mismatch", choices=("ok",), default=None,
                   help="ok: use --scenario's problem although it names another map than "
                   "--map (by default refused: its endpoints and optimal length are that "
                   "map's)")
    p.add_argument("--corner-rule", default=None, metavar="RULE",
                   help=f"one of {', '.join(CORNER_RULES)} (default: {rule_default})")
    _add_coarsen_argument(p)


def _add_coarsen_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--coarsen", type=int, metavar="K",
                   help="merge K x K cells into one, blocked if any of them is (for maps "
                   "over 512 x 512 cells); --start, --goal and --scenario stay in the "
                   "original map's cells")


def _add_preset_arguments(p: argparse.ArgumentParser) -> None:
    """The options of a GA experiment: preset, map, variant, generations, overrides."""
    p.add_argument("--preset", required=True, help="a preset name (jaxga presets) or a TOML file")
    _add_map_arguments(p, rule_default=RULE_DEFAULT)
    p.add_argument("--variant", help="a preset variant, e.g. 50x50 for agacd")
    p.add_argument("--generations", type=int, help="override the preset's generations")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration key, e.g. crossover.probability=0.7")


def _apply_scenario(args: argparse.Namespace) -> None:
    """``--scenario N``: ``args.start`` / ``args.goal`` from problem ``N`` of a Moving AI
    scenario file (``--scen``, else :func:`jaxga.maps.scenario_path` of the map; y
    converted to count from the bottom by :func:`jaxga.maps.read_scen`), checked against
    the map's size and name (:meth:`jaxga.maps.Scenario.is_for`: a problem of another map
    is refused unless ``--scenario-map-mismatch ok``); a note on stderr names the file and
    the problem. Refused with --start/--goal, and --scen or --scenario-map-mismatch
    without --scenario. Loads the map (starts JAX)."""
    if getattr(args, "scenario", None) is None:
        if getattr(args, "scen", None) is not None:
            raise JaxgaError("--scen names the scenario file of --scenario N: give N too")
        if getattr(args, "scenario_map_mismatch", None) is not None:
            raise JaxgaError("--scenario-map-mismatch applies to the problem of --scenario "
                             "N: give N too")
        return

    if any(getattr(args, k, None) is not None
           for k in ("start", "goal", "start_world", "goal_world")):
        raise JaxgaError("--scenario gives the start and goal: leave out --start and --goal "
                         "(and --start-world, --goal-world)")
    # a missing or malformed map is named first
    grid = load_map_info(args.map, coarsen=args.coarsen).grid
    path = Path(args.scen) if args.scen is not None else scenario_path(args.map)
    if path is None:
        raise JaxgaError(f"no scenario file for {args.map} (a built-in map's own, or "
                         "X-random-N.scen, X.map.scen or X.scen beside X.map): give --scen")
    problems = read_scen(path)
    if not problems:
        raise JaxgaError(f"{path.name} has no problems")
    if not 0 <= args.scenario < len(problems):
        raise JaxgaError(f"--scenario {args.scenario}: {path.name} has problems 0 .. "
                         f"{len(problems) - 1}")
    problem = problems[args.scenario]
    k = args.coarsen or 1
    if (-(-problem.width // k), -(-problem.height // k)) != (grid.width, grid.height):
        raise JaxgaError(f"{path.name} is for a {problem.width} x {problem.height} map "
                         f"({problem.map_name}), {args.map} is {grid.width} x {grid.height}")
    other = not problem.is_for(args.map)
    if other and getattr(args, "scenario_map_mismatch", None) != "ok":
        raise JaxgaError(f"{path.name}: problem {args.scenario} is for map "
                         f"{problem.map_name}, not {args.map}: its endpoints and optimal "
                         "length belong to that map; give its own scenario file (--scen), "
                         "or --scenario-map-mismatch ok to use it anyway")
    args.start, args.goal = problem.start, problem.goal
    print(f"scenario {args.scenario} of {path.name}: {problem.start} -> {problem.goal}, "
          f"optimal length {problem.optimal_length:.4f} without corner cutting"
          + (f" (on {problem.map_name}, not this map)" if other else ""),
          file=sys.stderr)


_SOURCE_OPTIONS = ("start", "goal", "coarsen", "start_world", "goal_world", "inflate",
                   "robot_radius")


def _map_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of :func:`jaxga.maps.load_map_info` given on the command
    line (endpoints, coarsening, image threshold, ROS unknown cells, inflation); None
    for an option not given, so that the loader applies its default and refuses an
    option given for a format it has no effect on."""
    return {k: getattr(args, k, None) for k in (*_SOURCE_OPTIONS, "threshold", "unknown")}


def _plain_map(args: argparse.Namespace) -> bool:
    """Whether the map is used as named, with none of the loading options."""
    return all(v is None for v in _map_options(args).values())


def _load_info(args: argparse.Namespace, rule: str | None):
    """The map of the command line, loaded with its options under corner rule ``rule``."""
    return load_map_info(args.map, corner_rule=rule, **_map_options(args))


def _load_grid(args: argparse.Namespace):

    if args.corner_rule is not None:
        check_corner_rule(args.corner_rule)
    info = _load_info(args, args.corner_rule)
    return info, info.grid.check_endpoints()


def _write_json(path: str, obj) -> None:
    """Write ``obj`` as one line of JSON to ``path`` (atomically) and say so on stdout."""
    export.atomic_write_text(path, json.dumps(obj) + "\n")
    print(f"wrote {path}")


def _xy_list(path) -> list[list[int]]:
    return [[int(x), int(y)] for x, y in path]


def cmd_optimum(args: argparse.Namespace) -> int:
    """``jaxga optimum``: exact 8-connected and any-angle optima of one map, and with
    ``--preset`` the exact optimum of that preset's fitness."""

    config = None
    if args.preset is None and (args.set or args.variant):
        raise JaxgaError("--set and --variant need --preset")
    if args.preset is not None:
        config = load_preset(args.preset, variant=args.variant, sets=args.set or ())
        set_keys = [parse_set(text)[0] for text in args.set or ()]
        check_overrides_read(config, set_keys)
        check_file_keys_read(args.preset, args.variant)  # as `jaxga run` checks a file
        check_one_corner_rule(args.corner_rule, config, set_keys)
        other = [k for k in set_keys if not k.startswith("fitness.") and k != "map.corner_rule"]
        if other:
            raise JaxgaError(f"jaxga optimum reads only the fitness keys and map.corner_rule "
                             f"of a preset, not {', '.join(other)}")
        # as `jaxga run`: --corner-rule, else a map.corner_rule the preset sets, else
        # the map's own rule
        args.corner_rule = configured_rule(args.corner_rule, config)
    timeline = _process_timeline()
    with timeline.phase("load"):
        info, grid = _load_grid(args)
    frame = info.frame
    with timeline.phase("references"):
        octile = octile_optimum(grid).raise_if_missing()
    progress = None if args.quiet else _Progress()
    with timeline.phase("any_angle"):
        bounds = any_angle_references(grid, octile, args.budget,
                                      None if progress is None
                                      else (lambda frac: progress("any-angle", frac)))
    print(f"map          {info.name} ({grid.width} x {grid.height} cells, corner rule "
          f"{grid.corner_rule!r}{'; ' + frame.describe() if frame.describe() else ''})")
    print(f"start, goal  cells {grid.start_xy} -> {grid.goal_xy}" + _world_ends(frame, grid))
    print(f"8-connected  {octile.length:.4f}{_metres(octile.length, frame)}  "
          f"({octile.n_cells} cells, {timeline.seconds['references']:.3f} s)")
    t_aa = timeline.seconds["any_angle"]
    if math.isfinite(bounds.optimum):
        print(f"any-angle    {bounds.optimum:.4f}{_metres(bounds.optimum, frame)}  "
              f"({len(bounds.path)} waypoints, {t_aa:.3f} s)")
    else:
        print(f"any-angle    {bounds.note} ({t_aa:.3f} s); --budget 0 for no limit")
    if math.isfinite(bounds.lower_bound):
        print(f"lower bound  {bounds.lower_bound:.4f}{_metres(bounds.lower_bound, frame)}  "
              "(Euclidean shortest path around the blocked cells, a proven bound of the "
              "any-angle optimum)")
    t2 = time.perf_counter()
    fit = None
    if config is not None:
        fit = fitness_optimum(grid, config)
        label = f"fitness of {config['name']} ({config['fitness.method']})"
        if fit.found:
            print(f"{label}  {fit.fitness:.6g}  (a path of length {fit.length:.4f}, "
                  f"{len(fit.path)} cells{'' if fit.loop_free else ', not loop-free: a bound'}"
                  f", {time.perf_counter() - t2:.3f} s)")
        else:
            print(f"{label}  not computed: {fit.reason}")
    if args.json:
        out = {
            "map": info.name,
            "corner_rule": grid.corner_rule,
            "start": list(grid.start_xy),
            "goal": list(grid.goal_xy),
            "length": float(octile.length),
            "path": _xy_list(octile.path),
            "any_angle_length": json_number(bounds.optimum),
            "any_angle_path": _xy_list(bounds.path),
            "any_angle_note": bounds.note,
            "lower_bound": json_number(bounds.lower_bound),
            "resolution": None if frame is None else frame.cell_size,
            "frame": None if frame is None else frame.to_json(),
        }
        if frame is not None and frame.has_metres:
            out["start_world"], out["goal_world"] = frame.to_world(
                np.array([grid.start_xy, grid.goal_xy], float)).round(4).tolist()
            out["path_world"] = frame.to_world(np.asarray(octile.path, float)).round(4).tolist()
            out["any_angle_path_world"] = (
                frame.to_world(np.asarray(bounds.path, float)).round(4).tolist()
                if len(bounds.path) else [])
        if fit is not None:
            out["fitness"] = {
                "preset": config["name"], "method": config["fitness.method"],
                "found": fit.found, "reason": fit.reason,
                "value": fit.fitness if fit.found else None,
                "length": fit.length if fit.found else None,
                "path": _xy_list(fit.path),
                "loop_free": fit.loop_free if fit.found else None,
            }
        _write_json(args.json, out)
    return 0


def cmd_maps(args: argparse.Namespace) -> int:
    """``jaxga maps``: list the built-in maps with their sizes."""

    for name in builtin_names():
        g = load_map(name)
        scen = " (with scenarios)" if builtin_scenario_path(name) else ""
        print(f"{name:44s} {g.width:4d} x {g.height:<4d}{scen}")
    return 0


def cmd_presets(args: argparse.Namespace) -> int:
    """``jaxga presets``: list the presets with their papers; ``--show NAME`` prints one
    preset's every setting with its source (the file and the comment next to the key,
    or the default)."""

    if args.show is not None:
        rows = preset_settings(args.show, variant=args.variant)
        width = max(len(key) for key, _, _ in rows)
        for key, value, source in rows:
            text = json.dumps(value) if isinstance(value, (list, str, bool)) else str(value)
            print(f"{key:{width}s} = {text:12s} # {source}")
        return 0
    if args.variant is not None:
        raise JaxgaError("--variant goes with --show NAME")
    for name, paper, description in preset_info():
        print(f"{name:10s} {paper}")
        if description:
            print(f"{'':10s} {description}")
    return 0


def describe_field(field: Any) -> str:
    """One line on a configuration field: type, range or choices, default, whether it
    can be swept without recompiling, and its meaning."""
    kinds = field.kind if isinstance(field.kind, tuple) else (field.kind,)
    parts = ["/".join(k.__name__ for k in kinds)]
    if field.choices is not None:
        parts.append("one of " + ", ".join(map(str, field.choices)))
    if field.low is not None and field.high is not None:
        parts.append(f"in [{field.low}, {field.high}]")
    elif field.low is not None:
        parts.append(f">= {field.low}")
    elif field.high is not None:
        parts.append(f"<= {field.high}")
    if field.default is not None:
        parts.append(f"default {field.default}")
    parts.append("dynamic" if field.dynamic else "static")
    return f"{field.doc} ({'; '.join(parts)})"


def cmd_operators(args: argparse.Namespace) -> int:
    """``jaxga operators [FAMILY]``: the registered operators of each family (or one),
    with their former names, traits, parameters and papers (:mod:`jaxga.config.registry`)."""

    families = registry.FAMILIES if args.family is None else (args.family,)
    for family in families:
        if family not in registry.FAMILIES:
            raise JaxgaError(f"unknown operator family {family!r} "
                             f"({', '.join(registry.FAMILIES)})")
        print(f"{family}.method")
        for op in registry.operators(family):
            former = f" (formerly {', '.join(op.aliases)})" if op.aliases else ""
            traits = f" [{', '.join(sorted(op.traits))}]" if op.traits else ""
            print(f"  {op.name}{former}{traits}")
            print(f"      {op.summary}")
            for key, field in op.params.items():
                print(f"      {key}: {describe_field(field)}")
    return 0


class _Progress:
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
            print(f"progress: {stage} {100 * frac:.0f}%", file=self.stream, flush=True)
            return
        bar = "#" * int(30 * frac)
        print(f"\r{stage:8s} [{bar:30s}] {100 * frac:5.1f}%", end="", file=self.stream,
              flush=True)
        if stage == "evolve" and frac >= 1.0:
            print(file=self.stream)

    def tick(self) -> None:
        """Say that the current phase is still running, when it has gone on for more than
        ``delay`` seconds and nothing was shown for ``delay`` seconds."""
        now = self.clock()
        if self.stage is None or now - self.last < self.delay \
                or now - self.stage_start < self.delay:
            return
        self.last = self.clock()
        self.shown = True
        text = f"{self.stage} still running ({now - self.stage_start:.0f} s)"
        if self.tty:
            print(f"\r{text:49s}", end="", file=self.stream, flush=True)
        else:
            print(f"progress: {text}", file=self.stream, flush=True)

    def start(self) -> _Progress:
        """Call :meth:`tick` every half second in a background thread until :meth:`close`."""
        self._stop = threading.Event()

        def beat(stop: threading.Event = self._stop) -> None:
            while not stop.wait(0.5):
                self.tick()

        threading.Thread(target=beat, daemon=True, name="jaxga-progress").start()
        return self

    def close(self) -> None:
        """Stop the background thread (and end a bar's line on a terminal)."""
        if self._stop is not None:
            self._stop.set()
        if self.tty and self.shown:
            print(file=self.stream, flush=True)


def cmd_run(args: argparse.Namespace) -> int:
    """``jaxga run``: many seeds of a preset on a map; summary table, JSON, path, plot.
    Every phase is timed, from the process's start to the last file written
    (:mod:`jaxga.api.timeline`); the time line is printed last."""

    timeline = _process_timeline()
    lead = parallel.process_index() == 0
    progress = None if args.quiet or not lead else _Progress().start()
    try:
        return _run_and_report(args, timeline, progress)
    finally:
        if progress is not None:
            progress.close()


def _run_and_report(args: argparse.Namespace, timeline: Timeline,
                    progress: _Progress | None) -> int:
    """:func:`cmd_run`'s work, each phase timed on ``timeline`` and shown on ``progress``."""

    def phase(name: str):
        if progress is not None:
            progress(name.replace("_", "-"), 0.0)
        return timeline.phase(name)

    with phase("load"):
        info = _map_for_run(args)
    if args.path_out and (info.frame is None or not info.frame.has_metres):
        raise JaxgaError(f"cannot write --path-out {args.path_out}: the map has no resolution "
                         "and origin (a ROS map_server .yaml has them); --json has the path "
                         "in cells")
    result = api.run(
        args.preset, info, seeds=args.seeds, generations=args.generations,
        corner_rule=args.corner_rule, variant=args.variant, sets=args.set or (),
        progress=progress, population_capacity=args.population_capacity,
        size_class=args.size_class, any_angle_budget=None if args.exact_optimum else "auto",
    )
    for key, seconds in result.timing.items():
        if key != "total_s":
            timeline.add(key[:-2], seconds)
    if _not_lead(f"{len(result.seeds)} seeds", timeline.elapsed()):
        return 0
    print(result.summary(time=False))
    curves = None
    if args.smooth and result.success.any():
        with phase("smooth"):
            curves = smooth_runs(result, info.grid)
        print(_smooth_summary(result, curves))
    best = _best_seed(result)
    if args.plot:
        with phase("plot"):
            curve = None
            if curves is not None and best is not None and curves[best]:
                curve = np.asarray(curves[best]["points"])
            plot_result(result, info.grid, args.plot, curve=curve, info=info)
        print(f"wrote {args.plot}")
    if args.path_out and best is not None:
        with phase("write"):
            export.write_path(args.path_out, _robot_path(result, best, curves))
        print(f"wrote {args.path_out} (seed {int(result.seeds[best])}, "
              f"{'smooth curve' if _use_curve(curves, best) else 'waypoints'}, metres)")
    if args.json:
        with phase("write"):
            doc = result.to_json()
            doc["timing"] = timeline.as_dict()  # every phase but this write
            if curves is not None:
                for run, curve in zip(doc["runs"], curves):
                    run["smooth"] = _curve_json(curve, result.frame)
            _write_json(args.json, doc)
    print(time_line(timeline.as_dict()))
    if not result.success.any():
        print(f"jaxga: no path: {result.reason}", file=sys.stderr)
        return EXIT_NO_PATH
    return 0


def _process_timeline() -> Timeline:
    """A timeline that starts at the process's start: its first phase, ``import``, is the
    interpreter's start and the imports (where the system says when the process began)."""
    age = process_age()
    timeline = Timeline()
    if age is not None:
        timeline.start -= age
        timeline.add("import", age)
    return timeline


def _best_seed(result) -> int | None:
    """The successful seed with the shortest post-optimised path, or None."""
    if not result.success.any():
        return None
    return int(np.nanargmin(np.where(result.success, result.length, np.nan)))


def _use_curve(curves, i: int) -> bool:
    """Whether seed ``i``'s smooth curve is the path to export: smoothed and certified
    clear (a curve that fell back to the polyline is the waypoint path)."""
    return bool(curves is not None and curves[i] and curves[i]["clear"]
                and not curves[i]["used_fallback"])


def _robot_path(result, i: int, curves) -> np.ndarray:
    """Seed ``i``'s path in metres for ``--path-out``: its smooth curve when it has a
    certified one, else its post-optimised waypoints."""
    if _use_curve(curves, i):
        return result.frame.to_world(np.asarray(curves[i]["points"], float))
    return result.world_path(i)


def _curve_json(curve: dict | None, frame) -> dict | None:
    """A smooth curve's JSON, with its points, length and clearance in metres too."""
    if curve is None or frame is None or not frame.has_metres:
        return curve
    return {**curve,
            "points_world": frame.to_world(np.asarray(curve["points"], float)).round(4).tolist(),
            "length_m": curve["length"] * frame.cell_size,
            "min_clearance_m": curve["min_clearance"] * frame.cell_size}


def smooth_runs(result, grid) -> list[dict | None]:
    """``jaxga run --smooth``: every successful seed's post-optimised path smoothed into
    a certified-clear cubic B-spline (:func:`jaxga.smooth.smooth_population`, one
    vectorised call), as JSON-ready dicts (None for a seed without a path): the dense
    ``points`` ``[[x, y], ...]``, ``length``, ``max_curvature``, ``min_clearance`` (cells),
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
    return out


def _smooth_summary(result, curves: list[dict | None]) -> str:
    """One line on the smoothed paths."""
    done = [c for c in curves if c is not None]
    curved = [c for c in done if not c["used_fallback"]]
    line = (f"smooth      {len(curved)} of {len(done)} paths smoothed into a certified clear "
            "curve")
    if curved:
        ratio = np.mean([c["length"] for c in curved]) / np.nanmean(
            [result.length[i] for i, c in enumerate(curves) if c and not c["used_fallback"]])
        line += (f" (mean length {np.mean([c['length'] for c in curved]):.4f}, "
                 f"{100 * (ratio - 1):+.2f} % against the polylines; max curvature "
                 f"{max(c['max_curvature'] for c in curved):.3f}, min clearance "
                 f"{min(c['min_clearance'] for c in curved):.3f} cells)")
    if len(curved) < len(done):
        line += f"; {len(done) - len(curved)} kept as polylines (no clear curve found)"
    return line


def cmd_doe(args: argparse.Namespace) -> int:
    """``jaxga doe``: a designed experiment (AGACD 5.2.1) with its confirmation run."""

    if args.factor:
        factors = [Factor.parse(text) for text in args.factor]
    elif args.design == "agacd-table4":
        factors = list(AGACD_TABLE3)
    else:
        raise JaxgaError("give the factors with --factor NAME=LOW,MID,HIGH (only "
                         "--design agacd-table4 has default factors, AGACD Table 3)")

    def progress(done: int, total: int) -> None:
        if not args.quiet:
            print(f"design points done: {done}/{total}", file=sys.stderr, flush=True)

    result = run_doe(
        args.preset, _map_for_run(args), factors, design=args.design, seeds=args.seeds,
        response=args.response, direction=args.direction, generations=args.generations,
        corner_rule=args.corner_rule, variant=args.variant, sets=args.set or (),
        checkpoint=args.checkpoint, block=args.block, progress=progress,
    )
    if _not_lead(f"{len(result.coded)} design points x {len(result.seeds)} seeds",
                 result.timing["total_s"]):
        return 0
    print(result.report())
    data = result.to_json()
    if args.json:
        _write_json(args.json, data)
    if args.plot:

        save_figure(plot_main_effects(data).figure, args.plot)
        print(f"wrote {args.plot}")
    return 0


def _not_lead(what: str, seconds: float) -> bool:
    """True (after a one-line note) on every process but process 0 of a multi-process
    run: process 0 prints and writes the results of all processes (docs/devices.md)."""

    if parallel.process_index() == 0:
        return False
    print(f"process {parallel.process_index()} of {parallel.process_count()}: done "
          f"({what}; process 0 writes the results)")
    print(f"time (s): total {seconds:.2f}", file=sys.stderr)
    return True


def cmd_compare(args: argparse.Namespace) -> int:
    """``jaxga compare``: several presets on one map with the same seeds; per-preset
    summary, pairwise tests with effect sizes (Holm-corrected), JSON, box plots."""

    presets = split_presets(args.presets)
    if len(presets) < 2:
        raise ParameterError(f"--presets needs at least two preset names, got {args.presets!r}")
    check_metric(args.metric)
    if args.test not in TESTS:
        raise ParameterError(f"unknown test {args.test!r}; choose from {', '.join(TESTS)}")
    if args.corner_rule is not None:

        check_corner_rule(args.corner_rule)
    grid = args.map
    if not _plain_map(args):
        # --corner-rule, else the map's own rule: a preset that names another is refused
        grid = _load_info(args, args.corner_rule)
    progress = None if args.quiet else (lambda label: print(f"running {label} ...",
                                                              file=sys.stderr, flush=True))
    comp = compare(presets, grid, seeds=args.seeds, metric=args.metric, test=args.test,
                   progress=progress, generations=args.generations,
                   corner_rule=args.corner_rule, sets=args.set or (),
                   size_class=args.size_class,
                   any_angle_budget=None if args.exact_optimum else "auto")
    if _not_lead(f"{len(presets)} presets x {args.seeds} seeds",
                 sum(r.timing["total_s"] for r in comp.results.values())):
        return 0
    print(comp.summary())
    if args.json:
        _write_json(args.json, comp.to_json())
    if args.plot:

        plot_comparison(comp, args.plot)
        print(f"wrote {args.plot}")
    if not any(r.success.any() for r in comp.results.values()):
        reasons = sorted({r.reason for r in comp.results.values() if r.reason})
        print("jaxga: no path: no preset found a path"
              + "".join(f"; {reason}" for reason in reasons), file=sys.stderr)
        return EXIT_NO_PATH
    return 0


def _map_for_run(args: argparse.Namespace):
    """The map of the command line loaded with its options (endpoints, inflation,
    coarsening) under the run's corner rule (the preset's unless --corner-rule), as a
    MapInfo: the results keep the map's name and frame (cells, metres)."""

    return _load_info(args, args.corner_rule or _preset_rule(args))


def _metres(length: float, frame) -> str:
    """`` (X m)`` for a length in planning cells on a map with a resolution, else ``""``."""
    if frame is None or frame.cell_size is None or not math.isfinite(length):
        return ""
    return f" ({length * frame.cell_size:.3f} m)"


def _world_ends(frame, grid) -> str:
    """``, (x, y) -> (x, y) m`` for the endpoints on a map with a resolution, else ``""``."""
    if frame is None or not frame.has_metres:
        return ""
    (sx, sy), (gx, gy) = frame.to_world(np.array([grid.start_xy, grid.goal_xy], float))
    return f", ({sx:.3f}, {sy:.3f}) -> ({gx:.3f}, {gy:.3f}) m"


def _grid_for_run(args: argparse.Namespace, rule: str):
    """The Grid of the run (endpoints applied) under its corner rule ``rule``."""

    return _load_info(args, rule).grid


def _preset_rule(args: argparse.Namespace) -> str | None:
    """A corner rule the preset (with --set) names, or None: the map's own."""
    return configured_rule(None, load_preset(args.preset, variant=args.variant,
                                             sets=args.set or ()))


def _parse_obstacles(text: str, option: str = "--obstacles", parse=None) -> list:
    """``X,Y;X,Y;...`` (empty: none) as a list of ``(x, y)``: cells (``_parse_xy``) or,
    with ``parse=_parse_point``, metres."""

    items = []
    for part in text.replace(" ", "").split(";"):
        if part:
            try:
                items.append((parse or _parse_xy)(part))
            except argparse.ArgumentTypeError as e:
                raise ParameterError(f"{option}: {e}") from None
    return items


def _number_or_inf(value: object) -> float:
    """A run's ``raw_length`` for ordering: anything that is not a finite number sorts last."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return float("inf")
    try:
        return float(value) if math.isfinite(value) else float("inf")
    except OverflowError:  # an integer too large for a float
        return float("inf")


def _read_path_json(path: str, run_index: int | None) -> list[tuple[int, int]]:
    """The robot's path from a JSON file: a list of ``[x, y]``, an object with a
    ``"path"`` list (``jaxga optimum --json``), or the JSON of ``jaxga run`` (the raw
    8-connected path of run ``run_index``, default the successful run with the shortest
    raw path). Read only from a regular file of at most
    :data:`jaxga.maps.inputs.PATH_JSON_CAP` bytes (:func:`jaxga.maps.inputs.read_input`):
    a FIFO, a device or a larger file is refused in one line."""

    try:
        raw = read_input(path, PATH_JSON_CAP, what="path JSON file", error=ParameterError,
                         note="1 KiB a cell of the largest map jaxga plans on")
    except FileNotFoundError:
        raise ParameterError(f"{path}: path JSON file not found") from None
    except OSError as e:
        raise ParameterError(f"{path}: cannot read the path JSON file "
                             f"({e.strerror or e})") from None
    try:
        data = json.loads(raw.decode("utf-8"))
    except ValueError as e:  # UnicodeDecodeError and JSONDecodeError
        raise ParameterError(f"{path}: not valid JSON ({e})") from None
    except RecursionError:
        raise ParameterError(f"{path}: not a path JSON file (nested too deeply)") from None
    expected = (f"{path}: expected a list of [x, y] cells, an object with a \"path\" list, "
                "or the JSON of `jaxga run`")
    if isinstance(data, dict) and "runs" in data:
        runs = data["runs"]
        if not (isinstance(runs, list) and all(isinstance(r, dict) for r in runs)):
            raise ParameterError(f"{expected} (its \"runs\" must be a list of objects)")
        if run_index is not None:
            if not 0 <= run_index < len(runs):
                raise ParameterError(f"{path}: --run {run_index} is outside 0..{len(runs) - 1}")
            run = runs[run_index]
        else:
            ok = [r for r in runs if r.get("success") and r.get("raw_path")]
            if not ok:
                raise ParameterError(f"{path}: no successful run with a path")
            run = min(ok, key=lambda r: _number_or_inf(r.get("raw_length")))
        data = run.get("raw_path") or run.get("path")
    elif isinstance(data, dict):
        data = data.get("path")
    try:  # integers only: 0.9 is not cell 0
        cells = [(as_integer(x), as_integer(y)) for x, y in data]
    except (TypeError, ValueError):
        raise ParameterError(f"{expected} (cells are pairs of integers)") from None
    if not cells:
        raise ParameterError(f"{path}: the path is empty")
    return cells


def cmd_replan(args: argparse.Namespace) -> int:
    """``jaxga replan``: re-plan a path around new obstacles from the robot's cell
    (MPMGA 5.2.1 / 5.3.1). The path's own ends are its endpoints (never the map's
    defaults); new obstacles grow like the map (``--inflate`` / ``--robot-radius``)."""

    use_compilation_cache()
    timeline = _process_timeline()
    if args.corner_rule is not None:
        check_corner_rule(args.corner_rule)
    rule = args.corner_rule or _preset_rule(args)
    with timeline.phase("load"):
        info = _load_info(args, rule)
        path = _read_path_json(args.path_json, args.run)
    grid = info.grid
    obstacles = [xy for text in args.obstacles or () for xy in _parse_obstacles(text)]
    for text in args.obstacles_world or ():
        obstacles += [info.frame.cell_of(p, grid.shape, "--obstacles-world point")
                      for p in _parse_obstacles(text, "--obstacles-world", _parse_point)]
    position = args.position
    if args.position_world is not None:
        if position is not None:
            raise JaxgaError("give the robot's position in cells (--position) or in metres "
                             "(--position-world), not both")
        position = info.frame.cell_of(args.position_world, grid.shape, "--position-world")
    if position is None:
        raise JaxgaError("give the robot's position: --position X,Y (cells) or "
                         "--position-world X,Y (metres)")
    result = replan(
        grid, path, obstacles, position, args.preset, seeds=args.seeds,
        generations=args.generations, population=args.population,
        window=_window_option(args.window), plan_from=args.plan_from, post=args.post,
        fallback=args.fallback, variant=args.variant, sets=tuple(args.set or ()),
        inflate=_inflation_cells(args, info),
    )
    timeline.add("replan", result.wall_s)
    print(result.summary())
    if args.json:
        with timeline.phase("write"):
            _write_json(args.json, result.to_json(info.frame))
    if args.plot:
        with timeline.phase("plot"):
            plot_replan(result, grid.replace(start=path[0], goal=path[-1]), path, obstacles,
                        args.plot, info=info)
        print(f"wrote {args.plot}")
    print(time_line(timeline.as_dict()))
    if not result.success:
        print(f"jaxga: no path: {result.reason}", file=sys.stderr)
        return EXIT_NO_PATH
    return 0


def _window_option(text: str) -> int | str | None:
    """``--window``: ``auto`` (default), ``none`` (the whole map) or a side in cells."""
    if text in ("auto", "none"):
        return None if text == "none" else "auto"
    try:
        return int(text)
    except ValueError:
        raise JaxgaError(f"--window must be auto, none or a side in cells, got {text!r}") \
            from None


def _inflation_cells(args: argparse.Namespace, info) -> float:
    """The growth of the map's obstacles in planning cells (``--inflate`` cells or
    ``--robot-radius`` metres), which new obstacles get too; 0 without either."""
    k = info.frame.coarsen if info.frame is not None else 1
    if args.robot_radius is not None:
        return args.robot_radius / info.frame.resolution / k
    return (args.inflate or 0.0) / k


def _int_list(text: str) -> list[int]:
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise JaxgaError(f"expected integers separated by commas, got {text!r}") from None


def cmd_warmup(args: argparse.Namespace) -> int:
    """``jaxga warmup``: compile the presets' programs ahead into the persistent cache."""
    # XLA compiles every program afresh (no read from JAX's own cache), so that each is
    # stored whole (jaxga.api.executables); before this process compiles anything
    jax.config.update("jax_enable_compilation_cache", False)
    presets = split_presets(args.presets) if args.presets else None
    maps: list = [*_int_list(args.sizes)] if args.sizes else []
    maps += list(args.map or ())
    if not maps:
        raise JaxgaError("nothing to warm up: give --sizes or --map")
    lead = parallel.process_index() == 0

    def show(row: dict) -> None:
        if lead:
            print(f"{row['preset']:>10}  {row['map']:<28} {row['seeds']:>4} seeds  "
                  f"compile {row['compile_s']:6.1f} s", flush=True)

    t0 = time.perf_counter()
    rows = warmup(presets, maps, seeds=_int_list(args.seeds) if args.seeds else None,
                  corner_rule=args.corner_rule, size_class=args.size_class, report=show)
    if lead:
        print(f"{len(rows)} program sets ready in {time.perf_counter() - t0:.0f} s "
              f"(cache: {jax.config.jax_compilation_cache_dir})")
    return 0


SIZE_CLASS_HELP = ("pad the map with blocked cells to its size class (each side 32, 64, 128, "
                   "256, 384 or 512 cells) so that maps of one class share compiled "
                   "programs; default: on for maps with a side over 64, off for smaller ones "
                   "(the papers' maps keep their shapes); results are the map's (decision "
                   "030)")
EXACT_HELP = ("compute the exact any-angle optimum whatever it costs (default: within the "
              "GA's own time; beyond it the gap is to a proven lower bound)")


class _Parser(argparse.ArgumentParser):
    """argparse, reporting a bad command line in the one-line form of every other jaxga
    error (``jaxga: error: ...``, exit 2) instead of a usage block."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"jaxga: error: {message} (see: {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``jaxga`` command."""
    parser = _Parser(
        prog="jaxga", description="Genetic-algorithm path planning on grid maps, in JAX."
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("optimum", help="exact 8-connected and any-angle optima of a map")
    _add_map_arguments(p, rule_default=RULE_DEFAULT)
    p.add_argument("--preset", help="also the exact optimum of this preset's fitness over "
                   "8-connected paths (not for agacd, whose fitness scores waypoint paths)")
    p.add_argument("--variant", help="a preset variant, e.g. 50x50 for agacd")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a preset key, e.g. fitness.omega=0.5")
    p.add_argument("--budget", type=_budget, default=None, metavar="SECONDS",
                   help="give the exact any-angle optimum at most this long (default: no "
                   "limit); beyond it the lower bound is reported")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--json", metavar="OUT", help="write the optima and paths as JSON")
    p.set_defaults(func=cmd_optimum)

    p = sub.add_parser("run", help="run a preset on a map for many seeds")
    _add_preset_arguments(p)
    p.add_argument("--seeds", type=int, default=10, help="number of seeded runs (default 10)")
    p.add_argument("--population-capacity", type=int, metavar="K",
                   help="individuals per island of the compiled program (default: "
                   "population.size; not the key population.capacity, the cells of a "
                   "path); a run's random numbers depend on it: give a DOE's or sweep's "
                   "population_capacity to repeat one of its points bit for bit")
    p.add_argument("--size-class", action=argparse.BooleanOptionalAction, default=None,
                   help=SIZE_CLASS_HELP)
    p.add_argument("--exact-optimum", action="store_true", help=EXACT_HELP)
    p.add_argument("--json", metavar="OUT", help="write every run as JSON (paths in cells "
                   "and, on a map with a resolution, in metres)")
    p.add_argument("--path-out", metavar="FILE.csv|FILE.yaml",
                   help="write the best seed's path in metres (a map with a resolution): "
                   "x,y rows (.csv) or a nav_msgs/Path in YAML (.yaml), frame 'map', "
                   "yaw along the path; the smooth curve with --smooth")
    p.add_argument("--plot", metavar="OUT.png", help="plot the map, best paths and convergence")
    p.add_argument("--smooth", action="store_true",
                   help="smooth every path found into a certified-clear cubic B-spline "
                   "(jaxga.smooth): a summary line, each run's curve in the JSON, the best "
                   "seed's in the plot")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("replan", help="re-plan a path around new obstacles (MPMGA 5.2.1)")
    p.add_argument("--map", required=True, help=MAP_HELP)
    _add_source_arguments(p)
    _add_coarsen_argument(p)
    p.add_argument("--path-json", required=True, metavar="FILE",
                   help="the planned path: a JSON list of [x, y], jaxga optimum's JSON, or "
                   "jaxga run's JSON (its raw path)")
    p.add_argument("--run", type=int, metavar="I", help="with jaxga run's JSON: the run to use "
                   "(default: the successful run with the shortest raw path)")
    p.add_argument("--obstacles", action="append", metavar="X,Y;X,Y...",
                   help="cells that became blocked (repeatable); they grow like the map "
                   "(--inflate, --robot-radius)")
    p.add_argument("--obstacles-world", action="append", metavar="X,Y;X,Y...",
                   help="points in metres that became blocked (a map with a resolution; "
                   "repeatable)")
    p.add_argument("--position", type=_parse_xy, metavar="X,Y",
                   help="the robot's current cell on the path")
    p.add_argument("--position-world", type=_parse_point, metavar="X,Y",
                   help="the robot's position in metres (the path cell holding it)")
    p.add_argument("--corner-rule", default=None, metavar="RULE",
                   help=f"one of {', '.join(CORNER_RULES)} (default: {RULE_DEFAULT})")
    p.add_argument("--preset", default="hybrid", help="the GA preset (default hybrid, whose "
                   "initialiser cannot fail where a detour exists; mpmga = the paper's)")
    p.add_argument("--variant", help="a preset variant")
    p.add_argument("--seeds", type=int, default=4, help="seeded GA runs (default 4)")
    p.add_argument("--generations", type=int, default=20, help="GA generations (default 20)")
    p.add_argument("--population", type=int, default=10,
                   help="population size, per island for island presets (default 10)")
    p.add_argument("--window", default="auto", metavar="S|auto|none",
                   help="run the GA on an S x S crop around the re-planned part (default "
                   "auto: the smallest of 32, 64, 128, 256 that holds it; none: the whole "
                   "map)")
    p.add_argument("--plan-from", choices=("robot", "blockage"), default="robot",
                   help="plan from the robot's cell (default) or the cell before the blockage")
    p.add_argument("--post", action="store_true",
                   help="splice the post-optimised (waypoint) segment")
    p.add_argument("--fallback", action="store_true",
                   help="splice the exact A* segment if the GA finds none (flagged)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration key, e.g. mutation.temperature_c1=50")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="draw the old path, the new obstacles "
                   "and the re-planned path")
    p.set_defaults(func=cmd_replan)


    p = sub.add_parser("doe", help="a designed experiment over hyper-parameters (AGACD 5.2.1)")
    _add_preset_arguments(p)
    p.add_argument("--design", default="agacd-table4", choices=DESIGNS,
                   help="AGACD's 9-run design (its Table 4), an orthogonal array or the "
                   "full factorial (default agacd-table4)")
    p.add_argument("--factor", action="append", metavar="NAME=LOW,MID,HIGH",
                   help="a factor and its levels coded -1,0,1, e.g. population.size=40,50,60 "
                   "(repeat; default for agacd-table4: AGACD Table 3)")
    p.add_argument("--seeds", type=int, default=5, help="seeded runs per point (default 5)")
    p.add_argument("--response", default="fitness",
                   choices=(*RESPONSES, *RESPONSE_ALIASES),
                   help="the response fitted (default fitness; angle_sum = smoothness)")
    p.add_argument("--direction", choices=("max", "min"),
                   help="maximise or minimise the response (default: max for fitness and "
                   "success, min for the others)")
    p.add_argument("--checkpoint", metavar="DIR",
                   help="write each finished point to DIR; rerun the same command to resume")
    p.add_argument("--block", type=int,
                   help="design points per compiled call (default: all; 1 with --checkpoint)")
    p.add_argument("--json", metavar="OUT", help="write the design, responses and fit as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="main-effects plot")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_doe)

    p = sub.add_parser("compare", help="compare presets on a map with statistical tests")
    p.add_argument("--presets", required=True, metavar="A,B,...",
                   help="comma-separated preset names (jaxga presets) or TOML files")
    _add_map_arguments(p, rule_default=RULE_DEFAULT)
    p.add_argument("--seeds", type=int, default=30,
                   help="seeded runs per preset, the same seeds for all (default 30)")
    p.add_argument("--metric", default="length",
                   help="main metric: length (post-optimised, default), raw_length, gap, "
                   "raw_gap, fitness_gap, turns, angle_sum, convergence_generation")
    p.add_argument("--test", default="mannwhitneyu",
                   help="mannwhitneyu (default; independent samples) or wilcoxon (paired "
                   "by seed; only when the presets share random numbers)")
    p.add_argument("--size-class", action=argparse.BooleanOptionalAction, default=None,
                   help=SIZE_CLASS_HELP)
    p.add_argument("--exact-optimum", action="store_true", help=EXACT_HELP)
    p.add_argument("--generations", type=int, help="override every preset's generations")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration key in every preset")
    p.add_argument("--json", metavar="OUT", help="write the comparison as JSON")
    p.add_argument("--plot", metavar="OUT.png",
                   help="box plots of the metric per preset (optima as reference lines)")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("presets", help="list the presets and their papers, or show one "
                       "preset's settings (--show NAME)")
    p.add_argument("--show", metavar="NAME", help="print every setting of this preset (or "
                   "TOML file) with its source: the preset file and its comment, or default")
    p.add_argument("--variant", help="with --show: apply this variant")
    p.set_defaults(func=cmd_presets)

    p = sub.add_parser("operators", help="list the operators of each family, with their "
                       "parameters (the values of --set FAMILY.method=NAME)")
    p.add_argument("family", nargs="?", help="one family: init, fitness, selection, "
                   "crossover, mutation, simplify or post")
    p.set_defaults(func=cmd_operators)

    p = sub.add_parser("warmup", help="compile presets' programs ahead into the persistent "
                       "compilation cache (any seed count and generation count then reuses "
                       "them)")
    p.add_argument("--presets", metavar="A,B,...",
                   help="presets to compile (default: every built-in preset)")
    p.add_argument("--sizes", default="20,32,64", metavar="N,N,...",
                   help="open N x N maps to compile for (default 20,32,64; '' for none)")
    p.add_argument("--map", action="append", metavar="MAP",
                   help="also a built-in map name or a map file (repeatable)")
    p.add_argument("--seeds", metavar="N,N,...",
                   help="seed counts to compile for (default: 4 and 32 per device, the "
                   "two program sizes that serve every seed count)")
    p.add_argument("--corner-rule", default=None, metavar="RULE",
                   help=f"one of {', '.join(CORNER_RULES)} (default: strict on the open maps, "
                   "a named map's own)")
    p.add_argument("--size-class", action=argparse.BooleanOptionalAction, default=None,
                   help="compile the size classes' programs (default: as jaxga run, the "
                   "classes of sizes over 64: --sizes 128,256,384,512 serve every map over "
                   "64 x 64; --size-class also pads 32 and 64)")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_warmup)

    p = sub.add_parser("maps", help="list the built-in maps")
    p.set_defaults(func=cmd_maps)
    return parser


_OUTPUT_OPTIONS = ("json", "plot", "path_out", "checkpoint")


def _input_files(args: argparse.Namespace) -> list[tuple[str, str | None]]:
    """``(label, path)`` of every file the command reads: the map (and a ROS map's image),
    the scenario file, the path JSON of replan, preset TOML files."""
    out: list[tuple[str, str | None]] = []
    maps = getattr(args, "map", None)
    for m in (maps if isinstance(maps, list) else [maps]):
        if m and Path(m).is_file():
            out.append(("map", m))
            if Path(m).suffix.lower() in (".yaml", ".yml"):
                with contextlib.suppress(JaxgaError, OSError):  # a bad YAML: named later
                    out.append(("map's image", str(read_ros_yaml(m).image)))
    out.append(("scenario file", getattr(args, "scen", None)))
    if getattr(args, "scenario", None) is not None and maps and not getattr(args, "scen", None):
        found = scenario_path(maps if isinstance(maps, str) else maps[0])
        out.append(("scenario file", str(found) if found else None))
    out.append(("path JSON", getattr(args, "path_json", None)))
    presets = [getattr(args, "preset", None), *str(getattr(args, "presets", "") or "")
               .split(",")]
    out.extend(("preset file", p) for p in presets if p and Path(p).is_file())
    return out


def check_outputs(args: argparse.Namespace) -> None:
    """Check every output (``--json``, ``--plot``, ``--path-out``, a DOE's
    ``--checkpoint`` folder) before the work, not after it
    (:func:`jaxga.core.files.check_outputs`): writable where it is, not a folder, not an
    input of the command nor another output; the plot's extension must be an image format
    matplotlib writes (no extension: ``.png`` is added, as matplotlib would, and
    reported)."""
    pid = getattr(args, "process_id", None)
    if pid is None:
        pid = env_int(ENV_PROCESS_ID)
    if getattr(args, "path_out", None):
        export.path_format(args.path_out)  # .csv or .yaml, refused in one line otherwise
    plot = getattr(args, "plot", None)
    if plot and not Path(plot).suffix:
        args.plot = plot + ".png"
    if pid not in (None, 0):  # only process 0 writes the outputs
        return
    outputs = {f"--{o.replace('_', '-')}": getattr(args, o, None) for o in _OUTPUT_OPTIONS
               if o != "checkpoint"}
    inputs = _input_files(args)
    check_output_files(outputs, inputs)
    folder = getattr(args, "checkpoint", None)
    if folder:
        for label, path in [*inputs, *outputs.items()]:
            if path and Path(path).is_dir() and same_file(path, folder):
                raise JaxgaError(f"cannot use --checkpoint {folder}: it is the {label}")
    plot = getattr(args, "plot", None)
    if plot:
        from matplotlib.figure import Figure

        formats = Figure().canvas.get_supported_filetypes()
        suffix = Path(plot).suffix.lower().lstrip(".")
        if suffix not in formats:
            raise JaxgaError(f"cannot write --plot {plot}: {suffix!r} is not an image format "
                             f"matplotlib writes ({', '.join(sorted(formats))})")
        else:  # some formats need outside tools (pgf: LaTeX for any text): try one first
            probe = Figure()
            probe.text(0.5, 0.5, "jaxga")
            try:
                probe.savefig(io.BytesIO(), format=suffix)
            except Exception as err:  # noqa: BLE001 - any backend failure, named
                raise JaxgaError(f"cannot write --plot {plot}: matplotlib cannot write "
                                 f"{suffix!r} here ({err})") from None


_NEGATIVE_XY = re.compile(r"-[\d.]")
_XY_OPTIONS = ("--start", "--goal", "--position", "--obstacles", "--start-world",
               "--goal-world", "--position-world", "--obstacles-world")


def _join_negative_xy(argv: Sequence[str]) -> list[str]:
    """``--start -1,0`` as ``--start=-1,0``, ``--start-world -1.5,2`` as
    ``--start-world=-1.5,2`` (every coordinate option, cells or metres, and their
    abbreviations): argparse would take ``-1.5,2`` for an option and say "expected one
    argument" instead of reading the usual negative coordinates of a ROS map."""
    out: list[str] = []
    for arg in argv:
        option = out[-1] if out else ""
        takes_xy = len(option) > 3 and any(o.startswith(option) for o in _XY_OPTIONS)
        if takes_xy and _NEGATIVE_XY.match(arg):
            out[-1] = f"{out[-1]}={arg}"
        else:
            out.append(arg)
    return out


def _one_line_warnings(show: Callable[..., None]) -> Callable[..., None]:
    """A ``warnings.showwarning`` that prints jaxga's own warnings (the categories of
    :mod:`jaxga.core.errors`) as one ``jaxga: warning: ...`` line, like its errors (Python's
    format adds the file and source line), JAX's warnings about compilation-cache entries
    as one such line per process naming the cache folder, and hands other warnings to
    ``show``."""

    said: set[str] = set()

    def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
        out = sys.stderr if file is None else file
        text = str(message)
        if category.__module__.split(".")[0] == "jaxga":
            print(f"jaxga: warning: {text}", file=out)
        elif "compilation cache" in text and "jax" in str(filename):
            # JAX's multi-line warning for each cache entry it cannot read or write: one
            # line per process, naming the folder; the program is compiled instead
            if "cache" not in said:
                said.add("cache")
                folder = jax.config.jax_compilation_cache_dir
                why = text.split(": ", 1)[-1].splitlines()[0][:160]
                print(f"jaxga: warning: the compilation cache {folder} ({CACHE_ENV_VAR}) "
                      f"could not be used ({why}): compiling without it", file=out)
        else:
            show(message, category, filename, lineno, file, line)

    return show_warning


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``jaxga`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(_join_negative_xy(sys.argv[1:] if argv is None else argv))
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warnings(warnings.showwarning)
            check_environment()  # $JAXGA_THREEFRY, which `import jaxga` does not refuse
            check_outputs(args)
            if hasattr(args, "devices"):  # subcommands with add_parallel_arguments
                configure_from_args(args)  # before JAX's backend starts
            _apply_scenario(args)  # after it: loading the map starts JAX
            if args.func in (cmd_run, cmd_doe, cmd_compare, cmd_warmup):
                use_compilation_cache()
            return args.func(args)
    except ProcessLostError as e:
        # Exit at once: a normal exit would wait in jax.distributed's shutdown barrier
        # for the lost process (up to --process-timeout).
        print(f"jaxga: error: {e}", file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(EXIT_PROCESS_LOST)
    except NoPathError as e:
        print(f"jaxga: no path: {e}", file=sys.stderr)
        return EXIT_NO_PATH
    except EndpointError as e:
        print(f"jaxga: bad start or goal: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except JaxgaError as e:
        print(f"jaxga: error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as e:
        print(f"jaxga: error: {e.strerror or e}: {e.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("jaxga: interrupted", file=sys.stderr)
        return 130


def console() -> None:
    """The ``jaxga`` console script: :func:`main`, then, in a single-process run, an exit
    that skips the interpreter's teardown of JAX (its backends and threads: about a third
    of a second a user would wait after the last line) once the output is flushed; every
    file jaxga writes is complete by then (written atomically). A run over several
    processes exits normally, through ``jax.distributed``'s shutdown. Ctrl-C and SIGTERM
    end it at once with 130 or 143 (:mod:`jaxga.interrupts`)."""
    interrupts.install(remove_temporaries)
    for stream in (sys.stdout, sys.stderr):  # a map named in Unicode, an ASCII terminal
        with contextlib.suppress(AttributeError, ValueError):
            stream.reconfigure(errors="backslashreplace")
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    if "jax" in sys.modules and jax.process_count() > 1:
        sys.exit(code)
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    console()
