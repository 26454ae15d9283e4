"""The map file formats: telling them apart, reading each into a ``blocked`` array and
writing a grid in each.

Every reader returns ``blocked[y, x]`` with ``y = 0`` the **bottom** row, the library's
convention (docs/maps.md). The file formats differ in which row comes first:

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
  ``unknown="free"``. :attr:`jaxga.maps.loaders.MapInfo.ros` keeps the metadata: metres
  per cell and the origin, for world coordinates (``start_world=``, ``goal_world=``).

:func:`detect_format` tells them apart from a file's content and extension;
:func:`save_map` writes each in the orientation its reader expects, so that a map
round-trips. A malformed file raises :class:`~jaxga.core.errors.MapFormatError` with a
one-line message that names the file, the problem and, where it helps, the line.
:func:`read_map_bytes` reads only a regular file, and no more of it than a map within the
size limit takes (:mod:`jaxga.maps.inputs`). :mod:`jaxga.maps.loaders` turns what these
readers return into a :class:`jaxga.Grid`.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from jaxga.core.errors import JaxgaError, MapFormatError
from jaxga.core.fields import python_scalar, shown_value
from jaxga.core.files import atomic_write, atomic_write_text, check_outputs, file_path, same_file
from jaxga.core.grid import Grid, blocked_array
from jaxga.core.matplotlib_env import matplotlib_ready
from jaxga.core.numerals import ASCII_SPACES, ascii_int
from jaxga.maps import builtin
from jaxga.maps.inputs import (
    MAX_READ_COARSEN,
    YAML_CAP,
    check_image_data,
    decode_image,
    image_size,
    lines_of,
    map_file_cap,
    map_file_cap_note,
    png_chunks,
    png_frames,
    png_header,
    read_input,
    several_frames,
)
from jaxga.maps.ros import MAX_ORIGIN, MAX_RESOLUTION, MIN_RESOLUTION, origin_in_cells_problem

__all__ = [
    "FORMATS",
    "declared_size",
    "decode_text",
    "detect_format",
    "parse_01",
    "parse_ascii",
    "parse_movingai",
    "parse_png",
    "read_map_bytes",
    "save_map",
]

FORMATS: tuple[str, ...] = ("01", "movingai", "ascii", "png", "ros")
"""The map formats :func:`jaxga.maps.load_map` reads and :func:`save_map` writes."""

MOVINGAI_PASSABLE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")
ASCII_FREE = frozenset(".SG")
ASCII_BLOCKED = frozenset("#@")

_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
IMAGE_SUFFIXES = (".png", ".pgm", ".ppm", ".pbm", ".pnm", ".bmp", ".gif", ".jpg", ".jpeg",
                  ".tif", ".tiff", ".webp")
"""Image files read as ``"png"`` maps (thresholded luminance; Pillow reads the others)."""


def _is_image(raw: bytes) -> bool:
    """Whether ``raw`` starts with the signature of an image format Pillow reads (PNG,
    GIF, BMP, JPEG, TIFF, WebP, Netpbm): none is a text map's first bytes."""
    return (raw.startswith((_PNG_MAGIC, b"GIF87a", b"GIF89a", b"BM", b"\xff\xd8\xff",
                            b"II*\x00", b"MM\x00*"))
            or (raw[:4] == b"RIFF" and raw[8:12] == b"WEBP")
            or (len(raw) > 2 and raw[:1] == b"P" and raw[1:2] in b"123456"
                and raw[2:3] in b" \t\r\n#"))
_ZERO_ONE = frozenset("01")
_SEPARATORS = frozenset(" \t,")

Source = str | os.PathLike
"""A map file's path (for :func:`jaxga.maps.load_map`, also a built-in map's name)."""
XY = tuple[int, int]
"""A cell ``(x, y)``, ``y`` counted from the bottom row."""


def detect_format(path: Source, raw: bytes | None = None) -> str:
    """Guess a map file's format from its content and extension.

    An image's signature (PNG, GIF, BMP, JPEG, TIFF, WebP, Netpbm) or an image extension
    (:data:`IMAGE_SUFFIXES`: ``.png``, ``.pgm``, ...) -> ``"png"``; ``.yaml``/``.yml`` -> ``"ros"``;
    ``.map`` extension or a first
    non-blank line starting with ``type`` -> ``"movingai"``; a first non-blank line
    starting with ``0`` or ``1`` -> ``"01"``; anything else -> ``"ascii"``
    (whose parser then reports any unknown character). ``raw`` is the file content if
    already read.
    """
    p = Path(os.fspath(path))
    if raw is None:
        raw = read_map_bytes(p, str(p), coarsen=MAX_READ_COARSEN)
    suffix = p.suffix.lower()
    if _is_image(raw) or suffix in IMAGE_SUFFIXES:
        return "png"
    if suffix in (".yaml", ".yml"):
        return "ros"
    if suffix == ".map":
        return "movingai"
    first = ""
    for line in lines_of(raw.decode("utf-8-sig", errors="replace")):  # BOM too
        if line.strip():
            first = line.strip()
            break
    if first.split(maxsplit=1)[:1] == ["type"]:
        return "movingai"
    if first[:1] in _ZERO_ONE:  # the 0/1 parser reports any other character
        return "01"
    return "ascii"


# -------------------------------------------------------------------------- parsers
_EMPTY_FIELD = re.compile(r"^\s*,|,\s*,")
"""A comma-separated row with an empty field before another (a trailing comma is kept as
the end of the row, as spreadsheets write it)."""


def parse_01(text: str, label: str = "<text>") -> np.ndarray:
    """Parse 0/1 text (file line 1 = row y = 0, the bottom); return ``bool[H, W]``.

    Cells are ``0`` (free) or ``1`` (obstacle), separated by spaces, tabs or commas, or
    written without separators (``0101``). Leading and trailing blank lines are ignored.
    ``label`` names the file in error messages.
    """
    rows: list[list[bool]] = []
    for lineno, line in _body_lines(text, label):
        if any(c in _SEPARATORS for c in line):
            if _EMPTY_FIELD.search(line):  # "0,,1": dropped, it would shift the columns
                raise MapFormatError(f"{label}: line {lineno}: an empty cell between commas "
                                     "(every cell is 0 or 1)")
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
    lines = lines_of(text)
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
                value = ascii_int(words[1])
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
    allowed = MOVINGAI_PASSABLE | MOVINGAI_BLOCKED
    rows = []
    for r, line in enumerate(body):
        lineno = i + r + 1
        row = line.rstrip(ASCII_SPACES)
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
        rows.append(row)
    # allocated once every row is checked: the header's size alone allocates nothing
    out = np.zeros((h, w), dtype=bool)
    for r, row in enumerate(rows):
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
def _check_image_is_ours(yaml_path: Path, image: Path) -> None:
    """Refuse to write a ROS map's image over a file that is not the image of the map
    being replaced: ``save_map(g, "b.yml")`` beside another map's ``b.pgm`` (named by
    ``b.yaml``) overwrote that map's image. An image the YAML being replaced names is
    its own, and is rewritten."""
    if not os.path.lexists(image):
        return
    named = None
    try:
        with open(yaml_path, encoding="utf-8") as f:
            doc = yaml.safe_load(f.read(1 << 20))
        if isinstance(doc, dict) and isinstance(doc.get("image"), str):
            named = yaml_path.parent / doc["image"]
    except (OSError, UnicodeDecodeError, yaml.YAMLError, ValueError):
        pass
    try:
        ours = named is not None and same_file(named, image)
    except (OSError, ValueError):  # a name no file can have (a lone surrogate, a NUL)
        ours = False
    if not ours:
        raise MapFormatError(
            f"cannot save {yaml_path}: its image {image} exists and is not the image of "
            f"the map being replaced (another map's?); save under another name or remove it")


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
    thresholds) and a binary PGM beside it (free 254, occupied 0), named as the YAML with
    ``.pgm``; an existing PGM of that name is only replaced when the YAML being replaced
    names it (it is that map's image), else refused. Returns the path.

    Refused before anything is written (:class:`~jaxga.core.errors.MapFormatError`, one
    line): an array :meth:`Grid.create` would refuse; a name whose extension
    :func:`load_map` would read as another format than ``fmt`` (an image extension other
    than ``.png``, ``.map`` for a non-Moving AI file, a ROS map not named ``.yaml``); a
    resolution or origin a ROS map cannot have (:data:`jaxga.maps.ros.MIN_RESOLUTION` to
    :data:`~jaxga.maps.ros.MAX_RESOLUTION` m, origins within
    :data:`~jaxga.maps.ros.MAX_ORIGIN` m and
    :data:`~jaxga.maps.ros.MAX_ORIGIN_CELLS` cells); a name that is not a ``str`` or a path. Each
    file is written whole or not at all (:func:`jaxga.core.files.atomic_write`), and one
    it cannot write is refused as a :class:`~jaxga.core.errors.JaxgaError` line (a
    folder of that name, a read-only file, a file inside jaxga's own folder); a ROS
    map's YAML and image are both checked before either is written.
    """
    p = file_path(path, "the map to save", MapFormatError)
    suffix = p.suffix.lower()
    if fmt is None:
        fmt = {".map": "movingai", ".png": "png", ".ascii": "ascii", ".asc": "ascii",
               ".yaml": "ros", ".yml": "ros"}.get(suffix, "01")
    if fmt not in FORMATS:
        raise MapFormatError(f"unknown map format {shown_value(fmt)}: expected one of "
                             f"{', '.join(FORMATS)}")
    _check_name_reads_back(p, suffix, fmt)
    if isinstance(grid, Grid):
        blocked = grid.blocked_np()
        endpoints = (grid.start_xy, grid.goal_xy)
    else:
        try:  # the arrays a grid may be made of, and no other (of any size)
            blocked = blocked_array(grid)
        except JaxgaError as e:
            raise MapFormatError(f"cannot save {p}: {e}") from None
        endpoints = None
    h, w = blocked.shape
    if fmt == "png":
        matplotlib_ready()
        import matplotlib.image as mpimg

        buf = io.BytesIO()
        mpimg.imsave(buf, (~blocked).astype(float), cmap="gray", vmin=0.0, vmax=1.0,
                     origin="lower", format="png")
        atomic_write(p, lambda f: f.write(buf.getvalue()), binary=True)
        return p
    if fmt == "ros":
        res, (x0, y0, yaw) = _checked_frame(p, resolution, origin)
        image = p.with_suffix(".pgm")
        _check_image_is_ours(p, image)
        # both files checked before either is written: a YAML that cannot be written (a
        # folder of that name, a read-only file) must not leave a new image behind
        check_outputs({"the map's YAML": p, "its image": image})
        pixels = np.where(blocked[::-1], 0, 254).astype(np.uint8)
        header = f"P5\n# CREATOR: jaxga {res!r} m/pix\n{w} {h}\n255\n".encode("ascii")
        new_image = not image.exists()
        atomic_write(image, lambda f: f.write(header + pixels.tobytes()), binary=True)
        # the name as a double-quoted scalar in YAML's own escapes: a name with a leading
        # space, '#', ': ', a YAML indicator or a character beyond the BMP (JSON writes
        # those as surrogate pairs, two lone surrogates to YAML) is read back as written
        name = yaml.safe_dump(image.name, default_style='"', width=float("inf")).strip()
        try:
            atomic_write_text(p, f"image: {name}\nmode: trinary\n"
                                 f"resolution: {_yaml_float(res)}\n"
                                 f"origin: [{_yaml_float(x0)}, {_yaml_float(y0)}, "
                                 f"{_yaml_float(yaw)}]\nnegate: 0\n"
                                 "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
        except BaseException:  # a full disk, an interrupt: no image without its YAML
            if new_image:
                with contextlib.suppress(OSError):
                    image.unlink()
            raise
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
    atomic_write_text(p, "\n".join(lines) + "\n")
    return p


def _check_name_reads_back(p: Path, suffix: str, fmt: str) -> None:
    """Refuse a file name that :func:`load_map` would read as another format than
    ``fmt`` (its extension decides before its content: :func:`detect_format`)."""
    read_as = ("png" if suffix in IMAGE_SUFFIXES else "ros" if suffix in (".yaml", ".yml")
               else "movingai" if suffix == ".map" else None)
    if fmt == "png" and suffix != ".png":
        raise MapFormatError(f"cannot save {p} as a PNG image: name it .png")
    if fmt == "ros" and read_as != "ros":
        raise MapFormatError(f"cannot save {p} as a ROS map: name its YAML file .yaml "
                             "(the image goes beside it, as .pgm)")
    if read_as is not None and read_as != fmt:
        raise MapFormatError(f"cannot save {p} in the {fmt!r} format: load_map would read a "
                             f"{suffix} file as {read_as!r}; use another extension")


def _checked_frame(p: Path, resolution: Any, origin: Any) -> tuple[float, tuple]:
    """``(resolution, (x, y, yaw))`` as finite floats a ROS map may have, else one line."""
    try:  # numbers only: "123" is not an origin (1, 2, 3), True not 1 m
        if isinstance(origin, (str, bytes)) or any(
                isinstance(v, (bool, np.bool_, str, bytes))
                for v in (resolution, *tuple(origin))):
            raise TypeError
        res = float(resolution)
        x0, y0, yaw = (float(v) for v in origin)
    except (TypeError, ValueError):
        raise MapFormatError(f"cannot save {p}: resolution must be a number and origin three "
                             f"numbers (x, y, yaw), got {shown_value(resolution)} and "
                             f"{shown_value(origin)}") from None
    if not MIN_RESOLUTION <= res <= MAX_RESOLUTION:
        raise MapFormatError(f"cannot save {p}: resolution must be {MIN_RESOLUTION:g} to "
                             f"{MAX_RESOLUTION:g} m a cell, got {shown_value(resolution)}")
    if not all(np.isfinite(v) and abs(v) <= MAX_ORIGIN for v in (x0, y0, yaw)):
        raise MapFormatError(f"cannot save {p}: the origin must be finite, within "
                             f"{MAX_ORIGIN:g} m, got {shown_value(origin)}")
    if (far := origin_in_cells_problem(res, (x0, y0))) is not None:
        raise MapFormatError(f"cannot save {p}: {far}")
    return res, (x0, y0, yaw)


def _yaml_float(x: float) -> str:
    """``x`` written so that it reads back as the same float, as a float in YAML 1.1 too
    (whose floats need a dot and a signed exponent: ``1e-09`` would be a string)."""
    text = repr(float(x))
    if "e" in text:
        mantissa, exponent = text.split("e")
        if "." not in mantissa:
            mantissa += ".0"
        if exponent[0] not in "+-":
            exponent = "+" + exponent
        text = f"{mantissa}e{exponent}"
    return text


# -------------------------------------------------------------------------- reading
def read_map_bytes(path: Path, label: str, builtin_hint: bool = False, *, yaml: bool = False,
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


def decode_text(raw: bytes, label: str) -> str:
    """A text map's bytes as text (UTF-8, a byte-order mark dropped), so that the text
    parsers see only text: an image, a binary file and a Moving AI scenario given as a
    map are each refused in one line naming the file."""
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
    first = next((ln.strip() for ln in lines_of(text) if ln.strip()), "")
    if first.split(maxsplit=1)[:1] == ["version"]:
        raise MapFormatError(
            f"{label}: is a Moving AI scenario file, not a map (read it with read_scen)"
        )
    return text


def _body_lines(text: str, label: str) -> list[tuple[int, str]]:
    """Non-blank lines (1-based line number, right-stripped), no blank line in between."""
    lines = [ln.rstrip(ASCII_SPACES) for ln in lines_of(text)]
    numbered = [(n, ln) for n, ln in enumerate(lines, 1) if ln]
    if not numbered:
        raise MapFormatError(f"{label}: map file is empty")
    first, last = numbered[0][0], numbered[-1][0]
    if len(numbered) != last - first + 1:
        gap = next(n for n in range(first, last + 1) if not lines[n - 1])
        raise MapFormatError(f"{label}: line {gap}: blank line inside the map")
    return numbered


def declared_size(raw: bytes, kind: str) -> tuple[int, int] | None:
    """``(width, height)`` of a map file from its header (an image's, Moving AI) or its
    first line and line count (0/1 text, ASCII art), without parsing it, so that a map
    too large is refused before it is parsed (decision 021); None if it cannot be told
    (the parser then reports what is wrong)."""
    if kind == "png":
        return image_size(raw)
    if kind == "ros":  # the image's size is checked once it is read
        return None
    if b"\x00" in raw[:4096]:  # a binary file, not text: the parser says so
        return None
    head = raw[:4096].decode("utf-8", errors="replace")
    if kind == "movingai":
        dims = {}
        for line in lines_of(head):  # the header, as the parser reads it (blank lines too)
            words = line.split()
            if words and words[0].lower() == "map":
                break
            if len(words) == 2 and words[0].lower() in ("height", "width"):
                try:
                    dims[words[0].lower()] = ascii_int(words[1])
                except ValueError:
                    pass  # the parser names the value
        return (dims["width"], dims["height"]) if len(dims) == 2 else None
    lines = [line for line in lines_of(raw) if line.strip()]
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


def _read_by_pillow(raw: bytes) -> bool:
    """Whether a PNG is a grey one of 1, 2 or 4 bits (matplotlib scales Pillow's 8-bit
    values of those again: a dark wall read as white), or holds a transparent colour (a
    ``tRNS`` chunk, before its image data where PNG puts it) or EXIF data (``eXIf``,
    before or after the image data), which matplotlib's reading drops and Pillow's reads
    (:func:`decode_image`)."""
    header = png_header(raw)
    if header is not None and header[3] == 0 and header[2] < 8:
        return True
    image_data = False
    for kind, _ in png_chunks(raw):
        if kind == b"eXIf" or (kind == b"tRNS" and not image_data):
            return True
        image_data = image_data or kind == b"IDAT"
    return False


def parse_png(path: Path, label: str, threshold: float = 0.5,
              raw: bytes | None = None) -> np.ndarray:
    """Threshold an image's luminance (blocked below ``threshold``); image top row -> top
    of the map (row H-1). ``raw``: the file's bytes, already read (else read here); an
    image whose pixel data does not match its header is refused first."""
    matplotlib_ready()
    import matplotlib.image as mpimg

    threshold = python_scalar(threshold)  # np.float32(0.5) is 0.5
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or not (
            0.0 < threshold <= 1.0):
        raise MapFormatError(f"{label}: the image threshold must be a luminance in (0, 1], "
                             f"got {threshold!r}")
    if raw is None:
        raw = read_map_bytes(path, label, coarsen=MAX_READ_COARSEN)
    check_image_data(raw, label)
    png = path.suffix.lower() == ".png" or raw.startswith(_PNG_MAGIC)
    if png and (frames := png_frames(raw)) > 1:  # matplotlib reads the first alone
        raise several_frames(label, frames)
    # a grey or colour PNG with a transparent colour (tRNS): matplotlib would drop the
    # transparency that it keeps for a palette's; Pillow's reading keeps both (and reads
    # an EXIF orientation, which matplotlib drops)
    if png and not _read_by_pillow(raw):
        try:  # matplotlib's PNG reading: values in [0, 1] at 8 and 16 bits
            img = np.asarray(mpimg.imread(io.BytesIO(raw), format="png"))
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
    else:  # PGM, BMP, TIFF, ...: scaled by their own bit depth (a 16-bit PGM's maxval)
        pixels, scale = decode_image(raw, label)
        img = pixels[..., 0] if pixels.shape[2] == 1 else pixels
        img = img.astype(np.float64) / scale
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
