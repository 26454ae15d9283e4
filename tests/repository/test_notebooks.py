"""Every notebook in ``notebooks/`` runs top to bottom, with small settings.

Each notebook reads ``JAXGA_NOTEBOOK_QUICK=1`` in its first code cell and then uses tiny
populations, few generations and few seeds; the kernel shares the suite's persistent
compilation cache. A cell that raises fails the test with the notebook's traceback.
"""

from __future__ import annotations

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

from tests.conftest import CACHE_DIR  # noqa: E402

NOTEBOOKS = sorted((Path(__file__).resolve().parents[2] / "notebooks").glob("*.ipynb"))


def test_every_notebook_is_listed():
    names = [p.stem for p in NOTEBOOKS]
    assert [n[:2] for n in names] == ["01", "02", "03", "04", "05"], names


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path: Path, monkeypatch, tmp_path):
    monkeypatch.setenv("JAXGA_NOTEBOOK_QUICK", "1")
    # The kernel's inline backend turns figures into image/png outputs (checked below);
    # a non-interactive MPLBACKEND such as Agg would suppress them.
    monkeypatch.delenv("MPLBACKEND", raising=False)
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(CACHE_DIR))
    monkeypatch.setenv("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.5")
    book = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        book, timeout=600, kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()
    errors = [o for cell in book.cells if cell.cell_type == "code"
              for o in cell.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors
    # The notebook produced visible results (tables or figures), not just ran.
    outputs = [o for cell in book.cells if cell.cell_type == "code"
               for o in cell.get("outputs", [])]
    assert any(o.get("output_type") == "stream" for o in outputs)
    assert any("image/png" in o.get("data", {}) for o in outputs)
    # the notebook read the variable: its parameter cell reports the quick settings
    first = next(cell for cell in book.cells if cell.cell_type == "code")
    printed = "".join(o.get("text", "") for o in first.get("outputs", []))
    assert "settings: quick (test suite)" in printed
