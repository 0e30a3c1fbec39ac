"""Statistics helpers against SciPy (tests only depend on it)."""

import math

import numpy as np
import pytest
from scipy import stats

from vcavity.analytic.statistics import (
    binomial_mean_abs_deviation,
    chi2_sf,
    pearson_chi_square,
    sidak_threshold,
)


@pytest.mark.parametrize("dof", [1, 2, 7, 60, 625, 3249, 20000])
def test_chi2_sf_matches_scipy(dof):
    for x in (0.0, 0.05 * dof, 0.8 * dof, dof, 1.1 * dof, dof + 6 * math.sqrt(2 * dof), 3 * dof + 50):
        expected = stats.chi2.sf(x, dof)
        assert chi2_sf(x, dof) == pytest.approx(expected, rel=1e-10, abs=1e-300)
    with pytest.raises(ValueError):
        chi2_sf(1.0, 0)


def test_binomial_mean_abs_deviation_matches_scipy():
    for n, p in ((1000, 0.3), (10**6, 2e-6), (10**6, 0.01), (50, 0.999)):
        x = np.arange(n + 1) if n <= 1000 else np.arange(0, int(n * p + 40 * math.sqrt(n * p) + 40))
        expected = np.sum(stats.binom.pmf(x, n, p) * np.abs(x - n * p))
        # (lgamma of N ~ 1e6 is ~1e7: round-off ~1e-9 relative after the exp)
        assert binomial_mean_abs_deviation(n, [p])[0] == pytest.approx(expected, rel=1e-8)
    assert binomial_mean_abs_deviation(10, [0.0, 1.0]).tolist() == [0.0, 0.0]


def test_sidak():
    assert sidak_threshold(0.01, 1) == pytest.approx(0.01)
    level = sidak_threshold(0.01, 14)
    assert 1 - (1 - level) ** 14 == pytest.approx(0.01)


def test_pearson_pooling_and_complement():
    expected = np.array([100.0, 50.0, 3.0, 1.0, 0.5])
    observed = np.array([110, 45, 2, 2, 0])
    paths = 200
    result = pearson_chi_square(observed, expected, paths)
    # categories: 100, 50, pooled (4.5 < 5 -> merged into the complement 45.5 + 4.5)
    rest_exp = paths - expected.sum() + 4.5
    rest_obs = paths - observed.sum() + 4
    manual = (10**2 / 100 + 5**2 / 50 + (rest_obs - rest_exp) ** 2 / rest_exp)
    assert result.statistic == pytest.approx(manual)
    assert result.dof == 2 and result.n_categories == 3 and result.pooled_cells == 3
    assert result.p_value == pytest.approx(stats.chi2.sf(manual, 2))
    assert result.max_z_cell == 0
    assert result.max_abs_z == pytest.approx(10 / math.sqrt(100 * (1 - 0.5)))


def test_pearson_false_alarm_rate_is_nominal():
    # Multinomial draws from the model itself: p-values uniform, so P(p < 0.05) ~ 0.05.
    # 400 draws: the count of p < 0.05 is Binomial(400, 0.05) = 20 +- 4.4; the bounds
    # [6, 36] fail with probability < 1e-4 (fixed seed: deterministic).
    rng = np.random.default_rng(2024)
    probs = rng.dirichlet(np.ones(300)) * 0.7  # 30 % "not in any cell"
    paths = 20000
    low = 0
    for _ in range(400):
        counts = rng.multinomial(paths, np.append(probs, 0.3))[:-1]
        if pearson_chi_square(counts, paths * probs, paths).p_value < 0.05:
            low += 1
    assert 6 <= low <= 36
