"""jaxga's random bits: JAX's Threefry-2x32 in its partitionable form, whatever the user's
JAX defaults say.

Every key of jaxga is a raw ``uint32[2]`` Threefry-2x32 key (Salmon et al., "Parallel
random numbers: as easy as 1, 2, 3", SC 2011), and seed ``s`` is the key
``jax.random.PRNGKey(s)`` under JAX's defaults. JAX itself reads three of its settings
when it turns a seed into a key or a key into bits:

- ``jax_default_prng_impl``: the generator a raw key is taken for (``rbg`` reads a
  ``uint32[4]``: a ``uint32[2]`` key is refused, deep in JAX);
- ``jax_threefry_partitionable``: the order in which Threefry's counters are laid out
  (JAX's default since 0.5; code that keeps its older numbers turns it off): the same
  key gives other bits, so the same seed another run;
- ``jax_random_seed_offset``: added to every seed, so seed ``s`` is run ``s + offset``;
- ``jax_legacy_prng_key``: ``"warn"`` or ``"error"`` on every draw from a raw key.

A user may set any of them for their own code. jaxga's results are its seeds', so every
draw of jaxga goes through the functions here, which are JAX's own drawn under
:func:`pinned` (the defaults, for the duration of the draw): the equations a draw
records carry the setting, so it holds however the program is later lowered, under the
user's own ``jax.jit`` too; and :func:`seed_keys` builds the keys without JAX's seeding
(Threefry's key of a 32-bit seed ``s`` is ``[0, s]``), so no offset applies. Under JAX's
defaults every function here gives exactly JAX's bits.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core.errors import ParameterError

__all__ = ["IMPL", "bits", "checked_key", "fold_in", "permutation", "pinned", "randint", "seed_key",
           "seed_keys", "split", "uniform"]

IMPL = "threefry2x32"
"""The generator of every jaxga key (JAX's default)."""

F = TypeVar("F", bound=Callable[..., Any])


@contextlib.contextmanager
def pinned() -> Iterator[None]:
    """JAX's default generator (:data:`IMPL`), partitionable Threefry and raw keys
    allowed, for the draws made inside (thread-local; the user's settings are back on
    leaving)."""
    with jax.default_prng_impl(IMPL), jax.threefry_partitionable(True), \
            jax.legacy_prng_key("allow"):
        yield


def _drawn_pinned(fn: F) -> F:
    @functools.wraps(fn)
    def draw(*args: Any, **kwargs: Any) -> Any:
        with pinned():
            return fn(*args, **kwargs)
    draw.__doc__ = (f"``jax.random.{fn.__name__}`` under :func:`pinned`: JAX's bits "
                    "whatever the user's PRNG settings.")
    return draw  # type: ignore[return-value]


split = _drawn_pinned(jax.random.split)
fold_in = _drawn_pinned(jax.random.fold_in)
bits = _drawn_pinned(jax.random.bits)
uniform = _drawn_pinned(jax.random.uniform)
randint = _drawn_pinned(jax.random.randint)
permutation = _drawn_pinned(jax.random.permutation)


def seed_keys(seeds: Any) -> jax.Array:
    """The keys ``uint32[..., 2]`` of seeds in ``[0, 2**32)`` (an integer, a NumPy or a
    JAX integer array, traced or not): ``[0, s]``, which is ``jax.random.PRNGKey(s)``
    under JAX's defaults (Threefry's key of a seed: its high and its low 32 bits),
    whatever ``jax_random_seed_offset`` or ``jax_default_prng_impl`` the user set."""
    low = (seeds.astype(jnp.uint32) if isinstance(seeds, jax.Array)
           else np.asarray(seeds).astype(np.uint32))
    return jnp.stack([jnp.zeros_like(low), jnp.asarray(low)], axis=-1)


def seed_key(seed: int) -> jax.Array:
    """The key ``uint32[2]`` of one 32-bit seed (:func:`seed_keys`)."""
    return seed_keys(seed)


def checked_key(key: Any) -> Any:
    """``key`` if it is one run's Threefry-2x32 key: a raw ``uint32[2]``
    (``jax.random.PRNGKey(s)``) or a typed key of that generator (``jax.random.key(s)``);
    anything else refused in one :class:`ParameterError` line. A key of another
    generator (``jax.random.key(s, impl="rbg")``) would run, but its bits depend on the
    keys that share its batch, so one seed's run would change with the others."""
    dtype, shape = getattr(key, "dtype", None), getattr(key, "shape", None)
    if dtype is not None and jnp.issubdtype(dtype, jax.dtypes.prng_key):
        impl = str(jax.random.key_impl(key))
        if impl != IMPL:
            raise ParameterError(
                f"a key of the {impl!r} generator: jaxga's runs take Threefry keys "
                f"(jaxga.core.prng.seed_key(seed), or jax.random.key(seed, "
                f"impl='threefry2x32')), whose bits do not depend on the other runs of a "
                f"batch")
        if shape != ():
            raise ParameterError(f"one run takes one key, got keys of shape {shape}: "
                                 "jax.vmap the function over them")
        return key
    if dtype == jnp.uint32 and shape == (2,):
        return key
    what = (f"{np.dtype(dtype).name}{list(shape)}" if dtype is not None and shape is not None
            else type(key).__name__)
    hint = (": jax.vmap the function over them" if dtype == jnp.uint32 and shape
            and shape[-1] == 2 else "")
    raise ParameterError(f"a run's key must be one Threefry key (jaxga.core.prng.seed_key("
                         f"seed), a uint32[2], or jax.random.key(seed, "
                         f"impl='threefry2x32')), got {what}{hint}")
