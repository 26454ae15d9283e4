"""Round fourteen (decision 062): a researcher's Python session around jaxga's objects:
copies and pickles compared by value, a GA sent to another process, a GA used after
64-bit mode was turned on, an operator of one's own in a process that did not register
it."""

from __future__ import annotations

import copy
import math
import pickle

import jax
import numpy as np
import pytest

import jaxga
from jaxga.core.equality import values_equal
from jaxga.core.errors import ParameterError
from jaxga.maps import load_map_info
from tests import canonical


def test_results_compare_by_value_with_their_copies_and_pickles():
    """`result == copy.deepcopy(result)` raised "truth value of an array is ambiguous"
    (dataclasses compare arrays element by element) and a pickled result's NaN
    references compared unequal; now a copy, a pickle and the sub-records compare
    equal, and a run of other seeds does not."""
    r = canonical.run("sga")
    for other in (copy.deepcopy(r), pickle.loads(pickle.dumps(r))):
        assert r == other
        assert r.outcome == other.outcome and r.references == other.references
    assert math.isnan(r.references.maximin_clearance)  # NaN, equal to its pickle's NaN
    assert r != canonical.run("sga", seeds=[7, 8, 9])
    assert r.setup != "sga"  # another type: not equal, no error


def test_records_a_user_may_change_say_they_are_not_hashable():
    """A result (not frozen) raised on hash() yet passed isinstance(Hashable): a library
    that keys a cache on hashable values took it and failed later; it is now declared
    unhashable, as a dataclass with == is, and frozen records stay hashable."""
    from collections.abc import Hashable

    r = canonical.run("sga")
    assert not isinstance(r, Hashable)
    with pytest.raises(TypeError, match="unhashable"):
        hash(r)
    assert hash(r.references) == hash(copy.deepcopy(r.references))  # frozen, plain values


def test_maps_and_grids_compare_by_value_and_keep_their_hash_rules():
    info = load_map_info(canonical.MAP)
    again = pickle.loads(pickle.dumps(info))
    assert info == again and info.grid == copy.deepcopy(info.grid)
    assert info.grid != info.grid.replace(corner_rule="strict")
    with pytest.raises(TypeError, match="unhashable"):
        hash(info.grid)  # it holds arrays
    shapes = jax.tree.map(lambda x: jax.ShapeDtypeStruct(np.shape(x), x.dtype), info.grid)
    assert hash(shapes) == hash(copy.deepcopy(shapes))  # a program's key, as before


def test_records_compare_and_hash_the_fields_their_dataclass_does():
    """A map frame's obstacles are declared compare=False: frames that differ only there
    are equal and hash alike, as before; a NaN field hashes alike in a record and its
    pickle, as == takes them (a set holds one)."""
    from jaxga.maps.frame import MapFrame

    a = MapFrame(map_shape=(4, 5), resolution=0.1, origin=(0.0, 0.0, 0.0),
                 obstacles=np.zeros((4, 5), bool))
    b = MapFrame(map_shape=(4, 5), resolution=0.1, origin=(0.0, 0.0, 0.0),
                 obstacles=np.ones((4, 5), bool))
    assert a == b and hash(a) == hash(b)
    assert a != MapFrame(map_shape=(4, 5), resolution=0.2, origin=(0.0, 0.0, 0.0))
    refs = canonical.run("sga").references
    again = pickle.loads(pickle.dumps(refs))
    assert refs == again and len({refs, again}) == 1


def test_values_equal_by_hand():
    assert values_equal({"a": [np.float32(np.nan), 1]}, {"a": [np.float32(np.nan), 1]})
    assert not values_equal(np.zeros(3, np.float32), np.zeros(3, np.float64))
    assert not values_equal(np.zeros(3), np.zeros(4))
    assert values_equal((1, "x", None), (1, "x", None))
    assert not values_equal([1, 2], (1, 2))


@pytest.fixture(scope="module")
def ga() -> jaxga.GA:
    return jaxga.GA("sga", canonical.MAP, generations=5)


class _MyGA(jaxga.GA):
    """A user's subclass of GA."""


def test_a_ga_is_sent_as_its_problem_and_built_again(ga):
    """Pickling a GA failed on a lambda inside the operators ("attribute lookup <lambda>
    on jaxga.operators.init failed"): it is sent as its problem and built again, with
    the same configuration, map and parameters; a subclass comes back as itself."""
    back = pickle.loads(pickle.dumps(ga))
    assert type(back) is jaxga.GA and repr(back) == repr(ga) == (
        "GA('sga' on 'classic_ga_gapp3_20x20', 20 x 20 cells)")
    assert back.config == ga.config and back.grid == ga.grid
    assert values_equal(back.default_params, ga.default_params)
    mine = pickle.loads(pickle.dumps(_MyGA("sga", canonical.MAP, generations=5)))
    assert type(mine) is _MyGA and mine.grid == ga.grid


def test_a_ga_used_after_64_bit_mode_was_turned_on_is_refused_in_one_line(ga):
    """GA(...) refused 64-bit mode, but a GA built before it was turned on failed deep in
    JAX (a scan's carry of int64) or returned int64 counts: every pure method refuses it
    in one line, before tracing anything."""
    key = jax.random.PRNGKey(0)
    jax.config.update("jax_enable_x64", True)
    try:
        for call in (lambda: ga.run(key, ga.default_params),
                     lambda: ga.init(key, ga.default_params),
                     lambda: ga.step(key, None, ga.default_params)):
            with pytest.raises(ParameterError, match="64-bit mode is on") as e:
                call()
            assert "\n" not in str(e.value)
    finally:
        jax.config.update("jax_enable_x64", False)


def test_an_operator_not_registered_here_says_so():
    """A Problem sent to a spawned process names its own operator; there it is unknown,
    and the message read as a misspelt built-in: it now says that an operator of your
    own must be registered in the process that reads it."""
    with pytest.raises(ParameterError, match=r"\(your own: register it in this process\)"):
        jaxga.problem("sga", canonical.MAP, sets=["mutation.method=my_own_mutation"])


def test_a_planner_says_what_it_plans_on():
    p = jaxga.Planner(canonical.MAP, seeds=[3, 4])
    assert repr(p) == "Planner('hybrid' on 'classic_ga_gapp3_20x20', 20 x 20 cells, 2 seeds)"
    assert repr(jaxga.Planner(canonical.MAP, seeds=8)).endswith(", 8 seeds)")
