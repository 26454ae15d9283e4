"""Load a grid map, a file or a built-in map, as a :class:`jaxga.Grid`, with the options
that change it on the way: endpoints (in cells or, on a ROS map, in metres), the corner
rule, coarsening, inflation by cells or by a robot's radius, and a ROS map's unknown cells.

Every loader returns a :class:`jaxga.Grid` in the library's convention (docs/maps.md):
``blocked[y, x]`` with ``y = 0`` the **bottom** row. The files are read by the readers of
:mod:`jaxga.maps.formats` (0/1 text, Moving AI ``.map``, ASCII art, images and ROS
``map_server`` maps), which flip the formats whose first row is the top.
:attr:`MapInfo.ros` keeps a ROS map's metadata: metres per cell and the origin, for world
coordinates (``start_world=``, ``goal_world=``).

The format is chosen from the file's content and extension (see :func:`detect_format`)
unless ``fmt=`` names it. Anything malformed - a missing or empty file, ragged rows, an
unknown character, a wrong Moving AI header, two ``S`` markers, an unreadable image, an
image whose pixel data does not match its header - raises
:class:`~jaxga.core.errors.MapFormatError` with a one-line message that names the file,
the problem and, where it helps, the line. Only a regular file is read, and no more of it
than a map within the size limit takes (:mod:`jaxga.maps.inputs`): a FIFO, a device or a
huge file is refused at once. An option given for a format it has no effect on (a
threshold on anything but an image, unknown cells on anything but a ROS map, metres on a
map without a resolution) is refused too, not ignored.

Endpoints: ``start`` defaults to ``(0, 0)`` and ``goal`` to ``(W - 1, H - 1)`` unless the
file names them (ASCII ``S``/``G``); explicit ``start=``/``goal=`` override both. Loaders
check that endpoints lie on the map but *not* that they are free (Moving AI maps have
blocked borders); :meth:`jaxga.Grid.check_endpoints` does that later.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import os
import types
from pathlib import Path
from typing import Any

import numpy as np

from jaxga.core.equality import ValueEquality
from jaxga.core.errors import EndpointError, MapFormatError
from jaxga.core.fields import python_scalar, shown_value
from jaxga.core.files import file_path
from jaxga.core.grid import Grid, as_xy, check_corner_rule, too_large
from jaxga.maps import builtin
from jaxga.maps.builtin import default_corner_rule
from jaxga.maps.formats import (
    FORMATS,
    XY,
    Source,
    declared_size,
    decode_text,
    detect_format,
    parse_01,
    parse_ascii,
    parse_movingai,
    parse_png,
    read_map_bytes,
)
from jaxga.maps.frame import MapFrame, world_point
from jaxga.maps.occupancy_grid import OccupancyGrid, is_occupancy_message
from jaxga.maps.preprocess import check_coarse_endpoints, coarsen_blocked, inflate_blocked
from jaxga.maps.ros import (
    RosMap,
    cell_to_world,
    check_occupied_from,
    occupancy,
    read_ros_image,
    read_ros_yaml,
    ros_blocked,
    world_to_cell,
)

__all__ = [
    "MapInfo",
    "MapLayers",
    "load_map",
    "load_map_info",
    "map_name",
]


@dataclasses.dataclass(frozen=True, eq=False)
class MapLayers(ValueEquality):
    """What each planning cell is, for plots: exclusive ``bool[H, W]`` masks (row 0 at the
    bottom, the planning grid's shape), in the order of precedence of a coarsened cell.

    Attributes:
        wall: obstacles of the map file (a ROS map's occupied cells, and its graded ones
            where unknown cells are blocked).
        margin: cells blocked only by the inflation (``--inflate``, ``--robot-radius``).
        unknown: a ROS map's unknown cells that are neither wall nor margin.
        unknown_blocked: whether unknown cells are planned on as blocked.
        graded: the walls that are graded cells (occupancy 1-99: a costmap's inflation, a
            scale-mode map's grey), not occupied ones, blocked by the default rule for
            graded cells (``unknown``); a part of ``wall``, not exclusive of it; None for
            a map without occupancies or loaded with ``occupied_from``. Tells why an
            endpoint is blocked.
    """

    wall: np.ndarray
    margin: np.ndarray
    unknown: np.ndarray
    unknown_blocked: bool = True
    graded: np.ndarray | None = None

    def coarsened(self, factor: int) -> MapLayers:
        """The layers of the map coarsened by ``factor``: a coarse cell is wall if any of
        its cells is, else margin if any is, else unknown if any is."""
        wall = coarsen_blocked(self.wall, factor)
        margin = coarsen_blocked(self.margin, factor) & ~wall
        unknown = coarsen_blocked(self.unknown, factor) & ~wall & ~margin
        # graded where a graded cell and no occupied one is: occupied_from then frees it
        graded = None if self.graded is None else (
            coarsen_blocked(self.graded, factor)
            & ~coarsen_blocked(self.wall & ~self.graded, factor))
        return MapLayers(wall, margin, unknown, self.unknown_blocked, graded)


@dataclasses.dataclass(frozen=True, eq=False)
class MapInfo(ValueEquality):
    """A loaded map together with where it came from.

    Attributes:
        name: short name for display: the built-in name, or the file name without its
            extension (see :func:`map_name`).
        path: the file that was read (an occupancy grid's name for one in memory).
        format: one of :data:`FORMATS`; "occupancy_grid" for an occupancy grid in memory
            (:class:`jaxga.maps.OccupancyGrid`, a ``nav_msgs/OccupancyGrid`` message);
            "grid" for a bare Grid given to the Planner.
        builtin: True when ``source`` was the name of a built-in map.
        grid: the loaded :class:`~jaxga.Grid`.
        ros: a ROS map's metadata (resolution in metres per map cell, origin; an
            occupancy grid's too, with no image), else None.
        frame: planning cells against the file's cells and metres (:mod:`jaxga.maps.frame`:
            the coarsening factor, the resolution and origin of a ROS map).
        layers: walls, inflation margin and unknown cells of the planning grid, for plots.
        defaulted: the endpoints (``"start"``, ``"goal"``) that were neither given nor
            marked in the file, so took their default corners.
        options: the options of :func:`load_map` that shaped its cells, as given
            (``fmt``, ``coarsen``, ``threshold``, ``unknown``, ``occupied_from``,
            ``inflate``, ``robot_radius``; endpoints and the corner rule are the
            problem's), as ``(name, value)`` pairs: a saved result names them
            (:meth:`source_json`), so that its map can be loaded again as it was.
    """

    name: str
    path: Path
    format: str
    builtin: bool
    grid: Grid
    ros: RosMap | None = None
    frame: MapFrame | None = None
    layers: MapLayers | None = None
    defaulted: tuple[str, ...] = ()
    options: tuple[tuple[str, Any], ...] = ()

    def source_json(self) -> dict[str, Any]:
        """Where the map came from and how it was loaded, as a result's JSON records it
        (``map_source``): the file (a built-in map's or an occupancy grid's name), its
        format, whether it is built in, and :attr:`options`."""
        return {"path": str(self.path), "format": self.format, "builtin": self.builtin,
                "options": {k: python_scalar(v) if not isinstance(v, (tuple, list))
                            else list(v) for k, v in self.options}}

    @property
    def resolution(self) -> float | None:
        """Metres per PLANNING cell (a ROS map's ``resolution`` times the coarsening
        factor), None for the formats without one."""
        return None if self.frame is None else self.frame.cell_size


LOADING_OPTIONS = ("fmt", "coarsen", "threshold", "unknown", "occupied_from", "inflate",
                   "robot_radius")
"""The options of :func:`load_map` that shape a map's cells (:attr:`MapInfo.options`)."""


# --------------------------------------------------------------------------- public
GENERIC_STEMS = frozenset({"map"})
"""File stems that name no map (``map_saver`` writes ``map.yaml`` and ``map.pgm``): such a
map is named by its folder."""


def map_name(source: Source) -> str:
    """Short display name of a map source: a built-in name itself, else the file stem,
    or the folder's name for a generic one (:data:`GENERIC_STEMS`).

    ``map_name("den312d") == "den312d"``, ``map_name("maps/arena.map") == "arena"``,
    ``map_name("worlds/office/map.yaml") == "office"``; bytes of the file name that are
    not UTF-8 are shown as escapes (``caf\\udce9``). Does not read the file.
    """

    if isinstance(source, str) and source in builtin.builtin_names():
        return source
    path = file_path(source, "a map", MapFormatError)
    name = path.stem
    if path.stem.lower() in GENERIC_STEMS:
        name = path.resolve().parent.name or path.stem
    # a file name's bytes that are not UTF-8 (lone surrogates in Python) shown escaped:
    # a plot's title, a JSON parser and a terminal cannot take them
    return name.encode("utf-8", "backslashreplace").decode("utf-8")


def load_map(
    source: Source | OccupancyGrid,
    *,
    start: XY | None = None,
    goal: XY | None = None,
    corner_rule: str | None = None,
    fmt: str | None = None,
    coarsen: int | None = None,
    threshold: float | None = None,
    unknown: str | None = None,
    occupied_from: int | None = None,
    start_world: tuple[float, float] | None = None,
    goal_world: tuple[float, float] | None = None,
    inflate: float | None = None,
    robot_radius: float | None = None,
) -> Grid:
    """Load a map file or a built-in map as a :class:`~jaxga.Grid`.

    Args:
        source: a path (``str`` or ``os.PathLike``), the name of a built-in map (see
            :func:`jaxga.maps.builtin_names`), or an occupancy grid in memory: a
            :class:`jaxga.maps.OccupancyGrid` or a ``nav_msgs/OccupancyGrid`` message
            (:mod:`jaxga.maps.occupancy_grid`), which takes the options of a ROS map.
            A ``str`` that is a built-in name is the built-in map even if a file of that
            name exists in the working directory (write ``./name`` for the file); a
            ``Path`` is always a file.
        start: ``(x, y)`` start (y counted from the bottom); default: the file's ``S``
            marker (ASCII), else ``(0, 0)``.
        goal: ``(x, y)`` goal; default: the file's ``G`` marker, else ``(W - 1, H - 1)``.
        corner_rule: ``"free"``, ``"no_squeeze"`` or ``"strict"``; default
            the map's own (:func:`jaxga.maps.default_corner_rule`): ``"free"`` on the
            papers' classic 20 x 20 maps, ``"strict"`` on every other map.
        fmt: force a format from :data:`FORMATS` instead of detecting it.
        coarsen: merge ``k x k`` cells into one, blocked when any of them is
            (:func:`jaxga.maps.coarsen_blocked`); ``start`` and ``goal`` (and a file's
            ``S``/``G``) are given on the original map and move to the coarse cells
            holding them, ``(x // k, y // k)``. The way to plan on a map of more than
            :data:`jaxga.core.grid.MAX_MAP_CELLS` cells. A factor that puts two distinct
            endpoints into one coarse cell, or that blocks the coarse cell of one, is
            refused (:class:`~jaxga.core.errors.EndpointError`).
        threshold: images (PNG, PGM, ...): a pixel with luminance below it (0 black, 1
            white) is blocked; default 0.5. Refused for any other format, on which it
            would have no effect (a ROS map's YAML sets its own thresholds).
        unknown: ROS maps and occupancy grids: ``"blocked"`` (default) or ``"free"``
            for unknown (and, without ``occupied_from``, graded) cells. Refused for any
            other format: only these have unknown cells.
        occupied_from: ROS maps and occupancy grids: the occupancy (an integer 1-100)
            from which a cell is blocked; the graded cells below it are free and unknown
            cells follow ``unknown``. ``99`` plans on a costmap as ``costmap_2d``'s
            planners do, its lethal 100 and inscribed 99 blocked
            (:func:`jaxga.maps.ros.ros_blocked`). Default: every graded cell goes with
            the unknown ones. Refused for any other format.
        start_world: ROS maps: the start in metres (world frame); the cell that holds
            it (:func:`jaxga.maps.ros.world_to_cell`). Not with ``start``; refused on a
            map without a resolution and an origin.
        goal_world: the goal in metres, as ``start_world``.
        inflate: grow the obstacles by this many cells (:func:`jaxga.maps.inflate`: every
            cell whose centre lies within that distance of a blocked cell's centre),
            on the map's own cells, before ``coarsen``.
        robot_radius: ROS maps: the robot's radius in metres, plus any safety distance
            wanted (nothing is added to it); the obstacles grow by
            ``robot_radius / resolution`` cells. Not with ``inflate``;
            refused on a map without a resolution.

    Options that would have no effect on the map's format are refused rather than
    ignored, so that a map is never planned on other than the caller asked.

    Raises:
        MapFormatError: missing, unreadable or malformed file; unknown built-in name; a
            map over :data:`jaxga.core.grid.MAX_MAP_CELLS` cells (after ``coarsen``), refused
            from the file's header or line count before it is parsed; a file that is not
            a regular file or is larger than jaxga reads for a map
            (:func:`jaxga.maps.inputs.map_file_cap`); an image whose pixel data does not
            match its header (:func:`jaxga.maps.inputs.check_image_data`); an option with
            no effect on the map's format; a ``coarsen`` factor larger than the map's
            longer side.
        EndpointError: an endpoint that is not a pair of integers (or, in metres, of
            numbers), off the map, or start and goal merged or an endpoint blocked by
            ``coarsen``. (Blocked endpoints are otherwise *not* checked here;
            see :meth:`jaxga.Grid.check_endpoints`.)
    """
    return load_map_info(**locals()).grid  # every argument above, by name


def load_map_info(source: Source | OccupancyGrid, **options: Any) -> MapInfo:
    """:func:`load_map` with the same keyword options, returning a :class:`MapInfo` (name,
    path, format, grid, frame, layers) instead of the grid alone.

    The options are :func:`load_map`'s own, checked against its signature (one list of
    options, documented there): an unknown one is a ``TypeError``, as in any call.
    """
    try:
        bound = inspect.signature(load_map).bind(source, **options)
    except TypeError as e:
        raise TypeError(f"load_map_info() {e}") from None
    bound.apply_defaults()
    o = types.SimpleNamespace(**bound.arguments)
    rule = check_corner_rule(default_corner_rule(source) if o.corner_rule is None
                             else o.corner_rule)
    if o.fmt is not None and o.fmt not in FORMATS:
        raise MapFormatError(f"unknown map format {o.fmt!r}: expected one of {', '.join(FORMATS)}")
    factor = 1 if o.coarsen is None else _coarsen_factor(o.coarsen)
    if isinstance(source, OccupancyGrid) or is_occupancy_message(source):
        return _from_occupancy_grid(source, o, rule, factor)
    is_builtin = isinstance(source, str) and source in builtin.builtin_names()
    if is_builtin:
        path = builtin.builtin_path(source)  # type: ignore[arg-type]
    else:
        if not isinstance(source, (str, os.PathLike)):
            hint = ("; an array becomes a map through jaxga.Grid.create(blocked), or with "
                    "its resolution and origin through jaxga.maps.OccupancyGrid"
                    if hasattr(source, "shape") else "")
            raise MapFormatError(f"a map source must be a file path or a built-in map name "
                                 f"(or an occupancy grid), got {shown_value(source)}{hint}")
        path = Path(os.fspath(source))
    label = str(source) if is_builtin else str(path)

    bare_name = isinstance(source, str) and not is_builtin and Path(source).name == source
    is_yaml = o.fmt == "ros" or (o.fmt is None and path.suffix.lower() in (".yaml", ".yml"))
    raw = read_map_bytes(path, label, builtin_hint=bare_name and not Path(source).suffix,
                      yaml=is_yaml, coarsen=factor)
    kind = o.fmt or detect_format(path, raw)
    _check_options_apply(kind, label, threshold=o.threshold, unknown=o.unknown,
                         occupied_from=o.occupied_from, robot_radius=o.robot_radius,
                         start_world=o.start_world,
                         goal_world=o.goal_world)
    size = declared_size(raw, kind)
    if size is not None:  # refuse a map too large from its header (decision 021)
        w0, h0 = size
        message = too_large(-(-w0 // factor), -(-h0 // factor))
        if message:
            raise MapFormatError(f"{label}: {message}")
    ros = None
    unknown_cells = graded_cells = None
    if kind == "png":
        blocked = parse_png(path, label, 0.5 if o.threshold is None else o.threshold, raw)
        file_start = file_goal = None
    elif kind == "ros":
        ros = read_ros_yaml(path, label, data=raw)
        occ = occupancy(read_ros_image(ros, label, coarsen=factor), ros)
        blocked = ros_blocked(occ, "blocked" if o.unknown is None else o.unknown,
                              o.occupied_from)
        unknown_cells = np.ascontiguousarray((occ == -1)[::-1])
        graded_cells = np.ascontiguousarray(((occ >= 1) & (occ <= 99))[::-1])
        file_start = file_goal = None
    else:
        text = decode_text(raw, label)
        if kind == "movingai":
            blocked = parse_movingai(text, label)
            file_start = file_goal = None
        elif kind == "ascii":
            blocked, file_start, file_goal = parse_ascii(text, label)
        else:
            blocked = parse_01(text, label)
            file_start = file_goal = None

    return _assembled(blocked, unknown_cells, ros, file_start, file_goal, o, rule, factor,
                      label, shown_name=map_name(source), path=path, kind=kind,
                      is_builtin=is_builtin, graded_cells=graded_cells)


def _from_occupancy_grid(source: Any, o: types.SimpleNamespace, rule: str,
                         factor: int) -> MapInfo:
    """:func:`load_map_info` of an :class:`OccupancyGrid` or a ``nav_msgs/OccupancyGrid``
    message: its occupancies planned on as a ``map_server`` map's are."""
    grid = source if isinstance(source, OccupancyGrid) else OccupancyGrid.from_message(source)
    label = f"occupancy grid {grid.name!r}"
    if o.fmt is not None:
        raise MapFormatError(f"{label}: a map format (fmt={o.fmt!r}) has no effect on an "
                             "occupancy grid, which is no file")
    _check_options_apply("occupancy_grid", label, threshold=o.threshold, unknown=o.unknown,
                         occupied_from=o.occupied_from, robot_radius=o.robot_radius,
                         start_world=o.start_world,
                         goal_world=o.goal_world)
    message = too_large(-(-grid.width // factor), -(-grid.height // factor))
    if message:
        raise MapFormatError(f"{label}: {message}")
    ros = RosMap(image=None, resolution=grid.resolution, origin=grid.origin)
    top_first = grid.occupancy[::-1]  # ros_blocked reads an image's rows, top first
    try:
        blocked = ros_blocked(top_first, "blocked" if o.unknown is None else o.unknown,
                              o.occupied_from)
    except MapFormatError as e:
        raise MapFormatError(f"{label}: {e}") from None
    unknown_cells = np.ascontiguousarray(grid.occupancy == -1)
    graded_cells = np.ascontiguousarray((grid.occupancy >= 1) & (grid.occupancy <= 99))
    return _assembled(blocked, unknown_cells, ros, None, None, o, rule, factor, label,
                      shown_name=grid.name, path=Path(grid.name), kind="occupancy_grid",
                      is_builtin=False, graded_cells=graded_cells)


def _assembled(blocked: np.ndarray, unknown_cells: np.ndarray | None, ros: RosMap | None,
               file_start: XY | None, file_goal: XY | None, o: types.SimpleNamespace,
               rule: str, factor: int, label: str, *, shown_name: str, path: Path, kind: str,
               is_builtin: bool, graded_cells: np.ndarray | None = None) -> MapInfo:
    """The :class:`MapInfo` of a map's cells as read (``blocked``, row 0 the bottom, the
    ROS map's unknown cells and metadata): the endpoints, inflation, layers, frame and
    coarsening that :func:`load_map`'s options ask for."""
    if factor > max(blocked.shape):  # 2**63 would ask for blocks no array can hold
        h0, w0 = blocked.shape
        raise MapFormatError(f"{label}: coarsen {factor} is more than the map's longer side "
                             f"({w0} x {h0} cells): a factor of {max(h0, w0)} already "
                             "merges it into one cell")
    try:  # integer pairs before any use (inflation and coarsening index with them)
        s = as_xy("start", o.start) if o.start is not None else file_start
        g = as_xy("goal", o.goal) if o.goal is not None else file_goal
    except EndpointError as e:
        raise EndpointError(f"{label}: {e}") from None
    for name, xy, world in (("start", o.start, o.start_world), ("goal", o.goal, o.goal_world)):
        if world is None or ros is None:  # without a frame: refused above
            continue
        if xy is not None:
            raise EndpointError(f"{label}: give the {name} in cells or in metres, not both")
        try:
            cell = world_to_cell(ros, world_point(name, world), blocked.shape, f"the {name}")
        except EndpointError as e:
            raise EndpointError(f"{label}: {e}") from None
        s, g = (cell, g) if name == "start" else (s, cell)
    walls = blocked & ~unknown_cells if unknown_cells is not None else blocked
    map_blocked = blocked
    blocked = _inflated(blocked, ros, o.inflate, o.robot_radius, s, g, label)
    layers = MapLayers(
        wall=walls, margin=blocked & ~map_blocked,
        unknown=(np.zeros_like(blocked) if unknown_cells is None
                 else unknown_cells & ~walls & ~(blocked & ~map_blocked)),
        unknown_blocked=o.unknown != "free",
        # cells blocked by the default rule for graded ones; with occupied_from, by the
        # caller's own threshold
        graded=(None if graded_cells is None or o.occupied_from is not None
                else graded_cells & walls))
    frame = MapFrame(map_shape=blocked.shape, coarsen=factor,
                     resolution=None if ros is None else ros.resolution,
                     origin=None if ros is None else ros.origin, obstacles=map_blocked,
                     robot_radius=o.robot_radius)
    if factor > 1:
        h0, w0 = blocked.shape
        for name, xy in (("start", s), ("goal", g)):
            if xy is not None and not (0 <= xy[0] < w0 and 0 <= xy[1] < h0):
                raise EndpointError(f"{label}: {name} map cell {tuple(xy)} is off the "
                                    f"{w0} x {h0} map")
        check_coarse_endpoints(s if s is not None else (0, 0),
                               g if g is not None else (w0 - 1, h0 - 1), factor, label)
        coarse = coarsen_blocked(blocked, factor)
        layers = layers.coarsened(factor)
        for name, xy in (("start", s), ("goal", g)):
            if xy is not None and coarse[xy[1] // factor, xy[0] // factor] \
                    and not blocked[xy[1], xy[0]]:
                raise EndpointError(
                    f"{label}: the {name}, map cell {tuple(xy)}, lies in coarse cell "
                    f"({xy[0] // factor}, {xy[1] // factor}) (map cells {factor} x {factor} "
                    f"from ({xy[0] // factor * factor}, {xy[1] // factor * factor})), which "
                    "holds an obstacle: coarsened, it is blocked")
        blocked = coarse
        s = None if s is None else (s[0] // factor, s[1] // factor)
        g = None if g is None else (g[0] // factor, g[1] // factor)
    message = too_large(blocked.shape[1], blocked.shape[0])
    if message:
        raise MapFormatError(f"{label}: {message}")
    try:
        grid = Grid.create(blocked, start=s, goal=g, corner_rule=rule)
    except EndpointError as e:
        raise EndpointError(f"{label}: {e}") from None
    defaulted = tuple(n for n, xy in (("start", s), ("goal", g)) if xy is None)
    options = tuple((k, getattr(o, k)) for k in LOADING_OPTIONS
                    if getattr(o, k) is not None)
    return MapInfo(name=shown_name, path=path, format=kind, builtin=is_builtin, grid=grid,
                   ros=ros, frame=frame, layers=layers, defaulted=defaulted, options=options)


def _inflated(blocked: np.ndarray, ros: RosMap | None, cells: float | None,
              metres: float | None, start: XY | None, goal: XY | None,
              label: str) -> np.ndarray:
    """``blocked`` with its obstacles grown by ``cells`` (or ``metres / resolution``); an
    endpoint that only the growth blocks is an :class:`EndpointError` naming it."""
    if metres is not None:
        if cells is not None:
            raise MapFormatError(f"{label}: give the inflation in cells or the robot's "
                                 "radius in metres, not both")
        if ros is None:
            raise MapFormatError(f"{label}: a robot radius in metres needs a map with a "
                                 "resolution (a ROS map_server .yaml); inflate by cells "
                                 "instead")
        metres = python_scalar(metres)  # np.float32(0.1) is 0.1
        if isinstance(metres, bool) or not isinstance(metres, (int, float)) or not (
                math.isfinite(metres) and metres >= 0):
            raise MapFormatError(f"{label}: the robot radius must be >= 0 metres, got "
                                 f"{metres!r}")
        cells = metres / ros.resolution
        if not math.isfinite(cells):  # 1e308 m on 0.05 m cells
            raise MapFormatError(f"{label}: the robot radius must be a finite number of "
                                 f"the map's {ros.resolution:g} m cells, got {metres:g} m")
    if cells is None:
        return blocked
    out = inflate_blocked(blocked, cells)
    h, w = blocked.shape
    size = f"{cells:g} cells" + ("" if metres is None else f" ({metres:g} m)")
    for name, xy in (("start", start), ("goal", goal)):  # the endpoints given, if any
        if xy is None:
            continue
        x, y = xy
        if 0 <= x < w and 0 <= y < h and out[y, x] and not blocked[y, x]:
            where = "" if ros is None else " at ({:.3f}, {:.3f}) m".format(
                *cell_to_world(ros, (x, y)))
            raise EndpointError(f"{label}: the {name}, map cell ({x}, {y}){where}, lies "
                                f"within {size} of an obstacle: the inflated map blocks it")
    return out


# -------------------------------------------------------------------------- helpers
def _coarsen_factor(value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise MapFormatError(f"coarsen must be a positive integer, got {value!r}")
    return int(value)


_FORMAT_NAMES = {"01": "a 0/1 text map", "movingai": "a Moving AI map",
                 "ascii": "an ASCII-art map", "png": "an image", "ros": "a ROS map_server map",
                 "occupancy_grid": "an occupancy grid"}


def _check_options_apply(kind: str, label: str, *, threshold: float | None,
                         unknown: str | None, occupied_from: int | None,
                         robot_radius: float | None,
                         start_world: tuple[float, float] | None,
                         goal_world: tuple[float, float] | None) -> None:
    """Refuse, in one line saying why, an option given for a map format on which it has
    no effect: it would be ignored, and the map planned on other than the caller asked."""
    what = _FORMAT_NAMES.get(kind, f"a {kind} map")
    if threshold is not None and kind != "png":
        why = ("its YAML's occupied_thresh and free_thresh decide which pixels are "
               "blocked" if kind == "ros" else "its values are occupancies already"
               if kind == "occupancy_grid" else "only an image's pixels are thresholded")
        raise MapFormatError(f"{label}: the image threshold (--threshold, threshold=) has no "
                             f"effect on {what}: {why}")
    if unknown is not None and kind not in ("ros", "occupancy_grid"):
        why = ("an image's grey pixels are thresholded like the others (load the map's "
               "map_server .yaml to keep them apart)" if kind == "png"
               else "this map has none")
        raise MapFormatError(f"{label}: the setting for unknown cells (--unknown, unknown=) "
                             f"has no effect on {what}: only a ROS map_server map (.yaml) "
                             f"has unknown cells; {why}")
    if occupied_from is not None and kind not in ("ros", "occupancy_grid"):
        raise MapFormatError(f"{label}: the occupancy from which a cell is blocked "
                             f"(--occupied-from, occupied_from=) has no effect on {what}: "
                             "only a ROS map_server map (.yaml) or an occupancy grid has "
                             "occupancies")
    if kind in ("ros", "occupancy_grid"):
        if occupied_from is not None:
            try:
                check_occupied_from(occupied_from)
            except MapFormatError as e:
                raise MapFormatError(f"{label}: {e}") from None
        return
    if robot_radius is not None:
        raise MapFormatError(f"{label}: a robot radius in metres needs a map with a "
                             f"resolution (a ROS map_server .yaml), and {what} has none; "
                             "inflate by cells instead")
    for name, world in (("start", start_world), ("goal", goal_world)):
        if world is not None:
            raise EndpointError(f"{label}: a {name} in metres needs a map with a resolution "
                                f"and an origin (a ROS map_server .yaml), and {what} has "
                                "neither; give it in cells")
