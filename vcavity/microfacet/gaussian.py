"""Oren-Nayar Gaussian distribution in theta_m (IL eq. 13, physics.md sec. 2).

``D(m) = C exp(-theta_m^2/(2 sigma^2)) / cos theta_m`` with
``1/C = 2 pi int_0^{pi/2} exp(-theta^2/(2 sigma^2)) sin theta dtheta``, so the
sampling pdf is ``D(m)(m.n) = C exp(-theta_m^2/(2 sigma^2))`` and the theta
marginal is ``p(theta) = 2 pi C exp(-theta^2/(2 sigma^2)) sin theta`` on
``[0, pi/2]``.  ``sigma`` (radians) is meant for about ``1e-3 .. 2``; every
``sigma > 0`` samples correctly (below 1e-100 the table is the exact Rayleigh limit
``theta = sigma w``).

``params`` layout (float64, built by :func:`params_from`, shape (5 + 2 (n+1),))::

    [sigma, C, n, h, w_max, theta_0 .. theta_n, dtheta_0 .. dtheta_n]

The inverse CDF has no closed form; it is tabulated as ``theta(w)`` with
``w = sqrt(-2 log(1 - u))`` on the uniform grid ``w_j = j h``, ``h = w_max/n``,
together with ``dtheta/dw``, and evaluated by cubic Hermite interpolation.
``w`` removes both end behaviours: ``theta ~ sqrt(u)`` near ``u = 0`` and the
Rayleigh-like tail ``theta ~ sigma sqrt(-2 log(1-u))`` near ``u = 1`` (for
small sigma ``theta = sigma w`` almost exactly), so ``theta(w)`` is smooth.
``w_max`` covers every float64 ``u1 < 1`` (``1 - u1 >= 2^-53``).  The table
nodes are exact roots (safeguarded Newton on composite 20-point Gauss-Legendre
CDF/tail integrals); the interpolation error measured about 1e-11 rad (tested < 1e-7 against
a scipy root-find reference in tests/microfacet/test_distributions.py).

Smith ``Lambda``: this distribution has infinite microsurface area
(``D ~ 1/cos theta_m`` at the horizon), so ``int D max(0, v.m) dw`` and
hence the Smith ``Lambda`` (H eq. 38-43) diverge logarithmically for every
``v != n``: :func:`smith_lambda` returns ``inf`` there (``G1_S = 0``) and
``SMITH = "infinite"``.  Use it with V-cavity masking (IL eq. 14), which
is well defined, as IL and Oren-Nayar do.
"""

import math

import numpy as np

from vcavity.microfacet.common import normal_sampler
from vcavity.parameters import Number
from vcavity._numba.jit import njit

NAME = "gaussian"
DESCRIPTION = "Oren-Nayar's Gaussian in theta_m, exp(-theta_m^2/(2 sigma^2))/cos theta_m (IL eq. 13)"
# Upper bound: beyond 1e6 rad the truncated Gaussian is uniform in theta_m to 1e-12, and
# the tabulated inverse CDF loses accuracy above ~1e10 (measured: the specular albedo of its
# samples drifts 4 % from the closed-form D by 1e20; docs/stability.md)
PARAMETERS = (Number("sigma", "standard deviation of theta_m", lo=0.0, lo_open=True, hi=1e6, units="rad",
                     example=0.3, reason="beyond 1e6 rad the Gaussian is uniform in theta_m to 1e-12 "
                     "and its sampling table loses accuracy"),)
SMITH = "infinite"  # D ~ 1/cos theta_m at the horizon: the Smith Lambda diverges
#: Named parameter sets as a user writes them in ``[material]``: the conformance suite
#: (tests/microfacet/test_conformance.py) runs every generic check on each (isotropic only).
EXAMPLES = {
    "typical": {"sigma": 0.35},  # Oren-Nayar's rough plaster range
    "smooth": {"sigma": 0.1},
    "rough": {"sigma": 1.0},
    "very_smooth": {"sigma": 1e-3},
    "very_rough": {"sigma": 2.0},
}

N_TABLE = 1024
W_MAX = math.sqrt(-2.0 * math.log(2.0**-54))  # > w(u1) for every float64 u1 < 1
_HALF_PI = 0.5 * math.pi
_TWO_PI = 2.0 * math.pi
_ONE_MINUS_ULP = 1.0 - 2.0**-53
_GL_X, _GL_W = np.polynomial.legendre.leggauss(20)
_HEADER = 5
# Below this sigma the table is the exact small-angle (Rayleigh) limit.
_RAYLEIGH_MAX_SIGMA = 1e-100


def _density(theta, sigma):
    """Unnormalised theta marginal ``exp(-theta^2/(2 sigma^2)) sin theta`` (IL eq. 13)."""
    return np.exp(-0.5 * (theta / sigma) ** 2) * np.sin(theta)


def _gl_integral(a, b, sigma):
    """Integral of :func:`_density` over ``[a, b]`` (arrays), 20-point Gauss-Legendre."""
    a = np.asarray(a, dtype=np.float64)[..., None]
    b = np.asarray(b, dtype=np.float64)[..., None]
    half = 0.5 * (b - a)
    return np.sum(_GL_W * _density(a + half * (_GL_X + 1.0), sigma), axis=-1) * half[..., 0]


def _build_table(sigma, n_table):
    """Return ``C`` and the tabulated ``theta(w)``, ``dtheta/dw`` (see module docstring)."""
    if sigma < _RAYLEIGH_MAX_SIGMA:
        # sin(theta) = theta to 1e-200 relative: the theta marginal is Rayleigh,
        # theta = sigma w exactly. (The quadrature below would underflow: the density
        # scales like sigma^2, which is 0 in float64 for sigma < 1.5e-154.)
        w_nodes = np.linspace(0.0, W_MAX, n_table + 1)
        with np.errstate(over="ignore", divide="ignore"):
            c_norm = float(np.float64(1.0) / (_TWO_PI * np.float64(sigma) * sigma))  # inf if sigma^2 underflows
        return c_norm, sigma * w_nodes, np.full(n_table + 1, sigma)
    theta_top = min(_HALF_PI, 12.0 * sigma)  # beyond: tail < exp(-72) of the total
    n_panels = 256
    edges = np.linspace(0.0, theta_top, n_panels + 1)
    panel = _gl_integral(edges[:-1], edges[1:], sigma)
    beyond = float(_gl_integral(theta_top, _HALF_PI, sigma)) if theta_top < _HALF_PI else 0.0
    total = panel.sum() + beyond
    cdf_edges = np.concatenate(([0.0], np.cumsum(panel))) / total
    tail_edges = (np.concatenate((np.cumsum(panel[::-1])[::-1], [0.0])) + beyond) / total

    def w_of_theta(theta):
        """w = sqrt(-2 log Q(theta)) with Q the tail probability, accurate at both ends."""
        k = np.clip(np.searchsorted(edges, theta, side="right") - 1, 0, n_panels - 1)
        cdf = cdf_edges[k] + _gl_integral(edges[k], theta, sigma) / total
        tail = tail_edges[k + 1] + _gl_integral(theta, edges[k + 1], sigma) / total
        with np.errstate(divide="ignore", invalid="ignore"):  # np.where evaluates both
            minus_log_tail = np.where(cdf < 0.5, -np.log1p(-cdf), -np.log(tail))
        return np.sqrt(2.0 * minus_log_tail), tail

    w_nodes = np.linspace(0.0, W_MAX, n_table + 1)
    lo = np.zeros_like(w_nodes)
    hi = np.full_like(w_nodes, theta_top)
    theta = np.clip(sigma * w_nodes, 0.0, 0.5 * theta_top)
    for _ in range(100):  # safeguarded Newton on w(theta) - w_j; converges in ~6 steps
        w, tail = w_of_theta(theta)
        resid = w - w_nodes
        lo = np.where(resid <= 0.0, theta, lo)
        hi = np.where(resid > 0.0, theta, hi)
        dens = _density(theta, sigma) / total
        with np.errstate(divide="ignore", invalid="ignore"):
            step = resid * tail * w / dens  # dtheta/dw = Q w / p
        new = theta - step
        bad = ~np.isfinite(new) | (new <= lo) | (new >= hi)
        new = np.where(bad, 0.5 * (lo + hi), new)
        done = np.all(np.abs(new - theta) <= 1e-14 * np.maximum(theta, sigma))
        theta = new
        if done:  # one more step after the last big one: at round-off level
            break
    theta[0] = 0.0
    theta = np.minimum(theta, _HALF_PI)
    w, tail = w_of_theta(theta)
    dens = _density(theta, sigma) / total
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where((dens > 0.0) & (tail > 0.0), tail * w / dens, 0.0)  # 0 at pi/2
    slope[0] = math.sqrt(total)  # w ~ theta/sqrt(total) for small theta
    c_norm = 1.0 / (_TWO_PI * total)
    return c_norm, theta, slope


def params_from(values, n_table=N_TABLE):
    """Build the parameter array with the tabulated inverse CDF (plain Python).

    Parameters
    ----------
    values : mapping
        ``sigma``: width of the Gaussian in ``theta_m``, radians (> 0; about 1e-3 .. 2).
    n_table : int, optional
        Number of table intervals in ``w``.

    Returns
    -------
    ndarray
        ``[sigma, C, n, h, w_max, theta_0..theta_n, dtheta_0..dtheta_n]``.
    """
    sigma = float(values["sigma"])
    c_norm, theta, slope = _build_table(sigma, int(n_table))
    header = [sigma, c_norm, float(n_table), W_MAX / n_table, W_MAX]
    return np.concatenate((header, theta, slope)).astype(np.float64)


def lobe_width(values):
    """Angular roughness scale: sigma (radians of theta_m)."""
    return float(values["sigma"])


@njit(cache=True)
def inverse_cdf_theta(u1, params):
    """``theta_m`` with ``P(theta <= theta_m) = u1`` from the table (cubic Hermite in w).

    Parameters
    ----------
    u1 : float
        Uniform in ``[0, 1)`` (``u1 >= 1`` is clamped to the largest float below 1).
    params : ndarray
        Output of :func:`params_from`.

    Returns
    -------
    float
        ``theta_m`` in ``[0, pi/2]`` (never above the float64 ``pi/2``).
    """
    if u1 >= 1.0:
        u1 = _ONE_MINUS_ULP
    n = int(params[2])
    h = params[3]
    w = math.sqrt(-2.0 * math.log1p(-u1))
    x = w / h
    j = int(x)
    if j >= n:
        j = n - 1
    t = x - j
    t2 = t * t
    t3 = t2 * t
    th0 = params[_HEADER + j]
    th1 = params[_HEADER + j + 1]
    d0 = params[_HEADER + n + 1 + j] * h
    d1 = params[_HEADER + n + 2 + j] * h
    theta = (
        (2.0 * t3 - 3.0 * t2 + 1.0) * th0
        + (t3 - 2.0 * t2 + t) * d0
        + (-2.0 * t3 + 3.0 * t2) * th1
        + (t3 - t2) * d1
    )
    if theta > _HALF_PI:
        return _HALF_PI
    if theta < 0.0:
        return 0.0
    return theta


@njit(cache=True)
def sample(u1, u2, params):
    """Sample ``m`` with pdf ``D(m)(m.n)``: tabulated theta (IL eq. 13), ``phi = 2 pi u2``.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: output of :func:`params_from`.
    Returns: Finite ``tan theta_m >= 0`` and a unit azimuth pair (``(1, 0)`` when the
    tangent is 0).
    """
    t = math.tan(inverse_cdf_theta(u1, params))
    if t <= 0.0:
        return 0.0, 1.0, 0.0
    phi = _TWO_PI * u2
    return t, math.cos(phi), math.sin(phi)


#: Unit normal ``(mx, my, mz)`` sampled with pdf ``D(m)(m.n)``: :func:`sample` as a normal.
sample_normal = normal_sampler(sample)


@njit(cache=True, inline="always")
def sample_disk(a, b, s, params):
    """:func:`sample` with ``u1 = 1 - s`` and azimuth ``(a, b)/sqrt(s)`` (no trig for the
    azimuth; see :func:`vcavity.microfacet.beckmann.sample_disk`); theta from the table.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: output of :func:`params_from`.
    """
    inv = 1.0 / math.sqrt(s)
    return math.tan(inverse_cdf_theta(1.0 - s, params)), a * inv, b * inv


@njit(cache=True)
def pdf(mx, my, mz, params):
    """Sampling pdf ``D(m)(m.n) = C exp(-theta_m^2/(2 sigma^2))`` (IL eq. 13).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: output of :func:`params_from`.
    Returns: Density per steradian; 0 for ``mz <= 0``.
    """
    if mz <= 0.0:
        return 0.0
    theta = math.atan2(math.sqrt(mx * mx + my * my), mz)
    r = theta / params[0]
    weight = math.exp(-0.5 * r * r)
    if weight == 0.0:  # also when C = inf (sigma < 1.5e-154): no inf * 0
        return 0.0
    return params[1] * weight


@njit(cache=True)
def D(mx, my, mz, params):
    """Gaussian distribution of normals ``C exp(-theta^2/(2 sigma^2))/cos theta`` (IL eq. 13).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: output of :func:`params_from`.
    Returns: ``D(m)`` in 1/sr; 0 for ``mz <= 0``.  ``D ~ 1/mz`` grows without bound toward
    the horizon (``inf`` once ``pdf/mz`` overflows).
    """
    if mz <= 0.0:
        return 0.0
    return pdf(mx, my, mz, params) / mz


@njit(cache=True)
def smith_lambda(vx, vy, vz, params):
    """Smith ``Lambda(v)``: ``inf`` for every ``v != n`` (see the module docstring).

    ``Lambda(v) = int D(m) max(0, -v.m) dw_m / (v.n)`` (H sec. 4) diverges like
    ``int dtheta_m / cos theta_m`` at the horizon because ``D ~ 1/cos theta_m``.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: output of :func:`params_from`
    (unused). Returns: 0 for ``v = n`` (``vz >= 1`` or no tangential part), else ``inf``.
    """
    if vz >= 1.0:
        return 0.0
    if vz > 0.0 and vx * vx + vy * vy <= 0.0:
        return 0.0
    return math.inf
