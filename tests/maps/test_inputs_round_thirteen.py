"""Round thirteen (decision 061): a robot's inflation bound, a binary file named as a
text map, the generation count in sweeps and listings, device counts from Python.

Each test is cheap: no whole GA is compiled."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jaxga.core.errors import JaxgaError, MapFormatError, ParameterError
from jaxga.maps.clearance import ObstacleClearance
from jaxga.maps.preprocess import inflate_blocked
from jaxga.reference.any_angle import any_angle_shortest_path_np


def _leg_clearance(radius: float) -> float:
    """The clearance, from one obstacle cell's square, of the any-angle optimum planned
    on the map inflated by ``radius`` cells: a straight leg from (0, 4) to (24, 5) that
    runs along the top edge of the inflated block around the obstacle (15, 2)."""
    b = np.zeros((14, 26), bool)
    b[2, 15] = True
    planned = inflate_blocked(b, radius)
    ref = any_angle_shortest_path_np(planned, (0, 4), (24, 5), "strict")
    assert ref.found
    return ObstacleClearance(b).of_path(np.asarray(ref.path))


def test_a_leg_passes_less_than_one_cell_inside_the_robots_radius():
    """The docs' bound: inflation measures centre to centre, and a straight leg may run
    along a free cell's edge, so a path passes up to (never quite) one cell closer than
    the radius (not half a cell, as the docs said); the radius plus one cell keeps it."""
    r = 2.9
    got = _leg_clearance(r)
    # the straight line y = 4 + x / 24 itself, nearest to the square's corner (14.5, 2.5)
    assert got == pytest.approx((14.5 / 24 + 1.5) / math.sqrt(1 + 1 / 24**2), abs=1e-9)
    assert r - 1 < got < r - 0.5
    assert _leg_clearance(r + 1) >= r


def test_the_bound_holds_for_every_radius_and_direction():
    """One obstacle square and a straight line that enters no square of the cells within
    ``r`` of it (centre to centre): the line passes less than one cell inside ``r`` of
    the obstacle, for any radius and direction (the worst: along an axis, as r nears a
    whole number)."""
    theta = np.linspace(0.0, math.pi / 4, 721)
    u = np.stack([np.cos(theta), np.sin(theta)], 1)
    worst = 0.0
    for r in np.linspace(1.0, 12.0, 2201):
        k = int(math.ceil(r)) + 1
        a, b = np.mgrid[-k:k + 1, -k:k + 1]
        inside = a * a + b * b <= r * r + 1e-9
        blocked = np.stack([a[inside], b[inside]], 1).astype(float)
        # a line clear of the blocked squares is at least their support away; the
        # obstacle's own square reaches as far in that direction: the line's distance
        # from it is at least (support of the blocked set) - (the square's own support)
        support = (blocked @ u.T).max(0)
        worst = max(worst, float((r - support).max()))
    assert 0.99 < worst < 1.0


def test_a_binary_file_past_the_size_limit_is_named_as_not_text(tmp_path):
    """A file of NUL bytes whose one "line" is over the cell limit: refused as not a text
    map (its content), not as a map too large to plan on (with advice to coarsen it)."""
    from jaxga.maps.loaders import load_map

    path = tmp_path / "zeros.txt"
    path.write_bytes(b"\0" * 4_200_000)
    with pytest.raises(MapFormatError, match="not a text map file"):
        load_map(str(path))


def test_a_sweep_over_generation_counts_says_one_count_per_sweep():
    """The generation count is a run-time value of the programs, one per call: a sweep
    point that changes it is refused saying so, not as a compiled-in key."""
    import jaxga

    points = [{"generations": 5}, {"generations": 6}]
    with pytest.raises(ParameterError, match="share its generation count") as e:
        jaxga.sweep("sga", "classic_ga_gapp3_20x20", points, seeds=2)
    assert "compiled program depends on" not in str(e.value)
    with pytest.raises(ParameterError, match=r"changes crossover.method, which the compiled "
                       r"program depends on \(and generations, one per sweep\)"):
        jaxga.sweep("sga", "classic_ga_gapp3_20x20",
                    [{"generations": 5, "crossover.method": "column"}], seeds=2)


def test_presets_show_marks_the_generation_count_per_call(capsys):
    from jaxga.cli import main

    assert main(["presets", "--show", "sga"]) == 0
    lines = capsys.readouterr().out.splitlines()
    line = next(ln for ln in lines if ln.startswith("generations "))
    assert "per call # " in line
    kind = {ln.split()[0]: ln.split(" # ")[0].split()[-1] for ln in lines}
    assert kind["crossover.probability"] == "dynamic" and kind["crossover.method"] == "static"


@pytest.mark.parametrize("n", [3.7, True, 0.5, "two", float("nan"), float("inf"), [2]])
def test_a_device_count_that_is_not_a_whole_number_is_one_line(n):
    """``set_local_devices`` refused 0.5 as "got 0", took 3.7 as 3 and True as 1, and
    raised Python's own errors for text, NaN, infinity and lists."""
    from jaxga.api.devices import set_local_devices

    with pytest.raises(JaxgaError, match="the device count must be a whole number"):
        set_local_devices(n)


def test_the_device_setting_named_is_the_one_jax_uses(monkeypatch):
    """XLA reads the last of a repeated flag, and JAX_NUM_CPU_DEVICES wins over XLA_FLAGS:
    the setting jaxga names (and warns about) is that one."""
    from jaxga._runtime.parallel import user_device_setting

    flag = "--xla_force_host_platform_device_count"
    monkeypatch.delenv("JAX_NUM_CPU_DEVICES", raising=False)
    monkeypatch.setenv("XLA_FLAGS", f"{flag}=3 {flag}=20")
    assert user_device_setting() == f"XLA_FLAGS {flag}=20"
    monkeypatch.setenv("JAX_NUM_CPU_DEVICES", "5")
    assert user_device_setting() == "JAX_NUM_CPU_DEVICES=5"


@pytest.mark.parametrize("n_ctrl", [4, 5, 7, 12, 300])
def test_the_span_matrices_equal_scipys_b_spline(n_ctrl):
    """The smoothing's power-basis span matrices (:func:`jaxga.bspline._span_matrices`,
    Cox-de Boor over only the four functions alive in each span: over all of them it
    took seconds for the hundreds of control points of a path on a robot's map) give
    the clamped uniform cubic B-spline that scipy's ``BSpline`` evaluates."""
    from scipy.interpolate import BSpline

    from jaxga.bspline import _span_matrices

    rng = np.random.default_rng(n_ctrl)
    control = rng.normal(size=(n_ctrl, 2))
    spans = n_ctrl - 3
    knots = np.r_[[0.0] * 3, np.arange(spans + 1), [float(spans)] * 3]
    a = _span_matrices(n_ctrl).astype(np.float64)  # [T, 4 powers, 4 ctrl]
    u = np.linspace(0.0, 1.0, 9)[:-1]
    power = u[:, None] ** np.arange(4)[None, :]
    for s in range(spans):
        mine = power @ (a[s] @ control[s:s + 4])
        np.testing.assert_allclose(mine, BSpline(knots, control, 3)(s + u), atol=1e-5)
