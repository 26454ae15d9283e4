"""Runs per second and individual-generations per second of the presets (first part of
the engine issue's speed benchmark; the NumPy loop baseline is not written yet).

    python benchmarks/speed.py [--presets sga,imga] [--seeds 1,100] [--generations G]
"""

from __future__ import annotations

import argparse
import resource

from _results import append, markdown_table

from jaxga.api import run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default="sga")
    ap.add_argument("--seeds", default="1,100")
    ap.add_argument("--map", default="classic_ga_gapp3_20x20")
    ap.add_argument("--generations", type=int, default=None)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows = []
    for preset in args.presets.split(","):
        for n in (int(s) for s in args.seeds.split(",")):
            r = run(preset, args.map, seeds=n, generations=args.generations)
            t = r.timing
            per_run = t["init_s"] + t["evolve_s"] + t["post_s"]
            ind_gen = n * r.population * r.generations / t["evolve_s"]
            rows.append([preset, n, r.population, r.generations, t["compile_s"],
                         t["init_s"], t["evolve_s"], n / per_run, f"{ind_gen:,.0f}",
                         f"{r.success.mean():.2f}"])
            print(rows[-1], flush=True)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    body = (f"Map {args.map}; times in seconds after compilation.\n\n"
            + markdown_table(["preset", "seeds", "population", "generations", "compile",
                              "init", "evolve", "runs/s", "ind-gen/s (evolve)", "success"],
                             rows)
            + f"\n\nPeak resident memory of the process: {peak:,.0f} MiB.")
    append("speed (engine, work in progress)", body, write=not args.no_write)


if __name__ == "__main__":
    main()
