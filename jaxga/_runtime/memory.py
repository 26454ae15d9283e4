"""Memory checked before it is allocated: a model of what a call of runs holds
(:func:`call_memory`, measured by ``benchmarks/memory.py``), calls laid out to fit
(:func:`jaxga._runtime.calls.fitting_layout` drops the padding of its calls where the padded runs
would not fit, and computes the runs in groups of calls, one group after another, where
even those would not fit), and one line naming the size and what to change where not one
run fits."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import jax

from jaxga.core.errors import ParameterError
from jaxga.core.grid import physical_memory
from jaxga.engine import (
    Algorithm,
)

RESULT_MEMORY_FRACTION = 0.5
"""A call is refused when it would need more than this fraction of the machine's physical
memory (:func:`call_memory`)."""


STATE_FACTOR = 8
"""A run's memory while it evolves, in units of its population's cells
(``population x islands x capacity`` int32): the population, its next generation and
each operator's working arrays; above what ``benchmarks/memory.py`` measures (decision
042)."""

INIT_FACTOR = 12
"""The initialisation's temporaries of one run (its walks' buffers and attempts), in the
same units, held for the runs a call initialises together (its devices' init blocks: 10
runs per device on the CPU, a whole call on a GPU, decision 048); above what
``benchmarks/memory.py`` measures on the CPU (decision 042; not measured on a GPU)."""

BASE_BYTES = 1 << 30
"""What a process holds beside its runs: JAX, the compiled programs, the map and its
tables, and the compilation's own peak (decision 042)."""


def population_bytes(algo: Algorithm) -> int:
    """The bytes of one run's population: ``population x islands x capacity`` int32 cells."""
    return 4 * algo.population * algo.islands * algo.capacity


def state_bytes(algo: Algorithm) -> int:
    """One run's state while its call computes (:data:`STATE_FACTOR`)."""
    return STATE_FACTOR * population_bytes(algo)


def result_bytes(algo: Algorithm) -> int:
    """What a run's outputs keep once its call has finished: its history (three numbers a
    generation) and its paths."""
    return 12 * algo.generations + 8 * algo.capacity + 256


def run_bytes(algo: Algorithm) -> int:
    """One run's state and outputs while its call computes."""
    return state_bytes(algo) + result_bytes(algo)


def call_memory(algo: Algorithm, runs: int, per_call: int, init_block: int = 10,
                total: int | None = None) -> int:
    """The peak memory of ``runs`` runs held together in calls of ``per_call`` (padding
    included: a padded run costs as much as a real one), ``init_block`` of each call's runs
    initialised at once (every device's block together), among ``total`` runs (default
    ``runs``) whose outputs are kept:
    :data:`BASE_BYTES`, the state of every run held (the states of a group of calls live
    until its finish), every run's outputs, and one init block's temporaries."""
    total = runs if total is None else max(total, runs)
    return (BASE_BYTES + runs * state_bytes(algo) + total * result_bytes(algo)
            + INIT_FACTOR * min(per_call, init_block) * population_bytes(algo))


DEVICE_MEMORY_FRACTION = 0.8
"""Off the CPU, a call may also use at most this fraction of each device's own memory (the
``bytes_limit`` of its allocator, ``Device.memory_stats()``), whichever bound is lower:
a GPU may have less memory than its host. A margin for the allocator's fragmentation; the
model (:data:`STATE_FACTOR`) is not measured on a GPU (decision 049)."""


def device_memory() -> tuple[int, int, str] | None:
    """``(bytes of one device, devices, kind)`` of the default backend's local devices,
    where the runs compute, when that is not the CPU (whose runs use the host's memory)
    and the device says; else None."""
    if jax.default_backend() == "cpu":
        return None
    try:
        device = jax.local_devices()[0]
        limit = (device.memory_stats() or {}).get("bytes_limit")
    except Exception:  # noqa: BLE001 - a backend without memory statistics
        return None
    if not isinstance(limit, int) or limit <= 0:
        return None
    return limit, jax.local_device_count(), device.device_kind


def budget(per_device: bool = False) -> tuple[int, str] | None:
    """``(bytes, words)``: the memory a call may use and how to name it in a refusal:
    :data:`RESULT_MEMORY_FRACTION` of the memory this process may use, or, lower,
    :data:`DEVICE_MEMORY_FRACTION` of the devices' own memory: all local devices' for a
    whole call (:func:`call_memory`), one device's with ``per_device`` (XLA's account of
    a program sharded over them is one device's share); None where neither is known."""
    bounds = []
    total = physical_memory()
    if total is not None:
        bounds.append((int(RESULT_MEMORY_FRACTION * total),
                       f"more than half of the {total / 2**30:.2f} GiB this process may use"))
    device = device_memory()
    if device is not None:
        one, count, kind = device
        n = 1 if per_device else count
        where = "a device's" if n == 1 else f"{count} devices'"
        bounds.append((int(DEVICE_MEMORY_FRACTION * one * n),
                       f"more than {DEVICE_MEMORY_FRACTION:.0%} of the {one * n / 2**30:.2f} "
                       f"GiB of {where} own memory ({kind})"))
    return min(bounds) if bounds else None


def memory_budget() -> int | None:
    """The memory a call may use (:func:`budget`; None where it is unknown)."""
    known = budget()
    return None if known is None else known[0]


def runs_that_fit(algo: Algorithm, budget: int, init_block: int = 10,
                  total: int | None = None) -> int:
    """The most runs one call of them fits in ``budget`` bytes (:func:`call_memory`),
    beside the outputs of ``total`` runs (default: the call's own only)."""
    run, init = state_bytes(algo), INIT_FACTOR * population_bytes(algo)
    room = budget - BASE_BYTES
    if total is None:
        run += result_bytes(algo)
    else:
        room -= total * result_bytes(algo)
    few = room // (run + init)  # up to one init block: each run brings its temporaries
    if few < init_block:
        return max(int(few), 0)
    return max(int((room - init_block * init) // run), init_block)


def most_runs(algo: Algorithm, budget: int, init_block: int = 10) -> int:
    """The most runs whose outputs fit in ``budget`` bytes beside one run computed at a
    time (:func:`call_memory`)."""
    one = call_memory(algo, 1, 1, init_block) - result_bytes(algo)
    return max(int((budget - one) // result_bytes(algo)), 0)


def too_much_memory(algo: Algorithm, runs: int, per_call: int, init_block: int = 10,
                    total: int | None = None) -> str:
    """One line saying why ``runs`` runs held together in calls of ``per_call``, among
    ``total`` runs (default ``runs``), do not fit the machine and what to change, or
    ``""`` when they fit (:func:`call_memory`)."""
    known = budget()
    total = runs if total is None else max(total, runs)
    need = call_memory(algo, runs, per_call, init_block, total)
    if known is None or need <= known[0]:
        return ""
    room, words = known
    if runs_that_fit(algo, room, init_block) < 1:
        hint = "not one run fits: a smaller population.size (or population.capacity)"
    elif total > (most := most_runs(algo, room, init_block)):
        hint = f"at most {most} fit: run fewer seeds (or sweep points) at a time"
    else:
        hint = f"at most {runs_that_fit(algo, room, init_block, total)} at a time fit"
    held = "" if runs == total else f", {runs} at a time,"
    return (f"{total} run{'s' * (total != 1)} of a population of "
            f"{algo.population * algo.islands} on paths of {algo.capacity} cells{held} "
            f"would need about {need / 2**30:.2f} GiB, {words}: {hint}")


def check_result_memory(n_runs: int, algo: Algorithm) -> None:
    """A clear error instead of the operating system killing the process, before
    anything compiles: ``n_runs`` runs computed one at a time, every run's outputs kept
    (:func:`call_memory`; the layout of the calls, checked again once known, computes as
    many at a time as fit: :func:`jaxga._runtime.calls.fitting_layout`)."""
    why = too_much_memory(algo, 1, 1, total=n_runs)
    if why:
        raise ParameterError(why)


def compiled_peak(stats: Any, calls: int) -> int | None:
    """The memory a compiled program's ``calls`` calls hold at their peak, from XLA's own
    account of it (``Compiled.memory_analysis()``): every call's output is kept (the
    states of all calls live until the finish) and one call's temporaries at a time;
    None where XLA gives no account."""
    try:
        out = int(stats.output_size_in_bytes)
        temp = int(stats.temp_size_in_bytes)
        args = int(stats.argument_size_in_bytes)
    except (AttributeError, TypeError, ValueError):
        return None
    return BASE_BYTES + calls * (out + args) + temp


def check_compiled_memory(stats: Mapping[str, Any], calls: int, runs: int) -> None:
    """Refuse, before they run, compiled programs whose calls would not fit (their
    :func:`compiled_peak` over half the memory the process may use): the accurate check,
    once the programs of a call are known, of what :func:`call_memory` estimated before.
    ``stats``: XLA's account of each program by name
    (:meth:`jaxga._runtime.programs.Programs.memory_stats`; None: not checked)."""
    known = budget(per_device=True)
    if known is None:
        return
    room, words = known
    for name, account in stats.items():
        need = None if account is None else compiled_peak(account, calls)
        if need is not None and need > room:
            raise ParameterError(
                f"{runs} runs in {calls} call(s) would need about {need / 2**30:.1f} GiB "
                f"in their {name} program (XLA's account of its buffers), {words}: run "
                "fewer seeds (or sweep points) at a time, or a smaller population.size")


NO_PATH_BYTES_PER_RUN = 256
"""What a run of a no-path result keeps (its seed, NaN metrics and empty paths)."""


def check_memory(n_runs: int, per_run: int, what: str) -> None:
    """``ParameterError`` when ``n_runs`` runs of ``per_run`` bytes need more than
    :data:`RESULT_MEMORY_FRACTION` of the machine's physical memory."""
    need, total = n_runs * per_run, physical_memory()
    if total is not None and need > RESULT_MEMORY_FRACTION * total:
        raise ParameterError(
            f"{n_runs} runs would need about {need / 2**30:.1f} GiB {what}, more than half "
            f"of the {total / 2**30:.1f} GiB this process may use: run fewer seeds at a "
            "time")

