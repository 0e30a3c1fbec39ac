"""The ziggurat's normal and exponential deviates (vcavity/rng/ziggurat.py) against their
closed-form CDFs (``math.erf``, ``math.exp``): independent of the tables' construction.

The chi-square bins are the ziggurat's own layer edges ``x_i`` (and the tail beyond ``r``),
so a fault in one layer's wedge or in the tail moves mass between the bins it owns, where
the test is most sensitive; the expected counts come from the closed forms alone. Each
chi-square test fails a correct sampler with probability 1e-6 (fixed seeds: the outcome
is the same on every run).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from scipy import stats

from vcavity.rng import ziggurat

N_DRAWS = 4_000_000
FALSE_POSITIVE_RATE = 1e-6


@njit(cache=False)
def _draw_normal(key, n):
    out = np.empty(n)
    state = np.uint64(key)
    for j in range(n):
        state, out[j] = ziggurat.standard_normal(state)
    return out


@njit(cache=False)
def _draw_exponential(key, n):
    out = np.empty(n)
    state = np.uint64(key)
    for j in range(n):
        state, out[j] = ziggurat.standard_exponential(state)
    return out


@njit(cache=False)
def _draw_tail(key, n, normal):
    out = np.empty(n)
    state = np.uint64(key)
    for j in range(n):
        if normal:
            state, out[j] = ziggurat.normal_tail(state)
        else:
            state, out[j] = ziggurat.exponential_tail(state)
    return out


def _normal_cdf(x):
    return np.array([0.5 * math.erfc(-xi / math.sqrt(2.0)) for xi in x])


def _exponential_cdf(x):
    return np.array([-math.expm1(-xi) for xi in x])


def _chi_square_p(samples, edges, cdf):
    """p-value of the counts between ``edges`` (``-inf``/``inf`` ends allowed) against ``cdf``."""
    counts, _ = np.histogram(samples, edges)
    expected = len(samples) * np.diff(cdf(edges))
    assert expected.min() > 20.0, "bins too fine for the chi-square approximation"
    chi2 = float(((counts - expected) ** 2 / expected).sum())
    return stats.chi2.sf(chi2, len(counts) - 1), chi2


def _layer_edges(width, merge):
    """Inner edges ``x_255 < ... < x_1 = r`` of the layers, every ``merge``-th one (the
    thin top layers merged so that each bin expects enough draws)."""
    x = np.sort(width[1:])
    return x[::-merge][::-1]


def test_normal_layers_have_equal_area():
    # the construction's invariant, checked with the closed-form tail: every layer's area is v
    f = lambda x: math.exp(-0.5 * x * x)
    x = list(ziggurat._NORMAL_WIDTH[1:]) + [0.0]
    areas = [x[i] * (f(x[i + 1]) - f(x[i])) for i in range(len(x) - 1)]
    tail = math.sqrt(math.pi / 2) * math.erfc(ziggurat.NORMAL_R / math.sqrt(2.0))
    areas.append(ziggurat.NORMAL_R * f(ziggurat.NORMAL_R) + tail)
    np.testing.assert_allclose(areas, ziggurat.NORMAL_V, rtol=1e-11)


def test_exponential_layers_have_equal_area():
    x = list(ziggurat._EXP_WIDTH[1:]) + [0.0]
    areas = [x[i] * (math.exp(-x[i + 1]) - math.exp(-x[i])) for i in range(len(x) - 1)]
    areas.append((ziggurat.EXPONENTIAL_R + 1.0) * math.exp(-ziggurat.EXPONENTIAL_R))
    np.testing.assert_allclose(areas, ziggurat.EXPONENTIAL_V, rtol=1e-11)


@pytest.mark.parametrize("key", [1, 0x5EED])
def test_normal_against_erf(key):
    x = _draw_normal(key, N_DRAWS)
    inner = _layer_edges(ziggurat._NORMAL_WIDTH, 2)
    # both signs: the sign bit must be independent of the magnitude
    edges = np.concatenate([[-np.inf], -inner[::-1], [0.0], inner, [np.inf]])
    p, chi2 = _chi_square_p(x, edges, _normal_cdf)
    assert p > FALSE_POSITIVE_RATE, f"chi2 {chi2:.1f} on {len(edges) - 2} dof, p = {p:.2e}"


@pytest.mark.parametrize("key", [2, 0xBEEF])
def test_exponential_against_closed_form(key):
    x = _draw_exponential(key, N_DRAWS)
    assert x.min() >= 0.0
    inner = _layer_edges(ziggurat._EXP_WIDTH, 2)
    edges = np.concatenate([[0.0], inner, [ziggurat.EXPONENTIAL_R + 0.5, np.inf]])
    p, chi2 = _chi_square_p(x, edges, _exponential_cdf)
    assert p > FALSE_POSITIVE_RATE, f"chi2 {chi2:.1f} on {len(edges) - 2} dof, p = {p:.2e}"


def test_moments():
    # a coarse, bin-free check: mean, variance and fourth moment within 6 standard errors
    z = _draw_normal(7, N_DRAWS)
    e = _draw_exponential(8, N_DRAWS)
    n = float(N_DRAWS)
    assert abs(z.mean()) < 6.0 / math.sqrt(n)
    assert abs((z * z).mean() - 1.0) < 6.0 * math.sqrt(2.0 / n)
    assert abs((z ** 4).mean() - 3.0) < 6.0 * math.sqrt(96.0 / n)
    assert abs(e.mean() - 1.0) < 6.0 / math.sqrt(n)
    assert abs((e * e).mean() - 2.0) < 6.0 * math.sqrt(20.0 / n)


@pytest.mark.parametrize("normal", [True, False], ids=["normal", "exponential"])
def test_tails_against_closed_form(normal):
    # the tails beyond r (2.6e-4 and 4.5e-4 of draws) drawn on their own, against the
    # conditional CDF (x > r) of the closed form
    r = ziggurat.NORMAL_R if normal else ziggurat.EXPONENTIAL_R
    cdf = _normal_cdf if normal else _exponential_cdf
    below = 1.0 - cdf([r])[0] if normal else math.exp(-r)
    if normal:
        conditional = lambda e: 1.0 - np.array([0.5 * math.erfc(xi / math.sqrt(2.0)) for xi in e]) / below
    else:
        conditional = lambda e: -np.expm1(-(np.asarray(e) - r))
    x = _draw_tail(3, 1_000_000, normal)
    assert x.min() >= r
    scale = 1.0 / r if normal else 1.0  # the tail's own length scale
    edges = r + scale * np.concatenate([np.linspace(0.0, 4.0, 41), [np.inf]])
    p, chi2 = _chi_square_p(x, edges, conditional)
    assert p > FALSE_POSITIVE_RATE, f"chi2 {chi2:.1f}, p = {p:.2e}"
