"""Does a generation cost more on a larger map? Time and memory per map size, one problem.

    python benchmarks/map_scale.py [--presets sga,...] [--sizes 32,64,128,256] [--seeds 8]
                                   [--generations 20]

The same problem on maps of growing area: random obstacles (15 %, ``random_map(N, N,
0.15, seed=1)``) with the start at (2, 2) and the goal at (29, 29) on N x N maps, N =
32 ... 256, and a fixed path capacity (``population.capacity = 160``). Only the map's
area changes, so a generation that does per-individual work proportional to the map's
area (a table of H x W entries per individual) shows up as growing time or memory.

Each (preset, size) runs in a fresh process (no compilation cache): evolution
milliseconds per generation per run, initialisation milliseconds per run, the XLA
temporary memory of the init and evolve programs (``memory_analysis()``), and the
process's peak resident memory. Prints the table and records it in RESULTS.md.
"""

from __future__ import annotations

import argparse
import json

from _results import PRESETS, cold_child, markdown_table, peak_rss_bytes, record


def child(spec: str) -> None:
    import gc

    import jaxga
    from jaxga import api
    from jaxga.maps.generators import random_map

    preset, size, seeds, generations = json.loads(spec)
    grid = random_map(size, size, 0.15, seed=1, start=(2, 2), goal=(29, 29))
    r = jaxga.run(preset, grid, seeds=seeds, generations=generations,
                  population__capacity=160)
    progs = [o for o in gc.get_objects() if isinstance(o, api.Programs)][-1]
    memory = {name: c.memory_analysis().temp_size_in_bytes / 2**20
              for name, c in progs._compiled.items()}
    print(json.dumps({
        "success": float(r.success.mean()),
        "evolve_ms": 1000 * r.timing["evolve_s"] / generations / seeds,
        "init_ms": 1000 * r.timing["init_s"] / seeds,
        "init_mb": memory["init"],
        "evolve_mb": max(v for k, v in memory.items() if k.startswith("evolve")),
        "rss_mb": peak_rss_bytes() / 2**20,
    }))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default=",".join((*PRESETS, "hybrid")))
    ap.add_argument("--sizes", default="32,64,128,256")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--generations", type=int, default=20)
    ap.add_argument("--child")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    rows = []
    for preset in args.presets.split(","):
        for size in map(int, args.sizes.split(",")):
            out, _ = cold_child(__file__, json.dumps([preset, size, args.seeds,
                                                      args.generations]))
            rows.append([preset, f"{size} x {size}", f"{out['success']:.2f}",
                         f"{out['evolve_ms']:.3f}", f"{out['init_ms']:.1f}",
                         f"{out['evolve_mb']:.1f}", f"{out['init_mb']:.1f}",
                         f"{out['rss_mb']:.0f}"])
            print(rows[-1], flush=True)
    body = (f"One problem, (2, 2) to (29, 29) on 15 % random maps of growing size, path "
            f"capacity 160, {args.seeds} seeds, {args.generations} generations, each cell in "
            "a fresh process. evolve = milliseconds per generation per run; init = "
            "milliseconds per run; MB = XLA temporary memory of the program (largest "
            "evolve program) and the process's peak resident memory.\n\n"
            + markdown_table(["preset", "map", "success", "evolve ms/gen/run",
                              "init ms/run", "evolve MB", "init MB", "peak RSS MB"], rows))
    record("time and memory per generation against map size (one problem)", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
