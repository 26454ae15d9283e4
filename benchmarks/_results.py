"""Shared by the benchmark scripts: machine description, child processes, and the
current results in RESULTS.md (with their history in ``history/results.jsonl``)."""

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
    ``benchmarks/``; it has no persistent compilation cache (``JAXGA_CACHE_DIR`` empty,
    ``JAX_COMPILATION_CACHE_DIR`` removed), so it compiles cold. ``env`` adds or replaces
    environment variables (``XLA_FLAGS``, ``JAXGA_DEVICES``, ``PYTHONPATH`` to import
    another checkout's ``jaxga``, ...). A failing child raises
    ``RuntimeError`` with the end of its stderr."""
    import json
    import subprocess

    here = Path(__file__).resolve().parent
    child_env = dict(os.environ, PYTHONPATH=f"{here.parent}{os.pathsep}{here}")
    child_env.pop("JAX_COMPILATION_CACHE_DIR", None)
    child_env["JAXGA_CACHE_DIR"] = ""  # the Python API turns a cache on unless this is empty
    child_env.update(env)
    proc = subprocess.run([sys.executable, script, "--child", spec], env=child_env,
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


def child_at(checkout: Path, script: str, spec: str) -> dict:
    """:func:`cold_child` of the benchmark ``script`` (a file name in this
    ``benchmarks/``) importing ``jaxga`` from ``checkout`` instead of this tree."""
    here = Path(__file__).resolve().parent
    return cold_child(str(here / script), spec,
                      PYTHONPATH=f"{checkout}{os.pathsep}{here}")[0]


def child_at_revision(revision: str, script: str, spec: str) -> dict:
    """:func:`child_at` on a checkout of ``revision`` (a temporary ``git worktree``,
    removed afterwards)."""
    import subprocess
    import tempfile

    root = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", str(base), revision],
                       cwd=root, check=True, capture_output=True)
        try:
            return child_at(base, script, spec)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=root,
                           check=True, capture_output=True)


def peak_rss_bytes() -> int:
    """This process's peak resident memory in bytes (``ru_maxrss``: KiB on Linux, bytes
    on macOS)."""
    import resource

    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(rss if sys.platform == "darwin" else rss * 1024)


PRESETS = ("sga", "imga", "agacd", "iga_zhang", "mpmga", "iga_zhu")
"""The six presets in the papers' order, the benchmarks' default and table order
(``jaxga.config.presets.preset_names()`` lists them alphabetically)."""

PROGRAMS = ("init", "finish", "evolve")
"""The programs of a program set (``jaxga.api.programs.Programs``), in the order of
:func:`xla_seconds_by_program`'s entries."""


def xla_seconds_by_program(xla: list) -> dict[str, float]:
    """:func:`instrumented_run`'s ``parts["xla"]`` as XLA seconds per program of
    :data:`PROGRAMS` (the evolve programs summed)."""
    return {"init": xla[0][0], "finish": xla[1][0], "evolve": sum(s for s, _ in xla[2:])}


STANDARD_POPULATION, STANDARD_GENERATIONS = 60, 300
"""The compile benchmarks' setting (:func:`standard_run`): AGACD Table 6's 20 x 20 run."""

STANDARD_SETTING = (f"`classic_ga_gapp3_20x20`, corner rule free, population "
                    f"{STANDARD_POPULATION} (mpmga 3 x {STANDARD_POPULATION // 3}), "
                    f"{STANDARD_GENERATIONS} generations")
""":func:`standard_run`'s setting in words, for the tables' captions."""


def standard_run(preset: str, seeds: int):
    """``jaxga.run(preset, classic_ga_gapp3_20x20, seeds)`` as the compile benchmarks run
    it: corner rule free, :data:`STANDARD_POPULATION` individuals (mpmga: 3 islands of a
    third of them), :data:`STANDARD_GENERATIONS` generations."""
    from jaxga import api
    from jaxga.maps import load_map

    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    size = STANDARD_POPULATION // 3 if preset == "mpmga" else STANDARD_POPULATION
    return api.run(preset, grid, seeds=seeds, population__size=size,
                   generations=STANDARD_GENERATIONS)


CLI_MAP = "classic_ga_gapp3_20x20"
"""The built-in map of :func:`cli_run` (the README's main command runs on it)."""


def cli_run(preset: str, seeds: int):
    """What ``jaxga run --preset <preset> --map classic_ga_gapp3_20x20 --seeds <seeds>``
    runs, through ``jaxga.cli.main``: the preset's own population and generations, and
    the progress bar's chunked evolution. Without a persistent compilation cache (the
    command line's own, ``$JAXGA_CACHE_DIR``, is turned off). Returns the ``Result``
    (the summary table the command prints is discarded)."""
    import contextlib
    import io

    from jaxga import api, cli
    from jaxga.api.compilation_cache import ENV_VAR

    os.environ[ENV_VAR] = ""
    got = []
    run = api.run

    def recording(*args, **kwargs):
        got.append(run(*args, **kwargs))
        return got[-1]

    api.run = recording
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            status = cli.main(["run", "--preset", preset, "--map", CLI_MAP,
                               "--seeds", str(seeds)])
    finally:
        api.run = run
    if status != 0 or len(got) != 1:
        raise RuntimeError(f"jaxga run --preset {preset} exited with {status}")
    return got[0]


def instrumented_run(preset: str, seeds: int, run=standard_run):
    """:func:`standard_run` (or ``run``, e.g. :func:`cli_run`) with its compilation timed.

    Returns ``(result, parts)``: ``parts["trace_s"]`` (JAX's ``jaxpr_trace_duration``
    events), ``parts["lower_s"]`` (``Traced.lower``), ``parts["xla"]`` (one
    ``(seconds, compiled program)`` per ``Lowered.compile``, in compile order) and
    ``parts["cpu_s"]`` (the process's user + system CPU seconds over the call). Used by
    ``compile_anatomy.py`` and ``compile_ab.py``, in a fresh process (:func:`cold_child`).
    """
    import resource
    import time

    import jax
    import jax.monitoring

    parts = {"trace_s": 0.0, "lower_s": 0.0, "xla": []}

    def listen(event: str, duration: float, **_kw) -> None:
        if event == "/jax/core/compile/jaxpr_trace_duration":
            parts["trace_s"] += duration

    jax.monitoring.register_event_duration_secs_listener(listen)
    lower, compile_ = jax.stages.Traced.lower, jax.stages.Lowered.compile

    def timed_lower(self, *a, **k):
        t = time.perf_counter()
        out = lower(self, *a, **k)
        parts["lower_s"] += time.perf_counter() - t
        return out

    def timed_compile(self, *a, **k):
        t = time.perf_counter()
        out = compile_(self, *a, **k)
        parts["xla"].append((time.perf_counter() - t, out))
        return out

    jax.stages.Traced.lower, jax.stages.Lowered.compile = timed_lower, timed_compile
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    result = run(preset, seeds)
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    parts["cpu_s"] = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    return result, parts


def parse_args(ap, child):
    """``ap.parse_args()`` for a benchmark script, which is also its own child process.

    :func:`cold_child` starts ``python <script> --child a:b:...``; then this calls
    ``child(a, b, ...)`` (parts made of digits as ``int``), prints its result as JSON for
    the parent and exits, instead of returning the arguments.
    """
    import argparse
    import json

    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        parts = [int(p) if p.lstrip("-").isdigit() else p for p in args.child.split(":")]
        print(json.dumps(child(*parts)))
        raise SystemExit(0)
    return args


def markdown_table(headers: list[str], rows: list[list]) -> str:
    """A GitHub markdown table (numbers right-aligned)."""
    def fmt(v):
        return f"{v:,.2f}" if isinstance(v, float) else str(v)

    out = ["| " + " | ".join(headers) + " |",
           "|" + "|".join("---:" if i else "---" for i in range(len(headers))) + "|"]
    out += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


RESULTS_HEADER = """# Benchmark results

The current result of every benchmark in `benchmarks/`: one section per script and
command line, replaced in place when the script runs again (`_results.record`). Each
section names the command, the commit it measured, the date and the machine. Every
run is also appended to `benchmarks/history/results.jsonl` (one JSON object per run:
title, command, commit, date, machine, body), where older readings stay; conclusions
and rejected experiments are the decision notes in `docs/decisions/`. Sections are
ordered by script. A section whose commit is older than the code you read measured that
commit ("recorded in X": measured on the code just before commit X); run its command
again to refresh it.
"""
"""The text above the sections of ``RESULTS.md``."""

HISTORY = Path(__file__).with_name("history") / "results.jsonl"


def script_command(command_line: str) -> str:
    """``command_line`` from its script on (``PYTHONPATH=. /x/python benchmarks/speed.py
    --seeds 1`` -> ``speed.py --seeds 1``): what identifies a benchmark's section."""
    words = command_line.strip().strip("`").split()
    for i, word in enumerate(words):
        if word.endswith(".py"):
            return " ".join([Path(word).name, *words[i + 1:]])
    return " ".join(words)


def commit() -> str:
    """The checkout's short commit, ``+changes`` appended when its tracked files differ
    from that commit (the measured code is then not exactly the commit)."""
    import subprocess

    root = Path(__file__).resolve().parents[1]

    def git(*args: str) -> str:
        out = subprocess.run(["git", *args], cwd=root, capture_output=True, text=True)
        return out.stdout.strip() if out.returncode == 0 else ""

    head = git("rev-parse", "--short", "HEAD") or "unknown"
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", "jaxga", "presets")
    return head + ("+changes" if dirty else "")


META = ("command", "commit", "date", "machine")
"""The bullets under a section's title, in order."""


def _meta(line: str) -> tuple[str, str] | None:
    """``("commit", "abc1234")`` for the line ``- commit: abc1234``, else None."""
    key, sep, value = line[2:].partition(":")
    return (key, value.strip()) if line.startswith("- ") and sep and key in META else None


def parse_sections(text: str) -> tuple[str, list[dict]]:
    """``RESULTS.md`` as its header and its sections: ``{"title", "command", "commit",
    "date", "machine", "body"}`` each (the inverse of :func:`render`)."""
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("## ")]
    header = "\n".join(lines[:starts[0]] if starts else lines).strip() + "\n"
    sections = []
    for a, b in zip(starts, [*starts[1:], len(lines)]):
        sec = {"title": lines[a][3:].strip(), **dict.fromkeys(META, "")}
        i = a + 1
        while i < b and (not lines[i].strip() or _meta(lines[i])):
            if lines[i].strip():
                key, value = _meta(lines[i])
                sec[key] = value.strip("`") if key == "command" else value
            i += 1
        sec["body"] = "\n".join(lines[i:b]).strip()
        sections.append(sec)
    return header, sections


def render(header: str, sections: list[dict]) -> str:
    """The text of ``RESULTS.md``: the header, then each section (title, command,
    commit, date, machine, body)."""
    out = [header.strip(), ""]
    for sec in sections:
        out += [f"## {sec['title']}", "", f"- command: `{sec['command']}`",
                f"- commit: {sec['commit']}", f"- date: {sec['date']}",
                f"- machine: {sec['machine']}", "", sec["body"].strip(), ""]
    return "\n".join(out)


def _section_key(sec: dict) -> tuple[str, str]:
    return sec["title"], script_command(sec["command"])


def replace_section(text: str, new: dict) -> str:
    """``RESULTS.md``'s text with ``new`` in place of the section of the same title and
    script command (added if there is none), sections ordered by script."""
    header, sections = parse_sections(text) if text.strip() else (RESULTS_HEADER, [])
    kept = [s for s in sections if _section_key(s) != _section_key(new)]
    order = {k: i for i, k in enumerate(_section_key(s) for s in sections)}
    kept.append(new)
    kept.sort(key=lambda s: (script_command(s["command"]).split(" ")[0],
                             order.get(_section_key(s), len(order))))
    return render(header, kept)


def record(title: str, body: str, *, write: bool = True, results: Path | None = None,
           history: Path | None = None) -> dict:
    """Make ``body`` the current result of this benchmark: the section of ``RESULTS.md``
    with this ``title`` and this script command is replaced (or added), and the run is
    appended to ``history/results.jsonl``. ``write=False`` only prints it."""
    import json

    if any(line.startswith("## ") for line in body.splitlines()):
        raise ValueError("a result's body cannot hold a level-2 heading ('## ')")
    sec = {"title": title, "command": command(), "commit": commit(),
           "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
           "machine": machine(), "body": body.strip()}
    print(render("", [sec]))
    if write:
        results = results or RESULTS
        history = history or HISTORY
        text = results.read_text(encoding="utf-8") if results.exists() else ""
        results.write_text(replace_section(text, sec), encoding="utf-8")
        history.parent.mkdir(parents=True, exist_ok=True)
        with history.open("a", encoding="utf-8") as fh:
            fh.write(json.dumps(sec) + "\n")
        print(f"recorded in {results} and {history}")
    return sec


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

