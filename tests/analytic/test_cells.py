"""Cell averaging (physics.md sec. 6) and directional albedos (physics.md sec. 9),
against brute-force references and sensor-independent exact values."""

import math

import numpy as np
import pytest
from scipy import integrate, special

from vcavity.analytic.albedo import (
    hemispherical_albedo,
    lambertian_normal_f1_albedo,
    mean_cos_theta_m,
    single_bounce_albedo,
    specular_albedo,
)
from vcavity.analytic.cells import cell_average, cell_integrals, expected_counts, specular_subpoints
from vcavity.analytic.oren_nayar import LambertModel
from vcavity.analytic.single_bounce import SingleBounceModel
from vcavity.config import validate
from vcavity.sensor.binning import cell_index, square_to_hemisphere
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import incident_vector


def model_of(masking="vcavity", n_nodes=64, **kw):
    return SingleBounceModel(validate({"material": kw}).material, masking=masking, n_nodes=n_nodes)


def concentric_map(u, v):
    """Shirley-Chiu square -> disk, then z = 1 - r^2, (x, y) = d sqrt(2 - r^2) (physics.md sec. 6)."""
    first = np.abs(u) > np.abs(v)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(first, u, v)
        phi = np.where(first, math.pi / 4 * v / u, math.pi / 2 - math.pi / 4 * u / v)
    r = np.where((u == 0) & (v == 0), 0.0, r)
    phi = np.where((u == 0) & (v == 0), 0.0, phi)
    lift = np.sqrt(2 - r * r)
    return np.stack([r * np.cos(phi) * lift, r * np.sin(phi) * lift, 1 - r * r], axis=1)


def test_concentric_map_reference_matches_the_sensor():
    rng = np.random.default_rng(0)
    u, v = rng.uniform(-1, 1, 200), rng.uniform(-1, 1, 200)
    np.testing.assert_allclose(concentric_map(u, v), [square_to_hemisphere(a, b) for a, b in zip(u, v)],
                               atol=1e-14)


def midpoint_cell_integral(projected, incident, sensor, cell, n):
    """Midpoint rule in the cell's square coordinates, dω = (π/2) du dv (physics.md sec. 9)."""
    width = 2.0 / sensor.resolution
    ix, iy = cell % sensor.resolution, cell // sensor.resolution
    t = (np.arange(n) + 0.5) / n
    u = -1.0 + width * (ix + t)
    v = -1.0 + width * (iy + t)
    uu, vv = np.meshgrid(u, v)
    dirs = concentric_map(uu.ravel(), vv.ravel())
    return float(np.sum(projected(incident, dirs)) * (0.5 * math.pi) * (width / n) ** 2)


def brute_force_cell_integral(projected, incident, sensor, cell):
    """Richardson-extrapolated midpoint rules (150^2 and 300^2): the O(h^2) error of
    the kinks cancels to a few 1e-8 relative."""
    coarse = midpoint_cell_integral(projected, incident, sensor, cell, 150)
    fine = midpoint_cell_integral(projected, incident, sensor, cell, 300)
    return (4.0 * fine - coarse) / 3.0


@pytest.mark.parametrize("theta_deg", [0.0, 35.0, 75.0])
def test_cell_integrals_match_brute_force(theta_deg):
    # includes cells on the diagonals |u| = |v| and the narrow lobe of alpha = 0.08;
    # the sub-cell rules are good to ~1e-5 in dim horizon cells, 1e-6 elsewhere.
    sensor = EqualAreaSensor(15)
    # (few body nodes: both sides integrate the same function of o, so only the
    # quadrature over the cell is tested here)
    model = model_of(distribution="beckmann", alpha=0.08, kd=0.6, eta=1.5, n_nodes=32)
    i = incident_vector(math.radians(theta_deg), 0.4)
    spec_dir = np.array([-i[0], -i[1], i[2]])
    lobe_cell = int(cell_index(sensor, spec_dir))
    cells = np.array(sorted({lobe_cell, 0, 7, 16, 112}))
    got = cell_integrals(model, i, sensor, cells=cells)
    for k, c in enumerate(cells):
        expected = brute_force_cell_integral(model.projected, i, sensor, int(c))
        assert got[k] == pytest.approx(expected, rel=1e-5, abs=1e-12)
    # the whole-sensor call agrees with the subset call, and averages divide by Ω⊥
    everything = cell_integrals(model, i, sensor)
    np.testing.assert_allclose(everything[cells], got, rtol=1e-12)
    np.testing.assert_allclose(cell_average(model, i, sensor) * sensor.cell_projected_solid_angle, everything,
                               rtol=1e-12)
    np.testing.assert_allclose(expected_counts(model, i, sensor, 1000), 1000 * everything, rtol=1e-12)


def test_lambert_cells_are_kd_over_pi():
    sensor = EqualAreaSensor(9)
    avg = cell_average(LambertModel(0.8), np.array([0.0, 0.0, 1.0]), sensor)
    np.testing.assert_allclose(avg, 0.8 / math.pi, rtol=1e-12)


@pytest.mark.parametrize("material", [
    dict(distribution="beckmann", alpha=0.05, kd=0.0, eta=1.5),
    dict(distribution="ggx", alpha_x=0.3, alpha_y=0.9, kd=0.0, eta=2.5),
    dict(distribution="phong", exponent=40.0, facet="mirror"),
])
@pytest.mark.parametrize("theta_deg", [0.0, 50.0, 80.0])
def test_specular_albedo_sensor_sum_equals_half_vector_integral(material, theta_deg):
    # Two independent quadratures of the same integral: the sum of cell integrals over
    # the sensor (o-space) and the half-vector integral (h-space, W eq. 14).
    model = model_of(**material)
    sensor = EqualAreaSensor(57)
    i = incident_vector(math.radians(theta_deg), 0.7)
    by_cells = cell_integrals(model, i, sensor).sum()
    by_h = specular_albedo(model, i)
    assert by_cells == pytest.approx(by_h, rel=2e-5)
    assert specular_subpoints(model, sensor) >= 16


@pytest.mark.parametrize("dist, params, exact", [
    ("beckmann", dict(alpha=0.6), lambda: math.sqrt(math.pi) / 0.6 * special.erfcx(1 / 0.6)),
    ("beckmann", dict(alpha=0.1), lambda: math.sqrt(math.pi) / 0.1 * special.erfcx(1 / 0.1)),
    ("ggx", dict(alpha=0.5), lambda: integrate.quad(
        lambda u: math.sqrt((1 - u) / (1 - u + 0.25 * u)), 0, 1, epsabs=1e-14, epsrel=1e-13)[0]),
])
def test_mean_cos_theta_m(dist, params, exact):
    # E[cos theta_m], m ~ D(m)(m.n): Beckmann E[(1 + alpha^2 X)^-1/2], X ~ Exp(1), in
    # closed form with erfcx; GGX tan^2 = alpha^2 u/(1-u) integrated by scipy.
    model = model_of(distribution=dist, kd=1.0, eta=1.0, **params)
    assert mean_cos_theta_m(model) == pytest.approx(exact(), rel=1e-10)


@pytest.mark.parametrize("material", [
    dict(distribution="beckmann", alpha=0.6, kd=1.0, eta=1.0),
    dict(distribution="ggx", alpha_x=0.2, alpha_y=0.9, kd=0.5, eta=1.0),
    dict(distribution="gaussian", sigma=0.5, kd=1.0, eta=1.0),
])
def test_body_albedo_at_normal_incidence_is_the_view_factor(material):
    # eta = 1, theta_i = 0: a1 = kd E[cos theta_m] exactly (crossed strings, albedo.py);
    # both the sensor sum and the hemispherical rule reproduce it to 1e-7.
    model = model_of(**material)
    exact = lambertian_normal_f1_albedo(model)
    i = np.array([0.0, 0.0, 1.0])
    assert cell_integrals(model, i, EqualAreaSensor(31)).sum() == pytest.approx(exact, rel=1e-7)
    assert sum(single_bounce_albedo(model, i)) == pytest.approx(exact, rel=1e-7)
    with pytest.raises(ValueError):
        lambertian_normal_f1_albedo(model_of(distribution="beckmann", alpha=0.6, kd=1.0, eta=1.5))


def test_hemispherical_albedo_of_lambert_and_body_convergence():
    assert hemispherical_albedo(LambertModel(0.7), np.array([0.3, 0.0, math.sqrt(0.91)])) == pytest.approx(0.7)
    # body albedo at oblique incidence: sensor sum and hemispherical rule agree (1e-6),
    # and the n_nodes control converges (64 vs 128 nodes: < 2e-5)
    material = validate({"material": dict(distribution="ggx", alpha=0.8, kd=0.9, eta=1.5)}).material
    i = incident_vector(math.radians(70.0), 0.0)
    coarse = SingleBounceModel(material, n_nodes=64)
    fine = SingleBounceModel(material, n_nodes=128)
    a64 = single_bounce_albedo(coarse, i)[1]
    a128 = single_bounce_albedo(fine, i)[1]
    assert a64 == pytest.approx(a128, rel=2e-5)
    by_cells = cell_integrals(_body_only(coarse), i, EqualAreaSensor(31), n_sub=4).sum()
    assert by_cells == pytest.approx(a64, rel=1e-6)


def _body_only(model):
    class Body:
        def projected(self, i, o):
            return model.body_projected(i, o)
    return Body()
