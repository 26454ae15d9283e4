"""Every preset on the Moving AI maps: success, gaps to the exact optima, time, memory.

    python benchmarks/movingai_ga.py [--presets sga,...,hybrid] [--maps NAME,...]
                                     [--seeds 8] [--fallback on,off] [--resume FILE]

The nine maps of ``../shared/benchmarks/movingai`` (32 x 32 to 256 x 256), corner rule
"strict" (the scenarios' convention), each preset with its default settings, on three
scenarios per map: the 10 % quantile of the scenario file's optimal lengths (short), the
median and the longest problem. Each (preset, fallback, map) runs in a fresh process
(no compilation cache, one XLA device per core as jaxga runs), which reports:

* success: share of seeds x scenarios returning a feasible path;
* raw gap: median over seeds and scenarios of raw length / the scenario's optimal length
  - 1 (the 8-connected optimum; AGACD's raw paths are waypoint paths and can be shorter);
* post gap: median of the post-optimised length / exact any-angle optimum - 1 (presets
  without post-optimisation report their raw path);
* s/run: mean over the scenarios of (initialisation + evolution + post-optimisation) /
  seeds, after compilation; compile s: mean compile seconds per scenario;
* peak RSS: the process's peak resident memory (compilation included);
* fallback: with ``--fallback off`` the papers' initialisers alone (``init.fallback =
  none``); the mean share of initial individuals the fallback made is reported with it on.

Every row is appended as one JSON line to ``--resume FILE`` (default
``benchmarks/.movingai_ga.jsonl``, not committed) and skipped when the script is run
again, so a long run can be resumed. Prints the table and records it in RESULTS.md.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from _results import PRESETS, SHARED, cold_child, markdown_table, peak_rss_bytes, record

MOVINGAI = SHARED / "movingai"
MAPS = ("maze-32-32-2", "random-32-32-20", "room-32-32-4", "den312d", "warehouse-10-20-10-2-1",
        "ht_chantry", "lak303d", "Berlin_1_256", "Boston_2_256")
QUANTILES = {"short": 0.1, "median": 0.5, "long": 1.0}


def scenarios(name: str):
    """The short, median and longest problem of the map's scenario file."""
    from jaxga.maps import read_scen

    path = sorted(MOVINGAI.glob(f"{name}*.scen"))[0]
    probs = read_scen(path)
    order = np.argsort([p.optimal_length for p in probs], kind="stable")
    return {label: probs[int(order[min(int(q * len(order)), len(order) - 1)])]
            for label, q in QUANTILES.items()}


def child(spec: str) -> None:

    import jaxga._runtime.parallel

    jaxga._runtime.parallel.use_all_cores()
    from jaxga.api import run
    from jaxga.maps import load_map_info

    preset, fallback, name, seeds = json.loads(spec)
    sets = [] if fallback == "on" or preset == "hybrid" else ["init.fallback=none"]
    out = {"success": [], "raw_gap": [], "post_gap": [], "run_s": [], "compile_s": [],
           "fallback_share": [], "scenarios": {}}
    for label, p in scenarios(name).items():
        info = load_map_info(MOVINGAI / f"{name}.map", start=p.start, goal=p.goal,
                             corner_rule="strict")
        r = run(preset, info, seeds=seeds, corner_rule="strict", sets=sets)
        ok = r.success
        out["success"] += ok.tolist()
        out["raw_gap"] += (r.raw_length[ok] / p.optimal_length - 1).tolist()
        out["post_gap"] += r.gap[ok].tolist()
        t = r.timing
        out["run_s"].append((t["init_s"] + t["evolve_s"] + t["post_s"]) / seeds)
        out["compile_s"].append(t["compile_s"])
        out["fallback_share"].append(float(np.mean(r.init_fallback)) / r.population)
        out["scenarios"][label] = {"optimum": p.optimal_length, "success": float(ok.mean()),
                                   "capacity": r.path_capacity, "reason": r.reason}
    out["rss_mb"] = peak_rss_bytes() / 2**20
    print(json.dumps(out))


def summarise(cell: dict) -> dict:
    def median(v):
        return float(np.median(v)) if v else float("nan")

    return {"success": float(np.mean(cell["success"])), "raw": 100 * median(cell["raw_gap"]),
            "post": 100 * median(cell["post_gap"]), "run_s": float(np.mean(cell["run_s"])),
            "compile_s": float(np.mean(cell["compile_s"])), "rss": cell["rss_mb"],
            "fallback": 100 * float(np.mean(cell["fallback_share"]))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default=",".join((*PRESETS, "hybrid")))
    ap.add_argument("--maps", default=",".join(MAPS))
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--fallback", default="on,off", help="on, off or on,off")
    ap.add_argument("--resume", default=str(Path(__file__).with_name(".movingai_ga.jsonl")))
    ap.add_argument("--child")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    from jaxga.maps import load_map

    done = {}
    resume = Path(args.resume)
    if resume.exists():
        for line in resume.read_text().splitlines():
            row = json.loads(line)
            done[tuple(row["key"])] = row["cell"]
    t0 = time.perf_counter()
    rows = []
    for preset in args.presets.split(","):
        for fallback in args.fallback.split(","):
            if preset == "hybrid" and fallback == "off":
                continue  # its initialiser is the field walk itself
            for name in args.maps.split(","):
                key = (preset, fallback, name, args.seeds)
                if key not in done:
                    cell, _ = cold_child(__file__, json.dumps(list(key)))
                    done[key] = cell
                    with resume.open("a") as f:
                        f.write(json.dumps({"key": list(key), "cell": cell}) + "\n")
                s = summarise(done[key])
                h, w = load_map(MOVINGAI / f"{name}.map").shape
                rows.append([preset, fallback, name, f"{w} x {h}", f"{s['success']:.2f}",
                             f"{s['raw']:.2f}", f"{s['post']:.2f}", f"{s['run_s']:.3f}",
                             f"{s['compile_s']:.1f}", f"{s['rss']:.0f}",
                             f"{s['fallback']:.0f}" if fallback == "on" else "-"])
                print(rows[-1], flush=True)
    body = (f"Corner rule strict, each preset's default settings, {args.seeds} seeds on "
            "each of three scenarios per map (10 % quantile, median and longest optimal "
            "length of its scenario file). success over seeds x scenarios; raw gap % = "
            "median raw length / scenario optimum - 1 (AGACD's raw paths are waypoint "
            "paths); post gap % = median post-optimised length / exact any-angle "
            "optimum - 1; s/run = (init + evolve + post) / seeds, mean over scenarios; "
            "compile s per scenario; peak RSS of the process (compilation included); "
            "fallback % = initial individuals made by the fallback (fallback on). "
            "fallback off = init.fallback = none, the papers' initialisers alone. Each "
            "(preset, fallback, map) in a fresh process with one XLA device per core.\n\n"
            + markdown_table(["preset", "fallback", "map", "size", "success", "raw gap %",
                              "post gap %", "s/run", "compile s", "peak RSS MB",
                              "fallback %"], rows)
            + f"\n\nWall time (this invocation): {time.perf_counter() - t0:.0f} s.")
    print(body)
    record("every preset on the Moving AI maps (success, gaps, time, memory)", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
