"""Threefry lowered rolled (JAX's CPU default) against unrolled (jaxga's), every preset.

    python benchmarks/lowering.py [--presets sga,imga,...] [--seeds 100]
        [--generations 50] [--repeats 1]

For each preset on ``classic_ga_gapp3_20x20`` (population 60, or 3 islands of 20 for
mpmga) and each lowering (``JAXGA_THREEFRY=rolled`` / ``unrolled``), one child process
with a cold compile (no persistent cache, one XLA device) runs ``jaxga.run`` and reports:
the XLA compile seconds of each of the three programs (from JAX's compile log), the
whole ``compile_s`` (tracing + lowering + XLA), evolution ind-gen/s, and a SHA-256 of
every per-seed output (paths, raw paths, fitness, histories). The hashes of the two
lowerings must be equal: the hash function is the same, only the program differs.
"""

from __future__ import annotations

import argparse
import re
import sys

from _results import cold_child, markdown_table, parse_args, record, result_hash

PROGRAM = re.compile(r"Finished XLA compilation of jit\((do_\w+)\) in ([0-9.]+) sec")


def child(preset: str, seeds: int, generations: int) -> dict:
    """One cold run (in a fresh process)."""
    from jaxga.api import run
    from jaxga.api.lowering import threefry_unrolled
    from jaxga.maps import load_map

    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    size = 20 if preset == "mpmga" else 60
    r = run(preset, grid, seeds=seeds, population__size=size, generations=generations)
    return {"unrolled": threefry_unrolled(), "compile_s": r.timing["compile_s"],
            "evolve_s": r.timing["evolve_s"], "population": r.population,
            "hash": result_hash(r)}


def measure(preset: str, seeds: int, generations: int, lowering: str) -> dict:
    out, stderr = cold_child(__file__, f"{preset}:{seeds}:{generations}",
                             XLA_FLAGS="--xla_force_host_platform_device_count=1",
                             JAXGA_THREEFRY=lowering, JAX_LOG_COMPILES="1")
    if out["unrolled"] != (lowering == "unrolled"):
        raise RuntimeError(f"JAXGA_THREEFRY={lowering} was not applied")
    out["xla"] = {name: float(s) for name, s in PROGRAM.findall(stderr)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default="sga,imga,agacd,iga_zhang,mpmga,iga_zhu")
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--generations", type=int, default=50)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--no-write", action="store_true")
    args = parse_args(ap, child)

    rows, same = [], True
    for preset in args.presets.split(","):
        for rep in range(args.repeats):
            m = {lw: measure(preset, args.seeds, args.generations, lw)
                 for lw in ("rolled", "unrolled")}
            same &= m["rolled"]["hash"] == m["unrolled"]["hash"]
            row = [preset, rep + 1]
            for key in ("do_init", "do_evolve", "do_finish"):
                row += [f"{m['rolled']['xla'].get(key, float('nan')):.1f} -> "
                        f"{m['unrolled']['xla'].get(key, float('nan')):.1f}"]
            xr, xu = sum(m["rolled"]["xla"].values()), sum(m["unrolled"]["xla"].values())
            rate = {lw: args.seeds * v["population"] * args.generations / v["evolve_s"]
                    for lw, v in m.items()}
            row += [f"{xr:.1f} -> {xu:.1f} ({xu / xr - 1:+.0%})",
                    f"{m['rolled']['compile_s']:.1f} -> {m['unrolled']['compile_s']:.1f}",
                    f"{rate['rolled']:,.0f} -> {rate['unrolled']:,.0f} "
                    f"({rate['unrolled'] / rate['rolled'] - 1:+.0%})",
                    "equal" if m["rolled"]["hash"] == m["unrolled"]["hash"] else "DIFFER"]
            rows.append(row)
            print(row, flush=True)
    body = (
        f"classic_ga_gapp3_20x20 (corner rule free), {args.seeds} seeds, {args.generations} "
        "generations, population 60 (mpmga: 3 islands of 20), one XLA device, cold "
        "compiles. Each cell: rolled -> unrolled. XLA columns: seconds of XLA compilation "
        "per program (JAX's compile log); compile_s adds tracing and lowering. Results: "
        "SHA-256 of every per-seed path, fitness and history under the two lowerings.\n\n"
        + markdown_table(["preset", "repeat", "XLA init", "XLA evolve", "XLA finish",
                          "XLA total", "compile_s", "evolve ind-gen/s", "results"], rows)
        + f"\n\nAll results identical under both lowerings: {'yes' if same else 'NO'}."
    )
    record("Threefry lowering: rolled vs unrolled", body, write=not args.no_write)
    if not same:
        sys.exit(1)


if __name__ == "__main__":
    main()
