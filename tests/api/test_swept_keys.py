"""Keys that change no array shape are traced parameters (decision 038).

``init.max_tries``, ``init.fallback``, ``termination.stagnation`` (IMGA 4.4),
``islands.interval``, the per-island rates (MPMGA 4.4), ``mutation.temperature_w`` (MPMGA
eq. 17) and ``fitness.importance_ratios`` (AGACD eq. 21-25) used to be compiled in, so a
sweep refused them. Now one :func:`jaxga.sweep` over two values of each is one compiled
program set, and each point equals a separate :func:`jaxga.run` at its value, seed for
seed. The cases share three program sets (one per preset: the same map, population,
generations and runs per call); the last test adds one finish program (each program is
keyed on the configuration it reads).
"""

from __future__ import annotations

import dataclasses
import warnings

import jax
import numpy as np
import pytest

import jaxga
from jaxga._runtime.programs import Programs, compiled_programs, program_algorithm, program_view
from jaxga.config.presets import load_preset, preset_names
from jaxga.config.schema import SCHEMA, Config, sweepable
from jaxga.core.errors import InitialisationWarning, ParameterError
from jaxga.doe import Factor
from jaxga.doe.design import check_factors
from jaxga.engine import PER_ISLAND, finish
from jaxga.engine.run import run_evolve, run_init

MAP = "classic_ga_gapp3_20x20"
SMALL = dict(seeds=2, generations=4)
"""Every call of this file: each preset at its own defaults on the README's map, 2
points x 2 seeds and 2 seeds both one call of the 4-run program, any number of
generations up to 25 one call of the evolve chunk: the sweeps and the runs of a preset
share one program set, and the suite's other runs of the preset on this map share it
too."""

CASES = [
    # (preset, key, value a, value b, base overrides)
    ("sga", "init.max_tries", 1, 30, {}),
    ("sga", "init.fallback", "field_walk", "none", {"init__max_tries": 3}),
    ("sga", "termination.stagnation", 0, 1, {}),
    ("mpmga", "islands.interval", 1, 3, {}),
    ("mpmga", "islands.crossover_probabilities", [0.1, 0.8, 0.1], [0.9, 0.0, 0.5], {}),
    ("mpmga", "islands.mutation_probabilities", [0.1, 0.1, 0.8], [0.9, 0.0, 0.5], {}),
    # the annealing decides between worse mutants only once the population has some
    # (no difference within 10 generations here): 25 generations, still one chunk
    ("mpmga", "mutation.temperature_w", 1.0, 0.05, {"generations": 25}),
    ("agacd", "fitness.importance_ratios", [1.2, 1.4], [0.2, 5.0], {}),
]

KEYS = ("cells", "n_cells", "raw_cells", "raw_n_cells", "length", "raw_length", "fitness",
        "success", "convergence_generation", "failures", "init_success_rate",
        "init_unfilled", "init_fallback", "initial_fitness")


def _kw(key: str) -> str:
    return key.replace(".", "__")


def _arrays(result: jaxga.Result) -> dict[str, np.ndarray]:
    out = {k: np.asarray(getattr(result, k)) for k in KEYS}
    out.update({f"history.{k}": np.asarray(v) for k, v in result.history.items()})
    out.update({f"metrics.{k}": np.asarray(v) for k, v in result.metrics.items()})
    return out


def _quiet(fn, *args, **kwargs):
    """``fn`` with the initialisation's warning (slots left to copies under
    ``init.fallback = "none"``) silenced: it is what the case sets out to do."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InitialisationWarning)
        return fn(*args, **kwargs)


@pytest.mark.parametrize("preset, key, a, b, base", CASES, ids=[c[1] for c in CASES])
def test_one_sweep_over_a_traced_key_equals_separate_runs(preset, key, a, b, base):
    """The key is dynamic; one sweep over two of its values compiles at most one program
    set (none when an earlier case of the preset compiled it), the runs at each value
    compile none (they take the sweep's programs: the value is not part of them), and
    every point's results equal its run's, array for array."""
    assert SCHEMA[key].dynamic and sweepable(key)
    before = compiled_programs.cache_info().misses
    points = [{key: a}, {key: b}]
    options = {**SMALL, **base}
    swept = _quiet(jaxga.sweep, preset, MAP, points, **options)
    after_sweep = compiled_programs.cache_info().misses
    assert after_sweep - before <= 1
    for value, res in zip((a, b), swept):
        single = _quiet(jaxga.run, preset, MAP, **options, **{_kw(key): value})
        assert single.config[key] == res.config[key]
        got, want = _arrays(res), _arrays(single)
        for name in want:
            assert np.array_equal(got[name], want[name], equal_nan=True), (key, value, name)
    assert compiled_programs.cache_info().misses == after_sweep  # the runs compiled nothing
    first, second = (_arrays(r) for r in swept)
    assert any(not np.array_equal(first[n], second[n], equal_nan=True) for n in first), \
        f"{key}: both values gave the same results, so the case shows nothing"


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["sga", "mpmga", "agacd"])
def test_traced_keys_are_parameters_of_the_pure_core(preset):
    """``jaxga.GA``: each of the preset's traced keys is a leaf of ``default_params`` (a
    per-island list under its rate's name, ``[islands]``), and a ``vmap`` over all of them
    traces (``eval_shape``: nothing is compiled)."""
    ga = jaxga.GA(preset, MAP, generations=2)
    params = dict(ga.default_params)
    keys = [k for p, k, *_ in CASES if p == preset]
    leaves = {next((rate for rate, isl in PER_ISLAND.items() if isl == k), k) for k in keys}
    assert leaves <= set(params)
    assert params["init.max_tries"].dtype == np.int32
    batched = {k: np.stack([np.asarray(v)] * 3) if k in leaves else v
               for k, v in params.items()}
    axes = {k: 0 if k in leaves else None for k in params}
    out = jax.eval_shape(jax.vmap(lambda p: ga.run(jax.random.PRNGKey(0), p), (axes,)),
                         batched)
    assert out["fitness"].shape == (3,)


@pytest.mark.parametrize("preset, points, words", [
    ("mpmga", [{"islands.crossover_probabilities": [0.1, 0.8]}],
     "islands.crossover_probabilities has 2 entries for 3 islands"),
    ("mpmga", [{"islands.mutation_probabilities": [0.1, 0.1, 0.8, 0.2]}],
     "islands.mutation_probabilities has 4 entries for 3 islands"),
    ("agacd", [{"fitness.importance_ratios": [1.2]}],
     "fitness.importance_ratios needs 2 entries"),
    ("sga", [{"islands.crossover_probabilities": [0.5]}, {}],
     "crossover.probability shape () (float32) where the first point gives it shape (1,)"),
])
def test_a_list_of_the_wrong_length_is_refused_in_one_line(preset, points, words):
    """A list's length is fixed by static keys (``islands.count``, AGACD's three
    objectives): another length is refused before anything compiles, in one line; so is
    a point that gives a parameter another shape than the others."""
    with pytest.raises(ParameterError) as err:
        jaxga.sweep(preset, MAP, points, **SMALL)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_integer_keys_are_factors_of_a_designed_experiment():
    """``jaxga.doe`` takes the traced integer keys as factors (one compiled sweep); a
    static key is still refused."""
    check_factors(load_preset("mpmga"), [Factor("islands.interval", (1, 2, 3)),
                                         Factor("init.max_tries", (5, 10, 20))])
    check_factors(load_preset("imga"), [Factor("termination.stagnation", (0, 10, 40))])
    with pytest.raises(ParameterError, match="islands.migrants' changes the compiled"):
        check_factors(load_preset("mpmga"), [Factor("islands.migrants", (1, 2, 3))])


def test_a_key_only_the_finish_reads_compiles_the_finish_alone():
    """Each program is keyed on the configuration sections it reads
    (:func:`jaxga._runtime.programs.program_view`): ``sga`` with another ``post.method``
    takes the init and evolve programs of the ``sga`` cases above and compiles only its
    finish program, also when the shared programs of that program set were pushed out
    by others (as after eight other program sets): a program set used again shares its
    programs anew."""
    from jaxga._runtime import programs

    jaxga.run("sga", MAP, **SMALL)  # the programs of the sga cases
    programs._SHARED_PROGRAMS.clear()
    jaxga.run("sga", MAP, **SMALL)  # the same program set, used again
    before = set(programs._SHARED_PROGRAMS)
    r = jaxga.run("sga", MAP, **SMALL, post__method="shortcut_greedy")
    assert r.success.all()
    assert [key[0] for key in programs._SHARED_PROGRAMS if key not in before] == ["finish"]


def test_the_unfilled_warning_names_each_runs_budget():
    """A sweep over ``init.max_tries`` warns with the budgets of the runs left short, not
    the preset's."""
    from jaxga.api.failures import warn_unfilled

    cfg = load_preset("sga")
    with pytest.warns(InitialisationWarning, match=r"init.max_tries = 1-30 did not fill"):
        warn_unfilled(np.array([12, 5, 0]), np.array([0.1, 0.2, 0.3]), 60, cfg,
                      np.array([1, 30, 100]))
    with pytest.warns(InitialisationWarning, match=r"init.max_tries = 100 did not fill"):
        warn_unfilled(np.array([12]), np.array([0.1]), 60, cfg)


class _ReadsRecorded(Config):
    """A program's view of a configuration that records every read of a key the full
    configuration has but the view hides (such a read would silently see the default)."""

    hidden: dict = {}
    reads: list = []

    def __getitem__(self, key: str):
        try:
            return super().__getitem__(key)
        except KeyError:
            if key in self.hidden:
                self.reads.append(key)
            raise


@pytest.mark.slow
@pytest.mark.parametrize("preset", sorted(preset_names()))
def test_each_program_reads_only_its_own_view_of_the_configuration(preset):
    """Every preset's init, evolve and finish programs traced (``jax.eval_shape``: nothing
    compiles) from their views (:func:`jaxga._runtime.programs.program_view`) read no key
    outside them: a program shared by configurations that differ only outside its view
    computes the same thing for all of them."""
    ga = jaxga.GA(preset, MAP)
    algo = program_algorithm(ga.algorithm)
    full = dict(algo.config.items)
    views = {}
    for name in Programs.NAMES:
        view = program_view(algo, name)
        config = _ReadsRecorded(view.config.items)
        config.hidden, config.reads = {k: v for k, v in full.items()
                                       if k not in dict(view.config.items)}, []
        views[name] = dataclasses.replace(view, config=config)
    key, params = jax.random.PRNGKey(0), ga.default_params
    state, _ = jax.eval_shape(lambda k, g, p: run_init(views["init"], k, g, p),
                              key, ga.grid, params)
    state, _ = jax.eval_shape(lambda k, g, s, p: run_evolve(views["evolve"], k, g, s, p, 2),
                              key, ga.grid, state, params)
    jax.eval_shape(lambda g, s, p: finish(views["finish"], g, s, None, p),
                   ga.grid, state, params)
    assert {name: view.config.reads for name, view in views.items()} == {
        name: [] for name in Programs.NAMES}
