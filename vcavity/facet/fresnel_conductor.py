"""Fresnel reflectance of a conductor: a complex relative index ``n = eta + i k``.

Light arrives from a dielectric outside medium onto a flat conductor (a metal) whose index
relative to that medium is ``n = eta + i k`` (``eta > 0``, extinction ``k >= 0``); ``c =
|d.m|`` is the cosine to the facet normal. The unpolarised reflectance is ``F = (R_s +
R_p)/2`` with ``R_s = |r_s|^2``, ``R_p = |r_p|^2`` (Born & Wolf, Principles of Optics,
ch. 14; pbrt-v4 ``FrComplex``, Pharr, Jakob and Humphreys, Physically Based Rendering 4th
ed., sec. 9.3; Mitsuba 3 ``fresnel_conductor``). physics.md sec. 4 states the formulas
and how they are arranged here.

The scalar :func:`fresnel_conductor` is ``numba.njit(cache=True)`` and can be called from
jitted kernels and from Python; :func:`fresnel_conductor_array` applies the same jitted
code to a NumPy array of cosines.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit

# Above this |eta| or k every term is scaled by s = max(eta, k): |n|^4 would overflow
# from |n| ~ 1e77; below it s = 1 and every division by s is exact (no extra rounding).
_SCALE_FROM = 1e60


@njit(cache=True)
def fresnel_conductor(cos_theta, eta, k):
    """Unpolarised Fresnel reflectance of a conductor of complex relative index ``eta + i k``.

    Parameters
    ----------
    cos_theta : float
        Cosine to the facet normal, as for
        :func:`~vcavity.facet.fresnel.fresnel_dielectric` (``|cos|``, clamped to 1).
    eta : float
        Real part of the relative index (conductor / outside medium), ``eta > 0``.
    k : float
        Extinction coefficient (imaginary part), ``k >= 0``; ``k = 0`` is a dielectric
        (with total internal reflection for ``eta < 1``).

    Returns
    -------
    float
        F in [0, 1]: ``((eta-1)^2 + k^2)/((eta+1)^2 + k^2)`` at normal incidence, 1 at
        ``cos_theta == 0`` and under total internal reflection (``k = 0``, ``eta < 1``),
        exactly 0 for ``eta == 1, k == 0``.

    Notes
    -----
    With ``w = a + i b = sqrt(n^2 - sin^2)`` (``a, b >= 0``: the wave decays into the
    metal; ``a^2 - b^2 = eta^2 - k^2 - sin^2``, ``2ab = 2 eta k``, the a^2, b^2 of Born &
    Wolf and pbrt-v3 ``FrConductor``), the amplitudes ``r_s = (c - w)/(c + w)`` and
    ``r_p = (n^2 c - w)/(n^2 c + w)`` are rewritten without a difference of nearly equal
    terms (physics.md sec. 4): ``c^2 - w^2 = 1 - n^2`` gives
    ``|r_s| = |1 - n| |1 + n| / |c + w|^2`` and ``|r_p| = |n^2 - 1| |n^2 c^2 - sin^2| /
    |n^2 c + w|^2``, where ``|1 -+ n|^2 = (1 -+ eta)^2 + k^2`` and ``|c + w|^2 = (c + a)^2
    + b^2`` are sums of squares. ``w`` is the numerically stable complex square root
    (the larger of a, b from ``(|z| +- Re z)/2``, the other from ``Im z``). For
    ``max(eta, k) > 1e60`` every quantity is divided by ``s = max(eta, k)`` first
    (``|n|^4`` would overflow), which leaves both ratios unchanged.
    """
    c = min(abs(cos_theta), 1.0)
    if eta == 1.0 and k == 0.0:
        return 0.0  # no interface
    if c == 0.0:
        return 1.0  # grazing: r_s = r_p = -1 (0/0 avoided when n^2 - 1 underflows)
    s = max(eta, k)
    s = s if s > _SCALE_FROM else 1.0
    e = eta / s
    kk = k / s
    inv_s = 1.0 / s
    e2_k2 = (e - kk) * (e + kk)  # Re n^2 / s^2
    im_n2 = 2.0 * e * kk  # Im n^2 / s^2
    sin2 = (1.0 - c) * (1.0 + c)
    # Re z = (eta^2 - k^2 - sin^2)/s^2, summed so that near its zero (for k = 0 the
    # critical angle of eta < 1, sin^2 = eta^2) the terms that cancel are as small as
    # possible: (eta^2 - 1) + c^2 (eta - 1 exact for eta in [0.5, 2]) when
    # 1 - eta^2 < eta^2, else eta^2 - sin^2 (terms of size eta^2 < 1/2).
    if eta * eta > 0.5:
        x = ((e - inv_s) * (e + inv_s) + (c * inv_s) * (c * inv_s)) - kk * kk
    else:
        x = e2_k2 - sin2 * inv_s * inv_s
    if x <= 0.0 and im_n2 == 0.0:
        return 1.0  # total internal reflection (k = 0, eta < 1): exactly, not 1 +- rounding
    modulus = math.hypot(x, im_n2)
    if x >= 0.0:
        a = math.sqrt(0.5 * (modulus + x))
        b = 0.5 * im_n2 / a if a > 0.0 else 0.0
    else:
        b = math.sqrt(0.5 * (modulus - x))
        a = 0.5 * im_n2 / b
    one_minus_n2 = math.hypot(inv_s - e, kk) * math.hypot(inv_s + e, kk)  # |1 - n^2| / s^2
    cs = c * inv_s
    c_plus_w = math.hypot(cs + a, b)  # |c + w| / s, > 0 (hypot: its square may underflow)
    r_s = one_minus_n2 / c_plus_w / c_plus_w
    q = math.hypot(e2_k2 * c * c - sin2 * inv_s * inv_s, im_n2 * c * c)  # |n^2 c^2 - sin^2| / s^2
    n2c_plus_w = math.hypot(e2_k2 * c + a * inv_s, im_n2 * c + b * inv_s)  # |n^2 c + w| / s^2, > 0
    r_p = (one_minus_n2 / n2c_plus_w) * (q / n2c_plus_w)
    return min(0.5 * (r_s * r_s + r_p * r_p), 1.0)


@njit(cache=True)
def _fresnel_conductor_loop(cos_flat, eta, k, out):
    for j in range(cos_flat.shape[0]):
        out[j] = fresnel_conductor(cos_flat[j], eta, k)


def fresnel_conductor_array(cos_array, eta, k):
    """Array version of :func:`fresnel_conductor` (the same jitted scalar code).

    Parameters
    ----------
    cos_array : array_like
        Cosines, any shape.
    eta, k : float
        Real part and extinction of the relative index (scalars).

    Returns
    -------
    numpy.ndarray
        F with the shape of ``cos_array``, float64.
    """
    cos = np.asarray(cos_array, dtype=np.float64)
    out = np.empty(cos.size, dtype=np.float64)
    _fresnel_conductor_loop(np.ascontiguousarray(cos.ravel()), float(eta), float(k), out)
    return out.reshape(cos.shape)


__all__ = ["fresnel_conductor", "fresnel_conductor_array"]
