"""The plan of a DOE (:class:`DoePlan`): every argument and every design point's key
combination checked before the first point runs.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from os import PathLike
from typing import Any

import jax
import numpy as np

import jaxga
from jaxga._runtime.device_probe import describe
from jaxga._runtime.memory import check_result_memory
from jaxga._runtime.seeds import seed_list
from jaxga.api import checked_capacity, load_problem
from jaxga.api.problem import Problem
from jaxga.config.presets import as_sets
from jaxga.config.schema import Config
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, as_integer
from jaxga.doe.checkpoint import Checkpoint, map_fingerprint
from jaxga.doe.design import Factor, check_factors, design_array, design_points
from jaxga.doe.fit import RESPONSE_ALIASES, RESPONSES
from jaxga.engine import build, check_combination
from jaxga.reference.optima import shortest_path


def checked_response(response: Any, direction: str | None) -> tuple[str, str]:
    """The response's name (an alias replaced) and the direction of its optimum."""
    response = RESPONSE_ALIASES.get(response, response) if isinstance(response, str) \
        else response
    if response not in RESPONSES:
        raise ParameterError(f"unknown response {response!r}: one of {', '.join(RESPONSES)}")
    direction = direction or RESPONSES[response]
    if direction not in ("max", "min"):
        raise ParameterError(f"direction must be 'max' or 'min', got {direction!r}")
    return response, direction


def check_response_factors(response: str, factors: Sequence[Factor]) -> None:
    """Refuse the ``fitness`` response of a design whose factors change the fitness
    formula itself (``fitness.*`` keys: weights, exponents, floors): its levels then
    differ in what a fitness value means, so the predicted best would be the level that
    scales fitness up (IMGA's ``1 / (aL + bS + cE)`` is largest at the smallest ``a``),
    not the one that searches better; as :func:`jaxga.compare` offers no fitness between
    presets. Any other response measures the path itself."""
    formula = [f.name for f in factors if f.name.startswith("fitness.")]
    if response == "fitness" and formula:
        others = ", ".join(r for r in RESPONSES if r != "fitness")
        raise ParameterError(
            f"factor {', '.join(formula)} changes the fitness formula itself, so the "
            "response 'fitness' would pick the level whose formula gives larger values, "
            f"not a better search: choose another response ({others})")


@dataclasses.dataclass(frozen=True)
class DoePlan:
    """A designed experiment, checked before any point runs: its configuration and map,
    the design (coded levels and the points' settings), the seeds, the points per
    compiled call, the checked problem every call runs (:func:`jaxga.problem`: the preset,
    its overrides and the map, loaded once) and the checkpoint."""

    config: Config
    loaded: Grid
    map_name: str
    factors: tuple[Factor, ...]
    coded: np.ndarray
    points: list[dict]
    capacity: int
    block: int
    seeds: np.ndarray
    problem: Problem
    checkpoint: Checkpoint | None
    path_capacity: int = 0


def plan_doe(preset: str | Config, grid: Grid | str, factors: Any, design: str,
             seeds: int | Sequence[int], generations: int | None, corner_rule: str | None,
             variant: str | None, sets: Sequence[str], checkpoint: str | PathLike | None,
             block: int | None, progress: Callable[[int, int], None] | None,
             overrides: Mapping[str, Any], response: str = "length") -> DoePlan:
    """Check every argument and every design point's key combination, and ``response``
    against the factors (:func:`check_response_factors`), before anything is built or
    written; the :class:`DoePlan` of :func:`run_doe`."""
    sets = as_sets(sets)  # one string is one set
    if not isinstance(factors, (str, bytes, Mapping)) and isinstance(factors, Iterable):
        factors = tuple(factors)
    if not isinstance(factors, tuple) or not all(isinstance(f, Factor) for f in factors):
        raise ParameterError(f"factors must be a list of jaxga.doe.Factor (Factor(name, "
                             f"(low, mid, high)) or Factor.parse('NAME=LOW,MID,HIGH')), got "
                             f"{factors!r}")
    check_response_factors(response, factors)
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable (done, total), got {progress!r}")
    if checkpoint is not None and not isinstance(checkpoint, (str, os.PathLike)):
        raise ParameterError(f"checkpoint must be a directory path, got {checkpoint!r}")
    if block is not None:
        try:
            block = as_integer(block)
        except TypeError:
            raise ParameterError(f"block must be an integer >= 1, got {block!r}") from None
    problem = load_problem(preset, grid, corner_rule, variant, sets, overrides, generations)
    config, loaded, map_name = problem.config, problem.grid, problem.map_name
    check_factors(config, factors)
    overridden = problem.given  # the call's overrides and --set, or a given Problem's
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
    seed_arr = seed_list(seeds, lambda n: check_result_memory(n * block, largest))
    shortest_path(loaded).raise_if_missing()  # nothing to fit: say why (NoPathError)
    ckpt = None
    if checkpoint is not None:
        ckpt = Checkpoint(checkpoint, {
            # 2: point files carry the experiment's mark; 3: the factors in their order (the
            # coded design's columns follow it, so another order is another experiment)
            "format": 3,
            "jaxga": jaxga.__version__,
            "jax": jax.__version__,
            # the contract of exactness lets another backend differ in rounding and its
            # runs per call (decision 040): points of two devices are not mixed in one fit
            "device": describe(jax.devices()[0]),
            "config": config.as_dict(),
            "map": map_fingerprint(loaded, map_name),
            "design": design,
            "coded": coded.tolist(),
            "factors": [[f.name, list(f.levels)] for f in factors],
            "seeds": [int(s) for s in seed_arr],
            "block": block,
            "capacity": capacity,
        })
    return DoePlan(config, loaded, map_name, factors, coded, points, capacity, block,
                    seed_arr, problem, ckpt, largest.capacity)
