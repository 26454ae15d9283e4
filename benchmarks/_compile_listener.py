"""pytest plugin for ``benchmarks/suite_time.py``: JAX's compile durations per test.

Loaded with ``pytest -p _compile_listener`` (``benchmarks/`` on ``PYTHONPATH``). It
listens to ``jax.monitoring``'s duration events (tracing, lowering to MLIR, XLA's
backend compile, persistent-cache hits) and records, for every test of this process, the
seconds and the number of each event between the test's start and its end (setup, call
and teardown; counts under ``"n:<event>"``), with the test's own wall time and CPU time
(``"cpu"``: this process's user + system seconds over all its threads, plus those of the
child processes the test started and waited for), and the compilations that took XLA
more than ``suite_time.LARGE_PROGRAM_S`` (``"large programs"``). Wall time grows when
other work shares the cores; CPU time hardly does, so it is what a file costs. Each pytest
process that runs tests (every xdist worker; not the xdist controller) writes
``<$JAXGA_SUITE_PROFILE>/<worker>.json``. Work done in child processes that a test
starts (notebook kernels, ``jax.distributed`` processes) is not seen: only its wall time,
and its CPU time once the test has waited for it.
"""

from __future__ import annotations

import collections
import json
import os
import resource
import time
from pathlib import Path

import jax.monitoring
from suite_time import BACKEND, LARGE, LARGE_PROGRAM_S

_totals: collections.defaultdict[str, float] = collections.defaultdict(float)
_counts: collections.defaultdict[str, int] = collections.defaultdict(int)
_rows: list[tuple[str, dict[str, float]]] = []
_start: dict[str, float] = {}


def _cpu_seconds() -> float:
    """User + system seconds of this process (every thread) and of its waited-for children."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _listen(event: str, duration: float, **_kwargs) -> None:
    _totals[event] += duration
    _counts[event] += 1
    if event == BACKEND and duration > LARGE_PROGRAM_S:
        _totals[LARGE] += duration
        _counts[LARGE] += 1


jax.monitoring.register_event_duration_secs_listener(_listen)


def pytest_runtest_logstart(nodeid: str, location) -> None:
    _start.clear()
    _start.update(_totals)
    _start.update({"n:" + k: v for k, v in _counts.items()})
    _start["wall"] = time.perf_counter()
    _start["cpu"] = _cpu_seconds()


def pytest_runtest_logfinish(nodeid: str, location) -> None:
    now = {**_totals, **{"n:" + k: v for k, v in _counts.items()}}
    row = {k: v - _start.get(k, 0) for k, v in now.items() if v > _start.get(k, 0)}
    row["wall"] = time.perf_counter() - _start.get("wall", time.perf_counter())
    row["cpu"] = _cpu_seconds() - _start.get("cpu", _cpu_seconds())
    _rows.append((nodeid, row))


def pytest_sessionfinish(session) -> None:
    if session.config.pluginmanager.has_plugin("dsession"):
        return  # the xdist controller: it sees its workers' tests, not their compilations
    out = Path(os.environ.get("JAXGA_SUITE_PROFILE", "."))
    out.mkdir(parents=True, exist_ok=True)
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    (out / f"{worker}.json").write_text(json.dumps(
        {"rows": _rows, "counts": dict(_counts), "totals": dict(_totals)}))
