"""A sweep's plan and its initialisation's outcome: the typed values the drivers of
:mod:`jaxga.api.runs` pass between their phases and build the results from (instead of
keyword bags)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from jaxga.config.schema import Config
from jaxga.core.grid import Grid
from jaxga.engine import Algorithm

__all__ = ["InitOutcome", "SweepPlan"]


@dataclasses.dataclass(frozen=True)
class SweepPlan:
    """A sweep checked and prepared before anything compiles.

    ``grid`` is the user's map: the results, the references and the paths are on it.
    ``program_grid`` is the map the programs run on: with the exact distance fields when
    an operator steers by them, padded to its size class when asked (decision 029).
    Without a path (``octile.found`` false) nothing runs: no ``algo``, programs' map or
    parameters."""

    config: Config
    configs: list[Config]
    points: Sequence[Mapping[str, Any]]
    map_name: str
    frame: Any
    grid: Grid
    capacity: int
    octile: Any
    seed_arr: np.ndarray
    size_class: bool = False
    map_source: dict | None = None
    algo: Algorithm | None = None
    program_grid: Grid | None = None
    per_point: list[dict] = dataclasses.field(default_factory=list)
    point_opt: list[Any] = dataclasses.field(default_factory=list)


@dataclasses.dataclass(frozen=True)
class InitOutcome:
    """What the initialisation did, for every run of every process (gathered, so that
    all of them decide alike whether to evolve)."""

    initial: np.ndarray
    rate: np.ndarray
    unfilled: np.ndarray
    from_fallback: np.ndarray

    @property
    def started(self) -> np.ndarray:
        """The runs whose initial population holds a path."""
        return self.initial > 0
