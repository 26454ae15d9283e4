"""Tests of jaxga.reference.lower_bound: the taut-string lower bound of the any-angle optimum.

Independent checks used here: a brute-force continuous shortest path (scipy Dijkstra over
the complete graph of ALL grid vertices plus the two centres, every edge decided by an
exact rational-arithmetic test written here from the definition), the brute-force
any-angle optimum of tests/reference/test_reference.py (every pair of free cell centres), and
lengths computed by hand.
"""

from __future__ import annotations

import math
import time
from fractions import Fraction

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from jaxga.core.errors import JaxgaError
from jaxga.core.grid import CORNER_RULES, Grid
from jaxga.reference.any_angle import any_angle_shortest_path_np
from jaxga.reference.lower_bound import (
    GeodesicBounds,
    euclidean_lower_bound,
    euclidean_lower_bound_np,
    free_space,
    segments_free_np,
)
from jaxga.reference.optima import clear_np, path_length, shortest_path_np
from tests.reference.test_reference import brute_any_angle_vectorised

SQ2 = math.sqrt(2.0)

# ------------------------------------------------------------------------------ helpers


def random_map(rng: np.random.Generator, lo: int, hi: int) -> np.ndarray:
    """Random cells or random rectangles, ``lo..hi`` cells a side."""
    h, w = (int(v) for v in rng.integers(lo, hi + 1, 2))
    if rng.random() < 0.5:
        return rng.random((h, w)) < rng.uniform(0.05, 0.45)
    b = np.zeros((h, w), bool)
    for _ in range(rng.integers(1, 6)):
        x0, y0 = rng.integers(0, w), rng.integers(0, h)
        dx, dy = rng.integers(1, max(2, w // 2)), rng.integers(1, max(2, h // 2))
        b[y0 : y0 + dy, x0 : x0 + dx] = True
    return b


def two_free_cells(rng: np.random.Generator, b: np.ndarray):
    free = np.argwhere(~b)
    if len(free) < 2:
        return None
    i, j = rng.integers(len(free), size=2)
    return (int(free[i][1]), int(free[i][0])), (int(free[j][1]), int(free[j][0]))


def is_pinch(b: np.ndarray, vx: int, vy: int) -> bool:
    """Grid vertex (vx, vy) (continuous coordinates) with exactly its two diagonal cells
    blocked (off the map counts as blocked)."""
    h, w = b.shape

    def blk(x: int, y: int) -> bool:
        return not (0 <= x < w and 0 <= y < h) or bool(b[y, x])

    sw, se, nw, ne = blk(vx - 1, vy - 1), blk(vx, vy - 1), blk(vx - 1, vy), blk(vx, vy)
    return sw + se + nw + ne == 2 and sw == ne


def exact_free_segment(b: np.ndarray, rule: str, p, q) -> bool:
    """Whether the segment p -> q (Fractions, continuous coordinates: cell (x, y) is
    [x, x+1] x [y, y+1]) lies in the union of the closed free cells and, unless the rule
    is "free", passes no pinch vertex in its interior. Splits the segment at every grid
    line it meets and checks each piece's midpoint."""
    h, w = b.shape

    def free_cell(x: int, y: int) -> bool:
        return 0 <= x < w and 0 <= y < h and not b[y, x]

    (px, py), (qx, qy) = p, q
    ts = {Fraction(0), Fraction(1)}
    for a0, a1, n in ((px, qx, w), (py, qy, h)):
        if a1 != a0:
            ts |= {(k - a0) / (a1 - a0) for k in range(n + 1) if 0 < (k - a0) / (a1 - a0) < 1}
    ts = sorted(ts)
    for t0, t1 in zip(ts, ts[1:]):
        tm = (t0 + t1) / 2
        x, y = px + (qx - px) * tm, py + (qy - py) * tm
        xs = [int(x) - 1, int(x)] if x.denominator == 1 else [math.floor(x)]
        ys = [int(y) - 1, int(y)] if y.denominator == 1 else [math.floor(y)]
        if not any(free_cell(cx, cy) for cx in xs for cy in ys):
            return False
    if rule != "free":
        for t in ts[1:-1]:
            x, y = px + (qx - px) * t, py + (qy - py) * t
            if x.denominator == 1 and y.denominator == 1 and is_pinch(b, int(x), int(y)):
                return False
    return True


def brute_taut(b: np.ndarray, rule: str, cells, sources) -> np.ndarray:
    """Continuous shortest distances from ``cells[i]`` for ``i`` in ``sources`` to every
    cell of ``cells`` (centre to centre): Dijkstra over the complete graph of those
    centres and every grid vertex (a vertex a path may not cross, a pinch under
    "no_squeeze"/"strict", is no node), edges by :func:`exact_free_segment`."""
    h, w = b.shape
    nodes = [(Fraction(2 * x + 1, 2), Fraction(2 * y + 1, 2)) for x, y in cells]
    nodes += [(Fraction(x), Fraction(y)) for y in range(h + 1) for x in range(w + 1)
              if rule == "free" or not is_pinch(b, x, y)]
    rows, cols, vals = [], [], []
    for i in range(len(nodes)):
        for j in range(i + 1, len(nodes)):
            if exact_free_segment(b, rule, nodes[i], nodes[j]):
                d = math.dist([float(v) for v in nodes[i]], [float(v) for v in nodes[j]])
                rows += [i, j]
                cols += [j, i]
                vals += [d, d]
    m = coo_matrix((vals, (rows, cols)), shape=(len(nodes), len(nodes))).tocsr()
    return dijkstra(m, indices=list(sources))[:, : len(cells)]


# ------------------------------------------------------------------- the bound is sound


@pytest.mark.parametrize("seed", range(3))
def test_bound_below_the_exact_any_angle_optimum(seed: int) -> None:
    """Several hundred random grids (random cells and rectangles, all three rules): the
    bound never exceeds the brute-force lattice optimum, is at least the straight-line
    distance, and both exist together."""
    rng = np.random.default_rng(100 + seed)
    tight = 0
    for trial in range(150):
        b = random_map(rng, 3, 12)
        ends = two_free_cells(rng, b)
        if ends is None:
            continue
        s, g = ends
        rule = CORNER_RULES[trial % 3]
        ref = brute_any_angle_vectorised(b, rule, s, g)
        res = euclidean_lower_bound_np(b, s, g, rule)
        assert res.found == math.isfinite(ref), (seed, trial)
        if not res.found:
            assert res.status == "unreachable"
            continue
        assert res.kind == "euclidean_bound"
        assert math.dist(s, g) - 1e-9 <= res.length <= ref + 1e-9, (seed, trial, rule)
        tight += res.length > ref - 1e-9
        # the returned polyline: its length, its ends, its bends on grid vertices
        assert path_length(res.path) == pytest.approx(res.length, abs=1e-9)
        assert tuple(res.path[0]) == s and tuple(res.path[-1]) == g
        assert np.all(res.path[1:-1] % 1 == 0.5)
    assert tight > 20  # often equal (straight or lattice-aligned optima): not vacuous


@pytest.mark.parametrize("seed", range(2))
def test_bound_is_the_continuous_shortest_path(seed: int) -> None:
    """Equal to an independent brute force over all grid vertices (exact rational
    visibility), so corner classification, pinches and tangent pruning lose nothing."""
    rng = np.random.default_rng(200 + seed)
    done = 0
    for trial in range(45):
        b = random_map(rng, 2, 5)
        ends = two_free_cells(rng, b)
        if ends is None:
            continue
        s, g = ends
        rule = CORNER_RULES[trial % 3]
        ref = float(brute_taut(b, rule, [s, g], [0])[0, 1])
        res = euclidean_lower_bound_np(b, s, g, rule, upper=1e6)
        if math.isinf(ref):
            assert not res.found
            continue
        assert res.found and res.length == pytest.approx(ref, abs=1e-9), (seed, trial, rule)
        done += 1
    assert done > 25


def test_straight_line_when_the_segment_is_clear() -> None:
    rng = np.random.default_rng(7)
    seen = 0
    for trial in range(300):
        b = random_map(rng, 3, 14)
        ends = two_free_cells(rng, b)
        if ends is None:
            continue
        s, g = ends
        rule = CORNER_RULES[trial % 3]
        if not clear_np(b, rule, s, g):
            continue
        res = euclidean_lower_bound_np(b, s, g, rule)
        assert res.length == pytest.approx(math.dist(s, g), abs=1e-12)
        assert res.path.shape == ((2, 2) if s != g else (1, 2))
        seen += 1
    assert seen > 50


# ------------------------------------------------------------------------- hand values


def test_single_blocked_cell() -> None:
    """Around one cell: centre -> its two corners -> centre, 1 + 2 sqrt(2.5)."""
    b = np.zeros((3, 5), bool)
    b[1, 2] = True
    for rule in CORNER_RULES:
        res = euclidean_lower_bound_np(b, (0, 1), (4, 1), rule)
        assert res.length == pytest.approx(1 + 2 * math.sqrt(2.5), abs=1e-12)
        bends = sorted(tuple(p) for p in res.path[1:-1].tolist())
        assert bends in ([(1.5, 0.5), (2.5, 0.5)], [(1.5, 1.5), (2.5, 1.5)])
        exact = any_angle_shortest_path_np(b, (0, 1), (4, 1), rule)
        assert res.length < exact.length


def test_wall_with_one_gap() -> None:
    """A wall at x = 3 open only at (3, 3): from (0, 0) to (6, 0) the string runs
    (0, 0) -> (2.5, 2.5) -> (3.5, 2.5) -> (6, 0): 2.5 sqrt 2 + 1 + 2.5 sqrt 2."""
    b = np.zeros((7, 7), bool)
    b[:, 3] = True
    b[3, 3] = False
    for rule in CORNER_RULES:
        res = euclidean_lower_bound_np(b, (0, 0), (6, 0), rule)
        assert res.length == pytest.approx(1 + 5 * SQ2, abs=1e-12)
        assert res.path.tolist() == [[0, 0], [2.5, 2.5], [3.5, 2.5], [6, 0]]
        # straight through the gap's diagonal: the string touches both gap corners
        assert euclidean_lower_bound_np(b, (0, 0), (6, 6), rule).length == pytest.approx(
            6 * SQ2, abs=1e-12)


def test_pinch_crossable_only_under_free() -> None:
    """Cells (1, 2) and (2, 1) blocked: from (1, 1) to (2, 2) the segment passes their
    shared corner. "free" crosses it (sqrt 2); the other rules go around one cell:
    sqrt(0.5) + 1 + 1 + sqrt(0.5) = 2 + sqrt 2."""
    b = np.zeros((4, 4), bool)
    b[2, 1] = b[1, 2] = True
    assert euclidean_lower_bound_np(b, (1, 1), (2, 2), "free").length == pytest.approx(SQ2)
    for rule in ("no_squeeze", "strict"):
        res = euclidean_lower_bound_np(b, (1, 1), (2, 2), rule)
        assert res.length == pytest.approx(2 + SQ2, abs=1e-12)
        assert res.length <= any_angle_shortest_path_np(b, (1, 1), (2, 2), rule).length
    # a pinch is a bend point under "free" only: from (1, 0) to (3, 3) the string turns
    # at (1.5, 1.5), else it goes round the corner (2.5, 0.5)
    res = euclidean_lower_bound_np(b, (1, 0), (3, 3), "free")
    assert res.path.tolist() == [[1, 0], [1.5, 1.5], [3, 3]]
    assert res.length == pytest.approx(math.sqrt(2.5) + math.sqrt(4.5), abs=1e-12)
    for rule in ("no_squeeze", "strict"):
        res = euclidean_lower_bound_np(b, (1, 0), (3, 3), rule)
        assert res.path.tolist() == [[1, 0], [2.5, 0.5], [3, 3]]
        assert res.length == pytest.approx(math.sqrt(2.5) + math.sqrt(6.5), abs=1e-12)


def test_results_not_exceptions_and_grid_form() -> None:
    b = np.zeros((5, 5), bool)
    b[1, 0] = b[0, 1] = True
    res = euclidean_lower_bound_np(b, (0, 0), (4, 4), "strict")
    assert not res.found and res.status == "unreachable" and "unreachable" in res.reason
    free = euclidean_lower_bound(Grid.create(b, (0, 0), (4, 4), "free"))
    assert free.found and free.length == pytest.approx(4 * SQ2)
    b[4, 4] = True
    blocked = euclidean_lower_bound_np(b, (0, 0), (4, 4), "free")
    assert not blocked.found and blocked.status == "endpoint_blocked"
    with pytest.raises(JaxgaError):
        euclidean_lower_bound_np(b, (0, 0), (3, 3), "diagonal")


# ------------------------------------------------------------------- segment primitive


@pytest.mark.parametrize("rule", CORNER_RULES)
def test_segments_free_matches_exact_rational_check(rule: str) -> None:
    """The vectorised test (and its cheap 'ends' pre-test, a necessary condition) against
    the rational-arithmetic one on random segments between half-integer points."""
    rng = np.random.default_rng(CORNER_RULES.index(rule))
    for _ in range(40):
        b = random_map(rng, 1, 8)
        h, w = b.shape
        space = free_space(b, rule)
        p = np.stack([rng.integers(0, 2 * w + 1, 60), rng.integers(0, 2 * h + 1, 60)], 1)
        q = np.stack([rng.integers(0, 2 * w + 1, 60), rng.integers(0, 2 * h + 1, 60)], 1)
        q[:10, 1] = p[:10, 1]  # some along grid lines and rows
        q[10:20, 0] = p[10:20, 0]
        p, q = p[np.any(p != q, axis=1)], q[np.any(p != q, axis=1)]
        got = segments_free_np(space, p, q)
        want = [exact_free_segment(b, rule, (Fraction(int(a), 2), Fraction(int(c), 2)),
                                   (Fraction(int(d), 2), Fraction(int(e), 2)))
                for (a, c), (d, e) in zip(p.tolist(), q.tolist(), strict=True)]
        assert got.tolist() == want
        assert np.all(segments_free_np(space, p, q, ends=1) >= got)
        assert np.array_equal(segments_free_np(space, q, p), got)


# ------------------------------------------------------------------------ cell bounds


def test_geodesic_cell_bounds_are_taut_distances() -> None:
    """Where a path of length <= upper can pass, the per-cell bounds are the brute-force
    taut distances from the start and to the goal; elsewhere the sum exceeds upper."""
    rng = np.random.default_rng(11)
    checked = 0
    for trial in range(9):
        b = random_map(rng, 4, 6)
        ends = two_free_cells(rng, b)
        if ends is None:
            continue
        s, g = ends
        rule = CORNER_RULES[trial % 3]
        octile = shortest_path_np(b, s, g, rule)
        if not octile.found:
            continue
        upper = octile.length * 1.2 + 1  # any level: the bounds are exact below it
        geo = GeodesicBounds(b, rule, s, g, upper)
        to_start, to_goal = geo.cells(upper)
        h, w = b.shape
        cells = [(int(x), int(y)) for y, x in np.argwhere(~b)]
        ts, tg = brute_taut(b, rule, cells, [cells.index(s), cells.index(g)])
        k = np.array([y * w + x for x, y in cells])
        near = ts + tg <= upper - 1e-9
        assert np.allclose(to_start[k][near], ts[near], atol=1e-9)
        assert np.allclose(to_goal[k][near], tg[near], atol=1e-9)
        assert np.all(to_start[k][~near] + to_goal[k][~near] >= (ts + tg)[~near] - 1e-9)
        assert geo.bound == pytest.approx(tg[cells.index(s)], abs=1e-9)
        checked += near.sum()
    assert checked > 50


# ------------------------------------------------------------------------- time budget


def test_budget() -> None:
    b = np.zeros((400, 400), bool)
    b[::8, 1:-1] = True  # 50 walls
    t0 = time.perf_counter()
    bound = euclidean_lower_bound_np(b, (0, 1), (399, 397), "strict", budget_s=0.0)
    assert not bound.found and bound.status == "budget" and bound.kind == "euclidean_bound"
    assert bound.reason == ("Euclidean lower bound of the any-angle optimum not computed "
                            "(budget 0 s)")
    assert time.perf_counter() - t0 < 1.0
    small = b[:40, :40].copy()
    timed = euclidean_lower_bound_np(small, (0, 1), (39, 33), "strict", budget_s=60.0)
    assert timed.found
    assert timed.length == euclidean_lower_bound_np(small, (0, 1), (39, 33), "strict").length


@pytest.mark.parametrize("rule", CORNER_RULES)
def test_segment_tests_in_memory_bounded_batches_give_the_same_answers(rule, monkeypatch):
    """The segment tests split a call whose segments span more unit steps than
    ``SPAN_CHUNK`` into batches (a 500 x 500 map in one pass asked for tens of GB): with
    a tiny chunk, every answer is the one-pass answer."""
    import jaxga.reference.optima as optima
    from jaxga.reference.optima import clear_pairs_np, span_chunks

    rng = np.random.default_rng(3)
    blocked = rng.random((24, 30)) < 0.2
    a = rng.integers(0, [30, 24], size=(400, 2))
    b = rng.integers(0, [30, 24], size=(400, 2))
    space = free_space(blocked, rule)
    p, q = 2 * a + 1, 2 * b + 1  # doubled coordinates: cell centres
    whole = (clear_pairs_np(blocked, rule, a, b), segments_free_np(space, p, q),
             segments_free_np(space, p, q, ends=3))
    monkeypatch.setattr(optima, "SPAN_CHUNK", 37)
    assert len(span_chunks(np.abs(b - a).max(axis=1) + 1)) > 100
    batched = (clear_pairs_np(blocked, rule, a, b), segments_free_np(space, p, q),
               segments_free_np(space, p, q, ends=3))
    for one, many in zip(whole, batched):
        np.testing.assert_array_equal(one, many)
    assert 0 < whole[0].sum() < whole[0].size  # both answers occur
