"""The array types of the engine: float32 for fitness, lengths and probabilities, int32 for
cell indices, path lengths and counts (the same bits on every backend; jaxga never uses
float64)."""

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

__all__ = ["F32", "I32", "on_device"]

F32 = jnp.float32
"""Fitness, lengths, angles and probabilities."""

I32 = jnp.int32
"""Cell indices, node counts, counters."""


def on_device(value: Any, dtype: Any = None) -> jax.Array:
    """A host value (a NumPy array or a Python number, not a traced value) as a JAX array
    of ``dtype`` on the default device, as ``jnp.asarray(value, dtype)`` gives it,
    without compiling anything: ``jnp.asarray`` stages a host array through a small
    compiled program, one for each shape and type, which a fresh process compiles
    anew."""
    return jax.device_put(np.asarray(value, dtype))
