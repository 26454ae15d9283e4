"""Occupancy grids in memory: a ROS ``nav_msgs/OccupancyGrid`` message, or an array with a
resolution and an origin, as a map source.

A robot node is given its map as a message, not as a file: ``map_server`` publishes the
map it loaded on ``/map``, and a costmap is published the same way. The message holds
the map's cells as occupancies (``data``: ``int8``, row-major, **the first row the
bottom** of the map, ``-1`` unknown, ``0`` free, ``100`` occupied, ``1-99`` graded), and
its frame in ``info``: ``width``, ``height``, ``resolution`` (metres per cell) and
``origin``, the pose of cell (0, 0)'s lower-left corner (a position and a quaternion).

:class:`OccupancyGrid` holds such a grid, checked; :func:`jaxga.maps.load_map_info` (and
:func:`~jaxga.maps.load_map`, :func:`jaxga.run`, :class:`jaxga.Planner`) takes one, or the
message itself (ROS 1 or ROS 2, or the dictionary ``rosbridge`` and
``rosidl_runtime_py.message_to_ordereddict`` make of it), with the options of a
``map_server`` file: the robot's radius, endpoints in metres, coarsening, unknown cells.
The cells are planned on as a ``map_server`` map's occupancies are
(:func:`jaxga.maps.ros.ros_blocked`): 100 blocked, 0 free, unknown and graded cells
blocked unless ``unknown="free"`` (graded cells, a costmap's inflation among them, are
possibly occupied), so that a map published by ``map_server`` plans as its file does;
``occupied_from=99`` plans on a costmap as ``costmap_2d``'s planners do (its lethal and
inscribed cells blocked, the inflation's cost below free).
"""

from __future__ import annotations

import math
import os
from array import array as array_type
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxga.core.errors import MapFormatError
from jaxga.core.fields import python_scalar, shown_value
from jaxga.maps.ros import MAX_ORIGIN, MAX_RESOLUTION, MIN_RESOLUTION, origin_in_cells_problem

__all__ = ["OccupancyGrid", "is_occupancy_message"]

QUATERNION_TOLERANCE = 1e-3
"""How far from 1 the norm of the origin's quaternion may be, and how far out of the
plane (its ``x`` and ``y``) it may turn, before the origin is refused: float32 and printed
quaternions are a few 1e-7 off, a tilted map or a mistyped one much more."""


class OccupancyGrid:
    """A map's occupancies in memory with their frame, as a ``nav_msgs/OccupancyGrid``
    carries them.

    Args:
        data: the occupancies, integers from -1 to 100 (-1 unknown, 0 free, 100
            occupied, 1-99 graded): a ``[height, width]`` array whose row 0 is the
            bottom of the map (the message's first row; the library's convention), or a
            flat sequence of ``width * height`` values, row-major from the bottom row,
            with ``width`` and ``height`` given (a message's ``data``; ``bytes`` are read
            as the message's ``int8``). The values are copied: the caller's array stays
            writable, and a later change to it does not reach the grid.
        resolution: metres per cell. A float32 value (every message's) is read as the
            shortest decimal that gives it: a published ``0.05`` is
            0.0500000007450580597 m, and plans in the frame of the map's file, 0.05 (a
            resolution with more digits than float32 holds, 0.0123456789, has lost them
            in the message already: 0.012345679).
        origin: a tuple, list or 1-D array ``(x, y)`` or ``(x, y, yaw)``: the lower-left
            corner of cell (0, 0) in metres and the map's rotation in radians, as a
            ``map_server`` YAML's origin (a message's quaternion gives a yaw in
            ``(-pi, pi]``: a YAML's 3.5 is published as -2.78, the same rotation).
        width: cells per row, with a flat ``data``.
        height: rows, with a flat ``data``.
        name: the map's name in outputs and errors (one printable line; a message's is
            given to :meth:`from_message`, then the grid to the loaders).

    Raises:
        MapFormatError: in one line naming the grid and the value: a shape that does not
            match ``width`` and ``height``, an empty grid, a value that is not an integer
            from -1 to 100 (naming its cell), a resolution or an origin a ``map_server``
            YAML could not have (:func:`jaxga.maps.ros.read_ros_yaml`).

    Attributes:
        occupancy: ``int8[height, width]``, row 0 the bottom, read-only.
        resolution: metres per cell.
        origin: ``(x, y, yaw)``.
        name: as given.
    """

    def __init__(self, data: Any, resolution: float, origin: Any = (0.0, 0.0, 0.0), *,
                 width: int | None = None, height: int | None = None,
                 name: str = "occupancy_grid") -> None:
        self._fill(data, resolution, origin, width, height, name, "occupancy grid")

    def _fill(self, data: Any, resolution: Any, origin: Any, width: Any, height: Any,
              name: Any, kind: str) -> None:
        """Check and keep the grid; errors name it as ``kind 'name'``."""
        self.name = _checked_name(name, kind)
        label = f"{kind} {self.name!r}"
        self.occupancy = _occupancies(data, width, height, label)
        self.resolution = _resolution(resolution, label)
        self.origin = _origin(origin, self.resolution, label)

    @classmethod
    def from_message(cls, message: Any, name: str = "occupancy_grid") -> OccupancyGrid:
        """The grid of a ``nav_msgs/OccupancyGrid`` message (ROS 1 or ROS 2), or of the
        dictionary ``rosbridge`` or ``message_to_ordereddict`` makes of one. The origin's
        quaternion becomes its yaw; one turned out of the plane, or not of unit norm
        (within :data:`QUATERNION_TOLERANCE`), is refused. An all-zero quaternion, a
        message's default when its publisher set none, is taken as no rotation."""
        kind = "OccupancyGrid message"
        label = f"{kind} {_checked_name(name, kind)!r}"
        info = _field(message, "info", label)
        width = _field(info, "width", label, "info.")
        height = _field(info, "height", label, "info.")
        resolution = _field(info, "resolution", label, "info.")
        pose = _field(info, "origin", label, "info.")
        position = _field(pose, "position", label, "info.origin.")
        orientation = _field(pose, "orientation", label, "info.origin.")
        x, y = (_field(position, k, label, "info.origin.position.") for k in ("x", "y"))
        q = [_field(orientation, k, label, "info.origin.orientation.")
             for k in ("x", "y", "z", "w")]
        yaw = _yaw(q, label)
        data = _field(message, "data", label)
        grid = cls.__new__(cls)
        grid._fill(data, resolution, (x, y, yaw), width, height, name, kind)
        return grid

    @property
    def width(self) -> int:
        """Cells per row."""
        return int(self.occupancy.shape[1])

    @property
    def height(self) -> int:
        """Rows of cells."""
        return int(self.occupancy.shape[0])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, OccupancyGrid):
            return NotImplemented
        return (self.name, self.resolution, self.origin) == (
            other.name, other.resolution, other.origin) and np.array_equal(
            self.occupancy, other.occupancy)

    __hash__ = None  # type: ignore[assignment]  (equal by value, and not immutable)

    def __repr__(self) -> str:
        return (f"OccupancyGrid({self.name!r}, {self.width} x {self.height} cells of "
                f"{self.resolution:g} m, origin {self.origin})")


def is_occupancy_message(source: Any) -> bool:
    """Whether ``source`` looks like a ``nav_msgs/OccupancyGrid`` message: it has an
    ``info`` (as an attribute, or as a key of a mapping); a message without its ``data``
    is then refused naming that field, not as a source of another kind."""
    if isinstance(source, Mapping):
        return "info" in source and ("data" in source or _has(source["info"], "width"))
    if isinstance(source, (str, bytes, os.PathLike, tuple)) or not hasattr(source, "info"):
        return False  # a tuple: jaxga.problem's Problem has an info too
    # an image's info dict, a table's info method: no map's metadata
    return hasattr(source, "data") or _has(source.info, "width")


def _has(obj: Any, key: str) -> bool:
    return key in obj if isinstance(obj, Mapping) else hasattr(obj, key)


def _holds_bool(data: Any) -> bool:
    """Whether a list or tuple of occupancies, flat or of rows (``[height, width]``: what
    an array of them can be), holds a bool."""
    if not isinstance(data, (list, tuple)):
        return False
    rows = data if data and isinstance(data[0], (list, tuple)) else [data]
    kinds = {type(v) for row in rows if isinstance(row, (list, tuple)) for v in row}
    return bool(kinds & {bool, np.bool_})


def _checked_name(name: Any, kind: str) -> str:
    """A grid's name as outputs show it: one line, its undecodable bytes escaped (as
    :func:`jaxga.maps.map_name` shows a file's)."""
    shown = name.encode("utf-8", "backslashreplace").decode("utf-8") \
        if isinstance(name, str) else ""
    if not shown or not shown.isprintable():  # a line break would split a summary's line
        raise MapFormatError(f"an {kind}'s name must be a non-empty string of printable "
                             f"characters, got {shown_value(name)}")
    return shown


def _field(obj: Any, key: str, label: str, prefix: str = "") -> Any:
    """``obj.key`` or ``obj[key]``; a one-line refusal naming the field when it has
    neither."""
    if isinstance(obj, Mapping):
        if key in obj:
            return obj[key]
    elif hasattr(obj, key):
        return getattr(obj, key)
    raise MapFormatError(f"{label}: it has no field {prefix}{key}")


def _count(value: Any, what: str, label: str) -> int:
    value = python_scalar(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise MapFormatError(f"{label}: {what} must be a positive integer, got "
                             f"{shown_value(value)}")
    return value


def _occupancies(data: Any, width: Any, height: Any, label: str) -> np.ndarray:
    """``data`` as checked ``int8[height, width]`` occupancies (row 0 the bottom)."""
    if isinstance(data, (bytes, bytearray)) or (
            isinstance(data, memoryview) and data.format in ("b", "B", "c")):
        values = np.frombuffer(bytes(data), np.int8)  # the message's int8, as sent
    else:
        try:
            values = np.asarray(data)
        except (ValueError, TypeError, RecursionError) as e:  # ragged nested lists
            raise MapFormatError(f"{label}: the data is not an array of occupancies "
                                 f"({str(e).splitlines()[0]})") from None
        if values.dtype.kind in "iuf" and _holds_bool(data):  # True read as occupancy 1
            raise MapFormatError(f"{label}: occupancies must be integers from -1 to 100, "
                                 "got a sequence holding true or false")
    if values.dtype.kind not in "iuf":  # not bool, complex, times, text or objects
        raise MapFormatError(f"{label}: occupancies must be integers from -1 to 100, got "
                             f"an array of {values.dtype}")
    if values.ndim == 1:
        if width is None or height is None:
            raise MapFormatError(f"{label}: flat data needs its width and height (or give "
                                 "a [height, width] array)")
        w, h = _count(width, "the width", label), _count(height, "the height", label)
        if values.size != w * h:
            raise MapFormatError(f"{label}: {values.size:,} values for {w} x {h} cells "
                                 f"({w * h:,})")
        values = values.reshape(h, w)
    elif values.ndim == 2:
        h, w = values.shape
        for what, given, actual in (("width", width, w), ("height", height, h)):
            if given is not None and _count(given, f"the {what}", label) != actual:
                raise MapFormatError(f"{label}: the {what} is {given}, but the data's "
                                     f"[height, width] shape is {list(values.shape)}")
    else:
        raise MapFormatError(f"{label}: the data must be flat or [height, width], got "
                             f"{values.ndim} dimensions {list(values.shape)}")
    if values.size == 0:
        raise MapFormatError(f"{label}: the grid has no cells ({w} x {h})")
    bad = ~np.isin(values, np.arange(-1, 101))  # NaN, 1.5, 101 and -2 alike
    if bad.any():
        y, x = (int(v) for v in np.argwhere(bad)[0])
        unsigned = ("; the data is unsigned (a message's data is int8, -1 for unknown: "
                    "send it as int8)" if values.dtype.kind == "u" or (
                        isinstance(data, array_type) and data.typecode in "BHILQ") else "")
        raise MapFormatError(f"{label}: cell ({x}, {y}) holds {values[y, x].item()!r}: an "
                             f"occupancy is -1 (unknown), 0 (free) to 100 (occupied)"
                             f"{unsigned}")
    out = np.array(values, np.int8, order="C", copy=True)  # the caller's array left as it is
    out.setflags(write=False)
    return out


def _number(value: Any, what: str, label: str) -> float:
    value = python_scalar(value)
    try:
        number = float(value) if isinstance(value, (int, float)) and not isinstance(
            value, bool) else math.nan
    except OverflowError:  # an integer of hundreds of digits
        number = math.nan
    if not math.isfinite(number):
        raise MapFormatError(f"{label}: {what} must be a finite int or float, got "
                             f"{shown_value(value)}")
    return number


def _resolution(value: Any, label: str) -> float:
    """Metres per cell, within a ``map_server`` YAML's bounds; a float32 value read as
    the shortest decimal that gives it."""
    r = _number(value, "the resolution", label)
    if float(np.float32(r)) == r:
        r = float(np.format_float_positional(np.float32(r), unique=True))
    if not MIN_RESOLUTION <= r <= MAX_RESOLUTION:
        raise MapFormatError(f"{label}: the resolution must be from {MIN_RESOLUTION:g} to "
                             f"{MAX_RESOLUTION:g} metres per cell, got {r}")
    return r


def _origin(value: Any, resolution: float, label: str) -> tuple[float, float, float]:
    """``(x, y, yaw)`` from ``(x, y)`` or ``(x, y, yaw)``, within a ``map_server`` YAML's
    bounds."""
    is_sequence = isinstance(value, (tuple, list)) or (
        isinstance(value, np.ndarray) and value.ndim == 1)
    parts = list(value) if is_sequence else []  # not a set's or a dict's order
    if len(parts) not in (2, 3):
        raise MapFormatError(f"{label}: the origin must be (x, y) or (x, y, yaw), got "
                             f"{shown_value(value)}")
    x, y, yaw = (_number(v, "the origin", label) for v in (*parts, 0.0)[:3])
    if max(abs(x), abs(y)) > MAX_ORIGIN:
        raise MapFormatError(f"{label}: the origin must lie within {MAX_ORIGIN:g} metres "
                             f"of 0, got ({x:g}, {y:g})")
    if (far := origin_in_cells_problem(resolution, (x, y))) is not None:
        raise MapFormatError(f"{label}: {far}")
    return x, y, yaw


def _yaw(q: list, label: str) -> float:
    """The rotation about z of the quaternion ``(x, y, z, w)``, refused in one line when
    it turns the map out of the plane or is not a rotation."""
    qx, qy, qz, qw = (_number(v, "the origin's orientation", label) for v in q)
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if norm == 0.0:  # a message's default: no orientation set, so none meant
        return 0.0
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise MapFormatError(f"{label}: the origin's orientation ({qx:g}, {qy:g}, {qz:g}, "
                             f"{qw:g}) is not a rotation: its norm is {norm:g}, not 1")
    if max(abs(qx), abs(qy)) > QUATERNION_TOLERANCE:
        raise MapFormatError(f"{label}: the origin's orientation ({qx:g}, {qy:g}, {qz:g}, "
                             f"{qw:g}) turns the map out of the plane; a grid map turns "
                             "about z only")
    return math.atan2(2.0 * qw * qz, qw * qw - qz * qz)  # in (-pi, pi]; q and -q alike
