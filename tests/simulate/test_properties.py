"""Property-based tests (Hypothesis) over the whole valid parameter space.

Sampled normals are unit and in the upper hemisphere; Fresnel terms lie in [0, 1], are
symmetric under the inside/outside swap and continuous through eta -> 1; facet events
conserve energy exactly when kd = 1; every table is finite, non-negative and keeps exact
books; the bounce cap bounds the work per path. Counting identities are exact, so these
tests have no false-positive rate. Example counts are bounded to keep the file fast.
"""

import math
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vcavity.config import validate
from vcavity.facet import interfaced_lambertian
from vcavity.facet.fresnel import (
    emergence_probability,
    fresnel_dielectric,
    fresnel_transmittance,
    one_minus_r_i,
    r_e,
    r_i,
)
from vcavity.io.table import open_table, write_table
from vcavity.facet import registry as facets
from vcavity.microfacet import registry
from vcavity.parameters import Roughness
from vcavity.rng import BLOCK_SIZE
from vcavity.simulate.pipeline import Simulation

FAST = settings(deadline=None, max_examples=60, suppress_health_check=[HealthCheck.too_slow])
SLOW = settings(deadline=None, max_examples=12, suppress_health_check=[HealthCheck.too_slow,
                                                                        HealthCheck.function_scoped_fixture])
ONE_MINUS_ULP = 1.0 - 2.0**-53

# uniforms the kernel can draw ([0, 1) with 53 bits), with the ends always in play
uniform = st.one_of(st.floats(0.0, 1.0, exclude_max=True), st.sampled_from(
    [0.0, 2.0**-53, 1e-300, 0.5, 0.25, 0.75, 1.0 - 2.0**-52, ONE_MINUS_ULP]))
# every positive finite float a config accepts for alpha / sigma (log-uniform-ish)
positive = st.one_of(st.floats(1e-300, 1e300), st.sampled_from([5e-324, 1e-170, 1e-4, 1.0, 10.0, 1e200, 1.7e308]))
cosine = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 5e-324, 1e-300, 1e-8, ONE_MINUS_ULP, 1.0]))
eta_outside = st.one_of(st.floats(1.0, 1e300), st.sampled_from(
    [1.0, 1.0 + 2.0**-52, 1.0 + 1e-12, 1.0 + 1e-9, 1.0001, 1.4, 4.0, 1e30, 1e50, 1e100, 1.7e308]))


def _assert_unit_upper(m):
    mx, my, mz = m
    assert all(math.isfinite(c) for c in m)
    assert mz > 0.0
    assert abs(math.sqrt(mx * mx + my * my + mz * mz) - 1.0) <= 4e-16


def _assert_sample_ok(module, params, u1, u2):
    t, c, s = module.sample(u1, u2, params)
    assert math.isfinite(t) and t >= 0.0
    assert abs(math.hypot(c, s) - 1.0) <= 4e-16
    _assert_unit_upper(module.sample_normal(u1, u2, params))


# ----------------------------------------------------------------------------- sampling


def _scalar_range(spec, lo_floor=None, hi_cap=None):
    """The declared range of a scalar parameter as (lo, hi) floats (open ends moved inside),
    optionally narrowed to [lo_floor, hi_cap]."""
    lo = -1.7e308 if spec.lo is None else (math.nextafter(spec.lo, math.inf) if spec.lo_open else spec.lo)
    hi = 1.7e308 if spec.hi is None else (math.nextafter(spec.hi, -math.inf) if spec.hi_open else spec.hi)
    if lo_floor is not None and lo < lo_floor < hi:
        lo = lo_floor
    if hi_cap is not None and lo < hi_cap < hi:
        hi = hi_cap
    return lo, hi


def distribution_values(name, roughness=None, lo_floor=None, hi_cap=None):
    """Canonical values of the registered distribution ``name`` over its declared ranges (from
    its PARAMETERS: no table per distribution): every roughness ``roughness`` (default: any
    positive float), every scalar anywhere in its range (optionally narrowed), ends included."""
    parts = []
    for spec in registry.get(name).PARAMETERS:
        if isinstance(spec, Roughness):
            alpha = roughness if roughness is not None else positive
            parts.append(st.builds(lambda a, b: {"alpha_x": a, "alpha_y": b}, alpha, alpha))
        else:
            lo, hi = _scalar_range(spec, lo_floor, hi_cap)
            parts.append(st.one_of(st.floats(lo, hi), st.sampled_from([lo, hi])).map(lambda x, k=spec.key: {k: x}))
    return st.tuples(*parts).map(lambda dicts: {k: v for d in dicts for k, v in d.items()})


def _examples_for(name):
    """Hypothesis examples for ``name``: 60, or 15 where building the parameter array is slow
    (the Gaussian's inverse-CDF table, ~0.2 s), each tried at 20 pairs of uniforms."""
    module = registry.get(name)
    start = time.perf_counter()
    module.params_from(registry.parse(name, next(iter(module.EXAMPLES.values()))))
    return 60 if time.perf_counter() - start < 0.02 else 15


@pytest.mark.parametrize("name", registry.NAMES)
def test_sampled_normals_are_unit_and_upper(name):
    """Every registered distribution over its whole declared parameter range (any positive
    roughness; scalars from end to end): finite tangents, unit azimuths, unit normals above
    the horizon, at uniforms including the ends of [0, 1)."""
    module = registry.get(name)

    @settings(deadline=None, max_examples=_examples_for(name), suppress_health_check=[HealthCheck.too_slow])
    @given(values=distribution_values(name), u=st.lists(st.tuples(uniform, uniform), min_size=20, max_size=20))
    def prop(values, u):
        params = module.params_from(values)
        for u1, u2 in u:
            _assert_sample_ok(module, params, u1, u2)

    prop()


# ----------------------------------------------------------------------------- Fresnel


@FAST
@given(c=cosine, eta=st.one_of(eta_outside, st.floats(1e-300, 1.0)))
def test_fresnel_and_transmittance_in_unit_interval_and_complementary(c, eta):
    f = fresnel_dielectric(c, eta)
    t = fresnel_transmittance(c, eta)
    assert 0.0 <= f <= 1.0 and 0.0 <= t <= 1.0
    assert abs(f + t - 1.0) <= 1e-14  # T is computed independently (no 1 - F)


@FAST
@given(c=st.floats(1e-3, 1.0), eta=st.one_of(st.floats(1.0, 1e3), st.sampled_from([1.0 + 1e-12, 1.0001, 1.5, 1e3])))
def test_fresnel_symmetric_under_inside_outside_swap(c, eta):
    # Stokes/reciprocity: light from outside at cos_i and from inside at the refracted
    # cos_t = g/eta (W eq. 22 with g^2 = eta^2 - 1 + c^2) see the same F and T.
    # Tolerance = conditioning of the inside form on a cos_t rounded to float64: it forms
    # g'^2 = 1/eta^2 - sin_t^2 = c^2/eta^2 by cancellation, from sin_t^2 = (1-cos_t)(1+cos_t)
    # with an absolute error ~eps, i.e. a relative error ~eps eta^2/c^2 (the swap is
    # meaningless in float64 for large eta at grazing light, hence the ranges).
    cos_t = math.sqrt((eta - 1.0) * (eta + 1.0) + c * c) / eta
    tol = 2e-15 * (1.0 + eta * eta) / (c * c)
    assert abs(fresnel_dielectric(c, eta) - fresnel_dielectric(cos_t, 1.0 / eta)) <= tol
    assert abs(fresnel_transmittance(c, eta) - fresnel_transmittance(cos_t, 1.0 / eta)) <= tol


@FAST
@given(c=st.floats(0.3, 1.0), eta=st.floats(1.0, 3.0))
def test_fresnel_swap_symmetry_is_tight_where_well_conditioned(c, eta):
    cos_t = math.sqrt((eta - 1.0) * (eta + 1.0) + c * c) / eta
    assert abs(fresnel_dielectric(c, eta) - fresnel_dielectric(cos_t, 1.0 / eta)) <= 1e-13


@FAST
@given(c=st.floats(0.05, 1.0), delta=st.one_of(st.floats(0.0, 1e-3), st.sampled_from([0.0, 2.0**-52, 1e-12])))
def test_fresnel_and_diffuse_reflectances_continuous_through_eta_one(c, delta):
    eta = 1.0 + delta
    delta = eta - 1.0  # exact (Sterbenz): the bounds below use the represented eta
    # both amplitudes are O((eta^2 - 1)/c^2): F <= ((eta^2 - 1)/(2 c^2))^2 <= (1.01 delta/c^2)^2
    assert fresnel_dielectric(c, eta) <= (1.01 * delta / (c * c)) ** 2
    assert 0.0 <= r_e(eta) <= 0.34 * delta  # slope 1/3 at eta = 1
    assert 0.0 <= r_i(eta) <= 2.34 * delta + 1e-16  # r_i = 1 - (1 - r_e)/eta^2
    assert abs(one_minus_r_i(eta) - 1.0) <= 2.34 * delta + 1e-16
    for kd in (0.0, 1e-6, 0.5, 1.0):
        assert abs(emergence_probability(kd, eta) - kd) <= 2.34 * delta + 1e-16


@FAST
@given(eta=eta_outside, c=cosine)
def test_facet_event_conserves_energy_exactly_when_kd_is_one(eta, c):
    assert emergence_probability(1.0, eta) == 1.0  # nothing absorbed inside the body
    data = interfaced_lambertian.prepare({"kd": 1.0, "eta": eta})
    assert data[1] == 1.0  # the event's re-emergence probability
    f = interfaced_lambertian.reflectance(c, data)  # reflect with F, else re-emerge with a = 1
    assert abs(f + (1.0 - f) * data[1] - 1.0) <= 2.0**-53
    assert 0.0 <= one_minus_r_i(eta) <= 1.0 and 0.0 <= r_e(eta) <= 1.0  # r_e rounds to 1 from eta ~ 1e17


# ----------------------------------------------------------------------------- whole walk

kd_positive = st.sampled_from([1e-6, 0.5, 1.0])
eta_dielectric = st.sampled_from([1.0 + 1e-9, 1.0001, 1.5, 1000.0, 1e300])
roughness = st.floats(1e-4, 10.0)
# Every (distribution, facet variant) pair is its own compiled kernel (~15 s when the cache
# is cold). The default properties use three pairs, each over its whole parameter range
# (IL with 0 < kd <= 1 and eta from 1 + 1e-9 to 1e300 on Beckmann and GGX, mirror facets
# on GGX); the slow ones every pair, from the registries: every registered distribution
# over its declared parameter ranges (roughness 1e-4 to 10, scalars narrowed to
# [1e-4, 1e8]) with, for every registered facet model, its first example of each compiled
# variant. scripts/stress.py covers every pair too.
material_fast = st.one_of(
    st.builds(lambda d, a, b, kd, eta: {"distribution": d, "alpha_x": a, "alpha_y": b, "kd": kd, "eta": eta},
              st.sampled_from(["beckmann", "ggx"]), roughness, roughness, kd_positive, eta_dielectric),
    st.builds(lambda a, b: {"distribution": "ggx", "alpha_x": a, "alpha_y": b, "facet": "mirror"}, roughness, roughness),
)


ALL_VARIANTS = [pytest.param(d, f, raw, id=f"{d}-{f}-{'-'.join(f'{k}={v:g}' for k, v in raw.items()) or 'default'}")
                for d in registry.NAMES for f, _, raw in facets.variant_examples()]


def _material(dist, values, facet, facet_raw):
    """A [material] table: the distribution's canonical values and the facet's example."""
    return {"distribution": dist, **values, "facet": facet, **facet_raw}


theta = st.one_of(st.floats(0.0, 90.0, exclude_max=True), st.sampled_from([0.0, 89.9, 89.99, 89.99999999999999]))


def _run(mat, theta_deg, phi_deg=0.0, paths=BLOCK_SIZE, **simulation):
    simulation.setdefault("seed", 17)
    cfg = validate({"material": mat, "incidence": {"theta_i_deg": [theta_deg], "phi_i_deg": phi_deg, "paths": paths},
                    "simulation": simulation})
    sim = Simulation(cfg)
    table = sim.run()
    books = dict(zip(sim.estimator.STATS, sim.last_state.stats[0]))  # the direction's integer path counts
    return cfg, table, books


def _lossless(material) -> bool:
    """True when no facet event absorbs: ``R + T a >= 1 - 1e-12`` at every cosine of a fine grid,
    ``a = 2 pi K ∫ T mu dmu`` the share of the light entering the body that re-emerges (the
    body term ``K T T``; tests/facet/test_conformance.py checks the event against it)."""
    kind, _, data = facets.prepare(material.facet, material.facet_params)
    factor = facets.body_factor(material.facet, material.facet_params)
    mu, w = np.polynomial.legendre.leggauss(200)
    mu, w = 0.5 * (mu + 1.0), 0.5 * w
    a = 2.0 * math.pi * factor * sum(wk * facets.transmittance(kind, m, data) * m for m, wk in zip(mu, w))
    return all(facets.reflectance(kind, c, data) + facets.transmittance(kind, c, data) * a >= 1.0 - 1e-12
               for c in np.linspace(0.0, 1.0, 65))


def _check_table(folder, mat, theta_deg, phi_deg):
    cfg, res, books = _run(mat, theta_deg, phi_deg, max_bounces=2000, sensor_resolution=15)
    path = folder / "t.h5"
    write_table(path, res)
    table = open_table(path)
    for array in (table.brdf, table.brdf_stderr, table.albedo, table.absorbed, table.truncated, table.degenerate):
        assert np.all(np.isfinite(array)) and np.all(array >= 0.0)
    lost = books["absorbed"] + books["truncated"] + books["degenerate"]
    assert np.array_equal(table.counts[:, 0].sum(axis=1) + lost, table.paths)  # exact integer books
    assert np.all(table.counts[:, 1:].sum(axis=1) <= table.counts[:, 0])
    total = table.albedo[:, 0] + table.absorbed + table.truncated + table.degenerate
    assert np.all(np.abs(total - 1.0) <= 4e-16)
    assert books["degenerate"] == 0
    if _lossless(cfg.material):  # R + T a = 1 at every event: nothing lost
        assert books["absorbed"] == 0


def _check_cap(mat, theta_deg, cap, max_order, track):
    max_order = min(max_order, cap)
    cfg, res, books = _run(mat, theta_deg, max_bounces=cap, max_order=max_order, track_all_orders=track,
                           sensor_resolution=5)
    limit = cfg.effective_max_bounces  # max_order when f_inf is not tracked
    assert res["max_bounces_seen"][0] <= limit
    if books["truncated"] > 0:
        assert res["max_bounces_seen"][0] == limit
    exits = res["counts"][0, 0].sum() if track else res["counts"][0].sum()
    assert exits + books["absorbed"] + books["truncated"] + books["degenerate"] == res["paths"][0]


@SLOW
@given(mat=material_fast, theta_deg=theta, phi_deg=st.floats(0.0, 360.0))
def test_every_table_is_finite_non_negative_with_exact_books(tmp_path, mat, theta_deg, phi_deg):
    _check_table(tmp_path, mat, theta_deg, phi_deg)


@SLOW
@given(mat=material_fast, theta_deg=theta, cap=st.integers(1, 40), max_order=st.integers(1, 3), track=st.booleans())
def test_bounce_cap_bounds_the_work_per_path(mat, theta_deg, cap, max_order, track):
    _check_cap(mat, theta_deg, cap, max_order, track)


SLOW_VALUES = {name: distribution_values(name, roughness=roughness, lo_floor=1e-4, hi_cap=1e8) for name in registry.NAMES}


@pytest.mark.slow
@pytest.mark.parametrize("dist, facet, facet_raw", ALL_VARIANTS)
def test_every_table_all_kernel_variants(tmp_path, dist, facet, facet_raw):
    @settings(deadline=None, max_examples=3, suppress_health_check=[HealthCheck.too_slow,
                                                                    HealthCheck.function_scoped_fixture])
    @given(values=SLOW_VALUES[dist], theta_deg=theta, phi_deg=st.floats(0.0, 360.0))
    def prop(values, theta_deg, phi_deg):
        _check_table(tmp_path, _material(dist, values, facet, facet_raw), theta_deg, phi_deg)

    prop()


@pytest.mark.slow
@pytest.mark.parametrize("dist, facet, facet_raw", ALL_VARIANTS)
def test_bounce_cap_all_kernel_variants(dist, facet, facet_raw):
    @settings(deadline=None, max_examples=3, suppress_health_check=[HealthCheck.too_slow])
    @given(values=SLOW_VALUES[dist], theta_deg=theta, cap=st.integers(1, 40), max_order=st.integers(1, 3),
           track=st.booleans())
    def prop(values, theta_deg, cap, max_order, track):
        _check_cap(_material(dist, values, facet, facet_raw), theta_deg, cap, max_order, track)

    prop()
