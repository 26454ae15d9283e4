"""Microseconds per individual for every operator of SPEC 4-9, jitted and vmapped.

P = 100 individuals at capacity 160 on a 20 x 20 classic map and capacity 400 on a
generated 50 x 50 map (corner rule "free", as the papers). Each timing is the median of
several calls after compilation; each call gets a fresh key so that nothing is hoisted.

    python benchmarks/operators.py [--repeats 7] [--no-write]
"""

from __future__ import annotations

import argparse
import functools
import time

import jax
import numpy as np
from _results import markdown_table, record

from jaxga.config import registry
from jaxga.core import objectives as ob
from jaxga.core.paths import remove_loops
from jaxga.maps import load_map, random_map
from jaxga.operators import crossover as cx
from jaxga.operators import init
from jaxga.operators import mutation as mu
from jaxga.operators import postprocess as post

P = 100


def median_us(fn, args_for_key, repeats: int) -> tuple[float, float]:
    """(compile seconds, median microseconds per individual)."""
    f = jax.jit(fn)
    t = time.perf_counter()
    jax.block_until_ready(f(*args_for_key(jax.random.PRNGKey(0))))
    compile_s = time.perf_counter() - t
    ts = []
    for r in range(repeats):
        a = args_for_key(jax.random.PRNGKey(r + 1))
        jax.block_until_ready(a)
        t = time.perf_counter()
        jax.block_until_ready(f(*a))
        ts.append(time.perf_counter() - t)
    return compile_s, float(np.median(ts)) / P * 1e6


def bench_map(grid, capacity: int, repeats: int) -> list[list]:
    rows = []
    sga_fit = jax.vmap(lambda c, n: ob.sga(grid, c, n))
    pop, _ = init.initialise(jax.random.PRNGKey(42), grid, init.median_insertion, P, capacity)
    fitness = sga_fit(pop.cells, pop.length)
    fit_fn = functools.partial(ob.sga)

    def k_only(k):
        return (k,)

    def k_pop(k):
        return (k, pop)

    for init_op in registry.operators("init"):
        fn = functools.partial(lambda k, fn: jax.vmap(
            lambda kk: fn(kk, grid, capacity))(jax.random.split(k, P)), fn=init_op.fn)
        rows.append(["init", init_op.name, *median_us(fn, k_only, repeats)])
    for sel_op in registry.operators("selection"):
        if sel_op.fn is None:
            continue
        rows.append(["selection", sel_op.name, *median_us(
            lambda k, fn=sel_op.fn: fn(k, fitness), k_only, repeats)])
    for cx_op in registry.operators("crossover"):
        if cx_op.fn is None:
            continue
        name, op = cx_op.name, cx_op.fn
        if registry.NEEDS_FITNESS in cx_op.traits:
            op = functools.partial(op, fitness_fn=fit_fn)
        lifted = cx.crossover_population(op)
        rows.append(["crossover", name, *median_us(
            lambda k, p, f=lifted: f(k, grid, p, 1.0), k_pop, repeats)])
    mutations = {
        "neighbour_point": mu.neighbour_point, "one_point": mu.one_point,
        "range": mu.range_mutation,
        "segment_sa": functools.partial(mu.segment_sa, temperature=1.0, fitness_fn=fit_fn),
        "point_checked": mu.point_checked, "corner_cut": mu.corner_cut,
    }
    for name, op in mutations.items():
        lifted = mu.mutation_population(op)
        rows.append(["mutation", name, *median_us(
            lambda k, p, f=lifted: f(k, grid, p, 1.0), k_pop, repeats)])
    posts = {
        "shortcut_greedy": lambda k, p: jax.vmap(
            lambda c, n: post.shortcut_greedy(grid, c, n))(p.cells, p.length),
        "simplify_adjacent": lambda k, p: jax.vmap(
            lambda kk, c, n: post.simplify_adjacent(kk, grid, c, n))(
                jax.random.split(k, P), p.cells, p.length),
        "remove_loops": lambda k, p: jax.vmap(
            lambda c, n: remove_loops(c, n, grid.n_cells))(p.cells, p.length),
        "fitness (sga, incl. continuity)": lambda k, p: sga_fit(p.cells, p.length),
    }
    for name, fn in posts.items():
        rows.append(["post", name, *median_us(fn, k_pop, repeats)])
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    maps = [
        ("classic_ga_gapp3_20x20", load_map("classic_ga_gapp3_20x20", corner_rule="free"), 160),
        ("random 50 x 50, 20 % (seed 0)", random_map(50, 50, 0.2, 0, corner_rule="free"), 400),
    ]
    body = [f"P = {P}, jit + vmap, median of {args.repeats} calls after compilation."]
    for label, grid, cap in maps:
        rows = bench_map(grid, cap, args.repeats)
        body.append(f"\n### {label}, capacity {cap}\n")
        body.append(markdown_table(["family", "operator", "compile (s)", "us / individual"],
                                   rows))
    record("operators: microseconds per individual", "\n".join(body), write=not args.no_write)


if __name__ == "__main__":
    main()
