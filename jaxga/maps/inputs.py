"""Reading the files jaxga takes as input: bounded, from regular files, images checked.

Every file jaxga reads as input (a map file, a ROS ``map_server`` YAML and its image, a
Moving AI scenario, a path JSON for re-planning) is read by :func:`read_input`:

* only a **regular file** is read. A FIFO, a character or block device (``/dev/zero``,
  ``/dev/stdin`` on a terminal) or a socket is refused at once: such a file may never
  end or never deliver, and its size cannot be known before it is read. The file is
  opened without blocking (``O_NONBLOCK``: a FIFO with no writer does not hang the
  open) and checked on the open descriptor, so the check and the read see one file;
* at most a **cap** of bytes is read, derived from the largest map jaxga plans on
  (:data:`jaxga.core.grid.MAX_MAP_CELLS`): :func:`map_file_cap` for map files and their
  images, :data:`SCENARIO_CAP`, :data:`YAML_CAP` and :data:`PATH_JSON_CAP` for the rest.
  A larger file is refused from its size before a byte is read; a file that grows while
  it is read is refused once it passes the cap.

Images are checked against their headers before they are decoded
(:func:`check_image_data`): the pixel data a PNG or a Netpbm image (PGM, PPM, PBM) holds
must be the size its header declares, so that a truncated file or one with extra data
is refused naming both sizes instead of being read from its header alone.
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import os
import re
import stat
import warnings
import zlib
from collections.abc import Iterator
from typing import Any

import numpy as np

from jaxga.core.errors import JaxgaError, MapFormatError
from jaxga.core.fields import shown_value
from jaxga.core.files import impossible_name, shown_name
from jaxga.core.grid import MAX_MAP_CELLS

__all__ = [
    "MAP_BYTES_PER_CELL",
    "MAP_FILE_SLACK",
    "MAX_READ_COARSEN",
    "PATH_JSON_CAP",
    "SCENARIO_CAP",
    "YAML_CAP",
    "check_image_data",
    "decode_image",
    "image_size",
    "json_value",
    "lines_of",
    "map_file_cap",
    "map_file_cap_note",
    "png_header",
    "read_input",
]

MAP_BYTES_PER_CELL = 16
"""The most bytes a map file may spend on one cell: a 16-bit RGBA pixel takes 8, a plain
(ASCII) PPM pixel up to 12 (``255 255 255``), a 0/1 text cell 2 to 4."""

MAP_FILE_SLACK = 1 << 20
"""Bytes a map file may hold beyond its cells (headers, comments, metadata): 1 MiB."""

MAX_READ_COARSEN = 4
"""The coarsening factor up to which a larger map file is read: a map of at most
``MAX_MAP_CELLS`` cells once coarsened ``K x K`` has ``K * K`` times as many cells. Beyond
``K = 4`` the cap stays at ``map_file_cap(4)`` (1 GiB and 1 MiB)."""

YAML_CAP = MAP_FILE_SLACK
"""The largest ROS ``map_server`` YAML file read (1 MiB: its metadata takes a few hundred
bytes)."""

SCENARIO_CAP = 64 * MAX_MAP_CELLS
"""The largest Moving AI scenario file read: 64 bytes (a problem line) for every cell of
the largest map jaxga plans on (256 MiB)."""

PATH_JSON_CAP = 64 * MAX_MAP_CELLS
"""The largest path JSON read for re-planning (``jaxga replan --path-json``, ``--path``):
64 bytes for every cell of the largest map jaxga plans on (256 MiB), room for the JSON of
``jaxga run`` with its paths in cells and metres for many seeds."""

_CHUNK = 1 << 20
_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def map_file_cap(coarsen: int = 1) -> int:
    """The most bytes read from a map file or a ROS map's image: :data:`MAP_BYTES_PER_CELL`
    for every cell of a map of :data:`~jaxga.core.grid.MAX_MAP_CELLS` cells once coarsened
    ``coarsen x coarsen`` (up to :data:`MAX_READ_COARSEN`), plus :data:`MAP_FILE_SLACK`.
    Without coarsening 65 MiB: a map over the size limit is refused anyway."""
    k = min(max(int(coarsen), 1), MAX_READ_COARSEN)
    return MAP_BYTES_PER_CELL * MAX_MAP_CELLS * k * k + MAP_FILE_SLACK


def map_file_cap_note(coarsen: int = 1) -> str:
    """Why :func:`map_file_cap` is what it is, for a refusal: the bytes a cell, the size
    limit, the coarsening, and how a larger map is read."""
    k = min(max(int(coarsen), 1), MAX_READ_COARSEN)
    return (f"{MAP_BYTES_PER_CELL} bytes a cell of the largest map jaxga plans on, "
            f"{MAX_MAP_CELLS:,} cells" + (f", coarsened {k} x {k}" if k > 1 else "")
            + ", and 1 MiB" + ("; --coarsen K reads K x K times more" if k == 1 else ""))


def json_value(text: bytes | str) -> Any:
    """The value of a JSON input (a saved result, a path file), read as ``json`` reads
    it except that an object holding a key twice is refused (``json`` keeps the last
    value in silence): :class:`ValueError` for that, for text that is not UTF-8 JSON and
    for nesting deeper than Python parses ("nested too deeply"), for the caller to name
    its file."""
    def once(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for k, v in pairs:
            if k in out:
                raise ValueError(f"the key {shown_value(k)} is given twice in one object")
            out[k] = v
        return out

    try:
        return json.loads(text, object_pairs_hook=once)
    except RecursionError:
        raise ValueError("nested too deeply") from None


def read_input(path: str | os.PathLike, cap: int, *, what: str = "file",
               label: str | None = None, error: type[JaxgaError] = MapFormatError,
               note: str = "") -> bytes:
    """The bytes of input file ``path``, refused in one line unless it is a regular file
    of at most ``cap`` bytes.

    The file is opened without blocking (a FIFO with no writer does not hang) and checked
    on the open descriptor; a regular file larger than ``cap`` is refused from its size,
    before it is read, and at most ``cap + 1`` bytes are ever read.

    Args:
        path: the file.
        cap: the most bytes accepted.
        what: what the file is, for the message (``"map file"``, ``"scenario file"``).
        label: how the message names the file (default: ``path``).
        error: the :class:`~jaxga.core.errors.JaxgaError` class raised.
        note: why the cap is what it is, appended to the refusal of a large file.

    Raises:
        error: ``path`` is not a regular file (a FIFO, a device, a socket) or holds more
            than ``cap`` bytes. The message names the file and the cap.
        FileNotFoundError, IsADirectoryError, OSError: as ``open`` would; callers name
            the file in their own words.
    """
    label = str(path) if label is None else label
    why = impossible_name(path)  # os.open's ValueError or UnicodeEncodeError otherwise
    if why is not None:
        raise error(f"{shown_name(label)}: {why}")
    flags = (os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
             | getattr(os, "O_BINARY", 0))
    fd = os.open(os.fspath(path), flags)
    try:
        mode = os.fstat(fd)
        if stat.S_ISDIR(mode.st_mode):
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), os.fspath(path))
        if not stat.S_ISREG(mode.st_mode):
            kind = next((name for test, name in _KINDS if test(mode.st_mode)),
                        "not a regular file")
            raise error(f"{label}: is {kind}, not a regular file: a {what} is read only "
                        f"from a regular file (of at most {cap:,} bytes)")
        if mode.st_size > cap:
            raise error(_too_large(label, f"{mode.st_size:,} bytes", cap, what, note))
        chunks: list[bytes] = []
        size = 0
        while size <= cap:
            chunk = os.read(fd, min(_CHUNK, cap + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > cap:  # it grew while it was read
            raise error(_too_large(label, f"more than {cap:,} bytes", cap, what, note))
        return b"".join(chunks)
    finally:
        os.close(fd)


def _too_large(label: str, size: str, cap: int, what: str, note: str) -> str:
    return (f"{label}: the file holds {size}, more than the {cap:,} bytes jaxga reads from "
            f"a {what}" + (f" ({note})" if note else ""))


# ---------------------------------------------------------------------------- images
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
_PNM_NAMES = {1: "PBM", 2: "PGM", 3: "PPM", 4: "PBM", 5: "PGM", 6: "PPM"}
_WHITESPACE = b" \t\r\n\v\f"
_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
_ADAM7 = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2),
          (0, 1, 1, 2))
_COMMENT = re.compile(rb"#[^\r\n]*")


def _pnm_header(raw: bytes) -> tuple[int, int, int, int, int] | None:
    """``(kind 1-6, width, height, maxval, offset of the pixel data)`` of a Netpbm image
    (``P1`` .. ``P6``), or None when ``raw`` is not one or its header is malformed (the
    image reader then says what is wrong)."""
    if len(raw) < 3 or raw[:1] != b"P" or raw[1:2] not in (b"1", b"2", b"3", b"4", b"5", b"6"):
        return None
    kind = raw[1] - ord("0")
    if raw[2:3] not in (*(bytes([c]) for c in _WHITESPACE), b"#"):
        return None
    values: list[int] = []
    i = 2
    while len(values) < (2 if kind in (1, 4) else 3):
        while i < len(raw):
            if raw[i] in _WHITESPACE:
                i += 1
            elif raw[i] == ord("#"):
                while i < len(raw) and raw[i] not in b"\r\n":
                    i += 1
            else:
                break
        j = i
        while j < len(raw) and 48 <= raw[j] <= 57:
            j += 1
        if j == i or j - i > 9:
            return None
        values.append(int(raw[i:j]))
        i = j
    if kind in (1, 4):
        values.append(1)
    width, height, maxval = values
    if width < 1 or height < 1 or not 1 <= maxval <= 65535:
        return None
    # one whitespace byte ends the header (none left: the data is missing)
    return kind, width, height, maxval, min(i + 1, len(raw))


_LINE_END = re.compile(r"\r\n|\r|\n")
_LINE_END_BYTES = re.compile(rb"\r\n|\r|\n")


def lines_of(text: Any) -> list:
    """The lines of a text file (``str`` or ``bytes``), ended by ``\\n``, ``\\r\\n`` or
    ``\\r`` only. ``str.splitlines`` also ends a line at a vertical tab, a form feed,
    ``\\x1c``-``\\x1e``, ``\\x85`` and the Unicode line and paragraph separators,
    which split one row of a map into two (a 2-line file read as 3 rows) where a row
    holding them is refused, naming the character."""
    lines = (_LINE_END_BYTES if isinstance(text, bytes) else _LINE_END).split(text)
    if lines and not lines[-1]:
        lines.pop()
    return lines


def png_header(raw: bytes) -> tuple[int, int, int, int, int] | None:
    """``(width, height, bit depth, colour type, interlace)`` of a PNG, or None."""
    if not (raw.startswith(_PNG_MAGIC) and raw[12:16] == b"IHDR" and len(raw) >= 29):
        return None
    ihdr = raw[16:29]
    return (int.from_bytes(ihdr[0:4], "big"), int.from_bytes(ihdr[4:8], "big"), ihdr[8],
            ihdr[9], ihdr[12])


def png_chunks(raw: bytes) -> Iterator[tuple[bytes, bytes]]:
    """``(type, data)`` of each chunk of a PNG's bytes, in order, up to ``IEND`` (a chunk
    cut short by the file's end gives the data there is)."""
    pos = 8
    while pos + 8 <= len(raw):
        length = int.from_bytes(raw[pos:pos + 4], "big")
        kind = raw[pos + 4:pos + 8]
        yield kind, raw[pos + 8:pos + 8 + length]
        if kind == b"IEND":
            return
        pos += 12 + length


def several_frames(label: str, frames: int) -> MapFormatError:
    """The refusal of an image of several frames (an animated GIF or PNG, a multi-page
    TIFF): which frame would be the map?"""
    return MapFormatError(f"{label}: the image holds {frames} frames (an animation or "
                          "pages): a map is one image; save the frame you mean alone")


def png_frames(raw: bytes) -> int:
    """The frames of a PNG: an animated PNG's ``acTL`` count, else 1."""
    for kind, data in png_chunks(raw):
        if kind == b"acTL" and len(data) >= 4:
            return int.from_bytes(data[:4], "big")
        if kind == b"IDAT":  # acTL comes before the image data
            break
    return 1


def image_size(raw: bytes) -> tuple[int, int] | None:
    """``(width, height)`` an image's header declares, without decoding its pixels: read
    from a PNG's ``IHDR`` or a Netpbm header, else from Pillow's reading of the header
    (BMP, GIF, TIFF, JPEG, ...). None when it cannot be told (the image reader then says
    what is wrong)."""
    png = png_header(raw)
    if png is not None:
        return png[0], png[1]
    pnm = _pnm_header(raw)
    if pnm is not None:
        return pnm[1], pnm[2]
    from PIL import Image  # here: Pillow's import is a tenth of a second

    try:
        with _quiet_pillow(), Image.open(io.BytesIO(raw)) as img:  # the header only
            return int(img.size[0]), int(img.size[1])
    except Exception:  # noqa: BLE001 - any unreadable header: the decoder reports it
        return None


@contextlib.contextmanager
def _quiet_pillow() -> Iterator[None]:
    """A context in which Pillow's warnings are not shown: its
    ``DecompressionBombWarning`` (jaxga bounds a map's cells from its header before
    decoding, :func:`too_large`, so the warning would only repeat in two lines of its own
    what the refusal or the coarsening says) and its complaints about damaged metadata
    (``Corrupt EXIF data``), lines before jaxga's own one line about a damaged file, or
    about data an image read as a map does not hold."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def _mismatch(label: str, name: str, width: int, height: int, expected: int,
              held: str) -> MapFormatError:
    return MapFormatError(
        f"{label}: the {name} header says {width} x {height} pixels ({expected:,} bytes of "
        f"pixel data) but the file holds {held}: a truncated or damaged image")


def check_image_data(raw: bytes, label: str) -> None:
    """Refuse a PNG or Netpbm image (PGM, PPM, PBM) whose pixel data is not the size its
    header declares, in one line naming both sizes: a file cut short, or one holding more
    data than its header says (which a reader would silently ignore, reading a map of
    the header's size from the wrong bytes). Other formats are left to Pillow, which
    refuses a truncated file as unreadable."""
    pnm = _pnm_header(raw)
    if pnm is not None:
        kind, width, height, maxval, offset = pnm
        name = _PNM_NAMES[kind]
        channels = 3 if kind in (3, 6) else 1
        data = raw[offset:]
        if kind >= 4:  # binary
            if kind == 4:
                expected = height * -(-width // 8)
            else:
                expected = width * height * channels * (2 if maxval > 255 else 1)
            if len(data) != expected:
                raise _mismatch(label, name, width, height, expected,
                                f"{len(data):,} bytes of pixel data")
            if kind in (5, 6) and maxval not in (255, 65535):
                # a sample above maxval has no shade (Pillow scaled it past white)
                samples = np.frombuffer(data, ">u2" if maxval > 255 else np.uint8)
                if samples.size and int(samples.max()) > maxval:
                    raise MapFormatError(
                        f"{label}: a {name} sample of {int(samples.max())} is above the "
                        f"header's maxval {maxval}: a damaged image")
        else:  # plain (ASCII) values
            text = _COMMENT.sub(b" ", raw[offset - 1:])
            count = (text.count(b"0") + text.count(b"1") if kind == 1
                     else len(text.split()))
            expected = width * height * channels
            if count != expected:
                raise MapFormatError(
                    f"{label}: the {name} header says {width} x {height} pixels "
                    f"({expected:,} values) but the file holds {count:,} values: a "
                    "truncated or damaged image")
        return
    png = png_header(raw)
    if png is None:
        return
    width, height, depth, colour, interlace = png
    if colour not in _PNG_CHANNELS or depth not in (1, 2, 4, 8, 16) or interlace > 1:
        return  # malformed: Pillow names it
    bits = depth * _PNG_CHANNELS[colour]
    passes = _ADAM7 if interlace else ((0, 0, 1, 1),)
    expected = 0
    for x0, y0, dx, dy in passes:
        pw, ph = -(-(width - x0) // dx), -(-(height - y0) // dy)
        if pw > 0 and ph > 0:
            expected += ph * (1 + -(-pw * bits // 8))  # a filter byte per row
    idat = [data for kind_, data in png_chunks(raw) if kind_ == b"IDAT"]
    limit = 16 * expected + (1 << 16)  # inflated only so far: a small file may hold a bomb
    inflater = zlib.decompressobj()
    try:
        held = len(inflater.decompress(b"".join(idat), limit + 1))
    except zlib.error:
        return  # damaged compressed data: Pillow names it
    if held != expected:
        amount = f"more than {limit:,}" if held > limit else f"{held:,}"
        raise _mismatch(label, "PNG", width, height, expected,
                        f"{amount} bytes of pixel data once inflated")


def exif_orientation(img: Any) -> int:
    """The EXIF orientation tag (274) of an image opened by Pillow: 1 (or 0) upright,
    2-8 turned or mirrored for display; 1 without a readable EXIF block."""
    try:
        value = img.getexif().get(274, 1)
    except Exception:  # noqa: BLE001 - a damaged EXIF block: metadata, not the map
        return 1
    return value if isinstance(value, int) else 1


_SIXTEEN_BIT = ("I;16", "I;16B", "I;16L", "I;16N")
_EIGHT_BIT = ("L", "LA", "RGB", "RGBA")


_PNG16_READ_AT_8 = {2: "colour", 4: "grey-and-alpha", 6: "colour-and-alpha"}
"""PNG colour types whose 16-bit images Pillow decodes at 8 bits a channel (a 16-bit
grey PNG keeps its 16 bits)."""


def decode_image(raw: bytes, label: str) -> tuple[np.ndarray, int]:
    """``(pixels, full_scale)`` of an image file's bytes, decoded by Pillow: ``pixels`` is
    ``[H, W, C]`` (C = 1-4: grey, grey + alpha, RGB, RGBA; top row first) and
    ``full_scale`` the value of white, 255 for 8-bit images or 65535 for 16-bit ones
    (PNG, TIFF, and Netpbm images with a ``maxval`` over 255, which Pillow scales to 16
    bits); palette, bilevel and other colour modes are converted to RGBA.

    Refused in one line naming ``label``: an image Pillow cannot read, a floating-point
    image (its values have no scale a map could be read against), a 32-bit integer
    image holding values over 16 bits, and a 16-bit colour, grey-and-alpha or
    colour-and-alpha PNG (Pillow keeps 8 bits of each channel). Callers check the data
    against the header first (:func:`check_image_data`)."""
    from PIL import Image, UnidentifiedImageError  # here: Pillow's import is a tenth of a second

    try:
        with _quiet_pillow(), Image.open(io.BytesIO(raw)) as img:
            # a TIFF's orientation is read before its pixels only; a PNG's getexif()
            # would decode the pixels itself and hide a decoding error from load()
            turned = exif_orientation(img) if img.format == "TIFF" else 1
            img.load()
            frames = getattr(img, "n_frames", 1)
            if frames > 1:  # which frame is the map? none is read silently
                raise several_frames(label, frames)
            if turned in (0, 1):  # a PNG's eXIf chunk may follow its image data
                turned = exif_orientation(img)
            if turned not in (0, 1):  # as drawn, or as a viewer shows it? neither silently
                raise MapFormatError(
                    f"{label}: the image asks to be shown turned or mirrored (EXIF "
                    f"orientation {turned}): save it upright, without that tag")
            header = png_header(raw)
            if header is not None and header[2] == 16 and header[3] in _PNG16_READ_AT_8:
                # Pillow keeps the high byte of each channel of these: a pixel near a
                # threshold could read otherwise than map_server (16-bit quanta) reads it
                raise MapFormatError(
                    f"{label}: a 16-bit {_PNG16_READ_AT_8[header[3]]} PNG is read by Pillow "
                    "at 8 bits a channel, so a pixel near a threshold could be read "
                    "otherwise than at its full precision: save the map at 8 bits, or as "
                    "16-bit grey")
            key = img.info.get("transparency")
            if img.mode in ("L", "RGB") and key is not None:
                if header is not None and header[2] < 8 and isinstance(key, int):
                    # Pillow scales a 2- or 4-bit grey PNG's values to 8 bits (mode L),
                    # not its transparent value (a 1-bit one is mode 1: Pillow maps it)
                    img.info["transparency"] = key * 255 // (2 ** header[2] - 1)
                # a tRNS colour, as a palette's: transparent pixels then count as white
                # (free) for grey and colour images as for palettes and alpha channels
                img = img.convert("RGBA")
            mode = img.mode
            if mode in _EIGHT_BIT:
                pixels, scale = np.asarray(img, np.uint8), 255
            elif mode in _SIXTEEN_BIT or mode == "I":
                pixels = np.asarray(img, np.int64)
                # Pillow scales a Netpbm maxval over 255 to 16 bits ("I"); another
                # 32-bit image is read as 16-bit when its values fit, as 8-bit when they
                # fit 8 bits (the one scale its values tell)
                pnm = _pnm_header(raw)
                scale = 65535 if mode != "I" or pnm is not None or \
                    pixels.max(initial=0) > 255 else 255
                if pixels.min(initial=0) < 0 or pixels.max(initial=0) > 65535:
                    raise MapFormatError(
                        f"{label}: a 32-bit image with values from {pixels.min()} to "
                        f"{pixels.max()}: save the map as an 8- or 16-bit image")
                if isinstance(key, int) and not isinstance(key, bool) and pixels.ndim == 2:
                    # a 16-bit grey PNG's tRNS colour: an alpha channel, as for 8 bits
                    pixels = np.stack([pixels, np.where(pixels == key, 0, scale)], axis=-1)
            elif mode == "F" or mode.startswith("F;"):
                raise MapFormatError(
                    f"{label}: a floating-point image (Pillow mode {mode}) has no scale "
                    "to read free and blocked against: save the map as an 8- or 16-bit "
                    "image")
            else:  # bilevel, palette, CMYK, ...: their colours, with an alpha channel
                # only where the image has transparency (an alpha made up here would be
                # averaged into a ROS map's trinary shade)
                clear = "transparency" in img.info or mode in ("PA", "LA", "La", "RGBa")
                pixels = np.asarray(img.convert("RGBA" if clear else "RGB"), np.uint8)
                scale = 255
    except MapFormatError:
        raise
    except Image.DecompressionBombError as e:  # over twice Pillow's MAX_IMAGE_PIXELS
        held = re.search(r"\((\d+) pixels\)", str(e))
        held = f"{int(held[1]):,} pixels" if held else "too many pixels"
        raise MapFormatError(f"{label}: the image holds {held}, more than Pillow decodes "
                             "(its guard against decompression bombs): save the map as a "
                             "smaller image") from None
    except (OSError, UnidentifiedImageError, ValueError, SyntaxError) as e:
        first = str(e).splitlines()[0] if str(e) else type(e).__name__
        first = re.sub(r"cannot identify image file <_io\.BytesIO object at 0x[0-9a-f]+>",
                       "not an image format Pillow reads", first)
        raise MapFormatError(f"{label}: unreadable image ({first})") from None
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.ndim != 3 or pixels.size == 0 or pixels.shape[2] not in (1, 2, 3, 4):
        raise MapFormatError(f"{label}: unsupported image shape {pixels.shape}")
    return pixels, scale
