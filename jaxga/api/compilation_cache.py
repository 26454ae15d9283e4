"""JAX's persistent compilation cache for jaxga's programs (on disk, across processes).

A cold ``jaxga.run`` spends seconds compiling its programs, most of a short run's time
(README, performance). JAX can keep compiled programs on disk, keyed by the program and
the JAX and XLA versions; a later process that compiles the same program (same preset,
map size and run count) reads it instead. Tracing and lowering still run, so such a
"warm" compile is shorter than a cold one but not free (``benchmarks/speed.py --warm``;
decision 014).

``jaxga run`` and the other commands turn the cache on by default, and so does the
Python API: the first :func:`jaxga.run` (``sweep``, ``compare``, ``run_doe``, ``replan``)
of a process calls :func:`ensure_compilation_cache`, which turns it on unless a cache
directory is already configured. One setting opts out everywhere: an empty
``$JAXGA_CACHE_DIR``.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import jax

from jaxga.core.errors import CacheWarning, ParameterError
from jaxga.core.files import folder_problem

__all__ = ["ENV_VAR", "MIN_COMPILE_SECONDS", "cache_problem", "default_directory",
           "ensure_compilation_cache", "use_compilation_cache", "warn_unusable"]

ENV_VAR = "JAXGA_CACHE_DIR"
"""Environment variable naming the cache directory; an empty value leaves the cache off."""

MIN_COMPILE_SECONDS = 1.0
"""Programs that compile faster than this are not written to the cache (JAX's default
threshold): reading them back would save nothing."""


def default_directory() -> str:
    """``~/.cache/jaxga/jax``: the cache directory when ``$JAXGA_CACHE_DIR`` is not set."""
    return str(Path.home() / ".cache" / "jaxga" / "jax")


def cache_problem(path: str | os.PathLike) -> str | None:
    """Why ``path`` cannot hold the cache (it cannot be made a folder, or takes no new
    file: :func:`jaxga.core.files.folder_problem`), or None when it can."""
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as e:
        return e.strerror or str(e)
    return folder_problem(path)


_WARNED: list[str] = []


def warn_unusable(path: str, why: str) -> None:
    """One :class:`~jaxga.core.errors.CacheWarning` per process naming the cache folder
    and what follows: programs are compiled without it."""
    if _WARNED:
        return
    _WARNED.append(path)
    warnings.warn(f"the compilation cache {path} ({ENV_VAR}) cannot be used ({why}): "
                  "compiling without it", CacheWarning, stacklevel=3)


def use_compilation_cache(directory: str | os.PathLike | None = None) -> str | None:
    """Turn on JAX's persistent compilation cache for every program compiled from now on.

    Args:
        directory: where to keep the compiled programs. ``None`` (the default): the
            directory ``$JAXGA_CACHE_DIR`` names, else :func:`default_directory`;
            an empty ``$JAXGA_CACHE_DIR`` leaves the cache off. An explicit
            ``directory`` wins over the environment.

    Returns:
        The directory used, or ``None`` when the cache was left off, also when the
        directory cannot be made or written (then one
        :class:`~jaxga.core.errors.CacheWarning` says so: the programs are compiled
        without it).

    Sets JAX's ``jax_compilation_cache_dir`` and
    ``jax_persistent_cache_min_compile_time_secs`` (:data:`MIN_COMPILE_SECONDS`) for the
    whole process; it works after other programs have been compiled. A restarted
    notebook kernel that calls it before ``jaxga.run`` compiles a preset it compiled
    before in a fraction of the cold compile time (decision 014). Not part of any
    paper: an engineering aid (jaxga's results never depend on it).
    """
    if directory is None:
        path = os.environ.get(ENV_VAR, default_directory())
    else:
        path = os.fspath(directory)
        if not path:
            raise ParameterError("use_compilation_cache: the directory must not be empty")
    if not path:
        return None
    why = cache_problem(path)
    if why is not None:
        warn_unusable(path, why)
        return None
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_SECONDS)
    return path


def ensure_compilation_cache() -> str | None:
    """The Python API's default: the persistent cache on, as :func:`use_compilation_cache`
    turns it on, unless a cache directory is already configured (by that function, by
    JAX's ``jax_compilation_cache_dir`` or ``$JAX_COMPILATION_CACHE_DIR``), which is left
    as it is; an empty ``$JAXGA_CACHE_DIR`` leaves the cache off. Returns the directory
    in use, or None."""
    current = jax.config.jax_compilation_cache_dir
    if current:
        return current
    return use_compilation_cache()

