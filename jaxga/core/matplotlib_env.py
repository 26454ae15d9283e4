"""Matplotlib started where its own folders or backend setting are unusable.

Matplotlib keeps its configuration and font cache in ``$MPLCONFIGDIR`` (else
``~/.config/matplotlib`` and ``~/.cache/matplotlib``). Where it cannot write there (an
unwritable ``$HOME``, a ``$MPLCONFIGDIR`` on a read-only mount) it makes a
``matplotlib-*`` folder in the temporary directory, prints two warning lines, and removes
the folder only at an orderly interpreter exit, which the ``jaxga`` command skips (it ends
with ``os._exit``). :func:`matplotlib_ready`, called before jaxga first imports
Matplotlib, gives it a folder of jaxga's own instead, removed when the process ends
(:func:`jaxga.core.files.remove_temporaries`), and turns an ``$MPLBACKEND`` that names no
backend into one line naming the variable.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from jaxga.core.errors import JaxgaError
from jaxga.core.files import folder_problem, home_folder, temporary_folder

__all__ = ["matplotlib_ready"]


def _usable(folder: Path) -> bool:
    if not folder.is_absolute():  # it would be made under every working folder
        return False
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return folder_problem(folder) is None


def _own_folders() -> list[Path]:
    """The folders Matplotlib would write to: ``$MPLCONFIGDIR``, else its configuration
    and cache folders under the XDG ones (as ``matplotlib.get_configdir`` and
    ``get_cachedir`` choose them on Linux and macOS)."""
    given = os.environ.get("MPLCONFIGDIR")
    if given:
        return [Path(given).expanduser().absolute()]  # as Matplotlib reads it
    home = home_folder() or Path("~")  # not known: a relative folder, not usable
    config = os.environ.get("XDG_CONFIG_HOME") or str(home / ".config")
    cache = os.environ.get("XDG_CACHE_HOME") or str(home / ".cache")
    return [Path(config) / "matplotlib", Path(cache) / "matplotlib"]


def matplotlib_ready() -> None:
    """Prepare Matplotlib's first import (nothing once it is imported: the process's
    own settings stand). Its folders unusable: ``$MPLCONFIGDIR`` set to a temporary
    folder of jaxga's, removed when the process ends. Raises :class:`JaxgaError` (one
    line) when ``$MPLBACKEND`` names no backend Matplotlib has."""
    if "matplotlib" not in sys.modules:
        try:
            usable = all(_usable(f) for f in _own_folders())
        except (OSError, RuntimeError):  # no home folder at all
            usable = False
        if not usable:
            os.environ["MPLCONFIGDIR"] = str(temporary_folder("jaxga-matplotlib-"))
    try:
        import matplotlib

        matplotlib.get_backend()
    except (ValueError, ImportError) as e:
        backend = os.environ.get("MPLBACKEND", "")
        raise JaxgaError(f"$MPLBACKEND={backend!r} is not a backend Matplotlib can use "
                         f"({str(e).splitlines()[0][:200]}); unset it or name one, "
                         "e.g. MPLBACKEND=Agg") from None
