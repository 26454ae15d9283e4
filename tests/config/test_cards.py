"""Paper cards (docs/cards/*.toml): the chain the engine builds for a preset is the paper's.

A card is written from the paper, not from the preset's TOML: per stage the operator and
every parameter the paper gives. The chain is read from what the engine actually binds:
the registered operator of each role (:func:`jaxga.engine.chosen_operators`), the keyword
options of its function after :meth:`~jaxga.operators.registry.Operator.bind` (defaults
included, so an option the registry never sets shows its default), the operator's own
configuration keys, the family's common keys (``init.unique``, ``crossover.adaptive``,
...) and the stage's rate.
"""

from __future__ import annotations

import functools
import inspect
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

from jaxga.config.presets import load_preset, preset_names
from jaxga.config.schema import COMMON_FIELDS
from jaxga.core.grid import Grid
from jaxga.engine import binding, build, chosen_operators

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

CARDS = sorted((Path(__file__).resolve().parents[2] / "docs" / "cards").glob("*.toml"))
RATED = ("crossover", "mutation", "simplify")


def engine_chain(preset: str) -> dict:
    """``{"generations": G, family: {"operator": name, option: value, ...}}`` as built."""
    grid = Grid.create(np.zeros((8, 8), bool))
    config = load_preset(preset)
    algo, params = build(config, grid)
    ctx = binding(algo, params, t=jnp.int32(0), fit_fn=lambda *a: 0.0)
    chain: dict = {"generations": algo.generations,
                   "population": int(config["population.size"])}
    for role, op in chosen_operators(config).items():
        family = role.split(".")[0]
        if role == "init.fallback":
            chain.setdefault("init", {})["fallback"] = op.name
            continue
        entry = chain.setdefault(family, {})
        entry["operator"] = op.name
        if op.fn is not None:
            bound = op.bind(ctx)
            fn, kw = ((bound.func, bound.keywords) if isinstance(bound, functools.partial)
                      else (bound, {}))
            for name, p in inspect.signature(fn).parameters.items():
                if p.kind is p.KEYWORD_ONLY and p.default is not p.empty:
                    entry[name] = p.default
            entry.update({k: v for k, v in kw.items() if not callable(v)})
        entry.update({key.split(".", 1)[1]: config[key] for key in op.params})
        entry.update({key.split(".", 1)[1]: config[key] for key in COMMON_FIELDS
                      if key.startswith(f"{family}.") and key not in (
                          f"{family}.method", f"{family}.fallback", f"{family}.probability")
                      and config.get(key) is not None})
        rate = config.get(f"{family}.probability")  # None: adaptive or per island
        if family in RATED and (op.fn is not None or op.population is not None) and (
                rate is not None):
            entry["probability"] = rate
    chain["islands"] = {key.split(".", 1)[1]: config[key] for key in COMMON_FIELDS
                        if key.startswith("islands.") and config.get(key) is not None}
    survival = {key.split(".", 1)[1]: config[key] for key in COMMON_FIELDS
                if key.startswith("survival.") and config.get(key) is not None}
    if survival:  # a front (decision 045): the stages it replaces and its objectives
        survival["objectives"] = list(algo.stages.objectives)
        chain["survival"] = survival
    return _lists(chain)


def _lists(value):
    """Tuples as lists (a card's TOML arrays are lists), recursively."""
    if isinstance(value, dict):
        return {k: _lists(v) for k, v in value.items()}
    return list(value) if isinstance(value, tuple) else value


def differences(card: dict, chain: dict) -> list[str]:
    """Where the engine's chain differs from the card (the card's keys only, and every
    family's operator); a card without ``[islands]`` means one population."""
    out = [f"{key}: card {card.get(key)!r}, engine {chain[key]!r}"
           for key in ("generations", "population")
           if key in card and card[key] != chain[key]]
    if "generations" not in card:
        out.append("generations: the card gives none")
    for family in ("init", "fitness", "selection", "crossover", "mutation", "simplify",
                   "post"):
        want, got = card.get(family, {}), chain.get(family, {})
        if "operator" not in want:
            out.append(f"{family}: the card names no operator")
        for key, value in want.items():
            if key not in got:
                out.append(f"{family}.{key}: card {value!r}, engine has no such option "
                           f"(operator {got.get('operator')!r})")
            elif got[key] != value:
                out.append(f"{family}.{key}: card {value!r}, engine {got[key]!r}")
    want, got = card.get("islands", {"count": 1}), chain["islands"]
    out += [f"islands.{key}: card {value!r}, engine {got.get(key)!r}"
            for key, value in want.items() if got.get(key) != value]
    want, got = card.get("survival", {}), chain.get("survival", {})
    if bool(want) != bool(got):
        out.append(f"survival: card {want!r}, engine {got!r}")
    out += [f"survival.{key}: card {value!r}, engine {got.get(key)!r}"
            for key, value in want.items() if got and got.get(key) != value]
    return out


@pytest.mark.parametrize("path", CARDS, ids=[p.stem for p in CARDS])
def test_the_engine_builds_the_papers_chain(path):
    card = tomllib.loads(path.read_text())
    assert card["preset"] == path.stem
    assert differences(card, engine_chain(card["preset"])) == []


def test_a_card_catches_a_chain_that_differs():
    """The comparison fails on a chain that misses an option or uses another operator."""
    card = tomllib.loads(CARDS[0].read_text())
    chain = engine_chain(card["preset"])
    changed = {**chain, "crossover": {**chain["crossover"], "operator": "column"}}
    assert any(d.startswith("crossover.operator") for d in differences(card, changed))
    missing = {**chain, "mutation": {"operator": chain["mutation"]["operator"]}}
    assert differences(card, missing)


def test_every_preset_has_a_card():
    assert sorted(p.stem for p in CARDS) == sorted(preset_names())
