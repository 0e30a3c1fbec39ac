"""Every facet model against the facet interface (vcavity/facet/registry.py).

Each check runs on every registered module and every one of its ``EXAMPLES`` (ids like
``interfaced_lambertian-dielectric``; together they select every compiled variant, which
the registry checks at import), read from the registry: a new facet model is a module, one
registry line and its examples, and this file checks it with no edit. A module's own test
file holds only what is its own (its Fresnel terms against textbook references, its tables,
how many random numbers its event draws).

What "the same facet" means here: the analytic models see a facet through ``reflectance R``,
``transmittance T`` and the body term ``K T(c_i) T(c_o)`` (``body_factor K``); the walk sees
it through ``event``. One event from incoming cosine ``c`` must then reflect specularly with
probability ``R(c)``, re-emit through the body with probability ``T(c) a``,
``a = 2 pi K ∫_0^1 T(mu) mu dmu`` (the body term integrated over the exits), in a direction of
pdf ``∝ T(mu) mu`` about the facet normal with a uniform azimuth, and absorb the rest; and
``R + T a <= 1`` at every cosine (energy). The integrals are scipy quad of the module's own
``transmittance``; the Fresnel terms themselves are checked against independent references in
the modules' own files.

False-positive rates (fixed seeds: a run is deterministic; the rate is over the choice of
seeds): each outcome frequency is a z-test at ``|z| < 5`` (5.7e-7 each; at most 3 outcomes x
2 cosines per case), and an outcome of probability below 1e-12 must not occur at all (at
most 2e5 x 1e-12 = 2e-7 per test); the chi-square tests of the emerging cosine are one family
at a family-wise rate of 1 % over the cases of the default suite (Sidak level per test), and
the same over the slow suite. Everything else is deterministic.
"""

from __future__ import annotations

import math
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from numba import literally
from scipy import integrate, stats

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

from tests.facet.frames import incoming  # noqa: E402
from vcavity._numba.jit import njit  # noqa: E402  (caches where vcavity's own code does)
from vcavity.config import Material, validate  # noqa: E402
from vcavity.facet import registry  # noqa: E402
from vcavity.facet.common import ABSORBED, SCATTERED  # noqa: E402
from vcavity.microfacet import registry as distributions  # noqa: E402
from vcavity.parameters import Number  # noqa: E402

FAMILY_RATE = 0.01
Z_MAX = 5.0


def sidak(n_tests: int, rate: float = FAMILY_RATE) -> float:
    """Per-test level for a family-wise false-positive rate ``rate`` over ``n_tests`` independent tests."""
    return 1.0 - (1.0 - rate) ** (1.0 / max(n_tests, 1))


def seed_of(*parts) -> int:
    return zlib.crc32("|".join(map(str, parts)).encode())


MODULES = [pytest.param(m, id=m.NAME) for m in registry.MODULES]
EXAMPLES = [pytest.param(m.NAME, label, id=f"{m.NAME}-{label}") for m in registry.MODULES for label in m.EXAMPLES]


def setup(name: str, label: str):
    """(module, canonical values, kind, variant, data) of one example."""
    module = registry.get(name)
    values = registry.parse(name, module.EXAMPLES[label])
    kind, variant, data = registry.prepare(name, values)
    return module, values, kind, variant, data


def emergence_probability(module, values, data) -> float:
    """``a = 2 pi K ∫_0^1 T(mu) mu dmu``: the share of the light entering the body that re-emerges,
    from the analytic interface (body term ``K T(c_i) T(c_o)``), by scipy quad; 0 without a body."""
    factor = module.body_factor(values)
    if factor == 0.0:
        return 0.0
    points = [p for p in (1e-4, 1e-3, 1e-2, 0.1, 0.5) if p < 1.0]
    integral = integrate.quad(lambda mu: module.transmittance(mu, data) * mu, 0.0, 1.0, points=points,
                              epsabs=1e-15, epsrel=1e-12, limit=400)[0]
    return 2.0 * math.pi * factor * integral


# ------------------------------------------------------------------ interface and examples


INTERFACE = ("NAME", "DESCRIPTION", "PARAMETERS", "VARIANTS", "EXAMPLES", "variant", "prepare", "event",
             "reflectance", "transmittance", "has_specular", "body_factor")


@pytest.mark.parametrize("module", MODULES)
def test_interface(module):
    for attr in INTERFACE:
        assert hasattr(module, attr), (module.NAME, attr)
    assert isinstance(module.NAME, str) and module.NAME
    assert isinstance(module.DESCRIPTION, str) and module.DESCRIPTION and "\n" not in module.DESCRIPTION
    assert all(isinstance(spec, Number) for spec in module.PARAMETERS)
    assert module.VARIANTS and len(set(module.VARIANTS)) == len(module.VARIANTS)
    keys = registry.config_keys(module.NAME)
    assert len(set(keys)) == len(keys) and keys == registry.value_keys(module.NAME)
    kind = registry.kind_of(module.NAME)
    assert registry.get(module.NAME) is module and registry.MODULES[kind] is module
    assert registry.NAMES[kind] == module.NAME
    # the examples select every compiled variant (also checked by the registry at import)
    selected = {registry.variant_name(module.NAME, registry.parse(module.NAME, raw)) for raw in module.EXAMPLES.values()}
    assert selected == set(module.VARIANTS)


@pytest.mark.parametrize("name, label", EXAMPLES)
def test_example_round_trips_through_the_config(name, label):
    """The example as a ``[material]`` table, with every distribution's every example: parsed to
    the registry's canonical values, and ``Material.from_dict(material.to_dict())`` is the
    material."""
    raw = registry.get(name).EXAMPLES[label]
    values = registry.parse(name, raw)
    assert set(raw) <= set(registry.config_keys(name))
    assert list(values) == list(registry.value_keys(name))
    for dist in distributions.MODULES:
        for dist_raw in dist.EXAMPLES.values():
            m = validate({"material": {"distribution": dist.NAME, **dist_raw, "facet": name, **raw}}).material
            assert m.facet == name and m.facet_params == values
            flat = m.to_dict()
            assert Material.from_dict(flat) == m
            assert Material.from_dict(Material.from_dict(flat).to_dict()) == m
            assert list(flat) == ["distribution", *distributions.value_keys(dist.NAME), "facet",
                                  *registry.value_keys(name)]


COSINES = np.concatenate([np.linspace(0.0, 1.0, 41), [1e-9, 1e-4, 0.999999]])


@pytest.mark.parametrize("name, label", EXAMPLES)
def test_prepare_variant_and_the_analytic_terms(name, label):
    """``prepare`` through the registry is the module's (float64, contiguous), the variant is a
    valid index, ``R`` and ``T`` lie in [0, 1] with ``R + T <= 1`` at every cosine (through the
    registry's dispatch and directly), ``K >= 0``, ``has_specular`` says whether R is ever > 0,
    and one facet event conserves energy on the analytic side: ``R + T a <= 1``."""
    module, values, kind, variant, data = setup(name, label)
    assert kind == registry.kind_of(name)
    assert isinstance(variant, int) and 0 <= variant < len(module.VARIANTS)
    assert registry.variant_name(name, values) == module.VARIANTS[variant]
    assert data.dtype == np.float64 and data.flags.c_contiguous
    np.testing.assert_array_equal(data, module.prepare(values))
    factor = registry.body_factor(name, values)
    assert isinstance(factor, float) and factor == module.body_factor(values) and factor >= 0.0
    assert registry.has_specular(name, values) is bool(module.has_specular(values))
    a = emergence_probability(module, values, data)
    assert 0.0 <= a <= 1.0 + 1e-12
    reflects = False
    for c in COSINES:
        r = registry.reflectance(kind, c, data)
        t = registry.transmittance(kind, c, data)
        assert r == module.reflectance(c, data) and t == module.transmittance(c, data)
        assert 0.0 <= r <= 1.0 and 0.0 <= t <= 1.0 and r + t <= 1.0 + 1e-15
        assert r + t * a <= 1.0 + 1e-12  # energy
        reflects = reflects or r > 0.0
    assert reflects == registry.has_specular(name, values)
    assert registry.is_specular(name, values) == (reflects and factor == 0.0)


# ------------------------------------------------------------------ dispatch


@njit(cache=True)
def _event_via_registry(kind, variant, seed, dx, dy, dz, cos_in, nx, nz, data):
    literally(kind)
    literally(variant)
    state = np.uint64(seed)
    state, outcome, ox, oy, oz = registry.event(kind, variant, state, dx, dy, dz, cos_in, nx, nz, data)
    return state, outcome, ox, oy, oz, registry.reflectance(kind, cos_in, data), registry.transmittance(kind, cos_in,
                                                                                                        data)


@njit(cache=True)
def _event_at_run_time(kind, variant, seed, dx, dy, dz, cos_in, nx, nz, data):
    """The same with a run-time ``kind`` (a branch over the registered modules)."""
    state = np.uint64(seed)
    state, outcome, ox, oy, oz = registry.event(kind, variant, state, dx, dy, dz, cos_in, nx, nz, data)
    return state, outcome, ox, oy, oz, registry.reflectance(kind, cos_in, data), registry.transmittance(kind, cos_in,
                                                                                                        data)


@pytest.mark.parametrize("name, label", EXAMPLES)
def test_dispatch_gives_the_module_event(name, label):
    """The registry's event (a compile-time and a run-time ``kind``) is the module's own (called
    directly), outcome for outcome, state for state."""
    module, _, kind, variant, data = setup(name, label)
    cos_in = 0.6
    d, nx, nz = incoming(cos_in)
    for seed in range(20):
        got = _event_via_registry(kind, variant, seed, *d, cos_in, nx, nz, data)
        assert _event_at_run_time(kind, variant, seed, *d, cos_in, nx, nz, data) == got
        assert got[:5] == module.event(variant, np.uint64(seed), *d, cos_in, nx, nz, data)
        assert got[1] in (SCATTERED, ABSORBED)
        assert got[5:] == (module.reflectance(cos_in, data), module.transmittance(cos_in, data))


# ------------------------------------------------------------------ the event: energy and directions


REFLECTED, EMERGED, LOST = 0, 1, 2


@njit(cache=True)
def _events(kind, variant, n, seed, dx, dy, dz, cos_in, nx, nz, data):
    """n facet events from one incoming direction: kind of outcome and direction."""
    literally(kind)
    literally(variant)
    state = np.uint64(seed)
    kinds = np.empty(n, np.int64)
    out = np.empty((n, 3))
    rx, rz = dx + 2.0 * cos_in * nx, dz + 2.0 * cos_in * nz  # the mirror direction d + 2 c n
    for k in range(n):
        state, outcome, ox, oy, oz = registry.event(kind, variant, state, dx, dy, dz, cos_in, nx, nz, data)
        out[k, 0], out[k, 1], out[k, 2] = ox, oy, oz
        if outcome == ABSORBED:
            kinds[k] = LOST
        elif abs(ox - rx) <= 1e-15 and oy == dy and abs(oz - rz) <= 1e-15:
            kinds[k] = REFLECTED
        else:
            kinds[k] = EMERGED
    return kinds, out


# 40 bins of equal probability for the pdf 2 mu (T = 1); populated for every T here
MU_EDGES = np.sqrt(np.linspace(0.0, 1.0, 41))
EVENT_COSINES = (0.9, 0.2)
N_EVENTS = 200_000


def _mu_bin_probabilities(module, data):
    """Probability of each MU_EDGES bin under the pdf ``T(mu) mu / ∫ T mu`` (scipy quad)."""
    f = lambda mu: module.transmittance(mu, data) * mu  # noqa: E731
    cells = [integrate.quad(f, lo, hi, epsabs=1e-15, epsrel=1e-12, limit=200)[0]
             for lo, hi in zip(MU_EDGES[:-1], MU_EDGES[1:])]
    return np.array(cells) / sum(cells)


def _chi_square_tests():
    """The emerging-cosine chi-square tests the default suite runs: one per example and cosine
    whose event re-emits through a body (known from the analytic terms, before any test)."""
    count = 0
    for module in registry.MODULES:
        for raw in module.EXAMPLES.values():
            values = registry.parse(module.NAME, raw)
            count += len(EVENT_COSINES) if module.body_factor(values) > 0.0 else 0
    return count


CHI_SQUARE_LEVEL = sidak(_chi_square_tests())


@pytest.mark.parametrize("name, label", EXAMPLES)
def test_event_conserves_energy_and_follows_the_analytic_terms(name, label):
    """2e5 events from each of two incoming cosines: reflected specularly with probability
    ``R(c)``, re-emitted with ``T(c) a``, absorbed otherwise (z-tests; outcomes of probability
    0 never occur: a lossless facet loses nothing); re-emitted directions are unit, leave on
    the outer side with the cosine pdf ``∝ T(mu) mu`` (chi-square over 40 bins) and a uniform
    azimuth (the tangential mean vanishes within 5 sigma)."""
    module, values, kind, variant, data = setup(name, label)
    a = emergence_probability(module, values, data)
    for cos_in in EVENT_COSINES:
        (dx, dy, dz), nx, nz = incoming(cos_in)
        kinds, out = _events(kind, variant, N_EVENTS, seed_of(name, label, cos_in) & 0x7FFFFFFF, dx, dy, dz, cos_in,
                             nx, nz, data)
        r, t = module.reflectance(cos_in, data), module.transmittance(cos_in, data)
        expected = {REFLECTED: r, EMERGED: t * a, LOST: max(0.0, 1.0 - r - t * a)}
        counts = np.bincount(kinds, minlength=3)
        for outcome, p in expected.items():
            if p < 1e-12:
                assert counts[outcome] == 0, (cos_in, outcome, counts, p)
            else:
                z = (counts[outcome] - N_EVENTS * p) / math.sqrt(max(N_EVENTS * p * (1.0 - p), 1e-300))
                assert abs(z) < Z_MAX, (cos_in, outcome, counts, expected)
        emerged = out[kinds == EMERGED]
        if emerged.shape[0]:
            np.testing.assert_allclose(np.linalg.norm(emerged, axis=1), 1.0, rtol=0, atol=1e-14)
            mu = emerged[:, 0] * nx + emerged[:, 2] * nz
            assert np.all(mu > 0.0)  # leaves on the outer side of the facet
            tangential = emerged - mu[:, None] * np.array([nx, 0.0, nz])
            assert np.all(np.abs(tangential.mean(axis=0)) < Z_MAX * 0.71 / math.sqrt(mu.size))
            observed, _ = np.histogram(mu, bins=MU_EDGES)
            expected_cells = _mu_bin_probabilities(module, data) * mu.size
            if expected_cells.min() >= 5.0:
                p_value = stats.chisquare(observed, expected_cells).pvalue
                assert p_value > CHI_SQUARE_LEVEL, (cos_in, p_value)
