"""Occupancy grids in memory (a ``nav_msgs/OccupancyGrid`` message, or an array with its
resolution and origin): the map a node is published plans as the ``map_server`` file it
came from; every malformed grid is one line naming it."""

from __future__ import annotations

import array
import math
import types

import numpy as np
import pytest

from jaxga import EndpointError, MapFormatError
from jaxga.maps import OccupancyGrid, load_map_info
from tests.maps.test_ros_maps import IMAGE

# IMAGE: test_ros_maps' 5 x 4 map as map_saver writes it (254 free, 0 occupied, 205
# unknown), top row first. OCCUPANCY: the same cells as map_server publishes them, row 0
# the bottom, -1 / 0 / 100.
OCCUPANCY = np.select([IMAGE == 0, IMAGE == 205], [100, -1], 0).astype(np.int8)[::-1]
YAML = """image: office.pgm
resolution: 0.050000
origin: [-2.000000, -1.500000, {yaw}]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
"""


def _office(folder, yaw: float = 0.0) -> str:
    h, w = IMAGE.shape
    (folder / "office.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + IMAGE.tobytes())
    (folder / "office.yaml").write_text(YAML.format(yaw=repr(yaw)))
    return str(folder / "office.yaml")


def _message(occupancy: np.ndarray = OCCUPANCY, quaternion=(0.0, 0.0, 0.0, 1.0),
             resolution: float = float(np.float32(0.05)), data=None) -> types.SimpleNamespace:
    """A message as rclpy gives one: int8 data in an ``array.array``, a float32
    resolution, float64 poses."""
    ns = types.SimpleNamespace
    h, w = occupancy.shape
    x, y, z, qw = quaternion
    info = ns(width=w, height=h, resolution=resolution,
              origin=ns(position=ns(x=-2.0, y=-1.5, z=0.0),
                        orientation=ns(x=x, y=y, z=z, w=qw)))
    if data is None:
        data = array.array("b", occupancy.ravel().tolist())
    return ns(header=ns(frame_id="map"), info=info, data=data)


def _as_dict(message) -> dict:
    """The message as rosbridge sends it (JSON) or message_to_ordereddict makes it."""
    if isinstance(message, types.SimpleNamespace):
        return {k: _as_dict(v) for k, v in vars(message).items()}
    return list(message) if isinstance(message, array.array) else message


def _same_map(a, b) -> None:
    """Two MapInfo plan alike: cells, endpoints, rule, layers and frame."""
    np.testing.assert_array_equal(a.grid.blocked_np(), b.grid.blocked_np())
    assert (a.grid.start_xy, a.grid.goal_xy, a.grid.corner_rule) == (
        b.grid.start_xy, b.grid.goal_xy, b.grid.corner_rule)
    for layer in ("wall", "margin", "unknown"):
        np.testing.assert_array_equal(getattr(a.layers, layer), getattr(b.layers, layer))
    assert a.layers.unknown_blocked == b.layers.unknown_blocked
    assert a.resolution == b.resolution and a.ros.origin == b.ros.origin
    cells = np.array([[0, 0], [4, 3], [2, 1]], float)
    np.testing.assert_array_equal(a.frame.to_world(cells), b.frame.to_world(cells))
    assert a.defaulted == b.defaulted


@pytest.mark.parametrize("options", [
    {}, {"unknown": "free"}, {"robot_radius": 0.05}, {"inflate": 1},
    {"occupied_from": 99}, {"occupied_from": 100, "unknown": "free"},
    {"coarsen": 2, "start": (0, 0), "goal": (4, 0)},
    {"start_world": (-1.97, -1.47), "goal_world": (-1.78, -1.33)},
    {"corner_rule": "free", "start": (1, 0), "goal": (3, 1)},
])
def test_a_message_plans_as_the_map_server_file_it_was_published_from(tmp_path, options):
    from_file = load_map_info(_office(tmp_path), **options)
    for source in (_message(), _as_dict(_message()),
                   OccupancyGrid(OCCUPANCY, 0.05, (-2.0, -1.5))):
        info = load_map_info(source, **options)
        assert info.format == "occupancy_grid" and info.name == "occupancy_grid"
        _same_map(info, from_file)


def test_the_forms_of_a_messages_data_read_alike():
    """ROS 2's array of int8, ROS 1's tuple, raw int8 bytes, a numpy array, flat or
    [height, width]: the same cells, row 0 the bottom (the message's first row)."""
    flat = OCCUPANCY.ravel()
    forms = [array.array("b", flat.tolist()), tuple(flat.tolist()), flat.tobytes(),
             flat.astype(np.int64), flat.astype(np.float32)]
    grids = [OccupancyGrid(d, 0.05, width=5, height=4) for d in forms]
    grids.append(OccupancyGrid(OCCUPANCY, 0.05))
    for g in grids:
        np.testing.assert_array_equal(g.occupancy, OCCUPANCY)
        assert g.occupancy.dtype == np.int8 and not g.occupancy.flags.writeable
        assert (g.width, g.height, g.origin) == (5, 4, (0.0, 0.0, 0.0))
    assert load_map_info(grids[0]).grid.blocked_np()[0, 0] == 0  # bottom-left: free
    assert load_map_info(grids[0]).grid.blocked_np()[3, 0] == 1  # top-left: occupied


def test_the_callers_array_is_copied_not_locked_or_shared():
    """The grid holds its own checked copy: the caller's array stays writable (a costmap
    updated in place), and a later change to it, or to a message's data, does not reach
    a grid already checked."""
    costmap = OCCUPANCY.copy()
    grid = OccupancyGrid(costmap, 0.05)
    costmap[0, 0] = 100  # still writable
    flat = array.array("b", OCCUPANCY.ravel().tolist())
    from_flat = OccupancyGrid(flat, 0.05, width=5, height=4)
    flat[1] = 7
    np.testing.assert_array_equal(grid.occupancy, OCCUPANCY)
    np.testing.assert_array_equal(from_flat.occupancy, OCCUPANCY)
    assert grid == from_flat != OccupancyGrid(costmap, 0.05)


def test_a_name_is_shown_on_one_line():
    assert OccupancyGrid(OCCUPANCY, 0.05, name="caf\udce9").name == "caf\\udce9"
    assert load_map_info(OccupancyGrid.from_message(_message(), name="floor 2")).name == \
        "floor 2"


def test_graded_cells_are_possibly_occupied_as_a_map_server_maps_are():
    """1-99 (a costmap's inflation, a scale-mode map's grey) and -1 are blocked unless
    unknown cells are planned as free; 100 always is."""
    occ = np.array([[0, 1, 50, 99, 100, -1]], np.int8)
    blocked = load_map_info(OccupancyGrid(occ, 0.1), start=(0, 0), goal=(0, 0))
    assert blocked.grid.blocked_np().tolist() == [[False, True, True, True, True, True]]
    free = load_map_info(OccupancyGrid(occ, 0.1), start=(0, 0), goal=(0, 0),
                         unknown="free")
    assert free.grid.blocked_np().tolist() == [[False, False, False, False, True, False]]
    assert blocked.layers.unknown.tolist() == [[False] * 5 + [True]]


def test_a_costmap_blocks_from_the_occupancy_given():
    """``occupied_from=99``: a costmap's lethal 100 and inscribed 99 blocked, its graded
    inflation below free, unknown cells blocked unless ``unknown="free"``; the graded
    cells are free space in the layers, not unknown."""
    occ = np.array([[0, 1, 50, 98, 99, 100, -1]], np.int8)
    rows = {}
    for unknown in ("blocked", "free"):
        info = load_map_info(OccupancyGrid(occ, 0.1), start=(0, 0), goal=(0, 0),
                             unknown=unknown, occupied_from=99)
        rows[unknown] = info.grid.blocked_np().tolist()[0]
        assert info.layers.unknown.tolist() == [[False] * 6 + [True]]
        assert info.layers.unknown_blocked == (unknown == "blocked")
        assert info.layers.wall.tolist() == [[False] * 4 + [True, True, False]]
    assert rows == {"blocked": [False] * 4 + [True] * 3,
                    "free": [False] * 4 + [True, True, False]}
    every = load_map_info(OccupancyGrid(occ, 0.1), start=(0, 0), goal=(0, 0),
                          occupied_from=1, unknown="free")
    assert every.grid.blocked_np().tolist() == [[False] + [True] * 5 + [False]]


def test_a_scale_mode_maps_graded_cells_block_from_the_occupancy_given(tmp_path):
    """A ``scale``-mode ROS map's graded grey: blocked from ``occupied_from`` on, the
    same cells from the file as from the message its map_server publishes."""
    from jaxga.maps.ros import occupancy, read_ros_image, read_ros_yaml

    shades = np.array([[254, 200, 180, 150, 120, 100, 0]], np.uint8)
    (tmp_path / "graded.pgm").write_bytes(b"P5\n7 1\n255\n" + shades.tobytes())
    path = tmp_path / "graded.yaml"
    path.write_text(YAML.replace("office.pgm", "graded.pgm").format(yaw="0.0")
                    + "mode: scale\n")
    ros = read_ros_yaml(path, "graded.yaml")
    occ = occupancy(read_ros_image(ros, "graded.yaml"), ros)[::-1]
    assert occ.min() == 0 and occ.max() == 100 and len(np.unique(occ)) == 7
    for level in (1, 30, 60, 99, 100):
        from_file = load_map_info(str(path), start=(0, 0), goal=(0, 0),
                                  occupied_from=level)
        assert from_file.grid.blocked_np().tolist() == (occ >= level).tolist()
        message = load_map_info(OccupancyGrid(occ, 0.05, (-2.0, -1.5)), start=(0, 0),
                                goal=(0, 0), occupied_from=level)
        _same_map(message, from_file)


@pytest.mark.parametrize("value", [0, 101, -1, True, 1.5, "99", None.__class__])
def test_an_occupancy_that_is_not_1_to_100_is_refused_in_one_line(value):
    with pytest.raises(MapFormatError, match="integer from 1 to 100") as e:
        load_map_info(_message(), occupied_from=value)
    assert "\n" not in str(e.value) and "occupancy_grid" in str(e.value)


def test_an_occupancy_threshold_on_a_map_without_occupancies_is_refused():
    with pytest.raises(MapFormatError, match="has no effect on a 0/1 text map"):
        load_map_info("classic_ga_gapp3_20x20", occupied_from=99)


def test_an_endpoint_on_a_graded_cell_is_told_why_and_the_way_out():
    """A robot in a costmap's inflation: its start is blocked by the rule for graded
    cells, which the refusal names with occupied_from; loaded with it, it is planned."""
    import jaxga

    occ = np.zeros((40, 40), np.int8)
    occ[5, 5], occ[6, 6] = 37, -1
    options = {"start": (5, 5), "goal": (30, 30)}
    text = _refused(lambda: jaxga.problem("sga", OccupancyGrid(occ, 0.05),
                                          map_options=options), EndpointError)
    assert "graded occupancy" in text and "occupied_from" in text
    assert jaxga.problem("sga", OccupancyGrid(occ, 0.05), map_options={
        **options, "occupied_from": 99}).grid.start_xy == (5, 5)
    unknown = _refused(lambda: jaxga.problem("sga", OccupancyGrid(occ, 0.05), map_options={
        **options, "start": (6, 6)}), EndpointError)
    assert "unknown" in unknown and "graded" not in unknown
    occ[4, 5] = 100  # coarsened with an occupied cell: no threshold frees its block
    lethal = _refused(lambda: jaxga.problem("sga", OccupancyGrid(occ, 0.05), map_options={
        "start": (4, 4), "goal": (30, 30), "coarsen": 2}), EndpointError)
    assert "graded" not in lethal and "occupied_from" not in lethal


def test_a_message_without_data_bools_and_unsigned_data_are_named():
    """A message missing its data is told so (not taken for another kind of source); a
    true among the values is no occupancy of 1; unsigned data is named as such."""
    message = _as_dict(_message())
    del message["data"]
    assert "it has no field data" in _refused(lambda: load_map_info(message))
    flat = [True] + [0] * 19
    assert "true or false" in _refused(
        lambda: OccupancyGrid(flat, 0.05, width=5, height=4))
    unsigned = np.where(OCCUPANCY < 0, 255, OCCUPANCY).astype(np.uint8)
    assert "the data is unsigned" in _refused(lambda: OccupancyGrid(unsigned, 0.05))
    rows = [[0] * 5 for _ in range(3)] + [[0, False, 0, 0, 0]]
    assert "true or false" in _refused(lambda: OccupancyGrid(rows, 0.05))
    deep: list = [0]
    for _ in range(5000):
        deep = [deep]
    assert "not an array of occupancies" in _refused(lambda: OccupancyGrid(deep, 0.05))
    picture = types.SimpleNamespace(info={"dpi": (72, 72)}, size=(4, 4))  # PIL's .info
    assert "a map source must be" in _refused(lambda: load_map_info(picture))


def test_a_float32_resolution_is_the_decimal_the_map_was_saved_with():
    """A message's resolution is float32 (0.05 arrives as 0.0500000007450580597): read as
    the shortest decimal that gives it, so the cells' metres are the file's; a float64
    value that is no float32 is kept as it is."""
    assert float(np.float32(0.05)) != 0.05
    assert load_map_info(_message()).resolution == 0.05
    assert OccupancyGrid(OCCUPANCY, 0.1).resolution == 0.1  # 0.1 is no float32: kept
    assert OccupancyGrid(OCCUPANCY, np.float32(0.025)).resolution == 0.025
    assert OccupancyGrid(OCCUPANCY, 0.0625).resolution == 0.0625  # exact in both


@pytest.mark.parametrize("yaw", [0.5, math.pi / 2, -2.0, math.pi])
def test_the_origins_quaternion_is_the_files_yaw(tmp_path, yaw):
    from_file = load_map_info(_office(tmp_path, yaw))
    q = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    for quaternion in (q, tuple(-v for v in q)):  # q and -q: the same rotation
        info = load_map_info(_message(quaternion=quaternion))
        assert info.ros.origin[2] == pytest.approx(math.atan2(math.sin(yaw), math.cos(yaw)),
                                                   abs=1e-12)
        cells = np.array([[0, 0], [4, 3]], float)
        np.testing.assert_allclose(info.frame.to_world(cells), from_file.frame.to_world(cells),
                                   atol=1e-12)


def test_a_message_with_no_orientation_set_has_no_rotation():
    assert load_map_info(_message(quaternion=(0.0, 0.0, 0.0, 0.0))).ros.origin[2] == 0.0


def _refused(make, kind: type = MapFormatError) -> str:
    with pytest.raises(kind) as e:
        make()
    text = str(e.value)
    assert "\n" not in text
    return text


@pytest.mark.parametrize("make, words", [
    (lambda: OccupancyGrid(np.zeros(19, np.int8), 0.05, width=5, height=4),
     "19 values for 5 x 4 cells (20)"),
    (lambda: OccupancyGrid(np.zeros(20, np.int8), 0.05), "needs its width and height"),
    (lambda: OccupancyGrid(np.zeros((4, 5), np.int8), 0.05, width=4),
     "the width is 4, but the data's [height, width] shape is [4, 5]"),
    (lambda: OccupancyGrid(np.zeros((2, 2, 2), np.int8), 0.05), "3 dimensions"),
    (lambda: OccupancyGrid(np.zeros((0, 5), np.int8), 0.05), "no cells"),
    (lambda: OccupancyGrid([], 0.05, width=0, height=4), "width must be a positive integer"),
    (lambda: OccupancyGrid([0] * 4, 0.05, width=True, height=4),
     "width must be a positive integer"),
    (lambda: OccupancyGrid([[0, 101]], 0.05), "cell (1, 0) holds 101"),
    (lambda: OccupancyGrid([[0, 0], [-2, 0]], 0.05), "cell (0, 1) holds -2"),
    (lambda: OccupancyGrid([[0.0, 1.5]], 0.05), "cell (1, 0) holds 1.5"),
    (lambda: OccupancyGrid([[0.0, math.nan]], 0.05), "cell (1, 0) holds nan"),
    (lambda: OccupancyGrid([["0", "1"]], 0.05), "integers from -1 to 100"),
    (lambda: OccupancyGrid([[0, 1], [0]], 0.05), "not an array of occupancies"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.0), "resolution must be from"),
    (lambda: OccupancyGrid(OCCUPANCY, math.nan), "resolution must be a finite int or float"),
    (lambda: OccupancyGrid(OCCUPANCY, "0.05"), "resolution must be a finite int or float"),
    (lambda: OccupancyGrid(OCCUPANCY, 10**400), "resolution must be a finite int or float"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, (10**400, 0)), "origin must be a finite int"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, {1: 1, 2: 2}), "origin must be (x, y) or"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, {1.0, 2.0}), "origin must be (x, y) or"),
    (lambda: OccupancyGrid(np.zeros((2, 2), "m8[s]"), 0.05), "got an array of timedelta64"),
    (lambda: OccupancyGrid(np.zeros((2, 2), bool), 0.05), "got an array of bool"),
    (lambda: OccupancyGrid(memoryview(np.array([100, 0], np.int16)), 0.05, width=4,
                           height=1), "2 values for 4 x 1 cells"),  # not 4 bytes
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, name="a\nb"), "printable characters"),
    (lambda: load_map_info(OccupancyGrid(OCCUPANCY, 0.05), unknown="maybe"),
     "occupancy grid 'occupancy_grid': unknown cells must be one of blocked, free"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, (1.0,)), "origin must be (x, y) or (x, y, yaw)"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, (math.inf, 0.0)), "origin must be a finite"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, (1e13, 0.0)), "within 1e+12 metres"),
    (lambda: OccupancyGrid(OCCUPANCY, 1e-9, (1e3, 0.0)), "cells of 1e-09 m away"),
    (lambda: OccupancyGrid(OCCUPANCY, 0.05, name=""), "non-empty string"),
    (lambda: OccupancyGrid.from_message(_message(quaternion=(0.5, 0.0, 0.0, 0.866))),
     "turns the map out of the plane"),
    (lambda: OccupancyGrid.from_message(_message(quaternion=(0.0, 0.0, 0.0, 2.0))),
     "is not a rotation: its norm is 2"),
    (lambda: OccupancyGrid.from_message(types.SimpleNamespace(info=1, data=[])),
     "OccupancyGrid message 'occupancy_grid': it has no field info.width"),
    (lambda: OccupancyGrid.from_message(_message(data=array.array("b", [0] * 3))),
     "OccupancyGrid message 'occupancy_grid': 3 values for 5 x 4 cells"),
    (lambda: load_map_info(OccupancyGrid(OCCUPANCY, 0.05), threshold=0.5),
     "has no effect on an occupancy grid: its values are occupancies already"),
    (lambda: load_map_info(OccupancyGrid(OCCUPANCY, 0.05), fmt="ros"),
     "occupancy grid 'occupancy_grid': a map format (fmt='ros') has no effect"),
    (lambda: load_map_info(np.zeros((4, 5))), "jaxga.maps.OccupancyGrid"),
])
def test_a_malformed_grid_is_refused_in_one_line_naming_it(make, words):
    assert words in _refused(make)


def test_an_endpoint_off_the_grid_is_refused_in_one_line_naming_it():
    grid = OccupancyGrid(OCCUPANCY, 0.05)
    text = _refused(lambda: load_map_info(grid, start_world=(9.0, 9.0)), EndpointError)
    assert text.startswith("occupancy grid 'occupancy_grid': the start (9, 9) m is off the map")


def test_a_grid_larger_than_jaxga_plans_on_is_refused_unless_coarsened():
    from jaxga.core.grid import MAX_MAP_CELLS

    side = math.isqrt(MAX_MAP_CELLS) + 1
    grid = OccupancyGrid(np.zeros((side, side), np.int8), 0.05)
    assert "coarse" in _refused(lambda: load_map_info(grid))
    info = load_map_info(grid, coarsen=2)
    assert info.grid.shape == (-(-side // 2), -(-side // 2)) and info.resolution == 0.1


def test_a_problem_takes_a_message_with_the_options_of_a_map_file(tmp_path):
    """``jaxga.problem`` (and so ``jaxga.run``) loads a message as it loads the file,
    ``map_options`` included; a loaded map still refuses them."""
    import jaxga

    options = {"robot_radius": 0.05, "start_world": (-1.97, -1.47),
               "goal_world": (-1.78, -1.48)}
    from_file = jaxga.problem("sga", _office(tmp_path), map_options=options)
    problem = jaxga.problem("sga", _message(), map_options=options)
    np.testing.assert_array_equal(problem.grid.blocked_np(), from_file.grid.blocked_np())
    assert (problem.grid.start_xy, problem.grid.goal_xy) == (
        from_file.grid.start_xy, from_file.grid.goal_xy)
    assert problem.map_name == "occupancy_grid" and problem.frame.resolution == 0.05
    with pytest.raises(jaxga.ParameterError, match="not to a loaded map"):
        jaxga.problem("sga", load_map_info(_message()), map_options=options)
