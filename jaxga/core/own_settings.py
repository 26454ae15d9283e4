"""The JAX settings jaxga's own work runs under, whatever the user's process has; and the
one process it cannot work in.

A user sets JAX's switches for their own code; jaxga's public functions are written for
JAX's defaults in three of them, and :func:`own_settings` gives them those while they run
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
- numeric dtype promotion (``jax_numpy_dtype_promotion``): under ``"strict"`` the
  smoothing's mixed float and integer arithmetic failed; inside jaxga's functions it is
  JAX's ``"standard"``.

A process forked after JAX's backend started cannot compute: its first computation waits
forever (JAX's backend does not survive a fork; ``multiprocessing``'s default start
method on Linux forks). :func:`own_settings` refuses to start in such a process, in one
line (:func:`check_not_forked`).

The pure core's methods (:class:`jaxga.engine.run.PureGA`) carry it too, so a user's own
``jax.jit`` of ``GA.run`` traces them under it; the settings change no program (a
traced function transfers nothing, and promotion is the same broadcast either way). An
operator called on its own, outside those methods, follows the user's settings.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from typing import Any, TypeVar

import jax

from jaxga.core.errors import ParameterError

__all__ = ["check_jax_settings", "check_not_forked", "own_settings"]

F = TypeVar("F", bound=Callable[..., Any])


_FORKED_AFTER_JAX = [False]
"""Whether this process was forked from one whose JAX backend had started."""


def _backend_started() -> bool:
    """JAX's own record of its started backends, read without JAX's lock (in a forked
    child a lock another thread of the parent held stays locked for good)."""
    try:
        from jax._src import xla_bridge  # JAX's own record; no public equivalent

        return bool(getattr(xla_bridge, "_backends", None))
    except ImportError:  # another JAX: nothing known, nothing refused
        return False


def _after_fork_in_child() -> None:
    _FORKED_AFTER_JAX[0] = _FORKED_AFTER_JAX[0] or _backend_started()


os.register_at_fork(after_in_child=_after_fork_in_child)


def check_not_forked() -> None:
    """Refuse, in one :class:`ParameterError` line, to work in a process forked from one
    whose JAX backend had started (module docstring)."""
    if _FORKED_AFTER_JAX[0]:
        raise ParameterError(
            "this process was forked from one that had started JAX, whose backend does not "
            "work after a fork (a run would wait forever): start the processes with "
            "multiprocessing.get_context('spawn') or 'forkserver', or fork before the "
            "parent starts JAX (a map loaded, a GA built or a run)")


def own_settings(fn: F) -> F:
    """``fn`` under jaxga's own JAX settings while it runs: JAX's transfers allowed
    (``jax.transfer_guard("allow")``), implicit rank promotion allowed
    (``jax.numpy_rank_promotion("allow")``) and JAX's standard dtype promotion,
    thread-locally; refused in a process forked after JAX started
    (:func:`check_not_forked`)."""

    @functools.wraps(fn)
    def under_own_settings(*args: Any, **kwargs: Any) -> Any:
        check_not_forked()
        with jax.transfer_guard("allow"), jax.numpy_rank_promotion("allow"), \
                jax.numpy_dtype_promotion("standard"):
            return fn(*args, **kwargs)

    return under_own_settings  # type: ignore[return-value]


def _given(variable: str) -> str:
    value = os.environ.get(variable)
    return f" (${variable}={value})" if value is not None else ""


def check_jax_settings(jit: bool = True) -> None:
    """Refuse JAX's 64-bit mode and (``jit``) a disabled ``jit`` (set by their environment
    variables or by ``jax.config.update``) in one :class:`ParameterError` line each; and a
    process forked from one whose JAX backend had started (``multiprocessing``'s default
    start method on Linux, after a run, a Planner or a GA in the parent:
    :func:`check_not_forked`). The pure core (:class:`jaxga.engine.run.PureGA`) checks
    without ``jit``: its functions also run eagerly, as a user's code under
    ``jax.disable_jit()`` does; the drivers' compiled programs cannot."""
    check_not_forked()
    if jax.config.jax_enable_x64:
        raise ParameterError(
            f"JAX's 64-bit mode is on{_given('JAX_ENABLE_X64')}: jaxga computes in 32 bits "
            "(int32 cells, float32 fitness); turn it off for jaxga's runs (unset "
            "JAX_ENABLE_X64, or jax.config.update('jax_enable_x64', False))")
    if jit and jax.config.jax_disable_jit:
        raise ParameterError(
            f"jit is disabled{_given('JAX_DISABLE_JIT')}: jaxga's runs are compiled "
            "programs, which JAX cannot run with jit disabled; unset JAX_DISABLE_JIT (or "
            "jax.config.update('jax_disable_jit', False))")
