"""The JAX settings jaxga's own work runs under, whatever the user's process has.

A user sets JAX's switches for their own code; jaxga's public functions are written for
JAX's defaults in two of them, and :func:`own_settings` gives them those while they run
(thread-local; the user's settings are back on return, for their code around them):

- the transfer guard (``jax_transfer_guard``, ``JAX_TRANSFER_GUARD``, the
  ``jax.transfer_guard`` scope) refuses or logs implicit transfers: a user sets it to
  find those of their own code. jaxga's host work moves its own data on purpose (a map's
  tables, a configuration's parameters, the seeds' keys, the results read back), through
  implicit transfers as JAX code does; under ``"disallow"`` each failed deep in XLA.
  Inside jaxga's functions transfers are allowed.
- rank promotion (``jax_numpy_rank_promotion``): jaxga's operators broadcast arrays of
  different ranks as NumPy does; under ``"raise"`` (or ``"warn"``) their tracing failed
  (or warned) wherever a program was not already stored. Inside jaxga's functions it is
  allowed.

The pure core's methods (:class:`jaxga.engine.run.PureGA`) carry it too, so a user's own
``jax.jit`` of ``GA.run`` traces them under it; the settings change no program (a
traced function transfers nothing, and promotion is the same broadcast either way). An
operator called on its own, outside those methods, follows the user's settings.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import jax

__all__ = ["own_settings"]

F = TypeVar("F", bound=Callable[..., Any])


def own_settings(fn: F) -> F:
    """``fn`` under jaxga's own JAX settings while it runs: JAX's transfers allowed
    (``jax.transfer_guard("allow")``) and implicit rank promotion allowed
    (``jax.numpy_rank_promotion("allow")``), thread-locally."""

    @functools.wraps(fn)
    def under_own_settings(*args: Any, **kwargs: Any) -> Any:
        with jax.transfer_guard("allow"), jax.numpy_rank_promotion("allow"):
            return fn(*args, **kwargs)

    return under_own_settings  # type: ignore[return-value]
