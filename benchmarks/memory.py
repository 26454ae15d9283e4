"""Memory checked before it is allocated: the estimate of a call against its measured peak.

For each preset on the papers' 20 x 20 map (paths of 160 cells), with large populations
(2,000 and 8,000 individuals a run) and 1 or 5 seeds (one call of 4 runs, or one padded
call of 32 on the CPU), a fresh process runs ``jaxga.run`` and reports its peak resident
memory (``ru_maxrss``, the compilation included), beside the estimate the run was
checked against before compiling (:func:`jaxga._runtime.memory.call_memory`, with the
layout the run used) and XLA's own account of the compiled programs, checked before they
run (:func:`jaxga._runtime.memory.compiled_peak`). The larger of the two must hold the peak
(ratio >= 1) without refusing what fits by far.

    python benchmarks/memory.py [--presets sga,imga] [--no-write]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from _results import markdown_table, record

HERE = Path(__file__).resolve().parent
PRESETS = ("sga", "imga", "agacd", "iga_zhang", "mpmga", "iga_zhu", "hybrid")
CASES = ((2000, 1), (2000, 5), (8000, 5))
MAP = "classic_ga_gapp3_20x20"
GENERATIONS = 3

CHILD = """
import json, resource, sys
import jaxga
from jaxga.api import runs
from jaxga._runtime import calls, memory
preset, pop, seeds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
seen, accounts = [], []
real = calls.fitting_layout
def spy(algo, n_local, n_dev, layout, padded=True):
    out = real(algo, n_local, n_dev, layout, padded)
    seen.append((algo, out[0] * n_dev * out[2], out[0] * n_dev, n_local))
    return out
calls.fitting_layout = spy
real_check = runs.check_compiled_memory
def account(stats, calls, n_runs):
    accounts.extend(memory.compiled_peak(s, calls) for s in stats.values() if s is not None)
    return real_check(stats, calls, n_runs)
runs.check_compiled_memory = account
r = jaxga.run(preset, sys.argv[4], seeds=seeds, generations=int(sys.argv[5]),
              population__size=pop, any_angle_budget=0)
algo, computed, per_call, n_local = seen[-1]
print(json.dumps({"peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "estimate": memory.call_memory(algo, computed, per_call, total=n_local),
                  "account": max(accounts, default=0),
                  "runs": computed, "capacity": algo.capacity, "islands": algo.islands,
                  "population": algo.population}))
"""


def measure(preset: str, population: int, seeds: int) -> dict:
    proc = subprocess.run([sys.executable, "-c", CHILD, preset, str(population), str(seeds),
                           MAP, str(GENERATIONS)],
                          capture_output=True, text=True, cwd=HERE.parent, timeout=1200)
    if proc.returncode != 0:
        raise RuntimeError(f"{preset} {population} x {seeds}: {proc.stderr[-1500:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default=",".join(PRESETS))
    parser.add_argument("--cases", default=",".join(f"{p}x{s}" for p, s in CASES),
                        help="POPULATIONxSEEDS,... (default %(default)s)")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    rows = []
    cases = [tuple(int(v) for v in c.split("x")) for c in args.cases.split(",")]
    for preset in args.presets.split(","):
        for population, seeds in cases:
            m = measure(preset, population, seeds)
            guard = max(m["estimate"], m["account"])
            rows.append([preset, f"{m['population']} x {m['islands']}", str(seeds),
                         str(m["runs"]), f"{m['peak'] / 2**30:.2f}",
                         f"{m['estimate'] / 2**30:.2f}", f"{m['account'] / 2**30:.2f}",
                         f"{guard / m['peak']:.2f}"])
            print(rows[-1], flush=True)
    body = (f"Map {MAP} (paths of 160 cells), {GENERATIONS} generations, a fresh process "
            "per row. runs = runs computed (the call's padding included); peak = the "
            "process's peak resident memory (ru_maxrss, its compilation included); "
            "model = jaxga._runtime.memory.call_memory for that layout, checked before "
            "anything compiles; XLA = XLA's own account of the compiled programs "
            "(jaxga._runtime.memory.compiled_peak of Compiled.memory_analysis), checked before "
            "they run; each must be within half the memory the process may use. ratio = "
            "the larger of the two / peak, which must be at least 1.\n\n"
            + markdown_table(["preset", "population x islands", "seeds", "runs",
                              "peak GiB", "model GiB", "XLA GiB", "ratio"], rows))
    record("memory: the estimate of a call against its measured peak (benchmarks/memory.py)",
           body, write=not args.no_write)


if __name__ == "__main__":
    main()
