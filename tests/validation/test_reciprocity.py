"""Reciprocity of every bounce order of the simulator: f_k(i, o) = f_k(o, i) (physics.md sec. 8).

Design. A cell average is not a point value, so comparing table values at cell centres
carries a built-in asymmetry of up to 2e-3 (physics.md sec. 9). Instead both sides
estimate the same symmetric double integral over a pair of sensor cells (A, B):

    Q(A, B) = ∫_A ∫_B f_k(i, o) cos θ_i cos θ_o dω_o dω_i = Q(B, A)   (reciprocity).

Q(A -> B) is estimated by simulating incident directions at the 6 x 6 Gauss-Legendre
nodes of cell A (weights w_q, ``subcell_quadrature``) and counting order-k exits in B:
``Σ_q w_q cos θ_q n_q(B) / N``; Q(B -> A) the other way. The node rule's own error
matters: measured with the (reciprocal) analytic f1 model on these 0.17 sr cells, the
asymmetry it leaves is up to 4e-3 with 3 x 3 nodes (a 3 x 3 run of this test at 640k
paths per direction gave chi2 = 137 on 20 dof: a false alarm), 1.5e-3 with 4 x 4 and
5e-4 with 6 x 6, which is 4 % of the per-pair Monte-Carlo error here (1.2 %).

Statistics. ``z = (Q(A->B) - Q(B->A)) / sqrt(var + var)`` with binomial variances; under
reciprocity each z is ~N(0, 1) (counts of order 100-10^4 per cell), the pairs are
independent simulations, so ``Σ z^2`` over the pairs is chi-square with one degree of
freedom per pair. One test per order (f_inf, f1, f2, f3), each at the Sidak level
``1 - 0.99^(1/4)``: the false-alarm rate of the whole test is 1 %.

Pairs. A pair is usable for an order only if paths of that order go both ways; a
narrow lobe (Phong mirror facets) links only some cells. The pairs are therefore
chosen from a pilot simulation with its own seed (cell-centre incidence, independent
of the test's counts, so the choice cannot bias the statistic): among the pairs the
pilot saw carrying paths of every order both ways, ``n_pairs`` at random. Each order's
test then needs at least ``MIN_PAIRS`` usable pairs (the material allows that many:
checked by the pilot, and asserted).
"""

import numpy as np
import pytest

from vcavity.analytic.quadrature import subcell_quadrature
from vcavity.analytic.statistics import chi2_sf, sidak_threshold
from vcavity.config import validate
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import simulate

RESOLUTION = 6  # 36 cells of 0.175 sr
N_SUB = 6
MIN_PAIRS = 12
PILOT_PATHS = 20_000


def _pairs(rng, n_pairs, sensor, material, seed):
    """``n_pairs`` cell pairs that carry paths of every order both ways (see module doc)."""
    theta = np.degrees(sensor.cell_theta)
    phi = np.degrees(sensor.cell_phi)
    pilot = simulate(validate({
        "material": material,
        "incidence": {"theta_i_deg": theta.tolist(), "phi_i_deg": phi.tolist(), "paths": PILOT_PATHS},
        "simulation": {"seed": seed + 1_000_003, "max_order": 3, "sensor_resolution": RESOLUTION}}))
    carries = np.all(pilot["counts"] > 0, axis=1)  # (source cell, target cell): every order seen
    both_ways = carries & carries.T
    eligible = [(a, b) for a in range(sensor.n_cells) for b in range(a + 1, sensor.n_cells) if both_ways[a, b]]
    assert len(eligible) >= MIN_PAIRS, f"the material links only {len(eligible)} cell pairs in every order"
    chosen = rng.choice(len(eligible), size=min(n_pairs, len(eligible)), replace=False)
    return sorted(eligible[k] for k in chosen)


def _reciprocity_chi_square(material, n_pairs, paths, seed):
    sensor = EqualAreaSensor(RESOLUTION)
    rng = np.random.default_rng(seed)
    pairs = _pairs(rng, n_pairs, sensor, material, seed)
    cells = sorted({c for pair in pairs for c in pair})
    directions, weights = subcell_quadrature(sensor, N_SUB, cells=np.array(cells))
    theta = np.degrees(np.arccos(directions[..., 2])).ravel()
    phi = np.degrees(np.arctan2(directions[..., 1], directions[..., 0])).ravel()
    cfg = validate({"material": material,
                    "incidence": {"theta_i_deg": theta.tolist(), "phi_i_deg": phi.tolist(), "paths": paths},
                    "simulation": {"seed": seed, "max_order": 3, "sensor_resolution": RESOLUTION}})
    result = simulate(cfg)
    counts = result["counts"].reshape(len(cells), N_SUB * N_SUB, result["order"].size, sensor.n_cells)
    factor = (weights * directions[..., 2])  # w_q cos θ_q, per (cell, node)
    position = {c: k for k, c in enumerate(cells)}
    statistics = {}
    for slot, order in enumerate(result["order"]):
        z = []
        for a, b in pairs:
            estimates = []
            for source, target in ((a, b), (b, a)):
                p = counts[position[source], :, slot, target] / paths
                f = factor[position[source]]
                estimates.append((np.sum(f * p), np.sum(f**2 * p * (1 - p) / paths)))
            (q_ab, v_ab), (q_ba, v_ba) = estimates
            if v_ab + v_ba > 0:
                z.append((q_ab - q_ba) / np.sqrt(v_ab + v_ba))
        statistics[int(order)] = (float(np.sum(np.square(z))), len(z))
    return statistics


def _check(statistics):
    level = sidak_threshold(0.01, len(statistics))
    for order, (chi2, dof) in statistics.items():
        assert dof >= MIN_PAIRS, (order, dof)
        assert chi2_sf(chi2, dof) >= level, (order, chi2, dof)


@pytest.mark.slow  # ~20 s: runs in CI's slow suite (keeps the default suite under 10 min)
def test_reciprocity_every_order_fig7():
    # IL paper fig. 7 material; 20 random cell pairs, 3 x 3 incident nodes per cell
    material = {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5}
    _check(_reciprocity_chi_square(material, n_pairs=20, paths=40_000, seed=17))


@pytest.mark.slow
@pytest.mark.parametrize("material", [
    {"distribution": "ggx", "alpha_x": 0.2, "alpha_y": 0.9, "kd": 0.5, "eta": 2.5},
    {"distribution": "gaussian", "sigma": 0.5, "kd": 1.0, "eta": 1.0},
    {"distribution": "phong", "exponent": 10.0, "facet": "mirror"},
])
def test_reciprocity_every_order_more_materials(material):
    _check(_reciprocity_chi_square(material, n_pairs=30, paths=50_000, seed=29))
