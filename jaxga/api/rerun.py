"""Run a saved result again: its JSON (``jaxga run --json``, :meth:`Result.to_json`, a sweep
point's) holds the resolved configuration, the seeds, the population capacity, the size
class, the corner rule, the endpoints and the digest of the map's cells, which together
fix every random number of its runs (:func:`jaxga.run`: seed ``s`` always gives the same
run, whatever runs beside it)."""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from jaxga.api.result import Result
from jaxga.api.runs import run
from jaxga.config.schema import Config
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.maps import MapInfo, load_map_info

__all__ = ["rerun"]

SAVED_KEYS = ("config", "runs", "map_digest", "corner_rule", "start", "goal",
              "population_capacity", "size_class")
"""What a saved result must hold to be run again."""

MAX_SAVED_BYTES = 1 << 30
"""The largest JSON file read as a saved result (a result of many seeds and long
histories is tens of megabytes)."""


def rerun(saved: Mapping[str, Any] | str | os.PathLike, map: Any, *,
          progress: Callable[[str, float], None] | None = None,
          any_angle_budget: float | str | None = "auto") -> Result:
    """The runs of a saved result, run again on ``map``.

    Args:
        saved: the result's JSON as a file or as the dictionary :meth:`Result.to_json`
            returns.
        map: the map it ran on: a file, a built-in name or an occupancy grid (loaded
            with the saved endpoints and corner rule and no other option), or a
            :class:`jaxga.maps.MapInfo` or :class:`jaxga.Grid` loaded as it was then (a
            ROS map with the robot's radius: ``load_map_info(path, robot_radius=...)``),
            given the saved endpoints and corner rule. Its cells must have the saved
            digest.
        progress: as :func:`jaxga.run`.
        any_angle_budget: as :func:`jaxga.run` (the references, not the runs).

    Returns:
        The :class:`Result`: on the jaxga, JAX and device the JSON's ``environment``
        names, every run bit for bit the saved one; on another backend within the
        contract of exactness (docs/devices.md).

    Raises:
        ParameterError: in one line: a file that cannot be read as a saved result, a
            result without what a run needs (:data:`SAVED_KEYS`; results saved before
            jaxga recorded the map's digest), or a map whose cells are not the saved
            map's (both digests named).
    """
    doc = _saved(saved)
    missing = [k for k in SAVED_KEYS if k not in doc]
    if missing:
        raise ParameterError(f"a saved result to run again needs {', '.join(missing)}; "
                             "this one has none (not the JSON of a run, or saved by an "
                             "older jaxga)")
    try:
        config = Config.from_mapping(doc["config"])
        seeds = [int(r["seed"]) for r in doc["runs"]]
        start, goal = tuple(doc["start"]), tuple(doc["goal"])
    except (TypeError, KeyError, ValueError) as e:
        raise ParameterError(f"a saved result's config, runs or endpoints cannot be read "
                             f"({type(e).__name__}: {e})") from None
    rule = doc["corner_rule"]
    if isinstance(map, MapInfo):
        info = dataclasses.replace(map, grid=map.grid.replace(start=start, goal=goal,
                                                              corner_rule=rule))
    elif isinstance(map, Grid):
        info = map.replace(start=start, goal=goal, corner_rule=rule)
    else:
        info = load_map_info(map, start=start, goal=goal, corner_rule=rule)
    grid = info.grid if isinstance(info, MapInfo) else info
    if grid.cells_digest() != doc["map_digest"]:
        raise ParameterError(
            f"the map given has other cells than the saved result's (cells "
            f"{grid.cells_digest()}, saved {doc['map_digest']}): load it as it was "
            "loaded then (the same file, coarsening and robot radius)")
    return run(config, info, seeds, population_capacity=int(doc["population_capacity"]),
               size_class=bool(doc["size_class"]), progress=progress,
               any_angle_budget=any_angle_budget)


def _saved(saved: Any) -> Mapping[str, Any]:
    """The saved result's JSON object, read from a file when given one."""
    if isinstance(saved, Mapping):
        return saved
    if not isinstance(saved, (str, os.PathLike)):
        raise ParameterError(f"a saved result is a JSON file or the dictionary "
                             f"Result.to_json() returns, got {type(saved).__name__}")
    path = Path(saved)
    try:
        if path.stat().st_size > MAX_SAVED_BYTES:
            raise ParameterError(f"{path}: more than the {MAX_SAVED_BYTES:,} bytes jaxga "
                                 "reads as a saved result")
        doc = json.loads(path.read_bytes())
    except OSError as e:
        raise ParameterError(f"{path}: cannot be read ({e.strerror or e})") from None
    except (ValueError, RecursionError) as e:  # JSON or UTF-8 errors, nesting
        raise ParameterError(f"{path}: not a JSON file ({str(e).splitlines()[0]})") \
            from None
    if not isinstance(doc, dict):
        raise ParameterError(f"{path}: not the JSON of a result (no object at its top)")
    return doc
