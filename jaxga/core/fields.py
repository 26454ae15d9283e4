"""Configuration fields: one key's type, range, meaning and default (:class:`Field`).

The operators' own keys are declared with their operator in :mod:`jaxga.operators.registry`, the
others in :data:`jaxga.config.schema.SCHEMA`; both are built from this module, which imports
nothing else of jaxga's but its errors.
"""

from __future__ import annotations

import dataclasses
import math
import reprlib
from typing import Any

import numpy as np

from jaxga.core.errors import ParameterError

__all__ = ["P", "POS", "Field", "finite_number", "python_scalar", "shown_value"]


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
            try:
                value = float(value)
            except OverflowError:  # an integer beyond the largest float
                raise ParameterError(
                    f"{key} must be finite, got {shown_value(value)}") from None
        if list in kinds and isinstance(value, tuple):  # (1.2, 1.4) from Python
            value = list(value)
        if isinstance(value, bool) and bool not in kinds:
            raise ParameterError(f"{key} must be {_kind_name(kinds)}, got {value!r}")
        if not isinstance(value, kinds):
            raise ParameterError(
                f"{key} must be {_kind_name(kinds)}, got {shown_value(value)}")
        if self.choices is not None and value not in self.choices:
            raise ParameterError(
                f"{key} = {shown_value(value)} is not one of {', '.join(map(str, self.choices))}"
            )
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if isinstance(value, float) and not math.isfinite(value):
                raise ParameterError(f"{key} must be finite, got {value!r}")
            if self.low is not None and value < self.low:
                raise ParameterError(
                    f"{key} = {shown_value(value)} is below its minimum {self.low}")
            if self.high is not None and value > self.high:
                raise ParameterError(
                    f"{key} = {shown_value(value)} is above its maximum {self.high}")
        return value


def finite_number(value: Any) -> bool:
    """Whether ``value`` is an int or float (not a bool) that a float holds finitely: an
    integer beyond the largest float is not (converting it raises ``OverflowError``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:  # an integer of 309 digits or more
        return False


LONGEST_SHOWN = 80
"""The most characters of a refused value that its message shows."""

_BOUNDED = reprlib.Repr()
"""A repr that looks at a bounded part of a value: a list of 10**8 entries, or a YAML
file whose aliases hold billions of elements, is not printed whole to be cut."""
_BOUNDED.maxlevel = 3
_BOUNDED.maxlist = _BOUNDED.maxtuple = _BOUNDED.maxset = _BOUNDED.maxfrozenset = 8
_BOUNDED.maxdict = 6
_BOUNDED.maxstring = _BOUNDED.maxother = _BOUNDED.maxlong = LONGEST_SHOWN


def shown_value(value: Any) -> str:
    """``repr(value)`` for a message (a refusal echoes the value it refuses), on one line
    and at most :data:`LONGEST_SHOWN` characters: an integer of more digits is named by
    its size (Python will not even print one of more than 4,300 digits), an array by its
    type and shape, anything longer is cut, the number of characters left out named."""
    if isinstance(value, int) and not isinstance(value, bool) \
            and abs(value).bit_length() > 3.33 * LONGEST_SHOWN:
        return f"an integer of about {int(abs(value).bit_length() * math.log10(2)) + 1:,} digits"
    if isinstance(value, np.ndarray) and value.ndim > 0:  # its repr spans lines
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    try:
        text = " ".join(_BOUNDED.repr(value).splitlines())  # one line: a message is one
    except (ValueError, RecursionError):  # a list holding such an integer, or nested deep
        return f"a {type(value).__name__} too long to show"
    if len(text) <= LONGEST_SHOWN:
        return text
    return f"{text[:LONGEST_SHOWN - 20]}...[{len(text) - LONGEST_SHOWN + 20:,} characters]"


def python_scalar(value: Any) -> Any:
    """A numpy scalar (``np.int64(8)``, ``np.float32(0.5)``, ``np.bool_(True)``), or a
    0-d NumPy or JAX array of one (``jnp.float32(0.5)``), as the Python value it holds;
    anything else unchanged (a traced value too). Sweeps and designs built with numpy or
    jax.numpy give these, which are the same values as far as a configuration goes."""

    if isinstance(value, np.generic) and value.dtype.kind in "biuf":
        return value.item()  # np.float64 is a float too: its Python value all the same
    dtype = getattr(value, "dtype", None)
    if getattr(dtype, "kind", None) in ("b", "i", "u", "f") and \
            getattr(value, "shape", None) == () and not isinstance(value, (int, float)):
        try:
            return value.item()
        except Exception:  # noqa: BLE001 - a traced value has no Python value
            return value
    return value


def _kind_name(kinds: tuple[type, ...]) -> str:
    return " or ".join({bool: "true/false", int: "an integer", float: "a number",
                        str: "a string", list: "a list"}.get(k, k.__name__) for k in kinds)


P = dict(kind=float, low=0.0, high=1.0, dynamic=True)
"""A probability: a dynamic float in [0, 1]."""
POS = dict(kind=float, low=0.0, dynamic=True)
"""A non-negative dynamic float (a weight, a temperature)."""
