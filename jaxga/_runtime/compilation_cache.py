"""Where compiled programs are kept across processes: jaxga's program store and, when
asked, JAX's persistent compilation cache.

A cold ``jaxga.run`` spends seconds compiling its programs, most of a short run's time
(README, performance). jaxga keeps its own programs whole on disk
(:mod:`jaxga._runtime.executables`), so that a later process that needs the same program
(same preset, map size and run count) reads it instead of tracing, lowering and
compiling it (decision 014). That store is jaxga's own folder: the Python API uses it by
default and changes no JAX setting (:func:`store_directory`).

:func:`configure` is the one explicit switch: it names the folder and turns JAX's own
persistent cache on in it too, a process-wide JAX setting that also serves the user's
own programs. ``jaxga run`` and the other commands call it. One setting opts out
everywhere: an empty ``$JAXGA_CACHE_DIR``.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import jax
import numpy as np

from jaxga.core.errors import CacheWarning, JaxgaError, ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.files import folder_problem, home_folder, jaxga_cache_home
from jaxga.core.numerals import ascii_int

__all__ = ["ENV_VAR", "MIN_COMPILE_SECONDS", "cache_problem", "configure", "default_directory",
           "env_directory", "expanded", "is_read_only", "jax_cache_folder", "jax_cache_source",
           "store_directory", "use_compilation_cache", "warn_unusable"]

ENV_VAR = "JAXGA_CACHE_DIR"
"""Environment variable naming the cache directory; an empty value leaves the cache off."""

MIN_COMPILE_SECONDS = 1.0
"""Programs that compile faster than this are not written to the cache (JAX's default
threshold): reading them back would save nothing."""


def default_directory() -> str:
    """``~/.cache/jaxga/jax``: the cache directory when ``$JAXGA_CACHE_DIR`` is not set
    (``~`` left as written where the home folder is not known: :func:`cache_problem`
    says so)."""
    return str(jaxga_cache_home("jax") or Path("~/.cache/jaxga/jax"))


def expanded(path: str) -> str:
    """``path`` with ``~`` and ``$VARIABLE`` expanded as a shell would: a service file or a
    ``.env`` file passes ``JAXGA_CACHE_DIR=~/cache`` unexpanded. A variable that is not
    set, and ``~`` where the home folder is not known (:func:`~jaxga.core.files.home_folder`),
    stay as written (:func:`cache_problem` refuses them)."""
    if not path:
        return path
    if (path == "~" or path.startswith("~/")) and home_folder() is None:
        return os.path.expandvars(path)
    return os.path.expandvars(os.path.expanduser(path))


_UNEXPANDED = re.compile(r"\$(\w+|\{[^}]*\})")


def cache_problem(path: str | os.PathLike) -> str | None:
    """Why ``path`` cannot hold the cache (it names an environment variable that is not
    set or a home folder that is not known, it cannot be made a folder, or takes no new
    file: :func:`jaxga.core.files.folder_problem`), or None when it can."""
    text = os.fspath(path)
    if isinstance(text, str) and text and not text.strip():
        return "it holds only spaces, no folder's name"
    unset = _UNEXPANDED.search(text) if isinstance(text, str) else None
    if unset is not None:
        return f"it names the environment variable {unset.group(0)}, which is not set"
    if isinstance(text, str) and text.startswith("~"):
        return f"it names the home folder {text.split('/')[0]}, which is not known"
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as e:
        return e.strerror or str(e)
    except ValueError:  # os.mkdir of a name holding a NUL
        return "a folder's name cannot hold a NUL character"
    return folder_problem(path)


def env_directory() -> str:
    """The folder ``$JAXGA_CACHE_DIR`` names (:func:`expanded`, without the spaces and
    line ends around it; "" when it is empty: no folder), else
    :func:`default_directory`."""
    value = os.environ.get(ENV_VAR)
    if value is None:
        return default_directory()
    # the line end and spaces a .env file or a CRLF script leaves are no part of the name
    return expanded(value.strip(" \t\r\n") or value)


def _readable_folder(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a folder whose files can be listed and read."""
    try:
        return Path(path).is_dir() and os.access(path, os.R_OK | os.X_OK)
    except (OSError, ValueError):  # a name too long, a NUL: no folder of that name
        return False


_READ_ONLY: set[str] = set()
"""The cache folders in use that take no new file: their stored programs are read, and
new ones are compiled without being kept."""


def is_read_only(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a cache folder this process reads but cannot add to (it has
    said so in one warning: a program that cannot be kept there needs no other)."""
    return str(Path(path)) in _READ_ONLY


def _use_read_only(path: str, why: str, source: str = ENV_VAR) -> None:
    """Read a folder that takes no new file (a shared cache on a read-only mount, a
    folder of another user's): one :class:`~jaxga.core.errors.CacheWarning` per process."""
    if is_read_only(path):  # said once per folder
        return
    _READ_ONLY.add(str(Path(path)))
    warnings.warn(f"the compilation cache {path} ({source}) takes no new files ({why}): "
                  "programs stored in it are read, new ones are compiled and not kept",
                  CacheWarning, stacklevel=4)


def _judged(path: str, source: str = ENV_VAR) -> str | None:
    """None when ``path`` can hold the cache, or be read as one that takes no new file
    (:func:`_use_read_only`); else why not, said in one warning (:func:`warn_unusable`)."""
    why = cache_problem(path)
    if why is not None and _readable_folder(path):
        _use_read_only(path, why, source)
        return None
    if why is not None:
        warn_unusable(path, why, source)
    return why


_WARNED: list[str] = []


def warn_unusable(path: str, why: str, source: str = ENV_VAR) -> None:
    """One :class:`~jaxga.core.errors.CacheWarning` per process naming the cache folder
    and what follows: programs are compiled without it."""
    if _WARNED:
        return
    _WARNED.append(path)
    warnings.warn(f"the compilation cache {path} ({source}) cannot be used ({why}): "
                  "compiling without it", CacheWarning, stacklevel=3)


_UNSET = object()
_configured: dict[str, str | None] = {}
_checked: dict[str, str | None] = {}


STORE_MAX_BYTES = 4 << 30
"""The most jaxga's program store and JAX's cache where jaxga turns it on take on disk
together by default (4 GiB: about 600 program sets of a whole GA on a small map)."""

ENV_STORE_MAX_MB = "JAXGA_STORE_MAX_MB"
"""The environment variable that sets another bound for the store, in MiB (whole, >= 1)."""


def store_limit() -> int:
    """The most jaxga's program store and JAX's cache where :func:`configure` turns it on
    (:func:`jax_cache_folder`) may take on disk together, in bytes: ``$JAXGA_STORE_MAX_MB``
    MiB, else :data:`STORE_MAX_BYTES`; a value that is not a whole number of at least 1
    is refused in one line (:class:`~jaxga.core.errors.JaxgaError`)."""
    text = os.environ.get(ENV_STORE_MAX_MB, "")
    if text == "":
        return STORE_MAX_BYTES
    try:
        mb = ascii_int(text)
    except ValueError:
        mb = 0
    if mb < 1:
        raise JaxgaError(f"{ENV_STORE_MAX_MB} must be a whole number of MiB of at least 1, "
                         f"got {shown_value(text)}")
    return min(mb, 1 << 40) << 20


def configure(cache_dir: str | os.PathLike | None | object = _UNSET, *,
              jax_cache: bool = True) -> str | None:
    """Where jaxga keeps its compiled programs, and JAX's persistent compilation cache.

    Args:
        cache_dir: the folder. Default: the folder ``$JAXGA_CACHE_DIR`` names, else
            JAX's own cache folder where the user set a local one
            (``JAX_COMPILATION_CACHE_DIR``, ``jax_compilation_cache_dir``; JAX's cache is
            then left as the user set it, and the store's bound counts jaxga's programs
            only), else :func:`default_directory` (also where the user's JAX cache is
            remote: jaxga's store is local); an empty ``$JAXGA_CACHE_DIR`` or ``None``:
            no folder (every process compiles its programs).
        jax_cache: also turn on JAX's persistent compilation cache in that folder
            (JAX's ``jax_compilation_cache_dir`` and
            ``jax_persistent_cache_min_compile_time_secs``, :data:`MIN_COMPILE_SECONDS`):
            a setting of the whole process, which serves the user's own programs too.

    Returns:
        The folder in use, or ``None`` when there is none, also when the folder cannot
        be made or read (then one :class:`~jaxga.core.errors.CacheWarning` says so: the
        programs are compiled without it). A folder that can be read but takes no new
        file (a read-only mount) is used for reading: jaxga's stored programs are read
        from it, new ones are compiled and not kept, and JAX's cache is not turned on
        (it would warn at every program it cannot write); one warning says so.

    Without a call, jaxga keeps its programs in the default folder and touches no JAX
    setting (:func:`store_directory`). Not part of any paper: an engineering aid
    (jaxga's results never depend on it).
    """
    users_jax_cache, source = False, "jaxga.configure"
    if cache_dir is _UNSET:
        own, source = jax.config.jax_compilation_cache_dir, ENV_VAR
        if own and own == _configured.get("jax"):  # set by an earlier call, not the user
            own = None
        if ENV_VAR in os.environ or not own:
            path = env_directory()
        else:  # the user's own JAX cache: left as it is (settings, entries, bound)
            users_jax_cache = True
            if "://" in str(own):  # a remote one: jaxga's store stays local
                path = default_directory()
            else:
                path, source = expanded(str(own)), "JAX's jax_compilation_cache_dir"
    elif cache_dir is None:
        path = ""
    else:
        if not isinstance(cache_dir, (str, os.PathLike)):
            raise ParameterError(f"configure: cache_dir must be a folder's path (a str or a "
                                 f"Path) or None, got {shown_value(cache_dir)}")
        path = os.fspath(cache_dir)
        if isinstance(path, bytes):
            raise ParameterError("configure: cache_dir must be a folder's path as a str or a "
                                 "Path, not bytes")
        if not path:
            raise ParameterError("configure: cache_dir must not be empty (None: no folder)")
        path = expanded(path)
        if "://" in path:
            raise ParameterError(
                f"configure: cache_dir must be a local folder, got the URL {shown_value(path)} "
                "(JAX's own cache may be remote: jax.config.update("
                "'jax_compilation_cache_dir', URL))")
    if not isinstance(jax_cache, (bool, np.bool_)):
        raise ParameterError(f"configure: jax_cache must be True or False, got "
                             f"{shown_value(jax_cache)}")
    if path and _judged(path, source) is not None:
        path = ""
    _configured["dir"] = path or None
    if path and jax_cache and not users_jax_cache and not is_read_only(path):
        jax.config.update("jax_compilation_cache_dir", path)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_SECONDS)
        # JAX's entries count against the store's bound (:func:`jax_cache_folder`); JAX's
        # own bound (jax_compilation_cache_max_size) needs the filelock package, and
        # without it JAX turns its cache off altogether
        _configured["jax"] = path
    else:
        _configured.pop("jax", None)
    return path or None


def jax_cache_source() -> str:
    """What set the folder of JAX's persistent cache, for a message: jaxga's
    (:data:`ENV_VAR` or its default folder) or the user's own setting."""
    folder = jax.config.jax_compilation_cache_dir
    if folder and folder == _configured.get("jax"):
        return ENV_VAR if ENV_VAR in os.environ else "jaxga's default folder"
    if os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return "JAX_COMPILATION_CACHE_DIR"
    return "JAX's jax_compilation_cache_dir"


def jax_cache_folder() -> str | None:
    """The folder in which :func:`configure` turned JAX's persistent cache on, while JAX
    still uses it, or None. JAX's entries there (``*-cache`` files) count against
    :func:`store_limit` together with jaxga's stored programs: the folder is jaxga's."""
    path = _configured.get("jax")
    if path and jax.config.jax_compilation_cache_dir == path:
        return path
    return None


def use_compilation_cache(directory: str | os.PathLike | None = None) -> str | None:
    """The former name of :func:`configure`: ``configure(directory)`` (``None``: the
    default folder), JAX's cache included. Deprecated: call :func:`configure`."""
    warnings.warn("jaxga.use_compilation_cache is deprecated: call jaxga.configure",
                  DeprecationWarning, stacklevel=2)
    return configure(_UNSET if directory is None else directory)


def store_directory() -> str | None:
    """The folder of jaxga's program store (:mod:`jaxga._runtime.executables`): the folder
    the last :func:`configure` named (None: none), else none where ``$JAXGA_CACHE_DIR`` is
    set empty, else JAX's own cache folder where the user set one (a local one; a remote
    one: none), else ``$JAXGA_CACHE_DIR`` or
    :func:`default_directory` (made on first use; ``None`` with one
    :class:`~jaxga.core.errors.CacheWarning` where it cannot be; one that takes no new
    file is read, with one warning)."""
    if "dir" in _configured:
        return _configured["dir"]
    if ENV_VAR in os.environ and not env_directory():  # set empty: no store
        return None
    base = jax.config.jax_compilation_cache_dir
    if base:
        return None if "://" in str(base) else str(base)
    path = env_directory()
    if not path:
        return None
    if path not in _checked:
        _checked[path] = _judged(path)
    return None if _checked[path] is not None else path
