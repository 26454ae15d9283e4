"""The public Python API (docs/api.md): the pure core of one preset on one map
(:class:`GA`), a problem checked once (:func:`jaxga.problem`), many seeded runs
(:func:`run`), sweeps over parameter points (:func:`sweep`), what they return
(:class:`Result`), a planner for a loaded map, the device check, and the devices and
processes of one experiment.

- :mod:`~jaxga.api.ga`: :class:`GA`, the pure core of one preset on one map;
- :mod:`~jaxga.api.problem`: a call's preset and map, loaded and checked once;
- :mod:`~jaxga.api.runs`: :func:`run`, :func:`sweep`;
- :mod:`~jaxga.api.result`: :class:`Result`, per-seed paths, metrics and gaps;
- :mod:`~jaxga.api.failures`: runs that found no path, their causes;
- :mod:`~jaxga.api.planner`: :class:`~jaxga.api.planner.Planner`, plans on a loaded map;
- :mod:`~jaxga.api.doctor`: does this backend compute what the CPU computes;
- :mod:`~jaxga.api.devices`: every core, and several processes, for one experiment;
- :mod:`~jaxga.api.warmup`: the programs of a preset compiled ahead of its runs.

The machinery behind them (compiled programs, their store, calls, memory, seeds) is the
private :mod:`jaxga._runtime`.
"""

from jaxga._runtime.programs import (
    clear_compiled,
)
from jaxga.api.ga import GA
from jaxga.api.problem import (
    Problem,
    check_one_corner_rule,
    configured_rule,
    load_problem,
)
from jaxga.api.result import (
    FITNESS_GAP_TOLERANCE,
    GAP_TOLERANCE,
    GAPS,
    SUMMARY_METRICS,
    Result,
    json_number,
    relative_gap,
    summarise,
)
from jaxga.api.runs import (
    RUN_OPTIONS,
    check_run,
    checked_capacity,
    run,
    sweep,
)

__all__ = [
    "GA",
    "FITNESS_GAP_TOLERANCE",
    "GAPS",
    "GAP_TOLERANCE",
    "Problem",
    "RUN_OPTIONS",
    "Result",
    "SUMMARY_METRICS",
    "check_one_corner_rule",
    "configured_rule",
    "check_run",
    "checked_capacity",
    "clear_compiled",
    "json_number",
    "load_problem",
    "relative_gap",
    "run",
    "summarise",
    "sweep",
]
