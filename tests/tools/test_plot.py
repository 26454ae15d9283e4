"""Plots: each figure is rendered to a PNG and its artists (lines, boxes, markers, labels)
are checked against the results they draw."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import PathCollection, PolyCollection  # noqa: E402

from jaxga.compare import compare_results  # noqa: E402
from jaxga.maps import load_map, random_map  # noqa: E402
from jaxga.plot import (  # noqa: E402
    plot_box,
    plot_comparison,
    plot_diversity,
    plot_paths,
    plot_replan,
    plot_result,
    plot_seed_scatter,
)
from tests import canonical  # noqa: E402

# the canonical problems (tests/canonical.py): the programs of tests/api/test_api.py
SMALL = dict(generations=canonical.GENERATIONS, init__max_tries=40)
SEEDS = canonical.SEEDS


@pytest.fixture(scope="module")
def grid():
    return load_map(canonical.MAP)


@pytest.fixture(scope="module")
def comparison(grid):
    from jaxga import api

    return compare_results({name: api.run(name, grid, seeds=SEEDS, **SMALL)
                            for name in ("sga", "imga")})


def _save(ax_or_fig, path):
    fig = ax_or_fig if hasattr(ax_or_fig, "savefig") else ax_or_fig.figure
    fig.savefig(path)
    plt.close(fig)
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    assert np.ptp(img[..., :3]) > 0  # not a blank image


def test_plot_paths_draws_raw_and_post_optimised_paths_with_endpoints(comparison, grid,
                                                                      tmp_path):
    r = comparison.results["imga"]
    i = int(np.nanargmin(np.where(r.success, r.length, np.nan)))
    ax = plot_paths(r, grid)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    raw = next(v for k, v in lines.items() if k.startswith("raw ("))
    post = next(v for k, v in lines.items() if k.startswith("post-optimised ("))
    np.testing.assert_array_equal(np.c_[raw.get_xdata(), raw.get_ydata()],
                                  np.asarray(r.path(i, raw=True)))
    np.testing.assert_array_equal(np.c_[post.get_xdata(), post.get_ydata()],
                                  np.asarray(r.path(i)))
    assert f"{r.length[i]:.2f}" in post.get_label()
    assert tuple(lines["start"].get_xydata()[0]) == grid.start_xy
    assert tuple(lines["goal"].get_xydata()[0]) == grid.goal_xy
    assert len(ax.get_lines()) == 4 and f"seed {int(r.seeds[i])}" in ax.get_title()
    _save(ax, tmp_path / "paths.png")
    # another seed on a given axes
    fig, given = plt.subplots()
    assert plot_paths(r, grid, seed=0, ax=given) is given
    plt.close(fig)


def test_plot_paths_refuses_a_map_the_result_was_not_computed_on(comparison, grid):
    """Drawing a result on another map would show its paths crossing walls."""
    from jaxga.core.errors import ParameterError

    r = comparison.results["imga"]
    with pytest.raises(ParameterError, match="20 cells wide .* this map is 12 wide"):
        plot_paths(r, random_map(10, 12, 0.2, 3, corner_rule="free"))
    walls = np.asarray(grid.blocked).copy()
    i = int(np.flatnonzero(r.success)[0])
    x, y = r.path(i, raw=True)[1]
    walls[y, x] = True  # a wall on the drawn path: same size, another map
    with pytest.raises(ParameterError, match="do not fit this map"):
        plot_paths(r, grid.replace(blocked=walls), seed=i)
    with pytest.raises(ParameterError, match="do not fit this map"):
        plot_paths(r, grid.replace(goal=grid.start_xy), seed=i)  # other endpoints
    for seed in (SEEDS, -1, 1.0, True):
        with pytest.raises(ParameterError, match="index into result.seeds"):
            plot_paths(r, grid, seed=seed)
    plt.close("all")


def test_plot_diversity_one_curve_per_algorithm(comparison, tmp_path):
    ax = plot_diversity(comparison)
    assert [ln.get_label() for ln in ax.get_lines()] == ["sga", "imga"]
    assert sum(isinstance(c, PolyCollection) for c in ax.collections) == 2  # sd bands
    sd = comparison.results["sga"].history["std"]
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), sd.mean(axis=0))
    np.testing.assert_allclose(ax.get_lines()[0].get_xdata(), np.arange(1, sd.shape[1] + 1))
    assert ax.get_xlabel() == "generation" and ax.get_ylabel() == "population fitness sd"
    _save(ax, tmp_path / "diversity.png")
    runs = plot_diversity(comparison.results, per_run=True, relative=True)
    assert len(runs.get_lines()) == 2 * SEEDS and "mean fitness" in runs.get_ylabel()
    plt.close(runs.figure)


def test_plot_box_one_box_per_preset_with_optima(comparison, tmp_path):
    ax = plot_box(comparison)
    assert len(ax.patches) == 2  # one box each
    assert [t.get_text() for t in ax.get_xticklabels()] == ["sga", "imga"]
    refs = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    assert sorted(ln.get_ydata()[0] for ln in refs) == pytest.approx(
        sorted([comparison.any_angle_optimum, comparison.optimum]))
    # the median line of each box is the median of the successful seeds
    medians = [ln for ln in ax.get_lines() if ln.get_gid() == "median"]
    assert [m.get_ydata()[0] for m in medians] == pytest.approx(
        [np.nanmedian(comparison.values(k)) for k in ("sga", "imga")])
    assert ax.get_ylabel() == "length"
    _save(ax, tmp_path / "box.png")
    plain = plot_box({"a": [1.0, 2.0, np.nan], "b": [3.0, 4.0], "c": [5.0]}, metric="x")
    assert len(plain.patches) == 3 and not [ln for ln in plain.get_lines()
                                            if ln.get_linestyle() == "--"]
    plt.close(plain.figure)


def test_plot_seed_scatter_series_per_algorithm(comparison, tmp_path):
    ax = plot_seed_scatter(comparison)
    pts = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert [c.get_label() for c in pts] == ["sga", "imga"]
    for c, name in zip(pts, ("sga", "imga"), strict=True):
        r = comparison.results[name]
        off = c.get_offsets()
        assert len(off) == int(r.success.sum())
        np.testing.assert_allclose(off[:, 1], r.length[r.success])
        np.testing.assert_allclose(off[:, 0], r.seeds[r.success])
    assert ax.get_xlabel() == "seed" and ax.get_ylabel() == "length"
    _save(ax, tmp_path / "scatter.png")
    conv = plot_seed_scatter(comparison.results, y="fitness", x="convergence_generation")
    assert conv.get_xlabel() == "convergence generation"
    plt.close(conv.figure)


def test_plot_comparison_and_plot_result_figures(comparison, grid, tmp_path):
    fig = plot_comparison(comparison)
    a1, a2 = fig.axes
    assert len(a1.patches) == 2 and len(a2.collections) == 2
    _save(fig, tmp_path / "comparison.png")
    out = tmp_path / "result.png"
    fig = plot_result(comparison.results["imga"], grid, out)
    assert out.stat().st_size > 0
    a1, a2 = fig.axes
    assert len(a1.get_lines()) == 4 and a2.get_xlabel() == "generation"


def _renderer(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def test_the_legend_sits_outside_the_map_and_hides_no_cell(comparison, grid):
    ax = plot_paths(comparison.results["imga"], grid)
    r = _renderer(ax.figure)
    legend, box = ax.get_legend().get_window_extent(r), ax.get_window_extent(r)
    assert legend.x0 >= box.x1  # right of the map, not on it
    plt.close(ax.figure)


def test_identical_raw_and_post_optimised_paths_stay_distinguishable(comparison, grid):
    """A post-optimiser that changes nothing gives two equal polylines: the raw one is
    drawn wide and translucent under the post-optimised one, thin and dashed."""
    import dataclasses

    r = comparison.results["sga"]  # no post-optimiser: the two paths are the same
    i = int(np.flatnonzero(r.success)[0])
    assert r.path(i) == r.path(i, raw=True)
    r = dataclasses.replace(r, success=np.arange(SEEDS) == i)
    ax = plot_paths(r, grid)
    lines = {ln.get_label().split(" ")[0]: ln for ln in ax.get_lines()}
    raw, post = lines["raw"], lines["post-optimised"]
    assert raw.get_linewidth() > 2 * post.get_linewidth()
    assert post.get_linestyle() != raw.get_linestyle() and raw.get_alpha() < 1
    assert post.get_zorder() > raw.get_zorder() and raw.get_color() != post.get_color()
    assert f"best of 1 paths found ({SEEDS} seeds): seed {int(r.seeds[i])}" in ax.get_title()
    plt.close(ax.figure)


def test_a_saved_result_figure_holds_its_labels_and_legend(comparison, grid, tmp_path):
    """Saved cropped to everything drawn: every axis label, title and the legend lie in
    the figure's tight bounding box, and the PNG is exactly that box (and the crop's
    margin) at 110 dpi."""
    fig = plot_result(comparison.results["imga"], grid)
    r = _renderer(fig)
    tight = fig.get_tightbbox(r)  # inches
    box = tight.transformed(fig.dpi_scale_trans)  # display pixels
    texts = [t for ax in fig.axes for t in (ax.xaxis.label, ax.yaxis.label, ax.title)
             if t.get_text()]
    for artist in [*texts, fig.axes[0].get_legend()]:
        ext = artist.get_window_extent(r)
        assert box.x0 - 1 <= ext.x0 and ext.x1 <= box.x1 + 1, artist
        assert box.y0 - 1 <= ext.y0 and ext.y1 <= box.y1 + 1, artist
    plt.close(fig)
    out = tmp_path / "result.png"
    plot_result(comparison.results["imga"], grid, out)
    img = mpimg.imread(out)
    pad = 2 * matplotlib.rcParams["savefig.pad_inches"]  # the crop's margin, both sides
    assert abs(img.shape[1] - (tight.width + pad) * 110) <= 3, (img.shape, tight)
    assert abs(img.shape[0] - (tight.height + pad) * 110) <= 3, (img.shape, tight)


def test_a_run_without_a_path_says_so_in_both_panels(comparison, grid, tmp_path):
    import dataclasses

    r = comparison.results["sga"]
    nan = np.full(SEEDS, np.nan)
    none = dataclasses.replace(r, success=np.zeros(SEEDS, bool), length=nan, raw_length=nan,
                               fitness=nan)
    fig = plot_result(none, grid)
    said = [t for ax in fig.axes for t in ax.texts if t.get_gid() == "no-path"]
    assert len(said) == 2 and all("no path found" in t.get_text() for t in said)
    assert not fig.axes[1].get_lines()  # no flat fitness curve at 0
    assert f"0 of {SEEDS} seeds found a path" in fig.axes[1].get_title()
    plt.close(fig)
    # a comparison keeps the failed preset's box-plot column, labelled
    c = compare_results({"sga": none, "imga": comparison.results["imga"]})
    ax = plot_box(c)
    assert [t.get_text() for t in ax.get_xticklabels()] == ["sga", "imga"]
    assert [t.get_text() for t in ax.texts if t.get_gid() == "no-path"] == ["no path\nfound"]
    plt.close(ax.figure)


def test_main_effects_plot_takes_a_doe_result_or_its_json(tmp_path):
    from jaxga.plot import plot_main_effects

    doc = {"preset": "sga", "map": "m", "response": "length",
           "factors": {"population.size": [4, 6, 8]},
           "points": [{"coded": {"population.size": c}, "mean": m}
                      for c, m in ((-1, 30.0), (0, 29.0), (1, 28.5))]}

    class Doe:  # a DoeResult stands in: plot_main_effects reads its to_json()
        def to_json(self):
            return doc

    for data in (doc, Doe()):
        ax = plot_main_effects(data)
        line = ax.get_lines()[0]
        np.testing.assert_array_equal(line.get_ydata(), [30.0, 29.0, 28.5])
        plt.close(ax.figure)


def test_a_replan_figure_shows_the_old_path_the_obstacles_and_the_new_path(grid):
    """`jaxga replan --plot`: the old path dashed grey, the new obstacles as red squares,
    the robot's cell, the re-planned path from it (exactly the result's cells)."""
    from types import SimpleNamespace

    old = [(0, 0), (1, 1), (2, 2), (3, 3)]
    new = [(1, 1), (2, 1), (3, 2), (3, 3)]
    done = SimpleNamespace(success=True, path=new, length=3.41, status="replanned",
                           prefix=[(0, 0), (1, 1)], corner_rule="free")
    fig = plot_replan(done, grid.replace(start=(0, 0), goal=(3, 3)), old, [(2, 2)])
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    np.testing.assert_array_equal(lines["old path"].get_xydata(), old)
    assert lines["old path"].get_linestyle() == "--"
    np.testing.assert_array_equal(lines["re-planned (3.41)"].get_xydata(), new)
    assert tuple(lines["robot"].get_xydata()[0]) == (1, 1)
    squares = [c for c in ax.collections if c.get_label().startswith("new obstacles")]
    assert len(squares) == 1 and squares[0].get_offsets().tolist() == [[2, 2]]
    plt.close(fig)
    failed = SimpleNamespace(success=False, path=[], length=float("inf"),
                             status="unreachable", prefix=[(0, 0), (1, 1)],
                             corner_rule="free")
    fig = plot_replan(failed, grid.replace(start=(0, 0), goal=(3, 3)), old, [(2, 2)])
    assert [t.get_text() for t in fig.axes[0].texts] == ["no path found: unreachable"]
    plt.close(fig)


# ----------------------------------------------------------------------- robot maps
def _layers_map(unknown_blocked: bool = True):
    """A hand-made 6 x 8 robot map: a wall column at x = 3, its inflation margin at x = 2
    and x = 4, unknown space in the right column (x = 7); the rest free. Returns the grid
    and its MapLayers."""
    from jaxga.core.grid import Grid
    from jaxga.maps.loaders import MapLayers

    h, w = 6, 8
    wall, margin, unknown = (np.zeros((h, w), bool) for _ in range(3))
    wall[1:5, 3] = True
    margin[1:5, 2] = margin[1:5, 4] = True
    unknown[:, 7] = True
    blocked = wall | margin | (unknown if unknown_blocked else False)
    grid = Grid.create(blocked, start=(0, 0), goal=(6, 5), corner_rule="strict")
    return grid, MapLayers(wall, margin, unknown, unknown_blocked)


def _colour(key: str) -> tuple[int, int, int]:
    from jaxga.plot import CELL_CLASSES

    return next(rgb for k, _, rgb in CELL_CLASSES if k == key)


def _cell_image(ax) -> np.ndarray:
    images = [im for im in ax.get_images() if im.get_gid() == "map-cells"]
    assert len(images) == 1
    return np.asarray(images[0].get_array())


@pytest.mark.parametrize("unknown_blocked", [True, False])
def test_a_robot_map_draws_walls_margin_unknown_and_free_cells_in_their_own_shades(
        unknown_blocked):
    from jaxga.plot import CELL_CLASSES, plot_map

    grid, layers = _layers_map(unknown_blocked)
    ax = plot_map(grid, layers=layers)
    img = _cell_image(ax)
    assert img.shape == (6, 8, 3)
    unknown = "unknown_blocked" if unknown_blocked else "unknown_free"
    for (x, y), key in {(3, 2): "wall", (2, 2): "margin", (4, 4): "margin",
                        (7, 0): unknown, (7, 5): unknown, (0, 0): "free",
                        (3, 0): "free", (6, 5): "free"}.items():
        assert tuple(img[y, x]) == _colour(key), (x, y, key)  # row 0 at the bottom
    assert len({rgb for _, _, rgb in CELL_CLASSES}) == len(CELL_CLASSES)  # all distinct
    key = next(a for a in ax.get_children() if a.get_gid() == "cell-key")
    labels = [t.get_text() for t in key.get_texts()]
    assert labels == ["free", "unknown (planned as blocked)" if unknown_blocked
                      else "unknown (planned as free)", "wall", "inflation margin (blocked)"]
    plt.close(ax.figure)


def test_a_map_without_layers_is_black_on_white_as_before(grid):
    from jaxga.plot import plot_map

    ax = plot_map(grid)
    img = _cell_image(ax)
    expected = np.where(grid.blocked_np()[..., None], 0, 255)
    np.testing.assert_array_equal(img, np.broadcast_to(expected, img.shape))
    assert not [a for a in ax.get_children() if a.get_gid() == "cell-key"]
    assert ax.get_xlim() == (-0.5, 19.5) and ax.get_ylim() == (-0.5, 19.5)  # 20 x 20 cells
    assert ax.get_xlabel() == "" and ax.get_ylabel() == ""
    plt.close(ax.figure)


def test_a_large_map_is_one_image_not_a_patch_per_cell():
    """A 512 x 512 map draws as one image (a patch per cell would take minutes)."""
    import time

    from jaxga.maps.loaders import MapLayers
    from jaxga.plot import plot_map

    big = random_map(512, 512, 0.2, 3, corner_rule="free")
    b = big.blocked_np()
    layers = MapLayers(b, np.zeros_like(b), np.zeros_like(b))
    t0 = time.perf_counter()
    ax = plot_map(big, layers=layers)
    ax.figure.canvas.draw()
    seconds = time.perf_counter() - t0
    assert len(ax.get_images()) == 1 and not ax.patches and not ax.collections
    assert _cell_image(ax).shape == (512, 512, 3)
    assert seconds < 5.0  # about 0.2 s; generous for a loaded machine
    plt.close(ax.figure)


def _frame(shape, yaw: float = 0.0, resolution: float = 0.25):
    from jaxga.maps.frame import MapFrame

    return MapFrame(map_shape=shape, resolution=resolution, origin=(-1.5, 2.0, yaw))


def test_a_map_with_a_resolution_is_drawn_in_metres_in_the_world_frame():
    from jaxga.plot import plot_map

    grid, _ = _layers_map()
    frame = _frame(grid.shape)
    path = [(0, 0), (1, 1), (1, 2), (0, 3)]
    ax = plot_map(grid, [(path, "p")], frame=frame)
    world = (-1.5, -1.5 + 8 * 0.25, 2.0, 2.0 + 6 * 0.25)  # origin + W, H cells of 0.25 m
    assert ax.get_xlim() == pytest.approx(world[:2]) and ax.get_ylim() == pytest.approx(world[2:])
    assert _cell_image(ax).shape == (6, 8, 3)
    assert ax.get_images()[0].get_extent() == pytest.approx(world)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    np.testing.assert_allclose(lines["p"].get_xydata(), frame.to_world(np.array(path)))
    start = next(ln for k, ln in lines.items() if k.startswith("start"))
    np.testing.assert_allclose(start.get_xydata()[0], frame.to_world(np.array([0, 0])))
    assert start.get_label() == "start (-1.38, 2.12) m"  # the cell's centre
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
    plt.close(ax.figure)


def test_a_turned_map_is_drawn_in_metres_along_its_own_axes_and_says_so():
    import math

    from jaxga.plot import plot_map

    grid, _ = _layers_map()
    frame = _frame(grid.shape, yaw=math.pi / 6)
    ax = plot_map(grid, [([(1, 1), (2, 0)], "p")], frame=frame)
    assert ax.get_xlim() == pytest.approx((0, 2.0)) and ax.get_ylim() == pytest.approx((0, 1.5))
    line = next(ln for ln in ax.get_lines() if ln.get_label() == "p")
    np.testing.assert_allclose(line.get_xydata(), [(0.375, 0.375), (0.625, 0.125)])
    assert "along the map" in ax.get_xlabel() and "30°" in ax.get_xlabel()
    assert "(m" in ax.get_ylabel()
    plt.close(ax.figure)


def test_unknown_space_around_a_robot_map_is_cropped_from_the_view():
    """The axes span the mapped area (and the paths), not the unknown padding of a
    robot's map; the image still holds the whole map."""
    from jaxga.core.grid import Grid
    from jaxga.maps.loaders import MapLayers
    from jaxga.plot import plot_map

    unknown = np.ones((100, 100), bool)
    unknown[40:60, 30:50] = False  # the building
    blocked = unknown.copy()
    grid = Grid.create(blocked, start=(31, 41), goal=(48, 58), corner_rule="strict")
    layers = MapLayers(np.zeros_like(blocked), np.zeros_like(blocked), unknown)
    ax = plot_map(grid, layers=layers, frame=_frame(grid.shape, resolution=0.1))
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    # the building's cells 30..49 x 40..59 plus 3 cells a side, in metres from the origin
    assert (x0, x1) == pytest.approx((-1.5 + 2.7, -1.5 + 5.3))
    assert (y0, y1) == pytest.approx((2.0 + 3.7, 2.0 + 6.3))
    assert ax.get_images()[0].get_extent() == pytest.approx((-1.5, 8.5, 2.0, 12.0))
    plt.close(ax.figure)


@pytest.fixture(scope="module")
def office(comparison, grid, tmp_path_factory):
    """The fixture map saved as a ROS map ``office/map.yaml`` (0.25 m cells, origin
    (-1.5, 2.0)) and loaded back, and the imga result moved onto it."""
    import dataclasses

    from jaxga.maps import load_map_info, save_map

    folder = tmp_path_factory.mktemp("maps") / "office"
    folder.mkdir()
    path = save_map(grid, folder / "map.yaml", fmt="ros", resolution=0.25,
                    origin=(-1.5, 2.0, 0.0))
    info = load_map_info(path, start=grid.start_xy, goal=grid.goal_xy, corner_rule="free")
    assert info.name == "office" and info.frame.has_metres
    np.testing.assert_array_equal(info.grid.blocked_np(), grid.blocked_np())
    r = dataclasses.replace(comparison.results["imga"], frame=info.frame,
                            map_name=info.name)
    return r, info


def test_a_result_on_a_ros_map_is_drawn_in_metres_titled_with_the_map(office, tmp_path):
    r, info = office
    i = int(np.nanargmin(np.where(r.success, r.length, np.nan)))
    fig = plot_result(r, info.grid, tmp_path / "office.png", info=info)
    a1 = fig.axes[0]
    title = a1.get_title()
    assert "office" in title and r.preset in title and repr(r.corner_rule) in title
    assert a1.get_xlim() == pytest.approx((-1.5, 3.5)) and a1.get_ylim() == pytest.approx(
        (2.0, 7.0))  # 20 x 20 cells of 0.25 m from the origin
    post = next(ln for ln in a1.get_lines() if ln.get_label().startswith("post-optimised"))
    np.testing.assert_allclose(post.get_xydata(), r.world_path(i))
    assert f"{r.length[i] * 0.25:.2f} m" in post.get_label()
    assert mpimg.imread(tmp_path / "office.png").shape[0] > 100


def test_the_map_name_comes_from_the_result_without_info(office):
    r, info = office
    ax = plot_paths(r, info.grid)  # result.frame: metres without the MapInfo
    assert "office" in ax.get_title() and ax.get_xlabel() == "x (m)"
    plt.close(ax.figure)


def test_a_replan_figure_uses_the_paths_ends_and_names_the_map(grid):
    """The start and goal drawn are the old path's ends, not the map's corners; the
    title names the map, the preset and the corner rule."""
    from types import SimpleNamespace

    from jaxga.maps import MapInfo
    from jaxga.maps.frame import MapFrame

    info = MapInfo(name="lab", path=None, format="ros", builtin=False, grid=grid,
                   frame=MapFrame(map_shape=grid.shape))
    old = [(2, 1), (3, 2), (4, 3), (5, 5)]
    done = SimpleNamespace(success=True, path=old[1:], length=3.65, status="replanned",
                           prefix=old[:2], corner_rule="free",
                           ga=[SimpleNamespace(preset="hybrid", map_name="lab")])
    assert grid.start_xy != old[0] and grid.goal_xy != old[-1]
    fig = plot_replan(done, grid, old, [(4, 4)], info=info)
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    assert tuple(lines["start"].get_xydata()[0]) == old[0]
    assert tuple(lines["goal"].get_xydata()[0]) == old[-1]
    title = ax.get_title()
    assert "lab" in title and "hybrid" in title and "'free'" in title
    plt.close(fig)


# ------------------------------------------------------------------------ convergence
def _history(values: np.ndarray) -> dict:
    values = np.asarray(values, float)
    return {"best": values, "mean": values, "std": np.zeros_like(values)}


def _drawn(ax):
    ax.figure.canvas.draw()
    return [t.get_text() for t in ax.get_yticklabels() if t.get_text()]


def test_the_fitness_axis_has_plain_labels_without_an_offset():
    """Values like 9.6903e-3 with float noise of 1e-9: no "1e-9+9.6903e-3" offset."""
    from jaxga.plot import plot_convergence

    rng = np.random.default_rng(0)
    noisy = 9.6903e-3 + 1e-9 * rng.random((3, 30))
    ax = plot_convergence(_history(noisy))
    labels = _drawn(ax)
    assert ax.yaxis.get_offset_text().get_text() == ""
    assert len(set(labels)) == len(labels) >= 3 and all("e" not in t for t in labels)
    lo, hi = ax.get_ylim()
    assert lo < 9.6903e-3 < hi and hi - lo > 1e-5  # the line mid-panel, not filling it
    plt.close(ax.figure)
    # a small real improvement: ticks written with as many digits as they need
    rising = np.linspace(9.6903e-3, 9.6909e-3, 30)[None, :] + np.zeros((3, 1))
    ax = plot_convergence(_history(rising))
    labels = _drawn(ax)
    assert ax.yaxis.get_offset_text().get_text() == ""
    assert len(set(labels)) == len(labels) >= 3
    locs = ax.get_yticks()  # each label is its tick's value, to a hundredth of a step
    np.testing.assert_allclose([float(t) for t in labels], locs,
                               atol=np.min(np.diff(locs)) / 100)
    assert not [t for t in ax.texts if t.get_gid() == "flat-note"]
    assert "(+0.00619 %)" in ax.get_lines()[0].get_label()  # the relative change
    plt.close(ax.figure)


def test_a_flat_convergence_curve_says_the_initial_population_held_the_best():
    from jaxga.plot import plot_convergence

    flat = np.full((4, 20), 2.32279e-3)
    ax = plot_convergence(_history(flat), success=np.ones(4, bool),
                          initial=np.full(4, 2.32279e-3))
    notes = [t.get_text() for t in ax.texts if t.get_gid() == "flat-note"]
    assert len(notes) == 1 and "unchanged from generation 0" in notes[0]
    assert "initial population already held it" in notes[0]
    assert ax.get_lines()[0].get_xdata()[0] == 0  # generation 0: the initial population
    plt.close(ax.figure)
    ax = plot_convergence(_history(flat))  # no initial fitness: generations 1..20
    notes = [t.get_text() for t in ax.texts if t.get_gid() == "flat-note"]
    assert len(notes) == 1 and "unchanged over generations 1 to 20" in notes[0]
    plt.close(ax.figure)
    some = np.r_[flat[:2], np.linspace(1e-3, 2e-3, 20)[None].repeat(2, axis=0)]
    ax = plot_convergence(_history(some))
    notes = [t.get_text() for t in ax.texts if t.get_gid() == "flat-note"]
    assert notes == ["best fitness unchanged in 2 of 4 seeds"]
    plt.close(ax.figure)


def test_a_result_figure_notes_a_run_that_the_initial_population_solved(comparison, grid):
    import dataclasses

    r = comparison.results["imga"]
    best = np.asarray(r.fitness, float)
    solved = dataclasses.replace(
        r, initial_fitness=best,
        history={**r.history, "best": np.repeat(best[:, None], r.history["best"].shape[1],
                                                axis=1)})
    fig = plot_result(solved, grid)
    notes = [t.get_text() for t in fig.axes[1].texts if t.get_gid() == "flat-note"]
    assert len(notes) == 1 and "generation 0" in notes[0]
    assert fig.axes[1].yaxis.get_offset_text().get_text() == ""
    plt.close(fig)
