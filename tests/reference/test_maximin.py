"""The exact widest path (jaxga.reference.maximin): clearances against a brute force over
every blocked square, the bottleneck on hand-made maps and against an exhaustive search
over thresholds on random maps, and the path's invariants."""

from __future__ import annotations

import itertools
import math
from collections import deque

import numpy as np
import pytest

from jaxga.core.grid import Grid
from jaxga.maps.clearance import cell_clearance
from jaxga.reference.maximin import maximin_path, maximin_path_np


def brute_clearance(blocked: np.ndarray, border: bool) -> np.ndarray:
    """The least distance from each centre to every blocked unit square, one by one."""
    h, w = blocked.shape
    squares = [(x, y) for y in range(h) for x in range(w) if blocked[y, x]]
    if border:
        squares += [(x, y) for x in range(-1, w + 1) for y in (-1, h)]
        squares += [(x, y) for y in range(h) for x in (-1, w)]
    out = np.full((h, w), math.inf)
    for y, x in itertools.product(range(h), range(w)):
        for qx, qy in squares:
            d = math.hypot(max(abs(x - qx) - 0.5, 0.0), max(abs(y - qy) - 0.5, 0.0))
            out[y, x] = min(out[y, x], d)
    return out


MOVES = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)]


def legal(blocked: np.ndarray, rule: str, x: int, y: int, dx: int, dy: int) -> bool:
    h, w = blocked.shape
    nx, ny = x + dx, y + dy
    if not (0 <= nx < w and 0 <= ny < h) or blocked[ny, nx]:
        return False
    if dx and dy:
        sides = (blocked[y, x + dx], blocked[y + dy, x])
        return rule == "free" or (rule == "no_squeeze" and not all(sides)) or not any(sides)
    return True


def brute_bottleneck(blocked, start, goal, rule, border) -> float:
    """The largest threshold whose cells join start and goal, tried from the top."""
    c = brute_clearance(blocked, border)
    for t in sorted(set(c[~blocked].tolist()), reverse=True):
        if c[start[1], start[0]] < t or c[goal[1], goal[0]] < t:
            continue
        seen, todo = {start}, deque([start])
        while todo:
            x, y = todo.popleft()
            for dx, dy in MOVES:
                if legal(blocked, rule, x, y, dx, dy) and c[y + dy, x + dx] >= t \
                        and (x + dx, y + dy) not in seen:
                    seen.add((x + dx, y + dy))
                    todo.append((x + dx, y + dy))
        if goal in seen:
            return t
    return math.nan


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("border", [False, True])
def test_clearances_are_the_distances_to_the_nearest_square(seed, border):
    blocked = np.random.default_rng(seed).random((9, 13)) < 0.15
    np.testing.assert_allclose(cell_clearance(blocked, border), brute_clearance(blocked, border),
                               rtol=0, atol=1e-12)


def test_a_map_without_obstacles_has_infinite_clearance():
    assert np.isinf(cell_clearance(np.zeros((4, 5), bool))).all()
    assert cell_clearance(np.zeros((4, 5), bool), border_blocked=True)[0, 0] == 0.5


def test_a_hand_made_map_around_one_block():
    """An 11 x 7 map with one blocked cell at (5, 3), from (1, 3) to (9, 3): every path
    crosses column 5, whose widest cells are 2.5 from the block (y = 0 or 6); with the
    map's border blocked, 1.5 (y = 1 or 5, halfway between the block and the border)."""
    blocked = np.zeros((7, 11), bool)
    blocked[3, 5] = True
    grid = Grid.create(blocked, start=(1, 3), goal=(9, 3), corner_rule="strict")
    open_map = maximin_path(grid)
    assert open_map.found and open_map.clearance == 2.5
    walled = maximin_path(grid, border_blocked=True)
    assert walled.clearance == 1.5
    for result, border in ((open_map, False), (walled, True)):
        c = cell_clearance(blocked, border)
        path = result.path
        assert tuple(path[0]) == (1, 3) and tuple(path[-1]) == (9, 3)
        assert min(c[y, x] for x, y in path) == result.clearance
        steps = np.abs(np.diff(path, axis=0))
        assert (steps.max(axis=1) == 1).all()
        assert result.length == pytest.approx(
            sum(math.hypot(*s) for s in np.diff(path, axis=0)))


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("rule", ["free", "no_squeeze", "strict"])
def test_the_bottleneck_equals_an_exhaustive_search(seed, rule):
    rng = np.random.default_rng(100 + seed)
    blocked = rng.random((8, 11)) < 0.3
    blocked[0, 0] = blocked[7, 10] = False
    border = bool(seed % 2)
    got = maximin_path_np(blocked, (0, 0), (10, 7), rule, border)
    expected = brute_bottleneck(blocked, (0, 0), (10, 7), rule, border)
    if math.isnan(expected):
        assert not got.found and "unreachable" in got.reason
        return
    assert got.found and got.clearance == expected
    c = cell_clearance(blocked, border)
    assert min(c[y, x] for x, y in got.path) == expected
    for (x, y), (nx, ny) in zip(got.path[:-1], got.path[1:]):
        assert legal(blocked, rule, int(x), int(y), int(nx - x), int(ny - y))


def test_blocked_endpoints_are_a_reason_not_an_exception():
    blocked = np.zeros((3, 3), bool)
    blocked[0, 0] = True
    result = maximin_path_np(blocked, (0, 0), (2, 2))
    assert not result.found and "blocked" in result.reason and result.path.shape == (0, 2)


def test_the_clearance_to_a_maps_own_obstacles_on_its_inflated_grid():
    """Planned on the map inflated by one cell around its block (cells 4-6 x 2-4 blocked),
    measured to the block itself: the widest cells, rows 0 and 6, are 2.5 from the block
    and 1.5 from the inflated margin."""
    own = np.zeros((7, 11), bool)
    own[3, 5] = True
    inflated = np.zeros_like(own)
    inflated[2:5, 4:7] = True
    grid = Grid.create(inflated, start=(1, 3), goal=(9, 3), corner_rule="strict")
    assert maximin_path(grid, obstacles=own).clearance == 2.5
    assert maximin_path(grid).clearance == 1.5
    path = maximin_path(grid, obstacles=own).path
    assert not inflated[path[:, 1], path[:, 0]].any()  # the path avoids the inflated map



def test_the_same_problem_is_searched_once_and_another_one_again(monkeypatch):
    """A front run asks for one problem twice (its fields' band, then the result's
    maximin clearance): the second ask returns the remembered, read-only result; another
    map, other obstacles or other endpoints are searched afresh."""
    from jaxga._runtime import references

    searched = []
    real = maximin_path_np

    def counting(*args, **kwargs):
        searched.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(references, "maximin_path_np", counting)
    references._maximin_cached.cache_clear()
    b = np.zeros((9, 11), bool)
    b[2:7, 5] = True
    grid = Grid.create(b, start=(0, 4), goal=(10, 4), corner_rule="strict")
    first = references.maximin_reference(grid)
    again = references.maximin_reference(Grid.create(b.copy(), start=(0, 4), goal=(10, 4),
                                                     corner_rule="strict"))
    assert again is first and len(searched) == 1
    with pytest.raises(ValueError):
        first.path[0, 0] = 3  # shared by both callers: read-only
    moved_grid = Grid.create(b, start=(0, 3), goal=(10, 4), corner_rule="strict")
    moved = references.maximin_reference(moved_grid)
    own = np.zeros_like(b)
    own[4, 5] = True
    narrower = references.maximin_reference(grid, own)
    b2 = b.copy()
    b2[7, 5] = True
    walled_grid = Grid.create(b2, start=(0, 4), goal=(10, 4), corner_rule="strict")
    walled = references.maximin_reference(walled_grid)
    assert len(searched) == 4
    for got, grid_, obstacles in ((moved, moved_grid, None), (narrower, grid, own),
                                  (walled, walled_grid, None)):
        want = maximin_path(grid_, obstacles=obstacles)
        assert got.clearance == want.clearance and (got.path == want.path).all()
    assert not np.array_equal(walled.path, first.path)  # not the remembered answer
