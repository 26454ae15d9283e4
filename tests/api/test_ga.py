"""The pure core (:class:`jaxga.GA`): host work in the constructor, then pure functions under
the user's own ``jit``, ``vmap`` (over keys and over parameters) and ``scan``."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxga
from jaxga.core.errors import ParameterError
from jaxga.core.paths import is_continuous
from tests import canonical

MAP = canonical.MAP
SEEDS = [0, 1, 2, 3]
GENERATIONS = 25


@pytest.fixture(scope="module")
def ga():
    return jaxga.GA("sga", MAP, generations=GENERATIONS)


@pytest.fixture(scope="module")
def reference():
    """Seeds 0-3 of ``jaxga.run``: what the pure core must give bit for bit."""
    ref = canonical.run("sga", SEEDS, generations=GENERATIONS)  # the canonical program
    assert ref.success.all()
    return ref


def assert_seed_for_seed(out: dict, ref) -> None:
    """``GA.finish`` outputs (one row per seed) equal ``ref``'s runs: success, fitness,
    node counts, failures and the post-optimised paths."""
    for key, expected in (("success", ref.success), ("fitness", ref.fitness),
                          ("n_cells", ref.n_cells), ("raw_n_cells", ref.raw_n_cells),
                          ("failures", ref.failures)):
        np.testing.assert_array_equal(np.asarray(out[key]), expected, err_msg=key)
    for i in range(len(ref.seeds)):
        n = int(ref.n_cells[i])
        np.testing.assert_array_equal(np.asarray(out["cells"][i, :n]), ref.cells[i, :n])


def test_a_run_of_the_pure_core_is_seed_for_seed_jaxga_run(ga, reference):
    """``GA.run(PRNGKey(s))`` under the user's ``jit(vmap)`` gives seed ``s`` of
    ``jaxga.run``, path for path (sga needs the distance fields its fallback initialiser
    steers by: the constructor attaches them)."""
    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(SEEDS, jnp.uint32))
    out = jax.jit(jax.vmap(ga.run, (0, None)))(keys, ga.default_params)
    assert_seed_for_seed(out, reference)
    np.testing.assert_array_equal(np.asarray(out["convergence_generation"]),
                                  reference.convergence_generation)


@pytest.mark.slow
def test_init_step_and_a_users_scan_over_keys_and_a_rate(ga):
    """init, then the user's own scan of ``step`` for 5 generations, vmapped over 3 keys x 2
    mutation rates: every population stays continuous and every generation counter is 5;
    the best fitness never falls."""
    params = ga.default_params
    rates = jnp.asarray([0.05, 0.5], jnp.float32)
    keys = jax.random.split(jax.random.PRNGKey(7), 3)

    def one(key, rate):
        p = {**params, "mutation.probability": rate}
        state = ga.init(key, p)
        first = state.best_fitness

        def body(s, t):
            return ga.step(jax.random.fold_in(key, t), s, p), s.best_fitness

        state, best = jax.lax.scan(body, state, jnp.arange(5))
        cells, length = state.islands.cells, state.islands.length
        continuous = jax.vmap(lambda c, n: is_continuous(ga.grid, c, n))(
            cells.reshape(-1, cells.shape[-1]), length.reshape(-1))
        return state.generation, first, best, continuous, ga.finish(state, p)["success"]

    grid_keys, grid_rates = jnp.repeat(keys, 2, axis=0), jnp.tile(rates, 3)
    generation, first, best, continuous, success = jax.jit(jax.vmap(one))(grid_keys,
                                                                          grid_rates)
    assert generation.tolist() == [5] * 6
    assert np.all(np.diff(np.asarray(best), axis=1) >= 0) and np.all(best[:, 0] == first)
    assert bool(jnp.all(continuous)) and bool(jnp.all(success))


def test_the_constructor_checks_what_jaxga_run_checks():
    with pytest.raises(ParameterError):
        jaxga.GA("sga", MAP, no_such__key=1)
    with pytest.raises(jaxga.EndpointError):
        jaxga.GA("sga", MAP, corner_rule="free").__class__("sga", jaxga.Grid.create(
            np.ones((4, 4), bool), start=(0, 0), goal=(3, 3)))


@pytest.mark.parametrize("values, words", [
    ({"mutation.probability": float("nan")}, "mutation.probability must be finite"),
    ({"crossover__probability": -1.0}, "crossover.probability = -1.0 is below its minimum"),
    ({"population__size": 1000}, "population.size 1000 is more than the GA's 60"),
    ({"population__size": 0}, "population.size = 0 is below its minimum 2"),
    ({"generations": 6}, "generations is not a parameter of the pure core's calls"),
    ({"mutation__method": "replace_point"}, "mutation.method is not a parameter"),
    ({"population__capacity_factor": 2.0}, "population.capacity_factor is not a parameter"),
])
def test_params_are_checked_as_jaxga_run_checks_them(values, words):
    """A value set in default_params by hand ran unchecked (a NaN rate, 1000 active
    individuals of 60 run as 60, a generations of 6 changed nothing): ga.params() sets
    dynamic keys checked, and refuses the rest in one line. Nothing is compiled."""
    ga = jaxga.GA("sga", MAP, generations=5)
    p = ga.params(crossover__probability=0.5, population__size=30)
    assert float(p["crossover.probability"]) == 0.5 and int(p["population.active"]) == 30
    assert set(p) == set(ga.default_params) and int(p["generations"]) == 5
    with pytest.raises(ParameterError, match=words) as e:
        ga.params(**values)
    assert "\n" not in str(e.value)


@pytest.mark.slow
def test_vmap_over_three_mutation_rates_equals_three_separate_runs(ga):
    """One ``jit(vmap)`` of ``GA.run`` over three values of ``mutation.probability`` (seed
    2 each) gives what three separate ``jaxga.run`` calls with those rates give."""
    rates = [0.01, 0.2, 0.9]
    params = {**ga.default_params,
              "mutation.probability": jnp.asarray(rates, jnp.float32)}
    axes = {k: (0 if k == "mutation.probability" else None) for k in params}
    out = jax.jit(jax.vmap(ga.run, (None, axes)))(jax.random.PRNGKey(2), params)
    for i, rate in enumerate(rates):
        ref = canonical.run("sga", [2], generations=GENERATIONS, mutation__probability=rate)
        assert float(out["fitness"][i]) == float(ref.fitness[0])
        n = int(ref.n_cells[0])
        np.testing.assert_array_equal(np.asarray(out["cells"][i, :n]), ref.cells[0, :n])
        np.testing.assert_array_equal(np.asarray(out["failures"][i]), ref.failures[0])
    assert len({float(f) for f in np.asarray(out["fitness"])}) > 1 or \
        len({int(x) for x in np.asarray(out["failures"][:, 1])}) > 1  # the rate mattered


@pytest.mark.slow
def test_a_users_own_scan_over_step_is_jaxga_run_seed_for_seed(ga, reference):
    """The user's loop: ``init`` on ``fold_in(key, 0)`` is the initial population of
    ``GA.init(key)``, then a ``lax.scan`` over ``ga.step`` with generation ``t``'s key
    ``fold_in(fold_in(key, 1), t)``, then ``finish``: seeds 0-3 of ``jaxga.run``, bit for
    bit (paths, node counts, fitness, failures)."""
    params = ga.default_params

    def users_run(key):
        state = ga.init(key, params)
        evolve_key = jax.random.fold_in(key, 1)

        def body(s, t):
            return ga.step(jax.random.fold_in(evolve_key, t), s, params), None

        state, _ = jax.lax.scan(body, state, jnp.arange(GENERATIONS))
        return ga.finish(state, params)

    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(SEEDS, jnp.uint32))
    assert_seed_for_seed(jax.jit(jax.vmap(users_run))(keys), reference)


def test_the_drivers_trace_the_pure_cores_own_methods(monkeypatch):
    """One door to the engine: :class:`jaxga.GA` is a :class:`~jaxga.engine.run.PureGA`, and
    the programs of :func:`jaxga.run` are traced from the methods of a ``PureGA`` of each
    program's view of the algorithm (init with its statistics, the evolve chunk, finish),
    the functions the pure core runs."""
    from jaxga._runtime import programs
    from jaxga._runtime.programs import compiled_programs, shape_spec, stack_params
    from jaxga.engine.run import PureGA

    assert issubclass(jaxga.GA, PureGA)
    called = []

    def spy(name):
        real = getattr(PureGA, name)

        def method(self, *args, **kwargs):
            called.append((name, self.algorithm))
            return real(self, *args, **kwargs)
        return method

    for name in ("init_with_stats", "evolve", "finish"):
        monkeypatch.setattr(PureGA, name, spy(name))
    ga = jaxga.GA("sga", MAP, population__size=6)
    algo = programs.program_algorithm(ga.algorithm)
    params = stack_params([ga.default_params], 2)
    progs = compiled_programs.__wrapped__(
        algo, shape_spec(ga.grid), tuple(sorted(shape_spec(params).items())), 2, 1)
    traced = progs._trace()  # traced only: nothing compiled
    assert sorted(traced) == ["evolve", "finish", "init"]
    assert [name for name, _ in called] == ["init_with_stats", "evolve", "finish"]
    for (_, seen), view in zip(called, ("init", "evolve", "finish")):
        assert seen == programs.program_view(algo, view)


@pytest.mark.slow
def test_a_run_of_the_pure_core_is_jaxga_run_on_a_large_ros_map(tmp_path):
    """``GA.run(PRNGKey(s))`` under the user's own ``jit`` and ``vmap`` is seed ``s`` of
    :func:`jaxga.run` on a ROS map_server map over 64 cells a side (an 80 x 72 map_saver
    image with two walls, 0.05 m cells), from one checked problem: one definition of a
    run."""
    pixels = np.full((72, 80), 254, np.uint8)  # free
    pixels[10:50, 25:28] = 0  # two occupied walls (image rows count from the top)
    pixels[30:72, 52:55] = 0
    (tmp_path / "large.pgm").write_bytes(b"P5\n80 72\n255\n" + pixels.tobytes())
    (tmp_path / "large.yaml").write_text(
        "image: large.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    problem = jaxga.problem("hybrid", tmp_path / "large.yaml",
                            map_options=dict(start=(2, 2), goal=(77, 69)),
                            population__size=8, generations=4)
    assert problem.frame.has_metres and min(problem.grid.width, problem.grid.height) > 64
    ga = jaxga.GA(problem)
    ref = jaxga.run(problem, seeds=[0, 3])
    keys = jnp.stack([jax.random.PRNGKey(s) for s in (0, 3)])
    out = jax.jit(jax.vmap(ga.run, (0, None)))(keys, ga.default_params)
    assert ref.success.all()
    assert_seed_for_seed(out, ref)
