"""Run a saved result again: its JSON (``jaxga run --json``, :meth:`Result.to_json`, a sweep
point's) holds the resolved configuration, the seeds, the population capacity, the size
class, the corner rule, the endpoints and the digest of the map's cells, which together
fix every random number of its runs (:func:`jaxga.run`: seed ``s`` always gives the same
run, whatever runs beside it)."""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Callable, Mapping
from typing import Any

from jaxga._runtime.device_probe import run_environment
from jaxga.api.result import Result
from jaxga.api.runs import run
from jaxga.config.schema import Config
from jaxga.core.errors import EnvironmentWarning, JaxgaError, ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.files import shown_name
from jaxga.core.grid import Grid, check_corner_rule
from jaxga.maps import MapInfo, load_map_info
from jaxga.maps.inputs import json_value, read_input
from jaxga.maps.loaders import LOADING_OPTIONS

__all__ = ["rerun"]

SAVED_KEYS = ("config", "runs", "map_digest", "corner_rule", "start", "goal",
              "population_capacity", "size_class")
"""What a saved result must hold to be run again."""

MAX_SAVED_BYTES = 1 << 28
"""The largest JSON file read as a saved result (a result of many seeds and long
histories is tens of megabytes; Python's JSON objects take several times a file's
bytes)."""


def rerun(saved: Mapping[str, Any] | str | os.PathLike, map: Any, *,
          progress: Callable[[str, float], None] | None = None,
          any_angle_budget: float | str | None = "auto") -> Result:
    """The runs of a saved result, run again on ``map``.

    Args:
        saved: the result's JSON: a file, its text, or the dictionary
            :meth:`Result.to_json` returns.
        map: the map it ran on: a file, a built-in name or an occupancy grid, loaded with
            the saved endpoints and corner rule and the loading options the result
            recorded (``map_source``: robot radius, inflation, coarsening, unknown cells,
            ...); or a :class:`jaxga.maps.MapInfo` or :class:`jaxga.Grid` loaded as it
            was then (``load_map_info(path, robot_radius=...)``), given the saved
            endpoints and corner rule. Its cells must have the saved digest and, where the
            result has a frame, the same resolution, origin and coarsening.
        progress: as :func:`jaxga.run`.
        any_angle_budget: as :func:`jaxga.run` (the references, not the runs).

    Returns:
        The :class:`Result`: on the jaxga, JAX and device the JSON's ``environment``
        names, every run bit for bit the saved one; on another backend within the
        contract of exactness (docs/devices.md). Where the environment differs, an
        :class:`~jaxga.core.errors.EnvironmentWarning` names what differs.

    Raises:
        ParameterError: in one line: a file that cannot be read as a saved result (not a
            regular file, not JSON, a key given twice), a result without what a run
            needs (:data:`SAVED_KEYS`: results saved before jaxga recorded the map's
            digest, or the JSON of a comparison or an experiment), a value of another
            type than a run writes (a seed that is not an integer, a size class that is
            not true or false), or a map whose cells or frame are not the saved map's.
    """
    doc = _saved(saved)
    missing = [k for k in SAVED_KEYS if k not in doc]
    if missing:
        kind = ("the JSON of a comparison (jaxga compare), whose presets' runs are not "
                "kept" if "presets" in doc else "the JSON of a designed experiment (jaxga "
                "doe), whose points' runs are not kept" if "points" in doc or "design" in doc
                else "not the JSON of a run, or saved before jaxga recorded the map's digest")
        raise ParameterError(f"a saved result to run again needs {', '.join(missing)}; "
                             f"this one has none: {kind}")
    config, seeds, start, goal, rule, capacity, size_class = _run_settings(doc)
    _warn_environment(doc.get("environment"))
    if isinstance(map, MapInfo):
        info = dataclasses.replace(map, grid=map.grid.replace(start=start, goal=goal,
                                                              corner_rule=rule))
    elif isinstance(map, Grid):
        info = map.replace(start=start, goal=goal, corner_rule=rule)
    else:
        options = _loading_options(doc.get("map_source"))
        k = options.get("coarsen") or 1  # the saved endpoints are planning cells
        info = load_map_info(map, start=(start[0] * k, start[1] * k),
                             goal=(goal[0] * k, goal[1] * k), corner_rule=rule, **options)
    grid = info.grid if isinstance(info, MapInfo) else info
    if (grid.start_xy, grid.goal_xy) != (start, goal):  # never other endpoints in silence
        raise ParameterError(f"the map given puts the saved endpoints {start} and {goal} "
                             f"at {grid.start_xy} and {grid.goal_xy}: load it as it was "
                             f"loaded then ({_loaded_as(doc.get('map_source'))})")
    digest = doc["map_digest"]
    if grid.cells_digest() != digest:
        shown = digest if isinstance(digest, str) and len(digest) <= 128 \
            and digest.isprintable() else shown_value(digest)
        raise ParameterError(
            f"the map given has other cells than the saved result's (cells "
            f"{grid.cells_digest()}, saved {shown}): load it as it was loaded then "
            f"({_loaded_as(doc.get('map_source'))})")
    frame = info.frame if isinstance(info, MapInfo) else None
    _check_frame(doc.get("frame"), frame)
    return run(config, info, seeds, population_capacity=capacity, size_class=size_class,
               progress=progress, any_angle_budget=any_angle_budget)


def _integer(value: Any, what: str) -> int:
    """``value`` if it is an integer as JSON writes one (not a bool, not 7.0), else a
    one-line :class:`ParameterError` naming ``what``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ParameterError(f"a saved result's {what} must be an integer, got "
                             f"{shown_value(value)}")
    return value


def _run_settings(doc: Mapping[str, Any]) -> tuple:
    """``(config, seeds, start, goal, corner rule, population capacity, size class)`` of
    a saved result, each of the type a run writes: nothing is converted, so that a value
    edited by hand is refused rather than read as another run's."""
    if not isinstance(doc["config"], Mapping):
        raise ParameterError(f"a saved result's config must be an object of settings, got "
                             f"{shown_value(doc['config'])}")
    runs = doc["runs"]
    if not isinstance(runs, list) or not runs or not all(isinstance(r, Mapping)
                                                         for r in runs):
        raise ParameterError("a saved result's runs must be a non-empty list of objects, "
                             f"got {shown_value(runs)}")
    if any("seed" not in r for r in runs):
        raise ParameterError("a saved result's runs must each name their seed")
    seeds = [_integer(r["seed"], "seed") for r in runs]
    ends = []
    for name in ("start", "goal"):
        xy = doc[name]
        if not isinstance(xy, list) or len(xy) != 2:
            raise ParameterError(f"a saved result's {name} must be a cell [x, y], got "
                                 f"{shown_value(xy)}")
        ends.append(tuple(_integer(v, name) for v in xy))
    rule = doc["corner_rule"]
    if not isinstance(rule, str):
        raise ParameterError(f"a saved result's corner_rule must be a name, got "
                             f"{shown_value(rule)}")
    try:
        check_corner_rule(rule)
    except JaxgaError as e:
        raise ParameterError(f"a saved result's {e}") from None
    capacity = _integer(doc["population_capacity"], "population_capacity")
    if not isinstance(doc["size_class"], bool):
        raise ParameterError(f"a saved result's size_class must be true or false, got "
                             f"{shown_value(doc['size_class'])}")
    try:
        config = Config.from_mapping(doc["config"])
    except (TypeError, KeyError, ValueError, OverflowError) as e:
        raise ParameterError(f"a saved result's config cannot be read "
                             f"({type(e).__name__}: {str(e).splitlines()[0]})") from None
    return config, seeds, ends[0], ends[1], rule, capacity, doc["size_class"]


def _loading_options(source: Any) -> dict[str, Any]:
    """The loading options a result's ``map_source`` recorded (none where it recorded
    no source: a result saved before it did, or of a bare grid)."""
    if source is None:
        return {}
    options = source.get("options") if isinstance(source, Mapping) else None
    if not isinstance(options, Mapping) or not set(options) <= set(LOADING_OPTIONS):
        raise ParameterError(f"a saved result's map_source.options must be an object of "
                             f"{', '.join(LOADING_OPTIONS)}, got {shown_value(options)}")
    return dict(options)


def _loaded_as(source: Any) -> str:
    """How the saved result's map was loaded, for a refusal's hint."""
    options = source.get("options") if isinstance(source, Mapping) else None
    if not isinstance(options, Mapping):
        return "the same file and loading options: robot radius, inflation, coarsening, " \
               "unknown cells"
    given = ", ".join(f"{k if k in LOADING_OPTIONS else shown_value(k)}={shown_value(v)}"
                      for k, v in options.items())
    return (f"it was {shown_value(source.get('path'))}"
            + (f" with {given}" if given else " with no loading option"))


FRAME_KEYS = ("coarsen", "map_shape", "resolution", "origin")
"""The parts of a result's frame that its world coordinates depend on."""


def _check_frame(saved: Any, frame: Any) -> None:
    """Refuse, in one line, a map whose frame (coarsening, shape, resolution, origin)
    differs from the saved result's: its cells would give the same runs, but every
    coordinate in metres another value."""
    if saved is None:
        return
    if not isinstance(saved, Mapping):
        raise ParameterError(f"a saved result's frame must be an object, got "
                             f"{shown_value(saved)}")
    if frame is None:  # a bare Grid: its cells are the saved ones; no metres, no blocks
        now = {"coarsen": 1, "resolution": None, "origin": None}
        differ = [k for k in now if saved.get(k, now[k]) != now[k]]
    else:
        now = frame.to_json()
        differ = [k for k in FRAME_KEYS if saved.get(k) != now.get(k)]
    if differ:
        shown = "; ".join(f"{k} {shown_value(now.get(k))}, saved {shown_value(saved.get(k))}"
                          for k in differ)
        raise ParameterError(f"the map given has the saved cells in another frame ({shown}):"
                             " load it as it was loaded then")


def _warn_environment(saved: Any) -> None:
    """An :class:`EnvironmentWarning` naming what computes these runs otherwise than the
    saved ones (versions, device): they may then differ from them."""
    if saved is None:
        return
    if not isinstance(saved, Mapping):
        raise ParameterError(f"a saved result's environment must be an object, got "
                             f"{shown_value(saved)}")
    now = run_environment()
    differ = [f"{k} {shown_value(saved.get(k))} saved, {shown_value(v)} here"
              for k, v in now.items() if k in saved and saved[k] != v]
    if differ:
        warnings.warn("the saved result was computed elsewhere (" + "; ".join(differ)
                      + "): its runs may differ from these", EnvironmentWarning,
                      stacklevel=3)


def _saved(saved: Any) -> Mapping[str, Any]:
    """The saved result's JSON object, read from a file (or from its text) when given
    one."""
    if isinstance(saved, Mapping):
        return saved
    if not isinstance(saved, (str, os.PathLike)):
        raise ParameterError(f"a saved result is a JSON file, its text or the dictionary "
                             f"Result.to_json() returns, got {type(saved).__name__}")
    if isinstance(saved, str) and saved.lstrip()[:1] in ("{", "["):
        label, text = "the saved result's JSON text", saved.encode("utf-8", "surrogatepass")
    else:
        label = shown_name(str(saved))
        if len(label) > 200:  # a name no file system holds, echoed in one short line
            label = f"{label[:120]}...{label[-60:]}"
        try:
            text = read_input(saved, MAX_SAVED_BYTES, what="saved result", label=label,
                              error=ParameterError,
                              note="a result of many seeds and histories is tens of MB")
        except OSError as e:
            raise ParameterError(f"{label}: cannot be read ({e.strerror or e})") from None
    try:
        doc = json_value(text)
    except ValueError as e:  # JSON or UTF-8 errors, a key twice, nesting
        what = "not JSON" if isinstance(saved, str) and label.endswith("text") \
            else "not a JSON file"
        raise ParameterError(f"{label}: {what} ({str(e).splitlines()[0][:200]})") from None
    if not isinstance(doc, dict):
        raise ParameterError(f"{label}: not the JSON of a result (no object at its top)")
    return doc
