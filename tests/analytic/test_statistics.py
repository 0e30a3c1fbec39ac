"""Statistics helpers against SciPy (tests only depend on it)."""

import math

import numpy as np
import pytest
from scipy import stats

from vcavity.analytic.statistics import (
    albedo_z_test,
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


# ---------------------------------------------------------------------- fail-safe rules

def _draw(seed=5, n_cells=200, albedo=0.69, paths=100_000):
    """Counts drawn from a known truth: cell probabilities summing to ``albedo``."""
    rng = np.random.default_rng(seed)
    probs = rng.dirichlet(np.ones(n_cells)) * albedo
    counts = rng.multinomial(paths, np.append(probs, 1.0 - albedo))[:-1]
    return counts, probs, paths


def test_truth_passes_both_tests():
    counts, probs, paths = _draw()
    chi = pearson_chi_square(counts, paths * probs, paths)
    assert chi.testable and not chi.failure and chi.p_value > 1e-3
    z = albedo_z_test(counts.sum(), probs.sum(), paths)
    assert not z.failure and z.p_value > 1e-3


def test_model_one_and_a_half_times_the_truth_fails():
    # A masking max() instead of min() predicted 1.26 against 0.69: the model albedo
    # passes 1 for such a model; also test a scaled model that stays below 1.
    counts, probs, paths = _draw(albedo=0.6)
    chi = pearson_chi_square(counts, 1.5 * paths * probs, paths)
    assert chi.p_value == 0.0 or chi.p_value < 1e-12
    assert not chi.passed(1e-3)
    z = albedo_z_test(counts.sum(), 1.5 * probs.sum(), paths)
    assert not z.passed(1e-3) and abs(z.z) > 10
    counts, probs, paths = _draw(albedo=0.69)
    over = pearson_chi_square(counts, 1.5 * paths * probs, paths)  # albedo 1.035 >= 1
    assert over.failure and over.p_value == 0.0 and not over.passed(1e-300)
    assert "albedo" in over.failure
    assert albedo_z_test(counts.sum(), 1.5 * probs.sum(), paths).failure


def test_nan_model_fails():
    counts, probs, paths = _draw()
    expected = paths * probs
    expected[7] = np.nan
    chi = pearson_chi_square(counts, expected, paths)
    assert chi.failure and chi.p_value == 0.0 and not chi.passed(1e-300)
    z = albedo_z_test(counts.sum(), float("nan"), paths)
    assert z.failure and not z.passed(1e-300)


def test_zero_expected_where_paths_landed_fails():
    counts, probs, paths = _draw()
    expected = paths * probs
    hit = int(np.flatnonzero(counts > 0)[0])
    expected[hit] = 0.0
    chi = pearson_chi_square(counts, expected, paths)
    assert chi.failure and not chi.passed(1e-300)
    # the complement category: the model leaves nothing outside the cells, paths did
    probs_all = probs / probs.sum()
    chi = pearson_chi_square(counts, paths * probs_all, paths)
    assert chi.failure and not chi.passed(1e-300)


def test_infinite_statistic_and_nan_p_values_are_never_a_pass():
    assert math.isnan(chi2_sf(float("nan"), 3))
    assert chi2_sf(float("inf"), 3) == 0.0
    counts = np.array([0, 5, 0])
    chi = pearson_chi_square(counts, np.array([0.0, 10.0, -1.0]), 10)
    assert chi.failure and not chi.passed(1e-300)


def test_fewer_than_two_categories_is_not_testable():
    # Every cell's expected count below 5: all pooled into the complement, one category
    # left. Not testable (no p-value), never a pass.
    chi = pearson_chi_square(np.array([1, 0, 2]), np.array([1.0, 1.0, 1.5]), 1000)
    assert not chi.testable and math.isnan(chi.p_value) and not chi.passed(0.0)
    assert "NOT TESTABLE" in chi.verdict(0.01)
    # Phong with exponent 1e300: the model gave every cell 0 while the table had paths
    # in one cell ("1 categories ... p = 1 -> PASS" before): a failure.
    chi = pearson_chi_square(np.array([0, 41]), np.array([0.0, 0.0]), 1000)
    assert chi.failure and not chi.passed(0.0)


def test_albedo_z_matches_binomial_and_has_nominal_false_alarm_rate():
    # z against SciPy's binomial mean and variance
    t = albedo_z_test(7000, 0.69, 10_000)
    mean, var = stats.binom.stats(10_000, 0.69)
    assert t.z == pytest.approx((7000 - mean) / math.sqrt(var), rel=1e-12)
    assert t.p_value == pytest.approx(2 * stats.norm.sf(abs(t.z)), rel=1e-10)
    # false-alarm rate: 2000 totals drawn from the model, P(p < 0.05) ~ 0.05; the count is
    # Binomial(2000, 0.05) = 100 +- 9.7 (plus a small normal-approximation error): the
    # bounds [60, 140] fail with probability < 1e-4 at the nominal rate (fixed seed).
    rng = np.random.default_rng(11)
    totals = rng.binomial(40_000, 0.3, size=2000)
    low = sum(albedo_z_test(k, 0.3, 40_000).p_value < 0.05 for k in totals)
    assert 60 <= low <= 140
