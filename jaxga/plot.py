"""Matplotlib figures: the map with paths, and convergence curves with sd bands.

Maps are drawn with ``origin="lower"`` (row 0 at the bottom, SPEC 1); cell ``(x, y)`` is
the unit square centred on ``(x, y)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from jaxga.grid import Grid

__all__ = ["plot_convergence", "plot_main_effects", "plot_map", "plot_result"]


def _pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        try:
            matplotlib.use("Agg", force=False)
        except Exception:  # pragma: no cover - a GUI backend already in use
            pass
    import matplotlib.pyplot as plt

    return plt


def plot_map(grid: Grid, paths: Sequence[tuple[Sequence[tuple[int, int]], str]] = (), ax=None):
    """Draw the map (obstacles black), start/goal markers and ``(path, label)`` polylines."""
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 5))
    b = grid.blocked_np()
    ax.imshow(b, origin="lower", cmap="Greys", vmin=0, vmax=1,
              extent=(-0.5, grid.width - 0.5, -0.5, grid.height - 0.5))
    for path, label in paths:
        if len(path):
            xy = np.asarray(path, float)
            ax.plot(xy[:, 0], xy[:, 1], marker=".", lw=1.5, label=label)
    (sx, sy), (gx, gy) = grid.start_xy, grid.goal_xy
    ax.plot([sx], [sy], "go", ms=8, label="start")
    ax.plot([gx], [gy], "r*", ms=11, label="goal")
    ax.set_xlim(-0.5, grid.width - 0.5)
    ax.set_ylim(-0.5, grid.height - 0.5)
    ax.set_aspect("equal")
    ax.legend(loc="upper left", fontsize=7, framealpha=0.8)
    return ax


def plot_convergence(histories: dict[str, np.ndarray], ax=None, label: str = ""):
    """Best-so-far fitness per generation: mean over seeds with a +-1 sd band."""
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 3.5))
    best = np.asarray(histories["best"], float)
    gens = np.arange(1, best.shape[1] + 1)
    mean, sd = best.mean(axis=0), best.std(axis=0)
    ax.plot(gens, mean, label=(label + " " if label else "") + "best fitness (mean over seeds)")
    ax.fill_between(gens, mean - sd, mean + sd, alpha=0.25)
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness")
    ax.legend(fontsize=7)
    return ax


def plot_result(result, grid: Grid | str, out: str | Path | None = None):
    """Map with the best seed's raw and post-optimised paths, and the convergence curve."""
    plt = _pyplot()
    if not isinstance(grid, Grid):
        from jaxga.maps import load_map

        grid = load_map(grid, corner_rule=result.corner_rule)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.6))
    paths = []
    if result.success.any():
        i = int(np.nanargmin(np.where(result.success, result.length, np.nan)))
        paths = [(result.path(i, raw=True), f"raw ({result.raw_length[i]:.2f})"),
                 (result.path(i), f"post-optimised ({result.length[i]:.2f})")]
    plot_map(grid, paths, ax=a1)
    a1.set_title(f"{result.preset} on {result.map_name}")
    if result.history["best"].shape[1]:
        plot_convergence(result.history, ax=a2)
    a2.set_title(f"{len(result.seeds)} seeds")
    fig.tight_layout()
    if out is not None:
        fig.savefig(out, dpi=110)
        plt.close(fig)
    return fig


def plot_main_effects(doe_json: dict, ax=None):
    """DOE main-effects plot (AGACD 5.2.1): mean response at coded level -1, 0, 1, one
    line per factor (its real levels in the legend); dashed: the grand mean of the design
    points.

    ``doe_json`` is the ``jaxga doe --json`` layout (``factors``, ``points`` with
    ``coded`` and ``mean``, ``response``); the level means are computed from the points
    (points without a mean left out). Returns the axes.
    """
    plt = _pyplot()
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
