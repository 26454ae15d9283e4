"""Are the paper reproductions unchanged? Result hashes of a base revision and this tree.

    python benchmarks/ab/reproduction_hashes.py --base 4d4b9ec [--seeds 100] [--doe-seeds 5]

Runs the reproductions in two fresh processes, one importing ``jaxga`` from a checkout of
``--base`` (``git worktree``, removed afterwards) and one from this working tree, and
compares a SHA-256 of every per-seed output of each run (``_results.result_hash``: paths,
raw paths, fitness, lengths, histories):

* Zhu & Pan Table 4 (``benchmarks/zhu_table4.py``): iga_zhu and sga (variant iga_zhu) on
  their Maps 3 and 4, corner rule "free", 30 seeds;
* AGACD's designed experiment (``benchmarks/doe_agacd.py``): the 9 points of its
  Table 4 and the confirmation run on ``classic_ga_gapp3_20x20``;
* the classic-map rows of the feasibility table (``benchmarks/feasibility.py``): every
  preset on the six classic 20 x 20 maps with the papers' corner rule.

Where the tree knows ``init.fallback``, the runs are made twice: with the fallback off
(``init.fallback = "none"``, the papers' initialisers alone), which must equal the base
bit for bit, and with the default (on), reported beside it (equal wherever the papers'
initialisers fill every slot). A run in which no seed found a path is compared as
"no path" (the tree stops it after the initialisation: nothing to evolve). Prints the
table and records it in RESULTS.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: _results
from _results import PRESETS, child_at, child_at_revision, commit, markdown_table, record

HERE = Path(__file__).resolve().parents[1]  # benchmarks/
ROOT = HERE.parent
ZHU = [(preset, variant, name) for preset, variant in (("iga_zhu", None), ("sga", "iga_zhu"))
       for name in ("classic_ga_gapp3_20x20", "routeplanning_yangbo_20x20")]


def child(spec: str) -> None:
    """Compute every hash with the jaxga on ``sys.path``; print them as one JSON line."""
    from _results import result_hash  # noqa: I001 (benchmarks/ is on sys.path)

    import jaxga
    from jaxga.api import run
    from jaxga.config.schema import SCHEMA
    from jaxga.doe import AGACD_TABLE3, run_doe
    from jaxga.maps import builtin_names, load_map

    def summary_hash(r) -> str:
        """The result's hash, or "no path" when no seed found one: the tree stops such
        runs after the initialisation (nothing to evolve), so their arrays differ in
        shape from the base's, which evolved populations holding no path."""
        return result_hash(r) if r.success.any() else "no path"

    opts = json.loads(spec)
    sets = [f"init.fallback={opts['fallback']}"] if opts["fallback"] else []
    if sets and "init.fallback" not in SCHEMA:
        raise SystemExit("this jaxga has no init.fallback")
    out = {"version": getattr(jaxga, "__file__", "")}
    for preset, variant, name in ZHU:
        r = run(preset, load_map(name, corner_rule="free"), seeds=30, variant=variant,
                sets=sets)
        out[f"zhu table 4: {preset}{' (' + variant + ')' if variant else ''} on {name}"] = \
            summary_hash(r)
    d = run_doe("agacd", "classic_ga_gapp3_20x20", AGACD_TABLE3, "agacd-table4",
                seeds=opts["doe_seeds"], sets=sets)
    import hashlib

    import numpy as np
    h = hashlib.sha256()
    for a in (d.responses, d.confirmation, *d.all_responses.values(),
              *d.confirmation_all.values()):
        h.update(np.ascontiguousarray(np.asarray(a, float)).tobytes())
    out["agacd doe (table 4 design + confirmation)"] = h.hexdigest()[:16]
    for preset in PRESETS:
        for name in [n for n in builtin_names() if "20x20" in n]:
            r = run(preset, name, seeds=opts["seeds"], sets=sets)
            out[f"feasibility: {preset} on {name}"] = summary_hash(r)
    print(json.dumps(out))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--base", help="git revision of the reference results (required)")
    ap.add_argument("--seeds", type=int, default=100, help="seeds per feasibility cell")
    ap.add_argument("--doe-seeds", type=int, default=5)
    ap.add_argument("--child")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    if not args.base:
        ap.error("--base is required")
    opts = {"seeds": args.seeds, "doe_seeds": args.doe_seeds}
    script = str(Path(__file__).resolve())  # this file, run with another jaxga
    base_h = child_at_revision(args.base, script, json.dumps({**opts, "fallback": None}))
    off = child_at(ROOT, script, json.dumps({**opts, "fallback": "none"}))
    on = child_at(ROOT, script, json.dumps({**opts, "fallback": "field_walk"}))
    rows, same = [], 0
    for name in base_h:
        if name == "version":
            continue
        equal = off[name] == base_h[name]
        same += equal
        rows.append([name, base_h[name], off[name], "yes" if equal else "**NO**", on[name],
                     "yes" if on[name] == base_h[name] else "no"])
        print(rows[-1], flush=True)
    body = (f"Base {args.base}, tree {commit()}; "
            f"{args.seeds} seeds per feasibility cell, {args.doe_seeds} per DOE point, 30 per "
            f"Zhu & Pan run. {same} of {len(rows)} reproductions are bit for bit the base's "
            "with the fallback off.\n\n"
            + markdown_table(["reproduction", "base hash", "fallback off", "equal",
                              "fallback on (default)", "equal"], rows))
    record("paper reproductions, result hashes against a base revision", body,
           write=not args.no_write)
    if same != len(rows):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
