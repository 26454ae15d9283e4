"""Seeds of a run: the accepted forms, their PRNG keys, and their sharding over devices.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from collections.abc import Set as AbstractSet
from typing import Any

import jax
import numpy as np

from jaxga.core.errors import JaxgaError
from jaxga.core.grid import as_integer

SEED_LIMIT = 2**32
"""Seeds are 32-bit (``jax.random.PRNGKey`` of a uint32): seeds must lie in
``[0, SEED_LIMIT)``, where no two give the same run."""


def seed_list(seeds: int | Sequence[int],
              check_count: Callable[[int], None] | None = None) -> np.ndarray:
    """The seeds of a call, checked: a count ``N`` (seeds ``0..N-1``) or explicit seeds.
    ``check_count(n)`` runs once the number of seeds is known, before a count is turned
    into an array (so a count too large for memory is refused before it is allocated)."""
    check_count = check_count or (lambda n: None)
    if isinstance(seeds, (bool, np.bool_)):  # True is not a count of 1
        raise JaxgaError(f"seeds must be a count or a list of integer seeds, got {seeds!r}")
    if isinstance(seeds, (int, np.integer)) or getattr(seeds, "ndim", None) == 0:
        try:  # a 0-d numpy or JAX integer array is a count too
            seeds = as_integer(seeds)
        except TypeError:
            raise JaxgaError(
                f"seeds must be a count or a list of integer seeds, got {seeds!r}") from None
        if seeds < 1:
            raise JaxgaError(f"seeds must be >= 1, got {seeds}")
        if seeds > SEED_LIMIT:
            raise JaxgaError(f"seeds must be at most 2**32 (seeds are 32-bit), got {seeds}")
        check_count(int(seeds))
        return np.arange(int(seeds))
    if isinstance(seeds, jax.Array) and seeds.dtype == np.uint32 and seeds.shape[-1:] == (2,):
        # jax.random.PRNGKey(7) is [0, 7]: read as seeds it would be runs 0 and 7
        raise JaxgaError(
            f"seeds must be a count or a list of integer seeds, got a uint32{list(seeds.shape)} "
            "JAX array, the shape of a raw PRNG key (jax.random.PRNGKey): jaxga makes each "
            "run's key from its seed; to mean these values as seeds, give a list or a "
            "NumPy array")
    try:
        if isinstance(seeds, (AbstractSet, Mapping)):  # no order: run i's seed is unknown
            raise TypeError
        listed = None if isinstance(seeds, np.ndarray) else list(seeds)
        arr = seeds if listed is None else np.asarray(listed)
    except TypeError:
        arr = listed = None
    if listed is not None and any(isinstance(v, (bool, np.bool_)) for v in listed):
        raise JaxgaError(f"seeds must be integers, got {listed!r}")  # [2, True]: not 2, 1
    if listed and all(isinstance(v, (int, np.integer)) for v in listed):
        # [np.uint64(2**32 - 1), -1] is float64 to NumPy: read each integer as it is
        arr = np.array([int(v) for v in listed], dtype=object)
    if arr is None or isinstance(seeds, (str, bytes)) or arr.ndim != 1:
        raise JaxgaError(f"seeds must be a count or a list of integer seeds, got {seeds!r}")
    if arr.size == 0:
        raise JaxgaError("seeds must not be empty")
    if arr.dtype.kind == "O":  # Python integers beyond 64 bits, or mixed integer types
        try:
            values = [as_integer(v) for v in arr.tolist()]
        except TypeError:
            raise JaxgaError(f"seeds must be integers, got {list(seeds)!r}") from None
        if min(values) < 0 or max(values) >= SEED_LIMIT:
            raise JaxgaError(f"seeds must be integers in [0, 2**32) (seeds are 32-bit), got "
                             f"{min(values)} .. {max(values)}")
        arr = np.array(values, np.int64)
    if arr.dtype.kind not in "iu":
        raise JaxgaError(f"seeds must be integers, got {list(seeds)!r}")
    if arr.min() < 0 or arr.max() >= SEED_LIMIT:  # (uint64 compares exactly)
        raise JaxgaError(f"seeds must be integers in [0, 2**32) (seeds are 32-bit), got "
                         f"{int(arr.min())} .. {int(arr.max())}")
    values, counts = np.unique(arr, return_counts=True)
    if (counts > 1).any():  # the same run twice: a pseudo-replicate in any statistic
        raise JaxgaError(f"seeds must be distinct: seed {int(values[counts > 1][0])} is "
                         f"given {int(counts[counts > 1][0])} times (a seed always gives "
                         "the same run)")
    check_count(arr.size)
    return arr.astype(np.int64)


def seed_sharding() -> tuple[jax.sharding.NamedSharding | None, Any]:
    """(runs axis split over all local devices, replicated); (None, None) with one device.

    Local devices only: with several processes each computes its own share of the runs
    (``jaxga._runtime.parallel``), so no program spans processes."""
    n = jax.local_device_count()
    if n == 1:
        return None, None
    mesh = jax.make_mesh((n,), ("runs",), axis_types=(jax.sharding.AxisType.Auto,),
                         devices=jax.local_devices())
    P = jax.sharding.PartitionSpec
    return (jax.sharding.NamedSharding(mesh, P("runs")),
            jax.sharding.NamedSharding(mesh, P()))

