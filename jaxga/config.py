"""Algorithm configurations: a validated, flat ``section.key -> value`` mapping.

A configuration says which operator fills each stage of the GA and with which
parameters (SPEC 4-10). Presets (``presets/*.toml``, one per paper) are configurations;
a user TOML file or ``--set key=value`` overrides any field. Every key is declared in
:data:`SCHEMA` with its type, allowed values or range and a one-line meaning: unknown
keys and out-of-range values are rejected with a message that names the key.

Keys marked *dynamic* never change array shapes (probabilities, weights, temperatures):
a sweep over them is one compiled call (``jax.vmap``). The others are *static*: they
choose operators or sizes and are compiled in.
"""

from __future__ import annotations

import dataclasses
import math
import re
import sys
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from jaxga.errors import ParameterError
from jaxga.grid import CORNER_RULES

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

INITIALISERS = ("random_walk", "median_insertion", "intermittent_connect",
                "greedy_random_target", "directional", "field_walk")
FALLBACKS = ("field_walk", "none")
REPAIR_FALLBACKS = ("none", "field")
FITNESSES = ("sga", "imga", "agacd", "mpmga", "iga_zhu", "iga_zhang")
SELECTIONS = ("roulette", "roulette_elite", "layered_thirds", "stratified", "tournament",
              "none")
CROSSOVERS = ("common_point", "cut_and_check", "heterologous", "column", "zhu_mixed", "none")
MUTATIONS = ("neighbour_point", "one_point", "range", "segment_sa", "point_checked",
             "zhu_mixed", "none")
SIMPLIFIERS = ("none", "simplify_adjacent", "corner_cut")
POSTPROCESSORS = ("none", "shortcut_greedy", "shortcut_optimal")
TOPOLOGIES = ("none", "ring", "star", "full", "mpmga")


@dataclasses.dataclass(frozen=True)
class Field:
    """One configuration key: its type, constraint, whether it is dynamic, and meaning."""

    kind: type | tuple[type, ...]
    doc: str
    choices: tuple | None = None
    low: float | None = None
    high: float | None = None
    dynamic: bool = False

    def check(self, key: str, value: Any) -> Any:
        kinds = self.kind if isinstance(self.kind, tuple) else (self.kind,)
        value = python_scalar(value)
        if float in kinds and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if list in kinds and isinstance(value, tuple):  # (1.2, 1.4) from Python
            value = list(value)
        if isinstance(value, bool) and bool not in kinds:
            raise ParameterError(f"{key} must be {_kind_name(kinds)}, got {value!r}")
        if not isinstance(value, kinds):
            raise ParameterError(f"{key} must be {_kind_name(kinds)}, got {value!r}")
        if self.choices is not None and value not in self.choices:
            raise ParameterError(
                f"{key} = {value!r} is not one of {', '.join(map(str, self.choices))}"
            )
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if isinstance(value, float) and not math.isfinite(value):
                raise ParameterError(f"{key} must be finite, got {value!r}")
            if self.low is not None and value < self.low:
                raise ParameterError(f"{key} = {value!r} is below its minimum {self.low}")
            if self.high is not None and value > self.high:
                raise ParameterError(f"{key} = {value!r} is above its maximum {self.high}")
        return value


def python_scalar(value: Any) -> Any:
    """A numpy scalar (``np.int64(8)``, ``np.float32(0.5)``, ``np.bool_(True)``) as the
    Python value it holds; anything else unchanged. Sweeps and designs built with numpy
    give numpy scalars, which are the same values as far as a configuration goes."""
    import numpy as np

    if isinstance(value, np.generic) and value.dtype.kind in "biuf":
        return value.item()
    return value


def _kind_name(kinds: tuple[type, ...]) -> str:
    return " or ".join({bool: "true/false", int: "an integer", float: "a number",
                        str: "a string", list: "a list"}.get(k, k.__name__) for k in kinds)


P = dict(kind=float, low=0.0, high=1.0, dynamic=True)
POS = dict(kind=float, low=0.0, dynamic=True)

SCHEMA: dict[str, Field] = {
    "name": Field(str, "preset name"),
    "paper": Field(str, "the paper the preset reproduces"),
    "description": Field(str, "one line on the algorithm"),
    "map.corner_rule": Field(str, "corner rule of SPEC 1 used unless the run names one",
                             choices=CORNER_RULES),
    "population.size": Field(int, "individuals per population (per island)", low=2, high=100_000),
    "population.capacity": Field(int, "path capacity L: cells a path can hold (not a "
                                 "number of individuals); 0 = automatic from the map size",
                                 low=0, high=1_000_000),
    "generations": Field(int, "generations per run", low=1, high=1_000_000),
    "init.method": Field(str, "initialiser (SPEC 4)", choices=INITIALISERS),
    "init.max_tries": Field(int, "redraws of a failed individual", low=1, high=10_000),
    "init.fallback": Field(str, "initialiser that fills the slots init.method left empty "
                           "after init.max_tries attempts ('none': the paper's initialiser "
                           "alone)", choices=FALLBACKS),
    "init.slack": Field(float, low=0.0, high=100.0, dynamic=True,
                        doc="field_walk: paths up to (1 + slack) x the optimal length"),
    "init.temperature": Field(float, low=0.0, high=1000.0, dynamic=True,
                              doc="field_walk: preference for short detours, "
                                  "exp(-excess / temperature); 0 = optimal moves only"),
    "repair.fallback": Field(str, "'field': a repair that does not close (median insertion "
                             "of the initialisers, the column crossover and the segment "
                             "mutation; the range mutation's walk) connects down the exact "
                             "distance field instead of failing ('none': the papers' "
                             "failure)", choices=REPAIR_FALLBACKS),
    "fitness.method": Field(str, "fitness combiner (SPEC 3)", choices=FITNESSES),
    "fitness.window": Field(bool, "evaluate grid paths on a narrow window when all fit "
                            "(same results; faster where paths stay short, 1-2 s more "
                            "compile)"),
    "fitness.a": Field(**POS, doc="IMGA length weight a / Zhang turn weight a"),
    "fitness.b": Field(**POS, doc="IMGA safety weight b"),
    "fitness.c": Field(**POS, doc="IMGA energy weight c / MPMGA smoothness constant c"),
    "fitness.importance_ratios": Field(list, "AGACD Delphi importance ratios (eq. 21-25)"),
    "fitness.smoothness_floor": Field(**POS, doc="floor of a zero smoothness (straight path)"),
    "fitness.alpha": Field(**POS, doc="MPMGA length weight alpha"),
    "fitness.beta": Field(**POS, doc="MPMGA smoothness weight beta"),
    "fitness.omega": Field(**P, doc="Zhu length weight omega"),
    "fitness.c1": Field(**POS, doc="Zhu penalty of a 45 degree turn"),
    "fitness.c2": Field(**POS, doc="Zhu penalty of a 90 degree turn"),
    "fitness.c3": Field(**POS, doc="Zhu penalty of a 135 degree turn"),
    "fitness.v": Field(**POS, doc="Zhang straight speed v"),
    "fitness.v_t": Field(**POS, doc="Zhang turning speed v_t"),
    "fitness.r": Field(**POS, doc="Zhang turning radius r"),
    "selection.method": Field(str, "selection (SPEC 5)", choices=SELECTIONS),
    "selection.tournament_size": Field(int, "tournament size k", low=1, high=1000),
    "crossover.method": Field(str, "crossover (SPEC 6)", choices=CROSSOVERS),
    "crossover.probability": Field(**P, doc="crossover probability pc per pair"),
    "crossover.adaptive": Field(bool, "AGACD adaptive pc (eq. 26-27)"),
    "crossover.pc_low": Field(**P, doc="AGACD pc_low"),
    "crossover.pc_high": Field(**P, doc="AGACD pc_high"),
    "mutation.method": Field(str, "mutation (SPEC 7)", choices=MUTATIONS),
    "mutation.probability": Field(**P, doc="mutation probability pm per individual"),
    "mutation.adaptive": Field(bool, "AGACD adaptive pm (eq. 28-29)"),
    "mutation.pm_low": Field(**P, doc="AGACD pm_low"),
    "mutation.pm_high": Field(**P, doc="AGACD pm_high"),
    "mutation.radius": Field(int, "AGACD point mutation radius in cells", low=1, high=10_000),
    "mutation.temperature_c1": Field(**POS, doc="MPMGA annealing T = c1 * w**t: c1"),
    "mutation.temperature_w": Field(float, low=0.0, high=1.0,
                                    doc="MPMGA annealing T = c1 * w**t: w (static: optax "
                                        "builds the schedule from it)"),
    "simplify.method": Field(str, "per-generation simplification (SPEC 9)", choices=SIMPLIFIERS),
    "simplify.probability": Field(**P, doc="simplification probability ps per individual"),
    "post.method": Field(str, "post-optimisation of the final best (SPEC 9)",
                         choices=POSTPROCESSORS),
    "termination.stagnation": Field(int, "IMGA: stop after K generations without improvement; "
                                    "0 = never", low=0, high=1_000_000),
    "islands.count": Field(int, "number of islands (1 = single population)", low=1, high=1024),
    "islands.topology": Field(str, "migration topology (SPEC 8)", choices=TOPOLOGIES),
    "islands.interval": Field(int, "generations between migrations", low=1, high=1_000_000),
    "islands.migrants": Field(int, "migrants per island and migration", low=0, high=100_000),
    "islands.crossover_probabilities": Field(list, "per-island pc (MPMGA A, B, C)"),
    "islands.mutation_probabilities": Field(list, "per-island pm (MPMGA A, B, C)"),
}

DEFAULTS: dict[str, Any] = {
    "description": "",
    "map.corner_rule": "strict",
    "population.capacity": 0,
    "init.max_tries": 20,
    "init.fallback": "field_walk",
    "init.slack": 0.5,
    "init.temperature": 1.0,
    "repair.fallback": "none",
    "fitness.window": True,
    "selection.tournament_size": 2,
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
}

REQUIRED = ("name", "population.size", "generations", "init.method", "fitness.method",
            "selection.method", "crossover.method", "mutation.method")


def flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}} -> {"a.b": 1}`` (TOML tables to dotted keys)."""
    out: dict[str, Any] = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


_LOOSE_NUMBER = re.compile(r"[+-]?(\d+\.\d*|\.\d+)([eE][+-]?\d+)?")
"""Decimal numbers that TOML refuses but nobody reads as words: ``.5``, ``5.``."""


def parse_value(text: str) -> Any:
    """A ``--set`` value: TOML syntax (``0.7``, ``true``, ``"ring"``, ``[0.9, 0.6]``), a
    decimal number TOML refuses (``.5``, ``5.``), or a bare word taken as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return float(text) if _LOOSE_NUMBER.fullmatch(text.strip()) else text


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
        return cls(tuple(sorted((k, _freeze(v)) for k, v in merged.items())))

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


def _freeze(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v


def _check_number_list(key: str, value: Iterable, positive: bool) -> None:
    for x in value:
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
            raise ParameterError(f"{key} must be a list of numbers, got {list(value)!r}")
        if positive and x <= 0:
            raise ParameterError(f"{key} entries must be > 0, got {list(value)!r}")
        if not positive and not 0 <= x <= 1:
            raise ParameterError(f"{key} entries must be probabilities in [0, 1]")


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file into dotted keys; a clear error for a missing or malformed file."""
    p = Path(path)
    try:
        with p.open("rb") as f:
            return flatten(tomllib.load(f))
    except FileNotFoundError:
        raise ParameterError(f"configuration file not found: {p}") from None
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(f"{p}: malformed TOML: {e}") from None
