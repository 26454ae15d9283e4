"""ROS map_server maps (YAML + image) as map_saver writes them: cells, resolution, origin,
thresholds, modes, world coordinates and the one-line errors."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

import jaxga
from jaxga import EndpointError, MapFormatError
from jaxga.cli.options import snap_notes
from jaxga.maps import load_map, load_map_info
from jaxga.maps.ros import (
    RosMap,
    cell_to_world,
    occupancy,
    read_ros_image,
    read_ros_yaml,
    world_to_cell,
)

# A 5 x 4 image, top row first, as map_saver writes it: 254 free, 0 occupied, 205 unknown.
IMAGE = np.array([
    [0, 254, 254, 254, 205],
    [254, 254, 0, 254, 205],
    [254, 254, 0, 254, 254],
    [254, 254, 254, 254, 254],
], np.uint8)
ROS1_YAML = """image: {image}
resolution: 0.050000
origin: [-2.000000, -1.500000, 0.000000]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196

"""


def write_pgm(path, pixels: np.ndarray, comment: str = "# CREATOR: map_saver.cpp 0.050 m/pix"):
    """A binary PGM (P5) exactly as ROS 1 map_saver writes one."""
    h, w = pixels.shape
    path.write_bytes(f"P5\n{comment}\n{w} {h}\n255\n".encode() + pixels.tobytes())
    return path


@pytest.fixture
def office(tmp_path):
    write_pgm(tmp_path / "office.pgm", IMAGE)
    (tmp_path / "office.yaml").write_text(ROS1_YAML.format(image="office.pgm"))
    return tmp_path / "office.yaml"


def test_a_map_saver_map_loads_with_its_cells_resolution_and_origin(office):
    info = load_map_info(office)
    assert info.format == "ros" and info.name == "office"
    assert info.resolution == 0.05 and info.ros.origin == (-2.0, -1.5, 0.0)
    blocked = info.grid.blocked_np()
    assert blocked.shape == (4, 5)
    # the image's top row is the map's top row (y = 3); unknown (205) is blocked
    want = np.array([
        [0, 0, 0, 0, 0],
        [0, 0, 1, 0, 0],
        [0, 0, 1, 0, 1],
        [1, 0, 0, 0, 1],
    ], bool)
    np.testing.assert_array_equal(blocked, want)
    free = load_map(office, unknown="free").blocked_np()
    np.testing.assert_array_equal(free, want & ~np.array([[0] * 5, [0] * 5, [0, 0, 0, 0, 1],
                                                           [0, 0, 0, 0, 1]], bool))


def test_thresholds_negate_and_modes_follow_map_server():
    meta = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0))
    shades = np.array([[0, 50, 89, 90, 204, 205, 206, 255]], np.uint8)
    # p = (255 - s) / 255: 0 -> 1.0, 89 -> 0.651 (> 0.65), 90 -> 0.647, 205 -> 0.196 (not <),
    # 206 -> 0.192 (< 0.196)
    assert occupancy(shades, meta).tolist() == [[100, 100, 100, -1, -1, -1, 0, 0]]
    neg = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), negate=True)
    # negate: p = s / 255: 50 -> 0.19608 (not < 0.196), 204 -> 0.8 (> 0.65)
    assert occupancy(shades, neg).tolist() == [[0, -1, -1, -1, 100, 100, 100, 100]]
    scale = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), mode="scale")
    got = occupancy(shades, scale)[0]
    assert got[[0, 1, 2, 6, 7]].tolist() == [100, 100, 100, 0, 0]
    # the band graded as nav2_map_server grades it, rint(100 * ratio): 90 is 0.647, 99 %;
    # map_saver's grey 205 (0.19608, a hair above 0.196) rounds to 0: free, as nav2 has it
    p = (255 - 90) / 255
    assert got[3] == round(100 * (p - 0.196) / (0.65 - 0.196)) == 99 and got[5] == 0
    alpha = np.stack([shades, np.array([[255] * 7 + [0]], np.uint8)], -1)
    assert occupancy(alpha, scale)[0, -1] == -1  # transparent: unknown in scale mode
    raw = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), mode="raw")
    assert occupancy(np.array([[0, 37, 100, 101, 255]], np.uint8), raw).tolist() == [
        [0, 37, 100, -1, -1]]
    rgb = np.repeat(shades[..., None], 3, -1)
    assert occupancy(rgb, meta).tolist() == occupancy(shades, meta).tolist()
    # trinary averages the alpha in with three colour channels (ROS 2's map_io.cpp; ROS 1
    # for colour images): s' = (3 s + alpha) / 4, so transparent white 191.25 (p = 0.25)
    # is unknown (it was read as free), and an opaque 50 is 101.25 (p = 0.603): unknown,
    # as map_server reads it; raw leaves the alpha out
    rgba = np.concatenate([rgb, alpha[..., 1:]], -1)
    assert occupancy(rgba, meta).tolist() == [[100, -1, -1, -1, 0, 0, 0, -1]]
    assert occupancy(alpha, meta).tolist() == occupancy(rgba, meta).tolist()
    assert occupancy(np.stack([np.array([[101, 37]], np.uint8)] * 2, -1), raw).tolist() \
        == [[-1, 37]]


def test_a_16_bit_image_is_thresholded_at_its_own_precision(tmp_path):
    """29427 / 65535 gives p = 0.55097, above an occupied threshold of 0.55; rounded to
    8 bits first (115 / 255: p = 0.5490) it was unknown, so free with unknown="free"."""
    import struct

    (tmp_path / "m.pgm").write_bytes(b"P5\n3 1\n65535\n"
                                     + struct.pack(">3H", 65535, 29427, 65535))
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.55\nfree_thresh: 0.2\n")
    assert load_map(tmp_path / "m.yaml", unknown="free").blocked_np().tolist() == [
        [False, True, False]]


def test_world_coordinates_name_the_cell_that_holds_the_point(office):
    info = load_map_info(office, start_world=(-1.98, -1.49), goal_world=(-1.76, -1.31),
                         corner_rule="strict")
    assert info.grid.start_xy == (0, 0)
    assert info.grid.goal_xy == (4, 3)  # x 0.24 m / 0.05 = 4.8, y 0.19 / 0.05 = 3.8
    meta = info.ros
    assert cell_to_world(meta, (4, 3)) == pytest.approx((-2 + 4.5 * 0.05, -1.5 + 3.5 * 0.05))
    # a map turned by 90 degrees: the cell's x axis points along the world's y
    turned = RosMap(image=None, resolution=0.5, origin=(1.0, 2.0, math.pi / 2))
    assert world_to_cell(turned, (0.8, 2.3), (4, 4)) == (0, 0)
    assert world_to_cell(turned, (0.8, 3.3), (4, 4)) == (2, 0)
    assert world_to_cell(turned, (-0.2, 2.3), (4, 4)) == (0, 2)
    for cell in [(0, 0), (3, 1), (2, 3)]:
        assert world_to_cell(turned, cell_to_world(turned, cell), (4, 4)) == cell


@pytest.mark.parametrize("yaml_text,message", [
    ("resolution: 0.05\norigin: [0, 0, 0]\n", "'image' is missing"),
    ("image: office.pgm\norigin: [0, 0, 0]\n", "'resolution' is missing"),
    ("image: office.pgm\nresolution: -1\norigin: [0, 0, 0]\n", "resolution must be from 1e-09"),
    ("image: office.pgm\nresolution: 0.05\norigin: [0, 0]\n", "origin must be [x, y, yaw]"),
    ("image: office.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.7\n",
     "0 <= free_thresh < occupied_thresh <= 1"),
    ("image: office.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nmode: fancy\n",
     "mode must be one of trinary, scale, raw"),
    ("image: missing.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "does not exist"),
    ("image: [office.pgm\n", "not a readable YAML file"),
    # PyYAML's problem and its line, not its context alone ("while scanning ...")
    ("image:\toffice.pgm\n", "YAML file (line 1, column 7: found character '\\t' that "
                             "cannot start any token"),
    ("image: office.pgm\n resolution: 0.05\n", "line 2, column 12: mapping values are not "
                                              "allowed here"),
    # numbers no map has: inf and NaN lengths and points otherwise, or a traceback
    ("image: office.pgm\nresolution: 1.0e+308\norigin: [0, 0, 0]\n",
     "resolution must be from 1e-09 to 1e+06"),
    ("image: office.pgm\nresolution: 1.0e-300\norigin: [0, 0, 0]\n",  # every point 0 m
     "resolution must be from 1e-09 to 1e+06 metres per cell, got 1e-300"),
    ("image: office.pgm\nresolution: 0.05\norigin: [1.0e+200, 0, 0]\n",
     "origin must lie within 1e+12 metres"),
    ("image: office.pgm\nresolution: 1" + "0" * 400 + "\norigin: [0, 0, 0]\n",
     "resolution must be a finite number, got an integer of 1329 bits"),
    # a number yaml-cpp (nav2) refuses, in quotes: Python's float() read it as 5.0
    ("image: office.pgm\nresolution: '0_05'\norigin: [0, 0, 0]\n",
     "resolution must be a finite number, got '0_05'"),
    ("image: office.pgm\nresolution: 0.05\norigin: [" + "9" * 5000 + ", 0, 0]\n",
     "not a readable YAML file (Exceeds the limit"),
    ('image: "office\\0.pgm"\nresolution: 0.05\norigin: [0, 0, 0]\n',
     "image must be a file name"),
    # lists or mappings thousands deep: a RecursionError traceback before
    ("image: office.pgm\nresolution: 0.05\norigin: " + "[" * 5000 + "]" * 5000 + "\n",
     "not a readable YAML file (nested too deeply)"),
    ("image: office.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nextra: " + "{a: " * 3000 + "1"
     + "}" * 3000 + "\n", "not a readable YAML file (nested too deeply)"),
    # a key given twice: PyYAML kept the last value without a word
    ("image: office.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nresolution: 5.0\n",
     "not a readable YAML file (line 4, column 1: the key 'resolution' is given twice)"),
], ids=lambda v: v if len(v) < 60 else None)
def test_malformed_ros_maps_give_one_line(office, yaml_text, message):
    bad = office.with_name("bad.yaml")
    bad.write_text(yaml_text)
    with pytest.raises(MapFormatError) as e:
        load_map(bad)
    assert message in str(e.value) and "\n" not in str(e.value) and "bad.yaml" in str(e.value)


def test_a_yaml_merge_key_is_not_a_key_given_twice(office):
    """``<<: *defaults`` merges an anchored mapping whose keys the file's own override, as
    YAML defines: the check for keys given twice leaves merges alone."""
    plain = load_map_info(office)
    merged = office.with_name("merged.yaml")
    merged.write_text("defaults: &d {resolution: 0.5, negate: 0}\n<<: *d\n"
                      + office.read_text())
    info = load_map_info(merged)
    assert info.resolution == plain.resolution == 0.05  # the file's own value
    np.testing.assert_array_equal(info.grid.blocked_np(), plain.grid.blocked_np())


def test_endpoints_in_metres_need_a_ros_map_and_must_lie_on_it(office, tmp_path):
    with pytest.raises(EndpointError, match=r"is off the map: it covers x -2\.\.-1\.75 m"):
        load_map(office, start_world=(0.0, 0.0))
    with pytest.raises(EndpointError, match="in cells or in metres, not both"):
        load_map(office, start=(0, 0), start_world=(-1.98, -1.49))
    txt = tmp_path / "m.txt"
    txt.write_text("0 0\n0 0\n")
    with pytest.raises(EndpointError, match="needs a map with a resolution"):
        load_map(txt, goal_world=(1.0, 1.0))


def test_a_pgm_alone_and_a_png_threshold(tmp_path):
    """A map image without its YAML loads as an image (luminance below the threshold is
    blocked): ROS's unknown grey 205 (luminance 0.80) is free at the default 0.5 and
    blocked at 0.85."""
    pgm = write_pgm(tmp_path / "office.pgm", IMAGE)
    grey = (IMAGE[::-1] == 205)
    occupied = (IMAGE[::-1] == 0)
    np.testing.assert_array_equal(load_map(pgm).blocked_np(), occupied)
    np.testing.assert_array_equal(load_map(pgm, threshold=0.85).blocked_np(), occupied | grey)
    with pytest.raises(MapFormatError, match="threshold must be a luminance in"):
        load_map(pgm, threshold=0.0)


@pytest.mark.parametrize("maxval", [65535, 1000, 300])
def test_a_pgm_of_more_than_8_bits_reads_its_values_against_its_maxval(tmp_path, maxval):
    """A PGM whose maxval is over 255 (two bytes a value) is the same map as its 8-bit
    copy, alone and through its YAML: each value is read against the maxval, not clipped
    to 8 bits (which made every non-black pixel free)."""
    wide = np.round(IMAGE.astype(np.float64) / 255 * maxval).astype(">u2")
    path = tmp_path / "wide.pgm"
    path.write_bytes(f"P5\n{IMAGE.shape[1]} {IMAGE.shape[0]}\n{maxval}\n".encode()
                     + wide.tobytes())
    narrow = write_pgm(tmp_path / "narrow.pgm", IMAGE)
    for threshold in (0.5, 0.85):
        np.testing.assert_array_equal(load_map(path, threshold=threshold).blocked_np(),
                                      load_map(narrow, threshold=threshold).blocked_np())
    (tmp_path / "wide.yaml").write_text(ROS1_YAML.format(image="wide.pgm"))
    (tmp_path / "narrow.yaml").write_text(ROS1_YAML.format(image="narrow.pgm"))
    np.testing.assert_array_equal(load_map(tmp_path / "wide.yaml").blocked_np(),
                                  load_map(tmp_path / "narrow.yaml").blocked_np())


@pytest.mark.parametrize("pixels, words", [
    (np.where(IMAGE == 0, 0.0, 1.0).astype(np.float32), "a floating-point image"),
    (np.where(IMAGE == 0, 0, 70_000).astype(np.int32), "a 32-bit image with values"),
], ids=["float", "int32-over-16-bits"])
def test_an_image_without_an_8_or_16_bit_scale_is_refused(tmp_path, pixels, words):
    """A floating-point TIFF, or a 32-bit one whose values pass 16 bits, has no white
    value to read it against: refused in one line, alone and through a YAML (it was read
    clipped to 8 bits: every cell blocked, or every non-black one free)."""
    from PIL import Image

    Image.fromarray(pixels).save(tmp_path / "m.tif")
    (tmp_path / "m.yaml").write_text(ROS1_YAML.format(image="m.tif"))
    for path in (tmp_path / "m.tif", tmp_path / "m.yaml"):
        with pytest.raises(MapFormatError, match=words) as info:
            load_map(path)
        assert "\n" not in str(info.value)


def test_inflation_by_cells_or_by_the_robots_radius_in_metres(office):
    """0.05 m cells: a 0.1 m robot radius is 2 cells; the inflated map equals
    jaxga.maps.inflate of the loaded one, and an endpoint the growth covers is named."""
    from jaxga.maps import inflate

    plain = load_map(office, start=(0, 0), goal=(4, 0))
    by_metres = load_map(office, start=(0, 0), goal=(4, 0), robot_radius=0.05)
    by_cells = load_map(office, start=(0, 0), goal=(4, 0), inflate=1)
    np.testing.assert_array_equal(by_metres.blocked_np(), inflate(plain, 1).blocked_np())
    np.testing.assert_array_equal(by_cells.blocked_np(), by_metres.blocked_np())
    assert by_cells.blocked_np().sum() > plain.blocked_np().sum()
    with pytest.raises(EndpointError, match=r"the goal, map cell \(4, 0\) at \(.*\) m, "
                                            r"lies within 2 cells \(0.1 m\) of an obstacle"):
        load_map(office, start=(0, 0), goal=(4, 0), robot_radius=0.1)
    # endpoints not given are not checked here: the map's default corners are no one's
    assert load_map_info(office, robot_radius=0.1).grid.shape == plain.shape
    with pytest.raises(MapFormatError, match="not both"):
        load_map(office, inflate=1, robot_radius=0.05)
    # finite in metres, not in cells: it named an "inflate radius" of inf, never given
    with pytest.raises(MapFormatError, match="the robot radius must be a finite number of "
                                             "the map's 0.05 m cells, got 1e[+]308 m"):
        load_map(office, robot_radius=1e308)


def test_a_pgm_whose_data_does_not_match_its_header_is_refused(tmp_path, office):
    """A PGM whose header says 10 x 10 but which holds 400 bytes, or 60, is refused naming
    both sizes, alone and as a ROS map's image (not read from its header, to fail later on
    a blocked start); so is a plain (ASCII) PGM with too few values."""
    header = b"P5\n# CREATOR: map_saver.cpp 0.050 m/pix\n10 10\n255\n"
    for held in (400, 60):
        pgm = tmp_path / "office.pgm"  # the image office.yaml names
        pgm.write_bytes(header + bytes([254]) * held)
        for source in (pgm, office):
            with pytest.raises(MapFormatError) as e:
                load_map(source)
            text = str(e.value)
            assert "\n" not in text and source.name in text
            assert (f"the PGM header says 10 x 10 pixels (100 bytes of pixel data) but the "
                    f"file holds {held} bytes of pixel data") in text
    plain = tmp_path / "plain.pgm"
    plain.write_bytes(b"P2\n3 2\n255\n0 254 254\n254 254\n")
    with pytest.raises(MapFormatError, match=r"says 3 x 2 pixels \(6 values\) but the file "
                                             r"holds 5 values"):
        load_map(plain)
    plain.write_bytes(b"P2\n3 2\n255\n0 254 254\n254 254 0\n")
    assert load_map(plain).blocked_np().sum() == 2


def test_options_a_ros_map_ignores_are_refused_and_its_own_apply(office, tmp_path):
    """A ROS map's YAML sets its thresholds: an image threshold is refused, even at its
    default; the unknown setting applies to it (also given as the default) and is
    refused on its PGM loaded alone, which has no unknown cells."""
    for value in (0.5, 0.3):
        with pytest.raises(MapFormatError, match=r"office\.yaml: the image threshold "
                                                 r"\(--threshold, threshold=\) has no effect "
                                                 r"on a ROS map_server map: its YAML's "
                                                 "occupied_thresh and free_thresh"):
            load_map(office, threshold=value)
    np.testing.assert_array_equal(load_map(office, unknown="blocked").blocked_np(),
                                  load_map(office).blocked_np())
    pgm = office.with_suffix(".pgm")
    with pytest.raises(MapFormatError, match=r"office\.pgm: .* has no effect on an image: only "
                                             r"a ROS map_server map \(\.yaml\) has unknown"):
        load_map(pgm, unknown="free")
    assert load_map_info(office, robot_radius=0.05).grid.shape == (4, 5)


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="needs FIFOs")
def test_a_ros_map_whose_yaml_or_image_is_a_fifo_is_refused_at_once(tmp_path):
    """Neither the YAML nor the image it names is opened in a way that waits for a
    writer: each is refused at once, naming the file and the cap."""
    import os
    import time

    from jaxga.maps.inputs import YAML_CAP, map_file_cap

    os.mkfifo(tmp_path / "pipe.pgm")
    (tmp_path / "a.yaml").write_text(ROS1_YAML.format(image="pipe.pgm"))
    os.mkfifo(tmp_path / "pipe.yaml")
    for source, words, cap in ((tmp_path / "a.yaml", "pipe.pgm': is a FIFO",
                                map_file_cap()),
                               (tmp_path / "pipe.yaml", "pipe.yaml: is a FIFO", YAML_CAP)):
        t0 = time.perf_counter()
        with pytest.raises(MapFormatError) as e:
            load_map(source)
        assert time.perf_counter() - t0 < 5.0
        text = str(e.value)
        assert words in text and "not a regular file" in text and "\n" not in text
        assert f"at most {cap:,} bytes" in text


def test_a_blocked_endpoint_is_reported_in_the_maps_own_terms(office):
    """The office's cell (4, 3) is unknown (grey 205, blocked by default), centre (-1.775,
    -1.325) m: a run refuses a goal there naming the metres, and why it is blocked with
    the way out; coarsened by 2 (coarse cell (2, 1), around map cell (4, 3): the last
    column of blocks holds one column of the 5-wide map, so its centre is that column's,
    (-1.775, -1.35) m), also the map cell, not the coarse cell alone. The run refuses
    before anything is compiled."""
    ends = dict(start_world=(-1.98, -1.49), goal_world=(-1.76, -1.31), corner_rule="strict")
    unknown = ("; the cell is unknown in the map (neither free nor occupied) and unknown "
               "cells are blocked: --unknown free (unknown='free') plans through them")
    with pytest.raises(EndpointError) as err:
        jaxga.run("sga", load_map_info(office, **ends), seeds=1)
    assert str(err.value) == "goal cell (4, 3) is blocked (centre (-1.775, -1.325) m)" + unknown
    with pytest.raises(EndpointError) as err:
        jaxga.run("sga", load_map_info(office, coarsen=2, **ends), seeds=1)
    assert str(err.value) == ("goal cell (2, 1) is blocked (the coarse cell around map cell "
                              "(4, 3), centre (-1.775, -1.35) m)") + unknown
    with pytest.raises(EndpointError) as err:  # an occupied cell: no such hint
        jaxga.run("sga", load_map_info(office, start_world=(-1.98, -1.49),
                                       goal_world=(-1.86, -1.36), corner_rule="strict"),
                  seeds=1)
    assert str(err.value) == "goal cell (2, 2) is blocked (centre (-1.875, -1.375) m)"
    # the pure core's pairs and `jaxga optimum` say the same (optimum said "is blocked"
    # alone); neither compiles anything to refuse
    ga = jaxga.GA("sga", load_map_info(office, start_world=(-1.98, -1.49),
                                       goal_world=(-1.825, -1.475), corner_rule="strict"))
    with pytest.raises(EndpointError) as err:
        ga.grid_for((0, 0), (4, 3))
    assert str(err.value) == "goal cell (4, 3) is blocked (centre (-1.775, -1.325) m)" + unknown
    from jaxga.cli.options import load_grid
    from jaxga.cli.parser import build_parser

    args = build_parser().parse_args(
        ["optimum", "--map", str(office), "--start-world=-1.98,-1.49",
         "--goal-world=-1.76,-1.31", "--corner-rule", "strict"])
    with pytest.raises(EndpointError) as err:
        load_grid(args)
    assert str(err.value) == "goal cell (4, 3) is blocked (centre (-1.775, -1.325) m)" + unknown


def test_endpoints_given_in_metres_say_where_the_plan_snaps_them(office):
    """The planner starts at a cell's centre: -1.98, -1.49 m lies in cell (0, 0), centre
    (-1.975, -1.475) m, 0.016 m away; a point given at a centre gets no note."""
    args = argparse.Namespace(start_world=(-1.98, -1.49), goal_world=(-1.825, -1.475))
    info = load_map_info(office, start_world=args.start_world, goal_world=args.goal_world)
    assert snap_notes(args, info) == [
        "note: the start (-1.98, -1.49) m is planned at the centre of its cell, "
        "(-1.975, -1.475) m, 0.016 m away"]
    assert snap_notes(argparse.Namespace(start_world=None, goal_world=None), info) == []
    # a point under a millimetre from its centre: the centre shown with the decimals that
    # tell it from the point (it was "(-1.975, -1.475) m ... (-1.975, -1.475) m")
    near = argparse.Namespace(start_world=(-1.9754, -1.4754), goal_world=None)
    info = load_map_info(office, start_world=near.start_world, goal_world=(-1.825, -1.475))
    assert snap_notes(near, info) == [
        "note: the start (-1.9754, -1.4754) m is planned at the centre of its cell, "
        "(-1.9750, -1.4750) m, 0.0006 m away"]



@pytest.mark.parametrize("maxval, samples, bad", [
    (100, b"\x00\x32\x64\xc8", 200), (1000, b"\x00\x00\x01\xf4\x03\xe8\xea\x60", 60000),
    (100, b"\x00\x32\x64\x64", None),
], ids=["8-bit", "16-bit", "at-maxval"])
def test_a_pgm_sample_above_its_maxval_is_refused(tmp_path, maxval, samples, bad):
    """A binary PGM sample above the header's maxval was read past white (free); the
    plain form was already refused by Pillow. Samples up to maxval load."""
    (tmp_path / "m.pgm").write_bytes(f"P5\n4 1\n{maxval}\n".encode() + samples)
    (tmp_path / "m.yaml").write_text(ROS1_YAML.format(image="m.pgm"))
    # 50 of 100: free as an image (luminance 0.5 is not below 0.5), unknown in ROS
    for path, half in ((tmp_path / "m.pgm", False), (tmp_path / "m.yaml", True)):
        if bad is None:
            assert load_map(path).blocked_np().tolist() == [[True, half, False, False]]
            continue
        with pytest.raises(MapFormatError, match=f"a PGM sample of {bad} is above the "
                                                 f"header's maxval {maxval}"):
            load_map(path)


def test_a_damaged_or_palette_png_as_a_ros_image(tmp_path):
    """Reading a PNG's EXIF before its pixels decoded them inside a swallowed error: a
    broken stream then loaded as zero rows (transparent: free). And a palette or 1-bit
    image was given an alpha channel of its own, averaged into the trinary shade:
    map_saver's unknown 205 read as free. Now the first is refused and the second reads
    as map_server reads it."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.full((64, 64, 4), 255, np.uint8)).save(buf, format="png")
    raw = bytearray(buf.getvalue())
    start = raw.index(b"IDAT") + 24
    raw[start:start + 8] = bytes(b ^ 0xFF for b in raw[start:start + 8])
    (tmp_path / "bad.png").write_bytes(bytes(raw))
    (tmp_path / "bad.yaml").write_text(ROS1_YAML.format(image="bad.png"))
    with pytest.raises(MapFormatError, match="unreadable image"):
        load_map(tmp_path / "bad.yaml")
    grey = np.full((4, 4), 205, np.uint8)
    grey[0, 0] = 254
    Image.fromarray(grey).convert("P").save(tmp_path / "palette.png")
    (tmp_path / "palette.yaml").write_text(ROS1_YAML.format(image="palette.png"))
    assert occupancy(read_ros_image(read_ros_yaml(tmp_path / "palette.yaml")),
                     read_ros_yaml(tmp_path / "palette.yaml")).tolist() == \
        [[0, -1, -1, -1]] + [[-1] * 4] * 3
