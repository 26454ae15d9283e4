"""Tests of jaxga.maps: loaders, scenarios, built-in maps, generators, preprocessing."""

from __future__ import annotations

import heapq
import math
import tempfile
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from jaxga import EndpointError, Grid, MapFormatError, ParameterError
from jaxga.core.errors import JaxgaError
from jaxga.core.grid import CORNER_RULES, move_legal
from jaxga.maps import (
    FORMATS,
    builtin_names,
    builtin_path,
    builtin_scenario_path,
    builtin_scenarios,
    detect_format,
    endpoints_connected,
    fill_enclosed,
    inflate,
    load_map,
    load_map_info,
    map_name,
    maze_map,
    preprocess,
    random_map,
    reachable,
    read_scen,
    rectangles_map,
    rooms_map,
    save_map,
)
from jaxga.maps.preprocess import INFLATE_BAND_CELLS, inflate_blocked

DATA = Path(__file__).parents[1] / "data"
EXT = {"01": "txt", "movingai": "map", "ascii": "ascii", "png": "png", "ros": "yaml"}
FAST = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])

blocked_arrays = hnp.arrays(
    bool, hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=9), elements=st.booleans()
)


def write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def dijkstra(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int], rule: str):
    """Independent 8-connected shortest path length (octile costs) for cross-checks."""
    h, w = blocked.shape

    def free(x, y):
        return 0 <= x < w and 0 <= y < h and not blocked[y, x]

    dist = {start: 0.0}
    heap = [(0.0, start)]
    while heap:
        d, (x, y) = heapq.heappop(heap)
        if (x, y) == goal:
            return d
        if d > dist[(x, y)]:
            continue
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                if (dx or dy) and free(x + dx, y + dy):
                    if dx and dy:
                        s1, s2 = not free(x + dx, y), not free(x, y + dy)
                        if (rule == "strict" and (s1 or s2)) or (
                            rule == "no_squeeze" and s1 and s2
                        ):
                            continue
                    nd = d + (math.sqrt(2) if dx and dy else 1.0)
                    if nd < dist.get((x + dx, y + dy), math.inf):
                        dist[(x + dx, y + dy)] = nd
                        heapq.heappush(heap, (nd, (x + dx, y + dy)))
    return math.inf


# ------------------------------------------------------------------------ round trips
@FAST
@given(blocked=blocked_arrays, fmt=st.sampled_from(FORMATS))
def test_round_trip_every_format(blocked, fmt):
    with tempfile.TemporaryDirectory() as d:
        p = save_map(blocked, Path(d) / f"m.{EXT[fmt]}")
        assert detect_format(p) == fmt
        g = load_map(p)
        np.testing.assert_array_equal(g.blocked_np(), blocked)
        assert g.start_xy == (0, 0) and g.goal_xy == (blocked.shape[1] - 1, blocked.shape[0] - 1)


def test_round_trip_ascii_keeps_endpoints(tmp_path):
    g = random_map(6, 8, 0.3, seed=4, start=(2, 1), goal=(6, 4))
    g2 = load_map(save_map(g, tmp_path / "m.ascii"))
    np.testing.assert_array_equal(g2.blocked_np(), g.blocked_np())
    assert (g2.start_xy, g2.goal_xy) == ((2, 1), (6, 4))


def test_forced_format_and_unknown_format(tmp_path):
    p = write(tmp_path, "m.dat", "..#\n...\n")
    assert load_map(p, fmt="ascii").blocked_np()[1, 2]
    with pytest.raises(MapFormatError, match="unknown map format"):
        load_map(p, fmt="bmp")


# ------------------------------------------------------------------------ orientation
def test_orientation_01_text_first_line_is_bottom(tmp_path):
    g = load_map(write(tmp_path, "m.txt", "1 0 0\n0 0 0\n0 0 0\n0 0 0\n"))
    b = g.blocked_np()
    assert b.shape == (4, 3) and b[0, 0] and b.sum() == 1


def test_orientation_01_without_separators_and_commas(tmp_path):
    a = load_map(write(tmp_path, "a.txt", "010\n001\n")).blocked_np()
    b = load_map(write(tmp_path, "b.txt", "0 1 0\n0 0 1\n")).blocked_np()
    c = load_map(write(tmp_path, "c.txt", "0,1,0\n0,0,1\n")).blocked_np()
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    assert a[0, 1] and a[1, 2]


@pytest.mark.parametrize("fmt", ["01", "ascii", "movingai"])
def test_a_byte_order_mark_is_ignored_in_every_text_format(tmp_path, fmt):
    """Editors on Windows save UTF-8 with a BOM: the format is still detected from the
    first line (no extension decides here) and the map is the same."""
    text = {"01": "0 0 1\n0 1 0\n",
            "ascii": "..#\n.#.\n",
            "movingai": "type octile\nheight 2\nwidth 3\nmap\n..@\n.@.\n"}[fmt]
    plain = tmp_path / "plain.txt"
    plain.write_bytes(text.encode())
    bom = tmp_path / "bom.txt"
    bom.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert detect_format(bom) == detect_format(plain) == fmt
    np.testing.assert_array_equal(load_map(bom).blocked_np(), load_map(plain).blocked_np())


@pytest.mark.parametrize("make", ["random_map", "maze_map", "rooms_map", "rectangles_map"])
def test_generators_refuse_huge_maps_at_once(make):
    """100,000 x 100,000 would take hours of Python flood fills or exhaust memory."""
    import jaxga.maps as maps

    with pytest.raises(ParameterError, match="larger than the generators' limit"):
        extra = {"random_map": {"density": 0.2}, "rectangles_map": {"n_rects": 3}}.get(make, {})
        getattr(maps, make)(100_000, 100_000, seed=1, **extra)


def test_orientation_movingai_first_row_is_top(tmp_path):
    text = "type octile\nheight 4\nwidth 3\nmap\n@..\n...\n...\n...\n"
    b = load_map(write(tmp_path, "m.map", text)).blocked_np()
    assert b.shape == (4, 3) and b[3, 0] and b.sum() == 1


def test_movingai_characters(tmp_path):
    text = "type octile\nheight 1\nwidth 7\nmap\n.GS@OTW\n"
    b = load_map(write(tmp_path, "m.map", text)).blocked_np()
    assert b.tolist() == [[False, False, False, True, True, True, True]]


def test_orientation_ascii_first_line_is_top(tmp_path):
    b = load_map(write(tmp_path, "m.txt", "#..\n...\n...\n...\n")).blocked_np()
    assert b.shape == (4, 3) and b[3, 0] and b.sum() == 1
    assert load_map(write(tmp_path, "n.txt", "@..\n...\n")).blocked_np()[1, 0]


def test_ascii_markers_and_overrides(tmp_path):
    p = write(tmp_path, "m.txt", "..G\n.#.\nS..\n")
    g = load_map(p)
    assert g.start_xy == (0, 0) and g.goal_xy == (2, 2) and g.blocked_np()[1, 1]
    p = write(tmp_path, "n.txt", "S..\n.#G\n...\n")
    g = load_map(p)
    assert g.start_xy == (0, 2) and g.goal_xy == (2, 1)
    g = load_map(p, start=(1, 0), goal=(0, 0), corner_rule="free")
    assert (g.start_xy, g.goal_xy, g.corner_rule) == ((1, 0), (0, 0), "free")
    only_s = load_map(write(tmp_path, "o.txt", "...\n.S.\n"))
    assert only_s.start_xy == (1, 0) and only_s.goal_xy == (2, 1)


def _write_png(path: Path, pixels: np.ndarray, mode: str) -> None:
    from PIL import Image

    Image.fromarray(pixels, mode=mode).save(path)


@pytest.mark.parametrize("mode", ["L", "RGB", "RGBA", "LA"])
def test_orientation_png_top_row_is_top(tmp_path, mode):
    h, w = 4, 3
    grey = np.full((h, w), 255, np.uint8)
    grey[0, 0] = 0  # image top-left pixel dark
    grey[2, 1] = 100  # dark enough (100/255 < 0.5)
    grey[3, 2] = 200  # light
    if mode == "L":
        px = grey
    elif mode == "LA":
        px = np.stack([grey, np.full_like(grey, 255)], -1)
        px[1, 2] = (0, 0)  # transparent black -> free
    else:
        px = np.repeat(grey[..., None], 3, -1)
        if mode == "RGBA":
            px = np.concatenate([px, np.full((h, w, 1), 255, np.uint8)], -1)
            px[1, 2] = (0, 0, 0, 0)  # transparent black -> free
    _write_png(tmp_path / "m.png", px, mode)
    b = load_map(tmp_path / "m.png").blocked_np()
    expected = np.zeros((h, w), bool)
    expected[h - 1, 0] = True
    expected[h - 1 - 2, 1] = True
    np.testing.assert_array_equal(b, expected)


def test_png_detected_by_content(tmp_path):
    p = save_map(np.eye(3, dtype=bool), tmp_path / "m.png")
    q = tmp_path / "no_extension"
    q.write_bytes(p.read_bytes())
    np.testing.assert_array_equal(load_map(q).blocked_np(), np.eye(3, dtype=bool))


@pytest.mark.parametrize("name, fmt", [("m.webp", "WEBP"), ("no_extension", "BMP"),
                                       ("no_extension", "GIF"), ("m.pnm", "PPM")])
def test_an_image_is_known_by_its_extension_or_its_signature(tmp_path, name, fmt):
    """A WebP map, and a BMP or GIF without an extension, load as images (they were read
    as text maps and refused: "not a text map file")."""
    from PIL import Image

    blocked = np.eye(5, dtype=bool)
    pixels = np.where(blocked[::-1], 0, 255).astype(np.uint8)
    image = Image.fromarray(pixels)
    image = image.convert("RGB") if fmt == "PPM" else image
    image.save(tmp_path / name, format=fmt, **({"lossless": True} if fmt == "WEBP" else {}))
    np.testing.assert_array_equal(load_map(tmp_path / name).blocked_np(), blocked)


# -------------------------------------------------------------------------- malformed
MALFORMED = [
    ("ragged.txt", "0 1 0\n0 1\n", "line 2: row has 2 cells"),
    ("ragged2.txt", "010\n01\n", "ragged"),
    ("token.txt", "0 1 2\n0 0 0\n", "line 1, cell 3: expected 0 or 1, got '2'"),
    ("char.txt", "010\n0x0\n", "line 2, column 2: expected 0 or 1"),
    ("blank.txt", "010\n\n010\n", "line 2: blank line"),
    ("empty.txt", "", "empty"),
    ("spaces.txt", "  \n\n", "empty"),
    ("ascii_char.txt", "..#\n.x.\n", "line 2, column 2: unknown map character 'x'"),
    ("ascii_ragged.txt", "...\n..\n", "ragged"),
    ("two_s.txt", "S..\n..S\n", "second 'S' marker"),
    ("two_g.txt", "G.G\n...\n", "second 'G' marker"),
    ("bad_header.map", "type octile\nheigth 2\nwidth 2\nmap\n..\n..\n", "unexpected header"),
    ("bad_type.map", "type hex\nheight 1\nwidth 1\nmap\n.\n", "unsupported map type 'hex'"),
    ("no_map_line.map", "type octile\nheight 1\nwidth 1\n.\n", "unexpected header"),
    ("missing_width.map", "type octile\nheight 1\nmap\n.\n", "missing width"),
    ("bad_height.map", "type octile\nheight x\nwidth 1\nmap\n.\n", "height must be a positive"),
    ("zero_height.map", "type octile\nheight 0\nwidth 1\nmap\n", "height must be a positive"),
    ("dup.map", "type octile\nheight 1\nheight 1\nwidth 1\nmap\n.\n", "duplicate header"),
    ("short.map", "type octile\nheight 3\nwidth 2\nmap\n..\n..\n", "height 3 but the file has 2"),
    ("long.map", "type octile\nheight 1\nwidth 2\nmap\n..\n..\n", "line 6: header says height 1"),
    ("wide.map", "type octile\nheight 2\nwidth 2\nmap\n...\n..\n", "line 5: row has 3 cells"),
    ("char.map", "type octile\nheight 2\nwidth 2\nmap\n..\n.#\n", "line 6, column 2: unknown"),
    ("header_only.map", "type octile\nheight 2\nwidth 2\n", "missing the 'map' line"),
    ("scen_as_map.txt", "version 1\n", "scenario file, not a map"),
    ("bad.png", "this is not a png", "unreadable image"),
]


@pytest.mark.parametrize("name,text,message", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_files_raise_map_format_error(tmp_path, name, text, message):
    p = write(tmp_path, name, text)
    with pytest.raises(MapFormatError) as info:
        load_map(p)
    msg = str(info.value)
    assert message in msg
    assert name in msg and "\n" not in msg


def test_missing_file_directory_and_binary(tmp_path):
    with pytest.raises(MapFormatError, match=r"nope\.txt: map file not found$"):
        load_map(tmp_path / "nope.txt")
    with pytest.raises(MapFormatError, match="not a built-in map .*den312d"):
        load_map("no_such_map_name")
    with pytest.raises(MapFormatError, match="is a directory"):
        load_map(tmp_path)
    (tmp_path / "bin.txt").write_bytes(b"\xff\xfe\x00\x01garbage")
    with pytest.raises(MapFormatError, match="bin.txt: not a text map file"):
        load_map(tmp_path / "bin.txt")
    with pytest.raises(MapFormatError, match="file path or a built-in map name"):
        load_map(42)  # type: ignore[arg-type]


def test_endpoint_off_map_is_endpoint_error_naming_file(tmp_path):
    p = write(tmp_path, "m.txt", "000\n000\n")
    with pytest.raises(EndpointError, match=r"m\.txt: goal \(3, 0\) is off the 3 x 2 map"):
        load_map(p, goal=(3, 0))
    # blocked endpoints are NOT checked at load time
    g = load_map(write(tmp_path, "b.txt", "100\n000\n"))
    assert g.blocked_np()[0, 0]
    with pytest.raises(EndpointError):
        g.check_endpoints()


# --------------------------------------------------------- inputs that must match
def _refused_at_once(read, error=MapFormatError, bound_s: float = 5.0) -> str:
    """The one-line message of ``read()``'s refusal, which must come within ``bound_s``."""
    import time

    t0 = time.perf_counter()
    with pytest.raises(error) as info:
        read()
    assert time.perf_counter() - t0 < bound_s
    message = str(info.value)
    assert "\n" not in message
    return message


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="needs FIFOs")
def test_a_fifo_or_a_device_is_refused_at_once_not_read(tmp_path):
    """A FIFO with no writer would block an open or a read for ever, /dev/zero never
    ends: each is refused at once, in one line naming the file and the cap."""
    import os

    from jaxga.maps.inputs import SCENARIO_CAP, map_file_cap

    fifo = tmp_path / "pipe.map"
    os.mkfifo(fifo)
    message = _refused_at_once(lambda: load_map(fifo))
    assert "pipe.map: is a FIFO" in message and "not a regular file" in message
    assert f"{map_file_cap():,} bytes" in message
    scen = tmp_path / "pipe.scen"
    os.mkfifo(scen)
    message = _refused_at_once(lambda: read_scen(scen))
    assert "pipe.scen: is a FIFO" in message and f"{SCENARIO_CAP:,} bytes" in message
    if Path("/dev/zero").exists():
        message = _refused_at_once(lambda: load_map("/dev/zero"))
        assert "/dev/zero: is a character device, not a regular file" in message
        message = _refused_at_once(lambda: read_scen("/dev/zero"))
        assert "/dev/zero: is a character device" in message


def test_a_file_over_the_cap_is_refused_from_its_size(tmp_path):
    """A 10 GB (sparse) map file is refused from its size before a byte is read; the cap
    grows with the coarsening a larger map needs (K x K times the cells)."""
    from jaxga.core.grid import MAX_MAP_CELLS
    from jaxga.maps.inputs import MAP_BYTES_PER_CELL, map_file_cap

    huge = tmp_path / "huge.txt"
    with open(huge, "wb") as f:
        f.truncate(10 * 10**9)
    message = _refused_at_once(lambda: load_map(huge), bound_s=1.0)
    assert "huge.txt: the file holds 10,000,000,000 bytes" in message
    assert f"more than the {map_file_cap():,} bytes jaxga reads from a map file" in message
    assert f"{MAX_MAP_CELLS:,} cells" in message and "--coarsen K" in message
    assert map_file_cap(2) - map_file_cap(1) == 3 * MAP_BYTES_PER_CELL * MAX_MAP_CELLS
    just_over = tmp_path / "over.txt"
    with open(just_over, "wb") as f:
        f.truncate(map_file_cap() + 1)
    with pytest.raises(MapFormatError, match="bytes jaxga reads from a map file"):
        load_map(just_over)
    with pytest.raises(MapFormatError) as info:  # read, then refused for what it holds
        load_map(just_over, coarsen=2)
    assert "bytes jaxga reads" not in str(info.value)
    scen = tmp_path / "huge.scen"
    with open(scen, "wb") as f:
        f.truncate(10 * 10**9)
    assert "huge.scen: the file holds 10,000,000,000 bytes" in _refused_at_once(
        lambda: read_scen(scen), bound_s=1.0)


def _png_chunks(raw: bytes) -> list[tuple[bytes, bytes]]:
    out, pos = [], 8
    while pos < len(raw):
        n = int.from_bytes(raw[pos:pos + 4], "big")
        out.append((raw[pos + 4:pos + 8], raw[pos + 8:pos + 8 + n]))
        pos += 12 + n
    return out


def _png(chunks: list[tuple[bytes, bytes]]) -> bytes:
    import struct
    import zlib

    return b"\x89PNG\r\n\x1a\n" + b"".join(
        struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
        for t, d in chunks)


def test_a_png_whose_data_does_not_match_its_header_is_refused(tmp_path):
    """A PNG cut short, and one whose image data holds more rows than its header says,
    are refused naming both sizes; the intact file loads."""
    import zlib

    b = np.zeros((6, 8), bool)
    b[2, 3] = True
    good = save_map(b, tmp_path / "good.png")
    raw = good.read_bytes()
    np.testing.assert_array_equal(load_map(good).blocked_np(), b)
    cut = tmp_path / "cut.png"
    cut.write_bytes(raw[: len(raw) * 2 // 3])
    message = _refused_at_once(lambda: load_map(cut))
    assert "cut.png: the PNG header says 8 x 6 pixels" in message and "holds" in message
    # the same pixels under a header that says 3 rows instead of 6: twice the data
    chunks = _png_chunks(raw)
    ihdr = chunks[0][1]
    data = zlib.decompress(b"".join(d for t, d in chunks if t == b"IDAT"))
    per_row = len(data) // 6
    short = [(b"IHDR", ihdr[:4] + (3).to_bytes(4, "big") + ihdr[8:]),
             (b"IDAT", zlib.compress(data)), (b"IEND", b"")]
    (tmp_path / "rows.png").write_bytes(_png(short))
    message = _refused_at_once(lambda: load_map(tmp_path / "rows.png"))
    assert (f"the PNG header says 8 x 3 pixels ({3 * per_row:,} bytes of pixel data) but the "
            f"file holds {6 * per_row:,} bytes of pixel data") in message


@pytest.mark.parametrize("name, text, option, words", [
    ("m.txt", "0 0\n0 0\n", {"threshold": 0.5}, "has no effect on a 0/1 text map"),
    ("m.map", "type octile\nheight 1\nwidth 2\nmap\n..\n", {"threshold": 0.3},
     "has no effect on a Moving AI map"),
    ("m.ascii", "S.\n.G\n", {"threshold": 0.9}, "has no effect on an ASCII-art map"),
    ("m.txt", "0 0\n0 0\n", {"unknown": "blocked"}, "unknown cells (--unknown, unknown=)"),
    ("m.map", "type octile\nheight 1\nwidth 2\nmap\n..\n", {"unknown": "free"},
     "only a ROS map_server map (.yaml) has unknown cells"),
    ("m.txt", "0 0\n0 0\n", {"robot_radius": 0.2}, "a robot radius in metres needs a map "
     "with a resolution"),
    ("m.txt", "0 0\n0 0\n", {"goal_world": (1.0, 1.0)}, "a goal in metres needs a map with a "
     "resolution and an origin"),
])
def test_an_option_with_no_effect_on_the_format_is_refused(tmp_path, name, text, option,
                                                          words):
    """Given explicitly (even at its default value), an option the format ignores is
    refused in one line naming the file and saying why, rather than ignored."""
    p = write(tmp_path, name, text)
    message = _refused_at_once(lambda: load_map(p, **option), error=JaxgaError)
    assert name in message and words in message
    load_map(p)  # without it the map loads


def test_image_options_apply_to_images_only(tmp_path):
    """An image takes a threshold (its default 0.5 when none is given) but not the ROS
    settings: unknown cells, a radius in metres, endpoints in metres."""
    b = np.zeros((4, 4), bool)
    b[1, 1] = True
    png = save_map(b, tmp_path / "m.png")
    np.testing.assert_array_equal(load_map(png).blocked_np(), b)
    np.testing.assert_array_equal(load_map(png, threshold=0.5).blocked_np(), b)
    for option, words in (({"unknown": "free"}, "has no effect on an image"),
                          ({"robot_radius": 0.1}, "an image has none"),
                          ({"start_world": (0.0, 0.0)}, "an image has neither")):
        message = _refused_at_once(lambda o=option: load_map(png, **o), error=JaxgaError)
        assert "m.png" in message and words in message


def test_a_scenario_names_its_map(tmp_path):
    """A problem is for the map its line names: the file name without folders and
    extension, so a built-in map's name or a copy elsewhere matches and another map of
    the same size does not; apply(grid, map_file=) refuses the other map."""
    from jaxga.maps import Scenario

    problem = Scenario(0, "maps/dao/maze-32-32-2.map", 32, 32, (1, 1), (2, 2), 1.4)
    for same in ("maze-32-32-2", "/x/maze-32-32-2.map", Path("y/MAZE-32-32-2.png"),
                 "maps\\dao\\maze-32-32-2.map"):
        assert problem.is_for(same), same
    for other in ("random-32-32-20", "/x/maze-32-32-20.map", "maze.map"):
        assert not problem.is_for(other), other
    grid = load_map("random-32-32-20")
    assert problem.apply(grid).start_xy == (1, 1)  # without the map's name: sizes only
    assert problem.apply(grid, map_file="maze-32-32-2").goal_xy == (2, 2)
    with pytest.raises(MapFormatError, match="scenario for maps/dao/maze-32-32-2.map is not "
                                             "for map random-32-32-20"):
        problem.apply(grid, map_file="random-32-32-20")


# -------------------------------------------------------------------------- scenarios
def test_read_scen_converts_y_on_tiny_file(tmp_path):
    p = write(
        tmp_path,
        "t.scen",
        "version 1\n0\tt.map\t3\t4\t0\t0\t2\t3\t3.5\n1\tt.map\t3\t4\t1\t2\t1\t1\t1\n",
    )
    sc = read_scen(p)
    assert len(sc) == 2
    assert sc[0].start == (0, 3) and sc[0].goal == (2, 0)
    assert sc[1].start == (1, 1) and sc[1].goal == (1, 2)
    assert (sc[0].bucket, sc[0].map_name, sc[0].width, sc[0].height) == (0, "t.map", 3, 4)
    assert sc[0].optimal_length == 3.5
    with pytest.raises(AttributeError):
        sc[0].bucket = 3  # type: ignore[misc]  # frozen


def test_read_scen_maze_copy_endpoints_free_and_lengths_match():
    grid = load_map(DATA / "maze-32-32-2.map")
    b = grid.blocked_np()
    scen = read_scen(DATA / "maze-32-32-2-random-1.scen")
    assert len(scen) == 333
    for s in scen:
        assert (s.width, s.height) == (32, 32) and s.map_name == "maze-32-32-2.map"
        assert not b[s.start[1], s.start[0]], s
        assert not b[s.goal[1], s.goal[0]], s
    # the test has teeth: without the y conversion many endpoints would be walls
    assert any(b[31 - s.start[1], s.start[0]] for s in scen)
    for s in scen[:25]:
        g = s.apply(grid)
        assert g.start_xy == s.start and g.goal_xy == s.goal
        assert dijkstra(b, s.start, s.goal, "strict") == pytest.approx(s.optimal_length, abs=1e-3)


SCEN_BAD = [
    ("", "empty"),
    ("1\tm.map\t3\t3\t0\t0\t1\t1\t1\n", "expected the header 'version 1'"),
    ("version 2\n", "expected the header 'version 1'"),
    ("version 1\n1\tm.map\t3\t3\t0\t0\t1\n", "line 2: expected 9 tab-separated fields, got 7"),
    ("version 1\n1\tm.map\t3\t3\ta\t0\t1\t1\t1\n", "line 2: non-numeric"),
    ("version 1\n1\tm.map\t3\t3\t0\t3\t1\t1\t1\n", "line 2: start (0, 3) is off the 3 x 3 map"),
    ("version 1\n1\tm.map\t3\t3\t0\t0\t-1\t1\t1\n", "goal (-1, 1) is off"),
    ("version 1\n1\tm.map\t0\t3\t0\t0\t0\t0\t1\n", "not positive"),
    ("version 1\n1\tm.map\t3\t3\t0\t0\t1\t1\tnan\n", "bad optimal length"),
]


@pytest.mark.parametrize("text,message", SCEN_BAD)
def test_malformed_scen(tmp_path, text, message):
    p = write(tmp_path, "bad.scen", text)
    with pytest.raises(MapFormatError) as info:
        read_scen(p)
    assert message in str(info.value) and "bad.scen" in str(info.value)


def test_scen_missing_and_version_variants(tmp_path):
    with pytest.raises(MapFormatError, match="scenario file not found"):
        read_scen(tmp_path / "x.scen")
    p = write(tmp_path, "v.scen", "version 1.0\n2 m.map 3 3 0 0 1 1 1.41\n")  # spaces tolerated
    assert read_scen(p)[0].goal == (1, 1)
    assert read_scen(write(tmp_path, "e.scen", "version 1\n")) == []
    grid = Grid.create(np.zeros((2, 2), bool))
    with pytest.raises(MapFormatError, match="3 x 3 but the grid is 2 x 2"):
        read_scen(p)[0].apply(grid)


# ---------------------------------------------------------------------------- builtin
CLASSIC = [
    "aco_classic_20x20_v1_lihongxin",
    "acoga_skolayat_G_20x20",
    "classic_ga_gapp3_20x20",
    "fealpy_grid0_20x20",
    "routeplanning_yangbo_20x20",
    "routeplanning_zhangzheng_paper_20x20",
]
MOVINGAI = {  # name -> (H, W)
    "random-32-32-20": (32, 32),
    "maze-32-32-2": (32, 32),
    "room-32-32-4": (32, 32),
    "den312d": (81, 65),
}


def test_builtin_listing_and_loading():
    names = builtin_names()
    assert names == sorted(names) and set(names) == set(CLASSIC) | set(MOVINGAI)
    for n in CLASSIC:
        info = load_map_info(n)
        assert info.builtin and info.name == n and info.format == "01"
        g = info.grid
        assert g.shape == (20, 20) and g.start_xy == (0, 0) and g.goal_xy == (19, 19)
        assert g.corner_rule == "free"  # the papers' convention on their classic maps
        g.check_endpoints()
        assert map_name(n) == n
        with pytest.raises(MapFormatError, match="no scenario file"):
            builtin_scenarios(n)
        assert builtin_scenario_path(n) is None
    for n, shape in MOVINGAI.items():
        g = load_map(n)
        assert g.shape == shape and load_map_info(n).format == "movingai"
        scen = builtin_scenarios(n)
        b = g.blocked_np()
        assert scen and all(not b[s.start[1], s.start[0]] for s in scen)
        assert all(not b[s.goal[1], s.goal[0]] for s in scen)
    assert builtin_path("den312d").name == "den312d.map"
    with pytest.raises(MapFormatError, match="unknown built-in map 'nope'.*maze-32-32-2"):
        builtin_path("nope")
    with pytest.raises(MapFormatError, match="unknown built-in map"):
        builtin_scenarios("nope")
    assert (Path(builtin_path("den312d")).parent / "SOURCES.md").exists()


@pytest.mark.parametrize(
    "name,free,strict",
    [
        ("classic_ga_gapp3_20x20", 30.9706, 31.5563),
        ("routeplanning_yangbo_20x20", 30.3848, 32.7279),
    ],
)
def test_classic_orientation_matches_reference_optima(name, free, strict):
    b = load_map(name).blocked_np()
    assert dijkstra(b, (0, 0), (19, 19), "free") == pytest.approx(free, abs=1e-3)
    assert dijkstra(b, (0, 0), (19, 19), "strict") == pytest.approx(strict, abs=1e-3)


def test_map_name_of_paths_and_builtin_over_cwd(tmp_path, monkeypatch):
    assert map_name("maps/arena.map") == "arena"
    assert map_name(Path("/x/y/z.png")) == "z"
    monkeypatch.chdir(tmp_path)
    (tmp_path / "den312d").write_text("000\n")
    assert load_map("den312d").shape == (81, 65)  # a built-in name wins over a file
    assert load_map("./den312d").shape == (1, 3)
    assert load_map(Path("den312d")).shape == (1, 3)  # a Path is always a file



def test_load_map_info_takes_load_maps_options(tmp_path):
    """One list of options: load_map_info reads a map as load_map does, with the same
    options, and refuses an option load_map does not have."""
    from jaxga.maps import load_map_info

    (tmp_path / "m.txt").write_text("S..\n.#.\n..G\n")
    for options in ({}, {"start": (0, 1), "corner_rule": "free"}, {"coarsen": 1}):
        info = load_map_info(tmp_path / "m.txt", **options)
        grid = load_map(tmp_path / "m.txt", **options)
        assert (info.grid.start_xy, info.grid.goal_xy, info.grid.corner_rule) == \
            (grid.start_xy, grid.goal_xy, grid.corner_rule)
        np.testing.assert_array_equal(info.grid.blocked_np(), grid.blocked_np())
        assert info.format == "ascii" and info.name == "m"
    with pytest.raises(TypeError, match="load_map_info.*colour"):
        load_map_info(tmp_path / "m.txt", colour="red")
    with pytest.raises(MapFormatError, match="threshold"):  # no effect on an ASCII map
        load_map_info(tmp_path / "m.txt", threshold=0.3)

# ------------------------------------------------------------------------- generators
def _check_generated(g: Grid, h: int, w: int) -> None:
    assert g.shape == (h, w)
    g.check_endpoints()
    assert endpoints_connected(g)
    gx, gy = g.goal_xy
    assert dijkstra(g.blocked_np(), g.start_xy, g.goal_xy, g.corner_rule) < math.inf
    assert reachable(g)[gy, gx]


@FAST
@given(
    seed=st.integers(0, 2**31 - 1),
    h=st.integers(2, 14),
    w=st.integers(2, 14),
    density=st.floats(0.0, 0.45),
    rule=st.sampled_from(CORNER_RULES),
)
def test_random_map_free_connected_endpoints(seed, h, w, density, rule):
    g = random_map(h, w, density, seed, corner_rule=rule)
    _check_generated(g, h, w)
    assert g.corner_rule == rule
    assert int(g.blocked_np().sum()) == min(round(density * h * w), h * w - 2)


@FAST
@given(
    seed=st.integers(0, 2**31 - 1),
    h=st.integers(1, 20),
    w=st.integers(1, 20),
    kind=st.sampled_from(["maze", "maze2", "rooms", "rects"]),
    rule=st.sampled_from(CORNER_RULES),
    data=st.data(),
)
def test_structured_generators_free_connected_endpoints(seed, h, w, kind, rule, data):
    start = data.draw(st.tuples(st.integers(0, w - 1), st.integers(0, h - 1)))
    goal = data.draw(st.tuples(st.integers(0, w - 1), st.integers(0, h - 1)))
    kw = dict(start=start, goal=goal, corner_rule=rule)
    if kind == "maze":
        g = maze_map(h, w, seed, **kw)
    elif kind == "maze2":
        g = maze_map(h, w, seed, corridor_width=2, wall_width=2, **kw)
    elif kind == "rooms":
        g = rooms_map(h, w, seed, room_size=3, door_width=2, **kw)
    else:
        n = 3 if min(h, w) >= 5 else 0  # tiny maps may have no room for a rectangle
        g = rectangles_map(h, w, n, seed, max_size=2, **kw)
    assert g.start_xy == start and g.goal_xy == goal
    _check_generated(g, h, w)


def test_generators_are_deterministic_and_seed_dependent():
    makers = [
        lambda s: random_map(16, 16, 0.3, s),
        lambda s: maze_map(16, 16, s),
        lambda s: rooms_map(16, 16, s, room_size=3),
        lambda s: rectangles_map(16, 16, 6, s),
    ]
    for make in makers:
        a, b, c = make(7).blocked_np(), make(7).blocked_np(), make(8).blocked_np()
        np.testing.assert_array_equal(a, b)
        assert not np.array_equal(a, c)


def test_maze_is_a_maze():
    g = maze_map(21, 21, 3)
    b = g.blocked_np()
    assert b[1::2, 1::2].all()  # wall posts between lattice cells
    assert not b[::2, ::2].any()  # lattice cells are open
    # a perfect maze on an 11 x 11 lattice opens exactly 120 walls
    assert int((~b).sum()) == 11 * 11 + 120


def test_generator_errors():
    with pytest.raises(ParameterError, match="lower the density"):
        random_map(6, 6, 0.95, 0, max_attempts=3)
    with pytest.raises(ParameterError, match="density must be in"):
        random_map(6, 6, 1.0, 0)
    with pytest.raises(ParameterError, match="height must be >= 1"):
        maze_map(0, 5, 0)
    with pytest.raises(ParameterError, match="seed must be an integer"):
        rooms_map(5, 5, 1.5)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="rectangles"):
        rectangles_map(4, 4, 50, 0, min_size=3, max_size=3, max_attempts=30)
    with pytest.raises(EndpointError, match="off the 5 x 5 map"):
        maze_map(5, 5, 0, goal=(5, 0))


# ---------------------------------------------------------------------- reachability
@settings(max_examples=20, deadline=None)
@given(blocked=hnp.arrays(bool, (4, 5), elements=st.booleans()), rule=st.sampled_from(CORNER_RULES))
def test_reachable_matches_move_legal_closure(blocked, rule):
    # one fixed shape: move_legal runs eagerly in JAX, and every new shape recompiles
    h, w = blocked.shape
    blocked = blocked.copy()
    blocked[0, 0] = False
    g = Grid.create(blocked, corner_rule=rule)
    n = h * w
    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    adj = np.asarray(move_legal(g, a, b))
    seen = {0}
    frontier = [0]
    while frontier:
        frontier = [q for p in frontier for q in np.flatnonzero(adj[p]) if q not in seen]
        seen.update(frontier)
    expected = np.zeros(n, bool)
    expected[list(seen)] = True
    np.testing.assert_array_equal(reachable(g), expected.reshape(h, w))


def test_reachable_blocked_source_and_corner_rules():
    b = np.array([[0, 1], [1, 0]], bool)  # two free cells touching diagonally
    for rule, ok in (("free", True), ("no_squeeze", False), ("strict", False)):
        assert endpoints_connected(Grid.create(b, corner_rule=rule)) is ok
    g = Grid.create(np.array([[1, 0]], bool))
    assert not reachable(g).any()
    assert reachable(g, source=(1, 0)).tolist() == [[False, True]]
    with pytest.raises(ParameterError):
        reachable(g, source=(2, 0))


# ----------------------------------------------------------------------- preprocessing
def test_inflate_hand_made():
    b = np.zeros((7, 7), bool)
    b[3, 3] = True
    g = Grid.create(b, start=(0, 0), goal=(6, 6), corner_rule="free")
    plus = inflate(g, 1).blocked_np()
    assert plus.sum() == 5 and plus[3, 2:5].all() and plus[2:5, 3].all()
    square = inflate(g, 1.5).blocked_np()
    np.testing.assert_array_equal(square, np.pad(np.ones((3, 3), bool), 2))
    r2 = inflate(g, 2).blocked_np()
    assert r2.sum() == 13 and r2[3, 1] and not r2[2, 1]
    out = inflate(g, 2)
    assert (out.start_xy, out.goal_xy, out.corner_rule) == ((0, 0), (6, 6), "free")
    np.testing.assert_array_equal(inflate(g, 0).blocked_np(), b)
    np.testing.assert_array_equal(g.blocked_np(), b)  # pure
    assert inflate(g, 100).blocked_np().all()
    for bad in (-1, -0.5, float("nan"), float("inf"), "1", None, True):
        with pytest.raises(ParameterError, match="radius"):
            inflate(g, bad)  # type: ignore[arg-type]


@FAST
@given(blocked=blocked_arrays, radius=st.floats(0, 12) | st.sampled_from([1 - 1e-10, 2**0.5]),
       band=st.sampled_from([1, 7, 64, INFLATE_BAND_CELLS]))
def test_inflate_matches_brute_force(blocked, radius, band):
    """Every cell within the radius of a blocked cell's centre, whatever the bands the
    distance transform is taken in (a band of 1 cell: one row and its halo)."""
    g = Grid.create(blocked)
    h, w = blocked.shape
    ys, xs = np.nonzero(blocked)
    yy, xx = np.mgrid[0:h, 0:w]
    expected = np.zeros_like(blocked)
    for y, x in zip(ys, xs, strict=True):
        expected |= (yy - y) ** 2 + (xx - x) ** 2 <= radius**2 + 1e-9
    np.testing.assert_array_equal(inflate_blocked(blocked, radius, band_cells=band), expected)
    if band == INFLATE_BAND_CELLS:
        np.testing.assert_array_equal(inflate(g, radius).blocked_np(), expected)


def test_inflate_by_a_large_radius_on_a_large_map():
    """A radius of 300 cells on a 1000 x 1000 map: one obstacle grows into the disc of
    cells within 300 of it (its pixel count), clipped by the map's edge."""
    b = np.zeros((1000, 1000), bool)
    b[100, 700] = True
    out = inflate_blocked(b, 300)
    yy, xx = np.mgrid[0:1000, 0:1000]
    np.testing.assert_array_equal(out, (yy - 100) ** 2 + (xx - 700) ** 2 <= 300**2)


def test_fill_enclosed_hand_made():
    b = np.array(
        [
            [0, 1, 0, 0, 0],
            [1, 1, 1, 1, 1],
            [1, 0, 1, 0, 1],
            [1, 1, 1, 1, 0],
        ],
        bool,
    )
    g = Grid.create(b, start=(4, 0), goal=(4, 0))
    out = fill_enclosed(g).blocked_np()
    expected = b.copy()
    expected[0, 0] = True  # corner cell: 3 on-map neighbours all blocked, off-map = blocked
    expected[2, 1] = True  # fully enclosed
    # (3, 2) has the free diagonal neighbour (4, 3); (2..4, 0) are free
    np.testing.assert_array_equal(out, expected)
    np.testing.assert_array_equal(g.blocked_np(), b)  # pure
    np.testing.assert_array_equal(fill_enclosed(fill_enclosed(g)).blocked_np(), out)
    assert fill_enclosed(Grid.create(np.zeros((1, 1), bool))).blocked_np().all()
    assert not fill_enclosed(Grid.create(np.zeros((3, 3), bool))).blocked_np().any()


def test_preprocess_combines_inflate_and_fill():
    b = np.pad(np.zeros((3, 3), bool), 1, constant_values=True)  # a walled 5 x 5 room
    g = Grid.create(b, start=(2, 2), goal=(2, 2))
    inflated = inflate(g, 1).blocked_np()
    assert inflated.sum() == 24 and not inflated[2, 2]  # the centre is 2 cells from any wall
    assert preprocess(g, radius=1).blocked_np().all()  # ... and then enclosed
    np.testing.assert_array_equal(preprocess(g, 1, fill=False).blocked_np(), inflated)
    np.testing.assert_array_equal(preprocess(g).blocked_np(), b)


@pytest.mark.parametrize("start", [(1.5, 0), "30", (True, False), (1, 2, 3), (1,)])
def test_endpoints_must_be_integer_pairs(start):
    """Not truncated (1.5 -> 1), split ("30" -> (3, 0)) or read as 0/1 (True)."""
    with pytest.raises(EndpointError, match="must be a pair of integers"):
        Grid.create(np.zeros((4, 4), bool), start=start)


def test_endpoints_accept_numpy_and_jax_integers():
    g = Grid.create(np.zeros((4, 4), bool), start=(np.int64(1), jnp.int32(2)), goal=[3, 3])
    assert g.start_xy == (1, 2) and g.goal_xy == (3, 3)


def test_a_ragged_list_is_not_a_grid():
    with pytest.raises(JaxgaError, match="rows of equal length"):
        Grid.create([[0, 0], [0]])


def test_generated_maps_check_endpoints_like_grids():
    with pytest.raises(EndpointError, match="must be a pair of integers"):
        random_map(10, 10, 0.0, 3, start=(1.5, 0.9))


# ------------------------------------------------------------ size limit, coarsening
def test_a_map_over_the_size_limit_is_refused_from_its_header(tmp_path, monkeypatch):
    """Refused before the body is parsed: a Moving AI header of 2000 x 2000 over one
    malformed row, a PNG's IHDR, and a 0/1 file's first line and line count, each with
    one line naming the limit and the way around it (a coarser map)."""
    from jaxga.core.grid import MAX_MAP_CELLS

    monkeypatch.setattr("jaxga.core.grid.physical_memory", lambda: 24 * 2**30)  # CI's
    header = tmp_path / "huge.map"
    header.write_text("type octile\nheight 8000\nwidth 8000\nmap\n@@@\n")
    with pytest.raises(MapFormatError) as e:
        load_map(header)
    text = str(e.value)
    assert "\n" not in text and "8000 x 8000 has 64,000,000 cells" in text
    assert f"{MAX_MAP_CELLS:,}" in text and "--coarsen 4" in text and "coarsen=4" in text
    # the files' own parsers are kept for the limit of a machine with less memory below
    monkeypatch.setattr("jaxga.core.grid.MAX_MAP_CELLS", 512 * 512)
    side = 600
    b = np.random.default_rng(0).random((side, side)) < 0.1
    from jaxga.maps import loaders

    def never(*args, **kwargs):
        raise AssertionError("the file was parsed")

    for ext in ("png", "txt"):
        path = save_map(b, tmp_path / f"big.{ext}")
        with monkeypatch.context() as m:  # refused before any parser runs
            m.setattr(loaders, "parse_png", never)
            m.setattr(loaders, "parse_01", never)
            with pytest.raises(MapFormatError, match=f"map {side} x {side} has 360,000 cells"):
                load_map(path)
        coarse = load_map(path, coarsen=2, start=(3, 5), goal=(599, 598))
        assert coarse.shape == (300, 300)
        assert coarse.start_xy == (1, 2) and coarse.goal_xy == (299, 299)
        np.testing.assert_array_equal(coarse.blocked_np(),
                                      b.reshape(300, 2, 300, 2).any(axis=(1, 3)))
    with pytest.raises(EndpointError, match=r"goal map cell \(600, 0\) is off the 600 x 600 map"):
        load_map(tmp_path / "big.txt", coarsen=2, goal=(600, 0))
    with pytest.raises(JaxgaError, match="more than jaxga plans on"):
        Grid.create(np.zeros((513, 512), bool))
    Grid.create(np.zeros((512, 512), bool))  # the limit itself is accepted


def test_a_map_the_memory_does_not_hold_is_refused_naming_the_memory(monkeypatch):
    """Within the cell limit, a map whose plan would need more than half of the machine's
    memory is refused in one line naming the memory a plan needs and the coarsening that
    fits; on a machine with the memory it is accepted."""
    from jaxga.core import grid as grid_module

    monkeypatch.setattr(grid_module, "physical_memory", lambda: 4 * 2**30)  # 4 GiB
    text = grid_module.too_large(1165, 945)  # 1.1 M cells: 1 GiB + 0.5 GiB
    assert text == ""
    text = grid_module.too_large(2000, 2000)  # 4 M cells: 2.9 GiB > 2 GiB
    assert "\n" not in text and "needs about 2.9 GiB" in text and "4.0 GiB" in text
    assert "--coarsen 2" in text
    monkeypatch.setattr(grid_module, "physical_memory", lambda: 24 * 2**30)
    assert grid_module.too_large(2000, 2000) == ""
    assert grid_module.plan_memory(1165 * 945) < 4 * 10**9  # the 1165 x 945 map's target


def test_a_comma_separated_row_with_an_empty_cell_is_refused(tmp_path):
    """``0,,0,1`` was read as three cells (every row alike: no ragged-row error), shifting
    the map's columns; a trailing comma, as spreadsheets write, ends the row."""
    empty = tmp_path / "empty.txt"
    empty.write_text("0,,0,1\n0,,0,1\n")
    with pytest.raises(MapFormatError, match=r"empty.txt: line 1: an empty cell between "
                       "commas"):
        load_map(empty)
    leading = tmp_path / "leading.txt"
    leading.write_text("0 ,0,1\n0, ,1\n")
    with pytest.raises(MapFormatError, match="line 2: an empty cell"):
        load_map(leading)
    trailing = tmp_path / "trailing.txt"
    trailing.write_text("0,0,0,\n0,1,0,\n")
    np.testing.assert_array_equal(load_map(trailing).blocked_np(),
                                  [[False, False, False], [False, True, False]])  # line 1: y 0


def test_an_image_of_several_frames_is_refused_and_transparency_reads_alike(tmp_path):
    """An animated GIF was read from its first frame alone; a grey PNG's transparent
    colour (tRNS) was dropped where a palette's was kept: now refused, and both read
    transparent pixels as white (free), as documented for alpha channels."""
    from PIL import Image

    b = np.full((6, 8), 255, np.uint8)
    b[1:5, 3] = 0  # a wall
    frames = [Image.fromarray(b), Image.fromarray(255 - b)]
    frames[0].save(tmp_path / "anim.gif", save_all=True, append_images=frames[1:])
    with pytest.raises(MapFormatError, match="the image holds 2 frames"):
        load_map(tmp_path / "anim.gif")
    Image.fromarray(b).save(tmp_path / "plain.png")
    assert load_map(tmp_path / "plain.png").blocked_np().sum() == 4
    Image.fromarray(b).save(tmp_path / "grey.png", transparency=0)
    Image.fromarray(b).convert("P").save(tmp_path / "palette.png", transparency=0)
    Image.fromarray(b).convert("RGB").save(tmp_path / "rgb.png", transparency=(0, 0, 0))
    for name in ("grey", "palette", "rgb"):  # the wall's colour is the transparent one
        assert load_map(tmp_path / f"{name}.png").blocked_np().sum() == 0, name
    Image.fromarray(b).save(tmp_path / "grey_white.png", transparency=255)
    assert load_map(tmp_path / "grey_white.png").blocked_np().sum() == 4  # white stays free
    from PIL.PngImagePlugin import PngInfo

    words = PngInfo()
    words.add_text("Comment", "IDAT tRNS")  # the chunks are walked, not searched as bytes
    Image.fromarray(b).save(tmp_path / "worded.png", transparency=0, pnginfo=words)
    assert load_map(tmp_path / "worded.png").blocked_np().sum() == 0
    Image.fromarray(b).save(tmp_path / "worded_plain.png", pnginfo=words)
    assert load_map(tmp_path / "worded_plain.png").blocked_np().sum() == 4
    frames[0].save(tmp_path / "anim.png", save_all=True, append_images=frames[1:])
    with pytest.raises(MapFormatError, match="the image holds 2 frames"):  # APNG too
        load_map(tmp_path / "anim.png")


def _png16(pixels: np.ndarray, colour_type: int, transparent: tuple[int, ...]) -> bytes:
    """A 16-bit PNG (grey: colour type 0, ``[H, W]``; colour: 2, ``[H, W, 3]``) with a
    transparent colour (``tRNS``), written chunk by chunk: Pillow writes neither."""
    import struct
    import zlib

    h, w = pixels.shape[:2]
    rows = b"".join(b"\0" + row.astype(">u2").tobytes() for row in pixels)
    return _png([(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, colour_type, 0, 0, 0)),
                 (b"tRNS", struct.pack(f">{len(transparent)}H", *transparent)),
                 (b"IDAT", zlib.compress(rows)), (b"IEND", b"")])


def test_a_16_bit_pngs_transparent_colour_is_read_or_refused(tmp_path):
    """A 16-bit grey PNG's transparent colour was dropped (an 8-bit one's is kept): its
    pixels of that value now read as transparent, so free, alone and through a ROS YAML
    (where map_server's trinary mode reads the colour and ignores the alpha). Pillow
    reads a 16-bit colour PNG at 8 bits (and keeps its 16-bit transparent colour, so the
    pixels it names cannot be told): refused in one line (it was read silently opaque),
    as every 16-bit PNG with more than a grey channel is (decision 063)."""
    grey = np.full((6, 8), 65535, np.int64)
    grey[1:5, 3] = 1000  # a dark wall, the transparent colour
    grey[0, 0] = 1001  # as dark, not transparent
    (tmp_path / "wall.png").write_bytes(_png16(grey, 0, (1000,)))
    assert load_map(tmp_path / "wall.png").blocked_np().sum() == 1
    (tmp_path / "white.png").write_bytes(_png16(grey, 0, (65535,)))
    assert load_map(tmp_path / "white.png").blocked_np().sum() == 5  # white stays free
    (tmp_path / "wall.yaml").write_text(
        "image: wall.png\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    assert load_map(tmp_path / "wall.yaml").blocked_np().sum() == 5  # trinary: colour
    (tmp_path / "colour.png").write_bytes(
        _png16(np.repeat(grey[..., None], 3, axis=2), 2, (1000, 1000, 1000)))
    with pytest.raises(MapFormatError, match="a 16-bit colour PNG is read by Pillow at 8") as e:
        load_map(tmp_path / "colour.png")
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("width, height, k", [
    (8000, 8000, 4), (2049, 2048, 2), (123_457, 98_765, 54), (10**7, 3, 3),
    (10**9, 10**9, 488_282), (99_999_999_999_999_999_999, 1, 23_841_857_910_157),
])
def test_the_coarsening_named_is_the_smallest_that_fits(width, height, k, monkeypatch):
    """The factor a refusal names is the smallest that brings the map under the limit
    (exactly: k - 1 does not), found at once for any header: a Moving AI header of
    10**20 x 1 cells counted up from 2, some 10**13 steps (the load hung)."""
    from jaxga.core import grid as grid_module

    monkeypatch.setattr(grid_module, "physical_memory", lambda: 24 * 2**30)  # CI's

    def cells(factor: int) -> int:
        return -(-width // factor) * -(-height // factor)

    text = grid_module.too_large(width, height)
    assert f"--coarsen {k} " in text and "\n" not in text
    assert cells(k) <= grid_module.MAX_MAP_CELLS < cells(k - 1)


def test_a_process_too_small_for_any_plan_judges_maps_by_the_cell_limit(monkeypatch):
    """Under 2 GiB (``ulimit -v``, a container) not even a map of one cell fits the memory
    model, so no coarsening helps: the search for a factor never ended (every map's load
    hung); the cell limit alone now decides."""
    from jaxga.core import grid as grid_module

    monkeypatch.setattr(grid_module, "physical_memory", lambda: int(1.5 * 2**30))
    assert grid_module.too_large(10, 10) == ""
    text = grid_module.too_large(3000, 3000)
    assert "more than jaxga plans on" in text and "--coarsen 2 " in text


def test_a_moving_ai_header_of_a_huge_thin_map_is_refused_at_once(tmp_path):
    header = tmp_path / "thin.map"
    header.write_text("type octile\nheight 1\nwidth 99999999999999999999\nmap\n.\n")
    with pytest.raises(MapFormatError, match="has 99,999,999,999,999,999,999 cells"):
        load_map(header)


@settings(max_examples=40, deadline=None)
@given(hnp.arrays(bool, st.tuples(st.integers(1, 13), st.integers(1, 13))),
       st.integers(1, 5))
def test_coarsen_blocks_a_cell_when_any_of_its_cells_is(blocked, k):
    from jaxga.maps import coarsen_blocked

    got = coarsen_blocked(blocked, k)
    h, w = blocked.shape
    assert got.shape == (-(-h // k), -(-w // k))
    for y in range(got.shape[0]):
        for x in range(got.shape[1]):
            assert got[y, x] == blocked[y * k:(y + 1) * k, x * k:(x + 1) * k].any()


def test_coarsen_a_grid_and_bad_factors():
    from jaxga.maps import coarsen

    b = np.zeros((9, 10), bool)
    b[4, 7] = True
    g = coarsen(Grid.create(b, start=(1, 1), goal=(9, 8), corner_rule="free"), 3)
    assert g.shape == (3, 4) and g.start_xy == (0, 0) and g.goal_xy == (3, 2)
    assert g.corner_rule == "free" and g.blocked_np()[1, 2] and g.blocked_np().sum() == 1
    for bad in (0, -2, 1.5, True):
        with pytest.raises((ParameterError, MapFormatError), match="positive integer"):
            coarsen(g, bad)
        with pytest.raises((ParameterError, MapFormatError), match="positive integer"):
            load_map("classic_ga_gapp3_20x20", coarsen=bad)


def test_one_corner_rule_per_map_everywhere():
    """The papers' classic 20 x 20 maps are planned under their convention (free), every
    other map under strict (no path touches a blocked cell's corner): load_map, the
    optimum and a preset's run by name agree, whichever preset runs."""
    from jaxga.config.presets import load_preset
    from jaxga.maps import default_corner_rule

    assert default_corner_rule("classic_ga_gapp3_20x20") == "free"
    assert default_corner_rule("den312d") == "strict"
    assert default_corner_rule("some/user_map.png") == "strict"
    assert load_map("routeplanning_yangbo_20x20").corner_rule == "free"
    assert load_map("maze-32-32-2").corner_rule == "strict"
    assert load_map("maze-32-32-2", corner_rule="free").corner_rule == "free"
    assert {load_preset(p)["map.corner_rule"] for p in ("sga", "hybrid", "iga_zhu")} == {"map"}


@pytest.mark.parametrize("suffix", ["jpg", "png", "tif"])
def test_an_image_that_asks_to_be_shown_turned_is_refused(tmp_path, suffix):
    """An image with an EXIF orientation (a phone's photo of a floor plan, an editor's
    save) was read as stored while every viewer shows it turned: which is the map? Now
    refused in one line, alone and through a ROS YAML; the upright tag (1) loads."""
    from PIL import Image

    b = np.full((6, 8), 255, np.uint8)
    b[1:5, 3] = 0
    for orientation in (1, 6):
        exif = Image.Exif()
        exif[274] = orientation
        Image.fromarray(b).save(tmp_path / f"m{orientation}.{suffix}", exif=exif.tobytes())
    assert load_map(tmp_path / f"m1.{suffix}").blocked_np().sum() == 4
    (tmp_path / "m6.yaml").write_text(
        f"image: m6.{suffix}\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    for path in (tmp_path / f"m6.{suffix}", tmp_path / "m6.yaml"):
        with pytest.raises(MapFormatError, match=r"shown turned or mirrored \(EXIF "
                                                 r"orientation 6\)") as e:
            load_map(path)
        assert "\n" not in str(e.value)


@pytest.mark.parametrize("bits, wall", [(2, 85), (4, 17), (4, 119)])
def test_a_grey_png_of_2_or_4_bits_reads_its_dark_walls(tmp_path, bits, wall):
    """matplotlib divided Pillow's 8-bit values of a 2- or 4-bit grey PNG by 3 or 15
    again: every wall but pure black read as white, and runs planned through it. Its
    transparent value, given at the image's own depth, is scaled as the pixels are."""
    from PIL import Image

    a = np.full((5, 9), 255, np.uint8)
    a[:, 4] = wall  # a level of the depth, darker than half
    Image.fromarray(a).save(tmp_path / "wall.png", bits=bits)
    assert load_map(tmp_path / "wall.png").blocked_np().sum() == 5
    level = wall * (2 ** bits - 1) // 255
    Image.fromarray(a).save(tmp_path / "clear.png", bits=bits, transparency=level)
    assert load_map(tmp_path / "clear.png").blocked_np().sum() == 0


def test_pillows_decompression_bomb_guard_is_one_line(tmp_path, monkeypatch, recwarn):
    """An image over twice Pillow's MAX_IMAGE_PIXELS (a 20000 x 20000 1-bit BMP of 50 MB)
    was a DecompressionBombError traceback; one over it printed Pillow's warning in two
    lines before jaxga's own size check. Pillow's limit is lowered here to keep the
    images small."""
    from PIL import Image

    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 100)
    Image.fromarray(np.full((20, 20), 255, np.uint8)).save(tmp_path / "big.bmp")
    with pytest.raises(MapFormatError, match="the image holds 400 pixels, more than "
                                             "Pillow decodes") as e:
        load_map(tmp_path / "big.bmp")
    assert "\n" not in str(e.value)
    Image.fromarray(np.full((12, 12), 255, np.uint8)).save(tmp_path / "mid.bmp")
    assert load_map(tmp_path / "mid.bmp").blocked_np().shape == (12, 12)
    assert not [w for w in recwarn if issubclass(w.category, Image.DecompressionBombWarning)]


@pytest.mark.parametrize("name, text, words", [
    ("lab.txt", "S..\u2028...\n..G\n", r"line 1, column 4: unknown map character '\\u2028'"),
    ("room.map", "type octile\nheight 2\nwidth 3\nmap\n.\x0c.\n...\n",
     r"line 5, column 2: unknown map character '\\x0c'"),
    ("grid.txt", "0 1 0\x850 0 0\n0 0 0\n", "ragged rows"),
])
def test_a_line_ends_only_at_a_line_break(tmp_path, name, text, words):
    """str.splitlines also split a row at a vertical tab, a form feed, \\x85 or U+2028: a
    2-line file was read as a 3-row map. Such a character in a row is now what is wrong
    with it."""
    (tmp_path / name).write_text(text, encoding="utf-8")
    with pytest.raises(MapFormatError, match=words):
        load_map(tmp_path / name)


def test_a_masked_array_is_refused_only_where_something_is_masked():
    """A grid given as a masked array lost its mask (the masked cells took their stored
    values), through Grid.create and through a plain Grid(...) checked by a run; one with
    nothing masked (netCDF4's default) is its data."""
    from jaxga.core.errors import JaxgaError

    data = np.zeros((3, 3))
    assert Grid.create(np.ma.masked_array(data, np.zeros((3, 3), bool))).blocked_np().sum() == 0
    masked = np.ma.masked_array(data, np.eye(3, dtype=bool))
    with pytest.raises(JaxgaError, match="a grid cannot be a masked array"):
        Grid.create(masked)
    with pytest.raises(JaxgaError, match="a grid cannot be a masked array"):
        Grid(blocked=masked, start=np.int32(0), goal=np.int32(8)).validated()
