"""Clearance metrics of one path: the smallest distance from the path (the polyline through
its cell centres) to a blocked cell's square, and the segments that touch one (IMGA Table 3,
"number of tangency"), searched in a band of cells around each segment (decision 009).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxga.core.dtypes import F32
from jaxga.core.grid import Grid, proximity_obstacles
from jaxga.core.path_geometry import Geometry, check_grid, geometry

__all__ = ["CLEARANCE_CHUNK", "CLEARANCE_PIECE", "CLEARANCE_RADIUS", "CLEARANCE_WIDE_RADIUS",
           "clearance_band", "min_clearance", "min_clearance_of", "tangencies",
           "tangencies_of"]


def _box_clearance(
    ax: jax.Array,
    ay: jax.Array,
    bx: jax.Array,
    by: jax.Array,
    cx: jax.Array,
    cy: jax.Array,
    blk: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """Distance from segment ``a b`` (cell centres) to the nearest of the given cell squares.

    ``cx, cy, blk``: the candidate cells' coordinates and whether each is an obstacle
    (the others count as absent). Returns ``(distance float32, touches bool)`` for one
    segment. A cell ``(cx, cy)`` is the closed square ``[cx - 1/2, cx + 1/2] x [cy - 1/2,
    cy + 1/2]``. Touching (closed intersection) is decided exactly with the
    separating-axis test in integers; the distance of a disjoint square is the minimum
    over the two segment endpoints (to the square) and the four square corners (to the
    segment), which is exact for two disjoint convex polygons. Each cell's distance
    depends on the segment and that cell only, so any set of candidates holding the
    nearest cell gives the same value.
    """
    dx, dy = bx - ax, by - ay
    over_x = (jnp.minimum(ax, bx) <= cx) & (cx <= jnp.maximum(ax, bx))
    over_y = (jnp.minimum(ay, by) <= cy) & (cy <= jnp.maximum(ay, by))
    side = jnp.abs(dx * (cy - ay) - dy * (cx - ax))
    # 2 |n . (c - a)| <= |dx| + |dy| without the doubling (it could overflow int32)
    touch = over_x & over_y & (side <= (jnp.abs(dx) + jnp.abs(dy)) // 2) & blk

    fax, fay, fbx, fby = (v.astype(F32) for v in (ax, ay, bx, by))
    fcx, fcy = cx.astype(F32), cy.astype(F32)

    def point_box(px, py):
        ex = jnp.maximum(jnp.abs(px - fcx) - 0.5, 0.0)
        ey = jnp.maximum(jnp.abs(py - fcy) - 0.5, 0.0)
        return ex * ex + ey * ey

    fdx, fdy = fbx - fax, fby - fay
    len2 = fdx * fdx + fdy * fdy
    inv = jnp.where(len2 > 0, 1.0 / jnp.where(len2 > 0, len2, 1.0), 0.0)
    best = jnp.minimum(point_box(fax, fay), point_box(fbx, fby))
    for sx in (-0.5, 0.5):
        for sy in (-0.5, 0.5):
            qx, qy = fcx + sx - fax, fcy + sy - fay
            t = jnp.clip((qx * fdx + qy * fdy) * inv, 0.0, 1.0)
            ex, ey = qx - t * fdx, qy - t * fdy
            best = jnp.minimum(best, ex * ex + ey * ey)
    dist = jnp.where(touch, 0.0, jnp.sqrt(best))
    dist = jnp.where(blk, dist, jnp.inf)
    return jnp.min(dist, initial=jnp.inf), jnp.any(touch)


def _segment_box_clearance(
    ax: jax.Array,
    ay: jax.Array,
    bx: jax.Array,
    by: jax.Array,
    blocked: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """:func:`_box_clearance` against every cell of the map (``O(H W)``)."""
    h, w = blocked.shape
    cy, cx = jnp.divmod(jnp.arange(h * w, dtype=jnp.int32), jnp.int32(w))
    return _box_clearance(ax, ay, bx, by, cx, cy, blocked.reshape(-1))


CLEARANCE_RADIUS = 4
"""Cells within this distance of a segment are searched around it first (a band), so that a
path's clearance costs ``O(L)`` on a map where it passes near obstacles (see
:func:`clearance_band`)."""

CLEARANCE_WIDE_RADIUS = 64
"""The radius of the second, wider band searched where no segment comes within
:data:`CLEARANCE_RADIUS` of an obstacle (a path across an open hall), so that only a
path farther than this from every obstacle is measured against the whole map."""

CLEARANCE_PIECE = 4
"""Major-axis cells per piece of a segment: each piece's share of the band is one fixed,
small array of cells (:func:`_piece_band_clearance`); a step of a continuous path is one
piece, a segment of ``s`` cells ``ceil(s / CLEARANCE_PIECE)``."""

CLEARANCE_CHUNK = 128
"""Pieces per block of :func:`clearance_band`'s loop."""


def _band_cells(radius: int) -> int:
    """Cells of one piece's band of ``radius`` (:func:`_piece_band_clearance`)."""
    return (CLEARANCE_PIECE + 2 * radius + 3) * (4 * radius + 7)


def _piece_band_clearance(
    ax: jax.Array,
    ay: jax.Array,
    bx: jax.Array,
    by: jax.Array,
    piece: jax.Array,
    blocked: jax.Array,
    radius: int = CLEARANCE_RADIUS,
) -> tuple[jax.Array, jax.Array]:
    """:func:`_box_clearance` of segment ``a b`` against the cells of piece ``piece`` of the
    band of ``radius`` (static; ``R`` below) around it.

    The band, along the segment's major axis ``u`` (x when ``|dx| >= |dy|``, so the slope
    is at most 1): the columns ``u0 - R - 1 .. u1 + R + 1`` (``u0 <= u1`` the segment's
    ends) and in each the rows within
    ``2 R + 3`` of the line at the column clamped to ``[u0, u1]``. A cell whose square is
    within ``R + 1/4`` of the segment lies in the band: its centre is within ``R + 3/4``
    of the nearest point ``p`` on each axis, and the line at the clamped column is within
    ``R + 3/4`` of ``p`` too. So a band distance of at most ``R`` is the segment's exact
    clearance, and a larger one says that it exceeds ``R``. Piece ``k`` holds the columns
    ``u0 + k P - R - 1 .. u0 + (k + 1) P + R + 1`` (``P`` = :data:`CLEARANCE_PIECE`), so
    the pieces ``0 .. ceil((u1 - u0) / P) - 1`` (at least one) cover the band.
    """
    h, w = blocked.shape
    r, size = radius, CLEARANCE_PIECE
    k = 2 * r + 3
    x_major = jnp.abs(bx - ax) >= jnp.abs(by - ay)
    au, av = jnp.where(x_major, ax, ay), jnp.where(x_major, ay, ax)
    bu, bv = jnp.where(x_major, bx, by), jnp.where(x_major, by, bx)
    du = bu - au
    u0, u1 = jnp.minimum(au, bu), jnp.maximum(au, bu)
    cols = u0 + piece * size - (r + 1) + jnp.arange(size + 2 * r + 3, dtype=jnp.int32)
    frac = (jnp.clip(cols, u0, u1) - au).astype(F32) / jnp.where(du == 0, 1, du).astype(F32)
    line = jnp.floor(av.astype(F32) + (bv - av).astype(F32) * frac).astype(jnp.int32)
    cu = jnp.broadcast_to(cols[:, None], (cols.shape[0], 2 * k + 1)).reshape(-1)
    cv = (line[:, None] + jnp.arange(-k, k + 1, dtype=jnp.int32)[None, :]).reshape(-1)
    cx, cy = jnp.where(x_major, cu, cv), jnp.where(x_major, cv, cu)
    inside = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    blk = inside & blocked.reshape(-1)[jnp.where(inside, cy * w + cx, 0)]
    return _box_clearance(ax, ay, bx, by, cx, cy, blk)


def clearance_band(grid: Grid, g: Geometry,
               border_blocked: bool = False) -> tuple[jax.Array, jax.Array]:
    """``(min distance float32, touches bool[S])``: the path's clearance to the cells
    :func:`jaxga.core.grid.proximity_obstacles` counts, and whether each segment (a node
    if L = 1) touches one (False for the zero-length segments after the last moving one:
    padding, never counted as tangencies).

    Exact, with the work bounded by the path rather than the map where the path passes
    within :data:`CLEARANCE_RADIUS` of an obstacle: every segment is measured against a
    band of cells around it, in pieces (:func:`_piece_band_clearance`; one per step of a
    continuous path), all the path's pieces in one loop of blocks that stops at the
    last one. A segment whose band distance is at most the radius has its exact
    clearance; the others are farther, so when any segment is that close the minimum is
    exact, and touching cells always lie in the band. Otherwise (a path that stays away
    from every obstacle) the pieces are measured again in a band of
    :data:`CLEARANCE_WIDE_RADIUS`, the same way, where that costs less than the whole
    map; a path beyond that band too, or on a map where the whole map costs less, has
    each straight run (consecutive segments in one direction, one segment to the map)
    measured against the whole map, ``O(R H W)`` for a path of ``R`` runs. A map without
    obstacles searches nothing (``inf``).
    """
    h, w = check_grid(grid)
    obstacles = proximity_obstacles(grid, border_blocked)
    if g.cells.shape[0] == 1:
        a = b = (g.x, g.y)
    else:  # from the cells sliced first, not from sliced coordinates: decision 048
        a, b = g.ends
    segs = (a[0], a[1], b[0], b[1])
    n_seg = a[0].shape[0]
    span = jnp.maximum(jnp.abs(b[0] - a[0]), jnp.abs(b[1] - a[1]))
    # Segments after the last moving one are points at the last node (the padding), no
    # nearer than that segment: they get no piece.
    j = jnp.arange(n_seg, dtype=jnp.int32)
    used = jnp.maximum(jnp.max(jnp.where(span > 0, j + 1, 0)), 1)
    pieces = jnp.where(j < used, jnp.maximum((span + CLEARANCE_PIECE - 1) // CLEARANCE_PIECE, 1),
                       0)
    first = jnp.cumsum(pieces) - pieces  # each segment's first piece
    total = jnp.sum(pieces)

    def band(radius: int, skip: jax.Array) -> tuple[jax.Array, jax.Array]:
        """Every piece's band of ``radius`` (none where ``skip``): the least distance
        and the int32 touch flags of the segments. A block holds about as many cells at
        either radius (:data:`CLEARANCE_CHUNK` pieces of the first band)."""
        chunk = max(1, CLEARANCE_CHUNK * _band_cells(CLEARANCE_RADIUS) // _band_cells(radius))

        def block(state):
            start, near, touch = state
            t = start + jnp.arange(chunk, dtype=jnp.int32)
            seg = jnp.clip(jnp.searchsorted(first, t, side="right") - 1, 0, n_seg - 1)
            sub = tuple(v[seg] for v in segs)
            d, hit = jax.vmap(lambda *s: _piece_band_clearance(*s, obstacles, radius))(
                *sub, t - first[seg])
            valid = t < total
            return (start + chunk, jnp.minimum(near, jnp.min(jnp.where(valid, d, jnp.inf))),
                    touch.at[jnp.where(valid & hit, seg, n_seg)].set(1, mode="drop"))

        _, near, touch = jax.lax.while_loop(
            lambda s: s[0] < jnp.where(skip, 0, total), block,
            # int32 flags, not bool: no bool table updated in a loop (docs/devices.md)
            (jnp.int32(0), jnp.asarray(jnp.inf, F32), jnp.zeros((n_seg,), jnp.int32)))
        return near, touch

    # The path's straight runs: consecutive moving segments in one direction lie on one
    # line, so they are one segment to the map (an 8-connected path's hundreds of steps
    # are a few dozen runs); zero-length segments inside a run change nothing.
    if g.cells.shape[0] == 1:
        starts, n_runs = jnp.zeros((1,), jnp.int32), jnp.int32(1)
    else:
        first_move = g.moving & (jnp.cumsum(g.moving.astype(jnp.int32)) == 1)
        begins = g.moving & (g.turning | first_move) & (j < used)
        starts = jnp.nonzero(begins, size=n_seg, fill_value=0)[0].astype(jnp.int32)
        n_runs = jnp.maximum(jnp.sum(begins, dtype=jnp.int32), 1)

    near, touch = band(CLEARANCE_RADIUS, jnp.bool_(False))
    none = ~jnp.any(obstacles)  # a map without obstacles: inf, with nothing to search
    first_exact = (near <= CLEARANCE_RADIUS) | none
    # A path that stays beyond the first band (an open hall): the wider band, whose
    # loop runs only for such a path (under vmap: while any path needs it), and only
    # where it costs less than the whole map (a small map). Each cell's distance is the
    # segment's and the cell's alone (:func:`_box_clearance`), so the value is the one
    # the whole map gives wherever it is at most the wider radius.
    r2 = CLEARANCE_WIDE_RADIUS
    skip_wide = first_exact | (total.astype(F32) * _band_cells(r2)
                               >= n_runs.astype(F32) * float(h * w))
    wide, _ = band(r2, skip_wide)
    near = jnp.minimum(near, wide)
    exact = first_exact | (~skip_wide & (near <= r2))

    def whole_map(state: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        # masking the segments and the map with the carried flag (False in the body) makes
        # all of the body depend on the loop state, so that XLA cannot hoist any of it out
        # of the loop (it would then run on every call)
        done = state[1]
        blocked = obstacles & ~done
        xs, ys = jnp.where(done, 0, g.x), jnp.where(done, 0, g.y)

        def run(r, near):  # one straight run of the path: a segment between two nodes
            a, b = starts[r], jnp.where(r + 1 < n_runs, starts[r + 1], used)
            d, _ = _segment_box_clearance(xs[a], ys[a], xs[b], ys[b], blocked)
            return jnp.minimum(near, d)

        near = jax.lax.fori_loop(0, n_runs, run, jnp.asarray(jnp.inf, F32))
        return near.astype(F32), jnp.bool_(True)

    # Runs its body only if this path (under vmap: any path) is not measured yet.
    near, _ = jax.lax.while_loop(lambda s: ~s[1], whole_map, (near.astype(F32), exact))
    return near, touch != 0


def min_clearance_of(grid: Grid, g: Geometry, border_blocked: bool) -> jax.Array:
    h, w = grid.blocked.shape
    result, _ = clearance_band(grid, g, border_blocked)  # padding segments: harmless points
    if border_blocked:
        xf, yf = g.x.astype(F32), g.y.astype(F32)
        edge = jnp.minimum(jnp.minimum(xf, (w - 1) - xf), jnp.minimum(yf, (h - 1) - yf)) + 0.5
        result = jnp.minimum(result, jnp.min(edge))
    return result


def tangencies_of(grid: Grid, g: Geometry) -> jax.Array:
    _, touch = clearance_band(grid, g)
    if g.cells.shape[0] == 1:
        return jnp.int32(0)
    return jnp.sum(touch & g.moving, dtype=jnp.int32)


def min_clearance(
    grid: Grid, cells: jax.Array, length: jax.Array, *, border_blocked: bool = False
) -> jax.Array:
    """Smallest Euclidean distance from the path to a blocked cell, float32 (a metric).

    The path is the polyline through the cell centres; a blocked cell is its closed unit
    square. So a path running along a wall has clearance 0.5, a diagonal step past an
    obstacle's corner (or a squeeze between two diagonal obstacles) has clearance 0, and
    a path through an obstacle has 0. ``inf`` when the map has no blocked cell (and
    ``border_blocked`` is False). With ``border_blocked`` (static) the map's outer
    boundary counts as an obstacle too.

    Cost: a band of cells around each segment (:func:`clearance_band`), ``O(L * H * W)``
    (every segment against every cell) only when no segment comes within
    :data:`CLEARANCE_RADIUS` of an obstacle: for reports on a few paths, not for fitness.
    """
    return min_clearance_of(grid, geometry(grid, cells, length), border_blocked)


def tangencies(grid: Grid, cells: jax.Array, length: jax.Array) -> jax.Array:
    """Number of path segments that touch a blocked cell (clearance 0), int32 (a metric).

    IMGA Table 3 "number of tangency": a segment passing an obstacle's corner or edge
    (or, for an infeasible path, crossing an obstacle) counts once however many cells it
    touches. Zero-length (padding, repeated-node) segments are not counted. Cost: a band
    of cells around each segment (:func:`clearance_band`).
    """
    return tangencies_of(grid, geometry(grid, cells, length))
