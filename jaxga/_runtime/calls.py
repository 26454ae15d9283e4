"""A request's runs laid out as calls of the compiled programs, and the generations run
as calls of the evolve chunk.

Run ``q * S + s`` is point ``q`` with seed ``s``; each process computes its contiguous
share (:mod:`jaxga._runtime.parallel`) as calls of a few sizes
(:func:`jaxga._runtime.programs.run_layout`) that fit the machine's memory
(:func:`fitting_layout`: padded calls held together, one unpadded call, or calls of as many
runs as fit, one group after another; :mod:`jaxga._runtime.memory`). A run's result depends
only on its own key and parameters, so no layout changes any result.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._runtime import parallel
from jaxga._runtime.memory import memory_budget, runs_that_fit, too_much_memory
from jaxga._runtime.programs import (
    GENERATION_CHUNK,
    compiled_buckets,
    platform_layout,
    run_layout,
    stack_params,
)
from jaxga._runtime.seeds import seed_sharding
from jaxga.core import prng
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.engine import Algorithm

__all__ = ["RunCalls", "evolve_in_chunks", "fitting_layout", "grouped_layout",
           "this_process_runs", "unpadded_layout"]


@dataclasses.dataclass(frozen=True)
class RunCalls:
    """This process's runs as calls of the compiled programs: ``calls`` = ``(keys,
    params)`` of ``per_call`` runs each (on the devices), the last run repeated to fill
    them; the first ``n_local`` runs are this process's share. ``at_once``: the calls
    whose states are held together (a group: initialised, evolved and finished before the
    next group starts); 0: all of them."""

    calls: list[tuple[jax.Array, dict]]
    per_call: int
    n_local: int
    grid: Grid
    at_once: int = 0

    def joined(self, parts: Sequence[Any]) -> np.ndarray:
        """The calls' outputs (runs first) joined, the padding dropped."""
        return np.concatenate([np.asarray(p) for p in parts])[:self.n_local]

    def groups(self) -> list[RunCalls]:
        """The groups of calls computed one after another, each with its own real runs
        (the padding is in the last call)."""
        at_once = self.at_once or len(self.calls)
        return [dataclasses.replace(
            self, calls=self.calls[c:c + at_once], at_once=0,
            n_local=min(self.n_local - c * self.per_call, at_once * self.per_call))
            for c in range(0, len(self.calls), at_once)]


def this_process_runs(seed_arr: np.ndarray, per_point: Sequence[dict], grid: Grid,
                       algo: Algorithm, padded: bool = True) -> RunCalls:
    """This process's runs, laid out as calls of the compiled programs, on its devices.

    Run ``q * S + s`` is point ``q`` with seed ``s``; the runs are padded (copies of the
    last run) to a multiple of processes x local devices; this process computes its
    contiguous share (:func:`jaxga._runtime.parallel.allgather_runs` joins the shares), as
    calls of a few sizes (:func:`jaxga._runtime.programs.run_layout`), the last run copied to
    fill them, held together or in groups as the memory allows (:func:`fitting_layout`;
    ``padded=False``: without the padding of :func:`run_layout`). A run's result depends
    only on its own key and parameters, so neither padding nor grouping changes any
    result."""
    n_seeds, n_points = len(seed_arr), len(per_point)
    n_runs = n_seeds * n_points
    n_total, share = parallel.run_share(n_runs)
    pad = n_total - n_runs
    run_seeds = np.concatenate([np.tile(seed_arr, n_points),
                                np.repeat(seed_arr[-1:], pad)])[share]
    params = stack_params(per_point, n_seeds)
    params = {k: np.concatenate([v, np.repeat(v[-1:], pad, axis=0)])[share]
              for k, v in params.items()}
    n_local = len(run_seeds)
    n_dev = jax.local_device_count()
    per_device, n_calls, at_once = fitting_layout(
        algo, n_local, n_dev, run_layout(n_local, n_dev, grid.height * grid.width,
                                         compiled_buckets(algo, grid, params)), padded)
    per_call = per_device * n_dev
    fill = n_calls * per_call - n_local
    run_seeds = np.concatenate([run_seeds, np.repeat(run_seeds[-1:], fill)])
    params = {k: np.concatenate([v, np.repeat(v[-1:], fill, axis=0)])
              for k, v in params.items()}
    keys = prng.seed_keys(jnp.asarray(run_seeds, jnp.uint32))
    sh, rep = seed_sharding()
    if sh is not None:
        grid = jax.device_put(grid, rep)
    calls = []
    for c in range(n_calls):
        sl = slice(c * per_call, (c + 1) * per_call)
        call = (keys[sl], {k: v[sl] for k, v in params.items()})
        calls.append(jax.device_put(call, sh) if sh is not None else jax.device_put(call))
    return RunCalls(calls, per_call, n_local, grid, at_once)


def fitting_layout(algo: Algorithm, n_local: int, n_dev: int, layout: tuple[int, int],
                   padded: bool = True) -> tuple[int, int, int]:
    """``(runs per device, calls, calls held at once)`` for this process's ``n_local``
    runs on ``n_dev`` devices that fits the machine's memory
    (:func:`jaxga._runtime.memory.too_much_memory`): the padded ``layout`` (runs per device,
    calls), all its calls held together, where it fits; else one call of exactly these
    runs (a program of that size is compiled); else calls of as many runs as fit, one
    call at a time (:func:`grouped_layout`). ``padded=False`` skips the padded layout."""
    block = platform_layout().init_run_block * n_dev  # every device initialises at once
    per_device, n_calls = layout
    if padded and not too_much_memory(algo, per_device * n_dev * n_calls,
                                      per_device * n_dev, block, n_local):
        return per_device, n_calls, n_calls
    exact = unpadded_layout(n_local, n_dev)
    if not too_much_memory(algo, exact[0] * n_dev, exact[0] * n_dev, block, n_local):
        return *exact, 1
    return grouped_layout(algo, n_local, n_dev)


def grouped_layout(algo: Algorithm, n_local: int, n_dev: int) -> tuple[int, int, int]:
    """``n_local`` runs as calls that each fit the machine's memory beside every run's
    outputs, computed one call after another (init, evolution and finish of a call before
    the next starts; a run's result depends only on its key and parameters, so the
    results are those of one call): ``(runs per device, calls, 1)``, the calls as even as
    the devices allow. :class:`ParameterError` naming the size and what to change where
    not one call of a run per device fits."""
    block = platform_layout().init_run_block * n_dev  # every device initialises at once
    budget = memory_budget()
    if budget is None:
        return *unpadded_layout(n_local, n_dev), 1
    fit = runs_that_fit(algo, budget, block, n_local)
    most = min(fit // n_dev, -(-n_local // n_dev))
    if most < 1:
        raise ParameterError(too_much_memory(algo, n_dev, n_dev, block, n_local))
    per_device = -(-n_local // (n_dev * -(-n_local // (most * n_dev))))
    return per_device, -(-n_local // (per_device * n_dev)), 1


def unpadded_layout(n_local: int, n_dev: int) -> tuple[int, int]:
    """One call of exactly ``n_local`` runs over ``n_dev`` devices (runs per device,
    calls): the padding only to a multiple of the devices."""
    return -(-n_local // n_dev), 1


def evolve_in_chunks(progs: Any, generations: int, runs: RunCalls, grid: Grid,
                      states: list, report: Callable[[float], None]) -> tuple[list, dict]:
    """``generations`` generations as calls of the compiled evolve chunk
    (:data:`GENERATION_CHUNK` generations, the last call running the ones left), every
    call of runs in each chunk, reporting the fraction done after each chunk; the
    per-generation history joined (NumPy, this process's runs)."""
    sh, rep = seed_sharding()
    hists: list[list[dict]] = [[] for _ in states]
    done = 0
    while done < generations:
        count = min(GENERATION_CHUNK, generations - done)
        n = jnp.asarray(count, jnp.int32)
        if rep is not None:
            n = jax.device_put(n, rep)
        for i, ((k, p), st) in enumerate(zip(runs.calls, states)):
            states[i], h = progs.evolve(k, grid, p, st, n)
            hists[i].append((count, h))
        jax.block_until_ready(states)
        done += count
        if done < generations and _all_frozen(states):
            # every run stopped (the stagnation rule): the generations left change
            # nothing, and each would record the run's last row again
            for call in hists:
                c, h = call[-1]
                call.append((generations - done, {
                    key: np.repeat(np.asarray(v)[:, c - 1:c], generations - done, axis=1)
                    for key, v in h.items()}))
            done = generations
        report(done / generations)
    history = {key: runs.joined([np.concatenate([np.asarray(h[key])[:, :c] for c, h in call],
                                                axis=1) for call in hists])
               for key in hists[0][0][1]}
    return states, history


def _all_frozen(states: list) -> bool:
    """Whether every run of this process's calls is frozen by the stagnation rule (read
    between two compiled calls; with several processes never, so that every process
    makes the same calls)."""
    return jax.process_count() == 1 and all(bool(np.asarray(st.frozen).all()) for st in states)
