"""Which part of the initialisers' path check does a device compute wrongly? (decision 048)

    PYTHONPATH=. python benchmarks/gpu_path_check_parts.py [RUNS ...]   # writes $OUT/probe2.json

The bisection (benchmarks/gpu_bisect.py) showed the walks' cells and lengths equal to the
CPU's at every batch size on an H200, while their check (``_valid_path``) said False for
some at 256 and 2048 runs per call. This evaluates each part of the check, and other ways
to build the position table, on the CPU's walks, as one call on the device and on the
CPU, and counts the walks that differ (0 everywhere on the CPU). Run at b4ddb0d on the
H200: only ``is_continuous`` differed (RESULTS "GPU diagnosis on ...").
"""

import json
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxga
from jaxga._batching import scatter
from jaxga.core import paths
from jaxga.operators.init import walks
from jaxga.operators.init.population import _valid_path

cpu, dev = jax.devices("cpu")[0], jax.devices()[0]
ga = jaxga.GA("sga", "classic_ga_gapp3_20x20")
grid, cap, P = ga.grid, ga.algorithm.capacity, 60
N = grid.n_cells
report = {"device": str(dev), "rows": []}


def on(fn, args, device):
    args = jax.device_put(args, device)
    return jax.tree_util.tree_map(np.asarray, jax.jit(fn).trace(*args).lower().compile()(*args))


def vv(f):
    return jax.vmap(jax.vmap(f))


def plain_table(keys):  # one row's scatter-max, batched by vmap (no custom_vmap)
    i = jnp.arange(keys.shape[-1], dtype=jnp.int32)
    return jnp.full((N,), -1, jnp.int32).at[keys].max(i, mode="drop")


def compare_table(keys):  # no scatter: table[c] = max_i where(keys[i]==c, i, -1)
    i = jnp.arange(keys.shape[-1], dtype=jnp.int32)
    c = jnp.arange(N, dtype=jnp.int32)
    return jnp.max(jnp.where(keys[None, :] == c[:, None], i[None, :], -1), axis=1)


def keys_of(c, n):
    i = jnp.arange(c.shape[0], dtype=jnp.int32)
    return jnp.where(i < n, c, N)


def with_table(table_fn):
    def lf(c, n):
        k = keys_of(c, n)
        t = table_fn(k)
        i = jnp.arange(c.shape[0], dtype=jnp.int32)
        look = jnp.where(i < n, t[jnp.clip(c, 0, N - 1)], i)
        on_map = (c >= 0) & (c < N)
        return jnp.all((i >= n) | (on_map & (look == i)))

    return lf


checks = {
    "valid_path": lambda c, n: _valid_path(grid, c, n),
    "has_endpoints": lambda c, n: paths.has_endpoints(grid, c, n),
    "is_continuous": lambda c, n: paths.is_continuous(grid, c, n),
    "loop_free_table": lambda c, n: paths.is_loop_free(c, n, N),
    "loop_free_sort": lambda c, n: paths.is_loop_free(c, n),
    "loop_free_flat_pt": with_table(lambda k: scatter.position_table(k, N)),
    "loop_free_plain_vmap": with_table(plain_table),
    "loop_free_compare": with_table(compare_table),
    "loop_free_batched_rows": with_table(lambda k: scatter._rows_batched(k[None], N)[0]),
}
tables = {
    "table_flat_pt": lambda c, n: scatter.position_table(keys_of(c, n), N),
    "table_plain_vmap": lambda c, n: plain_table(keys_of(c, n)),
    "table_compare": lambda c, n: compare_table(keys_of(c, n)),
}
for R in [int(r) for r in sys.argv[1:]] or [2048, 256, 10]:
    keys = jax.random.split(jax.random.PRNGKey(2026), R * P).reshape(R, P, -1)
    t0 = time.time()
    c, n, ok = on(vv(lambda k: walks.random_walk(k, grid, cap)), (keys,), cpu)
    row = {"runs": R, "walks": R * P, "walk_ok_cpu": int(ok.sum())}
    for name, f in {**checks, **tables}.items():
        try:
            here = on(vv(f), (c, n), dev)
            there = on(vv(f), (c, n), cpu)
            d = here != there
            row[name] = int(d.reshape(R * P, -1).any(1).sum()) if d.ndim > 2 else int(d.sum())
            if name == "valid_path":
                row["valid_ok_cpu_dev"] = [int(there.sum()), int(here.sum())]
        except Exception as e:
            row[name] = "error " + repr(e)[:200]
    # the flat table alone, one row per walk as the custom_vmap folds it (R*P rows)
    try:
        k2 = (
            np.where(np.arange(c.shape[-1]) < n[..., None], c, N)
            .reshape(R * P, -1)
            .astype(np.int32)
        )
        def flat(k):
            return scatter._rows_flat(k, N)

        def batched(k):
            return scatter._rows_batched(k, N)

        row["rows_flat_2d"] = int((on(flat, (k2,), dev) != on(flat, (k2,), cpu)).any(1).sum())
        row["rows_batched_2d"] = int(
            (on(batched, (k2,), dev) != on(batched, (k2,), cpu)).any(1).sum()
        )
    except Exception as e:
        row["rows_2d"] = "error " + repr(e)[:200]
    row["s"] = round(time.time() - t0, 1)
    report["rows"].append(row)
    print(json.dumps(row), flush=True)
json.dump(report, open(os.path.join(os.environ.get("OUT", "/tmp"), "probe2.json"), "w"), indent=1)
