"""The ``jaxga`` command line: optimum JSON and one-line errors for bad input."""

from __future__ import annotations

import argparse
import io
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from jaxga.cli import EXIT_BAD_INPUT, EXIT_NO_PATH, check_outputs, main


def test_optimum_json_on_builtin_map(tmp_path, capsys):
    out = tmp_path / "opt.json"
    rc = main(["optimum", "--map", "classic_ga_gapp3_20x20", "--corner-rule", "free",
               "--json", str(out)])
    assert rc == 0
    data = json.loads(out.read_text())
    assert data["length"] == pytest.approx(30.9706, abs=1e-4)  # classic README, Zhu Map 3
    assert data["path"][0] == [0, 0] and data["path"][-1] == [19, 19]
    assert data["any_angle_path"][0] == [0, 0] and data["any_angle_path"][-1] == [19, 19]
    assert data["any_angle_length"] <= data["length"] + 1e-9
    assert "30.9706" in capsys.readouterr().out


def test_optimum_of_a_presets_fitness(tmp_path, capsys):
    out = tmp_path / "opt.json"
    assert main(["optimum", "--map", "routeplanning_yangbo_20x20", "--preset", "iga_zhu",
                 "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["corner_rule"] == "free"  # the preset's, as `jaxga run` takes it
    fit = data["fitness"]
    assert fit["found"] and fit["method"] == "iga_zhu" and fit["loop_free"]
    assert fit["length"] == pytest.approx(31.5563, abs=1e-4)
    assert fit["length"] > data["length"]  # longer than the shortest path
    assert fit["path"][0] == [0, 0] and fit["path"][-1] == [19, 19]
    assert "a path of length 31.5563" in capsys.readouterr().out
    # --set changes the weights: omega = 1 is the length alone
    assert main(["optimum", "--map", "routeplanning_yangbo_20x20", "--preset", "iga_zhu",
                 "--set", "fitness.omega=1", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["fitness"]["length"] == pytest.approx(data["length"])
    assert main(["optimum", "--map", "classic_ga_gapp3_20x20", "--preset", "agacd",
                 "--json", str(out)]) == 0
    fit = json.loads(out.read_text())["fitness"]
    assert not fit["found"] and fit["value"] is None and "waypoint" in fit["reason"]
    assert "not computed" in capsys.readouterr().out
    # a user file is checked as `jaxga run` checks it: a key sga never reads is refused
    mine = tmp_path / "mine.toml"
    mine.write_text('base = "sga"\n[mutation]\npm_high = 0.3\n')
    assert main(["optimum", "--map", "classic_ga_gapp3_20x20", "--preset",
                 str(mine)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "mutation.pm_high" in err and "\n" not in err


def test_optimum_shows_each_phase_and_a_long_one_as_it_runs(monkeypatch, capsys):
    """`jaxga optimum` names each phase on its progress as it starts (a long search
    on a large map printed nothing until it ended), with the ticking thread started and
    stopped; --quiet shows none."""
    from jaxga.cli import optimum as cli_optimum

    seen = []

    class Recorder:
        def __init__(self):
            seen.append("new")

        def start(self):
            seen.append("start")
            return self

        def __call__(self, stage, frac):
            if not seen or seen[-1] != stage:
                seen.append(stage)

        def close(self):
            seen.append("close")

    monkeypatch.setattr(cli_optimum, "Progress", Recorder)
    assert main(["optimum", "--map", "routeplanning_yangbo_20x20", "--preset",
                 "iga_zhu"]) == 0
    # closed before the results are printed (a terminal's bar line ended), and again
    # at the end (nothing more)
    assert seen == ["new", "start", "load", "8-connected", "any-angle", "fitness", "close",
                    "close"]
    seen.clear()
    assert main(["optimum", "--map", "routeplanning_yangbo_20x20", "--quiet"]) == 0
    assert seen == []
    capsys.readouterr()


def test_front_point_with_a_preset_that_keeps_no_front_is_refused(capsys):
    """--front-point chooses a point of a front: with sga (one best path a seed) it did
    nothing, without a word."""
    assert main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20",
                 "--front-point", "knee", "--seeds", "2", "--quiet"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--front-point chooses a point of a front, and preset " \
        "'sga' keeps none" in err


@pytest.mark.parametrize("argv, meant", [
    (["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seed", "42"],
     "--seeds"),  # argparse alone ran 42 runs of seeds 0-41 for this
    (["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--gen=4"],
     "--generations"),
    (["optimum", "--map", "classic_ga_gapp3_20x20", "--bud", "3"], "--budget"),
    (["optimum", "--map", "classic_ga_gapp3_20x20", "--seed", "4"], None),  # run's option
])
def test_an_abbreviated_option_is_refused_naming_the_whole_one(argv, meant, capsys):
    """Refused, naming the options of the command given that the word begins (none where
    only another command has one)."""
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == EXIT_BAD_INPUT and err.count("\n") == 1
    assert err.startswith("jaxga: error: unrecognized arguments: ")
    if meant is None:
        assert "did you mean" not in err
    else:
        assert f"; did you mean {meant}?" in err


def test_optimum_uses_file_endpoints_and_overrides(tmp_path):
    art = tmp_path / "m.txt"
    art.write_text("S..#\n.#..\n...G\n")  # top row first
    out = tmp_path / "o.json"
    assert main(["optimum", "--map", str(art), "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["start"] == [0, 2] and data["goal"] == [3, 0]
    assert main(["optimum", "--map", str(art), "--start", "0,0", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["path"][0] == [0, 0]


def test_scenario_gives_the_endpoints_of_a_moving_ai_problem(tmp_path, capsys):
    """--scenario N takes problem N's start and goal (y converted from the file's top-down
    count): on a built-in map from its own .scen, whose optimal length the exact
    optimum then equals (strict rule); beside a map file (X.map.scen) or with --scen."""
    import shutil

    from jaxga.maps import builtin_scenarios
    from jaxga.maps.builtin import builtin_path

    out = tmp_path / "o.json"
    problem = builtin_scenarios("maze-32-32-2")[3]
    assert main(["optimum", "--map", "maze-32-32-2", "--corner-rule", "strict",
                 "--scenario", "3", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["start"] == list(problem.start) and data["goal"] == list(problem.goal)
    assert data["length"] == pytest.approx(problem.optimal_length, abs=1e-6)
    capsys.readouterr()
    # a map file with its scenario file beside it, then the same problem by --scen
    m = tmp_path / "maze.map"
    shutil.copy(builtin_path("maze-32-32-2"), m)
    (tmp_path / "maze.map.scen").write_text(
        "version 1\n3\tmaze.map\t32\t32\t11\t17\t3\t10\t15.24264069\n")
    for extra in ([], ["--scen", str(tmp_path / "maze.map.scen")]):
        assert main(["optimum", "--map", str(m), "--corner-rule", "strict",
                     "--scenario", "0", "--json", str(out), *extra]) == 0
        data = json.loads(out.read_text())
        assert data["start"] == [11, 31 - 17] and data["goal"] == [3, 31 - 10]
        # a note names the file and the problem
        assert capsys.readouterr().err == (
            "scenario 0 of maze.map.scen: (11, 14) -> (3, 21), optimal length 15.2426 "
            "without corner cutting\n")


@pytest.mark.parametrize("extra, words", [
    (["--scenario", "333"], "has problems 0 .. 332"),
    (["--scenario", "-1"], "has problems 0 .. 332"),
    (["--scen", "x.scen"], "give N too"),
    (["--scenario", "1", "--goal", "1,1"], "leave out --start and --goal"),
    (["--scenario", "1", "--scen", "missing.scen"], "scenario file not found"),
])
def test_bad_scenario_options_are_one_line(extra, words, capsys):
    rc = main(["optimum", "--map", "maze-32-32-2", *extra])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_BAD_INPUT and words in err and "\n" not in err


def test_a_scenario_of_another_map_size_or_a_map_without_one_is_refused(tmp_path, capsys):
    scen = tmp_path / "big.scen"
    scen.write_text("version 1\n0\tbig.map\t64\t64\t1\t1\t2\t2\t1.41421356\n")
    assert main(["optimum", "--map", "maze-32-32-2", "--scenario", "0", "--scen",
                 str(scen)]) == EXIT_BAD_INPUT
    assert "is for a 64 x 64 map (big.map), maze-32-32-2 is 32 x 32" in capsys.readouterr().err
    assert main(["optimum", "--map", "classic_ga_gapp3_20x20", "--scenario", "0"]) \
        == EXIT_BAD_INPUT
    assert "no scenario file for classic_ga_gapp3_20x20" in capsys.readouterr().err
    art = tmp_path / "m.txt"
    art.write_text("000\n000\n")
    assert main(["optimum", "--map", str(art), "--scenario", "0"]) == EXIT_BAD_INPUT
    assert "X.map.scen or X.scen beside X.map): give --scen" in capsys.readouterr().err
    # a missing map is named as such, not as a missing scenario file
    assert main(["optimum", "--map", str(tmp_path / "gone.map"), "--scenario", "0"]) \
        == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "gone.map: map file not found" in err and "scenario file" not in err
    (tmp_path / "m.scen").write_text("version 1\n")
    assert main(["optimum", "--map", str(art), "--scenario", "0"]) == EXIT_BAD_INPUT
    assert "m.scen has no problems" in capsys.readouterr().err


def test_scenario_files_beside_a_map_are_found_in_moving_ai_order(tmp_path):
    """X-random-N.scen with the smallest N (2 before 10), then X.map.scen, then X.scen."""
    from jaxga.maps import scenario_path

    m = tmp_path / "x.map"
    assert scenario_path(m) is None
    for name in ("x.scen", "x.map.scen", "x-random-10.scen", "x-random-2.scen"):
        (tmp_path / name).write_text("version 1\n")
    order = []
    while (found := scenario_path(m)) is not None:
        order.append(found.name)
        found.unlink()
    assert order == ["x-random-2.scen", "x-random-10.scen", "x.map.scen", "x.scen"]
    assert scenario_path("maze-32-32-2").name == "maze-32-32-2-random-1.scen"


@pytest.mark.parametrize(
    "args, code, words",
    [
        (["--map", "does-not-exist.txt"], EXIT_BAD_INPUT, "not found"),
        (["--map", "classic_ga_gapp3_20x20", "--start", "20,0"], EXIT_BAD_INPUT, "off the"),
        (["--map", "classic_ga_gapp3_20x20", "--start", "-1,0"], EXIT_BAD_INPUT, "(-1, 0)"),
        (["--map", "classic_ga_gapp3_20x20", "--goal", "-3,-4"], EXIT_BAD_INPUT, "(-3, -4)"),
        (["--map", "random-32-32-20"], EXIT_BAD_INPUT, "blocked"),
        (["--map", "classic_ga_gapp3_20x20", "--corner-rule", "loose"], EXIT_BAD_INPUT,
         "corner rule"),
        (["--map", "classic_ga_gapp3_20x20", "--set", "fitness.omega=1"], EXIT_BAD_INPUT,
         "need --preset"),
        (["--map", "classic_ga_gapp3_20x20", "--preset", "iga_zhu", "--set",
          "fitness.omega=-1"], EXIT_BAD_INPUT, "fitness.omega"),
        (["--map", "classic_ga_gapp3_20x20", "--preset", "sga", "--set",
          "fitness.omega=0.5"], EXIT_BAD_INPUT, "fitness.omega has no effect in 'sga'"),
        (["--map", "classic_ga_gapp3_20x20", "--preset", "sga", "--set",
          "generations=3"], EXIT_BAD_INPUT, "reads only the fitness keys and map.corner_rule"),
        (["--map", "classic_ga_gapp3_20x20", "--preset", "sga", "--corner-rule", "free",
          "--set", "map.corner_rule=strict"], EXIT_BAD_INPUT, "two corner rules given"),
    ],
)
def test_bad_input_is_one_line(args, code, words, capsys):
    assert main(["optimum", *args]) == code
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and words in err and "Traceback" not in err


def test_unreachable_goal_and_malformed_file(tmp_path, capsys):
    walled = tmp_path / "walled.txt"
    walled.write_text("S.#.\n..#G\n")
    assert main(["optimum", "--map", str(walled)]) == EXIT_NO_PATH
    assert "unreachable" in capsys.readouterr().err
    ragged = tmp_path / "ragged.txt"
    ragged.write_text("0 0 1\n0 1\n")
    assert main(["optimum", "--map", str(ragged)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "ragged.txt" in err and "\n" not in err


def test_run_with_an_unreachable_goal_reports_no_path(tmp_path, capsys):
    """`jaxga run` on a map whose goal cannot be reached: the summary, the JSON and the
    plot are still written, then "no path" with the cause and exit code 3."""
    walled = tmp_path / "walled.txt"
    walled.write_text("G#\n#S\n")  # the only move is a diagonal between two obstacles
    out, png = tmp_path / "out.json", tmp_path / "out.png"
    rc = main(["run", "--preset", "sga", "--map", str(walled), "--corner-rule", "strict",
               "--seeds", "2", "--generations", "3", "--quiet", "--json", str(out),
               "--plot", str(png)])
    captured = capsys.readouterr()
    assert rc == EXIT_NO_PATH
    assert "success 0/2" in captured.out and "Traceback" not in captured.err
    assert captured.err.strip().startswith("jaxga: no path:")
    assert "unreachable" in captured.err and "strict" in captured.err
    runs = json.loads(out.read_text())["runs"]
    assert [r["success"] for r in runs] == [False, False]
    assert all(r["path"] == [] and r["length"] is None for r in runs)
    assert png.stat().st_size > 0


def test_run_refuses_a_set_that_nothing_reads(capsys):
    """`--set` of a key the preset never reads is refused before anything compiles, with
    the reason (AGACD's rates are adaptive), not silently ignored."""
    rc = main(["run", "--preset", "agacd", "--map", "classic_ga_gapp3_20x20", "--seeds",
               "2", "--generations", "3", "--quiet", "--set", "crossover.probability=0.9"])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_BAD_INPUT and "\n" not in err
    assert "crossover.probability has no effect in 'agacd': crossover.adaptive = true" in err


def test_population_capacity_and_the_reference_budget_reach_the_run(capsys, monkeypatch):
    """--population-capacity is passed to jaxga.run (to repeat a DOE point's runs), and a
    capacity below the population is refused before anything compiles; --no-reference
    and --exact-optimum set the any-angle budget (0: skipped; None: no limit)."""
    import jaxga.api

    seen = {}

    class Stop(Exception):
        pass

    def fake_run(*args, **kwargs):
        seen.update(kwargs)
        raise Stop

    argv = ["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seeds", "2",
            "--generations", "3", "--quiet", "--set", "population.size=8"]
    monkeypatch.setattr(jaxga.api, "run", fake_run)
    with pytest.raises(Stop):
        main([*argv, "--population-capacity", "12"])
    assert seen["population_capacity"] == 12 and seen["any_angle_budget"] == "auto"
    with pytest.raises(Stop):  # references skipped: a budget of 0
        main([*argv, "--no-reference"])
    assert seen["any_angle_budget"] == 0.0
    with pytest.raises(Stop):
        main([*argv, "--exact-optimum"])
    assert seen["any_angle_budget"] is None
    with pytest.raises(SystemExit) as both:
        main([*argv, "--exact-optimum", "--no-reference"])
    assert both.value.code == EXIT_BAD_INPUT and "not allowed with" in capsys.readouterr().err
    monkeypatch.undo()
    assert main([*argv, "--population-capacity", "4"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "population_capacity 4 is below the largest population.size (8)" in err
    assert "\n" not in err


def test_size_class_reaches_run_compare_and_warmup(monkeypatch):
    """--size-class / --no-size-class of jaxga run, compare and warmup are passed on
    (None without either: the default, which pads maps over 64 a side)."""
    import jax

    import jaxga.api
    import jaxga.cli.compare
    import jaxga.cli.warmup

    seen = []

    class Stop(Exception):
        pass

    def fake(*args, **kwargs):
        seen.append(kwargs["size_class"])
        raise Stop

    monkeypatch.setattr(jaxga.api, "run", fake)
    monkeypatch.setattr(jaxga.cli.compare, "compare", fake)
    monkeypatch.setattr(jaxga.cli.warmup, "warmup", fake)
    monkeypatch.setattr(jax.config, "update", lambda *a: None)  # warmup's cache switch
    commands = (["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--quiet"],
                ["compare", "--presets", "sga,imga", "--map", "classic_ga_gapp3_20x20",
                 "--quiet"],
                ["warmup", "--presets", "sga", "--sizes", "32"])
    for argv in commands:
        for flag in ([], ["--size-class"], ["--no-size-class"]):
            with pytest.raises(Stop):
                main([*argv, *flag])
    assert seen == [None, True, False] * 3


@pytest.mark.parametrize("option, name, words", [
    ("--plot", "out.xyz", "'xyz' is not an image format"),
    ("--plot", "missing/out.png", "does not exist"),
    ("--json", "missing/out.json", "does not exist"),
])
def test_output_paths_are_checked_before_the_run(tmp_path, capsys, monkeypatch, option, name,
                                                 words):
    """A bad --plot or --json fails at once (exit 2, one line), not after the whole run."""
    import jaxga.api

    monkeypatch.setattr(jaxga.api, "run", lambda *a, **k: pytest.fail("the run started"))
    rc = main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seeds", "2",
               "--generations", "3", "--quiet", option, str(tmp_path / name)])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_BAD_INPUT and words in err and "\n" not in err
    assert not (tmp_path / name).exists()


def test_an_output_named_like_a_folder_is_refused(tmp_path, capsys):
    """``--json out.json/`` names a folder (POSIX): refused, not written as out.json."""
    rc = main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--quiet",
               "--json", f"{tmp_path}/out.json/"])
    assert rc == EXIT_BAD_INPUT and "names a folder" in capsys.readouterr().err
    assert not (tmp_path / "out.json").exists()


def test_an_output_inside_jaxgas_own_folder_is_refused(capsys, monkeypatch):
    """``--json`` onto a built-in map's own file (or anywhere in the package) would
    destroy the map every later run reads: refused before the run, the file unchanged."""
    import jaxga.api
    from jaxga.maps.builtin import builtin_path

    monkeypatch.setattr(jaxga.api, "run", lambda *a, **k: pytest.fail("the run started"))
    data = builtin_path("classic_ga_gapp3_20x20")
    before = data.read_bytes()
    rc = main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seeds", "2",
               "--quiet", "--json", str(data)])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_BAD_INPUT and "inside jaxga's own folder" in err and "\n" not in err
    assert data.read_bytes() == before


@pytest.mark.skipif(not __import__("os").path.exists("/dev/full"), reason="needs /dev/full")
def test_a_plot_onto_a_device_is_refused_not_renamed(capsys):
    """``--plot /dev/full`` (no extension) is checked as given, not as a new file
    ``/dev/full.png`` beside the device."""
    rc = main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--quiet",
               "--plot", "/dev/full"])
    assert rc == EXIT_BAD_INPUT and "not a regular file" in capsys.readouterr().err
    assert not __import__("os").path.exists("/dev/full.png")


def test_no_path_leaves_an_empty_path_file_not_the_last_one(tmp_path, capsys):
    """Where there is no path, ``--path-out`` holds an empty path (a CSV header alone, a
    YAML without poses) instead of the path an earlier request wrote there, which a
    robot would follow; the output says so and the exit status is 3."""
    import yaml

    import jaxga.export

    (tmp_path / "w.pgm").write_bytes(b"P5\n4 4\n255\n" + bytes([254, 254, 0, 254] * 4))
    (tmp_path / "w.yaml").write_text("image: w.pgm\nresolution: 0.1\n"
                                     "origin: [0.0, 0.0, 0.0]\n")
    for name in ("old.csv", "old.yaml"):
        out = tmp_path / name
        jaxga.export.write_path(out, np.array([[0.05, 0.05], [0.35, 0.35]]))
        rc = main(["run", "--preset", "sga", "--seeds", "2", "--generations", "2", "--quiet",
                   "--map", str(tmp_path / "w.yaml"), "--start-world", "0.05,0.05",
                   "--goal-world", "0.35,0.35", "--path-out", str(out)])
        captured = capsys.readouterr()
        assert rc == EXIT_NO_PATH and "jaxga: no path:" in captured.err
        assert f"wrote {out} (an empty path: no path)" in captured.out
        if name.endswith(".csv"):
            assert out.read_text() == "x,y\n"
        else:
            assert yaml.safe_load(out.read_text())["poses"] == []


def test_a_plot_without_extension_is_written_as_png_and_reported_so(tmp_path):
    args = argparse.Namespace(plot=str(tmp_path / "figure"), json=None)
    check_outputs(args)
    assert args.plot == str(tmp_path / "figure.png")


@pytest.mark.slow
def test_console_script_never_prints_a_traceback(tmp_path):
    """The real entry point, in a subprocess: bad input gives exit 2 and one stderr line."""
    bad = tmp_path / "bad.map"
    bad.write_text("type octile\nheight 2\nwidth 3\nmap\n...\n..\n")
    proc = subprocess.run(
        [sys.executable, "-m", "jaxga.cli", "optimum", "--map", str(bad)],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == EXIT_BAD_INPUT
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_the_command_line_compilation_cache_directory(tmp_path, monkeypatch):
    """`jaxga run` keeps compiled programs in $JAXGA_CACHE_DIR, by default
    ~/.cache/jaxga/jax, JAX's persistent cache included (jaxga.configure); where it is not
    set, in a local JAX cache folder the user set (JAX's settings left alone); an empty
    value turns it off (docs/cli.md). A script or notebook calls the same function,
    optionally with its own directory, or without JAX's cache."""
    import jax

    import jaxga
    from jaxga._runtime import compilation_cache as cc
    from jaxga.cli import entry as cli
    from jaxga.core.errors import ParameterError

    assert cli.configure is jaxga.configure
    monkeypatch.setattr(cc, "_configured", {})
    updates = []
    monkeypatch.setattr(jax.config, "update", lambda k, v: updates.append((k, v)))
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.delenv("JAXGA_CACHE_DIR", raising=False)

    def users_jax_folder(value):  # JAX_COMPILATION_CACHE_DIR, as JAX reads it
        monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir", value,
                            raising=False)

    users_jax_folder("")
    default = str(tmp_path / ".cache" / "jaxga" / "jax")
    assert jaxga.configure() == default
    assert ("jax_compilation_cache_dir", default) in updates
    updates.clear()
    # the user's own JAX cache folder, where $JAXGA_CACHE_DIR is not set: the store goes
    # there and JAX's cache is left as the user set it (not counted in the store's bound);
    # a remote one stays too, and the store takes the default folder
    users_jax_folder(str(tmp_path / "users"))
    assert jaxga.configure() == str(tmp_path / "users")
    assert updates == [] and "jax" not in cc._configured
    users_jax_folder("gs://bucket/jax")
    assert jaxga.configure() == default and updates == []
    users_jax_folder(default)  # set by jaxga's own earlier call: not the user's
    cc._configured["jax"] = default
    assert jaxga.configure() == default and cc._configured["jax"] == default
    updates.clear()
    users_jax_folder("")
    monkeypatch.setenv("JAXGA_CACHE_DIR", str(tmp_path / "mine"))
    assert jaxga.configure() == str(tmp_path / "mine")
    assert ("jax_compilation_cache_dir", str(tmp_path / "mine")) in updates
    updates.clear()
    monkeypatch.setenv("JAXGA_CACHE_DIR", "")
    assert jaxga.configure() is None and updates == []
    # an explicit directory wins over the environment, even over an empty one
    assert jaxga.configure(tmp_path / "nb") == str(tmp_path / "nb")
    assert ("jax_compilation_cache_dir", str(tmp_path / "nb")) in updates
    updates.clear()
    assert jaxga.configure(tmp_path / "own", jax_cache=False) == str(tmp_path / "own")
    assert updates == [] and cc._configured["dir"] == str(tmp_path / "own")
    assert jaxga.configure(None) is None and cc._configured["dir"] is None
    # what configure returns is the store in use, whatever JAX's own cache folder is
    monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir", str(tmp_path / "B"),
                        raising=False)
    assert cc.store_directory() is None
    assert jaxga.configure(tmp_path / "C", jax_cache=False) == cc.store_directory() \
        == str(tmp_path / "C")
    with pytest.raises(ParameterError, match="must not be empty"):
        jaxga.configure("")
    with pytest.raises(ParameterError, match="jax_cache must be True or False, got 'no'"):
        jaxga.configure(tmp_path / "D", jax_cache="no")
    with pytest.raises(ParameterError, match="must be a local folder, got the URL"):
        jaxga.configure("gs://bucket/x")
    assert not (tmp_path / "D").exists() and cc.store_directory() == str(tmp_path / "C")
    with pytest.warns(DeprecationWarning, match="jaxga.configure"):
        assert jaxga.use_compilation_cache(tmp_path / "old") == str(tmp_path / "old")
    assert ("jax_compilation_cache_dir", str(tmp_path / "old")) in updates


def test_presets_and_maps_list_what_the_package_ships(capsys):
    from jaxga.config.presets import preset_names
    from jaxga.maps.builtin import builtin_names

    assert main(["presets"]) == 0
    out = capsys.readouterr().out
    names = sorted(preset_names())
    assert names == ["agacd", "hybrid", "iga_zhang", "iga_zhu", "imga", "mpmga", "pareto",
                     "sga"]
    for name, paper in zip(names, ("Hao et al. 2021", "jaxga's own preset", "Zhang Ke-qi",
                                   "Zhu & Pan 2024", "Li, Hu, Liu 2021", "Hao et al. 2020",
                                   "jaxga's own preset", "AGACD")):
        line = next(x for x in out.splitlines() if x.startswith(name + " "))
        assert paper in line, (name, line)
    assert main(["maps"]) == 0
    listed = [x.split()[0] for x in capsys.readouterr().out.splitlines() if x.strip()]
    assert listed == sorted(builtin_names()) and "classic_ga_gapp3_20x20" in listed


@pytest.mark.slow
def test_run_json_holds_the_paths_from_the_given_endpoints(tmp_path, capsys):
    """A successful `jaxga run` with --start and --goal: every path in the JSON runs from
    the given start to the given goal over free cells, the raw path cell to adjacent
    cell, and the summary counts the successes."""
    from jaxga.maps import load_map

    art = tmp_path / "m.txt"
    art.write_text("00000000\n00110000\n00010000\n00000110\n01000000\n01000100\n"
                   "00000100\n00000000\n")
    out, png = tmp_path / "out.json", tmp_path / "out.png"
    rc = main(["run", "--preset", "sga", "--map", str(art), "--start", "1,0",
               "--goal", "6,7", "--corner-rule", "free", "--seeds", "3",
               "--generations", "3", "--set", "population.size=8", "--quiet",
               "--json", str(out), "--plot", str(png), "--smooth"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    # --smooth: each path found has its curve (or its polyline) in the JSON, from the
    # start to the goal, with the certificate's numbers; a line in the summary
    assert "paths smoothed into a certified clear curve" in captured.out
    for r in json.loads(out.read_text())["runs"]:
        if not r["success"]:
            assert r["smooth"] is None
            continue
        curve = np.asarray(r["smooth"]["points"])
        assert np.allclose(curve[0], [1, 0], atol=1e-3) and np.allclose(curve[-1], [6, 7],
                                                                        atol=1e-3)
        assert r["smooth"]["clear"] and r["smooth"]["min_clearance"] > 0
        assert r["smooth"]["length"] <= r["length"] + 1e-3  # no longer than its polyline
    blocked = load_map(str(art)).blocked_np()
    doc = json.loads(out.read_text())
    assert doc["corner_rule"] == "free" and len(doc["runs"]) == 3
    # the map keeps the name it has on the command line (a Grid is only "grid")
    assert doc["map"] == "m" and "on m (corner rule 'free')" in captured.out
    assert f"success {sum(r['success'] for r in doc['runs'])}/3" in captured.out
    assert any(r["success"] for r in doc["runs"])
    for r in (r for r in doc["runs"] if r["success"]):
        for key in ("path", "raw_path"):
            path = r[key]
            assert path[0] == [1, 0] and path[-1] == [6, 7], key
            assert not any(blocked[y, x] for x, y in path)
        assert all(max(abs(a - c), abs(b - d)) == 1
                   for (a, b), (c, d) in zip(r["raw_path"], r["raw_path"][1:]))
    assert png.stat().st_size > 0
    # The JSON goes as it is into `jaxga replan` (its default run: the successful run
    # with the shortest raw path): the robot on that path's second cell, its third
    # cell blocked. The GA settings are the run's (3 seeds, 8 individuals, 3
    # generations, the whole 8 x 8 map): replan reuses its compiled programs.
    best = min((r for r in doc["runs"] if r["success"]), key=lambda r: r["raw_length"])
    position, wall = best["raw_path"][1], best["raw_path"][2]
    replanned = tmp_path / "replan.json"
    rc = main(["replan", "--path-json", str(out), "--map", str(art), "--corner-rule", "free",
               "--position", "{},{}".format(*position), "--obstacles", "{},{}".format(*wall),
               "--preset", "sga", "--seeds", "3", "--generations", "3", "--population", "8",
               "--fallback", "--json", str(replanned), "--plot", str(tmp_path / "re.png")])
    assert rc == 0, capsys.readouterr().err
    assert (tmp_path / "re.png").stat().st_size > 0
    data = json.loads(replanned.read_text())
    path = data["path"]
    assert data["success"] and path[0] == position and path[-1] == [6, 7]
    assert wall not in path and not any(blocked[y, x] for x, y in path)
    assert all(max(abs(a - c), abs(b - d)) == 1 for (a, b), (c, d) in zip(path, path[1:]))


@pytest.mark.parametrize("argv, words", [
    (["run", "--preset", "sga", "--map", "m", "--seeds", "1.5"], "invalid int value: '1.5'"),
    (["run", "--preset", "sga", "--map", "m", "--start", "3,4,5"], "expected X,Y"),
    (["run", "--preset"], "expected one argument"),
    (["bogus"], "invalid choice: 'bogus'"),
])
def test_a_malformed_command_line_is_one_line_too(argv, words, capsys):
    """argparse's own errors in jaxga's one-line form (exit 2), not a usage block."""
    with pytest.raises(SystemExit) as e:
        main(argv)
    err = capsys.readouterr().err
    assert e.value.code == EXIT_BAD_INPUT
    assert err.startswith("jaxga: error: ") and words in err and err.count("\n") == 1


def test_a_plot_format_matplotlib_cannot_write_here_fails_before_the_run(tmp_path,
                                                                        monkeypatch):
    """pgf needs LaTeX: without it, the check of --plot fails at once, naming it."""
    from matplotlib.figure import Figure

    from jaxga.core.errors import JaxgaError

    def no_latex(self, *a, **k):
        raise RuntimeError("'xelatex' not found")

    args = argparse.Namespace(plot=str(tmp_path / "p.pgf"), json=None)
    monkeypatch.setattr(Figure, "savefig", no_latex)
    with pytest.raises(JaxgaError, match="cannot write --plot .*p.pgf.*xelatex"):
        check_outputs(args)
    monkeypatch.undo()
    args = argparse.Namespace(plot=str(tmp_path / "p.svg"), json=None)
    check_outputs(args)  # a format that needs nothing else passes
    assert not (tmp_path / "p.svg").exists()
    # the real probe, where this machine has no LaTeX (the CI machine has none)
    import shutil

    from matplotlib import rcParams

    if shutil.which(rcParams["pgf.texsystem"]) is None:
        with pytest.raises(JaxgaError, match="cannot write --plot .*p.pgf"):
            check_outputs(argparse.Namespace(plot=str(tmp_path / "p.pgf"), json=None))


@pytest.mark.slow
def test_a_doe_where_no_seed_finds_a_path_names_the_cause(tmp_path, capsys, monkeypatch):
    """Nothing to fit: exit 3 with the reason the runs give (here the capacity), also
    when every point is read back from the checkpoint (the point files keep it)."""
    import jaxga.api

    art = tmp_path / "m.txt"
    art.write_text("\n".join(["0000000"] * 7) + "\n")
    args = ["doe", "--preset", "sga", "--map", str(art), "--seeds", "1",
            "--generations", "2", "--quiet", "--design", "full",
            "--factor", "population.size=4,6,8", "--set", "population.capacity=3",
            "--checkpoint", str(tmp_path / "ckpt")]
    for again in (False, True):
        if again:  # every point is in the checkpoint: nothing runs
            monkeypatch.setattr(jaxga.api, "sweep", lambda *a, **k: pytest.fail("ran"))
        rc = main(args)
        err = capsys.readouterr().err
        assert rc == EXIT_NO_PATH
        assert err.startswith("jaxga: no path: no seed of any design point found a path")
        assert "population.capacity = 3 is probably too small" in err


class _Clock:
    """A settable clock for the progress display."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class _Stream(io.StringIO):
    def __init__(self, tty: bool) -> None:
        super().__init__()
        self.tty = tty

    def isatty(self) -> bool:
        return self.tty


@pytest.mark.parametrize("tty", [False, True])
def test_progress_is_shown_after_two_seconds_as_a_bar_or_as_log_lines(tty):
    """A quick run shows nothing; a long one shows every update from the first one
    after 2 s: redrawn in place on a terminal, one plain line each on a pipe (a log
    file gets no carriage returns, and no line twice in a row)."""
    from jaxga.cli.run import Progress as _Progress

    clock, stream = _Clock(), _Stream(tty)
    quick = _Progress(stream, clock)
    for stage, frac in [("compile", 0.0), ("compile", 1.0), ("evolve", 0.5), ("evolve", 1.0)]:
        quick(stage, frac)
    assert stream.getvalue() == ""
    show = _Progress(stream, clock)
    updates = [(0.0, "compile", 0.0), (1.0, "compile", 0.25), (2.5, "compile", 0.5),
               (3.0, "compile", 1.0), (3.5, "evolve", 0.5), (3.6, "evolve", 0.501),
               (4.0, "evolve", 1.0)]
    for now, stage, frac in updates:
        clock.now = now
        show(stage, frac)
    text = stream.getvalue()
    if tty:
        assert text == ("\rcompile  [###############               ]  50.0%"
                        "\rcompile  [##############################] 100.0%"
                        "\revolve   [###############               ]  50.0%"
                        "\revolve   [###############               ]  50.1%"
                        "\revolve   [##############################] 100.0%\n")
    else:
        assert text.splitlines() == ["progress: compile 50%", "progress: compile 100%",
                                     "progress: evolve 50%", "progress: evolve 100%"]
    # a phase without updates (a reference search) is said to be still running after 2 s
    stream = _Stream(tty)
    slow = _Progress(stream, clock)
    clock.now = 10.0
    slow("any-angle", 0.0)
    for now in (10.5, 11.5, 12.2, 13.0, 14.0, 14.5):
        clock.now = now
        slow.tick()
    lines = stream.getvalue().replace("\r", "\n").split("\n")
    shown = [line.strip() for line in lines if "still running" in line]
    assert [line.split("progress: ")[-1] for line in shown] == [
        "any-angle still running (2 s)", "any-angle still running (4 s)"]
    # a long phase: a bar redrawn every 2 s, a log's lines ever further apart
    long_stream = _Stream(tty)
    long = _Progress(long_stream, clock)
    clock.now = 100.0
    long("compile", 0.0)
    for k in range(1, 121):  # a tick every half second for 60 s
        clock.now = 100.0 + 0.5 * k
        long.tick()
    said = [line.strip() for line in long_stream.getvalue().replace("\r", "\n").split("\n")
            if "still running" in line]
    seconds = [int(line.split("(")[1].split(" ")[0]) for line in said]
    if tty:
        assert len(said) == 30 and seconds[:3] == [2, 4, 6]
    else:
        assert seconds == [2, 4, 8, 16, 32]
    # closing ends a bar's line once, however often it is closed (jaxga optimum closes
    # before its results and again at the end)
    before = stream.getvalue()
    slow.close()
    slow.close()
    assert stream.getvalue() == before + ("\n" if tty else "")


def test_jaxga_warnings_are_one_line_like_its_errors(capsys, monkeypatch):
    """An InitialisationWarning during `jaxga run` is one `jaxga: warning: ...` line
    (not Python's format with the console script's file and source line); other
    libraries' warnings keep Python's format."""
    import warnings

    import jaxga.api
    from jaxga.core.errors import InitialisationWarning

    class Stop(Exception):
        pass

    def fake_run(*args, **kwargs):
        warnings.warn("2 of 2 runs started with fewer individuals", InitialisationWarning,
                      stacklevel=2)
        warnings.warn("not ours", DeprecationWarning, stacklevel=2)
        raise Stop

    monkeypatch.setattr(jaxga.api, "run", fake_run)
    with pytest.warns(DeprecationWarning, match="not ours") as seen:  # handed on
        with pytest.raises(Stop):
            main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--quiet"])
    assert [w.category for w in seen] == [DeprecationWarning]
    err = capsys.readouterr().err
    assert err == "jaxga: warning: 2 of 2 runs started with fewer individuals\n"


def test_scenario_reaches_run_after_the_devices_are_configured(monkeypatch, capsys):
    """`jaxga run --scenario N`: the map reaches jaxga.run in the problem the command line
    checked once (:func:`jaxga.problem`), as the named map with the scenario's endpoints,
    loaded only after the devices and processes are configured (loading a map starts JAX,
    after which neither can change)."""
    import jaxga.api
    import jaxga.cli.entry as cli
    from jaxga.maps import MapInfo, builtin_scenarios

    calls, seen = [], {}

    class Stop(Exception):
        pass

    def fake_run(problem, grid=None, **kwargs):
        seen["problem"], seen["grid"] = problem, grid
        raise Stop

    real_apply = cli.apply_scenario
    monkeypatch.setattr(cli, "configure_from_args", lambda args: calls.append("devices"))
    monkeypatch.setattr(cli, "apply_scenario",
                        lambda args: (calls.append("scenario"), real_apply(args)))
    monkeypatch.setattr(jaxga.api, "run", fake_run)
    with pytest.raises(Stop):
        main(["run", "--preset", "sga", "--map", "maze-32-32-2", "--scenario", "4",
              "--quiet"])
    assert calls == ["devices", "scenario"]
    problem = builtin_scenarios("maze-32-32-2")[4]
    assert isinstance(seen["problem"], jaxga.Problem) and seen["grid"] is None
    info = seen["problem"].info
    assert isinstance(info, MapInfo) and info.name == "maze-32-32-2"
    assert seen["problem"].grid is info.grid and seen["problem"].map_name == info.name
    assert (info.grid.start_xy, info.grid.goal_xy) == (problem.start, problem.goal)
    assert info.grid.corner_rule == "strict"  # the map's own rule, as without --scenario
    capsys.readouterr()


def test_run_reads_the_preset_once_and_hands_jaxga_run_the_checked_problem(monkeypatch):
    """`jaxga run` builds the problem once (:func:`jaxga.problem`, the map loaded under the
    preset's corner rule): the preset is read and checked one time, and jaxga.run gets
    that value (it loads nothing again)."""
    import jaxga.api
    import jaxga.api.problem as problem_module
    import jaxga.cli.options as options_module

    reads, seen = [], {}
    real_load = problem_module.load_preset

    def counted(*args, **kwargs):
        reads.append(args)
        return real_load(*args, **kwargs)

    class Stop(Exception):
        pass

    def fake_run(problem, grid=None, **kwargs):
        seen.update(problem=problem, grid=grid, options=kwargs)
        raise Stop

    monkeypatch.setattr(problem_module, "load_preset", counted)
    monkeypatch.setattr(options_module, "load_preset", counted)
    monkeypatch.setattr(jaxga.api, "run", fake_run)
    with pytest.raises(Stop):
        main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--seeds", "2",
              "--generations", "3", "--set", "map.corner_rule=strict", "--quiet"])
    assert len(reads) == 1
    problem = seen["problem"]
    assert seen["grid"] is None and "preset" not in seen["options"]
    assert problem.config["generations"] == 3
    assert problem.grid.corner_rule == "strict" == problem.info.grid.corner_rule


def test_a_map_over_the_size_limit_is_one_line_and_coarsen_plans_on_it(tmp_path, capsys,
                                                                     monkeypatch):
    """``--map`` of 600 x 600 cells over a limit of 512 x 512 (a machine whose memory
    holds no more): refused with one line naming --coarsen; with ``--coarsen 2`` the
    optimum of the 300 x 300 map (endpoints in the original's cells)."""
    import numpy as np

    from jaxga.maps import save_map

    monkeypatch.setattr("jaxga.core.grid.MAX_MAP_CELLS", 512 * 512)

    b = np.zeros((600, 600), bool)
    b[100:500, 300] = True
    path = save_map(b, tmp_path / "big.map")
    assert main(["optimum", "--map", str(path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "600 x 600 has 360,000 cells" in err and "--coarsen 2" in err
    out = tmp_path / "opt.json"
    assert main(["optimum", "--map", str(path), "--coarsen", "2", "--start", "10,300",
                 "--goal", "590,300", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["path"][0] == [5, 150] and data["path"][-1] == [295, 150]
    assert data["length"] > 290  # around the wall, on the coarse map


@pytest.mark.slow
def test_a_ros_map_is_planned_on_in_world_coordinates_with_inflation(tmp_path, capsys):
    """A map written as ROS 1 map_saver writes it (binary PGM: 254 free, 0 occupied, 205
    unknown; YAML with resolution and origin), planned on from the command line with the
    endpoints in metres and the obstacles grown by the robot's radius: the cells, the
    resolution and the origin exactly; every path avoids the occupied, the unknown and
    the inflated cells. (8 x 8, sga, 3 seeds of 8 individuals for 3 generations under
    corner rule free: the compiled programs of the test above.)"""
    from jaxga.maps import inflate, load_map
    from jaxga.reference.optima import shortest_path

    img = np.full((8, 8), 254, np.uint8)  # top row first
    img[2:5, 3] = 0       # a wall, rows y = 3..5 at x = 3
    img[0, 5:] = 205      # unknown strip along the top (y = 7)
    (tmp_path / "lab.pgm").write_bytes(b"P5\n# CREATOR: map_saver.cpp 0.250 m/pix\n8 8\n255\n"
                                       + img.tobytes())
    yaml = tmp_path / "lab.yaml"
    yaml.write_text("image: lab.pgm\nresolution: 0.250000\norigin: [-1.000000, -2.000000, "
                    "0.000000]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n\n")
    where = ["--map", str(yaml), "--start-world=-0.9,-1.9", "--goal-world=0.6,-0.65",
             "--robot-radius", "0.25", "--corner-rule", "free"]
    out = tmp_path / "opt.json"
    assert main(["optimum", *where, "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    # (-0.9 + 1) / 0.25 = 0.4 -> x 0; (-1.9 + 2) / 0.25 -> y 0;
    # (0.6 + 1) / 0.25 = 6.4 -> x 6; (-0.65 + 2) / 0.25 = 5.4 -> y 5
    assert doc["start"] == [0, 0] and doc["goal"] == [6, 5] and doc["resolution"] == 0.25
    plain = load_map(yaml, corner_rule="free", start=(0, 0), goal=(6, 5))
    blocked = plain.blocked_np()
    assert blocked[3:6, 3].all() and blocked[7, 5:].all() and blocked.sum() == 6
    grown = inflate(plain, 1).blocked_np()
    assert doc["length"] == pytest.approx(shortest_path(plain.replace(blocked=grown)).length)
    assert f"({doc['length'] * 0.25:.3f} m)" in capsys.readouterr().out
    assert doc["length_m"] == pytest.approx(doc["length"] * 0.25)  # as run's JSON gives it
    assert doc["any_angle_length_m"] == pytest.approx(doc["any_angle_length"] * 0.25)
    out = tmp_path / "run.json"
    rc = main(["run", "--preset", "sga", *where, "--seeds", "3", "--generations", "3",
               "--set", "population.size=8", "--quiet", "--json", str(out), "--smooth"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    doc = json.loads(out.read_text())
    assert doc["resolution"] == 0.25 and doc["start"] == [0, 0] and doc["goal"] == [6, 5]
    assert "0.25 m per planning cell" in captured.out
    assert "m from the map's obstacles" in captured.out  # --smooth's clearance, like a path's
    assert any(r["success"] for r in doc["runs"])
    centres = np.argwhere(blocked)[:, ::-1]  # (x, y) of the map's own obstacle cells
    for r in (r for r in doc["runs"] if r["success"]):
        assert not any(grown[y, x] for x, y in r["raw_path"])
        # the curve's clearance is to the map's own obstacles (before inflation), as the
        # path's: at least its distance to the inflated grid, at most to a cell centre
        curve, smooth = np.asarray(r["smooth"]["points"]), r["smooth"]
        to_centres = np.hypot(*(curve[:, None, :] - centres[None]).transpose(2, 0, 1)).min()
        assert smooth["min_clearance"] * 0.25 - 1e-9 <= smooth["min_clearance_m"]
        assert smooth["min_clearance_m"] <= to_centres * 0.25 + 1e-9


def test_presets_show_prints_every_setting_with_its_source(capsys):
    """`jaxga presets --show NAME`: one line per key of the resolved configuration, with
    the file (or variant) that sets it and the comment written next to it there."""
    from jaxga.config.presets import load_preset

    assert main(["presets", "--show", "iga_zhu"]) == 0
    lines = capsys.readouterr().out.splitlines()
    keys = [line.split("=")[0].strip() for line in lines]
    assert keys == sorted(load_preset("iga_zhu").as_dict())
    size = next(line for line in lines if line.startswith("population.size "))
    assert "= 200" in size and "# iga_zhu.toml: Table 3, IGA Popnum = 200" in size
    adaptive = next(line for line in lines if line.startswith("crossover.adaptive "))
    assert adaptive.endswith("# default")
    assert main(["presets", "--show", "sga", "--variant", "agacd"]) == 0
    method = next(line for line in capsys.readouterr().out.splitlines()
                  if line.startswith("fitness.method "))
    assert '"agacd"' in method and "sga.toml [variants.agacd]: AGACD 4.4 eq. 7-8" in method
    assert main(["presets", "--variant", "agacd"]) == EXIT_BAD_INPUT


@pytest.mark.slow
def test_optimum_and_run_report_the_same_optimum_for_one_map(tmp_path):
    """One corner rule per map: a user's map is strict in `jaxga optimum` and in `jaxga
    run` of a paper preset alike (before, the run took the preset's free rule and found
    another optimum); naming a rule changes both the same way."""
    art = tmp_path / "squeeze.txt"  # a diagonal squeeze: free and strict optima differ
    art.write_text("00000000\n00000000\n00000000\n00010000\n00100000\n00000000\n"
                   "00000000\n00000000\n")
    for extra in ([], ["--corner-rule", "free"]):
        opt, run = tmp_path / "opt.json", tmp_path / "run.json"
        assert main(["optimum", "--map", str(art), *extra, "--json", str(opt)]) == 0
        assert main(["run", "--preset", "sga", "--map", str(art), *extra, "--seeds", "3",
                     "--generations", "3", "--set", "population.size=8", "--quiet",
                     "--json", str(run)]) == 0
        o, r = json.loads(opt.read_text()), json.loads(run.read_text())
        assert o["corner_rule"] == r["corner_rule"] == (extra[1] if extra else "strict")
        assert o["length"] == pytest.approx(r["optimum"])
    strict = json.loads(tmp_path.joinpath("opt.json").read_text())["length"]
    assert main(["optimum", "--map", str(art), "--json", str(opt)]) == 0
    assert json.loads(opt.read_text())["length"] > strict  # the squeeze is closed


def test_the_python_api_keeps_its_programs_without_touching_jaxs_settings(tmp_path,
                                                                          monkeypatch):
    """Without jaxga.configure, the API keeps its programs in its own store: JAX's cache
    folder where the user configured one (a remote one: no store), else $JAXGA_CACHE_DIR
    or the default (made on first use); an empty $JAXGA_CACHE_DIR: none. It changes no
    JAX setting, also when a run is checked (which used to turn JAX's cache on)."""
    import jax

    from jaxga import api
    from jaxga._runtime import compilation_cache as cc

    updates = []
    def update(k, v):  # jaxga's own updates (JAX's cache sets its own when it starts)
        if sys._getframe(1).f_globals.get("__name__", "").startswith("jaxga"):
            updates.append((k, v))

    monkeypatch.setattr(jax.config, "update", update)
    monkeypatch.setattr(cc, "_configured", {})
    monkeypatch.setattr(cc, "_checked", {})
    monkeypatch.setenv("JAXGA_CACHE_DIR", str(tmp_path / "c"))
    for configured, store in (("/already/there", "/already/there"), ("gs://bucket", None),
                              (None, str(tmp_path / "c"))):
        monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir", configured,
                            raising=False)
        assert cc.store_directory() == store
    assert (tmp_path / "c").is_dir()
    monkeypatch.setenv("JAXGA_CACHE_DIR", "")
    assert cc.store_directory() is None
    monkeypatch.setattr(cc, "_configured", {"dir": str(tmp_path / "own")})
    assert cc.store_directory() == str(tmp_path / "own")
    api.check_run("sga", "classic_ga_gapp3_20x20")
    assert updates == []


def _open_ros_map(folder, size: int, resolution: float, origin: tuple[float, float]):
    """An open ``size x size`` map_saver map (all free) in ``folder``/map.yaml."""
    folder.mkdir(parents=True, exist_ok=True)
    img = np.full((size, size), 254, np.uint8)
    (folder / "map.pgm").write_bytes(f"P5\n{size} {size}\n255\n".encode() + img.tobytes())
    yaml_file = folder / "map.yaml"
    yaml_file.write_text(f"image: map.pgm\nresolution: {resolution}\norigin: [{origin[0]}, "
                         f"{origin[1]}, 0.0]\nnegate: 0\noccupied_thresh: 0.65\n"
                         "free_thresh: 0.196\n")
    return yaml_file


@pytest.mark.slow
def test_metres_after_coarsen_paths_in_both_cell_frames_and_the_path_file(tmp_path, capsys):
    """A 16 x 16 map of 0.1 m cells (origin (-1, -2)) coarsened 2 x 2 is an 8 x 8 grid of
    0.2 m cells: the straight path from the world point (-0.95, -1.95) (map cell (0, 0),
    coarse (0, 0)) to (0.55, -1.95) (map cell (15, 0), coarse (7, 0)) is 7 coarse cells =
    1.4 m (not 0.7 m), its ends are the coarse cells' centres (-0.9, -1.9) and
    (0.5, -1.9) m and the map cells (1, 1) and (15, 1); the JSON records the factor and
    both cell frames; --path-out writes the path in metres as CSV and as a nav_msgs/Path
    YAML (heading +x: quaternion z 0, w 1), read back equal. Negative coordinates are
    given without '='. (8 x 8, sga as the tests above: their compiled programs.)"""
    import yaml

    ros = _open_ros_map(tmp_path / "lab", 16, 0.1, (-1.0, -2.0))
    out, csv, nav = tmp_path / "run.json", tmp_path / "path.csv", tmp_path / "path.yaml"
    base = ["run", "--preset", "sga", "--map", str(ros), "--coarsen", "2",
            "--start-world", "-0.95,-1.95", "--goal-world", "0.55,-1.95",
            "--corner-rule", "free", "--seeds", "3", "--generations", "3",
            "--set", "population.size=8", "--quiet"]
    assert main([*base, "--json", str(out), "--path-out", str(csv)]) == 0
    text = capsys.readouterr().out
    assert "coarsened 2 x 2" in text and "0.2 m per planning cell" in text
    assert "optimum 1.400 m" in text
    doc = json.loads(out.read_text())
    assert doc["frame"]["coarsen"] == 2 and doc["frame"]["map_shape"] == [16, 16]
    assert doc["resolution"] == pytest.approx(0.2) and doc["map"] == "lab"
    assert doc["start"] == [0, 0] and doc["goal"] == [7, 0]
    assert doc["map_start"] == [1, 1] and doc["map_goal"] == [15, 1]
    assert doc["start_world"] == pytest.approx([-0.9, -1.9])
    assert doc["goal_world"] == pytest.approx([0.5, -1.9])
    assert doc["optimum"] == pytest.approx(7.0)
    best = min((r for r in doc["runs"] if r["success"]), key=lambda r: r["length"])
    assert best["length_m"] == pytest.approx(0.2 * best["length"])
    assert best["map_path"] == [[2 * x + 1, 2 * y + 1] for x, y in best["path"]]
    np.testing.assert_allclose(
        best["path_world"], [[-1 + 0.2 * (x + 0.5), -2 + 0.2 * (y + 0.5)]
                             for x, y in best["path"]], atol=1e-4)
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert csv.read_text().startswith("x,y\n")
    np.testing.assert_allclose(rows, best["path_world"], atol=1e-4)
    assert main([*base, "--path-out", str(nav)]) == 0
    msg = yaml.safe_load(nav.read_text())
    points = np.asarray(best["path_world"])
    assert msg["header"]["frame_id"] == "map" and len(msg["poses"]) == len(points)
    for i, pose in enumerate(msg["poses"]):
        assert pose["header"]["frame_id"] == "map"
        position = [pose["pose"]["position"][k] for k in "xyz"]
        assert position == pytest.approx([*points[i], 0.0], abs=1e-4)
        # the yaw along the path: towards the next point (the last: from the one before)
        dx, dy = points[min(i + 1, len(points) - 1)] - points[max(min(i, len(points) - 2), 0)]
        q = [pose["pose"]["orientation"][k] for k in "xyzw"]
        yaw = math.atan2(dy, dx)
        assert q == pytest.approx([0, 0, math.sin(yaw / 2), math.cos(yaw / 2)], abs=1e-5)


def test_path_out_is_refused_before_the_run_where_it_cannot_be_written(tmp_path, capsys):
    """--path-out needs a map with metres and a .csv or .yaml name: refused in one line
    before any work."""
    art = tmp_path / "m.txt"
    art.write_text("0000\n0000\n")
    for target, words in ((tmp_path / "p.csv", "has no resolution"),
                          (tmp_path / "p.txt", "must be .csv")):
        ros = _open_ros_map(tmp_path / "r", 8, 0.1, (0.0, 0.0))
        source = art if target.suffix == ".csv" else ros
        rc = main(["run", "--preset", "sga", "--map", str(source), "--seeds", "1",
                   "--quiet", "--path-out", str(target)])
        err = capsys.readouterr().err.strip()
        assert rc == EXIT_BAD_INPUT and "\n" not in err and words in err, err
        assert not target.exists()


@pytest.mark.slow
def test_the_time_line_accounts_for_the_whole_wall_time(tmp_path):
    """`jaxga run` in a fresh process: the time line names every phase it went through
    (import, load, references, compile, init, evolve, post, any-angle, plot, write) and
    their seconds add up to the total, which is the process's wall time within a
    tolerance (the interpreter's exit after the last line is not in it)."""
    import re
    import time

    ros = _open_ros_map(tmp_path / "lab", 8, 0.25, (-1.0, -2.0))
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "jaxga.cli", "run", "--preset", "sga", "--map", str(ros),
         "--start-world", "-0.9,-1.9", "--goal-world", "0.6,-0.4", "--corner-rule", "free",
         "--seeds", "3", "--generations", "3", "--set", "population.size=8", "--quiet",
         "--json", str(tmp_path / "r.json"), "--plot", str(tmp_path / "r.png")],
        capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t0
    assert proc.returncode == 0, proc.stderr
    line = proc.stdout.strip().splitlines()[-1]
    assert line.startswith("time (s): "), line
    phases = dict((name, float(v)) for name, v in re.findall(r"([a-z-]+) ([\d.]+)", line))
    for name in ("import", "load", "references", "compile", "init", "evolve", "post",
                 "any-angle", "plot", "write"):
        assert name in phases, (name, line)
    total = phases.pop("total")
    assert sum(phases.values()) == pytest.approx(total, abs=0.02)
    assert phases.get("other", 0.0) < 0.25 + 0.05 * total, line
    assert total <= wall and wall - total < 1.5 + 0.1 * wall, (wall, line)
    timing = json.loads((tmp_path / "r.json").read_text())["timing"]
    assert {"import_s", "plot_s", "any_angle_s", "total_s"} <= set(timing)


def test_inputs_that_do_not_match_are_refused_in_one_line(tmp_path, capsys):
    """A problem of another map of the same size (refused naming both maps, unless
    --scenario-map-mismatch ok, which the note then repeats), an option the map's format
    ignores, and a coarsening that merges start and goal: each one line, exit 2."""
    scen = tmp_path / "random.scen"
    scen.write_text("version 1\n7\trandom-32-32-20.map\t32\t32\t5\t16\t31\t24\t31.31370850\n")
    base = ["optimum", "--quiet", "--corner-rule", "strict", "--scenario", "0", "--scen",
            str(scen)]
    assert main([*base, "--map", "maze-32-32-2"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and ("random.scen: problem 0 is for map random-32-32-20.map, not "
                                "maze-32-32-2") in err and "--scenario-map-mismatch ok" in err
    assert main([*base, "--map", "random-32-32-20"]) == 0  # its own map
    assert "(on random-32-32-20.map" not in capsys.readouterr().err
    assert main([*base, "--map", "maze-32-32-2", "--scenario-map-mismatch", "ok"]) == 0
    assert "(on random-32-32-20.map, not this map)" in capsys.readouterr().err
    art = tmp_path / "m.txt"
    art.write_text("0 0 0 0\n0 0 0 0\n0 0 0 0\n0 0 0 0\n")
    png = tmp_path / "m.png"
    from jaxga.maps import save_map

    save_map(np.zeros((4, 4), bool), png)
    for args, words in (
        (["--map", "maze-32-32-2", "--scenario-map-mismatch", "ok"], "give N too"),
        (["--map", str(art), "--threshold", "0.5"], "has no effect on a 0/1 text map"),
        (["--map", str(png), "--unknown", "blocked"], "has no effect on an image"),
        (["--map", str(png), "--occupied-from", "99"], "has no effect on an image"),
        (["--map", str(art), "--json", "-"], "cannot write --json -: jaxga writes its outputs"),
        (["--map", str(art), "--coarsen", "2", "--start", "0,0", "--goal", "1,1"],
         "fall into one coarse cell (0, 0)"),
    ):
        assert main(["optimum", "--quiet", *args]) == EXIT_BAD_INPUT, args
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and words in err, (args, err)
    assert main(["optimum", "--quiet", "--map", str(png), "--threshold", "0.5"]) == 0


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="needs FIFOs")
def test_a_device_or_a_fifo_as_an_input_is_refused_at_once(tmp_path, capsys):
    """--map /dev/zero, or a FIFO with no writer as the map, the scenario file or replan's
    path JSON: refused within seconds (not read until memory runs out, not waiting for
    a writer), in one line naming the file and the cap."""
    import os
    import time

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    art = tmp_path / "m.txt"
    art.write_text("0 0 0\n0 0 0\n")
    cases = [["optimum", "--quiet", "--map", str(fifo)],
             ["optimum", "--quiet", "--map", str(art), "--scenario", "0", "--scen", str(fifo)],
             ["replan", "--map", str(art), "--path-json", str(fifo), "--position", "0,0"]]
    if os.path.exists("/dev/zero"):
        cases.append(["optimum", "--quiet", "--map", "/dev/zero"])
    for argv in cases:
        t0 = time.perf_counter()
        assert main(argv) == EXIT_BAD_INPUT, argv
        assert time.perf_counter() - t0 < 5.0, argv
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "not a regular file" in err and "bytes)" in err, err
        assert ("/dev/zero" if "/dev/zero" in argv else str(fifo)) in err


@pytest.mark.slow
def test_a_front_s_summary_json_and_chosen_point(tmp_path, capsys):
    """pareto on a ROS map with a pillar: one summary line on the fronts; the JSON holds
    every point of each seed's front with its path and the comparison with the exact
    ends; --path-out writes the chosen point (the widest end here) shortcut without
    narrowing it: the file's polyline starts and ends at the endpoints in metres and
    keeps the widest point's clearance from the inflated obstacles."""
    from jaxga.maps import load_map_info
    from jaxga.maps.clearance import ObstacleClearance

    ros = _open_ros_map(tmp_path / "room", 24, 0.1, (0.0, 0.0))
    image = np.full((24, 24), 254, np.uint8)
    image[9:15, 10:14] = 0  # a pillar in the middle of the room (map rows 9-14)
    ros.with_name("map.pgm").write_bytes(b"P5\n24 24\n255\n" + image.tobytes())
    out, csv = tmp_path / "run.json", tmp_path / "front.csv"
    assert main(["run", "--preset", "pareto", "--map", str(ros), "--start-world",
                 "0.25,1.25", "--goal-world", "2.25,1.15", "--seeds", "2", "--generations",
                 "4", "--quiet", "--json", str(out), "--path-out", str(csv),
                 "--front-point", "widest"]) == 0
    text = capsys.readouterr().out
    assert "front (length, clearance, turning; medians over 2 seeds)" in text
    assert "front point widest" in text
    doc = json.loads(out.read_text())
    run = doc["runs"][0]
    widest = max(p["clearance"] for p in run["front"])
    assert run["front_ends"]["widest_clearance"] == pytest.approx(widest)
    assert run["front_ends"]["widest_ratio"] == pytest.approx(widest
                                                              / doc["maximin_clearance"])
    for p in run["front"]:
        assert p["length_m"] == pytest.approx(0.1 * p["length"])
        assert p["path"][0] == doc["start"] and p["path"][-1] == doc["goal"]
    best = min((r for r in doc["runs"] if r["success"]), key=lambda r: r["length"])
    chosen = max(best["front"], key=lambda p: (p["clearance"], -p["length"]))
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    np.testing.assert_allclose(rows[[0, -1]], [doc["start_world"], doc["goal_world"]],
                               atol=1e-4)
    cells = np.rint(rows / 0.1 - 0.5).astype(int)
    assert len(rows) <= len(chosen["path"])
    # the polyline keeps the point's clearance (cells) from the planning grid's obstacles
    blocked = load_map_info(str(ros)).grid.blocked_np()
    assert blocked[9:15, 10:14].all()
    assert ObstacleClearance(blocked).of_path(cells) >= chosen["clearance"] - 1e-9
    # a clearance no point keeps: no path, so the file holds an empty path (not the path
    # of the request before), and the JSON is still written
    out.unlink()
    assert main(["run", "--preset", "pareto", "--map", str(ros), "--start-world",
                 "0.25,1.25", "--goal-world", "2.25,1.15", "--seeds", "2", "--generations",
                 "4", "--quiet", "--json", str(out), "--path-out", str(csv),
                 "--front-point", "1000"]) == EXIT_NO_PATH
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("jaxga: no path: no point of seed ") \
        and err[-1].endswith("'s front keeps a clearance of 1000 m (--front-point)"), err
    assert csv.read_text().strip() == "x,y" and json.loads(out.read_text())["runs"]


def test_front_point_must_be_a_name_or_a_clearance(capsys):
    """--front-point takes knee, shortest, widest or metres >= 0: anything else is refused
    by the parser in one line, before any work."""
    for bad in ("middle", "-0.1", "nan"):
        with pytest.raises(SystemExit):
            main(["run", "--preset", "pareto", "--map", "classic_ga_gapp3_20x20",
                  "--front-point", bad])
        assert "--front-point takes knee, shortest, widest" in capsys.readouterr().err


def test_a_front_point_chosen_by_an_objective_the_front_lacks_is_refused_first(tmp_path, capsys):
    """--front-point widest (or a least clearance) on a front that does not minimise the
    clearance, or shortest on one without the length, is refused in one line before the
    run: no program compiled, no file written."""
    import time

    ros = _open_ros_map(tmp_path / "room", 24, 0.1, (0.0, 0.0))
    csv = tmp_path / "front.csv"
    for objectives, point, need in ((["length", "turning"], "widest", "clearance"),
                                    (["length", "turning"], "0.2", "clearance"),
                                    (["clearance", "turning"], "shortest", "length")):
        t0 = time.perf_counter()
        code = main(["run", "--preset", "pareto", "--map", str(ros), "--start-world",
                     "0.25,1.25", "--goal-world", "2.25,1.15", "--seeds", "2", "--quiet",
                     "--set", f"survival.objectives={json.dumps(objectives)}",
                     "--path-out", str(csv), "--front-point", point])
        err = capsys.readouterr().err.strip()
        assert code == EXIT_BAD_INPUT and "\n" not in err, err
        assert f"chosen by its {need}, which the front does not minimise" in err, err
        assert str(objectives) in err
        assert time.perf_counter() - t0 < 10.0 and not csv.exists()


def test_more_cpu_devices_than_four_per_core_are_refused(capsys):
    """``--devices 1000`` made a CPU run that never finished (64 took two minutes where
    one device took four seconds): refused in one line naming the bound."""
    from jaxga._runtime.parallel import max_cpu_devices

    rc = main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", "--quiet",
               "--devices", str(max_cpu_devices() + 1)])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_BAD_INPUT and f"at most {max_cpu_devices()}" in err and "\n" not in err


@pytest.mark.slow  # a process of its own
def test_python_dash_m_jaxga_is_the_command():
    """``python -m jaxga`` runs the ``jaxga`` command, as ``python -m jaxga.cli`` does."""
    proc = subprocess.run([sys.executable, "-m", "jaxga", "--help"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("usage: jaxga")


def test_coordinates_are_read_as_written_in_ascii():
    """Python's int() and float() took '1_0' as 10 and other scripts' digits ('\\u0663' as
    3): a cell no one typed by intent. Signs, spaces and exponents are kept."""
    import argparse

    from jaxga.cli.options import parse_point, parse_xy

    assert parse_xy(" 3 , -4") == (3, -4) and parse_point(".5,-1e3") == (0.5, -1000.0)
    for text in ("1_0,2", "\u0663,1", "1.5,2", "1,2,3"):
        with pytest.raises(argparse.ArgumentTypeError, match="two integers"):
            parse_xy(text)
    for text in ("1_0.5,2", "\u0663,1", "1,2,3"):
        with pytest.raises(argparse.ArgumentTypeError, match="two numbers in metres"):
            parse_point(text)
    with pytest.raises(argparse.ArgumentTypeError, match="expected finite coordinates"):
        parse_point("nan,1")


@pytest.mark.parametrize("argv, words", [
    (["--seeds", "2_0"], "argument --seeds: invalid int value: '2_0'"),  # ran 20 seeds
    (["--seeds", "\u0663"], "argument --seeds: invalid int value"),
    (["--threshold", "0_5"], "argument --threshold: invalid float value: '0_5'"),
    (["--generations", "5", "--generations=6"], "--generations is given 2 times"),  # 6
])
def test_numbers_are_ascii_and_a_one_value_option_is_given_once(argv, words, capsys):
    """Options read through int() and float() took '2_0' as 20 and other scripts'
    digits; an option given twice kept its last value without a word (--set of the same
    key twice is refused). Both refused in one line before anything loads."""
    with pytest.raises(SystemExit) as info:
        main(["run", "--preset", "sga", "--map", "classic_ga_gapp3_20x20", *argv])
    err = capsys.readouterr().err
    assert info.value.code == EXIT_BAD_INPUT and err.count("\n") == 1 and words in err


def test_a_goal_out_of_reach_is_known_from_the_regions_and_named_in_metres(
        tmp_path, capsys, monkeypatch):
    """With no path, nothing searches the start's whole region: the A* search of the
    8-connected optimum (43 s on a 2000 x 2000 race track, the start outside it), the
    distance fields of the capacity and of the guided reference are all skipped (made to
    fail here); the reason is the search's own, and on a map with metres the line gives
    the endpoints' cell centres in metres too."""
    from jaxga.maps import save_map
    from jaxga.operators import guide
    from jaxga.reference import optima

    def never(*_a, **_k):
        raise AssertionError("computed for a problem with no path")

    blocked = np.zeros((12, 16), bool)
    blocked[:, 7] = True  # two rooms
    save_map(blocked, tmp_path / "rooms.yaml", resolution=0.5, origin=(-2.0, 1.0, 0.0))
    monkeypatch.setattr(optima, "OctileGraph", never)
    monkeypatch.setattr(guide, "_fields_cached", never)
    rc = main(["run", "--preset", "hybrid", "--map", str(tmp_path / "rooms.yaml"),
               "--start-world", "-1.5,1.5", "--goal-world", "5.5,6.5", "--seeds", "2",
               "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_NO_PATH and "\n" not in err
    assert err == ("jaxga: no path: goal cell (15, 11) unreachable from start cell (1, 1) "
                   "under corner rule 'strict' (start (-1.25, 1.75) m, goal (5.75, "
                   "6.75) m)")
    found = optima.shortest_path_np(blocked[::-1], (1, 1), (15, 11), "strict")
    assert not found.found and found.status == "unreachable"
