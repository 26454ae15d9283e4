"""One version: the package's, the one a saved result records, and pyproject.toml's."""

from __future__ import annotations

from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import jaxga
from jaxga._runtime.device_probe import run_environment

ROOT = Path(__file__).resolve().parents[2]


def test_the_version_is_stated_once_and_recorded_as_it_is():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert jaxga.__version__ == project["version"] == run_environment()["jaxga"]
