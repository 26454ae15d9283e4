"""Hostile inputs to the Python API (decision 053): what a notebook user may pass to the
functions around a run (map files written, smoothing, a user's operators, comparisons,
per-seed accessors, plots, map options, the planner, the references) is refused in one
line naming the cause, or written whole and read back as written; never a silent wrong
value, a deep traceback or a damaged file."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxga
from jaxga import testing
from jaxga.api.failures import failure_causes
from jaxga.compare import compare_results
from jaxga.config.presets import load_preset
from jaxga.core.errors import EndpointError, JaxgaError, MapFormatError, ParameterError
from jaxga.engine.run import no_path_as_nan
from jaxga.maps import save_map
from jaxga.operators import registry
from jaxga.plot import plot_box, plot_convergence, plot_map, save_figure
from jaxga.reference import distances_from
from jaxga.replan import replan
from jaxga.smooth import smooth, smooth_population
from tests import canonical


def _one_line(e: pytest.ExceptionInfo) -> str:
    text = str(e.value)
    assert "\n" not in text and len(text) < 400, text
    return text


@pytest.fixture(scope="module")
def grid() -> jaxga.Grid:
    b = np.zeros((5, 7), bool)
    b[2, 3] = True
    return jaxga.Grid.create(b, start=(0, 0), goal=(6, 4))


@pytest.fixture(scope="module")
def result() -> jaxga.Result:
    """A canonical run of two explicit seeds (the shared 4-run sga program)."""
    return canonical.run("sga", seeds=[3, 1])


# ---------------------------------------------------------------- map files written
@pytest.mark.parametrize("name, kwargs, words", [
    ("x.pgm", {"fmt": "ros"}, "name its YAML file .yaml"),  # the YAML over its own image
    ("y.pgm", {}, "would read a .pgm file as 'png'"),  # 0/1 text under an image's name
    ("y.jpg", {}, "would read a .jpg file as 'png'"),
    ("a.map", {"fmt": "01"}, "would read a .map file as 'movingai'"),
    ("q.txt", {"fmt": "png"}, "name it .png"),  # Pillow's KeyError before
    ("r.yaml", {"resolution": -1}, "resolution must be"),
    ("r.yaml", {"resolution": float("nan")}, "resolution must be"),
    ("r.yaml", {"resolution": True}, "resolution must be"),
    ("r.yaml", {"origin": (0.0, float("inf"), 0.0)}, "origin must be finite"),
    ("r.yaml", {"origin": (1.0, 2.0)}, "origin three numbers"),
    ("m.txt", {"fmt": "svg"}, "unknown map format"),
])
def test_save_map_refuses_a_file_it_could_not_read_back(grid, tmp_path, name, kwargs, words):
    with pytest.raises(MapFormatError) as e:
        save_map(grid, tmp_path / name, **kwargs)
    assert words in _one_line(e)
    assert not list(tmp_path.iterdir())  # nothing written, nothing left behind


@pytest.mark.parametrize("values", [[[0, np.nan], [0.5, -1]], [[0, 2]], np.zeros((0, 3))])
def test_save_map_refuses_an_array_a_grid_cannot_be(tmp_path, values):
    with pytest.raises(MapFormatError) as e:
        save_map(np.asarray(values), tmp_path / "bad.txt")
    assert "cannot save" in _one_line(e) and not list(tmp_path.iterdir())


@pytest.mark.parametrize("name, kwargs", [
    ("a.txt", {}), ("a.png", {}), ("a.map", {}), ("a.asc", {}), ("noext", {}),
    ("m.yaml", {"resolution": 1e-9, "origin": (1e-7, -2.5, 0.1)}),
    ("n.yml", {"resolution": 0.05, "origin": (-10.0, 3.0, 0.0)}),
])
def test_save_map_round_trips(grid, tmp_path, name, kwargs):
    path = save_map(grid, tmp_path / name, **kwargs)
    info = jaxga.maps.load_map_info(path)
    np.testing.assert_array_equal(info.grid.blocked_np(), grid.blocked_np())
    if "resolution" in kwargs:  # the frame as given, to the last bit
        assert info.ros.resolution == kwargs["resolution"]
        assert tuple(info.ros.origin) == kwargs["origin"]
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted({name, name.rsplit(".", 1)[0] + ".pgm"} if "resolution" in kwargs
                           else [name])  # no temporary file left


def test_save_map_into_a_folder_is_one_line(grid, tmp_path):
    with pytest.raises(JaxgaError) as e:
        save_map(grid, tmp_path)
    assert "cannot write" in _one_line(e)


# ---------------------------------------------------------------------- smoothing
@pytest.mark.parametrize("cells, length, words", [
    (np.full(40, np.nan), 2, "got float32[40]"),  # NaN would become a cell
    (np.arange(8) + 0.5, 4, "got float32[8]"),
    ([(1, 2), (3, 2), (4, 3), (6, 4)], 4, "pass r.cells[i] and r.n_cells[i]"),  # r.path(i)
    (np.zeros(0, np.int32), 0, "got int32[0]"),
    (np.arange(8, dtype=np.int32), 4.0, "length must be an integer scalar"),
    (np.arange(8, dtype=np.int32), np.array([4]), "length must be an integer scalar"),
])
def test_smooth_refuses_cells_of_another_type(grid, cells, length, words):
    with pytest.raises(ParameterError) as e:
        smooth(grid, cells, length)
    assert words in _one_line(e)


def test_smooth_population_needs_one_length_per_path(grid):
    with pytest.raises(ParameterError) as e:
        smooth_population(grid, np.zeros((1, 8), np.int32), np.array([4, 4]))
    assert "one per path" in _one_line(e)


# ------------------------------------------------------------- a user's operators
def drop_last_cell(key, grid, cells, length):
    return cells[:-1], length, jnp.bool_(False)


def three_values(grid, cells, length, feasible):
    return jnp.zeros(3, jnp.float32)


def no_failed_flag(key, grid, cells, length):
    return cells, length, None


def no_value(grid, cells, length, feasible):
    return jnp.where(feasible, jnp.nan, 0.0).astype(jnp.float32)


@pytest.mark.parametrize("family, fn, words", [
    ("mutation", drop_last_cell, "must return (cells int32[64], length int32, failed"),
    ("fitness", three_values, "must return one float32 per path, got (float32[3])"),
    ("mutation", no_failed_flag, "got (int32[64], int32[], NoneType)"),
])
def test_a_user_operator_of_another_shape_is_named(family, fn, words):
    """The family's contract is checked where the operator is traced: its name and what it
    returned, not JAX's broadcasting error deep in the engine."""
    with pytest.raises(AssertionError) as e:
        testing.check_operator(family, fn)
    assert words in _one_line(e) and repr(fn.__name__) in str(e.value)


def test_check_operator_names_a_wrong_family_or_function():
    with pytest.raises(ValueError, match="unknown operator family 'mutate'"):
        testing.check_operator("mutate", drop_last_cell)
    with pytest.raises(TypeError, match="fn must be a function, got 3"):
        testing.check_operator("mutation", 3)


def test_jaxgas_own_operators_are_bound_unwrapped():
    """The contract check wraps a user's operators only: jaxga's programs are unchanged."""
    for op in registry.operators():
        if op.fn is not None and registry.is_jaxgas(op.fn) and not op.options \
                and not op.traits & {registry.NEEDS_FITNESS, registry.FIELD_REPAIR}:
            assert op.bind(registry.Binding(load_preset("sga"), {})) is op.fn


def test_an_objective_that_gives_no_path_a_positive_value_is_named():
    """Paths made, yet no run started: the user's objective is named, not the
    initialiser (which succeeded)."""
    registry.register_operator("fitness", no_value, replace=True)
    try:
        config = load_preset("sga", overrides={"fitness.method": "no_value"})
        causes = failure_causes(np.zeros(2, bool), np.zeros(2, bool), np.array([0.03, 0.0]),
                                np.array([0, 5]), config, capacity=160, shortest_cells=22)
    finally:
        registry.unregister("fitness", "no_value")
    assert all("the objective 'no_value' gave none of them a finite fitness > 0" in c
               for c in causes)
    # jaxga's own objective: the initialiser's words, as before
    causes = failure_causes(np.zeros(1, bool), np.zeros(1, bool), np.zeros(1), np.zeros(1),
                            load_preset("sga"), capacity=160, shortest_cells=22)
    assert "succeeded in none of its attempts" in causes[0]


# ------------------------------------------------------------- results and their use
def test_a_seed_position_is_checked(result):
    assert result.path(-1) == result.path(1) and result.path(np.int64(0)) == result.path(0)
    # an argmin's 0-d array, NumPy's or JAX's, is a position too
    assert result.path(np.array(1)) == result.path(jnp.int32(1)) == result.path(1)
    for bad in (2, -3, True, 1.0, "0"):
        for method in (result.path, result.world_path, result.obstacle_clearance):
            with pytest.raises(ParameterError) as e:
                method(bad)
            assert "from -2 to 1 (its place in r.seeds = [3, 1], not the seed itself)" \
                in _one_line(e)


def test_one_seed_has_no_sd(result):
    one = dataclasses.replace(result, success=np.array([True, False]))
    rows = {row[0]: row for row in one.summary_rows()}
    assert math.isnan(rows["length"][2]) and rows["length"][1] == result.length[0]
    line = next(t for t in one.summary(time=False).splitlines() if t.startswith("length "))
    assert line.split()[2] == "-"


def test_compare_results_refuses_grids_with_other_endpoints_or_cells(result):
    """Every bare Grid is named "grid": its endpoints, and its cells' digest where the
    size, endpoints and optimum are the same, tell two such maps apart."""
    a = dataclasses.replace(result, map_name="grid")
    b = dataclasses.replace(a, start=result.goal, goal=result.start)
    compare_results({"a": a, "b": dataclasses.replace(a)})  # the same map: compared
    with pytest.raises(ParameterError) as e:
        compare_results({"a": a, "b": b})
    assert "different maps, endpoints or corner rules" in _one_line(e)
    other_cells = dataclasses.replace(a, map_digest="0" * 24)
    with pytest.raises(ParameterError) as e:
        compare_results({"a": a, "b": other_cells})
    assert f"cells {a.map_digest})" in _one_line(e) and f"cells {'0' * 24})" in _one_line(e)


def test_a_maps_cells_digest_says_which_cells_are_blocked():
    """The same cells give the same digest whatever the endpoints or corner rule; one
    cell more, or the same cells in another shape, another digest."""
    b = np.zeros((4, 6), bool)
    b[1, 2] = True
    g = jaxga.Grid.create(b, corner_rule="free")
    assert len(g.cells_digest()) == 24
    assert jaxga.Grid.create(b, start=(5, 0), goal=(0, 3), corner_rule="strict"
                             ).cells_digest() == g.cells_digest()
    c = b.copy()
    c[3, 5] = True
    assert jaxga.Grid.create(c, start=(0, 0), goal=(4, 3)).cells_digest() != g.cells_digest()
    assert jaxga.Grid.create(b.reshape(6, 4)).cells_digest() != g.cells_digest()


def test_a_run_without_a_path_in_the_pure_core_has_no_length():
    """The pure core's outputs of a run that found no path: NaN lengths and metrics as in
    a Result (a 0 would be averaged as a path), -1 counts, the paths' values kept. A run
    whose post-optimised path failed the final feasibility check (run 2, as a user's own
    post step may make) has no path either, as ``jaxga.run`` counts it: not a success,
    fitness 0, convergence generation -1."""
    out = jaxga.engine.RunOutputs(
        success=jnp.array([True, False, True]), raw_cells=jnp.zeros((3, 4), jnp.int32),
        raw_n_cells=jnp.array([3, 1, 3]), cells=jnp.zeros((3, 4), jnp.int32),
        n_cells=jnp.array([3, 1, 3]), fitness=jnp.array([0.5, 0.0, 0.25]),
        raw_length=jnp.array([2.5, 0.0, 3.0]), length=jnp.array([2.0, 0.0, 1.5]),
        raw_metrics={"turns": jnp.array([1, 0, 2]), "angle_sum": jnp.array([0.7, 0.0, 1.0])},
        metrics={"turns": jnp.array([1, 0, 2]), "angle_sum": jnp.array([0.7, 0.0, 1.0])},
        generations_run=jnp.array([5, 5, 5]), failures=jnp.zeros((3, 3), jnp.int32),
        feasible_post=jnp.array([True, False, False]),
        convergence_generation=jnp.array([3, -1, 4], jnp.int32))
    nan = no_path_as_nan(out)
    np.testing.assert_array_equal(nan.success, [True, False, False])
    np.testing.assert_array_equal(nan.length, [2.0, np.nan, np.nan])
    np.testing.assert_array_equal(nan.raw_length, [2.5, np.nan, np.nan])
    np.testing.assert_array_equal(nan.metrics["turns"], [1, -1, -1])
    np.testing.assert_array_equal(nan.raw_metrics["angle_sum"],
                                  np.array([0.7, np.nan, np.nan], np.float32))
    np.testing.assert_array_equal(nan.fitness, np.array([0.5, 0.0, 0.0], np.float32))
    np.testing.assert_array_equal(nan.convergence_generation, [3, -1, -1])
    assert nan.metrics["turns"].dtype == jnp.int32 and nan.fitness.dtype == out.fitness.dtype
    assert nan.convergence_generation.dtype == jnp.int32
    np.testing.assert_array_equal(nan.cells, out.cells)  # the paths' values kept
    no_history = no_path_as_nan(dataclasses.replace(out, convergence_generation=None))
    assert no_history.convergence_generation is None


@pytest.mark.slow  # the pure core's own program
def test_the_pure_core_gives_a_run_without_a_path_no_length():
    from jaxga.core import prng

    b = np.zeros((20, 20), bool)
    b[:, 10] = True  # a wall across the map: no path
    ga = jaxga.GA("sga", jaxga.Grid.create(b, corner_rule="free"), generations=2)
    out = jax.jit(ga.run)(prng.seed_key(0), ga.default_params)
    assert not bool(out["success"]) and float(out["fitness"]) == 0.0
    assert np.isnan(out["length"]) and np.isnan(out["raw_length"])
    assert np.isnan(out["metrics"]["angle_sum"]) and int(out["metrics"]["turns"]) == -1


def test_a_run_that_cannot_start_says_nothing_was_run():
    b = np.zeros((12, 12), bool)
    b[:, 6] = True
    r = jaxga.run("sga", jaxga.Grid.create(b, start=(1, 1), goal=(10, 10)), seeds=2)
    assert not r.success.any()
    assert "initial population: not made (random_walk was not run: no path exists)" \
        in r.summary()


# --------------------------------------------------------------------------- plots
def test_plots_refuse_what_they_cannot_draw(result, tmp_path):
    import matplotlib.pyplot as plt

    for histories in ({"best": np.zeros(5)}, {"best": np.zeros((0, 5))}, {}):
        with pytest.raises(ParameterError) as e:
            plot_convergence(histories)
        assert "histories must be a mapping" in _one_line(e)
    with pytest.raises(ParameterError, match="data must be a Comparison, a Result"):
        plot_box(3)
    with pytest.raises(ParameterError) as e:
        plot_map(jaxga.Grid.create(np.zeros((4, 4), bool)), [[(0, 0), (1, 1)]])
    assert "(path, label) pairs" in _one_line(e)
    fig, _ = plt.subplots()
    with pytest.raises(ParameterError) as e:
        save_figure(fig, tmp_path / "x.xyz")
    assert "the format follows the extension" in _one_line(e)
    assert not list(tmp_path.iterdir())
    ax = plot_box(result)  # one Result: one box of its lengths
    assert [t.get_text() for t in ax.get_xticklabels()] == ["sga"]
    plt.close("all")


# ------------------------------------------------------ options, planner, references
def test_problem_refuses_an_unknown_map_option():
    with pytest.raises(ParameterError) as e:
        jaxga.problem("sga", canonical.MAP, map_options={"foo": 1})
    assert "unknown map option(s) 'foo'" in _one_line(e)


def test_a_planner_takes_a_grid_and_checks_its_seeds_when_made(grid):
    planner = jaxga.Planner(grid, "sga", seeds=2)
    assert planner.map.name == "grid" and planner.map.frame is None
    np.testing.assert_array_equal(planner.map.grid.blocked_np(), grid.blocked_np())
    assert jaxga.Planner(grid, "sga", seeds=iter([5, 7])).seeds == [5, 7]  # read once
    with pytest.raises(JaxgaError, match="seeds must be >= 1"):
        jaxga.Planner(grid, "sga", seeds=0)
    with pytest.raises(ParameterError) as e:
        jaxga.Planner(grid, "sga", inflate=1)
    assert "given with a Grid" in _one_line(e)


@pytest.mark.slow  # a program of its own: the planner sizes it for the map
def test_a_planner_on_a_grid_plans(grid):
    r = jaxga.Planner(grid, "sga", seeds=2, generations=5).plan((0, 0), (6, 0))
    assert r.success.all() and r.map_name == "grid"
    assert r.start == (0, 0) and r.goal == (6, 0)


@pytest.mark.parametrize("cell", [(1.5, 0), (1, 2, 3), (True, 0), "12", {1, 2}])
def test_reference_cells_are_integer_pairs(grid, cell):
    with pytest.raises(EndpointError) as e:
        distances_from(grid, cell)
    assert "a cell must be a pair of integers" in _one_line(e)


def test_a_replan_mask_of_integers_is_named(grid):
    mask = np.zeros(grid.blocked_np().shape, np.uint8)
    path = [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4), (5, 4), (6, 4)]
    with pytest.raises(ParameterError) as e:
        replan(grid, path, mask, (0, 0))
    assert "a mask must be bool" in _one_line(e)

