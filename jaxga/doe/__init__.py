"""Designed experiments over GA hyper-parameters (AGACD 5.2.1, eq. 30-31).

A :class:`Factor` is a configuration key with three levels coded -1, 0, 1 (low, mid,
high; AGACD Table 3). A design is an integer array ``coded[N, k]`` of coded levels, one
row per run ("point"): the orthogonal arrays L9 (3^4), L18 (the seven 3-level columns of
the standard L18, 2^1 x 3^7), L27 (3^13), the full factorial 3^k, and AGACD's own 9-run,
5-factor design (its Table 4). Factors take the first k columns of the array (of the
L27: its base columns 1, 2, 5 first, then 9, then the rest); an array that would repeat
its points for k factors is refused.

:func:`run_doe` runs every point x every seed in ONE compiled call of
:func:`jaxga.api.sweep` (the population size through the engine's active mask below a
capacity equal to the largest size of the design; every point sees the same seeds),
fits the linear prediction ``result = X0 + sum_i Xi * Fi`` (AGACD eq. 30) to the point
means by least squares, reports main effects (mean response per level of each factor),
picks the predicted best coded combination (each coefficient's sign: maximised for
fitness-like responses, minimised for length-like ones) and runs it as a confirmation run
with the same seeds (AGACD 5.2.1 reports predicted 0.28995, measured 0.30684).

With ``checkpoint=DIR`` the points run in blocks of ``block`` points per compiled call
and each finished point is written to ``DIR`` at once (temp file + ``os.replace``); a
restarted run with the same arguments skips the finished points. Every block uses the
design's population capacity and the same number of runs (the last block is padded with
copies of its last point), so one compiled program serves every block and a resumed run
is bit for bit the uninterrupted run with the same ``block``. On the CPU another ``block``
gives the same results bit for bit too (a run's float sums are taken in a fixed order,
docs/devices.md); on a GPU the number of runs per call may round a run's sums otherwise
(decision 040), so ``block`` stays part of the checkpoint's fingerprint, and a
checkpoint's points are never mixed with another block's.
``DIR/manifest.json`` records what was run (preset configuration, map, factors, design,
seeds, block, versions, the device); a checkpoint written by another configuration, or
computed on another kind of device, is refused.
With several processes (``jaxga doe --coordinator ...``, :mod:`jaxga._runtime.parallel`) every
block is split over the processes; process 0 alone reads and writes ``DIR`` and tells
the others which points are finished, so ``DIR`` need only be on process 0's disk. A lost
process loses the block being computed, never a finished point: the restarted command
completes the rest.

Decisions where AGACD is silent:

* Failed seeds (no feasible path): their ``fitness`` is 0 (what the engine reports for
  an individual without a feasible path) and ``success`` 0, so these responses average
  over all seeds; the length-like responses (``length``, ``raw_length``, ``turns``,
  ``smoothness`` = ``angle_sum`` of the post-optimised path, ``convergence_generation``)
  exclude failed seeds (``None`` in the JSON, NaN in arrays) and every point reports its
  number of successful seeds. A point without any successful seed has no mean and is
  left out of the fit (the fit is refused if too few points remain).
* The fit uses the point means (each point weighted equally, as AGACD Table 5 does).
  AGACD's own coefficients (eq. 31) are the contrasts ``mean_p(F_ip * y_p)`` rather than
  least squares; :func:`contrast_coefficients` reproduces them from its Table 5. On an
  orthogonal design with balanced levels the two differ by the factor 2/3 =
  ``mean(F^2)``; AGACD's Table 4 design is not orthogonal (its pm_high column is a
  relabelling of pc_high's), so there they differ more.
* A zero coefficient (within round-off: ``|Xi| <= 1e-10 max|X|``) puts its factor at the
  middle level in the predicted best.
* The checkpoint fingerprint leaves out the response and direction: the design points
  store every response per seed, and the confirmation run is stored per coded
  combination, so a finished checkpoint can be re-analysed for another response.
"""

from jaxga.doe.design import (
    AGACD_TABLE3,
    AGACD_TABLE4,
    DESIGNS,
    L9,
    L18,
    L27,
    MAX_FULL_FACTORIAL_POINTS,
    Factor,
    check_factors,
    design_array,
    design_points,
)
from jaxga.doe.experiment import run_doe
from jaxga.doe.fit import (
    RESPONSE_ALIASES,
    RESPONSES,
    contrast_coefficients,
    fit_linear,
    main_effects,
    point_means,
    predicted_best,
    seed_responses,
)
from jaxga.doe.result import DoeResult, column_names

__all__ = [
    "AGACD_TABLE3",
    "AGACD_TABLE4",
    "DESIGNS",
    "DoeResult",
    "Factor",
    "L18",
    "L27",
    "L9",
    "MAX_FULL_FACTORIAL_POINTS",
    "RESPONSES",
    "RESPONSE_ALIASES",
    "check_factors",
    "column_names",
    "contrast_coefficients",
    "design_array",
    "design_points",
    "fit_linear",
    "main_effects",
    "point_means",
    "predicted_best",
    "run_doe",
    "seed_responses",
]
