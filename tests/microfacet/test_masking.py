"""Masking: Smith Lambda, V-cavity G1/G2, Smith identity, weak white furnace.

physics.md sec. 2-3 and 8; H = Heitz 2014, W = Walter et al. 2007.  No test here is
statistical (all quadrature), so none has a false-positive rate.
"""

import math

import numpy as np
import pytest
from vcavity._numba.jit import njit  # caches where vcavity's own code does
from scipy import special

from vcavity.microfacet import beckmann, common, gaussian, ggx, phong, registry


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


@pytest.mark.parametrize("module", [beckmann, ggx, phong, gaussian])
def test_smith_lambda_edges(module):
    params = params_of(module, 0.3, 0.5) if module in (beckmann, ggx) else params_of(module, 0.3)
    assert module.smith_lambda(0.0, 0.0, 1.0, params) == 0.0
    assert module.smith_lambda(1e-30, 0.0, 1.0, params) == 0.0  # vz rounds to 1
    for vz in [0.0, -0.3, 5e-324, 1e-200, 1e-12]:
        lam = module.smith_lambda(math.sqrt(1.0 - vz * vz) if vz > 0 else 1.0, 0.0, vz, params)
        assert not math.isnan(lam) and lam >= 0.0
        assert common.g1_smith(lam) < 1e-3
    for vz in [0.1, 0.5, 0.99]:
        lam = module.smith_lambda(0.0, math.sqrt(1.0 - vz * vz), vz, params)
        assert lam >= 0.0 and not math.isnan(lam)


@njit(cache=True)
def _bound_rows(kind, v, params):
    out = np.empty(v.shape[0])
    for k in range(v.shape[0]):
        out[k] = registry.smith_lambda_bound(kind, v[k, 0], v[k, 1], v[k, 2], params)
    return out


@pytest.mark.parametrize("module", [beckmann, ggx])
@pytest.mark.parametrize(("ax", "ay"), [(0.05, 0.05), (0.6, 0.6), (0.2, 0.6), (2.0, 2.0)])
def test_smith_lambda_bound_bounds(module, ax, ay):
    """The walk's escape bound: >= Lambda (reference, scipy) everywhere, and as tight as
    A&S 7.1.13 makes it for Beckmann (within 1 + 1/(2 a^2) for a >= 2, 1.6 below); GGX's is
    Lambda itself (the registry's fallback)."""
    params = params_of(module, ax, ay)
    v = random_directions(np.random.default_rng(9), 4000, max_theta=math.radians(89.9))
    bound = _bound_rows(registry.kind_of(module.NAME), np.ascontiguousarray(v), params)
    theta, phi = np.arccos(v[:, 2]), np.arctan2(v[:, 1], v[:, 0])
    a = 1.0 / (np.sqrt(np.cos(phi) ** 2 * ax**2 + np.sin(phi) ** 2 * ay**2) * np.tan(theta))
    if module is beckmann:
        # (exp(-a^2)/(a sqrt(pi)) - erfc(a))/2 with erfc = erfcx exp(-a^2): relative error
        # ~ 2 a^2 ulp, where the textbook form (lambda_reference) loses everything once
        # Lambda < 1e-16
        ref = 0.5 * np.exp(-a * a) * (1.0 / (a * math.sqrt(math.pi)) - special.erfcx(a))
    else:
        ref = lambda_reference(module.NAME, v, ax, ay)
    keep = (ref > 1e-280) & (a < 20.0)  # the reference's terms have not underflowed
    assert np.all(bound[keep] >= ref[keep] * (1.0 - 1e-9))
    if module is ggx:
        np.testing.assert_allclose(bound, ref, rtol=1e-9, atol=1e-15)
        return
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


# ------------------------------------- positive projected area, Smith identity
def positive_projected_area(module, params, v, ax, ay, n=400):
    """int D(m) max(0, v.m) dw_m by quadrature in stretched slope polar coordinates.

    With s = (a_x rho cos psi, a_y rho sin psi) and m = normalize(-s, 1):
    D max(0, v.m) dw = D cos^4(theta_m) (v_z - k rho cos(psi - psi0))_+ d^2 s
    (dw = cos^3 theta d^2 s, H appendix A), k = |(v_x a_x, v_y a_y)|.  The
    positive part is exact: for rho < rho0 = v_z/k the whole circle, beyond it
    the arc |psi - psi0| > acos(rho0/rho); Gauss-Legendre on each piece.
    """
    k = math.hypot(v[0] * ax, v[1] * ay)
    psi0 = math.atan2(v[1] * ay, v[0] * ax)
    rho0 = v[2] / k
    x, w = np.polynomial.legendre.leggauss(n)
    t, wt = 0.5 * (x + 1.0), 0.5 * w

    def ring_integral(rho, w_rho, lo, hi):
        dpsi = lo[:, None] + (hi - lo)[:, None] * t[None, :]
        psi = psi0 + dpsi
        sx, sy = ax * rho[:, None] * np.cos(psi), ay * rho[:, None] * np.sin(psi)
        inv = 1.0 / np.sqrt(1.0 + sx * sx + sy * sy)
        m = np.stack([-sx * inv, -sy * inv, inv], axis=-1).reshape(-1, 3)
        d = rows("D", module, m, params).reshape(sx.shape)
        positive = np.maximum(v[2] - k * rho[:, None] * np.cos(dpsi), 0.0)
        f = d * inv**4 * positive * ax * ay * rho[:, None]
        return np.sum(np.sum(f * wt, axis=1) * (hi - lo) * w_rho)

    inner_rho, inner_w = rho0 * t, rho0 * wt
    inner = ring_integral(inner_rho, inner_w, np.zeros(n), np.full(n, 2.0 * math.pi))
    outer_rho = rho0 + t / (1.0 - t)
    outer_w = wt / (1.0 - t) ** 2
    delta0 = np.arccos(rho0 / outer_rho)
    outer = ring_integral(outer_rho, outer_w, delta0, 2.0 * math.pi - delta0)
    return inner + outer


VIEW_DIRECTIONS = [(0.3, 0.2), (1.0, 1.1), (math.radians(85.0), -0.6), (math.radians(89.0), 2.5)]


@pytest.mark.parametrize("module", [beckmann, ggx])
@pytest.mark.parametrize(("ax", "ay"), [(0.05, 0.05), (0.3, 0.3), (0.2, 0.6), (1.0, 1.0)])
def test_smith_identity(module, ax, ay):
    """int G1_S(v,m) max(0, v.m) D(m) dw = v.n (H eq. 38/43), G1_S = 1/(1 + Lambda(v))."""
    params = params_of(module, ax, ay)
    for theta_v, phi_v in VIEW_DIRECTIONS:
        v = direction(theta_v, phi_v)
        area = positive_projected_area(module, params, v, ax, ay)
        g1 = common.g1_smith(module.smith_lambda(*v, params))
        assert abs(g1 * area / v[2] - 1.0) < 1e-6


@pytest.mark.parametrize("exponent", [0.0, 2.0, 20.0, 200.0])
def test_phong_lambda_is_exact(exponent):
    """Phong's Lambda (the equal Student-t's, vcavity/microfacet/phong.py) satisfies the Smith
    identity int G1 max(0, v.m) D(m) dw = v.n (H eq. 38/43) with Phong's own D, by quadrature,
    to 1e-6; Walter's Beckmann-based form (W sec. 5.2), which it replaced, misses it by up to
    24 % at exponent 2, which this tolerance would catch."""
    params = params_of(phong, exponent)
    alpha_b = math.sqrt(2.0 / (exponent + 2.0))
    for theta_v in np.radians([10.0, 30.0, 50.0, 65.0, 75.0, 82.0, 86.0, 89.0]):
        v = direction(theta_v, 0.4)
        area = positive_projected_area(phong, params, v, alpha_b, alpha_b)
        g1 = common.g1_smith(phong.smith_lambda(*v, params))
        assert abs(g1 * area / v[2] - 1.0) < 1e-6


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


# ----------------------------------------------------- weak white furnace test
def weak_furnace(module, params, o, g1_kind, n_u=1200, n_phi=2400):
    """H eq. 36 by the midpoint rule over the whole sphere of i (port of H appendix C).

    int G1(o, h) D(h) / (4 |o.n|) dw_i, h = normalize(i + o); dw_i = du dphi, u = cos theta_i.
    """
    u = -1.0 + (np.arange(n_u) + 0.5) * (2.0 / n_u)
    phi = (np.arange(n_phi) + 0.5) * (2.0 * math.pi / n_phi)
    uu, pp = np.meshgrid(u, phi, indexing="ij")
    s = np.sqrt(1.0 - uu * uu)
    i = np.stack([s * np.cos(pp), s * np.sin(pp), uu], axis=-1).reshape(-1, 3)
    h = i + o
    h /= np.linalg.norm(h, axis=1)[:, None]
    if g1_kind == "vcavity":
        g1 = g1_vcavity_rows(np.broadcast_to(o, h.shape), h)
    else:
        g1 = common.g1_smith(module.smith_lambda(*o, params)) * (h @ o > 0.0)
    f = g1 * rows("D", module, h, params) / (4.0 * abs(o[2]))
    return f.sum() * (2.0 / n_u) * (2.0 * math.pi / n_phi)


FURNACE_CASES = [(beckmann, 0.3, 0.3), (beckmann, 0.2, 0.6), (ggx, 0.3, 0.3), (ggx, 0.2, 0.6)]
FURNACE_IDS = [f"{mod.NAME}-{ax}-{ay}" for mod, ax, ay in FURNACE_CASES]


@pytest.mark.parametrize(("module", "ax", "ay"), FURNACE_CASES, ids=FURNACE_IDS)
@pytest.mark.parametrize("g1_kind", ["vcavity", "smith"])
@pytest.mark.parametrize("theta_o_deg", [60.0, 85.0])
def test_weak_white_furnace(module, ax, ay, g1_kind, theta_o_deg):
    """H eq. 36 = 1 within 1e-3, at an oblique and a grazing (85 deg) direction.

    (The 1200 x 2400 grid reaches about 2e-4 at 85 deg, 5e-6 at 60 deg.)"""
    o = direction(math.radians(theta_o_deg), 0.5)
    value = weak_furnace(module, params_of(module, ax, ay), o, g1_kind)
    assert value == pytest.approx(1.0, abs=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize(("module", "ax", "ay"), FURNACE_CASES, ids=FURNACE_IDS)
@pytest.mark.parametrize("g1_kind", ["vcavity", "smith"])
@pytest.mark.parametrize("theta_o_deg", [0.0, 30.0, 75.0, 85.0, 88.0])
def test_weak_white_furnace_more_directions(module, ax, ay, g1_kind, theta_o_deg):
    """H eq. 36 = 1 within 1e-3 at more directions, on a finer grid."""
    o = direction(math.radians(theta_o_deg), 1.1)
    value = weak_furnace(module, params_of(module, ax, ay), o, g1_kind, n_u=2000, n_phi=4000)
    assert value == pytest.approx(1.0, abs=1e-3)
