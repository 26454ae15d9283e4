"""Tests of jaxga.reference.optima: exact 8-connected and any-angle optima, exact line of sight.

Independent checks used here: a brute-force any-angle optimum (scipy Dijkstra over the
complete visibility graph of all free cells, edges from the scalar walk ``clear_np``),
scipy Dijkstra on the legal-move graph, dense sampling of segments, the published
optimal lengths of the classic 20 x 20 maps (benchmarks/classic/README.md) and of
Moving AI scenarios.
"""

from __future__ import annotations

import math
import time
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from jaxga.core.errors import EndpointError, JaxgaError, NoPathError
from jaxga.core.grid import CORNER_RULES, DIRECTIONS, Grid
from jaxga.reference.any_angle import (
    any_angle_shortest_path,
    any_angle_shortest_path_np,
    obstacle_adjacent_cells,
)
from jaxga.reference.optima import (
    OctileGraph,
    ReferencePath,
    clear_many_np,
    clear_np,
    clear_pairs_np,
    distances_from,
    legal_moves_np,
    path_length,
    require,
    shortest_path,
    shortest_path_np,
)

DATA = Path(__file__).parents[1] / "data"
SQ2 = math.sqrt(2.0)

# ------------------------------------------------------------------------------ helpers


def load_01(path: Path) -> np.ndarray:
    """0/1 text map, file line 1 = row y = 0 (benchmarks/classic convention)."""
    return np.loadtxt(path, dtype=int).astype(bool)


def load_movingai(path: Path) -> np.ndarray:
    """Moving AI .map -> bool[H, W] with row 0 at the BOTTOM."""
    lines = path.read_text().splitlines()
    h = int(lines[1].split()[1])
    w = int(lines[2].split()[1])
    rows = lines[4 : 4 + h]
    return np.array([[c not in ".GS" for c in r[:w]] for r in rows], bool)[::-1].copy()


def load_scen(path: Path, h: int) -> list[tuple[tuple[int, int], tuple[int, int], float]]:
    """(start, goal, optimal length) with y converted to row-0-at-bottom."""
    out = []
    for line in path.read_text().splitlines()[1:]:
        f = line.split("\t")
        if len(f) >= 9:
            sx, sy, gx, gy = (int(v) for v in f[4:8])
            out.append(((sx, h - 1 - sy), (gx, h - 1 - gy), float(f[8])))
    return out


def move_ok(b: np.ndarray, rule: str, a, c) -> bool:
    """Independent statement of the move rule (decision 027)."""
    h, w = b.shape
    (ax, ay), (cx, cy) = a, c
    if not (0 <= ax < w and 0 <= ay < h and 0 <= cx < w and 0 <= cy < h):
        return False
    if max(abs(cx - ax), abs(cy - ay)) != 1 or b[ay, ax] or b[cy, cx]:
        return False
    if ax != cx and ay != cy:
        s1, s2 = bool(b[ay, cx]), bool(b[cy, ax])
        if rule == "no_squeeze":
            return not (s1 and s2)
        if rule == "strict":
            return not (s1 or s2)
    return True


def brute_any_angle(b: np.ndarray, rule: str, s, g) -> float:
    """Dijkstra over the complete visibility graph of all free cells (scalar clear_np)."""
    h, w = b.shape
    cells = [(x, y) for y in range(h) for x in range(w) if not b[y, x]]
    index = {c: i for i, c in enumerate(cells)}
    n = len(cells)
    rows, cols, vals = [], [], []
    for i in range(n):
        for j in range(i + 1, n):
            if clear_np(b, rule, cells[i], cells[j]):
                d = math.dist(cells[i], cells[j])
                rows += [i, j]
                cols += [j, i]
                vals += [d, d]
    m = coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    return float(dijkstra(m, indices=index[tuple(s)])[index[tuple(g)]])


def brute_any_angle_vectorised(b: np.ndarray, rule: str, s, g) -> float:
    """Same as brute_any_angle with clear_pairs_np (for 20 x 20 and 32 x 32 maps)."""
    fy, fx = np.nonzero(~b)
    xy = np.stack([fx, fy], 1)
    i, j = np.triu_indices(len(xy), 1)
    ok = clear_pairs_np(b, rule, xy[i], xy[j])
    i, j = i[ok], j[ok]
    d = np.hypot(*(xy[i] - xy[j]).T)
    n = len(xy)
    m = coo_matrix((np.r_[d, d], (np.r_[i, j], np.r_[j, i])), shape=(n, n)).tocsr()
    k = {tuple(c): t for t, c in enumerate(xy.tolist())}
    return float(dijkstra(m, indices=k[tuple(s)])[k[tuple(g)]])


def octile_graph_scipy(b: np.ndarray, rule: str):
    h, w = b.shape
    legal = legal_moves_np(b, rule).reshape(8, -1)
    src, dst, cost = [], [], []
    for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
        p = np.flatnonzero(legal[d])
        src.append(p)
        dst.append(p + dy * w + dx)
        cost.append(np.full(p.size, SQ2 if dx and dy else 1.0))
    return coo_matrix(
        (np.concatenate(cost), (np.concatenate(src), np.concatenate(dst))), shape=(h * w, h * w)
    ).tocsr()


def passes_vertex(a, c) -> bool:
    """Whether the segment between centres a and c passes exactly through a grid vertex."""
    (x0, y0), (x1, y1) = a, c
    dx, dy = x1 - x0, y1 - y0
    if dx == 0 or dy == 0:
        return False
    for k in range(min(x0, x1), max(x0, x1)):
        t = Fraction(2 * (k - x0) + 1, 2 * dx)  # crossing of the line x = k + 1/2
        y = y0 + dy * t
        if (y - Fraction(1, 2)).denominator == 1:
            return True
    return False


def sampled_clear(b: np.ndarray, a, c, n: int = 4001) -> bool:
    """Dense sampling: every sample point's cell must be free."""
    t = (np.arange(n) + 0.5) / n
    x = a[0] + (c[0] - a[0]) * t
    y = a[1] + (c[1] - a[1]) * t
    cx = np.floor(x + 0.5).astype(int)
    cy = np.floor(y + 0.5).astype(int)
    return not b[cy, cx].any() and not b[a[1], a[0]] and not b[c[1], c[0]]


# --------------------------------------------------------------------------- strategies


@st.composite
def grids(draw, max_side: int = 8, free_ends: bool = True):
    h = draw(st.integers(1, max_side))
    w = draw(st.integers(1, max_side))
    level = draw(st.integers(0, 4))  # density level/8
    vals = draw(st.lists(st.integers(0, 7), min_size=h * w, max_size=h * w))
    b = np.array(vals).reshape(h, w) < level
    s = (draw(st.integers(0, w - 1)), draw(st.integers(0, h - 1)))
    g = (draw(st.integers(0, w - 1)), draw(st.integers(0, h - 1)))
    if free_ends:
        b[s[1], s[0]] = False
        b[g[1], g[0]] = False
    rule = draw(st.sampled_from(CORNER_RULES))
    return b, s, g, rule


# ------------------------------------------------------------------------ classic table

CLASSIC = {  # benchmarks/classic/README.md: free, no_squeeze, strict
    "aco_classic_20x20_v1_lihongxin.txt": (34.3848, 34.3848, 37.8995),
    "acoga_skolayat_G_20x20.txt": (29.7990, 31.5563, 32.1421),
    "classic_ga_gapp3_20x20.txt": (30.9706, 30.9706, 31.5563),
    "fealpy_grid0_20x20.txt": (29.2132, 30.3848, 33.8995),
    "routeplanning_yangbo_20x20.txt": (30.3848, 30.3848, 32.7279),
    "routeplanning_zhangzheng_paper_20x20.txt": (28.6274, 28.6274, 31.5563),
}
# any-angle optima (cell-centre vertices); test_classic_table re-derives each by brute force
CLASSIC_ANY_ANGLE = {
    "aco_classic_20x20_v1_lihongxin.txt": (34.0285, 34.0285, 36.8518),
    "acoga_skolayat_G_20x20.txt": (28.1905, 29.8482, 30.5424),
    "classic_ga_gapp3_20x20.txt": (29.6065, 29.6065, 30.6828),
    "fealpy_grid0_20x20.txt": (28.3623, 29.2727, 30.1304),
    "routeplanning_yangbo_20x20.txt": (29.5760, 29.5760, 30.5111),
    "routeplanning_zhangzheng_paper_20x20.txt": (27.5155, 27.5155, 29.0661),
}


@pytest.mark.parametrize("name", sorted(CLASSIC))
@pytest.mark.parametrize("k,rule", list(enumerate(CORNER_RULES)))
def test_classic_table(name: str, k: int, rule: str) -> None:
    b = load_01(DATA / "classic" / name)
    assert b.shape == (20, 20)
    grid = Grid.create(b, (0, 0), (19, 19), rule)
    res = shortest_path(grid)
    assert res.found and res.reason == "" and res.kind == "octile"
    assert res.length == pytest.approx(CLASSIC[name][k], abs=5e-5)
    assert path_length(res.path) == pytest.approx(res.length, abs=1e-9)
    assert all(move_ok(b, rule, p, q) for p, q in zip(res.path[:-1], res.path[1:], strict=True))
    aa = any_angle_shortest_path(grid)
    assert aa.found and aa.kind == "any_angle"
    assert aa.length == pytest.approx(CLASSIC_ANY_ANGLE[name][k], abs=5e-5)
    # the tabled values re-derived: the brute force over every pair of cell centres
    assert aa.length == pytest.approx(brute_any_angle_vectorised(b, rule, (0, 0), (19, 19)),
                                      abs=1e-5)
    assert math.dist((0, 0), (19, 19)) - 1e-9 <= aa.length <= res.length + 1e-9
    assert all(clear_np(b, rule, p, q) for p, q in zip(aa.path[:-1], aa.path[1:], strict=True))


@pytest.mark.parametrize(
    "name,rule",
    [
        ("classic_ga_gapp3_20x20.txt", "free"),
        ("routeplanning_zhangzheng_paper_20x20.txt", "strict"),
        ("aco_classic_20x20_v1_lihongxin.txt", "strict"),
    ],
)
def test_classic_any_angle_is_brute_force_and_beats_obstacle_adjacent_vertices(name, rule):
    """On these maps the 'cells next to obstacles' vertex set misses the optimum."""
    b = load_01(DATA / "classic" / name)
    exact = any_angle_shortest_path_np(b, (0, 0), (19, 19), rule)
    assert exact.length == pytest.approx(
        brute_any_angle_vectorised(b, rule, (0, 0), (19, 19)), abs=1e-9
    )
    restricted = any_angle_shortest_path_np(
        b, (0, 0), (19, 19), rule, vertices=obstacle_adjacent_cells(b)
    )
    assert restricted.found and restricted.length > exact.length + 0.05


def test_bend_far_from_the_only_obstacle() -> None:
    """The docstring's counterexample: the optimal lattice bend is 6-7 cells from the
    only obstacle, so no obstacle-neighbourhood vertex set is exact."""
    b = np.zeros((4, 22), bool)
    b[1, 16] = True
    s, g = (0, 0), (21, 2)
    expect = {"free": (21.09524, (10, 1)), "no_squeeze": (21.09524, (10, 1))}
    expect["strict"] = (21.09698, (9, 1))
    for rule, (length, bend) in expect.items():
        res = any_angle_shortest_path_np(b, s, g, rule)
        assert res.length == pytest.approx(length, abs=1e-5)
        assert res.length == pytest.approx(brute_any_angle(b, rule, s, g), abs=1e-9)
        assert [tuple(p) for p in res.path.tolist()] == [s, bend, g]
        restricted = any_angle_shortest_path_np(b, s, g, rule, vertices=obstacle_adjacent_cells(b))
        assert restricted.length == pytest.approx(21.11724, abs=1e-5)


# ----------------------------------------------------------------------------- Moving AI


@pytest.mark.parametrize("name", ["random-32-32-20", "room-32-32-4"])
def test_movingai_scenarios_strict(name: str) -> None:
    b = load_movingai(DATA / "movingai" / f"{name}.map")
    scens = load_scen(DATA / "movingai" / f"{name}-random-1.scen", b.shape[0])
    assert len(scens) > 300
    graph = OctileGraph(b, "strict")
    for s, g, opt in scens:  # every scenario of the file
        res = graph.search(s, g)
        assert res.found and abs(res.length - opt) <= 1e-3, (s, g, res.length, opt)
    # a sample through the public Grid API, with the path checked
    for s, g, opt in scens[::60]:
        res = shortest_path(Grid.create(b, s, g, "strict"))
        assert abs(res.length - opt) <= 1e-3
        assert tuple(res.path[0]) == s and tuple(res.path[-1]) == g
        assert all(move_ok(b, "strict", p, q) for p, q in zip(res.path[:-1], res.path[1:]))


def test_movingai_any_angle_matches_brute_force() -> None:
    b = load_movingai(DATA / "movingai" / "room-32-32-4.map")
    scens = load_scen(DATA / "movingai" / "room-32-32-4-random-1.scen", b.shape[0])
    s, g, opt = max(scens, key=lambda t: t[2])
    res = any_angle_shortest_path_np(b, s, g, "strict")
    assert res.length == pytest.approx(brute_any_angle_vectorised(b, "strict", s, g), abs=1e-9)
    assert math.dist(s, g) <= res.length <= opt + 1e-6


# -------------------------------------------------------------------- property tests


@settings(max_examples=150)
@given(grids(max_side=8))
def test_any_angle_equals_brute_force(case) -> None:
    b, s, g, rule = case
    res = any_angle_shortest_path_np(b, s, g, rule)
    ref = brute_any_angle(b, rule, s, g)
    if math.isinf(ref):
        assert not res.found and res.status == "unreachable" and "unreachable" in res.reason
    else:
        assert res.found and res.length == pytest.approx(ref, abs=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_any_angle_equals_brute_force_random_10x10(seed: int) -> None:
    """Larger random grids than hypothesis tends to draw: 60 per seed, up to 10 x 10."""
    rng = np.random.default_rng(seed)
    for trial in range(60):
        h, w = rng.integers(4, 11, 2)
        b = rng.random((h, w)) < rng.uniform(0.1, 0.5)
        free = np.argwhere(~b)
        if len(free) < 2:
            continue
        s, g = (tuple(int(v) for v in free[rng.integers(len(free))][::-1]) for _ in range(2))
        rule = CORNER_RULES[trial % 3]
        res = any_angle_shortest_path_np(b, s, g, rule)
        ref = brute_any_angle(b, rule, s, g)
        assert res.found == math.isfinite(ref)
        if res.found:
            assert res.length == pytest.approx(ref, abs=1e-9), (seed, trial)


@settings(max_examples=100)
@given(grids(max_side=8))
def test_path_properties(case) -> None:
    b, s, g, rule = case
    grid = Grid.create(b, s, g, rule)
    octile = shortest_path(grid)
    aa = any_angle_shortest_path(grid)
    fast = any_angle_shortest_path(grid, exact=False)
    assert octile.found == aa.found == fast.found
    if not octile.found:
        for r in (octile, aa, fast):
            assert r.status == "unreachable" and f"corner rule {rule!r}" in r.reason
            assert r.path.shape == (0, 2) and math.isinf(r.length)
        with pytest.raises(NoPathError):
            require(octile)
        with pytest.raises(NoPathError):
            aa.raise_if_missing()
        return
    assert math.dist(s, g) - 1e-9 <= aa.length <= fast.length + 1e-9
    assert fast.length <= octile.length + 1e-9
    for r in (octile, aa, fast):
        assert r.path.dtype == np.int32 and r.path.shape[1] == 2
        assert tuple(r.path[0]) == s and tuple(r.path[-1]) == g
        assert path_length(r.path) == pytest.approx(r.length, abs=1e-9)
        assert require(r) is r
    pairs = list(zip(octile.path[:-1].tolist(), octile.path[1:].tolist(), strict=True))
    assert all(move_ok(b, rule, p, q) for p, q in pairs)
    for r in (aa, fast):
        pairs = list(zip(r.path[:-1].tolist(), r.path[1:].tolist(), strict=True))
        assert all(clear_np(b, rule, p, q) for p, q in pairs)
    # the octile length is the Dijkstra distance (scipy) and the distance field
    d = dijkstra(octile_graph_scipy(b, rule), indices=s[1] * b.shape[1] + s[0])
    assert octile.length == pytest.approx(d[g[1] * b.shape[1] + g[0]], abs=1e-9)
    field = distances_from(grid)
    finite = np.isfinite(d)
    assert np.array_equal(np.isfinite(field.reshape(-1)), finite)
    assert np.allclose(field.reshape(-1)[finite], d[finite], atol=1e-9)
    assert distances_from(grid, g)[s[1], s[0]] == pytest.approx(octile.length, abs=1e-9)


@settings(max_examples=60)
@given(grids(max_side=6, free_ends=False))
def test_blocked_endpoints_are_results_not_exceptions(case) -> None:
    b, s, g, rule = case
    b[s[1], s[0]] = True
    grid = Grid.create(b, s, g, rule)
    for res in (shortest_path(grid), any_angle_shortest_path(grid)):
        assert not res.found and res.status == "endpoint_blocked"
        assert res.reason == f"start cell ({s[0]}, {s[1]}) is blocked"
        assert math.isinf(res.length) and res.path.shape == (0, 2)
        with pytest.raises(EndpointError, match="is blocked"):
            res.raise_if_missing()
    with pytest.raises(EndpointError):
        distances_from(grid)


def test_unreachable_goal_and_off_map() -> None:
    b = np.zeros((5, 5), bool)
    b[1, 0] = b[0, 1] = True  # (0, 0) leaves only diagonally, between two obstacles
    for rule, reachable in (("free", True), ("no_squeeze", False), ("strict", False)):
        res = shortest_path(Grid.create(b, (0, 0), (4, 4), rule))
        assert res.found is reachable
        if not reachable:
            assert (
                res.reason
                == f"goal cell (4, 4) unreachable from start cell (0, 0) under corner rule "
                   f"{rule!r}"
            )
            assert not any_angle_shortest_path(Grid.create(b, (0, 0), (4, 4), rule)).found
    off = shortest_path_np(b, (0, 0), (5, 0), "strict")
    assert not off.found and off.status == "endpoint_blocked" and "off the 5 x 5 map" in off.reason
    one = shortest_path(Grid.create(np.zeros((1, 1), bool), (0, 0), (0, 0)))
    assert one.found and one.length == 0.0 and one.path.tolist() == [[0, 0]]
    assert isinstance(one, ReferencePath)


# ---------------------------------------------------------------------- line of sight


@settings(max_examples=80)
@given(grids(max_side=9, free_ends=False))
def test_clear_forms_agree_and_are_symmetric(case) -> None:
    b, a, _, rule = case
    h, w = b.shape
    targets = np.array([(x, y) for y in range(-1, h + 1) for x in range(-1, w + 1)])
    many = clear_many_np(b, rule, a, targets)
    pairs = clear_pairs_np(b, rule, np.broadcast_to(np.array(a), targets.shape), targets)
    scalar = np.array([clear_np(b, rule, a, t) for t in targets])
    back = np.array([clear_np(b, rule, t, a) for t in targets])
    assert np.array_equal(many, scalar)
    assert np.array_equal(pairs, scalar)
    assert np.array_equal(back, scalar)


@settings(max_examples=60)
@given(grids(max_side=8, free_ends=False))
def test_clear_on_adjacent_pairs_is_the_move_rule(case) -> None:
    b, _, _, rule = case
    h, w = b.shape
    legal = legal_moves_np(b, rule)
    for y in range(h):
        for x in range(w):
            for d, (dx, dy) in enumerate(DIRECTIONS.tolist()):
                want = move_ok(b, rule, (x, y), (x + dx, y + dy))
                assert clear_np(b, rule, (x, y), (x + dx, y + dy)) == want
                assert bool(legal[d, y, x]) == want


@settings(max_examples=60)
@given(grids(max_side=9, free_ends=False))
def test_clear_matches_dense_sampling_off_vertices(case) -> None:
    b, a, _, rule = case
    h, w = b.shape
    for y in range(h):
        for x in range(w):
            if passes_vertex(a, (x, y)):
                continue
            assert clear_np(b, rule, a, (x, y)) == sampled_clear(b, a, (x, y)), (a, (x, y))


def test_clear_vertex_cases() -> None:
    """Hand cases: interiors, and vertices between diagonal obstacles."""
    b = np.zeros((3, 3), bool)
    b[1, 1] = True
    assert not clear_np(b, "free", (0, 2), (2, 0))  # through the centre of (1, 1)
    assert clear_np(b, "free", (0, 0), (2, 0)) and clear_np(b, "strict", (0, 2), (2, 2))
    c = np.zeros((2, 2), bool)
    c[0, 1] = c[1, 0] = True  # the side cells of (0, 0) -> (1, 1)
    assert clear_np(c, "free", (0, 0), (1, 1))
    assert not clear_np(c, "no_squeeze", (0, 0), (1, 1))
    assert not clear_np(c, "strict", (0, 0), (1, 1))
    c[1, 0] = False
    assert clear_np(c, "no_squeeze", (0, 0), (1, 1))
    assert not clear_np(c, "strict", (0, 0), (1, 1))
    # (0, 0) -> (3, 1) crosses (0, 0), (1, 0), (2, 1), (3, 1) and the vertex (1.5, 0.5)
    d = np.zeros((2, 4), bool)
    d[0, 2] = True  # side cell (2, 0)
    assert clear_np(d, "free", (0, 0), (3, 1)) and clear_np(d, "no_squeeze", (0, 0), (3, 1))
    assert not clear_np(d, "strict", (0, 0), (3, 1))
    d[1, 1] = True  # the other side cell (1, 1)
    assert not clear_np(d, "no_squeeze", (0, 0), (3, 1))
    assert clear_np(d, "free", (0, 0), (3, 1))


# ------------------------------------------------------------------------ time budgets


def staggered_walls() -> np.ndarray:
    """400 x 400 cells, walls at every 20th column open at alternate ends: a long, winding
    optimum (the 8-connected one alone expands most of the map)."""
    b = np.zeros((400, 400), bool)
    for k, x in enumerate(range(20, 400, 20)):
        if k % 2:
            b[40:, x : x + 2] = True
        else:
            b[:-40, x : x + 2] = True
    return b


def test_budget_returns_promptly() -> None:
    b = staggered_walls()
    for budget in (0.0, 0.05, 0.3):
        t0 = time.perf_counter()
        res = any_angle_shortest_path_np(b, (0, 0), (399, 399), "strict", budget_s=budget)
        elapsed = time.perf_counter() - t0
        assert not res.found and res.status == "budget" and res.kind == "any_angle"
        assert res.reason == f"any-angle optimum not computed (budget {budget:g} s)"
        assert res.path.shape == (0, 2) and math.isinf(res.length)
        # Without a budget this search runs for minutes; the slack only absorbs the
        # preprocessing before the first deadline check on a loaded 2-core machine.
        assert elapsed < budget + 3.0, (budget, elapsed)
    with pytest.raises(JaxgaError, match="budget"):
        res.raise_if_missing()
    octile = OctileGraph(b, "strict").search((0, 0), (399, 399), budget_s=0.0)
    assert not octile.found and octile.status == "budget"


def test_generous_budget_and_known_path_change_nothing() -> None:
    rng = np.random.default_rng(5)
    b = rng.random((24, 24)) < 0.2
    s, g = (0, 0), (23, 23)
    b[0, 0] = b[23, 23] = False
    for rule in CORNER_RULES:
        free = any_angle_shortest_path_np(b, s, g, rule)
        assert free.found
        timed = any_angle_shortest_path_np(b, s, g, rule, budget_s=60.0)
        assert timed.found and timed.length == free.length
        assert any_angle_shortest_path(Grid.create(b, s, g, rule), budget_s=60.0).found
        octile = shortest_path_np(b, s, g, rule)
        given = any_angle_shortest_path_np(b, s, g, rule, known_path=octile.path)
        assert given.length == pytest.approx(free.length, abs=1e-9)
        best = any_angle_shortest_path_np(b, s, g, rule, known_path=free.path)
        assert best.length == pytest.approx(free.length, abs=1e-9)
        assert best.length == pytest.approx(brute_any_angle_vectorised(b, rule, s, g), abs=1e-9)
    wall = tuple(int(v) for v in np.argwhere(b)[0][::-1])
    with pytest.raises(JaxgaError, match="not clear"):
        any_angle_shortest_path_np(b, s, g, "strict", known_path=[s, wall, g])
    with pytest.raises(JaxgaError, match="from"):
        any_angle_shortest_path_np(b, s, g, "strict", known_path=[s, (1, 1)])
