"""``jaxga.run``: many seeded runs of a preset on a map, in one compiled call.

SPEC 10-11. ``run(preset, grid, seeds=N, **overrides) -> Result``: the seeds are a
``jax.vmap`` (sharded over the available devices), the generations a ``lax.scan``;
initialisation, evolution and post-optimisation are three compiled functions so that
their times can be reported separately, as the papers' tables do. Compilation is timed
on its own.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.config import Config
from jaxga.engine import build, evolve, finish, init_state
from jaxga.errors import JaxgaError
from jaxga.grid import Grid

SUMMARY_METRICS = ("length", "raw_length", "angle_sum", "turns", "fitness",
                   "convergence_generation")


@dataclasses.dataclass
class Result:
    """Per-seed results of :func:`run` (NumPy arrays, leading axis = seeds)."""

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

    def path(self, i: int, raw: bool = False) -> list[tuple[int, int]]:
        """Seed ``i``'s best path as ``(x, y)`` cells (post-optimised unless ``raw``)."""
        c = self.raw_cells[i] if raw else self.cells[i]
        n = int(self.raw_n_cells[i] if raw else self.n_cells[i])
        return [(int(p) % self.width, int(p) // self.width) for p in c[:n]]

    @property
    def gap(self) -> np.ndarray:
        """Relative gap of each post-optimised length to the any-angle optimum (its lower
        bound); NaN for failed seeds."""
        return np.where(self.success, self.length / self.any_angle_optimum - 1.0, np.nan)

    @property
    def raw_gap(self) -> np.ndarray:
        """Relative gap of each raw (8-connected) length to the 8-connected optimum."""
        return np.where(self.success, self.raw_length / self.optimum - 1.0, np.nan)

    def _column(self, name: str) -> np.ndarray:
        if name in self.metrics:
            return np.asarray(self.metrics[name], float)
        return np.asarray(getattr(self, name), float)

    def summary_rows(self) -> list[tuple[str, float, float, float, float]]:
        """``(metric, mean, sd, min, max)`` over successful seeds (AGACD Tables 8-9)."""
        ok = self.success
        rows = []
        names = list(SUMMARY_METRICS) + ["gap", "raw_gap"]
        for name in names:
            v = (getattr(self, name) if name in ("gap", "raw_gap") else self._column(name))[ok]
            if v.size == 0:
                rows.append((name, math.nan, math.nan, math.nan, math.nan))
            else:
                rows.append((name, float(v.mean()), float(v.std(ddof=1)) if v.size > 1
                             else 0.0, float(v.min()), float(v.max())))
        return rows

    def summary(self) -> str:
        """A text table: mean, sd, min and max per metric, success rate, optima, timing."""
        lines = [
            f"preset {self.preset} on {self.map_name} (corner rule {self.corner_rule!r}), "
            f"{len(self.seeds)} seeds, population {self.population}, "
            f"{self.generations} generations",
            f"success {int(self.success.sum())}/{len(self.seeds)}"
            + (f" ({self.reason})" if self.reason else ""),
            f"optimum: 8-connected {self.optimum:.4f}, any-angle {self.any_angle_optimum:.4f}",
            f"{'metric':24s} {'mean':>10s} {'sd':>10s} {'min':>10s} {'max':>10s}",
        ]
        for name, mean, sd, lo, hi in self.summary_rows():
            lines.append(f"{name:24s} {mean:10.4f} {sd:10.4f} {lo:10.4f} {hi:10.4f}")
        t = self.timing
        lines.append(
            "time (s): compile {compile_s:.2f}, init {init_s:.3f}, evolve {evolve_s:.3f}, "
            "post {post_s:.3f}, total {total_s:.2f}".format(**t)
        )
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` layout of ``jaxga run``."""
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
                "fitness": float(self.fitness[i]),
                "convergence_generation": int(self.convergence_generation[i]),
                "history": {k: [float(x) for x in v[i]] for k, v in self.history.items()},
            })
        return {
            "preset": self.preset, "map": self.map_name, "corner_rule": self.corner_rule,
            "optimum": self.optimum, "any_angle_optimum": self.any_angle_optimum,
            "timing": dict(self.timing), "population": self.population,
            "generations": self.generations, "runs": runs,
        }


def _seed_list(seeds: int | Sequence[int]) -> np.ndarray:
    if isinstance(seeds, (int, np.integer)):
        if seeds < 1:
            raise JaxgaError(f"seeds must be >= 1, got {seeds}")
        return np.arange(int(seeds))
    arr = np.asarray(list(seeds), dtype=np.int64)
    if arr.size == 0:
        raise JaxgaError("seeds must not be empty")
    return arr


def _seed_sharding() -> jax.sharding.NamedSharding | None:
    """Leading (seed) axis split over all local devices; None with one device."""
    n = jax.device_count()
    if n == 1:
        return None
    mesh = jax.make_mesh((n,), ("seeds",), axis_types=(jax.sharding.AxisType.Auto,))
    return jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("seeds"))


def run(
    preset: str | Config,
    grid: Grid | str,
    seeds: int | Sequence[int] = 1,
    *,
    generations: int | None = None,
    corner_rule: str | None = None,
    variant: str | None = None,
    sets: Sequence[str] = (),
    progress: Callable[[str, float], None] | None = None,
    chunks: int = 1,
    **overrides: Any,
) -> Result:
    """Run ``preset`` on ``grid`` once per seed, all seeds in one compiled call.

    Args:
        preset: a preset name (``jaxga presets``), a TOML file, or a :class:`Config`.
        grid: a :class:`Grid`, a map file or a built-in map name. A map given by name is
            loaded with ``corner_rule`` or else the preset's ``map.corner_rule``; a Grid
            keeps its own unless ``corner_rule`` is given.
        seeds: a count ``N`` (seeds ``0..N-1``) or explicit integer seeds. Seed ``s``
            always gives the same run, whatever other seeds run with it.
        generations: overrides the preset's generation count.
        overrides: configuration keys with ``.`` written as ``__`` (e.g.
            ``crossover__probability=0.7``) or passed as a mapping in ``sets``-style
            strings through ``sets=("crossover.probability=0.7",)``.
        progress: optional callback ``(stage, fraction)``; with ``chunks > 1`` the
            generations run in that many compiled chunks (same result) for a progress bar.

    Returns:
        A :class:`Result`. Seeds that found no feasible path have ``success`` False and
        are never reported with a path. An unreachable goal gives all seeds
        ``success = False`` and ``reason`` naming the cause (nothing is run).
    """
    from jaxga.maps import load_map_info
    from jaxga.presets import load_preset
    from jaxga.reference import any_angle_shortest_path, shortest_path

    t_start = time.perf_counter()
    ov: dict[str, Any] = {k.replace("__", "."): v for k, v in overrides.items()}
    if generations is not None:
        ov["generations"] = int(generations)
    config = (preset.override(ov) if isinstance(preset, Config)
              else load_preset(preset, variant=variant, overrides=ov, sets=sets))
    if isinstance(grid, Grid):
        map_name = "grid"
        if corner_rule is not None:
            grid = grid.replace(corner_rule=corner_rule)
    else:
        info = load_map_info(grid, corner_rule=corner_rule or config["map.corner_rule"])
        grid, map_name = info.grid, info.name
    grid.check_endpoints()
    seed_arr = _seed_list(seeds)
    octile = shortest_path(grid)
    any_angle = any_angle_shortest_path(grid) if octile.found else octile
    algo, params = build(config, grid)
    n_seeds = len(seed_arr)
    n_dev = jax.device_count()
    padded = np.concatenate([seed_arr, np.repeat(seed_arr[-1:], (-n_seeds) % n_dev)])
    sh = _seed_sharding()
    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(padded, jnp.uint32))
    if sh is not None:
        keys = jax.device_put(keys, sh)

    def report(stage: str, frac: float) -> None:
        if progress is not None:
            progress(stage, frac)

    if not octile.found:
        return _no_path_result(config, map_name, grid, seed_arr, algo, octile.reason,
                               time.perf_counter() - t_start)

    def do_init(k):
        k_init = jax.random.fold_in(k, 0)
        state, stats = init_state(algo, k_init, grid, params)
        return state, stats.success_rate, stats.n_failed

    n_chunks = max(1, min(int(chunks), algo.generations))
    sizes = [algo.generations // n_chunks + (1 if i < algo.generations % n_chunks else 0)
             for i in range(n_chunks)]

    def do_evolve(k, state, n):
        return evolve(algo, jax.random.fold_in(k, 1), grid, state, params, n)

    def do_finish(state, hist, init_best):
        return finish(algo, grid, state, hist, params, init_best)

    # Every input and output has the seed axis first: one sharding for all of them, so
    # each device runs its share of the seeds and the result does not depend on the
    # device count.
    init_j = jax.jit(jax.vmap(do_init), in_shardings=sh, out_shardings=sh)
    evolve_j = jax.jit(jax.vmap(do_evolve, in_axes=(0, 0, None)), static_argnums=2,
                       in_shardings=(sh, sh) if sh else None, out_shardings=sh)
    finish_j = jax.jit(jax.vmap(do_finish), in_shardings=(sh, sh, sh) if sh else None,
                       out_shardings=sh)

    report("compile", 0.0)
    t0 = time.perf_counter()
    init_c = init_j.lower(keys).compile()
    state_shape = jax.eval_shape(init_j, keys)
    evolve_c = {n: evolve_j.lower(keys, state_shape[0], n).compile() for n in set(sizes)}
    hist_shape = jax.eval_shape(lambda k, s: evolve_j(k, s, sizes[0]), keys, state_shape[0])
    full_hist = jax.tree_util.tree_map(
        lambda h: jax.ShapeDtypeStruct((h.shape[0], algo.generations), h.dtype), hist_shape[1])
    finish_c = finish_j.lower(hist_shape[0], full_hist,
                              jax.ShapeDtypeStruct((len(padded),), jnp.float32)).compile()
    compile_s = time.perf_counter() - t0
    report("compile", 1.0)

    t0 = time.perf_counter()
    state, init_rate, unfilled = jax.block_until_ready(init_c(keys))
    init_s = time.perf_counter() - t0
    init_best = state.best_fitness

    t0 = time.perf_counter()
    hists = []
    done = 0
    for n in sizes:
        state, h = evolve_c[n](keys, state)
        jax.block_until_ready(state)
        hists.append(h)
        done += n
        report("evolve", done / algo.generations)
    history = {k: jnp.concatenate([h[k] for h in hists], axis=1) for k in hists[0]}
    evolve_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    out = jax.block_until_ready(finish_c(state, history, init_best))
    post_s = time.perf_counter() - t0

    sl = slice(0, n_seeds)
    host = jax.tree_util.tree_map(lambda a: np.asarray(a)[sl], out)
    hist = {k: np.asarray(v)[sl] for k, v in history.items()}
    success = host["success"] & host["feasible_post"]
    return Result(
        preset=config["name"], map_name=map_name, corner_rule=grid.corner_rule,
        seeds=seed_arr, success=success,
        reason="" if success.all() else "no feasible path found by some seeds",
        cells=host["cells"], n_cells=host["length"],
        raw_cells=host["raw_cells"], raw_n_cells=host["raw_length"],
        length=host["path_length"].astype(float), raw_length=host["raw_path_length"]
        .astype(float), fitness=host["fitness"].astype(float),
        convergence_generation=host["convergence_generation"],
        history=hist, metrics=host["metrics"], raw_metrics=host["raw_metrics"],
        failures=host["failures"],
        init_success_rate=np.asarray(init_rate).reshape(len(padded), -1).mean(axis=1)[sl],
        init_unfilled=np.asarray(unfilled).reshape(len(padded), -1).sum(axis=1)[sl],
        optimum=float(octile.length), any_angle_optimum=float(any_angle.length),
        timing={"compile_s": compile_s, "init_s": init_s, "evolve_s": evolve_s,
                "post_s": post_s, "total_s": time.perf_counter() - t_start},
        population=int(config["population.size"]) * algo.islands,
        generations=algo.generations, width=grid.width, config=config,
    )


def _no_path_result(config, map_name, grid, seeds, algo, reason, elapsed) -> Result:
    s = len(seeds)
    empty = np.zeros((s, 1), np.int32)
    nan = np.full(s, np.nan)
    return Result(
        preset=config["name"], map_name=map_name, corner_rule=grid.corner_rule, seeds=seeds,
        success=np.zeros(s, bool), reason=reason, cells=empty, n_cells=np.zeros(s, np.int32),
        raw_cells=empty, raw_n_cells=np.zeros(s, np.int32), length=nan, raw_length=nan,
        fitness=np.zeros(s), convergence_generation=np.full(s, -1),
        history={k: np.zeros((s, 0)) for k in ("best", "mean", "std")},
        metrics={}, raw_metrics={}, failures=np.zeros((s, 3), np.int32),
        init_success_rate=np.zeros(s), init_unfilled=np.zeros(s, np.int32),
        optimum=math.inf, any_angle_optimum=math.inf,
        timing={"compile_s": 0.0, "init_s": 0.0, "evolve_s": 0.0, "post_s": 0.0,
                "total_s": elapsed},
        population=int(config["population.size"]) * algo.islands,
        generations=algo.generations, width=grid.width, config=config,
    )


def summarise(results: Mapping[str, Result]) -> str:
    """Several results side by side (one block per preset)."""
    return "\n\n".join(r.summary() for r in results.values())
