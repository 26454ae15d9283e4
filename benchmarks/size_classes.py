"""Size classes: runs on maps padded to their class against the same runs unpadded.

    python benchmarks/size_classes.py [--presets sga,imga,...] [--seeds 30] [--no-write]

For every preset and map (the papers' ``classic_ga_gapp3_20x20``, random 25 x 25 and
50 x 50 maps with 20 % obstacles from corner to corner), the same seeds with the preset's
own generations, once on the map (``jaxga.run``) and once padded to its size class
(``size_class=True``, :mod:`jaxga._runtime.size_classes`), all in one process. Reported:
whether every seed gave the same result bit for bit, success rates, mean post-optimised
lengths and the two-sided Mann-Whitney p-value of the lengths (what the padding may
change: which paths the seeds find; what it must not: feasibility and the lengths'
distribution), the path capacities, and the seconds of compilation and of evolution
(the padding's cost: a larger map and, on small maps, a larger capacity).
"""

from __future__ import annotations

import argparse

import numpy as np
from _results import PRESETS, markdown_table, record
from scipy.stats import mannwhitneyu

MAPS = ("classic_ga_gapp3_20x20", "random:25", "random:50")


def grid_of(spec: str):
    from jaxga.maps import load_map
    from jaxga.maps.generators import random_map

    if not spec.startswith("random:"):
        return load_map(spec)
    n = int(spec.split(":")[1])  # random_map redraws until the goal is reachable
    return random_map(n, n, 0.2, seed=3, start=(0, 0), goal=(n - 1, n - 1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default=",".join((*PRESETS, "hybrid")))
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()

    import jaxga

    rows = []
    for preset in args.presets.split(","):
        for spec in MAPS:
            grid = grid_of(spec)
            plain = jaxga.run(preset, grid, seeds=args.seeds)
            padded = jaxga.run(preset, grid, seeds=args.seeds, size_class=True)
            same = all(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
                       for a, b in ((plain.cells, padded.cells),
                                    (plain.n_cells, padded.n_cells),
                                    (plain.fitness, padded.fitness),
                                    (plain.history["best"], padded.history["best"])))
            a, b = (r.length[r.success] for r in (plain, padded))
            p = mannwhitneyu(a, b).pvalue if len(a) and len(b) and not same else float("nan")
            rows.append([preset, spec.replace(":", " "), "yes" if same else "no",
                         f"{plain.success.mean():.2f} / {padded.success.mean():.2f}",
                         f"{np.mean(a):.2f} / {np.mean(b):.2f}" if len(a) and len(b) else "-",
                         "-" if same else f"{p:.2f}",
                         f"{plain.path_capacity} / {padded.path_capacity}",
                         f"{plain.timing['compile_s']:.1f} / {padded.timing['compile_s']:.1f}",
                         f"{plain.timing['evolve_s']:.2f} / {padded.timing['evolve_s']:.2f}"])
            print(rows[-1], flush=True)
    body = (
        f"{args.seeds} seeds (0..{args.seeds - 1}) per preset and map, the preset's own "
        "generations, the map's corner rule (free on the classic map, strict on the random "
        "ones); each pair is unpadded / padded to the size class. same = every seed's paths, "
        "lengths, fitness and best-fitness history identical; p = two-sided Mann-Whitney "
        "p-value of the successful seeds' post-optimised lengths; capacity = path "
        "capacity; compile s and evolve s = `timing` (one process, in the table's "
        "order; the classic map's corner rule differs from the random maps', so each "
        "compiles its own programs).\n\n"
        + markdown_table(["preset", "map", "same", "success", "mean length", "p",
                          "capacity", "compile s", "evolve s"], rows)
    )
    record("size classes: padded against unpadded runs (benchmarks/size_classes.py)", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
