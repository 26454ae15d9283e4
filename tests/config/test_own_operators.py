"""Bring your own pieces: a mutation and an objective written here, outside ``jaxga/``,
pass the public contract check (:func:`jaxga.testing.check_operator`) and run in a preset,
passed as functions to :class:`jaxga.GA` and :func:`jaxga.run`; a broken one is caught."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxga
import jaxga.testing
from jaxga.core.grid import index_to_xy, move_legal
from jaxga.core.objectives import ordered_sum, path_length
from jaxga.core.paths import is_continuous
from jaxga.operators import registry
from jaxga.operators.postprocess import compact

pytestmark = pytest.mark.slow  # a user's operators through whole GAs (programs of their own)

MAP = "classic_ga_gapp3_20x20"


def drop_point(key, grid, cells, length):
    """Delete one random interior node whose neighbours are one legal move apart."""
    i = jnp.arange(cells.shape[0])
    prev, nxt = jnp.roll(cells, 1), jnp.roll(cells, -1)
    can = (i > 0) & (i < length - 1) & move_legal(grid, prev, nxt)
    pick = jax.random.categorical(key, jnp.where(can, 0.0, -jnp.inf))
    new, new_length = compact(cells, (i < length) & (i != pick))
    ok = jnp.any(can)
    return jnp.where(ok, new, cells), jnp.where(ok, new_length, length), ~ok


def short_and_straight(grid, cells, length, feasible):
    """1 / (1 + length + direction changes): short paths with few turns."""
    step = jnp.diff(index_to_xy(cells, grid.width), axis=0)
    inside = jnp.arange(1, cells.shape[0] - 1) < length - 1
    turns = jnp.sum(inside & jnp.any(step[1:] != step[:-1], axis=1))
    f = 1.0 / (1.0 + ordered_sum(jnp.hypot(*step.T.astype(jnp.float32))) + turns)
    return jnp.where(feasible, f, 0.0).astype(jnp.float32)


def teleport(key, grid, cells, length):
    """A broken mutation: node 1 jumps to the last cell of the map."""
    return cells.at[1].set(grid.n_cells - 1), length, jnp.bool_(False)


@jax.jit
def _path_facts(grid, cells, length):
    """Per path of ``cells[N, L]``: whether it is continuous, :func:`short_and_straight`
    of it as a feasible path, and its Euclidean length (one program for all runs)."""
    def one(c, n):
        return (is_continuous(grid, c, n), short_and_straight(grid, c, n, jnp.bool_(True)),
                path_length(grid, c, n))
    return jax.vmap(one)(cells, length)


@pytest.fixture(scope="module", autouse=True)
def _unregistered_afterwards():
    yield
    for family, fn in (("mutation", drop_point), ("fitness", short_and_straight)):
        for op in registry.operators(family):
            if op.fn is fn:
                registry.unregister(family, op.name)


def test_own_operators_pass_the_public_contract_check():
    jaxga.testing.check_operator("mutation", drop_point, traits={registry.SHRINKING})
    jaxga.testing.check_operator("fitness", short_and_straight)
    with pytest.raises(AssertionError, match="not continuous"):
        jaxga.testing.check_operator("mutation", teleport)
    assert registry.canonical("mutation", "teleport") is None  # the check leaves no trace


def test_own_operators_run_in_a_preset_through_the_pure_core_and_jaxga_run():
    """sga with the mutation and the objective passed as functions: ``GA.run`` under
    ``vmap`` over keys equals ``jaxga.run`` seed for seed; every path is continuous; the
    reported fitness is the objective's; the mutation never lengthened a raw path more
    than the crossover could (checked through the objective: finite, positive)."""
    ga = jaxga.GA("sga", MAP, generations=10, mutation=drop_point,
                  objective=short_and_straight, mutation__probability=0.5)
    assert ga.config["mutation.method"] == "drop_point"
    assert ga.config["fitness.method"] == "short_and_straight"
    runs = jax.vmap(lambda s, p: ga.run(jax.random.PRNGKey(s), p), (0, None))
    out = jax.jit(runs)(np.arange(3, dtype=np.uint32), ga.default_params)  # keys inside
    ref = jaxga.run("sga", MAP, seeds=3, generations=10, mutation=drop_point,
                    objective=short_and_straight, mutation__probability=0.5)
    np.testing.assert_array_equal(np.asarray(out["fitness"]), ref.fitness)
    assert ref.success.all()
    continuous, expected, length = (np.asarray(x) for x in _path_facts(
        ga.grid, np.asarray(ref.raw_cells), np.asarray(ref.raw_n_cells, np.int32)))
    for i in range(3):
        assert bool(continuous[i])
        assert float(ref.fitness[i]) == pytest.approx(float(expected[i]), rel=1e-6)
        assert 1.0 / float(ref.fitness[i]) - 1.0 >= float(length[i]) - 1e-3


def test_a_function_registered_again_under_its_name_is_traced_again():
    """A notebook cell run twice: the second function replaces the first, and a run uses
    the new one, not a program compiled for the old. The first is the previous test's
    configuration (its programs), the cell edited so that the mutation always fails; the
    same seeds and parameters, so a run of the old program would equal the first."""

    def edited_cell():
        def drop_point(key, grid, cells, length):  # the cell run again, edited
            return cells, length, jnp.bool_(True)  # always fails: the parent is kept
        return drop_point

    run = dict(seeds=2, generations=3, objective=short_and_straight,
               mutation__probability=1.0)
    first = jaxga.run("sga", MAP, mutation=drop_point, **run)
    second = jaxga.run("sga", MAP, mutation=edited_cell(), **run)
    try:
        assert registry.operator("mutation", "drop_point").fn is not drop_point
        assert second.failures[:, 1].sum() > 0
        assert second.failures[:, 1].sum() > first.failures[:, 1].sum()
    finally:
        registry.unregister("mutation", "drop_point")


def test_jaxgas_own_operators_are_never_replaced():
    def replace_point(key, grid, cells, length):
        return cells, length, jnp.bool_(True)

    with pytest.raises(ValueError, match="jaxga's own"):
        jaxga.GA("sga", MAP, mutation=replace_point)


def test_an_operator_declared_in_a_module_of_its_own_runs_in_a_preset_file(tmp_path):
    """A new operator is one module (its function and its declaration, as jaxga's own
    families have theirs) and a preset file that names it with its own key: importing the
    module registers it; the preset's key is checked against its declared range; the
    engine binds it; a run's paths are valid."""
    import importlib

    from jaxga.core.errors import ParameterError
    from jaxga.engine import chosen_operators

    module = importlib.import_module("tests.config.own_operator_module")
    try:
        jaxga.testing.check_operator(registry.operator("mutation", "drop_points"))
        preset = tmp_path / "dropping.toml"
        preset.write_text('base = "sga"\n[mutation]\nmethod = "drop_points"\n'
                          "probability = 0.5\ndrops = 2\n")
        ga = jaxga.GA(str(preset), MAP, generations=5)
        assert ga.config["mutation.drops"] == 2
        assert chosen_operators(ga.config)["mutation.method"].fn is module.drop_points
        r = jaxga.run(str(preset), MAP, seeds=3, generations=5)
        assert r.success.all() and r.config["mutation.method"] == "drop_points"
        continuous, _, _ = (np.asarray(x) for x in _path_facts(
            ga.grid, np.asarray(r.raw_cells), np.asarray(r.raw_n_cells, np.int32)))
        assert continuous.all()
        preset.write_text(preset.read_text().replace("drops = 2", "drops = 0"))
        with pytest.raises(ParameterError, match="mutation.drops"):
            jaxga.run(str(preset), MAP, seeds=1, generations=5)
    finally:
        registry.unregister("mutation", "drop_points")

