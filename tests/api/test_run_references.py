"""A run's references within their budget (jaxga._runtime.references): the exact any-angle
optimum, or its proven lower bound and a gap to it that says so."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jaxga._runtime import references
from jaxga.api.result import Result
from jaxga.core.grid import Grid
from jaxga.reference.any_angle import any_angle_shortest_path_np
from jaxga.reference.lower_bound import euclidean_lower_bound_np
from jaxga.reference.optima import clear_pairs_np, octile_length, shortest_path_np


def _grid():
    b = np.zeros((40, 40), bool)
    b[5:35, 20] = True
    b[20, 5:20] = True
    return Grid.create(b, start=(2, 2), goal=(37, 37), corner_rule="strict")


def test_no_budget_gives_the_exact_optimum_and_a_tiny_budget_only_the_bound(monkeypatch):
    grid = _grid()
    b = grid.blocked_np()
    octile = references.octile_optimum(grid)
    exact = any_angle_shortest_path_np(b, grid.start_xy, grid.goal_xy, "strict")
    bound = euclidean_lower_bound_np(b, grid.start_xy, grid.goal_xy, "strict")
    references._CACHE.clear()
    with monkeypatch.context() as m:  # a budget of 0 skips both searches (--no-reference)
        m.setattr(references, "euclidean_lower_bound_np", lambda *a, **k: pytest.fail("ran"))
        skipped = references.any_angle_references(grid, octile, 0.0)
    assert skipped.note == references.SKIPPED_NOTE
    assert math.isnan(skipped.optimum) and math.isnan(skipped.lower_bound)
    seen = []
    cut = references.any_angle_references(grid, octile, 1e-9, seen.append)
    assert math.isnan(cut.optimum) and len(cut.path) == 0
    assert cut.note == "any-angle optimum not computed (budget 0.00 s)"
    assert math.isnan(cut.lower_bound) or cut.lower_bound == pytest.approx(bound.length)
    assert seen[-1] == 1.0
    full = references.any_angle_references(grid, octile, None)  # a larger budget: again
    assert full.optimum == pytest.approx(exact.length) and full.note == ""
    assert full.lower_bound == pytest.approx(bound.length)
    assert full.lower_bound <= full.optimum
    np.testing.assert_array_equal(full.path, exact.path)
    again = references.any_angle_references(grid, octile, 0.0)  # cached: no search
    assert again is full


def test_a_search_out_of_memory_is_a_note_not_a_crash(monkeypatch):
    """A reference search that runs out of memory (a large map without a budget) gives
    the note that says so, the run and the other reference going on; not cached, so a
    later call may compute it."""
    grid = _grid()
    octile = references.octile_optimum(grid)

    def out_of_memory(*_a, **_k):
        raise MemoryError("Unable to allocate 1.80 GiB")

    references._CACHE.clear()
    with monkeypatch.context() as m:
        m.setattr(references, "any_angle_shortest_path_np", out_of_memory)
        short = references.any_angle_references(grid, octile, None)
    assert short.note == references.MEMORY_NOTE and math.isnan(short.optimum)
    assert math.isfinite(short.lower_bound)  # the bound's search had memory enough
    with monkeypatch.context() as m:
        m.setattr(references, "euclidean_lower_bound_np", out_of_memory)
        full = references.any_angle_references(grid, octile, None)
    assert full.note == "" and math.isfinite(full.optimum) and math.isnan(full.lower_bound)


def test_a_result_measures_its_gap_against_what_was_computed():
    """gap_reference: the exact optimum, else the lower bound (the gap then bounds the true
    gap from above), else the straight line; the summary and JSON say which."""
    base = dict(preset="p", map_name="m", corner_rule="strict", seeds=np.arange(2),
                success=np.array([True, False]), reason="", cells=np.zeros((2, 1), int),
                n_cells=np.ones(2, int), raw_cells=np.zeros((2, 1), int),
                raw_n_cells=np.ones(2, int), length=np.array([11.0, np.nan]),
                raw_length=np.array([12.0, np.nan]), fitness=np.array([0.1, np.nan]),
                convergence_generation=np.zeros(2, int),
                history={k: np.zeros((2, 1)) for k in ("best", "mean", "std")},
                metrics={k: np.array([1.0, np.nan]) for k in ("angle_sum", "turns")},
                raw_metrics={}, failures=np.zeros((2, 3), int),
                init_success_rate=np.ones(2), init_unfilled=np.zeros(2, int), optimum=12.0,
                timing={"total_s": 1.0}, population=4, generations=1, width=1)
    exact = Result(**base, any_angle_optimum=10.0, lower_bound=9.5)
    assert exact.gap_basis == "any-angle optimum" and exact.gap[0] == pytest.approx(0.1)
    bound = Result(**base, any_angle_optimum=math.nan, lower_bound=10.0,
                   any_angle_note="any-angle optimum not computed (budget 0.50 s)")
    assert bound.gap_basis == "lower bound" and bound.gap[0] == pytest.approx(0.1)
    assert np.isnan(bound.gap[1])
    text = bound.summary()
    assert "any-angle optimum not computed (budget 0.50 s), lower bound 10.0000" in text
    assert ("gap = length / lower bound - 1 (a lower bound of the any-angle optimum: at "
            "least the gap to that optimum)") in text
    doc = bound.to_json()
    assert doc["gap_basis"] == "lower bound" and doc["any_angle_optimum"] is None
    assert doc["lower_bound"] == 10.0 and doc["runs"][0]["gap"] == pytest.approx(0.1)
    # neither computed (skipped): the straight line from start to goal, a lower bound
    # that no path beats, never the 8-connected optimum (which any-angle paths beat)
    neither = Result(**base, any_angle_optimum=math.nan, lower_bound=math.nan,
                     start=(0, 0), goal=(6, 8))
    assert neither.gap_basis == "straight line"
    assert neither.gap[0] == pytest.approx(11 / 10 - 1)
    assert "the straight line from start to goal is a lower bound" in neither.summary()
    # no path (the goal unreachable): nothing to measure against, whatever was skipped
    unreachable = Result(**{**base, "optimum": math.inf, "success": np.array([False, False]),
                            "length": np.full(2, np.nan)}, any_angle_optimum=math.nan,
                         lower_bound=math.nan, start=(0, 0), goal=(6, 8))
    assert unreachable.gap_basis == "none" and math.isnan(unreachable.gap_reference)
    assert "gaps: none (no path exists)" in unreachable.summary()
    assert unreachable.to_json()["gap_basis"] == "none"


@pytest.mark.parametrize("rule", ["free", "no_squeeze", "strict"])
def test_the_octile_optimum_read_off_the_goals_field_is_the_searchs(rule):
    """With the exact distance fields (the field-walk presets compute them anyway) the
    8-connected optimum is read off the goal's field: the same length as the A* search,
    bit for bit; a path from start to goal of legal moves with that length; a blocked or
    unreachable endpoint gets the search's own reason."""
    rng = np.random.default_rng(7)
    blocked = rng.random((14, 17)) < 0.3
    free = np.argwhere(~blocked)[:, ::-1]
    for k in range(40):
        s, g = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2))
        if k == 0:
            g = s
        grid = Grid.create(blocked, start=s, goal=g, corner_rule=rule)
        field = references.octile_optimum(grid, guided=True)
        search = shortest_path_np(blocked, s, g, rule)
        assert (field.found, field.reason, field.status) == (
            search.found, search.reason, search.status)
        if not field.found:
            continue
        assert field.length == search.length == octile_length(field.path)
        p = field.path
        assert tuple(p[0]) == s and tuple(p[-1]) == g
        assert np.all(np.abs(np.diff(p, axis=0)).max(axis=1) == 1)
        assert clear_pairs_np(blocked, rule, p[:-1], p[1:]).all()
    wall = blocked.copy()
    wall[:, 8] = True  # two halves: unreachable
    wall[0, 0] = wall[13, 16] = False
    grid = Grid.create(wall, start=(0, 0), goal=(16, 13), corner_rule=rule)
    field = references.octile_optimum(grid, guided=True)
    assert not field.found and field.status == "unreachable"
    assert field.reason == shortest_path_np(wall, (0, 0), (16, 13), rule).reason
    wall[0, 0] = True
    grid = Grid.create(wall, start=(0, 0), goal=(16, 13), corner_rule=rule)
    field = references.octile_optimum(grid, guided=True)
    assert not field.found and field.status == "endpoint_blocked" and "blocked" in field.reason
