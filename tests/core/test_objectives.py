"""Objectives, metrics and fitness combiners against hand-computed values.

Maps are drawn with row y = 0 at the bottom; a path is a list of (x, y) cells. Every
function is evaluated under ``jax.jit``. Hand computations are written out in comments.
"""

from __future__ import annotations

import functools
import math
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jaxga import Grid, ParameterError
from jaxga.core import clearance, path_geometry
from jaxga.core import objectives as ob
from jaxga.core.paths import population_map

S2 = math.sqrt(2.0)
PI = math.pi


# ------------------------------------------------------------------------ helpers
def make_grid(
    size: int = 5, obstacles: Sequence[tuple[int, int]] = (), goal: tuple[int, int] | None = None
) -> Grid:
    """A ``size x size`` grid with the given blocked (x, y) cells, start (0, 0)."""
    b = np.zeros((size, size), dtype=bool)
    for x, y in obstacles:
        b[y, x] = True
    return Grid.create(b, start=(0, 0), goal=goal, corner_rule="free")


def make_path(
    xy: Sequence[tuple[int, int]], cap: int = 12, width: int = 5, pad: int | None = None
) -> tuple[jax.Array, jax.Array]:
    """``(cells int32[cap], length)``; padding repeats the last cell unless ``pad`` given."""
    cells = [y * width + x for x, y in xy]
    fill = cells[-1] if pad is None else pad
    return jnp.asarray(cells + [fill] * (cap - len(cells)), jnp.int32), jnp.int32(len(cells))


COMBINERS = (ob.imga, ob.agacd, ob.mpmga, ob.iga_zhu, ob.iga_zhang, ob.sga)
ALL_PER_PATH = (
    ob.path_length,
    ob.turn_angles,
    ob.turns,
    ob.angle_sum,
    ob.mpmga_penalty,
    ob.zhu_penalty,
    ob.imga_energy,
    ob.imga_safety,
    ob.agacd_safety,
    ob.min_clearance,
    ob.tangencies,
) + COMBINERS


def all_values(grid: Grid, cells: jax.Array, length: jax.Array) -> tuple:
    """Every per-path function at once (one compilation instead of seventeen)."""
    return tuple(fn(grid, cells, length) for fn in ALL_PER_PATH)


_all_values = jax.jit(all_values)
_all_values_pop = jax.jit(population_map(all_values))


@functools.cache
def _jitted(fn: Callable, kw: tuple) -> Callable:
    return jax.jit(functools.partial(fn, **dict(kw)))


def run(fn: Callable, grid: Grid, xy, cap: int = 12, **kw):
    """Evaluate one objective on one path under jit; returns a NumPy scalar/array.

    Default parameters on 5 x 5 maps go through the single compiled ``all_values``.
    """
    cells, length = make_path(xy, cap, grid.width)
    if not kw and cap == 12 and grid.shape == (5, 5) and fn in ALL_PER_PATH:
        return np.asarray(_all_values(grid, cells, length)[ALL_PER_PATH.index(fn)])
    return np.asarray(_jitted(fn, tuple(sorted(kw.items())))(grid, cells, length))


OPEN = make_grid()
L_SHAPE = [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (4, 1), (4, 2), (4, 3), (4, 4)]
STAIRCASE = [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4)]
# Turns: 45 deg at (1,0), 90 at (2,1), 135 at (1,2), straight at (2,2).
MIXED = [(0, 0), (1, 0), (2, 1), (1, 2), (2, 2), (3, 2)]
MIXED_LENGTH = 3.0 + 2.0 * S2  # 1 + sqrt2 + sqrt2 + 1 + 1
KNIGHT = [(0, 0), (2, 1), (4, 1)]  # waypoint path, first segment a knight move


# ------------------------------------------------------------------------ length
def test_path_length_hand_values():
    """IMGA eq. 5 / AGACD eq. 9 / MPMGA eq. 6 / Zhu eq. 7: sum of Euclidean segments."""
    assert run(ob.path_length, OPEN, L_SHAPE) == pytest.approx(8.0)
    assert run(ob.path_length, OPEN, STAIRCASE) == pytest.approx(4 * S2, rel=1e-6)
    assert run(ob.path_length, OPEN, MIXED) == pytest.approx(MIXED_LENGTH, rel=1e-6)
    assert run(ob.path_length, OPEN, KNIGHT) == pytest.approx(math.sqrt(5) + 2, rel=1e-6)
    assert run(ob.path_length, OPEN, [(3, 3)]) == 0.0  # one node


# ------------------------------------------------------------------- turn angles
def test_turn_angles_hand_values():
    """The turn angle atan2(|cross|, dot): 0 straight, pi/2 corner, 3pi/4, pi reversal."""
    a = run(ob.turn_angles, OPEN, L_SHAPE)
    assert a.shape == (12,) and a.dtype == np.float32
    np.testing.assert_allclose(a, np.eye(12)[4] * PI / 2, atol=1e-6)
    np.testing.assert_allclose(run(ob.turn_angles, OPEN, STAIRCASE), 0.0, atol=0)
    # 135 degrees: heading east, then north-west.
    a = run(ob.turn_angles, OPEN, [(0, 0), (1, 0), (0, 1)])
    np.testing.assert_allclose(a, np.eye(12)[1] * 3 * PI / 4, atol=1e-6)
    # knight move (2,1) then (2,0): atan2(|2*0 - 1*2|, 2*2 + 1*0) = atan(1/2)
    a = run(ob.turn_angles, OPEN, KNIGHT)
    assert a[1] == pytest.approx(math.atan(0.5), abs=1e-6) and a.sum() == a[1]
    # reversal on a waypoint path: east 3, then west 2
    assert run(ob.turn_angles, OPEN, [(0, 0), (3, 0), (1, 0)])[1] == pytest.approx(PI)


def test_fast_atan2_matches_numpy():
    """The branch-free float32 atan2 for y >= 0 agrees with NumPy's to 1e-6 rad."""
    v = np.arange(-60, 61)
    y, x = np.meshgrid(np.abs(v), v)
    got = np.asarray(jax.jit(path_geometry.atan2_nonneg)(jnp.asarray(y), jnp.asarray(x)))
    want = np.arctan2(y, x).astype(np.float64)
    want[(y == 0) & (x == 0)] = 0.0
    np.testing.assert_allclose(got, want, atol=1e-6, rtol=0)


def test_turns_count():
    """Zhang eq. 2 ``m`` (IMGA Table 3 'number of turns'): nodes with a non-zero turn."""
    assert run(ob.turns, OPEN, L_SHAPE) == 1
    assert run(ob.turns, OPEN, STAIRCASE) == 0
    zigzag = [(0, 0), (1, 1), (2, 0), (3, 1), (4, 0)]  # three 90-degree turns
    assert run(ob.turns, OPEN, zigzag) == 3
    assert run(ob.turns, OPEN, MIXED) == 3
    assert run(ob.turns, OPEN, [(2, 2)]) == 0
    assert run(ob.turns, OPEN, [(2, 2), (3, 3)]) == 0


def test_repeated_nodes_are_skipped():
    """Repeated consecutive nodes add no length, turn or penalty."""
    dup = [(0, 0), (1, 0), (1, 0), (1, 0), (2, 1), (1, 2), (1, 2), (2, 2), (3, 2)]
    for fn in (
        ob.path_length,
        ob.turns,
        ob.angle_sum,
        ob.mpmga_penalty,
        ob.zhu_penalty,
        ob.imga_energy,
        ob.imga_safety,
        ob.agacd_safety,
    ):
        grid = make_grid(obstacles=[(3, 0), (0, 3)], goal=(4, 4))
        assert run(fn, grid, dup) == pytest.approx(run(fn, grid, MIXED)), fn
    a = run(ob.turn_angles, OPEN, dup)  # turn reported at the run's last copy
    np.testing.assert_allclose(a[[3, 4, 6]], [PI / 4, PI / 2, 3 * PI / 4], atol=1e-6)
    assert np.count_nonzero(a) == 3


def _fill_forward_reference(key: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``v`` carried forward from the last position whose key is not -1 (numpy)."""
    m = np.maximum.accumulate(key, axis=-1)
    return np.where(m >= 0, np.take_along_axis(v, np.maximum(m, 0), axis=-1), v)


FILL_WIDTH = 12 * 41  # the longest example below: 12 runs of 41 entries
_fill_forward_pairs = jax.jit(jax.vmap(path_geometry.fill_forward))


@given(st.lists(st.tuples(st.booleans(), st.integers(0, 40)), min_size=1, max_size=12),
       st.integers(0, 2**31 - 1))
def test_direction_fill_forward_matches_running_maximum(runs, seed):
    """The last segment direction carried over repeated nodes (holes) equals a numpy
    running maximum, for holes at the start, in long runs and under vmap with paths
    without holes in the same batch. Every example is padded to one length with filled
    entries after its runs (a fill only looks back), so one program serves them all."""
    mask = np.concatenate([np.full(n + 1, filled) for filled, n in runs])
    mask = np.concatenate([mask, np.ones(FILL_WIDTH - mask.size, bool)])
    n = mask.size
    rng = np.random.default_rng(seed)
    keys = np.stack([np.where(mask, np.arange(n), -1), np.arange(n)]).astype(np.int32)
    vx, vy = (rng.integers(-3, 4, (2, n)).astype(np.int32) for _ in range(2))
    px, py = _fill_forward_pairs(jnp.asarray(keys), jnp.asarray(vx), jnp.asarray(vy))
    np.testing.assert_array_equal(px, _fill_forward_reference(keys, vx))
    np.testing.assert_array_equal(py, _fill_forward_reference(keys, vy))


def test_long_hole_runs_fill_exactly():
    """One path with 700 holes after its first segment and one with none: both exact."""
    n = 799
    keys = np.stack([np.where(np.arange(n) < 1, 0, -1), np.arange(n)]).astype(np.int32)
    keys[0, 701:] = np.arange(701, n)
    vx = np.tile(np.arange(n, dtype=np.int32) % 5 - 2, (2, 1))
    vy = -vx
    px, py = jax.jit(jax.vmap(path_geometry.fill_forward))(keys, vx, vy)
    np.testing.assert_array_equal(px, _fill_forward_reference(keys, vx))
    np.testing.assert_array_equal(py, _fill_forward_reference(keys, vy))
    assert (np.asarray(px)[0, :701] == vx[0, 0]).all()


# ---------------------------------------------------------------- smoothness
def test_angle_sum_agacd():
    """AGACD eq. 10-17: smoothness = sum of rotation angles (radians)."""
    assert run(ob.angle_sum, OPEN, MIXED) == pytest.approx(PI / 4 + PI / 2 + 3 * PI / 4)
    assert run(ob.angle_sum, OPEN, [(0, 0), (1, 0), (2, 1), (3, 1)]) == pytest.approx(PI / 2)
    assert run(ob.angle_sum, OPEN, STAIRCASE) == 0.0
    assert run(ob.angle_sum, OPEN, KNIGHT) == pytest.approx(math.atan(0.5), abs=1e-6)


def test_mpmga_penalty():
    """MPMGA eq. 13-14: 0 / 5 (0 < turn < pi/2) / 25 (= pi/2) / 125 (> pi/2) per node."""
    assert run(ob.mpmga_penalty, OPEN, MIXED) == 5 + 25 + 125
    assert run(ob.mpmga_penalty, OPEN, L_SHAPE) == 25
    assert run(ob.mpmga_penalty, OPEN, STAIRCASE) == 0
    assert run(ob.mpmga_penalty, OPEN, KNIGHT) == 5  # 26.6 degrees
    assert run(ob.mpmga_penalty, OPEN, [(0, 0), (3, 0), (1, 0)]) == 125  # reversal


def test_zhu_penalty():
    """Zhu & Pan eq. 8-9: 45 -> c1, 90 -> c2, 135 -> c3; other angles round up; >135 -> c4."""
    assert run(ob.zhu_penalty, OPEN, MIXED) == 1 + 2 + 3
    assert run(ob.zhu_penalty, OPEN, MIXED, c1=10.0, c2=20.0, c3=40.0) == 70
    assert run(ob.zhu_penalty, OPEN, KNIGHT) == 1  # 26.6 -> 45 bucket
    assert run(ob.zhu_penalty, OPEN, [(0, 0), (1, 0), (2, 2)]) == 2  # 63.4 -> 90 bucket
    assert run(ob.zhu_penalty, OPEN, [(2, 0), (3, 0), (2, 2)]) == 3  # 116.6 -> 135 bucket
    sharp = [(2, 0), (3, 0), (1, 1)]  # 153.4 degrees
    assert run(ob.zhu_penalty, OPEN, sharp) == 3  # default c4 = c3
    assert run(ob.zhu_penalty, OPEN, sharp, c4=9.0) == 9
    assert run(ob.zhu_penalty, OPEN, [(0, 0), (3, 0), (1, 0)], c4=9.0) == 9  # reversal


def test_imga_energy():
    """IMGA eq. 7 / Fig. 3: at each turn, new heading in the goal frame: +1 / +3 / +10."""
    grid = make_grid(goal=(4, 4))
    # (2,0): heading (0,1), goal offset (2,4): first quadrant            +1
    # (2,1): heading (-1,1), goal offset (2,3): second quadrant          +3
    # (1,2): heading (0,-1), goal offset (3,2): third (away from goal)   +10
    # (1,1): heading (1,1), goal offset (3,3): first quadrant            +1
    # (2,2), (3,3): straight on, no charge; the start is never charged.
    path = [(0, 0), (1, 0), (2, 0), (2, 1), (1, 2), (1, 1), (2, 2), (3, 3), (4, 4)]
    assert run(ob.imga_energy, grid, path) == 15
    assert run(ob.imga_energy, grid, L_SHAPE) == 1
    assert run(ob.imga_energy, grid, STAIRCASE) == 0
    # Goal straight above node (4,0): the x component is neutral.
    assert run(ob.imga_energy, grid, [(2, 0), (3, 0), (4, 0), (3, 1)]) == 1  # up-left
    assert run(ob.imga_energy, grid, [(2, 0), (3, 0), (4, 0), (4, 1)]) == 1  # up
    assert run(ob.imga_energy, grid, [(2, 1), (3, 1), (4, 1), (3, 0)]) == 10  # down-left
    assert run(ob.imga_energy, grid, [(3, 0), (4, 1), (3, 1)]) == 1  # sideways
    # Goal straight to the right of node (1,4): moving down is sideways too.
    assert run(ob.imga_energy, grid, [(0, 3), (1, 4), (1, 3)]) == 1


# ------------------------------------------------------------------------ safety
SAFETY_GRID = make_grid(obstacles=[(2, 2), (0, 2), (4, 0)], goal=(4, 4))
AROUND = [(0, 0), (1, 1), (1, 2), (2, 3), (3, 3), (4, 4)]


def test_imga_safety():
    """IMGA eq. 6: +5 per node with an obstacle among its 8 neighbours."""
    # (1,1), (1,2), (2,3), (3,3) touch (2,2) (and (0,2)); (0,0) and (4,4) are safe.
    assert run(ob.imga_safety, SAFETY_GRID, AROUND) == 20
    assert run(ob.imga_safety, SAFETY_GRID, AROUND, penalty=1.0) == 4
    # Off-map cells: free by default; with border_blocked (0,0) and (4,4) count too.
    assert run(ob.imga_safety, SAFETY_GRID, AROUND, border_blocked=True) == 30
    assert run(ob.imga_safety, OPEN, L_SHAPE) == 0


def test_agacd_safety_counts_shared_obstacle_once():
    """AGACD eq. 18-20: 1 + 0.1 per obstacle next to the path, each obstacle once."""
    # Obstacles next to the path: (2,2) (next to 4 nodes) and (0,2) (next to 2): 2.
    # With border_blocked: also 5 off-map cells around (0,0) and 5 around (4,4).
    variants = [(m, b) for m in ("auto", "bits", "table", "sort") for b in (False, True)]

    @jax.jit
    def every_variant(grid, cells, length):
        return [
            ob.agacd_safety(grid, cells, length, method=m, border_blocked=b) for m, b in variants
        ]

    got = every_variant(SAFETY_GRID, *make_path(AROUND))
    np.testing.assert_allclose(got, [1.2, 2.2] * 4, rtol=1e-6)
    assert run(ob.agacd_safety, OPEN, L_SHAPE) == pytest.approx(1.0)
    with pytest.raises(ParameterError):
        run(ob.agacd_safety, OPEN, L_SHAPE, method="hash")


def test_agacd_safety_methods_agree_with_brute_force():
    """The bits/table/sort de-duplications equal a set-based count, loops included."""
    rng = np.random.default_rng(1)
    # 10 x 35: a padded row of 37 bits spans two uint32 words, and half the walks start
    # near the word boundary (x = 31) or the map edges.
    size, cap, n = 35, 24, 40
    grid = Grid.create(rng.random((10, size)) < 0.35)
    steps = np.array([(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)])
    cells = np.zeros((n, cap), np.int64)
    lengths = rng.integers(1, cap + 1, n)
    for i in range(n):
        p = np.array([rng.integers(26, size) if i % 2 else rng.integers(0, size), rng.integers(10)])
        for j in range(cap):
            cells[i, j] = p[1] * size + p[0]
            p = np.clip(p + steps[rng.integers(8)], 0, [size - 1, 9])  # revisits are common
        cells[i, lengths[i] :] = cells[i, lengths[i] - 1]
    b = np.asarray(grid.blocked)
    want = []
    for i in range(n):
        hit = set()
        for c in cells[i, : lengths[i]]:
            x, y = c % size, c // size
            for dx, dy in steps:
                if 0 <= x + dx < size and 0 <= y + dy < 10 and b[y + dy, x + dx]:
                    hit.add((x + dx, y + dy))
        want.append(1 + 0.1 * len(hit))
    c, ln = jnp.asarray(cells, jnp.int32), jnp.asarray(lengths, jnp.int32)

    def every_method(g, cc, nn):
        _, x, y, node, _ = path_geometry.path_nodes(g, cc, nn)
        exact = ob._count_bits(x, y, node, jnp.pad(g.blocked, 1))[1]  # the bare bit table
        methods = ("bits", "table", "sort")
        return [ob.agacd_safety(g, cc, nn, method=m) for m in methods], exact

    got, exact = jax.jit(population_map(every_method))(grid, c, ln)
    for values in got:
        np.testing.assert_allclose(values, want, rtol=1e-6)
    # the bit table alone is exact on loop-free paths and flags every revisit
    runs = [
        [c for j, c in enumerate(row[:k]) if j == 0 or c != row[j - 1]]
        for row, k in zip(cells, lengths)
    ]  # repeated consecutive nodes are skipped
    loop_free = [len(set(r)) == len(r) for r in runs]
    assert not all(loop_free) and any(loop_free)
    np.testing.assert_array_equal(exact, loop_free)


# ----------------------------------------------------------------------- metrics
def test_min_clearance_hand_values():
    """Metric: distance from the centre polyline to the nearest blocked cell square."""
    wall = make_grid(obstacles=[(2, 2)])
    assert run(ob.min_clearance, wall, [(0, 1), (1, 1), (2, 1), (3, 1)]) == pytest.approx(0.5)
    assert run(ob.min_clearance, wall, [(0, 0), (4, 0)]) == pytest.approx(1.5)
    # diagonal squeeze between two obstacles touching at a corner
    squeeze = make_grid(obstacles=[(1, 0), (0, 1)])
    assert run(ob.min_clearance, squeeze, [(0, 0), (1, 1), (2, 2)]) == 0.0
    # node (1,1) to the corner (1.5, 0.5) of obstacle (2,0)
    corner = make_grid(obstacles=[(2, 0)])
    assert run(ob.min_clearance, corner, [(0, 0), (1, 1)]) == pytest.approx(math.sqrt(0.5))
    # segment interior to the corner (1.5, 1.5) of obstacle (1,2): |1.5 - 2*1.5| / sqrt5
    slope = make_grid(obstacles=[(1, 2)])
    assert run(ob.min_clearance, slope, [(0, 0), (4, 2)]) == pytest.approx(1.5 / math.sqrt(5))
    # knight segment (0,0)->(2,1) passes (1, 0.5): on the edge of obstacle (1,1)
    assert run(ob.min_clearance, make_grid(obstacles=[(1, 1)]), KNIGHT) == 0.0
    assert run(ob.min_clearance, OPEN, L_SHAPE) == np.inf
    # map boundary as obstacle: node (0,1) is 0.5 from the left edge
    assert run(ob.min_clearance, OPEN, [(0, 1), (2, 2)], border_blocked=True) == 0.5
    assert run(ob.min_clearance, wall, [(2, 0)]) == pytest.approx(1.5)  # one node


def test_tangencies():
    """IMGA Table 3 'number of tangency': segments touching an obstacle (clearance 0)."""
    grid = make_grid(obstacles=[(1, 0), (0, 1), (2, 1)])
    # (0,0)-(1,1) squeezes past (1,0) and (0,1); (1,1)-(2,2) passes the corner of (2,1);
    # (2,2)-(3,2) runs 0.5 above (2,1): not tangent.
    assert run(ob.tangencies, grid, [(0, 0), (1, 1), (2, 2), (3, 2)]) == 2
    assert run(ob.tangencies, OPEN, L_SHAPE) == 0
    assert run(ob.tangencies, grid, [(3, 3)]) == 0


def test_min_clearance_against_dense_sampling():
    """min_clearance lies between the sampled minimum distance and that minus the step."""
    rng = np.random.default_rng(3)
    size = 7
    fn = jax.jit(ob.min_clearance)
    for _ in range(5):
        b = rng.random((size, size)) < 0.2
        grid = Grid.create(b)
        xy = rng.integers(0, size, (4, 2))
        cells, n = make_path([tuple(p) for p in xy], cap=6, width=size)
        got = float(fn(grid, cells, n))
        t = np.linspace(0, 1, 801)[:, None]
        pts = np.concatenate([xy[i] + t * (xy[i + 1] - xy[i]) for i in range(3)])
        boxes = np.argwhere(b)[:, ::-1]  # (x, y)
        d = np.abs(pts[:, None, :] - boxes[None, :, :]) - 0.5
        dist = np.sqrt(np.sum(np.maximum(d, 0.0) ** 2, axis=-1)).min()
        assert dist - 6 / 800 - 1e-6 <= got <= dist + 1e-6


def _whole_map_clearance(grid: Grid, cells: jax.Array, length: jax.Array) -> tuple:
    """Every segment against every cell of the map: (min clearance, min clearance with
    the border blocked, tangencies)."""
    g = path_geometry.geometry(grid, cells, length)
    h, w = grid.shape
    segs = (g.x[:-1], g.y[:-1], g.x[1:], g.y[1:])
    d, t = jax.vmap(lambda *s: clearance._segment_box_clearance(*s, grid.blocked))(*segs)
    xf, yf = g.x.astype(jnp.float32), g.y.astype(jnp.float32)
    edge = jnp.minimum(jnp.minimum(xf, (w - 1) - xf), jnp.minimum(yf, (h - 1) - yf)) + 0.5
    return (jnp.min(d), jnp.minimum(jnp.min(d), jnp.min(edge)),
            jnp.sum(t & g.moving, dtype=jnp.int32))


_band_and_whole = jax.jit(jax.vmap(
    lambda g, c, n: ((ob.min_clearance(g, c, n), ob.min_clearance(g, c, n, border_blocked=True),
                      ob.tangencies(g, c, n)), _whole_map_clearance(g, c, n)),
    in_axes=(None, 0, 0)))


def test_clearance_bands_equal_the_whole_map():
    """min_clearance and tangencies measure each segment against a band of cells around
    it, and against the whole map only when the path stays beyond ``CLEARANCE_RADIUS``
    of every obstacle: the same values, bit for bit, as every segment against every
    cell, for continuous paths, waypoint paths with long segments, paths far from every
    obstacle and an open map."""
    rng = np.random.default_rng(4)
    size, cap = 24, 12
    for density in (0.0, 0.01, 0.05, 0.2, 0.4):
        for _ in range(3):
            grid = Grid.create(rng.random((size, size)) < density, corner_rule="strict")
            cells, lengths = [], []
            for k in range(16):
                n = int(rng.integers(1, cap + 1))
                if k % 2:  # a random walk: a continuous path (or repeated nodes)
                    xy = np.cumsum(rng.integers(-1, 2, (n, 2)), axis=0) + rng.integers(0, size, 2)
                    xy = np.clip(xy, 0, size - 1)
                else:  # random waypoints: long segments
                    xy = rng.integers(0, size, (n, 2))
                c, ln = make_path([tuple(p) for p in xy.tolist()], cap=cap, width=size)
                cells.append(c)
                lengths.append(ln)
            band, whole = _band_and_whole(grid, jnp.stack(cells), jnp.stack(lengths))
            for got, want in zip(band, whole):
                np.testing.assert_array_equal(np.asarray(got), np.asarray(want))


def test_clearance_beyond_the_first_band_equals_the_whole_map():
    """A path across an open hall: beyond :data:`clearance.CLEARANCE_RADIUS` of every
    obstacle it is measured in the wider band (its work bounded by the path), and only
    beyond :data:`clearance.CLEARANCE_WIDE_RADIUS` against the whole map; every value
    bit for bit the whole map's, an 8-connected staircase and long waypoint segments
    alike."""
    size = 160
    b = np.zeros((size, size), bool)
    b[2:5, 3:6] = True  # one obstacle near a corner of the open hall
    grid = Grid.create(b, corner_rule="strict")
    paths = [  # least distance to the obstacle about: 4-64 (the wide band), > 64 (whole map)
        [(12, 12), (40, 20)],
        [(20, 4), (21, 5), (22, 5), (23, 6), (24, 6), (25, 7), (26, 7)],
        [(30, 40), (31, 41), (32, 41), (33, 42)],
        [(150, 150), (100, 155), (140, 90)],
        [(9, 3), (9, 10)],  # within the first band
    ]
    made = [make_path(p, cap=8, width=size) for p in paths]
    band, whole = _band_and_whole(grid, jnp.stack([c for c, _ in made]),
                                  jnp.stack([n for _, n in made]))
    for got, want in zip(band, whole):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    near = np.asarray(band[0])
    assert (near[:3] > clearance.CLEARANCE_RADIUS).all()
    assert (near[:3] <= clearance.CLEARANCE_WIDE_RADIUS).all()
    assert near[3] > clearance.CLEARANCE_WIDE_RADIUS and near[4] <= clearance.CLEARANCE_RADIUS


def test_a_band_of_either_radius_is_exact_up_to_its_radius():
    """Each band's claim (:func:`clearance._piece_band_clearance`): over a segment's
    pieces, a least distance at most the band's radius is the whole map's, bit for bit,
    and a larger one only says that the whole map's is larger too; at the first band's
    radius and at the wider one, on segments of every slope near and far from sparse
    obstacles."""
    rng = np.random.default_rng(7)
    size = 150
    b = rng.random((size, size)) < 0.0004
    grid = Grid.create(b)
    blocked = jnp.asarray(b)
    pieces = jnp.arange(-(-size // clearance.CLEARANCE_PIECE), dtype=jnp.int32)
    whole = jax.jit(lambda ax, ay, bx, by: clearance._segment_box_clearance(
        ax, ay, bx, by, blocked)[0])
    for radius in (clearance.CLEARANCE_RADIUS, clearance.CLEARANCE_WIDE_RADIUS):
        band = jax.jit(lambda ax, ay, bx, by, n, r=radius: jnp.min(jnp.where(
            pieces < n, jax.vmap(lambda k: clearance._piece_band_clearance(
                ax, ay, bx, by, k, blocked, r)[0])(pieces), jnp.inf)))
        seen = 0
        for _ in range(40):
            ax, ay, bx, by = (jnp.int32(v) for v in rng.integers(0, size, 4))
            span = int(max(abs(bx - ax), abs(by - ay)))
            n = max((span + clearance.CLEARANCE_PIECE - 1) // clearance.CLEARANCE_PIECE, 1)
            got = float(band(ax, ay, bx, by, jnp.int32(n)))
            want = float(whole(ax, ay, bx, by))
            if got <= radius:
                assert got == want
                seen += 1
            else:
                assert want > radius
        assert seen >= 5
    assert grid.shape == (size, size)


def test_metrics_bundle():
    """The reported metrics in one call, consistent with the single functions."""
    grid = make_grid(obstacles=[(3, 0), (0, 3)], goal=(4, 4))
    m = jax.jit(ob.metrics)(grid, *make_path(MIXED))
    assert isinstance(m, ob.Metrics)
    assert float(m.length) == pytest.approx(MIXED_LENGTH)
    assert int(m.turns) == 3
    assert float(m.angle_sum) == pytest.approx(1.5 * PI)
    # (2,1) is 0.5 from obstacle (3,0)'s corner? No: |(2,1)-(2.5,0.5)| = sqrt(0.5);
    # (1,0)-(2,1) passes (1.5, 0.5)... 1 away from (2.5, 0.5); segment (2,1)-(1,2) to
    # the corner (0.5, 2.5) of (0,3): sqrt(0.5). So min_clearance = sqrt(0.5).
    assert float(m.min_clearance) == pytest.approx(math.sqrt(0.5))
    assert int(m.tangencies) == 0


# ------------------------------------------------------------- Delphi weights
def test_delphi_weights_agacd_example():
    """AGACD eq. 21-25: I = (1.2, 1.4) -> w = (0.4118, 0.3431, 0.2451)."""
    w = np.asarray(ob.delphi_weights((1.2, 1.4)))
    np.testing.assert_allclose(w, [0.4118, 0.3431, 0.2451], atol=1e-4)
    # w3 = 1 / (1 + I2 + I1 I2), w2 = I2 w3, w1 = I1 w2
    np.testing.assert_allclose(w, [1.68 / 4.08, 1.4 / 4.08, 1 / 4.08], rtol=1e-6)
    np.testing.assert_allclose(ob.AGACD_WEIGHTS, w, rtol=1e-6)
    np.testing.assert_allclose(jax.jit(ob.delphi_weights)(jnp.array([2.0])), [2 / 3, 1 / 3])
    np.testing.assert_allclose(ob.delphi_weights([]), [1.0])
    with pytest.raises(ParameterError):
        ob.delphi_weights((1.2, 0.0))


# ------------------------------------------------------------ fitness combiners
FIT_GRID = make_grid(obstacles=[(3, 0), (0, 3)], goal=(4, 4))
# MIXED on FIT_GRID: length 3 + 2 sqrt2; turns 45/90/135 (3 turns, angle sum 1.5 pi);
# IMGA safety: (2,1) is next to (3,0), (1,2) next to (0,3) -> 10; AGACD safety 1.2;
# IMGA energy: (1,0) heading (1,1) +1, (2,1) heading (-1,1) +3, (1,2) heading (1,0) +1 = 5;
# MPMGA penalty 5 + 25 + 125 = 155; Zhu penalty 1 + 2 + 3 = 6.


def test_fitness_imga():
    """IMGA eq. 4: F = 1 / (6 L + 1 S + 3 E)."""
    want = 1 / (6 * MIXED_LENGTH + 10 + 3 * 5)
    assert run(ob.imga, FIT_GRID, MIXED) == pytest.approx(want, rel=1e-6)
    assert run(ob.imga, FIT_GRID, MIXED, a=1.0, b=0.0, c=0.0) == pytest.approx(1 / MIXED_LENGTH)


def test_fitness_agacd():
    """AGACD eq. 7-8: F = w1/length + w2/smoothness + w3/safety, Delphi weights."""
    w1, w2, w3 = 1.68 / 4.08, 1.4 / 4.08, 1 / 4.08
    want = w1 / MIXED_LENGTH + w2 / (1.5 * PI) + w3 / 1.2
    assert run(ob.agacd, FIT_GRID, MIXED) == pytest.approx(want, rel=1e-6)
    # straight path: smoothness 0 floored at 0.1; safety 1 (no obstacle next to it)
    straight = [(0, 4), (1, 4), (2, 4)]
    want = w1 / 2 + w2 / 0.1 + w3 / 1.0
    assert run(ob.agacd, OPEN, straight) == pytest.approx(want, rel=1e-6)
    got = run(ob.agacd, OPEN, straight, smoothness_floor=0.5, weights=(1.0, 1.0, 0.0))
    assert got == pytest.approx(1 / 2 + 1 / 0.5)


def test_fitness_mpmga():
    """MPMGA eq. 3-5: F = alpha/length + beta*c/smoothness (alpha .8, beta .2, c 1)."""
    want = 0.8 / MIXED_LENGTH + 0.2 * 1 / 155
    assert run(ob.mpmga, FIT_GRID, MIXED) == pytest.approx(want, rel=1e-6)
    assert run(ob.mpmga, OPEN, STAIRCASE) == pytest.approx(0.8 / (4 * S2) + 0.2 / 0.1)


def test_fitness_iga_zhu():
    """Zhu & Pan eq. 6: F = 1 / (omega L + (1 - omega) fit_2), omega 0.7."""
    want = 1 / (0.7 * MIXED_LENGTH + 0.3 * 6)
    assert run(ob.iga_zhu, FIT_GRID, MIXED) == pytest.approx(want, rel=1e-6)


def test_fitness_iga_zhang():
    """Zhang eq. 2: F = 1 / (L + a m k), k = (v - vt) pi r / (2 v vt) = pi/4 by default."""
    want = 1 / (MIXED_LENGTH + 2 * 3 * PI / 4)
    assert run(ob.iga_zhang, FIT_GRID, MIXED) == pytest.approx(want, rel=1e-6)
    k = (2.0 - 1.0) * PI * 1.0 / (2 * 2.0 * 1.0)
    got = run(ob.iga_zhang, FIT_GRID, MIXED, a=3.0, v=2.0, v_t=1.0, r=1.0)
    assert got == pytest.approx(1 / (MIXED_LENGTH + 3 * 3 * k), rel=1e-6)


def test_fitness_sga():
    """The plain GA: F = 1 / length; a one-node path is finite (denominator floor)."""
    assert run(ob.sga, FIT_GRID, MIXED) == pytest.approx(1 / MIXED_LENGTH, rel=1e-6)
    assert np.isfinite(run(ob.sga, OPEN, [(0, 0)]))
    assert np.isfinite(run(ob.imga, OPEN, [(0, 0)]))


def test_infeasible_is_zero():
    """Infeasible individuals have fitness 0 (population of 3, middle infeasible)."""
    paths = [make_path(p) for p in (MIXED, STAIRCASE, KNIGHT)]
    cells = jnp.stack([c for c, _ in paths])
    length = jnp.stack([n for _, n in paths])

    @jax.jit
    def both(grid, cells, length, feasible):
        plain = [population_map(fn)(grid, cells, length) for fn in COMBINERS]
        masked = [population_map(fn)(grid, cells, length, feasible) for fn in COMBINERS]
        return plain, masked

    plain, masked = both(FIT_GRID, cells, length, jnp.array([True, False, True]))
    for fn, p, m in zip(COMBINERS, plain, masked, strict=True):
        assert np.all(np.asarray(p) > 0), fn.__name__
        np.testing.assert_array_equal(m, np.asarray(p) * np.array([1, 0, 1]), fn.__name__)
    # a scalar flag works too
    c, n = make_path(MIXED)
    assert float(jax.jit(ob.sga)(FIT_GRID, c, n, False)) == 0.0


def test_combiner_parameters_can_be_traced():
    """Weights may be traced: vmap over IMGA's (a, b, c) and AGACD's weight vector."""
    cells, n = make_path(MIXED)

    def f(a):
        return ob.imga(FIT_GRID, cells, n, a=a)

    got = jax.jit(jax.vmap(f))(jnp.array([6.0, 1.0]))
    np.testing.assert_allclose(
        got, [1 / (6 * MIXED_LENGTH + 25), 1 / (MIXED_LENGTH + 25)], rtol=1e-6
    )
    ws = jnp.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    got = jax.jit(jax.vmap(lambda w: ob.agacd(FIT_GRID, cells, n, weights=w)))(ws)
    np.testing.assert_allclose(got, [1 / MIXED_LENGTH, 1 / 1.2], rtol=1e-6)


def _assert_same(a, b, what: str) -> None:
    for fn, x, y in zip(ALL_PER_PATH, a, b, strict=True):
        np.testing.assert_array_equal(x, y, err_msg=f"{what}: {fn.__name__}")


def _population16(paths: list[tuple[jax.Array, jax.Array]]) -> list[tuple]:
    """Six capacity-16 paths through the one compiled population function, split by row."""
    cells = jnp.stack([c for c, _ in paths])
    length = jnp.stack([n for _, n in paths])
    pop = _all_values_pop(FIT_GRID, cells, length)
    rows = [tuple(np.asarray(v)[i] for v in pop) for i in range(len(paths))]
    # turn_angles has one entry per node: beyond the 12 of the reference it must be 0
    k = ALL_PER_PATH.index(ob.turn_angles)
    for r in rows:
        assert not np.any(r[k][12:])
    return [r[:k] + (r[k][:12],) + r[k + 1 :] for r in rows]


def test_padding_invariance():
    """The same path with capacity 12 and 16, and with padding that does not
    repeat the last cell, gives identical values for every function."""
    paths = [MIXED, KNIGHT, L_SHAPE]
    rows = _population16(
        [make_path(p, cap=16) for p in paths] + [make_path(p, cap=16, pad=24) for p in paths]
    )
    for i, p in enumerate(paths + paths):
        _assert_same(rows[i], _all_values(FIT_GRID, *make_path(p)), f"path {i}")


def test_population_equals_per_path():
    """population_map(fn) (vmap over paths) equals fn on each path."""
    paths = [MIXED, KNIGHT, STAIRCASE, [(4, 4)], AROUND, L_SHAPE]
    rows = _population16([make_path(p, cap=16) for p in paths])
    for i, p in enumerate(paths):
        _assert_same(rows[i], _all_values(FIT_GRID, *make_path(p)), f"path {i}")


def test_x64_mode_dtypes_and_values():
    """With JAX_ENABLE_X64=1 results stay float32/int32 and equal the x32 values."""
    script = textwrap.dedent(
        """
        import jax, jax.numpy as jnp, numpy as np
        from jaxga import Grid
        from jaxga.core import objectives as ob
        assert jax.config.jax_enable_x64
        b = np.zeros((5, 5), bool); b[0, 3] = b[3, 0] = True
        g = Grid.create(b, start=(0, 0), goal=(4, 4), corner_rule="free")
        xy = [(0, 0), (1, 0), (2, 1), (1, 2), (1, 2), (2, 2), (3, 2)]
        c = jnp.array([y * 5 + x for x, y in xy] + [17] * 3, jnp.int32)
        n = jnp.int32(len(xy))
        fs = (ob.angle_sum, ob.turns, ob.imga_energy, ob.agacd, ob.min_clearance)
        vals = jax.jit(lambda g, c, n: [f(g, c, n) for f in fs])(g, c, n)
        for f, v in zip(fs, vals):
            assert v.dtype in (jnp.float32, jnp.int32), (f.__name__, v.dtype)
        out = [float(v) for v in vals]
        print(repr(out))
        """
    )
    env = dict(os.environ, JAX_ENABLE_X64="1", JAX_PLATFORMS="cpu")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    res = subprocess.run(
        [sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    got = eval(res.stdout.strip().splitlines()[-1])
    want = [
        1.5 * PI,
        3,
        5,
        1.68 / 4.08 / MIXED_LENGTH + 1.4 / 4.08 / (1.5 * PI) + 1 / 4.08 / 1.2,
        math.sqrt(0.5),
    ]
    np.testing.assert_allclose(got, want, rtol=1e-6)


def test_map_too_large_for_int32_products():
    """Maps with a side above 32767 are rejected at trace time (int32 cross products)."""
    grid = Grid.create(np.zeros((1, 40000), bool), start=(0, 0), goal=(5, 0))
    with pytest.raises(ParameterError):
        ob.path_length(grid, jnp.zeros(4, jnp.int32), jnp.int32(2))


# ------------------------------------------------------------------- properties
SIZE, CAP = 8, 10
_props = jax.jit(
    population_map(
        lambda g, c, n: (
            ob.path_length(g, c, n),
            ob.turn_angles(g, c, n),
            ob.mpmga_penalty(g, c, n),
            ob.zhu_penalty(g, c, n),
            ob.turns(g, c, n),
        )
    )
)
_PROP_GRID = Grid.create(np.zeros((SIZE, SIZE), bool))

waypoint_paths = st.lists(
    st.tuples(st.integers(0, SIZE - 1), st.integers(0, SIZE - 1)), min_size=1, max_size=CAP
)


def _reference_angles(xy: np.ndarray) -> list[float]:
    """Turn angles in float64 from arccos of normalised dot products, repeats skipped."""
    keep = [0] + [i for i in range(1, len(xy)) if tuple(xy[i]) != tuple(xy[i - 1])]
    p = xy[keep].astype(float)
    out = []
    for i in range(1, len(p) - 1):
        u, v = p[i] - p[i - 1], p[i + 1] - p[i]
        out.append(math.acos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))
    return out


@given(st.lists(waypoint_paths, min_size=1, max_size=6))
def test_properties_waypoint_paths(paths):
    """Length >= |goal - start|; angles in [0, pi] and equal to arccos references;
    MPMGA/Zhu buckets equal float64 classifications; turns = #angles > 0."""
    paths = (paths * 6)[:6]  # a fixed population size: one compilation
    stacked = [make_path(p, cap=CAP, width=SIZE) for p in paths]
    cells = jnp.stack([c for c, _ in stacked])
    length = jnp.stack([n for _, n in stacked])
    lens, angles, mp, zh, nt = (np.asarray(v) for v in _props(_PROP_GRID, cells, length))
    for i, p in enumerate(paths):
        xy = np.asarray(p)
        assert lens[i] >= np.hypot(*(xy[-1] - xy[0])) - 1e-5
        assert np.all((angles[i] >= 0) & (angles[i] <= np.float32(PI)))
        ref = np.array(_reference_angles(xy))
        got = angles[i][angles[i] > 0]
        nonzero = ref[ref > 1e-6]  # arccos of collinear segments gives ~1e-8, not 0
        assert nt[i] == len(nonzero) == len(got)
        np.testing.assert_allclose(np.sort(got), np.sort(nonzero), atol=2e-6)
        tol = 1e-9
        want_mp = sum(5 if a < PI / 2 - tol else 25 if a < PI / 2 + tol else 125 for a in nonzero)
        want_zh = sum(1 if a < PI / 4 + tol else 2 if a < PI / 2 + tol else 3 for a in nonzero)
        assert mp[i] == want_mp and zh[i] == want_zh


@given(st.lists(st.sampled_from(range(8)), min_size=1, max_size=CAP - 1), st.integers(0, 63))
def test_agacd_angle_formula_matches_continuous_paths(dirs, start):
    """On continuous paths angle_sum equals AGACD eq. 11-17 (slopes + law of cosines),
    away from the 180-degree reversal that eq. 13 maps to 0 (equal slopes)."""
    d = np.array([(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)])
    xy = [np.array([start % SIZE, start // SIZE])]
    for k in dirs:
        xy.append(np.clip(xy[-1] + d[k], 0, SIZE - 1))
    xy = np.array(xy)
    total, reversal = 0.0, False
    keep = [0] + [i for i in range(1, len(xy)) if tuple(xy[i]) != tuple(xy[i - 1])]
    p = xy[keep].astype(float)
    for i in range(1, len(p) - 1):
        (x0, y0), (x1, y1), (x2, y2) = p[i - 1], p[i], p[i + 1]
        k1 = math.inf if x1 == x0 else (y1 - y0) / (x1 - x0)  # eq. 11
        k2 = math.inf if x2 == x1 else (y2 - y1) / (x2 - x1)  # eq. 12
        a1 = (x0 - x1) ** 2 + (y0 - y1) ** 2  # eq. 14
        b1 = (x2 - x1) ** 2 + (y2 - y1) ** 2
        c1 = (x0 - x2) ** 2 + (y0 - y2) ** 2
        alpha = math.acos(np.clip((a1 + b1 - c1) / (2 * math.sqrt(a1) * math.sqrt(b1)), -1, 1))
        reversal |= alpha < 1e-6
        total += 0.0 if k1 == k2 else PI - alpha  # eq. 13 (k1 = k2 also covers inf = inf)
    if reversal:
        return
    cells, n = make_path([tuple(q) for q in xy], cap=CAP, width=SIZE)
    got = float(_jitted(ob.angle_sum, ())(_PROP_GRID, cells, n))
    assert got == pytest.approx(total, abs=1e-5)


def test_min_clearance_agrees_with_the_host_measure_of_the_map_as_loaded():
    """:func:`ob.min_clearance` (float32, band then straight runs against the whole
    map) equals :class:`jaxga.maps.clearance.ObstacleClearance` (float64, pruned by a
    distance transform), two independent exact measures, on shortest paths between random
    cells of maps with a few small obstacles: paths near them (the band) and far from all
    of them (the whole map)."""
    from jaxga.maps.clearance import ObstacleClearance
    from jaxga.reference.optima import shortest_path_np

    rng = np.random.default_rng(1)
    h, w, cap = 40, 50, 120
    measure = jax.jit(jax.vmap(ob.min_clearance, (None, 0, 0)))
    far = 0
    for _ in range(3):
        b = np.zeros((h, w), bool)
        for _ in range(3):
            x, y = rng.integers(0, w - 3), rng.integers(0, h - 2)
            b[y:y + 2, x:x + 3] = True
        grid = Grid.create(b)
        free = np.argwhere(~b)[:, ::-1]
        paths = [np.asarray(shortest_path_np(b, tuple(free[i]), tuple(free[j]), "strict").path)
                 for i, j in rng.integers(len(free), size=(8, 2)) if i != j]
        cells = np.zeros((len(paths), cap), np.int32)
        for k, p in enumerate(paths):
            cells[k, :len(p)] = p[:, 1] * w + p[:, 0]
        got = np.asarray(measure(grid, cells, np.array([len(p) for p in paths], np.int32)))
        want = [ObstacleClearance(b).of_path(p) for p in paths]
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-5)
        far += sum(v > clearance.CLEARANCE_RADIUS for v in want)
    assert far >= 3  # the whole-map search was exercised
