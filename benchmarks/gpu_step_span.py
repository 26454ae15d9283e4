"""The smallest program an H200 computed wrongly (decision 048), ready to report upstream.

    PYTHONPATH=. python benchmarks/gpu_step_span.py [RUNS ...] [--json OUT]

The step span of paths ``c: int32[R, 60, 160]`` of cells on a 20-cell-wide map,
``max(|x[1:] - x[:-1]|, |y[1:] - y[:-1]|)`` with ``x = c % 20`` and ``y = c // 20``
(``jaxga.core.paths.cell_steps`` before decision 048), as one jitted call on JAX's
default device and on the CPU; the rows whose spans differ, for that program and for
variants of it. On jax 0.11.2 and an H200 XLA compiles it into two loop fusions (``y``
into memory, then ``x`` inline beside the slices of ``y``) and 14,411 of 15,360 rows
(R = 256) differ; computing ``x`` or ``y`` alone, slicing the cells before dividing, or
R = 10 give the CPU's values. The cells are the random walks of jaxga's sga initialiser on
``classic_ga_gapp3_20x20`` (R x 60 walks from ``split(PRNGKey(2026), R * 60)``), the input
the fault was found with; on the CPU every count is 0.
"""

from __future__ import annotations

import argparse
import json
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxga
from jaxga.operators.init import walks

WIDTH, CELLS = 20, 400


def xy(c):
    cc = jnp.clip(c, 0, CELLS - 1)
    return cc % WIDTH, cc // WIDTH


def span(c):
    """The program as jaxga had it: coordinates first, then sliced."""
    x, y = xy(c)
    return jnp.maximum(jnp.abs(x[..., 1:] - x[..., :-1]), jnp.abs(y[..., 1:] - y[..., :-1]))


def dx_only(c):
    x, _ = xy(c)
    return x[..., 1:] - x[..., :-1]


def dy_only(c):
    _, y = xy(c)
    return y[..., 1:] - y[..., :-1]


def barrier(c):
    """Both coordinates forced into memory before the slices."""
    x, y = jax.lax.optimization_barrier(xy(c))
    return jnp.maximum(jnp.abs(x[..., 1:] - x[..., :-1]), jnp.abs(y[..., 1:] - y[..., :-1]))


def gathered(c):
    """The next cell's coordinates by a gather (XLA makes it a slice again)."""
    x, y = xy(c)
    nxt, prv = jnp.arange(1, c.shape[-1]), jnp.arange(c.shape[-1] - 1)
    return jnp.maximum(jnp.abs(x[..., nxt] - x[..., prv]), jnp.abs(y[..., nxt] - y[..., prv]))


def cells_sliced_first(c):
    """jaxga since decision 048 (``jaxga.core.grid.step_ends``)."""
    cc = jnp.clip(c, 0, CELLS - 1)
    a, b = cc[..., :-1], cc[..., 1:]
    return jnp.maximum(jnp.abs(b % WIDTH - a % WIDTH), jnp.abs(b // WIDTH - a // WIDTH))


VARIANTS = {"span": span, "dx_only": dx_only, "dy_only": dy_only, "barrier": barrier,
            "gathered": gathered, "cells_sliced_first": cells_sliced_first}
OPTIONS = {"xla_gpu_experimental_max_unroll_factor": 1,
           "xla_gpu_native_emitter_tune_unroll_factor_for_loops": False}
"""XLA options tried on ``span`` off the CPU (neither changed the count on the H200)."""


def walk_cells(runs: int) -> np.ndarray:
    """The walks' cells, computed on the CPU."""
    ga = jaxga.GA("sga", "classic_ga_gapp3_20x20")
    keys = jax.random.split(jax.random.PRNGKey(2026), runs * 60).reshape(runs, 60, -1)
    cpu = jax.devices("cpu")[0]
    walk = jax.jit(jax.vmap(jax.vmap(
        lambda k: walks.random_walk(k, ga.grid, ga.algorithm.capacity)[0])))
    return np.asarray(walk(jax.device_put(keys, cpu)))


def on(fn, c: np.ndarray, device, options: dict | None = None) -> np.ndarray:
    x = jax.device_put(c, device)
    lowered = jax.jit(fn).trace(x).lower()
    return np.asarray((lowered.compile(options) if options else lowered.compile())(x))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", type=int, nargs="*", default=[256, 2048, 10])
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    cpu, dev = jax.devices("cpu")[0], jax.devices()[0]
    report = {"device": str(dev), "jax": jax.__version__, "rows": []}
    for runs in args.runs:
        c, t0 = walk_cells(runs), time.perf_counter()
        row: dict = {"runs": runs, "rows": int(np.prod(c.shape[:-1]))}
        ref = on(span, c, cpu)
        for name, fn in VARIANTS.items():
            differ = on(fn, c, dev) != on(fn, c, cpu)
            row[name] = int(differ.reshape(row["rows"], -1).any(1).sum())
        if dev.platform != "cpu":
            for key, value in OPTIONS.items():
                try:
                    differ = on(span, c, dev, {key: value}) != ref
                    row[f"span {key}={value}"] = int(differ.reshape(row["rows"], -1).any(1).sum())
                except Exception as err:  # noqa: BLE001 - an option this XLA lacks
                    row[f"span {key}={value}"] = f"error: {str(err)[:120]}"
        row["s"] = round(time.perf_counter() - t0, 1)
        report["rows"].append(row)
        print(json.dumps(row), flush=True)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
