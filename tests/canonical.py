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
* at most :data:`SEEDS` seeds: one call of the 4-run program (``jaxga.api.RUN_BUCKETS``);
  more seeds use the 32-run program;
* few generations: the generation count is a run-time value, any count is the same program.

Dynamic parameters (rates, weights, temperatures, ``init.max_tries``, the stagnation
limit, ...) never make another program: vary them freely.

:func:`run` is ``jaxga.run`` on these problems. Its first call for a program set takes
a lock shared by the pytest-xdist workers, so that one worker compiles and stores it
(jaxga's program store under the suite's cache directory) while another that needs the
same one waits and then reads it, instead of compiling it a second time (pytest-xdist's
recipe for session data shared by workers).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jaxga
from jaxga.api import RUN_BUCKETS

MAP = "classic_ga_gapp3_20x20"
SEEDS = 3
"""Seeds of a canonical run: one call of the small program (up to ``RUN_BUCKETS[0]``)."""
GENERATIONS = 3

_READY: set[tuple] = set()
"""Program sets this process has compiled or read (no lock needed again)."""


@contextlib.contextmanager
def shared_lock(name: str) -> Iterator[None]:
    """An exclusive lock on ``name`` shared by every process of this test session (a file
    in the suite's compilation cache directory); no lock where ``fcntl`` is missing."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: compile twice at worst
        yield
        return
    folder = Path(os.environ.get("JAXGA_CACHE_DIR") or ".") / "locks"
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / f"{name}.lock", "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def bucket(seeds: Any) -> int:
    """The runs per call of the program ``seeds`` runs with (4 or 32 on one CPU device)."""
    n = seeds if isinstance(seeds, int) else len(seeds)
    return RUN_BUCKETS[0] if n <= RUN_BUCKETS[0] else RUN_BUCKETS[-1]


def run(preset: str, seeds: Any = SEEDS, *, generations: int | None = GENERATIONS,
        grid: Any = MAP, **dynamic: Any) -> jaxga.Result:
    """``jaxga.run(preset, grid, seeds, generations=..., **dynamic)``; the first call of a
    program set in this session under the lock shared by the workers (module docstring).
    ``generations=None``: the preset's own count (the same program).

    ``dynamic`` should hold only dynamic keys (they share the program): a static override
    is another program, which is what the canonical problems are here to avoid;
    ``variant`` and ``corner_rule`` are part of the lock's name."""
    key = (preset, str(grid), bucket(seeds), dynamic.get("variant"),
           dynamic.get("corner_rule"))
    if key in _READY:
        return jaxga.run(preset, grid, seeds, generations=generations, **dynamic)
    with shared_lock("-".join(map(str, key)).replace("/", "_")):
        result = jaxga.run(preset, grid, seeds, generations=generations, **dynamic)
    _READY.add(key)
    return result
