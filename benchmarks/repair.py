"""Cost of median-insertion repair (jaxga.operators.repair.connect) against capacity and round cap.

The issue asks that the repair cost not grow with (insertion rounds x capacity). This
times ``connect`` for 100 S-N-G connections on classic_ga_gapp3_20x20 (random free N) at
capacities 160, 400 and 1600, and with round caps 16 and 64, plus the local repairs of a
mutation (gaps of 2 cells).

    python benchmarks/repair.py [--no-write]
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _results import markdown_table, record, timed

from jaxga.maps import load_map
from jaxga.operators.repair import connect

P = 100


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    free = np.flatnonzero(~grid.blocked_np().reshape(-1))
    rng = np.random.default_rng(0)
    sng = np.stack([np.zeros(P, int), rng.choice(free, P), np.full(P, 399)], 1)
    # Local repairs: a node and a cell two steps away (as after a point mutation).
    w = grid.width
    a = rng.choice(free, P)
    b = np.clip(a + 2 * rng.choice([1, -1, w, -w], P), 0, grid.n_cells - 1)
    local = np.stack([a, b, b], 1)
    keys = jax.random.split(jax.random.PRNGKey(0), P)
    rows = []
    for label, anchors in (("S-N-G (initialisation)", sng), ("2-cell gap (mutation)", local)):
        anchors = jnp.asarray(anchors, jnp.int32)
        for cap in (160, 400, 1600):
            for rounds in (16, 64):
                f = jax.jit(jax.vmap(lambda k, x, c=cap, r=rounds: connect(k, grid, x, 3, c, r)))
                t = timed(f, keys, anchors, repeats=7)
                ok = float(jnp.mean(f(keys, anchors)[2]))
                rows.append([label, cap, rounds, t / P * 1e6, f"{ok:.2f}"])
    body = (f"{P} connections, jit + vmap, median of 7 calls.\n\n"
            + markdown_table(["connection", "capacity", "max rounds", "us / connection",
                              "success rate"], rows))
    record("repair: connect cost vs capacity and round cap", body, write=not args.no_write)


if __name__ == "__main__":
    main()
