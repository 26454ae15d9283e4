"""Compile once, run many: the waiting a user sees before results (the targets of decision 028).

    python benchmarks/compile_once.py [--presets sga,imga,...] [--sizes 20,32,64]
        [--devices N] [--size-class] [--no-write]

Three measurements, each in fresh processes on this machine:

1. **First command, cold.** README's first command (``jaxga run --preset iga_zhu --map
   classic_ga_gapp3_20x20 --seeds 100``) in a new process with an empty persistent cache:
   seconds until it has printed its table (the process's wall time; the package is
   installed already). Target: 20 s.
2. **After a warm-up.** ``jaxga warmup --presets P --sizes ...`` once per preset into a
   fresh cache, then one new process per case (a map, a seed count, a generation count)
   that runs ``jaxga.run`` and reports ``timing["compile_s"]`` (tracing, lowering and
   reading the programs from the cache, or compiling what the cache lacks) and how many
   programs XLA compiled (``jax.monitoring``'s backend-compile events; 0 = all read from
   the cache). Target: compile <= 2 s for every map up to 64 x 64, seed count up to 1024
   and generation count. The cases: the warmed sizes' open maps and maps of those sizes
   with obstacles (their path capacity may differ: ``jaxga.engine.default_capacity``),
   and a 25 x 25 map (a size not warmed).
3. **A second run in one process.** ``jaxga.run`` of each preset on a 20 x 20 map with 10
   seeds and 50 generations, then on another 20 x 20 map with 30 seeds and 300
   generations: the programs XLA compiles or reads for the second run. Target: 0.

With ``--size-class`` (its own section of the results) every run pads its map to its
size class (``jaxga.run(..., size_class=True)``, ``jaxga warmup --size-class``, default
sizes 32,64: the two classes), measurement 1 is left out (the first command does not use
classes), and the second run of measurement 3 is on a 25 x 25 map (the 20 x 20 map's
class).

Throughput (individual-generations per second, 1000 seeds) is ``benchmarks/speed.py``'s.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import PRESETS, markdown_table, record

HERE = Path(__file__).resolve().parent
COMPILE_EVENT = "/jax/core/compile/backend_compile_duration"
CACHE_EVENT = "/jax/compilation_cache/cache_retrieval_time_sec"

CASES = [  # (map, seeds, generations)
    ("open:20", 5, 50),
    ("random:20", 1024, 20),
    ("random:32", 100, 300),
    ("random:64", 30, 100),
    ("random:25", 10, 50),
]
CLASS_CASES = [*CASES, ("random:50", 30, 100)]


def grid_of(spec: str):
    from jaxga.api.warmup import open_map
    from jaxga.maps.generators import random_map

    kind, size = spec.split(":")
    n = int(size)
    if kind == "open":
        return open_map(n)
    return random_map(n, n, 0.2, seed=3, start=(0, 0), goal=(n - 1, n - 1))


def child(spec: str) -> None:
    import jax

    from jaxga._runtime.parallel import set_local_devices

    set_local_devices(int(os.environ["JAXGA_DEVICES"]))  # as the CLI: before JAX starts

    compiled, loaded = [], []
    jax.monitoring.register_event_duration_secs_listener(
        lambda event, secs, **kw: (compiled if event == COMPILE_EVENT else loaded
                                   if event == CACHE_EVENT else []).append(secs))
    import jaxga._runtime as runtime
    from jaxga import api
    from jaxga.maps import load_map

    job = json.loads(spec)
    if job["kind"] == "case":
        import gc

        from jaxga._runtime.size_classes import class_capacity, class_shape
        from jaxga.api.warmup import open_map
        from jaxga.engine import default_capacity

        grid = grid_of(job["map"])
        r = api.run(job["preset"], grid, seeds=job["seeds"], generations=job["generations"],
                    size_class=job["size_class"])
        stored = sum(p.read for p in gc.get_objects() if isinstance(p, runtime.programs.Programs))
        size = int(job["map"].split(":")[1])
        if job["size_class"]:  # the open map of the class's size, as warmed
            size = max(class_shape(size, size))
            open_capacity = class_capacity(open_map(size))
        else:
            open_capacity = default_capacity(open_map(size))
        print(json.dumps({"compile_s": r.timing["compile_s"], "xla": len(compiled),
                          "loaded": len(loaded), "stored": stored,
                          "capacity": r.path_capacity, "shape": size,
                          "open_capacity": open_capacity,
                          "success": float(r.success.mean())}))
        return
    # second run in one process
    a = load_map("classic_ga_gapp3_20x20")
    b = grid_of("random:25" if job["size_class"] else "random:20")
    b = b.replace(corner_rule=a.corner_rule)
    api.run(job["preset"], a, seeds=10, generations=50, size_class=job["size_class"])
    compiled.clear()
    loaded.clear()
    r = api.run(job["preset"], b, seeds=30, generations=300, size_class=job["size_class"])
    print(json.dumps({"compile_s": r.timing["compile_s"], "xla": len(compiled),
                      "loaded": len(loaded)}))


def in_child(job: dict, cache: str, devices: int) -> dict:
    env = dict(os.environ, PYTHONPATH=f"{HERE.parent}{os.pathsep}{HERE}",
               JAXGA_CACHE_DIR=cache, JAXGA_DEVICES=str(devices))
    proc = subprocess.run([sys.executable, __file__, "--child", json.dumps(job)], env=env,
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    return json.loads(proc.stdout.strip().splitlines()[-1])


def jaxga_command(args: list[str], cache: str, devices: int) -> float:
    env = dict(os.environ, JAXGA_CACHE_DIR=cache, JAXGA_DEVICES=str(devices))
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "jaxga.cli", *args], env=env,
                          capture_output=True, text=True, cwd=HERE.parent)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", default=",".join((*PRESETS, "hybrid")))
    ap.add_argument("--sizes", help="warm-up sizes (default 20,32,64; with --size-class "
                    "32,64)")
    ap.add_argument("--size-class", action="store_true",
                    help="every run and the warm-up with size classes")
    ap.add_argument("--devices", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--child")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    if args.child:
        return child(args.child)
    presets = args.presets.split(",")
    sc = args.size_class
    args.sizes = args.sizes or ("32,64" if sc else "20,32,64")
    first = math.nan
    if not sc:
        with tempfile.TemporaryDirectory(prefix="jaxga-first-") as cache:
            first = jaxga_command(["run", "--preset", "iga_zhu", "--map",
                                   "classic_ga_gapp3_20x20", "--seeds", "100", "--quiet"],
                                  cache, args.devices)
        print(f"first command, cold: {first:.1f} s", flush=True)

    warm_rows, second_rows = [], []
    worst = 0.0
    for preset in presets:
        with tempfile.TemporaryDirectory(prefix="jaxga-warm-") as cache:
            warm_s = jaxga_command(["warmup", "--presets", preset, "--sizes", args.sizes,
                                    *(["--size-class"] if sc else [])], cache, args.devices)
            for m, seeds, gens in CLASS_CASES if sc else CASES:
                out = in_child({"kind": "case", "preset": preset, "map": m, "seeds": seeds,
                                "generations": gens, "size_class": sc}, cache, args.devices)
                warmed = (str(out["shape"]) in args.sizes.split(",")
                          and out["capacity"] == out["open_capacity"])
                if warmed:
                    worst = max(worst, out["compile_s"])
                warm_rows.append([preset, f"{warm_s:.0f}", m.replace(":", " "), seeds, gens,
                                  out["capacity"], "yes" if warmed else "no",
                                  out["compile_s"], out["stored"], out["loaded"],
                                  out["xla"]])
                print(warm_rows[-1], flush=True)
        with tempfile.TemporaryDirectory(prefix="jaxga-second-") as cache:
            out = in_child({"kind": "second", "preset": preset, "size_class": sc}, cache,
                           args.devices)
        second_rows.append([preset, out["compile_s"], out["xla"], out["loaded"]])
        print(second_rows[-1], flush=True)

    if sc:
        body = size_class_body(args, warm_rows, worst, second_rows)
        record("compile once, run many: size classes (benchmarks/compile_once.py "
               "--size-class)", body, write=not args.no_write)
        return
    body = (
        f"{args.devices} XLA host device(s) (the CLI's default: one per core). Targets: "
        "first command <= 20 s; after a warm-up, compile <= 2 s on any map up to 64 x 64 "
        "with any seed and generation count; a second run in one process compiles "
        "nothing.\n\n"
        f"**First command, cold cache, fresh process** (`jaxga run --preset iga_zhu --map "
        f"classic_ga_gapp3_20x20 --seeds 100`, after `pip install`): **{first:.1f} s** to "
        "the printed table.\n\n"
        f"**After `jaxga warmup --presets P --sizes {args.sizes}`** (warm-up seconds per "
        "preset), one fresh process per case. compile s = `timing['compile_s']` "
        "(reading jaxga's three programs from its store, or tracing, lowering and "
        "compiling them); stored = programs read from jaxga's store (3 = all); JAX cache = "
        "programs read from JAX's own cache; XLA = every XLA compilation in the process "
        "(jaxga's programs and its small helper computations: map tables, endpoints); "
        "capacity = the problem's path capacity, part of the programs' shape; shape "
        "warmed = a warmed size with the capacity of the warmed open map. Maps: `open N` "
        "= `jaxga.api.warmup.open_map(N)`, `random N` = `random_map(N, N, 0.2, seed=3)` "
        "corner to corner; corner rule strict.\n\n"
        + tables(warm_rows, worst, second_rows, "another 20 x 20 map under the same corner "
                 "rule")
    )
    record("compile once, run many (benchmarks/compile_once.py)", body,
           write=not args.no_write)


def size_class_body(args, warm_rows: list, worst: float, second_rows: list) -> str:
    """The results section of a ``--size-class`` run."""
    return (
        f"{args.devices} XLA host device(s). Every run with `size_class=True` (the map "
        "padded with blocked cells to its class: sides of 32 or 64 cells, and the class's "
        "path capacity, 160 or 320, unless the problem needs more). Target: after a "
        "warm-up, compile <= 2 s on any map up to 64 x 64 with any seed and generation "
        "count; a second run in one process on another map of the class compiles "
        "nothing.\n\n"
        f"**After `jaxga warmup --presets P --sizes {args.sizes} --size-class`** (warm-up "
        "seconds per preset), one fresh process per case; columns as in \"compile once, "
        "run many\" (shape warmed = the map's class was warmed and its capacity is the "
        "class's).\n\n"
        + tables(warm_rows, worst, second_rows, "a random 25 x 25 map, both with "
                 "`size_class=True`")
    )


def tables(warm_rows: list, worst: float, second_rows: list, second_map: str) -> str:
    """The warm-up table, the longest warmed compile and the second-run table."""
    return (
        markdown_table(["preset", "warm-up s", "map", "seeds", "generations", "capacity",
                        "shape warmed", "compile s", "stored", "JAX cache", "XLA"], warm_rows)
        + f"\n\nLongest compile on a warmed shape: {worst:.2f} s.\n\n"
        "**Second run in one process** (10 seeds x 50 generations on "
        f"`classic_ga_gapp3_20x20`, then 30 seeds x 300 generations on {second_map}): what "
        "the second run compiled or read.\n\n"
        + markdown_table(["preset", "compile s", "XLA", "read"], second_rows)
    )


if __name__ == "__main__":
    main()
