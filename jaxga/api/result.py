"""What a run returns: :class:`Result`, per-seed paths, metrics and gaps to the exact optima.

SPEC 11. Lengths, fitness and gaps per seed; :func:`summarise` over seeds; JSON numbers
for the command line's files.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxga.config.schema import Config
from jaxga.engine import (
    uses_waypoints,
)

SUMMARY_METRICS = ("length", "raw_length", "angle_sum", "turns", "fitness",
                   "convergence_generation")


GAPS = ("gap", "raw_gap", "fitness_gap")


GAP_TOLERANCE = 1e-6
"""Relative gaps smaller than this are reported as exactly 0: path lengths are summed in
float32 on the device, so an optimal path can come out a few 1e-8 below the optimum."""


FITNESS_GAP_TOLERANCE = 1e-5
"""The same for :attr:`Result.fitness_gap`: the fitness is a float32 sum of lengths and
turn costs and its reciprocal (errors of about 1e-6 relative), the reference float64."""


def relative_gap(length: np.ndarray, optimum: float, success: np.ndarray) -> np.ndarray:
    length = np.asarray(length, float)
    if optimum == 0.0:  # start == goal: the optimal path has length 0
        gap = np.where(length == 0.0, 0.0, np.inf)
    else:
        gap = length / optimum - 1.0
    gap = np.where(np.abs(gap) < GAP_TOLERANCE, 0.0, gap)
    return np.where(success, gap, np.nan)


@dataclasses.dataclass
class Result:
    """Per-seed results of :func:`run` (NumPy arrays, leading axis = seeds).

    A seed that found no path has no length, fitness or metrics: they are NaN (never 0),
    :meth:`path` returns None, its convergence generation is -1 and :attr:`causes` says
    why. ``np.nanmean(r.length)`` or ``r.length[r.success]`` averages the paths found.
    """

    preset: str
    map_name: str
    corner_rule: str
    seeds: np.ndarray
    success: np.ndarray
    reason: str
    cells: np.ndarray  # post-optimised best paths, int32[S, L] (padded)
    n_cells: np.ndarray
    raw_cells: np.ndarray
    raw_n_cells: np.ndarray
    length: np.ndarray
    raw_length: np.ndarray
    fitness: np.ndarray
    convergence_generation: np.ndarray
    history: dict[str, np.ndarray]  # best / mean / std, [S, G]
    metrics: dict[str, np.ndarray]
    raw_metrics: dict[str, np.ndarray]
    failures: np.ndarray  # [S, 3]: crossover, mutation, simplification
    init_success_rate: np.ndarray
    init_unfilled: np.ndarray
    optimum: float
    any_angle_optimum: float
    timing: dict[str, float]
    population: int
    generations: int
    width: int
    config: Config | None = None
    point: dict[str, Any] = dataclasses.field(default_factory=dict)
    fitness_optimum: float = math.nan
    """The exact optimum of the preset's fitness over 8-connected paths
    (:func:`jaxga.reference.fitness.fitness_optimum`); NaN where it is not computed
    (runs of waypoint paths, which it does not bound: AGACD, Zhang's eq. 5; maps over
    its size limit)."""
    fitness_optimum_length: float = math.nan
    """The length of the path that reaches :attr:`fitness_optimum`: where the fitness
    charges turns it can be longer than :attr:`optimum`."""
    fitness_optimum_loop_free: bool = True
    """False when the optimal walk visits a cell twice: :attr:`fitness_optimum` is then an
    upper bound of what a loop-free path (all that the GAs keep) can reach."""
    fitness_optimum_reason: str = ""
    """Why :attr:`fitness_optimum` is NaN (not computed), "" when it is computed."""
    start: tuple[int, int] | None = None
    """The start cell ``(x, y)``, y from the bottom."""
    goal: tuple[int, int] | None = None
    """The goal cell ``(x, y)``, y from the bottom."""
    population_capacity: int = 0
    """Individuals per island that the compiled program holds (the largest
    ``population.size`` of a sweep, or ``population_capacity=``): the random numbers of a
    run depend on it, so ``run(..., population_capacity=K)`` repeats a sweep point's runs
    bit for bit."""
    initial_fitness: np.ndarray | None = None
    """Per seed, the best fitness of the initial population (0 where it held no path):
    with :attr:`fitness` (the evolution's best) it says what the generations added."""
    init_fallback: np.ndarray | None = None
    """Per seed, how many initial individuals (all islands together) the fallback
    initialiser made (``init.fallback``): the slots the preset's own initialiser left
    empty after ``init.max_tries`` attempts per individual."""
    causes: np.ndarray | None = None
    """Per seed, why it returned no path ("" for a successful seed); :attr:`reason`
    sums them up."""
    path_capacity: int = 0
    """The cells a path can hold (``population.capacity``, or the automatic capacity of
    :func:`jaxga.engine.default_capacity`)."""
    size_class: bool = False
    """Whether the runs went on the map padded to its size class
    (:mod:`jaxga.api.size_classes`): ``run(..., size_class=True)`` repeats them."""

    def path(self, i: int, raw: bool = False) -> list[tuple[int, int]] | None:
        """Seed ``i``'s best path as ``(x, y)`` cells (post-optimised unless ``raw``); None
        for a seed that found no path (:attr:`causes` says why)."""
        if not self.success[i]:
            return None
        c = self.raw_cells[i] if raw else self.cells[i]
        n = int(self.raw_n_cells[i] if raw else self.n_cells[i])
        return [(int(p) % self.width, int(p) // self.width) for p in c[:n]]

    @property
    def gap(self) -> np.ndarray:
        """Relative gap of each post-optimised length to the any-angle optimum (its lower
        bound); NaN for failed seeds."""
        return relative_gap(self.length, self.any_angle_optimum, self.success)

    @property
    def raw_gap(self) -> np.ndarray:
        """Relative gap of each raw length to the exact optimum of its kind: the
        8-connected optimum for 8-connected raw paths, the any-angle optimum for the
        waypoint paths of AGACD and Zhang's eq. 5 (whose straight segments may beat the
        8-connected optimum); NaN for failed seeds."""
        return relative_gap(self.raw_length, self.raw_optimum, self.success)

    @property
    def raw_optimum(self) -> float:
        """The exact optimum that :attr:`raw_gap` measures against (see there)."""
        return self.any_angle_optimum if self._raw_waypoints() else self.optimum

    def _raw_waypoints(self) -> bool:
        return self.config is not None and uses_waypoints(self.config)

    @property
    def fitness_gap(self) -> np.ndarray:
        """``fitness_optimum / fitness - 1`` per seed: 0 for a run that found the optimum
        of its own fitness (for the ``1 / cost`` fitnesses, the relative excess of its
        cost); NaN for failed seeds and where the optimum is not computed."""
        ok = self.success & np.isfinite(self.fitness_optimum)  # success: fitness > 0
        gap = self.fitness_optimum / np.where(ok, np.asarray(self.fitness, float), 1.0) - 1.0
        gap = np.where(np.abs(gap) < FITNESS_GAP_TOLERANCE, 0.0, gap)
        return np.where(ok, gap, np.nan)

    def _column(self, name: str) -> np.ndarray:
        if name in self.metrics:
            return np.asarray(self.metrics[name], float)
        return np.asarray(getattr(self, name), float)

    def summary_rows(self) -> list[tuple[str, float, float, float, float]]:
        """``(metric, mean, sd, min, max)`` over successful seeds (AGACD Tables 8-9)."""
        ok = self.success
        rows = []
        names = list(SUMMARY_METRICS) + list(GAPS)
        for name in names:
            v = (getattr(self, name) if name in GAPS else self._column(name))[ok]
            if v.size == 0:
                rows.append((name, math.nan, math.nan, math.nan, math.nan))
            else:
                rows.append((name, float(v.mean()), float(v.std(ddof=1)) if v.size > 1
                             else 0.0, float(v.min()), float(v.max())))
        return rows

    def _fitness_optimum_text(self) -> str:
        if not np.isfinite(self.fitness_optimum):
            return (f"; no fitness optimum: {self.fitness_optimum_reason}"
                    if self.fitness_optimum_reason else "")
        bound = ("" if self.fitness_optimum_loop_free
                 else "; an upper bound: the optimal walk revisits a cell")
        return (f", fitness {self.fitness_optimum:.6g} (a path of length "
                f"{self.fitness_optimum_length:.4f}{bound})")

    def _initial_population_text(self) -> str:
        method = self.config.get("init.method") if self.config is not None else "?"
        text = (f"initial population: {method}, {100 * float(np.mean(self.init_success_rate)):.3g}"
                f" % of its attempts succeeded; paths of up to {self.path_capacity} cells")
        made = np.zeros(len(self.seeds), int) if self.init_fallback is None \
            else np.asarray(self.init_fallback)
        if made.any():
            fallback = self.config.get("init.fallback") if self.config is not None else "?"
            lo, hi = int(made[made > 0].min()), int(made.max())
            count = f"{lo}" if lo == hi else f"{lo}-{hi}"
            text += (f"; the fallback {fallback} made {count} of {self.population} initial "
                     f"individuals in {int((made > 0).sum())} of {len(self.seeds)} seeds "
                     f"({int(made.sum())} in all)")
        return text

    def summary(self) -> str:
        """A text table: mean, sd, min and max per metric, success rate, optima, timing."""
        lines = [
            f"preset {self.preset} on {self.map_name} (corner rule {self.corner_rule!r}), "
            f"{len(self.seeds)} seeds, population {self.population}, "
            f"{self.generations} generations",
            f"success {int(self.success.sum())}/{len(self.seeds)}"
            + (f" ({self.reason})" if self.reason else ""),
            f"optimum: 8-connected {self.optimum:.4f}, any-angle {self.any_angle_optimum:.4f}"
            + self._fitness_optimum_text(),
            f"{'metric':24s} {'mean':>10s} {'sd':>10s} {'min':>10s} {'max':>10s}",
        ]
        if not self.success.any():  # nothing to summarise: the reason says why
            lines[-1] = "no metrics: no seed found a path"
        else:
            for name, mean, sd, lo, hi in self.summary_rows():
                lines.append(f"{name:24s} {mean:10.4f} {sd:10.4f} {lo:10.4f} {hi:10.4f}")
        raw_basis = "any-angle" if self._raw_waypoints() else "8-connected"
        lines.append(f"gaps: gap = length / any-angle optimum - 1, raw_gap = raw_length / "
                     f"{raw_basis} optimum - 1, fitness_gap = fitness optimum / fitness - 1")
        lines.append(self._initial_population_text())
        t = self.timing
        lines.append(
            "time (s): compile {compile_s:.2f}, init {init_s:.3f}, evolve {evolve_s:.3f}, "
            "post {post_s:.3f}, total {total_s:.2f}".format(**t)
        )
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` layout of ``jaxga run``."""
        gaps = {k: getattr(self, k) for k in GAPS}
        runs = []
        for i, seed in enumerate(self.seeds):
            ok = bool(self.success[i])
            runs.append({
                "seed": int(seed),
                "success": ok,
                "path": [list(p) for p in self.path(i)] if ok else [],
                "raw_path": [list(p) for p in self.path(i, raw=True)] if ok else [],
                "length": float(self.length[i]) if ok else None,
                "raw_length": float(self.raw_length[i]) if ok else None,
                "fitness": json_number(float(self.fitness[i])),
                "initial_fitness": (None if self.initial_fitness is None
                                    else float(self.initial_fitness[i])),
                "convergence_generation": int(self.convergence_generation[i]),
                # the other metrics of the summary table, null for a failed seed
                **{k: json_number(float(self._column(k)[i])) if ok else None
                   for k in ("angle_sum", "turns")},
                **{k: json_number(float(gaps[k][i])) for k in GAPS},
                "history": {k: [float(x) for x in v[i]] for k, v in self.history.items()},
                "init_fallback": (None if self.init_fallback is None
                                  else int(self.init_fallback[i])),
                "cause": "" if self.causes is None else str(self.causes[i]),
            })
        return {
            "preset": self.preset, "map": self.map_name, "corner_rule": self.corner_rule,
            "start": None if self.start is None else list(self.start),
            "goal": None if self.goal is None else list(self.goal),
            "optimum": json_number(self.optimum),  # null when the goal is unreachable
            "any_angle_optimum": json_number(self.any_angle_optimum),
            "raw_optimum": json_number(self.raw_optimum),
            "fitness_optimum": json_number(self.fitness_optimum),
            "fitness_optimum_length": json_number(self.fitness_optimum_length),
            "fitness_optimum_loop_free": (self.fitness_optimum_loop_free
                                          if np.isfinite(self.fitness_optimum) else None),
            "fitness_optimum_reason": self.fitness_optimum_reason,
            "timing": dict(self.timing), "population": self.population,
            "population_capacity": self.population_capacity,
            "path_capacity": self.path_capacity, "size_class": self.size_class,
            "generations": self.generations,
            # every setting of the run (preset, file, --set and sweep point resolved)
            "config": None if self.config is None else self.config.as_dict(),
            "runs": runs,
        }


def json_number(x: float | None) -> float | None:
    """``x`` as a JSON number, or ``None`` (null) for None, NaN and infinities."""
    return None if x is None or not math.isfinite(x) else float(x)


def summarise(results: Mapping[str, Result]) -> str:
    """Several results side by side (one block per preset)."""
    return "\n\n".join(r.summary() for r in results.values())

