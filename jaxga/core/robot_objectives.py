"""What a robot asks of a path, in metres and radians: its length, how far it keeps from the
obstacles, how deep it goes into a band around them, and how much it turns.

These are the objectives of a front (decision 045) rather than one weighted fitness: the
papers weigh length, safety and smoothness into one number (IMGA's Delphi weights,
AGACD eq. 18-25, Zhu & Pan eq. 7-9); kept apart, they show the trade-off itself.

The clearance is read from a per-map field: each cell's exact distance, in cells, from
its centre to the nearest blocked cell's square (:func:`jaxga.maps.clearance.cell_clearance`,
computed once on the host), as ``float32[H * W]`` or ``[H, W]``. On a continuous path
(8-adjacent steps, what the GA evolves) the least over its cells is the path's clearance
as :mod:`jaxga.reference.maximin` defines it, so the front's widest end compares with
the exact maximin clearance. On a waypoint path the nodes alone are read: an upper
bound of the polyline's clearance, which :class:`jaxga.maps.clearance.ObstacleClearance`
measures exactly for reports.

Written for ONE path ``(grid, cells, length)`` like :mod:`jaxga.core.objectives` (padding
normalised, repeated nodes skipped); pure, float32, jit and vmap.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxga._batching.numerics import ordered_sum
from jaxga.core.dtypes import F32
from jaxga.core.grid import Grid
from jaxga.core.objectives import turn_angles
from jaxga.core.path_geometry import geometry

__all__ = ["ROBOT_OBJECTIVES", "RobotObjectives", "minimised", "robot_objectives"]


class RobotObjectives(NamedTuple):
    """One path's robot objectives (float32 scalars)."""

    length: jax.Array
    """Euclidean length through the cell centres, in metres; on an 8-connected path the
    same bits for the same steps in any order (orthogonal and diagonal steps counted),
    so that a front sees two paths of one length as tied (a waypoint path's longer
    steps are summed in order)."""
    clearance: jax.Array
    """The least clearance of its cells, in metres (module docstring)."""
    intrusion: jax.Array
    """How deep and how long it runs within ``band`` of the obstacles, in square
    metres: the integral along the path of ``max(0, band - clearance)`` (trapezoids
    between its nodes). 0 for a path that keeps at least ``band`` everywhere; it
    falls as a path moves out of the band, so a GA can climb it where the least
    clearance alone changes only at one cell."""
    turning: jax.Array
    """The sum of its turn angles, in radians (AGACD eq. 10-17's smoothness); the same
    bits for the same turns in any order where they are multiples of 45 degrees (every
    turn of an 8-connected path: counted); other angles are summed in order."""
    max_turn: jax.Array
    """Its largest turn, in radians."""


ROBOT_OBJECTIVES = ("length", "clearance", "intrusion", "turning", "max_turn")
"""The objectives by name, in :class:`RobotObjectives`' order."""

_MAXIMISED = frozenset({"clearance"})


def robot_objectives(grid: Grid, cells: jax.Array, length: jax.Array, field: jax.Array, *,
                     cell_size: float | jax.Array = 1.0,
                     band: float | jax.Array = 1.0) -> RobotObjectives:
    """The :class:`RobotObjectives` of one path on ``grid``, with ``field`` the map's cell
    clearances in cells, ``cell_size`` metres per planning cell and ``band`` (metres)
    the distance from the obstacles within which :attr:`RobotObjectives.intrusion`
    counts."""
    g = geometry(grid, cells, length)
    scale = jnp.asarray(cell_size, F32)
    clear = jnp.asarray(field, F32).reshape(-1)[g.cells] * scale  # per node, metres
    # a padding or repeated node repeats a real node's cell: it changes no minimum
    least = jnp.min(clear)
    cell_steps = jnp.sqrt((g.dx * g.dx + g.dy * g.dy).astype(F32))  # as path_length sums
    steps = cell_steps * scale
    depth = jnp.maximum(jnp.asarray(band, F32) - clear, 0.0)
    intrusion = ordered_sum(steps * 0.5 * (depth[:-1] + depth[1:]), dtype=F32)
    turns = turn_angles(grid, cells, length)
    return RobotObjectives(
        length=_tied_length(g.dx * g.dx + g.dy * g.dy, cell_steps) * scale,
        clearance=least.astype(F32),
        intrusion=intrusion,
        turning=_tied_turning(turns),
        max_turn=jnp.max(turns).astype(F32),
    )


def _tied_length(squared: jax.Array, steps: jax.Array) -> jax.Array:
    """The sum of ``steps`` (their squared lengths ``squared``, integers), in cells, the
    same bits for the same steps in any order: the orthogonal and the diagonal steps
    counted (``n1 + n2 sqrt(2)``), the longer ones of a waypoint path summed in order.
    An ordered float32 sum rounds by the order of its terms, so that two paths of equal
    length could differ in the last bit and one "dominate" the other on a front."""
    unit = jnp.sum(squared == 1, dtype=jnp.int32).astype(F32)
    diagonal = jnp.sum(squared == 2, dtype=jnp.int32).astype(F32)
    longer = ordered_sum(jnp.where(squared > 2, steps, 0.0), dtype=F32)
    return unit + diagonal * jnp.float32(math.sqrt(2.0)) + longer


_EIGHTH = math.pi / 4
_SNAP = 1e-5
"""Radians within which a turn angle is taken as its multiple of pi/4 (float32's atan2
is within about 1e-7 of it)."""


def _tied_turning(turns: jax.Array) -> jax.Array:
    """The sum of the turn angles ``turns``, the same bits for the same turns in any
    order (as :func:`_tied_length`): the turns by multiples of pi/4 (every turn of an
    8-connected path) counted in eighths of a revolution, any other angle summed in
    order."""
    eighths = jnp.round(turns / jnp.float32(_EIGHTH))
    snapped = jnp.abs(turns - eighths * jnp.float32(_EIGHTH)) <= _SNAP
    counted = jnp.sum(jnp.where(snapped, eighths, 0.0).astype(jnp.int32), dtype=jnp.int32)
    rest = ordered_sum(jnp.where(snapped, 0.0, turns), dtype=F32)
    return counted.astype(F32) * jnp.float32(_EIGHTH) + rest


def minimised(objectives: RobotObjectives, names: tuple[str, ...]) -> jax.Array:
    """``float32[len(names)]``: the named objectives as a front minimises them
    (:mod:`jaxga.operators.pareto`): each as it is, the clearance negated."""
    values = objectives._asdict()
    return jnp.stack([-values[n] if n in _MAXIMISED else values[n] for n in names]
                     ).astype(F32)
