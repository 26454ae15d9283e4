"""Random map generators (host NumPy, deterministic in an integer seed).

Every generator returns a :class:`jaxga.Grid` whose start and goal are free and
connected under its corner rule (checked with :func:`jaxga.maps.reachable`). The same
arguments always give the same map (``numpy.random.default_rng(seed)``); maps from
different generators or sizes are not related. ``start`` defaults to ``(0, 0)`` and
``goal`` to ``(W - 1, H - 1)``.

* :func:`random_map` - uniformly scattered obstacle cells at a given density; resampled
  until the endpoints are connected (bounded attempts).
* :func:`maze_map` - a perfect maze (recursive backtracker) with configurable corridor
  and wall widths.
* :func:`rooms_map` - a lattice of rooms joined by doors (a random spanning tree of doors
  plus extra doors), like the Moving AI ``room`` maps.
* :func:`rectangles_map` - random axis-aligned rectangular obstacles.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from jaxga.core.errors import ParameterError
from jaxga.core.grid import DEFAULT_CORNER_RULE, Grid, as_integer, check_corner_rule, check_xy
from jaxga.maps.preprocess import reachable_np

__all__ = ["maze_map", "random_map", "rectangles_map", "rooms_map"]

XY = tuple[int, int]


# -------------------------------------------------------------------------- helpers
MAX_GENERATED_CELLS = 4096 * 4096
"""The generators' size limit: their flood fills and corridor searches run in Python over
every cell, so a 100,000 x 100,000 request would take hours or exhaust memory instead of
failing; such maps are refused at once."""


def _int(name: str, value, minimum: int) -> int:
    try:
        v = as_integer(value)
    except TypeError:
        raise ParameterError(f"{name} must be an integer, got {value!r}") from None
    if v < minimum:
        raise ParameterError(f"{name} must be >= {minimum}, got {v}")
    return int(v)


def _setup(
    height, width, seed, start, goal, corner_rule
) -> tuple[int, int, np.random.Generator, XY, XY, str]:
    h = _int("height", height, 1)
    w = _int("width", width, 1)
    if h * w > MAX_GENERATED_CELLS:
        raise ParameterError(
            f"a generated map of {w} x {h} = {h * w:,} cells is larger than the generators' "
            f"limit of {MAX_GENERATED_CELLS:,} cells (4096 x 4096); load a larger map from a "
            f"file instead")
    s = _int("seed", seed, 0)
    rule = check_corner_rule(corner_rule)
    sxy = check_xy("start", (0, 0) if start is None else start, w, h)
    gxy = check_xy("goal", (w - 1, h - 1) if goal is None else goal, w, h)
    return h, w, np.random.default_rng(s), sxy, gxy, rule


def _connected(blocked: np.ndarray, start: XY, goal: XY, rule: str) -> bool:
    return bool(reachable_np(blocked, start, rule)[goal[1], goal[0]])


def _join(blocked: np.ndarray, anchor: XY, point: XY, rule: str) -> np.ndarray:
    """Free ``anchor`` and ``point`` and, if ``point`` is cut off from ``anchor``, carve a
    4-connected corridor from ``point`` to the nearest cell reachable from ``anchor``
    (orthogonal moves are legal under every corner rule, so the result is connected)."""
    b = blocked.copy()
    h, w = b.shape
    for x, y in (anchor, point):
        b[y, x] = False
    reach = reachable_np(b, anchor, rule)
    parent = {point: point}
    queue = deque([point])
    while queue:  # BFS over all cells, ignoring obstacles, to the nearest reachable cell
        c = queue.popleft()
        if reach[c[1], c[0]]:
            while c != point:
                b[c[1], c[0]] = False
                c = parent[c]
            return b
        for dx, dy in ((1, 0), (0, 1), (-1, 0), (0, -1)):
            n = (c[0] + dx, c[1] + dy)
            if 0 <= n[0] < w and 0 <= n[1] < h and n not in parent:
                parent[n] = c
                queue.append(n)
    raise AssertionError("unreachable: the anchor itself is reachable")  # pragma: no cover


def _spans(n: int, cell: int, wall: int) -> list[tuple[int, int]]:
    """Split ``n`` cells into corridor/room spans of ``cell`` cells separated by ``wall``
    cells; the last span absorbs the remainder so that no wall runs along the far edge."""
    k = max(1, (n + wall) // (cell + wall))
    spans = [(i * (cell + wall), i * (cell + wall) + cell) for i in range(k)]
    spans[-1] = (spans[-1][0], n)
    return spans


def _lattice_map(
    h: int,
    w: int,
    rng: np.random.Generator,
    cell: int,
    wall: int,
    door: int | None,
    extra: float,
) -> np.ndarray:
    """Walls everywhere but on a lattice of open cells; join neighbouring lattice cells
    through a random spanning tree (recursive backtracker) plus a fraction ``extra`` of
    the remaining walls. ``door`` = opening width (None: the full shared span)."""
    xs, ys = _spans(w, cell, wall), _spans(h, cell, wall)
    nx, ny = len(xs), len(ys)
    b = np.ones((h, w), dtype=bool)
    for y0, y1 in ys:
        for x0, x1 in xs:
            b[y0:y1, x0:x1] = False

    def open_wall(a: tuple[int, int], c: tuple[int, int]) -> None:
        (i, j), (k, l) = sorted((a, c))
        if j == l:  # side by side: open the wall columns between lattice columns i and k
            (lo, hi), rows, cols = ys[j], None, slice(xs[i][1], xs[k][0])
        else:  # one above the other: open the wall rows between lattice rows j and l
            (lo, hi), rows, cols = xs[i], slice(ys[j][1], ys[l][0]), None
        span = hi - lo
        width = span if door is None else min(door, span)
        off = lo + int(rng.integers(0, span - width + 1))
        if rows is None:
            b[off : off + width, cols] = False
        else:
            b[rows, off : off + width] = False

    # recursive backtracker (iterative) over lattice cells (i = column, j = row)
    visited = np.zeros((nx, ny), dtype=bool)
    tree: set[tuple[tuple[int, int], tuple[int, int]]] = set()
    stack = [(0, 0)]
    visited[0, 0] = True
    while stack:
        i, j = stack[-1]
        nbrs = [
            (i + di, j + dj)
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
            if 0 <= i + di < nx and 0 <= j + dj < ny and not visited[i + di, j + dj]
        ]
        if not nbrs:
            stack.pop()
            continue
        n = nbrs[int(rng.integers(len(nbrs)))]
        visited[n] = True
        open_wall((i, j), n)
        tree.add(tuple(sorted(((i, j), n))))  # type: ignore[arg-type]
        stack.append(n)
    if extra > 0:
        for i in range(nx):
            for j in range(ny):
                for n in ((i + 1, j), (i, j + 1)):
                    if n[0] < nx and n[1] < ny and ((i, j), n) not in tree:
                        if rng.random() < extra:
                            open_wall((i, j), n)
    return b


# ------------------------------------------------------------------------ generators
def random_map(
    height: int,
    width: int,
    density: float,
    seed: int,
    start: XY | None = None,
    goal: XY | None = None,
    corner_rule: str = DEFAULT_CORNER_RULE,
    max_attempts: int = 100,
) -> Grid:
    """Uniformly random obstacles with free, connected endpoints.

    Exactly ``round(density * H * W)`` obstacle cells (capped at the number of non-endpoint
    cells) are drawn uniformly without replacement among the cells other than the start
    and goal - so the density is exact, as in the Moving AI ``random-*-*-20`` maps. If the
    goal is not reachable from the start under ``corner_rule`` the map is redrawn, up to
    ``max_attempts`` times; then :class:`~jaxga.core.errors.ParameterError` (density too high).

    Args:
        height, width: map size in cells (>= 1; at most :data:`MAX_GENERATED_CELLS`
            cells in all, like every generator here).
        density: obstacle fraction in ``[0, 1)``.
        seed: non-negative integer seed.
        start, goal: ``(x, y)`` endpoints, default ``(0, 0)`` and ``(W - 1, H - 1)``.
        corner_rule: the grid's corner rule (also used for the connectivity check).
        max_attempts: redraws before giving up.
    """
    h, w, rng, s, g, rule = _setup(height, width, seed, start, goal, corner_rule)
    if isinstance(density, bool) or not isinstance(density, (int, float, np.floating, np.integer)):
        raise ParameterError(f"density must be a number in [0, 1), got {density!r}")
    if not (0.0 <= float(density) < 1.0):
        raise ParameterError(f"density must be in [0, 1), got {density!r}")
    attempts = _int("max_attempts", max_attempts, 1)
    candidates = np.setdiff1d(np.arange(h * w), [s[1] * w + s[0], g[1] * w + g[0]])
    k = min(int(round(float(density) * h * w)), candidates.size)
    for _ in range(attempts):
        b = np.zeros(h * w, dtype=bool)
        b[rng.choice(candidates, size=k, replace=False)] = True
        b = b.reshape(h, w)
        if _connected(b, s, g, rule):
            return Grid.create(b, start=s, goal=g, corner_rule=rule)
    raise ParameterError(
        f"random_map: no {w} x {h} map with density {density} connected {s} to {g} "
        f"(corner rule {rule!r}) in {attempts} attempts; lower the density"
    )


def maze_map(
    height: int,
    width: int,
    seed: int,
    *,
    corridor_width: int = 1,
    wall_width: int = 1,
    start: XY | None = None,
    goal: XY | None = None,
    corner_rule: str = DEFAULT_CORNER_RULE,
) -> Grid:
    """A perfect maze drawn by a recursive backtracker (randomised depth-first search).

    The map is cut into a lattice of ``corridor_width`` x ``corridor_width`` cells
    separated by ``wall_width`` walls (the last row/column of cells absorbs any
    remainder; the map edge is the outer wall). The backtracker knocks down the wall
    between a cell and a random unvisited neighbour, so every open cell is connected
    and there is exactly one corridor route between two lattice cells. Endpoints that
    fall in a wall are cleared and joined to the maze by a short corridor. At most
    :data:`MAX_GENERATED_CELLS` cells.
    """
    h, w, rng, s, g, rule = _setup(height, width, seed, start, goal, corner_rule)
    c = _int("corridor_width", corridor_width, 1)
    wl = _int("wall_width", wall_width, 1)
    b = _lattice_map(h, w, rng, c, wl, door=None, extra=0.0)
    b = _join(_join(b, (0, 0), s, rule), (0, 0), g, rule)  # (0, 0) is always open
    return Grid.create(b, start=s, goal=g, corner_rule=rule)


def rooms_map(
    height: int,
    width: int,
    seed: int,
    *,
    room_size: int = 5,
    wall_width: int = 1,
    door_width: int = 1,
    extra_doors: float = 0.3,
    start: XY | None = None,
    goal: XY | None = None,
    corner_rule: str = DEFAULT_CORNER_RULE,
) -> Grid:
    """Square rooms on a lattice, separated by walls with doors.

    Rooms are ``room_size`` cells wide, walls ``wall_width`` thick (the last row/column of
    rooms absorbs any remainder; the map edge is the outer wall). Doors ``door_width``
    wide, at a random place along the shared wall, join the rooms along a random spanning
    tree (so every room is reachable), and each remaining shared wall gets a door with
    probability ``extra_doors`` (loops, as in the Moving AI ``room`` maps). At most
    :data:`MAX_GENERATED_CELLS` cells.
    """
    h, w, rng, s, g, rule = _setup(height, width, seed, start, goal, corner_rule)
    size = _int("room_size", room_size, 1)
    wl = _int("wall_width", wall_width, 1)
    door = _int("door_width", door_width, 1)
    if isinstance(extra_doors, bool) or not 0.0 <= float(extra_doors) <= 1.0:
        raise ParameterError(f"extra_doors must be a probability in [0, 1], got {extra_doors!r}")
    b = _lattice_map(h, w, rng, size, wl, door=door, extra=float(extra_doors))
    b = _join(_join(b, (0, 0), s, rule), (0, 0), g, rule)  # (0, 0) is always open
    return Grid.create(b, start=s, goal=g, corner_rule=rule)


def rectangles_map(
    height: int,
    width: int,
    n_rects: int,
    seed: int,
    *,
    min_size: int = 1,
    max_size: int | None = None,
    start: XY | None = None,
    goal: XY | None = None,
    corner_rule: str = DEFAULT_CORNER_RULE,
    max_attempts: int | None = None,
) -> Grid:
    """``n_rects`` random axis-aligned rectangular obstacles (they may overlap).

    Each rectangle's width and height are uniform in ``[min_size, max_size]`` (default
    ``max_size = max(min_size, min(H, W) // 4)``, clipped to the map) and its position is
    uniform over the placements that fit on the map. A rectangle that would cover an
    endpoint or disconnect the start from the goal is rejected and redrawn; after
    ``max_attempts`` draws in total (default ``20 * n_rects + 20``) without placing all
    rectangles, :class:`~jaxga.core.errors.ParameterError` is raised. At most
    :data:`MAX_GENERATED_CELLS` cells.
    """
    h, w, rng, s, g, rule = _setup(height, width, seed, start, goal, corner_rule)
    n = _int("n_rects", n_rects, 0)
    lo = _int("min_size", min_size, 1)
    hi = max(lo, min(h, w) // 4) if max_size is None else _int("max_size", max_size, 1)
    if hi < lo:
        raise ParameterError(f"max_size ({hi}) must be >= min_size ({lo})")
    attempts = 20 * n + 20 if max_attempts is None else _int("max_attempts", max_attempts, 1)
    b = np.zeros((h, w), dtype=bool)
    if not _connected(b, s, g, rule):  # pragma: no cover - an empty map is connected
        raise ParameterError("rectangles_map: empty map is not connected")
    placed = 0
    for _ in range(attempts):
        if placed == n:
            break
        rw = min(int(rng.integers(lo, hi + 1)), w)
        rh = min(int(rng.integers(lo, hi + 1)), h)
        x0 = int(rng.integers(0, w - rw + 1))
        y0 = int(rng.integers(0, h - rh + 1))
        if any(x0 <= x < x0 + rw and y0 <= y < y0 + rh for x, y in (s, g)):
            continue
        trial = b.copy()
        trial[y0 : y0 + rh, x0 : x0 + rw] = True
        if _connected(trial, s, g, rule):
            b = trial
            placed += 1
    if placed < n:
        raise ParameterError(
            f"rectangles_map: placed only {placed} of {n} rectangles on the {w} x {h} map "
            f"in {attempts} draws without blocking {s} -> {g}; use fewer or smaller rectangles"
        )
    return Grid.create(b, start=s, goal=g, corner_rule=rule)
