"""Built-in presets (one TOML file per paper) and user configuration files -> :class:`Config`.

A preset is a TOML file whose tables are the dotted keys of :data:`jaxga.config.schema.SCHEMA`
(``[crossover] probability = 0.8`` is ``crossover.probability``). Besides those keys a
file may hold

* ``[variants.NAME]``: a table of overrides selected with ``variant="NAME"`` (for example
  AGACD's 50 x 50 parameter set, Table 10, on top of its 20 x 20 set, Table 6). Dotted
  keys work inside it: ``population.size = 80``.
* ``base = "imga"`` (user files only): start from a built-in preset, or from another TOML
  file (a relative path is relative to the file that names it), and override it.

Layers, later ones win::

    base preset -> base variant -> file -> file variant -> overrides -> sets

``variant`` applies to the whole ``base`` chain: each file contributes its own
``[variants.NAME]`` table if it has one, and at least one of them must. A user file that
does not set ``name`` is named after its file (``my_run.toml`` -> ``"my_run"``); a selected
variant is noted at the end of ``description``.

The built-in presets live in the repository's top-level ``presets/`` folder, which the
package build installs as ``jaxga/presets_data/`` (see ``[tool.setuptools]`` in
``pyproject.toml``); they are read with :mod:`importlib.resources`, falling back to the
``presets/`` folder next to the package in a source checkout.

Every error a user can cause (unknown preset, variant or key, a value of the wrong type or
out of range, malformed TOML, a malformed ``--set``) is a
:class:`~jaxga.core.errors.ParameterError` whose one-line message names the file or key.
"""

from __future__ import annotations

import copy
import difflib
import functools
import os
import sys
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from jaxga.config.schema import DEFAULTS, SCHEMA, Config, flatten, parse_value
from jaxga.core.errors import ParameterError
from jaxga.maps.inputs import read_input

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["load_preset", "preset_info", "preset_names", "preset_variants"]

_DATA_DIR = "presets_data"  # jaxga/presets_data/ in an installed package
_RESERVED = ("base", "variants")


def _preset_dir() -> Any:
    """The directory (a :class:`~importlib.resources.abc.Traversable`) of the built-in presets."""
    installed = resources.files("jaxga").joinpath(_DATA_DIR)
    if installed.is_dir():
        return installed
    checkout = Path(__file__).resolve().parents[2] / "presets"
    if checkout.is_dir():
        return checkout
    raise ParameterError(  # pragma: no cover - a broken installation
        "the built-in presets are missing (neither jaxga/presets_data nor presets/ exists)"
    )


def preset_names() -> list[str]:
    """Names of the built-in presets, sorted (``["agacd", "iga_zhang", ...]``)."""
    return sorted(p.name[: -len(".toml")] for p in _preset_dir().iterdir()
                  if p.name.endswith(".toml") and p.is_file())


def _preset_file(name: str) -> Any:
    if name not in preset_names():
        raise ParameterError(
            f"unknown preset {name!r} (built-in presets: {', '.join(preset_names())}; "
            "or give the path of a .toml file)"
        )
    return _preset_dir().joinpath(f"{name}.toml")


def _parse(text: str, label: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(f"{label}: malformed TOML: {e}") from None


def _read_builtin(name: str) -> dict[str, Any]:
    """A built-in preset's parsed table (a fresh copy: the parse is cached, since a
    re-plan or a sweep loads the same preset again and again)."""
    return copy.deepcopy(_parsed_builtin(name))


@functools.lru_cache(maxsize=64)
def _parsed_builtin(name: str) -> dict[str, Any]:
    return _parse(_preset_file(name).read_text(encoding="utf-8"), f"preset {name!r}")


PRESET_FILE_CAP = 1 << 20
"""The most bytes read from a preset or configuration TOML file (a preset is a few KiB)."""


def _read_file(path: Path) -> dict[str, Any]:
    try:
        text = read_input(path, PRESET_FILE_CAP, what="configuration file",
                          error=ParameterError).decode("utf-8")
    except FileNotFoundError:
        raise ParameterError(f"configuration file not found: {path}") from None
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not a UTF-8 text file") from None
    except OSError as e:
        raise ParameterError(f"cannot read configuration file {path}: {e.strerror}") from None
    return _parse(text, str(path))


def preset_info() -> list[tuple[str, str, str]]:
    """``(name, paper, description)`` of every built-in preset (for ``jaxga presets``)."""
    out = []
    for name in preset_names():
        table = _read_builtin(name)
        out.append((name, str(table.get("paper", "")), str(table.get("description", ""))))
    return out


def preset_variants(name_or_path: str | os.PathLike) -> list[str]:
    """The ``[variants.X]`` names available to a preset or user file (its base chain included)."""
    names: set[str] = set()
    for _, _, variants in _chain(name_or_path):
        names.update(variants)
    return sorted(names)


def _is_path(name_or_path: str | os.PathLike) -> bool:
    if isinstance(name_or_path, os.PathLike):
        return True
    s = str(name_or_path)
    if s.endswith(".toml") or "/" in s or os.sep in s:
        return True
    # a bare word is a preset name, unless it is none and a file of that name exists
    return s not in preset_names() and Path(s).is_file()


def _split(table: dict[str, Any], label: str) -> tuple[dict[str, Any], dict[str, dict]]:
    """A parsed file -> (its dotted keys without base/variants, {variant: dotted keys})."""
    variants_raw = table.get("variants", {})
    if not isinstance(variants_raw, Mapping) or not all(
        isinstance(v, Mapping) for v in variants_raw.values()
    ):
        raise ParameterError(f"{label}: 'variants' must hold tables [variants.NAME]")
    body = flatten({k: v for k, v in table.items() if k not in _RESERVED})
    variants = {str(k): flatten(v) for k, v in variants_raw.items()}
    for vname, keys in variants.items():
        for key in keys:
            if key in _RESERVED or key.split(".")[0] in _RESERVED:
                raise ParameterError(f"{label}: [variants.{vname}] cannot set {key!r}")
    return body, variants


def _chain(
    name_or_path: str | os.PathLike, relative_to: Path | None = None, seen: tuple = ()
) -> list[tuple[str, dict[str, Any], dict[str, dict]]]:
    """``[(label, keys, variants), ...]`` from the innermost base to ``name_or_path``."""
    if _is_path(name_or_path):
        path = Path(name_or_path).expanduser()
        if relative_to is not None and not path.is_absolute():
            path = relative_to / path
        label, ident = str(path), ("file", str(path.resolve()))
        table = _read_file(path)
    else:
        path, label, ident = None, f"preset {name_or_path!r}", ("preset", str(name_or_path))
        table = _read_builtin(str(name_or_path))
    if ident in seen:
        raise ParameterError(f"{label}: 'base' chain loops back to itself")
    body, variants = _split(table, label)
    if path is not None and "name" not in body:
        body = {"name": path.stem, **body}
    base = table.get("base")
    if base is None:
        return [(label, body, variants)]
    if path is None:
        raise ParameterError(f"{label}: a built-in preset cannot have a 'base'")
    if not isinstance(base, str) or not base:
        raise ParameterError(f"{label}: base must be a preset name or a file path, got {base!r}")
    try:
        inner = _chain(base, relative_to=path.parent, seen=(*seen, ident))
    except ParameterError as e:
        msg = str(e)
        raise ParameterError(msg if msg.startswith(label) else f"{label}: base: {msg}") from None
    return [*inner, (label, body, variants)]


def file_overrides(name_or_path: str | os.PathLike,
                   variant: str | None = None) -> list[tuple[str, Config, list[str]]]:
    """The keys that each user TOML file in the ``base`` chain of ``name_or_path`` sets,
    with the configuration of THAT file (with ``variant`` where the file's chain has it):
    ``[(label, config, keys), ...]``. Such a key is an override like ``--set``, checked by
    :func:`jaxga.engine.check_file_keys_read`. Built-in presets, the metadata and values
    equal to the key's default (:data:`jaxga.config.schema.DEFAULTS`: a file that spells
    out ``tournament_size = 2``) are left out, and so is ``map.corner_rule``, a default
    that ``corner_rule=`` or a Grid replaces as a built-in preset's is."""
    out = []
    chain = _chain(name_or_path)
    for depth, (label, body, variants) in enumerate(chain):
        if label.startswith("preset "):  # a built-in preset
            continue
        has_variant = variant is not None and any(
            variant in vs for _, _, vs in chain[:depth + 1])
        config = load_preset(label, variant=variant if has_variant else None)
        own = {**body, **(variants.get(variant, {}) if has_variant else {})}
        keys = [k for k in own
                if k not in ("name", "paper", "description", "map.corner_rule")
                and (k not in DEFAULTS or config.get(k) != DEFAULTS[k])]
        out.append((label, config, keys))
    return out


def as_sets(sets: Any) -> tuple[str, ...]:
    """``sets`` as a tuple of ``"key=value"`` strings: one string is one set (not its
    characters); anything but a string or a sequence is refused."""
    if isinstance(sets, bytes) or not isinstance(sets, (str, Sequence)):
        raise ParameterError(f"sets must be 'key=value' strings, got {sets!r}")
    return (sets,) if isinstance(sets, str) else tuple(sets)


def overridden_keys(overrides: Mapping[str, Any], sets: Sequence[str]) -> list[str]:
    """The dotted configuration keys that keyword ``overrides`` (``a__b=...`` or
    ``"a.b"``, nested mappings flattened) and ``sets`` give, in that order."""
    keys = list(flatten({k.replace("__", "."): v for k, v in overrides.items()}))
    return keys + [parse_set(text)[0] for text in sets]


def parse_set(text: str) -> tuple[str, Any]:
    """``(key, value)`` of a ``--set key=value`` string; the value is parsed as TOML."""
    if not isinstance(text, str) or "=" not in text:
        raise ParameterError(f"malformed --set {text!r}: expected key=value")
    key, _, value = text.partition("=")
    key, value = key.strip(), value.strip()
    if not key or not value:
        raise ParameterError(f"malformed --set {text!r}: expected key=value")
    if key not in SCHEMA:
        near = [k for k in SCHEMA if k.split(".")[-1] == key.split(".")[-1]]
        near = near or difflib.get_close_matches(key, list(SCHEMA), n=3)
        hint = f" (did you mean {', '.join(near)}?)" if near else ""
        raise ParameterError(f"--set {text!r}: unknown configuration key {key!r}{hint}")
    return key, parse_value(value)


def _validated(values: Mapping[str, Any], where: str) -> Config:
    try:
        return Config.from_mapping(values)
    except ParameterError as e:
        raise ParameterError(f"{where}: {e}") from None


def load_preset(
    name_or_path: str | os.PathLike,
    variant: str | None = None,
    overrides: Mapping[str, Any] | None = None,
    sets: Sequence[str] = (),
) -> Config:
    """A validated configuration from a built-in preset or a user TOML file.

    Args:
        name_or_path: a built-in preset name (:func:`preset_names`) or the path of a TOML
            file (a string ending in ``.toml`` or containing a path separator, a
            :class:`os.PathLike`, or an existing file whose name is not a preset name).
            A user file may start from another preset with a top-level ``base = "imga"``.
        variant: the name of a ``[variants.NAME]`` table to apply (e.g. ``"50x50"``).
        overrides: dotted keys (``{"crossover.probability": 0.7}``; nested mappings are
            flattened) applied after the file and its variant.
        sets: ``"key=value"`` strings as given to ``--set`` on the command line, applied
            last; the value is TOML (``0.7``, ``true``, ``[0.1, 0.8]``) or a bare word.

    Raises:
        ParameterError: unknown preset, file, variant or key; malformed TOML or ``--set``;
            a value of the wrong type or out of range. The message names the file or key.
    """
    sets = as_sets(sets)
    chain = _chain(name_or_path)
    label = chain[-1][0]
    merged: dict[str, Any] = {}
    found = False
    for _, body, variants in chain:
        merged.update(body)
        if variant is not None and variant in variants:
            merged.update(variants[variant])
            found = True
    if variant is not None:
        if not found:
            available = sorted({v for _, _, vs in chain for v in vs})
            have = f"available: {', '.join(available)}" if available else "it has no variants"
            raise ParameterError(f"{label} has no variant {variant!r} ({have})")
        desc = merged.get("description", "")
        if isinstance(desc, str):
            merged["description"] = f"{desc} [variant {variant}]".strip()
    config = _validated(merged, label)
    if overrides:
        if not isinstance(overrides, Mapping):
            raise ParameterError(f"overrides must be a mapping of dotted keys, got {overrides!r}")
        config = _validated({**config.as_dict(), **flatten(overrides)}, "overrides")
    for text in sets:
        key, value = parse_set(text)
        config = _validated({**config.as_dict(), key: value}, f"--set {text!r}")
    return config


def _key_comments(text: str) -> dict[str, str]:
    """``{dotted key: its comment}`` of a TOML preset file: the comment after ``key =
    value`` plus the comment-only lines right under it (continuations); keys of
    ``[variants.X]`` tables as ``variants.X.key``."""
    out: dict[str, str] = {}
    table, last = "", None
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("[") and not stripped.startswith("[["):
            table, last = stripped.strip("[]").strip(), None
            continue
        if stripped.startswith("#"):
            if last is not None and line.startswith(" "):  # an indented continuation
                out[last] += " " + stripped.lstrip("#").strip()
            else:
                last = None
            continue
        if "=" not in stripped:
            last = None
            continue
        key = stripped.split("=", 1)[0].strip()
        value_comment = stripped.split("=", 1)[1]
        comment = value_comment.split("#", 1)[1].strip() if "#" in value_comment else ""
        last = f"{table}.{key}" if table else key
        out[last] = comment
    return out


def preset_settings(name_or_path: str | os.PathLike,
                    variant: str | None = None) -> list[tuple[str, Any, str]]:
    """Every setting of a preset (and variant) with its source: ``(key, value, source)``,
    where the source is the file (or variant) that sets the key, with the comment written
    next to it (the paper's section, the decision), or ``"default"`` for a key the
    preset leaves at the schema's default (``jaxga presets --show``)."""
    config = load_preset(name_or_path, variant=variant)
    chain = _chain(name_or_path)
    sources: dict[str, str] = {}
    for label, body, variants in chain:
        if label.startswith("preset "):
            text = _preset_file(label.split("'")[1]).read_text(encoding="utf-8")
        else:
            text = Path(label).read_text(encoding="utf-8")
        comments = _key_comments(text)
        name = label.split("'")[1] + ".toml" if label.startswith("preset ") else label
        for key in body:
            note = comments.get(key, "")
            sources[key] = f"{name}: {note}" if note else name
        if variant is not None and variant in variants:
            for key in variants[variant]:
                note = comments.get(f"variants.{variant}.{key}", "")
                where = f"{name} [variants.{variant}]"
                sources[key] = f"{where}: {note}" if note else where
    return [(key, value, sources.get(key, "default"))
            for key, value in sorted(config.as_dict().items())]

