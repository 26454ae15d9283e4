"""Does every preset still give the same results? Result hashes of a base revision and this tree.

    python benchmarks/ab/preset_hashes.py --base REV [--seeds 20]

Runs every built-in preset of both (its default settings and corner rule) on every
classic 20 x 20 built-in map, in two fresh processes: one importing ``jaxga`` from a
checkout of ``--base`` (a temporary ``git worktree``) and one from this working tree.
Compares a SHA-256 of every per-seed output of each run (``_results.result_hash``:
paths, raw paths, fitness, lengths, histories). A change that only reorganises code
(moving code, renaming operators, splitting modules) must leave every hash equal.
Prints the table and records it in RESULTS.md; exits 1 if any hash differs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: _results
from _results import child_at, child_at_revision, commit, markdown_table, parse_args, record

ROOT = Path(__file__).resolve().parents[2]


def child(seeds: int) -> dict:
    """Every preset's hash on every classic map, with the jaxga on ``sys.path``."""
    from _results import result_hash  # noqa: I001 (benchmarks/ is on sys.path)

    from jaxga.api import run
    from jaxga.maps import builtin_names
    try:
        from jaxga.config.presets import preset_names
    except ImportError:  # a revision before the layer folders (before the operator registry)
        from jaxga.presets import preset_names

    out = {}
    for preset in preset_names():
        for name in [n for n in builtin_names() if "20x20" in n]:
            r = run(preset, name, seeds=seeds)
            out[f"{preset} on {name}"] = result_hash(r) if r.success.any() else "no path"
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--base", help="git revision of the reference results (required)")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--no-write", action="store_true")
    args = parse_args(ap, child)
    if not args.base:
        ap.error("--base is required")
    script = str(Path(__file__).resolve())  # this file, run with another jaxga
    base = child_at_revision(args.base, script, str(args.seeds))
    tree = child_at(ROOT, script, str(args.seeds))
    rows = [[name, base[name], tree.get(name, "-"), "yes" if tree.get(name) == base[name]
             else "**NO**"] for name in base]
    rows += [[name, "-", tree[name], "new"] for name in tree if name not in base]
    same = sum(r[3] == "yes" for r in rows)
    body = (f"Base {args.base}, tree {commit()}; every "
            f"built-in preset with its default settings on every classic 20 x 20 map, "
            f"{args.seeds} seeds. {same} of {len(base)} runs of the base are bit for bit "
            "the same in the tree.\n\n"
            + markdown_table(["preset on map", "base hash", "tree hash", "equal"], rows))
    record("every preset's result hashes against a base revision", body,
           write=not args.no_write)
    if same != len(base):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
