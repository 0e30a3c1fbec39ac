"""Isotropic Phong distribution of microfacet normals (W eq. 30-32).

``params`` layout (float64, shape (1,)): ``[exponent]`` (Walter's ``alpha_p``,
``>= 0``; similar to Beckmann with ``alpha_b = sqrt(2/(alpha_p + 2))``).

- ``D(m) = (alpha_p + 2)/(2 pi) cos^alpha_p theta_m`` (W eq. 30, physics.md sec. 2).
- Sampling: ``cos theta_m = (1 - u1)^(1/(alpha_p + 2))``, ``phi_m = 2 pi u2``
  (W eq. 31-32 with ``u1 -> 1 - u1``, the same distribution, so that ``u1 = 0``
  gives the normal and ``u1 -> 1`` stays finite).
- Smith ``Lambda``: APPROXIMATE (``HAS_EXACT_SMITH = False``).  The Smith
  integral has no closed form for Phong; following W sec. 5.2 we use the
  Beckmann Lambda (H eq. 69) with ``a = sqrt(0.5 alpha_p + 1)/tan theta_v``.
  Measured against a numerical quadrature of the exact Smith Lambda, the
  relative error of ``G1 = 1/(1 + Lambda)`` is at most about 24 % for
  ``alpha_p = 2``, 3.2 % for 20, 0.26 % for 200, 0.034 % for 1000 (worst
  near grazing); see tests/microfacet/test_masking.py.
"""

import math

import numpy as np

from vcavity.microfacet.beckmann import smith_lambda_of_a
from vcavity.microfacet.common import normal_from_slope_angle
from vcavity._jit import njit

NAME = "phong"
KIND = 2
HAS_EXACT_SMITH = False

_TWO_PI = 2.0 * math.pi
_ONE_MINUS_ULP = 1.0 - 2.0**-53  # largest float64 below 1


def make_params(exponent):
    """Pack the parameters (no validation: the config layer validates).

    Parameters
    ----------
    exponent : float
        Phong exponent ``alpha_p >= 0``.

    Returns
    -------
    ndarray, shape (1,)
        ``[exponent]``.
    """
    return np.array([exponent], dtype=np.float64)


@njit(cache=True)
def sample(u1, u2, params):
    """Sample ``m`` with pdf ``D(m)(m.n)`` (W eq. 31-32).

    ``cos^2 theta_m = (1 - u1)^(2/(alpha_p + 2))``, hence
    ``tan theta_m = sqrt(expm1(-2 log1p(-u1)/(alpha_p + 2)))`` without
    cancellation near the normal.

    Parameters
    ----------
    u1, u2 : float
        Uniforms in ``[0, 1)`` (``u1 >= 1`` is clamped to the largest float below 1).
    params : ndarray
        ``[exponent]``.

    Returns
    -------
    tan_theta_m, cos_phi_m, sin_phi_m : float
        Finite ``tan theta_m >= 0`` and a unit azimuth pair (``(1, 0)`` when the
        tangent is 0).
    """
    if u1 >= 1.0:
        u1 = _ONE_MINUS_ULP
    t2 = math.expm1(-2.0 * math.log1p(-u1) / (params[0] + 2.0))
    if t2 <= 0.0:
        return 0.0, 1.0, 0.0
    phi = _TWO_PI * u2
    return math.sqrt(t2), math.cos(phi), math.sin(phi)


@njit(cache=True)
def sample_normal(u1, u2, params):
    """Unit normal sampled with pdf ``D(m)(m.n)``; see :func:`sample`.

    Parameters
    ----------
    u1, u2 : float
        Uniforms in ``[0, 1)``.
    params : ndarray
        ``[exponent]``.

    Returns
    -------
    mx, my, mz : float
        Unit microfacet normal with ``mz > 0``.
    """
    t, c, s = sample(u1, u2, params)
    return normal_from_slope_angle(t, c, s)


@njit(cache=True)
def D(mx, my, mz, params):
    """Phong distribution of normals (W eq. 30).

    Parameters
    ----------
    mx, my, mz : float
        Unit microfacet normal.
    params : ndarray
        ``[exponent]``.

    Returns
    -------
    float
        ``D(m)`` in 1/sr; 0 for ``mz <= 0``.
    """
    if mz <= 0.0:
        return 0.0
    e = params[0]
    return (e + 2.0) / _TWO_PI * mz**e


@njit(cache=True)
def pdf(mx, my, mz, params):
    """Sampling pdf ``D(m)(m.n)`` of :func:`sample_normal` (W eq. 24).

    Parameters
    ----------
    mx, my, mz : float
        Unit microfacet normal.
    params : ndarray
        ``[exponent]``.

    Returns
    -------
    float
        Density per steradian.
    """
    if mz <= 0.0:
        return 0.0
    e = params[0]
    return (e + 2.0) / _TWO_PI * mz ** (e + 1.0)


@njit(cache=True)
def smith_lambda(vx, vy, vz, params):
    """APPROXIMATE Smith ``Lambda(v)`` for Phong (W sec. 5.2, H eq. 69).

    Beckmann Lambda with ``a = sqrt(0.5 alpha_p + 1)/tan theta_v``; see the
    module docstring for its measured accuracy.

    Parameters
    ----------
    vx, vy, vz : float
        Unit direction.
    params : ndarray
        ``[exponent]``.

    Returns
    -------
    float
        ``Lambda >= 0``; 0 for ``vz >= 1``, ``inf`` for ``vz <= 0``.
    """
    if vz >= 1.0:
        return 0.0
    if vz <= 0.0:
        return math.inf
    sin_theta = math.sqrt(vx * vx + vy * vy)
    if sin_theta <= 0.0:
        return 0.0
    a = math.sqrt(0.5 * params[0] + 1.0) * vz / sin_theta
    return smith_lambda_of_a(a)


@njit(cache=True)
def sample_normal_many(u1, u2, params):
    """Vectorised :func:`sample_normal`: arrays of uniforms to an ``(N, 3)`` array."""
    n = u1.shape[0]
    out = np.empty((n, 3))
    for k in range(n):
        out[k, 0], out[k, 1], out[k, 2] = sample_normal(u1[k], u2[k], params)
    return out


@njit(cache=True)
def D_many(m, params):
    """Vectorised :func:`D` over the rows of an ``(N, 3)`` array."""
    out = np.empty(m.shape[0])
    for k in range(m.shape[0]):
        out[k] = D(m[k, 0], m[k, 1], m[k, 2], params)
    return out


@njit(cache=True)
def pdf_many(m, params):
    """Vectorised :func:`pdf` over the rows of an ``(N, 3)`` array."""
    out = np.empty(m.shape[0])
    for k in range(m.shape[0]):
        out[k] = pdf(m[k, 0], m[k, 1], m[k, 2], params)
    return out


@njit(cache=True)
def smith_lambda_many(v, params):
    """Vectorised :func:`smith_lambda` over the rows of an ``(N, 3)`` array."""
    out = np.empty(v.shape[0])
    for k in range(v.shape[0]):
        out[k] = smith_lambda(v[k, 0], v[k, 1], v[k, 2], params)
    return out
