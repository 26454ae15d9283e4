"""Exact reference optima: the 8-connected and the any-angle shortest paths (SPEC 1, 11).

Every GA result is reported as a gap to an exact optimum (SPEC 11, 12). This module
computes those optima on the host with NumPy and :mod:`heapq`; it is not the hot path
and imports nothing from the JAX side of jaxga except the :class:`~jaxga.core.grid.Grid`
container, so it is an *independent* reference for the JAX code to be tested against
(in particular :func:`clear_np` is written from SPEC 1 alone, not from
``jaxga.core.geometry``).

Contents:

* :func:`shortest_path` - the 8-connected optimum: straight step cost 1, diagonal step
  cost ``sqrt(2)``, diagonal moves restricted by the grid's ``corner_rule`` (SPEC 1).
  A* with the octile heuristic over a precomputed sparse adjacency (:class:`OctileGraph`);
  :func:`distances_from` gives the whole Dijkstra distance field.
* :func:`any_angle_shortest_path` - the shortest polyline whose vertices are cell
  centres and whose every segment is *clear* (SPEC 1). This is the lower bound that a
  post-optimised GA path (SPEC 9, ``shortcut_greedy``) can reach. Every free cell can
  be a vertex (restricting the vertices to cells next to obstacles is *not* exact on a
  lattice of centres; the docstring gives a counterexample), so the search is an A*
  over the visibility graph of all free cells made fast by provable pruning (its
  heuristic is the taut-string distance of :mod:`jaxga.reference.lower_bound`, a proven
  lower bound that is also reported on its own); edges are checked lazily with the
  exact, vectorised line of sight :func:`clear_many_np`. An optional time budget makes
  the search give up promptly (status ``"budget"``) instead.
* :func:`clear_np` / :func:`clear_many_np` / :func:`clear_pairs_np` - exact,
  integer-only line of sight between cell centres (SPEC 1).

Coordinates are ``(x, y)`` with ``y = 0`` the bottom row (SPEC 1); arrays are indexed
``blocked[y, x]``. Paths are ``int32[k, 2]`` arrays of ``(x, y)`` cells from start to goal.

A blocked or off-map endpoint and an unreachable goal are *results* here
(``found=False`` with a human-readable ``reason``), not exceptions, so that a benchmark
can tabulate them; :meth:`ReferencePath.raise_if_missing` (or :func:`require`) turns
them into :class:`~jaxga.core.errors.EndpointError` / :class:`~jaxga.core.errors.NoPathError` for
the command line.
"""

from __future__ import annotations

import dataclasses
import functools
import heapq
import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from jaxga.core.errors import EndpointError, JaxgaError, NoPathError
from jaxga.core.grid import CORNER_RULES, Grid
from jaxga.maps.preprocess import legal_moves, move_edges

__all__ = [
    "ReferencePath",
    "OctileGraph",
    "require",
    "legal_moves_np",
    "shortest_path",
    "shortest_path_np",
    "distances_from",
    "clear_np",
    "clear_many_np",
    "clear_pairs_np",
    "obstacle_adjacent_cells",
    "any_angle_shortest_path",
    "any_angle_shortest_path_np",
    "path_length",
]

SQRT2 = math.sqrt(2.0)

XY = tuple[int, int] | Sequence[int] | np.ndarray


# =============================================================================== result
@dataclasses.dataclass(frozen=True, eq=False)
class ReferencePath:
    """The result of a reference search.

    Attributes:
        found: True when a path from start to goal exists.
        length: its length in cell units (``inf`` when not found).
        path: ``int32[k, 2]`` ``(x, y)`` cells from start to goal; consecutive cells are
            8-adjacent legal moves for :func:`shortest_path` and clear segments for
            :func:`any_angle_shortest_path`. Shape ``(0, 2)`` when not found. For the
            lower bound of :mod:`jaxga.reference.lower_bound`, ``float64[k, 2]`` points.
        reason: ``""`` when found, else why not, e.g. ``"start (0, 0) is blocked"`` or
            ``"goal (9, 9) unreachable from start (0, 0) under corner rule 'strict'"``.
        status: ``"found"``, ``"endpoint_blocked"`` (blocked or off-map start/goal),
            ``"unreachable"`` or ``"budget"`` (the search did not finish within its time
            budget); decides which exception :meth:`raise_if_missing` raises.
        kind: ``"octile"`` (8-connected), ``"any_angle"`` or ``"euclidean_bound"``.
        expanded: number of search nodes expanded (a cost measure for benchmarks).
    """

    found: bool
    length: float
    path: np.ndarray
    reason: str = ""
    status: str = "found"
    kind: str = "octile"
    expanded: int = 0

    def raise_if_missing(self) -> ReferencePath:
        """Return ``self`` if a path was found, else raise the matching jaxga error.

        Raises :class:`~jaxga.core.errors.EndpointError` for a blocked/off-map start or goal,
        :class:`~jaxga.core.errors.NoPathError` for an unreachable goal and
        :class:`~jaxga.core.errors.JaxgaError` for a search cut short by its time budget.
        """
        if self.found:
            return self
        if self.status == "endpoint_blocked":
            raise EndpointError(self.reason)
        if self.status == "budget":
            raise JaxgaError(self.reason)
        raise NoPathError(self.reason)

    @property
    def n_cells(self) -> int:
        """Number of cells (vertices) in :attr:`path`."""
        return int(self.path.shape[0])


def require(result: ReferencePath) -> ReferencePath:
    """Functional form of :meth:`ReferencePath.raise_if_missing` (for the CLI)."""
    return result.raise_if_missing()


def _missing(reason: str, status: str, kind: str, expanded: int = 0) -> ReferencePath:
    return ReferencePath(
        found=False,
        length=math.inf,
        path=np.zeros((0, 2), np.int32),
        reason=reason,
        status=status,
        kind=kind,
        expanded=expanded,
    )


class _OutOfBudget(Exception):
    """Raised inside a search whose time budget is spent; turned into a result."""


class _Deadline:
    """A wall-clock budget: :meth:`check` raises :class:`_OutOfBudget` once ``budget_s``
    seconds have passed since construction (never when ``budget_s`` is None). The long
    loops of the searches call it, so that a budgeted search returns promptly."""

    def __init__(self, budget_s: float | None) -> None:
        self.budget_s = budget_s
        self.end = math.inf if budget_s is None else time.perf_counter() + float(budget_s)

    def check(self) -> None:
        if time.perf_counter() > self.end:
            raise _OutOfBudget


def _budget_message(what: str, budget_s: float | None) -> str:
    return f"{what} optimum not computed (budget {budget_s:g} s)"


def _checked_in_chunks(
    check: Callable[[np.ndarray, np.ndarray], np.ndarray],
    p: np.ndarray,
    q: np.ndarray,
    deadline: _Deadline | None,
    steps: int = 300_000,
) -> np.ndarray:
    """``check(p, q)`` (a vectorised line-of-sight test of the segments ``p[i] -> q[i]``)
    in chunks of about ``steps`` unit steps, with ``deadline`` checked between chunks, so
    that one huge call cannot overrun a time budget. In one call without a budget."""
    p, q = np.broadcast_arrays(np.asarray(p).reshape(-1, 2), np.asarray(q).reshape(-1, 2))
    if deadline is None or deadline.budget_s is None:
        return check(p, q)
    total = np.cumsum(np.max(np.abs(q - p), axis=1) + 1)
    if total.size == 0 or total[-1] <= steps:
        return check(p, q)
    cuts = np.searchsorted(total, np.arange(steps, total[-1], steps)).tolist() + [p.shape[0]]
    parts, lo = [], 0
    for hi in cuts:
        deadline.check()
        parts.append(check(p[lo:hi], q[lo:hi]))
        lo = hi
    return np.concatenate(parts)


def path_length(path: np.ndarray) -> float:
    """Sum of the Euclidean lengths of the segments of an ``int[k, 2]`` path (SPEC 3)."""
    p = np.asarray(path, dtype=np.float64)
    if p.shape[0] < 2:
        return 0.0
    return float(np.sum(np.hypot(*(np.diff(p, axis=0).T))))


# ======================================================================= input checking
def _as_blocked(blocked: np.ndarray) -> np.ndarray:
    b = np.asarray(blocked)
    if b.ndim != 2 or b.size == 0:
        raise JaxgaError(f"blocked must be a non-empty 2-D array, got shape {b.shape}")
    return b.astype(bool, copy=False)


def _check_rule(rule: str) -> str:
    if rule not in CORNER_RULES:
        raise JaxgaError(f"unknown corner rule {rule!r}: expected one of {', '.join(CORNER_RULES)}")
    return rule


def _xy(xy: XY) -> tuple[int, int]:
    x, y = (int(v) for v in np.asarray(xy).reshape(-1)[:2])
    return x, y


def endpoint_problem(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> str:
    """Why ``start`` or ``goal`` cannot be a path's end (off the map, blocked), or ''."""
    h, w = blocked.shape
    for name, (x, y) in (("start", start), ("goal", goal)):
        if not (0 <= x < w and 0 <= y < h):
            return f"{name} cell ({x}, {y}) is off the {w} x {h} map"
        if blocked[y, x]:
            return f"{name} cell ({x}, {y}) is blocked"
    return ""


def unreachable_message(start: tuple[int, int], goal: tuple[int, int], rule: str) -> str:
    """The one-line reason given when no path joins ``start`` and ``goal``."""
    return (
        f"goal cell ({goal[0]}, {goal[1]}) unreachable from start cell ({start[0]}, "
        f"{start[1]}) under corner rule {rule!r}"
    )


# ======================================================================== moves (SPEC 1)
def legal_moves_np(blocked: np.ndarray, corner_rule: str) -> np.ndarray:
    """``bool[8, H, W]``: whether the move from ``(x, y)`` in direction ``d`` is legal.

    Directions are :data:`jaxga.core.grid.DIRECTIONS` (counter-clockwise from east). A move is
    legal (SPEC 1) when both end cells are on the map and free and, for a diagonal move,
    the two orthogonal side cells satisfy ``corner_rule``: ``"free"`` ignores them,
    ``"no_squeeze"`` forbids both blocked, ``"strict"`` forbids either blocked.
    """
    return legal_moves(_as_blocked(blocked), _check_rule(corner_rule))


class OctileGraph:
    """The 8-connected move graph of one map under one corner rule (SPEC 1).

    Built in one vectorised pass as a compressed sparse row adjacency (the neighbours of
    a cell in the order of :data:`~jaxga.core.grid.DIRECTIONS`); :meth:`search` answers
    start/goal queries with A* and the octile heuristic, and :meth:`distances` gives a
    full Dijkstra field (:func:`scipy.sparse.csgraph.dijkstra`). Reuse one graph for many
    queries on the same map (the Moving AI benchmark does).
    """

    def __init__(self, blocked: np.ndarray, corner_rule: str = "strict") -> None:
        self.blocked = _as_blocked(blocked).copy()
        self.corner_rule = _check_rule(corner_rule)
        h, w = self.blocked.shape
        self.shape = (h, w)
        src_a, dst_a, cost_a = move_edges(self.blocked, self.corner_rule)
        order = np.argsort(src_a, kind="stable")  # by cell, then by direction
        n = h * w
        self.indptr = np.searchsorted(src_a[order], np.arange(n + 1)).astype(np.int64)
        self.indices = dst_a[order]
        self.costs = cost_a[order]
        self._xs = np.tile(np.arange(w, dtype=np.float64), h)
        self._ys = np.repeat(np.arange(h, dtype=np.float64), w)

    # ----------------------------------------------------------------------- queries
    def _octile_to(self, goal: int) -> list[float]:
        w = self.shape[1]
        ddx = np.abs(self._xs - goal % w)
        ddy = np.abs(self._ys - goal // w)
        return (np.maximum(ddx, ddy) + (SQRT2 - 1.0) * np.minimum(ddx, ddy)).tolist()

    def search(self, start_xy: XY, goal_xy: XY, budget_s: float | None = None) -> ReferencePath:
        """A* with the (consistent) octile heuristic from ``start_xy`` to ``goal_xy``.

        Returns a :class:`ReferencePath` of kind ``"octile"``; a blocked/off-map
        endpoint or an unreachable goal gives ``found=False`` with a reason, and so does
        a search still running after ``budget_s`` seconds (status ``"budget"``).
        """
        try:
            return self._search(start_xy, goal_xy, _Deadline(budget_s))
        except _OutOfBudget:
            return _missing(_budget_message("8-connected", budget_s), "budget", "octile")

    def _search(self, start_xy: XY, goal_xy: XY, deadline: _Deadline) -> ReferencePath:
        start, goal = _xy(start_xy), _xy(goal_xy)
        problem = endpoint_problem(self.blocked, start, goal)
        if problem:
            return _missing(problem, "endpoint_blocked", "octile")
        w = self.shape[1]
        s = start[1] * w + start[0]
        g = goal[1] * w + goal[0]
        if s == g:
            return ReferencePath(True, 0.0, np.array([start], np.int32), kind="octile")
        hh = self._octile_to(g)
        n = len(hh)
        inf = math.inf
        dist = [inf] * n
        parent = [-1] * n
        closed = bytearray(n)
        ptr, nbr, cost = self.indptr.tolist(), self.indices.tolist(), self.costs.tolist()
        dist[s] = 0.0
        heap: list[tuple[float, int]] = [(hh[s], s)]
        pop, push = heapq.heappop, heapq.heappush
        expanded = 0
        while heap:
            _, u = pop(heap)
            if closed[u]:
                continue
            closed[u] = 1
            expanded += 1
            if u == g:
                break
            if not expanded & 4095:
                deadline.check()
            du = dist[u]
            for j in range(ptr[u], ptr[u + 1]):
                v = nbr[j]
                nd = du + cost[j]
                if nd < dist[v]:
                    dist[v] = nd
                    parent[v] = u
                    push(heap, (nd + hh[v], v))
        if not closed[g]:
            return _missing(unreachable_message(start, goal, self.corner_rule),
                            "unreachable", "octile", expanded)
        cells = [g]
        while cells[-1] != s:
            cells.append(parent[cells[-1]])
        idx = np.array(cells[::-1], dtype=np.int64)
        path = np.stack([idx % w, idx // w], axis=1).astype(np.int32)
        return ReferencePath(True, float(dist[g]), path, kind="octile", expanded=expanded)

    def distances(self, source_xy: XY) -> np.ndarray:
        """``float64[H, W]`` Dijkstra distances from ``source_xy`` (``inf`` where unreachable).

        The move graph is symmetric (a move and its reverse pass the same side cells), so
        this is also the distance *to* ``source_xy``. Raises
        :class:`~jaxga.core.errors.EndpointError` if the source is off the map or blocked.
        """
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra

        src = _xy(source_xy)
        problem = endpoint_problem(self.blocked, src, src)
        if problem:
            raise EndpointError(problem.replace("start", "source", 1))
        h, w = self.shape
        n = h * w
        graph = csr_matrix((self.costs, self.indices, self.indptr), shape=(n, n))
        return dijkstra(graph, indices=src[1] * w + src[0]).reshape(h, w)


def shortest_path_np(
    blocked: np.ndarray, start_xy: XY, goal_xy: XY, corner_rule: str = "strict"
) -> ReferencePath:
    """8-connected optimum on a raw ``bool[H, W]`` array (row 0 = bottom).

    Same as :func:`shortest_path` without building a :class:`~jaxga.core.grid.Grid`.
    """
    b = _as_blocked(blocked)
    problem = endpoint_problem(b, _xy(start_xy), _xy(goal_xy))
    if problem:
        _check_rule(corner_rule)
        return _missing(problem, "endpoint_blocked", "octile")
    return OctileGraph(b, corner_rule).search(start_xy, goal_xy)


def shortest_path(grid: Grid) -> ReferencePath:
    """The 8-connected shortest path of ``grid`` under its corner rule (SPEC 1, 11).

    Straight steps cost 1 and diagonal steps ``sqrt(2)``; a diagonal step is legal when
    its side cells satisfy ``grid.corner_rule``. A* with the octile heuristic (exact:
    the heuristic is consistent). A blocked start or goal or an unreachable goal gives
    ``found=False`` and a ``reason`` instead of an exception; call
    :meth:`ReferencePath.raise_if_missing` to get :class:`~jaxga.core.errors.EndpointError` /
    :class:`~jaxga.core.errors.NoPathError`.
    """
    return shortest_path_np(grid.blocked_np(), grid.start_xy, grid.goal_xy, grid.corner_rule)


def distances_from(grid: Grid, source_xy: XY | None = None) -> np.ndarray:
    """Full 8-connected distance field ``float64[H, W]`` from ``source_xy`` (SPEC 1, 11).

    ``source_xy`` defaults to the grid's start. ``inf`` marks blocked and unreachable
    cells. Because moves are symmetric under every corner rule, ``distances_from(grid,
    grid.goal_xy)`` is the cost-to-go field used for gap reporting. Raises
    :class:`~jaxga.core.errors.EndpointError` for a blocked or off-map source.
    """
    src = grid.start_xy if source_xy is None else source_xy
    return OctileGraph(grid.blocked_np(), grid.corner_rule).distances(src)


# ================================================================ line of sight (SPEC 1)
def _side_ok(s1: bool, s2: bool, rule: str) -> bool:
    if rule == "free":
        return True
    if rule == "no_squeeze":
        return not (s1 and s2)
    return not (s1 or s2)


def clear_np(blocked: np.ndarray, corner_rule: str, a_xy: XY, b_xy: XY) -> bool:
    """Exact line of sight between the centres of cells ``a_xy`` and ``b_xy`` (SPEC 1).

    The segment is *clear* when every cell whose interior it crosses is free (both end
    cells included) and, wherever it passes exactly through a grid vertex, the two cells
    it does not enter there (the *side cells* of the equivalent diagonal move) satisfy
    ``corner_rule``. An 8-adjacent pair is therefore clear exactly when the move is legal.

    Exact integer arithmetic, no floating point: walking from ``a`` with
    ``A = |dx|``, ``B = |dy|``, the ``i``-th vertical grid line (``i = 0..A-1``) is
    crossed at parameter ``(2i+1)/(2A)`` and the ``j``-th horizontal one at
    ``(2j+1)/(2B)``; the walk compares ``(2i+1)*B`` with ``(2j+1)*A`` and, on equality,
    crosses a vertex. Cells off the map count as blocked. Symmetric in ``a``/``b``.
    """
    b = np.asarray(blocked, dtype=bool)
    h, w = b.shape
    x, y = _xy(a_xy)
    x1, y1 = _xy(b_xy)
    if not (0 <= x < w and 0 <= y < h and 0 <= x1 < w and 0 <= y1 < h):
        return False
    if b[y, x]:
        return False
    dx, dy = x1 - x, y1 - y
    sx, sy = (dx > 0) - (dx < 0), (dy > 0) - (dy < 0)
    big_a, big_b = abs(dx), abs(dy)
    i = j = 0
    while i < big_a or j < big_b:
        tx = (2 * i + 1) * big_b if i < big_a else None
        ty = (2 * j + 1) * big_a if j < big_b else None
        if ty is None or (tx is not None and tx < ty):
            x += sx
            i += 1
        elif tx is None or ty < tx:
            y += sy
            j += 1
        else:  # exactly through a grid vertex: a diagonal move
            if not _side_ok(bool(b[y, x + sx]), bool(b[y + sy, x]), corner_rule):
                return False
            x += sx
            y += sy
            i += 1
            j += 1
        if b[y, x]:
            return False
    return True


def _concat_ranges(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row ids and within-row offsets ``0..counts[r]-1`` for every row, flattened."""
    counts = np.asarray(counts, dtype=np.int64)
    total = int(counts.sum())
    rows = np.repeat(np.arange(counts.size), counts)
    starts = np.cumsum(counts) - counts
    offs = np.arange(total, dtype=np.int64) - np.repeat(starts, counts)
    return rows, offs


def clear_pairs_np(
    blocked: np.ndarray, corner_rule: str, a_xy: np.ndarray, b_xy: np.ndarray
) -> np.ndarray:
    """Vectorised :func:`clear_np` over pairs of cells: ``bool[n]`` for ``int[n, 2]`` ends.

    Same definition as :func:`clear_np` (SPEC 1) but a different, closed-form computation
    (so that the two check each other in the tests): call the axis of larger extent the
    major one (extents ``A >= B``, offsets ``i`` along it and ``j`` across it, from
    ``a``). The segment meets the grid line between major columns ``i`` and ``i + 1``
    (``i = 0..A-1``) at minor offset ``q = B(2i+1)/(2A)``. With
    ``r, m = divmod(B(2i+1) + A, 2A)``, the crossing is a grid vertex exactly when
    ``m == 0``; the cell just before the line is ``(i, r - [m == 0])`` and the one just
    after it is ``(i + 1, r)``; at a vertex the side cells are ``(i + 1, r - 1)`` and
    ``(i, r)``. As the slope is at most 1, these before/after cells are *all* the cells
    the segment crosses. One flat, integer-only NumPy pass over ``sum(A)`` elements
    decides every pair. A pair with an end off the map or blocked gives False.
    """
    bl = np.asarray(blocked, dtype=bool)
    h, w = bl.shape
    _check_rule(corner_rule)
    a = np.asarray(a_xy, dtype=np.int64).reshape(-1, 2)
    t = np.asarray(b_xy, dtype=np.int64).reshape(-1, 2)
    a, t = np.broadcast_arrays(a, t)
    n = t.shape[0]
    out = np.zeros(n, bool)
    if n == 0:
        return out
    on_map = (a[:, 0] >= 0) & (a[:, 0] < w) & (a[:, 1] >= 0) & (a[:, 1] < h)
    on_map &= (t[:, 0] >= 0) & (t[:, 0] < w) & (t[:, 1] >= 0) & (t[:, 1] < h)
    sel = np.flatnonzero(on_map)
    if sel.size == 0:
        return out
    flat = bl.reshape(-1)
    x0, y0 = a[sel, 0], a[sel, 1]
    tx, ty = t[sel, 0], t[sel, 1]
    dx, dy = tx - x0, ty - y0
    adx, ady = np.abs(dx), np.abs(dy)
    xmajor = adx >= ady
    big_a = np.where(xmajor, adx, ady)
    big_b = np.where(xmajor, ady, adx)
    # flat-index strides of one step along the major / minor axis
    st_maj = np.where(xmajor, np.sign(dx), np.sign(dy) * w)
    st_min = np.where(xmajor, np.sign(dy) * w, np.sign(dx))
    base = y0 * w + x0
    n_bad = (flat[base] | flat[ty * w + tx]).astype(np.int64)  # the two end cells

    rows, i = _concat_ranges(big_a)
    if rows.size:
        aa, bb = big_a[rows], big_b[rows]
        r, m = np.divmod(bb * (2 * i + 1) + aa, 2 * aa)
        vert = m == 0
        sm, sn = st_maj[rows], st_min[rows]
        after = base[rows] + (i + 1) * sm + r * sn
        before = after - sm - vert * sn
        bad = flat[before] | flat[after]
        if corner_rule != "free" and vert.any():
            vi = np.flatnonzero(vert)
            s1 = flat[after[vi] - sn[vi]]  # (i + 1, r - 1)
            s2 = flat[after[vi] - sm[vi]]  # (i, r)
            bad[vi] |= (s1 & s2) if corner_rule == "no_squeeze" else (s1 | s2)
        n_bad += np.bincount(rows, weights=bad, minlength=sel.size).astype(np.int64)
    out[sel] = n_bad == 0
    return out


def clear_many_np(
    blocked: np.ndarray, corner_rule: str, a_xy: XY, targets_xy: np.ndarray
) -> np.ndarray:
    """Vectorised :func:`clear_np` from one source to many targets: ``bool[n]``.

    ``targets_xy`` is ``int[n, 2]``; see :func:`clear_pairs_np` for the method (SPEC 1).
    """
    t = np.asarray(targets_xy, dtype=np.int64).reshape(-1, 2)
    a = np.broadcast_to(np.asarray(_xy(a_xy), dtype=np.int64), t.shape)
    return clear_pairs_np(blocked, corner_rule, a, t)


def _segment_pattern(
    dx: int, dy: int
) -> tuple[list[tuple[int, int]], list[tuple[tuple[int, int], ...]]]:
    """Cells crossed by the segment ``(0, 0) -> (dx, dy)`` (source excluded) and the side
    cell pairs of the grid vertices it passes, as relative ``(x, y)`` offsets."""
    xmajor = abs(dx) >= abs(dy)
    a, bb = (abs(dx), abs(dy)) if xmajor else (abs(dy), abs(dx))
    smaj = (dx > 0) - (dx < 0) if xmajor else (dy > 0) - (dy < 0)
    smin = (dy > 0) - (dy < 0) if xmajor else (dx > 0) - (dx < 0)

    def rel(i: int, j: int) -> tuple[int, int]:
        return (smaj * i, smin * j) if xmajor else (smin * j, smaj * i)

    cells: set[tuple[int, int]] = set()
    sides: list[tuple[tuple[int, int], ...]] = []
    for i in range(a):
        r, m = divmod(bb * (2 * i + 1) + a, 2 * a)
        cells.add(rel(i, r - (m == 0)))
        cells.add(rel(i + 1, r))
        if m == 0:
            sides.append((rel(i + 1, r - 1), rel(i, r)))
    cells.discard((0, 0))
    return sorted(cells), sides


# ============================================================================ any angle
C_OCTILE = math.sqrt(4.0 - 2.0 * SQRT2)
"""Largest octile / Euclidean length ratio, reached at 22.5 degrees: sqrt(4 - 2 sqrt 2)."""


def _offsets(radius: int) -> list[tuple[int, int]]:
    return [
        (dx, dy)
        for dx in range(-radius, radius + 1)
        for dy in range(-radius, radius + 1)
        if (dx or dy) and math.gcd(dx, dy) == 1
    ]


def _move_masks(b: np.ndarray, rule: str, offsets: list[tuple[int, int]]) -> list[np.ndarray]:
    """For every offset ``d``: ``bool[H, W]``, whether the segment ``p -> p + d`` is clear."""
    h, w = b.shape
    r = max(max(abs(dx), abs(dy)) for dx, dy in offsets)
    pad = np.ones((h + 2 * r, w + 2 * r), bool)
    pad[r:-r, r:-r] = b

    def at(ox: int, oy: int) -> np.ndarray:
        return pad[r + oy : r + oy + h, r + ox : r + ox + w]

    masks = []
    for dx, dy in offsets:
        cells, sides = _segment_pattern(dx, dy)
        ok = ~b.copy()
        for cx, cy in cells:
            ok &= ~at(cx, cy)
        if rule != "free":
            for (ax, ay), (bx, by) in sides:
                s1, s2 = at(ax, ay), at(bx, by)
                ok &= ~(s1 & s2) if rule == "no_squeeze" else ~(s1 | s2)
        masks.append(ok)
    return masks


def _radius_graph_distances(
    b: np.ndarray, rule: str, source: tuple[int, int], radius: int, deadline: _Deadline
) -> tuple[np.ndarray, np.ndarray]:
    """Distances (upper bounds of the any-angle ones) and parents from ``source`` in the
    graph whose edges are the clear segments of Chebyshev length <= ``radius``.

    Dijkstra (:func:`scipy.sparse.csgraph.dijkstra`) on the edges of
    :func:`_move_masks`. Returns flat ``float64[H*W]`` distances and ``int64[H*W]``
    parent cell indices (-1 at the source and unreached cells).
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    h, w = b.shape
    offsets = _offsets(radius)
    src, dst, cost = [], [], []
    for (dx, dy), mask in zip(offsets, _move_masks(b, rule, offsets), strict=True):
        deadline.check()
        p = np.flatnonzero(mask)  # a clear move ends on the map
        src.append(p)
        dst.append(p + (dy * w + dx))
        cost.append(np.full(p.size, math.hypot(dx, dy)))
    n = h * w
    graph = csr_matrix((np.concatenate(cost), (np.concatenate(src), np.concatenate(dst))),
                       shape=(n, n))
    deadline.check()
    d, par = dijkstra(graph, indices=source[1] * w + source[0], return_predecessors=True)
    return d, np.where(par < 0, -1, par).astype(np.int64)


def _chain(par: np.ndarray, s: int, g: int, w: int) -> np.ndarray:
    cells = [g]
    while cells[-1] != s:
        cells.append(int(par[cells[-1]]))
    idx = np.array(cells[::-1], dtype=np.int64)
    return np.stack([idx % w, idx // w], axis=1)


def _string_pull(
    b: np.ndarray, rule: str, path: np.ndarray, deadline: _Deadline | None = None
) -> np.ndarray:
    """Greedy shortcutting of a clear polyline: from each kept vertex jump to the last
    later vertex it sees (SPEC 9 ``shortcut_greedy``). The result is clear and no longer."""
    out = [0]
    k = path.shape[0]
    while out[-1] != k - 1:
        i = out[-1]
        vis = _checked_in_chunks(functools.partial(clear_pairs_np, b, rule), path[i],
                                 path[i + 1 :], deadline)
        out.append(i + 1 + int(np.flatnonzero(vis)[-1]))  # i + 1 is always visible
    return path[out]


def _exact_astar(
    b: np.ndarray,
    rule: str,
    start: tuple[int, int],
    goal: tuple[int, int],
    ub: float,
    keep: np.ndarray,
    heuristic: np.ndarray,
    seeds: tuple[np.ndarray, np.ndarray] | None,
    deadline: _Deadline,
    lipschitz: Sequence[np.ndarray] = (),
) -> tuple[np.ndarray | None, int]:
    """A* on the visibility graph of the cells in ``keep`` (flat ``bool[H*W]``) and the ends.

    ``heuristic``: a consistent lower bound of every kept cell's distance to the goal
    (flat ``float64[H*W]``); ``ub``: the length of a known path (no path longer is
    followed). ``seeds = (g0, p0)``: upper bounds of the distances from the start,
    realised by actual clear paths through the parents ``p0``. They seed the search:
    every vertex starts in the open list with ``g0`` (only strict improvements are line
    of sight checked, which is what makes the search affordable). ``lipschitz``: fields
    ``F`` (flat ``float64[H*W]``) with ``|F(u) - F(v)| <= |u v|`` for every clear segment
    between vertices of an optimal path (distances in a metric no longer than the
    Euclidean along clear segments); pairs violating it are not line-of-sight checked.
    Returns the path (None if the goal was not reached) and the number of expansions.
    """
    h, w = b.shape
    s = start[1] * w + start[0]
    gl = goal[1] * w + goal[0]
    keep = keep.copy()
    keep[s] = keep[gl] = True
    zf = np.flatnonzero(keep)  # flat indices of the vertices
    zx, zy = (zf % w).astype(np.float64), (zf // w).astype(np.float64)
    zxy = np.stack([zf % w, zf // w], axis=1)
    hz = heuristic[zf]
    lz = np.stack([f[zf] for f in lipschitz]) if lipschitz else None
    slack = ub + 1e-9 - hz
    if seeds is None:
        g, par = np.full(h * w, math.inf), np.full(h * w, -1, np.int64)
    else:
        g, par = seeds[0].copy(), seeds[1].copy()
    g[s] = 0.0
    gz = g[zf]
    is_open = np.ones(zf.size, bool)
    opened = np.flatnonzero(np.isfinite(gz))
    heap = [(float(f), int(k)) for k, f in zip(opened, (gz + hz)[opened], strict=True)]
    heapq.heapify(heap)
    zgoal = int(np.searchsorted(zf, gl))
    expanded = 0
    while heap:
        f, k = heapq.heappop(heap)
        if not is_open[k] or f > gz[k] + hz[k] + 1e-9:
            continue
        is_open[k] = False
        expanded += 1
        if k == zgoal:
            break
        deadline.check()
        tent = gz[k] + np.hypot(zx - zx[k], zy - zy[k])
        cand = np.flatnonzero(is_open & (tent < gz - 1e-12) & (tent <= slack))
        if lz is not None and cand.size:
            gap = np.max(np.abs(lz[:, cand] - lz[:, k : k + 1]), axis=0)
            cand = cand[gap <= tent[cand] - gz[k] + 1e-9]
        if cand.size == 0:
            continue
        vis = cand[_checked_in_chunks(functools.partial(clear_pairs_np, b, rule), zxy[k],
                                      zxy[cand], deadline)]
        if vis.size == 0:
            continue
        gz[vis] = tent[vis]
        par[zf[vis]] = zf[k]
        for v, fv in zip(vis.tolist(), (tent[vis] + hz[vis]).tolist(), strict=True):
            heapq.heappush(heap, (fv, v))
    if is_open[zgoal]:
        return None, expanded
    return _chain(par, s, gl, w), expanded


def _path_near(
    b: np.ndarray,
    rule: str,
    start: tuple[int, int],
    goal: tuple[int, int],
    points: np.ndarray,
    deadline: _Deadline,
    radius: int = 3,
    skip: int = 2,
) -> np.ndarray | None:
    """A clear polyline through cell centres that bends near ``points`` (e.g. the bends of
    the taut string), or None: an upper bound of the any-angle optimum, usually equal to
    it or very close when the points are the taut string's bends.

    Dynamic programming over the layered graph whose layers are the start, the free
    cells within Chebyshev distance ``radius`` of each point in turn, and the goal; an
    edge joins a cell to every cell of the next ``skip`` layers when the segment is clear
    (:func:`clear_pairs_np`).
    """
    h, w = b.shape
    layers = [np.array([start], np.int64)]
    for x, y in np.asarray(points, np.float64).reshape(-1, 2).tolist():
        xs = np.arange(max(math.ceil(x - radius), 0), min(math.floor(x + radius), w - 1) + 1)
        ys = np.arange(max(math.ceil(y - radius), 0), min(math.floor(y + radius), h - 1) + 1)
        cells = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        layers.append(cells[~b[cells[:, 1], cells[:, 0]]])
    layers.append(np.array([goal], np.int64))
    dist = [np.zeros(1)] + [np.full(len(lay), math.inf) for lay in layers[1:]]
    par = [np.zeros((1, 2), np.int64)] + [np.full((len(lay), 2), -1) for lay in layers[1:]]
    for j in range(1, len(layers)):
        deadline.check()
        for i in range(max(0, j - skip), j):
            a = np.flatnonzero(np.isfinite(dist[i]))
            ai = np.repeat(a, len(layers[j]))
            cj = np.tile(np.arange(len(layers[j])), a.size)
            tent = dist[i][ai] + np.hypot(*(layers[i][ai] - layers[j][cj]).T)
            better = tent < dist[j][cj]
            ai, cj, tent = ai[better], cj[better], tent[better]
            ok = _checked_in_chunks(functools.partial(clear_pairs_np, b, rule),
                                    layers[i][ai], layers[j][cj], deadline)
            ai, cj, tent = ai[ok], cj[ok], tent[ok]
            order = np.lexsort((tent, cj))
            first = order[np.unique(cj[order], return_index=True)[1]]
            dist[j][cj[first]] = tent[first]
            par[j][cj[first]] = np.stack([np.full(first.size, i), ai[first]], axis=1)
    if not math.isfinite(dist[-1][0]):
        return None
    out = [(len(layers) - 1, 0)]
    while out[-1][0] != 0:
        j, k = out[-1]
        out.append((int(par[j][k, 0]), int(par[j][k, 1])))
    return np.array([layers[j][k] for j, k in out[::-1]], np.int64)


def _crop_box(
    b: np.ndarray, start: tuple[int, int], goal: tuple[int, int], ub: float
) -> tuple[int, int, int, int]:
    """Bounding box ``(x0, x1, y0, y1)`` (inclusive) of the ellipse ``|sv| + |vg| <= ub``:
    every vertex, hence every cell crossed, of a path of length ``<= ub`` lies in it."""
    h, w = b.shape
    ys, xs = np.mgrid[0:h, 0:w]
    inside = np.hypot(xs - start[0], ys - start[1]) + np.hypot(xs - goal[0], ys - goal[1])
    inside = inside <= ub + 1e-9
    yy, xx = np.nonzero(inside)
    return int(xx.min()), int(xx.max()), int(yy.min()), int(yy.max())


def any_angle_shortest_path_np(
    blocked: np.ndarray,
    start_xy: XY,
    goal_xy: XY,
    corner_rule: str = "strict",
    *,
    exact: bool = True,
    vertices: np.ndarray | None = None,
    radius: int = 2,
    budget_s: float | None = None,
    known_path: np.ndarray | None = None,
) -> ReferencePath:
    """Any-angle optimum on a raw ``bool[H, W]`` array; see :func:`any_angle_shortest_path`.

    Args:
        blocked: ``bool[H, W]``, row 0 at the bottom (SPEC 1).
        start_xy, goal_xy: ``(x, y)`` cells.
        corner_rule: ``"free"``, ``"no_squeeze"`` or ``"strict"``.
        exact: False skips the exact search and returns the clear, usually near-optimal
            upper-bound path (string-pulled shortest path of the radius graph).
        vertices: optional ``bool[H, W]``: restrict the interior vertices to these cells
            (experiments such as :func:`obstacle_adjacent_cells`; the result is then the
            optimum over that vertex set, an upper bound of the true optimum, and may be
            ``found=False`` when no path uses only those vertices).
        radius: Chebyshev length of the moves of the seeding graph; a speed knob only,
            it never changes the exact result.
        budget_s: wall-clock seconds the search may take; past them it stops and returns
            ``found=False`` with status ``"budget"`` (and the reason "any-angle optimum
            not computed (budget N s)"). None: no limit.
        known_path: optional ``int[k, 2]`` clear path from start to goal (e.g. a GA
            result after post-optimisation): its length tightens the pruning, and it is
            returned when nothing shorter exists. Checked (every segment clear, the ends
            right); a path that fails raises :class:`~jaxga.core.errors.JaxgaError`.
    """
    b = _as_blocked(blocked)
    _check_rule(corner_rule)
    start, goal = _xy(start_xy), _xy(goal_xy)
    problem = endpoint_problem(b, start, goal)
    if problem:
        return _missing(problem, "endpoint_blocked", "any_angle")
    if start == goal:
        return ReferencePath(True, 0.0, np.array([start], np.int32), kind="any_angle")
    known = None if known_path is None else _checked_path(b, corner_rule, start, goal, known_path)
    try:
        return _any_angle(b, corner_rule, start, goal, exact, vertices, max(1, int(radius)),
                          known, _Deadline(budget_s))
    except _OutOfBudget:
        return _missing(_budget_message("any-angle", budget_s), "budget", "any_angle")


def _checked_path(
    b: np.ndarray, rule: str, start: tuple[int, int], goal: tuple[int, int], path: np.ndarray
) -> np.ndarray:
    """``path`` as ``int64[k, 2]`` if it is a clear polyline from ``start`` to ``goal``."""
    p = np.asarray(path).reshape(-1, 2)
    if (p.shape[0] < 2 or not np.array_equal(p, np.round(p)) or tuple(p[0]) != start
            or tuple(p[-1]) != goal):
        raise JaxgaError(f"known_path must run from {start} to {goal} through cells")
    p = p.astype(np.int64)
    if not clear_pairs_np(b, rule, p[:-1], p[1:]).all():
        raise JaxgaError(f"known_path is not clear under corner rule {rule!r}")
    return p


def _any_angle(
    b: np.ndarray,
    rule: str,
    start: tuple[int, int],
    goal: tuple[int, int],
    exact: bool,
    vertices: np.ndarray | None,
    radius: int,
    known: np.ndarray | None,
    deadline: _Deadline,
) -> ReferencePath:
    """The search of :func:`any_angle_shortest_path_np` (see its steps in
    :func:`any_angle_shortest_path`); raises :class:`_OutOfBudget` past the deadline."""
    from jaxga.reference.lower_bound import GeodesicBounds

    octile = OctileGraph(b, rule)._search(start, goal, deadline)
    if not octile.found:
        return dataclasses.replace(octile, kind="any_angle")
    ub = octile.length
    if known is not None and path_length(known) >= ub:
        known = None
    if known is not None:
        ub = path_length(known)
    if vertices is None:
        # no path shorter than the 8-connected one leaves the ellipse's bounding box
        x0, x1, y0, y1 = _crop_box(b, start, goal, ub)
    else:
        x0, x1, y0, y1 = 0, b.shape[1] - 1, 0, b.shape[0] - 1
    cb = np.ascontiguousarray(b[y0 : y1 + 1, x0 : x1 + 1])
    cs, cg = (start[0] - x0, start[1] - y0), (goal[0] - x0, goal[1] - y0)
    ch, cw = cb.shape
    g0, p0 = _radius_graph_distances(cb, rule, cs, radius, deadline)
    best = _string_pull(cb, rule, _chain(p0, cs[1] * cw + cs[0], cg[1] * cw + cg[0], cw),
                        deadline)
    if known is not None and path_length(known) < path_length(best):
        best = known - np.array([x0, y0])
    expanded = 0
    if vertices is not None:
        vm = np.asarray(vertices, bool)
        if vm.shape != b.shape:
            raise JaxgaError(f"vertices must have the map's shape {b.shape}, got {vm.shape}")
        ys, xs = np.divmod(np.arange(ch * cw), cw)
        to_goal = np.hypot(xs - cg[0], ys - cg[1])
        keep = vm.reshape(-1) & ~cb.reshape(-1)
        # seeds must be realised by paths through the vertex set: none
        path, expanded = _exact_astar(cb, rule, cs, cg, math.inf, keep, to_goal, None, deadline)
        if path is None:
            return _missing(
                f"goal {goal} unreachable from start {start} through the given vertices",
                "unreachable",
                "any_angle",
                expanded,
            )
        best = path
    elif exact:
        geo = GeodesicBounds(cb, rule, cs, cg, path_length(best), deadline)
        near = _path_near(cb, rule, cs, cg, geo.bends, deadline)
        if near is not None and path_length(near) < path_length(best):
            best = near
        ub = path_length(best)
        if geo.bound < ub - 1e-9:  # else the upper-bound path is optimal already
            to_start, to_goal = geo.cells(ub, start_upper=g0)
            keep = to_start + to_goal <= ub + 1e-9
            path, expanded = _exact_astar(cb, rule, cs, cg, ub, keep, to_goal, (g0, p0),
                                          deadline, (to_start, to_goal))
            if path is not None and path_length(path) < path_length(best):  # always reached
                best = _string_pull(cb, rule, path, deadline)
    best = (best + np.array([x0, y0])).astype(np.int32)
    return ReferencePath(True, path_length(best), best, kind="any_angle", expanded=expanded)


def obstacle_adjacent_cells(blocked: np.ndarray) -> np.ndarray:
    """``bool[H, W]``: free cells with a blocked 8-neighbour (cells off the map do not count).

    The natural guess for the vertex set of an any-angle optimum, and NOT sufficient on a
    lattice of cell centres: see :func:`any_angle_shortest_path`. Kept for experiments
    (``any_angle_shortest_path_np(..., vertices=obstacle_adjacent_cells(b))``).
    """
    b = _as_blocked(blocked)
    h, w = b.shape
    pad = np.zeros((h + 2, w + 2), bool)
    pad[1:-1, 1:-1] = b
    near = np.zeros_like(b)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dx or dy:
                near |= pad[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]
    return near & ~b


def any_angle_shortest_path(
    grid: Grid, *, exact: bool = True, budget_s: float | None = None
) -> ReferencePath:
    """The any-angle optimum of ``grid``: the shortest clear polyline through cell centres.

    Vertices are cell centres and every segment must be clear under ``grid.corner_rule``
    (SPEC 1, :func:`clear_np`). This is the lower bound for GA paths after
    post-optimisation (SPEC 9, 11). It is at most the 8-connected optimum (a legal move
    is a clear segment), at least the straight-line distance, and it exists exactly when
    the 8-connected path does (the cells crossed by a clear segment, in order, form a
    legal 8-connected path: orthogonal steps between free cells, and diagonal steps only
    at vertex crossings, which obey the corner rule). A blocked start/goal or an
    unreachable goal gives ``found=False`` with a reason, as for :func:`shortest_path`.

    **Which cells can be vertices.** The tempting vertex set "start, goal and the free
    cells touching an obstacle" (:func:`obstacle_adjacent_cells`; the visibility graph
    over obstacle corners of SPEC 11) is exact for paths that may bend anywhere, because
    a taut string bends only at obstacle corners. It is *not* exact when the bends must
    be cell centres: obstacle corners are grid vertices, never centres, and the best
    lattice bend can be far from any obstacle. Example (tested): a 22 x 4 map with the
    single blocked cell (16, 1), start (0, 0), goal (21, 2). The optimum is
    (0, 0) -> (10, 1) -> (21, 2) = 21.09524 under "free"/"no_squeeze" (the second segment
    passes exactly through the corner (15.5, 1.5) of the obstacle) and
    (0, 0) -> (9, 1) -> (21, 2) = 21.09698 under "strict"; the bend is 6-7 cells from the
    obstacle, and the best path bending only at obstacle-adjacent cells is 21.11724.
    Scaling the example (the triangle start-bend-goal has area 1/2, so it holds no other
    lattice point) moves the bend arbitrarily far away, so *no* candidate set defined by
    a bounded neighbourhood of the obstacles is exact. On the classic 20 x 20 maps the
    obstacle-adjacent set misses the optimum in 5 of 18 map/rule cases (by up to 0.28);
    on random grids in about 0.5 % of the cases up to 10 x 10, 4 % at 8-16 cells a side
    and 8 % at 17-32.

    **So every free cell is a vertex**, and the search is made affordable by pruning that
    provably keeps every vertex and edge of an optimal path (``s``, ``g``: start and goal;
    ``geo_s(v)``, ``geo_g(v)``: the Euclidean shortest distances in the plane around the
    blocked cells, :mod:`jaxga.reference.lower_bound`, which no clear polyline beats):

    1. The 8-connected optimum ``U8`` is computed first (reachability, upper bound). No
       path of length ``<= U8`` leaves the bounding box of the ellipse
       ``|s v| + |v g| <= U8`` (a segment's crossed cells lie in the bounding box of its
       ends), so the map is cropped to that box.
    2. Upper bounds: Dijkstra distances ``g0`` of the graph whose edges are the clear
       segments of Chebyshev length ``<= radius``; its shortest path, greedily
       string-pulled, has length ``U >= optimum``. ``exact=False`` returns this path.
       Then the taut string (the Euclidean shortest path around the obstacles, bending
       at their convex corners) is computed, and the best clear polyline through cells
       within 3 of its bends (:func:`_path_near`) lowers ``U``, often to the optimum.
       If the taut string's length equals ``U``, ``U`` is optimal.
    3. Lower bounds: the taut-string distances ``geo_s(v)``, ``geo_g(v)`` of every cell
       that a path of length ``<= U`` can visit
       (:class:`~jaxga.reference.lower_bound.GeodesicBounds`, a shortest path map
       restricted to a geodesic ellipse). ``geo_g`` is a metric distance, so a consistent
       A* heuristic, and a lower bound of the any-angle distance (every clear polyline
       is a path of the plane); cells with ``geo_s(v) + geo_g(v) > U`` cannot be on an
       optimal path and are dropped.
    4. A* over the remaining cells, seeded with every ``g0`` (all seeds open; a standard
       exchange argument shows every vertex of an optimal path is closed with its exact
       distance). Expanding ``u`` line-of-sight checks only vertices ``v`` that it would
       strictly improve and that can still finish within ``U``; this also skips every
       ``v`` already seen from an ancestor of ``u`` (an ancestor relaxed it at least as
       well). Before the exact check, pairs with ``|geo_t(u) - geo_t(v)| > |u v|`` for
       ``t`` = start or goal are discarded (a clear segment is a geodesic).

    The tests check the result against a brute-force Dijkstra over the complete
    visibility graph of all free cells on a few hundred small random grids (random cells
    and random rectangles, all three rules) and on the classic 20 x 20 maps.

    ``budget_s`` (:func:`any_angle_shortest_path_np`) bounds the wall-clock time: every
    long loop of the search checks the clock, so a search past its budget returns
    ``found=False`` (status ``"budget"``) promptly.
    """
    return any_angle_shortest_path_np(grid.blocked_np(), grid.start_xy, grid.goal_xy,
                                      grid.corner_rule, exact=exact, budget_s=budget_s)
