"""The Gaussian distribution's own sampling table (vcavity/microfacet/gaussian.py; IL eq. 13).

The generic checks of every distribution (normalisation, sampling chi-square, the disk
sampler, the sampler's contract at the ends of [0, 1), dispatch) are in
tests/microfacet/test_conformance.py, over every registered module and its EXAMPLES.
Deterministic (no false-positive rate).
"""

import functools
import math

import numpy as np
import pytest
from scipy import integrate, optimize

from vcavity.microfacet import gaussian


@functools.lru_cache(maxsize=None)
def gaussian_params(sigma):
    """Gaussian tables are costly to build (~0.2 s): build each parameter set once."""
    return gaussian.params_from({"sigma": sigma})


def gaussian_theta_reference(u, sigma):
    """Slow reference: brentq on the scipy.quad CDF (tail integral for u > 1/2)."""
    top = min(math.pi / 2.0, 14.0 * sigma)  # beyond: < exp(-98), negligible even in the tail
    f = lambda t: math.exp(-0.5 * (t / sigma) ** 2) * math.sin(t)  # noqa: E731

    def quad(a, b):
        if b - a < 1e-9:  # midpoint rule: quad warns on intervals of a few ulp
            return f(0.5 * (a + b)) * (b - a)
        return integrate.quad(f, a, b, epsabs=0.0, epsrel=1e-13, limit=200)[0]

    total = quad(0.0, top)
    if u < 0.5:
        return optimize.brentq(lambda th: quad(0.0, th) / total - u, 0.0, top, xtol=1e-15)
    return optimize.brentq(lambda th: (1.0 - u) - quad(th, top) / total, 0.0, top, xtol=1e-15)


@pytest.mark.parametrize("sigma", [1e-3, 0.1, 0.35, 1.0, 2.0])
def test_gaussian_inverse_cdf_accuracy(sigma):
    """Tabulated inverse CDF within 1e-7 rad of a root-find reference (IL eq. 13)."""
    params = gaussian_params(sigma)
    rng = np.random.default_rng(7)
    us = np.concatenate((rng.random(30), [1e-12, 0.5, 1.0 - 1e-9, 1.0 - 2.0**-53]))
    err = [abs(gaussian.inverse_cdf_theta(u, params) - gaussian_theta_reference(u, sigma))
           for u in us]
    assert max(err) < 1e-7
    # normalisation constant: 1/C = 2 pi int_0^{pi/2} exp(-theta^2/(2 sigma^2)) sin theta
    density = lambda t: math.exp(-0.5 * (t / sigma) ** 2) * math.sin(t)  # noqa: E731
    top = min(math.pi / 2, 40 * sigma)
    inv_c = 2.0 * math.pi * integrate.quad(density, 0.0, top, epsabs=0.0, epsrel=1e-13)[0]
    assert abs(params[1] * inv_c - 1.0) < 1e-10
