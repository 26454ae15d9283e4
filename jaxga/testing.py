"""The operator contract, as a public check: ``jaxga.testing.check_operator``.

Run it on an operator of your own before you use it in a run::

    import jaxga.testing
    jaxga.testing.check_operator("mutation", my_mutation)        # a function, or
    jaxga.testing.check_operator(jaxga.operators.registry.operator("mutation", "drop_point"))

It raises ``AssertionError`` naming the operator and the rule it broke; jaxga's own test
suite runs it on every registered operator (``tests/config/test_registry.py``).

The contract of each family (the signatures: :mod:`jaxga.operators.registry`). Shared by
every family: outputs have the documented dtypes and shapes; paths are padded with their
last cell (the fixed-length masked chromosome, docs "the pure core") and their lengths lie
in ``[1, L]``; the same key gives the same result, under ``jax.vmap`` and ``jit`` as alone
(two separate traces). Path operators (crossover, mutation, simplify): a reported failure
returns the parent bit for bit, and feasible, loop-free parents from start to goal give
feasible, loop-free children from start to goal (continuous ones unless the operator makes
waypoint paths); a ``shrinking`` operator never lengthens a path. Objectives: float32, one
per path, finite, positive on feasible paths and 0 on infeasible ones, with no float
reduction whose rounding follows the batch's shape (:func:`float_reductions`: a float sum
is added in a fixed order, :func:`jaxga.core.objectives.ordered_sum`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.extend.core
import jax.numpy as jnp
import numpy as np

from jaxga._runtime.fields import program_fields
from jaxga.config.presets import load_preset
from jaxga.core import prng
from jaxga.core.fields import shown_value
from jaxga.core.grid import Grid
from jaxga.core.objectives import path_length
from jaxga.core.own_settings import own_settings
from jaxga.core.paths import (
    Population,
    has_endpoints,
    is_continuous,
    is_feasible,
    is_loop_free,
    remove_loops,
)
from jaxga.engine import binding, build, default_capacity, fitness_function
from jaxga.engine.maptables import with_tables
from jaxga.maps import random_map
from jaxga.operators import registry
from jaxga.operators.guide import with_guide
from jaxga.operators.repair import connect

P = 6
"""Individuals (or pairs) per check."""



def some_value(field):
    """A valid value of a field the configuration must set (its default, else the middle
    of its range, else one above its minimum)."""
    if field.default is not None:
        return field.default
    kind = field.kind[0] if isinstance(field.kind, tuple) else field.kind
    if field.low is not None and field.high is not None:
        return kind((field.low + field.high) / 2)
    return kind((field.low or 0) + 1)


def bound(op: registry.Operator, grid: Grid, capacity: int, field_repair: bool = False):
    """``op`` bound as the engine binds it, in a small SGA configuration that selects it
    (its required keys set): ``(bound function, Binding, fitness function)``."""
    changes = {f"{op.family}.method": op.name, "population.size": P, "generations": 2,
               "population.capacity": capacity,
               "repair.fallback": "field" if field_repair else "none"}
    changes.update({k: some_value(op.params[k]) for k in op.required})
    if registry.NEEDS_FRONT_FIELDS in op.traits:  # it reads a front's fields
        changes["survival.method"] = "nsga2"
    config = load_preset("sga").override(changes)
    algo, params = build(config, grid)
    fit_fn = fitness_function(algo, params)
    ctx = binding(algo, params, jnp.int32(1), fit_fn)
    return (None if op.fn is None else op.bind(ctx)), ctx, fit_fn


def _tree_equal(a, b) -> bool:
    return all(np.array_equal(np.asarray(x), np.asarray(y))
               for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b),
                               strict=True))


def _check(ok, op: registry.Operator, what: str) -> None:
    if not bool(np.all(np.asarray(ok))):
        raise AssertionError(f"{op.family} operator {op.name!r}: {what}")


@functools.partial(jax.jit, static_argnames="waypoints")
def _path_checks(grid: Grid, cells, length, waypoints: bool):
    """Per path: from start to goal, feasible (continuous unless ``waypoints``), loop-free;
    one compiled program per shape, shared by every operator's check."""
    feasible = is_feasible if waypoints else is_continuous
    ends = jax.vmap(lambda a, b: has_endpoints(grid, a, b))(cells, length)
    feas = jax.vmap(lambda a, b: feasible(grid, a, b))(cells, length)
    loops = jax.vmap(lambda a, b: is_loop_free(a, b, grid.n_cells))(cells, length)
    return ends, feas, loops


_path_lengths = jax.jit(jax.vmap(path_length, in_axes=(None, 0, 0)))


def check_paths(op, grid: Grid, cells, length, *, valid=None, waypoints=False) -> None:
    """Shapes, dtypes and padding of paths ``cells[N, L]``, ``length[N]``; where
    ``valid``: start to goal, feasible (continuous unless ``waypoints``), loop-free."""
    cells, length = np.asarray(cells), np.asarray(length)
    _check(cells.dtype == np.int32 and length.dtype == np.int32, op, "paths must be int32")
    n, cap = cells.shape
    _check((length >= 1) & (length <= cap), op, "a length outside [1, L]")
    last = cells[np.arange(n), np.clip(length - 1, 0, cap - 1)]
    pad_ok = np.where(np.arange(cap)[None, :] >= length[:, None], cells == last[:, None], True)
    _check(pad_ok, op, "paths must be padded with their last cell")
    if valid is None:
        return
    ends, feas, loops = _path_checks(grid, jnp.asarray(cells), jnp.asarray(length),
                                     waypoints)
    valid = np.asarray(valid)
    _check(~valid | np.asarray(ends), op, "a path that does not go from start to goal")
    _check(~valid | np.asarray(feas), op, "an infeasible path from feasible input"
           if waypoints else "a path that is not continuous (8-connected)")
    _check(~valid | np.asarray(loops), op, "a path with a loop from loop-free input")


def _vmap_equals_alone(op, batched, alone, args_of) -> None:
    """Same key, same result: the first and last rows of the batched (``vmap``) result
    equal the operator called alone (a separate trace under ``jit``)."""
    one = jax.jit(alone)
    for i in (0, P - 1):
        row = jax.tree_util.tree_map(lambda x, i=i: x[i], batched)
        _check(_tree_equal(one(*args_of(i)), row),
               op, "the same key gave another result alone than under vmap")


def check_init(op: registry.Operator, grid: Grid, capacity: int, key) -> None:
    """``init_fn(key, grid, capacity) -> (cells, length, ok)``: a successful draw is a
    feasible, loop-free path from start to goal."""
    fn, _, _ = bound(op, grid, capacity)
    if registry.NEEDS_FRONT_FIELDS in op.traits:
        grid = program_fields(grid, load_preset("pareto"))
    keys = prng.split(key, P)
    run = jax.jit(jax.vmap(lambda k: fn(k, grid, capacity)))
    cells, length, ok = out = run(keys)
    _check(np.asarray(ok).dtype == bool, op, "ok must be bool")
    check_paths(op, grid, cells, length, valid=ok)
    if registry.NEVER_FAILS in op.traits:
        _check(ok, op, "it declares never_fails, but failed on a reachable goal")
    _vmap_equals_alone(op, out, lambda k: fn(k, grid, capacity), lambda i: (keys[i],))


def check_fitness(op: registry.Operator, grid: Grid, pop: Population) -> None:
    """``f(grid, cells, length, feasible) -> f32``: finite and positive on feasible
    paths, 0 on infeasible ones."""
    fn, _, _ = bound(op, grid, pop.cells.shape[1])
    feasible = jnp.arange(P) % 2 == 0
    run = jax.jit(jax.vmap(lambda c, n, f: fn(grid, c, n, f)))
    f = run(pop.cells, pop.length, feasible)
    _check(np.asarray(f).dtype == np.float32 and np.asarray(f).shape == (P,), op,
           "fitness must be float32, one per path")
    _check(np.isfinite(f), op, "a fitness that is not finite")
    _check(np.where(np.asarray(feasible), np.asarray(f) > 0, np.asarray(f) == 0), op,
           "fitness must be > 0 for feasible paths and 0 for infeasible ones")
    _vmap_equals_alone(op, f, lambda c, n, ok: fn(grid, c, n, ok),
                       lambda i: (pop.cells[i], pop.length[i], feasible[i]))
    reductions = float_reductions(lambda c, n, ok: fn(grid, c, n, ok), pop.cells[0],
                                  pop.length[0], feasible[0])
    _check(not reductions, op,
           f"it adds floats with {', '.join(reductions)}, whose rounding follows the shape "
           "of the batch it runs in (jnp.sum alone and in a population differ in the last "
           "bit): add with jaxga.core.objectives.ordered_sum")


ORDER_DEPENDENT = ("reduce_sum", "reduce_prod", "cumsum", "cumprod", "cumlogsumexp",
                   "dot_general", "scatter-add")
"""Primitives whose floating-point result depends on the order XLA adds in, which it
chooses by the shape of the whole batch (decision 044)."""


def float_reductions(fn: Callable, *args: Any) -> list[str]:
    """The primitives of :data:`ORDER_DEPENDENT` with a floating-point result that
    ``fn(*args)`` binds (nested calls, loops and branches included): each rounds a row
    otherwise alone than in a batch. Sorted names, each once."""
    found: set[str] = set()

    def walk(jaxpr: jax.extend.core.Jaxpr) -> None:
        for eqn in jaxpr.eqns:
            if eqn.primitive.name in ORDER_DEPENDENT and any(
                    jnp.issubdtype(v.aval.dtype, jnp.inexact) for v in eqn.outvars):
                found.add(eqn.primitive.name)
            for sub in jax.extend.core.jaxprs_in_params(eqn.params):
                walk(sub)

    walk(jax.make_jaxpr(fn)(*args).jaxpr)
    return sorted(found)


def check_selection(op: registry.Operator, grid: Grid, key) -> None:
    """``select(key, fitness, active) -> int32[P]``: indices of active individuals."""
    if op.fn is None:
        return
    fn, _, _ = bound(op, grid, 32)
    fitness = jnp.asarray([0.5, 0.0, 0.9, 0.2, 0.7, 0.3], jnp.float32)
    active = jnp.arange(P) < P - 2
    keys = prng.split(key, P)
    run = jax.jit(jax.vmap(lambda k: fn(k, fitness, active)))
    idx = run(keys)
    idx = np.asarray(idx)
    _check(idx.dtype == np.int32 and idx.shape == (P, P), op, "indices must be int32[P]")
    _check((idx >= 0) & (idx < P - 2), op, "it selected an inactive or off-range individual")
    _vmap_equals_alone(op, jnp.asarray(idx), lambda k: fn(k, fitness, active),
                       lambda i: (keys[i],))


def check_variation(op: registry.Operator, grid: Grid, pop: Population, key,
                    field_repair: bool = False) -> None:
    """A crossover (pairs of rows ``2k, 2k+1``), mutation or simplification on feasible,
    loop-free parents from start to goal."""
    fn, ctx, _ = bound(op, grid, pop.cells.shape[1], field_repair)
    waypoints = registry.WAYPOINTS in op.traits
    if fn is None:  # a composition of registered operators: the population lift only
        return check_lift(op, grid, pop, key, ctx, waypoints)
    keys = prng.split(key, P)
    if op.family == "crossover":
        c1, l1 = pop.cells[0::2], pop.length[0::2]
        c2, l2 = pop.cells[1::2], pop.length[1::2]
        half = P // 2
        keys = keys[:half]
        run = jax.jit(jax.vmap(lambda k, a, b, c, d: fn(k, grid, a, b, c, d)))
        out = run(keys, c1, l1, c2, l2)
        o1, n1, o2, n2, failed = (np.asarray(x) for x in out)
        _check(failed.dtype == np.int32 and ((failed >= 0) & (failed <= 2)).all(), op,
               "n_failed must be an int32 count of 0, 1 or 2 slots")
        same1 = (o1 == np.asarray(c1)).all(1) & (n1 == np.asarray(l1))
        same2 = (o2 == np.asarray(c2)).all(1) & (n2 == np.asarray(l2))
        _check(same1.astype(int) + same2.astype(int) >= failed, op,
               "a failed child must be its parent, unchanged")
        cells = np.concatenate([o1, o2])
        length = np.concatenate([n1, n2])
        check_paths(op, grid, cells, length, valid=np.ones(len(length), bool),
                    waypoints=waypoints)
        grew = length > np.concatenate([np.asarray(l1), np.asarray(l2)])
        _vmap_equals_alone(op, out, lambda k, a, b, c, d: fn(k, grid, a, b, c, d),
                           lambda i: (keys[min(i, half - 1)], c1[min(i, half - 1)],
                                      l1[min(i, half - 1)], c2[min(i, half - 1)],
                                      l2[min(i, half - 1)]))
    else:
        run = jax.jit(jax.vmap(lambda k, c, n: fn(k, grid, c, n)))
        out = run(keys, pop.cells, pop.length)
        cells, length, failed = (np.asarray(x) for x in out)
        _check(failed.dtype == bool and failed.shape == (P,), op, "failed must be bool[P]")
        same = (cells == np.asarray(pop.cells)).all(1) & (length == np.asarray(pop.length))
        _check(~failed | same, op, "a failed individual must be its parent, unchanged")
        check_paths(op, grid, cells, length, valid=np.ones(P, bool), waypoints=waypoints)
        grew = length > np.asarray(pop.length)
        _vmap_equals_alone(op, out, lambda k, c, n: fn(k, grid, c, n),
                           lambda i: (keys[i], pop.cells[i], pop.length[i]))
    if registry.SHRINKING in op.traits:
        _check(~grew, op, "it declares shrinking, but lengthened a path")


def check_lift(op: registry.Operator, grid: Grid, pop: Population, key, ctx,
               waypoints: bool) -> None:
    """The population lift (probability 1): shapes, determinism, valid children."""
    lifted = jax.jit(lambda k, c, n: op.lift(ctx)(k, grid, Population(c, n), 1.0))
    out = lifted(key, pop.cells, pop.length)
    new, failed = out
    _check(np.asarray(failed).dtype == np.int32 and 0 <= int(failed) <= P, op,
           "n_failed must be an int32 count of at most P")
    check_paths(op, grid, new.cells, new.length, valid=np.ones(P, bool), waypoints=waypoints)


def check_post(op: registry.Operator, grid: Grid, pop: Population) -> None:
    """``post(grid, cells, length) -> (cells, length)``: a feasible path from start to
    goal, no longer than its input."""
    if op.fn is None:
        return
    fn, _, _ = bound(op, grid, pop.cells.shape[1])
    run = jax.jit(jax.vmap(lambda c, n: fn(grid, c, n)))
    out = run(pop.cells, pop.length)
    cells, length = out
    check_paths(op, grid, cells, length, valid=np.ones(P, bool), waypoints=True)
    before = _path_lengths(grid, pop.cells, pop.length)
    after = _path_lengths(grid, cells, length)
    _check(np.asarray(after) <= np.asarray(before) + 1e-4, op, "it lengthened a path")
    _vmap_equals_alone(op, out, lambda c, n: fn(grid, c, n),
                       lambda i: (pop.cells[i], pop.length[i]))


def check_family(op: registry.Operator, grid: Grid, pop: Population, key,
                 field_repair: bool = False) -> None:
    """The contract of ``op``'s family (module docstring) on ``grid`` with feasible,
    loop-free parents ``pop`` (``P`` paths of the grid's capacity); ``op`` registered."""
    checks = {
        "init": lambda: check_init(op, grid, pop.cells.shape[1], key),
        "fitness": lambda: check_fitness(op, grid, pop),
        "selection": lambda: check_selection(op, grid, key),
        "crossover": lambda: check_variation(op, grid, pop, key, field_repair),
        "mutation": lambda: check_variation(op, grid, pop, key, field_repair),
        "simplify": lambda: check_variation(op, grid, pop, key, field_repair),
        "post": lambda: check_post(op, grid, pop),
    }
    if op.family not in checks:
        raise AssertionError(f"no contract for the family {op.family!r}")
    if op.fn is not None or op.population is not None:  # "none": the stage does nothing
        checks[op.family]()


CAPACITY = 64
"""The capacity of the parents :func:`check_operator` makes by default."""


@functools.partial(jax.jit, static_argnames="capacity")
def _connected(keys, grid: Grid, anchors, capacity: int):
    cells, length, ok = jax.vmap(lambda k, a: connect(k, grid, a, 3, capacity))(keys, anchors)
    cells, length = jax.vmap(lambda c, n: remove_loops(c, n, grid.n_cells))(cells, length)
    return cells, length, ok


def random_parents(grid: Grid, n: int, seed: int, capacity: int = CAPACITY) -> Population:
    """``n`` continuous, loop-free paths from start to goal of ``capacity`` slots (start,
    a random free cell, goal, joined by median insertion, IMGA section 4.1; retried until
    ``n`` succeed): parents made without the operator under test."""
    rng = np.random.default_rng(seed)
    free = np.flatnonzero(~grid.blocked_np().reshape(-1))
    got_c, got_n = [], []
    for attempt in range(50):
        mids = rng.choice(free, 4 * n)
        anchors = np.stack([np.full(4 * n, int(grid.start)), mids,
                            np.full(4 * n, int(grid.goal))], 1).astype(np.int32)
        keys = prng.split(prng.seed_key(seed * 1000 + attempt), 4 * n)
        cells, length, ok = _connected(keys, grid, jnp.asarray(anchors), capacity)
        ok = np.asarray(ok)
        got_c += list(np.asarray(cells)[ok])
        got_n += list(np.asarray(length)[ok])
        if len(got_c) >= n:
            break
    if len(got_c) < n:
        raise RuntimeError("could not build valid parents: is the goal reachable?")
    return Population(jnp.asarray(np.stack(got_c[:n])),
                      jnp.asarray(np.array(got_n[:n], np.int32)))


def default_setting() -> tuple[Grid, Population]:
    """The map and parents :func:`check_operator` uses by default: a 10 x 10 map with 20 %
    obstacles under the strictest corner rule, as a run sees it (distance fields and
    per-map tables attached), and ``P`` feasible, loop-free parents of capacity
    :data:`CAPACITY`."""
    grid = with_tables(with_guide(random_map(10, 10, 0.2, 3, corner_rule="strict")))
    return grid, random_parents(grid, P, seed=5)


@own_settings
def check_operator(op: registry.Operator | str, fn: Callable | None = None, *,
                   grid: Grid | None = None, parents: Population | None = None,
                   key: jax.Array | None = None, field_repair: bool = False,
                   **declaration: Any) -> None:
    """Check an operator against its family's contract (module docstring).

    Args:
        op: a :class:`~jaxga.operators.registry.Operator` (registered or not), or a family
            name (``"mutation"``, ``"fitness"``, ...) with ``fn``.
        fn: the operator's function, with its family's signature
            (:mod:`jaxga.operators.registry`), when ``op`` is a family name.
        grid: the map to check on (default: :func:`default_setting`'s).
        parents: ``P`` feasible, loop-free parents on ``grid`` (default:
            :func:`default_setting`'s, or :func:`random_parents` on a ``grid`` given).
        key: the PRNG key of the check (default ``PRNGKey(0)``).
        field_repair: check it as bound with ``repair.fallback = "field"``.
        **declaration: the rest of the :class:`~jaxga.operators.registry.Operator` built
            from ``fn`` (``name``, ``summary``, ``traits``, ``params``, ``options``).

    Raises:
        AssertionError: naming the operator and the rule it broke.
    """
    if isinstance(op, str):
        if op not in registry.FAMILIES:
            raise ValueError(f"check_operator: unknown operator family {shown_value(op)} "
                             f"(one of {', '.join(registry.FAMILIES)})")
        if fn is None:
            raise TypeError("check_operator(family, fn): give the operator's function")
        if not callable(fn):
            raise TypeError(f"check_operator({op!r}, fn): fn must be a function, got "
                            f"{shown_value(fn)}")
        declared = {k: v for k, v in declaration.items() if k not in ("name", "summary")}
        declaration.setdefault("name", getattr(fn, "__name__", "operator"))
        declaration.setdefault("summary", "an operator under test")
        if "traits" in declaration:
            declaration["traits"] = registry.as_traits(declaration["traits"])
        op = registry.Operator(family=op, fn=fn, **declaration)
        current = registry.canonical(op.family, op.name)
        if current is not None and any(
                getattr(registry.operator(op.family, current), k) != getattr(op, k)
                for k in declared):
            raise ValueError(f"check_operator: {op.family} operator {op.name!r} is registered "
                             f"with another {', '.join(sorted(declared))}: the registered "
                             "one would be checked; drop these arguments or unregister it")
    if grid is None:
        grid, default_pop = default_setting()
        parents = default_pop if parents is None else parents
    elif parents is None:  # parents on the user's map, not the default map's, sized for it
        try:
            parents = random_parents(grid, P, seed=5,
                                     capacity=max(CAPACITY, default_capacity(grid)))
        except RuntimeError:
            raise ValueError("check_operator: no parents could be made on this grid (is "
                             "the goal reachable from the start?): pass parents=") from None
    if parents.cells.shape[0] != P:
        raise ValueError(f"check_operator needs {P} parents, got {parents.cells.shape[0]}")
    key = prng.seed_key(0) if key is None else key
    registered = registry.canonical(op.family, op.name) is not None
    if registered:  # check the registered operator (its options, traits), same function
        current = registry.operator(op.family, op.name)
        if current.fn is not op.fn:
            raise ValueError(f"another {op.family} operator is registered as {op.name!r}")
        op = current
    else:
        registry.register(op)
    try:
        check_family(op, grid, parents, key, field_repair)
    except registry.ContractError as e:  # outputs of another shape than the contract's
        raise AssertionError(str(e)) from None
    finally:
        if not registered:
            registry.unregister(op.family, op.name)
