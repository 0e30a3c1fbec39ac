"""Single-bounce models against slow, obviously-correct NumPy references (physics.md sec. 2-4, 7).

The references below are written from the formulas of physics.md directly, one point
at a time, with no project code except the config dataclass.
"""

import math

import numpy as np
import pytest
from numba import literally
from scipy import integrate

from vcavity._numba.jit import njit  # caches where vcavity's own code does

from vcavity.analytic.single_bounce import ModelNotApplicable, SingleBounceModel, flat_body_brdf
from vcavity.analytic.terms import accurate_transmittance_table, table_transmittance
from vcavity.config import validate
from vcavity.facet import registry as facets
from vcavity.facet.fresnel import fresnel_transmittance


def material(**kw):
    return validate({"material": kw}).material


# ------------------------------------------------------------------ slow references
def ref_fresnel(c, eta):
    """W eq. 22 as printed."""
    if eta == 1.0:
        return 0.0
    g = math.sqrt(eta * eta - 1.0 + c * c)
    return 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1.0 + (c * (g + c) - 1.0) ** 2 / (c * (g - c) + 1.0) ** 2)


def ref_fresnel_vec(c, eta):
    """W eq. 22 as printed, vectorised."""
    if eta == 1.0:
        return np.zeros_like(c)
    g = np.sqrt(eta * eta - 1.0 + c * c)
    return 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1.0 + (c * (g + c) - 1.0) ** 2 / (c * (g - c) + 1.0) ** 2)


def ref_r_e(eta):
    """∫ F(cos t) sin 2t dt by a dense midpoint rule."""
    t = (np.arange(200000) + 0.5) * (0.5 * math.pi / 200000)
    return float(np.sum(ref_fresnel_vec(np.cos(t), eta) * np.sin(2 * t)) * (0.5 * math.pi / 200000))


def gaussian_norm(sigma):
    t = (np.arange(200000) + 0.5) * (0.5 * math.pi / 200000)
    return 1.0 / (2 * math.pi * np.sum(np.exp(-t * t / (2 * sigma * sigma)) * np.sin(t)) * (0.5 * math.pi / 200000))


def ref_D(m, dist, p):
    """physics.md sec. 2, in polar form."""
    if m[2] <= 0:
        return 0.0
    theta = math.acos(min(1.0, m[2]))
    phi = math.atan2(m[1], m[0])
    c4 = math.cos(theta) ** 4
    if dist == "beckmann":
        e = math.tan(theta) ** 2 * (math.cos(phi) ** 2 / p["ax"] ** 2 + math.sin(phi) ** 2 / p["ay"] ** 2)
        return math.exp(-e) / (math.pi * p["ax"] * p["ay"] * c4)
    if dist == "ggx":
        e = math.tan(theta) ** 2 * (math.cos(phi) ** 2 / p["ax"] ** 2 + math.sin(phi) ** 2 / p["ay"] ** 2)
        return 1.0 / (math.pi * p["ax"] * p["ay"] * c4 * (1.0 + e) ** 2)
    if dist == "phong":
        return (p["e"] + 2) / (2 * math.pi) * math.cos(theta) ** p["e"]
    return p["C"] * math.exp(-theta * theta / (2 * p["sigma"] ** 2)) / math.cos(theta)


def ref_lambda_phong(a, e):
    """Smith Lambda of Phong by quadrature: ``(1/a) int_a^inf (q - a) P2(q) dq`` (H eq. 43), with
    Phong's marginal slope density ``P2(q) = (e + 2)/(2 pi) sqrt(pi) G(e/2 + 3/2)/G(e/2 + 2)
    (1 + q^2)^-(e + 3)/2`` (from ``P22 = D cos^4 = (e + 2)/(2 pi) (1 + |s|^2)^-(e/2 + 2)``)."""
    norm = (e + 2) / (2 * math.pi) * math.sqrt(math.pi) * math.exp(math.lgamma(0.5 * e + 1.5) - math.lgamma(0.5 * e + 2))
    tail = integrate.quad(lambda q: (q - a) * norm * (1 + q * q) ** (-0.5 * (e + 3)), a, math.inf,
                          epsabs=0.0, epsrel=1e-12, limit=200)[0]
    return tail / a


def ref_lambda(v, dist, p, fit=False):
    """H eq. 69, 72, 80; W eq. 27 (fit); Phong by quadrature (:func:`ref_lambda_phong`)."""
    theta = math.acos(v[2])
    if theta == 0:
        return 0.0
    phi = math.atan2(v[1], v[0])
    if dist == "phong":
        return ref_lambda_phong(1.0 / math.tan(theta), p["e"])
    alpha_o = math.sqrt(math.cos(phi) ** 2 * p["ax"] ** 2 + math.sin(phi) ** 2 * p["ay"] ** 2)
    a = 1.0 / (alpha_o * math.tan(theta))
    if dist == "ggx":
        return (-1 + math.sqrt(1 + 1 / (a * a))) / 2
    if fit:
        return 0.0 if a >= 1.6 else (1 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
    return (math.erf(a) - 1) / 2 + math.exp(-a * a) / (2 * a * math.sqrt(math.pi))


def ref_g1_v(v, m):
    vm = np.dot(v, m)
    return 0.0 if vm <= 0 else max(0.0, min(1.0, 2 * m[2] * v[2] / vm))


def ref_g2(i, o, m, masking, dist, p, fit=False):
    if np.dot(i, m) <= 0 or np.dot(o, m) <= 0:
        return 0.0
    if masking == "vcavity":
        return min(ref_g1_v(i, m), ref_g1_v(o, m))
    li, lo = ref_lambda(i, dist, p, fit), ref_lambda(o, dist, p, fit)
    return 1 / ((1 + li) * (1 + lo)) if masking == "smith" else 1 / (1 + li + lo)


def ref_specular(i, o, dist, p, eta, masking, mirror=False, fit=False):
    """W eq. 20."""
    h = (i + o) / np.linalg.norm(i + o)
    f = 1.0 if mirror else ref_fresnel(np.dot(i, h), eta)
    return f * ref_D(h, dist, p) * ref_g2(i, o, h, masking, dist, p, fit) / (4 * i[2] * o[2])


def ref_D_vec(m, dist, p):
    """physics.md sec. 2, in polar form, vectorised over rows of m (m_z > 0)."""
    theta = np.arccos(np.minimum(1.0, m[:, 2]))
    phi = np.arctan2(m[:, 1], m[:, 0])
    c4 = np.cos(theta) ** 4
    if dist in ("beckmann", "ggx"):
        e = np.tan(theta) ** 2 * (np.cos(phi) ** 2 / p["ax"] ** 2 + np.sin(phi) ** 2 / p["ay"] ** 2)
        if dist == "beckmann":
            return np.exp(-e) / (math.pi * p["ax"] * p["ay"] * c4)
        return 1.0 / (math.pi * p["ax"] * p["ay"] * c4 * (1.0 + e) ** 2)
    if dist == "phong":
        return (p["e"] + 2) / (2 * math.pi) * np.cos(theta) ** p["e"]
    return p["C"] * np.exp(-theta * theta / (2 * p["sigma"] ** 2)) / np.cos(theta)


def ref_body(i, o, dist, p, kd, eta, masking, n_theta=1200, n_phi=1200):
    """IL eq. 12 by a midpoint rule in (theta_m, phi_m) over the hemisphere of normals."""
    theta = (np.arange(n_theta) + 0.5) * (0.5 * math.pi / n_theta)
    phi = (np.arange(n_phi) + 0.5) * (2 * math.pi / n_phi)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    m = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    dw = (np.sin(tt) * (0.5 * math.pi / n_theta) * (2 * math.pi / n_phi)).ravel()
    im, om = m @ i, m @ o
    keep = (im > 0) & (om > 0)
    m, dw, im, om = m[keep], dw[keep], im[keep], om[keep]
    if masking == "vcavity":
        g = np.minimum(np.minimum(1.0, 2 * m[:, 2] * i[2] / im), np.minimum(1.0, 2 * m[:, 2] * o[2] / om))
    else:
        li, lo = ref_lambda(i, dist, p), ref_lambda(o, dist, p)
        g = 1 / ((1 + li) * (1 + lo)) if masking == "smith" else 1 / (1 + li + lo)
    r_i = 1 - (1 - ref_r_e(eta)) / eta**2 if eta != 1 else 0.0
    const = kd / (math.pi * eta * eta * (1 - kd * r_i))
    t_i, t_o = 1 - ref_fresnel_vec(im, eta), 1 - ref_fresnel_vec(om, eta)
    return const * np.sum(im * om / (i[2] * o[2]) * t_i * t_o * ref_D_vec(m, dist, p) * g * dw)


def random_direction(rng, max_theta_deg=85.0):
    ct = rng.uniform(math.cos(math.radians(max_theta_deg)), 1.0)
    ph = rng.uniform(0, 2 * math.pi)
    st = math.sqrt(1 - ct * ct)
    return np.array([st * math.cos(ph), st * math.sin(ph), ct])


CASES = [
    ("beckmann", dict(alpha_x=0.3, alpha_y=0.7), dict(ax=0.3, ay=0.7)),
    ("ggx", dict(alpha=0.5), dict(ax=0.5, ay=0.5)),
    ("ggx", dict(alpha_x=0.8, alpha_y=0.2), dict(ax=0.8, ay=0.2)),
    ("phong", dict(exponent=12.0), dict(e=12.0)),
    ("gaussian", dict(sigma=0.4), dict(sigma=0.4, C=gaussian_norm(0.4))),
]


@pytest.mark.parametrize("dist, params, ref_params", CASES)
@pytest.mark.parametrize("masking", ["vcavity", "smith", "smith-hc"])
def test_specular_matches_reference(dist, params, ref_params, masking):
    if dist == "gaussian" and masking != "vcavity":
        with pytest.raises(ModelNotApplicable):
            SingleBounceModel(material(distribution=dist, kd=0.0, eta=1.7, **params), masking=masking)
        return
    model = SingleBounceModel(material(distribution=dist, kd=0.0, eta=1.7, **params), masking=masking)
    rng = np.random.default_rng(11)
    for _ in range(25):
        i, o = random_direction(rng), random_direction(rng)
        expected = ref_specular(i, o, dist, ref_params, 1.7, masking)
        got = model.specular(i, o[None, :])[0]
        assert got == pytest.approx(expected, rel=1e-9, abs=1e-13)
        assert model.specular_projected(i, o[None, :])[0] == pytest.approx(expected * o[2], rel=1e-9, abs=1e-13)


def test_specular_mirror_and_walter_fit():
    rng = np.random.default_rng(3)
    mirror = SingleBounceModel(material(distribution="beckmann", alpha=0.4, facet="mirror"))
    fitted = SingleBounceModel(material(distribution="beckmann", alpha=0.4, kd=0.0, eta=1.5),
                               masking="smith", lambda_fit=True)
    p = dict(ax=0.4, ay=0.4)
    for _ in range(25):
        i, o = random_direction(rng), random_direction(rng)
        assert mirror.specular(i, o[None])[0] == pytest.approx(
            ref_specular(i, o, "beckmann", p, 1.0, "vcavity", mirror=True), rel=1e-9, abs=1e-13)
        assert fitted.specular(i, o[None])[0] == pytest.approx(
            ref_specular(i, o, "beckmann", p, 1.5, "smith", fit=True), rel=1e-9, abs=1e-13)
    with pytest.raises(ValueError):
        SingleBounceModel(material(distribution="ggx", alpha=0.4, kd=0.0, eta=1.5), lambda_fit=True)


@pytest.mark.parametrize("dist, params, ref_params, masking, kd, eta", [
    ("beckmann", dict(alpha=0.6), dict(ax=0.6, ay=0.6), "vcavity", 0.9, 1.5),
    ("ggx", dict(alpha_x=0.8, alpha_y=0.3), dict(ax=0.8, ay=0.3), "smith-hc", 0.5, 2.5),
    ("gaussian", dict(sigma=0.4), dict(sigma=0.4, C=gaussian_norm(0.4)), "vcavity", 1.0, 1.0),
    ("phong", dict(exponent=8.0), dict(e=8.0), "smith", 1.0, 1.33),
])
def test_body_matches_reference(dist, params, ref_params, masking, kd, eta):
    # The reference's midpoint rule (1500^2) is itself good to ~1e-5; the node
    # quadrature at the default n_nodes = 64 to ~1e-4 pointwise (module docstring).
    model = SingleBounceModel(material(distribution=dist, kd=kd, eta=eta, **params), masking=masking)
    rng = np.random.default_rng(5)
    for _ in range(3):
        i, o = random_direction(rng, 80), random_direction(rng, 80)
        expected = ref_body(i, o, dist, ref_params, kd, eta, masking)
        assert model.body(i, o[None])[0] == pytest.approx(expected, rel=3e-4)


def test_reciprocity_of_the_model():
    # f(i, o) = f(o, i): exact for the specular term, to the quadrature for the body.
    rng = np.random.default_rng(8)
    for masking in ("vcavity", "smith", "smith-hc"):
        model = SingleBounceModel(material(distribution="ggx", alpha_x=0.7, alpha_y=0.3, kd=0.8, eta=1.5),
                                  masking=masking)
        for _ in range(20):
            i, o = random_direction(rng), random_direction(rng)
            assert model.specular(i, o[None])[0] == pytest.approx(model.specular(o, i[None])[0], rel=1e-12)
            assert model.body(i, o[None])[0] == pytest.approx(model.body(o, i[None])[0], rel=3e-4)


def test_flat_and_lambert_limits():
    # alpha -> 0: the body integral tends to the flat IL body term (physics.md sec. 7)
    rng = np.random.default_rng(2)
    rough = SingleBounceModel(material(distribution="beckmann", alpha=1e-3, kd=0.7, eta=1.5))
    lambert = SingleBounceModel(material(distribution="beckmann", alpha=1e-3, kd=0.7, eta=1.0))
    for _ in range(10):
        i, o = random_direction(rng, 70), random_direction(rng, 70)
        flat = flat_body_brdf(i, o[None], rough.material)[0]
        assert rough.body(i, o[None])[0] == pytest.approx(flat, rel=2e-3)
        assert lambert.brdf(i, o[None])[0] == pytest.approx(0.7 / math.pi, rel=2e-3)
        # the flat body term K T(i.n) T(o.n) (IL eq. 4-8): reference form and reciprocity
        r_i = 1 - (1 - ref_r_e(1.5)) / 1.5**2
        expected = 0.7 / (math.pi * 1.5**2 * (1 - 0.7 * r_i)) * (1 - ref_fresnel(i[2], 1.5)) * (1 - ref_fresnel(o[2], 1.5))
        assert flat == pytest.approx(expected, rel=1e-9)
        assert flat == pytest.approx(flat_body_brdf(o, i[None], rough.material)[0], rel=1e-15)
    assert flat_body_brdf(np.array([0, 0, 1.0]), np.array([[0.6, 0, 0.8]]), lambert.material)[0] == pytest.approx(0.7 / math.pi)
    # mirror and specular dielectric facets have no body; below the horizon it is 0
    for m in (material(distribution="beckmann", alpha=0.3, facet="mirror"),
              material(distribution="beckmann", alpha=0.3, kd=0.0, eta=1.5)):
        assert flat_body_brdf(np.array([0, 0, 1.0]), np.array([[0.6, 0, 0.8]]), m)[0] == 0.0
    assert flat_body_brdf(np.array([0, 0, 1.0]), np.array([[0.6, 0, -0.8]]), lambert.material)[0] == 0.0


@njit(cache=True)
def _table_rows(c, table, facet_kind, facet_data):
    """table_transmittance over an array of cosines (facet_kind a compile-time constant)."""
    literally(facet_kind)
    out = np.empty(c.shape[0])
    for k in range(c.shape[0]):
        out[k] = table_transmittance(c[k], table, facet_kind, facet_data)
    return out


def test_transmittance_table():
    # the cubic table is used only where it is within 1e-11 of the closed form
    rng = np.random.default_rng(4)
    c = np.concatenate([rng.random(3000), [0.0, 1e-12, 0.5, 1.0]])
    for eta in (1.0, 1.0001, 1.01, 1.03, 1.5, 2.5, 10.0, 1e4):
        values = {"kd": 0.5, "eta": eta}
        kind, _, data = facets.prepare("interfaced_lambertian", values)
        table = accurate_transmittance_table(kind, data, facets.has_specular("interfaced_lambertian", values))
        assert (table.shape[0] > 0) == (eta in (1.03, 1.5, 2.5))
        worst = np.max(np.abs(_table_rows(c, table, kind, data) - np.array([fresnel_transmittance(x, eta) for x in c])))
        assert worst < 1e-11
    # a mirror transmits nothing: no table, T = 0
    kind, _, data = facets.prepare("mirror", {})
    table = accurate_transmittance_table(kind, data, facets.has_specular("mirror", {}))
    np.testing.assert_array_equal(_table_rows(c, table, kind, data), 0.0)


def test_model_validation():
    m = material(distribution="beckmann", alpha=0.5, kd=0.5, eta=1.5)
    with pytest.raises(ValueError):
        SingleBounceModel(m, masking="torrance")
    with pytest.raises(ValueError):
        SingleBounceModel(m, n_nodes=0)
    model = SingleBounceModel(m)
    below = np.array([[0.6, 0.0, -0.8]])
    assert model.brdf(np.array([0, 0, 1.0]), below)[0] == 0.0


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 15, 16, 17, 2047, 2048, 2049])
def test_ordered_sum_adds_every_term(n):
    """The body row sum's fixed-order addition (_ordered_sum) against math.fsum, for lengths
    around multiples of its eight partial sums (the tail included)."""
    from vcavity.analytic.single_bounce import _ordered_sum

    rng = np.random.default_rng(n)
    terms = rng.uniform(0.0, 1.0, n) * rng.choice([1e-8, 1.0, 1e3], n)
    exact = math.fsum(terms)
    assert abs(_ordered_sum(terms) - exact) <= 1e-14 * max(exact, 1.0)
