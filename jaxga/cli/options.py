"""The options every command shares: the map, its endpoints (cells, metres or a scenario), the
corner rule, the preset and its settings, and their parsing."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from jaxga import export
from jaxga._runtime import parallel
from jaxga._runtime.size_classes import CLASS_SIDES
from jaxga.api import configured_rule
from jaxga.api.problem import Problem, checked_endpoints, problem
from jaxga.compare import split_presets
from jaxga.config.presets import load_preset
from jaxga.core.errors import JaxgaError, ParameterError
from jaxga.core.grid import CORNER_RULES, check_corner_rule
from jaxga.core.numerals import ASCII_DECIMAL, ascii_int
from jaxga.maps import (
    load_map_info,
    read_scen,
    scenario_path,
)
from jaxga.reference.optima import shortest_path_np

EXIT_BAD_INPUT = 2


EXIT_NO_PATH = 3


EXIT_DEVICE_DISAGREES = 5
"""Exit status when JAX's default backend computes jaxga's exact results differently
from the CPU (``jaxga doctor``, or a run refused by the device probe)."""


def given_presets(text: str | None) -> list[str] | None:
    """``--presets A,B,...`` as a list; None when the option is not given (every built-in
    preset). A given list that names no preset (``''``, ``,``) is refused in one line,
    not taken for every preset or for none."""
    if text is None:
        return None
    names = split_presets(text)
    if not names:
        raise JaxgaError(f"--presets names no preset (got {text!r}): leave it out for every "
                         "built-in preset")
    return names


def parse_xy(text: str) -> tuple[int, int]:
    try:
        x, y = (ascii_int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected X,Y (two integers separated by a comma), got {text!r}"
        ) from None
    return x, y


def parse_budget(text: str) -> float | None:
    """``--budget``: seconds >= 0 (0: no limit)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") \
            from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"expected a number of seconds >= 0, got {text!r}")
    return value or None


def parse_point(text: str) -> tuple[float, float]:
    try:
        parts = text.split(",")
        if not all(ASCII_DECIMAL.fullmatch(v) for v in parts):
            raise ValueError(text)
        x, y = (float(v) for v in parts)
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


def add_source_arguments(p: argparse.ArgumentParser) -> None:
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
    p.add_argument("--occupied-from", type=int, metavar="OCC", default=None,
                   help="ROS maps: the occupancy (1-100) from which a cell is blocked; "
                   "graded cells below it are free, unknown ones follow --unknown (99 "
                   "plans on a costmap as costmap_2d does; default: graded cells go with "
                   "the unknown ones; refused for other formats)")
    grow = p.add_mutually_exclusive_group()
    grow.add_argument("--inflate", type=float, metavar="CELLS",
                      help="grow the obstacles by this many cells (centre to centre)")
    grow.add_argument("--robot-radius", type=float, metavar="METRES",
                      help="ROS maps: grow the obstacles by this many metres (the robot's "
                      "radius, plus any safety distance you want: nothing is added), cell "
                      "centre to cell centre (divided by the map's resolution)")


def add_map_arguments(p: argparse.ArgumentParser, rule_default: str = "strict") -> None:
    p.add_argument("--map", required=True, help=MAP_HELP)
    p.add_argument("--start", type=parse_xy, metavar="X,Y",
                   help="start cell; x = column, y = row from the bottom (default: the "
                   "file's S or (0, 0))")
    p.add_argument("--goal", type=parse_xy, metavar="X,Y",
                   help="goal cell (default: the file's G or (W-1, H-1))")
    p.add_argument("--start-world", type=parse_point, metavar="X,Y",
                   help="ROS maps: the start in metres (world frame), instead of --start")
    p.add_argument("--goal-world", type=parse_point, metavar="X,Y",
                   help="ROS maps: the goal in metres (world frame), instead of --goal")
    add_source_arguments(p)
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
    add_coarsen_argument(p)


def add_coarsen_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--coarsen", type=int, metavar="K",
                   help="merge K x K cells into one, blocked if any of them is (for maps "
                   "over 2048 x 2048 cells or the memory); --start, --goal and --scenario "
                   "stay in the original map's cells")


def add_preset_arguments(p: argparse.ArgumentParser) -> None:
    """The options of a GA experiment: preset, map, variant, generations, overrides."""
    p.add_argument("--preset", required=True, help="a preset name (jaxga presets) or a TOML file")
    add_map_arguments(p, rule_default=RULE_DEFAULT)
    p.add_argument("--variant", help="a preset variant, e.g. 50x50 for agacd")
    p.add_argument("--generations", type=int, help="override the preset's generations")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration key, e.g. crossover.probability=0.7")


def apply_scenario(args: argparse.Namespace) -> None:
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
          + (f" (on {problem.map_name}, not this map)" if other else
             scenario_disagreement(grid, problem) if k == 1 else ""),
          file=sys.stderr)


SCENARIO_TOLERANCE = 1e-3
"""Moving AI's files give lengths to 8 decimals or fewer: a stated optimal length this far
from the exact one is not rounding."""


def scenario_disagreement(grid, problem) -> str:
    """``""`` when a scenario's stated optimal length is the exact 8-connected optimum
    without corner cutting (``"strict"``) of its endpoints on ``grid``, else a note with
    the exact one (the file's number is printed as given, never used as the
    optimum)."""
    exact = shortest_path_np(grid.blocked_np(), problem.start, problem.goal, "strict")
    if not exact.found:
        return f"; but on this map {exact.reason}"
    if abs(exact.length - problem.optimal_length) <= SCENARIO_TOLERANCE * max(
            1.0, exact.length):
        return ""
    return (f"; but the exact optimum of these endpoints on this map is "
            f"{exact.length:.4f}: the file's length is wrong, the exact one is used")


SOURCE_OPTIONS = ("start", "goal", "coarsen", "start_world", "goal_world", "inflate",
                   "robot_radius")


def map_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of :func:`jaxga.maps.load_map_info` given on the command
    line (endpoints, coarsening, image threshold, ROS unknown and graded cells,
    inflation); None
    for an option not given, so that the loader applies its default and refuses an
    option given for a format it has no effect on."""
    return {k: getattr(args, k, None)
            for k in (*SOURCE_OPTIONS, "threshold", "unknown", "occupied_from")}


def plain_map(args: argparse.Namespace) -> bool:
    """Whether the map is used as named, with none of the loading options."""
    return all(v is None for v in map_options(args).values())


def load_info(args: argparse.Namespace, rule: str | None):
    """The map of the command line, loaded with its options under corner rule ``rule``."""
    return load_map_info(args.map, corner_rule=rule, **map_options(args))


def load_grid(args: argparse.Namespace):

    if args.corner_rule is not None:
        check_corner_rule(args.corner_rule)
    info = load_info(args, args.corner_rule)
    return info, checked_endpoints(info.grid, info.frame, info.layers, info.defaulted)


def write_json(path: str, obj) -> None:
    """Write ``obj`` as one line of JSON to ``path`` (atomically) and say so on stdout."""
    export.atomic_write_text(path, json.dumps(obj) + "\n")
    print(f"wrote {path}")


def xy_list(path) -> list[list[int]]:
    return [[int(x), int(y)] for x, y in path]


def not_lead(what: str, seconds: float) -> bool:
    """True (after a one-line note) on every process but process 0 of a multi-process
    run: process 0 prints and writes the results of all processes (docs/devices.md)."""

    if parallel.process_index() == 0:
        return False
    print(f"process {parallel.process_index()} of {parallel.process_count()}: done "
          f"({what}; process 0 writes the results)")
    print(f"time (s): total {seconds:.2f}", file=sys.stderr)
    return True


def problem_for_run(args: argparse.Namespace) -> Problem:
    """The problem of the command line, loaded and checked once (:func:`jaxga.problem`):
    the preset with its variant, ``--set`` values and ``--generations``; the map with its
    options (endpoints, inflation, coarsening) under the run's corner rule (the preset's
    unless --corner-rule). Its ``info`` keeps the map's name, frame (cells, metres) and
    layers."""

    return problem(args.preset, args.map, corner_rule=args.corner_rule,
                   variant=args.variant, sets=args.set or (),
                   generations=args.generations, map_options=map_options(args))


def metres_text(length: float, frame) -> str:
    """`` (X m)`` for a length in planning cells on a map with a resolution, else ``""``."""
    if frame is None or frame.cell_size is None or not math.isfinite(length):
        return ""
    return f" ({length * frame.cell_size:.3f} m)"


def world_ends(frame, grid) -> str:
    """``, (x, y) -> (x, y) m`` for the endpoints on a map with a resolution, else ``""``."""
    if frame is None or not frame.has_metres:
        return ""
    (sx, sy), (gx, gy) = frame.to_world(np.array([grid.start_xy, grid.goal_xy], float))
    m = frame.coordinate_text
    return f", ({m(sx)}, {m(sy)}) -> ({m(gx)}, {m(gy)}) m"


def snap_notes(args: argparse.Namespace, info) -> list[str]:
    """One line per endpoint given in metres that the plan starts or ends at its cell's
    centre instead (the planner works on cell centres): where, and how far away."""
    notes = []
    if info.frame is None or not info.frame.has_metres:
        return notes
    for name, world, xy in (("start", getattr(args, "start_world", None), info.grid.start_xy),
                            ("goal", getattr(args, "goal_world", None), info.grid.goal_xy)):
        if world is None:
            continue
        x, y = info.frame.to_world(np.asarray(xy, float))
        away = math.hypot(x - world[0], y - world[1])
        if away > 5e-4:
            d = 3  # decimals enough to tell the centre from the point given
            while d < 6 and f"{x:.{d}f},{y:.{d}f}" == f"{world[0]:.{d}f},{world[1]:.{d}f}":
                d += 1
            text = info.frame.coordinate_text
            given = f"({text(world[0])}, {text(world[1])})"
            notes.append(f"note: the {name} {given} m is planned at the "
                         f"centre of its cell, ({x:.{d}f}, {y:.{d}f}) m, {away:.{d}f} m away")
    return notes


def grid_for_run(args: argparse.Namespace, rule: str):
    """The Grid of the run (endpoints applied) under its corner rule ``rule``."""

    return load_info(args, rule).grid


def preset_rule(args: argparse.Namespace) -> str | None:
    """A corner rule the preset (with --set) names, or None: the map's own."""
    return configured_rule(None, load_preset(args.preset, variant=args.variant,
                                             sets=args.set or ()))


def parse_obstacles(text: str, option: str = "--obstacles", parse=None) -> list:
    """``X,Y;X,Y;...`` (empty: none) as a list of ``(x, y)``: cells (``parse_xy``) or,
    with ``parse=parse_point``, metres."""

    items = []
    for part in text.replace(" ", "").split(";"):
        if part:
            try:
                items.append((parse or parse_xy)(part))
            except argparse.ArgumentTypeError as e:
                raise ParameterError(f"{option}: {e}") from None
    return items


def parse_window(text: str) -> int | str | None:
    """``--window``: ``auto`` (default), ``none`` (the whole map) or a side in cells."""
    if text in ("auto", "none"):
        return None if text == "none" else "auto"
    try:
        return ascii_int(text)
    except ValueError:
        raise JaxgaError(f"--window must be auto, none or a side in cells, got {text!r}") \
            from None


def parse_int_list(text: str) -> list[int]:
    try:
        return [ascii_int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise JaxgaError(f"expected integers separated by commas, got {text!r}") from None


SIZE_CLASS_HELP = ("pad the map with blocked cells to its size class (each side "
                   f"{', '.join(map(str, CLASS_SIDES[:-1]))} or {CLASS_SIDES[-1]} cells) so "
                   "that maps of one class share compiled "
                   "programs; default: on for maps with a side over 64, off for smaller ones "
                   "(the papers' maps keep their shapes); results are the map's (decision "
                   "030)")


EXACT_HELP = ("compute the exact any-angle optimum whatever it costs (default: within the "
              "GA's own time; beyond it the gap is to a proven lower bound)")
