"""A saved result run again (:func:`jaxga.rerun`): its JSON fixes every random number of
its runs, so the runs come back bit for bit; a map with other cells, or a file that is no
saved result, is refused in one line."""

from __future__ import annotations

import copy
import json
import os
import warnings

import numpy as np
import pytest

import jaxga
from jaxga.core.errors import EnvironmentWarning
from jaxga.maps import load_map_info
from tests import canonical
from tests.api.test_planner import _ros_map


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A canonical sga run of two scattered seeds with a mutation rate and a crossover of
    the call's own, saved as ``jaxga run --json`` saves it."""
    r = jaxga.run("sga", canonical.MAP, seeds=[11, 2], generations=canonical.GENERATIONS,
                  mutation__probability=0.3)
    path = tmp_path_factory.mktemp("saved") / "run.json"
    path.write_text(json.dumps(r.to_json(), allow_nan=False))
    return r, path


def _same_runs(a, b) -> None:
    np.testing.assert_array_equal(a.seeds, b.seeds)
    np.testing.assert_array_equal(a.cells, b.cells)
    np.testing.assert_array_equal(a.raw_cells, b.raw_cells)
    np.testing.assert_array_equal(a.length, b.length)
    for key in a.history:
        np.testing.assert_array_equal(a.history[key], b.history[key])


def test_a_saved_run_comes_back_bit_for_bit(saved):
    r, path = saved
    _same_runs(jaxga.rerun(path, canonical.MAP), r)  # from the file
    doc = json.loads(path.read_text())
    again = jaxga.rerun(doc, load_map_info(canonical.MAP), any_angle_budget=0)
    _same_runs(again, r)  # from the dictionary, on a map loaded already
    assert again.config == r.config and again.population_capacity == r.population_capacity


def test_a_map_with_other_cells_is_refused_naming_both(saved):
    r, path = saved
    with pytest.raises(jaxga.ParameterError) as e:
        jaxga.rerun(path, "fealpy_grid0_20x20")
    text = str(e.value)
    assert "\n" not in text and f"saved {r.map_digest}" in text


@pytest.mark.parametrize("content, words", [
    ("{", "not a JSON file"),
    ("[1, 2]", "not the JSON of a result"),
    ('{"preset": "sga"}', "needs config, runs, map_digest"),
])
def test_a_file_that_is_no_saved_result_is_refused_in_one_line(tmp_path, content, words):
    path = tmp_path / "x.json"
    path.write_text(content)
    with pytest.raises(jaxga.ParameterError) as e:
        jaxga.rerun(path, canonical.MAP)
    assert words in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(jaxga.ParameterError, match="cannot be read"):
        jaxga.rerun(tmp_path / "missing.json", canonical.MAP)


def _edited(doc: dict, path: tuple, value) -> dict:
    doc = copy.deepcopy(doc)
    *parents, key = path
    target = doc
    for k in parents:
        target = target[k]
    target[key] = value
    return doc


@pytest.mark.parametrize("path, value, words", [
    (("runs", 0, "seed"), 7.9, "seed must be an integer, got 7.9"),
    (("runs", 0, "seed"), True, "seed must be an integer, got True"),
    (("runs", 0, "seed"), "1_0", "seed must be an integer"),
    (("runs", 0, "seed"), float("inf"), "seed must be an integer, got inf"),
    (("runs",), [], "runs must be a non-empty list"),
    (("size_class",), "false", "size_class must be true or false"),
    (("size_class",), 0, "size_class must be true or false"),
    (("population_capacity",), 100.0, "population_capacity must be an integer"),
    (("population_capacity",), None, "population_capacity must be an integer"),
    (("corner_rule",), None, "corner_rule must be a name"),
    (("corner_rule",), "x" * 100_000, "unknown corner rule"),
    (("corner_rule",), "foo", "a saved result's unknown corner rule 'foo'"),
    (("config",), "sga", "config must be an object"),
    (("start",), [1.0, 2], "start must be an integer"),
    (("environment",), "x", "environment must be an object"),
    (("map_digest",), "y" * 100_000, "other cells than the saved result's"),
    (("frame", "coarsen"), 2, "in another frame (coarsen 1, saved 2)"),
    (("map_source", "options"), {"bogus": 1}, "map_source.options must be an object"),
])
def test_a_value_edited_by_hand_is_refused_not_read_as_another_run(saved, path, value, words):
    """A saved value of another type than a run writes is refused in one short line
    naming it, before anything runs: 7.9 is not seed 7, "false" no true size class."""
    doc = _edited(json.loads(saved[1].read_text()), path, value)
    with pytest.raises(jaxga.ParameterError) as e:
        jaxga.rerun(doc, canonical.MAP)
    text = str(e.value)
    assert words in text and "\n" not in text and len(text) < 400


def test_text_duplicate_keys_pipes_and_other_results_are_told_apart(saved, tmp_path):
    """The JSON text itself runs as its file does; a key given twice, a FIFO, a device
    and the JSON of a comparison or an experiment are refused in one line saying so."""
    r, path = saved
    text = path.read_text()
    _same_runs(jaxga.rerun(text, canonical.MAP, any_angle_budget=0), r)
    twice = text.replace('"seed": 11', '"seed": 0, "seed": 11', 1)
    assert twice != text
    with pytest.raises(jaxga.ParameterError, match="'seed' is given twice"):
        jaxga.rerun(twice, canonical.MAP)
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    for special, words in ((fifo, "FIFO"), ("/dev/zero", "not a regular file")):
        with pytest.raises(jaxga.ParameterError, match=words):
            jaxga.rerun(special, canonical.MAP)
    for doc, words in (({"presets": {}}, "comparison"), ({"points": []}, "experiment")):
        with pytest.raises(jaxga.ParameterError, match=words):
            jaxga.rerun(doc, canonical.MAP)


def test_another_environment_is_named_in_a_warning(saved):
    r, path = saved
    doc = json.loads(path.read_text())
    doc["environment"] = {**doc["environment"], "jaxga": "0.0.1", "device": "a gpu"}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _same_runs(jaxga.rerun(doc, canonical.MAP, any_angle_budget=0), r)
    said = [str(w.message) for w in caught if w.category is EnvironmentWarning]
    assert len(said) == 1 and "jaxga '0.0.1' saved" in said[0] and "device" in said[0]
    assert "numpy" not in said[0]


@pytest.mark.slow  # sga's programs for the office ROS map's own capacity
def test_a_robot_map_runs_again_from_its_file_with_the_options_it_was_loaded_with(tmp_path):
    """The JSON records how the map was loaded (map_source): the file alone runs again
    with its robot radius and unknown cells; a map loaded otherwise is refused, the
    options named."""
    office = _ros_map(tmp_path, "office", range(10, 12), pillar=True)
    problem = jaxga.problem("sga", office, generations=canonical.GENERATIONS,
                            corner_rule="free", map_options={
                                "robot_radius": 0.1, "unknown": "free", "start": (1, 1),
                                "goal": (1, 18)})
    r = jaxga.run(problem, seeds=2)
    doc = r.to_json()
    assert doc["map_source"] == {"path": office, "format": "ros", "builtin": False,
                                 "options": {"unknown": "free", "robot_radius": 0.1}}
    _same_runs(jaxga.rerun(doc, office, any_angle_budget=0), r)
    with pytest.raises(jaxga.ParameterError, match="robot_radius=0.1") as e:
        jaxga.rerun(doc, load_map_info(office), any_angle_budget=0)
    assert "\n" not in str(e.value)


def test_a_bare_grid_and_a_coarsened_file_run_the_saved_endpoints(saved, monkeypatch):
    """A Grid of the saved cells runs again (it has no frame, and the saved one has no
    metres); a coarsened map's saved endpoints are planning cells, loaded as such (not
    divided by the factor again), and other endpoints are never run in silence."""
    import jaxga.api.rerun as rerun_module

    r, path = saved
    _same_runs(jaxga.rerun(path, jaxga.maps.load_map(canonical.MAP), any_angle_budget=0), r)
    coarse = load_map_info("room-32-32-4", coarsen=2, start=(6, 0), goal=(31, 25))
    doc = _edited(json.loads(path.read_text()), ("map_source",),
                  {"path": "room-32-32-4", "format": "movingai", "builtin": True,
                   "options": {"coarsen": 2}})
    doc.update(start=list(coarse.grid.start_xy), goal=list(coarse.grid.goal_xy),
               map_digest=coarse.grid.cells_digest(), frame=coarse.frame.to_json())
    ran = []
    monkeypatch.setattr(rerun_module, "run", lambda config, info, *a, **k: ran.append(info))
    jaxga.rerun(doc, "room-32-32-4")
    assert (ran[0].grid.start_xy, ran[0].grid.goal_xy) == ((3, 0), (15, 12))
    doc["map_source"]["options"] = {}  # the same file, not coarsened: other cells
    with pytest.raises(jaxga.ParameterError, match="with no loading option"):
        jaxga.rerun(doc, "room-32-32-4")
    doc["map_source"]["options"] = [1, 2]  # a hand edit, refused in one line
    with pytest.raises(jaxga.ParameterError, match="map_source.options must be"):
        jaxga.rerun(doc, "room-32-32-4")
    with pytest.raises(jaxga.ParameterError, match="other cells") as e:
        jaxga.rerun(doc, load_map_info("room-32-32-4"))  # a MapInfo: the options unread
    assert "loading options" in str(e.value) and "\n" not in str(e.value)
