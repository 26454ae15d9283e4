"""The entry point: arguments read, warnings as one line, errors as one line and an exit status."""

from __future__ import annotations

import contextlib
import os
import re
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import jax

from jaxga import interrupts
from jaxga._runtime.compilation_cache import configure, jax_cache_source
from jaxga._runtime.device_probe import DeviceDisagrees
from jaxga._runtime.jax_settings import check_jax_settings, check_platform, check_xla_flags
from jaxga._runtime.lowering import check_environment
from jaxga._runtime.parallel import (
    EXIT_PROCESS_LOST,
    ProcessLostError,
    configure_from_args,
)
from jaxga.cli.options import EXIT_BAD_INPUT, EXIT_DEVICE_DISAGREES, EXIT_NO_PATH, apply_scenario
from jaxga.cli.outputs import check_outputs, write_empty_path
from jaxga.cli.parser import build_parser, shortened
from jaxga.core.errors import EndpointError, JaxgaError, NoPathError
from jaxga.core.files import remove_temporaries
from jaxga.core.own_settings import own_settings

NEGATIVE_XY = re.compile(r"-[\d.]")


XY_OPTIONS = ("--start", "--goal", "--position", "--obstacles", "--start-world",
               "--goal-world", "--position-world", "--obstacles-world")


def join_negative_xy(argv: Sequence[str]) -> list[str]:
    """``--start -1,0`` as ``--start=-1,0``, ``--start-world -1.5,2`` as
    ``--start-world=-1.5,2`` (every coordinate option, cells or metres, and their
    abbreviations): argparse would take ``-1.5,2`` for an option and say "expected one
    argument" instead of reading the usual negative coordinates of a ROS map."""
    out: list[str] = []
    for arg in argv:
        option = out[-1] if out else ""
        takes_xy = len(option) > 3 and any(o.startswith(option) for o in XY_OPTIONS)
        if takes_xy and NEGATIVE_XY.match(arg):
            out[-1] = f"{out[-1]}={arg}"
        else:
            out.append(arg)
    return out


def one_line_warnings(show: Callable[..., None]) -> Callable[..., None]:
    """A ``warnings.showwarning`` that prints jaxga's own warnings (the categories of
    :mod:`jaxga.core.errors`) as one ``jaxga: warning: ...`` line, like its errors (Python's
    format adds the file and source line), JAX's warnings about compilation-cache entries
    as one such line per process naming the cache folder, and hands other warnings to
    ``show``."""

    said: set[str] = set()

    def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
        out = sys.stderr if file is None else file
        text = str(message)
        if category.__module__.split(".")[0] == "jaxga":
            print(f"jaxga: warning: {shortened(text)}", file=out)
        elif "compilation cache" in text and "jax" in str(filename):
            # JAX's multi-line warning for each cache entry it cannot read or write: one
            # line per process, naming the folder; the program is compiled instead
            if "cache" not in said:
                said.add("cache")
                folder = jax.config.jax_compilation_cache_dir
                why = text.split(": ", 1)[-1].splitlines()[0][:160]
                print(f"jaxga: warning: the compilation cache {folder} ({jax_cache_source()}) "
                      f"could not read or keep a program ({why}): such programs are "
                      "compiled and not kept", file=out)
        else:
            show(message, category, filename, lineno, file, line)

    return show_warning


@own_settings
def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``jaxga`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(join_negative_xy(sys.argv[1:] if argv is None else argv))
    try:
        with warnings.catch_warnings():
            warnings.showwarning = one_line_warnings(warnings.showwarning)
            check_working_folder()
            check_environment()  # $JAXGA_THREEFRY, which `import jaxga` does not refuse
            check_jax_settings()  # JAX_ENABLE_X64, JAX_DISABLE_JIT
            check_xla_flags()  # before the backend starts: XLA ends the process on a bad flag
            check_outputs(args)
            if hasattr(args, "devices"):  # subcommands with add_parallel_arguments
                configure_from_args(args)  # before JAX's backend starts
            check_platform()  # JAX_PLATFORMS naming a platform that is not there
            apply_scenario(args)  # after it: loading the map starts JAX
            if getattr(args, "compiles", False):  # run, doe, compare, warmup
                configure()
            return args.func(args)
    except ProcessLostError as e:
        # Exit at once: a normal exit would wait in jax.distributed's shutdown barrier
        # for the lost process (up to --process-timeout).
        print(f"jaxga: error: {shortened(str(e))}", file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(EXIT_PROCESS_LOST)
    except NoPathError as e:
        write_empty_path(args)  # found before the run: no stale path left to follow
        print(f"jaxga: no path: {shortened(str(e))}", file=sys.stderr)
        return EXIT_NO_PATH
    except DeviceDisagrees as e:
        print(f"jaxga: error: {shortened(str(e))}", file=sys.stderr)
        return EXIT_DEVICE_DISAGREES
    except EndpointError as e:
        print(f"jaxga: bad start or goal: {shortened(str(e))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except JaxgaError as e:
        print(f"jaxga: error: {shortened(str(e))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as e:
        print(shortened(f"jaxga: error: {e.strerror or e}: {e.filename or ''}".rstrip(": ")),
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("jaxga: interrupted", file=sys.stderr)
        return 130
    except Warning as e:  # made an error by python -W error or PYTHONWARNINGS=error
        print(f"jaxga: error: {shortened(str(e))} (a {type(e).__name__}, an error under "
              "-W error / PYTHONWARNINGS)", file=sys.stderr)
        return EXIT_BAD_INPUT


def check_working_folder() -> None:
    """Refuse, in one line, a working folder that no longer exists (removed after the
    shell entered it): every relative name, an output's or a cache's, would fail later
    with a bare "No such file or directory"."""
    try:
        os.getcwd()
    except FileNotFoundError:
        raise JaxgaError("the working folder no longer exists (it was removed after this "
                         "shell entered it): cd to a folder that exists") from None


def standard_streams() -> None:
    """A closed standard input, output or error (``jaxga run ... >&-``) opened on the null
    device: the output is lost, as asked, and the run does not fail for it. It also keeps
    the next file jaxga opens off descriptors 0-2, where a library's log line (XLA writes
    to descriptor 2) would land in a result file."""
    for fd, name, mode in ((0, "stdin", "r"), (1, "stdout", "w"), (2, "stderr", "w")):
        with contextlib.suppress(OSError):
            try:
                os.fstat(fd)
            except OSError:  # still closed: the null device takes the descriptor
                os.dup2(os.open(os.devnull, os.O_RDWR), fd)
            if getattr(sys, name) is None:  # Python found it closed when it started
                setattr(sys, name, open(os.devnull, mode))  # noqa: SIM115
    for name in ("stdout", "stderr"):  # `jaxga ... 2>&1 | head`: both meet the pipe
        stream = getattr(sys, name)
        if stream is not None and not isinstance(stream, ReaderMayLeave):
            setattr(sys, name, ReaderMayLeave(stream))


class ReaderMayLeave:
    """Standard output or error whose reader may leave before the end (``jaxga presets |
    head``), or that cannot be written (a full disk, ``>/dev/full``):
    at the first write or flush that fails, the descriptor is put on the null device and
    the command goes on to write its files; the rest of the output is lost, as when
    stdout is closed (``>&-``). A reader gone leaves the exit status the command's own; a
    stdout that could not be written is an error when the command ends
    (:func:`lost_output`). Python's own ``BrokenPipeError`` or ``OSError`` would end the
    command at once, or hide inside the report of another."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self.failure: OSError | None = None
        """The first error other than a reader gone (a full disk, a failing device)."""

    def _lost(self, err: OSError) -> None:
        if isinstance(err, BlockingIOError):  # a non-blocking stream that is full for now
            raise err
        if self.failure is None and not isinstance(err, BrokenPipeError):
            self.failure = err
        with contextlib.suppress(OSError, ValueError):
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._stream.fileno())
            os.close(null)

    def write(self, text: str) -> int:
        """Write ``text``; where the reader has gone, to the null device."""
        try:
            return self._stream.write(text)
        except OSError as e:
            self._lost(e)
            return len(text)

    def writelines(self, lines: Any) -> None:
        """Write each of ``lines`` (:meth:`write`)."""
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        """Flush; where the reader has gone, what the buffer held goes to the null device."""
        try:
            self._stream.flush()
        except OSError as e:
            self._lost(e)
            with contextlib.suppress(OSError, ValueError):
                self._stream.flush()  # what the buffer held goes to the null device

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def lost_output() -> str | None:
    """The one error line for a standard output that could not be written (a full disk),
    or None: the command's files are written, its output is not, so it did not do all it
    was asked."""
    out = sys.stdout
    failure = out.failure if isinstance(out, ReaderMayLeave) else None
    if failure is None:
        return None
    return (f"jaxga: error: standard output could not be written "
            f"({failure.strerror or failure}): the rest of it was lost (files were written)")


def console() -> None:
    """The ``jaxga`` console script: :func:`main`, then, in a single-process run, an exit
    that skips the interpreter's teardown of JAX (its backends and threads: about a third
    of a second a user would wait after the last line) once the output is flushed; every
    file jaxga writes is complete by then (written atomically). A run over several
    processes exits normally, through ``jax.distributed``'s shutdown. Ctrl-C and SIGTERM
    end it at once with 130 or 143 (:mod:`jaxga.interrupts`)."""
    interrupts.install(remove_temporaries)
    standard_streams()
    for stream in (sys.stdout, sys.stderr):  # a map named in Unicode, an ASCII terminal
        with contextlib.suppress(AttributeError, ValueError):
            stream.reconfigure(errors="backslashreplace")
    code = main()
    for stream in (sys.stdout, sys.stderr):  # a stream that cannot take it: said already
        with contextlib.suppress(OSError, ValueError):
            stream.flush()
    lost = lost_output()
    if lost is not None:
        with contextlib.suppress(OSError, ValueError):
            print(lost, file=sys.stderr, flush=True)
        code = code or EXIT_BAD_INPUT
    remove_temporaries()  # os._exit skips the interpreter's own exit handlers
    several = False
    with contextlib.suppress(Exception):  # several processes only through jax.distributed
        # (asked first: jax.process_count() would start a backend that never started)
        several = jax.distributed.is_initialized() and jax.process_count() > 1
    if several:
        sys.exit(code)
    os._exit(code)
