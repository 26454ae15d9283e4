"""``jaxga doctor`` and the device gate (docs/devices.md, "Exactness"): the probes agree
on the CPU; a backend made to disagree (a test double that corrupts what the device
computed, or a stand-in device whose probe fails) is named in one line, refused by the
runs unless ``JAXGA_TRUST_DEVICE=1``, and its verdict is remembered."""

from __future__ import annotations

import dataclasses
import json

import jax
import jaxlib
import numpy as np
import pytest

import jaxga
from jaxga._runtime import device_probe, programs
from jaxga._runtime.device_probe import DeviceDisagrees, ProbeRow, check_backend
from jaxga.api import runs
from jaxga.api.doctor import runs_off_tolerance
from jaxga.cli.entry import main
from jaxga.cli.options import EXIT_DEVICE_DISAGREES
from jaxga.core.errors import PlatformWarning
from tests import canonical


@dataclasses.dataclass(frozen=True)
class StandIn:
    """A device as the gate reads one: a platform other than the CPU."""

    platform: str = "gpu"
    device_kind: str = "Test GPU"


def failing(device) -> list[ProbeRow]:
    return [ProbeRow("random bits", 2048, 0, True, 0.1),
            ProbeRow("sga walks (2048 runs x 4)", 2048, 97, False, 0.2,
                     detail="success 0.04% (CPU 2.58%)")]


def never(device) -> list[ProbeRow]:
    raise AssertionError("probed again: the verdict was not remembered")


@pytest.fixture
def verdicts(tmp_path, monkeypatch):
    """A fresh file of remembered verdicts, and none in the process."""
    path = tmp_path / "verdicts.json"
    monkeypatch.setenv(device_probe.VERDICTS_ENV, str(path))
    monkeypatch.delenv(device_probe.TRUST_ENV, raising=False)
    monkeypatch.setattr(device_probe, "_CHECKED", {})
    return path


def corrupt_device_side(monkeypatch) -> None:
    """A backend that loses a write: the device's side of every probe has one bit
    flipped in one run."""
    compare = device_probe._compare

    def lossy(fn, keys, device):
        here, there = compare(fn, keys, device)
        here = [x.copy() for x in here]
        here[0].reshape(here[0].shape[0], -1)[3, 0] ^= 1
        return here, there

    monkeypatch.setattr(device_probe, "_compare", lossy)


def test_the_exact_probes_agree_on_the_cpu():
    report = jaxga.doctor(presets=(), runs=256)
    assert report.agrees and [r.name for r in report.rows] == [
        "random bits", "sga walks (256 runs x 4)", "field walks (256 runs x 4)"]
    assert all(r.exact and r.differ == 0 and r.compared == 256 for r in report.rows)
    assert report.verdict == (
        f"cpu (cpu, jaxlib {jaxlib.__version__}): agrees with the CPU (3 probes)")
    walks = report.rows[2]
    assert walks.detail == "success 100.00% (CPU 100.00%)"  # the field walk cannot fail


def test_a_backend_that_loses_a_write_is_named_in_one_line(monkeypatch):
    corrupt_device_side(monkeypatch)
    report = jaxga.doctor(presets=(), runs=64)
    assert not report.agrees
    assert [r.differ for r in report.rows] == [1, 1, 1]
    assert "\n" not in report.verdict
    assert report.verdict.endswith(
        "DISAGREES: random bits: 1 of 64 runs differ from the CPU's")


def test_the_command_prints_a_table_and_the_verdict_last(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(device_probe, "RUNS", 256)  # the command's probes, smaller
    out = tmp_path / "doctor.json"
    assert main(["doctor", "--quick", "--json", str(out)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert "agrees with the CPU (3 probes)" in lines[-1]
    assert any(line.startswith("sga walks (256 runs x 4)") and " ok " in line
               for line in lines)
    doc = json.loads(out.read_text())
    assert doc["agrees"] is True and len(doc["probes"]) == 3
    corrupt_device_side(monkeypatch)
    assert main(["doctor", "--quick"]) == EXIT_DEVICE_DISAGREES
    assert "DISAGREES: random bits" in capsys.readouterr().out.strip().splitlines()[-1]


def test_the_gate_does_nothing_on_the_cpu(verdicts):
    check_backend(jax.devices("cpu")[0], probes=never)
    assert not verdicts.exists()


def test_the_gate_refuses_a_failed_backend_remembers_and_can_be_overridden(
        verdicts, monkeypatch):
    with pytest.raises(DeviceDisagrees) as err:
        check_backend(StandIn(), probes=failing)
    line = str(err.value)
    assert "\n" not in line and "DISAGREES: sga walks (2048 runs x 4): 97 of 2048" in line
    assert "jaxga doctor" in line and "JAXGA_TRUST_DEVICE=1" in line
    saved = json.loads(verdicts.read_text())
    assert [v["agrees"] for v in saved.values()] == [False]
    monkeypatch.setattr(device_probe, "_CHECKED", {})  # a new process: read, not probed
    with pytest.raises(DeviceDisagrees):
        check_backend(StandIn(), probes=never)
    monkeypatch.setenv(device_probe.TRUST_ENV, "1")
    with pytest.warns(PlatformWarning, match="failed jaxga's probe"):
        check_backend(StandIn(), probes=never)


def test_a_backend_that_passed_is_not_probed_again(verdicts, monkeypatch):
    check_backend(StandIn(device_kind="Good GPU"), probes=lambda d: failing(d)[:1])
    monkeypatch.setattr(device_probe, "_CHECKED", {})
    check_backend(StandIn(device_kind="Good GPU"), probes=never)
    with pytest.raises(DeviceDisagrees):  # another kind of device: probed on its own
        check_backend(StandIn(device_kind="Other GPU"), probes=failing)


def test_the_first_verdict_on_a_fresh_machine_creates_its_folder(verdicts, monkeypatch):
    fresh = verdicts.parent / "home" / ".cache" / "jaxga" / "device_verdicts.json"
    monkeypatch.setenv(device_probe.VERDICTS_ENV, str(fresh))
    check_backend(StandIn(device_kind="Good GPU"), probes=lambda d: failing(d)[:1])
    assert [v["agrees"] for v in json.loads(fresh.read_text()).values()] == [True]


def test_a_run_on_a_failed_backend_is_refused_in_one_line(verdicts, monkeypatch, capsys):
    monkeypatch.setattr(programs, "check_backend",
                        lambda: check_backend(StandIn(), probes=failing))
    rc = main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seeds", "2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == EXIT_DEVICE_DISAGREES
    assert len(err) == 1 and err[0].startswith("jaxga: error: gpu (Test GPU, jaxlib ")
    assert "refusing to compute there" in err[0]


def test_the_first_run_on_a_new_device_kind_shows_the_probe_as_a_phase(verdicts,
                                                                        monkeypatch):
    """A stand-in GPU that passes: the run reports a ``device-probe`` stage before it
    compiles (stopped there: the program set's own check finds the verdict)."""
    passing = StandIn(device_kind="Good GPU")

    class Stop(Exception):
        pass

    def stop():
        assert device_probe._CHECKED  # the probe ran, as a phase of its own, before
        raise Stop

    monkeypatch.setattr(runs, "needs_probe", lambda: device_probe.needs_probe(passing))
    monkeypatch.setattr(runs, "check_backend",
                        lambda: check_backend(passing, probes=lambda d: failing(d)[:1]))
    monkeypatch.setattr(programs, "check_backend", stop)
    stages = []
    with pytest.raises(Stop):
        canonical.run("sga", progress=lambda stage, frac: stages.append(stage))
    assert stages.index("device-probe") < stages.index("compile")
    assert not device_probe.needs_probe(passing)  # remembered: not shown again


def test_probe_rows_compare_every_bit_of_every_leaf():
    a = [np.zeros((3, 2), np.float32), np.zeros(3, np.int32)]
    b = [x.copy() for x in a]
    b[0][1, 1] = -0.0  # equal as numbers, another bit pattern
    assert list(device_probe.differing(a, b)) == [False, True, False]


@pytest.mark.slow  # a whole GA compiled for the check
def test_whole_runs_agree_on_the_cpu_with_a_throughput_figure():
    report = jaxga.doctor(presets=["hybrid"], runs=64)
    row = report.rows[-1]
    assert report.agrees and row.name == "hybrid runs (10 generations)"
    assert row.exact and row.compared == 4 and row.detail == "identical 4/4"
    assert report.throughput == 0.0  # sga's runs give it; not asked for here
    assert json.loads(json.dumps(report.as_dict()))["probes"][-1]["name"] == row.name


def test_off_the_cpu_a_run_must_have_the_cpus_success_a_clear_path_and_its_length():
    """The rule for whole runs that may round differently (docs/devices.md): hand-made
    runs on a 3 x 3 map with its centre blocked, checked as the doctor checks a GPU's."""
    grid = jaxga.Grid.create(np.array([[0, 0, 0], [0, 1, 0], [0, 0, 0]], bool),
                             start=(0, 0), goal=(2, 2))
    cells = np.array([[0, 1, 2, 5, 8], [0, 1, 2, 5, 8], [0, 1, 2, 5, 8], [0, 4, 8, 8, 8],
                      [0, 0, 0, 0, 0]], np.int32)
    here = {"cells": cells, "n_cells": np.array([5, 5, 5, 3, 1], np.int32),
            "success": np.array([1, 1, 1, 1, 0], np.int32),
            "length": np.array([4.0, 4.0, 4.04, 2 * np.sqrt(2), 0.0], np.float32)}
    there = {"success": np.array([1, 0, 1, 1, 0], np.int32)}
    # 0: agrees; 1: the CPU's run failed; 2: its length is 1 % off; 3: through the
    # blocked centre; 4: failed on both (its cells are not looked at)
    assert list(runs_off_tolerance(grid, here, there)) == [False, True, True, True, False]


def test_presets_are_checked_before_any_probe(monkeypatch, capsys):
    """An unknown preset was refused only after the probes had run; with --quick it was
    not looked at (exit 0), and an empty --presets meant every preset."""
    from jaxga._runtime import device_probe
    from jaxga.cli import EXIT_BAD_INPUT, main
    from jaxga.core.errors import ParameterError

    monkeypatch.setattr(device_probe, "probe", lambda *a, **k: pytest.fail("a probe ran"))
    with pytest.raises(ParameterError, match="unknown preset 'nonexist'"):
        jaxga.doctor(presets=["sga", "nonexist"])
    with pytest.raises(ParameterError, match="presets must be a list of preset names"):
        jaxga.doctor(presets="sga")
    for argv, words in ((["--presets", "nonexist", "--quick"], "which --quick leaves out"),
                        (["--presets", ","], "--presets names no preset"),
                        (["--presets", "nonexist"], "unknown preset 'nonexist'")):
        assert main(["doctor", *argv]) == EXIT_BAD_INPUT
        assert words in capsys.readouterr().err
