"""Where the test suite's time goes: JAX compilation per test file, cold cache, as in CI.

    python benchmarks/suite_time.py [--tier all|fast] [--top 15] [--no-write] [-- PYTEST_ARGS...]

Runs the README's test command (``pytest -q``, from the repository root; ``--tier fast``:
the tier for every change, ``pytest -q -m "not slow"``) with an empty
persistent compilation cache (``JAXGA_TEST_JAX_CACHE`` set to a new temporary
directory: CI starts from a clean clone) and the ``_compile_listener`` plugin, then
prints, per test file: its tests, the sum of their wall times, and how much of that was
XLA's backend compilation (seconds, programs compiled, persistent-cache hits), tracing
to jaxprs and lowering to MLIR (JAX's ``jax.monitoring`` events, in the pytest workers
only; a test's child processes, such as notebook kernels or ``jax.distributed``
processes, count as wall time only), the compile seconds that persistent-cache hits
saved, and the CPU seconds its tests used
(user + system, every thread, the child processes they waited for: unlike wall time, not
inflated by whatever else shares the cores). The whole command's CPU seconds and the
CPU the rest of the machine used meanwhile (``/proc/stat``) say whether the wall time was
the suite's alone. Then the slowest tests. The whole
suite must stay under 17 minutes on CI's 2-core machine and the fast tier under 4
(docs/architecture.md); this says which files to look at when it creeps up. The worker
column assumes the suite's own ``--dist loadfile`` (a whole file on one worker).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import resource
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import markdown_table, record

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BACKEND = "/jax/core/compile/backend_compile_duration"
TRACE = "/jax/core/compile/jaxpr_trace_duration"
LOWER = "/jax/core/compile/jaxpr_to_mlir_module_duration"
SAVED = "/jax/compilation_cache/compile_time_saved_sec"
LARGE = "large programs"
LARGE_PROGRAM_S = 2.0
"""XLA seconds above which ``_compile_listener`` counts a compilation under :data:`LARGE`
as well: whole GAs and their init, evolve and finish programs, whole walks or repairs
(decision 046), as against the many small programs of operator tests."""
TIERS = {"all": [], "fast": ["-m", "not slow"]}
"""The pytest arguments of each tier (pyproject.toml's markers)."""
TITLES = {"all": "test suite time per file, cold compilation cache",
          "fast": "fast test tier time per file, cold compilation cache"}


def machine_busy_seconds() -> float | None:
    """CPU seconds every core of the machine has been busy since boot (``/proc/stat``:
    all but idle and I/O wait), or None off Linux."""
    try:
        fields = Path("/proc/stat").read_text().splitlines()[0].split()[1:]
    except OSError:
        return None
    ticks = [int(x) for x in fields]
    return (sum(ticks[:8]) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")


def run_suite(pytest_args: list[str], profile: Path,
              cache: Path) -> tuple[float, str, int, dict[str, float | None]]:
    """Run pytest once (cold compilation cache): its wall seconds, last line, exit code and
    CPU seconds (``"suite"``: pytest and the processes it waited for; ``"other"``: what
    the rest of the machine used meanwhile, None off Linux)."""
    env = dict(os.environ, JAXGA_SUITE_PROFILE=str(profile), JAXGA_TEST_JAX_CACHE=str(cache),
               PYTHONPATH=os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")])))
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "_compile_listener", *pytest_args]

    def children_cpu() -> float:
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    busy0, cpu0, t0 = machine_busy_seconds(), children_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    suite_cpu, busy1 = children_cpu() - cpu0, machine_busy_seconds()
    other = None if busy0 is None or busy1 is None else max(0.0, busy1 - busy0 - suite_cpu)
    lines = [ln for ln in proc.stdout.strip().splitlines() if ln.strip()]
    if proc.returncode != 0:
        print(proc.stdout[-5000:], proc.stderr[-3000:], file=sys.stderr)
    return wall, lines[-1] if lines else "", proc.returncode, {"suite": suite_cpu,
                                                               "other": other}


def per_file(profile: Path) -> tuple[dict[str, collections.Counter], list, dict]:
    """Sums per test file, every test's (wall, backend, nodeid), the worker of each file."""
    files: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    tests, worker_of = [], {}  # files in the order each worker ran them: dict order
    for path in sorted(profile.glob("*.json")):
        for nodeid, row in json.loads(path.read_text())["rows"]:
            name = nodeid.split("::")[0]
            files[name]["tests"] += 1
            files[name].update(row)
            worker_of[name] = path.stem
            tests.append((row["wall"], row.get("cpu", 0.0), row.get(BACKEND, 0.0), nodeid))
    return files, sorted(tests, reverse=True), worker_of


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tier", choices=sorted(TIERS), default="all",
                    help="all: the README's pytest -q; fast: pytest -q -m 'not slow'")
    ap.add_argument("--top", type=int, default=15, help="how many of the slowest tests")
    ap.add_argument("--no-write", action="store_true", help="do not append to RESULTS.md")
    ap.add_argument("--min-cpu", type=float, default=20.0,
                    help="files whose tests used less CPU (seconds) share one row of the table")
    ap.add_argument("--keep-profile", type=Path, metavar="DIR",
                    help="copy the per-test profile (one JSON per worker) to DIR")
    ap.add_argument("pytest_args", nargs="*", help="extra pytest arguments (after --)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="jaxga-suite-") as tmp:
        profile, cache = Path(tmp) / "profile", Path(tmp) / "cache"
        wall, last, code, cpu = run_suite([*TIERS[a.tier], *a.pytest_args], profile, cache)
        files, tests, worker_of = per_file(profile)
        if a.keep_profile:
            shutil.copytree(profile, a.keep_profile, dirs_exist_ok=True)
    order = sorted(files, key=lambda f: -files[f]["cpu"])
    def compiled(c: collections.Counter) -> int:
        """Programs XLA compiled: JAX times a persistent-cache load as a compile too."""
        return int(c["n:" + BACKEND] - c["n:" + SAVED])

    def row(name: str, worker: str, c: collections.Counter) -> list:
        return [name, worker, c["tests"], c["wall"], c["cpu"], c[BACKEND], compiled(c),
                int(c["n:" + SAVED]), c[TRACE], c[LOWER], c[SAVED], int(c["n:" + LARGE]),
                c[LARGE]]

    listed = [f for f in order if files[f]["cpu"] >= a.min_cpu]
    rows = [row(f.removeprefix("tests/"), worker_of[f], files[f]) for f in listed]
    short = collections.Counter()
    for f in order[len(listed):]:
        short.update(files[f])
    if short:  # the files a reader need not look at one by one
        rows.append(row(f"{len(order) - len(listed)} files under {a.min_cpu:g} s each",
                        "", short))
    total = collections.Counter()
    for f in order:
        total.update(files[f])
    rows.append(row("all", "", total))
    workers = collections.Counter()
    for f in order:
        workers[worker_of[f]] += files[f]["wall"]
    ran = collections.defaultdict(list)
    for f, w in worker_of.items():
        ran[w].append(f"{Path(f).stem.removeprefix('test_')} "
                      f"{files[f]['wall']:.0f}")
    body = (
        f"`{' '.join(['pytest', '-q', *(shlex.quote(x) for x in TIERS[a.tier])])}` from "
        f"the repository root, cold persistent compilation cache (a new "
        f"temporary `JAXGA_TEST_JAX_CACHE`), JAX's `jax.monitoring` duration events per "
        f"test (plugin `benchmarks/_compile_listener.py`). Seconds. Wall = sum of the "
        f"tests' own times (setup + call + teardown); CPU = their processes' user + "
        f"system seconds over the same spans (every thread, and the child processes a "
        f"test waited for): what a file costs, whatever else shares the cores; XLA s = "
        f"JAX's backend compile events (XLA compilations and persistent-cache loads); "
        f"compiled = programs XLA "
        f"compiled; cache hits = programs loaded from the persistent cache; trace = "
        f"Python to jaxpr; lower = jaxpr to MLIR; cache saved = XLA "
        f"seconds that persistent-cache hits saved; large = programs that took XLA more "
        f"than {LARGE_PROGRAM_S:g} s each (whole GAs and their parts, decision 046), "
        f"large s = their XLA seconds. JAX's events are seen in the pytest "
        f"workers only: tests that start processes (notebook kernels, `jax.distributed`, "
        f"device counts) count as wall and CPU time.\n\n"
        f"pytest: {last}; wall of the whole command {wall:.0f} s; CPU of the command "
        f"and its processes {cpu['suite']:.0f} s ({cpu['suite'] / wall:.2f} cores on "
        f"average, of {os.cpu_count()}); "
        + ("" if cpu["other"] is None else
           f"CPU used by the rest of the machine meanwhile {cpu['other']:.0f} s; ")
        + "tests' time per worker: "
        + ", ".join(f"{w} {s:.0f} s" for w, s in sorted(workers.items()))
        + "\n\nFiles in the order each worker ran them (seconds):\n\n"
        + "\n".join(f"- {w}: " + ", ".join(ran[w]) for w in sorted(ran))
        + "\n\n"
        + markdown_table(["file", "worker", "tests", "wall", "CPU", "XLA s", "compiled",
                          "cache hits", "trace", "lower", "cache saved", "large",
                          "large s"], rows)
        + f"\n\nSlowest {a.top} tests (by wall time):\n\n"
        + markdown_table(["test", "wall", "CPU", "XLA s"],
                         [[n, w, cpu_s, c] for w, cpu_s, c, n in tests[: a.top]])
    )
    # A failing suite's table is printed for diagnosis but never recorded as the result.
    record(TITLES[a.tier], body, write=not a.no_write and code == 0)
    if code != 0:
        raise SystemExit(f"pytest exited with {code}")


if __name__ == "__main__":
    main()
