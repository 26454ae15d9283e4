"""A proven lower bound of the any-angle optimum: the taut string among the obstacles.

The any-angle optimum (:func:`jaxga.reference.any_angle.any_angle_shortest_path`) bends
only at cell centres. Dropping that restriction gives the Euclidean shortest path in the
continuous plane between the start and goal centres among the blocked cells, each a
closed unit square (cells off the map are blocked): the *taut string*. Every clear
polyline through cell centres is such a path, so the taut string's length is a lower
bound of the any-angle optimum. It is cheap because a taut string bends only at convex
corners of the obstacles (Lozano-Perez & Wesley 1979: the shortest path among polygons
runs in the visibility graph of their vertices), and a grid map has far fewer corners
than cells.

The free space, per corner rule (see :func:`free_space`):

* a segment is allowed when it lies in the union of the *closed* free cells: it may run
  along a cell boundary or touch a blocked cell's corner (the limit of clear segments);
* a *pinch* is a grid vertex with exactly two diagonally opposite blocked cells. Under
  ``"free"`` a clear lattice segment may pass through it (between the two blocked
  cells), so the bound lets a path cross it and bend there; under ``"no_squeeze"`` and
  ``"strict"`` no clear segment passes it, so the bound forbids crossing it, which keeps
  the bound valid and makes it tighter.

The bound ignores the rest of the corner rules (under ``"strict"`` a clear segment does
not even touch a blocked corner, but it gets arbitrarily close), so it is a lower bound
under every rule, tight up to the lattice effect (decision 031).

Points are held in *doubled* integer coordinates: cell ``(x, y)`` occupies
``[2x, 2x + 2] x [2y, 2y + 2]``, its centre is ``(2x + 1, 2y + 1)`` and a grid vertex
is a pair of even numbers, so every line-of-sight test is exact integer arithmetic.

:class:`GeodesicBounds` turns the same search into per-cell lower bounds of the
any-angle distances from the start and to the goal, the heuristic and the pruning of the
exact lattice search.
"""

from __future__ import annotations

import dataclasses
import functools
import heapq
import math

import numpy as np

from jaxga.core.grid import Grid
from jaxga.reference.optima import (
    XY,
    Deadline,
    OctileGraph,
    OutOfBudget,
    ReferencePath,
    as_blocked,
    as_xy,
    budget_message,
    check_rule,
    checked_in_chunks,
    concat_ranges,
    endpoint_problem,
    missing_path,
    span_chunks,
    unreachable_message,
)

__all__ = [
    "FreeSpace",
    "free_space",
    "segments_free_np",
    "euclidean_lower_bound",
    "euclidean_lower_bound_np",
    "GeodesicBounds",
]

_TOL = 1e-9


@dataclasses.dataclass(frozen=True, eq=False)
class FreeSpace:
    """The closed free region of one map under one corner rule, and its convex corners.

    Attributes:
        free: ``bool[H + 2, W + 2]``: free cells, padded with a ring of blocked cells
            (``free[y + 1, x + 1]`` is cell ``(x, y)``).
        pinch: ``bool[H + 1, W + 1]``: grid vertices ``(x, y)`` (``pinch[y, x]``) that no
            path may pass through (the pinches, except under ``"free"``, where it is all
            False).
        corners: ``int64[n, 2]`` doubled coordinates of the vertices a taut string can
            bend at: exactly one of the four cells around them blocked, and under
            ``"free"`` also the pinches.
        turn: ``int64[n]``: +1 where the corner's blocked cell lies south-west or
            north-east of it, -1 where it lies north-west or south-east (for a pinch:
            where its two blocked cells lie). A taut string that bends at the corner
            wraps that cell, so both its segments there have ``turn * dx * dy <= 0``
            (:func:`_tangent`).
        inside: ``int64[n, 2]``: the diagonal step from the corner into its blocked cell,
            ``(0, 0)`` at a pinch (:func:`_wraps`).
        lookup: the tables :func:`segments_free_np` reads, flat: :attr:`free` with the x
            axis contiguous and with the y axis contiguous, the same for "a free cell on
            either side of the horizontal (vertical) grid line below (left of) the
            cell", and a block of True (start offsets in ``regions``).
        regions: ``(free_x, free_y, line_x, line_y, true)`` offsets into ``lookup``.
    """

    free: np.ndarray
    pinch: np.ndarray
    corners: np.ndarray
    turn: np.ndarray
    inside: np.ndarray
    lookup: np.ndarray
    regions: tuple[int, int, int, int, int]


def free_space(blocked: np.ndarray, corner_rule: str = "strict") -> FreeSpace:
    """The :class:`FreeSpace` of ``blocked`` (``bool[H, W]``, row 0 at the bottom).

    Corners are classified from the 2 x 2 window of cells around every grid vertex:
    one blocked cell makes a convex obstacle corner (the free space turns through
    270 degrees there); two diagonal blocked cells make a pinch, a bend point only
    where a path may cross it (``"free"``); every other vertex is no bend point of a
    shortest path (it is flat or a concave corner of the free space).
    """
    b = as_blocked(blocked)
    rule = check_rule(corner_rule)
    h, w = b.shape
    free = np.zeros((h + 2, w + 2), bool)
    free[1:-1, 1:-1] = ~b
    bp = ~free
    sw, se, nw, ne = bp[:-1, :-1], bp[:-1, 1:], bp[1:, :-1], bp[1:, 1:]
    count = sw.astype(np.int8) + se + nw + ne
    pinch = (count == 2) & (sw == ne)
    bend = count == 1
    if rule == "free":
        bend |= pinch
        pinch = np.zeros_like(pinch)
    vy, vx = np.nonzero(bend)
    corners = np.stack([2 * vx, 2 * vy], axis=1).astype(np.int64)
    turn = np.where(sw[vy, vx] | ne[vy, vx], 1, -1).astype(np.int64)
    one = count[vy, vx] == 1
    inside = np.stack([ne[vy, vx].astype(np.int64) + se[vy, vx] - nw[vy, vx] - sw[vy, vx],
                       ne[vy, vx].astype(np.int64) + nw[vy, vx] - se[vy, vx] - sw[vy, vx]],
                      axis=1) * one[:, None]
    tables = []
    for f in (free, free.T):
        line = np.zeros_like(f)
        line[1:] = f[:-1] | f[1:]
        tables.append((f, line))
    parts = [tables[0][0], tables[1][0], tables[0][1], tables[1][1], np.ones_like(free)]
    regions = tuple(int(v) for v in np.cumsum([0] + [t.size for t in parts[:-1]]))
    lookup = np.concatenate([np.ascontiguousarray(t).reshape(-1) for t in parts])
    return FreeSpace(free, pinch, corners, turn, inside, lookup, regions)


def segments_free_np(
    space: FreeSpace, p: np.ndarray, q: np.ndarray, ends: int = 0
) -> np.ndarray:
    """``bool[n]``: whether each segment ``p[i] -> q[i]`` (doubled coordinates inside the
    map's box) lies in the closed free space and crosses no forbidden pinch.

    Exact, one flat NumPy pass over every unit column the segments span, as
    :func:`jaxga.reference.optima.clear_pairs_np` does for centre-to-centre segments.
    Along the major axis (extent ``D``; minor extent ``E``, ``|E| <= D``, made ``>= 0`` by
    mirroring the minor axis), the part of a segment inside one column rises from minor
    coordinate ``na / D`` to ``nb / D`` (integers ``na <= nb``), at most one row: the cells
    holding its lowest and highest points, rows ``floor(na / 2D)`` and
    ``floor((nb - 1) / 2D)``, must both be free (their interiors are entered), except for
    a segment lying on a grid line, which needs a free cell on either side of it. Where it
    crosses a column boundary exactly at a grid vertex, that vertex must not be a
    forbidden pinch. A zero-length segment is allowed. (The floors are taken in floating
    point with a margin of 1e-9, far below the spacing ``1 / 2D`` of the non-integer
    quotients: exact for coordinates below a million.)

    ``ends > 0`` checks only the ``ends`` unit columns at either end of every segment: a
    cheap necessary condition that rejects most hidden pairs (those blocked near an end)
    before the full test.
    """
    p = np.asarray(p, np.int64).reshape(-1, 2)
    q = np.asarray(q, np.int64).reshape(-1, 2)
    p, q = np.broadcast_arrays(p, q)
    span = np.abs(q - p).max(axis=1) // 2 + 2  # unit columns a segment spans, at most
    chunks = span_chunks(span if ends <= 0 else np.minimum(span, 2 * ends + 2))
    if len(chunks) > 1:  # bounded memory: the segments in batches (SPAN_CHUNK)
        return np.concatenate([segments_free_np(space, p[c], q[c], ends) for c in chunks])
    n = p.shape[0]
    out = np.ones(n, bool)
    if n == 0:
        return out
    dx, dy = q[:, 0] - p[:, 0], q[:, 1] - p[:, 1]
    xmaj = np.abs(dx) >= np.abs(dy)
    maj0, maj1 = np.where(xmaj, p[:, 0], p[:, 1]), np.where(xmaj, q[:, 0], q[:, 1])
    min0, min1 = np.where(xmaj, p[:, 1], p[:, 0]), np.where(xmaj, q[:, 1], q[:, 0])
    flip = maj1 < maj0
    maj0, maj1 = np.where(flip, maj1, maj0), np.where(flip, maj0, maj1)
    min0, min1 = np.where(flip, min1, min0), np.where(flip, min0, min1)
    mirror = min1 < min0
    big_d, big_e = maj1 - maj0, np.abs(min1 - min0)
    min0 = np.where(mirror, -min0, min0)
    c0 = maj0 // 2
    count = np.where(big_d > 0, (maj1 - 1) // 2 - c0 + 1, 0)
    seg = np.flatnonzero(count)
    if seg.size == 0:
        return out
    # per segment: mirror, axes and tables (see FreeSpace.lookup)
    xm, mir, d, e = xmaj[seg], mirror[seg], big_d[seg], big_e[seg]
    c0, count, m0, mn0 = c0[seg], count[seg], maj0[seg], min0[seg]
    h2, w2 = space.free.shape
    fx, fy, lx, ly, true = space.regions
    stride = np.where(xm, w2, h2)
    on_line = (e == 0) & (mn0 % 2 == 0)
    table = np.where(on_line, np.where(xm, lx, ly), np.where(xm, fx, fy))
    base_lo = table + c0 + 1 + np.where(mir, 0, stride)  # + off + row * step
    base_hi = np.where(on_line, true + c0 + 1 + stride, base_lo)
    step = np.where(mir, -stride, stride)
    part = count if ends <= 0 else np.minimum(count, 2 * ends)
    rows, off = concat_ranges(part)
    if ends > 0:
        off += np.where(off < ends, 0, (count - part)[rows])
    starts = np.cumsum(part) - part
    # minor coordinate times D at the left boundary of each column, then both ends
    two_e = 2 * e
    na = (mn0 * d + e * (2 * c0 - m0))[rows] + two_e[rows] * off
    nb = na + two_e[rows]
    na[starts] += e * (m0 - 2 * c0)  # the first column starts at m0
    nb[starts + part - 1] -= e * (2 * (c0 + count) - (m0 + d))  # the last ends at m0 + d
    inv = (1.0 / (2 * d))[rows]
    r_lo = np.floor(na * inv + 1e-9).astype(np.int64)
    r_hi = np.floor((nb - 1) * inv + 1e-9).astype(np.int64)
    st = step[rows]
    ok = space.lookup[base_lo[rows] + off + r_lo * st]
    ok &= space.lookup[base_hi[rows] + off + r_hi * st]
    if space.pinch.any():
        # the left boundary of every column after the first is inside the segment
        k = np.flatnonzero((off > 0) & (na == r_lo * (2 * d)[rows]))
        if k.size:
            vmaj = (c0[rows[k]] + off[k])
            vmin = np.where(mir[rows[k]], -r_lo[k], r_lo[k])
            x_major = xm[rows[k]]
            vx, vy = np.where(x_major, vmaj, vmin), np.where(x_major, vmin, vmaj)
            ok[k] &= ~space.pinch[vy, vx]
    out[seg] = np.logical_and.reduceat(ok, starts)
    return out


def _tangent(turn: np.ndarray, ddx: np.ndarray, ddy: np.ndarray) -> np.ndarray:
    """Whether a segment of direction ``(ddx, ddy)`` may be one side of a bend at a corner
    of sign ``turn`` (0: no corner, always).

    At a bend of a shortest path the blocked cell lies inside the (convex) angle of the
    two segments, otherwise cutting the bend would be shorter and still free; so both
    edges of the cell at the corner lie on one side of each segment's line. For a cell
    south-west or north-east of the corner (edges along ``-x, -y`` or ``+x, +y``) that
    is ``dx * dy <= 0``; north-west or south-east, ``dx * dy >= 0`` (the tangent segments
    of the reduced visibility graph).
    """
    return turn * np.sign(ddx) * np.sign(ddy) <= 0


def _wraps(inside: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether a path arriving at a corner from direction ``a`` (the vector from the
    corner back to the previous point) and leaving along ``b`` wraps the corner's cell.

    ``inside``: the corner's diagonal step into its blocked cell (``(0, 0)``: a pinch,
    always true). A shortest path that bends at a convex corner has the blocked cell
    inside the convex angle between ``a`` and ``b``; otherwise the small triangle cut off
    at the corner is free (no other cell touches the corner) and cutting it is shorter.
    A straight pass (``a``, ``b`` collinear) is allowed. Arrays broadcast; integer
    coordinates, exact.
    """
    qx, qy = inside[..., 0], inside[..., 1]
    ax, ay, bx, by = a[..., 0], a[..., 1], b[..., 0], b[..., 1]
    ab = np.sign(ax * by - ay * bx)
    return (np.sign(ax * qy - ay * qx) * ab >= 0) & (np.sign(bx * qy - by * qx) * ab <= 0)


def _taut_search(
    space: FreeSpace,
    pts: np.ndarray,
    turn: np.ndarray,
    inside: np.ndarray,
    source: int,
    heur: np.ndarray,
    upper: float,
    stop: int = -1,
    both_ends: bool = False,
    deadline: Deadline | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """A* over the visibility graph of ``pts`` (doubled coordinates) from ``source``.

    ``heur`` is a lower bound of every point's distance to the target, consistent along
    the shortest paths that matter; only paths of length ``<= upper`` are followed (a
    point is relaxed when ``g + heur <= upper``), edges are line-of-sight checked lazily
    (only when they would strictly improve an open point) and vectorised. An edge leaving
    a corner must wrap it with the edge from the corner's parent (:func:`_wraps`, which
    holds for every shortest path through the corner: when the parent's path is shortest,
    so is the path through it) and be tangent there (:func:`_tangent`); with
    ``both_ends`` an edge must also be tangent at a corner it enters, which is right when
    the corners are bends, not targets (the reduced visibility graph). Stops when ``stop``
    is expanded, else exhausts the points within ``upper``. Returns the distances (exact
    for every point ``v`` with ``dist(v) + heur(v) <= upper``, ``inf`` or an upper bound
    elsewhere), the parents and the number of points expanded.
    """
    n = pts.shape[0]
    px, py = pts[:, 0], pts[:, 1]
    g = np.full(n, math.inf)
    par = np.full(n, -1, np.int64)
    closed = np.zeros(n, bool)
    slack = upper + _TOL - heur
    g[source] = 0.0
    heap = [(float(heur[source]), source)]
    expanded = 0
    while heap:
        f, k = heapq.heappop(heap)
        if closed[k] or f > g[k] + heur[k] + _TOL:
            continue
        closed[k] = True
        expanded += 1
        if k == stop:
            break
        if deadline is not None:
            deadline.check()
        ddx, ddy = px - px[k], py - py[k]
        tent = g[k] + np.hypot(ddx, ddy) / 2
        mask = ~closed & (tent < g - 1e-12) & (tent <= slack)
        if turn[k]:
            mask &= _tangent(turn[k], ddx, ddy)
            mask &= _wraps(inside[k], pts[par[k]] - pts[k], pts - pts[k])
        if both_ends:
            mask &= _tangent(turn, ddx, ddy)
        cand = np.flatnonzero(mask)
        if cand.size == 0:
            continue
        vis = cand[checked_in_chunks(functools.partial(segments_free_np, space), pts[k],
                                      pts[cand], deadline)]
        g[vis] = tent[vis]
        par[vis] = k
        for v, fv in zip(vis.tolist(), (tent[vis] + heur[vis]).tolist(), strict=True):
            heapq.heappush(heap, (fv, v))
    return g, par, expanded


def _doubled_centre(cell: tuple[int, int]) -> np.ndarray:
    return np.array([2 * cell[0] + 1, 2 * cell[1] + 1], np.int64)


def _points(
    space: FreeSpace, start: tuple[int, int], goal: tuple[int, int], upper: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``[start, goal, corners in the ellipse |s c| + |c g| <= upper]`` and their
    :attr:`FreeSpace.turn` and :attr:`FreeSpace.inside` (0 for the two ends)."""
    s2, g2 = _doubled_centre(start), _doubled_centre(goal)
    c = space.corners
    keep = np.hypot(*(c - s2).T) / 2 + np.hypot(*(c - g2).T) / 2 <= upper + _TOL
    pts = np.vstack([s2, g2, c[keep]])
    turn = np.concatenate([[0, 0], space.turn[keep]]).astype(np.int64)
    inside = np.vstack([np.zeros((2, 2), np.int64), space.inside[keep]])
    return pts, turn, inside


def euclidean_lower_bound_np(
    blocked: np.ndarray,
    start_xy: XY,
    goal_xy: XY,
    corner_rule: str = "strict",
    *,
    upper: float | None = None,
    budget_s: float | None = None,
) -> ReferencePath:
    """The taut-string length between the start and goal centres: a proven lower bound
    of :func:`~jaxga.reference.any_angle.any_angle_shortest_path_np` under ``corner_rule``.

    The Euclidean shortest path in the plane among the blocked cells (closed unit
    squares, the map's outside blocked; pinches crossable only under ``"free"``: see
    the module docstring), found as A* with the Euclidean heuristic over the visibility
    graph of the start, the goal and the convex obstacle corners (Lozano-Perez & Wesley
    1979), restricted to tangent edges (a taut string wraps every corner it bends at),
    pruned to the corners inside the ellipse ``|s c| + |c g| <= upper`` and with lazy,
    vectorised, exact line-of-sight tests (:func:`segments_free_np`).

    Args:
        blocked: ``bool[H, W]``, row 0 at the bottom.
        start_xy, goal_xy: ``(x, y)`` cells.
        corner_rule: ``"free"``, ``"no_squeeze"`` or ``"strict"``.
        upper: the length of an actual path from start to goal (e.g. a GA result): only
            corners that a path this short can reach are searched (a smaller value may
            make the goal unreachable). Default: the 8-connected optimum, which also
            settles reachability.
        budget_s: wall-clock seconds the search may take; past them it returns
            ``found=False`` with status ``"budget"``. None: no limit.

    Returns:
        A :class:`~jaxga.reference.optima.ReferencePath` of kind ``"euclidean_bound"``:
        ``length`` the bound and ``path`` ``float64[k, 2]``, the taut string's points in
        the frame of the cell indices (cell ``(x, y)``'s centre is ``(x, y)``, so it
        starts at ``start_xy``, ends at ``goal_xy`` and bends at half-integer grid
        vertices). A blocked start or goal or an unreachable goal gives ``found=False``
        with a reason, as the optima do.
    """
    b = as_blocked(blocked)
    rule = check_rule(corner_rule)
    start, goal = as_xy(start_xy), as_xy(goal_xy)
    kind = "euclidean_bound"
    problem = endpoint_problem(b, start, goal)
    if problem:
        return missing_path(problem, "endpoint_blocked", kind)
    if start == goal:
        return ReferencePath(True, 0.0, np.array([start], np.float64), kind=kind)
    deadline = Deadline(budget_s)
    try:
        if upper is None:
            octile = OctileGraph(b, rule)._search(start, goal, deadline)
            if not octile.found:
                return dataclasses.replace(octile, kind=kind)
            upper = octile.length
        space = free_space(b, rule)
        pts, turn, inside = _points(space, start, goal, float(upper))
        heur = np.hypot(*(pts - pts[1]).T) / 2
        g, par, expanded = _taut_search(space, pts, turn, inside, 0, heur, float(upper),
                                        stop=1, both_ends=True, deadline=deadline)
    except OutOfBudget:
        return missing_path(budget_message("Euclidean lower bound of the any-angle", budget_s),
                        "budget", kind)
    if not math.isfinite(g[1]):
        return missing_path(unreachable_message(start, goal, rule), "unreachable", kind)
    chain = [1]
    while chain[-1] != 0:
        chain.append(int(par[chain[-1]]))
    path = (pts[chain[::-1]] - 1) / 2.0
    return ReferencePath(True, float(g[1]), path, kind=kind, expanded=expanded)


def euclidean_lower_bound(
    grid: Grid, *, upper: float | None = None, budget_s: float | None = None
) -> ReferencePath:
    """The taut-string lower bound of ``grid``'s any-angle optimum under its corner rule;
    see :func:`euclidean_lower_bound_np`."""
    return euclidean_lower_bound_np(grid.blocked_np(), grid.start_xy, grid.goal_xy,
                                    grid.corner_rule, upper=upper, budget_s=budget_s)


class GeodesicBounds:
    """Taut-string distances from the start and to the goal: of the corners at once, and
    of the cells (:meth:`cells`) wherever a path of length ``<= upper`` can pass.

    The heuristic and the pruning of the exact lattice search
    (:func:`jaxga.reference.any_angle.any_angle_shortest_path`). ``geo_s(v)``, ``geo_g(v)``
    denote the taut-string distances of a point ``v`` from the start and to the goal.

    Construction computes the distances ``Ds``, ``Dg`` of the corners by
    :func:`_taut_search`: ``Dg`` with the Euclidean distance to the start as the heuristic,
    then ``Ds`` with ``Dg`` as the heuristic. Both are exact on the corner set
    ``E(T) = {c : Ds(c) + Dg(c) <= T}`` for every ``T <= upper``, and ``E(T)`` holds every
    corner that the taut path of any point ``v`` with ``geo_s(v) + geo_g(v) <= T`` bends
    at (by the triangle inequality, they all lie in that geodesic ellipse too).

    Args:
        blocked: ``bool[H, W]``, row 0 at the bottom.
        corner_rule: ``"free"``, ``"no_squeeze"`` or ``"strict"`` (see the module
            docstring for what each means here).
        start, goal: ``(x, y)`` cells, free and joined by a path of length ``<= upper``.
        upper: the length of an actual path from start to goal.
        deadline: the searches check it (a budgeted caller's clock), else None.

    Attributes:
        bound: the taut-string length (:func:`euclidean_lower_bound_np`).
        bends: ``float64[k, 2]``: the taut string's bend points in the frame of the cell
            indices (as :func:`euclidean_lower_bound_np`'s path, without its ends).
    """

    def __init__(
        self,
        blocked: np.ndarray,
        corner_rule: str,
        start: tuple[int, int],
        goal: tuple[int, int],
        upper: float,
        deadline: Deadline | None = None,
    ) -> None:
        b = as_blocked(blocked)
        self.shape = b.shape
        self.free = np.flatnonzero(~b.reshape(-1))
        self.space = free_space(b, corner_rule)
        self.upper = float(upper)
        self.deadline = deadline
        pts, turn, inside = _points(self.space, start, goal, self.upper)
        eu_s = np.hypot(*(pts - pts[0]).T) / 2
        dg, pg, _ = _taut_search(self.space, pts, turn, inside, 1, eu_s, self.upper,
                                 deadline=deadline)
        ds, ps, _ = _taut_search(self.space, pts, turn, inside, 0, dg, self.upper,
                                 deadline=deadline)
        self.bound = float(dg[0])
        chain = [int(pg[0])]
        while chain[-1] > 1:
            chain.append(int(pg[chain[-1]]))
        self.bends = (pts[chain[:-1]] - 1) / 2.0
        self._corners = (pts, turn, inside, ds, dg, pts[np.maximum(ps, 0)],
                         pts[np.maximum(pg, 0)])

    def cells(
        self, upper: float, start_upper: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(to_start, to_goal)``: flat ``float64[H * W]`` bounds for the cell centres.

        If ``to_start[v] + to_goal[v] > upper`` then ``geo_s(v) + geo_g(v) > upper``, so
        no path of length ``<= upper`` (``<=`` the construction's) visits ``v``; otherwise
        both are the taut-string distances (so ``to_goal`` is a consistent A* heuristic
        there). ``start_upper``: optional upper bounds of ``geo_s`` (flat, e.g. lattice
        distances from the start), used to skip hidden pairs.

        Method (a shortest path map restricted to a geodesic ellipse):

        1. ``m_g(v) = min_{c in E + goal} |v c| + Dg(c)`` ignoring visibility (``m_s``
           likewise): ``m_g <= geo_g`` on the cells that matter. Cells with
           ``m_s + m_g > upper`` are dropped.
        2. ``to_goal(v) = min |v c| + Dg(c)`` over the corners ``c`` of ``E`` (and the
           goal) that ``v`` sees and that can be the first bend of its taut path to the
           goal: tangent at ``c`` and wrapping it with the next point of ``c``'s path
           (:func:`_tangent`, :func:`_wraps`; every shortest continuation from a first
           bend is taut), ``|v c| + Dg(c) + m_s(v) <= upper`` and, when ``v`` sees
           ``c``, ``Ds(c) <= geo_s(v) + |v c| <= start_upper(v) + |v c|``. Then
           ``to_start`` likewise, with ``to_goal`` in the roles of ``m_g`` and of the
           upper bound. Each is at least the taut-string distance, and equal to it where
           ``geo_s + geo_g <= upper``. The candidates of a cell are tried in increasing
           order of ``|v c| + Dg(c)``, so the first visible one is the minimum, after a
           cheap test of both ends of every segment (:func:`segments_free_np`).
        """
        upper = min(float(upper), self.upper)
        pts, turn, inside, ds, dg, next_s, next_g = self._corners
        in_e = np.flatnonzero(ds + dg <= upper + _TOL)
        e_pts, e_ds, e_dg = pts[in_e], ds[in_e], dg[in_e]
        h, w = self.shape
        free = self.free
        cells = np.stack([2 * (free % w) + 1, 2 * (free // w) + 1], axis=1)
        cx, cy = cells[:, 0] / 2, cells[:, 1] / 2
        m_s = np.full(free.size, math.inf)
        m_g = np.full(free.size, math.inf)
        for (ex, ey), vs, vg in zip((e_pts / 2).tolist(), e_ds.tolist(), e_dg.tolist(),
                                    strict=True):
            if self.deadline is not None:
                self.deadline.check()
            dist = np.hypot(cx - ex, cy - ey)
            np.minimum(m_s, dist + vs, out=m_s)
            np.minimum(m_g, dist + vg, out=m_g)
        near = free[m_s + m_g <= upper + _TOL]
        sel = np.searchsorted(free, near)
        cells, m_s, m_g = cells[sel], m_s[sel], m_g[sel]
        to_goal = np.full(h * w, math.inf)
        to_start = np.full(h * w, math.inf)
        high_s = np.full(near.size, math.inf) if start_upper is None else start_upper[near]
        e = (e_pts, turn[in_e], inside[in_e])
        to_goal[near] = self._first_bend(cells, e, e_dg, next_g[in_e], m_s, e_ds, high_s,
                                         upper)
        high_g = to_goal[near]
        to_start[near] = self._first_bend(cells, e, e_ds, next_s[in_e],
                                          np.maximum(m_g, high_g), e_dg, high_g, upper)
        return to_start, to_goal

    def _first_bend(
        self,
        cells: np.ndarray,
        e: tuple[np.ndarray, np.ndarray, np.ndarray],
        to: np.ndarray,
        nxt: np.ndarray,
        low: np.ndarray,
        d_other: np.ndarray,
        high: np.ndarray,
        upper: float,
    ) -> np.ndarray:
        """Step 2 of :meth:`cells` for one target: the minimum over the candidate corners
        that a cell sees of ``|v c| + to(c)`` (``inf`` if none)."""
        e_pts, e_turn, e_inside = e
        space, deadline = self.space, self.deadline
        n = cells.shape[0]
        best = np.full(n, math.inf)
        if e_pts.shape[0] == 0:
            return best
        ci, ck = [], []
        for k in range(e_pts.shape[0]):
            ddx, ddy = cells[:, 0] - e_pts[k, 0], cells[:, 1] - e_pts[k, 1]
            dist = np.hypot(ddx, ddy) / 2
            sel = (dist + to[k] + low <= upper + _TOL) & (d_other[k] - dist <= high + _TOL)
            if e_turn[k]:
                sel &= _tangent(e_turn[k], ddx, ddy)
                sel &= _wraps(e_inside[k], cells - e_pts[k], nxt[k] - e_pts[k])
            sel = np.flatnonzero(sel)
            ci.append(sel)
            ck.append(np.full(sel.size, k))
        ci, ck = np.concatenate(ci), np.concatenate(ck)
        if deadline is not None:
            deadline.check()
        ok = checked_in_chunks(functools.partial(segments_free_np, space, ends=16),
                                cells[ci], e_pts[ck], deadline, steps=2_000_000)
        ci, ck = ci[ok], ck[ok]
        via = np.hypot(*(cells[ci] - e_pts[ck]).T) / 2 + to[ck]
        order = np.lexsort((via, ci))
        ci, ck, via = ci[order], ck[order], via[order]
        first = np.searchsorted(ci, np.arange(n))
        last = np.searchsorted(ci, np.arange(n), side="right")
        todo = np.flatnonzero(first < last)
        pos = first[todo]
        while todo.size:
            if deadline is not None:
                deadline.check()
            seen = checked_in_chunks(functools.partial(segments_free_np, space),
                                      cells[todo], e_pts[ck[pos]], deadline)
            best[todo[seen]] = via[pos[seen]]
            pos = pos + 1
            more = ~seen & (pos < last[todo])
            todo, pos = todo[more], pos[more]
        return best
