"""``jaxga maps``, ``jaxga presets`` and ``jaxga operators``: what is built in."""

from __future__ import annotations

import argparse
import json
from typing import Any

from jaxga.config.presets import preset_info, preset_settings
from jaxga.config.schema import sweepable
from jaxga.core.errors import JaxgaError
from jaxga.maps import (
    builtin_names,
    builtin_scenario_path,
    load_map,
)
from jaxga.operators import registry


def cmd_maps(args: argparse.Namespace) -> int:
    """``jaxga maps``: list the built-in maps with their sizes."""

    for name in builtin_names():
        g = load_map(name)
        scen = " (with scenarios)" if builtin_scenario_path(name) else ""
        print(f"{name:44s} {g.width:4d} x {g.height:<4d}{scen}")
    return 0


def sweep_kind(key: str) -> str:
    """``"dynamic"`` for a key a sweep varies in one compiled call (a traced parameter,
    or the population size: :func:`jaxga.config.schema.sweepable`), ``"static"`` for one
    compiled in, ``"per call"`` for the generation count (a run-time value of the
    programs, one per call: a sweep has one), ``""`` for metadata (name, paper,
    description)."""
    if key in ("name", "paper", "description"):
        return ""
    if key == "generations":
        return "per call"
    return "dynamic" if sweepable(key) else "static"


def cmd_presets(args: argparse.Namespace) -> int:
    """``jaxga presets``: list the presets with their papers; ``--show NAME`` prints one
    preset's every setting, whether a sweep can vary it in one compiled call
    (``dynamic``), it is compiled in (``static``) or it is one per call
    (``per call``: the generation count), and its source (the file and the
    comment next to the key, or the default)."""

    if args.show is not None:
        rows = preset_settings(args.show, variant=args.variant)
        width = max(len(key) for key, _, _ in rows)
        for key, value, source in rows:
            text = json.dumps(value) if isinstance(value, (list, str, bool)) else str(value)
            print(f"{key:{width}s} = {text:12s} {sweep_kind(key):8s} # {source}")
        return 0
    if args.variant is not None:
        raise JaxgaError("--variant goes with --show NAME")
    for name, paper, description in preset_info():
        print(f"{name:10s} {paper}")
        if description:
            print(f"{'':10s} {description}")
    return 0


def describe_field(field: Any) -> str:
    """One line on a configuration field: type, range or choices, default, whether it
    can be swept without recompiling, and its meaning."""
    kinds = field.kind if isinstance(field.kind, tuple) else (field.kind,)
    parts = ["/".join(k.__name__ for k in kinds)]
    if field.choices is not None:
        parts.append("one of " + ", ".join(map(str, field.choices)))
    if field.low is not None and field.high is not None:
        parts.append(f"in [{field.low}, {field.high}]")
    elif field.low is not None:
        parts.append(f">= {field.low}")
    elif field.high is not None:
        parts.append(f"<= {field.high}")
    if field.default is not None:
        parts.append(f"default {field.default}")
    parts.append("dynamic" if field.dynamic else "static")
    return f"{field.doc} ({'; '.join(parts)})"


def cmd_operators(args: argparse.Namespace) -> int:
    """``jaxga operators [FAMILY]``: the registered operators of each family (or one),
    with their former names, traits, parameters and papers (:mod:`jaxga.operators.registry`)."""

    families = registry.FAMILIES if args.family is None else (args.family,)
    for family in families:
        if family not in registry.FAMILIES:
            raise JaxgaError(f"unknown operator family {family!r} "
                             f"({', '.join(registry.FAMILIES)})")
        print(f"{family}.method")
        for op in registry.operators(family):
            former = f" (formerly {', '.join(op.aliases)})" if op.aliases else ""
            traits = f" [{', '.join(sorted(op.traits))}]" if op.traits else ""
            print(f"  {op.name}{former}{traits}")
            print(f"      {op.summary}")
            for key, field in op.params.items():
                print(f"      {key}: {describe_field(field)}")
    return 0


def add_parser(commands: argparse._SubParsersAction) -> None:
    """Add the ``presets, operators, maps`` commands to ``jaxga``'s parser."""
    p = commands.add_parser("presets", help="list the presets and their papers, or show one "
                       "preset's settings (--show NAME)")
    p.add_argument("--show", metavar="NAME", help="print every setting of this preset (or "
                   "TOML file), 'dynamic' (a sweep varies it in one compiled call), "
                   "'static' (compiled in) or 'per call' (the generation count: one per "
                   "sweep), with its source: the preset file and its comment, or default")
    p.add_argument("--variant", help="with --show: apply this variant")
    p.set_defaults(func=cmd_presets)

    p = commands.add_parser("operators", help="list the operators of each family, with their "
                       "parameters (the values of --set FAMILY.method=NAME)")
    p.add_argument("family", nargs="?", help="one family: init, fitness, selection, "
                   "crossover, mutation, simplify or post")
    p.set_defaults(func=cmd_operators)

    p = commands.add_parser("maps", help="list the built-in maps")
    p.set_defaults(func=cmd_maps)
