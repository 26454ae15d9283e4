"""Memory checks before a run: refuse, with a one-line error, results that would not fit.
"""

from __future__ import annotations

from jaxga.core.errors import ParameterError
from jaxga.core.grid import physical_memory
from jaxga.engine import (
    Algorithm,
)

RESULT_MEMORY_FRACTION = 0.5
"""A call is refused when its results alone would need more than this fraction of the
machine's physical memory (they are all held on the host at the end)."""




def check_result_memory(n_runs: int, algo: Algorithm) -> None:
    """A clear error instead of the operating system killing the process: every run keeps
    three float32 histories of ``generations`` values, two int32 paths of ``capacity``
    cells and a few hundred bytes of metrics, counters and keys, and while it evolves its
    population (``population x islands x capacity`` int32 cells, counted twice: the state
    and its next generation). An estimate, not a bound: blocks of runs need more."""
    per_run = (12 * algo.generations + 8 * algo.capacity + 256
               + 2 * 4 * algo.population * algo.islands * algo.capacity)
    check_memory(n_runs, per_run, (
        f"for their results and populations ({algo.generations} generations of history, "
        f"paths of {algo.capacity} cells and a population of "
        f"{algo.population * algo.islands} per run)"))


NO_PATH_BYTES_PER_RUN = 256
"""What a run of a no-path result keeps (its seed, NaN metrics and empty paths)."""


def check_memory(n_runs: int, per_run: int, what: str) -> None:
    """``ParameterError`` when ``n_runs`` runs of ``per_run`` bytes need more than
    :data:`RESULT_MEMORY_FRACTION` of the machine's physical memory."""
    need, total = n_runs * per_run, physical_memory()
    if total is not None and need > RESULT_MEMORY_FRACTION * total:
        raise ParameterError(
            f"{n_runs} runs would need about {need / 2**30:.1f} GiB {what}, more than half "
            f"of this machine's {total / 2**30:.1f} GiB: run fewer seeds per call")

