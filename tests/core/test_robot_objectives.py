"""Robot objectives in metres (jaxga.core.robot_objectives): exact values on hand-made
paths, the clearance equal to the exact widest path's definition, and the same results
one path at a time and for a population under jit and vmap."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga.core.grid import Grid
from jaxga.core.robot_objectives import ROBOT_OBJECTIVES, minimised, robot_objectives
from jaxga.maps.clearance import cell_clearance
from jaxga.reference.maximin import maximin_path_np

BLOCKED = np.zeros((7, 11), bool)
BLOCKED[3, 5] = True  # one obstacle in the middle of an 11 x 7 map
GRID = Grid.create(BLOCKED, start=(1, 3), goal=(9, 3), corner_rule="strict")
FIELD = jnp.asarray(cell_clearance(BLOCKED), jnp.float32)
objectives = jax.jit(robot_objectives, static_argnames=())


def cells_of(path, capacity=16):
    idx = [y * 11 + x for x, y in path]
    return jnp.asarray(idx + [idx[-1]] * (capacity - len(idx)), jnp.int32), jnp.int32(len(idx))


def test_a_path_around_the_obstacle_in_metres():
    """(1,3) up to (1,5), east to (9,5), down to (9,3); 0.05 m cells, a 0.1 m band."""
    path = [(1, 3), (1, 4), (1, 5)] + [(x, 5) for x in range(2, 10)] + [(9, 4), (9, 3)]
    cells, n = cells_of(path)
    r = objectives(GRID, cells, n, FIELD, cell_size=0.05, band=0.1)
    assert float(r.length) == pytest.approx(12 * 0.05)
    assert float(r.clearance) == pytest.approx(1.5 * 0.05)  # (5, 5): 1.5 cells above
    # within 2 cells of the block: (5, 5) at 1.5 cells; its neighbours (4, 5), (6, 5) at
    # hypot(0.5, 1.5) = 1.58 cells; (4,4)... are not on the path. Depth in cells:
    # 0.5 at (5,5), 0.42 at (4,5) and (6,5); trapezoids of one cell each side of them
    d = 2 - math.hypot(0.5, 1.5)
    expected = (0.5 * d + 0.5 * (d + 0.5) + 0.5 * (0.5 + d) + 0.5 * d) * 0.05 ** 2
    assert float(r.intrusion) == pytest.approx(expected, rel=1e-5)
    assert float(r.turning) == pytest.approx(math.pi)  # two right angles
    assert float(r.max_turn) == pytest.approx(math.pi / 2)


def test_a_straight_path_far_from_obstacles_has_no_intrusion_and_no_turn():
    cells, n = cells_of([(x, 0) for x in range(11)])
    r = objectives(GRID, cells, n, FIELD, cell_size=1.0, band=1.0)
    assert float(r.length) == 10.0 and float(r.intrusion) == 0.0
    assert float(r.turning) == 0.0 and float(r.max_turn) == 0.0
    assert float(r.clearance) == 2.5  # (5, 0), three rows below the block


def test_the_clearance_is_the_widest_paths_measure():
    """The exact widest path's cells give the maximin clearance as their objective."""
    widest = maximin_path_np(BLOCKED, (1, 3), (9, 3), "strict")
    cells, n = cells_of([tuple(p) for p in widest.path])
    r = objectives(GRID, cells, n, FIELD)
    assert float(r.clearance) == widest.clearance == 2.5


def test_minimised_negates_the_clearance_and_a_population_is_one_vmap():
    paths = [[(x, 0) for x in range(11)], [(x, 2) for x in range(11)],
             [(1, 3), (1, 4), (1, 5)] + [(x, 5) for x in range(2, 10)] + [(9, 4), (9, 3)]]
    cells = jnp.stack([cells_of(p, 16)[0] for p in paths])
    lengths = jnp.stack([cells_of(p, 16)[1] for p in paths])
    batch = jax.jit(jax.vmap(robot_objectives, (None, 0, 0, None)))(GRID, cells, lengths, FIELD)
    for i in range(3):
        one = objectives(GRID, cells[i], lengths[i], FIELD)
        for name in ROBOT_OBJECTIVES:
            assert float(getattr(batch, name)[i]) == float(getattr(one, name)), name
    vec = minimised(objectives(GRID, cells[1], lengths[1], FIELD), ("length", "clearance"))
    assert vec.tolist() == [10.0, -0.5]  # (5, 2) is right below the block


def test_length_and_turning_are_the_papers_objectives_tied_in_any_order():
    """The length and the turning are :func:`jaxga.core.objectives.path_length` and
    :func:`jaxga.core.objectives.angle_sum` (AGACD eq. 9 and 10-17) to float32's
    rounding, and the same bits for the same steps and turns in any order: a front must
    see two paths of one length as tied (an ordered sum of 1, 1, 1, sqrt 2, sqrt 2,
    sqrt 2 rounds otherwise in this order than in that one)."""
    from jaxga.core.objectives import angle_sum, path_length

    path = [(1, 3), (2, 4), (3, 5)] + [(x, 5) for x in range(4, 10)] + [(9, 4), (8, 3)]
    cells, n = cells_of(path)
    r = objectives(GRID, cells, n, FIELD)
    assert float(r.length) == pytest.approx(float(jax.jit(path_length)(GRID, cells, n)),
                                            rel=1e-6)
    assert float(r.turning) == pytest.approx(float(jax.jit(angle_sum)(GRID, cells, n)),
                                             rel=1e-6)
    assert float(r.turning) == float(np.float32(4) * np.float32(math.pi / 4))  # 4 eighths
    open_grid = Grid.create(np.zeros((7, 11), bool), start=(0, 0), goal=(6, 3))
    diagonal_first = [(0, 0), (1, 1), (2, 2), (3, 2), (4, 2), (5, 2), (6, 3)]
    straight_first = [(0, 0), (1, 0), (2, 0), (3, 0), (4, 1), (5, 2), (6, 3)]
    lengths = []
    for path in (diagonal_first, straight_first):
        cells, n = cells_of(path)
        lengths.append(float(objectives(open_grid, cells, n, FIELD).length))
    assert lengths[0] == lengths[1] == float(np.float32(3) + np.float32(3)
                                             * np.float32(math.sqrt(2)))
