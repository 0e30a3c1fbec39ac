"""The walk with conductor facets (physics.md sec. 4, 7): f1 against the V-cavity
single-bounce model and against the independent NumPy reference, and every order's albedo
below the mirror's.

f1: Pearson chi-square of the f1 counts per cell (expected < 5 pooled, plus the "not f1"
category) and the z-test of the f1 albedo, against (a) the package's
``SingleBounceModel`` with V-cavity masking (the exact expectation of f1) and (b)
tests/reference/single_bounce.py with the conductor Fresnel of
tests/reference/conductor_fresnel.py. The four tests are at the Sidak level for a
family-wise false-positive rate of 1 % (fixed seed: the outcome is deterministic; the
rate is over the choice of seed).

Every run here is Beckmann with conductor facets (and the mirror, already compiled by
the default suite), so the module adds one compiled kernel.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

from tests.reference import materials as ref_mat  # noqa: E402
from tests.reference import single_bounce as ref_sb  # noqa: E402
from tests.validation._reference_runs import (assert_pass, incident, order_counts, run, sensor_of,  # noqa: E402
                                              sidak_threshold, verdicts)
from vcavity.analytic.cells import cell_integrals  # noqa: E402
from vcavity.analytic.single_bounce import SingleBounceModel  # noqa: E402
from vcavity.config import validate  # noqa: E402
from vcavity.simulate.pipeline import incident_vector  # noqa: E402

# gold at 450.9 nm (Johnson & Christy 1972): F falls from 0.85 at grazing to 0.41 at normal
# incidence, so an F evaluated at the wrong cosine shows (at 548.6 nm F is flat within 1 %
# from cos 0.3 to 1, and the macro cosine instead of the facet's went unnoticed)
GOLD = {"distribution": "beckmann", "alpha": 0.5, "facet": "conductor", "eta": 1.38, "k": 1.914}
THETA_DEG, PHI_DEG = 70.0, 30.0  # phi not a symmetry plane: a mirrored exit azimuth fails
PATHS = 1_000_000
RESOLUTION = 15
LEVEL = sidak_threshold(0.01, 4)


@pytest.fixture(scope="module")
def gold_f1():
    return run(GOLD, THETA_DEG, PHI_DEG, PATHS, RESOLUTION, seed=5150, max_order=1)


def test_f1_matches_the_vcavity_model(gold_f1):
    cfg = validate({"material": GOLD, "incidence": {"theta_i_deg": [THETA_DEG], "phi_i_deg": PHI_DEG}})
    model = SingleBounceModel(cfg.material, masking="vcavity")
    i = incident_vector(math.radians(THETA_DEG), math.radians(PHI_DEG))
    chi, z = verdicts(order_counts(gold_f1, 1), cell_integrals(model, i, sensor_of(gold_f1)), PATHS)
    assert_pass(chi, z, LEVEL, "blue gold f1 vs SingleBounceModel")


def test_f1_matches_the_independent_reference(gold_f1):
    probabilities = ref_sb.f1_cells(ref_mat.parse_material(GOLD), incident(THETA_DEG, PHI_DEG), RESOLUTION)
    chi, z = verdicts(order_counts(gold_f1, 1), probabilities, PATHS)
    assert_pass(chi, z, LEVEL, "blue gold f1 vs tests/reference")


def test_every_order_albedo_is_below_the_mirrors():
    # Same distribution, seed and directions: the conductor absorbs at every hit
    # (F < 0.86 for gold at 450.9 nm), so each order keeps less; the margins are tens
    # of standard errors, so no false positive is possible at this seed.
    mirror = {key: value for key, value in GOLD.items() if key not in ("facet", "eta", "k")}
    mirror["facet"] = "mirror"
    thetas, phis = [0.0, 45.0, 75.0], [0.0, 20.0, 60.0]
    gold = run(GOLD, thetas, phis, 100_000, 9, seed=77, max_order=4)
    perfect = run(mirror, thetas, phis, 100_000, 9, seed=77, max_order=4)
    assert np.array_equal(gold["order"], perfect["order"]) and 0 in gold["order"]
    for d in range(len(thetas)):
        for slot, k in enumerate(gold["order"]):
            g, m = gold["counts"][d, slot].sum(), perfect["counts"][d, slot].sum()
            assert g < m or m == 0, (thetas[d], int(k), int(g), int(m))
        assert gold["absorbed"][d] > 0 and perfect["absorbed"][d] == 0
