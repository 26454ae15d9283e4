"""benchmarks/module_layout.py's import graph: right on a package counted by hand, in the
layers the checkout's tests/repository/test_layers.py names, and, on jaxga itself, every
module in a layer and no import cycle.

Only the :mod:`ast` part is tested (the sources are read, nothing imported); the main
job's hops and the drawing are the benchmark's own run, not the suite's.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def layout():
    """benchmarks/module_layout.py as a module (benchmarks/ is not a package)."""
    spec = importlib.util.spec_from_file_location(
        "module_layout", ROOT / "benchmarks" / "module_layout.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HAND_MADE = {
    # one edge each unless said
    "__init__.py": "from jaxga.api import run\n",  # jaxga -> jaxga.api (a name in it)
    "core/__init__.py": "from .grid import Grid\n",  # jaxga.core -> jaxga.core.grid
    "core/grid.py": "import numpy as np\n\n\nclass Grid:\n    cells = 0\n    side = 0\n",  # none
    "core/paths.py": ("from jaxga.core import grid\n"  # three imports, one edge:
                      "from jaxga.core.grid import Grid\n"  # jaxga.core.paths ->
                      "import jaxga.core.grid\n"),  # jaxga.core.grid
    "engine/__init__.py": "",
    "engine/evolution.py": ("from typing import TYPE_CHECKING\n"
                            "from ..core import paths, Grid\n"  # -> core.paths, -> core
                            "if TYPE_CHECKING:\n"
                            "    from jaxga.api import runs\n"),  # -> api.runs, typing
    "api/__init__.py": "from jaxga.api.runs import run\n",  # jaxga.api -> jaxga.api.runs
    "api/runs.py": ("from jaxga.engine import evolution\n"  # -> engine.evolution
                    "from jaxga.api import runs\n"  # itself: no edge
                    "def run():\n"
                    "    from jaxga.core.paths import Path\n"),  # -> core.paths, function
    "cli/__init__.py": "",
    "cli/run.py": "import os\nfrom jaxga import api\n",  # jaxga.cli.run -> jaxga.api
    "plot.py": "from . import cli\n",  # jaxga.plot -> jaxga.cli
}
"""A package of 11 modules and 11 edges, counted by hand in the comments."""


def _write(root: Path, files: dict[str, str]) -> Path:
    package = root / "jaxga"
    for name, text in files.items():
        (package / name).parent.mkdir(parents=True, exist_ok=True)
        (package / name).write_text(text)
    return package


def test_the_graph_of_a_package_counted_by_hand(layout, tmp_path):
    graph = layout.import_graph(_write(tmp_path, HAND_MADE))
    assert graph["edges"] == [
        ["jaxga", "jaxga.api", "top"],
        ["jaxga.api", "jaxga.api.runs", "top"],
        ["jaxga.api.runs", "jaxga.core.paths", "function"],
        ["jaxga.api.runs", "jaxga.engine.evolution", "top"],
        ["jaxga.cli.run", "jaxga.api", "top"],
        ["jaxga.core", "jaxga.core.grid", "top"],
        ["jaxga.core.paths", "jaxga.core.grid", "top"],
        ["jaxga.engine.evolution", "jaxga.api.runs", "typing"],
        ["jaxga.engine.evolution", "jaxga.core", "top"],
        ["jaxga.engine.evolution", "jaxga.core.paths", "top"],
        ["jaxga.plot", "jaxga.cli", "top"],
    ]
    numbers = layout.summary(graph)
    assert (numbers["modules"], numbers["edges"], numbers["edges_in_functions"],
            numbers["edges_for_type_checkers"], numbers["cycles"]) == (11, 11, 1, 1, 0)
    assert numbers["modules_per_layer"] == {
        "_batching": 0, "core": 3, "maps": 0, "operators": 0, "config": 0, "engine": 2,
        "reference": 0, "api": 2, "tools": 4}
    assert numbers["edges_per_layer_pair"] == {
        "core -> core": 2, "engine -> core": 2, "engine -> api": 1, "api -> core": 1,
        "api -> engine": 1, "api -> api": 1, "tools -> api": 2, "tools -> tools": 1}
    assert numbers["largest_modules"][0] == ["jaxga.core.grid", 6]


def test_a_cycle_is_found_and_a_type_checkers_import_makes_none(layout, tmp_path):
    files = dict(HAND_MADE)  # evolution's import of api.runs, run at import time
    files["engine/evolution.py"] = "from jaxga.api import runs\n"
    numbers = layout.summary(layout.import_graph(_write(tmp_path, files)))
    assert numbers["cycle_groups"] == [["jaxga.api.runs", "jaxga.engine.evolution"]]
    assert layout.cycles("abcde", [("a", "b"), ("b", "c"), ("c", "a"), ("c", "d"),
                                   ("d", "e"), ("e", "d")]) == [["a", "b", "c"], ["d", "e"]]
    assert layout.cycles("abc", [("a", "b"), ("b", "c"), ("a", "c")]) == []


def test_the_layers_are_the_checkouts_own(layout, tmp_path):
    assert layout.read_layers(tmp_path) == layout.LAYERS  # no test_layers.py: the default
    (tmp_path / layout.LAYERS_FILE).parent.mkdir(parents=True)
    (tmp_path / layout.LAYERS_FILE).write_text(
        'import ast\n\nLAYERS = ("core", "engine",\n          "tools")\n"""Bottom to top."""\n')
    assert layout.read_layers(tmp_path) == ("core", "engine", "tools")
    graph = layout.import_graph(_write(tmp_path, HAND_MADE), ("core", "engine", "tools"))
    assert {m: info["layer"] for m, info in graph["modules"].items()
            if info["layer"] != "tools"} == {
        "jaxga.core": "core", "jaxga.core.grid": "core", "jaxga.core.paths": "core",
        "jaxga.engine": "engine", "jaxga.engine.evolution": "engine"}


def test_jaxga_has_every_module_in_a_layer_and_no_import_cycle(layout):
    package = ROOT / "jaxga"
    layers = layout.read_layers(ROOT)
    graph = layout.import_graph(package, layers)
    modules = graph["modules"]
    assert len(modules) == len(list(package.rglob("*.py")))
    for name, info in modules.items():
        folder = Path(info["path"]).parts[1]  # jaxga/<folder>/... or jaxga/<file>.py
        expected = folder if folder in layers else "tools"
        assert info["layer"] == expected, name
        if expected == "tools":
            assert folder in ("cli", "doe") or folder.endswith(".py"), name
    assert all(a in modules and b in modules for a, b, _ in graph["edges"])
    numbers = layout.summary(graph)
    assert numbers["cycles"] == 0, numbers["cycle_groups"]
    assert sum(numbers["modules_per_layer"].values()) == numbers["modules"]
    assert sum(numbers["edges_per_layer_pair"].values()) == numbers["edges"]
