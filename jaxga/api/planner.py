"""A planner for a robot node: a map loaded once, then a plan for any start and goal.

A ROS node loads its map when it starts and is then asked for paths between new poses,
many times. :class:`Planner` does the map's work once (the file read, the inflation by the
robot's radius, the frame, the distance transform that the clearance is measured with)
and :meth:`Planner.plan` does only what a new start and goal need: their distance
fields, the runs (the compiled programs take the endpoints as inputs and hold the map's
longest optimal path, so a new pair compiles nothing) and the references within their
budget::

    planner = jaxga.Planner("map.yaml", robot_radius=0.2)   # or an OccupancyGrid message
    plan = planner.plan(start_world=(1.0, 2.0), goal_world=(-3.5, 0.25))
    best = plan.best_seed()                  # None when no seed found a path
    plan.world_path(best)                    # float[k, 2], metres
    jaxga.export.write_path("path.yaml", plan.world_path(best))   # nav_msgs/Path, or .csv

Each plan is a :class:`jaxga.api.result.Result`, the same as :func:`jaxga.run` returns.
"""

from __future__ import annotations

import dataclasses
import types
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from jaxga._runtime.seeds import seed_list
from jaxga._runtime.size_classes import auto_size_class, class_shape
from jaxga.api.problem import load_problem
from jaxga.api.result import Result
from jaxga.api.runs import check_call_options, run
from jaxga.config.schema import SCHEMA, Config
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, check_corner_rule
from jaxga.core.own_settings import own_settings
from jaxga.engine.algorithm import map_capacity
from jaxga.maps import MapInfo, load_map_info
from jaxga.maps.frame import endpoint_cells

__all__ = ["Planner"]

Point = tuple[float, float]


class Planner:
    """A preset on one loaded map, planning any start and goal.

    Args:
        map: a map file (a ROS ``map_server`` YAML, an image, a Moving AI map, ...), a
            built-in map's name, an occupancy grid in memory (a ``nav_msgs/OccupancyGrid``
            message, as a node receives its map, or a :class:`jaxga.maps.OccupancyGrid`),
            a :class:`jaxga.maps.MapInfo` already loaded, or a :class:`jaxga.Grid` (cells
            only: no metres, its own endpoints unused).
        preset: the preset (default ``"hybrid"``: a path on any map, close to the exact
            any-angle optimum), a TOML file or a :class:`Config`.
        seeds: runs per plan (the best of them is :meth:`Result.best_seed`).
        robot_radius: the robot's radius in metres, by which the obstacles grow (as
            :func:`jaxga.maps.load_map`; the following three too). A loaded MapInfo is
            loaded with these already: given with one, they are refused in one line.
        inflate: or the growth in cells.
        coarsen: K x K map cells into one planning cell.
        unknown: how a ROS map's unknown cells are planned on.
        occupied_from: the occupancy from which a ROS map's or an occupancy grid's cell
            is blocked (``99`` for a costmap: its lethal and inscribed cells).
        corner_rule: the corner rule (default: the map's own; applied to a loaded MapInfo
            too, as :func:`jaxga.run` applies it).
        any_angle_budget: as :func:`jaxga.run`: seconds the any-angle reference may
            take after each plan's runs (``"auto"``: at most their own time); 0 skips it.
        size_class: as :func:`jaxga.run`: ``True`` plans on the map padded to its size
            class, so that maps of other sizes in one class (a map that grows as it is
            explored) share the compiled programs; ``None``, the default, pads maps with
            a side over 64 cells.
        **overrides: configuration keys, as :func:`jaxga.run` takes them.

    Attributes:
        map: the :class:`jaxga.maps.MapInfo` planned on. A new map (a costmap update):
            :meth:`update_map`, or ``planner.map = ...``, which does the same.
        capacity: (read-only) the path capacity of the planner's programs, the same for
            every start and goal: the most cells an optimal path of the map can have,
            times the preset's ``population.capacity_factor``
            (:func:`jaxga.engine.algorithm.map_capacity`), and never less, through
            :meth:`update_map`, than any map planned on before whose programs have the
            same shape (a costmap updated: its programs are compiled again only when a
            map needs more than every map of that shape before); None where the preset
            or the overrides set ``population.capacity``. A plan equals
            :func:`jaxga.run` on the same pair with ``population.capacity`` set to it
            (and the planner's ``size_class``).
        overrides: (read-only) the configuration keys each plan runs with: the
            constructor's, and ``population__capacity``. Other keys: a new planner.
    """

    @own_settings
    def __init__(self, map: str | Any, preset: str | Config = "hybrid", *, seeds: int = 8,
                 robot_radius: float | None = None, inflate: float | None = None,
                 coarsen: int | None = None, unknown: str | None = None,
                 occupied_from: int | None = None, corner_rule: str | None = None,
                 any_angle_budget: float | str | None = "auto",
                 size_class: bool | None = None, **overrides: Any) -> None:
        self.preset = preset
        self.seeds = _checked_seeds(seeds)
        check_call_options(None, 1, size_class, any_angle_budget)  # now, not at a plan
        self.any_angle_budget = any_angle_budget
        self._size_class = size_class
        self._loading = {"robot_radius": robot_radius, "inflate": inflate,
                         "coarsen": coarsen, "unknown": unknown,
                         "occupied_from": occupied_from}
        self._corner_rule = corner_rule
        self._overrides = overrides
        self._planned_on = self._prepared(map, loaded_refused=True)

    @own_settings
    def update_map(self, map: str | Any) -> None:
        """Plan on ``map`` from the next :meth:`plan` on (a robot's costmap updated, a new
        floor). A file, a built-in name or an occupancy grid (a ``nav_msgs/OccupancyGrid``
        message: ``planner.update_map(msg)`` in the map topic's callback) is loaded with
        the planner's ``robot_radius``, ``inflate``, ``coarsen``, ``unknown``,
        ``occupied_from`` and ``corner_rule``. A map loaded already (a
        :class:`jaxga.maps.MapInfo` or a :class:`jaxga.Grid`) is planned on as it is,
        under the planner's ``corner_rule`` if it was given one: its caller loaded it
        with the robot's radius (``jaxga.maps.load_map_info(path, robot_radius=...)``).
        The planner then plans as one made on the new map with ``population__capacity``
        set to its :attr:`capacity`, which follows the new map's longest optimal path
        but is never less than any map's before whose programs have the same shape (the
        same size, or the same size class): a costmap update compiles nothing unless
        its map needs more than every map of that shape before, and then once. Give
        ``population__capacity`` to the constructor to keep one capacity, and its
        programs, through every update. A plan under way in another thread finishes on
        the map it started with; a map refused leaves the planner as it was."""
        self._planned_on = self._prepared(map, loaded_refused=False)

    @property
    def map(self) -> MapInfo:
        return self._planned_on[0]

    @map.setter
    def map(self, map: str | Any) -> None:
        self.update_map(map)

    @property
    def capacity(self) -> int | None:
        return self._planned_on[1]

    @property
    def overrides(self) -> Mapping[str, Any]:
        return types.MappingProxyType(self._planned_on[2])

    def __setstate__(self, state: dict) -> None:
        """A planner pickled by a version whose ``map``, ``capacity`` and ``overrides``
        were plain attributes unpickles as the same planner."""
        if "_planned_on" not in state:
            state = dict(state)
            info, capacity = state.pop("map"), state.pop("capacity")
            overrides = state.pop("overrides")
            state["_planned_on"] = (info, capacity, overrides)
            state["_overrides"] = {k: v for k, v in overrides.items()
                                   if capacity is None or k != "population__capacity"}
            state["_loading"] = None  # not kept then: a file cannot be loaded as before
            state["_corner_rule"] = None
        self.__dict__.update(state)

    def _prepared(self, map: str | Any, loaded_refused: bool
                  ) -> tuple[MapInfo, int | None, dict]:
        """``(map info, capacity, overrides)`` of a map: what a plan reads, made whole
        before the planner takes it, so that a thread planning meanwhile sees the old map
        or the new one, never parts of both. ``loaded_refused``: the loading options were
        given in the same call as a loaded map (the constructor), which they cannot
        change."""
        if self._loading is None and not isinstance(map, (MapInfo, Grid)):
            raise ParameterError(
                "this Planner was pickled by an older jaxga, which did not keep its "
                "robot_radius, inflate, coarsen, unknown and occupied_from: give "
                "update_map a map loaded with them (jaxga.maps.load_map_info(path, ...)), "
                "or make a new Planner")
        loading = [name for name, value in self._loading.items()
                   if value is not None] if loaded_refused else []
        corner_rule = self._corner_rule
        if isinstance(map, MapInfo):
            if loading:  # they were ignored without a word
                raise ParameterError(
                    f"{', '.join(loading)} given with a loaded map (a MapInfo), which they "
                    f"no longer change: load the map with them (jaxga.maps.load_map_info("
                    f"path, {loading[0]}=...)) or give the Planner the map's path")
            info = map if corner_rule is None else dataclasses.replace(
                map, grid=map.grid.replace(corner_rule=check_corner_rule(corner_rule)))
        elif isinstance(map, Grid):  # a map of the user's own, in cells
            if loading:
                raise ParameterError(
                    f"{', '.join(loading)} given with a Grid, which has no metres nor "
                    "unknown cells: inflate or coarsen its array first, or give the "
                    "Planner a map file")
            grid = map.validated()
            if corner_rule is not None:
                grid = grid.replace(corner_rule=check_corner_rule(corner_rule))
            info = MapInfo(name="grid", path=Path("grid"), format="grid", builtin=False,
                           grid=grid)
        else:
            info = load_map_info(map, corner_rule=corner_rule, **self._loading)
        overrides = self._overrides
        config = load_problem(self.preset, info, None, None, (), overrides, None,
                              check_endpoints=False)[0]
        capacity: int | None = None
        if not int(config["population.capacity"]) and not {
                "population.capacity", "population__capacity"} & overrides.keys():
            # programs sized for the map's longest optimal path, not its size class's
            capacity = map_capacity(info.grid, float(config["population.capacity_factor"]))
            shape = _program_shape(info.grid, getattr(self, "_size_class", None))
            largest = self.__dict__.setdefault("_largest", {})  # {} in an older pickle
            capacity = max(capacity, largest.get(shape, 0))  # its programs: no compile
            most = SCHEMA["population.capacity"].high
            if capacity > most:  # refused here, not at the first plan as an override
                raise ParameterError(
                    f"Planner: the longest optimal path of this {info.grid.width} x "
                    f"{info.grid.height} map may need {capacity:,} path cells, more "
                    f"than jaxga's {most:,}: load it coarser (coarsen=2) or give "
                    "population__capacity")
            overrides = {**overrides, "population__capacity": capacity}
            largest[shape] = capacity  # the most any map of this program shape needed
        if info.frame is not None:
            _ = info.frame.clearance  # the distance transform: once per map, not per plan
        return info, capacity, overrides

    def __repr__(self) -> str:
        preset = self.preset if isinstance(self.preset, str) else type(self.preset).__name__
        seeds = self.seeds if isinstance(self.seeds, int) else len(self.seeds)
        return (f"Planner({preset!r} on {self.map.name!r}, {self.map.grid.width} x "
                f"{self.map.grid.height} cells, {seeds} seeds)")

    @own_settings
    def plan(self, start: tuple[int, int] | None = None, goal: tuple[int, int] | None = None,
             *, start_world: Point | None = None, goal_world: Point | None = None,
             seeds: int | None = None, progress: Callable[[str, float], None] | None = None,
             any_angle_budget: float | str | None = None) -> Result:
        """Plan from ``start`` to ``goal`` (planning cells ``(x, y)``, y from the bottom) or
        from ``start_world`` to ``goal_world`` (metres, the map's frame; snapped to the
        centre of their cells). ``seeds`` and ``any_angle_budget`` default to the
        planner's; ``progress`` as :func:`jaxga.run`. A blocked or unreachable endpoint
        is a one-line error or a result with no path that names the cause, as for
        :func:`jaxga.run`."""
        info, _, overrides = self._planned_on  # one map, whatever update_map does
        ends = endpoint_cells(info.frame, info.grid, start, goal, start_world, goal_world)
        grid = info.grid.replace(start=ends[0], goal=ends[1])
        problem = dataclasses.replace(info, grid=grid, defaulted=())  # both given
        budget = self.any_angle_budget if any_angle_budget is None else any_angle_budget
        return run(self.preset, problem, self.seeds if seeds is None else seeds,
                   progress=progress, any_angle_budget=budget,
                   size_class=getattr(self, "_size_class", None), **overrides)


def _program_shape(grid: Grid, size_class: bool | None) -> tuple[int, int]:
    """The shape of the map a plan's programs run on: its size class's where the plan
    pads it (``size_class``, as :func:`jaxga.run` reads it), else its own."""
    padded = auto_size_class(grid) if size_class is None else size_class
    shape = class_shape(grid.height, grid.width) if padded else None
    return shape or grid.shape


class _Counted(Exception):
    """Raised by :func:`_checked_seeds`'s count check: the seeds were read, and nothing of
    their number need be allocated."""


def _checked_seeds(seeds: Any) -> Any:
    """``seeds`` as given, once :func:`jaxga._runtime.seeds.seed_list` accepts them: a bad
    value is refused when the planner is made, not at its first plan."""
    def counted(n: int) -> None:
        raise _Counted

    if isinstance(seeds, Iterator):  # read once here: kept as the list it gave
        seeds = list(seeds)
    try:
        seed_list(seeds, counted)
    except _Counted:
        pass
    return seeds
