"""Kernels a generation launches: the CPU's layout of a call against an accelerator's.

    PYTHONPATH=. python benchmarks/launches.py [--runs 1000] [--generations 2]
        [--presets sga,hybrid] [--maps 20x20,64x64] [--no-write]

On a GPU a generation's time is mostly its kernel launches, one after another, not its
arithmetic (decision 048: 189 ms per generation for 1000 ``sga`` runs on an H200, nearly
the same for 2048). jaxga lays its folded loops out per platform (decision 049): on the
CPU the gated operators run in blocks of at most 192 entries and the lane loops compact
their unfinished lanes; on a GPU or TPU a gated operator is one block of all its entries
and every lane loop one plain loop. This script counts what each layout executes for
the same call, on JAX's default backend (no GPU needed):

- for each preset, map and layout, ``GA.evolve`` of ``--runs`` runs in one ``jax.vmap``
  (``device_check``'s throughput call) is compiled with that layout forced
  (``jaxga._batching.folding.layout_as``; on the CPU with the Threefry hash unrolled as
  on a GPU, ``jaxga._runtime.lowering.jaxga_lowering``), run once warm, then once under
  ``jax.profiler.trace``; the trace's kernels are counted, per generation: on the CPU
  XLA:CPU's thunks (fusions, gathers, scatters, sorts), on a GPU the events of its
  streams (kernels and copies);
- the seconds per generation in each layout (on the CPU the accelerators' layout is
  slower: it computes the gated-off entries too, which a GPU does in parallel);
- whether the two layouts give the same bits (they must: the layout changes no result);
- the ``while`` loops of the program lowered for ``cuda`` (StableHLO, no GPU needed).

XLA:GPU fuses differently from XLA:CPU, so on the CPU the counts are a proxy for a
GPU's launches: what they show is how many loop iterations, times how many kernels
each, a layout runs. On a GPU they are its own (``--json PATH`` keeps the rows, for a
machine whose files come back only from an output folder).
"""

from __future__ import annotations

import argparse
import collections
import json
import re
import shlex
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import _results

LAYOUTS = ("cpu", "cuda")
"""The layouts compared, by the platform whose layout they are."""

NOT_KERNELS = ("end: ", "ThunkExecutor", "ThreadpoolListener")
"""Trace events of XLA:CPU's executor that are not kernels (a kernel is one event and its
``end:`` marker)."""


def kernel_counts(trace_dir: Path, backend: str) -> tuple[collections.Counter, list]:
    """Executions of each kernel in the profile under ``trace_dir`` (its XSpace, read with
    ``jax.profiler.ProfileData``, which keeps every event; the Perfetto trace keeps at
    most a million), and the timelines counted. On a GPU: the events of its streams (the
    lines ``Stream ...`` of the planes ``/device:GPU:N``: kernels and copies); a GPU
    profile without them (no CUPTI) is refused. On the CPU: XLA:CPU's thunks on the
    host's threads (with the few Python and runtime events of the call)."""
    from jax.profiler import ProfileData

    (path,) = list(trace_dir.rglob("*.xplane.pb"))
    planes = list(ProfileData.from_file(str(path)).planes)
    counts: collections.Counter = collections.Counter()
    lines = []
    if backend == "cpu":
        for plane in planes:
            if plane.name == "/host:CPU":
                for line in plane.lines:
                    lines.append(line.name)
                    counts.update(e.name for e in line.events
                                  if not e.name.startswith(NOT_KERNELS))
        return counts, lines
    for plane in planes:
        if re.fullmatch(r"/device:GPU:\d+", plane.name):
            for line in plane.lines:
                if line.name.startswith("Stream"):
                    lines.append(f"{plane.name} {line.name}")
                    counts.update(e.name for e in line.events)
    if not lines:
        raise SystemExit("launches.py: the profile has no GPU stream (is CUPTI there?): "
                         f"its planes are {', '.join(p.name for p in planes)}")
    return counts, lines


def measure(preset: str, map_name: str, runs: int, generations: int) -> dict:
    """Both layouts of one preset and map (module docstring)."""
    import jax
    import numpy as np
    from device_check import INITIAL_RUNS, _evolve_call, grid_for

    import jaxga
    from jaxga._batching.folding import layout_as
    from jaxga._runtime.lowering import jaxga_lowering

    ga = jaxga.GA(preset, grid_for(map_name), generations=generations)
    keys = jax.random.split(jax.random.PRNGKey(0), INITIAL_RUNS)
    initial = jax.block_until_ready(jax.vmap(ga.init, (0, None))(keys, ga.default_params))
    args = (jax.random.PRNGKey(1), initial, ga.default_params)
    row: dict[str, Any] = {"preset": preset, "map": map_name}
    outputs = {}
    for layout in LAYOUTS:
        with layout_as(layout), jaxga_lowering():
            compiled = jax.jit(_evolve_call(ga, runs, generations)).trace(*args).lower(
            ).compile()
        outputs[layout] = jax.block_until_ready(compiled(*args))
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(*args))
        row[f"{layout}_s_per_gen"] = (time.perf_counter() - t0) / generations
        trace_dir = Path(tempfile.mkdtemp(prefix="jaxga-launches-"))
        try:
            with jax.profiler.trace(str(trace_dir)):
                jax.block_until_ready(compiled(*args))
            counts, row[f"{layout}_timelines"] = kernel_counts(trace_dir,
                                                               jax.default_backend())
        finally:
            shutil.rmtree(trace_dir, ignore_errors=True)
        row[f"{layout}_kernels_per_gen"] = sum(counts.values()) / generations
        print(f"  {preset} {map_name} {layout} layout: "
              f"{row[f'{layout}_kernels_per_gen']:,.0f} kernels and "
              f"{row[f'{layout}_s_per_gen'] * 1e3:.1f} ms per generation on the "
              f"{jax.default_backend()}", flush=True)
    row["identical"] = all(
        np.array_equal(np.asarray(a), np.asarray(b))
        for a, b in zip(jax.tree_util.tree_leaves(outputs["cpu"]),
                        jax.tree_util.tree_leaves(outputs["cuda"])))
    lowered = jax.jit(_evolve_call(ga, runs, generations)).trace(*args).lower(
        lowering_platforms=("cuda",))
    row["cuda_while_loops"] = lowered.as_text().count("stablehlo.while")
    return row


def body(report: dict) -> str:
    """The RESULTS.md text of a report (:func:`main`)."""
    rows, backend = report["rows"], report["backend"]
    table = _results.markdown_table(
        ["preset", "map", "kernels per generation, CPU layout", "accelerators' layout",
         "fewer", f"ms per generation on the {backend}, CPU layout", "accelerators' layout",
         "same bits", "while loops lowered for cuda"],
        [[r["preset"], r["map"], f"{r['cpu_kernels_per_gen']:,.0f}",
          f"{r['cuda_kernels_per_gen']:,.0f}",
          (f"{r['cpu_kernels_per_gen'] / r['cuda_kernels_per_gen']:.0f}x"
           if r["cuda_kernels_per_gen"] else "(no trace)"),
          f"{r['cpu_s_per_gen'] * 1e3:.1f}", f"{r['cuda_s_per_gen'] * 1e3:.1f}",
          "yes" if r["identical"] else "NO", r["cuda_while_loops"]] for r in rows])
    what = ("compiled for the CPU in each layout (decision 049) with the Threefry hash "
            "unrolled as on a GPU. Kernels: XLA:CPU thunks executed, from a "
            "`jax.profiler` trace, per generation: a proxy for a GPU's launches (XLA:GPU "
            "fuses differently)." if backend == "cpu" else
            f"compiled for the {backend} in each layout (decision 049). Kernels: the "
            "events of the device's streams in a `jax.profiler` trace, per generation.")
    return (f"`GA.evolve` of {report['runs']} runs in one `jax.vmap` "
            f"({report['generations']} generations), " + what
            + " 20x20 = classic_ga_gapp3_20x20 (corner rule free), 64x64 = "
            "random_map(64, 64, 0.1, seed=0) (corner rule strict), as in device_check.py."
            "\n\n" + table + f"\n\nWall time: {report['wall_s']:.0f} s.")


def record(report: dict, write: bool) -> None:
    """The report's RESULTS.md section, with the command, commit, date and machine it
    was measured with."""
    sec = {"title": TITLE.format(device=report["device"]), "command": report["command"],
           "commit": report["commit"], "date": report["date"],
           "machine": report["machine"], "body": body(report)}
    print(_results.render("", [sec]))
    if write:
        _results.append_record(sec)
        print(f"recorded in {_results.HISTORY} and {_results.RESULTS}")


TITLE = "kernels per generation, CPU and accelerators' layouts, on {device}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    ap.add_argument("--runs", type=int, default=1000, help="runs in one vmap (default 1000)")
    ap.add_argument("--generations", type=int, default=2,
                    help="generations of each call (default 2)")
    ap.add_argument("--presets", default="sga,hybrid")
    ap.add_argument("--maps", default="20x20,64x64")
    ap.add_argument("--json", type=Path, help="also write the report to this file")
    ap.add_argument("--from-json", type=Path, metavar="PATH",
                    help="record the report of a run made elsewhere (--json)")
    ap.add_argument("--no-write", action="store_true")
    a = ap.parse_args()
    if a.from_json:
        record(json.loads(a.from_json.read_text()), write=not a.no_write)
        return 0
    if a.runs < 1 or a.generations < 1:
        print("launches.py: --runs and --generations must be at least 1", file=sys.stderr)
        return 2
    import jax

    t0 = time.perf_counter()
    backend = jax.default_backend()
    device = ("the CPU" if backend == "cpu"
              else f"{jax.device_count()} x {jax.devices()[0].device_kind}")
    argv, kept = sys.argv, []
    for i, w in enumerate(argv):  # what is measured: not where the report goes
        if not (w == "--no-write" or w.startswith("--json") or argv[i - 1] == "--json"):
            kept.append(w)
    command = "python " + " ".join(shlex.quote(w) for w in kept)
    report = {"command": command, "commit": _results.commit(), "date": _results._now(),
              "machine": _results.machine(), "backend": backend, "device": device,
              "runs": a.runs, "generations": a.generations, "rows": []}
    for preset in a.presets.split(","):
        for map_name in a.maps.split(","):
            report["rows"].append(measure(preset, map_name, a.runs, a.generations))
            report["wall_s"] = time.perf_counter() - t0
            if a.json:
                a.json.write_text(json.dumps(report, indent=1))
    record(report, write=not a.no_write)
    return 0 if all(r["identical"] for r in report["rows"]) else 1


if __name__ == "__main__":
    sys.exit(main())
