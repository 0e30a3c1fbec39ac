"""Anisotropic Student-t distribution of slopes (STD) for microfacet normals.

Ribardiere, Bringier, Meneveaux, Simonot 2017, "STD: Student's t-Distribution of Slopes for
Microfacet Based BSDFs", Computer Graphics Forum (Eurographics 2017), doi:10.1111/cgf.13137.
The derivation of the formulas below is written up in physics.md sec. 10.

``params`` layout (float64, shape (13,)), with ``z = gamma - 1`` and
``R = Gamma(z + 1/2) / Gamma(z)``: ``[alpha_x, alpha_y, gamma, z, 1/z, log z, K, C, z', 1/z',
log z', K', C']``, where ``C = R / sqrt(pi z) = P2(0)`` and ``K = C z / (2 z - 1)``; the
primed constants are the same for ``z' = z + 1/2``, the shape of the cross slope's
conditional density (:func:`sample_visible`).

- Slopes: ``P22(s) = z^gamma / (pi ax ay (z + sx^2/ax^2 + sy^2/ay^2)^gamma)``, so
  ``D(m) = 1 / (pi ax ay cos^4 theta_m (1 + t2/z)^gamma)``, with
  ``t2 = tan^2 theta_m (cos^2 phi_m/ax^2 + sin^2 phi_m/ay^2)``. ``gamma = 2`` is GGX
  exactly; ``gamma -> inf`` is Beckmann with the same alpha (relative change
  ``(t2 - t2^2/2)/z`` to first order).
- Sampling of ``D(m)(m.n)`` by stretched slopes (H sec. 5) with the exact inverse CDF of the
  unit-roughness radial slope, ``r^2 = z expm1(-log(1 - u1)/z)``.
- Exact Smith ``Lambda(a)``, ``a = 1/(alpha_o tan theta_v)`` (H eq. 80), from the marginal
  slope density ``P2(q) = (R / sqrt(pi z)) (1 + q^2/z)^-(z + 1/2)``:
  ``Lambda = T1 - I_x(z, 1/2)/2``, ``T1 = K (1 + a^2/z)^(1/2 - z) / a``, ``x = z/(z + a^2)``.
  For ``a^2 < 1.5/(1 + 1/z)`` the incomplete beta is Lentz's continued fraction for
  ``I_{1-x}(1/2, z)`` (Numerical Recipes' betacf; little cancellation, ``T1 > Lambda``).
  Above, ``Lambda = T1 (1 + (2z - 1) G) / (2z)`` with ``G = 1 - 2F1(1, 1/2; z+1; -z/a^2)``
  from Gauss's continued fraction, whose partial numerators are all positive: no
  cancellation for any ``a`` (``T1 - I_x/2`` would lose up to a factor ``min(2a^2, 2z)``,
  and ``1 - x`` carries a relative rounding error ``eps z / a^2``). Constants come from
  ``log(R / sqrt z)`` by a Stirling series, so none cancel for large gamma.

Measured accuracy (tests/microfacet/test_student_t.py, scipy references written there):
Lambda relative error <= 1e-13 for a in [1e-6, 1e6] and gamma in [1.51, 1e6] (worst
9.4e-14); at most 176 continued-fraction iterations (Gauss's, just above the switch, for
gamma >= 1e3; betacf <= 11). At gamma = 2, D and pdf equal ggx's within 4e-15 relative,
Lambda within 2e-15, sample and sample_disk within 7e-16. int D (m.n) = 1 within 2e-14;
the V-cavity weak white furnace is 1 within 2e-11 (quadrature-limited). At gamma = 1e6 the
deviations of D, Lambda and r^2 from Beckmann match their 1/gamma terms to 0.1 %. No NaN or
exception for alpha in [1e-300, 1e300] and gamma in (1.5, 1e300]; samplers are always
finite; D and Lambda are inf only where the true value exceeds the float64 range.
"""

import math

import numpy as np

from vcavity.microfacet import student_t_tails as tails
from vcavity.microfacet.common import MAX_TAN_THETA, normal_sampler, stretched_slope, visible_normal
from vcavity.parameters import Number, Roughness
from vcavity._numba.jit import njit

NAME = "student_t"
DESCRIPTION = ("STD, Student-t slopes: D ~ 1/(1 + tan^2/((gamma-1) alpha^2))^gamma, GGX at gamma 2, "
               "Beckmann as gamma -> inf (Ribardiere et al. 2017)")
PARAMETERS = (
    Roughness(summary="STD roughness (slope scale; GGX alpha at gamma = 2)", example=0.5),
    # no upper bound: every finite gamma is handled (tends to Beckmann to double precision)
    Number("gamma", "tail shape: 2 is GGX, infinity is Beckmann", lo=1.5, lo_open=True, example=2.0),
)
SMITH = "exact"
#: Named parameter sets as a user writes them in ``[material]``: the conformance suite
#: (tests/microfacet/test_conformance.py) runs every generic check on each.
EXAMPLES = {
    "typical": {"alpha": 0.4, "gamma": 3.0},
    "anisotropic": {"alpha_x": 0.2, "alpha_y": 0.6, "gamma": 4.0},
    "heavy_tail": {"alpha": 0.3, "gamma": 1.8},
    "near_beckmann": {"alpha": 0.8, "gamma": 30.0},
    "extreme_anisotropic": {"alpha_x": 0.05, "alpha_y": 0.9, "gamma": 2.5},
}

_TWO_PI = 2.0 * math.pi
_LOG_PI = math.log(math.pi)
_ONE_MINUS_ULP = 1.0 - 2.0**-53  # largest float64 below 1
_S_MIN = 2.0**-53  # sample_disk: s below this maps like u1 = 1 - 2^-53, as sample clamps it


def _log_gamma_ratio_half(z):
    """``log(Gamma(z + 1/2) / (Gamma(z) sqrt(z)))`` for ``z > 0``, to ~2e-16 absolute.

    Upward recurrence ``R(z) = R(z + 1) z / (z + 1/2)`` to ``z >= 10``, then the Stirling
    series ``log R = log z / 2 - sum (2 - 2^-k) B_{k+1} / (k (k+1) z^k)`` (k odd, to 13),
    without its ``log z / 2``: neither two lgamma values (``eps z log z`` lost) nor
    ``log z`` terms (``eps log z``) cancel.
    """
    shift = 0.0
    z0 = z
    while z < 10.0:
        shift -= math.log1p(0.5 / z)
        z += 1.0
    if z != z0:
        shift += 0.5 * math.log(z / z0)
    w = 1.0 / (z * z)
    series = (-1.0 / 8.0 + w * (1.0 / 192.0 + w * (-1.0 / 640.0 + w * (17.0 / 14336.0 + w * (
        -31.0 / 18432.0 + w * (691.0 / 180224.0 + w * (-5461.0 / 425984.0))))))) / z
    return shift + series


def params_from(values):
    """Parameter array (layout in the module docstring) from the canonical values.

    Parameters
    ----------
    values : mapping
        ``alpha_x``, ``alpha_y`` (> 0) and ``gamma`` (> 1.5, finite), validated upstream.

    Returns
    -------
    ndarray, shape (13,)
    """
    gamma = float(values["gamma"])
    z = gamma - 1.0
    c = math.exp(_log_gamma_ratio_half(z) - 0.5 * _LOG_PI)
    # z/(2z - 1): 2 gamma - 3 is exact for gamma <= 2; 2 - 1/z does not cancel above
    k = c * z / (2.0 * gamma - 3.0) if gamma <= 3.0 else c / (2.0 - 1.0 / z)
    # the cross slope's shape z' = z + 1/2 = gamma - 1/2; 2 z' - 1 = 2 z
    zc = gamma - 0.5
    cc = math.exp(_log_gamma_ratio_half(zc) - 0.5 * _LOG_PI)
    kc = cc * zc / (2.0 * z)
    return np.array([values["alpha_x"], values["alpha_y"], gamma, z, 1.0 / z, math.log(z), k, c,
                     zc, 1.0 / zc, math.log(zc), kc, cc], dtype=np.float64)


def lobe_width(values):
    """Angular roughness scale for quadratures: the smaller alpha (radians of theta_m)."""
    return float(min(values["alpha_x"], values["alpha_y"]))


@njit(cache=True)
def sample(u1, u2, params):
    """Sample ``m`` with pdf ``D(m)(m.n)`` (H sec. 5, stretched slopes).

    Slope ``(s_x, s_y) = (alpha_x r cos phi', alpha_y r sin phi')`` with
    ``r^2 = z expm1(-log1p(-u1)/z)`` (the inverse of the radial CDF
    ``1 - (1 + r^2/z)^-z``), ``phi' = 2 pi u2``; ``m = normalize(-s_x, -s_y, 1)``.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring. Returns:
    Finite ``tan theta_m >= 0`` (at most ~7e15 max(alpha), as gamma -> 1.5, and at most
    ``common.MAX_TAN_THETA``) and a unit azimuth pair (``(1, 0)`` when the tangent is 0,
    e.g. for ``u1 <= 0`` or when ``r^2`` underflows).
    """
    if u1 >= 1.0:
        u1 = _ONE_MINUS_ULP
    if u1 <= 0.0:
        return 0.0, 1.0, 0.0
    # exponent <= 36.8/z < 74: r^2 < 1e32 for every gamma > 1.5
    r = math.sqrt(params[3] * math.expm1(-math.log1p(-u1) * params[4]))
    if r == 0.0:  # u1 below ~1e-308 (subnormal r^2): the normal itself
        return 0.0, 1.0, 0.0
    phi = _TWO_PI * u2
    return stretched_slope(r, math.cos(phi), math.sin(phi), params[0], params[1])


#: Unit normal ``(mx, my, mz)`` sampled with pdf ``D(m)(m.n)``: :func:`sample` as a normal.
sample_normal = normal_sampler(sample)


@njit(cache=True, inline="always")
def sample_disk(a, b, s, params):
    """:func:`sample` with ``u1 = 1 - s`` and azimuth ``(a, b)/sqrt(s)``: the kernel's trig-free map.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring. ``s``: ``a*a
    + b*b`` in (0, 1); below ``2^-53`` the radius is that of ``s = 2^-53`` (where
    :func:`sample` clamps ``u1``).
    """
    sr = s if s > _S_MIN else _S_MIN
    # r^2 = z expm1(-log(1 - u1)/z) = z expm1(-log(s)/z) (physics.md sec. 10)
    r = math.sqrt(params[3] * math.expm1(-math.log(sr) * params[4]))
    # the slope is (alpha_x a, alpha_y b) r / sqrt(s); stretched_slope stays finite for
    # alpha from 1e-300 to 1e300 (H sec. 5) as long as r / sqrt(s) < 1e150
    if s > 1e-270:
        if params[0] == params[1] and 1e-150 < params[0] < 1e150:
            # isotropic (physics.md sec. 2): |slope| = alpha r and phi_m is opposite to (a, b),
            # so no stretching (two divisions and a sqrt fewer); the test is the same for every
            # path of a run, so it is predicted and costs nothing
            inv = 1.0 / math.sqrt(s)
            return min(params[0] * r, MAX_TAN_THETA), -a * inv, -b * inv
        return stretched_slope(r / math.sqrt(s), a, b, params[0], params[1])
    # tiny disk points (s underflows below |(a, b)| ~ 1e-162): r / |(a, b)| may exceed 1e150
    t, c, sn = stretched_slope(r / math.hypot(a, b), a, b, params[0], params[1])
    return min(t, MAX_TAN_THETA), c, sn


@njit(cache=True)
def D(mx, my, mz, params):
    """Student-t distribution of normals (module docstring, physics.md sec. 10).

    ``exp(-gamma log1p(t2/z)) / (pi ax ay mz^4)`` with ``t2 = (mx^2/ax^2 + my^2/ay^2)/mz^2``
    when alpha is in [1e-50, 1e50] and ``mz > 1e-50``; otherwise the same in logarithms
    (no overflow, underflow or 0/0 for any alpha and grazing ``m``).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring. Returns:
    ``D(m)`` in 1/sr; 0 for ``mz <= 0``; ``inf`` only where ``D`` exceeds the float64 range
    (the peak for ``alpha_x alpha_y < ~1e-308``; gamma near 1.5 at ``mz < 1e-300``).
    """
    if mz <= 0.0:
        return 0.0
    ax = params[0]
    ay = params[1]
    gamma = params[2]
    if 1e-50 < ax < 1e50 and 1e-50 < ay < 1e50 and mz > 1e-50:
        u = mx / (ax * mz)  # |u| < 1e100: u*u cannot overflow
        w = my / (ay * mz)
        mz2 = mz * mz
        return math.exp(-gamma * math.log1p((u * u + w * w) * params[4])) / (math.pi * ax * ay * mz2 * mz2)
    log_norm = -_LOG_PI - math.log(ax) - math.log(ay) - 4.0 * math.log(mz)
    if mx == 0.0 and my == 0.0:
        return math.exp(log_norm)
    lu = math.log(abs(mx)) - math.log(ax) if mx != 0.0 else -math.inf
    lw = math.log(abs(my)) - math.log(ay) if my != 0.0 else -math.inf
    hi = max(lu, lw)
    # log(t2/z) = log(u^2 + w^2) - log z, u = |mx|/(ax mz), w = |my|/(ay mz)
    log_x = 2.0 * (hi - math.log(mz)) + math.log1p(math.exp(2.0 * (min(lu, lw) - hi))) - params[5]
    if log_x < 36.0:
        log1p_x = math.log1p(math.exp(log_x))
    else:  # log1p(x) = log x + log1p(1/x)
        log1p_x = log_x + math.exp(-log_x)
    return math.exp(log_norm - gamma * log1p_x)


@njit(cache=True)
def pdf(mx, my, mz, params):
    """Sampling pdf ``D(m)(m.n)`` of :func:`sample_normal` (W eq. 24).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring. Returns:
    Density per steradian.
    """
    return D(mx, my, mz, params) * mz


@njit(cache=True)
def smith_lambda_of_a(a, params):
    """Exact Smith ``Lambda(a) = (1/a) int_a^inf (q - a) P2(q) dq`` (module docstring).

    Parameters
    ----------
    a : float
        ``1 / (alpha_o tan theta_v) >= 0``.
    params : ndarray
        See the module docstring.

    Returns
    -------
    float
        ``Lambda >= 0`` (``inf`` for ``a = 0`` or once ``K/a`` overflows, 0 once it underflows).
    """
    return tails.lambda_of_a(a, params[3], params[4], params[5], params[6], params[7])


@njit(cache=True)
def smith_lambda(vx, vy, vz, params):
    """Exact Smith ``Lambda(v)`` for the anisotropic STD (:func:`smith_lambda_of_a`, H eq. 80).

    ``1/a = alpha_o tan theta_v = hypot(vx ax, vy ay) / vz`` (no overflow for alpha up to 1e300).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring. Returns:
    ``Lambda >= 0``; 0 for ``vz >= 1``, ``inf`` for ``vz <= 0`` (grazing limit; ``chi+`` is
    the caller's business below the horizon) and where it overflows.
    """
    if vz >= 1.0:
        return 0.0
    if vz <= 0.0:
        return math.inf
    t = math.hypot(vx * params[0], vy * params[1])
    if t == 0.0:
        return 0.0
    inv_a = t / vz
    if inv_a == math.inf:
        return math.inf
    return smith_lambda_of_a(1.0 / inv_a, params)


@njit(cache=True)
def sample_visible(vx, vy, vz, u1, u2, params):
    """Sample ``m`` with the visible-normal density ``D_v(m) = <v, m>+ D(m) / (v.n (1 + Lambda(v)))``
    (physics.md sec. 14; the construction of Heitz and d'Eon 2014 with the STD's marginals).

    In the stretched configuration (unit roughness, view ``v' = normalize(alpha_x vx,
    alpha_y vy, vz)``, ``mu = cot theta_v'``) the slope ``x`` along ``v'``'s azimuth has the
    density ``(mu - x)+ P2(x)`` up to a constant, sampled by inverting its CDF
    (:func:`vcavity.microfacet.student_t_tails.visible_slope`). Given ``x``, the slope
    across is ``y = sqrt(z + x^2) tau`` with ``tau`` of density proportional to
    ``(1 + tau^2)^-(z + 1)``: the marginal of shape ``z' = z + 1/2`` scaled by
    ``1/sqrt(z')`` (:func:`vcavity.microfacet.student_t_tails.lower_quantile`). The
    slopes are rotated to ``v'``'s azimuth and stretched back.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring. ``v`` may lie
    below the horizon (a ray travelling up in the Smith walk), not straight down. Returns: a
    unit normal with ``mz > 0`` (``mz`` may round to 0 for slopes beyond ~1e16).
    """
    ax = params[0]
    ay = params[1]
    z, inv_z, log_z, k, c = params[3], params[4], params[5], params[6], params[7]
    sx = ax * vx
    sy = ay * vy
    sin_v = math.sqrt(sx * sx + sy * sy)
    if sin_v == 0.0:  # seen from the normal: every normal is visible in proportion to D(m)(m.n)
        if u1 >= 1.0:
            u1 = _ONE_MINUS_ULP
        r = math.sqrt(z * math.expm1(-math.log1p(-u1) * inv_z))
        return visible_normal(1.0, 0.0, r * math.cos(_TWO_PI * u2), r * math.sin(_TWO_PI * u2), ax, ay)
    mu = vz / sin_v  # cot of the stretched view
    x = tails.visible_slope(u1, mu, z, inv_z, log_z, k, c)
    zc = params[8]
    a = tails.lower_quantile(min(u2, 1.0 - u2), zc, params[9], params[10], params[11], params[12])
    y = math.hypot(math.sqrt(z), x) * (a / math.sqrt(zc))
    if u2 < 0.5:
        y = -y
    return visible_normal(sx / sin_v, sy / sin_v, x, y, ax, ay)
