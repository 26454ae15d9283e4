"""The layers: dependencies point one way, no private names cross modules, imports at the top.

Read from the source with :mod:`ast` (nothing is imported), against the order of the
folder tree of docs/architecture.md: a module imports only from its own folder and the
folders before it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "jaxga"

LAYERS = ("_batching", "core", "maps", "operators", "config", "engine", "reference", "_runtime",
          "api", "tools")
"""Bottom to top; the modules directly in ``jaxga/`` and the tool packages are the tools."""

TOOL_PACKAGES = ("cli", "doe")
"""Folders of ``jaxga/`` that belong to the tools layer: the command line (one module per
command) and the designed experiments (design, fit, checkpoint, confirmation)."""

DEFERRED = ("matplotlib", "scipy", "jax._src", "PIL")
"""Imports that may sit inside a function: heavy (Pillow's import is a tenth of a second,
paid only where an image is read), or JAX internals needed on one path only."""


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module: str) -> str | None:
    """The layer of a ``jaxga`` module; None for the package itself (it re-exports)."""
    parts = module.split(".")
    if parts[0] != "jaxga" or len(parts) == 1:
        return None
    return parts[1] if parts[1] in LAYERS else "tools"


def imports(source: str, module: str, is_package: bool):
    """``(target module, imported names, line, inside a function)`` of every import."""
    tree = ast.parse(source)
    in_function = {id(node) for fn in ast.walk(tree)
                   if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef))
                   for node in ast.walk(fn)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, [], node.lineno, id(node) in in_function
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module
                base = module.split(".")[: len(module.split(".")) - node.level + is_package]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [alias.name for alias in node.names]
            submodules = target in ("jaxga", *(f"jaxga.{x}" for x in LAYERS))
            if submodules:  # `from jaxga.operators import crossover`: the submodule
                for name in names:
                    yield f"{target}.{name}", [], node.lineno, id(node) in in_function
            else:
                yield target, names, node.lineno, id(node) in in_function


def violations(source: str, module: str, is_package: bool = False) -> list[str]:
    """What ``source`` (module ``module``) breaks of the three rules."""
    out = []
    here = layer(module)
    for target, names, line, inside in imports(source, module, is_package):
        where = f"{module}:{line}"
        there = layer(target)
        if here is not None and there is not None \
                and LAYERS.index(there) > LAYERS.index(here):
            out.append(f"{where} imports {target} from a layer above ({there} > {here})")
        if target.startswith("jaxga") and target != module:
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private:
                out.append(f"{where} imports private {', '.join(private)} from {target}")
        if inside and not target.startswith(DEFERRED):
            out.append(f"{where} imports {target} inside a function")
    return out


SOURCES = sorted(PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_module_keeps_the_layer_rules(path):
    assert violations(path.read_text(), module_name(path), path.name == "__init__.py") == []


def test_every_folder_is_a_layer():
    folders = {p.name for p in PACKAGE.iterdir()
               if p.is_dir() and (p / "__init__.py").exists()}
    assert folders == (set(LAYERS) - {"tools"}) | set(TOOL_PACKAGES)


@pytest.mark.parametrize(("module", "source", "expected"), [
    ("jaxga.core.paths", "from jaxga.engine import build\n", "from a layer above"),
    ("jaxga.core.paths", "from jaxga.operators import crossover\n", "from a layer above"),
    ("jaxga.operators.init", "def f():\n    from jaxga.config import registry\n",
     "from a layer above"),
    ("jaxga.doe", "from jaxga.api.runs import _load\n", "imports private _load"),
    ("jaxga.doe", "def f():\n    from jaxga.api import run\n", "inside a function"),
    ("jaxga.core.grid", "from ..engine import build\n", "from a layer above"),
    ("jaxga.operators.crossover", "from jaxga.operators.init import _check_capacity\n",
     "imports private _check_capacity"),
])
def test_the_rules_catch_a_breach(module, source, expected):
    found = violations(source, module)
    assert found and expected in found[0]


@pytest.mark.parametrize(("module", "source"), [
    ("jaxga.engine.evolution", "from jaxga.operators import crossover as cx\n"),
    ("jaxga.plot", "def f():\n    import matplotlib.pyplot as plt\n"),
    ("jaxga.api.runs", "from jaxga._runtime.programs import compiled_programs\n"),
])
def test_the_rules_accept_what_is_allowed(module, source):
    assert violations(source, module) == []
