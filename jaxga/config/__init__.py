"""Configurations: the schema of keys and the built-in presets.

The keys' fields are :class:`jaxga.core.fields.Field` (type, range, meaning, default); the
operators and their own keys are declared beside their code and gathered in
:mod:`jaxga.operators.registry`.

- :mod:`~jaxga.config.schema`: :class:`Config`, ``SCHEMA`` and ``DEFAULTS`` (the common keys
  and the registry's);
- :mod:`~jaxga.config.presets`: the built-in presets and TOML preset files.

The schema's names are re-exported here (``jaxga.config.Config``).
"""

from jaxga.config.schema import (
    COMMON_DEFAULTS,
    COMMON_FIELDS,
    DEFAULTS,
    FALLBACKS,
    REPAIR_FALLBACKS,
    REQUIRED,
    SCHEMA,
    TOPOLOGIES,
    Config,
    flatten,
    load_toml,
    parse_value,
)

__all__ = [
    "COMMON_DEFAULTS",
    "COMMON_FIELDS",
    "Config",
    "DEFAULTS",
    "FALLBACKS",
    "REPAIR_FALLBACKS",
    "REQUIRED",
    "SCHEMA",
    "TOPOLOGIES",
    "flatten",
    "load_toml",
    "parse_value",
]
