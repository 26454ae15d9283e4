"""Round twelve of hostile inputs (decision 060): the public Python API given what a user
plausibly passes, and a researcher's operators of their own through the registry and
the pure core. Nothing here compiles a whole GA."""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxga
import jaxga.testing
from jaxga import export
from jaxga._runtime.seeds import seed_list
from jaxga.api.problem import own_operators
from jaxga.api.result_fronts import front_point_which, least_clearance
from jaxga.compare import Comparison
from jaxga.core.errors import EndpointError, JaxgaError, MapFormatError, ParameterError
from jaxga.core.fields import Field
from jaxga.core.grid import Grid, index_to_xy
from jaxga.core.objectives import ordered_sum
from jaxga.maps import builtin_path, load_map, map_name, parse_scen, read_scen, save_map
from jaxga.maps.preprocess import check_coarse_endpoints, coarsen_blocked
from jaxga.operators import registry
from tests.config.test_own_operators import drop_point

MAP = "classic_ga_gapp3_20x20"


def _one_line(e: pytest.ExceptionInfo) -> str:
    text = str(e.value)
    assert "\n" not in text, text
    return text


# ------------------------------------------------------------------ maps and endpoints
@pytest.mark.parametrize("factor", [21, 10**8, 2**63])
def test_a_coarsening_past_the_map_is_one_line_at_once(factor):
    """A factor larger than the map's longer side (2**63 hung: the smaller factor was
    searched one by one; with endpoints given, the padding asked for a 2**63-cell side)."""
    for endpoints in ({}, {"start": (0, 0), "goal": (0, 0)}):
        t0 = time.perf_counter()
        with pytest.raises(MapFormatError) as e:
            load_map(MAP, coarsen=factor, **endpoints)
        assert time.perf_counter() - t0 < 5
        assert f"coarsen {factor} is more than the map's longer side (20 x 20" \
            in _one_line(e)


def test_a_coarsening_past_the_map_merges_it_into_one_cell():
    """The pure function takes any factor: past the longer side it is that side's."""
    b = np.zeros((3, 5), bool)
    b[2, 4] = True
    for k in (5, 6, 2**63):
        assert coarsen_blocked(b, k).tolist() == [[True]]
    assert coarsen_blocked(~b, 2**63).tolist() == [[True]]


def test_endpoints_in_one_coarse_cell_name_the_largest_factor_apart_at_once():
    t0 = time.perf_counter()
    with pytest.raises(EndpointError, match=r"a factor of 2 keeps them apart"):
        check_coarse_endpoints((1, 0), (2, 1), 2**63)
    with pytest.raises(EndpointError, match=r"a factor of 19 keeps them apart"):
        check_coarse_endpoints((0, 0), (19, 19), 10**12)
    assert time.perf_counter() - t0 < 1


@pytest.mark.parametrize("option", [{"coarsen": 2}, {"inflate": 1}])
@pytest.mark.parametrize("start", [(3.5, 2), "ab", (3,), (3, 1, 1), (True, 2)])
def test_an_endpoint_that_is_not_two_integers_is_one_line_when_preprocessed(option, start):
    """Inflation and coarsening indexed the map with the endpoint as given (IndexError,
    TypeError, an unpacking ValueError); now the endpoint is checked first."""
    with pytest.raises(EndpointError) as e:
        load_map(MAP, start=start, goal=(19, 19), **option)
    assert "start must be a pair of integers (x, y)" in _one_line(e)


@pytest.fixture(scope="module")
def ros_map(tmp_path_factory):
    """A ROS map_server copy of the built-in map, 0.05 m a cell."""
    path = tmp_path_factory.mktemp("ros") / "m.yaml"
    save_map(load_map(MAP), path, resolution=0.05)
    return path


@pytest.mark.parametrize("point", ["12", {"x": 0, "y": 0}, (True, 0.0), (0.1, 0.1, 0.0),
                                   (float("nan"), 0.1)])
def test_an_endpoint_in_metres_is_checked_as_the_planner_checks_it(ros_map, point):
    """``load_map(start_world=...)`` read a bool as 1 m and dropped a third value; a
    string or a dict was a TypeError or KeyError from the frame."""
    with pytest.raises(EndpointError) as e:
        load_map(ros_map, start_world=point, goal=(19, 19))
    assert "the start in metres must be" in _one_line(e)
    assert load_map(ros_map, start_world=(0.125, 0.075)).start_xy == (2, 1)


# ---------------------------------------------------------------------- files written
@pytest.mark.parametrize("points, words", [
    (np.array([[0, 1, 2, 3], [0, 0, 1, 1]]), "shape (2, 4)"),
    (np.zeros(4), "shape (4,)"),
    (np.zeros((3, 3)), "shape (3, 3)"),
    (None, "the points are None"),
    ([[1, "x"]], "must be numbers"),
])
@pytest.mark.parametrize("suffix", [".csv", ".yaml"])
def test_a_path_not_shaped_k_by_2_is_refused_not_reshaped(tmp_path, points, words, suffix):
    """A ``[2, k]`` array was written as other points (rows read pairwise), with no error."""
    out = tmp_path / f"p{suffix}"
    with pytest.raises(JaxgaError) as e:
        export.write_path(out, points)
    assert words in _one_line(e)
    assert not list(tmp_path.iterdir())


def test_a_path_of_rows_and_an_empty_path_are_written(tmp_path):
    export.write_path(tmp_path / "p.csv", [[0.0, 0.0], [1.0, 2.0]])
    np.testing.assert_array_equal(export.read_path(tmp_path / "p.csv"), [[0, 0], [1, 2]])
    assert export.path_text([], "csv") == "x,y\n"
    assert export.path_text(np.zeros((0, 2)), "csv") == "x,y\n"


def test_a_ros_map_whose_yaml_cannot_be_written_leaves_no_image(tmp_path):
    """The image was written before the YAML was found to be a folder, and stayed."""
    (tmp_path / "m.yaml").mkdir()
    with pytest.raises(JaxgaError) as e:
        save_map(load_map(MAP), tmp_path / "m.yaml")
    assert "it is a folder" in _one_line(e)
    assert [p.name for p in tmp_path.iterdir()] == ["m.yaml"]


@pytest.mark.parametrize("frame", [{"origin": "123"}, {"resolution": np.True_},
                                   {"resolution": True}, {"origin": (0, 0, np.bool_(True))},
                                   {"resolution": "0.05"}])
def test_a_ros_frame_of_strings_or_bools_is_refused(tmp_path, frame):
    """``origin="123"`` was saved as (1, 2, 3); numpy's True as a resolution of 1 m."""
    with pytest.raises(MapFormatError) as e:
        save_map(load_map(MAP), tmp_path / "m.yaml", **frame)
    assert "resolution must be a number and origin three numbers" in _one_line(e)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("call", [
    lambda: save_map(np.zeros((2, 2), bool), b"x.txt"),
    lambda: export.write_path(b"p.csv", np.zeros((2, 2))),
    lambda: export.read_path(b"p.csv"),
    lambda: read_scen(b"x.scen"),
    lambda: map_name(b"x.map"),
    lambda: read_scen(None),
])
def test_a_file_name_that_is_not_text_is_one_line(tmp_path, monkeypatch, call):
    """bytes (and None) were pathlib's TypeError; load_map already refused them."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(JaxgaError) as e:
        call()
    assert "must be a str or a pathlib.Path" in _one_line(e)
    assert not list(tmp_path.iterdir())


def test_no_writer_replaces_a_file_of_jaxgas_own():
    """``save_map(load_map(name), builtin_path(name))`` rewrote the installed built-in
    map (the command line already refused outputs inside jaxga's folder)."""
    path = builtin_path(MAP)
    before = (path.read_bytes(), path.stat().st_mtime_ns)
    for write in (lambda: save_map(load_map(MAP), path),
                  lambda: export.write_path(path.with_suffix(".csv"), [[0.0, 0.0]])):
        with pytest.raises(JaxgaError) as e:
            write()
        assert "inside jaxga's own folder" in _one_line(e)
    assert (path.read_bytes(), path.stat().st_mtime_ns) == before
    assert not path.with_suffix(".csv").exists()


def test_a_file_name_that_is_not_text_raises_the_documented_error(tmp_path):
    with pytest.raises(MapFormatError):
        save_map(np.zeros((2, 2), bool), b"x.txt")
    with pytest.raises(MapFormatError):
        read_scen(b"x.scen")
    with pytest.raises(ParameterError):
        export.read_path(None)


def test_a_folder_out_of_reach_is_said_so(tmp_path):
    """A folder whose name is too long: Path.is_dir raised OSError on Python 3.11."""
    from jaxga.core.files import check_outputs, folder_problem

    long = tmp_path / ("a" * 300)
    assert "cannot be used (File name too long)" in folder_problem(long)
    assert "does not exist" in folder_problem(tmp_path / "missing")
    with pytest.raises(JaxgaError, match="File name too long"):
        check_outputs({"--json": long / "x.json"})


def test_a_scenario_given_as_bytes_is_one_line():
    with pytest.raises(MapFormatError, match="must be a str"):
        parse_scen(b"version 1\n")


# ------------------------------------------------------------------ calls and results
def test_a_seed_list_holding_a_bool_is_refused():
    """``seeds=[2, True]`` ran seed 1 for the bool; a bool count is refused already."""
    with pytest.raises(JaxgaError, match=r"got \[2, True\]"):
        seed_list([2, True])
    with pytest.raises(JaxgaError):
        seed_list([np.bool_(False), 3])
    assert seed_list([2, 1]).tolist() == [2, 1]


def test_a_planners_any_angle_budget_is_checked_when_it_is_made():
    with pytest.raises(ParameterError) as e:
        jaxga.Planner(MAP, "sga", any_angle_budget="x")
    assert "any_angle_budget must be 'auto'" in _one_line(e)


def _comparison() -> Comparison:
    return Comparison(results={}, metric="length", metrics=("length", "turns"),
                      test="mannwhitneyu", alpha=0.05, pairwise=[], success_tests=[])


def test_a_comparison_refuses_a_metric_it_did_not_test_and_an_unknown_label():
    """``tests("nope")`` was an empty list (read as "no pair differs"); ``values`` of an
    unknown label a KeyError."""
    c = _comparison()
    assert c.tests("turns") == [] and c.tests() == []
    with pytest.raises(ParameterError) as e:
        c.tests("nope")
    assert "tested length, turns, not 'nope'" in _one_line(e)
    with pytest.raises(ParameterError, match="tested length, turns, not 'gap'"):
        c.tests("gap")
    with pytest.raises(ParameterError) as e:
        c.values("nope")
    assert "no preset labelled 'nope'" in _one_line(e)


@pytest.mark.parametrize("which", ["nope", None, float("nan"), True, "1.5", -1.0,
                                   float("inf"), [1.0]])
def test_a_front_point_that_is_no_point_is_refused(which):
    """A NaN, True or "1.5" returned None ("no point keeps it"); "nope" or None raised
    float()'s error."""
    with pytest.raises(ParameterError) as e:
        front_point_which(which)
    assert "must be 'knee', 'shortest', 'widest' or a least clearance" in _one_line(e)


@pytest.mark.parametrize("which, value", [("knee", "knee"), ("widest", "widest"),
                                          (0, 0.0), (np.float32(1.5), 1.5),
                                          (np.array(1.5), 1.5), (jnp.float32(2.0), 2.0)])
def test_a_front_point_is_a_name_or_a_clearance(which, value):
    """A 0-d NumPy or JAX array is the number it holds, as everywhere in the API."""
    assert front_point_which(which) == value


def test_a_least_clearance_is_a_number():
    assert least_clearance(np.array(0.5)) == 0.5
    with pytest.raises(ParameterError) as e:
        least_clearance("1.5")
    assert _one_line(e) == "min_clearance must be a number >= 0, got '1.5'"


@pytest.fixture(scope="module")
def ga():
    return jaxga.GA("sga", MAP, generations=2)


@pytest.mark.parametrize("params, words", [
    (None, "params must be the dict of the GA's parameters"),
    ([1, 2], "params must be the dict of the GA's parameters"),
    ({}, "missing"),
    ("missing one", "crossover.probability missing"),
    ("misspelt", "crossover.probabilty not read by this GA"),
])
def test_the_pure_core_refuses_params_that_are_not_the_gas(ga, params, words):
    """``GA.run(key, {})`` was a KeyError deep in the initialisers; a misspelt key set by
    hand was ignored (the run used the default)."""
    p = dict(ga.default_params)
    if params == "missing one":
        params = {k: v for k, v in p.items() if k != "crossover.probability"}
    elif params == "misspelt":
        params = {**p, "crossover.probabilty": 0.9}
    key = jax.random.PRNGKey(0)
    for call in (lambda: ga.run(key, params), lambda: ga.init(key, params)):
        with pytest.raises(ParameterError) as e:
            call()
        assert words in _one_line(e)


# ---------------------------------------------------------- a researcher's operators
def straight_summed(grid, cells, length, feasible):
    """1 / (1 + length), the length added by ``jnp.sum``."""
    step = jnp.diff(index_to_xy(cells, grid.width), axis=0).astype(jnp.float32)
    f = 1.0 / (1.0 + jnp.sum(jnp.hypot(step[:, 0], step[:, 1])))
    return jnp.where(feasible, f, 0.0).astype(jnp.float32)


def straight_ordered(grid, cells, length, feasible):
    """1 / (1 + length), the length added by ``ordered_sum``."""
    step = jnp.diff(index_to_xy(cells, grid.width), axis=0).astype(jnp.float32)
    f = 1.0 / (1.0 + ordered_sum(jnp.hypot(step[:, 0], step[:, 1])))
    return jnp.where(feasible, f, 0.0).astype(jnp.float32)


@pytest.fixture
def registered():
    """Names registered by a test, unregistered after it."""
    names: list[tuple[str, str]] = []
    yield names
    for family, name in names:
        if registry.canonical(family, name) is not None:
            registry.unregister(family, name)


@pytest.mark.parametrize("fn, declaration, words", [
    (drop_point, {"params": {"mutation.x": 1}}, "to a jaxga.core.fields.Field"),
    (3, {}, "a mutation operator is a function, got 3"),
    (lambda key, grid: (grid, key), {}, "must take (key, grid, cells, length)"),
    (lambda key, grid, cells, length, extra: cells, {}, "missing a required argument"),
])
def test_an_operator_that_cannot_run_is_refused_when_registered(registered, fn,
                                                                declaration, words):
    """A non-Field parameter broke every later run of the process (the schema read it);
    a number or a function of the wrong arguments failed only when traced, deep."""
    registered.append(("mutation", "bad_one"))
    with pytest.raises(ValueError) as e:
        jaxga.register_operator("mutation", fn, name="bad_one", **declaration)
    assert words in _one_line(e)
    assert registry.canonical("mutation", "bad_one") is None
    jaxga.GA("sga", MAP)  # the registry is whole


def test_keywords_an_operator_is_bound_with_are_not_counted_as_missing(registered):
    registered.append(("mutation", "drop_some"))

    def drop_some(key, grid, cells, length, count):
        return drop_point(key, grid, cells, length)

    op = jaxga.register_operator(
        "mutation", drop_some, options=lambda ctx: {"count": 1},
        params={"mutation.drop_count": Field(int, "nodes dropped", low=1, default=1)})
    assert op.name == "drop_some"


def test_one_trait_given_as_a_string_is_that_trait(registered):
    registered.append(("mutation", "drop_point"))
    op = jaxga.register_operator("mutation", drop_point, traits="shrinking")
    assert op.traits == frozenset({"shrinking"})


def test_two_operators_for_one_family_are_refused(registered):
    """``objective=f, fitness__method="sga"``: the later argument won, silently."""
    registered.append(("fitness", "straight_ordered"))
    with pytest.raises(ParameterError) as e:
        own_operators({"objective": straight_ordered, "fitness__method": "sga"})
    assert "two fitness operators given: objective=straight_ordered and " \
        "fitness__method='sga'" in _one_line(e)
    with pytest.raises(ParameterError, match="two fitness operators"):
        own_operators({"objective": straight_ordered, "fitness": straight_ordered})
    assert own_operators({"objective": straight_ordered, "mutation__method": "none"}) == {
        "fitness__method": "straight_ordered", "mutation__method": "none"}


def test_cells_of_another_integer_type_are_refused_when_traced(registered):
    """uint8 cells passed the check of the dtype's kind and wrapped the map's indices:
    the population silently became infeasible."""
    registered.append(("mutation", "as_u8"))

    def as_u8(key, grid, cells, length):
        return cells.astype(jnp.uint8), length, jnp.bool_(False)

    op = jaxga.register_operator("mutation", as_u8)
    grid, pop = jaxga.testing.default_setting()
    fn, _, _ = jaxga.testing.bound(op, grid, pop.cells.shape[1])
    with pytest.raises(registry.ContractError) as e:
        jax.eval_shape(fn, jax.random.PRNGKey(0), grid, pop.cells[0], pop.length[0])
    assert "got (uint8[64], int32[], bool[])" in _one_line(e)


def test_check_operator_on_a_map_of_ones_own_makes_parents_there():
    """Given a grid and no parents, the default map's parents were used on it and a
    correct operator was blamed for paths that do not go from start to goal."""
    grid = Grid.create(np.zeros((5, 5), bool), corner_rule="strict")
    jaxga.testing.check_operator("mutation", drop_point, grid=grid)


def test_check_operator_on_a_larger_map_of_ones_own_sizes_its_parents():
    """The parents made on a grid given took the default map's 64 cells, too few for a
    path across a 40 x 40 map: "could not build valid parents" for any operator."""
    grid = Grid.create(np.zeros((40, 40), bool), corner_rule="strict")
    jaxga.testing.check_operator("mutation", drop_point, grid=grid)
    walled = np.zeros((5, 5), bool)
    walled[:, 2] = True
    with pytest.raises(ValueError, match="no parents could be made on this grid"):
        jaxga.testing.check_operator("mutation", drop_point, grid=Grid.create(walled))


def test_check_operator_refuses_a_declaration_the_registered_operator_lacks(registered):
    registered.append(("mutation", "drop_point"))
    jaxga.register_operator("mutation", drop_point)
    with pytest.raises(ValueError, match="is registered with another traits"):
        jaxga.testing.check_operator("mutation", drop_point, traits={"shrinking"})


def test_an_objective_summed_by_jnp_sum_fails_the_contract():
    """``jnp.sum`` rounds a path's length by the batch's shape (the docs' example did: a
    run's fitness differed by one ulp alone and in a vmap of 60)."""
    with pytest.raises(AssertionError) as e:
        jaxga.testing.check_operator("fitness", straight_summed)
    assert "adds floats with reduce_sum" in str(e.value) and "ordered_sum" in str(e.value)
    jaxga.testing.check_operator("fitness", straight_ordered)


def test_float_reductions_are_found_in_loops_and_branches_not_in_integer_sums():
    x = jnp.arange(8.0)
    assert jaxga.testing.float_reductions(jnp.sum, x) == ["reduce_sum"]
    assert jaxga.testing.float_reductions(ordered_sum, x) == []
    assert jaxga.testing.float_reductions(lambda v: jnp.sum(v > 2), x) == []
    assert jaxga.testing.float_reductions(lambda v: jnp.dot(v, v), x) == ["dot_general"]
    assert jaxga.testing.float_reductions(
        lambda v: jax.lax.cond(v[0] > 0, jnp.sum, lambda u: u[0], v), x) == ["reduce_sum"]
    assert jaxga.testing.float_reductions(
        lambda v: jax.lax.fori_loop(0, 3, lambda i, c: c + jnp.cumsum(v)[i], 0.0),
        x) == ["cumsum"]
    assert jaxga.testing.float_reductions(
        lambda v: jnp.zeros(2).at[jnp.array([0, 1, 1, 0, 1, 0, 0, 1])].add(v), x) == [
        "scatter-add"]
    assert jaxga.testing.float_reductions(  # rounding each value alone is no reduction
        lambda v: jax.lax.reduce_precision(v, exponent_bits=5, mantissa_bits=10), x) == []


def test_the_papers_objectives_add_in_a_fixed_order():
    """The contract's check holds for every registered objective (IMGA's safety summed
    its 0/1 terms as floats; now counted as integers, the same bits)."""
    grid, pop = jaxga.testing.default_setting()
    for op in registry.operators("fitness"):
        fn, _, _ = jaxga.testing.bound(op, grid, pop.cells.shape[1])
        assert jaxga.testing.float_reductions(
            lambda c, n, fn=fn: fn(grid, c, n, jnp.bool_(True)), pop.cells[0],
            pop.length[0]) == [], op.name
