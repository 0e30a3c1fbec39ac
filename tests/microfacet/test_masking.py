"""Masking: the closed-form Smith Lambda of Beckmann and GGX, Beckmann's Lambda bound and
Walter's fit, the Gaussian's divergent Lambda, V-cavity G1/G2 and the Smith forms
(vcavity/microfacet/common.py).

physics.md sec. 2-3 and 8; H = Heitz 2014, W = Walter et al. 2007. The generic checks of every
distribution (Lambda against the quadrature of Smith's definition, Lambda's contract at the
horizon, the weak white furnace, the Lambda bound where a module has one) are in
tests/microfacet/test_conformance.py. No test here is statistical (all quadrature), so none
has a false-positive rate.
"""

import math

import numpy as np
import pytest
from vcavity._numba.jit import njit  # caches where vcavity's own code does
from scipy import special

from vcavity.microfacet import beckmann, common, gaussian, ggx, registry


def params_of(module, *args):
    """Parameter array from the canonical values given in key order (alpha_x, alpha_y / ...)."""
    return module.params_from(dict(zip(registry.value_keys(module.NAME), args)))


def rows(op, module, vectors, params):
    """``op`` ("D", "smith_lambda") of ``module`` over the rows of an (N, 3) array."""
    return registry.evaluate(op, registry.kind_of(module.NAME), vectors, params)


@njit(cache=True)
def g1_vcavity_rows(v, m):
    """common.g1_vcavity over the rows of two (N, 3) arrays."""
    out = np.empty(m.shape[0])
    for k in range(m.shape[0]):
        out[k] = common.g1_vcavity(v[k, 0], v[k, 1], v[k, 2], m[k, 0], m[k, 1], m[k, 2])
    return out


@njit(cache=True)
def g2_vcavity_rows(i, o, m):
    """common.g2_vcavity over the rows of three (N, 3) arrays."""
    out = np.empty(m.shape[0])
    for k in range(m.shape[0]):
        out[k] = common.g2_vcavity(i[k, 0], i[k, 1], i[k, 2], o[k, 0], o[k, 1], o[k, 2], m[k, 0], m[k, 1], m[k, 2])
    return out


def direction(theta, phi):
    sin_theta = math.sin(theta)
    return np.array([sin_theta * math.cos(phi), sin_theta * math.sin(phi), math.cos(theta)])


def random_directions(rng, n, max_theta=math.pi / 2):
    theta = rng.uniform(0.0, max_theta, n)
    phi = rng.uniform(-math.pi, math.pi, n)
    sin_theta = np.sin(theta)
    return np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), np.cos(theta)], axis=1)


# ---------------------------------------------------------------- Smith Lambda
def lambda_reference(name, v, ax, ay):
    """Slow reference: H eq. 80 projected roughness from (theta, phi) then eq. 69 / 72."""
    theta = np.arccos(v[:, 2])
    phi = np.arctan2(v[:, 1], v[:, 0])
    alpha_o = np.sqrt(np.cos(phi) ** 2 * ax**2 + np.sin(phi) ** 2 * ay**2)
    a = 1.0 / (alpha_o * np.tan(theta))
    if name == "beckmann":
        return (special.erf(a) - 1.0) / 2.0 + np.exp(-a * a) / (2.0 * a * np.sqrt(np.pi))
    return (-1.0 + np.sqrt(1.0 + 1.0 / a**2)) / 2.0


@pytest.mark.parametrize("module", [beckmann, ggx])
@pytest.mark.parametrize(
    ("ax", "ay"), [(0.05, 0.05), (0.3, 0.3), (0.2, 0.6), (1.0, 0.4), (2.0, 2.0)]
)
def test_smith_lambda_against_reference(module, ax, ay):
    params = params_of(module, ax, ay)
    v = random_directions(np.random.default_rng(5), 2000, max_theta=math.radians(89.9))
    got = rows("smith_lambda", module, v, params)
    ref = lambda_reference(module.NAME, v, ax, ay)
    # the textbook forms (erf(a) - 1, sqrt(1 + b) - 1) cancel for small Lambda: absolute
    # error ~1e-16 there, which is what atol allows; the implementation avoids it
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-15)
    assert np.all(got >= 0.0)


@njit(cache=True)
def _bound_rows(kind, v, params):
    out = np.empty(v.shape[0])
    for k in range(v.shape[0]):
        out[k] = registry.smith_lambda_bound(kind, v[k, 0], v[k, 1], v[k, 2], params)
    return out


@pytest.mark.parametrize("module", [beckmann])
@pytest.mark.parametrize(("ax", "ay"), [(0.05, 0.05), (0.6, 0.6), (0.2, 0.6), (2.0, 2.0)])
def test_smith_lambda_bound_bounds(module, ax, ay):
    """Beckmann's escape bound: >= Lambda (reference, scipy) everywhere, and as tight as
    A&S 7.1.13 makes it (within 1 + 1/(2 a^2) for a >= 2, 1.6 below). (That every bound is
    >= its Lambda, and the registry's fallback is Lambda itself, is checked for every
    distribution in tests/microfacet/test_conformance.py.)"""
    params = params_of(module, ax, ay)
    v = random_directions(np.random.default_rng(9), 4000, max_theta=math.radians(89.9))
    bound = _bound_rows(registry.kind_of(module.NAME), np.ascontiguousarray(v), params)
    theta, phi = np.arccos(v[:, 2]), np.arctan2(v[:, 1], v[:, 0])
    a = 1.0 / (np.sqrt(np.cos(phi) ** 2 * ax**2 + np.sin(phi) ** 2 * ay**2) * np.tan(theta))
    # (exp(-a^2)/(a sqrt(pi)) - erfc(a))/2 with erfc = erfcx exp(-a^2): relative error
    # ~ 2 a^2 ulp, where the textbook form (lambda_reference) loses everything once
    # Lambda < 1e-16
    ref = 0.5 * np.exp(-a * a) * (1.0 / (a * math.sqrt(math.pi)) - special.erfcx(a))
    keep = (ref > 1e-280) & (a < 20.0)  # the reference's terms have not underflowed
    assert np.all(bound[keep] >= ref[keep] * (1.0 - 1e-9))
    big = keep & (a >= 2.0)
    assert np.all(bound[big] <= ref[big] * (1.0 + 0.5 / a[big] ** 2) * (1.0 + 1e-6))
    assert np.all(bound[keep & (a < 2.0)] <= 1.6 * ref[keep & (a < 2.0)])


@pytest.mark.parametrize(("ax", "ay"), [(0.3, 0.3), (0.2, 0.6)])
def test_walter_fit_within_stated_error(ax, ay):
    """W eq. 27: G1 of the rational fit within 0.35 % of exact (checked at < 0.4 %)."""
    params = params_of(beckmann, ax, ay)
    theta = np.linspace(1e-3, math.pi / 2 - 1e-6, 4000)
    for phi in [0.0, 0.7, math.pi / 2]:
        v = np.array([direction(t, phi) for t in theta])
        g_exact = 1.0 / (1.0 + rows("smith_lambda", beckmann, v, params))
        lam_fit = np.array([beckmann.smith_lambda_walter_fit(*row, params) for row in v])
        g_fit = 1.0 / (1.0 + lam_fit)
        assert np.max(np.abs(g_fit / g_exact - 1.0)) < 4e-3


def test_gaussian_smith_lambda_diverges():
    """D ~ C exp(-pi^2/(8 sigma^2))/cos theta_m at the horizon, so the positive projected
    area truncated at cos theta_m = eps grows like A ln(1/eps) with
    A = 2 C sin(theta_v) exp(-pi^2/(8 sigma^2)): Lambda = inf is the exact answer."""
    sigma, theta_v = 1.0, math.radians(60.0)
    params = params_of(gaussian, sigma)
    v = direction(theta_v, 0.0)

    def truncated_area(eps):
        # theta_m integral of D sin(theta_m) times the exact phi integral of max(0, v.m)
        x, w = np.polynomial.legendre.leggauss(200)
        u = 0.5 * (x + 1.0) * (math.log(1.0 / eps))  # u = -ln cos theta_m, dtheta = cot(theta) du
        theta = np.arccos(np.exp(-u))
        c = math.cos(theta_v) * np.cos(theta)
        s = math.sin(theta_v) * np.sin(theta)
        phi0 = np.arccos(np.clip(-c / np.maximum(s, 1e-300), -1.0, 1.0))
        phi_int = np.where(s > 0, 2.0 * (s * np.sin(phi0) + c * phi0), 2.0 * math.pi * c)
        m = np.stack([np.sin(theta), 0.0 * theta, np.cos(theta)], axis=1)
        d = rows("D", gaussian, m, params)
        integrand = d * np.sin(theta) * phi_int / np.tan(np.maximum(theta, 1e-300))
        return np.sum(integrand * 0.5 * w * math.log(1.0 / eps))

    slope = 2.0 * params[1] * math.sin(theta_v) * math.exp(-(math.pi**2) / (8.0 * sigma**2))
    grow = truncated_area(1e-12) - truncated_area(1e-6)
    assert grow == pytest.approx(slope * math.log(1e6), rel=1e-4)
    assert gaussian.smith_lambda(*v, params) == math.inf
    assert common.g1_smith(gaussian.smith_lambda(*v, params)) == 0.0


# ------------------------------------------------------------------ V-cavity
def g1_vcavity_reference(v, m):
    """H eq. 49 / IL eq. 14 in plain NumPy."""
    vm = np.sum(v * m, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.minimum(1.0, 2.0 * m[:, 2] * v[:, 2] / vm)
    return np.where(vm > 0.0, np.maximum(g, 0.0), 0.0)


def test_g1_g2_vcavity_against_reference():
    rng = np.random.default_rng(9)
    v = random_directions(rng, 5000, max_theta=math.pi)  # includes v below the horizon
    o = random_directions(rng, 5000)
    m = random_directions(rng, 5000)
    g = g1_vcavity_rows(v, m)
    np.testing.assert_allclose(g, g1_vcavity_reference(v, m), rtol=1e-14, atol=0)
    assert np.all((g >= 0.0) & (g <= 1.0))
    assert np.all(g[np.sum(v * m, axis=1) <= 0.0] == 0.0)
    assert np.any(g == 1.0) and np.any((g > 0.0) & (g < 1.0))
    g2 = g2_vcavity_rows(v, o, m)
    np.testing.assert_array_equal(g2, np.minimum(g, g1_vcavity_rows(o, m)))
    assert common.g1_vcavity(*m[0], *m[0]) == 1.0  # a facet seen head-on is visible
    for theta_v in np.radians([10.0, 45.0, 70.0, 80.0, 89.0]):
        v1 = direction(theta_v, 0.3)
        # m halfway between n and v: v.m = m.n, so G1_V = min(1, 2 cos theta_v)
        g_half = common.g1_vcavity(*v1, *direction(0.5 * theta_v, 0.3))
        assert g_half == pytest.approx(min(1.0, 2.0 * math.cos(theta_v)), rel=1e-12)
        # m tilted away from v by more than 90 deg - theta_v: backfacing
        m_away = direction(math.pi / 2 - theta_v + 0.01, 0.3 + math.pi)
        assert common.g1_vcavity(*v1, *m_away) == 0.0


def test_smith_forms():
    """H eq. 43, 98, 99; height-correlated >= separable, both <= min(G1)."""
    lam = np.random.default_rng(4).exponential(1.0, (1000, 2))
    for li, lo in lam:
        sep = common.g2_smith_separable(li, lo)
        cor = common.g2_smith_height_correlated(li, lo)
        assert sep == pytest.approx(common.g1_smith(li) * common.g1_smith(lo), rel=1e-15)
        assert cor == pytest.approx(1.0 / (1.0 + li + lo), rel=1e-15)
        assert sep <= cor <= min(common.g1_smith(li), common.g1_smith(lo))
    assert common.g1_smith(0.0) == 1.0 and common.g1_smith(math.inf) == 0.0
    assert common.g2_smith_height_correlated(math.inf, 0.2) == 0.0
