"""Shared by the benchmark scripts: machine description, child processes, and the
results: every run appended to ``history/results.jsonl``, and ``RESULTS.md`` generated
from it (the latest record of each section).

``python benchmarks/_results.py render [--check]`` writes (or checks) ``RESULTS.md``;
``retire`` and ``amend`` remove a section or replace its text through the history."""

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

PROGRAMS = ("tables", "init", "evolve", "finish")
"""The programs a run compiles: the map's tables (``jaxga.engine.maptables``), then the
program set's (``jaxga._runtime.programs.Programs``), in compile order."""


def program_name(module: str) -> str:
    """The :data:`PROGRAMS` name of a lowered module's name (``jit_do_evolve`` ->
    ``evolve``, ``jit_compute_tables`` -> ``tables``), else the module's name."""
    return next((p for p in PROGRAMS if module.endswith(p)), module)


def xla_seconds_by_program(xla: list) -> dict[str, float]:
    """:func:`instrumented_run`'s ``parts["xla"]`` as XLA seconds per program of
    :data:`PROGRAMS` (several compiles of one program summed; 0.0 for one not compiled)."""
    out = dict.fromkeys(PROGRAMS, 0.0)
    for seconds, _, module in xla:
        name = program_name(module)
        out[name] = out.get(name, 0.0) + seconds
    return out


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
    from jaxga._runtime.compilation_cache import ENV_VAR

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
    ``(seconds, compiled program, program name)`` per ``Lowered.compile``, in compile
    order; the name is the lowered module's, e.g. ``jit_init``) and
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
        seconds = time.perf_counter() - t
        name = str(self.compiler_ir().operation.attributes["sym_name"]).strip('"')
        parts["xla"].append((seconds, out, name))
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
command line, naming the command, the commit it measured, the date and the machine.
This file is generated from `benchmarks/history/results.jsonl`, where every run is
appended (one JSON object per run: title, command, commit, date, machine, body): each
section is the latest record of its title and command (`_results.record`). Do not edit
it by hand: run the benchmark again, or amend or retire a section with
`python benchmarks/_results.py amend` / `retire`; `python benchmarks/_results.py render
--check` says whether the file is current. Older readings stay in the history;
conclusions and rejected experiments are the decision notes in `docs/decisions/`.
Sections are ordered by script. A section whose commit is older than the code you read
measured that commit ("recorded in X": measured on the code just before commit X); run
its command again to refresh it.
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

SECTION = ("title", *META, "body")
"""The fields of a history record that make its section; a record may hold more
(``edited``, ``edited_on``), which the history keeps and ``RESULTS.md`` does not show."""


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


def section_key(rec: dict) -> tuple[str, str]:
    """A section's identity: its title and its :func:`script_command`. A run with the key
    of a current section replaces it; a run with a new key adds a section."""
    return rec["title"], script_command(rec["command"])


def read_history(history: Path | None = None) -> list[dict]:
    """The records of ``history/results.jsonl`` (or ``history``), in file order."""
    import json

    path = history or HISTORY
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()
            if line.strip()]


def current_sections(history: list[dict]) -> list[dict]:
    """The sections that ``history`` leaves current, in ``RESULTS.md``'s order.

    The records are replayed in order: a record replaces the section of its key
    (:func:`section_key`) where it stands, or adds one after the others; a record with
    ``"retired"`` (a reason) removes the section of its key, which a later run of that
    key adds again. The survivors are then ordered by script name, stably, so a script's
    sections keep the order in which they first appeared. Each is the record's
    :data:`SECTION` fields."""
    live: dict[tuple[str, str], dict] = {}
    for rec in history:
        key = section_key(rec)
        if rec.get("retired"):
            live.pop(key, None)
        else:
            live[key] = rec
    ordered = sorted(live.values(), key=lambda r: script_command(r["command"]).split(" ")[0])
    return [{field: rec[field] for field in SECTION} for rec in ordered]


def render_history(history: list[dict]) -> str:
    """The text ``RESULTS.md`` must have for ``history``: :data:`RESULTS_HEADER` and
    :func:`current_sections`."""
    return render(RESULTS_HEADER, current_sections(history))


def _now() -> str:
    """The date as a record writes it (UTC, to the minute)."""
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def _write_atomically(path: Path, text: str) -> None:
    """Write ``path`` through a temporary file in its folder and ``os.replace``, so that a
    reader (or an interrupted run) never sees half a file."""
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
        os.chmod(tmp, path.stat().st_mode & 0o777 if path.exists() else 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _names(keys: list[tuple[str, str]], shown: int = 3) -> str:
    """The first ``shown`` section keys as ``"title" (script command)``, then how many more."""
    names = ", ".join(f'"{title}" ({command[:60]})' for title, command in keys[:shown])
    return names + (f" and {len(keys) - shown} more" if len(keys) > shown else "")


def difference(text: str, rendering: str) -> str:
    """One line saying how ``text`` (``RESULTS.md``) differs from ``rendering`` (its
    history's): the header, sections edited, sections not in the history, sections
    missing, their order; empty when the two are equal."""
    if text == rendering:
        return ""
    head_a, secs_a = parse_sections(text) if text.strip() else ("", [])
    head_b, secs_b = parse_sections(rendering)
    a = {section_key(s): s for s in secs_a}
    b = {section_key(s): s for s in secs_b}
    parts = ["the header"] if head_a != head_b else []
    edited = [k for k in a if k in b and a[k] != b[k]]
    extra = [k for k in a if k not in b]
    missing = [k for k in b if k not in a]
    if edited:
        parts.append(f"{len(edited)} section(s) differ from their last record: "
                     + _names(edited))
    if extra:
        parts.append(f"{len(extra)} section(s) not in the history: " + _names(extra))
    if missing:
        parts.append(f"{len(missing)} section(s) of the history missing: " + _names(missing))
    if not parts:
        parts.append("the order of the sections" if list(a) != list(b) else "the layout")
    return "; ".join(parts)


def check_results(results: Path | None = None, history: Path | None = None) -> str:
    """Empty when ``RESULTS.md`` (or ``results``) is the rendering of the history (or
    ``history``); else one line saying what differs and what to do instead of editing."""
    results, history = results or RESULTS, history or HISTORY
    text = results.read_text(encoding="utf-8") if results.exists() else ""
    diff = difference(text, render_history(read_history(history)))
    if not diff:
        return ""
    return (f"{results.name} is not the rendering of {history.name} ({diff}); it is "
            "generated, not edited by hand: record the benchmark again, or `python "
            "benchmarks/_results.py amend` / `retire` the section (`python "
            "benchmarks/_results.py render` writes it from the history)")


def append_record(rec: dict, *, results: Path | None = None,
                  history: Path | None = None) -> None:
    """Append ``rec`` to the history and write ``RESULTS.md`` again as the history's
    rendering (atomically). A ``RESULTS.md`` that was not the rendering before is
    replaced all the same, with a note saying what was lost (git keeps it)."""
    import json

    if any(line.startswith("## ") for line in rec.get("body", "").splitlines()):
        raise ValueError("a result's body cannot hold a level-2 heading ('## ')")
    results, history = results or RESULTS, history or HISTORY
    before = check_results(results, history) if results.exists() else ""
    history.parent.mkdir(parents=True, exist_ok=True)
    with history.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps(rec) + "\n")
    _write_atomically(results, render_history(read_history(history)))
    if before:
        print(f"note: rewritten from the history; before this record, {before}",
              file=sys.stderr)


def record(title: str, body: str, *, write: bool = True, results: Path | None = None,
           history: Path | None = None) -> dict:
    """Make ``body`` the current result of this benchmark: the run (title, this command,
    commit, date, machine, body) is appended to ``history/results.jsonl`` and
    ``RESULTS.md`` is rendered again from it, so the section with this ``title`` and
    this script command is replaced (or added). ``write=False`` only prints it."""
    if any(line.startswith("## ") for line in body.splitlines()):
        raise ValueError("a result's body cannot hold a level-2 heading ('## ')")
    sec = {"title": title, "command": command(), "commit": commit(), "date": _now(),
           "machine": machine(), "body": body.strip()}
    print(render("", [sec]))
    if write:
        append_record(sec, results=results, history=history)
        print(f"recorded in {history or HISTORY} and {results or RESULTS}")
    return sec


def _current(title: str, command_line: str, history: Path | None) -> dict:
    """The current section of this title and script command, or ``ValueError``."""
    key = (title, script_command(command_line))
    for sec in current_sections(read_history(history)):
        if section_key(sec) == key:
            return sec
    raise ValueError(f"no current section titled {title!r} with the command {key[1]!r}")


def retire(title: str, command_line: str, why: str, *, results: Path | None = None,
           history: Path | None = None) -> dict:
    """Remove a section from ``RESULTS.md`` for good: append a record ``{"title",
    "command", "retired": why, "retired_on": date}`` (its runs stay in the history; a
    later run of the same title and command brings the section back)."""
    if not why.strip():
        raise ValueError("a retired section needs a reason (--why)")
    sec = _current(title, command_line, history)
    rec = {"title": sec["title"], "command": sec["command"], "retired": why.strip(),
           "retired_on": _now()}
    append_record(rec, results=results, history=history)
    return rec


def amend(title: str, command_line: str, body: str, why: str, *,
          results: Path | None = None, history: Path | None = None) -> dict:
    """Replace the text of a section without a new run (a note, a correction): append
    its latest record with ``body`` and ``"edited": why``, ``"edited_on": date``; the
    run's command, commit, date and machine stay, so the section still says what was
    measured, and the history says the text was edited after the run."""
    if not why.strip():
        raise ValueError("an amended section needs a reason (--why)")
    sec = _current(title, command_line, history)
    rec = {**sec, "body": body.strip(), "edited": why.strip(), "edited_on": _now()}
    append_record(rec, results=results, history=history)
    return rec


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


def main(argv: list[str] | None = None) -> int:
    """``render`` writes ``RESULTS.md`` from the history (``--check`` only compares:
    exit 1 with a one-line summary when the file is not the rendering); ``retire`` and
    ``amend`` append a record that removes a section or replaces its text."""
    import argparse

    ap = argparse.ArgumentParser(
        prog="python benchmarks/_results.py",
        description="RESULTS.md as the rendering of history/results.jsonl")
    sub = ap.add_subparsers(dest="action", required=True)
    ren = sub.add_parser("render", help="write RESULTS.md from the history")
    ren.add_argument("--check", action="store_true",
                     help="write nothing; exit 1 if RESULTS.md is not the rendering")
    for name, helptext in (("retire", "remove a section (its runs stay in the history)"),
                           ("amend", "replace a section's text without a new run")):
        p = sub.add_parser(name, help=helptext)
        p.add_argument("title", help="the section's title")
        p.add_argument("command", help="its command line (from the script on is enough)")
        p.add_argument("--why", required=True, help="the reason, kept in the history")
        if name == "amend":
            p.add_argument("--body-file", required=True, metavar="PATH",
                           help="the section's new text (markdown, no '## ' heading)")
    args = ap.parse_args(argv)
    if args.action == "render":
        if args.check:
            diff = check_results()
            print(diff or f"{RESULTS.name} is the rendering of {HISTORY.name}",
                  file=sys.stderr if diff else sys.stdout)
            return 1 if diff else 0
        _write_atomically(RESULTS, render_history(read_history()))
        print(f"wrote {RESULTS} from {HISTORY}")
        return 0
    try:
        if args.action == "retire":
            retire(args.title, args.command, args.why)
        else:
            amend(args.title, args.command, Path(args.body_file).read_text(encoding="utf-8"),
                  args.why)
    except (OSError, ValueError) as err:
        ap.error(str(err))
    print(f"{'retired' if args.action == 'retire' else 'amended'}: appended to {HISTORY}, "
          f"wrote {RESULTS}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
