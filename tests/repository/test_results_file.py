"""benchmarks/_results.py keeps every run in history/results.jsonl and RESULTS.md as its
rendering: one section per title and script command, the latest record of each, a
retired section gone; the committed RESULTS.md is that rendering."""

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


def _rec(title: str, command: str, body: str, **extra) -> dict:
    return {"title": title, "command": command, "commit": "abc1234",
            "date": "2026-01-01 00:00 UTC", "machine": "m", "body": body, **extra}


def _shown(history: list[dict]) -> list[tuple[str, str, str]]:
    return [(s["title"], _results.script_command(s["command"]), s["body"])
            for s in _results.current_sections(history)]


def test_the_latest_record_of_a_section_wins_in_place_and_scripts_are_ordered():
    history = [_rec("speed", "python benchmarks/speed.py --seeds 1", "old"),
               _rec("zhu", "python zhu_table4.py", "z"),
               _rec("speed", "python speed.py --seeds 100", "hundred"),
               _rec("anatomy", "python compile_anatomy.py", "a"),
               _rec("speed", "/x/python /y/speed.py --seeds 1", "new")]
    assert _shown(history) == [("anatomy", "compile_anatomy.py", "a"),
                               ("speed", "speed.py --seeds 1", "new"),
                               ("speed", "speed.py --seeds 100", "hundred"),
                               ("zhu", "zhu_table4.py", "z")]


def test_a_retired_section_disappears_and_a_later_run_brings_it_back_last():
    history = [_rec("speed", "python speed.py --seeds 1", "one"),
               _rec("speed", "python speed.py --seeds 100", "hundred"),
               {"title": "speed", "command": "python speed.py --seeds 1",
                "retired": "superseded", "retired_on": "2026-01-02 00:00 UTC"}]
    assert _shown(history) == [("speed", "speed.py --seeds 100", "hundred")]
    history.append(_rec("speed", "python speed.py --seeds 1", "again"))
    assert _shown(history) == [("speed", "speed.py --seeds 100", "hundred"),
                               ("speed", "speed.py --seeds 1", "again")]


def test_an_edited_record_shows_its_text_and_the_run_it_edits():
    run = _rec("speed", "python speed.py", "table")
    edited = {**run, "body": "table\n\nA note.", "edited": "a note added after the run",
              "edited_on": "2026-01-03 00:00 UTC"}
    assert _results.current_sections([run, edited]) == [{**run, "body": "table\n\nA note."}]


def test_record_renders_the_whole_file_from_the_history(recorder):
    rec, results, history = recorder
    rec(["benchmarks/speed.py"], "speed", "first")
    results.write_text(results.read_text() + "\na hand edit\n")
    rec(["benchmarks/feasibility.py"], "feasibility", "table F")
    assert results.read_text() == _results.render_history(_results.read_history(history))
    assert "a hand edit" not in results.read_text()
    assert not list(results.parent.glob(".RESULTS.md.*"))  # no temporary file left


def test_retire_and_amend_append_to_the_history(recorder):
    rec, results, history = recorder
    rec(["benchmarks/speed.py", "--seeds", "1"], "speed", "one")
    rec(["benchmarks/speed.py", "--seeds", "9"], "speed", "nine")
    sec = _results.parse_sections(results.read_text())[1][0]
    amended = _results.amend("speed", "speed.py --seeds 1", "one, corrected", "a typo",
                             results=results, history=history)
    assert {k: amended[k] for k in _results.SECTION} == {**sec, "body": "one, corrected"}
    assert amended["edited"] == "a typo" and amended["edited_on"].endswith("UTC")
    _results.retire("speed", "python x/speed.py --seeds 9", "superseded",
                    results=results, history=history)
    assert [s["body"] for s in _results.parse_sections(results.read_text())[1]] \
        == ["one, corrected"]
    assert json.loads(history.read_text().splitlines()[-1])["retired"] == "superseded"
    with pytest.raises(ValueError, match="no current section"):
        _results.retire("speed", "speed.py --seeds 9", "twice", results=results,
                        history=history)
    with pytest.raises(ValueError, match="reason"):
        _results.amend("speed", "speed.py --seeds 1", "x", " ", results=results,
                       history=history)


def test_check_names_what_a_hand_edit_changed(recorder):
    rec, results, history = recorder
    rec(["benchmarks/speed.py"], "speed", "table")
    rec(["benchmarks/zhu_table4.py"], "zhu", "z")
    assert _results.check_results(results, history) == ""
    results.write_text(results.read_text().replace("table", "table, and a note"))
    message = _results.check_results(results, history)
    assert len(message.splitlines()) == 1
    assert '1 section(s) differ from their last record: "speed" (speed.py)' in message
    assert "record the benchmark again" in message


def test_the_render_command_writes_and_checks(recorder, monkeypatch, capsys):
    rec, results, history = recorder
    rec(["benchmarks/speed.py"], "speed", "table")
    monkeypatch.setattr(_results, "RESULTS", results)
    monkeypatch.setattr(_results, "HISTORY", history)
    assert _results.main(["render", "--check"]) == 0
    results.write_text("edited by hand\n")
    assert _results.main(["render", "--check"]) == 1
    assert "not the rendering" in capsys.readouterr().err
    assert _results.main(["render"]) == 0
    assert _results.main(["render", "--check"]) == 0


def test_the_committed_results_file_is_the_rendering_of_the_committed_history():
    message = _results.check_results(_results.RESULTS, _results.HISTORY)
    assert not message, message
