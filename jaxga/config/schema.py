"""Algorithm configurations: a validated, flat ``section.key -> value`` mapping.

A configuration says which operator fills each stage of the GA and with which
parameters (docs/operators.md). Presets (``presets/*.toml``, one per paper) are configurations;
a user TOML file or ``--set key=value`` overrides any field. Every key is declared in
:data:`SCHEMA` with its type, allowed values or range and a one-line meaning: unknown
keys and out-of-range values are rejected with a message that names the key.

Keys marked *dynamic* never change array shapes (probabilities, weights, temperatures,
integer settings such as ``init.max_tries``, ``termination.stagnation`` and
``islands.interval``, the per-island rates, AGACD's Delphi ratios and whether
``init.fallback`` is on): they are traced values of the parameter pytree
(:func:`jaxga.engine.default_params`), so a sweep over them is one compiled call
(``jax.vmap``). The others are *static*: they choose operators or sizes and are
compiled in. :data:`SWEPT_STATIC` names the one static key a sweep may still vary.
"""

from __future__ import annotations

import dataclasses
import re
import sys
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from jaxga.core.errors import ParameterError
from jaxga.core.fields import Field, P, finite_number, python_scalar, shown_value
from jaxga.core.grid import CORNER_RULES
from jaxga.core.robot_objectives import ROBOT_OBJECTIVES
from jaxga.operators import registry
from jaxga.operators.registry import MethodField

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["DEFAULTS", "REQUIRED", "SCHEMA", "SWEPT_STATIC", "Config", "Field", "dotted", "flatten",
           "load_toml", "normalised", "parse_value", "python_scalar", "sweepable"]

FALLBACKS = (*(op.name for op in registry.operators("init")
               if registry.NEVER_FAILS in op.traits), "none")
"""``init.fallback``: an initialiser that cannot fail where a path exists, or none."""
REPAIR_FALLBACKS = ("none", "field")
TOPOLOGIES = ("none", "ring", "star", "full", "mpmga")
MAP_RULE = "map"
"""``map.corner_rule = "map"``: the map's own corner rule (the default)."""
MIGRATION_TIMINGS = ("after_variation", "before_variation")
SURVIVALS = ("nsga2",)
"""``survival.method``: the multi-objective survival stages."""

COMMON_FIELDS: dict[str, Field] = {
    "name": Field(str, "preset name"),
    "paper": Field(str, "the paper the preset reproduces"),
    "description": Field(str, "one line on the algorithm"),
    "map.corner_rule": Field(str, "corner rule (decision 027): 'map' = the map's own "
                             "(free on the papers' classic 20 x 20 maps, strict elsewhere; "
                             "jaxga.maps.default_corner_rule), or one rule for this "
                             "configuration", choices=(MAP_RULE, *CORNER_RULES)),
    "population.size": Field(int, "individuals per population (per island)", low=2, high=100_000),
    "population.capacity": Field(int, "path capacity L: cells a path can hold (not a "
                                 "number of individuals); 0 = automatic from the map size",
                                 low=0, high=1_000_000),
    "population.capacity_factor": Field(float, "automatic path capacity (population.capacity "
                                        "= 0): this many times the cells of an optimal path; "
                                        "a size class's capacity scales with it",
                                        low=1.0, high=100.0),
    "generations": Field(int, "generations per run", low=1, high=1_000_000),
    "init.method": MethodField("init", "initialiser (see jaxga operators)"),
    "init.max_tries": Field(int, "attempts per individual of init.method, on average (the "
                            "bound of its rounds of redraws)", low=1, high=10_000,
                            dynamic=True),
    "init.unique": Field(bool, "reject an initial individual identical to one already "
                         "accepted, as a failed draw (IMGA 4.1 (iii): M non-repeating "
                         "chromosomes; the fallback's individuals are not checked)"),
    "init.fallback": Field(str, "initialiser that fills the slots init.method left empty "
                           "after init.max_tries attempts ('none': the paper's initialiser "
                           "alone; compiled in whenever init.method can fail, switched on "
                           "and off by a traced flag)", choices=FALLBACKS, dynamic=True),
    "repair.fallback": Field(str, "'field': a repair that does not close (median insertion "
                             "of the initialisers, the column crossover and the segment "
                             "mutation; the range mutation's walk) connects down the exact "
                             "distance field instead of failing ('none': the papers' "
                             "failure)", choices=REPAIR_FALLBACKS),
    "fitness.method": MethodField("fitness", "fitness combiner (see jaxga operators)"),
    "fitness.window": Field(bool, "evaluate grid paths on a narrow window when all fit "
                            "(same results; faster where paths stay short, one more "
                            "program to compile; decision 005)"),
    "selection.method": MethodField("selection", "selection (see jaxga operators)"),
    "crossover.method": MethodField("crossover", "crossover (see jaxga operators)"),
    "crossover.probability": Field(**P, doc="crossover probability pc per pair"),
    "crossover.adaptive": Field(bool, "AGACD adaptive pc (eq. 26-27)"),
    "crossover.pc_low": Field(**P, doc="AGACD pc_low"),
    "crossover.pc_high": Field(**P, doc="AGACD pc_high"),
    "mutation.method": MethodField("mutation", "mutation (see jaxga operators)"),
    "mutation.probability": Field(**P, doc="mutation probability pm per individual"),
    "mutation.adaptive": Field(bool, "AGACD adaptive pm (eq. 28-29)"),
    "mutation.pm_low": Field(**P, doc="AGACD pm_low"),
    "mutation.pm_high": Field(**P, doc="AGACD pm_high"),
    "simplify.method": MethodField("simplify", "per-generation simplification (Zhu & Pan 4.6)"),
    "simplify.probability": Field(**P, doc="simplification probability ps per individual"),
    "post.method": MethodField("post", "post-optimisation of the final best (IMGA 4.5)"),
    "termination.stagnation": Field(int, "IMGA 4.4: stop after K generations without "
                                    "improvement; 0 = never", low=0, high=1_000_000,
                                    dynamic=True),
    "survival.method": Field(str, "who survives a generation: 'nsga2' keeps a front of "
                             "survival.objectives of parents and offspring together (Deb et "
                             "al. 2002; decision 045); left out: the offspring replace their "
                             "parents (the papers' GAs)", choices=SURVIVALS),
    "survival.objectives": Field(list, "the robot objectives a front minimises (2 or 3 of "
                                 + ", ".join(ROBOT_OBJECTIVES) + "; clearance maximised); "
                                 "default length and clearance"),
    "survival.band": Field(float, "the band around the obstacles, in cells, that the "
                           "clearance-weighted fields and the intrusion objective count; "
                           "0 = the problem's exact maximin clearance", low=0.0, high=1e6),
    "islands.count": Field(int, "number of islands (1 = single population)", low=1, high=1024),
    "islands.topology": Field(str, "migration topology (mpmga: MPMGA 4.4)", choices=TOPOLOGIES),
    "islands.interval": Field(int, "generations between migrations", low=1, high=1_000_000,
                              dynamic=True),
    "islands.migrants": Field(int, "migrants per island and migration", low=0, high=100_000),
    "islands.timing": Field(str, "migration after the generation's variation (jaxga's default) or "
                            "before it (MPMGA Fig. 1)", choices=MIGRATION_TIMINGS),
    "islands.crossover_probabilities": Field(list, "per-island pc (MPMGA A, B, C): one per "
                                             "island (islands.count)", dynamic=True),
    "islands.mutation_probabilities": Field(list, "per-island pm (MPMGA A, B, C): one per "
                                            "island (islands.count)", dynamic=True),
}

COMMON_DEFAULTS: dict[str, Any] = {
    "description": "",
    "map.corner_rule": "map",
    "population.capacity": 0,
    "population.capacity_factor": 3.0,
    "init.max_tries": 20,
    "init.unique": False,
    "init.fallback": "field_walk",
    "repair.fallback": "none",
    "fitness.window": True,
    "crossover.adaptive": False,
    "mutation.adaptive": False,
    "simplify.method": "none",
    "simplify.probability": 0.0,
    "post.method": "none",
    "termination.stagnation": 0,
    "islands.count": 1,
    "islands.topology": "none",
    "islands.interval": 1,
    "islands.migrants": 0,
    "islands.timing": "after_variation",
}



class _WithOperators(Mapping):
    """A read-only mapping: ``common`` and what the registered operators add
    (``part(field)`` of each of their keys, None left out), rebuilt when the registry
    changes, so operators registered after import are part of it."""

    def __init__(self, common: dict[str, Any], part) -> None:
        self._common, self._part, self._version, self._merged = common, part, -1, {}

    def _get(self) -> dict[str, Any]:
        if self._version != registry.version():
            merged = dict(self._common)
            for key, field in registry.schema_fields().items():
                value = self._part(field)
                if value is not None:
                    merged[key] = value
            self._merged, self._version = merged, registry.version()
        return self._merged

    def __getitem__(self, key: str) -> Any:
        return self._get()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())

    def __repr__(self) -> str:
        return repr(self._get())


SCHEMA: Mapping[str, Field] = _WithOperators(COMMON_FIELDS, lambda field: field)
"""Every configuration key with its :class:`~jaxga.core.fields.Field`: the keys of the run,
the families' and the islands' (:data:`COMMON_FIELDS`) and the keys the registered
operators declare (:func:`jaxga.operators.registry.schema_fields`)."""

DEFAULTS: Mapping[str, Any] = _WithOperators(COMMON_DEFAULTS, lambda field: field.default)
"""The value of every key a configuration may leave out: :data:`COMMON_DEFAULTS` and
the defaults of the operators' keys."""

REQUIRED = ("name", "population.size", "generations", "init.method", "fitness.method",
            "selection.method", "crossover.method", "mutation.method")

SWEPT_STATIC = ("population.size",)
"""Static keys that a sweep may still vary in one compiled call: the population size (the
program holds the largest size swept, and a dynamic ``active`` count masks the rest)."""


def sweepable(key: str) -> bool:
    """Whether ``jaxga.sweep`` and ``jaxga.doe`` may vary ``key`` in one compiled call: a
    dynamic key (:attr:`Field.dynamic`: a traced value of the parameters) or one of
    :data:`SWEPT_STATIC`."""
    return key in SWEPT_STATIC or (key in SCHEMA and SCHEMA[key].dynamic)


def flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}} -> {"a.b": 1}`` (TOML tables to dotted keys), in the tables'
    order; without recursion, so that a dotted key of thousands of parts is a key (which
    the schema then refuses), not a RecursionError."""
    out: dict[str, Any] = {}
    stack = [(prefix, iter(table.items()))]
    while stack:
        base, items = stack[-1]
        for k, v in items:
            key = f"{base}{k}"
            if isinstance(v, Mapping):
                stack.append((key + ".", iter(v.items())))
                break
            out[key] = v
        else:
            stack.pop()
    return out


def dotted(overrides: Mapping[str, Any], *, underscores: bool = True) -> dict[str, Any]:
    """Keyword overrides as dotted keys: ``a__b=...``, ``"a.b"`` and ``a={"b": ...}``
    alike (:func:`flatten`). A key reached twice with different values (``a__b=0.5``
    beside ``a={"b": 0.9}``) is refused: one of them would be dropped without a word.
    ``underscores=False`` (a preset file's tables) reads ``__`` as part of a name."""
    out: dict[str, Any] = {}
    for name, value in overrides.items():
        name = str(name).replace("__", ".") if underscores else str(name)
        for key, v in flatten({name: value}).items():
            if key in out and normalised(key, out[key]) != normalised(key, v):
                raise ParameterError(f"{key} is given twice, as {shown_value(out[key])} and "
                                     f"{shown_value(v)}")
            out[key] = v
    return out


def normalised(key: str, value: Any) -> Any:
    """``value`` as the configuration stores it (a tuple and a list alike, numpy scalars
    as Python ones), to compare two values given for ``key`` (:func:`dotted`, keyword
    overrides against ``--set``); an invalid value is refused with the key's own message.
    A key the schema does not know (refused by name when the preset loads) compares by
    its value's repr, so ``True`` and ``1`` are two values."""
    if key not in SCHEMA:
        return repr(python_scalar(value))
    return freeze(SCHEMA[key].check(key, value))


_LOOSE_NUMBER = re.compile(r"[+-]?(\d+\.\d*|\.\d+)([eE][+-]?\d+)?")
"""Decimal numbers that TOML refuses but nobody reads as words: ``.5``, ``5.``."""


def parse_value(text: str) -> Any:
    """A ``--set`` value: TOML syntax (``0.7``, ``true``, ``"ring"``, ``[0.9, 0.6]``), a
    decimal number TOML refuses (``.5``, ``5.``), or a bare word taken as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except ValueError:  # TOMLDecodeError, or an integer past Python's 4300 digits
        return float(text) if _LOOSE_NUMBER.fullmatch(text.strip()) else text
    except RecursionError:  # arrays or tables nested thousands deep
        raise ParameterError("a value nested too deeply to read (arrays or tables inside "
                             "one another thousands deep)") from None


@dataclasses.dataclass(frozen=True)
class Config:
    """A validated configuration (immutable, hashable, so it can be a static jit argument)."""

    items: tuple[tuple[str, Any], ...]

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> Config:
        """Validate dotted keys (unknown keys, types, ranges, required keys)."""
        merged = dict(DEFAULTS)
        for key, value in values.items():
            if key not in SCHEMA:
                near = [k for k in SCHEMA if k.split(".")[-1] == key.split(".")[-1]]
                hint = f" (did you mean {', '.join(near)}?)" if near else ""
                raise ParameterError(f"unknown configuration key {key!r}{hint}")
            merged[key] = SCHEMA[key].check(key, value)
        missing = [k for k in REQUIRED if k not in merged]
        if missing:
            raise ParameterError(f"configuration is missing {', '.join(missing)}")
        for key in ("fitness.importance_ratios", "islands.crossover_probabilities",
                    "islands.mutation_probabilities"):
            if key in merged:
                _check_number_list(key, merged[key], positive=key.startswith("fitness"))
        return cls(tuple(sorted((k, freeze(v)) for k, v in merged.items())))

    def __getitem__(self, key: str) -> Any:
        for k, v in self.items:
            if k == key:
                return v
        raise KeyError(key)

    def get(self, key: str, default: Any = None) -> Any:
        try:
            return self[key]
        except KeyError:
            return default

    def as_dict(self) -> dict[str, Any]:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.items}

    def override(self, changes: Mapping[str, Any]) -> Config:
        """A new configuration with some keys replaced (validated)."""
        d = self.as_dict()
        d.update(changes)
        return Config.from_mapping(d)

    def dynamic(self) -> dict[str, Any]:
        """The keys that may be swept without recompilation, with their values."""
        return {k: v for k, v in self.items if SCHEMA[k].dynamic}


def freeze(v: Any) -> Any:
    """A configuration value in hashable form: lists become tuples."""
    return tuple(v) if isinstance(v, list) else v


def _check_number_list(key: str, value: Iterable, positive: bool) -> None:
    for x in value:
        if not finite_number(x):
            raise ParameterError(f"{key} must be a list of numbers, got "
                                 f"{shown_value(list(value))}")
        if positive and x <= 0:
            raise ParameterError(f"{key} entries must be > 0, got {shown_value(list(value))}")
        if not positive and not 0 <= x <= 1:
            raise ParameterError(f"{key} entries must be probabilities in [0, 1]")


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file into dotted keys; a clear error for a missing or malformed file."""
    p = Path(path)
    try:
        return flatten(tomllib.loads(p.read_bytes().decode("utf-8-sig")))  # a BOM, too
    except FileNotFoundError:
        raise ParameterError(f"configuration file not found: {p}") from None
    except ValueError as e:  # TOMLDecodeError, or an integer past Python's 4300 digits
        raise ParameterError(f"{p}: malformed TOML: {str(e).splitlines()[0]}") from None
    except RecursionError:  # arrays or tables nested thousands deep
        raise ParameterError(f"{p}: malformed TOML: nested too deeply") from None
