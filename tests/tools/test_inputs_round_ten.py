"""Round ten of hostile inputs (decision 056): maps of shapes nobody tuned for, and what a
blocked endpoint that no one chose says. The inflation at any radius is tested with the
maps (tests/maps/test_maps.py), a point off a turned ROS map with the frames
(tests/maps/test_frame.py)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from jaxga.api.problem import checked_endpoints
from jaxga.cli import EXIT_BAD_INPUT, main
from jaxga.core.errors import EndpointError
from jaxga.core.grid import Grid
from jaxga.maps import load_map_info


def _refusal(capsys, argv: list[str]) -> str:
    assert main(argv) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "\n" not in err, err
    return err


def test_a_blocked_default_endpoint_says_it_was_not_given(tmp_path, capsys):
    """An ASCII map without S or G: the start nobody gave is the corner (0, 0), blocked
    here; the message says it is the default and how to give one. A start that was given,
    or marked in the file, is only named."""
    path = tmp_path / "nosg.txt"
    path.write_text("..#\n.#.\n#..\n")  # row 0 at the bottom: (0, 0) and (2, 2) blocked
    err = _refusal(capsys, ["optimum", "--map", str(path), "--goal", "2,0"])
    assert err == ("jaxga: bad start or goal: start cell (0, 0) is blocked; no start was "
                   "given and the map marks none (an ASCII map's S): the default is the "
                   "corner (0, 0); give one with --start X,Y (in Python: load_map(..., "
                   "start=(x, y)))")
    err = _refusal(capsys, ["optimum", "--map", str(path), "--start", "1,0"])
    assert err.endswith("goal cell (2, 2) is blocked; no goal was given and the map marks "
                        "none (an ASCII map's G): the default is the corner (W - 1, H - 1); "
                        "give one with --goal X,Y (in Python: load_map(..., goal=(x, y)))")
    err = _refusal(capsys, ["optimum", "--map", str(path), "--start", "0,0", "--goal", "2,0"])
    assert err == "jaxga: bad start or goal: start cell (0, 0) is blocked"
    marked = tmp_path / "marked.txt"
    marked.write_text("..#\n.#G\n#S.\n")
    info = load_map_info(str(marked))
    assert info.defaulted == ()
    assert load_map_info(str(path), start=(1, 0)).defaulted == ("goal",)


def test_a_map_blocked_everywhere_says_so(tmp_path, capsys):
    """A map with no free cell (a 16-bit image read against its own white value, or
    the wrong threshold): the blocked endpoint's message says the whole map is blocked."""
    path = tmp_path / "walls.txt"
    path.write_text("##\n##\n")
    err = _refusal(capsys, ["optimum", "--map", str(path)])
    assert err == "jaxga: bad start or goal: start cell (0, 0) is blocked; every cell of " \
                  "the map is blocked"
    with pytest.raises(EndpointError, match="; every cell of the map is blocked$"):
        checked_endpoints(Grid(blocked=np.ones((3, 4), bool), start=0, goal=11,
                               corner_rule="free"))


def test_a_planners_given_endpoint_is_not_called_a_default(tmp_path):
    """A Planner's map is loaded without endpoints; each plan gives both. A given start
    the inflation blocks is named with the inflation, never as the default corner."""
    import jaxga

    image = np.full((8, 8), 254, np.uint8)
    image[4, 4] = 0  # an obstacle; map cell (4, 3) (y from the bottom) is next to it
    (tmp_path / "m.pgm").write_bytes(b"P5\n8 8\n255\n" + image.tobytes())
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"
                                     "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    planner = jaxga.Planner(str(tmp_path / "m.yaml"), robot_radius=0.1, seeds=2)
    with pytest.raises(EndpointError) as e:
        planner.plan((3, 3), (7, 7))
    message = str(e.value)
    assert message.startswith("start cell (3, 3) is blocked") and "inflation" in message
    assert "default" not in message, message


def test_a_map_the_inflation_blocks_everywhere_says_so(tmp_path, capsys):
    """An inflation wider than the free space: the message says the whole map is
    blocked, by the inflation, and nothing of the start cell's own reasons."""
    image = np.full((6, 6), 254, np.uint8)
    image[2, 2] = 0
    (tmp_path / "m.pgm").write_bytes(b"P5\n6 6\n255\n" + image.tobytes())
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"
                                     "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    err = _refusal(capsys, ["optimum", "--map", str(tmp_path / "m.yaml"),
                            "--robot-radius", "2"])
    assert err.endswith("; every cell of the map is blocked (the inflation, --inflate or "
                        "--robot-radius, covers the free ones)"), err
    assert "within the inflation" not in err and "default" not in err


def test_a_signal_the_moment_a_temporary_file_is_made_removes_it(tmp_path, monkeypatch):
    """The cleanup a signal runs (``remove_temporaries``) finds a write's temporary file
    from the moment it exists: here it runs right after the file is created, as a
    SIGTERM there would, and nothing is left; the write is interrupted, the old file
    whole. (It was registered only after ``mkstemp`` returned, and a signal in between
    left it in the output folder.)"""
    from jaxga.core import files

    target = tmp_path / "o.json"
    target.write_text("old")
    real_open = os.open

    def open_then_signal(path, flags, mode=0o777, **kw):
        fd = real_open(path, flags, mode, **kw)
        if str(path).endswith(".tmp"):
            os.close(fd)
            files.remove_temporaries()  # what interrupts.stop runs before os._exit
            raise KeyboardInterrupt
        return fd

    monkeypatch.setattr(files.os, "open", open_then_signal)
    with pytest.raises(KeyboardInterrupt):
        files.atomic_write_text(target, "new")
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.json"]
    assert target.read_text() == "old" and not files._TEMPORARIES
    files.atomic_write_text(target, "new")  # and a write after it works as before
    assert target.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.json"]


_FULL_DISK_LOCK = """
import resource, signal, sys
from pathlib import Path
from jaxga._runtime import executables
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
folder = Path(sys.argv[1])
executables.directory = lambda: folder
resource.setrlimit(resource.RLIMIT_FSIZE, (0, resource.RLIM_INFINITY))
with executables._compiling_here("k"):
    print("held", (folder / "locks" / "k.lock").exists())
"""


def test_a_lock_file_a_full_disk_refuses_a_word_is_let_go(tmp_path):
    """The store's lock file takes the holder's host and process id; on a disk that
    takes no byte more (here a file size limit of 0) the note is let go and the program
    is compiled as usual: the note's failed write raised again when the file was closed,
    and the run ended with "No space left on device"."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, "-c", _FULL_DISK_LOCK, str(tmp_path / "store")],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(root)})
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "held True"


def test_a_process_that_may_map_too_little_is_refused_in_one_line(monkeypatch):
    """Under ``ulimit -v`` below 2 GiB no run fits (a plan may take half of what the
    process may map, and its base is 1 GiB), and JAX's libraries failed first, in their
    own ways: OpenBLAS looped for ever in its start (SIGTERM could not end it), XLA
    aborted, an ImportError. The command refuses before it imports JAX; the Python API
    when a run is asked for."""
    import resource
    import subprocess
    import sys

    import jaxga
    from jaxga.core.address_space import MIN_ADDRESS_SPACE, address_space_refusal
    from jaxga.core.errors import ParameterError
    from jaxga.core.grid import PLAN_BASE_BYTES

    assert MIN_ADDRESS_SPACE == 2 * PLAN_BASE_BYTES
    _, hard = resource.getrlimit(resource.RLIMIT_AS)

    # the shell sets the limit (a preexec_fn would fork this multithreaded process)
    proc = subprocess.run(["sh", "-c", 'ulimit -v 1500000 && exec "$0" -m jaxga presets',
                           sys.executable], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr == ("jaxga: error: this process may map only 1.43 GiB of memory "
                           "(ulimit -v 1500000 KiB); jaxga needs at least 2 GiB (JAX, its "
                           "libraries and a run at most half of it): raise the limit\n")
    monkeypatch.setattr(resource, "getrlimit", lambda which: (MIN_ADDRESS_SPACE - 1, hard))
    with pytest.raises(ParameterError, match="may map only 2.00 GiB"):
        jaxga.run("sga", "classic_ga_gapp3_20x20", seeds=1, generations=1)
    monkeypatch.setattr(resource, "getrlimit", lambda which: (MIN_ADDRESS_SPACE, hard))
    assert address_space_refusal() is None
    monkeypatch.setattr(resource, "getrlimit",
                        lambda which: (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
    assert address_space_refusal() is None
