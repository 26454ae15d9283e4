"""Local re-planning (MPMGA 5.2.1 / 5.3.1): splice feasibility, the paper's two
scenarios, no-path results, errors and the ``jaxga replan`` command line.

Every GA call here uses the same preset, map shape (25 x 25, the 50 x 50 scenario runs in a
25 x 25 window), seed count and budget, so the whole file compiles ONE set of programs.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import jaxga.api
from jaxga.cli import EXIT_BAD_INPUT, EXIT_NO_PATH, main
from jaxga.core.errors import EndpointError, ParameterError
from jaxga.core.grid import Grid
from jaxga.maps import save_map
from jaxga.reference.optima import clear_np
from jaxga.replan import (
    first_blocked_step,
    mpmga_cell,
    mpmga_scenario,
    remove_loops_xy,
    replan,
)

BUDGET = dict(seeds=4, generations=10, population=10)  # one compiled program for the file


@pytest.fixture(scope="module")
def sc25():
    return mpmga_scenario("25x25")


@pytest.fixture(scope="module")
def sc50():
    return mpmga_scenario("50x50")


def assert_feasible(grid, new_obstacles, path, robot, goal, continuous=True):
    """Independent check: starts at the robot, ends at the goal, every step 8-adjacent
    (when continuous) and clear under the corner rule on the updated map."""
    blocked = grid.blocked_np().copy()
    for x, y in new_obstacles:
        blocked[y, x] = True
    assert path[0] == robot and path[-1] == goal
    for a, b in zip(path, path[1:], strict=False):
        if continuous:
            assert max(abs(a[0] - b[0]), abs(a[1] - b[1])) == 1, (a, b)
        assert clear_np(blocked, grid.corner_rule, a, b), (a, b)
    assert not set(path) & set(map(tuple, new_obstacles))
    assert len(set(path)) == len(path)  # loop-free


def test_mpmga_cell_numbering():
    # MPMGA section 3: 0, 1, 2, ... left to right, bottom to top == jaxga y * W + x
    assert mpmga_cell(0, 25) == (0, 0) and mpmga_cell(24, 25) == (24, 0)
    assert mpmga_cell(25, 25) == (0, 1) and mpmga_cell(624, 25) == (24, 24)
    assert [mpmga_cell(p, 25) for p in (295, 320, 345, 370)] == [
        (20, 11), (20, 12), (20, 13), (20, 14)]
    assert mpmga_cell(759, 50) == (9, 15) and mpmga_cell(963, 50) == (13, 19)
    assert {mpmga_cell(p, 50) for p in (810, 811, 812, 860, 861, 862, 910, 911, 912)} == {
        (x, y) for x in (10, 11, 12) for y in (16, 17, 18)}


def test_scenarios_put_the_papers_cells_on_the_planned_path(sc25, sc50):
    p = sc25.path
    i = p.index((20, 11))
    assert p[i:i + 4] == [(20, 11), (20, 12), (20, 13), (20, 14)]
    assert p[0] == (10, 0) and p[-1] == (24, 24)  # entry grid 10, exit grid 624
    q = sc50.path
    j = q.index((9, 15))
    assert q[j:j + 5] == [(9, 15), (10, 16), (11, 17), (12, 18), (13, 19)]
    assert q[0] == (0, 0) and q[-1] == (49, 49)  # entry grid 0, exit grid 2499


@pytest.mark.slow
def test_mpmga_25x25_scenario(sc25):
    """MPMGA 5.2.1: obstacles at 320 and 345, robot at 295, re-plan to 370."""
    r = replan(sc25.grid, sc25.path, sc25.new_obstacles, sc25.position, **BUDGET)
    assert r.success and r.status == "replanned" and not r.used_fallback
    assert r.blockage == ((20, 11), (20, 12))
    assert r.rejoin == (20, 14) == sc25.rejoin
    assert r.segment[0] == (20, 11) and r.segment[-1] == (20, 14)
    assert_feasible(sc25.grid, sc25.new_obstacles, r.path, sc25.position, sc25.path[-1])
    assert_feasible(sc25.grid, sc25.new_obstacles, r.segment, (20, 11), (20, 14))
    i = sc25.path.index(sc25.position)
    assert r.prefix == sc25.path[:i + 1]
    assert r.path[len(r.segment) - 1:] == sc25.path[sc25.path.index((20, 14)):]
    assert r.length == pytest.approx(
        sum(np.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(r.path, r.path[1:],
                                                             strict=False)))
    assert r.latency_s >= 0 and r.compile_s >= 0 and r.wall_s >= r.latency_s
    assert len(r.ga) == 1 and r.segments[0]["ga_success"] >= 1


@pytest.mark.slow
def test_mpmga_50x50_scenario_in_a_window(sc50):
    """MPMGA 5.3.1: a 3 x 3 block at 810-812/860-862/910-912, robot at 759, re-plan to 963
    (the GA runs on a 25 x 25 crop: the same compiled program as the 25 x 25 tests)."""
    r = replan(sc50.grid, sc50.path, sc50.new_obstacles, sc50.position, window=25, **BUDGET)
    assert r.success and r.status == "replanned"
    assert r.rejoin == (13, 19) and r.blockage == ((9, 15), (10, 16))
    assert r.segments[0]["window"] is not None and r.segments[0]["window"][2:] == (25, 25)
    assert_feasible(sc50.grid, sc50.new_obstacles, r.path, (9, 15), (49, 49))
    assert r.ga[0].width == 25


# The file's small budget (10 individuals, init.max_tries 20) leaves a few initial slots of
# MPMGA's intermittent initialisation filled with copies in the second re-planning, and
# jaxga.api.run warns so (test_api.py tests that warning); this test is about the splices.
@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::jaxga.core.errors.InitialisationWarning")
def test_every_blocked_part_is_replanned_and_loops_removed(sc25):
    """Two separate blockages: two splices (the second from the last clear cell before
    it); the result is one feasible loop-free path."""
    later = sc25.path[-4]  # a cell near the goal, far beyond the first blockage
    obstacles = [*sc25.new_obstacles, later]
    r = replan(sc25.grid, sc25.path, obstacles, sc25.position, **BUDGET)
    assert r.success and len(r.segments) == 2
    assert r.segments[1]["blockage"][1] == later
    assert_feasible(sc25.grid, obstacles, r.path, sc25.position, sc25.path[-1])


def test_plan_from_blockage_keeps_the_clear_prefix(sc25):
    pos = sc25.path[sc25.path.index((20, 11)) - 3]
    r = replan(sc25.grid, sc25.path, sc25.new_obstacles, pos, plan_from="blockage",
               **BUDGET)
    assert r.success and r.segments[0]["start"] == (20, 11)
    i = sc25.path.index(pos)
    assert r.path[:4] == sc25.path[i:i + 4]
    assert_feasible(sc25.grid, sc25.new_obstacles, r.path, pos, sc25.path[-1])


def test_nothing_blocked_returns_remaining_path_without_ga(sc25, monkeypatch):
    def no_run(*a, **k):  # pragma: no cover - must not be called
        raise AssertionError("the GA must not run when nothing is blocked")

    monkeypatch.setattr(jaxga.api, "run", no_run)
    i = sc25.path.index(sc25.position)
    behind = [sc25.path[1], (0, 24)]  # on the travelled part, and off the path
    for obstacles in ([], behind, np.zeros((25, 25), bool)):
        r = replan(sc25.grid, sc25.path, obstacles, sc25.position)
        assert r.success and r.status == "clear"
        assert r.path == sc25.path[i:] and r.segments == [] and r.ga == []
        assert r.rejoin is None and r.blockage is None and r.compile_s == 0.0
        # the rule the path was judged under, in the summary and the JSON
        assert r.corner_rule == sc25.grid.corner_rule == r.to_json()["corner_rule"]
        assert f"corner rule {sc25.grid.corner_rule!r}" in r.summary()
    at_goal = len(sc25.path) - 1
    strict = replan(sc25.grid.replace(corner_rule="strict"), sc25.path, [], at_goal)
    assert strict.corner_rule == "strict" and strict.status == "clear"
    r = replan(sc25.grid, sc25.path, [], len(sc25.path) - 1)  # at the goal
    assert r.success and r.path == [sc25.path[-1]] and r.length == 0.0


def test_first_blocked_step_and_corner_rule():
    b = np.zeros((3, 3), bool)
    b[0, 1] = True  # side cell of the diagonal (0, 0) -> (1, 1)
    path = [(0, 0), (1, 1), (2, 2)]
    assert first_blocked_step(b, "free", path) is None
    assert first_blocked_step(b, "no_squeeze", path) is None
    assert first_blocked_step(b, "strict", path) == 0
    b[2, 2] = True
    assert first_blocked_step(b, "free", path) == 1
    assert remove_loops_xy([(0, 0), (1, 0), (1, 1), (1, 0), (2, 0)]) == [
        (0, 0), (1, 0), (2, 0)]


def test_unreachable_and_blocked_goal_are_results(sc25):
    goal = sc25.path[-1]  # (24, 24), the top-right corner
    wall = [(23, 24), (23, 23), (24, 23)]
    r = replan(sc25.grid, sc25.path, [*sc25.new_obstacles, *wall], sc25.position)
    assert not r.success and r.status == "unreachable" and r.path == []
    assert "unreachable" in r.reason and str(goal) in r.reason and r.length == np.inf
    r = replan(sc25.grid, sc25.path, [goal], sc25.position)
    assert not r.success and r.status == "goal_blocked" and "blocked" in r.reason


def test_invalid_robot_cell_and_arguments(sc25):
    g, p = sc25.grid, sc25.path
    with pytest.raises(EndpointError, match="blocked"):
        replan(g, p, [sc25.position], sc25.position)
    with pytest.raises(ParameterError, match="not on the path"):
        replan(g, p, [], (0, 24))
    with pytest.raises(EndpointError, match="off the"):
        replan(g, p, [], (30, 3))
    with pytest.raises(ParameterError, match="off the"):
        replan(g, p, [(25, 0)], sc25.position)
    with pytest.raises(ParameterError, match="outside the path"):
        replan(g, p, [], len(p))
    with pytest.raises(ParameterError, match="shape"):
        replan(g, p, np.zeros((3, 3), bool), sc25.position)
    with pytest.raises(ParameterError):
        replan(g, p, [], sc25.position, plan_from="nowhere")
    with pytest.raises(ParameterError, match="empty"):
        replan(g, [], [], sc25.position)
    # coordinates are integers: 0.9 is not cell 0 (they were truncated)
    with pytest.raises(ParameterError, match="integer pairs"):
        replan(g, [(x + 0.5, y) for x, y in p], [], sc25.position)
    with pytest.raises(ParameterError, match="integer pairs"):
        replan(g, p, [(20.7, 12.2)], sc25.position)
    with pytest.raises(ParameterError, match="integer pairs"):
        replan(g, p, [], (20.5, 11))
    for obstacles in ([(20, 12)], []):  # also when nothing is blocked and no GA runs
        with pytest.raises(ParameterError, match="population"):
            replan(g, p, obstacles, sc25.position, population=2.5)
        # MPMGA's rates are per island: a single rate would change nothing
        with pytest.raises(ParameterError, match="crossover.probability has no effect"):
            replan(g, p, obstacles, sc25.position, "mpmga", crossover__probability=0.7)
        with pytest.raises(ParameterError, match="fitness.omega has no effect"):
            replan(g, p, obstacles, sc25.position, sets=("fitness.omega=0.5",))
        with pytest.raises(ParameterError, match="population.size is given twice"):
            replan(g, p, obstacles, sc25.position, population=12,
                   sets=("population.size=30",))


def test_sets_of_the_ga_size_replace_replans_defaults(sc25, monkeypatch):
    """``jaxga replan --set population.size=30`` (or generations) is the GA's size, not a
    second value against replan's defaults of 10 and 20."""
    import jaxga.api

    seen = {}

    def fake_run(preset, grid, seeds, **options):
        seen.update(options)
        raise KeyboardInterrupt

    monkeypatch.setattr(jaxga.api, "run", fake_run)
    with pytest.raises(KeyboardInterrupt):
        replan(sc25.grid, sc25.path, [(20, 12)], sc25.position,
               sets=("population.size=30", "generations=30"))
    # the capacity is pinned at 4 (H + W) of the map: one program per map size
    # and no any-angle reference: a re-plan reports its segment, not a gap
    assert seen == {"sets": ("population.size=30", "generations=30"),
                    "population__capacity": 4 * (25 + 25), "any_angle_budget": 0.0}
    seen.clear()
    with pytest.raises(KeyboardInterrupt):
        replan(sc25.grid, sc25.path, [(20, 12)], sc25.position,
               sets=("population.capacity=120",))
    assert "population__capacity" not in seen  # a capacity given is the user's


def test_ga_failure_is_honest_and_fallback_is_flagged(sc25, monkeypatch):
    real = jaxga.api.run

    def failing(*a, **k):
        r = real(*a, **k)
        return dataclasses.replace(r, success=np.zeros_like(r.success))

    monkeypatch.setattr(jaxga.api, "run", failing)
    r = replan(sc25.grid, sc25.path, sc25.new_obstacles, sc25.position, **BUDGET)
    assert not r.success and r.status == "ga_failed" and r.path == []
    assert "no feasible segment" in r.reason and not r.used_fallback
    r = replan(sc25.grid, sc25.path, sc25.new_obstacles, sc25.position, fallback=True,
               **BUDGET)
    assert r.success and r.status == "fallback" and r.used_fallback
    assert "A*" in r.reason
    assert_feasible(sc25.grid, sc25.new_obstacles, r.path, sc25.position, sc25.path[-1])


def _cli_files(tmp_path, sc):
    m = save_map(sc.grid, tmp_path / "map.txt")
    plain = tmp_path / "path.json"
    plain.write_text(json.dumps([list(c) for c in sc.path]))
    run_json = tmp_path / "run.json"
    run_json.write_text(json.dumps({"runs": [
        {"success": False, "raw_path": [], "path": []},
        {"success": True, "raw_path": [list(c) for c in sc.path], "raw_length": 30.0,
         "path": [list(sc.path[0]), list(sc.path[-1])]}]}))
    return str(m), str(plain), str(run_json)


@pytest.mark.slow
def test_cli_replan_end_to_end(tmp_path, sc25, capsys):
    m, plain, run_json = _cli_files(tmp_path, sc25)
    out = tmp_path / "out.json"
    common = ["--map", m, "--obstacles", "20,12;20,13", "--position", "20,11",
              "--seeds", "4", "--generations", "10", "--population", "10"]
    assert main(["replan", "--path-json", plain, *common, "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["success"] and data["status"] == "replanned" and data["rejoin"] == [20, 14]
    path = [tuple(c) for c in data["path"]]
    assert_feasible(sc25.grid, sc25.new_obstacles, path, (20, 11), (24, 24))
    assert "replanned" in capsys.readouterr().out
    # the JSON of `jaxga run` (--raw: its successful run's raw path), obstacles given twice
    assert main(["replan", "--path-json", run_json, "--raw", "--map", m, "--obstacles", "20,12",
                 "--obstacles", "20,13", "--position", "20,11", "--seeds", "4",
                 "--generations", "10", "--population", "10", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["rejoin"] == [20, 14]


@pytest.mark.parametrize("extra, code, words", [
    (["--position", "0,24"], EXIT_BAD_INPUT, "not on the path"),
    (["--position", "20,11", "--obstacles", "20,11"], EXIT_BAD_INPUT, "blocked"),
    (["--position", "20,11", "--obstacles", "23,24;23,23;24,23;20,12"], EXIT_NO_PATH,
     "unreachable"),
    (["--position", "20,11", "--corner-rule", "loose"], EXIT_BAD_INPUT, "corner rule"),
    (["--position", "20,11", "--obstacles", "x"], EXIT_BAD_INPUT, "--obstacles"),
    (["--position", "20,11", "--obstacles", "4,4;5"], EXIT_BAD_INPUT, "'5'"),
    (["--position", "-1,0"], EXIT_BAD_INPUT, "(-1, 0)"),
    (["--position", "20,11", "--obstacles", "-1,0"], EXIT_BAD_INPUT, "(-1, 0) is off the"),
])
def test_cli_replan_errors(tmp_path, sc25, capsys, extra, code, words):
    m, plain, _ = _cli_files(tmp_path, sc25)
    assert main(["replan", "--map", m, "--path-json", plain, *extra]) == code
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and words in err and "Traceback" not in err


def test_cli_replan_bad_path_file(tmp_path, sc25, capsys):
    m, _, _ = _cli_files(tmp_path, sc25)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    args = ["replan", "--map", m, "--position", "20,11", "--path-json"]
    assert main([*args, str(bad)]) == EXIT_BAD_INPUT
    assert "not valid JSON" in capsys.readouterr().err
    bad.write_text(json.dumps({"runs": [{"success": False}]}))
    assert main([*args, str(bad)]) == EXIT_BAD_INPUT
    capsys.readouterr()
    # malformed JSON of `jaxga run`, and cells that are not integers: one line each
    for content in ('{"runs": 5}', '{"runs": [1, 2]}', '{"runs": {"a": 1}}',
                    "[[0.9, 0.9], [1.9, 1.9]]", "[[0, 0], [1e400, 1]]"):
        bad.write_text(content)
        assert main([*args, str(bad)]) == EXIT_BAD_INPUT, content
        err = capsys.readouterr().err.strip()
        assert "bad.json" in err and "\n" not in err and "Traceback" not in err, err
    # a length that is not a number sorts last: the other run's path is taken
    bad.write_text(json.dumps({"runs": [
        {"success": True, "path": [list(c) for c in sc25.path], "length": "x"},
        {"success": True, "path": [[0, 0], [1, 1]], "length": 1.0}]}))
    assert main([*args, str(bad)]) == EXIT_BAD_INPUT
    assert "(20, 11) is not on the path" in capsys.readouterr().err
    bad.write_text(bad.read_text().replace('"x"', "1" + "0" * 400))  # too large for a float
    assert main([*args, str(bad)]) == EXIT_BAD_INPUT
    assert "(20, 11) is not on the path" in capsys.readouterr().err
    assert main([*args, str(tmp_path / "missing.json")]) == EXIT_BAD_INPUT


@pytest.mark.slow
@pytest.mark.parametrize("block", [((10, 11, 12), (12, 13)), ((10, 11, 12), (11, 12, 13))])
def test_the_default_replan_finds_the_detour_an_exact_search_finds(block):
    """A corridor three cells wide (rows 11-13 of a 25 x 25 map, the file's map shape and
    budget), the path along its middle, a 3 x 2 block on the path: the exact search on the
    updated map finds a detour, and so does the default re-plan (preset hybrid), spliced
    feasibly from the robot's cell to the goal. A 3 x 3 block closes the corridor: no
    detour exists, and the re-plan says so instead of returning a path."""
    from jaxga.reference.optima import shortest_path_np

    blocked = np.ones((25, 25), bool)
    blocked[11:14, 1:24] = False
    grid = Grid.create(blocked, start=(1, 12), goal=(23, 12), corner_rule="strict")
    path = [(x, 12) for x in range(1, 24)]
    obstacles = [(x, y) for x in block[0] for y in block[1]]
    updated = blocked.copy()
    for x, y in obstacles:
        updated[y, x] = True
    exact = shortest_path_np(updated, (3, 12), (23, 12), "strict")
    r = replan(grid, path, obstacles, (3, 12), **BUDGET)
    if len(block[1]) == 2:
        assert exact.found
        assert r.success and r.status == "replanned" and not r.used_fallback, r.reason
        assert_feasible(grid, obstacles, r.path, (3, 12), (23, 12))
        assert r.length >= exact.length - 1e-9
    else:
        assert not exact.found
        assert not r.success and r.path == [] and r.status == "unreachable"


def test_replan_on_a_ros_map_keeps_the_radius_from_new_obstacles(tmp_path, capsys):
    """A 25 x 25 map in map_saver's format (0.1 m cells, origin (-1.25, -1.25): a wall and
    a block of unknown cells, blocked as the map's rule says), planned with a 0.1 m robot
    radius (1 cell). `jaxga replan` with the robot's position and a new obstacle in metres
    (negative coordinates, no '='): the path's own ends are the endpoints (the map's
    default corner (0, 0) is inside the inflated wall and must not matter), the new
    obstacle grows by the same radius, so every cell of the new path is more than one
    cell from it, and no cell of it is unknown or within the map's inflation. The same
    GA budget and 25 x 25 shape as the file's other calls: its compiled programs."""
    import math

    from jaxga.maps import load_map_info

    img = np.full((25, 25), 254, np.uint8)  # top row first
    img[:, 0] = 0                 # a wall along the left edge (x = 0)
    img[8:12, 8:20] = 205         # unknown cells: rows y = 13..16, x = 8..19
    img[20, 4:21] = 0             # a wall at y = 4
    (tmp_path / "map.pgm").write_bytes(b"P5\n# CREATOR: map_saver.cpp 0.100 m/pix\n25 25\n"
                                       b"255\n" + img.tobytes())
    (tmp_path / "map.yaml").write_text(
        "image: map.pgm\nresolution: 0.100000\norigin: [-1.250000, -1.250000, 0.000000]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n\n")
    ros = str(tmp_path / "map.yaml")
    where = ["--map", ros, "--robot-radius", "0.1", "--corner-rule", "free"]
    plan = tmp_path / "plan.json"
    # from cell (3, 2) to (22, 22): (-1.25 + 0.35, -1.25 + 0.25) and (1.0, 1.0) m
    assert main(["optimum", *where, "--start-world", "-0.9,-1.0", "--goal-world", "1.0,1.0",
                 "--json", str(plan)]) == 0
    path = [tuple(c) for c in json.loads(plan.read_text())["path"]]
    assert path[0] == (3, 2) and path[-1] == (22, 22)
    robot, hit = path[3], path[12]

    def to_m(c):
        return f"{-1.25 + 0.1 * (c[0] + 0.5):.2f},{-1.25 + 0.1 * (c[1] + 0.5):.2f}"

    out = tmp_path / "replanned.json"
    rc = main(["replan", *where, "--path-json", str(plan), "--position-world", to_m(robot),
               "--obstacles-world", to_m(hit), "--seeds", "4", "--generations", "10",
               "--population", "10", "--json", str(out), "--plot", str(tmp_path / "r.png")])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    doc = json.loads(out.read_text())
    new = [tuple(c) for c in doc["path"]]
    assert doc["success"] and new[0] == robot and new[-1] == (22, 22)
    assert all(math.dist(c, hit) > 1.0 for c in new)  # the radius from the new obstacle
    info = load_map_info(ros, robot_radius=0.1, corner_rule="free")
    blocked = info.grid.blocked_np()
    assert not any(blocked[y, x] for x, y in new)
    assert not any(info.layers.unknown[y, x] or info.layers.wall[y, x] for x, y in new)
    np.testing.assert_allclose(doc["path_world"], [[-1.25 + 0.1 * (x + 0.5),
                                                    -1.25 + 0.1 * (y + 0.5)] for x, y in new])
    assert doc["length_m"] == pytest.approx(0.1 * doc["length"])
    # without growing the new obstacle the detour may pass next to it: the radius is
    # what the inflation adds (the API's inflate= is the CLI's --robot-radius)
    bare = replan(info.grid, path, [hit], robot, **BUDGET)
    assert bare.success and min(math.dist(c, hit) for c in bare.path) < \
        min(math.dist(c, hit) for c in new) + 1e-9


def _ros_corridor(tmp_path):
    """A 25 x 25 ROS map at 0.1 m, origin (-1.25, -1.25), with a wall at y = 4 (x 4-20)."""
    img = np.full((25, 25), 254, np.uint8)  # top row first
    img[20, 4:21] = 0
    (tmp_path / "map.pgm").write_bytes(b"P5\n25 25\n255\n" + img.tobytes())
    (tmp_path / "map.yaml").write_text(
        "image: map.pgm\nresolution: 0.1\norigin: [-1.25, -1.25, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return str(tmp_path / "map.yaml")


def test_replan_checks_the_post_optimised_path_the_robot_drives(tmp_path, capsys):
    """A new obstacle that the post-optimised path (what the robot was given, what
    --path-out wrote) crosses but the raw 8-connected path keeps clear of: `jaxga replan`
    on the run's JSON re-plans (the raw path, --raw, is reported clear); the same from
    the --path-out file in metres; the robot between two waypoints becomes one; the new
    path is written in metres (--path-out)."""
    import math

    from jaxga.export import read_path, write_path
    from jaxga.maps import load_map_info
    from jaxga.reference.optima import line_walk, shortest_path_np

    ros = _ros_corridor(tmp_path)
    info = load_map_info(ros, robot_radius=0.1, corner_rule="free")
    blocked = info.grid.blocked_np()
    raw = [(int(x), int(y)) for x, y in shortest_path_np(blocked, (2, 8), (22, 20), "free").path]
    post = [raw[0], raw[-1]]
    assert clear_np(blocked, "free", *post)
    crossed = [c for c, _ in line_walk(*post)][:-1]
    hit = next(c for c in crossed  # crossed by the waypoint segment, beyond 1 cell of raw
               if min(math.dist(c, r) for r in raw) > 1.5 and c[0] > 6)
    robot = next(c for c in crossed if c in raw)  # on the raw path; inside the segment
    run = tmp_path / "run.json"
    run.write_text(json.dumps({"runs": [{
        "success": True, "path": [list(c) for c in post], "length": math.dist(*post),
        "raw_path": [list(c) for c in raw], "raw_length": float(len(raw))}]}))
    to_m = info.frame.to_world
    where = ["--map", ros, "--robot-radius", "0.1", "--corner-rule", "free",
             "--position-world", ",".join(f"{v:.3f}" for v in to_m(np.asarray(robot, float))),
             "--obstacles-world", ",".join(f"{v:.3f}" for v in to_m(np.asarray(hit, float))),
             "--seeds", "4", "--generations", "10", "--population", "10"]
    out, written = tmp_path / "replanned.json", tmp_path / "new.yaml"
    assert main(["replan", "--path-json", str(run), *where, "--raw", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["status"] == "clear"
    assert main(["replan", "--path-json", str(run), *where, "--json", str(out),
                 "--path-out", str(written)]) == 0
    doc = json.loads(out.read_text())
    new = [tuple(c) for c in doc["path"]]
    assert doc["status"] == "replanned" and new[0] == robot and new[-1] == post[-1]
    assert all(math.dist(c, hit) > 1.0 for c in new)
    np.testing.assert_allclose(read_path(written), to_m(np.asarray(new, float)), atol=1e-4)
    assert "metres      length" in capsys.readouterr().out
    # the path file the robot was given (metres), as `jaxga run --path-out` writes it
    given = tmp_path / "given.csv"
    write_path(given, to_m(np.asarray(post, float)))
    assert main(["replan", "--path", str(given), *where, "--json", str(out)]) == 0
    assert json.loads(out.read_text())["status"] == "replanned"
    capsys.readouterr()
    three = tmp_path / "three.csv"  # x,y,z rows: never read as pairs of pairs
    three.write_text("x,y\n1,2,3\n4,5,6\n")
    for extra, words in ((["--path", str(given), "--path-json", str(run)], "once"),
                         (["--path", str(given), "--raw"], "--path-json"),
                         (["--path", str(run)], ".csv"),
                         (["--path", str(three)], "two values")):
        assert main(["replan", *where, *extra]) == EXIT_BAD_INPUT
        err = capsys.readouterr().err.strip()
        assert words in err and "\n" not in err


@pytest.mark.parametrize("rule, blocked, path, robot", [
    ("free", [(2, 0)], [(0, 0), (3, 1)], (1, 0)),     # robot -> (3, 1) would enter (2, 0)
    ("strict", [(0, 2)], [(0, 0), (1, 2)], (0, 1)),   # robot -> (1, 2): a squeezed diagonal
])
def test_a_robot_between_waypoints_finds_no_blockage_that_is_not_there(rule, blocked, path,
                                                                       robot):
    """A robot inside a clear waypoint segment becomes a waypoint without making the rest
    of the segment look blocked: the line from its centre may enter cells the segment does
    not, so the segment's own cells follow it there. Nothing new is blocked: nothing runs."""
    b = np.zeros((3, 5), bool)
    for x, y in blocked:
        b[y, x] = True
    grid = Grid.create(b, corner_rule=rule)
    assert clear_np(b, rule, *path)
    r = replan(grid, path, [], robot, **BUDGET)
    assert r.success and r.status == "clear" and r.path[0] == robot and r.path[-1] == path[-1]
    assert all(clear_np(b, rule, p, q) for p, q in zip(r.path[:-1], r.path[1:]))
