"""Map-size classes (decision 029): the padding of a map to its class keeps its cells and its
edge (runs on padded maps: tests/api/test_programs.py)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._runtime.size_classes import class_capacity, class_shape, map_cells, pad_to_class
from jaxga.core import objectives
from jaxga.core.grid import Grid
from jaxga.engine.algorithm import default_capacity


@pytest.mark.parametrize(("shape", "expected"), [
    ((1, 1), (32, 32)), ((20, 20), (32, 32)), ((25, 25), (32, 32)), ((32, 32), (32, 32)),
    ((33, 20), (64, 32)), ((20, 64), (32, 64)), ((64, 64), (64, 64)), ((65, 10), (128, 32)),
    ((10, 300), (32, 384)), ((384, 384), (384, 384)), ((500, 500), (512, 512)),
    ((307, 604), (384, 768)), ((200, 1024), (256, 1024)), ((100, 1025), (128, 1536)),
    ((945, 1165), (1024, 1536)), ((100, 2049), None),
])
def test_class_shape(shape, expected):
    assert class_shape(*shape) == expected


def test_class_capacity_is_the_class_s_unless_the_problem_needs_more():
    open_20 = Grid.create(np.zeros((20, 20), bool))
    assert class_capacity(open_20) == 160
    open_64 = Grid.create(np.zeros((64, 64), bool))
    assert class_capacity(open_64) == 320  # its own would be 192: the class's is larger
    # a serpentine 38 x 38 maze: 3 x its ~700-cell optimum is far over the class's 320
    maze = np.zeros((38, 38), bool)
    maze[1::4, :-1] = True
    maze[3::4, 1:] = True
    big = Grid.create(maze)
    assert class_capacity(big) == default_capacity(big) > 320


def test_padding_keeps_every_cell_s_coordinates():
    blocked = np.zeros((3, 5), bool)
    blocked[1, 2] = True
    grid = Grid.create(blocked, start=(1, 0), goal=(4, 2), corner_rule="no_squeeze")
    padded = pad_to_class(grid)
    assert padded.shape == (32, 32) and padded.corner_rule == "no_squeeze"
    assert padded.start_xy == (1, 0) and padded.goal_xy == (4, 2)
    b, out = padded.blocked_np(), np.asarray(padded.outside)
    np.testing.assert_array_equal(b[:3, :5], blocked)
    assert b[3:].all() and b[:, 5:].all()
    np.testing.assert_array_equal(out, b & ~np.pad(blocked, ((0, 29), (0, 27))))
    ys, xs = np.mgrid[:3, :5]
    np.testing.assert_array_equal(map_cells((ys * 32 + xs).ravel(), 32, 5),
                                  (ys * 5 + xs).ravel())
    # over the largest class: unchanged
    large = Grid.create(np.zeros((2049, 3), bool))
    assert pad_to_class(large) is large


@pytest.mark.slow
def test_the_padding_counts_as_off_the_map_for_safety_and_clearance():
    """A path along the map's top and right edges: the padding beyond them is blocked,
    but AGACD's and IMGA's safety, the clearance and the tangencies see the map's edge
    there, as without the padding (off-map cells free, or obstacles with
    ``border_blocked``)."""
    blocked = np.zeros((4, 4), bool)
    blocked[1, 1] = True
    grid = Grid.create(blocked, start=(0, 3), goal=(3, 0), corner_rule="free")
    padded = pad_to_class(grid)
    xy = [(0, 3), (1, 3), (2, 3), (3, 3), (3, 2), (3, 1), (3, 0)]
    cells = jnp.asarray([y * 4 + x for x, y in xy] + [0] * 3, jnp.int32)
    length = jnp.int32(len(xy))
    padded_cells = jnp.asarray(map_cells(np.asarray(cells), 4, 32), jnp.int32)
    for border in (False, True):
        for f in (objectives.agacd_safety, objectives.imga_safety, objectives.min_clearance):
            a = f(grid, cells, length, border_blocked=border)
            b = f(padded, padded_cells, length, border_blocked=border)
            assert float(a) == float(b), (f.__name__, border)
    # hand values: no node is 8-adjacent to the obstacle (1, 1), every node to the edge;
    # the obstacle's square is 1.5 from the path, the edge 0.5
    assert float(objectives.imga_safety(padded, padded_cells, length)) == 0.0
    assert float(objectives.imga_safety(padded, padded_cells, length,
                                        border_blocked=True)) == 5.0 * len(xy)
    assert float(objectives.min_clearance(padded, padded_cells, length)) == 1.5
    assert float(objectives.min_clearance(padded, padded_cells, length,
                                          border_blocked=True)) == 0.5
    np.testing.assert_array_equal(
        np.asarray(objectives.metrics(padded, padded_cells, length)),
        np.asarray(objectives.metrics(grid, cells, length)))


def test_by_default_maps_over_64_a_side_are_padded_and_the_papers_maps_are_not():
    from jaxga._runtime.size_classes import auto_size_class
    from jaxga.maps import load_map

    assert not auto_size_class(load_map("classic_ga_gapp3_20x20"))
    assert not auto_size_class(Grid.create(np.zeros((64, 50), bool)))
    assert auto_size_class(Grid.create(np.zeros((65, 3), bool)))
    assert auto_size_class(Grid.create(np.zeros((3, 384), bool)))


def test_distance_fields_padded_with_the_map_are_the_padded_maps_own():
    """A map's distance fields padded with infinity equal the fields computed on the padded
    map (its padding is blocked: unreachable), bit for bit, so a run computes them once."""
    from jaxga.maps import random_map
    from jaxga.operators.guide import with_guide

    for seed in range(3):
        grid = random_map(70, 90, 0.25, seed=seed)
        padded_fields = pad_to_class(with_guide(grid)).guide
        own = with_guide(pad_to_class(grid)).guide
        for name in ("to_goal", "from_start"):
            np.testing.assert_array_equal(np.asarray(getattr(padded_fields, name)),
                                          np.asarray(getattr(own, name)))
