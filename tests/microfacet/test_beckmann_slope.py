"""Beckmann's visible slope along the view drawn from a random stream
(:func:`vcavity.microfacet.beckmann_visible.sample_slope_along`, physics.md sec. 14) against its
closed-form CDF, one ``mu`` at a time: every piece of the mixture and the rejection proposals
on both sides of their switches, and ``mu`` far below 0 (rays travelling up nearly vertically),
which the chi-square of whole normals (test_visible_normals.py) cannot resolve.

The CDF ``F(x) = C(x)/C(mu)``, ``C(x) = (mu/2) erfc(-x) + exp(-x^2)/(2 sqrt(pi))``, is evaluated
with scipy's ``erfc`` and ``erfcx`` (independent of the package; for ``x < 0`` in the scaled form
that does not cancel). ``F`` of the samples must be uniform: chi-square on 50 equal bins of 2e5
samples, failing at p < 1e-4 (false-positive rate 1e-4 per ``mu``, 1.2e-3 for the file; fixed
seeds make the outcome deterministic). The mixture weights come from the closed form
``C(mu) = mu (1 + Lambda(mu))`` (scipy's erfc), as the walk passes them.
"""

import math

import numpy as np
import pytest
from numba import njit
from scipy import special, stats

from vcavity.microfacet import beckmann_visible as visible
from vcavity.rng import block_key

N = 200_000
BINS = 50
SQRT_PI = math.sqrt(math.pi)


@njit
def _draw(mu, total, n, seed):
    state = block_key(np.uint64(seed), 0)
    out = np.empty(n)
    for i in range(n):
        state, out[i] = visible.sample_slope_along(state, mu, total)
    return out


def _cdf(x, mu):
    """``C(x)/C(mu)`` for ``x <= mu`` (scipy), without cancellation."""
    x = np.asarray(x, dtype=np.float64)
    if mu > 0.0:  # every term positive, divided by mu
        c = lambda t: 0.5 * special.erfc(-t) + np.exp(-t * t) / (2.0 * SQRT_PI * mu)  # noqa: E731
        return c(x) / c(mu)
    # x <= mu <= 0: erfc(-x) = erfcx(|x|) exp(-x^2); C = exp(-x^2)/2 (mu erfcx(|x|) + 1/sqrt(pi))
    c = lambda t: 0.5 * (mu * special.erfcx(-t) + 1.0 / SQRT_PI)  # noqa: E731
    return np.exp(mu * mu - x * x) * c(x) / c(mu)


MUS = [-6.0, -2.4, -0.8, -0.1, 0.0, 0.05, 0.96, 1.7, 1.8, 3.0, 12.0, 1e200, float("nan")]


@pytest.mark.parametrize("mu", MUS[:-1])
def test_slope_along_follows_its_cdf(mu):
    total = 0.5 * mu * special.erfc(-mu) + math.exp(-mu * mu) / (2.0 * SQRT_PI) if mu > 0.0 else math.nan
    x = _draw(mu, total, N, 17)
    assert np.all(x <= mu)
    u = _cdf(x, mu)
    assert np.all((u >= 0.0) & (u <= 1.0 + 1e-12))
    observed = np.histogram(u, bins=BINS, range=(0.0, 1.0))[0]
    chi2, p = stats.chisquare(observed)
    assert p > 1e-4, f"chi2 {chi2:.1f} on {BINS - 1} dof"


def test_infinite_total_is_recomputed():
    """A non-finite ``C(mu)`` (Lambda overflowing) falls back to the closed form: same samples."""
    mu = 0.96
    total = 0.5 * mu * special.erfc(-mu) + math.exp(-mu * mu) / (2.0 * SQRT_PI)
    assert np.allclose(_draw(mu, math.inf, 1000, 5), _draw(mu, total, 1000, 5), rtol=0.0, atol=1e-12)


def test_nan_mu_ends():
    """A NaN ``mu`` gives NaN slopes (the walk counts them degenerate) instead of looping."""
    assert np.all(np.isnan(_draw(MUS[-1], math.nan, 10, 3)))
