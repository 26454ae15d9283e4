"""Speed of every preset at the papers' settings, against a per-individual NumPy loop SGA.

    python benchmarks/speed.py [--presets sga,imga,...] [--settings 20x20,50x50]
        [--seeds 1,100,1000] [--max-generations-many 50] [--devices N] [--warm]
        [--timeout-minutes M]

For each preset and setting (20 x 20: population 60, 300 generations on
``classic_ga_gapp3_20x20``; 50 x 50: population 80, 500 generations on
``random_map(50, 50, 0.1, seed=0)`` from (0, 0) to (49, 49)) and each seed count, one
child process (so that compile time is cold - no persistent cache - and peak memory is
that configuration's) reports: compile time, initialisation / evolution / post-
optimisation times, runs per second (init + evolve + post, after compilation) and
individual-generations per second of the evolution (population x generations x seeds /
evolve seconds), and the child's peak resident memory. Presets keep their operators and
parameters; only population size and generations are set to the setting's (and with
``--max-generations-many G`` the runs of 100 seeds or more evolve only ``G``
generations: ind-gen/s is per generation, runs/s is then extrapolated to the full
generation count). The extrapolation is a quick approximation and understates the full
run: the first generations cost more than the later ones, so the targets are judged on
full runs (the default; decision 023).

With ``--warm`` each configuration runs twice, in two child processes sharing a fresh
persistent compilation cache (``jaxga.configure``, which ``jaxga run``
calls): the first child's compile is then cold but includes writing the
cache (what a user's first ``jaxga run`` pays), the second child's is the "warm" compile
of every later run of the same preset, map size and seed count (tracing and lowering
still run; XLA's compilation is read from disk).

The same SGA written as a straightforward per-individual NumPy/Python loop
(``benchmarks/numpy_sga.py``) runs in this (parent) process on the same maps; the
ratio is its seconds per run over jaxga's sga seconds per run.

A configuration whose child runs longer than ``--timeout-minutes`` is stopped and
recorded as a row that says so; the script goes on with the next. Interrupted by hand
(Ctrl-C, or SIGTERM), it stops the running child and still appends the rows measured so
far, with a line naming the configuration it was measuring.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import markdown_table, parse_args, peak_rss_bytes, record

from jaxga._runtime.parallel import cores

SETTINGS = {"20x20": (60, 300), "50x50": (80, 500)}
HERE = Path(__file__).resolve().parent


def grid_for(setting: str):
    from jaxga.maps import load_map, random_map

    if setting == "20x20":
        return load_map("classic_ga_gapp3_20x20", corner_rule="free")
    return random_map(50, 50, 0.1, seed=0, corner_rule="free")


def child(preset: str, setting: str, seeds: int, generations: int) -> dict:
    """One measurement (runs in a fresh process)."""

    from jaxga.api import run

    population, _ = SETTINGS[setting]
    overrides = {"population__size": population, "generations": generations}
    if preset == "mpmga":  # 3 islands: the setting's population is the total
        overrides["population__size"] = population // 3
    if os.environ.get("JAXGA_CACHE_DIR"):  # --warm: the CLI's persistent cache
        from jaxga import configure

        configure()
    r = run(preset, grid_for(setting), seeds=seeds, **overrides)
    t = r.timing
    return {
        "compile_s": t["compile_s"], "init_s": t["init_s"], "evolve_s": t["evolve_s"],
        "post_s": t["post_s"], "population": r.population, "generations": r.generations,
        "success": float(r.success.mean()),
        "peak_mib": peak_rss_bytes() / 2**20,
    }


def measure(preset, setting, seeds, generations, devices, warm=False,
            timeout: float | None = None) -> dict:
    """One configuration in a child process; with ``warm``, a second child reads the
    persistent compilation cache the first one wrote (its compile is ``compile_warm_s``).
    ``timeout``: seconds per child (``subprocess.TimeoutExpired`` after stopping it)."""
    env = dict(os.environ, PYTHONPATH=f"{HERE.parent}{os.pathsep}{HERE}",
               XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")
    env["JAXGA_CACHE_DIR"] = ""  # cold: the Python API turns a cache on unless empty
    cmd = [sys.executable, __file__, "--child", f"{preset}:{setting}:{seeds}:{generations}"]

    def one() -> dict:
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr[-3000:])
        return json.loads(proc.stdout.strip().splitlines()[-1])

    if not warm:
        return one()
    with tempfile.TemporaryDirectory(prefix="jaxga-speed-cache-") as cache:
        env["JAXGA_CACHE_DIR"] = cache
        m = one()
        m["compile_warm_s"] = one()["compile_s"]
    return m


def numpy_baseline(setting: str, n: int) -> tuple[float, float]:
    """Seconds per run of the NumPy loop SGA (mean of ``n`` seeds) and its ind-gen/s."""
    from numpy_sga import run_sga

    g = grid_for(setting)
    population, generations = SETTINGS[setting]
    runs = [run_sga(np.asarray(g.blocked), int(g.start), int(g.goal), population,
                    generations, seed=seed) for seed in range(n)]
    per_run = float(np.mean([r["init_s"] + r["evolve_s"] for r in runs]))
    return per_run, population * generations / float(np.mean([r["evolve_s"] for r in runs]))


def configurations(args) -> list[tuple[str, str, int]]:
    """``(preset, setting, seeds)`` of every configuration, in the order they run."""
    return [(preset, setting, int(seeds)) for preset in args.presets.split(",")
            for setting in args.settings.split(",") for seeds in args.seeds.split(",")]


def measure_row(args, base: dict, timeout: float | None, preset: str, setting: str,
                seeds: int) -> list:
    """One configuration's table row (a row saying so when it ran past ``timeout``)."""
    generations = SETTINGS[setting][1]
    gens = generations
    if seeds >= 100 and args.max_generations_many:
        gens = min(generations, args.max_generations_many)
    try:
        m = measure(preset, setting, seeds, gens, args.devices, args.warm, timeout)
    except subprocess.TimeoutExpired:
        return [preset, setting, seeds, "", gens, "", "", "",
                f"stopped after {args.timeout_minutes:g} min", "", "", "", "", ""]
    ind_gen = seeds * m["population"] * m["generations"] / m["evolve_s"]
    per_run = (m["init_s"] + m["post_s"]
               + m["evolve_s"] * generations / m["generations"]) / seeds
    ratio = (f"{base[setting][0] / per_run:,.1f}" if preset == "sga" else "")
    return [preset, setting, seeds, m["population"], m["generations"],
            m["compile_s"], m.get("compile_warm_s", ""), m["init_s"], m["evolve_s"],
            f"{1 / per_run:,.2f}", f"{ind_gen:,.0f}", ratio,
            f"{m['peak_mib']:,.0f}", f"{m['success']:.2f}"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default="sga,imga,agacd,iga_zhang,mpmga,iga_zhu")
    ap.add_argument("--settings", default="20x20,50x50")
    ap.add_argument("--seeds", default="1,100,1000")
    ap.add_argument("--max-generations-many", type=int, default=0)
    # Default: one XLA host device per core, as jaxga itself runs (jaxga._runtime.parallel).
    ap.add_argument("--devices", type=int, default=cores())
    ap.add_argument("--baseline-seeds", type=int, default=3)
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--warm", action="store_true",
                    help="also measure the compile of a second run from the persistent cache")
    ap.add_argument("--timeout-minutes", type=float, default=0,
                    help="stop a configuration after this many minutes (0: no limit)")
    args = parse_args(ap, child)

    t_all = time.perf_counter()
    # SIGTERM (e.g. `kill`) ends the run like Ctrl-C: the rows so far are still written.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    base = {}
    for setting in args.settings.split(","):
        base[setting] = numpy_baseline(setting, args.baseline_seeds)
        print("numpy loop", setting, base[setting], flush=True)
    timeout = args.timeout_minutes * 60 or None
    configs, rows, notes = configurations(args), [], []

    def name(config: tuple[str, str, int]) -> str:
        return "{} {} with {} seed(s)".format(*config)

    try:
        for config in configs:
            rows.append(measure_row(args, base, timeout, *config))
            print(rows[-1], flush=True)
            if str(rows[-1][8]).startswith("stopped after"):
                notes.append(f"Stopped: {name(config)} ran longer than --timeout-minutes "
                             f"{args.timeout_minutes:g}.")
    except KeyboardInterrupt:
        notes.append(f"Interrupted by hand after {time.perf_counter() - t_all:.0f} s, while "
                     f"measuring {name(configs[len(rows)])}: the rows above are complete; "
                     "that configuration and the later ones did not run.")
    base_rows = [[s, SETTINGS[s][0], SETTINGS[s][1], f"{b[0]:.3f}", f"{b[1]:,.0f}"]
                 for s, b in base.items()]
    body = (
        f"{args.devices} XLA host device(s); 20x20 = classic_ga_gapp3_20x20, 50x50 = "
        "random_map(50, 50, 0.1, seed=0), corner rule free. Times in seconds; compile is "
        + ("cold, writing a fresh persistent cache; warm compile is a second process's, "
           "reading it. " if args.warm else "cold (no persistent cache). ")
        + "runs/s counts init + evolve + post after compilation "
        "(evolve extrapolated to the full generations when fewer were run). ind-gen/s = "
        "seeds x population x generations / evolve seconds. x loop = NumPy loop seconds "
        "per run / jaxga seconds per run (sga only). Peak memory: the child process's "
        "maximum resident set.\n\n"
        + markdown_table(["preset", "setting", "seeds", "population", "generations run",
                          "compile", "warm compile", "init", "evolve", "runs/s", "ind-gen/s",
                          "x loop", "peak MiB", "success"], rows)
        + "\n\nNumPy/Python loop SGA (`benchmarks/numpy_sga.py`, same process as this "
        f"script, mean of {args.baseline_seeds} seeds):\n\n"
        + markdown_table(["setting", "population", "generations", "s per run",
                          "ind-gen/s"], base_rows)
        + f"\n\nWall time: {time.perf_counter() - t_all:.0f} s."
        + "".join(f"\n\n{n}" for n in notes)
    )
    record("speed of every preset vs a NumPy loop SGA", body, write=not args.no_write)


if __name__ == "__main__":
    main()
