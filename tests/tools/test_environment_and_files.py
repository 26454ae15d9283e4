"""Round eight of hostile inputs (decision 054): JAX's environment variables, outputs that
are streams, links or long names, ROS raw maps with ``negate``, path files in another
frame, the cache folder's ``~``, empty preset lists, and numbers that Python reads but
no one writes (``1_0``)."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from jaxga._runtime import compilation_cache, parallel
from jaxga.cli import EXIT_BAD_INPUT, main
from jaxga.core.errors import CacheWarning, JaxgaError, MapFormatError, ParameterError
from jaxga.core.files import atomic_write_text, check_outputs, remove_stale_temporaries
from jaxga.core.numerals import ascii_float, ascii_int, yaml_number
from jaxga.export import read_path, write_path
from jaxga.jax_environment import jax_refusal
from jaxga.maps.formats import parse_movingai
from jaxga.maps.ros import RosMap, occupancy
from jaxga.maps.scenarios import parse_scen

ROOT = Path(__file__).resolve().parents[2]


# --- JAX's own environment variables -----------------------------------------------------


def _jaxga(code_or_args: list[str], **env: str) -> subprocess.CompletedProcess:
    environ = {**os.environ, "PYTHONPATH": str(ROOT), **env}
    return subprocess.run([sys.executable, *code_or_args], cwd=ROOT, env=environ,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.slow  # starts processes (a second each: JAX's import)
@pytest.mark.parametrize("variable, value", [("JAX_ENABLE_X64", "maybe"),
                                             ("JAX_NUM_CPU_DEVICES", "many")])
def test_a_jax_variable_jax_refuses_is_one_line_from_the_command(variable, value):
    proc = _jaxga(["-m", "jaxga", "maps"], **{variable: value})
    assert proc.returncode == EXIT_BAD_INPUT, proc.stderr
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("jaxga: error: JAX refuses its environment")
    assert f"{variable}={value!r}" in lines[0]


@pytest.mark.slow  # starts processes (a second each: JAX's import)
def test_a_jax_variable_jax_refuses_is_named_to_a_python_program():
    proc = _jaxga(["-c", "import jaxga"], JAX_ENABLE_X64="maybe")
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1].startswith(
        "ValueError: JAX refuses its environment")
    assert "JAX_ENABLE_X64='maybe'" in proc.stderr


def test_the_refusal_names_the_variable_jax_names_and_no_other():
    flag = ValueError('Invalid value "many" for JAX flag jax_num_cpu_devices')
    env = {"JAX_NUM_CPU_DEVICES": "many", "JAX_PLATFORMS": "cpu", "HOME": "/root"}
    assert jax_refusal(flag, env).endswith("JAX_NUM_CPU_DEVICES='many'; correct or unset it")
    truth = ValueError("invalid truth value 'maybe' for environment 'JAX_ENABLE_X64'")
    env = {"JAX_ENABLE_X64": "maybe", "JAX_DISABLE_JIT": "0"}
    assert "JAX_ENABLE_X64='maybe'" in jax_refusal(truth, env)
    assert "JAX_DISABLE_JIT" not in jax_refusal(truth, env)
    # an error that names no variable (numpy's ABI, a broken install) blames none
    assert jax_refusal(ValueError("numpy.dtype size changed"), env) is None
    assert jax_refusal(ValueError("x"), {}) is None


# --- outputs: streams, links, long names -----------------------------------------------


@pytest.mark.parametrize("name", ["/dev/stdout", "/dev/stderr", "/dev/fd/1",
                                  "/proc/self/fd/1"])
def test_an_output_that_is_a_stream_is_refused_before_the_work(name):
    """Refused whatever the stream is: a terminal or a pipe is no regular file, and a
    file it is redirected to (``2>> log``) would be replaced by the write's rename."""
    with pytest.raises(JaxgaError, match=STREAM):
        check_outputs({"--json": name})


STREAM = "(a stream or device, not a file|it exists and is not a regular file)"


@pytest.mark.slow  # starts processes (a second each: JAX's import)
def test_a_stream_redirected_to_a_file_is_refused_and_the_file_kept(tmp_path):
    """``--json /dev/stdout >> log.txt``: /dev/stdout leads to log.txt, a regular file,
    which the write would have replaced, losing what it held."""
    log = tmp_path / "log.txt"
    log.write_text("earlier run\n")
    (tmp_path / "out.csv").symlink_to("/dev/stdout")  # a path file's name, leading to it
    code = ("import sys\nimport numpy as np\nfrom jaxga.core.files import check_outputs\n"
            "from jaxga.export import write_path\n"
            "for write in (lambda: check_outputs({'--json': '/dev/stdout'}),\n"
            f"              lambda: write_path({str(tmp_path / 'out.csv')!r}, np.zeros((2, 2)))):\n"
            "    try:\n        write()\n"
            "    except Exception as e:\n        print(e, file=sys.stderr)\n")
    with open(log, "a") as out:
        proc = subprocess.run([sys.executable, "-c", code], stdout=out, text=True,
                              stderr=subprocess.PIPE, env={**os.environ, "PYTHONPATH": str(ROOT)},
                              timeout=120)
    said = proc.stderr.strip().splitlines()
    assert len(said) == 2, proc.stderr  # the command's check and the Python API's write
    assert all("names /dev/stdout, a stream or device, not a file" in line for line in said)
    assert log.read_text() == "earlier run\n"


def test_a_link_to_a_stream_is_a_stream(tmp_path):
    (tmp_path / "out.json").symlink_to("/dev/stdout")
    with pytest.raises(JaxgaError, match=STREAM):
        check_outputs({"--json": tmp_path / "out.json"})


def test_a_file_in_a_folder_of_dev_is_a_file():
    shm = Path("/dev/shm")
    if not shm.is_dir() or not os.access(shm, os.W_OK):
        pytest.skip("no writable /dev/shm here")
    check_outputs({"--json": shm / "jaxga-test-out.json"})  # accepted: a tmpfs file


def test_a_link_is_checked_where_its_file_is(tmp_path):
    (tmp_path / "dangling.json").symlink_to(tmp_path / "missing" / "x.json")
    with pytest.raises(JaxgaError, match=r"a link to .*missing/x\.json\): folder .* does "
                       "not exist"):
        check_outputs({"--json": tmp_path / "dangling.json"})
    (tmp_path / "real").mkdir()
    (tmp_path / "good.json").symlink_to(tmp_path / "real" / "x.json")
    check_outputs({"--json": tmp_path / "good.json"})
    atomic_write_text(tmp_path / "good.json", "{}")  # written where the link points
    assert (tmp_path / "good.json").is_symlink()
    assert (tmp_path / "real" / "x.json").read_text() == "{}"


def test_a_name_of_255_bytes_is_written_and_one_of_256_refused_at_once(tmp_path):
    longest = tmp_path / ("a" * 250 + ".json")
    check_outputs({"--json": longest})
    atomic_write_text(longest, "{}")
    assert longest.read_text() == "{}"
    assert [p.name for p in tmp_path.iterdir()] == [longest.name]  # no temporary left
    assert remove_stale_temporaries(longest) == []
    wide = tmp_path / ("é" * 126 + ".txt")  # 256 bytes in UTF-8
    with pytest.raises(JaxgaError, match="its name has 256 bytes, more than the 255"):
        check_outputs({"--plot": wide})


@pytest.mark.slow  # starts processes (a second each: JAX's import)
@pytest.mark.parametrize("argv, status", [(["maps"], 0), (["presets", "--show", "sga"], 0),
                                          (["presets", "--show", "no_such_preset"], 2)])
@pytest.mark.parametrize("both", [False, True], ids=["stdout", "stdout-and-stderr"])
def test_a_reader_that_leaves_is_no_error(argv, status, both):
    """``jaxga maps | head -1`` (and ``2>&1 | head``): the reader is gone before the
    output ends; the command ends with its own status, without a word about the pipe."""
    read, write = os.pipe()
    os.close(read)  # the reader left at once: every write meets a broken pipe
    try:
        proc = subprocess.run([sys.executable, "-m", "jaxga", *argv], cwd=ROOT, stdout=write,
                              stderr=write if both else subprocess.PIPE, text=True,
                              timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})
    finally:
        os.close(write)
    assert proc.returncode == status
    if not both:
        assert "pipe" not in proc.stderr.lower()
        assert (proc.stderr == "") == (status == 0)


# --- ROS raw maps, path files ----------------------------------------------------------


def test_a_raw_map_is_its_pixel_values_negate_or_not():
    """nav2_map_server's map_io.cpp: raw mode reads the pixel value as the occupancy and
    ignores negate (ROS 1 negated it first; decisions 051 and 054 follow ROS 2)."""
    pixels = np.array([[0, 37, 100, 101, 255]], np.uint8)
    for negate in (False, True):
        meta = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), mode="raw",
                      negate=negate)
        assert occupancy(pixels, meta).tolist() == [[0, 37, 100, -1, -1]]


def test_negate_still_swaps_black_and_white_in_trinary_mode():
    pixels = np.array([[0, 254]], np.uint8)
    plain = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0))
    negated = RosMap(image=None, resolution=1.0, origin=(0.0, 0.0, 0.0), negate=True)
    assert occupancy(pixels, plain).tolist() == [[100, 0]]
    assert occupancy(pixels, negated).tolist() == [[0, 100]]


@pytest.fixture
def path_yaml(tmp_path) -> str:
    write_path(tmp_path / "p.yaml", np.array([[0.0, 0.0], [1.0, 1.0]]))
    return (tmp_path / "p.yaml").read_text()


def test_a_path_file_reads_back_what_was_written(tmp_path, path_yaml):
    assert read_path(tmp_path / "p.yaml").tolist() == [[0.0, 0.0], [1.0, 1.0]]
    # ROS 1's '/map', and 1e-05 (a string in YAML 1.1, a number to yaml-cpp)
    (tmp_path / "ros1.yaml").write_text(path_yaml.replace("frame_id: map", "frame_id: /map")
                                        .replace("x: 1.0", "x: 1e-05"))
    assert read_path(tmp_path / "ros1.yaml").tolist() == [[0.0, 0.0], [1e-05, 1.0]]
    (tmp_path / "p.csv").write_text("x,y\n1,2\n3.5,-4e-1\n")
    assert read_path(tmp_path / "p.csv").tolist() == [[1.0, 2.0], [3.5, -0.4]]


@pytest.mark.parametrize("change, why", [
    (("frame_id: map\nposes", "frame_id: odom\nposes"), "the path is in the frame 'odom'"),
    (("- header:\n    frame_id: map", "- header:\n    frame_id: base_link"),
     "pose 0 is in the frame 'base_link'"),
    (("x: 1.0", "x: true"), "x and y are numbers, got True"),
    (("x: 1.0", "x: 'one'"), "x and y are numbers, got 'one'"),
    (("x: 1.0", "x: 1.0\n      x: 2.0"), "the key 'x' is given twice"),
    # a number yaml-cpp would not read, in quotes; an integer beyond a float (a traceback)
    (("x: 1.0", "x: '1_0'"), "x and y are numbers, got '1_0'"),
    (("x: 1.0", "x: 1" + "0" * 400), "int too large to convert to float"),
])
def test_a_path_file_in_another_frame_or_with_loose_values_is_refused(tmp_path, path_yaml,
                                                                      change, why):
    assert change[0] in path_yaml
    (tmp_path / "bad.yaml").write_text(path_yaml.replace(*change, 1))
    with pytest.raises(ParameterError, match=why):
        read_path(tmp_path / "bad.yaml")


@pytest.mark.parametrize("rows", ["1_0,2", "1,2\u20283,4", "\u0663,4", "1,2\u00a0"])
def test_a_csv_path_holds_numbers_in_ascii(tmp_path, rows):
    (tmp_path / "p.csv").write_text(f"x,y\n{rows}\n", encoding="utf-8")
    with pytest.raises(ParameterError, match="not a number in ASCII digits"):
        read_path(tmp_path / "p.csv")


# --- the cache folder, preset lists, numbers -------------------------------------------


def test_the_cache_folder_expands_home_and_variables(monkeypatch, tmp_path):
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("JAXGA_TEST_BASE", str(tmp_path / "base"))
    monkeypatch.setenv(compilation_cache.ENV_VAR, "~/cache")
    assert compilation_cache.env_directory() == str(tmp_path / "cache")
    monkeypatch.setenv(compilation_cache.ENV_VAR, "$JAXGA_TEST_BASE/c")
    assert compilation_cache.env_directory() == str(tmp_path / "base" / "c")
    monkeypatch.setenv(compilation_cache.ENV_VAR, "")
    assert compilation_cache.env_directory() == ""  # empty: no folder
    try:  # configure's own folder too
        assert compilation_cache.configure("~/mine", jax_cache=False) == str(tmp_path / "mine")
        assert (tmp_path / "mine").is_dir()
    finally:
        compilation_cache._configured.clear()  # back to the suite's folder


def test_a_cache_folder_naming_an_unset_variable_is_refused(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("JAXGA_NO_SUCH_VARIABLE", raising=False)
    assert "the environment variable $JAXGA_NO_SUCH_VARIABLE, which is not set" in \
        compilation_cache.cache_problem("$JAXGA_NO_SUCH_VARIABLE/c")
    assert "home folder ~jaxga_no_such_user" in \
        compilation_cache.cache_problem("~jaxga_no_such_user/c")
    assert list(tmp_path.iterdir()) == []  # no folder named '$...' or '~...' made


def test_configure_with_an_unset_variable_warns_and_uses_no_folder(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(compilation_cache, "_WARNED", [])
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert compilation_cache.configure("${JAXGA_NO_SUCH_VARIABLE}/c",
                                           jax_cache=False) is None
    assert [w.category for w in seen] == [CacheWarning]
    assert list(tmp_path.iterdir()) == []
    compilation_cache._configured.clear()  # back to the suite's folder


@pytest.mark.parametrize("command", [["warmup", "--sizes", "20"], ["doctor"]])
@pytest.mark.parametrize("presets", ["", ","])
def test_an_empty_preset_list_is_refused(command, presets, capsys):
    assert main([*command, "--presets", presets]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"jaxga: error: --presets names no preset (got {presets!r}): leave it out "
                   "for every built-in preset"]


@pytest.mark.parametrize("text", ["1_0", "\u0663", "1\u00a0", "0x10", "", "1.5"])
def test_an_integer_is_written_in_ascii_digits(text):
    with pytest.raises(ValueError):
        ascii_int(text)


def test_ascii_numbers_read_as_python_would():
    assert ascii_int(" -12\t") == -12 and ascii_float("2.5e-1") == 0.25
    assert np.isnan(ascii_float("nan")) and ascii_float("-inf") == -np.inf
    for text in ("7_0.5", "\u0663.5", "1.5\u00a0"):
        with pytest.raises(ValueError):
            ascii_float(text)


def test_a_yaml_number_is_read_as_yaml_cpp_reads_one():
    assert yaml_number(3) == 3.0 and yaml_number(0.5) == 0.5
    assert yaml_number("5e-2") == 0.05 and yaml_number(" -1e-05 ") == -1e-05
    for value in ("1_0", "\u0663", "0.05\u00a0", "five", True, None, [1.0]):
        with pytest.raises(TypeError):
            yaml_number(value)
    with pytest.raises(OverflowError):
        yaml_number(10 ** 400)


@pytest.mark.parametrize("field", ["1_0", "\u0663"])
def test_a_scenario_field_in_other_digits_is_refused(field):
    text = f"version 1\n0\tm.map\t32\t32\t{field}\t0\t5\t5\t7.0\n"
    with pytest.raises(MapFormatError, match="line 2: non-numeric field"):
        parse_scen(text)
    assert parse_scen(text.replace(field, "10"))[0].start == (10, 31)


def test_a_moving_ai_map_holds_ascii_numbers_and_spaces():
    good = "type octile\nheight 1\nwidth 2\nmap\n..\t\n"
    assert parse_movingai(good).shape == (1, 2)
    with pytest.raises(MapFormatError, match="height must be a positive integer, got '1_0'"):
        parse_movingai(good.replace("height 1", "height 1_0"))
    with pytest.raises(MapFormatError, match="row has 3 cells"):
        parse_movingai(good.replace("..\t", "..\u00a0"))


def test_an_integer_environment_variable_is_written_in_ascii(monkeypatch):
    monkeypatch.setenv("JAXGA_TEST_INT", "1_0")
    with pytest.raises(JaxgaError, match="JAXGA_TEST_INT must be an integer in ASCII"):
        parallel.env_int("JAXGA_TEST_INT")
    monkeypatch.setenv("JAXGA_TEST_INT", "12")
    assert parallel.env_int("JAXGA_TEST_INT") == 12
