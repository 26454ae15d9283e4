"""Zhu & Pan (2024) Table 4 side by side: their IGA and GA rows against jaxga's presets.

    python benchmarks/zhu_table4.py [--seeds 30] [--fallback none|field_walk]

A paper reproduction: the papers' initialisers alone by default (``init.fallback =
none``).

The paper runs each algorithm 30 times on its Map 3 and Map 4 (popnum 200, 50
generations, Table 3; squeezing between diagonal obstacles allowed, i.e. corner rule
``free``) and reports mean and sd of the path length and of the smoothness, and the
minimum length. jaxga's ``classic_ga_gapp3_20x20`` and ``routeplanning_yangbo_20x20``
have exactly those length optima (30.9706 and 30.3848). Rows: ``iga_zhu`` (the preset)
and ``sga`` with its ``iga_zhu`` variant (Table 3's GA row: popnum 200, 50 generations,
pc 0.8, pm 0.4).

Two tables. The first is the paper's layout (length, and smoothness = eq. 8's
``fit_2``, the sum of the turn costs c1 / c2 / c3 = 1 / 2 / 3 that the paper's Table 4
reports for every algorithm). The second sets the IGA against the exact optimum of its
own fitness (eq. 6, ``jaxga.reference.fitness``): the value a perfect optimiser of the
paper's objective reaches, the length and smoothness of that path, how many seeds reach
it, and the cost ``omega * length + (1 - omega) * smoothness`` (1 / fitness) of jaxga's
runs and, computed from the paper's means, of the paper's.
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _results import markdown_table, record

from jaxga.api import run
from jaxga.core.objectives import zhu_penalty
from jaxga.maps import load_map
from jaxga.reference.fitness import fitness_optimum

PAPER = {  # Zhu & Pan 2024, Table 4: length mean, sd, min; smoothness mean, sd
    ("iga_zhu", "classic_ga_gapp3_20x20"): (31.0096, 0.1486, 30.9706, 8.9333, 2.2118),
    ("iga_zhu", "routeplanning_yangbo_20x20"): (30.5215, 0.4533, 30.3848, 9.0, 0.6948),
    ("sga", "classic_ga_gapp3_20x20"): (34.3555, 1.29, 33.799, 13.6, 3.5487),
    ("sga", "routeplanning_yangbo_20x20"): (37.1787, 3.7141, 33.5864, 20.0667, 5.5456),
}
MAP_LABEL = {"classic_ga_gapp3_20x20": "Map 3", "routeplanning_yangbo_20x20": "Map 4"}
OMEGA = 0.7  # Table 3


def smoothness(result, grid) -> np.ndarray:
    """Eq. 8 ``fit_2`` (turn costs 1 / 2 / 3) of every seed's returned path."""
    fn = jax.jit(jax.vmap(lambda c, n: zhu_penalty(grid, c, n)))
    return np.asarray(fn(jnp.asarray(result.cells), jnp.asarray(result.n_cells)), float)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--fallback", choices=("none", "field_walk"), default="none",
                    help="init.fallback (default none: the paper's initialiser alone, as "
                         "the reproduction)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows, opt_rows = [], []
    for (preset, name), (p_mean, p_sd, p_min, p_smooth, p_smooth_sd) in PAPER.items():
        variant = "iga_zhu" if preset == "sga" else None
        grid = load_map(name, corner_rule="free")
        r = run(preset, grid, seeds=args.seeds, variant=variant,
                sets=[f"init.fallback={args.fallback}"])
        ok = r.success
        lengths, smooth = r.length[ok], smoothness(r, grid)[ok]
        rows.append([
            preset + (" (variant iga_zhu)" if variant else ""),
            f"{MAP_LABEL[name]} = {name}", f"{r.optimum:.4f}",
            f"{p_mean:.4f}", f"{p_sd:.4f}", f"{p_min:.4f}",
            f"{lengths.mean():.4f}", f"{lengths.std(ddof=1):.4f}", f"{lengths.min():.4f}",
            f"{p_smooth:.4f}", f"{p_smooth_sd:.4f}",
            f"{smooth.mean():.4f}", f"{smooth.std(ddof=1):.4f}",
            f"{np.mean(np.isclose(lengths, r.optimum, atol=1e-3)) * 100:.0f}",
            f"{int(ok.sum())}/{len(ok)}",
            f"{np.mean(r.convergence_generation[ok]):.1f}",
            f"{(r.timing['init_s'] + r.timing['evolve_s'] + r.timing['post_s']) / len(ok):.3f}",
        ])
        print(rows[-1], flush=True)
        if preset != "iga_zhu":
            continue
        opt = fitness_optimum(grid, "iga_zhu")
        opt_cost = 1.0 / opt.fitness
        opt_smooth = (opt_cost - OMEGA * opt.length) / (1 - OMEGA)
        cost = OMEGA * lengths + (1 - OMEGA) * smooth
        opt_rows.append([
            f"{MAP_LABEL[name]} = {name}", f"{opt_cost:.4f}", f"{opt.length:.4f}",
            f"{opt_smooth:.0f}",
            f"{OMEGA * p_mean + (1 - OMEGA) * p_smooth:.4f}",
            f"{cost.mean():.4f}", f"{cost.min():.4f}",
            f"{np.mean(r.fitness_gap[ok] == 0) * 100:.0f}",
            f"{np.nanmean(r.fitness_gap[ok]) * 100:.2f}",
        ])
        print(opt_rows[-1], flush=True)
    body = (
        f"{args.seeds} seeds per row; corner rule free; length and smoothness of the "
        "returned path (8-connected; Zhu & Pan's IGA has no any-angle post-optimisation); "
        "smoothness = eq. 8 `fit_2` with c1, c2, c3 = 1, 2, 3 (Table 4's 'Average "
        "Smoothness').\n\n"
        + markdown_table(["algorithm", "map", "exact length optimum", "paper mean",
                          "paper sd", "paper min", "jaxga mean", "jaxga sd", "jaxga min",
                          "paper smoothness", "paper sd", "jaxga smoothness", "jaxga sd",
                          "% length-optimal", "success", "mean conv. gen",
                          "s per run (after compile)"], rows)
        + "\n\nThe IGA against the exact optimum of its own fitness (eq. 6, omega 0.7: cost "
        "= 1 / fitness = 0.7 length + 0.3 smoothness; `jaxga.reference.fitness`). The "
        "paper's cost is computed from its mean length and mean smoothness (a cost of "
        "means, close to the mean cost).\n\n"
        + markdown_table(["map", "optimal cost", "its length", "its smoothness",
                          "paper cost (from means)", "jaxga mean cost", "jaxga min cost",
                          "% seeds at the fitness optimum", "mean fitness gap %"],
                         opt_rows)
    )
    record("Zhu & Pan Table 4 side by side", body, write=not args.no_write)


if __name__ == "__main__":
    main()
