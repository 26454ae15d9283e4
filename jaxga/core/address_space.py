"""The least memory a process running jaxga may map, checked before JAX is imported.

The standard library only: :mod:`jaxga.jax_environment` calls it before ``import jax``
(decision 056).
"""

from __future__ import annotations

try:
    import resource
except ImportError:  # not POSIX
    resource = None  # type: ignore[assignment]

__all__ = ["MIN_ADDRESS_SPACE", "address_space_refusal"]

MIN_ADDRESS_SPACE = 2 << 30
"""The least memory a process running jaxga may map (bytes): twice
:data:`jaxga.core.grid.PLAN_BASE_BYTES`, since a plan may take at most half of what the
process may use (:mod:`jaxga._runtime.memory`). Under a lower ``ulimit -v`` no run fits,
and JAX and its libraries fail before jaxga can say so, each in its own way: OpenBLAS
looping for ever in its start (SIGTERM cannot end it), XLA aborting a thread, an
``ImportError`` of a library that cannot be mapped."""


def address_space_refusal() -> str | None:
    """One line saying that the process may map less than :data:`MIN_ADDRESS_SPACE` (its
    ``RLIMIT_AS``, ``ulimit -v``), or None where it may map that much or has no limit."""
    if resource is None:  # not POSIX: no such limit
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft in (resource.RLIM_INFINITY, -1) or soft <= 0 or soft >= MIN_ADDRESS_SPACE:
        return None
    return (f"this process may map only {soft / 2**30:.2f} GiB of memory (ulimit -v "
            f"{soft // 1024} KiB); jaxga needs at least {MIN_ADDRESS_SPACE / 2**30:.0f} GiB "
            "(JAX, its libraries and a run at most half of it): raise the limit")
