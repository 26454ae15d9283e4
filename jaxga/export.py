"""Paths for a robot: a planned path in metres as CSV or as a ``nav_msgs/Path``-shaped YAML.

``jaxga run --path-out FILE`` writes the best seed's path in the map's world frame
(:mod:`jaxga.maps.frame`): ``FILE.csv`` as ``x,y`` rows in metres, ``FILE.yaml`` (or
``.yml``) as the YAML form of a ROS ``nav_msgs/Path`` message (``header.frame_id``
``map``; one ``geometry_msgs/PoseStamped`` per point, ``position`` in metres, ``z = 0``,
and ``orientation`` the quaternion of the yaw along the path: the direction of the
segment that leaves the point, the last point keeping the direction it arrives in), which
``rostopic pub`` / ``ros2 topic pub`` and ``yaml.safe_load`` read.

Every file is written atomically: to a temporary file beside the target, then renamed
over it, so that a failed write leaves a previous file whole
(:func:`jaxga.core.files.atomic_write_text`, re-exported here).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import yaml

from jaxga.core.errors import JaxgaError, ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.files import atomic_write_text, file_path
from jaxga.core.numerals import ASCII_SPACES, ascii_float, yaml_number
from jaxga.maps.frame import world_decimals
from jaxga.maps.inputs import PATH_JSON_CAP, lines_of, read_input
from jaxga.maps.ros import UniqueKeyLoader

__all__ = ["MAP_FRAME", "PATH_FORMATS", "PathFrameError", "atomic_write_text", "path_format",
           "path_text", "path_yaws", "read_path", "write_path"]

PATH_FORMATS: dict[str, str] = {".csv": "csv", ".yaml": "yaml", ".yml": "yaml"}
"""File extensions of ``--path-out`` and the format each one writes."""


def path_format(path: str | os.PathLike) -> str:
    """The format of a ``--path-out`` file from its extension, or a one-line error."""
    suffix = Path(path).suffix.lower()
    if suffix not in PATH_FORMATS:
        raise JaxgaError(f"cannot write --path-out {path}: the extension must be .csv "
                         f"(x,y in metres) or .yaml / .yml (a nav_msgs/Path), got "
                         f"{suffix or 'none'!r}")
    return PATH_FORMATS[suffix]


def _path_points(points: np.ndarray) -> np.ndarray:
    """``points`` as ``float[k, 2]`` rows ``(x, y)`` (an empty sequence: no points), or a
    one-line :class:`~jaxga.core.errors.JaxgaError`: a ``[2, k]`` array, a flat one or
    ``None`` (``world_path`` of a map without metres) is refused, not reshaped into other
    points."""
    if points is None:
        raise JaxgaError("cannot write a path: the points are None (a map without metres "
                         "has no path in metres: Result.world_path is None there; write "
                         "the cells of Result.path, or load a ROS map)")
    try:
        p = np.asarray(points, float)
    except (TypeError, ValueError):
        raise JaxgaError(f"cannot write a path: the points must be numbers, float[k, 2] "
                         f"rows (x, y), got {shown_value(points)}") from None
    if p.size == 0:
        return p.reshape(0, 2)
    if p.ndim != 2 or p.shape[1] != 2:
        raise JaxgaError(f"cannot write a path: the points must be float[k, 2] rows (x, y), "
                         f"got an array of shape {p.shape}")
    return p


def path_yaws(points: np.ndarray) -> np.ndarray:
    """``float[k]``: the heading (radians, counter-clockwise from +x) at each point of a
    polyline ``float[k, 2]``: the direction of the segment leaving it; the last point
    keeps the direction it arrives in; a single point faces +x. Repeated points take the
    next distinct direction."""
    p = _path_points(points)
    k = len(p)
    yaw = np.zeros(k)
    if k < 2:
        return yaw
    d = p[1:] - p[:-1]
    seg = np.arctan2(d[:, 1], d[:, 0])
    moving = np.hypot(d[:, 0], d[:, 1]) > 0
    if not moving.any():
        return yaw
    # each segment without length takes the direction of the next one that has one
    idx = np.where(moving, np.arange(k - 1), k - 1)
    idx = np.minimum.accumulate(idx[::-1])[::-1]
    last = np.flatnonzero(moving)[-1]
    idx = np.where(idx == k - 1, last, idx)
    yaw[:-1] = seg[idx]
    yaw[-1] = seg[last]
    return yaw


def path_text(points: np.ndarray, fmt: str, frame_id: str = "map",
              decimals: int | None = None) -> str:
    """The text of a path file: ``fmt`` ``"csv"`` or ``"yaml"`` (see the module).
    Coordinates are written to ``decimals`` (a map's :attr:`MapFrame.world_decimals
    <jaxga.maps.frame.MapFrame.world_decimals>`: a hundredth of its cell), or more where
    the points lie closer (a hundredth of the shortest step: a curve's points), so that
    a path on a fine map is read back in the cells it crosses. A point that is not a
    finite number, or points not shaped ``float[k, 2]`` (a ``[2, k]`` array, a flat one,
    ``None``), are refused in one line."""
    p = _path_points(points)
    if not np.isfinite(p).all():
        bad = int(np.flatnonzero(~np.isfinite(p).all(axis=1))[0])
        raise JaxgaError(f"cannot write a path whose point {bad} is {tuple(p[bad].tolist())}: "
                         "a path's coordinates are finite numbers")
    steps = np.hypot(*np.diff(p, axis=0).T) if len(p) > 1 else np.zeros(0)
    d = world_decimals(float(steps[steps > 0].min()) if (steps > 0).any() else None)
    d = max(d, 4 if decimals is None else int(decimals))
    if fmt == "csv":
        return "x,y\n" + "".join(f"{x:.{d}f},{y:.{d}f}\n" for x, y in p)
    if fmt != "yaml":
        raise JaxgaError(f"unknown path format {fmt!r}: expected csv or yaml")
    # the layout yaml.safe_dump gives, written line by line: safe_dump took half a
    # millisecond a pose (a path of 100,000 poses, a minute)
    frame = yaml.safe_dump(frame_id, width=float("inf")).removesuffix("\n...\n").strip()
    yaw = path_yaws(p)
    qz, qw = np.sin(yaw / 2), np.cos(yaw / 2)
    lines = [f"header:\n  frame_id: {frame}\nposes:" + ("" if len(p) else " []")]
    lines += [f"- header:\n    frame_id: {frame}\n  pose:\n    position:\n"
              f"      x: {_decimal(x, d)}\n      y: {_decimal(y, d)}\n      z: 0.0\n"
              f"    orientation:\n      x: 0.0\n      y: 0.0\n      z: {_decimal(z, 6)}\n"
              f"      w: {_decimal(w, 6)}"
              for (x, y), z, w in zip(p.tolist(), qz.tolist(), qw.tolist(), strict=True)]
    return "\n".join(lines) + "\n"


def _decimal(v: float, decimals: int) -> str:
    """``v`` to ``decimals`` places without trailing zeros, and always with a point: a
    YAML 1.1 float (``1e-05`` without one is a string to PyYAML)."""
    text = f"{v:.{decimals}f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def write_path(path: str | os.PathLike, points_world: np.ndarray, frame_id: str = "map",
               decimals: int | None = None) -> None:
    """Write a path in metres to ``path`` as CSV or YAML (by its extension), atomically;
    ``decimals`` as :func:`path_text` (pass the map's ``frame.world_decimals``)."""
    path = file_path(path, "a path file")
    atomic_write_text(path, path_text(points_world, path_format(path), frame_id, decimals))


MAP_FRAME = "map"
"""The frame of every path jaxga writes and reads: the map's (``map_server``'s default
``frame_id``), in which a path's metres are the map's own."""


class PathFrameError(ValueError):
    """A ``nav_msgs/Path`` whose poses are in a frame other than :data:`MAP_FRAME`."""


def _check_path_frame(doc: object) -> None:
    """Refuse a ``nav_msgs/Path`` in another frame than the map's (its header's or a
    pose's ``frame_id``): its metres are not the map's, and no transform is known here."""
    if not isinstance(doc, dict):
        return  # not a path: read_path says so
    headers = [("the path", doc.get("header"))]
    headers += [(f"pose {i}", pose.get("header")) for i, pose in
                enumerate(doc.get("poses") or []) if isinstance(pose, dict)]
    for what, header in headers:
        frame = header.get("frame_id") if isinstance(header, dict) else None
        if frame not in (None, "", MAP_FRAME, f"/{MAP_FRAME}"):  # ROS 1 wrote '/map'
            raise PathFrameError(
                f"{what} is in the frame {shown_value(frame)}, not the map's "
                f"{MAP_FRAME!r}: transform it to the map frame first (jaxga reads and "
                "writes paths in the map's metres)")


def _coordinate(value: object) -> float:
    """A pose's coordinate, as yaml-cpp reads a number
    (:func:`jaxga.core.numerals.yaml_number`); not a bool."""
    try:
        return yaml_number(value)
    except TypeError:
        raise TypeError(f"a position's x and y are numbers, got {shown_value(value)}") from None


def read_path(path: str | os.PathLike) -> np.ndarray:
    """``float[k, 2]``: the points in metres of a path file as :func:`write_path` writes
    it (``.csv`` with an ``x,y`` header, or a ``nav_msgs/Path`` YAML: its poses'
    positions, in the map's frame: :data:`MAP_FRAME`), so that the path a robot was given
    can be checked again (``jaxga replan --path``). A one-line :class:`ParameterError` for
    anything else: another frame, a key given twice, a coordinate that is not a number
    (``true``), a CSV value not written in ASCII digits (``1_0``). The empty path
    written for a goal that was not reached reads back as ``float[0, 2]``; a CSV may start
    with a UTF-8 byte-order mark."""
    path = file_path(path, "a path file", ParameterError)
    label = os.fspath(path)
    fmt = PATH_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ParameterError(f"{label}: a path file is .csv (x,y in metres) or .yaml / .yml "
                             "(a nav_msgs/Path)")
    try:
        text = read_input(path, PATH_JSON_CAP, what="path file",
                          error=ParameterError).decode("utf-8")
        text = text.removeprefix("\ufeff")  # the byte-order mark spreadsheets write
    except FileNotFoundError:
        raise ParameterError(f"{label}: path file not found") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterError(f"{label}: cannot read the path file ({e})") from None
    try:
        if fmt == "csv":
            lines = [ln.strip(ASCII_SPACES) for ln in lines_of(text) if ln.strip(ASCII_SPACES)]
            if not lines or lines[0].replace(" ", "").lower() != "x,y":
                raise ValueError("the first line must be the header x,y")
            points = [[ascii_float(v) for v in ln.split(",")] for ln in lines[1:]]
            if any(len(p) != 2 for p in points):
                raise ValueError("every row holds two values, x,y")
        else:
            doc = yaml.load(text, Loader=UniqueKeyLoader)  # noqa: S506 - a SafeLoader
            _check_path_frame(doc)
            points = [[_coordinate(pose["pose"]["position"][k]) for k in ("x", "y")]
                      for pose in doc["poses"]]
        out = np.asarray(points, float).reshape(-1, 2)
    except PathFrameError as e:
        raise ParameterError(f"{label}: {e}") from None
    except (ValueError, TypeError, OverflowError, KeyError, IndexError, yaml.YAMLError,
            RecursionError) as e:
        what = "x,y rows" if fmt == "csv" else "a nav_msgs/Path (poses[].pose.position)"
        why = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise ParameterError(f"{label}: not a path file of {what} ({why})") from None
    if not np.isfinite(out).all():
        raise ParameterError(f"{label}: the path holds a value that is not a finite number")
    return out
