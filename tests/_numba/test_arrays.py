"""vcavity/_numba/arrays.py: ``filled`` sets every element, whatever the shape and dtype,
in a plain jitted function and inside a ``parallel=True`` one (as the analytic models use it);
``borrowed`` is the same memory, without a reference count."""

import numba
import numpy as np
import pytest
from numba import prange, types
from numba.extending import intrinsic

from vcavity._numba.arrays import borrowed, filled
from vcavity._numba.jit import njit


@pytest.mark.parametrize("shape, dtype, value", [((7,), np.float64, 0.0), ((3, 4, 5), np.float64, -2.5),
                                                 ((2, 9), np.int64, -1), ((4, 6), np.bool_, True),
                                                 ((0,), np.float64, 1.0), ((1, 1), np.int64, 7)])
def test_every_element_is_set(shape, dtype, value):
    array = np.empty(shape, dtype)
    array.reshape(-1)[:] = np.arange(array.size) % 2 == 0 if dtype is np.bool_ else np.arange(array.size) + 11
    out = filled(array, value)
    assert out is array or np.shares_memory(out, array)
    assert out.shape == shape and out.dtype == dtype
    assert np.array_equal(array, np.full(shape, value, dtype))


@njit(cache=True, parallel=True)
def _row_sums(n_rows, n_cols):
    out = filled(np.empty((n_rows, n_cols)), 0.0)
    for r in prange(n_rows):
        for c in range(n_cols):
            if (r + c) % 3:
                out[r, c] += r + 0.5 * c
    return out


def test_inside_a_parallel_function():
    r, c = np.meshgrid(np.arange(13), np.arange(5), indexing="ij")
    expected = np.where((r + c) % 3 != 0, r + 0.5 * c, 0.0)
    assert np.array_equal(_row_sums(13, 5), expected)


@njit
def _through_view(array):
    view = borrowed(array)
    view[1, 1] = -7.0
    return view[0, 0] + view.sum(), view.shape, view.strides


def test_a_borrowed_view_is_the_same_memory():
    array = np.arange(12.0).reshape(3, 4)[:, ::2]  # not contiguous: strides carried over
    first, shape, strides = _through_view(array)
    assert array[1, 1] == -7.0
    assert first == array.sum() and shape == array.shape and strides == array.strides


@intrinsic
def _meminfo_address(typingctx, array):
    """The address of an array's reference-counted block (0: none), read from its struct."""
    def codegen(context, builder, signature, args):
        meminfo = context.make_array(array)(context, builder, value=args[0]).meminfo
        return builder.ptrtoint(meminfo, context.get_value_type(types.intp))

    return types.intp(array), codegen


@numba.njit
def _meminfo_addresses(array):
    return _meminfo_address(array), _meminfo_address(borrowed(array))


def test_a_borrowed_view_has_no_reference_count():
    """What makes a view free to pass: Numba's reference operations skip a null meminfo (the
    walks' calls apart would otherwise count references on every path, docs/performance.md,
    "Compile time: compiled apart")."""
    own, view = _meminfo_addresses(np.ones(5))
    assert own != 0
    assert view == 0
