"""What a DOE returns: :class:`DoeResult`, its table, its JSON and its timing line.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from jaxga.config.schema import Config
from jaxga.core.equality import MutableValueEquality
from jaxga.doe.checkpoint import json_float
from jaxga.doe.design import Factor, design_points
from jaxga.doe.fit import main_effects, point_means


@dataclasses.dataclass(eq=False)
class DoeResult(MutableValueEquality):
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
    start: tuple[int, int] | None = None
    """The start cell ``(x, y)`` every point ran from (y from the bottom)."""
    goal: tuple[int, int] | None = None
    """The goal cell ``(x, y)``."""
    map_digest: str = ""
    """The map's :meth:`jaxga.Grid.cells_digest` ("" where not known)."""
    path_capacity: int = 0
    """The cells a path can hold in every point's program."""
    size_class: bool = False
    """Whether every point ran on the map padded to its size class (automatic: a side
    over 64 cells); ``jaxga.run(..., size_class=...)`` with it repeats a point's runs."""
    environment: dict[str, Any] = dataclasses.field(default_factory=dict)
    """What computed the runs (:func:`jaxga._runtime.device_probe.run_environment`)."""

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
            "map": self.map_name, "map_digest": self.map_digest,
            "environment": dict(getattr(self, "environment", {})),  # {}: older pickles
            "corner_rule": self.corner_rule,
            "start": None if self.start is None else list(self.start),
            "goal": None if self.goal is None else list(self.goal),
            "response": self.response,
            "direction": self.direction,
            "design": self.design,
            "seeds": [int(s) for s in self.seeds],
            "factors": {f.name: list(f.levels) for f in self.factors},
            "points": [
                {"coded": {n: int(c) for n, c in zip(names, row)},
                 "values": vals,
                 "responses": [json_float(v) for v in resp],
                 "mean": json_float(m),
                 "n_success": int(ns)}
                for row, vals, resp, m, ns in zip(self.coded, self.values, self.responses,
                                                   self.means, self.n_success)
            ],
            "coefficients": {"X0": float(self.coefficients[0]),
                             **{n: float(c) for n, c in zip(names, self.coefficients[1:])}},
            "main_effects": {n: [json_float(v) for v in row]
                             for n, row in zip(names, self.main_effects)},
            "predicted_best": {"coded": {n: int(c) for n, c in zip(names, self.best_coded)},
                               "values": best_values, "predicted": float(self.predicted)},
            "confirmation": {"responses": [json_float(v) for v in self.confirmation],
                             "mean": json_float(self.confirmation_mean),
                             "n_success": int(self.confirmation_all["success"].sum())},
            "timing": {k: float(v) for k, v in self.timing.items()},
            "generations": None if self.config is None else int(self.config["generations"]),
            "population_capacity": self.population_capacity,
            "path_capacity": self.path_capacity, "size_class": self.size_class,
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
