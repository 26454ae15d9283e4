"""AGACD's DOE (5.2.1, Tables 3-5, eq. 30-31) with jaxga: the five factors of its Table 3
(population, pc_low, pc_high, pm_low, pm_high) in its 9-run Table 4 design, 5 seeds per
point, preset agacd on a built-in 20 x 20 map, fitness maximised.

    nice -n 10 python benchmarks/doe_agacd.py [--seeds 5] [--generations G] [--no-write]
                                              [--fallback none|field_walk]

A paper reproduction: AGACD's initialiser alone by default (``init.fallback = none``).

Prints and appends to RESULTS.md: the table in the layout of AGACD Table 5 (coded
levels, real values, one column per seed, mean), the least-squares fit and AGACD's own
contrast estimate of eq. 30, main effects, the predicted best combination and its
confirmation run (next to the paper's 0.28995 predicted / 0.30684 measured) and the wall
time of the whole sweep. The 9 x 5 design runs are one compiled call; the confirmation
run is a second call of 5 runs (same population capacity, same seeds).
"""

from __future__ import annotations

import argparse
import os
import time

from _results import markdown_table, record

from jaxga.doe import AGACD_TABLE3, contrast_coefficients, predicted_best, run_doe

PAPER_EQ31 = (0.24416, 0.00673, 0.00847, -0.00841, 0.00594, 0.01624)
PAPER_BEST = (1, 1, -1, 1, 1)
PAPER_PREDICTED, PAPER_MEASURED = 0.28995, 0.30684


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--map", default="classic_ga_gapp3_20x20")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--generations", type=int, help="default: the preset's (300, Table 6)")
    ap.add_argument("--checkpoint", help="resumable run (see jaxga doe --checkpoint)")
    ap.add_argument("--fallback", choices=("none", "field_walk"), default="none",
                    help="init.fallback (default none: the paper's initialiser alone, as "
                         "the reproduction)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    r = run_doe("agacd", args.map, AGACD_TABLE3, "agacd-table4", seeds=args.seeds,
                sets=[f"init.fallback={args.fallback}"],
                generations=args.generations, checkpoint=args.checkpoint)
    wall = time.perf_counter() - t0
    print(r.report())
    names = [f.name for f in r.factors]
    short = [n.split(".")[-1] for n in names]
    rows = []
    for q, (row, vals, resp, m, ns) in enumerate(zip(r.coded, r.values, r.responses,
                                                      r.means, r.n_success)):
        rows.append([q + 1, *[int(c) for c in row], *[f"{vals[n]:g}" for n in names],
                     *[f"{v:.4f}" for v in resp], f"{m:.4f}", f"{ns}/{len(r.seeds)}"])
    table = markdown_table(
        ["no.", *[f"X{i + 1}" for i in range(len(names))], *short,
         *[f"trial {i + 1}" for i in range(len(r.seeds))], "mean fitness", "success"], rows)
    contrast = contrast_coefficients(r.coded, r.means)
    c_best, c_pred = predicted_best(contrast, "max")
    coef_rows = [
        ["jaxga, least squares (issue 5)", *[f"{c:.5f}" for c in r.coefficients],
         str(tuple(int(c) for c in r.best_coded)), f"{r.predicted:.5f}"],
        ["jaxga, AGACD's contrasts mean(F*y)", *[f"{c:.5f}" for c in contrast],
         str(tuple(int(c) for c in c_best)), f"{c_pred:.5f}"],
        ["AGACD eq. 31 (paper)", *[f"{c:.5f}" for c in PAPER_EQ31], str(PAPER_BEST),
         f"{PAPER_PREDICTED:.5f}"],
    ]
    coef_table = markdown_table(["fit", "X0", *[f"X{i + 1} ({s})" for i, s in
                                                enumerate(short)],
                                 "best coded", "predicted"], coef_rows)
    best = ", ".join(f"{n} = {f.value(int(c)):g}" for n, f, c in
                     zip(short, r.factors, r.best_coded))
    conf = ", ".join(f"{v:.4f}" for v in r.confirmation)
    t = r.timing
    body = f"""
Preset agacd (generations {_generations(args)}),
map {r.map_name} (corner rule of the preset: free), AGACD Table 4 design with the levels
of its Table 3, {len(r.seeds)} seeds per point (seeds 0-{len(r.seeds) - 1}, the same for
every point and for the confirmation run), response = best fitness of each run (AGACD's
eq. 7-8 with its Delphi weights; a failed seed would count 0). Table in the layout of
AGACD Table 5:

{table}

Fitted prediction `fitness = X0 + sum Xi * Fi` (eq. 30); eq. 31 of the paper is its
contrast estimate, reproduced exactly from its Table 5 by `jaxga.doe.contrast_coefficients`
(tests/test_doe.py); least squares differs from it because Table 4 is not orthogonal
(pm_high is a relabelling of pc_high):

{coef_table}

Main effects (mean fitness at coded level -1 / 0 / 1):
{chr(10).join(f'- {n}: ' + ' / '.join(f'{v:.4f}' for v in row) for n, row in
              zip(names, r.main_effects))}

Predicted best (least squares): {best}. Confirmation run ({len(r.seeds)} seeds):
predicted {r.predicted:.5f}, measured {r.confirmation_mean:.5f} (per seed {conf});
the paper: predicted {PAPER_PREDICTED}, measured {PAPER_MEASURED} (its 5 trials 0.3077,
0.2398, 0.2398, 0.4392, 0.3077). The fitness values are of the paper's order
(its trials 0.14-0.47, ours 0.14-0.48) but its map, collision check and operators differ
in details (see presets/agacd.toml), so the runs are not expected to match one by one;
the comparison is of the procedure.

Wall time of the whole DOE: {wall:.1f} s (design sweep {t['sweep_s']:.1f} s and
confirmation {t['confirmation_s']:.1f} s, both including compilation, {t['compile_s']:.1f} s
in all); load average before
{', '.join(f'{v:.1f}' for v in load0)}, after {', '.join(f'{v:.1f}' for v in
os.getloadavg())} on a shared 2-core machine: times are noisy.
"""
    record("AGACD DOE (5.2.1, Tables 3-5)", body, write=not args.no_write)


def _generations(args: argparse.Namespace) -> int:
    from jaxga.config.presets import load_preset

    return args.generations or int(load_preset("agacd")["generations"])


if __name__ == "__main__":
    main()
