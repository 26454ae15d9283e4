"""A planner a robot node can call (:class:`jaxga.Planner`, :meth:`jaxga.GA.grid_for`): a
new start and goal on a loaded map compile nothing, in ``jaxga.run``'s programs and in
the pure core; the clearance is measured to the map's own obstacles, before inflation.

The map is 20 x 20 with the free corner rule, so that its programs are the canonical
``hybrid`` ones (tests/canonical.py) and the test compiles nothing of its own."""

from __future__ import annotations

import math

import jax
import jax.monitoring
import numpy as np
import pytest

import jaxga
from jaxga._runtime import programs
from jaxga.core.errors import EndpointError, ParameterError
from jaxga.engine.algorithm import map_capacity
from jaxga.maps import load_map_info
from jaxga.maps.clearance import ObstacleClearance, segment_square_distance
from jaxga.operators.guide import longest_optimal_path_cells
from jaxga.reference.optima import shortest_path_np
from tests import canonical

RES = 0.1
COMPILES: list[str] = []


def _listen(event: str, duration: float, **_: object) -> None:
    if event == "/jax/core/compile/backend_compile_duration":
        COMPILES.append(event)


jax.monitoring.register_event_duration_secs_listener(_listen)


def _occupancy(wall_rows: range, pillar: bool) -> np.ndarray:
    """A 20 x 20 map's occupancies as the map topic publishes them (row 0 the bottom, 0
    free, 100 occupied): a wall across ``wall_rows`` (x 0-13) and, with ``pillar``, a
    pillar at (15-16, 4-5)."""
    occ = np.zeros((20, 20), np.int8)
    occ[list(wall_rows), 0:14] = 100
    if pillar:
        occ[4:6, 15:17] = 100
    return occ


def _ros_map(folder, name: str, wall_rows: range, pillar: bool) -> str:
    """:func:`_occupancy`'s map as the ROS map ``folder/name.yaml`` at 0.1 m, origin
    (-1, -1), as map_saver writes it."""
    occupied = _occupancy(wall_rows, pillar)[::-1] == 100  # rows from the top in the image
    img = np.where(occupied, 0, 254).astype(np.uint8)
    header = b"P5\n20 20\n255\n"
    (folder / f"{name}.pgm").write_bytes(header + img.tobytes())
    (folder / f"{name}.yaml").write_text(
        f"image: {name}.pgm\nresolution: 0.1\norigin: [-1.0, -1.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return str(folder / f"{name}.yaml")


@pytest.fixture(scope="module")
def office(tmp_path_factory) -> str:
    """A 20 x 20 ROS map at 0.1 m: a wall across rows 10-11 (x 0-13), a pillar at
    (15-16, 4-5); origin (-1, -1)."""
    return _ros_map(tmp_path_factory.mktemp("office"), "office", range(10, 12), pillar=True)


def test_a_new_pair_on_a_loaded_map_compiles_nothing(office):
    planner = jaxga.Planner(office, robot_radius=0.1, corner_rule="free", seeds=3,
                            generations=canonical.GENERATIONS)
    first = planner.plan((1, 1), (18, 18))
    assert first.success.all()
    COMPILES.clear()
    before = set(programs._SHARED_PROGRAMS)
    pairs = [((18, 2), (2, 16)), ((5, 17), (17, 8))]
    plans = [planner.plan(s, g) for s, g in pairs]
    assert COMPILES == [] and set(programs._SHARED_PROGRAMS) == before
    for (s, g), plan in zip(pairs, plans, strict=True):
        assert plan.success.all() and plan.start == s and plan.goal == g
        for i in range(3):
            path = plan.path(i)
            assert tuple(path[0]) == s and tuple(path[-1]) == g
            np.testing.assert_allclose(plan.world_path(i)[0], np.add(s, 0.5) * RES - 1.0)
    # metres: the cell holding the point, its centre planned on
    world = planner.plan(start_world=(-0.85, -0.82), goal_world=(0.84, 0.88))
    assert (world.start, world.goal) == ((1, 1), (18, 18))
    np.testing.assert_array_equal(world.cells, first.cells)


def test_the_planner_refuses_endpoints_in_one_line(office):
    planner = jaxga.Planner(office, robot_radius=0.1, corner_rule="free")
    for call, words in (
            (lambda: planner.plan((1, 1), (5, 10)), "blocked"),
            (lambda: planner.plan((1, 1)), "give the goal once"),
            (lambda: planner.plan((1, 1), (2, 2), goal_world=(0.0, 0.0)), "give the goal once"),
            (lambda: planner.plan(start_world=(5.0, 0.0), goal_world=(0.0, 0.0)), "off the map"),
            # cells are integers on the map: not truncated, not read from bools or text
            (lambda: planner.plan((-0.9, 0), (2, 2)), "must be a pair of integers"),
            (lambda: planner.plan((1.5, 1), (2, 2)), "must be a pair of integers"),
            (lambda: planner.plan((True, False), (2, 2)), "must be a pair of integers"),
            (lambda: planner.plan(("1", "1"), (2, 2)), "must be a pair of integers"),
            (lambda: planner.plan((math.nan, 1), (2, 2)), "must be a pair of integers"),
            (lambda: planner.plan((1, 1), (20, 2)), "off the 20 x 20 map"),
            (lambda: planner.plan(start_world=("0.1", "0.1"), goal_world=(0.0, 0.0)),
             "must be a pair of numbers"),
            (lambda: planner.plan(start_world=(math.nan, 0.1), goal_world=(0.0, 0.0)),
             "must be finite")):
        with pytest.raises(EndpointError, match=words) as e:
            call()
        assert "\n" not in str(e.value)


@pytest.mark.slow  # two whole GAs compiled (one taking the endpoints, one closing over them)
def test_the_pure_core_takes_the_endpoints_as_an_input():
    """``GA.run(key, params, ga.grid_for(...))`` under one ``jit``: a second pair compiles
    nothing and equals a GA built on that pair with the same capacity, bit for bit."""
    ga = jaxga.GA("sga", canonical.MAP, generations=canonical.GENERATIONS)
    plan = jax.jit(jax.vmap(ga.run, (0, None, None)))
    keys = jax.random.split(jax.random.PRNGKey(3), 3)
    plan(keys, ga.default_params, ga.grid_for((0, 0), (19, 19)))
    COMPILES.clear()
    out = plan(keys, ga.default_params, ga.grid_for((0, 19), (19, 0)))
    assert COMPILES == []
    other = jaxga.GA("sga", ga.grid.replace(start=(0, 19), goal=(19, 0)),
                     generations=canonical.GENERATIONS,
                     population__capacity=ga.algorithm.capacity)
    ref = jax.jit(jax.vmap(other.run, (0, None)))(keys, other.default_params)
    for a, b in zip(jax.tree_util.tree_leaves(out), jax.tree_util.tree_leaves(ref), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    with pytest.raises(EndpointError, match="blocked"):
        ga.grid_for((0, 0), tuple(int(v) for v in np.argwhere(ga.grid.blocked_np())[0][::-1]))
    small = jaxga.GA("sga", canonical.MAP, population__capacity=16)
    with pytest.raises(ParameterError, match="population__capacity="):
        small.grid_for((0, 0), (19, 19))


def test_segment_square_distances_by_hand():
    centres = np.array([[3.0, 0.0], [3.0, 2.0], [0.0, 3.0], [5.0, 5.0]])
    d = segment_square_distance(np.array([0.0, 0.0]), np.array([2.0, 0.0]), centres)
    # to the square [2.5, 3.5] x [-0.5, 0.5]: 0.5; [2.5, 3.5] x [1.5, 2.5]: corner (2.5,
    # 1.5) from the end (2, 0); [-0.5, 0.5] x [2.5, 3.5]: 2.5 above the start
    np.testing.assert_allclose(d, [0.5, math.hypot(0.5, 1.5), 2.5, math.hypot(2.5, 4.5)])
    # a diagonal segment grazing a square's corner touches it
    touch = segment_square_distance(np.array([0.0, 0.0]), np.array([2.0, 2.0]),
                                    np.array([[1.0, 0.0], [2.0, 0.0]]))
    # (0.5, 0.5), the first square's corner, lies on the segment; the second square's
    # corner (1.5, 0.5) is 1 / sqrt(2) from the line y = x
    assert touch[0] == 0.0
    assert touch[1] == pytest.approx(1 / math.sqrt(2))


def test_the_clearance_is_to_the_map_as_loaded_before_inflation(office):
    """On the office map inflated by one cell, a path along row 8 (the wall's squares start
    at y = 9.5) is 1.5 cells = 0.15 m from the wall, although it touches the inflated
    margin: 0.05 m beyond the robot's 0.1 m radius."""
    info = load_map_info(office, robot_radius=0.1, corner_rule="free")
    assert info.grid.blocked_np()[9, 5]  # the margin
    clearance = info.frame.clearance
    assert clearance.of_path(np.array([[0, 8], [12, 8]])) == pytest.approx(1.5)
    # around the pillar (squares x 14.5-16.5, y 3.5-5.5): from (18, 8) to (18, 2), 1.5
    assert clearance.of_path(np.array([[18, 8], [18, 2]])) == pytest.approx(1.5)
    # a segment through the wall: 0
    assert clearance.of_path(np.array([[5, 8], [5, 13]])) == 0.0
    # coarsened 2 x 2: planning cell (2, 4) is centred at map point (4.5, 8.5), 1 from
    # the wall
    coarse = ObstacleClearance(clearance_obstacles(info), coarsen=2)
    assert coarse.of_path(np.array([[2, 4]])) == pytest.approx(1.0)
    planner = jaxga.Planner(info, seeds=3, generations=canonical.GENERATIONS)
    plan = planner.plan((1, 8), (12, 8))
    best = plan.best_seed()
    assert plan.obstacle_clearance(best) == pytest.approx(
        clearance.of_path(np.asarray(plan.path(best))))
    assert plan.clearance_margin_m(best) == pytest.approx(
        plan.obstacle_clearance(best) * RES - 0.1)
    run = plan.to_json()["runs"][best]
    assert run["min_clearance_m"] == pytest.approx(plan.obstacle_clearance(best) * RES)
    assert "beyond the robot's radius" in plan.summary()


def clearance_obstacles(info) -> np.ndarray:
    return info.frame.obstacles


@pytest.mark.parametrize("rule", ["free", "no_squeeze", "strict"])
def test_the_maps_longest_optimal_path_bounds_every_pair(rule):
    """:func:`longest_optimal_path_cells` bounds the cells of the optimal path between any
    two connected cells of the map (all pairs, by the exact search), also in a region
    other than the largest; the planner's capacity follows it."""
    rng = np.random.default_rng(3)
    blocked = rng.random((9, 12)) < 0.25
    blocked[:, 9] = True  # a second region on the right
    grid = jaxga.Grid.create(blocked, corner_rule=rule, start=(0, 0), goal=(0, 0))
    bound = longest_optimal_path_cells(grid)
    free = [tuple(int(v) for v in c) for c in np.argwhere(~blocked)[:, ::-1]]
    most = max(len(p.path) for a in free for b in free
               if (p := shortest_path_np(blocked, a, b, rule)).found)
    assert most <= bound <= int((~blocked).sum())
    assert map_capacity(grid, 1.5) >= math.ceil(1.5 * bound)


@pytest.mark.parametrize("rule", ["free", "strict"])
def test_a_large_region_enclosed_by_another_is_bounded_by_its_distances(rule):
    """A race track's infield, a closed room: a region other than the largest was bounded
    by its cell count, and a real track's infield of 723,543 cells asked the Planner for
    a capacity above jaxga's maximum. Here a frame 8 cells wide (1,024 cells) encloses an
    open square of 484 cells: the bound holds every optimal path of both regions (an
    optimal path has at most its length + 1 cells) and is far below the square's cells."""
    from scipy.sparse.csgraph import dijkstra

    from jaxga.operators.guide import _map_graph

    blocked = np.zeros((40, 40), bool)
    blocked[8:32, 8:32] = True  # the frame's inner edge
    blocked[9:31, 9:31] = False  # the square inside, 22 x 22 cells
    grid = jaxga.Grid.create(blocked, corner_rule=rule, start=(0, 0), goal=(0, 0))
    bound = longest_optimal_path_cells(grid)
    dist = dijkstra(_map_graph(blocked.tobytes(), blocked.shape, rule), directed=True)
    longest = dist[np.isfinite(dist)].max()
    assert math.floor(longest + 1e-9) + 1 <= bound < 22 * 22


def test_a_map_whose_paths_need_more_than_jaxgas_capacity_is_refused_when_loaded(
        monkeypatch):
    """Refused at construction in one line that says what to do, not at the first plan as
    an override of ``population.capacity`` the user never gave."""
    from jaxga.api import planner

    monkeypatch.setattr(planner, "map_capacity", lambda grid, factor: 1_310_720)
    with pytest.raises(ParameterError, match=r"may need 1,310,720 path cells, more than "
                                              r"jaxga's 1,000,000: load it coarser") as e:
        jaxga.Planner("classic_ga_gapp3_20x20")
    assert "\n" not in str(e.value)


def test_the_planners_capacity_is_the_maps(office):
    planner = jaxga.Planner(office, robot_radius=0.1, corner_rule="free")
    factor = 1.5  # hybrid's population.capacity_factor
    assert planner.capacity == map_capacity(planner.map.grid, factor)
    assert jaxga.Planner(office, robot_radius=0.1, corner_rule="free",
                         population__capacity=96).capacity is None


def test_map_options_with_a_loaded_map_are_refused_or_applied():
    """Given a loaded MapInfo, the Planner ignored robot_radius, inflate, coarsen and
    unknown without a word, and corner_rule too (jaxga.run applies it): the loading
    options are refused in one line, the corner rule applied. Nothing is compiled."""
    from jaxga.maps import load_map_info

    info = load_map_info("classic_ga_gapp3_20x20")
    assert info.grid.corner_rule == "free"
    for option in ({"robot_radius": 0.1}, {"inflate": 1}, {"coarsen": 2},
                   {"unknown": "free"}):
        with pytest.raises(ParameterError, match=f"{next(iter(option))} given with a "
                                                 "loaded map") as e:
            jaxga.Planner(info, "sga", **option)
        assert "\n" not in str(e.value)
    strict = jaxga.Planner(info, "sga", corner_rule="strict")
    assert strict.map.grid.corner_rule == "strict" and info.grid.corner_rule == "free"
    with pytest.raises(jaxga.JaxgaError, match="unknown corner rule 'diagonal'"):
        jaxga.Planner(info, "sga", corner_rule="diagonal")


def test_a_map_update_plans_as_a_planner_made_on_the_new_map(office, tmp_path):
    """A costmap update (``update_map``, or ``planner.map = ...``): loaded with the
    planner's options, its capacity the new map's, its plans those of a planner made on
    it; a map of the same size class compiles nothing; a map refused leaves the planner
    as it was; a map loaded already is planned on as it is."""
    options = {"robot_radius": 0.1, "corner_rule": "free", "seeds": 3,
               "generations": canonical.GENERATIONS}
    planner = jaxga.Planner(office, **options)
    before = planner.plan((1, 1), (1, 18))
    moved = _ros_map(tmp_path, "moved", range(6, 8), pillar=False)  # the wall moved
    fresh = jaxga.Planner(moved, **options)
    COMPILES.clear()
    planner.update_map(moved)
    after = planner.plan((1, 1), (1, 18))
    assert COMPILES == []  # the same 20 x 20 size class: the same programs
    assert planner.map.path == fresh.map.path and planner.capacity == fresh.capacity
    np.testing.assert_array_equal(planner.map.grid.blocked_np(), fresh.map.grid.blocked_np())
    assert planner.map.grid.blocked_np()[7, 0] and not planner.map.grid.blocked_np()[11, 0]
    np.testing.assert_array_equal(after.cells, fresh.plan((1, 1), (1, 18)).cells)
    assert after.length.tolist() != before.length.tolist()  # the wall moved: other paths
    planner.map = office  # the attribute does the same
    np.testing.assert_array_equal(planner.plan((1, 1), (1, 18)).cells, before.cells)
    with pytest.raises(jaxga.JaxgaError) as e:
        planner.update_map(str(tmp_path / "missing.yaml"))
    assert "\n" not in str(e.value) and planner.map.path.name == "office.yaml"
    planner.map = load_map_info(moved, robot_radius=0.1, corner_rule="free")
    assert planner.map == fresh.map and planner.capacity == fresh.capacity
    planner.update_map(load_map_info(moved, corner_rule="free"))  # as loaded: no radius
    assert not planner.map.grid.blocked_np()[5, 0]  # the wall at rows 6-7, not inflated
    assert fresh.map.grid.blocked_np()[5, 0]


def _map_message(occupancy: np.ndarray):
    """A nav_msgs/OccupancyGrid as rclpy delivers one: float32 resolution, int8 data."""
    import array
    from types import SimpleNamespace as Msg

    h, w = occupancy.shape
    pose = Msg(position=Msg(x=-1.0, y=-1.0, z=0.0), orientation=Msg(x=0.0, y=0.0, z=0.0, w=1.0))
    return Msg(info=Msg(width=w, height=h, resolution=float(np.float32(RES)), origin=pose),
               data=array.array("b", occupancy.ravel().tolist()))


def test_a_planner_given_the_map_topic_plans_as_one_given_the_map_file(office, tmp_path):
    """A node that receives its map as a nav_msgs/OccupancyGrid, at start and as
    updates, plans as one given the map_server files the map was published from: the
    same cells, capacity, programs and paths in metres."""
    options = {"robot_radius": 0.1, "corner_rule": "free", "seeds": 3,
               "generations": canonical.GENERATIONS}
    ends = {"start_world": (-0.85, -0.82), "goal_world": (-0.85, 0.88)}
    from_file = jaxga.Planner(office, **options)
    expected = from_file.plan(**ends)
    COMPILES.clear()
    planner = jaxga.Planner(_map_message(_occupancy(range(10, 12), pillar=True)), **options)
    plan = planner.plan(**ends)
    assert COMPILES == [] and planner.capacity == from_file.capacity
    assert planner.map.format == "occupancy_grid" and planner.map.resolution == RES
    np.testing.assert_array_equal(planner.map.grid.blocked_np(), from_file.map.grid.blocked_np())
    np.testing.assert_array_equal(plan.cells, expected.cells)
    np.testing.assert_array_equal(plan.world_path(0), expected.world_path(0))
    planner.update_map(_map_message(_occupancy(range(6, 8), pillar=False)))  # the wall moved
    moved = jaxga.Planner(_ros_map(tmp_path, "moved", range(6, 8), pillar=False), **options)
    np.testing.assert_array_equal(planner.plan(**ends).cells, moved.plan(**ends).cells)
    assert planner.capacity == moved.capacity


def test_a_planner_given_a_costmap_blocks_its_inscribed_cells_through_every_update():
    """A costmap on the topic (lethal 100, inscribed 99, graded inflation below):
    ``occupied_from=99`` blocks the lethal and inscribed cells and frees the inflation,
    at the start and at every update; without it the inflation is blocked too."""
    def costmap(rows: range) -> np.ndarray:
        occ = _occupancy(rows, pillar=False)
        occ[rows.start - 1, 0:14] = occ[rows.stop, 0:14] = 99  # inscribed
        occ[rows.start - 2, 0:14] = occ[rows.stop + 1, 0:14] = 40  # inflated cost
        occ[19, :] = -1  # not yet seen
        return occ

    for first, then in ((range(10, 12), range(6, 8)), (range(6, 8), range(12, 14))):
        planner = jaxga.Planner(_map_message(costmap(first)), occupied_from=99,
                                corner_rule="free", seeds=3)
        for rows in (first, then):
            if rows is then:
                planner.update_map(_map_message(costmap(rows)))
            occ = costmap(rows)
            expected = (occ >= 99) | (occ == -1)
            np.testing.assert_array_equal(planner.map.grid.blocked_np(), expected)
    assert jaxga.Planner(_map_message(costmap(range(10, 12))), corner_rule="free",
                         seeds=3).map.grid.blocked_np()[8, 0]  # the cost of 40 blocked


def test_a_costmap_update_keeps_the_larger_capacity_of_programs_of_one_shape():
    """The capacity follows a map's longest optimal path but never shrinks through
    updates whose programs have the same shape: a costmap that opens again keeps the
    programs its closed version compiled. A map of another shape takes its own."""
    open_map = np.zeros((20, 20), np.int8)
    serpentine = open_map.copy()
    for row in range(2, 19, 4):  # walls that leave a gap at alternate ends
        serpentine[row, 1:] = 100
        if row + 2 < 20:
            serpentine[row + 2, :19] = 100
    planner = jaxga.Planner(_map_message(open_map), corner_rule="free", seeds=3)
    small = planner.capacity
    planner.update_map(_map_message(serpentine))
    large = planner.capacity
    assert large > small == jaxga.Planner(_map_message(open_map), corner_rule="free",
                                          seeds=3).capacity
    planner.update_map(_map_message(open_map))
    assert planner.capacity == large and planner.overrides["population__capacity"] == large
    planner.update_map(_map_message(np.zeros((12, 20), np.int8)))  # another shape
    assert planner.capacity == jaxga.Planner(_map_message(np.zeros((12, 20), np.int8)),
                                             corner_rule="free", seeds=3).capacity
    with pytest.raises(jaxga.ParameterError, match="size_class"):
        jaxga.Planner(_map_message(open_map), size_class="yes")


def test_a_planners_map_capacity_and_overrides_are_read_only_and_old_pickles_load(office):
    """``capacity`` and ``overrides`` follow the map (update_map): a key written into
    them is refused, not silently lost at the next update; a planner pickled when they
    were plain attributes unpickles as the same planner."""
    import pickle

    planner = jaxga.Planner(office, robot_radius=0.1, corner_rule="free", seeds=3,
                            generations=canonical.GENERATIONS)
    with pytest.raises(TypeError):
        planner.overrides["generations"] = 5
    with pytest.raises(AttributeError):
        planner.capacity = 96
    old = jaxga.Planner.__new__(jaxga.Planner)
    state = {k: v for k, v in vars(planner).items() if not k.startswith("_")}
    state |= {"map": planner.map, "capacity": planner.capacity,
              "overrides": dict(planner.overrides)}
    old.__dict__.update(state)
    again = pickle.loads(pickle.dumps(old))
    assert again.map == planner.map and again.capacity == planner.capacity
    assert dict(again.overrides) == dict(planner.overrides)
    np.testing.assert_array_equal(again.plan((1, 1), (18, 18)).cells,
                                  planner.plan((1, 1), (18, 18)).cells)
    again.update_map(planner.map)
    assert dict(again.overrides) == dict(planner.overrides)
    with pytest.raises(ParameterError, match="pickled by an older jaxga, which did not "
                                             "keep its robot_radius") as e:
        again.update_map(office)  # its robot_radius is not known: not loaded without it
    assert "\n" not in str(e.value) and again.map == planner.map


def test_a_map_update_resizes_the_capacity_as_a_new_planner_would(monkeypatch):
    """The capacity is the new map's (a stale one left every seed short of path cells),
    and a capacity the user gave stays through every update."""
    from jaxga.api import planner as planner_module

    def by_walls(grid, factor):
        return 160 + 32 * int(grid.blocked_np().sum())

    monkeypatch.setattr(planner_module, "map_capacity", by_walls)
    open_map = jaxga.Grid.create(np.zeros((20, 20), bool))
    walled = np.zeros((20, 20), bool)
    walled[10, :15] = True
    planner = jaxga.Planner(open_map, "sga")
    assert planner.capacity == 160
    assert planner.overrides["population__capacity"] == 160
    planner.update_map(jaxga.Grid.create(walled))
    assert planner.capacity == 160 + 32 * 15
    assert planner.overrides["population__capacity"] == 160 + 32 * 15
    pinned = jaxga.Planner(open_map, "sga", population__capacity=96)
    pinned.map = jaxga.Grid.create(walled)
    assert pinned.capacity is None and pinned.overrides["population__capacity"] == 96


def test_a_plan_reads_one_map_while_another_thread_updates_it(office, tmp_path,
                                                              monkeypatch):
    """A plan takes the map, its frame and its capacity together: an update that lands
    while it is being set up (here: inside the endpoint conversion) is for the next
    plan, never half of this one."""
    from jaxga.api import planner as planner_module

    monkeypatch.setattr(planner_module, "map_capacity",
                        lambda grid, factor: 160 + int(grid.blocked_np()[7, 0]))
    planner = jaxga.Planner(office, robot_radius=0.1, corner_rule="free")
    moved = _ros_map(tmp_path, "moved", range(6, 8), pillar=False)  # the wall moved
    seen = []
    real_endpoints = planner_module.endpoint_cells

    def endpoints_then_update(*args):
        if not seen:
            planner.update_map(moved)
        return real_endpoints(*args)

    def recorded_run(preset, problem, seeds, **kw):
        seen.append((problem.grid.blocked_np(), kw["population__capacity"]))
        raise _Stop

    monkeypatch.setattr(planner_module, "endpoint_cells", endpoints_then_update)
    monkeypatch.setattr(planner_module, "run", recorded_run)
    office_blocked = load_map_info(office, robot_radius=0.1).grid.blocked_np()
    with pytest.raises(_Stop):
        planner.plan((1, 1), (18, 18))
    np.testing.assert_array_equal(seen[0][0], office_blocked)
    assert seen[0][1] == 160  # the office's capacity, with the office
    assert planner.map.path.name == "moved.yaml" and planner.capacity == 161
    with pytest.raises(_Stop):
        planner.plan((1, 1), (18, 18))
    assert not np.array_equal(seen[1][0], office_blocked) and seen[1][1] == 161


class _Stop(Exception):
    """Ends a recorded plan before its runs."""


def test_plans_from_several_threads_equal_the_same_plans_one_after_another(office):
    """A multi-threaded executor's callbacks share one planner: each thread gets its own
    pair's plan, bit for bit the plan of the same call made alone."""
    import concurrent.futures

    planner = jaxga.Planner(office, robot_radius=0.1, corner_rule="free", seeds=3,
                            generations=canonical.GENERATIONS)  # with the references
    pairs = [((1, 1), (18, 18)), ((18, 2), (2, 16)), ((5, 17), (17, 8)), ((2, 2), (3, 17))]
    alone = [planner.plan(s, g) for s, g in pairs]
    with concurrent.futures.ThreadPoolExecutor(4) as pool:
        together = list(pool.map(lambda pair: planner.plan(*pair), pairs * 2))
    for (s, g), one, other in zip(pairs * 2, alone * 2, together, strict=True):
        assert (other.start, other.goal) == (s, g)
        np.testing.assert_array_equal(other.cells, one.cells)
        np.testing.assert_array_equal(other.length, one.length)
