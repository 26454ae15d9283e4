"""Batched primitives on XLA:CPU: the plain vmapped op against jaxga's replacement.

    python benchmarks/batched_ops.py [--repeats 9] [--no-write]

Each row times one jitted call on the batch shape it has inside an evolution (seeds x
pairs or seeds x segments) and checks that both give the same array:

* position table (crossover lookups, loop removal): ``full(n, -1).at[keys].max(arange(L))``
  vmapped over 100 seeds x 30 pairs (20 x 20 map, L = 160) and 32 seeds x 40 pairs
  (50 x 50, L = 400), against :func:`jaxga._batching.scatter.position_table`;
* gate order of :func:`jaxga.operators.lift.gated_map` over AGACD's 60 x 159 segments for 20
  seeds: ``argsort(~flags, stable=True)`` against
  :func:`jaxga._batching.scatter.true_first_order`.
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from _results import markdown_table, record, timed

from jaxga._batching.scatter import position_table, true_first_order


def _nest(fn, depth, in_axes=0):
    for _ in range(depth):
        fn = jax.vmap(fn, in_axes=in_axes)
    return jax.jit(fn)


def cases(rng):
    for label, batch, n_cells, length in [("20x20", (100, 30), 400, 160),
                                          ("50x50", (32, 40), 2500, 400)]:
        keys = jnp.asarray(rng.integers(0, n_cells, batch + (length,)), jnp.int32)

        def plain(k, n=n_cells):
            return jnp.full((n,), -1, jnp.int32).at[k].max(
                jnp.arange(k.shape[0], dtype=jnp.int32), mode="drop")

        yield (f"position table, {label}: {batch[0]} x {batch[1]} x L {length}",
               _nest(plain, 2), _nest(lambda k, n=n_cells: position_table(k, n), 2), (keys,))

    flags = jnp.asarray(rng.random((20, 60 * 159)) < 0.13)
    yield ("gate order, 20 seeds x 9,540 segments",
           _nest(lambda f: jnp.argsort(~f, stable=True).astype(jnp.int32), 1),
           _nest(true_first_order, 1), (flags,))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows = []
    for name, plain, ours, xs in cases(np.random.default_rng(0)):
        same = bool(np.array_equal(np.asarray(plain(*xs)), np.asarray(ours(*xs))))
        t_plain = timed(plain, *xs, repeats=args.repeats)
        t_ours = timed(ours, *xs, repeats=args.repeats)
        rows.append([name, f"{t_plain * 1e3:.2f}", f"{t_ours * 1e3:.2f}",
                     f"{t_plain / t_ours:.1f}", "yes" if same else "NO"])
        print(rows[-1], flush=True)
    body = ("Median of the jitted call's wall time, in ms, one XLA device.\n\n"
            + markdown_table(["batched op", "plain vmap ms", "jaxga ms", "speed-up",
                              "same result"], rows))
    record("batched primitives: plain vmap vs position_table / true_first_order", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
