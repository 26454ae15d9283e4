"""A robot node's long session: one ``jaxga.Planner`` on a loaded map for hundreds of plans.

A node keeps its planner for hours, so whatever a plan leaves behind adds up. The planner
(``hybrid``, 8 seeds, robot radius 0.2 m) plans ``--plans`` requests on each map, four
kinds in turn: two free cells drawn at random, a blocked start, a start off the map (both
refused with ``EndpointError``) and a start equal to its goal. Recorded: the process's
resident memory (``VmRSS``) after plan 1 and every 50 plans, its open file descriptors and
threads, and the programs XLA compiled after plan 1 (JAX's compile events). A session
that leaks grows between plan 50 (every cache filled) and the last; this one should not:
growth <= 10 MB, no compile, the same descriptors and threads.

    python benchmarks/long_session.py [--map NAME=FILE.yaml] [--plans 800] [--no-write]
"""

from __future__ import annotations

import argparse
import gc
import os
import threading
import time
from pathlib import Path

import jax.monitoring
import numpy as np
from _results import markdown_table, record
from planner import COMPILES, _listen
from planner import MAPS as ROBOT_MAPS

MAPS = {name: ROBOT_MAPS[name] for name in ("tb3_world", "bookstore")}


def resident_mb() -> float:
    """This process's resident memory in MB (Linux's ``/proc``)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def open_descriptors() -> int:
    return len(os.listdir("/proc/self/fd"))


def session(name: str, path: Path, plans: int) -> dict:
    """``plans`` requests of the four kinds on one planner; the samples and counts."""
    import jaxga
    from jaxga.core.errors import EndpointError

    planner = jaxga.Planner(str(path), seeds=8, robot_radius=0.2)
    blocked = np.asarray(planner.map.grid.blocked)
    free, walls = np.argwhere(~blocked), np.argwhere(blocked)
    height, width = blocked.shape
    rng = np.random.default_rng(0)
    samples, kinds = [], {"pair": 0, "blocked start": 0, "off the map": 0, "start = goal": 0}
    refused = succeeded = 0
    compiled_after_first = None
    t0 = time.perf_counter()
    for i in range(plans):
        a, b = free[rng.integers(len(free), size=2)]
        start, goal = (int(a[1]), int(a[0])), (int(b[1]), int(b[0]))
        kind = list(kinds)[i % 4]
        if kind == "blocked start":
            c = walls[rng.integers(len(walls))]
            start = (int(c[1]), int(c[0]))
        elif kind == "off the map":
            start = (width + 5, height // 2)
        elif kind == "start = goal":
            goal = start
        kinds[kind] += 1
        try:
            result = planner.plan(start, goal)
            succeeded += bool(np.any(result.success))
        except EndpointError:
            refused += 1
        if i == 0:
            compiled_after_first = len(COMPILES)
        if i == 0 or (i + 1) % 50 == 0:
            gc.collect()
            samples.append((i + 1, resident_mb(), open_descriptors(), threading.active_count()))
    wall = time.perf_counter() - t0
    return {"map": name, "shape": f"{width} x {height}", "samples": samples, "kinds": kinds,
            "refused": refused, "succeeded": succeeded, "wall": wall,
            "compiles": len(COMPILES) - compiled_after_first}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--map", action="append", default=[], metavar="NAME=FILE.yaml")
    ap.add_argument("--plans", type=int, default=800)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    if args.plans < 100:
        ap.error("--plans: at least 100 (growth is measured from plan 50 to the last sample)")
    maps = dict(m.split("=", 1) for m in args.map) if args.map else MAPS
    jax.monitoring.register_event_duration_secs_listener(_listen)
    rows, curves = [], []
    for name, path in maps.items():
        s = session(name, Path(path), args.plans)
        by_plan = {n: (mb, fds, threads) for n, mb, fds, threads in s["samples"]}
        at50, last = by_plan[50], by_plan[max(by_plan)]
        rows.append([name, s["shape"], args.plans, f"{by_plan[1][0]:,.1f}", f"{at50[0]:,.1f}",
                     f"{last[0]:,.1f}", f"{last[0] - at50[0]:+.1f}",
                     f"{1000 * (last[0] - at50[0]) / (max(by_plan) - 50):+.1f}",
                     f"{at50[1]} / {last[1]}", f"{at50[2]} / {last[2]}", s["compiles"],
                     f"{s['succeeded']} with a path, {s['refused']} refused",
                     f"{s['wall'] / args.plans:.3f}",
                     "yes" if last[0] - at50[0] <= 10 and s["compiles"] == 0
                     and last[1:] == at50[1:] else "no"])
        curves.append(f"{name}: " + ", ".join(f"{n}: {mb:,.1f}" for n, mb, _, _ in s["samples"]))
        print(rows[-1], flush=True)
    body = (
        "One process; one `jaxga.Planner` per map, in the table's order (hybrid, 8 seeds, "
        f"robot radius 0.2 m), {args.plans} plans in turn of four kinds: a random pair of "
        "free cells, a blocked start and a start off the map (both refused with "
        "`EndpointError`), a start equal to its goal. Resident memory (MB) after plan 1, "
        "plan 50 (every cache filled) and the last; the growth from plan 50 on, in all and "
        "per plan; open file descriptors and threads at plan 50 / the last; XLA "
        "compilations after plan 1. Target: growth <= 10 MB, no compilation, the same "
        "descriptors and threads.\n\n"
        + markdown_table(["map", "cells", "plans", "MB plan 1", "MB plan 50", "MB last",
                          "growth MB", "KB per plan", "fds", "threads", "compiles",
                          "results", "s per plan", "flat"], rows)
        + "\n\nResident memory every 50 plans (MB): " + "; ".join(curves) + ".\n")
    print(body)
    if not args.no_write:
        record("a robot node's long session: memory over many plans "
               "(benchmarks/long_session.py)", body)


if __name__ == "__main__":
    main()
