"""How fast is a map over the size limit refused? (jaxga.core.grid.MAX_MAP_CELLS)

    python benchmarks/size_limit.py

Writes maps of 600 x 600 to 5000 x 5000 cells in each file format to a temporary folder
and times ``jaxga.maps.load_map`` until it raises its one-line refusal, then the same
``jaxga optimum --map FILE`` as a user types it (a fresh process: its time includes
starting Python and importing jaxga). Prints the table and records it in RESULTS.md.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import markdown_table, record

from jaxga.core.errors import MapFormatError
from jaxga.maps import load_map, save_map


def main() -> None:
    rows = []
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        for side in (600, 2000, 5000):
            b = rng.random((side, side)) < 0.15
            for ext in ("png", "map", "txt"):
                path = save_map(b, Path(tmp) / f"m{side}.{ext}")
                t0 = time.perf_counter()
                try:
                    load_map(path)
                    message = "(loaded)"
                except MapFormatError as e:
                    message = str(e)
                load_s = time.perf_counter() - t0
                t0 = time.perf_counter()
                proc = subprocess.run([sys.executable, "-m", "jaxga.cli", "optimum", "--map",
                                       str(path)], capture_output=True, text=True)
                cli_s = time.perf_counter() - t0
                err = proc.stderr.strip()
                rows.append([f"{side} x {side}", ext, f"{load_s * 1000:.1f}",
                             f"{cli_s:.2f}", proc.returncode, len(err.splitlines()),
                             message.split(": ", 1)[-1][:70] + "..."])
                print(rows[-1], flush=True)
    body = ("load ms = `jaxga.maps.load_map` until its refusal (the map's size read from "
            "its header, or its first line and line count); CLI s = `jaxga optimum --map "
            "FILE` in a fresh process (Python start and imports included); lines = lines "
            "on stderr.\n\n"
            + markdown_table(["map", "format", "load ms", "CLI s", "exit", "lines",
                              "message"], rows))
    record("a map over the size limit is refused at once", body)


if __name__ == "__main__":
    main()
