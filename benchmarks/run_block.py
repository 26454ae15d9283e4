"""How many runs one device computes together: the largest of
``jaxga.api.programs.RUNS_PER_DEVICE`` (the runs per device of a large call) swept.

    python benchmarks/run_block.py [--preset sga] [--seeds 1000] [--generations 50]
        [--blocks 64,32,16] [--devices N]

Each block limit runs in a child process (cold compile, ``N`` XLA host devices, default
one per core as jaxga uses) on ``classic_ga_gapp3_20x20`` (population 60; mpmga 3
islands of 20): compile, initialisation and evolution seconds, evolution
individual-generations per second, peak resident memory, and a SHA-256 of every per-seed
output. The hashes must all be equal: the block size changes the schedule, never a
result (``jaxga._batching.numerics`` keeps float sums independent of the batch).
"""

from __future__ import annotations

import argparse
import os
import sys

from _results import cold_child, markdown_table, parse_args, record, result_hash


def child(preset: str, seeds: int, generations: int, block: int) -> dict:
    """One cold run with calls of at most ``block`` runs per device (a fresh process)."""
    import resource

    import jax

    from jaxga import api
    from jaxga.maps import load_map

    api.programs.RUNS_PER_DEVICE = block
    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    size = 20 if preset == "mpmga" else 60
    r = api.run(preset, grid, seeds=seeds, population__size=size, generations=generations)
    n_dev = jax.local_device_count()
    block_runs, blocks = api.run_layout(seeds, n_dev)
    return {"devices": n_dev, "blocks": blocks, "block_runs": block_runs,
            "population": r.population, **{k: r.timing[k] for k in
                                            ("compile_s", "init_s", "evolve_s")},
            "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024,
            "hash": result_hash(r)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--preset", default="sga")
    ap.add_argument("--seeds", type=int, default=1000)
    ap.add_argument("--generations", type=int, default=50)
    ap.add_argument("--blocks", default="64,32,16")
    ap.add_argument("--devices", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--no-write", action="store_true")
    args = parse_args(ap, child)

    flags = f"--xla_force_host_platform_device_count={args.devices}"
    rows, hashes = [], set()
    for block in (int(b) for b in args.blocks.split(",")):
        spec = f"{args.preset}:{args.seeds}:{args.generations}:{block}"
        m = cold_child(__file__, spec, XLA_FLAGS=flags)[0]
        hashes.add(m["hash"])
        rate = args.seeds * m["population"] * args.generations / m["evolve_s"]
        rows.append([block, m["blocks"], m["block_runs"], m["compile_s"], m["init_s"],
                     m["evolve_s"], f"{rate:,.0f}", f"{m['peak_mib']:,}", m["hash"]])
        print(rows[-1], flush=True)
    body = (
        f"{args.preset}, classic_ga_gapp3_20x20 (corner rule free), {args.seeds} seeds, "
        f"{args.generations} generations, {args.devices} XLA host device(s), cold compiles. "
        "block: the largest runs per device of a call (`RUNS_PER_DEVICE`); calls and "
        "runs/device: what `api.run_layout` made of the runs. Times in seconds.\n\n"
        + markdown_table(["block", "calls", "runs/device", "compile", "init",
                          "evolve", "ind-gen/s", "peak MiB", "results hash"], rows)
        + f"\n\nAll results identical: {'yes' if len(hashes) == 1 else 'NO'}."
    )
    record("Runs per block (benchmarks/run_block.py)", body, write=not args.no_write)
    if len(hashes) != 1:
        sys.exit(1)


if __name__ == "__main__":
    main()
