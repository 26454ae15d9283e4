"""Time the jitted objectives and fitness combiners of :mod:`jaxga.core.objectives`.

1000 random continuous paths (8-adjacent random walks, lengths between L/2 and L,
padded by repeating the last cell) of capacity L = 256 on a 64 x 64 map with 20 % random
obstacles. Every function is lifted to the population with
:func:`jaxga.core.paths.population_map` and jitted; after a warm-up call, each repeat evaluates
a *different* pre-built population (the repeats cycle through several random populations
kept on the device), waits with ``block_until_ready`` and is timed on its own; the median
is reported. Because every timed call consumes fresh input, XLA cannot hoist or reuse
work across repeats. The metrics (``min_clearance``, ``tangencies``: ``O(L H W)`` per path)
are timed on 10 paths only.

Usage::

    PYTHONPATH=. python benchmarks/objectives.py [--paths 1000] [--capacity 256] \
        [--size 64] [--repeats 30] [--no-write]

Prints a table (total microseconds per call and per path) and appends a markdown section
to ``benchmarks/RESULTS.md`` (created with a ``# Benchmark results`` heading if missing).
"""

from __future__ import annotations

import argparse
import functools
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from _results import record

from jaxga.core import objectives as ob
from jaxga.core.grid import DIRECTIONS, Grid
from jaxga.core.paths import population_map


def random_population(
    rng: np.random.Generator, n_paths: int, capacity: int, size: int, loop_free: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Random continuous paths, vectorised over paths, padded by repeating the last cell.

    ``loop_free``: self-avoiding random walks (each step to a uniformly random unvisited
    8-neighbour on the map; a walk stops early at a dead end), like the loop-free paths
    a GA population holds. Otherwise plain random walks reflected at the map edges
    (they revisit cells). Target lengths are uniform in ``[capacity / 2, capacity]``.
    """
    rows = np.arange(n_paths)
    xy = np.empty((n_paths, capacity, 2), dtype=np.int64)
    xy[:, 0] = rng.integers(0, size, size=(n_paths, 2))
    visited = np.zeros((n_paths, size, size), dtype=bool)
    visited[rows, xy[:, 0, 1], xy[:, 0, 0]] = True
    length = rng.integers(capacity // 2, capacity + 1, size=n_paths)
    alive = np.ones(n_paths, dtype=bool)
    for j in range(1, capacity):
        cand = xy[:, j - 1, None, :] + DIRECTIONS[None, :, :]  # [P, 8, 2]
        on_map = np.all((cand >= 0) & (cand < size), axis=-1)
        cx, cy = np.clip(cand[..., 0], 0, size - 1), np.clip(cand[..., 1], 0, size - 1)
        ok = on_map & (~visited[rows[:, None], cy, cx] if loop_free else True)
        score = np.where(ok, rng.random(ok.shape), -1.0)
        pick = np.argmax(score, axis=1)
        alive &= ok[rows, pick] & (j < length)
        step = cand[rows, pick]
        xy[:, j] = np.where(alive[:, None], step, xy[:, j - 1])
        length = np.where(alive | (length <= j), length, j)
        visited[rows, xy[:, j, 1], xy[:, j, 0]] = True
    cells = xy[..., 1] * size + xy[..., 0]
    return cells.astype(np.int32), length.astype(np.int32)


def time_call(fn: Callable, inputs: list[tuple], repeats: int) -> tuple[float, float]:
    """Median and minimum wall time (s) of ``fn(*inputs[i % len(inputs)])``, after a warm-up."""
    jax.block_until_ready(fn(*inputs[0]))
    times = []
    for i in range(repeats):
        args = inputs[(i + 1) % len(inputs)]
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), float(np.min(times))


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark, print the table and append it to ``RESULTS.md``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--paths", type=int, default=1000)
    ap.add_argument("--capacity", type=int, default=256)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--no-write", action="store_true", help="do not append to RESULTS.md")
    args = ap.parse_args(argv)

    rng = np.random.default_rng(0)
    blocked = rng.random((args.size, args.size)) < 0.2
    grid = Grid.create(blocked, start=(0, 0), goal=(args.size - 1, args.size - 1))
    pops = []
    for _ in range(4):
        cells, length = random_population(rng, args.paths, args.capacity, args.size)
        feasible = rng.random(args.paths) < 0.9
        pops.append((grid, jnp.asarray(cells), jnp.asarray(length), jnp.asarray(feasible)))
    few = [(g, c[:10], n[:10], f[:10]) for g, c, n, f in pops]
    loopy = []
    for _ in range(4):
        cells, length = random_population(rng, args.paths, args.capacity, args.size, False)
        loopy.append((grid, jnp.asarray(cells), jnp.asarray(length), pops[0][3]))

    objectives: dict[str, Callable] = {
        "path_length": ob.path_length,
        "turn_angles": ob.turn_angles,
        "turns": ob.turns,
        "angle_sum": ob.angle_sum,
        "mpmga_penalty": ob.mpmga_penalty,
        "zhu_penalty": ob.zhu_penalty,
        "imga_energy": ob.imga_energy,
        "imga_safety": ob.imga_safety,
        "agacd_safety (auto = bits)": ob.agacd_safety,
        "agacd_safety (table)": functools.partial(ob.agacd_safety, method="table"),
        "agacd_safety (sort)": functools.partial(ob.agacd_safety, method="sort"),
    }
    combiners: dict[str, Callable] = {
        "imga": ob.imga,
        "agacd": ob.agacd,
        "mpmga": ob.mpmga,
        "iga_zhu": ob.iga_zhu,
        "iga_zhang": ob.iga_zhang,
        "sga": ob.sga,
    }

    def all_objectives(grid, cells, length, feasible):
        del feasible
        return [
            population_map(f)(grid, cells, length)
            for k, f in objectives.items()
            if "sort" not in k and "table" not in k
        ]

    def all_combiners(grid, cells, length, feasible):
        return [population_map(f)(grid, cells, length, feasible) for f in combiners.values()]

    rows: list[tuple[str, int, tuple[float, float]]] = []
    for name, f in objectives.items():
        fn = jax.jit(lambda g, c, n, fe, f=f: population_map(f)(g, c, n))
        rows.append((name, args.paths, time_call(fn, pops, args.repeats)))
    for name, f in combiners.items():
        fn = jax.jit(lambda g, c, n, fe, f=f: population_map(f)(g, c, n, fe))
        rows.append((f"fitness {name}", args.paths, time_call(fn, pops, args.repeats)))
    fn = jax.jit(lambda g, c, n, fe: population_map(ob.agacd_safety)(g, c, n))
    rows.append(
        (
            "agacd_safety (auto, walks that revisit cells: exact fallback)",
            args.paths,
            time_call(fn, loopy, args.repeats),
        )
    )
    rows.append(
        (
            "ALL objectives (one jit)",
            args.paths,
            time_call(jax.jit(all_objectives), pops, args.repeats),
        )
    )
    rows.append(
        (
            "ALL fitness combiners (one jit)",
            args.paths,
            time_call(jax.jit(all_combiners), pops, args.repeats),
        )
    )
    for name, f in (
        ("min_clearance", ob.min_clearance),
        ("tangencies", ob.tangencies),
        ("metrics", ob.metrics),
    ):
        fn = jax.jit(lambda g, c, n, fe, f=f: population_map(f)(g, c, n))
        rows.append((f"{name} (O(L H W))", 10, time_call(fn, few, max(3, args.repeats // 5))))

    header = (
        "| function | paths | median total (us) | median per path (us) | min total (us) |\n"
        "|---|---:|---:|---:|---:|"
    )
    lines = [header] + [
        f"| {name} | {n} | {t * 1e6:,.0f} | {t * 1e6 / n:.2f} | {tmin * 1e6:,.0f} |"
        for name, n, (t, tmin) in rows
    ]
    table = "\n".join(lines)
    print(table)

    mean_len = np.mean([np.mean(np.asarray(p[2])) for p in pops])
    record(
        "objectives",
        f"{args.paths} random continuous loop-free paths (self-avoiding random walks, "
        f"mean length {mean_len:.0f} nodes), capacity {args.capacity}, "
        f"{args.size} x {args.size} map with 20 % obstacles; median of {args.repeats} "
        "calls, each on a different population (other processes may share the cores: "
        f"compare the min column).\n\n{table}",
        write=not args.no_write,
    )


if __name__ == "__main__":
    main()
