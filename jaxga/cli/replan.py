"""``jaxga replan``: a path re-planned around new obstacles (:mod:`jaxga.replan`)."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

import numpy as np

from jaxga import export
from jaxga._runtime.compilation_cache import configure
from jaxga._runtime.timeline import time_line
from jaxga.cli.options import (
    EXIT_NO_PATH,
    MAP_HELP,
    RULE_DEFAULT,
    add_coarsen_argument,
    add_source_arguments,
    load_info,
    parse_obstacles,
    parse_point,
    parse_window,
    parse_xy,
    preset_rule,
    write_json,
)
from jaxga.cli.outputs import write_empty_path
from jaxga.cli.run import process_timeline
from jaxga.config.presets import parse_set
from jaxga.config.schema import normalised
from jaxga.core.errors import JaxgaError, ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import CORNER_RULES, as_integer, check_corner_rule
from jaxga.maps.frame import cells_crossed
from jaxga.maps.inputs import PATH_JSON_CAP, json_value, read_input
from jaxga.maps.preprocess import block_middle_cells
from jaxga.plot import (
    plot_replan,
)
from jaxga.reference.optima import clear_np
from jaxga.replan import DEFAULT_GENERATIONS, DEFAULT_POPULATION, replan


def number_or_inf(value: object) -> float:
    """A run's ``raw_length`` for ordering: anything that is not a finite number sorts last."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return float("inf")
    try:
        return float(value) if math.isfinite(value) else float("inf")
    except OverflowError:  # an integer too large for a float
        return float("inf")


def read_path_json(path: str, run_index: int | None, raw: bool = False,
                   frame: Any = None) -> list[tuple[int, int]]:
    """The robot's path from a JSON file: a list of ``[x, y]``, an object with a
    ``"path"`` list (``jaxga optimum --json``), or the JSON of ``jaxga run``: the path of
    run ``run_index`` (default the successful run with the shortest path) the robot was
    given, post-optimised (``--path-out`` writes it), or with ``raw`` the GA's raw
    8-connected path. Read only from a regular file of at most
    :data:`jaxga.maps.inputs.PATH_JSON_CAP` bytes (:func:`jaxga.maps.inputs.read_input`):
    a FIFO, a device or a larger file is refused in one line.

    ``frame``: the :class:`~jaxga.maps.frame.MapFrame` the replan plans on. The cells of
    a JSON that records its own frame (``jaxga run`` and ``jaxga optimum`` do) are
    planning cells of THAT frame: a path planned with another ``--coarsen`` is converted
    to this one's cells (:func:`recorded_cells`), one planned on a map of another size is
    refused."""

    try:
        text = read_input(path, PATH_JSON_CAP, what="path JSON file", error=ParameterError,
                         note="1 KiB a cell of the largest map jaxga plans on")
    except FileNotFoundError:
        raise ParameterError(f"{path}: path JSON file not found") from None
    except OSError as e:
        raise ParameterError(f"{path}: cannot read the path JSON file "
                             f"({e.strerror or e})") from None
    try:
        data = json_value(text.decode("utf-8"))
    except ValueError as e:  # UnicodeDecodeError, JSONDecodeError, a key twice, nesting
        raise ParameterError(f"{path}: not valid JSON ({e})") from None
    expected = (f"{path}: expected a list of [x, y] cells, an object with a \"path\" list, "
                "or the JSON of `jaxga run`")
    which = "raw_path" if raw else "path"
    recorded = data.get("frame") if isinstance(data, dict) else None
    if isinstance(data, dict) and "runs" in data:
        runs = data["runs"]
        if not (isinstance(runs, list) and all(isinstance(r, dict) for r in runs)):
            raise ParameterError(f"{expected} (its \"runs\" must be a list of objects)")
        if run_index is not None:
            if not 0 <= run_index < len(runs):
                raise ParameterError(f"{path}: --run {run_index} is outside 0..{len(runs) - 1}")
            run = runs[run_index]
        else:
            ok = [r for r in runs if r.get("success") and r.get(which)]
            if not ok:
                raise ParameterError(f"{path}: no successful run with a path")
            run = min(ok, key=lambda r: number_or_inf(
                r.get("raw_length" if raw else "length")))
        data = run.get(which)
    elif isinstance(data, dict):
        data = data.get("path")
    try:  # integers only: 0.9 is not cell 0
        cells = [(as_integer(x), as_integer(y)) for x, y in data]
    except (TypeError, ValueError):
        raise ParameterError(f"{expected} (cells are pairs of integers)") from None
    if not cells:
        raise ParameterError(f"{path}: the path is empty")
    return recorded_cells(cells, recorded, frame, path)


def given_budget(args: argparse.Namespace) -> dict[str, int]:
    """``replan``'s ``generations`` and ``population``: replan's defaults where the
    command line leaves them out (a ``--set`` of the key then wins), the values given
    otherwise; a value given both as an option and by ``--set`` differently is refused
    in one line (at its default, the option would otherwise give way without a word)."""
    out = {"generations": DEFAULT_GENERATIONS, "population": DEFAULT_POPULATION}
    for name, key in (("generations", "generations"), ("population", "population.size")):
        given = getattr(args, name)
        if given is None:
            continue
        for text in args.set or ():
            set_key, value = parse_set(text)
            if set_key == key and normalised(key, value) != normalised(key, given):
                raise ParameterError(f"{key} is given twice, as {given!r} (--{name}) and "
                                     f"{shown_value(value)} (--set)")
        out[name] = given
    return out


MAX_COARSENING = 2 ** 20
"""The largest coarsening a path file's frame may record: map cells a side per planning
cell, beyond any map jaxga reads (its cells are converted with 64-bit integers)."""


def recorded_cells(cells: list[tuple[int, int]], recorded: Any, frame: Any,
                   path: str) -> list[tuple[int, int]]:
    """``cells``, planning cells of the frame a JSON ``recorded`` (its ``"frame"``: the
    map's shape and coarsening), as planning cells of ``frame``: each cell's centre
    (:meth:`~jaxga.maps.frame.MapFrame.map_cell`) in the cell of ``frame`` holding it,
    repeats dropped. A map of another shape is refused; without a recorded frame the
    cells are taken as they are."""
    if not isinstance(recorded, dict):
        return cells
    try:  # integers as jaxga writes them: 2.9, "2" and true are not a coarsening
        was = as_integer(recorded.get("coarsen", 1))
        shape = tuple(as_integer(v) for v in recorded["map_shape"]) \
            if "map_shape" in recorded else None
    except (TypeError, ValueError):
        raise ParameterError(f"{path}: its \"frame\" is not jaxga's (coarsen, "
                             "map_shape: integers)") from None
    now = 1 if frame is None else frame.coarsen
    if frame is not None and shape is not None and shape != tuple(frame.map_shape):
        raise ParameterError(
            f"{path} was planned on a map of {shape[1]} x {shape[0]} cells, --map has "
            f"{frame.map_shape[1]} x {frame.map_shape[0]}: give the map it was planned on")
    if not 1 <= was <= MAX_COARSENING:
        raise ParameterError(f"{path}: its frame's coarsening {was} is not an integer "
                             f"from 1 to {MAX_COARSENING}")
    if was == now:
        return cells
    c = np.asarray(cells, np.int64)
    middle = c * was + was // 2 if shape is None else block_middle_cells(c, was, shape)
    out: list[tuple[int, int]] = []
    for x, y in (middle // now).tolist():
        if not out or out[-1] != (x, y):
            out.append((x, y))
    print(f"note: {path} was planned {was} x {was} map cells a planning cell, this replan "
          f"{now} x {now}: its cells converted (each cell's centre)", file=sys.stderr)
    return out


def cmd_replan(args: argparse.Namespace) -> int:
    """``jaxga replan``: re-plan a path around new obstacles from the robot's cell
    (MPMGA 5.2.1 / 5.3.1). The path's own ends are its endpoints (never the map's
    defaults); new obstacles grow like the map (``--inflate`` / ``--robot-radius``)."""

    configure()
    timeline = process_timeline()
    if args.corner_rule is not None:
        check_corner_rule(args.corner_rule)
    rule = args.corner_rule or preset_rule(args)
    with timeline.phase("load"):
        info = load_info(args, rule)
        if args.path_out:  # refused before any work
            export.path_format(args.path_out)
            if info.frame is None or not info.frame.has_metres:
                raise JaxgaError(f"cannot write --path-out {args.path_out}: the map has no "
                                 "resolution (metres)")
        path = read_robot_path(args, info, rule)
    grid = info.grid
    obstacles = [xy for text in args.obstacles or () for xy in parse_obstacles(text)]
    for text in args.obstacles_world or ():
        obstacles += [info.frame.cell_of(p, grid.shape, "--obstacles-world point")
                      for p in parse_obstacles(text, "--obstacles-world", parse_point)]
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
        **given_budget(args),
        window=parse_window(args.window), plan_from=args.plan_from, post=args.post,
        fallback=args.fallback, variant=args.variant, sets=tuple(args.set or ()),
        inflate=inflation_cells(args, info),
    )
    timeline.add("replan", result.wall_s)
    print(result.summary())
    metres = result.metres_text(info.frame)
    if metres:
        print(metres)
    if args.path_out and result.success:
        with timeline.phase("write"):
            export.write_path(args.path_out, info.frame.to_world(np.asarray(result.path, float)),
                              decimals=info.frame.world_decimals)
        print(f"wrote {args.path_out} (metres)")
    elif args.path_out:
        write_empty_path(args)
    if args.json:
        with timeline.phase("write"):
            write_json(args.json, result.to_json(info.frame))
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


def read_robot_path(args: argparse.Namespace, info, rule: str) -> list[tuple[int, int]]:
    """The path the robot drives, in planning cells: from ``--path-json`` (cells), or from
    ``--path`` (metres, as ``jaxga run --path-out`` wrote it: each point in the cell
    holding it, repeats dropped; where the chord between two consecutive points' cells is
    not clear under ``rule`` on the map, the cells the path's own segment crosses are put
    between them, so a smoothed curve's corner the robot did not cut is not a blocked
    step)."""
    if (args.path_json is None) == (args.path is None):
        raise JaxgaError("give the robot's path once: --path-json FILE (cells) or --path "
                         "FILE.csv|FILE.yaml (metres, as --path-out wrote it)")
    if args.path_json is not None:
        return read_path_json(args.path_json, args.run, raw=args.raw, frame=info.frame)
    if args.run is not None or args.raw:
        raise JaxgaError("--run and --raw choose a run of jaxga run's JSON (--path-json), "
                         "not of a --path file")
    if info.frame is None or not info.frame.has_metres:
        raise JaxgaError(f"--path {args.path} is in metres: the map needs a resolution and "
                         "an origin (a ROS map_server .yaml)")
    blocked = info.grid.blocked_np()
    cells: list[tuple[int, int]] = []
    last = None
    points = export.read_path(args.path)
    if not len(points):
        raise JaxgaError(f"--path {args.path} holds no points (the path file of a run that "
                         "found no path): nothing to re-plan")
    for k, point in enumerate(points):
        cell = info.frame.cell_of(tuple(point), info.grid.shape, f"--path point {k}")
        here = info.frame.cell_coordinates(tuple(point))
        if cells and cells[-1] != cell and not clear_np(blocked, rule, cells[-1], cell):
            cells += [c for c in cells_crossed(last, here)[1:-1] if c != cells[-1]]
        if not cells or cells[-1] != cell:
            cells.append(cell)
        last = here
    return cells


def inflation_cells(args: argparse.Namespace, info) -> float:
    """The growth of the map's obstacles in planning cells (``--inflate`` cells or
    ``--robot-radius`` metres), which new obstacles get too; 0 without either."""
    k = info.frame.coarsen if info.frame is not None else 1
    if args.robot_radius is not None:
        return args.robot_radius / info.frame.resolution / k
    return (args.inflate or 0.0) / k


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``replan`` command to ``jaxga``'s parser."""
    p = commands.add_parser("replan", help="re-plan a path around new obstacles (MPMGA 5.2.1)")
    p.add_argument("--map", required=True, help=MAP_HELP)
    add_source_arguments(p)
    add_coarsen_argument(p)
    p.add_argument("--path-json", metavar="FILE",
                   help="the planned path in cells: a JSON list of [x, y], jaxga optimum's "
                   "JSON, or jaxga run's JSON (the post-optimised path the robot was given)")
    p.add_argument("--path", metavar="FILE.csv|FILE.yaml",
                   help="the path the robot drives in metres, as jaxga run --path-out wrote "
                   "it (instead of --path-json)")
    p.add_argument("--run", type=int, metavar="I", help="with jaxga run's JSON: the run to use "
                   "(default: the successful run with the shortest path)")
    p.add_argument("--raw", action="store_true", help="with jaxga run's JSON: the GA's raw "
                   "8-connected path instead of the post-optimised one")
    p.add_argument("--path-out", metavar="FILE.csv|FILE.yaml",
                   help="write the re-planned path in metres (a map with a resolution): x,y "
                   "rows or a nav_msgs/Path")
    p.add_argument("--obstacles", action="append", metavar="X,Y;X,Y...",
                   help="cells that became blocked (repeatable); they grow like the map "
                   "(--inflate, --robot-radius)")
    p.add_argument("--obstacles-world", action="append", metavar="X,Y;X,Y...",
                   help="points in metres that became blocked (a map with a resolution; "
                   "repeatable)")
    p.add_argument("--position", type=parse_xy, metavar="X,Y",
                   help="the robot's current cell on the path")
    p.add_argument("--position-world", type=parse_point, metavar="X,Y",
                   help="the robot's position in metres (the path cell holding it)")
    p.add_argument("--corner-rule", default=None, metavar="RULE",
                   help=f"one of {', '.join(CORNER_RULES)} (default: {RULE_DEFAULT})")
    p.add_argument("--preset", default="hybrid", help="the GA preset (default hybrid, whose "
                   "initialiser cannot fail where a detour exists; mpmga = the paper's)")
    p.add_argument("--variant", help="a preset variant")
    p.add_argument("--seeds", type=int, default=4, help="seeded GA runs (default 4)")
    p.add_argument("--generations", type=int, default=None,
                   help=f"GA generations (default {DEFAULT_GENERATIONS})")
    p.add_argument("--population", type=int, default=None,
                   help=f"population size, per island for island presets (default "
                   f"{DEFAULT_POPULATION})")
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
    p.add_argument("--quiet", action="store_true",
                   help="accepted as by run: a re-plan shows no progress bar")
    p.set_defaults(func=cmd_replan)
