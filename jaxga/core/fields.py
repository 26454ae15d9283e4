"""Configuration fields: one key's type, range, meaning and default (:class:`Field`).

The operators' own keys are declared with their operator in :mod:`jaxga.operators.registry`, the
others in :data:`jaxga.config.schema.SCHEMA`; both are built from this module, which imports
nothing else of jaxga's but its errors.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from jaxga.core.errors import ParameterError

__all__ = ["P", "POS", "Field", "python_scalar"]


@dataclasses.dataclass(frozen=True)
class Field:
    """One configuration key: its type, constraint, whether it is dynamic, its meaning
    and, where the key may be left out, its default."""

    kind: type | tuple[type, ...]
    doc: str
    choices: tuple | None = None
    low: float | None = None
    high: float | None = None
    dynamic: bool = False
    default: Any = None

    def check(self, key: str, value: Any) -> Any:
        """``value`` as this key holds it (numpy scalars as Python values, integers as
        floats where a number is expected); :class:`ParameterError` naming ``key`` if it
        has the wrong type or lies outside the choices or the range."""
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

    if isinstance(value, np.generic) and value.dtype.kind in "biuf":
        return value.item()
    return value


def _kind_name(kinds: tuple[type, ...]) -> str:
    return " or ".join({bool: "true/false", int: "an integer", float: "a number",
                        str: "a string", list: "a list"}.get(k, k.__name__) for k in kinds)


P = dict(kind=float, low=0.0, high=1.0, dynamic=True)
"""A probability: a dynamic float in [0, 1]."""
POS = dict(kind=float, low=0.0, dynamic=True)
"""A non-negative dynamic float (a weight, a temperature)."""
