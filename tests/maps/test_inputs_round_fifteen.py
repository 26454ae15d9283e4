"""Round fifteen (decision 063): a robot engineer's maps read by a second reader with
hand-made cases: grey levels exactly at a threshold, world points on a cell's edge on a
map whose origin lies thousands of kilometres out (UTM coordinates), the messages that
name such points, and origins too many cells away for float64 metres.

Each test is cheap: no GA is compiled."""

from __future__ import annotations

import decimal
import itertools
import struct
import zlib

import numpy as np
import pytest

from jaxga.core.errors import EndpointError, MapFormatError
from jaxga.maps import load_map_info, save_map
from jaxga.maps.frame import MapFrame
from jaxga.maps.ros import RosMap, occupancy
from tests.maps.test_maps import _png

UTM = (512345.6, 4123456.7, 0.0)


def _nav2_cell(channels: tuple[int, ...], alpha: int | None, meta: RosMap) -> int:
    """One pixel as nav2_map_server's map_io.cpp computes it, written out scalar by scalar
    in its order of operations: GraphicsMagick's 16-bit quanta (257 per 8-bit step), their
    sum, over the channel count, over 65535; occ = 1 - shade (shade when negated)."""
    quanta = [257 * v for v in channels]
    if meta.mode == "trinary" and alpha is not None:
        quanta.append(257 * alpha)
    total = 0.0
    for q in quanta:
        total += q
    shade = (total / len(quanta)) / 65535.0
    occ = shade if meta.negate else 1.0 - shade
    if meta.mode == "raw":  # std::round: halves away from zero
        value = int(decimal.Decimal(shade * 255).quantize(0, decimal.ROUND_HALF_UP))
        return value if 0 <= value <= 100 else -1
    if meta.mode == "scale" and alpha is not None and alpha != 255:
        return -1
    if meta.occupied_thresh < occ:
        return 100
    if occ < meta.free_thresh:
        return 0
    if meta.mode == "trinary":
        return -1
    return int(np.rint((occ - meta.free_thresh)
                       / (meta.occupied_thresh - meta.free_thresh) * 100.0))


def test_a_grey_level_exactly_at_a_threshold_falls_where_nav2_puts_it():
    """jaxga computed p = (255 - s) / 255 (ROS 1's order); nav2 computes 1 - s / 255, which
    rounds the other way at a threshold: grey 204 under free_thresh 0.2 is free in nav2
    (1 - 0.8 = 0.19999999999999996), and an opaque RGBA 153 under occupied_thresh 0.3 is
    occupied (0.30000000000000004); jaxga called both unknown."""
    grey = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), free_thresh=0.2)
    assert occupancy(np.array([[204]], np.uint8), grey).tolist() == [[0]]
    rgba = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), occupied_thresh=0.3,
                  free_thresh=0.1)
    assert occupancy(np.array([[[153, 153, 153, 255]]], np.uint8), rgba).tolist() == [[100]]


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
def test_every_grey_level_agrees_with_nav2_at_every_threshold(mode):
    """Every 8-bit grey level, as a grey image, a grey image with alpha and an RGB one
    (channels v, v, v + 1), under thresholds a twentieth apart and negated or not: the
    occupancy is the one nav2's scalar arithmetic gives, cell for cell."""
    v = np.arange(256)
    alphas = np.where(v % 3 == 0, 255, (v * 7) % 256)
    for free, occ in itertools.combinations(np.round(np.arange(0, 1.0001, 0.05), 2), 2):
        for negate in (False, True):
            meta = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), mode=mode,
                          negate=negate, occupied_thresh=float(occ), free_thresh=float(free))
            got = occupancy(v[None].astype(np.uint8), meta)[0]
            assert got.tolist() == [_nav2_cell((g, g, g), None, meta) for g in v]
            ga = np.stack([v, alphas], -1)[None].astype(np.uint8)
            got = occupancy(ga, meta)[0]
            assert got.tolist() == [_nav2_cell((g, g, g), int(a), meta)
                                    for g, a in zip(v, alphas)]
            rgb = np.stack([v, v, np.minimum(v + 1, 255)], -1)[None].astype(np.uint8)
            got = occupancy(rgb, meta)[0]
            assert got.tolist() == [_nav2_cell((g, g, min(g + 1, 255)), None, meta)
                                    for g in v]


def test_points_on_cell_edges_far_from_zero_count_in_the_cell_above():
    """A 0.05 m map whose origin lies at UTM (512345.6, 4123456.7): float64's rounding of
    the origin (2e-10 m) put 320 of 399 edges written to two decimals in the cell below,
    so an obstacle or endpoint given there landed a cell off. Every edge now counts in the
    cell above it, as on a map at 0."""
    frame = MapFrame(map_shape=(400, 400), resolution=0.05, origin=UTM)
    for k in range(400):
        x, y = (float(f"{o + k * 0.05:.2f}") for o in UTM[:2])
        assert frame.cell_of((x, y), (400, 400)) == (k, k)
    # a point 1e-7 m (2e-6 of a cell) below an edge is in the cell below: the tolerance
    # here is 1.5e-7 of a cell; a coarsened frame's is as many map cells
    assert frame.cell_of((512346.2 - 1e-7, 4123458.0 - 1e-7), (400, 400)) == (11, 25)
    coarse = MapFrame(map_shape=(400, 400), coarsen=4, resolution=0.05, origin=UTM)
    assert coarse.cell_of((512346.2, 4123458.0), (100, 100)) == (3, 6)
    assert coarse.cell_of((512346.2 - 1e-7, 4123458.0 - 1e-7), (100, 100)) == (2, 6)
    # at the farthest origin allowed the tolerance is 2e-4 of a cell, not more
    far = MapFrame(map_shape=(40, 40), resolution=1e-9, origin=(100.0, 100.0, 0.0))
    assert far.cell_of((100.0 + 9.9995e-9, 100.0), (40, 40)) == (9, 0)
    assert far.edge_tolerance((float("nan"), float("inf"))) > 0  # no max() of nothing


def test_a_ros_map_far_from_zero_loads_its_endpoints_on_the_edges_given(tmp_path):
    blocked = np.zeros((40, 40), bool)
    save_map(blocked, tmp_path / "utm.yaml", resolution=0.05, origin=UTM)
    info = load_map_info(tmp_path / "utm.yaml", start_world=(512346.2, 4123458.0),
                         goal_world=(512347.3, 4123457.25))
    assert info.grid.start_xy == (12, 26) and info.grid.goal_xy == (34, 11)


def test_messages_name_far_coordinates_with_their_digits():
    """The off-map line printed UTM coordinates with six significant digits: 'the goal
    (512347, 4.12346e+06) m is off the map: it covers ... y 4.12346e+06..4.12346e+06 m',
    a range that seemed to hold the point."""
    frame = MapFrame(map_shape=(40, 40), resolution=0.05, origin=UTM)
    with pytest.raises(EndpointError) as err:
        frame.cell_of((512347.33, 4123459.73), (40, 40), "the goal")
    assert str(err.value) == ("the goal (512347.33, 4123459.73) m is off the map: it covers "
                              "x 512345.6..512347.6 m, y 4123456.7..4123458.7 m")
    assert frame.coordinate_text(-0.0) == "0" and frame.coordinate_text(5.0) == "5"
    with pytest.raises(EndpointError) as err:  # a slip of 1e300 m: not 300 digits
        frame.cell_of((1e300, 4123457.0), (40, 40))
    assert str(err.value).startswith("point (1e+300, 4123457) m is off the map")


def test_an_origin_too_many_cells_from_zero_is_refused_in_one_line(tmp_path):
    """Resolution (>= 1e-9 m) and origin (<= 1e12 m) were checked alone, so a nanometre
    map could lie 500 km out, where its written cell centres read back in other cells:
    such a map is refused when read and when saved, and nothing is written."""
    (tmp_path / "far.pgm").write_bytes(b"P5\n2 2\n255\n" + bytes([254] * 4))
    (tmp_path / "far.yaml").write_text("image: far.pgm\nresolution: 1.0e-9\n"
                                       "origin: [512345.6, 4123456.7, 0.0]\n")
    with pytest.raises(MapFormatError) as err:
        load_map_info(tmp_path / "far.yaml")
    assert "\n" not in str(err.value) and "cells of 1e-09 m away" in str(err.value)
    with pytest.raises(MapFormatError, match="cannot save .*cells of 1e-06 m away"):
        save_map(np.zeros((4, 4), bool), tmp_path / "out.yaml", resolution=1e-6,
                 origin=(-1e9, 3e9, 0.0))
    assert not (tmp_path / "out.yaml").exists() and not (tmp_path / "out.pgm").exists()
    # a UTM origin at centimetre cells is 8e7 cells out: loaded; 1e11 cells out, loaded
    save_map(np.zeros((4, 4), bool), tmp_path / "utm.yaml", resolution=0.05, origin=UTM)
    assert load_map_info(tmp_path / "utm.yaml").frame.origin == UTM
    save_map(np.zeros((4, 4), bool), tmp_path / "edge.yaml", resolution=0.5,
             origin=(5e10, -5e10, 0.0))
    assert load_map_info(tmp_path / "edge.yaml").frame.origin == (5e10, -5e10, 0.0)
    with pytest.raises(MapFormatError, match="1e\\+11 cells"):
        save_map(np.zeros((4, 4), bool), tmp_path / "past.yaml", resolution=0.5,
                 origin=(5.0001e10, 0.0, 0.0))


@pytest.mark.parametrize("colour_type, channels", [(2, 3), (4, 2), (6, 4)],
                         ids=["colour", "grey-and-alpha", "colour-and-alpha"])
def test_a_16_bit_png_with_more_than_grey_is_refused(tmp_path, colour_type, channels):
    """Pillow decodes a 16-bit colour or alpha PNG at 8 bits a channel: a pixel 0xCC00
    read as 204 is free under free_thresh 0.2 where nav2 (p = 0.2031) has it unknown.
    Refused in one line through a ROS YAML; 16-bit grey, which Pillow keeps at 16 bits,
    is read. (A plain PNG map is thresholded by its luminance, read by matplotlib.)"""
    pixels = np.full((2, 3, channels), 0xCC00, np.uint16)
    rows = b"".join(b"\0" + row.astype(">u2").tobytes() for row in pixels)
    (tmp_path / "deep.png").write_bytes(_png([
        (b"IHDR", struct.pack(">IIBBBBB", 3, 2, 16, colour_type, 0, 0, 0)),
        (b"IDAT", zlib.compress(rows)), (b"IEND", b"")]))
    (tmp_path / "deep.yaml").write_text("image: deep.png\nresolution: 0.05\n"
                                        "origin: [0.0, 0.0, 0.0]\nfree_thresh: 0.2\n")
    with pytest.raises(MapFormatError, match="16-bit .*PNG is read by Pillow at 8") as e:
        load_map_info(tmp_path / "deep.yaml")
    assert "\n" not in str(e.value)
    grey = np.full((2, 3), 0xCC00, np.uint16)
    rows = b"".join(b"\0" + row.astype(">u2").tobytes() for row in grey)
    (tmp_path / "deep.png").write_bytes(_png([
        (b"IHDR", struct.pack(">IIBBBBB", 3, 2, 16, 0, 0, 0, 0)),
        (b"IDAT", zlib.compress(rows)), (b"IEND", b"")]))
    assert load_map_info(tmp_path / "deep.yaml").grid.blocked_np().all()  # p 0.2031: unknown
