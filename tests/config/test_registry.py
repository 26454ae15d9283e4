"""The operator registry: every registered operator keeps its family's contract
(``tests/testing.py``), a broken one is caught, and the configuration accepts exactly
the registered names (former names included)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga import testing
from jaxga.config.presets import load_preset, preset_names
from jaxga.config.schema import COMMON_FIELDS, SCHEMA
from jaxga.core.errors import ParameterError
from jaxga.core.paths import Population
from jaxga.maps import load_map
from jaxga.operators import registry
from jaxga.operators.postprocess import compact

OPERATORS = registry.operators()


@pytest.fixture(scope="module")
def setting():
    """The contract check's own map and parents (:func:`jaxga.testing.default_setting`),
    the parents as host arrays: the check's slices and rows of them (pairs, one
    individual alone) are then NumPy's, not one compiled program each."""
    grid, pop = testing.default_setting()
    return grid, Population(np.asarray(pop.cells), np.asarray(pop.length))


@pytest.mark.parametrize("op", OPERATORS, ids=[f"{op.family}-{op.name}" for op in OPERATORS])
def test_every_registered_operator_keeps_its_family_contract(setting, op):
    """With ``repair.fallback = "none"``; the field repairs have their own property tests
    (``tests/operators/test_field.py``)."""
    grid, pop = setting
    testing.check_family(op, grid, pop, jax.random.PRNGKey(7))


# ------------------------------------------------------- a broken operator is caught
def _teleport(key, grid, cells, length):
    """Moves node 1 to the last cell of the map (the goal's cell on these maps is never
    next to the start's neighbour): a jump, not a legal move."""
    return cells.at[1].set(grid.n_cells - 1), length, jnp.bool_(False)


def _lies_about_failure(key, grid, cells, length):
    """Deletes node 1 and reports a failure (a failure must return the parent)."""
    keep = (jnp.arange(cells.shape[0]) < length) & (jnp.arange(cells.shape[0]) != 1)
    out, n = compact(cells, keep)
    return out, n, jnp.bool_(True)


def _not_pure(key, grid, cells, length):
    """Reads a Python counter: two traces with the same key give different results."""
    _not_pure.calls += 1
    return cells, length, jnp.bool_(_not_pure.calls % 2 == 0)


_not_pure.calls = 0


@pytest.mark.parametrize("fn, message", [
    (_teleport, "not continuous"),
    (_lies_about_failure, "a failed individual must be its parent"),
    (_not_pure, "the same key gave another result"),
])
def test_a_registered_operator_that_breaks_the_contract_fails_it(setting, fn, message):
    grid, pop = setting
    op = registry.register(registry.Operator("mutation", "broken_toy", fn, "broken (test)"))
    try:
        with pytest.raises(AssertionError, match=message):
            testing.check_family(op, grid, pop, jax.random.PRNGKey(0))
    finally:
        registry.unregister("mutation", "broken_toy")


def test_a_shrinking_operator_that_lengthens_fails_the_contract(setting):
    grid, pop = setting
    real = registry.operator("mutation", "neighbour_point")  # it may lengthen a path
    op = registry.register(registry.Operator("simplify", "toy_grow", real.fn, "test",
                                             traits=frozenset({registry.SHRINKING})))
    try:
        with pytest.raises(AssertionError, match="shrinking"):
            testing.check_family(op, grid, pop, jax.random.PRNGKey(1))
    finally:
        registry.unregister("simplify", "toy_grow")


# ------------------------------------------------ configuration and registry agree
def test_the_configuration_accepts_exactly_the_registered_names():
    base = load_preset("sga")
    for family in registry.FAMILIES:
        key = f"{family}.method"
        for op in registry.operators(family):
            for name in (op.name, *op.aliases):
                changes = {key: name, **{k: testing.some_value(op.params[k])
                                          for k in op.required}}
                assert base.override(changes)[key] == op.name  # aliases -> current name
        with pytest.raises(ParameterError, match=re.escape(f"{key} = 'no_such_op' is not one of")):
            base.override({key: "no_such_op"})
    assert set(SCHEMA) == set(COMMON_FIELDS) | set(registry.schema_fields())


def test_registering_adds_the_name_and_keys_and_unregistering_removes_them():
    from jaxga.core.fields import Field

    field = Field(float, "toy strength", low=0.0, high=2.0, dynamic=True, default=1.0)
    op = registry.Operator("mutation", "toy_op", registry.operator("mutation",
                                                                     "replace_point").fn,
                           "toy", params={"mutation.toy_strength": field}, aliases=("toy",))
    registry.register(op)
    try:
        config = load_preset("sga").override({"mutation.method": "toy"})
        assert config["mutation.method"] == "toy_op"
        assert config["mutation.toy_strength"] == 1.0  # the field's default
        assert SCHEMA["mutation.toy_strength"] is field
        with pytest.raises(ValueError, match="already registered"):
            registry.register(op)
    finally:
        registry.unregister("mutation", "toy_op")
    assert "mutation.toy_strength" not in SCHEMA
    with pytest.raises(ParameterError, match="is not one of"):
        load_preset("sga").override({"mutation.method": "toy"})


@pytest.mark.parametrize("bad, message", [
    (dict(family="mutations"), "unknown operator family"),
    (dict(name="neighbour_point"), "already registered"),
    (dict(aliases=("range",)), "already registered"),
    (dict(traits=frozenset({"fast"})), "unknown trait"),
    (dict(params={"fitness.toy": SCHEMA["fitness.window"]}), "not in the 'mutation' section"),
    (dict(params={"mutation.radius": SCHEMA["mutation.probability"]}),
     "declared with another field"),
    (dict(required=("mutation.nothing",)), "are not parameters"),
])
def test_register_refuses_inconsistent_declarations(bad, message):
    op = registry.Operator(**{"family": "mutation", "name": "toy_bad", "fn": None,
                              "summary": "test", **bad})
    with pytest.raises(ValueError, match=message):
        registry.register(op)
    assert registry.canonical("mutation", "toy_bad") is None


def test_the_old_names_in_a_users_preset_file_still_work(tmp_path):
    user = tmp_path / "old.toml"
    user.write_text("\n".join([
        "generations = 5", "[population]", "size = 8", "[init]", 'method = "directional"',
        "[fitness]", 'method = "sga"', "[selection]", 'method = "roulette"',
        "[crossover]", 'method = "zhu_mixed"', "probability = 0.8",
        "[mutation]", 'method = "range"', "probability = 0.4",
        "[simplify]", 'method = "corner_cut"', "probability = 0.5"]) + "\n")
    config = load_preset(user)
    assert (config["crossover.method"], config["mutation.method"],
            config["simplify.method"]) == ("common_point_or_column", "regrow_segment",
                                           "cut_corners")


def test_operators_command_lists_the_registry():
    out = subprocess.run([sys.executable, "-m", "jaxga.cli", "operators", "mutation"],
                         capture_output=True, text=True, check=True,
                         cwd=Path(__file__).resolve().parents[2]).stdout
    for op in registry.operators("mutation"):
        assert re.search(rf"^  {op.name}\b", out, re.M), op.name
        for key in op.params:
            assert key in out
    assert "replace_point (formerly one_point)" in out


@pytest.mark.parametrize("preset", preset_names())
def test_a_presets_stages_are_its_operators_resolved_once(preset):
    """An :class:`~jaxga.engine.Algorithm` carries its operators and rate rules resolved
    from the registry (:class:`~jaxga.engine.algorithm.Stages`), the ones the
    configuration names; a program's view holds only its own families' (the others
    None, so a stage outside the view fails while tracing); equality and hash are the
    configuration's."""
    import dataclasses

    from jaxga._runtime.programs import program_view
    from jaxga.engine import build, chosen_operators
    from jaxga.engine.algorithm import Stages
    from jaxga.operators.rates import rate_rule

    algo, _ = build(load_preset(preset), load_map("classic_ga_gapp3_20x20"))
    chosen = chosen_operators(algo.config)
    for family in registry.FAMILIES:
        assert getattr(algo.stages, family) is chosen[f"{family}.method"], family
    never_fails = registry.NEVER_FAILS in algo.stages.init.traits
    assert algo.stages.fallback is (None if never_fails else chosen.get("init.fallback"))
    for stage in ("crossover", "mutation"):
        assert getattr(algo.stages, f"{stage}_rate") is rate_rule(algo.config, stage)
    assert algo.stages.field_repair == (algo.get("repair.fallback") == "field")
    init = program_view(algo, "init").stages
    assert init.init is algo.stages.init and init.fitness is algo.stages.fitness
    assert init.crossover is None and init.mutation is None and init.post is None
    finish = program_view(algo, "finish").stages
    assert finish.post is algo.stages.post and finish.selection is None
    other = dataclasses.replace(algo, stages=Stages())
    assert other == algo and hash(other) == hash(algo)
