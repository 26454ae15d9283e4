"""Initialisation study: the layout of Zhu & Pan 2024 Table 2 for every jaxga initialiser.

For each initialiser of :mod:`jaxga.operators.init` (plus Zhu & Pan's "CGA", the unadjusted 1/d
roulette = ``directional`` with ``factors=(1, 1)``) on each classic 20 x 20 built-in map
(corner rule "free", as the papers; start cell 0, goal cell 399):

* per-attempt success rate, from ``--attempts`` independent attempts (one vmapped call
  at population-sized batches of keys; Zhu Table 2 reports successes per 100 attempts);
* microseconds per attempt (jit + vmap over 100 keys, capacity 160, warm);
* time to build a population of ``--size`` valid individuals with
  :func:`jaxga.operators.init.initialise` (redraws included), after compilation: median over
  ``--repeats`` different keys; the compile time is reported separately;
* mean and sd of the Euclidean lengths (:func:`jaxga.core.objectives.path_length`) of all
  individuals built (sd over individuals, which is the scale of Zhu's Table 2 sd column).

Usage::

    PYTHONPATH=. python benchmarks/init_study.py [--size 200] [--repeats 5] [--no-append]

Prints a markdown table and appends it to ``benchmarks/RESULTS.md`` with the command,
date, machine and load average.
"""

from __future__ import annotations

import argparse
import functools
import math
import time

import jax
import numpy as np

from jaxga.core.objectives import path_length
from jaxga.core.paths import population_map
from jaxga.maps import builtin_names, load_map
from jaxga.operators import init as I

CAPACITY = 160

METHODS = {
    "random_walk (GA)": I.random_walk,
    "directional 1/d (CGA)": functools.partial(I.directional, factors=(1.0, 1.0)),
    "directional (Zhu IGA)": I.directional,
    "median_insertion (IMGA)": I.median_insertion,
    "intermittent_connect (MPMGA)": I.intermittent_connect,
    "greedy_random_target (AGACD)": I.greedy_random_target,
    "field_walk (jaxga, preset defaults)": I.field_walk,
    "field_walk (jaxga, hybrid: slack 0.1, T 0)": functools.partial(I.field_walk, slack=0.1,
                                                                     temperature=0.0),
}


def problems(which: str) -> list[tuple[str, object, int]]:
    """``(label, grid with its guide, capacity)``: the classic 20 x 20 maps (corner rule
    free, capacity 160), or the longest scenario of each shared Moving AI map (corner rule
    strict, the automatic capacity)."""
    from _results import SHARED

    from jaxga.engine import default_capacity
    from jaxga.maps import load_map_info, read_scen
    from jaxga.operators.guide import with_guide

    out = []
    if which == "classic":
        for name in builtin_names():
            if name.endswith("_20x20"):
                out.append((name, with_guide(load_map(name, corner_rule="free")), CAPACITY))
        return out
    folder = SHARED / "movingai"
    for path in sorted(folder.glob("*.map")):
        scen = sorted(folder.glob(f"{path.stem}*.scen"))[0]
        p = max(read_scen(scen), key=lambda q: q.optimal_length)
        grid = load_map_info(path, start=p.start, goal=p.goal, corner_rule="strict").grid
        out.append((f"{path.stem} longest ({p.optimal_length:.1f})", with_guide(grid),
                    default_capacity(grid)))
    return out


def diversity(cells: np.ndarray, length: np.ndarray, valid: np.ndarray) -> tuple[int, float]:
    """``(distinct paths, mean pairwise Jaccard distance of their cell sets)`` over the
    valid individuals (up to 200 of them for the pairs)."""
    paths = [tuple(c[:n]) for c, n, v in zip(cells.tolist(), length.tolist(), valid) if v]
    sets = [set(p) for p in paths[:200]]
    dist = [1 - len(a & b) / len(a | b) for i, a in enumerate(sets) for b in sets[i + 1:]]
    return len(set(paths)), float(np.mean(dist)) if dist else float("nan")


def _block(x):
    return jax.tree_util.tree_map(lambda a: a.block_until_ready(), x)


def study(size: int, repeats: int, attempts: int, which: str) -> list[dict]:
    rows = []
    lengths_of = jax.jit(population_map(path_length))
    for map_name, grid, capacity in problems(which):
        for label, fn in METHODS.items():
            # Per-attempt success rate and cost per attempt (batches of 100 keys).
            batch = jax.jit(jax.vmap(lambda k, fn=fn, grid=grid, cap=capacity: fn(k, grid,
                                                                                 cap)))
            keys = jax.random.split(jax.random.PRNGKey(12345), attempts)
            _block(batch(keys[:100]))
            ok_total, times = 0, []
            for i in range(0, attempts, 100):
                t0 = time.perf_counter()
                out = _block(batch(keys[i : i + 100]))
                times.append(time.perf_counter() - t0)
                ok_total += int(np.sum(np.asarray(out[2])))
            rate = ok_total / attempts
            us_attempt = float(np.median(times)) / 100 * 1e6
            if rate == 0:  # the initialiser alone builds nothing here
                rows.append(dict(map=map_name, method=label, rate=0.0, us_attempt=us_attempt,
                                 chunk=0, compile_s=float("nan"), build_s=float("nan"),
                                 failed=size, mean=float("nan"), sd=float("nan"),
                                 init_rate=0.0, repeats=0, distinct=0,
                                 jaccard=float("nan")))
                print(f"{map_name:40s} {label:30s} no path in {attempts} attempts", flush=True)
                continue
            # Population of `size` valid individuals. Rounds of `chunk` candidates, chunk
            # sized from the measured rate so that about one or two rounds suffice.
            chunk = int(min(8000, max(size, math.ceil(1.3 * size / max(rate, 1e-3) / 100) * 100)))
            max_tries = max(1, math.ceil(20 * chunk / size))

            def build(key, fn=fn, grid=grid, chunk=chunk, max_tries=max_tries,
                      cap=capacity):
                return I.initialise(key, grid, fn, size, cap, max_tries=max_tries,
                                    chunk=chunk)

            # Compile time: ahead-of-time lowering + compilation with empty caches (the
            # jitted initialise would otherwise reuse the executable of the previous map).
            jax.clear_caches()
            t0 = time.perf_counter()
            I.initialise.lower(jax.random.PRNGKey(0), grid, fn, size, capacity,
                               max_tries=max_tries, chunk=chunk).compile()
            compile_s = time.perf_counter() - t0
            _block(build(jax.random.PRNGKey(0)))  # warm the jit cache
            build_times, lens, failed, init_rates = [], [], 0, []
            for r in range(1, repeats + 1):
                t0 = time.perf_counter()
                pop, st = _block(build(jax.random.PRNGKey(r)))
                build_times.append(time.perf_counter() - t0)
                valid = np.asarray(st.valid)
                failed += int(st.n_failed)
                init_rates.append(float(st.success_rate))
                lens.append(np.asarray(lengths_of(grid, pop.cells, pop.length))[valid])
                if r == 1:
                    distinct, jaccard = diversity(np.asarray(pop.cells),
                                                  np.asarray(pop.length), valid)
                if sum(build_times) > 30.0:  # very slow builds: fewer repeats
                    break
            lens = np.concatenate(lens) if lens else np.zeros(0)
            rows.append(
                dict(
                    map=map_name, method=label, rate=rate, us_attempt=us_attempt,
                    chunk=chunk, compile_s=compile_s,
                    build_s=float(np.median(build_times)), failed=failed,
                    mean=float(lens.mean()) if lens.size else float("nan"),
                    sd=float(lens.std(ddof=1)) if lens.size > 1 else float("nan"),
                    init_rate=float(np.mean(init_rates)), repeats=len(build_times),
                    distinct=distinct, jaccard=jaccard,
                )
            )
            r_ = rows[-1]
            print(f"{map_name:40s} {label:30s} rate {100 * rate:6.2f}%  {us_attempt:7.1f} us/att  "
                  f"build {r_['build_s']:.4f}s  compile {r_['compile_s']:.1f}s  "
                  f"len {r_['mean']:.2f} +- {r_['sd']:.2f}  failed {failed}", flush=True)
    return rows


def table(rows: list[dict], size: int, repeats: int) -> str:
    head = (
        "| map | method | success per 100 attempts | us per attempt | "
        f"time to build {size} (s) | builds timed | compile (s) | mean length | sd length | "
        f"unfilled | distinct of {size} | mean Jaccard distance |\n"
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    )
    body = "".join(
        f"| {r['map']} | {r['method']} | {100 * r['rate']:.2f} | {r['us_attempt']:.1f} | "
        f"{r['build_s']:.4f} | {r['repeats']} | {r['compile_s']:.1f} | {r['mean']:.2f} | "
        f"{r['sd']:.2f} | {r['failed']} | {r['distinct']} | {r['jaccard']:.3f} |\n"
        for r in rows
    )
    return head + body


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--attempts", type=int, default=2000)
    ap.add_argument("--maps", choices=("classic", "movingai"), default="classic",
                    help="the classic 20 x 20 maps (free) or the longest scenario of each "
                         "shared Moving AI map (strict, automatic capacity)")
    ap.add_argument("--no-append", action="store_true")
    args = ap.parse_args(argv)
    rows = study(args.size, args.repeats, args.attempts, args.maps)
    md = table(rows, args.size, args.repeats)
    print()
    print(md)
    from _results import record

    title = ("init_study: every initialiser on the classic 20 x 20 maps"
             if args.maps == "classic" else "init_study: every initialiser on the Moving AI maps")
    body = (
        (f"Zhu & Pan 2024 Table 2 layout for every initialiser of `jaxga.operators.init` on the "
         f"classic 20 x 20 maps (corner rule \"free\", start 0, goal 399, capacity "
         f"{CAPACITY}). " if args.maps == "classic" else
         "Every initialiser of `jaxga.operators.init` on the longest scenario of each shared "
         "Moving AI map (corner rule \"strict\", the automatic capacity). ")
        + f"distinct = different paths among the {args.size} of the first build; Jaccard = "
        f"mean over pairs of 1 - |A and B| / |A or B| of their cell sets (up to 200 paths). "
        f"Success rate from {args.attempts} independent attempts; us per attempt = jit + "
        f"vmap over 100 keys, warm, median; time to build {args.size} valid individuals "
        f"with `jaxga.operators.init.initialise` (redraws included, rounds of `chunk` candidates "
        f"sized from the measured rate), median over {args.repeats} keys after compilation "
        f"(fewer when the builds took over 30 s; compile time = ahead-of-time compilation of "
        f"`initialise` with empty caches); length = Euclidean path length of all individuals "
        f"built, sd over individuals; unfilled = individuals still missing after the redraw "
        f"budget (summed over the repeats). Paper (Zhu & Pan Table 2, MATLAB, 30 runs, their "
        "Map 3 = classic_ga_gapp3, Map 4 = routeplanning_yangbo): GA 3.57 / 3.03 successes "
        "per 100, CGA 5.42 / 4.12, IGA 34.1 / 24.15; IGA time for 200: 0.445 / 0.731 s; IGA "
        "mean length 71.4 / 81.3 (sd 16.4 / 19.0).\n\n" + md
    )
    record(title, body, write=not args.no_append)


if __name__ == "__main__":
    main()
