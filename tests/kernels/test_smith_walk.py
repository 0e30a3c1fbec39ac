"""The Smith random walk (vcavity/kernels/smith.py, physics.md sec. 15).

- f1 of mirror facets per sensor cell against the height-correlated Smith single-bounce
  BRDF ``D(h) G2(i, o) / (4 i.n o.n)``, ``G2 = 1/(1 + Λ(i) + Λ(o))`` (H eq. 99), integrated
  over each cell by an 8 x 8 midpoint rule, with ``D`` from tests/reference/materials and
  ``Λ`` written here in plain NumPy (H eq. 69, 72, 80): chi-square at p > 1e-4 per case
  (false-positive rate 1e-4 each, 7e-4 for the seven cases; fixed seeds). Student-t's and
  Phong's Λ by scipy's incomplete beta (Phong's slopes are Student-t's, phong.py).
- No light is lost by mirror facets or white Lambertian ones (eta = 1, kd = 1) but to the
  bounce cap, and nothing is degenerate.
- Counts do not depend on how blocks are split over calls and thread slots.
- Distributions whose Smith Λ diverges (Gaussian) are refused in one line.
"""

import math

import numpy as np
import pytest
from scipy import special, stats

from tests.reference import materials as ref
from vcavity.facet import registry as facets
from vcavity.kernels import walks
from vcavity.kernels.smith import walkable
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, direction_key
from vcavity.sensor.directions import incident_vector
from vcavity.sensor.grid import square_to_hemisphere_array

RESOLUTION = 15
N_PATHS = 2_000_000


def _run(distribution, roughness, facet, facet_values, incident, n_paths=N_PATHS, max_order=3, n_slots=2,
         splits=1, max_bounces=10_000, seed=3):
    kind, params = distributions.params_from(distribution, roughness)
    facet_kind, variant, data = facets.prepare(facet, facet_values)
    walk = walks.get("smith", kind, facet_kind, variant)
    n_blocks = -(-n_paths // BLOCK_SIZE)
    key = direction_key(seed, 0.5, 0.25)
    counts = np.zeros((max_order + 1, RESOLUTION ** 2), np.int64)
    lost = np.zeros(3, np.int64)
    edges = np.linspace(0, n_blocks, splits + 1).astype(int)
    for first, last in zip(edges[:-1], edges[1:]):
        tallies, stats = walk(walks.WalkCall(
            incident=incident, direction_key=key, first_block=first, n_blocks=last - first, n_paths=n_paths,
            params=params, facet_data=data, max_bounces=max_bounces, max_order=max_order, resolution=RESOLUTION,
            n_slots=n_slots))
        counts += tallies["counts"]
        lost += [stats["absorbed"], stats["truncated"], stats["degenerate"]]
    return counts, lost


def _lambda(distribution, ax, ay, v, gamma=None):
    """Smith Λ (H eq. 72 for GGX, eq. 69 for Beckmann, projected roughness eq. 80; for the
    Student-t slopes ``P2(q) = C (1 + q^2/z)^-(z + 1/2)``, ``z = γ - 1``, H eq. 43 in closed form:
    ``Λ = C z (1 + a^2/z)^(1/2 - z) / ((2z - 1) a) - I_{z/(z + a^2)}(z, 1/2)/2``, scipy's betainc)."""
    tan2 = (v[..., 0] ** 2 * ax ** 2 + v[..., 1] ** 2 * ay ** 2) / v[..., 2] ** 2  # (α_o tan θ)^2
    if distribution == "ggx":
        return 0.5 * (np.sqrt(1.0 + tan2) - 1.0)
    a = 1.0 / np.sqrt(np.maximum(tan2, 1e-300))
    if distribution == "student_t":
        z = gamma - 1.0
        c = math.exp(special.gammaln(z + 0.5) - special.gammaln(z)) / math.sqrt(math.pi * z)
        return (c * z / (2.0 * z - 1.0) * (1.0 + a * a / z) ** (0.5 - z) / a
                - 0.5 * special.betainc(z, 0.5, z / (z + a * a)))
    return 0.5 * (special.erf(a) - 1.0) + np.exp(-a * a) / (2.0 * a * math.sqrt(math.pi))


def _f1_cells(distribution, roughness, incident, nodes=8):
    """Cell integrals of ``f1 cos θo dω`` of the height-correlated Smith mirror BRDF."""
    material = ref.parse_material({"distribution": distribution, "facet": "mirror", **roughness})
    gamma = material.roughness.get("gamma")
    if distribution == "phong":
        # Phong's slopes (1 + |s|^2)^-(n/2 + 2) are Student-t's with γ = n/2 + 2, α = sqrt(2/(n + 2))
        # (D cos^4 of W eq. 30): its exact Λ is that one's
        n_exp = material.roughness["exponent"]
        ax = ay = math.sqrt(2.0 / (n_exp + 2.0))
        gamma, lam_name = 0.5 * n_exp + 2.0, "student_t"
    else:
        ax, ay = material.roughness["alpha_x"], material.roughness["alpha_y"]
        lam_name = distribution
    n = RESOLUTION
    x = (np.arange(nodes) + 0.5) / nodes
    iy, ix = np.divmod(np.arange(n * n), n)
    shape = (n * n, nodes, nodes)
    u = np.broadcast_to(-1.0 + 2.0 * (ix[:, None, None] + x[None, :, None]) / n, shape).ravel()
    v = np.broadcast_to(-1.0 + 2.0 * (iy[:, None, None] + x[None, None, :]) / n, shape).ravel()
    o = square_to_hemisphere_array(u, v)
    h = o + incident
    h /= np.linalg.norm(h, axis=1)[:, None]
    lam_i = _lambda(lam_name, ax, ay, incident[None, :], gamma)[0]
    lam_o = _lambda(lam_name, ax, ay, np.maximum(o, [-2, -2, 1e-300]), gamma)
    f = ref.ndf(material, h) / (4.0 * incident[2] * (1.0 + lam_i + lam_o))  # f1 cos θo
    # dω = (π/2) du dv, each node (2/(n nodes))^2 of the square
    return (f * 0.5 * math.pi * (2.0 / (n * nodes)) ** 2).reshape(n * n, nodes * nodes).sum(axis=1)


CASES = [("ggx", {"alpha": 0.5}, 60.0, 0.0), ("beckmann", {"alpha": 0.3}, 30.0, 0.0),
         ("ggx", {"alpha_x": 0.6, "alpha_y": 0.2}, 70.0, 37.0), ("beckmann", {"alpha": 1.0}, 85.0, 120.0),
         ("student_t", {"alpha_x": 0.5, "alpha_y": 0.25, "gamma": 1.8}, 50.0, 90.0),
         ("student_t", {"alpha": 0.4, "gamma": 6.0}, 80.0, 0.0),
         ("phong", {"exponent": 8.0}, 65.0, 0.0)]


@pytest.mark.parametrize("distribution, roughness, theta_deg, phi_deg", CASES)
def test_f1_is_the_height_correlated_smith_model(distribution, roughness, theta_deg, phi_deg):
    incident = incident_vector(math.radians(theta_deg), math.radians(phi_deg))
    canonical = distributions.parse(distribution, roughness)
    counts, lost = _run(distribution, canonical, "mirror", {}, incident)
    assert lost.tolist() == [0, 0, 0]
    expected = N_PATHS * _f1_cells(distribution, roughness, incident)
    observed = counts[1]
    big = expected >= 10.0
    obs = np.append(observed[big], observed[~big].sum())
    exp = np.append(expected[big], expected[~big].sum())
    if exp[-1] == 0.0:  # every cell is big
        obs, exp = obs[:-1], exp[:-1]
    chi2 = float(np.sum((obs - exp) ** 2 / exp))
    assert big.sum() >= 40
    assert stats.chi2.sf(chi2, obs.size - 1) > 1e-4, f"chi2 {chi2:.1f} on {obs.size - 1} dof"
    # the f1 albedo too (z test against the model's sum; same false-positive budget)
    z = (observed.sum() - expected.sum()) / math.sqrt(expected.sum() * (1.0 - expected.sum() / N_PATHS))
    assert abs(z) < 3.9, z


WHITE = [("mirror", {}, "ggx", 0.05), ("mirror", {}, "ggx", 1.0), ("mirror", {}, "beckmann", 3.0),
         ("interfaced_lambertian", {"kd": 1.0, "eta": 1.0}, "ggx", 0.05),
         ("interfaced_lambertian", {"kd": 1.0, "eta": 1.0}, "ggx", 1.0)]


@pytest.mark.parametrize("facet, values, distribution, alpha", WHITE)
def test_white_facets_lose_nothing(facet, values, distribution, alpha):
    """A white furnace: every path leaves (all orders) but the few the cap of 30 bounces
    truncates; none is absorbed or degenerate. (The Lambertian cases use GGX only: the
    same facet variant on Beckmann would be one more compiled kernel for the same check.)"""
    incident = incident_vector(math.radians(75.0), 0.3)
    canonical = distributions.parse(distribution, {"alpha": alpha})
    counts, lost = _run(distribution, canonical, facet, facets.parse(facet, values), incident, n_paths=200_000,
                        max_bounces=30)
    absorbed, truncated, degenerate = lost
    assert absorbed == 0 and degenerate == 0
    assert counts.sum() + truncated == 200_000
    assert truncated < 2000  # 1 %: the walk leaves within a few bounces
    assert counts[2:].sum() + counts[0].sum() > 0  # multiple scattering happened


def test_counts_do_not_depend_on_blocks_split_or_threads():
    incident = incident_vector(math.radians(50.0), 1.0)
    canonical = distributions.parse("ggx", {"alpha": 0.7})
    il = facets.parse("interfaced_lambertian", {"kd": 0.8, "eta": 1.0})
    a, lost_a = _run("ggx", canonical, "interfaced_lambertian", il, incident, n_paths=100_000, n_slots=1, splits=1)
    b, lost_b = _run("ggx", canonical, "interfaced_lambertian", il, incident, n_paths=100_000, n_slots=3, splits=4)
    assert np.array_equal(a, b) and np.array_equal(lost_a, lost_b)
    assert lost_a[0] > 0  # the body absorbs: the test covers that branch too


@pytest.mark.parametrize("name", ["gaussian"])
def test_distributions_with_a_diverging_lambda_are_refused(name):
    reason = walkable(name)
    assert reason is not None and "\n" not in reason and name in reason
    with pytest.raises(ValueError, match=name):
        walks.get("smith", distributions.kind_of(name), facets.kind_of("mirror"), 0)


def test_a_cap_of_one_bounce_keeps_f1(tmp_path):
    """``max_order = 1, track_all_orders = false`` caps the Smith walk at one bounce (issue 38
    item 4: a walk truncating one hit early gives f1 = 0 and passed every test). The capped
    run's f1 albedo equals the uncapped run's (two-sample binomial z per direction, |z| < 4.5:
    false-positive rate 1.4e-5 for the two; fixed seeds), the rest is truncated, and
    ``max_bounces_seen`` is the cap."""
    from vcavity.cli import main
    from vcavity.io.table import open_table

    paths = 40_000
    base = ('[material]\ndistribution = "ggx"\nalpha = 0.5\nfacet = "mirror"\nmicrosurface = "smith"\n'
            f'[incidence]\ntheta_i_deg = [30, 70]\npaths = {paths}\n'
            '[simulation]\nseed = {seed}\nsensor_resolution = 9\nmax_order = 1\ntrack_all_orders = {track}\n')
    tables = {}
    for track, seed in (("false", 8), ("true", 9)):
        config = tmp_path / f"{track}.toml"
        config.write_text(base.format(track=track, seed=seed))
        assert main(["run", str(config), "-o", str(tmp_path / f"{track}.h5"), "-q"]) == 0
        tables[track] = open_table(tmp_path / f"{track}.h5")
    capped, free = tables["false"], tables["true"]
    p_capped = capped.counts[:, list(capped.order).index(1)].sum(axis=1) / paths
    p_free = free.counts[:, list(free.order).index(1)].sum(axis=1) / paths
    z = (p_capped - p_free) / np.sqrt((p_capped * (1 - p_capped) + p_free * (1 - p_free)) / paths)
    assert np.all(np.abs(z) < 4.5) and np.all(p_capped > 0.5), (p_capped, p_free)
    assert np.all(capped.truncated > 0) and np.all(capped.max_bounces_seen == 1)
    assert np.all(free.max_bounces_seen > 1)
