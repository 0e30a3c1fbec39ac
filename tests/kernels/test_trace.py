"""Pieces of the walk: the Fresnel bracketing table and the exactness of its decisions."""

import numpy as np
import pytest
from numba import njit

from vcavity.facet.fresnel import fresnel_dielectric, fresnel_dielectric_array
from vcavity.kernels.trace import FRESNEL_BINS, _below_fresnel, fresnel_brackets


@pytest.mark.parametrize("eta", [1.0 + 1e-9, 1.0001, 1.33, 1.5, 2.5, 10.0, 1000.0, 1e4])
def test_brackets_contain_fresnel_on_a_fine_grid(eta):
    brackets = fresnel_brackets(eta)
    c = np.linspace(0.0, 1.0, 2_000_001)
    f = fresnel_dielectric_array(c, eta)
    j = np.minimum((c * FRESNEL_BINS).astype(int), FRESNEL_BINS - 1)
    assert np.all(brackets[j, 0] <= f) and np.all(f <= brackets[j, 1])
    # and they are useful: most bins bracket tightly at moderate eta (F is steep only near grazing)
    if eta < 5:
        assert np.mean(brackets[:, 1] - brackets[:, 0] < 0.01) > 0.8


@njit(cache=True)
def _decisions(u, c, eta, nodes):
    fast = np.empty(u.size, np.bool_)
    exact = np.empty(u.size, np.bool_)
    for k in range(u.size):
        fast[k] = _below_fresnel(u[k], c[k], eta, nodes)
        exact[k] = u[k] < fresnel_dielectric(c[k], eta)
    return fast, exact


@pytest.mark.parametrize("eta", [1.0 + 1e-6, 1.5, 3.0, 1000.0, 1e4])
def test_bracketed_decision_equals_exact_decision(eta):
    rng = np.random.default_rng(5)
    nodes = fresnel_brackets(eta)
    assert nodes.shape == (FRESNEL_BINS, 2)
    c = np.concatenate([rng.uniform(0, 1, 300_000), np.arange(FRESNEL_BINS + 1) / FRESNEL_BINS, [0.0, 1.0]])
    exact_f = fresnel_dielectric_array(c, eta)
    # uniforms both random and right at F (within a few ulp), where a wrong bound would show
    u = np.concatenate([rng.uniform(0, 1, c.size), exact_f, np.nextafter(exact_f, 0), np.nextafter(exact_f, 1)])
    fast, exact = _decisions(u, np.tile(c, 4), eta, nodes)
    np.testing.assert_array_equal(fast, exact)
