"""Linear interpolation of a scalar in jitted code, without Numba's ``np.interp``.

Numba's ``np.interp`` compiles a general implementation (array or scalar ``x``, slopes
precomputed or not, a guessed binary search), a sizeable part of the analytic models' cold
compile (docs/performance.md, "Figures from the code's comments"); the models interpolate one
scalar at a time in small increasing tables. :func:`interp` is that case alone, with NumPy's
arithmetic (``numpy/core/src/multiarray/compiled_base.c``, ``arr_interp``), so it returns
what ``np.interp`` returns, bit for bit.
"""

from __future__ import annotations

import math

from vcavity._numba.jit import njit


@njit(cache=True)
def interp(x, xp, fp):
    """``np.interp(x, xp, fp)`` for a float ``x`` and a strictly increasing ``xp``.

    Parameters
    ----------
    x : float
        Where to interpolate; NaN gives NaN (but ``fp[0]`` for a one-node table, as NumPy).
    xp : ndarray of float64
        Strictly increasing abscissae, at least one.
    fp : ndarray of float64
        Values at ``xp`` (same length).

    Returns
    -------
    float
        ``fp[0]`` left of ``xp[0]``, ``fp[-1]`` right of ``xp[-1]``, ``fp[j]`` at a node, else
        ``slope (x - xp[j]) + fp[j]`` on the interval ``[xp[j], xp[j + 1])``; where that is
        NaN (infinite values), NumPy's fallbacks.
    """
    n = xp.shape[0]
    if n == 1:  # NumPy's: the one value everywhere, NaN included
        return fp[0]
    if math.isnan(x):
        return x
    if x > xp[n - 1]:
        return fp[n - 1]
    if x < xp[0]:
        return fp[0]
    lo = 0  # xp[lo] <= x < xp[hi]
    hi = n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xp[mid] <= x:
            lo = mid
        else:
            hi = mid
    if lo == n - 1 or xp[lo] == x:
        return fp[lo]
    slope = (fp[lo + 1] - fp[lo]) / (xp[lo + 1] - xp[lo])
    value = slope * (x - xp[lo]) + fp[lo]
    if math.isnan(value):  # NumPy: try from the other end, then a flat interval's value
        value = slope * (x - xp[lo + 1]) + fp[lo + 1]
        if math.isnan(value) and fp[lo] == fp[lo + 1]:
            value = fp[lo]
    return value


__all__ = ["interp"]
