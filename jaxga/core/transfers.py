"""jaxga's own transfers between the host and a device, under a user's transfer guard.

JAX's transfer guard (``jax_transfer_guard``, ``JAX_TRANSFER_GUARD``, the
``jax.transfer_guard`` scope) refuses or logs the implicit transfers of the code it
covers: a user sets it to find those of their own code. jaxga's host work moves its own
data on purpose (a map's tables, a configuration's parameters, the seeds' keys, the
results read back), through implicit transfers as JAX code does; under a guard set to
``"disallow"`` each would fail deep in XLA ("Disallowed host-to-device transfer").
:func:`own_transfers` marks the public functions that do such work: inside them JAX's
transfers are allowed; the user's guard is back on return, for their code around them.
Inside a user's ``jax.jit`` it changes nothing (a traced function transfers nothing).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import jax

__all__ = ["own_transfers"]

F = TypeVar("F", bound=Callable[..., Any])


def own_transfers(fn: F) -> F:
    """``fn`` with JAX's transfers allowed while it runs (``jax.transfer_guard("allow")``,
    thread-local): the transfers of jaxga's own host work, whatever guard the user set."""

    @functools.wraps(fn)
    def allowed(*args: Any, **kwargs: Any) -> Any:
        with jax.transfer_guard("allow"):
            return fn(*args, **kwargs)

    return allowed  # type: ignore[return-value]
