"""Connecting cells into continuous paths: median insertion without rounds x capacity.

IMGA section 4.1 ("median insertion"), MPMGA section 4.2 (the connection operator) and
Zhu & Pan section 4 (connecting the cells chosen by the column crossover) all close a
gap between two cells ``a`` and ``b`` the same way: while some adjacent pair has
Chebyshev distance > 1, insert the median cell ``((x_a + x_b) // 2, (y_a + y_b) // 2)``;
if the median is blocked, insert a uniformly random free 8-neighbour of it instead; if it
has none, the connection fails.

Gaps are independent of each other, so :func:`connect` runs the paper's loop in rounds
that insert a median into every open gap at once, keeping the path as a linked list and
the open gaps as a small work queue: a round costs ``O(open gaps)``, not ``O(capacity)``,
and only the final walk along the links is proportional to the length of the result.

The papers' GAs allow squeezing diagonally between obstacles (corner rule ``"free"``).
Under the stricter rules the connected path first loses its loops (its remaining steps
are steps of the raw path); then, under ``"strict"``, a diagonal step past a blocked side
cell is made legal by inserting the free side cell (two orthogonal steps), and under
``"no_squeeze"`` and ``"strict"`` a diagonal step with both side cells blocked makes the
connection fail. This is jaxga's extension for the stricter corner rules (decision 027).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxga._batching.lanes import lane_while_loop
from jaxga.core import prng
from jaxga.core.errors import ParameterError
from jaxga.core.grid import Grid, blocked_at, diagonal_legal
from jaxga.core.paths import position_lookup, remove_loops

__all__ = ["concat", "connect", "pad_cells", "random_free_neighbour", "splice_loop_free"]

# NumPy, not jnp: importing jaxga must not start JAX's backend (see jaxga._runtime.parallel).
_OFFSETS = np.array(
    [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]], dtype=np.int32
)


def random_free_neighbour(
    key: jax.Array, grid: Grid, cell: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """A uniformly random free 8-neighbour of ``cell`` and whether one exists (IMGA 4.1)."""
    return _pick_free_neighbour(prng.bits(key, (), jnp.uint32), grid, cell)


def neighbour_masks(grid: Grid) -> jax.Array:
    """``int32[H * W]``: bit ``d`` (0-7) set when the 8-neighbour ``d`` of the cell (in
    the order of ``_OFFSETS``) is on the map and free; bit 8 set when the cell itself is
    free.

    One table per map, computed once outside the insertion rounds: a round then needs
    one gather per open gap instead of nine (gathers dominate a round on the CPU). Read
    from ``grid.tables`` when attached (:func:`jaxga.engine.maptables.with_tables`).
    """
    if grid.tables is not None:
        return grid.tables.masks
    return compute_neighbour_masks(grid)


def compute_neighbour_masks(grid: Grid) -> jax.Array:
    """:func:`neighbour_masks` computed from the map (what :mod:`jaxga.engine.maptables` stores)."""
    h, w = grid.blocked.shape
    ys, xs = jnp.divmod(jnp.arange(h * w, dtype=jnp.int32), w)
    free = ~blocked_at(grid.blocked, xs[:, None] + _OFFSETS[:, 0], ys[:, None] + _OFFSETS[:, 1])
    bits = jnp.left_shift(jnp.int32(1), jnp.arange(8, dtype=jnp.int32))
    masks = jnp.sum(jnp.where(free, bits, 0), axis=1, dtype=jnp.int32)
    return masks | jnp.where(grid.blocked.reshape(-1), 0, 256).astype(jnp.int32)


def _pick_free_neighbour(
    bits: jax.Array, grid: Grid, cell: jax.Array, masks: jax.Array | None = None
) -> tuple[jax.Array, jax.Array]:
    """The ``(bits mod n_free)``-th free 8-neighbour of ``cell``: uniform over the free ones.

    One random word per cell instead of eight uniforms (random bits dominate the cost);
    the free neighbours come from :func:`neighbour_masks` (pass it when calling often).
    """
    if masks is None:
        masks = neighbour_masks(grid)
    return _pick_from_mask(bits, masks[cell], cell, grid.width)


def _pick_from_mask(
    bits: jax.Array, mask: jax.Array, cell: jax.Array, w: int
) -> tuple[jax.Array, jax.Array]:
    # Population counts instead of a prefix sum over the 8 bits (jnp.cumsum lowers to a
    # reduce_window that dominated a connection round on CPU): the rank of neighbour d
    # among the free ones is the number of free neighbours below d.
    dirs = jnp.arange(8, dtype=jnp.int32)
    mask8 = mask & 255
    free = (mask8[..., None] >> dirs) & 1
    n_free = jax.lax.population_count(mask8)
    rank = (bits % jnp.maximum(n_free, 1).astype(jnp.uint32)).astype(jnp.int32)
    below = jax.lax.population_count(mask8[..., None] & ((1 << dirs) - 1))
    hit = (free == 1) & (below == rank[..., None])
    step = _OFFSETS[:, 1] * w + _OFFSETS[:, 0]
    pick = cell + jnp.sum(jnp.where(hit, step, 0), axis=-1, dtype=jnp.int32)
    return pick, n_free > 0


def prefix_count(x: jax.Array, axis: int = 0) -> jax.Array:
    """``int32``: inclusive prefix sum of a bool or integer array along ``axis``.

    ``jax.lax.associative_scan`` (O(n log n) work): ``jnp.cumsum`` lowers to a
    ``reduce_window`` that is O(n^2) on XLA's CPU backend and dominated the connection
    rounds (decision 004).
    """
    return jax.lax.associative_scan(jnp.add, jnp.asarray(x, jnp.int32), axis=axis)


def _chebyshev(a: jax.Array, b: jax.Array, w: int) -> jax.Array:
    return jnp.maximum(jnp.abs(a % w - b % w), jnp.abs(a // w - b // w))


def connect(
    key: jax.Array,
    grid: Grid,
    anchors: jax.Array,
    n_anchors: jax.Array,
    capacity: int,
    max_rounds: int = 64,
    queue: int = 64,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Join ``anchors[:n_anchors]`` into one continuous path by median insertion.

    IMGA section 4.1 eq. 2-3 / MPMGA section 4.2 (the connection operator): while two
    consecutive cells are more than one step apart (Chebyshev distance, IMGA eq. 2),
    insert their median (eq. 3) or, if it is blocked, a random free 8-neighbour of it.

    Implementation: the path is a linked list in a node table of ``capacity`` entries and
    the open gaps are a work queue. One round inserts a median into EVERY open gap at
    once (gaps are independent, so this has the distribution of the paper's one-at-a-time
    loop) and queues the (at most two) sub-gaps that are still open. A round costs
    ``O(queue)``; rounds stop when no gap is open (``lax.while_loop``), after at most
    ``max_rounds``; a final pass follows the links (as long as the chain). So the cost does not
    grow with rounds x capacity, only with rounds x open gaps.

    Args:
        key: PRNG key (random free neighbours of blocked medians).
        grid: the map; its corner rule is enforced on every step of the result.
        anchors: ``int32[K]`` cells to pass through in order (need not be adjacent).
        n_anchors: how many of them are used (1 <= n_anchors <= K).
        capacity: static length of the output (and of the node table).
        max_rounds: static bound on insertion rounds (the paper's loop is unbounded).
        queue: static bound on simultaneously open gaps.

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``. ``ok`` is False when an anchor
        is blocked, a blocked median had no free neighbour (IMGA: "the individual is
        directly discarded"), a gap was still open after ``max_rounds``, more than
        ``queue`` gaps were open at once, the path outgrew ``capacity``, or a diagonal
        step could not be made legal under the corner rule; the cells are then
        meaningless. Under ``"free"`` the path may contain loops (remove them with
        :func:`jaxga.core.paths.remove_loops`); under the stricter rules it has none, except
        where a strict corner's inserted side cell was already on the path.
    """
    anchors = jnp.asarray(anchors, jnp.int32)
    n_anchors = jnp.asarray(n_anchors, jnp.int32)
    k_max = anchors.shape[0]
    w = grid.width
    i32 = jnp.int32
    if k_max > capacity:
        # a static size: refused in one line when the program is built, not a traceback
        raise ParameterError(
            f"a path capacity of {capacity} cells cannot hold the {k_max} cells this "
            "operator joins (its anchors): give population.capacity (or, calling an "
            f"operator with a capacity of its own, that capacity) >= {k_max}")
    used = jnp.arange(k_max, dtype=i32) < n_anchors
    ok0 = jnp.all(~blocked_at(grid.blocked, anchors % w, anchors // w) | ~used)

    node = jnp.zeros((capacity,), i32).at[:k_max].set(anchors)
    nxt = jnp.full((capacity,), -1, i32)
    nxt = nxt.at[: k_max - 1].set(
        jnp.where(used[1:], jnp.arange(1, k_max, dtype=i32), -1)
    )
    # Initial queue: every open gap between consecutive used anchors.
    open0 = used[1:] & (_chebyshev(anchors[:-1], anchors[1:], w) > 1)
    q_pos = prefix_count(open0) - 1
    q0 = jnp.full((queue,), -1, i32).at[jnp.where(open0, q_pos, queue)].set(
        jnp.arange(k_max - 1, dtype=i32), mode="drop"
    )
    qlen0 = jnp.sum(open0, dtype=i32)
    ok0 &= qlen0 <= queue
    count0 = jnp.maximum(n_anchors, 1)

    masks = neighbour_masks(grid)

    def cond(c):
        _, _, _, qlen, _, r, ok = c
        return (qlen > 0) & (r < max_rounds) & ok

    # All random words up front: one generator call instead of one per round.
    bits_all = prng.bits(key, (max_rounds, queue), jnp.uint32)

    def body(c):
        node, nxt, q, qlen, count, r, ok = c
        active = jnp.arange(queue, dtype=i32) < qlen
        left = jnp.where(active, q, 0)
        right = nxt[left]
        lo, hi = node[left], node[jnp.maximum(right, 0)]
        mx = (lo % w + hi % w) // 2
        my = (lo // w + hi // w) // 2
        med_mask = masks[my * w + mx]
        med_blocked = med_mask < 256
        alt, has_alt = _pick_from_mask(bits_all[r], med_mask, my * w + mx, w)
        mid = jnp.where(med_blocked, alt, my * w + mx)
        ok &= ~jnp.any(active & med_blocked & ~has_alt)
        new_id = count + jnp.arange(queue, dtype=i32)  # active lanes are a prefix
        ok &= count + qlen <= capacity
        slot = jnp.where(active & (new_id < capacity), new_id, capacity)
        node = _set(node, slot, mid)
        nxt = _set(nxt, slot, right)
        nxt = _set(nxt, jnp.where(active, left, capacity), slot)
        # Sub-gaps still open: (left, mid) and (mid, right).
        cand = jnp.stack([left, slot], axis=1).reshape(-1)
        open_ = jnp.stack(
            [active & (_chebyshev(lo, mid, w) > 1), active & (_chebyshev(mid, hi, w) > 1)],
            axis=1,
        ).reshape(-1)
        q, new_qlen = _compact(open_, cand, queue)
        ok &= new_qlen <= queue
        return node, nxt, q, jnp.minimum(new_qlen, queue), count + qlen, r + 1, ok

    carry = (node, nxt, q0, qlen0, count0, jnp.int32(0), ok0)
    # A per-lane while_loop whose unfinished lanes are compacted under vmap: most
    # connections close in a round or two, a few take many more (jaxga._batching.lanes). Narrow:
    # one loop at the compacted width (the round body is compiled once).
    node, nxt, _, qlen, _, _, ok = lane_while_loop(cond, body, carry, narrow=True)
    ok &= qlen == 0

    # Follow the links from node 0. A while_loop, so that a batch of short bridges (the
    # mutations' case) stops after the longest chain instead of after `capacity` steps.
    slots = jnp.arange(capacity, dtype=i32)

    def follow_cond(c):
        return (c[0] >= 0) & (c[0] < capacity) & (c[1] < capacity)

    def follow_body(c):
        ptr, j, seq = c
        return nxt[ptr], j + 1, jnp.where(slots == j, node[ptr], seq)

    _, n_seq, seq = jax.lax.while_loop(
        follow_cond, follow_body, (jnp.int32(0), jnp.int32(0), jnp.zeros((capacity,), i32))
    )
    keep = jnp.arange(capacity, dtype=i32) < n_seq
    if grid.corner_rule != "free":
        # Judge the corners of the loop-free path: most squeezes of a raw connection lie
        # on loops (a loop-free path's steps are a subset of the raw path's), and failing
        # on them rejected nearly every connection on a random map (decision 044).
        seq, n_seq = remove_loops(seq, n_seq, grid.n_cells)
        keep = jnp.arange(capacity, dtype=i32) < n_seq

    # Make every diagonal step legal under the corner rule (strict: via the free side).
    there = jnp.concatenate([seq[1:], seq[-1:]])
    has_next = jnp.concatenate([keep[1:], jnp.array([False])])
    hx, hy, tx, ty = seq % w, seq // w, there % w, there // w
    diagonal = has_next & (hx != tx) & (hy != ty)
    side_a = blocked_at(grid.blocked, tx, hy)
    side_b = blocked_at(grid.blocked, hx, ty)
    legal = diagonal_legal(side_a, side_b, grid.corner_rule)
    ok &= ~jnp.any(diagonal & ~legal & side_a & side_b)
    insert = diagonal & ~legal
    if grid.corner_rule == "free":  # never needed: skip the second compaction
        length = jnp.sum(keep, dtype=i32)
        return pad_cells(seq, length), length, ok
    vals = jnp.stack([seq, jnp.where(side_a, ty * w + hx, hy * w + tx)], axis=1).reshape(-1)
    valid = jnp.stack([keep, insert], axis=1).reshape(-1)
    cells, total = _compact(valid, vals, capacity)
    ok &= total <= capacity
    length = jnp.minimum(total, capacity)
    return pad_cells(cells, length), length, ok


def _compact(flags: jax.Array, vals: jax.Array, size: int) -> tuple[jax.Array, jax.Array]:
    """``(vals[flags] padded with -1 to size, number of flags)`` (first ``size`` kept).

    Up to 32 flags: the flags packed into one word and the set bits extracted lowest
    first (``x & -x``, ``x & (x - 1)``), a few elementwise operations per slot; XLA
    otherwise fuses a prefix sum into every output slot of the one-hot scatter, which
    dominated a connection round on the CPU. Up to 64: two words. Longer: prefix count
    and scatter.
    """
    n = flags.shape[0]
    if 32 < n <= 64:
        # two words: compact each half and append the second half's values after the
        # first half's (one small gather) instead of the prefix count and one-hot set
        # below, which were a quarter of an MPMGA generation (queue 18, 36 flags)
        first, n_first = _compact(flags[:32], vals[:32], size)
        second, n_second = _compact(flags[32:], vals[32:], size)
        k = jnp.arange(size, dtype=jnp.int32)
        out = jnp.where(k < n_first, first, second[jnp.clip(k - n_first, 0, size - 1)])
        return out, n_first + n_second
    count = jnp.sum(flags, dtype=jnp.int32)
    if n > 32:
        pos = prefix_count(flags) - 1
        out = _set(jnp.full((size,), -1, jnp.int32), jnp.where(flags, pos, size), vals)
        return out, count
    bit = jnp.left_shift(jnp.uint32(1), jnp.arange(n, dtype=jnp.uint32))
    x = jnp.sum(jnp.where(flags, bit, jnp.uint32(0)), dtype=jnp.uint32)
    idx = []
    for _ in range(size):
        low = x & (jnp.uint32(0) - x)
        idx.append(jax.lax.population_count(low - jnp.uint32(1)).astype(jnp.int32))
        x = x & (x - jnp.uint32(1))
    idx = jnp.minimum(jnp.stack(idx), n - 1)
    out = jnp.where(jnp.arange(size, dtype=jnp.int32) < count, vals[idx], -1)
    return out.astype(jnp.int32), count


ONE_HOT_MAX = 1024
"""Largest ``updates x table`` size written with one-hot selects instead of a scatter."""


def _set(table: jax.Array, idx: jax.Array, vals: jax.Array) -> jax.Array:
    """``table.at[idx].set(vals, mode="drop")`` for distinct in-range ``idx``.

    Small tables (the mutations' bridges) use a one-hot select: under ``vmap`` XLA's CPU
    scatter is a serial loop over every update of every lane, which dominated a round.
    """
    n, k = table.shape[0], idx.shape[0]
    if n * k > ONE_HOT_MAX:
        return table.at[idx].set(vals, mode="drop")
    hit = idx[:, None] == jnp.arange(n, dtype=idx.dtype)[None, :]
    new = jnp.sum(jnp.where(hit, vals[:, None], 0), axis=0, dtype=table.dtype)
    return jnp.where(jnp.any(hit, axis=0), new, table)


def pad_cells(cells: jax.Array, length: jax.Array) -> jax.Array:
    """Repeat ``cells[length - 1]`` over the padding (docs, "the pure core")."""
    idx = jnp.arange(cells.shape[0], dtype=jnp.int32)
    return jnp.where(idx < length, cells, cells[jnp.maximum(length - 1, 0)])


def concat(
    parts: list[tuple[jax.Array, jax.Array, jax.Array]], capacity: int
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Concatenate slices ``cells[start:stop]`` of several paths into one padded path.

    Args:
        parts: ``(cells, start, stop)`` triples (traced ``start``/``stop`` allowed).
        capacity: static output length.

    Returns:
        ``(cells int32[capacity], length int32, ok bool)``; ``ok`` is False when the
        total exceeds ``capacity`` (the output is then truncated and must not be used).
        One gather per part over ``capacity`` lanes (none for a first part that starts at
        0 of a path of length ``capacity``), no scatter.
    """
    j = jnp.arange(capacity, dtype=jnp.int32)
    out = jnp.zeros((capacity,), jnp.int32)
    offset = jnp.int32(0)
    for k, (cells, start, stop) in enumerate(parts):
        n = jnp.maximum(jnp.asarray(stop, jnp.int32) - start, 0)
        if k == 0 and isinstance(start, int) and start == 0 and cells.shape[0] == capacity:
            out = jnp.where(j < n, cells, out)  # a prefix in place: no gather
        else:
            src = jnp.clip(j - offset + start, 0, cells.shape[0] - 1)
            out = jnp.where((j >= offset) & (j < offset + n), cells[src], out)
        offset = offset + n
    length = jnp.minimum(offset, capacity)
    last = out[jnp.maximum(length - 1, 0)]
    out = jnp.where(j < length, out, last)
    return out, length, offset <= capacity


SPLICE_LOCAL_MAX = 32
"""Largest inserted segment :func:`splice_loop_free` handles without a full loop removal."""


def splice_loop_free(
    cells: jax.Array,
    length: jax.Array,
    keep_to: jax.Array,
    seg: jax.Array,
    seg_len: jax.Array,
    resume: jax.Array,
    n_cells: int | None = None,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``remove_loops(cells[:keep_to] + seg[:seg_len] + cells[resume:length])`` in ``L``.

    The splice of a mutation (IMGA 4.3.3: replace a stretch of the path by a new
    connection, then remove the loops this creates; MPMGA 4.3 deletion operator).
    Returns ``(cells int32[L], length, fits)``; ``fits`` is False when the loop-free
    result is longer than ``L`` (the cells are then truncated and must not be used).

    For a loop-free parent ``P`` (every GA population here is loop-free) the loops of
    ``A + S + B`` (``A = P[:keep_to]``, ``S`` the segment, ``B = P[resume:length]``) can
    only involve cells of ``S``, so the walk of :func:`jaxga.core.paths.remove_loops` is: keep
    ``A`` up to its first cell that occurs in ``S`` (jump to that cell's last occurrence in
    ``S``), then follow ``S`` by last occurrences until a cell that occurs in ``B`` (jump
    there) or the end of ``S``, then keep the rest of ``B``. With a segment of at most
    :data:`SPLICE_LOCAL_MAX` cells this costs one :func:`~jaxga.core.paths.position_lookup`
    of the parent and a ``len(seg)``-step walk instead of a loop over the whole path;
    the result is the same as the full loop removal (for a loop-free parent; a parent
    with loops of its own keeps them). Longer segments take the full
    :func:`~jaxga.core.paths.remove_loops` (``n_cells`` selects its table variant).
    """
    cells = jnp.asarray(cells, jnp.int32)
    seg = jnp.asarray(seg, jnp.int32)
    length = jnp.asarray(length, jnp.int32)
    seg_len = jnp.asarray(seg_len, jnp.int32)
    cap, m = cells.shape[0], seg.shape[0]
    i32 = jnp.int32
    if m > SPLICE_LOCAL_MAX:
        work, work_len, _ = concat(
            [(cells, 0, keep_to), (seg, 0, seg_len), (cells, resume, length)], cap + m
        )
        work, work_len = remove_loops(work, work_len, n_cells)
        return work[:cap], work_len, work_len <= cap
    t = jnp.arange(m, dtype=i32)
    in_seg = t < seg_len
    # Where each cell of S is in P (-1: nowhere); P is loop-free, so at most once.
    pos = jnp.where(in_seg, position_lookup(cells, length, n_cells)(seg), -1)
    pos_a = jnp.where((pos >= 0) & (pos < keep_to), pos, cap)
    pos_b = jnp.where(pos >= resume, pos, -1)
    same = (seg[:, None] == seg[None, :]) & in_seg[None, :]
    last_s = jnp.max(jnp.where(same, t[None, :], -1), axis=1)  # last occurrence in S
    # The first cell of A that occurs in S: A is kept up to it, S is entered at the
    # cell's last occurrence there.
    k_a = jnp.min(pos_a)
    hit_a = k_a < cap
    entry = jnp.max(jnp.where(pos_a == k_a, t, -1))
    a_len = jnp.where(hit_a, k_a, keep_to)
    t0 = jnp.where(hit_a, entry, 0)

    def step(_, c):
        cur, done, kept, b_from = c
        here = ~done & (cur < seg_len)
        cc = jnp.clip(cur, 0, m - 1)
        kept = kept | (here & (t == cur))
        into_b = here & (pos_b[cc] >= 0)
        b_from = jnp.where(into_b, pos_b[cc] + 1, b_from)
        return (jnp.where(here, last_s[cc] + 1, cur), done | ~here | into_b, kept, b_from)

    init = (t0, jnp.bool_(False), jnp.zeros((m,), bool), jnp.asarray(resume, i32))
    _, _, kept, b_from = jax.lax.fori_loop(0, m, step, init)
    s_cells, s_len = _compact(kept, seg, m)
    return concat([(cells, 0, a_len), (s_cells, 0, s_len), (cells, b_from, length)], cap)
