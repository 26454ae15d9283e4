"""Throughput of a base revision and the working tree on the same machine, alternating.

    python benchmarks/ab/throughput_ab.py --base REV [--presets sga] [--settings 20x20,50x50]
        [--seeds 1000] [--rounds 1] [--devices N]

The throughput target of the compile-once work (decision 028): individual-generations per
second at 20 x 20 and 50 x 50 with 1000 seeds within 10 % of the code before it. The
settings are ``benchmarks/speed.py``'s (20 x 20: ``classic_ga_gapp3_20x20``, population 60,
300 generations; 50 x 50: ``random_map(50, 50, 0.1, seed=0)``, population 80, 500
generations); each measurement is one cold child process (``speed.py``'s child, importing
``jaxga`` from the base checkout or from this tree), base and tree alternating so that both
see the same machine load.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: _results
from _results import child_at, markdown_table, record

HERE = Path(__file__).resolve().parents[1]  # benchmarks/


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--base", required=True, help="the revision to compare with")
    ap.add_argument("--presets", default="sga")
    ap.add_argument("--settings", default="20x20,50x50")
    ap.add_argument("--seeds", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--devices", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    os.environ["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={args.devices}"

    from speed import SETTINGS

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", str(base), args.base],
                       cwd=HERE.parent, check=True, capture_output=True)
        try:
            for preset in args.presets.split(","):
                for setting in args.settings.split(","):
                    population, generations = SETTINGS[setting]
                    if preset == "mpmga":
                        population //= 3
                    spec = f"{preset}:{setting}:{args.seeds}:{generations}"
                    rates: dict[str, list[float]] = {"base": [], "tree": []}
                    for _ in range(args.rounds):
                        for name, checkout in (("base", base), ("tree", HERE.parent)):
                            m = child_at(checkout, "speed.py", spec)
                            rate = args.seeds * m["population"] * generations / m["evolve_s"]
                            rates[name].append(rate)
                            print(preset, setting, name, f"{rate:,.0f}", flush=True)
                    b, t = (max(rates[k]) for k in ("base", "tree"))
                    rows.append([preset, setting, args.seeds, f"{b:,.0f}", f"{t:,.0f}",
                                 f"{t / b - 1:+.1%}"])
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base)],
                           cwd=HERE.parent, check=True, capture_output=True)
    body = (
        f"Base `{args.base}` against the working tree, {args.devices} XLA host device(s), "
        f"cold children alternating, best of {args.rounds} round(s) each. ind-gen/s = "
        "seeds x population x generations / evolve seconds (speed.py's settings). Target "
        "(decision 028): the tree within 10 % of the base.\n\n"
        + markdown_table(["preset", "setting", "seeds", "base ind-gen/s", "tree ind-gen/s",
                          "change"], rows)
    )
    record("throughput: base revision against the working tree", body,
           write=not args.no_write)


if __name__ == "__main__":
    main()
