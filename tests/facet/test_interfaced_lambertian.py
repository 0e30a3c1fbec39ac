"""The interfaced Lambertian facet (vcavity/facet/interfaced_lambertian.py; IL eq. 4-8,
physics.md sec. 4): its parameters and variants, prepared data, the reflectance,
transmittance and body factor the analytic models use, the Fresnel bracketing table and
the facet event the kernel runs, and the emergence-direction samplers.

The emergence samplers are checked against the exact pdf 2 mu T(mu)/(1 - r_e) built from a
slow Snell's-law reference transmittance. Each chi-square test rejects at p < 1e-3
(false-positive rate 1e-3 per test, fixed seeds); each z-test at |z| > 5 (5.7e-7 per test).
The event's outcome frequencies and emerging directions against R, T and the body term are
checked for every facet model and example in tests/facet/test_conformance.py; R and T
themselves against the Snell's-law reference here.
"""

import math
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from vcavity._numba.jit import njit  # caches where vcavity's own code does
from scipy.integrate import quad
from scipy.stats import chi2

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

from tests.facet.frames import incoming  # noqa: E402
from vcavity.facet import interfaced_lambertian as il  # noqa: E402
from vcavity.facet.fresnel import (  # noqa: E402
    emergence_probability,
    fresnel_dielectric,
    fresnel_dielectric_array,
    fresnel_transmittance,
    one_minus_r_i,
    r_e,
    r_i,
)
from vcavity.parameters import ParameterError  # noqa: E402


def data_of(kd, eta):
    """Prepared facet data, as the kernel and the analytic models get it."""
    return il.prepare({"kd": kd, "eta": eta})


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
def sample_by_rejection(u_proposal, u_accept, data):
    """Cosine-weighted proposals mu = sqrt(u), kept with probability T(mu) (physics.md 4)."""
    out = np.empty_like(u_proposal)
    n = 0
    for k in range(u_proposal.size):
        mu = math.sqrt(u_proposal[k])
        if u_accept[k] < il.transmittance(mu, data):
            out[n] = mu
            n += 1
    return out[:n]


# ----------------------------------------------------------------------------- parameters, variants, data


def test_parameters_and_their_defaults():
    assert il.NAME == "interfaced_lambertian"
    assert [spec.key for spec in il.PARAMETERS] == ["kd", "eta"]
    kd, eta = il.PARAMETERS
    assert kd.default is None and (kd.lo, kd.hi) == (0.0, 1.0)  # kd is required
    assert eta.default == 1.5 and eta.lo == 1.0 and eta.hi is None
    values = {"kd": 0.5, "eta": 1.5}
    assert kd.parse({"kd": 0.5}, "material", "facet") == {"kd": 0.5}
    assert eta.parse({}, "material", "facet") == {"eta": 1.5}
    with pytest.raises(ParameterError, match=r"^material\.kd is missing: facet needs kd"):
        kd.parse({"eta": 1.5}, "material", "facet")
    assert il.has_specular(values) and not il.has_specular({"kd": 0.5, "eta": 1.0})


def test_variants_compile_only_what_the_values_need():
    assert il.VARIANTS[il.DIELECTRIC] == "specular dielectric"
    assert il.VARIANTS[il.LAMBERTIAN] == "lambertian"
    assert il.VARIANTS[il.FULL] == "interfaced lambertian"
    assert il.variant({"kd": 0.0, "eta": 1.5}) == il.DIELECTRIC
    assert il.variant({"kd": 0.5, "eta": 1.0}) == il.LAMBERTIAN
    assert il.variant({"kd": 0.0, "eta": 1.0}) == il.LAMBERTIAN  # eta = 1 first: no Fresnel at all
    assert il.variant({"kd": 1e-6, "eta": 1.0 + 1e-9}) == il.FULL
    assert il.variant({"kd": 1.0, "eta": 1000.0}) == il.FULL


@pytest.mark.parametrize("kd, eta", [(0.0, 1.5), (0.5, 1.0), (0.9, 1.5), (1.0, 1e300)])
def test_prepared_data_layout(kd, eta):
    data = data_of(kd, eta)
    assert data.dtype == np.float64 and data.flags.c_contiguous
    assert data.shape == (2 + 2 * il.FRESNEL_BINS,)
    assert data[0] == eta and data[1] == emergence_probability(kd, eta)
    np.testing.assert_array_equal(data[2:], il.fresnel_brackets(eta).ravel())


# ----------------------------------------------------------------------------- R, T and the body term


def test_reflectance_and_transmittance_are_the_interface_fresnel_terms():
    for eta in (1.0, 1.0 + 1e-6, 1.5, 1000.0):
        data = data_of(0.5, eta)
        for mu in np.linspace(1e-3, 1.0, 50):
            assert il.transmittance(mu, data) == pytest.approx(
                float(transmittance_reference(mu, eta)), rel=1e-11, abs=1e-16)
            assert il.reflectance(mu, data) == fresnel_dielectric(mu, eta)
            assert il.transmittance(mu, data) == fresnel_transmittance(mu, eta)
            assert abs(il.reflectance(mu, data) + il.transmittance(mu, data) - 1.0) <= 1e-15
    assert il.transmittance(0.0, data_of(0.5, 1.5)) == 0.0 and il.transmittance(0.0, data_of(0.5, 1.0)) == 1.0
    assert il.reflectance(0.3, data_of(0.5, 1.0)) == 0.0


@pytest.mark.parametrize("eta", [1.0, 1.0 + 1e-6, 1.5, 3.0, 1000.0])
@pytest.mark.parametrize("kd", [0.0, 0.3, 0.9, 1.0])
def test_body_reemission_integral_equals_transmitted_times_emergence(eta, kd):
    # int f_b(i, o) cos_o dw_o = (1 - F(i)) a with the body term f_b = K T(i) T(o) of the
    # facet interface (IL eq. 4-8): body_factor and transmittance are consistent with
    # emergence_probability (physics.md sec. 4), for several incident cosines
    values = {"kd": kd, "eta": eta}
    factor, data = il.body_factor(values), il.prepare(values)
    for cos_i in (1.0, 0.7, 0.2, 0.01):
        t_i = il.transmittance(cos_i, data)
        integrand = lambda mu: 2.0 * math.pi * factor * t_i * il.transmittance(mu, data) * mu
        value = quad(integrand, 0.0, 1.0, points=grazing_points(eta), epsabs=1e-15,
                     epsrel=1e-12, limit=200)[0]
        expected = (1.0 - fresnel_dielectric(cos_i, eta)) * emergence_probability(kd, eta)
        assert value == pytest.approx(expected, rel=1e-10, abs=1e-15)


def test_body_factor_formula_and_limits():
    rng = np.random.default_rng(11)
    for _ in range(200):
        kd = rng.uniform(0.0, 1.0)
        eta = math.exp(rng.uniform(0.0, math.log(100.0)))
        factor = il.body_factor({"kd": kd, "eta": eta})
        assert factor == pytest.approx(kd / (math.pi * eta * eta * (1.0 - kd * r_i(eta))), rel=1e-13)
        assert factor == pytest.approx(kd / (math.pi * eta * eta * ((1.0 - kd) + kd * one_minus_r_i(eta))),
                                       rel=1e-14)
        # eta = 1: Lambertian facet kd/pi (physics.md sec. 4 and 7, flat limit); T = 1
        assert il.body_factor({"kd": kd, "eta": 1.0}) == pytest.approx(kd / math.pi, rel=1e-15)
        assert il.transmittance(rng.uniform(0.0, 1.0), data_of(kd, 1.0)) == 1.0
        assert il.body_factor({"kd": 0.0, "eta": eta}) == 0.0
    assert il.body_factor({"kd": 0.0, "eta": 1.0}) == 0.0


@pytest.mark.parametrize("eta", [1e50, 1e108, 1e120, 1e154, 1e200, 1e300, 1.7e308])
def test_body_factor_is_finite_at_huge_eta(eta):
    """1 - r_i underflows from eta ~ 1e108 and eta^2 overflows from ~1.3e154: the factor
    stays finite, with the large-eta limits 0 (kd < 1: ~kd/(pi eta^2 (1 - kd))) and
    3 eta/(16 pi) (kd = 1: 1 - r_e ~ 16/(3 eta), IL eq. 10 asymptotics)."""
    for kd in (0.3, 0.999, 1.0):
        factor = il.body_factor({"kd": kd, "eta": eta})
        assert math.isfinite(factor) and factor >= 0.0, (kd, factor)
        if kd == 1.0:
            assert factor == pytest.approx(3.0 / (16.0 * math.pi) * eta, rel=1e-6)
        else:
            expected = kd / (math.pi * (1.0 - kd)) / eta / eta  # underflows to 0 where it must
            assert factor == pytest.approx(expected, rel=1e-6, abs=1e-300)


def test_albedo_of_flat_facet():
    # what one event does: reflect with probability F, else re-emerge with probability a
    rng = np.random.default_rng(12)
    for _ in range(500):
        cos_i, kd = rng.uniform(0.0, 1.0, 2)
        eta = math.exp(rng.uniform(0.0, math.log(1e4)))
        f = il.reflectance(cos_i, data_of(kd, eta))
        a = data_of(kd, eta)[1]
        albedo = f + (1.0 - f) * a
        assert 0.0 <= albedo <= 1.0
        assert f == fresnel_dielectric(cos_i, eta)
        assert a == pytest.approx(kd * one_minus_r_i(eta) / (1.0 - kd * r_i(eta)), rel=1e-12)
        a_white = data_of(1.0, eta)[1]
        assert f + (1.0 - f) * a_white == pytest.approx(1.0, abs=2.3e-16)  # white furnace
        assert f + (1.0 - f) * data_of(0.0, eta)[1] == f  # specular dielectric facet
        assert data_of(kd, 1.0)[1] == kd and il.reflectance(cos_i, data_of(kd, 1.0)) == 0.0  # Lambertian facet


# ----------------------------------------------------------------------------- Fresnel bracketing table


@pytest.mark.parametrize("eta", [1.0 + 1e-9, 1.0001, 1.33, 1.5, 2.5, 10.0, 1000.0, 1e4])
def test_brackets_contain_fresnel_on_a_fine_grid(eta):
    brackets = il.fresnel_brackets(eta)
    c = np.linspace(0.0, 1.0, 2_000_001)
    f = fresnel_dielectric_array(c, eta)
    j = np.minimum((c * il.FRESNEL_BINS).astype(int), il.FRESNEL_BINS - 1)
    assert np.all(brackets[j, 0] <= f) and np.all(f <= brackets[j, 1])
    # and they are useful: most bins bracket tightly at moderate eta (F is steep only near grazing)
    if eta < 5:
        assert np.mean(brackets[:, 1] - brackets[:, 0] < 0.01) > 0.8


@njit(cache=True)
def _decisions(u, c, eta, data):
    fast = np.empty(u.size, np.bool_)
    exact = np.empty(u.size, np.bool_)
    for k in range(u.size):
        fast[k] = il._below_fresnel(u[k], c[k], data)
        exact[k] = u[k] < fresnel_dielectric(c[k], eta)
    return fast, exact


@pytest.mark.parametrize("eta", [1.0 + 1e-6, 1.5, 3.0, 1000.0, 1e4])
def test_bracketed_decision_equals_exact_decision(eta):
    rng = np.random.default_rng(5)
    nodes = il.fresnel_brackets(eta)
    assert nodes.shape == (il.FRESNEL_BINS, 2)
    data = data_of(0.5, eta)  # the brackets as the facet event reads them
    c = np.concatenate([rng.uniform(0, 1, 300_000), np.arange(il.FRESNEL_BINS + 1) / il.FRESNEL_BINS, [0.0, 1.0]])
    exact_f = fresnel_dielectric_array(c, eta)
    # uniforms both random and right at F (within a few ulp), where a wrong bound would show
    u = np.concatenate([rng.uniform(0, 1, c.size), exact_f, np.nextafter(exact_f, 0), np.nextafter(exact_f, 1)])
    fast, exact = _decisions(u, np.tile(c, 4), eta, data)
    np.testing.assert_array_equal(fast, exact)


# ----------------------------------------------------------------------------- the facet event

@njit(cache=True)
def _draws(variant, n, seed, dx, dy, dz, cos_in, nx, nz, data):
    """How many of n facet events advanced the random stream."""
    state = np.uint64(seed)
    consumed = 0
    for _ in range(n):
        before = state
        state, _outcome, _ox, _oy, _oz = il.event(variant, state, dx, dy, dz, cos_in, nx, nz, data)
        if state != before:
            consumed += 1
    return consumed


@pytest.mark.parametrize("kd, eta", [(0.5, 1.5), (1.0, 1.5), (0.0, 1.5), (0.7, 1.0), (1.0, 1.0)])
def test_every_event_draws_from_the_stream(kd, eta):
    """Each variant decides every hit with random numbers (a mirror would not)."""
    values = {"kd": kd, "eta": eta}
    (dx, dy, dz), nx, nz = incoming(0.6)
    assert _draws(il.variant(values), 1000, 12345, dx, dy, dz, 0.6, nx, nz, il.prepare(values)) == 1000


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
    # Rejection route accepting with the facet's transmittance: same chi-square (p > 1e-3:
    # false-positive rate 1e-3 per eta) and acceptance rate 1 - r_e within 5 sigma (rate 6e-7).
    rng = np.random.default_rng(200 + int(eta * 7))
    n = 400_000
    samples = sample_by_rejection(rng.uniform(0.0, 1.0, n), rng.uniform(0.0, 1.0, n), data_of(0.5, eta))
    p_accept = 1.0 - r_e(eta)
    assert abs(samples.size - n * p_accept) < 5.0 * math.sqrt(n * p_accept * (1.0 - p_accept))
    assert chi_square_p_value(samples, CHI_SQUARE_EDGES, eta) > 1e-3
