"""Round eleven of hostile inputs (decision 057): long-lived processes, statistics and
designs checked against independent references, results across layouts, and every file
jaxga writes read back by another reader."""

from __future__ import annotations

import os
import tempfile

import pytest


def test_a_signal_the_moment_a_temporary_folder_is_made_removes_it(tmp_path, monkeypatch):
    """The cleanup a signal runs finds a temporary folder from the moment it exists: here
    it runs right after the folder is made, as a SIGTERM there would, and nothing is left.
    (``mkdtemp`` made it before it was registered, and a signal in between left it.) A
    folder made without a signal is private and removed by the same cleanup."""
    from jaxga.core import files

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    real_mkdir = os.mkdir

    def mkdir_then_signal(path, mode=0o777, **kw):
        real_mkdir(path, mode, **kw)
        files.remove_temporaries()  # what interrupts.stop runs before os._exit
        raise KeyboardInterrupt

    monkeypatch.setattr(files.os, "mkdir", mkdir_then_signal)
    with pytest.raises(KeyboardInterrupt):
        files.temporary_folder("jaxga-test-")
    monkeypatch.undo()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    assert list(tmp_path.iterdir()) == [] and not files._FOLDERS

    folder = files.temporary_folder("jaxga-test-")
    assert folder.parent == tmp_path and folder.name.startswith("jaxga-test-")
    assert folder.stat().st_mode & 0o777 == 0o700
    (folder / "inside").write_text("x")
    files.remove_temporaries()
    assert list(tmp_path.iterdir()) == [] and not files._FOLDERS
