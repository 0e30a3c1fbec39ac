"""Small statistics helpers for comparing Monte-Carlo counts with a model, in plain
Python/NumPy (SciPy is only a test dependency).

- :func:`chi2_sf`: upper tail of the chi-square distribution, ``Q(k/2, x/2)`` by the
  series / continued fraction of the regularised incomplete gamma function.
- :func:`pearson_chi_square`: Pearson's test of multinomial counts against expected
  counts, with pooling of small categories.
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
    """

    statistic: float
    dof: int
    p_value: float
    n_categories: int
    pooled_cells: int
    max_abs_z: float
    max_z_cell: int


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
    alone = expected >= min_expected
    obs = list(observed[alone])
    exp = list(expected[alone])
    pooled_obs = float(observed[~alone].sum())
    pooled_exp = float(expected[~alone].sum())
    rest_obs = paths - float(observed.sum())
    rest_exp = paths - float(expected.sum())
    if pooled_exp >= min_expected:
        obs.append(pooled_obs)
        exp.append(pooled_exp)
    else:
        rest_obs += pooled_obs
        rest_exp += pooled_exp
    if rest_exp > 0.0:
        obs.append(rest_obs)
        exp.append(rest_exp)
    elif rest_obs > 0.0:  # the model says nothing else can happen, the counts disagree
        obs.append(rest_obs)
        exp.append(1e-300)
    obs_a = np.array(obs)
    exp_a = np.array(exp)
    statistic = float(np.sum((obs_a - exp_a) ** 2 / exp_a)) if exp_a.size else 0.0
    dof = max(exp_a.size - 1, 1)
    z = np.zeros(0)
    if np.any(alone):
        p = expected[alone] / paths
        z = (observed[alone] - expected[alone]) / np.sqrt(expected[alone] * (1.0 - p))
    max_k = int(np.argmax(np.abs(z))) if z.size else -1
    return ChiSquareResult(
        statistic=statistic, dof=int(dof), p_value=chi2_sf(statistic, int(dof)),
        n_categories=int(exp_a.size), pooled_cells=int(np.count_nonzero(~alone)),
        max_abs_z=float(abs(z[max_k])) if z.size else 0.0,
        max_z_cell=int(np.flatnonzero(alone)[max_k]) if z.size else -1,
    )


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
