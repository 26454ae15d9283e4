"""XLA:CPU's default fusion emitters against its older ones: compile time, speed, results.

    python benchmarks/fast_compile.py [--presets sga,imga,...] [--seeds 1,10,64]
        [--devices N] [--no-write]

For each preset and seed count (20 x 20: ``classic_ga_gapp3_20x20``, population 60 in
all (mpmga: 3 islands of 20), 300 generations), two child processes (cold compile, no
persistent cache) run the same seeds: one with XLA's default (the MLIR fusion
emitters), one with ``XLA_FLAGS=--xla_cpu_use_fusion_emitters=false`` (the older
emitters). The table gives both processes' compile, init, evolve and total seconds, the
work per device (runs per device x population x generations) and whether the two
results are identical (``_results.result_hash``: every path, fitness, length and
history). Equal hashes here do not make the two compilations bit-identical in general:
a small mpmga run differed by 1 ulp in one history value. jaxga compiles the init and
evolve programs with XLA's default and only the finish program with the older emitters
(``jaxga.api.programs.FINISH_COMPILER_OPTIONS``, decision 012); the flag is a user's choice
(README, performance).
"""

from __future__ import annotations

import argparse
import time

from _results import (
    STANDARD_GENERATIONS,
    STANDARD_POPULATION,
    STANDARD_SETTING,
    cold_child,
    markdown_table,
    parse_args,
    record,
    result_hash,
    standard_run,
)

from jaxga.api.parallel import cores


def child(preset: str, seeds: int) -> dict:
    """One run in this (fresh) process (its ``XLA_FLAGS`` choose the emitters)."""
    r = standard_run(preset, seeds)
    t = r.timing
    return {k: t[k] for k in ("compile_s", "init_s", "evolve_s", "post_s", "total_s")} | {
        "hash": result_hash(r)}


def measure(preset: str, seeds: int, older: bool, devices: int) -> dict:
    """:func:`child`'s numbers from a fresh process (cold compile), older emitters or not."""
    flags = f"--xla_force_host_platform_device_count={devices}"
    if older:
        flags += " --xla_cpu_use_fusion_emitters=false"
    return cold_child(__file__, f"{preset}:{seeds}", XLA_FLAGS=flags)[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default="sga,imga,agacd,iga_zhang,mpmga,iga_zhu")
    ap.add_argument("--seeds", default="1,10,64")
    ap.add_argument("--devices", type=int, default=cores())
    ap.add_argument("--no-write", action="store_true")
    args = parse_args(ap, child)

    t_all = time.perf_counter()
    rows = []
    for preset in args.presets.split(","):
        for seeds in (int(s) for s in args.seeds.split(",")):
            default = measure(preset, seeds, False, args.devices)
            older = measure(preset, seeds, True, args.devices)
            # runs padded to a multiple of the device count
            work = -(-seeds // args.devices) * STANDARD_POPULATION * STANDARD_GENERATIONS
            rows.append([preset, seeds, f"{work:,}", *(f"{m[k]:.2f}" for m in (default, older)
                           for k in ("compile_s", "init_s", "evolve_s", "total_s")),
                         "yes" if default["hash"] == older["hash"] else "NO"])
            print(rows[-1], flush=True)
    body = (
        f"{args.devices} XLA host device(s); {STANDARD_SETTING}. "
        "Seconds; compile cold (no persistent cache), one child process per cell group; "
        "total = compile + init + evolve + post. Work per device = runs per device x "
        "population x generations. Same result = equal hashes of every path, fitness, "
        "length and history of the two processes.\n\n"
        + markdown_table(
            ["preset", "seeds", "work per device",
             "compile (default)", "init", "evolve", "total",
             "compile (older)", "init", "evolve", "total", "same result"], rows)
        + f"\n\nWall time: {time.perf_counter() - t_all:.0f} s."
    )
    record("XLA:CPU fusion emitters, default vs older: compile time, speed, results",
           body, write=not args.no_write)


if __name__ == "__main__":
    main()
