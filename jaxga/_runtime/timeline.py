"""Seconds per phase of a run, in the order a user waits for them.

Every phase a user waits for is timed and shown: :class:`Timeline` collects them
(``with timeline.phase("compile"): ...``), :meth:`Timeline.as_dict` gives the ``timing``
of a :class:`~jaxga.api.result.Result` and of the JSON files (``<phase>_s`` keys and
``total_s``), and :func:`time_line` the summary line ``time (s): load 0.21, ...``.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterator, Mapping

__all__ = ["PHASES", "Timeline", "process_age", "time_line"]

PHASES: dict[str, str] = {
    "import": "starting Python and importing jaxga and JAX",
    "load": "reading the map, inflating and coarsening it",
    "references": "the exact 8-connected optimum and the distance fields (path capacity)",
    "device_probe": "checking, once per device kind, that the device computes as the CPU",
    "compile": "compiling the programs, or reading them from the store",
    "init": "the initial populations",
    "evolve": "the generations",
    "post": "post-optimising the best paths and measuring them",
    "any_angle": "the any-angle optimum and its lower bound, within their budget",
    "smooth": "smoothing the paths into curves",
    "plot": "drawing the plot",
    "write": "writing the output files",
}
"""Every phase, in the order they happen, with what it is."""


class Timeline:
    """Seconds per phase; a phase timed twice adds up. ``clock`` is injectable for tests."""

    def __init__(self, clock: Callable[[], float] = time.perf_counter,
                 start: float | None = None) -> None:
        self.clock = clock
        self.start = clock() if start is None else start
        self.seconds: dict[str, float] = {}

    def add(self, name: str, seconds: float) -> None:
        """Add ``seconds`` to phase ``name``."""
        self.seconds[name] = self.seconds.get(name, 0.0) + float(seconds)

    @contextlib.contextmanager
    def phase(self, name: str) -> Iterator[None]:
        """Time the ``with`` block as phase ``name`` (also when it raises)."""
        t0 = self.clock()
        try:
            yield
        finally:
            self.add(name, self.clock() - t0)

    def elapsed(self) -> float:
        """Seconds since the timeline started."""
        return self.clock() - self.start

    def as_dict(self, total: float | None = None) -> dict[str, float]:
        """``{"<phase>_s": seconds, ..., "total_s": total}`` in :data:`PHASES` order (any
        other phase after them); ``total`` defaults to :meth:`elapsed`."""
        names = [p for p in PHASES if p in self.seconds]
        names += [p for p in self.seconds if p not in PHASES]
        out = {f"{p}_s": self.seconds[p] for p in names}
        out["total_s"] = self.elapsed() if total is None else float(total)
        return out


def time_line(timing: Mapping[str, float]) -> str:
    """``time (s): load 0.21, references 0.40, ..., total 2.95`` from a ``timing`` dict;
    the rest of the total (outside every named phase) is shown as ``other``."""
    parts, named = [], 0.0
    for key, value in timing.items():
        if key == "total_s" or not key.endswith("_s"):
            continue
        named += value
        digits = 3 if value < 1 else 2
        parts.append(f"{key[:-2].replace('_', '-')} {value:.{digits}f}")
    total = float(timing.get("total_s", named))
    other = total - named
    if other >= 0.005:
        parts.append(f"other {other:.3f}")
    parts.append(f"total {total:.2f}")
    return "time (s): " + ", ".join(parts)


def process_age() -> float | None:
    """Seconds since this process started (Linux ``/proc``: the interpreter's start and
    every import included), None where the system does not say."""
    try:
        with open("/proc/self/stat", encoding="ascii") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime", encoding="ascii") as f:
            uptime = float(f.read().split()[0])
        return max(uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError):
        return None
