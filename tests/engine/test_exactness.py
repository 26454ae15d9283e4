"""What a correct backend may compute differently, and that no preset relies on
(docs/devices.md, "Exactness"): the order in which a ``set`` scatter applies updates to
one index, the order an unstable sort gives equal keys, and the rounding of a
floating-point accumulation whose order XLA chooses.

* a lint over every preset's whole run (``GA.run``, traced only): every sort is stable
  (equal keys keep their positions, on every backend) and every combining scatter
  (add, mul, min, max) works on integers or booleans, whose result does not depend on
  the order of its updates;
* every preset's run compiled with every ``set`` scatter's updates in reverse order and
  the ties of unstable sorts flipped (:mod:`tests.lowering_variants`) gives
  ``jaxga.run``'s result bit for bit;
* the variants themselves change a program that does rely on those orders (the check is
  not vacuous);
* a run's initial population is the same alone, in a call of 10 and in one of 256.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.extend.core import Jaxpr

import jaxga
from jaxga.config.presets import preset_names
from tests import canonical
from tests.api.test_ga import assert_seed_for_seed
from tests.jaxprs import sub_jaxprs
from tests.lowering_variants import altered_lowering

SEEDS = [0, 1, 2]
COMBINING = ("scatter-add", "scatter_add", "scatter-mul", "scatter_mul", "scatter-min",
             "scatter_min", "scatter-max", "scatter_max")


def _where(eqn) -> str:
    """The innermost frames of the Python code that made ``eqn`` (file:function)."""
    frames = eqn.source_info.traceback.frames if eqn.source_info.traceback else []
    frames = [f for f in frames if "/jaxga/" in f.file_name] or frames  # jaxga's own first
    return " <- ".join(f"{'/'.join(f.file_name.rsplit('/', 2)[-2:])}:{f.function_name}"
                       for f in frames[:3])


def _order_dependent(jaxpr: Jaxpr, found: list[str]) -> None:
    """Append every unstable sort and every floating-point combining scatter of
    ``jaxpr`` and of the jaxprs inside it."""
    for eqn in jaxpr.eqns:
        name = eqn.primitive.name
        if name == "sort" and not eqn.params["is_stable"]:
            found.append(f"unstable sort at {_where(eqn)}")
        if name in COMBINING and jnp.issubdtype(eqn.outvars[0].aval.dtype, jnp.inexact):
            found.append(f"{name} of {eqn.outvars[0].aval.dtype} at {_where(eqn)}")
        for sub in sub_jaxprs(eqn.params):
            _order_dependent(sub, found)


def test_the_lint_sees_unstable_sorts_and_float_accumulation_inside_loops():
    def risky(x, i):
        def body(_, c):
            c = c.at[i].add(1.0)  # float scatter-add: rounding follows the order
            return jax.lax.sort(c, is_stable=False)

        return jax.lax.fori_loop(0, 2, body, x)

    found: list[str] = []
    _order_dependent(jax.make_jaxpr(risky)(jnp.zeros(4), jnp.array([1, 1])).jaxpr, found)
    assert len(found) == 2, found
    assert found[0].startswith("scatter-add of float32") or found[1].startswith(
        "scatter-add of float32"), found
    assert any(f.startswith("unstable sort") for f in found), found


@pytest.mark.parametrize("preset", preset_names())
def test_no_run_holds_an_unstable_sort_or_a_floating_point_combining_scatter(preset):
    ga = jaxga.GA(preset, canonical.MAP, generations=2)
    found: list[str] = []
    _order_dependent(jax.make_jaxpr(ga.run)(jax.random.PRNGKey(0), ga.default_params).jaxpr,
                     found)
    assert not found, found


def test_the_variants_change_programs_that_rely_on_those_orders():
    """A ``set`` scatter with a repeated index (alone and under ``vmap``, where JAX
    scatters with batching dimensions) and an unstable sort of equal keys: each gives
    another result under its variant; a stable sort gives the same."""
    x, idx, upd = jnp.zeros(4, jnp.int32), jnp.array([1, 1, 2]), jnp.array([5, 7, 9])
    rows = (jnp.zeros((2, 4), jnp.int32), jnp.array([[1, 1, 2]] * 2),
            jnp.array([[5, 7, 9], [1, 2, 3]]))
    keys, values = jnp.array([2, 1, 2, 1]), jnp.arange(4)

    def programs():  # new functions: jit lowers them under the rules in force
        return (jax.jit(lambda a, i, u: a.at[i].set(u)),
                jax.jit(jax.vmap(lambda a, i, u: a.at[i].set(u))),
                jax.jit(lambda k, v: jax.lax.sort((k, v), num_keys=1, is_stable=False)[1]),
                jax.jit(lambda k, v: jax.lax.sort((k, v), num_keys=1, is_stable=True)[1]))

    def results():
        one, batched, unstable, stable = programs()
        return [np.asarray(r) for r in (one(x, idx, upd), batched(*rows),
                                       unstable(keys, values), stable(keys, values))]

    plain = results()
    with altered_lowering():
        varied = results()
    np.testing.assert_array_equal(plain[0][[0, 2, 3]], varied[0][[0, 2, 3]])
    assert plain[0][1] != varied[0][1]  # the repeated index took the other update
    assert not np.array_equal(plain[1], varied[1])
    assert sorted(plain[2][:2]) == sorted(varied[2][:2]) and list(plain[2]) != list(varied[2])
    np.testing.assert_array_equal(plain[3], varied[3])  # a stable sort: one order


@pytest.mark.slow  # a whole GA compiled again for each preset
@pytest.mark.parametrize("preset", preset_names())
def test_a_run_is_the_same_with_scatters_reversed_and_sort_ties_flipped(preset):
    """``GA.run`` compiled under :func:`altered_lowering` gives the canonical
    ``jaxga.run``'s seeds bit for bit: no preset relies on the order of a scatter's
    updates or on how an unstable sort orders ties."""
    ref = canonical.run(preset, SEEDS)
    ga = jaxga.GA(preset, canonical.MAP, generations=canonical.GENERATIONS)
    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(SEEDS, jnp.uint32))
    with altered_lowering():
        out = jax.jit(jax.vmap(lambda k, p: ga.run(k, p), (0, None)))(keys,
                                                                       ga.default_params)
    assert_seed_for_seed(out, ref)


@pytest.mark.slow  # three initialisation programs per preset, one of 256 runs
@pytest.mark.parametrize("preset", preset_names())
def test_an_initial_population_is_the_same_alone_in_10_and_in_256_runs(preset):
    """``GA.init`` of run ``i`` in one ``vmap`` of 256 runs equals it in a ``vmap`` of 10
    and alone, every leaf of the state bit for bit: the batch a run shares changes
    nothing (decision 037: a GPU's initialisers failed at 256 and 2048 runs per call)."""
    ga = jaxga.GA(preset, canonical.MAP, generations=canonical.GENERATIONS)
    keys = jax.random.split(jax.random.PRNGKey(5), 256)
    many = jax.jit(jax.vmap(ga.init, (0, None)))(keys, ga.default_params)
    few = jax.jit(jax.vmap(ga.init, (0, None)))(keys[:10], ga.default_params)
    last = jax.jit(ga.init)(keys[-1], ga.default_params)
    for a, b, c in zip(*map(jax.tree_util.tree_leaves, (many, few, last))):
        np.testing.assert_array_equal(np.asarray(a)[:10], np.asarray(b))
        np.testing.assert_array_equal(np.asarray(a)[-1], np.asarray(c))
