"""The every-order model of specular V-cavities (vcavity/analytic/specular_orders.py,
physics.md sec. 12): energy, the deterministic NumPy groove-path reference per cell and
order (tests/reference/groove_paths.groove_orders: midpoint grid over normals, exact
entry pieces, independent code), and the honesty of its error estimate (a forced coarse
rule against a fine one). Deterministic quadratures: no false-positive rate."""

import numpy as np
import pytest

from tests.reference import groove_paths as G
from tests.reference import materials as M
from vcavity.analytic.single_bounce import ModelNotApplicable
from vcavity.analytic.specular_orders import is_specular, specular_orders
from vcavity.config import validate
from vcavity.sensor.directions import incident_vector
from vcavity.sensor.grid import EqualAreaSensor


def material(**raw):
    return validate({"material": raw}).material


@pytest.mark.parametrize("alpha", [0.05, 0.6, 3.0])
@pytest.mark.parametrize("theta_i", [0.0, 60.0, 85.0])
def test_mirror_energy_is_conserved(alpha, theta_i):
    """Mirror facets absorb nothing: what is not truncated by the cap leaves, to 1e-9."""
    result = specular_orders(material(distribution="beckmann", alpha=alpha, facet="mirror"),
                             incident_vector(np.radians(theta_i), 0.0), EqualAreaSensor(3), 3, 10_000, tolerance=1e-2)
    assert abs(result.exited + result.truncated - 1.0) < 1e-9
    assert result.absorbed < 1e-9
    assert np.all(result.integrals >= 0.0)


def test_dielectric_absorbs_and_orders_fall():
    """kd = 0, eta 1.5: survival < 1 at every hit, so less leaves than with mirrors."""
    inc = incident_vector(np.radians(40.0), 0.0)
    dielectric = specular_orders(material(distribution="ggx", alpha=0.5, facet="interfaced_lambertian", kd=0.0,
                                          eta=1.5), inc, EqualAreaSensor(3), 3, 10_000, tolerance=1e-2)
    assert 0.0 < dielectric.exited < 0.5 and dielectric.absorbed > 0.5
    per_order = dielectric.integrals.sum(axis=1)
    assert per_order[0] > per_order[1] > per_order[2] > 0.0


def test_refuses_facets_with_a_body():
    with pytest.raises(ModelNotApplicable, match="specular facets"):
        specular_orders(material(distribution="beckmann", alpha=0.5, kd=0.5, eta=1.5), incident_vector(0.0, 0.0),
                        EqualAreaSensor(3), 3, 100)
    assert not is_specular(material(distribution="beckmann", alpha=0.5, kd=0.0, eta=1.0))
    assert is_specular(material(distribution="beckmann", alpha=0.5, kd=0.0, eta=1.5))


# (material, theta_i, phi_i): mirrors and a dielectric, isotropic and anisotropic
CASES = [
    ({"distribution": "beckmann", "alpha": 0.8, "facet": "mirror"}, 30.0, 0.0),
    ({"distribution": "ggx", "alpha": 0.5, "facet": "mirror"}, 70.0, 0.0),
    ({"distribution": "beckmann", "alpha_x": 0.6, "alpha_y": 0.2, "facet": "mirror"}, 50.0, 45.0),
    ({"distribution": "beckmann", "alpha": 0.8, "facet": "interfaced_lambertian", "kd": 0.0, "eta": 1.5}, 60.0, 0.0),
]


@pytest.mark.parametrize("raw, theta_i, phi_i", CASES)
def test_orders_match_the_groove_path_reference(raw, theta_i, phi_i):
    """Per cell and order on a 9 x 9 sensor: relative L1 within the reference's own measured
    accuracy on its 256 x 512 grid (groove_paths.ACCURACY) plus the model's estimate."""
    n = 9
    inc = incident_vector(np.radians(theta_i), np.radians(phi_i))
    model = specular_orders(material(**raw), inc, EqualAreaSensor(n), 3, 10_000, tolerance=1e-4)
    ref_material = M.parse_material(raw)
    p, _ = G.groove_orders(ref_material, M.direction(np.radians(theta_i), np.radians(phi_i)), n, 3, 256, 512, 8)
    accuracy = G.ACCURACY[(256, 512)]
    for k in range(3):
        l1 = np.abs(model.integrals[k] - p[k]).sum() / p[k].sum()
        bound = 2.0 * accuracy[f"f{k + 1}_l1"] + model.error[k].sum() / p[k].sum()
        assert l1 < bound, (k + 1, l1, bound)


def test_error_estimate_of_a_coarse_rule_is_honest():
    """A forced coarse rule (no refinement, 3 nodes): its estimate per order is at least
    its actual L1 error against a fine rule, and the fine rule is far better."""
    mat = material(distribution="ggx", alpha=0.4, facet="mirror")
    inc, sensor = incident_vector(np.radians(45.0), 0.0), EqualAreaSensor(9)
    fine = specular_orders(mat, inc, sensor, 3, 10_000, tolerance=1e-6, n_azimuth=8, n_radial=8)
    coarse = specular_orders(mat, inc, sensor, 3, 10_000, n_azimuth=3, n_radial=3, refine=False)
    actual = np.abs(coarse.integrals - fine.integrals).sum(axis=1)
    estimate = coarse.error.sum(axis=1)
    assert np.all(estimate >= actual), (estimate, actual)
    assert actual[0] > 10.0 * fine.error[0].sum()  # the coarse rule is measurably worse
