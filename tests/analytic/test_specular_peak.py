"""Specular cell integrals of lobes finer than a cell (vcavity.analytic.specular_peak).

References are independent of the code under test: the delta limit of the lobe (all of
it, ``F(cos θ_i)`` with ``G2 = 1`` at ``m = n``, in the mirror direction's cell), the
plain-NumPy Fresnel of tests/reference/materials.py, the mirror symmetry of the sensor
grid, and the plain-NumPy half-vector albedo of tests/reference/single_bounce.py.
Before the peak rays, the sub-cell rule lost the whole lobe of Beckmann alpha 1e-4
(compare: model 0.2756 vs table 0.3173) and 39 % of a Beckmann 0.02 lobe at 89.9 deg.
"""

import math

import numpy as np
import pytest

from tests.reference import materials as ref_mat
from tests.reference import single_bounce as ref_sb
from vcavity.analytic import SingleBounceModel
from vcavity.analytic.cells import specular_integrals
from vcavity.analytic.peak_cells import mirror_cell, peak_cells
from vcavity.config import validate
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import incident_vector

DIELECTRIC = {"facet": "interfaced_lambertian", "kd": 0.0, "eta": 1.5}


def model_of(**raw):
    return SingleBounceModel(validate({"material": dict(DIELECTRIC, **raw)}).material)


@pytest.mark.parametrize("raw", [
    {"distribution": "beckmann", "alpha": 1e-300},
    {"distribution": "ggx", "alpha": 1e-300},
    {"distribution": "phong", "exponent": 1e300},
    {"distribution": "student_t", "alpha": 1e-300, "gamma": 3.0},
], ids=["beckmann-1e-300", "ggx-1e-300", "phong-1e300", "student_t-1e-300"])
@pytest.mark.parametrize("theta_deg", [30.0, 89.99])
def test_delta_lobe_is_the_fresnel_reflectance_in_the_mirror_cell(raw, theta_deg):
    """A lobe far below float resolution is a delta: the mirror cell holds F(cos θ_i)
    (to 1e-12; the integrand is constant, so the rule is exact up to round-off) and no
    other cell holds anything. Before: a ZeroDivisionError surfacing as SystemError."""
    model = model_of(**raw)
    sensor = EqualAreaSensor(9)
    i = incident_vector(math.radians(theta_deg), math.radians(10.0))
    values = specular_integrals(model, i, sensor)
    peak = mirror_cell(i, sensor)
    expected = float(ref_mat.fresnel_reflectance(np.array([i[2]]), 1.5)[0])
    assert values[peak] == pytest.approx(expected, rel=1e-12)
    assert np.max(np.abs(np.delete(values, peak))) < 1e-14


def test_narrow_lobe_on_cell_edges_splits_by_symmetry():
    """With an even resolution the mirror direction of phi_i = 0 lies on the edge v = 0
    (two cells, mirror images: equal halves) and at theta_i = 0 on the corner of four
    cells (quarters). Beckmann alpha 1e-4: the lobe's mass outside those cells is below
    exp(-1e5), so they sum to the half-vector albedo of the plain-NumPy reference."""
    sensor = EqualAreaSensor(16)
    model = model_of(distribution="beckmann", alpha=1e-4)
    material = ref_mat.parse_material(dict(DIELECTRIC, distribution="beckmann", alpha=1e-4))
    for theta_deg in (30.0, 0.0):
        i = incident_vector(math.radians(theta_deg), 0.0)
        values = specular_integrals(model, i, sensor)
        holding = np.flatnonzero(values > 1e-6 * values.max())
        assert holding.size == (2 if theta_deg else 4)
        np.testing.assert_allclose(values[holding], values[holding[0]], rtol=1e-9)
        albedo = ref_sb.specular_albedo_half_vector(material, ref_mat.direction(math.radians(theta_deg), 0.0))
        assert values.sum() == pytest.approx(albedo, rel=1e-7)


def test_grazing_wedge_is_integrated():
    """At 89.9 deg a Beckmann 0.02 lobe is a wedge of width ~alpha |i + o| above the
    mirror direction, far below the cell size: the cells must still sum to the albedo
    (plain-NumPy half-vector reference at 96 x 1024 nodes, converged to 3e-8 there;
    the sub-cell rule alone lost 39 %)."""
    sensor = EqualAreaSensor(17)
    model = model_of(distribution="beckmann", alpha=0.02)
    i = incident_vector(math.radians(89.9), 0.0)
    assert peak_cells(model, i, sensor).size > 0
    material = ref_mat.parse_material(dict(DIELECTRIC, distribution="beckmann", alpha=0.02))
    albedo = ref_sb.specular_albedo_half_vector(material, ref_mat.direction(math.radians(89.9), 0.0),
                                                n_gauss=96, n_phi=1024)
    assert specular_integrals(model, i, sensor).sum() == pytest.approx(albedo, rel=1e-6)


def test_wide_lobe_has_no_peak_cells():
    """The figure 7(b) lobe at 60 deg is resolved by the sub-cell rule: no rays, and the
    integrals are those of the plain rule."""
    sensor = EqualAreaSensor(17)
    model = SingleBounceModel(validate({"material": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9,
                                                     "eta": 1.5}}).material)
    i = incident_vector(math.radians(60.0), 0.0)
    assert peak_cells(model, i, sensor).size == 0
