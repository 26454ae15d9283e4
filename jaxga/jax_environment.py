"""JAX's own environment variables, read when JAX is imported: a value JAX refuses is named.

JAX reads its settings from ``JAX_*`` variables (``JAX_ENABLE_X64``,
``JAX_NUM_CPU_DEVICES``, ...) the moment it is imported, and refuses a value it cannot
read with a ``ValueError`` raised from deep in its flags' definitions. ``import jaxga``
imports JAX here first, so that such a refusal is one line naming the variable and its
value: the ``jaxga`` command says so and exits with status 2 (decision 054); a Python
program gets a ``ValueError`` with that line. Any other error of JAX's import is
raised as it is. Before it, the ``jaxga`` command refuses in one line a process that may
map too little memory for any run (:func:`address_space_refusal`, decision 056); the
Python API refuses it when a run is asked for. The module reads nothing but
the environment and uses the standard library before JAX, which may not load.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping

from jaxga import interrupts
from jaxga.core.address_space import address_space_refusal

__all__ = ["EXIT_BAD_ENVIRONMENT", "jax_refusal"]

EXIT_BAD_ENVIRONMENT = 2
"""The command's exit status for a ``JAX_*`` variable JAX refuses: bad input (the status
of every other refused input, :data:`jaxga.cli.options.EXIT_BAD_INPUT`)."""


def jax_refusal(error: BaseException, environ: Mapping[str, str]) -> str | None:
    """One line for JAX's refusal ``error`` of a ``JAX_*`` variable: the variables whose
    names (or values) its message holds, and what to do; None where it names none (an
    error of another kind, such as a broken installation, is not the environment's)."""
    said = str(error).splitlines()[0] if str(error) else type(error).__name__
    ours = {k: v for k, v in environ.items() if k.upper().startswith("JAX_")}
    named = {k: v for k, v in ours.items()
             if k.lower() in said.lower() or (v and (repr(v) in said or f'"{v}"' in said))}
    if not named:
        return None
    where = ", ".join(f"{k}={v!r}" for k, v in sorted(named.items()))
    return f"JAX refuses its environment ({said}): {where}; correct or unset it"


if interrupts.in_console_script() and address_space_refusal() is not None:
    print(f"jaxga: error: {address_space_refusal()}", file=sys.stderr)
    raise SystemExit(EXIT_BAD_ENVIRONMENT)

try:
    import jax  # noqa: F401  (imported here so that a refused JAX_* variable is named)
except ValueError as error:  # JAX's flags refuse a value read from a JAX_* variable
    _MESSAGE = jax_refusal(error, os.environ)
    if _MESSAGE is None:  # not a variable's value: JAX's own error, as it is
        raise
    if interrupts.in_console_script():
        print(f"jaxga: error: {_MESSAGE}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_ENVIRONMENT) from None
    raise ValueError(_MESSAGE) from error
