"""Round fourteen (decision 062): the process environment a user or a batch scheduler
gives the command: signals set to be ignored or sent as warnings, warnings made errors,
streams that cannot be written, a working folder removed, home and cache folders that
are blank, relative or not known, file names that are not UTF-8."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from jaxga import interrupts
from jaxga._runtime import compilation_cache, device_probe, jax_settings
from jaxga.cli import entry
from jaxga.core import files, matplotlib_env
from jaxga.core.errors import JaxgaError
from jaxga.maps.loaders import map_name

ROOT = Path(__file__).resolve().parents[2]


def _python(code: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env=env, cwd=ROOT)


@pytest.mark.slow  # processes of their own
@pytest.mark.skipif(not hasattr(signal, "SIGUSR1"), reason="POSIX signals")
def test_a_signal_ignored_at_start_stays_ignored_and_a_schedulers_signal_ends_cleanly():
    """nohup ignores SIGHUP and a script's background job SIGINT: the handlers leave
    them so (a closed terminal ended a nohup run with 129). SIGUSR1, a scheduler's
    warning, ends the process with one line and 128 + its number, like SIGTERM."""
    got = _python(
        "import signal\n"
        "signal.signal(signal.SIGHUP, signal.SIG_IGN)\n"
        "from jaxga import interrupts\n"
        "interrupts.install()\n"
        "print(signal.getsignal(signal.SIGHUP) is signal.SIG_IGN,\n"
        "      signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL)\n")
    assert got.stdout.split() == ["True", "True"], got.stderr
    got = _python("import os, signal, time\nfrom jaxga import interrupts\n"
                  "interrupts.install()\nos.kill(os.getpid(), signal.SIGUSR1)\ntime.sleep(30)\n")
    assert got.returncode == 128 + signal.SIGUSR1
    assert got.stderr.strip().splitlines()[-1] == "jaxga: stopped by SIGUSR1"
    for name in ("SIGXCPU", "SIGUSR1", "SIGUSR2", "SIGHUP"):
        assert interrupts.EXIT_CODES[getattr(signal, name)] == 128 + getattr(signal, name)


def test_a_warning_made_an_error_is_one_line(monkeypatch, capsys):
    """`python -W error` turned the unusable cache's warning into a traceback; it is now
    one `jaxga: error:` line naming the warning, exit 2, before anything is compiled."""
    monkeypatch.setenv(compilation_cache.ENV_VAR, "/proc/no-such-cache")
    monkeypatch.setattr(compilation_cache, "_WARNED", [])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code = entry.main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20",
                           "--seeds", "1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].startswith("jaxga: error: the compilation cache /proc/no-such-cache")
    assert err[0].endswith("(a CacheWarning, an error under -W error / PYTHONWARNINGS)")


class _Full:
    """A stream on a full disk: every write and flush fails with ENOSPC."""

    def __init__(self) -> None:
        self.fd = os.open(os.devnull, os.O_WRONLY)

    def write(self, text: str) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")

    def flush(self) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    def fileno(self) -> int:
        return self.fd


def test_a_stream_that_cannot_be_written_is_lost_then_named(monkeypatch, capsys):
    """stdout or stderr on a full disk ended the command at once (its JSON unwritten, a
    hidden traceback): the output is lost and the command goes on; a stdout that could
    not be written is one error line when it ends (a listing whose only product is its
    output did not succeed), a reader gone (EPIPE) is not, and a stream full for now
    (EAGAIN) is not swallowed."""
    full = _Full()
    try:
        out = entry.ReaderMayLeave(full)
        assert out.write("summary\n") == len("summary\n")
        out.flush()
        assert capsys.readouterr().err == ""  # nothing said yet: the command goes on
        monkeypatch.setattr(sys, "stdout", out)
        assert entry.lost_output() == (
            "jaxga: error: standard output could not be written (No space left on device): "
            "the rest of it was lost (files were written)")
        gone = entry.ReaderMayLeave(full)
        gone._lost(BrokenPipeError(errno.EPIPE, "Broken pipe"))
        monkeypatch.setattr(sys, "stdout", gone)
        assert entry.lost_output() is None
        with pytest.raises(BlockingIOError):
            gone._lost(BlockingIOError(errno.EAGAIN, "Resource temporarily unavailable"))
    finally:
        os.close(full.fd)


def test_a_working_folder_removed_is_named(monkeypatch):
    def gone() -> str:
        raise FileNotFoundError(errno.ENOENT, "No such file or directory")

    monkeypatch.setattr(os, "getcwd", gone)
    with pytest.raises(JaxgaError, match="the working folder no longer exists"):
        entry.check_working_folder()


def test_a_file_name_that_is_not_utf8_is_shown_escaped():
    """Bytes that are not UTF-8 in a map's file name (lone surrogates in Python) broke
    the plot's title and made JSON a strict parser refuses: the name shows them as
    escapes."""
    assert map_name(Path("maps/caf\udce9.txt")) == "caf\\udce9"
    assert map_name(Path("maps/caf\u00e9.txt")) == "caf\u00e9"


def test_a_home_folder_not_known_or_relative_is_no_folder(monkeypatch):
    """A container's user without a home (Path.home raised RuntimeError: a traceback) or
    a relative $HOME (folders under every working folder): no home folder; the cache's
    default then names `~`, which cache_problem refuses in one warning, and the
    verdict files are not kept."""
    def unknown() -> Path:
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(Path, "home", staticmethod(unknown))
    assert files.home_folder() is None
    assert compilation_cache.default_directory() == "~/.cache/jaxga/jax"
    assert "home folder ~, which is not known" in compilation_cache.cache_problem(
        compilation_cache.default_directory())
    assert compilation_cache.expanded("~/cache") == "~/cache"
    monkeypatch.delenv(device_probe.VERDICTS_ENV, raising=False)
    assert device_probe.verdicts_path() is None
    assert jax_settings.xla_flags_verdicts() is None
    monkeypatch.setattr(Path, "home", staticmethod(lambda: Path("relhome")))
    assert files.home_folder() is None


def test_cache_folder_values_with_spaces_or_line_ends(monkeypatch, tmp_path):
    """`JAXGA_CACHE_DIR=" "` made a folder named by a space, a CRLF .env file one whose
    name ends in a carriage return: spaces alone are refused, a line end is no part of
    the name."""
    monkeypatch.setenv(compilation_cache.ENV_VAR, f"{tmp_path}/cache\r")
    assert compilation_cache.env_directory() == f"{tmp_path}/cache"
    monkeypatch.setenv(compilation_cache.ENV_VAR, "  ")
    assert compilation_cache.cache_problem(compilation_cache.env_directory()) == \
        "it holds only spaces, no folder's name"
    monkeypatch.setenv(compilation_cache.ENV_VAR, "")
    assert compilation_cache.env_directory() == ""  # empty: no folder, as documented


def test_matplotlib_folders_under_a_relative_xdg_folder_are_not_used(monkeypatch, tmp_path):
    """A relative XDG folder would be made under every working folder: not used. A
    relative MPLCONFIGDIR is the user's choice, read as Matplotlib reads it."""
    monkeypatch.delenv("MPLCONFIGDIR", raising=False)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CONFIG_HOME", "rel2")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "abs"))
    config, cache = matplotlib_env._own_folders()
    assert not matplotlib_env._usable(config) and matplotlib_env._usable(cache)
    assert not (tmp_path / "rel2").exists()
    monkeypatch.setenv("MPLCONFIGDIR", "mine")
    assert matplotlib_env._own_folders() == [tmp_path / "mine"]
    assert matplotlib_env._usable(tmp_path / "mine")


def test_a_jax_cache_set_by_the_user_is_named_as_theirs(monkeypatch):
    import jax

    before = jax.config.jax_compilation_cache_dir
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", "/tmp/the-users-cache")
    monkeypatch.delenv(compilation_cache.ENV_VAR, raising=False)
    try:
        jax.config.update("jax_compilation_cache_dir", "/tmp/the-users-cache")
        assert compilation_cache.jax_cache_source() == "JAX_COMPILATION_CACHE_DIR"
    finally:
        jax.config.update("jax_compilation_cache_dir", before)
