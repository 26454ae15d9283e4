"""Every core, several processes (``jax.distributed`` on loopback), lost processes.

Every test starts fresh Python processes (JAX's device count and ``jax.distributed`` are
fixed once a process has started its backend); every wait has a timeout and every child
is killed at the end. The runs are tiny (6 runs of the sga preset, population 10, 5
generations, on a built-in 20 x 20 map) and share one persistent compilation cache with
the rest of the suite.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # processes of their own (jax.distributed, device counts)

ROOT = Path(__file__).resolve().parents[2]
MAP = "classic_ga_gapp3_20x20"
RUN = ["run", "--preset", "sga", "--map", MAP, "--corner-rule", "free", "--seeds", "6",
       "--generations", "5", "--set", "population.size=10", "--quiet"]
WAIT_S = 600  # a cold compile on a loaded 2-core machine; normally seconds


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _env() -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for k in list(env):
        if (k.startswith("JAXGA_") and k != "JAXGA_CACHE_DIR") or k in (
                "XLA_FLAGS", "JAX_NUM_CPU_DEVICES"):
            env.pop(k)
    return env


class _Procs:
    """Child processes with their output in files; all killed on exit."""

    def __init__(self, tmp: Path) -> None:
        self.tmp, self.procs = tmp, []

    def start(self, name: str, argv: list[str]) -> subprocess.Popen:
        out = open(self.tmp / f"{name}.out", "w")  # closed in __exit__
        err = open(self.tmp / f"{name}.err", "w")
        p = subprocess.Popen([sys.executable, *argv], cwd=self.tmp, env=_env(), stdout=out,
                             stderr=err, start_new_session=True)
        p.name, p.files = name, (out, err)
        self.procs.append(p)
        return p

    def wait(self, p: subprocess.Popen, timeout: float = WAIT_S) -> int:
        rc = p.wait(timeout=timeout)
        for f in p.files:
            f.flush()
        return rc

    def output(self, name: str) -> tuple[str, str]:
        return ((self.tmp / f"{name}.out").read_text(), (self.tmp / f"{name}.err").read_text())

    def wait_for_line(self, name: str, text: str, timeout: float = WAIT_S) -> None:
        end = time.monotonic() + timeout
        while text not in (self.tmp / f"{name}.out").read_text():
            assert time.monotonic() < end, f"{name} never printed {text!r}"
            time.sleep(0.2)

    def __enter__(self) -> _Procs:
        return self

    def __exit__(self, *exc) -> None:
        for p in self.procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=30)
            for f in p.files:
                f.close()


def _cli(*args: str) -> list[str]:
    return ["-m", "jaxga.cli", *args]


def _runs(path: Path) -> dict:
    out = json.loads(path.read_text())
    out.pop("timing")
    return out


@pytest.fixture(scope="module")
def single_run(tmp_path_factory) -> dict:
    """The reference: one process, one device."""
    tmp = tmp_path_factory.mktemp("single")
    with _Procs(tmp) as procs:
        p = procs.start("single", _cli(*RUN, "--devices", "1", "--json", "one.json"))
        assert procs.wait(p) == 0, procs.output("single")
    return _runs(tmp / "one.json")


def _distributed(procs: _Procs, argv: list[str], n: int = 2) -> list[subprocess.Popen]:
    port = _free_port()
    return [procs.start(f"p{i}", argv + ["--coordinator", f"127.0.0.1:{port}",
                                        "--num-processes", str(n), "--process-id", str(i)])
            for i in range(n)]


def test_two_processes_give_the_single_process_result(single_run, tmp_path):
    """``jaxga run`` in 2 processes on loopback: each computes 3 of the 6 runs, process 0
    writes the JSON; paths, lengths, fitness and histories equal one process's."""
    with _Procs(tmp_path) as procs:
        ps = _distributed(procs, _cli(*RUN, "--devices", "1", "--json", "two.json"))
        rcs = [procs.wait(p) for p in ps]
        assert rcs == [0, 0], [procs.output(p.name) for p in ps]
        out0, _ = procs.output("p0")
        out1, _ = procs.output("p1")
    assert "6 seeds" in out0 and "wrote two.json" in out0
    assert out1.strip() == "process 1 of 2: done (6 seeds; process 0 writes the results)"
    assert not (tmp_path / "p1.json").exists()
    two = _runs(tmp_path / "two.json")
    assert [r["seed"] for r in two["runs"]] == list(range(6))
    assert two == single_run


def test_processes_with_other_device_counts_give_the_single_process_result(single_run,
                                                                           tmp_path):
    """Processes on hosts of other core counts (here ``--devices 2`` and ``--devices 3``)
    split the runs alike, so every seed is computed once: before, each process took its
    share from its own device count, and a seed came back as a copy of another's."""
    with _Procs(tmp_path) as procs:
        port = _free_port()
        ps = [procs.start(f"p{i}", _cli(*RUN, "--devices", str(n), "--json", "mixed.json",
                                        "--coordinator", f"127.0.0.1:{port}",
                                        "--num-processes", "2", "--process-id", str(i)))
              for i, n in enumerate((2, 3))]
        rcs = [procs.wait(p) for p in ps]
        assert rcs == [0, 0], [procs.output(p.name) for p in ps]
    assert _runs(tmp_path / "mixed.json") == single_run


DOE = ["doe", "--preset", "sga", "--map", MAP, "--corner-rule", "free", "--design", "L9",
       "--factor", "crossover.probability=0.5,0.7,0.9",
       "--factor", "mutation.probability=0.1,0.2,0.3", "--seeds", "2", "--generations", "5",
       "--set", "population.size=10", "--block", "1", "--quiet", "--devices", "1"]


def test_doe_in_two_processes_gives_the_single_process_result(tmp_path):
    """``jaxga doe`` (9 points x 2 seeds in blocks of one point, checkpointed, and its
    confirmation run) in 2 processes == in 1 process; process 0 alone writes the JSON and
    the checkpoint, and the other process follows its list of finished points. Blocks of
    one point are 2 runs, like the confirmation: one compiled program per process."""
    with _Procs(tmp_path) as procs:
        p = procs.start("single", _cli(*DOE, "--checkpoint", "ck1", "--json", "one.json"))
        assert procs.wait(p) == 0, procs.output("single")
        ps = _distributed(procs, _cli(*DOE, "--checkpoint", "ck2", "--json", "two.json"))
        rcs = [procs.wait(p) for p in ps]
        assert rcs == [0, 0], [procs.output(p.name) for p in ps]
        out1, _ = procs.output("p1")
    assert out1.strip().startswith("process 1 of 2: done (9 design points x 2 seeds")
    one, two = _runs(tmp_path / "one.json"), _runs(tmp_path / "two.json")
    assert len(two["points"]) == 9 and two == one
    assert sorted(p.name for p in (tmp_path / "ck2").glob("point-*.json")) == sorted(
        p.name for p in (tmp_path / "ck1").glob("point-*.json"))
    assert len(list((tmp_path / "ck2").glob("point-*.json"))) == 9


def test_two_devices_give_the_one_device_result(single_run, tmp_path):
    """``--devices 2`` (6 runs sharded over 2 XLA CPU devices) == ``--devices 1``."""
    with _Procs(tmp_path) as procs:
        p = procs.start("dev2", _cli(*RUN, "--devices", "2", "--json", "dev2.json"))
        assert procs.wait(p) == 0, procs.output("dev2")
    assert _runs(tmp_path / "dev2.json") == single_run


_SWEEP_SCRIPT = """
import json, os, sys
import jax
jax.config.update("jax_compilation_cache_dir", os.environ["JAXGA_CACHE_DIR"])
import jaxga._runtime.parallel as par
par.set_local_devices(1)
if len(sys.argv) > 1:
    par.initialize(sys.argv[1], 2, int(sys.argv[2]), timeout=60)
from jaxga.api import sweep
results = sweep("sga", "classic_ga_gapp3_20x20",
                [{"crossover.probability": 0.5}, {"crossover.probability": 0.9}],
                seeds=3, generations=5, corner_rule="free", population__size=10)
out = []
for r in results:
    d = r.to_json()
    d.pop("timing")
    out.append(d)
told = par.broadcast({"from": par.process_index(), "points": [0.5, 0.9]})
print(json.dumps({"process": par.process_index(), "told": told, "results": out}))
"""


def test_a_sweep_in_two_processes_gives_the_single_process_result(tmp_path):
    """``jaxga.api.sweep`` (what ``jaxga doe`` is built on) over 2 points x 3 seeds in 2
    processes: both processes return the single-process results; ``broadcast`` gives
    both process 0's value."""
    with _Procs(tmp_path) as procs:
        one = procs.start("one", ["-c", _SWEEP_SCRIPT])
        port = _free_port()
        two = [procs.start(f"p{i}", ["-c", _SWEEP_SCRIPT, f"127.0.0.1:{port}", str(i)])
               for i in range(2)]
        for p in (one, *two):
            assert procs.wait(p) == 0, procs.output(p.name)
        got = [json.loads(procs.output(name)[0].strip().splitlines()[-1])
               for name in ("one", "p0", "p1")]
    assert [g["process"] for g in got] == [0, 0, 1]
    assert [g["told"]["from"] for g in got] == [0, 0, 0]  # parallel.broadcast
    assert got[1]["results"] == got[0]["results"]
    assert got[2]["results"] == got[0]["results"]
    a, b = got[0]["results"]
    assert [r["seed"] for r in a["runs"]] == [0, 1, 2] == [r["seed"] for r in b["runs"]]
    assert a["runs"] != b["runs"]  # the two points are different experiments


_JOIN_AND_WAIT = """
import sys, time
import jaxga._runtime.parallel as par
par.initialize(sys.argv[1], 2, int(sys.argv[2]), timeout=float(sys.argv[3]))
print("joined", flush=True)
time.sleep(600)
"""


def test_a_killed_process_is_named_by_the_survivor_within_the_timeout(tmp_path):
    """Process 1 joins and is killed; process 0 (``jaxga run``) exits with status 4 and
    one line naming process 1, within --process-timeout (10 s) plus a margin."""
    timeout = 10
    with _Procs(tmp_path) as procs:
        port = _free_port()
        p0 = procs.start("p0", _cli(*RUN, "--devices", "1", "--json", "x.json",
                                    "--coordinator", f"127.0.0.1:{port}", "--num-processes",
                                    "2", "--process-id", "0",
                                    "--process-timeout", str(timeout)))
        p1 = procs.start("p1", ["-c", _JOIN_AND_WAIT, f"127.0.0.1:{port}", "1",
                                str(timeout)])
        procs.wait_for_line("p1", "joined", timeout=120)
        p1.kill()
        killed = time.monotonic()
        rc = procs.wait(p0, timeout=timeout + 60)
        elapsed = time.monotonic() - killed
        _, err = procs.output("p0")
    assert rc == 4, err
    assert "jaxga: error: process 1 of 2 was lost: no heartbeat for 10 s" in err
    assert "Traceback" not in err
    assert timeout - 2 <= elapsed < timeout + 30  # last beat up to 1 s before the kill
    assert not (tmp_path / "x.json").exists()


def test_a_process_that_never_joins_ends_the_other_within_the_timeout(tmp_path):
    """Only process 0 of 2 starts: it exits with status 4 and a one-line message after
    --process-timeout, instead of JAX's abort several minutes later."""
    with _Procs(tmp_path) as procs:
        t0 = time.monotonic()
        p0 = procs.start("p0", _cli(*RUN, "--coordinator", f"127.0.0.1:{_free_port()}",
                                    "--num-processes", "2", "--process-id", "0",
                                    "--process-timeout", "5"))
        rc = procs.wait(p0, timeout=120)
        elapsed = time.monotonic() - t0
        _, err = procs.output("p0")
    assert rc == 4, err
    assert err.strip().splitlines()[-1].startswith(
        "jaxga: error: not every process joined at 127.0.0.1:")
    assert "within 5 s (2 processes expected" in err
    assert 5 <= elapsed < 60


def test_a_lost_coordinator_ends_the_other_process(tmp_path):
    """Process 0 (which hosts JAX's coordination service) is killed: JAX's runtime ends
    process 1 at once with a non-zero status (no Python code runs after that)."""
    with _Procs(tmp_path) as procs:
        port = _free_port()
        p0 = procs.start("p0", ["-c", _JOIN_AND_WAIT, f"127.0.0.1:{port}", "0", "30"])
        p1 = procs.start("p1", _cli(*RUN, "--devices", "1", "--coordinator",
                                    f"127.0.0.1:{port}", "--num-processes", "2",
                                    "--process-id", "1", "--process-timeout", "30"))
        procs.wait_for_line("p0", "joined", timeout=120)
        time.sleep(1.0)
        p0.kill()
        killed = time.monotonic()
        rc = procs.wait(p1, timeout=90)
        elapsed = time.monotonic() - killed
        _, err = procs.output("p1")
    assert rc != 0
    assert "distributed service" in err or "coordination service" in err, err[-2000:]
    assert elapsed < 60


def test_importing_jaxga_does_not_start_the_jax_backend():
    """``import jaxga.api.devices; jaxga.api.devices.use_all_cores()`` only works if
    importing jaxga creates no JAX array; afterwards JAX has one CPU device per core."""
    code = ("import os, jax, pkgutil, importlib, jaxga, jaxga._runtime.parallel as par\n"
            "from jax._src import xla_bridge\n"
            "for m in pkgutil.iter_modules(jaxga.__path__):\n"
            "    importlib.import_module('jaxga.' + m.name)\n"
            "assert not xla_bridge.backends_are_initialized()\n"
            "par.use_all_cores()\n"
            "print(jax.local_device_count(), par.cores())\n")
    proc = subprocess.run([sys.executable, "-c", code], env=_env(), cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    have, cores = map(int, proc.stdout.split())
    assert have == cores


def test_a_late_device_request_warns_and_an_explicit_xla_flag_is_kept():
    code = ("import warnings, jax, jax.numpy as jnp, jaxga._runtime.parallel as par\n"
            "assert par.use_all_cores() is None  # the user's XLA_FLAGS is kept\n"
            "jnp.zeros(1)\n"
            "with warnings.catch_warnings(record=True) as w:\n"
            "    warnings.simplefilter('always')\n"
            "    par.set_local_devices(5)\n"
            "print(jax.local_device_count(), len(w), str(w[0].message))\n")
    env = dict(_env(), XLA_FLAGS="--xla_force_host_platform_device_count=3")
    proc = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split()[:2] == ["3", "1"]
    assert "already running with 3 CPU device(s)" in proc.stdout


def test_a_users_device_count_past_the_bound_is_kept_and_said(monkeypatch):
    """XLA_FLAGS or JAX_NUM_CPU_DEVICES asking for 1000 CPU devices on a few cores was
    kept in silence (a run took 54 s instead of 2): it is still kept (the user's JAX), and
    one warning says what it costs. Nothing starts JAX's backend here."""
    from jaxga._runtime import parallel as par
    from jaxga.core.errors import DeviceWarning

    monkeypatch.delenv("JAX_NUM_CPU_DEVICES", raising=False)
    for name, value in (("XLA_FLAGS", "--xla_force_host_platform_device_count=1000"),
                        ("JAX_NUM_CPU_DEVICES", "1000")):
        monkeypatch.delenv("XLA_FLAGS", raising=False)
        monkeypatch.setenv(name, value)
        with pytest.warns(DeviceWarning, match="1000 CPU devices on .* slower, not faster"):
            assert par.set_local_devices(None) is None
    monkeypatch.setenv("JAX_NUM_CPU_DEVICES", str(par.max_cpu_devices()))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", DeviceWarning)
        assert par.set_local_devices(None) is None  # within the bound: nothing said


def test_incomplete_or_malformed_process_options_are_one_line_errors(capsys, monkeypatch):
    from jaxga.cli import main

    assert main([*RUN, "--coordinator", "127.0.0.1:1"]) == 2
    assert capsys.readouterr().err.strip() == (
        "jaxga: error: a multi-process run needs --num-processes, --process-id too (or "
        "JAXGA_COORDINATOR, JAXGA_NUM_PROCESSES, JAXGA_PROCESS_ID)")
    monkeypatch.setenv("JAXGA_NUM_PROCESSES", "two")
    assert main(RUN) == 2
    assert capsys.readouterr().err.strip() == (
        "jaxga: error: JAXGA_NUM_PROCESSES must be an integer in ASCII digits, got 'two'")
    monkeypatch.delenv("JAXGA_NUM_PROCESSES")
    assert main([*RUN, "--coordinator", "nohost", "--num-processes", "2",
                 "--process-id", "2"]) == 2
    assert "need 0 <= process id < number of processes" in capsys.readouterr().err


@pytest.mark.parametrize("timeout", [0.0, -1.0, float("nan"), float("inf"), 1e10])
def test_a_process_timeout_that_jax_cannot_take_is_refused(timeout):
    """Before anything starts: JAX's coordination service takes 32-bit seconds."""
    from jaxga._runtime import parallel
    from jaxga.core.errors import JaxgaError

    with pytest.raises(JaxgaError, match="process timeout must be > 0 s and at most"):
        parallel.initialize("localhost:1", 2, 1, timeout=timeout)
