"""The exact any-angle optimum: the shortest clear polyline through cell centres.

Split from :mod:`jaxga.reference.optima` (the 8-connected optimum, the exact line of sight
and the search budget it shares) so that the search can use the taut string's per-cell
bounds (:class:`jaxga.reference.lower_bound.GeodesicBounds`, decision 031) without a
circular import. :func:`any_angle_shortest_path` documents the method.
"""

from __future__ import annotations

import dataclasses
import functools
import heapq
import math
from collections.abc import Sequence

import numpy as np

from jaxga.core.errors import JaxgaError
from jaxga.core.grid import Grid
from jaxga.reference.lower_bound import GeodesicBounds
from jaxga.reference.optima import (
    SQRT2,
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
    clear_pairs_np,
    endpoint_problem,
    missing_path,
    path_length,
    segment_pattern,
)

__all__ = [
    "C_OCTILE",
    "any_angle_shortest_path",
    "any_angle_shortest_path_np",
    "obstacle_adjacent_cells",
]


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
        cells, sides = segment_pattern(dx, dy)
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
    b: np.ndarray, rule: str, source: tuple[int, int], radius: int, deadline: Deadline
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
    b: np.ndarray, rule: str, path: np.ndarray, deadline: Deadline | None = None
) -> np.ndarray:
    """Greedy shortcutting of a clear polyline: from each kept vertex jump to the last
    later vertex it sees (``shortcut_greedy``, MPMGA §4.7, IMGA §4.5, AGACD §4.8). The
    result is clear and no longer."""
    out = [0]
    k = path.shape[0]
    while out[-1] != k - 1:
        i = out[-1]
        vis = checked_in_chunks(functools.partial(clear_pairs_np, b, rule), path[i],
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
    deadline: Deadline,
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
        vis = cand[checked_in_chunks(functools.partial(clear_pairs_np, b, rule), zxy[k],
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
    deadline: Deadline,
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
            ok = checked_in_chunks(functools.partial(clear_pairs_np, b, rule),
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
        blocked: ``bool[H, W]``, row 0 at the bottom, as in the papers.
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
    b = as_blocked(blocked)
    check_rule(corner_rule)
    start, goal = as_xy(start_xy), as_xy(goal_xy)
    problem = endpoint_problem(b, start, goal)
    if problem:
        return missing_path(problem, "endpoint_blocked", "any_angle")
    if start == goal:
        return ReferencePath(True, 0.0, np.array([start], np.int32), kind="any_angle")
    known = None if known_path is None else _checked_path(b, corner_rule, start, goal, known_path)
    try:
        return _any_angle(b, corner_rule, start, goal, exact, vertices, max(1, int(radius)),
                          known, Deadline(budget_s))
    except OutOfBudget:
        return missing_path(budget_message("any-angle", budget_s), "budget", "any_angle")


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
    deadline: Deadline,
) -> ReferencePath:
    """The search of :func:`any_angle_shortest_path_np` (see its steps in
    :func:`any_angle_shortest_path`); raises :class:`OutOfBudget` past the deadline."""
    if known is None:
        # a clear known path proves the goal reachable and bounds the optimum already
        octile = OctileGraph(b, rule)._search(start, goal, deadline)
        if not octile.found:
            return dataclasses.replace(octile, kind="any_angle")
        ub = octile.length
    else:
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
            return missing_path(
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
    b = as_blocked(blocked)
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
    (:func:`clear_np`). This is the lower bound for GA paths after post-optimisation (the
    shortcut of MPMGA §4.7, IMGA §4.5, AGACD §4.8). It is at most the 8-connected optimum
    (a legal move is a clear segment), at least the straight-line distance, and it exists
    exactly when the 8-connected path does (the cells crossed by a clear segment, in order, form a
    legal 8-connected path: orthogonal steps between free cells, and diagonal steps only
    at vertex crossings, which obey the corner rule). A blocked start/goal or an
    unreachable goal gives ``found=False`` with a reason, as for :func:`shortest_path`.

    **Which cells can be vertices.** The tempting vertex set "start, goal and the free
    cells touching an obstacle" (:func:`obstacle_adjacent_cells`; the visibility graph
    over obstacle corners) is exact for paths that may bend anywhere, because
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
    a bounded neighbourhood of the obstacles is exact, and the obstacle-adjacent set
    does miss the optimum on the classic 20 x 20 maps and on random grids (decision 015).

    **So every free cell is a vertex**, and the search is made affordable by pruning that
    provably keeps every vertex and edge of an optimal path (``s``, ``g``: start and goal;
    ``geo_s(v)``, ``geo_g(v)``: the Euclidean shortest distances in the plane around the
    blocked cells, :mod:`jaxga.reference.lower_bound`, which no clear polyline beats):

    1. The 8-connected optimum ``U8`` is computed first (reachability, upper bound), or
       ``U8`` is the length of ``known_path`` when one is given (its clear segments prove
       the goal reachable). No path of length ``<= U8`` leaves the bounding box of the ellipse
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
