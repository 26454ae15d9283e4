"""Paper reproduction: every comparable table of the five papers beside jaxga, same settings.

    python benchmarks/reproduce.py [--seeds N] [--tables zhu2,zhu4,agacd5,agacd8,agacd12,
                                                        mpmga,imga,zhang] [--no-write]

For each table (docs/reproducing.md): the paper's value, jaxga's value under the paper's
settings (its preset or variant, its run count, corner rule ``free``, the papers'
initialisers alone: ``init.fallback = none``) and a verdict. The papers' numbers are in
``benchmarks/paper_tables.py``, one comment per number naming its table and row.

Tables (``--tables``; default all):

- ``zhu2``: Zhu & Pan 2024 Table 2, the initialisers (GA random walk, CGA 1/d roulette,
  IGA directional guidance): successes per 100 attempts over 30 x 100 attempts, time for
  a population of 200, mean and sd of the lengths made.
- ``zhu4``: Zhu & Pan Table 4 (the runs of ``benchmarks/zhu_table4.py``, plus the BGA
  row): length mean and sd, smoothness (eq. 8) mean and sd, minimum length, 30 runs.
- ``agacd5``: AGACD Table 5, its designed experiment (``jaxga.doe``): each design point's
  mean fitness, eq. 31's coefficients, the predicted best combination, its confirmation.
- ``agacd8``: AGACD Tables 7-9 (20 x 20, 20 runs): fitness (before and after the
  optimisation operator), convergence generation, times; best fitness and paired wins
  (5.2.5). The BGA is ``sga`` variant ``agacd`` (scored with AGACD's fitness).
- ``agacd12``: AGACD Tables 11-13 (50 x 50, 20 runs): AGACD, MPMGA, BGA, every fitness
  in AGACD's eq. 7.
- ``mpmga``: MPMGA Tables 3-7: times, the claims of its text (Tables 4 and 7 are not
  legible in our copy), convergence and diversity of Figs. 15-16.
- ``imga``: IMGA Table 3 (environment 4): best length, turns and tangencies of GA and
  IMGA; Tables 1, 2, 4 (maps only in figures) listed as not compared.
- ``zhang``: Zhang's Table 1 (garbled in our copy): the direction of its claim.

Verdict rules (one per row, in this order):

1. The paper gives a mean and an sd: **within the paper's spread** when |jaxga mean -
   paper mean| <= the paper's sd, else **different**.
2. The paper gives a mean without an sd: **within jaxga's spread** when the difference is
   at most jaxga's own sd over its runs (a count of paired wins: the binomial sd), else
   **different**.
3. The paper gives one value (a minimum, a best run, a count of turns): **equal** when
   jaxga's matching statistic is within 0.1 % of it (integers: the same), else **within
   jaxga's range** when it lies between jaxga's smallest and largest run, else
   **different**.
4. A claim of the paper's text (A better than B): **same direction** or **opposite
   direction** of jaxga's means; a regression coefficient: **same sign** / **opposite
   sign**.
5. Running times (MATLAB 2018-2023 on the papers' machines): printed, verdict **not
   comparable (hardware/language)**.
6. **not compared**, with the reason (map only in a figure, algorithm not implemented,
   table not legible).

Every **different** carries jaxga's relative difference and a short reason from the
row's data (map not the paper's, fitness scale, ...). The map column says which map ran:
the paper's own map is never available as such; ``classic_ga_gapp3_20x20``,
``routeplanning_yangbo_20x20`` and ``acoga_skolayat_G_20x20`` are identified with Zhu's
Maps 3 and 4 and IMGA's environment 4 only by equal optimal lengths ("inferred"), the
others are stand-ins. Runs use every core (``jaxga._runtime.parallel.use_all_cores``; results
do not depend on the device count). Prints every table and records them in one
RESULTS.md section ("Paper reproduction: the five papers' tables beside jaxga") unless
``--no-write``.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import os
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import paper_tables as P
from _results import markdown_table, record
from zhu_table4 import smoothness as zhu_smoothness

import jaxga._runtime.parallel
from jaxga.api import Result, clear_compiled, run
from jaxga.core.errors import InitialisationWarning
from jaxga.core.objectives import mpmga_penalty, path_length
from jaxga.core.paths import population_map
from jaxga.doe import AGACD_TABLE3, contrast_coefficients, predicted_best, run_doe
from jaxga.engine import build, default_capacity, fitness_function
from jaxga.maps import load_map, random_map
from jaxga.operators import init as init_ops
from jaxga.reference.any_angle import any_angle_shortest_path
from jaxga.reference.optima import shortest_path
from jaxga.replan import mpmga_scenario

TABLES = ("zhu2", "zhu4", "agacd5", "agacd8", "agacd12", "mpmga", "imga", "zhang")
"""The ``--tables`` keys, in the order the section lists them."""

FALLBACK = "init.fallback=none"
"""Paper reproductions run the papers' initialisers alone."""

TIME = "not comparable (hardware/language)"
HEADERS = ["paper", "table", "quantity", "algorithm", "map", "paper value", "jaxga value",
           "verdict"]

ZHU = "Zhu & Pan 2024"
AGACD = "AGACD (Hao et al. 2021)"
MPMGA = "MPMGA (Hao et al. 2020)"
IMGA = "IMGA (Li, Hu, Liu 2021)"
ZHANG = "Zhang Ke-qi (IGA)"

CAPACITY_50 = 400
"""Path capacity of the 50 x 50 runs: ``4 (H + W)``, jaxga's former default. With the
automatic capacity (192 cells) the papers' random walk and intermittent initialisers
almost never close a path on the 50 x 50 stand-in (0.0008 % and 0 % of attempts); the
papers' own runs spent 43-54 s building their populations (AGACD Table 11), i.e. they
did build them."""

MAPS: dict[str, tuple[str, Callable[[], Any]]] = {
    "zhu3": ("Map 3 = classic_ga_gapp3_20x20 (inferred: same optimum 30.9706)",
             lambda: load_map("classic_ga_gapp3_20x20", corner_rule="free")),
    "zhu4": ("Map 4 = routeplanning_yangbo_20x20 (inferred: same optimum 30.3848)",
             lambda: load_map("routeplanning_yangbo_20x20", corner_rule="free")),
    "agacd20": ("stand-in: classic_ga_gapp3_20x20 (AGACD's Fig. 5 map is only a figure)",
                lambda: load_map("classic_ga_gapp3_20x20", corner_rule="free")),
    "agacd50": ("stand-in: random_map(50, 50, 0.1, seed=0), capacity 400 (the paper's "
                "Fig. 11 map is only a figure)",
                lambda: random_map(50, 50, 0.1, seed=0, corner_rule="free")),
    "mpmga25": ("stand-in: mpmga_scenario('25x25'), generated, cells 10 -> 624 (MPMGA's "
                "Fig. 12 library map is only a figure)",
                lambda: mpmga_scenario("25x25").grid),
    "imga4": ("environment 4 = acoga_skolayat_G_20x20 (inferred: its optimum is "
              "literature [37]'s 29.7990)",
              lambda: load_map("acoga_skolayat_G_20x20", corner_rule="free")),
    "zhang": ("stand-in: classic_ga_gapp3_20x20 (Zhang's three environments are not given)",
              lambda: load_map("classic_ga_gapp3_20x20", corner_rule="free")),
}
"""Map key -> (label for the map column, loader)."""


@dataclasses.dataclass
class Row:
    """One line of a reproduction table."""

    paper: str
    table: str
    quantity: str
    algorithm: str
    map: str
    paper_value: str
    jaxga_value: str
    verdict: str

    def cells(self) -> list[str]:
        """The row as the markdown table's cells (:data:`HEADERS` order)."""
        return [self.paper, self.table, self.quantity, self.algorithm, self.map,
                self.paper_value, self.jaxga_value, self.verdict]


@dataclasses.dataclass
class Context:
    """What every table function needs: run counts, the cache of runs, the runs' log."""

    seeds: int | None
    results: dict[tuple, Result] = dataclasses.field(default_factory=dict)
    grids: dict[str, Any] = dataclasses.field(default_factory=dict)
    log: list[list] = dataclasses.field(default_factory=list)

    def n(self, paper_count: int) -> int:
        """``--seeds`` if given, else the paper's own count."""
        return self.seeds or paper_count

    def grid(self, key: str) -> Any:
        """The map of :data:`MAPS` ``key`` (loaded once)."""
        if key not in self.grids:
            self.grids[key] = MAPS[key][1]()
        return self.grids[key]

    def run(self, preset: str, map_key: str, seeds: int, variant: str | None = None,
            sets: Sequence[str] = (), label: str = "") -> Result:
        """``jaxga.api.run`` with the paper's initialiser alone, cached by its arguments,
        logged for the runs table (success, initial population, times)."""
        key = (preset, map_key, seeds, variant, tuple(sets))
        if key in self.results:
            return self.results[key]
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", InitialisationWarning)
            r = run(preset, self.grid(map_key), seeds=seeds, variant=variant,
                    sets=[FALLBACK, *sets])
        wall = time.perf_counter() - t0
        copied = int(np.sum(r.init_unfilled)) if r.init_unfilled is not None else 0
        t = r.timing
        self.log.append([
            label or preset, preset + (f" variant {variant}" if variant else ""),
            map_key, ", ".join(f"`{s}`" for s in sets) or "-", seeds,
            f"{int(r.success.sum())}/{seeds}",
            f"{100 * float(np.mean(r.init_success_rate)):.3g}",
            f"{copied}" + (" (warned)" if caught else ""),
            f"{t['compile_s']:.1f}",
            f"{(t['init_s'] + t['evolve_s'] + t['post_s']) / seeds:.3f}", f"{wall:.1f}",
        ])
        print(f"  run {label or preset} on {map_key}: {int(r.success.sum())}/{seeds} "
              f"successful, {wall:.1f} s", flush=True)
        self.results[key] = r
        return r


# ------------------------------------------------------------------ verdicts and values
def _f(v: float, digits: int = 4) -> str:
    """``v`` with ``digits`` decimals ("-" for NaN)."""
    return "-" if v is None or not np.isfinite(v) else f"{v:.{digits}f}"


def _mean_sd(values: np.ndarray) -> tuple[float, float]:
    """Mean and sd (ddof 1; 0 for a single value) of the finite ``values``."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan, math.nan
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0


def _delta(jaxga: float, paper: float) -> str:
    """jaxga's difference from the paper, relative when the paper's value is not 0."""
    if paper:
        return f"jaxga {100 * (jaxga - paper) / abs(paper):+.1f} %"
    return f"jaxga {jaxga - paper:+.4g}"


def mean_row(paper: tuple[float, float | None], values: np.ndarray, why: str,
             digits: int = 4, n_label: str = "") -> tuple[str, str, str]:
    """Rules 1-2: the paper's mean (and sd) against jaxga's per-run ``values``.

    Returns ``(paper value, jaxga value, verdict)`` strings."""
    p_mean, p_sd = paper
    m, s = _mean_sd(values)
    n = int(np.isfinite(np.asarray(values, float)).sum())
    p_text = _f(p_mean, digits) + (f" ± {_f(p_sd, digits)}" if p_sd is not None else "")
    j_text = f"{_f(m, digits)} ± {_f(s, digits)} ({n_label or f'{n} runs'})"
    if n == 0:
        return p_text, "no successful run", "not compared: no jaxga run succeeded"
    if p_sd is not None:
        if abs(m - p_mean) <= p_sd:
            return p_text, j_text, "within the paper's spread"
    elif abs(m - p_mean) <= s:
        return p_text, j_text, "within jaxga's spread"
    return p_text, j_text, f"different ({_delta(m, p_mean)}): {why}"


def single_row(paper: float, stat: float, values: np.ndarray, why: str, digits: int = 4,
               integer: bool = False, tol: float | None = None,
               stat_label: str = "") -> tuple[str, str, str]:
    """Rule 3: one paper value against jaxga's matching statistic ``stat`` and the range
    of its per-run ``values``."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    fmt = (lambda x: f"{x:.0f}") if integer else functools.partial(_f, digits=digits)
    p_text = fmt(paper)
    if v.size == 0:
        return p_text, "no successful run", "not compared: no jaxga run succeeded"
    j_text = (f"{fmt(stat)}{f' ({stat_label})' if stat_label else ''}; runs "
              f"{fmt(v.min())}-{fmt(v.max())}")
    if tol is None:
        tol = 0.5 if integer else 1e-3 * abs(paper)
    if abs(stat - paper) <= tol:
        return p_text, j_text, "equal"
    if v.min() - tol <= paper <= v.max() + tol:
        return p_text, j_text, "within jaxga's range"
    return p_text, j_text, f"different ({_delta(stat, paper)}): {why}"


def direction_row(claim: str, a: np.ndarray, b: np.ndarray, names: tuple[str, str],
                  why: str, digits: int = 4) -> tuple[str, str, str]:
    """Rule 4: the paper says ``names[0]`` is ``claim`` ("higher" / "lower") than
    ``names[1]``; jaxga's means of ``a`` and ``b``."""
    ma, _ = _mean_sd(a)
    mb, _ = _mean_sd(b)
    p_text = f"{names[0]} {claim} than {names[1]}"
    j_text = f"{names[0]} {_f(ma, digits)}, {names[1]} {_f(mb, digits)} (means)"
    if not (np.isfinite(ma) and np.isfinite(mb)):
        return p_text, j_text, "not compared: no jaxga run succeeded"
    same = ma > mb if claim == "higher" else ma < mb
    return p_text, j_text, "same direction" if same else f"opposite direction: {why}"


def wins_row(paper: int, a: np.ndarray, b: np.ndarray, why: str) -> tuple[str, str, str]:
    """Rule 2 for paired wins: how many runs ``i`` have ``a[i] > b[i]`` (the paper's
    count, no sd) against jaxga's count and its binomial sd."""
    n = min(len(a), len(b))
    wins = int(np.sum(np.asarray(a[:n]) > np.asarray(b[:n])))
    sd = math.sqrt(n * (wins / n) * (1 - wins / n)) if n else math.nan
    p_text, j_text = f"{paper} of 20", f"{wins} of {n} (binomial sd {sd:.1f})"
    if abs(wins * 20 / max(n, 1) - paper) <= sd * 20 / max(n, 1):
        return p_text, j_text, "within jaxga's spread"
    return p_text, j_text, f"different ({_delta(wins * 20 / max(n, 1), paper)}): {why}"


def time_row(paper: str, r: Result) -> tuple[str, str, str]:
    """Rule 5: the paper's times against jaxga's seconds per run (init + evolve + post of
    the whole batch divided by its runs, after compilation)."""
    t, s = r.timing, len(r.seeds)
    j = (f"init {t['init_s'] / s:.4f} + evolution {t['evolve_s'] / s:.4f} + post "
         f"{t['post_s'] / s:.4f} = {(t['init_s'] + t['evolve_s'] + t['post_s']) / s:.4f} s "
         f"per run (batch of {s}; compile {t['compile_s']:.1f} s once)")
    return paper, j, TIME


def not_compared(paper: str, table: str, quantity: str, algorithm: str, map_: str,
                 paper_value: str, why: str) -> Row:
    """Rule 6: a row saying why a table or row is not compared."""
    return Row(paper, table, quantity, algorithm, map_, paper_value, "-",
               f"not compared: {why}")


# ------------------------------------------------------------------ path evaluations
def _ok(r: Result, values: np.ndarray) -> np.ndarray:
    """``values`` as floats, NaN for the failed runs."""
    return np.where(r.success, np.asarray(values, float), np.nan)


def objective(config: Any, grid: Any, cells: np.ndarray, n_cells: np.ndarray) -> np.ndarray:
    """The fitness of ``config`` (a resolved configuration: its method and weights, as
    the engine binds them) of every path ``cells[i, :n_cells[i]]``."""
    algo, params = build(config, grid)
    f = fitness_function(algo, params)
    fn = jax.jit(jax.vmap(lambda c, n: f(grid, c, n, None)))
    return np.asarray(fn(jnp.asarray(cells), jnp.asarray(n_cells)), float)


def preset_fitness(r: Result, grid: Any, raw: bool = False) -> np.ndarray:
    """The run's own objective of its returned (post-optimised, or ``raw``) paths; NaN
    for failed runs. On the raw paths it is ``Result.fitness``."""
    cells, n = (r.raw_cells, r.raw_n_cells) if raw else (r.cells, r.n_cells)
    return _ok(r, objective(r.config, grid, cells, n))


@functools.cache
def _agacd_config() -> Any:
    """AGACD's fitness (eq. 7-8, Delphi weights of eq. 25) as the preset configures it."""
    from jaxga.config.presets import load_preset

    return load_preset("agacd")


def agacd_fitness(r: Result, grid: Any, raw: bool = False) -> np.ndarray:
    """AGACD's eq. 7 fitness of the returned (or ``raw``) paths of any run."""
    cells, n = (r.raw_cells, r.raw_n_cells) if raw else (r.cells, r.n_cells)
    return _ok(r, objective(_agacd_config(), grid, cells, n))


def mpmga_smoothness(r: Result, grid: Any) -> np.ndarray:
    """MPMGA eq. 13's turn penalty (0 / 5 / 25 / 125) of the returned paths."""
    fn = jax.jit(jax.vmap(lambda c, n: mpmga_penalty(grid, c, n)))
    return _ok(r, np.asarray(fn(jnp.asarray(r.cells), jnp.asarray(r.n_cells)), float))


def per_run_seconds(r: Result) -> np.ndarray:
    """Seconds per run (init + evolve + post of the batch / runs), one value per run."""
    t = r.timing
    return np.full(len(r.seeds), (t["init_s"] + t["evolve_s"] + t["post_s"]) / len(r.seeds))


# ------------------------------------------------------------------ Zhu & Pan Table 2
def table_zhu2(ctx: Context) -> tuple[list[Row], list[str]]:
    """Zhu & Pan Table 2: the three initialisers on Maps 3 and 4, 30 x 100 attempts."""
    reps = ctx.n(P.ZHU_TABLE2_RUNS)
    attempts = P.ZHU_TABLE2_ATTEMPTS
    methods = {
        "GA": ("random_walk", init_ops.random_walk),
        "CGA": ("directional, factors (1, 1) = 1/d roulette",
                functools.partial(init_ops.directional, factors=(1.0, 1.0))),
        "IGA": ("directional (Algorithm 1)", init_ops.directional),
    }
    why = {
        "GA": "map identity inferred; the paper's walk is not specified beyond 'random walk'",
        "CGA": "map identity inferred; literature [28]'s grid scores are read as 1/d",
        "IGA": "map identity inferred; Algorithm 1 read as a self-avoiding walk that stops "
               "when the goal is a neighbour",
    }
    rows: list[Row] = []
    for map_key, map_name in (("zhu3", "Map 3"), ("zhu4", "Map 4")):
        grid = ctx.grid(map_key)
        cap = default_capacity(grid)
        lengths_of = jax.jit(population_map(path_length))
        for alg, (op_name, fn) in methods.items():
            batch = jax.jit(jax.vmap(functools.partial(fn, grid=grid, capacity=cap)))
            keys = jax.random.split(jax.random.PRNGKey(0), reps * attempts).reshape(
                reps, attempts, -1)
            jax.block_until_ready(batch(keys[0]))  # compile
            successes, lengths, times = [], [], []
            for i in range(reps):
                t0 = time.perf_counter()
                cells, length, ok = jax.block_until_ready(batch(keys[i]))
                times.append(time.perf_counter() - t0)
                ok = np.asarray(ok, bool)
                successes.append(int(ok.sum()))
                lengths.append(np.asarray(lengths_of(grid, cells, length), float)[ok])
            lens = np.concatenate(lengths)
            rate = sum(successes) / (reps * attempts)
            p_succ, p_time, p_len, p_len_sd = P.ZHU_TABLE2[(map_name, alg)]
            label = f"{alg}: `{op_name}`"
            pv, jv, v = mean_row((p_succ, None), np.array(successes, float), why[alg],
                                 digits=2, n_label=f"{reps} x {attempts} attempts")
            rows.append(Row(ZHU, f"Table 2, {map_name}, {alg}",
                            f"successes per {attempts} attempts", label, MAPS[map_key][0],
                            pv, jv, v))
            per_attempt = float(np.median(times)) / attempts
            build_200 = 200 / rate * per_attempt if rate else math.nan
            rows.append(Row(ZHU, f"Table 2, {map_name}, {alg}",
                            "time to build a population of 200 (s)", label,
                            MAPS[map_key][0], _f(p_time),
                            f"{_f(build_200)} (200 / success rate x {per_attempt * 1e6:.1f}"
                            f" µs per attempt, vmapped batches of {attempts}, after "
                            "compilation)", TIME))
            pv, jv, v = mean_row((p_len, p_len_sd), lens, why[alg], digits=2,
                                 n_label=f"{lens.size} paths; sd over paths")
            rows.append(Row(ZHU, f"Table 2, {map_name}, {alg}",
                            "mean length of the paths made (sd over paths)", label,
                            MAPS[map_key][0], pv, jv, v))
            print(f"  zhu2 {map_name} {alg}: {rate * 100:.2f} % successes", flush=True)
    rows.append(not_compared(ZHU, "Table 2, Maps 1 and 2", "all", "GA, CGA, IGA",
                             "Maps 1 and 2 (literature [29])", "see Table 2",
                             "the maps are only figures; no built-in map has their minimum "
                             "lengths (31.5536, 27.4558)"))
    notes = [f"Each method: {reps} blocks of {attempts} independent attempts (the paper: 30 "
             "repetitions of 100); path capacity "
             f"{default_capacity(ctx.grid('zhu3'))} cells (the automatic capacity, the "
             "step cap of every walk). The paper's 'Sd of Population Average Path Length' "
             "is read as the sd over the paths made (its size, 16-27, is that of single "
             "paths, not of a mean of 200)."]
    return rows, notes


# ------------------------------------------------------------------ Zhu & Pan Table 4
ZHU_RUNS = {
    "IGA": ("iga_zhu", None, ()),
    "GA": ("sga", "iga_zhu", ()),
    "BGA": ("sga", "iga_zhu", ("mutation.method=regrow_segment",)),
}
"""Zhu Table 4's rows that jaxga runs: preset, variant, extra keys. BGA = literature
[29] as Zhu 4.7 describes it: the traditional GA with the range mutation operator."""

ZHU_WHY: dict[str, Callable[[Result], str]] = {
    "IGA": lambda r: (f"{100 * np.mean(r.fitness_gap[r.success] == 0):.0f} % of jaxga's runs "
                      "end at the optimum of the IGA's own fitness (eq. 6), a path of length "
                      f"{r.fitness_optimum_length:.4f}"),
    "GA": lambda r: "the paper describes its GA's operators in one sentence (4.7)",
    "BGA": lambda r: ("literature [29]'s GA is described in one sentence (4.7: the GA with "
                      "the range mutation)"),
}
"""Per Table 4 algorithm, the reason a different row gives (from the run's data)."""


def table_zhu4(ctx: Context) -> tuple[list[Row], list[str]]:
    """Zhu & Pan Table 4: GA, BGA and IGA on Maps 3 and 4, 30 runs each."""
    seeds = ctx.n(P.ZHU_TABLE4_RUNS)
    rows: list[Row] = []
    for map_key, map_name in (("zhu3", "Map 3"), ("zhu4", "Map 4")):
        grid = ctx.grid(map_key)
        for alg, (preset, variant, sets) in ZHU_RUNS.items():
            r = ctx.run(preset, map_key, seeds, variant, sets, label=f"Zhu {alg}")
            lengths = _ok(r, r.length)
            smooth = _ok(r, zhu_smoothness(r, grid))
            p_len, p_sd, p_smooth, p_smooth_sd, p_min = P.ZHU_TABLE4[(map_name, alg)]
            label = f"{alg}: {preset}" + (f" variant {variant}" if variant else "") + \
                "".join(f", `{s}`" for s in sets)
            why_len = "map identity inferred; " + ZHU_WHY[alg](r)
            for quantity, paper, values, why in (
                ("length mean ± sd", (p_len, p_sd), lengths, why_len),
                ("smoothness (eq. 8 fit_2) mean ± sd", (p_smooth, p_smooth_sd), smooth,
                 why_len),
            ):
                pv, jv, v = mean_row(paper, values, why)
                rows.append(Row(ZHU, f"Table 4, {map_name}, {alg}", quantity, label,
                                MAPS[map_key][0], pv, jv, v))
            ok = np.isfinite(lengths)
            pv, jv, v = single_row(p_min, float(np.min(lengths[ok])) if ok.any() else
                                   math.nan, lengths,
                                   "map identity inferred" + (
                                       "; the paper's minimum is not an 8-connected length "
                                       "(a + b sqrt 2)" if p_min in (33.5864, 30.758)
                                       else ""),
                                   stat_label="jaxga minimum")
            rows.append(Row(ZHU, f"Table 4, {map_name}, {alg}", "minimum length", label,
                            MAPS[map_key][0], pv, jv, v))
    for alg, why in (("CGA", "literature [28]'s initialiser (1/d roulette) has no preset "
                             "key (`init_study.py` measures it in Table 2)"),
                     ("CSAGA", "literature [30]'s chaotic simulated-annealing GA is not "
                               "implemented"),
                     ("BFO", "Bitterling fish optimisation is not a GA; not implemented")):
        rows.append(not_compared(ZHU, f"Table 4, Maps 3 and 4, {alg}", "all", alg,
                                 "Maps 3 and 4", "see Table 4", why))
    rows.append(not_compared(ZHU, "Table 4, Maps 1 and 2", "all", "all", "Maps 1 and 2",
                             "see Table 4", "the maps are only figures"))
    notes = [f"{seeds} runs per row, Table 3's settings (popnum 200, 50 generations; pc "
             "0.8, pm 0.4; IGA ps 0.4, omega 0.7, c1-c3 1-3); lengths and smoothness of "
             "the returned 8-connected path (no post-optimisation in Zhu & Pan). "
             "`benchmarks/zhu_table4.py` has the same IGA and GA runs with the optimum of "
             "the IGA's own fitness beside them."]
    return rows, notes


# ------------------------------------------------------------------ AGACD Table 5 (DOE)
def _agacd20_run(ctx: Context) -> Result:
    """AGACD Table 6's AGACD run on the 20 x 20 stand-in (Tables 8-9 and the DOE's
    confirmation at the paper's best combination)."""
    return ctx.run("agacd", "agacd20", ctx.n(P.AGACD_RUNS), label="AGACD 20x20")


def _agacd20_runs(ctx: Context) -> tuple[Result, Result]:
    """AGACD Table 6's two runs on the 20 x 20 stand-in: agacd and the BGA."""
    b = ctx.run("sga", "agacd20", ctx.n(P.AGACD_RUNS), "agacd", label="AGACD's BGA 20x20")
    return _agacd20_run(ctx), b


def table_agacd5(ctx: Context) -> tuple[list[Row], list[str]]:
    """AGACD Table 5: the DOE's design points, eq. 31, the best combination and its
    confirmation run."""
    seeds = ctx.n(P.AGACD_DOE_SEEDS)
    map_label = MAPS["agacd20"][0]
    t0 = time.perf_counter()
    r = run_doe("agacd", ctx.grid("agacd20"), AGACD_TABLE3, "agacd-table4", seeds=seeds,
                sets=[FALLBACK])
    wall = time.perf_counter() - t0
    t = r.timing
    ctx.log.append(["AGACD DOE (9 points)", "agacd (jaxga.doe.run_doe)", "agacd20",
                    "Table 3 factors, Table 4 design", seeds,
                    f"{int(r.n_success.sum())}/{9 * seeds}", "-", "-",
                    f"{t['compile_s']:.1f}", "-", f"{wall:.1f}"])
    print(f"  DOE: {wall:.1f} s", flush=True)
    why = ("stand-in map (AGACD's fitness has a safety term that counts the obstacles "
           "beside the path); exact line of sight instead of the paper's linear trial")
    rows: list[Row] = []
    for i, (trials, means) in enumerate(zip(P.AGACD_TABLE5, r.responses)):
        sd = float(np.std(trials, ddof=1))
        coded = ", ".join(f"{int(c):+d}" if c else "0" for c in r.coded[i])
        pv, jv, v = mean_row((P.AGACD_TABLE5_AVERAGES[i], sd), means, why,
                             n_label=f"{int(np.isfinite(means).sum())} runs")
        rows.append(Row(AGACD, f"Table 5, row {i + 1}", f"mean fitness at ({coded}); "
                        "paper sd = sd of its 5 trials", "agacd", map_label, pv, jv, v))
    contrast = contrast_coefficients(r.coded, r.means)
    all_trials = np.concatenate([np.asarray(x, float) for x in P.AGACD_TABLE5])
    pv, jv, v = mean_row((P.AGACD_EQ31[0], float(np.std(all_trials, ddof=1))),
                         np.asarray(r.responses, float).ravel(), why,
                         n_label=f"{np.isfinite(r.responses).sum()} runs")
    rows.append(Row(AGACD, "Table 5 / eq. 31", "X0 (grand mean); paper sd = sd of its 45 "
                    "trials", "agacd", map_label, pv, jv, v))
    names = [f.name.split(".")[-1] for f in r.factors]
    for k in range(1, 6):
        p, j = P.AGACD_EQ31[k], float(contrast[k])
        same = np.sign(p) == np.sign(j)
        rows.append(Row(AGACD, "Table 5 / eq. 31", f"X{k} ({names[k - 1]}), contrast "
                        "estimate mean(F * y)", "agacd", map_label, f"{p:+.5f}",
                        f"{j:+.5f}", "same sign" if same else f"opposite sign: {why}"))
    c_best, c_pred = predicted_best(contrast, "max")
    agree = int(np.sum(np.asarray(c_best) == np.asarray(P.AGACD_BEST)))
    rows.append(Row(AGACD, "5.2.1 (eq. 31 maximised)", "best coded combination "
                    "(predicted value)", "agacd", map_label,
                    f"{tuple(P.AGACD_BEST)} ({P.AGACD_PREDICTED})",
                    f"{tuple(int(c) for c in c_best)} ({c_pred:.5f})",
                    "equal" if agree == 5 else
                    f"different ({agree} of 5 factors agree): {why}"))
    a = _agacd20_run(ctx)
    conf = np.asarray(a.fitness, float)[:seeds]
    conf = np.where(a.success[:seeds], conf, np.nan)
    conf_post = preset_fitness(a, ctx.grid("agacd20"))[:seeds]
    p_sd = float(np.std(P.AGACD_CONFIRMATION, ddof=1))
    p_mean = float(np.mean(P.AGACD_CONFIRMATION))
    for which, values in (("before the optimisation operator (Result.fitness)", conf),
                          ("after it (post-optimised path)", conf_post)):
        pv, jv, v = mean_row((p_mean, p_sd), values, why)
        rows.append(Row(AGACD, "5.2.1 confirmation", "fitness at the paper's best "
                        f"combination (Table 6 = preset agacd), {which}",
                        "agacd (seeds of the DOE)", map_label, pv, jv, v))
    ls = ", ".join(f"{n} = {f.value(int(c)):g}" for n, f, c in
                   zip(names, r.factors, r.best_coded))
    notes = [f"{seeds} runs per design point (the same seeds for every point); the "
             "response is `Result.fitness`, the best individual's AGACD fitness before the "
             "optimisation operator, as this reproduction records it. jaxga's "
             f"least-squares fit predicts its best at {ls} ({r.predicted:.5f}); measured "
             f"there {r.confirmation_mean:.5f}. The confirmation rows run the paper's own "
             "best combination (the preset's Table 6 parameters) with the DOE's seeds "
             "(same population capacity 60, so the same runs as the DOE would make)."]
    return rows, notes


# ------------------------------------------------------------------ AGACD Tables 7-9
def table_agacd8(ctx: Context) -> tuple[list[Row], list[str]]:
    """AGACD Tables 7-9 (20 x 20): AGACD and the BGA, 20 runs each."""
    grid = ctx.grid("agacd20")
    map_label = MAPS["agacd20"][0]
    a, b = _agacd20_runs(ctx)
    why = ("stand-in map (the fitness's safety term and the reachable smoothness depend "
           "on the obstacles)")
    why_conv = ("convergence generation = first generation holding the final best (the "
                "paper does not define it); stand-in map")
    rows: list[Row] = []
    fits = {
        "AGACD": {"before": _ok(a, a.fitness), "after": preset_fitness(a, grid)},
        "BGA": {"before": _ok(b, b.fitness), "after": preset_fitness(b, grid)},
    }
    for alg, r, label in (("AGACD", a, "agacd"), ("BGA", b, "sga variant agacd")):
        (p_fit, p_fit_sd), (p_conv, p_conv_sd), (p_time, p_time_sd) = P.AGACD_TABLE8[alg]
        which = ((("before", "fitness of the best before the optimisation operator "
                              "(Result.fitness)"),
                  ("after", "fitness of the post-optimised path"))
                 if alg == "AGACD" else
                 (("before", "fitness of the best (no optimisation operator)"),))
        for k, text in which:
            pv, jv, v = mean_row((p_fit, p_fit_sd), fits[alg][k], why)
            rows.append(Row(AGACD, "Tables 8-9", f"average fitness: {text}", label,
                            map_label, pv, jv, v))
        pv, jv, v = mean_row((p_conv, p_conv_sd), _ok(r, r.convergence_generation),
                             why_conv, digits=1)
        rows.append(Row(AGACD, "Tables 8-9", "average convergence iteration number",
                        label, map_label, pv, jv, v))
        pv, jv, v = time_row(f"{p_time} ± {p_time_sd} s", r)
        rows.append(Row(AGACD, "Tables 8-9", "average program running time", label,
                        map_label, pv, jv, v))
        init, evol, total = P.AGACD_TABLE7[alg]
        pv, jv, v = time_row(f"init {init} + evolution {evol} = {total} s", r)
        rows.append(Row(AGACD, "Table 7", "running time of each stage", label, map_label,
                        pv, jv, v))
        for k in ("before", "after") if alg == "AGACD" else ("before",):
            vals = fits[alg][k]
            pv, jv, v = single_row(P.AGACD_TABLE8_BEST[alg], float(np.nanmax(vals)), vals,
                                   why, stat_label="jaxga best")
            rows.append(Row(AGACD, "5.2.5 (Fig. 8)", f"best fitness of the runs ({k} the "
                            "optimisation operator)" if alg == "AGACD" else
                            "best fitness of the runs", label, map_label, pv, jv, v))
    pv, jv, v = wins_row(P.AGACD_TABLE8_WINS, np.nan_to_num(fits["AGACD"]["after"]),
                         np.nan_to_num(fits["BGA"]["before"]), why)
    rows.append(Row(AGACD, "5.2.5 (Fig. 8)", "runs in which AGACD's fitness beats BGA's "
                    "(run i against run i; AGACD post-optimised)", "agacd vs sga variant "
                    "agacd", map_label, pv, jv, v))
    shortened = int(np.sum(a.success & (a.length < a.raw_length - 1e-6)))
    notes = [f"{len(a.seeds)} runs each, Table 6's settings (population 60, 300 "
             "generations; AGACD pc 0.65-0.7, pm 0.15-0.3; BGA pc 0.8, pm 0.3). Every "
             "fitness is AGACD's eq. 7-8 (Delphi weights 0.4118, 0.3431, 0.2451, smoothness "
             "floor 0.1 rad): the BGA evolves on it too (`sga` variant `agacd`; 1 / length "
             "cannot reach Table 8's 0.2072). The post-optimised fitness is the preset's "
             "objective evaluated on the final path (`jaxga.engine.fitness_function`). "
             f"AGACD's optimisation operator shortened {shortened} of {len(a.seeds)} final "
             "paths (on the others it dropped collinear nodes at most: after 300 "
             "generations of waypoint crossover and mutation there was nothing left to "
             "shortcut)."]
    return rows, notes


# ------------------------------------------------------------------ AGACD Tables 11-13
AGACD50_SETS = {
    "AGACD": ("agacd", "50x50", (f"population.capacity={CAPACITY_50}",)),
    "MPMGA": ("mpmga", "50x50", (f"population.capacity={CAPACITY_50}",
                                 "init.max_tries=300")),
    "BGA": ("sga", "50x50", (f"population.capacity={CAPACITY_50}", "init.max_tries=3000",
                             "fitness.method=agacd", "fitness.importance_ratios=[1.2, 1.4]",
                             "fitness.smoothness_floor=0.1")),
}
"""AGACD Table 10's three algorithms on the 50 x 50 stand-in: preset, variant, keys. The
initialisers' attempt budgets are raised so that they fill their populations (the
random walk succeeds in about 0.05 % of its attempts there, the intermittent path in
about 1.4 %); the BGA evolves on AGACD's fitness as in Table 8 (``sga`` variant
``agacd``'s keys on top of variant ``50x50``)."""


def _agacd50_runs(ctx: Context) -> dict[str, Result]:
    """The three 50 x 50 runs of AGACD Table 10 (shared with MPMGA's Tables 6-7)."""
    seeds = ctx.n(P.AGACD_RUNS)
    return {alg: ctx.run(preset, "agacd50", seeds, variant, sets, label=f"{alg} 50x50")
            for alg, (preset, variant, sets) in AGACD50_SETS.items()}


def table_agacd12(ctx: Context) -> tuple[list[Row], list[str]]:
    """AGACD Tables 11-13 (50 x 50): AGACD, MPMGA and the BGA, 20 runs each, every
    fitness in AGACD's eq. 7."""
    grid = ctx.grid("agacd50")
    map_label = MAPS["agacd50"][0]
    runs = _agacd50_runs(ctx)
    why = ("stand-in map (AGACD's fitness counts the path's turns and the obstacles beside "
           "it: it depends on the map)")
    rows: list[Row] = []
    final: dict[str, np.ndarray] = {}
    for alg, r in runs.items():
        preset, variant, sets = AGACD50_SETS[alg]
        label = f"{preset} variant {variant}" + ("" if alg == "AGACD" else
                                                 " (keys in the runs table)")
        (p_fit, p_fit_sd), (p_conv, p_conv_sd), (p_time, p_time_sd) = P.AGACD_TABLE12[alg]
        before = agacd_fitness(r, grid, raw=True)
        after = agacd_fitness(r, grid)
        final[alg] = after
        which = [("before", "AGACD fitness of the best before the optimisation operator",
                  before)]
        if alg != "BGA":
            which.append(("after", "AGACD fitness of the post-optimised path", after))
        else:
            which[0] = ("before", "AGACD fitness of the best (no optimisation operator)",
                        before)
        for _, text, values in which:
            pv, jv, v = mean_row((p_fit, p_fit_sd), values, why)
            rows.append(Row(AGACD, "Tables 12-13", f"average fitness: {text}", label,
                            map_label, pv, jv, v))
        pv, jv, v = mean_row((p_conv, p_conv_sd), _ok(r, r.convergence_generation),
                             "convergence generation of its own fitness; stand-in map",
                             digits=1)
        rows.append(Row(AGACD, "Tables 12-13", "average convergence iteration number",
                        label, map_label, pv, jv, v))
        pv, jv, v = time_row(f"{p_time} ± {p_time_sd} s", r)
        rows.append(Row(AGACD, "Tables 12-13", "average program running time", label,
                        map_label, pv, jv, v))
        init, evol, total = P.AGACD_TABLE11[alg]
        pv, jv, v = time_row(f"init {init} + evolution {evol} = {total} s", r)
        rows.append(Row(AGACD, "Table 11", "running time of each stage", label, map_label,
                        pv, jv, v))
        if alg in P.AGACD_TABLE12_BEST:
            pv, jv, v = single_row(P.AGACD_TABLE12_BEST[alg], float(np.nanmax(after)),
                                   after, why, stat_label="jaxga best, final path")
            rows.append(Row(AGACD, "5.3.5 (Fig. 14)", "best fitness of the runs (final "
                            "path)", label, map_label, pv, jv, v))
    for other, paper in P.AGACD_TABLE12_WINS.items():
        pv, jv, v = wins_row(paper, np.nan_to_num(final["AGACD"]),
                             np.nan_to_num(final[other]), why)
        rows.append(Row(AGACD, "5.3.5 (Fig. 14)", f"runs in which AGACD's fitness beats "
                        f"{other}'s (run i against run i; final paths)",
                        f"agacd vs {AGACD50_SETS[other][0]}", map_label, pv, jv, v))
    notes = [f"{len(runs['AGACD'].seeds)} runs each, Table 10's settings (AGACD population "
             "80, 500 generations, pc 0.75-0.9, pm 0.15-0.3; MPMGA 3 x 15, 500 generations, "
             "pc 0.3 / 0.8, pm 0.1 / 0.6, temperature 1, decay 0.9; BGA population 60, 500 "
             "generations, pc 0.9, pm 0.3). MPMGA evolves on its own fitness (eq. 3) and is "
             "scored with AGACD's; the BGA evolves on AGACD's. Path capacity "
             f"{CAPACITY_50} cells for all three (see the map column), and larger attempt "
             "budgets for the random-walk and intermittent initialisers (runs table)."]
    return rows, notes


# ------------------------------------------------------------------ MPMGA Tables 2-7
WHY_TIME = ("jaxga's SGA time is mostly its random-walk initialisation (its attempt budget "
            "in the runs table); jaxga's MPMGA runs its islands as one batch")
def table_mpmga(ctx: Context) -> tuple[list[Row], list[str]]:
    """MPMGA Tables 3-7: times, the claims of the text, Figs. 15-16."""
    seeds = ctx.n(P.MPMGA_RUNS)
    grid = ctx.grid("mpmga25")
    map25 = MAPS["mpmga25"][0]
    m = ctx.run("mpmga", "mpmga25", seeds, sets=("init.max_tries=300",),
                label="MPMGA 25x25")
    s = ctx.run("sga", "mpmga25", seeds, "mpmga", label="MPMGA's SGA 25x25")
    rows: list[Row] = []
    for alg, r, label in (("MPMGA", m, "mpmga (`init.max_tries=300`)"),
                          ("SGA", s, "sga variant mpmga")):
        init, evol, post, total = P.MPMGA_TABLE3[alg]
        post_text = f" + second optimisation {post}" if post is not None else ""
        pv, jv, v = time_row(f"init {init} + evolution {evol}{post_text} = {total} s", r)
        rows.append(Row(MPMGA, "Table 3", "running time of each stage", label, map25, pv,
                        jv, v))
    rows.append(not_compared(MPMGA, "Tables 3-7", "all", "PCDA", map25, "see the tables",
                             "PCDA (programmed cell death algorithm, literature [20]) is "
                             "not implemented"))
    rows.append(not_compared(MPMGA, "Table 4", "all (fitness, length, smoothness, "
                             "convergence iterations, running time)", "MPMGA, SGA", map25,
                             "not legible", "only the table's headers survive in our copy; "
                             "the claims of its text are compared below"))
    why25 = "stand-in map; the paper's Table 4 values are unknown"
    claims = _mpmga_claims(m, s, grid)
    for quantity, claim in P.MPMGA_CLAIMS:
        a, b = claims[quantity]
        pv, jv, v = direction_row(claim, a, b, ("MPMGA", "SGA"),
                                  WHY_TIME if "time" in quantity else why25)
        rows.append(Row(MPMGA, "Table 4 (text of 5.2.4)", quantity, "mpmga vs sga variant "
                        "mpmga", map25, pv, jv, v))
    for alg, r, label in (("MPMGA", m, "mpmga"), ("SGA", s, "sga variant mpmga")):
        conv = _ok(r, r.convergence_generation)
        pv, jv, v = single_row(P.MPMGA_CONVERGENCE[alg], float(np.nanmean(conv)), conv,
                               "the figure shows one run; stand-in map", digits=1,
                               stat_label="jaxga mean")
        rows.append(Row(MPMGA, "5.2.2 (Fig. 15)", "generation of convergence ('around')",
                        label, map25, pv, jv, v))
    std = np.asarray(s.history["std"], float)
    stall = P.MPMGA_SGA_STALL
    late = std[:, stall:] if std.shape[1] > stall else std[:, -1:]
    per_run = np.where(s.success, late.max(axis=1), np.nan)
    pv, jv, v = single_row(0.0, float(np.nanmean(per_run)), per_run,
                           "jaxga's SGA keeps some diversity; stand-in map", digits=5,
                           tol=1e-9, stat_label="mean over runs of the largest sd after "
                           f"generation {stall}")
    rows.append(Row(MPMGA, "5.2.2 (Fig. 16)", f"SGA population fitness sd after generation "
                    f"{stall} (the paper: zero, the population homogeneous)",
                    "sga variant mpmga", map25, pv, jv, v))
    rows.append(not_compared(MPMGA, "Table 5", "algorithm parameters (50 x 50)", "all",
                             "-", "not legible", "only its title survives; the 50 x 50 rows "
                             "use AGACD Table 10's MPMGA and BGA rows (the same authors' "
                             "50 x 50 runs, preset variants 50x50)"))
    runs50 = _agacd50_runs(ctx)
    map50 = MAPS["agacd50"][0] + "; the runs of AGACD Tables 11-13"
    for alg, key in (("MPMGA", "MPMGA"), ("SGA", "BGA")):
        init, evol, post, total = P.MPMGA_TABLE6[alg]
        post_text = f" + second optimisation {post}" if post is not None else ""
        pv, jv, v = time_row(f"init {init} + evolution {evol}{post_text} = {total} s",
                             runs50[key])
        rows.append(Row(MPMGA, "Table 6", "running time of each stage",
                        f"{AGACD50_SETS[key][0]} variant 50x50", map50, pv, jv, v))
    rows.append(not_compared(MPMGA, "Table 7", "all", "MPMGA, SGA", map50, "not legible",
                             "only its title survives; the claims of 5.3.4 are compared "
                             "below"))
    claims50 = _mpmga_claims(runs50["MPMGA"], runs50["BGA"], ctx.grid("agacd50"))
    why50 = ("stand-in map; the SGA is AGACD's BGA (Table 10), evolving on AGACD's fitness "
             "(MPMGA Table 5 is not legible)")
    for quantity, claim in P.MPMGA_CLAIMS:
        a, b = claims50[quantity]
        pv, jv, v = direction_row(claim, a, b, ("MPMGA", "SGA"),
                                  WHY_TIME if "time" in quantity else why50)
        rows.append(Row(MPMGA, "Table 7 (text of 5.3.4)", quantity, "mpmga vs sga, "
                        "variant 50x50", map50, pv, jv, v))
    notes = [f"{seeds} runs each on the 25 x 25 stand-in, Table 2's settings (MPMGA 3 x 20, "
             "200 generations, pc 0.1 / 0.8, pm 0.1 / 0.8, alpha 0.8, beta 0.2, c 1, "
             "temperature 1, decay 0.7; SGA population 60, 200 generations, pc 0.8, pm "
             "0.1, scored with MPMGA's fitness). MPMGA's intermittent initialiser gets 300 "
             "attempts per individual (the preset's 20 leave 26-46 of the 60 slots as "
             "copies on this map; the paper's population was full). Fitness, length and "
             "smoothness are of the final path (MPMGA post-optimised, SGA raw); the "
             "fitness is MPMGA's eq. 3 for both."]
    return rows, notes


def _mpmga_claims(m: Result, s: Result, grid: Any) -> dict[str, tuple[np.ndarray,
                                                                      np.ndarray]]:
    """Per quantity of :data:`paper_tables.MPMGA_CLAIMS`, MPMGA's and SGA's per-run
    values (final paths; fitness = MPMGA's eq. 3 with the MPMGA run's weights)."""
    def fit(r: Result) -> np.ndarray:
        """MPMGA's eq. 3 (the MPMGA run's weights) of ``r``'s final paths."""
        return _ok(r, objective(m.config, grid, r.cells, r.n_cells))

    names = [q for q, _ in P.MPMGA_CLAIMS]
    values = (
        (fit(m), fit(s)),
        (_ok(m, m.length), _ok(s, s.length)),
        (mpmga_smoothness(m, grid), mpmga_smoothness(s, grid)),
        (_ok(m, m.convergence_generation), _ok(s, s.convergence_generation)),
        (per_run_seconds(m), per_run_seconds(s)),
    )
    return dict(zip(names, values))


# ------------------------------------------------------------------ IMGA Table 3
def table_imga(ctx: Context) -> tuple[list[Row], list[str]]:
    """IMGA Table 3 (environment 4); Tables 1, 2 and 4 listed as not compared."""
    seeds = ctx.n(P.IMGA_RUNS)
    grid = ctx.grid("imga4")
    map_label = MAPS["imga4"][0]
    rows: list[Row] = []
    any_angle = any_angle_shortest_path(grid).length
    why = {
        "IMGA": f"the paper's best (of an unstated number of runs) is "
                f"{100 * (P.IMGA_TABLE3['IMGA'][0] / any_angle - 1):.1f} % above the "
                f"any-angle optimum {any_angle:.4f}; map identity inferred",
        "GA": "the paper's GA best is 6.0 above the 8-connected optimum; map identity "
              "inferred",
    }
    for alg, preset, variant, sets in (("GA", "sga", "imga", ("init.max_tries=300",)),
                                       ("IMGA", "imga", None, ())):
        r = ctx.run(preset, "imga4", seeds, variant, sets, label=f"IMGA Table 3 {alg}")
        label = preset + (f" variant {variant}" if variant else "") + \
            "".join(f", `{s}`" for s in sets)
        lengths = _ok(r, r.length)
        best = int(np.nanargmin(lengths))
        p_len, p_turns, p_tang = P.IMGA_TABLE3[alg]
        pv, jv, v = single_row(p_len, float(lengths[best]), lengths, why[alg],
                               stat_label=f"jaxga best, run {best}")
        rows.append(Row(IMGA, f"Table 3, {alg}", "optimal path length" + (
            " (after the delete operation)" if alg == "IMGA" else ""), label, map_label,
            pv, jv, v))
        for quantity, paper, key in (("number of turns of that path", p_turns, "turns"),
                                     ("number of tangencies of that path", p_tang,
                                      "tangencies")):
            vals = _ok(r, r.metrics[key])
            pv, jv, v = single_row(paper, float(vals[best]), vals, why[alg], integer=True,
                                   stat_label="jaxga's best path")
            rows.append(Row(IMGA, f"Table 3, {alg}", quantity, label, map_label, pv, jv,
                            v))
    opt = shortest_path(grid).length
    p_len = P.IMGA_TABLE3["Literature [37]"][0]
    rows.append(Row(IMGA, "Table 3, literature [37]", "optimal path length",
                    "exact 8-connected optimum (jaxga.reference)", map_label, _f(p_len),
                    _f(opt), "equal (by construction: the map was identified by this "
                    "length)" if abs(opt - p_len) < 1e-3 else "different: map identity"))
    rows.append(not_compared(IMGA, "Table 3, literature [37]", "turns, tangencies",
                             "literature [37]", map_label, "13, 8",
                             "literature [37]'s algorithm is not implemented"))
    rows.append(not_compared(IMGA, "Table 1", "path length and turns with / without the "
                             "delete operation", "IMGA", "environments 1-3",
                             "see Table 1", "environments 1-3 (10 x 10, 15 x 15, 20 x 20) "
                             "are only figures"))
    rows.append(not_compared(IMGA, "Table 2", "runs reaching the optimum vs max_gen",
                             "IMGA", "environment 3", "see Table 2",
                             "environment 3 is only a figure"))
    p_len4, p_time4 = P.IMGA_TABLE4["IMGA"]
    rows.append(not_compared(IMGA, "Table 4", "optimal path length, running time",
                             "IMGA, BCA", "environment 5", f"IMGA {p_len4}, {p_time4} s",
                             "environment 5 is only a figure; BCA (literature [38]) is "
                             "not implemented"))
    notes = [f"{seeds} runs each (the paper does not give Table 3's run count; 30 as its "
             "Table 4), IMGA 5.1's settings (NP 100, max_gen 50, PC 0.8, PM 0.2, a, b, c = "
             "6, 1, 3; GA: `sga` variant `imga`, the same control parameters, its random "
             "walk allowed 300 attempts per individual: with the preset's 100 a few runs "
             "start with copies). jaxga's "
             "value is its best run (shortest final path) and that path's turns and "
             "tangencies (segments touching a blocked cell, `jaxga.core.objectives."
             "tangencies`); the range is over all runs."]
    return rows, notes


# ------------------------------------------------------------------ Zhang Table 1
def table_zhang(ctx: Context) -> tuple[list[Row], list[str]]:
    """Zhang's Table 1: garbled in our copy; the direction of its claim on a stand-in."""
    seeds = ctx.n(P.ZHANG_RUNS)
    gens = P.ZHANG_ITERATIONS[0]
    map_label = MAPS["zhang"][0]
    imp = ctx.run("iga_zhang", "zhang", seeds, label="Zhang improvement")
    ordinary = ctx.run("sga", "zhang", seeds, sets=(f"generations={gens}",),
                       label="Zhang ordinary")
    rows = [not_compared(ZHANG, "Table 1, environments 1-3", "path length, turns, 45-, "
                         "90-, 135-degree angles", "ordinary, improvement", "environments "
                         "1-3", "garbled", "every cell of a row repeats one number in our "
                         "copy (14.01, 7, 0, 2, 2, 13.38); the maps are not given")]
    values = {
        "path length": (_ok(imp, imp.length), _ok(ordinary, ordinary.length)),
        "number of turns": (_ok(imp, imp.metrics["turns"]),
                            _ok(ordinary, ordinary.metrics["turns"])),
    }
    for quantity, claim in P.ZHANG_CLAIMS:
        a, b = values[quantity]
        pv, jv, v = direction_row(claim, a, b, ("improvement", "ordinary"),
                                  "stand-in map", digits=2)
        rows.append(Row(ZHANG, "Table 1, environment 1 (text under it)", quantity,
                        "iga_zhang vs sga (generations 45)", map_label, pv, jv, v))
    rows.append(not_compared(ZHANG, "Table 1, environments 2 and 3", "as environment 1",
                             "ordinary, improvement", "environments 2-3", "garbled",
                             "maps not given; environment 1's 45 iterations run above "
                             "(preset variants env2 / env3 hold 40 and 35)"))
    notes = [f"{seeds} runs each (the paper gives no count). 'improvement' = preset "
             "`iga_zhang` (population 60, 45 iterations, pc 0.8, corner-deleting mutation "
             "with probability 1); 'ordinary' = `sga` with the same population, iterations "
             "and pc (its pm 0.3: the paper gives none for the traditional GA)."]
    return rows, notes


TABLE_FUNCTIONS: dict[str, tuple[str, Callable[[Context], tuple[list[Row], list[str]]]]] = {
    "zhu2": (f"{ZHU}, Table 2 (initialisation)", table_zhu2),
    "zhu4": (f"{ZHU}, Table 4 (path planning)", table_zhu4),
    "agacd5": (f"{AGACD}, Table 5 (DOE, eq. 31)", table_agacd5),
    "agacd8": (f"{AGACD}, Tables 7-9 (20 x 20)", table_agacd8),
    "agacd12": (f"{AGACD}, Tables 11-13 (50 x 50)", table_agacd12),
    "mpmga": (f"{MPMGA}, Tables 3-7", table_mpmga),
    "imga": (f"{IMGA}, Tables 1-4", table_imga),
    "zhang": (f"{ZHANG}, Table 1", table_zhang),
}


# ------------------------------------------------------------------ report
VERDICT_CLASSES = (
    ("agree", ("within the paper's spread", "within jaxga's spread", "equal",
               "within jaxga's range", "same direction", "same sign")),
    ("different", ("different", "opposite")),
    ("time", (TIME,)),
    ("not compared", ("not compared",)),
)


def verdict_class(verdict: str) -> str:
    """The summary column a verdict counts in."""
    for name, starts in VERDICT_CLASSES:
        if verdict.startswith(starts):
            return name
    return "other"


def summary_table(sections: list[tuple[str, list[Row]]]) -> str:
    """One line per reproduced table: rows agreeing, different, times, not compared."""
    out = []
    for title, rows in sections:
        counts = {name: 0 for name, _ in VERDICT_CLASSES}
        for row in rows:
            counts[verdict_class(row.verdict)] = counts.get(verdict_class(row.verdict), 0) + 1
        out.append([title, len(rows), counts["agree"], counts["different"], counts["time"],
                    counts["not compared"]])
    return markdown_table(["paper, tables", "rows", "agree (spread, range, equal, "
                           "direction, sign)", "different", "times (not comparable)",
                           "not compared"], out)


def main() -> None:
    """Run the selected tables, print them and record one RESULTS.md section."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=None,
                    help="runs per row for every table (default: each paper's own count: "
                         "Zhu 30, AGACD 20 and its DOE 5, MPMGA 20, IMGA and Zhang 30)")
    ap.add_argument("--tables", default=",".join(TABLES),
                    help=f"comma-separated subset of {','.join(TABLES)}")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    chosen = [t.strip() for t in args.tables.split(",") if t.strip()]
    unknown = [t for t in chosen if t not in TABLES]
    if unknown:
        ap.error(f"unknown table(s) {', '.join(unknown)}: choose from {', '.join(TABLES)}")
    if args.seeds is not None and args.seeds < 2:
        ap.error("--seeds must be at least 2 (an sd needs two runs)")
    jaxga._runtime.parallel.use_all_cores()
    load0 = os.getloadavg()
    ctx = Context(seeds=args.seeds)
    t_all = time.perf_counter()
    sections: list[tuple[str, list[Row]]] = []
    parts: list[str] = []
    for key in TABLES:
        if key not in chosen:
            continue
        title, fn = TABLE_FUNCTIONS[key]
        print(f"== {title}", flush=True)
        t0 = time.perf_counter()
        rows, notes = fn(ctx)
        wall = time.perf_counter() - t0
        table = markdown_table(HEADERS, [r.cells() for r in rows])
        print(table, flush=True)
        print(f"({wall:.1f} s)", flush=True)
        sections.append((title, rows))
        parts.append(f"### {title}\n\n" + " ".join(notes) + f" Wall time {wall:.0f} s.\n\n"
                     + table)
        clear_compiled()  # XLA:CPU programs map memory regions; free them between tables
    wall = time.perf_counter() - t_all
    runs = markdown_table(["run", "preset", "map", "extra keys (all: `init.fallback=none`)",
                           "runs", "success", "init success %", "copied initial "
                           "individuals", "compile s", "s per run", "wall s"], ctx.log)
    seeds_text = (f"{args.seeds} runs per row in every table" if args.seeds else
                  "each paper's own run count (Zhu & Pan 30, AGACD 20 and its DOE 5 per "
                  "point, MPMGA 20; IMGA and Zhang give none for these tables: 30)")
    body = f"""
Every comparable table of the five papers beside jaxga under the paper's settings:
{seeds_text}; corner rule free; the papers' initialisers alone (`init.fallback =
none`); every core (results do not depend on the device count). The papers' numbers
are transcribed in `benchmarks/paper_tables.py` (table and row cited per number).

Verdicts: (1) the paper gives mean and sd: **within the paper's spread** when |jaxga
mean - paper mean| <= the paper's sd; (2) a mean without sd: **within jaxga's spread**
when the difference is at most jaxga's sd over its runs (paired wins: the binomial sd);
(3) one value (minimum, best run, turns): **equal** within 0.1 % (integers: the same),
else **within jaxga's range** (between its smallest and largest run); (4) a claim of the
text: **same / opposite direction** of jaxga's means, a regression coefficient: **same /
opposite sign**; (5) running times (MATLAB on the papers' 2018-2023 machines): **{TIME}**;
(6) **not compared**, with the reason. Otherwise **different**, with jaxga's relative
difference and the row's reason. The map column names the map that ran: the papers'
maps are only figures; three built-in maps are identified with paper maps by equal
optimal lengths (**inferred**), the others are **stand-ins**.

{summary_table(sections)}

{(chr(10) * 2).join(parts)}

Wall time of the whole reproduction: {wall:.0f} s (compilation included); load average
before {', '.join(f'{v:.1f}' for v in load0)}, after
{', '.join(f'{v:.1f}' for v in os.getloadavg())} on a shared 2-core machine.
"""
    record("Paper reproduction: the five papers' tables beside jaxga", body,
           write=not args.no_write)
    print(f"""
### jaxga runs

Every run above (a run shared by two tables is listed once): success = runs that
returned a feasible path; init success = share of the initialiser's attempts that made
a path; copied = initial individuals that are copies because the initialiser's attempt
budget ran out (`Result.init_unfilled`, summed over runs); s per run = (init + evolve
+ post) / runs of the batch, after compilation.

{runs}""")


if __name__ == "__main__":
    main()
