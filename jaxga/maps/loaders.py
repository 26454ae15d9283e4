"""Read and write grid maps: 0/1 text, Moving AI ``.map``, ASCII art, PNG images and ROS
``map_server`` maps (YAML + image).

Every loader returns a :class:`jaxga.Grid` in the library's convention (docs/maps.md):
``blocked[y, x]`` with ``y = 0`` the **bottom** row. The file formats differ in which
row comes first:

* ``"01"`` - ``0``/``1`` per cell (``1`` = obstacle), separated by spaces, tabs or
  commas or by nothing (``0 1 0`` or ``010``). **File line 1 is row y = 0, the
  bottom**, as in the classic GA maps and the papers' matrices.
* ``"movingai"`` - header ``type octile`` / ``height H`` / ``width W`` / ``map``, then H
  rows of W characters; ``.`` ``G`` ``S`` passable, ``@`` ``O`` ``T`` ``W`` blocked.
  **The first map row is the top** (Moving AI convention); it is flipped.
* ``"ascii"`` - ASCII art: ``.`` free, ``#`` or ``@`` blocked, at most one ``S``
  (start) and one ``G`` (goal), both free cells. **The first text line is the top
  row**, as a human draws it; it is flipped.
* ``"png"`` - an image: a pixel whose luminance (ITU-R BT.601 luma, 0 black to 1 white)
  is below ``threshold`` (default 0.5, ``load_map(..., threshold=)``, ``--threshold``)
  is blocked; transparent pixels count as white (free). **The image's top row is the
  top of the map**; it is flipped. A robot's map with unknown (grey) areas is better
  loaded as a ROS map, which keeps unknown apart from free.
* ``"ros"`` - a ROS ``map_server`` YAML file (``.yaml``/``.yml``) and the image it names
  (:mod:`jaxga.maps.ros`: ``resolution``, ``origin``, ``negate``, ``occupied_thresh``,
  ``free_thresh``, ``mode``). Occupied cells are blocked, unknown ones too unless
  ``unknown="free"``. :attr:`MapInfo.ros` keeps the metadata: metres per cell and the
  origin, for world coordinates (``start_world=``, ``goal_world=``).

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
import io
import math
import os
import types
from pathlib import Path
from typing import Any

import numpy as np

from jaxga.core.errors import EndpointError, MapFormatError
from jaxga.core.grid import Grid, check_corner_rule, too_large
from jaxga.core.matplotlib_env import matplotlib_ready
from jaxga.maps import builtin
from jaxga.maps.builtin import default_corner_rule
from jaxga.maps.frame import MapFrame
from jaxga.maps.inputs import (
    MAX_READ_COARSEN,
    YAML_CAP,
    check_image_data,
    image_size,
    map_file_cap,
    map_file_cap_note,
    read_input,
)
from jaxga.maps.preprocess import check_coarse_endpoints, coarsen_blocked, inflate_blocked
from jaxga.maps.ros import (
    RosMap,
    cell_to_world,
    occupancy,
    read_ros_image,
    read_ros_yaml,
    ros_blocked,
    world_to_cell,
)

__all__ = [
    "FORMATS",
    "MapInfo",
    "MapLayers",
    "detect_format",
    "load_map",
    "load_map_info",
    "map_name",
    "parse_01",
    "parse_ascii",
    "parse_movingai",
    "save_map",
]

FORMATS: tuple[str, ...] = ("01", "movingai", "ascii", "png", "ros")
"""The map formats :func:`load_map` reads and :func:`save_map` writes."""

MOVINGAI_PASSABLE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")
ASCII_FREE = frozenset(".SG")
ASCII_BLOCKED = frozenset("#@")

_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
IMAGE_SUFFIXES = (".png", ".pgm", ".ppm", ".pbm", ".bmp", ".gif", ".jpg", ".jpeg", ".tif",
                  ".tiff")
"""Image files read as ``"png"`` maps (thresholded luminance; Pillow reads the others)."""
_ZERO_ONE = frozenset("01")
_SEPARATORS = frozenset(" \t,")

Source = str | os.PathLike
XY = tuple[int, int]


@dataclasses.dataclass(frozen=True)
class MapLayers:
    """What each planning cell is, for plots: exclusive ``bool[H, W]`` masks (row 0 at the
    bottom, the planning grid's shape), in the order of precedence of a coarsened cell.

    Attributes:
        wall: obstacles of the map file (a ROS map's occupied cells, and its graded ones
            where unknown cells are blocked).
        margin: cells blocked only by the inflation (``--inflate``, ``--robot-radius``).
        unknown: a ROS map's unknown cells that are neither wall nor margin.
        unknown_blocked: whether unknown cells are planned on as blocked.
    """

    wall: np.ndarray
    margin: np.ndarray
    unknown: np.ndarray
    unknown_blocked: bool = True

    def coarsened(self, factor: int) -> MapLayers:
        """The layers of the map coarsened by ``factor``: a coarse cell is wall if any of
        its cells is, else margin if any is, else unknown if any is."""
        wall = coarsen_blocked(self.wall, factor)
        margin = coarsen_blocked(self.margin, factor) & ~wall
        unknown = coarsen_blocked(self.unknown, factor) & ~wall & ~margin
        return MapLayers(wall, margin, unknown, self.unknown_blocked)


@dataclasses.dataclass(frozen=True)
class MapInfo:
    """A loaded map together with where it came from.

    Attributes:
        name: short name for display: the built-in name, or the file name without its
            extension (see :func:`map_name`).
        path: the file that was read.
        format: one of :data:`FORMATS`.
        builtin: True when ``source`` was the name of a built-in map.
        grid: the loaded :class:`~jaxga.Grid`.
        ros: a ROS map's metadata (resolution in metres per map cell, origin), else None.
        frame: planning cells against the file's cells and metres (:mod:`jaxga.maps.frame`:
            the coarsening factor, the resolution and origin of a ROS map).
        layers: walls, inflation margin and unknown cells of the planning grid, for plots.
    """

    name: str
    path: Path
    format: str
    builtin: bool
    grid: Grid
    ros: RosMap | None = None
    frame: MapFrame | None = None
    layers: MapLayers | None = None

    @property
    def resolution(self) -> float | None:
        """Metres per PLANNING cell (a ROS map's ``resolution`` times the coarsening
        factor), None for the formats without one."""
        return None if self.frame is None else self.frame.cell_size


# --------------------------------------------------------------------------- public
GENERIC_STEMS = frozenset({"map"})
"""File stems that name no map (``map_saver`` writes ``map.yaml`` and ``map.pgm``): such a
map is named by its folder."""


def map_name(source: Source) -> str:
    """Short display name of a map source: a built-in name itself, else the file stem,
    or the folder's name for a generic one (:data:`GENERIC_STEMS`).

    ``map_name("den312d") == "den312d"``, ``map_name("maps/arena.map") == "arena"``,
    ``map_name("worlds/office/map.yaml") == "office"``. Does not read the file.
    """

    if isinstance(source, str) and source in builtin.builtin_names():
        return source
    path = Path(os.fspath(source))
    if path.stem.lower() in GENERIC_STEMS:
        folder = path.resolve().parent.name
        return folder or path.stem
    return path.stem


def load_map(
    source: Source,
    *,
    start: XY | None = None,
    goal: XY | None = None,
    corner_rule: str | None = None,
    fmt: str | None = None,
    coarsen: int | None = None,
    threshold: float | None = None,
    unknown: str | None = None,
    start_world: tuple[float, float] | None = None,
    goal_world: tuple[float, float] | None = None,
    inflate: float | None = None,
    robot_radius: float | None = None,
) -> Grid:
    """Load a map file or a built-in map as a :class:`~jaxga.Grid`.

    Args:
        source: a path (``str`` or ``os.PathLike``) or the name of a built-in map (see
            :func:`jaxga.maps.builtin_names`). A ``str`` that is a built-in name is the
            built-in map even if a file of that name exists in the working directory
            (write ``./name`` for the file); a ``Path`` is always a file.
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
        unknown: ROS maps: ``"blocked"`` (default) or ``"free"`` for unknown cells.
            Refused for any other format: only a ROS map has unknown cells.
        start_world: ROS maps: the start in metres (world frame); the cell that holds
            it (:func:`jaxga.maps.ros.world_to_cell`). Not with ``start``; refused on a
            map without a resolution and an origin.
        goal_world: the goal in metres, as ``start_world``.
        inflate: grow the obstacles by this many cells (:func:`jaxga.maps.inflate`: every
            cell whose centre lies within that distance of a blocked cell's centre),
            on the map's own cells, before ``coarsen``.
        robot_radius: ROS maps: the robot's radius plus safety margin in metres; the
            obstacles grow by ``robot_radius / resolution`` cells. Not with ``inflate``;
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
            no effect on the map's format.
        EndpointError: an endpoint off the map, or start and goal merged or an endpoint
            blocked by ``coarsen``. (Blocked endpoints are otherwise *not* checked here;
            see :meth:`jaxga.Grid.check_endpoints`.)
    """
    return load_map_info(**locals()).grid  # every argument above, by name


def load_map_info(source: Source, **options: Any) -> MapInfo:
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
    is_builtin = isinstance(source, str) and source in builtin.builtin_names()
    if is_builtin:
        path = builtin.builtin_path(source)  # type: ignore[arg-type]
    else:
        if not isinstance(source, (str, os.PathLike)):
            raise MapFormatError(
                f"a map source must be a file path or a built-in map name, got {source!r}"
            )
        path = Path(os.fspath(source))
    label = str(source) if is_builtin else str(path)

    bare_name = isinstance(source, str) and not is_builtin and Path(source).name == source
    factor = 1 if o.coarsen is None else _coarsen_factor(o.coarsen)
    is_yaml = o.fmt == "ros" or (o.fmt is None and path.suffix.lower() in (".yaml", ".yml"))
    raw = _read_bytes(path, label, builtin_hint=bare_name and not Path(source).suffix,
                      yaml=is_yaml, coarsen=factor)
    kind = o.fmt or detect_format(path, raw)
    _check_options_apply(kind, label, threshold=o.threshold, unknown=o.unknown,
                         robot_radius=o.robot_radius, start_world=o.start_world,
                         goal_world=o.goal_world)
    size = _declared_size(raw, kind)
    if size is not None:  # refuse a map too large from its header (decision 021)
        w0, h0 = size
        message = too_large(-(-w0 // factor), -(-h0 // factor))
        if message:
            raise MapFormatError(f"{label}: {message}")
    ros = None
    unknown_cells = None
    if kind == "png":
        blocked = _parse_png(path, label, 0.5 if o.threshold is None else o.threshold, raw)
        file_start = file_goal = None
    elif kind == "ros":
        ros = read_ros_yaml(path, label, data=raw)
        occ = occupancy(read_ros_image(ros, label, coarsen=factor), ros)
        blocked = ros_blocked(occ, "blocked" if o.unknown is None else o.unknown)
        unknown_cells = np.ascontiguousarray((occ == -1)[::-1])
        file_start = file_goal = None
    else:
        text = _decode(raw, label)
        if kind == "movingai":
            blocked = parse_movingai(text, label)
            file_start = file_goal = None
        elif kind == "ascii":
            blocked, file_start, file_goal = parse_ascii(text, label)
        else:
            blocked = parse_01(text, label)
            file_start = file_goal = None

    s = o.start if o.start is not None else file_start
    g = o.goal if o.goal is not None else file_goal
    for name, xy, world in (("start", o.start, o.start_world), ("goal", o.goal, o.goal_world)):
        if world is None or ros is None:  # without a frame: refused above
            continue
        if xy is not None:
            raise EndpointError(f"{label}: give the {name} in cells or in metres, not both")
        try:
            cell = world_to_cell(ros, world, blocked.shape, f"the {name}")
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
        unknown_blocked=o.unknown != "free")
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
    name = map_name(source)
    return MapInfo(name=name, path=path, format=kind, builtin=is_builtin, grid=grid, ros=ros,
                   frame=frame, layers=layers)


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
        if isinstance(metres, bool) or not isinstance(metres, (int, float)) or not (
                math.isfinite(metres) and metres >= 0):
            raise MapFormatError(f"{label}: the robot radius must be >= 0 metres, got "
                                 f"{metres!r}")
        cells = metres / ros.resolution
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


def detect_format(path: Source, raw: bytes | None = None) -> str:
    """Guess a map file's format from its content and extension.

    PNG signature or an image extension (:data:`IMAGE_SUFFIXES`: ``.png``, ``.pgm``,
    ...) -> ``"png"``; ``.yaml``/``.yml`` -> ``"ros"``;
    ``.map`` extension or a first
    non-blank line starting with ``type`` -> ``"movingai"``; a first non-blank line
    starting with ``0`` or ``1`` -> ``"01"``; anything else -> ``"ascii"``
    (whose parser then reports any unknown character). ``raw`` is the file content if
    already read.
    """
    p = Path(os.fspath(path))
    if raw is None:
        raw = _read_bytes(p, str(p), coarsen=MAX_READ_COARSEN)
    suffix = p.suffix.lower()
    if raw.startswith(_PNG_MAGIC) or suffix in IMAGE_SUFFIXES:
        return "png"
    if suffix in (".yaml", ".yml"):
        return "ros"
    if suffix == ".map":
        return "movingai"
    first = ""
    for line in raw.decode("utf-8-sig", errors="replace").splitlines():  # BOM too
        if line.strip():
            first = line.strip()
            break
    if first.split(maxsplit=1)[:1] == ["type"]:
        return "movingai"
    if first[:1] in _ZERO_ONE:  # the 0/1 parser reports any other character
        return "01"
    return "ascii"


# -------------------------------------------------------------------------- parsers
def parse_01(text: str, label: str = "<text>") -> np.ndarray:
    """Parse 0/1 text (file line 1 = row y = 0, the bottom); return ``bool[H, W]``.

    Cells are ``0`` (free) or ``1`` (obstacle), separated by spaces, tabs or commas, or
    written without separators (``0101``). Leading and trailing blank lines are ignored.
    ``label`` names the file in error messages.
    """
    rows: list[list[bool]] = []
    for lineno, line in _body_lines(text, label):
        if any(c in _SEPARATORS for c in line):
            tokens = line.replace(",", " ").split()
            for col, tok in enumerate(tokens, 1):
                if tok not in ("0", "1"):
                    raise MapFormatError(
                        f"{label}: line {lineno}, cell {col}: expected 0 or 1, got {tok!r}"
                    )
        else:
            tokens = list(line)
            for col, tok in enumerate(tokens, 1):
                if tok not in _ZERO_ONE:
                    raise MapFormatError(
                        f"{label}: line {lineno}, column {col}: expected 0 or 1, got {tok!r}"
                    )
        rows.append([t == "1" for t in tokens])
        _check_ragged(rows, lineno, label)
    return np.array(rows, dtype=bool)


def parse_movingai(text: str, label: str = "<text>") -> np.ndarray:
    """Parse a Moving AI ``.map`` (row 0 = top) and return ``bool[H, W]`` with row 0 = bottom.

    ``.``, ``G`` and ``S`` (swamp) are passable; ``@``, ``O``, ``T`` (trees) and ``W``
    (water) are blocked (https://movingai.com/benchmarks/formats.html). The header must be
    ``type octile``, ``height H``, ``width W`` (in any order) and then the line ``map``.
    """
    lines = text.splitlines()
    header: dict[str, int | str] = {}
    i = 0
    while True:
        while i < len(lines) and not lines[i].strip():
            i += 1
        if i == len(lines):
            missing = [k for k in ("type", "height", "width") if k not in header]
            what = f"header line(s) {', '.join(missing)} and " if missing else ""
            raise MapFormatError(f"{label}: missing {what}the 'map' line of a Moving AI map")
        words = lines[i].split()
        lineno = i + 1
        i += 1
        key = words[0].lower()
        if key == "map" and len(words) == 1:
            break
        if key not in ("type", "height", "width") or len(words) != 2:
            raise MapFormatError(
                f"{label}: line {lineno}: unexpected header line {lines[i - 1].strip()!r} "
                "(a Moving AI map starts with 'type octile', 'height H', 'width W', 'map')"
            )
        if key in header:
            raise MapFormatError(f"{label}: line {lineno}: duplicate header line {key!r}")
        if key == "type":
            if words[1] != "octile":
                raise MapFormatError(
                    f"{label}: line {lineno}: unsupported map type {words[1]!r} (expected 'octile')"
                )
            header[key] = words[1]
        else:
            try:
                value = int(words[1])
            except ValueError:
                value = 0
            if value < 1:
                raise MapFormatError(
                    f"{label}: line {lineno}: {key} must be a positive integer, got {words[1]!r}"
                )
            header[key] = value
    missing = [k for k in ("type", "height", "width") if k not in header]
    if missing:
        raise MapFormatError(
            f"{label}: Moving AI header is missing {', '.join(missing)} before the 'map' line"
        )
    h, w = int(header["height"]), int(header["width"])
    body = lines[i:]
    while body and not body[-1].strip():
        body.pop()
    if len(body) < h:
        raise MapFormatError(f"{label}: header says height {h} but the file has {len(body)} rows")
    if len(body) > h:
        raise MapFormatError(
            f"{label}: line {i + h + 1}: header says height {h} but the file has {len(body)} rows"
        )
    out = np.zeros((h, w), dtype=bool)
    allowed = MOVINGAI_PASSABLE | MOVINGAI_BLOCKED
    for r, line in enumerate(body):
        lineno = i + r + 1
        row = line.rstrip()
        if len(row) != w:
            raise MapFormatError(
                f"{label}: line {lineno}: row has {len(row)} cells but the header says width {w}"
            )
        for col, c in enumerate(row, 1):
            if c not in allowed:
                raise MapFormatError(
                    f"{label}: line {lineno}, column {col}: unknown map character {c!r} "
                    "(expected one of . G S @ O T W)"
                )
        out[h - 1 - r] = [c in MOVINGAI_BLOCKED for c in row]
    return out


def parse_ascii(text: str, label: str = "<text>") -> tuple[np.ndarray, XY | None, XY | None]:
    """Parse ASCII art; return ``(blocked[H, W], start, goal)`` in the bottom-up convention.

    The **first text line is the top row** of the map, as a human draws it. ``.`` is
    free, ``#`` and ``@`` are blocked, ``S`` and ``G`` mark the start and the goal (free
    cells; at most one of each; ``None`` when absent). Trailing whitespace on a line and
    leading/trailing blank lines are ignored; a space inside a row is an error.
    """
    rows: list[list[bool]] = []
    marks: dict[str, tuple[int, int, int]] = {}  # marker -> (lineno, column, row from top)
    for lineno, line in _body_lines(text, label):
        cells = []
        for col, c in enumerate(line, 1):
            if c in ("S", "G"):
                if c in marks:
                    raise MapFormatError(
                        f"{label}: line {lineno}, column {col}: a second {c!r} marker "
                        f"(the first is on line {marks[c][0]})"
                    )
                marks[c] = (lineno, col, len(rows))
            elif c not in ASCII_FREE and c not in ASCII_BLOCKED:
                raise MapFormatError(
                    f"{label}: line {lineno}, column {col}: unknown map character {c!r} "
                    "(expected . # @ S G)"
                )
            cells.append(c in ASCII_BLOCKED)
        rows.append(cells)
        _check_ragged(rows, lineno, label)
    h = len(rows)
    blocked = np.array(rows[::-1], dtype=bool)
    found = {k: (col - 1, h - 1 - r) for k, (_, col, r) in marks.items()}
    return blocked, found.get("S"), found.get("G")


# -------------------------------------------------------------------------- writers
def save_map(grid: Grid | np.ndarray, path: Source, *, fmt: str | None = None,
             resolution: float = 1.0,
             origin: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Path:
    """Write a grid (or a ``bool[H, W]`` array, row 0 = bottom) as a map file.

    ``fmt`` is one of :data:`FORMATS`; by default it follows the extension (``.map`` ->
    Moving AI, ``.png`` -> PNG, ``.ascii``/``.asc`` -> ASCII art, anything else -> 0/1
    text). Each format is written in the orientation its loader expects, so
    ``load_map(save_map(g, p))`` gives back the same ``blocked`` array. ASCII art marks
    the grid's start ``S`` and goal ``G`` when they are free and distinct, so those
    round-trip too; the other formats do not store endpoints. ``.yaml``/``.yml`` writes a
    ROS map as ``map_saver`` does: the YAML (``resolution``, ``origin``, trinary
    thresholds) and a binary PGM beside it (free 254, occupied 0). Returns the path.
    """
    p = Path(os.fspath(path))
    if fmt is None:
        fmt = {".map": "movingai", ".png": "png", ".ascii": "ascii", ".asc": "ascii",
               ".yaml": "ros", ".yml": "ros"}.get(p.suffix.lower(), "01")
    if fmt not in FORMATS:
        raise MapFormatError(f"unknown map format {fmt!r}: expected one of {', '.join(FORMATS)}")
    if isinstance(grid, Grid):
        blocked = grid.blocked_np()
        endpoints = (grid.start_xy, grid.goal_xy)
    else:
        blocked = np.asarray(grid, dtype=bool)
        endpoints = None
    if blocked.ndim != 2 or blocked.size == 0:
        raise MapFormatError(f"cannot save a map of shape {blocked.shape}: need a 2-D array")
    h, w = blocked.shape
    if fmt == "png":
        matplotlib_ready()
        import matplotlib.image as mpimg

        mpimg.imsave(p, (~blocked).astype(float), cmap="gray", vmin=0.0, vmax=1.0, origin="lower")
        return p
    if fmt == "ros":
        image = p.with_suffix(".pgm")
        pixels = np.where(blocked[::-1], 0, 254).astype(np.uint8)
        image.write_bytes(f"P5\n# CREATOR: jaxga {resolution:.3f} m/pix\n{w} {h}\n255\n"
                          .encode("ascii") + pixels.tobytes())
        x0, y0, yaw = (float(v) for v in origin)
        p.write_text(f"image: {image.name}\nmode: trinary\nresolution: {resolution:.6f}\n"
                     f"origin: [{x0:.6f}, {y0:.6f}, {yaw:.6f}]\nnegate: 0\n"
                     "occupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")
        return p
    if fmt == "01":
        lines = [" ".join("1" if b else "0" for b in row) for row in blocked]
    elif fmt == "movingai":
        rows = ["".join("@" if b else "." for b in row) for row in blocked[::-1]]
        lines = ["type octile", f"height {h}", f"width {w}", "map", *rows]
    else:
        chars = np.where(blocked, "#", ".").astype("<U1")
        if endpoints is not None and endpoints[0] != endpoints[1]:
            for mark, (x, y) in zip("SG", endpoints, strict=True):
                if not blocked[y, x]:
                    chars[y, x] = mark
        lines = ["".join(row) for row in chars[::-1]]
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


# -------------------------------------------------------------------------- helpers
def _read_bytes(path: Path, label: str, builtin_hint: bool = False, *, yaml: bool = False,
                coarsen: int = 1) -> bytes:
    """A map file's bytes (:func:`jaxga.maps.inputs.read_input`: a regular file of at most
    :data:`~jaxga.maps.inputs.YAML_CAP` bytes for a ROS map's YAML, else
    :func:`~jaxga.maps.inputs.map_file_cap` for a map coarsened ``coarsen x coarsen``);
    every failure one line naming the file."""
    if yaml:
        cap, note = YAML_CAP, "a map_server YAML holds a few lines of metadata"
    else:
        cap, note = map_file_cap(coarsen), map_file_cap_note(coarsen)
    try:
        raw = read_input(path, cap, what="map file", label=label, note=note)
    except FileNotFoundError:
        hint = ""
        if builtin_hint:

            hint = f" and it is not a built-in map ({', '.join(builtin.builtin_names())})"
        raise MapFormatError(f"{label}: map file not found{hint}") from None
    except IsADirectoryError:
        raise MapFormatError(f"{label}: is a directory, not a map file") from None
    except OSError as e:
        raise MapFormatError(f"{label}: cannot read map file ({e.strerror or e})") from None
    if not raw.strip():
        raise MapFormatError(f"{label}: map file is empty")
    return raw


def _decode(raw: bytes, label: str) -> str:
    if raw.startswith(_PNG_MAGIC):
        raise MapFormatError(f"{label}: is a PNG image, not a text map")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MapFormatError(
            f"{label}: not a text map file (byte {e.start} is not valid UTF-8)"
        ) from None
    if "\x00" in text:
        raise MapFormatError(f"{label}: not a text map file (contains NUL bytes)")
    first = next((ln.strip() for ln in text.splitlines() if ln.strip()), "")
    if first.split(maxsplit=1)[:1] == ["version"]:
        raise MapFormatError(
            f"{label}: is a Moving AI scenario file, not a map (read it with read_scen)"
        )
    return text


def _body_lines(text: str, label: str) -> list[tuple[int, str]]:
    """Non-blank lines (1-based line number, right-stripped), no blank line in between."""
    lines = [ln.rstrip() for ln in text.splitlines()]
    numbered = [(n, ln) for n, ln in enumerate(lines, 1) if ln]
    if not numbered:
        raise MapFormatError(f"{label}: map file is empty")
    first, last = numbered[0][0], numbered[-1][0]
    if len(numbered) != last - first + 1:
        gap = next(n for n in range(first, last + 1) if not lines[n - 1])
        raise MapFormatError(f"{label}: line {gap}: blank line inside the map")
    return numbered


def _coarsen_factor(value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise MapFormatError(f"coarsen must be a positive integer, got {value!r}")
    return int(value)


_FORMAT_NAMES = {"01": "a 0/1 text map", "movingai": "a Moving AI map",
                 "ascii": "an ASCII-art map", "png": "an image", "ros": "a ROS map_server map"}


def _check_options_apply(kind: str, label: str, *, threshold: float | None,
                         unknown: str | None, robot_radius: float | None,
                         start_world: tuple[float, float] | None,
                         goal_world: tuple[float, float] | None) -> None:
    """Refuse, in one line saying why, an option given for a map format on which it has
    no effect: it would be ignored, and the map planned on other than the caller asked."""
    what = _FORMAT_NAMES.get(kind, f"a {kind} map")
    if threshold is not None and kind != "png":
        why = ("its YAML's occupied_thresh and free_thresh decide which pixels are "
               "blocked" if kind == "ros" else "only an image's pixels are thresholded")
        raise MapFormatError(f"{label}: the image threshold (--threshold, threshold=) has no "
                             f"effect on {what}: {why}")
    if unknown is not None and kind != "ros":
        why = ("an image's grey pixels are thresholded like the others (load the map's "
               "map_server .yaml to keep them apart)" if kind == "png"
               else "this map has none")
        raise MapFormatError(f"{label}: the setting for unknown cells (--unknown, unknown=) "
                             f"has no effect on {what}: only a ROS map_server map (.yaml) "
                             f"has unknown cells; {why}")
    if kind == "ros":
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


def _declared_size(raw: bytes, kind: str) -> tuple[int, int] | None:
    """``(width, height)`` of a map file from its header (an image's, Moving AI) or its
    first line and line count (0/1 text, ASCII art), without parsing it; None if it cannot
    be told (the parser then reports what is wrong)."""
    if kind == "png":
        return image_size(raw)
    if kind == "ros":  # the image's size is checked once it is read
        return None
    head = raw[:4096].decode("utf-8", errors="replace")
    if kind == "movingai":
        dims = {}
        for line in head.splitlines()[:8]:
            words = line.split()
            if len(words) == 2 and words[0].lower() in ("height", "width") \
                    and words[1].isdigit():
                dims[words[0].lower()] = int(words[1])
        return (dims["width"], dims["height"]) if len(dims) == 2 else None
    lines = [line for line in raw.splitlines() if line.strip()]
    if not lines:
        return None
    first = lines[0].decode("utf-8-sig", errors="replace").strip()
    width = len(first.replace(",", " ").split()) if any(c in _SEPARATORS for c in first) \
        else len(first)
    return width, len(lines)


def _check_ragged(rows: list[list[bool]], lineno: int, label: str) -> None:
    if len(rows) > 1 and len(rows[-1]) != len(rows[0]):
        raise MapFormatError(
            f"{label}: line {lineno}: row has {len(rows[-1])} cells but the first row "
            f"has {len(rows[0])} (ragged rows)"
        )


def _parse_png(path: Path, label: str, threshold: float = 0.5,
               raw: bytes | None = None) -> np.ndarray:
    """Threshold an image's luminance (blocked below ``threshold``); image top row -> top
    of the map (row H-1). ``raw``: the file's bytes, already read (else read here); an
    image whose pixel data does not match its header is refused first."""
    matplotlib_ready()
    import matplotlib.image as mpimg

    if isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or not (
            0.0 < threshold <= 1.0):
        raise MapFormatError(f"{label}: the image threshold must be a luminance in (0, 1], "
                             f"got {threshold!r}")
    if raw is None:
        raw = _read_bytes(path, label, coarsen=MAX_READ_COARSEN)
    check_image_data(raw, label)
    # matplotlib reads a .png (or a PNG by content) as PNG, anything else through Pillow
    as_png = path.suffix.lower() == ".png" or raw.startswith(_PNG_MAGIC)
    try:
        img = np.asarray(mpimg.imread(io.BytesIO(raw), format="png" if as_png else "pil"))
    except Exception as e:  # Pillow/matplotlib raise many types for bad images
        msg = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise MapFormatError(f"{label}: unreadable image ({msg})") from None
    if (
        img.ndim not in (2, 3)
        or img.size == 0
        or (img.ndim == 3 and img.shape[2] not in (1, 2, 3, 4))
    ):
        raise MapFormatError(f"{label}: unsupported image shape {img.shape}")
    if np.issubdtype(img.dtype, np.integer):
        img = img.astype(np.float64) / np.iinfo(img.dtype).max
    img = img.astype(np.float64)
    if img.ndim == 2:
        lum = img
    else:
        c = img.shape[2]
        alpha = img[..., c - 1] if c in (2, 4) else None
        color = img[..., : (1 if c in (1, 2) else 3)]
        if color.shape[2] == 3:
            lum = color @ np.array([0.299, 0.587, 0.114])  # ITU-R BT.601 luma
        else:
            lum = color[..., 0]
        if alpha is not None:  # composite over white: transparent = free
            lum = lum * alpha + (1.0 - alpha)
    return np.ascontiguousarray((lum < threshold)[::-1])
