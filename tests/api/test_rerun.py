"""A saved result run again (:func:`jaxga.rerun`): its JSON fixes every random number of
its runs, so the runs come back bit for bit; a map with other cells, or a file that is no
saved result, is refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

import jaxga
from jaxga.maps import load_map_info
from tests import canonical


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
