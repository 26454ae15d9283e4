"""An independent, slow, exact line-of-sight reference for the tests (rational arithmetic).

It enumerates every parameter ``t`` at which the segment between two cell centres meets
a grid line, checks the cell containing the midpoint of every piece between consecutive
crossings, and applies the corner rule at every grid vertex the segment passes through.
It shares no code with :mod:`jaxga.core.geometry`.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np


def exact_clear(blocked: np.ndarray, rule: str, a: tuple[int, int], b: tuple[int, int]) -> bool:
    h, w = blocked.shape
    (ax, ay), (bx, by) = (int(a[0]), int(a[1])), (int(b[0]), int(b[1]))
    if blocked[ay, ax] or blocked[by, bx]:
        return False
    x0, y0 = Fraction(2 * ax + 1, 2), Fraction(2 * ay + 1, 2)
    dx, dy = Fraction(bx - ax), Fraction(by - ay)
    ts = {Fraction(0), Fraction(1)}
    if dx:
        ts |= {(X - x0) / dx for X in range(w + 1) if 0 <= (X - x0) / dx <= 1}
    if dy:
        ts |= {(Y - y0) / dy for Y in range(h + 1) if 0 <= (Y - y0) / dy <= 1}
    ts = sorted(ts)
    for t0, t1 in zip(ts, ts[1:]):
        tm = (t0 + t1) / 2
        if blocked[int(y0 + dy * tm), int(x0 + dx * tm)]:
            return False
    for t in ts[1:-1]:
        x, y = x0 + dx * t, y0 + dy * t
        if x.denominator == 1 and y.denominator == 1:
            X, Y = int(x), int(y)
            fc, tc = (X - 1, X) if dx > 0 else (X, X - 1)
            fr, tr = (Y - 1, Y) if dy > 0 else (Y, Y - 1)
            s1, s2 = blocked[fr, tc], blocked[tr, fc]
            if rule == "no_squeeze" and s1 and s2:
                return False
            if rule == "strict" and (s1 or s2):
                return False
    return True


def passes_vertex(a: tuple[int, int], b: tuple[int, int]) -> bool:
    """Whether the open segment between the two cell centres goes through a grid vertex."""
    (ax, ay), (bx, by) = a, b
    x0, y0 = Fraction(2 * ax + 1, 2), Fraction(2 * ay + 1, 2)
    dx, dy = bx - ax, by - ay
    if dx == 0 or dy == 0:
        return False
    for k in range(1, abs(dx) + 1):
        X = ax + (k if dx > 0 else 1 - k)
        t = (X - x0) / dx
        if (y0 + dy * t).denominator == 1:
            return True
    return False
