"""Dielectric Fresnel terms and the diffuse reflectances of an interface.

Scalar functions are ``numba.njit(cache=True)`` and can be called from jitted kernels
and from Python. ``*_array`` variants apply the same jitted scalar code to NumPy arrays.

Conventions (physics.md sec. 4): ``eta = n1/n0`` is the index of the body relative to
the outside medium; light arrives from the outside with ``c = |d.m|``. ``eta < 1``
describes light arriving from inside (use ``1/eta``), with total internal reflection.

References: W = Walter et al. 2007 eq. 22; IL = Meneveaux et al. eq. 7 and 10
(Molenaar's closed form of the hemispherical reflectance); physics.md sec. 4 and 9.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit

# Taylor coefficients c_1..c_40 of the regular part of Molenaar's r_e (IL eq. 10),
#   R(eta) = 1/2 + (eta-1)(3eta+1)/(6(eta+1)^2) - 2eta^3(eta^2+2eta-1)/((eta^2+1)(eta^4-1))
#            + 8eta^4(eta^4+1) ln(eta)/((eta^2+1)(eta^4-1)^2)  =  sum_k c_k (eta-1)^k,
# derived exactly in rational arithmetic and rounded to float64 (the test suite
# re-derives them). The two last terms diverge like 1/(eta-1) and cancel, which is why
# the closed form loses precision near eta = 1. Radius of convergence 1 (ln eta at 0).
_RE_REGULAR_TAYLOR = np.array(
    [
        0.3333333333333333, 0.7916666666666666, -1.0666666666666667, 0.16875,
        0.9360119047619048, -1.2409970238095238, 0.6062996031746032,
        0.34264012896825397, -0.892113658910534, 0.7788539693813131,
        -0.2432681467837718, -0.2770464805376915, 0.4849202799153971,
        -0.36118045569339513, 0.0843570079934108, 0.14096731793525294,
        -0.21062876267786687, 0.1436737885936098, -0.026572241695307846,
        -0.059613776222431046, 0.08137874113210995, -0.05251049618361607,
        0.00815065682605533, 0.022425348616864398, -0.028977693520114284,
        0.017979001668201124, -0.0023642949020084435, -0.007910432249900332,
        0.009818515161806476, -0.00592566126068345, 0.0006943354384350295,
        0.0026316271833782038, -0.0031791188019920824, 0.0018745646716882183,
        -0.00018882455531775823, -0.0008543679985693005, 0.0010075518417312064,
        -0.0005855105617814004, 5.6710469305225274e-05, 0.0002637633722465966,
    ],
    dtype=np.float64,
)

# Below eta = 1 + _RE_SERIES_MAX_DELTA, r_e uses the Taylor series of the regular part.
# Measured relative error against a 60-digit evaluation of IL eq. 10 (decimal module),
# max over 200 random eta per range. Float64 closed form (with eta^4 - 1 and ln eta
# factored to avoid avoidable cancellation): 4e-4 at eta-1 = 1e-6, 1e-8 at 1e-4,
# 6e-10 at 1e-3, 4e-13 in [0.05, 0.1], 1.3e-13 in [0.1, 0.2], 2.3e-14 in [0.3, 0.4],
# 1.7e-14 in [0.4, 0.5], 7e-15 in [0.8, 1]. The 40-term series: <= 1.5e-15 for
# eta-1 <= 0.4 (truncation there < 1e-16 relative). So the switch is at eta = 1.4 and
# r_e has relative error <= 2e-14 everywhere, <= 2e-15 away from [1.4, 1.6].
_RE_SERIES_MAX_DELTA = 0.4

# Above this eta, 1 - r_e is the quantity computed directly (it is < 0.5 there);
# below it r_e is. Each form is cancellation-free on its side (relative error ~1e-16).
_RE_COMPLEMENT_MIN_ETA = 4.0

# Above this eta, 1 - r_e = 16/(3 eta) - O(ln(eta)/eta^2) (measured: the correction is
# 8 ln(eta)/eta^2 to leading order), i.e. 16/(3 eta) to below 1e-27 relative: the closed
# form's eta^8-sized intermediates would overflow from eta ~ 1e38 on (NaN before).
_RE_ASYMPTOTIC_MIN_ETA = 1e30

# Above this eta, F and T use the same expressions divided through by powers of eta
# (no eta^4-sized intermediate, which overflows from eta ~ 1e77 and gave NaN): exact
# algebra, not an approximation, so the switch is seamless (tests/test_numerics_review.py).
_FRESNEL_SCALED_MIN_ETA = 1e50


@njit(cache=True, inline="always")
def _g_squared(eta, c, e2m1, sin2):
    """``g^2 = eta^2 - 1 + c^2 = eta^2 - sin^2`` of W eq. 22, in the form whose only
    cancellation is the genuine zero at the critical angle (eta < 1)."""
    if e2m1 >= 0.0:
        return e2m1 + c * c
    return eta * eta - sin2


@njit(cache=True, inline="always")
def _fresnel_scaled(c, sin2, inv_eta):
    """F of W eq. 22 for very large eta, written with ``g_hat = g/eta`` and ``1/eta``.

    ``r_s = (1 - 1/eta^2)/(g_hat + c/eta)^2`` and
    ``r_p = (1 - 1/eta^2) (c - sin/eta)(c + sin/eta)/(c + g_hat/eta)^2`` are the
    amplitudes of :func:`fresnel_dielectric` divided through by ``eta^2`` and ``eta^4``;
    every factor is a ratio bounded by ~1, so nothing overflows or underflows to 0/0.
    """
    sin_t = math.sqrt(sin2)
    s_inv = sin_t * inv_eta
    g_hat = math.sqrt((1.0 - s_inv) * (1.0 + s_inv))
    head = (1.0 - inv_eta) * (1.0 + inv_eta)
    den_s = g_hat + c * inv_eta
    r_s = head / (den_s * den_s)
    den_p = c + g_hat * inv_eta
    r_p = head * ((c - s_inv) / den_p) * ((c + s_inv) / den_p)
    return min(0.5 * (r_s * r_s + r_p * r_p), 1.0)


@njit(cache=True, inline="always")
def _transmittance_scaled(c, eta):
    """T of :func:`fresnel_transmittance` for very large eta (``g = eta g_hat``).

    ``2gc/(g+c)^2 = 2 (g_hat/(g_hat + c/eta)) ((c/eta)/(g_hat + c/eta))`` and
    ``2 g c eta^2/(eta^2 c + g)^2 = 2 (g_hat/(x + g_hat)) (x/(x + g_hat))`` with
    ``x = eta c``: bounded ratios only.
    """
    inv_eta = 1.0 / eta
    s_inv = math.sqrt((1.0 - c) * (1.0 + c)) * inv_eta
    g_hat = math.sqrt((1.0 - s_inv) * (1.0 + s_inv))
    c_inv = c * inv_eta
    x = c * eta  # <= eta: finite
    den_1 = g_hat + c_inv
    den_2 = x + g_hat
    t = 2.0 * (g_hat / den_1) * (c_inv / den_1) + 2.0 * (g_hat / den_2) * (x / den_2)
    return min(t, 1.0)


@njit(cache=True)
def fresnel_dielectric(cos_theta, eta):
    """Unpolarised dielectric Fresnel reflectance F (W eq. 22, IL eq. 7).

    Parameters
    ----------
    cos_theta : float
        ``|cos|`` of the angle between the direction and the facet normal, in [0, 1]
        (the absolute value is taken; values above 1 by rounding are clamped).
    eta : float
        Relative index (transmitted side / incident side), ``eta > 0``. ``eta < 1``
        gives total internal reflection (F = 1) beyond the critical angle.

    Returns
    -------
    float
        F in [0, 1]. Exactly 0 when ``eta == 1``; 1 at ``cos_theta == 0`` otherwise.

    Notes
    -----
    With ``g^2 = eta^2 - 1 + c^2`` (W eq. 22) the s and p amplitudes are rewritten so
    that the factor ``eta^2 - 1 = (eta-1)(eta+1)`` appears explicitly:
    ``r_s = (c-g)/(c+g) = -(eta^2-1)/(g+c)^2``,
    ``r_p = (eta^2 c-g)/(eta^2 c+g) = (eta^2-1)(eta^2 c^2-sin^2)/(eta^2 c+g)^2``,
    ``F = (r_s^2 + r_p^2)/2``. This is W eq. 22 (whose bracket is ``1 + (r_p/r_s)^2``)
    without the subtraction ``g - c``, so F -> 0 smoothly as eta -> 1. The remaining
    zero of ``eta^2 c^2 - sin^2`` is Brewster's angle, a true zero of r_p.
    """
    c = min(abs(cos_theta), 1.0)
    e2m1 = (eta - 1.0) * (eta + 1.0)  # eta^2 - 1 without cancellation
    if e2m1 == 0.0:
        return 0.0
    if c == 0.0:
        return 1.0  # grazing incidence: r_s = r_p = -1 (avoids sqrt(g^2)^2 != g^2 rounding)
    sin2 = (1.0 - c) * (1.0 + c)
    if eta > _FRESNEL_SCALED_MIN_ETA:
        return _fresnel_scaled(c, sin2, 1.0 / eta)
    g2 = _g_squared(eta, c, e2m1, sin2)
    if g2 <= 0.0:
        return 1.0  # total internal reflection (eta < 1)
    g = math.sqrt(g2)
    gpc = g + c
    r_s = e2m1 / (gpc * gpc)  # = -r_s; only the squares enter F
    e2c_g = eta * eta * c + g
    r_p = e2m1 * (eta * eta * c * c - sin2) / (e2c_g * e2c_g)
    return min(0.5 * (r_s * r_s + r_p * r_p), 1.0)


@njit(cache=True)
def fresnel_transmittance(cos_theta, eta):
    """Unpolarised dielectric Fresnel transmittance T = 1 - F (W eq. 22, IL eq. 7).

    Parameters
    ----------
    cos_theta : float
        ``|cos|`` of the angle to the facet normal on the incident side, in [0, 1].
    eta : float
        Relative index as in :func:`fresnel_dielectric`.

    Returns
    -------
    float
        T in [0, 1]; 1 when ``eta == 1``, 0 under total internal reflection.

    Notes
    -----
    Computed as ``T = (t_s + t_p)/2`` with ``t_s = 1 - r_s^2 = 4gc/(g+c)^2`` and
    ``t_p = 1 - r_p^2 = 4 eta^2 g c/(eta^2 c+g)^2``: a sum of positive terms, so T keeps
    full relative precision at large eta, where ``1 - F`` would cancel (T ~ 4/eta).
    """
    c = min(abs(cos_theta), 1.0)
    e2m1 = (eta - 1.0) * (eta + 1.0)
    if e2m1 == 0.0:
        return 1.0
    if eta > _FRESNEL_SCALED_MIN_ETA:
        return _transmittance_scaled(c, eta)
    g2 = _g_squared(eta, c, e2m1, (1.0 - c) * (1.0 + c))
    if g2 <= 0.0:
        return 0.0
    g = math.sqrt(g2)
    gpc = g + c
    e2 = eta * eta
    e2c_g = e2 * c + g
    return min(2.0 * g * c * (1.0 / (gpc * gpc) + e2 / (e2c_g * e2c_g)), 1.0)


# The scalars that have an array version, by position: the one jitted loop picks the
# scalar with an integer, so every array version shares one compiled (cached) loop.
_ELEMENTWISE = ("fresnel_dielectric", "fresnel_transmittance")


@njit(cache=True)
def _fresnel_loop(cos_flat, eta, out, which):
    for k in range(cos_flat.shape[0]):
        if which == 1:
            out[k] = fresnel_transmittance(cos_flat[k], eta)
        else:
            out[k] = fresnel_dielectric(cos_flat[k], eta)


_ARRAY_DOC = """Array version of :func:`{name}` (the same jitted scalar code, W eq. 22).

    Parameters
    ----------
    cos_array : array_like
        Cosines, any shape.
    eta : float
        Relative index (scalar).

    Returns
    -------
    numpy.ndarray
        {symbol} with the shape of ``cos_array``, float64.
    """


def _array_version(name: str, symbol: str):
    """``name_array(cos_array, eta)``: the scalar ``name`` of :data:`_ELEMENTWISE` over an array."""
    which = _ELEMENTWISE.index(name)

    def array_version(cos_array, eta):
        cos = np.asarray(cos_array, dtype=np.float64)
        out = np.empty(cos.size, dtype=np.float64)
        _fresnel_loop(np.ascontiguousarray(cos.ravel()), float(eta), out, which)
        return out.reshape(cos.shape)

    array_version.__name__ = array_version.__qualname__ = f"{name}_array"
    array_version.__doc__ = _ARRAY_DOC.format(name=name, symbol=symbol)
    return array_version


fresnel_dielectric_array = _array_version("fresnel_dielectric", "F")
fresnel_transmittance_array = _array_version("fresnel_transmittance", "T = 1 - F")


@njit(cache=True)
def _r_e_and_complement(eta):
    """Return ``(r_e, 1 - r_e)``, each with ~1e-16 relative error (IL eq. 10).

    Domain ``eta >= 1`` (every finite float; above 1e30 the leading asymptotic term
    ``1 - r_e = 16/(3 eta)``, exact to float precision there); NaN for ``eta < 1``
    (r_e is defined for light arriving from the optically thinner side).
    """
    delta = eta - 1.0
    if delta == 0.0:
        return 0.0, 1.0
    if not delta > 0.0:
        return np.nan, np.nan
    if eta > _RE_ASYMPTOTIC_MIN_ETA:
        complement = (16.0 / 3.0) / eta
        return 1.0 - complement, complement
    e2 = eta * eta
    e2p1 = e2 + 1.0
    e2m1 = delta * (eta + 1.0)
    # eta^2 (eta^2-1)^2/(eta^2+1)^3 ln((eta-1)/(eta+1)); the log is taken so that its
    # argument is formed without cancellation on either side of eta = 2.
    if eta < 2.0:
        log_ratio = math.log(delta / (eta + 1.0))
    else:
        log_ratio = math.log1p(-2.0 / (eta + 1.0))
    log_term = e2 * (e2m1 * e2m1) / (e2p1 * e2p1 * e2p1) * log_ratio
    if delta < _RE_SERIES_MAX_DELTA:
        regular = 0.0
        for k in range(_RE_REGULAR_TAYLOR.shape[0] - 1, -1, -1):
            regular = regular * delta + _RE_REGULAR_TAYLOR[k]
        r_e = regular * delta + log_term
        return r_e, 1.0 - r_e
    e4m1 = e2m1 * e2p1
    pole_term = -2.0 * e2 * eta * (e2 + 2.0 * eta - 1.0) / (e2p1 * e4m1)
    log_eta_term = 8.0 * e2 * e2 * (e2 * e2 + 1.0) / (e2p1 * e4m1 * e4m1) * math.log1p(delta)
    rest = log_term + pole_term + log_eta_term
    if eta < _RE_COMPLEMENT_MIN_ETA:
        r_e = 0.5 + delta * (3.0 * eta + 1.0) / (6.0 * (eta + 1.0) ** 2) + rest
        return r_e, 1.0 - r_e
    # 1/2 - (eta-1)(3eta+1)/(6(eta+1)^2) = (4eta+2)/(3(eta+1)^2); the other three terms
    # are each O(1/eta) with signs that do not cancel, so 1 - r_e ~ 16/(3 eta) keeps
    # full relative precision (measured: 1e-16 up to eta = 1e30).
    complement = (4.0 * eta + 2.0) / (3.0 * (eta + 1.0) ** 2) - rest
    return 1.0 - complement, complement


@njit(cache=True)
def r_e(eta):
    """External hemispherical (diffuse) reflectance of the interface (IL eq. 10).

    ``r_e = int_0^{pi/2} F(cos t) sin 2t dt`` (Molenaar's closed form), for light from
    the outside medium.

    Parameters
    ----------
    eta : float
        Relative index, ``eta >= 1`` (NaN below 1).

    Returns
    -------
    float
        r_e in [0, 1); exactly 0 at ``eta == 1``.

    Notes
    -----
    For ``eta - 1 < 0.4`` the closed form is replaced by a 40-term Taylor series of its
    regular part plus the (harmless) ``ln((eta-1)/(eta+1))`` term; physics.md sec. 9.
    """
    return _r_e_and_complement(eta)[0]


@njit(cache=True)
def one_minus_r_e(eta):
    """``1 - r_e``, computed directly where it is small (IL eq. 10, physics.md sec. 4, 9).

    Parameters
    ----------
    eta : float
        Relative index, ``eta >= 1``.

    Returns
    -------
    float
        Fraction of diffuse light from outside that the interface transmits; exactly 1 at
        ``eta == 1``, ~16/(3 eta) at large eta.
    """
    return _r_e_and_complement(eta)[1]


@njit(cache=True)
def one_minus_r_i(eta):
    """``1 - r_i = (1 - r_e)/eta^2``, computed without forming r_i (physics.md sec. 4, 9).

    Parameters
    ----------
    eta : float
        Relative index, ``eta >= 1``.

    Returns
    -------
    float
        Fraction of diffuse light inside the body that escapes per interface hit;
        exactly 1 at ``eta == 1``, ~16/(3 eta^3) at large eta.
    """
    complement = _r_e_and_complement(eta)[1]
    if eta > _RE_ASYMPTOTIC_MIN_ETA:
        return complement / eta / eta  # eta * eta would overflow first (eta > 1e154)
    return complement / (eta * eta)


@njit(cache=True)
def r_i(eta):
    """Internal diffuse reflectance ``r_i = 1 - (1 - r_e)/eta^2`` (IL, physics.md sec. 4).

    Parameters
    ----------
    eta : float
        Relative index, ``eta >= 1``.

    Returns
    -------
    float
        r_i in [0, 1). Prefer :func:`one_minus_r_i` where ``1 - r_i`` is needed.
    """
    return 1.0 - one_minus_r_i(eta)


@njit(cache=True)
def emergence_probability(kd, eta):
    """Probability that light entering the IL body re-emerges (physics.md sec. 4, 9).

    ``a = kd (1 - r_i)/(1 - kd r_i)``, evaluated as
    ``kd (1 - r_i)/((1 - kd) + kd (1 - r_i))`` (IL eq. 4-8 summed over internal
    reflections): exactly 1 at ``kd == 1``, exactly ``kd`` at ``eta == 1``, and a sum of
    non-negative terms in the denominator so nothing cancels at large eta.

    Parameters
    ----------
    kd : float
        Body albedo in [0, 1].
    eta : float
        Relative index, ``eta >= 1``.

    Returns
    -------
    float
        a in [0, 1].
    """
    escape = one_minus_r_i(eta)
    kd_escape = kd * escape
    denominator = (1.0 - kd) + kd_escape
    if denominator == 0.0:  # kd == 1 and 1 - r_i underflowed (eta > ~1e108): a = 1
        return 1.0
    return kd_escape / denominator
