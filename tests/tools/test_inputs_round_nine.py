"""Round nine of hostile inputs (decision 055): a Moving AI header the size check could not
read, a one-cell path smoothed, a path file's frame of absurd numbers, a coordinator port
another program holds, a preset file that sets one key twice, replan's budget options
beside ``--set``, NumPy scalars for map options, a default endpoint blocked by the
inflation, Pillow's warnings, a checkpoint folder inside jaxga, and a FIFO as the
verdicts file. ``--front-point`` that no point meets is tested with the other front
tests (tests/tools/test_cli.py)."""

from __future__ import annotations

import argparse
import os
import re
import socket
import warnings
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from jaxga._runtime import device_probe, parallel
from jaxga.api.runs import checked_capacity
from jaxga.cli import EXIT_BAD_INPUT, check_outputs, main
from jaxga.cli.replan import MAX_COARSENING, given_budget, recorded_cells
from jaxga.config.presets import load_preset
from jaxga.core.errors import JaxgaError, MapFormatError, ParameterError
from jaxga.maps import load_map

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "jaxga"


# --- maps ----------------------------------------------------------------------------------


@pytest.mark.parametrize("header", ["type octile\nheight 1\nwidth +1000000000000\n",
                                    "\n" * 6 + "type octile\nheight 1\nwidth 1000000000000\n"])
def test_a_moving_ai_header_of_a_huge_map_is_refused_before_any_allocation(tmp_path, header):
    """``+N`` and a header after blank lines escaped the size check, and the parser
    allocated the header's size (931 GiB: a MemoryError traceback)."""
    (tmp_path / "m.map").write_text(header + "map\n.\n")
    with pytest.raises(MapFormatError, match="map 1000000000000 x 1 has 1,000,000,000,000 "
                                             "cells, more than jaxga plans on"):
        load_map(str(tmp_path / "m.map"))


def test_a_moving_ai_body_short_of_its_header_allocates_nothing_first():
    from jaxga.maps.formats import parse_movingai

    with pytest.raises(MapFormatError, match="row has 1 cells but the header says width "
                                             "1000000000"):
        parse_movingai("type octile\nheight 1\nwidth 1000000000\nmap\n.\n")


def test_numpy_scalars_are_numbers_for_the_map_options(tmp_path):
    """``threshold=np.float32(0.5)`` and ``robot_radius=np.float32(0.1)`` were refused as
    not a luminance or not >= 0 metres."""
    image = np.full((4, 6), 255, np.uint8)
    image[1, 2] = 0
    Image.fromarray(image).save(tmp_path / "m.png")
    plain = load_map(str(tmp_path / "m.png"), threshold=0.5).blocked_np()
    for value in (np.float32(0.5), np.array(0.5), np.float64(0.5)):
        np.testing.assert_array_equal(
            load_map(str(tmp_path / "m.png"), threshold=value).blocked_np(), plain)
    office = str(ROOT / "docs" / "examples" / "office.yaml")
    np.testing.assert_array_equal(load_map(office, robot_radius=np.float32(0.1)).blocked_np(),
                                  load_map(office, robot_radius=0.1).blocked_np())
    with pytest.raises(MapFormatError, match="robot radius must be >= 0 metres"):
        load_map(office, robot_radius=np.bool_(True))


def test_a_default_corner_blocked_by_the_inflation_says_so(tmp_path, capsys):
    image = np.full((5, 5), 255, np.uint8)
    image[3, 1] = 0  # an obstacle next to the default start, map cell (0, 0)
    Image.fromarray(image).save(tmp_path / "m.png")
    assert main(["optimum", "--map", str(tmp_path / "m.png"), "--inflate", "1.5"]) \
        == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "start cell (0, 0) is blocked; the cell is free on the map, " \
        "within the inflation of an obstacle (--inflate or --robot-radius)" in err, err


def test_pillow_s_warnings_about_a_damaged_image_are_not_shown(tmp_path):
    (tmp_path / "t.tif").write_bytes(b"II*\x00\x08\x00\x00\x00")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(MapFormatError, match="unreadable image"):
            load_map(str(tmp_path / "t.tif"))
    assert not caught, [str(w.message) for w in caught]


# --- smoothing -------------------------------------------------------------------------------


@pytest.mark.slow  # compiles the smoothing of one path
def test_a_one_cell_path_is_smoothed_as_a_point():
    """start = goal: a path of one cell, whose one segment-less polyline was a gather out
    of range (a traceback after the run's summary)."""
    import jax.numpy as jnp

    from jaxga.smooth import smooth

    grid = load_map("classic_ga_gapp3_20x20", start=(0, 0), goal=(0, 0))
    out = smooth(grid, jnp.array([0], jnp.int32), jnp.int32(1))
    assert float(out.length) == 0.0 and float(out.polyline_length) == 0.0


# --- replan ----------------------------------------------------------------------------------


@pytest.mark.parametrize("coarsen", [1e400, 10 ** 20, 2.9, "2", True, MAX_COARSENING + 1, 0])
def test_a_path_file_s_frame_of_absurd_numbers_is_refused(coarsen):
    """``"coarsen": 1e400`` was an OverflowError traceback, ``2.9`` read as 2, ``"2"`` as
    2 and ``true`` as 1."""
    with pytest.raises(ParameterError, match="f.json: its"):
        recorded_cells([(0, 0), (1, 0)], {"coarsen": coarsen}, None, "f.json")


def test_replan_s_budget_options_and_a_set_of_the_same_key_are_not_two_silent_values():
    """``--generations 20 --set generations=6`` ran 6 generations without a word (20 is
    the default, which gives way to --set); given, the option and --set must agree."""
    def args(**kw):
        return argparse.Namespace(**{"generations": None, "population": None, "set": None,
                                     **kw})

    assert given_budget(args(set=["generations=6"])) == {"generations": 20, "population": 10}
    assert given_budget(args(generations=20, set=["generations=20"]))["generations"] == 20
    assert given_budget(args(population=12)) == {"generations": 20, "population": 12}
    with pytest.raises(ParameterError, match=r"generations is given twice, as 20 "
                                             r"\(--generations\) and 6 \(--set\)"):
        given_budget(args(generations=20, set=["generations=6"]))
    with pytest.raises(ParameterError, match=r"population.size is given twice, as 10 "
                                             r"\(--population\) and 20 \(--set\)"):
        given_budget(args(population=10, set=["population.size=20"]))


# --- configuration ---------------------------------------------------------------------------


@pytest.mark.parametrize("text, where", [
    ('base = "sga"\n"mutation.probability" = 0.2\n[mutation]\nprobability = 0.3\n', ""),
    ('base = "sga"\n[variants.v]\n"mutation.probability" = 0.2\n'
     'mutation = {probability = 0.4}\n', "[variants.v] "),
])
def test_a_preset_file_that_sets_a_key_twice_is_refused(tmp_path, text, where):
    """One key through two spellings: the last one was kept without a word."""
    (tmp_path / "p.toml").write_text(text)
    with pytest.raises(ParameterError,
                       match=rf"p.toml: {re.escape(where)}mutation\.probability is given twice"):
        load_preset(str(tmp_path / "p.toml"))


def test_a_preset_file_that_sets_a_key_twice_alike_is_read(tmp_path):
    (tmp_path / "p.toml").write_text('base = "sga"\n"mutation.probability" = 0.3\n'
                                     '[mutation]\nprobability = 0.3\n')
    assert load_preset(str(tmp_path / "p.toml"))["mutation.probability"] == 0.3


def test_a_population_capacity_beyond_a_program_names_itself():
    with pytest.raises(ParameterError, match="population_capacity 1000000000 is above the "
                                             "largest population a program holds"):
        checked_capacity([load_preset("sga")], 10 ** 9)


# --- processes, files and the environment ----------------------------------------------------


def test_a_coordinator_port_another_program_holds_is_one_line():
    """A port in use was a C++ log line and a JaxRuntimeError traceback; a port past
    65535 waited out the timeout, then blamed the other processes."""
    with socket.create_server(("", 0)) as held:
        port = held.getsockname()[1]
        with pytest.raises(JaxgaError, match=f"process 0 cannot listen at 127.0.0.1:{port}: "
                                             f"port {port} is taken"):
            parallel.initialize(f"127.0.0.1:{port}", 2, 0, timeout=5)
    with pytest.raises(JaxgaError, match="a port from 1 to 65535"):
        parallel.initialize("127.0.0.1:99999", 2, 0, timeout=5)


def test_the_process_timeout_variable_is_written_in_ascii_digits(monkeypatch):
    monkeypatch.setenv(parallel.ENV_PROCESS_TIMEOUT, "\u0663")
    args = argparse.Namespace(devices=None, coordinator=None, num_processes=None,
                              process_id=None, process_timeout=None)
    with pytest.raises(JaxgaError, match="JAXGA_PROCESS_TIMEOUT must be a number in ASCII "
                                         "digits"):
        parallel.configure_from_args(args)


def test_a_checkpoint_folder_inside_jaxga_is_refused(tmp_path):
    args = argparse.Namespace(json=None, plot=None, path_out=None,
                              checkpoint=str(PACKAGE / "maps"), map="classic_ga_gapp3_20x20",
                              preset="sga")
    with pytest.raises(JaxgaError, match="cannot use --checkpoint .*inside jaxga's own folder"):
        check_outputs(args)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_as_the_verdicts_file_is_no_verdict(tmp_path, monkeypatch):
    """Reading it blocked a GPU run before its first computation."""
    os.mkfifo(tmp_path / "fifo")
    monkeypatch.setenv(device_probe.VERDICTS_ENV, str(tmp_path / "fifo"))
    assert device_probe._remembered() == {}
