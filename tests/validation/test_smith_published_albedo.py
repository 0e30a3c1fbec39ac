"""The Smith walk's single-scattering albedo against a published table: Blender Cycles' ``ggx_E``.

Source. Blender's Cycles renderer ships ``table_ggx_E`` (32 x 32) and ``table_ggx_Eavg``
(32) in ``intern/cycles/scene/shader.tables`` (blender/blender, as of commit 09cf4924),
computed by ``intern/cycles/app/cycles_precompute.cpp``: the directional albedo ``E(μ)``
of Cycles' GGX microfacet reflection with white (``F = 1``) facets, 2^23 Sobol samples
per node of its visible-normal sampler, weight ``eval/pdf``. Its masking term
(``bsdf_G`` in ``kernel/closure/bsdf_microfacet.h``) is the *height-correlated* Smith
``G2 = 1/(1 + Λ(i) + Λ(o))`` (H eq. 99) with the exact GGX ``Λ`` (H eq. 72), so ``E``
is exactly the f1 albedo of the Smith walk with mirror facets (physics.md sec. 15,
"First order"). Layout: ``data[y * 32 + x]``, roughness ``r = x/31`` (clamped below
at 1e-4) with ``α = r²``, ``μ = cos θ_i = y/31`` (clamped to [1e-4, 1]);
``E_avg(r) = ∫ 2 μ E(μ) dμ`` (uniform random ``μ``, 2^26 samples). Rows of the table
are quoted below as shipped (6 decimals).

Multiple scattering. For a white conductor the energy single scattering misses, ``1 -
E(μ)``, is what multiple scattering returns (Kulla & Conty 2017, "Revisiting physically
based shading at Imageworks", SIGGRAPH course: the basis of their energy-compensation
lobe). The walk's orders >= 2 must carry exactly that: with nothing absorbed and nothing
truncated (asserted), their albedo is ``1 - f1``, so the same z tests cover it.

Statistics. Per node ``z = (p - E)/sqrt(p (1 - p)/N + σ_c²)``, ``p`` the walk's share of
order-1 exits, ``σ_c = 2e-4`` the table's own error (a weight in [0, 1] has SD <= 1/2:
``0.5/sqrt(2^23) = 1.7e-4``, plus 6-decimal rounding). Each node at ``|z| < 4.5`` and
the sum ``Σ z²`` at chi-square p >= 1e-4: false-positive rate below 2.5e-4 for the 20
default nodes (Bonferroni), fixed seeds. ``E_avg`` (slow): the walk at 96 incident ``μ``,
``μ²`` stratified (unbiased), the standard error from pairs per stratum, ``|z| < 4``
(6e-5 per roughness).
"""

import math

import numpy as np
import pytest
from scipy import stats

from vcavity.facet import registry as facets
from vcavity.kernels import walks
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, direction_key
from vcavity.sensor.directions import incident_vector

# rows y of Cycles' table_ggx_E (mu = y/31), each over x = 0 .. 31 (r = x/31), as shipped
CYCLES_GGX_E = {
    3: np.array([1.000000, 0.999941, 0.998997, 0.994519, 0.982075, 0.959460, 0.931758, 0.907714,
                  0.892271, 0.885248, 0.884058, 0.885962, 0.888923, 0.891666, 0.893488, 0.894054,
                  0.893246, 0.891062, 0.887565, 0.882845, 0.877003, 0.870143, 0.862365, 0.853766,
                  0.844436, 0.834459, 0.823915, 0.812876, 0.801410, 0.789581, 0.777445, 0.765057]),
    8: np.array([1.000000, 0.999991, 0.999858, 0.999255, 0.997533, 0.993686, 0.986490, 0.974988,
                  0.959173, 0.940264, 0.920251, 0.901030, 0.883794, 0.868900, 0.856078, 0.844728,
                  0.834154, 0.823720, 0.812914, 0.801368, 0.788846, 0.775227, 0.760476, 0.744623,
                  0.727744, 0.709946, 0.691355, 0.672105, 0.652332, 0.632172, 0.611753, 0.591195]),
    16: np.array([1.000000, 0.999998, 0.999959, 0.999786, 0.999307, 0.998254, 0.996252, 0.992808,
                  0.987348, 0.979302, 0.968235, 0.953973, 0.936669, 0.916763, 0.894859, 0.871576,
                  0.847421, 0.822737, 0.797698, 0.772347, 0.746651, 0.720547, 0.693982, 0.666934,
                  0.639428, 0.611535, 0.583366, 0.555065, 0.526792, 0.498719, 0.471015, 0.443841]),
    23: np.array([1.000000, 0.999999, 0.999976, 0.999874, 0.999596, 0.998993, 0.997858, 0.995914,
                  0.992810, 0.988121, 0.981374, 0.972090, 0.959837, 0.944301, 0.925331, 0.902963,
                  0.877406, 0.848999, 0.818163, 0.785347, 0.750991, 0.715502, 0.679256, 0.642589,
                  0.605812, 0.569211, 0.533054, 0.497587, 0.463038, 0.429607, 0.397469, 0.366766]),
    31: np.array([1.000000, 0.999999, 0.999983, 0.999911, 0.999716, 0.999296, 0.998513, 0.997184,
                  0.995072, 0.991884, 0.987261, 0.980785, 0.971982, 0.960355, 0.945407, 0.926694,
                  0.903873, 0.876756, 0.845349, 0.809871, 0.770757, 0.728630, 0.684249, 0.638454,
                  0.592102, 0.546006, 0.500893, 0.457373, 0.415925, 0.376893, 0.340499, 0.306853]),
}
CYCLES_GGX_EAVG = {16: 0.870874, 24: 0.631068, 31: 0.409137}  # table_ggx_Eavg[x], r = x/31
SIGMA_TABLE = 2e-4


def _f1_share(r, mu, n_paths, seed):
    """Share of paths leaving after one bounce, white GGX mirror facets, α = r², μ = cos θ_i."""
    kind, params = distributions.params_from("ggx", {"alpha_x": r * r, "alpha_y": r * r})
    facet_kind, variant, data = facets.prepare("mirror", {})
    walk = walks.get("smith", kind, facet_kind, variant)
    theta = math.acos(mu)
    tallies, stats = walk(walks.WalkCall(
        incident=incident_vector(theta, 0.0), direction_key=direction_key(seed, theta, r), first_block=0,
        n_blocks=-(-n_paths // BLOCK_SIZE), n_paths=n_paths, params=params, facet_data=data, max_bounces=10_000,
        max_order=1, resolution=3, n_slots=2))
    assert stats["absorbed"] == 0 and stats["truncated"] == 0
    counts = tallies["counts"]
    assert counts.sum() == n_paths  # white furnace: f_inf = 1, so orders >= 2 carry 1 - f1 (Kulla-Conty)
    return counts[1].sum() / n_paths


def _node_z(ys, xs, n_paths, seed):
    z = []
    for y in ys:
        for x in xs:
            p = _f1_share(x / 31.0, y / 31.0, n_paths, seed)
            expected = CYCLES_GGX_E[y][x]
            z.append((p - expected) / math.sqrt(p * (1.0 - p) / n_paths + SIGMA_TABLE ** 2))
    return np.array(z)


def _check(z):
    assert np.all(np.abs(z) < 4.5), np.round(z, 2)
    assert stats.chi2.sf(np.sum(z * z), z.size) >= 1e-4, (float(np.sum(z * z)), z.size)


def test_f1_albedo_is_cycles_ggx_e():
    _check(_node_z(sorted(CYCLES_GGX_E), (8, 16, 24, 31), 200_000, seed=41))


@pytest.mark.slow
def test_f1_albedo_is_cycles_ggx_e_more_nodes():
    _check(_node_z(sorted(CYCLES_GGX_E), tuple(range(2, 32, 2)) + (31,), 1_000_000, seed=47))


def _eavg_z(x, strata, n_paths, seed):
    """z of the walk's ``∫ 2 μ f1(μ) dμ`` against ``table_ggx_Eavg[x]``: ``u = μ²`` stratified into
    ``strata`` equal intervals, two uniform ``u`` in each (unbiased; the variance from the pairs)."""
    rng = np.random.default_rng(seed)
    u = (np.arange(strata)[:, None] + rng.random((strata, 2))) / strata
    p = np.array([[_f1_share(x / 31.0, math.sqrt(v), n_paths, seed) for v in pair] for pair in u])
    variance = np.sum((p[:, 0] - p[:, 1]) ** 2 / 4.0) / strata ** 2  # Σ_j s_j²/2 / J², s_j² = (Δp)²/2
    return (p.mean() - CYCLES_GGX_EAVG[x]) / math.sqrt(variance + SIGMA_TABLE ** 2)


@pytest.mark.slow
@pytest.mark.parametrize("x", sorted(CYCLES_GGX_EAVG))
def test_f1_albedo_averaged_over_mu_is_cycles_ggx_eavg(x):
    assert abs(_eavg_z(x, 48, 20_000, seed=53 + x)) < 4.0
