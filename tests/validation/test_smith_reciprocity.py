"""Reciprocity of the Smith walk, f_inf and each order: f_k(i, o) = f_k(o, i) (physics.md sec. 8, 15).

The design of tests/validation/test_reciprocity.py (the V-cavity walk's), run on the Smith
kernel directly. Both sides estimate one symmetric double integral over a pair of sensor
cells (A, B), ``Q(A, B) = ∫_A ∫_B f_k(i, o) cos θ_i cos θ_o dω_o dω_i``: Q(A -> B) from
incident directions at the ``n_sub x n_sub`` Gauss-Legendre nodes of cell A (weights
``w_q``, ``subcell_quadrature``) counting order-k exits in B, ``Σ_q w_q cos θ_q n_q(B)/N``;
Q(B -> A) the other way. The node rule's own asymmetry must stay well below the
Monte-Carlo error: measured with the (reciprocal) height-correlated Smith f1 model over
every linked pair, as the mean z² it adds per pair at the test's path counts, it is
0.004 for the default material with 4 x 4 nodes at 1.2e4 paths (3 x 3 nodes at 2e4:
0.17) and 0.005 for Beckmann 0.7 x 0.2 with 6 x 6 nodes at 5e4 (3 x 3 nodes: 1.97, which
made a first run of that slow case fail at chi2 = 72 on 25 pairs for f_inf and 56 for f1).

Statistics. ``z = (Q(A->B) - Q(B->A))/sqrt(var + var)`` with binomial variances; the
pairs are independent simulations, so ``Σ z²`` over the pairs is chi-square with one
degree of freedom per pair. One test per order slot (f_inf, f1, f2, f3), each at the
Šidák level of a 1e-3 false-alarm rate for the four (fixed seeds).

Pairs come from a pilot run with its own seed (cell-centre incidence; independent of the
test's counts, so the choice cannot bias the statistic): among the pairs the pilot saw
carrying paths of every order both ways, ``n_pairs`` at random.
"""

import math

import numpy as np
import pytest
from scipy import stats

from vcavity.analytic.quadrature import subcell_quadrature
from vcavity.config import validate
from vcavity.facet import registry as facets
from vcavity.kernels import walks
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, direction_key
from vcavity.sensor.directions import incident_vector
from vcavity.sensor.grid import EqualAreaSensor

RESOLUTION = 6  # 36 cells of 0.175 sr
MAX_ORDER = 3
PILOT_PATHS = 5_000
FALSE_ALARM = 1e-3


def _walker(material):
    m = validate({"material": dict(material, microsurface="smith")}).material
    dist_kind, params = distributions.params_from(m.distribution, m.distribution_params)
    facet_kind, variant, data = facets.prepare(m.facet, m.facet_params)
    walk = walks.get("smith", dist_kind, facet_kind, variant)

    def counts(theta, phi, n_paths, seed):
        """(order slot, cell) counts; slot 0 is f_inf here (every exit)."""
        tallies, _ = walk(walks.WalkCall(
            incident=incident_vector(theta, phi), direction_key=direction_key(seed, theta, phi), first_block=0,
            n_blocks=-(-n_paths // BLOCK_SIZE), n_paths=n_paths, params=params, facet_data=data, max_bounces=10_000,
            max_order=MAX_ORDER, resolution=RESOLUTION, n_slots=2))
        c = tallies["counts"]
        c[0] = c.sum(axis=0)
        return c

    return counts


def reciprocity_statistics(material, n_pairs, paths, seed, n_sub):
    """{order slot: (Σ z², pairs)} (slot 0: f_inf), ``n_sub x n_sub`` incident nodes per cell."""
    walk = _walker(material)
    sensor = EqualAreaSensor(RESOLUTION)
    pilot = np.array([walk(t, p, PILOT_PATHS, seed + 1_000_003) for t, p in zip(sensor.cell_theta, sensor.cell_phi)])
    carries = np.all(pilot > 0, axis=1)  # (source cell, target cell): every order seen
    both_ways = carries & carries.T
    eligible = [(a, b) for a in range(sensor.n_cells) for b in range(a + 1, sensor.n_cells) if both_ways[a, b]]
    assert len(eligible) >= n_pairs, f"the material links only {len(eligible)} cell pairs in every order"
    rng = np.random.default_rng(seed)
    pairs = [eligible[k] for k in sorted(rng.choice(len(eligible), size=n_pairs, replace=False))]
    cells = sorted({c for pair in pairs for c in pair})
    directions, weights = subcell_quadrature(sensor, n_sub, cells=np.array(cells))
    factor = weights * directions[..., 2]  # w_q cos θ_q, per (cell, node)
    theta = np.arccos(np.clip(directions[..., 2], -1.0, 1.0))
    phi = np.arctan2(directions[..., 1], directions[..., 0])
    counts = np.array([[walk(theta[j, q], phi[j, q], paths, seed) for q in range(theta.shape[1])]
                       for j in range(len(cells))])  # (cell, node, order slot, target cell)
    position = {c: k for k, c in enumerate(cells)}
    out = {}
    for slot in range(MAX_ORDER + 1):
        z = []
        for a, b in pairs:
            estimates = []
            for source, target in ((a, b), (b, a)):
                p = counts[position[source], :, slot, target] / paths
                f = factor[position[source]]
                estimates.append((np.sum(f * p), np.sum(f ** 2 * p * (1.0 - p) / paths)))
            (q_ab, v_ab), (q_ba, v_ba) = estimates
            z.append((q_ab - q_ba) / math.sqrt(v_ab + v_ba))
        out[slot] = (float(np.sum(np.square(z))), len(z))
    return out


def check(statistics):
    level = 1.0 - (1.0 - FALSE_ALARM) ** (1.0 / len(statistics))  # Šidák
    for slot, (chi2, dof) in statistics.items():
        assert stats.chi2.sf(chi2, dof) >= level, (f"f_{slot or 'inf'}", chi2, dof)


def test_smith_walk_is_reciprocal_anisotropic_ggx_mirror():
    check(reciprocity_statistics({"distribution": "ggx", "alpha_x": 0.3, "alpha_y": 0.9, "facet": "mirror"},
                                 n_pairs=10, paths=12_000, seed=31, n_sub=4))


@pytest.mark.slow
@pytest.mark.parametrize("material", [
    {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.5},
    {"distribution": "ggx", "alpha_x": 1.0, "alpha_y": 0.25, "facet": "interfaced_lambertian", "kd": 0.8,
     "eta": 1.0},
    {"distribution": "beckmann", "alpha_x": 0.7, "alpha_y": 0.2, "facet": "mirror"},
], ids=["beckmann-il", "ggx-aniso-lambertian", "beckmann-aniso-mirror"])
def test_smith_walk_is_reciprocal_more_materials(material):
    check(reciprocity_statistics(material, n_pairs=25, paths=50_000, seed=37, n_sub=6))
