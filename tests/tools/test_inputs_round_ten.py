"""Round ten of hostile inputs (decision 056): maps of shapes nobody tuned for, and what a
blocked endpoint that no one chose says. The inflation at any radius is tested with the
maps (tests/maps/test_maps.py), a point off a turned ROS map with the frames
(tests/maps/test_frame.py)."""

from __future__ import annotations

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
