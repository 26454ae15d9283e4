"""A front of length against clearance as a stage of the one engine (decision 045): the
survival stage's pieces on hand-made populations, the clearance walk, the fields a front
reads, the checks on its keys, and the invariants of a whole run of the ``pareto``
preset (every front point feasible and non-dominated, the ends against the exact
references, the JSON)."""

from __future__ import annotations

import dataclasses
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxga
from jaxga.api.result_fronts import knee
from jaxga.config.presets import load_preset
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.engine import build, unread_keys
from jaxga.engine.evolution import (
    IslandState,
    distinct,
    hypervolume_reference,
    survive,
)
from jaxga.maps.clearance import cell_clearance
from jaxga.operators.guide import (
    clearance_weighted_field,
    distance_fields,
    padded_guide,
    widest_field,
    with_front_fields,
)
from jaxga.operators.init import clearance_walk, field_descent
from jaxga.operators.pareto import domination_matrix
from jaxga.reference.maximin import maximin_path
from jaxga.reference.optima import clear_np

# A 16 x 14 room with a pillar: the short way passes it close, wide ways go round.
BLOCKED = np.zeros((14, 16), bool)
BLOCKED[5:9, 6:9] = True
BLOCKED[0, :] = BLOCKED[-1, :] = True
GRID = Grid.create(BLOCKED, start=(1, 7), goal=(14, 6), corner_rule="strict")


def test_distinct_keeps_the_first_of_equal_valid_vectors():
    obj = jnp.array([[1.0, 2.0], [1.0, 2.0], [0.0, 3.0], [1.0, 2.0], [0.0, 3.0]])
    valid = jnp.array([False, True, True, True, True])
    # slot 0 is invalid, so slot 1 is the first valid (1, 2); slot 3 copies it
    assert distinct(obj, valid).tolist() == [False, True, True, False, False]


def test_survival_keeps_the_front_then_crowding_then_copies_then_infeasible():
    """Parents and offspring of 3 each: 6 candidates, 3 survive."""
    cells = jnp.arange(6 * 4, dtype=jnp.int32).reshape(6, 4)
    obj = jnp.array([[5.0, -1.0],   # parent 0: dominated by offspring 0
                     [3.0, -3.0],   # parent 1: on the front
                     [9.0, -9.0],   # parent 2: infeasible
                     [4.0, -2.0],   # offspring 0: on the front
                     [3.0, -3.0],   # offspring 1: a copy of parent 1
                     [2.0, -1.0]])  # offspring 2: on the front
    feas = jnp.array([True, True, False, True, True, True])
    fit = 1.0 / obj[:, 0]

    def state(sl):
        return IslandState(cells[sl], jnp.full((3,), 4, jnp.int32), fit[sl], feas[sl], obj[sl])

    out = survive(state(slice(0, 3)), state(slice(3, 6)), jnp.ones(3, bool))
    # the front {1, 3, 5}: its extremes (1 and 5) have infinite crowding, then 3
    assert sorted(out.cells[:, 0].tolist()) == [4, 12, 20]
    assert out.feasible.all()
    # with two active slots the third is kept but inactive
    out2 = survive(state(slice(0, 3)), state(slice(3, 6)), jnp.array([True, True, False]))
    assert out2.feasible.tolist() == [True, True, False]
    assert float(out2.fitness[2]) == 0.0


def test_hypervolume_reference_lies_beyond_the_worst_valid_values():
    obj = jnp.array([[1.0, -4.0], [3.0, -2.0], [100.0, 100.0]])
    ref = hypervolume_reference(obj, jnp.array([True, True, False]))
    # worst 3 and -2, ranges 2 and 2: +0.2 each, + 1e-3 (1 + |worst|)
    np.testing.assert_allclose(ref, [3.0 + 0.2 + 0.004, -2.0 + 0.2 + 0.003], rtol=1e-6)
    assert hypervolume_reference(obj, jnp.zeros(3, bool)).tolist() == [0.0, 0.0]


def test_front_fields_and_their_padding():
    grid = with_front_fields(GRID, (0.0, 4.0), band=3.0)
    g = grid.guide
    n = GRID.n_cells
    field = cell_clearance(BLOCKED)
    np.testing.assert_allclose(np.asarray(g.clearance), field.reshape(-1).astype(np.float32))
    np.testing.assert_allclose(np.asarray(g.weighted[:n]),
                               widest_field(GRID, field, 3.0).astype(np.float32))
    to_goal, _, _ = distance_fields(GRID)
    np.testing.assert_allclose(np.asarray(g.weighted[n:2 * n]), to_goal.astype(np.float32))
    np.testing.assert_allclose(
        np.asarray(g.weighted[2 * n:]),
        clearance_weighted_field(GRID, field, 4.0, 3.0).astype(np.float32))
    assert float(g.band) == 3.0
    assert with_front_fields(grid, (1.0,), 9.0) is grid  # a grid keeps its fields
    padded = padded_guide(g, GRID.shape, ((0, 2), (0, 3)))
    planes = np.asarray(padded.weighted).reshape(3, 16, 19)
    assert np.isinf(planes[:, 14:, :]).all() and np.isinf(planes[:, :, 16:]).all()
    np.testing.assert_array_equal(planes[:, :14, :16].reshape(3, -1),
                                  np.asarray(g.weighted).reshape(3, -1))
    assert (np.asarray(padded.clearance).reshape(16, 19)[14:, :] == 0).all()


def _walks(grid, field, n=32):
    """``n`` walks from the start down ``field`` with no budget for detours."""
    walk = jax.jit(jax.vmap(lambda k: field_descent(k, grid, field, grid.start, 64, 0.0,
                                                    0.0)))
    return walk(jax.random.split(jax.random.key(0), n))


def _xy(cells, n):
    c = np.asarray(cells)[:int(n)]
    return np.stack([c % 16, c // 16], axis=1)


def test_the_weight_zero_field_gives_shortest_paths_and_the_widest_the_maximin():
    widest = maximin_path(GRID)
    grid = with_front_fields(GRID, (0.0,), band=widest.clearance)
    n = GRID.n_cells
    optimum = distance_fields(GRID)[0][int(GRID.start)]
    field = cell_clearance(BLOCKED)
    cells, length, ok = _walks(grid, grid.guide.weighted[n:])
    assert bool(ok.all())
    for c, k in zip(cells, length):
        xy = _xy(c, k)
        assert np.linalg.norm(np.diff(xy, axis=0), axis=1).sum() == pytest.approx(optimum,
                                                                                  rel=1e-6)
    cells, length, ok = _walks(grid, grid.guide.weighted[:n])
    assert bool(ok.all())
    for c, k in zip(cells, length):
        xy = _xy(c, k)
        assert field[xy[:, 1], xy[:, 0]].min() == pytest.approx(widest.clearance)
        assert np.linalg.norm(np.diff(xy, axis=0), axis=1).sum() == pytest.approx(
            widest.length, rel=1e-6)


def test_the_widest_field_of_an_unreachable_band_is_the_distance_field():
    field = cell_clearance(BLOCKED)
    np.testing.assert_array_equal(widest_field(GRID, field, 100.0), distance_fields(GRID)[0])


def test_the_clearance_walk_cannot_fail_and_draws_every_kind_of_walk():
    grid = with_front_fields(GRID, (64.0,), band=3.0)
    walk = jax.jit(jax.vmap(lambda k: clearance_walk(k, grid, 64, 0.5, 1.0)))
    cells, length, ok = walk(jax.random.split(jax.random.key(1), 128))
    assert bool(ok.all())
    field = cell_clearance(BLOCKED)
    least = []
    for c, k in zip(np.asarray(cells), np.asarray(length)):
        xy = _xy(c, k)
        assert tuple(xy[0]) == GRID.start_xy and tuple(xy[-1]) == GRID.goal_xy
        assert all(clear_np(BLOCKED, "strict", a, b) and np.abs(a - b).max() == 1
                   for a, b in zip(xy[:-1], xy[1:]))
        least.append(field[xy[:, 1], xy[:, 0]].min())
    assert min(least) < 1.0 < max(least)  # walks near the pillar and walks away from it


@pytest.mark.parametrize(("sets", "message"), [
    ({"islands.count": 2}, "islands.count must be 1"),
    ({"survival.objectives": ["length", "speed"]}, "2 or 3 distinct names"),
    ({"survival.objectives": ["length"]}, "2 or 3 distinct names"),
    ({"survival.objectives": ["length", "length"]}, "2 or 3 distinct names"),
])
def test_a_front_s_keys_are_checked(sets, message):
    config = load_preset("pareto").override(sets)
    with pytest.raises(ParameterError, match=message):
        build(config, GRID)


def test_the_clearance_walk_needs_a_front_and_a_front_s_keys_need_survival():
    hybrid = load_preset("hybrid")
    with pytest.raises(ParameterError, match="survival.method = 'nsga2'"):
        build(hybrid.override({"init.method": "clearance_walk"}), GRID)
    assert "survival.band" in unread_keys(hybrid)
    assert "survival.band" not in unread_keys(load_preset("pareto"))


@pytest.fixture(scope="module")
def front_run():
    return jaxga.run("pareto", GRID, seeds=3, generations=6)


@pytest.mark.slow  # a whole run of the pareto preset
def test_every_front_point_is_feasible_and_none_dominates_another(front_run):
    r = front_run
    widest = maximin_path(GRID)
    assert r.maximin_clearance == pytest.approx(widest.clearance)
    for i in range(3):
        points = r.front_points(i)
        assert len(points) >= 2
        names = r.front.names
        obj = np.array([[p[n] for n in names] for p in points])
        minimised = obj * np.where(np.array(names) == "clearance", -1.0, 1.0)
        dom = domination_matrix(jnp.asarray(minimised), jnp.ones(len(points), bool))
        assert not bool(dom.any())
        assert len({tuple(v) for v in minimised.tolist()}) == len(points)
        assert obj[:, 0].tolist() == sorted(obj[:, 0].tolist())
        field = cell_clearance(BLOCKED)
        for p in points:
            xy = np.asarray(p["path"])
            assert tuple(xy[0]) == GRID.start_xy and tuple(xy[-1]) == GRID.goal_xy
            assert all(clear_np(BLOCKED, "strict", a, b) and np.abs(a - b).max() == 1
                       for a, b in zip(xy[:-1], xy[1:]))
            assert p["clearance"] == pytest.approx(field[xy[:, 1], xy[:, 0]].min(), rel=1e-6)
            length = np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()
            assert p["length"] == pytest.approx(length, rel=1e-5)
        # no front path is wider than the exact widest path; the widest end reaches it here
        assert max(p["clearance"] for p in points) <= widest.clearance + 1e-6
        ends = r.front_ends(i)
        assert ends["widest_ratio"] == pytest.approx(1.0)
        assert ends["shortest_gap"] == pytest.approx(float(r.gap[i]))
        assert r.length[i] <= min(p["length"] for p in points) + 1e-4


@pytest.mark.slow  # a whole run of the pareto preset
def test_the_history_holds_the_hypervolume_and_the_json_the_front(front_run):
    r = front_run
    hv = r.history["hypervolume"]
    assert hv.shape == (3, 6) and (hv > 0).all()
    assert (r.front.initial_hypervolume > 0).all()
    np.testing.assert_allclose(r.front.gain(r.history), hv[:, -1] / r.front.initial_hypervolume)
    assert r.front_ends(0)["hypervolume_gain"] == pytest.approx(r.front.gain(r.history)[0])
    doc = json.loads(json.dumps(r.to_json()))
    assert doc["maximin_clearance"] == pytest.approx(r.maximin_clearance)
    run0 = doc["runs"][0]
    assert [p["length"] for p in run0["front"]] == pytest.approx(
        [p["length"] for p in r.front_points(0)])
    assert run0["front"][0]["path"][0] == list(GRID.start_xy)
    assert run0["front_ends"]["points"] == len(run0["front"])


@pytest.mark.slow  # a whole run of the pareto preset
def test_front_choice_knee_and_least_clearance(front_run):
    r = front_run
    points = r.front_points(0)
    assert r.front_choice(0) in points
    wide = max(p["clearance"] for p in points)
    assert r.front_choice(0, min_clearance=wide)["clearance"] == wide
    assert r.front_choice(0, min_clearance=wide + 1) is None
    chosen = r.front_choice(0, min_clearance=0.0)
    assert chosen is points[0] or chosen == points[0]
    assert r.front_point(0, "widest")["clearance"] == wide
    assert r.front_point(0, "shortest") == points[0]
    # a front of other objectives: the points chosen by the clearance are refused by name
    other = dataclasses.replace(r, front=dataclasses.replace(r.front,
                                                             names=("length", "turning")))
    for which in ("widest", 0.5):
        with pytest.raises(ParameterError, match="chosen by its clearance"):
            other.front_point(0, which)
    with pytest.raises(ParameterError, match="chosen by its clearance"):
        other.front_choice(0, min_clearance=0.5)
    assert other.front_point(0, "knee") in other.front_points(0)


def test_the_knee_is_the_point_farthest_beyond_the_line_towards_the_ideal():
    """Hand-made fronts of (length, clearance), minimised as (length, -clearance): the
    knee bulges towards the short-and-wide ideal; a point that another beats in these
    two (on the front for its turning) is never it, however far from the line; a front
    on the line, of two points or without obstacles (every clearance infinite) gives
    the shortest end."""
    front = [(41.142, 0.5), (41.971, 0.707), (43.385, 0.707), (43.728, 1.5),
             (45.142, 2.121), (46.314, 2.5)]
    minimised = [(length, -clear) for length, clear in front]
    # (43.385, 0.707) lies farthest from the line, on the side away from the ideal
    # (beaten by (41.971, 0.707)); (45.142, 2.121) lies 0.037 beyond it
    assert knee(minimised) == 4
    assert knee(minimised[::-1]) == 1  # the same point, whatever the order given
    assert knee([(1, 0), (2, -1), (3, -2)]) == 0  # on the line
    assert knee([(2, -1), (1, 0)]) == 1  # two points: the shortest
    assert knee([(1, 0), (1.1, -0.9), (3, -1)]) == 1
    assert knee([(3, -np.inf), (1, -np.inf), (2, -np.inf)]) == 1
    assert knee([(1, -1), (2, -4), (3, -5), (2.5, np.nan)]) == 1  # no value: never it


def test_a_front_measures_clearance_from_the_map_s_own_obstacles():
    """On a map inflated by a robot's radius the clearance field is the distance to the
    obstacles as loaded (the frame's), not to the inflated cells; a coarsened map, whose
    obstacles are in other cells, measures to the grid's blocked cells."""
    from jaxga._runtime.fields import front_obstacles, program_fields
    from jaxga.maps.frame import MapFrame

    own = np.zeros_like(BLOCKED)
    own[6:8, 7] = True  # a thin pillar, inflated into BLOCKED's block
    frame = MapFrame(map_shape=own.shape, resolution=0.05, origin=(0.0, 0.0, 0.0),
                     obstacles=own)
    assert front_obstacles(frame, GRID) is own
    assert front_obstacles(MapFrame(map_shape=(28, 32), coarsen=2, obstacles=np.zeros(
        (28, 32), bool)), GRID) is None
    assert front_obstacles(None, GRID) is None
    pareto = load_preset("pareto")
    grid = program_fields(GRID, pareto, own)
    np.testing.assert_allclose(np.asarray(grid.guide.clearance),
                               np.minimum(cell_clearance(own), 30).reshape(-1), rtol=1e-6)
    assert float(grid.guide.band) == pytest.approx(maximin_path(GRID, obstacles=own).clearance)
    assert float(program_fields(GRID, pareto).guide.band) == pytest.approx(
        maximin_path(GRID).clearance)
