"""The problem of a call, loaded and checked once: the preset with its overrides and
``--set`` values, the map with its corner rule and endpoints (:func:`load_problem`), and the
user's own operator functions registered under their names (:func:`own_operators`).
"""

from __future__ import annotations

import contextlib
import inspect
from collections.abc import Mapping, Sequence
from os import PathLike
from typing import Any, NamedTuple

import numpy as np

from jaxga._runtime.jax_settings import check_jax_settings, check_platform
from jaxga._runtime.lowering import check_environment
from jaxga.config.presets import as_sets, load_preset, parse_set
from jaxga.config.schema import MAP_RULE, Config, dotted, flatten, normalised
from jaxga.core.address_space import address_space_refusal
from jaxga.core.errors import EndpointError, ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import Grid, as_integer
from jaxga.core.own_settings import own_settings
from jaxga.engine import check_file_keys_read, check_overrides_read
from jaxga.maps import MapInfo, load_map, load_map_info
from jaxga.maps.frame import MapFrame
from jaxga.maps.occupancy_grid import OccupancyGrid, is_occupancy_message
from jaxga.operators import registry

__all__ = ["Problem", "check_one_corner_rule", "configured_rule", "load_problem",
           "own_operators", "problem"]


class Problem(NamedTuple):
    """A preset on a map, loaded and checked once (:func:`problem`): what :class:`jaxga.GA`,
    :func:`jaxga.run` and :func:`jaxga.sweep` build on when given it instead of a preset
    and a map, without loading or checking anything again."""

    config: Config
    """The checked configuration: the preset, its overrides and ``--set`` values."""
    grid: Grid
    """The map with its endpoints and corner rule."""
    map_name: str
    """The map's name (``"grid"`` for a bare :class:`Grid`)."""
    frame: MapFrame | None
    """The map's world frame (resolution, origin, coarsening), None for a bare grid."""
    info: MapInfo | None = None
    """The loaded map (its file, format, layers for plots), None for a bare grid."""
    given: tuple[str, ...] = ()
    """The configuration keys the call set (keyword overrides and ``--set`` values): a
    sweep's points and a DOE's factors may not set them again (which value would hold?)."""


def configured_rule(corner_rule: str | None, config: Config) -> str | None:
    """The corner rule a call names: ``corner_rule`` (``--corner-rule``), else the
    configuration's ``map.corner_rule`` unless it is ``"map"``; None = the map's own."""
    if corner_rule is not None:
        return corner_rule
    rule = config["map.corner_rule"]
    return None if rule == MAP_RULE else rule


def check_one_corner_rule(corner_rule: str | None, config: Config,
                          overridden: Sequence[str]) -> None:
    """Refuse a ``corner_rule=`` (``--corner-rule``) that disagrees with an overridden
    ``map.corner_rule`` (``--set``): two rules for one run."""
    rule = config["map.corner_rule"]
    if "map.corner_rule" in overridden and corner_rule is not None and rule != MAP_RULE \
            and corner_rule != rule:
        raise ParameterError(f"two corner rules given: {corner_rule!r} (corner_rule, "
                             f"--corner-rule) and {rule!r} (map.corner_rule)")


def own_operators(overrides: dict) -> dict:
    """``overrides`` with each function given for an operator family (``init``,
    ``fitness`` or its synonym ``objective``, ``selection``, ``crossover``, ``mutation``,
    ``simplify``, ``post``) registered under its name
    (:func:`jaxga.operators.registry.register_operator`, replacing an earlier one of that
    name) and chosen as ``<family>.method``."""
    out, given = {}, {}
    for key, value in overrides.items():
        family = "fitness" if key == "objective" else key
        said = f"{key}={getattr(value, '__name__', None) or shown_value(value)}"
        if family in registry.FAMILIES and callable(value):
            op = _registered_fn(family, value) or registry.register_operator(
                family, value, replace=True)
            key, value = f"{family}__method", op.name
        if key in given:  # objective= and fitness= or fitness__method=: which one runs?
            raise ParameterError(f"two {key.removesuffix('__method')} operators given: "
                                 f"{given[key]} and {said}; give one")
        given[key] = said
        out[key] = value
    return out


def _registered_fn(family: str, fn: Any) -> registry.Operator | None:
    """The registered operator of ``family`` whose function is ``fn``, if any."""
    return next((op for op in registry.operators(family) if op.fn is fn), None)


@own_settings
def problem(preset: str | Config, grid: Grid | MapInfo | str, *,
            corner_rule: str | None = None, variant: str | None = None,
            sets: Sequence[str] = (), generations: int | None = None,
            map_options: Mapping[str, Any] | None = None, **overrides: Any) -> Problem:
    """A preset on a map, loaded and checked once, as :func:`jaxga.run` checks them (the
    same arguments; a key the preset never reads is refused): pass the
    :class:`Problem` to :class:`jaxga.GA`, :func:`jaxga.run` or :func:`jaxga.sweep` in
    place of the preset and the map.

    ``map_options``: for a map file or a built-in map's name, the options of
    :func:`jaxga.maps.load_map` (``start``, ``goal``, ``start_world``, ``goal_world``,
    ``robot_radius``, ``inflate``, ``coarsen``, ``threshold``, ``unknown``,
    ``occupied_from``, ``fmt``; None
    values are left out), applied under the corner rule the call names (its
    ``corner_rule``, else the preset's ``map.corner_rule``, else the map's own), so the
    preset is read once, as the command line does."""
    return load_problem(preset, grid, corner_rule, variant, sets, overrides, generations,
                        map_options=map_options)


def _given_problem(given: Problem, grid, corner_rule, variant, sets, overrides,
                   generations) -> Problem:
    """``given`` itself, with ``generations`` if given; one line refusing anything else
    (a checked problem is not loaded again: build another with :func:`problem`)."""
    extra = [name for name, value in (("grid", grid), ("corner_rule", corner_rule),
                                      ("variant", variant)) if value is not None]
    extra += ["sets"] * bool(tuple(sets)) + sorted(overrides)
    if extra:
        raise ParameterError(f"{', '.join(extra)} given with a Problem, which is already "
                             "checked: build another with jaxga.problem(...)")
    if generations is None:
        return given
    config = given.config.override({"generations": as_integer(generations)})
    return given._replace(config=config, given=tuple(dict.fromkeys((*given.given,
                                                                    "generations"))))


def load_problem(preset: str | Config | Problem, grid: Grid | MapInfo | str | None,
                 corner_rule: str | None, variant: str | None, sets: Sequence[str],
                 overrides: Mapping[str, Any], generations: int | None, *,
                 check_read: bool = True, check_endpoints: bool = True,
                 map_options: Mapping[str, Any] | None = None) -> Problem:
    """The :class:`Problem` of a call, checked (the frame of a map file or
    :class:`~jaxga.maps.MapInfo`: :mod:`jaxga.maps.frame`; None for a bare Grid); a
    :class:`Problem` given as ``preset`` is taken as it is; ``check_read=False`` leaves
    overrides that nothing reads to the caller (:func:`jaxga.compare.compare`),
    ``check_endpoints=False`` the endpoints (a :class:`~jaxga.api.planner.Planner`'s map,
    whose endpoints each plan gives); ``map_options`` as for :func:`problem`."""

    low = address_space_refusal()  # before scipy's OpenBLAS, which hangs short of memory
    if low is not None:
        raise ParameterError(low)
    check_environment()  # a bad $JAXGA_THREEFRY, which `import jaxga` does not refuse
    check_jax_settings()  # 64-bit mode, jit disabled
    check_platform()
    map_options = {k: v for k, v in (map_options or {}).items() if v is not None}
    known = [k for k in inspect.signature(load_map).parameters if k not in
             ("source", "corner_rule")]
    unknown = sorted(str(k) for k in map_options if k not in known)
    if unknown:
        raise ParameterError(f"unknown map option(s) {', '.join(map(repr, unknown))}: "
                             f"map_options takes {', '.join(known)} (the corner rule is "
                             "the call's corner_rule)")
    if map_options and (isinstance(preset, Problem) or not (
            isinstance(grid, (str, PathLike, OccupancyGrid)) or is_occupancy_message(grid))):
        raise ParameterError("map_options apply to a map file, a built-in map's name or an "
                             "occupancy grid, not to a loaded map or a Problem: load it "
                             "with them instead")
    if isinstance(preset, Problem):
        return _given_problem(preset, grid, corner_rule, variant, sets, overrides,
                              generations)
    if grid is None:
        raise ParameterError("a map is needed: give a Grid, a map file or a built-in map "
                             "name (or a jaxga.problem(...) in place of the preset)")
    map_name, frame, info = "grid", None, None
    if isinstance(grid, MapInfo):  # a loaded map that keeps its name (and its endpoints)
        info = grid
        grid, map_name, frame = grid.grid, grid.name, grid.frame
    sets = as_sets(sets)
    ov: dict[str, Any] = dotted(own_operators(overrides))
    if generations is not None:  # a non-integer is left for the configuration to refuse
        with contextlib.suppress(TypeError):
            generations = as_integer(generations)
        ov["generations"] = generations
    given = flatten(ov)
    set_values = [parse_set(text) for text in sets]
    for key, value in set_values:  # one value per key
        if key in given and normalised(key, given[key]) != normalised(key, value):
            raise ParameterError(f"{key} is given twice, as {given[key]!r} and {value!r}")
        given[key] = value
    if isinstance(preset, Config):  # as load_preset: the overrides, then the sets
        if variant is not None:
            raise ParameterError(f"variant {variant!r} given with a Config: load the preset "
                                 "with its variant (jaxga.config.presets.load_preset) instead")
        config = preset.override(ov).override(dict(set_values))
    else:
        config = load_preset(preset, variant=variant, overrides=ov, sets=sets)
    if check_read:  # never silently ignored
        overridden = [*flatten(ov), *(key for key, _ in set_values)]
        check_overrides_read(config, overridden)
        if not isinstance(preset, Config):  # keys a user TOML file sets, in that file
            check_file_keys_read(preset, variant)
        check_one_corner_rule(corner_rule, config, overridden)
        rule = config["map.corner_rule"]
        if isinstance(grid, Grid) and corner_rule is None and rule != MAP_RULE \
                and grid.corner_rule != rule:  # set by an override or a user's file
            raise ParameterError(
                f"different corner rules: map.corner_rule = {rule!r} has no effect with a "
                f"Grid (or a loaded MapInfo), which keeps its own corner rule "
                f"({grid.corner_rule!r}): give the Grid that rule "
                "(corner_rule=... or Grid.replace; --corner-rule on the command line)")
    if isinstance(grid, Grid):
        grid = grid.validated()  # a grid made with the plain constructor is checked too
        if corner_rule is not None:
            grid = grid.replace(corner_rule=corner_rule)
    else:
        info = load_map_info(grid, corner_rule=configured_rule(corner_rule, config),
                             **map_options)
        grid, map_name, frame = info.grid, info.name, info.frame
    if check_endpoints:
        checked_endpoints(grid, frame, None if info is None else info.layers,
                          () if info is None else info.defaulted)
    return Problem(config, grid, map_name, frame, info, tuple(given))


def checked_endpoints(grid: Grid, frame: MapFrame | None = None, layers: Any = None,
                      defaulted: Sequence[str] = ()) -> Grid:
    """``grid.check_endpoints()``, a blocked endpoint named in the map's own terms (its map
    cells, its centre in metres) and, on a ROS map's unknown cell, with the way out
    (``--unknown free``); an endpoint in ``defaulted`` (given by no one: the map's
    default corner) or a map blocked everywhere said so: the words of ``jaxga run``,
    ``optimum`` and the Python API."""
    try:
        return grid.check_endpoints()
    except EndpointError as e:
        raise EndpointError(f"{e}{_on_the_map(frame, grid)}"
                            f"{_why_blocked(grid, layers, defaulted)}") from None


DEFAULT_CORNERS = {"start": ("(0, 0)", "S"), "goal": ("(W - 1, H - 1)", "G")}
"""Per endpoint: its default corner and its marker in an ASCII map
(:func:`jaxga.maps.load_map`)."""


def _why_blocked(grid: Grid, layers: Any, defaulted: Sequence[str]) -> str:
    """What a blocked endpoint's message adds: that the map has no free cell at all (and
    whether the inflation made it so), else why the cell is blocked
    (:func:`_blocked_hint`) and why the endpoint is there (:func:`_default_hint`)."""
    if grid.blocked_np().all():
        inflated = layers is not None and layers.margin.any()
        return ("; every cell of the map is blocked"
                + (" (the inflation, --inflate or --robot-radius, covers the free ones)"
                   if inflated else ""))
    return f"{_blocked_hint(layers, grid)}{_default_hint(grid, defaulted)}"


def _default_hint(grid: Grid, defaulted: Sequence[str]) -> str:
    """Why a blocked endpoint is where it is when no one chose it; "" elsewhere."""
    b = grid.blocked_np()
    for name, xy in (("start", grid.start_xy), ("goal", grid.goal_xy)):
        if b[xy[1], xy[0]]:  # the first blocked one, as check_endpoints
            if name not in defaulted:
                return ""
            corner, marker = DEFAULT_CORNERS[name]
            return (f"; no {name} was given and the map marks none (an ASCII map's "
                    f"{marker}): the default is the corner {corner}; give one with "
                    f"--{name} X,Y (in Python: load_map(..., {name}=(x, y)))")
    return ""


def _blocked_hint(layers: Any, grid: Grid) -> str:
    """Why a blocked endpoint is blocked where the map alone does not block it, and the
    way out: one of a ROS map's unknown cells, or a free cell the inflation covers (the
    default corners too, which no one chose); "" elsewhere."""
    if layers is None:
        return ""
    for xy in (grid.start_xy, grid.goal_xy):  # the first blocked one, as check_endpoints
        if grid.blocked_np()[xy[1], xy[0]]:
            if layers.margin.shape == grid.blocked.shape and layers.margin[xy[1], xy[0]]:
                return ("; the cell is free on the map, within the inflation of an "
                        "obstacle (--inflate or --robot-radius): the inflated map blocks it")
            if layers.unknown_blocked and layers.unknown.shape == grid.blocked.shape \
                    and layers.unknown[xy[1], xy[0]]:
                return ("; the cell is unknown in the map (neither free nor occupied) and "
                        "unknown cells are blocked: --unknown free (unknown='free') plans "
                        "through them")
            graded = getattr(layers, "graded", None)  # None from older pickles
            if graded is not None and graded.shape == grid.blocked.shape \
                    and graded[xy[1], xy[0]]:
                return ("; the cell holds a graded occupancy (1-99: a costmap's inflation "
                        "cost, a scale-mode map's grey), blocked by the rule for graded "
                        "cells: --occupied-from N (occupied_from=N) blocks only those of N "
                        "and more (99 for a costmap: its lethal and inscribed cells)")
            return ""
    return ""


def _on_the_map(frame: MapFrame | None, grid: Grid) -> str:
    """Where a blocked endpoint lies in the map's own terms: its map cells (a coarsened
    map) and its centre in metres (a map with a resolution); "" for a bare grid."""
    if frame is None or (frame.coarsen == 1 and not frame.has_metres):
        return ""
    for xy in (grid.start_xy, grid.goal_xy):  # the first blocked one, as check_endpoints
        if grid.blocked_np()[xy[1], xy[0]]:
            where = []
            if frame.coarsen > 1:
                middle = tuple(int(v) for v in frame.map_cell(np.asarray(xy)))
                where.append(f"the coarse cell around map cell {middle}")
            if frame.has_metres:
                x, y = frame.to_world(np.asarray(xy, float))
                where.append(f"centre ({frame.coordinate_text(x)}, {frame.coordinate_text(y)}) m")
            return f" ({', '.join(where)})"
    return ""
