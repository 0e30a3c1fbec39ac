"""The jitted kernel against the independent plain-NumPy walk (tests/reference/numpy_walk.py).

Both are analog walks of the same model, so their counts per (order slot, cell) and their
absorbed counts are two samples of one multinomial. Each material makes one two-sample
chi-square (homogeneity) over the categories "(order slot, cell)" with at least 20 paths
in the two runs, the pooled rest, and "absorbed"; it rejects at p < 1e-4, so the
family-wise false-positive rate over the four materials is below 4e-4 (fixed seeds: the
rate is over the choice of seeds). A cheap default-suite case (the fig. 7(b) material,
whose kernel variant the suite compiles anyway) and slow cases for other distributions,
facet limits and an anisotropic groove.
"""

import math
import sys
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy import stats  # noqa: E402

from tests.reference.numpy_walk import walk  # noqa: E402
from vcavity.config import validate  # noqa: E402
from vcavity.facet import registry as facets  # noqa: E402
from vcavity.kernels import walks  # noqa: E402
from vcavity.microfacet import registry as distributions  # noqa: E402
from vcavity.rng import BLOCK_SIZE  # noqa: E402

RESOLUTION = 9
MAX_ORDER = 3


def _kernel_counts(material, theta, phi, n_paths, key):
    m = validate({"material": material}).material
    dist_kind, params = distributions.params_from(m.distribution, m.distribution_params)
    facet_kind, variant, data = facets.prepare(m.facet, m.facet_params)
    walk = walks.get("v-cavity", dist_kind, facet_kind, variant)
    incident = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])
    tallies, stats = walk(walks.WalkCall(
        incident=incident, direction_key=np.uint64(key), first_block=0, n_blocks=-(-n_paths // BLOCK_SIZE),
        n_paths=n_paths, params=params, facet_data=data, max_bounces=10_000, max_order=MAX_ORDER,
        resolution=RESOLUTION, n_slots=2))
    return tallies["counts"], int(stats["absorbed"])


def _homogeneity_p(material, theta_deg, phi_deg, n_paths):
    theta, phi = math.radians(theta_deg), math.radians(phi_deg)
    ours, absorbed = _kernel_counts(material, theta, phi, n_paths, 2024)
    ref, totals = walk(material, theta, phi, n_paths, RESOLUTION, MAX_ORDER, seed=2024)
    table = np.array([ours.ravel(), ref.ravel()])
    keep = table.sum(axis=0) >= 20
    rows = np.column_stack([table[:, keep], table[:, ~keep].sum(axis=1), [absorbed, totals["absorbed"]]])
    rows = rows[:, rows.sum(axis=0) > 0]
    return stats.chi2_contingency(rows).pvalue


def test_fig7b_material_agrees_with_the_numpy_walk():
    material = {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.5}
    assert _homogeneity_p(material, 60.0, 25.0, 400_000) > 1e-4


@pytest.mark.slow
@pytest.mark.parametrize("material, theta_deg, phi_deg", [
    ({"distribution": "ggx", "alpha_x": 0.8, "alpha_y": 0.15, "facet": "interfaced_lambertian", "kd": 0.7, "eta": 1.0},
     45.0, 30.0),
    ({"distribution": "beckmann", "alpha_x": 0.2, "alpha_y": 0.7, "facet": "mirror"}, 72.5, 20.0),
    ({"distribution": "ggx", "alpha": 0.5, "facet": "interfaced_lambertian", "kd": 0.0, "eta": 1.5}, 35.0, 0.0),
], ids=["ggx-aniso-lambertian", "beckmann-aniso-mirror", "ggx-dielectric"])
def test_other_materials_agree_with_the_numpy_walk(material, theta_deg, phi_deg):
    assert _homogeneity_p(material, theta_deg, phi_deg, 2_000_000) > 1e-4
