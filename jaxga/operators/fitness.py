"""The fitness family: the papers' objectives (:mod:`jaxga.core.objectives`) as registered
operators, with their weights as keys, the checks of weights that together make no sense,
and AGACD's Delphi ratios as a traced parameter (:mod:`jaxga.operators.registry`).

An objective's keyword arguments are its dynamic scalar parameters
(:func:`objective_keywords`); their defaults are the objective's own keyword defaults, the
paper's value where it gives one (:func:`objective_default`; docs/presets.md).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Mapping

import jax.numpy as jnp

from jaxga.core import objectives
from jaxga.core.errors import ParameterError
from jaxga.core.fields import POS, Field, P
from jaxga.operators.registry import Binding, Operator, operator, register

__all__ = ["AGACD_OBJECTIVES", "AGACD_RATIOS", "fitness_weight", "objective_default",
           "objective_keywords"]


def objective_keywords(op: Operator) -> tuple[str, ...]:
    """The keys of fitness operator ``op`` that are keyword arguments of its objective in
    :mod:`jaxga.core.objectives`: its dynamic scalar (float) keys. AGACD's Delphi ratios
    (a list) are not: the objective takes the weights computed from them."""
    return tuple(key for key, field in op.params.items()
                 if field.dynamic and field.kind is float)


def _objective_options(op_name: str) -> Callable[[Binding], dict]:
    def options(ctx: Binding) -> dict:
        op = operator("fitness", op_name)
        kwargs = {key.split(".", 1)[1]: ctx.params[key] for key in objective_keywords(op)
                  if key in ctx.params}
        if op_name == "agacd":  # AGACD eq. 21-25, from the traced ratios
            kwargs["weights"] = objectives.delphi_weights(
                ctx.params["fitness.importance_ratios"])
        return kwargs

    return options


def objective_default(method: str, name: str) -> float:
    """The default of weight ``name`` of fitness ``method``: its objective's keyword
    default in :mod:`jaxga.core.objectives` (the paper's value where it gives one;
    docs/presets.md)."""
    return float(inspect.signature(getattr(objectives, method)).parameters[name].default)


def fitness_weight(config: Mapping, method: str, name: str) -> float:
    """Weight ``name`` as the objective sees it: the configuration's, else its default."""
    value = config.get(f"fitness.{name}")
    return objective_default(method, name) if value is None else value


def _weights_not_all_zero(method: str, names: tuple[str, ...]) -> Callable[[Mapping], None]:
    def check(config: Mapping) -> None:
        if all(fitness_weight(config, method, k) == 0 for k in names):
            raise ParameterError(f"{' and '.join('fitness.' + k for k in names)} are all 0: "
                                 "every path would have the same fitness (IMGA eq. 4, MPMGA "
                                 "eq. 3, Zhu & Pan eq. 6)")
    return check


def _floor_positive(method: str, config: Mapping) -> None:
    floor = fitness_weight(config, method, "smoothness_floor")
    if not floor > 0:
        raise ParameterError(f"fitness.smoothness_floor must be > 0 (it replaces the zero "
                             f"smoothness of a straight path as a divisor), got {floor}")


AGACD_OBJECTIVES = 3
"""AGACD's fitness combines length, smoothness and safety (eq. 18-25): 2 Delphi ratios."""


def _check_agacd(config: Mapping) -> None:
    ratios = config.get("fitness.importance_ratios")
    if ratios is not None and len(ratios) != AGACD_OBJECTIVES - 1:
        raise ParameterError(
            f"fitness.importance_ratios needs {AGACD_OBJECTIVES - 1} entries for AGACD's "
            f"{AGACD_OBJECTIVES} objectives (length, smoothness, safety), got {list(ratios)}")
    _floor_positive("agacd", config)


AGACD_RATIOS = (1.2, 1.4)
"""AGACD's Delphi importance ratios I1, I2 (section 4.4, Table 1): the default of
``fitness.importance_ratios``."""


def _agacd_ratios(config: Mapping) -> dict:
    """AGACD eq. 21-25: its importance ratios as a traced ``float32[2]`` parameter (default
    :data:`AGACD_RATIOS`); the objective computes the Delphi weights from them
    (:func:`jaxga.core.objectives.delphi_weights`), so that a sweep over the ratios is
    one compiled call."""
    ratios = config.get("fitness.importance_ratios", AGACD_RATIOS)
    return {"fitness.importance_ratios": jnp.asarray(ratios, jnp.float32)}


def _check_mpmga(config: Mapping) -> None:
    _weights_not_all_zero("mpmga", ("alpha", "beta"))(config)
    w = functools.partial(fitness_weight, config, "mpmga")
    if w("alpha") == 0 and w("beta") * w("c") == 0:
        raise ParameterError(
            "fitness.alpha = 0 with fitness.beta * fitness.c = 0: every path would have "
            "fitness 0 (MPMGA eq. 3: alpha / length + beta * c / smoothness), which the "
            "engine reads as infeasible")
    _floor_positive("mpmga", config)


def _check_zhang(config: Mapping) -> None:
    for key in ("fitness.v", "fitness.v_t"):
        if config.get(key) is not None and not config[key] > 0:
            raise ParameterError(f"{key} is a speed and must be > 0 (Zhang eq. 2 divides "
                                 f"by it), got {config[key]}")
    v, v_t = (fitness_weight(config, "iga_zhang", k) for k in ("v", "v_t"))
    if v_t > v:
        raise ParameterError(
            f"fitness.v_t = {v_t} is above fitness.v = {v}: a turn would take less time "
            "than going straight, so the time lost per turn (Zhang eq. 2, k = (v - v_t) "
            "pi r / (2 v v_t)) would be negative; the turning speed must not exceed v")


_FIT_A = Field(**POS, doc="IMGA length weight a / Zhang turn weight a")
_FIT_C = Field(**POS, doc="IMGA energy weight c / MPMGA smoothness constant c")
_FLOOR = Field(**POS, doc="floor of a zero smoothness (straight path)")
_FITNESS_CHECKS = {"imga": _weights_not_all_zero("imga", ("a", "b", "c")),
                   "agacd": _check_agacd, "mpmga": _check_mpmga,
                   "iga_zhu": _weights_not_all_zero("iga_zhu", ("omega", "c1", "c2", "c3")),
                   "iga_zhang": _check_zhang}
_FITNESS = {
    "sga": ("1 / length (the papers' basic GA objective)", {}),
    "imga": ("1 / (a L + b S + c E): length, safety, energy (IMGA eq. 4)", {
        "fitness.a": _FIT_A, "fitness.b": Field(**POS, doc="IMGA safety weight b"),
        "fitness.c": _FIT_C}),
    "agacd": ("Delphi-weighted length, smoothness and safety (AGACD eq. 7-8, 18-25)", {
        "fitness.smoothness_floor": _FLOOR,
        "fitness.importance_ratios": Field(list, "AGACD Delphi importance ratios I1, I2 "
                                           "(eq. 21-25): one per objective but the last",
                                           dynamic=True)}),
    "mpmga": ("alpha / length + beta c / smoothness (MPMGA eq. 3-5)", {
        "fitness.alpha": Field(**POS, doc="MPMGA length weight alpha"),
        "fitness.beta": Field(**POS, doc="MPMGA smoothness weight beta"),
        "fitness.c": _FIT_C, "fitness.smoothness_floor": _FLOOR}),
    "iga_zhu": ("1 / (omega length + (1 - omega) turn penalties) (Zhu & Pan eq. 6)", {
        "fitness.omega": Field(**P, doc="Zhu length weight omega"),
        "fitness.c1": Field(**POS, doc="Zhu penalty of a 45 degree turn"),
        "fitness.c2": Field(**POS, doc="Zhu penalty of a 90 degree turn"),
        "fitness.c3": Field(**POS, doc="Zhu penalty of a 135 degree turn")}),
    "iga_zhang": ("1 / (length + time lost in turns) (Zhang eq. 2)", {
        "fitness.a": _FIT_A, "fitness.v": Field(**POS, doc="Zhang straight speed v"),
        "fitness.v_t": Field(**POS, doc="Zhang turning speed v_t"),
        "fitness.r": Field(**POS, doc="Zhang turning radius r")}),
}
for _name, (_summary, _params) in _FITNESS.items():
    register(Operator("fitness", _name, getattr(objectives, _name), _summary, params=_params,
                      options=_objective_options(_name), check=_FITNESS_CHECKS.get(_name),
                      prepare=_agacd_ratios if _name == "agacd" else None))
