"""The two slopes of Beckmann's visible-normal sampler (Heitz and d'Eon 2014; physics.md sec. 14).

At unit roughness, seen from a view with ``mu = cot theta'``, the slope ``x`` along the
view's azimuth has the CDF ``C(x) = (mu/2) erfc(-x) + exp(-x^2)/(2 sqrt(pi))`` up to
``C(mu) = mu (1 + Lambda)``, and the slope across it is an independent normal deviate of
variance 1/2. Both are inverted exactly (to rounding) and fast:

- the slope along, by Newton on ``log C`` (concave: from the left Newton never passes the
  root, from the right one step lands left of it) started from a bilinear table of the
  inverse (:func:`guess_table`, in the distribution's ``params``): two evaluations of ``C``
  in most cases, against eight from a bisection start;
- the slope across, by Wichura's rational approximations of the normal quantile (AS 241,
  Applied Statistics 37(3), 1988, 477-484; relative error about 1e-16), with no iteration.
"""

import functools
import math

import numpy as np

from vcavity._numba.jit import njit

_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_INV_SQRT2 = 1.0 / math.sqrt(2.0)

#: The guess table: ``TABLE_T + 1`` nodes of ``t = mu/(1 + |mu|)`` over [-1, 1] by
#: ``TABLE_U + 1`` nodes of ``u`` over [0, 1], of ``x - min(mu, 0)`` (bounded in both
#: directions of ``mu``: the normal quantile as ``mu -> inf``, 0 as ``mu -> -inf``).
TABLE_T = 64
TABLE_U = 64

# Wichura's AS 241 (PPND16): numerator and denominator coefficients, highest degree first,
# of the central region |q| <= 0.425 (variable r = 0.180625 - q^2), the tails with
# r = sqrt(-log p) <= 5 (variable r - 1.6) and beyond (variable r - 5).
_A = (2.5090809287301226727e+3, 3.3430575583588128105e+4, 6.7265770927008700853e+4, 4.5921953931549871457e+4,
      1.3731693765509461125e+4, 1.9715909503065514427e+3, 1.3314166789178437745e+2, 3.3871328727963666080e+0)
_B = (5.2264952788528545610e+3, 2.8729085735721942674e+4, 3.9307895800092710610e+4, 2.1213794301586595867e+4,
      5.3941960214247511077e+3, 6.8718700749205790830e+2, 4.2313330701600911252e+1, 1.0)
_C = (7.74545014278341407640e-4, 2.27238449892691845833e-2, 2.41780725177450611770e-1, 1.27045825245236838258e+0,
      3.64784832476320460504e+0, 5.76949722146069140550e+0, 4.63033784615654529590e+0, 1.42343711074968357734e+0)
_D = (1.05075007164441684324e-9, 5.47593808499534494600e-4, 1.51986665636164571966e-2, 1.48103976427480074590e-1,
      6.89767334985100004550e-1, 1.67638483018380384940e+0, 2.05319162663775882187e+0, 1.0)
_E = (2.01033439929228813265e-7, 2.71155556874348757815e-5, 1.24266094738807843860e-3, 2.65321895265761230930e-2,
      2.96560571828504891230e-1, 1.78482653991729133580e+0, 5.46378491116411436990e+0, 6.65790464350110377720e+0)
_F = (2.04426310338993978564e-15, 1.42151175831644588870e-7, 1.84631831751005468180e-5, 7.86869131145613259100e-4,
      1.48753612908506148525e-2, 1.36929880922735805310e-1, 5.99832206555887937690e-1, 1.0)


@njit(cache=True, inline="always")
def _horner(coefficients, r):
    value = 0.0
    for c in coefficients:
        value = value * r + c
    return value


@njit(cache=True)
def normal_quantile(u):
    """``t`` with ``(1 + erf t)/2 = u``: the slope of ``exp(-t^2)/sqrt(pi)`` at probability ``u``
    (AS 241's standard normal quantile divided by ``sqrt 2``); ``u`` in (0, 1), clamped to
    ``[1e-300, 1 - 2^-53]`` otherwise."""
    q = u - 0.5
    if abs(q) <= 0.425:
        r = 0.180625 - q * q
        return q * _horner(_A, r) / _horner(_B, r) * _INV_SQRT2
    p = u if q < 0.0 else 1.0 - u
    p = max(p, 1e-300)
    r = math.sqrt(-math.log(p))
    if r <= 5.0:
        r -= 1.6
        z = _horner(_C, r) / _horner(_D, r)
    else:
        r -= 5.0
        z = _horner(_E, r) / _horner(_F, r)
    return (-z if q < 0.0 else z) * _INV_SQRT2


@njit(cache=True, inline="always")
def visible_cdf(x, mu):
    """``C(x) = ∫_-inf^x (mu - t) exp(-t^2)/sqrt(pi) dt`` for ``x <= mu`` (physics.md sec. 14)."""
    return 0.5 * mu * math.erfc(-x) + 0.5 * _INV_SQRT_PI * math.exp(-x * x)


@njit(cache=True)
def solve_slope(u, mu, x):
    """The slope ``x <= mu`` with ``C(x) = u C(mu)``, by Newton's method from the guess ``x``.

    Far from the root (``C`` off the target by more than a factor 2) the step is Newton's on
    ``log C``, which is concave and increasing on ``(-inf, mu]`` (from the left of the root it
    stays left of it, from the right one step crosses it); near it, Newton's on ``C`` itself
    (no logarithm). The bracket ``[min(mu, 0) - 10, mu]`` holds the root for every
    ``u >= 2^-53`` (the density ``(mu - t) exp(-t^2)`` has lost 1e-16 of its mass 10 below
    ``min(mu, 0)``; smaller ``u`` give its end); a step outside it, or one from a point where
    ``C`` or its derivative underflows, is replaced by the bracket's midpoint. Newton
    converges quadratically, so a step below ``1e-9 (1 + |x|)`` leaves an error below
    rounding: the result after that step is returned.
    """
    wanted = max(u, 1e-300) * visible_cdf(mu, mu)
    lo = min(mu, 0.0) - 10.0
    hi = mu
    if not lo < x < hi:
        x = 0.5 * (lo + hi)
    for _ in range(200):
        gauss = _INV_SQRT_PI * math.exp(-x * x)
        c = 0.5 * (mu * math.erfc(-x) + gauss)
        density = (mu - x) * gauss
        if c > wanted:
            hi = x
        else:
            lo = x
        if c > 1e-300 and density > 1e-300 and wanted > 0.0:
            ratio = c / wanted
            if 0.5 < ratio < 2.0:
                step = (c - wanted) / density
            else:
                step = math.log(ratio) * c / density
            new = x - step
            if lo < new < hi:
                if abs(step) <= 1e-9 * (1.0 + abs(x)):
                    return new
                x = new
                continue
        if hi - lo <= 4e-16 * (1.0 + abs(x)):
            return 0.5 * (lo + hi)
        x = 0.5 * (lo + hi)
    return x


@njit(cache=True)
def guess(u, mu, table):
    """Bilinear interpolation of the guess table (:data:`TABLE_T` x :data:`TABLE_U`) at ``(mu, u)``."""
    t = (mu / (1.0 + abs(mu)) + 1.0) * (0.5 * TABLE_T)
    i = min(max(int(t), 0), TABLE_T - 1)
    wt = min(max(t - i, 0.0), 1.0)
    s = u * TABLE_U
    j = min(max(int(s), 0), TABLE_U - 1)
    wu = min(max(s - j, 0.0), 1.0)
    row = TABLE_U + 1
    k = i * row + j
    g0 = table[k] + wu * (table[k + 1] - table[k])
    g1 = table[k + row] + wu * (table[k + row + 1] - table[k + row])
    return g0 + wt * (g1 - g0) + min(mu, 0.0)


@functools.lru_cache(maxsize=1)
def guess_table() -> np.ndarray:
    """The inverse of ``C`` at the table's nodes (flattened, ``t`` major), minus ``min(mu, 0)``:
    computed once per process by :func:`solve_slope` from the bracket's midpoint (exact)."""
    table = np.empty((TABLE_T + 1) * (TABLE_U + 1))
    for i in range(TABLE_T + 1):
        t = min(max(-1.0 + 2.0 * i / TABLE_T, -1.0 + 1e-6), 1.0 - 1e-6)
        # below mu = -20 a view sees only slopes past -20, where C underflows: the walk
        # meets such facets with probability ~exp(-400); those nodes repeat mu = -20's
        mu = max(t / (1.0 - abs(t)), -20.0)
        for j in range(TABLE_U + 1):
            u = min(max(j / TABLE_U, 1e-12), 1.0 - 1e-12)
            table[i * (TABLE_U + 1) + j] = solve_slope(u, mu, math.inf) - min(mu, 0.0)
    table.setflags(write=False)
    return table
