"""Anisotropic Beckmann distribution of microfacet normals.

``params`` layout (float64): ``[alpha_x, alpha_y]`` (Beckmann ``alpha = sqrt(2)
sigma_slope``, physics.md sec. 1-2).

- ``D(m) = exp(-tan^2 theta_m (cos^2 phi_m/alpha_x^2 + sin^2 phi_m/alpha_y^2))
  / (pi alpha_x alpha_y cos^4 theta_m)`` (H eq. 82, W eq. 25 when isotropic).
- Sampling of ``D(m)(m.n)`` by stretched slopes (H sec. 5, physics.md sec. 2).
- Smith ``Lambda`` exact with erf (H eq. 69) and projected roughness (H eq. 80);
  Walter's rational fit (W eq. 27) is :func:`smith_lambda_walter_fit`.
"""

import math

from vcavity.microfacet import beckmann_visible as visible
from vcavity.microfacet.common import (
    alpha_lobe_width,
    alpha_params_from,
    normal_sampler,
    ratio_squared,
    stretched_slope,
    visible_normal,
)
from vcavity.parameters import Roughness
from vcavity.rng.ziggurat import standard_normal
from vcavity._numba.jit import njit

NAME = "beckmann"
DESCRIPTION = "Gaussian slopes, exp(-tan^2 theta_m / alpha^2) (W eq. 25, H eq. 82)"
PARAMETERS = (Roughness(summary="Beckmann roughness, sqrt(2) x rms slope", example=0.6),)
SMITH = "exact"
#: Named parameter sets as a user writes them in ``[material]``: the conformance suite
#: (tests/microfacet/test_conformance.py) runs every generic check on each.
EXAMPLES = {
    "typical": {"alpha": 0.6},  # fig. 7(b) of the IL paper
    "anisotropic": {"alpha_x": 0.2, "alpha_y": 0.6},
    "smooth": {"alpha": 0.05},
    "rough": {"alpha": 1.0},
    "very_smooth": {"alpha_x": 1e-3, "alpha_y": 2e-3},
    "extreme_anisotropic": {"alpha_x": 0.05, "alpha_y": 0.9},
}

_TWO_PI = 2.0 * math.pi
_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_LOG_PI = math.log(math.pi)
_ONE_MINUS_ULP = 1.0 - 2.0**-53  # largest float64 below 1
_INV_SQRT2 = 1.0 / math.sqrt(2.0)  # a standard normal deviate over sqrt 2 has the density exp(-t^2)/sqrt(pi)


#: The smaller alpha as the lobe width.
lobe_width = alpha_lobe_width
#: Parameter array ``[alpha_x, alpha_y]`` from the canonical values.
params_from = alpha_params_from


@njit(cache=True)
def sample(u1, u2, params):
    """Sample ``m`` with pdf ``D(m)(m.n)`` (H sec. 5, W eq. 28-29 stretched).

    Slope ``(s_x, s_y) = (alpha_x r cos phi', alpha_y r sin phi')`` with
    ``r = sqrt(-log(1 - u1))``, ``phi' = 2 pi u2``; ``m = normalize(-s_x, -s_y, 1)``.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    Finite ``tan theta_m >= 0`` and a unit azimuth pair (``(1, 0)`` when the tangent is 0).
    """
    if u1 >= 1.0:
        u1 = _ONE_MINUS_ULP
    r = math.sqrt(-math.log1p(-u1))
    if r == 0.0:
        return 0.0, 1.0, 0.0
    phi = _TWO_PI * u2
    # |slope| / r = |(alpha_x cos, alpha_y sin)|; rescaled when alpha is extreme
    return stretched_slope(r, math.cos(phi), math.sin(phi), params[0], params[1])


#: Unit normal ``(mx, my, mz)`` sampled with pdf ``D(m)(m.n)``: :func:`sample` as a normal.
sample_normal = normal_sampler(sample)


@njit(cache=True, inline="always")
def sample_disk(a, b, s, params):
    """:func:`sample` with ``u1 = 1 - s`` and azimuth ``(a, b)/sqrt(s)``: the kernel's trig-free map.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``.
    """
    # r^2 = -log(1 - u1) = -log s (physics.md sec. 2)
    if params[0] == params[1] and 1e-150 < params[0] < 1e150:
        # isotropic (physics.md sec. 2): |slope| = alpha r and phi_m is opposite to (a, b),
        # so no stretching (two divisions and a sqrt fewer); the test is the same for every
        # path of a run, so it is predicted and costs nothing
        inv = 1.0 / math.sqrt(s)
        return params[0] * math.sqrt(-math.log(s)), -a * inv, -b * inv
    r_over_sqrt_s = math.sqrt(-math.log(s) / s)
    # the slope is (alpha_x a, alpha_y b) r / sqrt(s); stretched_slope stays finite for
    # alpha from 1e-300 to 1e300 (H sec. 5)
    return stretched_slope(r_over_sqrt_s, a, b, params[0], params[1])


@njit(cache=True)
def D(mx, my, mz, params):
    """Beckmann distribution of normals (H eq. 82, physics.md sec. 2).

    ``exp(-(u^2 + w^2)) / (pi ax ay mz^4)`` with ``u = mx/(ax mz)``, ``w = my/(ay mz)``
    (``u^2 + w^2 = tan^2 theta_m (cos^2 phi_m/ax^2 + sin^2 phi_m/ay^2)``). For alpha in
    [1e-50, 1e50] and ``mz > 1e-50`` no product under- or overflows; otherwise the same
    in logarithms, so no alpha in the accepted range (any float > 0) divides by zero.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    ``D(m)`` in 1/sr; 0 for ``mz <= 0``; ``inf`` only where ``D`` exceeds the float64 range
    (the peak for ``alpha_x alpha_y < ~1e-308``).
    """
    if mz <= 0.0:
        return 0.0
    ax = params[0]
    ay = params[1]
    if 1e-50 < ax < 1e50 and 1e-50 < ay < 1e50 and mz > 1e-50:
        u = mx / (ax * mz)  # |u| < 1e100: u*u cannot overflow
        w = my / (ay * mz)
        mz2 = mz * mz
        return math.exp(-(u * u + w * w)) / (math.pi * ax * ay * mz2 * mz2)  # denominator > 1e-300
    return math.exp(_log_norm(ax, ay, mz) - _stretched_tan2(mx, my, mz, ax, ay))


@njit(cache=True, inline="always")
def _log_norm(ax, ay, mz):
    """``log(1 / (pi ax ay mz^4))`` for any positive floats."""
    return -_LOG_PI - math.log(ax) - math.log(ay) - 4.0 * math.log(mz)


@njit(cache=True, inline="always")
def _stretched_tan2(mx, my, mz, ax, ay):
    """``(mx/(ax mz))^2 + (my/(ay mz))^2`` for any positive ``ax, ay, mz`` (``inf`` on overflow)."""
    return ratio_squared(mx, ax, mz) + ratio_squared(my, ay, mz)


@njit(cache=True)
def pdf(mx, my, mz, params):
    """Sampling pdf ``D(m)(m.n)`` of :func:`sample_normal` (W eq. 24).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    Density per steradian.
    """
    return D(mx, my, mz, params) * mz


@njit(cache=True)
def smith_lambda_of_a(a):
    """Beckmann Smith ``Lambda(a) = (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi))`` (H eq. 69).

    Evaluated as ``(exp(-a^2)/(a sqrt(pi)) - erfc(a))/2``.

    Parameters
    ----------
    a : float
        ``1 / (alpha_o tan theta_v) > 0``.

    Returns
    -------
    float
        ``Lambda >= 0`` (``inf`` for ``a = 0``, 0 once it underflows).
    """
    if a <= 0.0:
        return math.inf
    return 0.5 * (math.exp(-a * a) * _INV_SQRT_PI / a - math.erfc(a))


@njit(cache=True)
def _a_of_direction(vx, vy, vz, ax, ay):
    """``a = 1/(alpha_o tan theta_v)`` with projected roughness (H eq. 80); -1 if v is normal."""
    den2 = vx * vx * ax * ax + vy * vy * ay * ay  # alpha_o^2 tan^2 theta_v vz^2
    if den2 <= 0.0:
        return -1.0
    return vz / math.sqrt(den2)


@njit(cache=True)
def smith_lambda(vx, vy, vz, params):
    """Exact Smith ``Lambda(v)`` for anisotropic Beckmann (H eq. 69 with eq. 80).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    ``Lambda >= 0``; 0 for ``v = n`` (``vz >= 1``), ``inf`` for ``vz <= 0`` (grazing limit;
    ``chi+`` is the caller's business below the horizon).
    """
    if vz >= 1.0:
        return 0.0
    if vz <= 0.0:
        return math.inf
    a = _a_of_direction(vx, vy, vz, params[0], params[1])
    if a < 0.0:
        return 0.0
    return smith_lambda_of_a(a)


@njit(cache=True)
def smith_lambda_bound(vx, vy, vz, params):
    """An upper bound of :func:`smith_lambda` without ``erfc``: the Smith walk's escape test.

    From Abramowitz and Stegun 7.1.13, ``erfc(a) > (2/sqrt(pi)) exp(-a^2)/(a + sqrt(a^2 + 2))``,
    so ``Lambda(a) < exp(-a^2) / (sqrt(pi) a (a + sqrt(a^2 + 2))^2)`` (H eq. 69), within a
    factor ``1 + 1/(2 a^2)`` of it for large ``a`` and about 1.5 at ``a = 1``. A ray whose
    escape is decided by the bound needs no exact ``Lambda``.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    ``>= smith_lambda(v)``; the same edge conventions.
    """
    if vz >= 1.0:
        return 0.0
    if vz <= 0.0:
        return math.inf
    a = _a_of_direction(vx, vy, vz, params[0], params[1])
    if a < 0.0:
        return 0.0
    if a <= 0.0:
        return math.inf
    b = a + math.sqrt(a * a + 2.0)
    return math.exp(-a * a) * _INV_SQRT_PI / (a * b * b)


@njit(cache=True)
def smith_lambda_walter_fit(vx, vy, vz, params):
    """Walter's rational fit of the Beckmann Smith ``Lambda`` (W eq. 27).

    ``G1 = (3.535 a + 2.181 a^2)/(1 + 2.276 a + 2.577 a^2)`` for ``a < 1.6``,
    else 1, i.e. ``Lambda = (1 - 1.259 a + 0.396 a^2)/(3.535 a + 2.181 a^2)``
    (as in H appendix C); G1 within 0.35 % of the exact value.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    Approximate ``Lambda``; same edge conventions as :func:`smith_lambda`.
    """
    if vz >= 1.0:
        return 0.0
    if vz <= 0.0:
        return math.inf
    a = _a_of_direction(vx, vy, vz, params[0], params[1])
    if a < 0.0 or a >= 1.6:
        return 0.0
    return (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)


@njit(cache=True)
def sample_visible(vx, vy, vz, u1, u2, params):
    """Sample ``m`` with the visible-normal density ``D_v(m) = <v, m>+ D(m) / (v.n (1 + Lambda(v)))``
    (Heitz and d'Eon 2014, physics.md sec. 14).

    In the stretched configuration (unit roughness, view ``v' = normalize(alpha_x vx,
    alpha_y vy, vz)``) the slope along ``v'``'s azimuth has the density ``(mu - x)+
    exp(-x^2)/sqrt(pi)`` up to a constant, ``mu = cot theta_v'``, sampled by inverting its
    CDF (:mod:`vcavity.microfacet.beckmann_visible`); the slope across it is independent, ``exp(-y^2)/sqrt(pi)``
    (:func:`vcavity.microfacet.beckmann_visible.normal_quantile`). The slopes are rotated to ``v'``'s azimuth and stretched back.
    The root is found from the solver's bracket (about eight evaluations of ``C``); the
    Smith walk uses the faster :func:`sample_visible_stream`.

    Parameters
    ----------
    vx, vy, vz : float
        Unit direction seen from: toward the light or the viewer (``vz > 0``), or, in the
        Smith walk, against a ray travelling up (``vz < 0``: only facets facing down the
        ray are visible). Not straight down (``v = (0, 0, -1)`` sees no facet).
    u1, u2 : float
        Uniforms in ``[0, 1)``.
    params : ndarray
        ``[alpha_x, alpha_y]``.

    Returns
    -------
    mx, my, mz : float
        Unit normal, ``mz > 0``.
    """
    ax = params[0]
    ay = params[1]
    sx = ax * vx
    sy = ay * vy
    sin_v = math.sqrt(sx * sx + sy * sy)
    if sin_v == 0.0:  # seen from the normal: every normal is visible in proportion to D(m)(m.n)
        r = math.sqrt(-math.log1p(-min(u1, _ONE_MINUS_ULP)))
        return visible_normal(1.0, 0.0, r * math.cos(_TWO_PI * u2), r * math.sin(_TWO_PI * u2), ax, ay)
    mu = vz / sin_v  # cot of the stretched view
    x = visible.solve_slope(u1, mu, math.inf)
    y = visible.normal_quantile(u2)
    return visible_normal(sx / sin_v, sy / sin_v, x, y, ax, ay)


@njit(cache=True)
def sample_visible_stream(state, vx, vy, vz, lam, params):
    """:func:`sample_visible`'s density, drawn from the random stream: the Smith walk's sampler
    (physics.md sec. 14).

    The slope along the stretched view's azimuth comes from the exact mixture-rejection
    scheme of :func:`vcavity.microfacet.beckmann_visible.sample_slope_along`, whose mixture
    weights need ``C(mu) = mu (1 + Lambda(v))``: the walk has just computed ``Lambda(v)``
    for its height step, so it is passed in and no ``erfc`` is evaluated here. The slope
    across is a normal deviate from the ziggurat (:mod:`vcavity.rng.ziggurat`).

    Parameters
    ----------
    state : uint64
        Random stream state (:mod:`vcavity.rng`).
    vx, vy, vz : float
        Unit direction seen from, as for :func:`sample_visible`.
    lam : float
        ``Lambda(v)`` (:func:`smith_lambda`) when ``vz > 0``; unused otherwise.
    params : ndarray
        ``[alpha_x, alpha_y, ...]``.

    Returns
    -------
    state, mx, my, mz
        The advanced state and a unit normal, ``mz > 0``.
    """
    ax = params[0]
    ay = params[1]
    sx = ax * vx
    sy = ay * vy
    sin_v = math.sqrt(sx * sx + sy * sy)
    if sin_v == 0.0:  # seen from the normal: every normal visible in proportion to D(m)(m.n)
        cos_v, sin_v = 1.0, 0.0
        state, x = standard_normal(state)
        x *= _INV_SQRT2
    else:
        inv = 1.0 / sin_v
        mu = vz * inv  # cot of the stretched view
        cos_v, sin_v = sx * inv, sy * inv
        state, x = visible.sample_slope_along(state, mu, mu * (1.0 + lam))
    state, y = standard_normal(state)
    y *= _INV_SQRT2
    mx = -ax * (cos_v * x - sin_v * y)
    my = -ay * (sin_v * x + cos_v * y)
    if abs(mx) < 1e150 and abs(my) < 1e150:
        # visible_normal's normalisation with one division (|x|, |y| < 40: the squares
        # cannot overflow unless alpha is extreme, which takes the general path)
        inv = 1.0 / math.sqrt(mx * mx + my * my + 1.0)
        return state, mx * inv, my * inv, inv
    mx, my, mz = visible_normal(cos_v, sin_v, x, y, ax, ay)
    return state, mx, my, mz
