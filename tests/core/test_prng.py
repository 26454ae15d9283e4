"""jaxga's random bits (:mod:`jaxga.core.prng`): JAX's own under JAX's defaults, and the
same whatever PRNG settings the user's process has; every draw of the library goes
through them."""

from __future__ import annotations

import ast
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga.core import prng

PACKAGE = Path(prng.__file__).resolve().parents[1]

SEEDS = np.array([0, 1, 7, 12345, 2**31 - 1, 2**31, 2**32 - 1], np.int64)

USER_SETTINGS = [
    {"jax_threefry_partitionable": False},
    {"jax_default_prng_impl": "rbg"},
    {"jax_random_seed_offset": 7},
    {"jax_legacy_prng_key": "error"},
]
"""JAX settings a user may give their process (``jax.config.update`` or the variables of
the same names): each changes what ``jax.random`` computes from a raw key or a seed."""


@pytest.fixture
def user_settings(request):
    """The process under one of :data:`USER_SETTINGS`; JAX's defaults back after."""
    saved = {name: getattr(jax.config, name) for name in request.param}
    for name, value in request.param.items():
        jax.config.update(name, value)
    try:
        yield request.param
    finally:
        for name, value in saved.items():
            jax.config.update(name, value)


def _draws(key):
    """One of each draw jaxga makes, from one key."""
    a, b = prng.split(key)
    return (prng.split(key, 5), prng.fold_in(key, 3), prng.bits(a, (6,), jnp.uint32),
            prng.uniform(b, (4,), jnp.float32), prng.randint(a, (5,), 0, 9),
            prng.permutation(b, 7))


def test_seed_keys_are_jaxs_keys_of_32_bit_seeds():
    jax_keys = np.stack([np.asarray(jax.random.PRNGKey(int(s))) for s in SEEDS])
    assert np.array_equal(prng.seed_keys(SEEDS), jax_keys)
    assert np.array_equal(prng.seed_keys(SEEDS.astype(np.uint32)), jax_keys)
    assert np.array_equal(jax.jit(prng.seed_keys)(jnp.asarray(SEEDS, jnp.uint32)), jax_keys)
    assert np.array_equal(prng.seed_key(2**32 - 1), jax.random.PRNGKey(2**32 - 1))
    assert prng.seed_keys(SEEDS).dtype == jnp.uint32 and prng.seed_keys(3).shape == (2,)


def test_draws_under_jaxs_defaults_are_jaxs():
    key = jax.random.PRNGKey(11)
    a, b = jax.random.split(key)
    expected = (jax.random.split(key, 5), jax.random.fold_in(key, 3),
                jax.random.bits(a, (6,), jnp.uint32), jax.random.uniform(b, (4,), jnp.float32),
                jax.random.randint(a, (5,), 0, 9), jax.random.permutation(b, 7))
    for got, want in zip(_draws(key), expected, strict=True):
        assert np.array_equal(got, want)


@pytest.mark.parametrize("user_settings", USER_SETTINGS, indirect=True,
                         ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()))
def test_seeds_and_draws_are_the_same_under_the_users_prng_settings(user_settings):
    defaults_key = np.array([0, 11], np.uint32)
    key = prng.seed_key(11)
    assert np.array_equal(key, defaults_key)
    # a jit of its own: JAX's jit cache does not key on every PRNG setting
    eager, traced = _draws(key), jax.jit(lambda k: _draws(k))(key)
    for got_eager, got_traced, want in zip(eager, traced, EXPECTED_DRAWS, strict=True):
        assert np.array_equal(got_eager, want) and np.array_equal(got_traced, want)
    # the user's own draws keep the user's settings: the pinning is jaxga's alone
    name, value = next(iter(user_settings.items()))
    assert getattr(jax.config, name) == value


EXPECTED_DRAWS = tuple(np.asarray(x) for x in _draws(np.array([0, 11], np.uint32)))
"""The draws of seed 11's key under JAX's defaults (this module is imported under them)."""


def test_every_draw_of_jaxga_goes_through_its_prng_module():
    """No ``jax.random`` in jaxga's code but in :mod:`jaxga.core.prng` (any use, imported
    under any name): a draw made elsewhere would follow the user's PRNG settings (and
    programs stored under one setting would serve another: the program store's key
    leaves them out)."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "prng.py" and path.parent.name == "core":
            continue
        where = path.relative_to(PACKAGE.parent)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and ast.unparse(node.value) == "jax.random":
                found.append(f"{where}:{node.lineno} {ast.unparse(node)}")
            elif isinstance(node, ast.Import) and any(
                    a.name == "jax.random" for a in node.names):
                found.append(f"{where}:{node.lineno} import jax.random")
            elif isinstance(node, ast.ImportFrom) and (
                    node.module == "jax.random"
                    or node.module == "jax" and any(a.name == "random" for a in node.names)):
                found.append(f"{where}:{node.lineno} from {node.module} import ...")
    assert found == []
