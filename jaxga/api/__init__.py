"""The Python API: many seeded runs of a preset on a map (:func:`run`), sweeps over
parameter points (:func:`sweep`), and what they return (:class:`Result`).

- :mod:`~jaxga.api.ga`: :class:`GA`, the pure core of one preset on one map;
- :mod:`~jaxga.api.problem`: a call's preset and map, loaded and checked once;
- :mod:`~jaxga.api.runs`: :func:`run`, :func:`sweep`;
- :mod:`~jaxga.api.calls`: a request's runs as calls of the compiled programs;
- :mod:`~jaxga.api.result`: :class:`Result`, per-seed paths, metrics and gaps;
- :mod:`~jaxga.api.seeds`: accepted seeds, their keys and sharding;
- :mod:`~jaxga.api.programs`: the compiled programs, cached per shape;
- :mod:`~jaxga.api.memory`: memory checks before a run;
- :mod:`~jaxga.api.failures`: runs that found no path, their causes;
- :mod:`~jaxga.api.parallel`: every core, and several processes, for one experiment;
- :mod:`~jaxga.api.compilation_cache`: JAX's persistent compilation cache;
- :mod:`~jaxga.api.lowering`: how programs are lowered (Threefry without a loop on the CPU);
- :mod:`~jaxga.api.device_probe` and :mod:`~jaxga.api.doctor`: does a backend compute what
  the CPU computes (the gate before runs off the CPU, ``jaxga doctor``).

The tools (command line, DOE, comparisons, re-planning) use what is exported here.
"""

from jaxga.api.ga import GA
from jaxga.api.memory import (
    check_result_memory,
)
from jaxga.api.problem import (
    check_one_corner_rule,
    configured_rule,
    load_problem,
)
from jaxga.api.programs import (
    ACCELERATOR_BUCKETS,
    GENERATION_CHUNK,
    RUN_BUCKETS,
    RUNS_PER_DEVICE,
    SMALL_CALL_RUNS,
    clear_compiled,
    map_runs,
    platform_layout,
    run_blocks,
    run_layout,
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
from jaxga.api.seeds import (
    SEED_LIMIT,
    seed_list,
)

__all__ = [
    "GA",
    "ACCELERATOR_BUCKETS",
    "GENERATION_CHUNK",
    "RUN_BUCKETS",
    "RUNS_PER_DEVICE",
    "SMALL_CALL_RUNS",
    "FITNESS_GAP_TOLERANCE",
    "GAPS",
    "GAP_TOLERANCE",
    "RUN_OPTIONS",
    "Result",
    "SEED_LIMIT",
    "SUMMARY_METRICS",
    "check_one_corner_rule",
    "configured_rule",
    "check_result_memory",
    "check_run",
    "checked_capacity",
    "clear_compiled",
    "json_number",
    "load_problem",
    "map_runs",
    "platform_layout",
    "relative_gap",
    "run",
    "run_blocks",
    "run_layout",
    "seed_list",
    "summarise",
    "sweep",
]
