"""The grid world: an immutable ``Grid`` pytree, corner rules and cell coordinates.

A grid is ``H x W`` cells; ``blocked[y, x]`` is True for an obstacle and
``y = 0`` is the bottom row, as in the papers. Cells are addressed either by their
coordinates ``(x, y)`` (x = column, y = row counted from the bottom) or by their index
``p = y * W + x`` (0-based; the papers' 1-based ``x = mod(p, N) + 1, y = fix(p / N) + 1``
of AGACD eq. 1-2 name the same cells).

Moves are 8-connected. A diagonal move passes the two orthogonal *side cells*; the
``corner_rule`` says when that is legal (docs/maps.md; decision 027):

* ``"free"``: only the two end cells matter (the papers' GAs squeeze between two
  diagonally touching obstacles);
* ``"no_squeeze"``: illegal when both side cells are blocked;
* ``"strict"``: illegal when either side cell is blocked (the Moving AI convention).

``start`` and ``goal`` are int32 cell indices and are pytree leaves, so a batch of
start/goal pairs on one map is a ``jax.vmap`` without recompilation; ``corner_rule`` is
static (it changes the compiled code).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import operator
import os
import resource
from collections.abc import Mapping, Sequence
from collections.abc import Set as AbstractSet
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga.core.dtypes import on_device
from jaxga.core.equality import ValueEquality
from jaxga.core.errors import EndpointError, JaxgaError
from jaxga.core.fields import shown_value

CORNER_RULES: tuple[str, ...] = ("free", "no_squeeze", "strict")
"""The corner rules (decision 027), in order of strictness."""

DEFAULT_CORNER_RULE = "strict"

MAX_MAP_CELLS = 2048 * 2048
"""The largest map jaxga reads and plans on (4,194,304 cells, e.g. 2048 x 2048): the
caps on input files follow from it (:mod:`jaxga.maps.inputs`). Within it a map is planned
on when the memory a plan needs fits the machine (:func:`plan_memory`); a larger map, or
one the memory does not hold, is refused at once, naming the way around: a coarser map
(:func:`jaxga.maps.coarsen`, ``load_map(..., coarsen=k)``, ``--coarsen K``; decisions 021
and 041)."""

PLAN_BASE_BYTES = 1 << 30
"""Memory of a plan that does not grow with the map: the process, JAX, the compiled
programs and the runs (1 GiB, above the whole peak of a plan on a 500 x 500 map;
decision 041)."""

PLAN_BYTES_PER_CELL = 512
"""Memory of a plan per map cell (the map, its distance fields and move tables, the
references' searches, the clearance's distance transform): above the growth per cell
measured between a 500 x 500 and a 2330 x 1890 map (decision 041), with room to spare."""


def plan_memory(cells: int) -> int:
    """The memory (bytes) a plan on a map of ``cells`` cells is taken to need."""
    return PLAN_BASE_BYTES + PLAN_BYTES_PER_CELL * int(cells)


def physical_memory() -> int | None:
    """The memory this process may use, in bytes: the machine's, or a limit the process
    runs under where it is lower (its address-space limit, ``ulimit -v``; its control
    group's ``memory.max``, a container's limit); None where the system says nothing."""
    try:
        have = [os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")]
    except (AttributeError, ValueError, OSError):  # not POSIX
        have = []
    with contextlib.suppress(AttributeError, ValueError, OSError):
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft not in (resource.RLIM_INFINITY, -1) and soft > 0:
            have.append(int(soft))
    with contextlib.suppress(OSError, ValueError):
        text = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if text.isdigit():
            have.append(int(text))
    return min(have) if have else None


def too_large(width: int, height: int) -> str:
    """The one-line refusal of a map over :data:`MAX_MAP_CELLS` cells or whose plan would
    need more than half of this machine's memory (:func:`plan_memory`), or "" if it
    fits. Where the memory would not hold a plan on a map of one cell (a process limited
    to less than twice :data:`PLAN_BASE_BYTES`), no coarsening can help: the map is
    judged by the cell limit alone."""
    have = physical_memory()
    if have is not None and plan_memory(1) > have // 2:
        have = None

    def fits(cells: int) -> bool:
        return cells <= MAX_MAP_CELLS and (have is None or plan_memory(cells) <= have // 2)

    cells = width * height
    if fits(cells):
        return ""

    def coarse_fits(k: int) -> bool:  # the coarse cells never grow with k
        return fits(-(-width // k) * -(-height // k))

    # the smallest factor that fits: doubled until it fits, then halved in on (about 90
    # tries for a map of 10**20 x 1 cells, where counting up from 2 never ended); a
    # factor of the longer side makes one cell, which fits
    low, high = 1, 2
    while not coarse_fits(high) and high < max(width, height):
        low, high = high, 2 * high
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if coarse_fits(mid) else (mid, high)
    k = high
    if cells > MAX_MAP_CELLS:
        why = f"more than jaxga plans on ({MAX_MAP_CELLS:,}, e.g. 2048 x 2048)"
    else:
        why = (f"and a plan on it needs about {plan_memory(cells) / 2**30:.1f} GiB, more than "
               f"half of the {have / 2**30:.1f} GiB this process may use")
    return (f"map {width} x {height} has {cells:,} cells, {why}: make it coarser, e.g. "
            f"{k} x {k} cells into one (--coarsen {k} of jaxga run, optimum, compare and "
            f"doe; load_map(..., coarsen={k}); jaxga.maps.coarsen)")


# The 8 move directions, counter-clockwise from east. Index d gives (dx, dy).
DIRECTIONS = np.array(
    [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]], dtype=np.int32
)


def check_corner_rule(rule: str) -> str:
    """Return ``rule`` if it is one of :data:`CORNER_RULES`, else raise a clear error."""
    if not isinstance(rule, str) or rule not in CORNER_RULES:  # [] is unhashable
        raise JaxgaError(
            f"unknown corner rule {shown_value(rule)}: expected one of "
            f"{', '.join(CORNER_RULES)}"
        )
    return rule


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True, eq=False)
class Grid(ValueEquality):
    """An occupancy grid with a start, a goal and a corner rule.

    Attributes:
        blocked: ``bool[H, W]``, True for an obstacle, row 0 at the bottom.
        start: int32 scalar, the start cell index ``y * W + x``.
        goal: int32 scalar, the goal cell index.
        corner_rule: ``"free"``, ``"no_squeeze"`` or ``"strict"`` (static).
        guide: the exact distance fields of :mod:`jaxga.operators.guide`, or None.
        tables: the per-map lookup tables of :mod:`jaxga.engine.maptables`, or None.
        outside: the padding cells of a map padded to its size class, or None.

    Build grids with :meth:`Grid.create` (or a loader in :mod:`jaxga.maps`), which checks
    shapes, dtypes and that the endpoints lie on the map. Whether the endpoints are free
    is checked by :meth:`check_endpoints`, which every planner calls.
    """

    blocked: jax.Array
    start: jax.Array
    goal: jax.Array
    corner_rule: str = dataclasses.field(default=DEFAULT_CORNER_RULE, metadata={"static": True})
    guide: Any = None
    """The problem's exact distance fields (:class:`jaxga.operators.guide.Guide`), or None. Attached
    by :func:`jaxga.operators.guide.with_guide`; read by the field initialiser and the repairs that
    connect through the fields. It belongs to this map, these endpoints and this corner
    rule: :meth:`replace` and :meth:`validated` drop it."""
    tables: Any = None
    """Per-map lookup tables (:class:`jaxga.engine.maptables.MapTables`), or None: the legal moves
    and free neighbours of every cell, computed once per run instead of once per
    generation by every operator that reads them (:func:`jaxga.engine.maptables.with_tables`).
    They belong to this map and corner rule: :meth:`replace` and :meth:`validated` drop
    them."""

    outside: Any = None
    """``bool[H, W]`` or None: cells that are not part of the map but padding around it
    (:func:`jaxga._runtime.size_classes.pad_to_class`: a map padded to its size class so that
    maps of one class share compiled programs). They are blocked, so no path enters
    them, and they count as off the map where that differs from an obstacle: the safety
    and clearance measures of :mod:`jaxga.core.objectives` (:func:`proximity_obstacles`)."""

    # ----------------------------------------------------------------- construction
    @classmethod
    def create(
        cls,
        blocked: np.ndarray | jax.Array | Sequence[Sequence[int]],
        start: tuple[int, int] | None = None,
        goal: tuple[int, int] | None = None,
        corner_rule: str = DEFAULT_CORNER_RULE,
    ) -> Grid:
        """Build a grid from a ``bool[H, W]`` array (row 0 = bottom) and ``(x, y)`` endpoints.

        ``start`` defaults to ``(0, 0)`` and ``goal`` to ``(W - 1, H - 1)``. Raises
        :class:`~jaxga.core.errors.EndpointError` for an endpoint off the map and
        :class:`~jaxga.core.errors.JaxgaError` for a bad array or corner rule, or a map of more
        than :data:`MAX_MAP_CELLS` cells (:func:`too_large`).
        """
        arr = blocked_array(blocked)
        h, w = arr.shape
        if too_large(w, h):
            raise JaxgaError(too_large(w, h))
        check_corner_rule(corner_rule)
        sx, sy = check_xy("start", (0, 0) if start is None else start, w, h)
        gx, gy = check_xy("goal", (w - 1, h - 1) if goal is None else goal, w, h)
        return cls(
            blocked=on_device(arr),
            start=on_device(sy * w + sx, np.int32),
            goal=on_device(gy * w + gx, np.int32),
            corner_rule=corner_rule,
        )

    def replace(self, **changes) -> Grid:
        """Host-side copy with fields replaced; ``start``/``goal`` are given as ``(x, y)``."""
        unknown = set(changes) - {"blocked", "start", "goal", "corner_rule"}
        if unknown:
            raise JaxgaError(f"unknown Grid field(s): {', '.join(sorted(unknown))}")
        return Grid.create(
            np.asarray(changes.get("blocked", self.blocked)),
            start=changes.get("start", self.start_xy),
            goal=changes.get("goal", self.goal_xy),
            corner_rule=changes.get("corner_rule", self.corner_rule),
        )

    # ------------------------------------------------------------------- properties
    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)``."""
        return tuple(self.blocked.shape)  # type: ignore[return-value]

    @property
    def height(self) -> int:
        """Rows of the map (``H``)."""
        return self.blocked.shape[0]

    @property
    def width(self) -> int:
        """Columns of the map (``W``; a cell index is ``y * W + x``)."""
        return self.blocked.shape[1]

    @property
    def n_cells(self) -> int:
        """Cells of the map, ``H * W``."""
        return self.blocked.shape[0] * self.blocked.shape[1]

    @property
    def start_xy(self) -> tuple[int, int]:
        """The start as host ``(x, y)`` integers (not for use under ``jit``)."""
        return index_to_xy_host(int(self.start), self.width)

    @property
    def goal_xy(self) -> tuple[int, int]:
        """The goal as host ``(x, y)`` integers (not for use under ``jit``)."""
        return index_to_xy_host(int(self.goal), self.width)

    def blocked_np(self) -> np.ndarray:
        """``blocked`` as a host NumPy array."""
        return np.asarray(self.blocked, dtype=bool)

    def cells_digest(self) -> str:
        """A digest of the map's cells (its shape and which cells are blocked; not its
        endpoints or corner rule): equal for the same map however it was loaded, so
        results can be told to be on one map when their names are not enough (two
        bare grids are both named "grid")."""
        b = self.blocked_np()
        raw = repr(b.shape).encode() + np.packbits(b).tobytes()
        return hashlib.blake2b(raw, digest_size=12).hexdigest()

    def validated(self) -> Grid:
        """This grid rebuilt by :meth:`create`, so that one made with the plain constructor
        (``Grid(blocked=..., start=..., goal=...)``) is checked as ``create`` checks its
        arguments: a 2-D array of booleans or 0/1, integer cell indices on the map, a
        known corner rule. Raises :class:`~jaxga.core.errors.JaxgaError` (or
        :class:`~jaxga.core.errors.EndpointError`) naming the problem."""
        # the array and the corner rule exactly as create checks them
        blocked = self.blocked if isinstance(self.blocked, np.ma.MaskedArray) \
            else np.asarray(self.blocked)  # a mask is refused by create, not dropped
        base = Grid.create(blocked, corner_rule=self.corner_rule)
        cells = {}
        for name in ("start", "goal"):
            value = np.asarray(getattr(self, name))
            if value.ndim != 0 or not np.issubdtype(value.dtype, np.integer):
                raise JaxgaError(f"the grid's {name} must be one integer cell index "
                                 f"(y * W + x), got {value!r}")
            if not 0 <= int(value) < base.n_cells:
                raise EndpointError(f"{name} cell index {int(value)} is off the "
                                    f"{base.width} x {base.height} map")
            cells[name] = jnp.int32(value)
        return Grid(blocked=base.blocked, corner_rule=base.corner_rule, **cells)

    def check_endpoints(self) -> Grid:
        """Raise :class:`~jaxga.core.errors.EndpointError` if the start or goal is blocked.

        Returns the grid itself so that calls can be chained.
        """
        b = self.blocked_np()
        for name in ("start", "goal"):  # a grid of the plain constructor is unchecked
            index = int(getattr(self, name))
            if not 0 <= index < self.n_cells:
                raise EndpointError(f"{name} cell index {index} is off the "
                                    f"{self.width} x {self.height} map")
        for name, (x, y) in (("start", self.start_xy), ("goal", self.goal_xy)):
            if b[y, x]:
                raise EndpointError(f"{name} cell ({x}, {y}) is blocked")
        return self

    def __repr__(self) -> str:  # pragma: no cover - cosmetic
        try:
            return (
                f"Grid({self.width}x{self.height}, start={self.start_xy}, goal={self.goal_xy}, "
                f"corner_rule={self.corner_rule!r}, blocked={int(np.sum(self.blocked_np()))})"
            )
        except Exception:  # traced values inside jit
            return f"Grid(shape={self.blocked.shape}, corner_rule={self.corner_rule!r})"


def proximity_obstacles(grid: Grid, border_blocked: bool) -> jax.Array:
    """``bool[H, W]``: the cells that count as obstacles for safety and clearance
    measures (IMGA eq. 6, AGACD eq. 18-20, jaxga's clearance and tangency metrics):
    the blocked cells of the map, and the padding cells (``grid.outside``) only when
    cells off the map count as obstacles (``border_blocked``), as off-map cells do."""
    if grid.outside is None:
        return grid.blocked
    return jnp.where(grid.outside, border_blocked, grid.blocked)


def as_integer(value) -> int:
    """``value`` as a Python int when it is an integer of any kind (Python, numpy, a 0-d
    JAX or numpy integer array); ``TypeError`` for anything else, bools included (1.5 is
    not truncated, ``True`` is not 1)."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{value!r} is a bool, not an integer")
    return int(operator.index(value))


def blocked_array(blocked: Any) -> np.ndarray:
    """``blocked`` as a ``bool[H, W]`` NumPy array, or one :class:`JaxgaError` line: a
    non-empty 2-D array of booleans or 0/1 values (no NaN, 0.5, 2 or -1), not a masked
    array with masked cells, rows of equal length. What :meth:`Grid.create` and
    :func:`jaxga.maps.save_map` take; the size limit is :meth:`Grid.create`'s alone."""
    if isinstance(blocked, np.ma.MaskedArray) and np.ma.getmaskarray(blocked).any():
        # np.asarray drops the mask (one with nothing masked is its data)
        raise JaxgaError("a grid cannot be a masked array: which are its masked cells, "
                         "free or blocked? Fill them first (np.ma.filled(a, 1): blocked)")
    try:
        arr = np.asarray(blocked)
    except ValueError:  # ragged rows
        raise JaxgaError("a grid must be a non-empty 2-D array with rows of equal "
                         "length") from None
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise JaxgaError(f"a grid must be a non-empty 2-D array, got shape {arr.shape}")
    if arr.dtype != np.bool_:
        try:
            zero_one = bool(np.all(np.isin(arr, (0, 1))))
        except TypeError:  # structured or void records: no comparison with numbers
            zero_one = False
        if not zero_one:
            raise JaxgaError("a grid array must hold booleans or 0/1 values")
        arr = arr.astype(bool)
    return arr


def as_xy(name: str, xy) -> tuple[int, int]:
    """``xy`` as a pair of Python integers ``(x, y)``, or a one-line
    :class:`EndpointError` naming ``name`` (start, goal): integers only, 1.5 or "30" are
    refused, not truncated or split."""
    try:
        if isinstance(xy, (str, bytes, AbstractSet, Mapping)):  # {3, 1}: which is x?
            raise TypeError
        x, y = (as_integer(v) for v in tuple(xy))
    except (TypeError, ValueError):
        raise EndpointError(f"{name} must be a pair of integers (x, y), got "
                            f"{shown_value(xy)}") from None
    return x, y


def check_xy(name: str, xy, w: int, h: int) -> tuple[int, int]:
    """``xy`` as integer ``(x, y)`` on a ``w`` x ``h`` map (:func:`as_xy`), or a one-line
    :class:`EndpointError` naming ``name`` (start, goal) and the problem."""
    x, y = as_xy(name, xy)
    if not (0 <= x < w and 0 <= y < h):
        raise EndpointError(f"{name} ({x}, {y}) is off the {w} x {h} map")
    return x, y


# --------------------------------------------------------------------- coordinates
def xy_to_index(xy: jax.Array, width: int) -> jax.Array:
    """Cell index ``y * W + x`` of ``int[..., 2]`` coordinates (AGACD eq. 2, 0-based)."""
    xy = jnp.asarray(xy, dtype=jnp.int32)
    return xy[..., 1] * jnp.int32(width) + xy[..., 0]


def index_to_xy(p: jax.Array, width: int) -> jax.Array:
    """``int32[..., 2]`` coordinates ``(x, y)`` of cell indices (AGACD eq. 1, 0-based)."""
    p = jnp.asarray(p, dtype=jnp.int32)
    return jnp.stack([p % jnp.int32(width), p // jnp.int32(width)], axis=-1)


def index_to_xy_host(p: int, width: int) -> tuple[int, int]:
    """Host version of :func:`index_to_xy` for one cell."""
    return int(p) % width, int(p) // width


def in_bounds(x: jax.Array, y: jax.Array, height: int, width: int) -> jax.Array:
    """True where ``(x, y)`` lies on an ``H x W`` map."""
    return (x >= 0) & (x < width) & (y >= 0) & (y < height)


def blocked_at(blocked: jax.Array, x: jax.Array, y: jax.Array) -> jax.Array:
    """``blocked[y, x]`` with cells off the map counted as blocked (flat 1-D gather)."""
    h, w = blocked.shape
    inside = in_bounds(x, y, h, w)
    flat = blocked.reshape(-1)
    idx = jnp.where(inside, y * w + x, 0)
    return jnp.where(inside, flat[idx], True)


def step_ends(cells: jax.Array, width: int
              ) -> tuple[tuple[jax.Array, jax.Array], tuple[jax.Array, jax.Array]]:
    """``((x_a, y_a), (x_b, y_b))``, each ``int32[..., L-1]``: the coordinates of the two
    ends of every step ``cells[..., i] -> cells[..., i+1]`` of cells on a map ``width``
    cells wide.

    The cells are sliced before they are divided: on an H200, XLA loop fusions reading
    coordinates sliced one cell apart beside coordinates already in memory
    (``x[1:] - x[:-1]`` beside ``y[1:] - y[:-1]``) computed wrong steps, at 256 runs per
    call and more, and at 10 when both coordinates were in memory, while slicing the
    cells first computed the CPU's bits there (decision 048). Same values everywhere.
    """
    a, b = cells[..., :-1], cells[..., 1:]
    return (a % width, a // width), (b % width, b // width)


def diagonal_legal(
    side1_blocked: jax.Array, side2_blocked: jax.Array, corner_rule: str
) -> jax.Array:
    """Whether a diagonal step past two side cells is allowed by ``corner_rule``."""
    if corner_rule == "free":
        return jnp.ones_like(side1_blocked, dtype=bool)
    if corner_rule == "no_squeeze":
        return ~(side1_blocked & side2_blocked)
    if corner_rule == "strict":
        return ~(side1_blocked | side2_blocked)
    raise JaxgaError(f"unknown corner rule {corner_rule!r}")


def move_legal(grid: Grid, a: jax.Array, b: jax.Array) -> jax.Array:
    """Whether one step from cell index ``a`` to cell index ``b`` is a legal move.

    Legal means: both cells on the map and free, 8-adjacent (Chebyshev distance exactly
    1), and for a diagonal step the side cells satisfy the grid's corner rule. Pure and
    elementwise, so it broadcasts over arrays of indices and works under ``jit``/``vmap``.
    """
    w = grid.width
    a = jnp.asarray(a, jnp.int32)
    b = jnp.asarray(b, jnp.int32)
    ax, ay = a % w, a // w
    bx, by = b % w, b // w
    n = grid.n_cells
    on_map = (a >= 0) & (a < n) & (b >= 0) & (b < n)
    dx, dy = bx - ax, by - ay
    adjacent = (jnp.maximum(jnp.abs(dx), jnp.abs(dy)) == 1) & on_map
    ends_free = ~blocked_at(grid.blocked, ax, ay) & ~blocked_at(grid.blocked, bx, by)
    diagonal = (dx != 0) & (dy != 0)
    corner_ok = diagonal_legal(
        blocked_at(grid.blocked, bx, ay), blocked_at(grid.blocked, ax, by), grid.corner_rule
    )
    return adjacent & ends_free & (~diagonal | corner_ok)
