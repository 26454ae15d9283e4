"""Seeds per second with 1 device, one device per core, and 2 processes.

    python benchmarks/scale.py [--presets sga,mpmga] [--seeds 32] [--generations G]
        [--no-write]

For each preset on ``classic_ga_gapp3_20x20`` (corner rule free) at the papers' settings
(sga: AGACD Table 6, population 60, 300 generations; mpmga: its preset, 3 islands of 20,
200 generations; ``--generations`` overrides both) and each layout

* ``1 device``: one process, ``--devices 1`` (XLA's default on a CPU);
* ``1 device per core``: one process, ``jaxga._runtime.parallel.set_local_devices()`` (the CLI's
  default);
* ``2 processes``: two processes on loopback (``jaxga._runtime.parallel.initialize``), one device
  each, every process computing half of the seeds, gathered on all;

fresh worker processes run the seeds twice: once to compile (or load compiled programs
from the CLI's persistent cache, ``$JAXGA_CACHE_DIR``) and once timed, with other
seeds of the same count. Seeds per second = seeds / wall time of the second call on
process 0 (initialisation, evolution, post-optimisation and, with 2 processes, the
gathering). The machine may be shared: the load averages before
and after are printed and recorded; timings under load are noisy.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

from _results import markdown_table, record

HERE = Path(__file__).resolve().parent
MAP = "classic_ga_gapp3_20x20"
PAPER = {"sga": dict(population__size=60, generations=300),
         "mpmga": dict(population__size=20, generations=200)}


def worker(preset: str, seeds: int, generations: int | None, devices: int | None,
           coordinator: str | None, process_id: int) -> dict:
    """One layout's measurement in this (fresh) process."""
    import jaxga._runtime.parallel as par

    par.set_local_devices(devices)
    if coordinator:
        par.initialize(coordinator, 2, process_id, timeout=600)
    import jax

    from jaxga import configure
    from jaxga.api import run

    configure()  # as the CLI does: $JAXGA_CACHE_DIR

    kw = dict(PAPER[preset])
    if generations:
        kw["generations"] = generations
    first = run(preset, MAP, seeds=seeds, corner_rule="free", **kw)
    t0 = time.perf_counter()
    r = run(preset, MAP, seeds=range(seeds, 2 * seeds), corner_rule="free", **kw)
    wall = time.perf_counter() - t0
    return {"devices": jax.local_device_count(), "processes": par.process_count(),
            "compile_s": first.timing["compile_s"], "wall_s": wall,
            "seeds_per_s": seeds / wall, "success": float(r.success.mean()),
            "generations": r.generations}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def measure(preset: str, seeds: int, generations: int | None, layout: str) -> dict:
    """Run one layout in fresh processes; process 0's measurement."""
    base = [sys.executable, str(Path(__file__).resolve()), "--worker", preset,
            "--seeds", str(seeds)]
    if generations:
        base += ["--generations", str(generations)]
    if layout == "1 device":
        cmds = [base + ["--devices", "1"]]
    elif layout == "1 device per core":
        cmds = [base]
    else:
        port = _free_port()
        cmds = [base + ["--devices", "1", "--coordinator", f"127.0.0.1:{port}",
                        "--process-id", str(i)] for i in range(2)]
    env = {k: v for k, v in os.environ.items()
           if k not in ("XLA_FLAGS", "JAX_NUM_CPU_DEVICES")}
    procs = [subprocess.Popen(c, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for c in cmds]
    try:
        outs = [p.communicate(timeout=3600) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    for p, (_, err) in zip(procs, outs):
        if p.returncode != 0:
            raise SystemExit(f"{layout} worker failed:\n{err[-3000:]}")
    return json.loads(outs[0][0].strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="sga,mpmga")
    ap.add_argument("--seeds", type=int, default=32)
    ap.add_argument("--generations", type=int, default=None,
                    help="override the papers' generation counts")
    ap.add_argument("--no-write", action="store_true", help="do not append to RESULTS.md")
    ap.add_argument("--worker", metavar="PRESET", help=argparse.SUPPRESS)
    ap.add_argument("--devices", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--coordinator", help=argparse.SUPPRESS)
    ap.add_argument("--process-id", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker, args.seeds, args.generations, args.devices,
                                args.coordinator, args.process_id)))
        return

    layouts = ("1 device", "1 device per core", "2 processes")
    load_before = os.getloadavg()
    print(f"load average before: {load_before}", flush=True)
    rows = []
    for preset in args.presets.split(","):
        base = None
        for layout in layouts:
            m = measure(preset, args.seeds, args.generations, layout)
            base = base or m["seeds_per_s"]
            rows.append([preset, layout, m["processes"], m["devices"], m["generations"],
                         args.seeds, m["compile_s"], m["wall_s"], m["seeds_per_s"],
                         m["seeds_per_s"] / base, f"{os.getloadavg()[0]:.1f}"])
            print(rows[-1], flush=True)
    load_after = os.getloadavg()
    table = markdown_table(
        ["preset", "layout", "processes", "devices per process", "generations", "seeds",
         "compile s (proc 0)", "wall s", "seeds/s", "speed-up", "load (1 min)"], rows)
    body = (
        f"Map {MAP} (corner rule free); sga population 60, mpmga 3 x 20 (papers' "
        "settings unless the generations column says otherwise). Seeds/s from the second "
        "of two calls in fresh worker processes (the first compiles); with 2 processes, "
        "process 0's wall time including the gathering. Load averages "
        f"{', '.join(f'{v:.1f}' for v in load_before)} before and "
        f"{', '.join(f'{v:.1f}' for v in load_after)} after: the machine was shared, "
        "the numbers are noisy.\n\n" + table)
    record("Scaling: devices and processes (benchmarks/scale.py)", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
