"""The exact fitness optimum (jaxga.reference.fitness) against brute force over every
simple path of small maps, scored by the GA's own fitness functions (jaxga.core.objectives)."""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxga.config.presets import load_preset
from jaxga.core import objectives
from jaxga.core.errors import ParameterError
from jaxga.core.grid import DIRECTIONS, Grid
from jaxga.maps import load_map
from jaxga.maps.preprocess import legal_moves
from jaxga.reference.fitness import (
    MAX_CELLS,
    SUPPORTED_METHODS,
    fitness_optimum,
    fitness_optimum_np,
    fitness_weights,
    path_fitness_np,
)
from jaxga.reference.optima import shortest_path

H, W = 3, 4
L = H * W  # a simple path has at most every cell
CHUNK = 4096
MAX_PATHS = 100_000


def _simple_paths(blocked: np.ndarray, start: int, goal: int, rule: str) -> list[list[int]]:
    """Every path of legal 8-connected moves from start to goal that repeats no cell."""
    h, w = blocked.shape
    legal = legal_moves(blocked, rule).reshape(8, -1)
    nbrs = [[c + int(dy) * w + int(dx) for d, (dx, dy) in enumerate(DIRECTIONS.tolist())
             if legal[d, c]] for c in range(h * w)]
    out: list[list[int]] = []
    path, seen = [start], [False] * (h * w)
    seen[start] = True

    def dfs(u: int) -> None:
        if len(out) > MAX_PATHS:
            return
        if u == goal:
            out.append(list(path))
            return
        for v in nbrs[u]:
            if not seen[v]:
                seen[v] = True
                path.append(v)
                dfs(v)
                path.pop()
                seen[v] = False

    dfs(start)
    return out


@functools.cache
def _scorer(method: str):
    """jaxga's fitness over a batch of paths (the objectives do not read the corner rule,
    which only decides which paths exist: one compiled program per method)."""
    fn = getattr(objectives, method)

    @jax.jit
    def score(blocked, start, goal, cells, length, weights):
        grid = Grid(blocked=blocked, start=start, goal=goal, corner_rule="free")
        return jax.vmap(lambda c, n: fn(grid, c, n, **weights))(cells, length)

    return score


def _padded(paths: list[list[int]]) -> tuple[np.ndarray, np.ndarray]:
    cells = np.array([p + [p[-1]] * (L - len(p)) for p in paths], np.int32)
    return cells, np.array([len(p) for p in paths], np.int32)


def _scores(grid: Grid, method: str, weights: dict, paths: list[list[int]]) -> np.ndarray:
    """jaxga's fitness of every path, in fixed-size chunks (one compiled program)."""
    score = _scorer(method)
    w = {k: jnp.float32(v) for k, v in weights.items()}
    out = []
    for i in range(0, len(paths), CHUNK):
        part = paths[i : i + CHUNK]
        part = part + [part[-1]] * (CHUNK - len(part))
        cells, length = _padded(part)
        out.append(np.asarray(score(grid.blocked, grid.start, grid.goal, cells, length, w)))
    return np.concatenate(out)[: len(paths)]


def _jaxga_fitness(grid: Grid, method: str, weights: dict, path_xy: np.ndarray) -> float:
    cells = [int(y) * grid.width + int(x) for x, y in path_xy.tolist()]
    return float(_scores(grid, method, weights, [cells])[0])


WEIGHTS = {  # the papers' weights and other settings per method
    "sga": [{}],
    "iga_zhu": [{}, {"omega": 0.3, "c1": 2.0, "c2": 2.5, "c3": 7.0}],
    "iga_zhang": [{}, {"a": 5.0, "v": 1.0, "v_t": 0.25, "r": 1.0}],
    "imga": [{}, {"a": 1.0, "b": 2.0, "c": 4.0}],
    "mpmga": [{}, {"alpha": 0.2, "beta": 0.8, "c": 2.0, "smoothness_floor": 0.1},
              {"alpha": 1.0, "beta": 0.05, "c": 1.0, "smoothness_floor": 0.1}],
}


def _full(method: str, weights: dict) -> dict:
    from jaxga.reference.fitness import DEFAULT_WEIGHTS

    return {**DEFAULT_WEIGHTS[method], **weights}


@settings(max_examples=40)
@given(
    bits=st.integers(0, 2**L - 1),
    density=st.sampled_from([0.0, 0.2, 0.35]),
    ends=st.tuples(st.integers(0, L - 1), st.integers(0, L - 1)),
    rule=st.sampled_from(["free", "no_squeeze", "strict"]),
    method=st.sampled_from(SUPPORTED_METHODS),
    which=st.integers(0, 2),
)
def test_the_optimum_is_the_best_simple_path_by_brute_force(bits, density, ends, rule,
                                                            method, which):
    rng = np.random.default_rng(bits)
    blocked = rng.random((H, W)) < density
    start, goal = ends
    blocked.reshape(-1)[[start, goal]] = False
    weights = _full(method, WEIGHTS[method][which % len(WEIGHTS[method])])
    grid = Grid(blocked=jnp.asarray(blocked), start=jnp.int32(start), goal=jnp.int32(goal),
                corner_rule=rule)
    opt = fitness_optimum(grid, method, **weights)
    if start == goal:
        assert not opt.found and "start equals goal" in opt.reason
        return
    paths = _simple_paths(blocked, start, goal, rule)
    if not paths:
        assert not opt.found and "unreachable" in opt.reason
        return
    assert len(paths) <= MAX_PATHS
    scores = _scores(grid, method, weights, paths)
    best = float(scores.max())
    # the search's cost model is the GA's fitness, path by path (a sample of the paths)
    for i in rng.choice(len(paths), size=min(len(paths), 300), replace=False):
        q = np.array(paths[i])
        xy = np.stack([q % W, q // W], axis=1)
        assert math.isclose(path_fitness_np(blocked, grid.goal_xy, method, weights, xy),
                            float(scores[i]), rel_tol=1e-5), (method, paths[i])
    assert opt.found, opt.reason
    # the optimum's own path: start to goal, legal moves, scored the same by jaxga
    p = opt.path
    assert tuple(p[0]) == grid.start_xy and tuple(p[-1]) == grid.goal_xy
    legal = legal_moves(blocked, rule)
    for (x0, y0), (x1, y1) in zip(p[:-1].tolist(), p[1:].tolist()):
        d = [tuple(v) for v in DIRECTIONS.tolist()].index((x1 - x0, y1 - y0))
        assert legal[d, y0, x0]
    assert math.isclose(_jaxga_fitness(grid, method, weights, p), opt.fitness, rel_tol=1e-5)
    assert math.isclose(opt.length, float(np.sum(np.hypot(*np.diff(p, axis=0).T))),
                        rel_tol=1e-12)
    # no simple path is better; when the optimal walk is simple, one is as good
    assert best <= opt.fitness * (1 + 1e-5)
    if opt.loop_free:
        assert math.isclose(best, opt.fitness, rel_tol=1e-5)


def test_zhu_pan_map_3_optimum_is_a_shortest_path_with_two_45_degree_turns():
    grid = load_map("classic_ga_gapp3_20x20", corner_rule="free")
    opt = fitness_optimum(grid, "iga_zhu")
    assert opt.found and opt.loop_free
    assert math.isclose(opt.length, 14 + 12 * math.sqrt(2))  # 30.9706, the 8-connected optimum
    # cost 0.7 * 30.9706 + 0.3 * (c1 + c1): two 45-degree turns
    assert math.isclose(1 / opt.fitness, 0.7 * opt.length + 0.3 * 2.0)


def test_zhu_pan_map_4_optimum_is_longer_than_the_shortest_path():
    grid = load_map("routeplanning_yangbo_20x20", corner_rule="free")
    opt = fitness_optimum(grid, "iga_zhu")
    assert math.isclose(shortest_path(grid).length, 12 + 13 * math.sqrt(2))  # 30.3848
    assert math.isclose(opt.length, 16 + 11 * math.sqrt(2))  # 31.5563: fewer turns pay
    assert math.isclose(1 / opt.fitness, 0.7 * opt.length + 0.3 * 4.0)  # four 45-degree turns
    # with omega = 1 the fitness is 1 / length again
    assert math.isclose(fitness_optimum(grid, "iga_zhu", omega=1.0).length,
                        shortest_path(grid).length)


def test_hand_made_open_map():
    # 5 x 3 open map, (0, 0) -> (4, 2): two diagonals and two straight steps, one
    # 45-degree turn, is both shortest and least turning
    blocked = np.zeros((3, 5), bool)
    length = 2 * math.sqrt(2) + 2
    cases = {
        "sga": length,
        "iga_zhu": 0.7 * length + 0.3 * 1.0,
        "iga_zhang": length + 2.0 * (1.0 - 0.5) * math.pi * 0.5 / (2 * 1.0 * 0.5),
    }
    for method, cost in cases.items():
        opt = fitness_optimum_np(blocked, (0, 0), (4, 2), "strict", method)
        assert math.isclose(1 / opt.fitness, cost), method
        assert math.isclose(opt.length, length)
    # MPMGA: 0.8 / length + 0.2 / 5 (one turn below 90 degrees costs 5)
    opt = fitness_optimum_np(blocked, (0, 0), (4, 2), "strict", "mpmga")
    assert math.isclose(opt.fitness, 0.8 / length + 0.2 / 5)
    # a straight line has smoothness 0, floored at 0.1
    opt = fitness_optimum_np(blocked, (0, 1), (4, 1), "strict", "mpmga")
    assert math.isclose(opt.fitness, 0.8 / 4 + 0.2 / 0.1) and opt.length == 4


def test_preset_weights_are_read_from_the_configuration():
    method, w = fitness_weights(load_preset("iga_zhu"))
    assert method == "iga_zhu" and w == {"omega": 0.7, "c1": 1.0, "c2": 2.0, "c3": 3.0}
    method, w = fitness_weights(load_preset("iga_zhu", overrides={"fitness.omega": 0.5}))
    assert w["omega"] == 0.5
    method, w = fitness_weights(load_preset("mpmga"))
    assert method == "mpmga" and w["alpha"] == pytest.approx(0.8)


def test_mpmga_optimum_in_a_later_layer_than_the_smoothest_path():
    # the smoothest path (smoothness 30) is longer than one with smoothness 35; with
    # alpha = 1, beta = 0.05 the shorter one wins (found by brute force over 50 paths)
    blocked = np.array([[0, 0, 0, 0, 0], [0, 0, 1, 0, 1], [1, 0, 0, 0, 0], [0, 1, 1, 0, 0]],
                       bool)  # row 0 at the bottom
    w = {"alpha": 1.0, "beta": 0.05, "c": 1.0, "smoothness_floor": 0.1}
    r = fitness_optimum_np(blocked, (0, 0), (4, 3), "strict", "mpmga", w)
    # diagonal, up (45), right (90), right, diagonal (45): 5 + 25 + 5
    assert r.path.tolist() == [[0, 0], [1, 1], [1, 2], [2, 2], [3, 2], [4, 3]]
    assert r.fitness == pytest.approx(1 / (3 + 2 * math.sqrt(2)) + 0.05 / 35)
    paths = _simple_paths(blocked, 0, 19, "strict")
    values = [path_fitness_np(blocked, (4, 3), "mpmga", w,
                              np.stack([np.array(p) % 5, np.array(p) // 5], axis=1))
              for p in paths]
    assert max(values) == pytest.approx(r.fitness)


def test_mpmga_search_gives_up_beyond_its_layer_budget(monkeypatch):
    import jaxga.reference.fitness as fr

    # a zigzag corridor: every path turns at least 4 times by 90 degrees (smoothness 100)
    blocked = np.array([[0, 0, 0, 0, 0], [1, 1, 1, 1, 0], [0, 0, 0, 0, 0],
                        [0, 1, 1, 1, 1], [0, 0, 0, 0, 0]], bool)
    r = fitness_optimum_np(blocked, (0, 0), (4, 4), "strict", "mpmga")
    assert r.found and r.length == 16 and r.fitness == pytest.approx(0.8 / 16 + 0.2 / 100)
    monkeypatch.setattr(fr, "MAX_LAYER_STATES", 8 * 25 * 10)  # 10 layers: smoothness < 50
    r = fitness_optimum_np(blocked, (0, 0), (4, 4), "strict", "mpmga")
    assert not r.found and "more than 10 smoothness layers" in r.reason


def test_a_walk_that_revisits_a_cell_is_flagged_as_a_bound():
    # reversals cost c4 = c3 = 1 and 45 / 90-degree turns 100: the optimal walk goes up
    # the left column, reverses and turns once (found by a review of this module)
    blocked = np.zeros((4, 4), bool)
    blocked[0, 1] = blocked[2, 2] = True
    w = {"omega": 0.05, "c1": 100.0, "c2": 100.0, "c3": 1.0}
    r = fitness_optimum_np(blocked, (0, 0), (1, 3), "free", "iga_zhu", w)
    assert r.found and not r.loop_free
    assert len({tuple(p) for p in r.path.tolist()}) < len(r.path)
    paths = _simple_paths(blocked, 0, 13, "free")
    best = max(path_fitness_np(blocked, (1, 3), "iga_zhu", w,
                               np.stack([np.array(p) % 4, np.array(p) // 4], axis=1))
               for p in paths)
    assert best <= r.fitness * (1 + 1e-12)  # an upper bound of every simple path


def test_weights_are_checked_and_a_zero_cost_is_floored_as_the_ga_does():
    blocked = np.zeros((3, 5), bool)
    with pytest.raises(ParameterError, match="no weight omgea"):
        fitness_optimum_np(blocked, (0, 0), (4, 2), "free", "iga_zhu", {"omgea": 1.0})
    grid = Grid(blocked=jnp.asarray(blocked), start=jnp.int32(0), goal=jnp.int32(14),
                corner_rule="free")
    with pytest.raises(ParameterError, match="in the configuration"):
        fitness_optimum(grid, load_preset("iga_zhu"), omega=0.5)
    # omega = 0 and a straight path: cost 0, fitness 1 / EPS like jaxga.core.objectives
    r = fitness_optimum_np(blocked, (0, 1), (4, 1), "free", "iga_zhu", {"omega": 0.0})
    assert r.fitness == pytest.approx(1 / objectives.EPS)
    g = Grid(blocked=jnp.asarray(blocked), start=jnp.int32(5), goal=jnp.int32(9),
             corner_rule="free")
    assert r.fitness == pytest.approx(_jaxga_fitness(g, "iga_zhu", _full("iga_zhu", {
        "omega": 0.0}), r.path))


def test_what_is_not_computed_says_why():
    blocked = np.zeros((5, 5), bool)
    assert "waypoint" in fitness_optimum_np(blocked, (0, 0), (4, 4), "free", "agacd").reason
    big = np.zeros((1, MAX_CELLS + 1), bool)
    r = fitness_optimum_np(big, (0, 0), (5, 0), "free", "sga")
    assert not r.found and "cells" in r.reason and math.isnan(r.fitness)
    assert fitness_optimum_np(big, (0, 0), (5, 0), "free", "sga", max_cells=None).found
    r = fitness_optimum_np(np.zeros((128, 128), bool), (0, 0), (127, 127), "free", "mpmga")
    assert r.found and r.fitness == pytest.approx(0.8 / (127 * math.sqrt(2)) + 0.2 / 0.1)
    walled = blocked.copy()
    walled[:, 2] = True
    for method in SUPPORTED_METHODS:
        r = fitness_optimum_np(walled, (0, 0), (4, 4), "free", method)
        assert not r.found and "unreachable" in r.reason, method
        r = fitness_optimum_np(walled, (2, 0), (4, 4), "free", method)
        assert not r.found and "start cell (2, 0) is blocked" in r.reason, method
