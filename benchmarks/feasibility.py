"""Every preset x the classic maps and two Moving AI maps, 100 seeds each: are all
returned paths feasible, how often is a path found, how far from the exact optimum?

    python benchmarks/feasibility.py [--presets sga,imga] [--maps ...] [--seeds 100]
                                     [--fallback none|field_walk]

A paper reproduction: the papers' initialisers alone by default (``init.fallback =
none``); ``--fallback field_walk`` gives the presets' defaults.

Classic 20 x 20 maps run under the papers' corner rule ``free`` with their usual
corners (0, 0) -> (19, 19). The Moving AI maps run under their own rule (``strict``, no
corner cutting) between the endpoints of the longest scenario of their ``.scen`` file.
Every returned path (raw and post-optimised) is checked independently of the engine with
``jaxga.reference.optima.clear_np`` (exact segment test under the corner rule).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _results import PRESETS as PAPER_PRESETS
from _results import markdown_table, record

from jaxga.api import run
from jaxga.maps import builtin_names, load_map_info
from jaxga.maps.builtin import builtin_scenarios
from jaxga.reference.optima import clear_np

MOVINGAI = ("random-32-32-20", "maze-32-32-2")


def grid_for(name: str):
    if name in MOVINGAI:
        scen = max(builtin_scenarios(name), key=lambda s: s.optimal_length)
        info = load_map_info(name, corner_rule="strict")
        return info.grid.replace(start=scen.start, goal=scen.goal), name
    return load_map_info(name, corner_rule="free").grid, name


def feasible(grid, path) -> bool:
    blocked = grid.blocked_np()
    return (len(path) > 0 and path[0] == grid.start_xy and path[-1] == grid.goal_xy
            and all(clear_np(blocked, grid.corner_rule, p, q) for p, q in zip(path, path[1:])))


def main() -> None:
    classic = [n for n in builtin_names() if "20x20" in n]
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default=",".join(sorted(PAPER_PRESETS)))
    ap.add_argument("--maps", default=",".join(classic + list(MOVINGAI)))
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--fallback", choices=("none", "field_walk"), default="none",
                    help="init.fallback (default none: the paper's initialiser alone, as "
                         "the reproduction)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows = []
    t_all = time.perf_counter()
    for preset in args.presets.split(","):
        for name in args.maps.split(","):
            grid, label = grid_for(name)
            r = run(preset, grid, seeds=args.seeds, sets=[f"init.fallback={args.fallback}"])
            bad = sum(not (feasible(grid, r.path(i)) and feasible(grid, r.path(i, raw=True)))
                      for i in np.flatnonzero(r.success))
            ok = r.success
            rows.append([
                preset, f"{label} ({grid.corner_rule})", f"{ok.mean():.2f}", bad,
                f"{r.optimum:.4f}", f"{np.nanmean(np.where(ok, r.raw_length, np.nan)):.4f}"
                if ok.any() else "-",
                f"{np.nanmean(r.raw_gap) * 100:.2f}" if ok.any() else "-",
                f"{r.any_angle_optimum:.4f}",
                f"{np.nanmean(np.where(ok, r.length, np.nan)):.4f}" if ok.any() else "-",
                f"{np.nanmean(r.gap) * 100:.2f}" if ok.any() else "-",
                f"{np.mean(r.fitness_gap[ok] == 0) * 100:.0f}"
                if ok.any() and np.isfinite(r.fitness_optimum) else "-",
                f"{np.nanmean(r.fitness_gap) * 100:.2f}"
                if ok.any() and np.isfinite(r.fitness_optimum) else "-",
                f"{np.mean(r.init_success_rate) * 100:.1f}",
                f"{r.timing['compile_s']:.1f}", f"{r.timing['total_s']:.1f}",
            ])
            print(rows[-1], flush=True)
    body = (
        f"{args.seeds} seeds per cell; preset parameters as published (20 x 20 settings). "
        "success = share of seeds returning a feasible path; infeasible = returned paths "
        "that fail the independent check (must be 0); raw = best path of the GA "
        "(8-connected for the grid-step presets, gap to the exact 8-connected optimum; "
        "AGACD's are waypoint paths, gap to the exact any-angle optimum: Result.raw_gap); "
        "post = after the preset's post-optimisation (none for sga), gap to the exact "
        "any-angle optimum (the lower bound of any path); fitness optimal = share of "
        "successful seeds whose best fitness equals the exact optimum of the preset's own "
        "fitness over 8-connected paths (`jaxga.reference.fitness`; none for AGACD's "
        "waypoint fitness), fitness gap = mean of optimum / fitness - 1; init = share of "
        "initialisation attempts that produced a path.\n\n"
        + markdown_table(["preset", "map (corner rule)", "success", "infeasible",
                          "8-conn optimum", "raw mean", "raw gap %", "any-angle optimum",
                          "post mean", "post gap %", "fitness optimal %",
                          "fitness gap %", "init success %", "compile s",
                          "total s"], rows)
        + f"\n\nWall time of the whole table: {time.perf_counter() - t_all:.0f} s."
    )
    record("feasibility, success and optimality gap of every preset", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
