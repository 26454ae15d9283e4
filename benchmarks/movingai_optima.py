"""Reproduce the optimal lengths of every Moving AI scenario with jaxga.reference.optima.

For every ``.scen`` file in a folder of Moving AI benchmarks (default
``/work/shared/benchmarks/movingai``), load its map, run
:func:`jaxga.reference.optima.OctileGraph.search` (the engine of
:func:`jaxga.reference.optima.shortest_path`) under the ``"strict"`` corner rule
(the Moving AI convention: no corner cutting) on every scenario, and count how many
optimal lengths are reproduced within ``--tol`` (default 1e-3). A sample of scenarios
per map is also cross-checked against ``scipy.sparse.csgraph.dijkstra`` on the legal-move
graph (scipy is a test/benchmark dependency only).

Prints a table and appends a markdown section (command, date, machine, table) to
``benchmarks/RESULTS.md`` (through ``benchmarks/_results.py``) unless ``--no-append``
is given. Also times the exact any-angle optimum on a few scenarios of one map. Exits 0
when the folder is missing (with a message), 1 when a scenario is not reproduced.

    PYTHONPATH=. python benchmarks/movingai_optima.py [--root DIR] [--rule strict]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from jaxga.reference.any_angle import any_angle_shortest_path_np
from jaxga.reference.optima import OctileGraph, legal_moves_np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402  (benchmarks/_results.py: machine line, RESULTS.md)

DEFAULT_ROOT = Path("/work/shared/benchmarks/movingai")
PASSABLE = frozenset(".GS")  # '@', 'O', 'T', 'W' and anything else are blocked


def load_movingai_map(path: Path) -> np.ndarray:
    """``bool[H, W]`` blocked array of a Moving AI ``.map`` file, row 0 at the BOTTOM."""
    lines = path.read_text().splitlines()
    header: dict[str, str] = {}
    k = 0
    while k < len(lines) and lines[k].strip().lower() != "map":
        parts = lines[k].split()
        if len(parts) == 2:
            header[parts[0].lower()] = parts[1]
        k += 1
    h, w = int(header["height"]), int(header["width"])
    rows = lines[k + 1 : k + 1 + h]
    if len(rows) != h or any(len(r) < w for r in rows):
        raise ValueError(f"{path}: expected {h} rows of {w} characters")
    top_down = np.array([[c not in PASSABLE for c in r[:w]] for r in rows], dtype=bool)
    return top_down[::-1].copy()  # Moving AI row 0 is the top; ours is the bottom


def load_scen(path: Path) -> list[tuple[str, int, int, tuple[int, int], tuple[int, int], float]]:
    """Scenarios ``(map name, W, H, start (x, y_top), goal (x, y_top), optimal length)``."""
    out = []
    for line in path.read_text().splitlines():
        f = line.rstrip("\n").split("\t")
        if len(f) < 9:
            continue  # the "version 1" header and blank lines
        out.append(
            (
                os.path.basename(f[1]),
                int(f[2]),
                int(f[3]),
                (int(f[4]), int(f[5])),
                (int(f[6]), int(f[7])),
                float(f[8]),
            )
        )
    return out


def scipy_check(blocked: np.ndarray, rule: str, pairs: list, lengths: list[float]) -> int:
    """Number of ``pairs`` whose scipy Dijkstra distance differs from ``lengths`` by > 1e-9."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    from jaxga.core.grid import DIRECTIONS

    h, w = blocked.shape
    legal = legal_moves_np(blocked, rule).reshape(8, -1)
    src, dst, cost = [], [], []
    for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
        p = np.flatnonzero(legal[d])
        src.append(p)
        dst.append(p + dy * w + dx)
        cost.append(np.full(p.size, np.sqrt(2.0) if dx and dy else 1.0))
    m = coo_matrix(
        (np.concatenate(cost), (np.concatenate(src), np.concatenate(dst))), shape=(h * w, h * w)
    ).tocsr()
    starts = [s[1] * w + s[0] for s, _ in pairs]
    dist = dijkstra(m, indices=starts)
    wrong = 0
    for row, ((_, g), length) in enumerate(zip(pairs, lengths, strict=True)):
        if abs(dist[row, g[1] * w + g[0]] - length) > 1e-9:
            wrong += 1
    return wrong


def any_angle_timing(args: argparse.Namespace) -> str:
    """Time the exact any-angle optimum on a few scenarios of one map; markdown table."""
    if args.any_angle_count <= 0:
        return ""
    scen_paths = [
        p for p in sorted(args.root.glob("*.scen")) if p.name.startswith(args.any_angle_map)
    ]
    if not scen_paths:
        print(f"any-angle timing skipped: no scenarios for {args.any_angle_map}")
        return ""
    scens = sorted(load_scen(scen_paths[0]), key=lambda t: t[5])
    blocked = load_movingai_map(args.root / scens[0][0])
    h = blocked.shape[0]
    picks = np.unique(np.linspace(0, len(scens) - 1, args.any_angle_count).round().astype(int))
    out = (
        "| start | goal | octile optimum | any-angle optimum | time (s) | expansions | "
        "upper bound | time (s) |\n|---|---|---|---|---|---|---|---|\n"
    )
    for k in picks:
        _, _, _, s_top, g_top, opt = scens[k]
        s, g = (s_top[0], h - 1 - s_top[1]), (g_top[0], h - 1 - g_top[1])
        t0 = time.perf_counter()
        exact = any_angle_shortest_path_np(blocked, s, g, args.rule)
        t_exact = time.perf_counter() - t0
        t0 = time.perf_counter()
        fast = any_angle_shortest_path_np(blocked, s, g, args.rule, exact=False)
        t_fast = time.perf_counter() - t0
        line = (
            f"| {s} | {g} | {opt:.4f} | {exact.length:.4f} | {t_exact:.2f} | "
            f"{exact.expanded} | {fast.length:.4f} | {t_fast:.2f} |\n"
        )
        print(line, end="", flush=True)
        out += line
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=DEFAULT_ROOT, help="folder of .map/.scen")
    ap.add_argument("--rule", default="strict", choices=("free", "no_squeeze", "strict"))
    ap.add_argument("--tol", type=float, default=1e-3)
    ap.add_argument("--scipy-sample", type=int, default=25, help="scenarios per map (0: off)")
    ap.add_argument("--any-angle-map", default="Berlin_1_256", help="map for the any-angle timing")
    ap.add_argument(
        "--any-angle-count", type=int, default=6, help="scenarios to time there (0: off)"
    )
    ap.add_argument("--no-append", action="store_true", help="do not write RESULTS.md")
    args = ap.parse_args(argv)

    if not args.root.is_dir():
        print(f"skipped: Moving AI folder {args.root} not found")
        return 0
    scen_files = sorted(args.root.glob("*.scen"))
    if not scen_files:
        print(f"skipped: no .scen files in {args.root}")
        return 0

    rows = []
    rng = np.random.default_rng(0)
    t_all = time.perf_counter()
    for scen_path in scen_files:
        scens = load_scen(scen_path)
        map_name = scens[0][0]
        blocked = load_movingai_map(args.root / map_name)
        h, w = blocked.shape
        t0 = time.perf_counter()
        graph = OctileGraph(blocked, args.rule)
        t_build = time.perf_counter() - t0
        ok = 0
        worst = 0.0
        ours: list[float] = []
        pairs = []
        t0 = time.perf_counter()
        for name, sw, sh, s_top, g_top, opt in scens:
            if (name, sw, sh) != (map_name, w, h):
                raise ValueError(f"{scen_path}: scenario for {name} {sw}x{sh}, map is {w}x{h}")
            s = (s_top[0], h - 1 - s_top[1])
            g = (g_top[0], h - 1 - g_top[1])
            res = graph.search(s, g)
            err = abs(res.length - opt) if res.found else float("inf")
            worst = max(worst, err)
            ok += err <= args.tol
            ours.append(res.length)
            pairs.append((s, g))
        t_search = time.perf_counter() - t0
        scipy_txt = "-"
        if args.scipy_sample > 0:
            pick = rng.choice(len(pairs), size=min(args.scipy_sample, len(pairs)), replace=False)
            wrong = scipy_check(
                blocked, args.rule, [pairs[i] for i in pick], [ours[i] for i in pick]
            )
            scipy_txt = f"{len(pick) - wrong}/{len(pick)}"
        rows.append(
            (
                scen_path.name,
                f"{w}x{h}",
                len(scens),
                ok,
                worst,
                t_build + t_search,
                1e3 * t_search / len(scens),
                scipy_txt,
            )
        )
        print(
            f"{scen_path.name:42s} {ok}/{len(scens)} within {args.tol:g}  max err {worst:.2e}  "
            f"{t_build + t_search:6.2f} s",
            flush=True,
        )
    total = time.perf_counter() - t_all
    any_angle_table = any_angle_timing(args)

    head = (
        "| scen file | map W x H | scenarios | within tol | max abs error | time (s) | "
        "ms / scenario | scipy cross-check |\n|---|---|---|---|---|---|---|---|\n"
    )
    body = "".join(
        f"| {r[0]} | {r[1]} | {r[2]} | {r[3]}/{r[2]} | {r[4]:.1e} | {r[5]:.2f} | {r[6]:.2f} | "
        f"{r[7]} |\n"
        for r in rows
    )
    n_all, ok_all = sum(r[2] for r in rows), sum(r[3] for r in rows)
    foot = (
        f"| **all** | | {n_all} | {ok_all}/{n_all} | {max(r[4] for r in rows):.1e} | "
        f"{total:.2f} | {1e3 * total / n_all:.2f} | |\n"
    )
    table = head + body + foot
    print()
    print(table)
    if any_angle_table:
        print(any_angle_table)
    body = (
        f"`jaxga.reference.optima` 8-connected optimum (A*, octile heuristic, one `OctileGraph` "
        f"per map) on every scenario of every `.scen` file in `{args.root}`, corner rule "
        f"'{args.rule}', tolerance {args.tol:g}; 'scipy cross-check' compares a random sample "
        f"with `scipy.sparse.csgraph.dijkstra`. `platform.processor()` = "
        f"{platform.processor()!r}, `os.cpu_count()` = {os.cpu_count()}.\n\n" + table
    )
    if any_angle_table:
        body += (
            f"\nAny-angle optimum (`any_angle_shortest_path_np`, corner rule '{args.rule}') on "
            f"{args.any_angle_count} scenarios of {args.any_angle_map} spread over the range "
            "of optimal lengths; 'upper bound' is `exact=False`.\n\n" + any_angle_table
        )
    _results.record(
        f"Moving AI optimal lengths (jaxga.reference.optima, '{args.rule}')",
        body,
        write=not args.no_append,
    )
    return 0 if ok_all == n_all else 1


if __name__ == "__main__":
    raise SystemExit(main())
