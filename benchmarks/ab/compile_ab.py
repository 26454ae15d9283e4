"""Cold compile of two checkouts, interleaved: a git revision against this working tree.

    python benchmarks/ab/compile_ab.py --base HEAD~1 [--presets sga,iga_zhu] [--reps 2]
        [--seeds 1] [--devices 1] [--warm N] [--cli] [--no-write]

The machine's speed drifts within an hour by more than the few per cent a change may
move a compile (decision 023), so two compile tables taken at different times cannot
show such a change. This script checks the base revision out into a temporary
``git worktree`` and, for every preset and repetition, runs one fresh process on the
base and one on this working tree, one after the other, base first in odd repetitions
and new first in even ones (cold compile: no persistent compilation cache). Each child
runs ``jaxga.run(preset, classic_ga_gapp3_20x20, seeds)`` as ``_results.standard_run`` does
(:data:`_results.STANDARD_SETTING`) and reports ``compile_s`` and its parts: tracing (JAX's
trace events), lowering (``Traced.lower``) and XLA (``Lowered.compile``; also per program:
init, finish, evolve), plus a hash of every per-seed output (``_results.result_hash``):
equal hashes mean the change left the results bit for bit the same. With ``--warm N``
each child then runs the same call ``N`` more times (its programs compiled) and reports
the fastest initialisation + evolution and the fastest post-optimisation, so that a
change's effect on run time is measured the same interleaved way. With ``--cli`` each
child runs the command line instead, ``jaxga run --preset P --map classic_ga_gapp3_20x20
--seeds N`` (``_results.cli_run``: the preset's own population and generations, the
progress bar's chunked evolution).
The worktree is removed at the end; if the script is killed, ``git worktree prune``
forgets it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: _results
from _results import (
    CLI_MAP,
    PRESETS,
    STANDARD_SETTING,
    cli_run,
    cold_child,
    instrumented_run,
    markdown_table,
    parse_args,
    record,
    result_hash,
    standard_run,
    xla_seconds_by_program,
)

ROOT = Path(__file__).resolve().parents[2]


def child(preset: str, seeds: int, warm: int, cli: int = 0) -> dict:
    """One cold ``jaxga.run`` in this process (``cli``: ``jaxga run`` on the command
    line): compile split and result hash; then the fastest init + evolve of ``warm`` more
    calls (0: none)."""
    import jaxga

    run = cli_run if cli else standard_run
    r, parts = instrumented_run(preset, seeds, run)
    runs = [run(preset, seeds).timing for _ in range(warm)]
    best = min(runs, key=lambda t: t["init_s"] + t["evolve_s"], default=None)
    post = min((t["post_s"] for t in runs), default=None)
    by_program = xla_seconds_by_program(parts["xla"])
    return {"jaxga": jaxga.__file__, "compile_s": r.timing["compile_s"],
            "trace_s": parts["trace_s"], "lower_s": parts["lower_s"],
            "xla_s": sum(s for s, *_ in parts["xla"]), "hash": result_hash(r),
            **{f"xla_{name}_s": s for name, s in by_program.items()},
            "init_s": best and best["init_s"], "evolve_s": best and best["evolve_s"],
            "post_s": post}


def measure(root: Path, preset: str, seeds: int, devices: int, warm: int, cli: bool) -> dict:
    """:func:`child` in a fresh process importing ``jaxga`` from ``root``."""
    here = Path(__file__).resolve().parents[1]  # benchmarks/: _results
    m = cold_child(__file__, f"{preset}:{seeds}:{warm}:{int(cli)}",
                   PYTHONPATH=f"{root}{os.pathsep}{here}",
                   JAXGA_DEVICES=str(devices),
                   XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")[0]
    if not Path(m["jaxga"]).resolve().is_relative_to(Path(root).resolve() / "jaxga"):
        raise RuntimeError(f"the child imported {m['jaxga']}, not the checkout {root}")
    return m


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="HEAD", help="git revision to compare against")
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--devices", type=int, default=1)
    ap.add_argument("--warm", type=int, default=0,
                    help="also time this many warm calls per child (init, evolve)")
    ap.add_argument("--cli", action="store_true",
                    help="run `jaxga run --preset P --map classic_ga_gapp3_20x20 --seeds N` "
                         "(the preset's own settings) instead of the standard setting")
    ap.add_argument("--no-write", action="store_true")
    a = parse_args(ap, child)
    base = subprocess.run(["git", "rev-parse", "--short", a.base], cwd=ROOT, check=True,
                          capture_output=True, text=True).stdout.strip()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                          capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "jaxga"], cwd=ROOT,
                           check=True, capture_output=True, text=True).stdout.strip()
    new_name = f"{head}{' + uncommitted jaxga changes' if dirty else ''}"
    rows, same = [], True
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", str(tree), base], cwd=ROOT,
                       check=True, capture_output=True)
        try:
            for preset in a.presets.split(","):
                for rep in range(a.reps):
                    got = {}
                    order = (("base", tree), ("new", ROOT))
                    for name, root in order if rep % 2 == 0 else order[::-1]:  # ABBA
                        got[name] = m = measure(root, preset, a.seeds, a.devices, a.warm, a.cli)
                        print(preset, rep, name, json.dumps(m), flush=True)
                    b, n = got["base"], got["new"]
                    same &= b["hash"] == n["hash"]
                    rows.append([preset, rep + 1]
                                + [f"{b[k]:.2f} -> {n[k]:.2f}"
                                   for k in ("compile_s", "trace_s", "lower_s", "xla_s",
                                             "xla_init_s", "xla_finish_s", "xla_evolve_s")]
                                + [f"{n['compile_s'] - b['compile_s']:+.2f}"]
                                + [f"{b[k]:.3f} -> {n[k]:.3f}"
                                   for k in ("init_s", "evolve_s", "post_s") if a.warm]
                                + ["equal" if b["hash"] == n["hash"] else "DIFFERENT"])
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                           capture_output=True)
    setting = (f"`jaxga run --preset P --map {CLI_MAP} --seeds {a.seeds}` (each preset's "
               "own population and generations; the evolution in the progress bar's chunks)"
               if a.cli else STANDARD_SETTING)
    body = (
        f"base {base} -> new {new_name}. {setting}, {a.seeds} seed(s), {a.devices} XLA "
        "device(s); each pair of cold compiles (fresh processes, no persistent cache) ran "
        "one after the other, base first in odd repeats, new first in even ones. Seconds, "
        "base -> new. results: hash of every per-seed output, base against new."
        + (f" warm init / evolve: the fastest of {a.warm} more calls in the same process "
           "(programs compiled), by init + evolve; warm post: the fastest post-optimisation "
           "of those calls." if a.warm else "")
        + "\n\n"
        + markdown_table(["preset", "repeat", "compile", "trace", "lower", "XLA", "XLA init",
                          "XLA finish", "XLA evolve", "change"]
                         + (["warm init", "warm evolve", "warm post"] if a.warm else [])
                         + ["results"],
                         rows)
        + f"\n\nAll results identical: {'yes' if same else 'NO'}."
    )
    record("cold compile, base against new (benchmarks/ab/compile_ab.py)", body,
           write=not a.no_write)


if __name__ == "__main__":
    sys.exit(main())
