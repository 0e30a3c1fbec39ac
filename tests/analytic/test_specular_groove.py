"""The closed-form outcomes of one specular V-groove (vcavity/analytic/specular_groove.py,
physics.md sec. 12) against a brute-force 2-D groove tracer in plain NumPy
(tests/reference/groove_paths.trace_steps: explicit line intersections and reflections,
independent of the unfolding). Deterministic: random pairs with a fixed seed, exact or
rounding-level tolerances (no false-positive rate)."""

import math

import numpy as np
import pytest
from vcavity._numba.jit import njit  # caches where vcavity's own code does

from tests.reference import conductor_fresnel as ref_conductor, materials as ref
from tests.reference.groove_paths import trace_steps
from vcavity.analytic import specular_groove as sg
from vcavity.facet import conductor, interfaced_lambertian, registry as facets

MIRROR = facets.kind_of("mirror")
IL = facets.kind_of("interfaced_lambertian")
CONDUCTOR = facets.kind_of("conductor")


@njit(cache=True)
def _outcomes_with(tan_m, dx, dz, kind, data, log_table, unit, max_bounces):
    out = np.empty((tan_m.shape[0], sg.N_SLOTS, sg.N_FIELDS))
    regime = np.empty(tan_m.shape[0], np.int64)
    buf = np.empty((sg.N_SLOTS, sg.N_FIELDS))
    for i in range(tan_m.shape[0]):
        regime[i] = sg.groove_outcomes(buf, tan_m[i], dx[i], dz[i], kind, data, log_table, unit, max_bounces)
        out[i] = buf
    return out, regime


def _outcomes(tan_m, dx, dz, kind, data, unit, max_bounces, exact_reflectance=False):
    """Outcomes with the facet's log-F table as the model uses it (``exact_reflectance``:
    without the table, F evaluated at every hit)."""
    table = np.empty(0) if unit or exact_reflectance else sg.log_reflectance_table(kind, data)
    return _outcomes_with(tan_m, dx, dz, kind, data, table, unit, max_bounces)


def _pairs(n, seed, theta_max=1.55):
    """Random grooves and incoming directions (groove frame), edge cases appended."""
    rng = np.random.default_rng(seed)
    theta_m = rng.uniform(0.0, theta_max, n)
    cos_i = rng.uniform(0.0, 1.0, n)
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    sin_i = np.sqrt(1.0 - cos_i ** 2)
    d = np.stack([-sin_i * np.cos(phi), -sin_i * np.sin(phi), -cos_i], axis=1)
    edges = [
        (0.7, 0.0, 0.0, -1.0),  # normal incidence
        (0.3, 0.0, 0.6, -0.8),  # in-plane normal incidence, out-of-plane tilt
        (1.2, -math.sqrt(1 - 1e-12), 0.0, -1e-6),  # grazing
        (1.0, math.sqrt(1 - 1e-12), 0.0, -1e-6),
        (1e-9, 0.3, 0.1, -math.sqrt(1 - 0.1)),  # almost flat groove
        (1.5607, 0.6, 0.0, -0.8),  # deep groove, ~40 bounces
    ]
    # the n - 1 / n boundary: the line through V exits exactly at a spoke (phi_d = a_j)
    for theta, j in ((0.5, 2), (0.9, 4), (1.3, 9)):
        beta = math.pi - 2.0 * theta
        phi_d = theta + j * beta + 1e-13
        if math.sin(phi_d) < 0.0:
            edges.append((theta, math.cos(phi_d), 0.0, math.sin(phi_d)))
    extra = np.array(edges)
    theta_m = np.concatenate([theta_m, extra[:, 0]])
    d = np.concatenate([d, extra[:, 1:] / np.linalg.norm(extra[:, 1:], axis=1)[:, None]])
    return theta_m, d


def _traced(theta_m, d, x0, reflectance=None, chunk=50_000):
    """trace_steps on every entry; rays sorted by groove depth so that the few deep grooves
    (many bounces) do not keep the whole batch stepping."""
    n, m = x0.shape
    rays = [np.repeat(theta_m, m), x0.ravel(), np.repeat(d[:, 0], m), np.repeat(d[:, 1], m),
            np.repeat(d[:, 2], m)]
    order = np.argsort(rays[0], kind="stable")
    result = [np.empty(n * m, dtype=np.int64)] + [np.empty(n * m) for _ in range(3)]
    for start in range(0, n * m, chunk):
        part = order[start:start + chunk]
        k, ex, _, ez, w = trace_steps(*[a[part] for a in rays], 100_000, reflectance)
        for target, value in zip(result, (k, ex, ez, w)):
            target[part] = value
    return [a.reshape(n, m) for a in result]


def _slot_of(theta_m, d, x0, k):
    x_vertex = np.tan(theta_m) * d[:, 0] / d[:, 2]
    side = np.where(x0 < x_vertex[:, None], 0, 1)  # left of V: the left wall first
    return 2 * side + k % 2


def test_outcomes_match_the_brute_force_tracer():
    """1e5 random (groove, direction) pairs plus edge cases, 4 random entries each: the
    bounce count, exit direction and survival of every traced path are those of its slot."""
    theta_m, d = _pairs(100_000, seed=18)
    out, _ = _outcomes(np.tan(theta_m), d[:, 0], d[:, 2], MIRROR, np.zeros(0), True, 10 ** 6)
    assert np.all(np.abs(out[:, :, sg.FRACTION].sum(axis=1) - 1.0) < 1e-12)
    x0 = np.random.default_rng(5).uniform(-1.0, 1.0, (theta_m.size, 4))
    k, ex, ez, _ = _traced(theta_m, d, x0)
    mine = out[np.arange(theta_m.size)[:, None], _slot_of(theta_m, d, x0, k)]
    assert np.all(mine[..., sg.FRACTION] > 0.0)
    assert np.array_equal(mine[..., sg.BOUNCES], k)
    assert np.max(np.hypot(mine[..., sg.EXIT_X] - ex, mine[..., sg.EXIT_Z] - ez)) < 1e-9
    assert np.all(mine[..., sg.EXIT_Z] > 0.0)  # every exit leaves through the opening
    assert out[:, :, sg.BOUNCES].max() >= 30  # the deep grooves were reached


def test_fractions_are_the_traced_shares_of_the_opening():
    """On 1000 pairs the fraction of each slot is the share of 2048 evenly spaced entries
    with that outcome, to the grid's resolution (1/2048 per interval end)."""
    theta_m, d = _pairs(1000, seed=7)
    out, _ = _outcomes(np.tan(theta_m), d[:, 0], d[:, 2], MIRROR, np.zeros(0), True, 10 ** 6)
    m = 2048
    x0 = np.broadcast_to(-1.0 + (np.arange(m) + 0.5) * 2.0 / m, (theta_m.size, m))
    k, _, _, _ = _traced(theta_m, d, x0)
    slot = _slot_of(theta_m, d, x0, k)
    for s in range(sg.N_SLOTS):
        share = np.mean(slot == s, axis=1)
        assert np.max(np.abs(share - out[:, s, sg.FRACTION])) <= 2.0 / m + 1e-12, s


def test_survival_is_the_product_of_the_fresnel_factors():
    """kd = 0 dielectric facets (eta 1.5): the survival of each slot is the product of the
    reference Fresnel factors at the traced hits; with a cap, only the first hits count."""
    theta_m, d = _pairs(20_000, seed=3, theta_max=1.45)
    values = {"kd": 0.0, "eta": 1.5}
    data = interfaced_lambertian.prepare(values)
    out, _ = _outcomes(np.tan(theta_m), d[:, 0], d[:, 2], IL, data, False, 10 ** 6)
    x0 = np.random.default_rng(9).uniform(-1.0, 1.0, (theta_m.size, 2))
    k, _, _, w = _traced(theta_m, d, x0, lambda c: ref.fresnel_reflectance(c, 1.5))
    mine = out[np.arange(theta_m.size)[:, None], _slot_of(theta_m, d, x0, k)]
    expected = np.where(w < sg.NEGLIGIBLE_SURVIVAL, 0.0, w)  # a negligible survival is 0 by design
    assert np.allclose(mine[..., sg.SURVIVAL], expected, rtol=1e-10, atol=1e-300)
    assert np.any(k >= 3) and np.min(w) < 0.01  # products of several factors were tested
    capped, _ = _outcomes(np.tan(theta_m), d[:, 0], d[:, 2], IL, data, False, 2)
    two = np.where(out[:, :, sg.BOUNCES] > 2, capped[:, :, sg.SURVIVAL], out[:, :, sg.SURVIVAL])
    first_two = np.isclose(capped[:, :, sg.SURVIVAL], two, rtol=1e-12)
    assert np.all(first_two)
    deeper = out[:, :, sg.BOUNCES] > 2
    assert np.all(capped[:, :, sg.SURVIVAL][deeper] >= out[:, :, sg.SURVIVAL][deeper])


@pytest.mark.parametrize("eta, k, tabled", [(0.43, 2.455, True), (1e-3, 1e-3, False)])
def test_conductor_survival_in_deep_grooves(eta, k, tabled):
    """Conductor facets in grooves of up to ~400 hits: each slot's survival is the product
    of the reference conductor Fresnel factors at the traced hits, to 1e-9 relative, whether
    the model reads ``log F`` from its table (gold) or, where no table is accurate enough
    (eta = k = 1e-3: F falls steeply at grazing), evaluates F at every hit."""
    theta_m, d = _pairs(4_000, seed=21, theta_max=1.565)
    data = conductor.prepare({"eta": eta, "k": k})
    assert (sg.log_reflectance_table(CONDUCTOR, data).size > 0) == tabled
    out, _ = _outcomes(np.tan(theta_m), d[:, 0], d[:, 2], CONDUCTOR, data, False, 10 ** 6)
    x0 = np.random.default_rng(4).uniform(-1.0, 1.0, (theta_m.size, 2))
    k_traced, _, _, w = _traced(theta_m, d, x0, lambda c: ref_conductor.fresnel_conductor(c, eta, k))
    mine = out[np.arange(theta_m.size)[:, None], _slot_of(theta_m, d, x0, k_traced)][..., sg.SURVIVAL]
    expected = np.where(w < sg.NEGLIGIBLE_SURVIVAL, 0.0, w)
    # a survival within rounding of the 1e-12 cut may land on either side of it
    near_cut = np.abs(w / sg.NEGLIGIBLE_SURVIVAL - 1.0) < 1e-6
    assert np.allclose(mine[~near_cut], expected[~near_cut], rtol=1e-9, atol=1e-300)
    assert k_traced.max() >= 100 and np.any((w > 1e-6) & (k_traced >= 30))


@pytest.mark.parametrize("theta_m", [0.2, 0.8, 1.3])
def test_regime_bits_follow_the_outcomes(theta_m):
    """SPLIT_* is set exactly when a side has two counts, VERTEX_INSIDE when both are lit."""
    _, d = _pairs(5000, seed=int(theta_m * 10))
    tan = np.full(d.shape[0], math.tan(theta_m))
    out, regime = _outcomes(tan, d[:, 0], d[:, 2], MIRROR, np.zeros(0), True, 10 ** 6)
    lit = out[:, :, sg.FRACTION] > 0.0
    assert np.array_equal((regime & sg.SPLIT_LEFT) != 0, lit[:, 0] & lit[:, 1])
    assert np.array_equal((regime & sg.SPLIT_RIGHT) != 0, lit[:, 2] & lit[:, 3])
    both = (lit[:, 0] | lit[:, 1]) & (lit[:, 2] | lit[:, 3])
    assert np.array_equal((regime & sg.VERTEX_INSIDE) != 0, both)
