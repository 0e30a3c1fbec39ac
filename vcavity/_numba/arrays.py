"""Array set-up for ``parallel=True`` functions without parallel loops of its own.

Under ``parallel=True`` Numba turns ``np.zeros``, ``np.full``, ``np.ones`` and whole-array
expressions (``a[:] = v``, ``a += b``) into parallel loops, each lowered as one more gufunc:
0.3-0.5 s of CPU apiece on a cold cache (docs/performance.md, "Compile time: literal kinds
first"), for set-up work that takes microseconds. :func:`filled` does the same with a plain
loop, compiled once per array type and cached.
"""

from __future__ import annotations

from vcavity._numba.jit import njit


@njit(cache=True)
def filled(array, value):
    """``array`` (C-contiguous, e.g. fresh from ``np.empty``) with every element set to ``value``.

    Parameters
    ----------
    array : ndarray
        C-contiguous, any shape; changed in place.
    value : scalar
        Converted to the array's dtype as an assignment converts it.

    Returns
    -------
    ndarray
        ``array`` itself, so that ``out = filled(np.empty(n), 0.0)`` reads as ``np.zeros(n)``.
    """
    flat = array.reshape(array.size)
    for j in range(flat.size):
        flat[j] = value
    return array


__all__ = ["filled"]
