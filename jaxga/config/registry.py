"""The operator registry: every operator of every family, declared once.

An :class:`Operator` says which family it belongs to, which function it is, which
configuration keys it alone reads (:class:`jaxga.config.fields.Field`: type, range, help,
default), its traits, and how the engine binds it to a configuration. Everything that
needs the list of operators reads it from here:

* the configuration's allowed names and keys (:data:`jaxga.config.schema.SCHEMA`; old names
  still accepted through each operator's ``aliases``);
* the engine's dispatch (:mod:`jaxga.engine`: ``operator(family, name).lift(ctx)``, no
  chains of ``if method == ...``);
* the rule that refuses keys no stage reads (:func:`jaxga.engine.unread_keys`);
* ``jaxga operators`` (the command line's list, with parameters and traits);
* the contract tests (``tests/config/test_registry.py``), parametrised over the registry.

Adding an operator is one function plus one :func:`register_operator` call, from any
module (docs, "the pure core"); :func:`jaxga.testing.check_operator` runs its family's
contract on it. The engine's contract per family, i.e. what :meth:`Operator.bind` returns:

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
operators) gives its own ``population`` lift. ``"none"`` is registered in every family
but ``init`` and ``fitness`` with ``fn=None``: the stage does nothing.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from collections.abc import Callable, Mapping
from typing import Any

import jax
import jax.numpy as jnp

from jaxga.config.fields import POS, Field, P
from jaxga.core import objectives
from jaxga.core.errors import ParameterError
from jaxga.operators import crossover as cx
from jaxga.operators import init as ini
from jaxga.operators import mutation as mu
from jaxga.operators import postprocess as post
from jaxga.operators import schedules
from jaxga.operators import selection as sel
from jaxga.operators.lift import over_individuals_gated, over_pairs_gated

__all__ = [
    "FAMILIES",
    "FIELD_REPAIR",
    "NEEDS_FITNESS",
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
    "canonical",
    "initialiser",
    "names",
    "objective_keywords",
    "operator",
    "operators",
    "readers",
    "register",
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

TRAITS = (NEEDS_FITNESS, FIELD_REPAIR, WAYPOINTS, SPLICING, NEVER_FAILS, SHRINKING,
          CONTINUOUS_ONLY, NEEDS_GUIDE)
"""Every trait an operator may declare."""


@dataclasses.dataclass(frozen=True)
class Binding:
    """What an operator may read when the engine binds it: the static configuration
    (anything with ``get(key, default)``: a :class:`~jaxga.config.schema.Config` or an
    :class:`~jaxga.engine.Algorithm`), the dynamic parameters, the generation ``t``
    (traced) and the number of generations, the configured fitness function and
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
            family does (``<family>.<key>``) with their :class:`~jaxga.config.fields.Field`.
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
        return functools.partial(self.fn, **kwargs) if kwargs else self.fn

    def lift(self, ctx: Binding) -> Callable:
        """The operator on a whole population, ``lifted(key, grid, pop, probability) ->
        (Population, n_failed)`` (crossover: a probability per pair; mutation and
        simplification: per individual): :attr:`population` if given, else the
        family's lift of :meth:`bind` (:func:`jaxga.operators.crossover.crossover_population`,
        dense: at the papers' crossover rates computing every pair and selecting is
        cheaper than gathering the crossed pairs, decision 004; splicing crossovers on
        twice the window when the parents fit it, decision 005;
        :func:`jaxga.operators.lift.over_individuals_gated`). The same results either way."""
        if self.population is not None:
            return self.population(ctx)
        op = self.bind(ctx)
        if self.family == "crossover":
            return cx.crossover_population(op, dense=True, splicing=SPLICING in self.traits)
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
            raise ParameterError(f"{key} = {value!r} is not one of "
                                 f"{', '.join(names(self.family))}")
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
    name = name or getattr(fn, "__name__", None)
    if not name or not name.isidentifier():
        raise ValueError(f"an operator needs a name that is an identifier, got {name!r}")
    current = canonical(family, name) if family in FAMILIES else None
    if current is not None and replace:
        old = _REGISTRY[family][current]
        if old.fn is None or (getattr(old.fn, "__module__", None) or "").startswith("jaxga."):
            raise ValueError(f"{family} operator {name!r} is jaxga's own: choose another name")
        unregister(family, current)
    traits = frozenset(declaration.pop("traits", ()))
    return register(Operator(family, name, fn, summary or (fn.__doc__ or name).strip()
                             .split("\n")[0], traits=traits, **declaration))


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


# ------------------------------------------------------------------- registrations
def _none(family: str, what: str) -> Operator:
    return register(Operator(family, "none", None, what))


# init
register(Operator("init", "random_walk", ini.random_walk,
                  "uniformly random self-avoiding walk from start to goal (Zhu & Pan 4.1; "
                  "the plain GA)"))
register(Operator("init", "median_insertion", ini.median_insertion,
                  "random free cell per row, connected by median insertion (IMGA 4.1)",
                  traits=frozenset({FIELD_REPAIR})))
register(Operator("init", "intermittent_connect", ini.intermittent_connect,
                  "barrier-free intermittent path + connection + deletion (MPMGA 4.2)",
                  traits=frozenset({FIELD_REPAIR})))
register(Operator("init", "greedy_random_target", ini.greedy_random_target,
                  "greedy walk towards the goal or a random target (AGACD 4.3)"))
register(Operator("init", "directional", ini.directional,
                  "walk with directional guidance, eq. 5 weights (Zhu & Pan 4.1, "
                  "Algorithm 1)"))
register(Operator(
    "init", "field_walk", ini.field_walk,
    "random detour down the exact distance fields; cannot fail where a path exists "
    "(jaxga; decision notes)",
    params={
        "init.slack": Field(float, low=0.0, high=100.0, dynamic=True, default=0.5,
                            doc="field_walk: paths up to (1 + slack) x the optimal length"),
        "init.temperature": Field(float, low=0.0, high=1000.0, dynamic=True, default=1.0,
                                  doc="field_walk: preference for short detours, "
                                      "exp(-excess / temperature); 0 = optimal moves only"),
    },
    traits=frozenset({NEVER_FAILS, NEEDS_GUIDE}),
    options=lambda ctx: {"slack": ctx.params["init.slack"],
                         "temperature": ctx.params["init.temperature"]},
))


# fitness: the objective's keyword arguments are its dynamic scalar parameters
def objective_keywords(op: Operator) -> tuple[str, ...]:
    """The keys of fitness operator ``op`` that are keyword arguments of its objective in
    :mod:`jaxga.core.objectives`: its dynamic scalar (float) keys. AGACD's Delphi ratios
    (a list) are not: the objective takes the weights computed from them."""
    return tuple(key for key, field in op.params.items()
                 if field.dynamic and field.kind is float)


def _objective_options(op_name: str) -> Callable[[Binding], dict]:
    def options(ctx: Binding) -> dict:
        op = operator("fitness", op_name)
        kwargs = {key.split(".", 1)[1]: ctx.params[key] for key in objective_keywords(op)
                  if key in ctx.params}
        if op_name == "agacd":  # AGACD eq. 21-25, from the traced ratios
            kwargs["weights"] = objectives.delphi_weights(
                ctx.params["fitness.importance_ratios"])
        return kwargs

    return options


def objective_default(method: str, name: str) -> float:
    """The default of weight ``name`` of fitness ``method``: its objective's keyword
    default in :mod:`jaxga.core.objectives` (the paper's value where it gives one;
    docs/presets.md)."""
    return float(inspect.signature(getattr(objectives, method)).parameters[name].default)


def fitness_weight(config: Mapping, method: str, name: str) -> float:
    """Weight ``name`` as the objective sees it: the configuration's, else its default."""
    value = config.get(f"fitness.{name}")
    return objective_default(method, name) if value is None else value


def _weights_not_all_zero(method: str, names: tuple[str, ...]) -> Callable[[Mapping], None]:
    def check(config: Mapping) -> None:
        if all(fitness_weight(config, method, k) == 0 for k in names):
            raise ParameterError(f"{' and '.join('fitness.' + k for k in names)} are all 0: "
                                 "every path would have the same fitness (IMGA eq. 4, MPMGA "
                                 "eq. 3, Zhu & Pan eq. 6)")
    return check


def _floor_positive(method: str, config: Mapping) -> None:
    floor = fitness_weight(config, method, "smoothness_floor")
    if not floor > 0:
        raise ParameterError(f"fitness.smoothness_floor must be > 0 (it replaces the zero "
                             f"smoothness of a straight path as a divisor), got {floor}")


AGACD_OBJECTIVES = 3
"""AGACD's fitness combines length, smoothness and safety (eq. 18-25): 2 Delphi ratios."""


def _check_agacd(config: Mapping) -> None:
    ratios = config.get("fitness.importance_ratios")
    if ratios is not None and len(ratios) != AGACD_OBJECTIVES - 1:
        raise ParameterError(
            f"fitness.importance_ratios needs {AGACD_OBJECTIVES - 1} entries for AGACD's "
            f"{AGACD_OBJECTIVES} objectives (length, smoothness, safety), got {list(ratios)}")
    _floor_positive("agacd", config)


AGACD_RATIOS = (1.2, 1.4)
"""AGACD's Delphi importance ratios I1, I2 (section 4.4, Table 1): the default of
``fitness.importance_ratios``."""


def _agacd_ratios(config: Mapping) -> dict:
    """AGACD eq. 21-25: its importance ratios as a traced ``float32[2]`` parameter (default
    :data:`AGACD_RATIOS`); the objective computes the Delphi weights from them
    (:func:`jaxga.core.objectives.delphi_weights`), so that a sweep over the ratios is
    one compiled call."""
    ratios = config.get("fitness.importance_ratios", AGACD_RATIOS)
    return {"fitness.importance_ratios": jnp.asarray(ratios, jnp.float32)}


def _check_mpmga(config: Mapping) -> None:
    _weights_not_all_zero("mpmga", ("alpha", "beta"))(config)
    w = functools.partial(fitness_weight, config, "mpmga")
    if w("alpha") == 0 and w("beta") * w("c") == 0:
        raise ParameterError(
            "fitness.alpha = 0 with fitness.beta * fitness.c = 0: every path would have "
            "fitness 0 (MPMGA eq. 3: alpha / length + beta * c / smoothness), which the "
            "engine reads as infeasible")
    _floor_positive("mpmga", config)


def _check_zhang(config: Mapping) -> None:
    for key in ("fitness.v", "fitness.v_t"):
        if config.get(key) is not None and not config[key] > 0:
            raise ParameterError(f"{key} is a speed and must be > 0 (Zhang eq. 2 divides "
                                 f"by it), got {config[key]}")
    v, v_t = (fitness_weight(config, "iga_zhang", k) for k in ("v", "v_t"))
    if v_t > v:
        raise ParameterError(
            f"fitness.v_t = {v_t} is above fitness.v = {v}: a turn would take less time "
            "than going straight, so the time lost per turn (Zhang eq. 2, k = (v - v_t) "
            "pi r / (2 v v_t)) would be negative; the turning speed must not exceed v")


_FIT_A = Field(**POS, doc="IMGA length weight a / Zhang turn weight a")
_FIT_C = Field(**POS, doc="IMGA energy weight c / MPMGA smoothness constant c")
_FLOOR = Field(**POS, doc="floor of a zero smoothness (straight path)")
_FITNESS_CHECKS = {"imga": _weights_not_all_zero("imga", ("a", "b", "c")),
                   "agacd": _check_agacd, "mpmga": _check_mpmga,
                   "iga_zhu": _weights_not_all_zero("iga_zhu", ("omega", "c1", "c2", "c3")),
                   "iga_zhang": _check_zhang}
_FITNESS = {
    "sga": ("1 / length (the papers' basic GA objective)", {}),
    "imga": ("1 / (a L + b S + c E): length, safety, energy (IMGA eq. 4)", {
        "fitness.a": _FIT_A, "fitness.b": Field(**POS, doc="IMGA safety weight b"),
        "fitness.c": _FIT_C}),
    "agacd": ("Delphi-weighted length, smoothness and safety (AGACD eq. 7-8, 18-25)", {
        "fitness.smoothness_floor": _FLOOR,
        "fitness.importance_ratios": Field(list, "AGACD Delphi importance ratios I1, I2 "
                                           "(eq. 21-25): one per objective but the last",
                                           dynamic=True)}),
    "mpmga": ("alpha / length + beta c / smoothness (MPMGA eq. 3-5)", {
        "fitness.alpha": Field(**POS, doc="MPMGA length weight alpha"),
        "fitness.beta": Field(**POS, doc="MPMGA smoothness weight beta"),
        "fitness.c": _FIT_C, "fitness.smoothness_floor": _FLOOR}),
    "iga_zhu": ("1 / (omega length + (1 - omega) turn penalties) (Zhu & Pan eq. 6)", {
        "fitness.omega": Field(**P, doc="Zhu length weight omega"),
        "fitness.c1": Field(**POS, doc="Zhu penalty of a 45 degree turn"),
        "fitness.c2": Field(**POS, doc="Zhu penalty of a 90 degree turn"),
        "fitness.c3": Field(**POS, doc="Zhu penalty of a 135 degree turn")}),
    "iga_zhang": ("1 / (length + time lost in turns) (Zhang eq. 2)", {
        "fitness.a": _FIT_A, "fitness.v": Field(**POS, doc="Zhang straight speed v"),
        "fitness.v_t": Field(**POS, doc="Zhang turning speed v_t"),
        "fitness.r": Field(**POS, doc="Zhang turning radius r")}),
}
for _name, (_summary, _params) in _FITNESS.items():
    register(Operator("fitness", _name, getattr(objectives, _name), _summary, params=_params,
                      options=_objective_options(_name), check=_FITNESS_CHECKS.get(_name),
                      prepare=_agacd_ratios if _name == "agacd" else None))

# selection
register(Operator("selection", "roulette", sel.roulette,
                  "fitness-proportionate roulette (AGACD 4.5, MPMGA 5.2)"))
register(Operator("selection", "roulette_elite", sel.roulette_elite,
                  "roulette, the previous best replaces the worst (AGACD 4.5, Zhu & Pan 4.3)"))
register(Operator("selection", "layered_thirds", sel.layered_thirds,
                  "top third twice, middle third once (IMGA 4.3.1)"))
register(Operator("selection", "stratified", sel.stratified,
                  "layers A > B > C > D, D dropped, refill by roulette (Zhang eq. 1)"))
register(Operator(
    "selection", "tournament", sel.tournament, "the best of k uniformly drawn individuals",
    params={"selection.tournament_size": Field(int, "tournament size k", low=1, high=1000,
                                               default=2)},
    options=lambda ctx: {"k": int(ctx.config.get("selection.tournament_size"))},
))
register(Operator("selection", "shuffle", sel.shuffle,
                  "no selection pressure, random pairs: each individual once (MPMGA 4.4)"))
_none("selection", "no selection: individuals keep their slots (fixed pairs 2k, 2k + 1)")


# crossover
def _half_common_point_half_column(ctx: Binding) -> Callable:
    """Zhu & Pan 4.4 / 4.7 step 3: half the pairs through the common-point crossover,
    half through the column (non-common point) crossover, drawn per generation."""
    lifted = over_pairs_gated(operator("crossover", "common_point").bind(ctx),
                              alternative=operator("crossover", "column").bind(ctx))

    def run(key, grid, pop, pc):
        k_half, key = jax.random.split(key)
        return lifted(key, grid, pop, pc, mu.split_half(k_half, pop.size // 2))

    return run


register(Operator("crossover", "common_point", cx.common_point,
                  "single point at a cell both parents share (IMGA 4.3.2, Zhu & Pan 4.4)",
                  traits=frozenset({SPLICING})))
register(Operator("crossover", "cut_and_check", cx.cut_and_check,
                  "single point, child kept only if its junction is collision-free "
                  "(AGACD 4.6)", traits=frozenset({WAYPOINTS})))
register(Operator("crossover", "heterologous", cx.heterologous,
                  "single point between different cells, child kept only if fitter "
                  "(MPMGA 4.5)", traits=frozenset({NEEDS_FITNESS})))
register(Operator("crossover", "column", cx.column,
                  "non-common point: join the parents across a column (Zhu & Pan 4.4)",
                  traits=frozenset({NEEDS_FITNESS, FIELD_REPAIR})))
register(Operator("crossover", "common_point_or_column", None,
                  "half the pairs common_point, half column (Zhu & Pan 4.4, 4.7 step 3)",
                  traits=frozenset({NEEDS_FITNESS, FIELD_REPAIR}),
                  population=_half_common_point_half_column, aliases=("zhu_mixed",)))
_none("crossover", "no crossover")


# mutation
def _half_replace_point_half_regrow(ctx: Binding) -> Callable:
    """Zhu & Pan 4.5 / 4.7 step 3: half the individuals through the one-point mutation
    (``replace_point``), half through the range mutation (``regrow_segment``)."""
    lifted = over_individuals_gated(operator("mutation", "replace_point").bind(ctx),
                                    alternative=operator("mutation", "regrow_segment").bind(ctx))

    def run(key, grid, pop, pm):
        k_half, key = jax.random.split(key)
        return lifted(key, grid, pop, pm, mu.split_half(k_half, pop.size))

    return run


def _check_annealing(config: Mapping) -> None:
    if not config["mutation.temperature_w"] > 0:
        raise ParameterError("mutation.temperature_w must be in (0, 1] (MPMGA eq. 17: "
                             f"T = c1 * w**t), got {config['mutation.temperature_w']}")


def _annealing_temperature(ctx: Binding) -> dict:
    """MPMGA eq. 17: ``T = c1 * w**t`` at generation ``t`` (``c1`` and ``w`` traced)."""
    schedule = schedules.mpmga_temperature(ctx.params["mutation.temperature_c1"],
                                           ctx.params["mutation.temperature_w"])
    return {"temperature": schedule(ctx.generation)}


register(Operator("mutation", "neighbour_point", mu.neighbour_point,
                  "move a node to a free 8-neighbour and reconnect (IMGA 4.3.3)"))
register(Operator("mutation", "replace_point", mu.replace_point,
                  "replace a node by another cell adjacent to both its neighbours "
                  "(Zhu & Pan 4.5 one-point mutation)", aliases=("one_point",)))
register(Operator("mutation", "regrow_segment", mu.regrow_segment,
                  "delete the path between two nodes and regrow it by Algorithm 1's walk "
                  "(Zhu & Pan 4.5 range mutation)", traits=frozenset({FIELD_REPAIR}),
                  aliases=("range",)))
register(Operator(
    "mutation", "segment_sa", mu.segment_sa,
    "delete a segment, reconnect, accept by simulated annealing (MPMGA 4.6, eq. 15-17)",
    params={
        "mutation.temperature_c1": Field(**POS, doc="MPMGA annealing T = c1 * w**t: c1"),
        "mutation.temperature_w": Field(float, low=0.0, high=1.0, dynamic=True,
                                        doc="MPMGA annealing T = c1 * w**t: decay rate w "
                                            "in (0, 1]"),
    },
    traits=frozenset({NEEDS_FITNESS, FIELD_REPAIR}), options=_annealing_temperature,
    required=("mutation.temperature_c1", "mutation.temperature_w"), check=_check_annealing,
))
register(Operator(
    "mutation", "point_checked", mu.point_checked,
    "move a node within a radius, kept only if collision-free (AGACD 4.7)",
    params={"mutation.radius": Field(int, "AGACD point mutation radius in cells", low=1,
                                     high=10_000)},
    traits=frozenset({WAYPOINTS}),
    options=lambda ctx: {"radius": int(ctx.config.get("mutation.radius", 2))},
))
register(Operator("mutation", "replace_point_or_regrow", None,
                  "half replace_point, half regrow_segment (Zhu & Pan 4.5, 4.7 step 3)",
                  traits=frozenset({FIELD_REPAIR}), population=_half_replace_point_half_regrow,
                  aliases=("zhu_mixed",)))
register(Operator("mutation", "delete_corner", mu.delete_corner,
                  "delete the node at one random position when it is a 45, 90 or 135 degree "
                  "corner (Zhang eq. 3-5)", traits=frozenset({SHRINKING, WAYPOINTS})))
_none("mutation", "no mutation")


# simplify (Zhu & Pan 4.6): per generation, with simplify.probability
def simplify_adjacent_step(key: jax.Array, grid: Any, cells: jax.Array,
                           length: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """:func:`jaxga.operators.postprocess.simplify_adjacent` (Zhu & Pan 4.6) as a per-generation
    simplification: a path with nothing to simplify is returned unchanged, which is not
    a failure (``failed`` always False)."""
    out, out_len, _ = post.simplify_adjacent(key, grid, cells, length)
    return out, out_len, jnp.bool_(False)


register(Operator("simplify", "simplify_adjacent", simplify_adjacent_step,
                  "replace two-step detours by direct moves (Zhu & Pan 4.6)",
                  traits=frozenset({SHRINKING, NEVER_FAILS})))
register(Operator("simplify", "cut_corners", mu.cut_corners,
                  "delete the middle node of a corner whose ends are adjacent (Zhang "
                  "eq. 3-4)", traits=frozenset({SHRINKING, NEVER_FAILS}),
                  aliases=("corner_cut",)))
_none("simplify", "no simplification")

# post (IMGA 4.5, AGACD 4.8, MPMGA 4.7): the final best path
register(Operator("post", "shortcut_greedy", post.shortcut_greedy,
                  "delete nodes while the shortcut is collision-free (IMGA 4.5, AGACD 4.8, "
                  "MPMGA 4.7)"))
register(Operator("post", "shortcut_optimal", post.shortcut_optimal,
                  "the shortest any-angle path through the path's nodes (jaxga)",
                  traits=frozenset({CONTINUOUS_ONLY})))
_none("post", "no post-optimisation (loops removed)")


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
