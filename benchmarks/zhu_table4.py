"""Zhu & Pan (2024) Table 4 side by side: their IGA and GA rows against jaxga's presets.

    python benchmarks/zhu_table4.py [--seeds 30]

The paper runs each algorithm 30 times on its Map 3 and Map 4 (popnum 200, 50
generations, Table 3; squeezing between diagonal obstacles allowed, i.e. corner rule
``free``) and reports mean, sd and minimum of the path length. jaxga's
``classic_ga_gapp3_20x20`` and ``routeplanning_yangbo_20x20`` have exactly those optima
(30.9706 and 30.3848). Rows: ``iga_zhu`` (the preset) and ``sga`` with its ``iga_zhu``
variant (Table 3's GA row: popnum 200, 50 generations, pc 0.8, pm 0.4).
"""

from __future__ import annotations

import argparse

import numpy as np
from _results import append, markdown_table

from jaxga.api import run

PAPER = {  # Zhu & Pan 2024, Table 4: (mean, sd, min) of the path length
    ("iga_zhu", "classic_ga_gapp3_20x20"): (31.0096, 0.1486, 30.9706),
    ("iga_zhu", "routeplanning_yangbo_20x20"): (30.5215, 0.4533, 30.3848),
    ("sga", "classic_ga_gapp3_20x20"): (34.3555, None, None),
    ("sga", "routeplanning_yangbo_20x20"): (37.1787, None, None),
}
MAP_LABEL = {"classic_ga_gapp3_20x20": "Map 3", "routeplanning_yangbo_20x20": "Map 4"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows = []
    for (preset, name), (p_mean, p_sd, p_min) in PAPER.items():
        variant = "iga_zhu" if preset == "sga" else None
        r = run(preset, name, seeds=args.seeds, variant=variant, corner_rule="free")
        ok = r.success
        lengths = r.length[ok]
        rows.append([
            preset + (" (variant iga_zhu)" if variant else ""),
            f"{MAP_LABEL[name]} = {name}", f"{r.optimum:.4f}",
            f"{p_mean:.4f}", "-" if p_sd is None else f"{p_sd:.4f}",
            "-" if p_min is None else f"{p_min:.4f}",
            f"{lengths.mean():.4f}", f"{lengths.std(ddof=1):.4f}", f"{lengths.min():.4f}",
            f"{np.mean(np.isclose(lengths, r.optimum, atol=1e-3)) * 100:.0f}",
            f"{int(ok.sum())}/{len(ok)}",
            f"{np.mean(r.convergence_generation[ok]):.1f}",
            f"{(r.timing['init_s'] + r.timing['evolve_s'] + r.timing['post_s']) / len(ok):.3f}",
        ])
        print(rows[-1], flush=True)
    body = (
        f"{args.seeds} seeds per row; corner rule free; lengths of the returned path "
        "(8-connected; Zhu & Pan's IGA has no any-angle post-optimisation).\n\n"
        + markdown_table(["algorithm", "map", "exact optimum", "paper mean", "paper sd",
                          "paper min", "jaxga mean", "jaxga sd", "jaxga min", "% optimal",
                          "success", "mean conv. gen", "s per run (after compile)"], rows)
    )
    append("Zhu & Pan Table 4 side by side", body, write=not args.no_write)


if __name__ == "__main__":
    main()
