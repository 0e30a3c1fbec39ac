"""Arrays in jitted code: set-up without parallel loops, and views without reference counts.

:func:`filled`: under ``parallel=True`` Numba turns ``np.zeros``, ``np.full``, ``np.ones`` and whole-array
expressions (``a[:] = v``, ``a += b``) into parallel loops, each lowered as one more gufunc
(its cold compile: docs/performance.md, "Figures from the code's comments"), for set-up work
that takes microseconds. :func:`filled` does the same with a plain
loop, compiled once per array type and cached.

:func:`borrowed`: a function compiled apart (:func:`vcavity._numba.dispatch.apart` and the
registries' dispatch) takes a reference to each array argument on entry and drops it on
return, two atomic operations on the array's counter (``NRT_incref``/``NRT_decref``) that
LLVM keeps after inlining the function (docs/performance.md, "Compile time: compiled
apart"). The walks hand such functions views of their arrays that have no counter: every
reference operation on them is then a test of a null pointer that LLVM folds away.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

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


@intrinsic
def borrowed(typingctx, array):
    """A view of ``array`` (same data, shape and strides) without a reference count.

    Jitted code only. The view's meminfo and parent are null, so Numba's reference
    operations on it do nothing; it must not outlive ``array``: use it within the function
    that holds ``array``, never return or store it.

    Parameters
    ----------
    array : ndarray
        Any array type.

    Returns
    -------
    ndarray
        Of ``array``'s type.
    """
    if not isinstance(array, types.Array):
        return None

    def codegen(context, builder, signature, args):
        source = context.make_array(array)(context, builder, value=args[0])
        view = context.make_array(array)(context, builder)
        for field in ("nitems", "itemsize", "data", "shape", "strides"):
            setattr(view, field, getattr(source, field))
        view.meminfo = cgutils.get_null_value(view.meminfo.type)
        view.parent = cgutils.get_null_value(view.parent.type)
        return view._getvalue()

    return array(array), codegen


__all__ = ["borrowed", "filled"]
