"""Every estimator agrees with the analog walk within error bars (physics.md sec. 11).

For each material and estimator, an independent run (its own seed) of the estimator and
of the analog walk give two estimates of each cell of f_inf and f2; under the hypothesis
that both estimate the same BRDF, ``z = (a - b) / sqrt(sa^2 + sb^2)`` is close to standard
normal in cells with enough paths (>= 40 analog counts), so ``Σ z^2`` is chi-square with
one degree per cell. Each test has a false-alarm rate of 1e-3 (Sidak over its two orders);
with 12 tests the whole file raises a false alarm with probability about 1.2e-2. The
tests fail for a biased estimator: e.g. a paper weight without its 1/(m.n) factor, or an
exact-f1 table that drops (or double counts) the analytic f1 in f_inf.
"""

import numpy as np
import pytest
from scipy import stats

from vcavity import config as config_mod
from vcavity.simulate.pipeline import simulate

pytestmark = pytest.mark.slow

FAMILY_ALPHA = 1e-3
PER_ORDER = 1.0 - (1.0 - FAMILY_ALPHA) ** 0.5  # Sidak over f_inf and f2

MATERIALS = {
    "beckmann-il": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
    "ggx-aniso-il": {"distribution": "ggx", "alpha_x": 0.5, "alpha_y": 0.2, "kd": 0.8, "eta": 1.5},
    "beckmann-mirror": {"distribution": "beckmann", "alpha": 0.5, "facet": "mirror"},
    "ggx-lambertian": {"distribution": "ggx", "alpha": 0.8, "kd": 0.7, "eta": 1.0},
}


def _run(material, estimator, seed, phi_deg, paths=1_500_000):
    raw = {"material": material,
           "incidence": {"theta_i_deg": [55.0], "phi_i_deg": phi_deg, "paths": paths},
           "simulation": {"seed": seed, "max_order": 2, "sensor_resolution": 19, "estimator": estimator,
                          "fold_symmetry": False}}
    return simulate(config_mod.validate(raw))


@pytest.mark.parametrize("estimator", ["paper", "exact-f1"])
@pytest.mark.parametrize("name", list(MATERIALS))
def test_estimator_agrees_with_analog(name, estimator):
    phi = 30.0 if "aniso" in name else 0.0  # anisotropic: off the principal planes
    analog = _run(MATERIALS[name], "analog", seed=101, phi_deg=phi)
    other = _run(MATERIALS[name], estimator, seed=202, phi_deg=phi)
    for k in (0, 2):
        row = list(analog["order"]).index(k)
        lit = analog["counts"][0, row] >= 40
        assert lit.sum() >= 40, (name, k)
        sigma = np.hypot(analog["brdf_stderr"][0, row, lit], other["brdf_stderr"][0, row, lit])
        z = (other["brdf"][0, row, lit] - analog["brdf"][0, row, lit]) / sigma
        p = stats.chi2.sf(np.sum(z * z), lit.sum())
        assert p > PER_ORDER, (name, estimator, k, lit.sum(), float(np.sum(z * z)))
