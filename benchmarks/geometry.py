"""How long exact line of sight takes per segment, and path checks per population.

``clear`` on random segments of a 256 x 256 Moving AI map (Berlin_1_256, from
``../shared/benchmarks/movingai``; falls back to a generated 256 x 256 map), and
continuity / feasibility / loop removal on populations of 1000 paths of capacity 256.

    python benchmarks/geometry.py [--segments 100000] [--no-write]
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _results import SHARED, markdown_table, record, timed

from jaxga.core.geometry import clear, linear_trial
from jaxga.core.paths import is_continuous, is_feasible, remove_loops
from jaxga.maps import load_map, random_map


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--segments", type=int, default=100_000)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()

    berlin = SHARED / "movingai" / "Berlin_1_256.map"
    if berlin.exists():
        grid, name = load_map(berlin), "Berlin_1_256 (256 x 256)"
    else:
        grid, name = random_map(256, 256, 0.2, 0), "random 256 x 256, 20 % (shared/ missing)"
    free = np.flatnonzero(~grid.blocked_np().reshape(-1)).astype(np.int32)
    rng = np.random.default_rng(0)
    a = jnp.asarray(rng.choice(free, args.segments))
    b = jnp.asarray(rng.choice(free, args.segments))
    rows = []
    for label, fn in (("clear (exact)", clear), ("linear_trial (AGACD eq. 3-6)", linear_trial)):
        f = jax.jit(jax.vmap(fn, in_axes=(None, 0, 0)))
        t = timed(f, grid, a, b)
        frac = float(jnp.mean(f(grid, a, b)))
        rows.append([f"{label}, random segments", args.segments, t * 1e3,
                     t / args.segments * 1e9, f"{frac:.3f} clear"])
    # Short segments, as inside a GA (length <= 8 cells).
    xy = np.stack([free % grid.width, free // grid.width], 1)
    pick = rng.choice(len(free), args.segments)
    d = rng.integers(-8, 9, size=(args.segments, 2))
    bxy = np.clip(xy[pick] + d, 0, 255)
    bs = jnp.asarray((bxy[:, 1] * grid.width + bxy[:, 0]).astype(np.int32))
    for span in (None, 8):
        f = jax.jit(jax.vmap(lambda g, p, q, s=span: clear(g, p, q, s), in_axes=(None, 0, 0)))
        t = timed(f, grid, jnp.asarray(free[pick]), bs)
        rows.append([f"clear (exact), segments <= 8 cells, max_span={span}", args.segments,
                     t * 1e3, t / args.segments * 1e9, ""])

    P, L = 1000, 256
    cells = jnp.asarray(rng.choice(free, (P, L)).astype(np.int32))
    length = jnp.full((P,), 200, jnp.int32)
    for label, fn in (
        ("is_continuous", jax.vmap(is_continuous, in_axes=(None, 0, 0))),
        ("is_feasible (exact clear per segment)", jax.vmap(is_feasible, in_axes=(None, 0, 0))),
    ):
        t = timed(jax.jit(fn), grid, cells, length)
        rows.append([f"{label}, 1000 paths x 256", P, t * 1e3, t / P * 1e9, "per path"])
    for label, nc in (("remove_loops, sort variant", None), ("remove_loops, table variant", 400)):
        small = cells % 400
        fn = jax.jit(jax.vmap(lambda c, n, nc=nc: remove_loops(c, n, nc)))
        t = timed(fn, small, length)
        rows.append([f"{label}, 1000 paths x 256 (20 x 20 cells)", P, t * 1e3, t / P * 1e9,
                     "per path"])
    body = f"Map: {name}.\n\n" + markdown_table(
        ["what", "n", "total (ms)", "per item (ns)", "note"], rows)
    record("geometry: clear per segment, path checks", body, write=not args.no_write)


if __name__ == "__main__":
    main()
