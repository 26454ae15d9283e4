"""One device check: what matters of jaxga's speed and results, on whatever JAX runs on.

    PYTHONPATH=. python benchmarks/device_check.py [--small] [--json PATH] [--no-write]
        [--budget-s S] [--skip PHASE,...] [--maps 20x20,...] [--init-block N]
        [--max-runs-per-call N]
    python benchmarks/device_check.py --from-json PATH   # record a run made elsewhere

Runs on JAX's default backend (a GPU where a CUDA build of JAX finds one, else the CPU)
with nothing but jaxga's own dependencies, from the source tree (``PYTHONPATH=.``), and
prints every phase's time as it goes. Compiles are cold: jaxga's program store and JAX's
persistent cache are off. The phases, in order:

1. **Main job**: the README's first command, ``jaxga run --preset iga_zhu --map
   classic_ga_gapp3_20x20 --seeds 100``, as ``jaxga.run``, with its time line
   (``Result.timing``: loading, references, compile, init, evolve, post, ...).
2. **Agreement** with the CPU for the same seeds (:func:`agreement`): the random bits,
   and a short sweep (32 seeds of the first and the last sweep point) on the device:
   its paths evaluated again, and its runs against the pure core (``jaxga.GA.run``,
   the same seeds) compiled for ``jax.devices("cpu")[0]`` in this process, with both
   mean lengths. Second, so that a device lent for minutes still says whether it agrees.
3. **Sweep**: ``jaxga.sweep("sga", ...)`` over 16 values of ``mutation.probability`` x
   1000 seeds (50 generations), through jaxga's own programs and devices
   (``jaxga._runtime.programs``: calls of the platform's sizes, ``run_layout``).
4. **Throughput** (:func:`throughput`): individual-generations per second of ``sga``
   and ``hybrid`` on 20 x 20, 64 x 64 and 256 x 256 maps, 1k, 10k and 100k runs in ONE
   ``jax.vmap`` call on one device, with each call's compile time and XLA memory. A
   call XLA says will not fit the device's free memory is not run, and an out-of-memory
   error is caught: both are recorded as "did not fit". What the time budget
   (``--budget-s``, default 300 s; 240 s with ``--small``) leaves no room for is
   recorded as "skipped (time budget)".
   Each row also counts the compiled program's while loops and fusions (XLA's kernels,
   about), what a generation launches whatever the number of runs.
5. **Peak memory**: ``device.memory_stats()["peak_bytes_in_use"]`` where the backend
   keeps it (GPUs), else the process's peak resident memory (the CPU), named as such.

Exit status 0 when every phase ran and the agreement holds, else 1 (bad input: 2, one
line). ``--small`` runs the same phases smaller (8 seeds of the main job, 20
generations; a sweep of 16 x 2 seeds; throughput on 20 x 20 with 64 runs per call) so
that the CPU finishes in under 3 minutes; ``tests/repository/test_device_check.py``
runs it. The results go to ``--json`` (default ``./device_check.json``; written after
every phase, so a run cut short keeps what it measured) and, unless ``--no-write``, to
the RESULTS.md section "device check on ..." that names the device. A GPU machine
without a way back for files other than its own output folder runs ``--no-write --json
OUT/device_check.json``; ``--from-json`` then records that file's section here, with
the machine, commit and date it measured.

For a device lent for minutes: ``--skip main_job,agreement`` leaves phases out (shown as
skipped), ``--maps 20x20,64x64`` narrows the throughput maps, and ``--init-block N``
initialises jaxga's runs N at a time on that device instead of the platform's layout
(``jaxga._runtime.programs.platform_layout``: 10 on the CPU, a whole call on a GPU).
``--max-runs-per-call N`` (a power of two) lets jaxga's calls on a GPU or TPU hold up to
N runs per device instead of ``ACCELERATOR_BUCKETS``' 2048, so that a sweep of 16 x 1000
runs is one call: the layout the throughput table's larger calls suggest, measured
through jaxga's own programs (``--skip main_job,agreement,throughput`` measures the sweep
alone). The CPU's layout does not use those buckets: there it changes nothing.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import gc
import json
import os
import platform
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import _results

MAIN_PRESET, MAIN_MAP = "iga_zhu", "classic_ga_gapp3_20x20"
SWEEP_PRESET, SWEEP_KEY = "sga", "mutation.probability"
SWEEP_POINTS = [round(0.02 + 0.032 * i, 3) for i in range(16)]
THROUGHPUT_PRESETS = ("sga", "hybrid")
INITIAL_RUNS = 8
"""Initial populations computed per preset and map for the throughput calls; call ``i``
starts from population ``i mod 8`` with a key of its own."""
AGREEMENT_SEEDS = 32
"""Seeds of the first and of the last sweep point that the agreement phase runs on the
device (a ``jaxga.sweep`` of its own, before the long phases) and again on the CPU."""
INIT_PRESETS = ("sga", "iga_zhu")
"""Presets whose initialisation the agreement phase runs as one ``vmap`` of
:data:`INIT_RUNS` runs on the device and on the CPU (their initialisers, the random and
the directional walk, failed far more often on an H200 than on the CPU: decision 037)."""
INIT_RUNS = 256
"""Runs of that ``vmap`` (32 with ``--small``)."""
LENGTH_RTOL = 1e-5
"""Relative tolerance of a path's float32 length evaluated on another platform.

A length is a sum of square roots of exact integer squares, in a fixed order
(``jaxga.core.objectives.path_length``, ``jaxga._batching.numerics.ordered_sum``), so the
one rounding another backend may do differently is the square root's (XLA promises no
precision for it; a GPU's may be an ulp off): 160 terms an ulp each is 160 x 2^-24, about
1e-5 relative at most. On the CPU the lengths must be identical."""

FULL = {"init_runs": INIT_RUNS, "main_seeds": 100, "main_generations": None,
        "sweep_seeds": 1000, "sweep_generations": 50, "maps": ("20x20", "64x64", "256x256"),
        "seeds": (1000, 10_000, 100_000), "generations": 20, "budget_s": 300.0}
SMALL = {"init_runs": 32, "main_seeds": 8, "main_generations": 20, "sweep_seeds": 2,
         "sweep_generations": 10, "maps": ("20x20",), "seeds": (64,), "generations": 5,
         "budget_s": 240.0}

TITLE = "device check on {device}"

NOT_MEASURED = {"error": "not measured (the run ended before this phase)"}
"""What a partial report (a run cut short) shows for the phases it did not reach."""

PHASES = ("main_job", "agreement", "sweep", "throughput")
SKIPPED = "not measured (skipped: --skip)"
MAP_NAMES = ("20x20", "64x64", "256x256")


class _Parser(argparse.ArgumentParser):
    """Bad input is one line on stderr and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"device_check.py: error: {message}\n")


def say(message: str) -> None:
    """One progress line, at once (a user is waiting for it)."""
    print(f"[device check] {message}", flush=True)


def one_line(err: BaseException) -> str:
    """An error as one line: its type and the first line of its message."""
    text = (str(err).strip().splitlines() or [""])[0][:200]
    return f"{type(err).__name__}: {text}"


@contextlib.contextmanager
def phase(report: dict, name: str, key: str, json_path: Path) -> Iterator[None]:
    """Time the phase ``name`` into ``report["phases"]``, print it, and write the JSON.
    An exception inside ends the phase, not the check: ``report[key]`` is then
    ``{"error": ...}`` (a GPU machine lent for a few minutes keeps the other phases)."""
    say(f"{name} ...")
    t0 = time.perf_counter()
    try:
        yield
    except Exception as err:  # noqa: BLE001 - recorded, the next phase runs
        report[key] = {"error": one_line(err)}
        say(f"{name} failed: {report[key]['error']}")
    finally:
        report["phases"][name] = time.perf_counter() - t0
        say(f"{name}: {report['phases'][name]:.1f} s")
        write_json(report, json_path)


def write_json(report: dict, path: Path) -> None:
    """``report`` as JSON at ``path``, written whole (a partial file is never left)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(report, indent=1, default=float) + "\n", encoding="utf-8")
    tmp.replace(path)


def grid_for(name: str) -> Any:
    """The map of a throughput setting: the README's 20 x 20 map (corner rule free), or
    ``random_map(N, N, 0.1, seed=0)`` from corner to corner (corner rule strict)."""
    from jaxga.maps import load_map, random_map

    if name == "20x20":
        return load_map(MAIN_MAP)
    size = int(name.split("x")[0])
    return random_map(size, size, 0.1, seed=0)


def describe_devices() -> dict:
    """The devices the runs go over (:func:`jaxga._runtime.parallel.run_devices`)."""
    import jax

    from jaxga._runtime.parallel import run_devices

    devices = run_devices()
    kind = devices[0].device_kind
    name = (f"the CPU ({len(devices)} XLA devices)" if devices[0].platform == "cpu"
            else f"{len(devices)} x {kind}")
    return {"platform": devices[0].platform, "device_kind": kind, "count": len(devices),
            "name": name, "jax": jax.__version__, "backend": jax.default_backend()}


def free_device_memory(device: Any) -> tuple[int | None, str]:
    """Bytes a new program may still use on ``device``, and where the number comes from:
    the backend's own counters (``bytes_limit - bytes_in_use``), else 80 % of the
    host's available memory (``/proc/meminfo``; or half the physical memory)."""
    stats = device.memory_stats() or {}
    if "bytes_limit" in stats:
        return int(stats["bytes_limit"] - stats.get("bytes_in_use", 0)), "device"
    with contextlib.suppress(OSError, ValueError, StopIteration):
        with open("/proc/meminfo", encoding="ascii") as f:
            line = next(x for x in f if x.startswith("MemAvailable:"))
        return int(0.8 * int(line.split()[1]) * 1024), "host"
    from jaxga._runtime.memory import physical_memory

    total = physical_memory()
    return (None if total is None else total // 2), "host"


def peak_memory(device: Any) -> dict:
    """The peak memory so far: the device's own counter where it has one, else the
    process's peak resident set (the CPU backend keeps its arrays there)."""
    stats = device.memory_stats() or {}
    if "peak_bytes_in_use" in stats:
        return {"bytes": int(stats["peak_bytes_in_use"]),
                "source": "device.memory_stats()['peak_bytes_in_use']"}
    return {"bytes": _results.peak_rss_bytes(), "source": "process peak RSS (ru_maxrss)"}


def out_of_memory(err: BaseException) -> bool:
    """Whether ``err`` is XLA's out-of-memory error."""
    text = str(err)
    return "RESOURCE_EXHAUSTED" in text or "out of memory" in text.lower()


def main_job(settings: dict) -> dict:
    """The README's first command as ``jaxga.run``: its time line and summary."""
    import numpy as np

    import jaxga
    from jaxga._runtime.timeline import time_line

    t0 = time.perf_counter()
    kw = {} if settings["main_generations"] is None else {
        "generations": settings["main_generations"]}
    r = jaxga.run(MAIN_PRESET, MAIN_MAP, seeds=settings["main_seeds"], **kw)
    wall = time.perf_counter() - t0
    say(time_line(r.timing))
    ok = r.success.astype(bool)
    return {"preset": MAIN_PRESET, "map": MAIN_MAP, "seeds": int(len(r.seeds)),
            "generations": int(r.generations), "timing": dict(r.timing), "wall_s": wall,
            "success": float(ok.mean()),
            "mean_length": float(np.mean(r.length[ok])) if ok.any() else None}


def sweep(settings: dict) -> dict:
    """``jaxga.sweep`` of :data:`SWEEP_PRESET` over :data:`SWEEP_POINTS`: its summary."""
    import jax
    import numpy as np

    import jaxga
    from jaxga._runtime.programs import run_layout

    t0 = time.perf_counter()
    results = jaxga.sweep(SWEEP_PRESET, MAIN_MAP, [{SWEEP_KEY: p} for p in SWEEP_POINTS],
                          seeds=settings["sweep_seeds"],
                          generations=settings["sweep_generations"])
    wall = time.perf_counter() - t0
    timing = results[0].timing
    runs = len(SWEEP_POINTS) * settings["sweep_seeds"]
    n_dev = jax.local_device_count()
    per_device, calls = run_layout(runs, n_dev, grid_for("20x20").n_cells)
    ind_gen = runs * results[0].population * results[0].generations
    summary = {
        "preset": SWEEP_PRESET, "map": MAIN_MAP, "key": SWEEP_KEY, "points": SWEEP_POINTS,
        "seeds": settings["sweep_seeds"], "generations": int(results[0].generations),
        "population": int(results[0].population), "runs": runs, "wall_s": wall,
        "runs_per_call": per_device * n_dev, "calls": calls,
        "timing": dict(timing), "runs_per_s": runs / wall,
        "evolve_ind_gen_per_s": ind_gen / timing["evolve_s"],
        "success": float(np.mean([r.success.mean() for r in results])),
        "mean_length": [float(np.mean(r.length[r.success.astype(bool)]))
                        if r.success.any() else None for r in results],
    }
    say(f"sweep: {runs} runs as {calls} call(s) of {per_device * n_dev} in {wall:.1f} s "
        f"(compile {timing['compile_s']:.1f} s), "
        f"{summary['evolve_ind_gen_per_s']:,.0f} ind-gen/s in the evolution")
    return summary


RUN_FIELDS = ("success", "fitness", "length", "raw_length", "n_cells", "raw_n_cells",
              "failures", "convergence_generation")


def _same_run(device: Any, ref: dict, i: int, j: int) -> bool:
    """Whether run ``i`` of the Result ``device`` equals run ``j`` of the pure core's
    output ``ref``, bit for bit (every field, both paths; the Result's float64 copies of
    the float32 values are compared as float32, which they hold exactly)."""
    import numpy as np

    for key in RUN_FIELDS:
        want = np.asarray(ref[key][j])
        got = np.asarray(getattr(device, key)[i]).astype(want.dtype)
        if got.tobytes() != want.tobytes():
            return False
    for cells, count in (("cells", "n_cells"), ("raw_cells", "raw_n_cells")):
        n = int(getattr(device, count)[i])
        if not np.array_equal(getattr(device, cells)[i, :n], np.asarray(ref[cells][j, :n])):
            return False
    return True


def init_agreement(preset: str, n_runs: int) -> dict:
    """The initial populations of ``n_runs`` seeds of ``preset``, one ``jax.vmap`` on the
    device against the same on the CPU: how many runs are identical, and each side's
    mean initialiser success rate (the share of attempts that made a path)."""
    import jax
    import numpy as np

    import jaxga
    from jaxga.core import prng
    from jaxga.engine.run import run_init

    ga = jaxga.GA(preset, MAIN_MAP)
    keys = prng.seed_keys(np.arange(n_runs))

    def init(key, grid, params):
        state, stats = run_init(ga.algorithm, key, grid, params)
        return state, stats.success_rate

    out = {}
    for side, dev in (("device", jax.devices()[0]), ("cpu", jax.devices("cpu")[0])):
        with jax.default_device(dev):  # every input on that device: nothing closed over
            state, rate = jax.jit(jax.vmap(init, (0, None, None)))(
                *jax.device_put((keys, ga.grid, ga.default_params), dev))
            out[side] = (jax.tree_util.tree_map(np.asarray, state), np.asarray(rate))
    leaves = [jax.tree_util.tree_leaves(out[side][0]) for side in ("device", "cpu")]
    same = np.ones(n_runs, bool)
    for a, b in zip(*leaves):
        same &= np.array([a[i].tobytes() == b[i].tobytes() for i in range(n_runs)])
    return {"preset": preset, "runs": n_runs, "identical": int(same.sum()),
            "device_success_rate": float(out["device"][1].mean()),
            "cpu_success_rate": float(out["cpu"][1].mean())}


def agreement(settings: dict, device: dict) -> dict:
    """A short sweep on the device against the same seeds computed on the CPU, in this
    process: :data:`AGREEMENT_SEEDS` seeds of the first and the last sweep point, run
    by ``jaxga.sweep`` on the device (jaxga's own programs and layout), first among the
    long phases so that a device lent for minutes still says whether it agrees.

    * **bits**: ``jax.random`` draws of every seed's key (split, fold_in, bits,
      uniform), one compiled program on the device against the same draws op by op on
      ``jax.devices("cpu")[0]``: bit for bit on every platform (Threefry is integer
      arithmetic, Salmon et al. 2011).
    * **evaluation**: every path of that sweep (post-optimised and raw) evaluated again
      on the CPU (``jaxga.core.objectives.path_length``) against the lengths the device
      reported: bit for bit on the CPU; within :data:`LENGTH_RTOL` on another platform.
    * **runs**: the same seeds and points as whole runs of the pure core
      (``jax.jit(jax.vmap(GA.run))``, a program of its own: not jaxga's blocked,
      sharded, chunked programs) on the CPU, against the device's. On
      the CPU they must be the same runs bit for bit (``GA.run(PRNGKey(s))`` is seed
      ``s`` of ``jaxga.run``: docs/pure-core.md). On another platform the share of
      identical runs is reported, not required: the selection compares float32
      fitness values, so one ulp of difference in one evaluation can change one choice,
      after which the run follows the same random stream on another trajectory; the
      mean lengths of each point on both show whether the trajectories differ only as
      different seeds would.

    * **initialisation**: :data:`INIT_RUNS` initial populations of each of
      :data:`INIT_PRESETS` as one ``vmap`` (:func:`init_agreement`): identical on the CPU;
      elsewhere, the share of identical runs and both success rates are reported.

    ``agree``: bits and evaluation hold, and on the CPU every run and every initial
    population is identical.
    """
    import jax
    import jax.numpy as jnp
    import numpy as np

    import jaxga
    from jaxga.core import objectives, prng

    cpu = jax.devices("cpu")[0]
    same = device["platform"] == "cpu"
    seeds = list(range(AGREEMENT_SEEDS))
    chosen = [SWEEP_POINTS[0], SWEEP_POINTS[-1]]
    results = jaxga.sweep(SWEEP_PRESET, MAIN_MAP, [{SWEEP_KEY: p} for p in chosen],
                          seeds=len(seeds), generations=settings["sweep_generations"])

    def draws(seed: jax.Array) -> jax.Array:
        key = jax.random.PRNGKey(seed)
        a, b = jax.random.split(key)
        bits = jax.random.bits(jax.random.fold_in(a, 1), (64,), jnp.uint32)
        u = jax.random.uniform(b, (64,))
        return jnp.concatenate([jax.random.key_data(a).ravel(), bits,
                                jax.lax.bitcast_convert_type(u, jnp.uint32)])

    seed_arr = jnp.asarray(seeds, jnp.uint32)
    on_device = np.asarray(jax.jit(jax.vmap(draws))(seed_arr))
    with jax.default_device(cpu):
        on_cpu = np.stack([np.asarray(draws(jax.device_put(s, cpu))) for s in seed_arr])
    bits_identical = bool(np.array_equal(on_device, on_cpu))

    with jax.default_device(cpu):
        ga = jaxga.GA(SWEEP_PRESET, MAIN_MAP, generations=settings["sweep_generations"])
        cells = np.concatenate([np.concatenate([r.cells, r.raw_cells]) for r in results])
        counts = np.concatenate([np.concatenate([r.n_cells, r.raw_n_cells])
                                 for r in results])
        reported = np.concatenate([np.concatenate([r.length, r.raw_length])
                                   for r in results]).astype(np.float32)
        found = counts > 0
        lengths = np.asarray(jax.jit(jax.vmap(lambda c, n: objectives.path_length(
            ga.grid, c, n)))(jax.device_put(cells[found], cpu),
                             jax.device_put(counts[found], cpu)))
        diff = np.abs(lengths - reported[found]) / np.maximum(np.abs(reported[found]), 1)
        eval_identical = bool(np.array_equal(lengths, reported[found]))
        eval_ok = eval_identical if same else bool(np.all(diff <= LENGTH_RTOL))

        keys = prng.seed_keys(np.asarray(seeds * len(chosen)))  # jaxga.run's seeds' keys
        probs = np.repeat(np.asarray(chosen, np.float32), len(seeds))
        params = {k: jnp.broadcast_to(v, (len(probs), *jnp.shape(v)))
                  for k, v in ga.default_params.items()}
        params[SWEEP_KEY] = jnp.asarray(probs, jnp.float32)
        t0 = time.perf_counter()
        ref = jax.jit(jax.vmap(ga.run, (0, 0)))(jax.device_put(keys, cpu),
                                                jax.device_put(params, cpu))
        ref = jax.tree_util.tree_map(np.asarray, ref)
        ref_s = time.perf_counter() - t0
    identical = [_same_run(results[k], ref, s, k * len(seeds) + s)
                 for k in range(len(chosen)) for s in range(len(seeds))]
    ok = ref["success"].astype(bool).reshape(len(chosen), len(seeds))
    cpu_means = [float(np.mean(ref["length"].reshape(ok.shape)[k][ok[k]]))
                 if ok[k].any() else None for k in range(len(chosen))]
    device_means = [float(np.mean(r.length[r.success.astype(bool)]))
                    if r.success.any() else None for r in results]
    inits = [init_agreement(p, settings["init_runs"]) for p in INIT_PRESETS]
    say("agreement: initial populations identical "
        + ", ".join(f"{i['preset']} {i['identical']} of {i['runs']} (success "
                    f"{100 * i['device_success_rate']:.3g} % / {100 * i['cpu_success_rate']:.3g} %"
                    " of attempts)" for i in inits))
    agree = (bits_identical and eval_ok
             and (not same or (all(identical) and all(i["identical"] == i["runs"]
                                                      for i in inits))))
    say(f"agreement: bits {'identical' if bits_identical else 'DIFFER'}; "
        f"{int(found.sum())} path lengths {'identical' if eval_identical else 'differ'} "
        f"(max relative difference {float(diff.max(initial=0)):.1e}); "
        f"{sum(identical)} of {len(identical)} runs identical to the CPU's pure core "
        f"(compiled and run in {ref_s:.1f} s)")
    return {
        "reference": "jax.devices('cpu')[0] in this process",
        "same_platform": same, "bits_identical": bits_identical,
        "evaluation": {"paths": int(found.sum()), "identical": eval_identical,
                       "max_relative_difference": float(diff.max(initial=0)),
                       "tolerance": 0.0 if same else LENGTH_RTOL, "ok": eval_ok},
        "runs": {"compared": len(identical), "identical": int(sum(identical)),
                 "points": chosen, "seeds": seeds,
                 "required": same, "reference_s": ref_s,
                 "device_success": float(np.mean([r.success for r in results])),
                 "cpu_success": float(np.mean(ref["success"])),
                 "device_mean_length": device_means, "cpu_mean_length": cpu_means},
        "init": inits,
        "agree": agree,
    }


def _evolve_call(ga: Any, n: int, generations: int) -> Callable:
    """``(key, initial states, params) -> (best fitness, history)`` of ``n`` runs in one
    ``jax.vmap``: run ``i`` evolves initial population ``i mod INITIAL_RUNS`` with key
    ``split(key, n)[i]`` for ``generations`` generations (``GA.evolve``)."""
    import jax
    import jax.numpy as jnp

    def call(key: jax.Array, initial: Any, params: dict) -> tuple:
        which = jnp.arange(n, dtype=jnp.int32) % INITIAL_RUNS
        states = jax.tree_util.tree_map(lambda x: x[which], initial)
        keys = jax.random.split(key, n)
        final, history = jax.vmap(lambda k, s: ga.evolve(k, s, params, generations))(
            keys, states)
        return final.best_fitness, history["best"]

    return call


def _timed_compile(fn: Callable, *args: Any) -> tuple[Any, float]:
    """``jax.jit(fn)`` traced, lowered and compiled for ``args``; and its seconds."""
    import jax

    t0 = time.perf_counter()
    compiled = jax.jit(fn).trace(*args).lower().compile()
    return compiled, time.perf_counter() - t0


def _timed_call(compiled: Any, *args: Any) -> float:
    """Seconds of a call (the faster of two when the first takes under a second)."""
    import jax

    best = float("inf")
    for _ in range(2):
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(*args))
        best = min(best, time.perf_counter() - t0)
        if best >= 1.0:
            break
    return best


class _Setting:
    """One preset on one map for the throughput calls: the pure core (host work done
    once) and its :data:`INITIAL_RUNS` initial populations, computed at first use."""

    def __init__(self, preset: str, map_name: str, generations: int) -> None:
        import jaxga

        self.preset, self.map_name = preset, map_name
        self.ga = jaxga.GA(preset, grid_for(map_name), generations=generations)
        self.population = self.ga.algorithm.population * self.ga.algorithm.islands
        self.initial: Any = None
        self.init_compile_s: float | None = None
        self.too_large = False

    def initial_states(self) -> Any:
        """The initial populations (compiled and computed the first time)."""
        import jax

        if self.initial is None:
            keys = jax.random.split(jax.random.PRNGKey(12345), INITIAL_RUNS)
            init, self.init_compile_s = _timed_compile(
                jax.vmap(self.ga.init, (0, None)), keys, self.ga.default_params)
            self.initial = jax.block_until_ready(init(keys, self.ga.default_params))
        return self.initial


def program_shape(compiled: Any) -> dict:
    """The compiled program's ``while`` loops and fusions, counted in its optimised HLO
    text: a generation's kernel launches and the loops whose trip counts the slowest run
    sets, whatever the number of runs (empty when the backend gives no text)."""
    try:
        text = compiled.as_text()
    except Exception:  # noqa: BLE001 - a backend without HLO text
        return {}
    ops = [line.split("=", 1)[1] for line in text.splitlines() if " = " in line]
    return {"hlo_while": sum(" while(" in op for op in ops),
            "hlo_fusions": sum(" fusion(" in op for op in ops)}


def _measure(setting: _Setting, n: int, generations: int, device: Any) -> dict:
    """One throughput call of ``n`` runs: compiled, checked against the device's free
    memory, then run (:func:`_timed_call`)."""
    import jax

    params = setting.ga.default_params
    initial = setting.initial_states()
    key = jax.random.PRNGKey(n)
    compiled, compile_s = _timed_compile(_evolve_call(setting.ga, n, generations), key,
                                         initial, params)
    memory = compiled.memory_analysis()
    need = (memory.argument_size_in_bytes + memory.output_size_in_bytes
            + memory.temp_size_in_bytes)
    free, where = free_device_memory(device)
    row = {"compile_s": compile_s, "init_compile_s": setting.init_compile_s,
           "program_bytes": int(need), **program_shape(compiled)}
    if free is not None and need > free:
        row["status"] = (f"did not fit ({need / 2**30:.1f} GiB needed, "
                         f"{free / 2**30:.1f} GiB free on the {where})")
        return row
    run_s = _timed_call(compiled, key, initial, params)
    return {**row, "status": "ok", "run_s": run_s,
            "ind_gen_per_s": n * setting.population * generations / run_s}


def throughput(settings: dict, deadline: float) -> list[dict]:
    """Individual-generations per second of every preset and map at each runs-per-call
    count (:func:`_evolve_call`), the smallest count of every preset and map first,
    until ``deadline`` (``time.perf_counter``); rows in preset, map, count order."""
    import jax

    device = jax.devices()[0]
    generations = settings["generations"]
    settings_by_key: dict[tuple[str, str], _Setting] = {}
    last: dict[tuple[str, str], dict] = {}  # the last call measured, per preset and map
    rows: list[dict] = []
    for n in settings["seeds"]:
        for map_name in settings["maps"]:
            for preset in THROUGHPUT_PRESETS:
                setting = settings_by_key.get((preset, map_name))
                row = {"preset": preset, "map": map_name, "seeds": n,
                       "generations": generations}
                rows.append(row)
                # the estimate: this preset and map's last call, else this preset's,
                # else any preset's (compiles of one map size take about as long)
                seen = last.get((preset, map_name)) or next(
                    (v for (p, _), v in reversed(last.items()) if p == preset),
                    next(reversed(last.values()), None))
                estimate = 0.0 if seen is None else (
                    seen["compile_s"] + seen["run_s"] * n / seen["seeds"]
                    + (seen["init_s"] if setting is None else 0.0))
                left = deadline - time.perf_counter()
                if setting is not None and setting.too_large:
                    row["status"] = "did not fit (a smaller call did not)"
                elif left < 10 or estimate > left:
                    row["status"] = "skipped (time budget)"
                else:
                    try:
                        if setting is None:
                            setting = _Setting(preset, map_name, generations)
                            settings_by_key[preset, map_name] = setting
                        row.update(_measure(setting, n, generations, device))
                        setting.too_large = row["status"] != "ok"
                    except Exception as err:  # noqa: BLE001 - a failure is a row
                        oom = out_of_memory(err)
                        if setting is not None:
                            setting.too_large = oom
                        row["status"] = ("did not fit (out of memory)" if oom
                                         else "error: " + one_line(err))
                    gc.collect()
                if setting is not None:
                    row.update(population=setting.population,
                               capacity=setting.ga.algorithm.capacity)
                    if row["status"] == "ok":
                        last[preset, map_name] = {
                            "compile_s": row["compile_s"], "run_s": row["run_s"],
                            "init_s": setting.init_compile_s or 0.0, "seeds": n}
                say(f"throughput {preset} {map_name} {n:,} runs: " + (
                    f"compile {row['compile_s']:.1f} s, run {row['run_s']:.3f} s, "
                    f"{row['ind_gen_per_s']:,.0f} ind-gen/s, program "
                    f"{row['program_bytes'] / 2**20:,.0f} MiB" if row["status"] == "ok"
                    else row["status"]))
    order = {(p, m, n): i for i, (p, m, n) in enumerate(
        (p, m, n) for p in THROUGHPUT_PRESETS for m in settings["maps"]
        for n in settings["seeds"])}
    return sorted(rows, key=lambda r: order[r["preset"], r["map"], r["seeds"]])


def _fmt(value: Any, digits: int = 2) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:,.{digits}f}"
    return f"{value:,}" if isinstance(value, int) else str(value)


def _main_part(report: dict) -> list[str]:
    s, m = report["settings"], report.get("main_job", NOT_MEASURED)
    generations = ("" if s["main_generations"] is None
                   else f" --generations {s['main_generations']}")
    head = (f"**Main job** (`jaxga run --preset {MAIN_PRESET} --map {MAIN_MAP} --seeds "
            f"{s['main_seeds']}{generations}`, as `jaxga.run`)")
    if "error" in m:
        return [f"{head}: {m['error']}"]
    t = m["timing"]
    return [f"{head}:", "", _results.markdown_table(
        ["load", "references", "compile", "init", "evolve", "post", "any-angle", "total",
         "success", "mean length"],
        [[t.get("load_s"), t.get("references_s"), t.get("compile_s"), t.get("init_s"),
          t.get("evolve_s"), t.get("post_s"), t.get("any_angle_s"), t.get("total_s"),
          m["success"], m["mean_length"]]])]


def _throughput_part(report: dict) -> list[str]:
    s, rows = report["settings"], report.get("throughput", NOT_MEASURED)
    head = (f"**Throughput**: {s['generations']} generations of N runs in one `jax.vmap` "
            f"call on one device, from {INITIAL_RUNS} initial populations; compile = "
            "trace + lower + XLA of that call; MiB = XLA's argument + output + temporary "
            "buffers")
    if isinstance(rows, dict):
        return [f"{head}: {rows['error']}"]
    return [f"{head}.", "", _results.markdown_table(
        ["preset", "map", "runs per call", "population", "compile", "run", "ms/gen",
         "ind-gen/s", "MiB", "loops", "fusions", "status"],
        [[r["preset"], r["map"], f"{r['seeds']:,}", r.get("population", ""),
          _fmt(r.get("compile_s")), _fmt(r.get("run_s"), 3),
          _fmt(1e3 * r["run_s"] / r["generations"], 1) if r.get("run_s") else "",
          _fmt(r.get("ind_gen_per_s"), 0),
          _fmt(r["program_bytes"] / 2**20, 0) if r.get("program_bytes") else "",
          r.get("hlo_while", ""), r.get("hlo_fusions", ""),
          r["status"]] for r in rows])]


def _sweep_part(report: dict) -> list[str]:
    s, sw = report["settings"], report.get("sweep", NOT_MEASURED)
    head = (f"**Sweep** (`jaxga.sweep(\"{SWEEP_PRESET}\", ...)`, {len(SWEEP_POINTS)} "
            f"values of `{SWEEP_KEY}` x {s['sweep_seeds']} seeds, "
            f"{s['sweep_generations']} generations)")
    if "error" in sw:
        return [f"{head}: {sw['error']}"]
    t = sw["timing"]
    return [f"{head}: {sw['wall_s']:.1f} s (compile {t['compile_s']:.1f}, init "
            f"{t['init_s']:.2f}, evolve {t['evolve_s']:.2f}), {sw['runs_per_s']:,.1f} "
            f"runs/s, {sw['evolve_ind_gen_per_s']:,.0f} ind-gen/s in the evolution "
            f"(jaxga's programs: {sw.get('calls', '?')} call(s) of "
            f"{sw.get('runs_per_call', '?')} runs); success {sw['success']:.3f}, mean length "
            f"{_fmt(sw['mean_length'][0])} at `{SWEEP_KEY}` {SWEEP_POINTS[0]:g} and "
            f"{_fmt(sw['mean_length'][-1])} at {SWEEP_POINTS[-1]:g}."]


def _agreement_part(report: dict) -> list[str]:
    ag = report.get("agreement", NOT_MEASURED)
    if ag is NOT_MEASURED or ag.get("error") == SKIPPED:
        return [f"**Agreement with the CPU**: {ag['error']}: **unknown**."]
    if "error" in ag:
        return [f"**Agreement with the CPU**: {ag['error']}: **DO NOT AGREE**."]
    ev, runs = ag["evaluation"], ag["runs"]
    means = ""
    if "device_mean_length" in runs:
        pairs = ", ".join(f"{p:g}: {_fmt(d)} / {_fmt(c)}" for p, d, c in zip(
            runs["points"], runs["device_mean_length"], runs["cpu_mean_length"]))
        means = f"; mean length per `{SWEEP_KEY}`, device / CPU: {pairs}"
    for i in ag.get("init", ()):
        means += (f"; {i['runs']} initial populations of `{i['preset']}` in one `vmap`: "
                  f"{i['identical']} identical, initialiser success "
                  f"{100 * i['device_success_rate']:.3g} % / {100 * i['cpu_success_rate']:.3g} %")
    return [
        f"**Agreement with the CPU** ({ag['reference']}): random bits "
        f"{'identical' if ag['bits_identical'] else 'DIFFERENT'}; {ev['paths']} path "
        f"lengths re-evaluated on the CPU {'identical' if ev['identical'] else 'not identical'}"
        f" (largest relative difference {ev['max_relative_difference']:.1e}, tolerance "
        f"{ev['tolerance']:g}); {runs['identical']} of {runs['compared']} whole runs "
        "identical to `GA.run` compiled for the CPU "
        f"({'required' if runs['required'] else 'reported, not required'}){means}: "
        f"**{'agree' if ag['agree'] else 'DO NOT AGREE'}**."]


def body(report: dict) -> str:
    """The RESULTS.md section of ``report`` (a phase that failed shows its error)."""
    s, device = report["settings"], report["device"]
    lines = [
        f"Device: {device['name']} (JAX's default backend `{device['backend']}`, jax "
        f"{device['jax']}); {'`--small`' if s['small'] else 'full size'}; every compile "
        "cold (no persistent cache); jaxga's runs initialised "
        f"{s.get('init_block', 'the platform layout')} at a time"
        + (f", in calls of up to {s['max_runs_per_call']:,} runs per device on an "
           "accelerator" if s.get("max_runs_per_call") else "")
        + ". Seconds unless named; "
        "ind-gen/s = runs x population x generations / seconds; ms/gen = run / generations; "
        "loops, fusions: `while` loops and fusions in the compiled program.",
        "", *_main_part(report), "", *_throughput_part(report), "", *_sweep_part(report),
        "", *_agreement_part(report), "",
        (f"**Peak memory**: {report['peak_memory']['bytes'] / 2**20:,.0f} MiB "
         f"({report['peak_memory']['source']}). " if "peak_memory" in report else "")
        + "**Phases**: " + ", ".join(f"{k} {v:.1f}" for k, v in report["phases"].items())
        + (f"; wall {report['wall_s']:.0f} s." if "wall_s" in report
           else "; the run ended there (a partial report)."),
    ]
    return "\n".join(lines)


def record(report: dict, write: bool) -> dict:
    """The report's history record and RESULTS.md section, with the command, commit,
    date and machine the report was measured with (``_results.append_record``)."""
    title = TITLE.format(device=report["device"]["name"])
    sec = {"title": title, "command": report["command"], "commit": report["commit"],
           "date": report["date"], "machine": report["machine"], "body": body(report)}
    print(_results.render("", [sec]))
    if write:
        _results.append_record(sec)
        print(f"recorded in {_results.HISTORY} and {_results.RESULTS}")
    return sec


def measured_command(args: argparse.Namespace) -> str:
    """The command line as far as it sets what is measured (``--json`` and
    ``--no-write`` do not): the key of its RESULTS.md section, the same wherever the
    report was written."""
    words = ["python", "benchmarks/device_check.py"]
    if args.small:
        words.append("--small")
    if args.budget_s is not None:
        words += ["--budget-s", f"{args.budget_s:g}"]
    if args.skip:
        words += ["--skip", args.skip]
    if args.maps:
        words += ["--maps", args.maps]
    if args.init_block is not None:
        words += ["--init-block", str(args.init_block)]
    if args.max_runs_per_call is not None:
        words += ["--max-runs-per-call", str(args.max_runs_per_call)]
    return " ".join(words)


def _checked_output(path: str) -> Path:
    """``--json``'s path, refused at once (one line) when it cannot be written."""
    p = Path(path)
    if p.is_dir():
        raise SystemExit(f"device_check.py: error: --json {path} is a directory")
    if not p.parent.is_dir() or not os.access(p.parent, os.W_OK):
        raise SystemExit(f"device_check.py: error: --json {path}: its folder "
                         f"{p.parent} does not exist or is not writable")
    return p


def _read_report(path: str) -> dict:
    """A report written by this script (maybe cut short), or a one-line error."""
    try:
        report = json.loads(Path(path).read_text(encoding="utf-8"))
        report["device"]["name"], report["settings"]["small"], report["phases"]  # noqa: B018
        return report
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise SystemExit(f"device_check.py: error: --from-json {path}: not a complete "
                         f"device check report ({type(err).__name__}: {err})") from None


def main(argv: list[str] | None = None) -> int:
    """Run the check (or record ``--from-json``); the exit status (module docstring)."""
    ap = _Parser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true",
                    help="smaller seeds, maps and generations (under 3 minutes on a CPU)")
    ap.add_argument("--json", default="device_check.json", metavar="PATH",
                    help="where the JSON report goes (default: ./device_check.json)")
    ap.add_argument("--no-write", action="store_true", help="do not touch RESULTS.md")
    ap.add_argument("--budget-s", type=float, default=None, metavar="S",
                    help="seconds the whole check may take; the throughput settings it "
                    "leaves no room for are skipped (default 300, --small 240)")
    ap.add_argument("--from-json", metavar="PATH",
                    help="record the RESULTS.md section of a report written elsewhere")
    ap.add_argument("--skip", default="", metavar="PHASE,...",
                    help=f"phases left out, of {', '.join(PHASES)}")
    ap.add_argument("--maps", default="", metavar="MAP,...",
                    help=f"the throughput maps, of {', '.join(MAP_NAMES)} (default: all; "
                    "--small: 20x20)")
    ap.add_argument("--init-block", type=int, default=None, metavar="N",
                    help="runs initialised together on this device (default: the "
                    "platform's layout)")
    ap.add_argument("--max-runs-per-call", type=int, default=None, metavar="N",
                    help="the most runs per device of jaxga's calls on a GPU or TPU, a "
                    "power of two from 2048 (default: the platform's layout, 2048)")
    args = ap.parse_args(argv)
    if args.from_json:
        record(_read_report(args.from_json), write=not args.no_write)
        return 0
    settings = dict(SMALL if args.small else FULL, small=args.small)
    skip = [p for p in args.skip.split(",") if p]
    if bad := [p for p in skip if p not in PHASES]:
        ap.error(f"--skip {bad[0]!r}: the phases are {', '.join(PHASES)}")
    if args.maps:
        maps = tuple(m for m in args.maps.split(",") if m)
        if bad := [m for m in maps if m not in MAP_NAMES]:
            ap.error(f"--maps {bad[0]!r}: the maps are {', '.join(MAP_NAMES)}")
        settings["maps"] = maps
    if args.init_block is not None:
        if not 1 <= args.init_block <= 1 << 20:
            ap.error(f"--init-block must be between 1 and {1 << 20}, got {args.init_block}")
        settings["init_block"] = args.init_block
    if args.max_runs_per_call is not None:
        n = args.max_runs_per_call
        if not 2048 <= n <= 1 << 20 or n & (n - 1):
            ap.error(f"--max-runs-per-call must be a power of two from 2048 to {1 << 20}, "
                     f"got {n}")
        settings["max_runs_per_call"] = n
    if args.budget_s is not None:
        if not 0 < args.budget_s < 1e6:
            ap.error(f"--budget-s must be a positive number of seconds, got {args.budget_s:g}")
        settings["budget_s"] = args.budget_s
    json_path = _checked_output(args.json)

    t_start = time.perf_counter()
    # Cold compiles: neither jaxga's program store nor JAX's persistent cache.
    os.environ["JAXGA_CACHE_DIR"] = ""
    os.environ.pop("JAX_COMPILATION_CACHE_DIR", None)
    import jaxga._runtime.parallel as par

    par.use_all_cores()  # as `jaxga run` does; on a GPU it sizes only the CPU backend
    import jax

    import jaxga._runtime.programs as programs

    settings["init_block"] = settings.get("init_block", programs.platform_layout().init_run_block)
    # read by platform_layout at every call: the default backend's own block only
    if jax.default_backend() == "cpu":
        programs.INIT_RUN_BLOCK = settings["init_block"]
    else:
        programs.ACCELERATOR_INIT_BLOCK = settings["init_block"]
    if "max_runs_per_call" in settings:  # read by platform_layout and run_layout
        sizes = programs.ACCELERATOR_BUCKETS
        while sizes[-1] < settings["max_runs_per_call"]:
            sizes = (*sizes, 2 * sizes[-1])
        programs.ACCELERATOR_BUCKETS = sizes

    device = describe_devices()
    report: dict[str, Any] = {
        "command": measured_command(args), "commit": _results.commit(),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": _results.machine(), "python": platform.python_version(),
        "device": device, "settings": settings, "phases": {}}
    say(f"{device['name']} (backend {device['backend']}, jax {device['jax']}); "
        f"{'--small' if args.small else 'full size'}, budget {settings['budget_s']:.0f} s; "
        f"report in {json_path}")
    for key in skip:
        report[key] = {"error": SKIPPED}
    if "main_job" not in skip:
        with phase(report, "main job", "main_job", json_path):
            report["main_job"] = main_job(settings)
    if "agreement" not in skip:
        with phase(report, "agreement", "agreement", json_path):
            report["agreement"] = agreement(settings, device)
    if "sweep" not in skip:
        with phase(report, "sweep", "sweep", json_path):
            report["sweep"] = sweep(settings)
    if "throughput" not in skip:
        with phase(report, "throughput", "throughput", json_path):
            report["throughput"] = throughput(settings, t_start + settings["budget_s"])
    report["peak_memory"] = peak_memory(jax.devices()[0])
    report["wall_s"] = time.perf_counter() - t_start
    write_json(report, json_path)
    failed = [k for k in PHASES if k not in skip
              and isinstance(report[k], dict) and "error" in report[k]]
    agree = "agreement" in skip or report["agreement"].get("agree", False)
    verdict = "skipped" if "agreement" in skip else "holds" if agree else "FAILS"
    say(f"done in {report['wall_s']:.0f} s; agreement {verdict}"
        + (f"; failed: {', '.join(failed)}" if failed else "") + f"; report in {json_path}")
    record(report, write=not args.no_write)
    return 0 if agree and not failed else 1


if __name__ == "__main__":
    sys.exit(main())
