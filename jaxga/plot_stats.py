"""Matplotlib figures over seeds and presets: diversity curves (MPMGA Fig. 16), box plots
and per-seed scatters (AGACD Figs. 8-10), a comparison's figure and a designed
experiment's main effects (AGACD 5.2.1).

As in :mod:`jaxga.plot` (which re-exports them), every function takes ``ax=None`` (a new
figure when None) and returns the axes (``plot_comparison`` returns the figure).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from jaxga.compare import metric_values
from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value
from jaxga.figures import finish_figure, pyplot

__all__ = ["plot_box", "plot_comparison", "plot_diversity", "plot_main_effects",
           "plot_seed_scatter"]


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
    plt = pyplot()
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
    post-optimised lengths, 0 for gaps), one :class:`~jaxga.api.result.Result` (one box
    of ``metric``, default its lengths) or a mapping label -> per-seed values (NaN =
    failed) with optional ``reference`` lines ``{label: value}``.
    """
    if hasattr(data, "history") and hasattr(data, "preset"):  # one Result: one box
        data = {data.preset: metric_values(data, metric or "length")}
        metric = metric or "length"
    elif not (hasattr(data, "results") or hasattr(data, "items")):
        raise ParameterError(f"plot_box: data must be a Comparison, a Result or a mapping "
                             f"label -> per-seed values, got {shown_value(data)}")
    plt = pyplot()
    if ax is None:
        n = len(data.results) if hasattr(data, "results") else len(data)
        _, ax = plt.subplots(figsize=(1.1 * max(4, n) + 1, 3.8))
    if hasattr(data, "results"):
        metric = metric or data.metric
        values = {k: data.values(k, metric) for k in data.labels}
        if reference is None:
            reference = {}
            if metric == "length":
                if np.isfinite(data.any_angle_optimum):  # not computed within its budget
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

    plt = pyplot()
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
    plt = pyplot()
    n = len(comparison.results)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(max(10, 1.2 * n + 6), 4.2))
    metric = metric or comparison.metric
    plot_box(comparison, metric, ax=a1)
    a1.set_title(f"{metric} on {next(iter(comparison.results.values())).map_name}")
    plot_seed_scatter(comparison, y=metric, x="convergence_generation", ax=a2)
    a2.set_title(f"{len(next(iter(comparison.results.values())).seeds)} seeds per preset")
    return finish_figure(fig, out)


def plot_main_effects(doe_json: Any, ax=None):
    """DOE main-effects plot (AGACD 5.2.1): mean response at coded level -1, 0, 1, one
    line per factor (its real levels in the legend); dashed: the grand mean of the design
    points.

    ``doe_json`` is a :class:`jaxga.doe.DoeResult` or its ``jaxga doe --json`` layout
    (``factors``, ``points`` with ``coded`` and ``mean``, ``response``); the level means
    are computed from the points (points without a mean left out). Returns the axes.
    """
    plt = pyplot()
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
