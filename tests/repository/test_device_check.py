"""benchmarks/device_check.py runs on the CPU as it would on a GPU machine: from the
source tree (``PYTHONPATH=.``), in a process of its own, with every measurement in its
JSON report and the CPU agreeing with itself."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # a process of its own running the whole check

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "device_check.py"


def _run(*args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> tuple[dict, str, Path]:
    """One ``--small --no-write`` run (a budget that skips nothing): its report, its
    output and the report's path."""
    path = tmp_path_factory.mktemp("device_check") / "report.json"
    proc = _run("--small", "--no-write", "--json", str(path), "--budget-s", "3000")
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(path.read_text()), proc.stdout, path


def _positive(*values) -> bool:
    return all(isinstance(v, (int, float)) and v > 0 for v in values)


def test_the_small_check_measures_everything_and_the_cpu_agrees(small):
    report, out, _ = small
    assert report["device"]["platform"] == "cpu"
    for name in ("main job", "sweep", "agreement", "throughput"):
        assert _positive(report["phases"][name])
        assert f"[device check] {name}: " in out  # each phase printed its time
    main = report["main_job"]
    assert main["preset"] == "iga_zhu" and main["seeds"] == 8
    assert _positive(*(main["timing"][k] for k in ("compile_s", "init_s", "evolve_s",
                                                    "post_s", "total_s")))
    assert main["success"] == 1.0 and _positive(main["mean_length"])

    settings = report["settings"]
    rows = report["throughput"]
    assert {(r["preset"], r["map"], r["seeds"]) for r in rows} == {
        (p, m, n) for p in ("sga", "hybrid") for m in settings["maps"]
        for n in settings["seeds"]}
    for r in rows:
        assert r["status"] == "ok", r
        assert _positive(r["compile_s"], r["init_compile_s"], r["run_s"],
                         r["ind_gen_per_s"], r["program_bytes"])

    sweep = report["sweep"]
    assert len(sweep["points"]) == 16 and sweep["runs"] == 16 * settings["sweep_seeds"]
    assert _positive(sweep["runs_per_s"], sweep["evolve_ind_gen_per_s"],
                     sweep["timing"]["compile_s"])

    agreement = report["agreement"]
    assert agreement["agree"] and agreement["bits_identical"]
    assert agreement["evaluation"]["identical"] and agreement["evaluation"]["paths"] > 0
    assert agreement["runs"]["required"]
    assert agreement["runs"]["identical"] == agreement["runs"]["compared"] > 0
    assert [i["preset"] for i in agreement["init"]] == ["sga", "iga_zhu"]
    for i in agreement["init"]:  # on the CPU both sides are the CPU: this runs the code
        assert i["identical"] == i["runs"] == settings["init_runs"]
        assert 0 < i["device_success_rate"] == i["cpu_success_rate"] <= 1

    assert _positive(report["peak_memory"]["bytes"], report["wall_s"])
    assert "RSS" in report["peak_memory"]["source"]
    assert "## device check on the CPU (" in out  # the section names the device


def test_a_report_from_elsewhere_renders_its_section(small):
    """``--from-json`` (what a GPU machine's report comes back as) renders the same
    section, with the machine and commit the report measured."""
    report, _, path = small
    proc = _run("--from-json", str(path), "--no-write", timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert f"## device check on {report['device']['name']}" in proc.stdout
    assert f"- machine: {report['machine']}" in proc.stdout
    assert "| sga | 20x20 |" in proc.stdout and "**agree**" in proc.stdout
    sweep = report["sweep"]
    assert f"{sweep['calls']} call(s) of {sweep['runs_per_call']} runs" in proc.stdout


def test_a_report_cut_short_says_what_it_did_not_measure(small, tmp_path):
    """A run ended by its time limit after the main job (as on a GPU lent for minutes):
    the phases it did not reach are 'not measured', the agreement 'unknown', never a
    verdict. The phases run in the order main job, agreement, sweep, throughput."""
    report, out, _ = small
    order = [out.index(f"[device check] {name} ...") for name in
             ("main job", "agreement", "sweep", "throughput")]
    assert order == sorted(order)
    cut = {k: v for k, v in report.items() if k in ("command", "commit", "date", "machine",
                                                     "python", "device", "settings",
                                                     "main_job")}
    cut["phases"] = {"main job": report["phases"]["main job"]}
    path = tmp_path / "cut.json"
    path.write_text(json.dumps(cut))
    proc = _run("--from-json", str(path), "--no-write", timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "**Agreement with the CPU**: not measured" in proc.stdout
    assert "**unknown**" in proc.stdout and "AGREE" not in proc.stdout
    assert "**Sweep** (" in proc.stdout and "16 values" in proc.stdout
    assert proc.stdout.count("not measured (the run ended before this phase)") == 3
    assert "the run ended there (a partial report)" in proc.stdout
    sweep = report["sweep"]
    assert sweep["runs_per_call"] * sweep["calls"] >= sweep["runs"]


@pytest.mark.parametrize(("args", "message"), [
    (["--budget-s", "-5"], "--budget-s must be a positive number"),
    (["--budget-s", "soon"], "invalid float value"),
    (["--json", "/no/such/folder/r.json"], "does not exist or is not writable"),
    (["--from-json", "/no/such/report.json"], "not a complete device check report"),
    (["--max-runs-per-call", "3000"], "must be a power of two from 2048"),
    (["--max-runs-per-call", "1024"], "must be a power of two from 2048"),
])
def test_bad_input_is_one_line(args, message):
    proc = _run(*args, timeout=120)
    assert proc.returncode != 0
    assert proc.stderr.count("\n") == 1 and message in proc.stderr, proc.stderr
