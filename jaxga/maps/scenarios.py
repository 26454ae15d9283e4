"""Moving AI scenario (``.scen``) files.

A scenario file (https://movingai.com/benchmarks/formats.html) starts with ``version 1``
and then has one problem per line with 9 tab-separated fields: bucket, map file, map
width, map height, start x, start y, goal x, goal y, optimal length. Moving AI counts y
from the **top**; :func:`read_scen` converts it to the library's bottom-up convention,
``y_ours = height - 1 - y_movingai``. The optimal length is the 8-connected shortest path
without corner cutting (``corner_rule="strict"``).

Each problem names its map (``maze-32-32-2.map``, ``maps/dao/arena.map``); a problem of
one map is meaningless on another of the same size (its endpoints may be blocked and its
optimal length is another map's): :meth:`Scenario.is_for` and ``apply(grid, map_file=)``
compare the names.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path

from jaxga.core.errors import MapFormatError
from jaxga.core.fields import shown_value
from jaxga.core.files import file_path
from jaxga.core.grid import Grid
from jaxga.core.numerals import ascii_float, ascii_int
from jaxga.maps.inputs import SCENARIO_CAP, lines_of, read_input

__all__ = ["Scenario", "parse_scen", "read_scen"]


@dataclasses.dataclass(frozen=True)
class Scenario:
    """One Moving AI problem, with coordinates in the bottom-up convention (docs/maps.md).

    Attributes:
        bucket: the file's bucket number (``floor(optimal_length / 4)`` in these files).
        map_name: the map field as written in the file (e.g. ``"maze-32-32-2.map"``).
        width: map width W.
        height: map height H.
        start: ``(x, y)`` start, y counted from the bottom.
        goal: ``(x, y)`` goal, y counted from the bottom.
        optimal_length: the file's optimal 8-connected length (strict corner rule).
    """

    bucket: int
    map_name: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal_length: float

    def is_for(self, map_file: str | os.PathLike) -> bool:
        """Whether this problem names the map ``map_file`` (a path, or a built-in map's
        name, which is its file's name without the extension): the file names compared
        without their folders and extensions, ignoring case, so that
        ``maps/dao/arena.map`` is ``/data/arena.map`` (and ``arena.png``, the same map
        converted) but not ``arena2.map``."""
        return _map_stem(os.fspath(map_file)) == _map_stem(self.map_name)

    def apply(self, grid: Grid, map_file: str | os.PathLike | None = None) -> Grid:
        """Return ``grid`` with this problem's start and goal. The map sizes must match,
        and with ``map_file`` (the map's path or built-in name) the problem must name that
        map (:meth:`is_for`): a problem of another map would be planned on silently."""
        if (grid.width, grid.height) != (self.width, self.height):
            raise MapFormatError(
                f"scenario for {self.map_name} is {self.width} x {self.height} but the grid is "
                f"{grid.width} x {grid.height}"
            )
        if map_file is not None and not self.is_for(map_file):
            raise MapFormatError(f"scenario for {self.map_name} is not for map "
                                 f"{os.fspath(map_file)} (another map of the same size)")
        return grid.replace(start=self.start, goal=self.goal)


def _map_stem(name: str) -> str:
    """A map's file name without folders (``/`` or ``\\``) and extension, case-folded."""
    base = re.split(r"[\\/]", name.strip())[-1]
    return Path(base).stem.casefold() if base not in ("", ".", "..") else base


def read_scen(path: str | os.PathLike) -> list[Scenario]:
    """Read a Moving AI ``.scen`` file; y is converted to count from the bottom.

    Raises :class:`~jaxga.core.errors.MapFormatError` for a missing or unreadable file, one
    that is not a regular file or holds more than :data:`jaxga.maps.inputs.SCENARIO_CAP`
    bytes, a missing ``version`` header, a line without 9 fields, a non-numeric field or
    a start or goal off its map, naming the file and line.
    """
    p = file_path(path, "a scenario file", MapFormatError)
    label = str(p)
    try:
        text = read_input(p, SCENARIO_CAP, what="scenario file", label=label,
                          note="64 bytes a problem, one problem for every cell of the "
                          "largest map jaxga plans on").decode("utf-8-sig")
    except FileNotFoundError:
        raise MapFormatError(f"{label}: scenario file not found") from None
    except IsADirectoryError:
        raise MapFormatError(f"{label}: is a directory, not a scenario file") from None
    except UnicodeDecodeError as e:
        raise MapFormatError(
            f"{label}: not a text scenario file (byte {e.start} is not valid UTF-8)"
        ) from None
    except OSError as e:
        raise MapFormatError(f"{label}: cannot read scenario file ({e.strerror or e})") from None
    return parse_scen(text, label)


def parse_scen(text: str, label: str = "<scen>") -> list[Scenario]:
    """Parse the text of a ``.scen`` file (see :func:`read_scen`); ``label`` names it."""
    if not isinstance(text, str):
        raise MapFormatError(f"{label}: a scenario's text must be a str (decode bytes "
                             f"first), got {shown_value(text)}")
    lines = lines_of(text)
    numbered = [(n, ln.strip("\r\n")) for n, ln in enumerate(lines, 1) if ln.strip()]
    if not numbered:
        raise MapFormatError(f"{label}: scenario file is empty")
    n0, head = numbered[0]
    words = head.split()
    if len(words) != 2 or words[0].lower() != "version" or not _is_version_1(words[1]):
        raise MapFormatError(
            f"{label}: line {n0}: expected the header 'version 1', got {head.strip()!r}"
        )
    out: list[Scenario] = []
    for lineno, line in numbered[1:]:
        fields = line.split("\t") if "\t" in line else line.split()
        fields = [f.strip() for f in fields]
        while fields and fields[-1] == "":  # trailing tab
            fields.pop()
        if len(fields) != 9:
            raise MapFormatError(
                f"{label}: line {lineno}: expected 9 tab-separated fields, got {len(fields)}"
            )
        bucket_s, map_s, *nums, opt_s = fields
        try:
            bucket = ascii_int(bucket_s)
            w, h, sx, sy, gx, gy = (ascii_int(v) for v in nums)
            opt = ascii_float(opt_s)
        except ValueError:
            raise MapFormatError(
                f"{label}: line {lineno}: non-numeric field in {line.strip()!r}"
            ) from None
        if w < 1 or h < 1:
            raise MapFormatError(f"{label}: line {lineno}: map size {w} x {h} is not positive")
        for what, x, y in (("start", sx, sy), ("goal", gx, gy)):
            if not (0 <= x < w and 0 <= y < h):
                raise MapFormatError(
                    f"{label}: line {lineno}: {what} ({x}, {y}) is off the {w} x {h} map"
                )
        if not math.isfinite(opt) or opt < 0:
            raise MapFormatError(f"{label}: line {lineno}: bad optimal length {opt_s!r}")
        out.append(
            Scenario(
                bucket=bucket,
                map_name=map_s,
                width=w,
                height=h,
                start=(sx, h - 1 - sy),
                goal=(gx, h - 1 - gy),
                optimal_length=opt,
            )
        )
    return out


def _is_version_1(s: str) -> bool:
    try:
        return ascii_float(s) == 1.0
    except ValueError:
        return False
