"""Small statistics helpers for comparing Monte-Carlo counts with a model, in plain
Python/NumPy (SciPy is only a test dependency).

- :func:`chi2_sf`: upper tail of the chi-square distribution, ``Q(k/2, x/2)`` by the
  series / continued fraction of the regularised incomplete gamma function.
- :func:`pearson_chi_square`: Pearson's test of multinomial counts against expected
  counts, with pooling of small categories; fail-safe (below).
- :func:`albedo_z_test`: the total of the counts against the model's albedo (normal
  approximation of the binomial total, two-sided); fail-safe.

Fail-safe means a model that cannot be right never passes: a NaN or infinite
statistic, a category the model gives an expected count <= 0 while paths landed there,
a NaN model value, or a model albedo >= 1 (the model predicts every path or more) is a
failure with p = 0 and the reason recorded; fewer than two categories is "not
testable" (no p-value), which callers must not report as a pass.
- :func:`binomial_mean_abs_deviation`: ``E|X - Np|`` of a binomial count, exactly
  (De Moivre), the yardstick for an L1 difference that noise alone would give.
- :func:`sidak_threshold`: per-test level for a family of independent tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_MAX_ITERATIONS = 100_000
_EPS = 1e-16


def _gamma_series(a: float, x: float) -> float:
    """Regularised lower incomplete gamma ``P(a, x)`` by its series (x < a + 1)."""
    term = 1.0 / a
    total = term
    ap = a
    for _ in range(_MAX_ITERATIONS):
        ap += 1.0
        term *= x / ap
        total += term
        if abs(term) < abs(total) * _EPS:
            break
    return total * math.exp(-x + a * math.log(x) - math.lgamma(a))


def _gamma_continued_fraction(a: float, x: float) -> float:
    """Regularised upper incomplete gamma ``Q(a, x)`` by Lentz's continued fraction."""
    tiny = 1e-300
    b = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / b
    h = d
    for n in range(1, _MAX_ITERATIONS):
        an = -n * (n - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    return math.exp(-x + a * math.log(x) - math.lgamma(a)) * h


def chi2_sf(statistic: float, dof: int) -> float:
    """``P(X >= statistic)`` for ``X ~ chi^2(dof)``.

    Parameters
    ----------
    statistic : float
        Non-negative chi-square value.
    dof : int
        Degrees of freedom (>= 1).

    Returns
    -------
    float
        The p-value in [0, 1] (relative accuracy ~1e-14; tested against SciPy).
    """
    if dof < 1:
        raise ValueError(f"dof = {dof}: must be >= 1")
    if math.isnan(statistic):
        return math.nan  # no p-value; never 1 (min/max with NaN would give 1)
    if math.isinf(statistic):
        return 0.0 if statistic > 0.0 else 1.0
    if not statistic > 0.0:
        return 1.0
    a = 0.5 * dof
    x = 0.5 * statistic
    if x < a + 1.0:
        return max(0.0, 1.0 - _gamma_series(a, x))
    return min(1.0, _gamma_continued_fraction(a, x))


def sidak_threshold(family_level: float, n_tests: int) -> float:
    """Per-test level ``1 - (1 - family_level)^(1/n_tests)`` (Sidak correction)."""
    return -math.expm1(math.log1p(-family_level) / max(int(n_tests), 1))


@dataclass(frozen=True)
class ChiSquareResult:
    """Pearson chi-square test of counts against a model.

    Attributes
    ----------
    statistic, dof, p_value : float, int, float
    n_categories : int
        Categories after pooling (cells with expected >= ``min_expected``, the pooled
        small cells, the complement category).
    pooled_cells : int
        Cells pooled because their expected count was below ``min_expected``.
    max_abs_z : float
        Largest ``|observed - expected| / sqrt(expected (1 - expected/N))`` over the
        cells kept on their own.
    max_z_cell : int
        Cell index where it occurs (-1 if none).
    failure : str
        Why the model fails regardless of the statistic (empty when it does not); then
        ``p_value == 0``.
    testable : bool
        False with fewer than two categories: no test was made (``p_value`` is NaN).
    """

    statistic: float
    dof: int
    p_value: float
    n_categories: int
    pooled_cells: int
    max_abs_z: float
    max_z_cell: int
    failure: str = ""
    testable: bool = True

    def passed(self, level: float) -> bool:
        """True only for a testable result without failure and ``p_value >= level``."""
        return self.testable and not self.failure and self.p_value >= level

    def verdict(self, level: float) -> str:
        """``"pass"``, ``"FAIL (reason)"`` or ``"NOT TESTABLE (...)"``; a failure wins."""
        if self.failure:
            return f"FAIL ({self.failure})"
        if not self.testable:
            return f"NOT TESTABLE ({self.n_categories} category: a chi-square needs two)"
        return "pass" if self.p_value >= level else f"FAIL (p = {self.p_value:.3g} < {level:.3g})"


def pearson_chi_square(observed, expected, paths: int, min_expected: float = 5.0) -> ChiSquareResult:
    """Pearson's chi-square of per-cell counts of one outcome against expected counts.

    The categories partition all ``paths``: every cell whose expected count is at least
    ``min_expected`` on its own, the other cells pooled into one category, and the
    complement ("did not land in any cell", ``paths - Σ observed`` against
    ``paths - Σ expected``). A pooled category below ``min_expected`` is merged into the
    complement. Degrees of freedom: categories - 1 (no parameter is fitted).

    Parameters
    ----------
    observed : array_like of int (n_cells,)
    expected : array_like of float (n_cells,)
        Model expected counts, ``paths ∫_c f cos θ_o dω_o`` (physics.md sec. 6).
    paths : int
        Total number of paths (multinomial size).
    min_expected : float
        Pooling threshold (Cochran's rule: 5).

    Returns
    -------
    ChiSquareResult
    """
    observed = np.asarray(observed, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    paths = float(paths)
    failure = _model_failure(observed, expected, paths)
    alone = expected >= min_expected  # False for NaN
    obs = list(observed[alone])
    exp = list(expected[alone])
    small = ~alone
    pooled_obs = float(observed[small].sum())
    pooled_exp = float(expected[small].sum())
    rest_obs = paths - float(observed.sum())
    rest_exp = paths - float(expected.sum())
    if pooled_exp >= min_expected:
        obs.append(pooled_obs)
        exp.append(pooled_exp)
    else:
        rest_obs += pooled_obs
        rest_exp += pooled_exp
    if rest_exp > 0.0 or rest_obs > 0.0:
        obs.append(rest_obs)
        exp.append(rest_exp)
    obs_a = np.array(obs)
    exp_a = np.array(exp)
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(exp_a > 0.0, (obs_a - exp_a) ** 2 / np.where(exp_a > 0.0, exp_a, 1.0), np.inf)
    statistic = float(np.sum(terms)) if exp_a.size else 0.0
    if not failure and np.any(exp_a <= 0.0) and np.any(obs_a[exp_a <= 0.0] > 0.0):
        failure = "the model expects no paths in a category where paths landed"
    if not failure and not math.isfinite(statistic):
        failure = f"the chi-square statistic is {statistic}"
    testable = exp_a.size >= 2
    dof = max(exp_a.size - 1, 1)
    z = np.zeros(0)
    if np.any(alone):
        p = expected[alone] / paths
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (observed[alone] - expected[alone]) / np.sqrt(expected[alone] * np.abs(1.0 - p))
    max_k = int(np.argmax(np.abs(z))) if z.size else -1
    if failure:
        p_value = 0.0
    elif not testable:
        p_value = math.nan
    else:
        p_value = chi2_sf(statistic, int(dof))
    return ChiSquareResult(
        statistic=statistic, dof=int(dof), p_value=p_value,
        n_categories=int(exp_a.size), pooled_cells=int(np.count_nonzero(small)),
        max_abs_z=float(abs(z[max_k])) if z.size else 0.0,
        max_z_cell=int(np.flatnonzero(alone)[max_k]) if z.size else -1,
        failure=failure, testable=testable,
    )


def _model_failure(observed: np.ndarray, expected: np.ndarray, paths: float) -> str:
    """Reasons a model fails whatever the statistic says (see the module docstring)."""
    if not np.all(np.isfinite(expected)):
        return "the model has NaN or infinite expected counts"
    if np.any(expected < 0.0):
        return "the model has negative expected counts"
    if np.any((expected == 0.0) & (observed > 0.0)):
        return "the model expects no paths in a cell where paths landed"
    albedo = float(expected.sum()) / paths
    if albedo >= 1.0:
        return f"the model's albedo is {albedo:.6g} (>= 1: it predicts every path or more)"
    return ""


@dataclass(frozen=True)
class AlbedoTest:
    """Two-sided z-test of a total count against a model probability.

    Attributes
    ----------
    observed, expected : float
        Observed total and model expectation ``N p`` (paths).
    z : float
        ``(observed - N p) / sqrt(N p (1 - p))``.
    p_value : float
        ``erfc(|z| / sqrt(2))``; 0 on failure.
    failure : str
        Why the model fails regardless of z (empty when it does not).
    """

    observed: float
    expected: float
    z: float
    p_value: float
    failure: str = ""

    def passed(self, level: float) -> bool:
        """True without failure and with ``p_value >= level``."""
        return not self.failure and self.p_value >= level

    def verdict(self, level: float) -> str:
        """``"pass"`` or ``"FAIL (...)"``."""
        if self.failure:
            return f"FAIL ({self.failure})"
        return "pass" if self.p_value >= level else f"FAIL (|z| = {abs(self.z):.2f}, p = {self.p_value:.3g})"


def albedo_z_test(observed_total, model_albedo: float, paths: int) -> AlbedoTest:
    """Test the number of paths in a class (e.g. all f1 exits) against the model albedo.

    The observed total is Binomial(``paths``, ``model_albedo``) under the model; with
    ``N p (1 - p)`` of at least ~10 its normal approximation is accurate, so the
    two-sided p-value ``erfc(|z|/sqrt(2))`` has the nominal false-positive rate.
    Fail-safe: a NaN, negative or >= 1 model albedo fails (p = 0); a model albedo of 0
    fails when anything was observed and passes (p = 1) otherwise.

    Parameters
    ----------
    observed_total : int
        Paths observed in the class.
    model_albedo : float
        The model's probability of the class.
    paths : int
        Paths simulated.

    Returns
    -------
    AlbedoTest
    """
    n = float(paths)
    observed = float(observed_total)
    p = float(model_albedo)
    expected = n * p if math.isfinite(p) else math.nan
    if not math.isfinite(p) or p < 0.0:
        return AlbedoTest(observed, expected, math.nan, 0.0, f"the model albedo is {p}")
    if p >= 1.0:
        return AlbedoTest(observed, expected, math.nan, 0.0,
                          f"the model's albedo is {p:.6g} (>= 1: it predicts every path or more)")
    if p == 0.0:
        if observed > 0.0:
            return AlbedoTest(observed, 0.0, math.inf, 0.0, "the model predicts no paths, some were observed")
        return AlbedoTest(observed, 0.0, 0.0, 1.0)
    z = (observed - expected) / math.sqrt(expected * (1.0 - p))
    return AlbedoTest(observed, expected, z, math.erfc(abs(z) / math.sqrt(2.0)))


def binomial_mean_abs_deviation(paths: int, probabilities) -> np.ndarray:
    """``E|X - N p|`` for ``X ~ Binomial(N, p)``, elementwise, exactly.

    De Moivre's formula ``2 ν C(N, ν) p^ν (1-p)^(N-ν+1)`` with ``ν = floor(N p) + 1``,
    in logarithms. Summed over cells and divided by the expected total it is the
    relative L1 difference that Monte-Carlo noise alone gives.
    """
    n = int(paths)
    p = np.clip(np.asarray(probabilities, dtype=np.float64), 0.0, 1.0)
    out = np.zeros(p.shape)
    for index, pk in np.ndenumerate(p):
        if pk <= 0.0 or pk >= 1.0:
            continue
        nu = math.floor(n * pk) + 1
        if nu > n:
            continue
        log_value = (math.log(2.0 * nu) + math.lgamma(n + 1) - math.lgamma(nu + 1) - math.lgamma(n - nu + 1)
                     + nu * math.log(pk) + (n - nu + 1) * math.log1p(-pk))
        out[index] = math.exp(log_value)
    return out
