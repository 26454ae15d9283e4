"""Tests of jaxga.smooth: B-spline smoothing of waypoint paths (IMGA section 6).

Every property of a smoothed curve is checked independently of the module: the curve is
re-evaluated from its control points with ``scipy.interpolate.BSpline`` 20 times more
densely than the module samples it, and its clearance is the exact distance of every
sample to every blocked unit square and to the outside of the map, in NumPy. Paths are
real reference paths (any-angle optimum and 8-connected A*) on the built-in 20 x 20 maps,
the same maps read from ``tests/data/classic`` and a Moving AI room map from
``tests/data/movingai``. Everything 20 x 20 shares one compiled population call (same
shapes: P = 2 paths of capacity 64), so the file stays fast.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.interpolate import BSpline

from jaxga import Grid, ParameterError
from jaxga.cli.run import smooth_summary
from jaxga.core.paths import from_coords
from jaxga.curve_clearance import distance_field, verify_curve
from jaxga.maps import load_map
from jaxga.maps.clearance import segments_square_distance
from jaxga.maps.frame import MapFrame
from jaxga.maps.scenarios import read_scen
from jaxga.polyline import polyline_points, turning_curvature_bound
from jaxga.reference.any_angle import any_angle_shortest_path
from jaxga.reference.optima import clear_np, shortest_path
from jaxga.smooth import (
    RESAMPLE_TOLERANCE,
    SmoothConfig,
    resample_curve,
    smooth,
    smooth_population,
)

pytestmark = pytest.mark.slow  # smoothing on real paths (programs of their own)

DATA = Path(__file__).parents[1] / "data"
CFG = SmoothConfig(steps=120)
CAP = 64
DENSE = 20 * CFG.verify_per_span  # samples per span of the independent check
LENGTH_FACTOR = 1.05  # a smoothed curve is at most 5 % longer than its polyline
BUILTIN = [
    "classic_ga_gapp3_20x20",
    "routeplanning_yangbo_20x20",
    "aco_classic_20x20_v1_lihongxin",
    "fealpy_grid0_20x20",
    "acoga_skolayat_G_20x20",
    "routeplanning_zhangzheng_paper_20x20",
]


# ----------------------------------------------------------------- independent checks
def np_clearance(blocked: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Exact distance from points to the blocked unit squares and the map's outside
    (0 for a point off the map)."""
    h, w = blocked.shape
    by, bx = np.nonzero(blocked)
    out = np.minimum.reduce(
        [pts[:, 0] + 0.5, w - 0.5 - pts[:, 0], pts[:, 1] + 0.5, h - 0.5 - pts[:, 1]]
    )
    for i in range(0, len(pts), 4096):
        p = pts[i : i + 4096]
        ex = np.maximum(np.abs(p[:, None, 0] - bx[None]) - 0.5, 0.0)
        ey = np.maximum(np.abs(p[:, None, 1] - by[None]) - 0.5, 0.0)
        if len(bx):
            out[i : i + 4096] = np.minimum(out[i : i + 4096], np.hypot(ex, ey).min(axis=1))
    return np.maximum(out, 0.0)  # 0 off the map


def np_in_blocked(blocked: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """A point is in a blocked cell when floor(x + 1/2), floor(y + 1/2) is blocked/off map."""
    h, w = blocked.shape
    cx, cy = np.floor(pts[:, 0] + 0.5).astype(int), np.floor(pts[:, 1] + 0.5).astype(int)
    on = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    return ~on | blocked[np.clip(cy, 0, h - 1), np.clip(cx, 0, w - 1)]


def np_curve(control: np.ndarray, per_span: int):
    """Points, |curvature| and parameters of the clamped cubic B-spline, via scipy."""
    control = np.asarray(control, np.float64)
    t_spans = len(control) - 3
    knots = np.r_[[0.0] * 3, np.arange(t_spans + 1), [float(t_spans)] * 3]
    spl = BSpline(knots, control, 3)
    u = np.linspace(0.0, t_spans, per_span * t_spans + 1)
    p, d1, d2 = spl(u), spl.derivative(1)(u), spl.derivative(2)(u)
    kappa = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.linalg.norm(d1, axis=1) ** 3
    return p, kappa, u


def pad_paths(paths: list[np.ndarray], width: int) -> tuple[jax.Array, jax.Array]:
    cells, lengths = zip(*(from_coords(p, width, CAP) for p in paths))
    return jnp.stack(cells), jnp.stack(lengths)


def run(grid: Grid, paths: list[np.ndarray]) -> list[dict]:
    """Smooth two paths on a 20 x 20 grid (the shared compiled call); numpy results."""
    assert grid.shape == (20, 20) and len(paths) == 2
    cells, lengths = pad_paths(paths, grid.width)
    res = jax.device_get(smooth_population(grid, cells, lengths, config=CFG))
    return [
        {"grid": grid, "path": np.asarray(p), "res": jax.tree.map(lambda v, i=i: v[i], res)}
        for i, p in enumerate(paths)
    ]


def squeeze_grid() -> Grid:
    """20 x 20 with the anti-diagonal x + y = 19 blocked: every route from (0, 0) to
    (19, 19) squeezes between two diagonally touching obstacles (legal under "free"), so
    no curve can pass with positive clearance."""
    b = np.zeros((20, 20), bool)
    for i in range(20):
        b[19 - i, i] = True
    return Grid.create(b, start=(0, 0), goal=(19, 19), corner_rule="free")


# ------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def cases() -> list[dict]:
    """Smoothed any-angle and 8-connected optimal paths on every 20 x 20 test map."""
    grids = [(n, load_map(n, corner_rule="free")) for n in BUILTIN]
    grids += [
        (f"data/{p.name}", load_map(p, corner_rule="strict"))
        for p in sorted((DATA / "classic").glob("*.txt"))[:3]
    ]
    out = []
    for name, g in grids:
        paths = [any_angle_shortest_path(g).path, shortest_path(g).path]
        for kind, c in zip(("any-angle", "8-connected"), run(g, paths)):
            out.append(c | {"name": f"{name} {kind}"})
    return out


@pytest.fixture(scope="module")
def squeeze() -> list[dict]:
    g = squeeze_grid()
    return run(g, [any_angle_shortest_path(g).path, shortest_path(g).path])


def _check_case(c: dict) -> None:
    """Every property of one smoothing result, checked independently."""
    g, path, r = c["grid"], c["path"], c["res"]
    b = g.blocked_np()
    start, goal = path[0].astype(np.float32), path[-1].astype(np.float32)
    pts = np.asarray(r.points)
    # starts at the start, ends at the goal (exactly)
    np.testing.assert_array_equal(pts[0], start)
    np.testing.assert_array_equal(pts[-1], goal)
    poly_len = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    assert float(r.polyline_length) == pytest.approx(poly_len, rel=1e-5)
    straight = float(np.linalg.norm(goal - start))
    assert float(r.curvature_bound) == pytest.approx(bound_np(path), rel=1e-4)
    if bool(r.used_fallback):
        # the polyline itself, every vertex among the samples, feasible
        assert bool(r.clear) == all(
            clear_np(b, g.corner_rule, path[i], path[i + 1]) for i in range(len(path) - 1)
        )
        assert {tuple(v) for v in path.tolist()} <= {tuple(v) for v in pts.tolist()}
        assert float(r.length) == pytest.approx(poly_len, rel=1e-5)
        assert float(r.max_curvature) == float(r.curvature_bound)
        return
    assert bool(r.clear)
    dense, kappa, _ = np_curve(r.control, DENSE)
    # the module's samples are points of the same curve
    np.testing.assert_allclose(dense[:: DENSE // CFG.verify_per_span], pts, atol=2e-4)
    np.testing.assert_allclose(dense[0], start, atol=1e-5)
    np.testing.assert_allclose(dense[-1], goal, atol=1e-5)
    # never enters a blocked cell; positive clearance, as reported
    assert not np_in_blocked(b, dense).any(), c["name"]
    clearance = np_clearance(b, dense)
    assert clearance.min() > 0.0, c["name"]
    assert float(r.min_clearance) == pytest.approx(clearance.min(), abs=1e-2)
    # length: at least the straight line, at most LENGTH_FACTOR x the polyline
    length = float(np.sum(np.linalg.norm(np.diff(dense, axis=0), axis=1)))
    assert float(r.length) == pytest.approx(length, rel=1e-3)
    assert straight - 1e-4 <= length <= LENGTH_FACTOR * poly_len, c["name"]
    # curvature below the polyline's turning curvature bound
    assert kappa.max() <= float(r.curvature_bound) + 1e-4, (c["name"], kappa.max())
    assert float(r.max_curvature) == pytest.approx(kappa.max(), rel=2e-2, abs=1e-3)
    ds = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    mean_k = float(np.sum(0.5 * (kappa[1:] + kappa[:-1]) * ds) / length)
    assert float(r.mean_curvature) == pytest.approx(mean_k, rel=3e-2, abs=1e-3)


def bound_np(path: np.ndarray) -> float:
    """max over corners of 2 tan(theta / 2) / min(a, b, 1), in float64."""
    best = 0.0
    for i in range(1, len(path) - 1):
        u, v = path[i] - path[i - 1], path[i + 1] - path[i]
        theta = math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v))
        a, b = float(np.linalg.norm(u)), float(np.linalg.norm(v))
        best = max(best, 2.0 * math.tan(theta / 2.0) / min(a, b, 1.0))
    return best


# ---------------------------------------------------------------------------- tests
def test_real_paths_smooth_clear_short_and_gentle(cases):
    """Reference paths on real maps: every property, and most are actually smoothed."""
    for c in cases:
        _check_case(c)
    smoothed = [c["name"] for c in cases if not bool(c["res"].used_fallback)]
    # the free-rule optima of fealpy and skolayat squeeze diagonally: those fall back
    assert len(smoothed) >= len(cases) - 4, smoothed
    assert all(bool(c["res"].clear) for c in cases)


def test_smoothing_removes_tangencies(cases):
    """IMGA Table 4 / Fig. 9: the curve is not tangent to any obstacle (the polyline is)."""
    for c in cases:
        r = c["res"]
        if not bool(r.used_fallback):
            assert float(r.min_clearance) > 0.1, c["name"]


def test_fallback_on_diagonal_squeeze(squeeze):
    """Smoothing cannot be clear through a diagonal squeeze: the polyline comes back."""
    for c in squeeze:
        r = c["res"]
        assert bool(r.used_fallback)
        assert bool(r.clear)  # the polyline is feasible under corner_rule "free"
        assert float(r.min_clearance) == 0.0
        np.testing.assert_array_equal(
            r.points,
            np.asarray(polyline_points(c["grid"], *from_coords(c["path"], 20, CAP),
                                       CFG.resolved((20, 20)).n_points)),
        )
        _check_case(c | {"name": "squeeze"})


def test_degenerate_paths():
    """A straight segment stays straight; a one-node path falls back to itself."""
    g = Grid.create(np.zeros((20, 20), bool), start=(2, 3), goal=(17, 3), corner_rule="free")
    straight, single = run(g, [np.array([[2, 3], [17, 3]]), np.array([[5, 5]])])
    r = straight["res"]
    assert not bool(r.used_fallback) and bool(r.clear)
    assert float(r.length) == pytest.approx(15.0, rel=1e-5)
    assert float(r.max_curvature) <= 1e-5 and float(r.curvature_bound) == 0.0
    np.testing.assert_allclose(np.asarray(r.points)[:, 1], 3.0, atol=1e-5)
    r = single["res"]
    assert bool(r.used_fallback) and bool(r.clear)
    assert float(r.length) == 0.0
    np.testing.assert_array_equal(np.asarray(r.points), np.full((CFG.resolved((20, 20))
                                                                 .n_points, 2), 5.0))


def test_cap_factors_at_their_limits_give_a_number_not_a_fallback():
    """cap = cap_factor x the turning bound, where inf x 0 (a straight path) and 0 x inf
    (a path that turns back) are 0: both were NaN, a NaN loss and a silent fallback to
    the polyline. With an infinite factor a straight path is the straight curve; with
    a factor of 0 a path that turns back is smoothed (the cap is a penalty, not a
    refusal), each with a finite loss."""
    g = Grid.create(np.zeros((20, 20), bool), start=(2, 3), goal=(17, 3), corner_rule="free")
    straight = pad_paths([np.array([[2, 3], [17, 3]])], 20)
    r = jax.device_get(smooth(g, straight[0][0], straight[1][0],
                              config=SmoothConfig(steps=20, cap_factor=float("inf"))))
    assert np.isfinite(r.loss) and not r.used_fallback and r.clear
    assert float(r.length) == pytest.approx(15.0, rel=1e-5)
    back = pad_paths([np.array([[0, 3], [6, 3], [2, 3]])], 20)
    r = jax.device_get(smooth(g, back[0][0], back[1][0],
                              config=SmoothConfig(steps=20, cap_factor=0.0)))
    assert float(r.curvature_bound) == np.inf
    assert np.isfinite(r.loss) and not r.used_fallback


def test_moving_ai_room_map():
    """tests/data/movingai: a 32 x 32 room map (strict rule), a Moving AI scenario."""
    scen = read_scen(DATA / "movingai" / "room-32-32-4-random-1.scen")[1]
    g = load_map(DATA / "movingai" / "room-32-32-4.map", start=scen.start, goal=scen.goal,
                 corner_rule="strict")
    paths = [any_angle_shortest_path(g).path, shortest_path(g).path]
    cells, lengths = pad_paths(paths, g.width)
    res = jax.device_get(smooth_population(g, cells, lengths, config=CFG))
    for i, p in enumerate(paths):
        c = {"grid": g, "path": p, "res": jax.tree.map(lambda v, i=i: v[i], res),
             "name": f"room {i}"}
        _check_case(c)
        assert not bool(c["res"].used_fallback)


def test_vmap_equals_single_and_deterministic(cases):
    """The population call equals per-path calls; a path's curve does not depend on its
    row (the batch reversed gives the same curves, bit for bit, reversed)."""
    g = cases[0]["grid"]
    paths = [cases[0]["path"], cases[1]["path"]]
    cells, lengths = pad_paths(paths, g.width)
    batched = jax.device_get(smooth_population(g, cells, lengths, config=CFG))
    swapped = jax.device_get(smooth_population(g, cells[::-1], lengths[::-1], config=CFG))
    jax.tree.map(lambda a, b: np.testing.assert_array_equal(a, b[::-1]), batched, swapped)
    field = distance_field(g, CFG.upsample)
    for i in range(2):
        single = jax.device_get(smooth(g, cells[i], lengths[i], field, config=CFG))
        row = jax.tree.map(lambda v, i=i: v[i], batched)
        for name, a, b in zip(single._fields, single, row):
            if np.asarray(a).dtype == bool:
                assert a == b, name
            else:
                np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-4, err_msg=name)


def test_distance_field_is_exact_at_nodes():
    """Signed distance at every node equals a brute-force distance to the squares."""
    g = load_map("classic_ga_gapp3_20x20")
    f = jax.device_get(jax.jit(distance_field, static_argnums=1)(g, 2))
    ny, nx = f.values.shape
    assert (ny, nx) == (2 * 22 + 1, 2 * 22 + 1)
    xs = float(f.origin) + np.arange(nx) / 2.0
    ys = float(f.origin) + np.arange(ny) / 2.0
    pts = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    b = g.blocked_np()
    outside = np.ones((24, 24), bool)
    outside[2:-2, 2:-2] = b  # blocked cells plus two rings of outside cells
    free = ~outside

    def dist_to(mask):
        cy, cx = np.nonzero(mask)
        ex = np.maximum(np.abs(pts[:, None, 0] - (cx[None] - 2)) - 0.5, 0.0)
        ey = np.maximum(np.abs(pts[:, None, 1] - (cy[None] - 2)) - 0.5, 0.0)
        return np.hypot(ex, ey).min(axis=1)

    want = (dist_to(outside) - dist_to(free)).reshape(ny, nx)
    np.testing.assert_allclose(f.values, want, atol=1e-5)
    inside = np_in_blocked(b, pts).reshape(ny, nx)
    assert (f.values[inside] <= 0).all() and (f.values[~inside] >= 0).all()


def test_verify_curve_is_sound():
    """Random curves near obstacles: certified clear => the dense exact check agrees, and
    the certified lower bound never exceeds the true clearance; a hit is never clear."""
    g = load_map("classic_ga_gapp3_20x20")
    b = g.blocked_np()
    rng = np.random.default_rng(0)
    free = np.argwhere(~b)[:, ::-1]
    base = free[rng.integers(0, len(free), 300)].astype(np.float32)
    ctrl = base[:, None, :] + np.cumsum(rng.normal(0, 0.45, (300, 8, 2)), axis=1)
    ctrl = ctrl.astype(np.float32)
    ver = jax.device_get(jax.jit(jax.vmap(verify_curve, (None, 0)))(g, jnp.asarray(ctrl)))
    n_clear = n_hit = 0
    for i in range(len(ctrl)):
        dense, _, _ = np_curve(ctrl[i], 400)
        true = np_clearance(b, dense).min()
        hit = np_in_blocked(b, dense).any()
        assert float(ver.lower_bound[i]) <= true + 1e-4
        if bool(ver.clear[i]):
            n_clear += 1
            assert not hit and true > 0
        n_hit += hit
        assert not (hit and bool(ver.clear[i]))
        # exact chords where refined (within the chord deviation), sampled elsewhere
        assert float(ver.min_clearance[i]) == pytest.approx(min(true, 1.0), abs=5e-3)
    assert n_clear > 50 and n_hit > 50  # both outcomes are exercised


def test_turning_curvature_bound_hand_values():
    """2 tan(theta / 2) / min(a, b, 1): 90 deg -> 2, 45 deg -> 0.828, straight -> 0."""
    g = Grid.create(np.zeros((10, 10), bool), corner_rule="free")
    fn = jax.jit(turning_curvature_bound)

    def bound(xy):
        return float(fn(g, *from_coords(xy, 10, 8)))

    assert bound([(0, 0), (5, 0), (5, 5)]) == pytest.approx(2.0, rel=1e-6)
    assert bound([(0, 0), (1, 0), (2, 1)]) == pytest.approx(2 * math.tan(math.pi / 8), rel=1e-6)
    assert bound([(0, 0), (1, 0), (2, 1), (2, 3)]) == pytest.approx(
        2 * math.tan(math.pi / 8), rel=1e-6)
    assert bound([(0, 0), (3, 0), (6, 0)]) == 0.0
    assert bound([(4, 4)]) == 0.0
    assert bound([(0, 0), (3, 0), (1, 0)]) == math.inf  # a reversal
    assert bound([(0, 0), (4, 1), (8, 3)]) == pytest.approx(
        bound_np(np.array([(0, 0), (4, 1), (8, 3)])), rel=1e-5)


def test_config_validation():
    with pytest.raises(ParameterError):
        SmoothConfig(n_ctrl=3)
    with pytest.raises(ParameterError):
        SmoothConfig(margin=-1.0)
    with pytest.raises(ParameterError):
        SmoothConfig(steps=1.5)  # type: ignore[arg-type]
    assert SmoothConfig().resolved((20, 20)).n_ctrl == 40
    assert SmoothConfig().resolved((300, 400)).n_ctrl == 512
    g = Grid.create(np.zeros((4, 4), bool))
    with pytest.raises(ParameterError, match="capacity"):
        smooth(g, jnp.zeros(200, jnp.int32), jnp.int32(1), config=SmoothConfig(n_ctrl=8))


def test_plot_smooth(cases):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jaxga.smooth import plot_smooth

    c = next(c for c in cases if not bool(c["res"].used_fallback))
    fig, ax = plt.subplots()
    assert plot_smooth(ax, c["grid"], c["res"], c["path"]) is ax
    labels = [line.get_label() for line in ax.get_lines()]
    assert any(lab.startswith("smooth (") for lab in labels)
    assert any(lab.startswith("polyline (") for lab in labels)
    plt.close(fig)


def test_a_curve_is_resampled_within_its_tolerance_of_the_curve():
    """A dense quarter circle of radius 10 (arc 5 pi, about 15.7 cells) in 4001 points:
    points on the circle at most a cell apart, both ends kept, and every chord within
    the tolerance of the curve. A chord of length h on that circle lies h**2 / 80 inside
    it, so the 16 pieces of 0.98 cells (0.012 inside) are halved until 0.001 holds:
    64 pieces of 0.245 cells."""
    t = np.linspace(0.0, np.pi / 2, 4001)
    dense = np.stack([10 * np.cos(t), 10 * np.sin(t)], axis=1)
    got = resample_curve(dense, 1.0)
    assert got.shape == (65, 2)
    np.testing.assert_allclose(got[[0, -1]], dense[[0, -1]])
    np.testing.assert_allclose(np.hypot(*got.T), 10.0, atol=1e-6)
    steps = np.hypot(*np.diff(got, axis=0).T)
    np.testing.assert_allclose(steps, 5 * np.pi / 64, rtol=1e-3)
    mid = (got[:-1] + got[1:]) / 2  # each chord's point farthest inside the circle
    assert (10.0 - np.hypot(*mid.T)).max() <= RESAMPLE_TOLERANCE
    coarse = resample_curve(dense, 1.0, tolerance=0.02)  # 0.012 inside is allowed
    assert coarse.shape == (17, 2)
    # a segment is divided evenly, a cell apart
    np.testing.assert_allclose(resample_curve(np.array([[0.0, 0.0], [3.0, 4.0]])),
                               [[0, 0], [0.6, 0.8], [1.2, 1.6], [1.8, 2.4], [2.4, 3.2],
                                [3.0, 4.0]], atol=1e-12)


def test_a_resampled_curve_keeps_its_clearance_past_a_corner():
    """A unit circle about a point 0.97 / sqrt(2) beyond a blocked cell's corner clears
    the cell by 0.03; chords a cell long cut that bend (0.125 inside) and touched the
    cell. The resampled path clears it by at least 0.03 less the tolerance."""
    o = np.array([4.5, 4.5]) + 0.97 * np.sqrt(0.5)
    th = np.radians(np.linspace(120, 270, 3001))
    dense = o + np.stack([np.cos(th), np.sin(th)], axis=1)
    cell = np.array([[5.0, 5.0]])
    assert segments_square_distance(dense[:-1], dense[1:], cell).min() > 0.0299
    got = resample_curve(dense, 1.0)
    assert segments_square_distance(got[:-1], got[1:], cell).min() >= 0.03 - RESAMPLE_TOLERANCE
    np.testing.assert_allclose(got[[0, -1]], dense[[0, -1]])
    assert np.hypot(*np.diff(got, axis=0).T).max() <= 1.0 + 1e-12


@pytest.mark.parametrize("points, spacing, tolerance, message", [
    (np.arange(6.0), 1.0, 1e-3, "shape \\[N, 2\\]"),
    ([[0.0, 0.0], [np.nan, 1.0]], 1.0, 1e-3, "finite"),
    ([[0.0, 0.0], [1.0, 1.0]], 0.0, 1e-3, "spacing must be a number > 0"),
    ([[0.0, 0.0], [1.0, 1.0]], 1.0, float("inf"), "tolerance must be a number > 0"),
])
def test_resample_curve_refuses_what_is_not_a_curve_in_one_line(points, spacing, tolerance,
                                                                 message):
    with pytest.raises(ParameterError, match=message):
        resample_curve(points, spacing, tolerance)


def test_the_smooth_line_speaks_metres_on_a_map_with_a_resolution():
    """Curvature in 1/m and clearance in m at 0.05 m per cell; cells without a frame."""
    curves = [{"length": 20.0, "max_curvature": 0.5, "min_clearance": 2.0,
               "used_fallback": False}]
    frame = MapFrame(map_shape=(10, 10), coarsen=1, resolution=0.05, origin=(0.0, 0.0, 0.0))
    result = SimpleNamespace(length=np.array([21.0]), frame=frame)
    assert smooth_summary(result, curves).endswith(
        "(mean length 1.000 m, -4.76 % against the polylines; max curvature 10.000 1/m, "
        "min clearance 0.100 m)")
    result.frame = None
    assert smooth_summary(result, curves).endswith("min clearance 2.000 cells)")
