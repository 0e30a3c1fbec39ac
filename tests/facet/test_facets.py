"""Tests of the facet models: interfaced Lambertian (IL eq. 4-8) and perfect mirror.

The emergence-direction samplers are checked against the exact pdf 2 mu T(mu)/(1 - r_e)
(physics.md sec. 4) built from a slow Snell's-law reference transmittance.
"""

import math

import numba
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import chi2

from vcavity.facet import interfaced_lambert as il
from vcavity.facet import mirror
from vcavity.facet.fresnel import emergence_probability, fresnel_dielectric, one_minus_r_i, r_e


def transmittance_reference(cos_i, eta):
    """Slow reference T: power transmittances (eta cos_t/cos_i)|t|^2, Snell's law."""
    cos_i = np.asarray(cos_i, dtype=np.float64)
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - (1.0 - cos_i**2) / eta**2))
    t_s = 2.0 * cos_i / (cos_i + eta * cos_t)
    t_p = 2.0 * cos_i / (eta * cos_i + cos_t)
    return 0.5 * eta * cos_t / cos_i * (t_s**2 + t_p**2)


def grazing_points(eta):
    """Break points for quad where T varies fast: sqrt(eta^2-1) (eta ~ 1) and 1/eta."""
    scales = [math.sqrt((eta - 1.0) * (eta + 1.0)), 1.0 / eta]
    points = sorted({s * f for s in scales for f in (0.3, 1.0, 3.0, 10.0)})
    return [p for p in points if 0.0 < p < 1.0] or None


def emergence_cdf_reference(mu, eta, n_cells=200):
    """int_0^mu 2 t T(t) dt / (1 - r_e) by Gauss-Legendre on cells graded toward 0."""
    nodes, weights = np.polynomial.legendre.leggauss(8)
    edges = mu[:, None] * (np.arange(n_cells + 1) / n_cells)[None, :] ** 2
    half = 0.5 * (edges[:, 1:] - edges[:, :-1])
    t = (0.5 * (edges[:, 1:] + edges[:, :-1]))[..., None] + half[..., None] * nodes
    with np.errstate(invalid="ignore", divide="ignore"):  # t = 0 only when mu = 0
        integral = (half * ((2.0 * t * transmittance_reference(t, eta)) @ weights)).sum(axis=1)
    return np.where(mu > 0.0, integral, 0.0) / (1.0 - r_e(eta))


def bin_probabilities(edges, eta):
    """Exact probability of each mu bin under the pdf 2 mu T(mu)/(1 - r_e), by quad."""
    pdf = lambda m: 2.0 * m * float(transmittance_reference(m, eta)) / (1.0 - r_e(eta))
    points = grazing_points(eta)
    probs = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        inner = [p for p in (points or []) if lo < p < hi] or None
        probs.append(quad(pdf, lo, hi, points=inner, epsabs=1e-13, epsrel=1e-11, limit=200)[0])
    return np.array(probs)


def chi_square_p_value(samples, edges, eta):
    counts, _ = np.histogram(samples, bins=edges)
    expected = bin_probabilities(edges, eta) * samples.size
    assert expected.min() > 20.0  # chi-square approximation is adequate
    assert abs(expected.sum() - samples.size) < 1e-6 * samples.size
    stat = np.sum((counts - expected) ** 2 / expected)
    return chi2.sf(stat, df=len(expected) - 1)


@numba.njit
def sample_with_table(u, table):
    out = np.empty_like(u)
    for k in range(u.size):
        out[k] = il.sample_emergence_mu_table(u[k], table)
    return out


@numba.njit
def sample_by_rejection(u_proposal, u_accept, eta):
    """Cosine-weighted proposals mu = sqrt(u), kept with probability T(mu) (physics.md 4)."""
    out = np.empty_like(u_proposal)
    n = 0
    for k in range(u_proposal.size):
        mu = math.sqrt(u_proposal[k])
        if u_accept[k] < il.emergence_accept(mu, eta):
            out[n] = mu
            n += 1
    return out[:n]


# ----------------------------------------------------------------------------- body BRDF


@pytest.mark.parametrize("eta", [1.0, 1.0 + 1e-6, 1.5, 3.0, 1000.0])
@pytest.mark.parametrize("kd", [0.0, 0.3, 0.9, 1.0])
def test_body_reemission_integral_equals_transmitted_times_emergence(eta, kd):
    # int f_b(i, o) cos_o dw_o = (1 - F(i)) a: body_brdf (IL eq. 4-8) is consistent with
    # emergence_probability (physics.md sec. 4), for several incident cosines
    escape = one_minus_r_i(eta)
    for cos_i in (1.0, 0.7, 0.2, 0.01):
        integrand = lambda mu: 2.0 * math.pi * il.body_brdf(cos_i, mu, kd, eta, escape) * mu
        value = quad(integrand, 0.0, 1.0, points=grazing_points(eta), epsabs=1e-15,
                     epsrel=1e-12, limit=200)[0]
        expected = (1.0 - fresnel_dielectric(cos_i, eta)) * emergence_probability(kd, eta)
        assert value == pytest.approx(expected, rel=1e-10, abs=1e-15)


def test_body_brdf_limits_and_reciprocity():
    rng = np.random.default_rng(11)
    for _ in range(200):
        ci, co, kd = rng.uniform(0.0, 1.0, 3)
        eta = math.exp(rng.uniform(0.0, math.log(100.0)))
        escape = one_minus_r_i(eta)
        assert il.body_brdf(ci, co, kd, eta, escape) == il.body_brdf(co, ci, kd, eta, escape)
        # eta = 1: Lambertian facet kd/pi (physics.md sec. 4 and 7, flat limit)
        assert il.body_brdf(ci, co, kd, 1.0, 1.0) == pytest.approx(kd / math.pi, rel=1e-15)
        assert il.body_brdf(ci, co, 0.0, eta, escape) == 0.0


def test_albedo_of_flat_facet():
    rng = np.random.default_rng(12)
    for _ in range(500):
        cos_i, kd = rng.uniform(0.0, 1.0, 2)
        eta = math.exp(rng.uniform(0.0, math.log(1e4)))
        f = fresnel_dielectric(cos_i, eta)
        albedo = il.albedo(kd, eta, cos_i)
        assert 0.0 <= albedo <= 1.0
        assert il.albedo(1.0, eta, cos_i) == pytest.approx(1.0, abs=2.3e-16)  # white furnace
        assert il.albedo(0.0, eta, cos_i) == f  # specular dielectric facet
        assert il.albedo(kd, 1.0, cos_i) == kd  # Lambertian facet
        assert albedo == pytest.approx(f + (1.0 - f) * emergence_probability(kd, eta), rel=1e-15)


def test_emergence_accept_is_transmittance():
    for eta in (1.0, 1.5, 1000.0):
        for mu in np.linspace(1e-3, 1.0, 50):
            assert il.emergence_accept(mu, eta) == pytest.approx(
                float(transmittance_reference(mu, eta)), rel=1e-11, abs=1e-16)
    assert il.emergence_accept(0.0, 1.5) == 0.0 and il.emergence_accept(0.0, 1.0) == 1.0


# ----------------------------------------------------------------------------- emergence sampling


def test_emergence_table_shape_and_eta_one():
    table = il.make_emergence_table(1.0, 257)
    assert table.shape == (257,) and table.dtype == np.float64
    # eta = 1: pdf 2 mu, CDF mu^2, and the nodes sit at w = sqrt(u): mu = w exactly
    np.testing.assert_allclose(table, np.linspace(0.0, 1.0, 257), rtol=0.0, atol=4.5e-16)
    table = il.make_emergence_table(1.5)
    assert table[0] == 0.0 and table[-1] == 1.0 and np.all(np.diff(table) > 0.0)
    with pytest.raises(ValueError):
        il.make_emergence_table(0.9)
    with pytest.raises(ValueError):
        il.make_emergence_table(1.5, 1)


@pytest.mark.parametrize("eta", [1.0001, 1.5, 10.0, 1000.0])
def test_emergence_table_inversion_cdf_error(eta):
    table = il.make_emergence_table(eta)
    n = table.size
    # the reference quadrature itself: total mass must be 1 (checks it against r_e)
    assert emergence_cdf_reference(np.array([1.0]), eta)[0] == pytest.approx(1.0, abs=1e-12)
    # nodes are accurate to quadrature precision
    nodes_u = (np.arange(n) / (n - 1)) ** 2
    assert np.max(np.abs(emergence_cdf_reference(table, eta) - nodes_u)) < 1e-12
    # between nodes the linear interpolation is worst: probe quarter, half and 3/4 points
    # of every cell, plus random u
    w = np.concatenate([(np.arange(n - 1) + f) / (n - 1) for f in (0.25, 0.5, 0.75)])
    u = np.concatenate([w**2, np.random.default_rng(13).uniform(0.0, 1.0, 2000)])
    mu = sample_with_table(u, table)
    errors = [np.abs(emergence_cdf_reference(m, eta) - x) for m, x in
              zip(np.array_split(mu, 16), np.array_split(u, 16))]  # chunks bound memory
    assert max(e.max() for e in errors) < 1e-6


# 40 bins of equal probability for the eta = 1 pdf 2 mu (populated at every eta tested)
CHI_SQUARE_EDGES = np.sqrt(np.linspace(0.0, 1.0, 41))


@pytest.mark.parametrize("eta", [1.0001, 1.5, 10.0, 1000.0])
def test_emergence_table_samples_chi_square(eta):
    # 2e5 samples in 40 bins against the exact pdf. The seed is fixed; were it not, this
    # test (threshold p > 1e-3) would fail by chance with probability 1e-3 per eta.
    table = il.make_emergence_table(eta)
    u = np.random.default_rng(100 + int(eta * 7)).uniform(0.0, 1.0, 200_000)
    assert chi_square_p_value(sample_with_table(u, table), CHI_SQUARE_EDGES, eta) > 1e-3


@pytest.mark.parametrize("eta", [1.0001, 1.5, 10.0])
def test_emergence_rejection_samples_chi_square(eta):
    # Rejection route with emergence_accept: same chi-square (p > 1e-3: false-positive
    # rate 1e-3 per eta) and acceptance rate 1 - r_e within 5 sigma (rate 6e-7).
    rng = np.random.default_rng(200 + int(eta * 7))
    n = 400_000
    samples = sample_by_rejection(rng.uniform(0.0, 1.0, n), rng.uniform(0.0, 1.0, n), eta)
    p_accept = 1.0 - r_e(eta)
    assert abs(samples.size - n * p_accept) < 5.0 * math.sqrt(n * p_accept * (1.0 - p_accept))
    assert chi_square_p_value(samples, CHI_SQUARE_EDGES, eta) > 1e-3


# ----------------------------------------------------------------------------- mirror


def test_mirror_facet():
    assert mirror.MODEL == "mirror" and il.MODEL == "interfaced_lambertian"
    for c in np.linspace(0.0, 1.0, 11):
        assert mirror.fresnel(c) == 1.0 and mirror.fresnel(c, 1.5, 0.3) == 1.0
        assert mirror.albedo(0.5, 1.5, c) == 1.0
    assert mirror.albedo() == 1.0
