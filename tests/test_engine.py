"""The engine end to end on a tiny map: every reported path feasible, same seed same run."""

from __future__ import annotations

import numpy as np
import pytest

from jaxga.api import run
from jaxga.maps import random_map
from jaxga.reference import any_angle_shortest_path, clear_np


@pytest.fixture(scope="module")
def tiny_runs():
    grid = random_map(10, 10, 0.2, 3, corner_rule="free")
    # test_api's SMALL settings and run count: one compiled program for both modules
    overrides = dict(population__size=8, generations=3, init__max_tries=40)
    a = run("sga", grid, seeds=[0, 1, 2], **overrides)
    b = run("sga", grid, seeds=[9, 2, 5], **overrides)
    return grid, a, b


def test_reported_paths_are_feasible_and_never_below_the_optimum(tiny_runs):
    grid, a, _ = tiny_runs
    blocked = grid.blocked_np()
    bound = any_angle_shortest_path(grid).length
    assert a.success.any()
    for i in np.flatnonzero(a.success):
        path = a.path(i)
        assert path[0] == grid.start_xy and path[-1] == grid.goal_xy
        assert all(clear_np(blocked, grid.corner_rule, p, q) for p, q in zip(path, path[1:]))
        assert a.length[i] >= bound - 1e-5
        raw = a.path(i, raw=True)
        assert all(max(abs(p[0] - q[0]), abs(p[1] - q[1])) == 1 for p, q in zip(raw, raw[1:]))
    assert a.history["best"].shape == (3, 3)
    assert np.all(np.diff(a.history["best"], axis=1) >= 0)  # best-so-far never drops


def test_a_seed_gives_the_same_run_whichever_runs_share_its_batch(tiny_runs):
    """Seed 2 third in a batch with seeds 0 and 1, and second between seeds 9 and 5: the
    same run (a run alone against blocks of one: the device-count test below)."""
    _, a, b = tiny_runs
    assert a.success[2] == b.success[1]
    assert np.array_equal(a.cells[2], b.cells[1])
    for h in ("best", "mean", "std"):
        assert np.array_equal(a.history[h][2], b.history[h][1])


_DEVICE_SCRIPT = """
import json, jax
from jaxga import api
from jaxga.maps import random_map
if jax.device_count() > 1:  # and each device computes its runs one block at a time
    api.RUN_BLOCK = 1
g = random_map(10, 10, 0.2, 3, corner_rule="free")
r = api.run("sga", g, seeds=21, population__size=8, generations=3, init__max_tries=50)
print(json.dumps({"devices": jax.device_count(), "blocks": api.run_blocks(24, jax.device_count()),
                  "cells": r.cells.tolist(), "raw": r.raw_cells.tolist(),
                  "fitness": r.fitness.tolist(), "length": r.length.tolist(),
                  **{h: r.history[h].tolist() for h in ("best", "mean", "std")}}))
"""


def test_results_do_not_depend_on_the_device_count():
    """Seeds sharded over 4 forced host devices (21 seeds padded to 24), each device
    computing its runs one at a time (``api.map_runs``), == one device, one ``vmap`` of
    21: the same paths and the same float bits for every reported value (sums in a
    fixed order, ``jaxga.numerics``)."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = str(Path(__file__).resolve().parents[1])
    out = []
    for n in (1, 4):
        env = dict(os.environ, PYTHONPATH=root,
                   XLA_FLAGS=f"--xla_force_host_platform_device_count={n}")
        proc = subprocess.run([sys.executable, "-c", _DEVICE_SCRIPT], env=env, cwd=root,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        out.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    assert [o["devices"] for o in out] == [1, 4]
    assert [o["blocks"] for o in out] == [1, 6]
    for field in ("cells", "raw", "fitness", "length", "best", "mean", "std"):
        np.testing.assert_array_equal(out[0][field], out[1][field], err_msg=field)  # NaN == NaN


def test_population_waypoint_feasibility_equals_the_per_path_check():
    """The engine's two-tier check (bounded test for short segments, full test gathered
    for long ones) gives exactly ``paths.is_feasible`` on random waypoint paths."""
    import jax
    import jax.numpy as jnp

    from jaxga.engine import waypoints_feasible
    from jaxga.paths import is_feasible

    grid = random_map(12, 12, 0.25, 5, corner_rule="strict")
    rng = np.random.default_rng(0)
    p, cap = 64, 12
    free = np.flatnonzero(~grid.blocked_np().reshape(-1))
    cells = rng.choice(free, (p, cap)).astype(np.int32)
    # short hops for half of the segments so that both tiers are exercised
    hop = rng.integers(-2, 3, (p, cap, 2))
    xs = np.clip(cells % 12 + hop[..., 0], 0, 11)
    ys = np.clip(cells // 12 + hop[..., 1], 0, 11)
    near = (ys * 12 + xs).astype(np.int32)
    cells = np.where(rng.random((p, cap)) < 0.6, np.roll(near, 1, axis=1), cells)
    cells[:, 0] = free[0]
    length = rng.integers(1, cap + 1, p).astype(np.int32)
    cells, length = jnp.asarray(cells), jnp.asarray(length)
    got = jax.jit(waypoints_feasible)(grid, cells, length)
    want = jax.vmap(lambda c, n: is_feasible(grid, c, n))(cells, length)
    assert np.array_equal(np.asarray(got), np.asarray(want))
    assert 0 < int(np.sum(want)) < p  # both outcomes occur
