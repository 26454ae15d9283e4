"""benchmarks/_results.py keeps RESULTS.md as current results: one section per script
command, replaced in place, with every run appended to the history file."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import _results  # noqa: E402


@pytest.fixture
def recorder(tmp_path, monkeypatch):
    results, history = tmp_path / "RESULTS.md", tmp_path / "history" / "results.jsonl"
    monkeypatch.setattr(_results, "machine", lambda: "test machine")

    def rec(argv: list[str], title: str, body: str) -> None:
        monkeypatch.setattr(sys, "argv", argv)
        _results.record(title, body, results=results, history=history)

    return rec, results, history


def test_script_command_drops_interpreter_and_paths():
    assert _results.script_command("PYTHONPATH=. /x/bin/python benchmarks/speed.py --seeds 1") \
        == "speed.py --seeds 1"
    assert _results.script_command("python speed.py") == "speed.py"


def test_a_rerun_replaces_its_section_and_keeps_the_others(recorder):
    rec, results, history = recorder
    rec(["benchmarks/speed.py", "--seeds", "1"], "speed", "| a |\n|---|\n| 1 |")
    rec(["benchmarks/speed.py", "--seeds", "100"], "speed", "hundred")
    rec(["benchmarks/feasibility.py"], "feasibility", "table F")
    rec(["/other/path/speed.py", "--seeds", "1"], "speed", "| a |\n|---|\n| 2 |")
    header, sections = _results.parse_sections(results.read_text())
    assert header.startswith("# Benchmark results")
    # ordered by script; the re-run took the place of its first run, which is gone
    assert [(s["title"], _results.script_command(s["command"]), s["body"])
            for s in sections] == [
        ("feasibility", "feasibility.py", "table F"),
        ("speed", "speed.py --seeds 1", "| a |\n|---|\n| 2 |"),
        ("speed", "speed.py --seeds 100", "hundred"),
    ]
    assert all(s["machine"] == "test machine" and s["date"].endswith("UTC")
               and s["commit"] for s in sections)
    runs = [json.loads(line) for line in history.read_text().splitlines()]
    assert [r["body"] for r in runs] == ["| a |\n|---|\n| 1 |", "hundred", "table F",
                                         "| a |\n|---|\n| 2 |"]


def test_render_and_parse_are_inverse():
    sec = {"title": "t", "command": "python x.py --a 1", "commit": "abc1234+changes",
           "date": "2026-01-01 00:00 UTC", "machine": "m",
           "body": "- a bullet that is not metadata\n\n### sub\n\ntext"}
    header, sections = _results.parse_sections(_results.render(_results.RESULTS_HEADER, [sec]))
    assert sections == [sec]
    assert header.strip() == _results.RESULTS_HEADER.strip()


def test_a_body_with_a_section_heading_is_refused(recorder):
    rec, results, _ = recorder
    with pytest.raises(ValueError, match="level-2 heading"):
        rec(["x.py"], "t", "text\n## not allowed")
    assert not results.exists()
