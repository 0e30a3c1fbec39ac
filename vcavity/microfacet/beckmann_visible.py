"""The two slopes of Beckmann's visible-normal sampler (Heitz and d'Eon 2014; physics.md sec. 14).

At unit roughness, seen from a view with ``mu = cot theta'``, the slope ``x`` along the
view's azimuth has the CDF ``C(x) = (mu/2) erfc(-x) + exp(-x^2)/(2 sqrt(pi))`` up to
``C(mu) = mu (1 + Lambda)``, and the slope across it is an independent normal deviate of
variance 1/2. Both are inverted exactly (to rounding) and fast:

- the slope along, by Newton on ``log C`` (concave: from the left Newton never passes the
  root, from the right one step lands left of it) from the middle of a bracket, about eight
  evaluations of ``C``;
- the slope across, by Wichura's rational approximations of the normal quantile (AS 241,
  Applied Statistics 37(3), 1988, 477-484; relative error about 1e-16), with no iteration.

The Smith walk draws the slope along from its random stream instead
(:func:`sample_slope_along`): an exact mixture of three pieces of the density, one of them
by rejection, with no ``erfc`` and no iteration to a root (physics.md sec. 14): 20-35 ns
a slope against ~260 ns for the inversion even from a table of guesses (docs/performance.md).
"""

import math

from vcavity._numba.jit import njit
from vcavity.rng import next_uniform
from vcavity.rng.ziggurat import standard_exponential, standard_normal

_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_HALF_INV_SQRT_PI = 0.5 / math.sqrt(math.pi)
#: Below this ``mu`` the piece on ``(0, mu]`` is proposed from the triangle ``mu - x``, above
#: it from the half-normal: their acceptance rates are the piece's mass over ``mu^2/2`` and
#: over ``mu sqrt(pi)/2``, equal at ``mu = sqrt(pi)`` (0.68 there, rising to 1 either side).
MU_TRIANGLE = math.sqrt(math.pi)
#: Above this ``mu`` the view is the normal's to rounding (the density's factor ``mu - x``
#: is ``mu (1 - x/mu)``, ``|x| < 40``): the slope is a normal deviate, and no infinite ``mu``
#: reaches a rejection loop.
MU_NORMAL_VIEW = 1e150
_INV_SQRT2 = 1.0 / math.sqrt(2.0)

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
def sample_slope_along(state, mu, total):
    """The slope ``x <= mu`` with density ``(mu - x) exp(-x^2)/sqrt(pi) / total`` from the
    random stream ``state`` (physics.md sec. 14): the exact alternative to :func:`solve_slope`.

    For ``mu > 0`` the density is the mixture of ``mu exp(-x^2)`` on ``x <= 0`` (mass
    ``mu/2``; a half-normal), ``-x exp(-x^2)`` on ``x <= 0`` (mass ``1/(2 sqrt(pi))``;
    ``x = -sqrt(E)``, ``E`` exponential) and ``(mu - x) exp(-x^2)`` on ``(0, mu]`` (the
    rest), the last by rejection: proposed from the triangle ``mu - x`` (``x = mu (1 - sqrt u)``)
    and accepted with ``exp(-x^2)`` when ``mu <= MU_TRIANGLE``, else proposed half-normal and
    accepted with ``(mu - x)/mu``. For ``mu <= 0``, ``x = mu - s`` with ``s >= 0`` of density
    ``s exp(-(m + s)^2)``, ``m = -mu``: proposed ``Gamma(2, rate l)`` (the sum of two
    exponentials over ``l``), accepted with ``exp(-(s - s*)^2)``, ``s* = l/2 - m``, which
    bounds the ratio of the two; the rate ``l = m + sqrt(m^2 + 4)`` maximises the acceptance
    (0.74 at ``m = 0``, rising to 1). Normal and exponential deviates come from the ziggurat
    (:mod:`vcavity.rng.ziggurat`), and an acceptance with probability ``exp(-t)`` is an
    exponential deviate above ``t``: no ``log``, ``exp`` or normal quantile on the common paths.

    The rejection loops have no try counter: with one, LLVM compiles them about ten times
    slower (measured, docs/performance.md). They end with probability 1 (acceptance >= 0.68)
    and on a NaN ``mu`` (a NaN slope, which the walk counts degenerate).

    Parameters
    ----------
    state : uint64
        Random stream state (:mod:`vcavity.rng`).
    mu : float
        ``cot`` of the stretched view (``mu > 0`` above the horizon).
    total : float
        ``C(mu) = mu (1 + Lambda(mu))`` for ``mu > 0`` (Beckmann's Lambda, H eq. 69, as the
        walk has it); unused for ``mu <= 0``. Recomputed (:func:`visible_cdf`) when not finite.

    Returns
    -------
    state, x
        The advanced state and the slope.
    """
    if mu > 0.0:
        state, u = next_uniform(state)
        if mu > MU_NORMAL_VIEW:
            return state, normal_quantile(u)
        if not total < math.inf:
            total = visible_cdf(mu, mu)
        pick = u * total
        half = 0.5 * mu
        if pick < half:
            state, x = standard_normal(state)
            return state, -abs(x) * _INV_SQRT2
        if pick < half + _HALF_INV_SQRT_PI:
            state, e = standard_exponential(state)
            return state, -math.sqrt(e)
        if mu <= MU_TRIANGLE:
            while True:
                state, u = next_uniform(state)
                state, e = standard_exponential(state)
                x = mu * (1.0 - math.sqrt(u))
                if e > x * x:  # probability exp(-x^2), without the exp
                    return state, x
        while True:
            state, x = standard_normal(state)
            x = abs(x) * _INV_SQRT2
            state, w = next_uniform(state)
            if x < mu and w * mu < mu - x:
                return state, x
    m = -mu
    root = math.sqrt(m * m + 4.0) if m < 1e150 else m
    peak = 2.0 / (root + m)  # s* = l/2 - m, written without cancellation
    rate = 2.0 * (m + peak)
    while True:
        state, e1 = standard_exponential(state)
        state, e2 = standard_exponential(state)
        state, e = standard_exponential(state)
        s = (e1 + e2) / rate
        d = s - peak
        if e > d * d or not d == d:  # kept with probability exp(-d^2)
            return state, mu - s
