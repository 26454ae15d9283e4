"""The canonical problems: the few whole-GA configurations the suite's tests share.

Compiling a whole GA (init, evolve and finish programs) takes 20-40 s on the CI machine,
and a configuration that differs from another in any static key (population size, map
shape, corner rule, run count, a compiled-in operator) is another compilation. Tests
that need a run of a preset therefore use these problems unless what they check needs
another one:

* :data:`MAP`, the README's built-in 20 x 20 map (``classic_ga_gapp3_20x20``, free
  corner rule), the map of the docs' examples and of the notebooks' quick mode;
* every preset at its own defaults (population, operators, capacity), so that a test
  run and an example of the docs are one program;
* at most :data:`SEEDS` seeds: one call of the 4-run program
  (``jaxga._runtime.programs.RUN_BUCKETS``);
  more seeds use the 32-run program;
* few generations: the generation count is a run-time value, any count is the same program.

Dynamic parameters (rates, weights, temperatures, ``init.max_tries``, the stagnation
limit, ...) never make another program: vary them freely.

:func:`run` is ``jaxga.run`` on these problems. The pytest-xdist workers, the notebooks'
kernels and the other processes of the suite share jaxga's program store (under the
suite's cache directory), which compiles a program once across processes
(:mod:`jaxga._runtime.executables`): a worker that needs a program another one is compiling
waits for it and reads it.
"""

from __future__ import annotations

from typing import Any

import jaxga

MAP = "classic_ga_gapp3_20x20"
SEEDS = 3
"""Seeds of a canonical run: one call of the small program (up to ``RUN_BUCKETS[0]``)."""
GENERATIONS = 3


def run(preset: str, seeds: Any = SEEDS, *, generations: int | None = GENERATIONS,
        grid: Any = MAP, **dynamic: Any) -> jaxga.Result:
    """``jaxga.run(preset, grid, seeds, generations=..., **dynamic)``; ``generations=None``:
    the preset's own count (the same program). ``dynamic`` should hold only dynamic keys
    (they share the program): a static override is another program, which is what the
    canonical problems are here to avoid."""
    return jaxga.run(preset, grid, seeds, generations=generations, **dynamic)
