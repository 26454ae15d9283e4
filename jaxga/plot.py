"""Matplotlib figures: the map with paths, a re-plan and a front, convergence curves; the
figures over seeds and presets (diversity, box plots, scatters, main effects) are
:mod:`jaxga.plot_stats`'s, re-exported here.

Every function takes ``ax=None`` (a new figure when None) and returns the axes (the
``plot_result`` / ``plot_comparison`` figures return the figure).

Maps are drawn with ``origin="lower"`` (row 0 at the bottom); cell ``(x, y)`` is the unit
square centred on ``(x, y)``. A map with a resolution (a ROS ``map_server`` map) is drawn
in metres instead (:class:`MapView`), and a map with :class:`~jaxga.maps.MapLayers` shows
free, unknown, wall and inflation-margin cells in distinct shades (:data:`CELL_CLASSES`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import Grid, as_integer
from jaxga.figures import finish_figure, pyplot, save_figure
from jaxga.maps import load_map_info
from jaxga.maps.frame import MapFrame
from jaxga.maps.loaders import MapLayers
from jaxga.plot_stats import (
    plot_box,
    plot_comparison,
    plot_diversity,
    plot_main_effects,
    plot_seed_scatter,
)

__all__ = ["CELL_CLASSES", "MapView", "cell_classes", "plot_box", "plot_comparison",
           "plot_convergence", "plot_diversity", "plot_front", "plot_main_effects", "plot_map",
           "plot_paths",
           "plot_replan", "plot_result", "plot_seed_scatter", "save_figure"]


PATH_STYLES = (
    {"lw": 4.0, "alpha": 0.45, "solid_capstyle": "round", "zorder": 2},
    {"lw": 1.3, "ls": "--", "marker": "o", "ms": 2.5, "zorder": 3},
    {"lw": 1.0, "ls": ":", "marker": "x", "ms": 3.0, "zorder": 4},
)
"""Line styles of the paths of :func:`plot_map`, in order: a wide translucent line under a
thin dashed one, so that two paths that coincide (a raw path the post-optimiser left as
it was) both stay visible."""

CELL_CLASSES: tuple[tuple[str, str, tuple[int, int, int]], ...] = (
    ("free", "free", (255, 255, 255)),
    ("unknown_free", "unknown (planned as free)", (222, 222, 222)),
    ("unknown_blocked", "unknown (planned as blocked)", (172, 172, 172)),
    ("wall", "wall", (0, 0, 0)),
    ("margin", "inflation margin (blocked)", (246, 190, 182)),
)
"""``(key, legend label, RGB)`` of each kind of cell, indexed by the codes of
:func:`cell_classes`: white free space, light grey unknown space the planner may cross,
mid grey unknown space it may not, black walls and a light red tint for the cells that
only the inflation by the robot's radius blocks (free in the map, too close to a wall for
the robot's centre)."""

_PALETTE = np.array([rgb for _, _, rgb in CELL_CLASSES], np.uint8)
_CODE = {key: i for i, (key, _, _) in enumerate(CELL_CLASSES)}


def cell_classes(grid: Grid, layers: MapLayers | None = None) -> np.ndarray:
    """``int8[H, W]`` codes into :data:`CELL_CLASSES` of every planning cell, row 0 at the
    bottom: what the map says each cell is, for a plot that tells walls from unknown space
    and from the inflation margin.

    The grid decides what is blocked (it is what the planner saw); ``layers`` only say why:
    a blocked cell is margin where ``layers.margin`` holds, unknown (blocked) where
    ``layers.unknown`` does, else wall; a free cell is unknown (planned as free) where
    ``layers.unknown`` holds, else free. Without layers (or with layers of another shape)
    cells are free or wall, as on a plain map.
    """
    blocked = grid.blocked_np()
    codes = np.where(blocked, _CODE["wall"], _CODE["free"]).astype(np.int8)
    if layers is None or np.shape(layers.wall) != blocked.shape:
        return codes
    unknown = np.asarray(layers.unknown, bool)
    margin = np.asarray(layers.margin, bool)
    codes[~blocked & unknown] = _CODE["unknown_free"]
    codes[blocked & unknown] = _CODE["unknown_blocked"]
    codes[blocked & margin] = _CODE["margin"]
    return codes


@dataclasses.dataclass(frozen=True)
class MapView:
    """Where the planning cells lie on a map plot's axes, so that every artist (the map's
    image, paths, markers) is placed the same way.

    Without metres (``frame`` None or without a resolution) the axes are in planning
    cells, cell ``(x, y)`` centred on ``(x, y)``. With metres and a yaw of 0 they are the
    map's world frame (``x``, ``y`` in metres, :meth:`MapFrame.to_world`); with a non-zero
    yaw, metres along the map's own axes from its origin (the map is not turned on the
    page, the axis labels say so).
    """

    frame: MapFrame | None = None

    @property
    def metres(self) -> bool:
        """Whether the axes are in metres."""
        return self.frame is not None and self.frame.has_metres

    @property
    def world(self) -> bool:
        """Whether the axes are the world frame itself (metres, map yaw 0)."""
        return self.metres and self.frame.origin[2] == 0  # type: ignore[union-attr]

    def xy(self, points: Any) -> np.ndarray:
        """``float[..., 2]`` plot coordinates of points in planning cells."""
        p = np.asarray(points, float)
        if not self.metres:
            return p
        if self.world:
            return self.frame.to_world(p)  # type: ignore[union-attr]
        return self.frame.local_metres(p)  # type: ignore[union-attr]

    def extent(self, shape: tuple[int, int]) -> tuple[float, float, float, float]:
        """``(left, right, bottom, top)`` of a map of ``shape = (H, W)`` planning cells:
        the outer edges of its corner cells (imshow's ``extent`` and the axes' limits)."""
        h, w = shape
        (x0, y0), (x1, y1) = self.xy([(-0.5, -0.5), (w - 0.5, h - 0.5)])
        return float(x0), float(x1), float(y0), float(y1)

    def labels(self) -> tuple[str, str]:
        """The x and y axis labels: "" on a map in cells (as the papers' maps are drawn)."""
        if not self.metres:
            return "", ""
        if self.world:
            return "x (m)", "y (m)"
        yaw = math.degrees(self.frame.origin[2])  # type: ignore[union-attr]
        return (f"x along the map (m from its origin; map turned {yaw:.4g}° in the world)",
                "y along the map (m)")

    def length(self, cells: float) -> str:
        """A path length in planning cells, as the legend writes it (metres when known)."""
        if self.metres:
            return f"{self.frame.metres(cells):.2f} m"  # type: ignore[union-attr]
        return f"{cells:.2f}"

    def point(self, cell: tuple[int, int]) -> str:
        """A cell's position for a legend: its world coordinates in metres (what
        ``--start-world`` takes, whatever the map's yaw), nothing without metres."""
        if not self.metres:
            return ""
        x, y = self.frame.to_world(np.asarray(cell, float))  # type: ignore[union-attr]
        return f" ({x:.2f}, {y:.2f}) m" + ("" if self.world else " in the world")


def plot_map(grid: Grid, paths: Sequence[tuple[Sequence[tuple[int, int]], str]] = (), ax=None,
             layers: MapLayers | None = None, frame: MapFrame | None = None,
             endpoints: tuple[tuple[int, int], tuple[int, int]] | None = None,
             include: Sequence[tuple[int, int]] = ()):
    """Draw the map, start/goal markers and ``(path, label)`` polylines (styles
    :data:`PATH_STYLES`); the legend sits outside the map, right of it, so that it hides no
    cell.

    The cells are one RGB image (:func:`cell_classes`, :data:`CELL_CLASSES`), drawn at
    once whatever the map's size: obstacles black on white, and
    with ``layers`` (:class:`~jaxga.maps.MapLayers`) unknown cells grey and the inflation
    margin tinted, explained by a key below the legend. ``frame`` with a resolution puts
    the axes in metres (:class:`MapView`). ``endpoints`` ``(start, goal)`` replaces the
    grid's own (a re-plan's path runs between its own ends).

    The axes span the whole map, except on a map whose unknown cells frame the mapped
    area (a robot's map is mostly unknown space around the building): there they span
    the cells that are not unknown, the paths, the endpoints and the ``include`` cells,
    with a small margin (the image still holds the whole map; :func:`_view_box`).
    """
    paths = list(paths)
    for item in paths:
        if not (isinstance(item, (tuple, list)) and len(item) == 2 and isinstance(item[1], str)):
            raise ParameterError(f"plot_map: paths must be (path, label) pairs, got "
                                 f"{shown_value(item)} (one path: paths=[(path, 'best')])")
    plt = pyplot()
    if ax is None:
        size = (6.2, 5) if max(grid.shape) <= 100 else (7.6, 6.2)
        _, ax = plt.subplots(figsize=size)
    view = MapView(frame)
    codes = cell_classes(grid, layers)
    extent = view.extent(grid.shape)
    if view.metres and frame.coarsen > 1:  # type: ignore[union-attr]
        # drawn in map cells: a last block past the map's edge is narrower than the others
        k, (h, w) = frame.coarsen, frame.map_shape  # type: ignore[union-attr]
        codes = np.repeat(np.repeat(codes, k, axis=0), k, axis=1)[:h, :w]
    ax.imshow(_PALETTE[codes], origin="lower", extent=extent, interpolation="auto",
              gid="map-cells")
    for i, (path, label) in enumerate(paths):
        if path is not None and len(path):
            xy = view.xy(path)
            ax.plot(xy[:, 0], xy[:, 1], label=label, color=f"C{i}",
                    **PATH_STYLES[i % len(PATH_STYLES)])
    start, goal = endpoints if endpoints is not None else (grid.start_xy, grid.goal_xy)
    (sx, sy), (gx, gy) = view.xy(start), view.xy(goal)
    ax.plot([sx], [sy], "go", ms=8, label="start" + view.point(start))
    ax.plot([gx], [gy], "r*", ms=11, label="goal" + view.point(goal))
    shown = [start, goal, *include, *(c for path, _ in paths if path is not None for c in path)]
    (x0, y0), (x1, y1) = _view_box(codes, shown)
    (left, bottom), (right, top) = view.xy([(x0 - 0.5, y0 - 0.5), (x1 + 0.5, y1 + 0.5)])
    ax.set_xlim(left, right)
    ax.set_ylim(bottom, top)
    ax.set_aspect("equal")
    xlabel, ylabel = view.labels()
    if xlabel:
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
    if layers is not None:
        _cell_key(ax, codes)
    _legend_outside(ax)
    return ax


def _view_box(codes: np.ndarray, shown: Sequence[tuple[int, int]]
              ) -> tuple[tuple[int, int], tuple[int, int]]:
    """The cells a map plot spans, ``((x0, y0), (x1, y1))`` inclusive: the whole map, or
    on a map with unknown cells the box around its other cells and the ``shown`` ones
    (paths, endpoints), widened by 3 % of the map's larger side: a robot's map is padded
    with unknown space that would shrink the building to a corner of the figure."""
    h, w = codes.shape
    whole = ((0, 0), (w - 1, h - 1))
    unknown = (codes == _CODE["unknown_free"]) | (codes == _CODE["unknown_blocked"])
    if not unknown.any() or unknown.all():
        return whole
    rows, cols = np.flatnonzero(~unknown.all(axis=1)), np.flatnonzero(~unknown.all(axis=0))
    x0, x1, y0, y1 = cols[0], cols[-1], rows[0], rows[-1]
    if len(shown):
        xy = np.asarray(shown, int).reshape(-1, 2)
        x0, x1 = min(x0, xy[:, 0].min()), max(x1, xy[:, 0].max())
        y0, y1 = min(y0, xy[:, 1].min()), max(y1, xy[:, 1].max())
    pad = max(1, math.ceil(0.03 * max(h, w)))
    return ((max(0, int(x0) - pad), max(0, int(y0) - pad)),
            (min(w - 1, int(x1) + pad), min(h - 1, int(y1) + pad)))


def _cell_key(ax, codes: np.ndarray) -> None:
    """A key of the kinds of cell the map holds, outside the axes at their lower right
    (the paths' legend is at the upper right): a robot's map mixes walls, unknown space and
    the inflation margin, which the picture tells apart only with it."""
    from matplotlib.legend import Legend
    from matplotlib.patches import Patch

    present = np.zeros(len(CELL_CLASSES), bool)
    present[np.unique(codes)] = True
    handles = [Patch(facecolor=np.array(rgb) / 255, edgecolor="0.4", lw=0.5, label=label)
               for (_, label, rgb), shown in zip(CELL_CLASSES, present, strict=True) if shown]
    key = Legend(ax, handles, [h.get_label() for h in handles], loc="lower left",
                 bbox_to_anchor=(1.02, 0.0), borderaxespad=0.0, fontsize=7,
                 title="cells", title_fontsize=7)
    key.set_gid("cell-key")
    ax.add_artist(key)
    key.set_clip_on(False)  # outside the axes: in the saved figure's tight crop


def _legend_outside(ax) -> None:
    """The legend right of the axes, outside the map, so that it hides no cell."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=7)


def _no_path(ax, what: str = "no path found") -> None:
    """Say in the middle of ``ax`` that there is nothing to draw."""
    ax.text(0.5, 0.5, what, transform=ax.transAxes, ha="center", va="center", fontsize=11,
            color="firebrick", gid="no-path",
            bbox={"boxstyle": "round", "facecolor": "white", "edgecolor": "firebrick"})


FLAT_TOLERANCE = 1e-6
"""Relative change of a seed's best fitness below which :func:`plot_convergence` calls it
unchanged: float32 fitness sums wobble by about 1e-7 of their value between equal paths."""


def plot_convergence(histories: dict[str, np.ndarray], ax=None, label: str = "",
                     success: np.ndarray | None = None, initial: np.ndarray | None = None):
    """Best-so-far fitness per generation (higher is better): mean over seeds with a +-1
    sd band; with ``success``, over the seeds that found a path only (a failed seed's
    fitness is no value), and "no path found" when none did.

    ``initial`` (per seed, the initial population's best fitness,
    :attr:`jaxga.api.result.Result.initial_fitness`) adds generation 0 where every seed's
    initial population held a path. The fitness axis is labelled with plain numbers, as
    many digits as its ticks need (no offset or power of ten to add in one's head), and
    a curve that never moves says so on the panel (the initial population often holds the
    best path already) instead of drawing a line at an arbitrary height; otherwise the
    legend gives the first and last values and the relative change.
    """
    best = np.asarray(histories["best"], float) if hasattr(histories, "keys") and \
        "best" in histories else None
    if best is None or best.ndim != 2 or best.shape[0] < 1:
        raise ParameterError(
            "plot_convergence: histories must be a mapping whose 'best' is float[seeds, "
            "generations] with at least one seed (a Result's history), got "
            + (shown_value(histories) if best is None else f"'best' of shape {best.shape}"))
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 3.5))
    ax.set_xlabel("generation")
    ax.set_ylabel("best fitness (higher is better)")
    which = "seeds"
    keep = np.ones(best.shape[0], bool)
    if success is not None:
        keep = np.asarray(success, bool)
        if not keep.any() or best.shape[1] == 0:
            _no_path(ax, "no path found: no fitness to plot")
            return ax
        best = best[keep]
        which = f"the {int(keep.sum())} seeds with a path"
    first_gen = 1
    if initial is not None:
        init = np.asarray(initial, float)[keep]
        if init.shape == best.shape[:1] and np.all(init > 0):
            best = np.c_[init, best]
            first_gen = 0
    gens = np.arange(first_gen, first_gen + best.shape[1])
    mean, sd = best.mean(axis=0), best.std(axis=0)
    scale = max(float(np.max(np.abs(best))), np.finfo(float).tiny)
    flat = np.ptp(best, axis=1) <= FLAT_TOLERANCE * scale
    name = (label + " " if label else "") + f"best fitness (mean over {which})"
    if not flat.all() and len(gens) > 1:
        change = (mean[-1] - mean[0]) / abs(mean[0]) if mean[0] else math.inf
        name += (f"\n{_sig(mean[0])} at generation {gens[0]} -> {_sig(mean[-1])} at "
                 f"{gens[-1]} ({100 * change:+.3g} %)")
    ax.plot(gens, mean, label=name)
    ax.fill_between(gens, mean - sd, mean + sd, alpha=0.25)
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.yaxis.set_major_formatter(FuncFormatter(
        lambda v, _pos: f"{v:.{_decimals(ax.yaxis.get_majorticklocs())}f}"))
    lo, hi = float(np.min(mean - sd)), float(np.max(mean + sd))
    if hi - lo <= FLAT_TOLERANCE * scale:  # a line at one height: put it mid-panel
        centre = float(np.mean(mean))
        half = 0.01 * abs(centre) or 1.0
        ax.set_ylim(centre - half, centre + half)
    if flat.all():
        start = ("from generation 0:\nthe initial population already held it"
                 if first_gen == 0 else f"over generations 1 to {gens[-1]}")
        ax.text(0.5, 0.9, f"best fitness {_sig(float(np.mean(mean)))} unchanged {start}",
                transform=ax.transAxes, ha="center", va="top", fontsize=8, gid="flat-note",
                bbox={"boxstyle": "round", "facecolor": "white", "edgecolor": "0.6"})
    elif flat.any():
        ax.text(0.02, 0.04, f"best fitness unchanged in {int(flat.sum())} of {len(flat)} "
                "seeds", transform=ax.transAxes, ha="left", va="bottom", fontsize=7,
                gid="flat-note")
    ax.legend(fontsize=7, loc="lower right")
    return ax


def _sig(value: float) -> str:
    """A fitness value with enough significant digits to tell nearby values apart."""
    return f"{value:.6g}"


def _decimals(locs: Sequence[float]) -> int:
    """The fewest decimals that write every tick location exactly (to a thousandth of the
    tick spacing): plain tick labels that differ from one another, without an offset."""
    v = np.asarray(locs, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0
    steps = np.diff(np.unique(v))
    if steps.size == 0:  # one tick: four significant digits
        m = float(np.max(np.abs(v)))
        return 0 if m == 0 else max(0, 3 - math.floor(math.log10(m)))
    tol = 1e-3 * float(np.min(steps))
    for d in range(16):
        if np.all(np.abs(np.round(v, d) - v) <= tol):
            return d
    return 16


def plot_paths(result, grid: Grid | str, seed: int | None = None, ax=None, info: Any = None):
    """The map with one run's raw and post-optimised paths and the start/goal markers.

    ``seed`` is an index into ``result.seeds`` (default: the successful run with the
    shortest post-optimised length). Raw = the GA's own best path, post-optimised = after
    the preset's post-optimiser; the legend gives both lengths (in metres on a map with a
    resolution). ``info`` (a :class:`~jaxga.maps.MapInfo`) brings the map's name, its
    cell classes (walls, unknown, inflation margin) and its frame; without it the frame
    is ``result.frame``. The title names the map, the preset and the corner rule.
    """
    grid, info = _map_of(grid, result.corner_rule, info)
    if grid.width != result.width:
        raise ParameterError(f"the result is on a map {result.width} cells wide "
                             f"({result.map_name}), this map is {grid.width} wide")
    frame = _frame_of(result, info)
    view = MapView(frame)
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
        paths = [(result.path(seed, raw=True),
                  f"raw ({view.length(float(result.raw_length[seed]))})"),
                 (result.path(seed), f"post-optimised ({view.length(float(result.length[seed]))})")]
        _check_paths_fit(grid, result, [p for p, _ in paths])
    ax = plot_map(grid, paths, ax=ax, layers=None if info is None else info.layers,
                  frame=frame)
    name = info.name if info is not None else result.map_name
    title = f"{result.preset} on {name}, corner rule {result.corner_rule!r}"
    if view.metres:
        title += f", {frame.cell_size:g} m cells"
    n_ok = int(np.sum(result.success))
    if seed is not None and result.success[seed]:
        title += (f"\nbest of {n_ok} paths found ({len(result.seeds)} seeds): seed "
                  f"{int(result.seeds[seed])}" if chosen else f"\nseed {int(result.seeds[seed])}")
    else:
        which = (f"seed {int(result.seeds[seed])}" if seed is not None
                 else f"any of {len(result.seeds)} seeds")
        title += f"\nno path found by {which}"
        _no_path(ax)
    ax.set_title(title, fontsize=9)
    return ax


def _frame_of(result: Any, info: Any) -> MapFrame | None:
    """The frame a result is drawn in: the map's (``info``), else the result's own."""
    if info is not None and info.frame is not None:
        return info.frame
    return getattr(result, "frame", None)


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


def _map_of(grid: Grid | str, corner_rule: str, info: Any) -> tuple[Grid, Any]:
    """The grid to draw and its :class:`~jaxga.maps.MapInfo` (None when unknown): a map
    file's name is loaded with its layers and frame, so that a ROS map given by its path
    is drawn as one given by its :class:`~jaxga.maps.MapInfo`."""
    if isinstance(grid, Grid):
        return grid, info
    loaded = load_map_info(grid, corner_rule=corner_rule)
    return loaded.grid, info if info is not None else loaded


def plot_replan(replanned: Any, grid: Grid, old_path: Sequence[tuple[int, int]],
                obstacles: Sequence[tuple[int, int]], out: str | Path | None = None,
                info: Any = None):
    """``jaxga replan --plot``: the map with the new obstacles (red squares), the old
    path (grey, dashed), the robot's cell and the re-planned path from it to the goal
    (or "no path found"). ``replanned`` is a :class:`jaxga.replan.ReplanResult`.

    The start and goal markers are the old path's ends (``old_path[0]``,
    ``old_path[-1]``), never the map's default corners: a re-plan runs between them.
    ``info`` (a :class:`~jaxga.maps.MapInfo`) brings the map's name, cell classes and
    metres, as in :func:`plot_paths`; the title names the map, the preset and the corner
    rule.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 5) if max(grid.shape) <= 100 else (7.6, 6.2))
    if not len(old_path):
        raise ParameterError("the old path is empty: nothing was re-planned")
    ends = (tuple(int(v) for v in old_path[0]), tuple(int(v) for v in old_path[-1]))
    frame = None if info is None else info.frame
    view = MapView(frame)
    plot_map(grid, [], ax=ax, layers=None if info is None else info.layers, frame=frame,
             endpoints=ends, include=[*old_path, *obstacles,  # type: ignore[arg-type]
                                      *(replanned.path or [])])
    if len(obstacles):
        xy = view.xy(obstacles)
        ax.scatter(xy[:, 0], xy[:, 1], marker="s", s=60, color="red", zorder=5,
                   label=f"new obstacles ({len(obstacles)})")
    old = view.xy(old_path)
    ax.plot(old[:, 0], old[:, 1], color="0.45", ls="--", lw=1.5, zorder=3, label="old path")
    if replanned.success:
        new = view.xy(replanned.path)
        ax.plot(new[:, 0], new[:, 1], color="C0", lw=2.2, zorder=4,
                label=f"re-planned ({view.length(float(replanned.length))})")
    else:
        _no_path(ax, f"no path found: {replanned.status}")
    robot = view.xy(replanned.prefix[-1] if replanned.prefix else old_path[0])
    ax.plot([robot[0]], [robot[1]], marker="^", color="darkorange", ms=10, ls="none",
            zorder=6, label="robot")
    _legend_outside(ax)
    runs = list(getattr(replanned, "ga", None) or [])
    name = info.name if info is not None else (runs[0].map_name if runs else "")
    about = [f"preset {runs[0].preset}"] if runs else []
    about.append(f"corner rule {replanned.corner_rule!r}")
    ax.set_title(f"re-plan{' on ' + name if name else ''}: {replanned.status}\n"
                 f"{', '.join(about)}", fontsize=9)
    return finish_figure(fig, out)


def plot_front(result, grid: Grid | str, seed: int | None = None, axes=None,
               info: Any = None):
    """One seed's front (decision 045) in two panels: the map with every path of the front
    coloured by its clearance (the shortest end blue, the widest yellow), and the front
    itself, length against clearance (metres on a map with a resolution), with the
    exact ends: the any-angle optimum's length and the maximin clearance as lines, the
    post-optimised shortest end as a star. ``seed`` is an index into ``result.seeds``
    (default: the first seed with a path); ``axes`` a pair of axes (default: a new
    figure). Returns the axes."""
    plt = pyplot()
    if getattr(result, "front", None) is None:
        raise ParameterError(f"{result.preset} keeps no front: plot_front needs a preset "
                             "with survival.method (pareto)")
    grid, info = _map_of(grid, result.corner_rule, info)
    if seed is None:
        ok = np.flatnonzero(result.success)
        seed = int(ok[0]) if ok.size else 0
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(12, 5), width_ratios=(1.4, 1))
    a_map, a_front = axes
    frame = _frame_of(result, info)
    view = MapView(frame)
    points = result.front_points(seed)
    plot_map(grid, [], ax=a_map, layers=None if info is None else info.layers, frame=frame,
             include=[c for p in points for c in p["path"]])
    unit = frame.cell_size if view.metres else 1.0
    clear = np.array([p["clearance"] for p in points], float) * unit
    unbounded = bool(len(clear)) and bool(np.isinf(clear).all())  # no obstacle on the map
    if unbounded:
        clear = np.zeros_like(clear)  # drawn on the axis, and said so in the label
    colours = plt.get_cmap("viridis")(np.linspace(0, 1, max(len(points), 1)))
    order = np.argsort(clear, kind="stable")
    for rank, k in enumerate(order):
        xy = view.xy(points[k]["path"])
        a_map.plot(xy[:, 0], xy[:, 1], color=colours[rank], lw=1.2, zorder=3)
    a_map.set_title(f"{result.preset}: the {len(points)} paths of seed "
                    f"{int(result.seeds[seed])}'s front, by clearance", fontsize=9)
    length = np.array([p["length"] for p in points]) * unit
    a_front.scatter(length, clear, c=[colours[r] for r in np.argsort(order)], zorder=3,
                    label="front (as evolved)")
    what = "m" if view.metres else "cells"
    if np.isfinite(result.any_angle_optimum):
        a_front.axvline(result.any_angle_optimum * unit, color="0.4", ls="--",
                        label="any-angle optimum")
    if np.isfinite(result.maximin_clearance):
        a_front.axhline(result.maximin_clearance * unit, color="0.4", ls=":",
                        label="maximin clearance")
    if result.success[seed]:
        a_front.plot([result.length[seed] * unit], [clear.min()], "r*", ms=11,
                     label="shortest end post-optimised")
    a_front.set_xlabel(f"length ({what})")
    a_front.set_ylabel(f"least clearance ({what})" if not unbounded else
                       "least clearance: unbounded (no obstacle), drawn at 0")
    a_front.legend(fontsize=8)
    a_front.set_title("front: length against clearance", fontsize=9)
    return axes


def plot_result(result, grid: Grid | str, out: str | Path | None = None,
                curve: np.ndarray | None = None, info: Any = None):
    """Map with the best seed's raw and post-optimised paths (and ``curve``, the smooth
    curve's dense points in planning cells, ``float[N, 2]``), and the convergence curve.

    ``info`` (a :class:`~jaxga.maps.MapInfo`) brings the map's name, its cell classes
    (walls, unknown space, inflation margin) and metres (:func:`plot_paths`); a large map
    gets a larger figure, so that a one-cell wall stays visible.
    """
    plt = pyplot()
    if getattr(result, "front", None) is not None and result.success.any():
        # a front: its paths and its trade-off, then the hypervolume over the generations
        fig, axes = plt.subplots(1, 3, figsize=(17, 5.2), width_ratios=(1.4, 1, 1))
        seed = int(np.flatnonzero(result.success)[0])
        plot_front(result, grid, seed, axes=axes[:2], info=info)
        hv = result.history["hypervolume"]
        start = result.front.initial_hypervolume
        for i in np.flatnonzero(result.success):
            axes[2].plot(np.arange(hv.shape[1] + 1), np.concatenate([[1.0], hv[i] / start[i]]),
                         lw=1)
        axes[2].set_xlabel("generation")
        axes[2].set_ylabel("hypervolume / the initial population's")
        axes[2].set_title("what the generations gain, per seed", fontsize=9)
        return finish_figure(fig, out)
    shape = grid.shape if isinstance(grid, Grid) else (0, 0)
    large = max(shape) > 100 or (info is not None and max(info.grid.shape) > 100)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(14, 6.2) if large else (11, 4.6),
                                 width_ratios=(1.5, 1) if large else (1, 1))
    a1 = plot_paths(result, grid, ax=a1, info=info)
    if large:  # as tall as the map (cropped to its mapped area) needs, no taller
        (x0, x1), (y0, y1) = a1.get_xlim(), a1.get_ylim()
        aspect = abs(x1 - x0) / max(abs(y1 - y0), 1e-12)
        fig.set_size_inches(14, min(7.5, max(4.6, 5.3 / aspect + 1.4)))
    if curve is not None and len(curve):
        c = MapView(_frame_of(result, info)).xy(curve)
        a1.plot(c[:, 0], c[:, 1], color="C2", lw=1.6, zorder=4, label="smooth curve")
        _legend_outside(a1)
    plot_convergence(result.history, ax=a2, success=result.success,
                     initial=getattr(result, "initial_fitness", None))
    a2.set_title(f"{int(np.sum(result.success))} of {len(result.seeds)} seeds found a path",
                 fontsize=9)
    return finish_figure(fig, out)
