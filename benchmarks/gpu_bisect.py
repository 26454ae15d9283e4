# Copied from the project's shared tools (gpu_bisect.py) as it was run for decision 048, so that
# RESULTS "GPU diagnosis on ..." can be reproduced from this repository.
"""GPU bisection of the initialisation failure (decision 037), one short script.

sga's random walks and the field walks use no operation a correct backend may compute
differently (every construct they use was reviewed), so on ANY correct backend every walk equals the
CPU's bit for bit, and a field walk never fails. This computes one round of walks
(+ the initialiser's path check) for R runs x 60 candidates as one nested vmap on the
default device and compares each walk with the CPU's:

  differ      walks whose cells or length differ from the CPU's
  raw_ok_bad  walks the walk itself calls successful whose path fails the check
              (a hole in the path buffer: lost or misplaced `buf.at[n_moves+1].set`)
  ok_only     same cells and length, different verdict (the check itself differs)

Variants (one suspect switched off at a time; all equal the CPU's as_is on the CPU):
  as_is          random walks as the code is                  (every R)
  field          field walks (the fallback; never fails)      (every R)
  full_init      the whole initialisation of R runs, runs compared (largest R <= 256)
  no_compaction  lane_while_loop as one plain vmapped while_loop
  masked         the walk's loop masked (finished lanes keep their carry)
  no_hints       every scatter/gather lowered without unique_indices/indices_are_sorted
  probe_bool / probe_i32   a per-lane table updated by .at[i].set in a vmapped
                 while_loop (jax-ml/jax#38005's pattern: bool tables wrong on TPU)
  xla:<opt>=<v>  as_is compiled with one XLA option changed (GPU only)

Usage: python gpu_bisect.py [--runs 10 256 2048] [--variants ...] [--json out.json]
"""
import argparse
import json
import time

import jax
import jax.numpy as jnp
import numpy as np
from jax._src.interpreters import mlir
from jax._src.lax import slicing

import jaxga
from jaxga._batching import lanes
from jaxga.engine.run import run_init
from jaxga.operators.init import field_walk, walks
from jaxga.operators.init.population import _valid_path

ap = argparse.ArgumentParser()
ap.add_argument("--runs", type=int, nargs="+", default=[10, 256, 2048])
ap.add_argument("--variants", nargs="+", default=None)
ap.add_argument("--json", default=None)
args = ap.parse_args()

cpu, dev = jax.devices("cpu")[0], jax.devices()[0]
on_gpu = dev.platform != "cpu"
ga = jaxga.GA("sga", "classic_ga_gapp3_20x20")
cap, P = ga.algorithm.capacity, 60
ORIG_LWL = walks.lane_while_loop
DEFAULT_MIN = lanes.lane_while_loop.__kwdefaults__["min_lanes"]
ORIG_SCATTER, ORIG_GATHER = slicing._scatter_lower, slicing._gather_lower


def walk_fn(kind="random"):
    def one(k):
        if kind == "field":
            c, n, ok = field_walk(k, ga.grid, cap)
        else:
            c, n, ok = walks.random_walk(k, ga.grid, cap)
        return c, n, ok, ok & _valid_path(ga.grid, c, n)
    return jax.vmap(jax.vmap(one))


def full_init_fn():
    def one(k):
        st, s = run_init(ga.algorithm, k[0], ga.grid, ga.default_params)
        return st.islands.cells, st.islands.length, s.successes, s.attempts, s.n_failed
    return jax.vmap(one)


def probe_fn(dtype):
    T = 64
    def one(k):
        idx = jax.random.randint(k, (T,), 0, 400)
        def body(c):
            t, tab = c
            return t + 1, tab.at[idx[t]].set(jnp.ones((), dtype))
        _, tab = jax.lax.while_loop(lambda c: c[0] < T, body, (0, jnp.zeros((400,), dtype)))
        return jnp.array_equal(tab, jnp.zeros((400,), dtype).at[idx].set(jnp.ones((), dtype)))
    return jax.vmap(jax.vmap(one))


def set_variant(v):
    walks.lane_while_loop = ORIG_LWL
    lanes.lane_while_loop.__kwdefaults__["min_lanes"] = DEFAULT_MIN
    mlir.register_lowering(slicing.scatter_p, ORIG_SCATTER)
    mlir.register_lowering(slicing.gather_p, ORIG_GATHER)
    if v == "no_compaction":
        lanes.lane_while_loop.__kwdefaults__["min_lanes"] = 1 << 40
    elif v == "masked":
        walks.lane_while_loop = lambda c, b, i, **kw: ORIG_LWL(c, b, i, **{**kw, "masked": True})
    elif v == "no_hints":
        mlir.register_lowering(slicing.scatter_p, lambda ctx, *a, **kw: ORIG_SCATTER(
            ctx, *a, **{**kw, "unique_indices": False, "indices_are_sorted": False}))
        mlir.register_lowering(slicing.gather_p, lambda ctx, *a, **kw: ORIG_GATHER(
            ctx, *a, **{**kw, "unique_indices": False, "indices_are_sorted": False}))
    jax.clear_caches()


def run(fn, keys, device, options=None):
    keys = jax.device_put(keys, device)
    lowered = jax.jit(fn).trace(keys).lower()
    compiled = lowered.compile(options) if options else lowered.compile()
    return jax.tree_util.tree_map(np.asarray, compiled(keys))


def compare_walks(here, ref):
    same_path = np.all(here[0] == ref[0], axis=-1) & (here[1] == ref[1])
    return {"differ": int((~same_path).sum()),
            "raw_ok_bad": int((here[2] & ~here[3]).sum()),
            "ok_only": int((same_path & (here[3] != ref[3])).sum()),
            "success_device": round(float(here[3].mean()), 5),
            "success_cpu": round(float(ref[3].mean()), 5)}


xla_opts = ["xla:xla_gpu_enable_command_buffer=", "xla:xla_gpu_deterministic_ops=true",
            "xla:xla_gpu_autotune_level=0"] if on_gpu else []
variants = args.variants or (["as_is", "field", "full_init", "no_compaction", "masked",
                              "no_hints", "probe_bool", "probe_i32"] + xla_opts)
big = max(args.runs)
report = {"device": str(dev), "jax": jax.__version__, "rows": []}
refs = {}
for R in args.runs:
    keys = jax.random.split(jax.random.PRNGKey(2026), R * P).reshape(R, P, -1)
    for v in variants:
        every_r = v in ("as_is", "field") or v.startswith("probe_")
        if v == "full_init":
            if R != max([r for r in args.runs if r <= 256] or [min(args.runs)]):
                continue
        elif not every_r and R != big:
            continue
        t0 = time.time()
        options = None
        try:
            if v.startswith("xla:"):
                name, _, val = v[4:].partition("=")
                flag = {"true": True, "false": False}
                options = {name: flag.get(val, int(val) if val.isdigit() else val)}
            set_variant(v if v in ("no_compaction", "masked", "no_hints") else "as_is")
            if v == "full_init":
                fn = full_init_fn()
                here = run(fn, keys, dev)
                set_variant("as_is")
                ref = run(fn, keys, cpu)
                d = (np.any((here[0] != ref[0]).reshape(R, -1), 1)
                     | np.any((here[1] != ref[1]).reshape(R, -1), 1))
                row = {"runs_differ": int(d.sum()), "of": R,
                       "success_device": round(float(here[2].sum() / here[3].sum()), 5),
                       "success_cpu": round(float(ref[2].sum() / ref[3].sum()), 5),
                       "runs_short_device": int((here[4] > 0).sum()),
                       "runs_short_cpu": int((ref[4] > 0).sum())}
            elif v.startswith("probe_"):
                fn = probe_fn(jnp.bool_ if v == "probe_bool" else jnp.int32)
                row = {"lanes": R * P, "wrong_tables_device": int((~run(fn, keys, dev)).sum()),
                       "wrong_tables_cpu": int((~run(fn, keys, cpu)).sum())}
            else:
                kind = "field" if v == "field" else "random"
                here = run(walk_fn(kind), keys, dev, options)
                if (kind, R) not in refs:   # every variant's CPU result equals as_is's
                    set_variant("as_is")
                    refs[kind, R] = run(walk_fn(kind), keys, cpu)
                row = {"walks": R * P, **compare_walks(here, refs[kind, R])}
        except Exception as e:  # an option this XLA does not know, a device error, ...
            row = {"error": repr(e)[:300]}
        row["s"] = round(time.time() - t0, 1)
        report["rows"].append({"runs": R, "variant": v, **row})
        print(f"R={R:5d} {v:38s} {json.dumps(row)}", flush=True)
set_variant("as_is")
if args.json:
    json.dump(report, open(args.json, "w"), indent=1)
