"""Matplotlib figures: the map with paths, convergence and diversity curves, comparisons.

Every function takes ``ax=None`` (a new figure when None) and returns the axes (the
``plot_result`` / ``plot_comparison`` figures return the figure).

Maps are drawn with ``origin="lower"`` (row 0 at the bottom, SPEC 1); cell ``(x, y)`` is
the unit square centred on ``(x, y)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxga.compare import metric_values
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, as_integer
from jaxga.maps import load_map

__all__ = ["plot_box", "plot_comparison", "plot_convergence", "plot_diversity",
           "plot_main_effects", "plot_map", "plot_paths", "plot_replan", "plot_result",
           "plot_seed_scatter"]


def _pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        try:
            matplotlib.use("Agg", force=False)
        except Exception:  # pragma: no cover - a GUI backend already in use
            pass
    import matplotlib.pyplot as plt

    return plt


PATH_STYLES = (
    {"lw": 4.0, "alpha": 0.45, "solid_capstyle": "round", "zorder": 2},
    {"lw": 1.3, "ls": "--", "marker": "o", "ms": 2.5, "zorder": 3},
    {"lw": 1.0, "ls": ":", "marker": "x", "ms": 3.0, "zorder": 4},
)
"""Line styles of the paths of :func:`plot_map`, in order: a wide translucent line under a
thin dashed one, so that two paths that coincide (a raw path the post-optimiser left as
it was) both stay visible."""


def plot_map(grid: Grid, paths: Sequence[tuple[Sequence[tuple[int, int]], str]] = (), ax=None):
    """Draw the map (obstacles black), start/goal markers and ``(path, label)`` polylines
    (styles :data:`PATH_STYLES`); the legend sits outside the map, right of it, so that
    it hides no cell."""
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.2, 5))
    b = grid.blocked_np()
    ax.imshow(b, origin="lower", cmap="Greys", vmin=0, vmax=1,
              extent=(-0.5, grid.width - 0.5, -0.5, grid.height - 0.5))
    for i, (path, label) in enumerate(paths):
        if path is not None and len(path):
            xy = np.asarray(path, float)
            ax.plot(xy[:, 0], xy[:, 1], label=label, color=f"C{i}",
                    **PATH_STYLES[i % len(PATH_STYLES)])
    (sx, sy), (gx, gy) = grid.start_xy, grid.goal_xy
    ax.plot([sx], [sy], "go", ms=8, label="start")
    ax.plot([gx], [gy], "r*", ms=11, label="goal")
    ax.set_xlim(-0.5, grid.width - 0.5)
    ax.set_ylim(-0.5, grid.height - 0.5)
    ax.set_aspect("equal")
    _legend_outside(ax)
    return ax


def _legend_outside(ax) -> None:
    """The legend right of the axes, outside the map, so that it hides no cell."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=7)


def _no_path(ax, what: str = "no path found") -> None:
    """Say in the middle of ``ax`` that there is nothing to draw."""
    ax.text(0.5, 0.5, what, transform=ax.transAxes, ha="center", va="center", fontsize=11,
            color="firebrick", gid="no-path",
            bbox={"boxstyle": "round", "facecolor": "white", "edgecolor": "firebrick"})


def plot_convergence(histories: dict[str, np.ndarray], ax=None, label: str = "",
                     success: np.ndarray | None = None):
    """Best-so-far fitness per generation: mean over seeds with a +-1 sd band; with
    ``success``, over the seeds that found a path only (a failed seed's fitness is no
    value), and "no path found" when none did."""
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 3.5))
    best = np.asarray(histories["best"], float)
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness")
    which = "seeds"
    if success is not None:
        success = np.asarray(success, bool)
        if not success.any() or best.shape[1] == 0:
            _no_path(ax, "no path found: no fitness to plot")
            return ax
        best = best[success]
        which = f"the {int(success.sum())} seeds with a path"
    gens = np.arange(1, best.shape[1] + 1)
    mean, sd = best.mean(axis=0), best.std(axis=0)
    ax.plot(gens, mean, label=(label + " " if label else "") + f"best fitness (mean over {which})")
    ax.fill_between(gens, mean - sd, mean + sd, alpha=0.25)
    ax.legend(fontsize=7)
    return ax


def plot_paths(result, grid: Grid | str, seed: int | None = None, ax=None):
    """The map with one run's raw and post-optimised paths and the start/goal markers.

    ``seed`` is an index into ``result.seeds`` (default: the successful run with the
    shortest post-optimised length). Raw = the GA's own best path, post-optimised = after
    the preset's post-optimiser (SPEC 9); the legend gives both lengths.
    """
    grid = _as_grid(grid, result.corner_rule)
    if grid.width != result.width:
        raise ParameterError(f"the result is on a map {result.width} cells wide "
                             f"({result.map_name}), this map is {grid.width} wide")
    paths = []
    chosen = seed is None
    if seed is None and result.success.any():
        seed = int(np.nanargmin(np.where(result.success, result.length, np.nan)))
    if seed is not None:
        try:
            index = as_integer(seed)
        except TypeError:  # 1.0 or True: refused just below
            index = -1
        if not 0 <= index < len(result.seeds):
            raise ParameterError(f"seed is an integer index into result.seeds, "
                                 f"0..{len(result.seeds) - 1}; got {seed!r}")
        seed = index
    if seed is not None and result.success[seed]:
        paths = [(result.path(seed, raw=True), f"raw ({result.raw_length[seed]:.2f})"),
                 (result.path(seed), f"post-optimised ({result.length[seed]:.2f})")]
        _check_paths_fit(grid, result, [p for p, _ in paths])
    ax = plot_map(grid, paths, ax=ax)
    title = f"{result.preset} on {result.map_name}"
    n_ok = int(np.sum(result.success))
    if seed is not None and result.success[seed]:
        title += (f"\nbest of {n_ok} paths found ({len(result.seeds)} seeds): seed "
                  f"{int(result.seeds[seed])}" if chosen else f", seed {int(result.seeds[seed])}")
    else:
        which = (f"seed {int(result.seeds[seed])}" if seed is not None
                 else f"any of {len(result.seeds)} seeds")
        title += f"\nno path found by {which}"
        _no_path(ax)
    ax.set_title(title, fontsize=9)
    return ax


def _check_paths_fit(grid: Grid, result: Any, paths: list[list[tuple[int, int]]]) -> None:
    """Refuse to draw a result on a map it was not computed on (same width, but another
    map or other endpoints): its paths would cross walls in the picture."""
    blocked = grid.blocked_np()
    h = blocked.shape[0]
    for path in paths:
        ends = (path[0], path[-1]) == (grid.start_xy, grid.goal_xy)
        if not ends or any(not 0 <= y < h or blocked[y, x] for x, y in path):
            raise ParameterError(
                f"the result's paths ({result.map_name}, {path[0]} -> {path[-1]}) do not fit "
                f"this map (start {grid.start_xy}, goal {grid.goal_xy}): pass the map and "
                f"endpoints the result was computed on")


def _as_grid(grid: Grid | str, corner_rule: str) -> Grid:
    if isinstance(grid, Grid):
        return grid

    return load_map(grid, corner_rule=corner_rule)


def _labelled(results) -> dict:
    """A Result, a sequence of Results, a mapping label -> Result, or a Comparison."""
    if hasattr(results, "results") and isinstance(results.results, dict):  # Comparison
        return dict(results.results)
    if hasattr(results, "history"):  # one Result
        return {results.preset: results}
    if isinstance(results, dict):
        return dict(results)
    return {r.preset: r for r in results}


def plot_diversity(results, ax=None, per_run: bool = False, relative: bool = False):
    """Population diversity per generation: the population's fitness sd (MPMGA Fig. 16).

    One curve per algorithm on one axes (``results``: a Result, a mapping label -> Result
    or a :class:`~jaxga.compare.Comparison`): the mean over seeds of the per-generation
    fitness standard deviation with a +-1 sd band over seeds, or with ``per_run`` every
    seed's curve (thin lines). MPMGA measures diversity by this sd. Fitness functions
    differ between presets, so raw sds of different presets are on different scales;
    ``relative`` divides each generation's sd by the population mean fitness (the
    coefficient of variation), which is scale-free.
    """
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 3.5))
    for i, (label, r) in enumerate(_labelled(results).items()):
        sd = np.asarray(r.history["std"], float)
        if relative:
            sd = sd / np.asarray(r.history["mean"], float)
        gens = np.arange(1, sd.shape[1] + 1)
        colour = f"C{i % 10}"
        if per_run:
            for j, row in enumerate(sd):
                ax.plot(gens, row, color=colour, lw=0.6, alpha=0.5,
                        label=label if j == 0 else None)
        else:
            mean, spread = sd.mean(axis=0), sd.std(axis=0)
            ax.plot(gens, mean, color=colour, label=label)
            ax.fill_between(gens, mean - spread, mean + spread, color=colour, alpha=0.2)
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness sd / mean fitness" if relative else "population fitness sd")
    ax.legend(fontsize=7)
    return ax


def plot_box(data, metric: str | None = None, ax=None, reference: dict | None = None):
    """Box plots of a metric, one box per preset (failed seeds left out).

    ``data`` is a :class:`~jaxga.compare.Comparison` (``metric`` defaults to its main
    metric, and the optima are drawn as horizontal reference lines: the any-angle
    optimum for post-optimised lengths, the exact 8-connected optimum for raw and
    post-optimised lengths, 0 for gaps) or a mapping label -> per-seed values (NaN =
    failed) with optional ``reference`` lines ``{label: value}``.
    """
    plt = _pyplot()
    if ax is None:
        n = len(data.results) if hasattr(data, "results") else len(data)
        _, ax = plt.subplots(figsize=(1.1 * max(4, n) + 1, 3.8))
    if hasattr(data, "results"):
        metric = metric or data.metric
        values = {k: data.values(k, metric) for k in data.labels}
        if reference is None:
            reference = {}
            if metric == "length":
                reference["any-angle optimum"] = data.any_angle_optimum
            if metric in ("length", "raw_length"):
                reference["8-connected optimum"] = data.optimum
            if metric in ("gap", "raw_gap", "fitness_gap"):
                reference["optimum"] = 0.0
    else:
        values = {k: np.asarray(v, float) for k, v in data.items()}
        metric = metric or "value"
    clean = [v[np.isfinite(v)] for v in values.values()]
    drawn = [i for i, v in enumerate(clean) if v.size]
    if drawn:
        ax.boxplot([clean[i] for i in drawn], positions=[i + 1 for i in drawn],
                   patch_artist=True, boxprops={"facecolor": "#cfe2f3"},
                   medianprops={"color": "k", "gid": "median"})
    for i, v in enumerate(clean):
        if not v.size:  # a preset that found no path keeps its column, saying so
            ax.text(i + 1, 0.5, "no path\nfound", transform=ax.get_xaxis_transform(),
                    ha="center", va="center", fontsize=8, color="firebrick", gid="no-path")
    ax.set_xticks(range(1, len(clean) + 1), labels=list(values))
    ax.set_xlim(0.5, len(clean) + 0.5)
    for i, (label, y) in enumerate((reference or {}).items()):
        ax.axhline(y, color=f"C{(i + 3) % 10}", ls="--", lw=1, label=f"{label} ({y:.4g})")
    if reference:
        ax.legend(fontsize=7)
    ax.set_xlabel("preset")
    ax.set_ylabel(metric.replace("_", " "))
    return ax


def plot_seed_scatter(results, y: str = "length", x: str = "seed", ax=None):
    """Per-seed results, one series per algorithm (AGACD Figs. 8-10).

    ``x = "seed"`` puts the seed on the horizontal axis (AGACD plots the best fitness,
    the convergence generation and the time of each of its 20 runs against the run
    number);
    otherwise ``x`` is a second metric, e.g. ``x="convergence_generation"`` for length
    against convergence speed. ``y`` / ``x`` are :data:`jaxga.compare.METRICS` or
    ``"fitness"``; failed seeds are not drawn. (Per-run times do not exist: the seeds
    of a preset run in one vectorised call.)
    """

    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 3.5))
    markers = "os^vDP*Xh<>"
    for i, (label, r) in enumerate(_labelled(results).items()):
        yv = metric_values(r, y)
        xv = np.asarray(r.seeds, float) if x == "seed" else metric_values(r, x)
        ok = np.isfinite(xv) & np.isfinite(yv)
        ax.scatter(xv[ok], yv[ok], s=18, marker=markers[i % len(markers)], label=label,
                   alpha=0.8)
    if x in ("seed", "convergence_generation", "turns"):
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(x.replace("_", " "))
    ax.set_ylabel(y.replace("_", " "))
    ax.legend(fontsize=7)
    return ax


def plot_comparison(comparison, out: str | Path | None = None, metric: str | None = None):
    """``jaxga compare --plot``: box plots of the metric (optima as reference lines) and
    the per-seed scatter of the metric against the convergence generation."""
    plt = _pyplot()
    n = len(comparison.results)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(max(10, 1.2 * n + 6), 4.2))
    metric = metric or comparison.metric
    plot_box(comparison, metric, ax=a1)
    a1.set_title(f"{metric} on {next(iter(comparison.results.values())).map_name}")
    plot_seed_scatter(comparison, y=metric, x="convergence_generation", ax=a2)
    a2.set_title(f"{len(next(iter(comparison.results.values())).seeds)} seeds per preset")
    return _finish(fig, out)


def _finish(fig, out: str | Path | None):
    """Lay the figure out; with ``out``, save it there (110 dpi, cropped to everything
    drawn: ``bbox_inches="tight"`` keeps the axis labels and the outside legend) and
    close it."""
    fig.tight_layout()
    if out is not None:
        fig.savefig(out, dpi=110, bbox_inches="tight")
        _pyplot().close(fig)
    return fig


def plot_main_effects(doe_json: Any, ax=None):
    """DOE main-effects plot (AGACD 5.2.1): mean response at coded level -1, 0, 1, one
    line per factor (its real levels in the legend); dashed: the grand mean of the design
    points.

    ``doe_json`` is a :class:`jaxga.doe.DoeResult` or its ``jaxga doe --json`` layout
    (``factors``, ``points`` with ``coded`` and ``mean``, ``response``); the level means
    are computed from the points (points without a mean left out). Returns the axes.
    """
    plt = _pyplot()
    if hasattr(doe_json, "to_json"):
        doe_json = doe_json.to_json()
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    points = [p for p in doe_json["points"] if p.get("mean") is not None]
    levels = (-1, 0, 1)
    for name, real in doe_json["factors"].items():
        means = []
        for level in levels:
            v = [p["mean"] for p in points if p["coded"][name] == level]
            means.append(float(np.mean(v)) if v else np.nan)
        ax.plot(levels, means, marker="o",
                label=f"{name} ({', '.join(f'{r:g}' for r in real)})")
    if points:
        ax.axhline(float(np.mean([p["mean"] for p in points])), color="grey", ls="--",
                   lw=1, label="mean of the points")
    ax.set_xticks(levels)
    ax.set_xticklabels(["-1 (low)", "0 (mid)", "1 (high)"])
    ax.set_xlabel("coded level")
    ax.set_ylabel(f"mean {doe_json.get('response', 'response')}")
    ax.set_title(f"main effects: {doe_json.get('preset', '')} on {doe_json.get('map', '')}",
                 fontsize=9)
    ax.legend(fontsize=7)
    return ax
def plot_replan(replanned: Any, grid: Grid, old_path: Sequence[tuple[int, int]],
                obstacles: Sequence[tuple[int, int]], out: str | Path | None = None):
    """``jaxga replan --plot``: the map with the new obstacles (red squares), the old
    path (grey, dashed), the robot's cell and the re-planned path from it to the goal
    (or "no path found"). ``replanned`` is a :class:`jaxga.replan.ReplanResult`."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 5))
    plot_map(grid, [], ax=ax)
    if len(obstacles):
        xy = np.asarray(obstacles, float)
        ax.scatter(xy[:, 0], xy[:, 1], marker="s", s=60, color="red", zorder=5,
                   label=f"new obstacles ({len(obstacles)})")
    old = np.asarray(old_path, float)
    ax.plot(old[:, 0], old[:, 1], color="0.45", ls="--", lw=1.5, zorder=3, label="old path")
    if replanned.success:
        new = np.asarray(replanned.path, float)
        ax.plot(new[:, 0], new[:, 1], color="C0", lw=2.2, zorder=4,
                label=f"re-planned ({replanned.length:.2f})")
    else:
        _no_path(ax, f"no path found: {replanned.status}")
    robot = replanned.prefix[-1] if replanned.prefix else (old[0][0], old[0][1])
    ax.plot([robot[0]], [robot[1]], marker="^", color="darkorange", ms=10, ls="none",
            zorder=6, label="robot")
    _legend_outside(ax)
    ax.set_title(f"re-plan: {replanned.status} (corner rule {replanned.corner_rule!r})",
                 fontsize=9)
    return _finish(fig, out)


def plot_result(result, grid: Grid | str, out: str | Path | None = None,
                curve: np.ndarray | None = None):
    """Map with the best seed's raw and post-optimised paths (and ``curve``, the smooth
    curve's dense points, ``float[N, 2]``), and the convergence curve."""
    plt = _pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.6))
    plot_paths(result, grid, ax=a1)
    if curve is not None and len(curve):
        c = np.asarray(curve, float)
        a1.plot(c[:, 0], c[:, 1], color="C2", lw=1.6, zorder=4, label="smooth curve")
        _legend_outside(a1)
    plot_convergence(result.history, ax=a2, success=result.success)
    a2.set_title(f"{int(np.sum(result.success))} of {len(result.seeds)} seeds found a path",
                 fontsize=9)
    return _finish(fig, out)
