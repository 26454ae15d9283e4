"""Exact reference optima: the 8-connected shortest path, exact line of sight, search budgets.

Every GA result is reported as a gap to an exact optimum (decisions 015, 031). This module
computes those optima on the host with NumPy and :mod:`heapq`; it is not the hot path
and imports nothing from the JAX side of jaxga except the :class:`~jaxga.core.grid.Grid`
container, so it is an *independent* reference for the JAX code to be tested against
(in particular :func:`clear_np` is written from its own definition, not from
``jaxga.core.geometry``).

Contents:

* :func:`shortest_path` - the 8-connected optimum: straight step cost 1, diagonal step
  cost ``sqrt(2)``, diagonal moves restricted by the grid's ``corner_rule`` (decision 027).
  A* with the octile heuristic over a precomputed sparse adjacency (:class:`OctileGraph`);
  :func:`distances_from` gives the whole Dijkstra distance field.
* the any-angle optimum is in :mod:`jaxga.reference.any_angle` (it uses the taut string's
  bounds of :mod:`jaxga.reference.lower_bound`, which in turn uses this module); the
  search budget both share is here (:class:`Deadline`, status ``"budget"``).
* :func:`clear_np` / :func:`clear_many_np` / :func:`clear_pairs_np` - exact,
  integer-only line of sight between cell centres.

Coordinates are ``(x, y)`` with ``y = 0`` the bottom row (docs/maps.md); arrays are indexed
``blocked[y, x]``. Paths are ``int32[k, 2]`` arrays of ``(x, y)`` cells from start to goal.

A blocked or off-map endpoint and an unreachable goal are *results* here
(``found=False`` with a human-readable ``reason``), not exceptions, so that a benchmark
can tabulate them; :meth:`ReferencePath.raise_if_missing` (or :func:`require`) turns
them into :class:`~jaxga.core.errors.EndpointError` / :class:`~jaxga.core.errors.NoPathError` for
the command line.
"""

from __future__ import annotations

import dataclasses
import heapq
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from collections.abc import Set as AbstractSet

import numpy as np

from jaxga.core.errors import EndpointError, JaxgaError, NoPathError
from jaxga.core.fields import shown_value
from jaxga.core.grid import CORNER_RULES, Grid, as_integer
from jaxga.maps.preprocess import legal_moves, move_edges, region_labels

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
    "octile_length",
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


def missing_path(reason: str, status: str, kind: str, expanded: int = 0) -> ReferencePath:
    return ReferencePath(
        found=False,
        length=math.inf,
        path=np.zeros((0, 2), np.int32),
        reason=reason,
        status=status,
        kind=kind,
        expanded=expanded,
    )


class OutOfBudget(Exception):
    """Raised inside a search whose time budget is spent; turned into a result."""


class Deadline:
    """A wall-clock budget: :meth:`check` raises :class:`OutOfBudget` once ``budget_s``
    seconds have passed since construction (never when ``budget_s`` is None). The long
    loops of the searches call it, so that a budgeted search returns promptly."""

    def __init__(self, budget_s: float | None) -> None:
        self.budget_s = budget_s
        self.end = math.inf if budget_s is None else time.perf_counter() + float(budget_s)

    def check(self) -> None:
        if time.perf_counter() > self.end:
            raise OutOfBudget


def budget_message(what: str, budget_s: float | None) -> str:
    return f"{what} optimum not computed (budget {budget_s:g} s)"


def checked_in_chunks(
    check: Callable[[np.ndarray, np.ndarray], np.ndarray],
    p: np.ndarray,
    q: np.ndarray,
    deadline: Deadline | None,
    steps: int = 300_000,
) -> np.ndarray:
    """``check(p, q)`` (a vectorised line-of-sight test of the segments ``p[i] -> q[i]``)
    in chunks of about ``steps`` unit steps, with ``deadline`` checked between chunks, so
    that one huge call cannot overrun a time budget. In one call without a budget."""
    p, q = np.broadcast_arrays(np.asarray(p).reshape(-1, 2), np.asarray(q).reshape(-1, 2))
    if deadline is None or deadline.budget_s is None:
        return check(p, q)  # the checks bound their own memory (span_chunks)
    chunks = span_chunks(np.max(np.abs(q - p), axis=1) + 1, steps)
    if len(chunks) <= 1:
        return check(p, q)
    parts = []
    for c in chunks:
        deadline.check()
        parts.append(check(p[c], q[c]))
    return np.concatenate(parts)


def octile_length(path: np.ndarray) -> float:
    """The length of an 8-connected path of ``int[k, 2]`` cells, ``a + b sqrt(2)`` for its
    ``a`` straight and ``b`` diagonal steps: one value for every path with the same step
    counts, whichever order its steps come in (so two exact searches that return
    different optimal paths report the same optimum, bit for bit)."""
    p = np.asarray(path, dtype=np.int64)
    if p.shape[0] < 2:
        return 0.0
    step = np.abs(np.diff(p, axis=0))
    diagonal = int(np.count_nonzero((step[:, 0] != 0) & (step[:, 1] != 0)))
    return float(p.shape[0] - 1 - diagonal) + diagonal * SQRT2


def path_length(path: np.ndarray) -> float:
    """Sum of the Euclidean lengths of the segments of an ``int[k, 2]`` path."""
    p = np.asarray(path, dtype=np.float64)
    if p.shape[0] < 2:
        return 0.0
    return float(np.sum(np.hypot(*(np.diff(p, axis=0).T))))


# ======================================================================= input checking
def as_blocked(blocked: np.ndarray) -> np.ndarray:
    b = np.asarray(blocked)
    if b.ndim != 2 or b.size == 0:
        raise JaxgaError(f"blocked must be a non-empty 2-D array, got shape {b.shape}")
    return b.astype(bool, copy=False)


def check_rule(rule: str) -> str:
    if rule not in CORNER_RULES:
        raise JaxgaError(f"unknown corner rule {rule!r}: expected one of {', '.join(CORNER_RULES)}")
    return rule


def as_xy(xy: XY) -> tuple[int, int]:
    """``xy`` as a pair of Python integers ``(x, y)``, or one
    :class:`~jaxga.core.errors.EndpointError` line: as :meth:`Grid.create`, ``1.5`` or a
    triple is refused, not truncated."""
    if type(xy) is tuple and len(xy) == 2 and all(
            isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in xy):
        return int(xy[0]), int(xy[1])  # the common case, in the searches' inner loops
    try:
        if isinstance(xy, (str, bytes, AbstractSet, Mapping)):  # {3, 1}: which is x?
            raise TypeError
        arr = np.asarray(xy)
        if arr.shape != (2,) or arr.dtype == bool or (isinstance(xy, (tuple, list)) and any(
                isinstance(v, (bool, np.bool_)) for v in xy)):
            raise TypeError
        x, y = (as_integer(v) for v in arr.tolist())
    except (TypeError, ValueError):
        raise EndpointError(f"a cell must be a pair of integers (x, y), got "
                            f"{shown_value(xy)}") from None
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


# =============================================================================== moves
def legal_moves_np(blocked: np.ndarray, corner_rule: str) -> np.ndarray:
    """``bool[8, H, W]``: whether the move from ``(x, y)`` in direction ``d`` is legal.

    Directions are :data:`jaxga.core.grid.DIRECTIONS` (counter-clockwise from east). A move is
    legal when both end cells are on the map and free and, for a diagonal move,
    the two orthogonal side cells satisfy ``corner_rule``: ``"free"`` ignores them,
    ``"no_squeeze"`` forbids both blocked, ``"strict"`` forbids either blocked.
    """
    return legal_moves(as_blocked(blocked), check_rule(corner_rule))


class OctileGraph:
    """The 8-connected move graph of one map under one corner rule.

    Built in one vectorised pass as a compressed sparse row adjacency (the neighbours of
    a cell in the order of :data:`~jaxga.core.grid.DIRECTIONS`); :meth:`search` answers
    start/goal queries with A* and the octile heuristic, and :meth:`distances` gives a
    full Dijkstra field (:func:`scipy.sparse.csgraph.dijkstra`). Reuse one graph for many
    queries on the same map (the Moving AI benchmark does).
    """

    def __init__(self, blocked: np.ndarray, corner_rule: str = "strict") -> None:
        self.blocked = as_blocked(blocked).copy()
        self.corner_rule = check_rule(corner_rule)
        h, w = self.blocked.shape
        self.shape = (h, w)
        src_a, dst_a, cost_a = move_edges(self.blocked, self.corner_rule)
        order = np.argsort(src_a, kind="stable")  # by cell, then by direction
        n = h * w
        self.indptr = np.searchsorted(src_a[order], np.arange(n + 1)).astype(np.int64)
        self.indices = dst_a[order]
        self.costs = cost_a[order]
        self._labels: np.ndarray | None = None  # the regions, labelled when first asked
        self._xs = np.tile(np.arange(w, dtype=np.float64), h)
        self._ys = np.repeat(np.arange(h, dtype=np.float64), w)

    # ----------------------------------------------------------------------- queries
    def _regions(self) -> np.ndarray:
        """``int[H * W]``: each cell's connected region under the corner rule
        (:func:`jaxga.maps.preprocess.region_labels`), labelled once per graph."""
        if self._labels is None:
            self._labels = region_labels(self.blocked, self.corner_rule).reshape(-1)
        return self._labels

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
            return self._search(start_xy, goal_xy, Deadline(budget_s))
        except OutOfBudget:
            return missing_path(budget_message("8-connected", budget_s), "budget", "octile")

    def _search(self, start_xy: XY, goal_xy: XY, deadline: Deadline) -> ReferencePath:
        start, goal = as_xy(start_xy), as_xy(goal_xy)
        problem = endpoint_problem(self.blocked, start, goal)
        if problem:
            return missing_path(problem, "endpoint_blocked", "octile")
        w = self.shape[1]
        s = start[1] * w + start[0]
        g = goal[1] * w + goal[0]
        if s == g:
            return ReferencePath(True, 0.0, np.array([start], np.int32), kind="octile")
        labels = self._regions()
        if labels[s] != labels[g]:  # known at once: A* would search all of start's region
            return missing_path(unreachable_message(start, goal, self.corner_rule),
                                "unreachable", "octile")
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
            return missing_path(unreachable_message(start, goal, self.corner_rule),
                            "unreachable", "octile", expanded)
        cells = [g]
        while cells[-1] != s:
            cells.append(parent[cells[-1]])
        idx = np.array(cells[::-1], dtype=np.int64)
        path = np.stack([idx % w, idx // w], axis=1).astype(np.int32)
        return ReferencePath(True, octile_length(path), path, kind="octile", expanded=expanded)

    def distances(self, source_xy: XY) -> np.ndarray:
        """``float64[H, W]`` Dijkstra distances from ``source_xy`` (``inf`` where unreachable).

        The move graph is symmetric (a move and its reverse pass the same side cells), so
        this is also the distance *to* ``source_xy``. Raises
        :class:`~jaxga.core.errors.EndpointError` if the source is off the map or blocked.
        """
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra

        src = as_xy(source_xy)
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
    b = as_blocked(blocked)
    start, goal = as_xy(start_xy), as_xy(goal_xy)
    problem = endpoint_problem(b, start, goal)
    if problem:
        check_rule(corner_rule)
        return missing_path(problem, "endpoint_blocked", "octile")
    labels = region_labels(b, check_rule(corner_rule))
    if labels[start[1], start[0]] != labels[goal[1], goal[0]]:  # no graph to build
        return missing_path(unreachable_message(start, goal, corner_rule), "unreachable",
                            "octile")
    graph = OctileGraph(b, corner_rule)
    graph._labels = labels.reshape(-1)  # labelled once
    return graph.search(start_xy, goal_xy)


def shortest_path(grid: Grid) -> ReferencePath:
    """The 8-connected shortest path of ``grid`` under its corner rule.

    Straight steps cost 1 and diagonal steps ``sqrt(2)``; a diagonal step is legal when
    its side cells satisfy ``grid.corner_rule``. A* with the octile heuristic (exact:
    the heuristic is consistent). A blocked start or goal or an unreachable goal gives
    ``found=False`` and a ``reason`` instead of an exception; call
    :meth:`ReferencePath.raise_if_missing` to get :class:`~jaxga.core.errors.EndpointError` /
    :class:`~jaxga.core.errors.NoPathError`.
    """
    return shortest_path_np(grid.blocked_np(), grid.start_xy, grid.goal_xy, grid.corner_rule)


def distances_from(grid: Grid, source_xy: XY | None = None) -> np.ndarray:
    """Full 8-connected distance field ``float64[H, W]`` from ``source_xy``.

    ``source_xy`` defaults to the grid's start. ``inf`` marks blocked and unreachable
    cells. Because moves are symmetric under every corner rule, ``distances_from(grid,
    grid.goal_xy)`` is the cost-to-go field used for gap reporting. Raises
    :class:`~jaxga.core.errors.EndpointError` for a blocked or off-map source.
    """
    src = grid.start_xy if source_xy is None else source_xy
    return OctileGraph(grid.blocked_np(), grid.corner_rule).distances(src)


# ======================================================================= line of sight
def side_ok(s1: bool, s2: bool, rule: str) -> bool:
    if rule == "free":
        return True
    if rule == "no_squeeze":
        return not (s1 and s2)
    return not (s1 or s2)


def clear_np(blocked: np.ndarray, corner_rule: str, a_xy: XY, b_xy: XY) -> bool:
    """Exact line of sight between the centres of cells ``a_xy`` and ``b_xy``.

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
    x, y = as_xy(a_xy)
    x1, y1 = as_xy(b_xy)
    if not (0 <= x < w and 0 <= y < h and 0 <= x1 < w and 0 <= y1 < h):
        return False
    if b[y, x]:
        return False
    for (cx, cy), sides in line_walk((x, y), (x1, y1)):
        if sides is not None and not side_ok(bool(b[sides[0][1], sides[0][0]]),
                                             bool(b[sides[1][1], sides[1][0]]), corner_rule):
            return False
        if b[cy, cx]:
            return False
    return True


def line_walk(a_xy: XY, b_xy: XY) -> Iterator[tuple[XY, tuple[XY, XY] | None]]:
    """The cells the segment between the centres of ``a_xy`` and ``b_xy`` enters after
    ``a_xy``, in order (``b_xy`` last), each with the two side cells it passes between
    when it enters through a grid vertex (a diagonal move), else None. Exact integer
    arithmetic, as :func:`clear_np` describes."""
    x, y = as_xy(a_xy)
    x1, y1 = as_xy(b_xy)
    dx, dy = x1 - x, y1 - y
    sx, sy = (dx > 0) - (dx < 0), (dy > 0) - (dy < 0)
    big_a, big_b = abs(dx), abs(dy)
    i = j = 0
    while i < big_a or j < big_b:
        tx = (2 * i + 1) * big_b if i < big_a else None
        ty = (2 * j + 1) * big_a if j < big_b else None
        sides = None
        if ty is None or (tx is not None and tx < ty):
            x += sx
            i += 1
        elif tx is None or ty < tx:
            y += sy
            j += 1
        else:  # exactly through a grid vertex: a diagonal move
            sides = ((x + sx, y), (x, y + sy))
            x += sx
            y += sy
            i += 1
            j += 1
        yield (x, y), sides


SPAN_CHUNK = 1 << 21
"""The most unit steps (summed over segments) one flat NumPy pass of the segment tests
(:func:`clear_pairs_np`, :func:`jaxga.reference.lower_bound.segments_free_np`) handles
at once: each step takes about a dozen 8-byte temporaries, so a pass stays near 200 MB
(on a 500 x 500 map a single pass asked for tens of GB and the process was killed)."""


def span_chunks(spans: np.ndarray, cap: int | None = None) -> list[slice]:
    """Consecutive slices of items whose ``spans`` sum to at most ``cap`` (default
    :data:`SPAN_CHUNK`) each, an item over ``cap`` alone in its slice: the batches of a
    segment test that bound its memory. One slice when everything fits."""
    cap = SPAN_CHUNK if cap is None else cap
    ends = np.cumsum(np.asarray(spans, np.int64))
    out, start, before = [], 0, 0
    while start < ends.size:
        stop = max(int(np.searchsorted(ends, before + cap, side="right")), start + 1)
        out.append(slice(start, stop))
        before, start = int(ends[stop - 1]), stop
    return out


def concat_ranges(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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

    Same definition as :func:`clear_np` but a different, closed-form computation
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
    check_rule(corner_rule)
    a = np.asarray(a_xy, dtype=np.int64).reshape(-1, 2)
    t = np.asarray(b_xy, dtype=np.int64).reshape(-1, 2)
    a, t = np.broadcast_arrays(a, t)
    chunks = span_chunks(np.abs(t - a).max(axis=1) + 1)
    if len(chunks) > 1:  # bounded memory: the pairs in batches (module constant)
        return np.concatenate([clear_pairs_np(bl, corner_rule, a[c], t[c]) for c in chunks])
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

    rows, i = concat_ranges(big_a)
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

    ``targets_xy`` is ``int[n, 2]``; see :func:`clear_pairs_np` for the method.
    """
    t = np.asarray(targets_xy, dtype=np.int64).reshape(-1, 2)
    a = np.broadcast_to(np.asarray(as_xy(a_xy), dtype=np.int64), t.shape)
    return clear_pairs_np(blocked, corner_rule, a, t)


def segment_pattern(
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
