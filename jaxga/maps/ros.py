"""ROS ``map_server`` maps: a YAML file and its image (PGM, PNG, ...) as a blocked grid.

A map saved by ROS ``map_saver`` (ROS 1 ``map_server``, ROS 2 ``nav2_map_server``) is two
files: ``office.yaml``::

    image: office.pgm
    mode: trinary            # ROS 2 only; ROS 1 maps are trinary
    resolution: 0.050000     # metres per cell
    origin: [-10.0, -12.5, 0.0]   # x, y (metres) and yaw (radians) of the lower-left cell
    negate: 0
    occupied_thresh: 0.65
    free_thresh: 0.196

and the image, whose top row is the top of the map (it is flipped to the library's
``y = 0`` bottom row, docs/maps.md). Each pixel becomes an occupancy as ``map_server`` computes
it: the pixel's shade ``s`` is the mean of its colour channels over 255 (a grey pixel
counting as three equal ones; in ``trinary`` mode its alpha is averaged in as a fourth,
as both ``map_server`` versions do, elsewhere left out; a 16-bit image is read at its
full precision, as ``nav2_map_server`` reads it), ``p = 1 - s`` (``s`` when ``negate``) is
its occupancy probability, and

* ``trinary``: ``p > occupied_thresh`` occupied, ``p < free_thresh`` free, anything
  between unknown (``map_saver``'s grey 205 has ``p = 0.196``: unknown);
* ``scale``: as trinary, except that the band between the thresholds is graded
  occupancy, ``rint(100 (p - free_thresh) / (occupied_thresh - free_thresh))``
  (``nav2_map_server``: the band's ends round to 0, free, and 100, occupied; ROS 1's
  ``map_server`` gave ``1 + 98`` times the ratio), and a transparent pixel (alpha < 255)
  is unknown;
* ``raw``: the pixel value is the occupancy itself (0-100), anything above 100 unknown;
  ``negate`` does not apply (``nav2_map_server``; ROS 1's ``map_server`` negated the
  value first, decision 054).

Planning: occupied cells are blocked; unknown cells are blocked too unless
``unknown="free"``; scale mode's graded cells count as unknown (jaxga plans on free and
blocked cells only, and a cell that is possibly occupied is not driven through by
default), unless ``occupied_from`` names the occupancy from which a cell is blocked
(:func:`ros_blocked`). Cell ``(x, y)`` covers the square of side ``resolution`` whose lower-left
corner is at ``origin + R(yaw) (x resolution, y resolution)``; :func:`world_to_cell` and
:func:`cell_to_world` convert (cell centres).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from jaxga.core.errors import MapFormatError
from jaxga.core.fields import shown_value
from jaxga.core.grid import too_large
from jaxga.core.numerals import yaml_number
from jaxga.maps.frame import MapFrame
from jaxga.maps.inputs import (
    YAML_CAP,
    check_image_data,
    decode_image,
    image_size,
    map_file_cap,
    map_file_cap_note,
    read_input,
)

__all__ = [
    "MODES",
    "UNKNOWN_AS",
    "check_occupied_from",
    "RosMap",
    "UniqueKeyLoader",
    "cell_to_world",
    "occupancy",
    "read_ros_image",
    "read_ros_yaml",
    "ros_blocked",
    "world_to_cell",
]

MODES = ("trinary", "scale", "raw")
"""``map_server``'s interpretations of the image (the YAML's ``mode``)."""

UNKNOWN_AS = ("blocked", "free")
"""How unknown cells are planned on: blocked (default) or free."""


@dataclasses.dataclass(frozen=True)
class RosMap:
    """The metadata of a ``map_server`` YAML file.

    Attributes:
        image: the image file (absolute, or relative to the YAML's folder as written);
            None for an occupancy grid in memory (:mod:`jaxga.maps.occupancy_grid`).
        resolution: metres per cell (> 0).
        origin: ``(x, y, yaw)``: the lower-left cell's lower-left corner in metres and the
            map's rotation in radians.
        negate: swap the meaning of black and white (trinary and scale modes; raw mode
            reads the pixel value as it is, as ``nav2_map_server`` does).
        occupied_thresh: occupancy probability above which a cell is occupied.
        free_thresh: occupancy probability below which a cell is free.
        mode: one of :data:`MODES`.
    """

    image: Path | None
    resolution: float
    origin: tuple[float, float, float]
    negate: bool = False
    occupied_thresh: float = 0.65
    free_thresh: float = 0.196
    mode: str = "trinary"


MAX_RESOLUTION = 1e6
"""The most metres a map cell may span, and :data:`MAX_ORIGIN` the farthest an origin may
lie (metres): far beyond any robot's map, and small enough that every coordinate of a
map of :data:`jaxga.core.grid.MAX_MAP_CELLS` cells, and every length on it, is a finite
number (a resolution of 1e308 made path lengths and written points inf and NaN)."""
MAX_ORIGIN = 1e12
MIN_RESOLUTION = 1e-9
"""The fewest metres a map cell may span (a nanometre): points on a finer map could not
be written apart in metres (a resolution of 1e-300 wrote every point as 0)."""
MAX_ORIGIN_CELLS = 1e11
"""The farthest an origin may lie from 0 in the map's own cells (``|x|`` and ``|y|`` over
the resolution): float64 metres then name every cell centre to within 1e-4 of a cell.
Each bound alone let a nanometre map lie 500 km out, where written cell centres read
back in other cells."""


def origin_in_cells_problem(resolution: float, origin: tuple[float, ...]) -> str | None:
    """Why float64 metres cannot name the cells of a map of ``resolution`` whose origin is
    ``origin`` (one phrase), or None when they can (:data:`MAX_ORIGIN_CELLS`)."""
    far = max(abs(origin[0]), abs(origin[1]))
    if far <= MAX_ORIGIN_CELLS * resolution:
        return None
    return (f"an origin {far:.6g} m from 0 is {far / resolution:.3g} cells of "
            f"{resolution:g} m away, beyond the {MAX_ORIGIN_CELLS:.0e} cells at which "
            "metres in float64 still name every cell: move the origin nearer 0 or use "
            "coarser cells")


def _number(value: Any, key: str, label: str) -> float:
    """A finite number as yaml-cpp reads one (:func:`jaxga.core.numerals.yaml_number`):
    ``5e-2``, a string to YAML 1.1, is a number; ``"1_0"`` is not."""
    try:
        number = yaml_number(value)
    except OverflowError:  # an integer of hundreds of digits
        raise MapFormatError(f"{label}: {key} must be a finite number, got an integer "
                             f"of {value.bit_length()} bits") from None
    except TypeError:
        number = math.nan
    if not math.isfinite(number):
        raise MapFormatError(f"{label}: {key} must be a finite number, got {shown_value(value)}")
    return number


class UniqueKeyLoader(yaml.SafeLoader):
    """``yaml.safe_load``'s loader refusing a mapping that names a key twice: YAML
    forbids it, PyYAML keeps the last value silently, and a map server may keep the
    first (``resolution: 0.05`` then ``resolution: 5.0``: which map is it?)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: set = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":  # "<<: *base": a merge, which
                continue  # the node's own keys override (flatten_mapping, below)
            key = self.construct_object(key_node, deep=deep)
            try:
                twice = key in seen
                seen.add(key)
            except TypeError:  # an unhashable key: SafeLoader's own error follows
                continue
            if twice:
                raise yaml.constructor.ConstructorError(
                    None, None, f"the key {shown_value(key)} is given twice",
                    key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


def _yaml_problem(e: Any) -> str:
    """PyYAML's problem and where it is (``line 1, column 7: found character '\\t' that
    cannot start any token``), not its context alone ("while scanning for the next
    token"), which named no line."""
    mark = e.problem_mark or e.context_mark
    where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
    what = e.problem or e.context or type(e).__name__
    return where + " ".join(str(what).split())


def read_ros_yaml(path: str | Path, label: str | None = None, *,
                  data: bytes | None = None) -> RosMap:
    """Read a ``map_server`` YAML file (``image``, ``resolution``, ``origin``, ``negate``,
    ``occupied_thresh``, ``free_thresh``, ``mode``; unknown keys are ignored, as
    ``map_server`` does). Raises :class:`~jaxga.core.errors.MapFormatError` with one line
    naming the file and the key for a missing or invalid value, or for a file that is not
    a regular file of at most :data:`jaxga.maps.inputs.YAML_CAP` bytes. ``data``: the
    file's bytes when already read (``path`` still places a relative image)."""
    path = Path(path)
    label = label or str(path)
    try:
        if data is None:
            data = read_input(path, YAML_CAP, what="map_server YAML file", label=label,
                              note="a map_server YAML holds a few lines of metadata")
        elif len(data) > YAML_CAP:
            raise MapFormatError(f"{label}: the file holds {len(data):,} bytes, more than "
                                 f"the {YAML_CAP:,} bytes jaxga reads from a map_server "
                                 "YAML file")
        data = yaml.load(data.decode("utf-8"), Loader=UniqueKeyLoader)  # noqa: S506
    except FileNotFoundError:
        raise MapFormatError(f"{label}: no such file") from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError, ValueError, RecursionError) as e:
        # ValueError: an integer past Python's digit limit for str -> int (4300 digits);
        # RecursionError: lists or mappings nested thousands deep
        first = ("nested too deeply" if isinstance(e, RecursionError)
                 else _yaml_problem(e) if isinstance(e, yaml.MarkedYAMLError)
                 else str(e).splitlines()[0] if str(e) else type(e).__name__)
        raise MapFormatError(f"{label}: not a readable YAML file ({first})") from None
    if not isinstance(data, dict):
        raise MapFormatError(f"{label}: not a map_server YAML file (no 'key: value' pairs)")
    for key in ("image", "resolution", "origin"):
        if key not in data:
            raise MapFormatError(f"{label}: the map_server key {key!r} is missing")
    if not isinstance(data["image"], str) or not data["image"] or "\0" in data["image"]:
        raise MapFormatError(f"{label}: image must be a file name, got "
                             f"{shown_value(data['image'])}")
    resolution = _number(data["resolution"], "resolution", label)
    if not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise MapFormatError(f"{label}: resolution must be from {MIN_RESOLUTION:g} to "
                             f"{MAX_RESOLUTION:g} metres per cell, got {resolution}")
    origin = data["origin"]
    if not isinstance(origin, (list, tuple)) or len(origin) != 3:
        raise MapFormatError(f"{label}: origin must be [x, y, yaw], got {shown_value(origin)}")
    origin = tuple(_number(v, "origin", label) for v in origin)
    if max(abs(origin[0]), abs(origin[1])) > MAX_ORIGIN:
        raise MapFormatError(f"{label}: origin must lie within {MAX_ORIGIN:g} metres of 0, "
                             f"got {shown_value(list(origin[:2]))}")
    if (far := origin_in_cells_problem(resolution, origin)) is not None:
        raise MapFormatError(f"{label}: {far}")
    negate = data.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise MapFormatError(f"{label}: negate must be 0 or 1, got {shown_value(negate)}")
    occ = _number(data.get("occupied_thresh", 0.65), "occupied_thresh", label)
    free = _number(data.get("free_thresh", 0.196), "free_thresh", label)
    if not 0.0 <= free < occ <= 1.0:
        raise MapFormatError(f"{label}: thresholds must satisfy 0 <= free_thresh < "
                             f"occupied_thresh <= 1, got free_thresh {free}, "
                             f"occupied_thresh {occ}")
    mode = data.get("mode", "trinary")
    if mode not in MODES:
        raise MapFormatError(f"{label}: mode must be one of {', '.join(MODES)}, got "
                             f"{shown_value(mode)}")
    image = Path(data["image"])
    if not image.is_absolute():
        image = path.parent / image
    return RosMap(image=image, resolution=resolution, origin=origin, negate=bool(negate),
                  occupied_thresh=occ, free_thresh=free, mode=mode)


def read_ros_image(meta: RosMap, label: str | None = None, *, coarsen: int = 1) -> np.ndarray:
    """The image of a ``map_server`` map as ``[H, W, C]`` values from 0 to 255 (C = 1-4),
    top row first, read with Pillow (PGM, PNG, BMP, ...): ``uint8`` for an 8-bit image,
    ``float64`` for a 16-bit one (its values over its own white, times 255: no precision
    lost to a rounding before the thresholds).

    Refused in one line naming the image: a file that is not a regular file or holds more
    than :func:`jaxga.maps.inputs.map_file_cap` bytes for a map to be coarsened
    ``coarsen x coarsen``; an image over :data:`jaxga.core.grid.MAX_MAP_CELLS` cells once
    coarsened, from its header before its pixels are decoded; a PNG or PGM whose pixel
    data does not match its header (:func:`jaxga.maps.inputs.check_image_data`); an image
    that cannot be decoded or has no 8- or 16-bit scale
    (:func:`jaxga.maps.inputs.decode_image`)."""
    label = label or str(meta.image)
    where = f"{label}: the map image {str(meta.image)!r}"
    factor = max(int(coarsen), 1)
    try:
        raw = read_input(meta.image, map_file_cap(factor), what="map image", label=where,
                         note=map_file_cap_note(factor))
    except FileNotFoundError:
        raise MapFormatError(f"{label}: the map image {str(meta.image)!r} does not exist") \
            from None
    except OSError as e:
        raise MapFormatError(f"{where}: cannot be read ({e.strerror or e})") from None
    if not raw:
        raise MapFormatError(f"{label}: the map image {str(meta.image)!r} is empty")
    size = image_size(raw)
    if size is not None:  # refuse a map too large before decoding it
        message = too_large(-(-size[0] // factor), -(-size[1] // factor))
        if message:
            raise MapFormatError(f"{where}: {message}")
    check_image_data(raw, where)
    pixels, scale = decode_image(raw, f"{label}: map image {str(meta.image)!r}")
    if scale == 255:
        return pixels.astype(np.uint8)
    return pixels / scale * 255.0


def occupancy(pixels: np.ndarray, meta: RosMap) -> np.ndarray:
    """``int8[H, W]`` occupancy as ``map_server`` publishes it: 0 free, 100 occupied, -1
    unknown, 1-99 graded (scale mode, whose band rounds to 0-100 as nav2's does); rows as
    in the image (top first).

    ``pixels``: ``[H, W, C]`` values from 0 to 255 (:func:`read_ros_image`); with C = 2
    or 4 the last channel is alpha. In ``trinary`` mode the alpha is averaged in with the
    colour channels (ROS 2's ``map_io.cpp``: "To preserve existing behavior, average in
    alpha with color channels in Trinary mode"; a grey pixel is three equal channels
    there, where ROS 1 averages a grey and alpha image's two channels), so a transparent
    white pixel is unknown, not free. The arithmetic is nav2's to the last bit
    (GraphicsMagick's 16-bit quanta, their mean over 65535, ``p = 1 - s``), so a shade
    exactly at a threshold falls where nav2 puts it (grey 204 under ``free_thresh: 0.2``
    is free: ``1 - 0.8`` is below 0.2); ROS 1's ``map_server``, which computes
    ``(255 - mean) / 255``, can put such a pixel on the other side.
    """
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    c = pixels.shape[2]
    has_alpha = c in (2, 4)
    # nav2's arithmetic to the last bit, so that a shade exactly at a threshold falls on
    # the side nav2 puts it: GraphicsMagick's 16-bit quanta (an 8-bit value v is 257 v,
    # a 16-bit one itself; grey counts as three equal channels), their sum over the
    # channels, the mean over 65535, and p = 1 - shade
    quanta = np.rint(pixels.astype(np.float64) * 257.0)
    colour = quanta[..., : c - 1] if has_alpha else quanta
    total = colour.sum(axis=2) * (3.0 / colour.shape[2])  # exact: 3 x a grey channel
    channels = 3.0
    if has_alpha and meta.mode == "trinary":  # three colour channels and the alpha
        total, channels = total + quanta[..., -1], 4.0
    shade = total / channels / 65535.0  # 0-1
    if meta.mode == "raw":  # the pixel value itself, negate or not (nav2's map_io.cpp)
        value = np.floor(shade * 255.0 + 0.5)  # std::round: halves away from zero
        return np.where(value > 100, -1, value).astype(np.int8)
    p = shade if meta.negate else 1.0 - shade
    out = np.full(p.shape, -1, np.int8)
    out[p > meta.occupied_thresh] = 100
    out[p < meta.free_thresh] = 0
    if meta.mode == "scale":
        band = (out == -1)
        ratio = (p - meta.free_thresh) / (meta.occupied_thresh - meta.free_thresh)
        out[band] = np.rint(100.0 * ratio[band]).astype(np.int8)  # nav2's std::rint
        if has_alpha:
            out[pixels[..., -1] < 255] = -1
    return out


def ros_blocked(occ: np.ndarray, unknown: str = "blocked",
                occupied_from: int | None = None) -> np.ndarray:
    """Blocked cells for planning, ``bool[H, W]`` with ``y = 0`` the bottom row (the
    image's rows flipped).

    Without ``occupied_from``: occupied (100), and unknown (-1) or graded (1-99) cells
    unless ``unknown="free"``. With it (an integer 1-100): the cells whose occupancy is
    at least ``occupied_from`` (a costmap's lethal 100 and inscribed 99 with
    ``occupied_from=99``, as ``costmap_2d``'s planners block a cost of at least
    ``INSCRIBED_INFLATED_OBSTACLE``), the graded cells below it free, and unknown (-1)
    cells blocked unless ``unknown="free"``."""
    if unknown not in UNKNOWN_AS:
        raise MapFormatError(f"unknown cells must be one of {', '.join(UNKNOWN_AS)}, "
                             f"got {unknown!r}")
    occ = np.asarray(occ)
    if occupied_from is None:
        blocked = occ == 100 if unknown == "free" else occ != 0
    else:
        blocked = occ >= check_occupied_from(occupied_from)
        if unknown != "free":
            blocked |= occ == -1
    return np.ascontiguousarray(blocked[::-1])


def check_occupied_from(value: Any) -> int:
    """``value`` as the occupancy (an integer 1-100) from which a cell is blocked;
    :class:`~jaxga.core.errors.MapFormatError` in one line otherwise."""
    if (isinstance(value, bool) or not isinstance(value, (int, np.integer))
            or not 1 <= value <= 100):
        raise MapFormatError(f"occupied_from (--occupied-from) must be an occupancy, an "
                             f"integer from 1 to 100, got {shown_value(value)}")
    return int(value)


def _frame(meta: RosMap, shape: tuple[int, int] = (0, 0)) -> MapFrame:
    return MapFrame(map_shape=shape, resolution=meta.resolution, origin=meta.origin)


def cell_to_world(meta: RosMap, cell: tuple[int, int]) -> tuple[float, float]:
    """The world coordinates (metres) of cell ``(x, y)``'s centre (``y = 0`` bottom)."""
    x, y = _frame(meta).to_world(np.asarray(cell, float))
    return float(x), float(y)


def world_to_cell(meta: RosMap, point: tuple[float, float], shape: tuple[int, int],
                  what: str = "point") -> tuple[int, int]:
    """The cell ``(x, y)`` (``y = 0`` bottom) that holds world point ``point`` (metres);
    :class:`~jaxga.core.errors.EndpointError` naming ``what`` when it lies off the
    ``shape = (H, W)`` map (:meth:`jaxga.maps.frame.MapFrame.cell_of`)."""
    return _frame(meta, shape).cell_of(point, shape, what)
