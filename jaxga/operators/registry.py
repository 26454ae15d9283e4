"""The operator registry: every operator of every family, declared once, beside its code.

An :class:`Operator` says which family it belongs to, which function it is, which
configuration keys it alone reads (:class:`jaxga.core.fields.Field`: type, range, help,
default), its traits, and how the engine binds it to a configuration. Everything that
needs the list of operators reads it from here:

* the configuration's allowed names and keys (:data:`jaxga.config.schema.SCHEMA`; old names
  still accepted through each operator's ``aliases``);
* the engine's dispatch (:mod:`jaxga.engine`: ``operator(family, name).lift(ctx)``, no
  chains of ``if method == ...``);
* the rule that refuses keys no stage reads (:func:`jaxga.engine.unread_keys`);
* ``jaxga operators`` (the command line's list, with parameters and traits);
* the contract tests (``tests/config/test_registry.py``), parametrised over the registry.

Each operator module declares its own operators at its end (:func:`register`, with the
function it defines): :mod:`jaxga.operators.init`, :mod:`~jaxga.operators.fitness`,
:mod:`~jaxga.operators.selection`, :mod:`~jaxga.operators.crossover`,
:mod:`~jaxga.operators.mutation`, :mod:`~jaxga.operators.simplify` and
:mod:`~jaxga.operators.postprocess`; importing :mod:`jaxga.operators` registers them all,
in the order of :data:`FAMILIES`. Adding an operator is one function plus one
:func:`register_operator` call, from any module (docs, "the pure core");
:func:`jaxga.testing.check_operator` runs its family's contract on it. The engine's
contract per family, i.e. what :meth:`Operator.bind` returns:

====================  ===================================================================
``init``              ``init_fn(key, grid, capacity) -> (cells, length, ok)``
``fitness``           ``f(grid, cells, length, feasible) -> f32``
``selection``         ``select(key, fitness, active) -> int32[P]``
``crossover``         ``op(key, grid, c1, l1, c2, l2) -> (c1, l1, c2, l2, n_failed)``
``mutation``          ``op(key, grid, cells, length) -> (cells, length, failed)``
``simplify``          as ``mutation``, never lengthening a path
``post``              ``post(grid, cells, length) -> (cells, length)``
====================  ===================================================================

``crossover``, ``mutation`` and ``simplify`` operators reach a population through
:meth:`Operator.lift` (``lifted(key, grid, pop, probability) -> (pop, n_failed)``); an
operator that is itself a population-level composition (Zhu & Pan's half-and-half
operators) gives its own ``population`` lift. An operator of a user's own (a function
from outside jaxga) is bound with a check of what it returns against this contract, made
when it is traced: one line naming it, not a broadcasting error deep in the engine.
``"none"`` is registered in every family but ``init`` and ``fitness`` with ``fn=None``: the
stage does nothing.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from collections.abc import Callable, Mapping
from typing import Any

import jax.numpy as jnp

from jaxga.core.errors import ParameterError
from jaxga.core.fields import Field, shown_value
from jaxga.operators.lift import over_individuals_gated, over_pairs_gated

__all__ = [
    "FAMILIES",
    "FIELD_REPAIR",
    "NEEDS_FITNESS",
    "NEEDS_FRONT_FIELDS",
    "NEEDS_GUIDE",
    "NEVER_FAILS",
    "SHRINKING",
    "SPLICING",
    "TRAITS",
    "WAYPOINTS",
    "Binding",
    "MethodField",
    "Operator",
    "accepted_names",
    "as_traits",
    "canonical",
    "initialiser",
    "names",
    "operator",
    "operators",
    "readers",
    "register",
    "register_none",
    "register_operator",
    "schema_fields",
    "unregister",
]

FAMILIES = ("init", "fitness", "selection", "crossover", "mutation", "simplify", "post")
"""The operator families, in the order of a run (``<family>.method`` names one)."""

NEEDS_FITNESS = "needs_fitness"
"""The operator compares fitnesses: it is bound with ``fitness_fn``."""
FIELD_REPAIR = "field_repair"
"""``repair.fallback = "field"`` changes it: bound with ``field_repair=True`` then."""
WAYPOINTS = "waypoints"
"""It makes waypoint paths (segments checked by line of sight), not 8-connected ones: a
configuration that uses it evolves waypoint paths (AGACD)."""
SPLICING = "splicing"
"""A crossover whose children are a head of one parent and a tail of the other (it may
run on twice the narrow window, :func:`jaxga.operators.lift.spliced_pairs_map`)."""
NEVER_FAILS = "never_fails"
"""It never reports a failure (an initialiser: wherever a path exists)."""
SHRINKING = "shrinking"
"""It never lengthens a path (computed on the narrow window when the paths fit)."""
CONTINUOUS_ONLY = "continuous_only"
"""It needs 8-connected cell paths (not for configurations that evolve waypoint paths)."""
NEEDS_GUIDE = "needs_guide"
"""It steers by the problem's exact distance fields: the grid of a run that uses it
carries them (:func:`jaxga.operators.guide.with_guide`)."""

NEEDS_FRONT_FIELDS = "needs_front_fields"
"""It walks the clearance-weighted fields of a front
(:func:`jaxga.operators.guide.with_front_fields`): only with ``survival.method``."""

TRAITS = (NEEDS_FITNESS, FIELD_REPAIR, WAYPOINTS, SPLICING, NEVER_FAILS, SHRINKING,
          CONTINUOUS_ONLY, NEEDS_GUIDE, NEEDS_FRONT_FIELDS)
"""Every trait an operator may declare."""


@dataclasses.dataclass(frozen=True)
class Binding:
    """What an operator may read when the engine binds it: the static configuration
    (anything with ``get(key, default)``: a :class:`~jaxga.config.schema.Config` or an
    :class:`~jaxga.engine.Algorithm`), the dynamic parameters, the papers' iteration
    ``t`` (traced; 1 in the first generation, as AGACD eq. 27 and 29 and MPMGA eq. 17
    count) and the number of generations, the configured fitness function and
    whether the field repairs are on (``repair.fallback``)."""

    config: Any
    params: Mapping[str, Any]
    generation: Any = None
    generations: int = 0
    fitness_fn: Callable | None = None
    field_repair: bool = False


@dataclasses.dataclass(frozen=True)
class Operator:
    """One registered operator.

    Attributes:
        family: one of :data:`FAMILIES`.
        name: the name configurations use (``<family>.method = name``).
        fn: the operator function (the family's contract, module docstring); None for
            ``"none"``, the stage that does nothing.
        summary: one line: what it does, and the paper and section it comes from.
        params: the configuration keys this operator reads and no operator of another
            family does (``<family>.<key>``) with their :class:`~jaxga.core.fields.Field`.
            Several operators may declare one key with the same field.
        traits: a subset of :data:`TRAITS`.
        options: ``options(ctx) -> kwargs`` bound to ``fn`` besides those its traits
            bind (a tournament size, a temperature at generation ``t``, ...).
        population: ``population(ctx) -> lifted`` for an operator that is a
            population-level composition of others (default: the family's lift).
        aliases: former names, still accepted in configurations and preset files.
        required: keys of ``params`` that a configuration must set to use it.
        check: ``check(config)`` raises :class:`~jaxga.core.errors.ParameterError` for values
            of its keys that are each in range but together make no sense (run by
            :func:`jaxga.engine.check_combination` before anything is traced).
        prepare: ``prepare(config) -> {key: array}``: dynamic parameters it derives from
            the configuration (AGACD's Delphi ratios, with their default where the
            configuration leaves them out).
    """

    family: str
    name: str
    fn: Callable | None
    summary: str
    params: Mapping[str, Field] = dataclasses.field(default_factory=dict)
    traits: frozenset[str] = frozenset()
    options: Callable[[Binding], dict] | None = None
    population: Callable[[Binding], Callable] | None = None
    aliases: tuple[str, ...] = ()
    required: tuple[str, ...] = ()
    check: Callable[[Mapping], None] | None = None
    prepare: Callable[[Mapping], dict] | None = None

    def bind(self, ctx: Binding) -> Callable:
        """``fn`` with its static options bound for ``ctx``: ``fitness_fn`` (trait
        :data:`NEEDS_FITNESS`), ``field_repair=True`` (trait :data:`FIELD_REPAIR`, when
        ``ctx.field_repair``) and :attr:`options`. Unbound when there is nothing to bind
        (the function itself)."""
        if self.fn is None:
            raise ParameterError(f"{self.family}.method = 'none' has no function to bind")
        kwargs: dict[str, Any] = {}
        if NEEDS_FITNESS in self.traits:
            kwargs["fitness_fn"] = ctx.fitness_fn
        if FIELD_REPAIR in self.traits and ctx.field_repair:
            kwargs["field_repair"] = True
        if self.options is not None:
            kwargs.update(self.options(ctx))
        bound = functools.partial(self.fn, **kwargs) if kwargs else self.fn
        return bound if is_jaxgas(self.fn) else _checking_returns(self, bound)

    def lift(self, ctx: Binding) -> Callable:
        """The operator on a whole population, ``lifted(key, grid, pop, probability) ->
        (Population, n_failed)`` (crossover: a probability per pair; mutation and
        simplification: per individual): :attr:`population` if given, else the
        family's lift of :meth:`bind` (:func:`jaxga.operators.lift.over_pairs_gated`,
        dense: at the papers' crossover rates computing every pair and selecting is
        cheaper than gathering the crossed pairs, decision 004; splicing crossovers on
        twice the window when the parents fit it, decision 005;
        :func:`jaxga.operators.lift.over_individuals_gated`). The same results either way."""
        if self.population is not None:
            return self.population(ctx)
        op = self.bind(ctx)
        if self.family == "crossover":
            return over_pairs_gated(op, dense=True, splicing=SPLICING in self.traits)
        if self.family in ("mutation", "simplify"):
            return over_individuals_gated(op, shrinking=SHRINKING in self.traits)
        raise ParameterError(f"the {self.family} family has no population lift")


class MethodField(Field):
    """The field of ``<family>.method``: a registered name of the family, an alias
    giving its current name. Checked against the registry as it is when the check runs,
    so operators registered after import are accepted."""

    def __init__(self, family: str, doc: str) -> None:
        super().__init__(str, doc)
        object.__setattr__(self, "family", family)

    @property
    def names(self) -> tuple[str, ...]:
        """The accepted values: the family's names, then their aliases."""
        return accepted_names(self.family)

    def check(self, key: str, value: Any) -> Any:
        """The operator's current name (an alias replaced); :class:`ParameterError`
        naming ``key`` and the family's names otherwise."""
        value = super().check(key, value)
        if canonical(self.family, value) is None:
            raise ParameterError(f"{key} = {shown_value(value)} is not one of "
                                 f"{', '.join(names(self.family))} (your own: register it in "
                                 "this process)")
        return canonical(self.family, value)


_REGISTRY: dict[str, dict[str, Operator]] = {f: {} for f in FAMILIES}
_ALIASES: dict[str, dict[str, str]] = {f: {} for f in FAMILIES}
_VERSION = [0]


def register(op: Operator) -> Operator:
    """Add ``op`` to the registry and return it.

    Refuses (``ValueError``) an unknown family or trait, a name or alias already taken
    in the family, a parameter key outside the family's section (``<family>.``), one
    declared with another field by a registered operator, and a required key that is
    not a parameter.
    """
    if op.family not in FAMILIES:
        raise ValueError(f"unknown operator family {op.family!r} ({', '.join(FAMILIES)})")
    taken = set(_REGISTRY[op.family]) | set(_ALIASES[op.family])
    clash = [n for n in (op.name, *op.aliases) if n in taken]
    if clash:
        raise ValueError(f"{op.family} operator name(s) {', '.join(clash)} already registered")
    unknown = set(op.traits) - set(TRAITS)
    if unknown:
        raise ValueError(f"unknown trait(s) {', '.join(sorted(unknown))} ({', '.join(TRAITS)})")
    fields = schema_fields()
    if not isinstance(op.params, Mapping) or not all(
            isinstance(k, str) and isinstance(f, Field) for k, f in op.params.items()):
        raise ValueError(f"{op.family} operator {op.name!r}: params maps each key "
                         f"'{op.family}.<name>' to a jaxga.core.fields.Field (its type, "
                         f"range and default), got {shown_value(op.params)}")
    for key, field in op.params.items():
        if not key.startswith(f"{op.family}."):
            raise ValueError(f"{op.family} operator {op.name!r}: parameter {key!r} is not "
                             f"in the {op.family!r} section")
        if key in fields and fields[key] != field:
            raise ValueError(f"{key} is declared with another field by "
                             f"{', '.join(readers(key))}")
    missing = [k for k in op.required if k not in op.params]
    if missing:
        raise ValueError(f"required key(s) {', '.join(missing)} are not parameters of "
                         f"{op.name!r}")
    _REGISTRY[op.family][op.name] = op
    for alias in op.aliases:
        _ALIASES[op.family][alias] = op.name
    _VERSION[0] += 1
    return op


def register_operator(family: str, fn: Callable, name: str | None = None, *,
                      summary: str = "", replace: bool = False, **declaration: Any) -> Operator:
    """Register a function of your own as an operator of ``family`` and return it.

    ``fn`` has the family's signature (module docstring; an objective is a ``fitness``
    operator ``f(grid, cells, length, feasible) -> float32`` on one masked path, which the
    engine maps over the population). ``name`` (default ``fn.__name__``) is what
    ``<family>.method`` takes. ``replace``: replace an operator of that name registered
    from outside jaxga (a notebook cell run again); jaxga's own are never replaced.
    ``declaration``: the other fields of :class:`Operator` (``params``, ``traits``,
    ``options``, ...). Check it with :func:`jaxga.testing.check_operator`.
    """
    if not callable(fn):
        raise ValueError(f"a {family} operator is a function, got {shown_value(fn)}")
    name = name or getattr(fn, "__name__", None)
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"an operator needs a name that is an identifier, got {name!r}")
    current = canonical(family, name) if family in FAMILIES else None
    if current is not None and replace:
        old = _REGISTRY[family][current]
        if old.fn is None or is_jaxgas(old.fn):
            raise ValueError(f"{family} operator {name!r} is jaxga's own: choose another name")
        unregister(family, current)
    traits = as_traits(declaration.pop("traits", ()))
    if family in FAMILIES:
        _check_arguments(family, name, fn, binds=bool(
            declaration.get("options") or {NEEDS_FITNESS, FIELD_REPAIR} & traits))
    return register(Operator(family, name, fn, summary or (fn.__doc__ or name).strip()
                             .split("\n")[0], traits=traits, **declaration))


def as_traits(traits: Any) -> frozenset[str]:
    """An operator's traits as a frozenset: one trait may be given as its name (a string
    is not the set of its letters)."""
    return frozenset((traits,) if isinstance(traits, str) else traits)


_ARGUMENTS = {"init": "key, grid, capacity", "fitness": "grid, cells, length, feasible",
              "selection": "key, fitness, active",
              "crossover": "key, grid, c1, l1, c2, l2", "mutation": "key, grid, cells, length",
              "simplify": "key, grid, cells, length", "post": "grid, cells, length"}
"""The positional arguments the engine passes an operator of each family (the contract
of the module docstring)."""


def _check_arguments(family: str, name: str, fn: Callable, binds: bool) -> None:
    """Refuse, when it is registered, a function that cannot take its family's
    positional arguments (:data:`_ARGUMENTS`): too few parameters, or (where nothing
    binds keywords: no ``options``, no trait that binds one) more required ones than
    the engine passes. A function whose signature Python cannot read is let through."""
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return
    args = _ARGUMENTS[family]
    dummies = [None] * len(args.split(", "))
    try:
        sig.bind(*dummies) if not binds else sig.bind_partial(*dummies)
    except TypeError as e:
        raise ValueError(f"{family} operator {name!r} must take ({args}): {e}") from None


class ContractError(ParameterError):
    """A user's operator returned what its family's contract does not allow (raised when
    the operator is traced; :func:`jaxga.testing.check_operator` raises it as an
    ``AssertionError``)."""


def in_jaxga(module: str) -> bool:
    """Whether the module named ``module`` is jaxga or one of its modules."""
    return module == "jaxga" or module.startswith("jaxga.")


def is_jaxgas(fn: Callable | None) -> bool:
    """Whether ``fn`` is one of jaxga's own functions (not a user's operator)."""
    return in_jaxga(getattr(fn, "__module__", None) or "")


_DTYPES = {"i": {jnp.dtype(jnp.int32)}, "b": {jnp.dtype(bool)},
           "f": {jnp.dtype(jnp.float32)}, "ib": {jnp.dtype(jnp.int32), jnp.dtype(bool)}}
"""The dtypes each output kind of :func:`_returns` allows, exactly: cells of uint8 or
int16 would wrap a map's cell indices, a float16 fitness round others' ties."""


def _returns(family: str, args: tuple) -> tuple[str, list[tuple[tuple, str]]]:
    """A family's contract for what an operator returns on ``args`` (one individual or
    pair, as :meth:`Operator.bind` calls it): its words, and per output the shape and the
    dtypes it may have (:data:`_DTYPES`: ``"i"`` int32, ``"b"`` bool, ``"f"`` float32,
    ``"ib"`` int32 or bool)."""
    def shape(x: Any) -> tuple:
        return tuple(getattr(x, "shape", ()))

    if family == "init":
        try:
            cap = int(args[2])
        except TypeError:  # a traced capacity: the outputs' own length
            cap = None
        return (f"(cells int32[{'capacity' if cap is None else cap}], length int32, ok bool)",
                [((cap,), "i"), ((), "i"), ((), "b")])
    if family == "fitness":
        return "one float32 per path", [((), "f")]
    if family == "selection":
        n = shape(args[1])[:1]
        return f"int32{list(n)}: one parent index per individual", [(n, "i")]
    if family == "crossover":
        c1, c2 = shape(args[2]), shape(args[4])
        return (f"(cells int32{list(c1)}, length int32, cells int32{list(c2)}, length int32, "
                "n_failed int32)", [(c1, "i"), ((), "i"), (c2, "i"), ((), "i"), ((), "ib")])
    c = shape(args[1] if family == "post" else args[2])  # (key, grid, cells, length, *extra)
    if family == "post":
        return f"(cells int32{list(c)}, length int32)", [(c, "i"), ((), "i")]
    return (f"(cells int32{list(c)}, length int32, failed bool or int32)",
            [(c, "i"), ((), "i"), ((), "ib")])


def _checking_returns(op: Operator, bound: Callable) -> Callable:
    """``bound`` refusing, in one :class:`ContractError` line when it is traced, outputs
    of another structure, shape or kind of dtype than its family's contract (module
    docstring): a user's operator of the wrong shape fails there, naming itself, not
    deep in the engine with JAX's broadcasting error."""
    def checked(*args: Any) -> Any:
        out = bound(*args)
        words, want = _returns(op.family, args)
        got = list(out) if isinstance(out, (tuple, list)) else [out]
        arrays = []
        for x in got:
            try:
                arrays.append(jnp.asarray(x))
            except (TypeError, ValueError):  # None, a string: not an array nor a number
                arrays.append(None)
        if any(a is None for a in arrays):
            shown = ", ".join(type(x).__name__ if a is None else f"{a.dtype}{list(a.shape)}"
                              for x, a in zip(got, arrays))
            raise ContractError(f"{op.family} operator {op.name!r} must return {words}, "
                                f"got ({shown})")
        dtypes = [a.dtype for a in arrays]
        shapes = [tuple(a.shape) for a in arrays]
        if len(got) != len(want) or any(
                len(s) != len(ws) or any(w is not None and a != w for a, w in zip(s, ws))
                or d not in _DTYPES[wk] for s, d, (ws, wk) in zip(shapes, dtypes, want)):
            shown = ", ".join(f"{a.dtype}{list(a.shape)}" for a in arrays)
            raise ContractError(f"{op.family} operator {op.name!r} must return {words}, "
                                f"got ({shown})")
        return out

    return functools.wraps(bound)(checked) if hasattr(bound, "__name__") else checked


def unregister(family: str, name: str) -> None:
    """Remove an operator (and its aliases) from the registry; for tests and notebooks
    that register an operator of their own for a while."""
    op = _REGISTRY[family].pop(name)
    for alias in op.aliases:
        _ALIASES[family].pop(alias, None)
    _VERSION[0] += 1


def version() -> int:
    """A number that changes whenever the registry does (for caches of what it says)."""
    return _VERSION[0]


def canonical(family: str, name: str) -> str | None:
    """The registered name that ``name`` (a name or an alias) stands for, or None."""
    if name in _REGISTRY[family]:
        return name
    return _ALIASES[family].get(name)


def operator(family: str, name: str) -> Operator:
    """The registered operator ``name`` (or alias) of ``family``; a
    :class:`ParameterError` listing the family's names if there is none."""
    if family not in _REGISTRY:
        raise ParameterError(f"unknown operator family {family!r} ({', '.join(FAMILIES)})")
    found = canonical(family, name) if isinstance(name, str) else None
    if found is None:
        raise ParameterError(f"unknown {family} operator {name!r}: expected one of "
                             f"{', '.join(names(family))}")
    return _REGISTRY[family][found]


def operators(family: str | None = None) -> tuple[Operator, ...]:
    """The registered operators of ``family`` (all families: None), in registration
    order."""
    fams = FAMILIES if family is None else (family,)
    return tuple(op for f in fams for op in _REGISTRY[f].values())


def names(family: str) -> tuple[str, ...]:
    """The registered names of ``family``, in registration order."""
    return tuple(_REGISTRY[family])


def accepted_names(family: str) -> tuple[str, ...]:
    """The names a configuration may give for ``family``: its names, then the aliases."""
    return (*_REGISTRY[family], *_ALIASES[family])


@functools.lru_cache(maxsize=8)
def _fields(_version: int) -> dict[str, Field]:
    out: dict[str, Field] = {}
    for op in operators():
        out.update(op.params)
    return out


def schema_fields() -> dict[str, Field]:
    """Every key some operator declares, with its field (the operators' part of
    :data:`jaxga.config.schema.SCHEMA`)."""
    return _fields(version())


def readers(key: str) -> tuple[str, ...]:
    """The names of the operators that declare ``key``."""
    return tuple(op.name for op in operators(key.split(".", 1)[0]) if key in op.params)


def register_none(family: str, what: str) -> Operator:
    """Register family ``family``'s ``"none"``: the stage that does nothing (``what``
    says so in the listings)."""
    return register(Operator(family, "none", None, what))


def initialiser(name_or_fn: str | Callable) -> Callable:
    """An initialiser ``(key, grid, capacity) -> (cells, length, ok)`` by its registered
    name (family ``init``; an old name is accepted), or the callable itself."""
    if callable(name_or_fn):
        return name_or_fn
    if isinstance(name_or_fn, str) and canonical("init", name_or_fn) is not None:
        return operator("init", name_or_fn).fn
    raise ParameterError(
        f"unknown initialiser {name_or_fn!r}: expected a callable or one of "
        f"{', '.join(names('init'))}")
