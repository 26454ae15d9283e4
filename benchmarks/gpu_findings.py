"""Record a GPU session's diagnosis in RESULTS.md: the bisection before the fix, the
smallest wrong program, and the agreement after the fix (decision 048).

    python benchmarks/gpu_findings.py --before DIR --parts FILE FILE --reproducer FILE \\
        --after DIR --machine-from DIR/device_check.json --commit REV [--no-write]

The files are what ``benchmarks/gpu_session.sh`` (``diagnose``, ``verify``) and
``benchmarks/gpu_step_span.py --json`` write on the device machine: ``--before`` holds
``bisect_old.json`` (the code before decision 040) and ``bisect_new.json`` (the code as it
was, before decision 048), ``--parts`` names the reports of
``benchmarks/gpu_path_check_parts.py`` and ``benchmarks/gpu_continuity_parts.py``, and
``--after`` holds ``doctor.json`` and ``bisect_init.json``.
``--commit`` is the revision the after-fix files were measured at, and the machine and
date come from the device check's report of the same session.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: _results
from _results import append_record, markdown_table, render

TITLE = "GPU diagnosis on {device}"


def _load(path: Path) -> dict:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise SystemExit(f"gpu_findings.py: error: {path}: {err}") from None


def _pct(x: float) -> str:
    return f"{100 * x:.3g} %"


def bisection_table(rows: list[dict]) -> str:
    out = []
    for r in rows:
        if "walks" in r:
            out.append([f"{r['runs']:,}", r["variant"], f"{r['walks']:,}", r["differ"],
                        r["raw_ok_bad"], f"{_pct(r['success_device'])} / {_pct(r['success_cpu'])}"])
        elif "runs_differ" in r:
            out.append([f"{r['runs']:,}", r["variant"], f"{r['of']:,} runs", r["runs_differ"],
                        f"{r['runs_short_device']} runs short (CPU {r['runs_short_cpu']})",
                        f"{_pct(r['success_device'])} / {_pct(r['success_cpu'])}"])
        elif "lanes" in r:
            out.append([f"{r['runs']:,}", r["variant"], f"{r['lanes']:,} tables",
                        r["wrong_tables_device"], "", ""])
    return markdown_table(["runs per call", "variant", "compared", "differ from the CPU",
                           "walks the check refuses", "success device / CPU"], out)


def parts_table(report: dict) -> str:
    """A parts probe's rows: walks whose part differs from the CPU's, per part."""
    names = [k for k in report["rows"][0] if k not in ("runs", "walks", "s", "walk_ok_cpu",
                                                        "valid_ok_cpu_dev")]
    return markdown_table(["runs per call", *names],
                          [[f"{r['runs']:,}", *[r.get(n, "") for n in names]]
                           for r in report["rows"]])


def body(before: Path, parts: list[Path], reproducer: Path, after: Path) -> str:
    old, new = _load(before / "bisect_old.json"), _load(before / "bisect_new.json")
    def timeless(rows: list[dict]) -> list[dict]:
        return [{k: v for k, v in r.items() if k != "s"} for r in rows]

    same, old_rows = timeless(new["rows"]), timeless(old["rows"])
    also = sum(r in old_rows for r in same)
    repro = _load(reproducer)
    names = [k for k in repro["rows"][0] if k not in ("runs", "rows", "s")]
    doctor, init = _load(after / "doctor.json"), _load(after / "bisect_init.json")
    return "\n".join([
        f"Device: {old['device']} (jax {old['jax']}). Each walk of sga's initialiser "
        "(random walk, field walk) computed for the runs x 60 keys as one call on the GPU "
        "and on the CPU (`gpu_bisect.py`): *differ* counts walks whose cells or length "
        "differ, *walks the check refuses* those the walk calls successful whose path the "
        "initialiser's path check then refused on the GPU.",
        "",
        "**Before the fix**, the code before decision 040 (b365ff4); one suspect switched "
        f"off per row. The code as it was before decision 048 gave the same numbers "
        f"({also} of its {len(same)} rows identical):",
        "", bisection_table(old["rows"]), "",
        "**The check's parts** at b4ddb0d (`benchmarks/gpu_path_check_parts.py`, then "
        "`benchmarks/gpu_continuity_parts.py`): walks whose part differs from the CPU's "
        "(`cell_steps`: inside, free, span, step_ok):", "",
        *[line for f in parts for line in (parts_table(_load(f)), "")],
        "**The smallest wrong program** (`benchmarks/gpu_step_span.py`): rows of the step "
        "span `max(|x[1:] - x[:-1]|, |y[1:] - y[:-1]|)`, `x = c % 20`, `y = c // 20`, "
        "that differ from the CPU's, and variants of it:", "",
        markdown_table(["runs per call", "rows", *names],
                       [[f"{r['runs']:,}", f"{r['rows']:,}", *[r.get(n, "") for n in names]]
                        for r in repro["rows"]]), "",
        f"**After the fix** ({doctor['verdict']}):", "",
        markdown_table(["probe", "rule", "runs", "differ", "result", "detail"],
                       [[p["name"], "exact" if p["exact"] else "close", p["compared"],
                         p["differ"], "ok" if p["agrees"] else "FAIL", p["detail"]]
                        for p in doctor["probes"]]), "",
        "The whole initialisation in one call after the fix:", "",
        bisection_table(init["rows"]),
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True)
    ap.add_argument("--parts", type=Path, nargs=2, required=True)
    ap.add_argument("--reproducer", type=Path, required=True)
    ap.add_argument("--after", type=Path, required=True)
    ap.add_argument("--machine-from", type=Path, required=True)
    ap.add_argument("--commit", required=True)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    check = _load(args.machine_from)
    sec = {"title": TITLE.format(device=check["device"]["name"]),
           "command": "python benchmarks/gpu_findings.py", "commit": args.commit,
           "date": check["date"], "machine": check["machine"],
           "body": body(args.before, args.parts, args.reproducer, args.after)}
    print(render("", [sec]))
    if not args.no_write:
        append_record(sec)


if __name__ == "__main__":
    main()
