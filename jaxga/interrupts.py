"""Ctrl-C and ``kill``: the command line stops at once, with 130 or 143, leaving no file half
written (decision 033).

Python runs a signal handler only between bytecodes of the main thread, so a process busy in
XLA's compiler or in a long NumPy call would notice Ctrl-C only when that call returns
(seconds to minutes), and a normal exit would then tear JAX down under threads still
compiling. :func:`install` therefore also hands each signal to a watcher thread through
:func:`signal.set_wakeup_fd`; whichever notices first ends the process with
:func:`os._exit` after removing the temporary files of writes in progress
(the ``cleanup`` given to :func:`install`: :func:`jaxga.core.files.remove_temporaries`).
Every file jaxga writes is renamed into place whole (:func:`jaxga.core.files.atomic_write`),
so the previous file, a finished DOE point or a stored program is either there whole or
not there at all, and a DOE resumes from its checkpoint.

Only the ``jaxga`` console script installs this, as the first thing ``import jaxga`` does
in that process (:func:`install_in_console_script`: a Ctrl-C during the imports is handled
too); the Python API leaves signals alone. The module uses the standard library only, so
that it loads before JAX.
"""

from __future__ import annotations

import os
import signal
import socket
import sys
import threading
from collections.abc import Callable
from pathlib import Path

__all__ = ["EXIT_CODES", "in_console_script", "install", "install_in_console_script", "stop"]

EXIT_CODES: dict[int, int] = {signal.SIGINT: 130, signal.SIGTERM: 143}
"""The exit status for each handled signal: 128 + its number, as a shell reports it
(SIGHUP, SIGXCPU, SIGUSR1 and SIGUSR2 too where they exist). A signal the parent set to be
ignored (``nohup``, a shell's background job) stays ignored."""

_WORDS = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}
# not on Windows: a closed terminal; a CPU-time limit (``ulimit -t``, a batch queue's);
# the warning signals of schedulers (Slurm's --signal, SGE's -notify), whose default
# ends the process with no word and its temporary files left behind
for _name, _word in (("SIGHUP", "hung up"), ("SIGXCPU", "CPU time limit reached"),
                     ("SIGUSR1", "stopped by SIGUSR1"), ("SIGUSR2", "stopped by SIGUSR2")):
    if hasattr(signal, _name):
        _signum = getattr(signal, _name)
        EXIT_CODES[_signum] = 128 + _signum
        _WORDS[_signum] = _word
_ONCE = threading.Lock()
_WAKEUP: list[socket.socket] = []  # the socket pair of install(), kept open with the process
_CLEANUP: list[Callable[[], None]] = []


def stop(signum: int) -> None:
    """End the process for signal ``signum``: one line on stderr, the temporary files of
    writes in progress removed, exit status :data:`EXIT_CODES` (no interpreter teardown:
    nothing is left to flush but the standard streams)."""
    if not _ONCE.acquire(blocking=False):  # the other path is already ending the process
        threading.Event().wait()
    for cleanup in _CLEANUP:
        try:
            cleanup()
        except Exception:  # noqa: BLE001, S110 - exiting anyway: nothing to report it to
            pass
    try:
        sys.stdout.flush()
    except (OSError, ValueError):  # a closed pipe or stream: nothing left to say there
        pass
    try:
        print(f"jaxga: {_WORDS.get(signum, 'stopped')}", file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass
    os._exit(EXIT_CODES.get(signum, 128 + signum))


def _on_signal(signum: int, frame: object) -> None:
    stop(signum)


def _watch(reader: socket.socket) -> None:
    while True:
        try:
            data = reader.recv(16)
        except OSError:
            return
        for signum in data:
            if signum in EXIT_CODES:
                stop(signum)


def install(cleanup: Callable[[], None] | None = None) -> None:
    """Make the signals of :data:`EXIT_CODES` end the process promptly (:func:`stop`), even
    while the main thread is inside a long native call; ``cleanup`` (if given) runs first on
    such an exit. A signal this process inherited as ignored is left ignored. Installs once
    (a later call only sets ``cleanup``); from the main thread only."""
    if cleanup is not None:
        _CLEANUP[:] = [cleanup]
    if _WAKEUP or threading.current_thread() is not threading.main_thread():
        return
    reader, writer = socket.socketpair()
    writer.setblocking(False)
    signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)
    for signum in EXIT_CODES:
        if signal.getsignal(signum) is not signal.SIG_IGN:  # nohup's, a background job's
            signal.signal(signum, _on_signal)
    threading.Thread(target=_watch, args=(reader,), name="jaxga-signals", daemon=True).start()
    _WAKEUP[:] = [reader, writer]


def install_in_console_script() -> None:
    """:func:`install` when this process is the ``jaxga`` console script (``sys.argv[0]``
    names it), so that a signal during the imports already exits cleanly; nothing in any
    other program."""
    if in_console_script():
        install()


def in_console_script() -> bool:
    """Whether this process is the ``jaxga`` command (its script, ``python -m jaxga`` or
    ``python -m jaxga.cli``), also while ``import jaxga`` runs."""
    return _is_console_script(sys.argv, getattr(sys, "orig_argv", []))


def _is_console_script(argv: list[str], orig_argv: list[str]) -> bool:
    """The ``jaxga`` script, or ``python -m jaxga.cli`` (whose ``sys.argv[0]`` is still
    ``-m`` while the package loads: the interpreter's own arguments say which module)."""
    if argv and Path(argv[0]).name in ("jaxga", "jaxga.exe"):
        return True
    # the interpreter's own arguments end with "-m MODULE"; the program's own follow
    # (``python script.py -m jaxga`` is not the command)
    head = orig_argv[:len(orig_argv) - len(argv) + 1] if argv else orig_argv
    return len(head) >= 2 and head[-2] == "-m" and head[-1] in ("jaxga.cli", "jaxga")
