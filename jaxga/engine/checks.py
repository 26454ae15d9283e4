"""What a configuration uses and whether it holds together, checked before anything is traced.

The registered operators a configuration chooses (by role), the keys no stage reads
(refused as overrides), combinations of keys (an operator's required keys, its own
``check``), migration sizes, and the traits that decide a run's shape (waypoint paths,
the distance-field guide, the field repairs). All read :mod:`jaxga.operators.registry`.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from typing import Any

from jaxga.config.presets import file_overrides
from jaxga.config.schema import DEFAULTS, Config
from jaxga.core.errors import ParameterError
from jaxga.core.robot_objectives import ROBOT_OBJECTIVES
from jaxga.operators import registry
from jaxga.operators.islands import migrates
from jaxga.operators.registry import FIELD_REPAIR, NEVER_FAILS, WAYPOINTS


def chosen_operators(config: Config) -> dict[str, registry.Operator]:
    """The registered operators a configuration uses, by role: ``<family>.method`` for
    every family, and ``init.fallback`` when it names an initialiser. A configuration
    without a family's key (a fitness alone, :mod:`jaxga.reference.fitness`) uses
    none there."""
    out = {f"{family}.method": registry.operator(family, config.get(f"{family}.method"))
           for family in registry.FAMILIES if config.get(f"{family}.method") is not None}
    if config.get("init.fallback", "none") != "none":
        out["init.fallback"] = registry.operator("init", config["init.fallback"])
    return out


def compiled_fallback(config: Config) -> str:
    """The initialiser compiled into a run's programs as ``init.fallback``: ``"none"`` when
    ``init.method`` cannot fail (trait :data:`~jaxga.operators.registry.NEVER_FAILS`: there is
    nothing to fill), else the configured fallback, or the default one
    (:data:`jaxga.config.schema.DEFAULTS`, the field walk) when the configuration says
    ``"none"``. Whether it runs is the traced flag ``init.fallback`` of the parameters
    (:func:`jaxga.engine.default_params`): a fallback and ``"none"`` share one compiled
    program, and ``"none"`` discards every slot it would fill (the same results as
    without it)."""
    method = registry.operator("init", config["init.method"])
    if NEVER_FAILS in method.traits:
        return "none"
    fallback = config.get("init.fallback", "none")
    return fallback if fallback != "none" else DEFAULTS["init.fallback"]


FIELD_REPAIR_ROLES = ("init.method", "crossover.method", "mutation.method")
"""The roles whose operator ``repair.fallback`` can change (not the fallback initialiser)."""


def has_trait(chosen: dict[str, registry.Operator], trait: str,
               roles: Iterable[str] | None = None) -> bool:
    """Whether an operator of ``chosen`` (:func:`chosen_operators`), in one of ``roles``
    (all: None), declares ``trait``."""
    return any(trait in op.traits for role, op in chosen.items()
               if roles is None or role in roles)


def uses_waypoints(config: Config) -> bool:
    """Whether the population holds waypoint paths (an operator with the trait
    :data:`~jaxga.operators.registry.WAYPOINTS`, AGACD's crossover or point mutation: segments
    checked by line of sight) rather than 8-connected cell paths."""
    return has_trait(chosen_operators(config), WAYPOINTS)


PER_ISLAND: dict[str, str] = {
    "crossover.probability": "islands.crossover_probabilities",
    "mutation.probability": "islands.mutation_probabilities",
}
"""A rate and the key that, when set, gives each island its own (MPMGA A, B, C)."""


NEEDS: tuple[tuple[str, Any, tuple[str, ...]], ...] = (
    ("crossover.adaptive", True, ("crossover.pc_low", "crossover.pc_high")),
    ("mutation.adaptive", True, ("mutation.pm_low", "mutation.pm_high")),
)

"""``(key, value, keys needed)``: configuration keys read when ``key`` has ``value``
(AGACD eq. 26-29's adaptive rates). An operator's own needed keys are its
``required`` keys in the registry (MPMGA eq. 17's temperature schedule)."""


def unread_keys(config: Config) -> dict[str, str]:
    """The configuration keys that no stage of this configuration reads, with the reason.

    Setting one of them changes nothing (a fitness weight of another objective, a fixed
    rate under AGACD's adaptive rates eq. 26-29, MPMGA's temperature without its
    simulated-annealing mutation, migration settings of a single island, ...), so
    :func:`jaxga.run` refuses them as overrides instead of ignoring them silently. An
    operator's own keys (:func:`jaxga.operators.registry.schema_fields`) are read exactly when an
    operator the configuration uses declares them (:func:`chosen_operators`); the
    families' shared keys follow what :func:`build`, the stages and
    :func:`jaxga.operators.islands.migrate` read.
    """
    out: dict[str, str] = {}
    chosen = chosen_operators(config)
    if NEVER_FAILS in chosen["init.method"].traits:  # nothing for the fallback to fill
        chosen.pop("init.fallback", None)
    read = {key for op in chosen.values() for key in op.params}
    for key in registry.schema_fields():
        if key in read:
            continue
        family, name = key.split(".", 1)
        who = registry.readers(key)
        where = " as init.method or init.fallback" if family == "init" else ""
        out[key] = (f"{family}.method = {config[f'{family}.method']!r} has no parameter "
                    f"{name!r} (read by {', '.join(map(repr, who))} only{where})")
    if int(config.get("population.capacity") or 0):
        out["population.capacity_factor"] = ("population.capacity is set: the capacity is "
                                             "not automatic")
    if has_trait(chosen, WAYPOINTS):
        out["fitness.window"] = "waypoint paths are evaluated without the narrow window"
    if NEVER_FAILS in chosen["init.method"].traits:
        out["init.fallback"] = (f"init.method = {config['init.method']!r} cannot fail where "
                                "a path exists")
    if not has_trait(chosen, FIELD_REPAIR, FIELD_REPAIR_ROLES):
        out["repair.fallback"] = ("no operator of this configuration repairs by median "
                                  "insertion or a regrowth walk")
    for stage, low, high in (("crossover", "pc_low", "pc_high"),
                             ("mutation", "pm_low", "pm_high")):
        island_key = PER_ISLAND[f"{stage}.probability"]
        if config[f"{stage}.method"] == "none":
            for k in (f"{stage}.probability", f"{stage}.adaptive", f"{stage}.{low}",
                      f"{stage}.{high}", island_key):
                out[k] = f"{stage}.method = 'none'"
        elif config[f"{stage}.adaptive"]:
            for k in (f"{stage}.probability", island_key):
                out[k] = (f"{stage}.adaptive = true: the rate is {stage}.{low} .. "
                          f"{stage}.{high} (AGACD eq. 26-29)")
        else:
            for k in (low, high):
                out[f"{stage}.{k}"] = f"{stage}.adaptive = false"
            if config.get(island_key) is not None:
                out[f"{stage}.probability"] = f"{island_key} sets each island's rate"
    if config["simplify.method"] == "none":
        out["simplify.probability"] = "simplify.method = 'none'"
    if config.get("survival.method") is None:
        for k in ("survival.objectives", "survival.band"):
            out[k] = "survival.method is not set: there is no front"
    if int(config["islands.count"]) == 1:
        for k in ("islands.topology", "islands.interval", "islands.migrants"):
            out[k] = "islands.count = 1: there is no migration"
    elif not migrates(config):
        why = ("islands.topology = 'none'" if config["islands.topology"] == "none"
               else "islands.migrants = 0")
        for k in ("islands.topology", "islands.interval", "islands.migrants"):
            if k not in why:
                out[k] = f"{why}: there is no migration"
    return out


OFF_VALUES: dict[str, Any] = {
    "init.fallback": "none",
    "repair.fallback": "none",
    "islands.topology": "none", "islands.migrants": 0, "islands.interval": 1,
    "simplify.probability": 0.0, "crossover.adaptive": False, "mutation.adaptive": False,
    "fitness.window": False,
}
"""Values of unread keys that say what happens anyway (no migration, no simplification,
fixed rates, no narrow window): accepted as overrides, as in notebook 04's one-island
MPMGA with ``islands.topology = "none"``."""


def check_overrides_read(config: Config, keys: Iterable[str]) -> None:
    """Refuse overridden ``keys`` that ``config`` never reads (:func:`unread_keys`),
    unless set to the value that says what happens anyway (:data:`OFF_VALUES`)."""
    unread = unread_keys(config)
    bad = [k for k in keys
           if k in unread and (k not in OFF_VALUES or config.get(k) != OFF_VALUES[k])]
    if bad:
        name = config.get("name", "the configuration")
        raise ParameterError("; ".join(
            f"{k} has no effect in {name!r}: {unread[k]}" for k in bad))


def check_combination(config: Config) -> None:
    """Checks that involve several configuration keys, before anything is traced.

    Raises :class:`ParameterError` naming the keys: keys an operator needs and the
    configuration does not set (:data:`NEEDS`, the operators' ``required`` keys; a fixed
    crossover or mutation rate, or one per island), a post-optimisation of cell paths on
    waypoint paths, and what each chosen operator's own ``check`` refuses
    (:mod:`jaxga.operators.registry`: MPMGA's decay rate ``w = 0``, eq. 17; Zhang's speeds not
    positive or a turning speed above the straight one, eq. 2; IMGA's, MPMGA's or Zhu's
    fitness weights all 0; a smoothness floor not positive; a Delphi ratio list whose
    length does not match AGACD's three objectives, eq. 21-25). Migrants are checked
    against the island size by :func:`check_migration`.
    """
    chosen = chosen_operators(config)
    needs = [*NEEDS, *((role, op.name, op.required)
                       for role, op in chosen.items() if op.required)]
    for key, value, needed in needs:
        if config.get(key) == value:
            missing = [k for k in needed if config.get(k) is None]
            if missing:
                raise ParameterError(
                    f"{key} = {value!r} needs {' and '.join(missing)}, which this "
                    f"configuration does not set (--set KEY=VALUE)")
    for stage in ("crossover", "mutation"):  # a fixed rate, or one per island
        rate, island_key = f"{stage}.probability", PER_ISLAND[f"{stage}.probability"]
        method = config.get(f"{stage}.method", "none")  # fitness_optimum: fitness only
        if method != "none" and not config.get(f"{stage}.adaptive") \
                and config.get(rate) is None and config.get(island_key) is None:
            raise ParameterError(
                f"{stage}.method = {method!r} with {stage}.adaptive = "
                f"false needs {rate} (or {island_key}), which this configuration does not "
                "set (--set KEY=VALUE)")
    post_op = chosen.get("post.method")
    if post_op is not None and registry.CONTINUOUS_ONLY in post_op.traits \
            and has_trait(chosen, WAYPOINTS):
        raise ParameterError(
            f"post.method = {post_op.name!r} needs continuous paths (8-connected cells); "
            "this configuration evolves waypoint paths (AGACD's cut_and_check crossover or "
            "point_checked mutation): use post.method = 'shortcut_greedy'")
    for op in chosen.values():
        if op.check is not None:
            op.check(config)
    check_front(config)


def check_front(config: Config) -> None:
    """A front's keys (decision 045): 2 or 3 distinct objectives of
    :data:`jaxga.core.robot_objectives.ROBOT_OBJECTIVES`, one island (migration does not
    carry a front), and an initialiser that needs a front's fields only with a front."""
    needs_front = has_trait(chosen_operators(config), registry.NEEDS_FRONT_FIELDS)
    if config.get("survival.method") is None:
        if needs_front:
            raise ParameterError(
                f"init.method = {config['init.method']!r} walks the clearance-weighted "
                "fields of a front: set survival.method = 'nsga2'")
        return
    names = config.get("survival.objectives", ("length", "clearance"))
    unknown = [n for n in names if n not in ROBOT_OBJECTIVES]
    if unknown or len(set(names)) != len(names) or not 2 <= len(names) <= 3:
        raise ParameterError(
            f"survival.objectives must be 2 or 3 distinct names of "
            f"{', '.join(ROBOT_OBJECTIVES)}, got {list(names)}")
    if int(config["islands.count"]) != 1:
        raise ParameterError("survival.method = 'nsga2' keeps one front: islands.count must "
                             "be 1")


def check_migration(config: Config, population: int) -> None:
    """Migrants must fit the islands of ``population`` individuals (the capacity: a sweep
    over sizes is checked at its largest). Each island receives ``k`` migrants per source
    (ring, full: ``k``; star: the centre ``(I - 1) k``; MPMGA's A-B-C scheme: ``2 k`` into
    A, and B and C swap ``k`` others than the ``k`` that moved), MPMGA 4.4."""
    count, topology = int(config["islands.count"]), config["islands.topology"]
    k = int(config["islands.migrants"])
    if not migrates(config):
        return
    if topology == "mpmga" and count != 3:
        raise ParameterError(f"islands.topology = 'mpmga' needs islands.count = 3 (A, B, C), "
                             f"got {count}")
    need = {"star": (count - 1) * k, "mpmga": 2 * k}.get(topology, k)
    if need > population:
        raise ParameterError(
            f"islands.migrants = {k} needs {need} individuals per island under the "
            f"{topology!r} topology; an island has {population} (population.size)")


def uses_guide(config: Config) -> bool:
    """Whether a run of ``config`` steers by the problem's exact distance fields (its grid
    needs :func:`jaxga.operators.guide.with_guide`): an operator with the trait
    :data:`~jaxga.operators.registry.NEEDS_GUIDE` (the field initialiser, as ``init.method`` or as
    the fallback compiled in for another initialiser, :func:`compiled_fallback`, also when
    ``init.fallback = "none"`` switches it off), and the field repairs
    (``repair.fallback``)."""
    fallback = compiled_fallback(config) if config.get("init.method") else "none"
    return uses_front_fields(config) or has_trait(chosen_operators(config),
                                                  registry.NEEDS_GUIDE) or (
        fallback != "none"
        and registry.NEEDS_GUIDE in registry.operator("init", fallback).traits) or (
        config["repair.fallback"] != "none" and field_repairs(config))


def uses_front_fields(config: Config) -> bool:
    """Whether a run of ``config`` keeps a front (``survival.method``): its grid carries
    the clearance fields of :func:`jaxga.operators.guide.with_front_fields`."""
    return config.get("survival.method") is not None


def field_repairs(config: Config) -> bool:
    """Whether ``repair.fallback = "field"`` changes an operator of ``config`` (one with
    the trait :data:`~jaxga.operators.registry.FIELD_REPAIR`: its ``field_repair`` option;
    decision 019)."""
    return has_trait(chosen_operators(config), FIELD_REPAIR, FIELD_REPAIR_ROLES)


def check_file_keys_read(name_or_path: str | os.PathLike, variant: str | None = None) -> None:
    """Refuse keys that a user TOML file in the ``base`` chain of ``name_or_path`` sets
    but that the configuration of that file never reads (:func:`unread_keys`, as
    :func:`check_overrides_read` refuses ``--set``), naming the file; which keys a file
    sets is :func:`jaxga.config.presets.file_overrides`."""
    for label, config, keys in file_overrides(name_or_path, variant):
        try:
            check_overrides_read(config, keys)
        except ParameterError as e:
            raise ParameterError(f"{label}: {e}") from None
