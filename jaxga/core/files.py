"""Files jaxga writes: atomically, checked before the work, never over an input.

Every result file (run and DOE JSON, plots, path exports, DOE checkpoints) is written to a
temporary file beside its target, flushed to disk, then renamed over the target
(:func:`atomic_write`): an interrupt, a full disk or any other failure leaves the previous
file whole, removes the temporary file, and raises one line that names the path.

:func:`check_outputs` is run before any work (decision 033): each output must be
writable where it is (its folder must take a new file: probed, not guessed from the mode
bits, so that a read-only mount, ``/proc`` or an immutable file is refused at once), must
not be a folder, and must not be the same file as an input or as another output.
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import functools
import hashlib
import os
import re
import secrets
import shutil
import socket
import stat
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import IO, Any

from jaxga.core.errors import JaxgaError
from jaxga.core.fields import shown_value

__all__ = ["NAME_MAX", "atomic_write", "atomic_write_text", "check_outputs", "file_path",
           "folder_problem", "remove_stale_temporaries", "remove_temporaries", "same_file",
           "temporary_folder", "written_file"]

PACKAGE = Path(__file__).resolve().parents[1]
"""jaxga's own folder: no writer replaces a file in it (a built-in map, a module)."""

_TEMPORARIES: set[str] = set()
_LOCK = threading.RLock()  # reentrant: a signal's cleanup may run in the thread holding it


def _why(err: OSError) -> str:
    if err.errno == errno.ENOSPC:
        return "no space left on the device (the previous file, if any, is unchanged)"
    return err.strerror or str(err)


def atomic_write(path: str | os.PathLike, write: Callable[[IO], None], *,
                 binary: bool = False) -> None:
    """Write a file through ``write(f)`` on a temporary file beside ``path``, flushed and
    synced, then renamed over ``path`` (over the file it names, when ``path`` is a symbolic
    link: the link stays).

    A failure (an ``OSError`` such as a full disk, an exception from ``write``, an
    interrupt) removes the temporary file and leaves any previous ``path`` whole; an
    ``OSError`` becomes a :class:`JaxgaError` naming ``path``. A ``path`` that is, or
    links to, a process's stream (``/dev/stdout``, ``/proc/self/fd/1``) is refused: the
    rename would replace the file the stream is redirected to, and so is a file inside
    jaxga's own folder (:data:`PACKAGE`: a built-in map, a module). While the file is being
    written its temporary name (``.NAME.<pid>.<machine>.<random>.tmp``) is registered,
    so that a process ended by a signal removes it first (:func:`remove_temporaries`); one that a
    process killed outright left is removed by the next write of the same file
    (:func:`remove_stale_temporaries`)."""
    path = file_path(path, "a file to write")
    _refuse_unwritable_name(path)
    try:
        _refuse_long_name(f"{path}", Path(path))
        _refuse_stream(f"{path}", Path(path))
        target = written_file(path)
        _refuse_long_name(f"{path}", target)
        if PACKAGE in target.resolve().parents:  # save_map over a built-in map's file
            raise JaxgaError(f"cannot write {path}: it is inside jaxga's own folder "
                             f"{PACKAGE} (its code, built-in maps and presets)")
        folder = target.parent if str(target.parent) else Path(".")
        remove_stale_temporaries(target)
        fd, tmp = _new_temporary(
            folder, f"{_temporary_stem(target.name)}{os.getpid()}.{this_machine()}.")
    except OSError as e:  # a folder in the path that is a file, a path too long, ...
        raise JaxgaError(f"cannot write {path}: {_why(e)}") from None
    try:
        os.fchmod(fd, _mode_of(target))  # mkstemp's 0600 would make every output private
        with os.fdopen(fd, "wb" if binary else "w", **({} if binary else
                                                         {"encoding": "utf-8"})) as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, target)
    except BaseException as e:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(e, OSError):
            raise JaxgaError(f"cannot write {path}: {_why(e)}") from None
        raise
    finally:
        with _LOCK:
            _TEMPORARIES.discard(tmp)


def _new_temporary(folder: Path, prefix: str) -> tuple[int, str]:
    """Create ``folder/<prefix><8 random hex digits>.tmp`` (new, mode 0600) and register
    it for :func:`remove_temporaries` BEFORE it exists, so that a signal at any moment
    finds every temporary file it must remove (registering after ``mkstemp`` left one
    behind when the signal came in between). The caller unregisters it."""
    for _ in range(100):
        tmp = os.path.join(folder, f"{prefix}{secrets.token_hex(4)}.tmp")
        with _LOCK:
            _TEMPORARIES.add(tmp)
        try:
            flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
            return os.open(tmp, flags, 0o600), tmp
        except FileExistsError:  # another write's name: draw again
            with _LOCK:
                _TEMPORARIES.discard(tmp)
        except BaseException:
            with _LOCK:
                _TEMPORARIES.discard(tmp)
            raise
    raise FileExistsError(errno.EEXIST, f"no free temporary name in {folder}")


NAME_MAX = 255
"""The bytes a file's name can have on Linux's and macOS's file systems."""


def _temporary_stem(name: str) -> str:
    """``.NAME.``, the start of a write's temporary name
    (``.NAME.<pid>.<machine>.<random>.tmp``), with ``NAME`` cut short where the whole would
    pass :data:`NAME_MAX` bytes: a name of up to 255 bytes can be written."""
    # a pid of <= 20 digits, the machine's 8 and the random 8
    room = NAME_MAX - len("..") - 20 - len(".") - 8 - len(".") - 8 - len(".tmp")
    whole = os.fsencode(name)
    if len(whole) <= room:
        return f".{name}."
    return f".{whole[:room].decode('utf-8', 'ignore')}."  # cut at a whole character


def written_file(path: str | os.PathLike) -> Path:
    """The file a write of ``path`` replaces: the file a symbolic link names (every link
    followed; the link stays a link), else ``path`` itself."""
    target = Path(path)
    return Path(os.path.realpath(target)) if target.is_symlink() else target


def _mode_of(target: Path) -> int:
    """The permission bits a written file gets: the replaced file's, else what ``open``
    gives a new file (0666 less the process's umask)."""
    with contextlib.suppress(OSError):
        return stat.S_IMODE(os.stat(target).st_mode)
    with _LOCK:  # os.umask only reads the mask by setting it
        mask = os.umask(0o022)
        os.umask(mask)
    return 0o666 & ~mask


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`)."""
    atomic_write(path, lambda f: f.write(text))


_TEMPORARY = re.compile(r"(?:(\d+)\.)?(?:([0-9a-f]{8})\.)?[a-z0-9_]{8}")
"""The middle of a temporary file's name, ``.NAME.<pid>.<machine>.<random>.tmp``: the
writing process, its machine (:func:`this_machine`) and eight random characters
(hexadecimal digits). Older versions wrote ``<pid>.<random>``, and before that
:func:`tempfile.mkstemp`'s random characters alone."""

OLD_TEMPORARY_S = 3600.0
"""A temporary file whose process cannot be asked (another machine's or container's, or
an older version's name) is left by a killed write once it is this old (seconds)."""


@functools.cache
def this_machine() -> str:
    """Eight hexadecimal digits naming the process table a pid belongs to: this host's
    name and machine id, its boot and its pid namespace (each where the system has it).
    Two writers of one file in a shared folder (an NFS home seen from cluster nodes, a
    volume of two containers) see other process tables: a pid in a temporary name is
    asked only of the machine that wrote it, so a live write elsewhere is never taken for
    a killed one here."""
    parts = [socket.gethostname()]
    for read in (lambda: Path("/etc/machine-id").read_text(),
                 lambda: Path("/proc/sys/kernel/random/boot_id").read_text(),
                 lambda: os.readlink("/proc/self/ns/pid")):
        try:
            parts.append(read().strip())
        except OSError:
            parts.append("")
    return hashlib.sha256("\0".join(parts).encode("utf-8", "replace")).hexdigest()[:8]


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):  # another user's process, or no way to know
        return True
    return True


def remove_stale_temporaries(path: str | os.PathLike) -> list[str]:
    """Remove the temporary files of writes of ``path`` that a killed process left
    (``kill -9`` ends a process before it can remove them, :func:`remove_temporaries`):
    those of this machine (:func:`this_machine`) whose writing process has ended, and
    those of another machine, or of an older version, older than :data:`OLD_TEMPORARY_S`.
    A write in progress in another process, here or elsewhere, is left alone. Returns the
    names removed; every failure is ignored (the write that follows names its own)."""
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    prefix = _temporary_stem(target.name)
    removed: list[str] = []
    try:
        entries = [e for e in os.scandir(folder)
                   if e.name.startswith(prefix) and e.name.endswith(".tmp")]
    except OSError:
        return removed
    for entry in entries:
        match = _TEMPORARY.fullmatch(entry.name[len(prefix):-len(".tmp")])
        if match is None or entry.path in _TEMPORARIES:
            continue
        try:
            if match.group(1) is not None and match.group(2) == this_machine():
                stale = not _alive(int(match.group(1)))
            else:
                stale = time.time() - entry.stat().st_mtime > OLD_TEMPORARY_S
            if stale and entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(entry.name)
        except (OSError, ValueError, OverflowError):
            continue
    return removed


_FOLDERS: list[str] = []


def temporary_folder(prefix: str) -> Path:
    """A new folder in the temporary directory, removed with everything in it by
    :func:`remove_temporaries` (the ``jaxga`` command's exit, a signal) or at the
    interpreter's exit. Its name is registered before the folder is made (as
    :func:`atomic_write`'s temporary files are), so a signal at any moment leaves none
    behind."""
    with _LOCK:
        if not _FOLDERS:
            atexit.register(remove_temporaries)
    for _ in range(100):
        folder = os.path.join(tempfile.gettempdir(), f"{prefix}{secrets.token_hex(6)}")
        with _LOCK:
            _FOLDERS.append(folder)
        try:
            os.mkdir(folder, 0o700)
            return Path(folder)
        except BaseException as e:
            with _LOCK, contextlib.suppress(ValueError):
                _FOLDERS.remove(folder)
            if not isinstance(e, FileExistsError):  # another folder's name: draw again
                raise
    raise FileExistsError(errno.EEXIST, f"no free folder name in {tempfile.gettempdir()}")


def remove_temporaries() -> None:
    """Remove the temporary files of writes still in progress and the folders of
    :func:`temporary_folder`: what a process ends with, also when ended by a signal, so
    that it leaves no ``.NAME.*.tmp`` or temporary folder behind."""
    with _LOCK:
        names = list(_TEMPORARIES)
        folders = list(_FOLDERS)
        _FOLDERS.clear()
    for name in names:
        with contextlib.suppress(OSError):
            os.unlink(name)
    for folder in folders:
        shutil.rmtree(folder, ignore_errors=True)


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two paths name one file: the same inode where both exist (hard and symbolic
    links included), else the same absolute path once symbolic links are resolved."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):  # one is missing, or a name no file can have
        pass
    try:
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, ValueError):  # a NUL or a lone surrogate (impossible_name)
        return os.path.abspath(a) == os.path.abspath(b)


def home_folder() -> Path | None:
    """The user's home folder, or None where it is not known (no ``$HOME`` and no entry
    in the password database: a container's arbitrary user) or is not an absolute path (a
    relative ``$HOME`` would put jaxga's folders under every working folder)."""
    try:
        home = Path.home()
    except (RuntimeError, KeyError, OSError):
        return None
    return home if home.is_absolute() else None


def jaxga_cache_home(name: str) -> Path | None:
    """``~/.cache/jaxga/<name>``, where jaxga keeps what it remembers between processes,
    or None without a known home folder (:func:`home_folder`)."""
    home = home_folder()
    return None if home is None else home / ".cache" / "jaxga" / name


def file_path(path: Any, what: str = "a file",
              error: type[JaxgaError] = JaxgaError) -> Path:
    """``path`` (a ``str`` or an ``os.PathLike`` such as :class:`pathlib.Path`) as a
    :class:`~pathlib.Path`, or one ``error`` line (a :class:`JaxgaError`, or the one its
    caller documents) naming ``what`` and what was given: bytes, numbers, None and other
    objects are not file names here."""
    name = os.fspath(path) if isinstance(path, os.PathLike) else path
    if not isinstance(name, str):
        raise error(f"the name of {what} must be a str or a pathlib.Path, got "
                    f"{shown_value(path)}")
    return Path(name)


def impossible_name(path: str | os.PathLike) -> str | None:
    """Why no file system can hold ``path``, or None: a NUL character, or a lone surrogate
    the file system encoding cannot write (``os``'s ValueError or UnicodeEncodeError
    otherwise). Readers and writers refuse such a path in one line with it."""
    name = os.fspath(path)
    if isinstance(name, bytes):
        return None
    if "\0" in name:
        return "a file name cannot hold a NUL character"
    try:
        os.fsencode(name)
    except UnicodeEncodeError as e:
        return (f"no file can have this name (it holds {e.object[e.start:e.end]!r}, which "
                "no file system encoding writes)")
    return None


def shown_name(text: str) -> str:
    """``text`` printable on one line whatever it holds: each control character or lone
    surrogate written as Python escapes it (``\\x00``, ``\\ud83d``), every other
    character, backslashes and quotes included, as it is."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)


def _refuse_unwritable_name(path: str | os.PathLike, option: str = "") -> None:
    """Refuse, naming it (and the ``option`` that gave it), a path no file system can
    hold (:func:`impossible_name`)."""
    why = impossible_name(path)
    if why is not None:
        what = f"{option} " if option else ""
        raise JaxgaError(f"cannot write {what}{shown_name(os.fspath(path))}: {why}")


def _refuse_long_name(what: str, path: Path) -> None:
    """Refuse to write ``what`` where the file's name (the last part of ``path``) is
    longer than :data:`NAME_MAX` bytes: no file system takes it (``ENAMETOOLONG``)."""
    size = len(os.fsencode(path.name))
    if size > NAME_MAX:
        raise JaxgaError(f"cannot write {what}: its name has {size} bytes, more than the "
                         f"{NAME_MAX} a file's name can have")


def _refuse_stream(what: str, path: Path) -> None:
    """Refuse to write ``what`` where ``path`` exists and is, or leads to, a process's
    stream or a device (:func:`_stream_hop`)."""
    stream = _stream_hop(path) if path.exists() else None
    if stream is not None:
        raise JaxgaError(f"cannot write {what}: it names {stream}, a stream or device, not a "
                         "file (the file it is redirected to would be replaced, not appended "
                         "to): give a file's name")


def _stream_hop(path: Path) -> str | None:
    """The first name that ``path`` is or leads to through its symbolic links which is a
    process's stream or a device (an entry of ``/dev`` itself, such as ``/dev/stdout``, or
    anything under ``/proc``, such as ``/proc/self/fd/1``), or None: a write through it
    would replace the file the stream is redirected to. Files in ``/dev``'s folders
    (``/dev/shm``) are files."""
    hop, seen = Path(os.path.abspath(path)), set()
    while hop not in seen:
        seen.add(hop)
        parent = os.path.realpath(hop.parent)
        if parent == "/dev" or f"{parent}/".startswith("/proc/"):
            return str(hop)
        if not hop.is_symlink():
            return None
        try:
            hop = Path(os.path.abspath(hop.parent / os.readlink(hop)))
        except OSError:
            return None
    return None


def folder_problem(folder: str | os.PathLike) -> str | None:
    """Why a new file cannot be made in ``folder``, or None when it can (a real try: mode
    bits lie for root, ``/proc`` and read-only mounts)."""
    folder = Path(folder)
    try:  # not Path.is_dir: it raises for a name too long or a folder out of reach
        is_folder = stat.S_ISDIR(os.stat(folder).st_mode)
    except (FileNotFoundError, NotADirectoryError):
        is_folder = False
    except OSError as e:  # a name too long, a loop of links, no search permission
        return f"folder {str(folder)!r} cannot be used ({_why(e)})"
    if not is_folder:
        return f"folder {str(folder)!r} does not exist"
    try:
        fd, tmp = _new_temporary(folder, ".jaxga-probe.")
    except OSError as e:
        return f"folder {str(folder)!r} is not writable ({_why(e)})"
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)
    with _LOCK:
        _TEMPORARIES.discard(tmp)
    return None


def check_outputs(outputs: Mapping[str, str | os.PathLike | None],
                  inputs: Iterable[tuple[str, str | os.PathLike | None]] = ()) -> None:
    """Refuse, in one line, outputs that cannot be written or would destroy something.

    Args:
        outputs: what each output option names (``{"--json": "run.json", ...}``); None or
            empty entries are skipped.
        inputs: ``(label, path)`` of every file the command reads (the map, a ROS map's
            image, a scenario, a path JSON, a preset TOML); None entries are skipped.

    Raises:
        JaxgaError: an output that is a folder, whose folder is missing or takes no new
            file, that exists and cannot be replaced, or that is the same file as an input
            or as another output.
    """
    for option, path in outputs.items():
        if path is not None and not str(path).strip():
            raise JaxgaError(f"cannot write {option}: the file name is empty")
    given = [(option, Path(path)) for option, path in outputs.items() if path]
    sources = [(label, Path(path)) for label, path in inputs if path]
    for i, (option, path) in enumerate(given):
        try:
            _check_output(option, path, given[:i], sources)
        except OSError as e:  # a folder's name too long, a loop of links, ...
            raise JaxgaError(f"cannot write {option} {path}: {_why(e)}") from None


def _check_output(option: str, path: Path, earlier_outputs: list,
                  sources: list) -> None:
    """:func:`check_outputs` of one output, after ``earlier_outputs``."""
    _refuse_unwritable_name(path, option)
    _refuse_long_name(f"{option} {path}", path)
    if path.is_dir():
        raise JaxgaError(f"cannot write {option} {path}: it is a folder")
    if path.exists() and not path.is_file():
        raise JaxgaError(f"cannot write {option} {path}: it exists and is not a regular "
                         "file (a device, a FIFO or a socket)")
    _refuse_stream(f"{option} {path}", path)
    for label, source in sources:
        if same_file(path, source):
            raise JaxgaError(f"cannot write {option} {path}: it is the {label} this "
                             "command reads")
    for other, earlier in earlier_outputs:
        if same_file(path, earlier):
            raise JaxgaError(f"cannot write {option} {path}: {other} names the same "
                             "file")
    target = written_file(path)
    shown = f"{path}" if target == path else f"{path} (a link to {target})"
    folder = target.parent if str(target.parent) else Path(".")
    why = folder_problem(folder)
    if why is not None:
        raise JaxgaError(f"cannot write {option} {shown}: {why}")
    _refuse_long_name(f"{option} {shown}", target)
    if path.exists() and not os.access(path, os.W_OK):
        raise JaxgaError(f"cannot write {option} {path}: the existing file cannot be "
                         "replaced (read-only or immutable)")
