"""Equality by value for jaxga's records that hold arrays.

A dataclass's own ``==`` compares its fields as a tuple, and a field that is an array
compares element by element: ``result == copy.deepcopy(result)`` raised "the truth value
of an array is ambiguous", and only the same object compared equal. Records that mix
arrays with other values take :class:`ValueEquality` instead: equal when of one type and
every field is equal, arrays by shape, dtype and values (NaN equal to NaN, as a failed
run's NaN length read back from a file is the same result), hashed as the dataclass would
be: a frozen record by its fields, a record the user may change (:class:`MutableValueEquality`)
not at all, so ``isinstance(record, collections.abc.Hashable)`` tells the truth.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import jax
import numpy as np

__all__ = ["MutableValueEquality", "ValueEquality", "values_equal"]


_ARRAYS = (np.ndarray, np.generic, jax.Array)
_NAN = object()  # what a NaN field hashes as


def values_equal(a: Any, b: Any) -> bool:
    """Whether ``a`` and ``b`` hold the same values: arrays (NumPy or JAX) of one shape,
    dtype and values, NaN equal to NaN; dataclasses of one type field by field (the fields
    they compare);
    mappings, lists and tuples item by item; anything else by ``==``."""
    if a is b:
        return True
    if isinstance(a, _ARRAYS) or isinstance(b, _ARRAYS):
        x, y = np.asarray(a), np.asarray(b)
        return (x.shape == y.shape and x.dtype == y.dtype
                and bool(np.array_equal(x, y, equal_nan=x.dtype.kind in "fc")))
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(
            values_equal(getattr(a, f.name), getattr(b, f.name))
            for f in dataclasses.fields(a) if f.compare)
    if isinstance(a, Mapping):
        return (isinstance(b, Mapping) and a.keys() == b.keys()
                and all(values_equal(a[k], b[k]) for k in a))
    if isinstance(a, (list, tuple)):
        return (type(a) is type(b) and len(a) == len(b)
                and all(values_equal(x, y) for x, y in zip(a, b)))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


class ValueEquality:
    """``==`` by value (:func:`values_equal`, over the fields the dataclass compares) for a
    dataclass declared with ``eq=False`` (its generated ``==`` would compare arrays element
    by element). Hashed as a dataclass's own hash would be: a frozen one by the fields it
    hashes (a grid of shapes is a program's key; one holding arrays is not hashable),
    any other not at all."""

    __slots__ = ()

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return values_equal(self, other)

    def __hash__(self) -> int:
        params = getattr(type(self), "__dataclass_params__", None)
        if params is None or not params.frozen:
            raise TypeError(f"unhashable type: {type(self).__name__!r}")
        # the fields the dataclass would hash; every NaN alike, as == takes them
        return hash(tuple(_NAN if isinstance(v, float) and math.isnan(v) else v
                          for v in (getattr(self, f.name) for f in dataclasses.fields(self)
                                    if (f.compare if f.hash is None else f.hash))))


class MutableValueEquality(ValueEquality):
    """:class:`ValueEquality` for a record that is not frozen: ``==`` by value and no hash,
    declared (``__hash__ = None``) as a dataclass with ``==`` declares it, so that
    ``isinstance(record, collections.abc.Hashable)`` is False rather than True with a
    ``hash()`` that raises."""

    __slots__ = ()
    __hash__ = None  # type: ignore[assignment]
