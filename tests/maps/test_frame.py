"""The world frame of a map (planning cells, map cells, metres), its layers for plots, the
path files a robot reads, and the time line of a run."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
import yaml

from jaxga._runtime.timeline import Timeline, time_line
from jaxga.core.errors import EndpointError, JaxgaError
from jaxga.core.grid import DIRECTIONS
from jaxga.export import (
    atomic_write_text,
    path_format,
    path_text,
    path_yaws,
    read_path,
    write_path,
)
from jaxga.maps import load_map_info, map_name
from jaxga.maps.frame import MapFrame
from jaxga.maps.preprocess import legal_moves, reachable_np


def test_planning_cells_map_cells_and_metres_by_hand():
    """A 10 x 7 map (H 7, W 10) of 0.05 m cells, origin (-1, 2), coarsened 3 x 3: a
    planning cell is 0.15 m; planning cell (1, 1)'s centre is map cell (4, 4), planning
    cell (1, 1)'s the world point (-1 + 1.5 * 0.15, 2 + 1.5 * 0.15); the last blocks
    (x = 3: map cells 9..11, y = 2: rows 6..8) stand for their cells on the map, 9 and
    6, are named by them and drawn in their middle (planning cell (1, 2) at row 6.5,
    not 7.5, past the map's edge at 7); a world point maps back to its planning cell."""
    f = MapFrame(map_shape=(7, 10), coarsen=3, resolution=0.05, origin=(-1.0, 2.0, 0.0))
    assert f.cell_size == pytest.approx(0.15) and f.has_metres
    np.testing.assert_allclose(f.to_world(np.array([1, 1])), [-1 + 1.5 * 0.15, 2 + 1.5 * 0.15])
    np.testing.assert_allclose(f.to_world(np.array([1, 2])), [-1 + 1.5 * 0.15, 2 + 6.5 * 0.05])
    assert f.map_cell(np.array([[1, 1], [3, 2], [0, 0]])).tolist() == [[4, 4], [9, 6], [1, 1]]
    assert f.planning_cell(np.array([[4, 7], [9, 6]])).tolist() == [[1, 2], [3, 2]]
    assert f.cell_of((-1 + 1.5 * 0.15, 2 + 6.5 * 0.05), (3, 4)) == (1, 2)
    assert f.metres(10.0) == pytest.approx(1.5)
    with pytest.raises(EndpointError, match=r"\(5, 2\) m is off the map: it covers x -1\.\.-0\.5"):
        f.cell_of((5.0, 2.0), (3, 4), "the goal")
    plain = MapFrame(map_shape=(7, 10))
    assert plain.cell_size is None and plain.metres(3.0) is None and not plain.has_metres
    assert plain.map_cell(np.array([2, 3])).tolist() == [2, 3]
    with pytest.raises(EndpointError, match="needs a map with a resolution"):
        plain.cell_of((0.0, 0.0), (7, 10))


def test_a_turned_map_rotates_about_its_origin():
    """With yaw 90 degrees the map's x axis points along the world's y: cell (0, 0)'s
    centre (0.5, 0.5) cells = (0.05, 0.05) m lies at origin + (-0.05, 0.05). A point off
    the turned map is named along the map's own axes, where its extent is plain: the
    world point (1.1, 2.1), inside the unturned rectangle x 1..1.4, y 2..2.4, lies at
    (0.1, -0.1) m along them."""
    f = MapFrame(map_shape=(4, 4), resolution=0.1, origin=(1.0, 2.0, math.pi / 2))
    np.testing.assert_allclose(f.to_world(np.array([0, 0])), [0.95, 2.05])
    np.testing.assert_allclose(f.to_world(np.array([2, 0])), [0.95, 2.25])
    assert f.cell_of((0.95, 2.25), (4, 4)) == (2, 0)
    with pytest.raises(EndpointError) as e:
        f.cell_of((1.1, 2.1), (4, 4), "the start")
    assert str(e.value) == (
        "the start (1.1, 2.1) m is off the map: along the map's own axes (turned by its yaw, "
        "1.5708 rad, about its origin (1, 2) m) the point lies at (0.1, -0.1) m from the "
        "origin, and the map covers 0..0.4 m by 0..0.4 m")


def _write_ros(folder, image_rows, resolution=0.1, origin=(0.0, 0.0)):
    folder.mkdir(parents=True, exist_ok=True)
    img = np.asarray(image_rows, np.uint8)
    h, w = img.shape
    (folder / "map.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + img.tobytes())
    (folder / "map.yaml").write_text(
        f"image: map.pgm\nresolution: {resolution}\norigin: [{origin[0]}, {origin[1]}, 0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return folder / "map.yaml"


def test_layers_say_what_each_cell_is_and_coarsen_with_precedence(tmp_path):
    """A 6 x 6 map: one wall cell, a 2-cell unknown strip, inflated by 1 cell. The layers
    are exclusive (wall, margin, unknown), the margin is exactly what the inflation adds,
    the planning grid blocks wall + margin + unknown; coarsened 2 x 2 a block is wall if
    any of its cells is, else margin, else unknown. A generic map.yaml is named by its
    folder, with the resolution scaled by the coarsening."""
    img = np.full((6, 6), 254)
    img[3, 2] = 0          # wall at (x 2, y 2): image row 3 from the top = y 2
    img[0, 4:6] = 205      # unknown at y 5, x 4..5
    path = _write_ros(tmp_path / "office", img)
    info = load_map_info(path, inflate=1, start=(0, 0), goal=(5, 0))
    lay = info.layers
    assert info.name == "office" and map_name(path) == "office"
    assert lay.wall.sum() == 1 and lay.wall[2, 2] and lay.unknown_blocked
    # around the wall, and around the unknown cells (blocked: they grow too)
    expected_margin = {(2, 1), (2, 3), (1, 2), (3, 2), (4, 4), (5, 4), (3, 5)}
    assert {(x, y) for y, x in zip(*np.nonzero(lay.margin))} == expected_margin
    assert {(x, y) for y, x in zip(*np.nonzero(lay.unknown))} == {(4, 5), (5, 5)}
    assert not (lay.wall & lay.margin).any() and not (lay.margin & lay.unknown).any()
    blocked = info.grid.blocked_np()
    np.testing.assert_array_equal(blocked, lay.wall | lay.margin | lay.unknown)
    coarse = load_map_info(path, inflate=1, coarsen=2, start=(0, 0), goal=(5, 0))
    assert coarse.grid.shape == (3, 3) and coarse.resolution == pytest.approx(0.2)
    assert coarse.frame.coarsen == 2 and coarse.frame.map_shape == (6, 6)
    assert coarse.layers.wall[1, 1] and coarse.layers.margin[1, 0] and coarse.layers.margin[2, 2]
    assert not coarse.layers.unknown.any()  # (4..5, 5) shares its block with margin (4, 4)
    free = load_map_info(path, unknown="free", start=(0, 0), goal=(5, 0))
    assert not free.layers.unknown_blocked and free.layers.unknown.sum() == 2
    assert not free.grid.blocked_np()[5, 4]


def test_an_endpoint_the_coarsening_blocks_is_named_in_both_frames(tmp_path):
    img = np.full((6, 6), 254)
    img[5, 1] = 0  # wall at (1, 0): shares the coarse block of (0, 0)
    path = _write_ros(tmp_path / "lab", img)
    with pytest.raises(EndpointError, match=r"the start, map cell \(0, 0\), lies in coarse "
                                            r"cell \(0, 0\) .* holds an obstacle"):
        load_map_info(path, coarsen=2, start=(0, 0), goal=(5, 5))



def test_a_coarsening_that_merges_start_and_goal_is_refused(tmp_path):
    """Start (1, 1) and goal (2, 2) of a free 8 x 8 map: coarsened 4 x 4 both lie in coarse
    cell (0, 0), which would plan a path of length 0 and call it a success; refused in
    one line naming both endpoints, the coarse cell and a factor that keeps them apart.
    Coarsened 2 x 2 they stay apart; a start equal to the goal is no merge; the grid
    function coarsen refuses the same merge."""
    from jaxga.core.grid import Grid
    from jaxga.maps import coarsen

    path = _write_ros(tmp_path / "hall", np.full((8, 8), 254))
    with pytest.raises(EndpointError) as e:
        load_map_info(path, coarsen=4, start=(1, 1), goal=(2, 2))
    text = str(e.value)
    assert "\n" not in text and "map.yaml" in text
    assert ("coarsened 4 x 4, the start (map cell (1, 1)) and the goal (map cell (2, 2)) fall "
            "into one coarse cell (0, 0)") in text and "a factor of 2 keeps them apart" in text
    ok = load_map_info(path, coarsen=2, start=(1, 1), goal=(2, 2)).grid
    assert (ok.start_xy, ok.goal_xy) == ((0, 0), (1, 1))
    same = load_map_info(path, coarsen=4, start=(1, 1), goal=(1, 1)).grid
    assert same.start_xy == same.goal_xy == (0, 0)
    with pytest.raises(EndpointError, match=r"the start \(map cell \(0, 0\)\) and the goal "
                                            r"\(map cell \(7, 7\)\) fall into one"):
        load_map_info(path, coarsen=8)  # the default corners, on a 1 x 1 coarse map
    grid = Grid.create(np.zeros((6, 6), bool), start=(0, 0), goal=(1, 0))
    with pytest.raises(EndpointError, match="fall into one coarse cell"):
        coarsen(grid, 2)
    assert coarsen(grid.replace(goal=(2, 0)), 2).goal_xy == (1, 0)

def _bfs(blocked, source, rule):
    """Breadth-first search over legal moves: an independent reachability reference."""
    h, w = blocked.shape
    legal = legal_moves(blocked, rule).reshape(8, -1)
    seen = np.zeros(h * w, bool)
    if blocked[source[1], source[0]]:
        return seen.reshape(h, w)
    start = source[1] * w + source[0]
    seen[start] = True
    queue = deque([start])
    while queue:
        p = queue.popleft()
        for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
            q = p + dy * w + dx
            if legal[d][p] and not seen[q]:
                seen[q] = True
                queue.append(q)
    return seen.reshape(h, w)


@pytest.mark.parametrize("rule", ["free", "no_squeeze", "strict"])
def test_reachable_cells_are_the_breadth_first_search_over_legal_moves(rule):
    rng = np.random.default_rng(7)
    for _ in range(300):
        h, w = rng.integers(1, 14, 2)
        b = rng.random((h, w)) < rng.random() * 0.6
        src = (int(rng.integers(w)), int(rng.integers(h)))
        np.testing.assert_array_equal(reachable_np(b, src, rule), _bfs(b, src, rule))


def test_path_files_in_metres_read_back(tmp_path):
    """CSV rows and a nav_msgs/Path YAML: positions as given, frame 'map', the yaw of each
    pose the direction to the next point (a repeated point takes the next direction; the
    last keeps the one it arrives with); other extensions are refused in one line."""
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, -2.0]])
    np.testing.assert_allclose(path_yaws(pts), [0, -math.pi / 2, -math.pi / 2, -math.pi / 2])
    np.testing.assert_allclose(path_yaws(pts[:1]), [0.0])
    write_path(tmp_path / "p.csv", pts)
    rows = np.loadtxt(tmp_path / "p.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(rows, pts)
    write_path(tmp_path / "p.yml", pts, frame_id="map")
    msg = yaml.safe_load((tmp_path / "p.yml").read_text())
    assert msg["header"]["frame_id"] == "map"
    q = msg["poses"][1]["pose"]["orientation"]
    assert (q["z"], q["w"]) == pytest.approx((-math.sqrt(0.5), math.sqrt(0.5)))
    assert [msg["poses"][3]["pose"]["position"][k] for k in "xyz"] == [1.0, -2.0, 0.0]
    assert path_format("a.YAML") == "yaml" and path_text(pts, "csv").startswith("x,y\n")
    with pytest.raises(JaxgaError, match=r"must be \.csv .* got '\.json'"):
        path_format("a.json")


def test_points_in_metres_are_written_apart_on_a_fine_map(tmp_path):
    """Written to 4 decimals, a path on a map of 10 um cells collapsed onto 0.0000 and
    0.0001 (and `replan` could not read the file back); the decimals follow the cells:
    4 on centimetre cells and coarser, a hundredth of a cell or finer below."""
    from jaxga.maps.frame import MapFrame, world_decimals

    assert [world_decimals(s) for s in (None, 1.0, 0.05, 0.01, 0.005, 1e-5, 1e-9)] == [
        4, 4, 4, 4, 5, 7, 11]
    frame = MapFrame(map_shape=(5, 9), resolution=1e-5, origin=(0.0, 0.0, 0.0))
    cells = np.array([[0, 2], [1, 2], [2, 2], [3, 3]], float)
    pts = frame.to_world(cells)
    assert frame.world_list(cells) == pts.round(7).tolist()
    assert len({tuple(p) for p in frame.world_list(cells)}) == 4
    for name in ("p.csv", "p.yaml"):
        write_path(tmp_path / name, pts)
        np.testing.assert_allclose(read_path(tmp_path / name), pts, rtol=0, atol=1e-8)
    # a waypoint path's long steps chose 4 decimals (10 cells here): the map's own
    # decimals are the least a path file is written to
    waypoints = frame.to_world(np.array([[0, 0], [900, 0]], float))
    write_path(tmp_path / "w.csv", waypoints, decimals=frame.world_decimals)
    np.testing.assert_allclose(read_path(tmp_path / "w.csv"), waypoints, rtol=0, atol=1e-8)
    coarse = MapFrame(map_shape=(5, 9), resolution=0.05, origin=(-2.0, -1.5, 0.0))
    assert path_text(coarse.to_world(cells), "csv").splitlines()[1] == "-1.9750,-1.3750"


def test_a_failed_write_leaves_the_previous_file_whole(tmp_path, monkeypatch):
    target = tmp_path / "out.json"
    target.write_text("previous")
    atomic_write_text(target, "new")
    assert target.read_text() == "new"

    def full_disk(*_a, **_k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("os.replace", full_disk)
    with pytest.raises(JaxgaError, match=r"cannot write .*out\.json: no space left on the device"):
        atomic_write_text(target, "newer")
    assert target.read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]  # no temporary file left


def test_the_time_line_lists_phases_in_order_and_the_rest_as_other():
    clock = iter([0.0, 1.0, 1.5, 2.0, 4.25, 5.0]).__next__
    t = Timeline(clock=clock)
    with t.phase("evolve"):
        pass
    with t.phase("load"):
        pass
    t.add("custom", 0.1)
    timing = t.as_dict()
    assert list(timing) == ["load_s", "evolve_s", "custom_s", "total_s"]
    assert timing == pytest.approx({"load_s": 2.25, "evolve_s": 0.5, "custom_s": 0.1,
                                    "total_s": 5.0})
    assert time_line(timing) == ("time (s): load 2.25, evolve 0.500, custom 0.100, "
                                 "other 2.150, total 5.00")
    assert time_line({"any_angle_s": 0.25, "total_s": 0.25}) == \
        "time (s): any-angle 0.250, total 0.25"
