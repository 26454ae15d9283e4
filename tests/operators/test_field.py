"""The exact distance fields (jaxga.operators.guide) and the initialiser steered by them.

Property tests on generated random maps, mazes and rooms of several sizes under all three
corner rules: the fields equal the reference Dijkstra (jaxga.reference.optima, heapq, written
independently of SciPy); field_walk returns valid (independent NumPy check), bounded and
distinct paths on every reachable problem and an explicit failure on unreachable ones;
the population fallback fills exactly the slots its initialiser left empty.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxga import Grid
from jaxga.core.objectives import path_length
from jaxga.engine import SMALL_MAP_CAPACITY, capacity_class, default_capacity
from jaxga.maps import builtin_names, load_map, maze_map, random_map, reachable, rooms_map
from jaxga.operators import init as I
from jaxga.operators.guide import distance_fields, problem_facts, with_guide
from jaxga.reference.optima import distances_from, shortest_path
from tests.strategies import check_paths

# the field walks and repairs in depth, whole GAs with map tables (contracts: test_registry)
pytestmark = pytest.mark.slow

FIELD_CAP = 256  # one compiled program per map size
KEYS = 16
SIZES = (12, 24)
RULES = ("free", "no_squeeze", "strict")


def _map(kind: str, size: int, seed: int, rule: str) -> Grid:
    end = (size - 1, size - 1)
    if kind == "maze":
        return maze_map(size, size, seed, corridor_width=2, start=(0, 0), goal=end,
                        corner_rule=rule)
    if kind == "rooms":
        return rooms_map(size, size, seed, room_size=4, door_width=2, start=(0, 0), goal=end,
                         corner_rule=rule)
    return random_map(size, size, 0.25, seed, start=(0, 0), goal=end, corner_rule=rule)


@st.composite
def problems(draw, kinds=("random", "maze", "rooms")):
    """A generated map (kind, size, corner rule) with random free endpoints."""
    kind = draw(st.sampled_from(kinds))
    size = draw(st.sampled_from(SIZES))
    rule = draw(st.sampled_from(RULES))
    grid = _map(kind, size, draw(st.integers(0, 10_000)), rule)
    free = np.flatnonzero(~grid.blocked_np().reshape(-1))
    a, b = draw(st.lists(st.sampled_from(free.tolist()), min_size=2, max_size=2))
    return kind, grid.replace(start=(a % size, a // size), goal=(b % size, b // size))


@functools.partial(jax.jit, static_argnames=("capacity",))
def _walks(keys, grid, slack, temperature, capacity=FIELD_CAP):
    return jax.vmap(lambda k: I.field_walk(k, grid, capacity, slack, temperature))(keys)


_lengths = jax.jit(jax.vmap(path_length, in_axes=(None, 0, 0)))


# ----------------------------------------------------------------------------- fields
@settings(max_examples=30, deadline=None)
@given(problems())
def test_fields_and_facts_equal_the_reference(problem):
    """The SciPy fields equal the heapq Dijkstra of jaxga.reference.optima from both endpoints;
    the optimum, its cell count and the start's region agree with the reference A* and
    flood fill."""
    _, grid = problem
    to_goal, from_start, _ = distance_fields(grid)
    want_goal = distances_from(grid, grid.goal_xy).reshape(-1)
    want_start = distances_from(grid, grid.start_xy).reshape(-1)
    np.testing.assert_allclose(to_goal, want_goal, rtol=0, atol=1e-9)
    np.testing.assert_allclose(from_start, want_start, rtol=0, atol=1e-9)
    facts = problem_facts(grid)
    ref = shortest_path(grid)
    assert facts.reachable == ref.found
    assert facts.reachable_cells == int(reachable(grid).sum())
    if ref.found:
        assert math.isclose(facts.optimal_length, ref.length, abs_tol=1e-9)
        assert facts.optimal_cells == ref.n_cells
    else:
        assert facts.optimal_cells == 0 and math.isinf(facts.optimal_length)


def test_a_blocked_endpoint_has_no_field():
    b = np.zeros((6, 6), bool)
    b[5, 5] = True
    grid = Grid.create(b, start=(0, 0), goal=(5, 5))
    to_goal, from_start, _ = distance_fields(grid)
    assert np.isinf(to_goal).all() and not problem_facts(grid).reachable
    assert from_start[0] == 0 and np.isinf(from_start[35])


def test_the_guide_belongs_to_its_endpoints():
    """Grid.replace (other endpoints) drops the guide; with_guide keeps an attached one."""
    grid = with_guide(random_map(12, 12, 0.2, 3))
    assert grid.guide is not None and with_guide(grid) is grid
    moved = grid.replace(goal=(5, 5))
    assert moved.guide is None
    assert float(with_guide(moved).guide.to_goal[int(moved.goal)]) == 0.0
    with pytest.raises(Exception, match="with_guide"):
        I.field_walk(jax.random.PRNGKey(0), moved, 64)


# ------------------------------------------------------------------- field_walk
@settings(max_examples=30, deadline=None)
@given(problems(), st.integers(0, 2**31 - 1), st.sampled_from([0.0, 0.3, 1.0]),
       st.sampled_from([0.0, 0.5, 2.0]))
def test_field_walk_paths_are_valid_bounded_and_spread(problem, seed, slack, temperature):
    """Every reachable problem: all KEYS walks succeed and are valid paths (independent
    check: start to goal, legal moves under the corner rule, loop-free, padded), no
    longer than (1 + slack) times the optimum; with slack > 0 on random and room maps
    the walks spread over several paths. An unreachable goal: every walk fails."""
    kind, grid = problem
    guided = with_guide(grid)
    keys = jax.random.split(jax.random.PRNGKey(seed), KEYS)
    cells, length, ok = _walks(keys, guided, slack, temperature)
    facts = problem_facts(grid)
    if not facts.reachable:
        assert not np.asarray(ok).any()
        return
    assert np.asarray(ok).all()
    assert check_paths(grid, cells, length, ok, cap=FIELD_CAP) == KEYS
    lengths = np.asarray(_lengths(grid, cells, length), float)
    assert (lengths >= facts.optimal_length - 1e-4).all()
    assert (lengths <= (1 + slack) * facts.optimal_length + 1e-3 * FIELD_CAP).all()
    distinct = {tuple(c[:n]) for c, n in zip(np.asarray(cells).tolist(), np.asarray(length))}
    if slack > 0 and kind != "maze" and facts.optimal_cells > 8:
        assert len(distinct) >= 2


def test_field_walk_without_slack_or_temperature_is_optimal():
    """slack 0, temperature 0: only optimal moves through a cell of a shortest path, so
    every walk is an 8-connected optimum (the reference A*'s length)."""
    for rule in RULES:
        for seed in range(3):
            grid = random_map(24, 24, 0.3, seed, corner_rule=rule)
            keys = jax.random.split(jax.random.PRNGKey(seed), KEYS)
            cells, length, ok = _walks(keys, with_guide(grid), 0.0, 0.0)
            assert np.asarray(ok).all()
            np.testing.assert_allclose(np.asarray(_lengths(grid, cells, length)),
                                       shortest_path(grid).length, rtol=1e-5)


def test_field_descent_spends_at_most_its_budget():
    """One walk down the goal's field from the start with budget B: it reaches the goal
    by moves that lower the field, no longer than the optimum plus B."""
    grid = with_guide(rooms_map(24, 24, 2, room_size=5, corner_rule="strict"))
    opt = problem_facts(grid).optimal_length
    walk = jax.jit(jax.vmap(lambda k, b: I.field_descent(
        k, grid, grid.guide.to_goal, grid.start, FIELD_CAP, b, 1.0), in_axes=(0, None)))
    for budget in (0.0, 2.0, 10.0):
        cells, length, ok = walk(jax.random.split(jax.random.PRNGKey(1), KEYS), budget)
        assert np.asarray(ok).all()
        check_paths(grid, cells, length, ok, cap=FIELD_CAP)
        field = np.asarray(grid.guide.to_goal)
        for c, n in zip(np.asarray(cells), np.asarray(length)):
            assert (np.diff(field[c[:n]]) < 0).all()  # strictly down the field
        lengths = np.asarray(_lengths(grid, cells, length))
        assert (lengths <= opt + budget + 1e-3).all()


def test_field_walk_fails_only_when_the_capacity_is_below_the_path():
    """A corridor of 30 cells: capacity 29 fails every walk, 30 succeeds with slack 0."""
    b = np.ones((3, 30), bool)
    b[1, :] = False
    grid = with_guide(Grid.create(b, start=(0, 1), goal=(29, 1)))
    keys = jax.random.split(jax.random.PRNGKey(0), 4)
    for cap, expect in ((29, False), (30, True)):
        _, length, ok = _walks(keys, grid, 0.5, 1.0, capacity=cap)
        assert (np.asarray(ok) == expect).all()
        if expect:
            assert (np.asarray(length) == 30).all()


# ----------------------------------------------------------------------- fallback
def _sometimes(key, grid, capacity):
    """An initialiser that succeeds for about a third of its keys (a field walk kept or
    marked failed by a coin): its successes are valid paths."""
    cells, length, ok = I.field_walk(jax.random.fold_in(key, 1), grid, capacity, 0.2, 0.0)
    return cells, length, ok & (jax.random.uniform(key) < 0.33)


def _never(key, grid, capacity):
    cells, length, _ = I.random_walk(key, grid, capacity)
    return cells, length, jnp.bool_(False)


@pytest.mark.parametrize("init_fn", [_sometimes, _never, I.median_insertion])
def test_the_fallback_fills_exactly_the_slots_the_initialiser_left_empty(init_fn):
    grid = with_guide(rooms_map(24, 24, 5, room_size=5, corner_rule="strict"))
    key = jax.random.PRNGKey(3)
    pop0, st0 = initialise(key, grid, init_fn, 24, FIELD_CAP, max_tries=1)
    pop1, st1 = initialise(key, grid, init_fn, 24, FIELD_CAP, max_tries=1,
                             fallback=I.field_walk)
    valid0, valid1 = np.asarray(st0.valid), np.asarray(st1.valid)
    assert valid1.all() and int(st1.n_failed) == 0
    assert int(st1.from_fallback) == int((~valid0).sum())
    # the initialiser's own individuals are untouched, its statistics too
    np.testing.assert_array_equal(np.asarray(pop1.cells)[valid0], np.asarray(pop0.cells)[valid0])
    np.testing.assert_array_equal(np.asarray(pop1.length)[valid0],
                                  np.asarray(pop0.length)[valid0])
    for name in ("attempts", "successes", "rounds"):
        assert int(getattr(st1, name)) == int(getattr(st0, name))
    assert check_paths(grid, pop1.cells, pop1.length, valid1, cap=FIELD_CAP) == 24


def test_a_full_population_is_the_same_with_or_without_the_fallback():
    grid = with_guide(random_map(24, 24, 0.1, 4, corner_rule="free"))
    key = jax.random.PRNGKey(5)
    pop0, st0 = initialise(key, grid, I.directional, 16, FIELD_CAP, max_tries=50)
    pop1, st1 = initialise(key, grid, I.directional, 16, FIELD_CAP, max_tries=50,
                             fallback=I.field_walk)
    assert np.asarray(st0.valid).all() and int(st1.from_fallback) == 0
    np.testing.assert_array_equal(np.asarray(pop0.cells), np.asarray(pop1.cells))
    np.testing.assert_array_equal(np.asarray(pop0.length), np.asarray(pop1.length))


def test_the_fallback_cannot_fill_an_unreachable_goal():
    b = np.zeros((12, 12), bool)
    b[6, :] = True
    grid = with_guide(Grid.create(b))
    _, stats = initialise(jax.random.PRNGKey(0), grid, I.random_walk, 8, FIELD_CAP,
                            max_tries=2, fallback=I.field_walk)
    assert int(stats.n_failed) == 8 and int(stats.from_fallback) == 0


# ----------------------------------------------------------------------- capacity
def test_capacity_classes_round_up_to_a_few_sizes():
    assert [capacity_class(c) for c in (1, 8, 9, 100, 128, 129, 161, 400, 1100)] == \
        [8, 8, 10, 112, 128, 160, 192, 448, 1280]
    for c in range(1, 3000, 7):
        k = capacity_class(c)
        assert c <= k <= max(8, 1.25 * c + 1)


def test_the_automatic_capacity_fits_the_problem():
    """3 x the optimal path's cells (a size class), at least min(4 (H + W), 160): the
    papers' 20 x 20 maps keep the 160 cells their reproductions ran with; the long
    optimum of a 65 x 65 maze fits; an unreachable goal gets the minimum."""
    for name in builtin_names():
        if "20x20" in name:
            assert default_capacity(load_map(name, corner_rule="free")) == SMALL_MAP_CAPACITY
    maze = maze_map(65, 65, 7, corner_rule="strict")
    facts = problem_facts(maze)
    assert facts.optimal_cells > 300
    cap = default_capacity(maze)
    assert cap == max(160, capacity_class(min(3 * facts.optimal_cells, facts.reachable_cells)))
    assert cap > 600  # the maze's optimal path and its detours fit (4 (H + W) = 520)
    small = random_map(8, 8, 0.0, 1)
    assert default_capacity(small) == 4 * (8 + 8)
    b = np.zeros((30, 30), bool)
    b[15, :] = True
    assert default_capacity(Grid.create(b)) == SMALL_MAP_CAPACITY


# ------------------------------------------------------------------ field repairs
from jaxga.core.objectives import sga as sga_fitness  # noqa: E402
from jaxga.operators import column_crossover as CX  # noqa: E402
from jaxga.operators import mutation as MU  # noqa: E402
from tests.plain_lifts import initialise  # noqa: E402
from tests.strategies import CAP, grids_and_parents  # noqa: E402


@functools.partial(jax.jit, static_argnames=("repair",))
def _repairs(keys, grid, cells, length, repair):
    """Every repairing operator with a single round of median insertion (so that most
    connections do not close), with and without the field repair."""
    one = dict(max_rounds=1, field_repair=repair)
    seg = jax.vmap(lambda k, c, n: MU.segment_sa(k, grid, c, n, 1.0, fitness_fn=sga_fitness,
                                                 **one))(keys, cells, length)
    rng = jax.vmap(lambda k, c, n: MU.regrow_segment(k, grid, c, n, field_repair=repair))(
        keys, cells, length)
    col = jax.vmap(lambda k, c1, n1, c2, n2: CX.column_child(k, grid, c1, n1, c2, n2, **one))(
        keys, cells, length, jnp.roll(cells, 1, 0), jnp.roll(length, 1, 0))
    med = jax.vmap(lambda k: I.median_insertion(k, grid, CAP, **one))(keys)
    inter = jax.vmap(lambda k: I.intermittent_connect(k, grid, CAP, **one))(keys)
    return {"segment_sa": seg, "range": rng, "column": col, "median_insertion": med,
            "intermittent_connect": inter}


@settings(max_examples=15, deadline=None)
@given(grids_and_parents(n=8, corner_rules=("strict",)))
def test_field_repairs_close_every_gap_with_a_valid_path(gp):
    """With the field repair an operator whose median insertion or regrowth walk does not
    close still returns a valid path (independent check), and no longer fails at all
    here (the capacity holds every result). On strict maps, the rule with the fewest
    legal moves, for one compiled program (the field walk under every rule:
    test_field_walk_paths_are_valid_bounded_and_spread)."""
    grid, parents = gp
    guided = with_guide(grid)
    keys = jax.random.split(jax.random.PRNGKey(int(parents.cells.sum())), 8)
    got = _repairs(keys, guided, parents.cells, parents.length, True)
    for name in ("segment_sa", "range"):
        cells, length, failed = got[name]
        assert not np.asarray(failed).any(), name
        check_paths(grid, cells, length, ~np.asarray(failed))
    for name in ("column", "median_insertion", "intermittent_connect"):
        cells, length, ok = got[name]
        assert np.asarray(ok).all(), name
        check_paths(grid, cells, length, ok)


def test_field_repairs_replace_real_failures():
    """The failures the repair replaces are real: on one cluttered map, the same
    operators with one round of median insertion and without the repair fail often."""
    from tests.strategies import random_parents

    grid = random_map(10, 10, 0.3, 11, corner_rule="strict")
    parents = random_parents(grid, 8, 1)
    keys = jax.random.split(jax.random.PRNGKey(0), 8)
    plain = _repairs(keys, with_guide(grid), parents.cells, parents.length, False)
    failed = {n: int(np.asarray(plain[n][2]).sum()) for n in ("segment_sa", "range")}
    failed.update({n: int((~np.asarray(plain[n][2])).sum()) for n in
                   ("column", "median_insertion", "intermittent_connect")})
    assert sum(failed.values()) >= 8, failed


# ------------------------------------------------------------------ map tables
@pytest.mark.parametrize("preset", ["iga_zhu", "mpmga"])
def test_map_tables_give_the_same_generations(preset):
    """The per-map tables attached once (jaxga.engine.maptables) instead of computed by every
    operator: the same initial population and generations, bit for bit. Between them the
    two presets read every table: iga_zhu the moves of its walks (directional
    initialiser, regrowth mutation) and the column crossover's free-cell prefixes, mpmga
    the neighbour masks of median insertion (intermittent initialiser, segment mutation)
    and the heterologous crossover's step masks."""
    from jaxga import engine
    from jaxga.config.presets import load_preset
    from jaxga.engine.maptables import with_tables

    grid = with_guide(rooms_map(16, 16, 3, room_size=4, corner_rule="no_squeeze"))
    config = load_preset(preset).override({"population.size": 12, "generations": 3,
                                           "islands.migrants": 1})
    algo, params = engine.build(config, grid)

    @jax.jit
    def whole(g):
        state, _ = engine.init_state(algo, jax.random.PRNGKey(2), g, params)
        return engine.evolve(algo, jax.random.PRNGKey(3), g, state, params, 3)

    plain, tabled = whole(grid), whole(with_tables(grid))
    for a, b in zip(jax.tree_util.tree_leaves(plain), jax.tree_util.tree_leaves(tabled)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_clearance_weighted_fields_trade_length_for_clearance():
    """Weight 0 is the goal's exact distance field; on a map whose short route squeezes
    past a wall and whose long route is open, the descent of a heavier field takes the
    open route: longer, and farther from the obstacles."""
    from jaxga.maps.clearance import cell_clearance
    from jaxga.operators.guide import clearance_weighted_field, distance_fields

    blocked = np.zeros((11, 15), bool)
    blocked[0:8, 7] = True  # a wall up to row 7, open above it (rows 8-10)
    blocked[4, 7] = False  # the short route squeezes through a gap at (7, 4)
    grid = Grid.create(blocked, start=(1, 4), goal=(13, 4), corner_rule="strict")
    clearance = cell_clearance(blocked)
    np.testing.assert_allclose(clearance_weighted_field(grid, clearance, 0.0, 2.0),
                               distance_fields(grid)[0])

    def descent(field):
        h, w = blocked.shape
        cell, path = int(grid.start), [int(grid.start)]
        while cell != int(grid.goal):
            x, y = cell % w, cell // w
            moves = [(x + dx, y + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)
                     if (dx or dy) and 0 <= x + dx < w and 0 <= y + dy < h
                     and not blocked[y + dy, x + dx]
                     and not (dx and dy and (blocked[y, x + dx] or blocked[y + dy, x]))]
            cell = min(((my * w + mx) for mx, my in moves), key=lambda c: field[c])
            path.append(cell)
        return np.array([(c % w, c // w) for c in path])

    plain = descent(clearance_weighted_field(grid, clearance, 0.0, 2.0))
    wide = descent(clearance_weighted_field(grid, clearance, 50.0, 2.0))
    least = [min(clearance[y, x] for x, y in p) for p in (plain, wide)]
    lengths = [np.hypot(*np.diff(p, axis=0).T).sum() for p in (plain, wide)]
    assert least[0] == 0.5 and lengths[0] == 12.0  # straight through the gap
    assert (7, 4) not in map(tuple, wide)  # over the wall instead
    assert least[1] > 1.0 and lengths[1] > lengths[0]
    with pytest.raises(ValueError, match="weight"):
        clearance_weighted_field(grid, clearance, -1.0, 2.0)
