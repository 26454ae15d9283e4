"""Walking a jaxpr and the jaxprs inside it (loops, conditionals, custom rules,
``shard_map`` bodies): what the tests that inspect whole runs share."""

from __future__ import annotations

from collections.abc import Iterator

from jax.extend.core import ClosedJaxpr, Jaxpr


def sub_jaxprs(params: dict) -> Iterator[Jaxpr]:
    """The jaxprs among an equation's parameters (a loop's body, a branch, ...)."""
    for value in params.values():
        for v in value if isinstance(value, (tuple, list)) else (value,):
            if isinstance(v, ClosedJaxpr):
                yield v.jaxpr
            elif isinstance(v, Jaxpr):
                yield v
