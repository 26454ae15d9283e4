"""Configurations: the schema of keys, the operator registry, the built-in presets.

- :mod:`~jaxga.config.fields`: one key's type, range, meaning and default;
- :mod:`~jaxga.config.registry`: every operator, declared once (family, function, keys,
  traits);
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
