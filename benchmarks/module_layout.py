"""The module layout of jaxga drawn: its import graph by layer, and the hops of the main job.

    python benchmarks/module_layout.py [--rev REV] [--out PNG] [--json JSON]
                                       [--preset iga_zhu] [--no-run] [--no-api]

Why: a restructuring of the package is judged by what a reader and a call go through,
not by the names of its folders. This script measures both, for the working tree or for
any revision (``--rev``, checked out in a temporary ``git worktree``, removed after), so
that "before" and "after" are drawn by one tool with one rule:

1. **Imports.** Every module of ``jaxga/`` is read with :mod:`ast` (nothing is imported).
   ``import jaxga.a.b`` and ``from jaxga.a import b`` point to the module ``jaxga.a.b``
   where it exists, else to the longest enclosing module (``from jaxga.api import run``:
   ``jaxga.api``); relative imports are resolved against the importing module, as
   tests/repository/test_layers.py does. Modules are grouped into the layers that the
   analysed checkout's own test_layers.py names (``LAYERS``, bottom to top; at 547c6ec
   ``_batching``, ``core``, ``maps``, ``operators``, ``config``, ``engine``,
   ``reference``, ``api``, ``tools``): a module's layer is its first folder, and the
   tools are the other modules (the package itself, its own ``*.py`` files, ``cli/``
   and ``doe/``). Reported: modules, edges (one per importing and imported module,
   self-imports left out; ``if TYPE_CHECKING:`` imports counted apart), import cycles
   (strongly connected groups of more than one module over the edges that run when
   imported or called; must be none), edges per layer pair, and the largest modules in
   lines.
2. **Hops of the main job.** The README's main job (``jaxga run --preset iga_zhu --map
   classic_ga_gapp3_20x20``, here 2 seeds and 5 generations: every program it needs is
   traced, compiled and run once; more seeds or generations call the same programs
   more often) runs in a child process under :func:`sys.setprofile`, compiling cold (a
   fresh ``$JAXGA_CACHE_DIR``). Every call of a jaxga function whose nearest jaxga caller
   on the stack (frames of JAX, NumPy or the standard library in between are skipped:
   a program traced by ``jax.jit`` is called by the module that handed it to JAX) is in
   another module is a hop, counted per ordered pair of modules (module-level, from
   ``frame.f_globals["__name__"]``; the execution of a module body on import is not a
   call). Counted apart: the hops with no frame of another library between the two
   (direct), the hops made while JAX traces a program, and, while tracing, the hops
   between ``jaxga.engine.*`` and ``jaxga.config.*`` or ``jaxga.operators.registry`` (a
   traced generation that asks the configuration layer how to call its operators). The
   same for the Python API, ``jaxga.run(preset, map, seeds=2, generations=5)``, in
   another fresh process.
3. **Drawing** (``--out``, a 1400-pixel-wide PNG in 256 colours, or SVG): layers as
   horizontal bands, bottom to top, each module a box labelled with its name and lines;
   imports as thin grey lines; the command line's hops on top as arrows, thicker for
   more calls, the busiest labelled with their counts (orange: mostly while tracing;
   blue: outside tracing; red: engine and configuration while tracing, labelled
   ``traced/all``). Every number, the API's hops included, is in ``--json``.

The job's modules are imported from the analysed checkout (``PYTHONPATH``), this script
is not: it needs only the standard library and Matplotlib.
"""

from __future__ import annotations

import argparse
import ast
import collections
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

LAYERS = ("_batching", "core", "maps", "operators", "config", "engine", "reference", "api",
          "tools")
"""Bottom to top, as in docs/architecture.md: the layers of a checkout whose
tests/repository/test_layers.py cannot be read (:func:`read_layers`)."""

LAYERS_FILE = Path("tests") / "repository" / "test_layers.py"
"""Where a checkout names its own layers (``LAYERS``), so that each revision is drawn in
the layers it had."""

MAP = "classic_ga_gapp3_20x20"
"""The README main job's map."""

TRACING_PAIR = ("jaxga.engine", ("jaxga.config", "jaxga.operators.registry"))
"""The hops counted apart while tracing: engine on one side, configuration on the other."""


# --------------------------------------------------------------------------- the imports

def module_name(path: Path, package: Path) -> str:
    """``jaxga/api/runs.py`` -> ``jaxga.api.runs``; a package's ``__init__.py`` is the
    package."""
    parts = list(path.relative_to(package.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def read_layers(checkout: Path) -> tuple[str, ...]:
    """The ``LAYERS`` tuple of the checkout's tests/repository/test_layers.py, read with
    :mod:`ast`; :data:`LAYERS` where the file or the name is missing."""
    try:
        tree = ast.parse((checkout / LAYERS_FILE).read_text())
    except (OSError, SyntaxError):
        return LAYERS
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "LAYERS" for t in node.targets):
            return tuple(ast.literal_eval(node.value))
    return LAYERS


def layer(module: str, layers: tuple[str, ...] = LAYERS) -> str:
    """The layer of a ``jaxga`` module: its first folder when that is a layer, else the
    tools (the package itself, its own ``*.py`` files, ``cli`` and ``doe``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in layers else "tools"


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """The ids of the nodes under an ``if TYPE_CHECKING:`` (never run)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            test = node.test
            name = test.id if isinstance(test, ast.Name) else \
                test.attr if isinstance(test, ast.Attribute) else None
            if name == "TYPE_CHECKING":
                out |= {id(n) for stmt in node.body for n in ast.walk(stmt)}
    return out


def imported_modules(source: str, module: str, is_package: bool, modules: set[str]):
    """``(imported module, kind)`` for every import of a module of ``modules`` in
    ``source`` (the text of ``module``); ``kind`` is ``"top"``, ``"function"`` (inside a
    function: runs when called) or ``"typing"`` (under ``if TYPE_CHECKING:``)."""
    tree = ast.parse(source)
    in_function = {id(node) for fn in ast.walk(tree)
                   if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef))
                   for node in ast.walk(fn)}
    typing = _type_checking_nodes(tree)

    def known(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    for node in ast.walk(tree):
        kind = "typing" if id(node) in typing else \
            "function" if id(node) in in_function else "top"
        if isinstance(node, ast.Import):
            for alias in node.names:
                if (target := known(alias.name)) is not None:
                    yield target, kind
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolved against this module
                parts = module.split(".")
                base = parts[: len(parts) - node.level + is_package]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:  # `from jaxga.x import y`: y itself if a module
                found = known(f"{target}.{alias.name}") if target else None
                if found is None or found != f"{target}.{alias.name}":
                    found = known(target)
                if found is not None:
                    yield found, kind


def import_graph(package: Path, layers: tuple[str, ...] = LAYERS) -> dict:
    """The import graph of the package in folder ``package`` (its ``__init__.py``'s
    folder) in ``layers`` (bottom to top): ``layers``, ``modules`` (name -> layer, lines,
    path) and ``edges`` (sorted ``[importer, imported, kind]``, one per pair, the kind
    that runs first: top before function before typing)."""
    files = sorted(package.rglob("*.py"))
    modules = {module_name(p, package): p for p in files}
    names = set(modules)
    rank = {"top": 0, "function": 1, "typing": 2}
    edges: dict[tuple[str, str], str] = {}
    for name, path in modules.items():
        for target, kind in imported_modules(path.read_text(), name,
                                             path.name == "__init__.py", names):
            if target == name:
                continue
            old = edges.get((name, target))
            if old is None or rank[kind] < rank[old]:
                edges[(name, target)] = kind
    info = {name: {"layer": layer(name, layers), "lines": len(path.read_text().splitlines()),
                   "path": str(path.relative_to(package.parent))}
            for name, path in modules.items()}
    return {"layers": list(layers), "modules": info,
            "edges": sorted([a, b, k] for (a, b), k in edges.items())}


def cycles(nodes, edges) -> list[list[str]]:
    """The strongly connected groups of more than one node (Tarjan's algorithm, without
    recursion): each is at least one import cycle."""
    succ = collections.defaultdict(list)
    for a, b in edges:
        succ[a].append(b)
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in sorted(nodes):
        if root in index:
            continue
        work = [(root, iter(sorted(succ[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(succ[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    group = []
                    while True:
                        top = stack.pop()
                        on_stack.discard(top)
                        group.append(top)
                        if top == node:
                            break
                    if len(group) > 1:
                        out.append(sorted(group))
    return sorted(out)


def summary(graph: dict, largest: int = 10) -> dict:
    """The numbers of an :func:`import_graph`: modules, modules per layer, edges (and how
    many run only inside a function or only for type checkers), cycles, edges per layer
    pair (``"from -> to"``) and the ``largest`` modules by lines."""
    modules, edges, layers = graph["modules"], graph["edges"], graph["layers"]
    runtime = [(a, b) for a, b, k in edges if k != "typing"]
    pairs = collections.Counter(f"{modules[a]['layer']} -> {modules[b]['layer']}"
                                for a, b, _ in edges)
    order = {name: i for i, name in enumerate(layers)}
    found = cycles(modules, runtime)
    return {
        "modules": len(modules),
        "modules_per_layer": {name: sum(m["layer"] == name for m in modules.values())
                              for name in layers},
        "lines": sum(m["lines"] for m in modules.values()),
        "edges": len(edges),
        "edges_in_functions": sum(k == "function" for _, _, k in edges),
        "edges_for_type_checkers": sum(k == "typing" for _, _, k in edges),
        "cycles": len(found),
        "cycle_groups": found,
        "edges_per_layer_pair": dict(sorted(
            pairs.items(), key=lambda kv: tuple(order[x] for x in kv[0].split(" -> ")))),
        "largest_modules": [[name, m["lines"]] for name, m in sorted(
            modules.items(), key=lambda kv: -kv[1]["lines"])[:largest]],
    }


# ------------------------------------------------------------------------ the hops of a job

class HopRecorder:
    """A :func:`sys.setprofile` function that counts the calls from one jaxga module into
    another (module docstring, item 2)."""

    def __init__(self, trace_state=None):
        self.trace_state = trace_state  # JAX's current trace (None: tracing not known)
        self.hops: dict[tuple[str, str], list[int]] = {}  # in order of first call
        self.functions: dict[tuple[str, str], collections.Counter] = {}
        self.visited: collections.Counter = collections.Counter()

    def tracing(self) -> bool:
        if self.trace_state is None:
            return False
        return type(self.trace_state.trace).__name__ != "EvalTrace"

    def __call__(self, frame, event, arg):
        if event != "call":
            return
        callee = frame.f_globals.get("__name__", "")
        if not (callee == "jaxga" or callee.startswith("jaxga.")):
            return
        if frame.f_code.co_name == "<module>":  # an import, not a call
            return
        self.visited[callee] += 1
        caller, direct, up = None, True, frame.f_back
        while up is not None:
            name = up.f_globals.get("__name__", "")
            if name == "jaxga" or name.startswith("jaxga."):
                caller = name
                break
            direct = False
            up = up.f_back
        if caller is None or caller == callee:
            return
        tracing = self.tracing()
        counts = self.hops.setdefault((caller, callee), [0, 0, 0])
        counts[0] += 1
        counts[1] += direct
        counts[2] += tracing
        if tracing and is_tracing_pair(caller, callee):
            self.functions.setdefault((caller, callee), collections.Counter())[
                frame.f_code.co_name] += 1

    def report(self) -> dict:
        """The counts: total hops, distinct pairs, direct hops, hops while tracing, the
        engine and configuration hops while tracing (with the functions called), modules
        passed through, and every pair ``[caller, callee, calls, direct, tracing]`` in the
        order of its first call."""
        rows = [[a, b, *c] for (a, b), c in self.hops.items()]
        return {
            "hops": sum(r[2] for r in rows),
            "distinct_hops": len(rows),
            "direct_hops": sum(r[3] for r in rows),
            "hops_while_tracing": sum(r[4] for r in rows),
            "engine_config_hops_while_tracing": sum(
                r[4] for r in rows if is_tracing_pair(r[0], r[1])),
            "engine_config_functions": {f"{a} -> {b}": dict(c.most_common())
                                        for (a, b), c in self.functions.items()},
            "modules_visited": len(self.visited),
            "visited": sorted(self.visited),
            "pairs": rows,
        }


def is_tracing_pair(a: str, b: str) -> bool:
    """Whether one of ``a``, ``b`` is in ``jaxga.engine`` and the other in ``jaxga.config``
    or is ``jaxga.operators.registry``."""
    engine, others = TRACING_PAIR

    def inside(name, prefix):
        return name == prefix or name.startswith(prefix + ".")

    def other(name):
        return any(inside(name, p) for p in others)

    return (inside(a, engine) and other(b)) or (inside(b, engine) and other(a))


def child(kind: str, preset: str, seeds: int, generations: int) -> dict:
    """In the child process: run the main job (``kind`` ``cli``: ``jaxga.cli.main``;
    ``api``: ``jaxga.run``) under a :class:`HopRecorder` and return its report."""
    import threading
    import time

    import jaxga  # from $PYTHONPATH: the analysed checkout
    import jaxga.cli

    try:
        from jax._src.core import trace_ctx
    except ImportError:  # another JAX: tracing not told apart
        trace_ctx = None
    recorder = HopRecorder(trace_ctx)
    argv = ["run", "--preset", preset, "--map", MAP, "--seeds", str(seeds),
            "--generations", str(generations)]
    start = time.perf_counter()
    threading.setprofile(recorder)
    sys.setprofile(recorder)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            if kind == "cli":
                code = jaxga.cli.main(argv)
                if code:
                    raise SystemExit(f"jaxga {' '.join(argv)} exited {code}")
            else:
                jaxga.run(preset, MAP, seeds=seeds, generations=generations)
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    out = recorder.report()
    out["job"] = (f"jaxga {' '.join(argv)}" if kind == "cli" else
                  f"jaxga.run({preset!r}, {MAP!r}, seeds={seeds}, generations={generations})")
    out["seconds"] = round(time.perf_counter() - start, 1)
    out["jaxga_file"] = jaxga.__file__
    out["tracing_known"] = trace_ctx is not None
    return out


def run_child(checkout: Path, kind: str, args) -> dict:
    """:func:`child` in a fresh process importing jaxga from ``checkout``, compiling cold
    (a new, empty ``$JAXGA_CACHE_DIR``; JAX's own cache variable removed)."""
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as cwd:
        env = dict(os.environ, PYTHONPATH=str(checkout), JAXGA_CACHE_DIR=cache,
                   MPLBACKEND="Agg")
        env.pop("JAX_COMPILATION_CACHE_DIR", None)
        out = Path(cwd) / "hops.json"
        proc = subprocess.run(
            [sys.executable, str(Path(__file__).resolve()), "--child", kind,
             "--preset", args.preset, "--seeds", str(args.seeds),
             "--generations", str(args.generations), "--json", str(out)],
            cwd=cwd, env=env, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"the {kind} job failed:\n{proc.stderr[-3000:]}")
        report = json.loads(out.read_text())
    if not Path(report["jaxga_file"]).resolve().is_relative_to(checkout.resolve()):
        raise RuntimeError(f"the child imported {report['jaxga_file']}, not {checkout}")
    return report


# ------------------------------------------------------------------------------ drawing

def _short(module: str, layer_name: str) -> str:
    """A box's label: the name inside its layer (``jaxga.api.runs`` -> ``runs``)."""
    parts = module.split(".")
    if module == "jaxga":
        return "jaxga/__init__"
    if parts[1] == layer_name:
        return ".".join(parts[2:]) or f"{parts[1]}/__init__"
    return ".".join(parts[1:])


def layout(modules: dict, layers, per_row: int = 11) -> tuple[dict, dict]:
    """Box centres ``(x, y)`` in a unit-wide frame, and each layer's band ``(y0, y1)``:
    layers bottom to top, a layer's modules in rows of at most ``per_row`` (sorted by
    name, so a subpackage's modules sit together)."""
    pos, bands, y = {}, {}, 0.0
    row_h, gap = 1.0, 0.35
    for name in layers:
        members = sorted(m for m, info in modules.items() if info["layer"] == name)
        rows = [members[i:i + per_row] for i in range(0, len(members), per_row)] or [[]]
        y0 = y
        for r, row in enumerate(reversed(rows)):
            for i, module in enumerate(row):
                pos[module] = ((i + 0.5) / per_row + (per_row - len(row)) / (2 * per_row),
                               y + row_h * (r + 0.5))
        y += row_h * len(rows)
        bands[name] = (y0, y)
        y += gap
    return pos, bands


def draw(report: dict, out: Path, labelled: int = 24) -> None:
    """The figure of module docstring item 3, 1400 pixels wide; the ``labelled`` busiest
    hops (and every engine and configuration hop while tracing) carry their counts."""
    import math

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    modules = report["graph"]["modules"]
    layers = report["graph"]["layers"]
    pos, bands = layout(modules, layers)
    top = max(y1 for _, y1 in bands.values())
    hops = report.get("hops", {}).get("cli")
    inch_per_unit, head, foot = 0.62, 1.0 if hops else 0.4, 0.45  # a row, title, legend
    fig = plt.figure(figsize=(14.0, head + foot + inch_per_unit * (top + 0.4)), dpi=100)
    height = fig.get_figheight()
    ax = fig.add_axes((0.005, foot / height, 0.99, 1 - (head + foot) / height))
    ax.set_xlim(-0.09, 1.0)
    ax.set_ylim(-0.2, top + 0.2)
    ax.axis("off")
    box_w, box_h = 0.082, 0.56
    shades = ("#f4f4f4", "#e8eef6")
    for i, name in enumerate(layers):
        y0, y1 = bands[name]
        ax.add_patch(plt.Rectangle((-0.09, y0 - 0.1), 1.09, y1 - y0 + 0.2,
                                   color=shades[i % 2], zorder=0, lw=0))
        ax.text(-0.085, (y0 + y1) / 2, name, ha="left", va="center", fontsize=11,
                fontweight="bold", color="#333333")
    for a, b, kind in report["graph"]["edges"]:
        (xa, ya), (xb, yb) = pos[a], pos[b]
        ax.plot([xa, xb], [ya, yb], "-" if kind == "top" else ":", color="#a0a0a0",
                lw=0.4, alpha=0.4, zorder=1)
    max_lines = max(m["lines"] for m in modules.values())
    for module, (x, y) in pos.items():
        lines = modules[module]["lines"]
        shade = 1.0 - 0.45 * lines / max_lines
        ax.add_patch(FancyBboxPatch((x - box_w / 2, y - box_h / 2), box_w, box_h,
                                    boxstyle="round,pad=0.002,rounding_size=0.01",
                                    fc=(shade, shade, 1.0), ec="#445", lw=0.6, zorder=3))
        label = _short(module, modules[module]["layer"])
        size = 8 if len(label) <= 15 else 7 if len(label) <= 18 else 6
        behind = {"boxstyle": "square,pad=0.05", "fc": (shade, shade, 1.0), "ec": "none",
                  "alpha": 0.8}  # names stay legible over the arrows
        ax.text(x, y + 0.09, label, ha="center", va="center", fontsize=size, zorder=8,
                bbox=behind)
        ax.text(x, y - 0.15, f"{lines} lines", ha="center", va="center", fontsize=6.5,
                color="#555", zorder=8, bbox=behind)

    rad = 0.2
    if hops:
        rows = [r for r in hops["pairs"] if r[0] in pos and r[1] in pos]
        most = max(r[2] for r in rows)
        busiest = {(r[0], r[1]) for r in sorted(rows, key=lambda r: -r[2])[:labelled]}
        to_px, from_px = ax.transData.transform, ax.transData.inverted().transform
        for a, b, calls, _direct, tracing in sorted(rows, key=lambda r: r[2]):
            special = tracing > 0 and is_tracing_pair(a, b)
            colour = "#d62728" if special else \
                "#ff7f0e" if 2 * tracing > calls else "#1f77b4"
            weight = math.log1p(calls) / math.log1p(most)
            lw = 0.5 + 3.5 * weight
            ax.add_patch(FancyArrowPatch(
                pos[a], pos[b], connectionstyle=f"arc3,rad={rad}", arrowstyle="-|>",
                mutation_scale=5 + 2 * lw, lw=lw, color=colour,
                alpha=0.95 if special else 0.35 + 0.5 * weight, zorder=6 if special else 5,
                shrinkA=6, shrinkB=6))
            if (a, b) in busiest or special:
                # arc3 bends in display space: the curve's middle is half the control
                # point's offset, rad times the chord turned right
                (xa, ya), (xb, yb) = to_px(pos[a]), to_px(pos[b])
                mx = (xa + xb) / 2 + 0.5 * rad * (yb - ya)
                my = (ya + yb) / 2 - 0.5 * rad * (xb - xa)
                shown = f"{tracing}/{calls}" if special and tracing != calls else f"{calls}"
                ax.text(*from_px((mx, my)), shown, fontsize=7.5, color=colour,
                        fontweight="bold", ha="center", va="center", zorder=9,
                        bbox={"boxstyle": "round,pad=0.12", "fc": "white", "ec": colour,
                              "lw": 0.5, "alpha": 0.9})

    g = report["summary"]
    title = (f"jaxga at {report['revision']}: {g['modules']} modules, {g['edges']} imports "
             f"(grey lines), {g['cycles']} import cycles")
    if hops:
        title += (f"\nmain job: {hops['job']}\n{hops['hops']} hops (calls from one module "
                  f"into another) over {hops['distinct_hops']} module pairs (arrows), "
                  f"{hops['modules_visited']} modules passed through\n"
                  f"{hops['hops_while_tracing']} hops while JAX traces, "
                  f"{hops['engine_config_hops_while_tracing']} of them between engine and "
                  f"config/registry (red)")
    fig.text(0.01, 1 - 0.1 / height, title, fontsize=10.5, ha="left", va="top")
    legend = [Line2D([], [], color="#a0a0a0", lw=0.8, label="import")]
    if hops:
        legend += [Line2D([], [], color="#1f77b4", lw=2, label="calls outside tracing"),
                   Line2D([], [], color="#ff7f0e", lw=2, label="calls mostly while tracing"),
                   Line2D([], [], color="#d62728", lw=2,
                          label="engine <-> config/registry while tracing (traced/all)")]
    fig.legend(handles=legend, loc="lower left", bbox_to_anchor=(0.01, 0.0), ncol=4,
               fontsize=9, frameon=False,
               title="box: a module, its lines as its shade" + (
                   f"; arrow: thicker = more calls, the {labelled} busiest labelled"
                   if hops else ""), title_fontsize=9,
               alignment="left")
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() != ".png":
        fig.savefig(out, dpi=100)
    else:  # 256 colours: a quarter of the bytes of the full-colour image, for git
        from PIL import Image  # Matplotlib's own dependency

        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=100, format="png")
        image = Image.open(buffer).convert("RGB")
        image.quantize(256, method=Image.Quantize.MAXCOVERAGE).save(out, optimize=True)
    plt.close(fig)


# ----------------------------------------------------------------------------- the driver

def analyse(checkout: Path, revision: str, args) -> dict:
    """The graph, its summary and (unless ``--no-run``) the hops of the checkout."""
    graph = import_graph(checkout / "jaxga", read_layers(checkout))
    report = {"revision": revision, "graph": graph, "summary": summary(graph), "hops": {}}
    if not args.no_run:
        report["hops"]["cli"] = run_child(checkout, "cli", args)
        if not args.no_api:
            report["hops"]["api"] = run_child(checkout, "api", args)
    return report


def describe(revision: str | None) -> str:
    """``REV (short hash)`` of a revision, or the working tree's ``HEAD`` and whether
    jaxga/ has changes that are not committed."""
    def git(*a):
        return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()

    if revision is not None:
        return git("rev-parse", "--short", f"{revision}^{{commit}}")
    dirty = git("status", "--porcelain", "--", "jaxga")
    return git("rev-parse", "--short", "HEAD") + (" + uncommitted changes" if dirty else "")


def print_report(report: dict) -> None:
    g = report["summary"]
    print(f"revision {report['revision']}")
    print(f"modules {g['modules']} ({g['lines']} lines), edges {g['edges']} "
          f"({g['edges_in_functions']} only inside functions, "
          f"{g['edges_for_type_checkers']} for type checkers), cycles {g['cycles']}")
    for group in g["cycle_groups"]:
        print("  cycle group:", ", ".join(group))
    print("modules per layer:", ", ".join(f"{k} {v}" for k, v in g["modules_per_layer"].items()))
    print("edges per layer pair:")
    for pair, n in g["edges_per_layer_pair"].items():
        print(f"  {pair:24s} {n}")
    print("largest modules:", ", ".join(f"{m} {n}" for m, n in g["largest_modules"]))
    for kind, h in report["hops"].items():
        print(f"{kind}: {h['job']} ({h['seconds']} s under the profiler)")
        print(f"  hops {h['hops']} over {h['distinct_hops']} module pairs "
              f"({h['direct_hops']} direct, {h['hops_while_tracing']} while tracing), "
              f"modules passed through {h['modules_visited']}")
        print(f"  engine <-> config/registry while tracing: "
              f"{h['engine_config_hops_while_tracing']}")
        for pair, functions in h["engine_config_functions"].items():
            print(f"    {pair}: " + ", ".join(f"{f} {n}" for f, n in functions.items()))
        top = sorted(h["pairs"], key=lambda r: -r[2])[:12]
        print("  most calls: " + "; ".join(f"{a} -> {b} {n}" for a, b, n, _, _ in top))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rev", help="analyse this revision (a temporary git worktree) "
                        "instead of the working tree")
    parser.add_argument("--out", type=Path, help="draw the figure into this PNG")
    parser.add_argument("--json", type=Path, help="write the numbers to this JSON file")
    parser.add_argument("--preset", default="iga_zhu",
                        help="the main job's preset (default: the README's, iga_zhu)")
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--generations", type=int, default=5)
    parser.add_argument("--no-run", action="store_true", help="imports only: no job run")
    parser.add_argument("--no-api", action="store_true",
                        help="run the command line's job only, not jaxga.run's")
    parser.add_argument("--child", choices=("cli", "api"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.child:
        report = child(args.child, args.preset, args.seeds, args.generations)
        args.json.write_text(json.dumps(report))
        return 0

    revision = describe(args.rev)
    if args.rev is None:
        report = analyse(ROOT, revision, args)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            checkout = Path(tmp) / "checkout"
            subprocess.run(["git", "worktree", "add", "--detach", str(checkout), args.rev],
                           cwd=ROOT, check=True, capture_output=True)
            try:
                report = analyse(checkout, revision, args)
            finally:
                subprocess.run(["git", "worktree", "remove", "--force", str(checkout)],
                               cwd=ROOT, check=True, capture_output=True)
    print_report(report)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=1) + "\n")
    if args.out:
        draw(report, args.out)
        print(f"drawn: {args.out}")
    return 1 if report["summary"]["cycles"] else 0


if __name__ == "__main__":
    sys.exit(main())
