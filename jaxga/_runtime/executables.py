"""Compiled programs kept on disk whole, so that a later process neither traces, lowers
nor compiles them (decision 028).

JAX's persistent compilation cache (:mod:`jaxga._runtime.compilation_cache`) saves XLA's
compilation only: a later process still traces the Python functions and lowers them to
StableHLO to find the entry (decisions 014 and 028).
This store keeps each compiled program (``jax.experimental.serialize_executable``)
under a key made of everything the tracing depends on: the program's name, the
algorithm (operators, sizes, static settings), the shapes and static parts of the map and
of the parameters, the runs per call, the devices, the JAX, jaxlib and jaxga versions
(jaxga's by a digest of its source files, so an edited checkout never reads a stale
program), the lowering choice (:mod:`jaxga._runtime.lowering`) and ``XLA_FLAGS``. A program is
stored only when every operator it uses is one of jaxga's own: a user's operator
(registered in a notebook) can change without any of these, so its programs go through
JAX's cache alone, which keys on the lowered program.

The files live beside JAX's cache entries (``<cache dir>/jaxga-programs/``) and the store
is on and off with that cache. They are Python pickles that run code when loaded:
like JAX's own cache directory, it must be writable only by its user. A file that cannot
be read (truncated, written by another version) is ignored and compiled again; a program
read from it that fails to run has every program this process read deleted, and the call
runs again with programs compiled afresh (:func:`jaxga.api.runs.sweep`).

Processes that share the store compile each program once: :func:`load_or_compile` holds
a lock on the program's key (``fcntl.flock`` on a file under ``locks/``, released by the
system when a process ends, however it ends) while it compiles, and a process that needs
the same program meanwhile waits for it and then reads it (a DOE over several processes,
a notebook beside a command, a test suite's workers). The wait is bounded
(:data:`LOCK_WAIT_S`): after it, or where files cannot be locked, a process compiles the
program itself, as without the store. The process that holds a lock writes its host and
process id into the lock file: one waiting on the same host does not wait for a holder
that is stopped (Ctrl-Z, a paused notebook, a debugger) or gone, and after
:data:`LOCK_NOTE_S` it says, once, which process it waits for. The holder removes the
lock file when it is done (a process that was waiting for it finds the program stored).

The store is bounded (:func:`store_limit`, 4 GiB unless ``JAXGA_STORE_MAX_MB`` says
otherwise), together with JAX's entries where :func:`~jaxga._runtime.compilation_cache.configure`
turned JAX's cache on in the same folder: when a program is saved past it, the programs
used longest ago are removed (a program read from the store counts as used then), and
lock files a killed process left behind are removed with them. Every new jaxga version
or edited checkout keys its programs anew, so without a bound the store would only grow.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import pickle
import re
import socket
import stat
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import jax
import jaxlib
from jax.experimental.serialize_executable import deserialize_and_load, serialize

from jaxga._runtime.compilation_cache import (
    STORE_MAX_BYTES,  # noqa: F401 (the store's bound, with the store)
    is_read_only,
    jax_cache_folder,
    store_directory,
    store_limit,
)
from jaxga._runtime.lowering import jaxga_lowering, threefry_unrolled
from jaxga.core.errors import CacheWarning, JaxgaError
from jaxga.core.files import atomic_write
from jaxga.engine import chosen_operators
from jaxga.operators import registry

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: a program may be compiled twice
    fcntl = None

SUBDIRECTORY = "jaxga-programs"


@functools.lru_cache(maxsize=1)
def source_digest() -> str:
    """A digest of jaxga's Python source files (any edit changes it)."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.blake2b(digest_size=16)
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def directory() -> Path | None:
    """Where the programs are kept: under the cache folder
    (:func:`jaxga._runtime.compilation_cache.store_directory`); None without one."""
    base = store_directory()
    return None if base is None else Path(base) / SUBDIRECTORY


def _only_builtin_operators(algo: Any) -> bool:
    return all(op.fn is None or registry.is_jaxgas(op.fn)
               for op in chosen_operators(algo.config).values())


COMPILE_OPTIONS = ("jax_disable_most_optimizations", "jax_optimization_level",
                   "jax_exec_time_optimization_effort", "jax_memory_fitting_effort",
                   "jax_memory_fitting_level")
"""JAX settings that change the compiled program, part of every program's key."""


def _config_value(name: str) -> Any:
    try:
        return jax.config.read(name)
    except (AttributeError, KeyError):  # not in this JAX
        return None


def program_key(name: str, algo: Any, grid_spec: Any, params_spec: Any, n_runs: int,
                devices: Any, settings: Any = ()) -> str | None:
    """The file name of a program, or None when it is not to be stored (no cache
    directory, or an operator that is not jaxga's own; ``algo`` None: a program of no
    algorithm, such as the map tables). ``settings``: the values of the
    caller's module settings that shape the program (block sizes, compiler options)."""
    if directory() is None or (algo is not None and not _only_builtin_operators(algo)):
        return None
    leaves, tree = jax.tree_util.tree_flatten((grid_spec, params_spec))
    parts = (
        name, repr(algo), str(tree), repr(leaves),
        n_runs, settings, [(d.platform, d.device_kind, d.id) for d in devices],
        # in a run over several processes each process's program addresses its own
        # devices: one process must never read a program another one stored
        jax.process_count(), jax.process_index(),
        jax.__version__, jaxlib.__version__, source_digest(),
        threefry_unrolled(), os.environ.get("XLA_FLAGS", ""),
        # JAX's PRNG settings are not here: every draw of jaxga is pinned to JAX's
        # defaults (jaxga.core.prng), so they change no program
        jax.config.jax_enable_x64,
        # JAX's options that change what XLA compiles (jax.config.read: they may be
        # missing as attributes): a program compiled under one is not another's
        [(name, _config_value(name)) for name in COMPILE_OPTIONS],
    )
    return hashlib.blake2b(repr(parts).encode(), digest_size=20).hexdigest()


_CACHE_HITS = [0]


def _count_cache_hits(event: str, **_kwargs: Any) -> None:
    if event == "/jax/compilation_cache/cache_hits":
        _CACHE_HITS[0] += 1


jax.monitoring.register_event_listener(_count_cache_hits)


STORE_OPTION = "xla_debug_buffer_assignment_show_max"
"""An XLA debug option that only bounds the length of a debugging printout. A program
that JAX read from its own cache is compiled again with this option set to a random
value (:func:`compile_and_store`): JAX's cache key includes the compile options, so XLA
compiles it afresh, and what it compiles can be stored. A value drawn from the
program's key instead was itself in JAX's cache the second time the store lost that
program, which was then never stored again."""


def compile_and_store(key: str | None, lowered: Any, options: dict | None,
                      devices: Any) -> Any:
    """``lowered.compile(options)``, stored under ``key`` as a program for ``devices``.

    An XLA:CPU program that JAX read from its own persistent cache does not serialise
    whole (it loads but fails at run time: "Function ... not found"). JAX's cache holds
    a program the store lacks when the store's key changed and the program did not (a
    new jaxga version, a deleted store file): without a stored program every later
    process would trace and lower it again (seconds), so such a program is compiled
    once more, with :data:`STORE_OPTION` making JAX's cache miss, and that one is
    stored."""
    hits = _CACHE_HITS[0]
    program = lowered.compile(options)
    if key is not None and _CACHE_HITS[0] != hits:
        hits = _CACHE_HITS[0]
        fresh = int.from_bytes(os.urandom(6), "big")  # a key JAX's cache has never seen
        program = lowered.compile({**(options or {}), STORE_OPTION: fresh})
    if _CACHE_HITS[0] == hits:
        save(key, program, devices)
    return program


_READ: set[str] = set()
"""The keys of the programs this process has read from the store."""


_NOT_READ: set[str] = set()
"""Keys whose stored program failed to run and could not be deleted (a read-only store):
this process never reads them again, so that a call run again compiles them."""


def forget_read() -> bool:
    """Delete every stored program this process has read (after one failed to run), or,
    where the store takes no change, never read it again in this process; True if there
    were any (each key is read and forgotten at most once, so a retry ends)."""
    keys = list(_READ)
    _READ.clear()
    for key in keys:
        try:
            (directory() / f"{key}.pkl").unlink()
        except FileNotFoundError:  # already removed (another process, the store's bound)
            pass
        except OSError:
            _NOT_READ.add(key)
    return bool(keys)


STORE_FORMAT = 2
"""The layout of a stored program's file: a pickled dict of this format number, the
program's key, the devices it was compiled for, and the digest and bytes of the program
itself (JAX's serialised executable and its argument and result trees)."""


def _device_names(devices: Any) -> list[list]:
    return [[d.platform, d.device_kind, d.id] for d in devices]


def _entry_problem(entry: Any, key: str, devices: Any) -> str | None:
    """Why a stored entry is not the program ``key`` on ``devices`` (None when it is),
    decided before XLA reads any of it: XLA aborts the process on a program meant for
    other devices or shapes."""
    if not isinstance(entry, dict) or entry.get("format") != STORE_FORMAT:
        return "written by another version of jaxga"
    if entry.get("key") != key:
        return "holds another program (copied or renamed)"
    if entry.get("devices") != _device_names(devices):
        return f"was compiled for other devices ({entry.get('devices')!r})"
    blob = entry.get("program")
    if not isinstance(blob, bytes) or \
            hashlib.blake2b(blob, digest_size=20).hexdigest() != entry.get("digest"):
        return "is damaged (its digest does not match)"
    return None


_FORGOTTEN: set[tuple[str, str]] = set()
"""(store, reason) already said in this process: one line each, however many entries."""


def _forget(path: Path, why: str) -> None:
    """Remove a stored program that cannot be used, saying so in one line per store and
    reason (a store whose files were all swapped says it once)."""
    try:
        path.unlink()
        done = "removed"
    except FileNotFoundError:  # another process removed it first (its own read, the bound)
        done = "removed"
    except OSError:  # a read-only store
        done = "left in place (the store takes no changes)"
    if (str(path.parent), why) in _FORGOTTEN:
        return
    _FORGOTTEN.add((str(path.parent), why))
    warnings.warn(f"the stored program {path.name} in {path.parent} {why}: {done}, "
                  "compiling it again (so is any other entry of the store like it)",
                  CacheWarning, stacklevel=4)


def load(key: str | None, devices: Any) -> Any | None:
    """The compiled program stored under ``key`` on these devices, or None.

    The entry's format, key, devices and digest are checked first
    (:func:`_entry_problem`); an entry that fails a check or does not load is removed
    with one warning line naming the store, and the program is compiled again."""
    if key is None or key in _NOT_READ:
        return None
    path = directory() / f"{key}.pkl"
    if not path.is_file():
        return None
    try:
        with open(path, "rb") as f:
            entry = pickle.load(f)
    except FileNotFoundError:  # gone since: another process's bound removed it
        return None
    except Exception:  # noqa: BLE001 - any unreadable file is compiled again
        _forget(path, "cannot be read")
        return None
    why = _entry_problem(entry, key, devices)
    if why is not None:
        _forget(path, why)
        return None
    try:
        payload, in_tree, out_tree = pickle.loads(entry["program"])
        program = deserialize_and_load(payload, in_tree, out_tree,
                                       execution_devices=list(devices))
    except Exception:  # noqa: BLE001 - an entry XLA refuses is compiled again
        _forget(path, "does not load on these devices")
        return None
    _READ.add(key)
    with contextlib.suppress(OSError):  # used now: the last the bound removes
        os.utime(path)
    return program


_JAX_ENTRY = re.compile(r".+-[0-9a-f]{64}-cache")
"""The name of an entry of JAX's persistent cache: the module's name, its key's SHA-256
in hex, ``-cache`` (``jax._src.cache_key.get``, ``jax._src.lru_cache``)."""


def _prune(folder: Path, kept: Path) -> None:
    """Remove the programs used longest ago until the store, with JAX's entries where
    jaxga turned JAX's cache on in the folder above it (:func:`jax_cache_folder`), is
    within :func:`store_limit` (never ``kept``, the one just saved), and lock files older
    than an hour that no process holds (left by a killed process). A stored program's
    time is its last use (:func:`load` renews it); a JAX entry's is the later of its
    access and modification times (JAX renews neither without its own bound)."""
    limit = store_limit()
    entries = []
    kinds = [(folder, "*.pkl", False)]
    jax_folder = jax_cache_folder()
    if jax_folder is not None and Path(jax_folder) == folder.parent:
        kinds.append((folder.parent, "*-cache", True))
    for where, pattern, accessed in kinds:
        with contextlib.suppress(OSError):
            for p in where.glob(pattern):
                if accessed and not _JAX_ENTRY.fullmatch(p.name):
                    continue  # not JAX's: a user's file in a folder they share with it
                with contextlib.suppress(OSError):
                    st = p.lstat()
                    if stat.S_ISREG(st.st_mode):
                        used = max(st.st_mtime, st.st_atime) if accessed else st.st_mtime
                        entries.append((used, st.st_size, p))
    total = sum(size for _, size, _ in entries)
    for _, size, p in sorted(entries, key=lambda e: e[0]):
        if total <= limit:
            break
        if p == kept:
            continue
        with contextlib.suppress(OSError):
            p.unlink()
            total -= size
            if p.parent != folder:  # JAX's access-time note, where its own bound keeps one
                with contextlib.suppress(OSError):
                    p.with_name(p.name.removesuffix("-cache") + "-atime").unlink()
    if fcntl is None:
        return
    old = time.time() - 3600.0
    with contextlib.suppress(OSError):
        for lock in (folder / "locks").glob("*.lock"):
            with contextlib.suppress(OSError):
                if lock.lstat().st_mtime > old or not stat.S_ISREG(lock.lstat().st_mode):
                    continue
                fd = os.open(lock, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # no one holds it
                    lock.unlink()
                finally:
                    os.close(fd)


LOCK_WAIT_S = 300.0
"""The longest a process waits for another one compiling the same program (a whole GA
compiles in well under a minute; a process stuck for longer is not waited for)."""

LOCK_NOTE_S = 10.0
"""After this long waiting for another process's compile, a waiting process says which
process it waits for (one :class:`~jaxga.core.errors.CacheWarning`): the wait is not a
compile of its own."""


def _holder(lock: Path) -> tuple[str, int] | None:
    """``(host, process id)`` written in a lock file by the process holding it, or None
    (not written yet, or unreadable)."""
    try:  # without blocking, a regular file only: a FIFO there would block for good
        fd = os.open(lock, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                return None
            words = os.read(fd, 256).decode("ascii", errors="replace").split()
        finally:
            os.close(fd)
        return words[0], int(words[1])
    except (OSError, IndexError, ValueError):
        return None


def _stopped_or_gone(pid: int) -> bool:
    """Whether process ``pid`` of this host is stopped (``T``: Ctrl-Z, SIGSTOP; ``t``: a
    debugger), a zombie, or gone: it compiles nothing (Linux's ``/proc``; False where it
    cannot be told)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return Path("/proc/self").exists()  # gone, where /proc is there to tell
    except (OSError, IndexError):
        return False
    return state in ("T", "t", "Z", "X")


_THREAD_LOCKS: dict[str, threading.Lock] = {}
_THREAD_LOCKS_GUARD = threading.Lock()


@contextlib.contextmanager
def _compiling(key: str | None) -> Iterator[None]:
    """Hold this process's lock on ``key``, then the store's (:func:`_compiling_here`):
    threads of one process that need the same program wait for each other on the first,
    without a word (a file lock would have one thread wait for "another process", its
    own); each of the two waits lasts at most :data:`LOCK_WAIT_S`."""
    if key is None:
        yield
        return
    with _THREAD_LOCKS_GUARD:
        lock = _THREAD_LOCKS.setdefault(key, threading.Lock())
    got = lock.acquire(timeout=LOCK_WAIT_S)
    try:
        with _compiling_here(key):
            yield
    finally:
        if got:
            lock.release()


@contextlib.contextmanager
def _compiling_here(key: str) -> Iterator[None]:
    """Hold the store's lock on ``key`` (module docstring); nothing when there is no
    ``fcntl`` (not POSIX) or the lock file cannot be made."""
    if fcntl is None:
        yield
        return
    try:
        folder = directory() / "locks"
        folder.mkdir(parents=True, exist_ok=True)
        # without blocking: a FIFO put in the lock file's place would block open() for
        # good; anything but a regular file is not used as a lock
        lock = folder / f"{key}.lock"
        fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_APPEND
                     | getattr(os, "O_NONBLOCK", 0), 0o644)
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            os.close(fd)
            raise OSError(f"{key}.lock is not a regular file")
        # unbuffered: a note that a full disk refuses fails where it is written (and is
        # let go), never again when the file is closed
        handle = os.fdopen(fd, "ab", buffering=0)
    except OSError:
        yield
        return
    with handle:
        locked, start, looked, noted = False, time.monotonic(), 0.0, False
        here = socket.gethostname()
        while True:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                locked = True
                with contextlib.suppress(OSError):  # who holds it, for those who wait
                    handle.truncate(0)
                    handle.write(f"{here} {os.getpid()}\n".encode())
                break
            except BlockingIOError:  # another process compiles it: wait (interruptibly)
                waited = time.monotonic() - start
                if waited > LOCK_WAIT_S:
                    break
                if waited - looked >= 1.0:  # is the holder compiling at all?
                    looked = waited
                    holder = _holder(lock)
                    if holder is not None and holder[0] == here and \
                            _stopped_or_gone(holder[1]):
                        break  # stopped (Ctrl-Z) or gone: compile it here
                    if waited >= LOCK_NOTE_S and not noted \
                            and holder != (here, os.getpid()):
                        noted = True
                        who = "another process" if holder is None else \
                            f"process {holder[1]} on {holder[0]}"
                        warnings.warn(
                            f"waiting for {who}, which compiles the same program (jaxga's "
                            f"program store; at most {LOCK_WAIT_S:.0f} s, then this process "
                            "compiles it itself)", CacheWarning, stacklevel=6)
                time.sleep(0.05)
            except OSError:  # a file system without locks
                break
        try:
            yield
        finally:
            if locked:
                # done: the program is stored (or this process failed, and a waiting one
                # compiles it); the file goes first, so the store keeps no lock per program
                with contextlib.suppress(OSError):
                    lock.unlink()
                fcntl.flock(handle, fcntl.LOCK_UN)


def load_or_compile(key: str | None, devices: Any, lower: Callable[[], Any],
                    options: dict | None = None) -> tuple[Any, bool]:
    """The program stored under ``key``, else ``lower()`` (in jaxga's lowering scope:
    :func:`jaxga._runtime.lowering.jaxga_lowering`) compiled and stored; and whether it was
    read. The compilation holds the key's lock, so that processes sharing the store
    compile it once (module docstring): one that waited reads what the other stored."""
    if key is not None:
        store_limit()  # a bound that is not a number is refused before a compile
    program = load(key, devices)
    if program is not None:
        return program, True
    with _compiling(key):
        program = load(key, devices)  # stored by another process while this one waited
        if program is not None:
            return program, True
        with jaxga_lowering():  # jaxga's own lowering rules, for this program only
            lowered = lower()
        return compile_and_store(key, lowered, options, devices), False


def save(key: str | None, compiled: Any, devices: Any) -> None:
    """Store a program compiled for ``devices`` under ``key`` (atomically), with its key,
    devices and digest (:data:`STORE_FORMAT`). Nothing when the program cannot be
    serialised; when the store cannot take the file (an entry replaced by a folder, a
    full disk), one :class:`~jaxga.core.errors.CacheWarning` per store names the file
    and the cause: every process compiles that program again until it is mended."""
    if key is None:
        return
    try:
        program = pickle.dumps(serialize(compiled))
    except Exception:  # noqa: BLE001 - a program that cannot be serialised is only compiled
        return
    blob = pickle.dumps({
        "format": STORE_FORMAT, "key": key, "devices": _device_names(devices),
        "digest": hashlib.blake2b(program, digest_size=20).hexdigest(),
        "program": program})
    folder = directory()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write(folder / f"{key}.pkl", lambda f: f.write(blob), binary=True)
    except (OSError, JaxgaError) as e:
        _cannot_keep(folder, e)
        return
    _prune(folder, folder / f"{key}.pkl")


_CANNOT_KEEP: set[str] = set()
"""The stores this process has said it cannot write to."""


def _cannot_keep(folder: Path, error: Exception) -> None:
    if str(folder) in _CANNOT_KEEP or is_read_only(folder.parent):
        return  # said once (a read-only cache folder: when it was chosen)
    _CANNOT_KEEP.add(str(folder))
    why = str(error) if isinstance(error, JaxgaError) else f"{folder}: {error.strerror or error}"
    warnings.warn(f"a compiled program could not be kept in the program store ({why}): "
                  "each process compiles it again", CacheWarning, stacklevel=4)
