"""All six presets compared on two classic maps and one Moving AI map, with statistics.

    python benchmarks/compare_presets.py [--seeds 100] [--maps a,b] [--presets a,b]
        [--cache DIR] [--report-only] [--no-write] [--plot-dir DIR]

Issue 5, must show: every preset at its preset settings, 100 seeds each, on
``classic_ga_gapp3_20x20`` and ``routeplanning_yangbo_20x20`` (corner rule ``free``, as
the papers) and the Moving AI map ``random-32-32-20`` (corner rule ``strict``, the Moving
AI convention; its corner (0, 0) is blocked, so the endpoints are those of the longest
scenario of its ``.scen`` file, as in ``benchmarks/feasibility.py``). Per map:
the per-preset summary (mean / sd / min / max of the post-optimised length, gap of the raw
path to the exact 8-connected optimum and of the post-optimised path to the any-angle
optimum, success rate, seconds per run after compilation) and the pairwise two-sided
Mann-Whitney U tests (Holm-corrected within each metric, Vargha-Delaney A12) made by
:func:`jaxga.compare.compare_results`.

Heavy (tens of minutes): every finished (map, preset) batch is pickled in ``--cache``
(default ``/tmp/jaxga_compare_presets``), so a killed run restarted with the same
command skips what is done; ``--report-only`` reports the maps whose presets are all in
the cache (and names the missing ones) without running anything.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
import time
from pathlib import Path

from _results import PRESETS, record

MAPS = {
    "classic_ga_gapp3_20x20": "free",
    "routeplanning_yangbo_20x20": "free",
    "random-32-32-20": "strict",
}
METRICS = ("length", "raw_length", "turns", "convergence_generation")


def _grid(map_name: str):
    """The map name itself for the classic maps (their own endpoints); for the Moving AI
    map a Grid with the endpoints of its longest scenario."""
    if not map_name.startswith("random-"):
        return map_name
    from jaxga.maps import load_map
    from jaxga.maps.builtin import builtin_scenarios

    scen = max(builtin_scenarios(map_name), key=lambda s: s.optimal_length)
    return scen.apply(load_map(map_name, corner_rule=MAPS[map_name]))


def _label(map_name: str) -> str:
    if not map_name.startswith("random-"):
        return map_name
    from jaxga.maps.builtin import builtin_scenarios

    scen = max(builtin_scenarios(map_name), key=lambda s: s.optimal_length)
    return (f"{map_name} (longest scenario {scen.start} -> {scen.goal}, "
            f"optimal {scen.optimal_length:.4f})")


def _cache_file(cache: Path, map_name: str, preset: str, seeds: int) -> Path:
    return cache / f"{map_name}__{preset}__{seeds}.pkl"


def _log(msg: str) -> None:
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"[{time.strftime('%H:%M:%S')} load {load}] {msg}", flush=True)


def run_missing(maps, presets, seeds: int, cache: Path) -> None:
    """Run every (map, preset) batch not yet in the cache; pickle each as it finishes."""
    from jaxga.api import run
    from jaxga.cli import use_compilation_cache

    use_compilation_cache()
    cache.mkdir(parents=True, exist_ok=True)
    for map_name in maps:
        for preset in presets:
            f = _cache_file(cache, map_name, preset, seeds)
            if f.exists():
                _log(f"{map_name} {preset}: cached")
                continue
            _log(f"{map_name} {preset}: running {seeds} seeds")
            r = run(preset, _grid(map_name), seeds=seeds, corner_rule=MAPS[map_name])
            r.map_name = _label(map_name)
            tmp = f.with_suffix(".tmp")
            tmp.write_bytes(pickle.dumps(r))
            tmp.replace(f)
            t = r.timing
            _log(f"{map_name} {preset}: done, success {int(r.success.sum())}/{seeds}, "
                 f"compile {t['compile_s']:.1f} s, total {t['total_s']:.1f} s")


def report(maps, presets, seeds: int, cache: Path, write: bool,
           plot_dir: Path | None = None, report_only: bool = False) -> None:
    """One RESULTS.md section per map (the presets that finished; the others named)."""
    from jaxga.compare import compare_results

    missing_all = []
    for map_name in maps:
        results, missing = {}, []
        for preset in presets:
            f = _cache_file(cache, map_name, preset, seeds)
            if f.exists():
                results[preset] = pickle.loads(f.read_bytes())
            else:
                missing.append(preset)
        if missing:
            missing_all.append(f"{map_name}: {', '.join(missing)}")
        if len(results) < 2:
            continue
        comp = compare_results(results, metric="length", metrics=METRICS)
        if plot_dir is not None:
            _plots(comp, map_name, plot_dir)
        note = (f"{seeds} seeds per preset (seeds 0..{seeds - 1}), every preset at its "
                f"preset settings (its own population and generations), corner rule "
                f"`{MAPS[map_name]}`. The gap columns: see the line under the table. "
                "s/run = (init + evolve + post) / seeds, compilation excluded; timings are "
                "noisy (2 shared cores, other jobs running; see the load average). "
                "Tests: two-sided Mann-Whitney U per "
                "pair (independent samples: different algorithms do not share random "
                "numbers, so seed i of one preset is not paired with seed i of another), "
                "failed seeds excluded; p Holm-corrected over the pairs of each metric; "
                "A12 = P(a > b) + P(a = b)/2 (lower length is better, so A12 < 0.5 "
                "favours a); success rates by Fisher's exact test (Holm).")
        if report_only:
            note += (" The batches were run by this script without `--report-only` (each "
                     "pickled in the cache as it finished) and tabulated from the cache.")
        compile_s = ", ".join(f"{k} {r.timing['compile_s']:.0f}" for k, r in results.items())
        note += (f" Compile seconds (under the same load; ~0 = programs reused from the "
                 f"previous map of the same size): {compile_s}.")
        if missing:
            note += f"\n\nNOT RUN (did not finish in time): {', '.join(missing)}."
        body = note + "\n\n" + comp.to_markdown()
        record(f"compare presets on {map_name}", body, write=write)
    if missing_all:
        print("missing batches: " + "; ".join(missing_all), file=sys.stderr)


def _plots(comp, map_name: str, plot_dir: Path) -> None:
    """Box plots + per-seed scatter, and the diversity curves (MPMGA Fig. 16), as PNGs."""
    import matplotlib.pyplot as plt

    from jaxga.plot import plot_comparison, plot_diversity

    plot_dir.mkdir(parents=True, exist_ok=True)
    plot_comparison(comp, plot_dir / f"compare_{map_name}.png")
    ax = plot_diversity(comp, relative=True)
    ax.set_title(f"population diversity on {map_name}")
    ax.figure.tight_layout()
    ax.figure.savefig(plot_dir / f"diversity_{map_name}.png", dpi=110)
    plt.close(ax.figure)
    print(f"wrote plots to {plot_dir}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--maps", default=",".join(MAPS))
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--cache", default="/tmp/jaxga_compare_presets")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--plot-dir", help="also write box plots and diversity curves here")
    args = ap.parse_args()
    maps = [m for m in args.maps.split(",") if m]
    presets = [p for p in args.presets.split(",") if p]
    unknown = [m for m in maps if m not in MAPS]
    if unknown:
        ap.error(f"unknown map(s) {unknown}; choose from {list(MAPS)}")
    cache = Path(args.cache)
    if not args.report_only:
        run_missing(maps, presets, args.seeds, cache)
    report(maps, presets, args.seeds, cache, write=not args.no_write,
           plot_dir=Path(args.plot_dir) if args.plot_dir else None,
           report_only=args.report_only)


if __name__ == "__main__":
    main()
