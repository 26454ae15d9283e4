"""Time B-spline smoothing (jaxga.smooth) of 1 and 100 paths on 20 x 20 and 50 x 50.

IMGA's Table 4 compares its broken line with BCA, a GA over Bezier control points that
needs 136.5 s per smoothed path; this measures what smoothing a post-optimised path costs
here. Paths: for 100 random start/goal pairs (at least half a map apart, connected), the
exact any-angle optimum (even pairs) or the 8-connected optimum (odd pairs), as a GA's
post-optimised and raw best paths would look. Maps: classic_ga_gapp3_20x20 and a 50 x 50
random map with 20 % obstacles, corner rule "strict" (under "free" optima often squeeze
between diagonal obstacles, where smoothing must fall back). Default SmoothConfig
(``n_ctrl = H + W``, 200 Adam steps). Times are medians of repeated calls after a
compiling call; the distance field is computed once per map and passed in (its own time
is a separate row).

    PYTHONPATH=. python benchmarks/smooth.py [--repeats 5] [--no-write]
"""

from __future__ import annotations

import argparse
import functools
import time

import jax
import jax.numpy as jnp
import numpy as np
from _results import markdown_table, record

from jaxga.core.grid import Grid
from jaxga.core.paths import from_coords
from jaxga.curve_clearance import distance_field
from jaxga.maps import load_map
from jaxga.maps.generators import random_map
from jaxga.reference.any_angle import any_angle_shortest_path
from jaxga.reference.optima import shortest_path
from jaxga.smooth import SmoothConfig, smooth, smooth_population

P = 100


def paths_for(grid: Grid, n: int, seed: int = 0) -> list[np.ndarray]:
    """``n`` optimal paths between random free start/goal pairs at least (H + W) / 4 apart."""
    rng = np.random.default_rng(seed)
    free = np.argwhere(~grid.blocked_np())[:, ::-1]
    min_dist = (grid.height + grid.width) / 4
    out: list[np.ndarray] = []
    while len(out) < n:
        s, g = free[rng.integers(0, len(free), 2)]
        if np.hypot(*(g - s)) < min_dist:
            continue
        sub = grid.replace(start=tuple(s), goal=tuple(g))
        ref = any_angle_shortest_path(sub) if len(out) % 2 == 0 else shortest_path(sub)
        if ref.found:
            out.append(ref.path)
    return out


def timed(fn, inputs: list[tuple], repeats: int) -> tuple[float, float]:
    """(first call incl. compilation, median of ``repeats`` later calls), seconds."""
    t = time.perf_counter()
    jax.block_until_ready(fn(*inputs[0]))
    first = time.perf_counter() - t
    ts = []
    for i in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(fn(*inputs[(i + 1) % len(inputs)]))
        ts.append(time.perf_counter() - t)
    return first, float(np.median(ts))


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark, print the table and append it to ``RESULTS.md``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-write", action="store_true", help="do not append to RESULTS.md")
    args = ap.parse_args(argv)

    maps = [
        ("classic_ga_gapp3_20x20", load_map("classic_ga_gapp3_20x20", corner_rule="strict")),
        ("random 50x50 20 %", random_map(50, 50, 0.2, seed=0, corner_rule="strict")),
    ]
    rows = []
    for name, grid in maps:
        cfg = SmoothConfig().resolved(grid.shape)
        paths = paths_for(grid, P)
        cap = int(max(len(p) for p in paths))
        cap = max(16, 1 << (cap - 1).bit_length())
        cells, lengths = zip(*(from_coords(p, grid.width, cap) for p in paths))
        cells, lengths = jnp.stack(cells), jnp.stack(lengths)

        field_fn = jax.jit(distance_field, static_argnums=1)
        f_first, f_t = timed(field_fn, [(grid, cfg.upsample)], args.repeats)
        field = field_fn(grid, cfg.upsample)
        rows.append([name, "distance_field", 1, f_first, f_t * 1e3, f_t * 1e3, "", "", "", ""])

        one_in = [(grid, cells[i], lengths[i], field) for i in range(args.repeats + 1)]
        first1, t1 = timed(functools.partial(smooth, config=cfg), one_in, args.repeats)
        pop_in = [(grid, cells, lengths, field)]
        first_p, tp = timed(functools.partial(smooth_population, config=cfg), pop_in, args.repeats)

        res = jax.device_get(smooth_population(grid, cells, lengths, field, config=cfg))
        ok = ~res.used_fallback
        ratio = res.length[ok] / res.polyline_length[ok]
        within = res.max_curvature[ok] <= res.curvature_bound[ok] + 1e-4
        turning = ok & (res.curvature_bound > 0)  # straight polylines stay straight
        kb = res.max_curvature[turning] / res.curvature_bound[turning]
        quality = [
            f"{np.mean(res.used_fallback):.2f}",
            f"{np.mean(ratio):.4f} (max {np.max(ratio):.4f})",
            f"{np.mean(res.min_clearance[ok]):.3f} (min {np.min(res.min_clearance[ok]):.3f})",
            f"{np.mean(within):.2f} (max ratio {np.max(kb):.2f})",
        ]
        rows.append([name, f"smooth (n_ctrl {cfg.n_ctrl}, L {cap})", 1, first1, t1 * 1e3,
                     t1 * 1e3, *quality])
        rows.append([name, f"smooth_population (n_ctrl {cfg.n_ctrl}, L {cap})", P, first_p,
                     tp * 1e3, tp * 1e3 / P, *quality])

    headers = ["map", "call", "paths", "first call incl. compile (s)", "median (ms)",
               "ms / path", "fallback rate", "length / polyline", "min clearance",
               "max kappa <= bound"]
    table = markdown_table(headers, rows)
    print(table)
    record(
        "smooth: B-spline smoothing of 1 and 100 paths",
        f"{P} optimal paths (any-angle and 8-connected, alternating) between random "
        "start/goal pairs, corner rule strict; default SmoothConfig (200 Adam steps, "
        f"n_ctrl = H + W); median of {args.repeats} calls after the compiling call, "
        "distance field passed in. Quality columns are over the 100 paths (curves only, "
        "fallbacks excluded); the last is the fraction whose max curvature is within the "
        "polyline's turning curvature bound, and the largest ratio among paths with a "
        "corner. For scale: BCA took 136.5 s per path (IMGA Table 4)."
        f"\n\n{table}",
        write=not args.no_write,
    )


if __name__ == "__main__":
    main()
