""":func:`run_doe`: a DOE as a composition of phases over a plan (the response checked, the
plan, the points run, the fit, the confirmation).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxga import api
from jaxga._runtime.device_probe import run_environment
from jaxga._runtime.size_classes import auto_size_class
from jaxga.config.schema import Config
from jaxga.core.errors import NoPathError
from jaxga.core.grid import Grid
from jaxga.core.own_settings import own_settings
from jaxga.doe.checkpoint import decode
from jaxga.doe.confirmation import run_confirmation
from jaxga.doe.design import Factor
from jaxga.doe.fit import fit_linear, point_means, predicted_best, seed_responses
from jaxga.doe.plan import DoePlan, checked_response, plan_doe
from jaxga.doe.result import DoeResult


@own_settings
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

    ``preset``, ``grid``, ``generations``, ``corner_rule``, ``variant``, ``sets`` and the
    keyword overrides are those of :func:`jaxga.run`; the factors are applied on top.

    Args:
        factors: the :class:`Factor` s, assigned to the columns of ``design`` in
            :func:`~jaxga.doe.design.design_array`'s order.
        design: one of :data:`DESIGNS`.
        seeds: a count or explicit seeds; every point and the confirmation run use them.
        response: one of :data:`RESPONSES` (``"angle_sum"`` is ``"smoothness"``);
            ``direction`` (``"max"`` / ``"min"``) overrides its default.
        checkpoint: a directory for a resumable run (see :mod:`jaxga.doe`).
        block: design points per compiled call; default all of them (one call) without
            a checkpoint, 1 with one.
        progress: optional callback ``(points done, points total)``.

    Returns:
        A :class:`DoeResult` (``to_json()`` is the ``jaxga doe --json`` layout).

    Raises:
        ParameterError: a factor, level or key combination of some design point is
            invalid (checked for every point before the first one runs), or a factor
            changes the fitness formula while the response is ``fitness``.
        NoPathError: the goal is unreachable, or no seed of any design point found a
            path (nothing to fit; the message carries the runs' reason).
    """
    t_start = time.perf_counter()
    response, direction = checked_response(response, direction)
    plan = plan_doe(preset, grid, factors, design, seeds, generations, corner_rule, variant,
                 sets, checkpoint, block, progress, overrides, response)
    results, reasons, sweep_s, compile_s = _run_points(plan, progress)
    all_responses = {k: np.stack([r[k] for r in results]) for k in results[0]}
    if not np.any(all_responses["success"]):  # nothing to fit: say why
        raise NoPathError("no seed of any design point found a path"
                          + "".join(f"; {r}" for r in reasons[:2]))
    coef = fit_linear(plan.coded, point_means(all_responses[response]))
    best, predicted = predicted_best(coef, direction)
    t0 = time.perf_counter()
    confirm, confirm_compile_s = run_confirmation(plan, best)
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
        corner_rule=plan.loaded.corner_rule, start=plan.loaded.start_xy,
        goal=plan.loaded.goal_xy, map_digest=plan.loaded.cells_digest(),
        path_capacity=plan.path_capacity, environment=run_environment(),
        size_class=auto_size_class(plan.loaded),  # the sweeps' automatic size class
    )


def _run_points(plan: DoePlan, progress) -> tuple:
    """Every design point's per-seed responses, ``block`` points per compiled call, the
    points a checkpoint holds read instead of run: ``(responses per point, reasons the
    seeds found no path, sweep seconds, compile seconds)``."""
    n_points = len(plan.points)
    results: list[dict[str, np.ndarray] | None] = [None] * n_points
    reasons: list[str] = []  # why the seeds of the points found no path
    if plan.checkpoint is not None:
        for q, saved in enumerate(plan.checkpoint.load_points(n_points, len(plan.seeds))):
            if saved is not None:
                results[q] = decode(saved)
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
        out = api.sweep(plan.problem, None, [plan.points[q] for q in padded], plan.seeds,
                        population_capacity=plan.capacity)
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
