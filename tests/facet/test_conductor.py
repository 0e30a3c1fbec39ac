"""The conductor facet (vcavity/facet/conductor.py; physics.md sec. 4): its parameters and
defaults, prepared data, the reflectance and transmittance the analytic models use, the
bracketing table and the facet event the kernel runs.

Deterministic (no false-positive rate). The event's reflection frequency against F is
checked for every facet model and example in tests/facet/test_conformance.py; here, that
each event draws exactly one uniform and reflects into the mirror direction.
"""

import sys
from pathlib import Path

import numpy as np
import pytest
from vcavity._numba.jit import njit  # caches where vcavity's own code does

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

from tests.facet.frames import incoming  # noqa: E402
from vcavity.facet import conductor  # noqa: E402
from vcavity.facet.common import ABSORBED, BRACKET_BINS, SCATTERED, reflect  # noqa: E402
from vcavity.facet.fresnel_conductor import fresnel_conductor, fresnel_conductor_array  # noqa: E402
from vcavity.parameters import ParameterError  # noqa: E402
from vcavity.rng import next_uniform  # noqa: E402

# gold at 659.5, 548.6 and 450.9 nm (Johnson & Christy 1972), a dielectric-like and an
# extreme index, and eta < 1 without absorption (total internal reflection near grazing)
INDICES = [(0.14, 3.697), (0.43, 2.455), (1.38, 1.914), (1.5, 0.0), (8.0, 0.3), (0.05, 20.0), (0.7, 0.0)]


def test_interface_and_defaults():
    assert conductor.NAME == "conductor" and conductor.VARIANTS == ("conductor",)
    eta, k = conductor.PARAMETERS
    assert (eta.key, eta.default, k.key, k.default) == ("eta", 0.43, "k", 2.455)
    assert "Johnson & Christy 1972" in eta.summary and "Johnson & Christy 1972" in k.summary
    assert conductor.variant({"eta": 0.43, "k": 2.455}) == 0
    assert conductor.has_specular({"eta": 2.0, "k": 1.0}) and conductor.body_factor({"eta": 2.0, "k": 1.0}) == 0.0


def test_parameter_ranges():
    parse = {spec.key: spec for spec in conductor.PARAMETERS}
    with pytest.raises(ParameterError, match=r"^material\.eta = 0: must be > 0$"):
        parse["eta"].parse({"eta": 0}, "material", "facet 'conductor'")
    with pytest.raises(ParameterError, match=r"^material\.k = -0\.1: must be >= 0$"):
        parse["k"].parse({"k": -0.1}, "material", "facet 'conductor'")
    assert parse["k"].parse({}, "material", "facet 'conductor'") == {"k": 2.455}


def test_gold_defaults_hold_only_together():
    """Both absent: gold at 548.6 nm; both given: the user's; one alone is refused, naming the
    missing one (gold's k with another metal's eta would be no metal at all)."""
    from vcavity.facet import registry

    assert registry.parse("conductor", {}) == {"eta": 0.43, "k": 2.455}
    assert registry.parse("conductor", {"eta": 0.2, "k": 3.0}) == {"eta": 0.2, "k": 3.0}
    with pytest.raises(ParameterError, match=r"^material\.k is missing: .* with material\.eta = 0\.2; "):
        registry.parse("conductor", {"eta": 0.2})
    with pytest.raises(ParameterError, match=r"^material\.eta is missing: .* with material\.k = 0; "):
        registry.parse("conductor", {"k": 0})


@pytest.mark.parametrize("eta, k", INDICES)
def test_prepared_data_and_reflectance(eta, k):
    data = conductor.prepare({"eta": eta, "k": k})
    assert data.dtype == np.float64 and data.flags.c_contiguous and data.shape == (2 + 2 * BRACKET_BINS,)
    assert data[0] == eta and data[1] == k
    for c in np.linspace(0.0, 1.0, 11):
        assert conductor.reflectance(c, data) == fresnel_conductor(c, eta, k)
        assert conductor.transmittance(c, data) == 0.0  # nothing enters and comes back


@pytest.mark.parametrize("eta, k", INDICES)
def test_brackets_contain_the_reflectance_on_a_fine_grid(eta, k):
    brackets = conductor.prepare({"eta": eta, "k": k})[2:].reshape(BRACKET_BINS, 2)
    c = np.linspace(0.0, 1.0, 2_000_001)
    f = fresnel_conductor_array(c, eta, k)
    j = np.minimum((c * BRACKET_BINS).astype(int), BRACKET_BINS - 1)
    assert np.all(brackets[j, 0] <= f) and np.all(f <= brackets[j, 1])
    assert np.mean(brackets[:, 1] - brackets[:, 0] < 0.01) > 0.8  # and useful: F is steep only near grazing


@njit(cache=True)
def _decisions(u, c, data):
    fast = np.empty(u.size, np.bool_)
    exact = np.empty(u.size, np.bool_)
    for j in range(u.size):
        fast[j] = conductor._below_reflectance(u[j], c[j], data)
        exact[j] = u[j] < fresnel_conductor(c[j], data[0], data[1])
    return fast, exact


@pytest.mark.parametrize("eta, k", INDICES)
def test_bracketed_decision_equals_exact_decision(eta, k):
    rng = np.random.default_rng(5)
    data = conductor.prepare({"eta": eta, "k": k})
    c = np.concatenate([rng.uniform(0, 1, 200_000), np.arange(BRACKET_BINS + 1) / BRACKET_BINS, [0.0, 1.0]])
    exact_f = fresnel_conductor_array(c, eta, k)
    # uniforms both random and right at F (within an ulp), where a wrong bound would show
    u = np.concatenate([rng.uniform(0, 1, c.size), exact_f, np.nextafter(exact_f, 0), np.nextafter(exact_f, 1)])
    fast, exact = _decisions(u, np.tile(c, 4), data)
    np.testing.assert_array_equal(fast, exact)


@njit(cache=True)
def _events(n, seed, dx, dy, dz, cos_in, nx, nz, data):
    """n facet events from one direction: reflected count, whether each event drew exactly
    one uniform, and whether every reflection is the mirror direction."""
    state = np.uint64(seed)
    reflected = 0
    one_draw = True
    mirror_direction = True
    rx, rz = reflect(dx, dz, cos_in, nx, nz)
    for _ in range(n):
        expected_state, _u = next_uniform(state)
        state, outcome, ox, oy, oz = conductor.event(0, state, dx, dy, dz, cos_in, nx, nz, data)
        one_draw = one_draw and state == expected_state
        if outcome == SCATTERED:
            reflected += 1
            mirror_direction = mirror_direction and ox == rx and oy == dy and oz == rz
        elif outcome != ABSORBED:
            one_draw = False
    return reflected, one_draw, mirror_direction


def test_event_draws_one_uniform_and_reflects_specularly():
    data = conductor.prepare({"eta": 0.43, "k": 2.455})
    for seed, cos_in in enumerate((0.02, 0.1, 0.3, 0.55, 0.8, 0.999)):
        d, nx, nz = incoming(cos_in)
        reflected, one_draw, mirror_direction = _events(5000, 1000 + seed, *d, cos_in, nx, nz, data)
        assert one_draw and mirror_direction
        assert 0 < reflected < 5000
