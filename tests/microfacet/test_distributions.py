"""Distributions of normals: sampling, normalisation, edge cases (physics.md sec. 2, 8).

Statistical tests use fixed seeds; each chi-square test rejects at p < 1e-3, so
a correct sampler fails a given case with probability 1e-3 (about 1.4 % for
the 14 cases together, were the seeds redrawn).
"""

import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, optimize, stats

from vcavity.microfacet import beckmann, gaussian, ggx, phong, student_t
from vcavity.microfacet import registry


def values_of(module, args):
    """Canonical values (what ``params_from`` takes) from positional arguments, in the
    order of the distribution's canonical keys (alpha_x, alpha_y / exponent / sigma)."""
    keys = registry.value_keys(module.NAME)
    assert len(keys) == len(args), (module.NAME, keys, args)
    return dict(zip(keys, args))


@functools.lru_cache(maxsize=None)
def cached_params(name, args):
    """Gaussian tables are costly to build (~0.2 s): build each parameter set once."""
    module = registry.get(name)
    return module.params_from(values_of(module, args))


def gaussian_params(sigma):
    return cached_params("gaussian", (sigma,))


def kind(module):
    return registry.kind_of(module.NAME)


# (module, canonical values in key order, slope scale (x, y) for quadrature)
CASES = [
    (beckmann, (0.05, 0.05)),
    (beckmann, (0.3, 0.3)),
    (beckmann, (0.2, 0.6)),
    (beckmann, (1.0, 1.0)),
    (ggx, (0.05, 0.05)),
    (ggx, (0.3, 0.3)),
    (ggx, (0.2, 0.6)),
    (ggx, (1.0, 1.0)),
    (phong, (2.0,)),
    (phong, (20.0,)),
    (phong, (200.0,)),
    (gaussian, (0.1,)),
    (gaussian, (0.35,)),
    (gaussian, (1.0,)),
    (student_t, (0.3, 0.3, 1.8)),
    (student_t, (0.2, 0.6, 4.0)),
    (student_t, (0.8, 0.8, 30.0)),
]
CASE_IDS = [f"{mod.NAME}-{'-'.join(map(str, args))}" for mod, args in CASES]


def params_of(module, args):
    return cached_params(module.NAME, tuple(args))


def slope_scales(module, args):
    """Typical slope widths (stretching of H sec. 5), used to place quadrature nodes."""
    if module in (beckmann, ggx, student_t):
        return args[:2]
    if module is phong:
        scale = math.sqrt(2.0 / (args[0] + 2.0))  # W: similar to Beckmann of this alpha
        return scale, scale
    return math.tan(min(args[0], 1.0)), math.tan(min(args[0], 1.0))


def gauss_legendre(a, b, n):
    x, w = np.polynomial.legendre.leggauss(n)
    half = 0.5 * (b - a)
    return a + half * (x + 1.0), half * w


def normals_from_slopes(sx, sy):
    """m = normalize(-s_x, -s_y, 1) (H sec. 5) for arrays of slopes."""
    inv = 1.0 / np.sqrt(1.0 + sx * sx + sy * sy)
    return np.stack([-sx * inv, -sy * inv, inv], axis=-1).reshape(-1, 3), inv.ravel()


def hemisphere_integral_of_pdf_times(module, params, scales, weight_fn, n_rho=400, n_psi=64):
    """int pdf(m) weight(m) dw over stretched slope polar coordinates.

    s = (a_x rho cos psi, a_y rho sin psi), rho = t/(1-t), dw = cos^3 theta d^2 s
    (H appendix A), d^2 s = a_x a_y rho drho dpsi; Gauss-Legendre in t, trapezoid
    in psi (periodic).  Independent of the sampling code.
    """
    ax, ay = scales
    t, wt = gauss_legendre(0.0, 1.0, n_rho)
    rho = t / (1.0 - t)
    w_rho = wt / (1.0 - t) ** 2
    psi = (np.arange(n_psi) + 0.5) * (2.0 * math.pi / n_psi)
    rr, pp = np.meshgrid(rho, psi, indexing="ij")
    m, cos_theta = normals_from_slopes(ax * rr * np.cos(pp), ay * rr * np.sin(pp))
    integrand = registry.evaluate("pdf", kind(module), m, params) * cos_theta**3 * weight_fn(m)
    integrand = integrand.reshape(rr.shape) * (ax * ay) * rr
    return float(np.sum(integrand.sum(axis=1) * (2.0 * math.pi / n_psi) * w_rho))


EXTREME_CASES = [(gaussian, (1e-3,)), (gaussian, (2.0,)), (beckmann, (1e-3, 2e-3)), (ggx, (3.0, 0.01)),
                 (phong, (0.0,)), (phong, (1e5,))]


@pytest.mark.parametrize(
    ("module", "args"), CASES + EXTREME_CASES,
    ids=CASE_IDS + [f"{mod.NAME}-{'-'.join(map(str, args))}" for mod, args in EXTREME_CASES],
)
def test_normalisation_and_signed_projected_area(module, args):
    """int D(m)(m.n) dw = 1 (W eq. 4) and int D(m)(v.m) dw = v.n (W eq. 3)."""
    params = params_of(module, args)
    scales = slope_scales(module, args)
    total = hemisphere_integral_of_pdf_times(module, params, scales, lambda m: 1.0)
    assert abs(total - 1.0) < 1e-8
    for theta_v, phi_v in [(0.4, 0.3), (1.2, 2.0), (math.radians(85.0), -1.0)]:
        v = np.array([math.sin(theta_v) * math.cos(phi_v), math.sin(theta_v) * math.sin(phi_v),
                      math.cos(theta_v)])
        # (v.m)/(m.n) times pdf = D (v.m)
        proj = hemisphere_integral_of_pdf_times(module, params, scales, lambda m: (m @ v) / m[:, 2])
        assert abs(proj - v[2]) < 1e-8


def chi_square_pvalue(counts, expected):
    """Pearson chi-square p-value after pooling bins with expected count < 5."""
    order = np.argsort(expected)
    counts, expected = counts[order], expected[order]
    n_pool = int(np.count_nonzero(expected < 5.0))  # pool every bin below 5 ...
    while n_pool and expected[:n_pool].sum() < 5.0:  # ... plus the next ones if needed
        n_pool += 1
    if n_pool:
        counts = np.concatenate(([counts[:n_pool].sum()], counts[n_pool:]))
        expected = np.concatenate(([expected[:n_pool].sum()], expected[n_pool:]))
    assert np.all(expected >= 5.0)
    stat = np.sum((counts - expected) ** 2 / expected)
    return stats.chi2.sf(stat, df=len(counts) - 1)


@pytest.mark.parametrize(("module", "args"), CASES, ids=CASE_IDS)
def test_sampled_normals_chi_square(module, args):
    """Sampled m against D(m)(m.n) integrated over (cos theta_m, phi_m) bins (W eq. 24)."""
    params = params_of(module, args)
    n_samples, n_cos, n_phi = 200_000, 20, 16
    # cos-theta bin edges from a pilot sample with another seed: independent of the data
    pilot_rng = np.random.default_rng(11)
    pilot = registry.sample_normals(kind(module), pilot_rng.random(20_000), pilot_rng.random(20_000), params)
    inner = np.quantile(pilot[:, 2], np.linspace(0.0, 1.0, n_cos + 1)[1:-1])
    cos_edges = np.concatenate(([0.0], inner, [1.0]))
    phi_edges = np.linspace(-math.pi, math.pi, n_phi + 1)

    rng = np.random.default_rng(12345)
    m = registry.sample_normals(kind(module), rng.random(n_samples), rng.random(n_samples), params)
    counts, _, _ = np.histogram2d(m[:, 2], np.arctan2(m[:, 1], m[:, 0]), [cos_edges, phi_edges])

    # expected: int over the bin of pdf(m) dc dphi (dw = dc dphi), by Gauss-Legendre in
    # t = tan theta (dc = t (1 + t^2)^(-3/2) dt) and phi; the outermost cos bin [0, c_1]
    # (t from t_1 to infinity) via t = t_1/(1 - tau)
    t_edges = np.sqrt(1.0 - cos_edges**2) / np.maximum(cos_edges, 1e-300)
    prob = np.empty((n_cos, n_phi))
    for i in range(n_cos):
        if i == 0:
            tau, w_tau = gauss_legendre(0.0, 1.0, 64)
            t, wt = t_edges[1] / (1.0 - tau), w_tau * t_edges[1] / (1.0 - tau) ** 2
        else:
            t, wt = gauss_legendre(t_edges[i + 1], t_edges[i], 32)
        wc = wt * t / (1.0 + t * t) ** 1.5
        for j in range(n_phi):
            phi, wp = gauss_legendre(phi_edges[j], phi_edges[j + 1], 24)
            tt, pp = np.meshgrid(t, phi, indexing="ij")
            mm, _ = normals_from_slopes(-tt * np.cos(pp), -tt * np.sin(pp))
            prob[i, j] = np.sum(registry.evaluate("pdf", kind(module), mm, params).reshape(tt.shape)
                                * np.outer(wc, wp))
    assert abs(prob.sum() - 1.0) < 1e-6
    assert chi_square_pvalue(counts.ravel(), n_samples * prob.ravel()) > 1e-3


EDGE_U1 = [0.0, 0.5, 1.0 - 2.0**-53, float(np.nextafter(1.0, 0.0)), 1e-300, 2.0**-60]


def check_sample(module, u1, u2, params):
    t, c, s = module.sample(u1, u2, params)
    assert math.isfinite(t) and t >= 0.0
    assert abs(math.hypot(c, s) - 1.0) < 1e-14
    if t == 0.0:
        assert (c, s) == (1.0, 0.0)
    mx, my, mz = module.sample_normal(u1, u2, params)
    assert mz > 0.0
    assert abs(math.sqrt(mx * mx + my * my + mz * mz) - 1.0) < 1e-14
    return t


@pytest.mark.parametrize(("module", "args"), CASES, ids=CASE_IDS)
def test_sample_edge_uniforms(module, args):
    params = params_of(module, args)
    for u1 in EDGE_U1:
        for u2 in [0.0, 0.25, 0.7, float(np.nextafter(1.0, 0.0))]:
            check_sample(module, u1, u2, params)
    assert module.sample(0.0, 0.3, params) == (0.0, 1.0, 0.0)
    # the largest u1 gives the steepest facet, still finite
    steepest = module.sample(float(np.nextafter(1.0, 0.0)), 0.3, params)[0]
    assert steepest > module.sample(1.0 - 1e-9, 0.3, params)[0] > module.sample(0.5, 0.3, params)[0]


uniform01 = st.floats(0.0, 1.0, exclude_max=True)
alpha = st.floats(1e-3, 3.0)
PARAM_STRATEGIES = {
    "beckmann": st.tuples(alpha, alpha).map(lambda a: beckmann.params_from({"alpha_x": a[0], "alpha_y": a[1]})),
    "ggx": st.tuples(alpha, alpha).map(lambda a: ggx.params_from({"alpha_x": a[0], "alpha_y": a[1]})),
    "phong": st.floats(0.0, 1e5).map(lambda e: phong.params_from({"exponent": e})),
    "gaussian": st.sampled_from([1e-3, 0.05, 0.35, 1.0, 2.0]).map(gaussian_params),
    "student_t": st.tuples(alpha, alpha, st.floats(1.5 + 1e-9, 1e6)).map(
        lambda a: student_t.params_from({"alpha_x": a[0], "alpha_y": a[1], "gamma": a[2]})),
}


def test_every_registered_distribution_has_test_cases():
    assert {mod.NAME for mod, _ in CASES} == set(registry.NAMES)
    assert set(PARAM_STRATEGIES) == set(registry.NAMES)
    assert {name for name, _ in DISK_CASES} == set(registry.NAMES)


@pytest.mark.parametrize("name", sorted(PARAM_STRATEGIES))
def test_sample_property(name):
    """Finite tan >= 0, unit azimuth, unit normal, and tan non-decreasing in u1."""
    module = registry.get(name)

    @settings(deadline=None, max_examples=300)
    @given(u1=uniform01, u1b=uniform01, u2=uniform01, params=PARAM_STRATEGIES[name])
    def prop(u1, u1b, u2, params):
        t = check_sample(module, u1, u2, params)
        tb = check_sample(module, u1b, u2, params)
        if u1 < u1b:
            assert t <= tb
        elif u1 > u1b:
            assert t >= tb

    prop()


def gaussian_theta_reference(u, sigma):
    """Slow reference: brentq on the scipy.quad CDF (tail integral for u > 1/2)."""
    top = min(math.pi / 2.0, 14.0 * sigma)  # beyond: < exp(-98), negligible even in the tail
    f = lambda t: math.exp(-0.5 * (t / sigma) ** 2) * math.sin(t)  # noqa: E731

    def quad(a, b):
        if b - a < 1e-9:  # midpoint rule: quad warns on intervals of a few ulp
            return f(0.5 * (a + b)) * (b - a)
        return integrate.quad(f, a, b, epsabs=0.0, epsrel=1e-13, limit=200)[0]

    total = quad(0.0, top)
    if u < 0.5:
        return optimize.brentq(lambda th: quad(0.0, th) / total - u, 0.0, top, xtol=1e-15)
    return optimize.brentq(lambda th: (1.0 - u) - quad(th, top) / total, 0.0, top, xtol=1e-15)


@pytest.mark.parametrize("sigma", [1e-3, 0.1, 0.35, 1.0, 2.0])
def test_gaussian_inverse_cdf_accuracy(sigma):
    """Tabulated inverse CDF within 1e-7 rad of a root-find reference (IL eq. 13)."""
    params = gaussian_params(sigma)
    rng = np.random.default_rng(7)
    us = np.concatenate((rng.random(30), [1e-12, 0.5, 1.0 - 1e-9, 1.0 - 2.0**-53]))
    err = [abs(gaussian.inverse_cdf_theta(u, params) - gaussian_theta_reference(u, sigma))
           for u in us]
    assert max(err) < 1e-7
    # normalisation constant: 1/C = 2 pi int_0^{pi/2} exp(-theta^2/(2 sigma^2)) sin theta
    density = lambda t: math.exp(-0.5 * (t / sigma) ** 2) * math.sin(t)  # noqa: E731
    top = min(math.pi / 2, 40 * sigma)
    inv_c = 2.0 * math.pi * integrate.quad(density, 0.0, top, epsabs=0.0, epsrel=1e-13)[0]
    assert abs(params[1] * inv_c - 1.0) < 1e-10


@pytest.mark.parametrize(("module", "args"), CASES, ids=CASE_IDS)
def test_D_pdf_consistency_and_horizon(module, args):
    """pdf = D (m.n); D = 0 below the horizon; vectorised = scalar = registry dispatch."""
    params = params_of(module, args)
    k = kind(module)
    rng = np.random.default_rng(3)
    u1, u2 = rng.random(200), rng.random(200)
    m = registry.sample_normals(k, u1, u2, params)
    np.testing.assert_array_equal(m, [module.sample_normal(a, b, params) for a, b in zip(u1, u2)])
    d = registry.evaluate("D", k, m, params)
    np.testing.assert_allclose(registry.evaluate("pdf", k, m, params), d * m[:, 2], rtol=1e-13)
    np.testing.assert_array_equal(d, [module.D(*row, params) for row in m])
    np.testing.assert_array_equal(d, [registry.D(k, *row, params) for row in m])
    np.testing.assert_array_equal(registry.evaluate("pdf", k, m, params), [module.pdf(*row, params) for row in m])
    lam = registry.evaluate("smith_lambda", k, m, params)
    np.testing.assert_array_equal(lam, [module.smith_lambda(*row, params) for row in m])
    assert module.D(0.6, 0.0, -0.8, params) == 0.0 and module.pdf(1.0, 0.0, 0.0, params) == 0.0


# ------------------------------------------------------- the kernel's disk-point sampler

# (name, canonical values in key order): ordinary, anisotropic and edge parameters
DISK_CASES = [
    ("beckmann", (0.6, 0.6)), ("beckmann", (0.05, 0.9)), ("ggx", (0.3, 0.3)), ("ggx", (2.0, 0.01)),
    ("phong", (20.0,)), ("phong", (0.0,)), ("gaussian", (0.35,)),
    ("student_t", (0.4, 0.4, 2.5)), ("student_t", (0.05, 0.9, 1.6)),
]
DISK_IDS = [f"{name}-{'-'.join(map(str, args))}" for name, args in DISK_CASES]


@pytest.mark.parametrize("name, args", DISK_CASES, ids=DISK_IDS)
def test_sample_disk_is_sample_with_u1_one_minus_s(name, args):
    """sample_disk(a, b, s) = sample(u1 = 1 - s, u2) for the disk point (a, b) at azimuth 2 pi u2."""
    module = registry.get(name)
    params = params_of(module, args)
    k = registry.kind_of(name)
    rng = np.random.default_rng(99)
    # u1 >= 0.5 so that s = 1 - u1 is exact (Sterbenz); plus the lower half separately
    for u1, u2 in zip(np.concatenate([rng.uniform(0.5, 1.0, 2000), rng.uniform(1e-9, 0.5, 2000)]),
                      rng.uniform(0.0, 1.0, 4000)):
        s = 1.0 - u1
        a, b = math.sqrt(s) * math.cos(2 * math.pi * u2), math.sqrt(s) * math.sin(2 * math.pi * u2)
        t_ref, c_ref, s_ref = module.sample(u1, u2, params)
        t, c, sn = module.sample_disk(a, b, a * a + b * b, params)
        assert registry.sample_disk(k, a, b, a * a + b * b, params) == (t, c, sn)
        assert t == pytest.approx(t_ref, rel=1e-9, abs=1e-12)
        if t_ref > 1e-12:
            assert c == pytest.approx(c_ref, abs=1e-9)
            assert sn == pytest.approx(s_ref, abs=1e-9)
        assert abs(math.hypot(c, sn) - 1.0) < 1e-14


@pytest.mark.parametrize("name, args", DISK_CASES, ids=DISK_IDS)
def test_sample_disk_at_extreme_disk_points_is_finite(name, args):
    module = registry.get(name)
    params = params_of(module, args)
    # the kernel's disk points are 2u - 1 with 53-bit u: |a|, |b| are 0 or >= 2^-52, and
    # the centre (s = 0) and the rim (s >= 1) are rejected
    tiny, edge = 2.0**-52, 1.0 - 2.0**-52
    for a, b in [(tiny, 0.0), (0.0, -tiny), (tiny, tiny), (edge, 0.0), (0.0, -edge),
                 (0.7071067811865475, 0.7071067811865475)]:
        s = a * a + b * b
        if not 0.0 < s < 1.0:
            continue
        t, c, sn = module.sample_disk(a, b, s, params)
        assert math.isfinite(t) and t >= 0.0
        assert abs(math.hypot(c, sn) - 1.0) < 1e-12
