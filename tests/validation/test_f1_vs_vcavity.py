"""f1 of the simulator against the V-cavity single-bounce model (physics.md sec. 7).

The model (specular + IL body with G2 = min(G1_V)) is exactly the expectation of f1,
so the f1 counts of each configuration must pass Pearson's chi-square test against
``N ∫_c f1 cos θ_o dω_o`` (cells with expected < 5 pooled, plus the "not f1"
category) AND the z-test of the f1 albedo (the total). Both tests per configuration at
the Sidak level ``1 - (1 - 0.01)^(1/(2n))`` for the n configurations of a run:
family-wise false-alarm rate 1 % for the fast subset and 1 % for the full matrix (fixed
seeds: the outcome is deterministic; the rate is over the choice of seeds). Both
statistics are fail-safe (a model predicting albedo >= 1 or NaN fails). The model's own error (body nodes,
sub-cell quadrature) is below 1e-4 relative per cell (docs/validation.md), far below
the per-cell noise of these runs (> 1e-2), so it cannot cause a false alarm.

The matrix covers Beckmann, GGX, anisotropic GGX and Beckmann, Phong and Gaussian
distributions; eta 1, 1.5, 2.5; kd 0, 0.5, 1 and mirror facets; theta_i 0 to 80 deg;
alpha 0.05 to 1. The registry matrix (slow) is built from the registries: every example of
every registered distribution, each with a compiled variant of a facet model in turn (the
model's first example of that variant), and every (distribution, facet variant) pair at
least once (the typical example where the turn missed it), at incidences 0 to 80 deg in
turn: a new distribution or facet model enters it with no edit. Family-wise 1 % over its
cases likewise.
"""

import math

import pytest

from vcavity.analytic.cells import cell_integrals
from vcavity.analytic.single_bounce import SingleBounceModel
from vcavity.analytic.statistics import albedo_z_test, pearson_chi_square, sidak_threshold
from vcavity.config import validate
from vcavity.facet import registry as facets
from vcavity.microfacet import registry as distributions
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import incident_vector, simulate

# (id, material, theta_i_deg, phi_i_deg)
MATRIX = [
    ("fig7-beckmann", {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5}, 60.0, 0.0),
    ("ggx-aniso-dielectric", {"distribution": "ggx", "alpha_x": 0.1, "alpha_y": 0.5, "kd": 0.0, "eta": 2.5}, 50.0, 60.0),
    ("gaussian-lambertian", {"distribution": "gaussian", "sigma": 0.4, "kd": 1.0, "eta": 1.0}, 0.0, 0.0),
    ("beckmann-mirror-grazing", {"distribution": "beckmann", "alpha": 0.3, "facet": "mirror"}, 80.0, 10.0),
    ("beckmann-narrow-dielectric", {"distribution": "beckmann", "alpha": 0.05, "kd": 0.0, "eta": 1.5}, 30.0, 0.0),
    ("beckmann-lambertian-grazing", {"distribution": "beckmann", "alpha": 1.0, "kd": 1.0, "eta": 1.0}, 80.0, 0.0),
    ("beckmann-aniso-il", {"distribution": "beckmann", "alpha_x": 0.2, "alpha_y": 0.8, "kd": 0.5, "eta": 2.5}, 45.0, 30.0),
    ("ggx-il-normal", {"distribution": "ggx", "alpha": 0.3, "kd": 0.5, "eta": 1.5}, 0.0, 0.0),
    ("ggx-rough-il", {"distribution": "ggx", "alpha": 1.0, "kd": 1.0, "eta": 2.5}, 70.0, 0.0),
    ("ggx-narrow-lambertian", {"distribution": "ggx", "alpha": 0.05, "kd": 1.0, "eta": 1.0}, 20.0, 0.0),
    ("phong-il", {"distribution": "phong", "exponent": 20.0, "kd": 0.5, "eta": 1.5}, 40.0, 0.0),
    ("phong-mirror", {"distribution": "phong", "exponent": 200.0, "facet": "mirror"}, 10.0, 0.0),
    ("gaussian-il-grazing", {"distribution": "gaussian", "sigma": 0.2, "kd": 0.5, "eta": 1.5}, 75.0, 0.0),
    ("ggx-aniso-il-grazing", {"distribution": "ggx", "alpha_x": 0.6, "alpha_y": 0.15, "kd": 0.5, "eta": 1.5}, 80.0, 45.0),
]
FAST = MATRIX[:4]


def f1_chi_square(material, theta_deg, phi_deg, paths, resolution, seed):
    cfg = validate({"material": material,
                    "incidence": {"theta_i_deg": [theta_deg], "phi_i_deg": phi_deg, "paths": paths},
                    "simulation": {"seed": seed, "max_order": 1, "track_all_orders": False,
                                   "sensor_resolution": resolution}})
    result = simulate(cfg)
    model = SingleBounceModel(cfg.material, masking="vcavity")
    incident = incident_vector(math.radians(theta_deg), math.radians(phi_deg))
    expected = paths * cell_integrals(model, incident, EqualAreaSensor(resolution))
    observed = result["counts"][0, 0]
    return (pearson_chi_square(observed, expected, paths),
            albedo_z_test(int(observed.sum()), float(expected.sum()) / paths, paths))


@pytest.mark.parametrize("name, material, theta_deg, phi_deg", FAST, ids=[c[0] for c in FAST])
def test_f1_matches_vcavity_model_fast(name, material, theta_deg, phi_deg):
    chi, albedo = f1_chi_square(material, theta_deg, phi_deg, 1_000_000, 25, seed=101)
    level = sidak_threshold(0.01, 2 * len(FAST))
    assert chi.passed(level), (name, chi)
    assert albedo.passed(level), (name, albedo)


@pytest.mark.slow
@pytest.mark.parametrize("name, material, theta_deg, phi_deg", MATRIX, ids=[c[0] for c in MATRIX])
def test_f1_matches_vcavity_model_matrix(name, material, theta_deg, phi_deg):
    chi, albedo = f1_chi_square(material, theta_deg, phi_deg, 8_000_000, 57, seed=202)
    level = sidak_threshold(0.01, 2 * len(MATRIX))
    assert chi.passed(level), (name, chi)
    assert albedo.passed(level), (name, albedo)


def _registry_matrix():
    variants = [(f"{name}-{label}", {"facet": name, **example})
                for name, label, example in facets.variant_examples()]
    thetas = [0.0, 30.0, 60.0, 80.0, 45.0]
    cases = []
    for d, module in enumerate(distributions.MODULES):
        examples = list(module.EXAMPLES.items())
        pairs = [(examples[j], variants[(j + d) % len(variants)]) for j in range(len(examples))]
        covered = {v for _, (v, _) in pairs}
        pairs += [(examples[0], (v, f)) for v, f in variants if v not in covered]
        for (label, example), (vname, facet) in pairs:
            theta = thetas[len(cases) % len(thetas)]
            cases.append((f"{module.NAME}-{label}-{vname}", {"distribution": module.NAME, **example, **facet},
                          theta, 25.0))
    return cases


REGISTRY_MATRIX = _registry_matrix()


@pytest.mark.slow
@pytest.mark.parametrize("name, material, theta_deg, phi_deg", REGISTRY_MATRIX, ids=[c[0] for c in REGISTRY_MATRIX])
def test_f1_matches_vcavity_model_registry_matrix(name, material, theta_deg, phi_deg):
    chi, albedo = f1_chi_square(material, theta_deg, phi_deg, 2_000_000, 17, seed=303)
    level = sidak_threshold(0.01, 2 * len(REGISTRY_MATRIX))
    assert chi.passed(level), (name, chi)
    assert albedo.passed(level), (name, albedo)
