"""Numbers as people write them in files and options: ASCII digits only.

Python's ``int()`` and ``float()`` also read ``1_0`` (10), other scripts' digits
(``٣``: 3) and Unicode spaces around them, which no map, scenario, path file or option
holds by intent: a value written so is refused, not read as another number (decisions
051 and 054).
"""

from __future__ import annotations

import re

__all__ = ["ASCII_DECIMAL", "ASCII_INTEGER", "ASCII_SPACES", "ascii_float", "ascii_int",
           "yaml_number"]

ASCII_SPACES = " \t\r\n\f\v"
"""The spaces a number or a map's row may have around it (``str.strip()`` also strips a
no-break space and other Unicode spaces)."""

_SPACE = "[ \t\r\n\f\v]*"

ASCII_INTEGER = re.compile(f"{_SPACE}[+-]?[0-9]+{_SPACE}")
"""An integer in ASCII digits, with ASCII spaces around it."""

ASCII_DECIMAL = re.compile(
    f"{_SPACE}[+-]?(([0-9]+(\\.[0-9]*)?|\\.[0-9]+)([eE][+-]?[0-9]+)?|nan|inf|infinity)"
    f"{_SPACE}", re.IGNORECASE)
"""A decimal number in ASCII (``nan`` and ``inf`` spelled out), with ASCII spaces around
it; whether a non-finite value is allowed is the reader's to say."""


def ascii_int(text: str) -> int:
    """``int(text)`` of an integer written in ASCII digits (:data:`ASCII_INTEGER`);
    ``ValueError`` otherwise (``1_0``, other scripts' digits, a no-break space)."""
    if not isinstance(text, str) or not ASCII_INTEGER.fullmatch(text):
        raise ValueError(f"not an integer in ASCII digits: {text!r}")
    return int(text)


def ascii_float(text: str) -> float:
    """``float(text)`` of a number written in ASCII (:data:`ASCII_DECIMAL`);
    ``ValueError`` otherwise."""
    if not isinstance(text, str) or not ASCII_DECIMAL.fullmatch(text):
        raise ValueError(f"not a number in ASCII digits: {text!r}")
    return float(text)


def yaml_number(value: object) -> float:
    """A YAML scalar read as a number, as yaml-cpp (ROS's map_server, nav2) reads one: an
    integer or a float, not a bool; or a string holding a number in ASCII
    (:data:`ASCII_DECIMAL`), since YAML 1.1 (PyYAML) reads ``5e-2`` and ``1e-05`` (no dot
    in the mantissa), as C++ tools write them, as strings. ``TypeError`` for anything
    else (``1_0`` or ``٣`` in quotes, ``true``, a list); ``OverflowError`` for an integer
    beyond a float. Whether a non-finite value is allowed is the reader's to say."""
    if isinstance(value, str):
        try:
            return ascii_float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"not a number: {value!r}")
    return float(value)
