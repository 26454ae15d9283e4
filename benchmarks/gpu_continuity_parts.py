"""Which construct of ``is_continuous`` does a device compute wrongly? (decision 048)

    PYTHONPATH=. python benchmarks/gpu_continuity_parts.py [RUNS ...]  # writes $OUT/probe3.json

After benchmarks/gpu_path_check_parts.py: each piece of ``is_continuous``
(``jaxga.core.paths.cell_steps``), and the whole check with its blocked table gathered as
int32, uint8 and bool (``cont_table_*``, written as the code was before decision 048), on
the CPU's walks, as one call on the device and on the CPU: the walks that differ. Run at
b4ddb0d on the H200: only ``cell_steps``' third output, the step span, and every
``cont_table_*`` differed; since decision 048 ``cell_steps`` slices the cells first.
"""

import json
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxga
from jaxga.core import paths
from jaxga.core.grid import blocked_at, diagonal_legal
from jaxga.operators.init import walks

cpu, dev = jax.devices("cpu")[0], jax.devices()[0]
ga = jaxga.GA("sga", "classic_ga_gapp3_20x20")
grid, cap, P = ga.grid, ga.algorithm.capacity, 60
N, W = grid.n_cells, grid.width
B = np.asarray(grid.blocked)
report = {"device": str(dev), "rows": []}


def on(fn, args, device):
    args = jax.device_put(args, device)
    return jax.tree_util.tree_map(np.asarray, jax.jit(fn).trace(*args).lower().compile()(*args))


def cont_with(table_dtype):
    """is_continuous with the blocked table gathered as table_dtype."""

    def f(cells, length):
        t = jnp.asarray(B.reshape(-1).astype(table_dtype))
        b2 = jnp.asarray(B.astype(table_dtype))
        n = N
        inside = (cells >= 0) & (cells < n)
        cc = jnp.clip(cells, 0, n - 1)
        free = inside & (t[cc] == 0)
        x, y = cc % W, cc // W
        dx, dy = x[1:] - x[:-1], y[1:] - y[:-1]
        span = jnp.maximum(jnp.abs(dx), jnp.abs(dy))
        step_ok = free[:-1] & free[1:]

        def bat(xx, yy):
            ins = (xx >= 0) & (xx < W) & (yy >= 0) & (yy < grid.height)
            return jnp.where(ins, b2.reshape(-1)[jnp.where(ins, yy * W + xx, 0)] != 0, True)

        corner_ok = diagonal_legal(bat(x[1:], y[:-1]), bat(x[:-1], y[1:]), grid.corner_rule)
        step_ok &= (dx == 0) | (dy == 0) | corner_ok
        i = jnp.arange(cells.shape[0] - 1, dtype=jnp.int32)
        legal = ((span == 1) & step_ok) | (i >= length - 1)
        return (
            (length >= 1) & (length <= cells.shape[0]) & jnp.all(inside) & free[0] & jnp.all(legal)
        )

    return f


def vv(f):
    return jax.vmap(jax.vmap(f))


pieces = {
    "is_continuous": lambda c, n: paths.is_continuous(grid, c, n),
    "cont_table_int32": cont_with(np.int32),
    "cont_table_uint8": cont_with(np.uint8),
    "cont_table_bool": cont_with(np.bool_),
    "free_bool_gather": lambda c, n: ~grid.blocked.reshape(-1)[jnp.clip(c, 0, N - 1)],
    "free_int32_gather": lambda c, n: (
        grid.blocked.reshape(-1).astype(jnp.int32)[jnp.clip(c, 0, N - 1)] == 0
    ),
    "xy_divmod": lambda c, n: jnp.stack([jnp.clip(c, 0, N - 1) % W, jnp.clip(c, 0, N - 1) // W]),
    "cell_steps": lambda c, n: paths.cell_steps(grid, c),
    "corner_blocked_at": lambda c, n: blocked_at(
        grid.blocked, jnp.clip(c, 0, N - 1)[1:] % W, jnp.clip(c, 0, N - 1)[:-1] // W
    ),
}
arg_pieces = {  # the table as an argument, not a constant
    "free_bool_gather_arg": lambda c, n, b: ~b.reshape(-1)[jnp.clip(c, 0, N - 1)],
    "free_int32_gather_arg": lambda c, n, b: (
        b.reshape(-1).astype(jnp.int32)[jnp.clip(c, 0, N - 1)] == 0
    ),
}
for R in [int(r) for r in sys.argv[1:]] or [2048, 256, 10]:
    keys = jax.random.split(jax.random.PRNGKey(2026), R * P).reshape(R, P, -1)
    t0 = time.time()
    c, n, ok = on(vv(lambda k: walks.random_walk(k, grid, cap)), (keys,), cpu)
    row = {"runs": R, "walks": R * P}
    for name, f in pieces.items():
        try:
            here, there = on(vv(f), (c, n), dev), on(vv(f), (c, n), cpu)
            diff = [
                np.asarray(h != t).reshape(R * P, -1).any(1)
                if np.ndim(h) >= 2
                else np.asarray(h != t)
                for h, t in zip(jax.tree_util.tree_leaves(here), jax.tree_util.tree_leaves(there))
            ]
            row[name] = [int(d.sum()) for d in diff] if len(diff) > 1 else int(diff[0].sum())
        except Exception as e:
            row[name] = "error " + repr(e)[:200]
    for name, f in arg_pieces.items():
        try:
            g = jax.vmap(jax.vmap(f, (0, 0, None)), (0, 0, None))
            here, there = on(g, (c, n, B), dev), on(g, (c, n, B), cpu)
            row[name] = int((here != there).reshape(R * P, -1).any(1).sum())
        except Exception as e:
            row[name] = "error " + repr(e)[:200]
    row["s"] = round(time.time() - t0, 1)
    report["rows"].append(row)
    print(json.dumps(row), flush=True)
json.dump(report, open(os.path.join(os.environ.get("OUT", "/tmp"), "probe3.json"), "w"), indent=1)
# the failing program's optimised HLO on the device, for a reproducer (256 runs)
try:
    keys = jax.random.split(jax.random.PRNGKey(2026), 256 * P).reshape(256, P, -1)
    c, n, _ = on(vv(lambda k: walks.random_walk(k, grid, cap)), (keys,), cpu)
    args = jax.device_put((c, n), dev)
    comp = jax.jit(vv(lambda c, n: paths.is_continuous(grid, c, n))).trace(*args).lower().compile()
    open(os.path.join(os.environ.get("OUT", "/tmp"), "is_continuous_gpu_hlo.txt"), "w").write(
        comp.as_text()
    )
    np.savez_compressed(
        os.path.join(os.environ.get("OUT", "/tmp"), "walks256.npz"), cells=c, length=n
    )
except Exception as e:
    print("hlo dump failed", repr(e)[:200])
