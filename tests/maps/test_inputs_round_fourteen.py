"""Round fourteen (decision 062): what a robot is given after the GA, read by a reviewer
with hand-made cases: a coarsened map's last blocks in metres, replan's index into the
path as given, path files written and read back, the curve functions' inputs.

Each test is cheap: no whole GA is compiled."""

from __future__ import annotations

import numpy as np
import pytest

from jaxga import Grid
from jaxga.bspline import curve_points
from jaxga.core.errors import EndpointError, JaxgaError, ParameterError
from jaxga.curve_clearance import verify_curve
from jaxga.export import read_path, write_path
from jaxga.maps.clearance import ObstacleClearance
from jaxga.maps.frame import MapFrame
from jaxga.maps.preprocess import block_middle_cells, blocks_to_map, map_to_blocks
from jaxga.replan import replan


def test_a_last_block_past_the_map_is_drawn_on_its_part_of_the_map():
    """A 5 x 5 map of 1 m cells coarsened 4 x 4: planning cell 1 is map cell 4 alone
    (the block 4..8 reaches past the map), so its centre is 4.5 m, not 6 m, and it is
    named by map cell 4; points off the map (7.9 m) are refused although they fall in
    that block; every world point maps back to its planning cell."""
    f = MapFrame(map_shape=(5, 5), coarsen=4, resolution=1.0, origin=(0.0, 0.0, 0.0))
    np.testing.assert_allclose(f.to_world(np.array([[1, 1], [0, 0], [1, 0]])),
                               [[4.5, 4.5], [2.0, 2.0], [4.5, 2.0]])
    assert f.map_cell(np.array([1, 1])).tolist() == [4, 4]
    assert f.cell_of((4.5, 4.5), (2, 2)) == (1, 1)
    assert f.cell_of((4.999, 0.5), (2, 2)) == (1, 0)
    for far in ((7.9, 7.9), (5.0, 0.5), (0.5, 5.2)):
        with pytest.raises(EndpointError, match="is off the map: it covers x 0..5 m"):
            f.cell_of(far, (2, 2), "the goal")


def test_world_points_and_planning_cells_are_inverses_on_a_turned_coarsened_map():
    """7 x 9 map cells of 0.5 m coarsened 4 x 4, origin (-1, 2) turned by 0.3 rad: the
    last blocks hold 1 and 3 map cells; a curve's points (not only centres) map to
    metres and back within float rounding, and stay on the map."""
    f = MapFrame(map_shape=(7, 9), coarsen=4, resolution=0.5, origin=(-1.0, 2.0, 0.3))
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.5, [1.5, 1.5], size=(200, 2))  # planning cells 0..2 x 0..1
    back = np.array([f.cell_coordinates(tuple(q)) for q in f.to_world(pts)]) - 0.5
    np.testing.assert_allclose(back, pts, atol=1e-8)
    edges = blocks_to_map(pts + 0.5, 4, (7, 9))
    assert (edges >= 0).all() and (edges <= [9, 7]).all()
    np.testing.assert_allclose(map_to_blocks(edges, 4, (7, 9)), pts + 0.5, atol=1e-12)
    # a full block keeps its bits: K times the planning position
    assert blocks_to_map(np.array([1.5, 0.5]), 4, (7, 9)).tolist() == [6.0, 2.0]


def test_a_blocks_middle_cell_is_found_in_integers(tmp_path):
    """The middle of a last block's part lies on a cell edge when the part is even; the
    float floor chose the cell below for some factors (K = 47, part 6: 2, not 3). The
    integer rule names the cell above, for every factor and part; replan's conversion
    between coarsenings (it kept the old formula) uses it."""
    for k in range(2, 65):
        for part in range(1, k):
            size = 3 * k + part
            got = block_middle_cells(np.array([[3, 0]]), k, (k, size))
            assert got.tolist() == [[3 * k + part // 2, k // 2]], (k, part)
    assert block_middle_cells(np.array([[3, 3]]), 47, (147, 147)).tolist() == [[144, 144]]
    from jaxga.cli.replan import read_path_json

    path = tmp_path / "planned.json"
    path.write_text('{"frame": {"coarsen": 5, "map_shape": [13, 13]}, '
                    '"runs": [{"success": true, "length": 2.9, "path": [[0, 0], [2, 2]]}]}')
    # block 2 of 13 cells by 5 is cells 10..12: middle 11, planning cell 5 at K = 2
    assert read_path_json(str(path), None, frame=MapFrame(map_shape=(13, 13),
                                                          coarsen=2)) == [(1, 1), (5, 5)]


def test_the_plot_draws_a_coarsened_map_where_its_paths_are(tmp_path):
    """The last block of a 10-cell side coarsened by 3 is one map cell wide: the plot's
    cells are drawn in map cells over the map's extent, and a path's points (yaw 0 or
    turned) at the middle of that cell, as --path-out writes them."""
    import matplotlib

    matplotlib.use("Agg")
    from jaxga.plot import MapView, plot_map

    blocked = np.zeros((4, 4), bool)
    blocked[0, 3] = True  # the last block of the bottom row
    g = Grid.create(blocked, start=(0, 3), goal=(3, 3))
    for yaw in (0.0, 0.5):
        f = MapFrame(map_shape=(10, 10), coarsen=3, resolution=1.0, origin=(0.0, 0.0, yaw))
        view = MapView(f)  # yaw 0: the world frame; else metres along the map's axes
        np.testing.assert_allclose(view.xy(np.array([3.0, 0.0])), [9.5, 1.5])
        np.testing.assert_allclose(view.extent((4, 4)), (0.0, 10.0, 0.0, 10.0))
        ax = plot_map(g, [([(0, 3), (3, 3)], "p")], frame=f)
        image = next(a for a in ax.get_images() if a.get_gid() == "map-cells")
        assert image.get_array().shape[:2] == (10, 10)
        assert image.get_array()[0, 9].tolist() != image.get_array()[0, 8].tolist()
        np.testing.assert_allclose(ax.lines[0].get_xydata(),
                                   view.xy(np.array([[0, 3], [3, 3]], float)))


def test_the_clearance_of_a_coarsened_path_is_measured_where_it_is_drawn():
    """An obstacle at map cell (0, 4) of a 5 x 5 map coarsened 4 x 4: the path through
    planning cells (0, 0) and (0, 1) runs from map point (1.5, 1.5) to (1.5, 4), the
    middle of the last block's part on the map, so it passes 1 cell from the obstacle's
    square (not through a point at y = 5.5, off the map)."""
    obstacles = np.zeros((5, 5), bool)
    obstacles[4, 0] = True
    c = ObstacleClearance(obstacles, coarsen=4)
    np.testing.assert_allclose(c.map_points(np.array([[0, 0], [0, 1]])),
                               [[1.5, 1.5], [1.5, 4.0]])
    assert c.of_path(np.array([[0, 0], [0, 1]])) == pytest.approx(1.0)


def test_an_index_into_replans_path_counts_the_path_as_given():
    """A path that waits a step at its start (its first cell twice): index 2 is the
    cell (1, 0) of the path given, not of the path without the repeat, and the last
    index, 6, is the goal."""
    g = Grid.create(np.zeros((6, 6), bool), start=(0, 0), goal=(5, 0))
    path = [(0, 0), (0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (5, 0)]
    assert replan(g, path, [], 2).path[0] == (1, 0)
    assert replan(g, path, [], 1).path[0] == (0, 0)
    assert replan(g, path, [], 6).path == [(5, 0)]
    with pytest.raises(ParameterError, match=r"position index 7 is outside the path \(0..6\)"):
        replan(g, path, [], 7)


def test_a_path_file_reads_back_what_was_written_even_empty(tmp_path):
    """The empty path written for an unreachable goal reads back as no points (it was
    refused as empty), and a CSV a spreadsheet saved with a byte-order mark reads."""
    for name in ("none.csv", "none.yaml"):
        write_path(tmp_path / name, np.zeros((0, 2)))
        got = read_path(tmp_path / name)
        assert got.shape == (0, 2)
    (tmp_path / "excel.csv").write_bytes(b"\xef\xbb\xbfx,y\r\n1.5,2\r\n3,-4\r\n")
    assert read_path(tmp_path / "excel.csv").tolist() == [[1.5, 2.0], [3.0, -4.0]]


def test_replan_of_an_empty_path_file_says_so_in_one_line(tmp_path):
    from jaxga.cli.replan import read_robot_path
    from jaxga.maps import load_map_info

    write_path(tmp_path / "none.csv", np.zeros((0, 2)))
    info = load_map_info("docs/examples/office.yaml")
    args = type("A", (), {"path_json": None, "run": None, "raw": False,
                          "path": str(tmp_path / "none.csv")})()
    with pytest.raises(JaxgaError, match="holds no points .* nothing to re-plan"):
        read_robot_path(args, info, "free")


@pytest.mark.parametrize("call, message", [
    (lambda g: curve_points(np.zeros((3, 2))), "shape \\[M, 2\\] with M >= 4"),
    (lambda g: curve_points(np.zeros((2, 5))), "shape \\[M, 2\\] with M >= 4"),
    (lambda g: curve_points(np.zeros((5, 2)), per_span=0), "per_span must be an integer"),
    (lambda g: verify_curve(g, np.zeros((3, 2))), "shape \\[M, 2\\] with M >= 4"),
    (lambda g: verify_curve(g, np.ones((5, 2)), per_span=0), "per_span must be an integer"),
    (lambda g: verify_curve(g, np.ones((5, 2)), refine_factor=1.5),
     "refine_factor must be an integer"),
])
def test_the_curve_functions_refuse_what_is_not_a_spline_in_one_line(call, message):
    with pytest.raises(ParameterError, match=message):
        call(Grid.create(np.zeros((6, 6), bool)))
