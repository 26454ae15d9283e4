"""What a run returns: :class:`Result`, per-seed paths, metrics and gaps to the exact optima.

Lengths, fitness and gaps per seed; :func:`summarise` over seeds; JSON numbers
for the command line's files.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxga._runtime.timeline import time_line
from jaxga.api.result_fronts import Fronts, FrontsOfResult, json_number
from jaxga.config.schema import Config
from jaxga.core.equality import MutableValueEquality, ValueEquality
from jaxga.core.errors import ParameterError
from jaxga.core.fields import shown_value
from jaxga.core.grid import as_integer
from jaxga.engine import (
    uses_waypoints,
)
from jaxga.maps.frame import MapFrame

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
    """Per seed, ``length / optimum - 1`` (:attr:`Result.gap`): 0 within
    :data:`GAP_TOLERANCE` of the optimum (float32 lengths against a float64 reference),
    0 or infinite for an optimum of 0 (start = goal), NaN for a seed without a path."""
    length = np.asarray(length, float)
    if optimum == 0.0:  # start == goal: the optimal path has length 0
        gap = np.where(length == 0.0, 0.0, np.inf)
    else:
        gap = length / optimum - 1.0
    gap = np.where(np.abs(gap) < GAP_TOLERANCE, 0.0, gap)
    return np.where(success, gap, np.nan)


@dataclasses.dataclass(frozen=True, eq=False)
class RunSetup(ValueEquality):
    """What was run (:attr:`Result.setup`): the preset, the map and the sizes."""

    preset: str
    """The preset's name."""
    map_name: str
    """The map's name."""
    corner_rule: str
    """The corner rule the paths obey."""
    seeds: np.ndarray
    """The seeds, one per run."""
    config: Config | None
    """The checked configuration."""
    point: dict[str, Any]
    """A sweep point's settings ({} for :func:`jaxga.run`)."""
    population: int
    """Individuals per island."""
    population_capacity: int
    """Individuals per island the compiled program holds."""
    generations: int
    """Generations per run."""
    path_capacity: int
    """The cells a path can hold."""
    size_class: bool
    """Whether the runs went on the map padded to its size class."""
    width: int
    """The map's width in cells (a cell index is ``y * width + x``)."""
    start: tuple[int, int] | None
    """The start cell ``(x, y)``."""
    goal: tuple[int, int] | None
    """The goal cell ``(x, y)``."""
    frame: MapFrame | None
    """Planning cells against the map file's cells and metres (None for a bare grid)."""
    map_digest: str
    """The planning map's :meth:`jaxga.Grid.cells_digest` ("" where not known): which
    results :func:`jaxga.compare_results` may compare."""
    environment: dict[str, Any]
    """What computed the runs: versions and device ({} where not known)."""
    map_source: dict[str, Any] | None
    """Where the map came from and how it was loaded (:meth:`jaxga.maps.MapInfo.source_json`:
    file, format, loading options); None for a bare grid or where not known."""


@dataclasses.dataclass(frozen=True, eq=False)
class RunPaths(ValueEquality):
    """The best paths, per seed (:attr:`Result.paths`; :meth:`Result.path` reads one as
    ``(x, y)`` cells, :meth:`Result.world_path` in metres)."""

    cells: np.ndarray
    """int32[S, L]: post-optimised best paths, cell indices, padded with the last cell."""
    n_cells: np.ndarray
    """int32[S]: their numbers of cells."""
    raw_cells: np.ndarray
    """int32[S, L]: the GA's own best paths, before the post-optimisation."""
    raw_n_cells: np.ndarray
    """int32[S]: their numbers of cells."""
    front: Fronts | None
    """Each seed's front of length against clearance (``survival.method``), None for a
    scalar GA."""


@dataclasses.dataclass(frozen=True, eq=False)
class RunOutcome(ValueEquality):
    """What each seed found (:attr:`Result.outcome`): success and its causes, lengths,
    fitness, the paths' metrics, the convergence and what the initialisation did. A seed
    without a path has NaN lengths, fitness and metrics."""

    success: np.ndarray
    """bool[S]: a feasible path was found."""
    reason: str
    """Why seeds found no path, summed up ("" when all did)."""
    causes: np.ndarray | None
    """str[S]: why each seed found no path ("" for a successful one)."""
    length: np.ndarray
    """float[S]: the post-optimised path's Euclidean length in cells."""
    raw_length: np.ndarray
    """float[S]: the raw path's length."""
    fitness: np.ndarray
    """float[S]: the best fitness."""
    initial_fitness: np.ndarray | None
    """float[S]: the initial population's best fitness."""
    convergence_generation: np.ndarray
    """int[S]: the generation the best was found (-1 without a path)."""
    generations_run: np.ndarray | None
    """int[S]: the generations each seed ran (fewer when the stagnation rule stopped it)."""
    history: dict[str, np.ndarray]
    """``best`` / ``mean`` / ``std`` of the fitness per generation, ``[S, G]``."""
    metrics: dict[str, np.ndarray]
    """The post-optimised paths' metrics by name (``angle_sum``, ``turns``, ...)."""
    raw_metrics: dict[str, np.ndarray]
    """The raw paths' metrics by name."""
    failures: np.ndarray
    """int[S, 3]: failed crossovers, mutations and simplifications."""
    init_success_rate: np.ndarray
    """float[S]: the share of the initialiser's attempts that made a path."""
    init_unfilled: np.ndarray
    """int[S]: initial slots left empty."""
    init_fallback: np.ndarray | None
    """int[S]: initial individuals the fallback initialiser made."""


@dataclasses.dataclass(frozen=True, eq=False)
class References(ValueEquality):
    """The exact references a result is measured against (:attr:`Result.references`; the
    gaps are :attr:`Result.gap`, :attr:`Result.raw_gap` and :attr:`Result.fitness_gap`)."""

    optimum: float
    """The exact 8-connected optimum."""
    any_angle_optimum: float
    """The exact any-angle optimum (NaN where not computed: :attr:`any_angle_note`)."""
    lower_bound: float
    """A proven lower bound of the any-angle optimum (NaN where not computed)."""
    any_angle_note: str
    """Why :attr:`any_angle_optimum` is NaN ("" when it is computed)."""
    fitness_optimum: float
    """The exact optimum of the preset's fitness over 8-connected paths (NaN where not
    computed: :attr:`fitness_optimum_reason`)."""
    fitness_optimum_length: float
    """The length of the path that reaches it."""
    fitness_optimum_loop_free: bool
    """False when that path visits a cell twice (the optimum is then an upper bound)."""
    fitness_optimum_reason: str
    """Why :attr:`fitness_optimum` is NaN ("" when it is computed)."""
    maximin_clearance: float
    """The exact maximin clearance in cells (:func:`jaxga.reference.maximin.maximin_path`),
    what a front's widest end is measured against; NaN without a front."""


RESULT_RECORDS = (RunSetup, RunPaths, RunOutcome, References)
"""The sub-records of a :class:`Result`, which with its ``timing`` hold each of its
fields once."""


@dataclasses.dataclass(eq=False)
class Result(FrontsOfResult, MutableValueEquality):
    """Per-seed results of :func:`run` (NumPy arrays, leading axis = seeds).

    A seed that found no path has no length, fitness or metrics: they are NaN (never 0),
    :meth:`path` returns None, its convergence generation is -1 and :attr:`causes` says
    why. ``np.nanmean(r.length)`` or ``r.length[r.success]`` averages the paths found.

    The fields read by name (``r.length``) or grouped as typed sub-records:
    :attr:`setup` (what was run), :attr:`paths` (the best paths), :attr:`outcome` (what
    each seed found), :attr:`references` (the exact optima) and ``timing`` (seconds per
    phase).
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
    generations_run: np.ndarray | None = None
    """Per seed, the generations it ran: :attr:`generations` unless the stagnation rule
    (``termination.stagnation``) stopped it earlier."""
    causes: np.ndarray | None = None
    """Per seed, why it returned no path ("" for a successful seed); :attr:`reason`
    sums them up."""
    path_capacity: int = 0
    """The cells a path can hold (``population.capacity``, or the automatic capacity of
    :func:`jaxga.engine.default_capacity`)."""
    size_class: bool = False
    """Whether the runs went on the map padded to its size class
    (:mod:`jaxga._runtime.size_classes`): ``run(..., size_class=True)`` repeats them."""
    lower_bound: float = math.nan
    """A proven lower bound of :attr:`any_angle_optimum`: the Euclidean shortest path
    around the blocked cells (:func:`jaxga.reference.lower_bound.euclidean_lower_bound_np`);
    NaN where it is not computed."""
    front: Fronts | None = None
    """Each seed's front (:class:`Fronts`; a preset with ``survival.method``), else None."""
    maximin_clearance: float = math.nan
    """The exact maximin clearance in cells (:func:`jaxga.reference.maximin.maximin_path`),
    what the front's widest end is measured against (:meth:`front_ends`); NaN without a
    front."""
    any_angle_note: str = ""
    """Why :attr:`any_angle_optimum` is NaN ("" when it is computed), e.g.
    "any-angle optimum not computed (budget 0.52 s)": :attr:`gap` then measures against
    :attr:`lower_bound` (:attr:`gap_basis`)."""
    frame: MapFrame | None = None
    """How the planning cells relate to the map file's cells and to metres
    (:mod:`jaxga.maps.frame`); None for a map given as a bare :class:`~jaxga.Grid`."""
    map_digest: str = ""
    """The planning map's :meth:`jaxga.Grid.cells_digest` ("" where not known)."""
    environment: dict[str, Any] = dataclasses.field(default_factory=dict)
    """What computed the runs: the versions of jaxga, JAX, jaxlib, NumPy and Python and the
    device (:func:`jaxga._runtime.device_probe.run_environment`); empty where not known."""
    map_source: dict[str, Any] | None = None
    """Where the map came from and how it was loaded: its file (a built-in map's or an
    occupancy grid's name), format and the options that shaped its cells
    (:meth:`jaxga.maps.MapInfo.source_json`), so that :func:`jaxga.rerun` loads a file
    again as it was; None for a bare :class:`~jaxga.Grid` or where not known."""

    def _record(self, record: type) -> Any:
        return record(**{f.name: getattr(self, f.name) for f in dataclasses.fields(record)})

    @property
    def setup(self) -> RunSetup:
        """What was run: preset, map, seeds, configuration, sizes (:class:`RunSetup`)."""
        return self._record(RunSetup)

    @property
    def paths(self) -> RunPaths:
        """The best paths, raw and post-optimised (:class:`RunPaths`)."""
        return self._record(RunPaths)

    @property
    def outcome(self) -> RunOutcome:
        """What each seed found: success, lengths, fitness, metrics, convergence
        (:class:`RunOutcome`)."""
        return self._record(RunOutcome)

    @property
    def references(self) -> References:
        """The exact optima and bounds it is measured against (:class:`References`)."""
        return self._record(References)

    def seed_index(self, i: Any) -> int:
        """``i`` as a position in :attr:`seeds` (``-n <= i < n``), or one
        :class:`~jaxga.core.errors.ParameterError` line: what every per-seed method takes."""
        n = len(self.seeds)
        try:  # an integer of any kind (a 0-d array from an argmin too), not a bool
            k = as_integer(i)
        except TypeError:
            k = None
        if k is None or not -n <= k < n:
            seeds = [int(s) for s in self.seeds]
            raise ParameterError(f"a seed's position must be an integer from {-n} to {n - 1} "
                                 f"(its place in r.seeds = {shown_value(seeds)}, "
                                 f"not the seed itself), got {shown_value(i)}")
        return k % n

    def path(self, i: int, raw: bool = False) -> list[tuple[int, int]] | None:
        """Seed ``i``'s best path as ``(x, y)`` cells (post-optimised unless ``raw``); None
        for a seed that found no path (:attr:`causes` says why)."""
        i = self.seed_index(i)
        if not self.success[i]:
            return None
        c = self.raw_cells[i] if raw else self.cells[i]
        n = int(self.raw_n_cells[i] if raw else self.n_cells[i])
        return [(int(p) % self.width, int(p) // self.width) for p in c[:n]]

    @property
    def straight_line(self) -> float:
        """The distance between the start's and the goal's centres (cells): no path is
        shorter; NaN where the endpoints are not known."""
        if self.start is None or self.goal is None:
            return math.nan
        return math.dist(self.start, self.goal)

    @property
    def gap_reference(self) -> float:
        """What :attr:`gap` measures against: the any-angle optimum, else (not computed
        within its budget, or skipped) its Euclidean lower bound around the obstacles,
        else the straight line from start to goal (:attr:`straight_line`), a lower bound
        too: a gap is never measured against a length a path can beat."""
        basis = {"any-angle optimum": self.any_angle_optimum,
                 "lower bound": self.lower_bound, "straight line": self.straight_line}
        return float(basis.get(self.gap_basis, math.nan))

    @property
    def gap_basis(self) -> str:
        """The name of :attr:`gap_reference`: ``"any-angle optimum"``, ``"lower bound"`` or
        ``"straight line"`` (for both, the gap is an upper bound of the gap to the
        optimum, never below zero); ``"none"`` where no path exists (the goal
        unreachable: no length to measure against) or the endpoints are not known."""
        if math.isfinite(self.any_angle_optimum):
            return "any-angle optimum"
        if math.isinf(self.optimum):  # unreachable: a straight line would be no basis
            return "none"
        if math.isfinite(self.lower_bound):
            return "lower bound"
        return "straight line" if math.isfinite(self.straight_line) else "none"

    @property
    def gap(self) -> np.ndarray:
        """Relative gap of each post-optimised length to the any-angle optimum (or, where
        it was not computed within its budget, to :attr:`gap_reference`: see
        :attr:`gap_basis`); NaN for failed seeds."""
        return relative_gap(self.length, self.gap_reference, self.success)

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
        return self.gap_reference if self._raw_waypoints() else self.optimum

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
        """``(metric, mean, sd, min, max)`` over successful seeds (AGACD Tables 8-9); the
        sd (the sample's, ``ddof=1``) is NaN where one seed succeeded."""
        ok = self.success
        rows = []
        names = list(SUMMARY_METRICS) + list(GAPS)
        for name in names:
            v = (getattr(self, name) if name in GAPS else self._column(name))[ok]
            if v.size == 0:
                rows.append((name, math.nan, math.nan, math.nan, math.nan))
            else:
                # the sample sd of one value is undefined: NaN, not 0 (no spread seen)
                rows.append((name, float(v.mean()), float(v.std(ddof=1)) if v.size > 1
                             else math.nan, float(v.min()), float(v.max())))
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
        if math.isinf(self.optimum) and not self.success.any():  # no path: nothing was run
            return f"initial population: not made ({method} was not run: no path exists)"
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

    def best_seed(self) -> int | None:
        """The index of the successful seed with the shortest post-optimised path (the
        first of equals), or None when no seed found a path."""
        if not self.success.any():
            return None
        return int(np.nanargmin(np.where(self.success, self.length, np.nan)))

    def world_path(self, i: int, raw: bool = False) -> np.ndarray | None:
        """Seed ``i``'s best path in metres (``float[k, 2]``, the map's world frame: cell
        centres, :meth:`jaxga.maps.frame.MapFrame.to_world`); None for a failed seed or
        a map without a resolution."""
        path = self.path(i, raw=raw)
        if path is None or self.frame is None or not self.frame.has_metres:
            return None
        return self.frame.to_world(np.asarray(path, float))

    def metres_text(self) -> str:
        """One summary line with the lengths in metres ("" for a map without a resolution)."""
        f = self.frame
        if f is None or f.cell_size is None:
            return ""
        head = f"metres      {f.describe()}"
        ok = self.success
        if not ok.any():
            return f"{head}; no path found"
        post, raw = self.length[ok] * f.cell_size, self.raw_length[ok] * f.cell_size
        ref = (f"any-angle {self.any_angle_optimum * f.cell_size:.3f} m"
               if math.isfinite(self.any_angle_optimum)
               else f"lower bound {self.lower_bound * f.cell_size:.3f} m"
               if math.isfinite(self.lower_bound) else "any-angle not computed")
        text = (f"{head}: length mean {post.mean():.3f} m, best {post.min():.3f} m (raw mean "
                f"{raw.mean():.3f} m); optimum {self.optimum * f.cell_size:.3f} m, {ref}")
        clear = [c for c in map(self.obstacle_clearance, np.flatnonzero(ok))
                 if c is not None and math.isfinite(c)]
        if clear and f.resolution is not None:
            least = min(clear) * f.resolution
            text += (f"; the best paths' clearance from the map's obstacles (before "
                     f"inflation) at least {least:.3f} m")
            if f.robot_radius is not None:
                text += f", {least - f.robot_radius:.3f} m beyond the robot's radius"
        return text

    def summary(self, time: bool = True) -> str:
        """A text table: mean, sd, min and max per metric, success rate, optima, metres
        (on a map with a resolution) and, with ``time``, the time line."""
        lines = [
            f"preset {self.preset} on {self.map_name} (corner rule {self.corner_rule!r}), "
            f"{len(self.seeds)} seeds, population {self.population}, "
            f"{self.generations} generations{self._stopped_text()}",
            f"success {int(self.success.sum())}/{len(self.seeds)}"
            + (f" ({self.reason})" if self.reason else ""),
            f"optimum: 8-connected {self.optimum:.4f}, {self.any_angle_text()}"
            + self._fitness_optimum_text(),
            f"{'metric':24s} {'mean':>10s} {'sd':>10s} {'min':>10s} {'max':>10s}",
        ]
        if not self.success.any():  # nothing to summarise: the reason says why
            lines[-1] = "no metrics: no seed found a path"
        else:
            for name, mean, sd, lo, hi in self.summary_rows():
                # "-": one seed's sd, or a gap not computed (a fitness optimum without
                # a path to weigh: start = goal)
                cols = [f"{'-':>10s}" if math.isnan(v) else f"{v:10.4f}"
                        for v in (mean, sd, lo, hi)]
                lines.append(f"{name:24s} {' '.join(cols)}")
        raw_basis = self.gap_basis if self._raw_waypoints() else "8-connected optimum"
        bound = {"lower bound": " (a lower bound of the any-angle optimum: at least the "
                                "gap to that optimum)",
                 "straight line": " (the any-angle optimum was not computed; the straight "
                                  "line from start to goal is a lower bound of it: at least "
                                  "the gap to that optimum)"}.get(self.gap_basis, "")
        if self.gap_basis == "none":
            why = ("no path exists" if math.isinf(self.optimum)
                   else "the start and goal are not known")
            lines.append(f"gaps: none ({why})")
        else:
            lines.append(f"gaps: gap = length / {self.gap_basis} - 1{bound}, raw_gap = "
                         f"raw_length / {raw_basis} - 1, fitness_gap = fitness optimum / "
                         "fitness - 1")
        lines.append(self._initial_population_text())
        metres = self.metres_text()
        if metres:
            lines.append(metres)
        if time:
            lines.append(time_line(self.timing))
        return "\n".join(lines)

    def _stopped_text(self) -> str:
        """`` (stopped after 3-6: no better best in 5 generations)`` when the stagnation
        rule ended runs early, else ""."""
        ran = self.generations_run
        if ran is None or not len(ran) or ran.max() >= self.generations:
            return ""
        span = f"{ran.min()}" if ran.min() == ran.max() else f"{ran.min()}-{ran.max()}"
        limit = self.config["termination.stagnation"] if self.config is not None else "K"
        return f" (every run stopped after {span}: no better best in {limit} generations)"

    def any_angle_text(self) -> str:
        """``any-angle 402.7829``, or why it is missing and the lower bound."""
        if math.isfinite(self.any_angle_optimum):
            return f"any-angle {self.any_angle_optimum:.4f}"
        text = self.any_angle_note or "any-angle optimum not computed"
        if math.isfinite(self.lower_bound):
            text += f", lower bound {self.lower_bound:.4f} (Euclidean, around the obstacles)"
        return text

    def _frame_json(self, i: int) -> dict[str, Any]:
        """Seed ``i``'s paths and lengths in the other frames: map cells (when coarsened)
        and metres (on a map with a resolution)."""
        f, ok = self.frame, bool(self.success[i])
        out: dict[str, Any] = {}
        if f is None:
            return out
        if f.coarsen > 1:
            for key, raw in (("map_path", False), ("map_raw_path", True)):
                out[key] = f.map_cell(np.asarray(self.path(i, raw=raw))).tolist() if ok else []
        if f.has_metres:
            for key, raw in (("path_world", False), ("raw_path_world", True)):
                out[key] = f.world_list(np.asarray(self.path(i, raw=raw), float)) if ok else []
            out["length_m"] = float(self.length[i] * f.cell_size) if ok else None
            out["raw_length_m"] = float(self.raw_length[i] * f.cell_size) if ok else None
            clearance = self.obstacle_clearance(i)
            out["min_clearance_m"] = (json_number(clearance * f.resolution)
                                      if clearance is not None else None)
            margin = self.clearance_margin_m(i)
            out["clearance_margin_m"] = json_number(margin) if margin is not None else None
        return out

    def obstacle_clearance(self, i: int) -> float | None:
        """Seed ``i``'s post-optimised path's least distance to the obstacles of the map as
        loaded, before inflation, in the map file's cells
        (:class:`jaxga.maps.clearance.ObstacleClearance`: the polyline through the cell
        centres against the obstacle cells' squares, exact); None for a failed seed or a
        grid without a loaded map. ``metrics["min_clearance"]`` is the distance to the
        grid planned on (inflated), in planning cells."""
        i = self.seed_index(i)
        f = self.frame
        path = self.path(i)
        if path is None or f is None or f.clearance is None:
            return None
        return f.clearance.of_path(np.asarray(path))

    def clearance_margin_m(self, i: int) -> float | None:
        """Metres between seed ``i``'s path's :meth:`obstacle_clearance` and the robot's
        radius the map was inflated by (``robot_radius``): what is left beyond the robot's
        body; None without a radius, a resolution or a path."""
        i = self.seed_index(i)
        f = self.frame
        clearance = self.obstacle_clearance(i)
        if clearance is None or f.robot_radius is None or f.resolution is None:
            return None
        return clearance * f.resolution - f.robot_radius


    def _endpoints_world(self) -> dict[str, Any]:
        """The endpoints in metres (and in map cells when coarsened), where known."""
        f, out = self.frame, {}
        if f is None or self.start is None or self.goal is None:
            return out
        ends = np.array([self.start, self.goal])
        if f.coarsen > 1:
            out["map_start"], out["map_goal"] = f.map_cell(ends).tolist()
        if f.has_metres:
            out["start_world"], out["goal_world"] = f.world_list(ends)
        return out

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
                "generations_run": (None if self.generations_run is None
                                    else int(self.generations_run[i])),
                # the other metrics of the summary table, null for a failed seed
                **{k: json_number(float(self._column(k)[i])) if ok else None
                   for k in ("angle_sum", "turns")},
                **{k: json_number(float(gaps[k][i])) for k in GAPS},
                "history": {k: [float(x) for x in v[i]] for k, v in self.history.items()},
                "init_fallback": (None if self.init_fallback is None
                                  else int(self.init_fallback[i])),
                "cause": "" if self.causes is None else str(self.causes[i]),
                **self._frame_json(i),
                **self._front_json(i),
            })
        return {
            "preset": self.preset, "map": self.map_name, "map_digest": self.map_digest,
            "map_source": getattr(self, "map_source", None),  # None from older pickles
            "environment": dict(getattr(self, "environment", {})),  # {} from older pickles
            "corner_rule": self.corner_rule,
            "start": None if self.start is None else list(self.start),
            "goal": None if self.goal is None else list(self.goal),
            **self._endpoints_world(),
            "optimum": json_number(self.optimum),  # null when the goal is unreachable
            "any_angle_optimum": json_number(self.any_angle_optimum),
            "any_angle_note": self.any_angle_note,
            "lower_bound": json_number(self.lower_bound),
            "gap_basis": self.gap_basis,
            "raw_optimum": json_number(self.raw_optimum),
            "fitness_optimum": json_number(self.fitness_optimum),
            "fitness_optimum_length": json_number(self.fitness_optimum_length),
            "fitness_optimum_loop_free": (self.fitness_optimum_loop_free
                                          if np.isfinite(self.fitness_optimum) else None),
            "fitness_optimum_reason": self.fitness_optimum_reason,
            "maximin_clearance": json_number(self.maximin_clearance),
            "timing": dict(self.timing), "population": self.population,
            "population_capacity": self.population_capacity,
            "path_capacity": self.path_capacity, "size_class": self.size_class,
            "generations": self.generations,
            "frame": None if self.frame is None else self.frame.to_json(),
            "resolution": None if self.frame is None else self.frame.cell_size,
            # every setting of the run (preset, file, --set and sweep point resolved)
            "config": None if self.config is None else self.config.as_dict(),
            "runs": runs,
        }


def summarise(results: Mapping[str, Result]) -> str:
    """Several results side by side (one block per preset)."""
    return "\n\n".join(r.summary() for r in results.values())

