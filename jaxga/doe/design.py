"""Designs of a DOE: factors with three coded levels (AGACD Table 3) and the arrays of coded
points: Taguchi L9, L18, L27, the full factorial 3^k and AGACD's own 9-run design (its Table
4).
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from jaxga.config.schema import SCHEMA, Config, parse_value, python_scalar, sweepable
from jaxga.core.errors import ParameterError
from jaxga.core.fields import finite_number, shown_value
from jaxga.engine import unread_keys

# ----------------------------------------------------------------------------- factors


@dataclasses.dataclass(frozen=True)
class Factor:
    """A swept configuration key with three levels: coded -1, 0, 1 = low, mid, high."""

    name: str
    levels: tuple[Any, Any, Any]

    def __post_init__(self) -> None:
        if not isinstance(self.name, str):
            raise ParameterError(f"a factor's name is a configuration key (a string), got "
                                 f"{self.name!r}")
        if isinstance(self.levels, (str, bytes)):
            raise ParameterError(f"factor {self.name}: levels must be three numbers, got "
                                 f"{self.levels!r}")
        try:  # numpy levels are the numbers they hold
            levels = tuple(python_scalar(v) for v in self.levels)
        except TypeError:
            raise ParameterError(f"factor {self.name}: levels must be three numbers, got "
                                 f"{self.levels!r}") from None
        object.__setattr__(self, "levels", levels)
        if len(self.levels) != 3:
            raise ParameterError(
                f"factor {self.name} needs three levels low,mid,high, got {list(self.levels)}")
        for v in self.levels:
            if not finite_number(v):
                raise ParameterError(f"factor {self.name}: levels must be finite numbers, got "
                                     f"{shown_value(list(self.levels))}")
        lo, mid, hi = self.levels
        if not lo < mid < hi:
            raise ParameterError(
                f"factor {self.name}: levels must increase (low < mid < high), got "
                f"{list(self.levels)}")

    def value(self, coded: int) -> Any:
        """The real value of coded level -1, 0 or 1 (AGACD Table 3)."""
        if coded not in (-1, 0, 1):
            raise ParameterError(f"coded level must be -1, 0 or 1, got {coded!r}")
        return self.levels[int(coded) + 1]

    @classmethod
    def parse(cls, text: str) -> Factor:
        """``"name=low,mid,high"`` (e.g. ``population.size=40,50,60``)."""
        name, sep, rest = text.partition("=")
        if not sep or not name.strip():
            raise ParameterError(f"expected NAME=LOW,MID,HIGH for a factor, got {text!r}")
        try:
            values = [parse_value(v.strip()) for v in rest.split(",")]
        except ParameterError as e:  # a level nested too deeply to read
            raise ParameterError(f"factor {name.strip()}: {e}") from None
        return cls(name.strip(), tuple(values))


AGACD_TABLE3: tuple[Factor, ...] = (
    Factor("population.size", (40, 50, 60)),
    Factor("crossover.pc_low", (0.55, 0.6, 0.65)),
    Factor("crossover.pc_high", (0.7, 0.75, 0.8)),
    Factor("mutation.pm_low", (0.05, 0.1, 0.15)),
    Factor("mutation.pm_high", (0.2, 0.25, 0.3)),
)
"""AGACD Table 3: the five factors of its DOE and their levels (20 x 20 map)."""


def check_factors(config: Config, factors: Sequence[Factor]) -> None:
    """Refuse factors a sweep cannot vary in one compiled call, or that do nothing.

    A factor must be a configuration key that ``config`` (the preset after overrides)
    reads (:func:`jaxga.engine.unread_keys`: a fitness weight the preset leaves at the
    objective's default is read), either dynamic (probabilities, weights, temperatures,
    integer settings such as ``islands.interval``: :data:`jaxga.config.schema.SCHEMA`) or
    ``population.size`` (the engine's active mask; :func:`jaxga.config.schema.sweepable`); names
    must be distinct; every level must be a valid value of the key.
    """
    if not factors:
        raise ParameterError("a designed experiment needs at least one factor")
    names = [f.name for f in factors]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ParameterError(f"factor {', '.join(dup)} given more than once")
    unread = unread_keys(config)
    for f in factors:
        if f.name not in SCHEMA:
            near = [k for k in SCHEMA if k.split(".")[-1] == f.name.split(".")[-1]]
            hint = f" (did you mean {', '.join(near)}?)" if near else ""
            raise ParameterError(f"unknown factor {f.name!r}: not a configuration key{hint}")
        if not sweepable(f.name):
            raise ParameterError(
                f"factor {f.name!r} changes the compiled program: only dynamic keys "
                "(probabilities, weights, temperatures, init.max_tries, "
                "termination.stagnation, islands.interval; 'dynamic' in jaxga presets "
                "--show) and population.size can be factors; run the other values as "
                "separate experiments")
        if f.name in unread:
            raise ParameterError(f"factor {f.name!r} has no effect in preset "
                                 f"{config['name']!r}: {unread[f.name]}")
        for v in f.levels:
            config.override({f.name: v})  # type and range of every level


# ----------------------------------------------------------------------------- designs


def _gf3_array(forms: Sequence[Sequence[int]]) -> np.ndarray:
    """Orthogonal array from linear forms over GF(3): column j of run ``(a, b, ...)`` (the
    first base factor slowest) is ``sum_i forms[j][i] * base_i mod 3``, coded -1, 0, 1."""
    n_base = len(forms[0])
    base = np.array(list(itertools.product(range(3), repeat=n_base)), np.int64)
    return ((base @ np.array(forms, np.int64).T) % 3 - 1).astype(np.int8)


L9 = _gf3_array(((1, 0), (0, 1), (1, 1), (2, 1)))
"""Taguchi L9 (3^4), columns A, B, AB, A^2 B in the standard order (levels 1, 2, 3 ->
-1, 0, 1)."""


L27 = _gf3_array(((1, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0), (0, 0, 1), (1, 0, 1),
                  (2, 0, 1), (0, 1, 1), (1, 1, 1), (2, 1, 1), (0, 2, 1), (1, 2, 1),
                  (2, 2, 1)))
"""Taguchi L27 (3^13) in the standard column order (columns 1, 2, 5 are the base factors
A, B, C)."""


_L18_STANDARD = np.array([
    # the standard L18 (2^1 x 3^7); column 1 is the two-level one
    [1, 1, 1, 1, 1, 1, 1, 1],
    [1, 1, 2, 2, 2, 2, 2, 2],
    [1, 1, 3, 3, 3, 3, 3, 3],
    [1, 2, 1, 1, 2, 2, 3, 3],
    [1, 2, 2, 2, 3, 3, 1, 1],
    [1, 2, 3, 3, 1, 1, 2, 2],
    [1, 3, 1, 2, 1, 3, 2, 3],
    [1, 3, 2, 3, 2, 1, 3, 1],
    [1, 3, 3, 1, 3, 2, 1, 2],
    [2, 1, 1, 3, 3, 2, 2, 1],
    [2, 1, 2, 1, 1, 3, 3, 2],
    [2, 1, 3, 2, 2, 1, 1, 3],
    [2, 2, 1, 2, 3, 1, 3, 2],
    [2, 2, 2, 3, 1, 2, 1, 3],
    [2, 2, 3, 1, 2, 3, 2, 1],
    [2, 3, 1, 3, 2, 3, 1, 2],
    [2, 3, 2, 1, 3, 1, 2, 3],
    [2, 3, 3, 2, 1, 2, 3, 1],
])


L18 = (_L18_STANDARD[:, 1:] - 2).astype(np.int8)
"""The seven 3-level columns (2-8) of the standard L18 (18 runs)."""


AGACD_TABLE4 = np.array([
    # population, pc_low, pc_high, pm_low, pm_high (AGACD Table 4, coded columns)
    [-1, -1, -1, -1, 0],
    [-1, 0, 0, 0, 1],
    [-1, 1, 1, 1, -1],
    [0, -1, 0, 1, 1],
    [0, 0, 1, -1, -1],
    [0, 1, -1, 0, 0],
    [1, -1, 1, 0, -1],
    [1, 0, -1, 1, 0],
    [1, 1, 0, -1, 1],
], np.int8)
"""AGACD Table 4: its 9-run, 5-factor design. Columns 1-4 are the L9; column 5 is not
orthogonal to column 3 (pm_high = 0, 1, -1 where pc_high = -1, 0, 1)."""


DESIGNS = ("agacd-table4", "L9", "L18", "L27", "full")


_ARRAYS = {"agacd-table4": AGACD_TABLE4, "L9": L9, "L18": L18, "L27": L27}

_COLUMN_ORDER = {"L27": (0, 1, 4, 8, 2, 3, 5, 6, 7, 9, 10, 11, 12)}
"""The columns factors take, in order, where it is not the array's own: the L27's base
columns 1, 2, 5 first (up to three factors make the full 3^3, where the first three
columns, A, B and A + B, repeated 9 points three times each), then column 9 (A + B + C: a
fourth factor clear of the two-factor interactions of the other three), then the rest
in order (Taguchi's assignment by the linear graph)."""


MAX_FULL_FACTORIAL_POINTS = 3 ** 8


def design_array(design: str, n_factors: int) -> np.ndarray:
    """Coded levels ``int8[N, n_factors]`` of ``design``: ``n_factors`` columns of an
    orthogonal array (or AGACD Table 4), the first ones except in the L27 (its base
    columns 1, 2, 5 first, then 9, then the others: :data:`_COLUMN_ORDER`), or the full
    factorial 3^k (first factor slowest). A design whose columns would repeat points
    (every array for one factor, the L18 for two) is refused: a repeated point runs the
    same seeds again and gives the same result, so it adds cost, not evidence."""
    if n_factors < 1:
        raise ParameterError("a designed experiment needs at least one factor")
    if design == "full":
        if 3 ** n_factors > MAX_FULL_FACTORIAL_POINTS:
            raise ParameterError(
                f"a full factorial of {n_factors} factors has {3 ** n_factors} points "
                f"(limit {MAX_FULL_FACTORIAL_POINTS}); use L27 or L18")
        return np.array(list(itertools.product((-1, 0, 1), repeat=n_factors)), np.int8)
    if design not in _ARRAYS:
        raise ParameterError(f"unknown design {design!r}: one of {', '.join(DESIGNS)}")
    arr = _ARRAYS[design]
    if n_factors > arr.shape[1]:
        raise ParameterError(
            f"design {design} has {arr.shape[1]} columns, too few for {n_factors} factors; "
            "use a larger array (L18: 7, L27: 13) or the full factorial")
    columns = _COLUMN_ORDER.get(design, range(arr.shape[1]))[:n_factors]
    coded = arr[:, list(columns)].copy()
    distinct = len(np.unique(coded, axis=0))
    if distinct < len(coded):
        raise ParameterError(
            f"design {design} with {n_factors} factor{'s' if n_factors > 1 else ''} has "
            f"only {distinct} distinct points among its {len(coded)} (each repeated, with "
            f"the same seeds and the same result): use the full factorial (design "
            f"'full'), its {3 ** n_factors} points once")
    return coded


def design_points(factors: Sequence[Factor], coded: np.ndarray) -> list[dict[str, Any]]:
    """The real values ``{factor name: value}`` of each row of coded levels."""
    return [{f.name: f.value(int(c)) for f, c in zip(factors, row)} for row in coded]
