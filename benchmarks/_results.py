"""Shared by the benchmark scripts: machine description and appending to RESULTS.md."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import shlex
import sys
from pathlib import Path

RESULTS = Path(__file__).with_name("RESULTS.md")
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "benchmarks"


def machine() -> str:
    """One line naming the machine, the software and the current load."""
    import jax
    import numpy as np

    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    return (
        f"{platform.platform()}, {platform.machine()}, os.cpu_count() = {os.cpu_count()}, "
        f"python {platform.python_version()}, jax {jax.__version__} "
        f"({jax.default_backend()}, {jax.device_count()} device(s)), numpy {np.__version__}, "
        f"load average {load}"
    )


def command() -> str:
    """The command line that is running, as a user would retype it."""
    return "python " + " ".join(shlex.quote(a) for a in sys.argv)


def result_hash(result) -> str:
    """First 16 hex digits of a SHA-256 of every per-seed output of a ``jaxga.Result``
    (paths, raw paths, fitness, lengths, histories): equal hashes = identical results."""
    import hashlib

    import numpy as np

    h = hashlib.sha256()
    for a in (result.cells, result.n_cells, result.raw_cells, result.raw_n_cells,
              result.fitness, result.length, result.history["best"],
              result.history["mean"], result.history["std"]):
        h.update(np.ascontiguousarray(np.asarray(a)).tobytes())
    return h.hexdigest()[:16]


def cold_child(script: str, spec: str, **env: str) -> tuple[dict, str]:
    """Run ``python <script> --child <spec>`` in a fresh process and return its last
    stdout line parsed as JSON, and its stderr.

    The child imports ``jaxga`` from this checkout and the benchmark helpers from
    ``benchmarks/``; it has no persistent compilation cache (``JAXGA_CACHE_DIR`` and
    ``JAX_COMPILATION_CACHE_DIR`` removed), so it compiles cold. ``env`` adds or replaces
    environment variables (``XLA_FLAGS``, ``JAXGA_DEVICES``, ``PYTHONPATH`` to import
    another checkout's ``jaxga``, ...). A failing child raises
    ``RuntimeError`` with the end of its stderr."""
    import json
    import subprocess

    here = Path(__file__).resolve().parent
    child_env = dict(os.environ, PYTHONPATH=f"{here.parent}{os.pathsep}{here}")
    for key in ("JAXGA_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR"):
        child_env.pop(key, None)
    child_env.update(env)
    proc = subprocess.run([sys.executable, script, "--child", spec], env=child_env,
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


def markdown_table(headers: list[str], rows: list[list]) -> str:
    """A GitHub markdown table (numbers right-aligned)."""
    def fmt(v):
        return f"{v:,.2f}" if isinstance(v, float) else str(v)

    out = ["| " + " | ".join(headers) + " |",
           "|" + "|".join("---:" if i else "---" for i in range(len(headers))) + "|"]
    out += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


def append(title: str, body: str, *, write: bool = True) -> None:
    """Append a section (title, date, command, machine, body) to ``RESULTS.md``."""
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    section = (
        f"\n## {title} ({stamp})\n\n- command: `{command()}`\n- machine: {machine()}\n\n"
        f"{body.strip()}\n"
    )
    print(section)
    if write:
        new = not RESULTS.exists()
        with RESULTS.open("a", encoding="utf-8") as fh:
            if new:
                fh.write("# Benchmark results\n")
            fh.write(section)
        print(f"appended to {RESULTS}")


def timed(fn, *args, repeats: int = 5) -> float:
    """Median wall seconds of ``fn(*args)`` (after one warm-up call), results blocked on."""
    import time

    import jax
    import numpy as np

    jax.block_until_ready(fn(*args))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        times.append(time.perf_counter() - t0)
    return float(np.median(times))

