"""Every reference in the repository is one a reader can open: a paper (author, equation,
section), a docs page or a decision note. The working note the project started from and
its issue tracker live outside the repository, so their section and issue numbers are
refused wherever a reader looks: code, tests, benchmarks, docs, notebooks, presets."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
UNREADABLE = re.compile(r"\b(?:" + "SP" + r"EC\s*§?\s*\d|" + "iss" + r"ues?\s*#?\s*\d)",
                        re.IGNORECASE)
SUFFIXES = {".py", ".md", ".toml", ".ipynb", ".yml", ".yaml", ".txt", ".cfg"}
SKIPPED = ("benchmarks/history/",)  # measurements as recorded, not prose


def _tracked() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [ROOT / f for f in out if Path(f).suffix in SUFFIXES and not f.startswith(SKIPPED)]


def test_no_reference_to_a_document_outside_the_repository():
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()}"
             for p in _tracked() if p.exists()
             for i, line in enumerate(p.read_text(errors="replace").splitlines(), 1)
             if UNREADABLE.search(line)]
    assert not found, "cite the paper, a docs page or a decision note:\n" + "\n".join(found)


@pytest.mark.parametrize(("line", "refused"), [
    ("see " + "SP" + "EC 3", True), ("(" + "sp" + "ec §4)", True), ("Is" + "sue 41, item 3", True),
    ("is" + "sues #12", True), ("AGACD eq. 30", False), ("decision 028", False),
    ("shape_spec(grid)", False), ("the issue of memory", False),
])
def test_the_pattern_refuses_what_it_should(line, refused):
    assert bool(UNREADABLE.search(line)) is refused
