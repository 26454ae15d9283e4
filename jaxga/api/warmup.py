"""``jaxga warmup``: compile a day's programs ahead, into the persistent cache.

A program set (:mod:`jaxga._runtime.programs`) depends on the preset, the map's shape and
corner rule, the path capacity and the runs per call (4, or 32 per device); not on
the seeds, the number of generations or the dynamic parameter values. :func:`warmup`
compiles, for each preset and map, the set of every run size (one generation of each),
so that a later process finds them in the persistent compilation cache
(:mod:`jaxga._runtime.compilation_cache`) and only traces and loads. A map given as a size
``N`` is an open ``N x N`` map from corner to corner (a user's map: corner rule strict);
a map of that size with obstacles holds the same programs when its path capacity is the
same (it is on maps whose optimal path is short enough, :func:`jaxga.engine.default_capacity`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from typing import Any

import jax
import numpy as np

from jaxga._runtime.compilation_cache import ENV_VAR, store_directory
from jaxga._runtime.programs import SMALL_CALL_RUNS, platform_layout
from jaxga.api.runs import run
from jaxga.config.presets import preset_names
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid
from jaxga.maps import MapInfo

__all__ = ["open_map", "warmup"]


def open_map(size: int, corner_rule: str = "strict") -> Grid:
    """An open ``size x size`` map from its bottom-left to its top-right corner."""
    if not isinstance(size, int | np.integer) or isinstance(size, bool) or size < 2:
        raise ParameterError(f"a warm-up map size must be an integer >= 2, got {size!r}")
    return Grid.create(np.zeros((size, size), bool), corner_rule=corner_rule)


def warmup(
    presets: Sequence[str] | None = None,
    maps: Sequence[int | str | Grid | MapInfo] = (20, 32, 64),
    *,
    seeds: Sequence[int] | None = None,
    corner_rule: str | None = None,
    size_class: bool | None = None,
    report: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Compile every program set ``presets`` x ``maps`` x ``runs`` needs (one generation
    of each), into the program store (:func:`jaxga._runtime.compilation_cache.store_directory`).

    Args:
        presets: preset names or TOML files (default: every built-in preset).
        maps: map sizes (an open ``N x N`` map, :func:`open_map`), built-in map names,
            map files, Grids or MapInfos.
        seeds: seed counts to compile for (default: 4, and the platform's program sizes
            per device: 32 on the CPU, powers of two from 32 to 2048 on a GPU; together
            they serve every seed count on maps up to 64 x 64,
            :func:`jaxga._runtime.programs.run_layout`), compiled smallest first.
        corner_rule: the corner rule of every map (default: sizes strict, named maps
            their own, :func:`jaxga.maps.default_corner_rule`).
        size_class: compile the programs of runs with ``size_class=True``
            (:mod:`jaxga._runtime.size_classes`): the maps' size classes, so that sizes 32 and
            64 serve every map up to 64 x 64 whose problem fits its class's path
            capacity; None (the default) as :func:`jaxga.run`'s default: the classes of
            maps with a side over 64 (sizes 128, 256, 384 and 512 serve every user map).
        report: called with each row as it is done.

    The programs are stored whole (:mod:`jaxga._runtime.executables`) when XLA compiles them;
    one that JAX reads from its own cache is not (it would not serialise whole), so a
    warm-up stores every program only in a process that has not used JAX's cache, as
    ``jaxga warmup`` (which turns JAX's cache off before compiling anything).

    Returns:
        One row per preset, map and seed count: ``preset``, ``map``, ``seeds``,
        ``compile_s`` (tracing, and compiling or loading from the cache) and
        ``total_s``.
    """
    if store_directory() is None:
        why = ("$JAXGA_CACHE_DIR is empty" if os.environ.get(ENV_VAR) == ""
               else "no folder is configured, or it cannot be used")
        raise ParameterError(f"the persistent compilation cache is off ({why}): a warm-up "
                             "would compile for this process only")
    presets = list(preset_names()) if presets is None else list(presets)
    n_dev = jax.local_device_count()
    sizes = (SMALL_CALL_RUNS, *(b * n_dev for b in platform_layout().buckets))
    counts = sorted({int(n) for n in (seeds or sizes)})
    if not counts or counts[0] < 1:
        raise ParameterError(f"seed counts must be >= 1, got {list(seeds or ())}")
    rows = []
    for preset in presets:
        for m in maps:
            if isinstance(m, int | np.integer) and not isinstance(m, bool):
                grid, name = open_map(int(m), corner_rule or "strict"), f"open {m} x {m}"
            else:
                grid, name = m, getattr(m, "name", m if isinstance(m, str) else "grid")
            for count in counts:  # smallest first: a larger one would be reused
                t0 = time.perf_counter()
                r = run(preset, grid, seeds=count, generations=1,
                        corner_rule=None if isinstance(m, int | np.integer) else corner_rule,
                        size_class=size_class)
                row = {"preset": preset, "map": str(name), "seeds": count,
                       "compile_s": r.timing["compile_s"],
                       "total_s": time.perf_counter() - t0}
                rows.append(row)
                if report is not None:
                    report(row)
    return rows
