"""Map preprocessing (AGACD section 2, MPMGA section 3) and reachability.

Both papers prepare a map before planning: the robot is reduced to a point and the
obstacles are *expanded* by the robot's radius plus a safety distance (AGACD §2, MPMGA
§3 step 1) - :func:`inflate`; and a free cell whose eight neighbours are all obstacles is
marked as an obstacle too (MPMGA §3 step 3) - :func:`fill_enclosed`. Both return new
grids (the input is never changed) with the same start, goal and corner rule; they do not
check that the endpoints stay free - :meth:`jaxga.Grid.check_endpoints` does.

:func:`reachable` gives the cells reachable from a cell over legal moves under the grid's
corner rule (host-side connected components), used by the map generators to guarantee
connected endpoints and by re-planning.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from jaxga.core.errors import EndpointError, ParameterError
from jaxga.core.grid import DIRECTIONS, Grid, check_corner_rule

__all__ = [
    "check_coarse_endpoints",
    "coarsen",
    "block_middle_cells",
    "blocks_to_map",
    "coarsen_blocked",
    "endpoints_connected",
    "fill_enclosed",
    "inflate",
    "legal_moves",
    "map_to_blocks",
    "move_edges",
    "preprocess",
    "reachable",
    "region_labels",
]


# ----------------------------------------------------------------------- reachability
def legal_moves(blocked: np.ndarray, corner_rule: str) -> np.ndarray:
    """``bool[8, H, W]``: whether the move from ``(x, y)`` in direction ``d`` is legal.

    Directions are :data:`jaxga.core.grid.DIRECTIONS`. A move is legal when both cells are on
    the map and free and, for a diagonal move, the two side cells satisfy ``corner_rule``
    (decision 027) - the same rule as :func:`jaxga.core.grid.move_legal`, for every cell at once.
    """
    check_corner_rule(corner_rule)
    b = np.asarray(blocked, dtype=bool)
    h, w = b.shape
    pad = np.pad(b, 1, constant_values=True)  # off the map counts as blocked

    def at(dx: int, dy: int) -> np.ndarray:
        return pad[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]

    out = np.empty((len(DIRECTIONS), h, w), dtype=bool)
    for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
        ok = ~b & ~at(dx, dy)
        if dx and dy:
            s1, s2 = at(dx, 0), at(0, dy)
            if corner_rule == "no_squeeze":
                ok &= ~(s1 & s2)
            elif corner_rule == "strict":
                ok &= ~(s1 | s2)
        out[d] = ok
    return out


def move_edges(blocked: np.ndarray, corner_rule: str
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The legal-move graph as edge lists ``(from, to, length)`` of flat cell indices
    (``y * W + x``), direction by direction (:data:`jaxga.core.grid.DIRECTIONS`): every
    legal move under ``corner_rule``, 1 long straight and ``sqrt(2)`` diagonal."""
    h, w = np.shape(blocked)
    legal = legal_moves(blocked, corner_rule).reshape(len(DIRECTIONS), -1)
    src, dst, cost = [], [], []
    for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
        p = np.flatnonzero(legal[d])
        src.append(p)
        dst.append(p + (dy * w + dx))
        cost.append(np.full(p.size, math.sqrt(2.0) if dx and dy else 1.0))
    return np.concatenate(src), np.concatenate(dst), np.concatenate(cost)


def reachable_np(blocked: np.ndarray, source: tuple[int, int], corner_rule: str) -> np.ndarray:
    """``bool[H, W]``: the free cells reachable from ``source`` by legal 8-connected moves
    under ``corner_rule``.

    A connected-component labelling (:func:`scipy.ndimage.label`), exact for every rule:
    under ``"free"`` every diagonal step between free cells is legal, so the regions are
    the 8-connected components; under ``"no_squeeze"`` and ``"strict"`` a legal diagonal
    step has a free side cell, through which two orthogonal steps join the same cells, so
    the regions are the 4-connected components."""
    b = np.asarray(blocked, dtype=bool)
    x0, y0 = source
    if b[y0, x0]:
        return np.zeros(b.shape, bool)
    labels = region_labels(b, corner_rule)
    return labels == labels[y0, x0]


def region_labels(blocked: np.ndarray, corner_rule: str) -> np.ndarray:
    """``int[H, W]``: the connected regions of free cells under ``corner_rule``, numbered
    from 1 (0 on blocked cells); two cells share a label exactly when legal moves join
    them (see :func:`reachable_np`)."""
    from scipy import ndimage

    b = np.asarray(blocked, dtype=bool)
    structure = np.ones((3, 3), bool) if check_corner_rule(corner_rule) == "free" else None
    labels, _ = ndimage.label(~b, structure=structure)
    return labels


def reachable(grid: Grid, source: tuple[int, int] | None = None) -> np.ndarray:
    """``bool[H, W]``: the cells reachable from ``source`` (default: the grid's start).

    Legal 8-connected moves under ``grid.corner_rule`` (:func:`reachable_np`, host
    NumPy and SciPy, not for use under ``jit``). A blocked source reaches nothing (all
    False); otherwise the source itself is True.
    """
    x, y = grid.start_xy if source is None else (int(source[0]), int(source[1]))
    if not (0 <= x < grid.width and 0 <= y < grid.height):
        raise ParameterError(f"source ({x}, {y}) is off the {grid.width} x {grid.height} map")
    return reachable_np(grid.blocked_np(), (x, y), grid.corner_rule)


def endpoints_connected(grid: Grid) -> bool:
    """True when the start and goal are free and the goal is reachable from the start."""
    gx, gy = grid.goal_xy
    return bool(reachable(grid)[gy, gx])


# ---------------------------------------------------------------------- preprocessing
def inflate(grid: Grid, radius: float) -> Grid:
    """Expand the obstacles by ``radius`` cells (AGACD §2, MPMGA §3 step 1).

    Every cell whose centre lies within Euclidean distance ``radius`` (in cells, centre
    to centre, inclusive) of a blocked cell's centre becomes blocked. ``radius`` is the
    robot radius plus the safety distance, in cells; it may be fractional (1 adds the
    4 orthogonal neighbours, 1.5 adds all 8). ``radius = 0`` returns an unchanged copy.
    The map border is not an obstacle (only blocked cells are inflated). The endpoints
    are not protected: call :meth:`jaxga.Grid.check_endpoints` afterwards.

    Raises :class:`~jaxga.core.errors.ParameterError` for a negative or non-finite radius.
    """
    return grid.replace(blocked=inflate_blocked(grid.blocked_np(), radius))


INFLATE_BAND_CELLS = 1 << 22
"""Cells of one band (with its halo) :func:`inflate_blocked` transforms at a time: the
distance transform needs about 16 bytes a cell, so a band holds its memory to tens of
megabytes on a map of any size."""


def inflate_blocked(blocked: np.ndarray, radius: float,
                    band_cells: int = INFLATE_BAND_CELLS) -> np.ndarray:
    """:func:`inflate` on a ``bool[H, W]`` array (a new array).

    A cell is blocked when the nearest blocked cell's centre lies within ``radius`` of its
    own: the squared distance to it, from an exact Euclidean distance transform
    (:func:`scipy.ndimage.distance_transform_edt`, recovered as an integer, so no
    rounding decides a cell), compared with ``radius ** 2`` (1e-9 of slack for a radius
    given as ``sqrt(2)``). That costs the same at any radius, where one shifted copy per
    offset within the radius would cost ``pi r^2`` passes over the map. The map is
    transformed in bands of rows of about ``band_cells`` cells (more where the radius is
    large), each with the ``floor(radius)`` rows either side that can hold its cells'
    nearest obstacles."""
    if isinstance(radius, bool) or not isinstance(radius, numbers.Real):
        raise ParameterError(f"inflate radius must be a number of cells, got {radius!r}")
    r = float(radius)
    if not math.isfinite(r) or r < 0:
        raise ParameterError(f"inflate radius must be finite and >= 0, got {radius!r}")
    b = np.asarray(blocked, bool)
    h, w = b.shape
    r = min(r, math.hypot(h, w))  # a larger radius cannot add anything
    r2 = r * r + 1e-9
    if r2 < 1 or not b.any():  # no other cell's centre is closer than 1
        return b.copy()
    from scipy import ndimage  # deferred (decision 016)

    halo = min(math.isqrt(int(r2)), h - 1)  # rows farther away are beyond the radius
    rows = max(1, halo, band_cells // max(w, 1) - 2 * halo)  # halos at most 2/3 of a band
    out = np.empty_like(b)
    for top in range(0, h, rows):
        lo, hi = max(0, top - halo), min(h, top + rows + halo)
        band = b[lo:hi]
        if not band.any():
            out[top:top + rows] = False
            continue
        dist = ndimage.distance_transform_edt(~band)
        d2 = np.rint(np.square(dist[top - lo:top - lo + rows]))
        out[top:top + rows] = d2 <= r2
    return out


def fill_enclosed(grid: Grid) -> Grid:
    """Block every free cell whose 8 neighbours are all blocked (MPMGA §3 step 3).

    Cells off the map count as blocked, so a free corner cell whose three on-map
    neighbours are blocked is filled (and a 1 x 1 map becomes fully blocked). Such a cell
    cannot be entered or left by any move, so filling it changes no path between other
    cells. One pass reaches the fixed point: filling a cell only affects its neighbours,
    which are already blocked. The endpoints are not protected.
    """
    b = grid.blocked_np()
    h, w = b.shape
    pad = np.pad(b, 1, constant_values=True)
    enclosed = ~b
    for dx, dy in DIRECTIONS.tolist():
        enclosed &= pad[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]
    return grid.replace(blocked=b | enclosed)


def preprocess(grid: Grid, radius: float = 0.0, fill: bool = True) -> Grid:
    """The papers' preprocessing in order: :func:`inflate` by ``radius``, then (if
    ``fill``) :func:`fill_enclosed` (AGACD §2, MPMGA §3)."""
    out = inflate(grid, radius)
    return fill_enclosed(out) if fill else out


# ------------------------------------------------------------------------ coarsening
def blocks_to_map(edges: np.ndarray, factor: int, shape: tuple[int, int],
                  unit: float = 1.0) -> np.ndarray:
    """``float[..., 2]``: positions ``(x, y)`` on a grid coarsened by ``factor``
    (:func:`coarsen_blocked`), in coarse cells counted from the grid's corner (coarse cell
    ``(x, y)`` covers ``[x, x + 1) x [y, y + 1)``), as positions in the cells of the map
    of ``shape = (H, W)`` it was made from, counted the same way. A full block is ``factor``
    map cells a side; a last block that reaches past the map stands for its part on the
    map and is drawn there, so that no position of the coarse grid lies off the map
    (its centre is the middle of that part). ``unit``: the length of a map cell to
    give the positions in (metres), 1 for map cells. The inverse is
    :func:`map_to_blocks`."""
    return _scale_last_block(np.asarray(edges, np.float64) * (factor * unit), factor, shape,
                             True, unit)


def block_middle_cells(cells: np.ndarray, factor: int, shape: tuple[int, int]) -> np.ndarray:
    """``int[..., 2]``: for coarse cells ``(x, y)``, the map cell holding the middle of each
    block's part on the map of ``shape = (H, W)`` (where :func:`blocks_to_map` draws its
    centre), in integers: ``x K + K // 2``, or ``x K + part // 2`` for a last block that
    reaches past the map with ``part`` cells on it."""
    c = np.asarray(cells, np.int64)
    k = int(factor)
    out = c * k + k // 2
    for axis, size in ((0, shape[1]), (1, shape[0])):
        start = (size // k) * k
        if size - start:
            v = c[..., axis]
            out[..., axis] = np.where(v * k >= start, v * k + (size - start) // 2,
                                      out[..., axis])
    return np.minimum(out, np.array([shape[1] - 1, shape[0] - 1]))


def map_to_blocks(points: np.ndarray, factor: int, shape: tuple[int, int]) -> np.ndarray:
    """The inverse of :func:`blocks_to_map`: positions in map cells (from the map's corner)
    as positions in coarse cells."""
    return _scale_last_block(np.asarray(points, np.float64), factor, shape, False) / factor


def _scale_last_block(u: np.ndarray, k: int, shape: tuple[int, int], shrink: bool,
                      unit: float = 1.0) -> np.ndarray:
    """``u`` (map cells of length ``unit``) with the part beyond each axis's last whole
    block scaled by the last block's share of the map (``shrink``) or back."""
    out = np.array(u, np.float64, copy=True)
    for axis, size in ((0, shape[1]), (1, shape[0])):
        start = (size // k) * k * unit
        part = size - (size // k) * k
        if part and k > 1:
            ratio = part / k if shrink else k / part
            v = out[..., axis]
            out[..., axis] = np.where(v > start, start + (v - start) * ratio, v)
    return out


def coarsen_blocked(blocked: np.ndarray, factor: int) -> np.ndarray:
    """``bool[ceil(H / k), ceil(W / k)]``: ``k x k`` blocks of cells merged into one cell,
    blocked when any of its cells is (row 0 = bottom, as the input). A path on the coarse
    map is a corridor of free cells at least ``k`` wide on the original (with the corner
    rule ``"strict"``), so a plan on it is safe on the original. A last row or column of
    blocks that reaches past the map counts only the cells on the map."""
    if isinstance(factor, bool) or not isinstance(factor, numbers.Integral) or factor < 1:
        raise ParameterError(f"coarsen factor must be a positive integer, got {factor!r}")
    b = np.asarray(blocked, dtype=bool)
    if b.ndim != 2:
        raise ParameterError(f"a map must be a 2-D array, got shape {b.shape}")
    h, w = b.shape
    # a factor past the map's longer side merges it into one cell, as that side does
    # (and 2**63 would be a block no array can hold)
    k = min(int(factor), max(h, w, 1))
    hc, wc = -(-h // k), -(-w // k)
    pad = np.zeros((hc * k, wc * k), dtype=bool)  # cells past the map are not obstacles
    pad[:h, :w] = b
    return pad.reshape(hc, k, wc, k).any(axis=(1, 3))


def check_coarse_endpoints(start: tuple[int, int], goal: tuple[int, int], factor: int,
                           label: str = "") -> None:
    """Refuse a coarsening by ``factor`` that puts two distinct endpoints (map cells
    ``(x, y)``) into one coarse cell: the coarse problem would be solved by a path of
    length 0, a "success" that says nothing about the map. The message names both
    endpoints, the coarse cell and the largest smaller factor that keeps them apart;
    ``label`` (a file) starts it.

    Raises:
        EndpointError: start and goal differ but share a coarse cell.
    """
    k = int(factor)
    (sx, sy), (gx, gy) = (int(v) for v in start), (int(v) for v in goal)
    if (sx, sy) == (gx, gy) or (sx // k, sy // k) != (gx // k, gy // k):
        return
    # a factor past every coordinate puts both into cell (0, 0): start below those
    apart = next(f for f in range(min(k - 1, max(sx, sy, gx, gy)), 0, -1)
                 if (sx // f, sy // f) != (gx // f, gy // f))
    raise EndpointError(
        f"{label + ': ' if label else ''}coarsened {k} x {k}, the start (map cell "
        f"({sx}, {sy})) and the goal (map cell ({gx}, {gy})) fall into one coarse cell "
        f"({sx // k}, {sy // k}): there is nothing left to plan; coarsen less (a factor of "
        f"{apart} keeps them apart) or move an endpoint")


def coarsen(grid: Grid, factor: int) -> Grid:
    """``grid`` with ``factor x factor`` cells merged into one (:func:`coarsen_blocked`);
    the start and goal move to the coarse cells holding them, ``(x // k, y // k)``. The way
    to plan on a map over :data:`jaxga.core.grid.MAX_MAP_CELLS`: load it with
    ``load_map(..., coarsen=k)`` (``--coarsen K``), which coarsens before building the
    grid. A coarse endpoint whose block holds an obstacle is blocked:
    :meth:`jaxga.Grid.check_endpoints` says so. A factor that puts a distinct start and
    goal into one coarse cell is refused (:func:`check_coarse_endpoints`)."""
    (sx, sy), (gx, gy) = grid.start_xy, grid.goal_xy
    coarse = coarsen_blocked(grid.blocked_np(), factor)  # checks the factor
    k = int(factor)
    check_coarse_endpoints((sx, sy), (gx, gy), k)
    return Grid.create(coarse, start=(sx // k, sy // k), goal=(gx // k, gy // k),
                       corner_rule=grid.corner_rule)
