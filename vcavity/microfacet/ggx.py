"""Anisotropic GGX (Trowbridge-Reitz) distribution of microfacet normals.

``params`` layout (float64, shape (2,)): ``[alpha_x, alpha_y]``.

- ``D(m) = 1 / (pi alpha_x alpha_y cos^4 theta_m (1 + tan^2 theta_m
  (cos^2 phi_m/alpha_x^2 + sin^2 phi_m/alpha_y^2))^2)`` (H eq. 85, W eq. 33).
- Sampling of ``D(m)(m.n)`` by stretched slopes with ``r = sqrt(u1/(1-u1))``
  (H sec. 5, W eq. 35-36, physics.md sec. 2).
- Exact Smith ``Lambda = (-1 + sqrt(1 + 1/a^2))/2`` (H eq. 72) with the
  projected roughness of H eq. 80.
"""

import math

from vcavity.microfacet.common import (
    alpha_lobe_width,
    alpha_params_from,
    log_ratio_squared,
    normal_sampler,
    stretched_slope,
)
from vcavity.parameters import Roughness
from vcavity._numba.jit import njit
from vcavity.rng import next_uniform

NAME = "ggx"
DESCRIPTION = "Trowbridge-Reitz: slopes with a 1/(1 + tan^2/alpha^2)^2 tail (W eq. 33, H eq. 85)"
PARAMETERS = (Roughness(summary="GGX roughness", example=0.5),)
SMITH = "exact"
#: Named parameter sets as a user writes them in ``[material]``: the conformance suite
#: (tests/microfacet/test_conformance.py) runs every generic check on each.
EXAMPLES = {
    "typical": {"alpha": 0.3},
    "anisotropic": {"alpha_x": 0.6, "alpha_y": 0.2},
    "smooth": {"alpha": 0.05},
    "rough": {"alpha": 1.0},
    "extreme_anisotropic": {"alpha_x": 3.0, "alpha_y": 0.01},
}

_TWO_PI = 2.0 * math.pi
_LOG_PI = math.log(math.pi)
_ONE_MINUS_ULP = 1.0 - 2.0**-53  # largest float64 below 1


#: ``[alpha_x, alpha_y]`` from the canonical values; the smaller alpha as the lobe width.
params_from = alpha_params_from
lobe_width = alpha_lobe_width


@njit(cache=True)
def sample(u1, u2, params):
    """Sample ``m`` with pdf ``D(m)(m.n)`` (H sec. 5, W eq. 35-36 stretched).

    Slope ``(s_x, s_y) = (alpha_x r cos phi', alpha_y r sin phi')`` with
    ``r = sqrt(u1/(1 - u1))``, ``phi' = 2 pi u2``; ``m = normalize(-s_x, -s_y, 1)``.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    Finite ``tan theta_m >= 0`` (at most ~1e8 max(alpha), and at most
    ``common.MAX_TAN_THETA``) and a unit azimuth pair (``(1, 0)`` when the tangent is 0).
    """
    if u1 >= 1.0:
        u1 = _ONE_MINUS_ULP
    if u1 <= 0.0:
        return 0.0, 1.0, 0.0
    r = math.sqrt(u1 / (1.0 - u1))
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
    # r^2 = u1/(1 - u1) = (1 - s)/s (physics.md sec. 2)
    if params[0] == params[1] and 1e-150 < params[0] < 1e150:
        # isotropic (physics.md sec. 2): |slope| = alpha r and phi_m is opposite to (a, b),
        # so no stretching (two divisions and a sqrt fewer); the test is the same for every
        # path of a run, so it is predicted and costs nothing
        inv = 1.0 / math.sqrt(s)
        return params[0] * (math.sqrt(1.0 - s) * inv), -a * inv, -b * inv
    r_over_sqrt_s = math.sqrt(1.0 - s) / s
    # the slope is (alpha_x a, alpha_y b) r / sqrt(s); stretched_slope stays finite for
    # alpha from 1e-300 to 1e300 (H sec. 5)
    return stretched_slope(r_over_sqrt_s, a, b, params[0], params[1])


@njit(cache=True)
def D(mx, my, mz, params):
    """GGX distribution of normals (H eq. 85, physics.md sec. 2).

    Evaluated as ``1 / (pi ax ay (mx^2/ax^2 + my^2/ay^2 + mz^2)^2)``, the same
    expression multiplied through by ``mz^4``: no division by ``mz``. For alpha in
    [1e-50, 1e50] no product under- or overflows; otherwise the same in logarithms, so
    no alpha in the accepted range (any float > 0) divides by zero.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    ``D(m)`` in 1/sr; 0 for ``mz <= 0``; ``inf`` only where ``D`` exceeds the float64 range
    (the peak for ``alpha_x alpha_y < ~1e-308``).
    """
    if mz <= 0.0:
        return 0.0
    ax = params[0]
    ay = params[1]
    if 1e-50 < ax < 1e50 and 1e-50 < ay < 1e50:
        u = mx / ax  # |u| < 1e50
        w = my / ay
        s = u * u + w * w + mz * mz  # >= 1/(3 max(1, alpha)^2) for a unit m: s^2 > 1e-201
        if s == 0.0:  # only for a zero-length m: never for a unit normal
            return 0.0
        return 1.0 / (math.pi * ax * ay * s * s)
    # log s, s = (mx/ax)^2 + (my/ay)^2 + mz^2, from exact exponents (no term under- or
    # overflows), then 1/(pi ax ay s^2) in logarithms
    lu = log_ratio_squared(mx, ax)
    lw = log_ratio_squared(my, ay)
    lz = log_ratio_squared(mz, 1.0)
    top = max(lu, lw, lz)
    log_s = top + math.log(math.exp(lu - top) + math.exp(lw - top) + math.exp(lz - top))
    return math.exp(-_LOG_PI - math.log(ax) - math.log(ay) - 2.0 * log_s)


@njit(cache=True)
def pdf(mx, my, mz, params):
    """Sampling pdf ``D(m)(m.n)`` of :func:`sample_normal` (W eq. 24).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    Density per steradian.
    """
    return D(mx, my, mz, params) * mz


@njit(cache=True)
def smith_lambda(vx, vy, vz, params):
    """Exact Smith ``Lambda(v)`` for anisotropic GGX (H eq. 72 with eq. 80).

    With ``b = 1/a^2 = alpha_o^2 tan^2 theta_v``,
    ``Lambda = (sqrt(1 + b) - 1)/2``, evaluated as ``b / (2 (sqrt(1+b) + 1))``
    for small ``b`` (no cancellation).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: ``[alpha_x, alpha_y]``. Returns:
    ``Lambda >= 0``; 0 for ``vz >= 1``, ``inf`` for ``vz <= 0``.
    """
    if vz >= 1.0:
        return 0.0
    if vz <= 0.0:
        return math.inf
    ax = params[0]
    ay = params[1]
    vz2 = vz * vz
    if vz2 == 0.0:  # vz so small that its square underflows: grazing limit
        return math.inf
    b = (vx * vx * ax * ax + vy * vy * ay * ay) / vz2
    if b > 1.0:
        return 0.5 * (math.sqrt(1.0 + b) - 1.0)  # also right for b = inf
    return 0.5 * b / (math.sqrt(1.0 + b) + 1.0)


@njit(cache=True)
def sample_visible(vx, vy, vz, u1, u2, params):
    """Sample ``m`` with the visible-normal density ``D_v(m) = <v, m>+ D(m) / (v.n (1 + Lambda(v)))``
    (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4); physics.md sec. 14).

    GGX is the distribution of normals of an ellipsoid: stretched to unit roughness it is a
    hemisphere, whose visible normals seen from ``v' = normalize(alpha_x vx, alpha_y vy, vz)``
    are those under a uniform point of its projected outline: a disk whose far half is
    squeezed by ``(1 + v'_z)/2``. The point is lifted onto the hemisphere and the normal
    stretched back.

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
        Unit normal, ``mz >= 0``.
    """
    r = math.sqrt(u1)
    phi = _TWO_PI * u2
    return _visible_from_disk(vx, vy, vz, r * math.cos(phi), r * math.sin(phi), params)


@njit(cache=True)
def sample_visible_stream(state, vx, vy, vz, lam, params):
    """:func:`sample_visible`'s density, drawn from the random stream: the Smith walk's sampler.

    The uniform point of the unit disk is drawn by rejection from its square (acceptance
    pi/4, about 2.5 uniforms) instead of by ``sqrt`` and ``cos``/``sin`` of two uniforms;
    the rest is Heitz 2018's construction (physics.md sec. 14).

    Parameters
    ----------
    state : uint64
        Random stream state (:mod:`vcavity.rng`).
    vx, vy, vz : float
        Unit direction seen from, as for :func:`sample_visible`.
    lam : float
        Unused (GGX's sampler needs no ``Lambda``).
    params : ndarray
        ``[alpha_x, alpha_y]``.

    Returns
    -------
    state, mx, my, mz
        The advanced state and a unit normal, ``mz >= 0``.
    """
    while True:
        state, u1 = next_uniform(state)
        state, u2 = next_uniform(state)
        p1 = 2.0 * u1 - 1.0
        p2 = 2.0 * u2 - 1.0
        if p1 * p1 + p2 * p2 < 1.0:
            break
    mx, my, mz = _visible_from_disk(vx, vy, vz, p1, p2, params)
    return state, mx, my, mz


@njit(cache=True, inline="always")
def _visible_from_disk(vx, vy, vz, p1, p2, params):
    """Heitz 2018's visible normal from ``v`` of the point ``(p1, p2)`` of the unit disk."""
    ax = params[0]
    ay = params[1]
    hx = ax * vx
    hy = ay * vy
    norm = math.sqrt(hx * hx + hy * hy + vz * vz)
    hx, hy, hz = hx / norm, hy / norm, vz / norm
    # an orthonormal frame (t1, t2, h) around the stretched view
    lensq = hx * hx + hy * hy
    if lensq > 0.0:
        inv = 1.0 / math.sqrt(lensq)
        t1x, t1y = -hy * inv, hx * inv
    else:
        t1x, t1y = 1.0, 0.0
    t2x, t2y, t2z = -hz * t1y, hz * t1x, hx * t1y - hy * t1x
    # the disk's half beyond t1 squeezed onto the projection of the hemisphere
    s = 0.5 * (1.0 + hz)
    p2 = (1.0 - s) * math.sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx = p1 * t1x + p2 * t2x + p3 * hx
    ny = p1 * t1y + p2 * t2y + p3 * hy
    nz = p2 * t2z + p3 * hz
    # back to the distribution's roughness (normals transform with the inverse stretch)
    mx = ax * nx
    my = ay * ny
    mz = max(0.0, nz)
    norm = math.sqrt(mx * mx + my * my + mz * mz)
    return mx / norm, my / norm, mz / norm
