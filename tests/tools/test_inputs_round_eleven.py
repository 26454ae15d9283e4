"""Round eleven of hostile inputs (decision 057): long-lived processes, statistics and
designs checked against independent references, results across layouts, and every file
jaxga writes read back by another reader."""

from __future__ import annotations

import argparse
import os
import tempfile

import jax
import numpy as np
import pytest
import yaml

from jaxga import export
from jaxga.cli.replan import read_robot_path
from jaxga.core import files
from jaxga.core.errors import JaxgaError, MapFormatError, ParameterError
from jaxga.core.grid import Grid
from jaxga.maps import load_map, load_map_info, save_map
from jaxga.maps.frame import cells_crossed
from jaxga.operators.repair import connect
from jaxga.operators.selection import roulette
from jaxga.reference.optima import clear_np


def test_a_signal_the_moment_a_temporary_folder_is_made_removes_it(tmp_path, monkeypatch):
    """The cleanup a signal runs finds a temporary folder from the moment it exists: here
    it runs right after the folder is made, as a SIGTERM there would, and nothing is left.
    (``mkdtemp`` made it before it was registered, and a signal in between left it.) A
    folder made without a signal is private and removed by the same cleanup."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    real_mkdir = os.mkdir

    def mkdir_then_signal(path, mode=0o777, **kw):
        real_mkdir(path, mode, **kw)
        files.remove_temporaries()  # what interrupts.stop runs before os._exit
        raise KeyboardInterrupt

    monkeypatch.setattr(files.os, "mkdir", mkdir_then_signal)
    with pytest.raises(KeyboardInterrupt):
        files.temporary_folder("jaxga-test-")
    monkeypatch.undo()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    assert list(tmp_path.iterdir()) == [] and not files._FOLDERS

    folder = files.temporary_folder("jaxga-test-")
    assert folder.parent == tmp_path and folder.name.startswith("jaxga-test-")
    assert folder.stat().st_mode & 0o777 == 0o700
    (folder / "inside").write_text("x")
    files.remove_temporaries()
    assert list(tmp_path.iterdir()) == [] and not files._FOLDERS


@pytest.mark.parametrize("name", [" lead.yaml", "a #b.yaml", "#a.yaml", "- x.yaml",
                                  "x: y.yaml", "t\tab.yaml", "&a.yaml", '"q.yaml', "'q.yaml",
                                  "u\u2028v.yaml", "\u00e9.yaml", "[a].yml",
                                  "\U0001F600.yaml", "a\udcffb.yaml"])
def test_a_ros_map_saved_under_any_name_reads_back(tmp_path, monkeypatch, name):
    """The YAML names its image as a quoted scalar: unquoted, a leading space was lost (a
    map read back another map's image), '#' began a comment and an indicator made the file
    unreadable; a character beyond the BMP, written as JSON's surrogate pair, read back
    as two lone surrogates no file can be named by. PyYAML reads the name back as written,
    jaxga the map, and the map saves again over itself."""
    monkeypatch.chdir(tmp_path)
    other = np.zeros((6, 7), bool)
    save_map(other, name.strip().lstrip("#&-\"'[x: ") + "other.yaml")
    ours = other.copy()
    ours[1:, 3] = True
    save_map(ours, name, resolution=0.05, origin=(1.0, -2.0, 0.0))
    doc = yaml.safe_load((tmp_path / name).read_text(encoding="utf-8"))
    assert doc["image"] == name[:-len(name.rsplit(".", 1)[1])] + "pgm"
    np.testing.assert_array_equal(load_map(name).blocked_np(), ours)
    save_map(other, name, resolution=0.05)
    np.testing.assert_array_equal(load_map(name).blocked_np(), other)


@pytest.mark.parametrize("image", ["\\ud83d.pgm", "a\\0b.pgm"])
def test_a_file_name_no_file_can_have_is_one_line(tmp_path, monkeypatch, image):
    """A YAML naming its image with a lone surrogate (or a NUL) is refused in one line
    naming the map, as is a map saved under such a name: ``os``'s UnicodeEncodeError
    came through a traceback."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.yaml").write_text(f'image: "{image}"\nresolution: 0.1\n'
                                     "origin: [0, 0, 0]\nnegate: 0\n"
                                     "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    with pytest.raises(MapFormatError, match=r"m.yaml: .*(no file can have this name|"
                                             r"image must be a file name)"):
        load_map("m.yaml")
    name = yaml.safe_load(f'"{image}"')[:-4] + ".yaml"
    with pytest.raises(JaxgaError, match=r"cannot write .*(no file can have this name|"
                                         r"cannot hold a NUL)"):
        save_map(np.zeros((3, 3), bool), name, resolution=0.1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.yaml"]


def test_a_ros_map_is_not_saved_over_another_maps_image(tmp_path):
    """``b.yml`` beside ``b.yaml`` would write ``b.pgm``, b.yaml's image: refused, and the
    other map untouched. Saving a map again over itself rewrites its own image."""
    first = np.zeros((5, 5), bool)
    first[2, 2] = True
    save_map(first, tmp_path / "b.yaml")
    before = (tmp_path / "b.pgm").read_bytes()
    with pytest.raises(MapFormatError, match=r"b.yml: its image .*b.pgm exists and is not "
                                             "the image of the map being replaced"):
        save_map(np.zeros((3, 3), bool), tmp_path / "b.yml")
    assert (tmp_path / "b.pgm").read_bytes() == before and not (tmp_path / "b.yml").exists()
    (tmp_path / "c.pgm").write_bytes(b"not ours")  # an image no YAML names
    with pytest.raises(MapFormatError, match="c.pgm exists"):
        save_map(first, tmp_path / "c.yaml")
    assert (tmp_path / "c.pgm").read_bytes() == b"not ours"
    again = np.ones((5, 5), bool)
    again[0, 0] = False
    save_map(again, tmp_path / "b.yaml")  # b.yaml names b.pgm: its own image
    np.testing.assert_array_equal(load_map(tmp_path / "b.yaml").blocked_np(), again)


def _sampled_cells(p, q, n=20001):
    """The cells of ``n`` points along the segment, in order, repeats dropped: the
    reference for segments that pass no grid vertex."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    xy = np.floor(np.asarray(p) + t * (np.asarray(q) - np.asarray(p))).astype(int)
    keep = np.r_[True, np.any(xy[1:] != xy[:-1], axis=1)]
    return [tuple(c) for c in xy[keep].tolist()]


def test_the_cells_a_segment_crosses_are_those_along_it():
    """Amanatides & Woo's walk against dense sampling on random segments (none near a
    vertex), and the hand-made cases: straight, backwards, through vertices."""
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(400):
        p, q = rng.uniform(-3, 9, 2), rng.uniform(-3, 9, 2)
        ref = _sampled_cells(p, q)
        # a segment within a sample's step of a vertex may skip a corner cell in sampling
        if any(abs(a[0] - b[0]) + abs(a[1] - b[1]) > 1 for a, b in zip(ref, ref[1:])):
            continue
        assert cells_crossed(tuple(p), tuple(q)) == ref
        checked += 1
    assert checked > 300
    assert cells_crossed((0.5, 0.5), (2.5, 1.5)) == [(0, 0), (1, 0), (1, 1), (2, 1)]
    assert cells_crossed((0.5, 0.5), (2.5, 2.5)) == [(0, 0), (1, 1), (2, 2)]  # vertices
    assert cells_crossed((2.5, 2.5), (0.5, 0.5)) == [(2, 2), (1, 1), (0, 0)]
    assert cells_crossed((0.5, 0.5), (0.5, 3.5)) == [(0, 0), (0, 1), (0, 2), (0, 3)]
    assert cells_crossed((0.2, 0.7), (0.9, 0.1)) == [(0, 0)]


def test_segments_between_grid_points_cross_the_cells_along_them():
    """Endpoints on grid lines and vertices (quarter cells), in every direction: the walk
    goes from p's cell to q's by side or vertex steps, visits no cell twice, and its cells
    are exactly those of p, q and every stretch between two grid lines the segment meets
    (its midpoint's cell). A segment ending on a line going down or left stepped past q,
    off the map."""
    rng = np.random.default_rng(12)
    for _ in range(3000):
        p, q = rng.integers(0, 25, 2) / 4, rng.integers(0, 25, 2) / 4
        out = cells_crossed(tuple(p), tuple(q))
        d = q - p
        ts = {0.0, 1.0}
        for k in range(2):
            if d[k]:
                ts |= {(g - p[k]) / d[k] for g in range(0, 8)}
        ts = sorted(t for t in ts if 0.0 <= t <= 1.0)
        want = {tuple(np.floor(p).astype(int)), tuple(np.floor(q).astype(int))}
        want |= {tuple(np.floor(p + (a + b) / 2 * d).astype(int))
                 for a, b in zip(ts, ts[1:]) if b > a}
        assert out[0] == tuple(np.floor(p).astype(int))
        assert out[-1] == tuple(np.floor(q).astype(int))
        assert len(set(out)) == len(out) and set(out) == want, (p, q, out)
        assert all(max(abs(a[0] - b[0]), abs(a[1] - b[1])) == 1 for a, b in zip(out, out[1:]))
    assert cells_crossed((2.0, 0.0), (1.0, 1.0)) == [(2, 0), (1, 0), (1, 1)]
    assert cells_crossed((0.0, 4.0), (1.0, 0.0))[-1] == (1, 0)
    assert cells_crossed((0.5, 0.5), (1.0, 1.0)) == [(0, 0), (1, 1)]


def test_a_recorded_curve_that_cuts_no_corner_is_not_a_blocked_step(tmp_path):
    """A path in metres (``jaxga replan --path``, as ``--smooth --path-out`` writes a
    curve) whose consecutive points lie in diagonal cells (0, 0) and (1, 1): the curve
    passes through (0, 1), but the chord between the cells' centres cuts the corner of
    the blocked (1, 0), which the strict rule calls a blocked step. The cells the curve
    crosses are taken instead; a path through a vertex keeps its diagonal step."""
    image = np.full((4, 4), 254, np.uint8)
    image[3, 1] = 0  # row 3 from the top: map cell (1, 0)
    (tmp_path / "m.pgm").write_bytes(b"P5\n4 4\n255\n" + image.tobytes())
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.5\norigin: [0, 0, 0]\n"
                                     "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    info = load_map_info(str(tmp_path / "m.yaml"), corner_rule="strict")
    assert info.grid.blocked_np()[0, 1]

    def cells(points):
        path = tmp_path / "p.csv"
        path.write_text("x,y\n" + "".join(f"{x},{y}\n" for x, y in points))
        args = argparse.Namespace(path=str(path), path_json=None, run=None, raw=False)
        return read_robot_path(args, info, "strict")

    got = cells([(0.4, 0.3), (0.6, 0.8), (1.6, 1.6)])  # metres: cells (0, 0), (1, 1), (3, 3)
    assert got == [(0, 0), (0, 1), (1, 1), (3, 3)]
    blocked = info.grid.blocked_np()
    assert all(clear_np(blocked, "strict", a, b) for a, b in zip(got, got[1:]))
    # a chord that is clear stays as it was: no cells added
    assert cells([(0.25, 1.25), (1.25, 1.75)]) == [(0, 2), (2, 3)]


@pytest.mark.parametrize("n", [0, 1, 2, 7, 400])
def test_a_path_yaml_is_what_yaml_writes_in_a_fraction_of_its_time(n):
    """``path_text`` writes a nav_msgs/Path line by line (``yaml.safe_dump`` took half a
    millisecond a pose, a minute for 100,000): the same text as ``safe_dump`` of the same
    document, which PyYAML reads back as the same numbers."""
    rng = np.random.default_rng(n)
    p = np.cumsum(rng.normal(size=(n, 2)), axis=0) * 0.37 + [-2e-5, 1234.5]
    if n > 3:
        p[3] = p[2]  # a repeated point takes the next direction
    d = 4  # the steps (about a third of a metre) ask for no more decimals
    yaw = export.path_yaws(p)
    reference = yaml.safe_dump({"header": {"frame_id": "map"}, "poses": [
        {"header": {"frame_id": "map"},
         "pose": {"position": {"x": round(float(x), d), "y": round(float(y), d), "z": 0.0},
                  "orientation": {"x": 0.0, "y": 0.0, "z": round(float(np.sin(a / 2)), 6),
                                  "w": round(float(np.cos(a / 2)), 6)}}}
        for (x, y), a in zip(p, yaw)]}, sort_keys=False)
    text = export.path_text(p, "yaml", decimals=d)
    assert yaml.safe_load(text) == yaml.safe_load(reference)
    assert text == reference


@pytest.mark.parametrize("fmt", ["yaml", "csv"])
def test_a_path_with_a_point_that_is_not_a_number_is_refused(tmp_path, fmt):
    """A NaN or infinite coordinate was written as ``nan`` / ``inf``, which YAML reads as
    a string: refused in one line naming the point, and no file is written."""
    points = np.array([[0.0, 0.0], [1.0, np.nan], [2.0, np.inf]])
    with pytest.raises(JaxgaError, match=r"point 1 is \(1.0, nan\)"):
        export.path_text(points, fmt)
    with pytest.raises(JaxgaError, match="finite numbers"):
        export.write_path(tmp_path / f"p.{fmt}", points)
    assert list(tmp_path.iterdir()) == []


def test_a_roulette_over_weights_whose_sum_overflows_draws_evenly():
    """Five equal weights of 3e38: their float32 sum overflowed, and every draw took the
    last eligible individual. Scaled by the largest, they draw as five equal weights of
    0.5 do; infinite weights share the draws evenly; ordinary weights are untouched."""
    draw = jax.jit(roulette)  # one program for the three draws
    key = jax.random.PRNGKey(3)
    active = np.arange(6) < 5
    huge = draw(key, np.full(6, 3e38, np.float32), active)
    np.testing.assert_array_equal(huge, draw(key, np.full(6, 0.5, np.float32), active))
    assert len(set(np.asarray(huge).tolist())) > 1
    draws = np.asarray(draw(key, np.array([1.0, np.inf, 2.0, np.inf, 1.0, 1.0], np.float32),
                            np.ones(6, bool)))
    assert set(draws.tolist()) <= {1, 3} and len(set(draws.tolist())) == 2


def test_a_capacity_too_small_for_an_operators_anchors_is_one_line():
    """``segment_sa`` joins two anchor cells (``repair.connect``): at
    ``population.capacity`` 1 (a start equal to its goal fits) it raised a bare
    ValueError through a traceback; it is now a ParameterError naming the key, raised
    when the program is traced, before any work."""
    grid = Grid.create(np.zeros((4, 4), bool), start=(1, 1), goal=(1, 1))
    with pytest.raises(ParameterError, match=r"cannot hold the 2 cells this operator joins "
                                             r".* population.capacity .*>= 2"):
        connect(jax.random.PRNGKey(0), grid, np.array([5, 5], np.int32), 2, capacity=1)


# ------------------------------------------------- a review of decision 058's changes
def test_an_input_no_file_can_have_beside_an_output_is_one_line(tmp_path, monkeypatch,
                                                                  capsys):
    """The outputs are checked against every input before any work, the image a ROS YAML
    names among them: an image named by a lone surrogate went through ``same_file``'s
    ``Path.resolve`` (UnicodeEncodeError, a traceback) before the map's reader could
    refuse it in one line."""
    from jaxga.cli import EXIT_BAD_INPUT, main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.yaml").write_text('image: "\\ud83d.pgm"\nresolution: 0.1\n'
                                     "origin: [0, 0, 0]\nnegate: 0\n"
                                     "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    assert main(["run", "--preset", "sga", "--map", "m.yaml", "--json", "o.json",
                 "--quiet"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert "no file can have this name" in err and "\n" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.yaml"]
    for name in ("m\0.yaml", "\ud83d.pgm"):
        assert not files.same_file("o.json", name)
        files.check_outputs({"--json": "o.json"}, [("map", name)])  # nothing to refuse
    assert files.same_file("\ud83d.pgm", "./\ud83d.pgm")
    with pytest.raises(JaxgaError, match=r"^cannot write --json out\\ud83d.json: no file"):
        files.check_outputs({"--json": "out\ud83d.json"})


def test_a_name_too_long_for_any_file_system_is_one_line_when_written(tmp_path):
    """Every writer, not only the command line's checks: a name over 255 bytes, or a
    folder in the path that long, was ``OSError: [Errno 36] File name too long`` from the
    Python API (``atomic_write``'s stream check ran before its error handling)."""
    grid = np.zeros((3, 3), bool)
    writes = {
        "text": lambda p: files.atomic_write_text(p, "x"),
        "path": lambda p: export.write_path(p.with_suffix(".csv"), np.zeros((2, 2))),
        "map": lambda p: save_map(grid, p.with_suffix(".yaml"), resolution=0.1),
    }
    for what, write in writes.items():
        for path, words in ((tmp_path / ("y" * 256 + ".json"), "its name has 2"),
                            (tmp_path / ("x" * 300) / "a.json", "File name too long")):
            with pytest.raises(JaxgaError, match=f"^cannot write .*{words}") as e:
                write(path)
            assert "\n" not in str(e.value), what
    assert list(tmp_path.iterdir()) == []


def test_a_stored_program_already_removed_is_said_removed(tmp_path, monkeypatch):
    """Two processes that read one damaged program both remove it: the second's unlink
    finds nothing, and its warning said the store "takes no changes"; a program this
    process read that is gone when it is forgotten is not marked never to read again."""
    from jaxga._runtime import executables
    from jaxga.core.errors import CacheWarning

    monkeypatch.setattr(executables, "_FORGOTTEN", set())
    with pytest.warns(CacheWarning, match="is damaged .*: removed, compiling it again"):
        executables._forget(tmp_path / "gone.pkl", "is damaged (its digest does not match)")
    monkeypatch.setattr(type(jax.config), "jax_compilation_cache_dir",
                        property(lambda self: str(tmp_path)), raising=False)
    monkeypatch.setattr(executables, "_READ", {"gone"})
    monkeypatch.setattr(executables, "_NOT_READ", set())
    assert executables.forget_read() and executables._NOT_READ == set()


@pytest.mark.parametrize("base, words", [("a\\u0000.toml", "cannot hold a NUL"),
                                         ("a\\ud83d.toml", None)])
def test_a_preset_base_no_file_can_have_is_one_line(tmp_path, base, words):
    """A preset file's ``base`` is read from the file, where TOML writes a NUL as
    ``\\u0000``: ``Path.resolve`` raised ValueError (a traceback). TOML has no lone
    surrogates (tomllib refuses the file); a name given in Python can hold one."""
    from jaxga.config.presets import load_preset

    (tmp_path / "p.toml").write_text(f'base = "{base}"\n')
    with pytest.raises(ParameterError, match=words or "p.toml: ") as e:
        load_preset(tmp_path / "p.toml")
    assert "\n" not in str(e.value)
    with pytest.raises(ParameterError, match=r"^configuration file a\\ud83d.toml: no file"):
        load_preset("a\ud83d.toml")


def test_a_name_is_shown_with_escapes_for_its_unprintable_characters_only():
    """Backslashes and quotes as they are (a Windows path stays readable), a NUL or a lone
    surrogate escaped."""
    assert files.shown_name("C:\\maps\\a\0.yaml") == "C:\\maps\\a\\x00.yaml"
    assert files.shown_name("it's \"x\"\ud83d.yaml") == "it's \"x\"\\ud83d.yaml"
    assert files.shown_name("plain é.yaml") == "plain é.yaml"
