"""``jaxga doctor`` on this machine: its verdict, table and time, cold and warm.

    python benchmarks/doctor.py [--no-write]

Runs ``jaxga doctor --json`` twice in fresh processes on one new, empty cache directory
(``JAXGA_CACHE_DIR``): the first compiles the whole runs' programs (cold), the second
reads them from jaxga's program store (warm). The target on the CPU: it agrees, in at
most 60 s. Records the section "jaxga doctor" of RESULTS.md.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: _results
from _results import markdown_table, record


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows, last, verdicts = [], None, []
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "JAXGA_CACHE_DIR": str(Path(tmp) / "cache")}
        for phase in ("cold", "warm"):
            out = Path(tmp) / f"{phase}.json"
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "jaxga.cli", "doctor", "--json",
                                   str(out)], env=env, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            print(proc.stdout, proc.stderr, sep="", flush=True)
            if proc.returncode not in (0, 5):
                raise SystemExit(f"jaxga doctor failed ({proc.returncode})")
            last = json.loads(out.read_text())
            verdicts.append(last["verdict"])
            rows.append([phase, f"{wall:.1f}", "yes" if last["agrees"] else "NO",
                         f"{last['throughput_individual_generations_per_s']:,.0f}"])
    probes = [[p["name"], "exact" if p["exact"] else "close", p["compared"], p["differ"],
               "ok" if p["agrees"] else "FAIL", p["detail"]] for p in last["probes"]]
    body = (f"Verdict: {verdicts[-1]}\n\n"
            + markdown_table(["process", "wall s", "agrees", "ind-gen/s"], rows)
            + "\n\nProbes (the warm run):\n\n"
            + markdown_table(["probe", "rule", "runs", "differ", "result", "detail"], probes))
    record("jaxga doctor", body, write=not args.no_write)


if __name__ == "__main__":
    main()
