"""How the ``hybrid`` preset was chosen: an operator screen, then a designed experiment.

    python benchmarks/hybrid_tuning.py --stage operators [--seeds 8]
    python benchmarks/hybrid_tuning.py --stage doe [--seeds 8]
    python benchmarks/hybrid_tuning.py --stage refine [--seeds 8]

Tuned on the shared Moving AI maps (``../shared/benchmarks/movingai``, corner rule
"strict"), never on the test maps. Problems: for each of the nine maps, its scenario of
median length and its longest one (the hard case). The measure is the post-optimised
length's gap to the exact any-angle optimum (``Result.gap``), the quality the preset
promises, and the seconds per run (initialisation + evolution + post-optimisation).

* ``--stage operators``: one operator changed at a time from the base (field_walk init,
  tournament selection, common-point crossover, neighbour-point mutation, corner-cut
  simplification, 1 / length fitness, shortcut_optimal post-optimisation, 40
  generations) on the longest problem of every map: median gap, worst gap, seconds per
  run. Static choices (operators, generations) change the compiled program, so each is
  a run of its own.
* ``--stage doe``: the dynamic parameters in one L18 design (jaxga's own DOE,
  :func:`jaxga.doe.run_doe`, AGACD 5.2.1) per problem, the response the post-optimised
  length; the table gives each design point's mean gap over all problems and the main
  effect of each factor level (mean gap over the points at that level), from which the
  preset's levels are read.
* ``--stage refine``: the L18's best levels of init.slack and init.temperature were its
  lowest; a full 3 x 3 factorial below them (the other factors at their best levels)
  says whether lower still is better.

Prints the tables and appends them to RESULTS.md.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _results import SHARED, markdown_table, record

from jaxga.api import run
from jaxga.config.presets import load_preset
from jaxga.doe import Factor, run_doe
from jaxga.maps import load_map_info, read_scen
from jaxga.reference.any_angle import any_angle_shortest_path

MOVINGAI = SHARED / "movingai"
MAPS = ("Berlin_1_256", "Boston_2_256", "den312d", "ht_chantry", "lak303d", "maze-32-32-2",
        "random-32-32-20", "room-32-32-4", "warehouse-10-20-10-2-1")

BASE = {
    "name": "hybrid-base", "paper": "jaxga (tuning base)", "generations": 40,
    "map.corner_rule": "strict", "population.size": 40, "population.capacity": 0,
    "init.method": "field_walk", "init.slack": 0.3, "init.temperature": 1.0,
    "fitness.method": "sga", "selection.method": "tournament",
    "selection.tournament_size": 2, "crossover.method": "common_point",
    "crossover.probability": 0.7, "mutation.method": "neighbour_point",
    "mutation.probability": 0.3, "simplify.method": "corner_cut",
    "simplify.probability": 0.5, "post.method": "shortcut_optimal",
}
VARIANTS = {  # one static choice changed at a time
    "base": {},
    "selection roulette_elite": {"selection.method": "roulette_elite"},

    "crossover heterologous": {"crossover.method": "heterologous"},

    "mutation range": {"mutation.method": "range"},
    "mutation one_point": {"mutation.method": "one_point"},

    "simplify simplify_adjacent": {"simplify.method": "simplify_adjacent"},
    "simplify none": {"simplify.method": "none"},
    "post shortcut_greedy": {"post.method": "shortcut_greedy"},
    "generations 20": {"generations": 20},
    "generations 80": {"generations": 80},
}
DOE_BASE = {**BASE, "generations": 20}
"""The design's fixed part: the base with 20 generations (the operator screen: 20, 40 and
80 generations gave the same gaps; every other operator of the base was at least as good
as its alternatives)."""
FACTORS = (
    Factor("init.slack", (0.1, 0.3, 0.6)),
    Factor("init.temperature", (0.25, 1.0, 4.0)),
    Factor("crossover.probability", (0.5, 0.7, 0.9)),
    Factor("mutation.probability", (0.1, 0.3, 0.5)),
    Factor("simplify.probability", (0.2, 0.5, 0.8)),
    Factor("population.size", (20, 40, 80)),
)


def problems(which: str) -> list[tuple[str, object]]:
    """``(label, MapInfo)`` of each map's median-length and longest scenario."""
    out = []
    for name in MAPS:
        scen = sorted(MOVINGAI.glob(f"{name}*.scen"))[0]
        probs = read_scen(scen)
        order = np.argsort([p.optimal_length for p in probs], kind="stable")
        picks = {"median": order[len(order) // 2], "longest": order[-1]}
        for label in (("longest",) if which == "longest" else ("median", "longest")):
            p = probs[int(picks[label])]
            info = load_map_info(MOVINGAI / f"{name}.map", start=p.start, goal=p.goal,
                                 corner_rule="strict")
            out.append((f"{name} {label} ({p.optimal_length:.1f})", info))
    return out


def per_run_s(r) -> float:
    t = r.timing
    return (t["init_s"] + t["evolve_s"] + t["post_s"]) / len(r.seeds)


def stage_operators(seeds: int) -> str:
    rows = []
    probs = problems("longest")
    for label, changes in VARIANTS.items():
        config = load_preset("sga").override({**BASE, **changes})
        gaps, worst, secs = [], [], []
        for _, info in probs:
            r = run(config, info, seeds=seeds)
            assert r.success.all(), (label, r.reason)
            gaps.append(np.median(r.gap))
            worst.append(np.max(r.gap))
            secs.append(per_run_s(r))
        rows.append([label, f"{100 * np.median(gaps):.2f}", f"{100 * np.mean(gaps):.2f}",
                     f"{100 * np.max(worst):.2f}", f"{np.mean(secs):.3f}"])
        print(rows[-1], flush=True)
    return (f"Longest scenario of each of the 9 Moving AI maps, {seeds} seeds, corner rule "
            "strict; base: " + ", ".join(f"{k} = {v}" for k, v in BASE.items()
                                         if k not in ("name", "paper"))
            + ". gap = post-optimised length / exact any-angle optimum - 1 (median over "
            "the maps of each map's median; mean of the same; worst single run); s/run = "
            "mean over maps of (init + evolve + post) / seeds.\n\n"
            + markdown_table(["variant", "median gap %", "mean gap %", "worst gap %",
                              "s/run"], rows))


REFINE_BASE = {**DOE_BASE, "crossover.probability": 0.9, "mutation.probability": 0.3,
               "simplify.probability": 0.2, "population.size": 80}
"""The L18's best levels of the other factors."""
REFINE_FACTORS = (Factor("init.slack", (0.0, 0.05, 0.1)),
                  Factor("init.temperature", (0.0, 0.1, 0.25)))


def stage_doe(seeds: int, refine: bool = False) -> str:
    config = load_preset("sga").override(REFINE_BASE if refine else DOE_BASE)
    factors, design = (REFINE_FACTORS, "full") if refine else (FACTORS, "L18")
    gaps = []
    for label, info in problems("both"):
        t0 = time.perf_counter()
        d = run_doe(config, info, factors, design, seeds=seeds, response="length",
                    direction="min")
        opt = any_angle_shortest_path(info.grid).length
        gaps.append(np.nanmean(d.all_responses["length"], axis=1) / opt - 1)
        print(label, np.round(100 * gaps[-1], 2), f"{time.perf_counter() - t0:.0f} s",
              flush=True)
    gap = np.mean(gaps, axis=0)  # per design point, over the problems
    coded = d.coded
    rows = [[q + 1, *[int(c) for c in coded[q]], f"{100 * gap[q]:.3f}"]
            for q in range(len(gap))]
    effects = []
    for k, f in enumerate(factors):
        means = [100 * gap[coded[:, k] == level].mean() for level in (-1, 0, 1)]
        best = int(np.argmin(means))
        effects.append([f.name, *[f"{m:.3f}" for m in means], f"{f.levels[best]}"])
    if refine:
        shown = ("crossover.probability", "mutation.probability", "simplify.probability",
                 "population.size", "generations")
        fixed = ", ".join(f"{k} = {REFINE_BASE[k]}" for k in shown)
        return (f"Full 3 x 3 factorial of init.slack and init.temperature below the L18's "
                f"lowest levels, the other factors at the L18's best levels "
                f"({fixed}), "
                f"on the same {len(gaps)} problems, {seeds} seeds per point.\n\n"
                + markdown_table(["point", *[f.name for f in factors], "mean gap %"], rows)
                + "\n\nMain effects:\n\n"
                + markdown_table(["factor", "low", "mid", "high", "best level"], effects))
    return (f"L18 design of the dynamic parameters, on the median-length and the longest "
            f"scenario of each of the 9 Moving AI maps ({len(gaps)} problems), {seeds} "
            "seeds per point, the operators of the base with 20 generations (the operator "
            "screen). "
            "Response: post-optimised length; gap % = mean over seeds and problems of "
            "length / any-angle optimum - 1.\n\n"
            + markdown_table(["point", *[f.name for f in factors], "mean gap %"], rows)
            + "\n\nMain effects (mean gap % of the points at each level):\n\n"
            + markdown_table(["factor", "low", "mid", "high", "best level"], effects))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--stage", choices=("operators", "doe", "refine"), required=True)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    if args.stage == "operators":
        body = stage_operators(args.seeds)
        title = "hybrid tuning: operator screen on the Moving AI maps"
    elif args.stage == "doe":
        body = stage_doe(args.seeds)
        title = "hybrid tuning: L18 design of the dynamic parameters on the Moving AI maps"
    else:
        body = stage_doe(args.seeds, refine=True)
        title = "hybrid tuning: init.slack and init.temperature below the L18's levels"
    body += f"\n\nWall time: {time.perf_counter() - t0:.0f} s."
    print(body)
    record(title, body, write=not args.no_write)


if __name__ == "__main__":
    main()
