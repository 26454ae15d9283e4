"""The array types of the engine: float32 for fitness, lengths and probabilities, int32 for
cell indices, path lengths and counts (the same bits on every backend; jaxga never uses
float64)."""

import jax.numpy as jnp

__all__ = ["F32", "I32"]

F32 = jnp.float32
"""Fitness, lengths, angles and probabilities."""

I32 = jnp.int32
"""Cell indices, node counts, counters."""
