"""The one small helper that applies per-individual operators to a population.

Every operator of jaxga is written for ONE individual (or one pair) as a pure function of
an explicit PRNG key (docs, "the pure core"). This module lifts such functions to a population with
``jax.vmap``, splitting the key so that individual ``i`` always gets the same sub-key
for the same population key (same key, same result), and it implements the common
failure contract: an operator that fails for an individual (capacity overflow, a
connection that does not close, ...) returns its input unchanged, and the population
helper returns how many individuals failed.

Conventions:

* mutation-like operators: ``op(key, grid, cells, length, *args) -> (cells, length, failed)``
* pair operators (crossover): ``op(key, grid, c1, l1, c2, l2, *args) -> (c1, l1, c2, l2, failed)``
  where ``failed`` is a bool or an int count for the pair.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.folding import fold_call, hoist, on_accelerator
from jaxga._batching.scatter import true_first_order
from jaxga.core import prng
from jaxga.core.grid import Grid
from jaxga.core.paths import Population

__all__ = [
    "gated_map",
    "keep_parent_on_failure",
    "over_individuals",
    "over_individuals_gated",
    "over_pairs",
    "over_pairs_gated",
    "pool_width",
    "spliced_pairs_map",
    "windowed_map",
]


def keep_parent_on_failure(
    failed: jax.Array,
    new_cells: jax.Array,
    new_length: jax.Array,
    cells: jax.Array,
    length: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """Return the parent where ``failed`` (a failed operator keeps its parent)."""
    return jnp.where(failed, cells, new_cells), jnp.where(failed, length, new_length)


def over_individuals(op: Callable, *, in_axes_extra: tuple = ()) -> Callable:
    """Lift ``op(key, grid, cells, length, *extra)`` to ``(key, grid, pop, *extra)``.

    Returns a function giving ``(Population, n_failed int32)``. ``in_axes_extra`` gives
    the vmap axes of the extra arguments (default: all mapped along axis 0).
    """

    def lifted(key: jax.Array, grid: Grid, pop: Population, *extra):
        keys = prng.split(key, pop.size)
        axes = (0, None, 0, 0) + (in_axes_extra or (0,) * len(extra))
        cells, length, failed = jax.vmap(op, in_axes=axes)(
            keys, grid, pop.cells, pop.length, *extra
        )
        return Population(cells, length), jnp.sum(failed, dtype=jnp.int32)

    lifted.__name__ = getattr(op, "__name__", "op") + "_population"
    lifted.__doc__ = f"``{lifted.__name__[:-11]}`` applied to every individual (vmap)."
    return lifted


def _interleave(pop: Population, c1, l1, c2, l2) -> Population:
    """Children of pairs (0, 1), (2, 3), ... back in population order; an odd last
    individual of ``pop`` passes through."""
    n_pairs = c1.shape[0]
    # [pairs, 2L] rows c1[i] ++ c2[i], reshaped to [2 pairs, L]: the same rows as stacking on
    # a new axis 1, but one contiguous copy (a stack is a transposing copy on XLA:CPU)
    cells = jnp.concatenate([c1, c2], axis=-1).reshape(2 * n_pairs, -1)
    length = jnp.stack([l1, l2], axis=1).reshape(-1)
    if pop.size % 2:
        cells = jnp.concatenate([cells, pop.cells[-1:]], axis=0)
        length = jnp.concatenate([length, pop.length[-1:]], axis=0)
    return Population(cells, length)


def over_pairs(op: Callable, *, in_axes_extra: tuple = ()) -> Callable:
    """Lift a pair operator to a population: pairs are (0, 1), (2, 3), ...

    ``op(key, grid, c1, l1, c2, l2, *extra) -> (c1, l1, c2, l2, failed)``. With an odd
    population the last individual passes through unchanged. Returns
    ``(Population, n_failed int32)``. Shuffle the population first (selection does) if
    pairs should be random.
    """

    def lifted(key: jax.Array, grid: Grid, pop: Population, *extra):
        n_pairs = pop.size // 2
        keys = prng.split(key, max(n_pairs, 1))[:n_pairs]
        c, ln = pop.cells, pop.length
        axes = (0, None, 0, 0, 0, 0) + (in_axes_extra or (0,) * len(extra))
        c1, l1, c2, l2, failed = jax.vmap(op, in_axes=axes)(
            keys, grid, c[0 : 2 * n_pairs : 2], ln[0 : 2 * n_pairs : 2],
            c[1 : 2 * n_pairs : 2], ln[1 : 2 * n_pairs : 2], *extra,
        )
        return _interleave(pop, c1, l1, c2, l2), jnp.sum(failed, dtype=jnp.int32)

    lifted.__name__ = getattr(op, "__name__", "op") + "_population"
    lifted.__doc__ = f"``{lifted.__name__[:-11]}`` applied to consecutive pairs (vmap)."
    return lifted


POOL_SHRINK = 4
"""Under ``vmap``, :func:`gated_map` computes ``1 / POOL_SHRINK`` of its per-run block
width times the number of runs per iteration, at most :data:`POOL_MAX` entries (see
there)."""

POOL_MAX = 192
"""Largest pooled block of :func:`gated_map` under ``vmap`` (unless one run's block is
wider): about the best width both for 100 runs in one ``vmap`` and for the blocks of
runs that ``jaxga.api`` runs per device, where :data:`POOL_SHRINK` 4 gives it
(decision 004). The results do not depend on the width."""

ACCELERATOR_POOL_MAX = 1 << 18
"""Largest block of :func:`gated_map` on a GPU or TPU
(:func:`jaxga._batching.folding.on_accelerator`), where a block is all the entries of
the folded batch up to this many (and :data:`ACCELERATOR_POOL_BYTES`): 2048 runs of up
to 128 individuals are one block. There an iteration of the block loop costs a chain of
kernel launches whatever its width, so one wide block is faster than many small ones,
although it computes the operator for the entries the gate skips as well (decision 049).
The results do not depend on the width."""

ACCELERATOR_POOL_BYTES = 1 << 29
"""Most bytes of entries (the gate, the operator's arguments and its defaults) in one
block of :func:`gated_map` on a GPU or TPU: on large maps an entry's path is long, and
the operator's working arrays grow with the block (decision 049)."""


def gated_map(
    fn: Callable,
    apply: jax.Array,
    args: tuple,
    defaults: tuple,
    *,
    block: int | None = None,
    dense: bool = False,
    shrinking: bool = False,
    splicing: bool = False,
) -> tuple:
    """``vmap(fn)`` over the entries where ``apply`` holds; ``defaults`` elsewhere.

    ``out[i] = fn(*[a[i] for a in args]) if apply[i] else defaults[i]`` (every element of
    ``args`` and ``defaults`` has the leading axis ``N``). Equal to
    ``where(apply, vmap(fn)(*args), defaults)`` but computed only for the applied
    entries: they are moved to the front (:func:`true_first_order`) and processed in
    blocks of ``block`` inside a ``lax.while_loop`` that stops after the last applied
    entry. A mutation with ``pm = 0.3`` on 60 individuals thus costs 2 blocks of 16
    instead of 60 operator evaluations (decision 004: under ``vmap`` a gate does
    not skip work by itself). ``fn`` must return a tuple of arrays.

    Under ``vmap`` (runs, islands) the applied entries of ALL the batch's calls are
    pooled (:func:`jaxga._batching.folding.fold_call`): blocks of ``block * R / POOL_SHRINK``
    (at most :data:`POOL_MAX`, at least ``block``)
    entries for ``R`` calls, as many as the batch's applied entries need (on a GPU or
    TPU: one block of all ``R * N`` entries, at most :data:`ACCELERATOR_POOL_MAX`
    and :data:`ACCELERATOR_POOL_BYTES`). Without
    pooling every run paid the block count of its busiest run (for SGA's mutation of
    100 runs: 1,500 to 2,250 operator evaluations for about 1,800 mutants; pooled,
    about 1,900). Each entry computes exactly what it computes alone.

    ``dense=True`` (static) computes ``fn`` for every entry and selects: the same result,
    cheaper when most entries apply (a crossover with ``pc = 0.8``: the sort and the
    per-block scatters cost more than the skipped work).

    ``shrinking=True`` (static) declares ``fn(key, cells, length, ...) -> (cells, length,
    ...)`` a path operator that reads only the first ``length`` cells, returns a path no
    longer than its input, padded with its last cell, and has no width-dependent float sum.
    A block whose paths all fit :func:`window_width` cells is then computed on that many
    (the operator traced at both widths) and re-padded: the same bits, less work (a
    sequential pass such as :func:`jaxga.operators.mutation.cut_corners` scans the window only).

    ``splicing=True`` (static, with ``dense``) declares ``fn`` a splicing pair operator
    (:func:`spliced_pairs_map`): computed on twice the window when every parent fits it.
    """
    if splicing and not dense:
        raise ValueError("splicing=True needs dense=True")
    apply = jnp.asarray(apply, bool)
    if dense:
        res = spliced_pairs_map(fn, args) if splicing else jax.vmap(fn)(*args)
        return tuple(
            jnp.where(apply.reshape(apply.shape + (1,) * (d.ndim - 1)), r.astype(d.dtype), d)
            for r, d in zip(res, defaults)
        )
    n = apply.shape[0]
    b = block or max(4, -(-n // 4))
    args, defaults = tuple(jnp.asarray(a) for a in args), tuple(jnp.asarray(d) for d in defaults)
    example = [a[0] for a in args]
    n_args = len(args)
    narrow = None
    w = window_width(args[1].shape[1]) if shrinking else None
    if shrinking and w < args[1].shape[1]:
        fn_op, narrow_op, consts, j = _hoist_two_widths(fn, example, (1,), w)
        narrow = (narrow_op, j, w)
    else:
        fn_op, consts = hoist(lambda *a: tuple(fn(*a)), *example)

    def client(lead, lanes, operands, axes):
        r = int(np.prod(lead, dtype=np.int64)) if lead else 1
        flat = [x.reshape((r * n,) + x.shape[1 + bool(lead):]) for x in lanes]
        entry_bytes = sum(x.dtype.itemsize * math.prod(x.shape[1:]) for x in flat)
        width = pool_width(b, r, n, entry_bytes)
        out = _blocks(fn_op, flat[0], flat[1:1 + n_args], flat[1 + n_args:], operands,
                      axes, n, width, narrow)
        return [x.reshape(((r, n) if lead else (n,)) + x.shape[1:]) for x in out]

    out = fold_call(client, [apply, *args, *defaults], consts, defaults)
    return tuple(out)


def pool_width(block: int, calls: int, per_call: int, entry_bytes: int = 0) -> int:
    """The block width of :func:`gated_map` over ``calls`` folded calls (1 without
    ``vmap``) of ``per_call`` entries each, with a per-call block of ``block``: on a GPU
    or TPU (:func:`jaxga._batching.folding.on_accelerator`) all the entries, at most
    :data:`ACCELERATOR_POOL_MAX` and :data:`ACCELERATOR_POOL_BYTES` of entries of
    ``entry_bytes`` each; on the CPU ``block * calls / POOL_SHRINK``, at most
    :data:`POOL_MAX`; never less than ``block``."""
    if on_accelerator():
        most = ACCELERATOR_POOL_MAX
        if entry_bytes > 0:
            most = min(most, max(1, ACCELERATOR_POOL_BYTES // entry_bytes))
        return max(block, min(calls * per_call, most))
    return max(block, min(-(-block * calls // POOL_SHRINK), POOL_MAX))


def _blocks(fn_op, apply, args, defaults, consts, axes, n, b, narrow=None):
    """The applied entries of ``apply`` (``R * n`` entries of ``R`` calls: call ``i // n``
    owns entry ``i`` and the rows ``consts[j][i // n]`` where ``axes[j] == 0``), in blocks
    of ``b`` inside a ``while_loop``. ``narrow = (op, first const, width)``: a shrinking
    path operator's narrow program (:func:`gated_map`)."""
    total = apply.shape[0]
    n_blocks = -(-total // b)
    order = true_first_order(apply)
    order = jnp.concatenate([order, jnp.full((n_blocks * b - total,), total, jnp.int32)])
    n_apply = jnp.sum(apply, dtype=jnp.int32)
    lane = jnp.arange(b, dtype=jnp.int32)

    def cond(c):
        return c[0] * b < n_apply

    def body(c):
        k, out = c
        idx = jax.lax.dynamic_slice_in_dim(order, k * b, b)
        valid = k * b + lane < n_apply
        src = jnp.minimum(idx, total - 1)
        lane_consts = [x if ax is None else x[src // n] for x, ax in zip(consts, axes)]
        lane_args = [a[src] for a in args]
        if narrow is None:
            res = _vmap_hoisted(fn_op, lane_consts, axes, lane_args)
        else:
            op, j, w = narrow
            longest = jnp.max(jnp.where(valid, lane_args[2], 0))
            res = jax.lax.cond(
                longest <= w,
                lambda: _narrow_call(op, lane_consts[j:], axes[j:], lane_args, (1,), w, (0,)),
                lambda: _vmap_hoisted(fn_op, lane_consts[:j], axes[:j], lane_args))
        dst = jnp.where(valid, idx, total)
        out = tuple(o.at[dst].set(r.astype(o.dtype), mode="drop") for o, r in zip(out, res))
        return k + 1, out

    _, out = jax.lax.while_loop(cond, body, (jnp.int32(0), tuple(defaults)))
    return out


@dataclasses.dataclass(frozen=True)
class _Gates:
    """What a gated lift draws before any operator runs (:func:`over_individuals_gated`,
    :func:`over_pairs_gated`): for each individual or pair, whether it goes through an
    operator (``applied``: a uniform draw of its gate key below its probability), its
    operator key, which of the two operators (``use_op``, None without an alternative),
    and the extra arguments, the per-individual ones (``mapped``) apart."""

    applied: jax.Array
    op_keys: jax.Array
    use_op: jax.Array | None
    extra: tuple
    axes: tuple
    mapped: list

    @classmethod
    def draw(cls, keys: jax.Array, prob: Any, extra: tuple, has_alternative: bool,
             in_axes_extra: tuple) -> _Gates:
        """Each of ``keys`` (one per individual or pair) split into a gate key and an
        operator key; with an alternative, ``extra[0]`` is ``use_op``."""
        use_op = None
        if has_alternative:
            use_op, extra = jnp.asarray(extra[0], bool), extra[1:]
            use_op = use_op[:keys.shape[0]] if use_op.ndim else use_op  # pairs: P // 2
        prob = jnp.broadcast_to(jnp.asarray(prob, jnp.float32), (keys.shape[0],))
        k_gate, k_op = jax.vmap(lambda k: tuple(prng.split(k)))(keys)
        applied = jax.vmap(lambda k: prng.uniform(k, (), jnp.float32))(k_gate) < prob
        axes = in_axes_extra or (0,) * len(extra)
        mapped = [e for e, ax in zip(extra, axes) if ax == 0]
        return cls(applied, k_op, use_op, tuple(extra), tuple(axes), mapped)

    def bound(self, fn: Callable | None, grid: Grid, n_paths: int) -> Callable | None:
        """``fn(key, grid, *paths, *extra)`` as a function of ``(key, *paths, *mapped)``:
        the grid and the shared extra arguments bound, the per-individual ones in place."""
        if fn is None:
            return None

        def call(k, *operands):
            per = iter(operands[n_paths:])
            args = [next(per) if ax == 0 else e for e, ax in zip(self.extra, self.axes)]
            return fn(k, grid, *operands[:n_paths], *args)
        return call

    def apply(self, op: Callable, alternative: Callable | None, args: tuple, out: tuple,
              **options: Any) -> tuple:
        """``out`` with the applied individuals (pairs) replaced by ``op``'s results; with
        an alternative, by ``op``'s where ``use_op`` and ``alternative``'s elsewhere, each
        computed for its own individuals only (:func:`gated_map`)."""
        if self.use_op is None:
            return gated_map(op, self.applied, args, out, **options)
        out = gated_map(op, self.applied & self.use_op, args, out, **options)
        return gated_map(alternative, self.applied & ~self.use_op, args, out, **options)


def over_individuals_gated(
    op: Callable, *, alternative: Callable | None = None, in_axes_extra: tuple = (),
    shrinking: bool = False,
) -> Callable:
    """Lift ``op(key, grid, cells, length, *extra)`` with a per-individual probability.

    Returns ``lifted(key, grid, pop, prob, *extra) -> (Population, n_failed)``: individual
    ``i`` goes through ``op`` with probability ``prob[i]`` (a scalar or ``f32[P]``) and is
    otherwise unchanged; ``n_failed`` counts failures of applied operators only. The keys
    are those of :func:`over_individuals`, each split into a gate key and an operator
    key, so the result equals applying ``op`` to every individual and keeping it with
    probability ``pm``; the work is done only for the applied individuals
    (:func:`gated_map`).
    ``in_axes_extra``: 0 (per individual) or None (shared) for each extra argument.

    With ``alternative``, the signature is ``lifted(key, grid, pop, prob, use_op,
    *extra)``: an applied individual goes through ``op`` where ``use_op`` (bool[P]) and
    through ``alternative`` elsewhere, with the same key, as
    choosing between the two per individual does, but each operator is computed only for
    its own individuals (Zhu & Pan's half one-point, half range mutation).

    ``shrinking=True`` (static): ``op`` (and ``alternative``) never lengthen a path and
    are computed on a narrow window when the paths fit (:func:`gated_map`).
    """

    def lifted(key: jax.Array, grid: Grid, pop: Population, prob, *extra):
        n = pop.size
        gates = _Gates.draw(prng.split(key, n), prob, extra, alternative is not None,
                            in_axes_extra)
        args = (gates.op_keys, pop.cells, pop.length, *gates.mapped)
        out = (pop.cells, pop.length, jnp.zeros((n,), bool))
        cells, length, failed = gates.apply(
            gates.bound(op, grid, 2), gates.bound(alternative, grid, 2), args, out,
            shrinking=shrinking)
        return Population(cells, length), jnp.sum(failed, dtype=jnp.int32)

    lifted.__name__ = getattr(op, "__name__", "op") + "_population"
    lifted.__doc__ = f"``{lifted.__name__[:-11]}`` applied with a probability (gated vmap)."
    return lifted


def over_pairs_gated(
    op: Callable, *, alternative: Callable | None = None, in_axes_extra: tuple = (),
    dense: bool = False, splicing: bool = False,
) -> Callable:
    """Lift a pair operator with a per-pair probability (the pair form of
    :func:`over_individuals_gated`).

    Returns ``lifted(key, grid, pop, prob, *extra) -> (Population, n_failed)``: pairs
    ``(0, 1), (2, 3), ...``; pair ``k`` goes through ``op`` with probability ``prob[k]``
    (scalar or ``f32[P // 2]``); an odd last individual passes through. Keys as in
    :func:`over_pairs`, each split into a gate and an operator key (the result equals
    crossing every pair and keeping it with probability ``pc``); only applied pairs are computed.
    With ``alternative``: ``lifted(key, grid, pop, prob, use_op, *extra)``, pair ``k``
    goes through ``op`` where ``use_op[k]`` else through ``alternative`` (Zhu & Pan's
    half one-point, half column crossover), each computed only for its own pairs.
    ``dense=True``: every pair is computed and the applied ones selected (same result;
    see :func:`gated_map`), cheaper for the papers' crossover rates of 0.6-0.9.
    ``splicing=True`` (with ``dense``): ``op`` builds its children from a head and a
    tail of its parents and is computed on twice the window (:func:`spliced_pairs_map`).
    """
    if splicing and (not dense or alternative is not None):
        raise ValueError("splicing=True needs dense=True and no alternative operator")

    def lifted(key: jax.Array, grid: Grid, pop: Population, prob, *extra):
        n_pairs = pop.size // 2
        gates = _Gates.draw(prng.split(key, max(n_pairs, 1))[:n_pairs], prob, extra,
                            alternative is not None, in_axes_extra)
        c, ln = pop.cells, pop.length
        c1, l1 = c[0 : 2 * n_pairs : 2], ln[0 : 2 * n_pairs : 2]
        c2, l2 = c[1 : 2 * n_pairs : 2], ln[1 : 2 * n_pairs : 2]

        def one(fn):
            if fn is None:
                return None
            call = gates.bound(fn, grid, 4)

            def counted(*operands):
                n1, m1, n2, m2, failed = call(*operands)
                return n1, m1, n2, m2, jnp.asarray(failed, jnp.int32)
            return counted

        args = (gates.op_keys, c1, l1, c2, l2, *gates.mapped)
        out = (c1, l1, c2, l2, jnp.zeros((n_pairs,), jnp.int32))
        c1, l1, c2, l2, failed = gates.apply(one(op), one(alternative), args, out, dense=dense,
                                             splicing=splicing)
        return _interleave(pop, c1, l1, c2, l2), jnp.sum(failed, dtype=jnp.int32)

    lifted.__name__ = getattr(op, "__name__", "op") + "_population"
    return lifted


WINDOW_FRACTION = 0.4
""":func:`windowed_map`'s narrow width is the smallest power of two at least this share
of the capacity: wide enough to hold the longest path of a whole batch of evolving runs
once their first generations have shortened it, so that the narrow program is the one
that runs (the longest paths measured: decision 005)."""


def window_width(capacity: int) -> int:
    """The narrow width :func:`windowed_map` uses for rows of ``capacity`` cells."""
    return 1 << max(0, math.ceil(WINDOW_FRACTION * capacity) - 1).bit_length()


def windowed_map(fn: Callable, cells: jax.Array, length: jax.Array, *args,
                 window: int | None = None) -> tuple:
    """``vmap(fn)(cells, length, *args)`` computed on ``cells[:, :window]`` when every path
    of the whole batch fits the window.

    ``fn(cells_row, length, *a)`` must read only the first ``length`` cells of its row
    and reduce floats with :func:`jaxga._batching.numerics.ordered_sum` (or exactly), so that
    its result does not depend on the row's width beyond ``length`` (the tree of
    ``ordered_sum`` over a power-of-two width only adds exact zeros past ``window``).
    Under ``vmap`` the calls of all runs are folded (:func:`jaxga._batching.folding.fold_call`) and
    ONE scalar test on their longest path picks the narrow or the full-width program
    (``lax.cond`` on an unbatched predicate: only the chosen one runs).
    """
    cells = jnp.asarray(cells)
    w = window_width(cells.shape[1]) if window is None else int(window)
    return _windowed(fn, (cells, length, *args), paths=(0,), lengths=(1,), fits=w, cut=w)


def spliced_pairs_map(fn: Callable, args: tuple, window: int | None = None) -> tuple:
    """``vmap(fn)(*args)`` for a splicing pair operator, on ``2 * window`` cells when
    every parent of the whole batch fits ``window`` cells.

    ``args = (keys, c1, l1, c2, l2, *rest)``, the parents padded with their last cell
    (docs, "the pure core"); ``fn`` returns ``(c1', l1', c2', l2', ...)``. ``fn``'s result
    must depend only on the first ``l1`` / ``l2`` cells of its parents (it may look past
    them and mask what it finds), it must draw the same random numbers at every width and build
    children no longer than ``l1 + l2 - 1`` cells (a head of one parent and a tail of the
    other: the common-point crossover's are at most ``l1 + l2 - 3``).
    Such children always fit ``2 * window`` cells, as they fit the full width, so the
    narrow program gives the same children, re-padded with their last cell,
    and the same failure counts. As :func:`windowed_map`, one unbatched test on the
    longest parent of all folded runs picks the program (decision 005).
    """
    w = window_width(args[1].shape[1]) if window is None else int(window)
    return _windowed(fn, tuple(args), paths=(1, 3), lengths=(2, 4), fits=w, cut=2 * w,
                     out_paths=(0, 2))


def _windowed(fn: Callable, args: tuple, *, paths: tuple, lengths: tuple, fits: int,
              cut: int, out_paths: tuple = ()) -> tuple:
    """``vmap(fn)(*args)``; when every length ``args[i]`` (``i`` in ``lengths``) of the
    folded batch is at most ``fits``, computed with the paths ``args[i]`` (``i`` in
    ``paths``) cut to ``cut`` cells and the output paths ``out_paths`` re-padded to the
    full width (:func:`windowed_map`, :func:`spliced_pairs_map`)."""
    args = tuple(jnp.asarray(a) for a in args)
    n, cap = args[paths[0]].shape
    if cut >= cap:
        return tuple(jax.vmap(fn)(*args))
    example = [a[0] for a in args]
    wide_op, narrow_op, consts, j = _hoist_two_widths(fn, example, paths, cut)

    def client(lead, lanes, operands, axes):
        total = (int(np.prod(lead, dtype=np.int64)) if lead else 1) * n
        flat = [x.reshape((total,) + x.shape[1 + bool(lead):]) for x in lanes]
        entry = jnp.arange(total, dtype=jnp.int32) // n
        lane_consts = [x if ax is None else x[entry] for x, ax in zip(operands, axes)]
        longest = jnp.max(jnp.stack([jnp.max(flat[i]) for i in lengths]))
        out = jax.lax.cond(
            longest <= fits,
            lambda: _narrow_call(narrow_op, lane_consts[j:], axes[j:], flat, paths, cut,
                                 out_paths),
            lambda: _vmap_hoisted(wide_op, lane_consts[:j], axes[:j], flat))
        return [x.reshape(((total // n, n) if lead else (n,)) + x.shape[1:]) for x in out]

    out_like = [jax.ShapeDtypeStruct((n,) + o.shape, o.dtype)
                for o in jax.eval_shape(wide_op, consts[:j], *example)]
    return tuple(fold_call(client, list(args), consts, out_like))


def _narrow_call(op: Callable, consts: list, axes: list, lanes: list, paths: tuple,
                 cut: int, out_paths: tuple) -> tuple:
    """A narrow program (:func:`_hoist_two_widths`) over lanes: the paths ``lanes[i]``
    (``i`` in ``paths``) cut to ``cut`` cells, the output paths ``out_paths`` re-padded
    to the lanes' full width."""
    width = lanes[paths[0]].shape[1]
    lanes = [x[:, :cut] if i in paths else x for i, x in enumerate(lanes)]
    out = _vmap_hoisted(op, consts, axes, lanes)
    return tuple(_repad(x, width) if i in out_paths else x for i, x in enumerate(out))


def _repad(cells: jax.Array, width: int) -> jax.Array:
    """Rows of paths widened to ``width`` cells by repeating their last cell."""
    w = cells.shape[1]
    pad = jnp.broadcast_to(cells[:, w - 1:], (cells.shape[0], width - w))
    return jnp.concatenate([cells, pad], axis=1)


def _hoist_two_widths(fn: Callable, example: list, at: tuple, w: int) -> tuple:
    """``(wide_op, narrow_op, consts, j)``: ``fn`` hoisted (:func:`jaxga._batching.folding.hoist`)
    for the ``example`` arguments and for them with the paths ``example[i]`` (``i`` in
    ``at``) cut to their first ``w`` cells (a jaxpr has fixed shapes); ``consts[:j]`` are
    the wide program's closed-over values, ``consts[j:]`` the narrow one's."""
    wide_op, wide_consts = hoist(lambda *a: tuple(fn(*a)), *example)
    cut = [x[:w] if i in at else x for i, x in enumerate(example)]
    narrow_op, narrow_consts = hoist(lambda *a: tuple(fn(*a)), *cut)
    return wide_op, narrow_op, wide_consts + narrow_consts, len(wide_consts)


def _vmap_hoisted(op: Callable, consts: list, axes: list, args: list) -> tuple:
    """A hoisted ``op`` over lanes: ``args`` and the ``consts`` whose ``axes`` entry is
    not None are per lane (leading axis), the others shared."""
    in_axes = ([None if ax is None else 0 for ax in axes],) + (0,) * len(args)
    return tuple(jax.vmap(op, in_axes=in_axes)(consts, *args))
