"""Time the post-optimisation of long continuous paths (1000+ cells) on 500 x 500 maps.

What it measures: ``shortcut_optimal`` (post.method of the hybrid preset) on 8 paths in
one compiled, vmapped call, and the whole ``finish`` program of 8 runs of the hybrid
preset on the same 8 best paths (post-optimisation, the metrics of the raw and
post-optimised paths, the feasibility check: what ``jaxga run`` reports as "post").
Both are compiled first (with the finish program's XLA options), then timed warm: the
median of ``--repeats`` calls.

Maps: a ROS map given by ``--ros-map`` (``/work/rosmaps/small_house/map.yaml`` is the
500 x 500 house map, loaded with a 0.2 m robot radius and the start and goal of
``--start-world``/``--goal-world``) and a synthetic 500 x 500 maze made here
(:func:`jaxga.maps.generators.maze_map`, corridors 30 cells wide, walls 8), whose
8-connected optimum has 1375 cells. Paths (:func:`long_paths`): the 8-connected optimum
when it has at least ``--min-cells`` cells, then detours through random free cells,
kept when they have ``--min-cells`` to twice as many cells: long continuous loop-free
paths of optimal legs, as a GA's best path looks before post-optimisation, only longer.
The capacity is the one a run on that map uses
(:func:`jaxga.engine.algorithm.default_capacity`), or the size class of the longest
path if that is larger (the house map's runs have 1280 cells).

Columns: path cells (min-max over the 8), corner nodes of the input (turns + 2
endpoints), waypoints and collinear interior waypoints after ``shortcut_optimal`` and
after the papers' greedy pass, mean lengths (cell units).

    PYTHONPATH=. python benchmarks/post_long_paths.py \\
        --ros-map /work/rosmaps/small_house/map.yaml [--no-write]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from _results import markdown_table, record

from jaxga._runtime.programs import FINISH_COMPILER_OPTIONS
from jaxga.config.presets import load_preset
from jaxga.core.grid import Grid
from jaxga.core.objectives import path_length
from jaxga.core.paths import from_coords
from jaxga.engine import build, default_params
from jaxga.engine.algorithm import capacity_class, default_capacity
from jaxga.engine.evolution import GAState, finish
from jaxga.engine.maptables import with_tables
from jaxga.maps import load_map_info
from jaxga.maps.generators import maze_map
from jaxga.operators.postprocess import shortcut_greedy, shortcut_optimal
from jaxga.reference.optima import distances_from, shortest_path_np

PATHS = 8


def _detour(grid: Grid, free: np.ndarray, min_cells: int,
            rng: np.random.Generator) -> np.ndarray | None:
    """A continuous loop-free start-goal path through random via cells, or None.

    Each leg is the 8-connected optimum to the next via cell (at least 100 cells away;
    the goal once the legs hold ``0.8 * min_cells`` cells) on the map with the cells of
    the earlier legs blocked: the path never meets itself, and every step stays legal
    on the map (more blocked cells only forbid moves)."""
    used, rule = grid.blocked_np().copy(), grid.corner_rule
    legs, here, cells = [np.asarray([grid.start_xy])], grid.start_xy, 1
    for _ in range(10):
        if cells >= 0.8 * min_cells:
            break
        via = tuple(int(v) for v in free[rng.integers(len(free))])
        if np.hypot(via[0] - here[0], via[1] - here[1]) < 100 or used[via[1], via[0]]:
            continue
        used[here[1], here[0]] = False
        leg = shortest_path_np(used, here, via, rule)
        used[here[1], here[0]] = True
        if leg.found:
            used[leg.path[:, 1], leg.path[:, 0]] = True
            legs.append(leg.path[1:])
            cells += len(leg.path) - 1
            here = via
    used[here[1], here[0]] = False
    leg = shortest_path_np(used, here, grid.goal_xy, rule)
    return np.concatenate([*legs, leg.path[1:]]) if leg.found else None


def long_paths(grid: Grid, n: int, min_cells: int, seed: int) -> list[np.ndarray]:
    """``n`` continuous loop-free start-goal paths of ``min_cells`` to ``2 * min_cells``
    cells: the 8-connected optimum if it is long enough, then :func:`_detour` paths."""
    best = shortest_path_np(grid.blocked_np(), grid.start_xy, grid.goal_xy,
                            grid.corner_rule).path
    out = [best] if min_cells <= len(best) <= 2 * min_cells else []
    rng = np.random.default_rng(seed)
    free = np.argwhere(np.isfinite(distances_from(grid, grid.start_xy)))[:, ::-1]
    for _ in range(20 * n):
        if len(out) >= n:
            break
        path = _detour(grid, free, min_cells, rng)
        if path is not None and min_cells <= len(path) <= 2 * min_cells:
            out.append(path)
    if len(out) < n:
        raise RuntimeError(f"found {len(out)} paths of {min_cells}+ cells, not {n}")
    return out


def _compiled(fn, *args):
    """``fn`` jitted and compiled for ``args`` with the finish program's XLA options."""
    return jax.jit(fn).lower(*args).compile(FINISH_COMPILER_OPTIONS)


def _median_seconds(fn, args: tuple, repeats: int) -> float:
    jax.block_until_ready(fn(*args))
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(fn(*args))
        ts.append(time.perf_counter() - t)
    return float(np.median(ts))


def _corners(cells: np.ndarray, n: int, width: int) -> tuple[int, int]:
    """(nodes where the direction changes, plus the two endpoints; interior nodes on a
    straight line through their neighbours) of one path."""
    xy = np.stack([cells[:n] % width, cells[:n] // width], axis=1).astype(np.int64)
    if n < 3:
        return n, 0
    d1, d2 = xy[1:-1] - xy[:-2], xy[2:] - xy[1:-1]
    collinear = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] == 0
    return int(n - np.sum(collinear & (np.sum(d1 * d2, axis=1) > 0))), int(np.sum(collinear))


def finish_program(grid: Grid, capacity: int):
    """The hybrid preset's finish for a batch of best paths ``(cells [R, L], length [R])``."""
    config = load_preset("hybrid").override({"population.capacity": capacity})
    algo, _ = build(config, grid)
    params = default_params(config)

    def run(grid, cells, length):
        def one(c, n):
            state = GAState(islands=None, best_cells=c, best_length=n,
                            best_fitness=jnp.float32(1.0), generation=jnp.int32(0),
                            stall=jnp.int32(0), frozen=jnp.bool_(False),
                            failures=jnp.zeros(3, jnp.int32))
            return finish(algo, grid, state, None, params)

        return jax.vmap(one)(cells, length)

    return run


def measure(name: str, grid: Grid, args: argparse.Namespace) -> list:
    """One table row: build the paths, time the calls, count the waypoints."""
    paths = long_paths(grid, PATHS, args.min_cells, args.seed)
    capacity = max(default_capacity(grid), capacity_class(max(len(p) for p in paths)))
    cells, lengths = zip(*(from_coords(p, grid.width, capacity) for p in paths))
    cells, lengths = jnp.stack(cells), jnp.stack(lengths)
    batched = jax.vmap(shortcut_optimal, in_axes=(None, 0, 0))
    opt_fn = _compiled(batched, grid, cells, lengths)
    opt_s = _median_seconds(opt_fn, (grid, cells, lengths), args.repeats)
    tables = with_tables(grid)
    fin_fn = _compiled(finish_program(grid, capacity), tables, cells, lengths)
    fin_s = _median_seconds(fin_fn, (tables, cells, lengths), args.repeats)

    lengths_of = jax.jit(jax.vmap(path_length, in_axes=(None, 0, 0)))
    opt_c, opt_n = jax.device_get(opt_fn(grid, cells, lengths))
    gr_c, gr_n = jax.device_get(jax.jit(jax.vmap(shortcut_greedy, in_axes=(None, 0, 0)))(
        grid, cells, lengths))
    w = grid.width
    raw = [_corners(c, n, w)[0] for c, n in zip(np.asarray(cells), np.asarray(lengths))]
    opt = [_corners(c, n, w)[1] for c, n in zip(opt_c, opt_n)]
    greedy = [_corners(c, n, w)[1] for c, n in zip(gr_c, gr_n)]
    opt_len = np.asarray(lengths_of(grid, opt_c, opt_n))
    gr_len = np.asarray(lengths_of(grid, gr_c, gr_n))
    n_cells = np.asarray(lengths)
    return [name, capacity, f"{n_cells.min()}-{n_cells.max()}", opt_s, fin_s,
            f"{np.mean(raw):.1f}",
            f"{np.mean(opt_n):.1f} / {np.mean(gr_n):.1f}", f"{sum(opt)} / {sum(greedy)}",
            f"{opt_len.mean():.2f} / {gr_len.mean():.2f}"]


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark, print the table and record it in ``RESULTS.md``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ros-map", help="a 500 x 500 ROS map_server .yaml "
                    "(/work/rosmaps/small_house/map.yaml); left out: the maze only")
    ap.add_argument("--start-world", default="9.075,2.875", help="ROS map start, metres")
    ap.add_argument("--goal-world", default="-9.075,-5.275", help="ROS map goal, metres")
    ap.add_argument("--robot-radius", type=float, default=0.2, help="metres")
    ap.add_argument("--min-cells", type=int, default=1000, help="shortest path kept")
    ap.add_argument("--seed", type=int, default=0, help="seed of the detours' via cells")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-write", action="store_true", help="do not record in RESULTS.md")
    args = ap.parse_args(argv)

    maps = []
    if args.ros_map:
        start = tuple(float(v) for v in args.start_world.split(","))
        goal = tuple(float(v) for v in args.goal_world.split(","))
        info = load_map_info(args.ros_map, robot_radius=args.robot_radius,
                             start_world=start, goal_world=goal)
        label = Path(args.ros_map).resolve().parent.name  # small_house/map.yaml: small_house
        maps.append((f"ROS {label} {info.grid.width}x{info.grid.height}", info.grid))
    maps.append(("maze 500x500 (corridor 30, wall 8, seed 1)",
                 maze_map(500, 500, 1, corridor_width=30, wall_width=8, corner_rule="strict")))
    rows = [measure(name, grid, args) for name, grid in maps]
    headers = ["map", "capacity", "path cells", f"shortcut_optimal, {PATHS} paths (s)",
               f"finish, {PATHS} runs (s)", "input corners", "waypoints optimal / greedy",
               "collinear waypoints optimal / greedy", "length optimal / greedy"]
    table = markdown_table(headers, rows)
    print(table)
    record(
        "post_long_paths: post-optimising 8 long continuous paths on 500 x 500 maps",
        f"{PATHS} continuous paths of {args.min_cells}+ cells per map (the 8-connected "
        "optimum when long enough, then detours through random free cells), corner rule "
        "strict, capacity of a run on the map (or the longest path's size class). "
        "Seconds: median of "
        f"{args.repeats} warm calls of one compiled program: shortcut_optimal vmapped "
        "over the paths, and the hybrid preset's whole finish program (post-optimisation, "
        "metrics of the raw and post paths, feasibility). Waypoint columns: means over "
        "the paths (collinear: totals).\n\n" + table,
        write=not args.no_write,
    )


if __name__ == "__main__":
    main()
