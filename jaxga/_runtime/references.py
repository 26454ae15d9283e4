"""The exact references of a run: the 8-connected optimum, and the any-angle optimum or its
lower bound within a time budget.

Every result is reported as a gap to an exact reference (:mod:`jaxga.reference.optima`).
The 8-connected optimum is fast and computed before the run (it says whether a path
exists at all). The any-angle optimum over cell centres, what a post-optimised path can
reach, can take minutes on a large map; a run gives it a budget (by default the GA's own
time, so that the references never take longer than the GA itself). What it reports:

* the exact any-angle optimum when the search finishes within the budget;
* otherwise the Euclidean lower bound (the taut string around the blocked cells,
  :func:`jaxga.reference.lower_bound.euclidean_lower_bound_np`), proven below the
  any-angle optimum and fast (it scales with the obstacles' corners, not the cells): the
  gap to it is an upper bound of the gap to the optimum;
* otherwise (the bound did not finish either, or the references were skipped) the gap to
  the straight line from start to goal, a lower bound too
  (:attr:`jaxga.api.result.Result.gap_basis`).

Exact results are cached per problem, so that comparing presets or repeating runs on one
map computes them once; a result cut short by its budget is computed again by a call with
a larger budget.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import threading
import time
from collections.abc import Callable

import numpy as np

from jaxga.core.errors import JaxgaError
from jaxga.core.grid import Grid
from jaxga.maps.clearance import cell_clearance
from jaxga.maps.preprocess import endpoints_connected
from jaxga.operators.guide import field_path
from jaxga.reference.any_angle import any_angle_shortest_path_np
from jaxga.reference.lower_bound import euclidean_lower_bound_np
from jaxga.reference.maximin import MaximinPath, maximin_path, maximin_path_np
from jaxga.reference.optima import ReferencePath, octile_length, shortest_path_np

__all__ = ["SKIPPED_NOTE", "AnyAngleBounds", "any_angle_references", "budget_note",
           "maximin_reference", "octile_optimum"]


def _problem_key(grid: Grid) -> tuple:
    b = np.ascontiguousarray(grid.blocked_np())
    raw = b.tobytes()
    key = (b.shape, grid.start_xy, grid.goal_xy, grid.corner_rule)
    digest = hashlib.blake2b(raw + repr(key).encode(), digest_size=16).digest()
    return digest, b.shape, raw, *key[1:]


@functools.lru_cache(maxsize=32)
def _octile_cached(digest: bytes, shape: tuple[int, int], blocked: bytes, start: tuple,
                   goal: tuple, corner_rule: str) -> ReferencePath:
    del digest  # the cache key; the arguments are the data
    b = np.frombuffer(blocked, dtype=bool).reshape(shape)
    return shortest_path_np(b, start, goal, corner_rule)


def octile_optimum(grid: Grid, guided: bool = False) -> ReferencePath:
    """The exact 8-connected optimum of ``grid``'s problem.

    ``guided``: the run steers by the exact distance fields
    (:func:`jaxga.operators.guide.distance_fields`, computed once for its programs), so
    an optimal path is read off the goal's field (each cell's next cell towards the
    goal) in time proportional to its cells. Otherwise, and where the field says no path
    exists (the reason named by the search), the A* search of
    :func:`jaxga.reference.optima.shortest_path_np`, cached for the last 32 problems.
    Both report the length as :func:`jaxga.reference.optima.octile_length`, so both give
    the same optimum bit for bit."""
    if guided and _connected(grid):  # else no field to compute: the search says why
        path = _field_path(grid)
        if path is not None:
            return ReferencePath(True, octile_length(path), path, kind="octile")
    return _octile_cached(*_problem_key(grid))


def _connected(grid: Grid) -> bool:
    """Whether the start reaches the goal (free, on the map, one region): a labelling of
    the map's regions, far cheaper than the distance fields of a problem with no path."""
    try:
        return endpoints_connected(grid)
    except JaxgaError:  # an endpoint off the map: the search names it
        return False


@functools.lru_cache(maxsize=8)
def _maximin_cached(digest: bytes, shape: tuple[int, int], blocked: bytes, start: tuple,
                    goal: tuple, corner_rule: str, obstacles: bytes | None) -> MaximinPath:
    del digest  # the cache key; the arguments are the data
    b = np.frombuffer(blocked, dtype=bool).reshape(shape)
    own = None if obstacles is None else np.frombuffer(obstacles, dtype=bool).reshape(shape)
    field = None if own is None else cell_clearance(own)
    found = maximin_path_np(b, start, goal, corner_rule, clearance=field)
    found.path.setflags(write=False)  # shared by every caller of the same problem
    return found


def maximin_reference(grid: Grid, obstacles: np.ndarray | None = None) -> MaximinPath:
    """The exact widest path of ``grid``'s problem (:func:`jaxga.reference.maximin.maximin_path`,
    the clearance to ``obstacles``, ``bool[H, W]`` in the grid's cells, by default its
    blocked cells), cached for the last 8 problems: a run of a front preset asks for it
    twice (its fields' band before the run, the result's ``maximin_clearance`` after it),
    and the search takes a fraction of a second on a 500 x 500 map. The result is
    shared: its path is read-only."""
    own = None if obstacles is None else np.ascontiguousarray(obstacles, dtype=bool)
    if own is not None and own.shape != grid.shape:
        return maximin_path(grid, obstacles=own)  # refused there, with its message
    return _maximin_cached(*_problem_key(grid), None if own is None else own.tobytes())


def _field_path(grid: Grid) -> np.ndarray | None:
    """:func:`jaxga.operators.guide.field_path` as ``(x, y)`` cells."""
    idx = field_path(grid)
    if idx is None:
        return None
    return np.stack([idx % grid.width, idx // grid.width], axis=1).astype(np.int32)


@dataclasses.dataclass(frozen=True)
class AnyAngleBounds:
    """The any-angle references of a problem.

    Attributes:
        optimum: the exact any-angle optimum (cell centres as vertices), NaN when not
            computed.
        lower_bound: the Euclidean lower bound of it, NaN when not computed.
        note: why :attr:`optimum` is missing ("" when it is computed), e.g.
            "any-angle optimum not computed (budget 0.52 s)".
        budget_s: the budget the search had (None: none).
        path: the optimal path's waypoints, ``int32[k, 2]`` ``(x, y)`` cells (empty when
            not computed).
    """

    optimum: float
    lower_bound: float
    note: str = ""
    budget_s: float | None = None
    path: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2), np.int32))


_CACHE: dict[bytes, AnyAngleBounds] = {}
_CACHE_SIZE = 32
_CACHE_LOCK = threading.Lock()  # threads planning at once evict one entry each


MEMORY_NOTE = "any-angle optimum not computed (its search ran out of memory: try --coarsen)"
"""The note of an any-angle search that ran out of memory."""
SKIPPED_NOTE = "any-angle optimum not computed (skipped: budget 0)"
"""The note of references skipped on purpose (a budget of 0: ``--no-reference``)."""


def budget_note(budget_s: float | None) -> str:
    """The one line that says the any-angle optimum was not computed within its budget."""
    return f"any-angle optimum not computed (budget {budget_s:.2f} s)"


def any_angle_references(grid: Grid, octile: ReferencePath, budget_s: float | None,
                         progress: Callable[[float], None] | None = None,
                         known_path: np.ndarray | None = None) -> AnyAngleBounds:
    """The any-angle optimum of ``grid``'s problem within ``budget_s`` seconds (None: no
    limit), and its Euclidean lower bound (computed first, within the same budget; it is
    cheap). ``octile`` is the problem's 8-connected optimum (its length bounds both
    searches); ``known_path``, a clear ``(x, y)`` path such as a run's best, tightens the
    exact search (:func:`jaxga.reference.any_angle.any_angle_shortest_path_np`).
    ``progress(fraction of the budget used)`` is called while they run."""
    out = _references(grid, octile, budget_s, progress, known_path)
    if progress is not None:
        progress(1.0)
    return out


def _references(grid: Grid, octile: ReferencePath, budget_s: float | None,
                progress: Callable[[float], None] | None,
                known_path: np.ndarray | None) -> AnyAngleBounds:
    """:func:`any_angle_references`' work, the cache first."""
    digest, shape, raw, start, goal, rule = _problem_key(grid)
    known = _CACHE.get(digest)
    if known is not None and (not known.note or (
            budget_s is not None and known.budget_s is not None
            and budget_s <= known.budget_s)):
        return known
    if not octile.found:
        return AnyAngleBounds(math.nan, math.nan, octile.reason, budget_s)
    if budget_s is not None and budget_s <= 0:  # skipped: neither search starts
        return AnyAngleBounds(math.nan, math.nan, SKIPPED_NOTE, 0.0)
    b = np.frombuffer(raw, dtype=bool).reshape(shape)
    t0 = time.perf_counter()

    def left() -> float | None:
        return None if budget_s is None else max(budget_s - (time.perf_counter() - t0), 0.0)

    try:
        bound = euclidean_lower_bound_np(b, start, goal, rule, upper=octile.length,
                                         budget_s=left())
        lower = bound.length if bound.found else math.nan
    except MemoryError:  # a reference is a measure, not the plan: say so and go on
        lower = math.nan
    if progress is not None and budget_s:
        progress(min((time.perf_counter() - t0) / budget_s, 1.0))
    try:
        exact = any_angle_shortest_path_np(b, start, goal, rule, budget_s=left(),
                                           known_path=known_path)
    except MemoryError:
        return AnyAngleBounds(math.nan, lower, MEMORY_NOTE, budget_s)  # not cached
    if exact.found:
        out = AnyAngleBounds(exact.length, lower, "", budget_s, np.asarray(exact.path))
    else:
        out = AnyAngleBounds(math.nan, lower, budget_note(budget_s), budget_s)
    with _CACHE_LOCK:
        while len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[digest] = out
    return out
