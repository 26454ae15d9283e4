"""A multi-objective result's fronts (decision 045): the :class:`Fronts` record and the
methods of :class:`~jaxga.api.result.Result` that read them (its points, its exact ends,
a chosen point)."""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxga._runtime.fields import measures_own_obstacles
from jaxga.core.errors import ParameterError
from jaxga.core.fields import python_scalar, shown_value


def json_number(x: float | None) -> float | None:
    """``x`` as a JSON number, or ``None`` (null) for None, NaN and infinities."""
    return None if x is None or not math.isfinite(x) else float(x)


FRONT_POINT_OBJECTIVE = {"shortest": "length", "widest": "clearance"}
"""The objective each named point of a front is chosen by (a number: a least clearance,
so ``clearance``); the knee is taken on any two objectives."""


def check_front_point(names: tuple[str, ...], which: str | float) -> None:
    """:class:`ParameterError`, in one line, where the point ``which`` of a front
    (:meth:`Result.front_point`, ``--front-point``) is chosen by an objective that the
    front's ``names`` (``survival.objectives``) do not hold."""
    need = "clearance" if not isinstance(which, str) else FRONT_POINT_OBJECTIVE.get(which)
    if need is not None and need not in names:
        raise ParameterError(
            f"the front point {which!r} is chosen by its {need}, which the front does not "
            f"minimise (survival.objectives = {list(names)}): add {need!r} to them or take "
            f"the knee")


def front_point_which(which: Any) -> str | float:
    """``which`` as :meth:`Result.front_point` takes it: ``"knee"``, ``"shortest"``,
    ``"widest"`` or a least clearance (:func:`least_clearance`), else a one-line
    :class:`ParameterError` (a string of digits, a bool, NaN or None would otherwise be
    read as another point, or as none)."""
    if isinstance(which, str) and (which == "knee" or which in FRONT_POINT_OBJECTIVE):
        return which
    if not isinstance(which, str):
        try:
            return least_clearance(which, "which")
        except ParameterError:
            pass
    raise ParameterError(f"which must be 'knee', 'shortest', 'widest' or a least clearance "
                         f"(a number >= 0), got {shown_value(which)}")


def least_clearance(value: Any, name: str = "min_clearance") -> float:
    """``value`` as a least clearance: a real number >= 0 (a NumPy or JAX scalar, a 0-d
    array of one, a fraction), as a float; a one-line :class:`ParameterError` naming
    ``name`` otherwise (a bool, a string, NaN)."""
    number = python_scalar(value)
    if not isinstance(number, bool) and isinstance(number, numbers.Real):
        number = float(number)
        if math.isfinite(number) and number >= 0:
            return number
    raise ParameterError(f"{name} must be a number >= 0, got {shown_value(value)}")


def knee(points: Any) -> int:
    """The index of the knee of ``points`` (``float[k, 2]``, two objectives, both
    minimised; a front's first two): among the points that no other beats in both, the
    one that lies farthest beyond the line between the two ends towards the ideal point
    (each objective scaled to those points' range), the trade-off that gives most of
    each; the end of least first objective (the shortest) where no point lies beyond the
    line, or where fewer than three points are left. A point of the front that another
    beats in these two (it is on the front for a third objective) is never the knee."""
    xy = np.array(points, float).reshape(-1, 2)
    for j in range(2):  # an objective without bound (a clearance with no obstacle): all tie
        col = xy[:, j]
        if not np.isfinite(col).all():
            finite = col[np.isfinite(col)]
            low, high = (finite.min() - 1, finite.max() + 1) if finite.size else (0, 0)
            xy[:, j] = np.where(col == -np.inf, low, np.where(col == np.inf, high, col))
    beaten = ((xy[None, :, :] <= xy[:, None, :]).all(-1)
              & (xy[None, :, :] < xy[:, None, :]).any(-1)).any(1)
    beaten |= np.isnan(xy).any(1)  # a point without a value is never the knee
    ends = np.flatnonzero(~beaten)
    if not len(ends):
        return 0
    ends = ends[np.lexsort((ends, xy[ends, 1], xy[ends, 0]))]  # shortest first
    if len(ends) < 3:
        return int(ends[0])
    z = xy[ends]
    span = np.ptp(z, axis=0)
    z = (z - z.min(axis=0)) / np.where(span > 0, span, 1.0)
    # scaled, the ends are (0, 1) and (1, 0) (points no other beats, shortest first),
    # the line x + y = 1 and the ideal point (0, 0) beyond it
    beyond = 1.0 - z[:, 0] - z[:, 1]
    best = int(np.argmax(beyond))
    return int(ends[best] if beyond[best] > 1e-9 else ends[0])


@dataclasses.dataclass(frozen=True)
class Fronts:
    """The fronts of a multi-objective preset's seeds (decision 045): every distinct
    non-dominated path of each seed's final population, in its slots (``mask``)."""

    names: tuple[str, ...]
    """The objectives (``survival.objectives``: :mod:`jaxga.core.robot_objectives`)."""
    mask: np.ndarray
    """bool[S, P]: the slot holds a point of the seed's front."""
    cells: np.ndarray
    """int32[S, P, L]: the paths, cell indices (8-connected, as evolved)."""
    n_cells: np.ndarray
    """int32[S, P]: their numbers of cells."""
    objectives: np.ndarray
    """float[S, P, M]: their objectives in cells and radians, as named (the clearance
    positive: the least clearance of the path's cells, the measure of the exact maximin
    clearance, :mod:`jaxga.reference.maximin`)."""
    initial_hypervolume: np.ndarray
    """float[S]: each seed's initial population's hypervolume, against the reference
    point of its history's ``hypervolume`` (fixed at initialisation)."""
    reference: np.ndarray | None = None
    """float[S, M]: each seed's reference point of its hypervolumes, as
    :attr:`objectives` (the clearance positive): each objective's worst value over the
    valid initial individuals moved a tenth of their range, plus ``1e-3 (1 + |worst|)``,
    further (:func:`jaxga.engine.evolution.hypervolume_reference`). The volume is of the
    points no longer than its length and no narrower than its clearance (of its
    turning, no more). None in a result saved before it was kept."""

    def gain(self, history: Mapping[str, np.ndarray]) -> np.ndarray:
        """float[S]: each seed's last hypervolume over its initial population's: what the
        generations added to the front (1: nothing)."""
        return history["hypervolume"][:, -1] / self.initial_hypervolume

    def points(self, i: int, width: int) -> list[dict[str, Any]]:
        """Seed ``i``'s front, shortest first (by its first objective where ``length`` is
        not one): each point's objectives by name and its path as ``(x, y)`` cells."""
        slots = np.flatnonzero(self.mask[i])
        first = self.names.index("length") if "length" in self.names else 0
        slots = slots[np.lexsort((slots, self.objectives[i, slots, first]))]
        return [{**{n: float(self.objectives[i, k, j]) for j, n in enumerate(self.names)},
                 "path": [(int(c) % width, int(c) // width)
                          for c in self.cells[i, k, :int(self.n_cells[i, k])]]}
                for k in slots]


class FrontsOfResult:
    """The front methods of :class:`~jaxga.api.result.Result` (its fields ``front``,
    ``frame``, ``success``, ``width``, ``gap``, ``history`` and ``maximin_clearance``, its
    :meth:`~jaxga.api.result.Result.seed_index`): every point of a seed's front, its
    ends against the exact ones, and one point chosen by name or clearance."""

    def front_points(self, i: int) -> list[dict[str, Any]]:
        """Seed ``i``'s front, shortest first (decision 045): each point's objectives in
        cells and radians (:attr:`Fronts.names`; the clearance positive), the length and
        clearance also in metres (``length_m``, ``clearance_m``) on a map with a
        resolution, and its ``path`` as ``(x, y)`` cells. Empty for a failed seed or a
        preset without a front."""
        i = self.seed_index(i)
        if self.front is None or not self.success[i]:
            return []
        cell = None if self.frame is None else self.frame.cell_size
        points = self.front.points(i, self.width)
        if cell:
            for p in points:
                p.update({f"{k}_m": p[k] * cell for k in ("length", "clearance") if k in p})
        return points

    def front_ends(self, i: int) -> dict[str, float | None]:
        """Seed ``i``'s front measured against the exact ends (decision 045):
        ``shortest_gap``, its shortest end post-optimised (the seed's best path) over
        the any-angle optimum (:attr:`gap`); ``widest_clearance`` and its share of the
        exact maximin clearance (``widest_ratio``, 1 where it keeps the widest path's
        clearance; None where no obstacle bounds that clearance, on a map without
        obstacles); ``points``; ``hypervolume_gain`` (:meth:`Fronts.gain`). Nones
        without a front."""
        i = self.seed_index(i)
        points = self.front_points(i)
        widest = max((p.get("clearance", math.nan) for p in points), default=math.nan)
        bound = self.maximin_clearance  # inf on a map without obstacles: no share of it
        ratio = widest / bound if 0 < bound < math.inf else math.nan
        gain = math.nan if self.front is None else float(self.front.gain(self.history)[i])
        return {"points": len(points), "shortest_gap": json_number(float(self.gap[i])),
                "widest_clearance": json_number(widest), "widest_ratio": json_number(ratio),
                "hypervolume_gain": json_number(gain)}

    def front_choice(self, i: int, min_clearance: float | None = None
                     ) -> dict[str, Any] | None:
        """One point of seed ``i``'s front: the shortest that keeps at least
        ``min_clearance`` cells from the obstacles (None when no point does), or by
        default the knee of its first two objectives (:func:`knee`).
        :class:`ParameterError` for ``min_clearance`` where the front does not minimise
        the clearance."""
        i = self.seed_index(i)
        if min_clearance is not None:
            min_clearance = least_clearance(min_clearance)
        if self.front is not None and min_clearance is not None:
            check_front_point(self.front.names, min_clearance)
        points = self.front_points(i)
        if not points:
            return None
        if min_clearance is not None:
            return next((p for p in points if p.get("clearance", 0.0) >= min_clearance),
                        None)
        names = self.front.names[:2]
        sign = [-1.0 if n == "clearance" else 1.0 for n in names]  # both minimised
        return points[knee([[s * p[n] for s, n in zip(sign, names)] for p in points])]

    def front_point(self, i: int, which: str | float = "knee") -> dict[str, Any] | None:
        """One point of seed ``i``'s front by name: ``"knee"`` (:meth:`front_choice`),
        ``"shortest"``, ``"widest"``, or a number: the shortest point that keeps at least
        that clearance, in metres on a map with a resolution, else in cells; None where
        the seed has no front or no point keeps it. :class:`ParameterError` where the
        front does not minimise the objective the point is chosen by
        (:func:`check_front_point`)."""
        i = self.seed_index(i)
        which = front_point_which(which)
        if self.front is not None:
            check_front_point(self.front.names, which)
        points = self.front_points(i)
        if not points:
            return None
        if which == "knee":
            return self.front_choice(i)
        if which == "shortest":
            return points[0]
        if which == "widest":
            return max(points, key=lambda p: (p["clearance"], -p["length"]))
        least = float(which)
        if self.frame is None or not self.frame.cell_size:
            return self.front_choice(i, min_clearance=least)
        # compared in metres: a point's own clearance_m, given back, keeps itself (its
        # metres divided by the cell size may round below its cells)
        return next((p for p in points if p["clearance_m"] >= least), None)

    def front_text(self) -> str:
        """The fronts in one line ("" without one): points per seed, the shortest end's
        gap, the widest end's share of the exact maximin clearance and what the
        generations added to the hypervolume (medians over the seeds that found a
        path)."""
        ok = np.flatnonzero(self.success)
        if self.front is None or ok.size == 0:
            return ""
        ends = [self.front_ends(int(i)) for i in ok]

        def median(key: str) -> float:
            values = [e[key] for e in ends if e[key] is not None]
            return float(np.median(values)) if values else math.nan

        cell = None if self.frame is None else self.frame.cell_size
        walls = ("map's obstacles (before inflation)" if measures_own_obstacles(self.frame)
                 else "blocked cells planned on")
        wide = median("widest_clearance")
        wide_text = f"{wide * cell:.3f} m" if cell else f"{wide:.2f} cells"
        ratio = median("widest_ratio")
        if self.maximin_clearance == math.inf:  # widest_clearance is None: no obstacle
            widest = "widest end: the map has no obstacle to keep clear of"
        else:
            share = ("no obstacle bounds the exact maximin clearance" if math.isnan(ratio)
                     else f"{ratio:.3f} of the exact maximin clearance")
            widest = f"widest end: its cells {wide_text} from the {walls}, {share}"
        return (f"front ({', '.join(self.front.names)}; medians over {ok.size} seeds): "
                f"{median('points'):g} points; shortest end {100 * median('shortest_gap'):.2f} "
                f"% over the any-angle optimum; {widest}; hypervolume "
                f"x{median('hypervolume_gain'):.3f} over the initial population's")

    def _front_json(self, i: int) -> dict[str, Any]:
        """Seed ``i``'s ``front`` (every point, paths as ``[x, y]`` lists) and
        ``front_ends``, for a preset with a front."""
        if self.front is None:
            return {}
        points = [{**{k: json_number(v) for k, v in p.items() if k != "path"},
                   "path": [list(c) for c in p["path"]]} for p in self.front_points(i)]
        out = {"front": points, "front_ends": self.front_ends(i)}
        if self.front.reference is not None:
            out["hypervolume_reference"] = {
                n: json_number(float(self.front.reference[self.seed_index(i), j]))
                for j, n in enumerate(self.front.names)}
        return out

