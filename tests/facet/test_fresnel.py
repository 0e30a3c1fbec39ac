"""Tests of vcavity.facet.fresnel against independent slow references.

References: the s/p-polarised Fresnel equations with Snell's law written in angles (not
the g-form of W eq. 22 that the module uses), scipy.integrate.quad of F for r_e
(IL eq. 10), and an exact rational re-derivation of the Taylor coefficients used near
eta = 1 (physics.md sec. 9).
"""

from fractions import Fraction

import numpy as np
import pytest
from scipy.integrate import quad

from vcavity.facet import fresnel as fr


def fresnel_reference(cos_i, eta):
    """Slow reference: s/p amplitudes with Snell's law n0 sin(i) = n1 sin(t), n0 = 1."""
    cos_i = np.asarray(cos_i, dtype=np.float64)
    sin_i = np.sqrt(np.maximum(0.0, 1.0 - cos_i**2))
    sin_t = sin_i / eta
    tir = sin_t >= 1.0
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin_t**2))
    with np.errstate(invalid="ignore", divide="ignore"):
        r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
        r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(tir, 1.0, 0.5 * (r_s**2 + r_p**2))


def transmittance_reference(cos_i, eta):
    """Slow reference: power transmittances (eta cos_t/cos_i) |t|^2 with Snell's law."""
    cos_i = np.asarray(cos_i, dtype=np.float64)
    sin_t = np.sqrt(1.0 - cos_i**2) / eta
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin_t**2))
    t_s = 2.0 * cos_i / (cos_i + eta * cos_t)
    t_p = 2.0 * cos_i / (eta * cos_i + cos_t)
    return np.where(sin_t >= 1.0, 0.0, 0.5 * eta * cos_t / cos_i * (t_s**2 + t_p**2))


def r_e_quad(eta, integrand=fr.fresnel_dielectric):
    """r_e = int_0^{pi/2} F(cos t) sin 2t dt = int_0^1 F(c) 2c dc (IL eq. 10), by quad.

    F rises to 1 for c below ~sqrt(eta^2 - 1): break points at that scale."""
    scale = np.sqrt((eta - 1.0) * (eta + 1.0))
    points = [p for p in scale * np.array([0.3, 1.0, 3.0, 10.0, 30.0]) if 0.0 < p < 1.0]
    value, _ = quad(lambda c: 2.0 * c * integrand(c, eta), 0.0, 1.0, points=points or None,
                    epsabs=0.0, epsrel=1e-13, limit=500)
    return value


# ----------------------------------------------------------------------------- F, T


def test_fresnel_matches_snell_reference_outside():
    rng = np.random.default_rng(1)
    cos = rng.uniform(0.0, 1.0, 4000)
    eta = np.exp(rng.uniform(0.0, np.log(1000.0), 4000))
    got = np.array([fr.fresnel_dielectric(c, e) for c, e in zip(cos, eta)])
    np.testing.assert_allclose(got, fresnel_reference(cos, eta), rtol=1e-12, atol=1e-14)


def test_fresnel_matches_snell_reference_inside_with_tir():
    rng = np.random.default_rng(2)
    cos = rng.uniform(0.0, 1.0, 4000)
    eta = rng.uniform(0.05, 1.0, 4000)
    got = np.array([fr.fresnel_dielectric(c, e) for c, e in zip(cos, eta)])
    np.testing.assert_allclose(got, fresnel_reference(cos, eta), rtol=1e-12, atol=1e-14)
    tir = np.sqrt(1.0 - cos**2) > eta
    assert tir.sum() > 1000
    assert np.all(got[tir] == 1.0)
    t_tir = [fr.fresnel_transmittance(c, e) for c, e in zip(cos[tir], eta[tir])]
    assert np.all(np.array(t_tir) == 0.0)


def test_transmittance_matches_reference_and_complements_f():
    rng = np.random.default_rng(3)
    cos = rng.uniform(1e-6, 1.0, 4000)
    eta = np.exp(rng.uniform(np.log(0.05), np.log(1e4), 4000))
    t = np.array([fr.fresnel_transmittance(c, e) for c, e in zip(cos, eta)])
    f = np.array([fr.fresnel_dielectric(c, e) for c, e in zip(cos, eta)])
    # relative: T keeps precision where it is tiny (large eta), unlike 1 - F
    np.testing.assert_allclose(t, transmittance_reference(cos, eta), rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(f + t, 1.0, rtol=0.0, atol=1e-15)


def test_fresnel_range_and_edge_cosines():
    etas = [1e-3, 0.5, 1.0 - 1e-12, 1.0, 1.0 + 1e-12, 1.0 + 1e-6, 1.5, 1e3, 1e8]
    cosines = np.concatenate([[0.0, 1e-300, 1e-12, 1.0 - 1e-16, 1.0],
                              np.linspace(0.0, 1.0, 1001)])
    for eta in etas:
        f = fr.fresnel_dielectric_array(cosines, eta)
        t = fr.fresnel_transmittance_array(cosines, eta)
        assert np.all(np.isfinite(f)) and np.all(np.isfinite(t))
        assert np.all((f >= 0.0) & (f <= 1.0)) and np.all((t >= 0.0) & (t <= 1.0))
        if eta != 1.0:
            assert fr.fresnel_dielectric(0.0, eta) == 1.0  # grazing: total reflection
            assert fr.fresnel_transmittance(0.0, eta) == 0.0


def test_fresnel_normal_incidence():
    for eta in [1.0 + 1e-9, 1.1, 1.5, 2.0, 1e3, 0.7]:
        expected = ((eta - 1.0) / (eta + 1.0)) ** 2
        assert fr.fresnel_dielectric(1.0, eta) == pytest.approx(expected, rel=1e-13)


def test_fresnel_exact_zero_and_continuity_at_eta_one():
    cos = np.linspace(0.0, 1.0, 101)
    assert np.all(fr.fresnel_dielectric_array(cos, 1.0) == 0.0)  # also at cos = 0
    assert np.all(fr.fresnel_transmittance_array(cos, 1.0) == 1.0)
    for eta in (1.0 + 1e-12, 1.0 - 1e-12):
        # F ~ ((eta-1)/(2c))^2 away from grazing: continuous, no 0/0 noise
        f = fr.fresnel_dielectric_array(cos[1:], eta)
        assert np.all(f <= 1e-24 / cos[1:] ** 4)
    # and it grows smoothly: F(c, 1+d)/d^2 has a finite limit
    deltas = [(1.0 + d) - 1.0 for d in (1e-6, 1e-9, 1e-12)]  # representable eta - 1
    ratio = [fr.fresnel_dielectric(0.5, 1.0 + d) / d**2 for d in deltas]
    np.testing.assert_allclose(ratio, ratio[-1], rtol=1e-5)


def test_array_versions_equal_scalar_and_keep_shape():
    cos = np.random.default_rng(4).uniform(0.0, 1.0, (7, 3))
    f = fr.fresnel_dielectric_array(cos, 1.33)
    t = fr.fresnel_transmittance_array(cos, 1.33)
    assert f.shape == (7, 3) and t.shape == (7, 3)
    assert np.array_equal(f, np.vectorize(fr.fresnel_dielectric)(cos, 1.33))
    assert np.array_equal(t, np.vectorize(fr.fresnel_transmittance)(cos, 1.33))
    assert fr.fresnel_dielectric_array(0.5, 1.5).shape == ()


# ----------------------------------------------------------------------------- r_e


def _regular_part_taylor(n_terms):
    """Exact Taylor coefficients c_1..c_n of the regular part of IL eq. 10 in d = eta-1.

    R = 1/2 + d(4+3d)/(6(2+d)^2) + [-2 eta^3 (eta^2+2eta-1)/((eta^2+1) P)
        + 8 eta^4 (eta^4+1) (ln(1+d)/d)/((eta^2+1) P^2)] / d,  with P = (eta^4-1)/d."""
    m = n_terms + 3

    def series(coeffs):
        return [Fraction(c) for c in coeffs] + [Fraction(0)] * (m - len(coeffs))

    def mul(a, b):
        return [sum(a[i] * b[k - i] for i in range(k + 1)) for k in range(m)]

    def inv(a):
        b = [Fraction(0)] * m
        b[0] = 1 / a[0]
        for k in range(1, m):
            b[k] = -sum(a[j] * b[k - j] for j in range(1, k + 1)) / a[0]
        return b

    def add(*terms):
        return [sum(t[k] for t in terms) for k in range(m)]

    eta = series([1, 1])
    eta2 = mul(eta, eta)
    eta4 = mul(eta2, eta2)
    one = series([1])
    p = series([4, 6, 4, 1])
    log_over_d = [Fraction((-1) ** k, k + 1) for k in range(m)]
    pole = mul(mul(series([-2]), mul(mul(eta2, eta), add(eta2, eta, eta, series([-1])))),
               inv(mul(add(eta2, one), p)))
    log_eta = mul(mul(series([8]), mul(mul(eta4, add(eta4, one)), log_over_d)),
                  inv(mul(add(eta2, one), mul(p, p))))
    bracket = add(pole, log_eta)
    assert bracket[0] == 0  # the 1/d poles cancel
    smooth = mul(series([0, 4, 3]), inv(mul(series([6]), mul(series([2, 1]), series([2, 1])))))
    regular = add(bracket[1:] + [Fraction(0)], smooth)
    regular[0] += Fraction(1, 2)
    assert regular[0] == 0  # r_e(1) = 0
    return regular[1 : n_terms + 1]


def test_taylor_coefficients_are_the_exact_ones_rounded():
    stored = fr._RE_REGULAR_TAYLOR
    exact = _regular_part_taylor(len(stored))
    assert [float(c) for c in exact] == list(stored)


ETAS_NEAR_ONE = [1.0 + 1e-9, 1.0 + 1e-6, 1.001, 1.01, 1.019, 1.02, 1.021, 1.05]
ETAS_DENSE = list(np.linspace(1.0, 3.0, 41)[1:]) + [1.4 - 1e-9, 1.4 + 1e-9, 1.7, 2.9]


@pytest.mark.parametrize("eta", ETAS_NEAR_ONE + ETAS_DENSE)
def test_r_e_matches_quadrature(eta):
    expected = r_e_quad(eta)
    assert abs(fr.r_e(eta) - expected) <= 1e-9
    assert fr.r_e(eta) == pytest.approx(expected, rel=1e-11)


@pytest.mark.parametrize("eta", [4.0 - 1e-9, 4.0, 10.0, 100.0, 1000.0, 1e4])
def test_one_minus_r_e_at_large_eta_matches_quadrature_of_t(eta):
    # 1 - r_e = int_0^1 T(c) 2c dc: checks the complement branch to full relative precision
    expected = r_e_quad(eta, integrand=fr.fresnel_transmittance)
    assert fr.one_minus_r_i(eta) * eta**2 == pytest.approx(expected, rel=1e-11)


@pytest.mark.parametrize(
    "eta, value",
    [(1.1, 0.0251574), (1.33, 0.0659308), (1.5, 0.0917780), (2.0, 0.1605966), (3.0, 0.2762034)],
)
def test_r_e_reference_values(eta, value):
    assert abs(fr.r_e(eta) - value) <= 1e-7  # physics.md sec. 4 (7 digits quoted)


def test_r_e_exact_at_one_continuous_and_monotone():
    assert fr.r_e(1.0) == 0.0
    assert fr.one_minus_r_i(1.0) == 1.0 and fr.r_i(1.0) == 0.0
    eta_min = np.nextafter(1.0, 2.0)
    assert fr.r_e(eta_min) == pytest.approx((eta_min - 1.0) / 3.0, rel=1e-15)
    # slope 1/3 at eta = 1: r_e ~ (eta-1)/3
    assert fr.r_e(1.0 + 1e-9) == pytest.approx(1e-9 / 3.0, rel=1e-8)
    etas = np.concatenate([1.0 + np.geomspace(1e-12, 1.0, 400), np.linspace(1.0, 3.0, 2001),
                           1.4 + np.linspace(-1e-6, 1e-6, 201), 4.0 + np.linspace(-1e-6, 1e-6, 201),
                           np.geomspace(3.0, 1e6, 400)])
    etas = np.unique(etas)
    values = np.array([fr.r_e(e) for e in etas])
    assert np.all(np.diff(values) > 0.0)
    assert np.all((values >= 0.0) & (values < 1.0))
    # no jump at the branch switches (eta = 1.4 series/closed form, 4 closed form/complement)
    for switch in (1.0 + fr._RE_SERIES_MAX_DELTA, fr._RE_COMPLEMENT_MIN_ETA):
        below = fr.r_e(np.nextafter(switch, 0.0))
        assert abs(fr.r_e(switch) - below) <= 4e-16


def test_r_e_below_one_is_nan():
    assert np.isnan(fr.r_e(0.9)) and np.isnan(fr.one_minus_r_i(0.5))


# ----------------------------------------------------------------------------- r_i, a


def test_r_i_value_and_identity():
    assert abs(fr.r_i(1.5) - 0.5963458) <= 1e-7
    for eta in [1.0, 1.0 + 1e-9, 1.01, 1.33, 1.5, 2.0, 3.0, 10.0, 1e3, 1e6]:
        # eta^2 (1 - r_i) = 1 - r_e; the atol covers the rounding of 1 - r_e itself
        expected = 1.0 - fr.r_e(eta)
        assert eta**2 * fr.one_minus_r_i(eta) == pytest.approx(expected, rel=1e-14, abs=2.3e-16)
    # r_i -> 1 at large eta while 1 - r_i stays accurate: 1 - r_e ~ 16/(3 eta) (see module)
    assert fr.one_minus_r_i(1e8) * 1e24 == pytest.approx(16.0 / 3.0, rel=1e-6)


def test_emergence_probability_exact_limits():
    for eta in (1.0, 1.5, 1000.0, 1e30):
        assert fr.emergence_probability(1.0, eta) == 1.0
        assert fr.emergence_probability(0.0, eta) == 0.0
    kd = np.random.default_rng(5).uniform(0.0, 1.0, 2000)
    assert all(fr.emergence_probability(k, 1.0) == k for k in kd)


def test_emergence_probability_range_and_definition():
    rng = np.random.default_rng(6)
    kd = rng.uniform(0.0, 1.0, 2000)
    eta = np.exp(rng.uniform(0.0, np.log(1e4), 2000))
    a = np.array([fr.emergence_probability(k, e) for k, e in zip(kd, eta)])
    assert np.all((a >= 0.0) & (a <= 1.0))
    assert np.all(a <= kd * (1.0 + 1e-15))  # internal reflections can only lose light
    # definition a = kd (1 - r_i)/(1 - kd r_i), with r_i from a quadrature of r_e (IL).
    # Formed naively it loses ~eps eta^3 relative precision (1 - r_i ~ 5/eta^3), so it is
    # compared only for eta <= 30, where that is below 1e-11.
    kd, eta = kd[:300], np.exp(rng.uniform(0.0, np.log(30.0), 300))
    a = np.array([fr.emergence_probability(k, e) for k, e in zip(kd, eta)])
    r_i = 1.0 - (1.0 - np.array([r_e_quad(e) for e in eta])) / eta**2
    np.testing.assert_allclose(a, kd * (1.0 - r_i) / (1.0 - kd * r_i), rtol=1e-10)
