"""Faults a careless user or script produces: interrupts, outputs that would destroy
something, writes that fail, caches that cannot be used.

Interrupts run the real console script in a subprocess (a signal handler is a
process-wide thing); the rest run :func:`jaxga.cli.main` in-process. The map-input cases
(a scenario of another map, a coarsening that merges the endpoints, options without
effect, images that disagree with their header, unbounded files) are in
``test_maps.py`` / ``test_cli.py`` beside the loaders they check.
"""

from __future__ import annotations

import errno
import json
import os
import re
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from jaxga import cli
from jaxga.cli import entry as cli_main
from jaxga.cli import main
from jaxga.cli import run as cli_run
from jaxga.core import files
from jaxga.core.errors import JaxgaError
from jaxga.core.files import atomic_write_text, check_outputs

EXIT_BAD_INPUT = 2
RUN = ["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seeds", "2",
       "--generations", "3", "--quiet"]


def _start(tmp_path: Path, argv: list[str]) -> subprocess.Popen:
    """The console script on ``argv`` with an empty compilation cache of its own, so that
    it compiles (the longest phase, spent in XLA's native code)."""
    env = dict(os.environ, JAXGA_CACHE_DIR=str(tmp_path / "cache"), PYTHONFAULTHANDLER="")
    return subprocess.Popen([sys.executable, "-m", "jaxga.cli", *argv], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for(proc: subprocess.Popen, words: str, timeout: float = 120.0) -> list[str]:
    """stderr lines up to and including the first that contains ``words``."""
    seen: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        seen.append(line)
        if words in line:
            return seen
    proc.kill()
    pytest.fail(f"never printed {words!r}: {''.join(seen)}")


@pytest.mark.parametrize("signum, code, word", [(signal.SIGINT, 130, "interrupted"),
                                                 (signal.SIGTERM, 143, "terminated"),
                                                 (signal.SIGHUP, 129, "hung up")])
def test_a_signal_during_compilation_ends_the_run_at_once(tmp_path, signum, code, word):
    """Ctrl-C or kill while XLA compiles: exit 130 / 143 within seconds, one line, no core
    dump, the previous results file whole and no temporary file beside it."""
    previous = tmp_path / "run.json"
    previous.write_text('{"previous": true}\n')
    proc = _start(tmp_path, [*RUN[:-1], "--json", str(previous)])
    _wait_for(proc, "compile")  # the progress line of a compilation over 2 s
    sent = time.monotonic()
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    waited = time.monotonic() - sent
    assert proc.returncode == code, err
    assert waited < 10, waited
    assert err.strip().splitlines()[-1] == f"jaxga: {word}"
    assert "Traceback" not in err and "Fatal Python error" not in err
    assert json.loads(previous.read_text()) == {"previous": True}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache", "run.json"]


def test_outputs_that_would_destroy_an_input_or_each_other_are_refused(tmp_path, capsys,
                                                                         monkeypatch):
    """--json naming the map, --json and --plot naming one file, --path-out over the path
    JSON replan reads, a preset file as --json: refused before any work, inputs intact."""
    import jaxga.api

    monkeypatch.setattr(jaxga.api, "run", lambda *a, **k: pytest.fail("the run started"))
    grid = tmp_path / "lab.txt"
    grid.write_text("S...\n.##.\n...G\n")
    preset = tmp_path / "mine.toml"
    preset.write_text('base = "sga"\n')
    cases = [
        (["run", "--preset", "sga", "--map", str(grid), "--json", str(grid)], "the map"),
        (["run", "--preset", "sga", "--map", str(grid), "--json", str(tmp_path / "a.png"),
          "--plot", str(tmp_path / "a.png")], "--json names the same file"),
        (["run", "--preset", str(preset), "--map", str(grid), "--json", str(preset)],
         "the preset file"),
        (["run", "--preset", "sga", "--map", str(grid), "--json",
          str(tmp_path / "x" / ".." / "lab.txt")], "the map"),
    ]
    for argv, words in cases:
        rc = main(argv)
        err = capsys.readouterr().err.strip()
        assert rc == EXIT_BAD_INPUT and words in err and "\n" not in err, (argv, err)
    assert grid.read_text() == "S...\n.##.\n...G\n"
    assert preset.read_text() == 'base = "sga"\n'
    assert not (tmp_path / "a.png").exists()


def test_a_ros_maps_image_and_a_hard_link_count_as_the_input(tmp_path):
    image = tmp_path / "office.pgm"
    image.write_bytes(b"P5\n2 2\n255\n" + bytes([254, 0, 254, 254]))
    yaml_file = tmp_path / "office.yaml"
    yaml_file.write_text("image: office.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    os.link(yaml_file, tmp_path / "same.yaml")
    args = cli.build_parser().parse_args(
        ["run", "--preset", "sga", "--map", str(yaml_file), "--plot", str(image)])
    with pytest.raises(JaxgaError, match="the map's image"):
        cli.check_outputs(args)
    args = cli.build_parser().parse_args(
        ["run", "--preset", "sga", "--map", str(yaml_file), "--json",
         str(tmp_path / "same.yaml")])
    with pytest.raises(JaxgaError, match="it is the map"):
        cli.check_outputs(args)


def test_an_output_that_cannot_be_written_is_refused_before_the_work(tmp_path):
    (tmp_path / "folder").mkdir()
    with pytest.raises(JaxgaError, match="it is a folder"):
        check_outputs({"--json": tmp_path / "folder"})
    with pytest.raises(JaxgaError, match="does not exist"):
        check_outputs({"--plot": tmp_path / "no" / "a.png"})
    if Path("/proc/self").is_dir():  # a folder that takes no new file, even for root
        with pytest.raises(JaxgaError, match="not writable"):
            check_outputs({"--plot": "/proc/jaxga.png"})
    check_outputs({"--json": tmp_path / "fine.json", "--plot": None})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"]  # the probe is gone


def test_a_full_disk_leaves_the_previous_file_whole_and_names_it(tmp_path, monkeypatch,
                                                                 capsys):
    """ENOSPC while the results are written (simulated at the flush to disk): exit 2, one
    line naming the file, the previous file parses as before, no temporary file left."""
    out = tmp_path / "optima.json"
    out.write_text('{"previous": true}\n')

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files.os, "fsync", full)
    rc = main(["optimum", "--map", "classic_ga_gapp3_20x20", "--json", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_BAD_INPUT and "\n" not in err
    assert str(out) in err and "no space left" in err
    assert json.loads(out.read_text()) == {"previous": True}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["optima.json"]


def test_an_atomic_write_that_fails_midway_keeps_the_old_file(tmp_path):
    target = tmp_path / "plot.png"
    target.write_bytes(b"old")

    def broken(f) -> None:
        f.write(b"half")
        raise RuntimeError("the figure could not be drawn")

    with pytest.raises(RuntimeError):
        files.atomic_write(target, broken, binary=True)
    assert target.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["plot.png"]
    atomic_write_text(target, "new")
    assert target.read_text() == "new"


def test_a_written_file_has_the_permissions_open_would_give_it(tmp_path):
    """A new output gets 0666 less the umask (not the temporary file's private 0600);
    a replaced one keeps its own mode."""
    old = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "new.json", "{}")
        kept = tmp_path / "kept.json"
        kept.write_text("old")
        kept.chmod(0o640)
        atomic_write_text(kept, "new")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "new.json").stat().st_mode) == 0o644
    assert stat.S_IMODE(kept.stat().st_mode) == 0o640


def test_an_unusable_cache_folder_is_one_warning_line_and_the_command_goes_on(
        tmp_path, capsys, monkeypatch):
    """$JAXGA_CACHE_DIR naming a file: one jaxga line naming it, and the command goes on
    (the run itself replaced by a stand-in: only the cache set-up before it is checked)."""
    from jaxga._runtime import compilation_cache

    blocker = tmp_path / "not-a-folder"
    blocker.write_text("")
    monkeypatch.setenv("JAXGA_CACHE_DIR", str(blocker))
    monkeypatch.setattr(compilation_cache, "_WARNED", [])
    monkeypatch.setattr(cli_run, "cmd_run", lambda args: print("the run goes on") or 0)
    rc = main(RUN)
    out, err = capsys.readouterr()
    assert rc == 0 and out == "the run goes on\n"
    assert err.strip().splitlines() == [
        f"jaxga: warning: the compilation cache {blocker} (JAXGA_CACHE_DIR) cannot be used "
        f"({os.strerror(errno.EEXIST)}): compiling without it"], err


def test_a_value_of_thousands_of_characters_is_shortened_in_its_one_line_refusal(capsys):
    """A hostile --set value or option argument: still one line, a few hundred characters,
    naming the key and how much was left out (the value, not a traceback or a 10 kB line)."""
    huge = "9" * 3000
    assert main(["optimum", "--map", "classic_ga_gapp3_20x20", "--preset", "iga_zhu",
                 "--set", f"fitness.omega={huge}"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and len(err) < 600, err
    assert err.startswith("jaxga: error: --set 'fitness.omega=999")
    left_out = len(f"'fitness.omega={huge}':") - 210  # the word: first 150, last 60 kept
    assert f"...[{left_out:,} characters]..." in err
    assert err.endswith("fitness.omega must be finite, got an integer of about 3,001 digits\n")
    with pytest.raises(SystemExit) as info:  # argparse's own refusal
        main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seeds",
              "q" * 3000])
    err = capsys.readouterr().err
    assert info.value.code == EXIT_BAD_INPUT and err.count("\n") == 1 and len(err) < 600, err
    assert "invalid int value" in err and "...[2,792 characters]..." in err  # 'q...q' cut


def test_shortened_keeps_words_up_to_the_limit_and_cuts_longer_ones():
    from jaxga.cli.parser import LONGEST_LINE, LONGEST_WORD, shortened

    kept = "a " + "x" * LONGEST_WORD + " b"
    assert shortened(kept) == kept
    word = "y" * 150 + "z" * 91 + "w" * 60
    assert shortened(f"a {word} b") == f"a {'y' * 150}...[91 characters]...{'w' * 60} b"
    # many short words (a list with spaces): the line itself is cut, start and end kept
    line = "--set 'key=[" + " 1," * 1000 + " 2]': not a number"
    assert shortened(line) == \
        f"{line[:600]}...[{len(line) - 900:,} characters]...{line[-300:]}"
    assert len(shortened(line)) < LONGEST_LINE + 40
    assert shortened(line[:LONGEST_LINE]) == line[:LONGEST_LINE]


def _store_in(tmp_path, monkeypatch) -> Path:
    """The program store under ``tmp_path`` as JAX's cache folder (this process's own one
    is the test session's)."""
    import jax

    from jaxga._runtime import executables

    monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir",
                        property(lambda self: str(tmp_path)), raising=False)
    monkeypatch.setattr(executables, "_CANNOT_KEEP", set())
    return executables.directory()


def _fresh_cache_settings(monkeypatch) -> None:
    """No cache folder chosen or judged yet in this process, and JAX's own cache off."""
    import jax

    from jaxga._runtime import compilation_cache

    monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir",
                        property(lambda self: ""), raising=False)
    for name, fresh in (("_WARNED", []), ("_READ_ONLY", set()), ("_configured", {}),
                        ("_checked", {})):
        monkeypatch.setattr(compilation_cache, name, fresh)


def _tiny_program(offset: int):
    import jax
    import numpy as np

    return jax.jit(lambda x: x + offset).lower(np.int32(1))


def test_a_store_entry_replaced_by_a_folder_is_one_warning_naming_it(tmp_path, monkeypatch):
    """The file of a stored program replaced by a folder: the program is compiled (the
    result is right), one warning per store names the file and the cause, and the folder
    is left alone (it may be the user's)."""
    import jax
    import numpy as np

    from jaxga._runtime import executables
    from jaxga.core.errors import CacheWarning

    store = _store_in(tmp_path, monkeypatch)
    (store / "k1.pkl").mkdir(parents=True)
    (store / "k1.pkl" / "theirs.txt").write_text("kept")
    devices = jax.devices()[:1]
    with pytest.warns(CacheWarning) as said:
        program, read = executables.load_or_compile("k1", devices, lambda: _tiny_program(1))
    assert not read and int(program(np.int32(4))) == 5
    assert len(said) == 1, [str(w.message) for w in said]
    text = str(said[0].message)
    assert f"cannot write {store / 'k1.pkl'}" in text and "each process compiles it again" \
        in text and "\n" not in text
    assert (store / "k1.pkl" / "theirs.txt").read_text() == "kept"
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said once per store
        program, read = executables.load_or_compile("k1", devices, lambda: _tiny_program(1))
    assert not read and int(program(np.int32(6))) == 7


def test_a_read_only_cache_folder_is_read_and_said_once(tmp_path, monkeypatch):
    """A cache folder that takes no new file (a shared cache on a read-only mount; here
    the write probe made to fail, since root writes anywhere): one warning saying its
    programs are read and new ones not kept; a program stored in it before is read; JAX's
    own cache is not turned on there; a program that cannot be kept says nothing more."""
    import jax
    import numpy as np

    from jaxga._runtime import compilation_cache, executables
    from jaxga.core.errors import CacheWarning

    devices = jax.devices()[:1]
    store = _store_in(tmp_path, monkeypatch)  # writable: store one program first
    executables.save("k2", _tiny_program(2).compile(), devices)
    assert (store / "k2.pkl").is_file()

    _fresh_cache_settings(monkeypatch)
    monkeypatch.setattr(compilation_cache, "folder_problem",
                        lambda folder: f"folder {str(folder)!r} is not writable "
                                       "(Read-only file system)")
    updates = []
    monkeypatch.setattr(jax.config, "update", lambda *a: updates.append(a))
    with pytest.warns(CacheWarning) as said:
        assert compilation_cache.configure(str(tmp_path)) == str(tmp_path)
    assert len(said) == 1 and "takes no new files" in str(said[0].message)
    assert "programs stored in it are read, new ones are compiled and not kept" \
        in str(said[0].message)
    assert updates == []  # JAX's cache left off: it would warn at every write
    assert executables.directory() == store
    program, read = executables.load_or_compile("k2", devices, lambda: pytest.fail("compiled"))
    assert read and int(program(np.int32(1))) == 3

    def no_room(*args, **kwargs):
        raise JaxgaError("cannot write the store: Read-only file system")

    monkeypatch.setattr(executables, "atomic_write", no_room)
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the folder's warning said it already
        program, read = executables.load_or_compile("k3", devices, lambda: _tiny_program(3))
    assert not read and int(program(np.int32(1))) == 4

    # a stored program that then fails to run cannot be deleted here: it is not read again
    # in this process, so the call run again compiles it (it looped for ever)
    monkeypatch.setattr(executables, "_NOT_READ", set())
    monkeypatch.setattr(executables, "_READ", {"k2"})

    def read_only_unlink(self, *args, **kwargs):
        raise PermissionError(13, "Read-only file system", str(self))

    monkeypatch.setattr(Path, "unlink", read_only_unlink)
    assert executables.forget_read() is True and (store / "k2.pkl").is_file()
    assert executables.load("k2", devices) is None
    assert executables.forget_read() is False  # nothing read since: no retry


def test_store_directory_reads_a_read_only_default_folder(tmp_path, monkeypatch):
    """Without configure (the Python API's default): $JAXGA_CACHE_DIR naming a folder that
    takes no new file is still the store's folder, with one warning; one that cannot be
    read at all is not (the existing one-line warning)."""

    from jaxga._runtime import compilation_cache
    from jaxga.core.errors import CacheWarning

    _fresh_cache_settings(monkeypatch)
    monkeypatch.setattr(compilation_cache, "folder_problem",
                        lambda folder: "folder is not writable (Permission denied)")
    monkeypatch.setenv("JAXGA_CACHE_DIR", str(tmp_path))
    with pytest.warns(CacheWarning, match="takes no new files"):
        assert compilation_cache.store_directory() == str(tmp_path)
    assert compilation_cache.is_read_only(tmp_path)
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no second warning
        assert compilation_cache.store_directory() == str(tmp_path)
        monkeypatch.setattr(compilation_cache, "_checked", {})  # judged afresh: still one
        assert compilation_cache.store_directory() == str(tmp_path)
    gone = tmp_path / "missing" / "deeper"
    monkeypatch.setattr(compilation_cache, "cache_problem", lambda path: "No such file")
    monkeypatch.setenv("JAXGA_CACHE_DIR", str(gone))
    with pytest.warns(CacheWarning, match="cannot be used"):  # its own one warning
        assert compilation_cache.store_directory() is None


def test_jax_cache_warnings_become_one_jaxga_line(capsys, monkeypatch):
    """JAX warns once per cache entry it cannot read, over several lines: the command line
    shows one line per process naming the folder."""
    import warnings

    import jax

    from jaxga._runtime import compilation_cache

    monkeypatch.setattr(compilation_cache, "_configured", {})  # jaxga set no JAX cache
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(jax.config.jax_compilation_cache_dir))
    show = cli_main.one_line_warnings(lambda *a: pytest.fail(f"passed on: {a}"))
    jax_file = str(Path(jax.__file__).parent / "_src" / "compiler.py")
    for key in ("a", "b"):
        show(UserWarning(f"Error reading persistent compilation cache entry for 'jit_{key}': "
                         "EOFError: Ran out of input\n  warnings.warn("), UserWarning,
             jax_file, 782)
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("jaxga: warning: the compilation cache ")
    # named by what set the folder: the user's JAX setting, not jaxga's JAXGA_CACHE_DIR
    assert "(JAX_COMPILATION_CACHE_DIR) could not read or keep a program (EOFError: Ran " \
        "out of input)" in lines[0]
    assert lines[0].endswith("such programs are compiled and not kept")
    with warnings.catch_warnings():
        other = []
        cli_main.one_line_warnings(lambda *a: other.append(a))(
            UserWarning("something else"), UserWarning, jax_file, 1)
        assert len(other) == 1


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_while_jaxga_imports_exits_cleanly(tmp_path, signum, code):
    """The handlers go in before the package's heavy imports (JAX), so a signal a second
    after start, wherever it lands, ends the process with the shell's code and one line."""
    proc = _start(tmp_path, RUN)
    time.sleep(1.0)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("jaxga: ")


def test_only_the_console_script_handles_signals():
    from jaxga.interrupts import _is_console_script

    assert _is_console_script(["/venv/bin/jaxga", "run"], ["python", "/venv/bin/jaxga", "run"])
    # while the package loads under -m, sys.argv[0] is "-m" and the rest the program's own
    assert _is_console_script(["-m", "run"], ["python3", "-m", "jaxga.cli", "run"])
    assert _is_console_script(["-m", "run"], ["python3", "-X", "dev", "-m", "jaxga", "run"])
    assert _is_console_script(["/src/jaxga/__main__.py"], ["python3", "-m", "jaxga"])
    assert not _is_console_script(["-m", "-f", "x"],
                                  ["python3", "-m", "ipykernel_launcher", "-f", "x"])
    assert not _is_console_script(["script.py", "-m"], ["python", "script.py", "-m"])
    # a program's own arguments that happen to read "-m jaxga" (pytest -m jaxga)
    assert not _is_console_script(["script.py", "-m", "jaxga"],
                                  ["python", "script.py", "-m", "jaxga"])
    assert not _is_console_script(["-m", "-m", "jaxga"],
                                  ["python", "-m", "pytest", "-m", "jaxga"])
    assert not _is_console_script([], [])


def test_more_outputs_that_would_go_wrong(tmp_path):
    """An empty name (``--json "$OUT"`` with OUT unset) and an existing device or FIFO are
    refused; a symbolic link is written through, and stays a link."""
    with pytest.raises(JaxgaError, match="--json: the file name is empty"):
        check_outputs({"--json": ""})
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(JaxgaError, match="not a regular file"):
        check_outputs({"--plot": fifo})
    target = tmp_path / "target.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    check_outputs({"--json": link})
    atomic_write_text(link, "new")
    assert link.is_symlink() and target.read_text() == "new"


def test_a_unicode_map_name_in_an_ascii_locale_is_printed_escaped(tmp_path):
    grid = tmp_path / "карта 🗺.txt"
    grid.write_text("S...\n.##.\n...G\n")
    env = dict(os.environ, PYTHONIOENCODING="ascii", LC_ALL="C", LANG="C")
    proc = subprocess.run([sys.executable, "-m", "jaxga.cli", "optimum", "--map", str(grid)],
                          env=env, capture_output=True, text=True, timeout=120,
                          encoding="ascii")
    assert proc.returncode == 0, proc.stderr
    assert "\\u043a" in proc.stdout + proc.stderr and "Traceback" not in proc.stderr


def test_hostile_yaml_json_and_preset_chains_are_one_line(tmp_path):
    """A YAML alias bomb (9 levels of 9) in a ROS map's origin, a path JSON nested 100,000
    deep, a preset ``base`` chain of 40 files: refused in one line, at once."""
    from jaxga.cli.replan import read_path_json as _read_path_json
    from jaxga.config.presets import load_preset
    from jaxga.maps.ros import read_ros_yaml

    levels = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    levels += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("\n".join(levels) + "\nimage: m.pgm\nresolution: 0.05\norigin: *a8\n")
    t0 = time.monotonic()
    with pytest.raises(JaxgaError, match="origin must be") as e:
        read_ros_yaml(bomb)
    assert time.monotonic() - t0 < 5 and len(str(e.value)) < 300
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000)
    with pytest.raises(JaxgaError, match="nested too deeply|not valid JSON"):
        _read_path_json(str(deep), None)
    for i in range(40):
        (tmp_path / f"p{i}.toml").write_text(f'base = "p{i + 1}.toml"\n' if i < 39 else
                                             'base = "sga"\n')
    with pytest.raises(JaxgaError, match="longer than 32 files"):
        load_preset(tmp_path / "p0.toml")


def test_ros_numbers_with_exponents_and_a_far_origin(tmp_path):
    """``resolution: 5e-2`` is a number to ROS (YAML 1.1 reads a string); an origin so far
    away that coordinates overflow is refused in one line naming it (decision 047: it
    made inf and NaN points where the endpoints were given in cells), and one far but
    finite puts a world endpoint off the map, in one line."""
    from jaxga.core.errors import EndpointError, MapFormatError
    from jaxga.maps import load_map_info

    (tmp_path / "m.pgm").write_bytes(b"P5\n4 4\n255\n" + bytes([254] * 16))
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 5e-2\norigin: [0, 0, 0]\n")
    assert load_map_info(tmp_path / "m.yaml").frame.cell_size == pytest.approx(0.05)
    (tmp_path / "far.yaml").write_text(
        "image: m.pgm\nresolution: 0.05\norigin: [1.0e+308, 1.0e+308, 0.0]\n")
    with pytest.raises(MapFormatError, match="origin must lie within 1e[+]12 metres"):
        load_map_info(tmp_path / "far.yaml", start_world=(0.0, 0.0), goal_world=(0.1, 0.1))
    (tmp_path / "far.yaml").write_text(  # 2e12 cells out: refused (decision 063)
        "image: m.pgm\nresolution: 0.05\norigin: [1.0e+11, 1.0e+11, 0.0]\n")
    with pytest.raises(MapFormatError, match="2e[+]12 cells of 0.05 m away"):
        load_map_info(tmp_path / "far.yaml", start_world=(0.0, 0.0), goal_world=(0.1, 0.1))
    (tmp_path / "far.yaml").write_text(
        "image: m.pgm\nresolution: 0.05\norigin: [1.0e+8, 1.0e+8, 0.0]\n")
    with pytest.raises(EndpointError, match="off the map"):
        load_map_info(tmp_path / "far.yaml", start_world=(0.0, 0.0), goal_world=(0.1, 0.1))


# ------------------------------------------------------------ round two: inputs behind inputs
def test_the_files_behind_an_input_are_inputs_too(tmp_path, capsys, monkeypatch):
    """--json onto a file of the preset's ``base`` chain (relative to the file naming it),
    a DOE output inside its own --checkpoint folder, replan's --path-out over its --path:
    refused before any work, the files intact."""
    import jaxga.api

    monkeypatch.setattr(jaxga.api, "run", lambda *a, **k: pytest.fail("the run started"))
    grid = tmp_path / "lab.txt"
    grid.write_text("S...\n.##.\n...G\n")
    (tmp_path / "presets").mkdir()
    parent = tmp_path / "presets" / "parent.toml"
    parent.write_text('base = "sga"\n[mutation]\nprobability = 0.2\n')
    child = tmp_path / "child.toml"
    child.write_text('base = "presets/parent.toml"\n')
    checkpoint = tmp_path / "doe"
    path_csv = tmp_path / "path.csv"
    path_csv.write_text("x,y\n0.5,0.5\n3.5,0.5\n")
    cases = [
        (["run", "--preset", str(child), "--map", str(grid), "--json", str(parent)],
         "the preset file"),
        (["compare", "--presets", f"sga,{child}", "--map", str(grid), "--json",
          str(parent)], "the preset file"),
        (["doe", "--preset", "sga", "--map", str(grid), "--checkpoint", str(checkpoint),
          "--json", str(checkpoint / "manifest.json")], "inside the --checkpoint folder"),
        (["doe", "--preset", "sga", "--map", str(grid), "--checkpoint", str(checkpoint),
          "--plot", str(checkpoint / "sub" / ".." / "effects.png")],
         "inside the --checkpoint folder"),
        (["replan", "--map", str(grid), "--path", str(path_csv), "--position", "0,0",
          "--obstacles", "1,0", "--path-out", str(path_csv)], "the path file"),
    ]
    checkpoint.mkdir()
    (checkpoint / "sub").mkdir()
    for argv, words in cases:
        rc = main(argv)
        err = capsys.readouterr().err.strip()
        assert rc == EXIT_BAD_INPUT and words in err and "\n" not in err, (argv, err)
    assert parent.read_text() == 'base = "sga"\n[mutation]\nprobability = 0.2\n'
    assert path_csv.read_text() == "x,y\n0.5,0.5\n3.5,0.5\n"
    assert not (checkpoint / "manifest.json").exists()


def test_a_temporary_file_a_killed_write_left_is_removed_by_the_next_write(tmp_path):
    """``kill -9`` during a write leaves ``.NAME.<pid>.<machine>.<random>.tmp``: the next
    write of that file removes it when the pid has ended on this machine; one of a process
    still writing, of another file, or of another machine or container (whose pid cannot be
    asked here) stays until it is an hour old, as an older version's names do."""
    target = tmp_path / "run.json"
    here = files.this_machine()
    elsewhere = "0123abcd" if here != "0123abcd" else "89abcdef"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    hour_ago = (time.time() - 2 * files.OLD_TEMPORARY_S,) * 2

    def left(name: str, text: str = "half a file", old: bool = False):
        path = tmp_path / name
        path.write_text(text)
        if old:
            os.utime(path, hour_ago)
        return path

    removed = [
        left(f".run.json.{dead.pid}.{here}.a1b2c3d4.tmp"),  # killed here
        left(f".run.json.{dead.pid}.{elsewhere}.b1b2c3d4.tmp", old=True),  # elsewhere, old
        left(f".run.json.{dead.pid}.c1b2c3d4.tmp", old=True),  # an older version's, old
        left(".run.json.q1w2e3r4.tmp", old=True),  # mkstemp's name, old
    ]
    kept = [
        left(f".run.json.{os.getppid()}.{here}.zz9y8x7w.tmp"),  # a live process here
        left(f".run.json.{dead.pid}.{elsewhere}.d1b2c3d4.tmp"),  # a live write elsewhere
        left(f".run.json.{dead.pid}.e1b2c3d4.tmp"),  # an older version's, recent
        left(".run.json.p0o9i8u7.tmp"),  # mkstemp's name, recent
    ]
    other = left(f".other.json.{dead.pid}.{here}.a1b2c3d4.tmp", "another file's")
    atomic_write_text(target, "{}")
    assert target.read_text() == "{}"
    assert not any(p.exists() for p in removed)
    assert other.exists()
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".run.json")) \
        == sorted(p.name for p in kept)


def test_a_write_names_its_temporary_file_by_process_and_machine(tmp_path, monkeypatch):
    """The temporary name carries the writer's pid and :func:`files.this_machine`, which
    differs between hosts, boots and pid namespaces (it hashes all three)."""
    seen = []

    def write(f):
        seen.extend(p.name for p in tmp_path.iterdir())
        f.write("{}")

    files.atomic_write(tmp_path / "run.json", write)
    assert seen == [f".run.json.{os.getpid()}.{files.this_machine()}.{seen[0][-12:-4]}.tmp"]
    assert re.fullmatch(r"[0-9a-f]{8}", files.this_machine())
    host = files.this_machine()
    files.this_machine.cache_clear()
    monkeypatch.setattr(files.socket, "gethostname", lambda: "another-node")
    try:
        assert files.this_machine() != host
    finally:
        files.this_machine.cache_clear()


@pytest.mark.slow  # starts processes
@pytest.mark.parametrize("redirect", [">&-", "2>&-", ">&- 2>&-"])
def test_a_closed_stdout_or_stderr_does_not_fail_a_run(tmp_path, redirect):
    out = tmp_path / "run.json"
    argv = " ".join([sys.executable, "-m", "jaxga.cli", *RUN, "--json", str(out)])
    proc = subprocess.run(f"{argv} {redirect}", shell=True, cwd=tmp_path, timeout=300,
                          capture_output=True, text=True)  # the suite's program store
    assert proc.returncode == 0, proc.stderr
    assert [r["success"] for r in json.loads(out.read_text())["runs"]] == [True, True]


@pytest.mark.slow  # starts processes
def test_matplotlib_with_unusable_folders_leaves_nothing_and_a_bad_backend_is_one_line(
        tmp_path):
    """``MPLCONFIGDIR`` (or ``HOME``) unwritable: the plot is written, no warning from
    Matplotlib, no ``matplotlib-*`` folder left in the temporary directory. An invalid
    ``MPLBACKEND`` with --plot: one line naming the variable, before any work."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    base = dict(os.environ, TMPDIR=str(scratch))  # the suite's program store
    argv = [sys.executable, "-m", "jaxga.cli", *RUN, "--plot", str(tmp_path / "p.png")]
    for env in ({"MPLCONFIGDIR": "/proc/no-such-folder"}, {"HOME": "/proc/no-such-home"}):
        proc = subprocess.run(argv, env={**base, **env}, capture_output=True, text=True,
                              timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert (tmp_path / "p.png").stat().st_size > 0
        assert "Matplotlib" not in proc.stderr and "matplotlib" not in proc.stderr
        assert list(scratch.iterdir()) == [], env
        (tmp_path / "p.png").unlink()
    proc = subprocess.run(argv, env={**base, "MPLBACKEND": "no-such-backend"},
                          capture_output=True, text=True, timeout=300)
    err = proc.stderr.strip()
    assert proc.returncode == EXIT_BAD_INPUT and "\n" not in err, err
    assert err.startswith("jaxga: error: $MPLBACKEND='no-such-backend'")
    assert not (tmp_path / "p.png").exists()


@pytest.mark.slow  # starts processes
@pytest.mark.parametrize("variable, value, words", [
    ("JAX_ENABLE_X64", "1", "64-bit mode is on ($JAX_ENABLE_X64=1)"),
    ("JAX_DISABLE_JIT", "1", "jit is disabled ($JAX_DISABLE_JIT=1)"),
    ("JAX_PLATFORMS", "cuda", "$JAX_PLATFORMS='cuda' names a platform"),
    ("JAX_PLATFORMS", "no-such-platform", "$JAX_PLATFORMS='no-such-platform'"),
    ("XLA_FLAGS", "--xla_no_such_flag=1", "XLA does not accept $XLA_FLAGS="
                                           "'--xla_no_such_flag=1' (Unknown flag"),
])
def test_jaxs_own_switches_are_one_line_naming_the_variable(tmp_path, variable, value,
                                                            words):
    if variable == "JAX_PLATFORMS" and value == "cuda":
        import jax

        if any(d.platform == "gpu" for d in jax.devices()):
            pytest.skip("this machine has CUDA")
    proc = subprocess.run([sys.executable, "-m", "jaxga.cli", *RUN],
                          env=dict(os.environ, HOME=str(tmp_path), **{variable: value}),
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    err = proc.stderr.strip()
    assert proc.returncode == EXIT_BAD_INPUT and "\n" not in err, err
    assert err.startswith("jaxga: error: ") and words in err, err


@pytest.mark.slow  # starts processes
def test_xla_flags_xla_accepts_are_probed_once_and_remembered(tmp_path, monkeypatch):
    """A flag XLA knows passes; the verdict is remembered per flags, platforms and jaxlib,
    so a later command does not start a probe process again."""
    from jaxga._runtime import jax_settings

    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=1")
    jax_settings.check_xla_flags()
    remembered = json.loads(jax_settings.xla_flags_verdicts().read_text())
    assert [k.split("|")[0] for k in remembered] == ["--xla_force_host_platform_device_count=1"]
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("probed again"))
    jax_settings.check_xla_flags()
    monkeypatch.delenv("XLA_FLAGS")
    jax_settings.check_xla_flags()  # nothing to check


def test_the_api_refuses_64_bit_mode_and_disabled_jit_in_one_line():
    import jax

    import jaxga
    from jaxga.core.errors import ParameterError

    for option in ("jax_enable_x64", "jax_disable_jit"):
        jax.config.update(option, True)
        try:
            with pytest.raises(ParameterError, match="64-bit mode|jit is disabled") as e:
                jaxga.run("sga", "classic_ga_gapp3_20x20", seeds=1, generations=1)
            assert "\n" not in str(e.value)
        finally:
            jax.config.update(option, False)


def test_replan_reads_the_frame_its_path_json_records(tmp_path, capsys):
    """A run's JSON made with --coarsen 2, replanned without it: its coarse cells become
    the map's (each cell's centre), never taken for map cells; the JSON of a map of
    another size is refused; a JSON without a frame is taken as it is."""
    from jaxga.cli.replan import read_path_json
    from jaxga.core.errors import ParameterError
    from jaxga.maps.frame import MapFrame

    run = {"frame": {"coarsen": 2, "map_shape": [20, 20]},
           "runs": [{"success": True, "length": 12.7, "path": [[0, 0], [4, 4], [9, 9]]}]}
    path = tmp_path / "run.json"
    path.write_text(json.dumps(run))
    fine = MapFrame(map_shape=(20, 20))
    assert read_path_json(str(path), None, frame=fine) == [(1, 1), (9, 9), (19, 19)]
    assert "planned 2 x 2 map cells a planning cell" in capsys.readouterr().err
    coarse = MapFrame(map_shape=(20, 20), coarsen=2)
    assert read_path_json(str(path), None, frame=coarse) == [(0, 0), (4, 4), (9, 9)]
    quarter = MapFrame(map_shape=(20, 20), coarsen=4)
    assert read_path_json(str(path), None, frame=quarter) == [(0, 0), (2, 2), (4, 4)]
    other = MapFrame(map_shape=(20, 24))
    with pytest.raises(ParameterError, match="planned on a map of 20 x 20 cells, --map "
                                             "has 24 x 20") as e:
        read_path_json(str(path), None, frame=other)
    assert "\n" not in str(e.value)
    path.write_text(json.dumps({"path": [[0, 0], [3, 3]]}))
    assert read_path_json(str(path), None, frame=fine) == [(0, 0), (3, 3)]


def test_a_scenario_length_that_contradicts_the_exact_optimum_is_reported(tmp_path, capsys):
    """A scenario file whose stated optimal length is wrong (1.0 where the exact optimum
    is 64.3137): the note beside it gives the exact one; a right one gets no comment."""
    data = Path(__file__).resolve().parents[1] / "data"
    (tmp_path / "maze-32-32-2.map").write_bytes((data / "maze-32-32-2.map").read_bytes())
    lines = (data / "maze-32-32-2-random-1.scen").read_text().splitlines()
    first = lines[1].split("\t")
    wrong = "\t".join([*first[:-1], "1.00000000"])
    (tmp_path / "maze-32-32-2.map.scen").write_text("\n".join([lines[0], wrong, lines[2]]))
    for n, words in ((0, "the exact optimum of these endpoints on this map is 64.3137"),
                     (1, None)):
        rc = main(["optimum", "--map", str(tmp_path / "maze-32-32-2.map"), "--scenario",
                   str(n)])
        err = capsys.readouterr().err
        assert rc == 0, err
        note = [line for line in err.splitlines() if line.startswith("scenario ")]
        assert len(note) == 1, err
        if words:
            assert "optimal length 1.0000" in note[0] and words in note[0], note
        else:
            assert "but" not in note[0], note


def test_a_cache_folder_that_cannot_be_named_is_one_warning(tmp_path, monkeypatch):
    """configure() with a name too long for the file system raised OSError (from
    Path.is_dir), one holding a NUL ValueError, and a number or bytes TypeError: the
    unusable names are one warning naming their source and the programs compile without
    a cache; a value that is no path at all is refused in one line."""
    import jax

    from jaxga._runtime import compilation_cache
    from jaxga.core.errors import CacheWarning, ParameterError

    _fresh_cache_settings(monkeypatch)
    monkeypatch.setattr(jax.config, "update", lambda *a: pytest.fail("JAX's cache turned on"))
    for name, why in ((str(tmp_path / ("a" * 300)), "File name too long"),
                      (str(tmp_path / "a\0b"), "a folder.s name cannot hold a NUL")):
        monkeypatch.setattr(compilation_cache, "_WARNED", [])
        with pytest.warns(CacheWarning, match=f"\\(jaxga.configure\\) cannot be used "
                                              f"\\({why}"):
            assert compilation_cache.configure(name) is None
    for value in (123, b"/x"):
        with pytest.raises(ParameterError, match="cache_dir must be a folder's path"):
            compilation_cache.configure(value)
