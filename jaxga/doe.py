"""Designed experiments over GA hyper-parameters (AGACD 5.2.1, eq. 30-31).

A :class:`Factor` is a configuration key with three levels coded -1, 0, 1 (low, mid,
high; AGACD Table 3). A design is an integer array ``coded[N, k]`` of coded levels, one
row per run ("point"): the orthogonal arrays L9 (3^4), L18 (the seven 3-level columns of
the standard L18, 2^1 x 3^7), L27 (3^13), the full factorial 3^k, and AGACD's own 9-run,
5-factor design (its Table 4). Factors take the first k columns of the array.

:func:`run_doe` runs every point x every seed in ONE compiled call of
:func:`jaxga.api.sweep` (the population size through the engine's active mask below a
capacity equal to the largest size of the design; every point sees the same seeds),
fits the linear prediction ``result = X0 + sum_i Xi * Fi`` (AGACD eq. 30) to the point
means by least squares, reports main effects (mean response per level of each factor),
picks the predicted best coded combination (each coefficient's sign: maximised for
fitness-like responses, minimised for length-like ones) and runs it as a confirmation run
with the same seeds (AGACD: predicted 0.28995, measured 0.30684).

With ``checkpoint=DIR`` the points run in blocks of ``block`` points per compiled call
and each finished point is written to ``DIR`` at once (temp file + ``os.replace``); a
restarted run with the same arguments skips the finished points. Every block uses the
design's population capacity and the same number of runs (the last block is padded with
copies of its last point), so one compiled program serves every block and a resumed run
is bit for bit the uninterrupted run with the same ``block``. Another ``block`` runs the
same GA runs (fitness, success, turns, convergence generation identical in the tests) but
the float32 lengths and angle sums of the post-optimised paths may differ in the last bit
(XLA rounds its vectorised reductions differently for another number of runs per call);
``block`` is therefore part of the checkpoint's fingerprint.
``DIR/manifest.json`` records what was run (preset configuration, map, factors, design,
seeds, block, versions); a checkpoint written by another configuration is refused.
With several processes (``jaxga doe --coordinator ...``, :mod:`jaxga.api.parallel`) every
block is split over the processes; process 0 alone reads and writes ``DIR`` and tells
the others which points are finished, so ``DIR`` need only be on process 0's disk. A lost
process loses the block being computed, never a finished point: the restarted command
completes the rest.

Decisions where AGACD and the issue are silent:

* Failed seeds (no feasible path): their ``fitness`` is 0 (what the engine reports for
  an individual without a feasible path) and ``success`` 0, so these responses average
  over all seeds; the length-like responses (``length``, ``raw_length``, ``turns``,
  ``smoothness`` = ``angle_sum`` of the post-optimised path, ``convergence_generation``)
  exclude failed seeds (``None`` in the JSON, NaN in arrays) and every point reports its
  number of successful seeds. A point without any successful seed has no mean and is
  left out of the fit (the fit is refused if too few points remain).
* The fit uses the point means (each point weighted equally, as AGACD Table 5 does).
  AGACD's own coefficients (eq. 31) are the contrasts ``mean_p(F_ip * y_p)`` rather than
  least squares; :func:`contrast_coefficients` reproduces them from its Table 5. On an
  orthogonal design with balanced levels the two differ by the factor 2/3 =
  ``mean(F^2)``; AGACD's Table 4 design is not orthogonal (its pm_high column is a
  relabelling of pc_high's), so there they differ more.
* A zero coefficient (within round-off: ``|Xi| <= 1e-10 max|X|``) puts its factor at the
  middle level in the predicted best.
* The checkpoint fingerprint leaves out the response and direction: the design points
  store every response per seed, and the confirmation run is stored per coded
  combination, so a finished checkpoint can be re-analysed for another response.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np

import jaxga
from jaxga import api
from jaxga.api import checked_capacity, load_problem, parallel, seed_list
from jaxga.config.presets import as_sets, overridden_keys
from jaxga.config.schema import SCHEMA, Config, parse_value, python_scalar
from jaxga.core.errors import NoPathError, ParameterError
from jaxga.core.files import atomic_write
from jaxga.core.grid import Grid, as_integer
from jaxga.engine import build, check_combination, unread_keys
from jaxga.reference.optima import shortest_path

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
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParameterError(
                    f"factor {self.name}: levels must be finite numbers, got {list(self.levels)}")
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
        values = [parse_value(v.strip()) for v in rest.split(",")]
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
    objective's default is read), either dynamic (probabilities, weights, temperatures:
    :data:`jaxga.config.schema.SCHEMA`) or ``population.size`` (the engine's active mask); names
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
        if not (SCHEMA[f.name].dynamic or f.name == "population.size"):
            raise ParameterError(
                f"factor {f.name!r} changes the compiled program: only dynamic keys "
                "(probabilities, weights, temperatures) and population.size can be "
                "factors; run the other values as separate experiments")
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
MAX_FULL_FACTORIAL_POINTS = 3 ** 8


def design_array(design: str, n_factors: int) -> np.ndarray:
    """Coded levels ``int8[N, n_factors]`` of ``design``: the first ``n_factors`` columns
    of an orthogonal array (or AGACD Table 4), or the full factorial 3^k (first factor
    slowest)."""
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
    return arr[:, :n_factors].copy()


def design_points(factors: Sequence[Factor], coded: np.ndarray) -> list[dict[str, Any]]:
    """The real values ``{factor name: value}`` of each row of coded levels."""
    return [{f.name: f.value(int(c)) for f, c in zip(factors, row)} for row in coded]


# ----------------------------------------------------------------------------- analysis

RESPONSE_ALIASES: dict[str, str] = {"angle_sum": "smoothness"}
"""Other names of a response: ``angle_sum`` is what :func:`jaxga.run`'s summary and
``jaxga compare`` call the smoothness (AGACD eq. 10-17)."""

RESPONSES: dict[str, str] = {
    "fitness": "max",
    "success": "max",
    "length": "min",
    "raw_length": "min",
    "convergence_generation": "min",
    "turns": "min",
    "smoothness": "min",
}
"""Responses a DOE can optimise, with their default direction."""


def seed_responses(result: Any) -> dict[str, np.ndarray]:
    """Every response of every seed of a :class:`jaxga.api.Result` (float arrays).

    ``fitness`` of a failed seed is 0 and ``success`` is 0/1; the length-like responses
    are NaN for failed seeds (see the module docstring).
    """
    ok = np.asarray(result.success, bool)

    def only_ok(v) -> np.ndarray:
        return np.where(ok, np.asarray(v, float), np.nan)

    metrics = result.metrics or {}
    nan = np.full(ok.shape, np.nan)
    return {
        "fitness": np.where(ok, np.asarray(result.fitness, float), 0.0),
        "success": ok.astype(float),
        "length": only_ok(result.length),
        "raw_length": only_ok(result.raw_length),
        "convergence_generation": only_ok(result.convergence_generation),
        "turns": only_ok(metrics.get("turns", nan)),
        "smoothness": only_ok(metrics.get("angle_sum", nan)),
    }


def point_means(responses: np.ndarray) -> np.ndarray:
    """Mean over the seeds of each point, ignoring NaN (failed seeds of a length-like
    response); NaN for a point without any value."""
    r = np.asarray(responses, float)
    n = np.sum(~np.isnan(r), axis=1)
    s = np.nansum(r, axis=1)
    return np.where(n > 0, s / np.maximum(n, 1), np.nan)


def fit_linear(coded: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares ``[X0, X1, ..., Xk]`` of ``y = X0 + sum_i Xi * F_i`` (AGACD eq. 30)
    over the rows with a finite ``y`` (``numpy.linalg.lstsq``).

    Raises :class:`ParameterError` when the remaining rows do not determine the
    coefficients (fewer rows than coefficients, or a rank-deficient design)."""
    coded = np.asarray(coded, float)
    y = np.asarray(y, float)
    keep = np.isfinite(y)
    X = np.column_stack([np.ones(int(keep.sum())), coded[keep]])
    if X.shape[0] < X.shape[1]:
        raise ParameterError(
            f"only {X.shape[0]} design points have a response, too few to fit "
            f"{X.shape[1]} coefficients")
    coef, _, rank, _ = np.linalg.lstsq(X, y[keep], rcond=None)
    if rank < X.shape[1]:
        raise ParameterError(
            "the design points with a response do not determine the linear fit "
            f"(rank {rank} < {X.shape[1]})")
    return coef


def contrast_coefficients(coded: np.ndarray, y: np.ndarray) -> np.ndarray:
    """AGACD's own estimate (its Table 5, last row): ``X0 = mean(y)``,
    ``Xi = mean(F_i * y)``. Not least squares: see the module docstring."""
    coded = np.asarray(coded, float)
    y = np.asarray(y, float)
    return np.concatenate([[y.mean()], (coded * y[:, None]).mean(axis=0)])


def main_effects(coded: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``[k, 3]``: mean of the point means at coded level -1, 0, 1 of each factor
    (points without a mean left out; NaN for a level without points)."""
    coded = np.asarray(coded)
    y = np.asarray(y, float)
    out = np.full((coded.shape[1], 3), np.nan)
    for i in range(coded.shape[1]):
        for j, level in enumerate((-1, 0, 1)):
            v = y[(coded[:, i] == level) & np.isfinite(y)]
            if v.size:
                out[i, j] = v.mean()
    return out


def predicted_best(coef: np.ndarray, direction: str) -> tuple[np.ndarray, float]:
    """The coded combination that maximises (``"max"``) or minimises (``"min"``) the
    fitted linear prediction, and its predicted value (AGACD: eq. 31 is maximal at
    X1 = X2 = X4 = X5 = 1, X3 = -1, predicted 0.28995)."""
    if direction not in ("max", "min"):
        raise ParameterError(f"direction must be 'max' or 'min', got {direction!r}")
    sign = 1.0 if direction == "max" else -1.0
    slopes = np.asarray(coef[1:], float)
    # round-off zeros (an exactly flat factor fits as +-1e-18) count as zero
    zero = np.abs(slopes) <= 1e-10 * max(float(np.abs(coef).max()), 1e-300)
    best = np.where(zero, 0.0, np.sign(slopes) * sign).astype(np.int8)
    return best, float(coef[0] + np.dot(slopes, best))


# ----------------------------------------------------------------------------- results


def _json_float(v: float) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


@dataclasses.dataclass
class DoeResult:
    """A finished designed experiment (see :func:`run_doe`)."""

    preset: str
    map_name: str
    design: str
    response: str
    direction: str
    factors: tuple[Factor, ...]
    seeds: np.ndarray
    coded: np.ndarray  # int8[N, k]
    responses: np.ndarray  # float[N, S] of ``response`` (NaN = excluded failed seed)
    all_responses: dict[str, np.ndarray]  # every response, float[N, S]
    coefficients: np.ndarray  # [X0, X1..Xk], least squares
    best_coded: np.ndarray
    predicted: float
    confirmation: np.ndarray  # float[S]
    confirmation_all: dict[str, np.ndarray]
    timing: dict[str, float]
    config: Config | None = None
    """The resolved configuration that every point overrides with its factor levels."""
    population_capacity: int = 0
    """Individuals per island of every point's and the confirmation's compiled program
    (the largest ``population.size`` of the design): ``jaxga.run(...,
    population_capacity=...)`` with a point's values repeats its runs bit for bit."""
    corner_rule: str = ""
    """The corner rule the design ran under (the map's own unless one was named)."""

    @property
    def values(self) -> list[dict[str, Any]]:
        """Real values of every design point."""
        return design_points(self.factors, self.coded)

    @property
    def means(self) -> np.ndarray:
        """Mean response of each point (failed seeds of length-like responses left out)."""
        return point_means(self.responses)

    @property
    def n_success(self) -> np.ndarray:
        """Successful seeds per point."""
        return self.all_responses["success"].sum(axis=1).astype(int)

    @property
    def main_effects(self) -> np.ndarray:
        """``[k, 3]`` mean response at coded level -1, 0, 1 of each factor."""
        return main_effects(self.coded, self.means)

    @property
    def confirmation_mean(self) -> float:
        """Mean response of the confirmation run."""
        return float(point_means(self.confirmation[None])[0])

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` layout of ``jaxga doe`` (docs/cli.md), plus ``design``,
        ``direction``, ``seeds``, ``n_success`` per point and ``main_effects``."""
        names = [f.name for f in self.factors]
        best_values = {f.name: f.value(int(c)) for f, c in zip(self.factors, self.best_coded)}
        return {
            "preset": self.preset,
            "map": self.map_name, "corner_rule": self.corner_rule,
            "response": self.response,
            "direction": self.direction,
            "design": self.design,
            "seeds": [int(s) for s in self.seeds],
            "factors": {f.name: list(f.levels) for f in self.factors},
            "points": [
                {"coded": {n: int(c) for n, c in zip(names, row)},
                 "values": vals,
                 "responses": [_json_float(v) for v in resp],
                 "mean": _json_float(m),
                 "n_success": int(ns)}
                for row, vals, resp, m, ns in zip(self.coded, self.values, self.responses,
                                                   self.means, self.n_success)
            ],
            "coefficients": {"X0": float(self.coefficients[0]),
                             **{n: float(c) for n, c in zip(names, self.coefficients[1:])}},
            "main_effects": {n: [_json_float(v) for v in row]
                             for n, row in zip(names, self.main_effects)},
            "predicted_best": {"coded": {n: int(c) for n, c in zip(names, self.best_coded)},
                               "values": best_values, "predicted": float(self.predicted)},
            "confirmation": {"responses": [_json_float(v) for v in self.confirmation],
                             "mean": _json_float(self.confirmation_mean),
                             "n_success": int(self.confirmation_all["success"].sum())},
            "timing": {k: float(v) for k, v in self.timing.items()},
            "generations": None if self.config is None else int(self.config["generations"]),
            "population_capacity": self.population_capacity,
            "config": None if self.config is None else self.config.as_dict(),
        }

    def table(self) -> str:
        """The design with its results in the layout of AGACD Table 5: run number, coded
        levels, real values, one column per seed ("trial") and the mean."""
        names = [f.name for f in self.factors]
        short = column_names(names)
        trials = [f"trial {i + 1}" for i in range(len(self.seeds))]
        head = (["no."] + [f"X{i + 1}" for i in range(len(names))] + short + trials
                + [f"mean {self.response}", "ok"])
        rows = []
        for p, (row, vals, resp, m, ns) in enumerate(zip(
                self.coded, self.values, self.responses, self.means, self.n_success)):
            rows.append([str(p + 1)] + [f"{int(c):d}" for c in row]
                        + [f"{vals[n]:g}" for n in names]
                        + [_fmt(v) for v in resp] + [_fmt(m), f"{ns}/{len(self.seeds)}"])
        widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
        lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths))]
        lines += ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in rows]
        return "\n".join(lines)

    def equation(self) -> str:
        """The fitted prediction in AGACD's eq. 31 form."""
        c = self.coefficients
        terms = [f"{c[0]:.5f}"]
        for i, x in enumerate(c[1:]):
            terms.append(f"{'-' if x < 0 else '+'} X{i + 1} * {abs(x):.5f}")
        legend = ", ".join(f"X{i + 1} = {f.name}" for i, f in enumerate(self.factors))
        return f"{self.response} = " + " ".join(terms) + f"   ({legend})"

    def report(self) -> str:
        """Table, fitted equation, main effects, predicted best, confirmation, timing."""
        names = [f.name for f in self.factors]
        lines = [
            f"DOE {self.design} on preset {self.preset}, map {self.map_name} (corner rule "
            f"{self.corner_rule!r}): "
            f"{len(self.coded)} points x {len(self.seeds)} seeds, response {self.response} "
            f"({'maximised' if self.direction == 'max' else 'minimised'})",
            self.table(), "", "fitted (least squares): " + self.equation(), "",
            "main effects (mean response at coded level -1, 0, 1):",
        ]
        for n, row in zip(names, self.main_effects):
            lines.append(f"  {n:24s} " + "  ".join(f"{_fmt(v):>10s}" for v in row))
        best = ", ".join(f"{n} = {f.value(int(c)):g} ({int(c):+d})"
                         for n, f, c in zip(names, self.factors, self.best_coded))
        lines += [
            "", f"predicted best: {best}",
            f"predicted {self.predicted:.5f}, confirmation run measured "
            f"{_fmt(self.confirmation_mean)} (per seed: "
            + ", ".join(_fmt(v) for v in self.confirmation) + ")",
            _timing_line(self.timing),
        ]
        return "\n".join(lines)


def _timing_line(timing: Mapping[str, float]) -> str:
    """The report's time line. The compile time is part of the design points' and the
    confirmation run's times (each sweep call compiles, or finds its programs compiled),
    so the line says so instead of listing four parts that do not add up."""
    t = {k: float(v) for k, v in timing.items()}
    return (f"time (s): total {t['total_s']:.2f} = design points {t['sweep_s']:.2f}"
            f" + confirmation {t['confirmation_s']:.2f} + the rest (checks, fit)"
            f"; compiling took {t['compile_s']:.2f} of the first two")


def column_names(keys: Sequence[str]) -> list[str]:
    """Table headers for configuration keys: the last part of each key
    (``crossover.pc_low`` -> ``pc_low``), or the whole key where two would read alike
    (``crossover.probability`` and ``mutation.probability``)."""
    last = [k.split(".")[-1] for k in keys]
    return [k if last.count(s) > 1 else s for k, s in zip(keys, last)]


def _fmt(v: float) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.5g}"


# ----------------------------------------------------------------------------- checkpoint


def _atomic_write_json(path: Path, data: Any) -> None:
    """Write JSON to ``path`` atomically (:func:`jaxga.core.files.atomic_write`): a killed
    process leaves either the old file or the new one."""
    atomic_write(path, lambda f: json.dump(data, f))


def _map_fingerprint(grid: Grid, name: str) -> dict[str, Any]:
    blocked = np.ascontiguousarray(grid.blocked_np(), dtype=np.uint8)
    return {"name": name, "width": int(grid.width), "height": int(grid.height),
            "start": list(grid.start_xy), "goal": list(grid.goal_xy),
            "corner_rule": grid.corner_rule,
            "blocked_sha256": hashlib.sha256(blocked.tobytes()).hexdigest()}


class _Checkpoint:
    """A directory of finished points: ``manifest.json``, ``point-NNNN.json``,
    ``confirm_<coded>.json``."""

    def __init__(self, directory: str | Path, manifest: dict[str, Any]) -> None:

        self.dir = Path(directory)
        config = manifest.get("config")
        self.generations = config.get("generations") if isinstance(config, dict) else None
        # Several processes (jaxga.api.parallel): process 0 alone reads and writes the
        # checkpoint; the others receive what it read (and its refusal) by broadcast, so
        # every process agrees on which points remain even without a shared filesystem.
        self.lead = parallel.process_index() == 0
        error = self._check(manifest) if self.lead else None
        error = parallel.broadcast(error)
        if error:
            raise ParameterError(error)

    def _check(self, manifest: dict[str, Any]) -> str | None:
        """Validate (or create) the manifest; the refusal message, or None."""
        if self.dir.exists() and not self.dir.is_dir():
            return f"checkpoint {self.dir} is a file, not a directory"
        self.dir.mkdir(parents=True, exist_ok=True)
        path = self.dir / "manifest.json"
        if path.exists():
            try:
                old = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError, RecursionError) as e:
                return f"checkpoint {self.dir}: unreadable manifest: {e}"
            if old != manifest:
                keys = sorted(k for k in old.keys() | manifest.keys()
                              if old.get(k) != manifest.get(k))
                return (f"checkpoint {self.dir} was written by a different configuration "
                        f"(differs in {', '.join(keys)}); use another directory or delete it")
        else:
            if any(self.dir.glob("point-*.json")):
                return f"checkpoint {self.dir} has points but no manifest"
            _atomic_write_json(path, manifest)
        return None

    def _point(self, q: int) -> Path:
        return self.dir / f"point-{q:04d}.json"

    def _read(self, path: Path, n_seeds: int) -> dict[str, list]:
        """The responses saved in ``path``, checked: every response, one value (a number
        or null) per seed; ``ParameterError`` naming the file otherwise."""
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError) as e:
            raise ParameterError(f"checkpoint file {path} is unreadable ({e}): delete it "
                                 f"and run again to recompute it") from None
        responses = data.get("responses") if isinstance(data, dict) else None
        ok = (isinstance(responses, dict) and set(responses) == set(RESPONSES)
              and all(isinstance(v, list) and len(v) == n_seeds
                      and all(x is None or x in _INFINITIES
                              or (isinstance(x, (int, float)) and not isinstance(x, bool))
                              for x in v)
                      for v in responses.values()))
        if not ok:
            raise ParameterError(
                f"checkpoint file {path} does not hold the responses ({', '.join(RESPONSES)}) "
                f"of {n_seeds} seeds: delete it and run again to recompute it")
        wrong = _impossible_response(responses, self.generations)
        if wrong:
            raise ParameterError(f"checkpoint file {path} holds an impossible value: {wrong}; "
                                 "delete it and run again to recompute it")
        reason = data.get("reason", "")
        if not isinstance(reason, str):
            raise ParameterError(f"checkpoint file {path}: reason must be a string, got "
                                 f"{reason!r}; delete it and run again to recompute it")
        return {**responses, "reason": reason}

    def _broadcast_read(self, paths: list[Path], n_seeds: int) -> list[dict[str, list] | None]:
        """Process 0 reads (None for files not written yet); every process gets its result
        or its refusal."""

        saved, error = None, None
        if self.lead:
            try:
                saved = [self._read(p, n_seeds) if p.exists() else None for p in paths]
            except ParameterError as e:
                error = str(e)
        saved, error = parallel.broadcast((saved, error))
        if error:
            raise ParameterError(error)
        return saved

    def load_points(self, n: int, n_seeds: int) -> list[dict[str, list] | None]:
        """The saved responses of points ``0..n-1`` (None where not finished yet), as
        process 0 read them."""
        return self._broadcast_read([self._point(q) for q in range(n)], n_seeds)

    def save_point(self, q: int, responses: dict[str, np.ndarray], reason: str = "") -> None:
        """Write point ``q``'s responses and, if some seeds found no path, why."""
        if self.lead:
            _atomic_write_json(self._point(q), {"point": q, "responses": _encode(responses),
                                                "reason": reason})

    def _confirm(self, coded: np.ndarray) -> Path:
        return self.dir / ("confirm_" + "_".join(f"{int(c):+d}" for c in coded) + ".json")

    def load_confirmation(self, coded: np.ndarray, n_seeds: int) -> dict[str, list] | None:
        return self._broadcast_read([self._confirm(coded)], n_seeds)[0]

    def save_confirmation(self, coded: np.ndarray, responses: dict[str, np.ndarray]) -> None:
        if self.lead:
            _atomic_write_json(self._confirm(coded), {"coded": [int(c) for c in coded],
                                                      "responses": _encode(responses)})


_INTEGER_RESPONSES = ("convergence_generation", "turns")
_LENGTH_LIKE = ("length", "raw_length", "convergence_generation", "turns", "smoothness")


def _impossible_response(responses: Mapping[str, list], generations: int | None = None
                         ) -> str:
    """What no run can have returned (what :func:`seed_responses` makes of a Result), as
    text naming the response and seed; "" if every value is possible. A success is 0 or
    1; a failed seed has fitness 0 and no length-like value (null); a successful one has
    a fitness >= 0 (+inf when extreme weights overflow float32) and finite length-like
    values >= 0, whole numbers for the generation (at most ``generations``) and the
    turns."""
    for s, ok in enumerate(responses["success"]):
        if ok not in (0, 1):
            return f"success of seed {s} is {ok!r}, not 0 or 1"
        fit = _INFINITIES.get(responses["fitness"][s], responses["fitness"][s])
        if fit is None or math.isnan(fit) or fit < 0 or (fit != 0 and not ok):
            return (f"fitness of seed {s} is {fit!r} for a "
                    f"{'successful' if ok else 'failed'} seed")
        for key in _LENGTH_LIKE:
            v = responses[key][s]
            if isinstance(v, str):  # "inf": only a fitness can overflow
                return f"{key} of seed {s} is {v!r}"
            if not ok:
                if v is not None:
                    return f"{key} of the failed seed {s} is {v!r}, not null"
                continue
            if v is None or not math.isfinite(v) or v < 0 \
                    or (key in _INTEGER_RESPONSES and v != int(v)):
                return f"{key} of seed {s} is {v!r}"
            if key == "convergence_generation" and generations is not None \
                    and v > generations:
                return f"{key} of seed {s} is {v!r}, after the last of {generations}"
    return ""


_INFINITIES = {"inf": math.inf, "-inf": -math.inf}


def _encode(responses: Mapping[str, np.ndarray]) -> dict[str, list]:
    """NaN -> null, +-inf -> "inf" / "-inf" (a fitness can overflow float32 with extreme
    weights); Python floats round-trip exactly through JSON."""
    def one(x: float):
        return ("inf" if x > 0 else "-inf") if math.isinf(x) else _json_float(x)

    return {k: [one(float(x)) for x in v] for k, v in responses.items()}


def _decode(responses: Mapping[str, list]) -> dict[str, np.ndarray]:
    return {k: np.array([np.nan if x is None else _INFINITIES.get(x, x) for x in v], float)
            for k, v in responses.items() if k in RESPONSES}


# ----------------------------------------------------------------------------- running


def run_doe(
    preset: str | Config,
    grid: Grid | str,
    factors: Sequence[Factor],
    design: str = "agacd-table4",
    seeds: int | Sequence[int] = 5,
    *,
    response: str = "fitness",
    direction: str | None = None,
    generations: int | None = None,
    corner_rule: str | None = None,
    variant: str | None = None,
    sets: Sequence[str] = (),
    checkpoint: str | Path | None = None,
    block: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    **overrides: Any,
) -> DoeResult:
    """Run a designed experiment (AGACD 5.2.1) and its confirmation run.

    Args:
        preset, grid, generations, corner_rule, variant, sets, overrides: as in
            :func:`jaxga.api.run`; the factors are applied on top.
        factors: the :class:`Factor` s, assigned to the first columns of ``design``.
        design: one of :data:`DESIGNS`.
        seeds: a count or explicit seeds; every point and the confirmation run use them.
        response: one of :data:`RESPONSES` (``"angle_sum"`` is ``"smoothness"``);
            ``direction`` (``"max"`` / ``"min"``) overrides its default.
        checkpoint: a directory for a resumable run (see the module docstring).
        block: design points per compiled call; default all of them (one call) without
            a checkpoint, 1 with one.
        progress: optional callback ``(points done, points total)``.

    Returns:
        A :class:`DoeResult` (``to_json()`` is the ``jaxga doe --json`` layout).

    Raises:
        ParameterError: a factor, level or key combination of some design point is
            invalid (checked for every point before the first one runs).
        NoPathError: the goal is unreachable, or no seed of any design point found a
            path (nothing to fit; the message carries the runs' reason).
    """
    t_start = time.perf_counter()
    response, direction = _checked_response(response, direction)
    plan = _plan(preset, grid, factors, design, seeds, generations, corner_rule, variant,
                 sets, checkpoint, block, progress, overrides)
    results, reasons, sweep_s, compile_s = _run_points(plan, preset, grid, progress)
    all_responses = {k: np.stack([r[k] for r in results]) for k in results[0]}
    if not np.any(all_responses["success"]):  # nothing to fit: say why
        raise NoPathError("no seed of any design point found a path"
                          + "".join(f"; {r}" for r in reasons[:2]))
    coef = fit_linear(plan.coded, point_means(all_responses[response]))
    best, predicted = predicted_best(coef, direction)
    t0 = time.perf_counter()
    confirm, confirm_compile_s = _confirm(plan, preset, grid, best)
    confirm_s = time.perf_counter() - t0
    return DoeResult(
        preset=plan.config["name"], map_name=plan.map_name, design=design,
        response=response, direction=direction, factors=plan.factors, seeds=plan.seeds,
        coded=plan.coded, responses=all_responses[response], all_responses=all_responses,
        coefficients=coef, best_coded=best, predicted=predicted,
        confirmation=confirm[response], confirmation_all=confirm,
        timing={"compile_s": compile_s + confirm_compile_s, "sweep_s": sweep_s,
                "confirmation_s": confirm_s, "total_s": time.perf_counter() - t_start},
        config=plan.config, population_capacity=plan.capacity,
        corner_rule=plan.loaded.corner_rule,
    )


def _checked_response(response: Any, direction: str | None) -> tuple[str, str]:
    """The response's name (an alias replaced) and the direction of its optimum."""
    response = RESPONSE_ALIASES.get(response, response) if isinstance(response, str) \
        else response
    if response not in RESPONSES:
        raise ParameterError(f"unknown response {response!r}: one of {', '.join(RESPONSES)}")
    direction = direction or RESPONSES[response]
    if direction not in ("max", "min"):
        raise ParameterError(f"direction must be 'max' or 'min', got {direction!r}")
    return response, direction


@dataclasses.dataclass(frozen=True)
class _DoePlan:
    """A designed experiment, checked before any point runs: its configuration and map,
    the design (coded levels and the points' settings), the seeds, the points per
    compiled call, the options every call shares and the checkpoint."""

    config: Config
    loaded: Grid
    map_name: str
    factors: tuple[Factor, ...]
    coded: np.ndarray
    points: list[dict]
    capacity: int
    block: int
    seeds: np.ndarray
    common: dict
    checkpoint: _Checkpoint | None


def _plan(preset, grid, factors, design, seeds, generations, corner_rule, variant, sets,
          checkpoint, block, progress, overrides) -> _DoePlan:
    """Check every argument and every design point's key combination; the
    :class:`_DoePlan` of :func:`run_doe`."""
    sets = as_sets(sets)  # one string is one set
    if not isinstance(factors, (str, bytes, Mapping)) and isinstance(factors, Iterable):
        factors = tuple(factors)
    if not isinstance(factors, tuple) or not all(isinstance(f, Factor) for f in factors):
        raise ParameterError(f"factors must be a list of jaxga.doe.Factor (Factor(name, "
                             f"(low, mid, high)) or Factor.parse('NAME=LOW,MID,HIGH')), got "
                             f"{factors!r}")
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable (done, total), got {progress!r}")
    if checkpoint is not None and not isinstance(checkpoint, (str, os.PathLike)):
        raise ParameterError(f"checkpoint must be a directory path, got {checkpoint!r}")
    if block is not None:
        try:
            block = as_integer(block)
        except TypeError:
            raise ParameterError(f"block must be an integer >= 1, got {block!r}") from None
    config, loaded, map_name, _ = load_problem(preset, grid, corner_rule, variant, sets,
                                               overrides, generations)
    check_factors(config, factors)
    overridden = overridden_keys(overrides, sets)
    both = [f.name for f in factors if f.name in overridden]
    if both:
        raise ParameterError(f"{', '.join(both)} is both a factor and an override: the "
                             "factor's levels would replace the override")
    coded = design_array(design, len(factors))
    points = design_points(factors, coded)
    point_configs = [config.override(p) for p in points]
    for c in point_configs:  # key combinations of every point, before any point runs
        check_combination(c)
    capacity = checked_capacity(point_configs, None)  # the largest size
    if block is None:
        block = 1 if checkpoint is not None else len(points)
    if block < 1:
        raise ParameterError(f"block must be >= 1 design point, got {block}")
    block = min(int(block), len(points))
    # only a block of points is in memory at a time (between blocks, a few floats per seed)
    largest, _ = build(config.override({"population.size": capacity}), loaded)
    seed_arr = seed_list(seeds, lambda n: api.check_result_memory(n * block, largest))
    shortest_path(loaded).raise_if_missing()  # nothing to fit: say why (NoPathError)
    common = dict(generations=generations, corner_rule=corner_rule, variant=variant,
                  sets=tuple(sets), population_capacity=capacity, **overrides)
    ckpt = None
    if checkpoint is not None:
        ckpt = _Checkpoint(checkpoint, {
            "format": 1,
            "jaxga": jaxga.__version__,
            "jax": jax.__version__,
            "config": config.as_dict(),
            "map": _map_fingerprint(loaded, map_name),
            "design": design,
            "coded": coded.tolist(),
            "factors": {f.name: list(f.levels) for f in factors},
            "seeds": [int(s) for s in seed_arr],
            "block": block,
            "capacity": capacity,
        })
    return _DoePlan(config, loaded, map_name, factors, coded, points, capacity, block,
                    seed_arr, common, ckpt)


def _run_points(plan: _DoePlan, preset, grid, progress) -> tuple:
    """Every design point's per-seed responses, ``block`` points per compiled call, the
    points a checkpoint holds read instead of run: ``(responses per point, reasons the
    seeds found no path, sweep seconds, compile seconds)``."""
    n_points = len(plan.points)
    results: list[dict[str, np.ndarray] | None] = [None] * n_points
    reasons: list[str] = []  # why the seeds of the points found no path
    if plan.checkpoint is not None:
        for q, saved in enumerate(plan.checkpoint.load_points(n_points, len(plan.seeds))):
            if saved is not None:
                results[q] = _decode(saved)
                if saved["reason"] and saved["reason"] not in reasons:
                    reasons.append(saved["reason"])
    done = sum(r is not None for r in results)
    if progress is not None:
        progress(done, n_points)
    sweep_s = compile_s = 0.0
    for b0 in range(0, n_points, plan.block):
        idx = list(range(b0, min(b0 + plan.block, n_points)))
        if all(results[q] is not None for q in idx):
            continue
        padded = idx + [idx[-1]] * (plan.block - len(idx))  # same run count in every call
        t0 = time.perf_counter()
        out = api.sweep(preset, grid, [plan.points[q] for q in padded], plan.seeds,
                        **plan.common)
        sweep_s += time.perf_counter() - t0
        compile_s += out[0].timing["compile_s"]
        for q, res in zip(idx, out):
            if results[q] is None:
                results[q] = seed_responses(res)
                if res.reason and res.reason not in reasons:
                    reasons.append(res.reason)
                if plan.checkpoint is not None:
                    plan.checkpoint.save_point(q, results[q], res.reason)
                done += 1
        if progress is not None:
            progress(done, n_points)
    return results, reasons, sweep_s, compile_s


def _confirm(plan: _DoePlan, preset, grid, best: np.ndarray) -> tuple[dict, float]:
    """The confirmation run at the predicted best combination (AGACD 5.2.1), with the
    design's seeds, or the checkpoint's: ``(per-seed responses, compile seconds)``."""
    saved = (plan.checkpoint.load_confirmation(best, len(plan.seeds))
             if plan.checkpoint is not None else None)
    if saved is not None:
        return _decode(saved), 0.0
    best_point = {f.name: f.value(int(c)) for f, c in zip(plan.factors, best)}
    res = api.sweep(preset, grid, [best_point], plan.seeds, **plan.common)[0]
    confirm = seed_responses(res)
    if plan.checkpoint is not None:
        plan.checkpoint.save_confirmation(best, confirm)
    return confirm, res.timing["compile_s"]
