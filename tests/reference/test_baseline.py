"""The deterministic baseline of a front (jaxga.reference.baseline): its two ends on a
hand-made map, and on random maps the invariants that make it a baseline (clear paths,
the widest no narrower than the widest path and no longer, the shortest the any-angle
optimum)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jaxga.core.grid import Grid
from jaxga.maps.clearance import ObstacleClearance
from jaxga.reference.any_angle import any_angle_shortest_path
from jaxga.reference.baseline import baseline, turning, widest_shortcut
from jaxga.reference.maximin import maximin_path
from jaxga.reference.optima import clear_np


def test_the_two_ends_around_one_block():
    """An 11 x 7 map with one blocked cell at (5, 3), from (1, 3) to (9, 3): the shortest
    end passes over the block through (5, 4), 2 * sqrt(17) long; the widest end keeps
    to the map's edge row, 2.5 cells from the block."""
    blocked = np.zeros((7, 11), bool)
    blocked[3, 5] = True
    grid = Grid.create(blocked, start=(1, 3), goal=(9, 3), corner_rule="strict")
    shortest, widest = baseline(grid)
    assert shortest.name == "shortest" and widest.name == "widest"
    assert shortest.path.tolist() in ([[1, 3], [5, 4], [9, 3]], [[1, 3], [5, 2], [9, 3]])
    assert shortest.length == pytest.approx(2 * math.sqrt(17))
    # the segment (1,3)-(5,4) passes the block's corner (4.5, 3.5) at |(3.5, 0.5) x (4, 1)|
    # / sqrt(17) = 1.5 / sqrt(17)
    assert shortest.clearance == pytest.approx(1.5 / math.sqrt(17))
    assert widest.clearance >= 2.5 - 1e-12  # along row 0 or 6 the block is 2.5 away
    assert widest.length > shortest.length
    assert shortest.turning == pytest.approx(2 * math.atan(0.25))
    assert widest.max_turn <= math.pi / 2


def test_turning_of_hand_made_paths():
    assert turning(np.array([[0, 0], [3, 0]])) == (0.0, 0.0)
    total, largest = turning(np.array([[0, 0], [2, 0], [2, 2], [0, 2]]))
    assert total == pytest.approx(math.pi) and largest == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("seed", range(6))
def test_baseline_invariants_on_random_maps(seed):
    rng = np.random.default_rng(seed)
    blocked = rng.random((14, 18)) < 0.22
    blocked[0, 0] = blocked[13, 17] = False
    grid = Grid.create(blocked, start=(0, 0), goal=(17, 13), corner_rule="no_squeeze")
    points = baseline(grid)
    widest_path = maximin_path(grid)
    if not widest_path.found:
        assert points == []
        return
    shortest, widest = points
    assert shortest.length == pytest.approx(any_angle_shortest_path(grid).length)
    clearance = ObstacleClearance(blocked)
    assert widest.clearance >= clearance.of_path(widest_path.path) - 1e-12
    assert widest.length <= widest_path.length + 1e-9
    for point in points:
        path = point.path
        assert tuple(path[0]) == (0, 0) and tuple(path[-1]) == (17, 13)
        assert all(clear_np(blocked, "no_squeeze", a, b) for a, b in zip(path, path[1:]))
    again = widest_shortcut(blocked, "no_squeeze", widest.path, clearance)
    np.testing.assert_array_equal(again, widest.path)  # a shortcut path stays as it is
