"""Oren-Nayar (physics.md sec. 7) and Walter's rough dielectric BSDF (W eq. 20-21)
against slow scalar references and exact identities."""

import math

import numpy as np
import pytest

from vcavity.analytic.albedo import hemispherical_albedo
from vcavity.analytic.oren_nayar import LambertModel, OrenNayarModel, oren_nayar_brdf
from vcavity.analytic.single_bounce import ModelNotApplicable, SingleBounceModel
from vcavity.analytic.walter import WalterDielectric
from vcavity.config import validate


def material(**kw):
    return validate({"material": kw}).material


def spherical(theta, phi):
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])


def ref_oren_nayar(ti, pi_, to, po, sigma, rho):
    """Oren & Nayar 1994, full model, one point (physics.md sec. 7)."""
    s2 = sigma * sigma
    a, b = max(ti, to), min(ti, to)
    cd = math.cos(po - pi_)
    c1 = 1 - 0.5 * s2 / (s2 + 0.33)
    if cd >= 0:
        c2 = 0.45 * s2 / (s2 + 0.09) * math.sin(a)
    else:
        c2 = 0.45 * s2 / (s2 + 0.09) * (math.sin(a) - (2 * b / math.pi) ** 3)
    c3 = 0.125 * s2 / (s2 + 0.09) * (4 * a * b / math.pi**2) ** 2
    l1 = rho / math.pi * (c1 + cd * c2 * math.tan(b) + (1 - abs(cd)) * c3 * math.tan((a + b) / 2))
    l2 = 0.17 * rho**2 / math.pi * s2 / (s2 + 0.13) * (1 - cd * (2 * b / math.pi) ** 2)
    return l1 + l2


def test_oren_nayar_matches_reference_and_is_symmetric():
    rng = np.random.default_rng(7)
    for _ in range(200):
        ti, to = rng.uniform(0.01, 1.5, 2)
        pi_, po = rng.uniform(0, 2 * math.pi, 2)
        sigma, rho = rng.uniform(0.05, 1.0), rng.uniform(0, 1)
        i, o = spherical(ti, pi_), spherical(to, po)
        got = oren_nayar_brdf(i, o[None], sigma, rho)[0]
        assert got == pytest.approx(ref_oren_nayar(ti, pi_, to, po, sigma, rho), rel=1e-12)
        assert got == pytest.approx(oren_nayar_brdf(o, i[None], sigma, rho)[0], rel=1e-12)


def test_oren_nayar_limits_and_applicability():
    i, o = spherical(0.4, 0.0), spherical(1.0, 2.0)
    # sigma = 0: Lambert rho/pi; normal incidence: no azimuth dependence
    assert oren_nayar_brdf(i, o[None], 0.0, 0.6)[0] == pytest.approx(0.6 / math.pi)
    n = np.array([0.0, 0.0, 1.0])
    values = oren_nayar_brdf(n, np.array([spherical(0.7, p) for p in np.linspace(0, 6, 7)]), 0.5, 0.8)
    np.testing.assert_allclose(values, values[0], rtol=1e-14)
    model = OrenNayarModel(material(distribution="gaussian", sigma=0.3, kd=0.8, eta=1.0))
    assert model.projected(i, o[None])[0] == pytest.approx(model.brdf(i, o[None])[0] * o[2])
    single = OrenNayarModel(model.material, interreflection=False)
    assert single.brdf(i, o[None])[0] < model.brdf(i, o[None])[0]
    for bad in (dict(distribution="ggx", alpha=0.3, kd=0.8, eta=1.0),
                dict(distribution="gaussian", sigma=0.3, kd=0.8, eta=1.5),
                dict(distribution="gaussian", sigma=0.3, facet="mirror")):
        with pytest.raises(ModelNotApplicable):
            OrenNayarModel(material(**bad))
    assert LambertModel(0.5).brdf(i, np.array([[0, 0, -1.0]]))[0] == 0.0


# ------------------------------------------------------------------ Walter
def ref_fresnel(c, eta):
    """W eq. 22 (eta relative index across; TIR -> 1)."""
    g2 = eta * eta - 1 + c * c
    if g2 < 0:
        return 1.0
    g = math.sqrt(g2)
    return 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1 + (c * (g + c) - 1) ** 2 / (c * (g - c) + 1) ** 2)


def ref_ggx_D(m, ax, ay):
    if m[2] <= 0:
        return 0.0
    t2 = (m[0] ** 2 / ax**2 + m[1] ** 2 / ay**2) / m[2] ** 2
    return 1 / (math.pi * ax * ay * m[2] ** 4 * (1 + t2) ** 2)


def ref_ggx_g1(v, m, ax, ay):
    """W eq. 34 generalised by stretching (H eq. 72, 80), with chi+(v.m / v.n)."""
    if np.dot(v, m) / v[2] <= 0:
        return 0.0
    r2 = v[0] ** 2 + v[1] ** 2
    if r2 == 0:
        return 1.0
    alpha2 = (v[0] ** 2 * ax**2 + v[1] ** 2 * ay**2) / r2
    tan2 = r2 / v[2] ** 2
    return 2 / (1 + math.sqrt(1 + alpha2 * tan2))


def ref_walter(i, o, eta, ax, ay):
    """W eq. 20-21, one point, Smith separable G."""
    eta_i = 1.0 if i[2] > 0 else eta
    eta_o = 1.0 if o[2] > 0 else eta
    if (i[2] > 0) == (o[2] > 0):
        h = np.sign(i[2]) * (i + o)
    else:
        h = -(eta_i * i + eta_o * o)
    h = h / np.linalg.norm(h)
    if h[2] < 0:
        h = -h
    f = ref_fresnel(abs(np.dot(i, h)), eta_o / eta_i if (i[2] > 0) != (o[2] > 0) else (eta if i[2] > 0 else 1 / eta))
    g = ref_ggx_g1(i, h, ax, ay) * ref_ggx_g1(o, h, ax, ay)
    d = ref_ggx_D(h, ax, ay)
    if (i[2] > 0) == (o[2] > 0):
        return f * d * g / (4 * abs(i[2] * o[2]))
    ih, oh = np.dot(i, h), np.dot(o, h)
    if ih * oh >= 0:
        return 0.0
    return abs(ih * oh) / abs(i[2] * o[2]) * eta_o**2 * (1 - f) * d * g / (eta_i * ih + eta_o * oh) ** 2


def random_sphere(rng):
    v = rng.normal(size=3)
    v /= np.linalg.norm(v)
    if abs(v[2]) < 0.05:
        v[2] = 0.05 * np.sign(v[2] or 1.0)
        v /= np.linalg.norm(v)
    return v


def test_walter_matches_reference_and_reciprocity():
    eta = 1.6
    w = WalterDielectric(material(distribution="ggx", alpha_x=0.3, alpha_y=0.6, kd=0.0, eta=eta))
    rng = np.random.default_rng(12)
    n_transmission = 0
    for _ in range(400):
        i, o = random_sphere(rng), random_sphere(rng)
        got = w.bsdf(i, o[None])[0]
        assert got == pytest.approx(ref_walter(i, o, eta, 0.3, 0.6), rel=1e-9, abs=1e-12)
        # reciprocity: f(i, o)/eta_o^2 = f(o, i)/eta_i^2 (W sec. 3)
        eta_i = 1.0 if i[2] > 0 else eta
        eta_o = 1.0 if o[2] > 0 else eta
        assert got / eta_o**2 == pytest.approx(w.bsdf(o, i[None])[0] / eta_i**2, rel=1e-9, abs=1e-12)
        n_transmission += (i[2] > 0) != (o[2] > 0) and got > 0
    assert n_transmission > 30
    # the reflection part is the single-bounce specular term with Smith G and kd = 0
    spec = SingleBounceModel(w.material, masking="smith")
    for _ in range(20):
        i, o = np.abs(random_sphere(rng)), np.abs(random_sphere(rng))
        assert w.brdf(i, o[None])[0] == pytest.approx(spec.specular(i, o[None])[0], rel=1e-12)
        assert w.btdf(i, o[None])[0] == 0.0


@pytest.mark.parametrize("theta_deg", [0.0, 40.0])
def test_walter_transmission_jacobian(theta_deg):
    # ∫ f_t |o.n| dω_o over the lower hemisphere equals the half-vector integral
    # ∫ (i.h)(1 - F) D G1(i,h) / (i.n) dω_h over the h that refract below the surface
    # (W eq. 17 Jacobian); masking of i only (shadowing=False), so G is o-independent.
    eta = 1.5
    mat = material(distribution="beckmann", alpha=0.4, kd=0.0, eta=eta)
    w = WalterDielectric(mat, shadowing=False)
    i = spherical(math.radians(theta_deg), 0.3)
    by_o = hemispherical_albedo(w, i, n_mu=400, n_phi=800, lower=True)
    # h-space midpoint quadrature in (theta_h, phi_h)
    n_t, n_p = 1000, 1000
    th = (np.arange(n_t) + 0.5) * (0.5 * math.pi / n_t)
    ph = (np.arange(n_p) + 0.5) * (2 * math.pi / n_p)
    tt, pp = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    dw = (np.sin(tt) * (0.5 * math.pi / n_t) * (2 * math.pi / n_p)).ravel()
    c = h @ i
    keep = c > 0
    h, dw, c = h[keep], dw[keep], c[keep]
    # refracted direction (W eq. 40) and its side
    root = np.sqrt(1 + (c * c - 1) / eta**2)
    o = (c / eta - root)[:, None] * h - i / eta
    below = o[:, 2] < 0
    d = np.exp(-np.tan(tt.ravel()[keep]) ** 2 / 0.16) / (math.pi * 0.16 * h[:, 2] ** 4)
    g1 = np.array([w._g1(i[None], hh[None])[0][0] for hh in h[::50]])  # spot check of G1 form
    assert np.all(g1 <= 1.0)
    lam = w._g1(np.broadcast_to(i, h.shape).copy(), h)[0]
    g = np.sqrt(eta * eta - 1 + c * c)  # W eq. 22, vectorised
    fres = 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1 + (c * (g + c) - 1) ** 2 / (c * (g - c) + 1) ** 2)
    by_h = np.sum((c * (1 - fres) * d * lam / i[2] * dw)[below])
    assert by_o == pytest.approx(by_h, rel=2e-3)
