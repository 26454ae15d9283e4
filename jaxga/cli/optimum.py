"""``jaxga optimum``: the exact optima of a map (decisions 015 and 031)."""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from jaxga._runtime.references import any_angle_references, octile_optimum
from jaxga.api import check_one_corner_rule, configured_rule
from jaxga.api.result_fronts import json_number
from jaxga.cli.options import (
    RULE_DEFAULT,
    add_map_arguments,
    load_grid,
    metres_text,
    parse_budget,
    world_ends,
    write_json,
    xy_list,
)
from jaxga.cli.run import Progress, process_timeline
from jaxga.config.presets import load_preset, parse_set
from jaxga.core.errors import JaxgaError
from jaxga.engine import check_file_keys_read, check_overrides_read
from jaxga.reference.fitness import fitness_optimum


def cmd_optimum(args: argparse.Namespace) -> int:
    """``jaxga optimum``: exact 8-connected and any-angle optima of one map, and with
    ``--preset`` the exact optimum of that preset's fitness. Each phase is shown on
    stderr as it starts, and one that runs on (an exact search on a large map) says
    every few seconds how long it has run (:class:`jaxga.cli.run.Progress`)."""
    progress = None if args.quiet else Progress().start()
    try:
        return _optimum(args, progress)
    finally:
        if progress is not None:
            progress.close()


def _optimum(args: argparse.Namespace, progress: Progress | None) -> int:
    """:func:`cmd_optimum`'s work, each phase shown on ``progress``."""

    def phase(label: str, name: str):
        if progress is not None:
            progress(label, 0.0)
        return timeline.phase(name)

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
    timeline = process_timeline()
    with phase("load", "load"):
        info, grid = load_grid(args)
    frame = info.frame
    with phase("8-connected", "references"):
        octile = octile_optimum(grid).raise_if_missing()
    with phase("any-angle", "any_angle"):
        bounds = any_angle_references(grid, octile, args.budget,
                                      None if progress is None
                                      else (lambda frac: progress("any-angle", frac)))
    fit, t_fit = None, 0.0
    if config is not None:  # before the results: the progress line ends first
        if progress is not None:
            progress("fitness", 0.0)
        t2 = time.perf_counter()
        fit = fitness_optimum(grid, config)
        t_fit = time.perf_counter() - t2
    if progress is not None:
        progress.close()  # its bar's line ended, its ticks stopped: the results follow
    print(f"map          {info.name} ({grid.width} x {grid.height} cells, corner rule "
          f"{grid.corner_rule!r}{'; ' + frame.describe() if frame.describe() else ''})")
    print(f"start, goal  cells {grid.start_xy} -> {grid.goal_xy}" + world_ends(frame, grid))
    print(f"8-connected  {octile.length:.4f}{metres_text(octile.length, frame)}  "
          f"({octile.n_cells} cells, {timeline.seconds['references']:.3f} s)")
    t_aa = timeline.seconds["any_angle"]
    if math.isfinite(bounds.optimum):
        print(f"any-angle    {bounds.optimum:.4f}{metres_text(bounds.optimum, frame)}  "
              f"({len(bounds.path)} waypoints, {t_aa:.3f} s)")
    else:
        print(f"any-angle    {bounds.note} ({t_aa:.3f} s); --budget 0 for no limit")
    if math.isfinite(bounds.lower_bound):
        print(f"lower bound  {bounds.lower_bound:.4f}{metres_text(bounds.lower_bound, frame)}  "
              "(Euclidean shortest path around the blocked cells, a proven bound of the "
              "any-angle optimum)")
    if fit is not None:
        label = f"fitness of {config['name']} ({config['fitness.method']})"
        if fit.found:
            print(f"{label}  {fit.fitness:.6g}  (a path of length {fit.length:.4f}, "
                  f"{len(fit.path)} cells{'' if fit.loop_free else ', not loop-free: a bound'}"
                  f", {t_fit:.3f} s)")
        else:
            print(f"{label}  not computed: {fit.reason}")
    if args.json:
        out = {
            "map": info.name,
            "corner_rule": grid.corner_rule,
            "start": list(grid.start_xy),
            "goal": list(grid.goal_xy),
            "length": float(octile.length),
            "path": xy_list(octile.path),
            "any_angle_length": json_number(bounds.optimum),
            "any_angle_path": xy_list(bounds.path),
            "any_angle_note": bounds.note,
            "lower_bound": json_number(bounds.lower_bound),
            "resolution": None if frame is None else frame.cell_size,
            "frame": None if frame is None else frame.to_json(),
        }
        if frame is not None and frame.has_metres:
            out["start_world"], out["goal_world"] = frame.world_list(
                np.array([grid.start_xy, grid.goal_xy], float))
            out["path_world"] = frame.world_list(np.asarray(octile.path, float))
            out["any_angle_path_world"] = (
                frame.world_list(np.asarray(bounds.path, float))
                if len(bounds.path) else [])
            # the lengths in metres too, as run's and replan's JSON give them
            out["length_m"] = json_number(float(octile.length) * frame.cell_size)
            out["any_angle_length_m"] = json_number(bounds.optimum * frame.cell_size)
        if fit is not None:
            out["fitness"] = {
                "preset": config["name"], "method": config["fitness.method"],
                "found": fit.found, "reason": fit.reason,
                "value": fit.fitness if fit.found else None,
                "length": fit.length if fit.found else None,
                "path": xy_list(fit.path),
                "loop_free": fit.loop_free if fit.found else None,
            }
        write_json(args.json, out)
    return 0


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``optimum`` command to ``jaxga``'s parser."""
    p = commands.add_parser("optimum", help="exact 8-connected and any-angle optima of a map")
    add_map_arguments(p, rule_default=RULE_DEFAULT)
    p.add_argument("--preset", help="also the exact optimum of this preset's fitness over "
                   "8-connected paths (not for agacd, whose fitness scores waypoint paths)")
    p.add_argument("--variant", help="a preset variant, e.g. 50x50 for agacd")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a preset key, e.g. fitness.omega=0.5")
    p.add_argument("--budget", type=parse_budget, default=None, metavar="SECONDS",
                   help="give the exact any-angle optimum at most this long (default: no "
                   "limit); beyond it the lower bound is reported")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--json", metavar="OUT", help="write the optima and paths as JSON")
    p.set_defaults(func=cmd_optimum)
