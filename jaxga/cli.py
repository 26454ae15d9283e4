"""The ``jaxga`` command line.

``jaxga optimum`` prints the exact 8-connected and any-angle optima of a map
(SPEC 11, reference optima); ``jaxga maps`` lists the built-in maps. Bad input (a missing
or malformed file, a start or goal off the map or blocked, an unreachable goal, an
unknown corner rule) ends with a one-line message on stderr and a non-zero exit status,
never a Python traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence

from jaxga.errors import EndpointError, JaxgaError, NoPathError
from jaxga.grid import CORNER_RULES
from jaxga.parallel import (
    EXIT_PROCESS_LOST,
    ProcessLostError,
    add_parallel_arguments,
    configure_from_args,
)

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


def _add_map_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--map", required=True, help="a map file (0/1 text, .map, ASCII, PNG) or a "
                   "built-in map name (see `jaxga maps`)")
    p.add_argument("--start", type=_parse_xy, metavar="X,Y",
                   help="start cell; x = column, y = row from the bottom (default: the "
                   "file's S or (0, 0))")
    p.add_argument("--goal", type=_parse_xy, metavar="X,Y",
                   help="goal cell (default: the file's G or (W-1, H-1))")
    p.add_argument("--corner-rule", default=None, metavar="RULE",
                   help=f"one of {', '.join(CORNER_RULES)} (default: strict)")


def _load_grid(args: argparse.Namespace):
    from jaxga.grid import check_corner_rule
    from jaxga.maps import load_map_info

    if args.corner_rule is not None:
        check_corner_rule(args.corner_rule)
    info = load_map_info(args.map, start=args.start, goal=args.goal, corner_rule=args.corner_rule)
    return info, info.grid.check_endpoints()


def _xy_list(path) -> list[list[int]]:
    return [[int(x), int(y)] for x, y in path]


def cmd_optimum(args: argparse.Namespace) -> int:
    """``jaxga optimum``: exact 8-connected and any-angle optima of one map."""
    from jaxga.reference import any_angle_shortest_path, shortest_path

    info, grid = _load_grid(args)
    t0 = time.perf_counter()
    octile = shortest_path(grid).raise_if_missing()
    t1 = time.perf_counter()
    any_angle = any_angle_shortest_path(grid).raise_if_missing()
    t2 = time.perf_counter()
    print(f"map          {info.name} ({grid.width} x {grid.height}, corner rule "
          f"{grid.corner_rule!r})")
    print(f"start, goal  {grid.start_xy} -> {grid.goal_xy}")
    print(f"8-connected  {octile.length:.4f}  ({octile.n_cells} cells, {t1 - t0:.3f} s)")
    print(f"any-angle    {any_angle.length:.4f}  ({any_angle.n_cells} waypoints, "
          f"{t2 - t1:.3f} s)")
    if args.json:
        out = {
            "map": info.name,
            "corner_rule": grid.corner_rule,
            "start": list(grid.start_xy),
            "goal": list(grid.goal_xy),
            "length": float(octile.length),
            "path": _xy_list(octile.path),
            "any_angle_length": float(any_angle.length),
            "any_angle_path": _xy_list(any_angle.path),
        }
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(out, f)
            f.write("\n")
        print(f"wrote {args.json}")
    return 0


def cmd_maps(args: argparse.Namespace) -> int:
    """``jaxga maps``: list the built-in maps with their sizes."""
    from jaxga.maps import builtin_names, builtin_scenario_path, load_map

    for name in builtin_names():
        g = load_map(name)
        scen = " (with scenarios)" if builtin_scenario_path(name) else ""
        print(f"{name:44s} {g.width:4d} x {g.height:<4d}{scen}")
    return 0


def cmd_presets(args: argparse.Namespace) -> int:
    """``jaxga presets``: list the presets with their papers."""
    from jaxga.presets import preset_info

    for name, paper, description in preset_info():
        print(f"{name:10s} {paper}")
        if description:
            print(f"{'':10s} {description}")
    return 0


class _Progress:
    """A one-line progress bar on stderr, shown only for runs longer than ~2 s."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()
        self.shown = False

    def __call__(self, stage: str, frac: float) -> None:
        if time.perf_counter() - self.t0 < 2.0 and frac < 1.0 and not self.shown:
            return
        self.shown = True
        bar = "#" * int(30 * frac)
        print(f"\r{stage:8s} [{bar:30s}] {100 * frac:5.1f}%", end="", file=sys.stderr,
              flush=True)
        if stage == "evolve" and frac >= 1.0:
            print(file=sys.stderr)


def cmd_run(args: argparse.Namespace) -> int:
    """``jaxga run``: many seeds of a preset on a map; summary table, JSON, plot."""
    from jaxga import parallel
    from jaxga.api import run

    lead = parallel.process_index() == 0
    progress = None if args.quiet or not lead else _Progress()
    result = run(
        args.preset, _grid_for_run(args), seeds=args.seeds, generations=args.generations,
        corner_rule=args.corner_rule, variant=args.variant, sets=args.set or (),
        progress=progress, chunks=10 if progress else 1,
    )
    if not lead:  # process 0 prints and writes the results of all processes
        print(f"process {parallel.process_index()} of {parallel.process_count()}: done "
              f"({len(result.seeds)} seeds; process 0 writes the results)")
        print("time (s): compile {compile_s:.2f}, total {total_s:.2f}".format(
            **result.timing), file=sys.stderr)
        return 0
    print(result.summary())
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(result.to_json(), f)
            f.write("\n")
        print(f"wrote {args.json}")
    if args.plot:
        from jaxga.plot import plot_result

        plot_result(result, _grid_for_run(args, rule=result.corner_rule), args.plot)
        print(f"wrote {args.plot}")
    if not result.success.any():
        print(f"jaxga: no path: {result.reason}", file=sys.stderr)
        return EXIT_NO_PATH
    return 0


def _grid_for_run(args: argparse.Namespace, rule: str | None = None):
    """The map as named on the command line (endpoints applied); the corner rule is the
    run's (the preset's unless --corner-rule)."""
    from jaxga.maps import load_map

    if args.start is None and args.goal is None and rule is None:
        return args.map
    return load_map(args.map, start=args.start, goal=args.goal,
                    corner_rule=rule or args.corner_rule or _preset_rule(args))


def _preset_rule(args: argparse.Namespace) -> str:
    from jaxga.presets import load_preset

    return load_preset(args.preset, variant=args.variant, sets=args.set or ())["map.corner_rule"]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``jaxga`` command."""
    parser = argparse.ArgumentParser(
        prog="jaxga", description="Genetic-algorithm path planning on grid maps, in JAX."
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("optimum", help="exact 8-connected and any-angle optima of a map")
    _add_map_arguments(p)
    p.add_argument("--json", metavar="OUT", help="write the optima and paths as JSON")
    p.set_defaults(func=cmd_optimum)

    p = sub.add_parser("run", help="run a preset on a map for many seeds")
    p.add_argument("--preset", required=True, help="a preset name (jaxga presets) or a TOML file")
    _add_map_arguments(p)
    p.add_argument("--variant", help="a preset variant, e.g. 50x50 for agacd")
    p.add_argument("--seeds", type=int, default=10, help="number of seeded runs (default 10)")
    p.add_argument("--generations", type=int, help="override the preset's generations")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration key, e.g. crossover.probability=0.7")
    p.add_argument("--json", metavar="OUT", help="write every run as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="plot the map, best paths and convergence")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_parallel_arguments(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("presets", help="list the presets and their papers")
    p.set_defaults(func=cmd_presets)

    p = sub.add_parser("maps", help="list the built-in maps")
    p.set_defaults(func=cmd_maps)
    return parser


def use_compilation_cache() -> str | None:
    """Turn on JAX's persistent compilation cache for the command line.

    ``$JAXGA_CACHE_DIR`` (default ``~/.cache/jaxga/jax``; empty to disable): a second
    ``jaxga run`` of the same preset on a map of the same size loads its compiled
    programs from disk instead of compiling them again (seconds instead of tens of
    seconds). Returns the directory used, or None.
    """
    import os
    from pathlib import Path

    path = os.environ.get("JAXGA_CACHE_DIR", str(Path.home() / ".cache" / "jaxga" / "jax"))
    if not path:
        return None
    import jax

    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``jaxga`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if hasattr(args, "devices"):  # subcommands with add_parallel_arguments
            configure_from_args(args)  # before JAX's backend starts
        if args.func is cmd_run:
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
