"""Local re-planning around obstacles that appear on a planned path (MPMGA 5.2.1, 5.3.1).

Local re-planning (docs/replanning.md): a robot follows a planned path; obstacles suddenly appear
on it (MPMGA 5.2.1: two pedestrians at grid cells 320 and 345 of the 25 x 25 library map;
5.3.1: a 3 x 3 block at cells 810-812, 860-862, 910-912 of the 50 x 50 map). From the
robot's cell the GA plans to the first path cell beyond the blockage (295 -> 370 and
759 -> 963 in the paper) and the new segment is spliced into the old path. The paper
needed 0.3-0.4 s (25 x 25) and under 1 s (50 x 50) per re-plan in Matlab.

:func:`replan` does this with a small GA budget:

1. the robot's cell must be free and on the path, one of its cells or a cell one of its
   segments crosses (a waypoint path: the robot's cell becomes a waypoint there), else
   :class:`~jaxga.core.errors.EndpointError` / :class:`~jaxga.core.errors.ParameterError`;
2. walking the remaining path from the robot's cell, the first *blocked step* is the first
   pair of consecutive path cells whose segment is no longer clear (a cell now blocked, or
   a diagonal step made illegal by the corner rule; :func:`jaxga.reference.optima.clear_np`, so
   waypoint paths work as well as 8-connected ones). Nothing blocked: the remaining path
   is returned unchanged and no GA runs;
3. the *rejoin cell* is the first path cell beyond the blocked step that is free and
   reachable from the robot's cell on the updated map (an exact flood fill). If the goal
   (the last path cell) is blocked or unreachable the result is an explicit no-path
   result (``success=False``, ``status`` and ``reason`` name the cause); nothing is
   raised from inside JAX;
4. the preset (default ``hybrid``) runs ``seeds`` seeded runs in ONE compiled call
   (:func:`jaxga.run`) from the robot's cell (or, with ``plan_from="blockage"``, from the
   last path cell before the blocked step) to the rejoin cell, with a small population
   and few generations. The best successful seed (shortest segment) is taken. Compiled
   programs are cached per (algorithm, map shape, number of runs), so every re-plan on a
   map of the same size - or in a window of the same size, see ``window`` - after the
   first reuses them;
5. splice: robot's cell -> GA segment -> the old path after the rejoin cell; loops are
   cut out (MPMGA's deletion operator, ``remove_loops``); the rest of the path is
   checked again, and a later blocked step is re-planned the same way from the last clear
   cell before it;
6. the spliced path is verified step by step on the updated map before it is returned.

Decisions (not in the paper):

* The GA segment that is spliced is the seed's raw 8-connected best path (the robot's
  path stays a sequence of legal moves); ``post=True`` splices the post-optimised
  waypoint segment (feasible by line of sight) instead.
* GA failure (no seed found a feasible segment) is reported honestly by default:
  ``success=False``, ``status="ga_failed"``, a ``reason``. With ``fallback=True`` the
  exact 8-connected A* segment (:func:`jaxga.reference.optima.shortest_path`) is spliced
  instead and the result says so (``used_fallback=True``, ``status="fallback"``).
* ``latency_s`` is the wall time of the call minus the time spent compiling
  (``compile_s``, non-zero only on the first call for a map/window size and seed count;
  with JAX's persistent cache it is the time to load the compiled programs).
* MPMGA numbers grid cells 0, 1, 2, ... from left to right and bottom to top (its
  section 3 and Fig. 2; eq. 1-2 give 1-based coordinates ``x = mod(p, N) + 1``,
  ``y = fix(p / N) + 1``). In jaxga's 0-based ``(x, y)`` with row 0 at the bottom that is
  exactly ``p = y * W + x``: :func:`mpmga_cell` is ``(p % W, p // W)``. So cell 295 of the
  25 x 25 map is ``(20, 11)``, 320 ``(20, 12)``, 345 ``(20, 13)``, 370 ``(20, 14)`` (a
  vertical run of the path), and on the 50 x 50 map 759 is ``(9, 15)``, the block is
  ``x`` 10-12 by ``y`` 16-18 and 963 is ``(13, 19)`` (a diagonal run).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from jaxga import api
from jaxga.config.presets import as_sets, overridden_keys
from jaxga.config.schema import SCHEMA
from jaxga.core.equality import MutableValueEquality
from jaxga.core.errors import EndpointError, JaxgaError, ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import Grid
from jaxga.core.own_settings import own_settings
from jaxga.maps import rectangles_map
from jaxga.maps.frame import MapFrame
from jaxga.maps.preprocess import inflate_blocked, reachable, reachable_np
from jaxga.reference.optima import (
    clear_np,
    line_walk,
    path_length,
    shortest_path,
    shortest_path_np,
)

__all__ = [
    "MPMGA_SCENARIOS",
    "ReplanResult",
    "Scenario",
    "first_blocked_step",
    "mpmga_cell",
    "mpmga_scenario",
    "remove_loops_xy",
    "replan",
]

XY = tuple[int, int]

DEFAULT_PRESET = "hybrid"
"""The re-planning GA unless one is named: jaxga's own preset, whose initialiser walks down
the exact distance field (it found the detour of every reachable re-plan; MPMGA's
intermittent initialiser can fail on a corridor's detour)."""
DEFAULT_SEEDS = 4
DEFAULT_GENERATIONS = 20
DEFAULT_POPULATION = 10
"""Small GA budget of a re-plan: 4 seeds x 20 generations x population 10 (per island
for ``mpmga``: 3 islands of 10). The paper re-planned with its global settings."""


# =============================================================================== result
@dataclasses.dataclass(eq=False)
class ReplanResult(MutableValueEquality):
    """The outcome of :func:`replan` (MPMGA 5.2.1 / 5.3.1).

    Attributes:
        success: True when ``path`` is a feasible path from the robot's cell to the goal.
        status: ``"clear"`` (nothing blocked, path unchanged, no GA run), ``"replanned"``,
            ``"fallback"`` (A* segment spliced, ``fallback=True``), ``"goal_blocked"``,
            ``"unreachable"`` or ``"ga_failed"``.
        reason: ``""`` on a plain success, else why (no path, GA failure, fallback used).
        path: ``(x, y)`` cells from the robot's cell to the goal; ``[]`` when not success.
        length: Euclidean length of ``path`` (``inf`` when not success).
        segment: the (first) replanned part, from the cell planned from to the rejoin cell
            inclusive; ``[]`` when nothing was replanned.
        rejoin: the (first) rejoin cell, or None.
        blockage: the first blocked step ``((x, y), (x, y))`` of the remaining path, or None.
        segments: every splice made, as dicts (``start``, ``rejoin``, ``blockage``,
            ``segment``, ``ga_success`` = seeds that found a segment, ``window``,
            ``used_fallback``, ``wall_s``).
        used_fallback: True when an exact A* segment replaced a failed GA.
        latency_s: wall time of the call minus ``compile_s``.
        compile_s: time spent compiling (or loading compiled) GA programs in this call.
        wall_s: wall time of the whole call.
        prefix: the travelled part of the old path, up to and including the robot's cell.
        ga: the :class:`jaxga.Result` of every GA call (for inspection).
        corner_rule: the corner rule under which the path was judged and re-planned.
    """

    success: bool
    status: str
    reason: str
    path: list[XY]
    length: float
    segment: list[XY]
    rejoin: XY | None
    blockage: tuple[XY, XY] | None
    segments: list[dict[str, Any]]
    used_fallback: bool
    latency_s: float
    compile_s: float
    wall_s: float
    prefix: list[XY]
    ga: list[Any] = dataclasses.field(default_factory=list, repr=False)
    corner_rule: str = ""

    def summary(self) -> str:
        """A few lines: status, blockage, rejoin, segment, length and times."""
        lines = [f"status      {self.status}" + (f" ({self.reason})" if self.reason else ""),
                 f"corner rule {self.corner_rule!r}"]
        if self.blockage is not None:
            lines.append(f"blocked     step {self.blockage[0]} -> {self.blockage[1]}")
        for s in self.segments:
            lines.append(
                f"replanned   {s['start']} -> {s['rejoin']}: {len(s['segment'])} cells, "
                f"{s['ga_success']}/{s['seeds']} seeds succeeded"
                + (" (A* fallback)" if s["used_fallback"] else "")
                + (f", window {s['window']}" if s["window"] else "")
            )
        if self.success:
            lines.append(f"path        {len(self.path)} cells, length {self.length:.4f}, "
                         f"{self.path[0]} -> {self.path[-1]}")
        lines.append(f"time (s)    latency {self.latency_s:.3f}, compile {self.compile_s:.2f}, "
                     f"wall {self.wall_s:.3f}")
        return "\n".join(lines)

    def metres_text(self, frame: MapFrame | None) -> str:
        """The re-planned path in metres (a map with a resolution; "" otherwise): its
        length and its ends' centres."""
        if frame is None or not frame.has_metres or not self.success:
            return ""
        ends = frame.to_world(np.asarray([self.path[0], self.path[-1]], float))
        return (f"metres      length {self.length * frame.cell_size:.3f} m, "
                f"({ends[0][0]:.3f}, {ends[0][1]:.3f}) -> ({ends[1][0]:.3f}, {ends[1][1]:.3f})")

    def to_json(self, frame: MapFrame | None = None) -> dict[str, Any]:
        """A JSON-serialisable dict (the ``--json`` layout of ``jaxga replan``); with a
        ``frame`` (:mod:`jaxga.maps.frame`) the path also in metres (``path_world``,
        ``length_m``) and in the map file's cells (``map_path``, when coarsened)."""
        def xy(p):
            return None if p is None else [int(p[0]), int(p[1])]

        extra: dict[str, Any] = {}
        if frame is not None and self.success:
            cells = np.asarray(self.path, float)
            if frame.coarsen > 1:
                extra["map_path"] = frame.map_cell(cells.astype(np.int64)).tolist()
            if frame.has_metres:
                extra["path_world"] = frame.world_list(cells)
                extra["length_m"] = float(self.length * frame.cell_size)
        return {
            "success": self.success, "status": self.status, "reason": self.reason,
            "corner_rule": self.corner_rule, "path": [xy(p) for p in self.path],
            "length": None if not math.isfinite(self.length) else float(self.length),
            "segment": [xy(p) for p in self.segment], "rejoin": xy(self.rejoin),
            "blockage": None if self.blockage is None else [xy(p) for p in self.blockage],
            "segments": [{**s, "start": xy(s["start"]), "rejoin": xy(s["rejoin"]),
                          "blockage": [xy(p) for p in s["blockage"]],
                          "segment": [xy(p) for p in s["segment"]],
                          "window": None if s["window"] is None else list(s["window"])}
                         for s in self.segments],
            "used_fallback": self.used_fallback, "latency_s": self.latency_s,
            "compile_s": self.compile_s, "wall_s": self.wall_s,
            "prefix": [xy(p) for p in self.prefix],
            **extra,
        }


# ============================================================================== helpers
def mpmga_cell(p: int, width: int) -> XY:
    """MPMGA's grid number ``p`` as jaxga ``(x, y)`` (MPMGA section 3, eq. 1-2; docs/maps.md).

    MPMGA numbers cells 0, 1, 2, ... from left to right and bottom to top, so its number
    is jaxga's cell index ``y * W + x`` and this is ``(p % W, p // W)`` (the paper's eq. 1
    adds 1 to both for its 1-based coordinates).
    """
    p, width = int(p), int(width)
    if width < 1 or p < 0:
        raise ParameterError(f"bad MPMGA cell {p} for width {width}")
    return p % width, p // width


def _as_xy_list(path: Any, name: str) -> list[XY]:
    try:
        arr = np.asarray(path)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a list of (x, y) integer pairs") from None
    if arr.size and arr.dtype.kind not in "iu":  # 0.9 is not cell 0, True is not 1
        raise ParameterError(f"{name} must be a list of (x, y) integer pairs, got values of "
                             f"type {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 2:
        if arr.size == 0:
            return []
        raise ParameterError(f"{name} must be a list of (x, y) integer pairs, got shape "
                             f"{arr.shape}")
    return [(int(x), int(y)) for x, y in arr]


def _on_map(xy: XY, w: int, h: int) -> bool:
    return 0 <= xy[0] < w and 0 <= xy[1] < h


def _obstacle_mask(new_obstacles: Any, h: int, w: int) -> np.ndarray:
    """``bool[H, W]`` of the new obstacles: a mask of the map's shape or (x, y) cells."""
    if new_obstacles is None:
        return np.zeros((h, w), bool)
    arr = np.asarray(new_obstacles)
    if arr.dtype == np.bool_ and arr.ndim == 2:
        if arr.shape != (h, w):
            raise ParameterError(f"new_obstacles mask has shape {arr.shape}, the map is "
                                 f"{(h, w)} (H, W)")
        return arr.copy()
    if arr.ndim == 2 and arr.shape == (h, w) and w != 2:  # (H, 2) could be pairs
        raise ParameterError(f"new_obstacles of the map's shape {(h, w)} but of type "
                             f"{arr.dtype}: a mask must be bool (mask.astype(bool)), or give "
                             "a list of (x, y) cells")
    mask = np.zeros((h, w), bool)
    for x, y in _as_xy_list(new_obstacles, "new_obstacles"):
        if not _on_map((x, y), w, h):
            raise ParameterError(f"new obstacle cell ({x}, {y}) is off the {w} x {h} map")
        mask[y, x] = True
    return mask


def first_blocked_step(blocked: np.ndarray, corner_rule: str, path: Sequence[XY],
                       start: int = 0) -> int | None:
    """Index ``k >= start`` of the first step ``path[k] -> path[k+1]`` that is not clear.

    A step is clear when its segment is (:func:`jaxga.reference.optima.clear_np`): for
    8-adjacent cells, exactly when the move is legal under the corner rule. Returns None
    when every step from ``start`` on is clear (MPMGA 5.2.1: "obstacles suddenly appear
    ... blocking the path").
    """
    for k in range(start, len(path) - 1):
        if not clear_np(blocked, corner_rule, path[k], path[k + 1]):
            return k
    return None


def remove_loops_xy(path: Sequence[XY]) -> list[XY]:
    """Cut out everything between two visits of the same cell (MPMGA 4.2 deletion
    operator, ``remove_loops``), keeping the first visit; host version.

    Used after splicing (MPMGA 5.2.1): a detour that touches the old path
    again must not make the robot walk a loop. Feasibility is kept (the cut joins a cell
    to itself).
    """
    out: list[XY] = []
    where: dict[XY, int] = {}
    for c in path:
        if c in where:
            keep = where[c] + 1
            for d in out[keep:]:
                del where[d]
            del out[keep:]
        else:
            where[c] = len(out)
            out.append(c)
    return out


def _dedupe(path: Sequence[XY]) -> list[XY]:
    out: list[XY] = []
    for c in path:
        if not out or out[-1] != c:
            out.append(c)
    return out


WINDOW_SIDES: tuple[int, ...] = (32, 64, 128, 256)
"""Window sides ``window="auto"`` tries, smallest first: a few shapes, so that the
compiled programs of one side serve every re-plan of that size on any map."""

WINDOW_MARGIN = 8
"""Cells ``window="auto"`` keeps at least between the re-planned pair and a window's edge,
room for a detour."""


def _window_sizes(window: int | str | None, a: XY, b: XY, h: int, w: int) -> list[int]:
    """The window sides to try for a re-plan from ``a`` to ``b`` (see :func:`replan`)."""
    if window is None:
        return []
    if window != "auto":
        return [int(window)]
    span = max(abs(a[0] - b[0]), abs(a[1] - b[1]))
    return [s for s in WINDOW_SIDES if span + 2 * WINDOW_MARGIN <= s and s < max(h, w)]


def _window_box(a: XY, b: XY, size: int, h: int, w: int) -> tuple[int, int, int, int] | None:
    """``(x0, y0, ww, hh)``: a ``size`` x ``size`` window (clipped to the map) holding
    ``a`` and ``b`` with the pair centred as far as the map edge allows; None if they do
    not fit."""
    ww, hh = min(size, w), min(size, h)
    if abs(a[0] - b[0]) >= ww or abs(a[1] - b[1]) >= hh:
        return None
    cx = (a[0] + b[0]) // 2
    cy = (a[1] + b[1]) // 2
    x0 = min(max(cx - ww // 2, 0), w - ww)
    y0 = min(max(cy - hh // 2, 0), h - hh)
    x0 = min(x0, min(a[0], b[0]))
    x0 = max(x0, max(a[0], b[0]) - ww + 1)
    y0 = min(y0, min(a[1], b[1]))
    y0 = max(y0, max(a[1], b[1]) - hh + 1)
    return x0, y0, ww, hh


# ================================================================================ replan
def _run_options(overrides: Mapping[str, Any], generations: int | None,
                 population: int | None, grid: Grid | None = None) -> dict[str, Any]:
    """:func:`jaxga.run`'s keyword options for the re-planning GA. ``generations`` and
    ``population`` at replan's defaults give way to the same keys in ``overrides`` or
    their ``sets`` (``--set generations=30``); other values are given as such, so that
    :func:`jaxga.run` refuses two different values for one key. With ``grid`` the path
    capacity is ``4 (H + W)`` unless ``population.capacity`` is given: one compiled
    program per map (or window) size, whatever the segment (the automatic capacity
    follows the problem's optimum, which would compile again for longer segments;
    decision 020)."""

    kw = dict(overrides)
    keys = set(overridden_keys({k: v for k, v in kw.items() if k != "sets"},
                               as_sets(kw.get("sets", ()))))
    if grid is not None and "population.capacity" not in keys:
        kw["population__capacity"] = 4 * (grid.height + grid.width)
    if not (generations == DEFAULT_GENERATIONS and "generations" in keys):
        kw["generations"] = generations
    if population is None or (population == DEFAULT_POPULATION and "population.size" in keys):
        return kw
    if "population__size" in kw and kw["population__size"] != population:
        raise ParameterError(f"population.size is given twice, as {population!r} "
                             f"(population) and {kw['population__size']!r}")
    kw["population__size"] = population  # checked as the configuration key
    return kw


@own_settings
def replan(
    grid: Grid,
    path: Sequence[XY] | np.ndarray,
    new_obstacles: Iterable[XY] | np.ndarray | None,
    position: XY | int,
    preset: Any = DEFAULT_PRESET,
    *,
    seeds: int | Sequence[int] = DEFAULT_SEEDS,
    generations: int = DEFAULT_GENERATIONS,
    population: int | None = DEFAULT_POPULATION,
    window: int | str | None = "auto",
    plan_from: str = "robot",
    post: bool = False,
    fallback: bool = False,
    inflate: float = 0.0,
    **overrides: Any,
) -> ReplanResult:
    """Re-plan the rest of ``path`` around ``new_obstacles`` from the robot's cell.

    MPMGA 5.2.1 / 5.3.1 (local path re-planning against sudden obstacles; docs/replanning.md);
    the steps and decisions are in the module docstring.

    Args:
        grid: the map (its ``blocked`` array and ``corner_rule``; its start and goal are
            ignored: the path's last cell is the goal).
        path: the robot's planned path, ``(x, y)`` cells from its start to the goal
            (e.g. ``Result.path(i, raw=True)``, any continuous path, or a feasible
            waypoint path).
        new_obstacles: cells ``(x, y)`` that became blocked, or a ``bool[H, W]`` mask.
        position: the robot's current cell ``(x, y)`` (its first occurrence on ``path``)
            or an index into ``path``.
        preset: the GA (a preset name, TOML file or :class:`jaxga.config.schema.Config`).
            Default ``"hybrid"``: its field-walk initialiser cannot fail where a segment
            exists, so the re-plan finds the detour whenever there is one (within the
            path capacity); ``"mpmga"`` is the paper's own re-planning GA.
        seeds: seeded GA runs in one compiled call; the best successful one is used.
        generations: GA generations (small: this is a real-time re-plan). At its
            default, a ``generations`` in the overrides (``sets``) wins.
        population: ``population.size`` override (per island for island presets); None
            keeps the preset's. At its default, a ``population.size`` in the overrides
            wins.
        window: the GA runs on a ``window`` x ``window`` crop of the map around the
            planning start and the rejoin cell, so one compiled program serves every
            map size; when they do not fit in the window or the crop cuts them apart,
            the whole map is used. ``"auto"`` (default): the smallest of
            :data:`WINDOW_SIDES` that holds both with a margin and joins them (the cost
            of a re-plan then follows the detour, not the map); None: the whole map.
        plan_from: ``"robot"`` (MPMGA 5.2.1: plan from the robot's cell) or
            ``"blockage"`` (from the last path cell before the blocked step).
        post: splice the GA's post-optimised waypoint segment instead of its raw
            8-connected one.
        fallback: if no seed finds a segment, splice the exact A* segment and flag it
            (``used_fallback``) instead of returning ``success=False``.
        inflate: grow the new obstacles by this many cells (centre to centre,
            :func:`jaxga.maps.preprocess.inflate_blocked`), as the map was grown for the
            robot's size (``--inflate``, ``--robot-radius``), so that the new path keeps
            the same distance from them.
        overrides: further configuration overrides for :func:`jaxga.run`
            (``mutation__temperature_c1=...``; checked at once, as :func:`jaxga.run`
            checks them, also when the path needs no GA run).

    Returns:
        A :class:`ReplanResult`. An unreachable or blocked goal and a GA failure are
        results (``success=False`` with ``status`` and ``reason``), not exceptions.

    Raises:
        EndpointError: the robot's cell is off the map or blocked.
        ParameterError: the robot's cell is not on the path, or bad arguments.
    """
    t_start = time.perf_counter()
    _check_arguments(grid, plan_from, window, population, post=post, fallback=fallback)
    problem = _problem(grid, path, new_obstacles, position, inflate)
    # The GA's configuration is checked now (overrides that nothing reads, key
    # combinations), not only when a blocked path needs a GA run; on the map with the
    # robot's cell as its endpoints (never the map's default corners).
    api.check_run(preset, grid.replace(start=problem.robot, goal=problem.robot),
                  **_run_options(overrides, generations, population, grid))
    k = first_blocked_step(problem.blocked, problem.rule, problem.rest)
    blockage = None if k is None else (problem.rest[k], problem.rest[k + 1])

    def result(success: bool, status: str, reason: str, out: list[XY] = (),
               segments: list[dict] = (), compile_s: float = 0.0,
               ga: list = ()) -> ReplanResult:
        return _result(problem, blockage, t_start, success, status, reason, list(out),
                       list(segments), compile_s, list(ga))

    if k is None:
        return result(True, "clear", "", problem.rest)
    goal, robot = problem.goal, problem.robot
    if problem.blocked[goal[1], goal[0]]:
        why = ("a new obstacle" if problem.added[goal[1], goal[0]]
               else "an obstacle of the map")
        return result(False, "goal_blocked", f"goal {goal} is blocked ({why})")
    work = grid.replace(blocked=problem.blocked, start=robot, goal=robot)
    reach = reachable(work, robot)
    if not reach[goal[1], goal[0]]:
        return result(False, "unreachable",
                      f"goal {goal} is unreachable from the robot's cell {robot} after the "
                      f"new obstacles (corner rule {problem.rule!r})")
    spliced, segments, compile_s, ga_results = _splice_detours(
        problem, work, reach, k, plan_from, dict(
            preset=preset, seeds=seeds, generations=generations, population=population,
            window=window, post=post, fallback=fallback, overrides=overrides))
    if spliced is None:
        return result(False, "ga_failed", segments[-1]["reason"], [], segments, compile_s,
                      ga_results)
    used = any(s["used_fallback"] for s in segments)
    return result(True, "fallback" if used else "replanned",
                  "GA found no segment; the exact A* segment was spliced" if used else "",
                  spliced, segments, compile_s, ga_results)


def _check_arguments(grid: Grid, plan_from: str, window: Any, population: int | None,
                     **switches: Any) -> None:
    """Refuse bad arguments of :func:`replan` before any work; ``switches`` (post,
    fallback) must be booleans: ``fallback="no"`` would be true."""
    for name, value in switches.items():
        if not isinstance(value, (bool, np.bool_)):
            raise ParameterError(f"{name} must be True or False, got {shown_value(value)}")
    if not isinstance(grid, Grid):
        raise ParameterError(f"grid must be a jaxga.Grid, got {type(grid).__name__}")
    if plan_from not in ("robot", "blockage"):
        raise ParameterError(f"plan_from must be 'robot' or 'blockage', got {plan_from!r}")
    if window != "auto" and window is not None and (
            isinstance(window, bool) or not isinstance(window, int) or window < 2):
        raise ParameterError(f"window must be 'auto', an integer >= 2 or None, got "
                             f"{window!r}")
    if population is not None:  # checked now, also when no GA run is needed
        SCHEMA["population.size"].check("population", population)


@dataclasses.dataclass(frozen=True)
class _Problem:
    """A re-planning problem, checked: the path (repeated cells merged), the map with the
    new obstacles (grown by ``inflate``), the robot's cell and where it is on the path."""

    rule: str
    cells: list[XY]
    added: np.ndarray  # bool[H, W]: the new obstacles as grown
    blocked: np.ndarray  # bool[H, W]: the map's and the new obstacles
    robot: XY
    prefix: list[XY]  # the path up to the robot's cell
    rest: list[XY]  # the path from the robot's cell to the goal

    @property
    def goal(self) -> XY:
        return self.rest[-1]


def _problem(grid: Grid, path: Any, new_obstacles: Any, position: XY | int,
             inflate: float) -> _Problem:
    """The checked :class:`_Problem` of :func:`replan`'s arguments."""
    h, w = grid.height, grid.width
    given = _as_xy_list(path, "path")
    cells = _dedupe(given)
    if not cells:
        raise ParameterError("path is empty")
    for c in cells:
        if not _on_map(c, w, h):
            raise ParameterError(f"path cell {c} is off the {w} x {h} map")
    added = _obstacle_mask(new_obstacles, h, w)
    if inflate:
        added = inflate_blocked(added, inflate) & ~grid.blocked_np()
    blocked = grid.blocked_np() | added
    if isinstance(position, (int, np.integer)) and not isinstance(position, bool):
        if not 0 <= int(position) < len(given):
            raise ParameterError(f"position index {position} is outside the path "
                                 f"(0..{len(given) - 1})")
        # the index is into the path as given; a cell repeated in a row is one waypoint
        i = sum(given[k] != given[k - 1] for k in range(1, int(position) + 1))
        robot = cells[i]
    else:
        robot = _as_xy_list([position], "position")[0]
        if not _on_map(robot, w, h):
            raise EndpointError(f"robot cell {robot} is off the {w} x {h} map")
        if robot not in cells:  # between two waypoints: it becomes one
            cells = _with_waypoint(cells, robot, grid.blocked_np(), grid.corner_rule)
        i = cells.index(robot)
    if blocked[robot[1], robot[0]]:
        why = ("a new obstacle" + (f" or within {inflate:g} cells of one" if inflate else "")
               if added[robot[1], robot[0]] else "an obstacle of the map")
        raise EndpointError(f"robot cell {robot} is blocked ({why})")
    return _Problem(grid.corner_rule, cells, added, blocked, robot, cells[: i + 1], cells[i:])


def _with_waypoint(cells: list[XY], robot: XY, blocked: np.ndarray,
                   corner_rule: str) -> list[XY]:
    """``cells`` with ``robot`` inserted where the path passes through it: in the first
    segment ``a b`` whose line (:func:`jaxga.reference.optima.line_walk`) enters that
    cell; a one-line :class:`ParameterError` when no segment does.

    The robot's centre is not on the line, so ``robot b`` may enter cells ``a b`` does
    not: where ``robot b`` is not clear on the map planned on (``blocked``, before the new
    obstacles), the rest of the line's own cells follow the robot instead (each step of
    them is clear exactly when that part of ``a b`` is), so a clear path never shows a
    blocked step that is not there."""
    for k, (a, b) in enumerate(zip(cells[:-1], cells[1:])):
        walk = [cell for cell, _ in line_walk(a, b)]
        if robot in walk:
            rest = [] if clear_np(blocked, corner_rule, robot, b) else \
                walk[walk.index(robot) + 1:-1]
            return [*cells[: k + 1], robot, *rest, *cells[k + 1:]]
    raise ParameterError(f"robot cell {robot} is not on the path (neither one of its cells "
                         "nor crossed by one of its segments)")


def _result(problem: _Problem, blockage: tuple | None, t_start: float, success: bool,
            status: str, reason: str, out: list[XY], segments: list[dict], compile_s: float,
            ga: list) -> ReplanResult:
    """The :class:`ReplanResult` of a re-plan that ends here."""
    wall = time.perf_counter() - t_start
    first = segments[0] if segments else None
    return ReplanResult(
        success=success, status=status, reason=reason,
        path=out if success else [],
        length=path_length(np.asarray(out)) if success else math.inf,
        segment=list(first["segment"]) if first else [],
        rejoin=first["rejoin"] if first else None,
        blockage=blockage, segments=segments,
        used_fallback=any(s["used_fallback"] for s in segments),
        latency_s=wall - compile_s, compile_s=compile_s, wall_s=wall,
        prefix=problem.prefix, ga=ga, corner_rule=problem.rule)


def _splice_detours(problem: _Problem, work: Grid, reach: np.ndarray, k: int,
                    plan_from: str, ga_options: dict) -> tuple:
    """Splice a GA segment past each blocked step of the path, from the first (step
    ``k``): ``(spliced path or None when a segment was not found, segments, compile
    seconds, GA results)``."""
    blocked, rule = problem.blocked, problem.rule
    segments: list[dict] = []
    ga_results: list = []
    compile_s = 0.0
    current = list(problem.rest)
    for _ in range(len(problem.cells) + 1):  # each pass splices past one blocked step
        # rejoin: first cell after the blocked step that is free and reachable
        j = next(j for j in range(k + 1, len(current))
                 if not blocked[current[j][1], current[j][0]]
                 and reach[current[j][1], current[j][0]])
        s_idx = 0 if (plan_from == "robot" and not segments) else k
        start, rejoin = current[s_idx], current[j]
        seg, info, c_s = _plan_segment(work, blocked, start, rejoin, **ga_options)
        compile_s += c_s
        res = info.pop("result", None)
        if res is not None:
            ga_results.append(res)
        info.update(blockage=(current[k], current[k + 1]))
        segments.append(info)
        if seg is None:
            return None, segments, compile_s, ga_results
        spliced = remove_loops_xy(current[:s_idx] + seg + current[j + 1:])
        r_idx = spliced.index(rejoin) if rejoin in spliced else 0
        current = spliced
        k = first_blocked_step(blocked, rule, current, r_idx)
        if k is None:
            break
    bad = first_blocked_step(blocked, rule, current)
    if bad is not None or current[0] != problem.robot \
            or current[-1] != problem.goal:  # pragma: no cover
        raise JaxgaError(f"internal error: spliced path is not feasible at step {bad}")
    return current, segments, compile_s, ga_results


def _plan_segment(work: Grid, blocked: np.ndarray, start: XY, rejoin: XY, preset: Any, *,
                  seeds, generations, population, window, post, fallback, overrides
                  ) -> tuple[list[XY] | None, dict[str, Any], float]:
    """One GA call from ``start`` to ``rejoin`` (MPMGA 5.2.1); returns the
    segment (or None), a description and the compile time."""

    t0 = time.perf_counter()
    rule = work.corner_rule
    h, w = blocked.shape
    info: dict[str, Any] = {"start": start, "rejoin": rejoin, "window": None,
                            "used_fallback": False, "reason": "", "result": None}
    if start == rejoin:
        info.update(segment=[start], ga_success=0, seeds=0, wall_s=0.0)
        return [start], info, 0.0
    ox = oy = 0
    sub = blocked
    for size in _window_sizes(window, start, rejoin, h, w):
        box = _window_box(start, rejoin, size, h, w)
        if box is None:
            continue
        x0, y0, ww, hh = box
        crop = blocked[y0:y0 + hh, x0:x0 + ww]
        if reachable_np(crop, (start[0] - x0, start[1] - y0), rule)[rejoin[1] - y0,
                                                                      rejoin[0] - x0]:
            ox, oy, sub = x0, y0, crop
            info["window"] = box
            break
    g = Grid.create(sub, start=(start[0] - ox, start[1] - oy),
                    goal=(rejoin[0] - ox, rejoin[1] - oy), corner_rule=rule)
    # no any-angle reference: a re-plan reports its segment, not a gap
    r = api.run(preset, g, seeds=seeds, any_angle_budget=0.0,
                **_run_options(overrides, generations, population, g))
    info["result"] = r
    n_ok = int(np.sum(r.success))
    info.update(ga_success=n_ok, seeds=len(r.seeds))
    best: list[XY] | None = None
    best_len = math.inf
    for s in np.flatnonzero(r.success):
        cand = [(x + ox, y + oy) for x, y in r.path(int(s), raw=not post)]
        if (len(cand) < 1 or cand[0] != start or cand[-1] != rejoin
                or first_blocked_step(blocked, rule, cand) is not None):
            continue  # never splice a segment that is not feasible on the whole map
        length = path_length(np.asarray(cand))
        if length < best_len:
            best, best_len = cand, length
    if best is None:
        info["reason"] = (f"the GA ({r.preset}, {len(r.seeds)} seeds x {r.generations} "
                          f"generations) found no feasible segment {start} -> {rejoin}")
        if fallback:
            exact = shortest_path_np(blocked, start, rejoin, rule)
            best = [tuple(int(v) for v in c) for c in exact.path]  # type: ignore[misc]
            info["used_fallback"] = True
    info.update(segment=list(best or []), wall_s=time.perf_counter() - t0)
    return best, info, float(r.timing.get("compile_s", 0.0))


# ============================================================================ scenarios
@dataclasses.dataclass(frozen=True)
class Scenario:
    """A re-planning scenario: map, planned path, new obstacles, robot cell, expected
    rejoin cell (MPMGA 5.2.1 / 5.3.1)."""

    name: str
    grid: Grid
    path: list[XY]
    new_obstacles: list[XY]
    position: XY
    rejoin: XY
    description: str


MPMGA_SCENARIOS: dict[str, dict[str, Any]] = {
    # MPMGA 5.2.1, Fig. 14: 25 x 25 map, entry grid 10, exit grid 624; sudden obstacles
    # at grids 320 and 345; the robot at grid 295 re-plans to grid 370.
    "25x25": dict(size=25, start=10, goal=624, obstacles=[320, 345], position=295,
                  rejoin=370, n_rects=8, seed=6),
    # MPMGA 5.3.1, Fig. 20: 50 x 50 map, entry grid 0, exit grid 2499; a 3 x 3 block at
    # grids 810-812, 860-862, 910-912; the robot at grid 759 re-plans to grid 963.
    "50x50": dict(size=50, start=0, goal=2499,
                  obstacles=[810, 811, 812, 860, 861, 862, 910, 911, 912], position=759,
                  rejoin=963, n_rects=25, seed=16),
}
"""The paper's cell numbers; the maps are generated (the paper's maps are figures only)."""


def mpmga_scenario(name: str) -> Scenario:
    """MPMGA's re-planning scenario ``"25x25"`` (5.2.1) or ``"50x50"`` (5.3.1).

    The paper's maps exist only as figures, so the map is generated
    (:func:`jaxga.maps.rectangles_map`, corner rule ``"free"`` as in the paper's GA, the
    paper's entry and exit cells) with a seed chosen so that the exact 8-connected
    shortest path - the "planned path" the robot follows - runs through the paper's
    cells: 295 -> 320 -> 345 -> 370 on the 25 x 25 map and 759 -> 810 -> 861 -> 912 -> 963
    on the 50 x 50 map. Cell numbers are converted by :func:`mpmga_cell`.
    """

    if name not in MPMGA_SCENARIOS:
        raise ParameterError(f"unknown scenario {name!r}: expected one of "
                             f"{', '.join(MPMGA_SCENARIOS)}")
    s = MPMGA_SCENARIOS[name]
    n = s["size"]
    grid = rectangles_map(n, n, s["n_rects"], s["seed"], min_size=2, max_size=n // 5,
                          start=mpmga_cell(s["start"], n), goal=mpmga_cell(s["goal"], n),
                          corner_rule="free")
    planned = [(int(x), int(y)) for x, y in shortest_path(grid).path]
    position, rejoin = mpmga_cell(s["position"], n), mpmga_cell(s["rejoin"], n)
    obstacles = [mpmga_cell(p, n) for p in s["obstacles"]]
    if position not in planned or rejoin not in planned:  # pragma: no cover - generator drift
        raise JaxgaError(f"scenario {name}: the generated planned path no longer passes "
                         f"through cells {s['position']} and {s['rejoin']}")
    return Scenario(
        name=name, grid=grid, path=planned, new_obstacles=obstacles, position=position,
        rejoin=rejoin,
        description=(f"MPMGA {'5.2.1' if n == 25 else '5.3.1'}: {n} x {n}, obstacles at "
                     f"cells {s['obstacles']}, robot at {s['position']}, re-plan to "
                     f"{s['rejoin']}"),
    )
