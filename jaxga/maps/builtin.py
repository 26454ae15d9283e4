"""Built-in maps shipped in ``jaxga/maps/data`` (origins and licences: ``data/SOURCES.md``).

* the six classic 20 x 20 GA maps (0/1 text, file line 1 = bottom row, start (0, 0),
  goal (19, 19)), e.g. ``"classic_ga_gapp3_20x20"``;
* four Moving AI maps with their scenario files: ``"random-32-32-20"``,
  ``"maze-32-32-2"``, ``"room-32-32-4"`` and ``"den312d"`` (65 x 81).

A built-in map's name is its file name without the extension. Load one with
``jaxga.maps.load_map(name)``.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

from jaxga.core.errors import MapFormatError
from jaxga.maps.scenarios import Scenario, read_scen

__all__ = [
    "DATA_DIR",
    "builtin_names",
    "builtin_path",
    "builtin_scenario_path",
    "builtin_scenarios",
    "default_corner_rule",
    "scenario_path",
]

DATA_DIR = Path(__file__).resolve().parent / "data"
"""Folder holding the built-in map files."""

_MAP_SUFFIXES = (".txt", ".map")


@functools.lru_cache(maxsize=1)
def _index() -> dict[str, Path]:
    files = sorted(p for p in DATA_DIR.iterdir() if p.suffix in _MAP_SUFFIXES and p.is_file())
    return {p.stem: p for p in files}


def default_corner_rule(source: str | os.PathLike) -> str:
    """The corner rule (decision 027) a map is planned under unless one is named: ``"free"``
    for the six classic 20 x 20 GA maps (the papers' convention: their GAs squeeze
    between diagonal obstacles, and their reported lengths assume it), ``"strict"`` for
    every other map: the built-in Moving AI maps (the convention of their scenario
    files) and any map a user brings, so that a path never touches a blocked cell's
    corner. Every command and function that loads a map by name uses this rule, so one
    map has one optimum everywhere."""
    if isinstance(source, str) and source in _index() and _index()[source].suffix == ".txt":
        return "free"
    return "strict"


def builtin_names() -> list[str]:
    """Names of the built-in maps, sorted."""
    return sorted(_index())


def builtin_path(name: str) -> Path:
    """Path of the built-in map ``name``; unknown name -> MapFormatError listing the names."""
    try:
        return _index()[name]
    except (KeyError, TypeError):
        raise MapFormatError(
            f"unknown built-in map {name!r}: available maps are {', '.join(builtin_names())}"
        ) from None


def _scenario_beside(folder: Path, stem: str) -> Path | None:
    """The scenario file of map ``stem`` in ``folder``, by Moving AI's names: the first
    of ``stem-random-N.scen`` (smallest N), ``stem.map.scen``, ``stem.scen``."""
    def number(p: Path) -> tuple[int, str]:
        tail = p.name[len(stem) + len("-random-"):-len(".scen")]
        return (int(tail), "") if tail.isdigit() else (1 << 62, tail)

    for pattern in (f"{stem}-random-*.scen", f"{stem}.map.scen", f"{stem}.scen"):
        found = sorted((p for p in folder.glob(pattern) if p.is_file()), key=number)
        if found:
            return found[0]
    return None


def builtin_scenario_path(name: str) -> Path | None:
    """Path of the ``.scen`` file shipped with built-in map ``name``, or None if none is."""
    builtin_path(name)  # validates the name
    return _scenario_beside(DATA_DIR, name)


def scenario_path(source: str | os.PathLike) -> Path | None:
    """The Moving AI scenario file of a map: a built-in map's own, or for a map file
    ``X.map`` the first of ``X-random-N.scen`` (smallest N), ``X.map.scen`` and
    ``X.scen`` beside it; None if there is none."""
    if isinstance(source, str) and source in builtin_names():
        return builtin_scenario_path(source)
    path = Path(os.fspath(source))
    return _scenario_beside(path.parent, path.stem)


def builtin_scenarios(name: str) -> list[Scenario]:
    """The Moving AI problems shipped with built-in map ``name`` (y counted from the bottom).

    Raises MapFormatError for an unknown name or a map without a scenario file.
    """
    path = builtin_scenario_path(name)
    if path is None:
        with_scen = [n for n in builtin_names() if builtin_scenario_path(n) is not None]
        raise MapFormatError(
            f"built-in map {name!r} has no scenario file; maps with scenarios: "
            f"{', '.join(with_scen)}"
        )
    return read_scen(path)
