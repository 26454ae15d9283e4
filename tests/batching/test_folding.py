"""jaxga._batching.folding: every vmap level above a call folded into one flat batch of lanes.

Inputs are made in NumPy (no eager iota, reshape or swap); what stays eager is the folded
call itself, whose eager path (the primitive's implementation) is under test. The tests
that observe a client traced at lowering jit a function of their own, once.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxga._batching.folding import fold_call, hoist, layout_as, on_accelerator


def _i32(x):
    """An int32 JAX array of ``x``, made in NumPy (one transfer per shape, not an eager
    computation)."""
    return jnp.asarray(np.asarray(x, np.int32))


def _probe(seen):
    """A client that records what it was given and returns, per lane,
    ``lane + operand`` (operands broadcast to the flat lanes when batched)."""

    def client(lead, lanes, operands, axes):
        seen.append((lead, [x.shape for x in lanes], [None if a is None else x.shape
                                                       for x, a in zip(operands, axes)]))
        (x,) = lanes
        total = x
        for o, a in zip(operands, axes):
            total = total + (o if a is None else o.reshape(o.shape + (1,) * (x.ndim - o.ndim)))
        return [total]

    return client


def test_without_vmap_the_client_sees_the_call_itself():
    seen = []
    out = fold_call(_probe(seen), [_i32(np.arange(3))], [_i32(5)], [_i32(np.arange(3))])
    assert seen == [((), [(3,)], [None])]
    np.testing.assert_array_equal(out[0], [5, 6, 7])


def test_two_levels_fold_into_one_leading_dimension_and_operands_broadcast():
    seen = []
    x = _i32(np.arange(2 * 3 * 4).reshape(2, 3, 4))
    outer = _i32([100, 200])  # batched at the outer level only
    shared = _i32(7)  # batched at no level: stays one copy

    def call(xi, o):
        return fold_call(_probe(seen), [xi], [o, shared], [xi])[0]

    want = np.asarray(x) + np.asarray(outer)[:, None, None] + 7
    out = jax.vmap(jax.vmap(call, in_axes=(0, None)))(x, outer)
    lead, lane_shapes, op_shapes = seen[-1]
    assert lead == (2, 3) and lane_shapes == [(6, 4)]
    assert op_shapes == [(6,), None]  # the outer-only operand broadcast to all 6 lanes
    np.testing.assert_array_equal(out, want)
    # the same under jit, where the client runs when the program is lowered
    jitted = jax.jit(jax.vmap(jax.vmap(call, in_axes=(0, None)), in_axes=(1, 0)))
    np.testing.assert_array_equal(jitted(np.swapaxes(np.asarray(x), 0, 1), outer), want)
    assert seen[-1] == ((2, 3), [(6, 4)], [(6,), None])


_apply = jax.jit(lambda fn_op, consts, *args: fn_op(consts, *args), static_argnums=0)
"""``fn_op(consts, *args)`` of a hoisted function (the consts as jit arguments)."""


def test_hoist_turns_closed_over_values_into_operands():
    table = _i32([3, 1, 4, 1, 5])

    def fn(i, j):
        return {"a": table[i] * j}

    fn_op, consts = hoist(fn, _i32(0), _i32(0))
    assert any(np.array_equal(c, table) for c in consts)
    other = [_i32([10, 20, 30, 40, 50]) if np.array_equal(c, table) else c
             for c in consts]
    assert int(_apply(fn_op, consts, _i32(2), _i32(3))["a"]) == 12
    assert int(_apply(fn_op, other, _i32(2), _i32(3))["a"]) == 90


def test_the_client_is_traced_once_with_every_level_folded():
    """Nested vmap inside a scan inside jit: the batching rule adds levels without
    tracing the client; it is traced once, at lowering, with all three levels folded."""
    seen = []
    x = _i32(np.arange(2 * 3 * 4 * 5).reshape(2, 3, 4, 5))
    one = _i32(1)

    def call(xi):
        return fold_call(_probe(seen), [xi], [one], [xi])[0]

    def scanned(xs):  # the scan body is traced unbatched, then batched by the outer vmap
        return jax.lax.scan(lambda c, row: (c, jax.vmap(jax.vmap(call))(row)), 0, xs)[1]

    out = jax.jit(jax.vmap(scanned))(x)
    assert [s[0] for s in seen] == [(2, 4, 5)]
    np.testing.assert_array_equal(out, np.asarray(x) + 1)


def test_a_client_returning_other_shapes_than_declared_is_an_error():
    def client(lead, lanes, operands, axes):
        return [lanes[0][..., :1]]

    with pytest.raises(TypeError, match="declared"):
        fold_call(client, [_i32(np.arange(3))], [], [_i32(np.arange(3))])
    with pytest.raises(TypeError, match="declared"):  # a dtype, under jit
        jax.jit(lambda x: fold_call(_probe([]), [x], [], [x.astype(jnp.float32)]))(
            _i32(np.arange(3)))


def _ident(lead, lanes, operands, axes):
    return list(lanes)


def _times_bf16(x):
    return fold_call(_ident, [x], [], [x])[0] * jnp.bfloat16(2)


_times_bf16_jit = jax.jit(_times_bf16)


def test_declared_outputs_keep_weak_types_and_take_numpy_values():
    """A weakly typed declared output stays weak under jit (as ``lax.while_loop``'s
    carry does), and NumPy values declare the dtype JAX gives them."""
    weak = jnp.asarray(1.5)  # a Python float: weakly typed float32
    assert _times_bf16_jit(weak).dtype == _times_bf16(weak).dtype == jnp.bfloat16
    assert _times_bf16_jit(np.float32(1.5)).dtype == jnp.float32
    (out,) = fold_call(_ident, [np.zeros(3)], [], [np.zeros(3)])  # float64 -> float32
    assert out.dtype == jnp.float32


def _platform_probe(seen):
    """A client that records :func:`on_accelerator` as it is traced."""

    def client(lead, lanes, operands, axes):
        seen.append(on_accelerator())
        return lanes

    return client


@pytest.mark.parametrize("platforms, accelerator", [
    (("cpu",), False), (("cuda",), True), (("rocm",), True), (("tpu",), True),
    (("cpu", "cuda"), False)])
def test_a_client_knows_whether_its_program_is_lowered_for_an_accelerator(platforms,
                                                                          accelerator):
    """Lowered for a GPU or TPU (here only lowered, never run), the client lays its lanes
    out for an accelerator; for the CPU, or for several platforms one of which is the
    CPU, as on the CPU."""
    seen = []
    x = np.zeros((2, 3), np.int32)
    jax.jit(jax.vmap(lambda v: fold_call(_platform_probe(seen), [v], [], [v])[0])).trace(
        x).lower(lowering_platforms=platforms)
    assert seen == [accelerator]


def test_layout_as_overrides_the_platform_and_ends_with_its_scope():
    """Outside a client the layout is the CPU's; ``layout_as`` forces one for programs
    lowered inside it (either way), and the platform's own again after it."""
    assert not on_accelerator()
    x = np.zeros((2, 3), np.int32)
    seen = []

    def lower(platform):
        fn = jax.vmap(lambda v: fold_call(_platform_probe(seen), [v], [], [v])[0])
        jax.jit(fn).trace(x).lower(lowering_platforms=(platform,))

    with layout_as("cuda"):
        assert on_accelerator()
        lower("cpu")
    with layout_as("cpu"):
        lower("cuda")
    lower("cuda")
    assert seen == [True, False, True]
    assert not on_accelerator()


def test_an_eager_call_is_laid_out_for_the_default_backend(monkeypatch):
    """Run eagerly (no lowering), the client is laid out for JAX's default backend."""
    seen = []
    x = _i32(np.arange(3))
    fold_call(_platform_probe(seen), [x], [], [x])
    monkeypatch.setattr(jax, "default_backend", lambda: "cuda")
    fold_call(_platform_probe(seen), [x], [], [x])
    assert seen == [False, True]


@pytest.mark.parametrize("name", ["CUDA", "Tpu"])
def test_layout_as_takes_a_platform_in_any_case(name):
    with layout_as(name):
        assert on_accelerator()
    with layout_as("CPU"):
        assert not on_accelerator()


@pytest.mark.parametrize("name", ["gpu0", "host", ""])
def test_layout_as_refuses_an_unknown_platform_in_one_line(name):
    with pytest.raises(ValueError, match="unknown platform") as err:
        with layout_as(name):
            pass
    assert "\n" not in str(err.value)
