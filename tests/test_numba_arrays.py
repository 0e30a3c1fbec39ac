"""vcavity/_numba/arrays.py: ``filled`` sets every element, whatever the shape and dtype,
in a plain jitted function and inside a ``parallel=True`` one (as the analytic models use it)."""

import numpy as np
import pytest
from numba import prange

from vcavity._numba.arrays import filled
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
