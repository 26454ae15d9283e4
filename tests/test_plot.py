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
from jaxga.maps import random_map  # noqa: E402
from jaxga.plot import (  # noqa: E402
    plot_box,
    plot_comparison,
    plot_diversity,
    plot_paths,
    plot_replan,
    plot_result,
    plot_seed_scatter,
)

# the map and settings of tests/test_api.py and tests/test_compare.py (shared programs)
SMALL = dict(population__size=8, generations=3, init__max_tries=40)
SEEDS = 3


@pytest.fixture(scope="module")
def grid():
    return random_map(10, 10, 0.2, 3, corner_rule="free")


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
    with pytest.raises(ParameterError, match="10 cells wide"):
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
