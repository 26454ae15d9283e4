"""A hostile-input campaign against the ``jaxga`` command line (decision 033).

About a hundred inputs and faults a careless user or script produces, beyond the cases of
``tests/tools/test_faults.py``: broken or odd map files (empty, garbage, huge headers, ragged
rows, lying PGM/PNG headers, truncated images, unusual file names, a folder, /dev/zero, a
FIFO, symlink loops), ROS YAML files with NaN, negative or absurd values and images that
are missing, oversized or garbage, bad endpoints, bad options and preset files, outputs
that would destroy an input or cannot be written, scenarios of another map, replan inputs
that do not fit the map, unusable compilation caches and environment variables, and
SIGINT / SIGTERM at several moments (during import, compilation and evolution).

Each case runs ``python -m jaxga.cli ...`` in a fresh process (8 GiB address-space limit,
no core dumps), in a temporary folder whose files are compared before and after. Every
case declares what it expects; the outcome is classed automatically:

* ``refused``: exit 2 (4 for a lost process) and exactly one line from jaxga on stderr,
  ``jaxga: error: ...`` or ``jaxga: bad start or goal: ...`` (``jaxga: warning:`` lines
  and progress lines aside);
* ``no path``: exit 3 and one ``jaxga: no path: ...`` line;
* ``handled``: exit 0, nothing on stderr but jaxga's one-line warnings and progress, and
  the case's own check of the result passed (an output written and readable, a warning
  said, ...);
* ``interrupted``: exit 128 + n after the signal n the case sent (130 / 143 / 129 for
  SIGINT, SIGTERM, SIGHUP; SIGUSR1 too), within 10 s, with ``jaxga: interrupted`` /
  ``terminated`` / ``hung up`` / ``stopped by SIGUSR1`` last and no warning or error
  before it
  (progress and status lines are allowed);

and the defects: ``traceback`` (a Python traceback on stderr), ``crash`` (killed by
SIGSEGV, SIGABRT, ... or a fatal Python error), ``signal exit`` (ended by another signal
instead of exiting 130 / 143), ``hang`` (over the case's timeout), ``silent`` (exit 0 where
a refusal, or a warning, was expected), ``wrongly refused`` (refused where the input
should have worked), ``multi-line error`` (the right exit with more than jaxga's one line,
e.g. a JAX warning), ``foreign warning`` (exit 0 with a JAX, XLA or Python warning on
stderr instead of jaxga's one line; other lines, such as a scenario's description, are
allowed), ``damaged file`` (an input or a previous output changed, a file left
behind, an output written despite a refusal, a temporary file left in a cache),
``slow`` (a refusal that should come at once took longer than the case allows),
``slow interrupt``, ``wrong result`` (exit 0 but the case's check failed) and ``other
exit``.

All cases share one compilation cache in the temporary folder (compiled once by the first
case, ``baseline``), except the cache cases and the interrupts during compilation, which
have their own. Maps are small: the built-in ``classic_ga_gapp3_20x20`` and copies of it
in every format (``--corner-rule free``, so that they reuse its programs), files of at
most 32 x 32 cells, and a copy of ``benchmarks/maps/tb3_world`` for the ROS options.
Runs use ``--preset sga --seeds 2 --generations 5``.

Prints the table (case, group, expected, class, exit, seconds, first stderr line,
command with ``$T`` for the temporary folder) and the counts per class, and records them
in RESULTS.md.

    python benchmarks/fault_campaign.py [--quick] [--only NAME,...] [--no-write] [--keep]
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import re
import resource
import shlex
import shutil
import signal
import socket
import stat
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from _results import markdown_table, record

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
TB3 = HERE / "maps" / "tb3_world"
CLASSIC = "classic_ga_gapp3_20x20"
BASE = ["--preset", "sga", "--seeds", "2", "--generations", "5"]
QUIET = [*BASE, "--quiet"]
FREE = ["--corner-rule", "free"]  # a file copy of the classic map shares its programs
MEMORY_LIMIT = 8 << 30  # bytes of address space per case (JAX runs well within it)
INTERRUPT_S = 10.0  # a signal must end the process within this many seconds
WARNING_LIKE = re.compile(r"warn|error|exception|traceback|^\s|^[WEF]\d{4} ", re.IGNORECASE)
"""A stderr line of a successful run that is not jaxga's own: a JAX/XLA/Python warning."""

OK_CLASSES = ("refused", "no path", "handled", "interrupted")
DEFECTS = ("traceback", "crash", "signal exit", "hang", "silent", "wrongly refused",
           "multi-line error", "foreign warning", "damaged file", "slow", "slow interrupt",
           "wrong result", "other exit")

Check = Callable[["Outcome"], "str | None"]


@dataclasses.dataclass
class Case:
    """One hostile input: ``jaxga <argv>`` and what a correct program does with it."""

    name: str
    group: str
    argv: list[str]
    expect: tuple[str, ...] = ("refused",)
    env: dict[str, str | None] = dataclasses.field(default_factory=dict)
    outputs: tuple[Path, ...] = ()  # files (or folders) the case may create or replace
    writes_on_error: bool = False  # its outputs are written, then the error said (stdout)
    check: Check | None = None  # for an exit 0 or an interrupt: None = fine, else why not
    check_fails_as: str = "wrong result"
    signal: tuple[int, str | None, float, int] | None = None  # signum, stderr trigger
    # (None: time from start), delay after it, how many signals (0.05 s apart)
    timeout: float = 60.0
    max_s: float | None = None  # a refusal later than this is 'slow'
    stdout: str = "pipe"  # "pipe", "closed" (a pipe whose reader is gone), "full" (/dev/full)
    stdout_file: Path | None = None  # stdout appended to this file (`>> log`) instead
    closed_fds: tuple[int, ...] = ()  # descriptors closed in the child (`>&-`, `2>&-`)
    removes: tuple[Path, ...] = ()  # files the case must remove (a killed write's leftovers)
    caches: tuple[Path, ...] = ()  # this case's own caches, checked for temporaries after
    teardown: Callable[[], None] | None = None
    quick: bool = False
    note: str = ""


@dataclasses.dataclass
class Outcome:
    rc: int | None
    seconds: float
    stdout: str
    stderr: str
    signal_to_exit: float | None = None
    signalled: bool = False
    cls: str = ""
    why: str = ""

    @property
    def err_lines(self) -> list[str]:
        return [ln for ln in self.stderr.splitlines() if ln.strip()]


# --- files --------------------------------------------------------------------------


ONE_VALUE = ("--preset", "--seeds", "--generations")
"""The common options (:data:`BASE`) a case may give again with its own value."""


def last_given(argv: list[str]) -> list[str]:
    """``argv`` with each of :data:`ONE_VALUE` kept at its last place only: a case's own
    value replaces the common one, as argparse let it, but the command line now refuses
    an option of one value given twice."""
    out, seen, i = [], set(), len(argv) - 1
    while i >= 0:
        word, before = argv[i], argv[i - 1] if i > 0 else ""
        if before in ONE_VALUE:  # the value of an option: keep or drop the pair
            if before not in seen:
                seen.add(before)
                out[:0] = [before, word]
            i -= 2
            continue
        out.insert(0, word)
        i -= 1
    return out


def chunk(kind: bytes, data: bytes) -> bytes:
    """One PNG chunk: length, type, data, CRC."""
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def png(width: int, height: int, gray: bytes, *, header: tuple[int, int] | None = None,
        truncate: int | None = None) -> bytes:
    """An 8-bit grayscale PNG of ``gray`` (rows top first); ``header`` = the size the IHDR
    claims instead, ``truncate`` = keep only this many bytes."""
    w, h = header or (width, height)
    raw = b"".join(b"\0" + gray[y * width:(y + 1) * width] for y in range(height))
    out = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    return out[:truncate] if truncate else out


def alias_bomb(key: str, levels: int = 9) -> str:
    """A YAML 'billion laughs': ``key`` holds 9 ** levels strings through aliases (a few
    hundred bytes of text)."""
    lines = ['l0: &l0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, levels):
        lines.append(f"l{i}: &l{i} [" + ",".join([f"*l{i - 1}"] * 9) + "]")
    lines.append(f"{key}: *l{levels - 1}")
    return "\n".join(lines) + "\n"


def snapshot(root: Path) -> dict[str, tuple]:
    """Every file, folder and link under ``root``: type, and content hash / target / mode."""
    out: dict[str, tuple] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = os.path.join(dirpath, name)
            try:
                st = os.lstat(p)
            except OSError:
                continue
            if stat.S_ISREG(st.st_mode):
                try:
                    with open(p, "rb") as f:
                        digest = hashlib.sha256(f.read()).hexdigest()[:16]
                except OSError as e:
                    digest = f"unreadable {e.errno}"
                out[p] = ("file", st.st_size, digest, stat.S_IMODE(st.st_mode))
            elif stat.S_ISLNK(st.st_mode):
                out[p] = ("link", os.readlink(p))
            elif stat.S_ISDIR(st.st_mode):
                out[p] = ("dir",)
            elif stat.S_ISFIFO(st.st_mode):
                out[p] = ("fifo",)
            elif stat.S_ISCHR(st.st_mode):
                out[p] = ("char device", st.st_rdev)
            else:
                out[p] = ("other", stat.S_IFMT(st.st_mode))
    return out


def is_temporary(name: str) -> bool:
    return name.endswith(".tmp") or name.startswith(".jaxga-probe")


# --- running and classing -----------------------------------------------------------


def _limits() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def execute(case: Case, env: dict[str, str], cwd: Path) -> Outcome:
    """Run the case in a fresh process; send its signals; collect its output."""
    run_env = dict(env)
    for k, v in case.env.items():
        if v is None:
            run_env.pop(k, None)
        else:
            run_env[k] = v
    stdout_arg: int | object = subprocess.PIPE
    to_close = []
    if case.stdout == "closed":
        r, w = os.pipe()
        os.close(r)
        stdout_arg = w
        to_close.append(w)
    elif case.stdout == "full":
        fh = open("/dev/full", "wb")  # noqa: SIM115 - closed below
        stdout_arg = fh
        to_close.append(fh)
    if case.stdout_file is not None:
        fh = open(case.stdout_file, "ab")  # noqa: SIM115 - closed below
        stdout_arg = fh
        to_close.append(fh)
    t0 = time.monotonic()
    def child_setup() -> None:
        _limits()
        for fd in case.closed_fds:
            os.close(fd)

    proc = subprocess.Popen([sys.executable, "-m", "jaxga.cli", *case.argv], cwd=cwd,
                            env=run_env, stdin=subprocess.DEVNULL, stdout=stdout_arg,
                            stderr=subprocess.PIPE, preexec_fn=child_setup)
    for c in to_close:
        if isinstance(c, int):
            os.close(c)
        else:
            c.close()
    err_lines: list[str] = []
    out_chunks: list[bytes] = []

    def read_err() -> None:
        for raw in iter(proc.stderr.readline, b""):
            err_lines.append(raw.decode("utf-8", "replace"))

    def read_out() -> None:
        out_chunks.append(proc.stdout.read())

    readers = [threading.Thread(target=read_err, daemon=True)]
    if proc.stdout is not None:
        readers.append(threading.Thread(target=read_out, daemon=True))
    for t in readers:
        t.start()
    deadline = t0 + case.timeout
    sent_at = None
    if case.signal is not None:
        signum, trigger, delay, times = case.signal
        seen = trigger is None
        while proc.poll() is None and time.monotonic() < deadline:
            if not seen:
                seen = any(trigger in ln for ln in list(err_lines))
                if seen:
                    time.sleep(delay)
            elif time.monotonic() - t0 >= (delay if trigger is None else 0):
                break
            time.sleep(0.02)
        if proc.poll() is None and seen and time.monotonic() < deadline:
            sent_at = time.monotonic()
            for i in range(times):
                if i:
                    time.sleep(0.05)
                proc.send_signal(signum)
    try:
        proc.wait(timeout=max(deadline - time.monotonic(), 0.1))
        rc: int | None = proc.returncode
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        rc = None
    end = time.monotonic()
    for t in readers:
        t.join(timeout=5)
    return Outcome(rc=rc, seconds=end - t0,
                   stdout=b"".join(out_chunks).decode("utf-8", "replace"),
                   stderr="".join(err_lines),
                   signal_to_exit=None if sent_at is None else end - sent_at,
                   signalled=sent_at is not None)


SIGNAL_EXITS = {128 + signum: f"jaxga: {words}" for signum, words in (
    (signal.SIGINT, "interrupted"), (signal.SIGTERM, "terminated"), (signal.SIGHUP, "hung up"),
    (signal.SIGUSR1, "stopped by SIGUSR1"), (signal.SIGUSR2, "stopped by SIGUSR2"),
    (signal.SIGXCPU, "CPU time limit reached"))}
"""The exit status of each signal jaxga ends on (128 + its number) and its last line."""


def _jaxga_line(line: str) -> bool:
    return line.startswith("progress:") or line.startswith("jaxga: warning:")


def classify(case: Case, out: Outcome, damage: list[str]) -> tuple[str, str]:
    """(class, a few words why) of an outcome."""
    err = out.err_lines
    if out.rc is None:
        return "hang", f"no exit within {case.timeout:.0f} s"
    if "Fatal Python error" in out.stderr:
        return "crash", "fatal Python error"
    if out.rc < 0:
        try:
            name = signal.Signals(-out.rc).name
        except ValueError:
            name = f"signal {-out.rc}"
        if -out.rc in (signal.SIGSEGV, signal.SIGABRT, signal.SIGBUS, signal.SIGFPE,
                       signal.SIGILL, signal.SIGKILL):
            return "crash", f"killed by {name}"
        if "Traceback (most recent call last)" in out.stderr:
            return "traceback", f"traceback, then killed by {name}"
        return "signal exit", f"ended by {name}, not exit {128 - out.rc}"
    if "Traceback (most recent call last)" in out.stderr:
        exc = [ln for ln in err if re.match(r"\w+(Error|Exception|Interrupt)\b", ln)]
        return "traceback", f"{(exc or err)[-1][:120]}; exit {out.rc}"
    if damage:
        return "damaged file", "; ".join(damage)[:300]
    others = [ln for ln in err if not _jaxga_line(ln)]
    if out.rc in SIGNAL_EXITS:
        if not out.signalled:
            return "other exit", f"exit {out.rc} without a signal"
        words = SIGNAL_EXITS[out.rc]
        if not err or err[-1].strip() != words:
            return "multi-line error", f"last line is not {words!r}"
        noisy = [ln for ln in others[:-1] if WARNING_LIKE.search(ln)]
        if noisy:
            return "multi-line error", f"{len(noisy)} warning-like line(s) before it"
        if out.signal_to_exit is not None and out.signal_to_exit > INTERRUPT_S:
            return "slow interrupt", f"exit {out.signal_to_exit:.1f} s after the signal"
        problem = case.check(out) if case.check else None
        if problem:
            return case.check_fails_as, problem
        cls = "interrupted"
    elif out.rc in (2, 4, 3):
        prefixes = (("jaxga: no path:",) if out.rc == 3
                    else ("jaxga: error:", "jaxga: bad start or goal:"))
        if len(others) != 1 or not others[0].startswith(prefixes):
            return "multi-line error", f"{len(others)} lines besides warnings and progress"
        cls = "no path" if out.rc == 3 else "refused"
        problem = case.check(out) if cls == "no path" and case.check else None
        if problem:  # what a no-path run leaves (its outputs) is checked too
            return case.check_fails_as, problem
        if cls == "refused" and case.max_s is not None and out.seconds > case.max_s:
            return "slow", f"refused after {out.seconds:.1f} s (> {case.max_s:.0f} s)"
    elif out.rc == 0:
        noisy = [ln for ln in others if WARNING_LIKE.search(ln)]
        if noisy:
            return "foreign warning", f"exit 0 with {len(noisy)} warning-like line(s)"
        if "handled" not in case.expect:
            return "silent", "exit 0"
        problem = case.check(out) if case.check else None
        if problem:
            return case.check_fails_as, problem
        cls = "handled"
    else:
        return "other exit", f"exit {out.rc}"
    if cls in case.expect:
        return cls, ""
    if cls == "refused" and "handled" in case.expect:
        return "wrongly refused", "expected to work"
    if cls == "interrupted" or case.signal is not None:
        return "other exit", f"{cls}, expected {' or '.join(case.expect)}"
    return "wrong result", f"{cls}, expected {' or '.join(case.expect)}"


def damage_of(case: Case, before: dict, after: dict, cls_hint: int | None) -> list[str]:
    """What changed under the files folder that the case had no right to change."""
    allowed = {str(p) for p in case.outputs}
    # a refusal writes nothing (unless its error is the output it could not show); no
    # path does
    may_write = cls_hint in (0, 3, *SIGNAL_EXITS) or case.writes_on_error

    def permitted(p: str) -> bool:
        if is_temporary(os.path.basename(p)):
            return False
        return may_write and any(p == a or p.startswith(a + os.sep) for a in allowed)

    out = []
    removes = {str(p) for p in case.removes}
    for p in removes:
        if p in after:
            out.append(f"left {p} (a killed write's file the next write removes)")
    for p, v in before.items():
        if p in removes:
            continue
        if p not in after:
            out.append(f"removed {p}")
        elif after[p] != v and not permitted(p):
            out.append(f"changed {p} ({v[0]} -> {after[p][0]})")
    for p in after:
        if p not in before and not permitted(p):
            out.append(f"left {p}")
    for cache in case.caches:
        if cache.is_dir():
            for dirpath, _, filenames in os.walk(cache):
                out += [f"left {dirpath}/{n}" for n in filenames if is_temporary(n)]
    return out


# --- checks ---------------------------------------------------------------------------


def wrote_json(path: Path, key: str = "runs") -> Check:
    def check(out: Outcome) -> str | None:
        try:
            doc = json.loads(path.read_text())
        except (OSError, ValueError) as e:
            return f"{path.name} not written or not JSON ({type(e).__name__})"
        return None if key in doc else f"{path.name} has no {key!r}"
    return check


def said(text: str) -> Check:
    def check(out: Outcome) -> str | None:
        return None if text in out.stdout else f"stdout lacks {text!r}"
    return check


def warned(text: str) -> Check:
    """Exactly one ``jaxga: warning:`` line, naming ``text``."""
    def check(out: Outcome) -> str | None:
        lines = [ln for ln in out.err_lines if ln.startswith("jaxga: warning:")]
        if len(lines) != 1 or text not in lines[0]:
            return f"expected one warning naming {text!r}, got {len(lines)}"
        return None
    return check


def refused_saying(text: str) -> Check:
    """Its one ``jaxga:`` line on stderr names ``text``."""
    def check(out: Outcome) -> str | None:
        lines = [ln for ln in out.err_lines if ln.startswith("jaxga:")]
        return None if lines and text in lines[-1] else f"the refusal does not name {text!r}"
    return check


def distinct_rows(path: Path) -> Check:
    """``path`` (a CSV path file) holds no two equal consecutive points."""
    def check(out: Outcome) -> str | None:
        try:
            rows = path.read_text().splitlines()[1:]
        except OSError as e:
            return f"{path.name} not written ({type(e).__name__})"
        same = sum(a == b for a, b in zip(rows, rows[1:]))
        return f"{same} consecutive points written alike" if same or not rows else None
    return check


def lines_under(width: int) -> Check:
    """Every line on stderr shorter than ``width`` characters."""
    def check(out: Outcome) -> str | None:
        longest = max((len(ln) for ln in out.err_lines), default=0)
        return None if longest < width else f"a stderr line of {longest} characters"
    return check


def at_most_one_warning(out: Outcome) -> str | None:
    n = sum(ln.startswith("jaxga: warning:") for ln in out.err_lines)
    return None if n <= 1 else f"{n} warning lines"


def all_of(*checks: Check) -> Check:
    def check(out: Outcome) -> str | None:
        return next((p for c in checks if (p := c(out))), None)
    return check


def free_path(path: Path, blocked) -> Check:
    """``path`` holds a JSON ``"path"`` of cells, all free on ``blocked[y, x]``."""
    def check(out: Outcome) -> str | None:
        try:
            cells = json.loads(path.read_text())["path"]
        except (OSError, ValueError, KeyError) as e:
            return f"{path.name} not written or without a path ({type(e).__name__})"
        bad = [c for c in cells if blocked[c[1], c[0]]]
        return f"the new path crosses blocked cells {bad[:3]}" if bad else None
    return check


def runs_free(path: Path, blocked) -> Check:
    """``path`` holds a run's JSON whose every successful seed's path crosses only free
    cells of ``blocked[y, x]``, and at least one seed succeeded."""
    def check(out: Outcome) -> str | None:
        try:
            runs = json.loads(path.read_text())["runs"]
        except (OSError, ValueError, KeyError) as e:
            return f"{path.name} not written or without runs ({type(e).__name__})"
        paths = [r["path"] for r in runs if r.get("success")]
        bad = [c for p in paths for c in p if blocked[c[1], c[0]]]
        if not paths:
            return "no seed found a path"
        return f"a path crosses blocked cells {bad[:3]}" if bad else None
    return check


def empty_path_file(path: Path) -> Check:
    """``path`` is a CSV path file holding its header alone (no path)."""
    def check(out: Outcome) -> str | None:
        text = path.read_text() if path.exists() else None
        return None if text == "x,y\n" else f"{path.name} holds {text!r}, not an empty path"
    return check


def link_kept(link: Path, target: Path) -> Check:
    def check(out: Outcome) -> str | None:
        if not link.is_symlink():
            return f"{link.name} is no longer a symlink (replaced by a regular file)"
        return wrote_json(target)(out)
    return check


def still_char_device(path: Path) -> Check:
    def check(out: Outcome) -> str | None:
        st = os.lstat(path)
        return None if stat.S_ISCHR(st.st_mode) else f"{path.name} replaced by a regular file"
    return check


# --- the cases ------------------------------------------------------------------------


def build(t: Path) -> list[Case]:
    """Write the hostile inputs under ``t/files`` and return the cases."""
    import numpy as np

    from jaxga.maps import load_map, load_map_info, save_map

    f = t / "files"
    f.mkdir()
    caches = t / "caches"
    caches.mkdir()
    cases: list[Case] = []

    def add(name, group, argv, expect="refused", *, repeats=False, **kw) -> Case:
        kw.setdefault("timeout", 120.0 if "handled" in expect or "signal" in kw else 60.0)
        argv = [str(a) for a in argv]
        if not repeats:  # a case's own --seeds, ... replaces the common one (given once)
            argv = last_given(argv)
        c = Case(name, group, argv,
                 (expect,) if isinstance(expect, str) else tuple(expect), **kw)
        cases.append(c)
        return c

    def run(map_, *extra):
        return ["run", "--map", map_, *QUIET, *extra]

    def write(name: str, data: str | bytes) -> Path:
        p = f / name
        raw = data.encode("utf-8") if isinstance(data, str) else data
        if p.exists() and p.read_bytes() != raw:  # it would replace another case's input
            raise ValueError(f"two cases write {name} differently: give each its own name")
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(raw)
        return p

    # the classic map, as text, image and PGM; a blocked cell of it
    grid = load_map(CLASSIC)
    blocked = grid.blocked_np()
    h, w = blocked.shape
    classic = f / "classic.txt"
    save_map(grid, classic)
    by, bx = map(int, np.argwhere(blocked)[0])
    gray_top = bytes((0 if b else 255) for b in blocked[::-1].ravel())
    classic_png = write("classic.png", png(w, h, gray_top))
    base_json = f / "base.json"
    previous = write("previous.json", '{"previous": true}\n')

    # baseline: compiles the shared cache; a file copy of the map must reuse it
    add("baseline", "control", ["run", "--map", CLASSIC, *QUIET, "--json", base_json],
        "handled", outputs=(base_json,), check=wrote_json(base_json), timeout=300,
        quick=True, note="compiles the shared cache")
    out = f / "copy.json"
    add("classic-file-copy", "control", run(classic, *FREE, "--json", out), "handled",
        outputs=(out,), check=wrote_json(out))

    # --- map files -------------------------------------------------------------------
    add("empty-file", "map", run(write("empty.txt", b"")), quick=True)
    add("only-whitespace", "map", run(write("blank.txt", "\n  \n\t\n")))
    add("binary-garbage", "map", run(write("garbage.map", os.urandom(4096))))
    add("nul-bytes-in-text", "map", run(write("nul.txt", "0 0 0\n0 \0 0\n0 0 0\n")))
    add("utf16-text-map", "map",
        run(write("utf16.txt", classic.read_text().encode("utf-16")), *FREE),
        ("refused", "handled"), check=said("success"))
    add("crlf-text-map", "map",
        run(write("crlf.txt", classic.read_text().replace("\n", "\r\n")), *FREE),
        "handled", check=said("success"), note="a Windows copy of a valid map")
    add("ragged-rows", "map", run(write("ragged.txt", "0 0 0 0\n0 0\n0 0 0 0 0 0\n")))
    add("movingai-huge-header", "map", run(write(
        "huge.map", "type octile\nheight 1000000000\nwidth 1000000000\nmap\n....\n")),
        max_s=15)
    add("movingai-negative-height", "map", run(write(
        "neg.map", "type octile\nheight -4\nwidth 4\nmap\n....\n....\n")))
    add("movingai-header-lies", "map", run(write(
        "lies.map", "type octile\nheight 3\nwidth 3\nmap\n.....\n.....\n.....\n")))
    add("movingai-not-octile", "map", run(write(
        "hex.map", "type hexagonal\nheight 2\nwidth 2\nmap\n..\n..\n")), ("refused", "handled"))
    add("ascii-two-starts", "map", run(write("two_s.txt", "S..\n.#.\nS.G\n")))
    add("ascii-emoji-cells", "map", run(write("emoji.txt", "S..\n.🧱.\n..G\n")))
    add("all-blocked", "map", run(write("blocked.txt", ("1 " * 20 + "\n") * 20)))
    walled = np.zeros((20, 20), int)
    walled[10, :] = 1
    add("wall-between-endpoints", "map",
        run(write("walled.txt", "\n".join(" ".join(map(str, r)) for r in walled) + "\n")),
        "no path")
    add("one-row-over-size-limit", "map", run(write("long.txt", "0" * 300_000 + "\n")),
        max_s=15)
    add("pgm-header-lies", "map", run(write("lies.pgm", b"P5\n10 10\n255\n" + bytes(400))))
    add("pgm-huge-header", "map", run(write("huge.pgm", b"P5\n100000 100000\n255\n"
                                            + bytes(100))), max_s=15)
    add("pgm-maxval-zero", "map", run(write("max0.pgm", b"P5\n4 4\n0\n" + bytes(16))))
    add("pgm-negative-width", "map", run(write("negw.pgm", b"P5\n-4 4\n255\n" + bytes(16))))
    add("pgm-ascii-over-maxval", "map",
        run(write("p2.pgm", "P2\n3 3\n255\n255 900 255\n255 255 255\n255 255 255\n")))
    comment_pgm = write("comments.pgm", b"P5\n# made by hand\n%d %d\n# max\n255\n" % (w, h)
                        + gray_top)
    add("pgm-header-comments", "map", run(comment_pgm, *FREE), "handled",
        check=said("success"), note="comments are legal in a PGM header")
    add("png-truncated", "map", run(write("trunc.png", png(w, h, gray_top, truncate=80))),
        quick=True)
    add("png-zero-bytes", "map", run(write("zero.png", b"")))
    add("png-garbage-after-signature", "map",
        run(write("junk.png", b"\x89PNG\r\n\x1a\n" + os.urandom(500))))
    add("png-huge-ihdr", "map", run(write("bomb.png", png(w, h, gray_top,
                                                          header=(100_000, 100_000)))),
        max_s=15)
    add("png-ihdr-lies", "map", run(write("ihdr.png", png(w, h, gray_top, header=(300, 300)))))
    add("png-threshold-nan", "map", run(classic_png, "--threshold", "nan"))
    add("png-threshold-above-1", "map", run(classic_png, "--threshold", "7"))
    add("png-unknown-free", "map", run(classic_png, "--unknown", "free"))
    add("directory-as-map", "map", run(f))
    add("dev-zero", "map", run("/dev/zero"), max_s=15, quick=True)
    fifo = f / "pipe.map"
    os.mkfifo(fifo)
    add("fifo-as-map", "map", run(fifo), max_s=15, timeout=30)
    (f / "loop-a.map").symlink_to(f / "loop-b.map")
    (f / "loop-b.map").symlink_to(f / "loop-a.map")
    add("symlink-loop", "map", run(f / "loop-a.map"))
    (f / "dangling.map").symlink_to(f / "gone.map")
    add("dangling-symlink", "map", run(f / "dangling.map"))
    add("unknown-builtin-name", "map", run("classic_ga_gapp3_20x21"))
    unicode = f / "карта 地图 🗺.txt"
    shutil.copy(classic, unicode)
    add("unicode-file-name", "map", run(unicode, *FREE), "handled", check=said("success"))
    add("unicode-name-ascii-locale", "map", run(unicode, *FREE), ("handled", "refused"),
        env={"LC_ALL": "C", "LANG": "C", "PYTHONIOENCODING": "ascii"},
        check=said("success"), note="the name cannot be printed in the locale")
    newline = f / "two\nlines.txt"
    shutil.copy(classic, newline)
    add("newline-in-file-name", "map", run(newline, *FREE), ("handled", "refused"),
        check=said("success"))
    dash = f / "-dash.txt"
    shutil.copy(classic, dash)
    add("dash-file-name", "map", ["run", "--map=-dash.txt", *QUIET, *FREE], "handled",
        check=said("success"), note="--map=-dash.txt, relative to the working folder")

    # --- ROS map_server YAML -------------------------------------------------------------
    room = write("room.pgm", b"P5\n%d %d\n255\n" % (w, h)
                 + bytes((0 if b else 254) for b in blocked[::-1].ravel()))
    good = f"image: {room.name}\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"

    def ros(name, text, *extra, **kw):
        add(name, "ros", run(write(f"{name}.yaml", text), *extra), **kw)

    ros("ros-resolution-nan", good.replace("0.05", ".nan"))
    ros("ros-origin-inf", good.replace("[0.0, 0.0, 0.0]", "[.inf, 0.0, 0.0]"))
    ros("ros-resolution-negative", good.replace("0.05", "-0.05"))
    ros("ros-resolution-zero", good.replace("0.05", "0"))
    ros("ros-resolution-string", good.replace("0.05", '"fine"'))
    ros("ros-resolution-exponent", good.replace("0.05", "5e-2"), *FREE, expect="handled",
        check=said("success"), note="yaml-cpp (map_server) reads 5e-2 as a number")
    ros("ros-resolution-tiny", good.replace("0.05", "1.0e-300"), "--start-world", "1,1",
        "--goal-world", "0,0", note="a metre is 1e300 cells")
    ros("ros-origin-huge", good.replace("[0.0, 0.0, 0.0]", "[1.0e+308, 1.0e+308, 0.0]"),
        "--start-world", "0,0", "--goal-world", "1,1")
    ros("ros-image-missing", good.replace(room.name, "nowhere.pgm"))
    ros("ros-image-garbage", good.replace(room.name, write("junk.pgm",
                                                           os.urandom(900)).name))
    ros("ros-image-oversized", good.replace(room.name, write(
        "big.pgm", b"P5\n60000 60000\n255\n" + bytes(64)).name), max_s=15)
    ros("ros-image-is-the-yaml", good.replace(room.name, "ros-image-is-the-yaml.yaml"))
    ros("ros-image-is-a-folder", good.replace(room.name, "."))
    ros("ros-image-dev-zero", good.replace(room.name, "/dev/zero"), max_s=15)
    ros("ros-image-zero-bytes", good.replace(room.name, write("empty.pgm", b"").name))
    ros("ros-yaml-syntax-error", "image: [room.pgm\nresolution: 0.05\n")
    ros("ros-yaml-a-list", "- image\n- resolution\n")
    ros("ros-thresholds-swapped", good + "occupied_thresh: 0.1\nfree_thresh: 0.9\n")
    ros("ros-mode-unknown", good + "mode: bogus\n")
    ros("ros-negate-maybe", good + "negate: maybe\n")
    ros("ros-python-tag", good + "evil: !!python/object/apply:os.system ['true']\n")
    ros("ros-alias-bomb-origin", alias_bomb("origin") + good.replace(
        "origin: [0.0, 0.0, 0.0]\n", ""), max_s=15, timeout=20,
        note="origin = 9^9 strings by YAML aliases")
    ros("ros-alias-bomb-image", alias_bomb("image") + good.replace(
        f"image: {room.name}\n", ""), max_s=15, timeout=20)
    ros("ros-threshold-option", good, "--threshold", "0.3",
        note="--threshold has no effect on a ROS map")
    # a copy of tb3_world (384 x 384, 0.05 m): options that need a resolution
    tb3 = f / "tb3"
    shutil.copytree(TB3, tb3)
    tb3_yaml = tb3 / "map.yaml"
    info = load_map_info(tb3_yaml)
    free = np.argwhere(~info.grid.blocked_np())
    (y0, x0), (y1, x1) = free[len(free) // 3], free[2 * len(free) // 3]
    ends = ["--start", f"{x0},{y0}", "--goal", f"{x1},{y1}"]
    add("world-start-off-map", "endpoints", run(tb3_yaml, "--start-world", "1e9,1e9",
                                                "--goal-world", "0,0"))
    add("world-start-nan", "endpoints", run(tb3_yaml, "--start-world", "nan,0",
                                            "--goal-world", "0,0"))
    add("robot-radius-negative", "options", run(tb3_yaml, *ends, "--robot-radius", "-0.5"))
    add("robot-radius-huge", "options", run(tb3_yaml, *ends, "--robot-radius", "1e6"))
    add("path-out-wrong-extension", "outputs", run(tb3_yaml, *ends, "--path-out",
                                                   f / "path.txt"))
    add("path-out-is-the-yaml", "outputs", run(tb3_yaml, *ends, "--path-out", tb3_yaml))
    add("plot-is-the-map-image", "outputs", run(tb3_yaml, *ends, "--plot", tb3 / "map.pgm"))
    add("json-and-path-out-same", "outputs", run(tb3_yaml, *ends, "--json", f / "same.yaml",
                                                 "--path-out", f / "same.yaml"))

    # --- endpoints on the classic map ---------------------------------------------------
    def ends_case(name, *extra, expect="refused", **kw):
        add(name, "endpoints", ["run", "--map", CLASSIC, *QUIET, *extra], expect, **kw)

    ends_case("start-outside", "--start", "25,3")
    ends_case("start-negative", "--start", "-1,0")
    ends_case("goal-blocked", "--goal", f"{bx},{by}")
    ends_case("start-nan", "--start", "nan,nan", quick=True)
    ends_case("start-inf", "--start", "inf,0")
    ends_case("start-huge", "--start", "1e30,1")
    ends_case("start-letters", "--start", "a,b")
    ends_case("start-three-numbers", "--start", "1,2,3")
    ends_case("start-empty", "--start", "")
    ends_case("start-equals-goal", "--start", "19,19", expect=("refused", "handled"),
              check=said("success"))
    ends_case("start-fraction", "--start", "0.5,0.5", expect=("refused", "handled"),
              check=said("success"))
    ends_case("start-arabic-digits", "--start", "٠,٠", expect=("refused", "handled"),
              check=said("success"), note="int() reads Unicode digits")
    ends_case("world-on-map-without-resolution", "--start-world", "1,1", "--goal-world",
              "2,2")

    # --- options ------------------------------------------------------------------------
    def opt(name, *extra, expect="refused", map_=CLASSIC, **kw):
        add(name, "options", ["run", "--map", map_, *QUIET, *extra], expect, **kw)

    opt("seeds-negative", "--seeds", "-3")
    opt("seeds-float", "--seeds", "2.5")
    opt("seeds-absurd", "--seeds", "1000000000000", note="would need terabytes")
    opt("generations-negative", "--generations", "-5")
    opt("coarsen-zero", "--coarsen", "0")
    opt("coarsen-negative", "--coarsen", "-2")
    opt("coarsen-absurd", "--coarsen", "1000000")
    opt("coarsen-fraction", "--coarsen", "2.5")
    opt("coarsen-merges-endpoints", "--coarsen", "20", quick=True)
    opt("inflate-negative", "--inflate", "-1")
    opt("inflate-huge", "--inflate", "1e9")
    opt("inflate-nan", "--inflate", "nan")
    opt("robot-radius-no-resolution", "--robot-radius", "0.2")
    opt("unknown-preset", "--preset", "sgaa")
    opt("corner-rule-unknown", "--corner-rule", "diagonal")
    opt("variant-unknown", "--variant", "50x50x50")
    opt("set-no-equals", "--set", "garbage")
    opt("set-unknown-key", "--set", "nosuch.key=1")
    opt("set-nan-probability", "--set", "crossover.probability=nan")
    opt("set-probability-two", "--set", "crossover.probability=2")
    opt("set-unknown-method", "--set", "mutation.method=teleport")
    opt("set-population-zero", "--set", "population.size=0")
    opt("set-population-absurd", "--set", "population.size=1e12")
    opt("set-wrong-type", "--set", "population.size=[1,2]")
    opt("population-capacity-zero", "--population-capacity", "0")
    opt("devices-zero", "--devices", "0")
    opt("process-id-out-of-range", "--coordinator", "127.0.0.1:1", "--num-processes", "2",
        "--process-id", "5")
    opt("process-timeout-nan", "--coordinator", "127.0.0.1:1", "--num-processes", "2",
        "--process-id", "1", "--process-timeout", "nan", timeout=40)
    opt("threshold-on-text-map", "--threshold", "0.5")

    def preset_file(name, text, **kw):
        p = write(f"{name}.toml", text)
        add(name, "presets", run(CLASSIC, "--preset", p), **kw)

    preset_file("preset-wrong-type", 'base = "sga"\ngenerations = "many"\n')
    preset_file("preset-unknown-key", 'base = "sga"\n[population]\nsizee = 60\n')
    preset_file("preset-syntax-error", 'base = "sga\n[population\n')
    preset_file("preset-missing-base", 'base = "nosuch"\n')
    preset_file("preset-huge-int", 'base = "sga"\ngenerations = 99999999999999999999999\n')
    preset_file("preset-binary", os.urandom(300).decode("latin-1"))
    chain = f / "chain"
    chain.mkdir()
    for i in range(1500):
        (chain / f"p{i}.toml").write_text(f'base = "p{i + 1}.toml"\n' if i < 1499
                                          else 'base = "sga"\n')
    add("preset-base-chain-1500", "presets", run(CLASSIC, "--preset", chain / "p0.toml"),
        ("refused", "handled"), check=said("success"), note="1500 files, each the base of the last")
    add("preset-is-a-folder", "presets", run(CLASSIC, "--preset", chain))

    # --- outputs ------------------------------------------------------------------------
    def out_case(name, *extra, expect="refused", map_=CLASSIC, **kw):
        add(name, "outputs", ["run", "--map", map_, *QUIET, *extra], expect, **kw)

    map_copy = write("victim.txt", classic.read_text())
    out_case("json-is-the-map", "--json", map_copy, *FREE, map_=map_copy, quick=True)
    (f / "victim-link.json").symlink_to(map_copy)
    out_case("json-symlink-to-map", "--json", f / "victim-link.json", *FREE, map_=map_copy)
    out_case("json-equals-plot", "--json", f / "both.png", "--plot", f / "both.png")
    out_case("json-in-missing-folder", "--json", f / "missing" / "x.json",
             expect=("refused", "handled"), outputs=(f / "missing",),
             check=wrote_json(f / "missing" / "x.json"))
    (f / "outdir").mkdir()
    out_case("json-is-a-folder", "--json", f / "outdir")
    out_case("json-empty-name", "--json", "")
    out_case("json-dash", "--json", "-", expect=("refused", "handled"), outputs=(f / "-",),
             note="'-' for stdout, or a file named '-'")
    out_case("plot-into-proc", "--plot", "/proc/x.png", "--json", previous)
    out_case("json-proc-file", "--json", "/proc/version")
    ro = write("readonly.json", '{"keep": true}\n')
    ro.chmod(0o444)
    immutable = subprocess.run(["chattr", "+i", str(ro)], capture_output=True).returncode == 0
    out_case("json-read-only-file", "--json", ro,
             teardown=(lambda: subprocess.run(["chattr", "-i", str(ro)])) if immutable
             else None, note="mode 444" + (" and chattr +i" if immutable else ""))
    out_case("path-out-without-resolution", "--path-out", f / "p.csv")
    target = write("target.json", "{}\n")
    (f / "link.json").symlink_to(target)
    out_case("json-through-symlink", "--json", f / "link.json", expect="handled",
             outputs=(target, f / "link.json"), check_fails_as="damaged file",
             check=link_kept(f / "link.json", target),
             note="the link is expected to stay a link")
    nul = f / "null-device"
    try:
        os.mknod(nul, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except OSError:
        nul = None
    if nul is not None:
        out_case("json-to-a-null-device", "--json", nul, expect=("handled", "refused"),
                 check=still_char_device(nul), check_fails_as="damaged file",
                 outputs=(nul,), note="a copy of /dev/null; it must stay a device")
    out_case("plot-no-extension", "--plot", f / "plotfile", expect=("handled", "refused"),
             outputs=(f / "plotfile", f / "plotfile.png"), check=said("success"))

    # --- scenarios ----------------------------------------------------------------------
    scen_map = f / "classic.scen"
    scen_map.write_text("version 1\n0\tclassic.txt\t20\t20\t0\t19\t19\t0\t30.97056274\n")
    other = write("other.scen", "version 1\n0\tother-20x20.map\t20\t20\t0\t19\t19\t0\t30.97\n")

    def scen(name, *extra, expect="refused", **kw):
        add(name, "scenarios", run(classic, *FREE, *extra), expect, **kw)

    scen("scen-of-another-map", "--scen", other, "--scenario", "0", quick=True)
    scen("scenario-out-of-range", "--scen", scen_map, "--scenario", "99999")
    scen("scenario-negative", "--scen", scen_map, "--scenario", "-1")
    scen("scen-garbage", "--scen", write("garbage.scen", os.urandom(700)), "--scenario", "0")
    scen("scen-nan-optimum", "--scen", write(
        "nan.scen", "version 1\n0\tclassic.txt\t20\t20\t0\t19\t19\t0\tnan\n"), "--scenario", "0")
    scen("scen-without-scenario", "--scen", scen_map, note="--scen alone has no effect")
    add("scenario-on-map-without-scen", "scenarios",
        run(write("noscen.txt", classic.read_text()), *FREE, "--scenario", "0"))
    scen("json-is-the-scen", "--scen", scen_map, "--scenario", "0", "--json", scen_map)
    bom = write("bom.scen", "\ufeffversion 1\r\n0\tclassic.txt\t20\t20\t0\t19\t19\t0\t"
                "30.97056274\r\n")
    scen("scen-bom-crlf", "--scen", bom, "--scenario", "0", expect="handled",
         check=said("success"), note="a Windows-edited scenario file")

    # --- replan -------------------------------------------------------------------------
    def replan(name, path_json, *extra, expect="refused", **kw):
        add(name, "replan", ["replan", "--map", CLASSIC, "--path-json", path_json,
                             "--preset", "sga", "--seeds", "2", "--generations", "5",
                             *extra], expect, **kw)

    obstacle = ["--obstacles", "0,5", "--position", "0,0"]
    replan("path-json-not-json", write("notjson.json", "this is not JSON"), *obstacle,
           quick=True)
    replan("path-json-strings", write("strings.json", '[["a", "b"], ["c", "d"]]'), *obstacle)
    replan("path-json-empty-list", write("emptylist.json", "[]"), *obstacle)
    replan("path-json-deep-nesting", write("deep.json", "[" * 100_000 + "]" * 100_000),
           *obstacle)
    replan("path-json-overflow", write("overflow.json", "[[1e400, 0], [1, 1]]"), *obstacle)
    replan("path-json-nan", write("nan.json", "[[NaN, 0], [1, 1]]"), *obstacle)
    row = next(y for y in range(6, h) if blocked[y].any())  # a row with walls across it
    through = ([[0, y] for y in range(row)] + [[x, row] for x in range(w)]
               + [[w - 1, y] for y in range(row + 1, h)])
    walls = [p for p in through if blocked[p[1], p[0]]]
    assert walls, "the path must cross a wall"
    walls_out = f / "walls-replanned.json"
    replan("path-through-walls", write("walls.json", json.dumps(through)), *obstacle,
           "--json", walls_out, expect=("refused", "handled"), outputs=(walls_out,),
           check=free_path(walls_out, blocked),
           note=f"{len(walls)} of its cells are blocked: refused, or repaired into a free path")
    replan("path-json-fifo", fifo, *obstacle, timeout=30, max_s=15)
    replan("obstacles-off-map", base_json, "--obstacles", "100,100", "--position", "0,0")
    replan("obstacles-nan", base_json, "--obstacles", "nan,nan", "--position", "0,0")
    replan("position-off-path", base_json, "--obstacles", "0,5", "--position", "19,0")
    replan("run-index-out-of-range", base_json, *obstacle, "--run", "99")
    replan("window-zero", base_json, *obstacle, "--window", "0")
    replan("obstacle-on-goal", base_json, "--obstacles", "19,19", "--position", "0,0",
           expect=("refused", "no path"))
    replan("replan-json-is-path-json", base_json, *obstacle, "--json", base_json)

    # --- environment --------------------------------------------------------------------
    def env_case(name, env, *extra, expect="refused", argv=None, **kw):
        add(name, "environment", argv or ["run", "--map", CLASSIC, *QUIET, *extra], expect,
            env=env, **kw)

    a_file = write("cache-file", "not a folder\n")
    # an unusable cache: one warning line, then the run goes on (compiling: stopped there)
    stop_at_compile = (signal.SIGINT, "progress: compile", 0.2, 1)
    for name, cache_dir, extra in (
            ("cache-dir-is-a-file", str(a_file), {}),
            ("cache-dir-in-proc", "/proc/jaxga-cache", {}),
            ("cache-under-unwritable-home", None, {"HOME": "/proc/nohome"})):
        env = {"JAXGA_CACHE_DIR": cache_dir, **extra}
        shown = cache_dir or "/proc/nohome"
        env_case(name, env, argv=["run", "--map", CLASSIC, *BASE], expect="interrupted",
                 signal=stop_at_compile, check=warned(shown), check_fails_as="silent",
                 quick=name == "cache-dir-is-a-file",
                 note="one warning expected; stopped once compiling")
    frozen = caches / "immutable"
    frozen.mkdir()
    if subprocess.run(["chattr", "+i", str(frozen)], capture_output=True).returncode == 0:
        env_case("cache-dir-immutable", {"JAXGA_CACHE_DIR": str(frozen)},
                 argv=["run", "--map", CLASSIC, *BASE], expect="interrupted",
                 signal=stop_at_compile, check=warned(str(frozen)), check_fails_as="silent",
                 teardown=lambda: subprocess.run(["chattr", "-i", str(frozen)]),
                 note="chattr +i folder; stopped once compiling")
    # damaged caches: copies of the shared cache made just before the case runs
    garbage_cache = caches / "programs-garbage"
    as_file_cache = caches / "programs-a-file"
    xla_cache = caches / "xla-garbage"
    env_case("cache-programs-garbage", {"JAXGA_CACHE_DIR": str(garbage_cache)},
             argv=["run", "--map", CLASSIC, *BASE], expect="interrupted",
             signal=(signal.SIGINT, "progress: compile", 0.5, 1), caches=(garbage_cache,),
             check=at_most_one_warning,
             note="every stored program overwritten with garbage; stopped once compiling")
    env_case("cache-programs-a-file", {"JAXGA_CACHE_DIR": str(as_file_cache)},
             argv=["run", "--map", CLASSIC, *BASE], expect="interrupted",
             signal=(signal.SIGINT, "progress: compile", 0.5, 1), caches=(as_file_cache,),
             check=at_most_one_warning,
             note="jaxga-programs is a file; stopped once compiling")
    env_case("cache-jax-entries-garbage", {"JAXGA_CACHE_DIR": str(xla_cache)},
             expect="handled", caches=(xla_cache,), check=at_most_one_warning,
             note="JAX's own entries garbage, jaxga's stored programs whole")
    env_case("devices-env-letters", {"JAXGA_DEVICES": "many"})
    env_case("devices-env-negative", {"JAXGA_DEVICES": "-3"})
    env_case("threefry-env-garbage", {"JAXGA_THREEFRY": "maybe"})
    env_case("xla-flags-garbage", {"XLA_FLAGS": "--xla_no_such_flag=1"})
    env_case("process-timeout-env-text", {"JAXGA_PROCESS_TIMEOUT": "soon",
                                          "JAXGA_COORDINATOR": "127.0.0.1:1",
                                          "JAXGA_NUM_PROCESSES": "2",
                                          "JAXGA_PROCESS_ID": "1"})
    env_case("stdout-closed-pipe", {}, argv=["maps"], expect=("handled", "refused"),
             stdout="closed", note="the reader of stdout is gone (| head)")
    env_case("stdout-full-device", {}, argv=["presets"], stdout="full",
             note="stdout is /dev/full: the listing is lost")

    # --- round two: inputs behind inputs, the store, memory, JAX's and Matplotlib's own
    # switches, closed streams, results against their own records ------------------------
    def two(name, argv, expect="refused", **kw):
        add(name, "round two", argv, expect, **kw)

    parent = write("presets/parent.toml", 'base = "sga"\n[mutation]\nprobability = 0.2\n')
    child = write("child.toml", 'base = "presets/parent.toml"\n')
    two("json-onto-a-presets-base", ["run", "--map", CLASSIC, "--preset", child, "--seeds",
                                     "2", "--generations", "5", "--quiet", "--json", parent],
        quick=True, note="--json names the file the preset's base chain reads")
    own_checkpoint = f / "doe-own"
    write("doe-own/manifest.json", '{"design": "an earlier DOE, to resume"}\n')
    two("doe-json-into-its-checkpoint",
        ["doe", "--preset", "sga", "--map", CLASSIC, "--design", "full", "--factor",
         "crossover.probability=0.6,0.7,0.8", "--seeds", "2", "--generations", "5",
         "--checkpoint", own_checkpoint, "--json", own_checkpoint / "manifest.json"])
    dead = subprocess.Popen(["true"])
    dead.wait()
    killed = write("killed.json", '{"previous": true}\n')
    from jaxga.core.files import OLD_TEMPORARY_S, this_machine

    here = this_machine()
    elsewhere = "0123abcd" if here != "0123abcd" else "89abcdef"
    stale = write(f".killed.json.{dead.pid}.{here}.k1l2e3d4.tmp", '{"half": ')
    two("temporary-of-a-killed-write", ["run", "--map", CLASSIC, *QUIET, "--json", killed],
        "handled", outputs=(killed,), removes=(stale,), check=wrote_json(killed),
        note="a .NAME.<pid>.<machine>.<random>.tmp of a dead process beside the output")
    shared = write("shared.json", '{"previous": true}\n')
    live_elsewhere = write(f".shared.json.{dead.pid}.{elsewhere}.l1i2v3e4.tmp", '{"half": ')
    old_elsewhere = write(f".shared.json.{dead.pid}.{elsewhere}.o1l2d3e4.tmp", '{"half": ')
    hour_ago, tomorrow = time.time() - 2 * OLD_TEMPORARY_S, time.time() + 86400
    os.utime(old_elsewhere, (hour_ago, hour_ago))
    os.utime(live_elsewhere, (tomorrow, tomorrow))  # still recent when the case runs
    two("temporary-of-another-machine", ["run", "--map", CLASSIC, *QUIET, "--json", shared],
        "handled", outputs=(shared,), removes=(old_elsewhere,), check=wrote_json(shared),
        note=f"a folder shared with another host: its recent write ({live_elsewhere.name}, "
             "a pid this machine cannot ask) stays, its hour-old one goes")
    scratch = t / "scratch-mpl"
    scratch.mkdir()
    plot = f / "mpl.png"

    def nothing_left(out: Outcome) -> str | None:
        left = list(scratch.iterdir())
        if left:
            return f"left {left[0]} in the temporary folder"
        return None if plot.is_file() else "no plot written"

    two("matplotlib-folders-unusable", ["run", "--map", CLASSIC, *QUIET, "--plot", plot],
        "handled", env={"MPLCONFIGDIR": "/proc/no-mpl", "TMPDIR": str(scratch)},
        outputs=(plot,), check=nothing_left, check_fails_as="damaged file")
    two("matplotlib-backend-invalid", ["run", "--map", CLASSIC, *QUIET, "--plot",
                                       f / "never.png"], env={"MPLBACKEND": "nonsense"})
    coarse = f / "coarse.json"
    rows = ["." * 20 for _ in range(20)]
    rows[0], rows[-1] = "." * 19 + "G", "S" + "." * 19
    open20 = write("open20.txt", "\n".join(rows) + "\n")
    subprocess.run([sys.executable, "-m", "jaxga.cli", "optimum", "--map", str(open20),
                    "--coarsen", "2", "--json", str(coarse)], capture_output=True,
                   cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=300)

    def converted(out: Outcome) -> str | None:
        return None if "its cells converted" in out.stderr else "no conversion note"

    two("replan-on-a-coarsened-runs-json",
        ["replan", "--map", open20, "--path-json", coarse, "--position", "1,1",
         "--obstacles", "9,9", *BASE], "handled", check=converted,
        timeout=300, note="the JSON records --coarsen 2; this replan has none")
    maze = write("scen/maze-32-32-2.map",
                 (ROOT / "tests" / "data" / "maze-32-32-2.map").read_text())
    scen_lines = (ROOT / "tests" / "data" / "maze-32-32-2-random-1.scen").read_text() \
        .splitlines()
    write("scen/maze-32-32-2.map.scen", "\n".join([scen_lines[0], "\t".join(
        [*scen_lines[1].split("\t")[:-1], "1.00000000"])]) + "\n")

    def reported(out: Outcome) -> str | None:
        return None if "the file's length is wrong" in out.stderr else "not reported"

    two("scenario-optimum-contradicts-the-exact-one",
        ["optimum", "--map", maze, "--scenario", "0"], "handled", check=reported,
        check_fails_as="silent", note="the .scen says 1.0; the exact optimum is 64.31")
    for kind, words in (("swapped", "holds another program"),
                        ("older", "another version"), ("flipped", "")):
        store = caches / f"programs-{kind}"
        two(f"store-programs-{kind}", ["run", "--map", CLASSIC, *QUIET], "handled",
            env={"JAXGA_CACHE_DIR": str(store)}, caches=(store,),
            check=warned(words) if words else at_most_one_warning,
            check_fails_as="silent", timeout=300,
            note={"swapped": "each stored program under another's key",
                  "older": "every entry in an older version's layout",
                  "flipped": "64 bytes flipped inside every stored program"}[kind])
    grouped = f / "grouped.json"
    two("population-of-100000-5-seeds", ["run", "--map", CLASSIC, "--preset", "hybrid",
                                          "--seeds", "5", "--generations", "2", "--set",
                                          "population.size=100000", "--quiet", "--json",
                                          grouped],
        "handled", outputs=(grouped,), check=wrote_json(grouped), timeout=300,
        note="8 GiB address space: 2 runs fit at a time, the 5 run as 3 calls in turn")
    two("population-of-100000-paths-of-4096", ["run", "--map", CLASSIC, "--preset", "sga",
                                               "--seeds", "1", "--generations", "2", "--set",
                                               "population.size=100000", "--set",
                                               "population.capacity=4096", "--quiet"],
        max_s=30.0, note="8 GiB address space: not one run fits, refused before anything "
        "is allocated")
    two("jax-64-bit-mode", ["run", "--map", CLASSIC, *QUIET], env={"JAX_ENABLE_X64": "1"})
    two("jax-platform-cuda-absent", ["run", "--map", CLASSIC, *QUIET],
        env={"JAX_PLATFORMS": "cuda"})
    two("jax-jit-disabled", ["run", "--map", CLASSIC, *QUIET], env={"JAX_DISABLE_JIT": "1"})
    closed_out = f / "closed-stdout.json"
    two("stdout-descriptor-closed", ["run", "--map", CLASSIC, *QUIET, "--json", closed_out],
        "handled", closed_fds=(1,), outputs=(closed_out,), check=wrote_json(closed_out),
        note="`jaxga run ... >&-`")
    two("stderr-descriptor-closed", ["run", "--map", CLASSIC, *QUIET], "handled",
        closed_fds=(2,), note="`jaxga run ... 2>&-`")

    # --- signals ------------------------------------------------------------------------
    def sig(name, argv, signum, trigger, delay=0.0, times=1, cache="own", **kw):
        env = {}
        own = ()
        if cache == "own":
            own = (caches / name,)
            env["JAXGA_CACHE_DIR"] = str(own[0])
        add(name, "signals", argv, "interrupted", env=env, caches=own,
            signal=(signum, trigger, delay, times), **kw)

    prev_run = ["run", "--map", CLASSIC, *BASE, "--json", previous]
    sig("sigint-during-compile", prev_run, signal.SIGINT, "progress: compile", quick=True)
    sig("sigterm-during-compile", prev_run, signal.SIGTERM, "progress: compile")
    sig("double-sigint-during-compile", prev_run, signal.SIGINT, "progress: compile", times=2)
    sig("sigint-during-evolve", ["run", "--map", CLASSIC, "--preset", "sga", "--seeds", "2",
                                 "--generations", "1000000", "--json", previous],
        signal.SIGINT, "progress: evolve", 0.5, cache="shared")
    sig("sigint-at-startup", prev_run, signal.SIGINT, None, 0.4,
        note="0.4 s after start: Python is importing")
    sig("sigterm-at-startup", prev_run, signal.SIGTERM, None, 0.4)
    sig("sigint-during-replan-compile",
        ["replan", "--map", CLASSIC, "--path-json", base_json, *obstacle, "--preset", "sga",
         "--seeds", "2", "--generations", "5", "--json", previous],
        signal.SIGINT, None, 7.0, note="7 s after start")
    sig("sigterm-during-warmup", ["warmup", "--presets", "sga", "--sizes", "20", "--seeds",
                                  "2"], signal.SIGTERM, None, 7.0, note="7 s after start")
    checkpoint = f / "doe-checkpoint"
    sig("sigint-during-doe", ["doe", "--preset", "sga", "--map", CLASSIC, "--design", "full",
                              "--factor", "crossover.probability=0.6,0.7,0.8", "--seeds",
                              "2", "--generations", "5", "--checkpoint", checkpoint,
                              "--json", previous],
        signal.SIGINT, None, 7.0, outputs=(checkpoint,), note="7 s after start")
    sig("sighup-during-compile", prev_run, signal.SIGHUP, "progress: compile",
        note="a closed terminal")

    # --- round three (decision 047) -----------------------------------------------------
    from PIL import Image


    wide = np.where(blocked[::-1], 5000, 60000).astype(">u2")
    grey16 = write("grey16.pgm", b"P5\n%d %d\n65535\n" % (w, h) + wide.tobytes())
    out16 = f / "grey16.json"
    add("pgm-16-bit", "round three", run(grey16, *FREE, "--json", out16), "handled",
        outputs=(out16,), check=all_of(wrote_json(out16), runs_free(out16, blocked)),
        note="was read clipped to 8 bits: every non-black pixel free")
    Image.fromarray(np.where(blocked[::-1], 0.0, 1.0).astype(np.float32)).save(f / "f.tif")
    add("tiff-floating-point", "round three", run(f / "f.tif", *FREE))
    Image.fromarray(np.where(blocked[::-1], 0, 255).astype(np.uint8)).save(f / "m.webp",
                                                                          lossless=True)
    add("webp-map", "round three", run(f / "m.webp", *FREE), "handled", check=said("success"))
    Image.fromarray(np.where(blocked[::-1], 0, 255).astype(np.uint8)).save(f / "bmp-no-ext",
                                                                          format="BMP")
    add("bmp-without-extension", "round three", run(f / "bmp-no-ext", *FREE), "handled",
        check=said("success"))
    for name, text in (("resolution-1e308", "resolution: 1.0e+308\norigin: [0, 0, 0]\n"),
                       ("resolution-400-digits",
                        "resolution: 1" + "0" * 400 + "\norigin: [0, 0, 0]\n"),
                       ("origin-5000-digits",
                        "resolution: 0.05\norigin: [" + "9" * 5000 + ", 0, 0]\n"),
                       ("image-name-nul", "resolution: 0.05\norigin: [0, 0, 0]\n")):
        image = ('image: "classic\\0.png"\n' if name == "image-name-nul"
                 else "image: classic.png\n")
        add(f"ros-{name}", "round three", run(write(f"ros-{name}.yaml", image + text)))
    digits = "9" * 5000
    digits_toml = write("digits.toml", f'base = "sga"\ngenerations = {digits}\n')
    add("preset-5000-digit-integer", "round three",
        ["run", "--map", CLASSIC, "--preset", digits_toml, "--seeds", "2", "--quiet"])
    add("set-5000-digit-integer", "round three",
        run(CLASSIC, "--set", f"crossover.probability={digits}"))
    # the checkout under test (ROOT), not the jaxga this script imported: an editable
    # install of another checkout would be written over
    builtin_file = ROOT / "jaxga" / "maps" / "data" / f"{CLASSIC}.txt"
    add("json-onto-the-builtin-map", "round three", run(CLASSIC, "--json", builtin_file),
        quick=True, note="would destroy the built-in map for every later run")
    add("plot-onto-dev-full", "round three", run(CLASSIC, "--plot", "/dev/full"),
        note="was written as a new file /dev/full.png")
    add("json-trailing-slash", "round three", run(CLASSIC, "--json", f"{f}/slash.json/"))
    add("devices-1000", "round three", run(CLASSIC, "--devices", "1000"), max_s=15,
        note="never finished")
    doe_list = f / "doe-list"
    write("doe-list/manifest.json", "[1, 2]\n")
    add("doe-manifest-a-list", "round three",
        ["doe", "--preset", "sga", "--map", CLASSIC, "--design", "full", "--factor",
         "crossover.probability=0.6,0.7", "--seeds", "2", "--generations", "5",
         "--checkpoint", doe_list])
    unknown_yaml = write("unknown.yaml", "image: unknown.pgm\nresolution: 0.1\n"
                                         "origin: [0.0, 0.0, 0.0]\n")
    write("unknown.pgm", b"P5\n4 4\n255\n" + bytes([254, 254, 254, 205] * 4))
    add("endpoint-on-an-unknown-cell", "round three",
        run(unknown_yaml, "--start", "0,0", "--goal", "3,3"), note="names --unknown free")
    stale_path = write("stale-path.csv", "x,y\n0.05,0.05\n0.35,0.35\n")
    walled_yaml = write("walled.yaml", "image: walled.pgm\nresolution: 0.1\n"
                                       "origin: [0.0, 0.0, 0.0]\n")
    write("walled.pgm", b"P5\n4 4\n255\n" + bytes([254, 254, 0, 254] * 4))
    add("no-path-with-a-stale-path-out", "round three",
        run(walled_yaml, "--start", "0,0", "--goal", "3,3", "--path-out", stale_path),
        "no path", outputs=(stale_path,), check=empty_path_file(stale_path),
        note="the file holds an empty path afterwards, not the earlier one")
    # --- round four ---------------------------------------------------------------------
    add("set-400-digit-integer", "round four",
        run(CLASSIC, "--set", "crossover.probability=" + "9" * 400),
        note="was an OverflowError traceback (an integer beyond the largest float)")
    add("factor-400-digit-level", "round four",
        ["doe", "--preset", "sga", "--map", CLASSIC, "--design", "full", "--factor",
         "crossover.probability=0.1,0.5," + "9" * 400, "--seeds", "2"],
        note="was an OverflowError traceback")
    add("set-3000-character-value", "round four",
        run(CLASSIC, "--set", "mutation.method=" + "z" * 3000), check=lines_under(600),
        note="was echoed whole, twice: a line of 6 kB")
    add("seeds-3000-character-value", "round four", run(CLASSIC, "--seeds", "q" * 3000),
        check=lines_under(600), note="argparse's refusal, echoed whole")
    add("abbreviated-seed-option", "round four", run(CLASSIC, "--seed", "42"),
        note="argparse took it for --seeds 42: 42 runs instead of seed 42")
    thin = write("thin-header.map", "type octile\nheight 1\nwidth 99999999999999999999\nmap\n.\n")
    add("movingai-header-10e20-by-1", "round four", run(thin), max_s=15,
        note="hung: the coarsening factor was counted up from 2")
    room4 = write("room4x4.pgm", b"P5\n4 4\n255\n" + bytes([254] * 16))
    deep = "[" * 5000 + "]" * 5000
    add("ros-yaml-nested-5000-deep", "round four",
        run(write("deep.yaml", f"image: {room4.name}\nresolution: 0.1\norigin: {deep}\n")),
        note="was a RecursionError traceback")
    add("ros-yaml-key-twice", "round four",
        run(write("twice.yaml", f"image: {room4.name}\nresolution: 0.1\norigin: [0, 0, 0]\n"
                                "resolution: 5.0\n")),
        note="the last value was used without a word")
    add("preset-nested-3000-deep", "round four",
        ["run", "--map", CLASSIC, "--preset",
         write("deep.toml", 'base = "sga"\nx = ' + "[" * 3000 + "]" * 3000 + "\n"), *BASE[2:],
         "--quiet"], note="was a RecursionError traceback")
    add("preset-dotted-key-3000-parts", "round four",
        ["run", "--map", CLASSIC, "--preset",
         write("dotted.toml", 'base = "sga"\n' + ".".join(["a"] * 3000) + " = 1\n"),
         *BASE[2:], "--quiet"], check=lines_under(600), note="was a RecursionError traceback")
    add("set-nested-3000-deep", "round four",
        run(CLASSIC, "--set", "init.clearance_weights=" + "[" * 3000 + "]" * 3000),
        note="was a RecursionError traceback")
    add("csv-empty-cell", "round four", run(write("empty-cell.txt", "0,,0,1\n0,,0,1\n")),
        note="read as 3 cells a row: the columns shifted")
    from PIL import Image as _Image

    frames = [_Image.fromarray(np.where(blocked[::-1], 0, 255).astype(np.uint8)),
              _Image.fromarray(np.where(blocked[::-1], 255, 0).astype(np.uint8))]
    frames[0].save(f / "anim.gif", save_all=True, append_images=frames[1:])
    add("gif-two-frames", "round four", run(f / "anim.gif", *FREE),
        note="the first frame was read, the second ignored")
    add("front-point-without-a-front", "round four", run(CLASSIC, "--front-point", "knee"),
        note="did nothing, without a word")
    folders_cache = caches / "programs-folders"
    add("cache-entries-folders", "round four", ["run", "--map", CLASSIC, *QUIET],
        "handled", env={"JAXGA_CACHE_DIR": str(folders_cache)}, caches=(folders_cache,),
        check=warned("could not be kept"),
        note="every stored program's file replaced by a folder: was compiled in every "
             "process without a word")
    # --- round five ---------------------------------------------------------------------
    level = np.where(blocked[::-1], 17, 255).astype(np.uint8)  # walls at a 4-bit level
    _Image.fromarray(level).save(f / "four-bit.png", bits=4)
    out = f / "four-bit.json"
    add("png-4-bit-grey-walls", "round five", run(f / "four-bit.png", *FREE, "--json", out),
        "handled", outputs=(out,), check=runs_free(out, blocked),
        note="every wall but pure black read as free: paths went through walls")
    gap = np.full((5, 9, 4), 255, np.uint8)
    gap[:, 4, :3] = 0
    gap[2, 4] = (255, 255, 255, 0)  # a transparent white gap in the wall
    _Image.fromarray(gap).save(f / "gap.png")
    add("ros-trinary-transparent-gap", "round five",
        run(write("gap.yaml", "image: gap.png\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\n"
                              "mode: trinary\n"), "--start", "0,2", "--goal", "8,2"),
        "no path", note="the transparent gap was free; map_server averages the alpha in: "
                        "unknown, blocked")
    fine = write("fine.yaml", good.replace("0.05", "0.00001"))
    fine_csv = f / "fine.csv"
    add("path-out-10-micrometre-cells", "round five",
        run(fine, *FREE, "--path-out", fine_csv), "handled", outputs=(fine_csv,),
        check=distinct_rows(fine_csv), note="points written to 4 decimals: 0.0000 and 0.0001")
    add("pgm-sample-over-maxval", "round five",
        run(write("over.pgm", b"P5\n4 1\n100\n\x00\x32\x64\xc8"), "--start", "0,0",
            "--goal", "3,0"), note="the sample 200 of maxval 100 was read as white")
    add("ros-yaml-tab", "round five",
        run(write("tab.yaml", good.replace("image: ", "image:\t"))),
        check=refused_saying("line 1, column 7"),
        note="said 'while scanning for the next token', without the line")
    unknown = write("unknown-all.pgm", b"P5\n4 4\n255\n" + bytes([205] * 16))
    add("optimum-on-unknown-cells", "round five",
        ["optimum", "--map", write("unknown-all.yaml", good.replace(room.name, unknown.name))],
        check=refused_saying("--unknown free"), note="said 'is blocked' without why")
    add("robot-radius-1e308", "round five",
        run(write("radius.yaml", good), "--robot-radius", "1e308"),
        check=refused_saying("robot radius"), note="named an 'inflate radius' of inf")
    add("ascii-line-separator", "round five",
        run(write("separator.txt", "S..\u2028...\n..G\n")),
        note="U+2028 split a row: a 2-line file read as 3 rows")
    add("start-underscore-digits", "round five", run(CLASSIC, "--start", "1_0,0"),
        note="int() read it as cell 10")
    exif = _Image.Exif()
    exif[274] = 6
    _Image.fromarray(np.where(blocked[::-1], 0, 255).astype(np.uint8)).save(
        f / "turned.jpg", exif=exif.tobytes())
    add("jpeg-exif-turned", "round five", run(f / "turned.jpg", *FREE),
        note="read as stored while viewers show it turned")
    add("png-16-bit-colour-transparent", "round five",
        run(write("colour16.png", png16_rgb_with_key())),
        note="Pillow reads it at 8 bits with a 16-bit key: read silently opaque")
    bomb = f / "bomb.bmp"
    with bomb.open("wb") as fh:  # a 20000 x 20000 1-bit BMP, sparse on disk
        row = 20000 // 32 * 4
        fh.write(b"BM" + struct.pack("<IHHI", 62 + row * 20000, 0, 0, 62)
                 + struct.pack("<IiiHHIIiiII", 40, 20000, 20000, 1, 1, 0, row * 20000,
                               2835, 2835, 2, 0) + b"\0\0\0\0\xff\xff\xff\0")
        fh.seek(row * 20000 - 1, 1)
        fh.write(b"\xff")
    add("bmp-over-pillows-bomb-limit", "round five", ["optimum", "--map", bomb], max_s=15,
        note="a DecompressionBombError traceback")
    add("doe-set-of-a-factor", "round five",
        ["doe", "--preset", "sga", "--map", CLASSIC, "--design", "full", "--factor",
         "crossover.probability=0.6,0.7,0.8", "--set", "crossover.probability=0.5",
         "--seeds", "2", "--generations", "5", "--quiet"],
        note="the --set was ignored (exit 0): the factor's levels replaced it")
    add("doctor-presets-with-quick", "round five",
        ["doctor", "--quick", "--presets", "nonexist"], note="ignored, exit 0")
    add("generations-given-twice", "round five", run(CLASSIC, "--generations", "6"),
        repeats=True, note="(--generations 5 is among the common options) the last was "
                           "kept in silence")
    add("seeds-underscore-digits", "round five", run(CLASSIC, "--seeds", "2_0"),
        note="int() read it as 20 seeds")
    env_case("cache-dir-name-too-long", {"JAXGA_CACHE_DIR": str(t / ("a" * 300))},
             argv=["run", "--map", CLASSIC, *BASE], expect="interrupted",
             signal=stop_at_compile, check=warned("File name too long"),
             check_fails_as="silent", note="refused the run; the Python API raised OSError")
    # --- round six: the user's own JAX settings ------------------------------------------
    plain = f / "plain-settings.json"
    add("jax-default-settings", "round six", run(CLASSIC, "--json", plain), "handled",
        outputs=(plain,), check=wrote_json(plain),
        note="the reference for the next cases: the same run under JAX's defaults")
    for name, env, note in (
            ("jax-transfer-guard-disallow", {"JAX_TRANSFER_GUARD": "disallow"},
             "failed deep in XLA ('Disallowed host-to-device transfer')"),
            ("jax-threefry-not-partitionable", {"JAX_THREEFRY_PARTITIONABLE": "0"},
             "other runs from the same seeds, in silence"),
            ("jax-seed-offset", {"JAX_RANDOM_SEED_OFFSET": "7"},
             "seed s ran as seed s + 7, in silence"),
            ("jax-prng-rbg", {"JAX_DEFAULT_PRNG_IMPL": "rbg"},
             "'invalid PRNG key data' deep in JAX"),
            # without the program store: these two fail while a program is traced
            ("jax-legacy-keys-refused", {"JAX_LEGACY_PRNG_KEY": "error", "JAXGA_CACHE_DIR": ""},
             "every draw from a raw key refused by JAX (compiled without the store)"),
            ("jax-rank-promotion-raise",
             {"JAX_NUMPY_RANK_PROMOTION": "raise", "JAXGA_CACHE_DIR": ""},
             "tracing failed (compiled without the store)")):
        out = f / f"{name}.json"
        add(name, "round six", run(CLASSIC, "--json", out), "handled", env=env,
            outputs=(out,), check=same_runs_as(out, plain), note=note)

    # --- round eight: JAX's environment, streams, links, long names, numbers as written --
    for name, env in (("jax-truth-value-refused", {"JAX_ENABLE_X64": "maybe"}),
                      ("jax-integer-refused", {"JAX_NUM_CPU_DEVICES": "many"})):
        add(name, "round eight", run(CLASSIC), env=env, quick=True,
            note="a traceback from `import jax`, for every command")
    log = write("stdout.log", "earlier run\n")
    add("json-to-redirected-stdout", "round eight", run(CLASSIC, "--json", "/dev/stdout"),
        stdout_file=log, quick=True,
        note="`>> stdout.log`: the rename replaced the log (as root)")
    dangling = f / "dangling.json"
    dangling.symlink_to(f / "missing" / "x.json")
    add("json-through-a-dangling-link", "round eight", run(CLASSIC, "--json", dangling),
        quick=True, note="refused after the whole run")
    longest = f / ("a" * 245 + ".json")
    add("json-of-250-bytes", "round eight", run(CLASSIC, "--json", longest), "handled",
        outputs=(longest,), check=wrote_json(longest),
        note="refused after the run: the temporary name passed 255 bytes")
    add("json-of-256-bytes", "round eight", run(CLASSIC, "--json", f / ("b" * 251 + ".json")),
        quick=True, note="refused after the run")
    underscore = write("underscore.scen",
                       "version 1\n0\tclassic.txt\t20\t20\t0\t1_9\t19\t0\t30.97056274\n")
    add("scen-underscore-digits", "round eight",
        run(classic, *FREE, "--scen", underscore, "--scenario", "0"), quick=True,
        note="1_9 was read as 19")
    add("warmup-presets-of-none", "round eight",
        ["warmup", "--presets", ",", "--sizes", "20"], quick=True,
        note="warmed nothing, exit 0")
    home, tilde = t / "home", f / "tilde.json"
    add("cache-dir-with-tilde", "round eight", run(CLASSIC, "--json", tilde), "handled",
        env={"JAXGA_CACHE_DIR": "~/cache8", "HOME": str(home)}, outputs=(tilde, home),
        check=all_of(wrote_json(tilde), no_folder_named(f / "~")), timeout=300,
        note="made a folder named '~' in the working folder")

    # --- round nine: huge headers, one-cell paths, ports in use, keys set twice ----------
    huge = write("huge-plus.map", "type octile\nheight 1\nwidth +1000000000000\nmap\n.\n")
    add("movingai-width-with-a-plus", "round nine", run(huge), quick=True,
        note="the header's size allocated before any row was read: MemoryError (931 GiB)")
    smooth_out = f / "smooth-one-cell.json"
    add("smooth-start-is-goal", "round nine",
        run(CLASSIC, "--smooth", "--start", "0,0", "--goal", "0,0", "--json", smooth_out),
        "handled", outputs=(smooth_out,), check=wrote_json(smooth_out), timeout=300,
        note="a gather out of range after the summary")
    replan("path-json-frame-coarsen-1e400",
           write("coarse-1e400.json", '{"frame": {"coarsen": 1e400}, "path": [[0, 0], [1, 0]]}'),
           *obstacle, quick=True, note="OverflowError traceback")
    replan("replan-generations-beside-set", base_json, *obstacle, "--generations", "20",
           "--set", "generations=6", note="ran 6 generations without a word")
    add("coordinator-port-past-65535", "round nine",
        run(CLASSIC, "--coordinator", "127.0.0.1:99999", "--num-processes", "2",
            "--process-id", "0"), quick=True, max_s=15,
        note="waited out the timeout, then blamed the other processes")
    held = socket.create_server(("127.0.0.1", 0))
    HELD_PORTS.append(held)  # listening until this process ends
    port = held.getsockname()[1]
    add("coordinator-port-in-use", "round nine",
        run(CLASSIC, "--coordinator", f"127.0.0.1:{port}", "--num-processes", "2",
            "--process-id", "0"), quick=True,
        note="a C++ log line and a JaxRuntimeError traceback")
    env_case("process-timeout-underscore", {"JAXGA_PROCESS_TIMEOUT": "1_0"},
             "--coordinator", "127.0.0.1:23999", "--num-processes", "2", "--process-id", "0",
             note="read as 10 s")
    twice = write("twice.toml", 'base = "sga"\n"mutation.probability" = 0.2\n'
                  "[mutation]\nprobability = 0.3\n")
    add("preset-key-set-twice", "round nine", run(CLASSIC, "--preset", twice),
        note="ran 0.3 without a word")
    add("damaged-tiff", "round nine", run(write("damaged.tif", b"II*\x00\x08\x00\x00\x00")),
        note="Pillow's four warning lines before jaxga's")
    corner = write("corner.txt", "000\n010\n000\n")
    add("default-corner-inflated", "round nine", ["optimum", "--map", corner, "--inflate", "1.5"],
        note="'start cell (0, 0) is blocked', no word of the inflation")
    quoted = tb3 / "quoted.yaml"
    quoted.write_text(re.sub(r"resolution:[^\n]*", "resolution: '0_05'", tb3_yaml.read_text()))
    add("ros-resolution-quoted-underscore", "round nine", run(quoted), quick=True,
        note="read as 5.0 m cells (yaml-cpp refuses it)")
    add("population-capacity-past-a-program", "round nine",
        run(CLASSIC, "--population-capacity", "1000000000"),
        note="named population.size, a key not given")
    # --- round ten: maps nobody tuned for (decision 056) ------------------------------
    nosg = write("no-markers.txt", "..#\n.#.\n#..\n")
    add("default-start-blocked", "round ten", ["optimum", "--map", nosg, "--goal", "2,0"],
        check=refused_saying("no start was given"), quick=True,
        note="named the default corner as if it had been chosen")
    add("map-blocked-everywhere", "round ten",
        ["optimum", "--map", write("all-walls.txt", "##\n##\n")],
        check=refused_saying("every cell of the map is blocked"), quick=True,
        note="said only that the start was blocked")
    turned = tb3 / "turned.yaml"
    turned.write_text(re.sub(r"origin:[^\n]*", "origin: [10.0, -5.0, 1.5707963267948966]",
                             tb3_yaml.read_text()))
    add("point-off-a-turned-map", "round ten",
        ["optimum", "--map", turned, "--start-world", "10.1,-4.9", "--goal-world", "9,-4"],
        check=refused_saying("along the map's own axes"), quick=True,
        note="named an unturned extent that held the point")
    add("robot-radius-of-20-m", "round ten", run(tb3_yaml, "--robot-radius", "20"),
        check=refused_saying("every cell of the map is blocked (the inflation"), quick=True,
        max_s=15,
        note="the inflation shifted the map once per offset within 400 cells: minutes")
    # --- round eleven: statistics, designs, files read back (decision 057) -------------
    add("l18-of-two-factors-repeating-points", "round eleven",
        ["doe", "--preset", "sga", "--map", CLASSIC, "--design", "L18", "--factor",
         "mutation.probability=0.05,0.2,0.5", "--factor", "crossover.probability=0.5,0.7,0.9",
         "--seeds", "2", "--generations", "5", "--quiet"],
        check=refused_saying("only 9 distinct points among its 18"), quick=True,
        note="ran each of 9 points twice on the same seeds (the L27: three times)")
    # --- from the review of round eleven (decision 058) ---------------------------------
    lone = tb3 / "lone-surrogate.yaml"
    lone.write_text(re.sub(r"image:[^\n]*", lambda _: 'image: "\\ud83d.pgm"',
                           tb3_yaml.read_text()))
    add("ros-image-named-by-a-lone-surrogate", "review of round eleven", run(lone),
        check=refused_saying("no file can have this name"), quick=True,
        note="UnicodeEncodeError traceback (how JSON's escape of a character beyond the "
             "BMP read back)")
    # --- from the review of decision 058 ----------------------------------------------
    add("lone-surrogate-image-beside-json", "review of decision 058",
        run(lone, "--json", f / "lone.json"),
        check=refused_saying("no file can have this name"), quick=True,
        note="UnicodeEncodeError traceback (the outputs' check resolved the image's name)")
    nul_base = write("nul-base.toml", 'base = "a\\u0000.toml"\n')
    add("preset-base-with-a-nul", "review of decision 058",
        run(CLASSIC, "--preset", nul_base),
        check=refused_saying("cannot hold a NUL"), quick=True,
        note="ValueError traceback (embedded null byte)")
    add("json-name-of-300-bytes", "review of decision 058",
        run(CLASSIC, "--json", f / ("j" * 295 + ".json")),
        check=refused_saying("more than the 255"), quick=True)
    # --- round fourteen (decision 062): the process a user or a scheduler starts --------
    run_json = f / "r14.json"
    add("stdout-full-during-a-run", "round fourteen", run(CLASSIC, "--json", run_json),
        stdout="full", outputs=(run_json,), writes_on_error=True,
        check=refused_saying("standard output could not be written"),
        note="exit 2 'No space left on device' before the JSON was written: now at the end, "
             "the JSON written")
    add("warnings-as-errors", "round fourteen", run(CLASSIC),
        env={"PYTHONWARNINGS": "error", "JAXGA_CACHE_DIR": "/proc/jaxga-no-cache"},
        check=refused_saying("an error under -W error"), quick=True,
        note="a CacheWarning traceback")
    add("cache-dir-of-spaces", "round fourteen", run(CLASSIC), "handled",
        env={"JAXGA_CACHE_DIR": "  "}, check=warned("holds only spaces"),
        note="made a folder named by two spaces in the working folder")
    sig("sigusr1-during-compile", prev_run, signal.SIGUSR1, "progress: compile",
        note="a scheduler's warning signal (Slurm --signal, SGE -notify): ended silently")
    # --- round fifteen (decision 063): a robot's map far from 0 -------------------------
    utm_blocked = np.zeros((40, 40), bool)
    utm_blocked[25] = True  # the row just below the start's edge
    save_map(utm_blocked, f / "utm.yaml", resolution=0.05, origin=(512345.6, 4123456.7, 0.0))
    add("utm-start-on-a-cell-edge", "round fifteen",
        ["optimum", "--map", f / "utm.yaml", "--start-world", "512346.2,4123458.0",
         "--goal-world", "512347.3,4123458.6"], "handled", quick=True,
        note="'start cell (12, 25) is blocked': float64's rounding of the UTM origin put "
             "the edge's point in the cell below")
    far = tb3 / "nanometre-far.yaml"
    far.write_text(re.sub(r"origin:[^\n]*", "origin: [512345.6, 4123456.7, 0.0]",
                          re.sub(r"resolution:[^\n]*", "resolution: 1.0e-9",
                                 tb3_yaml.read_text())))
    add("origin-too-many-cells-away", "round fifteen", ["optimum", "--map", far],
        check=refused_saying("cells of 1e-09 m away"), quick=True,
        note="loaded: written cell centres read back in other cells")
    return cases


HELD_PORTS: list[socket.socket] = []
"""Ports this process listens on while the campaign runs: a coordinator's port another
program holds (``coordinator-port-in-use``)."""


def no_folder_named(path: Path) -> Check:
    """No file or folder ``path`` was made (a name a shell would have expanded)."""
    def check(out: Outcome) -> str | None:
        return f"made {path}" if os.path.lexists(path) else None
    return check


def same_runs_as(path: Path, reference: Path) -> Check:
    """``path`` holds a run's JSON whose runs (success, length, path) are those of the
    JSON at ``reference``."""
    def runs(p: Path) -> list:
        return [(r.get("success"), r.get("length"), r.get("path"))
                for r in json.loads(p.read_text())["runs"]]

    def check(out: Outcome) -> str | None:
        try:
            got, want = runs(path), runs(reference)
        except (OSError, ValueError, KeyError) as e:
            return f"{path.name} or {reference.name} not written ({type(e).__name__})"
        return None if got == want else "other runs than under JAX's defaults"
    return check


def png16_rgb_with_key() -> bytes:
    """A 2 x 1 16-bit colour PNG whose transparent colour (tRNS) is its first pixel."""
    rows = b"\0" + struct.pack(">6H", 1000, 1000, 1000, 65535, 65535, 65535)
    return (b"\x89PNG\r\n\x1a\n"
            + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 1, 16, 2, 0, 0, 0))
            + chunk(b"tRNS", struct.pack(">3H", 1000, 1000, 1000))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def prepare(case: Case, t: Path) -> None:
    """Make the damaged copies of the shared cache the cache cases need."""
    shared = t / "cache"
    for target in case.caches:
        if target.exists() or not target.name.startswith(("programs-", "xla-")):
            continue
        shutil.copytree(shared, target)
        programs = target / "jaxga-programs"
        if target.name == "programs-garbage":
            for p in programs.glob("*.pkl"):
                p.write_bytes(os.urandom(2048))
        elif target.name == "programs-a-file":
            shutil.rmtree(programs, ignore_errors=True)
            programs.write_text("not a folder\n")
        elif target.name == "programs-swapped":  # each program under the next one's key
            files = sorted(programs.glob("*.pkl"))
            data = [p.read_bytes() for p in files]
            for p, d in zip(files, data[1:] + data[:1]):
                p.write_bytes(d)
        elif target.name == "programs-older":  # an older version's layout of each entry
            import pickle

            for p in programs.glob("*.pkl"):
                entry = pickle.loads(p.read_bytes())
                p.write_bytes(entry["program"] if isinstance(entry, dict) else p.read_bytes())
        elif target.name == "programs-flipped":  # bytes flipped inside each program
            for p in programs.glob("*.pkl"):
                b = bytearray(p.read_bytes())
                for k in range(len(b) // 2, len(b) // 2 + 64):
                    b[k] ^= 0xFF
                p.write_bytes(bytes(b))
        elif target.name == "programs-folders":  # each entry's file now a folder
            for p in programs.glob("*.pkl"):
                p.unlink()
                (p / "theirs").mkdir(parents=True)
        elif target.name == "xla-garbage":
            for p in target.iterdir():
                if p.is_file():
                    p.write_bytes(os.urandom(4096))


# --- report ---------------------------------------------------------------------------


def shown(text: str, t: Path, width: int) -> str:
    text = text.replace(str(t), "$T").replace(str(ROOT), ".").replace("\n", "\\n")
    text = text.replace("|", "\\|").replace("`", "'")
    return text if len(text) <= width else text[:width - 3] + "..."


def command_line(case: Case, t: Path) -> str:
    words = [f"{k}={shlex.quote(v)}" for k, v in case.env.items() if v is not None]
    line = " ".join([*words, "jaxga", *(shlex.quote(a) for a in case.argv)])
    if case.stdout == "closed":
        line += " | (closed)"
    elif case.stdout == "full":
        line += " > /dev/full"
    if case.signal:
        signum, trigger, delay, times = case.signal
        when = (f"at {trigger!r}" + (f" + {delay:g} s" if delay else "")) if trigger \
            else f"{delay:g} s after start"
        line += f"  [{'2 x ' if times > 1 else ''}{signal.Signals(signum).name} {when}]"
    return shown(line, t, 170)


def aligned(table: str, columns: str) -> str:
    """``table`` (:func:`markdown_table`) with its columns aligned l(eft) or r(ight)."""
    lines = table.split("\n")
    lines[1] = "|" + "|".join("---:" if c == "r" else "---" for c in columns) + "|"
    return "\n".join(lines)


def first_line(out: Outcome) -> str:
    lines = [ln for ln in out.err_lines if not ln.startswith("progress:")]
    return lines[0] if lines else ""


def group_table(results: list) -> str:
    """Markdown: per group of cases, how many ended in each class."""
    classes = [cls for cls in (*OK_CLASSES, *DEFECTS)
               if any(o.cls == cls for _, o in results)]
    groups = list(dict.fromkeys(c.group for c, _ in results))
    rows = [[g, sum(c.group == g for c, _ in results),
             *(sum(c.group == g and o.cls == cls for c, o in results) for cls in classes)]
            for g in groups]
    align = "l" + "r" * (1 + len(classes))
    return aligned(markdown_table(["group", "cases", *classes], rows), align)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="about 10 cases")
    ap.add_argument("--only", default="", help="comma-separated case names (baseline added)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = ap.parse_args()
    # a campaign ended by SIGTERM (kill, a CI timeout) still runs its teardowns (the
    # immutable folder's chattr -i) and removes its folder: Python's default would not
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    t0 = time.monotonic()
    tmp = Path(tempfile.mkdtemp(prefix="jaxga-faults-"))
    env = dict(os.environ, PYTHONPATH=str(ROOT), JAXGA_CACHE_DIR=str(tmp / "cache"))
    for k in ("JAX_COMPILATION_CACHE_DIR", "JAXGA_DEVICES", "JAXGA_THREEFRY", "XLA_FLAGS",
              "JAXGA_COORDINATOR", "JAXGA_NUM_PROCESSES", "JAXGA_PROCESS_ID",
              "JAXGA_PROCESS_TIMEOUT", "PYTHONFAULTHANDLER"):
        env.pop(k, None)
    work = tmp / "files"
    cases = everything = build(tmp)
    names = {c.name for c in cases}
    if args.only:
        wanted = {"baseline", *args.only.split(",")}
        unknown = wanted - names
        if unknown:
            raise SystemExit(f"unknown cases: {', '.join(sorted(unknown))}")
        cases = [c for c in cases if c.name in wanted]
    elif args.quick:
        cases = [c for c in cases if c.quick]
    rows, results = [], []
    try:
        for i, case in enumerate(cases, 1):
            prepare(case, tmp)
            before = snapshot(work)
            out = execute(case, env, work)
            after = snapshot(work)
            damage = damage_of(case, before, after, out.rc)
            out.cls, out.why = classify(case, out, damage)
            if case.teardown:
                case.teardown()
            results.append((case, out))
            flag = "DEFECT " if out.cls in DEFECTS else ""
            print(f"[{i}/{len(cases)}] {case.name}: {flag}{out.cls} (exit {out.rc}, "
                  f"{out.seconds:.1f} s) {out.why}\n    {first_line(out)[:160]}", flush=True)
            rows.append([case.name, case.group, " / ".join(case.expect),
                         f"**{out.cls}**" if out.cls in DEFECTS else out.cls,
                         "timeout" if out.rc is None else str(out.rc), f"{out.seconds:.1f}",
                         shown(first_line(out) or "(none)", tmp, 110),
                         f"`{command_line(case, tmp)}`"])
    finally:
        for case in everything:  # the files were made for every case, selected or not
            if case.teardown:
                case.teardown()
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    total = time.monotonic() - t0
    counts = Counter(out.cls for _, out in results)
    count_rows = [[cls, counts[cls], "defect" if cls in DEFECTS else "correct"]
                  for cls in (*OK_CLASSES, *DEFECTS) if counts[cls]]
    defects = [(c, o) for c, o in results if o.cls in DEFECTS]
    body = (
        f"{len(results)} hostile inputs and faults against the `jaxga` command line, each in "
        f"a fresh process (`python -m jaxga.cli`, shown as `jaxga`; `$T` = the campaign's "
        f"temporary folder, `.` = the checkout), classed automatically; the campaign took "
        f"{total:.0f} s. Runs: `--preset sga --seeds 2 --generations 5` on the built-in "
        f"`{CLASSIC}` or a copy of it in the format under test (`--corner-rule free`), "
        "maps of at most 32 x 32 cells, and a copy of `benchmarks/maps/tb3_world`; one "
        "shared compilation cache (compiled by `baseline`) except where a case names its "
        "own. refused = exit 2 and one `jaxga: error:` / `jaxga: bad start or goal:` line; "
        "no path = exit 3 and one `jaxga: no path:` line; handled = exit 0, the case's "
        "check passed (output written, warning said); interrupted = exit 128 + the signal's "
        "number (130 / 143 / 129 / 138) within "
        f"{INTERRUPT_S:.0f} s of the signal. A defect is any other class (the script's "
        "docstring defines them); the files under `$T` are compared before and after each "
        "case (inputs and previous outputs unchanged, nothing left behind).\n\n"
        "**Counts per class**\n\n"
        + aligned(markdown_table(["class", "cases", "kind"], count_rows), "lrl")
        + "\n\n**Cases per group** (every case, its command and first stderr line: the "
        "script's output)\n\n" + group_table(results)
    )
    if defects:
        body += "\n\n**Defects**\n\n" + "\n".join(
            f"- `{c.name}`: {o.cls}: {shown(o.why, tmp, 200)}" for c, o in defects)
    title = "hostile inputs to the command line (benchmarks/fault_campaign.py)"
    record(title + (" (--quick)" if args.quick else ""), body,
           write=not args.no_write and not args.only)
    print("\n" + aligned(markdown_table(["case", "group", "expected", "class", "exit", "s",
                                         "first stderr line", "command"], rows), "lllllrll"))
    print(f"\n{len(results)} cases in {total:.0f} s: "
          + ", ".join(f"{cls} {n}" for cls, n in counts.most_common()))
    for c, o in defects:
        lines = o.stderr.splitlines()
        if len(lines) > 24:
            lines = [*lines[:8], f"... ({len(lines) - 20} lines)", *lines[-12:]]
        print(f"\nDEFECT {c.name} ({o.cls}: {o.why})\n  {command_line(c, tmp)}\n"
              + "".join(f"  | {ln}\n" for ln in lines)
              + "".join(f"  > {ln}\n" for ln in o.stdout.splitlines()[:6]))


if __name__ == "__main__":
    main()
