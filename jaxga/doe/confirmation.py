"""The confirmation run of a DOE: the predicted best coded combination run with the design's
seeds (AGACD 5.2.1), or read back from the checkpoint.
"""

from __future__ import annotations

import numpy as np

from jaxga import api
from jaxga.doe.checkpoint import decode
from jaxga.doe.fit import seed_responses
from jaxga.doe.plan import DoePlan


def run_confirmation(plan: DoePlan, best: np.ndarray) -> tuple[dict, float]:
    """The confirmation run at the predicted best combination (AGACD 5.2.1), with the
    design's seeds, or the checkpoint's: ``(per-seed responses, compile seconds)``."""
    saved = (plan.checkpoint.load_confirmation(best, len(plan.seeds))
             if plan.checkpoint is not None else None)
    if saved is not None:
        return decode(saved), 0.0
    best_point = {f.name: f.value(int(c)) for f, c in zip(plan.factors, best)}
    res = api.sweep(plan.problem, None, [best_point], plan.seeds,
                    population_capacity=plan.capacity)[0]
    confirm = seed_responses(res)
    if plan.checkpoint is not None:
        plan.checkpoint.save_confirmation(best, confirm)
    return confirm, res.timing["compile_s"]
