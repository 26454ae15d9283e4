"""Latency of local re-planning in MPMGA's two scenarios (MPMGA 5.2.1 / 5.3.1).

For each scenario (25 x 25: obstacles at cells 320 and 345, robot at 295, re-plan to
370; 50 x 50: a 3 x 3 block at 810-812/860-862/910-912, robot at 759, re-plan to 963; the
maps are generated, see :func:`jaxga.replan.mpmga_scenario`) and each way of running the
GA (the whole map, or a 25 x 25 window around the re-planned part), this times the first
call (which compiles) and then ``--calls`` further calls with fresh seeds: the median,
min and max latency (wall time of ``jaxga.replan`` minus compilation), how many calls
found a segment, and the spliced path's length against the exact 8-connected optimum from
the robot's cell to the goal on the updated map. The paper's figures (Matlab R2018a) are
beside them: about 0.3-0.4 s (25 x 25) and under 1 s (50 x 50).

    python benchmarks/replan.py [--preset hybrid] [--calls 10] [--seeds 4]
                                [--generations 20] [--population 10] [--no-write]

The default preset is ``jaxga.replan``'s (hybrid); ``--preset mpmga`` times the paper's
own re-planning GA. Target: a median latency of at most 50 ms per re-plan in a
25 x 25 window on the 2-core machine, after compilation.
"""

from __future__ import annotations

import argparse
import os

import numpy as np
from _results import markdown_table, record

from jaxga.reference.optima import shortest_path_np
from jaxga.replan import DEFAULT_PRESET, mpmga_scenario, replan

PAPER = {"25x25": "about 0.3-0.4 s (5.2.1)", "50x50": "under 1 s (5.3.1)"}


def main() -> None:
    # no persistent cache, as the table says (the Python API turns one on by default)
    os.environ["JAXGA_CACHE_DIR"] = ""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--preset", default=DEFAULT_PRESET)
    ap.add_argument("--calls", type=int, default=10, help="timed calls after the first")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--generations", type=int, default=20)
    ap.add_argument("--population", type=int, default=10)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    s = args.seeds
    rows = []
    for name, window in (("25x25", None), ("50x50", None), ("50x50", 25)):
        sc = mpmga_scenario(name)
        blocked = sc.grid.blocked_np().copy()
        for x, y in sc.new_obstacles:
            blocked[y, x] = True
        exact = shortest_path_np(blocked, sc.position, sc.path[-1], sc.grid.corner_rule)

        def call(i: int, sc=sc, window=window):
            return replan(sc.grid, sc.path, sc.new_obstacles, sc.position, args.preset,
                          seeds=list(range(i * s, (i + 1) * s)),
                          generations=args.generations, population=args.population,
                          window=window)

        first = call(0)
        results = [call(i) for i in range(1, args.calls + 1)]
        lat = np.array([r.latency_s for r in results])
        ok = [r for r in results if r.success and not r.used_fallback]
        lengths = np.array([r.length for r in ok]) if ok else np.array([np.nan])
        ga_map = (f"{window} x {window} window" if window
                  else f"whole map ({sc.grid.width} x {sc.grid.height})")
        rows.append([
            f"{name}: {sc.position} -> {sc.rejoin}", ga_map, first.compile_s,
            first.latency_s, float(np.median(lat)), float(lat.min()), float(lat.max()),
            f"{len(ok)}/{len(results)}", f"{np.mean(lengths):.3f}",
            f"{exact.length:.3f}", PAPER[name],
        ])
    body = (
        f"`jaxga.replan` with preset {args.preset}, {s} seeds x {args.generations} "
        f"generations x population {args.population}"
        + (" per island (3 islands)" if args.preset == "mpmga" else "")
        + " in one compiled call; the "
        f"first call compiles (no persistent cache), then {args.calls} calls with fresh "
        "seeds. Latency = wall time of the call minus compilation (map checks, reachability "
        "flood fill, the GA's init / evolve / post-optimisation, the reference optima that "
        "`jaxga.run` computes, splicing and verification). The maps are generated so that "
        "the planned (exact shortest) path runs through the paper's cells "
        "(`jaxga.replan.mpmga_scenario`). The paper's times are Matlab R2018a on its own "
        "machine.\n\n"
        + markdown_table(
            ["scenario (robot -> rejoin)", "GA runs on", "compile (s)",
             "first call latency (s)", "median latency (s)", "min (s)", "max (s)",
             "segment found", "mean spliced length", "exact optimum robot -> goal",
             "paper (MPMGA)"], rows)
    )
    record(f"replan: local re-planning latency, MPMGA 5.2.1 / 5.3.1, preset "
           f"{args.preset}", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
