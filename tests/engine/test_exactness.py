"""What a correct backend may compute differently, and that no preset relies on
(docs/devices.md, "Exactness"): the order in which a ``set`` scatter applies updates to
one index, the order an unstable sort gives equal keys, and the rounding of a
floating-point accumulation whose order XLA chooses.

* a lint over every preset's whole run (256 runs of ``GA.run`` in one ``vmap``, traced
  and lowered only): every sort is stable (equal keys keep their positions, on every
  backend), every combining scatter (add, mul, min, max) works on integers, whose result
  does not depend on the order of its updates, every scatter and sort is one reviewed in
  ``order_sites.toml`` (with the reason its result is defined), and the lowered program
  calls no custom kernel;
* every preset's run compiled with every ``set`` scatter's updates in reverse order and
  the ties of unstable sorts flipped (:mod:`tests.lowering_variants`), in the layout of
  an accelerator's program (and a few presets in the CPU's), gives ``jaxga.run``'s
  result bit for bit;
* the variants themselves change a program that does rely on those orders (the check is
  not vacuous);
* a run's initial population is the same alone, in a call of 10 and in one of 256.
"""

from __future__ import annotations

import contextlib
import re
import sys
from pathlib import Path

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
from tests.lowering_variants import accelerators_layout, altered_lowering

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SEEDS = [0, 1, 2]
PACKAGE = str(Path(jaxga.__file__).parent) + "/"
REVIEWED = tomllib.loads((Path(__file__).parent / "order_sites.toml").read_text())["site"]
REFUSED = ("unstable sort", "scatter-add of floats", "scatter-mul of floats",
           "scatter-min of floats", "scatter-max of floats")
LINT_RUNS = 256  # a batch wide enough for the compacted loops (jaxga._batching.lanes)


def _site(eqn, parent: str) -> str:
    """``module:function`` of the innermost jaxga frame that made ``eqn``, or
    ``parent``'s (an equation inside a jitted JAX function, such as ``jnp.argsort``,
    records only the frames inside it). jaxga's draws (:mod:`jaxga.core.prng`) are JAX's
    own functions: their caller is the site."""
    frames = eqn.source_info.traceback.frames if eqn.source_info.traceback else []
    for f in frames:
        if f.file_name.startswith(PACKAGE) and not f.file_name.endswith("core/prng.py"):
            return f"{f.file_name[len(PACKAGE):]}:{f.function_name}"
    return parent


def _kind(eqn) -> str | None:
    """What ``eqn`` leaves to the backend, if anything: a sort or a scatter."""
    name = eqn.primitive.name
    if name == "sort":
        return "stable sort" if eqn.params["is_stable"] else "unstable sort"
    if name == "scatter":
        return "set scatter"
    if name.startswith("scatter"):
        inexact = jnp.issubdtype(eqn.outvars[0].aval.dtype, jnp.inexact)
        return f"{name.replace('_', '-')} of {'floats' if inexact else 'integers'}"
    return None


def order_sites(jaxpr: Jaxpr, parent: str = "") -> set[tuple[str, str]]:
    """Every ``(kind, site)`` of a sort or scatter in ``jaxpr`` and the jaxprs inside it."""
    found = set()
    for eqn in jaxpr.eqns:
        site = _site(eqn, parent)
        if kind := _kind(eqn):
            found.add((kind, site))
        for sub in sub_jaxprs(eqn.params):
            found |= order_sites(sub, site)
    return found


def test_the_lint_sees_unstable_sorts_and_float_accumulation_inside_loops():
    def risky(x, i):
        def body(_, c):
            c = c.at[i].add(1.0)  # float scatter-add: rounding follows the order
            return jax.lax.sort(c, is_stable=False)

        return jax.lax.fori_loop(0, 2, body, x)

    found = order_sites(jax.make_jaxpr(risky)(jnp.zeros(4), jnp.array([1, 1])).jaxpr)
    assert {kind for kind, _ in found} == {"scatter-add of floats", "unstable sort"}, found


def test_the_reviewed_list_names_each_site_once_with_a_reason():
    pairs = [(s["kind"], s["at"]) for s in REVIEWED]
    assert len(pairs) == len(set(pairs))
    assert all(s["why"].strip() and s["kind"] not in REFUSED for s in REVIEWED)


@pytest.fixture(scope="module")
def preset_sites() -> dict[str, tuple[set[tuple[str, str]], str]]:
    """Per preset: the order sites of ``LINT_RUNS`` runs of ``GA.run`` in one ``vmap``
    (traced only) and the StableHLO text of that program."""
    keys = jax.random.split(jax.random.PRNGKey(0), LINT_RUNS)
    out = {}
    for preset in preset_names():
        ga = jaxga.GA(preset, canonical.MAP, generations=2)
        traced = jax.jit(jax.vmap(ga.run, (0, None))).trace(keys, ga.default_params)
        out[preset] = order_sites(traced.jaxpr.jaxpr), traced.lower().as_text()
    return out


@pytest.mark.parametrize("preset", preset_names())
def test_every_scatter_and_sort_of_a_run_is_reviewed(preset_sites, preset):
    """No unstable sort, no floating-point combining scatter, no scatter or sort outside
    tests/engine/order_sites.toml, and no custom call (an opaque kernel) in the lowered
    program."""
    found, text = preset_sites[preset]
    reviewed = {(s["kind"], s["at"]) for s in REVIEWED}
    refused = sorted(f"{kind} at {site}" for kind, site in found if kind in REFUSED)
    new = sorted(f"{kind} at {site}" for kind, site in found - reviewed if kind not in REFUSED)
    assert not refused, f"order-dependent: {refused}"
    assert not new, f"not in tests/engine/order_sites.toml (review, then add): {new}"
    assert "custom_call" not in text, re.findall(r"custom_call @\w+", text)


def test_every_reviewed_site_is_still_used(preset_sites):
    used = set().union(*(found for found, _ in preset_sites.values()))
    stale = [f"{s['kind']} at {s['at']}" for s in REVIEWED if (s["kind"], s["at"]) not in used]
    assert not stale, f"no preset uses these any more: remove them from order_sites.toml: {stale}"


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


CPU_LAYOUT_PRESETS = ("sga", "iga_zhu", "mpmga")
"""Presets whose run is also checked with the CPU's layout of the folded loops: it has
scatters of its own (the compacted lanes, the gated blocks' write-back), and a program
lowered for several platforms, one of them the CPU, runs it on a GPU too (decision 049).
Every preset is checked in the accelerators' layout."""


@pytest.mark.slow  # a whole GA compiled again for each preset
@pytest.mark.parametrize("preset, layout", [(p, "accelerator") for p in preset_names()]
                         + [(p, "cpu") for p in CPU_LAYOUT_PRESETS])
def test_a_run_is_the_same_with_scatters_reversed_and_sort_ties_flipped(preset, layout):
    """``GA.run`` compiled under :func:`altered_lowering` gives the canonical
    ``jaxga.run``'s seeds bit for bit: no preset relies on the order of a scatter's
    updates or on how an unstable sort orders ties. Laid out as a GPU's program
    (:func:`accelerators_layout`: one block for all gated entries, plain lane loops;
    decision 049) as well, where no preset relies on how its batch is laid out either."""
    ref = canonical.run(preset, SEEDS)
    ga = jaxga.GA(preset, canonical.MAP, generations=canonical.GENERATIONS)
    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(SEEDS, jnp.uint32))
    with contextlib.ExitStack() as scope:
        scope.enter_context(altered_lowering())
        seen = (scope.enter_context(accelerators_layout()) if layout == "accelerator"
                else None)
        out = jax.jit(jax.vmap(lambda k, p: ga.run(k, p), (0, None)))(keys,
                                                                       ga.default_params)
    if seen is not None:
        assert seen and all(seen)  # the folded loops were traced, laid out for a GPU
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
